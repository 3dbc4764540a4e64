from typing import ClassVar, Literal

import equinox as eqx
import numpy as np

from ._base import (
    AbstractSurfaceScheme,
    Counts,
    Level,
    LimitStencils,
    check_boundary_interpolation,
    edge_end_rule,
    limit_stencils,
    refined_tags,
    ring_positions,
    vertex_rule,
)
from ._stencil import Sparse
from ._topology import Topology


def loop_beta(n: np.ndarray) -> np.ndarray:
    r"""Loop's vertex weight $\beta(n) = \frac1n\left(\frac58 - (\frac38 + \frac14\cos\frac{2\pi}{n})^2\right)$."""
    n = np.maximum(np.asarray(n, np.float64), 1.0)
    return (5 / 8 - (3 / 8 + np.cos(2 * np.pi / n) / 4) ** 2) / n


def loop_sector_ring(topo: Topology, half: np.ndarray) -> np.ndarray:
    r"""`(n, k + 2)` ring columns of sectors of `k` triangles: the vertex, then its
    neighbors $p_0, \dots, p_k$ in counter-clockwise order ($p_0$, $p_k$ on the sharp
    edges)."""
    nb = topo.origin[topo.next[half]]
    last = topo.origin[topo.prev[half[:, -1]]]
    return np.concatenate([topo.origin[half[:, :1]], nb, last[:, None]], axis=1)


def loop_sector_matrix(k: int) -> tuple[np.ndarray, np.ndarray]:
    r"""Loop's local subdivision matrix on the ring of a crease (or boundary) vertex
    sector of `k` triangles, and the ring's mirror permutation: vertex $\frac34 v +
    \frac18(p_0 + p_k)$, sharp edges midpoints, smooth edges $\frac38(v + p_i) +
    \frac18(p_{i-1} + p_{i+1})$ (the rules of `Loop.level`)."""
    S = np.zeros((k + 2, k + 2))
    S[0, [0, 1, k + 1]] = 3 / 4, 1 / 8, 1 / 8
    for i in (1, k + 1):
        S[i, [0, i]] = 1 / 2
    for i in range(2, k + 1):
        S[i, [0, i]] = 3 / 8
        S[i, [i - 1, i + 1]] = 1 / 8
    perm = np.concatenate([[0], np.arange(k + 1, 0, -1)])
    return S, perm


def loop_dart_matrix(n: int) -> tuple[np.ndarray, np.ndarray]:
    r"""Loop's local subdivision matrix on the 1-ring $v, p_0, \dots, p_{n-1}$ of a dart
    of valence $n$ ($p_0$ on the crease edge), and the mirror permutation: the smooth
    vertex rule, the midpoint on the crease edge, the smooth edge rule elsewhere."""
    S = np.zeros((n + 1, n + 1))
    beta = float(loop_beta(n))
    S[0, 0], S[0, 1:] = 1 - n * beta, beta
    S[1, [0, 1]] = 1 / 2
    for i in range(1, n):
        S[1 + i, [0, 1 + i]] = 3 / 8
        S[1 + i, 1 + (i - 1) % n] += 1 / 8
        S[1 + i, 1 + (i + 1) % n] += 1 / 8
    return S, np.concatenate([[0], 1 + (-np.arange(n)) % n])


class Loop(AbstractSurfaceScheme):
    r"""Loop subdivision (Loop 1987) for triangle meshes: the quartic box spline.

    Each triangle is split into four. New *edge points* are $\frac38(a + b) +
    \frac18(c + d)$ for an edge $(a, b)$ with opposite vertices $c, d$; a smooth vertex
    of valence $n$ moves to $(1 - n\beta)v + \beta\sum_i p_i$ with
    $\beta(n) = \frac1n\left(\frac58 - (\frac38 + \frac14\cos\frac{2\pi}n)^2\right)$.
    On a regular (valence-6) region the limit is the three-direction quartic box
    spline: $C^2$; at extraordinary vertices it is $C^1$.

    Boundary edges and tagged creases follow the cubic B-spline curve rules (edge
    midpoint, vertex $\frac18 a + \frac34 v + \frac18 b$; Hoppe et al. 1994); corners
    (tagged, or a vertex on three or more sharp edges) are kept. A vertex on one crease
    (a *dart*) uses the smooth rule.

    Tags may be semi-sharp (`Mesh(..., crease_sharpness=..., corner_sharpness=...)`):
    the sharp rules last as many levels as the sharpness, and a fractional remainder
    blends them with the smooth ones, by OpenSubdiv's rules (DeRose, Kass and Truong
    1998; see `crease_method` and `docs/surfaces.md`).

    **Arguments:**

    - `boundary_interpolation`: what a boundary vertex in a single triangle does, by
      OpenSubdiv's names: `"edge_and_corner"` (default) keeps it as a corner;
      `"edge_only"` gives it the boundary curve's rule, like any boundary vertex (as
      trimesh's Loop does).
    - `crease_method`: how semi-sharp creases (`Mesh(..., crease_sharpness=...)`)
      decay, by OpenSubdiv's names: `"uniform"` (default) lowers every sharpness by 1
      per level; `"chaikin"` gives each half of a crease edge 3/4 of its sharpness
      plus 1/4 of the mean of the other semi-sharp edges at its end, less 1, so that
      sharpness varying along a crease varies smoothly.

    Use it for triangle meshes; for quads or mixed polygons use
    [`jaxsubdiv.surfaces.CatmullClark`][].

    Refined vertex order: the $V$ vertex points (same order as the input), then one
    edge point per edge in lexicographic order of the sorted edge (see `Mesh.edges`).

    References: C. Loop, "Smooth subdivision surfaces based on triangles", MS thesis,
    University of Utah, 1987; H. Hoppe et al., "Piecewise smooth surface
    reconstruction", SIGGRAPH 1994.
    """

    boundary_interpolation: Literal["edge_and_corner", "edge_only"] = eqx.field(
        static=True, default="edge_and_corner"
    )
    crease_method: Literal["uniform", "chaikin"] = eqx.field(static=True, default="uniform")

    bytes_per_half_edge: ClassVar[int] = 200  # measured 120-180

    def __check_init__(self):
        check_boundary_interpolation(self)

    @property
    def boundary_corners(self) -> bool:
        return self.boundary_interpolation == "edge_and_corner"

    def refined_counts(self, c: Counts) -> Counts:
        # Exact for triangles: an edge point per edge, four triangles per triangle.
        return Counts(
            c.vertices + c.edges, 2 * c.edges + 3 * c.faces, 4 * c.faces, 4 * c.half_edges,
            2 * c.sharp, c.corner_ends, c.isolated,
        )  # fmt: skip

    def level(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> Level:
        topo = topology
        if np.any(topo.sizes != 3):
            f = int(np.argmax(topo.sizes != 3))
            raise ValueError(
                f"Loop subdivision needs a triangle mesh, but face {f} has "
                f"{int(topo.sizes[f])} vertices. Triangulate the mesh, or use "
                "`CatmullClark()` or `DooSabin()`, which take any polygons."
            )
        V, E = topo.num_vertices, topo.num_edges
        n = topo.valence.astype(np.float64)
        beta = loop_beta(n)
        rows, cols, weights = vertex_rule(topo, 1 - n * beta, beta, (3 / 4, 1 / 8))
        # Edge points: sharp edges take the midpoint, smooth ones 3/8 and 1/8.
        edge_rows, edge_cols, edge_weights = edge_end_rule(topo, 3 / 8)
        rows += edge_rows
        cols += edge_cols
        weights += edge_weights
        h = np.flatnonzero(~topo.sharp_edge[topo.edge])
        rows.append(V + topo.edge[h])
        cols.append(topo.origin[topo.prev[h]])  # the vertex opposite the edge
        weights.append(np.full(len(h), 1 / 8))
        stencil = Sparse.blocks(rows, cols, weights, (V + E, V))
        # Four triangles per triangle, orientation kept: with the corners p0, p1, p2
        # (half-edges 3f, 3f + 1, 3f + 2 run p0 -> p1 -> p2) and the edge points m0, m1,
        # m2 of those half-edges, (p0, m0, m2), (p1, m1, m0), (p2, m2, m1), (m0, m1, m2).
        # One `np.take` from the six columns: a third of the time of nested stacks or of
        # fancy indexing (the strided writes dominate).
        corners_and_mids = np.empty((topo.num_faces, 6), np.int64)
        corners_and_mids[:, :3] = topo.origin.reshape(-1, 3)
        np.add(topo.edge.reshape(-1, 3), V, out=corners_and_mids[:, 3:])
        faces = np.take(corners_and_mids, [0, 3, 5, 1, 4, 3, 2, 5, 4, 3, 4, 5], axis=1).reshape(-1, 3)
        new_creases, new_corners = refined_tags(topo, corners, V)
        return Level(stencil, faces, new_creases, new_corners)

    def limit(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> LimitStencils:
        r"""Limit stencils from the eigenvectors of Loop's local subdivision matrix.

        Position at a smooth vertex: $(1 - n\chi)v + \chi\sum_i p_i$ with
        $\chi = 1/(\frac{3}{8\beta} + n)$; tangents $\sum_i \cos\frac{2\pi i}{n} p_i$ and
        $\sum_i \sin\frac{2\pi i}{n} p_i$ over the ordered ring (Loop 1987; Hoppe et al.
        1994). Crease vertices: the cubic B-spline curve limit $\frac16 a + \frac23 v
        + \frac16 b$; corners: $v$.

        Tangents at boundary, crease and corner vertices, one pair per sector (the faces
        between two sharp edges): the crease tangent and the cross tangent from the
        eigenvectors of the sector's local subdivision matrix where it has a tangent
        plane, the two crease tangents at corners (see `sector_stencils` and
        `docs/surfaces.md`). Darts: position and tangents from the eigenvectors of the
        dart's local subdivision matrix (`dart_stencils`).
        """
        topo = topology
        V = topo.num_vertices
        n = topo.valence.astype(np.float64)
        chi = 1 / (3 / (8 * loop_beta(n)) + np.maximum(n, 1))
        rows, cols, weights = vertex_rule(topo, 1 - n * chi, chi, (2 / 3, 1 / 6))
        position = Sparse.build(np.concatenate(rows), np.concatenate(cols), np.concatenate(weights), (V, V))
        h, rank, valence = ring_positions(topo)
        angle = 2 * np.pi * rank / valence
        neighbor = topo.origin[topo.next[h]]
        tu = Sparse.build(topo.origin[h], neighbor, np.cos(angle), (V, V))
        tv = Sparse.build(topo.origin[h], neighbor, np.sin(angle), (V, V))
        return limit_stencils(
            topo, position, tu, tv, loop_sector_ring, loop_sector_matrix, loop_dart_matrix
        )
