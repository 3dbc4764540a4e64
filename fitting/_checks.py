"""Host-side checks of the arguments of `fit` and `fit_batch`, before anything is traced.

Shapes and static settings are checked here, with errors that name the argument and
the fix; concrete values are checked too (finite samples, non-negative weights, an
outline that looks closed), while traced ones are left to the fit. Also here: what the
compiled program is sized for (`bucket`, `default_levels`), the padding of the samples
to it, and the memory estimate that refuses oversized fits before allocating anything.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np

import jaxsubdiv as js
from jaxsubdiv.validation import (
    DEFAULT_MEMORY_BUDGET,
    MemoryBudgetError,
    as_float_array,
    check_boundary,
    checked_budget,
    is_traced,
    min_points,
    static_int,
)

from ._curve import BLOCK_PAIRS, curve_samples
from ._init import order_samples
from ._objective import REFINE_MAX
from ._params import fitted_names, to_unconstrained, uses_tangents


def default_tol(dtype) -> float:
    """`tol`'s default for samples of `dtype`."""
    return 1e-7 if dtype == jnp.float64 else 1e-5


def check_tol(tol, caller: str):
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


def pad(target, weights, size: int):
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


def looks_open(target: np.ndarray) -> tuple[bool, float, float]:
    # In units of the largest coordinate, so that no square overflows or underflows.
    unit = float(np.max(np.abs(target))) or 1.0
    target = target / unit
    gaps = np.linalg.norm(np.diff(target, axis=0), axis=-1)
    closing = float(np.linalg.norm(target[0] - target[-1]))
    typical = float(max(4 * np.median(gaps), 1.5 * gaps.max()))
    return closing > typical, closing * unit, float(np.median(gaps)) * unit


def float_array(value, name: str):
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
    holds: 10 N n numbers for N curve samples and n control points (about 10 copies of
    the dense curve basis, which the fit held until 2026-12-07 and now reads from its
    stencil tables: kept as margin), 3 blocks of the
    foot-point searches' points-by-anchors distances (at most `_curve.BLOCK_PAIRS`
    entries each: they run in blocks of samples) and the reported maximum's
    refinement (`_curve.all_distances`: up to 8 numbers for each of at most
    `BLOCK_PAIRS` pairs), and 1,200 numbers per sample;
    with `ordered=False` also the m x m arrays of `order_samples` (measured: 0.63 GB
    at m = 5,000, about 3 float64 copies; 4 are counted). Linear in `m` at fixed
    `levels`, and at the default `levels` too (which grow with log m).

    Measured (`benchmarks/bench_fit_memory.py`, cubic B-spline, n = 32, default
    levels; the peak less that of a fit of 400 samples): 54, 43 and 115 MB at 4,000,
    16,000 and 32,000 samples on 2026-12-01 (`results/fit_memory_027fd27.md`); on
    2026-12-07 208, 415 and 513 MB with
    the code of that morning (a15acd1, `results/fit_memory_a15acd1.md`), above the
    estimate of then (400 numbers per sample: 152, 304 and 508 MB), and 159, 331 and
    432 MB with the stencil tables (`results/fit_memory.md`), so 1,200 numbers per
    sample since (178, 409 and 717 MB).
    """
    N = curve_samples(scheme, n, levels, boundary)
    anchors = N // max(1, min(8, N // 64))
    itemsize = np.dtype(dtype).itemsize
    m = bucket(m)
    # The maximum's refinement (`_curve.all_distances`): its points by m chords,
    # at most BLOCK_PAIRS pairs at once, 2d + 2 numbers a pair (8 covers d <= 3).
    refine = 8 * min(REFINE_MAX * m, BLOCK_PAIRS)
    searches = 3 * min(m * anchors, BLOCK_PAIRS) + refine
    ordering = 0 if ordered else 4 * 8 * m * m  # order_samples works in float64
    return itemsize * (10 * N * n + searches + 1200 * m) + ordering


def check_memory(caller, m, pad_to, n, levels, scheme, boundary, dtype, memory_budget,
                 ordered):
    """Refuse, before anything is allocated, a fit estimated (`fit_memory`) to need
    more than `memory_budget` bytes."""
    budget = checked_budget(memory_budget, f"{caller}(memory_budget=...)")
    need = fit_memory(max(m, pad_to), n, levels, scheme, boundary, dtype, ordered)
    if need > budget:
        raise MemoryBudgetError(
            f"`{caller}` of {max(m, pad_to)} samples with {n} control points at levels="
            f"{levels} would need about {need / 1024**3:.3g} GiB, above memory_budget="
            f"{int(budget):,} bytes. Use fewer samples (resample the outline: a few hundred "
            "to a few thousand are plenty) or fewer levels, or raise `memory_budget`.",
            need=need, budget=budget,
        )


#: The default profile (`_core.profile_start`): values per fitted parameter, by how many
#: parameters are fitted (9 fits for w or t, 26 for r and s, each with the start).
DEFAULT_PROFILE = {1: 8, 2: 5}

#: The most fits a profile may hold: they run one after another (`jax.lax.map`, so one
#: fit's memory at a time), and this bounds the time they take.
PROFILE_LIMIT = 64


def profile_values(profile, names: tuple[str, ...], caller: str = "fit") -> int:
    """Resolve `fit(profile=...)`: values per fitted parameter (0 when none is fitted)."""
    if profile is None:
        return DEFAULT_PROFILE.get(len(names), 0)
    values = static_int(profile, "profile", minimum=0)
    if names and values ** len(names) > PROFILE_LIMIT:
        raise ValueError(
            f"`{caller}(profile={values})` with {len(names)} fitted parameters would hold "
            f"{values ** len(names)} fits at once; the most is {PROFILE_LIMIT} (profile="
            f"{int(PROFILE_LIMIT ** (1 / len(names)))} for {len(names)} parameters)."
        )
    return values if names else 0


def prepare(target, scheme, n_control, *, levels, boundary, fit_params, weights, ordered,
            smoothing, caller="fit", pad_to=0, memory_budget=DEFAULT_MEMORY_BUDGET,
            profile=None, pin_ends=False):
    """Validate the arguments of `fit` (and each item of `fit_batch`); return the
    checked target, weights, static settings, names and profile values
    (`profile_values`)."""
    target = float_array(target, "target")
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
    boundary = check_boundary(boundary, scheme)
    n = static_int(n_control, "n_control", minimum=1)
    need = min_points(scheme, boundary)
    if n < need:
        raise ValueError(
            f"`n_control={n}` is too small: {type(scheme).__name__} with "
            f"boundary={boundary!r} needs at least {need} control points."
        )
    check_pin_ends(pin_ends, boundary, caller)
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
        hermite = uses_tangents(scheme, names, boundary)
        levels = default_levels(n, bucket(max(m, pad_to)), hermite)
    else:
        levels = static_int(levels, "levels", minimum=1, maximum=40,
                            why=": the curve would have n x 2^levels samples")
    profile = profile_values(profile, names, caller)
    check_memory(caller, m, pad_to, n, levels, scheme, boundary, target.dtype, memory_budget,
                 ordered)
    if weights is None:
        weights = np.ones((m,), target.dtype)
    else:
        weights = float_array(weights, "weights").astype(target.dtype)
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
            is_open, closing, typical = looks_open(values)
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
        # Relative weights, divided on the host: inside the compiled program the CPU
        # flushes subnormal numbers to zero, and weights of 1e-320 were all zero there.
        weights = values / values.max()
    if np.ndim(smoothing) != 0:
        raise ValueError(
            f"`{caller}(smoothing=...)` must be a scalar; got shape {np.shape(smoothing)}."
        )
    if not is_traced(smoothing) and not (math.isfinite(float(smoothing)) and float(smoothing) >= 0):
        raise ValueError(f"`{caller}(smoothing=...)` must be finite and >= 0, got {smoothing}.")
    return target, weights, n, levels, names, profile




def check_on_failure(on_failure) -> str:
    """`on_failure` checked: what to do with fits that did not converge."""
    if on_failure not in ("raise", "warn", "ignore"):
        raise ValueError(f"`on_failure` must be 'raise', 'warn' or 'ignore'; got {on_failure!r}.")
    return on_failure


def check_pin_ends(pin_ends, boundary: str, caller: str = "fit") -> bool:
    """`pin_ends` checked: a bool, and only for curves with ends."""
    if not isinstance(pin_ends, (bool, np.bool_)):
        raise TypeError(f"`{caller}(pin_ends=...)` must be True or False; got {pin_ends!r}.")
    if pin_ends and boundary == "closed":
        raise ValueError(
            f"`{caller}(pin_ends=True)` needs a curve with ends: pass boundary='open' or "
            "boundary='clamped' (a closed curve has no first or last point)."
        )
    return bool(pin_ends)


#: The most phases a fit tries (`check_phases`): each is a fit of its own.
MAX_PHASES = 64


def check_phases(phases, *, boundary: str, fit_params: bool, init: bool, solver: bool,
                 who: str = "fit") -> int | None:
    """`fit(phases=...)`: None (the default, `fitting.PHASES`) or an int from 1 to
    `MAX_PHASES` (static: each count is a program of its own). More than one is for
    what `_core.phase_solve` fits: a closed curve from the linear start, with the
    default solver and no fitted parameters (`fit_params`, `init` and `solver`: whether
    those are given); otherwise a `ValueError` that says so. (With corners the phases are
    not searched: the corners place the spans; `make_objective`.)"""
    if phases is None:
        return None
    phases = static_int(phases, "phases", minimum=1, maximum=MAX_PHASES,
                        why=" (each phase is a fit of its own)")
    if phases > 1:
        conflict = ("an open curve (its ends fix the phase)" if boundary != "closed" else
                    "fit_params (its profile starts from one phase)" if fit_params else
                    "an `init` (the start is given)" if init else
                    "another `solver` (the phases run the default one)" if solver else None)
        if conflict is not None:
            raise ValueError(f"`{who}(phases={phases})` searches the start of a closed "
                             f"curve's fit, which does not apply to {conflict}; leave "
                             "`phases` out.")
    return phases
