"""What a fit returns: [`fitting.FitResult`][] and its status codes, [`fitting.FitStatus`][]."""

import warnings

import equinox as eqx
import numpy as np
import optimistix as optx
from jaxtyping import Array, Bool, Float, Int

import jaxsubdiv as js
from jaxsubdiv.validation import is_traced


# equinox warns when a subclass gives an inherited entry a new message; ours is meant.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", UserWarning)

    class FitStatus(optx.RESULTS):
        """Why a fit stopped: optimistix's results (`optimistix.RESULTS`, whose entries
        and numbers it keeps: `FitStatus.promote(solution.result)`), with our messages
        for `nonlinear_divergence` and `nonfinite_input`, and `invalid_input`,
        `tolerance_not_reached` and `poor_local_minimum` (after optimistix's entries).

        `FitResult.status` holds an entry's number, the index of its name in
        [`fitting.STATUSES`][]: 0 (`successful`) when the solver met its tolerance.
        """

        # The default solver's when no step lowers the loss (`_solver.judge`; among
        # optimistix's solvers only its root finders and Nelder-Mead use it). Its text
        # ("Nonlinear solve diverged.") reads as if the fit had run off; the float32
        # fits measured stopping so were at good fits, held up by rounding
        # (`benchmarks/results/float32_status.md`).
        nonlinear_divergence = (
            "no step lowered the loss further, although the solver's test says it is not "
            "at a minimum: the loss and its local model disagree (a start far from the "
            "data), or rounding hides the remaining decrease (in float32: fit in float64 "
            "with JAX's x64 mode on, or with a looser `tol`). The last iterate is "
            "returned; `newton_step` estimates how far it is from the optimum."
        )
        # Set by `fit_batch` for items it does not fit (lineax's own text for this entry
        # blames a bug upstream of a linear solver, which is not what happened).
        nonfinite_input = "the target has NaN or infinite values; it was not fitted."
        # Set by `fit_batch` for items that are not valid outlines for the settings.
        invalid_input = (
            "the target is not a valid outline for these settings (the warning says why); "
            "it was not fitted."
        )
        # Set by `fit_tolerance` when no control-point count it tried fitted within the
        # tolerance (the fit of smallest error is returned).
        tolerance_not_reached = (
            "no control-point count tried fitted within the tolerance. The fit of "
            "smallest error is returned; with on_failure='warn' a warning lists the counts "
            "tried and why the search stopped."
        )
        # Set by `fit` when the fit from a given `init` ends worse than the default
        # start before any step (`_core.poor_start`, `_core.flag_poor_start`).
        poor_local_minimum = (
            "the fit from the given `init` stopped at a local minimum worse than the start "
            "taken without `init` before any step (the linear fit at the samples' "
            "chord-length positions): a higher loss, or a two-sided RMS above 1.1 times "
            "its. A poor start; the last iterate is returned. Fit without `init`, or from "
            "a better one."
        )


#: The names of the [`fitting.FitStatus`][] entries, by number: `FitResult.status` is
#: the index of its entry here (0: `successful`).
STATUSES: tuple[str, ...] = tuple(
    sorted(FitStatus._name_to_item, key=lambda name: int(getattr(FitStatus, name)._value))
)


def status_code(result: optx.RESULTS) -> Int[Array, ""]:
    """The number of an optimistix result, or of a [`fitting.FitStatus`][] entry (traced
    or not): the index of its name in `STATUSES`."""
    if not isinstance(result, FitStatus):
        result = FitStatus.promote(result)
    # An enumeration entry's number is its `_value`; equinox has no public accessor.
    return result._value


def status_message(code: int) -> str:
    """`"converged"`, or `"<name>: <why>"` for the status number `code`."""
    if code == 0:
        return "converged"
    name = STATUSES[code]
    return f"{name}: {FitStatus[getattr(FitStatus, name)]}"


class FitResult(eqx.Module):
    """The result of [`fitting.fit`][] or [`fitting.fit_batch`][].

    All array fields carry a leading batch axis for `fit_batch`. Distances are in the
    target's units and *two-sided*: target to curve (each sample's distance to the limit
    curve at its global nearest point: to its Hermite model, within O(h^4) of it, for
    C^1 schemes, else to the chords between the exact samples in `curve`; RMS over the
    samples with non-zero weight) and curve to target (the curve's distance to the
    polyline through the ordered samples, RMS by arc length along the curve and
    maximum), so a curve that wanders away from the data between samples is caught.
    `rms` and `max_error` are the larger of the two directions. How each is computed
    and how exact it is: `docs/fitting.md`, "Reported errors". The curve-to-target half
    includes the chords' own sagitta: a curve through noise-free samples of a curved
    outline has `rms_target_to_curve` ~ 0 but `rms_curve_to_target` about
    h^2 kappa / 8 for sample spacing h and curvature kappa. All are differentiable (at
    their nearest points, held fixed).

    **Fields:**

    - `control_points`: the fitted control polygon, `(n, d)`.
    - `scheme`: the scheme with its fitted parameters (e.g. `result.scheme.w`).
    - `creases`: with `fit(corners=...)` and corners found, a boolean mask `(n,)` of the
      creased control points (the curve passes through each with a corner:
      `jaxsubdiv.refine(P, scheme, levels, creases=np.flatnonzero(result.creases))`),
      else None.
    - `curve`: the limit curve at the dyadic parameters of `levels` levels, `(N, d)`.
    - `rms`, `max_error`: two-sided RMS and maximum distance.
    - `rms_target_to_curve`, `max_target_to_curve`, `rms_curve_to_target`,
      `max_curve_to_target`: each direction.
    - `num_steps`: solver steps taken (including rejected trust-region steps).
    - `status`: an integer array, 0 on success, else the number of the
      [`fitting.FitStatus`][] entry (optimistix's result) that stopped the solver: its
      name is `fitting.STATUSES[status]`. `converged` and `message` are derived from it.
    - `params_held`: with `fit_params` (and a profile, the default solver): True where
      the fit with the parameters held at their start was returned instead of the
      joint fit, because its two-sided `rms` was lower (or the joint fit's was not a
      number): the start's parameter values (the scheme's as given, up to the rounding
      of the fit's bijection onto their range) with that fit's control points and
      errors. False where the fitted values are returned. None when no parameter is
      fitted, or with `profile=0` or an optimistix `solver` (no fit at the start to
      compare with).
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
    creases: Bool[Array, "*batch n"] | None = None
    params_held: Bool[Array, "*batch"] | None = None

    @property
    def converged(self) -> Array:
        """True where the solver met its tolerance."""
        return self.status == 0

    @property
    def message(self):
        """Why the solver stopped: a string, or a list of strings for a batch."""
        codes = np.asarray(self.status)
        if codes.ndim == 0:
            return status_message(int(codes))
        return [status_message(int(c)) for c in codes.ravel()]


def report(result: FitResult, on_failure: str, caller: str = "fit") -> None:
    """Raise or warn, on the host, for items that did not converge."""
    if on_failure == "ignore" or is_traced(result.status):
        return
    # Items not fitted as invalid input have had their own warning, with the reasons.
    invalid = np.asarray(result.status) == int(status_code(FitStatus.invalid_input))
    failed = np.nonzero(np.atleast_1d(~np.asarray(result.converged) & ~invalid))[0]
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
