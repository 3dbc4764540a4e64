"""The one mask-driven refinement kernel behind every curve scheme.

A level of a binary stationary scheme is $Q_K = \\sum_j a_{K-2j} P_j$. Composing `k`
levels gives another such map with the composite mask
$a^{(k)}(z) = \\prod_{l<k} a(z^{2^l})$ and dilation $2^k$:

    Q^{(k)}_{2^k i + r} = sum_m W[r, m] P_{i + jmin + m},   W[r, m] = a^{(k)}_{r - 2^k (jmin + m)}

so `k` levels are one polyphase filter with a small table `W` (2^k rows, a few columns).
Applying it reads each control point a few times and writes each output once, which is
as close to a memory copy as a refinement can be. `W` is built with `jax.numpy` from the
scheme's mask, so it is differentiable in the scheme's parameters.

Closed curves apply the filter periodically. Open curves apply it to the polygon padded
with zeros and keep the run of outputs whose stencil lay inside the polygon at every
level (the zero padding meets only zero weights there). Clamped ends and creases are
not stationary, so they are refined one level at a time with ghost points.
"""

import math
from typing import NamedTuple

import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, Float


class Polyphase(NamedTuple):
    table: Float[Array, "rows width"]  # W[r, m]
    jmin: int  # control-point offset of column 0
    rows: int  # 2**levels


def composite_mask(mask: Float[Array, " L"], start: int, levels: int):
    """Coefficients and start index of $a^{(k)}(z) = \\prod_{l<k} a(z^{2^l})$."""
    length = mask.shape[-1]
    if levels == 0:
        return jnp.ones((1,), mask.dtype), 0
    composite = mask
    for _ in range(1, levels):
        # a^{(l+1)}(z) = a(z) a^{(l)}(z^2): upsample by two, then a `length`-tap filter
        # whose taps are static slices of one padded array (XLA fuses them into one loop;
        # measured 20x faster than shifted pads at 16 levels).
        up = jnp.stack([composite, jnp.zeros_like(composite)], axis=-1).reshape(-1)[:-1]
        padded = jnp.pad(up, (length - 1, length - 1))
        total = up.shape[-1] + length - 1
        composite = sum(
            mask[q] * padded[length - 1 - q : length - 1 - q + total] for q in range(length)
        )
    return composite, start * (2**levels - 1)


def polyphase(mask: Float[Array, " L"], start: int, levels: int) -> Polyphase:
    """The polyphase table of `levels` levels of the scheme with this mask."""
    composite, first = composite_mask(mask, start, levels)
    rows = 2**levels
    last = first + composite.shape[-1] - 1
    qmin, qmax = first // rows, last // rows
    blocks = qmax - qmin + 1
    padded = jnp.pad(composite, (first - qmin * rows, blocks * rows - (last - qmin * rows) - 1))
    # blocks[q - qmin, r] = a^{(k)}_{q * rows + r}, and W[r, m] uses q = -(jmin + m).
    table = padded.reshape(blocks, rows)[::-1].T
    return Polyphase(table, -qmax, rows)


def _filter(windows: list[Array], table: Array) -> Array:
    """sum_m table[r, m] * windows[m][..., i, :] -> (..., i, r, :)."""
    *batch, blocks, d = windows[0].shape
    rows, width = table.shape
    if 2 <= d <= 3 and math.prod(batch) * blocks >= 8 * width * d:
        # XLA:CPU vectorises the broadcast form below poorly when the minor axis is a
        # 2-D or 3-D point. Then one GEMM (blocks, width d) @ (width d, rows d) writes the
        # output in its final layout, with kernel[m d + c, r d + c'] = W[r, m] [c = c'].
        # Used only when the kernel is small next to the output (<= 1/8 of it); the
        # kernel's zeros cost d-fold multiply-adds, which pays only for d <= 3 (measured:
        # 1.1-4.6x faster at 1M points for d = 2; slower for d = 1, 8, 32).
        stacked = jnp.concatenate(windows, axis=-1).reshape(-1, width * d)
        eye = jnp.eye(d, dtype=table.dtype)
        kernel = table.T[:, None, :, None] * eye[None, :, None, :]
        out = jnp.matmul(
            stacked, kernel.reshape(width * d, rows * d), precision=lax.Precision.HIGHEST
        )
        return out.reshape(*batch, blocks, rows, d)
    # Few blocks: broadcast multiply-adds, which XLA fuses into one loop.
    out = None
    for m, window in enumerate(windows):
        term = window[..., :, None, :] * table[:, m][:, None]
        out = term if out is None else out + term
    return out


def apply_periodic(points: Float[Array, "*batch n d"], phase: Polyphase) -> Array:
    """All $2^k n$ outputs of a closed curve, in order."""
    n, d = points.shape[-2:]
    width = phase.table.shape[1]
    # windows[m][..., i, :] = P[(i + jmin + m) mod n]: static slices of the polygon
    # extended periodically once (cheaper for XLA than one roll per column).
    start = phase.jmin % n
    copies = -(-(start + n + width - 1) // n)
    extended = jnp.concatenate([points] * copies, axis=-2) if copies > 1 else points
    windows = [extended[..., start + m : start + m + n, :] for m in range(width)]
    out = _filter(windows, phase.table)
    return out.reshape(*points.shape[:-2], n * phase.rows, d)


def apply_window(
    points: Float[Array, "*batch n d"], phase: Polyphase, first: int, count: int
) -> Array:
    """Outputs $K$ = `first`, ..., `first + count - 1` of the infinite (non-periodic)
    refinement of `points`, with zeros standing for the points beyond the ends."""
    n, d = points.shape[-2:]
    rows, width = phase.rows, phase.table.shape[1]
    i0 = first // rows
    i1 = (first + count - 1) // rows
    lo = i0 + phase.jmin  # first control point index any output needs
    hi = i1 + phase.jmin + width - 1
    pad_lo, pad_hi = max(0, -lo), max(0, hi - (n - 1))
    pad = [(0, 0)] * (points.ndim - 2) + [(pad_lo, pad_hi), (0, 0)]
    padded = jnp.pad(points, pad)
    blocks = i1 - i0 + 1
    windows = [
        padded[..., lo + pad_lo + m : lo + pad_lo + m + blocks, :] for m in range(width)
    ]
    out = _filter(windows, phase.table).reshape(*points.shape[:-2], blocks * rows, d)
    offset = first - i0 * rows
    return out[..., offset : offset + count, :]


# --------------------------------------------------------------------------------------
# Static bookkeeping: which outputs an open or clamped level keeps.


def parity_ranges(start: int, length: int):
    """(lowest, highest) mask index of each parity."""
    ranges = []
    for p in (0, 1):
        ks = [k for k in range(start, start + length) if k % 2 == p]
        ranges.append((min(ks), max(ks)) if ks else None)
    return ranges


def open_run(n: int, start: int, length: int) -> tuple[int, int]:
    """(first, count) of the outputs of one open level on `n` points.

    Output $K$ of parity $p$ has a full stencil inside $P_0..P_{n-1}$ iff
    $\\max_p \\le K \\le 2(n-1) + \\min_p$ over the mask indices of parity $p$; the open
    rule keeps the longest run of consecutive outputs that all have one.
    """
    ranges = parity_ranges(start, length)
    if any(r is None for r in ranges):
        raise ValueError("a mask needs coefficients of both parities")
    first = max(hi for _, hi in ranges) - 1
    last = min(2 * (n - 1) + lo for lo, _ in ranges) + 1
    return first, last - first + 1


def open_levels(n: int, start: int, length: int, levels: int) -> tuple[int, int]:
    """(first, count) of the open run after `levels` levels, in level-`levels` indices.

    One level maps `n` points to `2n - c` (with `first` a constant `f`), so while the
    polygon does not shrink (`n >= c`) the closed forms `c + 2^k (n - c)` and
    `f (2^k - 1)` give any number of levels in a few integer operations.
    """
    if levels == 0:
        return 0, n
    f, count = open_run(n, start, length)
    c = 2 * n - count
    if n >= c:
        scale = 2**levels
        return f * (scale - 1), c + scale * (n - c)
    first = 0
    for _ in range(levels):  # a shrinking polygon: below one point within n levels
        level_first, n = open_run(n, start, length)
        first = 2 * first + level_first
        if n < 1:
            return first, n
    return first, n


def clamped_run(n: int, center: float) -> tuple[int, int]:
    """(first, count) of the outputs at curve parameters in [0, n - 1] (one level)."""
    # Integer arithmetic (the center is an integer or a half-integer): no float overflow
    # for huge n.
    first = math.ceil(center)
    last = 2 * (n - 1) + math.floor(center)
    return first, last - first + 1


def clamped_count(n: int, center: float) -> int:
    _, count = clamped_run(n, center)
    # Primal schemes replace their two end outputs by the end points; dual ones add them.
    return count if float(center).is_integer() else count + 2


def clamped_levels(n: int, center: float, levels: int) -> int:
    """Number of points after `levels` clamped levels: a primal level maps n to 2n - 1,
    a dual one n to 2n, so `1 + 2^k (n - 1)` and `2^k n` (no loop over the levels)."""
    if float(center).is_integer():
        return 1 + 2**levels * (n - 1)
    return 2**levels * n


def ghost_reach(n: int, start: int, length: int, center: float) -> tuple[int, int]:
    """How many ghost points one clamped level needs before and after the polygon."""
    first, count = clamped_run(n, center)
    last_k = first + count - 1
    end = start + length - 1
    j_lo = -((end - first) // 2)  # ceil((first - end) / 2)
    j_hi = (last_k - start) // 2
    return max(0, -j_lo), max(0, j_hi - (n - 1))


def with_ghosts(points: Array, before: int, after: int, kind: str) -> Array:
    """Extend a polygon by ghost points: reflected through the end point, or repeated."""
    n = points.shape[-2]
    p0, pn = points[..., :1, :], points[..., -1:, :]
    if kind == "repeat":
        head = jnp.repeat(p0, before, axis=-2)
        tail = jnp.repeat(pn, after, axis=-2)
    else:
        # P_{-q} = 2 P_0 - P_q (q capped at n - 1), and likewise at the far end.
        head_idx = [min(q, n - 1) for q in range(before, 0, -1)]
        tail_idx = [n - 1 - min(q, n - 1) for q in range(1, after + 1)]
        head = 2 * p0 - points[..., head_idx, :]
        tail = 2 * pn - points[..., tail_idx, :]
    return jnp.concatenate([head, points, tail], axis=-2)


def clamped_level(points: Array, mask: Array, start: int, center: float, kind: str) -> Array:
    """One clamped level: interior outputs from ghost-extended points, ends pinned."""
    n = points.shape[-2]
    length = mask.shape[-1]
    before, after = ghost_reach(n, start, length, center)
    extended = with_ghosts(points, before, after, kind)
    first, count = clamped_run(n, center)
    # In the extended polygon index j is shifted by `before`, so output K by 2 * before.
    inner = apply_window(extended, polyphase(mask, start, 1), first + 2 * before, count)
    ends = points[..., :1, :], points[..., -1:, :]
    if float(center).is_integer():
        return jnp.concatenate([ends[0], inner[..., 1:-1, :], ends[1]], axis=-2)
    return jnp.concatenate([ends[0], inner, ends[1]], axis=-2)
