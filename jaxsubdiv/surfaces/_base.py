"""The abstract surface scheme and the host-side pieces the schemes share."""

import abc
import dataclasses
from typing import ClassVar

import equinox as eqx
import numpy as np

from ._stencil import Sparse, _ranks
from ._topology import CORNER, CREASE, SMOOTH, Topology


@dataclasses.dataclass(frozen=True)
class Level:
    """One level of refinement on the host: the stencil and the refined topology."""

    stencil: Sparse  # (new vertices, old vertices)
    faces: np.ndarray  # padded (F', K') refined faces
    creases: np.ndarray  # (C', 2) tagged crease edges of the refined mesh
    corners: np.ndarray  # tagged corner vertices of the refined mesh
    crease_sharpness: np.ndarray | None = None  # (C',); None: all infinitely sharp
    corner_sharpness: np.ndarray | None = None


# Kinds of sector normals (see `sector_stencils`).
EXACT, CORNER_TANGENTS, APPROXIMATE = 0, 1, 2


@dataclasses.dataclass(frozen=True)
class LimitStencils:
    """Limit position and tangent stencils, one row per base vertex, and per-sector
    tangent stencils at vertices on sharp edges."""

    position: Sparse
    tangent_u: Sparse  # exact tangents; zero rows where there is no single tangent plane
    tangent_v: Sparse
    smooth: np.ndarray  # (V,) bool: vertices whose normal is tangent_u x tangent_v
    sector_u: Sparse  # (S, V): two tangents per sector of a vertex on sharp edges
    sector_v: Sparse
    sector_vertex: np.ndarray  # (S,) the vertex of each sector
    sector_kind: np.ndarray  # (S,) EXACT, CORNER_TANGENTS or APPROXIMATE
    corner_points: Sparse  # (3T, V) limit points (prev, vertex, next) of face corners (Newell triples at valence 2)
    corner_sector: np.ndarray  # (T,) the sector of each such face corner

    def compose(self, keep: np.ndarray, first: Sparse) -> "LimitStencils":
        """These stencils (on a refined mesh) for the vertices `keep` of the coarse mesh
        it came from, composed with the refinement stencil `first`."""
        sectors = np.flatnonzero(np.isin(self.sector_vertex, keep))
        remap = np.full(self.position.shape[0], -1, np.int64)
        remap[keep] = np.arange(len(keep))
        corners = np.flatnonzero(np.isin(self.corner_sector, sectors))
        new_sector = np.full(len(self.sector_vertex), -1, np.int64)
        new_sector[sectors] = np.arange(len(sectors))
        points = np.stack([3 * corners, 3 * corners + 1, 3 * corners + 2], 1).reshape(-1)
        return LimitStencils(
            *(s.take_rows(keep) @ first for s in (self.position, self.tangent_u, self.tangent_v)),
            self.smooth[keep],
            *(s.take_rows(sectors) @ first for s in (self.sector_u, self.sector_v)),
            remap[self.sector_vertex[sectors]],
            self.sector_kind[sectors],
            self.corner_points.take_rows(points) @ first,
            new_sector[self.corner_sector[corners]],
        )

    def replace(self, vertices: np.ndarray, other: "LimitStencils") -> "LimitStencils":
        """These stencils with those of `vertices` taken from `other`, whose rows are
        `vertices` in that order (on the same base vertices)."""
        V = self.position.shape[0]
        mine = np.ones(V, bool)
        mine[vertices] = False

        def rows(a: Sparse, b: Sparse, keep: np.ndarray, b_rows: np.ndarray, count: int):
            # `a`'s rows `keep` (by row) and `b`'s, renumbered `b_rows[row]`.
            ka = keep[a.rows]
            return Sparse.build(np.concatenate([a.rows[ka], b_rows[b.rows]]),
                                np.concatenate([a.cols[ka], b.cols]),
                                np.concatenate([a.weights[ka], b.weights]), (count, a.shape[1]))  # fmt: skip

        kept = mine[self.sector_vertex]
        old = np.flatnonzero(kept)
        S = len(old) + len(other.sector_vertex)
        sector_index = np.full(len(self.sector_vertex), -1, np.int64)
        sector_index[old] = np.arange(len(old))
        their_sectors = len(old) + np.arange(len(other.sector_vertex))
        corner_kept = kept[self.corner_sector]
        T = int(corner_kept.sum()) + len(other.corner_sector)
        point_kept = np.repeat(corner_kept, 3)
        point_index = np.full(len(point_kept), -1, np.int64)
        point_index[point_kept] = np.arange(int(point_kept.sum()))
        their_points = int(point_kept.sum()) + np.arange(3 * len(other.corner_sector))
        smooth = self.smooth.copy()
        smooth[vertices] = other.smooth
        return LimitStencils(
            *(rows(a, b, mine, vertices, V) for a, b in ((self.position, other.position),
              (self.tangent_u, other.tangent_u), (self.tangent_v, other.tangent_v))),  # fmt: skip
            smooth,
            *(Sparse.build(np.concatenate([sector_index[a.rows[kept[a.rows]]], their_sectors[b.rows]]),
                           np.concatenate([a.cols[kept[a.rows]], b.cols]),
                           np.concatenate([a.weights[kept[a.rows]], b.weights]), (S, a.shape[1]))
              for a, b in ((self.sector_u, other.sector_u), (self.sector_v, other.sector_v))),  # fmt: skip
            np.concatenate([self.sector_vertex[old], vertices[other.sector_vertex]]),
            np.concatenate([self.sector_kind[old], other.sector_kind]),
            Sparse.build(np.concatenate([point_index[self.corner_points.rows[point_kept[self.corner_points.rows]]],
                                         their_points[other.corner_points.rows]]),
                         np.concatenate([self.corner_points.cols[point_kept[self.corner_points.rows]],
                                         other.corner_points.cols]),
                         np.concatenate([self.corner_points.weights[point_kept[self.corner_points.rows]],
                                         other.corner_points.weights]),
                         (3 * T, self.corner_points.shape[1])),  # fmt: skip
            np.concatenate([sector_index[self.corner_sector[corner_kept]],
                            len(old) + other.corner_sector]),
        )


@dataclasses.dataclass(frozen=True)
class Counts:
    """Sizes of a mesh's topology, for estimating refinement before building it."""

    vertices: int
    edges: int
    faces: int
    half_edges: int
    sharp: int  # sharp (boundary or crease) edges
    corner_ends: int  # sharp edges counted at each corner vertex they end at
    isolated: int = 0  # vertices in no face (every scheme keeps them as they are)

    @staticmethod
    def of(topo: Topology) -> "Counts":
        ends = np.bincount(topo.edges[topo.sharp_edge].reshape(-1), minlength=topo.num_vertices)
        return Counts(
            topo.num_vertices, topo.num_edges, topo.num_faces, topo.num_half_edges,
            int(topo.sharp_edge.sum()), int(ends[topo.vertex_type == CORNER].sum()),
            int((topo.valence == 0).sum()),
        )  # fmt: skip


class AbstractSurfaceScheme(eqx.Module):
    """A stationary linear subdivision scheme for polygon meshes.

    A scheme turns the *topology* of a mesh into stencil tables on the host (numpy,
    vectorized); the tables are then applied to vertex data in JAX. Subclasses are
    [`jaxsubdiv.surfaces.Loop`][], [`jaxsubdiv.surfaces.CatmullClark`][] and
    [`jaxsubdiv.surfaces.DooSabin`][]. Schemes have no numeric parameters (Loop and
    Catmull-Clark have one static option, `boundary_interpolation`); they are modules so
    that they can sit inside other modules and pass through `jax.jit`.
    """

    @property
    def boundary_corners(self) -> bool:
        """Whether a boundary vertex in a single face is a corner, kept where it is
        (OpenSubdiv's "edge and corner" boundary interpolation); otherwise it follows
        the boundary curve's rule like any boundary vertex ("edge only")."""
        return True

    #: Peak host memory of building a `Refiner`, in bytes per half-edge of the refined
    #: mesh (topology, stencil tables, refined faces), measured in float64 on meshes of
    #: 0.1 to 1.5 million half-edges; used to check `memory_budget` before building.
    bytes_per_half_edge: ClassVar[int] = 400

    @abc.abstractmethod
    def level(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> Level:
        """One level of refinement of `topology` (host-side, numpy)."""

    def refined_counts(self, counts: Counts) -> Counts:
        """The counts after one level (exact, or an upper estimate), without refining.

        The default is a generic estimate (four times the half-edges, plus eight per
        sharp edge); the built-in schemes give their own.
        """
        c = counts
        half_edges = 4 * c.half_edges + 8 * c.sharp
        sharp = 2 * c.sharp + c.corner_ends
        return Counts(
            c.vertices + c.edges + c.faces + c.half_edges, (half_edges + sharp) // 2,
            half_edges // 3, half_edges, sharp, c.corner_ends, c.isolated,
        )  # fmt: skip

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
    smooth: bool = True,
) -> tuple[list, list, list]:
    """Coordinate lists for vertex rows that use only the vertex and its edge neighbors.

    Smooth vertices: `smooth_center[v] * v + smooth_neighbor[v] * sum(neighbors)`.
    Crease vertices (two sharp edges): `c * v + s * (a + b)` over the two sharp
    neighbors, `(c, s) = crease_weights` (the cubic B-spline curve rule or its limit).
    Corners are kept. Face-point terms, if any, are added by the caller.
    `smooth=False` leaves the smooth vertices' rows out (the caller builds them; the
    other entries are the same, in the same order); `smooth_center` and
    `smooth_neighbor` are then unused.
    """
    V = topo.num_vertices
    vt = topo.vertex_type
    center, side = crease_weights
    if smooth:
        diag = np.where(vt == SMOOTH, smooth_center, np.where(vt == CREASE, center, 1.0))
        rows, cols, weights = [np.arange(V)], [np.arange(V)], [diag]
    else:
        keep = np.flatnonzero(vt != SMOOTH)
        rows, cols, weights = [keep], [keep], [np.where(vt[keep] == CREASE, center, 1.0)]
    a, b = topo.edges[:, 0], topo.edges[:, 1]
    sharp_at = (topo.sharp_edge, topo.sharp_edge) if topo.crease_end is None else topo.crease_end.T
    for p, q, sharp in ((a, b, sharp_at[0]), (b, a, sharp_at[1])):
        if smooth:
            m = vt[p] == SMOOTH
            if m.all():  # no sharp features (every refined level of a closed mesh)
                m = slice(None)
            rows += [p[m]]
            cols += [q[m]]
            weights += [smooth_neighbor[p[m]]]
        m = (vt[p] == CREASE) & sharp
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


def symmetric_subspace(perm: np.ndarray) -> np.ndarray:
    """Orthonormal basis (columns) of the vectors `x` with `x[perm] == x`, for an
    involution `perm`."""
    n = len(perm)
    pairs = np.unique(np.sort(np.stack([np.arange(n), perm], 1), axis=1), axis=0)
    basis = np.zeros((n, len(pairs)))
    basis[pairs[:, 0], np.arange(len(pairs))] = 1.0
    basis[pairs[:, 1], np.arange(len(pairs))] = 1.0
    return basis / np.linalg.norm(basis, axis=0)


def antisymmetric_subspace(perm: np.ndarray) -> np.ndarray:
    """Orthonormal basis (columns) of the vectors `x` with `x[perm] == -x`."""
    n = len(perm)
    i = np.flatnonzero(np.arange(n) < perm)
    basis = np.zeros((n, len(i)))
    basis[i, np.arange(len(i))] = 1 / np.sqrt(2)
    basis[perm[i], np.arange(len(i))] = -1 / np.sqrt(2)
    return basis


#: How much larger the tangent eigenvalues must be than all others for an exact tangent
#: plane. Well above LAPACK's accuracy for repeated eigenvalues, which is about the square
#: root of machine epsilon (a Loop boundary sector of 6 triangles has a defective double
#: eigenvalue 1/2 that one build returned split by 1.7e-9, which a margin of 1e-9 then
#: called dominant): doubtful cases are called approximate, never the other way round.
DOMINANCE_MARGIN = 1e-6


def dominant(matrix: np.ndarray, basis: np.ndarray, skip: int = 0) -> tuple[float, np.ndarray]:
    """The `skip`-th largest eigenvalue of `matrix.T` on the invariant subspace spanned
    by `basis`, and its (left) eigenvector."""
    values, vectors = np.linalg.eig(basis.T @ matrix.T @ basis)
    order = np.argsort(-values.real)
    return float(values[order[skip]].real), basis @ vectors[:, order[skip]].real


def dart_masks(matrix: np.ndarray, perm: np.ndarray):
    r"""Limit position and tangent masks at a dart (an interior vertex on one crease
    edge), and whether the tangents span the limit tangent plane.

    `matrix` is the local subdivision matrix of the dart's ring (the smooth vertex
    rule, the crease edge's midpoint, the smooth edge rule elsewhere), `perm` the ring's
    mirror symmetry through the crease edge, ring position 1 on the crease edge and 2
    the next counter-clockwise. Position: the left eigenvector of eigenvalue 1;
    tangents: the dominant left eigenvectors below 1 in the symmetric subspace (along
    the crease edge) and in the antisymmetric one (across it), valid when their
    eigenvalues are strictly larger than all the others (Reif 1995).
    """
    _, position = dominant(matrix, symmetric_subspace(perm))
    lam_s, along = dominant(matrix, symmetric_subspace(perm), skip=1)
    antisymmetric = antisymmetric_subspace(perm)
    if antisymmetric.shape[1] == 0:
        # Valence 2 (Loop): the mirror fixes the whole ring, so nothing crosses the
        # crease edge and there is no tangent plane; the position is still exact.
        return position / position.sum(), np.zeros(len(perm)), np.zeros(len(perm)), False
    lam_a, across = dominant(matrix, antisymmetric)
    rest = list(np.linalg.eigvals(matrix))
    for target in (1.0, lam_s, lam_a):
        rest.pop(int(np.argmin(np.abs(np.array(rest) - target))))
    exact = max((abs(x) for x in rest), default=0.0) < min(lam_s, lam_a) - DOMINANCE_MARGIN
    along = along / np.abs(along).max() * np.sign(along[1] - along[0])
    across = across / np.abs(across).max() * np.sign(across[2])
    return position / position.sum(), along, across, exact


def cross_tangent(matrix: np.ndarray, perm: np.ndarray, interior: np.ndarray):
    r"""The cross-boundary limit tangent mask of a boundary sector, and whether the
    limit surface has a tangent plane there.

    `matrix` is the sector's local subdivision matrix (ring to refined ring), `perm`
    the ring's mirror symmetry (which the matrix commutes with) and `interior` the
    ring positions off the sharp edges. The tangent along the sharp edges is the
    antisymmetric left eigenvector $p_0 - p_k$ (eigenvalue $\frac12$, the cubic
    B-spline curve's); the cross tangent is the dominant symmetric left eigenvector
    below 1, found in the symmetric subspace. The tangent plane they span is the limit
    tangent plane if these two eigenvalues are strictly larger in modulus than all the
    others (Reif 1995; Zorin 2000), which this checks numerically. Sign: pointing into
    the sector (positive total weight on the interior ring points).
    """
    basis = symmetric_subspace(perm)
    values, vectors = np.linalg.eig(basis.T @ matrix.T @ basis)
    order = np.argsort(-values.real)
    lam = float(values[order[1]].real) if len(order) > 1 else 0.0
    mask = basis @ vectors[:, order[1]].real if len(order) > 1 else np.zeros(len(perm))
    rest = list(np.linalg.eigvals(matrix))
    for target in (1.0, 0.5, lam):
        rest.pop(int(np.argmin(np.abs(np.array(rest) - target))))
    largest = max((abs(x) for x in rest), default=0.0)
    exact = bool(len(interior)) and largest < min(0.5, lam) - DOMINANCE_MARGIN
    mask = mask / np.abs(mask).max()
    if mask[interior].sum() < 0:
        mask = -mask
    return mask, exact


def sector_stencils(topo: Topology, position: Sparse, ring, local,
                    no_tangent_plane: np.ndarray | None = None):  # fmt: skip
    r"""Per-sector tangent stencils at the vertices on sharp edges (boundary or crease).

    For every sector (a fan of faces between two sharp edges, see
    `Topology.sectors`) of `k` faces:

    - at a crease or boundary vertex (not a corner): the tangent along the sharp
      edges $p_0 - p_k$ and the cross tangent from the eigenvectors of the sector's
      local subdivision matrix (`local(k) -> (matrix, perm)` on the ring
      `ring(topo, half_edges) -> (n, m)` columns: the vertex, then $p_0, \dots, p_k$
      along the sector's edges, then scheme-specific points), kind `EXACT`, or kind
      `APPROXIMATE` with zero rows where that sector has no tangent plane;
    - for a sector of one face (not at a corner), in closed form: $p_0 - p_1$ and
      $\frac12(p_0 + p_1) - v$, the control triangle's plane, kind `EXACT`;
    - at a corner: the two sharp-edge tangents $p_0 - v$ and $p_k - v$ (the limit
      tangents of the crease curves at a clamped end), kind `CORNER_TANGENTS`;
      `APPROXIMATE` if the sector starts and ends on the same sharp edge;
    - tagged corners on no sharp edge, and the interior vertices in
      `no_tangent_plane` (smooth or dart, e.g. of valence 2): the whole ring as one
      `APPROXIMATE` sector.

    Also the face corners (previous, vertex, next; as rows of limit positions) of
    the non-`EXACT` sectors, for the orientation and the approximate normals; at an
    interior vertex of valence 2, whose two corners' cross products cancel, for each
    edge (a, b) of each of its faces the triple (b, face centroid, a) instead, so that
    the sum is their Newell normals.
    """
    V = topo.num_vertices
    order, start = topo.sectors()
    counts = np.diff(start)
    keep = topo.vertex_type[topo.origin[order[start[:-1]]]] != SMOOTH  # not darts
    order, counts = order[np.repeat(keep, counts)], counts[keep]
    start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    S = len(counts)
    first, last = order[start[:-1]], order[start[1:] - 1]
    vertex = topo.origin[first]
    # A corner on a single sharp edge has one crease tangent: approximate it.
    corner = (topo.vertex_type[vertex] == CORNER) & (topo.edge[first] != topo.edge[topo.prev[last]])
    kind = np.where(corner, CORNER_TANGENTS, APPROXIMATE).astype(np.int8)
    rows_u, cols_u, w_u, rows_v, cols_v, w_v = ([] for _ in range(6))
    for k in np.unique(counts):  # one vectorized pass per distinct sector size
        sel = np.flatnonzero(counts == k)
        half = order[start[sel][:, None] + np.arange(k)]  # (n, k) in ring order
        cols = ring(topo, half)  # (n, m): vertex, p_0..p_k, ...
        p0, pk, v = cols[:, 1], cols[:, k + 1], cols[:, 0]
        c = corner[sel]
        # Corners: the two crease tangents.
        rows_u += [sel[c], sel[c]]
        cols_u += [p0[c], v[c]]
        w_u += [np.ones(c.sum()), -np.ones(c.sum())]
        rows_v += [sel[c], sel[c]]
        cols_v += [pk[c], v[c]]
        w_v += [np.ones(c.sum()), -np.ones(c.sum())]
        side = topo.vertex_type[vertex[sel]] != CORNER  # boundary or crease sectors
        if k == 1:
            # One face between two sharp edges (a boundary vertex in a single face under
            # "edge only" boundary interpolation, or a crease turning within a face):
            # v, p_0, p_1 refine among themselves by the curve rules (the vertex rule
            # (1, 6, 1) / 8 and midpoints), so their local matrix has eigenvalues 1,
            # 1/2 (p_0 - p_1) and 1/4 (the curve's second difference). In Catmull-
            # Clark the face point makes 1/4 a double, defective eigenvalue, whose
            # Jordan chain also ends on the second difference: either way the tangent
            # plane is spanned by p_0 - p_1 and (p_0 + p_1) / 2 - v, the plane of the
            # control triangle (v, p_0, p_1). Nearby surface normals approach it
            # geometrically in Loop, but only as 1/level in Catmull-Clark.
            s = sel[side]
            kind[s] = EXACT
            rows_u += [s, s]
            cols_u += [p0[side], pk[side]]
            w_u += [np.ones(len(s)), -np.ones(len(s))]
            rows_v += [s, s, s]
            cols_v += [p0[side], pk[side], v[side]]
            w_v += [np.full(len(s), 0.5), np.full(len(s), 0.5), -np.ones(len(s))]
            continue
        matrix, perm = local(int(k))
        interior = np.setdiff1d(np.arange(1, matrix.shape[0]), [1, k + 1])
        mask, exact = cross_tangent(matrix, perm, interior)
        if exact and np.any(side):
            s = sel[side]
            kind[s] = EXACT
            rows_u += [s, s]
            cols_u += [p0[side], pk[side]]
            w_u += [np.ones(len(s)), -np.ones(len(s))]
            rows_v.append(np.repeat(s, cols.shape[1]))
            cols_v.append(cols[side].reshape(-1))
            w_v.append(np.tile(mask, len(s)))
    empty = [np.zeros(0, np.int64)]
    sector_u = Sparse.build(np.concatenate(rows_u + empty), np.concatenate(cols_u + empty),
                            np.concatenate(w_u + empty), (S, V))  # fmt: skip
    sector_v = Sparse.build(np.concatenate(rows_v + empty), np.concatenate(cols_v + empty),
                            np.concatenate(w_v + empty), (S, V))  # fmt: skip
    # Tagged corners on no sharp edge, and interior vertices without a tangent plane:
    # their whole ring is one approximate sector.
    ring_order, ring_start = topo.ring()
    ring_counts = np.diff(ring_start)
    lone = (topo.vertex_type != SMOOTH) & (ring_counts > 0) & (topo.num_sharp() == 0)
    if no_tangent_plane is not None:
        lone[no_tangent_plane] = True
    lone = np.flatnonzero(lone)
    order = np.concatenate([order, ring_order[np.isin(topo.origin[ring_order], lone)]])
    counts = np.concatenate([counts, ring_counts[lone]])
    vertex = np.concatenate([vertex, lone])
    kind = np.concatenate([kind, np.full(len(lone), APPROXIMATE, np.int8)])
    S = len(counts)
    sector_u = Sparse(sector_u.rows, sector_u.cols, sector_u.weights, (S, V))
    sector_v = Sparse(sector_v.rows, sector_v.cols, sector_v.weights, (S, V))
    # Face corners of the sectors that are not exact.
    sector_of = np.repeat(np.arange(S), counts)
    h = order[kind[sector_of] != EXACT]
    corner_sector = sector_of[kind[sector_of] != EXACT]
    ids = np.stack([topo.origin[topo.prev[h]], topo.origin[h], topo.origin[topo.next[h]]], 1)
    corner_points = position.take_rows(ids.reshape(-1))
    valence_two = ~topo.boundary_vertex & (topo.valence == 2)
    centre = np.flatnonzero(valence_two[ids[:, 1]])
    if len(centre):
        # At an interior vertex of valence 2 (smooth, dart or tagged corner) both faces
        # have the same two neighbors in opposite order, so the corner cross products
        # cancel. Its faces' Newell normals (of the limit points) are used instead: for
        # each face edge (a, b) the triple (b, face centroid, a), whose cross products
        # (next - centre) x (previous - centre) sum to twice the face's vector area.
        f = topo.face[h[centre]]
        edge_h = np.repeat(topo.offsets[f], topo.sizes[f]) + _ranks(topo.sizes[f])
        face_of = np.repeat(np.arange(len(f)), topo.sizes[f])  # per triple: its face
        size = topo.sizes[f[face_of]]
        t = np.arange(len(edge_h))
        rows = np.concatenate([3 * t, 3 * t + 2, np.repeat(3 * t + 1, size)])
        cols = np.concatenate([
            topo.origin[topo.next[edge_h]], topo.origin[edge_h],
            topo.origin[np.repeat(topo.offsets[f[face_of]], size) + _ranks(size)],
        ])  # fmt: skip
        weights = np.concatenate([np.ones(2 * len(t)), np.repeat(1 / size, size)])
        newell = Sparse.build(rows, cols, weights, (3 * len(t), V)) @ position
        keep = np.ones(len(h), bool)
        keep[centre] = False
        corner_points = Sparse.stack([
            position.take_rows(ids[keep].reshape(-1)), newell
        ])  # fmt: skip
        corner_sector = np.concatenate([corner_sector[keep], corner_sector[centre][face_of]])
    return sector_u, sector_v, vertex, kind, corner_points, corner_sector


def dart_stencils(topo: Topology, position: Sparse, tangent_u: Sparse, tangent_v: Sparse,
                  ring, dart) -> tuple[Sparse, Sparse, Sparse, np.ndarray]:  # fmt: skip
    """Replace the smooth-formula rows of darts by the eigenvector masks of
    `dart_masks` (`dart(n) -> (matrix, perm)` on the ring `ring` without its repeated
    closing neighbor): the position at every dart, the tangents at the valences where
    they span the tangent plane (elsewhere the dart has no tangent rows). Also returns
    the darts where they do not (valence 2)."""
    V = topo.num_vertices
    order, start = topo.sectors()
    counts = np.diff(start)
    first = order[start[:-1]]
    darts = np.flatnonzero(topo.vertex_type[topo.origin[first]] == SMOOTH)
    if len(darts) == 0:
        return position, tangent_u, tangent_v, np.zeros(0, np.int64)
    rows, cols, weights = [[], [], []], [[], [], []], [[], [], []]
    done, no_plane = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for n in np.unique(counts[darts]):  # one pass per dart valence
        sel = darts[counts[darts] == n]
        half = order[start[sel][:, None] + np.arange(n)]
        ring_cols = np.delete(ring(topo, half), n + 1, axis=1)  # p_n = p_0 again
        *masks, exact = dart_masks(*dart(int(n)))
        v = topo.origin[half[:, 0]]
        done.append(v)
        if not exact:
            no_plane.append(v)
        for t, mask in enumerate(masks if exact else masks[:1]):
            rows[t].append(np.repeat(v, ring_cols.shape[1]))
            cols[t].append(ring_cols.reshape(-1))
            weights[t].append(np.tile(mask, len(v)))
    replaced = np.zeros(V, bool)
    replaced[np.concatenate(done)] = True
    no_plane = np.concatenate(no_plane)

    def replace(table: Sparse, t: int) -> Sparse:
        keep = ~replaced[table.rows]
        return Sparse.build(
            np.concatenate([table.rows[keep], *rows[t]]),
            np.concatenate([table.cols[keep], *cols[t]]),
            np.concatenate([table.weights[keep], *weights[t]]),
            table.shape,
        )

    return replace(position, 0), replace(tangent_u, 1), replace(tangent_v, 2), no_plane


def limit_stencils(topo: Topology, position: Sparse, tangent_u: Sparse, tangent_v: Sparse,
                   ring, local, dart=None) -> LimitStencils:  # fmt: skip
    """[`LimitStencils`][] from the smooth-vertex stencils, the dart stencils
    (`dart_stencils`, if `dart` is given) and the sector stencils (`sector_stencils`);
    a boundary vertex with one exact sector also gets its two tangents as its
    `tangent_u`, `tangent_v` rows."""
    V = topo.num_vertices
    # An interior vertex of valence 2 has no tangent plane (nearby normals tend to
    # different limits along different rays), smooth or dart: its closed-form tangents
    # vanish or are rounding noise, so its normal is approximated like a sector's.
    no_plane = np.zeros(V, bool)
    no_plane[(topo.vertex_type == SMOOTH) & ~topo.boundary_vertex & (topo.valence == 2)] = True
    if dart is not None:
        position, tangent_u, tangent_v, inexact = dart_stencils(
            topo, position, tangent_u, tangent_v, ring, dart
        )
        no_plane[inexact] = True
    if np.any(no_plane):
        tangent_u, tangent_v = (
            Sparse.build(*(x[~no_plane[t.rows]] for x in (t.rows, t.cols, t.weights)), t.shape)
            for t in (tangent_u, tangent_v)
        )
    su, sv, vertex, kind, corner_points, corner_sector = sector_stencils(
        topo, position, ring, local, np.flatnonzero(no_plane)
    )
    per_vertex = np.bincount(vertex, minlength=V)
    single = np.flatnonzero((kind == EXACT) & (per_vertex[vertex] == 1))

    def merge(table: Sparse, sector_table: Sparse) -> Sparse:
        rows = sector_table.take_rows(single)
        return Sparse.build(
            np.concatenate([table.rows, vertex[single][rows.rows]]),
            np.concatenate([table.cols, rows.cols]),
            np.concatenate([table.weights, rows.weights]),
            table.shape,
        )

    return LimitStencils(
        position, merge(tangent_u, su), merge(tangent_v, sv), (topo.vertex_type == SMOOTH) & ~no_plane,
        su, sv, vertex, kind, corner_points, corner_sector,
    )  # fmt: skip


#: OpenSubdiv's names for how boundary vertices in a single face are treated
#: (`Sdc::Options::VtxBoundaryInterpolation`, without "none").
BOUNDARY_INTERPOLATION = ("edge_and_corner", "edge_only")


CREASE_METHODS = ("uniform", "chaikin")


def check_boundary_interpolation(scheme) -> None:
    """A `ValueError` naming the scheme and the values for an unknown
    `boundary_interpolation` or `crease_method`."""
    for name, allowed in (("boundary_interpolation", BOUNDARY_INTERPOLATION),
                          ("crease_method", CREASE_METHODS)):  # fmt: skip
        if getattr(scheme, name) not in allowed:
            raise ValueError(
                f"`{type(scheme).__name__}({name}=...)` must be "
                f"{' or '.join(map(repr, allowed))}, got {getattr(scheme, name)!r}."
            )
