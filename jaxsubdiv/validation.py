"""Checks of user arguments, shared by jaxsubdiv and packages built on it (`fitting`).

Each check either returns the argument in a normal form or raises an error that names
the argument and says how to fix it. They run on the host, before anything is traced or
compiled: shape-setting arguments must be concrete Python values, while array values
may be traced (inside `jax.jit`, `jax.grad`, ...) and are then left to the computation.

- [`jaxsubdiv.validation.static_int`][]: an integer that sets array shapes.
- [`jaxsubdiv.validation.real_array`][], [`jaxsubdiv.validation.as_float_array`][]:
  array-likes as floating JAX arrays.
- [`jaxsubdiv.validation.checked_budget`][]: a memory budget in bytes.
- [`jaxsubdiv.validation.check_boundary`][]: a curve's boundary rule for a scheme.
- [`jaxsubdiv.validation.min_points`][] (also `jaxsubdiv.min_points`): the fewest
  control points a scheme refines with a boundary rule.
- [`jaxsubdiv.validation.is_traced`][]: whether a value is a JAX tracer.
- [`jaxsubdiv.validation.check_creasable`][]: a scheme whose closed curves take creases
  as data (`curve_stencil(creases=mask)`, `fitting.fit(corners=...)`).
"""

from ._misc import (
    DEFAULT_MEMORY_BUDGET as DEFAULT_MEMORY_BUDGET,
    MemoryBudgetError as MemoryBudgetError,
    as_float_array as as_float_array,
    check_creasable as check_creasable,
    checked_budget as checked_budget,
    is_traced as is_traced,
    real_array as real_array,
    static_int as static_int,
)
from ._refine import BOUNDARIES as BOUNDARIES, _check_boundary, _min_points
from ._scheme.base import AbstractCurveScheme


__all__ = [
    "BOUNDARIES",
    "DEFAULT_MEMORY_BUDGET",
    "MemoryBudgetError",
    "as_float_array",
    "check_boundary",
    "check_creasable",
    "checked_budget",
    "is_traced",
    "min_points",
    "real_array",
    "static_int",
]


def check_boundary(boundary, scheme: AbstractCurveScheme) -> str:
    """`boundary` checked against [`jaxsubdiv.refine`][]'s rules and returned.

    One of `"closed"`, `"open"` and `"clamped"` (`BOUNDARIES`); `"clamped"` only for a
    scheme with a clamped end rule (`scheme.clamp_ghost`). Anything else is a
    `ValueError` that lists the choices.
    """
    return _check_boundary(boundary, scheme)


def min_points(scheme: AbstractCurveScheme, boundary: str) -> int:
    """The fewest control points `scheme` refines with `boundary` (checked first with
    [`jaxsubdiv.validation.check_boundary`][]).

    Closed polygons need 3 points and clamped ones 2; an open polygon needs enough
    points that one level of refinement does not shrink it (each level of an open
    curve loses the points whose stencils would reach past its ends, so a mask of
    length `L` needs about `L / 2` points or more).
    """
    return _min_points(scheme, check_boundary(boundary, scheme))
