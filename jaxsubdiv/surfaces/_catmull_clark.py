from typing import ClassVar, Literal

import equinox as eqx
import numpy as np

from ._base import (
    AbstractSurfaceScheme,
    Counts,
    Level,
    LimitStencils,
    check_boundary_interpolation,
    limit_stencils,
    refined_tags,
    ring_positions,
    vertex_rule,
)
from ._stencil import Sparse
from ._topology import SMOOTH, Topology, build_topology


def cc_sector_ring(topo: Topology, half: np.ndarray) -> np.ndarray:
    r"""`(n, 2k + 2)` ring columns of sectors of `k` quads: the vertex, its edge
    neighbors $e_0, \dots, e_k$ counter-clockwise ($e_0$, $e_k$ on the sharp edges),
    then the diagonal vertices $f_1, \dots, f_k$ of the quads."""
    nb = topo.origin[topo.next[half]]
    last = topo.origin[topo.prev[half[:, -1]]]
    diag = topo.origin[topo.next[topo.next[half]]]
    return np.concatenate([topo.origin[half[:, :1]], nb, last[:, None], diag], axis=1)


def cc_sector_matrix(k: int) -> tuple[np.ndarray, np.ndarray]:
    r"""Catmull-Clark's local subdivision matrix on the ring of a crease (or boundary)
    vertex sector of `k` quads, and the ring's mirror permutation: vertex
    $\frac34 v + \frac18(e_0 + e_k)$, sharp edge midpoints, smooth edges
    $\frac14(v + e_i + F_i + F_{i+1})$, face points $F_i$ (the rules of
    `CatmullClark.level`)."""
    m = 2 * k + 2
    face = np.zeros((k + 2, m))  # face point of quad i = 1..k: (v, e_{i-1}, f_i, e_i)
    for i in range(1, k + 1):
        face[i, [0, i, k + 1 + i, i + 1]] = 1 / 4
    S = np.zeros((m, m))
    S[0, [0, 1, k + 1]] = 3 / 4, 1 / 8, 1 / 8
    for i in (1, k + 1):
        S[i, [0, i]] = 1 / 2
    for i in range(1, k):
        S[1 + i, [0, 1 + i]] = 1 / 4
        S[1 + i] += (face[i] + face[i + 1]) / 4
    S[k + 2 :] = face[1 : k + 1]
    perm = np.concatenate([[0], np.arange(k + 1, 0, -1), np.arange(2 * k + 1, k + 1, -1)])
    return S, perm


def cc_dart_matrix(n: int) -> tuple[np.ndarray, np.ndarray]:
    r"""Catmull-Clark's local subdivision matrix on the ring $v, e_0, \dots, e_{n-1},
    f_1, \dots, f_n$ of a dart of valence $n$ on quads ($e_0$ on the crease edge,
    $f_i$ the diagonal of the quad between $e_{i-1}$ and $e_i$), and the mirror
    permutation: the smooth vertex rule, the midpoint on the crease edge, the smooth
    edge rule elsewhere, face points."""
    m = 2 * n + 1
    face = np.zeros((n + 1, m))
    for i in range(1, n + 1):
        face[i, [0, 1 + (i - 1) % n, n + i, 1 + i % n]] = 1 / 4
    S = np.zeros((m, m))
    S[0, 0] = (n - 2) / n
    S[0, 1 : n + 1] = 1 / n**2
    S[0] += face[1:].sum(axis=0) / n**2
    S[1, [0, 1]] = 1 / 2
    for i in range(1, n):
        S[1 + i, [0, 1 + i]] += 1 / 4
        S[1 + i] += (face[i] + face[i + 1]) / 4
    S[n + 1 :] = face[1:]
    perm = np.concatenate([[0], 1 + (-np.arange(n)) % n, n + 1 + (n - np.arange(1, n + 1))])
    return S, perm


def _face_rest(topo: Topology, half: np.ndarray, row: np.ndarray, weight: np.ndarray, skip: int,
               rows: list, cols: list, weights: list):  # fmt: skip
    """Append, for each half-edge `half[i]`, entries `(row[i], vertex, weight[i])` for
    the vertices `next^k` of its origin in its face, k = 2, ..., size - skip + 1: all
    but the origin and the next vertex (`skip=2`), and the previous one (`skip=3`)."""
    uniform = len(topo.sizes) and topo.sizes[0] == topo.sizes.min() == topo.sizes.max()
    # Faces of one size (every level after the first): no per-entry sizes to look up.
    size = topo.sizes[topo.face[half]] if not uniform else None
    largest = int(topo.sizes[0]) if uniform else int(size.max(initial=0))
    current = topo.next[topo.next[half]]
    for k in range(2, largest - skip + 2):
        # Walking the `next` pointers: one gather per step (all-quad meshes take one
        # or two steps), no per-entry index arithmetic.
        valid = slice(None) if uniform else size - skip + 2 > k
        if not uniform and valid.all():
            valid = slice(None)
        rows.append(row[valid])
        cols.append(topo.origin[current[valid]])
        weights.append(weight[valid])
        current = topo.next[current]
    return rows, cols, weights


class CatmullClark(AbstractSurfaceScheme):
    r"""Catmull-Clark subdivision (1978) for meshes of any polygons.

    Every $k$-gon is split into $k$ quads around a new *face point* (its centroid);
    *edge points* are $\frac14(a + b + f_0 + f_1)$ with $f_0, f_1$ the face points of
    the two faces on the edge; a smooth vertex of valence $n$ moves to
    $\frac{n-2}{n}v + \frac1{n^2}\sum_i e_i + \frac1{n^2}\sum_i f_i$ (the form in
    DeRose, Kass and Truong 1998; $e_i$ its edge neighbors, $f_i$ the face points
    around it). After one level every face is a quad. On a regular quad grid the limit
    is the bicubic tensor-product uniform B-spline ($C^2$); at extraordinary vertices
    it is $C^1$.

    Boundary edges and tagged creases follow the cubic B-spline curve rules (edge
    midpoint, vertex $\frac18 a + \frac34 v + \frac18 b$); corners (tagged, or a vertex
    on three or more sharp edges) are kept. A vertex on one crease (a *dart*) uses the
    smooth rule.

    Tags may be semi-sharp (`Mesh(..., crease_sharpness=..., corner_sharpness=...)`):
    the sharp rules last as many levels as the sharpness, and a fractional remainder
    blends them with the smooth ones, by OpenSubdiv's rules (DeRose, Kass and Truong
    1998; see `crease_method` and `docs/surfaces.md`).

    **Arguments:**

    - `boundary_interpolation`: what a boundary vertex in a single face does, by
      OpenSubdiv's names: `"edge_and_corner"` (default) keeps it as a corner;
      `"edge_only"` gives it the boundary curve's rule, like any boundary vertex.
    - `crease_method`: how semi-sharp creases (`Mesh(..., crease_sharpness=...)`)
      decay, by OpenSubdiv's names: `"uniform"` (default) lowers every sharpness by 1
      per level; `"chaikin"` gives each half of a crease edge 3/4 of its sharpness
      plus 1/4 of the mean of the other semi-sharp edges at its end, less 1, so that
      sharpness varying along a crease varies smoothly.

    The usual scheme for quad-dominant meshes (film, CAD). Refined vertex order: the
    $V$ vertex points, then one edge point per edge (lexicographic order of the
    sorted edge), then one face point per face.

    References: E. Catmull and J. Clark, "Recursively generated B-spline surfaces on
    arbitrary topological meshes", Computer-Aided Design 10 (1978); T. DeRose, M. Kass
    and T. Truong, "Subdivision surfaces in character animation", SIGGRAPH 1998.
    """

    boundary_interpolation: Literal["edge_and_corner", "edge_only"] = eqx.field(
        static=True, default="edge_and_corner"
    )
    crease_method: Literal["uniform", "chaikin"] = eqx.field(static=True, default="uniform")

    bytes_per_half_edge: ClassVar[int] = 400  # measured 360-440

    def __check_init__(self):
        check_boundary_interpolation(self)

    @property
    def boundary_corners(self) -> bool:
        return self.boundary_interpolation == "edge_and_corner"

    def refined_counts(self, c: Counts) -> Counts:
        # Exact: a vertex, edge and face point each; every k-gon becomes k quads.
        return Counts(
            c.vertices + c.edges + c.faces, 2 * c.edges + c.half_edges, c.half_edges,
            4 * c.half_edges, 2 * c.sharp, c.corner_ends, c.isolated,
        )  # fmt: skip

    def level(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> Level:
        topo = topology
        V, E, F = topo.num_vertices, topo.num_edges, topo.num_faces
        # The face points are centroids; they appear in the vertex and edge rules, whose
        # weights on the vertices are summed here in closed form (fewer entries than
        # expanding every face point, and no product with a centroid matrix).
        inv_size = 1 / topo.sizes[topo.face]  # per half-edge: 1 / size of its face
        # Crease and corner vertices: the curve rules (no face points); the smooth rows
        # are built below.
        rows, cols, weights = vertex_rule(topo, None, None, (3 / 4, 1 / 8), smooth=False)
        # Smooth vertices: (n - 2)/n v + 1/n^2 (sum of edge neighbours + face points).
        # Around v, outgoing half-edge h (in face f) leads to the edge neighbour dest(h),
        # which is also in twin(h)'s face; f's other vertices appear once.
        n = np.maximum(topo.valence.astype(np.float64), 1.0)
        out = np.flatnonzero(topo.vertex_type[topo.origin] == SMOOTH)
        v = topo.origin[out]
        scale = 1 / n[v] ** 2
        centre = np.flatnonzero(topo.vertex_type == SMOOTH)
        rows.append(centre)
        cols.append(centre)
        weights.append(((n - 2) / n)[centre] + np.bincount(v, scale * inv_size[out], V)[centre])
        rows.append(v)
        cols.append(topo.origin[topo.next[out]])
        weights.append(scale * (1 + inv_size[out] + inv_size[topo.twin[out]]))
        rows, cols, weights = _face_rest(topo, out, v, scale * inv_size[out], 3, rows, cols, weights)
        # Edge points: sharp edges the midpoint; smooth ones 1/4 (a + b + F0 + F1).
        sharp = topo.sharp_edge
        e = np.arange(E)
        h0 = topo.edge_half
        h1 = np.where(sharp, h0, topo.twin[h0])
        end = np.where(sharp, 1 / 2, (1 + inv_size[h0] + inv_size[h1]) / 4)
        rows += [V + e, V + e]
        cols += [topo.edges[:, 0], topo.edges[:, 1]]
        weights += [end, end]
        for half in (h0[~sharp], h1[~sharp]):
            rows, cols, weights = _face_rest(topo, half, V + topo.edge[half], inv_size[half] / 4, 2,
                                             rows, cols, weights)  # fmt: skip
        # Face points: centroids.
        rows.append(V + E + topo.face)
        cols.append(topo.origin)
        weights.append(inv_size)
        stencil = Sparse.blocks(rows, cols, weights, (V + E + F, V))
        # One quad per half-edge h: its origin, its edge point, its face point and the
        # previous half-edge's edge point (columns written in place: no stacked copies).
        faces = np.empty((topo.num_half_edges, 4), np.int64)
        faces[:, 0] = topo.origin
        np.add(topo.edge, V, out=faces[:, 1])
        np.add(topo.face, V + E, out=faces[:, 2])
        faces[:, 3] = faces[topo.prev, 1]
        new_creases, new_corners = refined_tags(topo, corners, V)
        return Level(stencil, faces, new_creases, new_corners)

    def limit(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> LimitStencils:
        r"""Limit stencils of Halstead, Kass and DeRose (1993).

        On an all-quad mesh, a smooth vertex of valence $n$ with edge neighbors $e_i$
        and diagonal neighbors $f_i$ (ordered counter-clockwise) has limit position
        $(n^2 v + 4\sum_i e_i + \sum_i f_i) / (n(n + 5))$ and tangents
        $\sum_i A_n\cos\frac{2\pi i}{n} e_i + (\cos\frac{2\pi i}{n} +
        \cos\frac{2\pi(i+1)}{n}) f_i$ (and the same with $\sin$), where
        $A_n = 1 + \cos\frac{2\pi}{n} + \cos\frac{\pi}{n}\sqrt{2(9 + \cos\frac{2\pi}{n})}$.
        Crease vertices: $\frac16 a + \frac23 v + \frac16 b$; corners: $v$. A mesh with
        non-quad faces is refined once first (vertex $v$ keeps its index) and the
        stencils composed with that level.

        Tangents at boundary, crease and corner vertices, one pair per sector (the faces
        between two sharp edges): the crease tangent and the cross tangent from the
        eigenvectors of the sector's local subdivision matrix where it has a tangent
        plane, the two crease tangents at corners (see `sector_stencils` and
        `docs/surfaces.md`). Darts: position and tangents from the eigenvectors of the
        dart's local subdivision matrix (`dart_stencils`).

        Reference: M. Halstead, M. Kass and T. DeRose, "Efficient, fair interpolation
        using Catmull-Clark surfaces", SIGGRAPH 1993, eqs. (4)-(5) and Appendix A.
        """
        topo = topology
        V = topo.num_vertices
        if np.any(topo.sizes != 4):
            first = self.level(topo, creases, corners)
            fine = build_topology(first.faces, first.stencil.shape[0], first.creases,
                                  first.corners, self.boundary_corners, validate=False)
            stencils = self.limit(fine, first.creases, first.corners)
            return stencils.compose(np.arange(V), first.stencil)
        n = topo.valence.astype(np.float64)
        safe = np.maximum(n, 1.0)
        rows, cols, weights = vertex_rule(
            topo, n / (safe + 5), 4 / (safe * (safe + 5)), (2 / 3, 1 / 6)
        )
        smooth = topo.vertex_type[topo.origin] == SMOOTH
        hs = np.flatnonzero(smooth)
        rows.append(topo.origin[hs])
        cols.append(topo.origin[topo.next[topo.next[hs]]])
        weights.append(1 / (n[topo.origin[hs]] * (n[topo.origin[hs]] + 5)))
        position = Sparse.build(np.concatenate(rows), np.concatenate(cols), np.concatenate(weights), (V, V))
        h, rank, valence = ring_positions(topo)
        theta = 2 * np.pi / valence
        a_n = 1 + np.cos(theta) + np.cos(theta / 2) * np.sqrt(2 * (9 + np.cos(theta)))
        v = topo.origin[h]
        edge_nb = topo.origin[topo.next[h]]
        diag_nb = topo.origin[topo.next[topo.next[h]]]
        tables = []
        for trig in (np.cos, np.sin):
            w_edge = a_n * trig(theta * rank)
            w_diag = trig(theta * rank) + trig(theta * (rank + 1))
            tables.append(
                Sparse.build(
                    np.concatenate([v, v]),
                    np.concatenate([edge_nb, diag_nb]),
                    np.concatenate([w_edge, w_diag]),
                    (V, V),
                )
            )
        return limit_stencils(
            topo, position, *tables, cc_sector_ring, cc_sector_matrix, cc_dart_matrix
        )
