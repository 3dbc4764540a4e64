"""Semi-sharp creases and corners: OpenSubdiv's rules for one level of a primal scheme.

A tag of sharpness s in (0, 10) keeps the sharp rules while it lasts and decays every
level; where a sharpness drops to zero the rule of a vertex changes, and the level
blends the two rules. The rules (DeRose, Kass and Truong, "Subdivision surfaces in
character animation", SIGGRAPH 1998, section 3; OpenSubdiv's `Sdc::Crease` and
`Sdc::Scheme`, whose definitions these follow):

- **Child sharpness.** Uniform method: `s - 1`, or 0 once `s <= 1`; the two halves of
  an edge keep one value. Chaikin method: the half of an edge at vertex v gets
  `(3/4 s + 1/4 mean of the other semi-sharp edges at v) - 1` (0 if not positive)
  when v has two or more semi-sharp edges, else `s - 1`. Vertex sharpness decays by 1.
  Infinite values (10 or more) stay infinite.
- **Edge points.** Sharpness 1 or more: the crease rule (midpoint). Between 0 and 1
  the child is smooth (Uniform; Chaikin unless both child halves stay sharp), and the
  edge point is `s * crease + (1 - s) * smooth`.
- **Vertex points.** The parent's rule (from its sharp edges, counting those with s >
  0, and its own sharpness: corner, crease, or smooth for none or one sharp edge) and
  the child's rule (the same from the child values). A smooth parent, or one whose
  rule the child keeps, uses its rule. Otherwise the point is `w * parent + (1 - w) *
  child` with `w` the mean sharpness of the parent tags that decay to zero in this
  level (the vertex's own included), capped at 1.

Each level builds the scheme's stencil twice: once with the parent's sharp set and
rules (`A`), once with the child's (`B`), and blends row by row with those weights, so
the schemes' own rules are used unchanged. New vertex `V + e` is edge `e`'s point
(both Loop and Catmull-Clark number them so), which gives the refined tags.
"""

import dataclasses

import numpy as np

from ._base import AbstractSurfaceScheme, Level
from ._stencil import Sparse
from ._topology import CORNER, CREASE, SMOOTH, Topology


def decrement(sharpness: np.ndarray) -> np.ndarray:
    """Uniform decay: `s - 1`, 0 once `s <= 1`, infinite stays infinite."""
    return np.where(sharpness > 1, sharpness - 1, 0.0)


def child_edge_sharpness(topo: Topology, sharpness: np.ndarray, method: str) -> np.ndarray:
    """`(E, 2)` sharpness of each edge's two halves, at `edges[:, 0]` and `edges[:, 1]`."""
    uniform = decrement(sharpness)
    if method == "uniform":
        return np.stack([uniform, uniform], 1)
    V = topo.num_vertices
    semi = np.isfinite(sharpness) & (sharpness > 0)
    ends = topo.edges.T  # (2, E)
    count = sum(np.bincount(end[semi], minlength=V) for end in ends)
    total = sum(np.bincount(end[semi], weights=sharpness[semi], minlength=V) for end in ends)
    halves = []
    for end in ends:
        others = count[end] - 1
        mean_other = (total[end] - np.where(semi, sharpness, 0)) / np.maximum(others, 1)
        chaikin = np.maximum(0.75 * sharpness + 0.25 * mean_other - 1, 0.0)
        # Chaikin only where the vertex has another semi-sharp edge (OpenSubdiv
        # decrements uniformly otherwise).
        use = semi & (others >= 1)
        halves.append(np.where(use, chaikin, uniform))
    return np.stack(halves, 1)


def _vertex_rules(topo: Topology, sharp_ends: np.ndarray, corner: np.ndarray) -> np.ndarray:
    """SMOOTH (no or one sharp edge: smooth or dart), CREASE (two) or CORNER (more, or
    `corner`) for every vertex, counting each edge at each end where `sharp_ends` says."""
    V = topo.num_vertices
    count = sum(np.bincount(topo.edges[:, i], weights=sharp_ends[:, i], minlength=V) for i in (0, 1))
    rules = np.where(count == 2, CREASE, np.where(count > 2, CORNER, SMOOTH)).astype(np.int8)
    rules[corner] = CORNER
    return rules


def semi_sharp_level(
    scheme: AbstractSurfaceScheme,
    parent: Topology,
    creases: np.ndarray,
    crease_sharpness: np.ndarray,
    corners: np.ndarray,
    corner_sharpness: np.ndarray,
) -> Level:
    """One level of `scheme` (Loop or Catmull-Clark) with semi-sharp tags (see the
    module docstring) on the topology `parent`, built with every tag sharp; tags of
    the refined mesh carry their decayed sharpness.

    The child rules' stencil is built for the whole level, not only for the rows that
    blend: simpler, and at most doubles the level's host cost (measured on a torus of
    8,192 quads, 3 levels, one semi-sharp edge: 0.89 s against 0.46 s)."""
    method = scheme.crease_method
    V, E = parent.num_vertices, parent.num_edges
    edge_sharpness = np.zeros(E)
    edge_sharpness[parent.edge_ids(creases, "creases")] = crease_sharpness
    edge_sharpness[parent.boundary_edge] = np.inf
    vertex_sharpness = np.zeros(V)
    vertex_sharpness[np.asarray(corners, np.int64)] = corner_sharpness
    child_edges = child_edge_sharpness(parent, edge_sharpness, method)
    child_vertices = decrement(vertex_sharpness)
    parent_level = scheme.level(parent, creases, corners)

    # Edge points: the crease rule from sharpness 1 (or both halves still sharp), a
    # blend below.
    full = (edge_sharpness >= 1) | (edge_sharpness <= 0) | np.all(child_edges > 0, axis=1)
    edge_weight = np.where(full, 1.0, edge_sharpness)

    # Vertex points: the child's rule, and the blend weight where it differs.
    nfaces = np.bincount(parent.origin, minlength=V)
    fixed = parent.valence == 0
    if scheme.boundary_corners:
        fixed |= parent.boundary_vertex & (nfaces == 1)
    child_rules = _vertex_rules(parent, child_edges > 0, fixed | (child_vertices > 0))
    parent_rules = parent.vertex_type
    decays = (vertex_sharpness > 0) & (child_vertices <= 0)
    total = np.where(decays, vertex_sharpness, 0.0)
    count = decays.astype(np.float64)
    for i in (0, 1):
        gone = (edge_sharpness > 0) & (
            (edge_sharpness <= 1) if method == "uniform" else (child_edges[:, i] <= 0)
        )
        total += np.bincount(parent.edges[gone, i], weights=edge_sharpness[gone], minlength=V)
        count += np.bincount(parent.edges[gone, i], minlength=V)
    fraction = np.minimum(total / np.maximum(count, 1), 1.0)
    keep = (parent_rules == SMOOTH) | (parent_rules == child_rules)
    vertex_weight = np.where(keep, 1.0, fraction)

    rows = parent_level.stencil.shape[0]
    weight = np.ones(rows)
    weight[:V] = vertex_weight
    weight[V : V + E] = edge_weight
    stencil = parent_level.stencil
    if np.any(weight < 1):
        child = dataclasses.replace(
            parent,
            sharp_edge=np.all(child_edges > 0, axis=1),
            vertex_type=child_rules,
            crease_end=child_edges > 0,
        )
        child_level = scheme.level(child, creases, corners)
        a, b = stencil, child_level.stencil
        stencil = Sparse.build(
            np.concatenate([a.rows, b.rows]),
            np.concatenate([a.cols, b.cols]),
            np.concatenate([a.weights * weight[a.rows], b.weights * (1 - weight[b.rows])]),
            a.shape,
        )

    # Tags of the refined mesh: each half of a tagged edge with its child sharpness
    # (edge e's point is new vertex V + e), each corner with its decayed sharpness.
    tagged = np.flatnonzero((edge_sharpness > 0) & ~parent.boundary_edge)
    mid = V + tagged
    pairs = np.concatenate([np.stack([parent.edges[tagged, 0], mid], 1),
                            np.stack([mid, parent.edges[tagged, 1]], 1)])  # fmt: skip
    values = np.concatenate([child_edges[tagged, 0], child_edges[tagged, 1]])
    alive = values > 0
    corners = np.asarray(corners, np.int64)
    corner_alive = child_vertices[corners] > 0
    return Level(
        stencil,
        parent_level.faces,
        np.sort(pairs[alive], axis=1),
        corners[corner_alive],
        values[alive],
        child_vertices[corners][corner_alive],
    )
