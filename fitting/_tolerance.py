"""[`fitting.fit_tolerance`][]: the fewest control points that fit within a tolerance.

A host-side search over control-point counts, each a [`fitting.fit`][]. The counts come
from one ladder, four per octave (4, 5, 6, 7, 8, 10, 12, 14, 16, 20, ...), because every
count is a compiled program of its own: contours, files and later processes (with
`jaxsubdiv.enable_compilation_cache`) that search the same ladder reuse them.

How the next count is chosen: a curve approximated by a spline of n pieces has an error
that falls about like n^-p; p is measured from the last two fits that missed it, going
up (p = 2 before there are two, clamped to [0.5, 6]) and the count predicted to reach the tolerance is tried next,
at most 4x the last one (or half of it, going down). Once one count fits and a smaller
one does not, the counts between them on the ladder are bisected. Errors do not always
fall with n (a fit can stop in a poorer minimum at a larger n), so the result is the
smallest count *tried* that met the tolerance, not a certified minimum.
"""

import bisect
import math
import warnings
from collections.abc import Callable
from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

import jaxsubdiv as js
from jaxsubdiv.validation import check_boundary, is_traced, min_points, static_int

from ._checks import MemoryBudgetError, check_on_failure, float_array
from ._fit import fit
from ._params import fitted_names
from ._pixels import _traced_samples, pixel_error
from ._result import FitResult, FitStatus, status_code


#: Counts per octave of the ladder of control-point counts.
_PER_OCTAVE = 4
#: The first count tried (or the nearest in [n_min, n_max]).
_START = 16
#: An error falling more slowly than n^-_STALL from one count to the next tried has stalled.
_STALL = 0.5
#: After the error stalls, a count twice as large is tried once if the least error met
#: so far is within this factor of the tolerance (a plateau of local minima just above
#: it; the ones measured were 1.08x and 1.15x).
_RETRY_WITHIN = 1.5


def ladder_floor(n: int) -> int:
    """The largest ladder count <= n (n >= 4): 4, 5, 6, 7, 8, 10, 12, 14, 16, 20, ..."""
    octave = 2 ** (int(n).bit_length() - 3)  # n in [4 octave, 8 octave)
    return (n // octave) * octave


def ladder(low: int, high: int) -> list[int]:
    """The ladder's counts in [low, high] (low >= 4), increasing."""
    counts, n = [], ladder_floor(low)
    while n <= high:
        if n >= low:
            counts.append(n)
        octave = 2 ** (n.bit_length() - 3)
        n += octave
    return counts


def fit_tolerance(
    target: Float[ArrayLike, "m d"],
    scheme: js.AbstractCurveScheme,
    tolerance: float,
    *,
    error: Literal["max_error", "rms", "pixel"] = "max_error",
    n_min: int | None = None,
    n_max: int | None = None,
    max_fits: int = 8,
    on_trial: Callable[[int, FitResult], None] | None = None,
    on_failure: Literal["raise", "warn", "ignore"] = "warn",
    **options,
) -> FitResult:
    """Fit with the fewest control points whose error is within `tolerance`.

    Tries control-point counts from a fixed ladder (4, 5, 6, 7, 8, 10, 12, 14, 16, 20,
    24, ...: four per octave, so that the compiled programs are shared) with
    [`fitting.fit`][], predicting from the errors met so far (an error falling like
    n^-p, p measured) which count reaches the tolerance, then bisecting the ladder
    between the largest count that missed and the smallest that met it. Returns the fit
    of the smallest count tried that met the tolerance.

    When none does, up to `n_max` or within `max_fits` fits, or because the error stops
    falling as n grows (more slowly than n^-0.5 twice in a row: the samples' own
    resolution, noise, or the pixel staircase limit it; or fits stuck in local minima,
    so when the least error is within 1.5x of the tolerance, twice the largest count
    tried, at most `n_max`, is then tried once, and the search goes on from there),
    the fit of smallest error is
    returned with the status `tolerance_not_reached` (`converged` False, the reason and
    the error reached in the warning), as `on_failure` says. The figures stay those of
    that fit: `rms` and `max_error` are measured as in any fit (two-sided, in the
    target's units; `docs/fitting.md`, "Reported errors").

    Host-side (each count is its own compiled program, and the search needs the
    errors' values): not under `jax.jit`. Each new count compiles a program once per
    process (about 5 s on 2 cores; cached on disk with
    `jaxsubdiv.enable_compilation_cache()`). Each program holds about a thousand
    memory mappings, of the 65,530 Linux allows a process by default: many outlines of
    different sample counts in one process should share a `pad_to` (see
    `docs/fitting.md`, "The number of control points for a tolerance").

    **Arguments:**

    - `target`, `scheme`: as for [`fitting.fit`][].
    - `tolerance`: the largest acceptable error, in the target's units (pixels for
      traced images), > 0.
    - `error`: which figure must be within it: `"max_error"` (default; the two-sided
      maximum distance), `"rms"` (the two-sided RMS), or `"pixel"` for a contour traced
      from a bitmap (`jaxsubdiv.io.read_image`, in pixels, not resampled): the
      two-sided maximum error against its pixels, [`fitting.pixel_error`][], which does
      not charge the curve for the corners the traced contour cuts short. The
      result's own figures stay those against the samples.
    - `n_min`, `n_max`: the range of counts searched (default: the scheme's smallest
      valid count, at least 4; and a quarter of the samples, two samples per unknown in
      the plane, at least `n_min`; at most one sample per unknown). Both are among the
      counts searched even when they are not on the ladder. With `corners` given as
      indices, `n_min` is at least their number.
    - `max_fits`: the most fits tried (default 8).
    - `on_trial`: called with `(n, result)` after each fit, e.g. to report progress.
    - `on_failure`: `"raise"` (`RuntimeError`), `"warn"` (default) or `"ignore"` when the
      tolerance is not reached; a chosen fit whose solver did not converge (its status
      says so) is reported the same way.
    - every other keyword (`boundary`, `corners`, `fit_params`, `weights`, `levels`,
      `max_steps`, ...) is passed to each [`fitting.fit`][] (not `n_control` or `init`).

    **Returns:** a [`fitting.FitResult`][]; its count is `result.control_points.shape[0]`.
    """
    check_on_failure(on_failure)
    for name in ("n_control", "init"):
        if name in options:
            raise TypeError(f"`fit_tolerance` chooses `{name}` itself; do not pass it.")
    try:
        tolerance = float(tolerance)
    except (TypeError, ValueError):
        raise TypeError(f"`fit_tolerance(tolerance=...)` must be a number; got {tolerance!r}.")
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(
            f"`fit_tolerance(tolerance=...)` must be a finite number > 0 (in the target's "
            f"units); got {tolerance}."
        )
    if error not in ("max_error", "rms", "pixel"):
        raise ValueError("`fit_tolerance(error=...)` must be 'max_error', 'rms' or 'pixel'; "
                         f"got {error!r}.")
    max_fits = static_int(max_fits, "max_fits", minimum=1)
    target = float_array(target, "target")
    if is_traced(target):
        raise TypeError(
            "`fit_tolerance` runs on the host (it compares the errors of whole fits to "
            "choose the next count), so not under `jax.jit` or `jax.grad`; trace "
            "`fitting.fit` at the count it chose instead."
        )
    if not isinstance(scheme, js.AbstractCurveScheme):
        raise TypeError(
            "`fit_tolerance(scheme=...)` must be a jaxsubdiv curve scheme such as "
            f"`jaxsubdiv.CubicBSpline()`; got {type(scheme).__name__}."
        )
    if target.ndim != 2 or target.shape[1] < 2:
        raise ValueError(
            f"`fit_tolerance(target=...)` must have shape (m, d) with d >= 2 (samples of an "
            f"outline); got shape {target.shape}."
        )
    samples, d = target.shape
    if error == "pixel":
        # Checked before any fit: the samples must lie between pixel centres.
        traced = _traced_samples(target, "fit_tolerance(target=...)` with `error='pixel'")
        if options.get("boundary", "closed") != "closed":
            raise ValueError("`fit_tolerance(error='pixel')` measures closed traced contours; "
                             f"got boundary={options.get('boundary')!r}: leave the boundary "
                             "closed, or use error='max_error'.")
    smallest = max(4, min_points(scheme, check_boundary(options.get("boundary", "closed"),
                                                        scheme)))
    corners = options.get("corners")
    if corners is not None and not isinstance(corners, str):
        # Every corner given is a control point: no count below their number fits.
        given = np.unique(np.mod(np.asarray(corners, dtype=np.int64).ravel(), samples))
        smallest = max(smallest, given.size)
    n_min = smallest if n_min is None else static_int(n_min, "n_min", minimum=smallest)
    # At least as many samples as unknowns (fit's own limit), checked before any fit.
    largest = (samples - len(fitted_names(scheme, options.get("fit_params", False)))) // d
    if n_min > largest:
        raise ValueError(
            f"`fit_tolerance`: {samples} samples fit at most {largest} control points "
            f"(one sample per unknown), fewer than n_min={n_min}; give more samples."
        )
    if n_max is None:
        n_max = max(n_min, samples // (2 * d))  # two samples per unknown
    else:
        n_max = static_int(n_max, "n_max", minimum=n_min)
        if n_max > largest:
            raise ValueError(
                f"`fit_tolerance(n_max={n_max})`: {samples} samples fit at most {largest} "
                "control points (one sample per unknown); use a smaller n_max or more samples."
            )
    counts = ladder(n_min, n_max) or [n_min]
    if counts[-1] != n_max and n_max > counts[-1]:
        counts.append(n_max)  # the user's (or samples') limit is tried even off the ladder
    if counts[0] != n_min:
        counts.insert(0, n_min)

    tried: dict[int, FitResult | None] = {}
    errors: dict[int, float] = {}

    too_large = []  # the smallest count found above memory_budget, if any

    def attempt(i: int) -> None:
        n = counts[i]
        try:
            # Each fit's own non-convergence is judged once, for the one returned.
            result = fit(target, scheme, n, on_failure="ignore", **options)
        except MemoryBudgetError:
            if not tried:
                raise  # not even the first count fits in memory_budget: fit's own error
            if i < max(tried):  # (the default levels fall as n grows: not monotone)
                tried[i], errors[i] = None, math.inf
                return
            # Going up: search below this count, and say so if nothing there is within.
            too_large[:] = [n]
            del counts[i:]
            return
        if error != "pixel":
            value = float(getattr(result, error))
        elif np.all(np.isfinite(np.asarray(result.curve))):
            value = pixel_error(result, traced).max_error
        else:
            value = math.inf  # a failed fit (its own status says why): a miss
        tried[i], errors[i] = result, value if math.isfinite(value) else math.inf
        if on_trial is not None:
            on_trial(n, result)

    def ok(i):
        return errors[i] <= tolerance

    attempt(min(range(len(counts)), key=lambda k: abs(counts[k] - max(_START, n_min))))
    stalls, exponent, stopped = 0, 2.0, f"{max_fits} fits (max_fits) were tried"
    stalled = False
    while len(tried) < max_fits:
        met = [k for k in sorted(tried) if ok(k)]
        if met:
            below = [k for k in tried if k < met[0]]
            if met[0] == 0 or (below and max(below) == met[0] - 1):
                break  # the count below the smallest that met was tried, and missed
            if below:
                j = (max(below) + met[0]) // 2  # bisect the ladder between them
            else:  # predict down from the smallest that met, at most to half of it
                wanted = counts[met[0]] * (errors[met[0]] / tolerance) ** (1 / exponent)
                at_most = bisect.bisect_right(counts, max(wanted, counts[met[0]] / 2)) - 1
                j = min(met[0] - 1, max(0, at_most))
        else:
            k = max(tried)
            if k == len(counts) - 1:
                stopped = (f"the error stopped falling as n grew (more slowly than n^-{_STALL} "
                           f"twice in a row), and n_max={counts[-1]} did not fit either"
                           if stalled else f"no count up to n_max={counts[-1]} fitted")
                if too_large:
                    stopped = (f"no count up to n = {counts[-1]} fitted, and n = "
                               f"{too_large[0]} would need more than memory_budget (raise it, "
                               "or resample the outline)")
                break
            below = [q for q in tried if q < k]
            if below:
                q = max(below)
                if math.isfinite(errors[q]):
                    # The exponent of the fall from q to k (inf or NaN errors: none).
                    fall = (math.log(errors[q] / errors[k]) / math.log(counts[k] / counts[q])
                            if 0 < errors[k] < math.inf and errors[q] > 0 else -math.inf)
                    stalls = stalls + 1 if fall < _STALL else 0
                    if stalls >= 2:
                        # A plateau just above the tolerance can be the fits' local
                        # minima rather than a floor (STIXGeneral '&' at 1e-2 em: 1.09e-2
                        # at 40, 1.15e-2 at 48, 2.9e-3 at 56): twice the count, once,
                        # before giving up (not n_max, whose fit can cost minutes on a
                        # traced contour). Far above it, a floor (the pixel staircase at
                        # 0.6 px for 0.3 px asked): no retry, which would cost the
                        # largest fit yet for nothing.
                        retry = bisect.bisect_left(counts, 2 * counts[k])
                        near = min(errors.values()) <= _RETRY_WITHIN * tolerance
                        if not stalled and retry > k and near:
                            stalled = True
                            attempt(min(retry, len(counts) - 1))
                            continue
                        stopped = ("the error stopped falling as n grew (more slowly than "
                                   f"n^-{_STALL} twice in a row)"
                                   + (f", and n = {counts[k]} did not fit either"
                                      if stalled else ""))
                        break
                    if fall > 0:
                        exponent = float(np.clip(fall, _STALL, 6.0))
            grow = (errors[k] / tolerance) ** (1 / exponent) if math.isfinite(errors[k]) else 2
            at_least = bisect.bisect_left(counts, min(counts[k] * grow, 4 * counts[k]))
            j = max(k + 1, min(len(counts) - 1, at_least))
        attempt(j)

    met = [k for k in sorted(tried) if ok(k)]
    if met and met[0] > 0 and met[0] - 1 not in tried and on_failure == "warn":
        warnings.warn(
            f"fit_tolerance: n = {counts[met[0]]} is within the tolerance, but max_fits="
            f"{max_fits} ran out before n = {counts[met[0] - 1]} was tried: a smaller count "
            "may be within it too.", RuntimeWarning, stacklevel=2)
    best = met[0] if met else min((k for k in tried if tried[k] is not None),
                                  key=lambda k: (errors[k], counts[k]))
    result = tried[best]
    if not met:
        label = "pixel error" if error == "pixel" else error
        text = (
            f"fit_tolerance: {stopped}; none fitted within the tolerance {tolerance:.3g} "
            f"({label}); the smallest {label} was {errors[best]:.3g}, at n = {counts[best]} "
            "(tried "
            + ", ".join(f"{counts[k]}: {errors[k]:.2g}" for k in sorted(tried))
            + "); that fit is returned with the status tolerance_not_reached."
        )
        result = _with_status(result, FitStatus.tolerance_not_reached)
        if on_failure == "raise":
            raise RuntimeError(text)
        if on_failure == "warn":
            warnings.warn(text, RuntimeWarning, stacklevel=2)
    elif not bool(result.converged) and on_failure != "ignore":
        text = (f"fit_tolerance: the fit at n = {counts[best]} is within the tolerance but its "
                f"solver did not converge ({result.message}).")
        if on_failure == "raise":
            raise RuntimeError(text)
        warnings.warn(text, RuntimeWarning, stacklevel=2)
    return result


def _with_status(result: FitResult, status) -> FitResult:
    code = jnp.asarray(status_code(status), result.status.dtype)
    return eqx.tree_at(lambda r: r.status, result, code)
