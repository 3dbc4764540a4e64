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
from ._local import _level
from ._mesh import Mesh, as_faces
from ._refine import (
    MAX_LEVELS,
    Refiner,
    _check,
    _check_surface_memory,
    apply_tables,
)
from ._stencil import StencilTable
from ._topology import build_topology, flatten_faces


#: OpenSubdiv's `FVarLinearInterpolation` options, by its names (lower case, without
#: the `FVAR_LINEAR_` prefix), from the smoothest to the most linear.
LINEAR_INTERPOLATION = ("none", "corners_only", "corners_plus1", "corners_plus2",
                        "boundaries", "all")  # fmt: skip


def _option_corners(mesh: Mesh, flat: np.ndarray, count: int, topo, scheme, option: str):
    """The values that the option keeps sharp from the start (OpenSubdiv's
    `Vtr::FVarLevel` rules), as indices into the level-0 values; refinement keeps their
    indices, and children inherit them."""
    V = topo.num_vertices
    sharp = np.zeros(V, bool)
    if scheme.boundary_corners:  # the mesh's own corners pin every value there
        sharp |= topo.boundary_vertex & (np.bincount(topo.origin, minlength=V) == 1)
    values_at = np.bincount(np.unique(np.stack([topo.origin, flat], 1), axis=0)[:, 0],
                            minlength=V)  # fmt: skip
    if option in ("corners_plus1", "corners_plus2"):
        sharp |= values_at >= 3  # a junction of three or more regions
        # Per value: the faces of its region at its vertex, and whether an infinitely
        # sharp edge of the mesh lies inside that region (continuous at that end: a
        # crease along a seam bounds the region and does not count).
        span = np.bincount(flat, minlength=count)
        edge_sharpness = np.zeros(topo.num_edges)
        if len(mesh.creases):
            edge_sharpness[topo.edge_ids(mesh.creases, "creases")] = mesh.crease_sharpness
        h = np.flatnonzero(np.isinf(edge_sharpness[topo.edge]) & (topo.twin >= 0))
        inside = np.zeros(count, bool)
        inside[flat[h[flat[h] == flat[topo.next[topo.twin[h]]]]]] = True
        either = np.zeros(V, bool)
        either[topo.origin[inside[flat]]] = True
        if option == "corners_plus2":
            either[topo.origin[span[flat] == 1]] = True  # one region's corner is concave
            # A seam's end inside the mesh (a dart): one value, and a seam edge at it (an
            # edge whose faces disagree at either end touches both ends).
            inner = np.flatnonzero(topo.twin >= 0)
            seam = np.zeros(topo.num_edges, bool)
            seam[topo.edge[inner[flat[inner] != flat[topo.next[topo.twin[inner]]]]]] = True
            touched = np.zeros(V, bool)
            touched[topo.edges[seam].reshape(-1)] = True
            sharp |= (values_at == 1) & touched & ~topo.boundary_vertex
        sharp |= (values_at == 2) & either
    return np.unique(flat[sharp[topo.origin]])


def _mapped_tags(topo, flat: np.ndarray, creases, crease_sharpness, corners, corner_sharpness):
    """The mesh's tags (at this level, with their sharpness) on the channel: a tagged edge
    on each of its faces' channel edges, a tagged vertex on each of its values. The
    channel takes the mesh's decayed sharpness every level, so that it decays as the
    mesh's does (under Chaikin, by the mesh's neighbours, not the channel's)."""
    edge_sharpness = np.zeros(topo.num_edges)
    if len(creases):
        edge_sharpness[topo.edge_ids(creases, "creases")] = crease_sharpness
    tagged = np.flatnonzero(edge_sharpness[topo.edge] > 0)
    pairs = np.sort(np.stack([flat[tagged], flat[topo.next[tagged]]], 1), axis=1)
    vertex_sharpness = np.zeros(topo.num_vertices)
    vertex_sharpness[np.asarray(corners, np.int64)] = corner_sharpness
    corner = np.flatnonzero(vertex_sharpness[topo.origin] > 0)
    return (*_merge(pairs, edge_sharpness[topo.edge[tagged]]),
            *_merge(flat[corner], vertex_sharpness[topo.origin[corner]]))


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
          numbered from 0 without gaps, and a value belongs to one vertex of the mesh
          (an OBJ file's `vt` shared by two vertices must be copied for each).
        - `scheme`: `Loop()` or `CatmullClark()`.
        - `levels`: as for `Refiner`.
        - `linear_interpolation`: which values stay sharp (above). Keyword only.
        - `memory_budget`: as for `Refiner`, for the channel and the mesh's tags
          refined side by side (checked before anything is built). Keyword only.
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
        try:
            channel = as_faces(indices)
        except (TypeError, ValueError) as error:
            raise type(error)(str(error).replace("`faces`", "`indices`")) from None
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
        count = len(used)
        topo = build_topology(mesh.faces, mesh.num_vertices, mesh.creases, mesh.corners,
                              scheme.boundary_corners)  # fmt: skip
        flat, _ = flatten_faces(channel)  # one value per half-edge, like `topo.origin`
        owners = np.unique(np.stack([flat, topo.origin], 1), axis=0)
        if len(owners) > count:
            u = int(owners[np.argmax(owners[1:, 0] == owners[:-1, 0]) + 1, 0])
            at = owners[owners[:, 0] == u, 1][:2].tolist()
            raise ValueError(
                f"`indices`: value {u} is used at the mesh's vertices {at[0]} and {at[1]}; "
                "a value belongs to one vertex (as in OpenSubdiv). Give each vertex its "
                "own copy of a shared value."
            )
        # Values in a single face are corners except under "none" (OpenSubdiv's
        # corners-only rule and everything more linear).
        boundary = "edge_only" if linear_interpolation == "none" else "edge_and_corner"
        rules = type(scheme)(boundary_interpolation=boundary, crease_method=scheme.crease_method)
        try:
            values_topo = build_topology(channel, count, boundary_corners=rules.boundary_corners)
        except ValueError as error:
            raise ValueError(f"`indices` as a mesh of face-varying values: {error}") from None
        _check_surface_memory(values_topo, rules, levels, memory_budget, "FaceVarying", factor=2)
        extra = _option_corners(mesh, flat, count, topo, scheme, linear_interpolation)

        # Level by level, the mesh (for its refined tags) and the channel side by side.
        faces, tags = mesh.faces, (mesh.creases, mesh.crease_sharpness, mesh.corners,
                                   mesh.corner_sharpness)  # fmt: skip
        vertices, tables = mesh.num_vertices, []
        for level in range(levels):
            creases, crease_sharpness, corners, corner_sharpness = _mapped_tags(
                topo, flat, *tags
            )
            corners, corner_sharpness = _merge(
                np.concatenate([corners, extra]),
                np.concatenate([corner_sharpness, np.full(len(extra), np.inf)]),
            )
            if linear_interpolation in ("boundaries", "all"):
                creases, crease_sharpness, corners, corner_sharpness = _linear_tags(
                    channel, count, linear_interpolation, creases, crease_sharpness,
                    corners, corner_sharpness,
                )  # fmt: skip
            step = Refiner(
                Mesh(np.zeros((count, 0)), channel, creases=creases, corners=corners,
                     crease_sharpness=crease_sharpness, corner_sharpness=corner_sharpness),
                rules, 1, memory_budget=memory_budget,
            )  # fmt: skip
            tables += step.tables
            channel, count = step.faces, step.num_vertices
            if level == levels - 1:
                break
            refined = _level(scheme, faces, vertices, tags[0], tags[2], tags[1], tags[3], topo=topo)
            faces, vertices = refined.faces, refined.stencil.shape[0]
            tags = (refined.creases, refined.crease_sharpness, refined.corners,
                    refined.corner_sharpness)  # fmt: skip
            topo = build_topology(faces, vertices, tags[0], tags[2], scheme.boundary_corners,
                                  validate=False)  # a level of a checked mesh
            flat, _ = flatten_faces(channel)
        self.tables = tuple(tables)
        self.linear_interpolation = linear_interpolation
        self.num_base_values = int(used[-1]) + 1 if len(used) else 0
        self.memory_budget = memory_budget
        self._template = Mesh(np.zeros((count, 0)), channel)

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
