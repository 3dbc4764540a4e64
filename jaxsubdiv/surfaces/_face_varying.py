"""Face-varying data (UVs with seams): values per face corner, refined like OpenSubdiv's
face-varying channels.

A face-varying channel gives every face corner an index into its own value array;
neighbouring faces that use different indices at a shared vertex make a *seam*. The
channel is refined as a mesh of its own: its faces are the corner indices, so a seam
is a boundary of that mesh, and the vertex mesh's creases and corners (with their
sharpness) carry over to the corresponding face-varying edges and values. Which
face-varying values are kept sharp follows OpenSubdiv's linear-interpolation options
(`Sdc::Options::FVarLinearInterpolation`), see `FaceVarying`. Because the refined
faces of both meshes are made in the same order, corner by corner, refined face `i`'s
corner `j` of the channel belongs to refined face `i`'s corner `j` of the mesh.
"""

import equinox as eqx
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from ..validation import DEFAULT_MEMORY_BUDGET, checked_budget, static_int
from ._base import AbstractSurfaceScheme
from ._mesh import Mesh, as_faces
from ._refine import MAX_LEVELS, Refiner, _check, apply_tables
from ._stencil import StencilTable
from ._topology import build_topology, flatten_faces


#: OpenSubdiv's `FVarLinearInterpolation` options, by its names (lower case, without
#: the `FVAR_LINEAR_` prefix), from the smoothest to the most linear.
LINEAR_INTERPOLATION = ("none", "corners_only", "corners_plus1", "corners_plus2",
                        "boundaries", "all")  # fmt: skip


def _channel_tags(mesh: Mesh, channel: np.ndarray, topo, scheme, option: str):
    """Creases and corners (with sharpness) of the channel's own mesh at level 0: the
    mesh's tags moved to the channel's edges and values, plus the values that the
    option keeps sharp (`Vtr::FVarLevel`'s rules, see `FaceVarying`)."""
    flat, _ = flatten_faces(channel)  # one value per half-edge, like `topo.origin`
    count = int(flat.max(initial=-1)) + 1
    # The mesh's tagged edges, from each of their faces, become the channel's edges.
    edge_sharpness = np.zeros(topo.num_edges)
    if len(mesh.creases):
        edge_sharpness[topo.edge_ids(mesh.creases, "creases")] = mesh.crease_sharpness
    tagged = np.flatnonzero(edge_sharpness[topo.edge] > 0)
    pairs = np.sort(np.stack([flat[tagged], flat[topo.next[tagged]]], 1), axis=1)
    crease_sharpness = edge_sharpness[topo.edge[tagged]]
    vertex_sharpness = np.zeros(topo.num_vertices)
    vertex_sharpness[mesh.corners] = mesh.corner_sharpness
    if scheme.boundary_corners:  # the mesh's own corners pin every value there
        nfaces = np.bincount(topo.origin, minlength=topo.num_vertices)
        vertex_sharpness[topo.boundary_vertex & (nfaces == 1)] = np.inf
    corner = np.flatnonzero(vertex_sharpness[topo.origin] > 0)
    corners, corner_sharpness = flat[corner], vertex_sharpness[topo.origin[corner]]

    # Per vertex of the mesh: how many values meet there, and whether a seam (an edge
    # whose two faces disagree at one of its ends) touches it.
    V = topo.num_vertices
    pairs_at = np.unique(np.stack([topo.origin, flat], 1), axis=0)
    values_at = np.bincount(pairs_at[:, 0], minlength=V)
    inner = topo.twin >= 0
    h = np.flatnonzero(inner)
    t = topo.twin[h]
    seam = flat[h] != flat[topo.next[t]]  # h starts where t ends
    touched = np.zeros(V, bool)
    touched[topo.origin[h[seam]]] = True
    touched[topo.origin[t[seam]]] = True
    # Faces of each value's span (the corners carrying it), and whether its span holds an
    # infinitely sharp edge of the mesh (a mesh edge inside the channel's region).
    span = np.bincount(flat, minlength=count)
    sharp_inside = np.zeros(count, bool)
    inf = np.flatnonzero(np.isinf(edge_sharpness[topo.edge]) & (topo.twin >= 0))
    sharp_inside[flat[inf]] = True
    sharp_inside[flat[topo.next[inf]]] = True

    keep = np.zeros(V, bool)  # vertices all of whose values are kept
    if option in ("corners_plus1", "corners_plus2"):
        keep |= values_at >= 3  # a junction of three or more regions
        two = values_at == 2
        either = np.zeros(V, bool)
        either[topo.origin[sharp_inside[flat]]] = True
        if option == "corners_plus2":
            either[topo.origin[span[flat] == 1]] = True  # one region's corner is concave
            keep |= (values_at == 1) & touched & ~topo.boundary_vertex  # a seam's dart end
        keep |= two & either
    extra = np.unique(flat[keep[topo.origin]])
    corners = np.concatenate([corners, extra])
    corner_sharpness = np.concatenate([corner_sharpness, np.full(len(extra), np.inf)])
    return count, _merge(pairs, crease_sharpness), _merge(corners, corner_sharpness)


def _merge(keys, sharpness):
    """Unique tags (rows of sorted pairs, or indices), each with its largest sharpness
    (an edge tagged from both of its faces appears twice)."""
    if len(keys) == 0:
        return keys, sharpness
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    largest = np.full(len(unique), -np.inf)
    np.maximum.at(largest, inverse.reshape(-1), sharpness)
    return unique, largest


def _linear_tags(faces: np.ndarray, count: int, option: str, creases, crease_sharpness,
                 corners, corner_sharpness):  # fmt: skip
    """For "boundaries" and "all", at every level: every value on the channel's
    boundary (or every value, and every edge, for "all") kept sharp."""
    topo = build_topology(faces, count, boundary_corners=False)
    if option == "all":
        corners = np.arange(count)
        creases = np.unique(np.sort(np.stack([topo.origin, topo.origin[topo.next]], 1), axis=1), axis=0)
        return creases, np.full(len(creases), np.inf), corners, np.full(count, np.inf)
    extra = np.flatnonzero(topo.boundary_vertex)
    return (creases, crease_sharpness, *_merge(np.concatenate([corners, extra]),
                                               np.concatenate([corner_sharpness,
                                                               np.full(len(extra), np.inf)])))


class FaceVarying(eqx.Module):
    r"""Refine face-varying data (UV coordinates with seams, per-corner colours) along
    with a mesh, as OpenSubdiv refines its face-varying channels.

    `indices` gives each face corner of the mesh an index into a value array of its
    own: faces that meet at a vertex but use different indices there make a *seam*,
    across which the values do not blend. The channel is refined by the same scheme as
    its own mesh of `indices`, in which a seam is a boundary: face points are the
    average of the face's values, a seam edge's point is the midpoint of its side's two
    values, other edges and values away from seams follow the mesh's rules (its creases,
    corners and sharpness carried to the corresponding edges and values), and a value on
    a seam follows the boundary curve rule along the seam, unless
    `linear_interpolation` keeps it sharp. The options are OpenSubdiv's
    `Sdc::Options::FVarLinearInterpolation` (with its rules from `Vtr::FVarLevel`; in
    Blender's `uv_smooth`, "None" is `"all"` and "All" is `"none"`):

    - `"none"`: smooth everywhere; only values at the mesh's corners stay (OpenSubdiv
      pins those under its default "edge and corner" boundary rule);
    - `"corners_only"`: also a value whose region has a single face at that vertex (a
      corner of a UV island);
    - `"corners_plus1"`: also every value at a vertex where three or more values meet
      (a junction of islands), and both values at a vertex with two values where either
      region holds an infinitely sharp crease;
    - `"corners_plus2"`: also both values at a vertex with two values where either
      region has a single face (a concave corner of the other island), and the value at
      an interior vertex where a seam ends (a dart);
    - `"boundaries"`: every value on a seam or on the mesh's boundary, at every level
      (linear along them);
    - `"all"` (OpenSubdiv's default): every value and edge, at every level (bilinear).

    Calling it refines `(..., U, C)` values to `(..., U', C)`: one jitted stencil
    kernel per level, differentiable and batched like [`jaxsubdiv.surfaces.Refiner`][].
    `faces` are the refined corner indices: refined face `i`'s corner `j` belongs to
    corner `j` of face `i` of `Refiner(mesh, scheme, levels).faces` (both refine faces
    in the same order).

    For `Loop()` and `CatmullClark()`. Not handled (a `ValueError` from the channel's
    own mesh, or documented): a value used in two separate fans of faces around one
    vertex (OpenSubdiv makes it sharp; here it is a non-manifold channel, an error),
    and OpenSubdiv's "dependent sharpness" at a vertex with two values of which only
    one region holds a semi-sharp crease.
    """

    tables: tuple[StencilTable, ...]
    linear_interpolation: str = eqx.field(static=True)
    num_base_values: int = eqx.field(static=True)
    memory_budget: float = eqx.field(static=True)
    _template: Mesh

    def __init__(
        self,
        mesh: Mesh,
        indices: Int[ArrayLike, "F K"],
        scheme: AbstractSurfaceScheme,
        levels: int = 1,
        *,
        linear_interpolation: str = "all",
        memory_budget: float = DEFAULT_MEMORY_BUDGET,
    ):
        """**Arguments:**

        - `mesh`: the [`jaxsubdiv.surfaces.Mesh`][] the data belong to (its faces and
          tags are used).
        - `indices`: `(F, K)` integer array (or lists) like `mesh.faces`: the value index
          of every face corner, `-1` exactly where `mesh.faces` pads. Values are
          numbered from 0 without gaps.
        - `scheme`: `Loop()` or `CatmullClark()`.
        - `levels`: as for `Refiner`.
        - `linear_interpolation`: which values stay sharp (above). Keyword only.
        - `memory_budget`: as for `Refiner`. Keyword only.
        """
        _check(mesh, scheme)
        if not hasattr(scheme, "boundary_interpolation"):
            raise ValueError(
                f"`FaceVarying` takes `Loop()` or `CatmullClark()`, got "
                f"{type(scheme).__name__}(): OpenSubdiv defines face-varying rules for "
                "the primal schemes only."
            )
        if linear_interpolation not in LINEAR_INTERPOLATION:
            raise ValueError(
                f"`linear_interpolation` must be one of {LINEAR_INTERPOLATION}, got "
                f"{linear_interpolation!r}."
            )
        levels = static_int(levels, "levels", minimum=0, maximum=MAX_LEVELS)
        memory_budget = checked_budget(memory_budget)
        channel = as_faces(indices)
        if channel.shape != mesh.faces.shape or np.any((channel < 0) != (mesh.faces < 0)):
            raise ValueError(
                f"`indices` must have the shape of `mesh.faces` {mesh.faces.shape} and -1 "
                f"exactly where it pads a face; got shape {channel.shape}."
            )
        used = np.unique(channel[channel >= 0])
        if len(used) and (used[0] != 0 or used[-1] != len(used) - 1):
            raise ValueError(
                "`indices` must number the values 0, 1, ..., U - 1 without gaps "
                f"(value {int(np.setdiff1d(np.arange(used[-1] + 1), used)[0])} is unused)."
            )
        topo = build_topology(mesh.faces, mesh.num_vertices, mesh.creases, mesh.corners,
                              scheme.boundary_corners)  # fmt: skip
        count, (creases, crease_sharpness), (corners, corner_sharpness) = _channel_tags(
            mesh, channel, topo, scheme, linear_interpolation
        )
        # Values in a single face are corners except under "none" (OpenSubdiv's
        # corners-only rule and everything more linear); the mesh's own corners were
        # tagged above.
        boundary = "edge_only" if linear_interpolation == "none" else "edge_and_corner"
        rules = type(scheme)(boundary_interpolation=boundary, crease_method=scheme.crease_method)
        faces, tables = channel, []
        try:
            for level in range(levels):
                if linear_interpolation in ("boundaries", "all"):
                    creases, crease_sharpness, corners, corner_sharpness = _linear_tags(
                        faces, count, linear_interpolation, creases, crease_sharpness,
                        corners, corner_sharpness,
                    )  # fmt: skip
                step = Refiner(
                    Mesh(np.zeros((count, 0)), faces, creases=creases, corners=corners,
                         crease_sharpness=crease_sharpness, corner_sharpness=corner_sharpness),
                    rules, 1, memory_budget=memory_budget,
                )  # fmt: skip
                tables += step.tables
                faces, count = step.faces, step.num_vertices
                creases, crease_sharpness = step.creases, step.crease_sharpness
                corners, corner_sharpness = step.corners, step.corner_sharpness
        except ValueError as error:
            raise ValueError(f"`indices` as a mesh of face-varying values: {error}") from None
        self.tables = tuple(tables)
        self.linear_interpolation = linear_interpolation
        self.num_base_values = int(used[-1]) + 1 if len(used) else 0
        self.memory_budget = memory_budget
        self._template = Mesh(np.zeros((count, 0)), faces)

    def __call__(self, values: Float[ArrayLike, "*batch U C"]) -> Float[Array, "*batch N C"]:
        """The refined values, `(..., U', C)` for `(..., U, C)`."""
        return apply_tables(self.tables, values, self.num_base_values, self.num_values,
                            self.memory_budget, "FaceVarying", "values")  # fmt: skip

    @property
    def faces(self) -> np.ndarray:
        """Refined corner indices into the refined values, aligned with the refined
        mesh's faces."""
        return self._template.faces

    @property
    def num_values(self) -> int:
        return self._template.num_vertices
