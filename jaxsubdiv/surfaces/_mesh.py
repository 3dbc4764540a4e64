"""`Mesh`: vertex positions (traced) plus static polygon topology and tags."""

from collections.abc import Sequence

import equinox as eqx
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from .._misc import as_float_array, is_traced


class StaticArray:
    """A read-only numpy array (int64 unless `dtype` says otherwise) that is hashable,
    so it can be a static field.

    `jax.jit` and `eqx.filter_jit` hash static fields on every call; the hash is
    computed from the bytes when first asked for and cached (a refined mesh that is
    never hashed never pays for it). Equality compares contents. The array is copied
    unless it already is a `StaticArray` of that dtype (then it is shared).
    """

    __slots__ = ("array", "_hash")

    def __init__(self, array: np.ndarray, dtype=np.int64):
        if isinstance(array, StaticArray) and array.array.dtype == dtype:
            self.array, self._hash = array.array, array._hash
            return
        array = np.array(array, dtype=dtype, copy=True)
        array.setflags(write=False)
        self.array = array
        self._hash = None

    @staticmethod
    def owned(array: np.ndarray) -> "StaticArray":
        """Wrap an array nobody else holds, without a copy (made read-only)."""
        out = StaticArray.__new__(StaticArray)
        array.setflags(write=False)
        out.array, out._hash = array, None
        return out

    def __hash__(self) -> int:
        if self._hash is None:
            self._hash = hash((self.array.shape, self.array.dtype.str, self.array.tobytes()))
        return self._hash

    def __eq__(self, other) -> bool:
        return (
            isinstance(other, StaticArray)
            and hash(self) == hash(other)
            and np.array_equal(self.array, other.array)
        )

    def __repr__(self) -> str:
        return f"StaticArray(shape={self.array.shape})"


def as_faces(faces) -> np.ndarray:
    """Faces as a padded `(F, K)` int64 array: a rectangular array, or ragged lists
    (checked); a `StaticArray` is already a checked faces array (refined meshes)."""
    if isinstance(faces, StaticArray):
        return faces.array
    if is_traced(faces):
        raise TypeError("`faces` is topology and must be concrete (numpy or lists), not traced.")
    try:
        array = np.asarray(faces)
        ragged = array.dtype == object
    except ValueError:  # ragged nested lists on recent numpy
        ragged = True
    if ragged:
        rows = [list(f) for f in faces]
        width = max((len(r) for r in rows), default=3)
        array = np.full((len(rows), width), -1, np.int64)
        for i, r in enumerate(rows):  # host-side, once per mesh construction
            array[i, : len(r)] = r
    if array.size == 0:
        array = array.reshape(0, 3)
    if array.ndim != 2:
        raise ValueError(f"`faces` must be an (F, K) array or a list of vertex lists, got shape {array.shape}.")
    if not np.issubdtype(array.dtype, np.integer):
        if np.any(array != np.round(array)):
            raise TypeError("`faces` must hold integer vertex indices.")
    array = array.astype(np.int64)
    if np.any(array < -1):
        f, k = np.argwhere(array < -1)[0]
        raise ValueError(
            f"`faces`: face {int(f)} holds the index {int(array[f, k])}; vertex indices "
            "are 0 or more, and -1 only pads a face shorter than the others. (Negative "
            "indices that count back from the last vertex are an OBJ convention: "
            "`read_mesh` resolves them.)"
        )
    valid = array >= 0
    # Padding (-1) may only trail the real indices of a face.
    if np.any(~valid[:, :-1] & valid[:, 1:]):
        raise ValueError("`faces`: -1 padding must come after a face's vertex indices.")
    return array


#: OpenSubdiv's infinite sharpness: a crease or corner of this sharpness or more never
#: decays (`Sdc::Crease::SHARPNESS_INFINITE`).
INFINITE_SHARPNESS = 10.0


def as_sharpness(values, count: int, name: str) -> np.ndarray:
    """`(count,)` float64 sharpness, `inf` where the tag is infinitely sharp: `None`
    means all infinite; values of 10 or more (OpenSubdiv's infinite) become `inf`."""
    if values is None:
        return np.full(count, np.inf)
    array = np.asarray(values)
    if array.ndim == 0:
        array = np.full(count, array)
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise TypeError(f"`{name}` must be real numbers, got dtype {array.dtype}.")
    array = array.astype(np.float64).reshape(-1)
    if len(array) != count:
        raise ValueError(f"`{name}` must have one value per tag ({count}), got {len(array)}.")
    if np.any(np.isnan(array) | (array <= 0)):
        bad = array[np.isnan(array) | (array <= 0)][0]
        raise ValueError(
            f"`{name}` must be > 0 (a tag of sharpness 0 is no tag: leave it out), got {bad}."
        )
    return np.where(array >= INFINITE_SHARPNESS, np.inf, array)


def _unique_tags(keys: np.ndarray, sharpness: np.ndarray, name: str, what):
    """Sorted unique tags and their sharpness; a tag given twice must agree."""
    if len(keys) == 0:
        return keys, sharpness
    order = np.lexsort(keys.T[::-1]) if keys.ndim == 2 else np.argsort(keys, kind="stable")
    keys, sharpness = keys[order], sharpness[order]
    same = np.all(keys[1:] == keys[:-1], axis=-1) if keys.ndim == 2 else keys[1:] == keys[:-1]
    clash = same & (sharpness[1:] != sharpness[:-1])
    if np.any(clash):
        i = int(np.argmax(clash))
        raise ValueError(
            f"`{name}` tags {what(keys[i])} twice with different sharpness "
            f"({sharpness[i]} and {sharpness[i + 1]})."
        )
    keep = np.concatenate([[True], ~same])
    return keys[keep], sharpness[keep]


def as_pairs(values, name: str, sharpness=None, sharpness_name: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Sorted unique `(C, 2)` vertex pairs and their sharpness."""
    array = np.zeros((0, 2), np.int64) if values is None else np.asarray(values, dtype=np.int64)
    if array.size == 0:
        array = np.zeros((0, 2), np.int64)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"`{name}` must be a list of (vertex, vertex) pairs, got shape {array.shape}.")
    values = as_sharpness(sharpness, len(array), sharpness_name)
    return _unique_tags(np.sort(array, axis=1), values, name, lambda k: f"the edge {k.tolist()}")


def as_indices(values, name: str, sharpness=None, sharpness_name: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Sorted unique vertex indices and their sharpness."""
    array = np.zeros(0, np.int64) if values is None else np.asarray(values, dtype=np.int64).reshape(-1)
    values = as_sharpness(sharpness, len(array), sharpness_name)
    return _unique_tags(array, values, name, lambda k: f"the vertex {int(k)}")


class Mesh(eqx.Module):
    r"""A polygon mesh: vertex data plus fixed topology.

    `vertices` is an ordinary array field, so it is traced, differentiated and vmapped
    through `jax.jit`/`eqx.filter_jit`. The topology (`faces`, `creases`, `corners`) is
    a static field: it is hashed and compared, not traced, so a jitted function that
    takes a `Mesh` compiles once per topology and sees the faces as concrete numpy
    arrays, which is what building a stencil table needs.

    Faces may be polygons of any size. `mesh.faces` is always an `(F, K)` integer numpy
    array, `K` the largest face size, with smaller faces padded by `-1` at the end
    (there is no padding for pure triangle or quad meshes).

    Tags (Hoppe et al. 1994; semi-sharp ones after DeRose, Kass and Truong 1998, with
    OpenSubdiv's rules):

    - `creases`: `(C, 2)` vertex pairs: edges refined with the cubic B-spline curve
      rules, so the surface keeps a sharp feature along them.
    - `corners`: vertex indices held fixed (interpolated) by refinement.
    - `crease_sharpness`, `corner_sharpness`: how many levels a tag stays sharp
      (OpenSubdiv's edge and vertex sharpness). `None` (the default), `inf` or any
      value of 10 or more is infinitely sharp; a value in (0, 10) is *semi-sharp*: the
      sharp rules apply while the sharpness lasts, it decays by one per level (or by
      OpenSubdiv's Chaikin rule, see `crease_method` of `Loop` and `CatmullClark`),
      and a fractional remainder blends the sharp and smooth rules. Semi-sharp tags
      are for Loop and Catmull-Clark; Doo-Sabin takes infinitely sharp tags only.

    Vertices that no face uses are allowed: every scheme keeps them, unchanged.

    Boundary edges are always treated as creases; a boundary vertex with a single
    incident face is a corner unless the scheme's `boundary_interpolation` is
    `"edge_only"` (Loop, Catmull-Clark). [`jaxsubdiv.surfaces.refine_mesh`][] carries
    the tags over to the refined mesh.
    """

    vertices: Float[Array, "V C"]
    _faces: StaticArray = eqx.field(static=True)
    _creases: StaticArray = eqx.field(static=True)
    _corners: StaticArray = eqx.field(static=True)
    # Sharpness is topology to subdivision (it selects the rules, as in OpenSubdiv's
    # topology descriptor), so it is static like the tags, not traced.
    _crease_sharpness: StaticArray = eqx.field(static=True)
    _corner_sharpness: StaticArray = eqx.field(static=True)

    def __init__(
        self,
        vertices: Float[ArrayLike, "V C"],
        faces: Int[ArrayLike, "F K"] | Sequence[Sequence[int]],
        *,
        creases: Int[ArrayLike, "C 2"] | None = None,
        corners: Int[ArrayLike, " K"] | None = None,
        crease_sharpness: Float[ArrayLike, " C"] | float | None = None,
        corner_sharpness: Float[ArrayLike, " K"] | float | None = None,
    ):
        """**Arguments:**

        - `vertices`: `(V, C)` vertex data, usually positions with `C = 3`.
        - `faces`: an `(F, K)` integer array (`-1` pads smaller faces; no other
          negative index) or a list of vertex-index lists of any lengths. Counter-clockwise faces give outward
          normals.
        - `creases`: optional `(C, 2)` vertex pairs tagged as infinitely sharp edges.
          Keyword only.
        - `corners`: optional vertex indices tagged as corners. Keyword only.
        - `crease_sharpness`, `corner_sharpness`: optional sharpness of each tag, one
          number for all, or `None` for infinitely sharp (see above). Values must be
          > 0. Keyword only.
        """
        vertices = as_float_array(vertices, "vertices")
        if vertices.ndim != 2:
            raise ValueError(f"`vertices` must have shape (V, C), got {vertices.shape}.")
        checked = faces if isinstance(faces, StaticArray) else None
        faces = as_faces(faces)
        if faces.size and faces.max() >= vertices.shape[0]:
            raise ValueError(
                f"`faces` refers to vertex {int(faces.max())}, but there are only "
                f"{vertices.shape[0]} vertices."
            )
        creases, crease_sharpness = as_pairs(creases, "creases", crease_sharpness, "crease_sharpness")
        corners, corner_sharpness = as_indices(corners, "corners", corner_sharpness, "corner_sharpness")
        self.vertices = vertices
        self._faces = StaticArray(faces) if checked is None else checked
        self._creases = StaticArray(creases)
        self._corners = StaticArray(corners)
        self._crease_sharpness = StaticArray(crease_sharpness, np.float64)
        self._corner_sharpness = StaticArray(corner_sharpness, np.float64)

    @property
    def faces(self) -> np.ndarray:
        """`(F, K)` vertex indices, `-1`-padded for faces smaller than `K` (read-only)."""
        return self._faces.array

    @property
    def creases(self) -> np.ndarray:
        """`(C, 2)` tagged crease edges (sorted vertex pairs; read-only)."""
        return self._creases.array

    @property
    def corners(self) -> np.ndarray:
        """Tagged corner vertices (read-only)."""
        return self._corners.array

    @property
    def crease_sharpness(self) -> np.ndarray:
        """`(C,)` sharpness of each crease in `creases` (`inf`: infinitely sharp)."""
        return self._crease_sharpness.array

    @property
    def corner_sharpness(self) -> np.ndarray:
        """Sharpness of each corner in `corners` (`inf`: infinitely sharp)."""
        return self._corner_sharpness.array

    @property
    def semi_sharp(self) -> bool:
        """Whether any tag is semi-sharp (finite sharpness)."""
        return bool(np.any(np.isfinite(self.crease_sharpness)) or np.any(np.isfinite(self.corner_sharpness)))

    @property
    def num_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def num_faces(self) -> int:
        return int(self.faces.shape[0])

    def face_sizes(self) -> np.ndarray:
        """Number of vertices of every face."""
        return (self.faces >= 0).sum(axis=1)

    def edges(self) -> np.ndarray:
        """`(E, 2)` unique undirected edges (sorted pairs, lexicographic order)."""
        faces = self.faces
        valid = faces >= 0
        sizes = valid.sum(axis=1)
        nxt = np.where(
            np.arange(faces.shape[1])[None, :] + 1 < sizes[:, None],
            np.roll(faces, -1, axis=1),
            faces[:, :1],
        )
        pairs = np.stack([faces[valid], nxt[valid]], axis=1)
        return np.unique(np.sort(pairs, axis=1), axis=0)
