"""The editor's matplotlib view and controller (see `jaxsubdiv.editor`).

[`jaxsubdiv.editor.Editor`][] builds a figure around an
[`jaxsubdiv.editor.EditorState`][] (`_editor_state.py`, the model, headless), draws it,
and maps mouse and key events to the state's methods. The key map is the table `KEYS`
(plus `FIT_KEYS` in fit mode), and the help line in the figure is generated from it.

Design notes:

- At the press of a drag, the curves and the polygon become animated and one full draw
  saves the rest of the figure; each move then redraws only them and blits the axes
  (when the canvas can blit; otherwise `draw_idle`).
- Everything else updates the existing `Line2D` artists with `set_data` and asks for a
  redraw with `draw_idle`, so the backend coalesces events it cannot keep up with.
- Smoothness is recomputed live while a slider moves as long as the last computation
  was quick (`_LIVE_SMOOTHNESS_BUDGET`), and otherwise once the slider is released.
"""

import os
import typing
from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
from jaxtyping import ArrayLike, Float

from ._editor_state import (
    CURVES,
    DEFAULT_CURVES,
    MAX_LEVELS,
    PARAMETERS,
    EditorState,
    check_parameter,
)
from ._scheme.base import AbstractCurveScheme


#: What a key does: `action(editor, key_event)`.
KeyAction = Callable[["Editor", Any], None]

# Seconds a live smoothness update may take before further updates wait for the
# slider's release.
_LIVE_SMOOTHNESS_BUDGET = 0.025


def _short(label: str) -> str:
    """A curve's label without its parenthesised details: "Jarek (split-tweak t)" -> "Jarek"."""
    return label.split(" (")[0]


def _delete_at_cursor(editor: "Editor", event) -> None:
    if event.x is None or event.y is None:
        return
    editor.delete_vertex(editor.nearest_vertex(event.x, event.y)[0])


def _save_reporting_errors(editor: "Editor", event) -> None:
    try:
        editor.save()
    except (OSError, ValueError) as e:  # a key press has no caller to raise to
        editor.status = f"save failed: {e}"
        editor._refresh()


#: Keys that show or hide things: `key -> (description, action)`.
SHOW_KEYS: dict[str, tuple[str, KeyAction]] = {
    "c": ("polygon", lambda ed, ev: ed.toggle("polygon")),
    **{
        curve.key: (_short(curve.label), lambda ed, ev, name=name: ed.toggle(name))
        for name, curve in CURVES.items()
    },
}
#: Keys that edit or act: `key -> (description, action)`.
EDIT_KEYS: dict[str, tuple[str, KeyAction]] = {
    **{
        str(level): ("level", lambda ed, ev, level=level: ed.set_level(level))
        for level in range(1, MAX_LEVELS + 1)
    },
    "d": ("delete vertex", _delete_at_cursor),
    "delete": ("delete vertex", _delete_at_cursor),
    "backspace": ("delete vertex", _delete_at_cursor),
    "o": ("open/closed", lambda ed, ev: ed.set_closed(not ed.closed)),
    " ": ("reset", lambda ed, ev: ed.reset()),
    "a": ("view all", lambda ed, ev: ed.view_all()),
    "s": ("save", _save_reporting_errors),
    "h": ("help", lambda ed, ev: ed.toggle_help()),
}
#: Keys of fit mode (`Editor.from_fit`): `key -> (description, action)`.
FIT_KEYS: dict[str, tuple[str, KeyAction]] = {
    "t": ("target", lambda ed, ev: ed.toggle("target")),
    "r": ("refit", lambda ed, ev: ed.refit()),
}
#: The editor's key map: `key -> (description, action)`.
KEYS: dict[str, tuple[str, KeyAction]] = {**SHOW_KEYS, **EDIT_KEYS, **FIT_KEYS}
#: Mouse gestures, for the help line: `(gesture, what it does)`.
MOUSE = (("drag", "move vertex"), ("drag near edge", "insert"), ("right-click", "delete"))

_KEY_NAMES = {" ": "space"}


def _format_keys(table: dict[str, tuple[str, KeyAction]], separator: str) -> str:
    """`"key description"` items of `table`, keys with one description merged
    (`d/delete/backspace`, and runs of digits as `1-9`)."""
    groups: dict[str, list[str]] = {}
    for key, (description, _) in table.items():
        groups.setdefault(description, []).append(_KEY_NAMES.get(key, key))
    items = []
    for description, keys in groups.items():
        digits = [int(k) for k in keys if k.isdigit()]
        if len(keys) > 2 and len(digits) == len(keys) and digits == list(range(digits[0], digits[-1] + 1)):
            keys = [f"{digits[0]}-{digits[-1]}"]
        items.append(f"{'/'.join(keys)} {description}")
    return separator.join(items)


def help_lines(fit: bool = False) -> list[str]:
    """The help shown at the top of the figure, generated from `MOUSE` and the key
    tables: mouse and show/hide keys on the first line, the other keys on the second."""
    mouse = " | ".join(f"{gesture}: {effect}" for gesture, effect in MOUSE)
    edits = {**EDIT_KEYS, **(FIT_KEYS if fit else {})}
    return [
        f"{mouse} | show: {_format_keys(SHOW_KEYS, ', ')}",
        f"keys: {_format_keys(edits, ' | ')}",
    ]


@typing.final
class Editor:
    """An interactive editor for subdivision curves in a matplotlib figure.

    Drag control vertices and watch the cubic B-spline, four-point, Jarek, Chaikin and
    corner-cutting curves follow; tune `w`, `r`, `s` and `t` with sliders and read each
    shown curve's Hölder exponent and $C^k$ class (from [`jaxsubdiv.smoothness`][]).
    Use it to learn how the schemes differ, to tune a parameter by eye, or to touch up a
    fitted polygon ([`jaxsubdiv.editor.Editor.from_fit`][]).

    The editor is a view of an [`jaxsubdiv.editor.EditorState`][] (`editor.state`), the
    model without matplotlib: the methods below change the state and redraw.

    Mouse: drag a vertex to move it; press near an edge and drag to insert a vertex
    there; right-click a vertex to delete it. Keys (the table `jaxsubdiv.editor.KEYS`;
    press `h` for the on-screen help): `c` control polygon, `b` cubic B-spline, `f`
    four-point, `j` Jarek, `k` Chaikin, `x` corner cutting, `1`-`9` level, `o`
    open/closed, `d`/`delete`/`backspace` delete the vertex nearest the cursor, space
    reset, `a` fit the view, `s` save, `h` help, and in fit mode `t` target and `r`
    refit. matplotlib's own key bindings are switched off for this figure; its toolbar
    still works.

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
    - `pick_radius`: how close, in screen pixels, a press must be to a vertex or an edge.
    - `save_prefix`: path prefix of the files the `s` key writes (see `save`).
    - `figure`: a matplotlib `Figure` to draw into (it is cleared); default a new
      `pyplot` figure.
    - `target`: an outline `(m, 2)` to show behind the curves (fit mode).
    - `**parameters`: starting parameter values: `w` (four-point tension), `r`, `s`
      (corner-cutting ratios), `t` (split-tweak; `t = 1/2` is Jarek's scheme). Defaults
      and valid ranges from the scheme registry; a value outside its range is a
      `ValueError` naming it.
    """

    def __init__(
        self,
        points: Float[ArrayLike, "n 2"],
        *,
        closed: bool = True,
        curves: Sequence[str] = DEFAULT_CURVES,
        levels: int = 5,
        pick_radius: float = 10.0,
        save_prefix: str | os.PathLike = "jaxsubdiv-edit",
        figure=None,
        target: Float[ArrayLike, "m 2"] | None = None,
        **parameters: float,
    ):
        state = EditorState(
            points, closed=closed, curves=curves, levels=levels, target=target,
            save_prefix=save_prefix, **parameters,
        )
        self._attach(state, pick_radius, figure)

    @classmethod
    def from_state(
        cls, state: EditorState, *, pick_radius: float = 10.0, figure=None
    ) -> "Editor":
        """An editor drawing `state` (which it then changes in place)."""
        if not isinstance(state, EditorState):
            raise TypeError(f"`state` must be an EditorState, got {type(state).__name__}.")
        editor = cls.__new__(cls)
        editor._attach(state, pick_radius, figure)
        return editor

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
        pick_radius: float = 10.0,
        figure=None,
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
        - `pick_radius`, `figure`, `editor_options`: keyword arguments for `Editor`
          (not `points`, `closed`, `target`).

        **Returns:** the `Editor`; `editor.fit_result` holds the `fitting.FitResult`.
        """
        state = EditorState.from_fit(
            source, n_control=n_control, scheme=scheme, outline=outline, samples=samples,
            fit_options=fit_options, **editor_options,
        )
        return cls.from_state(state, pick_radius=pick_radius, figure=figure)

    # ----------------------------------------------------------------------------------
    # Construction

    def _attach(self, state: EditorState, pick_radius, figure) -> None:
        if not pick_radius > 0:
            raise ValueError(f"`pick_radius` must be a positive number of pixels, got {pick_radius}.")
        self.state = state
        self.pick_radius = float(pick_radius)
        self.keys = dict(KEYS)
        self._dragging: int | None = None
        self._background = None
        self._build_figure(figure)
        self._update_lines()
        self._update_text()
        self.view_all()

    def _build_figure(self, figure):
        import matplotlib.pyplot as plt
        from matplotlib.widgets import Slider

        if figure is None:
            figure = plt.figure(figsize=(11, 7.5))
        else:
            figure.clear()
        self.figure = figure
        self.ax = figure.add_axes((0.04, 0.2, 0.62, 0.71))
        self.ax.set_aspect("equal", adjustable="box")
        info = figure.add_axes((0.68, 0.2, 0.31, 0.71))
        info.set_axis_off()
        self._info_ax = info
        target = self.state.target
        if target is not None:
            closed_target = np.vstack([target, target[:1]])
            (self.target_line,) = self.ax.plot(
                *closed_target.T, ".", ms=2.5, color="0.6", zorder=1, label="target"
            )
        else:
            self.target_line = None
        self.lines = {}
        for name, curve in CURVES.items():
            (self.lines[name],) = self.ax.plot([], [], lw=1.6, color=curve.color, zorder=2)
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
        # Two deliberate lines, never wrapped (tests/test_editor.py measures that they
        # fit the default figure's width).
        self._help_text = figure.text(
            0.01, 0.99, "\n".join(help_lines(fit=target is not None)),
            fontsize=8, va="top", color="0.3",
        )
        self.sliders = {}
        for i, (name, (low, high, _)) in enumerate(PARAMETERS.items()):
            slider_ax = figure.add_axes((0.1, 0.13 - 0.035 * i, 0.5, 0.025))
            slider = Slider(
                slider_ax, name, low, high, valinit=self.state.parameters[name], valfmt="%.4f"
            )
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

    # ----------------------------------------------------------------------------------
    # The state (read from `self.state`)

    @property
    def points(self) -> np.ndarray:
        """The control polygon, `(n, 2)` (a copy)."""
        return self.state.points

    @property
    def closed(self) -> bool:
        """True if the polygon is closed (set it with `set_closed`)."""
        return self.state.closed

    @property
    def boundary(self) -> Literal["closed", "clamped"]:
        """The boundary the curves are refined with: `"closed"` or `"clamped"` (open)."""
        return self.state.boundary

    @property
    def levels(self) -> int:
        """The refinement level (set it with `set_level`)."""
        return self.state.levels

    @property
    def parameters(self) -> dict[str, float]:
        """The parameter values by name (set them with `set_parameter`)."""
        return self.state.parameters

    @property
    def shown(self) -> tuple[str, ...]:
        """Names of the curves shown."""
        return self.state.shown

    @property
    def curve_points(self) -> dict[str, np.ndarray]:
        """The refined points of every shown curve, by name."""
        return self.state.curve_points

    @property
    def target(self) -> np.ndarray | None:
        """The outline of fit mode, `(m, 2)`, or None."""
        return self.state.target

    @property
    def fit_info(self) -> dict | None:
        """How `refit` fits (fit mode), or None."""
        return self.state.fit_info

    @property
    def fit_result(self):
        """The last `fitting.FitResult` (fit mode), or None."""
        return self.state.fit_result

    @property
    def save_prefix(self) -> str | os.PathLike:
        """Path prefix of the files `save` writes."""
        return self.state.save_prefix

    @property
    def status(self) -> str:
        """The status line: what the last action did or why it was refused."""
        return self.state.status

    @status.setter
    def status(self, text: str) -> None:
        self.state.status = text

    @property
    def polygon_shown(self) -> bool:
        return self.polygon_line.get_visible()

    def scheme(self, name: str) -> AbstractCurveScheme | None:
        """The scheme of curve `name` at the current parameters (None if they are invalid)."""
        return self.state.scheme(name)

    def min_points(self) -> int:
        """The fewest control points every curve accepts with the current boundary."""
        return self.state.min_points()

    # ----------------------------------------------------------------------------------
    # Edits (what the mouse and keys do; callable from scripts)

    def set_points(self, points: Float[ArrayLike, "n 2"], closed: bool | None = None) -> None:
        """Replace the control polygon (and optionally open or close it)."""
        self.state.set_points(points, closed)
        self._refresh()

    def move_vertex(self, index: int, xy: Float[ArrayLike, "2"]) -> None:
        """Move control vertex `index` to `xy` (data coordinates)."""
        self.state.move_vertex(index, xy)
        self._refresh()

    def insert_vertex(self, edge: int, xy: Float[ArrayLike, "2"]) -> int:
        """Insert a vertex at `xy` on edge `(edge, edge + 1)`; returns its index."""
        index = self.state.insert_vertex(edge, xy)
        self._refresh()
        return index

    def delete_vertex(self, index: int) -> bool:
        """Delete vertex `index`, unless that leaves fewer than `min_points()` (the
        status line then says why).

        **Returns:** True if the vertex was deleted.
        """
        deleted = self.state.delete_vertex(index)
        self._refresh()
        return deleted

    def set_closed(self, closed: bool) -> bool:
        """Close or open the polygon (an open one is refined with clamped ends); returns
        False if it cannot be closed (fewer than 3 points)."""
        done = self.state.set_closed(closed)
        self._refresh()
        return done

    def set_level(self, levels: int) -> None:
        """Set the refinement level (0-9)."""
        self.state.set_level(levels)
        self._refresh()

    def toggle(self, name: str) -> bool:
        """Show or hide curve `name` (or `"polygon"`, or `"target"`); returns the new state."""
        if name == "polygon":
            self.polygon_line.set_visible(not self.polygon_line.get_visible())
            self._redraw()
            return self.polygon_line.get_visible()
        if name == "target":
            if self.target_line is None:
                return False
            self.target_line.set_visible(not self.target_line.get_visible())
            self._redraw()
            return self.target_line.get_visible()
        if name not in CURVES:
            raise ValueError(
                f"`name` must be 'polygon', 'target' or one of {tuple(CURVES)}; got {name!r}."
            )
        shown = self.state.toggle(name)
        self._refresh()
        return shown

    def toggle_help(self) -> bool:
        """Show or hide the help lines at the top of the figure; returns the new state."""
        self._help_text.set_visible(not self._help_text.get_visible())
        self._redraw()
        return self._help_text.get_visible()

    def set_parameter(self, name: str, value: float) -> None:
        """Set `w`, `r`, `s` or `t` and update the curves that use it.

        Called by the sliders; calling it moves the slider too.

        **Raises:** `ValueError` naming the parameter and its range if `value` is outside
        it (e.g. `w` outside (-1/2, 1/2), where four-point converges).
        """
        value = check_parameter(name, value)
        slider = self.sliders[name]
        if slider.val != value:
            slider.set_val(value)  # calls back into set_parameter
            return
        # While the slider is dragged after a slow smoothness call, the labels wait for
        # the release (`_on_release`).
        defer = slider.drag_active and self.state.smoothness_seconds >= _LIVE_SMOOTHNESS_BUDGET
        self.state.set_parameter(name, value, defer_smoothness=defer)
        self._refresh()

    def reset(self) -> None:
        """Back to the polygon (and open/closed state) the editor started with."""
        self.state.reset()
        self._refresh()

    def view_all(self) -> None:
        """Fit the view to the polygon, the shown curves and the target."""
        low, high = self.state.bounds()
        margin = 0.08 * max(float(np.max(high - low)), 1e-9)
        self.ax.set_xlim(low[0] - margin, high[0] + margin)
        self.ax.set_ylim(low[1] - margin, high[1] + margin)
        self._redraw()

    def refit(self) -> None:
        """Fit the target again with the current number of control points, starting
        from the current polygon (fit mode only)."""
        self.state.refit()
        self._refresh()

    def save(self, prefix: str | os.PathLike | None = None) -> list[str]:
        """Write the polygon, the shown curves and a picture.

        Files, for `prefix` `P` (default `save_prefix`): `P.json`, `P-polygon.svg`,
        `P-<curve>.svg` per shown curve (see [`jaxsubdiv.editor.EditorState.save`][]),
        and `P.png`, a picture of the editor.

        **Returns:** the paths written.
        """
        written = self.state.save(prefix, picture=self.savefig)
        self._refresh()
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
    # Drawing

    def _update_lines(self) -> None:
        """Set the lines' data from the state's curves and polygon."""
        state = self.state
        for name, line in self.lines.items():
            shown = name in state.curve_points and name in state.shown
            line.set_visible(shown)
            if not shown:
                continue
            curve = state.curve_points[name]
            if state.closed and len(curve):
                curve = np.concatenate([curve, curve[:1]])
            line.set_data(curve[:, 0], curve[:, 1])
        points = state.points
        closed = np.concatenate([points, points[:1]]) if state.closed else points
        self.polygon_line.set_data(closed[:, 0], closed[:, 1])

    def _update_text(self) -> None:
        state = self.state
        for name, curve in CURVES.items():
            shown = name in state.shown
            mark = "■" if shown else "□"
            values = ", ".join(f"{p} = {state.parameters[p]:.4g}" for p in curve.parameters)
            smooth = state.smoothness.get(name, "")
            if name in state.stale_smoothness:
                smooth += " (updates on release)"
            head = f"{mark} [{curve.key}] {curve.label}" + (f"  {values}" if values else "")
            self._texts[name].set_text(f"{head}\n     {smooth}")
            self._texts[name].set_alpha(1.0 if shown else 0.45)
        n = len(state.points)
        counts = sorted({len(state.curve_points[c]) for c in state.shown if c in state.curve_points})
        lines = [
            f"{n} control points, {'closed' if state.closed else 'open (clamped ends)'}",
            f"level {state.levels}: "
            + (f"{'/'.join(map(str, counts))} points per curve" if counts else "no curve shown"),
            f"{state.dtype.name}",
        ]
        if state.status:
            lines.append(state.status)
        self._status_text.set_text("\n".join(lines))

    def _refresh(self) -> None:
        self._update_lines()
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
        return self.ax.transData.transform(self.state.points.astype(np.float64))

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
        self.state.move_vertex(self._dragging, self._data(event))
        self._update_lines()
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
        if self.state.stale_smoothness:  # a slider was released
            self.state.update_smoothness()
            self._update_text()
            self._redraw()

    def _on_key(self, event) -> None:
        entry = self.keys.get(event.key)
        if entry is not None:
            entry[1](self, event)
