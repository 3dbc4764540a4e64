"""Reading and writing polygon meshes: Wavefront OBJ, OFF and ASCII PLY."""

import os
from pathlib import Path

import numpy as np

from ._mesh import Mesh
from ._topology import build_topology, pad_faces


FORMATS = ("obj", "off", "ply")


def _format(path, format) -> str:
    fmt = (format or Path(path).suffix.lstrip(".")).lower()
    if fmt not in FORMATS:
        raise ValueError(
            f"Cannot tell the mesh format of {str(path)!r}: pass `format=` one of {FORMATS} "
            "or use a file name ending in .obj, .off or .ply."
        )
    return fmt


class _Lines:
    """Non-empty, comment-stripped lines with their 1-based line numbers."""

    def __init__(self, path, text: str, comment: str = "#"):
        self.path = str(path)
        self.items = []
        for number, line in enumerate(text.splitlines(), start=1):
            line = line.split(comment, 1)[0].strip()
            if line:
                self.items.append((number, line))
        self.pos = 0

    def error(self, number: int, message: str) -> ValueError:
        return ValueError(f"{self.path}, line {number}: {message}")

    def next(self, what: str) -> tuple[int, str]:
        if self.pos >= len(self.items):
            raise ValueError(f"{self.path}: the file ends early; expected {what}.")
        self.pos += 1
        return self.items[self.pos - 1]

    def numbers(self, number: int, tokens: list[str], kind=float) -> list:
        try:
            return [kind(t) for t in tokens]
        except ValueError:
            raise self.error(number, f"expected numbers, got {' '.join(tokens)!r}.") from None


def _obj_index(lines: _Lines, number: int, token: str, count: int, what: str) -> int:
    """A 1-based (or negative, from the end) OBJ index to a 0-based one, checked."""
    index = lines.numbers(number, [token], int)[0]
    if index == 0:
        raise lines.error(number, f"OBJ {what} indices start at 1, got 0.")
    index = index - 1 if index > 0 else count + index
    if not 0 <= index < count:
        raise lines.error(
            number, f"face refers to {what} {token}, but only {count} are defined so far."
        )
    return index


def _read_obj(lines: _Lines, uvs: list | None = None):
    """Vertices, flat face indices and sizes; with `uvs` a list, also `(texture
    coordinates, flat per-corner texture indices or -1)` appended to it."""
    vertices, flat, sizes, textures, corners = [], [], [], [], []
    for number, line in lines.items:
        tokens = line.split()
        key = tokens[0]
        if key == "v":
            if len(tokens) < 4:
                raise lines.error(number, f"a vertex needs 3 coordinates, got {line!r}.")
            vertices.append(lines.numbers(number, tokens[1:4]))
        elif key == "vt" and uvs is not None:
            if len(tokens) < 3:
                raise lines.error(number, f"a texture coordinate needs u and v, got {line!r}.")
            textures.append(lines.numbers(number, tokens[1:3]))
        elif key == "f":
            if len(tokens) < 4:
                raise lines.error(number, f"a face needs at least 3 vertices, got {line!r}.")
            for t in tokens[1:]:  # "i", "i/t", "i//n", "i/t/n"
                parts = t.split("/")
                flat.append(_obj_index(lines, number, parts[0], len(vertices), "vertex"))
                if uvs is not None:
                    corners.append(_obj_index(lines, number, parts[1], len(textures),
                                              "texture coordinate")
                                   if len(parts) > 1 and parts[1] else -1)  # fmt: skip
            sizes.append(len(tokens) - 1)
        # vn, o, g, s, usemtl, mtllib, l, ... carry nothing we use.
    if uvs is not None:
        uvs += [textures, corners]
    return vertices, flat, sizes


def _read_off(lines: _Lines):
    number, header = lines.next("the OFF header")
    tokens = header.split()
    if tokens[0] != "OFF":
        raise lines.error(number, f"an OFF file starts with 'OFF', got {tokens[0]!r}.")
    counts = tokens[1:]
    if not counts:
        number, line = lines.next("the vertex, face and edge counts")
        counts = line.split()
    if len(counts) < 2:
        raise lines.error(number, "expected the vertex and face counts.")
    nv, nf = lines.numbers(number, counts[:2], int)
    vertices, flat, sizes = [], [], []
    for _ in range(nv):
        number, line = lines.next(f"{nv} vertex lines")
        tokens = line.split()
        if len(tokens) < 3:
            raise lines.error(number, f"a vertex needs 3 coordinates, got {line!r}.")
        vertices.append(lines.numbers(number, tokens[:3]))
    for _ in range(nf):
        number, line = lines.next(f"{nf} face lines")
        values = lines.numbers(number, line.split()[:1], int)
        k = values[0]
        tokens = line.split()[1 : 1 + k]
        if len(tokens) != k or k < 3:
            raise lines.error(number, f"a face of {k} vertices needs {k} indices (and k >= 3), got {line!r}.")
        face = lines.numbers(number, tokens, int)
        if min(face) < 0 or max(face) >= nv:
            raise lines.error(number, f"face index out of range [0, {nv - 1}]: {line!r}.")
        flat += face
        sizes.append(k)
    return vertices, flat, sizes


def _read_ply(lines: _Lines):
    number, line = lines.next("the PLY header")
    if line != "ply":
        raise lines.error(number, f"a PLY file starts with 'ply', got {line!r}.")
    elements = []  # (name, count, [(property name, is_list)])
    while True:
        number, line = lines.next("'end_header'")
        tokens = line.split()
        if tokens[0] == "format":
            if len(tokens) < 2 or tokens[1] != "ascii":
                raise lines.error(number, f"only ASCII PLY is supported, got {line!r}.")
        elif tokens[0] == "element":
            if len(tokens) != 3:
                raise lines.error(number, f"malformed element line {line!r}.")
            elements.append((tokens[1], lines.numbers(number, [tokens[2]], int)[0], []))
        elif tokens[0] == "property":
            if not elements:
                raise lines.error(number, "a property before any element.")
            is_list = len(tokens) >= 2 and tokens[1] == "list"
            elements[-1][2].append((tokens[-1], is_list))
        elif tokens[0] == "end_header":
            break
        # "comment" lines were stripped; "obj_info" and others are ignored.
    vertices, flat, sizes = [], [], []
    for name, count, props in elements:
        names = [p for p, _ in props]
        for _ in range(count):
            number, line = lines.next(f"{count} {name} lines")
            tokens = line.split()
            if name == "vertex":
                if not {"x", "y", "z"} <= set(names):
                    raise lines.error(number, "the vertex element needs properties x, y and z.")
                if len(tokens) < len(names):
                    raise lines.error(number, f"expected {len(names)} values, got {line!r}.")
                values = lines.numbers(number, tokens[: len(names)])
                vertices.append([values[names.index(c)] for c in "xyz"])
            elif name == "face":
                if not props or not props[0][1]:
                    raise lines.error(number, "the face element must start with a list property of vertex indices.")
                k = lines.numbers(number, tokens[:1], int)[0]
                face = lines.numbers(number, tokens[1 : 1 + k], int)
                if len(face) != k or k < 3:
                    raise lines.error(number, f"a face of {k} vertices needs {k} indices (and k >= 3), got {line!r}.")
                flat += face
                sizes.append(k)
    nv = len(vertices)
    if flat and (min(flat) < 0 or max(flat) >= nv):
        raise ValueError(f"{lines.path}: a face index is outside [0, {nv - 1}].")
    return vertices, flat, sizes


def _read_text(path, fmt: str) -> str:
    """The file as text; a clear error for binary PLY and for files that are not text."""
    data = Path(path).read_bytes()
    if fmt == "ply":
        header = data[: data.find(b"end_header")] if b"end_header" in data else data[:4096]
        for number, line in enumerate(header.splitlines(), start=1):
            tokens = line.split()
            if tokens[:1] == [b"format"] and tokens[1:2] != [b"ascii"]:
                kind = tokens[1].decode("ascii", "replace") if len(tokens) > 1 else "?"
                raise ValueError(
                    f"{path}, line {number}: only ASCII PLY is supported, got the {kind} "
                    "format; convert the file to ASCII PLY, OBJ or OFF (e.g. "
                    "`trimesh.load(path).export('mesh.obj')`, or MeshLab or Blender)."
                )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ValueError(
            f"{path}: not a text {fmt.upper()} file (byte {e.start} is not UTF-8 text); "
            f"read_mesh reads text OBJ, OFF and ASCII PLY files."
        ) from None


def read_mesh(path: str | os.PathLike, format: str | None = None, *, check: bool = True) -> Mesh:
    """Read a polygon mesh from a Wavefront OBJ, OFF or ASCII PLY file.

    OBJ: `v` and `f` lines are read (indices in the `i`, `i/t`, `i//n` and `i/t/n`
    forms, negative indices counting back from the last vertex); normals, groups and
    materials are ignored, and texture coordinates are read by
    [`jaxsubdiv.surfaces.read_uvs`][]. OFF: the plain `OFF` header. PLY: the
    `ascii` format with `x, y, z` vertex properties and a face list property.

    **Arguments:**

    - `path`: the file.
    - `format`: `"obj"`, `"off"` or `"ply"`; by default taken from the file extension.
    - `check`: also check that the mesh is manifold and consistently oriented (what
      subdivision needs). Keyword only.

    **Returns:**

    A [`jaxsubdiv.surfaces.Mesh`][] with `(V, 3)` vertices (the default float dtype).

    **Raises:**

    `ValueError` naming the file (and the line, for malformed input), for bad syntax,
    out-of-range indices, non-finite (NaN or infinite) vertex coordinates, a binary PLY
    or another file that is not UTF-8 text, or (with `check`) a non-manifold mesh.
    """
    fmt = _format(path, format)
    text = _read_text(path, fmt)
    lines = _Lines(path, text, comment="#")
    reader = {"obj": _read_obj, "off": _read_off, "ply": _read_ply}[fmt]
    vertices, flat, sizes = reader(lines)
    faces = pad_faces(np.asarray(flat, np.int64), np.asarray(sizes, np.int64))
    vertices = np.asarray(vertices, np.float64).reshape(-1, 3)
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        i = int(np.argmin(finite))
        raise ValueError(
            f"{path}: vertex {i} has a non-finite coordinate ({vertices[i].tolist()}); a mesh "
            "needs finite vertex positions (numbers beyond +-1.8e308 read as infinite). Fix "
            "or remove that vertex."
        )
    if check:
        try:
            build_topology(faces, len(vertices))
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None
    return Mesh(vertices, faces)


def read_uvs(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """The texture coordinates of a Wavefront OBJ file, as a face-varying channel for
    [`jaxsubdiv.surfaces.FaceVarying`][].

    ```python
    mesh = read_mesh("model.obj")
    values, indices = read_uvs("model.obj")
    uvs = FaceVarying(mesh, indices, CatmullClark(), 2, linear_interpolation="boundaries")
    refined_uvs = uvs(values)  # one per corner of uvs.faces
    ```

    OBJ shares a `vt` between vertices where it likes (a repeating texture); a
    face-varying value belongs to one vertex, so each distinct (vertex, `vt`) pair of
    the file becomes one value.

    **Returns:**

    `(values, indices)`: `(U, 2)` float64 texture coordinates (u, v), and the `(F, K)`
    value index of every face corner, `-1`-padded like `read_mesh(path).faces`.

    **Raises:**

    `ValueError` naming the file and line for bad syntax or an out-of-range index, and
    naming the face when a corner has no texture coordinate.
    """
    lines = _Lines(path, _read_text(path, "obj"), comment="#")
    found = []
    _, flat, sizes = _read_obj(lines, found)
    textures, corners = found
    corners = np.asarray(corners, np.int64)
    if np.any(corners < 0):
        corner = int(np.argmax(corners < 0))
        face = int(np.searchsorted(np.cumsum(sizes), corner, side="right"))
        raise ValueError(
            f"{path}: face {face} has a corner without a texture coordinate (`f i` or "
            "`f i//n`); every corner needs one (`f i/t`) to read the file's UVs."
        )
    pairs, values = np.unique(np.stack([np.asarray(flat, np.int64), corners], 1), axis=0,
                              return_inverse=True)  # fmt: skip
    uvs = np.asarray(textures, np.float64).reshape(-1, 2)[pairs[:, 1]]
    return uvs, pad_faces(values.reshape(-1), np.asarray(sizes, np.int64))


def write_mesh(path: str | os.PathLike, mesh: Mesh, format: str | None = None) -> None:
    """Write `mesh` (3-d vertices) as Wavefront OBJ, OFF or ASCII PLY.

    Vertices are written with 17 significant digits, so float64 positions round-trip
    exactly. Tags (creases, corners) are not written: none of the three formats has them.

    **Arguments:**

    - `path`: the file to write.
    - `mesh`: a [`jaxsubdiv.surfaces.Mesh`][] with `(V, 3)` vertices.
    - `format`: `"obj"`, `"off"` or `"ply"`; by default taken from the file extension.
    """
    fmt = _format(path, format)
    if not isinstance(mesh, Mesh):
        raise TypeError(f"`mesh` must be a jaxsubdiv.surfaces.Mesh, got {type(mesh).__name__}.")
    vertices = np.asarray(mesh.vertices, np.float64)
    if vertices.shape[1] != 3:
        raise ValueError(f"Mesh files hold 3-d positions; `mesh.vertices` has shape {vertices.shape}.")
    faces = mesh.faces
    sizes = (faces >= 0).sum(axis=1)
    vlines = [" ".join(f"{x:.17g}" for x in row) for row in vertices.tolist()]
    flines = [[int(i) for i in row[:k]] for row, k in zip(faces.tolist(), sizes.tolist())]
    if fmt == "obj":
        out = ["# written by jaxsubdiv"]
        out += [f"v {v}" for v in vlines]
        out += ["f " + " ".join(str(i + 1) for i in f) for f in flines]
    elif fmt == "off":
        out = ["OFF", f"{len(vlines)} {len(flines)} 0", *vlines]
        out += [f"{len(f)} " + " ".join(map(str, f)) for f in flines]
    else:
        out = [
            "ply",
            "format ascii 1.0",
            "comment written by jaxsubdiv",
            f"element vertex {len(vlines)}",
            "property double x",
            "property double y",
            "property double z",
            f"element face {len(flines)}",
            "property list uchar int vertex_indices",
            "end_header",
            *vlines,
        ]
        out += [f"{len(f)} " + " ".join(map(str, f)) for f in flines]
    Path(path).write_text("\n".join(out) + "\n")
