"""[`fitting.pixel_error`][]: a curve's error against the pixels a contour was traced from.

A contour traced from a bitmap (`jaxsubdiv.io.read_image`: level lines interpolated
between pixel centres, which sit at integer coordinates) does not say where the
outline is, only between which pixel centres it passes: each sample lies on the unit
segment between a pixel centre inside and one outside, and the outline crosses that
segment *somewhere*. Where the outline turns by more than the pixel grid resolves,
the traced polyline cuts it short: a star's tips by up to 1.2-1.4 px (at 256 and 1024
px, `benchmarks/results/pixel_tolerance.md`), the corner of an axis-aligned square by
0.35 px. The two-sided error against the samples ([`fitting.FitResult`][]'s
`max_error`) then charges a curve that follows the true outline with that chamfer, and
a tolerance below it is met only by curves that cut the corners as the samples do.

The pixel error charges only what the pixels contradict (host, NumPy):

- each sample's *pixel segment* (between the two pixel centres it lies between; a point
  for a sample at a pixel centre) to the curve: 0 when the curve crosses it;
- each curve point to the *band*, the union of the pixel cells (unit squares with
  pixel centres at their corners) that the traced contour runs through: 0 inside it.
  Outside the band, the four pixel centres around a point are all on one side, so the
  pixels say the outline does not pass there.

A curve that crosses every pixel segment and stays in the band has pixel error 0, also
where the traced contour cuts a corner short. Only a feature thinner than a pixel can
pass between pixel centres unseen: the pixels cannot show it, so a curve is charged for
it, conservatively, whether it is a spike of the fit or the outline's own sharp tip (a
45-degree star tip centred between two columns of pixel centres pokes 0.9-1.05 px out
of the band, `benchmarks/results/pixel_tolerance.md`; the star of
`tests/test_fit_pixels.py`, turned 0.3 rad off the grid's axes, scores 0.07 px).
"""

import math
from typing import NamedTuple

import numpy as np
from jaxtyping import ArrayLike, Float

import jaxsubdiv as js
from jaxsubdiv.validation import is_traced

from ._result import FitResult


#: The curve is evaluated (limit points, then chords) at about this spacing, in pixels,
#: and the pixel segments probed at it (`pixel_error`'s resolution).
PIXEL_SPACING = 0.05
#: A coordinate within this of an integer (in pixels) is on a row or column of pixel
#: centres (float32 rounding of coordinates up to a few thousand pixels).
_ON_GRID = 1e-3
#: The most limit points evaluated (a stencil table of `width` weights each): beyond,
#: the rest of the spacing comes from chords between them, whose sagitta is then
#: counted too (4M limit points about 0.2 px apart: some 800,000 px of outline).
_MOST_POINTS = 2**22
#: Pixel cells searched per curve point for the nearest one (`_points_to_band`).
_CELLS_SEARCHED = 16


class PixelError(NamedTuple):
    """[`fitting.pixel_error`][]'s result, in pixels."""

    #: The larger of the two halves.
    max_error: float
    #: The largest distance from a sample's pixel segment to the curve.
    max_segment_distance: float
    #: The largest distance from a point of the curve to the band of pixel cells the
    #: traced contour runs through.
    max_band_distance: float


def pixel_error(
    curve: FitResult | Float[ArrayLike, "N 2"],
    samples: Float[ArrayLike, "m 2"],
) -> PixelError:
    """A curve's two-sided maximum error against the pixels `samples` were traced from.

    For contours of a bitmap as `jaxsubdiv.io.read_image` traces them (pixel centres at
    integer coordinates; each sample between two of them, so one of its coordinates is
    an integer), not resampled. The pixels only say between which pixel centres the
    outline passes, so this charges only what they contradict:

    - **pixel segments**: the distance from each sample's pixel segment (the unit
      segment between the two pixel centres it lies between) to the curve: 0 when the
      curve crosses it;
    - **the band**: the distance from each point of the curve to the band of pixel
      cells (the unit squares between four pixel centres) that the traced contour runs
      through: 0 inside it (outside it, the pixel centres around a point are all on
      one side, so the outline does not pass there).

    A curve that follows the true outline scores about 0 also where the traced contour
    cuts a corner short (a star's tips by about a pixel), where its `max_error` against
    the samples does not; never more than that `max_error`, up to the resolution of
    each (the samples lie on their pixel segments, their polyline in the band).
    Features thinner than a pixel are charged as they poke out of the band, a spike of
    the fit and a sharp tip of the outline alike (a 45-degree tip centred between two
    columns of pixel centres: 0.9-1.05 px). `jaxsubdiv fit --tolerance` measures
    traced PNG contours this way, as does [`fitting.fit_tolerance`][] with
    `error="pixel"`. The module docstring of `fitting._pixels` says why;
    `docs/fitting.md`, "Traced bitmaps: the pixel error", what was measured.

    Host-side, not under `jax.jit`: a `FitResult`'s limit points come from a compiled
    curve stencil (one program per count and levels, about a second to compile), the
    rest is NumPy and a k-d tree. Resolution: limit points about 0.2 px apart, points
    every `PIXEL_SPACING` (0.05 px) along their chords, each pixel segment probed at
    its sample and every 0.05 px; the segments' half is over by at most 0.05 px, the
    band's under by at most 0.025 px (plus the chords' sagitta, 0.005 px on a bend of
    radius 1 px).

    **Arguments:**

    - `curve`: a closed curve: a [`fitting.FitResult`][] (one fit, not a batch; its
      limit curve is evaluated densely, creases and fitted scheme parameters included),
      or the points `(N, 2)` of a closed polyline, in pixels.
    - `samples`: the traced contour `(m, 2)`, closed (its last point not repeated), in
      order, in pixels.

    **Returns:** a [`fitting.PixelError`][]: `max_error` and its two halves, in pixels.
    """
    samples = _traced_samples(samples)
    if isinstance(curve, FitResult):
        points = _dense_limit_curve(curve)
    else:
        if is_traced(curve):
            raise TypeError("`pixel_error(curve=...)` runs on the host: not under `jax.jit`.")
        points = np.asarray(curve, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2:
            raise ValueError(
                "`pixel_error(curve=...)` must be a FitResult or the points (N, 2) of a "
                f"polyline, N >= 2; got shape {points.shape}.")
        if not np.all(np.isfinite(points)):
            raise ValueError("`pixel_error(curve=...)` has non-finite points.")
    points = _densified(points, PIXEL_SPACING)
    segments = _segments_to_curve(samples, points)
    band = _points_to_band(points, _band_cells(samples))
    return PixelError(max(segments, band), segments, band)


def traced_problem(samples: Float[ArrayLike, "m 2"]) -> str | None:
    """Why `samples` (finite, `(m, 2)`, m >= 3) are not a closed contour as
    `jaxsubdiv.io.read_image` traces it, or None: each sample needs an integer
    coordinate (it lies between two pixel centres of a row or column), and each chord
    between consecutive samples must lie in one pixel cell (a contour subsampled or
    resampled does not)."""
    samples = np.asarray(samples, dtype=np.float64)
    off_grid = np.abs(samples - np.round(samples)).min(axis=1) > _ON_GRID
    if off_grid.any():
        k = int(np.argmax(off_grid))
        return (f"{int(off_grid.sum())} of {len(samples)} samples (the first: #{k}, "
                f"{samples[k].tolist()}) lie between no two pixel centres (neither "
                "coordinate is an integer)")
    after = np.roll(samples, -1, axis=0)
    cell = np.floor(0.5 * (samples + after))
    outside = np.any((np.minimum(samples, after) < cell - _ON_GRID)
                     | (np.maximum(samples, after) > cell + 1 + _ON_GRID), axis=1)
    if outside.any():
        k = int(np.argmax(outside))
        return (f"{int(outside.sum())} chords between consecutive samples cross more than "
                f"one pixel cell (the first: samples #{k} and #{(k + 1) % len(samples)}, "
                f"{samples[k].tolist()} and {after[k].tolist()})")
    return None


def _traced_samples(samples, caller: str = "pixel_error(samples=...)") -> np.ndarray:
    """`samples` as float64, checked to be a closed contour as traced (`traced_problem`)."""
    if is_traced(samples):
        raise TypeError(f"`{caller}` runs on the host: not under `jax.jit`.")
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 2 or samples.shape[1] != 2 or len(samples) < 3:
        raise ValueError(
            f"`{caller}` must be a traced contour's points (m, 2), m >= 3; "
            f"got shape {samples.shape}.")
    if not np.all(np.isfinite(samples)):
        raise ValueError(f"`{caller}` has non-finite points.")
    problem = traced_problem(samples)
    if problem is not None:
        raise ValueError(
            f"`{caller}`: {problem}: give the contour as `jaxsubdiv.io.read_image` traced "
            "it, in pixels, not resampled or subsampled.")
    return samples


def _dense_limit_curve(result: FitResult) -> np.ndarray:
    """The result's limit curve at dyadic parameters, levels enough for chords of about
    4 `PIXEL_SPACING` (its chords halve per level; `_densified` does the rest)."""
    if result.control_points.ndim != 2:
        raise ValueError(
            "`pixel_error(curve=...)` takes one fit, not a batch: index it first "
            f"(control points of shape {tuple(result.control_points.shape)}).")
    if result.control_points.shape[1] != 2 or result.boundary != "closed":
        raise ValueError("`pixel_error(curve=...)` measures closed plane curves; got a fit "
                         f"with boundary {result.boundary!r} in "
                         f"{result.control_points.shape[1]} dimensions.")
    coarse = np.asarray(result.curve, dtype=np.float64)
    if not np.all(np.isfinite(coarse)):
        raise ValueError("`pixel_error(curve=...)`: the fit's curve has non-finite points.")
    chord = float(np.max(np.linalg.norm(np.diff(coarse, axis=0), axis=1), initial=0.0))
    n = result.control_points.shape[0]
    extra = max(0, math.ceil(math.log2(max(chord, 1e-300) / (4 * PIXEL_SPACING))))
    levels = result.levels + extra
    while levels > result.levels and n * 2**levels > _MOST_POINTS:
        levels -= 1  # (then more of the spacing comes from chords: see _MOST_POINTS)
    creases = None if result.creases is None else np.asarray(result.creases, dtype=bool)
    if creases is not None and not creases.any():
        creases = None
    table = js.curve_stencil(result.scheme, n, levels, boundary=result.boundary,
                             creases=creases)
    return np.asarray(table.apply(result.control_points), dtype=np.float64)


def _densified(points: np.ndarray, spacing: float) -> np.ndarray:
    """The closed polyline through `points` (repeated points dropped) with points added
    on each chord, at most `spacing` apart."""
    ends = np.vstack([points, points[:1]])
    chords = np.diff(ends, axis=0)
    length = np.linalg.norm(chords, axis=1)
    ends, chords, length = ends[:-1][length > 0], chords[length > 0], length[length > 0]
    if not len(chords):  # a curve collapsed to a point
        return points[:1]
    pieces = np.ceil(length / spacing).astype(np.int64)
    start = np.repeat(np.arange(len(chords)), pieces)
    fraction = (np.arange(pieces.sum()) - np.repeat(np.cumsum(pieces) - pieces, pieces)) / \
        np.repeat(pieces, pieces)
    return ends[start] + fraction[:, None] * chords[start]


def _segments_to_curve(samples: np.ndarray, points: np.ndarray) -> float:
    """The largest distance from a sample's pixel segment to the polyline `points`
    (chords of at most `PIXEL_SPACING`), each segment probed at the sample and every
    `PIXEL_SPACING`: over by at most `PIXEL_SPACING` (half of it from the probes, half
    from the nearest vertex's chords)."""
    from scipy.spatial import cKDTree

    # The segment runs along the axis whose coordinate is farther from an integer (the
    # other one is an integer, to rounding); a sample exactly at a pixel centre is its
    # own segment.
    fraction = np.abs(samples - np.round(samples))
    along = np.argmax(fraction, axis=1)
    rows = np.flatnonzero(fraction.max(axis=1) > 0)
    low, high = samples.copy(), samples.copy()
    low[rows, along[rows]] = np.floor(samples[rows, along[rows]])
    high[rows, along[rows]] = np.ceil(samples[rows, along[rows]])
    t = np.linspace(0.0, 1.0, int(round(1 / PIXEL_SPACING)) + 1)
    tree = cKDTree(points)
    largest = 0.0
    for block in range(0, len(samples), 8192):  # bounded memory
        a, b = low[block:block + 8192], high[block:block + 8192]
        probes = np.concatenate([samples[block:block + 8192, None, :],
                                 a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]],
                                axis=1)
        distance = _points_to_curve(probes.reshape(-1, 2), points, tree)
        largest = max(largest, float(distance.reshape(len(a), -1).min(axis=1).max()))
    return largest


def _points_to_curve(probes: np.ndarray, points: np.ndarray, tree) -> np.ndarray:
    """Each probe's distance to the closed polyline `points` (the k-d `tree` of its
    vertices; chords of at most `PIXEL_SPACING`): to its nearest vertex's two chords,
    over by at most half a chord."""
    count = len(points)
    out = np.empty(len(probes))
    for block in range(0, len(probes), 65536):  # bounded memory
        p = probes[block:block + 65536]
        _, nearest = tree.query(p)
        out[block:block + 65536] = np.minimum(
            _to_chords(p, points[nearest], points[(nearest - 1) % count]),
            _to_chords(p, points[nearest], points[(nearest + 1) % count]))
    return out


def _to_chords(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The distance from each point `p` to the chord from `a` to `b` (row by row)."""
    chord = b - a
    length2 = np.einsum("ij,ij->i", chord, chord)
    t = np.clip(np.einsum("ij,ij->i", p - a, chord) / np.where(length2 > 0, length2, 1.0),
                0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * chord), axis=1)


def _band_cells(samples: np.ndarray) -> np.ndarray:
    """The lower-left pixel centres of the cells the traced (closed) polyline runs
    through, unique: each chord between consecutive samples lies in one cell, the one
    of its middle (chords of length 0, where a pixel is exactly at the threshold, in
    none)."""
    after = np.roll(samples, -1, axis=0)
    moving = np.any(after != samples, axis=1)
    middles = 0.5 * (samples + after)[moving]
    return np.unique(np.floor(middles), axis=0)


def _points_to_band(points: np.ndarray, cells: np.ndarray) -> float:
    """The largest distance from a point to the union of the unit squares `cells`.
    A square is at least its centre's distance less sqrt(2)/2 away: the squares among
    the `_CELLS_SEARCHED` nearest centres settle a point unless a centre beyond them
    could be nearer, and such points are settled from all centres within reach."""
    from scipy.spatial import cKDTree

    centres = cells + 0.5
    tree, k = cKDTree(centres), min(_CELLS_SEARCHED, len(cells))
    reach = math.sqrt(2) / 2

    def box(p, c):  # distance from points p to the squares of centres c
        return np.linalg.norm(np.maximum(0.0, np.abs(p - c) - 0.5), axis=-1)

    largest = 0.0
    for block in range(0, len(points), 65536):  # bounded memory
        p = points[block:block + 65536]
        far, nearest = tree.query(p, k=k)
        far, nearest = far.reshape(len(p), k), nearest.reshape(len(p), k)
        best = box(p[:, None, :], centres[nearest]).min(axis=1)
        if k < len(cells):
            for i in np.flatnonzero(best > far[:, -1] - reach):
                near = tree.query_ball_point(p[i], best[i] + reach)
                best[i] = min(best[i], float(box(p[i], centres[near]).min(initial=np.inf)))
        largest = max(largest, float(best.max()))
    return largest
