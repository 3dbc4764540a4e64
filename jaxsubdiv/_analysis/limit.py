r"""Exact evaluation of the limit curve at the control points: positions, tangents and
curvature, without refining.

Every point of a polygon, at any refinement level, is pushed to the limit curve at its
own parameter with the vertex stencils of [`jaxsubdiv.limit_stencil`][] (also for dual
schemes, whose stencils then use the basis function at half-integers). Derivatives are
with respect to a parameter with unit spacing per point of the polygon passed in.
"""

import math
from fractions import Fraction
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._misc import as_float_array
from .._refine import refine
from .._scheme.base import AbstractCurveScheme
from .local import (
    basis_at_integers,
    check_scheme,
    neighborhood,
    require_smoothness,
    stencil_values,
)


Boundary = Literal["closed", "open", "clamped"]

# Clamped ends: refine this many levels before using the regular stencils, so that the
# points they read are computed by the regular rule at every later level.
_CLAMPED_LEVELS = 5


def _check_points(points, caller: str) -> Array:
    points = as_float_array(points, "points")
    if points.ndim < 2:
        raise ValueError(
            f"`{caller}(points=...)` must have shape (..., n, d), got shape "
            f"{points.shape}. For a sequence of scalars use `points[:, None]`."
        )
    return points


def _closed(points: Array, weights: Array, offsets: list[int]) -> Array:
    out = None
    for w, u in zip(weights, offsets):
        term = w * jnp.roll(points, -u, axis=-2)
        out = term if out is None else out + term
    return out


def _open(points: Array, weights: Array, offsets: list[int], caller: str) -> Array:
    n = points.shape[-2]
    lo, hi = -min(offsets), max(offsets)
    count = n - lo - hi
    if count < 1:
        raise ValueError(
            f"`{caller}` with boundary='open' needs at least {lo + hi + 1} points for this "
            f"scheme (its neighborhood spans {lo + hi + 1} points), got n={n}."
        )
    out = None
    for w, u in zip(weights, offsets):
        term = w * points[..., lo + u : lo + u + count, :]
        out = term if out is None else out + term
    return out


def _clamped(points: Array, scheme: AbstractCurveScheme, caller: str) -> Array:
    r"""Limit positions with clamped ends.

    The ends are kept at every level, so their limits are the end points. For an interior
    point $P_j$, refine $k$ levels with the clamped rule and evaluate the limit curve at
    $t = j$ from the level-$k$ points with the regular weights $\varphi(m)$: after $k$
    levels the points around $t = j$ are far enough from the ends that every later level
    computes them with the regular rule, so this is exact.
    """
    n = points.shape[-2]
    if n < 2:
        raise ValueError(f"`{caller}` with boundary='clamped' needs n >= 2, got n={n}.")
    if n == 2:
        return points
    k = _CLAMPED_LEVELS
    mask = scheme.mask().astype(points.dtype)
    start, length = scheme.mask_start, scheme.mask_length
    fine = refine(points, scheme, k, boundary="clamped")
    c = Fraction(2 * start + length - 1, 2)
    # Index in the clamped list of regular level-k point K: K + s_1 (2^k - 1).
    shift = -math.ceil(c) + (0 if c.denominator == 1 else 1)
    offset = shift * (2**k - 1)
    phi = basis_at_integers(mask, start, 0)
    ms = range(start + 1, start + length - 1)
    base = 2**k * c  # 2^k (j + c) = 2^k j + base
    out = None
    for m, weight in zip(ms, phi):
        first = int(2**k * 1 + base) - m + offset  # index used for j = 1
        idx = slice(first, first + 2**k * (n - 3) + 1, 2**k)
        term = weight * fine[..., idx, :]
        out = term if out is None else out + term
    return jnp.concatenate([points[..., :1, :], out, points[..., -1:, :]], axis=-2)


def _derivative(points, scheme, order: int, boundary: str, caller: str) -> Array:
    points = _check_points(points, caller)
    scheme = check_scheme(scheme, caller)
    if boundary not in ("closed", "open", "clamped"):
        raise ValueError(
            f"`{caller}(boundary=...)` must be 'closed', 'open' or 'clamped', got "
            f"{boundary!r}."
        )
    require_smoothness(scheme, order, caller)
    if boundary == "clamped":
        if scheme.clamp_ghost is None:
            raise ValueError(
                f"{type(scheme).__name__} has no clamped end rule; use boundary='closed' "
                "or boundary='open'."
            )
        if order > 0:
            raise ValueError(
                f"`{caller}` does not support boundary='clamped': the derivatives at a "
                "clamped end depend on the end rule's own eigen-structure, which is not "
                "implemented. Use boundary='closed' or 'open', or `limit_points` (which "
                "supports 'clamped')."
            )
        return _clamped_jit(points, scheme, caller)
    return _regular_jit(points, scheme, order, boundary, caller)


def _regular(points, scheme, order: int, boundary: str, caller: str) -> Array:
    offsets = [int(u) for u in neighborhood(scheme, "vertex")]
    weights = stencil_values(scheme, order, "vertex").astype(points.dtype)
    if boundary == "closed":
        return _closed(points, weights, offsets)
    return _open(points, weights, offsets, caller)


# Compiled once per (scheme type, shapes, dtype, order, boundary); new values do not
# recompile.
_regular_jit = eqx.filter_jit(_regular)
_clamped_jit = eqx.filter_jit(_clamped)


_ARGS = """**Arguments:**

- `points`: a polygon of any refinement level, shape `(..., n, d)`; leading axes are
  batch axes. Works under `jit`, `vmap` and `grad`, in float32 and float64.
- `scheme`: the curve scheme. Its parameters may be traced, so you can differentiate
  with respect to `w`, `r`, `s`, `t` or a mask. A concrete scheme that is not smooth
  enough is an error; with traced parameters that check (which runs on the host) is
  skipped, so check the parameter range once with [`jaxsubdiv.smoothness`][].
- `boundary`: `"closed"` (periodic), or `"open"`: only the points whose parameter lies
  on the open limit curve, i.e. whose whole neighborhood is inside the polygon: points
  `a .. n-1-a` with `a = len(neighborhood(scheme, "vertex")) // 2` (cubic B-spline and
  Chaikin `a = 1`, four-point `a = 2`). The same curve `refine(..., boundary="open")`
  converges to."""


def limit_points(
    points: Float[ArrayLike, "*batch n d"],
    scheme: AbstractCurveScheme,
    *,
    boundary: Boundary = "closed",
) -> Float[Array, "*batch m d"]:
    r"""Push every point of a polygon to its exact position on the limit curve.

    Point $P_j$ goes to $C(j)$, the limit curve at its own parameter, by the vertex limit
    stencil ([`jaxsubdiv.limit_stencil`][] with `at="vertex"`): for the cubic B-spline
    $(P_{j-1} + 4P_j + P_{j+1})/6$, for Chaikin $(P_{j-1} + 6P_j + P_{j+1})/8$, for
    interpolating schemes $P_j$ itself. Use it instead of "refine a lot": it is exact,
    costs one small convolution, and applied to `refine(P, scheme, k)` gives exact
    samples of the limit curve at spacing $2^{-k}$.

    {ARGS}
  `"clamped"` (end points kept; the ends map to themselves and interior points are
  evaluated exactly after a few clamped levels) is supported for schemes with a clamped
  rule. Keyword only.

    **Returns:** the limit positions, shape `(..., m, d)`: `m = n` for closed and clamped
    curves, `n - 2a` for open ones.
    """
    return _derivative(points, scheme, 0, boundary, "limit_points")


def limit_tangents(
    points: Float[ArrayLike, "*batch n d"],
    scheme: AbstractCurveScheme,
    *,
    boundary: Literal["closed", "open"] = "closed",
) -> Float[Array, "*batch m d"]:
    r"""Exact tangent vectors $dC/dt$ of the limit curve at every point of a polygon.

    $t$ has unit spacing per point of the polygon passed in: for a polygon refined $k$
    times from a level-0 polygon, multiply by $2^k$ to get the derivative with respect to
    the level-0 parameter. Uses [`jaxsubdiv.tangent_stencil`][] with `at="vertex"`; the
    scheme must be $C^1$.

    {ARGS} Keyword only.

    **Returns:** the tangents, shape `(..., m, d)` (as for `limit_points`).
    """
    return _derivative(points, scheme, 1, boundary, "limit_tangents")


def limit_second_derivatives(
    points: Float[ArrayLike, "*batch n d"],
    scheme: AbstractCurveScheme,
    *,
    boundary: Literal["closed", "open"] = "closed",
) -> Float[Array, "*batch m d"]:
    r"""Exact second derivatives $d^2C/dt^2$ of the limit curve at every point.

    Same conventions as [`jaxsubdiv.limit_tangents`][] (multiply by $4^k$ for the level-0
    parameter); the scheme must be $C^2$ (e.g. the cubic B-spline, `SplitTweak(t)`,
    `LaneRiesenfeld(d)` for `d >= 3`; not Chaikin or the four-point scheme).

    {ARGS} Keyword only.

    **Returns:** shape `(..., m, d)` (as for `limit_points`).
    """
    return _derivative(points, scheme, 2, boundary, "limit_second_derivatives")


def limit_curvature(
    points: Float[ArrayLike, "*batch n d"],
    scheme: AbstractCurveScheme,
    *,
    boundary: Literal["closed", "open"] = "closed",
) -> Float[Array, "*batch m"]:
    r"""Exact curvature of the limit curve at every point of a polygon.

    $\kappa = (x'y'' - y'x'')/|C'|^3$ for planar curves (signed: positive when the curve
    turns counter-clockwise) and $|C' \times C''|/|C'|^3$ for $d \ge 3$ (unsigned), from
    [`jaxsubdiv.limit_tangents`][] and [`jaxsubdiv.limit_second_derivatives`][].
    Curvature does not depend on the parametrisation, so no $2^k$ factors are needed. The
    scheme must be $C^2$. Where the tangent vanishes the curvature is undefined and is
    returned as NaN (gradients of the other points stay finite).

    {ARGS} Keyword only.

    **Returns:** shape `(..., m)`.
    """
    points = _check_points(points, "limit_curvature")
    d = points.shape[-1]
    if d < 2:
        raise ValueError(f"`limit_curvature` needs points with d >= 2 coordinates, got d={d}.")
    first = _derivative(points, scheme, 1, boundary, "limit_curvature")
    second = _derivative(points, scheme, 2, boundary, "limit_curvature")
    # Each derivative in units of its largest coordinate, so that no square or cube
    # overflows or underflows at extreme scales (a circle of radius 1e160 or 1e-160);
    # the curvature is (b / a^2) times that of the rescaled derivatives, and with `a`
    # and `b` held constant the expression is the same function: exact derivatives.
    a = jax.lax.stop_gradient(jnp.max(jnp.abs(first), axis=-1))
    b = jax.lax.stop_gradient(jnp.max(jnp.abs(second), axis=-1))
    a, b = jnp.where(a > 0, a, 1.0), jnp.where(b > 0, b, 1.0)
    first, second = first / a[..., None], second / b[..., None]
    speed2 = jnp.sum(first**2, axis=-1)
    if d == 2:
        numerator = first[..., 0] * second[..., 1] - first[..., 1] * second[..., 0]
    else:
        cross2 = speed2 * jnp.sum(second**2, axis=-1) - jnp.sum(first * second, axis=-1) ** 2
        ok2 = cross2 > 0
        numerator = jnp.where(ok2, jnp.sqrt(jnp.where(ok2, cross2, 1.0)), 0.0)
    ok = speed2 > 0
    safe = jnp.where(ok, speed2, 1.0)
    return jnp.where(ok, (b / a) / a * (numerator / safe**1.5), jnp.nan)


for _function in (limit_points, limit_tangents, limit_second_derivatives, limit_curvature):
    _function.__doc__ = _function.__doc__.replace("{ARGS}", _ARGS.replace("\n", "\n    "))
del _function
