import concurrent.futures
import contextlib
import math
import os
import warnings
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float, Int

import jaxsubdiv as js
from jaxsubdiv._misc import (
    DEFAULT_MEMORY_BUDGET,
    as_float_array,
    checked_budget,
    is_traced,
    static_int,
)
from jaxsubdiv._refine import _min_points

from . import _exported, _progress
from ._curve import BLOCK_PAIRS, curve_samples, distances, evaluate, locate, safe_norm
from ._init import initial_control, order_samples
from ._objective import BACK_WEIGHT as BACK_WEIGHT, FitData, Objective
from ._params import fitted_names, from_unconstrained, to_unconstrained
from ._solver import FootPointLevenbergMarquardt


# Our status codes are optimistix's result names, in this order (0 = success).
STATUSES = (
    "successful",
    "nonlinear_max_steps_reached",
    "nonlinear_divergence",
    "nonfinite",
    "nonfinite_input",
    "singular",
    "breakdown",
    "stagnation",
    "max_steps_reached",
    "conlim",
)
_MESSAGES = {
    name: (optx.RESULTS[getattr(optx.RESULTS, name)] or "converged")
    for name in STATUSES
    if hasattr(optx.RESULTS, name)
}
# Set by fit_batch for items it does not fit (lineax's own text for this code blames a
# bug upstream of the solver, which is not what happened).
_MESSAGES["nonfinite_input"] = "the target has NaN or infinite values; it was not fitted."


SOLVERS = (
    "levenberg-marquardt", "optimistix-levenberg-marquardt", "gauss-newton", "dogleg", "bfgs"
)


class FitResult(eqx.Module):
    """The result of [`fitting.fit`][] or [`fitting.fit_batch`][].

    All array fields carry a leading batch axis for `fit_batch`. Distances are in the
    target's units and *two-sided*: target to curve (each sample's distance to the limit
    curve: to its Hermite model, within O(h^4) of it, for C^1 schemes, else to the
    chords between the exact samples in `curve`) and curve to target (each point of
    `curve` to the polyline through the ordered samples), so a curve that wanders away
    from the data between samples is caught. `rms` and `max_error` are the larger of the
    two directions. The curve-to-target half includes the chords' own sagitta: a curve
    through noise-free samples of a curved outline has `rms_target_to_curve` ~ 0 but
    `rms_curve_to_target` about h^2 kappa / 8 for sample spacing h and curvature kappa.
    All are differentiable (at their nearest points, held fixed).

    **Fields:**

    - `control_points`: the fitted control polygon, `(n, d)`.
    - `scheme`: the scheme with its fitted parameters (e.g. `result.scheme.w`).
    - `curve`: the limit curve at the dyadic parameters of `levels` levels, `(N, d)`.
    - `rms`, `max_error`: two-sided RMS and maximum distance.
    - `rms_target_to_curve`, `max_target_to_curve`, `rms_curve_to_target`,
      `max_curve_to_target`: each direction.
    - `num_steps`: solver steps taken (including rejected trust-region steps).
    - `status`: 0 on success, else the index in `fitting.STATUSES` of the optimistix
      result. `converged` and `message` are derived from it.
    - `newton_step`: how far the control points still are from the exact optimum, as
      the local model of the loss estimates it: the largest control-point coordinate
      of the Newton step $-H^{-1} g$ at the returned point (a step in all the unknowns,
      scheme parameters included if fitted), in the target's units. `inf` where the
      loss's Hessian is not positive definite there (the point is not a strict minimum
      of the smooth model: e.g. a loose `tol` stopped on a saddle, or the optimum sits
      on a kink of the loss at a sharp corner). Derivatives through the fit are exact
      at the optimum only; compare this with the size of the changes you differentiate
      for. Measured: within a factor 3 of the true remaining distance once the solver
      is near the optimum, and about 1e-8 of the outline's size at full convergence.
    """

    control_points: Float[Array, "*batch n d"]
    scheme: js.AbstractCurveScheme
    curve: Float[Array, "*batch N d"]
    rms: Float[Array, "*batch"]
    max_error: Float[Array, "*batch"]
    rms_target_to_curve: Float[Array, "*batch"]
    max_target_to_curve: Float[Array, "*batch"]
    rms_curve_to_target: Float[Array, "*batch"]
    max_curve_to_target: Float[Array, "*batch"]
    num_steps: Int[Array, "*batch"]
    status: Int[Array, "*batch"]
    newton_step: Float[Array, "*batch"]
    boundary: str = eqx.field(static=True)
    levels: int = eqx.field(static=True)

    @property
    def converged(self) -> Array:
        """True where the solver met its tolerance."""
        return self.status == 0

    @property
    def message(self):
        """Why the solver stopped: a string, or a list of strings for a batch."""
        codes = np.asarray(self.status)
        text = lambda c: f"{STATUSES[c]}: {_MESSAGES[STATUSES[c]]}" if c else "converged"
        return text(int(codes)) if codes.ndim == 0 else [text(int(c)) for c in codes.ravel()]


def _make_solver(solver, rtol: float, atol: float, progress: bool = False):
    """None for the default (built inside the fit, which knows the problem's structure),
    else an optimistix solver."""
    if solver is None or solver == "levenberg-marquardt":
        return None
    # Normal equations + Cholesky: 14-200x faster than the default QR on small,
    # well-conditioned control-point problems, with the same steps (shared notes, d2).
    normal = lx.Normal(lx.Cholesky())
    verbose = _progress.progress_verbose if progress else False
    # Arrays, so that the compiled program takes them as data (new values, no compiling).
    rtol, atol = jnp.asarray(rtol), jnp.asarray(atol)
    if solver == "optimistix-levenberg-marquardt":
        return optx.LevenbergMarquardt(rtol, atol, linear_solver=normal, verbose=verbose)
    if solver == "gauss-newton":
        return optx.GaussNewton(rtol, atol, linear_solver=normal, verbose=verbose)
    if solver == "dogleg":
        return optx.Dogleg(rtol, atol, linear_solver=normal, verbose=verbose)
    if solver == "bfgs":
        return optx.BFGS(rtol, atol, verbose=verbose)
    if isinstance(solver, (optx.AbstractLeastSquaresSolver, optx.AbstractMinimiser)):
        if progress:
            raise ValueError(
                "`progress=True` works with the named solvers; for your own solver "
                "instance pass `verbose=fitting.progress_verbose` to it instead."
            )
        return solver
    raise ValueError(
        f"`solver` must be one of {SOLVERS}, an optimistix least-squares solver or "
        f"minimiser, or None; got {solver!r}."
    )


def _default_tol(dtype) -> float:
    return 1e-7 if dtype == jnp.float64 else 1e-5


def _check_tol(tol, caller: str):
    """`tol` checked: a finite positive real number (a traced scalar is not checked)."""
    if is_traced(tol):
        if np.ndim(tol) != 0:
            raise ValueError(f"`{caller}(tol=...)` must be a scalar; got shape {np.shape(tol)}.")
        return tol
    real = isinstance(tol, (int, float, np.integer, np.floating)) or (
        isinstance(tol, (np.ndarray, jax.Array)) and np.ndim(tol) == 0
        and np.issubdtype(np.asarray(tol).dtype, np.floating)
    )
    if isinstance(tol, (bool, np.bool_)) or not real:
        raise TypeError(f"`{caller}(tol=...)` must be a number such as 1e-7; got {tol!r}.")
    if not (math.isfinite(float(tol)) and float(tol) > 0):
        raise ValueError(f"`{caller}(tol=...)` must be finite and positive; got {tol!r}.")
    return float(tol)


def default_levels(n: int, m: int, hermite: bool) -> int:
    """Enough levels for max(512, 2m) refined points joined by Hermite segments (whose
    error is O(h^4) for smooth limits), or max(1024, 4m) joined by chords. Open curves
    have a few samples fewer: the limit stencils do not reach their end points."""
    samples = max(512, 2 * m) if hermite else max(1024, 4 * m)
    return max(2, math.ceil(math.log2(samples / n)))


def bucket(m: int, smallest: int = 16) -> int:
    """The sample count a fit's program is compiled for: the smallest of 16, 20, 24,
    28, 32, 40, 48, 56, 64, 80, ... (four steps per doubling, from `smallest`) that
    holds `m` samples. (`fit_batch` buckets its item counts the same way, from 1.)

    Outlines are padded up to it (copies of the last sample with weight zero, which the
    fit ignores), so outlines of different lengths share one compiled program, at the
    cost of up to a quarter more samples in every solver step (400 samples: 448).
    """
    size = smallest
    while size < m:
        size += max(1, (1 << (size.bit_length() - 1)) // 4)
    return size


def _pad(target, weights, size: int):
    """`target` and `weights` padded to `size` samples: copies of the last sample, with
    weight zero (for a closed outline the closing chord then runs from the last copy to
    the first sample; `_curve._closed_segments` keeps searches across it local).

    numpy for concrete arrays: JAX would compile the padding for every new length."""
    extra = size - target.shape[0]
    if extra == 0:
        return target, weights
    xp = jnp if is_traced(target) or is_traced(weights) else np
    target = xp.concatenate([target, xp.repeat(target[-1:], extra, axis=0)])
    weights = xp.concatenate([weights, xp.zeros((extra,), weights.dtype)])
    return target, weights


def _numbers(smoothing, tol, max_steps, dtype, own_solver: bool):
    """The traced settings of `_fit_one`: (root of smoothing, tol, max_steps); numpy
    for concrete values (no compiling of scalar operations)."""
    xp = jnp if is_traced(smoothing) or is_traced(tol) else np
    steps = np.int32(max_steps) if own_solver else max_steps
    return xp.sqrt(xp.asarray(smoothing, dtype)), xp.asarray(tol, dtype), steps


def _result_structure(scheme, boundary: str, levels: int):
    """The pytree structure of `_fit_one`'s `FitResult` (the fitted scheme has the
    structure of the given one)."""
    blank = dict.fromkeys(
        ("control_points", "curve", "rms", "max_error", "rms_target_to_curve",
         "max_target_to_curve", "rms_curve_to_target", "max_curve_to_target", "num_steps",
         "status", "newton_step"), 0.0)
    return jax.tree.structure(FitResult(scheme=scheme, boundary=boundary, levels=levels,
                                        **blank))


def _program_key(target, size: int, scheme, init, static) -> tuple:
    """What selects `_fit_jit`'s compiled program besides the data's values (for the
    progress display's "compiling" line)."""
    settings = tuple((k, v) for k, v in sorted(static.items()) if k not in ("solver",))
    return (size, target.shape[1], str(target.dtype), init is None,
            jax.tree.structure(scheme), type(static["solver"]).__name__, settings)


def _status(result) -> Array:
    code = jnp.zeros((), jnp.int32)
    for k, name in enumerate(STATUSES):
        if hasattr(optx.RESULTS, name):
            code = jnp.where(result == getattr(optx.RESULTS, name), k, code)
    return code


def _uses_tangents(scheme, names, boundary) -> bool:
    """Whether the fit can use the scheme's exact limit tangents (a C1 Hermite curve).

    Needs a C^1 limit at every parameter the solver may visit: the concrete scheme is
    checked with `jaxsubdiv.smoothness`; fitted parameters must stay in a C^1 range by
    construction (four-point w in (0, 0.19), split-and-tweak t in (0, 1)), and traced values
    of w or t are assumed to lie there; corner cutting is only C^0 for most (r, s), so
    fitting r or s uses chords. Clamped ends have no tangent rule yet.
    """
    if boundary == "clamped":
        return False
    if names and not isinstance(scheme, (js.FourPoint, js.SplitTweak)):
        return False
    if any(is_traced(leaf) for leaf in jax.tree.leaves(eqx.filter(scheme, eqx.is_array))):
        # Values unknown (e.g. differentiating the fit with respect to w): assume the
        # ranges above, so that the model, and the optimum, are the same as for
        # concrete values in them.
        return isinstance(scheme, (js.FourPoint, js.SplitTweak))
    # Concrete parameters: certify on the host, also when called inside a trace. Cached
    # (fit and each item of fit_batch ask again; building the mask costs ~0.5 ms).
    leaves = jax.tree.leaves(eqx.filter(scheme, eqx.is_array))
    key = (type(scheme), jax.tree.structure(scheme),
           tuple(np.asarray(leaf).tobytes() for leaf in leaves))
    if key not in _C1_CACHE:
        if len(_C1_CACHE) > 256:
            _C1_CACHE.clear()
        with jax.ensure_compile_time_eval():
            _C1_CACHE[key] = js.smoothness(scheme).continuity >= 1
    return _C1_CACHE[key]


_C1_CACHE: dict = {}


def _band_width(scheme, n: int) -> int:
    """Window of the banded Hessian assembly (`_curve.band_basis`), or 0 for the dense
    one: banded once the windows are small against the polygon (measured with the cubic
    B-spline, width 5: 0.36 ms against 0.51 ms dense at n = 32, but 0.41 against 0.29 at
    n = 16)."""
    width = scheme.mask_length
    return width if n >= 4 * width else 0


def _fit_one(target, weights, count, scheme, init, numbers, *, n, levels, boundary, names,
             solver, hermite, progress=False):
    """Fit one target (pure JAX; `fit` and `fit_batch` jit and map this).

    `target` and `weights` are padded to their shape bucket (`bucket`); `count` is the
    number of samples before padding. `numbers = (root_smoothing, tol, max_steps)` are
    arrays: traced, so new values reuse the compiled program. With a solver of
    optimistix's own, `max_steps` is its static step limit (optimistix needs an int).
    """
    root_smoothing, tol, max_steps = numbers
    closed = boundary == "closed"
    dtype = target.dtype
    m = target.shape[0]
    # Samples with zero weight (including the padding) are ignored.
    valid = weights > 0
    valid_count = jnp.sum(valid)
    share = (valid / valid_count).astype(dtype)
    center = share @ target  # a convex combination: cannot overflow
    # The RMS distance to the center, computed as `reach * RMS(offsets / reach)` so that
    # squaring neither overflows nor underflows at any finite scale (coordinates near
    # 1e160, or 1e-160, in float64; 1e20 in float32). `reach` is a constant factor of
    # an expression homogeneous in it: the value and its derivatives are exact.
    offsets = jnp.where(valid[:, None], target - center, 0.0)
    reach = jax.lax.stop_gradient(jnp.max(jnp.abs(offsets)))
    reach = jnp.where(reach > 0, reach, 1.0)
    scale = reach * jnp.sqrt(share @ jnp.sum((offsets / reach) ** 2, -1))
    scale = jnp.where(scale > 0, scale, 1.0)
    T = (target - center) / scale  # work in units of the outline's size
    N = curve_samples(scheme, n, levels, boundary)
    objective = Objective(n=n, levels=levels, boundary=boundary, names=names, hermite=hermite,
                          num_curve=N, num_target=m, band=_band_width(scheme, n))
    # The curve's basis at the starting parameters: for the initial linear fit, for the
    # whole solve when no parameter is fitted, and for the final curve then.
    basis = objective.basis_of(scheme, dtype)
    if basis[0].shape[0] != N:  # static shapes: a defect here, never the data's
        raise AssertionError(f"curve_samples gave {N}, the basis has {basis[0].shape[0]} rows")
    if init is None:
        P0 = initial_control(T, weights, basis[0], boundary, root_smoothing**2)
    else:
        P0 = (init - center) / scale
    y0 = {"control": jax.lax.stop_gradient(P0), "params": to_unconstrained(scheme, names)}
    own_solver = solver is None
    if own_solver:
        # Stop when two accepted steps in a row lower the loss (a sum of squared
        # distances over the valid samples) by less than `tol` of it, or the loss is
        # below that count times tol^2 (RMS `tol`).
        solver = FootPointLevenbergMarquardt(
            rtol=tol, atol=valid_count * tol**2, max_steps=max_steps,
            model=objective.quadratic_model, hint=objective.feet,
            verbose=_progress.progress_verbose if progress else None,
        )
    args = FitData(T, weights, scheme, root_smoothing, None if names else basis, count)
    sol = optx.least_squares(
        objective.residuals, solver, y0, args=args, max_steps=None if own_solver else max_steps,
        throw=False,
    )
    newton = _newton_step(objective, sol, args, own_solver)
    fitted = from_unconstrained(scheme, names, sol.value["params"])
    P = sol.value["control"]
    A, V, _ = objective.basis_of(fitted, dtype) if names else basis
    X = A @ P
    if hermite:
        # Distances to the Hermite curve at its nearest points (each a point of the curve,
        # so never below the true distance to it). The default solver found them at its
        # last accepted point (closed curves; open ones pin their ends' feet) with the
        # same search as `locate`: reusing them saves compiling that search once more.
        if closed and own_solver:
            tau = sol.state.hint[0]
        else:
            tau = locate(T, X, V @ P, closed, coarse=max(1, min(8, N // 64)))
        # Differentiated with the feet held (the distance is stationary in them), and
        # with a zero derivative for a sample exactly on the curve.
        feet, _ = evaluate(X, V @ P, jax.lax.stop_gradient(tau), closed)
        t2c = safe_norm(feet - T)
    else:
        t2c = distances(T, X, closed)
    # Errors summed in units of the outline's size, then scaled: squares of distances in
    # the caller's units could overflow or underflow (outlines of size 1e160 or 1e-160).
    t2c = jnp.where(valid, t2c, 0.0)
    c2t = distances(X, T, closed, count=count)
    rms_t2c = scale * jnp.sqrt(share @ t2c**2)
    rms_c2t = scale * jnp.sqrt(jnp.mean(c2t**2))
    max_t2c, max_c2t = scale * jnp.max(t2c), scale * jnp.max(c2t)
    return FitResult(
        control_points=center + scale * P,
        scheme=fitted,
        curve=center + scale * X,
        rms=jnp.maximum(rms_t2c, rms_c2t),
        max_error=jnp.maximum(max_t2c, max_c2t),
        rms_target_to_curve=rms_t2c,
        max_target_to_curve=max_t2c,
        rms_curve_to_target=rms_c2t,
        max_curve_to_target=max_c2t,
        num_steps=sol.stats["num_steps"],
        status=_status(sol.result),
        newton_step=scale * newton,
        boundary=boundary,
        levels=levels,
    )


_fit_jit = eqx.filter_jit(_fit_one)


def _newton_step(objective, sol, args, own_solver: bool):
    """Largest control-point coordinate of the Newton step at the solution, in units of
    the outline's size; inf where the Hessian does not factor (not positive definite).

    The default solver carries the loss's gradient and Hessian at its last accepted
    point (the returned one); for other solvers the model is evaluated there once.
    A diagnostic, not differentiated.
    """
    y = jax.lax.stop_gradient(sol.value)
    if own_solver:
        hessian, gradient = sol.state.hessian, sol.state.gradient
    else:
        _, gradient, hessian = objective.quadratic_model(y, jax.lax.stop_gradient(args))
    hessian, gradient = jax.lax.stop_gradient((hessian, gradient))
    factor = jax.scipy.linalg.cho_factor(hessian)
    step = jax.scipy.linalg.cho_solve(factor, gradient)
    # ravel_pytree puts the control points first.
    largest = jnp.max(jnp.abs(step[: y["control"].size]))
    return jnp.where(jnp.all(jnp.isfinite(factor[0])), largest, jnp.inf)


def _looks_open(target: np.ndarray) -> tuple[bool, float, float]:
    # In units of the largest coordinate, so that no square overflows or underflows.
    unit = float(np.max(np.abs(target))) or 1.0
    target = target / unit
    gaps = np.linalg.norm(np.diff(target, axis=0), axis=-1)
    closing = float(np.linalg.norm(target[0] - target[-1]))
    typical = float(max(4 * np.median(gaps), 1.5 * gaps.max()))
    return closing > typical, closing * unit, float(np.median(gaps)) * unit


def _float_array(value, name: str):
    """`as_float_array`, but a numpy array for concrete values: the host-side checks,
    ordering and padding then compile nothing for a new sample count (JAX compiles its
    eager operations per shape); the fit's one call moves the data to the device."""
    if is_traced(value):
        return as_float_array(value, name)
    try:
        array = np.asarray(value)
    except (TypeError, ValueError) as e:
        raise TypeError(f"`{name}` must be array-like, got {type(value).__name__}.") from e
    if array.dtype == object:
        return as_float_array(value, name)  # its own error message
    if not np.issubdtype(array.dtype, np.inexact):
        return array.astype(jax.dtypes.canonicalize_dtype(float))
    return array.astype(jax.dtypes.canonicalize_dtype(array.dtype), copy=False)


#: `order_samples` holds several m x m arrays and its 2-opt passes take O(m^2) each:
#: `fit(ordered=False)` refuses more samples than this (about 1 GB of those arrays).
ORDER_SAMPLES_LIMIT = 5000


def fit_memory(m: int, n: int, levels: int, scheme, boundary: str, dtype,
               ordered: bool = True) -> int:
    """An estimate, in bytes, of the arrays one fit of `m` samples (its shape bucket)
    holds: about 10 copies of the dense curve basis (N curve samples x n control
    points, with its tangents and the refinement that builds it), 3 blocks of the
    foot-point searches' points-by-anchors distances (at most `_curve.BLOCK_PAIRS`
    entries each: they run in blocks of samples), and about 400 numbers per sample;
    with `ordered=False` also the m x m arrays of `order_samples` (measured: 0.63 GB
    at m = 5,000, about 3 float64 copies; 4 are counted). Linear in `m` at fixed
    `levels`, and at the default `levels` too (which grow with log m).

    Measured (`benchmarks/bench_fit_memory.py`, cubic B-spline, n = 32, default
    levels): the peak less the 0.69 GB of a fit of 400 samples was 54, 43 and 115 MB
    at 4,000, 16,000 and 32,000 samples, 0.2-0.4x this estimate (before the blocked
    searches: 1.1 and 4.6 GB at 16,000 and 32,000).
    """
    N = curve_samples(scheme, n, levels, boundary)
    anchors = N // max(1, min(8, N // 64))
    itemsize = np.dtype(dtype).itemsize
    m = bucket(m)
    searches = 3 * min(m * anchors, BLOCK_PAIRS)
    ordering = 0 if ordered else 4 * 8 * m * m  # order_samples works in float64
    return itemsize * (10 * N * n + searches + 400 * m) + ordering


def _check_memory(caller, m, pad_to, n, levels, scheme, boundary, dtype, memory_budget,
                  ordered):
    budget = checked_budget(memory_budget, f"{caller}(memory_budget=...)")
    need = fit_memory(max(m, pad_to), n, levels, scheme, boundary, dtype, ordered)
    if need > budget:
        raise ValueError(
            f"`{caller}` of {max(m, pad_to)} samples with {n} control points at levels="
            f"{levels} would need about {need / 1024**3:.3g} GiB, above memory_budget="
            f"{int(budget):,} bytes. Use fewer samples (resample the outline: a few hundred "
            "to a few thousand are plenty) or fewer levels, or raise `memory_budget`."
        )


def prepare(target, scheme, n_control, *, levels, boundary, fit_params, weights, ordered,
            smoothing, caller="fit", pad_to=0, memory_budget=DEFAULT_MEMORY_BUDGET):
    """Validate the arguments of `fit` (and each item of `fit_batch`); return the
    checked target, weights, static settings and names."""
    target = _float_array(target, "target")
    if target.dtype not in (jnp.float32, jnp.float64):
        raise TypeError(
            f"`{caller}(target=...)` must be real float32 or float64; got {target.dtype}. "
            "Convert it first, e.g. `np.asarray(target, np.float64)` (complex points: "
            "stack their real and imaginary parts)."
        )
    if not isinstance(scheme, js.AbstractCurveScheme):
        raise TypeError(
            f"`{caller}(scheme=...)` must be a jaxsubdiv curve scheme such as "
            f"`jaxsubdiv.CubicBSpline()`; got {type(scheme).__name__}."
        )
    if target.ndim != 2 or target.shape[-1] < 2:
        raise ValueError(
            f"`{caller}(target=...)` must have shape (m, d) with d >= 2 (samples of an "
            f"outline); got shape {target.shape}."
        )
    if boundary not in ("closed", "open", "clamped"):
        raise ValueError(
            f"`{caller}(boundary=...)` must be 'closed', 'open' or 'clamped'; got {boundary!r}."
        )
    n = static_int(n_control, "n_control", minimum=1)
    need = _min_points(scheme, boundary)
    if n < need:
        raise ValueError(
            f"`n_control={n}` is too small: {type(scheme).__name__} with "
            f"boundary={boundary!r} needs at least {need} control points."
        )
    names = fitted_names(scheme, fit_params)
    if names and not any(is_traced(leaf) for leaf in jax.tree.leaves(scheme)):
        to_unconstrained(scheme, names)  # checks the starting values (e.g. w's range)
    m, d = target.shape
    unknowns = n * d + len(names)
    if m < unknowns:
        raise ValueError(
            f"`{caller}` got {m} samples for {unknowns} unknowns ({n} control points x "
            f"{d} coordinates" + (f" + {len(names)} scheme parameters" if names else "")
            + "); give at least as many samples as unknowns, or fewer control points."
        )
    if levels is None:
        levels = default_levels(n, bucket(max(m, pad_to)), _uses_tangents(scheme, names,
                                                                          boundary))
    else:
        levels = static_int(levels, "levels", minimum=1, maximum=40,
                            why=": the curve would have n x 2^levels samples")
    _check_memory(caller, m, pad_to, n, levels, scheme, boundary, target.dtype, memory_budget,
                  ordered)
    if weights is None:
        weights = np.ones((m,), target.dtype)
    else:
        weights = _float_array(weights, "weights").astype(target.dtype)
        if weights.shape != (m,):
            raise ValueError(
                f"`{caller}(weights=...)` must have shape ({m},), one per sample; got "
                f"{weights.shape}."
            )
    if not is_traced(target):
        values = np.asarray(target)
        if not np.all(np.isfinite(values)):
            bad = np.unique(np.nonzero(~np.isfinite(values))[0])[:5].tolist()
            raise ValueError(
                f"`{caller}(target=...)` has non-finite values (NaN or inf) at samples "
                f"{bad}; remove or repair them."
            )
        with np.errstate(over="ignore"):
            extent = np.ptp(values, axis=0)
        if not np.all(np.isfinite(extent)):
            raise ValueError(
                f"`{caller}(target=...)` spans more than the largest {target.dtype} number "
                f"({np.finfo(target.dtype).max:.3g}) in some coordinate; scale it down first."
            )
        if extent.max() == 0:
            raise ValueError(f"`{caller}(target=...)`: all samples are the same point.")
        if not ordered and m > ORDER_SAMPLES_LIMIT:
            raise ValueError(
                f"`{caller}(ordered=False)`: ordering {m} samples needs O(m^2) memory and "
                f"time (`fitting.order_samples`); the limit is {ORDER_SAMPLES_LIMIT}. Order "
                "them yourself, or fit a subsample."
            )
        if not ordered:
            order = order_samples(values, closed=boundary == "closed")
            target = target[order]
            weights = weights[order]
            values = values[order]
        if boundary == "closed":
            is_open, closing, typical = _looks_open(values)
            if is_open:
                raise ValueError(
                    f"`{caller}(target=...)` looks like an open curve: its first and last "
                    f"samples are {closing:.3g} apart, the samples {typical:.3g} (median). "
                    "Use boundary='open' (or 'clamped'), or pass ordered=False if the "
                    "samples are not in order along the outline."
                )
    elif not ordered:
        raise ValueError(
            f"`{caller}(ordered=False)` orders the samples on the host, which needs "
            "concrete values; when differentiating or jitting through the fit, order them "
            "first with `fitting.order_samples` and pass ordered=True."
        )
    if not is_traced(weights):
        values = np.asarray(weights)
        if not np.all(np.isfinite(values)):
            raise ValueError(f"`{caller}(weights=...)` has non-finite values (NaN or inf).")
        if not np.all(values >= 0):
            raise ValueError(f"`{caller}(weights=...)` must be non-negative.")
        if np.count_nonzero(values) < unknowns:
            raise ValueError(
                f"`{caller}(weights=...)` leaves {np.count_nonzero(values)} samples with "
                f"non-zero weight for {unknowns} unknowns; give at least as many."
            )
    if np.ndim(smoothing) != 0:
        raise ValueError(
            f"`{caller}(smoothing=...)` must be a scalar; got shape {np.shape(smoothing)}."
        )
    if not is_traced(smoothing) and not (math.isfinite(float(smoothing)) and float(smoothing) >= 0):
        raise ValueError(f"`{caller}(smoothing=...)` must be finite and >= 0, got {smoothing}.")
    return target, weights, n, levels, names


def report(result: FitResult, on_failure: str, caller: str = "fit") -> None:
    """Raise or warn, on the host, for items that did not converge."""
    if on_failure == "ignore" or is_traced(result.status):
        return
    failed = np.nonzero(np.atleast_1d(~np.asarray(result.converged)))[0]
    if len(failed) == 0:
        return
    messages = result.message if isinstance(result.message, list) else [result.message]
    first = messages[failed[0]].split(". ")[0]
    text = (
        f"{caller}: {len(failed)} of {len(messages)} fits did not converge "
        f"(first: item {failed[0]}, {first}). The last iterates are returned; see "
        "`result.converged` and `result.message`."
        if len(messages) > 1
        else f"{caller} did not converge ({first}) after {int(result.num_steps)} steps; the "
        "last iterate is returned."
    )
    if on_failure == "raise":
        raise RuntimeError(text)
    warnings.warn(text, RuntimeWarning, stacklevel=3)


def fit(
    target: Float[ArrayLike, "m d"],
    scheme: js.AbstractCurveScheme,
    n_control: int,
    *,
    levels: int | None = None,
    boundary: Literal["closed", "open", "clamped"] = "closed",
    fit_params: bool | str | tuple[str, ...] = False,
    init: Float[ArrayLike, "n d"] | None = None,
    solver=None,
    max_steps: int = 500,
    tol: float | None = None,
    weights: Float[ArrayLike, " m"] | None = None,
    smoothing: float = 0.0,
    ordered: bool = True,
    progress: bool | Literal["time"] = False,
    on_failure: Literal["raise", "warn", "ignore"] = "warn",
    pad_to: int | None = None,
    memory_budget: float = DEFAULT_MEMORY_BUDGET,
) -> FitResult:
    """Fit a control polygon (and optionally the scheme's parameters) to an outline.

    Minimises the squared distances from the samples to the subdivision scheme's limit
    curve over the control points (and `r`, `s`, `w` or `t`). The correspondence between
    samples and curve is optimised, not frozen: every residual is the distance from a
    sample to its foot point on the current curve (tangent-distance minimisation), so
    Gauss-Newton-type solvers converge fast instead of alternating slowly.

    How: the samples are centered and scaled to unit size; control points start from a
    linear least-squares fit at chord-length positions (lineax Cholesky); then a
    Levenberg-Marquardt iteration minimises the squared distances from the samples to
    the limit curve plus a weak curve-to-samples term (see `fitting._objective`). The
    curve is sampled exactly at the dyadic parameters of `levels` levels (see
    [`jaxsubdiv.limit_points`][]) and, for $C^1$ schemes, joined by cubic Hermite segments
    with the exact limit tangents ([`jaxsubdiv.limit_tangents`][]), otherwise by chords.
    The default solver is an optimistix least-squares solver written for this problem:
    it assembles the exact Hessian of the squared distances in closed form (the foot
    points eliminated as in variable projection) instead of differentiating a black
    box. Scheme parameters stay in their valid open ranges through a smooth
    reparameterisation (see `fitting._params`).

    Works under `jax.jit` (`eqx.filter_jit`) and with `jax.grad`/`jacrev`/`jacfwd` with
    respect to the target, the weights, the smoothing and the scheme's parameters, by
    implicit differentiation of the optimum (`optimistix.ImplicitAdjoint`).

    **Compilation.** The fit is one compiled program per shape and static setting:
    sample-count bucket (the `m` samples are padded with ignored copies to the next of
    16, 20, 24, 28, 32, 40, 48, ...: outlines of 400 and 440 samples share the program
    for 448), dimension, dtype, `n_control`, `levels`, `boundary`, the scheme's type,
    `fit_params`, `solver` and whether `init` is given. Values are data: new samples,
    `weights`, `smoothing`, `tol`, `max_steps` (with the default solver) and scheme
    parameter values compile nothing. `jaxsubdiv.enable_compilation_cache()` keeps
    compiled programs on disk for later processes.

    **Arguments:**

    - `target`: samples of the outline, shape `(m, d)`, `d >= 2`, in order along it
      (else pass `ordered=False`). Unevenly spaced and noisy samples are fine.
    - `scheme`: a curve scheme; its parameters are the fixed values, or the starting
      values when they are fitted.
    - `n_control`: number of control points (static).
    - `levels`: levels at which the curve is sampled exactly (static; default: enough
      for max(512, 2M) refined points joined by Hermite segments, or max(1024, 4M)
      joined by chords, for the sample-count bucket M (see Compilation); an open curve
      has a few samples fewer at its ends).
    - `boundary`: `"closed"`, `"open"` or `"clamped"`, as in [`jaxsubdiv.refine`][].
    - `fit_params`: `False`, `True` (all of the scheme's parameters) or names such as
      `("w",)`. Fittable: `CornerCutting` r, s; `FourPoint` w (kept in
      (0, 0.19), where the scheme is C1); `SplitTweak` t.
    - `init`: starting control points `(n, d)` instead of the linear fit.
    - `solver`: `"levenberg-marquardt"` (default: the structured solver above),
      `"optimistix-levenberg-marquardt"`, `"gauss-newton"`, `"dogleg"`, `"bfgs"`
      (optimistix's own, on the same residuals, Jacobians by autodiff; slower), or any
      optimistix least-squares solver or minimiser.
    - `max_steps`: solver step limit (traced with the default solver; with optimistix's
      own solvers it is their static limit, and a new value compiles again).
    - `tol`: the default solver stops when two accepted steps in a row each lower the
      loss (a sum of squared distances) by less than `tol` of itself, or the RMS
      distance is below `tol` of the outline's size; optimistix's solvers use it as
      their `rtol` and `atol`. Default 1e-7 in float64, 1e-5 in float32. When only the
      curve matters, `tol=1e-5` is up to 15x faster on outlines with a nearly free
      sliding of the control points (superellipse, n = 32: 17 steps instead of 249) and
      changed the RMS error by under 2% on the benchmark outlines; but derivatives
      through the fit need the optimum: at 1e-5, d(control points)/d(smoothing) on the
      letter 'o' was 2x off (at 1e-7, within 0.4% of finite differences).
      `result.newton_step` estimates how far the returned control points are from it.
    - `weights`: non-negative per-sample weights `(m,)`.
    - `smoothing`: weight of a second-difference penalty on the control points (the
      sum of their squared second differences, divided by n), added to the sum of
      squared sample distances (in units of the outline's size); its effect therefore
      weakens as the number of samples grows.
    - `ordered`: False to order unordered samples first ([`fitting.order_samples`][]).
    - `progress`: `True` to show the step count and loss on stderr while the solver
      runs (from a host callback inside the compiled program, which JAX then does not
      write to its persistent compilation cache); `"time"` to show the elapsed time
      instead, from a host thread (the program is unchanged and cacheable: what the
      `jaxsubdiv` command uses). Either also says on stderr when a program is prepared
      for the first time in the process (compiled, or loaded from the cache).
    - `on_failure`: what to do if the solver does not converge: `"raise"` a
      `RuntimeError`, `"warn"` (default) or `"ignore"`. The last iterate is always
      returned, with `converged` False and the reason in `message`. Under `jax.jit`
      (or `grad`) the status is not known while tracing, so nothing is raised or
      warned: check `result.converged` yourself.
    - `pad_to`: compile for at least this many samples (the bucket of `max(m, pad_to)`),
      so that fits of outlines of different lengths, such as the contours of one file,
      share one program. The padding's samples are ignored; each costs as much as a
      sample in every solver step.
    - `memory_budget`: the most memory, in bytes, the fit's arrays may take (default 2
      GiB, as `jaxsubdiv.refine`); a fit estimated to need more (`fitting.fit_memory`,
      linear in the sample count) is a `ValueError` before anything is allocated. At
      the default `levels`, 32,000 samples took 0.12 GB more than 400 (measured). The
      time per step still grows with the square of the sample count (every sample is
      compared with every N/8-th curve sample): about 1.5 s a step at 20,000 samples.

    **Returns:** a [`fitting.FitResult`][].
    """
    if on_failure not in ("raise", "warn", "ignore"):
        raise ValueError(f"`on_failure` must be 'raise', 'warn' or 'ignore'; got {on_failure!r}.")
    pad_to = 0 if pad_to is None else static_int(pad_to, "pad_to", minimum=1)
    if not (isinstance(progress, bool) or progress == "time"):
        raise ValueError(f"`fit(progress=...)` must be True, False or 'time'; got {progress!r}.")
    target, weights, n, levels, names = prepare(
        target, scheme, n_control, levels=levels, boundary=boundary, fit_params=fit_params,
        weights=weights, ordered=ordered, smoothing=smoothing, pad_to=pad_to,
        memory_budget=memory_budget,
    )
    max_steps = static_int(max_steps, "max_steps", minimum=1)
    tol = _default_tol(target.dtype) if tol is None else _check_tol(tol, "fit")
    if init is not None:
        init = _float_array(init, "init").astype(target.dtype)
        if init.shape != (n, target.shape[1]):
            raise ValueError(
                f"`fit(init=...)` must have shape ({n}, {target.shape[1]}); got {init.shape}."
            )
        if not is_traced(init) and not np.all(np.isfinite(np.asarray(init))):
            raise ValueError("`fit(init=...)` has non-finite values (NaN or inf).")
    dtype = target.dtype
    if dtype == jnp.float32 and jax.config.jax_enable_x64:
        # optimistix's damping is float64 when x64 is on, which lineax rejects next to
        # float32 iterates; solve in float64 and return float32.
        target, weights = target.astype(jnp.float64), weights.astype(jnp.float64)
        init = None if init is None else init.astype(jnp.float64)
    m = target.shape[0]
    size = bucket(max(m, pad_to))
    steps = progress is True  # a line per solver step, from inside the program
    static = dict(
        n=n, levels=levels, boundary=boundary, names=names,
        solver=_make_solver(solver, tol, tol, steps),
        hermite=_uses_tangents(scheme, names, boundary), progress=steps,
    )
    if progress:
        _progress.compiling(_program_key(target, size, scheme, init, static), size)
    padded, weights = _pad(target, weights, size)
    args = (padded, weights, np.int32(m), scheme, init,
            _numbers(smoothing, tol, max_steps, target.dtype, solver is None))
    # With the persistent compilation cache on, a concrete call with the default solver
    # runs a program exported to disk: a new process then skips tracing and lowering.
    exported = (solver is None and not steps and _exported.folder() is not None
                and not any(is_traced(x) for x in jax.tree.leaves(args)))
    clock = _progress.elapsed() if progress == "time" else contextlib.nullcontext()
    with clock:
        if exported:
            result = _exported.call(_fit_one, args, static,
                                    _result_structure(scheme, boundary, levels))
        else:
            result = _fit_jit(*args, **static)
        if progress:
            jax.block_until_ready(result)
    if steps:
        _progress.finish()
    if result.control_points.dtype != dtype:
        cast = lambda x: x.astype(dtype) if eqx.is_inexact_array(x) else x
        result = jax.tree.map(cast, result)
    report(result, on_failure)
    return result


def _fit_items(targets, weights, counts, steps, scheme, numbers, total, *, devices: int,
               **static):
    """Fit `(k, m, d)` targets one after another (`lax.map`, a scan of single solves).

    One after another rather than `vmap` over the items: a batched solver loop runs every
    item until the slowest converges, and its batched gathers and factorizations ran
    slower per item on CPU; measured 1.9x slower than a Python loop of single fits (64
    items), where `lax.map` matches the loop with one dispatch for the whole batch.
    `steps`: each item's step limit `(k,)`, or one static int for optimistix's solvers;
    `numbers = (root_smoothing, tol)`; `total`: the number of real items in the whole
    batch (for the progress line).
    """
    progress = static.pop("progress", False)
    per_item = eqx.is_array(steps)

    def solve(item):
        index, target, weight, count, *limit = item
        numbers_i = (*numbers, limit[0] if per_item else steps)
        result = _fit_one(target, weight, count, scheme, None, numbers_i, progress=False,
                          **static)
        if progress:  # one line for the batch: outlines done, not every solver step
            _progress.items_done(index, devices, total)
        return result

    items = (jnp.arange(targets.shape[0]), targets, weights, counts)
    return jax.lax.map(solve, items + ((steps,) if per_item else ()))


def _batched(targets, weights, counts, steps, scheme, numbers, total, **static):
    """Fit `(devices, per_device, m, d)` targets: `vmap` over the device axis, which the
    sharding splits (one slice per device), and one item after another within a device.

    The vmapped solver loop makes the devices step together (its stopping test is
    reduced over the device axis), so a device waits for the other's slower item at
    every `lax.map` iteration, and its `lax.cond`s run both branches. `jax.shard_map`
    would give each device its own loop, but lineax's structure check rejects the
    manual-axis shardings it introduces (measured with lineax's Cholesky in the
    initialisation); to revisit.
    """
    count = targets.shape[0]
    shares = static.pop("shares", 1)  # concurrent calls of this program (progress only)
    per_item = eqx.is_array(steps)
    items = lambda t, w, c, k: _fit_items(t, w, c, k if per_item else steps, scheme, numbers,
                                          total, devices=count * shares, **static)
    if count == 1:
        # No vmap for one device: under vmap, the solver's `lax.cond`s (the global
        # foot-point search that `_curve.track` and `_curve.distances` fall back to)
        # would run both branches at every step.
        result = items(targets[0], weights[0], counts[0], steps[0] if per_item else None)
        return jax.tree.map(lambda x: x[None], result)
    if per_item:
        return jax.vmap(items)(targets, weights, counts, steps)
    return jax.vmap(lambda t, w, c: items(t, w, c, None))(targets, weights, counts)


# Module level, so that repeated calls with the same shapes and settings reuse the
# compiled program.
_batched_jit = eqx.filter_jit(_batched)


def _available_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        return os.cpu_count() or 1


def _run_batch(targets, weights, counts, scheme, numbers, static, devices, threads):
    """Fit the stacked batch over `devices`, or on one CPU device from `threads` threads.

    Each device's (or thread's) share is padded to an item-count bucket (`bucket(...,
    smallest=1)`), so batches of similar sizes share one compiled program; the padding
    items are copies of the first, stopped after one step by the default solver.
    `numbers = (root_smoothing, tol, max_steps)`.
    """
    size = targets.shape[0]
    root_smoothing, tol, max_steps = numbers
    per_item = static["solver"] is None  # else max_steps is optimistix's static limit
    # Threads only for concrete arrays: inside a trace (`jit`, `grad` of the batch) the
    # whole batch is one program anyway, and tracing is not shared across threads.
    threaded = (not is_traced(targets) and len(devices) == 1
                and devices[0].platform == "cpu" and 1 < threads <= size // 2)
    parts = threads if threaded else len(devices)
    share = bucket(-(-size // parts), smallest=1)
    extra = parts * share - size
    xp = jnp if is_traced(targets) or is_traced(weights) else np  # as in `_pad`
    pad = lambda x: xp.concatenate([x, xp.repeat(x[:1], extra, axis=0)]) if extra else x
    arrays = [pad(targets), pad(weights), pad(counts)]
    if per_item:
        arrays.append(np.concatenate([np.full((size,), max_steps, np.int32),
                                      np.ones((extra,), np.int32)]))
    # (parts, share, ...): one slice per device, or per thread.
    arrays = [x.reshape((parts, share) + x.shape[1:]) for x in arrays]
    steps = arrays.pop() if per_item else max_steps
    total = np.int32(size)
    program = lambda t, w, c, k, **extra_static: _batched_jit(
        t, w, c, k, scheme, (root_smoothing, tol), total, **static, **extra_static
    )
    if threaded:
        # The same compiled program from `threads` Python threads, one share each: XLA's
        # CPU client runs them concurrently (JAX releases the GIL while a program runs).
        # Measured on 2 cores: 40 outlines in 0.32 s instead of 0.57 s in one call.
        # Concurrent first calls compile the program once (checked with
        # `jax_log_compiles`). Each share keeps a leading device axis of one.
        def run(k):
            t, w, c = (x[k:k + 1] for x in arrays)
            limit = steps[k:k + 1] if per_item else steps
            return jax.block_until_ready(program(t, w, c, limit, shares=threads))

        with concurrent.futures.ThreadPoolExecutor(threads) as pool:
            done = list(pool.map(run, range(threads)))
        merge = lambda *x: jnp.concatenate([p.reshape((-1,) + p.shape[2:]) for p in x])[:size]
        return jax.tree.map(lambda *x: merge(*x) if eqx.is_array(x[0]) else x[0], *done)
    if len(devices) == 1:
        arrays = jax.device_put(arrays, devices[0])
    else:
        # The device axis is split over the devices; XLA partitions the program (SPMD).
        mesh = jax.sharding.Mesh(np.array(devices), ("batch",))
        sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("batch"))
        arrays = jax.device_put(arrays, sharding)
    result = program(*arrays, steps)
    merge = lambda x: x.reshape((-1,) + x.shape[2:])[:size]
    return jax.tree.map(lambda x: merge(x) if eqx.is_array(x) else x, result)


def fit_batch(
    targets,
    scheme: js.AbstractCurveScheme,
    n_control: int,
    *,
    levels: int | None = None,
    boundary: Literal["closed", "open", "clamped"] = "closed",
    fit_params: bool | str | tuple[str, ...] = False,
    solver=None,
    max_steps: int = 200,
    tol: float | None = None,
    weights=None,
    smoothing: float = 0.0,
    ordered: bool = True,
    devices=None,
    threads: int | None = None,
    progress: bool = False,
    on_failure: Literal["raise", "warn", "ignore"] = "warn",
    memory_budget: float = DEFAULT_MEMORY_BUDGET,
) -> FitResult:
    """Fit many outlines at once; the same settings as [`fitting.fit`][].

    The batch is split evenly over `devices` (default: all of `jax.devices()`; sharded,
    SPMD), and each device fits its share one item after another in one compiled loop
    (`lax.map`), so several devices or hosts scale without code changes (the devices
    step together: see `_batched`). On one CPU device (JAX's default on a CPU), the
    batch is instead split into `threads` shares fitted concurrently, one per core.
    One item that
    fails (non-finite samples, no convergence) does not spoil the others: see
    `result.converged[i]` and `result.message[i]`. Items that are invalid as input (wrong
    shape, all samples equal, an open-looking outline with `boundary="closed"`) raise a
    `ValueError` naming the item before anything is fitted.

    **Arguments:**

    - `targets`: an array `(B, m, d)`, or a list of `B` arrays `(m_i, d)` of different
      lengths (padded internally with zero-weight samples).
    - `weights`: `None`, an array `(B, m)`, or a list of `(m_i,)` arrays.
    - `max_steps`: solver step limit per item (default 200).
    - `devices`: the devices to split the batch over.
    - `threads`: with a single CPU device, the batch is split into this many equal shares,
      fitted concurrently by one compiled program from as many threads (default: the
      CPU cores available to this process; 1.75x a single share's throughput measured
      on 2 cores). Results do not depend on it.
    - `progress`: one line on stderr for the whole batch, counting outlines done.
    - `memory_budget`: as for `fit`, checked per outline (one outline is fitted at a
      time in each thread or device, so the batch needs up to that many times it).
    - others: as for [`fitting.fit`][]. Items whose samples are not finite are not
      fitted: their status is `nonfinite_input` and their numbers are NaN.

    **Returns:** one [`fitting.FitResult`][] whose array fields have a leading batch axis
    (for a ragged list, `curve` and the control points have the common shapes).
    """
    checked_budget(memory_budget, "fit_batch(memory_budget=...)")
    if on_failure not in ("raise", "warn", "ignore"):
        raise ValueError(f"`on_failure` must be 'raise', 'warn' or 'ignore'; got {on_failure!r}.")
    if isinstance(targets, (list, tuple)):
        items = [_float_array(t, "targets[i]") for t in targets]
    else:
        array = _float_array(targets, "targets")
        if array.ndim != 3:
            raise ValueError(
                f"`fit_batch(targets=...)` must be an array of shape (B, m, d) or a list of "
                f"(m_i, d) arrays; got shape {array.shape}."
            )
        items = list(array)
    if not items:
        raise ValueError("`fit_batch(targets=...)` is empty.")
    if weights is None:
        weights = [None] * len(items)
    elif (
        not isinstance(weights, (list, tuple)) and np.ndim(weights) == 0
    ) or len(weights) != len(items):
        raise ValueError(
            f"`fit_batch(weights=...)` needs one weight array per target ({len(items)}): "
            "an array (B, m) or a list of (m_i,) arrays."
        )
    dims = sorted({int(t.shape[-1]) for t in items if t.ndim == 2})
    if len(dims) > 1:
        raise ValueError(
            f"`fit_batch(targets=...)` mixes points of dimensions {dims}; fit each "
            "dimension in its own batch."
        )
    devices = jax.devices() if devices is None else list(devices)
    if not devices:
        raise ValueError("`fit_batch(devices=...)` is empty; pass None for all devices.")
    prepared, bad = [], []
    for i, (t, w) in enumerate(zip(items, weights)):
        if not is_traced(t) and not np.all(np.isfinite(np.asarray(t))):
            bad.append(i)
            # A stand-in that passes validation, so the batch keeps its shape; the item's
            # outputs are replaced by NaN and its status by nonfinite_input below.
            angle = 2 * np.pi * np.arange(t.shape[0]) / t.shape[0]
            circle = np.zeros(t.shape)
            circle[:, 0], circle[:, 1] = np.cos(angle), np.sin(angle)
            t, w = jnp.asarray(circle, t.dtype), None
        t, w, n, _, names = prepare(
            t, scheme, n_control, levels=levels, boundary=boundary, fit_params=fit_params,
            weights=w, ordered=ordered, smoothing=smoothing, caller=f"fit_batch(targets[{i}])",
            memory_budget=memory_budget,
        )
        prepared.append((t, w))
    # One sample-count bucket for the whole batch: every item padded to it.
    size = bucket(max(t.shape[0] for t, _ in prepared))
    if levels is None:
        levels = default_levels(n, size, _uses_tangents(scheme, names, boundary))
    padded = [_pad(t, w, size) for t, w in prepared]
    xp = jnp if any(is_traced(x) for item in padded for x in item) else np
    stacked = xp.stack([t for t, _ in padded])
    stacked_weights = xp.stack([w for _, w in padded])
    counts = np.array([t.shape[0] for t, _ in prepared], np.int32)
    max_steps = static_int(max_steps, "max_steps", minimum=1)
    tol = _default_tol(stacked.dtype) if tol is None else _check_tol(tol, "fit_batch")
    static = dict(
        n=n, levels=levels, boundary=boundary, names=names,
        solver=_make_solver(solver, tol, tol, progress),
        hermite=_uses_tangents(scheme, names, boundary), progress=progress,
    )
    if progress:
        _progress.begin()
    result = _run_batch(
        stacked, stacked_weights, counts, scheme,
        _numbers(smoothing, tol, max_steps, stacked.dtype, solver is None), static, devices,
        _available_cores() if threads is None else static_int(threads, "threads", minimum=1),
    )
    if progress:
        jax.block_until_ready(result)
        _progress.finish()
    if bad:
        index = jnp.array(bad)
        code = STATUSES.index("nonfinite_input")
        blank = lambda x: x.at[index].set(jnp.nan) if eqx.is_inexact_array(x) else x
        result = jax.tree.map(blank, result)
        result = eqx.tree_at(lambda r: r.status, result, result.status.at[index].set(code))
    report(result, on_failure, caller="fit_batch")
    return result
