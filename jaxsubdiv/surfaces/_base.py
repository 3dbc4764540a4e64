"""The abstract surface scheme and the host-side pieces the schemes share."""

import abc
import dataclasses

import equinox as eqx
import numpy as np

from ._stencil import Sparse
from ._topology import CREASE, SMOOTH, Topology


@dataclasses.dataclass(frozen=True)
class Level:
    """One level of refinement on the host: the stencil and the refined topology."""

    stencil: Sparse  # (new vertices, old vertices)
    faces: np.ndarray  # padded (F', K') refined faces
    creases: np.ndarray  # (C', 2) tagged crease edges of the refined mesh
    corners: np.ndarray  # tagged corner vertices of the refined mesh


@dataclasses.dataclass(frozen=True)
class LimitStencils:
    """Limit position and tangent stencils, one row per base vertex."""

    position: Sparse
    tangent_u: Sparse  # zero rows at non-smooth vertices
    tangent_v: Sparse
    smooth: np.ndarray  # (V,) bool: rows where the tangents are exact


class AbstractSurfaceScheme(eqx.Module):
    """A stationary linear subdivision scheme for polygon meshes.

    A scheme turns the *topology* of a mesh into stencil tables on the host (numpy,
    vectorized); the tables are then applied to vertex data in JAX. Subclasses are
    [`jaxsubdiv.surfaces.Loop`][], [`jaxsubdiv.surfaces.CatmullClark`][] and
    [`jaxsubdiv.surfaces.DooSabin`][]. Schemes have no parameters; they are modules so
    that they can sit inside other modules and pass through `jax.jit`.
    """

    @abc.abstractmethod
    def level(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> Level:
        """One level of refinement of `topology` (host-side, numpy)."""

    def limit(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> LimitStencils:
        """Limit position and tangent stencils at the vertices of `topology`."""
        raise ValueError(
            f"{type(self).__name__} has no limit stencils; limit positions and normals "
            "are available for `Loop()` and `CatmullClark()`."
        )


def edge_end_rule(topo, smooth_weight: float):
    """Rows, columns and weights of an edge point's two end vertices, the edge points
    numbered after the `topo.num_vertices` vertex points: sharp (and boundary) edges
    take the midpoint, smooth ones `smooth_weight` on each end."""
    V, E = topo.num_vertices, topo.num_edges
    end = np.where(topo.sharp_edge, 1 / 2, smooth_weight)
    rows = [V + np.arange(E), V + np.arange(E)]
    return rows, [topo.edges[:, 0], topo.edges[:, 1]], [end, end]


def vertex_rule(
    topo: Topology,
    smooth_center: np.ndarray,
    smooth_neighbor: np.ndarray,
    crease_weights: tuple[float, float],
) -> tuple[list, list, list]:
    """Coordinate lists for vertex rows that use only the vertex and its edge neighbors.

    Smooth vertices: `smooth_center[v] * v + smooth_neighbor[v] * sum(neighbors)`.
    Crease vertices (two sharp edges): `c * v + s * (a + b)` over the two sharp
    neighbors, `(c, s) = crease_weights` (the cubic B-spline curve rule or its limit).
    Corners are kept. Face-point terms, if any, are added by the caller.
    """
    V = topo.num_vertices
    vt = topo.vertex_type
    center, side = crease_weights
    diag = np.where(vt == SMOOTH, smooth_center, np.where(vt == CREASE, center, 1.0))
    rows, cols, weights = [np.arange(V)], [np.arange(V)], [diag]
    a, b = topo.edges[:, 0], topo.edges[:, 1]
    for p, q in ((a, b), (b, a)):
        m = vt[p] == SMOOTH
        rows += [p[m]]
        cols += [q[m]]
        weights += [smooth_neighbor[p[m]]]
        m = (vt[p] == CREASE) & topo.sharp_edge
        rows += [p[m]]
        cols += [q[m]]
        weights += [np.full(m.sum(), side)]
    return rows, cols, weights


def refined_tags(
    topo: Topology, corners: np.ndarray, edge_vertex_offset: int
) -> tuple[np.ndarray, np.ndarray]:
    """Tags of a primal refinement: each tagged crease edge `(a, b)` becomes
    `(a, m), (m, b)` with `m = edge_vertex_offset + edge`; corners keep their indices."""
    tagged = np.flatnonzero(topo.sharp_edge & ~topo.boundary_edge)
    mid = edge_vertex_offset + tagged
    a, b = topo.edges[tagged, 0], topo.edges[tagged, 1]
    creases = np.concatenate([np.stack([a, mid], 1), np.stack([b, mid], 1)])
    return np.sort(creases, axis=1), corners


def ring_positions(topo: Topology) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ordered one-rings of the smooth vertices: `(half_edge, index, valence)`.

    For every outgoing half-edge `h` of a smooth vertex `v`, its rank `i` in the
    counter-clockwise ring of `v` and the valence of `v`.
    """
    order, start = topo.ring()
    v = topo.origin[order]
    keep = topo.vertex_type[v] == SMOOTH
    rank = np.arange(len(order)) - start[v]
    return order[keep], rank[keep], topo.valence[v[keep]].astype(np.float64)
