"""The editor's model, headless: polygon, edits, schemes, curves, smoothness, fit, save.

[`jaxsubdiv.editor.EditorState`][] holds everything the interactive editor shows and
changes, and nothing about how it is shown: no matplotlib is imported here, so scripts,
tests and other front ends (a notebook widget, a web page) drive the same model as the
matplotlib view ([`jaxsubdiv.editor.Editor`][], in `_editor.py`).

Design notes:

- The control polygon lives on the host as a NumPy array in JAX's default float dtype
  (float64 when `jax_enable_x64` is on, float32 otherwise); the state never changes
  JAX's configuration.
- Curves are computed with the public [`jaxsubdiv.refine`][], whose jitted kernel is
  compiled once per (scheme type, number of points, dtype, levels, boundary). Moving a
  vertex or changing a parameter changes values, not shapes, so it never recompiles.
  Closed polygons are padded to a bucket of sizes (`_closed_refine`), so inserting or
  deleting a vertex does not recompile either; an open polygon (clamped ends) compiles
  once per new vertex count, and a new level once per level.
- Scheme knowledge (parameter names, defaults, valid ranges, titles) comes from the
  scheme registry ([`jaxsubdiv.schemes`][]); the editor's own table `CURVES` only says
  which registry entry each curve draws, and its key letter and colour in the view.
- Smoothness ([`jaxsubdiv.smoothness`][], NumPy and SciPy on the host, a few ms per
  value, 10-150 ms when the invariant polytope runs; cached per value) can be deferred
  while a parameter moves: the view asks for that when the last computation was slow.
"""

import dataclasses
import math
import os
import time
import typing
from collections.abc import Callable, Iterable, Sequence
from typing import Literal

import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from ._analysis.smoothness import smoothness
from ._kernel import open_levels
from ._refine import _min_points, refine
from ._scheme.base import AbstractCurveScheme
from ._scheme.registry import Parameter, SchemeInfo, scheme_info


@dataclasses.dataclass(frozen=True)
class Curve:
    """One curve the editor draws: what is the editor's own, the rest is the registry's.

    - `key`: the key that shows or hides it in the view.
    - `color`: its matplotlib colour in the view.
    - `scheme`: the registry name of the scheme it draws ([`jaxsubdiv.schemes`][]); its
      parameters are the editor's parameters of that curve.
    - `label`: the name shown in the view (default: the registry entry's title).
    - `also_draws`: registry names of parameterless schemes this curve draws at its
      parameters' defaults (`Jarek()` is the split-tweak curve at its default `t = 1/2`).
    """

    key: str
    color: str
    scheme: str
    label: str = ""
    also_draws: tuple[str, ...] = ()

    def __post_init__(self):
        if not self.label:
            object.__setattr__(self, "label", self.info.title)

    @property
    def info(self) -> SchemeInfo:
        """The registry entry of the scheme drawn."""
        return scheme_info(self.scheme)

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of the parameters the curve depends on."""
        return tuple(p.name for p in self.info.parameters)

    def make(self, values: dict[str, float]) -> AbstractCurveScheme:
        """The scheme at the parameter values `values` (a dict holding at least its own)."""
        return self.info.make(**{name: values[name] for name in self.parameters})


#: The curves the editor draws, by name (the names of the `jaxsubdiv edit` command's
#: `--curves` option), in the order of the view's panel.
CURVES: dict[str, Curve] = {
    "cubic-bspline": Curve("b", "tab:red", "cubic-bspline", label="cubic B-spline"),
    "four-point": Curve("f", "tab:blue", "four-point"),
    "jarek": Curve(
        "j", "tab:green", "split-tweak", label="Jarek (split-tweak t)", also_draws=("jarek",)
    ),
    "chaikin": Curve("k", "tab:purple", "chaikin", label="Chaikin"),
    "corner-cutting": Curve("x", "tab:brown", "corner-cutting", label="corner cutting (r, s)"),
}
DEFAULT_CURVES = ("cubic-bspline", "four-point", "jarek")
#: The levels the editor refines to (the view's keys 1-9 set 1 to 9).
MAX_LEVELS = 9


def _editor_parameters() -> dict[str, Parameter]:
    """Every parameter of the editor's curves, by name (from the registry)."""
    table: dict[str, Parameter] = {}
    for name, curve in CURVES.items():
        for parameter in curve.info.parameters:
            # One value per name: two curves sharing a name would share one slider.
            if parameter.name in table and table[parameter.name] != parameter:
                raise RuntimeError(f"two editor curves declare parameter {parameter.name!r}")
            table[parameter.name] = parameter
    return table


#: The parameters of the editor's curves, by name, as the registry declares them.
PARAMETER_INFO: dict[str, Parameter] = _editor_parameters()


def slider_range(parameter: Parameter) -> tuple[float, float]:
    """The range a slider for `parameter` covers: its declared `slider` range, or where
    the scheme converges (its `converges` interval), or else its valid range, with an
    open end moved inside by 1% of the range (an open end itself is not a valid
    value)."""
    if parameter.slider is not None:
        return tuple(float(v) for v in parameter.slider)
    if parameter.converges is not None:
        low, high = (float(v) for v in parameter.converges)
        low_open = high_open = True
    else:
        low, high = float(parameter.low), float(parameter.high)
        low_open, high_open = parameter.low_open, parameter.high_open
    nudge = 0.01 * (high - low)
    return (low + nudge if low_open else low, high - nudge if high_open else high)


#: Slider ranges and defaults: `name -> (low, high, default)`.
PARAMETERS: dict[str, tuple[float, float, float]] = {
    name: (*slider_range(p), float(p.default)) for name, p in PARAMETER_INFO.items()
}


def check_parameter(name: str, value) -> float:
    """`value` as a float if it is a valid value of editor parameter `name`.

    **Raises:** `ValueError` naming the parameter and its range when it is not.
    """
    if name not in PARAMETER_INFO:
        raise ValueError(
            f"`name` must be an editor parameter, one of {tuple(PARAMETER_INFO)}; got {name!r}."
        )
    parameter = PARAMETER_INFO[name]
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be a number, got {value!r}.") from None
    if not (parameter.valid(value) and parameter.converges_at(value)):
        # The editor draws limit curves: a value where the scheme diverges has none.
        where = (f"{parameter.converges_text()} (where the scheme converges)"
                 if parameter.converges else parameter.range_text())
        raise ValueError(f"{parameter.help}: `{name}` must satisfy {where}, got {value:g}.")
    return value


def scheme_curve(scheme: AbstractCurveScheme) -> tuple[str, dict[str, float]]:
    """The editor curve that draws `scheme`, and the parameter values it sets."""
    try:
        entry = scheme_info(scheme).name
    except (TypeError, ValueError):  # not in the registry: drawn by no curve
        entry = None
    for name, curve in CURVES.items():
        if entry == curve.scheme:
            return name, {k: float(v) for k, v in curve.info.values(scheme).items()}
        if entry in curve.also_draws:
            return name, {p.name: float(p.default) for p in curve.info.parameters}
    drawn = [
        scheme_info(entry).cls.__name__
        for curve in CURVES.values()
        for entry in (curve.scheme, *curve.also_draws)
    ]
    raise ValueError(
        f"the editor draws {', '.join(drawn)} curves; got "
        f"`scheme={type(scheme).__name__}(...)`. Fit one of those, or refine this scheme "
        "with `jaxsubdiv.refine`."
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


def _checked_points(points, closed: bool, dtype) -> np.ndarray:
    try:
        array = np.array(points, dtype=dtype)
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


def _checked_levels(levels) -> int:
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)):
        raise TypeError(f"`levels` must be an int from 0 to {MAX_LEVELS}, got {levels!r}.")
    if not 0 <= levels <= MAX_LEVELS:
        raise ValueError(f"`levels` must be from 0 to {MAX_LEVELS}, got {levels}.")
    return int(levels)


@typing.final
class EditorState:
    """The editor's model, without a figure: the control polygon and everything computed
    from it.

    Holds the control polygon (open or closed), the refinement level, which curves are
    shown, the curves' parameters, each shown curve's refined points, each curve's
    smoothness label, and in fit mode the target outline and the last fit. Its methods
    are the edits the editor's mouse and keys make; each recomputes what it changes
    (`curve_points`, smoothness) at once. [`jaxsubdiv.editor.Editor`][] draws one in a
    matplotlib figure; use `EditorState` directly for scripts, tests or another front
    end (it imports no matplotlib).

    ```python
    state = EditorState(js.shapes.get("star"), levels=4, w=0.1)
    state.move_vertex(3, (0.2, 0.5))
    state.curve_points["four-point"]        # (n 2^4, 2) points of the four-point curve
    state.smoothness["four-point"]          # e.g. "C¹, α ≈ 1.678"
    ```

    **Arguments:**

    - `points`: the control polygon, shape `(n, 2)`.
    - `closed`: True for a closed polygon; an open one is refined with
      `boundary="clamped"`, so the curves end at the end vertices.
    - `curves`: the curves shown at the start, names from `CURVES`: `"cubic-bspline"`,
      `"four-point"`, `"jarek"`, `"chaikin"`, `"corner-cutting"`.
    - `levels`: refinement level, 0-9.
    - `target`: an outline `(m, 2)` the polygon was fitted to (fit mode).
    - `save_prefix`: path prefix of the files `save` writes.
    - `**parameters`: starting parameter values by name, `w` (four-point tension), `r`
      and `s` (corner-cutting ratios), `t` (split-tweak; `t = 1/2` is Jarek's scheme);
      defaults and valid ranges from the scheme registry ([`jaxsubdiv.scheme_info`][]).
    """

    def __init__(
        self,
        points: Float[ArrayLike, "n 2"],
        *,
        closed: bool = True,
        curves: Sequence[str] = DEFAULT_CURVES,
        levels: int = 5,
        target: Float[ArrayLike, "m 2"] | None = None,
        save_prefix: str | os.PathLike = "jaxsubdiv-edit",
        **parameters: float,
    ):
        self.dtype = np.dtype(jnp.result_type(float))
        self.closed = bool(closed)
        self._points = _checked_points(points, self.closed, self.dtype)
        self._initial = (self._points.copy(), self.closed)
        if isinstance(curves, str):
            curves = (curves,)
        unknown = [c for c in curves if c not in CURVES]
        if unknown:
            raise ValueError(f"`curves` must be names from {tuple(CURVES)}; got {unknown[0]!r}.")
        self._shown = {name: name in curves for name in CURVES}
        self.levels = _checked_levels(levels)
        self.parameters = {name: float(p.default) for name, p in PARAMETER_INFO.items()}
        for name, value in parameters.items():
            if name not in PARAMETER_INFO:
                raise TypeError(
                    f"unknown argument `{name}`: the editor's parameters are "
                    f"{', '.join(PARAMETER_INFO)}."
                )
            self.parameters[name] = check_parameter(name, value)
        self.target = None if target is None else np.asarray(target, dtype=np.float64)
        self.save_prefix = save_prefix
        #: How to refit (set by `from_fit`): the fitted scheme, its curve, fit options.
        self.fit_info: dict | None = None
        #: The last `fitting.FitResult` (fit mode).
        self.fit_result = None
        #: One line saying what the last edit did or why it was refused.
        self.status = ""
        #: The refined points of every shown curve, by name.
        self.curve_points: dict[str, np.ndarray] = {}
        #: A smoothness label per curve (`format_smoothness`), or why it has no scheme.
        self.smoothness: dict[str, str] = {}
        #: Curves whose smoothness label waits for `update_smoothness()`.
        self.stale_smoothness: set[str] = set()
        #: Seconds the last smoothness update took.
        self.smoothness_seconds = 0.0
        self._schemes: dict[str, AbstractCurveScheme | None] = {}
        self._errors: dict[str, str] = {}
        for name in CURVES:
            self._build_scheme(name)
        self.update_curves()
        self.update_smoothness(CURVES)

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
        **state_options,
    ) -> "EditorState":
        """Fit a curve to an outline; the state of the fitted control polygon.

        Arguments as [`jaxsubdiv.editor.Editor.from_fit`][]; `state_options` are
        `EditorState` keyword arguments (not `points`, `closed`, `target`).
        """
        from . import io

        scheme = scheme_info("cubic-bspline").make() if scheme is None else scheme
        name, parameters = scheme_curve(scheme)
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
        curves = tuple(state_options.pop("curves", (name,)))
        if name not in curves:
            curves = (name, *curves)
        state = cls(
            np.asarray(result.control_points),
            closed=chosen.closed,
            curves=curves,
            target=target,
            **{**state_options, **parameters},
        )
        state.fit_info = dict(scheme=scheme, curve=name, boundary=boundary, options=fit_options)
        state.fit_result = result
        state.status = _fit_status(result)
        return state

    # ----------------------------------------------------------------------------------
    # What it holds

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
        """Names of the curves shown, in `CURVES` order."""
        return tuple(name for name, on in self._shown.items() if on)

    def scheme(self, name: str) -> AbstractCurveScheme | None:
        """The scheme of curve `name` at the current parameters (None if they are not a
        scheme, e.g. corner cutting with r >= s; `invalid_reason(name)` says why)."""
        return self._schemes[name]

    def invalid_reason(self, name: str) -> str | None:
        """Why curve `name` has no scheme at the current parameters (None if it has one)."""
        return self._errors.get(name)

    def min_points(self) -> int:
        """The fewest control points every curve accepts with the current boundary."""
        return max(
            _min_points(s, self.boundary) for s in self._schemes.values() if s is not None
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower-left and upper-right corners of the polygon, the shown curves and the
        target (float64)."""
        parts = [self._points] + [self.curve_points[n] for n in self.shown if n in self.curve_points]
        if self.target is not None:
            parts.append(self.target)
        everything = np.concatenate([np.asarray(p, np.float64) for p in parts if len(p)])
        return everything.min(axis=0), everything.max(axis=0)

    # ----------------------------------------------------------------------------------
    # Edits

    def set_points(self, points: Float[ArrayLike, "n 2"], closed: bool | None = None) -> None:
        """Replace the control polygon (and optionally open or close it)."""
        closed = self.closed if closed is None else bool(closed)
        self._points = _checked_points(points, closed, self.dtype)
        self.closed = closed
        self.update_curves()

    def _checked_index(self, index) -> int:
        n = len(self._points)
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < n:
            raise ValueError(f"`index` must be a vertex index in [0, {n - 1}], got {index!r}.")
        return int(index)

    def move_vertex(self, index: int, xy: Float[ArrayLike, "2"]) -> None:
        """Move control vertex `index` to `xy`."""
        self._points[self._checked_index(index)] = np.asarray(xy, dtype=self.dtype)
        self.update_curves()

    def insert_vertex(self, edge: int, xy: Float[ArrayLike, "2"]) -> int:
        """Insert a vertex at `xy` on edge `(edge, edge + 1)`; returns its index."""
        n = len(self._points)
        last = n if self.closed else n - 1
        if not 0 <= edge < last:
            raise ValueError(f"`edge` must be in [0, {last - 1}], got {edge}.")
        self._points = np.insert(self._points, edge + 1, np.asarray(xy, self.dtype), axis=0)
        self.update_curves()
        return edge + 1

    def delete_vertex(self, index: int) -> bool:
        """Delete vertex `index`, unless that leaves fewer than `min_points()` (then
        `status` says why).

        **Returns:** True if the vertex was deleted.
        """
        index = self._checked_index(index)
        if len(self._points) - 1 < self.min_points():
            self.status = (
                f"cannot delete: the curves need at least {self.min_points()} control "
                f"points ({self.boundary})"
            )
            return False
        self._points = np.delete(self._points, index, axis=0)
        self.status = ""
        self.update_curves()
        return True

    def set_closed(self, closed: bool) -> bool:
        """Close or open the polygon (an open one is refined with clamped ends).

        **Returns:** False (and `status` says why) if a polygon of fewer than 3 points
        was to be closed.
        """
        if closed and len(self._points) < 3:
            self.status = "cannot close a polygon of fewer than 3 points"
            return False
        self.closed = bool(closed)
        self.update_curves()
        return True

    def set_level(self, levels: int) -> None:
        """Set the refinement level (0-9)."""
        self.levels = _checked_levels(levels)
        self.update_curves()

    def set_shown(self, name: str, shown: bool) -> None:
        """Show or hide curve `name` (a name from `CURVES`)."""
        if name not in CURVES:
            raise ValueError(f"`name` must be one of {tuple(CURVES)}; got {name!r}.")
        self._shown[name] = bool(shown)
        if shown:
            self.update_curves((name,))
        else:
            self.curve_points.pop(name, None)

    def toggle(self, name: str) -> bool:
        """Show curve `name` if it is hidden, hide it if it is shown; returns the new state."""
        if name not in CURVES:
            raise ValueError(f"`name` must be one of {tuple(CURVES)}; got {name!r}.")
        self.set_shown(name, not self._shown[name])
        return self._shown[name]

    def set_parameter(self, name: str, value: float, *, defer_smoothness: bool = False) -> None:
        """Set parameter `name` (`w`, `r`, `s` or `t`) and update the curves that use it.

        With `defer_smoothness`, their smoothness labels wait for `update_smoothness()`
        (listed in `stale_smoothness`).

        **Raises:** `ValueError` naming the parameter and its valid range if `value` is
        outside it. (Values valid one by one but not together, such as corner cutting's
        r >= s, are accepted: that curve has no scheme until they are, see `scheme`.)
        """
        value = check_parameter(name, value)
        self.parameters[name] = value
        affected = tuple(n for n, c in CURVES.items() if name in c.parameters)
        for curve in affected:
            self._build_scheme(curve)
        self.update_curves(affected)
        if defer_smoothness:
            self.stale_smoothness.update(affected)
        else:
            self.update_smoothness(affected)

    def reset(self) -> None:
        """Back to the polygon (and open/closed state) the editor started with."""
        points, closed = self._initial
        self._points = points.copy()
        self.closed = closed
        self.status = "reset"
        self.update_curves()

    def refit(self) -> bool:
        """Fit the target again with the current number of control points, starting from
        the current polygon (fit mode only: otherwise `status` says so).

        **Returns:** True if a fit ran.
        """
        if self.fit_info is None:
            self.status = "no target to refit (start with Editor.from_fit or --fit)"
            return False
        info = self.fit_info
        scheme = self._schemes[info["curve"]] or info["scheme"]
        result = _run_fit(
            self.target, scheme, len(self._points), self.boundary, self._points, info["options"]
        )
        self.fit_result = result
        self._points = np.asarray(result.control_points, dtype=self.dtype)
        self.status = _fit_status(result)
        self.update_curves()
        return True

    def save(
        self,
        prefix: str | os.PathLike | None = None,
        *,
        picture: Callable[[str], None] | None = None,
    ) -> list[str]:
        """Write the polygon and the shown curves.

        Files, for `prefix` `P` (default `save_prefix`):

        - `P.json`: the control polygon and the scheme of the fitted curve (or of the
          first shown curve), boundary and levels, via [`jaxsubdiv.io.write_result_json`][];
          `info["editor"]` records the parameters, the shown curves and `closed`. Read it
          back with [`jaxsubdiv.io.read_result_json`][].
        - `P-polygon.svg`: the control polygon.
        - `P-<curve>.svg` for each shown curve, via [`jaxsubdiv.io.write_curve_svg`][]
          (exact Bezier segments for the B-spline and Chaikin curves).
        - `P.png` if `picture` is given: `picture(path)` draws it (the view passes its
          `savefig`).

        **Returns:** the paths written.
        """
        from . import io

        prefix = os.fspath(self.save_prefix if prefix is None else prefix)
        directory = os.path.dirname(prefix)
        if directory:
            os.makedirs(directory, exist_ok=True)
        primary = self.fit_info["curve"] if self.fit_info else (self.shown or DEFAULT_CURVES)[0]
        scheme = self._schemes[primary] or CURVES[primary].info.make()
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
        kinds = ".json, *.svg"
        if picture is not None:
            path = f"{prefix}.png"
            picture(path)
            written.append(path)
            kinds = ".json, .png, *.svg"
        self.status = f"saved {len(written)} files: {prefix}{kinds}"
        return written

    # ----------------------------------------------------------------------------------
    # Computation

    def _build_scheme(self, name: str) -> None:
        try:
            self._schemes[name] = CURVES[name].make(self.parameters)
            self._errors.pop(name, None)
        except ValueError as e:  # e.g. r >= s
            self._schemes[name] = None
            self._errors[name] = str(e).split(" Got ")[0]

    def update_curves(self, names: Iterable[str] | None = None) -> None:
        """Refine the polygon with every shown curve in `names` (default: all shown)."""
        names = self.shown if names is None else [n for n in names if self._shown[n]]
        for name in names:
            scheme = self._schemes[name]
            if scheme is None:
                self.curve_points[name] = np.empty((0, 2), self.dtype)
            elif self.closed:
                self.curve_points[name] = _closed_refine(self._points, scheme, self.levels)
            else:
                self.curve_points[name] = np.asarray(
                    refine(self._points, scheme, self.levels, boundary="clamped")
                )

    def update_smoothness(self, names: Iterable[str] | None = None) -> None:
        """Compute the smoothness labels of curves `names` (default: the stale ones)."""
        names = tuple(self.stale_smoothness if names is None else names)
        start = time.perf_counter()
        for name in names:
            scheme = self._schemes[name]
            self.smoothness[name] = (
                self._errors.get(name, "invalid parameters")
                if scheme is None
                else format_smoothness(smoothness(scheme))
            )
            self.stale_smoothness.discard(name)
        self.smoothness_seconds = time.perf_counter() - start


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


def _run_fit(target, scheme, n_control, boundary, init, options):
    import fitting

    return fitting.fit(
        target, scheme, n_control, boundary=boundary, init=init, on_failure="ignore", **options
    )


def _fit_status(result) -> str:
    size = float(np.linalg.norm(np.ptp(np.asarray(result.curve), axis=0))) or 1.0
    rms = float(result.rms)
    import fitting

    # (The status's name: a refit from dragged points can end in a poor local minimum.)
    state = ("converged" if bool(result.converged)
             else f"NOT converged ({fitting.STATUSES[int(result.status)]})")
    text = f"fit {state}: rms {rms:.3g} ({rms / size:.1e} of size), {int(result.num_steps)} steps"
    return text if math.isfinite(rms) else f"fit failed: {result.message}"
