"""Corners of a closed outline's samples: [`fitting.find_corners`][] (host, NumPy).

A corner is where the outline turns through a large angle within a short arc: the
angle between the chord that ends a distance `skip` before a sample and the one that
starts `skip` after it, each reaching out to `scale` (measured by arc length along the
samples' polyline, so uneven spacing does not matter). A smooth bend of radius R turns
through about `(scale + skip) / R` radians there, a corner through its full angle.
Clean samples measure from the sample itself (`skip` 0, `scale` 3 spacings). A traced
bitmap's contour rounds every corner over about a pixel and wobbles on its staircase,
so it is measured in pixels instead (`pixel=`): the first pixel on each side skipped,
chords over the next three. Corners are the samples where this angle is at least
`angle` and largest within `scale + skip` on both sides.
"""

import numpy as np
from jaxtyping import ArrayLike, Float, Int

from jaxsubdiv.validation import check_creasable, is_traced


#: Default smallest turning angle of a corner, in degrees.
CORNER_ANGLE = 50.0
#: Default scale of the turning angle, in median sample spacings.
CORNER_SPACINGS = 3.0
#: With `pixel=`: the default `scale` and `skip`, in pixels (see `find_corners`).
PIXEL_SCALE = 4.0
PIXEL_SKIP = 1.0


def _turning(points: np.ndarray, s: np.ndarray, total: float, scale: float,
             skip: float = 0.0) -> np.ndarray:
    """The angle (radians, in [0, pi]) between the chord from `scale` to `skip` before
    each sample and the one from `skip` to `scale` after it, along the closed polyline
    (arc-length positions `s`)."""
    closed_s = np.append(s, total)
    closed_p = np.vstack([points, points[:1]])

    def at(position):
        position = np.mod(position, total)
        return np.stack([np.interp(position, closed_s, closed_p[:, k])
                         for k in range(points.shape[1])], axis=1)

    near_before, near_after = (at(s - skip), at(s + skip)) if skip > 0 else (points, points)
    before, after = near_before - at(s - scale), at(s + scale) - near_after
    nb, na = np.linalg.norm(before, axis=1), np.linalg.norm(after, axis=1)
    ok = (nb > 0) & (na > 0)
    cosine = np.einsum("ij,ij->i", before, after) / np.where(ok, nb * na, 1.0)
    return np.where(ok, np.arccos(np.clip(cosine, -1.0, 1.0)), 0.0)


def _length(value, name: str, unit: float, allow_zero: bool = False) -> float:
    """A length argument of `find_corners`, checked, in the normalised units."""
    value = float(value)
    if not (np.isfinite(value) and (value >= 0 if allow_zero else value > 0)):
        what = "a length >= 0" if allow_zero else "a positive length"
        raise ValueError(f"`find_corners({name}=...)` must be {what}; got {value}.")
    return value / unit


def find_corners(
    samples: Float[ArrayLike, "m d"],
    *,
    angle: float = CORNER_ANGLE,
    scale: float | None = None,
    skip: float | None = None,
    pixel: float | None = None,
) -> Int[np.ndarray, " k"]:
    """Indices of the samples at corners of a closed outline, strongest first.

    **Arguments:**

    - `samples`: `(m, d)` ordered samples of a closed outline (NumPy or concrete arrays).
    - `angle`: the smallest turning angle of a corner, in degrees (default 50; a square's
      corners turn 90, a five-point star's tips 144 and its inner corners 72).
    - `scale`: how far along the outline, on each side of a sample, the turning is
      measured, in the samples' units (default: 3 median sample spacings, or 4 pixels
      with `pixel`). Bends of radius below about `(scale + skip) / radians(angle)`
      count as corners; corners closer than `scale + skip` to a stronger one do not.
      Keep it well below the shortest edge between corners (a square sampled 3 times
      per side has no corners at this resolution).
    - `skip`: the arc length next to the sample left out of each chord (default 0, or
      1 pixel with `pixel`): the chords run from `skip` to `scale` on each side, so a
      corner rounded within `skip` still counts at its full angle. Less than `scale`.
    - `pixel`: for the contour of a traced bitmap (`jaxsubdiv.io.read_image`), the
      size of a pixel in the samples' units (1.0 for `read_image`'s own). Its corners
      are rounded over about a pixel and its edges wobble a pixel on the staircase, so
      `scale` and `skip` default to 4 and 1 pixels: on the 24 glyph bitmaps of
      `benchmarks/bench_potrace.py`, 3 of 160 corners missed against 10 at the
      sample-spacing default, with one tight bend taken for a corner in both; on traced
      polygons, 6 of 1,260 against 290 (`benchmarks/bench_corners.py`).

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
    unit = float(np.max(np.abs(offsets)))
    unit = unit if unit > 0 else 1.0
    points = offsets / unit
    angle = float(angle)
    if not 0.0 < angle < 180.0:
        raise ValueError(f"`find_corners(angle=...)` must be in (0, 180) degrees; got {angle}.")
    if pixel is not None:
        pixel = _length(pixel, "pixel", unit)
    if scale is not None:
        scale = _length(scale, "scale", unit)
    if skip is not None:
        skip = _length(skip, "skip", unit, allow_zero=True)
    gaps = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    total = float(gaps.sum())
    if total == 0:
        return np.zeros((0,), np.int64)
    s = np.concatenate([[0.0], np.cumsum(gaps)[:-1]])
    if scale is None:
        scale = (PIXEL_SCALE * pixel if pixel is not None
                 else CORNER_SPACINGS * float(np.median(gaps[gaps > 0])))
    if skip is None:
        skip = PIXEL_SKIP * pixel if pixel is not None else 0.0
    if skip >= scale:
        raise ValueError(
            f"`find_corners(skip=...)` must be less than `scale`; got skip {skip * unit:g} "
            f"and scale {scale * unit:g} (in the samples' units).")
    # Chords longer than a quarter turn measure nothing local; a short contour keeps
    # the ratio of skip to scale.
    shrink = min(1.0, total / 4 / scale)
    scale, skip = scale * shrink, skip * shrink
    turning = _turning(points, s, total, scale, skip)
    candidates = np.nonzero(turning >= np.radians(angle))[0]
    # Largest within `scale + skip` on both sides (arc length, cyclic; a sharp tip
    # blunted by the pixels turns twice within about `2 skip`); ties to the first.
    order = candidates[np.argsort(-turning[candidates], kind="stable")]
    reach = scale + skip
    kept: list[int] = []
    for i in order:
        distance = np.abs(s[kept] - s[i]) if kept else np.zeros(0)
        distance = np.minimum(distance, total - distance)
        if not np.any(distance < reach):
            kept.append(int(i))
    return np.asarray(kept, np.int64)


def corner_flags(corners, target, weights, scheme, n: int, boundary: str, pin_ends: bool,
                 ordered: bool, caller: str = "fit(corners=...)") -> np.ndarray | None:
    """`fit(corners=...)` checked: per-sample flags `(m,)` of the corners, or None for
    a smooth fit (no corners asked for, or none found). `caller` names the argument in
    errors."""
    if corners is None:
        return None
    if boundary != "closed":
        raise ValueError(
            f"`{caller}` needs boundary='closed'; got boundary={boundary!r}. An open "
            "stroke's corners split it into strokes: fit each with pin_ends=True."
        )
    check_creasable(scheme, caller)
    m = target.shape[0]
    if isinstance(corners, str):
        if corners != "auto":
            raise ValueError(
                f"`{caller}` must be None, 'auto' or sample indices; got {corners!r}."
            )
        if is_traced(target):
            raise ValueError(
                f"`{caller}` as 'auto' finds corners on the host: the target must be "
                "concrete, not traced; under `jax.jit` (or `grad`) pass the corner samples' "
                "indices (from `fitting.find_corners`) instead."
            )
        index = find_corners(np.asarray(target))
        index = index[:n]  # the strongest, at most one per control point
    else:
        if not ordered:
            raise ValueError(
                f"`{caller}` as sample indices needs ordered samples (ordered=True): "
                "with ordered=False the samples are reordered first. Use corners='auto'."
            )
        index = np.asarray(corners)
        if index.ndim != 1 or (index.size and not np.issubdtype(index.dtype, np.integer)):
            raise ValueError(
                f"`{caller}` must be a 1-d sequence of sample indices; got {corners!r}."
            )
        if np.any((index < -m) | (index >= m)):
            raise ValueError(f"`{caller}` must be indices in [0, {m - 1}].")
        index = np.unique(np.mod(index, m))
        if index.size > n:
            raise ValueError(
                f"`{caller}` has {index.size} corners for n_control={n}: every corner "
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
