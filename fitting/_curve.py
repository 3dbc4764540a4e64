"""The fitted curve: exact limit points, joined by Hermite segments or chords; feet on it.

The fit measures distances to the *limit* curve. It evaluates the curve at the dyadic
parameters of `levels` levels: refine `levels` times, then push every refined point to
its limit position with the scheme's limit stencil (exact, and differentiable in the
points and the scheme's parameters). Between those points the curve is modelled by cubic
Hermite segments with the exact limit tangents for C^1 schemes (`evaluate`), else by its
chords, whose distance to the curve is about h^2 kappa / 8 for spacing h and curvature
kappa.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

import jaxsubdiv as js


def _segment_ends(curve, closed):
    nxt = jnp.roll(curve, -1, axis=0) if closed else curve[1:]
    return (curve if closed else curve[:-1]), nxt


def _coordinates(x) -> list:
    """The coordinates of points `x` `(..., d)` as `d` arrays `(...)`.

    The searches below compute distances coordinate by coordinate, on arrays without a
    trailing axis of size d: XLA on CPU (jax 0.10.2) compiles a sum over a minor axis of
    2 or 3 (`jnp.sum((p[:, None] - q[None]) ** 2, -1)`) into a reduction fusion many
    times slower than the same sum written out, and gathers `(m, k, d)` points more
    slowly than one coordinate at a time. With these and the pruned check for lost feet,
    the solve of two traced 1024-px glyphs took 0.45 and 0.56 of
    its time, their error measurement 0.55 and 0.54
    (`benchmarks/results/fit_step.md` against `fit_step_2f81813.md`). The sums are the
    same; their rounding in a compiled program may differ (fused multiply-adds)."""
    return [x[..., i] for i in range(x.shape[-1])]


def _sum(terms: list):
    """The sum of a list of arrays, first to last (as a reduction over them would add)."""
    total = terms[0]
    for term in terms[1:]:
        total = total + term
    return total


def _squared_distance(p: list, q: list):
    """`|p - q|^2` from coordinate lists (`_coordinates`), broadcasting."""
    return _sum([(a - b) ** 2 for a, b in zip(p, q)])


def _closed_segments(index, N: int, count):
    """The segments of a closed polyline of `N` vertices at outline positions `index`.

    `count` (traced) says that only the first `count` vertices are the outline and the
    rest copies of its last vertex (padding up to a shape bucket, see `fitting._fit`);
    None means all `N`. Positions count segments along the outline, wrapping after
    `count`: the closing chord is position `count - 1`, but the polyline's segment
    `N - 1` (the padding's segments before it have length zero). So a search window
    around the seam covers the closing chord and the outline's first segments, as it
    does without padding."""
    if count is None:
        return index % N
    index = index % count
    return jnp.where(index == count - 1, N - 1, index)


def _outline_position(segment, count):
    """Inverse of `_closed_segments`: a segment's position along the outline (padding
    segments, which lie at the last vertex, count as the closing chord)."""
    return segment if count is None else jnp.minimum(segment, count - 1)


def _window_project(points, curve, closed, window, count=None):
    """Nearest point of each point's candidate segments `window` `(m, w)`, given as
    positions along the outline (`_closed_segments`): (segment, fraction).

    Or clusters of points `(c, K, d)` that share their cluster's window `(c, w)`,
    whose segments are then gathered once per cluster: (segment, fraction), each
    `(c, K)`."""
    N = curve.shape[0]
    window = _closed_segments(window, N, count) if closed else jnp.clip(window, 0, N - 2)
    a, b = _segment_ends(curve, closed)
    A = [x[window] for x in _coordinates(a)]  # d arrays (m, w) or (c, w)
    B = [x[window] for x in _coordinates(b)]
    if points.ndim == 3:  # clusters: one window for the points of each
        A, B, window = [x[:, None] for x in A], [x[:, None] for x in B], window[:, None]
    P = [x[..., None] for x in _coordinates(points)]
    AB = [y - x for x, y in zip(A, B)]
    length2 = _sum([x**2 for x in AB])
    safe = jnp.where(length2 > 0, length2, 1.0)
    raw = jnp.where(length2 > 0, _sum([(p - x) * y for p, x, y in zip(P, A, AB)]) / safe, 0.0)
    u = jnp.clip(raw, 0.0, 1.0)
    # A foot at a vertex is that vertex exactly (not A + 1 * AB, which rounds), so the
    # two chords meeting there tie exactly; the tie goes to the chord the point lies
    # less far beyond the end of (a geometric rule): with the first index winning, the
    # chord chosen, and with it its band (`Objective._band`), depended on which way
    # the samples ran (a reversed serif 'g': curves 2.9e-4 of the size apart).
    foot = [jnp.where(u == 1, y, x + u * z) for x, y, z in zip(A, B, AB)]
    square = _squared_distance(P, foot)
    beyond = (jnp.maximum(raw - 1, 0.0) + jnp.maximum(-raw, 0.0)) * jnp.sqrt(length2)
    nearest = square == jnp.min(square, axis=-1, keepdims=True)
    best = jnp.argmin(jnp.where(nearest, beyond, jnp.inf), axis=-1)
    pick = lambda x: jnp.take_along_axis(jnp.broadcast_to(x, u.shape), best[..., None],
                                         axis=-1)[..., 0]
    return pick(window), pick(u)


#: The searches over anchors (and the global search over all segments) hold a points x
#: anchors (or points x segments) array; above this many entries they run in blocks of
#: points (`_in_row_blocks`), so that the fit's memory grows linearly with its samples
#: (at the default `levels` the anchors grow with the samples too: the arrays of all
#: pairs took about 1.1 GB at 16,000 samples). 2^22 pairs of float64: 32 MiB an array.
BLOCK_PAIRS = 2**22

#: Points that `nearest_on_polyline`'s certificate leaves unsure, searched again
#: together (`_redo`), at least.
RECHECK = 16

#: `_redo` takes at least a `REDO_PASSES`-th of the points a pass (so about a quarter
#: of that many passes, or all of them with `at_once=False`).
REDO_PASSES = 256


def _in_row_blocks(function, pairs_per_row: int, *rows):
    """`function(*rows)`, for arrays whose first axis runs over the points and whose
    outputs do too, evaluated in blocks of points (`lax.map`) when all at once would
    hold more than `BLOCK_PAIRS` point pairs. The last block is padded with copies of
    the last point, whose results are dropped."""
    m = rows[0].shape[0]
    size = max(1, BLOCK_PAIRS // max(1, pairs_per_row))
    if m <= size:
        return function(*rows)
    pad = -m % size

    def split(x):
        x = jnp.concatenate([x, jnp.repeat(x[-1:], pad, axis=0)])
        return x.reshape(-1, size, *x.shape[1:])

    out = jax.lax.map(lambda block: function(*block), tuple(split(x) for x in rows))
    return jax.tree.map(lambda y: y.reshape(-1, *y.shape[2:])[:m], out)


#: Anchors per group in `_nearest_anchor`'s two-level search.
ANCHOR_GROUP = 32

#: From this many anchors (or groups of segments, for the certificate) on, the searches
#: run in two levels; below it one pass over all pairs is cheaper (with two levels
#: throughout, 400-sample fits took 1.13-1.3x as long: the second level's gathers cost
#: more than the pass saves on 56-128 anchors; measured 2026-12-05 alternating
#: processes, a side run not kept in the benchmark).
TWO_LEVELS_FROM = 512

#: Anchors per group in `_pruned_nearest_anchor`, and groups of segments per block in
#: `_pruned_unsure`.
PRUNE_GROUP = 32

#: From this many anchors on, `_nearest_anchor` prunes groups by their bounding balls
#: (`_pruned_nearest_anchor`). Below it the groups of a glyph's outline are too long to
#: be told apart (at 512 anchors along DejaVu Sans 'S', 58-59% of points near it were
#: certified) and the two-level search is cheaper: 1.8 against 4.1 ms for 1,500 points,
#: 6.4 against 13.2 ms for 6,000; at 1,024 anchors pruning took 2.5 against 2.7 ms and
#: 10.4 against 23.0 ms, all certified (`benchmarks/results/nearest_anchor.md`).
#: `_unsure` prunes blocks of groups of segments from as many groups on.
PRUNED_FROM = 1024


def _nearest_anchor(points, anchors):
    """Each point's nearest anchor and the squared distance to it (less |p|^2, as
    `_anchor_distance2`), in blocks of points when there are many pairs.

    Below `TWO_LEVELS_FROM` anchors, one `argmin` over all pairs; then the two-level
    search (`_grouped_nearest_anchor`); from `PRUNED_FROM` anchors on, a pruned search
    (`_pruned_nearest_anchor`) whose unsure points go to the two-level search."""
    k, d = anchors.shape
    if k < TWO_LEVELS_FROM:
        def one_pass(p):
            d2 = _anchor_distance2(p, anchors)
            return jnp.argmin(d2, axis=1), jnp.min(d2, axis=1)

        return _in_row_blocks(one_pass, k, points)
    if k < PRUNED_FROM:
        return _grouped_nearest_anchor(points, anchors)
    index, distance2, certain = _pruned_nearest_anchor(points, anchors)
    return _redo(~certain, (index, distance2),
                 lambda p: _grouped_nearest_anchor(p, anchors), points)


def _grouped_nearest_anchor(points, anchors):
    """`_nearest_anchor` in two levels: the nearest of groups of `ANCHOR_GROUP`
    consecutive anchors by its smallest distance, then the nearest anchor in that group
    (the first where distances tie). On CPU an `argmin` over the points x anchors array
    is a variadic reduction that XLA does not fuse with the matrix product as it does a
    `min`: with it, and with the certificate's mask (`_smallest_outside`), fits of
    5,000-7,000 samples (1024-px glyphs) took 1.3-2.6x and of 16,000 samples 3.2x the
    time they took with two levels, with the same steps and errors
    (`benchmarks/results/fit_samples_91eb5fa.md`, jax 0.10.2, 2 cores)."""
    k, d = anchors.shape
    group = min(ANCHOR_GROUP, k)
    # Padding: copies of the last anchor, never nearer than it (ties go to the first).
    padded = jnp.concatenate([anchors, jnp.repeat(anchors[-1:], -k % group, axis=0)])
    groups = padded.reshape(-1, group, d)

    def block(p):
        d2 = _anchor_distance2(p, padded).reshape(p.shape[0], -1, group)
        best = jnp.min(d2, axis=2)  # (m, k / group): a plain reduction, fused
        g = jnp.argmin(best, axis=1)  # the small array only
        members = [x[g] for x in _coordinates(groups)]  # d arrays (m, group)
        # `_anchor_distance2` within the group (rounding may differ: any of anchors
        # tied to rounding is a nearest one).
        within = (_sum([x**2 for x in members])
                  - 2 * _sum([x[:, None] * y for x, y in zip(_coordinates(p), members)]))
        return g * group + jnp.argmin(within, axis=1), jnp.min(best, axis=1)

    return _in_row_blocks(block, anchors.shape[0], points)


def _pruned_nearest_anchor(points, anchors):
    r"""`_nearest_anchor` by bounds on groups: `(index, distance2, certain)`.

    The anchors go in groups of `PRUNE_GROUP` consecutive ones, group $g$ inside the
    ball of radius $r_g$ about its middle anchor $c_g$, so no anchor of $g$ is nearer
    to a point $p$ than $\ell_g = |p - c_g| - r_g$ (the triangle inequality). Each
    point searches exactly the anchors of the group of least $\ell_g$ and of its two
    neighbours along the curve, and the result is certain when every other group's
    bound is at least the distance found. One pass over points x groups instead of
    points x anchors: the global foot-point search of a traced 1024-px glyph's samples
    (3,774-5,224 of them, about 4,000 anchors) took 13-19 ms against 69-90 ms with
    `_grouped_nearest_anchor` alone (`benchmarks/results/fit_step_cc4d111.md` against
    `fit_step_2fe90b9.md`, back to back on 2026-12-06). Points near a glyph's outline
    were all certain from 1,024 anchors along it on (`results/nearest_anchor.md`).

    Distances here are sums of squared differences, not matrix products: their
    rounding is relative (a few eps of each distance), whatever the coordinates'
    offset, and no backend's reduced-precision matrix product can enter the
    certificate."""
    k, d = anchors.shape
    groups, loose, bound, nearest_groups = _anchor_groups(anchors, points.dtype)
    count, group = groups.shape[:2]

    def block(p):
        lower, g, near, gap2 = nearest_groups(p)
        j = jnp.argmin(gap2, axis=1)
        found2 = jnp.min(gap2, axis=1)
        index = jnp.take_along_axis(near, (j // group)[:, None], axis=1)[:, 0] * group + j % group
        certain = found2 * (1 + loose) <= bound(lower, g) ** 2
        # Padding copies the last anchor exactly; as the other searches, the squared
        # distance less |p|^2.
        return jnp.minimum(index, k - 1), found2 - jnp.sum(p**2, -1), certain

    return _in_row_blocks(block, (count + 3 * group) * (d + 1), points)


def _anchor_groups(anchors, dtype):
    """The pruned searches' groups of anchors: `(groups, loose, bound, nearest_groups)`.

    `groups` `(count, PRUNE_GROUP, d)`: the anchors in groups of `PRUNE_GROUP`
    consecutive ones (the last padded with copies of the last anchor), group $g$ inside
    the ball of radius $r_g$ about its middle anchor $c_g$. `loose`: the relative
    rounding allowed each computed distance (generously, a few eps for d <= 3).
    `nearest_groups(p, g=None)`: for points `p` `(m, d)`, the bounds $|p - c_g| - r_g$
    (lowered by `loose`) `(m, count)`, the group `g` of least bound (unless given),
    it and its two neighbours (sorted) `(m, 3)`, and the squared distances to their
    anchors `(m, 3 PRUNE_GROUP)`.
    `bound(lower, g)`: each point's least bound, at least 0, over the groups not
    searched."""
    k, d = anchors.shape
    group = PRUNE_GROUP
    padded = jnp.concatenate([anchors, jnp.repeat(anchors[-1:], -k % group, axis=0)])
    groups = padded.reshape(-1, group, d)
    count = groups.shape[0]
    centre = groups[:, group // 2]
    radius = jnp.sqrt(jnp.max(_squared_distance(_coordinates(groups),
                                                 _coordinates(centre[:, None])), axis=1))
    loose = 16 * (d + 2) * jnp.finfo(dtype).eps

    def nearest_groups(p, g=None):
        P = _coordinates(p[:, None])
        to_centre = jnp.sqrt(_squared_distance(P, _coordinates(centre[None])))  # (m, groups)
        lower = to_centre * (1 - loose) - radius * (1 + loose)  # may be negative
        if g is None:
            g = jnp.argmin(lower, axis=1)
        # In increasing order, so that exact ties go to the first anchor, as elsewhere.
        near = jnp.sort((g[:, None] + jnp.arange(-1, 2)) % count, axis=1)
        members = [x[near].reshape(p.shape[0], -1) for x in _coordinates(groups)]
        return lower, g, near, _squared_distance(P, members)

    def bound(lower, g):
        offset = (jnp.arange(count)[None, :] - g[:, None]) % count
        searched = (offset <= 1) | (offset == count - 1)
        return jnp.min(jnp.where(searched, jnp.inf, jnp.maximum(lower, 0.0)), axis=1)

    return groups, loose, bound, nearest_groups


def _nearest_anchor_distance2(points, anchors):
    """`_nearest_anchor`'s squared distances alone (one fused reduction)."""
    return _in_row_blocks(lambda p: jnp.min(_anchor_distance2(p, anchors), axis=1),
                          anchors.shape[0], points)


def _anchors(curve, closed, coarse):
    segments = curve.shape[0] if closed else curve.shape[0] - 1
    coarse = max(1, min(coarse, segments // 4 or 1))
    return coarse, curve[::coarse]


def _anchor_distance2(points, anchors):
    """Squared distances from the points to the anchors, `(m, k)`, as one matrix product
    (argmin |p - a|^2 = argmin (|a|^2 - 2 p.a); measured 2.6x faster than an
    `(m, k, d)` difference array)."""
    return jnp.sum(anchors**2, -1)[None, :] - 2 * points @ anchors.T


def _lost(points, anchors, found2, near=None):
    """Which points have an anchor nearer than the foot found (squared distances
    `found2`): that foot is not the nearest point, and a global search is due.

    From `PRUNED_FROM` anchors on, the anchors' groups are pruned by their bounding
    balls first (`_pruned_lost`), and only the points that leaves undecided are checked
    against every anchor (`_redo`). `near`: an anchor near each point's foot (any
    index gives the same answer; one near the nearest anchor decides the most)."""
    # The matrix-product distances carry rounding of about eps |p|^2: an absolute margin
    # keeps exact fits (feet at distance ~0) from falling back at every step.
    scale = jnp.maximum(jnp.max(jnp.sum(points**2, -1)), jnp.max(jnp.sum(anchors**2, -1)))
    reach2 = found2 - 1e3 * jnp.finfo(points.dtype).eps * scale

    def everywhere(rows):
        points, reach2 = rows
        return _nearest_anchor_distance2(points, anchors) + jnp.sum(points**2, -1) < reach2

    if anchors.shape[0] < PRUNED_FROM:
        return everywhere((points, reach2))
    lost, undecided = _pruned_lost(points, anchors, reach2, near)
    return _redo(undecided, lost, everywhere, (points, reach2))


def _pruned_lost(points, anchors, reach2, near=None):
    """`_lost` by bounds on the groups of anchors (`_anchor_groups`): `(lost, undecided)`.

    A point is lost when an anchor of the group of its anchor `near` (by default its
    nearest group by bound), or of the two groups either side, is nearer than `reach2`
    (squared); it is not lost when, besides, every other group lies beyond it as a
    whole, and undecided otherwise. One pass over points x groups instead of points x
    anchors; the fit's feet give `near`, which saves an `argmin` over the groups. In a
    fit of a traced 1024-px glyph this check runs at every solver step over about 6,000
    samples and 4,000 anchors. Distances are sums of
    squared differences, with relative rounding (`loose`)."""
    groups, loose, bound, nearest_groups = _anchor_groups(anchors, points.dtype)
    count, group, d = groups.shape
    k = anchors.shape[0]

    def block(p, reach2, *near):
        g = jnp.clip(near[0], 0, k - 1) // group if near else None
        lower, g, _, gap2 = nearest_groups(p, g)
        lost = jnp.min(gap2, axis=1) < reach2
        elsewhere = bound(lower, g) ** 2 < reach2 * (1 + loose)
        return lost, ~lost & elsewhere

    rows = (points, reach2) if near is None else (points, reach2, near)
    return _in_row_blocks(block, (count + 3 * group) * (d + 1), *rows)


def _unless(skip, found2):
    """Squared foot distances with those of the `skip`ped points zero (never lost)."""
    return found2 if skip is None else jnp.where(skip, 0.0, found2)


def _redo(flags, values, search, points, at_once: bool = True):
    """`values` (arrays over the points) with those of the flagged points replaced by
    `search(their points)`, a pointwise search, some at a time (`lax.while_loop`), so
    that the cost is theirs, not every point's. When more than a quarter of the points
    are flagged, all are searched anew, at once (`lax.cond`). `points`: an array over
    the points, or a tuple of them (what `search` takes). `at_once=False`: always the
    loop (one traced copy of `search` instead of two).

    `RECHECK` points a pass, or a `REDO_PASSES`-th of all of them when that is more:
    each pass costs some work over all points besides the search (listing the next
    flagged ones), and 16 at a time, the 36,000 of 262,144 points (a fit's curve of
    20,000 samples) left unsure took 2,264 passes and 5.3 s, against 0.63 s 1,024 at
    a time."""
    m = flags.shape[0]
    size = min(m, max(RECHECK, m // REDO_PASSES))

    def few(values):
        def more(carry):
            return jnp.any(carry[0])

        def redo(carry):
            flags, values = carry
            index = jnp.nonzero(flags, size=size, fill_value=m)[0]  # m: none (dropped)
            new = search(jax.tree.map(lambda x: x[jnp.minimum(index, m - 1)], points))
            values = jax.tree.map(lambda v, n: v.at[index].set(n, mode="drop"), values, new)
            return flags.at[index].set(False, mode="drop"), values

        return jax.lax.while_loop(more, redo, (flags, values))[1]

    def many(values):
        return search(points)

    if not at_once:
        return few(values)
    return jax.lax.cond(4 * jnp.sum(flags) > m, many, few, values)


def project(
    points: Float[Array, "m d"],
    curve: Float[Array, "N d"],
    closed: bool,
    coarse: int,
    count: Int[Array, ""] | None = None,
) -> tuple[Int[Array, " m"], Float[Array, " m"]]:
    """Nearest point of the polyline `curve` to each of `points`: (segment, fraction).

    Coarse to fine: the nearest of every `coarse`-th vertex first, then exact projection
    onto the segments within `coarse` vertices of it either way. Exact for curves whose
    vertices are at most ~`coarse` segments away from the nearest coarse vertex, which
    holds for refined curves sampled densely enough. Not differentiated (the fit treats
    the foot points as fixed, see `foot_residual`). `count`: for a closed polyline padded
    after its last vertex, the number of its own vertices (`_closed_segments`).
    """
    points, curve = jax.lax.stop_gradient((points, curve))
    _, _, _, segment, fraction = _coarse_to_fine(points, curve, closed, coarse, count)
    return segment, fraction


def _coarse_to_fine(points, curve, closed, coarse, count=None):
    """`project`'s search: (coarse, anchors, each point's nearest anchor, segment,
    fraction)."""
    coarse, anchors = _anchors(curve, closed, coarse)
    nearest, _ = _nearest_anchor(points, anchors)
    offsets = jnp.arange(-coarse - 1, coarse + 1)
    start = _outline_position(nearest * coarse, count) if closed else nearest * coarse
    window = start[:, None] + offsets[None, :]
    return (coarse, anchors, nearest, *_window_project(points, curve, closed, window, count))


def track(
    points: Float[Array, "m d"],
    curve: Float[Array, "N d"],
    closed: bool,
    coarse: int,
    segment: Int[Array, " m"],
    radius: int = 2,
    count: Int[Array, ""] | None = None,
    skip: Bool[Array, " m"] | None = None,
) -> tuple[Int[Array, " m"], Float[Array, " m"]]:
    """`project`, starting from each point's previous foot segment `segment`.

    Searches the segments within `radius` of the previous one; if any coarse vertex (as in
    `project`) is nearer to its point than the foot found, the foot has jumped elsewhere
    and the global search runs instead for all points (`lax.cond`: only then is its cost
    paid). Between consecutive solver steps feet move little: the fit's foot points (400
    samples on 1024 curve samples, and the held curve points on the samples) took 0.24 ms
    this way against 0.48 ms by the global search (measured). Points flagged in `skip`
    (whose feet the caller replaces) never call for the global search.
    """
    points, curve = jax.lax.stop_gradient((points, curve))
    offsets = jnp.arange(-radius, radius + 1)
    start = _outline_position(segment, count) if closed else segment
    near, fraction = _window_project(points, curve, closed, start[:, None] + offsets[None, :],
                                     count)
    a, b = _segment_ends(curve, closed)
    foot = a[near] + fraction[:, None] * (b[near] - a[near])
    coarse, anchors = _anchors(curve, closed, coarse)
    # Every foot searched again when one is lost (not only the lost ones, `_redo`): on
    # corner-heavy outlines that led fits to poorer minima and to crawl (measured on
    # matplotlib's home icon: 500 steps unconverged, RMS 1.3x, instead of 167 steps).
    lost = _lost(points, anchors, _unless(skip, jnp.sum((points - foot) ** 2, -1)),
                 near // coarse)
    return jax.lax.cond(jnp.any(lost), lambda: project(points, curve, closed, coarse, count),
                        lambda: (near, fraction))


def foot_residual(
    points: Float[Array, "m d"],
    curve: Float[Array, "N d"],
    segment: Int[Array, " m"],
    fraction: Float[Array, " m"],
    closed: bool,
) -> Float[Array, "m d"]:
    """Distance vector from the polyline `curve` to each point, given its foot point.

    For a foot point inside a segment, the vector from the line through that segment
    (exactly the distance vector, and differentiable in the segment's ends, so its
    Jacobian includes the segment turning: tangent-distance minimisation, see W. Wang,
    H. Pottmann, Y. Liu, "Fitting B-spline curves to point clouds by curvature-based
    squared distance minimization", ACM TOG 25 (2006)); at a segment end, the vector
    from that vertex. The choice of segment is not differentiated.
    """
    N = curve.shape[0]
    a = curve[segment]
    b = curve[(segment + 1) % N] if closed else curve[jnp.minimum(segment + 1, N - 1)]
    u = jax.lax.stop_gradient(fraction)
    ab = b - a
    ap = points - a
    length2 = jnp.sum(ab**2, -1)
    interior = (u > 0) & (u < 1) & (jax.lax.stop_gradient(length2) > 0)
    safe = jnp.where(interior, length2, 1.0)  # no division by zero, even in gradients
    line = ap - ab * (jnp.sum(ab * ap, -1) / safe)[:, None]
    vertex = points - jnp.where((u >= 1)[:, None], b, a)
    return jnp.where(interior[:, None], line, vertex)


def all_distances(points, curve, closed, chunk):
    """Nearest point of the polyline to each point, every segment checked: (segment,
    fraction). Chunks of `chunk` points (fewer when the curve is long: at most
    `BLOCK_PAIRS` point-segment pairs) bound the memory to chunk x N x d."""
    a, b = _segment_ends(curve, closed)
    ab = b - a
    length2 = jnp.sum(ab**2, -1)
    safe = jnp.where(length2 > 0, length2, 1.0)

    def block(p):
        ap = p[:, None, :] - a[None]
        u = jnp.clip(jnp.sum(ap * ab, -1) / safe, 0.0, 1.0)
        u = jnp.where(length2 > 0, u, 0.0)
        gap = ap - u[..., None] * ab
        best = jnp.argmin(jnp.sum(gap**2, -1), axis=1)
        return best, jnp.take_along_axis(u, best[:, None], axis=1)[:, 0]

    m = points.shape[0]
    chunk = max(1, min(chunk, m, BLOCK_PAIRS // a.shape[0]))  # no padding beyond m
    pad = -m % chunk
    padded = jnp.concatenate([points, jnp.repeat(points[-1:], pad, axis=0)])
    segment, fraction = jax.lax.map(block, padded.reshape(-1, chunk, points.shape[-1]))
    return segment.reshape(-1)[:m], fraction.reshape(-1)[:m]


def _searched_groups(N: int, k: int, coarse: int, closed: bool, count):
    """For `distances`' certificate: a function `searched(nearest, g)` saying whether
    `_coarse_to_fine`'s window searched group `g` whole, for each point's nearest anchor
    `nearest` `(m,)` and group indices `g` `(m, ...)`.

    Unpadded (`count` None): the nearest anchor's group and the one before it. Padded to
    a shape bucket, by outline position: the padding's segments lie at the outline's
    last vertex (closed: together with the closing chord, at position `count - 1`; open:
    at the end of the last segment), so a group of padding is searched whenever the
    window reaches that position. Without this, every point near a closed outline's seam
    or an open one's end was unsure, and the certificate fell back to checking every
    segment on every call (52 s of a 67 s fit of 20,000 samples).
    """
    def per_point(nearest, g):
        return nearest.reshape(nearest.shape + (1,) * (g.ndim - 1))

    if count is None:
        def searched(nearest, g):
            nearest = per_point(nearest, g)
            before = (nearest - 1) % k if closed else nearest - 1
            return (g == nearest) | (g == before)
        return searched
    segments = N if closed else N - 1
    end = count - 1 if closed else count - 2  # the position every padding segment has
    position = lambda segment: jnp.minimum(segment, end)
    width = 2 * coarse + 2  # `_coarse_to_fine`'s window: offsets -coarse - 1 ... coarse

    def searched(nearest, g):
        nearest = per_point(nearest, g)
        first = g * coarse
        last = jnp.minimum(first + coarse - 1, segments - 1)
        if closed:
            low = _outline_position(nearest * coarse, count) - coarse - 1
            inside = lambda p: jnp.mod(p - low, count) < width
        else:
            low = position(jnp.clip(nearest * coarse - coarse - 1, 0, N - 2))
            high = position(jnp.clip(nearest * coarse + coarse, 0, N - 2))
            inside = lambda p: (p >= low) & (p <= high)
        # Positions grow along a group, which is shorter than the window: its first and
        # last segments inside means all of it inside.
        return inside(position(first)) & inside(position(last))

    return searched


def _smallest_outside(rows, columns, norms, near, excluded):
    r"""For each row $q_i$, $\min_j (n_j - 2 q_i \cdot c_j)$ over the columns $c_j$ with
    norms $n_j$, leaving out the columns `j` (`(m, e, ANCHOR_GROUP)` indices) for which
    `excluded(j)` is true, among those in the groups of `ANCHOR_GROUP` consecutive
    columns that hold the row's `near` columns `(m, e)`; columns of other groups are
    never left out. `+inf` where nothing is left.

    Two levels, as in `_nearest_anchor`: the smallest of each group by one fused
    reduction over the rows x columns products, the row's own groups then recomputed
    with the exclusions, instead of a mask over the whole rows x columns array, whose
    reduction XLA's CPU backend does not fuse with the product (see `_nearest_anchor`
    for the measured effect)."""
    k, d = columns.shape
    group = min(ANCHOR_GROUP, k)
    pad = -k % group
    columns = jnp.concatenate([columns, jnp.zeros((pad, d), columns.dtype)])
    norms = jnp.concatenate([norms, jnp.full((pad,), jnp.inf, norms.dtype)])  # never least
    m = rows.shape[0]
    value = norms[None, :] - 2 * rows @ columns.T
    smallest = jnp.min(value.reshape(m, -1, group), axis=2)  # (m, groups)
    own = near // group  # (m, e)
    smallest = jnp.where(jnp.any(jnp.arange(smallest.shape[1])[None, :, None] == own[:, None, :],
                                 axis=2), jnp.inf, smallest)
    j = own[:, :, None] * group + jnp.arange(group)  # (m, e, group)
    own_value = norms[j] - 2 * jnp.sum(rows[:, None, None, :] * columns[j], -1)
    own_value = jnp.where(excluded(j) | (j >= k), jnp.inf, own_value)
    return jnp.minimum(jnp.min(smallest, axis=1), jnp.min(own_value, axis=(1, 2)))


def safe_sqrt(x: Float[Array, "..."]) -> Float[Array, "..."]:
    """The square root with a finite derivative (zero) at 0 (a double `where`: no 0/0).

    NaN stays NaN (an overflowed fit's distances must not read as zero errors)."""
    positive = x > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, x, 1.0)),
                     jnp.where(jnp.isnan(x), x, 0.0))


def safe_norm(x: Float[Array, "m d"]) -> Float[Array, " m"]:
    """Row norms with a finite derivative (zero) where a row is zero."""
    return safe_sqrt(jnp.sum(x**2, -1))


def nearest_on_polyline(
    points: Float[Array, "m d"],
    curve: Float[Array, "N d"],
    closed: bool,
    coarse: int = 8,
    chunk: int = 256,
    count: Int[Array, ""] | None = None,
) -> tuple[Int[Array, " m"], Float[Array, " m"]]:
    """The nearest point of the polyline `curve` to each point, certified: (segment,
    fraction). Not differentiated.

    `project` finds a candidate near the nearest of every `coarse`-th vertex; the result
    is then certified: the segments from coarse vertex `k` to the next lie within a known
    ball (about the center of their vertices' bounding box), so that group can hold a
    nearer point only if its ball comes closer than the candidate. Groups that `project`
    did not search (all but the two either side of the nearest coarse vertex) must not;
    where one does, every segment is checked for that point (`_redo`).
    Certified, this took 0.8-2 ms against 4-5 ms for checking every segment (measured,
    1024 points near a 400-segment outline). `count`: as for `project`.

    From `TWO_LEVELS_FROM` coarse vertices on, when the points are at least as many as
    the polyline's vertices (a fit's curve samples against its outline's), they go in
    clusters of `CLUSTER` consecutive ones (`_clustered`): cheaper by about that factor
    when consecutive points lie close together, as a curve's samples do; the same answer
    otherwise. (Points sparser than the vertices, as an outline's samples against the
    fit's curve, span more segments per cluster than the window searched around its
    center: measured on a 1024-px glyph, the certificate failed for 85% of them.)
    """
    points, curve = jax.lax.stop_gradient((points, curve))
    coarse, anchors = _anchors(curve, closed, coarse)
    m, N = points.shape[0], curve.shape[0]
    if anchors.shape[0] >= TWO_LEVELS_FROM and m >= max(N, 2 * CLUSTER):
        return _clustered(points, curve, closed, coarse, chunk, count)
    return _pointwise(points, curve, closed, coarse, chunk, count)


#: Consecutive points per cluster in `nearest_on_polyline`'s search from
#: `TWO_LEVELS_FROM` coarse vertices on (`_clustered`).
CLUSTER = 8


def _pointwise(points, curve, closed, coarse, chunk, count):
    """`nearest_on_polyline`, each point searched and certified on its own."""
    coarse, anchors, nearest, segment, fraction = _coarse_to_fine(points, curve, closed, coarse,
                                                                  count)
    unsure = _unsure(points, curve, closed, coarse, count, nearest,
                     _found(points, curve, closed, segment, fraction))
    # Searched again for the unsure points only (`_redo`): typically a few points of
    # hundreds are unsure, and checking the whole block that held them took 70% of a
    # fit's error measurement (4 of 7 ms, 448 samples on a 1,024-point curve); a fit far
    # from converged (20,000 samples after one step) once spent 52 s checking every
    # point for a few unsure ones. By blocks of segments (`_block_nearest`), which
    # checks every segment only for the points its own certificate leaves unsure.
    # (The blocks' balls once, outside the loop; the loop alone, also for many unsure
    # points: a branch for all at once beside it would put a second copy of the search
    # in the program, which compile time pays for.)
    blocks = _segment_blocks(jax.lax.stop_gradient(curve), closed)
    return _redo(unsure, (segment, fraction),
                 lambda p: _block_nearest(p, curve, closed, chunk, blocks), points,
                 at_once=False)


#: Blocks of segments that `_block_nearest` searches for each point.
BLOCKS_SEARCHED = 3


def _block_size(segments: int) -> int:
    r"""`_block_nearest`'s segments per block: a power of two near $\sqrt{s / 3}$
    for $s$ segments (rounded in its logarithm; at least 8), which makes the bounds on
    all blocks and the segments of the `BLOCKS_SEARCHED` searched cost about the same."""
    return max(8, 1 << round(np.log2(max(1.0, np.sqrt(segments / BLOCKS_SEARCHED)))))


def _segment_blocks(curve, closed):
    """`_block_nearest`'s blocks of segments: each one's ball (centre `(count, d)`,
    radius `(count,)`, raised by `loose`) and `loose`, the relative rounding allowed a
    computed distance (as in `_anchor_groups`). Block b holds segments b size ... b size
    + size - 1 (`_block_size`; the last block's clipped to the last segment) and their
    ends."""
    N, d = curve.shape
    segments = N if closed else N - 1
    size = _block_size(segments)
    count = -(-segments // size)
    # (Index tables from iota, not host constants: at 131,072 segments a table of
    # 512 x 257 indices took a megabyte of the program.)
    vertex = jnp.minimum(jnp.arange(count)[:, None] * size + jnp.arange(size + 1),
                         segments) % N
    members = curve[vertex]  # (count, size + 1, d)
    centre = 0.5 * (jnp.min(members, axis=1) + jnp.max(members, axis=1))
    loose = 16 * (d + 2) * jnp.finfo(curve.dtype).eps
    radius = jnp.sqrt(jnp.max(_squared_distance(_coordinates(members),
                                                 _coordinates(centre[:, None])), axis=1))
    return centre, radius * (1 + loose), loose


def _block_nearest(points, curve, closed, chunk, blocks=None):
    r"""Nearest point of the polyline to each point, by blocks of consecutive
    segments: (segment, fraction), as `all_distances`.

    The segments go in blocks of `_block_size`, block $B$ inside the ball of radius
    $R_B$ about $C_B$ (the centre of its vertices' bounding box), so that none of its
    points is nearer to $p$ than $|p - C_B| - R_B$. Each point is projected onto every
    segment of the `BLOCKS_SEARCHED` blocks of least bound, and the answer is certain
    when every other block's bound is at least the distance found; the other points
    check every segment (`all_distances`, `_redo`). This is what the certificate of the
    window search falls back to (`_pointwise`): where the fit's curve is sampled far
    more densely than its distance to the samples (8,000 samples up to a few
    thousandths of the size from a curve of 32,768 points; 2,207 of them unsure), the
    window around the nearest coarse vertex is shorter than that distance; checking
    every segment for all of them made the error measurement quadratic in the samples
    (5 of 6 s of a warm fit of 8,000 samples). Per point this costs the blocks' count plus
    the searched blocks' segments, about $2\sqrt{3 s}$ for $s$ segments, instead of
    $s$. Distances to the balls are sums of squared differences, with relative
    rounding (lowered by `loose`, as in `_anchor_groups`). `blocks`: the blocks'
    balls (`_segment_blocks`), if computed already (once for several calls)."""
    points, curve = jax.lax.stop_gradient((points, curve))
    centre, radius, loose = _segment_blocks(curve, closed) if blocks is None else blocks
    N = curve.shape[0]
    segments = N if closed else N - 1
    size = _block_size(segments)
    count = centre.shape[0]
    searched = min(BLOCKS_SEARCHED, count)
    window_of = jnp.minimum(jnp.arange(count)[:, None] * size + jnp.arange(size),
                            segments - 1)  # (count, size)

    def rows(p):
        m = p.shape[0]
        lower = (jnp.sqrt(_squared_distance(_coordinates(p[:, None]), _coordinates(centre[None])))
                 * (1 - loose) - radius[None, :])  # (m, count)
        chosen = []
        for _ in range(searched):  # the blocks of least bound, one `argmin` each
            b = jnp.argmin(lower, axis=1)
            chosen.append(b)
            lower = jnp.where(jnp.arange(count)[None, :] == b[:, None], jnp.inf, lower)
        window = window_of[jnp.stack(chosen, axis=1)].reshape(m, -1)
        # (No outline `count`: the window holds the polyline's own segment indices.)
        segment, fraction = _window_project(p, curve, closed, window)
        found = _found(p, curve, closed, segment, fraction)
        certain = found * (1 + loose) <= jnp.maximum(jnp.min(lower, axis=1), 0.0)
        return segment, fraction, certain

    segment, fraction, certain = _in_row_blocks(rows, count + searched * size, points)
    # (A loop for the uncertain points, however many: a branch for all at once would
    # compile another copy of `all_distances` into every copy of this search.)
    return _redo(~certain, (segment, fraction),
                 lambda p: all_distances(p, curve, closed, chunk), points, at_once=False)


def _clustered(points, curve, closed, coarse, chunk, count):
    r"""`nearest_on_polyline` for clusters of `CLUSTER` consecutive points at once.

    Each cluster's center $c$ (of its bounding box) is searched (`_coarse_to_fine`) and
    found at distance $f$ from the polyline, and its points lie within $\rho$ of $c$.
    A point $x$ of the cluster is then at most $\rho + f$ from the polyline, so its
    nearest point lies within $2\rho + f$ of $c$: certified for $c$ at that distance
    (`_unsure`), the groups searched around $c$'s nearest coarse vertex hold every
    point's nearest, and each point is projected onto that window alone. Clusters the
    certificate leaves unsure (points far apart, or far from the polyline) are searched
    point by point (`_pointwise`, `_redo`). For the 65,536 points (samples and
    midpoints) of a fit's curve against its outline's 6,144 samples (STIXGeneral 'S' at
    1024 px, n = 64), the passes over all pairs hold an eighth of the pairs, and 0.06%
    of the clusters were unsure: 131 ms against 440 ms point by point
    (`benchmarks/results/fit_step_2481955.md`).
    """
    m = points.shape[0]
    coarse, nearest, unsure = cluster_certificate(points, curve, closed, coarse, count)
    each = lambda x: jnp.repeat(x, CLUSTER, axis=0)[:m]
    offsets = jnp.arange(-coarse - 1, coarse + 1)  # `_coarse_to_fine`'s window
    start = nearest * coarse
    start = _outline_position(start, count) if closed else start
    # Each cluster's window gathered once for its points (the last cluster padded).
    segment, fraction = _window_project(_clusters(points), curve, closed,
                                        start[:, None] + offsets[None, :], count)
    segment, fraction = segment.reshape(-1)[:m], fraction.reshape(-1)[:m]
    return _redo(each(unsure), (segment, fraction),
                 lambda p: _pointwise(p, curve, closed, coarse, chunk, count), points)


def _clusters(points):
    """The points in clusters of `CLUSTER` consecutive ones, `(c, CLUSTER, d)`, the last
    padded with copies of the last point."""
    m, d = points.shape
    padded = jnp.concatenate([points, jnp.repeat(points[-1:], -m % CLUSTER, axis=0)])
    return padded.reshape(-1, CLUSTER, d)


def cluster_certificate(points, curve, closed, coarse, count):
    """`_clustered`'s search of the clusters' centers: `(coarse, nearest, unsure)`, each
    cluster's nearest coarse vertex and whether the certificate at its center's distance
    plus twice its radius leaves it unsure (also what `benchmarks/bench_fit_step.py`
    counts)."""
    members = _clusters(points)
    center = 0.5 * (jnp.min(members, axis=1) + jnp.max(members, axis=1))
    rho = jnp.sqrt(jnp.max(_squared_distance(_coordinates(members),
                                             _coordinates(center[:, None])), axis=1))
    coarse, _, nearest, segment, fraction = _coarse_to_fine(center, curve, closed, coarse, count)
    found = _found(center, curve, closed, segment, fraction)
    return coarse, nearest, _unsure(center, curve, closed, coarse, count, nearest,
                                    found + 2 * rho)


def _found(points, curve, closed, segment, fraction):
    """The distance from each point to its candidate nearest point (segment, fraction)."""
    a, b = _segment_ends(curve, closed)
    foot = a[segment] + fraction[:, None] * (b[segment] - a[segment])
    return jnp.sqrt(jnp.sum((points - foot) ** 2, -1))


def _unsure(points, curve, closed, coarse, count, nearest, found):
    """Which points may have a point of the polyline nearer than `found` outside the
    groups of segments `_coarse_to_fine`'s window searched around their nearest coarse
    vertex `nearest` (`nearest_on_polyline`'s certificate).

    Each group's ball against each point: in one pass, or in two levels from
    `TWO_LEVELS_FROM` groups on (`_smallest_outside`). From `PRUNED_FROM` groups on,
    blocks of groups are pruned first (`_pruned_unsure`), and only the points that
    leaves undecided are checked against every group (`_redo`). For the samples of
    traced 1024-px glyphs against their fitted curves (4,096-6,144 points, about 4,000
    groups) the search and certificate took 0.38-0.46 of the time of the two-level pass
    (`benchmarks/results/fit_step_d71ed09.md` against `fit_step_57dbbf1.md`, back to back)."""
    N = curve.shape[0]
    k = _anchors(curve, closed, coarse)[1].shape[0]
    # Group g: segments g*coarse ... g*coarse + coarse - 1, inside the ball about the
    # center of its vertices' bounding box through the farthest of them.
    vertex = jnp.arange(k)[:, None] * coarse + jnp.arange(coarse + 1)[None, :]
    vertex = curve[vertex % N if closed else jnp.minimum(vertex, N - 1)]  # (k, coarse+1, d)
    center = 0.5 * (jnp.min(vertex, axis=1) + jnp.max(vertex, axis=1))
    radius = jnp.sqrt(jnp.max(_squared_distance(_coordinates(vertex),
                                                _coordinates(center[:, None])), axis=1))
    # Rounding of the matrix-product distances (about eps |p|^2) must not certify a
    # group that is truly nearer: a margin relative to the coordinates' scale.
    scale = jnp.sqrt(jnp.maximum(jnp.max(jnp.sum(points**2, -1)), jnp.max(jnp.sum(curve**2, -1))))
    margin = 1e-6 * scale

    searched_groups = _searched_groups(N, k, coarse, closed, count)

    def unsure_rows_one_pass(p, found, nearest):
        to_center = _anchor_distance2(p, center) + jnp.sum(p**2, -1)[:, None]
        lower = jnp.sqrt(jnp.maximum(to_center, 0.0)) - radius[None, :]
        searched = searched_groups(nearest, jnp.broadcast_to(jnp.arange(k), (p.shape[0], k)))
        return jnp.any(~searched & (lower < found[:, None] + margin), axis=1)

    def unsure_rows(p, found, nearest):
        # A group g not searched that may hold a nearer point: |p - c_g| - r_g < f, with
        # f the found distance plus the margin; squared (both sides non-negative), that
        # is (|c|^2 - r^2)_g - 2 [p, f] . [c, r]_g + |p|^2 - f^2 < 0, a product of
        # rows and columns like `_anchor_distance2`'s, reduced without a mask.
        f = found + margin
        rows = jnp.concatenate([p, f[:, None]], axis=1)
        groups = jnp.stack([nearest, (nearest - 1) % k if closed else nearest - 1], axis=1)
        least = _smallest_outside(rows, columns, norms, jnp.maximum(groups, 0),
                                  lambda g: searched_groups(nearest, g))
        return least + jnp.sum(p**2, -1) - f**2 < 0

    columns = jnp.concatenate([center, radius[:, None]], axis=1)
    norms = jnp.sum(center**2, -1) - radius**2

    def every_group(p, found, nearest):
        return _in_row_blocks(unsure_rows if k >= TWO_LEVELS_FROM else unsure_rows_one_pass,
                              k, p, found, nearest)

    if k < PRUNED_FROM:
        return every_group(points, found, nearest)
    unsure, undecided = _pruned_unsure(points, found + margin, nearest, center, radius,
                                       searched_groups, closed)
    return _redo(undecided, unsure, lambda rows: every_group(*rows), (points, found, nearest))


def _pruned_unsure(points, reach, nearest, center, radius, searched, closed):
    r"""`_unsure` by bounds on groups of groups: `(unsure, undecided)`.

    The certificate's groups of segments, group $g$ inside the ball of radius $r_g$
    about $c_g$, go in blocks of `PRUNE_GROUP` consecutive groups, block $B$ inside the
    ball about $C_B$ (the centre of its groups' centres' bounding box) of radius
    $R_B = \max_{g \in B} |c_g - C_B| + r_g$. A point $p$ whose nearest coarse vertex
    lies in block $B_0$ checks the groups of $B_0$ and its two neighbours one by one, as
    `_unsure` does all of them ($|p - c_g| - r_g$ below `reach`, outside the groups
    searched); every other block must lie beyond `reach` as a whole
    ($|p - C_B| - R_B \ge$ `reach`), else the point is `undecided`, and `_unsure`
    checks it against every group. One pass over points x blocks and 3 `PRUNE_GROUP`
    groups instead of points x groups.

    Distances are sums of squared differences (relative rounding, as in
    `_pruned_nearest_anchor`): each distance to a ball's centre is lowered and each
    radius raised by a few eps of it."""
    k, d = center.shape
    group = PRUNE_GROUP
    pad = -k % group
    # Padding groups have radius -inf: their bound is +inf, never below `reach`.
    center = jnp.concatenate([center, jnp.repeat(center[-1:], pad, axis=0)])
    radius = jnp.concatenate([radius, jnp.full((pad,), -jnp.inf, radius.dtype)])
    loose = 16 * (d + 2) * jnp.finfo(points.dtype).eps
    radius = radius * (1 + loose)
    real = (radius > -jnp.inf).reshape(-1, group, 1)
    members = center.reshape(-1, group, d)
    blocks = members.shape[0]
    block_center = 0.5 * (jnp.min(jnp.where(real, members, jnp.inf), axis=1)
                          + jnp.max(jnp.where(real, members, -jnp.inf), axis=1))
    spread = jnp.sqrt(_squared_distance(_coordinates(members),
                                        _coordinates(block_center[:, None])))
    block_radius = jnp.max(spread * (1 + loose) + radius.reshape(-1, group), axis=1) * (1 + loose)

    def rows(p, reach, nearest):
        m = p.shape[0]
        P = _coordinates(p[:, None])
        lower = (jnp.sqrt(_squared_distance(P, _coordinates(block_center[None]))) * (1 - loose)
                 - block_radius[None, :])  # (m, blocks)
        own = nearest // group
        offset = jnp.arange(blocks)[None, :] - own[:, None]
        if closed:
            offset = (offset + 1) % blocks - 1  # -1, 0, 1 for the neighbours along the curve
        undecided = jnp.any((jnp.abs(offset) > 1) & (lower < reach[:, None]), axis=1)
        near = own[:, None] + jnp.arange(-1, 2)[None, :]
        near = near % blocks if closed else jnp.clip(near, 0, blocks - 1)  # repeats: harmless
        g = (near[:, :, None] * group + jnp.arange(group)).reshape(m, -1)  # (m, 3 group)
        to_group = jnp.sqrt(_squared_distance(P, [x[g] for x in _coordinates(center)]))
        to_group = to_group * (1 - loose)
        unsure = jnp.any(~searched(nearest, g) & (to_group - radius[g] < reach[:, None]), axis=1)
        return unsure, undecided

    return _in_row_blocks(rows, blocks + 3 * group * (d + 1), points, reach, nearest)


def distances(
    points: Float[Array, "m d"],
    curve: Float[Array, "N d"],
    closed: bool,
    coarse: int = 8,
    chunk: int = 256,
    count: Int[Array, ""] | None = None,
) -> Float[Array, " m"]:
    """Exact distance from each point to the polyline `curve` (`nearest_on_polyline`).

    Differentiable in `points` and `curve`: the distance to the nearest point found,
    with that point's segment held fixed (its derivative where the nearest point is
    unique; zero where a point lies on the polyline).
    """
    segment, fraction = nearest_on_polyline(points, curve, closed, coarse, chunk, count)
    return safe_norm(foot_residual(points, curve, segment, fraction, closed))


def curve_tables(
    scheme, n: int, levels: int, boundary: str, dtype, tangents: bool
) -> tuple[js.CurveStencil, js.CurveStencil | None]:
    """The curve's samples and tangents as banded linear maps of the control points
    ([`jaxsubdiv.curve_stencil`][]): row `K` of the first gives the limit point at
    dyadic position `K`, row `K` of the second its exact derivative with respect to `K`
    (one unit per sample), or `None` when `tangents` is False. Both read the same
    windows of control points. Differentiable in the scheme's parameters; O(N width)."""
    position = js.curve_stencil(scheme, n, levels, boundary=boundary, dtype=dtype)
    if not tangents:
        return position, None
    tangent = js.curve_stencil(scheme, n, levels, boundary=boundary, derivative=1, dtype=dtype)
    return position, _per_sample(tangent, levels)


def _per_sample(tangent: js.CurveStencil, levels: int) -> js.CurveStencil:
    """A tangent table in units of curve samples: `curve_stencil` differentiates with
    respect to the control points' parameter, and the fit's positions count samples,
    2^levels of them per control point."""
    return eqx.tree_at(lambda t: t.weights, tangent, tangent.weights / 2**levels)


def creased_tables(
    scheme, n: int, levels: int, creases: Bool[Array, " n"], dtype, tangents: bool
) -> tuple[js.CurveStencil, tuple[js.CurveStencil, js.CurveStencil] | None]:
    """`curve_tables` of a closed curve creased at the control points `creases` (a mask,
    which may be traced): its samples, and for the Hermite model its tangents from after
    and from before each sample (one-sided at the creases, the same elsewhere:
    [`jaxsubdiv.curve_stencil`][]`(side=...)`), in units of samples."""
    position = js.curve_stencil(scheme, n, levels, creases=creases, dtype=dtype)
    if not tangents:
        return position, None
    return position, tuple(
        _per_sample(js.curve_stencil(scheme, n, levels, derivative=1, creases=creases,
                                     side=side, dtype=dtype), levels)
        for side in ("right", "left"))


def tangents_of(V, P: Float[Array, "n d"]):
    """The curve's tangents from the tangent tables `V` (None, a table, or a creased
    curve's pair from after and from before each sample) and the control points: the
    same structure, each `(N, d)`."""
    if V is None:
        return None
    return tuple(v.apply(P) for v in V) if isinstance(V, tuple) else V.apply(P)


def stencil_rows(table: js.CurveStencil, index) -> Float[Array, "k n"]:
    """Rows `index` `(k,)` (integers; a NumPy array reads the columns on the host, a
    traced one gathers them) of `table` as dense `(k, n)` rows, not the O(N n) of the
    whole dense table. Repeated columns (windows wider than the polygon) add up."""
    if np.ndim(index) != 1:
        raise ValueError(f"`index` must be one-dimensional, got shape {np.shape(index)}")
    if isinstance(index, np.ndarray):
        columns = jnp.asarray(table.columns()[index])  # (k, width), host constants
    else:
        columns = jnp.asarray(table.columns())[index]
    k = columns.shape[0]
    rows = jnp.zeros((k, table.n), table.weights.dtype)
    return rows.at[jnp.arange(k)[:, None], columns].add(table.weights[index])


def kinks(V) -> Bool[Array, " N"] | None:
    """The curve samples where a creased curve's tangents from after and from before
    differ (its corners; `V` a pair of tables, or of the tangents `(N, d)` they give),
    else None (a $C^1$ curve, or chords)."""
    if not isinstance(V, tuple):
        return None
    right, left = V
    if isinstance(right, js.CurveStencil):
        # Static: rows on the same windows, no control point twice in one (the dense
        # rows sum repeated columns).
        if (np.array_equal(right.first, left.first) and right.width == left.width
                and right.width <= right.n):
            right, left = right.weights, left.weights
        else:
            right, left = right.dense(), left.dense()
    return jnp.any(right != left, axis=tuple(range(1, right.ndim)))


class Band(eqx.Module):
    """A curve basis stored by segments, for the banded assembly (`band_basis`).

    Segment `k` joins curve samples `k` and `k + 1`; every control point it depends on
    lies in the window of `width` consecutive ones starting at `start[k]` (cyclically
    on closed curves). `ends[k]` holds the rows of the sample, its tangent, the next
    sample and its tangent, restricted to that window (zeros for tangents on chords).
    """

    start: Int[Array, " N"]
    ends: Float[Array, "N 4 width"]


def band_basis(position: js.CurveStencil, tangent: js.CurveStencil | None,
               left: js.CurveStencil | None = None) -> Band:
    """The curve's tables (`curve_tables`) by segments, read off their windows.

    Sample `k` reads control points `first[k] ... first[k] + w - 1`, and `first` grows by
    0 or 1 from one sample to the next (a host fact of the table's layout), so segment
    `k` reads the `w + 1` control points from `first[k]`: the next sample's row is its
    own, shifted by that step. `left`: a creased curve's tangents from before each
    sample (`creased_tables`), which segment `k` takes at its end `k + 1` (`tangent`
    then holds those from after).
    """
    first, n, width = position.first, position.n, position.width
    N = len(first)
    nxt = (np.arange(N) + 1) % N if position.closed else np.minimum(np.arange(N) + 1, N - 1)
    step = first[nxt] - first
    step = step % n if position.closed else step
    if not np.all((step == 0) | (step == 1)):  # static: a defect here, never the data's
        raise AssertionError(f"curve table windows step by {sorted(set(step.tolist()))}")
    column = np.arange(width + 1)[None, :]
    here = np.broadcast_to(column, (N, width + 1))  # column `width` is the zero one
    there = column - step[:, None]
    there = np.where((there >= 0) & (there < width), there, width)

    def padded(table):  # the rows with a zero column at `width`
        if table is None:
            return jnp.zeros((N, width + 1), position.weights.dtype)
        return jnp.concatenate([table.weights, jnp.zeros((N, 1), table.weights.dtype)], 1)

    A, V = padded(position), padded(tangent)
    W = V if left is None else padded(left)
    take = lambda M, index, rows: jnp.take_along_axis(M[rows], jnp.asarray(index), axis=1)
    ends = jnp.stack([take(A, here, slice(None)), take(V, here, slice(None)),
                      take(A, there, nxt), take(W, there, nxt)], axis=1)
    return Band(start=jnp.asarray(first, jnp.int32), ends=ends)


def band_rows(
    band: Band, tau: Float[Array, " m"], n: int, closed: bool, hermite: bool
) -> tuple[Int[Array, "m width"], Float[Array, "m width"], Float[Array, "m width"],
           Float[Array, "m width"]]:
    """`evaluate(A, V, tau, closed, order=2)` in banded form: each position's window of
    control points `(m, width)` and its rows of the curve, tangent and second derivative
    on that window."""
    N = band.start.shape[0]
    segment, u = _segment(tau, N, closed)
    values, slopes, bends = _interpolation(u, hermite)
    ends = band.ends[segment]  # (m, 4, width)
    combine = lambda h: jnp.einsum("hm,mhw->mw", h, ends)
    width = ends.shape[-1]
    # Modulo n also on open curves: a window of a polygon with fewer points than the
    # window (n < width) has zero weights beyond its last point.
    window = (band.start[segment][:, None] + jnp.arange(width)[None, :]) % n
    return window, combine(values), combine(slopes), combine(bends)


def curve_samples(scheme, n: int, levels: int, boundary: str) -> int:
    """Number of exact curve samples (rows of `curve_tables`): the refined count, less the
    `a` points at each end of an open curve that its limit stencils cannot reach (see
    [`jaxsubdiv.limit_points`][])."""
    count = js.refined_count(n, scheme, levels, boundary)
    if boundary == "open":
        count -= 2 * (len(js.neighborhood(scheme, "vertex")) // 2)
    return count


def _hermite(u):
    """Cubic Hermite basis at `u` in [0, 1] and its first and second derivatives, each
    `(4, m)` (for the point, tangent, next point, next tangent)."""
    u2, u3 = u * u, u * u * u
    values = jnp.stack([2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2])
    slopes = jnp.stack([6 * u2 - 6 * u, 3 * u2 - 4 * u + 1, 6 * u - 6 * u2, 3 * u2 - 2 * u])
    bends = jnp.stack([12 * u - 6, 6 * u - 4, 6 - 12 * u, 6 * u - 2])
    return values, slopes, bends


def _interpolation(u, hermite: bool):
    """Weights of (point, tangent, next point, next tangent) at `u` in [0, 1] for the
    value, first and second derivative, each `(4, m)`: cubic Hermite, or the chord
    (1 - u) X_k + u X_{k+1} (tangents unused)."""
    if hermite:
        return _hermite(u)
    zero, one = jnp.zeros_like(u), jnp.ones_like(u)
    values = jnp.stack([1 - u, zero, u, zero])
    return values, jnp.stack([-one, zero, one, zero]), jnp.zeros_like(values)


def _segment(tau, N: int, closed: bool):
    """Segment index and fraction of the global positions `tau`."""
    if closed:
        base = jnp.floor(tau)
        return base.astype(jnp.int32) % N, tau - base
    base = jnp.clip(jnp.floor(tau), 0, N - 2)
    return base.astype(jnp.int32), tau - base


def evaluate(
    X: Float[Array, "N ..."],
    V: Float[Array, "N ..."] | None,
    tau: Float[Array, " m"],
    closed: bool,
    order: int = 1,
) -> tuple[Float[Array, "m ..."], ...]:
    r"""The curve and its derivatives up to `order` (0, 1 or 2) at the global positions `tau`
    (units of samples).

    With tangents `V`, the cubic Hermite interpolant of the samples `X` and their exact
    tangents: a $C^1$ curve within $O(h^4)$ of a $C^4$ limit curve (and within
    $O(h^{1+\alpha})$ in position of any $C^{1,\alpha}$ one), so distances to it are smooth in
    the control points and the sample positions. Without, the polyline through `X` (zero
    second derivative). `X` and `V` may carry trailing axes (e.g. basis matrices). A
    creased curve's `V` is a pair, its tangents from after and from before each sample
    (`creased_tables`): segment `k` takes the first at sample `k`, the second at `k + 1`,
    so the curve has a corner at each crease and is $C^1$ elsewhere.
    """
    N = X.shape[0]
    seg, u = _segment(tau, N, closed)
    nxt = (seg + 1) % N if closed else seg + 1
    expand = lambda c: c.reshape(c.shape + (1,) * (X.ndim - 1))
    if V is None:
        ends = (X[seg], None, X[nxt], None)
    else:  # a creased curve's segment starts with the tangent after, ends with the one before
        after, before = V if isinstance(V, tuple) else (V, V)
        ends = (X[seg], after[seg], X[nxt], before[nxt])
    combine = lambda basis: sum(expand(h) * e for h, e in zip(basis, ends) if e is not None)
    return tuple(combine(basis) for basis in _interpolation(u, V is not None)[: order + 1])


def _newton(points, X, V, tau, closed, steps, reach):
    r"""`steps` Gauss-Newton steps on the Hermite curve for $(C - p) \cdot C' = 0$, each at
    most `reach` samples long."""
    N = X.shape[0]
    top = N if closed else N - 1

    def newton(_, tau):
        C, dC = evaluate(X, V, tau, closed)
        speed2 = jnp.sum(dC**2, -1)
        step = -jnp.sum((C - points) * dC, -1) / jnp.where(speed2 > 0, speed2, 1.0)
        trial = tau + jnp.clip(step, -reach, reach)
        trial = jnp.mod(trial, top) if closed else jnp.clip(trial, 0.0, top)
        # Only steps that bring the foot nearer: near a sample's center of curvature the
        # Gauss-Newton step can overshoot to a farther point (measured: a tracked foot
        # 5e-7 worse than its start stalled 4 of 1,000 fits).
        (moved,) = evaluate(X, V, trial, closed, order=0)
        nearer = jnp.sum((moved - points) ** 2, -1) <= jnp.sum((C - points) ** 2, -1)
        return jnp.where(nearer, trial, tau)

    # A loop, not unrolled: the search appears several times in the fit's program, and
    # unrolled copies cost compile time.
    tau = jax.lax.fori_loop(0, steps, newton, tau)
    corner = kinks(V)
    if corner is None:
        return tau
    # At a corner of a creased curve the distance has no stationary point: a point
    # whose nearest is the corner sends Newton's steps back and forth across it, nearer
    # each time but never there. Each foot goes to a corner at an end of its segment
    # when that is at least as near (then it is the nearest point).
    seg, _ = _segment(tau, N, closed)
    (C,) = evaluate(X, V, tau, closed, order=0)
    best = jnp.sum((C - points) ** 2, -1)
    for end in (seg, (seg + 1) % N if closed else jnp.minimum(seg + 1, N - 1)):
        there = jnp.sum((X[end] - points) ** 2, -1)
        snap = corner[end] & (there <= best)
        tau = jnp.where(snap, end.astype(tau.dtype), tau)
        best = jnp.where(snap, there, best)
    return tau


def locate(
    points: Float[Array, "m d"],
    X: Float[Array, "N d"],
    V: Float[Array, "N d"] | None,
    closed: bool,
    coarse: int,
    newton: int = 4,
    previous: Float[Array, " m"] | None = None,
    skip: Bool[Array, " m"] | None = None,
) -> Float[Array, " m"]:
    r"""Foot-point positions (in units of curve samples) of `points` on the curve.

    The nearest point of the polyline through `X` first (`project`), then, when the
    tangents `V` are given, `newton` Gauss-Newton steps on the Hermite curve for
    $(C(\tau) - p) \cdot C'(\tau) = 0$, each at most one sample long (the foot may move
    into the next segment). Not differentiated.

    With `previous` positions (the feet on a nearby curve, e.g. the last solver step's):
    without tangents, `track` from them; with tangents, the Newton steps start from them
    and may each move up to `coarse` samples (the Gauss-Newton step is exact for a foot
    sliding along a straight piece), and the global search runs instead (`lax.cond`) if
    any of every `coarse`-th curve sample is nearer to its point than the foot found.
    Measured on glyph fits, this keeps the global search to a few steps per fit. Points
    flagged in `skip` (whose feet the caller replaces) never call for it.
    """
    points, X = jax.lax.stop_gradient((points, X))
    if previous is not None and V is None:
        start = jnp.floor(jax.lax.stop_gradient(previous)).astype(jnp.int32)
        segment, fraction = track(points, X, closed, coarse, start, skip=skip)
        return segment + fraction
    if previous is None:
        segment, fraction = project(points, X, closed, coarse)
        tau = segment + fraction
        if V is None:
            return tau
        return _newton(points, X, jax.lax.stop_gradient(V), tau, closed, newton, 1.0)
    V = jax.lax.stop_gradient(V)
    tau = _newton(points, X, V, jax.lax.stop_gradient(previous), closed, newton, float(coarse))
    (C,) = evaluate(X, V, tau, closed, order=0)
    spacing, anchors = _anchors(X, closed, coarse)
    lost = _lost(points, anchors, _unless(skip, jnp.sum((C - points) ** 2, -1)),
                 jnp.floor(tau).astype(jnp.int32) // spacing)
    return jax.lax.cond(jnp.any(lost), lambda: locate(points, X, V, closed, coarse, newton),
                        lambda: tau)  # all searched again, as in `track`


def nearest_on_curve(
    points: Float[Array, "m d"],
    X: Float[Array, "N d"],
    V: Float[Array, "N d"],
    closed: bool,
    previous: Float[Array, " m"] | None = None,
    newton: int = 4,
) -> Float[Array, " m"]:
    r"""Positions (units of curve samples) of the nearest points of the Hermite curve
    through `X` with tangents `V` (`evaluate`) to `points`, found globally. Not
    differentiated.

    The certified nearest point of the polyline through `X` (`nearest_on_polyline`),
    then `newton` Gauss-Newton steps on the curve from there (`locate`'s). The curve's
    segment `k` lies within $\delta_k = \tfrac{4}{27}(|V_k - \Delta_k| + |V_{k+1} -
    \Delta_k|)$ of its chord $\Delta_k = X_{k+1} - X_k$ (the Hermite basis's correction
    terms peak at 4/27), so the distance to the point found exceeds the true distance by
    at most $2 \max_k \delta_k$ (about $0.3 h^2 \kappa$ for sample spacing $h$ and
    curvature $\kappa$), and only where two branches of the curve nearly tie; elsewhere
    Newton's method converges to the true nearest point. Unlike a foot tracked from an
    earlier curve, which may sit on a branch that is no longer nearest (the waist of an
    '8'), this is the global answer. With `previous` positions, each point keeps the
    nearer of the two.
    """
    points, X, V = jax.lax.stop_gradient((points, X, V))
    segment, fraction = nearest_on_polyline(points, X, closed)
    tau = _newton(points, X, V, segment + fraction, closed, newton, 1.0)
    if previous is None:
        return tau
    previous = jax.lax.stop_gradient(previous)
    (here,) = evaluate(X, V, tau, closed, order=0)
    (there,) = evaluate(X, V, previous, closed, order=0)
    nearer = jnp.sum((there - points) ** 2, -1) < jnp.sum((here - points) ** 2, -1)
    return jnp.where(nearer, previous, tau)


def chord_band(
    points: Float[Array, "m d"], closed: bool, count: Int[Array, ""] | None = None
) -> Float[Array, " m"]:
    """How far a smooth curve through the ordered `points` may stray from each chord.

    For chord `j` (from point `j` to `j + 1`) of length `h`: the larger of `h / 16` and
    three times the sagitta `h^2 kappa / 8` of a circular arc of the curvature `kappa`
    estimated at its ends (turning angle over mean chord length). A curve through the
    samples bulges from the chords by about the sagitta, and by more where its curvature
    is large between samples (limits of four-point schemes have unbounded curvature at
    dense sets of points); measured on noise-free four-point data, the curve exceeded
    twelve sagittas, but stayed within `h / 16`.

    `count`: for a closed polyline padded after its last vertex, the number of its own
    vertices (`_closed_segments`): the last one's neighbour is then the first, and the
    padding's chords (of length zero) get a zero band.
    """
    M = points.shape[0]
    index = jnp.arange(M)
    last = M - 1 if count is None or not closed else count - 1
    # Each vertex's neighbours along the outline, for its turning angle.
    prev = points[jnp.where(index == 0, last, index - 1)]
    nxt = points[jnp.where(index == last, 0, (index + 1) % M)]
    before, after = points - prev, nxt - points
    len_before, len_after = safe_norm(before), safe_norm(after)
    # The turning angle as atan2(|a x b|, a.b): unlike arccos of the cosine, it has a
    # finite derivative at straight runs (the band is differentiated with the loss).
    dot = jnp.sum(before * after, -1)
    cross2 = jnp.maximum(len_before**2 * len_after**2 - dot**2, 0.0)
    bent = cross2 > 0
    cross = jnp.where(bent, jnp.sqrt(jnp.where(bent, cross2, 1.0)), 0.0)
    ok = (len_before > 0) & (len_after > 0)  # repeated samples: no turning
    angle = jnp.where(ok, jnp.arctan2(jnp.where(ok, cross, 0.0), jnp.where(ok, dot, 1.0)), 0.0)
    mean = 0.5 * (len_before + len_after)
    kappa = angle / jnp.where(mean > 0, mean, 1.0)
    if not closed:  # the ends have one chord: use their neighbor's curvature
        kappa = kappa.at[0].set(kappa[1]).at[-1].set(kappa[-2])
    # Chord j runs from vertex `start` to `end`; the polyline's last closes the outline.
    start = jnp.where(index == M - 1, last, index)
    end = (index + 1) % M
    length = safe_norm(points[end] - points[start])
    bound = jnp.maximum(kappa[start], kappa[end])
    return jnp.maximum(length / 16, 3 * length**2 * bound / 8)
