r"""The limit curve of a control polygon as exact Bezier segments when it is a uniform
B-spline, else as a dense polyline of exact limit points."""

import math

import numpy as np

from .._analysis.limit import limit_curve
from .._refine import refine
from .._scheme.base import AbstractCurveScheme


def bspline_degree(scheme: AbstractCurveScheme) -> int | None:
    """1, 2 or 3 when the scheme's mask is the uniform B-spline mask
    $\binom{d+1}{k}/2^d$ of that degree (Chaikin, the cubic B-spline scheme,
    `LaneRiesenfeld(1..3)`, an equal `MaskScheme` or `CornerCutting(1/4, 3/4)`), else None.
    """
    mask = np.asarray(scheme.mask(), dtype=np.float64)
    d = len(mask) - 2
    if d not in (1, 2, 3):
        return None
    expected = np.array([math.comb(d + 1, k) for k in range(d + 2)]) / 2**d
    return d if np.allclose(mask, expected, rtol=0, atol=1e-12) else None


def _ghosted(points: np.ndarray) -> np.ndarray:
    # The clamped rules reflect a ghost point at each end at every level; for uniform
    # B-splines that is the same as reflecting once: 2 P_0 - P_1 and 2 P_{n-1} - P_{n-2}.
    return np.concatenate([2 * points[:1] - points[1:2], points, 2 * points[-1:] - points[-2:-1]])


def bezier_segments(points: np.ndarray, degree: int, boundary: str) -> np.ndarray:
    r"""Bezier control points, `(s, degree + 1, 2)`, of the uniform B-spline of `points`.

    Cubic (Boehm's conversion): the span between $P_i$ and $P_{i+1}$ has
    $B_0 = (P_{i-1} + 4P_i + P_{i+1})/6$, $B_1 = (2P_i + P_{i+1})/3$,
    $B_2 = (P_i + 2P_{i+1})/3$, $B_3 = (P_i + 4P_{i+1} + P_{i+2})/6$. Quadratic: the span
    of $P_i$ runs from the midpoint of $P_{i-1}P_i$ to that of $P_iP_{i+1}$ with control
    point $P_i$. Linear: the polygon itself. A closed curve has one span per point; an
    open one only the spans whose control points all exist (the curve that
    `refine(..., boundary="open")` converges to); a clamped one is the open curve of the
    polygon with reflected ghost ends, cut at the end points (a quadratic then starts and
    ends with half a span, which is straight).
    """
    if degree == 1:
        ring = np.concatenate([points, points[:1]]) if boundary == "closed" else points
        return np.stack([ring[:-1], ring[1:]], axis=1)
    if boundary == "clamped":
        points = _ghosted(points)
    if boundary == "closed":
        prev, nxt, nxt2 = (np.roll(points, s, axis=0) for s in (1, -1, -2))
        cur = points
    else:
        prev, cur, nxt = points[:-2], points[1:-1], points[2:]
        nxt2 = points[3:]
    if degree == 2:
        start, end = (prev + cur) / 2, (cur + nxt) / 2
        spans = np.stack([start, cur, end], axis=1)
        if boundary == "clamped":  # keep the halves from P_0 and to P_{n-1}
            spans = spans[1:-1]
            head = np.stack(
                [
                    points[1],
                    (points[1] + (points[1] + points[2]) / 2) / 2,
                    (points[1] + points[2]) / 2,
                ]
            )
            tail = np.stack(
                [
                    (points[-3] + points[-2]) / 2,
                    (points[-2] + (points[-3] + points[-2]) / 2) / 2,
                    points[-2],
                ]
            )
            spans = np.concatenate([head[None], spans, tail[None]])
        return spans
    if boundary != "closed":
        cur, nxt, prev = cur[:-1], nxt[:-1], prev[:-1]
    knots = (prev + 4 * cur + nxt) / 6
    ends = np.roll(knots, -1, axis=0) if boundary == "closed" else (cur + 4 * nxt + nxt2) / 6
    return np.stack([knots, (2 * cur + nxt) / 3, (cur + 2 * nxt) / 3, ends], axis=1)


def crease_pieces(points: np.ndarray, creases) -> list[np.ndarray]:
    """A creased closed polygon's clamped pieces, from each crease to the next (the
    last wrapping around), as `refine(creases=...)` cuts it."""
    cuts = sorted(int(c) for c in creases)
    n = len(points)
    ends = cuts[1:] + [cuts[0] + n]
    return [points[np.arange(c, e + 1) % n] for c, e in zip(cuts, ends)]


def creased_bezier_segments(points: np.ndarray, degree: int, creases) -> np.ndarray:
    """`bezier_segments` of a creased closed uniform B-spline: its clamped pieces'
    segments, one closed run from the first crease."""
    return np.concatenate([bezier_segments(piece, degree, "clamped")
                           for piece in crease_pieces(points, creases)])


def dense_curve(
    points: np.ndarray, scheme: AbstractCurveScheme, boundary: str, levels: int | None,
    creases=None,
) -> np.ndarray:
    """Exact limit points at the dyadic parameters of `levels` levels
    ([`jaxsubdiv.limit_curve`][]; default: enough for about 2048 points); the refined
    polygon when the scheme has no limit stencil. `creases`: a closed curve's creased
    control points (indices), or None."""
    if levels is None:
        levels = max(1, math.ceil(math.log2(2048 / len(points))))
    if creases is not None and len(creases):
        return np.asarray(limit_curve(points, scheme, levels, creases=list(creases)),
                          np.float64)
    try:
        return np.asarray(limit_curve(points, scheme, levels, boundary=boundary), np.float64)
    except ValueError:  # no limit stencil (a scheme proven not to converge)
        return np.asarray(refine(points, scheme, levels, boundary=boundary), np.float64)
