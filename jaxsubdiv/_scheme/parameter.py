"""What a curve scheme declares about itself: `Parameter` and `SchemeInfo`.

Plain data, without JAX: the command line reads the declarations to build its options
and `--help` before (or without) importing JAX (`jaxsubdiv._scheme.registry`).
"""

import dataclasses
import fractions
import numbers
import warnings
from typing import Any


class DivergenceWarning(UserWarning):
    """A scheme was built with a parameter value where it does not converge.

    Refinement still applies the rule, but the refined polygons approach no continuous
    curve (their differences do not shrink): the limit, its stencils and a fit do not
    exist. Raised at construction with concrete values outside a parameter's
    `converges` interval (traced values are not checked); `jaxsubdiv.smoothness` says
    why for any value. Turn it into an error with
    `warnings.simplefilter("error", jaxsubdiv.DivergenceWarning)`.
    """


def number_text(x: float) -> str:
    """`1/16`, `-1/4`, `0.19`, `55`: a fraction when `x` is one with a small denominator."""
    if isinstance(x, bool) or not isinstance(x, numbers.Real):
        return repr(x)
    if float(x).is_integer():
        return str(int(x))
    exact = fractions.Fraction(float(x))
    if exact.denominator <= 64:
        return f"{exact.numerator}/{exact.denominator}"
    return f"{float(x):g}"


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One numeric parameter of a curve scheme: its name, default and ranges.

    Declared once, on the scheme class (`scheme_parameters`); the constructor's range
    check, the command line's options and `--help`, the editor's sliders, the JSON reader
    and the fit's reparameterisation all read it from there.

    **Fields:**

    - `name`: the constructor argument and the field that holds the value (e.g. `"w"`).
    - `default`: the value used when none is given (e.g. `1/16`).
    - `low`, `high`, `low_open`, `high_open`: the valid range; an open end is not valid.
      `None` for no bound: then any finite real number is valid on that side.
    - `c1`: the open interval where the scheme is $C^1$ (the other parameters at their
      defaults), which the fit keeps the parameter inside; None when there is none.
    - `help`: one line for `--help` (e.g. `"four-point tension"`).
    - `integer`: a shape-setting integer (static, e.g. `LaneRiesenfeld`'s degree).
    - `fit_interval`: the open interval a fit keeps the parameter in; by default `c1`.
      Set it alone for a parameter fitted where the scheme is not $C^1$ (corner cutting's
      `r` and `s`, fitted with the chord model); None (with `c1` None): not fittable.
    - `converges`: the open interval where the scheme converges (its limit curves are
      continuous), the other parameters at their defaults, as `jaxsubdiv.smoothness`
      decides; None when it converges on the whole valid range. A valid value outside it
      builds the scheme with a [`jaxsubdiv.DivergenceWarning`][].
    - `slider`: the closed range an interactive slider offers (the editor), when it
      should be narrower than where the scheme converges (split-and-tweak's $[0, 1]$);
      None: the `converges` interval, else the valid range.
    - `scheme`: the class name, for messages (filled in by the registry).
    """

    name: str
    default: float | int
    low: float | None
    high: float | None
    low_open: bool
    high_open: bool
    c1: tuple[float, float] | None
    help: str
    integer: bool = False
    fit_interval: tuple[float, float] | None = None
    converges: tuple[float, float] | None = None
    slider: tuple[float, float] | None = None
    scheme: str = ""

    def __post_init__(self):
        if self.fit_interval is None and self.c1 is not None:
            object.__setattr__(self, "fit_interval", tuple(self.c1))

    @property
    def label(self) -> str:
        """`FourPoint(w)`, or `w` when the scheme is not known."""
        return f"{self.scheme}({self.name})" if self.scheme else self.name

    def range_text(self) -> str:
        """The valid range as an inequality, e.g. `0 < r < 1`, `1 <= degree <= 55`, or
        `any finite w` when it is unbounded."""
        below = "<" if self.low_open else "<="
        above = "<" if self.high_open else "<="
        if self.low is None and self.high is None:
            return f"any finite {self.name}"
        if self.low is None:
            return f"{self.name} {above} {number_text(self.high)}"
        if self.high is None:
            return f"{self.name} {'>' if self.low_open else '>='} {number_text(self.low)}"
        return (
            f"{number_text(self.low)} {below} {self.name} {above} {number_text(self.high)}"
        )

    def valid(self, value: Any) -> Any:
        """Whether `value` lies in the valid range, elementwise (Python numbers, NumPy or
        JAX arrays, also traced ones: no conversion happens). NaN and infinities are
        never valid."""
        finite = (value == value) & (abs(value) < float("inf"))
        if self.low is not None:
            finite = finite & ((self.low < value) if self.low_open else (self.low <= value))
        if self.high is not None:
            finite = finite & ((value < self.high) if self.high_open else (value <= self.high))
        return finite

    def converges_text(self) -> str:
        """The `converges` interval as an inequality, e.g. `-1/2 < w < 1/2` ("" without
        one)."""
        if self.converges is None:
            return ""
        low, high = (number_text(v) for v in self.converges)
        return f"{low} < {self.name} < {high}"

    def converges_at(self, value: Any) -> Any:
        """Whether the scheme converges at `value` (the other parameters at their
        defaults), elementwise, from the declared `converges` interval."""
        if self.converges is None:
            return self.valid(value)
        low, high = self.converges
        return (low < value) & (value < high)

    def warn_if_divergent(self, value: Any, scheme: str, stacklevel: int = 3) -> None:
        """A [`jaxsubdiv.DivergenceWarning`][] when the concrete `value` (a number or an
        array) of `scheme`'s parameter lies outside the `converges` interval; nothing
        without an interval. The constructors call it for concrete values only (traced
        ones cannot be tested)."""
        import numpy as np

        if self.converges is None or np.all(self.converges_at(np.asarray(value))):
            return
        interval = self.converges_text()
        warnings.warn(
            f"`{scheme}({self.name})` = {np.asarray(value).tolist()} is outside {interval}, "
            f"where {scheme} converges: refinement still applies the rule, but the refined "
            "polygons approach no continuous curve (`jaxsubdiv.smoothness` says why). Use "
            f"{interval} for a limit curve.",
            DivergenceWarning,
            stacklevel=stacklevel,
        )

    def check(self, value: Any) -> None:
        """Raise a `ValueError` naming the scheme, the argument and the range when the
        concrete `value` is outside it (a `TypeError` when an integer parameter gets a
        non-integer, or a real one a non-number)."""
        if self.integer:
            if isinstance(value, bool) or not isinstance(value, numbers.Integral):
                raise TypeError(
                    f"`{self.label}` must be an int with {self.range_text()}, got {value!r}."
                )
        elif isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise TypeError(
                f"`{self.label}` must be a real number with {self.range_text()}, got "
                f"{value!r}."
            )
        if not bool(self.valid(value)):
            raise ValueError(f"`{self.label}` needs {self.range_text()}; got {value!r}.")


@dataclasses.dataclass(frozen=True)
class SchemeInfo:
    """A curve scheme's registry entry: its names, class and parameters.

    Built by `jaxsubdiv.scheme_info` / `jaxsubdiv.schemes()` from the class variables
    the scheme declares (`scheme_name`, `scheme_title`, `scheme_parameters`).

    **Fields:**

    - `name`: the command-line name, e.g. `"four-point"`.
    - `title`: a human title, e.g. `"corner cutting"`.
    - `cls`: the scheme class.
    - `parameters`: its [`jaxsubdiv.Parameter`][]s, in constructor order.
    - `listed`: whether `jaxsubdiv.schemes()` (and the command line) lists it; False for
      `MaskScheme`, whose mask is its argument (build it with its constructor).
    """

    name: str
    title: str
    cls: type
    parameters: tuple[Parameter, ...]
    listed: bool = True

    def __post_init__(self):
        named = tuple(
            p if p.scheme else dataclasses.replace(p, scheme=self.cls.__name__)
            for p in self.parameters
        )
        object.__setattr__(self, "parameters", named)

    @property
    def fittable(self) -> tuple[str, ...]:
        """The parameters `fitting.fit(fit_params=True)` fits (those with a fit interval:
        their `c1` interval, or corner cutting's explicit one)."""
        return tuple(p.name for p in self.parameters if p.fit_interval is not None)

    def parameter(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise ValueError(
            f"{self.cls.__name__} has no parameter {name!r}; its parameters are "
            f"{[p.name for p in self.parameters] or 'none'}."
        )

    def make(self, **values):
        """The scheme with these parameter values; missing ones take their defaults.

        Concrete values are checked against their ranges here (`Parameter.check`); the
        constructor checks traced ones, and relations between parameters (corner
        cutting's $r < s$)."""
        if not self.listed:
            raise TypeError(
                f"{self.cls.__name__} is not built from registry parameters; call its "
                f"constructor (e.g. `MaskScheme(coefficients, start)`)."
            )
        names = [p.name for p in self.parameters]
        unknown = [name for name in values if name not in names]
        if unknown:
            raise TypeError(
                f"{self.cls.__name__} has no parameter {unknown[0]!r}; its parameters are "
                f"{names or 'none'}."
            )
        arguments = {}
        for p in self.parameters:
            value = values.get(p.name, p.default)
            if isinstance(value, numbers.Number):  # arrays: the constructor checks them
                p.check(value)
            arguments[p.name] = value
        return self.cls(**arguments)

    def values(self, scheme) -> dict[str, float | int]:
        """The scheme's parameter values as Python numbers (needs concrete values)."""
        if type(scheme) is not self.cls:
            raise TypeError(
                f"`SchemeInfo({self.name!r}).values` needs a {self.cls.__name__}, got "
                f"{type(scheme).__name__}."
            )
        return {
            p.name: int(getattr(scheme, p.name)) if p.integer else float(getattr(scheme, p.name))
            for p in self.parameters
        }
