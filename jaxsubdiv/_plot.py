"""Matplotlib figures of subdivision curves, refinement levels, fits and smoothness.

Everything here draws into a given `matplotlib.axes.Axes` or into a new
`matplotlib.figure.Figure` made without `pyplot`, so no display and no global figure
state are involved (save with `artists.ax.figure.savefig(...)`).
"""

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from jaxtyping import ArrayLike, Float

from ._analysis.limit import limit_curve
from ._analysis.smoothness import smoothness
from ._refine import refine, refined_count
from ._scheme.base import AbstractCurveScheme


#: Colors shared by all figures.
_CONTROL = "tab:orange"
_CURVE = "tab:blue"
_BACKGROUND = "0.72"


class CurveArtists(NamedTuple):
    """What [`jaxsubdiv.plot.plot_curve`][] draws (and each panel of
    [`jaxsubdiv.plot.plot_levels`][]).

    **Fields:**

    - `ax`: the axes drawn into.
    - `control`: the control polygon's `Line2D` (a closed polygon repeats its first point
      at the end, so `control.get_xydata()` is the drawn polyline).
    - `curve`: the refined polygon's or the limit curve's `Line2D`.
    - `method`: how `curve` was computed, a phrase for a caption.
    """

    ax: object
    control: object
    curve: object
    method: str


class LevelsFigure(NamedTuple):
    """What [`jaxsubdiv.plot.plot_levels`][] returns.

    **Fields:**

    - `figure`: the figure holding the row of panels.
    - `panels`: one [`jaxsubdiv.plot.CurveArtists`][] per level, in the order given.
    - `caption`: a sentence saying how every level was computed (and, for levels drawn
      as limit points, how far the level's polygon is from them).
    """

    figure: object
    panels: list[CurveArtists]
    caption: str


class FitArtists(NamedTuple):
    """What [`jaxsubdiv.plot.plot_fit`][] draws.

    **Fields:**

    - `ax`: the axes drawn into.
    - `samples`: the target samples, a `PathCollection` colored by `distances`.
    - `control`: the control polygon's `Line2D`.
    - `curve`: the limit curve's `Line2D`.
    - `colorbar`: the colorbar of the distances, or None.
    - `distances`: each sample's distance to the drawn limit curve, `(m,)`.
    """

    ax: object
    samples: object
    control: object
    curve: object
    colorbar: object
    distances: np.ndarray


class SmoothnessArtists(NamedTuple):
    """What [`jaxsubdiv.plot.plot_smoothness`][] draws.

    **Fields:**

    - `ax`: the axes drawn into.
    - `exponent`: the `Line2D` of the Hölder exponent's lower bound against the parameter.
    - `bounds`: the band between the lower and upper bounds (a `PolyCollection`).
    - `parameters`, `lower`, `upper`: the plotted numbers, `(p,)` each (NaN where the
      scheme does not converge).
    """

    ax: object
    exponent: object
    bounds: object
    parameters: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


def _new_axes(ax, figsize=(5.0, 5.0)):
    if ax is not None:
        return ax
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, dpi=100).add_subplot()


def _polygon(points, name: str = "points") -> np.ndarray:
    array = np.asarray(points, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2 or len(array) < 2:
        raise ValueError(f"`{name}` must be a planar polygon of shape (n, 2), got {array.shape}.")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"`{name}` contains NaN or infinite values.")
    return array


def _ring(points: np.ndarray, closed: bool) -> np.ndarray:
    return np.concatenate([points, points[:1]]) if closed and len(points) > 1 else points


def _size(points: np.ndarray) -> float:
    """The diagonal of the bounding box, the unit of all relative errors here."""
    return float(np.linalg.norm(np.ptp(points, axis=0))) or 1.0


class _Level(NamedTuple):
    points: np.ndarray
    method: str  # a phrase for the caption
    limit_level: int | None = None  # the level whose limit points are drawn
    count: int = 0  # points of the level asked for
    deviation: float = math.nan  # estimated max distance, level polygon to its limit
    measured: float = math.nan  # the same at the drawn level `limit_level`
    shown: int | None = None  # the level drawn instead, when this one could not be


def _level_points(points, scheme, level: int, boundary: str, max_points: int,
                  display_points: int) -> _Level:
    """Level `level` of a polygon for drawing.

    Refined with `refine` while it has at most `max_points` points. Deeper levels are
    drawn as the exact limit points of a shallower level `k` with at least
    `display_points` points (`limit_curve(P, scheme, k)`, which is
    `limit_points(refine(P, k))`: each level-k point pushed to
    its own parameter on the limit curve). A level-L polygon converges to those curve
    points; how far it still is from them is estimated from the levels k - 1 and k,
    whose point-to-limit distance shrinks by a fixed factor per level.
    """
    n = len(points)
    count = refined_count(n, scheme, level, boundary)
    if count <= max_points:
        refined = np.asarray(refine(points, scheme, level, boundary=boundary), dtype=np.float64)
        how = "the control polygon" if level == 0 else f"refined ({count:,} points)"
        return _Level(refined, how, count=count)
    k = 1
    while k < level and refined_count(n, scheme, k, boundary) < display_points:
        k += 1
    while k > 1 and refined_count(n, scheme, k, boundary) > max_points:
        k -= 1
    try:
        distances = []
        for j in (k - 1, k):
            polygon = refine(points, scheme, j, boundary=boundary)
            curve = np.asarray(limit_curve(points, scheme, j, boundary=boundary), np.float64)
            cut = (len(polygon) - len(curve)) // 2  # open curves lose ends
            polygon = np.asarray(polygon, np.float64)[cut : len(polygon) - cut]
            distances.append(float(np.max(np.linalg.norm(polygon - curve, axis=-1))))
    except ValueError as e:
        # No limit points (a scheme proven not to converge): draw what refine can.
        deepest = max(
            j for j in range(level) if refined_count(n, scheme, j, boundary) <= max_points
        )
        refined = np.asarray(refine(points, scheme, deepest, boundary=boundary), np.float64)
        reason = str(e).split(": ", 1)[-1].split(". ")[0]
        return _Level(
            refined,
            f"not drawn: it has {count:,} points, and limit_points cannot evaluate the limit "
            f"({reason}); level {deepest} shown instead",
            count=count,
            shown=deepest,
        )
    before, now = distances
    ratio = now / before if before > 0 else 0.0
    deviation = now * min(ratio, 1.0) ** (level - k)
    how = (
        f"exact limit points: limit_points of level {k} ({len(curve):,} points; level "
        f"{level} has {count:,})"
    )
    return _Level(curve, how, limit_level=k, count=count, deviation=deviation, measured=now)


def _pixel(ax, points: np.ndarray) -> float:
    """The data length of one pixel in `ax`, for the extent of `points`."""
    box = ax.get_window_extent()
    extent = np.ptp(points, axis=0) * 1.08
    return float(max(extent[0] / max(box.width, 1), extent[1] / max(box.height, 1)))


def plot_curve(
    points: Float[ArrayLike, "n 2"],
    scheme: AbstractCurveScheme,
    levels: int,
    *,
    closed: bool = True,
    ax=None,
    max_points: int = 50_000,
    display_points: int = 4096,
) -> CurveArtists:
    """Draw a control polygon and its curve after `levels` levels of subdivision.

    Use it for a quick look at what a scheme does to a polygon. Levels with at most
    `max_points` points are drawn as `refine` computes them; deeper levels as exact
    points of the limit curve (see [`jaxsubdiv.plot.plot_levels`][]).

    **Arguments:**

    - `points`: the control polygon, `(n, 2)`.
    - `scheme`: the subdivision scheme.
    - `levels`: subdivision levels (0 draws the polygon itself).
    - `closed`: True for a closed polygon (`boundary="closed"`), False for an open one.
    - `ax`: the axes to draw into (default: a new figure).
    - `max_points`, `display_points`: see [`jaxsubdiv.plot.plot_levels`][].

    **Returns:** a [`jaxsubdiv.plot.CurveArtists`][].
    """
    points = _polygon(points)
    boundary = "closed" if closed else "open"
    level = _level_points(points, scheme, int(levels), boundary, max_points, display_points)
    ax = _new_axes(ax)
    (control,) = ax.plot(*_ring(points, closed).T, "o--", ms=3, lw=0.8, color=_CONTROL,
                         label=f"{len(points)} control points")
    (curve,) = ax.plot(*_ring(level.points, closed).T, lw=1.4, color=_CURVE,
                       label=f"level {levels}")
    ax.set_aspect("equal")
    return CurveArtists(ax, control, curve, level.method)


def plot_levels(
    points: Float[ArrayLike, "n 2"],
    scheme: AbstractCurveScheme,
    levels: Sequence[int] = (0, 1, 2, 10, 20),
    *,
    closed: bool = True,
    axes=None,
    title: str | None = None,
    max_points: int = 50_000,
    display_points: int = 4096,
    panel_size: float = 2.4,
) -> LevelsFigure:
    """Draw a row of panels: a polygon after each of several levels of subdivision.

    The figure rows of Alam (2025), "Study of subdivision curve schemes ...", Figures
    3.2-5.4: the initial polygon and its 1st, 2nd, 10th and 20th refinements. Level 20 of
    a 20-point polygon has 20 million points, so levels with more than `max_points`
    points are not refined: they are drawn as exact limit-curve points
    ([`jaxsubdiv.limit_points`][] of `refine(points, scheme, k)` for the first level `k`
    with at least `display_points` points), which is what such a level's polygon
    converges to. The caption says so, with an estimate of how far the level's polygon
    still is from those points (from the distances at levels k - 1 and k, which shrink
    geometrically), and compares it with a pixel.

    **Arguments:**

    - `points`: the control polygon, `(n, 2)`.
    - `scheme`: the subdivision scheme.
    - `levels`: the levels to draw, one panel each.
    - `closed`: True for a closed polygon, False for an open one.
    - `axes`: a sequence of `len(levels)` axes to draw into (default: a new figure with
      one row of panels).
    - `title`: the row's title (default: the scheme's class name); starts the caption.
    - `max_points`: the largest level refined outright.
    - `display_points`: the least number of limit points drawn for a deeper level.
    - `panel_size`: panel width and height in inches, for a new figure.

    **Returns:** a [`jaxsubdiv.plot.LevelsFigure`][]; `panels[i].curve.get_xydata()` is
    what panel `i` shows (for level 0, exactly the polygon, closed by its first point).
    """
    points = _polygon(points)
    levels = [int(level) for level in levels]
    if not levels or min(levels) < 0:
        raise ValueError(f"`levels` must be one or more levels >= 0, got {levels}.")
    boundary = "closed" if closed else "open"
    if axes is None:
        from matplotlib.figure import Figure

        figure = Figure(figsize=(panel_size * len(levels), panel_size * 1.1), dpi=100,
                        layout="constrained")
        axes = figure.subplots(1, len(levels), squeeze=False)[0]
        made = True
    else:
        made = False
        axes = list(np.ravel(axes))
        if len(axes) != len(levels):
            raise ValueError(
                f"`axes` must hold {len(levels)} axes (one per level), got {len(axes)}."
            )
        figure = axes[0].figure
    title = title or type(scheme).__name__
    size = _size(points)
    results = [
        _level_points(points, scheme, level, boundary, max_points, display_points)
        for level in levels
    ]
    drawn = np.concatenate([points] + [r.points for r in results])
    margin = 0.04 * np.ptp(drawn, axis=0).max()
    low, high = drawn.min(axis=0) - margin, drawn.max(axis=0) + margin
    panels, refined, deep = [], [], []
    for ax, level, result in zip(axes, levels, results):
        (control,) = ax.plot(*_ring(points, closed).T, "--", lw=0.7, color=_BACKGROUND)
        few = len(result.points) <= 300
        (curve,) = ax.plot(*_ring(result.points, closed).T, "o-" if few else "-",
                           ms=2.2 if few else 0, lw=1.2, color=_CURVE)
        ax.set_aspect("equal")
        ax.set_xlim(low[0], high[0])
        ax.set_ylim(low[1], high[1])
        ax.set_axis_off()
        name = "initial polygon" if level == 0 else f"level {level}"
        if result.limit_level is not None:
            name += " (limit)"
        elif result.shown is not None:
            name = f"level {result.shown} (not {level})"
        ax.set_title(name, fontsize=9)
        panels.append(CurveArtists(ax, control, curve, result.method))
        if result.limit_level is None and result.shown is None:
            refined.append((level, result.count))
        else:
            deep.append((level, result, _pixel(ax, points) / size))
    parts = []
    if refined:
        listed = ", ".join(str(level) for level, _ in refined)
        most = max(count for _, count in refined)
        parts.append(f"levels {listed} computed with jaxsubdiv.refine (up to {most:,} points)")
    for level, result, pixel in deep:
        if result.limit_level is None:
            parts.append(f"level {level}: {result.method}")
            continue
        text = (
            f"level {level} ({result.count:,} points) drawn as the exact limit curve: "
            f"limit_points of level {result.limit_level} ({len(result.points):,} points); "
        )
        if result.measured <= 1e-12 * size:
            text += f"the scheme interpolates, so the level-{level} points lie on that curve"
        else:
            relative = result.deviation / size
            amount = f"about {relative:.0e}" if relative >= 1e-12 else "less than 1e-12"
            relation = "below a pixel" if relative < pixel else "more than a pixel"
            text += (
                f"the level-{level} polygon differs from it by {amount} of the shape's size "
                f"(extrapolated from levels {result.limit_level - 1}-{result.limit_level}), "
                f"{relation} ({pixel:.0e} of the size)"
            )
        parts.append(text)
    caption = f"{title}: " + "; ".join(parts) + "."
    if made:
        figure.suptitle(title, fontsize=10)
    return LevelsFigure(figure, panels, caption)


def _segment_distances(samples: np.ndarray, polyline: np.ndarray, closed: bool,
                       block: int = 32) -> np.ndarray:
    """Each sample's distance to the polyline: exact point-to-segment distances, the
    minimum over every segment, computed only where it can be attained.

    The segments are taken in blocks of `block` consecutive ones, each inside a ball
    around its middle vertex. A sample's distance to the nearest block vertex bounds
    its distance from above; a block whose ball is farther than that cannot hold the
    minimum, so only the segments of the other blocks are measured (a few per sample
    on an outline, instead of all of them: the brute force took 26-35 s for a
    2,644-sample silhouette's picture, issue #18)."""
    ring = _ring(polyline, closed)
    a, b = ring[:-1], ring[1:]
    count = len(a)
    blocks = -(-count // block)
    # Each block's ball: around its middle vertex, through its farthest vertex.
    first = np.arange(blocks) * block
    last = np.minimum(first + block, count)  # the block's segments end at vertex `last`
    centre = ring[np.minimum(first + block // 2, count)]
    reach = np.zeros(blocks)
    for k in range(block + 1):  # the farthest of each block's vertices
        index = np.minimum(first + k, last)
        reach = np.maximum(reach, np.linalg.norm(ring[index] - centre, axis=-1))
    out = np.empty(len(samples))
    chunk = max(1, 1_000_000 // blocks)
    for start in range(0, len(samples), chunk):
        p = samples[start : start + chunk]
        to_centre = np.linalg.norm(p[:, None, :] - centre[None], axis=-1)
        upper = np.min(to_centre, axis=1)  # a distance to a vertex: attained by the curve
        rows, columns = np.nonzero(to_centre - reach <= upper[:, None])
        # Every segment of each candidate block (segments past the end repeat the last).
        segment = np.minimum(first[columns][:, None] + np.arange(block), count - 1)
        rows = np.broadcast_to(rows[:, None], segment.shape).ravel()
        segment = segment.ravel()
        ab = b[segment] - a[segment]
        length2 = np.maximum(np.sum(ab**2, axis=-1), np.finfo(np.float64).tiny)
        t = np.clip(np.sum((p[rows] - a[segment]) * ab, axis=-1) / length2, 0.0, 1.0)
        square = np.sum((p[rows] - a[segment] - t[:, None] * ab) ** 2, axis=-1)
        best = np.full(len(p), np.inf)
        np.minimum.at(best, rows, square)
        out[start : start + chunk] = np.sqrt(best)
    return out


def _limit_curve(
    control_points: Float[ArrayLike, "n 2"],
    scheme: AbstractCurveScheme,
    *,
    boundary: str = "closed",
    count: int = 4096,
    creases=None,
) -> Float[np.ndarray, "N 2"]:
    """At least `count` exact points of a control polygon's limit curve, in order.

    `limit_curve(control_points, scheme, k)` (the same numbers as
    `limit_points(refine(control_points, scheme, k))`) for the first `k` that gives
    `count` points (the polygon refined once if the scheme has no limit stencil).

    **Returns:** a float64 NumPy array `(N, 2)`.
    """
    points = _polygon(control_points, "control_points")
    k = 0
    while refined_count(len(points), scheme, k, boundary) < count:
        k += 1
    if creases is not None and len(creases):  # a closed curve's creased control points
        return np.asarray(limit_curve(points, scheme, k, creases=list(creases)), np.float64)
    try:
        return np.asarray(limit_curve(points, scheme, k, boundary=boundary), np.float64)
    except ValueError:  # no limit stencil (a scheme proven not to converge)
        return np.asarray(refine(points, scheme, k, boundary=boundary), np.float64)


def plot_fit(
    result,
    target: Float[ArrayLike, "m 2"],
    ax=None,
    *,
    colorbar: bool = True,
    vmax: float | None = None,
    cmap: str = "viridis",
    legend: bool = True,
) -> FitArtists:
    """Draw a fit: the target samples colored by their distance to the curve, the control
    polygon and the limit curve.

    Use it to see where a fit is good and where it is not. The distances are exact
    point-to-curve distances to a dense polyline of exact limit points (at least
    max(16384, 16m) of them), so they are what `fitting.fit` reports as target-to-curve
    errors, up to the polyline's chords.

    **Arguments:**

    - `result`: a single `fitting.FitResult`, a [`jaxsubdiv.io.SavedResult`][] (from
      [`jaxsubdiv.io.read_result_json`][]), or anything with `control_points`, `scheme`
      and optionally `boundary` (default closed).
    - `target`: the samples that were fitted, `(m, 2)`.
    - `ax`: the axes to draw into (default: a new figure).
    - `colorbar`: add a colorbar of the distances.
    - `vmax`: the distance at the top of the color scale (default: the largest); pass the
      same value to draw several contours on one scale.
    - `cmap`: the colormap.
    - `legend`: add a legend (pass False for all but one contour drawn on the same axes).

    **Returns:** a [`jaxsubdiv.plot.FitArtists`][].
    """
    control = np.asarray(result.control_points, dtype=np.float64)
    if control.ndim != 2 or control.shape[1] != 2:
        raise ValueError(
            f"`result` must be one planar fit (control points of shape (n, 2)), got "
            f"control points of shape {control.shape}; index a batch of results first."
        )
    target = _polygon(target, "target")
    boundary = getattr(result, "boundary", "closed")
    closed = boundary == "closed"
    creases = getattr(result, "creases", None)
    if creases is not None and np.asarray(creases).dtype == bool:
        creases = np.flatnonzero(np.asarray(creases))
    curve = _limit_curve(control, result.scheme, boundary=boundary,
                        count=max(16384, 16 * len(target)), creases=creases)
    distances = _segment_distances(target, curve, closed)
    ax = _new_axes(ax, figsize=(6.0, 5.0))
    # The samples first, small, and the curve and polygon over them: a good fit's curve
    # runs through its samples and would otherwise be hidden under them.
    samples = ax.scatter(*target.T, c=distances, s=5, cmap=cmap, vmin=0.0,
                         vmax=vmax if vmax is not None else max(float(distances.max()), 1e-300),
                         label=f"{len(target)} samples", zorder=2, linewidths=0)
    (line,) = ax.plot(*_ring(curve, closed).T, color=_CURVE, lw=0.9, label="limit curve",
                      zorder=3)
    (polygon,) = ax.plot(*_ring(control, closed).T, "o--", ms=3, lw=0.7, color=_CONTROL,
                         label=f"{len(control)} control points", zorder=4)
    bar = None
    if colorbar:
        bar = ax.figure.colorbar(samples, ax=ax, shrink=0.8)
        bar.set_label("distance of a sample to the curve")
    ax.set_aspect("equal")
    if legend:  # below the axes, where it covers no data
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=3, fontsize=7,
                  frameon=False)
    return FitArtists(ax, samples, polygon, line, bar, distances)


def plot_loss(values: Float[ArrayLike, " steps"], ax=None, *, log: bool = True):
    """Draw a loss (or any per-step value) against the step number.

    `fitting.FitResult` keeps no loss history; collect one yourself (for example with a
    `verbose` callable, or by fitting with increasing `max_steps`) and pass it here.

    **Arguments:**

    - `values`: one value per step, `(steps,)`.
    - `ax`: the axes to draw into (default: a new figure).
    - `log`: a logarithmic loss axis (used only if every value is positive).

    **Returns:** the `Line2D` (its axes are `line.axes`).
    """
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 1 or len(values) == 0:
        raise ValueError(f"`values` must be a non-empty 1-D array, got shape {values.shape}.")
    ax = _new_axes(ax, figsize=(5.0, 3.5))
    (line,) = ax.plot(np.arange(len(values)), values, "o-" if len(values) <= 50 else "-",
                      ms=3, color=_CURVE)
    if log and np.all(values[np.isfinite(values)] > 0):
        ax.set_yscale("log")
    ax.set_xlabel("step")
    ax.set_ylabel("loss")
    return line


def plot_smoothness(
    scheme_factory: Callable[[float], AbstractCurveScheme],
    param_values: Float[ArrayLike, " p"],
    ax=None,
    *,
    label: str = "parameter",
) -> SmoothnessArtists:
    """Draw the Hölder exponent of a family of schemes against its parameter.

    Use it to choose a parameter: the limit curves are $C^k$ exactly where the exponent
    is above $k$. Each value is [`jaxsubdiv.smoothness`][] of `scheme_factory(value)`
    (rigorous lower and upper bounds from the joint spectral radius of the difference
    scheme; about a millisecond each).

    **Arguments:**

    - `scheme_factory`: a function from a parameter value to a scheme, e.g.
      `jaxsubdiv.FourPoint` or `lambda r: jaxsubdiv.CornerCutting(r, r + 0.5)`.
    - `param_values`: the parameter values, `(p,)`.
    - `ax`: the axes to draw into (default: a new figure).
    - `label`: the parameter's name, for the x axis.

    **Returns:** a [`jaxsubdiv.plot.SmoothnessArtists`][].
    """
    values = np.asarray(param_values, dtype=np.float64)
    if values.ndim != 1 or len(values) == 0:
        raise ValueError(f"`param_values` must be a non-empty 1-D array, got {values.shape}.")
    found = [smoothness(scheme_factory(float(v))) for v in values]
    lower = np.array([s.holder_lower if s.converges else np.nan for s in found])
    upper = np.array([s.holder_upper if s.converges else np.nan for s in found])
    ax = _new_axes(ax, figsize=(5.0, 3.5))
    bounds = ax.fill_between(values, lower, upper, color=_CURVE, alpha=0.25, lw=0,
                             label="rigorous bounds")
    (exponent,) = ax.plot(values, lower, color=_CURVE, lw=1.3, label="Hölder exponent")
    for k in range(1, int(np.nanmax(upper, initial=0)) + 1):
        ax.axhline(k, color="0.5", lw=0.6, ls=":")
    ax.set_xlabel(label)
    ax.set_ylabel("Hölder exponent (C^k where > k)")
    ax.legend(fontsize=7)
    return SmoothnessArtists(ax, exponent, bounds, values, lower, upper)
