"""The fit of one outline: `fit_one`, its two parts, their keys, and how they run.

`fit_one` is pure JAX: the solve (`solve_one`) and the measurement of its errors
(`measure_one`, a function of the curve alone, so one program serves fits of many
settings). `fitting.fit` jits the two parts separately (`eqx.filter_jit`) or runs their
programs exported to disk (`_exported`); `fitting.fit_batch` maps `fit_one` over a
batch. What selects the solve's compiled program is static and hashable: the
`Objective` (shapes and settings, built on the host by `make_objective`), the solver's
kind and the shapes and dtypes of the data; everything else is a traced array: the
samples and weights (`FitData`), the smoothing, `tol`, and `max_steps` with the default
solver.
"""

import contextlib
import dataclasses
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Float, Int

import jaxsubdiv as js
from jaxsubdiv.validation import is_traced

from . import _exported, _progress
from ._curve import curve_samples
from ._init import canonical_order, corner_creases, initial_control
from ._objective import (
    FitData,
    Objective,
    curve_errors,
    root_mean_square,
    target_distances,
)
from ._params import from_unconstrained, to_unconstrained
from ._result import FitResult, FitStatus, status_code
from ._solver import FootPointLevenbergMarquardt, newton_solve, settled
from ._threads import one_blas_thread


def make_objective(scheme, *, n: int, levels: int, boundary: str, names: tuple[str, ...],
                   hermite: bool, size: int, profile: int = 0,
                   pin_ends: bool = False, corners: bool = False,
                   phases: int | None = None) -> Objective:
    """The fit's `Objective` for `n` control points and `size` samples (the bucket),
    built on the host: every field is a Python value, so equal settings compare (and
    hash) equal and select the same compiled program. `profile`: values per fitted
    parameter of the profile before the joint fit (`profile_start`), 0 for none.
    `pin_ends`: the curve's ends on the first and last samples (`end_pivots`).
    `corners`: a closed curve creased at the control points of the samples'
    corners (`FitData.corners`); `hermite` then says whether its pieces have exact
    end tangents (`uses_tangents(..., creased=True)`)."""
    pivots = end_pivots(scheme, n, levels, boundary) if pin_ends else ()
    return Objective(n=n, levels=levels, boundary=boundary, names=tuple(names),
                     hermite=hermite,
                     num_curve=curve_samples(scheme, n, levels, boundary),
                     num_target=size, profile=profile if names else 0, pivots=pivots,
                     corners=corners,
                     phases=(PHASES if phases is None else phases)
                     if boundary == "closed" and not corners and not names else 1)


def end_pivots(scheme, n: int, levels: int, boundary: str) -> tuple[int, int]:
    """The control points that pinned ends solve for (`Objective.pin_map`): the one of
    largest weight in the curve's first point, and of the others the one of largest
    weight in its last (the 2 x 2 system is then far from singular: for the cubic
    B-spline P_1 and P_{n-2}, at weight 2/3 each). Chosen at the scheme's values, or at
    its type's defaults when they are traced; a static choice of the program."""
    if any(is_traced(leaf) for leaf in jax.tree.leaves(scheme)):
        try:
            scheme = type(scheme)()
        except TypeError:  # no defaults (a user's mask): nothing concrete to choose from
            raise ValueError(
                f"`fit(pin_ends=True)` chooses two control points from the scheme's "
                f"values, and this {type(scheme).__name__}'s are traced: pass it with "
                "concrete values (trace the samples, not the scheme)."
            ) from None
    # Concrete values even inside a caller's `jax.jit` (the scheme is concrete here; a
    # table built under the trace had traced weights, and `fit` failed under `jit`).
    with jax.ensure_compile_time_eval():
        table = js.curve_stencil(scheme, n, levels, boundary=boundary)
    first, last = np.abs(np.asarray(table.weights))[[0, -1]]
    start, end = np.asarray(table.first)[[0, -1]]
    width = first.size
    head = int((start + np.argmax(first)) % n)
    tail_weights = np.where((start + np.arange(width)) % n == head, -1.0, last)
    tail = int((end + np.argmax(tail_weights)) % n)
    return (head, tail)


def traced_settings(smoothing, tol, max_steps, dtype, default_solver: bool):
    """`(root of smoothing, tol, max_steps)` as `fit_one` takes them: numpy arrays for
    concrete values (no compiling of scalar operations), traced as data by the jitted
    program. With the default solver (`default_solver`) `max_steps` is data too; with
    optimistix's own solvers it stays a Python int: their step
    limit is static (`optimistix.least_squares` builds its loop from it).

    The root is of `smoothing` plus the dtype's smallest normal number: the loss holds
    it squared, so its derivative in `smoothing` is exactly that of the loss, also at
    `smoothing=0`, where the root's own derivative is infinite and the implicit
    derivative was 0 x inf = NaN (issue #14). The loss changes by 1e-308 (float64) or
    1e-38 (float32) of the smoothing term's norm: nothing."""
    xp = jnp if is_traced(smoothing) or is_traced(tol) else np
    steps = np.int32(max_steps) if default_solver else max_steps
    tiny = np.finfo(dtype).tiny
    return xp.sqrt(xp.asarray(smoothing, dtype) + tiny), xp.asarray(tol, dtype), steps


class Solved(eqx.Module):
    """A fit solved but not yet measured (`solve_one`): the fields of its `FitResult`
    that the solve gives, and what `measure_one` needs. `curve` (the curve's samples),
    `tangents` (its tangents there for the Hermite model, else None), `target` and
    `feet` (the tracked curve positions of the samples on a closed Hermite curve, else
    None) are in units of the outline's size: `center + scale * x` in the target's."""

    control_points: Array
    scheme: Any
    creases: Array | None
    curve: Array
    tangents: Array | None
    target: Array
    weights: Array
    count: Any
    feet: Array | None
    center: Array
    scale: Array
    num_steps: Array
    status: Array
    newton_step: Array
    # With a profile (`profile_start`): the fit with the parameters held at their start,
    # which the result falls back to when its two-sided RMS is lower (`prefer_start`).
    at_start: "Solved | None" = None
    # With a given `init`: the start taken without it (the linear fit, no steps), whose
    # errors `flag_poor_start` compares, and (on that start only) its samples-to-curve
    # RMS in units of the size, as `measure_one` finds it: a lower bound of its
    # two-sided RMS, which spares measuring it where the fit is clearly better.
    linear_start: "Solved | None" = None
    target_to_curve: Array | None = None


def solve_one(data: FitData, init, tol, max_steps, *, objective: Objective, solver=None,
              progress: bool = False) -> Solved:
    """Solve one fit (pure JAX): everything of `fit_one` but the errors.

    `data.target` and `data.weights` are padded to the program's bucket
    (`objective.num_target` samples), `data.count` is the number of samples before
    padding; `init` is None or starting control points in the target's units. `tol`
    and `max_steps` are arrays, traced with the default solver (`solver=None`); with
    an optimistix solver (`_solver.make_solver`, its tolerances fixed at construction),
    `max_steps` is its static step limit. `progress`: a line per solver step.
    """
    problem = set_up(data, init, objective)
    y0 = problem.start
    own_solver = solver is None
    at_start = None
    if objective.names and objective.profile:
        # (With an optimistix solver the profile's fits still use the default one, whose
        # fit at the start is then not the fit the caller asked for: not kept.)
        y0, held = profile_start(objective, problem.data, y0, tol,
                                 max_steps if own_solver else None)
        at_start = None if not own_solver else solved_from(objective, problem,
                               {"control": held["control"], "params": held["params"]},
                               hint=held["hint"], num_steps=held["num_steps"],
                               status=held["status"], newton=held["newton"])
    if own_solver:
        solver = default_solver(objective, tol, problem.valid_count, max_steps, progress)
    if own_solver and init is None and objective.phases > 1:
        sol = phase_solve(objective, problem, tol, max_steps, progress)
    else:
        sol = optx.least_squares(
            objective.residuals, solver, y0, args=problem.data,
            max_steps=None if own_solver else max_steps, throw=False,
        )
    # The default solver reports its foot points and model at the returned point.
    newton = newton_step(objective, sol.value, problem.data, sol.stats.get("model"))
    result = (settled(sol.result, sol.stats["model"], solver.rtol, solver.atol)
              if own_solver else sol.result)
    status = status_code(result)
    linear = None
    if problem.default_start is not None:
        # The start taken without `init`, measured too (`flag_poor_start`).
        linear_y = jax.lax.stop_gradient(problem.default_start)
        data = jax.lax.stop_gradient(problem.data)
        hint = objective.feet(linear_y, data)
        linear_loss = loss_at(objective, linear_y, data, hint)
        loss = (sol.stats["model"][0] if own_solver
                else loss_at(objective, sol.value, problem.data))
        # (Not the fit at the start's loss: for some schemes the profile's fixed model is
        # not the joint one, `profile_start`; the RMS check covers whichever is chosen.)
        status = poor_start(loss, linear_loss, status, tol, problem.valid_count)
        linear = solved_from(objective, problem, linear_y, hint=hint,
                             num_steps=jnp.zeros_like(sol.stats["num_steps"]),
                             status=jnp.zeros_like(status), newton=jnp.zeros_like(newton))
        near = target_distances(linear.curve, linear.tangents, linear.target, linear.weights,
                                linear.feet, closed=objective.closed)
        linear = eqx.tree_at(lambda s: s.target_to_curve, linear,
                             root_mean_square(near, linear.weights),
                             is_leaf=lambda x: x is None)
    solved = solved_from(objective, problem, sol.value, hint=sol.stats.get("hint"),
                         num_steps=sol.stats["num_steps"], status=status, newton=newton)
    return eqx.tree_at(lambda s: (s.at_start, s.linear_start), solved, (at_start, linear),
                       is_leaf=lambda x: x is None)


class Problem(eqx.Module):
    """One fit set up for a solver (`set_up`): its `data` in units of the outline's size
    (`center + scale * x` in the target's), the solver's `start` and the number of
    samples of non-zero weight."""

    data: FitData
    start: dict
    center: Array
    scale: Array
    valid_count: Array
    # With a given `init`: the default start (the linear fit), for `poor_start`.
    default_start: dict | None = None


def set_up(data: FitData, init, objective: Objective) -> Problem:
    """The samples in canonical order, scaled to unit size, and the starting point (the
    linear fit at the samples' chord parameters, or `init`): everything of `solve_one`
    before the solver runs. Pure JAX, one fit (`fit_batch`'s batched solver maps it)."""
    if objective.closed:
        # The samples in an order found from them as a set (`_init.canonical_order`):
        # the fit is then the same, bit for bit, for any phase and direction.
        order = canonical_order(data.target, data.count)
        outline = jnp.arange(order.shape[0]) < (order.shape[0] if data.count is None
                                                else data.count)
        data = eqx.tree_at(lambda d: (d.target, d.weights), data,
                           (data.target[order],
                            jnp.where(outline, data.weights[order], data.weights)))
        if objective.corners:
            data = eqx.tree_at(lambda d: d.corners, data, outline & data.corners[order])
    target, weights, scheme = data.target, data.weights, data.scheme
    dtype = target.dtype
    # Weights are relative: divided by the largest first, so that normalising them to
    # mean 1 (`Objective.residuals_at`) neither overflows their sum (1e307 each) nor
    # the reciprocal of their mean (1e-320 each); both gave NaN before (issue #14).
    # Exact for derivatives too: the fit does not change when all weights scale.
    weights = weights / jnp.max(weights)
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
    # Corners: the creased control points, and the samples' starting positions that put
    # each corner sample at its crease.
    # (In units of the outline's size: chord lengths of coordinates near 1e160 would
    # overflow, and near 1e-160 vanish.)
    creases, position = (corner_creases((target - center) / scale, data.corners & valid,
                                        objective.n)
                         if objective.corners else (None, None))
    # The curve's basis at the starting parameters: for the initial linear fit, for the
    # whole solve when no parameter is fitted, and for the final curve then.
    basis = objective.basis_of(scheme, dtype, creases)
    if len(basis[0]) != objective.num_curve:  # static shapes: a defect, never data
        raise AssertionError(f"the objective expects {objective.num_curve} curve samples, "
                             f"the basis has {len(basis[0])} rows")
    # The problem in units of the outline's size.
    scaled = FitData(target=(target - center) / scale, weights=weights, scheme=scheme,
                     root_smoothing=data.root_smoothing,
                     basis=None if objective.names else basis, count=data.count,
                     corners=data.corners, creases=creases)
    linear = initial_control(scaled.target, weights, basis[0], objective.boundary,
                             data.root_smoothing**2, position, creases, offset=data.phase)
    params = to_unconstrained(scheme, objective.names)
    start = lambda P: {"control": jax.lax.stop_gradient(objective.unknowns(P)),
                       "params": params}
    if init is None:
        return Problem(data=scaled, start=start(linear), center=center, scale=scale,
                       valid_count=valid_count)
    return Problem(data=scaled, start=start((init - center) / scale), center=center,
                   scale=scale, valid_count=valid_count, default_start=start(linear))


def loss_at(objective: Objective, y, data: FitData, hint=None) -> Float[Array, ""]:
    """The fit's loss (the sum of squared residuals) at `y`, with the feet `hint`
    (`Objective.feet`; found afresh when None)."""
    hint = objective.feet(y, data) if hint is None else hint
    return sum(jnp.sum(r**2) for r in jax.tree.leaves(objective.residuals_at(y, data, hint)))


#: A fit from `init` whose two-sided RMS exceeds this multiple of the linear start's is
#: a poor local minimum (`flag_poor_start`): a fit of lower loss can have a higher RMS
#: (the halves' weights differ), by up to 7.7% measured (`prefer_start`).
RMS_MARGIN = 1.1


def poor_start(loss, linear_loss, status, tol, valid_count) -> Int[Array, ""]:
    """`status`, made `poor_local_minimum` where it is success but the fit from the given
    `init` ended at a higher `loss` than the start taken without `init` has before any
    step (`linear_loss`: the linear fit at the samples' chord-length positions,
    `Problem.default_start`), by more than the solver's tolerances (`tol` of it plus
    `valid_count` tol^2: where the linear start is already the optimum, on data the
    scheme represents exactly, a warm start ends level with it up to rounding). The
    default solver never accepts a step that raises the loss, so the fit without
    `init` ends at or below it: this fit is worse. Not differentiated: a diagnostic
    (`benchmarks/results/bad_starts.md`)."""
    margin = linear_loss * (1 + tol) + valid_count * tol**2
    poor = (status == 0) & (jax.lax.stop_gradient(loss) > margin)
    return jnp.where(poor, status_code(FitStatus.poor_local_minimum), status)


def solved_from(objective: Objective, problem: Problem, value, *, hint, num_steps, status,
                newton) -> Solved:
    """The `Solved` of `problem` at the solver's returned point `value`, with the
    solver's `hint` (foot points) there, if any, and its step count, status number and
    Newton step (in units of the outline's size)."""
    scaled, center, scale = problem.data, problem.center, problem.scale
    curve, tangents = objective.curve(value, scaled)
    return Solved(
        control_points=center + scale * objective.control_of(value, scaled),
        scheme=from_unconstrained(scaled.scheme, objective.names, value["params"]),
        creases=scaled.creases,
        curve=curve,
        tangents=tangents,
        target=scaled.target,
        weights=scaled.weights,
        count=scaled.count,
        feet=hint[0] if hint is not None and objective.closed and objective.hermite else None,
        center=center,
        scale=scale,
        num_steps=num_steps,
        status=status,
        newton_step=scale * newton,
    )


def measure_one(curve, tangents, target, weights, count, feet, center, scale, *,
                closed: bool) -> dict[str, Array]:
    """The curve in the target's units and the fit's two-sided errors (pure JAX; the
    arguments are `Solved`'s, `measure_arguments`).

    A function of the curve's samples alone, not of the scheme or the fit's settings:
    `fitting.fit` compiles it as a program of its own, which fits of other schemes,
    control-point counts and fitted parameters share when their shapes agree (dimension,
    dtype, sample-count bucket, number of curve samples), and the boundary, the curve
    model and (closed Hermite curves: whether the solver tracked feet, as the default
    one does) too. The errors are about 40% of a fit's compile time when compiled with
    the solve (`benchmarks/results/fit_parts.md`)."""
    errors = curve_errors(curve, tangents, target, weights, count, feet, closed=closed)
    # Measured in units of the outline's size, then scaled: squares of distances in the
    # caller's units could overflow or underflow (size 1e160 or 1e-160).
    rms_t2c, max_t2c = scale * errors.rms_target_to_curve, scale * errors.max_target_to_curve
    rms_c2t, max_c2t = scale * errors.rms_curve_to_target, scale * errors.max_curve_to_target
    return dict(
        curve=center + scale * curve,
        rms=jnp.maximum(rms_t2c, rms_c2t),
        max_error=jnp.maximum(max_t2c, max_c2t),
        rms_target_to_curve=rms_t2c,
        max_target_to_curve=max_t2c,
        rms_curve_to_target=rms_c2t,
        max_curve_to_target=max_c2t,
    )


def measure_arguments(solved: Solved) -> tuple:
    """`measure_one`'s arguments from a `Solved`."""
    return (solved.curve, solved.tangents, solved.target, solved.weights, solved.count,
            solved.feet, solved.center, solved.scale)


def assemble(solved: Solved, measured: dict, objective: Objective) -> FitResult:
    """The `FitResult` from `solve_one`'s and `measure_one`'s outputs."""
    return FitResult(control_points=solved.control_points, scheme=solved.scheme,
                     creases=solved.creases,
                     num_steps=solved.num_steps, status=solved.status,
                     newton_step=solved.newton_step, boundary=objective.boundary,
                     levels=objective.levels, **measured)


def prefer_start(solved: Solved, measured: dict, start_measured: dict) -> tuple[Solved, dict]:
    """The joint fit of control points and parameters (`solved`, its errors `measured`),
    or the fit with the parameters held at their start (`solved.at_start`, its errors
    `start_measured`) where that one's two-sided RMS is lower, or the joint fit's is not
    a number and the start's is; but not a start's fit that did not converge for a joint
    fit that did. Without `at_start`, `solved` as it is.

    The joint fit's loss is never above the start's fit's (`profile_start`), but the
    loss is not the reported two-sided RMS (the larger of its two halves; the loss
    weighs the curve-to-samples half less beyond a chord band), and moving the
    parameters can move error from one half to the other: on scikit-image's horse the
    fitted parameters raised the RMS by up to 7.7% (issue #14). A choice between two
    fits, each with its own implicit derivatives (not differentiated itself). Concrete
    values choose on the host (no program compiled); traced ones with `jnp.where`, so
    both fits' derivatives are computed, the other one's with zero tangents. The
    measurements returned say which was chosen: `params_held` (`FitResult.params_held`),
    True for the start's fit."""
    start = solved.at_start
    if start is None:
        return solved, measured
    joint = eqx.tree_at(lambda s: s.at_start, solved, None, is_leaf=lambda x: x is None)
    joint_rms, start_rms = measured["rms"], start_measured["rms"]
    statuses = joint.status, start.status
    if not any(is_traced(x) for x in (joint_rms, start_rms, *statuses)):
        joint_rms, start_rms = float(joint_rms), float(start_rms)
        joint_ok, start_ok = (int(x) == 0 for x in statuses)
        better = bool(np.isfinite(start_rms) and not joint_rms <= start_rms
                      and (start_ok or not joint_ok))
        # (device_put of a host value: no program is compiled for the flag.)
        held = jax.device_put(np.asarray(better))
        chosen = (start, start_measured) if better else (joint, measured)
        return chosen[0], chosen[1] | {"params_held": held}
    joint_ok, start_ok = (x == 0 for x in statuses)
    better = jnp.isfinite(start_rms) & ~(joint_rms <= start_rms) & (start_ok | ~joint_ok)
    pick = lambda a, b: jnp.where(better, a, b)
    chosen = jax.tree.map(pick, start_measured, measured)
    return jax.tree.map(pick, start, joint), chosen | {"params_held": better}


def measure_solved(solved: Solved, objective: Objective, tol, measure=None
                   ) -> tuple[Solved, dict]:
    """`measure_one` of `solved` (and of its fit at the start, if any), the result
    `prefer_start` chooses, and that flagged by `flag_poor_start` against its linear
    start, if any (`tol`: the fit's). `measure`: how to run `measure_one` on
    `measure_arguments` (a compiled program, called once per fit); default: traced in
    place, the fits measured by one `vmap` of it (one copy of the measurement in the
    program, whose compile time is about 40% of a fit's: `measure_one`)."""
    linear = solved.linear_start
    solved = eqx.tree_at(lambda s: s.linear_start, solved, None, is_leaf=lambda x: x is None)
    fits = [x for x in (solved, solved.at_start) if x is not None]
    if measure is not None:
        results = [measure(*measure_arguments(x)) for x in fits]
    else:
        parts = fits + ([] if linear is None else [linear])
        if len(parts) == 1:
            results = [measure_one(*measure_arguments(solved), closed=objective.closed)]
        else:
            stacked = jax.tree.map(lambda *xs: jnp.stack(xs),
                                   *(measure_arguments(x) for x in parts))
            every = jax.vmap(lambda *args: measure_one(*args, closed=objective.closed))(*stacked)
            results = [jax.tree.map(lambda x, i=i: x[i], every) for i in range(len(parts))]
    chosen = (solved, results[0]) if solved.at_start is None else prefer_start(
        solved, results[0], results[1])
    if linear is None:
        return chosen
    if measure is None:
        return flag_poor_start(*chosen, results[-1], tol)
    # The linear start's samples-to-curve half bounds its two-sided RMS from below:
    # where the fit is within the margin of that bound, it is within the margin of the
    # RMS, and measuring the start (most of the check's cost: `bench_init_check.py`)
    # is skipped. Concrete values only; traced ones are measured.
    # (Shrunk by 1e-6 of itself: the two programs compiling the same code could round
    # it differently, and a bound above the measured value must not spare a flag.)
    bound = {"rms": (1 - 1e-6) * linear.scale * linear.target_to_curve}
    if not any(is_traced(x) for x in (bound["rms"], chosen[1]["rms"], chosen[0].status)):
        if int(flag_poor_start(*chosen, bound, tol)[0].status) == int(chosen[0].status):
            return chosen
    return flag_poor_start(*chosen, measure(*measure_arguments(linear)), tol)


def flag_poor_start(solved: Solved, measured: dict, linear_measured: dict, tol
                    ) -> tuple[Solved, dict]:
    """`solved` (a fit from a given `init`, its errors `measured`), its status made
    `poor_local_minimum` where it is success but its two-sided RMS is above `RMS_MARGIN`
    times that of the start taken without `init` (`linear_measured`: the linear fit at
    the samples' chord-length positions, before any step) plus `tol` of the outline's
    size (the RMS the solver calls converged; on exact data both are near zero). The
    loss weighs the curve-to-samples half less beyond a chord band, so a fit from a bad
    start can end below the linear start's loss (`poor_start`) with loops that leave
    the samples: on glyphs at 1.6-2.9x its RMS (`benchmarks/results/bad_starts.md`).
    Concrete values decide on the host (no program compiled), traced ones with
    `jnp.where`."""
    rms, linear_rms, status = measured["rms"], linear_measured["rms"], solved.status
    slack = tol * solved.scale
    poor_code = status_code(FitStatus.poor_local_minimum)
    if not any(is_traced(x) for x in (rms, linear_rms, status, slack)):
        poor = int(status) == 0 and float(rms) > RMS_MARGIN * float(linear_rms) + float(slack)
        if not poor:
            return solved, measured
        flagged = jax.device_put(np.asarray(poor_code, np.asarray(status).dtype))
        return eqx.tree_at(lambda s: s.status, solved, flagged), measured
    poor = (status == 0) & (rms > RMS_MARGIN * linear_rms + slack)
    return eqx.tree_at(lambda s: s.status, solved, jnp.where(poor, poor_code, status)), measured


def fit_one(data: FitData, init, tol, max_steps, *, objective: Objective, solver=None,
            progress: bool = False) -> FitResult:
    """Fit one target (pure JAX; `fit_batch` maps this, and `fit` runs its two parts,
    `solve_one` and `measure_one`, as two compiled programs)."""
    solved = solve_one(data, init, tol, max_steps, objective=objective, solver=solver,
                       progress=progress)
    return assemble(*measure_solved(solved, objective, tol), objective)


# Module level, so that repeated calls with the same shapes and settings reuse them.
solve_jit = eqx.filter_jit(solve_one)
measure_jit = eqx.filter_jit(measure_one)


def default_solver(objective: Objective, tol, valid_count, max_steps, progress=False):
    """The default solver for `objective` (`FootPointLevenbergMarquardt`).

    It stops when two accepted steps in a row lower the loss (a sum of squared distances
    over the valid samples) by less than `tol` of it, when 50 steps lowered it by at
    most sqrt(tol) of it (a plateau), or the loss is below that count times tol^2 (RMS
    `tol`)."""
    return FootPointLevenbergMarquardt(
        rtol=tol, atol=valid_count * tol**2, max_steps=max_steps,
        model=objective.quadratic_model, hint=objective.feet,
        verbose=_progress.progress_verbose if progress else None,
    )


#: Phases of a closed curve's start tried by default (`phase_solve`, `run_phases`): one,
#: the linear fit at the samples' chord-length positions. `phases=4` against it
#: (`benchmarks/results/fit_phases.md`): the true curve of a known polygon reached in 32
#: of 36 cases instead of 17; on real outlines the two-sided RMS lower by over 5% in 31
#: of 76 fits and never higher, in a median 3.8x the warm time (`docs/fitting.md`, "Phase
#: of the start", says why it is not yet the default).
PHASES = 1


class PhaseSolution(eqx.Module):
    """What `solve_one` reads of an `optimistix.Solution`, for `phase_solve`'s fit."""

    value: dict[str, Any]
    result: optx.RESULTS
    stats: dict[str, Any]


def phase_preferred(rms, converged, best_rms, best_converged, tol, size):
    """Whether a later phase's fit (two-sided RMS `rms`, non-finite as inf; `converged`:
    its status is success) replaces the best so far (`best_rms`, `best_converged`): a
    converged fit replaces one that did not converge; between two that both converged
    or both did not, the one of lower RMS, by more than the solver's tolerance (`tol`
    of it, and `tol` of the outline's `size`: the RMS the solver calls converged). So,
    up to that tolerance, the choice does not depend on the phases' order: the
    converged fit of least RMS, else the fit of least RMS (a fit whose RMS is not
    finite counts as not converged; a lower RMS reported as "did not converge" is not what a
    search should return when a phase converged: icon filesave at n = 64 ended at 0.87x
    phase 0's RMS after 500 steps, `max_steps`). Within the tolerance the earlier phase
    is kept: starts that reach the same curve, often with the polygon relabelled, tie to
    rounding, which would make the choice (and the polygon's labels) differ between
    programs (`fit`'s phases one by one and `fit_batch`'s `phase_solve`, `jit` and not).
    NumPy values (on the host: no program is compiled) or JAX arrays (also traced)."""
    xp = jnp if any(is_traced(x) or isinstance(x, jax.Array)
                    for x in (rms, converged, best_rms, best_converged)) else np
    # (Written without inf - inf, which NumPy warns about, for a best of inf.)
    converged = converged & (rms < xp.inf)
    best_converged = best_converged & (best_rms < xp.inf)
    lower = rms + tol * (best_rms + size) < best_rms
    same = converged == best_converged
    return ((converged & xp.logical_not(best_converged)) | (same & lower)
            | (same & (best_rms == xp.inf) & (rms < best_rms)))


def phase_solve(objective: Objective, problem: Problem, tol, max_steps,
                progress: bool = False) -> PhaseSolution:
    r"""The fit of a closed curve without fitted parameters from `objective.phases`
    starts, the linear fit with the control polygon's phase along the samples shifted by
    $j / K$ of a span ($j = 0, \dots, K - 1$; 0 is `fit`'s one start, `problem.start`),
    each fitted to `tol`: the converged fit of least two-sided RMS (`curve_errors`, the
    figure `fit` reports), else the fit of least RMS, the first of those within the
    solver's tolerance of it (`phase_preferred`).

    The phase of a closed curve's control polygon is not given by its samples: the
    linear start puts the first control point's span at the first sample (in
    `canonical_order`), and which local minimum the fit then reaches depends on it
    (`benchmarks/results/fit_phases.md`). Every start is fitted to `tol`: ranked after
    fits to 1e-6 instead, with the best continued, the start of least loss led to a
    two-sided RMS up to 7.6x that of the fit from phase 0 on real outlines
    (`results/fit_phases_ranked.md`). Chosen by least loss, fits to `tol` still reached
    up to 3.6x phase 0's RMS (`results/fit_phases_by_loss.md`): the loss weighs the
    curve-to-samples half less beyond a chord band, so a lower loss can be a higher
    two-sided RMS. Chosen by that RMS, the fit returned is never above phase 0's by more
    than the tolerance where phase 0 converged. The K solves and measurements are one `lax.scan` over one solver
    loop (its body compiled once) that carries the best solution so far (memory does not
    grow with K), under `stop_gradient`; the derivatives are the implicit ones of the fit
    returned (`held_implicit`), as `optimistix.least_squares` gives its solution."""
    data = jax.lax.stop_gradient(problem.data)
    K = objective.phases
    solver = default_solver(objective, tol, problem.valid_count, max_steps, progress)

    start = jax.lax.stop_gradient(problem.start["control"])

    def two_sided_rms(value, stats):
        # `measure_one`'s RMS in units of the outline's size: the feet the solver tracked
        # (closed Hermite curves) are checked against global nearest points there too.
        curve, tangents = objective.curve(value, data)
        hint = stats.get("hint")
        feet = hint[0] if hint is not None and objective.hermite else None
        errors = curve_errors(curve, tangents, data.target, data.weights, data.count, feet,
                              closed=True)
        rms = jnp.maximum(errors.rms_target_to_curve, errors.rms_curve_to_target)
        return jnp.where(jnp.isfinite(rms), rms, jnp.inf)

    def solve(j):
        P0 = initial_control(data.target, data.weights, data.basis[0], "closed",
                             data.root_smoothing**2, offset=(j / K).astype(data.target.dtype))
        # Phase 0 is `problem.start`, the one-phase fit's start (also from its program).
        control = jnp.where(j == 0, start, objective.unknowns(P0))
        sol = optx.least_squares(objective.residuals, solver, {"control": control, "params": {}},
                                 args=data, max_steps=None, throw=False)
        # Converged as `solve_one` reports it (`settled`; no `lax.cond`, see there).
        result = settled(sol.result, sol.stats["model"], solver.rtol, solver.atol)
        return (two_sided_rms(sol.value, sol.stats), result == optx.RESULTS.successful,
                PhaseSolution(sol.value, sol.result, sol.stats))

    def keep_best(best, j):
        rms, converged, solution = solve(j)
        better = (j == 0) | phase_preferred(rms, converged, best[0], best[1], tol, 1.0)
        return jax.tree.map(lambda new, old: jnp.where(better, new, old),
                            (rms, converged, solution), best), None

    # The carry's first value: shaped as a solution, replaced by phase 0's.
    shapes = jax.eval_shape(solve, 0)
    empty = jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)
    first = (jnp.asarray(jnp.inf, shapes[0].dtype), jnp.asarray(False), empty[2])
    (_, _, chosen), _ = jax.lax.scan(keep_best, first, jnp.arange(K))
    control = held_implicit(objective, chosen.value["control"], problem.data)
    return PhaseSolution({"control": control, "params": {}}, chosen.result, chosen.stats)


#: The tolerance of the profile's fits on its grid (the fit at the start takes the
#: fit's own): they only rank the values, and the joint fit goes on from the best.
PROFILE_TOL = 1e-4


def profile_grid(scheme, names: tuple[str, ...], values: int) -> dict:
    """The profile's parameter values, unconstrained (`AbstractCurveScheme.from_unconstrained`):
    `values` per fitted parameter at the centres of equal cells of the unit interval that
    the scheme's bijection maps onto its fit interval (for `FourPoint` w = 0.19 (i + 1/2) /
    values; for `CornerCutting` r and s a grid over the triangle 0 < r < s < 1), every
    combination of them: a dict of `(values ** len(names),)` arrays (host constants)."""
    cells = (np.arange(values) + 0.5) / values
    grid = np.stack(np.meshgrid(*([cells] * len(names)), indexing="ij"), -1)
    grid = grid.reshape(-1, len(names))
    raw = np.log(grid) - np.log1p(-grid)  # logit: the bijections are logistic
    return {name: raw[:, k] for k, name in enumerate(names)}


def profile_start(objective: Objective, data: FitData, y0: dict, tol, max_steps) -> dict:
    r"""Where the joint fit of control points and scheme parameters starts: the best of
    fits with the parameters held fixed on a grid (a profile of the loss over the
    parameters), one of them at the given start.

    The loss is far from convex in the scheme's parameters: measured on curves made from
    known parameters, the joint fit from the far end of the range stopped in a local
    minimum with them more than 1e-3 off in 15 of 17 cases (by up to 0.87). So the parameters are
    first held at `objective.profile` values each (`profile_grid`) and at the start `y0`,
    the control points fitted at each (one after another in one compiled loop,
    `jax.lax.map`, which measured 3-4x faster than a `vmap` of them on CPU, and 1.3-4x
    with the grid's fits limited to 15 steps; each from its own linear fit, the start's
    from `y0`'s control points), and the joint fit starts from the fit of lowest loss.
    The profile is most of `fit_params=True`'s time (`benchmarks/results/
    fit_params_after.md`), and what is cheaper measured worse (2026-12-05): continuing
    the start's fit to the grid's values (one Newton step of the control points at each,
    the feet held; a fraction of the time) inherited its local minimum and recovered the
    true parameters in 2 of the 9 recovery tests (`tests/test_fit.py`); limiting the
    grid's fits to 15 steps cut the time by a median 20% (up to 35%) and lost one
    recovery of 17 in `bench_fit_quality.py` (t = 0.75 from 0.03), 8 steps also one of
    the tests. The default solver never accepts a step that raises the
    loss, so the joint fit's loss is at most that of the fit with the parameters held at
    their start (with `max_steps` None, for optimistix's solvers, the profile's fits
    take the default solver's limit of 500 steps).

    Returns the joint fit's start and the fit with the parameters held at their start
    (control points, the parameters' unconstrained values, the solver's feet, steps,
    status and Newton step), which `prefer_start` may return instead of the joint fit.
    The joint fit's start is not differentiated: it is a choice, and the implicit
    derivatives of the fit are those of the optimum it then reaches. The start's fit is:
    it may be the result.
    """
    names, scheme = objective.names, data.scheme
    dtype = data.target.dtype
    fixed = dataclasses.replace(objective, names=(), profile=0)
    grid = profile_grid(scheme, names, objective.profile)
    raws = {k: jnp.concatenate([jnp.reshape(y0["params"][k], (1,)).astype(dtype),
                                jnp.asarray(grid[k], dtype)]) for k in names}
    valid_count = jnp.sum(data.weights > 0)
    steps = jnp.asarray(500 if max_steps is None else max_steps, jnp.int32)

    def held_data(raw):  # the data with the scheme at the parameters' values `raw`
        held_scheme = from_unconstrained(scheme, names, raw)
        basis = fixed.basis_of(held_scheme, dtype, data.creases)
        return eqx.tree_at(lambda d: (d.scheme, d.basis), data, (held_scheme, basis),
                           is_leaf=lambda x: x is None)

    def held(raw, start):
        # The start to `tol`; the grid's fits only rank the values, to PROFILE_TOL.
        solver = default_solver(fixed, jnp.where(start, tol, jnp.maximum(tol, PROFILE_TOL)),
                                valid_count, steps)
        at = held_data(raw)
        basis = at.basis
        position = (corner_creases(at.target, at.corners & (at.weights > 0), objective.n)[1]
                    if objective.corners else None)
        P0 = initial_control(at.target, at.weights, basis[0], objective.boundary,
                             at.root_smoothing**2, position, at.creases)
        P0 = jnp.where(start, y0["control"], fixed.unknowns(P0))
        sol = optx.least_squares(fixed.residuals, solver, {"control": P0, "params": {}},
                                 args=at, max_steps=None, throw=False)
        model = sol.stats["model"]
        loss = jnp.where(jnp.isfinite(model[0]), model[0], jnp.inf)
        newton = newton_step(fixed, sol.value, at, model)
        status = status_code(settled(sol.result, model, solver.rtol, solver.atol))
        return dict(control=sol.value["control"], loss=loss, hint=sol.stats["hint"],
                    num_steps=sol.stats["num_steps"], status=status, newton=newton)

    start = jnp.arange(1 + len(grid[names[0]])) == 0
    # Not differentiated: derivatives through the map would run the implicit solves of
    # every fit in it (and a grid fit that failed, never chosen, would poison them).
    fits = jax.lax.stop_gradient(jax.lax.map(lambda item: held(*item), (raws, start)))
    best = jnp.argmin(fits["loss"])
    joint_start = {"control": fits["control"][best],
                   "params": {k: jax.lax.stop_gradient(v[best]) for k, v in raws.items()}}
    at_start = {k: v[0] for k, v in fits.items() if k != "loss"}
    start_params = {k: v[0] for k, v in raws.items()}
    # The start's fit may be the result (`prefer_start`): its control points get the
    # implicit derivatives its own solve would have given (`held_implicit`).
    at_start["control"] = held_implicit(fixed, at_start["control"], held_data(start_params))
    at_start["params"] = start_params
    return joint_start, at_start


def _held_primal(inputs):
    y, _, _ = inputs
    return y, None


def _held_rewrite(y, _, inputs):
    # optimistix's optimality condition of a least-squares solve: the loss's gradient.
    _, objective, args = inputs
    return jax.grad(lambda z: 0.5 * loss_at(objective, z, args))(y)


def held_implicit(objective: Objective, control, args: FitData):
    r"""`control` (converged control points of `objective`, a fit without fitted
    parameters, on `args`), with the derivatives that `optimistix.least_squares`'s
    implicit adjoint gives its solution: $-H^{-1} \partial g / \partial \theta$, $g$
    the loss's gradient in the control points and $\theta$ everything in `args`. The
    solve is not run again (it ran in the profile's map, under `stop_gradient`); only
    the derivatives' linear solve runs, and only when differentiated."""
    y = {"control": jax.lax.stop_gradient(control), "params": {}}
    y, _ = optx.internal.implicit_jvp(_held_primal, _held_rewrite, (y, objective, args),
                                      frozenset(), optx.ImplicitAdjoint().linear_solver)
    return y["control"]


def newton_step(objective: Objective, y, data: FitData, model=None) -> Float[Array, ""]:
    """Largest control-point coordinate of the Newton step at `y`, in units of the
    outline's size; inf where the Hessian does not factor (not positive definite).

    `model`: the loss, half gradient and half Hessian at `y` if the solver has them
    (the default solver's `stats["model"]`), else the objective's model is evaluated
    there once. A diagnostic, not differentiated.
    """
    y = jax.lax.stop_gradient(y)
    if model is None:
        model = objective.quadratic_model(y, jax.lax.stop_gradient(data))
    _, gradient, hessian = jax.lax.stop_gradient(model)
    step, definite = newton_solve(hessian, gradient)
    # ravel_pytree puts the control points first.
    largest = jnp.max(jnp.abs(step[: y["control"].size]))
    return jnp.where(definite, largest, jnp.inf)


def solved_structure(scheme, objective: Objective, counted: bool, init_given: bool):
    """The pytree structure of `solve_one`'s `Solved` with the default solver (the fitted
    scheme has the structure of the given one; `counted`: the data have a `count`;
    `init_given`: with the linear start, `Solved.linear_start`)."""
    tangents = (0.0, 0.0) if objective.corners else 0.0  # a creased curve's: a pair
    varying = dict(scheme=scheme, tangents=tangents if objective.hermite else None,
                   creases=0.0 if objective.corners else None,
                   count=0.0 if counted else None,
                   feet=0.0 if objective.closed and objective.hermite else None)
    # Every other field is one array.
    arrays = {f.name: 0.0 for f in dataclasses.fields(Solved) if f.name not in varying
              and f.name not in ("at_start", "linear_start", "target_to_curve")}
    plain = Solved(**varying, **arrays)
    at_start = plain if objective.names and objective.profile else None
    linear = Solved(**varying, **arrays, target_to_curve=0.0) if init_given else None
    return jax.tree.structure(Solved(**varying, **arrays, at_start=at_start,
                                     linear_start=linear))


MEASURED = jax.tree.structure(dict.fromkeys(
    ("curve", "rms", "max_error", "rms_target_to_curve", "max_target_to_curve",
     "rms_curve_to_target", "max_curve_to_target"), 0.0))


def program_key(objective: Objective, data: FitData, init, solver, progress: bool) -> tuple:
    """What selects `solve_jit`'s compiled program besides the data's values (for the
    progress display's "compiling" line)."""
    return (objective, data.target.shape[1], str(data.target.dtype), init is None,
            jax.tree.structure(data.scheme), type(solver).__name__, progress,
            data.phase is None)


def run(data: FitData, init, tol, max_steps, *, objective: Objective, solver=None,
        progress=False):
    """`fit_one`, compiled as two programs, `solve_one` and `measure_one` (shared by fits
    of other settings with the same shapes): `progress` True for a line per solver
    step, `"time"` for the elapsed time (the program is then the one without progress).

    With the persistent compilation cache on, a concrete call with the default solver
    runs programs exported to disk: a new process then skips tracing and lowering.

    A concrete fit of several phases (`Objective.phases`) runs them one by one
    (`run_phases`); a traced one, as `fit_batch`, in one program (`phase_solve`).
    """
    args = (data, init, tol, max_steps)
    if objective.phases > 1 and not any(is_traced(x) for x in jax.tree.leaves(args)):
        return run_phases(data, init, tol, max_steps, objective=objective, solver=solver,
                          progress=progress)
    return run_once(data, init, tol, max_steps, objective=objective, solver=solver,
                    progress=progress)[0]


def run_phases(data: FitData, init, tol, max_steps, *, objective: Objective, solver=None,
               progress=False):
    """`run` of a concrete fit from `objective.phases` starts (`phase_solve`'s), one by
    one through one program: the fit of one phase, its start shifted by `FitData.phase`
    (a traced number), and its measurement, whose status and two-sided RMS choose
    (`phase_preferred`). The programs are those of one phase with a phase input (one
    solve program more than a fit of one phase, whatever K; the measurement's is
    shared): `phase_solve`'s in-program measurement made a first fit compile 1.48x as
    long as one phase's (`benchmarks/results/fit_phases_in_one_program.md`, 2026-12-07
    22:59 UTC), these 1.02x (`fit_phases.md`, 23:39 UTC). `num_steps` and `status` are the chosen
    fit's."""
    K = objective.phases
    single = dataclasses.replace(objective, phases=1)
    dtype = data.target.dtype
    best = None
    for j in range(K):
        phased = eqx.tree_at(lambda d: d.phase, data, np.asarray(j / K, dtype),
                             is_leaf=lambda x: x is None)
        result, scale = run_once(phased, init, tol, max_steps, objective=single,
                                 solver=solver, progress=progress,
                                 label=f"fitting, phase {j + 1} of {K}")
        if any(is_traced(x) for x in (result.rms, result.status, scale)):
            # Concrete inputs inside an outer trace (`jit` of a function that closes over
            # them): the results are traced, so the phases are chosen in one program.
            return run_once(data, init, tol, max_steps, objective=objective, solver=solver,
                            progress=progress)[0]
        rms = float(result.rms)
        rms = np.float64(rms if np.isfinite(rms) else np.inf)
        converged = np.bool_(int(result.status) == 0)
        if best is None or phase_preferred(rms, converged, best[0], best[1], float(tol),
                                           float(scale)):
            best = (rms, converged, result)
    return best[2]


def run_once(data: FitData, init, tol, max_steps, *, objective: Objective, solver=None,
             progress=False, label: str = "fitting") -> tuple[FitResult, Array]:
    """`run` of one program's fit: its result, and the outline's size (the units the
    solver works in, `Problem.scale`). `label`: the progress line's."""
    steps = progress is True  # a line per solver step, from inside the program
    if progress:
        _progress.compiling(program_key(objective, data, init, solver, steps),
                            objective.num_target)
        _progress.step_label(label)
    args = (data, init, tol, max_steps)
    static = dict(objective=objective, solver=solver, progress=steps)
    concrete = not any(is_traced(x) for x in jax.tree.leaves(args))
    exported = solver is None and not steps and _exported.folder() is not None and concrete
    clock = _progress.elapsed(label=label) if progress == "time" else contextlib.nullcontext()
    # One BLAS thread while the programs run (`_threads`), so they must have finished
    # inside the block: a concrete fit is waited for here (its caller reads its status
    # next anyway).
    with clock, one_blas_thread():
        if exported:
            structure = solved_structure(data.scheme, objective, data.count is not None,
                                         init is not None)
            solved = _exported.call(solve_one, args, static, structure)
            measure = lambda *a: _exported.call(measure_one, a, {"closed": objective.closed},
                                                MEASURED)
        else:
            solved = solve_jit(*args, **static)
            measure = lambda *a: measure_jit(*a, closed=objective.closed)
        result = assemble(*measure_solved(solved, objective, tol, measure), objective)
        if progress or concrete:
            jax.block_until_ready(result)
    if steps:
        _progress.finish()
    return result, solved.scale
