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
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._curve_stencil import CurveStencil, build as build_stencil, vertex_offsets
from .._kernel import ghost_reach, with_ghosts
from .._misc import (
    DEFAULT_MEMORY_BUDGET,
    as_float_array,
    checked_budget,
    is_traced,
    static_int,
)
from .._refine import (
    BOUNDARIES,
    _check_boundary,
    _check_creases,
    _check_enough_points,
    _check_memory,
    _check_scheme,
    _count,
    refine,
)
from .._scheme.base import AbstractCurveScheme
from .crease_stencil import check_creasable, crease_reach, creased_stencil
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
    if boundary not in BOUNDARIES:
        raise ValueError(f"`{caller}(boundary=...)` must be one of {BOUNDARIES}, got {boundary!r}.")
    require_smoothness(scheme, order, caller)
    if boundary == "clamped":
        if scheme.clamp_ghost is None:
            raise ValueError(
                f"{type(scheme).__name__} has no clamped end rule; use boundary='closed' "
                "or boundary='open'."
            )
        if order > 0:
            check_clamped_derivatives(scheme, points.shape[-2], caller)
            return _regular_jit(points, scheme, order, "clamped", caller)
        return _clamped_jit(points, scheme, caller)
    return _regular_jit(points, scheme, order, boundary, caller)


def supports_clamped_derivatives(scheme: AbstractCurveScheme) -> bool:
    r"""Whether the derivatives of `scheme`'s clamped limit curve are its regular ones of
    the polygon extended by its reflection through each end point.

    True for primal schemes with a symmetric mask whose clamped rule reflects (ghost
    points $P_{-q} = 2 P_0 - P_q$, and the end point kept): a symmetric primal rule maps
    a polygon symmetric through $P_0$ ($P_{-q} + P_q = 2 P_0$) to one symmetric through
    the same point, which it keeps, so every clamped level is the uniform rule on that
    infinite polygon, and the clamped limit curve is the uniform limit curve of the
    reflected polygon: $C(-t) = 2 P_0 - C(t)$, hence $C''(0) = 0$ (a natural end). The
    cubic B-spline, split-and-tweak, Jarek and Lane-Riesenfeld of odd degree. The
    four-point scheme's clamped rule repeats the end points instead (not symmetric
    through them), and dual schemes add the end point to each level: their ends have
    eigen-structures of their own, not implemented.

    Where True, `limit_tangents`, `limit_second_derivatives`, `limit_curvature` and
    `curve_stencil`/`limit_curve` with `derivative >= 1` accept `boundary="clamped"`
    (and `fitting.fit` models clamped curves of $C^1$ schemes by Hermite segments).
    Decided on the host from the scheme's type and mask; a traced mask of a primal
    reflecting scheme (every registered one is symmetric for any parameter) counts as
    symmetric.
    """
    if scheme.clamp_ghost != "reflect" or not scheme.is_primal:
        return False
    if is_traced(scheme.mask()):
        return True  # the registered primal reflecting schemes are symmetric for any value
    mask = np.asarray(scheme.mask())
    return bool(np.allclose(mask, mask[::-1], rtol=0, atol=1e-12 * np.max(np.abs(mask))))


def check_clamped_derivatives(scheme: AbstractCurveScheme, n: int, caller: str) -> None:
    """`supports_clamped_derivatives`, or a ValueError naming the caller and the way out; and
    enough points that the reflection through one end does not reach past the other."""
    if not supports_clamped_derivatives(scheme):
        raise ValueError(
            f"`{caller}` does not support boundary='clamped' for {type(scheme).__name__}: "
            "its clamped end rule (ghost points repeated, or a dual scheme's added end "
            "point) gives the ends an eigen-structure of their own, which is not "
            "implemented. Derivatives at clamped ends are supported for the cubic "
            "B-spline, SplitTweak, Jarek and LaneRiesenfeld of odd degree; otherwise use "
            "boundary='closed' or 'open', or derivative 0 (`limit_points`)."
        )
    reach = max(abs(u) for u in neighborhood(scheme, "vertex"))
    ghosts = max(reach, *clamped_ghosts(scheme))
    if n <= ghosts:
        raise ValueError(
            f"`{caller}` with boundary='clamped' needs at least {ghosts + 1} points for "
            f"{type(scheme).__name__} (its reflected end reaches {ghosts} points in); got "
            f"n={n}."
        )


def clamped_ghosts(scheme: AbstractCurveScheme) -> tuple[int, int]:
    """The ghost points one clamped level reads before and after a long polygon."""
    return ghost_reach(64, scheme.mask_start, scheme.mask_length, scheme.center)


def _regular(points, scheme, order: int, boundary: str, caller: str) -> Array:
    offsets = [int(u) for u in neighborhood(scheme, "vertex")]
    weights = stencil_values(scheme, order, "vertex").astype(points.dtype)
    if boundary == "closed":
        return _closed(points, weights, offsets)
    if boundary == "clamped":  # the regular stencils on the reflected polygon
        reach = max(abs(u) for u in offsets)
        points = with_ghosts(points, reach, reach, "reflect")
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
  converges to. Or `"clamped"` (`refine(..., boundary="clamped")`'s curve, every
  point): derivatives for primal schemes whose clamped rule reflects the polygon
  through its end points (the cubic B-spline, `SplitTweak`, `Jarek`,
  `LaneRiesenfeld` of odd degree), where that curve is the regular limit curve of
  the reflected polygon, so the regular stencils apply to it, with $C''$ zero at the
  ends (see [`jaxsubdiv.supports_clamped_derivatives`][]); other schemes raise a `ValueError`."""


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

    {ARGS} For positions, `"clamped"` (end points kept; the ends map to themselves and
  interior points are evaluated exactly after a few clamped levels) is supported for
  every scheme with a clamped rule. Keyword only.

    **Returns:** the limit positions, shape `(..., m, d)`: `m = n` for closed and clamped
    curves, `n - 2a` for open ones.
    """
    return _derivative(points, scheme, 0, boundary, "limit_points")


def limit_tangents(
    points: Float[ArrayLike, "*batch n d"],
    scheme: AbstractCurveScheme,
    *,
    boundary: Boundary = "closed",
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
    boundary: Boundary = "closed",
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
    boundary: Boundary = "closed",
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


# --------------------------------------------------------------------------------------
# The limit curve at dyadic parameters, as a stencil table.


def curve_stencil(
    scheme: AbstractCurveScheme,
    n: int,
    levels: int,
    *,
    boundary: Boundary = "closed",
    derivative: int | None = 0,
    dtype=None,
    creases=None,
    side: Literal["right", "left"] = "right",
) -> CurveStencil:
    r"""The linear map from `n` control points to the limit curve at the dyadic
    parameters of `levels` levels, as a banded table ([`jaxsubdiv.CurveStencil`][]).

    Output `K` reads the window of `table.width` consecutive control points starting at
    `table.first[K]` (cyclically on closed curves): after $L$ levels every output of the
    refinement is a combination of a few control points with weights from the composite
    mask $a(z) a(z^2) \cdots a(z^{2^{L-1}})$, periodic in `K` with period $2^L$, and the
    limit stencils ([`jaxsubdiv.limit_stencil`][], [`jaxsubdiv.tangent_stencil`][]) add a
    few more (N. Dyn, D. Levin, "Subdivision schemes in geometric modelling", Acta
    Numerica 11 (2002)). The windows are known on the host from the mask's support; the
    weights are built with `jax.numpy` from the scheme's mask, so they are
    differentiable and vmappable in its parameters. Memory and work O(N width), never
    O(N n): use it where [`jaxsubdiv.subdivision_matrix`][] would be too large.

    **Arguments:**

    - `scheme`, `n`, `levels`, `boundary`: as for [`jaxsubdiv.refine`][] (no creases).
    - `derivative`: 0 for the limit points (`limit_points(refine(P, L))`), 1 for the
      tangents and 2 for the second derivatives with respect to the level-0 parameter
      (one unit per control point: $2^L$ and $4^L$ times `limit_tangents` and
      `limit_second_derivatives` of `refine(P, L)`; on clamped curves, derivatives for
      the schemes `limit_tangents` supports there), or
      `None` for the refined points themselves (`refine(P, L)`). Static.
    - `dtype`: of the weights (default: the scheme's mask's).
    - `creases`: `None`, or a boolean mask `(n,)` of the control points where a closed
      curve has a corner (as `refine(creases=...)`, which takes their indices: the
      curve is cut there into clamped pieces). Unlike `refine`'s, the mask may be
      traced: the table's layout depends only on `n` and `levels`, so new creases
      compile nothing. Closed curves of primal schemes with a clamped end rule; with
      `derivative` 1 or 2, those whose clamped rule reflects the polygon
      ([`jaxsubdiv.supports_clamped_derivatives`][]: each piece's derivatives are its
      clamped ones). See `jaxsubdiv._analysis.crease_stencil`.
    - `side`: at a crease the derivative jumps: `"right"` (default) gives the one of the
      piece that starts there, $C'(t^+)$, `"left"` that of the piece that ends there,
      $C'(t^-)$. Elsewhere, and for `derivative=0`, both are the same.

    **Returns:** a `CurveStencil`; `table.apply(P)` gives the outputs, as many as
    `limit_points(refine(P, L))` has rows (open curves lose the stencil's reach at each
    end, see [`jaxsubdiv.limit_points`][]).
    """
    scheme = _check_stencil_arguments(scheme, n, levels, boundary, derivative, "curve_stencil")
    dtype = scheme.mask().dtype if dtype is None else jnp.dtype(dtype)
    _check_side(side, "curve_stencil")
    if creases is not None:
        mask, reach = _check_creases_mask(scheme, n, levels, boundary, derivative, creases)
        return _creased_jit(scheme, n, levels, mask, reach, dtype, _stencil, derivative, side)
    return _stencil_jit(scheme, n, levels, boundary, derivative, dtype)


def _check_side(side, caller: str) -> None:
    if side not in ("right", "left"):
        raise ValueError(
            f"`{caller}(side=...)` must be 'right' (the derivative after a crease) or "
            f"'left' (before it); got {side!r}."
        )


def _check_creases_mask(scheme, n, levels, boundary, derivative, creases):
    """`curve_stencil(creases=...)`'s checks: a boolean mask (traced or not) and the
    scheme's reach (`crease_reach`)."""
    if boundary != "closed" or derivative is None:
        raise ValueError(
            "`curve_stencil(creases=...)` needs boundary='closed' and a derivative 0, 1 or "
            "2 (an open curve's creases are its pieces' ends: fit or refine the pieces); "
            f"got boundary={boundary!r}, derivative={derivative!r}."
        )
    check_creasable(scheme, "curve_stencil(creases=...)")
    if derivative > 0:
        # A crease cuts the curve into clamped pieces, the shortest one span long.
        check_clamped_derivatives(scheme, _count(2, scheme, levels, "clamped", ()),
                                  "curve_stencil(creases=..., derivative>=1)")
    mask = jnp.asarray(creases)
    if mask.shape != (n,) or mask.dtype != jnp.bool_:
        raise ValueError(
            f"`creases` must be a boolean mask of shape ({n},) (one entry "
            f"per control point); got dtype {mask.dtype}, shape {mask.shape}. For indices "
            "`idx`, pass `jnp.zeros(n, bool).at[idx].set(True)`."
        )
    return mask, crease_reach(scheme, _stencil_jit)


def _check_stencil_arguments(scheme, n, levels, boundary, derivative, caller):
    scheme = _check_scheme(scheme)
    n = static_int(n, "n", minimum=1)
    static_int(levels, "levels", minimum=0)
    boundary = _check_boundary(boundary, scheme)
    _check_enough_points(n, scheme, boundary)
    if derivative is not None:
        static_int(derivative, "derivative", minimum=0, maximum=2)
        scheme = check_scheme(scheme, caller)
        require_smoothness(scheme, derivative, caller)
        if boundary == "open":
            from_ends = vertex_offsets(scheme.mask_length)[1]  # samples lost at each end
            refined = _count(n, scheme, levels, "open", ())
            if refined - 2 * from_ends < 1:
                raise ValueError(
                    f"`{caller}` with boundary='open': {n} control points refined "
                    f"{levels} times give {refined} points, too few for the limit "
                    f"stencils, which lose {from_ends} at each end. Use more control "
                    "points or more levels."
                )
        if boundary == "clamped" and derivative > 0:
            # The stencils read the refined polygon (refined with the capped ghosts of
            # a short one, whose clamped curve that is): its count must suffice.
            check_clamped_derivatives(scheme, _count(n, scheme, levels, "clamped", ()), caller)
    return scheme


def _stencil(scheme, n, levels, boundary, derivative, dtype) -> CurveStencil:
    """`curve_stencil` without the checks (traceable: the scheme may be traced)."""
    if derivative is None:
        rows_of = lambda E, b: refine(E, scheme, levels, boundary=b)
    else:
        scale = 2.0 ** (derivative * levels)  # per refined sample -> per control point
        rows_of = lambda E, b: scale * _derivative(
            refine(E, scheme, levels, boundary=b), scheme, derivative, b, "curve_stencil"
        )
    return build_stencil(scheme, n, levels, boundary, rows_of, limit=derivative is not None,
                         dtype=dtype)


# One compiled program per (scheme type, n, levels, boundary, derivative, dtype) when
# called eagerly, instead of one per operation of the build.
_stencil_jit = eqx.filter_jit(_stencil)
_creased_jit = eqx.filter_jit(creased_stencil)


def _limit_curve(points, scheme, levels, boundary, derivative):
    table = _stencil(scheme, points.shape[-2], levels, boundary, derivative, points.dtype)
    return table.apply(points)


# Compiled once per (scheme type, shapes, dtype, levels, boundary, derivative).
_limit_curve_jit = eqx.filter_jit(_limit_curve)


def limit_curve(
    points: Float[ArrayLike, "*batch n d"],
    scheme: AbstractCurveScheme,
    levels: int,
    *,
    boundary: Boundary = "closed",
    derivative: int = 0,
    creases=None,
    side: Literal["right", "left"] = "right",
    memory_budget: int = DEFAULT_MEMORY_BUDGET,
) -> Float[Array, "*batch N d"]:
    r"""Exact points (or derivatives) of the limit curve at the dyadic parameters of
    `levels` levels.

    The same numbers as `limit_points(refine(points, scheme, levels))`, computed in one
    gather and one product from a [`jaxsubdiv.curve_stencil`][] table: output $K$ is
    $C(t_K) = \sum_m w_{K,m} P_{f_K + m}$, where the weights combine the composite mask
    $a(z) a(z^2) \cdots a(z^{2^{L-1}})$ of the $L$ levels with the vertex limit stencil
    $\varphi(m)$ of the scheme's basic limit function (N. Dyn, D. Levin, "Subdivision
    schemes in geometric modelling", Acta Numerica 11 (2002)). Closed curves have
    $t_K = K/2^L - c(1 - 2^{-L})$ for the mask's center $c$
    ([`jaxsubdiv.AbstractCurveScheme.center`][]), $K = 0, \dots, 2^L n - 1$; open curves
    keep the samples whose stencils lie inside the polygon (as `limit_points` with
    `boundary="open"`), clamped ones start and end at the end points.

    Derivatives are a keyword, not a second function: `derivative=1` gives $dC/dt$ and
    `derivative=2` gives $d^2C/dt^2$ with respect to the level-0 parameter $t$ (one unit
    per control point), so the samples of every `levels` are samples of the same
    functions (like `scipy.interpolate.BSpline(x, nu)`); the scheme must be $C^1$ or
    $C^2$. On clamped curves, derivatives for the schemes whose clamped rule
    reflects the polygon (see `limit_tangents`).

    **Arguments:**

    - `points`: control points `(..., n, d)`; leading axes are batch axes.
      Differentiable, and the scheme's parameters too; works under `jit`, `vmap` and
      `grad`.
    - `scheme`: the curve scheme; a concrete scheme that is not smooth enough is an
      error (with traced parameters the check is skipped, as for `limit_points`).
    - `levels`: number of levels (a Python int >= 0): $2^L$ samples per control point
      on closed curves.
    - `boundary`: `"closed"`, `"open"` or `"clamped"` (keyword only).
    - `derivative`: 0, 1 or 2 (keyword only).
    - `creases`: a closed curve's creased control points, as indices (as for
      `refine`) or a boolean mask `(n,)` (which may be traced; see
      [`jaxsubdiv.curve_stencil`][]): the curve is cut there into clamped pieces and
      passes through each with a corner, $2^L n$ samples for primal schemes. Closed
      curves; derivatives as for `curve_stencil(creases=...)`.
    - `side`: `"right"` or `"left"`: which one-sided derivative at a crease (as for
      `curve_stencil`).
    - `memory_budget`: as for [`jaxsubdiv.refine`][] (default 2 GiB); the estimate adds
      the table and its gathered windows (`N x width` weights and `N x width x d`
      coordinates). Checked before anything is built.

    **Returns:** `(..., N, d)`, with `N` as for `limit_points(refine(points, ...))`.
    """
    points = _check_points(points, "limit_curve")
    levels = static_int(levels, "levels", minimum=0)
    derivative = static_int(derivative, "derivative", minimum=0, maximum=2)
    scheme = _check_stencil_arguments(
        scheme, points.shape[-2], levels, boundary, derivative, "limit_curve"
    )
    n, d = points.shape[-2:]
    batch, itemsize = math.prod(points.shape[:-2]), jnp.dtype(points.dtype).itemsize
    extra = 0
    if creases is not None and not is_traced(creases) and np.size(creases) == 0:
        creases = None  # no crease: the closed curve (as `refine(creases=[])`)
    if creases is not None:
        creases = _crease_mask(creases, n)
    if levels <= 64:  # beyond, `_check_memory` refuses from the bit length alone
        # A bound of the table's width (creased rows read up to a whole piece each side).
        width = (scheme.mask_length + 2) * (1 if creases is None else 4)
        count = _count(n, scheme, levels, boundary, ())
        extra = count * width * (itemsize + 8 + max(1, batch * d) * itemsize)
    _check_memory(n, d, batch, itemsize, scheme, levels, boundary, (),
                  checked_budget(memory_budget), extra=extra, caller="limit_curve")
    _check_side(side, "limit_curve")
    if creases is not None:
        mask, reach = _check_creases_mask(scheme, n, levels, boundary, derivative, creases)
        return _creased_jit(scheme, n, levels, mask, reach, points.dtype, _stencil,
                            derivative, side).apply(points)
    return _limit_curve_jit(points, scheme, levels, boundary, derivative)


def _crease_mask(creases, n: int):
    """Crease indices (an int or a sequence of ints, as `refine` takes them) as a boolean
    mask; a boolean mask (a sequence or array, which may be traced) passes as an array."""
    if is_traced(creases):
        if creases.dtype != jnp.bool_:
            raise ValueError(
                "traced `creases` must be a boolean mask of shape (n,): indices set which "
                "points are creased on the host. Pass `jnp.zeros(n, bool).at[idx].set(True)`."
            )
        return creases
    values = np.asarray(creases)
    if values.dtype == bool:
        return jnp.asarray(values)
    index = _check_creases(creases, n, "closed")  # `refine`'s own check of the indices
    mask = np.zeros(n, bool)
    mask[list(index)] = True
    return jnp.asarray(mask)
