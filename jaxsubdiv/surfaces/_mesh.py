"""`Mesh`: vertex positions (traced) plus static polygon topology and tags."""

from collections.abc import Sequence

import equinox as eqx
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from .._misc import as_float_array, is_traced


class StaticArray:
    """A read-only numpy integer array that is hashable, so it can be a static field.

    `jax.jit` and `eqx.filter_jit` hash static fields on every call; the hash is
    computed once from the bytes and cached. Equality compares contents.
    """

    __slots__ = ("array", "_hash")

    def __init__(self, array: np.ndarray):
        array = np.array(array, dtype=np.int64, copy=True)
        array.setflags(write=False)
        self.array = array
        self._hash = hash((array.shape, array.tobytes()))

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other) -> bool:
        return (
            isinstance(other, StaticArray)
            and self._hash == other._hash
            and np.array_equal(self.array, other.array)
        )

    def __repr__(self) -> str:
        return f"StaticArray(shape={self.array.shape})"


def as_faces(faces) -> np.ndarray:
    """Faces as a padded `(F, K)` int64 array: a rectangular array, or ragged lists."""
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


def as_pairs(values, name: str) -> np.ndarray:
    if values is None:
        return np.zeros((0, 2), np.int64)
    array = np.asarray(values, dtype=np.int64)
    if array.size == 0:
        return np.zeros((0, 2), np.int64)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"`{name}` must be a list of (vertex, vertex) pairs, got shape {array.shape}.")
    return np.unique(np.sort(array, axis=1), axis=0)


def as_indices(values, name: str) -> np.ndarray:
    if values is None:
        return np.zeros((0,), np.int64)
    return np.unique(np.asarray(values, dtype=np.int64).reshape(-1))


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

    Tags (Hoppe et al. 1994; DeRose, Kass and Truong 1998, infinitely sharp only):

    - `creases`: `(C, 2)` vertex pairs: edges refined with the cubic B-spline curve
      rules, so the surface keeps a sharp feature along them.
    - `corners`: vertex indices held fixed (interpolated) by refinement.

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

    def __init__(
        self,
        vertices: Float[ArrayLike, "V C"],
        faces: Int[ArrayLike, "F K"] | Sequence[Sequence[int]],
        *,
        creases: Int[ArrayLike, "C 2"] | None = None,
        corners: Int[ArrayLike, " K"] | None = None,
    ):
        """**Arguments:**

        - `vertices`: `(V, C)` vertex data, usually positions with `C = 3`.
        - `faces`: an `(F, K)` integer array (`-1` pads smaller faces; no other
          negative index) or a list of vertex-index lists of any lengths. Counter-clockwise faces give outward
          normals.
        - `creases`: optional `(C, 2)` vertex pairs tagged as infinitely sharp edges.
          Keyword only.
        - `corners`: optional vertex indices tagged as corners. Keyword only.
        """
        vertices = as_float_array(vertices, "vertices")
        if vertices.ndim != 2:
            raise ValueError(f"`vertices` must have shape (V, C), got {vertices.shape}.")
        faces = as_faces(faces)
        if faces.size and faces.max() >= vertices.shape[0]:
            raise ValueError(
                f"`faces` refers to vertex {int(faces.max())}, but there are only "
                f"{vertices.shape[0]} vertices."
            )
        self.vertices = vertices
        self._faces = StaticArray(faces)
        self._creases = StaticArray(as_pairs(creases, "creases"))
        self._corners = StaticArray(as_indices(corners, "corners"))

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
