"""An interactive matplotlib editor for subdivision curves (see `jaxsubdiv.editor`).

Design notes:

- The control polygon lives on the host as a NumPy array in JAX's default float dtype
  (float64 when `jax_enable_x64` is on, float32 otherwise); the editor never changes
  JAX's configuration.
- Curves are computed with the public [`jaxsubdiv.refine`][], whose jitted kernel is
  compiled once per (scheme type, number of points, dtype, levels, boundary). Moving a
  vertex or a slider changes values, not shapes, so it never recompiles. Closed
  polygons are padded to a bucket of sizes (`_closed_refine`), so inserting or deleting
  a vertex does not recompile either; an open polygon (clamped ends) compiles once per
  new vertex count, and a new level once per level (about 0.2 s per shown curve,
  measured in `benchmarks/results/editor.md`).
- At the press of a drag, the curves and the polygon become animated and one full draw
  saves the rest of the figure; each move then redraws only them and blits the axes
  (when the canvas can blit; otherwise `draw_idle`).
- Everything else updates the existing `Line2D` artists with `set_data` and asks for a
  redraw with `draw_idle`, so the backend coalesces events it cannot keep up with.
- Smoothness (`jaxsubdiv.smoothness`, NumPy on the host, ~5 ms per value, up to ~120 ms
  near borderline values; cached per value) is recomputed live while a slider moves as
  long as the last computation was quick, and otherwise once the slider is released.
"""

import math
import os
import time
import typing
from collections.abc import Sequence
from typing import Literal

import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from ._analysis.smoothness import smoothness
from ._kernel import open_levels
from ._refine import _min_points, refine
from ._scheme.base import AbstractCurveScheme
from ._scheme.chaikin import Chaikin
from ._scheme.corner_cutting import CornerCutting
from ._scheme.cubic_bspline import CubicBSpline
from ._scheme.four_point import FourPoint
from ._scheme.split_tweak import SplitTweak


class _Curve(typing.NamedTuple):
    key: str  # the key that shows or hides it
    label: str
    color: str
    parameters: tuple[str, ...]  # the sliders it depends on
    make: typing.Callable[[dict], AbstractCurveScheme]


#: The curves the editor draws, by name (the names of the `jaxsubdiv` command's
#: `--scheme` option), with their toggle keys.
CURVES: dict[str, _Curve] = {
    "cubic-bspline": _Curve("b", "cubic B-spline", "tab:red", (), lambda p: CubicBSpline()),
    "four-point": _Curve("f", "four-point", "tab:blue", ("w",), lambda p: FourPoint(p["w"])),
    "jarek": _Curve("j", "Jarek (split-tweak t)", "tab:green", ("t",), lambda p: SplitTweak(p["t"])),
    "chaikin": _Curve("k", "Chaikin", "tab:purple", (), lambda p: Chaikin()),
    "corner-cutting": _Curve(
        "x", "corner cutting (r, s)", "tab:brown", ("r", "s"), lambda p: CornerCutting(p["r"], p["s"])
    ),
}
DEFAULT_CURVES = ("cubic-bspline", "four-point", "jarek")
#: Slider ranges and defaults.
PARAMETERS = {
    "w": (-0.24, 0.24, 1 / 16),
    "r": (0.01, 0.99, 0.25),
    "s": (0.01, 0.99, 0.75),
    "t": (0.0, 1.0, 0.5),
}
_KEYS_HELP = (
    "drag: move vertex | drag near edge: insert | right-click/d: delete | "
    "c polygon, b B-spline, f four-point, j Jarek, k Chaikin, x corner cutting | "
    "1-9 level | o open/closed | space reset | a view | s save | h help"
)
_FIT_HELP = " | t target | r refit"
# Seconds a live smoothness update may take before further updates wait for the
# slider's release.
_LIVE_SMOOTHNESS_BUDGET = 0.025


def _scheme_curve(scheme: AbstractCurveScheme) -> tuple[str, dict]:
    """The editor curve that draws `scheme`, and the slider values it sets."""
    if isinstance(scheme, CubicBSpline):
        return "cubic-bspline", {}
    if isinstance(scheme, FourPoint):
        return "four-point", {"w": float(scheme.w)}
    if isinstance(scheme, SplitTweak):
        return "jarek", {"t": float(scheme.t)}
    if isinstance(scheme, Chaikin):
        return "chaikin", {}
    if isinstance(scheme, CornerCutting):
        return "corner-cutting", {"r": float(scheme.r), "s": float(scheme.s)}
    raise ValueError(
        f"the editor draws CubicBSpline, FourPoint, SplitTweak (Jarek), Chaikin and "
        f"CornerCutting curves; got `scheme={type(scheme).__name__}(...)`."
    )


_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def format_smoothness(result) -> str:
    """A short label for a [`jaxsubdiv.Smoothness`][], e.g. `C¹, α ∈ [1.463, 1.467]`.

    `C^k` is the proven class (`≥C^k` when $C^{k+1}$ is undecided) and α the Hölder
    exponent: exact (`=`), bracketed to within 5e-4 (`≈`), or its bounds.
    """
    if not result.converges:
        return "does not converge" if result.decided else "convergence undecided"
    low, high = result.holder_lower, result.holder_upper
    if low == high:
        alpha = f"α = {low:.3f}"
    elif high - low < 5e-4:
        alpha = f"α ≈ {(low + high) / 2:.3f}"
    else:
        alpha = f"α ∈ [{low:.3f}, {high:.3f}]"
    k = "C" + str(result.continuity).translate(_SUPERSCRIPT)
    return f"{k if result.decided else '≥' + k}, {alpha}"


@typing.final
class Editor:
    """An interactive editor for subdivision curves in a matplotlib figure.

    Drag control vertices and watch the cubic B-spline, four-point, Jarek, Chaikin and
    corner-cutting curves follow; tune `w`, `r`, `s` and `t` with sliders and read each
    shown curve's Hölder exponent and $C^k$ class (from [`jaxsubdiv.smoothness`][]).
    Use it to learn how the schemes differ, to tune a parameter by eye, or to touch up a
    fitted polygon ([`jaxsubdiv.editor.Editor.from_fit`][]).

    Mouse: drag a vertex to move it; press near an edge and drag to insert a vertex
    there; right-click a vertex to delete it. Keys (press `h` for the on-screen help):
    `c` control polygon, `b` cubic B-spline, `f` four-point, `j` Jarek, `k` Chaikin,
    `x` corner cutting, `1`-`9` level, `o` open/closed, `d`/`delete` delete the vertex
    nearest the cursor, space reset, `a` fit the view, `s` save, and in fit mode `t`
    target and `r` refit. matplotlib's own key bindings are switched off for this
    figure; its toolbar still works.

    It works without a display (Agg backend): construct it, drive it with
    matplotlib events or the methods below, and save pictures and files. Interactively,
    call `show()`, or in Jupyter use an interactive backend (`%matplotlib widget`) and
    keep a reference to the editor (matplotlib holds its callbacks weakly).

    Dtype: the polygon is held in JAX's default float dtype (float64 when
    `jax_enable_x64` is on, else float32); the editor does not change JAX's
    configuration.

    **Arguments:**

    - `points`: the control polygon, shape `(n, 2)`.
    - `closed`: True for a closed polygon; an open one is refined with
      `boundary="clamped"`, so the curves end at the end vertices.
    - `curves`: the curves shown at the start, names from
      `jaxsubdiv.editor.CURVES`: `"cubic-bspline"`, `"four-point"`, `"jarek"`,
      `"chaikin"`, `"corner-cutting"` (all can be toggled later).
    - `levels`: refinement level, 0-9.
    - `w`, `r`, `s`, `t`: starting parameter values (four-point tension, corner-cutting
      ratios, split-tweak parameter; `t = 1/2` is Jarek's scheme).
    - `pick_radius`: how close, in screen pixels, a press must be to a vertex or an edge.
    - `save_prefix`: path prefix of the files the `s` key writes (see `save`).
    - `figure`: a matplotlib `Figure` to draw into (it is cleared); default a new
      `pyplot` figure.
    - `target`: an outline `(m, 2)` to show behind the curves (fit mode).
    """

    def __init__(
        self,
        points: Float[ArrayLike, "n 2"],
        *,
        closed: bool = True,
        curves: Sequence[str] = DEFAULT_CURVES,
        levels: int = 5,
        w: float = PARAMETERS["w"][2],
        r: float = PARAMETERS["r"][2],
        s: float = PARAMETERS["s"][2],
        t: float = PARAMETERS["t"][2],
        pick_radius: float = 10.0,
        save_prefix: str | os.PathLike = "jaxsubdiv-edit",
        figure=None,
        target: Float[ArrayLike, "m 2"] | None = None,
    ):
        self._dtype = np.dtype(jnp.result_type(float))
        self._points = self._check_points(points, closed)
        self._initial = (self._points.copy(), bool(closed))
        self.closed = bool(closed)
        if isinstance(curves, str):
            curves = (curves,)
        unknown = [c for c in curves if c not in CURVES]
        if unknown:
            raise ValueError(
                f"`curves` must be names from {tuple(CURVES)}; got {unknown[0]!r}."
            )
        self._shown = {name: name in curves for name in CURVES}
        if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)):
            raise TypeError(f"`levels` must be an int from 0 to 9, got {levels!r}.")
        if not 0 <= levels <= 9:
            raise ValueError(f"`levels` must be from 0 to 9, got {levels}.")
        self.levels = int(levels)
        self.parameters = {"w": float(w), "r": float(r), "s": float(s), "t": float(t)}
        if not pick_radius > 0:
            raise ValueError(f"`pick_radius` must be a positive number of pixels, got {pick_radius}.")
        self.pick_radius = float(pick_radius)
        self.save_prefix = save_prefix
        self.target = None if target is None else np.asarray(target, dtype=np.float64)
        self.fit_info = None  # set by from_fit: how to refit
        self.fit_result = None
        self._schemes: dict[str, AbstractCurveScheme | None] = {}
        self._errors: dict[str, str] = {}
        self._smooth_text: dict[str, str] = {}
        self._smooth_stale: set[str] = set()
        self._smooth_seconds = 0.0
        self._dragging: int | None = None
        self._background = None
        self.status = ""
        self.curve_points: dict[str, np.ndarray] = {}
        for name in CURVES:
            self._build_scheme(name)
        self._build_figure(figure)
        self._update_curves()
        self._update_smoothness(CURVES)
        self._update_text()
        self.view_all()

    # ----------------------------------------------------------------------------------
    # Construction

    def _check_points(self, points, closed) -> np.ndarray:
        try:
            array = np.array(points, dtype=self._dtype)
        except (TypeError, ValueError):
            raise TypeError("`points` must be an (n, 2) array of numbers.") from None
        if array.ndim != 2 or array.shape[1] != 2:
            raise ValueError(f"`points` must have shape (n, 2), got {array.shape}.")
        if not np.all(np.isfinite(array)):
            raise ValueError("`points` contain NaN or infinite values.")
        minimum = 3 if closed else 2
        if len(array) < minimum:
            raise ValueError(
                f"a{' closed' if closed else 'n open'} polygon needs at least {minimum} "
                f"points, got {len(array)}."
            )
        return array

    def _build_figure(self, figure):
        import matplotlib.pyplot as plt
        from matplotlib.widgets import Slider

        if figure is None:
            figure = plt.figure(figsize=(11, 7.5))
        else:
            figure.clear()
        self.figure = figure
        self.ax = figure.add_axes((0.04, 0.2, 0.62, 0.72))
        self.ax.set_aspect("equal", adjustable="box")
        info = figure.add_axes((0.68, 0.2, 0.31, 0.72))
        info.set_axis_off()
        self._info_ax = info
        if self.target is not None:
            closed_target = np.vstack([self.target, self.target[:1]])
            (self.target_line,) = self.ax.plot(
                *closed_target.T, ".", ms=2.5, color="0.6", zorder=1, label="target"
            )
        else:
            self.target_line = None
        self.lines = {}
        for name, curve in CURVES.items():
            (line,) = self.ax.plot([], [], lw=1.6, color=curve.color, zorder=2)
            line.set_visible(self._shown[name])
            self.lines[name] = line
        (self.polygon_line,) = self.ax.plot(
            [], [], "o--", ms=5, lw=0.8, color="0.25", mfc="white", zorder=3
        )
        # Info panel: one line per curve (its key, name and smoothness), then the status.
        self._texts = {}
        for i, (name, curve) in enumerate(CURVES.items()):
            self._texts[name] = info.text(
                0.0, 0.97 - 0.075 * i, "", color=curve.color, fontsize=9, va="top",
                transform=info.transAxes,
            )
        self._status_text = info.text(
            0.0, 0.97 - 0.075 * len(CURVES), "", fontsize=9, va="top", color="0.2",
            transform=info.transAxes, wrap=True,
        )
        self._help_text = figure.text(
            0.01, 0.99, _KEYS_HELP + (_FIT_HELP if self.target is not None else ""),
            fontsize=8, va="top", color="0.3", wrap=True,
        )
        self.sliders = {}
        for i, (name, (low, high, _)) in enumerate(PARAMETERS.items()):
            slider_ax = figure.add_axes((0.1, 0.13 - 0.035 * i, 0.5, 0.025))
            slider = Slider(slider_ax, name, low, high, valinit=self.parameters[name],
                            valfmt="%.4f")
            slider.drawon = False  # set_parameter redraws once, after the curves
            slider.on_changed(lambda value, name=name: self.set_parameter(name, value))
            self.sliders[name] = slider
        canvas = figure.canvas
        manager = getattr(canvas, "manager", None)
        if manager is not None and getattr(manager, "key_press_handler_id", None) is not None:
            # matplotlib's default keys (s = save dialog, f = fullscreen, ...) clash with
            # the editor's.
            canvas.mpl_disconnect(manager.key_press_handler_id)
        self._cids = [
            canvas.mpl_connect("button_press_event", self._on_press),
            canvas.mpl_connect("motion_notify_event", self._on_motion),
            canvas.mpl_connect("button_release_event", self._on_release),
            canvas.mpl_connect("key_press_event", self._on_key),
        ]

    @classmethod
    def from_fit(
        cls,
        source,
        *,
        n_control: int = 16,
        scheme: AbstractCurveScheme | None = None,
        outline: int | None = None,
        samples: int | None = None,
        fit_options: dict | None = None,
        **editor_options,
    ) -> "Editor":
        """Fit a curve to an outline, then edit the fitted control polygon.

        The outline is shown as gray dots behind the curves; `r` refits it with the
        current number of control points, starting from the current polygon.

        **Arguments:**

        - `source`: a file [`jaxsubdiv.io.read_outlines`][] reads (CSV/TXT, NPY/NPZ,
          JSON, SVG, PNG), a [`jaxsubdiv.io.Outline`][], or an `(m, 2)` array of samples
          (closed).
        - `n_control`: number of control points of the fit.
        - `scheme`: the scheme fitted (default `CubicBSpline()`); one the editor draws
          (`CubicBSpline`, `FourPoint`, `SplitTweak`/`Jarek`, `Chaikin`,
          `CornerCutting`). Its parameters become the sliders' starting values, and its
          curve is shown.
        - `outline`: which outline of a file with several (default: the largest).
        - `samples`: resample the outline to this many points (see `read_outlines`).
        - `fit_options`: more keyword arguments for `fitting.fit` (e.g. `levels`).
        - `editor_options`: keyword arguments for `Editor` (not `points`, `closed`,
          `target`).

        **Returns:** the `Editor`; `editor.fit_result` holds the `fitting.FitResult`.
        """
        from . import io

        scheme = CubicBSpline() if scheme is None else scheme
        name, parameters = _scheme_curve(scheme)
        if isinstance(source, io.Outline):
            outlines = [source]
        elif isinstance(source, (str, os.PathLike)):
            outlines = io.read_outlines(source, samples=samples)
        else:
            outlines = [io.Outline(np.asarray(source, dtype=np.float64), True)]
        if outline is None:
            chosen = max(outlines, key=lambda o: float(np.prod(np.ptp(o.points, axis=0))))
        elif not 0 <= outline < len(outlines):
            raise ValueError(
                f"`outline` must be in [0, {len(outlines) - 1}] (the input has "
                f"{len(outlines)} outlines), got {outline}."
            )
        else:
            chosen = outlines[outline]
        target = np.asarray(chosen.points, dtype=np.float64)
        boundary = "closed" if chosen.closed else "clamped"
        fit_options = dict(fit_options or {})
        result = _run_fit(target, scheme, n_control, boundary, None, fit_options)
        curves = tuple(editor_options.pop("curves", (name,)))
        if name not in curves:
            curves = (name, *curves)
        options = {**editor_options, **parameters}
        editor = cls(
            np.asarray(result.control_points),
            closed=chosen.closed,
            curves=curves,
            target=target,
            **options,
        )
        editor.fit_info = dict(scheme=scheme, curve=name, boundary=boundary, options=fit_options)
        editor.fit_result = result
        editor.status = _fit_status(result)
        editor._update_text()
        return editor

    # ----------------------------------------------------------------------------------
    # State

    @property
    def points(self) -> np.ndarray:
        """The control polygon, `(n, 2)` (a copy)."""
        return self._points.copy()

    @property
    def boundary(self) -> Literal["closed", "clamped"]:
        """The boundary the curves are refined with: `"closed"` or `"clamped"` (open)."""
        return "closed" if self.closed else "clamped"

    @property
    def shown(self) -> tuple[str, ...]:
        """Names of the curves shown."""
        return tuple(name for name, on in self._shown.items() if on)

    @property
    def polygon_shown(self) -> bool:
        return self.polygon_line.get_visible()

    def scheme(self, name: str) -> AbstractCurveScheme | None:
        """The scheme of curve `name` at the current parameters (None if they are invalid)."""
        return self._schemes[name]

    def min_points(self) -> int:
        """The fewest control points every curve accepts with the current boundary."""
        return max(
            _min_points(s, self.boundary) for s in self._schemes.values() if s is not None
        )

    # ----------------------------------------------------------------------------------
    # Edits (what the mouse and keys do; callable from scripts)

    def set_points(self, points: Float[ArrayLike, "n 2"], closed: bool | None = None) -> None:
        """Replace the control polygon (and optionally open or close it)."""
        closed = self.closed if closed is None else bool(closed)
        self._points = self._check_points(points, closed)
        self.closed = closed
        self._refresh()

    def move_vertex(self, index: int, xy: Float[ArrayLike, "2"]) -> None:
        """Move control vertex `index` to `xy` (data coordinates)."""
        self._points[index] = np.asarray(xy, dtype=self._dtype)
        self._refresh()

    def insert_vertex(self, edge: int, xy: Float[ArrayLike, "2"]) -> int:
        """Insert a vertex at `xy` on edge `(edge, edge + 1)`; returns its index."""
        n = len(self._points)
        last = n if self.closed else n - 1
        if not 0 <= edge < last:
            raise ValueError(f"`edge` must be in [0, {last - 1}], got {edge}.")
        self._points = np.insert(self._points, edge + 1, np.asarray(xy, self._dtype), axis=0)
        self._refresh()
        return edge + 1

    def delete_vertex(self, index: int) -> bool:
        """Delete vertex `index`, unless that leaves fewer than `min_points()`.

        **Returns:** True if the vertex was deleted.
        """
        if len(self._points) - 1 < self.min_points():
            self.status = (
                f"cannot delete: the curves need at least {self.min_points()} control "
                f"points ({self.boundary})"
            )
            self._update_text()
            self._redraw()
            return False
        self._points = np.delete(self._points, index, axis=0)
        self.status = ""
        self._refresh()
        return True

    def set_closed(self, closed: bool) -> None:
        """Close or open the polygon (an open one is refined with clamped ends)."""
        if closed and len(self._points) < 3:
            self.status = "cannot close a polygon of fewer than 3 points"
            self._update_text()
            self._redraw()
            return
        self.closed = bool(closed)
        self._refresh()

    def set_level(self, levels: int) -> None:
        """Set the refinement level (0-9)."""
        if not 0 <= levels <= 9:
            raise ValueError(f"`levels` must be from 0 to 9, got {levels}.")
        self.levels = int(levels)
        self._refresh()

    def toggle(self, name: str) -> bool:
        """Show or hide curve `name` (or `"polygon"`, or `"target"`); returns the new state."""
        if name == "polygon":
            line = self.polygon_line
        elif name == "target":
            if self.target_line is None:
                return False
            line = self.target_line
        elif name in CURVES:
            self._shown[name] = not self._shown[name]
            line = self.lines[name]
            line.set_visible(self._shown[name])
            if self._shown[name]:
                self._update_curves((name,))
                self._update_smoothness((name,))
            self._update_text()
            self._redraw()
            return self._shown[name]
        else:
            raise ValueError(
                f"`name` must be 'polygon', 'target' or one of {tuple(CURVES)}; got {name!r}."
            )
        line.set_visible(not line.get_visible())
        self._redraw()
        return line.get_visible()

    def set_parameter(self, name: str, value: float) -> None:
        """Set `w`, `r`, `s` or `t` and update the curves that use it.

        Called by the sliders; calling it moves the slider too.
        """
        if name not in PARAMETERS:
            raise ValueError(f"`name` must be one of {tuple(PARAMETERS)}, got {name!r}.")
        value = float(value)
        slider = self.sliders[name]
        if slider.val != value:
            slider.set_val(value)  # calls back into set_parameter
            return
        self.parameters[name] = value
        affected = tuple(n for n, c in CURVES.items() if name in c.parameters)
        for curve in affected:
            self._build_scheme(curve)
        self._update_curves(affected)
        live = not slider.drag_active or self._smooth_seconds < _LIVE_SMOOTHNESS_BUDGET
        if live:
            self._update_smoothness(affected)
        else:
            self._smooth_stale.update(affected)
        self._update_text()
        self._redraw()

    def reset(self) -> None:
        """Back to the polygon (and open/closed state) the editor started with."""
        points, closed = self._initial
        self._points = points.copy()
        self.closed = closed
        self.status = "reset"
        self._refresh()

    def view_all(self) -> None:
        """Fit the view to the polygon, the shown curves and the target."""
        parts = [self._points] + [self.curve_points[n] for n in self.shown if n in self.curve_points]
        if self.target is not None:
            parts.append(self.target)
        everything = np.concatenate([np.asarray(p, np.float64) for p in parts if len(p)])
        low, high = everything.min(axis=0), everything.max(axis=0)
        margin = 0.08 * max(float(np.max(high - low)), 1e-9)
        self.ax.set_xlim(low[0] - margin, high[0] + margin)
        self.ax.set_ylim(low[1] - margin, high[1] + margin)
        self._redraw()

    def refit(self) -> None:
        """Fit the target again with the current number of control points, starting
        from the current polygon (fit mode only)."""
        if self.fit_info is None:
            self.status = "no target to refit (start with Editor.from_fit or --fit)"
            self._update_text()
            self._redraw()
            return
        info = self.fit_info
        scheme = self._schemes[info["curve"]] or info["scheme"]
        boundary = self.boundary
        result = _run_fit(
            self.target, scheme, len(self._points), boundary, self._points, info["options"]
        )
        self.fit_result = result
        self._points = np.asarray(result.control_points, dtype=self._dtype)
        self.status = _fit_status(result)
        self._refresh()

    def save(self, prefix: str | os.PathLike | None = None) -> list[str]:
        """Write the polygon and the shown curves.

        Files, for `prefix` `P` (default `save_prefix`):

        - `P.json`: the control polygon and the scheme of the first shown curve (or the
          fitted one), boundary and levels, via [`jaxsubdiv.io.write_result_json`][];
          `info["editor"]` records the parameters, the shown curves and `closed`. Read it
          back with [`jaxsubdiv.io.read_result_json`][].
        - `P-polygon.svg`: the control polygon.
        - `P-<curve>.svg` for each shown curve, via [`jaxsubdiv.io.write_curve_svg`][]
          (exact Bezier segments for the B-spline and Chaikin curves).
        - `P.png`: a picture of the editor.

        **Returns:** the paths written.
        """
        from . import io

        prefix = os.fspath(self.save_prefix if prefix is None else prefix)
        directory = os.path.dirname(prefix)
        if directory:
            os.makedirs(directory, exist_ok=True)
        primary = self.fit_info["curve"] if self.fit_info else (self.shown or DEFAULT_CURVES)[0]
        scheme = self._schemes[primary] or CURVES[primary].make(PARAMETERS_DEFAULTS)
        written = []
        path = f"{prefix}.json"
        io.write_result_json(
            path,
            dict(
                control_points=self._points,
                scheme=scheme,
                boundary=self.boundary,
                levels=self.levels,
            ),
            info={
                "editor": dict(
                    closed=self.closed,
                    parameters=self.parameters,
                    shown=list(self.shown),
                    curve=primary,
                )
            },
        )
        written.append(path)
        path = f"{prefix}-polygon.svg"
        io.write_points(path, self._points.astype(np.float64), closed=self.closed)
        written.append(path)
        for name in self.shown:
            if self._schemes[name] is None:
                continue
            path = f"{prefix}-{name}.svg"
            io.write_curve_svg(
                path, self._points.astype(np.float64), self._schemes[name],
                boundary=self.boundary, levels=max(self.levels, 1),
            )
            written.append(path)
        path = f"{prefix}.png"
        self.savefig(path)
        written.append(path)
        self.status = f"saved {len(written)} files: {prefix}.json, .png, *.svg"
        self._update_text()
        self._redraw()
        return written

    def savefig(self, path: str | os.PathLike, **kwargs) -> None:
        """Save a picture of the editor (`Figure.savefig` arguments)."""
        self.figure.savefig(path, **kwargs)

    def show(self, block: bool | None = None) -> None:
        """Show the editor window (`matplotlib.pyplot.show`)."""
        import matplotlib.pyplot as plt

        plt.show(block=block)

    def disconnect(self) -> None:
        """Stop reacting to the figure's mouse and key events."""
        for cid in self._cids:
            self.figure.canvas.mpl_disconnect(cid)
        self._cids = []

    # ----------------------------------------------------------------------------------
    # Computation and drawing

    def _build_scheme(self, name: str) -> None:
        try:
            self._schemes[name] = CURVES[name].make(self.parameters)
            self._errors.pop(name, None)
        except ValueError as e:  # e.g. r >= s
            self._schemes[name] = None
            self._errors[name] = str(e).split(" Got ")[0]

    def _update_curves(self, names: Sequence[str] | None = None) -> None:
        """Refine the polygon with every shown curve in `names` and set the lines' data."""
        names = self.shown if names is None else [n for n in names if self._shown[n]]
        points = self._points
        for name in names:
            scheme = self._schemes[name]
            line = self.lines[name]
            if scheme is None:
                self.curve_points[name] = np.empty((0, 2), self._dtype)
                line.set_data([], [])
                continue
            if self.closed:
                curve = _closed_refine(points, scheme, self.levels)
            else:
                curve = np.asarray(refine(points, scheme, self.levels, boundary="clamped"))
            self.curve_points[name] = curve
            if self.closed:
                curve = np.concatenate([curve, curve[:1]])
            line.set_data(curve[:, 0], curve[:, 1])
        closed = np.concatenate([points, points[:1]]) if self.closed else points
        self.polygon_line.set_data(closed[:, 0], closed[:, 1])

    def _update_smoothness(self, names) -> None:
        start = time.perf_counter()
        for name in names:
            scheme = self._schemes[name]
            self._smooth_text[name] = (
                self._errors.get(name, "invalid parameters")
                if scheme is None
                else format_smoothness(smoothness(scheme))
            )
            self._smooth_stale.discard(name)
        self._smooth_seconds = time.perf_counter() - start

    def _update_text(self) -> None:
        for name, curve in CURVES.items():
            mark = "■" if self._shown[name] else "□"
            values = ", ".join(f"{p} = {self.parameters[p]:.4g}" for p in curve.parameters)
            smooth = self._smooth_text.get(name, "")
            if name in self._smooth_stale:
                smooth += " (updates on release)"
            head = f"{mark} [{curve.key}] {curve.label}" + (f"  {values}" if values else "")
            self._texts[name].set_text(f"{head}\n     {smooth}")
            self._texts[name].set_alpha(1.0 if self._shown[name] else 0.45)
        n = len(self._points)
        counts = sorted({len(self.curve_points[c]) for c in self.shown if c in self.curve_points})
        lines = [
            f"{n} control points, {'closed' if self.closed else 'open (clamped ends)'}",
            f"level {self.levels}: "
            + (f"{'/'.join(map(str, counts))} points per curve" if counts else "no curve shown"),
            f"{self._dtype.name}",
        ]
        if self.status:
            lines.append(self.status)
        self._status_text.set_text("\n".join(lines))

    def _refresh(self) -> None:
        self._update_curves()
        self._update_text()
        self._redraw()

    def _redraw(self) -> None:
        self.figure.canvas.draw_idle()

    # ----------------------------------------------------------------------------------
    # Events

    def _toolbar_busy(self) -> bool:
        toolbar = getattr(self.figure.canvas, "toolbar", None)
        return bool(toolbar is not None and getattr(toolbar, "mode", ""))

    def _pixels(self) -> np.ndarray:
        return self.ax.transData.transform(self._points.astype(np.float64))

    def _data(self, event) -> np.ndarray:
        return self.ax.transData.inverted().transform((event.x, event.y))

    def nearest_vertex(self, x: float, y: float) -> tuple[int, float]:
        """Index of the vertex nearest the pixel `(x, y)` and its distance in pixels."""
        distances = np.hypot(*(self._pixels() - np.array([x, y])).T)
        index = int(np.argmin(distances))
        return index, float(distances[index])

    def nearest_edge(self, x: float, y: float) -> tuple[int, float]:
        """Index `i` of the edge `(i, i + 1)` nearest the pixel `(x, y)`, and its
        distance in pixels."""
        a = self._pixels()
        b = np.roll(a, -1, axis=0)
        if not self.closed:
            a, b = a[:-1], b[:-1]
        p = np.array([x, y])
        ab = b - a
        length2 = np.maximum((ab**2).sum(axis=1), 1e-12)
        u = np.clip(((p - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
        distances = np.hypot(*(a + u[:, None] * ab - p).T)
        index = int(np.argmin(distances))
        return index, float(distances[index])

    def _on_press(self, event) -> None:
        if event.inaxes is not self.ax or self._toolbar_busy():
            return
        vertex, distance = self.nearest_vertex(event.x, event.y)
        if event.button == 3:
            if distance <= self.pick_radius:
                self.delete_vertex(vertex)
            return
        if event.button != 1:
            return
        if distance <= self.pick_radius:
            self._begin_drag(vertex)
            return
        edge, distance = self.nearest_edge(event.x, event.y)
        if distance <= self.pick_radius:
            self._begin_drag(self.insert_vertex(edge, self._data(event)))

    def _dynamic_artists(self) -> list:
        return [self.lines[name] for name in self.shown] + [self.polygon_line]

    def _begin_drag(self, vertex: int) -> None:
        """Start dragging `vertex`. With a canvas that can blit, the curves and the
        polygon become animated: one full draw saves everything else as a background,
        and each move then redraws only them over it."""
        self._dragging = vertex
        canvas = self.figure.canvas
        if not canvas.supports_blit:
            return
        for artist in self._dynamic_artists():
            artist.set_animated(True)
        canvas.draw()
        self._background = canvas.copy_from_bbox(self.ax.bbox)
        self._blit()

    def _blit(self) -> None:
        canvas = self.figure.canvas
        canvas.restore_region(self._background)
        for artist in self._dynamic_artists():
            self.ax.draw_artist(artist)
        canvas.blit(self.ax.bbox)

    def _on_motion(self, event) -> None:
        if self._dragging is None:
            return
        self._points[self._dragging] = self._data(event)
        self._update_curves()
        if self._background is None:
            self._redraw()
        else:
            self._blit()

    def _on_release(self, event) -> None:
        if self._dragging is not None:
            self._dragging = None
            if self._background is not None:
                self._background = None
                for artist in self._dynamic_artists():
                    artist.set_animated(False)
            self._refresh()
        if self._smooth_stale:  # a slider was released
            self._update_smoothness(tuple(self._smooth_stale))
            self._update_text()
            self._redraw()

    def _on_key(self, event) -> None:
        key = event.key
        toggles = {curve.key: name for name, curve in CURVES.items()}
        if key in toggles:
            self.toggle(toggles[key])
        elif key == "c":
            self.toggle("polygon")
        elif key is not None and len(key) == 1 and key.isdigit() and key != "0":
            self.set_level(int(key))
        elif key in ("d", "delete", "backspace"):
            if event.x is None or event.y is None or len(self._points) == 0:
                return
            self.delete_vertex(self.nearest_vertex(event.x, event.y)[0])
        elif key == "o":
            self.set_closed(not self.closed)
        elif key == " ":
            self.reset()
        elif key == "a":
            self.view_all()
        elif key == "s":
            try:
                self.save()
            except (OSError, ValueError) as e:
                self.status = f"save failed: {e}"
                self._update_text()
                self._redraw()
        elif key == "h":
            self._help_text.set_visible(not self._help_text.get_visible())
            self._redraw()
        elif key == "t":
            self.toggle("target")
        elif key == "r":
            self.refit()


#: Closed polygons are padded to a multiple of this many points (see `_closed_refine`).
_BUCKET = 32


def _closed_refine(points: np.ndarray, scheme: AbstractCurveScheme, levels: int) -> np.ndarray:
    """`refine(points, scheme, levels)` for a closed polygon, compiled once per bucket of
    `_BUCKET` polygon sizes rather than once per size.

    The polygon is wrapped around by `e` points on each side (more than the scheme's
    stencil reaches), padded to a multiple of `_BUCKET` points by repeating its last
    point, and refined with `boundary="open"`, whose shapes depend only on the padded
    size. Each output depends only on the few control points under its stencil, so the
    outputs of the wrapped polygon are exactly the closed curve's; the host slices them
    out. Inserting or deleting a vertex then reuses the compiled kernel.
    """
    n = len(points)
    e = scheme.mask_length
    wrapped = np.take(points, np.arange(-e, n + e) % n, axis=0)
    capacity = -(-len(wrapped) // _BUCKET) * _BUCKET
    padded = np.concatenate([wrapped, np.repeat(wrapped[-1:], capacity - len(wrapped), 0)])
    out = np.asarray(refine(padded, scheme, levels, boundary="open"))
    first, _ = open_levels(capacity, scheme.mask_start, scheme.mask_length, levels)
    offset = e * 2**levels - first
    return out[offset : offset + n * 2**levels]


PARAMETERS_DEFAULTS = {name: default for name, (_, _, default) in PARAMETERS.items()}


def _run_fit(target, scheme, n_control, boundary, init, options):
    import fitting

    return fitting.fit(
        target, scheme, n_control, boundary=boundary, init=init, on_failure="ignore", **options
    )


def _fit_status(result) -> str:
    size = float(np.linalg.norm(np.ptp(np.asarray(result.curve), axis=0))) or 1.0
    rms = float(result.rms)
    state = "converged" if bool(result.converged) else "NOT converged"
    text = f"fit {state}: rms {rms:.3g} ({rms / size:.1e} of size), {int(result.num_steps)} steps"
    return text if math.isfinite(rms) else f"fit failed: {result.message}"
