"""The limit surface anywhere: position and derivatives at (face, u, v), as stencil tables.

Catmull-Clark's limit over a quad whose corners are regular is the bicubic uniform
B-spline patch of the 16 vertices around it; sharp sides (boundary or crease edges) and
corners are the same patch with phantom points mirrored across the side (the tensor
product of the cubic B-spline end rule), which reproduces the crease and corner rules
exactly. Loop's limit over a triangle whose corners are smooth, interior and of
valence 6 is the quartic three-direction box spline of its 12 surrounding vertices, and
over a triangle with one sharp side between regular boundary or crease vertices the same
patch with three parallelogram phantoms. Everywhere else the face is refined: the
sub-face containing the point is regular after a few levels unless the point is an
irregular vertex itself (an extraordinary vertex, a dart, a crease end, a corner).
Refinement is local: a
sub-face's limit depends only on its 1-ring (the faces sharing a vertex with it), so
each level refines the disjoint union of the 1-rings of the sub-faces still holding
points, one vectorized numpy level for all of them. This is the evaluation OpenSubdiv's
patch tables make (adaptive refinement to regular patches); every point becomes a row
of weights on the base vertices, so evaluation is one stencil kernel, differentiable and
batched.

References: J. Stam, "Exact evaluation of Catmull-Clark subdivision surfaces at
arbitrary parameter values" and "Evaluation of Loop subdivision surfaces", SIGGRAPH
1998 (the same limits, reached here by refinement instead of the eigenbasis);
OpenSubdiv's `Far::PatchTable` documentation (phantom points for boundary patches).
"""

import dataclasses
import functools
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .._misc import DEFAULT_MEMORY_BUDGET, as_float_array, checked_budget, static_int
from ._base import AbstractSurfaceScheme
from ._catmull_clark import CatmullClark
from ._local import Patches, _one_rings, refine_patches
from ._loop import Loop
from ._mesh import Mesh
from ._refine import _check, _check_surface_memory, _safe_normalize
from ._stencil import Sparse, StencilTable
from ._topology import CORNER, CREASE, SMOOTH, Topology, build_topology, flatten_faces


# Rows of the local weights: position, then d/du, d/dv, d2/du2, d2/dudv, d2/dv2.
_KINDS = 6

# The quadrant a point of a quad falls in is the child face at that corner; its own
# (u, v) are `Q @ (u, v) + b` (the child's origin is the parent's corner, its u axis
# runs to the midpoint of the corner's outgoing edge; see `CatmullClark.level`).
_QUADRANT_MAP = np.array(
    [[[2, 0], [0, 2]], [[0, 2], [-2, 0]], [[-2, 0], [0, -2]], [[0, -2], [2, 0]]], np.float64
)
_QUADRANT_SHIFT = np.array([[0, 0], [0, 2], [2, 2], [2, 0]], np.float64)

#: Default number of levels a face is refined towards a point before the point, then
#: within 2^-16 of the face's size of an irregular vertex, is evaluated by the bilinear
#: (Loop: linear) interpolation of the limit positions of the last sub-face's corners.
DEFAULT_MAX_DEPTH = 16


def _cubic_basis(t: np.ndarray) -> np.ndarray:
    """`(3, 4, n)`: the uniform cubic B-spline basis on the span between its 2nd and 3rd
    control points, and its first and second derivatives, at `t` in [0, 1]."""
    s = 1 - t
    return np.stack([
        np.stack([s**3, 3 * t**3 - 6 * t**2 + 4, -3 * t**3 + 3 * t**2 + 3 * t + 1, t**3]) / 6,
        np.stack([-(s**2) / 2, 1.5 * t**2 - 2 * t, -1.5 * t**2 + t + 0.5, t**2 / 2]),
        np.stack([s, 3 * t - 2, 1 - 3 * t, t]),
    ])  # fmt: skip


def _mirror(basis: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The basis with the first (`low`) or last (`high`) control point a phantom
    `2 p_1 - p_2` (`2 p_2 - p_1`): the cubic B-spline end rule on a sharp side."""
    b = basis.copy()
    b[:, 1] += np.where(low, 2 * b[:, 0], 0) - np.where(high, b[:, 3], 0)
    b[:, 2] += np.where(high, 2 * b[:, 3], 0) - np.where(low, b[:, 0], 0)
    b[:, 0] = np.where(low, 0, b[:, 0])
    b[:, 3] = np.where(high, 0, b[:, 3])
    return b


def _to_face_frame(local: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """Local weights `(n, 6, K)` (position, derivatives in the sub-face's (u, v)) to the
    query face's (u, v), given `jac` `(n, 2, 2)` = d(local)/d(face)."""
    out = local.copy()
    grad = local[:, 1:3]  # (n, 2, K)
    out[:, 1:3] = np.einsum("nba,nbk->nak", jac, grad)
    hess = np.stack([local[:, [3, 4]], local[:, [4, 5]]], axis=1)  # (n, 2, 2, K)
    hess = np.einsum("nba,nbdk,ndc->nack", jac, hess, jac)
    out[:, 3], out[:, 4], out[:, 5] = hess[:, 0, 0], hess[:, 0, 1], hess[:, 1, 1]
    return out


def _irregular_vertices(p: Patches) -> np.ndarray:
    """Vertices on a semi-sharp edge or with a semi-sharp corner tag: their rules
    blend or change with the level, so no fixed patch describes them."""
    mark = np.zeros(p.count, bool)
    if len(p.creases):
        mark[p.creases[np.isfinite(p.crease_sharpness)].reshape(-1)] = True
    if len(p.corners):
        mark[p.corners[np.isfinite(p.corner_sharpness)]] = True
    return mark


def _quad_patches(topo: Topology, irregular: np.ndarray, faces: np.ndarray):
    """Which of `faces` are regular patches, their `(n, 16)` control vertices (row j,
    column i: the point at u-index i, v-index j; corners at (1,1), (2,1), (2,2), (1,2))
    and `(n, 4)` sharp sides (side i runs from corner i to corner i + 1).

    A corner is regular when its two sides are smooth and it is a smooth interior
    vertex of valence 4 in four quads with no sharp edge (no dart); when exactly one
    side is sharp and it is a crease vertex whose sector holds this face and one more
    quad; or when both sides are sharp and it is a corner."""
    quad = topo.sizes[faces] == 4
    h = topo.offsets[faces][:, None] + np.where(quad[:, None], np.arange(4), 0)
    corner = topo.origin[h]
    side = topo.sharp_edge[topo.edge[h]]
    before = np.roll(side, 1, axis=1)
    vtype = topo.vertex_type[corner]
    V = topo.num_vertices
    nsharp = np.bincount(topo.edges[topo.sharp_edge].reshape(-1), minlength=V)
    in_quads = np.ones(V, bool)
    np.logical_and.at(in_quads, topo.origin, topo.sizes[topo.face] == 4)
    smooth = (
        (vtype == SMOOTH) & ~topo.boundary_vertex[corner] & (topo.valence[corner] == 4)
        & (nsharp[corner] == 0) & in_quads[corner]
    )  # fmt: skip
    # One sharp side: the quad across the other side must close the sector.
    twin_next = np.where(side, -1, topo.twin[h])  # across the outgoing side, if smooth
    twin_prev = np.where(before, -1, topo.twin[topo.prev[h]])
    safe_next, safe_prev = np.maximum(twin_next, 0), np.maximum(twin_prev, 0)
    closes_next = topo.sharp_edge[topo.edge[topo.next[safe_next]]] & (
        topo.sizes[topo.face[safe_next]] == 4
    )
    closes_prev = topo.sharp_edge[topo.edge[topo.prev[safe_prev]]] & (
        topo.sizes[topo.face[safe_prev]] == 4
    )
    crease = (vtype == CREASE) & np.where(side, closes_prev, closes_next)
    ok_corner = np.where(
        side & before, vtype == CORNER, np.where(side | before, crease, smooth)
    ) & ~irregular[corner]
    ok = quad & np.all(ok_corner, axis=1)

    grid = np.repeat(corner[:, :1], 16, axis=1)
    grid[:, [5, 6, 10, 9]] = corner
    across = np.maximum(topo.twin[h], 0)
    near = topo.origin[topo.next[topo.next[across]]]  # next to corner i, across side i
    far = topo.origin[topo.prev[across]]  # next to corner i + 1, across side i
    diagonal = topo.origin[topo.prev[np.maximum(topo.twin[topo.next[across]], 0)]]
    near_slot, far_slot = [4 * 0 + 1, 4 * 1 + 3, 4 * 3 + 2, 4 * 2 + 0], [2, 11, 13, 4]
    diagonal_slot = [0, 3, 15, 12]
    for i in range(4):
        grid[:, near_slot[i]] = np.where(side[:, i], grid[:, near_slot[i]], near[:, i])
        grid[:, far_slot[i]] = np.where(side[:, i], grid[:, far_slot[i]], far[:, i])
        both_smooth = ~side[:, i] & ~before[:, i]
        grid[:, diagonal_slot[i]] = np.where(both_smooth, diagonal[:, i], grid[:, diagonal_slot[i]])
    return ok, np.where(ok[:, None], grid, 0), side & ok[:, None]


def _bicubic_weights(sides: np.ndarray, uv: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """`(n, 6, 16)` weights of a regular patch's control points for the position and
    derivatives at local `uv`, in the query face's frame."""
    bu = _mirror(_cubic_basis(uv[:, 0]), sides[:, 3], sides[:, 1])  # (3, 4, n)
    bv = _mirror(_cubic_basis(uv[:, 1]), sides[:, 0], sides[:, 2])
    orders = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]
    local = np.stack([np.einsum("in,jn->nji", bu[a], bv[b]).reshape(-1, 16)
                      for a, b in orders], axis=1)  # fmt: skip
    return _to_face_frame(local, jac)


def _bilinear_weights(uv: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """`(n, 6, 4)` weights of the four corners' limit points: the bilinear patch's
    position at `uv`, and its derivatives at the sub-face's centre (secants over the
    sub-face: at the corner itself the two edges can be parallel, at an interior
    vertex of valence 2)."""
    u, v = uv[:, 0], uv[:, 1]
    n = len(u)
    local = np.zeros((n, _KINDS, 4))
    local[:, 0] = np.stack([(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v], 1)
    local[:, 1] = [-0.5, 0.5, 0.5, -0.5]
    local[:, 2] = [-0.5, -0.5, 0.5, 0.5]
    local[:, 4] = [1.0, -1.0, 1.0, -1.0]
    return _to_face_frame(local, jac)


def _linear_weights(uv: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """`(n, 6, 3)` weights of a triangle's three corners' limit points: the linear
    patch (its constant derivatives are the secants over the sub-face)."""
    u, v = uv[:, 0], uv[:, 1]
    local = np.zeros((len(u), _KINDS, 3))
    local[:, 0] = np.stack([1 - u - v, u, v], 1)
    local[:, 1] = [-1.0, 1.0, 0.0]
    local[:, 2] = [-1.0, 0.0, 1.0]
    return _to_face_frame(local, jac)


def _triangle_patches(topo: Topology, irregular: np.ndarray, faces: np.ndarray):
    """Which of `faces` are regular Loop patches, their 12 control vertices (the
    corners `c_j`, the vertex `o_j` across each side `j` (from `c_j` to `c_j+1`), then
    two more around each corner, `x2_j`, `x3_j`, counter-clockwise) and the sharp side
    of each (-1: none).

    Regular: three smooth interior corners of valence 6 with no sharp edge (the quartic
    box spline); or one sharp side (boundary or crease) whose two corners are crease
    vertices with three triangles on this side, the third corner as before. The three
    points beyond a sharp side are phantoms, parallelograms of points on this side
    (`o_j = c_j + c_j+1 - c_j+2`, ...): the interior rules on them give the boundary
    curve's rules (the vertex's 1/8, 3/4, 1/8 and the midpoint), as in OpenSubdiv's
    boundary patches."""
    h = topo.offsets[faces][:, None] + np.arange(3)
    corner = topo.origin[h]
    V = topo.num_vertices
    sharp = topo.sharp_edge
    nsharp = np.bincount(topo.edges[sharp].reshape(-1), minlength=V)
    vtype = topo.vertex_type[corner]
    side = sharp[topo.edge[h]]  # side j runs from corner j to corner j + 1
    before = np.roll(side, 1, axis=1)

    def turn(g):  # the next outgoing half-edge counter-clockwise around its origin
        return topo.twin[topo.prev[g]]

    def back(g):  # the next one clockwise
        return topo.next[np.maximum(topo.twin[g], 0)]

    ccw = turn(turn(h).clip(0)).clip(0)  # c_j -> o_j+2, past side j - 1
    cw1 = back(h)  # c_j -> o_j, past side j
    cw2 = back(cw1)  # c_j -> x3_j
    smooth = (
        (vtype == SMOOTH) & ~topo.boundary_vertex[corner] & (topo.valence[corner] == 6)
        & (nsharp[corner] == 0)
    )  # fmt: skip
    # One sharp side at a corner: the sector on this side must be three triangles.
    closes_ccw = ~sharp[topo.edge[ccw]] & sharp[topo.edge[topo.prev[ccw]]]
    closes_cw = ~sharp[topo.edge[cw1]] & sharp[topo.edge[cw2]]
    crease = (vtype == CREASE) & np.where(side, ~before & closes_ccw, ~side & closes_cw)
    ok_corner = np.where(side | before, crease & ~(side & before), smooth) & ~irregular[corner]
    ok = np.all(ok_corner, axis=1) & (side.sum(axis=1) <= 1)

    across = topo.origin[topo.prev[np.maximum(topo.twin[h], 0)]]
    x2 = topo.origin[topo.prev[ccw]]
    x3 = topo.origin[topo.next[cw2]]
    grid = np.concatenate([corner, across, np.stack([x2, x3], 2).reshape(-1, 6)], axis=1)
    sharp_side = np.where(ok & side.any(axis=1), np.argmax(side, axis=1), -1)
    return ok, np.where(ok[:, None], grid, 0), sharp_side


_LOOP_LATTICE = np.array([(i / 4, j / 4) for i in range(5) for j in range(5 - i)])
_QUARTIC_POWERS = np.array([(a, b) for a in range(5) for b in range(5 - a)])


def _monomials(uv: np.ndarray, du: int = 0, dv: int = 0) -> np.ndarray:
    """`(n, 15)` the monomials `u^a v^b` (a + b <= 4), differentiated `du`, `dv` times."""
    a, b = _QUARTIC_POWERS[:, 0], _QUARTIC_POWERS[:, 1]
    coef = np.ones(len(a))
    for k in range(du):
        coef = coef * (a - k)
    for k in range(dv):
        coef = coef * (b - k)
    pa, pb = np.maximum(a - du, 0), np.maximum(b - dv, 0)
    return coef * uv[:, :1] ** pa * uv[:, 1:] ** pb


@functools.cache
def _box_spline_coefficients() -> np.ndarray:
    """`(15, 12)` monomial coefficients of the 12 basis functions of a regular Loop
    patch (the three-direction quartic box spline on one triangle).

    The patch is one quartic polynomial (Stam 1998, "Evaluation of Loop subdivision
    surfaces"), so it is fixed by its values at the 15 points of the triangle's
    quartic lattice, which are vertices after two levels: their limits (Loop's limit
    stencils after refining a regular torus locally, the patches switched off) give
    the polynomials. The tests check the patch at other points against refinement."""
    n = 8
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    idx = lambda a, b: (a % n) * n + (b % n)
    a, b, c, d = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1))
    faces = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    mesh = Mesh(np.zeros((n * n, 0)), faces)
    table, *_ = _stencils(mesh, Loop(), np.zeros(15, np.int64), _LOOP_LATTICE,
                          np.full(15, -1), 2, np.inf, patches=False)  # fmt: skip
    values = table.take_rows(np.arange(15)).dense()
    topo = build_topology(faces, n * n)
    _, grid, _ = _triangle_patches(topo, np.zeros(n * n, bool), np.zeros(1, np.int64))
    outside = np.delete(values, grid[0], axis=1)
    assert np.abs(outside).max() < 1e-12, "a regular Loop patch reaches past its 12 points"
    return np.linalg.solve(_monomials(_LOOP_LATTICE), values[:, grid[0]])


def _box_spline_weights(sharp_side: np.ndarray, uv: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """`(n, 6, 12)` weights of a regular Loop patch's control points; on a patch with a
    sharp side, the weights of its three phantoms moved onto the points they are made
    of (see `_triangle_patches`)."""
    coef = _box_spline_coefficients()
    orders = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]
    w = np.stack([_monomials(uv, a, b) @ coef for a, b in orders], axis=1)
    c, o = (lambda j: j % 3), (lambda j: 3 + j % 3)
    x2, x3 = (lambda j: 6 + 2 * (j % 3)), (lambda j: 7 + 2 * (j % 3))
    for i in range(3):
        rows = sharp_side == i
        for phantom, plus, minus in ((o(i), (c(i), c(i + 1)), c(i + 2)),
                                     (x3(i), (x2(i), c(i)), o(i + 2)),
                                     (x2(i + 1), (c(i + 1), x3(i + 1)), o(i + 1))):  # fmt: skip
            moved = w[rows, :, phantom]
            for k in plus:
                w[rows, :, k] += moved
            w[rows, :, minus] -= moved
            w[rows, :, phantom] = 0
    return _to_face_frame(w, jac)


# Loop's children of triangle [p0, p1, p2] (`Loop.level`): 4f + k for the triangle at
# corner k (origin there, u towards the midpoint of its outgoing side, v towards that
# of its incoming one) and 4f + 3 for the middle one [m01, m12, m20].
_TRIANGLE_MAP = np.array(
    [[[2, 0], [0, 2]], [[0, 2], [-2, -2]], [[-2, -2], [2, 0]], [[2, 2], [-2, 0]]], np.float64
)
_TRIANGLE_SHIFT = np.array([[0, 0], [0, 2], [2, 0], [-1, 1]], np.float64)


@dataclasses.dataclass(frozen=True)
class _Family:
    """What differs between Catmull-Clark's quads and Loop's triangles."""

    corners: int
    regular: Callable  # (topo, irregular, faces) -> ok, control vertices, extra
    weights: Callable  # (extra, uv, jac) -> (n, 6, control vertices)
    cap: Callable  # (uv, jac) -> (n, 6, corners)

    def children(self, topo: Topology, where, local, sub):
        """The child face holding each point, and the map to its coordinates."""
        u, v = local[:, 0], local[:, 1]
        if self.corners == 4:
            quad = sub < 0
            k = np.where(u < 0.5, np.where(v < 0.5, 0, 3), np.where(v < 0.5, 1, 2))
            q_map = np.where(quad[:, None, None], _QUADRANT_MAP[k], np.eye(2))
            q_shift = np.where(quad[:, None], _QUADRANT_SHIFT[k], 0.0)
            return topo.offsets[where] + np.where(quad, k, sub), q_map, q_shift
        k = np.where(u + v <= 0.5, 0, np.where(u >= 0.5, 1, np.where(v >= 0.5, 2, 3)))
        return 4 * where + k, _TRIANGLE_MAP[k], _TRIANGLE_SHIFT[k]


_QUADS = _Family(4, _quad_patches, _bicubic_weights, _bilinear_weights)
_TRIANGLES = _Family(3, _triangle_patches, _box_spline_weights, _linear_weights)


def _rows(weights: np.ndarray, points: np.ndarray, patches: Patches, queries: np.ndarray,
          total: int, num_base: int) -> Sparse:  # fmt: skip
    """Stencil rows `kind * total + query` on the base vertices for local `weights`
    `(n, 6, K)` of the patch vertices `points` `(n, K)`."""
    n, _, K = weights.shape
    used, inverse = np.unique(points, return_inverse=True)
    local = Sparse.build(
        np.repeat(np.arange(_KINDS * n), K),
        np.broadcast_to(inverse.reshape(n, 1, K), (n, _KINDS, K)).transpose(1, 0, 2).reshape(-1),
        weights.transpose(1, 0, 2).reshape(-1),
        (_KINDS * n, len(used)),
    )
    out = local @ patches.rows(used, num_base)
    kind, i = out.rows // n, out.rows % n
    return Sparse(kind * total + queries[i], out.cols, out.weights, (_KINDS * total, num_base))


def _stencils(mesh: Mesh, scheme, face: np.ndarray, uv: np.ndarray, subface: np.ndarray,
              max_depth: int, budget: float, patches: bool = True):  # fmt: skip
    """Rows of position and derivative stencils for every point (kind-major: `k * N +
    point`), whether each was evaluated on a regular patch, at which level, and the
    tangent rows `normals` uses for the points that were not (and their indices).
    `patches=False` refines every point to `max_depth` (for `_box_spline_coefficients`)."""
    family = _TRIANGLES if isinstance(scheme, Loop) else _QUADS
    N, V0, K = len(face), mesh.num_vertices, family.corners
    current = Patches(mesh.faces, V0, mesh.creases, mesh.corners, mesh.crease_sharpness,
                       mesh.corner_sharpness, None)  # fmt: skip
    topo = current.topology(scheme)
    blocks, exact, depth = [], np.zeros(N, bool), np.zeros(N, np.int64)
    cap, capped = Sparse.build([], [], [], (0, V0)), np.zeros(0, np.int64)
    queries, where, local, sub = np.arange(N), face.copy(), uv.copy(), subface.copy()
    jac = np.broadcast_to(np.eye(2), (N, 2, 2)).copy()
    for level in range(max_depth + 1):
        ok, grid, extra = family.regular(topo, _irregular_vertices(current), where)
        ok &= (sub < 0) & patches  # a point on a sub-face of an n-gon starts at level 1
        if np.any(ok):
            w = family.weights(None if extra is None else extra[ok], local[ok], jac[ok])
            blocks.append(_rows(w, grid[ok], current, queries[ok], N, V0))
            exact[queries[ok]], depth[queries[ok]] = True, level
        rest = ~ok
        queries, where, local, jac, sub = (a[rest] for a in (queries, where, local, jac, sub))
        if not len(queries):
            break
        if level == max_depth:
            # Within 2^-max_depth of an irregular vertex: the bilinear (linear) patch
            # of the limit positions of the sub-face's corners.
            limit = scheme.limit(topo, current.creases, current.corners)
            corners = topo.origin[topo.offsets[where][:, None] + np.arange(K)]
            used, inverse = np.unique(corners, return_inverse=True)
            at_corners = limit.position.take_rows(used)
            if current.weights is not None:
                at_corners = at_corners @ current.weights
            w = family.cap(local, jac)
            at = dataclasses.replace(current, weights=at_corners)
            blocks.append(_rows(w, inverse.reshape(-1, K), at, queries, N, V0))
            # Normals: the exact limit tangents where the vertex (corner 0 of every
            # sub-face below level 1) is smooth, the secants elsewhere, and at interior
            # vertices of valence 2, which have no tangent plane (the normals along
            # different rays tend to different limits).
            M = len(queries)
            secant = _rows(w, inverse.reshape(-1, K), at, np.arange(M), M, V0)
            secant = secant.take_rows(np.arange(M, 3 * M))
            vertex = corners[:, 0]
            tangents = Sparse.stack([limit.tangent_u.take_rows(vertex),
                                     limit.tangent_v.take_rows(vertex)])  # fmt: skip
            if current.weights is not None:
                tangents = tangents @ current.weights
            use = np.tile(limit.smooth[vertex] & (topo.valence[vertex] > 2), 2)
            a, b = ~use[secant.rows], use[tangents.rows]
            cap = Sparse.build(*(np.concatenate([x[a], y[b]]) for x, y in (
                (secant.rows, tangents.rows), (secant.cols, tangents.cols),
                (secant.weights, tangents.weights))), (2 * M, V0))  # fmt: skip
            # Only their directions matter: rows scaled to a largest weight of 1, so
            # that tangents of size 0.4^16 do not underflow in float32 products.
            largest = np.zeros(2 * M)
            np.maximum.at(largest, cap.rows, np.abs(cap.weights))
            cap = Sparse(cap.rows, cap.cols, cap.weights / np.where(largest > 0, largest, 1)[cap.rows],
                         cap.shape)  # fmt: skip
            capped = queries
            depth[queries] = level
            break
        if level == 0:
            _check_surface_memory(topo, scheme, 1, budget, who="SurfacePoints")
        children, q_map, q_shift = family.children(topo, where, local, sub)
        local = np.einsum("nab,nb->na", q_map, local) + q_shift
        jac = np.einsum("nab,nbc->nac", q_map, jac)
        sub = np.full(len(queries), -1, np.int64)
        refined = refine_patches(scheme, current, topo)
        targets, which = np.unique(children, return_inverse=True)
        rings, index = _one_rings(refined, targets)
        try:
            topo = rings.topology(scheme)
            current, where = rings, index[which.reshape(-1)]
        except ValueError:
            # Two 1-rings that are not disks (fans meeting at an outer vertex; not
            # seen on any mesh tried): go on with the whole refined mesh this level.
            current, where = refined, children
            topo = current.topology(scheme)
            _check_surface_memory(topo, scheme, 1, budget, who="SurfacePoints")
    blocks.append(Sparse.build([], [], [], (_KINDS * N, V0)))
    table = Sparse.build(*(np.concatenate(a) for a in zip(*(
        (b.rows, b.cols, b.weights) for b in blocks))), (_KINDS * N, V0))  # fmt: skip
    return table, exact, depth, cap, capped


class SurfacePoints(eqx.Module):
    r"""Points on the limit surface of Catmull-Clark or Loop at any `(face, u, v)`:
    positions, first and second derivatives and normals, as stencil tables.

    Each point's limit position and derivatives are fixed linear combinations of the
    base vertices. They are found once, on the host, and stored as stencil tables, so
    evaluating them for new vertex positions is one kernel per quantity,
    differentiable and batched like [`jaxsubdiv.surfaces.Limit`][] (OpenSubdiv's limit
    stencils at locations).

    **Parametrisation.** On a quad face `[c0, c1, c2, c3]`, `(u, v)` in $[0, 1]^2$ has
    `(0, 0)` at `c0`, `(1, 0)` at `c1`, `(1, 1)` at `c2` and `(0, 1)` at `c3`; on a
    triangle `[c0, c1, c2]` (Loop), `u, v >= 0` with `u + v <= 1` are the weights of
    `c1` and `c2` (`(0, 0)` at `c0`, `(1, 0)` at `c1`, `(0, 1)` at `c2`). The
    derivatives are with respect to these `u` and `v`. For Catmull-Clark, a face of
    `k != 4` vertices is split into `k` quads by the first level (OpenSubdiv's ptex
    sub-faces): give `subfaces[i] = j` for the quad at its corner `j`, whose `(u, v)`
    has `(0, 0)` at the corner, `(1, 0)` at the midpoint of the edge to corner
    `j + 1`, `(1, 1)` at the face's centroid point and `(0, 1)` at the midpoint of the
    edge from corner `j - 1`.

    **Exactness.** Where the sub-face containing a point is a regular patch, the point
    is evaluated exactly on it (`exact` is True): for Catmull-Clark, a quad whose
    corners are smooth vertices of valence 4, or boundary, crease or corner vertices
    that the bicubic B-spline patch with mirrored phantom points reproduces; for Loop,
    a triangle whose corners are smooth interior vertices of valence 6 (the quartic box
    spline; Stam 1998), or with one sharp side whose corners are boundary or crease
    vertices with three triangles on this side (phantom points again). Other faces are
    refined locally towards the point, up to `max_depth` levels. A point still next to
    an irregular vertex then (an extraordinary vertex, a dart, a crease end, a corner, a
    boundary vertex of another valence) lies within $2^{-\text{max\_depth}}$
    of the face's size from it, and is evaluated on the bilinear (Loop: linear) patch
    of the limit positions of the last sub-face's corners (`exact` is False): its
    position is exact at the vertex itself and within about $4^{-\text{max\_depth}}$
    times the curvature times the squared face size elsewhere; its first derivatives
    are the secants over that sub-face and its second derivatives those of that patch.
    At an extraordinary vertex the limit surface has no parametric derivatives (they
    vanish or diverge like $r^{\log_2(1/\lambda) - 1}$, $\lambda$ the subdominant
    eigenvalue), but it has a normal: `normals` there is the exact limit normal of the
    vertex where it is smooth (the tangent stencils of [`jaxsubdiv.surfaces.Limit`][]),
    the secant normal elsewhere (`docs/surfaces.md` has the measured errors).

    Points on semi-sharp edges are refined until the sharpness has decayed (at most 10
    levels). Available for `CatmullClark()` and `Loop()` with either boundary
    interpolation and crease method.

    Attributes: `position` (`N` rows), `first` (`2N`: d/du then d/dv), `second` (`3N`:
    d2/du2, d2/dudv, d2/dv2) stencil tables; `exact` and `depth` (levels refined) per
    point; `cap_tangents` and `capped`, the tangents `normals` uses at the points not
    on a regular patch.
    """

    position: StencilTable
    first: StencilTable
    second: StencilTable
    exact: Bool[Array, " N"]
    depth: Int[Array, " N"]
    cap_tangents: StencilTable
    capped: Int[Array, " K"]
    num_points: int = eqx.field(static=True)

    def __init__(
        self,
        mesh: Mesh,
        scheme: AbstractSurfaceScheme,
        faces: Int[ArrayLike, " N"],
        uv: Float[ArrayLike, "N 2"],
        *,
        subfaces: Int[ArrayLike, " N"] | None = None,
        max_depth: int = DEFAULT_MAX_DEPTH,
        memory_budget: float = DEFAULT_MEMORY_BUDGET,
    ):
        """**Arguments:**

        - `mesh`: the base [`jaxsubdiv.surfaces.Mesh`][] (only its topology is used).
        - `scheme`: `CatmullClark()` or `Loop()`.
        - `faces`: `(N,)` face index of each point.
        - `uv`: `(N, 2)` coordinates on the face (or its sub-face): in $[0, 1]^2$ on
          quads, with `u + v <= 1` on triangles (Loop).
        - `subfaces`: `(N,)` for Catmull-Clark points on faces that are not quads: the
          corner whose quad of the first level holds the point (`-1` on quads, the
          default).
        - `max_depth`: the most levels a face is refined towards a point (10 to 24;
          default 16: deeper, the tangents at a vertex lose digits to cancellation as
          the sub-face shrinks). Keyword only.
        - `memory_budget`: the most memory, in bytes, for the one level of the whole
          mesh that faces that are not regular need, and for the tables (about
          `6 N` rows of up to a few hundred weights); checked before building. Keyword
          only.
        """
        _check(mesh, scheme)
        if not isinstance(scheme, (CatmullClark, Loop)):
            raise ValueError(
                f"SurfacePoints evaluates `CatmullClark()` and `Loop()` surfaces; got "
                f"{type(scheme).__name__}(). Use a `Refiner` for points as close to its "
                "surface as needed."
            )
        if isinstance(scheme, Loop) and np.any(mesh.face_sizes() != 3):
            f = int(np.argmax(mesh.face_sizes() != 3))
            raise ValueError(
                f"Loop subdivision needs a triangle mesh, but face {f} has "
                f"{int(mesh.face_sizes()[f])} vertices. Triangulate the mesh, or use "
                "`CatmullClark()`."
            )
        max_depth = static_int(max_depth, "max_depth", minimum=10, maximum=24,
                               why=" (semi-sharp tags last up to 10 levels)")  # fmt: skip
        budget = checked_budget(memory_budget)
        face, uv, subface = _checked_points(mesh, faces, uv, subfaces,
                                            3 if isinstance(scheme, Loop) else 4)  # fmt: skip
        need = _BYTES_PER_WEIGHT * _KINDS * int(_support_sizes(mesh, face).sum())
        if need > budget:
            raise ValueError(
                f"SurfacePoints: {len(face):,} points need up to about {need:,} bytes of "
                f"stencil tables, above memory_budget={budget:,}. Evaluate fewer points at "
                "a time, or raise `memory_budget`."
            )
        table, exact, depth, cap, capped = _stencils(mesh, scheme, face, uv, subface,
                                                     max_depth, budget)  # fmt: skip
        N = len(face)
        self.position = StencilTable.from_sparse(table.take_rows(np.arange(N)))
        self.first = StencilTable.from_sparse(table.take_rows(np.arange(N, 3 * N)))
        self.second = StencilTable.from_sparse(table.take_rows(np.arange(3 * N, 6 * N)))
        self.exact = jax.device_put(exact)
        self.depth = jax.device_put(depth.astype(np.int32))
        self.num_points = N
        self.cap_tangents = StencilTable.from_sparse(cap)
        self.capped = jax.device_put(capped.astype(np.int32))

    def positions(self, vertices: Float[ArrayLike, "*batch V C"]) -> Float[Array, "*batch N C"]:
        """Limit positions (any channels) of the points, in order."""
        return self.position(vertices)

    def derivatives(
        self, vertices: Float[ArrayLike, "*batch V C"]
    ) -> tuple[Float[Array, "*batch N C"], Float[Array, "*batch N C"]]:
        """The derivatives with respect to `u` and to `v` at the points."""
        both = self.first(vertices)
        N = self.num_points
        return both[..., :N, :], both[..., N:, :]

    def second_derivatives(
        self, vertices: Float[ArrayLike, "*batch V C"]
    ) -> tuple[Float[Array, "*batch N C"], Float[Array, "*batch N C"], Float[Array, "*batch N C"]]:
        """d2/du2, d2/dudv and d2/dv2 at the points."""
        three = self.second(vertices)
        N = self.num_points
        return three[..., :N, :], three[..., N : 2 * N, :], three[..., 2 * N :, :]

    def normals(self, vertices: Float[ArrayLike, "*batch V 3"]) -> Float[Array, "*batch N 3"]:
        """Unit normals `d/du x d/dv` (the side the faces' counter-clockwise order points
        to); zero where both derivatives are parallel (a degenerate mesh)."""
        vertices = as_float_array(vertices, "vertices")
        if vertices.shape[-1] != 3:
            raise ValueError(f"`normals` needs 3-d positions, got {vertices.shape[-1]} channels.")
        du, dv = self.derivatives(vertices)
        K = self.capped.shape[0]
        if K:
            tangents = self.cap_tangents(vertices)
            du = du.at[..., self.capped, :].set(tangents[..., :K, :])
            dv = dv.at[..., self.capped, :].set(tangents[..., K:, :])
        return _safe_normalize(jnp.cross(du, dv))


# Peak host bytes per stored stencil weight while building (indices, weight, the
# sparse products' copies): measured 68 on Suzanne at 10^4 and 10^5 points.
_BYTES_PER_WEIGHT = 80


def _support_sizes(mesh: Mesh, face: np.ndarray) -> np.ndarray:
    """The number of base vertices on the faces sharing a vertex with each face of
    `face`: every point on a face is a combination of those (its limit depends on its
    1-ring only), so this bounds the weights per stencil row."""
    import scipy.sparse

    flat, sizes = flatten_faces(mesh.faces)
    incidence = scipy.sparse.csr_matrix(
        (np.ones(len(flat)), (np.repeat(np.arange(len(sizes)), sizes), flat)),
        shape=(len(sizes), mesh.num_vertices),
    )
    wanted, inverse = np.unique(face, return_inverse=True)
    ring = (incidence[wanted] @ incidence.T) @ incidence
    return np.diff(ring.indptr)[inverse.reshape(-1)]


def _checked_points(mesh: Mesh, faces, uv, subfaces, patch_size: int):
    """Face indices, coordinates and sub-faces as numpy arrays, or a `ValueError`
    naming the argument and the fix."""
    face = np.asarray(faces)
    if face.size == 0:
        face = face.reshape(0).astype(np.int64)
    integral = np.issubdtype(face.dtype, np.integer) or (
        np.issubdtype(face.dtype, np.floating) and np.all(np.isfinite(face))
        and np.all(face == np.round(face))
    )  # fmt: skip
    if face.ndim != 1 or not integral:
        raise ValueError(f"`faces` must be a 1-d array of face indices, got shape {face.shape} "
                         f"of {face.dtype}.")  # fmt: skip
    F = mesh.num_faces
    out = (face < 0) | (face >= F)  # before any cast: uint64 and float indices too
    if np.any(out):
        bad = face[out][0].item()
        raise ValueError(f"`faces` holds {bad}, but the mesh has {F} faces (0 to {F - 1}).")
    face = face.astype(np.int64)
    try:
        uv = np.asarray(uv)
        if np.iscomplexobj(uv):
            raise TypeError
        uv = uv.astype(np.float64)
    except (TypeError, ValueError):
        raise ValueError("`uv` must be real numbers, an (N, 2) array of (u, v) per face "
                         "index.") from None  # fmt: skip
    if uv.size == 0 and len(face) == 0:
        uv = uv.reshape(0, 2)
    if uv.shape != (len(face), 2):
        raise ValueError(f"`uv` must have shape ({len(face)}, 2), one (u, v) per face index; "
                         f"got {uv.shape}.")  # fmt: skip
    slack = 1e-12  # rounding errors just outside go back onto the side
    inside = np.all(np.isfinite(uv) & (uv >= -slack) & (uv <= 1 + slack), axis=1)
    if patch_size == 3:
        inside &= uv.sum(axis=1) <= 1 + slack
    if not np.all(inside):
        i = int(np.argmax(~inside))
        where = "the triangle u, v >= 0, u + v <= 1" if patch_size == 3 else "[0, 1]^2"
        raise ValueError(f"`uv` must lie in {where}; point {i} is {uv[i].tolist()}.")
    uv = np.clip(uv, 0, 1)
    if patch_size == 3:
        uv = uv / np.maximum(uv.sum(axis=1, keepdims=True), 1)
    sizes = mesh.face_sizes()[face]
    if subfaces is None:
        subface = np.full(len(face), -1, np.int64)
    else:
        subface = np.asarray(subfaces)
        if subface.shape != face.shape or not np.issubdtype(subface.dtype, np.integer):
            raise ValueError(f"`subfaces` must be {len(face)} integers, one per point; got "
                             f"shape {subface.shape} of {subface.dtype}.")  # fmt: skip
        subface = subface.astype(np.int64)
    quad = sizes == patch_size
    bad = (quad & (subface != -1)) | (~quad & ((subface < 0) | (subface >= sizes)))
    if np.any(bad):
        i = int(np.argmax(bad))
        if quad[i]:
            raise ValueError(f"Point {i} is on face {int(face[i])}, which has {patch_size} "
                             f"vertices: its `subfaces` entry must be -1, got "
                             f"{int(subface[i])}.")  # fmt: skip
        raise ValueError(
            f"Point {i} is on face {int(face[i])}, which has {int(sizes[i])} vertices: give "
            f"`subfaces[{i}]` in [0, {int(sizes[i]) - 1}], the corner whose quad of the "
            f"first level holds the point (got {int(subface[i])})."
        )
    return face, uv, subface
