"""[`fitting.fit`][]: one outline, checked on the host, fitted by two compiled programs.

The rest of the package, by concern: `_result` (what a fit returns, its statuses),
`_checks` (host-side validation, sizes and memory), `_core` (the jitted single fit and
how it runs), `_batch` (`fit_batch` over devices and threads), `_objective` (the loss),
`_solver` (the solvers), `_curve` (the curve model), `_params` (fitted parameters).
"""

from collections.abc import Sequence
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

import jaxsubdiv as js
from jaxsubdiv.validation import DEFAULT_MEMORY_BUDGET, is_traced, static_int

from ._checks import (
    bucket,
    check_memory,
    check_on_failure,
    check_phases,
    check_tol,
    default_levels,
    default_tol,
    float_array,
    pad,
    prepare,
)
from ._core import make_objective, run, traced_settings
from ._corners import corner_flags
from ._objective import FitData
from ._params import uses_tangents
from ._result import FitResult, report
from ._solver import make_solver


def fit(
    target: Float[ArrayLike, "m d"],
    scheme: js.AbstractCurveScheme,
    n_control: int,
    *,
    levels: int | None = None,
    boundary: Literal["closed", "open", "clamped"] = "closed",
    pin_ends: bool = False,
    corners: None | Literal["auto"] | Sequence[int] = None,
    fit_params: bool | str | tuple[str, ...] = False,
    profile: int | None = None,
    phases: int | None = None,
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
    linear least-squares fit at chord-length positions (a Cholesky factorization); then a
    Levenberg-Marquardt iteration minimises the squared distances from the samples to
    the limit curve plus a weak curve-to-samples term (see `fitting._objective`). The
    curve is sampled exactly at the dyadic parameters of `levels` levels (see
    [`jaxsubdiv.limit_points`][]) and, for $C^1$ schemes, joined by cubic Hermite segments
    with the exact limit tangents ([`jaxsubdiv.limit_tangents`][]), otherwise by chords
    (also at clamped ends without a tangent rule, see
    [`jaxsubdiv.supports_clamped_derivatives`][]). The default solver is an optimistix
    least-squares solver written for this problem: it assembles the exact Hessian of the squared distances in closed form (the foot
    points eliminated as in variable projection) instead of differentiating a black
    box. Scheme parameters stay in their valid open ranges through a smooth
    reparameterisation (see `fitting._params`).

    Works under `jax.jit` (`eqx.filter_jit`) and with `jax.grad`/`jacrev`/`jacfwd` with
    respect to the target, the weights, the smoothing and the scheme's parameters, by
    implicit differentiation of the optimum (`optimistix.ImplicitAdjoint`).

    **Compilation.** The fit is one compiled solve per shape and static setting:
    sample-count bucket (the `m` samples are padded with ignored copies to the next of
    16, 20, 24, 28, 32, 40, 48, ...: outlines of 400 and 440 samples share the program
    for 448), dimension, dtype, `n_control`, `levels`, `boundary`, the scheme's type,
    `fit_params`, `solver` and whether `init` is given. Values are data: new samples,
    `weights`, `smoothing`, `tol`, `max_steps` (with the default solver) and scheme
    parameter values compile nothing, except across the scheme's C1 boundary: the curve
    model (Hermite where the scheme is C1 at its values, chords elsewhere, decided on the
    host by `jaxsubdiv.smoothness`) and the default `levels` that follow from it are
    static, so `FourPoint(0.18)` and `FourPoint(0.2)` run two programs. The errors are
    measured by a second program that depends only on the shapes (bucket, number of
    curve samples, dimension, dtype), the boundary and the curve model, so fits of
    other schemes, control-point counts and settings share it.
    `jaxsubdiv.enable_compilation_cache()` keeps compiled programs on disk for later
    processes.

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
    - `pin_ends`: with an open or clamped `boundary`, `True` makes the curve start at
      the first sample and end at the last (of non-zero weight) exactly, as strokes
      are usually wanted; without it the ends are fitted like every other sample and
      land near them (on 30 glyph strokes up to 3.5% of the size away,
      `benchmarks/results/fit_ends.md`). An exact constraint on the curve at `levels`:
      two control points (`_core.end_pivots`) are solved from the others and the two end
      samples, so derivatives with respect to the end samples move the ends. An `init`
      polygon has those two points replaced. See `docs/fitting.md`, "Open strokes".
    - `corners`: `None` (default: a smooth curve), `"auto"` (corners found in the
      samples by [`fitting.find_corners`][] with its defaults), or indices of the corner
      samples (of `target` as given; ordered samples). A closed outline with corners is
      fitted with *creased* control points, one per corner, which the curve passes
      through with a corner (the scheme's crease rule: `jaxsubdiv.refine(creases=...)`),
      so corners are neither rounded nor overshot. The control points are shared among
      the pieces between corners in proportion to their arc length (largest
      remainders, so the same wherever the samples start), and the creases
      sit at the corner samples' control points at the start; the solver then moves
      every control point, corners included. `result.creases` marks them. The curve is
      modelled by chords (default `levels` as for non-C1 schemes; Hermite segments
      with one-sided tangents at the creases exist, measured but not yet the default:
      `docs/fitting.md`, "Corners"); the creases are data, so fits with other corners
      reuse the compiled program. Closed curves of
      primal schemes (CubicBSpline, FourPoint, SplitTweak, Jarek); at most `n_control`
      corners (`"auto"` keeps the strongest). No corners found: the smooth fit. See
      `docs/fitting.md`, "Corners".
    - `fit_params`: `False`, `True` (all of the scheme's parameters) or names such as
      `("w",)`. Fittable: `CornerCutting` r, s; `FourPoint` w (kept in
      (0, 0.19), where the scheme is C1); `SplitTweak` t. The scheme's values are the
      start; the joint fit begins from the best of a profile (see `profile`).
    - `profile`: with `fit_params`, how many values of each fitted parameter to try
      with it held fixed before the joint fit (static): the control points are fitted
      at each value of a grid over the parameter's fit interval and at the start (one
      after another in the same compiled program), and the joint fit of control points and parameters starts
      from the one of lowest loss, so it never ends with a higher loss than the fit
      with the parameters held at their starting values (the loss is not convex in
      them: from the far end of the range, the joint fit alone stopped with them
      more than 1e-3 off on 15 of 17 curves made from known parameters). The loss is
      not the reported two-sided `rms`, though (the larger of its two halves): where
      the fit with the parameters held at their start has the lower `rms`, that fit is
      returned, its parameters the start's (their derivatives then those of that fit;
      not if it did not converge and the joint fit did; default solver only). So `rms`
      is never above that of the fit with the parameters held at their start: for
      `FourPoint` and `SplitTweak` the fit `fit` makes with them fixed, to the solver's
      tolerance (two programs, which may round differently and stop a step apart;
      measured 1.2e-9 of the RMS apart on the horse). `CornerCutting`'s fitted model is
      chords at one more level than its fixed one.
      On scikit-image's horse the joint fit's was up to 7.7% above. Default (None): 8 for
      one parameter (9 fits before the joint one), 5 for r and s (26). 0: the joint
      fit from the start alone, without that guarantee. At most 64 grid fits.
      `num_steps` counts the returned fit's steps only (the joint fit's, or the
      start's).
    - `phases`: a closed curve's fit from this many starts, the linear fit with the
      control polygon's phase along the samples shifted by 0, 1/K, ..., (K - 1)/K of a
      span, each fitted to `tol`; the converged fit of least two-sided RMS (`rms`) is
      returned, else (none converged) the fit of least RMS; its `num_steps` and `status`
      are that fit's (static; default
      `fitting.PHASES` = 1, the linear start at the samples' chord-length positions
      alone). Which local minimum a fit reaches depends on that phase:
      `benchmarks/results/fit_phases.md` measures `phases=4` against 1 (`docs/fitting.md`,
      "Phase of the start"): never a higher RMS, lower by over 5% in 31 of 76 real
      outlines. About K times the time; the phases run through the programs of one fit
      (one program beside one phase's, whatever K; under `jit` or `grad`, in one
      program, `fit_batch`'s).
      More than 1 with an open `boundary`, `fit_params`, `init` or another `solver` is a
      `ValueError`; with `corners` found it is not searched (the corners place the spans).
    - `init`: starting control points `(n, d)` instead of the linear fit. A fit from
      `init` that ends worse than the linear fit before any step (a higher loss, or a
      two-sided RMS above 1.1 times its) reports `poor_local_minimum`: a local minimum
      worse than the fit without `init` (a one-sided test: `docs/fitting.md`).
    - `solver`: `"levenberg-marquardt"` (default: the structured solver above),
      `"optimistix-levenberg-marquardt"`, `"gauss-newton"`, `"dogleg"`, `"bfgs"`
      (optimistix's own, on the same residuals, Jacobians by autodiff; slower), or any
      optimistix least-squares solver or minimiser.
    - `max_steps`: solver step limit (traced with the default solver; with optimistix's
      own solvers it is their static limit, and a new value compiles again).
    - `tol`: the default solver stops when two accepted steps in a row each lower the
      loss (a sum of squared distances) by less than `tol` of itself, when it fell by
      at most `sqrt(tol)` of itself over the last 50 steps (a plateau), or the RMS
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
      for the first time in the process (compiled, or loaded from the cache). With
      `phases` > 1, a line per phase ("fitting, phase 2 of 4: ...").
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
    check_on_failure(on_failure)
    pad_to = 0 if pad_to is None else static_int(pad_to, "pad_to", minimum=1)
    if not (isinstance(progress, bool) or progress == "time"):
        raise ValueError(f"`fit(progress=...)` must be True, False or 'time'; got {progress!r}.")
    levels_given = levels is not None
    target, weights, n, levels, names, profile = prepare(
        target, scheme, n_control, levels=levels, boundary=boundary, fit_params=fit_params,
        weights=weights, ordered=ordered, smoothing=smoothing, pad_to=pad_to,
        memory_budget=memory_budget, profile=profile, pin_ends=pin_ends,
    )
    flags = corner_flags(corners, target, weights, scheme, n, boundary, pin_ends, ordered)
    hermite = uses_tangents(scheme, names, boundary, creased=flags is not None)
    if flags is not None and not levels_given:
        # The creased curve's model may differ from the smooth one's: its default
        # levels (checked again).
        levels = default_levels(n, bucket(max(target.shape[0], pad_to)), hermite)
        check_memory("fit", target.shape[0], pad_to, n, levels, scheme, boundary,
                     target.dtype, memory_budget, ordered)
    max_steps = static_int(max_steps, "max_steps", minimum=1)
    tol = default_tol(target.dtype) if tol is None else check_tol(tol, "fit")
    if init is not None:
        init = float_array(init, "init").astype(target.dtype)
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
    solver = make_solver(solver, tol, tol, progress is True)
    objective = make_objective(scheme, n=n, levels=levels, boundary=boundary, names=names,
                               hermite=hermite, size=size,
                               profile=profile, pin_ends=pin_ends,
                               corners=flags is not None,
                               phases=check_phases(phases, boundary=boundary,
                                                   fit_params=bool(names),
                                                   init=init is not None,
                                                   solver=solver is not None))
    root_smoothing, tol, max_steps = traced_settings(smoothing, tol, max_steps, target.dtype,
                                                     solver is None)
    padded, weights = pad(target, weights, size)
    if flags is not None:
        flags = jnp.asarray(np.concatenate([flags, np.zeros(size - m, bool)]))
    data = FitData(target=padded, weights=weights, scheme=scheme,
                   root_smoothing=root_smoothing, count=np.int32(m), corners=flags)
    result = run(data, init, tol, max_steps, objective=objective, solver=solver,
                 progress=progress)
    if result.control_points.dtype != dtype:
        cast = lambda x: x.astype(dtype) if eqx.is_inexact_array(x) else x
        result = jax.tree.map(cast, result)
    report(result, on_failure)
    return result
