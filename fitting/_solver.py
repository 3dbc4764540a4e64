"""A Levenberg-Marquardt solver for the fit that takes its Jacobian from the problem.

optimistix's `LevenbergMarquardt` builds the Jacobian of a black-box residual function by
autodiff and solves the damped normal equations with lineax. The fit has more structure:
the curve is linear in the control points, so the problem can hand over its loss,
gradient and exact Hessian, assembled in closed form (`Objective.quadratic_model`), and a
step is one small Cholesky solve.
The solver is an ordinary optimistix least-squares solver, so `optimistix.least_squares`
runs it: `throw`, the result codes and the implicit adjoint work unchanged.

When the damped matrix is not positive definite (the exact Hessian is indefinite away
from a minimum), the damping is raised tenfold until it is, within the step, before the
model is evaluated at the trial point.
Steps follow Nielsen's damping update (H. B. Nielsen, "Damping parameter in Marquardt's
method", IMM-REP-1999-05): accept when the actual decrease is a positive fraction of the
decrease the linear model predicts, and scale the damping by
max(1/3, 1 - (2 rho - 1)^3) on acceptance and by a growing factor on rejection. The
damping is Levenberg's (a multiple of the identity, relative to the mean of the normal
matrix's diagonal), not Marquardt's diagonal scaling: points sliding along straight parts
of the curve leave some diagonal entries near zero, and those directions need damping.

It stops (successfully) when two accepted steps in a row each lower the loss by at most
`rtol * loss + atol` (one such step may be a heavily damped one far from a minimum), when
the loss fell by at most `sqrt(rtol) * loss + atol` over the last `PLATEAU_STEPS` (50)
steps (a plateau: the slow slide of a fit along a nearly flat valley, which otherwise
ran out of steps with its figures no longer moving), or when the loss is below `atol`;
it reports
`nonlinear_divergence` when no step can lower the loss although the gradient does not
vanish (which `settled` makes a success where the full Newton step would gain at most
`rtol` of the loss plus `atol`), and `nonlinear_max_steps_reached` after `max_steps`
steps. Step 0 only evaluates the model at the starting point (so `num_steps` counts it).

Besides optimistix's `num_steps` and `max_steps`, `solution.stats` holds the returned
point's `hint` and `model` (loss, half gradient, half Hessian), so that the caller can
reuse them (the fit's errors and Newton step) instead of evaluating them again.

`rtol`, `atol` and `max_steps` are array fields, traced like the data: new values reuse
the compiled program. (optimistix's own step limit must be a Python integer, a static
value; run this solver with `optimistix.least_squares(..., max_steps=None)`.)
"""

from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import optimistix as optx
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Bool, Float, Int

from . import _progress


#: The solvers `fit(solver=...)` takes by name; the first is `FootPointLevenbergMarquardt`.
SOLVERS = (
    "levenberg-marquardt", "optimistix-levenberg-marquardt", "gauss-newton", "dogleg", "bfgs"
)


def make_solver(solver, rtol: float, atol: float, progress: bool = False):
    """The optimistix solver for `fit(solver=...)`, or None for the default
    (`FootPointLevenbergMarquardt`, built inside the fit, which knows the problem's
    structure and the data-dependent `atol`).

    `rtol` and `atol` become array fields: traced, so new values compile nothing. What
    stays static in optimistix's solvers: their step limit (`optimistix.least_squares`
    needs a Python int to build its loop), the linear solver, norm and `verbose`
    callable (functions and solver choices, which select code, not data).
    """
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


class _State(eqx.Module):
    hint: Any  # the problem's data carried from step to step (e.g. foot points)
    loss: Float[Array, ""]
    gradient: Float[Array, " D"]
    hessian: Float[Array, "D D"]
    damping: Float[Array, ""]
    growth: Float[Array, ""]
    num_steps: Int[Array, ""]
    small: Bool[Array, ""]
    checkpoint: Float[Array, ""]  # the loss at the last multiple of PLATEAU_STEPS
    terminate: Bool[Array, ""]
    result: optx.RESULTS


class FootPointLevenbergMarquardt(optx.AbstractLeastSquaresSolver):
    """Levenberg-Marquardt with a problem-supplied linearization (see module docstring).

    `model(y, args, hint)` returns the loss (a sum of squares), half its gradient and half
    its Hessian (or a Gauss-Newton approximation), flattened in
    `jax.flatten_util.ravel_pytree(y)` order. `hint(y, args, previous)` returns data the
    model needs at `y` that are cheaper to find from their values at the previous
    accepted point (the fit's foot points); the first step passes zeros as `previous`,
    so `hint` must find them from any start. Without `hint`, the model gets None. `fn`
    itself is only used by optimistix for the implicit adjoint.
    """

    rtol: Float[Array, ""]
    atol: Float[Array, ""]
    max_steps: Int[Array, ""]
    model: Callable = eqx.field(static=True)
    hint: Callable | None = eqx.field(static=True, default=None)
    verbose: Callable | None = eqx.field(static=True, default=None)
    norm: Callable = eqx.field(static=True, default=optx.max_norm)  # optimistix's interface

    def init(self, fn, y, args, options, f_struct, aux_struct, tags) -> _State:
        # The model at `y` is evaluated by the first step (a zero step, always accepted),
        # so that the compiled program holds one copy of it, not two.
        flat, _ = ravel_pytree(y)
        size, dtype = flat.size, flat.dtype
        return _State(
            hint=self._first_hint(y, args),
            loss=jnp.asarray(jnp.inf, dtype),
            gradient=jnp.zeros((size,), dtype),
            hessian=jnp.zeros((size, size), dtype),
            damping=jnp.asarray(1e-3, dtype),
            growth=jnp.asarray(2.0, dtype),
            num_steps=jnp.array(0),
            small=jnp.array(False),
            checkpoint=jnp.asarray(jnp.inf, dtype),
            terminate=jnp.array(False),
            result=optx.RESULTS.successful,
        )

    def _first_hint(self, y, args):
        # Zeros of the hint's shape: the first step's `hint(y, args, zeros)` must then
        # find the data afresh (the fit's foot-point search falls back to its global
        # search), so that the program holds one copy of that search, not two.
        if self.hint is None:
            return None
        shapes = jax.eval_shape(self.hint, y, args, None)
        return jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)

    def step(self, fn, y, args, options, state: _State, tags) -> tuple[Any, _State, None]:
        flat, unravel = ravel_pytree(y)
        first = state.num_steps == 0
        raised, delta = damped_step(state.hessian, state.gradient, state.damping)
        delta = jnp.where(first, 0.0, delta)
        trial = unravel(flat + delta)
        hint = None if self.hint is None else self.hint(trial, args, state.hint)
        loss, gradient, hessian = self.model(trial, args, hint)
        if callable(self.verbose):
            self.verbose(num_steps=("Step", state.num_steps),
                         loss_this_step=("Loss on this step", 0.5 * loss))
        verdict = judge(state, delta, raised, loss, self.rtol, self.atol, self.max_steps)
        keep = lambda new, old: jnp.where(verdict.accept, new, old)
        new_state = _State(
            hint=jax.tree.map(keep, hint, state.hint),
            loss=keep(loss, state.loss),
            gradient=keep(gradient, state.gradient),
            hessian=keep(hessian, state.hessian),
            damping=verdict.damping,
            growth=verdict.growth,
            num_steps=state.num_steps + 1,
            small=verdict.small,
            checkpoint=verdict.checkpoint,
            terminate=verdict.terminate,
            result=verdict.result,
        )
        return jax.tree.map(keep, trial, y), new_state, None

    def terminate(self, fn, y, args, options, state: _State, tags):
        return state.terminate, state.result

    def postprocess(self, fn, y, aux, args, options, state, tags, result):
        # The last accepted point's hint (the fit's foot points) and model, for the
        # caller's diagnostics (`solution.stats`): the returned `y` is that point.
        model = (state.loss, state.gradient, state.hessian)
        return y, aux, {"hint": state.hint, "model": model}


def damped_step(H: Float[Array, "D D"], g: Float[Array, " D"],
                damping: Float[Array, ""]) -> tuple[Float[Array, ""], Float[Array, " D"]]:
    """The Levenberg step `-(H + damping scale I)^{-1} g` (`scale` the mean of H's
    diagonal), with the damping raised tenfold until the damped matrix factors:
    `(raised damping, step)`."""
    size = H.shape[0]
    trace = jnp.trace(H)
    scale = jnp.where(trace > 0, trace / size, 1.0)
    eye = scale * jnp.eye(size, dtype=H.dtype)
    solve = lambda damping: -jax.scipy.linalg.cho_solve(
        jax.scipy.linalg.cho_factor(H + damping * eye), g
    )

    # The exact Hessian is indefinite away from a minimum, and a damping too small
    # to make it definite fails the factorization. Raise the damping tenfold until it
    # succeeds (a factorization is cheap) instead of evaluating the model at a
    # non-finite trial and rejecting it (measured: a third of all steps on glyphs).
    def undefined(carry):
        damping, delta = carry
        return ~jnp.all(jnp.isfinite(delta)) & (damping < 1e16)

    def raise_damping(carry):
        damping, _ = carry
        return 10 * damping, solve(10 * damping)

    return jax.lax.while_loop(undefined, raise_damping, (damping, solve(damping)))


def newton_solve(H: Float[Array, "D D"], g: Float[Array, " D"]):
    """`(H^{-1} g, definite)`: minus the Newton step of the local model (loss + 2 g d +
    d H d, `g` and `H` half the gradient and Hessian), by Cholesky, and whether `H`
    factored (positive definite; else the step is not finite)."""
    factor = jax.scipy.linalg.cho_factor(H)
    return jax.scipy.linalg.cho_solve(factor, g), jnp.all(jnp.isfinite(factor[0]))


def newton_decrement(H: Float[Array, "D D"], g: Float[Array, " D"]) -> Float[Array, ""]:
    """`g H^{-1} g`: the decrease of the loss that its local model predicts for the full
    Newton step `d = -H^{-1} g` (`newton_solve`); inf where `H` does not factor (not
    positive definite)."""
    step, definite = newton_solve(H, g)
    value = g @ step
    return jnp.where(definite & (value >= 0), value, jnp.inf)


def settled(result: optx.RESULTS, model, rtol, atol) -> optx.RESULTS:
    """The result of a solve by `FootPointLevenbergMarquardt`, with a stop for want of a
    step that lowers the loss (`nonlinear_divergence`) made a success where the full
    Newton step at the returned point would gain at most `rtol` of the loss plus `atol`
    (`newton_decrement`; `model`: the solution's `stats["model"]`, the loss and its half
    gradient and Hessian there): a minimum to the tolerance, which rounding keeps the
    steps from confirming (float32 fits: `benchmarks/results/float32_status.md`).

    After the solver's loop, not in it: a Cholesky in the loop's body (a `lax.cond`,
    which `vmap` turns into a select) made a jitted `vmap` of `fit` hang in XLA on its
    first call (n = 48, 8 outlines: `benchmarks/results/vmap_fit.md`).
    """
    loss, gradient, hessian = model
    within = jnp.isfinite(loss) & (newton_decrement(hessian, gradient) <= rtol * loss + atol)
    stopped = result == optx.RESULTS.nonlinear_divergence
    return optx.RESULTS.where(stopped & within, optx.RESULTS.successful, result)


class Verdict(eqx.Module):
    """What a step decides (`judge`)."""

    accept: Bool[Array, ""]
    damping: Float[Array, ""]
    growth: Float[Array, ""]
    small: Bool[Array, ""]
    checkpoint: Float[Array, ""]
    terminate: Bool[Array, ""]
    result: optx.RESULTS


#: Steps between the plateau checks (`judge`).
PLATEAU_STEPS = 50


def judge(state, delta, raised, loss, rtol, atol, max_steps) -> Verdict:
    """Accept or reject the step `delta` (taken at damping `raised`) that led to `loss`,
    update the damping, and decide whether to stop (see the module docstring). `state`:
    the solver's state before the step (its `loss`, `gradient`, `hessian`, `damping`,
    `growth`, `num_steps`, `small`). One fit; a batched solver maps it."""
    H, g = state.hessian, state.gradient
    first = state.num_steps == 0
    predicted = -(2 * g @ delta + delta @ (H @ delta))
    actual = state.loss - loss
    ratio = actual / jnp.where(predicted > 0, predicted, 1.0)
    finite = jnp.isfinite(loss) & jnp.all(jnp.isfinite(delta))
    accept = first | (finite & (predicted > 0) & (ratio > 1e-4))
    damping = jnp.where(
        first,
        state.damping,
        jnp.where(
            accept,
            raised * jnp.maximum(1 / 3, 1 - (2 * ratio - 1) ** 3),
            raised * state.growth,
        ),
    )
    growth = jnp.where(accept, 2.0, 2 * state.growth).astype(state.growth.dtype)
    # Converged when two accepted steps in a row lower the loss by at most rtol of it
    # (one small decrease may come from a heavily damped step, not a minimum).
    small = ~first & accept & (actual <= rtol * state.loss + atol)
    # A plateau: over the last PLATEAU_STEPS steps the loss fell by at most sqrt(rtol)
    # of itself. The loss is then flat for every purpose of its figures (the RMS moves
    # by under sqrt(rtol) / 2 of itself per PLATEAU_STEPS steps), although each step
    # still lowers it by more than rtol: a slow slide of the control points along a
    # nearly flat valley, where the Hessian is usually indefinite (newton_step inf).
    kept = jnp.where(accept, loss, state.loss)
    check = (state.num_steps + 1) % PLATEAU_STEPS == 0
    plateau = check & (state.checkpoint - kept <= jnp.sqrt(rtol) * state.checkpoint + atol)
    checkpoint = jnp.where(check | first, kept, state.checkpoint)
    done = (small & state.small) | (accept & (loss <= atol)) | plateau
    # The damping cannot grow without bound: past 1e16 of the matrix's scale the steps
    # vanish in rounding and no step lowers the loss. That is a minimum to working
    # precision if the gradient vanishes; otherwise the model and the loss disagree
    # (e.g. from a start far outside the data) and the fit has failed, or rounding
    # hides the last gain (`settled` tells that from the returned point).
    stuck = ~accept & (damping > 1e16)
    out_of_steps = state.num_steps + 1 >= max_steps
    # (A loss that overflowed to inf is no minimum: inf <= inf would say it is.)
    flat_gradient = (jnp.isfinite(state.loss)
                     & (jnp.max(jnp.abs(g)) <= 1e-6 * jnp.maximum(1.0, jnp.sqrt(state.loss))))
    result = optx.RESULTS.where(
        stuck & ~flat_gradient,
        optx.RESULTS.nonlinear_divergence,
        optx.RESULTS.where(
            ~(done | stuck) & out_of_steps,
            optx.RESULTS.nonlinear_max_steps_reached,
            optx.RESULTS.successful,
        ),
    )
    return Verdict(accept=accept, damping=jnp.minimum(damping, 1e20), growth=growth,
                   small=jnp.where(accept, small, state.small), checkpoint=checkpoint,
                   terminate=done | stuck | out_of_steps, result=result)
