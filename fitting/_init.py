"""Initial control points: order the samples, parameterise them, solve a linear fit."""

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

import jaxsubdiv as js

from ._curve import stencil_rows


def order_samples(points, *, closed: bool = True) -> np.ndarray:
    """Order unordered samples of an outline along it; returns the index order.

    A nearest-neighbor tour improved by 2-opt moves until no move shortens it (Croes
    1958): on samples that cover a curve densely compared with its thinnest feature this
    recovers the order along the curve. For an open curve the tour is cut at its longest
    edge. Runs on the host with numpy in O(m^2) memory and time per 2-opt pass, fine for
    a few thousand samples.

    **Arguments:**

    - `points`: samples, shape `(m, d)`, concrete (not traced).
    - `closed`: whether the outline is closed.

    **Returns:** an int array `order` such that `points[order]` runs along the outline.
    """
    P = np.asarray(points, dtype=float)
    m = len(P)
    if m < 3:
        return np.arange(m)
    dist = np.sqrt(((P[:, None, :] - P[None, :, :]) ** 2).sum(-1))
    # Nearest-neighbor tour from the first sample.
    tour = [0]
    seen = np.zeros(m, bool)
    seen[0] = True
    for _ in range(m - 1):
        d = np.where(seen, np.inf, dist[tour[-1]])
        nxt = int(np.argmin(d))
        tour.append(nxt)
        seen[nxt] = True
    tour = np.array(tour)
    # 2-opt: reverse tour[i+1..j] when d(a,c) + d(b,d) < d(a,b) + d(c,d).
    for _ in range(10 * m):
        a, b = tour, np.roll(tour, -1)
        gain = dist[a, b][:, None] + dist[a, b][None, :] - dist[a[:, None], a[None, :]] - dist[
            b[:, None], b[None, :]
        ]
        gain = np.triu(gain, 2)
        gain[0, -1] = 0.0  # those two edges are adjacent in a closed tour
        i, j = np.unravel_index(np.argmax(gain), gain.shape)
        if gain[i, j] <= 1e-12 * dist.max():
            break
        tour[i + 1 : j + 1] = tour[i + 1 : j + 1][::-1].copy()
    if not closed:
        edges = dist[tour, np.roll(tour, -1)]
        cut = int(np.argmax(edges))
        tour = np.roll(tour, -(cut + 1))
    return tour


def chord_fractions(target: Float[Array, "m d"], closed: bool) -> Float[Array, " m"]:
    """Cumulative chord length of the ordered samples, as a fraction in [0, 1)
    (closed: of the length including the closing chord) or [0, 1] (open)."""
    nxt = jnp.roll(target, -1, axis=0)
    gaps = jnp.sqrt(jnp.sum((nxt - target) ** 2, -1) + 1e-30)
    if not closed:
        gaps = gaps.at[-1].set(0.0)
    cumulative = jnp.concatenate([jnp.zeros((1,), gaps.dtype), jnp.cumsum(gaps)[:-1]])
    total = jnp.sum(gaps)
    return cumulative / jnp.where(total > 0, total, 1.0)


def interpolate_rows(table: js.CurveStencil, position: Float[Array, " m"], closed: bool):
    """Linear interpolation of the rows of the curve table `table` at fractional row
    `position`s: dense `(m, n)` rows."""
    N = len(table)
    base = jnp.floor(position).astype(int)
    if closed:
        i0 = base % N
        i1 = (i0 + 1) % N
    else:
        i0 = jnp.clip(base, 0, N - 2)
        i1 = i0 + 1
    frac = jnp.clip(position - i0, 0.0, 1.0)[:, None] if not closed else (position - base)[:, None]
    return (1 - frac) * stencil_rows(table, i0) + frac * stencil_rows(table, i1)


def second_differences(n: int, closed: bool, dtype, creases=None) -> Array:
    """The second differences of the control points, as a matrix; on a creased closed
    curve (`creases`, a boolean mask `(n,)`) none is taken at a creased point, so that
    smoothing does not round the corners."""
    eye = jnp.eye(n, dtype=dtype)
    if closed:
        D = jnp.roll(eye, -1, axis=1) - 2 * eye + jnp.roll(eye, 1, axis=1)
        return D if creases is None else jnp.where(creases[:, None], 0.0, D)
    return eye[:-2] - 2 * eye[1:-1] + eye[2:]


#: A piece of outline between two corners is *bent* when a sample lies farther than
#: this many mean sample spacings from the chord between the corners. One span between
#: two creases is a straight segment, so a bent piece needs at least two. The pixel
#: staircase of a straight edge strays well under one spacing from its chord; below
#: two spacings the samples cannot tell a bend from a straight edge (a 20-degree arc of
#: radius 1, sagitta 0.015, is bent at 400 samples along its sector, not at 100).
BENT_SPACINGS = 2.0


def corner_creases(
    target: Float[Array, "m d"], corners: Bool[Array, " m"], n: int
) -> tuple[Bool[Array, " n"], Float[Array, " m"]]:
    """The creased control points for a closed outline's corner samples, and every
    sample's starting position along the curve (in control-point units, `[0, n)`).

    The corners (flags on the samples, in their canonical order) split the outline into
    pieces, and the `n` spans of the curve are apportioned among the pieces by their
    arc length (chord length of the samples) with Hamilton's largest-remainder method:
    each piece gets the whole part of its share and the spans left over go to the
    largest fractional parts. A piece's spans depend only on the pieces' lengths, not
    on which corner the count starts from, so an outline and its mirror image, or the
    same outline started elsewhere, get the same spans piece by piece. (Rounding the
    cumulative shares from the first corner, as before, moved a span between pieces
    with the start: STIXGeneral 'S' traced at 256 px fitted to 0.63 px from its outline
    and its mirror image to 1.86 px.)

    One span between two creases is a straight segment, so every piece gets at least
    one, and a *bent* piece (`BENT_SPACINGS`) at least two where all these floors fit in
    `n` (`_least_spans`); the pieces whose share falls below their floor get the floor
    and the others share the rest by arc length (`_floored_spans`) before the
    apportionment, which keeps the floors. The first corner is control point 0 and
    corner `j` is at the sum of the spans before it (a cyclic relabelling of the control
    points, which does not change the curve).

    A sample between corners `j` and `j + 1` starts at the chord-length position between
    their control points, so every corner sample starts exactly at its crease.
    Traceable: the corners are data. At most `n` corners (`fit` checks).
    """
    m = target.shape[0]
    first = jnp.argmax(corners)
    # Chord-length fractions counted from the first corner (rolled there first: a
    # difference of two cumulative sums is not exactly 0 at the corner under jit, and a
    # wrap of -1e-17 to 1 put it last).
    u = jnp.roll(chord_fractions(jnp.roll(target, -first, axis=0), True), first)
    order = jnp.argsort(jnp.where(corners, u, jnp.inf))  # the corners first, in turn
    count = jnp.sum(corners)
    j = jnp.arange(m)
    real = j < count
    at = jnp.where(real, u[order], 1.0)
    # Each sample's piece: the last corner at or before it (in u).
    piece = jnp.clip(jnp.searchsorted(at, u, side="right") - 1, 0, jnp.maximum(count - 1, 0))
    fraction = jnp.where(real, jnp.diff(at, append=jnp.ones((1,), at.dtype)), 0.0)
    least = _least_spans(target, order, real, count, piece)
    least = jnp.where(jnp.sum(least) <= n, least, jnp.minimum(least, 1))
    spans = _largest_remainders(_floored_spans(fraction, least, real, n), real, n)
    index = jnp.concatenate([jnp.zeros((1,), spans.dtype), jnp.cumsum(spans)[:-1]])
    creases = jnp.zeros((n,), bool).at[jnp.where(real, index, n)].set(True, mode="drop")
    start_u, start_c = at[piece], index[piece]
    last = piece + 1 >= count
    end_u = jnp.where(last, 1.0, at[jnp.minimum(piece + 1, m - 1)])
    end_c = jnp.where(last, n, index[jnp.minimum(piece + 1, m - 1)])
    span = end_u - start_u
    share = jnp.where(span > 0, (u - start_u) / jnp.where(span > 0, span, 1.0), 0.0)
    # No corner (all at samples of weight 0): no crease, and the plain chord positions.
    plain = chord_fractions(target, True) * n
    return creases, jnp.where(count > 0, start_c + (end_c - start_c) * share, plain)


def _largest_remainders(
    shares: Float[Array, " m"], real: Bool[Array, " m"], n: int
) -> Int[Array, " m"]:
    """Whole numbers of spans summing to `n` from real-valued `shares` (summing to `n`
    up to rounding; 0 past the real pieces), by Hamilton's method: the whole part of
    each share, and one more for each of the largest fractional parts until the sum is
    `n` (ties to the earlier piece). Each result is the floor or the ceiling of its
    share, so whole-number floors under the shares are kept."""
    whole = jnp.floor(shares)
    # The shares sum to n only up to rounding: a whole part can come out one short
    # (1.9999999 -> 1, with a remainder near 1 that wins the extra span back).
    left = n - jnp.sum(jnp.where(real, whole, 0.0)).astype(jnp.int32)
    remainder = jnp.where(real, shares - whole, -1.0)
    rank = jnp.argsort(jnp.argsort(-remainder, stable=True), stable=True)
    return (jnp.where(real, whole, 0.0) + (real & (rank < left))).astype(jnp.int32)


def _least_spans(
    target: Float[Array, "m d"],
    order: Int[Array, " m"],
    real: Bool[Array, " m"],
    count: Int[Array, ""],
    piece: Int[Array, " m"],
) -> Int[Array, " m"]:
    """The fewest spans each piece between corners needs (`corner_creases`): 2 where it
    is bent (a sample more than `BENT_SPACINGS` mean sample spacings from the chord
    between its corners), 1 where it is straight, 0 past the `count` pieces."""
    m = target.shape[0]
    j = jnp.arange(m)
    # The chord of every piece, from its corner to the next (the last back to the first).
    start = target[order]
    end = target[jnp.where(j + 1 < count, order[jnp.minimum(j + 1, m - 1)], order[0])]
    a, chord = start[piece], (end - start)[piece]
    length2 = jnp.sum(chord**2, -1)
    t = jnp.clip(jnp.sum((target - a) * chord, -1) / jnp.where(length2 > 0, length2, 1.0), 0, 1)
    off = jnp.sqrt(jnp.sum((target - a - t[:, None] * chord) ** 2, -1))
    deviation = jax.ops.segment_max(off, piece, num_segments=m)
    gaps = jnp.sqrt(jnp.sum((jnp.roll(target, -1, axis=0) - target) ** 2, -1))
    spacing = jnp.sum(gaps) / jnp.maximum(jnp.sum(gaps > 0), 1)  # (padding has no gaps)
    bent = deviation > BENT_SPACINGS * spacing
    return jnp.where(real, jnp.where(bent, 2, 1), 0)


def _floored_spans(
    fraction: Float[Array, " m"], least: Int[Array, " m"], real: Bool[Array, " m"], n: int
) -> Float[Array, " m"]:
    """`n` spans shared in proportion to the pieces' arc-length `fraction`s, each piece
    at least its `least` (which must sum to at most `n`): the pieces whose share falls
    below their floor get the floor, and the others share the rest."""
    least = least.astype(fraction.dtype)

    def shares(fixed):
        budget = n - jnp.sum(jnp.where(fixed, least, 0.0))
        free = jnp.sum(jnp.where(fixed, 0.0, fraction))
        return jnp.where(fixed, least, budget * fraction / jnp.where(free > 0, free, 1.0))

    def grow(state):
        fixed, _ = state
        more = fixed | (real & (shares(fixed) < least))
        return more, jnp.any(more != fixed)

    # Fixing a piece at its floor only lowers the others' shares, so the fixed set grows
    # to a fixed point, within `count` rounds (not all can be fixed while the floors fit).
    fixed, _ = jax.lax.while_loop(
        lambda state: state[1], grow, (jnp.zeros(fraction.shape, bool), jnp.array(True))
    )
    return shares(fixed)


def canonical_order(target: Float[Array, "m d"], count=None) -> Int[Array, " m"]:
    """Indices that put a closed outline's samples in an order found from the samples
    as a set: from the lexicographically largest sample (the largest first coordinate,
    ties broken by the next ones), counter-clockwise in the plane of the first two
    coordinates (where the signed area is zero, as for a curve in a plane of other
    coordinates, the given direction). The first `count` samples are the outline (None:
    all); each padding position after them gets the new last sample (padding copies
    the last sample: its chords keep zero length), and the caller keeps the padding's
    weights (zero).

    `fit` gathers its samples (and weights) in this order before anything else, so the
    same samples cyclically shifted or reversed are the same arrays to it, bit for bit,
    and so is its result (issue #14: 400 samples of a serif '8' shifted or reversed had
    given errors up to 10x apart; `benchmarks/results/fit_quality_before.md`: 1.14x
    apart in median, up to 3.46x, on 38 real outlines). A sample repeated exactly at
    the largest position, or a polygon of zero signed area, can still tie."""
    M = target.shape[0]
    index = jnp.arange(M)
    count = M if count is None else count
    valid = index < count
    candidate = valid
    for axis in range(target.shape[1]):  # static: the dimension
        coordinate = jnp.where(candidate, target[:, axis], -jnp.inf)
        candidate = candidate & (coordinate == jnp.max(coordinate))
    start = jnp.argmax(candidate)
    # The signed area of the outline (padding copies the last sample: zero-length
    # chords, and the closing chord from the last copy is the outline's own).
    if target.shape[1] < 2:  # a curve in one coordinate has no orientation
        twice_area = jnp.zeros((), target.dtype)
    else:
        # In units of the largest offset from that sample: products of coordinates of
        # 1e160 would overflow (and of 1e-300 underflow), and the sign with them.
        offset = target[:, :2] - target[start, :2]
        reach = jnp.max(jnp.where(valid[:, None], jnp.abs(offset), 0.0))
        offset = offset / jnp.where(reach > 0, reach, 1.0)
        x, y = offset[:, 0], offset[:, 1]
        twice_area = jnp.sum(x * jnp.roll(y, -1) - jnp.roll(x, -1) * y)
    step = jnp.where(twice_area < 0, -1, 1)
    return jnp.mod(start + step * jnp.minimum(index, count - 1), count)


def initial_control(
    target: Float[Array, "m d"],
    weights: Float[Array, " m"],
    table: js.CurveStencil,
    boundary: str,
    smoothing,
    position=None,
    creases=None,
    offset=None,
) -> Float[Array, "n d"]:
    """Linear least-squares control points for chord-length parameters (from the first
    sample: `fit` has put a closed outline's samples in `canonical_order`).

    `table` is the curve's table: row `K` maps the control points to the limit curve at
    its dyadic sample `K` (`_curve.curve_tables`).

    Solves $(B^T W B + \\mu D^T D) P = B^T W T$ with a Cholesky factorization, where B maps
    control points to the curve at the samples' chord-length positions and D takes
    second differences; $\\mu$ is the user's smoothing plus a tiny ridge (1e-9 of the
    system's scale) that keeps the system positive definite when samples leave some
    control point unconstrained.

    `position`: each sample's position in control-point units instead of its chord
    fraction (`corner_creases`); `creases`: the creased control points (no second
    differences there). `offset`: a closed curve's phase, in spans: the samples'
    chord-length positions shifted by it along the control polygon (`FitData.phase`);
    0 is the start without it, exactly.
    """
    closed = boundary == "closed"
    N, n = len(table), table.n
    fractions = chord_fractions(target, closed) if position is None else position / n
    if offset is not None:
        # (Exactly the fractions at offset 0: `% 1` would move a fraction of 1, the
        # closing sample of an outline that repeats its first, to 0.)
        fractions = jnp.where(offset == 0, fractions, (fractions + offset / n) % 1)
    W = weights / jnp.sum(weights)
    D = second_differences(n, closed, target.dtype, creases)

    def solve_at(position):
        B = interpolate_rows(table, position, closed)
        normal = B.T @ (W[:, None] * B)
        ridge = 1e-9 * jnp.trace(normal) / n
        matrix = normal + (smoothing / n + ridge) * (D.T @ D) + ridge * jnp.eye(n, dtype=B.dtype)
        rhs = B.T @ (W[:, None] * target)
        # jax.scipy's Cholesky, not lineax's: lineax's structure check rejects the
        # arrays of a `shard_map` (their sharding is part of the structure it compares).
        return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(matrix), rhs)

    return solve_at(fractions * (N if closed else N - 1))
