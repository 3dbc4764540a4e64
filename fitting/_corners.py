"""Corners of a closed outline's samples: [`fitting.find_corners`][] (host, NumPy).

A corner is where the outline turns through a large angle within a short arc: the
angle between the chords from a sample to the points `scale` before and after it
along the samples' polyline (measured by arc length, so uneven spacing does not
matter). A smooth bend of radius R turns through about `scale / R` radians there, a
corner through its full angle; the pixel staircase of a traced image turns back and
forth within a pixel and averages out over a few. Corners are the samples where this
angle is at least `angle` and largest within `scale` on both sides.
"""

import numpy as np
from jaxtyping import ArrayLike, Float, Int

from jaxsubdiv.validation import check_creasable, is_traced


#: Default smallest turning angle of a corner, in degrees.
CORNER_ANGLE = 50.0
#: Default scale of the turning angle, in median sample spacings.
CORNER_SPACINGS = 3.0


def _turning(points: np.ndarray, s: np.ndarray, total: float, scale: float) -> np.ndarray:
    """The angle (radians, in [0, pi]) between the chords to the points `scale` before
    and after each sample, along the closed polyline (arc-length positions `s`)."""
    closed_s = np.append(s, total)
    closed_p = np.vstack([points, points[:1]])

    def at(position):
        position = np.mod(position, total)
        return np.stack([np.interp(position, closed_s, closed_p[:, k])
                         for k in range(points.shape[1])], axis=1)

    before, after = points - at(s - scale), at(s + scale) - points
    nb, na = np.linalg.norm(before, axis=1), np.linalg.norm(after, axis=1)
    ok = (nb > 0) & (na > 0)
    cosine = np.einsum("ij,ij->i", before, after) / np.where(ok, nb * na, 1.0)
    return np.where(ok, np.arccos(np.clip(cosine, -1.0, 1.0)), 0.0)


def find_corners(
    samples: Float[ArrayLike, "m d"],
    *,
    angle: float = CORNER_ANGLE,
    scale: float | None = None,
) -> Int[np.ndarray, " k"]:
    """Indices of the samples at corners of a closed outline, strongest first.

    **Arguments:**

    - `samples`: `(m, d)` ordered samples of a closed outline (NumPy or concrete arrays).
    - `angle`: the smallest turning angle of a corner, in degrees (default 50; a square's
      corners turn 90, a five-point star's tips 144 and its inner corners 72).
    - `scale`: the arc length over which the turning is measured, in the samples' units
      (default: 3 median sample spacings; for a traced image, a few pixels). Bends of
      radius below about `scale / radians(angle)` count as corners; corners closer than
      `scale` to a stronger one do not. Keep it well below the shortest edge between
      corners (a square sampled 3 times per side has no corners at this resolution).

    **Returns:** an integer array of sample indices, sorted by decreasing turning angle.
    """
    points = np.asarray(samples, dtype=np.float64)
    if points.ndim != 2 or points.shape[0] < 3 or points.shape[1] < 2:
        raise ValueError(
            f"`find_corners(samples=...)` must be (m, d) with m >= 3 and d >= 2; got shape "
            f"{points.shape}."
        )
    if not np.all(np.isfinite(points)):
        raise ValueError("`find_corners(samples=...)` has non-finite values (NaN or inf).")
    # In units of the largest offset from the bounding box's centre: squared chords of
    # coordinates near 1e300 would overflow (angles and spacings are scale-free).
    offsets = points - (points.min(axis=0) / 2 + points.max(axis=0) / 2)
    unit = np.max(np.abs(offsets))
    points = offsets / (unit if unit > 0 else 1.0)
    angle = float(angle)
    if not 0.0 < angle < 180.0:
        raise ValueError(f"`find_corners(angle=...)` must be in (0, 180) degrees; got {angle}.")
    gaps = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    total = float(gaps.sum())
    if total == 0:
        return np.zeros((0,), np.int64)
    s = np.concatenate([[0.0], np.cumsum(gaps)[:-1]])
    if scale is None:
        scale = CORNER_SPACINGS * float(np.median(gaps[gaps > 0]))
    else:
        scale = float(scale)
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(
                f"`find_corners(scale=...)` must be a positive length; got {scale}.")
        scale = scale / (unit if unit > 0 else 1.0)
    scale = min(scale, total / 4)  # chords longer than a quarter turn measure nothing local
    turning = _turning(points, s, total, scale)
    candidates = np.nonzero(turning >= np.radians(angle))[0]
    # Largest within `scale` on both sides (arc length, cyclic); ties to the first.
    order = candidates[np.argsort(-turning[candidates], kind="stable")]
    kept: list[int] = []
    for i in order:
        distance = np.abs(s[kept] - s[i]) if kept else np.zeros(0)
        distance = np.minimum(distance, total - distance)
        if not np.any(distance < scale):
            kept.append(int(i))
    return np.asarray(kept, np.int64)


def corner_flags(corners, target, weights, scheme, n: int, boundary: str, pin_ends: bool,
                 ordered: bool) -> np.ndarray | None:
    """`fit(corners=...)` checked: per-sample flags `(m,)` of the corners, or None for
    a smooth fit (no corners asked for, or none found)."""
    if corners is None:
        return None
    if boundary != "closed":
        raise ValueError(
            f"`fit(corners=...)` needs boundary='closed'; got boundary={boundary!r}. An open "
            "stroke's corners split it into strokes: fit each with pin_ends=True."
        )
    check_creasable(scheme, "fit(corners=...)")
    m = target.shape[0]
    if isinstance(corners, str):
        if corners != "auto":
            raise ValueError(
                f"`fit(corners=...)` must be None, 'auto' or sample indices; got {corners!r}."
            )
        if is_traced(target):
            raise ValueError(
                "`fit(corners='auto')` finds corners on the host: the target must be "
                "concrete, not traced; under `jax.jit` (or `grad`) pass the corner samples' "
                "indices (from `fitting.find_corners`) instead."
            )
        index = find_corners(np.asarray(target))
        index = index[:n]  # the strongest, at most one per control point
    else:
        if not ordered:
            raise ValueError(
                "`fit(corners=...)` as sample indices needs ordered samples (ordered=True): "
                "with ordered=False the samples are reordered first. Use corners='auto'."
            )
        index = np.asarray(corners)
        if index.ndim != 1 or (index.size and not np.issubdtype(index.dtype, np.integer)):
            raise ValueError(
                f"`fit(corners=...)` must be a 1-d sequence of sample indices; got {corners!r}."
            )
        if np.any((index < -m) | (index >= m)):
            raise ValueError(f"`fit(corners=...)` must be indices in [0, {m - 1}].")
        index = np.unique(np.mod(index, m))
        if index.size > n:
            raise ValueError(
                f"`fit(corners=...)` has {index.size} corners for n_control={n}: every corner "
                "is a control point, so use at least as many control points as corners."
            )
    if index.size and not is_traced(weights):
        # A corner at a sample of weight 0 is not data: drop it (the fit ignores it).
        index = index[np.asarray(weights)[index] > 0]
    if index.size == 0:
        return None
    flags = np.zeros(m, bool)
    flags[index] = True
    return flags
