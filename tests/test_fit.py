"""`fitting.fit` and `fitting.fit_batch` against independent references."""

import dataclasses
import json
import logging
import os
import re
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest
import scipy.interpolate
from helpers import (
    CompileCounter,
    glyph_outline,
    polyline_distances,
    resample_closed,
    splprep_curve,
    superellipse,
    two_sided_rms,
)

import fitting
import jaxsubdiv as js
from fitting import _curve


def blob(m, seed=0, closed=True):
    rng = np.random.default_rng(seed)
    theta = np.sort(rng.uniform(0, 2 * np.pi if closed else 2.5, m))
    radius = 1 + 0.2 * np.sin(3 * theta + rng.uniform(0, 6)) + 0.1 * np.cos(5 * theta)
    return np.stack([radius * np.cos(theta), radius * np.sin(theta)], -1)


def exact_curve(control, scheme, levels=11):
    """The limit curve at 2^levels points per control point (independent of the fit's
    own polyline: far finer, and built with refine + limit_points directly)."""
    return np.asarray(js.limit_points(js.refine(control, scheme, levels), scheme))


# --------------------------------------------------------------------------------------
# Recovery of control points and scheme parameters


TRUE_CONTROL = np.array(
    [[2.0, 0.0], [1.4, 1.1], [0.0, 1.3], [-1.2, 0.9], [-2.1, 0.1], [-1.3, -1.0],
     [0.1, -0.7], [1.5, -1.2]]
)

recovery_cases = [
    ("four_point", js.FourPoint(0.09), js.FourPoint(1 / 16), "w"),
    ("split_tweak", js.SplitTweak(0.3), js.SplitTweak(0.5), "t"),
    ("corner_cutting", js.CornerCutting(0.2, 0.7), js.CornerCutting(0.25, 0.75), ("r", "s")),
    # Issue #14: true values across the range, near its ends, each started at the far
    # end (the profile's grid, not the start, finds the basin).
    ("four_point_far", js.FourPoint(0.17), js.FourPoint(0.01), "w"),
    ("four_point_low", js.FourPoint(0.02), js.FourPoint(0.18), "w"),
    ("split_tweak_far", js.SplitTweak(0.9), js.SplitTweak(0.03), "t"),
    ("split_tweak_low", js.SplitTweak(0.05), js.SplitTweak(0.97), "t"),
    ("corner_cutting_far", js.CornerCutting(0.1, 0.4), js.CornerCutting(0.45, 0.95),
     ("r", "s")),
    ("corner_cutting_high", js.CornerCutting(0.6, 0.9), js.CornerCutting(0.05, 0.55),
     ("r", "s")),
]


#: Cases whose fitted curve stays 4e-6 to 3e-5 of the size from the true one, from every
#: start including the truth itself (its polygon and parameters): a bias of the loss, not
#: a local minimum. The curve-to-samples half measures the curve's distance to the chords
#: between the 300 samples beyond a band of a few sagittas (`_curve.chord_band`), and
#: these curves of low regularity (w near either end, r and s far from 1/4, 3/4) bend
#: beyond it between samples. Measured with the parameters held at the truth, from the
#: true polygon: 4e-6 to 3.2e-5 with 300 samples; with 1200, 3e-7 (four-point), 1e-16
#: (r, s = 0.1, 0.4), but still 3.7e-6 for (0.6, 0.9).
BIASED_AT_300_SAMPLES = {"four_point_far", "four_point_low", "corner_cutting_far",
                         "corner_cutting_high"}

_recovered = {}


def _curve_distance(control, scheme, dense):
    """Largest distance between the curve of (`control`, `scheme`) and `dense`, both at
    the same 2^11 parameters per control point, at the best cyclic relabelling of
    `control` (a closed curve's polygon is defined up to one, and the fit picks its
    phase from the samples: issue #14). It bounds the distance between the curves (a
    polyline comparison would measure its own chords: 5e-6 of the size for these
    four-point curves)."""
    return min(
        np.sqrt(np.sum((exact_curve(np.roll(control, k, axis=0), scheme) - dense) ** 2,
                       -1)).max()
        for k in range(len(control))
    )


def _recover(name, m=300, levels=11):
    """The fit of case `name` of `recovery_cases` from its start, and the joint fit
    started at the truth (true polygon and parameters, no profile), with their curves'
    distances to the true curve in units of its size. Cached: two tests inspect each."""
    if name in _recovered:
        return _recovered[name]
    _, truth, start, _ = next(case for case in recovery_cases if case[0] == name)
    dense = exact_curve(TRUE_CONTROL, truth)
    size = np.linalg.norm(np.ptp(dense, axis=0))
    # Samples at arc-length positions that are not refined points (offset 0.37).
    samples = resample_closed(dense, m, offset=0.37)
    settings = dict(fit_params=True, levels=levels, tol=1e-12, max_steps=500,
                    on_failure="raise")
    result = fitting.fit(samples, start, 8, **settings)
    from_truth = fitting.fit(samples, truth, 8, init=TRUE_CONTROL, profile=0, **settings)
    error = _curve_distance(result.control_points, result.scheme, dense) / size
    truth_error = _curve_distance(from_truth.control_points, from_truth.scheme, dense) / size
    between = _curve_distance(result.control_points, result.scheme,
                              exact_curve(from_truth.control_points, from_truth.scheme)) / size
    _recovered[name] = result, error, truth_error, between
    return _recovered[name]


@pytest.mark.parametrize(
    "name,truth,start,params", recovery_cases, ids=[c[0] for c in recovery_cases]
)
def test_recovers_parameters_from_any_start(name, truth, start, params):
    """Issue #14: from the far end of the parameter range, the true parameters to 1e-3,
    and the same optimum (curves within 1e-6 of the size) as the fit started at the
    truth: no local minimum. Measured: 1e-12 to 6e-10 between the two curves."""
    result, _, _, between = _recover(name)
    # The fitted values, not the start's (`params_held` says which was returned).
    assert not bool(result.params_held)
    for p in (params,) if isinstance(params, str) else params:
        assert abs(float(getattr(result.scheme, p)) - float(getattr(truth, p))) < 1e-3, p
    assert between < 1e-6


@pytest.mark.parametrize(
    "name",
    [pytest.param(c[0], marks=pytest.mark.xfail(
        strict=True, reason="the curve-to-samples half's chord band biases the fit of "
        "this low-regularity curve (BIASED_AT_300_SAMPLES)"))
     if c[0] in BIASED_AT_300_SAMPLES else c[0] for c in recovery_cases],
)
def test_recovers_the_curve_to_1e_6(name):
    """Issue 4: the curve to 1e-6 of its size, noise-free. Measured: 2e-8 (four-point
    0.09), 1.2e-7 (split-and-tweak 0.3), 8e-12 (corner cutting 0.2, 0.7, whose chord
    model needs the 11 levels; at 9 levels its chords limit it to 2.6e-6); the biased
    cases 6e-6 to 3.2e-5, the same as from the truth (so strict: they must fail until
    the bias is fixed, when they should be unmarked)."""
    _, error, truth_error, _ = _recover(name)
    assert error < 1e-6, (error, truth_error)


# --------------------------------------------------------------------------------------
# Real outlines against scipy's splprep


outlines = {
    "S": lambda: glyph_outline("S"),
    "a": lambda: glyph_outline("a"),
    "superellipse": lambda: superellipse(),
}


@pytest.mark.parametrize("n", [16, 32, 64])
@pytest.mark.parametrize("shape", sorted(outlines))
def test_beats_splprep_on_real_outlines(shape, n):
    samples = outlines[shape]()
    result = fitting.fit(samples, js.CubicBSpline(), n, on_failure="ignore")
    ours = two_sided_rms(exact_curve(result.control_points, js.CubicBSpline(), 7), samples)
    scipy_rms = two_sided_rms(splprep_curve(samples, n), samples)
    assert ours < scipy_rms, (ours, scipy_rms)
    # The reported error is what an independent measurement finds.
    np.testing.assert_allclose(float(result.rms), ours, rtol=0.05)


# --------------------------------------------------------------------------------------
# Open curves, ordering, dtypes


@pytest.mark.parametrize("boundary", ["open", "clamped"])
def test_open_curves(boundary):
    samples = blob(200, seed=3, closed=False)
    result = fitting.fit(samples, js.CubicBSpline(), 12, boundary=boundary)
    assert bool(result.converged)
    size = np.linalg.norm(np.ptp(samples, axis=0))
    assert float(result.rms) < 1e-2 * size
    # The reported distance is what a brute-force measurement against a 32x finer
    # polyline of the limit curve finds. Clamped ends have exact tangents now
    # (reflected ghost points), so both fits use the Hermite curve model.
    from fitting._params import uses_tangents

    assert uses_tangents(js.CubicBSpline(), (), boundary)
    fine = js.refine(result.control_points, js.CubicBSpline(), result.levels + 5, boundary=boundary)
    dense = np.asarray(js.limit_points(fine, js.CubicBSpline(), boundary=boundary))
    t2c = polyline_distances(samples, dense, closed=False)
    np.testing.assert_allclose(float(result.rms_target_to_curve), np.sqrt(np.mean(t2c**2)), rtol=1e-3)
    if boundary == "clamped":
        np.testing.assert_allclose(result.curve[0], result.control_points[0], atol=1e-12)


@pytest.mark.parametrize("scheme", [js.CubicBSpline(), js.Chaikin(), js.FourPoint(1 / 16)],
                         ids=["bspline", "chaikin", "four_point"])
def test_open_curve_ends_at_the_end_samples(scheme):
    # A straight line is exactly representable: the open curve must run from the first
    # sample to the last (an off-by-the-stencil sample count once put its end 8e-4 of the
    # size past the last sample).
    t = np.linspace(0, 1, 80)
    line = np.stack([t, 2 * t], -1)
    result = fitting.fit(line, scheme, 12, boundary="open")
    size = np.linalg.norm(np.ptp(line, axis=0))
    np.testing.assert_allclose(result.curve[0], line[0], atol=1e-7 * size)
    np.testing.assert_allclose(result.curve[-1], line[-1], atol=1e-7 * size)
    assert float(result.max_error) < 1e-7 * size


def test_order_samples_recovers_the_order():
    samples = superellipse(150)
    shuffle = np.random.default_rng(0).permutation(150)
    order = fitting.order_samples(samples[shuffle])
    recovered = shuffle[order]
    # A rotation of 0..149, in either direction.
    steps = np.diff(np.r_[recovered, recovered[:1]]) % 150
    assert np.all(steps == 1) or np.all(steps == 149)


def test_unordered_samples_are_fitted():
    samples = blob(150, seed=1)
    shuffled = samples[np.random.default_rng(2).permutation(150)]
    ordered = fitting.fit(samples, js.CubicBSpline(), 12)
    unordered = fitting.fit(shuffled, js.CubicBSpline(), 12, ordered=False)
    # Same data, another start (sample and direction): an equally good fit.
    assert bool(unordered.converged)
    assert float(unordered.rms) < 1.5 * float(ordered.rms)
    assert polyline_distances(samples, np.asarray(unordered.curve)).max() < 0.05


def test_float32():
    samples = blob(200, seed=4).astype(np.float32)
    result = fitting.fit(jnp.asarray(samples), js.CubicBSpline(), 12)
    assert result.control_points.dtype == jnp.float32
    assert bool(result.converged)
    reference = fitting.fit(samples.astype(np.float64), js.CubicBSpline(), 12)
    np.testing.assert_allclose(float(result.rms), float(reference.rms), rtol=1e-2)


def test_weights_and_smoothing():
    samples = blob(200, seed=5)
    plain = fitting.fit(samples, js.CubicBSpline(), 16)
    smooth = fitting.fit(samples, js.CubicBSpline(), 16, smoothing=1.0)
    second = lambda P: np.sum(np.diff(np.vstack([P, P[:2]]), 2, axis=0) ** 2)
    assert second(np.asarray(smooth.control_points)) < second(np.asarray(plain.control_points))
    # Zero weight on every other sample: those samples no longer count in the error.
    w = np.tile([1.0, 0.0], 100)
    weighted = fitting.fit(samples, js.CubicBSpline(), 16, weights=w)
    dense = exact_curve(weighted.control_points, js.CubicBSpline(), 9)
    d = polyline_distances(samples[::2], dense)
    np.testing.assert_allclose(float(weighted.rms_target_to_curve), np.sqrt(np.mean(d**2)), rtol=1e-4)


# --------------------------------------------------------------------------------------
# Non-convergence


def test_non_convergence_is_reported_and_last_iterate_returned():
    samples = superellipse(300)
    kw = dict(max_steps=2)
    with pytest.warns(RuntimeWarning, match="did not converge"):
        result = fitting.fit(samples, js.CubicBSpline(), 16, **kw)
    assert not bool(result.converged)
    assert "nonlinear_max_steps_reached" in result.message
    assert int(result.num_steps) == 2
    assert np.all(np.isfinite(np.asarray(result.control_points)))
    with pytest.raises(RuntimeError, match="did not converge"):
        fitting.fit(samples, js.CubicBSpline(), 16, on_failure="raise", **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fitting.fit(samples, js.CubicBSpline(), 16, on_failure="ignore", **kw)


def test_newton_step_estimates_the_distance_to_the_optimum():
    samples = glyph_outline("a")
    size = np.ptp(samples, axis=0).max()
    optimum = fitting.fit(samples, js.CubicBSpline(), 16, tol=1e-13, max_steps=3000,
                          on_failure="ignore").control_points
    floor = 1e-7 * size  # the reference's own accuracy (its newton_step: 2e-8)
    for tol in (1e-5, 1e-7):
        result = fitting.fit(samples, js.CubicBSpline(), 16, tol=tol)
        remaining = np.abs(np.asarray(result.control_points - optimum)).max()
        if tol == 1e-5:
            assert remaining > floor  # a loose fit: measurably short of the optimum
        if remaining > floor:
            assert remaining / 3 < float(result.newton_step) < 3 * remaining
        else:  # converged to the floor (measured: 2.8e-8 at 1e-7): the estimate says so
            assert float(result.newton_step) < 3 * floor
    # Where the Hessian is not positive definite the estimate is inf (a loose fit of 'S'
    # at n = 32 once stopped at such a point; which fits do depends on their start):
    # checked on a given model, against the closed form H^-1 g.
    from fitting._core import newton_step

    y = {"control": jnp.zeros((1, 2)), "params": {}}
    gradient = jnp.array([1.0, 2.0])
    definite = (0.0, gradient, jnp.diag(jnp.array([2.0, 4.0])))
    indefinite = (0.0, gradient, jnp.diag(jnp.array([2.0, -4.0])))
    assert float(newton_step(None, y, None, model=definite)) == 0.5
    assert float(newton_step(None, y, None, model=indefinite)) == np.inf


# --------------------------------------------------------------------------------------
# Batches


def test_batch_equals_loop_and_nan_item_fails_alone():
    targets = np.stack([blob(120, seed=s) for s in range(4)])
    targets[2, 7] = np.nan
    with pytest.warns(RuntimeWarning, match="1 of 4"):
        batch = fitting.fit_batch(targets, js.CubicBSpline(), 10, max_steps=400)
    assert batch.control_points.shape == (4, 10, 2)
    assert list(np.asarray(batch.converged)) == [True, True, False, True]
    assert batch.message[2].startswith("nonfinite_input") and "NaN or infinite" in batch.message[2]
    assert np.all(np.isnan(np.asarray(batch.control_points[2])))
    assert np.isnan(float(batch.rms[2])) and np.isnan(float(batch.newton_step[2]))
    for i in (0, 1, 3):
        single = fitting.fit(targets[i], js.CubicBSpline(), 10, max_steps=400)
        np.testing.assert_allclose(batch.control_points[i], single.control_points, atol=1e-8)
        np.testing.assert_allclose(batch.rms[i], single.rms, rtol=1e-6)


def test_fits_run_with_one_blas_thread_and_leave_the_users_setting(monkeypatch):
    """`fit` and `fit_batch` run their programs under a limit of one BLAS thread
    (`fitting._threads`: scipy's OpenBLAS threads, spinning after each small
    factorisation, took cores from XLA's), once per call, as the BLAS libraries
    themselves report it (threadpoolctl reads their own thread counts); afterwards every
    library has its thread count of before."""
    import contextlib

    from threadpoolctl import threadpool_info

    from fitting import _batch, _core, _threads

    counts = lambda: sorted((i["filepath"], i["num_threads"]) for i in threadpool_info()
                            if i["user_api"] == "blas")
    real, seen = _threads.one_blas_thread, []

    @contextlib.contextmanager
    def spy():
        with real():
            seen.append({n for _, n in counts()})
            yield

    fitting.fit(blob(120, seed=1), js.CubicBSpline(), 10)  # the BLAS libraries loaded
    before = counts()
    assert before, "no BLAS library found: the limit would do nothing"
    monkeypatch.setattr(_core, "one_blas_thread", spy)
    monkeypatch.setattr(_batch, "one_blas_thread", spy)
    fitting.fit(blob(120, seed=1), js.CubicBSpline(), 10)
    fitting.fit_batch(np.stack([blob(120, seed=s) for s in range(2)]), js.CubicBSpline(), 10)
    assert seen == [{1}, {1}]
    assert counts() == before


INVALID_ITEMS = [
    ("one_dimensional", np.linspace(0.0, 1.0, 50), "must have shape (m, d)"),
    ("one_column", np.linspace(0.0, 1.0, 50)[:, None], "must have shape (m, d)"),
    ("all_equal", np.ones((80, 2)), "all samples are the same point"),
    ("too_few", blob(120, seed=9)[:5], "give at least as many samples as unknowns"),
    ("open_looking", blob(120, seed=9)[:70], "looks like an open curve"),
]  # fmt: skip


@pytest.mark.parametrize("bad, words", [c[1:] for c in INVALID_ITEMS], ids=[c[0] for c in INVALID_ITEMS])
def test_invalid_batch_item_fails_alone(bad, words):
    """#16: an item that is not a valid outline gets the status invalid_input and NaN
    numbers, with one warning that says why; the other items are what `fit` gives them
    alone. With on_failure="raise" it is the ValueError, before anything is fitted."""
    good = [blob(120, seed=s) for s in (1, 2)]
    with pytest.warns(RuntimeWarning, match=r"1 of 3 items are not valid .* item 1: .*" + re.escape(words)):
        batch = fitting.fit_batch([good[0], bad, good[1]], js.CubicBSpline(), 8, max_steps=400)
    assert list(np.asarray(batch.converged)) == [True, False, True]
    assert batch.message[1].startswith("invalid_input") and int(batch.num_steps[1]) == 0
    assert np.all(np.isnan(np.asarray(batch.control_points[1]))) and np.isnan(float(batch.rms[1]))
    for i, target in zip((0, 2), good):
        single = fitting.fit(target, js.CubicBSpline(), 8, max_steps=400)
        np.testing.assert_allclose(batch.control_points[i], single.control_points, atol=1e-8)
        assert int(batch.num_steps[i]) == int(single.num_steps)
    with pytest.raises(ValueError, match=re.escape(words)):
        fitting.fit_batch([good[0], bad, good[1]], js.CubicBSpline(), 8, on_failure="raise")


def test_unordered_batch_equals_single_fits():
    """#16: items of an `ordered=False` batch (samples shuffled) are what `fit` gives
    each alone (an earlier batch item ended unconverged, 1.56 away from its single fit)."""
    rng = np.random.default_rng(0)
    targets = [t[rng.permutation(len(t))] for t in (blob(120, seed=s) for s in range(3))]
    batch = fitting.fit_batch(targets, js.CubicBSpline(), 8, ordered=False, max_steps=400)
    for i, target in enumerate(targets):
        single = fitting.fit(target, js.CubicBSpline(), 8, ordered=False, max_steps=400)
        assert bool(batch.converged[i]) and bool(single.converged)
        np.testing.assert_allclose(batch.control_points[i], single.control_points, atol=1e-8)


def test_ragged_batch_equals_single_fits():
    # Converged tightly: the padded and unpadded programs round differently, and at the
    # default tol their iterations may stop at different points of a flat valley.
    targets = [blob(90, seed=7), blob(130, seed=8)]
    batch = fitting.fit_batch(targets, js.FourPoint(0.07), 10, levels=6, max_steps=400, tol=1e-10)
    for i, t in enumerate(targets):
        single = fitting.fit(t, js.FourPoint(0.07), 10, levels=6, max_steps=400, tol=1e-10)
        np.testing.assert_allclose(batch.rms[i], single.rms, rtol=1e-6)
        np.testing.assert_allclose(batch.control_points[i], single.control_points, atol=1e-7)


def test_threaded_batch_equals_one_thread():
    """Shares fitted concurrently from several threads give the same numbers as one
    share (an uneven split: 7 items over 3 threads, padded)."""
    targets = np.stack([blob(100, seed=s) for s in range(7)])
    one = fitting.fit_batch(targets, js.CubicBSpline(), 8, threads=1)
    three = fitting.fit_batch(targets, js.CubicBSpline(), 8, threads=3)
    assert three.control_points.shape == (7, 8, 2)
    np.testing.assert_array_equal(np.asarray(three.control_points), np.asarray(one.control_points))
    np.testing.assert_array_equal(np.asarray(three.num_steps), np.asarray(one.num_steps))
    with pytest.raises(ValueError, match="threads"):
        fitting.fit_batch(targets, js.CubicBSpline(), 8, threads=0)


def test_batch_under_jit_and_grad():
    """Inside a trace the batch is one program (no threads): jit gives the eager numbers,
    and the gradient of a batch's total error is finite."""
    targets = np.stack([blob(80, seed=s) for s in range(6)])
    batch = lambda T, tol=None: fitting.fit_batch(T, js.CubicBSpline(), 8, tol=tol).rms
    # To the solver's accuracy: the traced batch is one program with the measurement, which
    # XLA may round otherwise at the suite's settings (conftest): with the measurement's
    # search by blocks (`_curve._block_nearest`) in it, two of the six fits stopped with
    # control points 1.4e-8 apart and RMS 4.4e-9 of itself apart (bit for bit with the
    # every-segment search in its place, and at XLA's default settings).
    np.testing.assert_allclose(jax.jit(batch)(targets), batch(targets), rtol=1e-7)
    gradient = jax.grad(lambda T: batch(T, 1e-10).sum())(jnp.asarray(targets))
    assert gradient.shape == targets.shape and bool(jnp.all(jnp.isfinite(gradient)))


def test_sharded_batch_equals_unsharded():
    # Two host devices need XLA_FLAGS before JAX starts: run in a fresh interpreter.
    code = textwrap.dedent(
        """
        import jax, numpy as np
        jax.config.update("jax_enable_x64", True)
        import fitting, jaxsubdiv as js
        assert len(jax.devices()) == 2, jax.devices()
        rng = np.random.default_rng(0)
        th = np.sort(rng.uniform(0, 2 * np.pi, (3, 80)), axis=1)
        r = 1 + 0.2 * np.sin(3 * th)
        targets = np.stack([r * np.cos(th), r * np.sin(th)], -1)
        # Tight tol: the two programs round differently (a shard_map over the devices or not).
        a = fitting.fit_batch(targets, js.CubicBSpline(), 8, tol=1e-10)
        b = fitting.fit_batch(targets, js.CubicBSpline(), 8, devices=jax.devices()[:1],
                              tol=1e-10)
        c = fitting.fit_batch(targets, js.CubicBSpline(), 8, progress=True)  # one line
        assert np.all(np.asarray(c.converged))
        # optimistix's solvers keep a vmap over the devices (lineax rejects shard_map's
        # arrays): they run on both devices and agree with one device where they
        # converge. Gauss-Newton crawls on the third outline: at XLA's default
        # optimisation 200 steps on both (max_steps reached), at level 0 it converged in
        # 194 and 137 steps to the same RMS (2026-12-06): which is a matter of rounding.
        d, e = (fitting.fit_batch(targets, js.CubicBSpline(), 8, solver="gauss-newton",
                                  devices=devices, on_failure="ignore")
                for devices in (jax.devices(), jax.devices()[:1]))
        statuses = [list(np.asarray(r.status)) for r in (d, e)]
        assert all(s[:2] == [0, 0] and s[2] in (0, 7) for s in statuses), statuses
        both = (np.asarray(d.status) == 0) & (np.asarray(e.status) == 0)
        np.testing.assert_allclose(np.asarray(d.rms)[both], np.asarray(e.rms)[both], rtol=1e-9)
        for i in range(3):
            ca, cb = np.asarray(a.control_points[i]), np.asarray(b.control_points[i])
            print(float(np.abs(ca - cb).max()), float(abs(float(a.rms[i]) / float(b.rms[i]) - 1)),
                  max(float(a.newton_step[i]), float(b.newton_step[i])))
        """
    )
    flags = os.environ.get("XLA_FLAGS", "")  # the suite's (conftest.py), plus 2 devices
    env = dict(os.environ, XLA_FLAGS=f"{flags} --xla_force_host_platform_device_count=2")
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert out.returncode == 0, out.stderr[-3000:]
    # The two programs round differently (a shard_map over the devices or not), so they
    # may stop at slightly different points; each within its own `newton_step` of the
    # optimum. Where that is tiny they agree to 1e-6 (measured 4e-8); the third outline
    # (three lobes, 8 control points: a nearly free sliding) stops 3e-3 from its
    # optimum, where the two stopped 6e-8 apart (8e-5 apart, 3 steps apart, when the
    # devices' program was a vmap).
    for line in out.stdout.strip().splitlines()[-3:]:
        control, rms, newton = map(float, line.split())
        if newton < 1e-6:
            assert control < 1e-6 and rms < 1e-6, (control, rms, newton)
        else:
            assert control < 2 * newton and rms < 1e-3, (control, rms, newton)
    # The batch's progress line, across two devices, with a sane clock (it once showed
    # the seconds since the machine started: its first report counts two outlines).
    seconds = [float(x) for x in re.findall(r"outlines\s+([0-9.]+) s", out.stderr)]
    assert seconds and max(seconds) < 600, out.stderr


_TWO_PROCESSES = textwrap.dedent(
    """
    import sys, warnings
    import jax, numpy as np
    jax.config.update("jax_enable_x64", True)
    process, port, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
    jax.distributed.initialize(coordinator_address=f"localhost:{port}", num_processes=2,
                               process_id=process, initialization_timeout=120)
    import fitting, jaxsubdiv as js
    assert jax.process_count() == 2 and len(jax.local_devices()) == 1
    batch = [np.asarray(x) for x in np.load(sys.argv[4], allow_pickle=True)["targets"]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the invalid and NaN items
        many = fitting.fit_batch(batch, js.CubicBSpline(), 8, max_steps=400, threads=1)
    one = fitting.fit_batch(batch[:1], js.CubicBSpline(), 8, max_steps=400, threads=1)
    fields = lambda r, p: {p + k: np.asarray(getattr(r, k)) for k in
                           ("control_points", "rms", "max_error", "num_steps", "status")}
    # One program over both processes' devices: every process gets the whole result.
    spmd = fitting.fit_batch([batch[0], batch[3]], js.CubicBSpline(), 8, max_steps=400,
                             tol=1e-10, devices=jax.devices())
    np.savez(out, **fields(many, "many_"), **fields(one, "one_"), **fields(spmd, "spmd_"))
    # A process that passes another batch: every process raises, nothing is fitted.
    other = [x + process for x in batch]
    try:
        fitting.fit_batch(other, js.CubicBSpline(), 8, max_steps=400)
    except ValueError as error:
        print("raised:", error)
    # A process whose share fails: it raises its error, the other says so (no hang).
    import fitting._batch as batch_module
    if process == 1:
        def broken(*args, **kwargs):
            raise MemoryError("no memory for this share (a test)")
        batch_module._run_batch = broken
    try:
        fitting.fit_batch(batch[:1], js.CubicBSpline(), 8, max_steps=400, threads=1)
    except (MemoryError, RuntimeError) as error:
        print("failed:", type(error).__name__, error)
    jax.distributed.shutdown()
    """
)


def test_batch_across_two_processes_equals_one_process(tmp_path, suite_cache_environment):
    """#16: two CPU processes joined by `jax.distributed` (a local coordinator) fit one
    batch, each its share, and both return the whole batch: the same numbers as one
    process (the same compiled program per item on one machine: equal bits), per-item
    statuses included, also when there are fewer items than processes; and one program
    over both processes' devices (`devices=jax.devices()`), to its rounding. A process
    passing another batch, or failing in its share, makes both raise (no hang)."""
    import socket

    batch = [blob(100, seed=1), blob(3)[:2], blob(120, seed=2), blob(100, seed=3)]
    batch[2][5] = np.nan
    inputs = tmp_path / "batch.npz"
    np.savez(inputs, targets=np.array(batch, dtype=object))
    # One device each; the suite's other flags kept: the same compiled programs as here,
    # which this process can then load from the suite's cache (run alone on 2026-12-06,
    # it loaded 2 of its 59 programs, and compiled for 7 s instead of 22 s).
    env = dict(os.environ, **suite_cache_environment, XLA_FLAGS=" ".join(
        flag for flag in os.environ.get("XLA_FLAGS", "").split() if "device_count" not in flag))
    env["JAX_PLATFORMS"] = "cpu"
    for attempt in range(3):  # a port found free may be taken before the coordinator binds it
        with socket.socket() as free:
            free.bind(("localhost", 0))
            port = str(free.getsockname()[1])
        logs = [(tmp_path / f"{p}.out", tmp_path / f"{p}.err") for p in (0, 1)]
        runs = []
        try:
            for p, (out, err) in enumerate(logs):
                with open(out, "w") as o, open(err, "w") as e:
                    runs.append(subprocess.Popen(
                        [sys.executable, "-c", _TWO_PROCESSES, str(p), port,
                         str(tmp_path / f"{p}.npz"), str(inputs)], stdout=o, stderr=e, env=env))
            codes = [run.wait(timeout=600) for run in runs]
        finally:
            for run in runs:  # none left running, whatever happened
                run.kill()
                run.wait()
        errors = [err.read_text() for _, err in logs]
        if not any("address already in use" in e.lower() for e in errors):
            break
    for code, error, (out, _) in zip(codes, errors, logs):
        assert code == 0, error[-3000:]
        assert "raised: fit_batch across 2 processes: process 1 passed other" in out.read_text()
    assert ("failed: RuntimeError fit_batch across 2 processes: process 1 failed while "
            "fitting its share") in logs[0][0].read_text()
    assert "failed: MemoryError no memory for this share" in logs[1][0].read_text()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        # Two shares of two, as the two processes fit them: the same compiled program.
        many = fitting.fit_batch(batch, js.CubicBSpline(), 8, max_steps=400, threads=2)
    one = fitting.fit_batch(batch[:1], js.CubicBSpline(), 8, max_steps=400, threads=1)
    tight = fitting.fit_batch([batch[0], batch[3]], js.CubicBSpline(), 8, max_steps=400,
                              tol=1e-10)
    assert list(np.asarray(many.converged)) == [True, False, False, True]
    for p in (0, 1):
        with np.load(tmp_path / f"{p}.npz") as file:
            got = dict(file)
        for name in ("control_points", "rms", "max_error", "num_steps", "status"):
            for prefix, reference in (("many_", many), ("one_", one)):
                np.testing.assert_array_equal(got[prefix + name],
                                              np.asarray(getattr(reference, name)),
                                              err_msg=f"process {p}: {prefix}{name}")
        # That program (a shard_map) rounds differently: converged tightly, both stop
        # within 1e-6 of the same optimum (as on one host, above).
        np.testing.assert_allclose(got["spmd_control_points"], tight.control_points, atol=1e-6)
        np.testing.assert_allclose(got["spmd_rms"], tight.rms, rtol=1e-6)


# --------------------------------------------------------------------------------------
# Foot points and distances: the fast paths against brute force


def _executions(monkeypatch, module, name):
    """Count the executions (not the tracings) of `module.name`: a `lax.cond` branch."""
    calls = []
    original = getattr(module, name)

    def spy(*args, **kwargs):
        jax.debug.callback(lambda: calls.append(1))
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, spy)
    return calls


@pytest.fixture(params=["one pass", "two levels", "pruned"])
def search_levels(request, monkeypatch):
    """The nearest-anchor search and the certificate each way: one pass over all pairs
    (small searches); in two levels (`_curve.TWO_LEVELS_FROM` anchors on); and in two
    levels with the nearest anchor and the certificate by pruning (`_curve.PRUNED_FROM`),
    in groups of 4 anchors and blocks of 4 groups of segments (`_curve.PRUNE_GROUP`) so
    that the tests' small outlines make many of them (their uncertain points, most on
    random anchors, take the two-level search and certificate)."""
    monkeypatch.setattr(_curve, "TWO_LEVELS_FROM", 10**9 if request.param == "one pass" else 1)
    if request.param == "pruned":
        monkeypatch.setattr(_curve, "PRUNED_FROM", 1)
        monkeypatch.setattr(_curve, "PRUNE_GROUP", 4)
    return request.param


@pytest.mark.parametrize("closed", [True, False])
@pytest.mark.parametrize("spread, fallback", [(0.002, False), (0.3, True)])
def test_distances_equal_brute_force(monkeypatch, closed, spread, fallback, search_levels):
    """`distances` certifies its fast answer, else checks every segment; either way it
    equals the brute-force distance."""

    polyline = glyph_outline("S", 400) if closed else glyph_outline("S", 400)[:250]
    rng = np.random.default_rng(5)
    size = np.linalg.norm(np.ptp(polyline, axis=0))
    points = polyline[rng.integers(0, len(polyline), 700)]
    points = points + spread * size * rng.standard_normal(points.shape)
    _assert_brute_force_distances(monkeypatch, points, polyline, closed, fallback)


def _assert_brute_force_distances(monkeypatch, points, polyline, closed, fallback):
    calls = _executions(monkeypatch, _curve, "all_distances")
    ours = _curve.distances(jnp.asarray(points), jnp.asarray(polyline), closed)
    jax.block_until_ready(ours)
    assert bool(calls) == fallback
    np.testing.assert_allclose(ours, polyline_distances(points, polyline, closed), rtol=1e-12,
                               atol=1e-15)


@pytest.mark.parametrize("closed", [True, False])
def test_distances_to_a_padded_polyline_are_certified_without_fallback(monkeypatch, closed,
                                                                       search_levels):
    """A polyline padded to a shape bucket with copies of its last vertex (`count` real
    ones, as the fit pads samples): distances from points near it, also near a closed
    outline's seam and an open one's ends, equal brute force on the unpadded polyline,
    and the certificate holds without checking every segment (once it fell back on
    every call: 52 s of a 67 s fit of 20,000 samples)."""
    polyline = glyph_outline("S", 400) if closed else glyph_outline("S", 400)[:250]
    count = len(polyline)
    padded = np.concatenate([polyline, np.repeat(polyline[-1:], 48, axis=0)])
    rng = np.random.default_rng(7)
    size = np.linalg.norm(np.ptp(polyline, axis=0))
    ends = np.concatenate([polyline[:3], polyline[-3:]])
    points = np.concatenate([polyline[rng.integers(0, count, 600)], np.repeat(ends, 10, axis=0)])
    points = points + 0.002 * size * rng.standard_normal(points.shape)
    calls = _executions(monkeypatch, _curve, "all_distances")
    ours = _curve.distances(jnp.asarray(points), jnp.asarray(padded), closed,
                            count=jnp.int32(count))
    jax.block_until_ready(ours)
    assert not calls
    np.testing.assert_allclose(ours, polyline_distances(points, polyline, closed), rtol=1e-12,
                               atol=1e-15)


@pytest.mark.parametrize("closed", [True, False])
def test_distances_of_a_dense_curve_are_certified_by_clusters(monkeypatch, closed,
                                                              search_levels):
    """A curve's samples against a sparser outline (as the fit measures its curve to
    the samples): with two levels, consecutive points go in clusters
    (`_curve._clustered`), each certified as a whole, so that few points (of 2,400) are
    searched on their own; the distances equal brute force on the unpadded outline, near a closed
    outline's seam and an open one's ends too (the outline padded as the fit pads)."""
    outline = glyph_outline("S", 400) if closed else glyph_outline("S", 400)[:250]
    count = len(outline)
    padded = np.concatenate([outline, np.repeat(outline[-1:], 48, axis=0)])
    # A smooth curve near the outline: its periodic cubic spline, sampled 6 times as
    # densely, moved off it by a slow wave of 0.3% of the size.
    size = np.linalg.norm(np.ptp(outline, axis=0))
    t = np.linspace(0, 1, 6 * count, endpoint=not closed)
    # (A copy: splprep with per=True writes the first point over the last.)
    tck, _ = scipy.interpolate.splprep(outline.T.copy(), s=0, per=closed)
    curve = np.stack(scipy.interpolate.splev(t, tck), -1)
    curve = curve + 0.003 * size * np.sin(40 * np.pi * t)[:, None] * np.array([0.6, 0.8])
    searched = []  # points searched on their own, per execution
    original = _curve._pointwise

    def spy(points, *args):
        jax.debug.callback(lambda: searched.append(points.shape[0]))
        return original(points, *args)

    monkeypatch.setattr(_curve, "_pointwise", spy)
    # One program, traced here (a new function: no trace of another test's is reused).
    distances = jax.jit(lambda p, c, closed, count: _curve.distances(p, c, closed, count=count),
                        static_argnames="closed")
    ours = distances(jnp.asarray(curve), jnp.asarray(padded), closed, count=jnp.int32(count))
    jax.block_until_ready(ours)
    if search_levels != "one pass":  # a few unsure clusters, `RECHECK` points at a time
        assert sum(searched) <= 4 * _curve.RECHECK, searched
    else:
        assert searched == [len(curve)], searched
    np.testing.assert_allclose(ours, polyline_distances(curve, outline, closed), rtol=1e-12,
                               atol=1e-15)


@pytest.mark.parametrize("spread, fallback", [(0.002, False), (0.3, True)])
def test_searches_in_blocks_of_points_give_the_same_distances(monkeypatch, spread, fallback,
                                                              search_levels):
    """With few point pairs allowed at once (`_curve.BLOCK_PAIRS`, so that memory stays
    linear in the samples), the nearest anchors, the certificate and the global search
    run in blocks of 10 points (one point for the global search) and still give the
    brute-force distances."""
    monkeypatch.setattr(_curve, "BLOCK_PAIRS", 500)  # 50 anchors: blocks of 10 points
    polyline = glyph_outline("S", 400)
    rng = np.random.default_rng(6)
    size = np.linalg.norm(np.ptp(polyline, axis=0))
    points = polyline[rng.integers(0, len(polyline), 703)]  # not a multiple of 10
    points = points + spread * size * rng.standard_normal(points.shape)
    _assert_brute_force_distances(monkeypatch, points, polyline, True, fallback)


def _wavy(segments, closed, rng):
    """A wavy loop (37 waves of 5%) with a step of 2% at its middle."""
    t = np.linspace(0.0, 1.0, segments + (0 if closed else 1), endpoint=not closed)
    radius = (1.0 + 0.05 * np.sin(37 * np.pi * t)) * np.where(t < 0.5, 1.0, 0.98)
    return np.stack([radius * np.cos(1.9 * np.pi * t), radius * np.sin(1.9 * np.pi * t)], -1)


def _walk(segments, closed, rng):
    """A random walk: it crosses itself, and some of its steps have length zero."""
    steps = rng.standard_normal((segments + (0 if closed else 1), 2))
    steps[rng.integers(0, len(steps), len(steps) // 10)] = 0.0
    return np.cumsum(steps, axis=0) * 0.1


def _comb(segments, closed, rng):
    """A comb: teeth 1 long and 0.02 apart, each tooth a run of vertices down and up,
    so that far along the polyline lie points 0.02 away."""
    per = max(1, (segments + 1) // 20)  # vertices per tooth side
    teeth = []
    for k in range(10):
        down = np.linspace(1.0, 0.0, per, endpoint=False)
        teeth += [np.stack([np.full(per, 0.04 * k), down], -1),
                  np.stack([np.full(per, 0.04 * k + 0.02), down[::-1]], -1)]
    comb = np.concatenate(teeth)
    return comb[: segments + (0 if closed else 1)]


#: (shape, segments, closed, spread): one block (every block searched), blocks that do
#: not divide the segments, long polylines; points near them and far away; self-crossing
#: walks and combs, where parts far apart along the polyline are close in the plane.
block_cases = [(_wavy, 5, True, 0.05), (_wavy, 99, False, 0.3), (_wavy, 1500, True, 0.01),
               (_wavy, 1500, False, 0.01), (_wavy, 1500, True, 0.3),
               (_walk, 99, True, 0.05), (_walk, 1500, False, 0.5),
               (_comb, 399, False, 0.01), (_comb, 1500, True, 0.2)]


@pytest.mark.parametrize("shape, segments, closed, spread", block_cases,
                         ids=lambda x: getattr(x, "__name__", None))
def test_search_by_blocks_of_segments_equals_brute_force(monkeypatch, shape, segments, closed,
                                                         spread):
    """`_curve._block_nearest` (the nearest point among the segments of the blocks whose
    balls come nearest, certified by every other block's ball, else every segment
    checked) gives the brute-force distance; points near a smooth outline are certified
    without checking every segment."""
    rng = np.random.default_rng(segments)
    polyline = shape(segments, closed, rng)
    points = polyline[rng.integers(0, len(polyline), 301)]
    points = points + spread * rng.standard_normal(points.shape)
    calls = _executions(monkeypatch, _curve, "all_distances")
    search = jax.jit(_curve._block_nearest, static_argnums=(2, 3))
    segment, fraction = search(jnp.asarray(points), jnp.asarray(polyline), closed, 256)
    ends = np.roll(polyline, -1, axis=0) if closed else polyline[1:]
    segment, fraction = np.asarray(segment), np.asarray(fraction)[:, None]
    foot = polyline[segment] + fraction * (ends[segment] - polyline[segment])
    np.testing.assert_allclose(np.linalg.norm(points - foot, axis=1),
                               polyline_distances(points, polyline, closed), rtol=1e-12,
                               atol=1e-15)
    if shape is _wavy and spread <= 0.02:
        assert not calls


def test_unsure_points_far_from_a_dense_curve_are_searched_by_blocks(monkeypatch):
    """Points farther from a densely sampled curve than the window of the nearest coarse
    vertex reaches (a fit's samples against its curve of 4 samples per sample and
    more): most are unsure, and the search by blocks of segments (`_block_nearest`)
    certifies them, so that no segment-by-segment check of all points runs (it made the
    error measurement of a fit quadratic in its samples); the distances equal brute
    force."""
    t = np.linspace(0.0, 1.0, 8192, endpoint=False)
    curve = np.stack([np.cos(2 * np.pi * t), 0.6 * np.sin(2 * np.pi * t)], -1)
    rng = np.random.default_rng(3)
    points = curve[::4] * (1.0 + 0.01 * rng.standard_normal((2048, 1)))

    @jax.jit
    def unsure(points, curve):  # the window search's certificate (`_curve._pointwise`)
        coarse, _, nearest, segment, fraction = _curve._coarse_to_fine(points, curve, True, 8)
        found = _curve._found(points, curve, True, segment, fraction)
        return _curve._unsure(points, curve, True, coarse, None, nearest, found)

    assert np.mean(unsure(jnp.asarray(points), jnp.asarray(curve))) > 0.25  # fails for most
    blocks = _executions(monkeypatch, _curve, "_block_nearest")
    every = _executions(monkeypatch, _curve, "all_distances")
    ours = _curve.distances(jnp.asarray(points), jnp.asarray(curve), True)
    jax.block_until_ready(ours)
    assert blocks and not every
    np.testing.assert_allclose(ours, polyline_distances(points, curve), rtol=1e-12, atol=1e-15)


#: (points, anchors, duplicated anchors): anchor counts below one group, not a multiple
#: of `_curve.ANCHOR_GROUP`, and exact ties (an anchor repeated later).
anchor_cases = [(50, 7, 0), (300, 100, 0), (200, 257, 5), (64, 96, 3)]


@pytest.mark.parametrize("m, k, repeated", anchor_cases)
def test_nearest_anchor_is_the_nearest_by_brute_force(m, k, repeated, search_levels):
    """`_nearest_anchor`, in one pass or in two levels (nearest group, then nearest
    anchor in it), finds an anchor at the brute-force least distance, the first of
    exact ties, and that distance."""
    rng = np.random.default_rng(k)
    anchors = rng.standard_normal((k, 2)) * 10.0 + 3.0
    anchors[k - repeated:] = anchors[:repeated]  # ties: the first copy must win
    points = anchors[rng.integers(0, k, m)] + rng.standard_normal((m, 2))
    index, least = _curve._nearest_anchor(jnp.asarray(points), jnp.asarray(anchors))
    exact = np.sum((points[:, None, :] - anchors[None]) ** 2, -1)
    scale = np.max(np.sum(anchors**2, -1)) + np.max(np.sum(points**2, -1))
    index = np.asarray(index)
    np.testing.assert_allclose(exact[np.arange(m), index], exact.min(1), atol=1e-12 * scale)
    np.testing.assert_allclose(np.asarray(least) + np.sum(points**2, -1), exact.min(1),
                               atol=1e-12 * scale)
    tied = np.flatnonzero(np.isin(index, np.arange(k - repeated, k)))
    assert tied.size == 0, "a repeated anchor won over its first copy"


def _anchors_and_points(k: int, seed: int):
    """`k` anchors along a glyph's outline, 3,000 points near it (1e-3 of its size off)
    and 600 far off it (0.1), each point's brute-force least squared distance to the
    anchors, the outline's size, and the random generator (to go on drawing from)."""
    anchors = glyph_outline("S", k)
    rng = np.random.default_rng(seed)
    size = np.linalg.norm(np.ptp(anchors, axis=0))
    on = glyph_outline("S", 3000) + 1e-3 * size * rng.standard_normal((3000, 2))
    off = anchors[rng.integers(0, k, 600)] + 0.1 * size * rng.standard_normal((600, 2))
    points = np.concatenate([on, off])
    exact = np.sum((points[:, None, :] - anchors[None]) ** 2, -1).min(1)
    return anchors, points, exact, size, rng


@pytest.mark.parametrize("k", [1024, 1000])
def test_pruned_nearest_anchor_certifies_only_the_nearest(monkeypatch, k):
    """The pruned search (`_curve._pruned_nearest_anchor`, the nearest of groups by a
    lower bound on their balls, then three groups searched exactly) on anchors along a
    glyph outline, as a fit's curve gives them (1,000: the last group padded): every
    answer it calls certain is at the brute-force least distance, with that distance;
    samples of the outline are nearly all certain, points far off it a tenth or more
    not; and `_nearest_anchor`, which sends the uncertain ones to the two-level search,
    is exact for all."""
    monkeypatch.setattr(_curve, "PRUNED_FROM", 1)
    anchors, points, exact, size, _ = _anchors_and_points(k, seed=8)
    P, A = jnp.asarray(points), jnp.asarray(anchors)
    index, least, certain = map(np.asarray, _curve._pruned_nearest_anchor(P, A))
    at = np.sum((points - anchors[index]) ** 2, -1)
    # Both sides are numpy's sums of squared differences: equal unless another anchor
    # is nearer (ties within rounding aside).
    assert np.all(at[certain] <= exact[certain] * (1 + 1e-13)), "certain but not the nearest"
    np.testing.assert_allclose(least[certain] + np.sum(points[certain] ** 2, -1), at[certain],
                               rtol=1e-10, atol=1e-14 * size**2)
    assert np.mean(certain[:3000]) > 0.95 and np.mean(certain[3000:]) < 0.9
    index, least = map(np.asarray, _curve._nearest_anchor(P, A))
    np.testing.assert_allclose(np.sum((points - anchors[index]) ** 2, -1), exact, rtol=1e-13)
    np.testing.assert_allclose(least + np.sum(points**2, -1), exact, rtol=1e-10,
                               atol=1e-14 * size**2)


def _segment_distances(points, a, b):
    """Distances from every point to every segment [a_j, b_j], `(m, segments)`."""
    ab = b - a
    out = np.empty((len(points), len(a)))
    for start in range(0, len(points), 256):
        ap = points[start : start + 256, None, :] - a
        u = np.clip((ap * ab).sum(-1) / np.maximum((ab**2).sum(-1), 1e-300), 0, 1)
        out[start : start + 256] = np.sqrt(((ap - u[..., None] * ab) ** 2).sum(-1))
    return out


@pytest.mark.parametrize("closed", [True, False])
def test_pruned_certificate_leaves_no_nearer_point_unchecked(closed):
    """The certificate's pruned pass (`_curve._pruned_unsure`: blocks of 32 groups of
    segments bounded by balls, the point's own block and its neighbours group by group),
    given balls of the test's own that hold each group of 8 segments of a glyph's
    outline, and each point's distance to the nearest point of the groups searched
    around its nearest coarse vertex: no point it certifies (neither unsure nor
    undecided) has a nearer point in another group, by brute force; points near the
    outline are nearly all certified, and points far off it are left undecided (for the
    check against every group) often enough that the bounds are seen to bite."""
    coarse = 8
    outline = glyph_outline("S", 8192)  # closed: 1,024 groups, 32 blocks
    polyline = outline if closed else outline[:6401]  # open: 800 groups, 25 blocks
    segments = len(polyline) if closed else len(polyline) - 1
    a, b = polyline[:segments], np.roll(polyline, -1, axis=0)[:segments]
    group_of = np.arange(segments) // coarse
    k = group_of[-1] + 1
    ends = [np.concatenate([a[group_of == g], b[group_of == g]]) for g in range(k)]
    center = np.stack([e.mean(0) for e in ends])  # not the library's choice of centre
    radius = np.array([np.sqrt(((e - c) ** 2).sum(-1).max()) for e, c in zip(ends, center)])
    rng = np.random.default_rng(9)
    size = np.linalg.norm(np.ptp(polyline, axis=0))
    on = polyline[rng.integers(0, len(polyline), 3000)] + 1e-3 * size * rng.standard_normal((3000, 2))
    off = polyline[rng.integers(0, len(polyline), 600)] + 0.1 * size * rng.standard_normal((600, 2))
    points = np.concatenate([on, off])
    anchors = polyline[::coarse]
    nearest = np.argmin(((points[:, None, :] - anchors[None]) ** 2).sum(-1), axis=1)
    before = (nearest - 1) % k if closed else nearest - 1
    searched = (group_of[None, :] == nearest[:, None]) | (group_of[None, :] == before[:, None])
    distance = _segment_distances(points, a, b)
    found = np.where(searched, distance, np.inf).min(1)
    elsewhere = np.where(searched, np.inf, distance).min(1)

    def searched_groups(nearest, g):
        nearest = nearest[:, None]
        return (g == nearest) | (g == ((nearest - 1) % k if closed else nearest - 1))

    unsure, undecided = map(np.asarray, _curve._pruned_unsure(
        jnp.asarray(points), jnp.asarray(found), jnp.asarray(nearest), jnp.asarray(center),
        jnp.asarray(radius), searched_groups, closed))
    certified = ~unsure & ~undecided
    assert np.all(elsewhere[certified] >= found[certified] * (1 - 1e-12)), \
        "certified with a nearer point elsewhere"
    assert np.mean(certified[:3000]) > 0.95
    assert 0.1 < np.mean(undecided[3000:]) < 1


@pytest.mark.parametrize("pruned", [True, False])
@pytest.mark.parametrize("k", [1024, 1000])
def test_lost_feet_are_those_with_a_nearer_anchor(monkeypatch, k, pruned):
    """`_curve._lost` (is an anchor nearer than the point's foot?, which sends a fit's
    feet to the global search) on anchors along a glyph's outline, by groups pruned by
    their balls or against every anchor (1,000 anchors: the last group padded): equal to
    brute force for points near the outline and far off it, with feet 10-50% nearer or
    farther than the nearest anchor (far beyond the check's rounding margin) and skipped
    points' zero distances (never lost), whatever anchor near each foot it is given. The
    pruned pass (`_curve._pruned_lost`) decides
    nearly all points near the outline itself, never wrongly, and leaves points far off
    it undecided often enough that its bounds are seen to bite."""
    monkeypatch.setattr(_curve, "PRUNED_FROM", 1 if pruned else 10**9)
    anchors, points, exact, _, rng = _anchors_and_points(k, seed=10)
    factor = np.where(rng.random(len(points)) < 0.5, rng.uniform(0.5, 0.9, len(points)),
                      rng.uniform(1.1, 1.5, len(points)))
    found2 = exact * factor**2
    found2[::7] = 0.0
    truth = exact < found2
    assert 0.3 < np.mean(truth[:3000]) < 0.6 and 0.3 < np.mean(truth[3000:]) < 0.6
    P, A = jnp.asarray(points), jnp.asarray(anchors)
    # An anchor near each foot, as the fit passes it: the nearest one's neighbour for
    # points on the outline, any one for points off it (the answer must not depend on it).
    near = np.argmin(np.sum((points[:, None, :] - anchors[None]) ** 2, -1), axis=1)
    near = np.where(np.arange(len(points)) < 3000, (near + 1) % k, rng.integers(0, k, len(points)))
    for given in (None, jnp.asarray(near)):
        lost = np.asarray(_curve._lost(P, A, jnp.asarray(found2), given))
        np.testing.assert_array_equal(lost, truth)
    if pruned:
        pruned_lost, undecided = map(np.asarray, _curve._pruned_lost(P, A, jnp.asarray(found2)))
        decided = ~undecided
        np.testing.assert_array_equal(pruned_lost[decided], truth[decided])
        assert np.mean(decided[:3000]) > 0.95
        # Far points not lost: only the bounds can clear them.
        cleared_by_bounds = ~truth & (found2 > 0)
        assert 0.1 < np.mean(undecided[3000:][cleared_by_bounds[3000:]]) < 1


@pytest.mark.parametrize("m, k, excluded", [(40, 10, 2), (300, 250, 2), (100, 64, 5)])
def test_smallest_outside_matches_a_masked_minimum(m, k, excluded):
    """`_smallest_outside` (the certificate's least value over the columns not
    excluded, in two levels) equals a plain minimum over a masked array, with the
    exclusions among the columns it is told to recompute, and +inf when every column is
    excluded."""
    rng = np.random.default_rng(m + k)
    rows, columns = rng.standard_normal((m, 3)), rng.standard_normal((k, 3))
    norms = rng.standard_normal(k)
    near = rng.integers(0, k, (m, excluded))
    value = norms[None, :] - 2 * rows @ columns.T
    mask = np.zeros((m, k), bool)
    mask[np.arange(m)[:, None], near] = True
    expected = np.where(mask, np.inf, value).min(1)
    near_j = jnp.asarray(near)
    ours = _curve._smallest_outside(
        jnp.asarray(rows), jnp.asarray(columns), jnp.asarray(norms), near_j,
        lambda j: jnp.any(j[..., None] == near_j[:, None, None, :], axis=-1))
    np.testing.assert_allclose(ours, expected, rtol=1e-12, atol=1e-12)
    everything = _curve._smallest_outside(
        jnp.asarray(rows[:3]), jnp.asarray(columns[:5]), jnp.asarray(norms[:5]),
        jnp.zeros((3, 1), jnp.int32), lambda j: jnp.ones(j.shape, bool))
    assert np.all(np.isinf(everything))


def test_only_unsure_points_are_searched_again(monkeypatch):
    """Points near an outline and a few far from it: the certificate is unsure of a few
    far ones, and only those (`_curve.RECHECK` at a time) are searched again, by blocks
    of segments (`_curve._block_nearest`; the whole block of points was once checked
    against every segment: 4 of a fit's 7 ms of error measurement); all distances equal
    brute force."""
    polyline = glyph_outline("S", 400)
    rng = np.random.default_rng(8)
    size = np.linalg.norm(np.ptp(polyline, axis=0))
    near = polyline[rng.integers(0, len(polyline), 500)]
    near = near + 0.002 * size * rng.standard_normal(near.shape)
    far = polyline[rng.integers(0, len(polyline), 40)] + 0.3 * size * rng.standard_normal((40, 2))
    points = np.concatenate([near, far])
    checked = []
    original = _curve._block_nearest

    def spy(points, *args, **kwargs):
        checked.append(points.shape[0])  # at tracing: the points searched together
        return original(points, *args, **kwargs)

    monkeypatch.setattr(_curve, "_block_nearest", spy)
    ours = _curve.distances(jnp.asarray(points), jnp.asarray(polyline), True)
    np.testing.assert_allclose(ours, polyline_distances(points, polyline), rtol=1e-12,
                               atol=1e-15)
    # Traced once, for the unsure points RECHECK at a time (a loop only, however many:
    # one copy of the search in the program).
    assert checked == [_curve.RECHECK]
    calls = []  # executions: one per `RECHECK` unsure points, fewer than the far ones
    monkeypatch.setattr(_curve, "_block_nearest", lambda *a, **k: (
        jax.debug.callback(lambda: calls.append(1)), original(*a, **k))[1])
    jax.block_until_ready(_curve.distances(jnp.asarray(points), jnp.asarray(polyline), True))
    assert 1 <= len(calls) <= -(-len(far) // _curve.RECHECK)


@pytest.mark.parametrize("angle, scrambled, searches", [(0.002, 0, 0), (0.8, 0, 1), (0.002, 3, 1)])
def test_feet_tracked_from_the_last_step_are_the_nearest_points(monkeypatch, angle, scrambled,
                                                                searches):
    """Feet found from the previous curve's feet are the nearest points of the new curve
    (brute force on a 64x finer polyline of it): after a small move (no global search),
    after a large one that makes the search start over, and after a small move with
    three feet put on the far side of the curve (lost: all are searched again, once)."""

    samples = jnp.asarray(blob(300, seed=4))
    n, levels, scheme = 12, 6, js.CubicBSpline()
    A, V = (t.dense() for t in _curve.curve_tables(scheme, n, levels, "closed", samples.dtype,
                                                     True))
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False)
    P = np.stack([1.1 * np.cos(theta), np.sin(theta)], -1)
    previous = _curve.locate(samples, A @ P, V @ P, True, coarse=8)
    far = np.array([5, 100, 200])[:scrambled]
    previous = previous.at[far].set((previous[far] + A.shape[0] / 2) % A.shape[0])
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    moved = P @ rotation.T
    calls = _executions(monkeypatch, _curve, "project")
    tau = _curve.locate(samples, A @ moved, V @ moved, True, coarse=8, previous=previous)
    jax.block_until_ready(tau)
    assert len(calls) == searches
    feet, _ = _curve.evaluate(A @ moved, V @ moved, tau, True)
    found = np.linalg.norm(np.asarray(feet) - np.asarray(samples), axis=1)
    dense = np.asarray(js.limit_points(js.refine(moved, scheme, levels + 6), scheme))
    np.testing.assert_allclose(found, polyline_distances(samples, dense), rtol=0, atol=1e-8)


@pytest.mark.parametrize("hermite", [True, False])
@pytest.mark.parametrize("skipped", [False, True])
def test_skipped_feet_call_for_no_global_search(monkeypatch, hermite, skipped):
    """Points flagged in `skip` (the corner samples, whose feet the fit replaces) never
    call for the global search: three feet put on the far side of the curve make it run
    once, unless those three are skipped, and either way every other foot is the nearest
    point of the new curve (brute force on a 64x finer polyline of it)."""
    samples = jnp.asarray(blob(300, seed=4))
    n, levels, scheme = 12, 6, js.CubicBSpline()
    A, V = (t.dense() for t in _curve.curve_tables(scheme, n, levels, "closed", samples.dtype,
                                                     True))
    V = V if hermite else None
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False)
    P = np.stack([1.1 * np.cos(theta), np.sin(theta)], -1)
    tangents = lambda P: None if V is None else V @ P
    previous = _curve.locate(samples, A @ P, tangents(P), True, coarse=8)
    far = np.array([5, 100, 200])
    previous = previous.at[far].set((previous[far] + A.shape[0] / 2) % A.shape[0])
    skip = np.isin(np.arange(samples.shape[0]), far) if skipped else None
    angle = 0.002
    moved = P @ np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]).T
    calls = _executions(monkeypatch, _curve, "project")
    tau = _curve.locate(samples, A @ moved, tangents(moved), True, coarse=8,
                        previous=previous, skip=skip)
    jax.block_until_ready(tau)
    assert len(calls) == (0 if skipped else 1)
    (feet,) = _curve.evaluate(A @ moved, tangents(moved), tau, True, order=0)
    found = np.linalg.norm(np.asarray(feet) - np.asarray(samples), axis=1)
    dense = np.asarray(js.limit_points(js.refine(moved, scheme, levels + 6), scheme))
    nearest = polyline_distances(samples, dense)
    kept = ~np.isin(np.arange(samples.shape[0]), far)
    # Chords lie within h^2 kappa / 8 of the curve (about 1e-5 here); Hermite segments
    # far closer.
    np.testing.assert_allclose(found[kept], nearest[kept], rtol=0,
                               atol=1e-8 if hermite else 1e-4)
    if skipped:  # those three stayed on the far side
        assert np.all(found[far] > nearest[far] + 0.5)


# --------------------------------------------------------------------------------------
# Gradients through the fit (implicit differentiation) against finite differences


def _small_problem(m=60):
    # A curve the model can represent, plus a little noise: the distance to the fitted
    # curve is then small, so the chord model's kinks (which scale with it) are
    # negligible and the optimum is a smooth function of the data.
    rng = np.random.default_rng(9)
    control = TRUE_CONTROL + 0.05 * rng.standard_normal(TRUE_CONTROL.shape)
    samples = resample_closed(exact_curve(control, js.FourPoint(0.08), 9), m, offset=0.37)
    samples = samples + 1e-4 * rng.standard_normal(samples.shape)
    direction = jnp.asarray(rng.standard_normal((8, 2)))
    return jnp.asarray(samples), direction


def assert_matches_finite_difference(derivative, f, x, direction, steps=(1e-3, 1e-4, 1e-5),
                                     rtol=1e-3):
    """`derivative` (along `direction`) against central differences at steps 1e-3,
    1e-4 and 1e-5: it must match one of them to 1e-3. The fit's curve is a fine
    polyline, so the optimum is only piecewise smooth in the data: a foot point crossing
    a vertex between x - h and x + h spoils that step's difference (seen at 1e-4 on one
    probe, where 1e-3 and 1e-5 agree with the implicit derivative to 5 digits)."""
    fds = []
    for h in steps:
        fds.append((float(f(x + h * direction)) - float(f(x - h * direction))) / (2 * h))
        if abs(derivative - fds[-1]) <= rtol * abs(fds[-1]) + 1e-7:
            return
    raise AssertionError(f"derivative {derivative} matches no finite difference: {fds}")


@pytest.mark.parametrize("scheme, phases", [(js.FourPoint(0.08), None), (js.CubicBSpline(), None),
                                            (js.FourPoint(0.08), 4)],
                         ids=["four_point", "bspline", "four_point_phases"])
def test_gradient_with_respect_to_target(scheme, phases):
    """With `phases`, the fit chosen among the starts carries the implicit derivatives
    of its own optimum (`_core.phase_solve`, `held_implicit`)."""
    samples, direction = _small_problem()

    def loss(target):
        result = fitting.fit(target, scheme, 8, levels=8, tol=1e-12, max_steps=400,
                             phases=phases)
        return jnp.sum(result.control_points * direction)

    grad = np.asarray(jax.grad(loss)(samples))
    rng = np.random.default_rng(11)
    # The cubic B-spline's fit stops 1e-7 to 3e-7 from its optimum along a flat
    # direction (`newton_step`), differently with the rounding of each compilation, which
    # blurs differences at small steps (measured at 1e-3: up to 3e-3 relative, noise
    # growing as 1/h) while at 1e-2 their truncation error is 1.3e-3: at 5e-3 the three
    # probes are within 6e-4, at both XLA optimisation levels (2026-12-06).
    # (The curve-to-target band held constant once gave 0.10 here against -1.03.)
    steps = (1e-3, 1e-4, 1e-5) if isinstance(scheme, js.FourPoint) else (5e-3,)
    rtol = 1e-3
    for k in rng.choice(60, 3, replace=False):
        e = np.zeros((60, 2))
        e[k] = rng.standard_normal(2)
        assert_matches_finite_difference(float(np.sum(grad * e)), loss, samples, e, steps, rtol)


@pytest.mark.parametrize("boundary", ["closed", "clamped"])
def test_gradient_of_the_reported_errors(boundary):
    # Both directions of the two-sided error, on the Hermite curve (closed cubic
    # B-spline) and on chords (the clamped four-point curve, which has no tangent rule
    # at its ends): each is differentiated at its nearest points held fixed.
    scheme = js.CubicBSpline() if boundary == "closed" else js.FourPoint(1 / 16)
    samples, _ = _small_problem()
    if boundary == "clamped":
        samples = samples[:45]
    direction = np.random.default_rng(13).standard_normal(samples.shape)
    fields = ("rms_target_to_curve", "rms_curve_to_target", "max_error")
    # The closed fit without smoothing has a nearly free sliding of its control points:
    # float64 determines its optimum only to ~2.5e-7 (`newton_step`), and its maximum
    # error then varies by ~1e-8 at random between nearby targets (measured: the
    # residual of a quadratic through 21 fits 1e-6 apart), which is 3% of a difference
    # quotient at 1e-5. Smoothing pins the sliding down: 1e-4 did (noise 4e-10) until
    # the samples were put in their canonical order (issue #14), which starts this fit
    # elsewhere; then the quotients of the curve-to-samples RMS (a mean over curve
    # samples uniform in parameter, which move when the control points slide) scattered
    # by 1-4% between steps 1e-5 and 1e-7 at smoothing 1e-4 and 1e-3 (0.01706, 0.01663,
    # 0.01771 against the implicit 0.016817 at 1e-4). At 1e-2 they settle. The
    # arc-length average that replaced that mean did not cure it: at 1e-4 one quotient
    # still scatters (-0.01299, -0.01308, -0.01278, -0.01022 at 1e-5 ... 1e-8 against
    # the implicit -0.01297), so the noise is the stopping point's, not the measure's.
    smoothing = 1e-2 if boundary == "closed" else 0.0

    def errors(target):
        result = fitting.fit(target, scheme, 8, levels=8, boundary=boundary,
                             tol=1e-12, max_steps=400, smoothing=smoothing)
        return jnp.stack([getattr(result, name) for name in fields])

    jacobian = np.asarray(jax.jacrev(errors)(samples))
    # Distances to polylines are only piecewise smooth, and the fitted curve moves much
    # more than the samples: the difference quotient settles at small steps only
    # (measured, clamped curve to target: -0.28 at 1e-5, 0.1067 at 1e-6, 0.10625 at 1e-7;
    # implicit 0.10626), and the maximum's to 3e-3 (closed: 0.272326 at 1e-5; 0.272343).
    for i in range(len(fields)):
        assert_matches_finite_difference(
            float(np.sum(jacobian[i] * direction)), lambda t: errors(t)[i], samples, direction,
            steps=(1e-5, 1e-6, 1e-7, 1e-8), rtol=5e-3 if fields[i] == "max_error" else 1e-3,
        )


#: Hyperparameters at the end of their range, where a square root's derivative is
#: infinite: (name, how the fit takes the value x, the steps of the one-sided
#: differences). `smoothing=0`, and a weight of 0 (a sample switched off; the padding
#: to the program's bucket is such weights too, so before the fix every weight's
#: derivative was NaN, measured 0 x inf). The weight's steps are larger: without
#: smoothing, control points slide nearly freely and the stopping point's jitter
#: (~1e-8 of the curve) swamps quotients at small steps.
boundary_hyperparameters = [
    ("smoothing", lambda x: dict(smoothing=x), (1e-5, 1e-6, 1e-7)),
    ("zero_weight", lambda x: dict(weights=jnp.ones(60).at[7].set(x)), (1e-2, 3e-3, 1e-3)),
]


@pytest.mark.parametrize("name, options, steps", boundary_hyperparameters,
                         ids=[case[0] for case in boundary_hyperparameters])
def test_derivative_at_a_hyperparameter_boundary(name, options, steps):
    """The fitted curve's derivative with respect to a hyperparameter at 0, the end of
    its range (issue #14: NaN before), against second-order one-sided differences
    (-3 f(0) + 4 f(h) - f(2 h)) / (2 h), which need no value below 0."""
    samples, _ = _small_problem()
    curve_direction = jnp.asarray(np.random.default_rng(12).standard_normal((8 * 2**8, 2)))

    def curve_along(x):
        result = fitting.fit(samples, js.CubicBSpline(), 8, levels=8, tol=1e-12,
                             max_steps=400, **options(x))
        return jnp.sum(result.curve * curve_direction)

    derivative = float(jax.grad(curve_along)(0.0))
    assert np.isfinite(derivative)
    f0 = float(curve_along(0.0))
    quotients = []
    for h in steps:
        quotients.append((-3 * f0 + 4 * float(curve_along(h)) - float(curve_along(2 * h)))
                         / (2 * h))
        if abs(derivative - quotients[-1]) <= 2e-3 * abs(quotients[-1]):
            return
    raise AssertionError(f"{name}: derivative {derivative} matches no one-sided "
                         f"difference: {quotients}")


def test_gradient_of_the_errors_is_finite_on_exact_data():
    # Samples exactly on a line: zero distances, where a plain norm has no derivative.
    t = np.linspace(0, 1, 60)
    line = jnp.asarray(np.stack([t, 2 * t], -1))
    for name in ("rms", "max_error", "rms_target_to_curve"):
        grad = jax.grad(lambda x: getattr(
            fitting.fit(x, js.CubicBSpline(), 6, boundary="open"), name))(line)
        assert np.all(np.isfinite(np.asarray(grad))), name


def test_gradient_with_respect_to_scheme_parameters():
    samples, direction = _small_problem()

    def fitted_w(target):  # design study: sensitivity of the fitted tension to the data
        return fitting.fit(target, js.FourPoint(0.08), 8, fit_params=True, levels=8,
                           tol=1e-12, max_steps=400).scheme.w

    curve_direction = jnp.asarray(np.random.default_rng(12).standard_normal((8 * 2**8, 2)))

    def control_given_w(w):  # sensitivity of the fitted curve to a fixed tension
        # (The curve, not the control points: where the data leave control points free
        # to slide along the curve, their derivatives are large and ill-determined.)
        result = fitting.fit(samples, js.FourPoint(w), 8, levels=8, tol=1e-12, max_steps=400)
        return jnp.sum(result.curve * curve_direction)

    # Jitted: differentiated eagerly, the fits ran op by op, compiling 110 small programs.
    for mode in (jax.grad, jax.jacfwd):
        derivative = jax.jit(mode(control_given_w))(0.08)
        assert_matches_finite_difference(float(derivative), control_given_w, 0.08, 1.0)
    grad = np.asarray(jax.jit(jax.jacrev(fitted_w))(samples))
    e = np.zeros((60, 2))
    e[:20, 1] = 1.0  # move part of the outline
    assert_matches_finite_difference(float(np.sum(grad * e)), fitted_w, samples, e)


def _assert_model_matches_finite_differences(objective, args, P, direction):
    """The model's half gradient and half Hessian at `P` (fixed scheme) along `direction`
    against central finite differences (h = 1e-5) of its loss, the feet found afresh."""
    model = jax.jit(lambda P: objective.quadratic_model({"control": P, "params": {}}, args))
    loss = lambda P: float(model(P)[0])
    _, gradient, hessian = model(P)
    v = np.asarray(direction).reshape(-1)
    h = 1e-5
    slope = (loss(P + h * direction) - loss(P - h * direction)) / (2 * h)
    curvature = (loss(P + h * direction) - 2 * loss(P) + loss(P - h * direction)) / h**2
    np.testing.assert_allclose(2 * float(gradient @ v), slope, rtol=1e-4)
    np.testing.assert_allclose(2 * float(v @ hessian @ v), curvature, rtol=2e-2)


@pytest.mark.parametrize("n, boundary", [(8, "closed"), (24, "closed")])
@pytest.mark.parametrize("scheme, hermite", [(js.CubicBSpline(), True), (js.Chaikin(), False)],
                         ids=["hermite", "chords"])
def test_model_matches_finite_differences_of_its_loss(scheme, hermite, n, boundary):
    """The solver's closed-form gradient and (reduced) Hessian against central finite
    differences of the loss with the feet found afresh at every point: at n = 8 (windows
    wrapping around most of the polygon) and n = 24, on the Hermite curve (cubic
    B-spline) and on chords (Chaikin)."""
    from fitting._checks import default_levels
    from fitting._objective import FitData, Objective

    samples, _ = _small_problem(60 if n == 8 else 120)
    samples = (samples - samples.mean(0)) / 1.3
    m = samples.shape[0]
    levels = default_levels(n, m, hermite)
    N = _curve.curve_samples(scheme, n, levels, boundary)
    objective = Objective(n=n, levels=levels, boundary=boundary, names=(), hermite=hermite,
                          num_curve=N, num_target=m)
    weights = jnp.asarray(np.random.default_rng(3).uniform(0.5, 1.5, m))
    basis = objective.basis_of(scheme, samples.dtype)
    args = FitData(target=samples, weights=weights, scheme=scheme,
                   root_smoothing=jnp.sqrt(0.01), basis=basis)
    fit = fitting.fit(samples, scheme, n, levels=levels, weights=weights, smoothing=0.01,
                      boundary=boundary)
    # Near (not at) the optimum, where the model must hold.
    direction = jnp.asarray(np.random.default_rng(n).standard_normal((n, 2)))
    P = (fit.control_points - samples.mean(0)) + 0.01 * direction
    _assert_model_matches_finite_differences(objective, args, P, direction)


def _pillow(m=120):
    """A closed outline with 4 corners, at samples 0, m/4, m/2, 3m/4: four arcs bulging
    out from the sides of a square, samples evenly spaced along each."""
    corners = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    side = m // 4
    t = np.arange(side) / side
    out = []
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        normal = (a + b) / np.linalg.norm(a + b)
        out.append(a + t[:, None] * (b - a) + 0.25 * np.sin(np.pi * t)[:, None] * normal)
    samples = np.concatenate(out)
    # The corner samples a little outside the corners, where the curve's corner point
    # is their nearest (feet at the crease, where the distance is to a point).
    samples[np.arange(4) * side] *= 1.02
    return samples, np.arange(4) * side


@pytest.mark.parametrize("scheme, hermite", [(js.CubicBSpline(), True), (js.FourPoint(0.06), False)],
                         ids=["hermite", "chords"])
def test_creased_model_matches_finite_differences_of_its_loss(monkeypatch, scheme, hermite):
    """With corners, the creased curve's model (Hermite segments with one-sided tangents
    at the creases for the cubic B-spline, with `CREASED_HERMITE` on; chords for the
    four-point scheme, whose clamped ends have no tangent rule) against central finite
    differences of the loss with the feet found afresh, near the fit's optimum; the fit
    picks that model."""
    from fitting import _params
    from fitting._checks import default_levels
    from fitting._init import corner_creases
    from fitting._objective import FitData, Objective

    monkeypatch.setattr(_params, "CREASED_HERMITE", True)
    samples, at = _pillow()
    m, n = samples.shape[0], 16
    flags = np.zeros(m, bool)
    flags[at] = True
    # The corner samples weigh most (feet at the creases, where the model's Hessian is
    # the point distance's, would otherwise be 4 of 120 terms).
    weights = jnp.asarray(1.0 + 29.0 * flags)
    fit = fitting.fit(samples, scheme, n, smoothing=0.01, corners=at, weights=weights)
    assert fit.levels == default_levels(n, fitting._checks.bucket(m), hermite)
    levels = fit.levels
    objective = Objective(n=n, levels=levels, boundary="closed", names=(), hermite=hermite,
                          num_curve=_curve.curve_samples(scheme, n, levels, "closed"),
                          num_target=m, corners=True)
    corners = jnp.asarray(flags)
    creases = corner_creases(jnp.asarray(samples), corners, n)[0]
    np.testing.assert_array_equal(creases, fit.creases)
    args = FitData(target=jnp.asarray(samples), weights=weights, scheme=scheme,
                   root_smoothing=jnp.sqrt(0.01), corners=corners, creases=creases,
                   basis=objective.basis_of(scheme, samples.dtype, creases))
    assert (args.basis[1] is not None) == hermite
    direction = jnp.asarray(np.random.default_rng(4).standard_normal((n, 2)))
    P = fit.control_points + 0.01 * direction
    _assert_model_matches_finite_differences(objective, args, P, direction)


#: Schemes with parameters, the fitted names and whether their fit uses the Hermite model.
parameter_model_cases = [
    (js.FourPoint(0.08), ("w",), True), (js.SplitTweak(0.4), ("t",), True),
    (js.CornerCutting(0.3, 0.8), ("r", "s"), False),
]


def _parameter_model(scheme, names, hermite):
    """The model of an 8-point closed fit with `names` fitted, jitted, and a point `y`
    near (not at) the fit's optimum, with the random generator that drew it."""
    from fitting._checks import default_levels
    from fitting._objective import FitData, Objective

    samples, _ = _small_problem(60)
    samples = (samples - samples.mean(0)) / 1.3
    m, n = samples.shape[0], 8
    levels = default_levels(n, m, hermite)
    objective = Objective(n=n, levels=levels, boundary="closed", names=names,
                          hermite=hermite, num_curve=_curve.curve_samples(scheme, n, levels,
                                                                          "closed"),
                          num_target=m)
    args = FitData(target=samples, weights=jnp.ones(m), scheme=scheme,
                   root_smoothing=jnp.sqrt(0.01))
    fit = fitting.fit(samples, scheme, n, levels=levels, smoothing=0.01)
    rng = np.random.default_rng(5)
    y = {"control": fit.control_points + 0.01 * rng.standard_normal((n, 2)),
         "params": {k: jnp.asarray(v + 0.1) for k, v in scheme.to_unconstrained(names).items()}}
    return jax.jit(lambda y: objective.quadratic_model(y, args)), y, rng


@pytest.mark.parametrize("scheme, names, hermite", parameter_model_cases,
                         ids=["four_point", "split_tweak", "corner_cutting"])
def test_model_with_parameters_matches_finite_differences_of_its_loss(scheme, names, hermite):
    """With scheme parameters fitted, the model's gradient (assembled in closed form,
    the parameters' entries from the tables' derivatives) against central finite
    differences of the loss with the feet found afresh, along a random direction in
    control points and (unconstrained) parameters together."""
    model, y, rng = _parameter_model(scheme, names, hermite)
    n = y["control"].shape[0]
    direction = {"control": jnp.asarray(rng.standard_normal((n, 2))),
                 "params": {k: jnp.asarray(rng.standard_normal()) for k in names}}
    along = lambda h: jax.tree.map(lambda a, b: a + h * b, y, direction)
    loss = lambda h: float(model(along(h))[0])
    _, gradient, hessian = model(y)
    v = jax.flatten_util.ravel_pytree(direction)[0]
    h = 1e-5
    slope = (loss(h) - loss(-h)) / (2 * h)
    np.testing.assert_allclose(2 * float(gradient @ v), slope, rtol=1e-4)
    assert hessian.shape == (2 * n + len(names),) * 2
    np.testing.assert_allclose(hessian, hessian.T, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("scheme, names, hermite", parameter_model_cases,
                         ids=["four_point", "split_tweak", "corner_cutting"])
def test_model_parameter_columns_match_differences_of_its_gradient(scheme, names, hermite,
                                                                  monkeypatch):
    """The control points' rows of the parameters' columns of the model's Hessian
    against central differences of the control points' (closed-form) gradient along the
    parameters, the feet found afresh, away from the optimum (residuals of about 1% of
    the size). Exact there through the mixed term r . d2C/dP dq (the curve is bilinear
    in the tables and the points). The curve-to-target term is switched off: its
    Gauss-Newton form (as in the control points' own block) adds up to ~1%. Measured
    (largest difference / largest entry, three directions): 2e-10 (corner cutting) to
    2.3e-3; without the mixed term 2-6%, and with the Gauss-Newton blocks of the
    residuals assembled before 2026-12-05 1.2-5%."""
    import fitting._objective as objective_module

    model, y, rng = _parameter_model(scheme, names, hermite)
    # Read when `model` is traced (its first call, below): after the fit, so that no
    # program of `fitting.fit` is compiled, cached or exported without the term.
    monkeypatch.setattr(objective_module, "BACK_WEIGHT", 0.0)
    n = y["control"].shape[0]
    _, _, hessian = model(y)
    h = 1e-5
    for _ in range(3):
        dq = {k: jnp.asarray(rng.standard_normal()) for k in names}
        shift = {"control": jnp.zeros((n, 2)), "params": dq}
        at = lambda h: model(jax.tree.map(lambda a, b: a + h * b, y, shift))[1][: 2 * n]
        difference = np.asarray((at(h) - at(-h)) / (2 * h))
        cross = np.asarray(hessian[: 2 * n, 2 * n:] @ jax.flatten_util.ravel_pytree(dq)[0])
        assert np.max(np.abs(cross - difference)) < 5e-3 * np.max(np.abs(difference))


@pytest.mark.parametrize("scheme, names, hermite", parameter_model_cases,
                         ids=["four_point", "split_tweak", "corner_cutting"])
def test_model_hessian_with_parameters_matches_finite_differences_at_zero_residual(
        scheme, names, hermite):
    """The model's whole Hessian, the scheme parameters' rows and columns included
    (assembled in closed form from the tables' derivatives), against central second
    differences of the loss (feet found afresh) along random directions, at samples
    lying exactly on the model's curve: there the terms the model leaves out (the
    residual times the curve's second derivative in the parameters) vanish, so the
    two must agree. Before the closed form, the Gauss-Newton parameter blocks of the
    Newton-stepped residuals held the same value; a sign or index slip in the
    assembly fails here."""
    from fitting._checks import default_levels
    from fitting._curve import evaluate
    from fitting._objective import FitData, Objective

    n, m = 8, 96
    levels = default_levels(n, m, hermite)
    objective = Objective(n=n, levels=levels, boundary="closed", names=names,
                          hermite=hermite, num_curve=_curve.curve_samples(scheme, n, levels,
                                                                          "closed"),
                          num_target=m)
    P = jnp.asarray(TRUE_CONTROL / 2.0)
    A, V, _ = objective.basis_of(scheme, jnp.float64)
    A, V = A.dense(), None if V is None else V.dense()
    N = A.shape[0]
    # Samples on the model's curve, between its exact samples (not at its vertices,
    # where the chords' distance has a kink).
    tau = jnp.arange(m) * (N / m) + 0.37
    (samples,) = evaluate(A @ P, None if V is None else V @ P, tau, True, order=0)
    args = FitData(target=samples, weights=jnp.ones(m), scheme=scheme,
                   root_smoothing=jnp.sqrt(0.01))
    y = {"control": P, "params": scheme.to_unconstrained(names)}
    model = jax.jit(lambda y: objective.quadratic_model(y, args))
    loss0, gradient, hessian = model(y)
    rng = np.random.default_rng(11)
    for _ in range(3):
        direction = {"control": jnp.asarray(rng.standard_normal((n, 2))),
                     "params": {k: jnp.asarray(rng.standard_normal()) for k in names}}
        along = lambda h: float(model(jax.tree.map(lambda a, b: a + h * b, y, direction))[0])
        v = jax.flatten_util.ravel_pytree(direction)[0]
        h = 1e-4
        curvature = (along(h) - 2 * float(loss0) + along(-h)) / (2 * h**2)
        np.testing.assert_allclose(float(v @ hessian @ v), curvature, rtol=1e-3)
        np.testing.assert_allclose(2 * float(gradient @ v), (along(h) - along(-h)) / (2 * h),
                                   rtol=1e-4, atol=1e-7)


def horse_outline():
    """scikit-image's horse silhouette (`skimage.data.horse()`, public domain): its
    longest contour at level 0.5, resampled to 400 samples by arc length
    (`benchmarks/bench_fit_quality.py`'s `silhouette("horse")`), in pixels. With the
    four-point scheme at n = 24 the profile's best joint fit has a lower loss than the
    fit with w held at 1/16 but a two-sided RMS 7.7% higher (2026-12-07, the same at
    XLA's optimisation levels 0 and 3)."""
    return np.load(Path(__file__).parent / "data" / "skimage_horse.npy")


#: Outlines and schemes on which fit_params=True must not do worse than holding the
#: parameters at their starting values (issue #14: the joint fit alone did, on 5 of 18
#: real outlines; the profile's best joint fit on the horse, until the start was kept).
never_worse_cases = [
    ("a", lambda: glyph_outline("a", 300), js.FourPoint(), 16),
    ("S", lambda: glyph_outline("S", 300), js.SplitTweak(), 16),
    ("g", lambda: glyph_outline("g", 300), js.CornerCutting(), 16),
    ("a", lambda: glyph_outline("a", 300), js.FourPoint(), 24),
    ("horse", horse_outline, js.FourPoint(), 24),
]


@pytest.mark.parametrize("outline, scheme, n", [c[1:] for c in never_worse_cases],
                         ids=[f"{c[0]}-{type(c[2]).__name__}-{c[3]}" for c in never_worse_cases])
def test_fitted_parameters_never_do_worse_than_the_start_held_fixed(outline, scheme, n):
    samples = outline()
    fixed = fitting.fit(samples, scheme, n)
    fitted = fitting.fit(samples, scheme, n, fit_params=True)
    independent = lambda r: two_sided_rms(np.asarray(r.curve), samples)
    # To the solver's tolerance (1e-7): where the start's fit is returned, it comes from
    # the fit_params program, which may round differently from the fixed fit's and stop
    # a step apart (1.2e-9 of the RMS on the horse).
    assert float(fitted.rms) <= float(fixed.rms) * (1 + 1e-7)
    assert independent(fitted) <= independent(fixed) * (1 + 1e-6)
    # Where the start's fit was returned, it has the start's values.
    values = lambda s: [float(x) for x in jax.tree.leaves(s)]
    if bool(fitted.params_held):  # (up to the round trip through the fit's bijection)
        np.testing.assert_allclose(values(fitted.scheme), values(scheme), rtol=1e-12)


def _area(curve):
    """Signed area of a closed polyline (shoelace): a function of the fitted curve that
    does not depend on where its samples start."""
    x, y = curve[:, 0], curve[:, 1]
    return 0.5 * jnp.sum(x * jnp.roll(y, -1) - jnp.roll(x, -1) * y)


def test_the_start_held_fixed_is_kept_with_its_derivatives_where_its_rms_is_lower(monkeypatch):
    """On the horse the profile's joint fit has the higher two-sided RMS, so
    fit_params=True returns the fit with w held at its start: the same control points
    as `fit` with w fixed (its own program), and the same derivatives with respect to
    the samples (the fixed fit's are checked against finite differences above; on a
    pixel silhouette the fit jumps between local minima under small perturbations, so
    differences of it do not converge). Before, the start's fit carried no derivatives: the
    profile is under `stop_gradient`.

    Which local minimum the joint fit reaches depends on rounding, so a differentiated
    program (another program than the concrete fit's) may find a better one and rightly
    return it (one did, in the suite, once the curve was read from its stencil tables:
    w = 0.128, RMS 3.19 against 3.39; so `fit(x)` and `grad` of it may follow different
    minima on this pixel silhouette, a sensitivity of the fit, not of its derivatives,
    which agreed computed directly). The derivatives
    are therefore checked with the choice made for the start (`prefer_start` shown a
    joint RMS of inf; the choice itself is tested below), and the program says so."""
    from fitting import _core

    samples = jnp.asarray(horse_outline())
    scheme = js.FourPoint()
    fixed = fitting.fit(samples, scheme, 24)
    fitted = fitting.fit(samples, scheme, 24, fit_params=True)
    assert float(fitted.scheme.w) == pytest.approx(1 / 16, rel=1e-12)
    assert fixed.params_held is None and bool(fitted.params_held)
    # The same fit to the solver's accuracy: the two programs may round differently
    # (curves 1.5e-7 of the size and RMS 1.2e-9 of itself apart with XLA's fusion
    # emitters off).
    size = float(jnp.max(jnp.ptp(samples, axis=0)))
    np.testing.assert_allclose(fitted.curve, fixed.curve, rtol=0, atol=1e-6 * size)
    assert float(fitted.rms) == pytest.approx(float(fixed.rms), rel=1e-7)
    direction = jnp.asarray(np.random.default_rng(3).standard_normal(samples.shape))
    # Traced, the choice is made by `jnp.where` (as in `fit_batch`); reverse mode goes
    # through the profile's `lax.map` (forward mode too: its rule is a custom JVP).
    # One program each.
    area = lambda x, **kw: _area(fitting.fit(x, scheme, 24, **kw).curve)
    expected = jax.jit(lambda x: jax.jvp(area, (x,), (direction,))[1])(samples)
    assert abs(float(expected)) > 1e-3  # the check below is not of zeros
    choose = _core.prefer_start
    monkeypatch.setattr(_core, "prefer_start", lambda solved, measured, start: choose(
        solved, measured | {"rms": jnp.full_like(measured["rms"], jnp.inf)}, start))
    jax.clear_caches()  # no program traced with the real choice

    def kept(x):
        result = fitting.fit(x, scheme, 24, fit_params=True)
        return _area(result.curve), result.params_held

    try:
        gradient, held = jax.jit(jax.grad(kept, has_aux=True))(samples)
    finally:
        jax.clear_caches()  # nor this one for the tests after
    assert bool(held)
    # (Measured 1e-14 apart: the two differentiated programs' fits agree more closely
    # than the concrete ones above.)
    np.testing.assert_allclose(jnp.sum(gradient * direction), expected, rtol=1e-8)


@pytest.mark.parametrize("joint_rms, start_rms, statuses, keeps_start", [
    (2.0, 1.0, (0, 0), True), (1.0, 2.0, (0, 0), False), (1.0, 1.0, (0, 0), False),
    (np.nan, 1.0, (0, 0), True), (1.0, np.nan, (0, 0), False), (np.nan, np.nan, (0, 0), False),
    (np.inf, 1.0, (0, 0), True), (1.0, np.inf, (0, 0), False),
    # A start's fit that did not converge does not replace a joint fit that did.
    (2.0, 1.0, (0, 1), False), (2.0, 1.0, (1, 0), True), (2.0, 1.0, (1, 1), True),
    (np.nan, 1.0, (0, 1), False),
])
def test_the_choice_of_the_start_on_the_host_and_traced(joint_rms, start_rms, statuses,
                                                        keeps_start):
    """`prefer_start` keeps the joint fit unless the start's RMS is lower, or the joint
    fit's is not a number and the start's is, and the start's fit converged or the
    joint one did not; concrete and traced choices agree."""
    from fitting import _core

    def solved(tag, status):
        arrays = {f.name: jnp.asarray(tag) for f in dataclasses.fields(_core.Solved)
                  if f.name not in ("at_start", "linear_start", "target_to_curve", "tangents",
                                    "creases", "count", "feet")}
        arrays["status"] = jnp.asarray(status)
        return _core.Solved(tangents=None, creases=None, count=None, feet=None, **arrays)

    def choose(joint, start, joint_status, start_status):
        pair = eqx.tree_at(lambda s: s.at_start, solved(1.0, joint_status),
                           solved(2.0, start_status), is_leaf=lambda x: x is None)
        result, measured = _core.prefer_start(pair, {"rms": joint}, {"rms": start})
        return result.num_steps, measured["rms"], measured["params_held"]

    expected = (2.0, start_rms) if keeps_start else (1.0, joint_rms)
    args = (joint_rms, start_rms, *statuses)
    for steps, rms, held in (choose(*args), jax.jit(choose)(*map(jnp.asarray, args))):
        assert float(steps) == expected[0]
        np.testing.assert_equal(float(rms), expected[1])
        assert held.dtype == bool and bool(held) == keeps_start


@pytest.mark.parametrize(
    "change, words",
    [(dict(profile=-1), "`profile` must be"), (dict(profile=9), "the most is 64"),
     (dict(profile=2.5), "`profile` must be")],
)
def test_bad_profile_is_a_clear_error(change, words):
    with pytest.raises((ValueError, TypeError)) as info:
        fitting.fit(blob(100), js.CornerCutting(), 8, fit_params=True, **change)
    assert words in str(info.value)


def test_gradient_on_exact_data_is_finite():
    """Samples exactly on the curve put held curve points on the target polyline: the
    curve-to-target term must still have a finite derivative there."""
    samples = exact_curve(TRUE_CONTROL, js.CubicBSpline(), 6)[::4]
    grad = jax.grad(lambda t: jnp.sum(fitting.fit(t, js.CubicBSpline(), 8).control_points))(
        jnp.asarray(samples)
    )
    assert np.all(np.isfinite(np.asarray(grad)))


def test_a_hopeless_start_is_not_reported_as_converged():
    samples = glyph_outline("S", 150)
    line = np.stack([np.linspace(0, 1, 8), np.zeros(8)], -1)  # collinear control points
    result = fitting.fit(samples, js.FourPoint(1 / 16), 8, init=line, on_failure="ignore")
    size = np.linalg.norm(np.ptp(samples, axis=0))
    assert (not bool(result.converged)) or float(result.rms) < 0.1 * size


def _poor_starts(samples):
    """Starts for a 16-point fit from every 18th of 300 samples: scaled 10x about their
    centre, and moved 10 sizes diagonally (`benchmarks/bench_bad_starts.py`)."""
    corners = samples[::18][:16]
    centre, size = corners.mean(0), np.linalg.norm(np.ptp(samples, axis=0))
    return [centre + 10 * (corners - centre), corners + 10 * size]


@pytest.mark.parametrize("char, which", [("S", 0), ("S", 1), ("a", 0)],
                         ids=["S-scaled_10x", "S-moved_10_sizes", "a-scaled_10x"])
def test_a_start_that_ends_worse_than_the_default_start_says_so(char, which):
    """DejaVu Sans glyphs (300 samples), 16 control points: from these starts the fit
    ends in a local minimum with the two-sided RMS 8-21x that of the fit without
    `init` (as in bad_starts.md), and reported `successful` (issue #14). From 'S' its
    loss is above that of the linear start (which the fit without `init` only lowers);
    from 'a' the loss is below it, but the curve loops away from the samples and its
    RMS is above the linear start's (with the RMS check off, measured: `successful`).
    Both: `poor_local_minimum`, a failure, the last iterate returned."""
    samples = glyph_outline(char, 300)
    default = fitting.fit(samples, js.CubicBSpline(), 16)
    init = _poor_starts(samples)[which]
    with pytest.warns(RuntimeWarning, match="poor_local_minimum"):
        result = fitting.fit(samples, js.CubicBSpline(), 16, init=init)
    assert fitting.STATUSES[int(result.status)] == "poor_local_minimum"
    assert not bool(result.converged)
    assert float(result.rms) > 5 * float(default.rms)
    assert np.all(np.isfinite(np.asarray(result.control_points)))
    # The editor refits from the points a user dragged, and says why a fit failed.
    from jaxsubdiv._editor_state import _fit_status

    assert _fit_status(result).startswith("fit NOT converged (poor_local_minimum): rms")


@pytest.mark.parametrize("rms, linear_rms, status, tol, flagged", [
    (1.11, 1.0, 0, 0.0, True), (1.09, 1.0, 0, 0.0, False), (0.5, 1.0, 0, 0.0, False),
    (2.0, 1.0, 7, 0.0, False), (np.nan, 1.0, 0, 0.0, False), (2.0, np.nan, 0, 0.0, False),
    # Exact data: both near zero, within tol of the size (here 2) of each other.
    (1.9e-7, 1e-9, 0, 1e-7, False), (2.2e-7, 1e-9, 0, 1e-7, True),
])
def test_the_rms_check_of_a_given_start_on_the_host_and_traced(rms, linear_rms, status,
                                                                tol, flagged):
    """`flag_poor_start`: a successful fit from `init` whose two-sided RMS is above 1.1
    times the linear start's plus `tol` of the size becomes `poor_local_minimum`;
    other statuses stay; NaN flags nothing; concrete and traced values agree."""
    from fitting import _core

    arrays = {f.name: jnp.asarray(1.0) for f in dataclasses.fields(_core.Solved)
              if f.name not in ("at_start", "linear_start", "target_to_curve", "tangents",
                                "creases", "count", "feet")}

    def flag(rms, linear_rms, status, tol):
        solved = _core.Solved(tangents=None, creases=None, count=None, feet=None,
                              **(arrays | {"status": status, "scale": jnp.asarray(2.0)}))
        result, measured = _core.flag_poor_start(solved, {"rms": rms}, {"rms": linear_rms},
                                                 tol)
        return result.status, measured["rms"]

    expected = fitting.STATUSES.index("poor_local_minimum") if flagged else status
    args = (jnp.asarray(rms), jnp.asarray(linear_rms), jnp.asarray(status, jnp.int32),
            jnp.asarray(tol))
    for code, kept in (flag(*args), jax.jit(flag)(*args)):
        assert int(code) == expected
        np.testing.assert_equal(float(kept), rms)


def test_a_warm_start_is_not_a_poor_local_minimum():
    """Starts near the optimum (the fit without `init`, moved by noise of 1% of the
    size; that fit of the samples' other half) converge as before, to the default
    fit's RMS: the check does not flag good starts."""
    samples = glyph_outline("S", 300)
    default = fitting.fit(samples, js.CubicBSpline(), 16)
    size = np.linalg.norm(np.ptp(samples, axis=0))
    noise = 0.01 * size * np.random.default_rng(3).standard_normal((16, 2))
    other_half = fitting.fit(samples[1::2], js.CubicBSpline(), 16).control_points
    for init in (np.asarray(default.control_points) + noise, other_half):
        result = fitting.fit(samples, js.CubicBSpline(), 16, init=init, on_failure="raise")
        assert fitting.STATUSES[int(result.status)] == "successful"
        np.testing.assert_allclose(float(result.rms), float(default.rms), rtol=0.02)


@pytest.mark.parametrize("char, start, expected, calls_expected", [
    ("S", "warm", "successful", 1), ("a", "scaled_10x", "poor_local_minimum", 2),
    ("S", "scaled_10x", "poor_local_minimum", 1)], ids=["warm", "rms-rule", "loss-rule"])
def test_the_linear_start_is_measured_only_where_it_decides(monkeypatch, char, start,
                                                            expected, calls_expected):
    """`measure_solved` measures a fit from `init` and, only where its lower bound (the
    start's samples-to-curve half, computed in the solve) does not clear the fit, the
    linear start too: a warm start costs one measurement, a start flagged by its RMS
    two, one already flagged by its loss one. The status is the one that measuring
    everything gives (traced, under `jit`), and the bound is the measured half (the
    skip's premise)."""
    import fitting._fit as fit_module
    from fitting import _core

    samples = glyph_outline(char, 300)
    default = fitting.fit(samples, js.CubicBSpline(), 16)
    init = (np.asarray(default.control_points) if start == "warm"
            else _poor_starts(samples)[0])
    seen = {}

    def capture(data, init, tol, max_steps, *, objective, solver=None, progress=False):
        seen.update(data=data, init=init, tol=tol, max_steps=max_steps, objective=objective)
        raise _Stop

    monkeypatch.setattr(fit_module, "run", capture)
    with pytest.raises(_Stop):
        fitting.fit(samples, js.CubicBSpline(), 16, init=init)
    objective, tol = seen["objective"], seen["tol"]
    solved = _core.solve_jit(seen["data"], seen["init"], tol, seen["max_steps"],
                             objective=objective)
    calls = []

    def measure(*args):
        calls.append(1)
        return _core.measure_jit(*args, closed=objective.closed)

    skipping, _ = _core.measure_solved(solved, objective, tol, measure)
    everything, _ = jax.jit(lambda s: _core.measure_solved(s, objective, tol))(solved)
    assert fitting.STATUSES[int(skipping.status)] == expected
    assert int(everything.status) == int(skipping.status)
    assert len(calls) == calls_expected
    linear = solved.linear_start
    half = _core.measure_jit(*_core.measure_arguments(linear), closed=objective.closed)
    np.testing.assert_allclose(float(linear.scale * linear.target_to_curve),
                               float(half["rms_target_to_curve"]), rtol=1e-12)


def _line(m=40):
    return np.stack([np.linspace(0.0, 1.0, m), 0.3 * np.linspace(0.0, 1.0, m)], -1)


def _square(m=30):
    s = np.linspace(0, 1, m, endpoint=False)
    zero, one = 0 * s, 1 + 0 * s
    return np.concatenate([np.stack([s, zero], -1), np.stack([one, s], -1),
                           np.stack([1 - s, one], -1), np.stack([zero, 1 - s], -1)])


#: Data the scheme represents exactly (the fit without `init` ends at its linear start,
#: RMS ~1e-10), and warm starts there: (samples, n, settings, noise in units of the size).
exact_warm_cases = [
    (_square, 8, dict(corners="auto"), 0.0), (_square, 8, dict(corners="auto"), 1e-3),
    (_line, 6, dict(boundary="clamped", pin_ends=True), 0.0),
    (_line, 6, dict(boundary="clamped", pin_ends=True), 1e-3),
    (_line, 6, dict(boundary="open", pin_ends=True), 1e-6),
]


@pytest.mark.parametrize("shape, n, settings, noise", exact_warm_cases,
                         ids=["square", "square-noise", "line", "line-noise", "open-line"])
def test_a_warm_start_on_exact_data_is_not_a_poor_local_minimum(shape, n, settings, noise):
    """On a square with its corners found, and on a straight line with clamped or open
    pinned ends, the fit without `init` is its linear start, and a warm start ends
    level with it up to rounding: it converges. (The first version of the check
    compared the losses with no tolerance and flagged these, e.g. 4.134949e-17
    against 4.134948e-17, the round trip of the points through the scaling; found in
    review.) The editor's refit of the square, nothing dragged, says converged."""
    samples = shape()
    default = fitting.fit(samples, js.CubicBSpline(), n, on_failure="raise", **settings)
    size = np.linalg.norm(np.ptp(samples, axis=0))
    control = np.asarray(default.control_points)
    init = control + noise * size * np.random.default_rng(1).standard_normal(control.shape)
    result = fitting.fit(samples, js.CubicBSpline(), n, init=init, on_failure="raise",
                         **settings)
    assert fitting.STATUSES[int(result.status)] == "successful"
    if shape is _square and noise == 0.0:
        from jaxsubdiv._editor_state import EditorState

        state = EditorState.from_fit(samples, n_control=n, fit_options=dict(settings))
        state.refit()
        assert state.status.startswith("fit converged"), state.status


def test_fit_under_filter_jit():
    """The fit traced into a larger program gives the fit run on its own, to the
    solver's accuracy: the two are different programs, which XLA may round differently
    (with its fusion emitters off, as in this suite, their control points ended 1.8e-7
    of the size apart, their curves 1.1e-7 and their RMS 6.6e-8 of itself, 29 steps
    each, at the default tol), so they are compared to 1e-6, not bit for bit."""
    samples, _ = _small_problem()
    size = float(jnp.max(jnp.ptp(samples, axis=0)))
    jitted = eqx.filter_jit(lambda t: fitting.fit(t, js.CubicBSpline(), 8, levels=6))
    a, b = jitted(samples), fitting.fit(samples, js.CubicBSpline(), 8, levels=6)
    assert bool(a.converged) and bool(b.converged)
    np.testing.assert_allclose(a.control_points, b.control_points, rtol=0, atol=1e-6 * size)
    np.testing.assert_allclose(a.curve, b.curve, rtol=0, atol=1e-6 * size)
    assert float(a.rms) == pytest.approx(float(b.rms), rel=1e-6)


# --------------------------------------------------------------------------------------
# Bad input


@pytest.mark.parametrize(
    "change, error, words",
    [
        (dict(target=np.zeros((10, 2)) + np.arange(10)[:, None]), ValueError, "samples for"),
        (dict(target=np.full((100, 2), 3.0)), ValueError, "same point"),
        (dict(target=np.zeros(100)), ValueError, "shape (m, d)"),
        (dict(target=np.zeros((100, 1))), ValueError, "shape (m, d)"),
        (dict(n_control=2), ValueError, "n_control=2"),
        (dict(boundary="periodic"), ValueError, "boundary"),
        (dict(fit_params=("w",)), ValueError, "no fittable parameter"),
        (dict(scheme=js.MaskScheme([0.25, 0.75, 0.75, 0.25], -2), fit_params=True), ValueError, "MaskScheme"),
        (dict(scheme=js.Jarek(), fit_params=True), ValueError, "fit t with `SplitTweak(0.5)`"),
        (dict(scheme=js.Chaikin(), fit_params=True), ValueError, "no parameters to fit"),
        (dict(weights=np.ones(5)), ValueError, "weights"),
        (dict(weights=-np.ones(100)), ValueError, "non-negative"),
        (dict(on_failure="shout"), ValueError, "on_failure"),
        (dict(solver="newton"), ValueError, "solver"),
        (dict(scheme="cubic"), TypeError, "scheme"),
        (dict(init=np.zeros((3, 2))), ValueError, "init"),
        (dict(init=np.full((8, 2), np.nan)), ValueError, "init=...)` has non-finite"),
        (dict(target=blob(100).astype(np.complex128)), TypeError, "real float32 or float64"),
        (dict(target=blob(100).astype(np.float16)), TypeError, "real float32 or float64"),
        (dict(weights=np.full(100, np.nan)), ValueError, "non-finite"),
        (dict(smoothing=np.nan), ValueError, "smoothing"),
        (dict(smoothing=np.ones(3)), ValueError, "scalar"),
        (dict(tol=-1.0), ValueError, "finite and positive"),
        (dict(tol=np.nan), ValueError, "finite and positive"),
        (dict(tol="1e-6"), TypeError, "tol"),
        (dict(fit_params=1), TypeError, "fit_params"),
        (dict(scheme=js.FourPoint(0.2), fit_params=True), ValueError, "(0, 0.19"),
        # Resources: refused before anything is allocated, with what it would take.
        (dict(levels=19), ValueError, "GiB, above memory_budget=2,147,483,648 bytes"),
        (dict(memory_budget=10**5), ValueError, "above memory_budget=100,000 bytes"),
        (dict(memory_budget=np.nan), ValueError, "finite number of bytes > 0"),
        (dict(memory_budget=0), ValueError, "finite number of bytes > 0"),
        (dict(memory_budget="2GB"), TypeError, "must be a number of bytes"),
        (dict(target=np.tile(blob(100), (61, 1)), ordered=False), ValueError, "limit is 5000"),
        (dict(target=blob(100) * 1e308), ValueError, "spans more than the largest float64"),
        (dict(levels=1100), ValueError, "`levels` must be <= 40"),
        # order_samples' m x m arrays count too: 4,000 samples need 0.5 GiB for them.
        (dict(target=np.tile(blob(100), (40, 1)), ordered=False, memory_budget=3e8),
         ValueError, "above memory_budget=300,000,000 bytes"),
    ],
)
def test_bad_input_is_a_clear_error(change, error, words):
    args = dict(target=blob(100), scheme=js.CubicBSpline(), n_control=8)
    args.update(change)
    with pytest.raises(error) as info:
        fitting.fit(args.pop("target"), args.pop("scheme"), args.pop("n_control"), **args)
    assert words in str(info.value)


@pytest.mark.parametrize(
    "change, words",
    [
        (dict(targets=[blob(100), np.zeros((100, 3)) + blob(100, seed=1)[:, :1]]), "dimensions"),
        (dict(weights=1.0), "one weight array per target"),
        (dict(devices=[]), "devices"),
        (dict(tol=0.0), "tol"),
        (dict(memory_budget=-1), r"`fit_batch\(memory_budget=...\)` must be a finite"),
        # A 1-D item with a NaN (issue #18: an IndexError from the NaN item's stand-in),
        # with on_failure="raise"; by default it is an item's status (below).
        (dict(targets=[blob(100), np.array([1.0, np.nan])], on_failure="raise"),
         r"`fit_batch\(targets\[1\]\)\(target=...\)` must have shape \(m, d\)"),
        # A setting wrong for every item raises whatever on_failure says.
        (dict(boundary="periodic"), "boundary"),
        # A batch of invalid items raises the first item's error.
        (dict(targets=[np.ones((50, 2)), np.ones((60, 2))]),
         r"`fit_batch\(targets\[0\]\)\(target=...\)`: all samples are the same point"),
    ],
)
def test_bad_batch_input_is_a_clear_error(change, words):
    args = dict(targets=[blob(100), blob(100, seed=1)])
    args.update(change)
    with pytest.raises(ValueError, match=words):
        fitting.fit_batch(args.pop("targets"), js.CubicBSpline(), 8, **args)


def test_non_finite_target_is_a_clear_error():
    for bad in (np.nan, np.inf):
        target = blob(100)
        target[17, 1] = bad
        with pytest.raises(ValueError, match=r"non-finite .* samples \[17\]"):
            fitting.fit(target, js.CubicBSpline(), 8)


def test_open_target_with_closed_boundary_is_a_clear_error():
    with pytest.raises(ValueError, match="looks like an open curve"):
        fitting.fit(blob(100, closed=False), js.CubicBSpline(), 8)


@pytest.mark.parametrize("scale", [1e160, 1e-160, 1e300, 1e-300])
def test_fits_at_any_finite_scale(scale):
    """A fit commutes with scaling (the solver works in units of the outline's size):
    control points, errors and `newton_step` of the outline times 1e+-160 or 1e+-300
    are those of the outline itself, times the scale (once: NaN, or a curve 24% of
    the size away, reported converged)."""
    reference = fitting.fit(blob(100), js.CubicBSpline(), 8, tol=1e-10)
    scaled = fitting.fit(blob(100) * scale, js.CubicBSpline(), 8, tol=1e-10)
    assert bool(scaled.converged)
    np.testing.assert_allclose(np.asarray(scaled.control_points) / scale,
                               reference.control_points, atol=1e-6)
    for name in ("rms", "max_error", "rms_target_to_curve", "max_curve_to_target"):
        np.testing.assert_allclose(float(getattr(scaled, name)) / scale,
                                   float(getattr(reference, name)), rtol=1e-5, err_msg=name)


@pytest.mark.parametrize("scale", [1e300, 1e307, 1e-300, 1e-320])
def test_weights_at_any_finite_scale(scale):
    """Weights are relative: times 1e307 (their sum overflowed) or 1e-320 (subnormal
    numbers, which the compiled program flushed to zero) they give the fit of the same
    weights at unit scale (before: NaN control points, status nonfinite, rms 0)."""
    weights = np.linspace(1.0, 2.0, 100)
    reference = fitting.fit(blob(100), js.CubicBSpline(), 8, weights=weights, tol=1e-10)
    scaled = fitting.fit(blob(100), js.CubicBSpline(), 8, weights=weights * scale, tol=1e-10)
    assert bool(scaled.converged)
    # 1e-320 keeps only 3-4 digits (a multiple of 4.9e-324): other weights, by 2.5e-4.
    atol = 1e-4 if scale < np.finfo(float).tiny else 1e-6
    np.testing.assert_allclose(np.asarray(scaled.control_points), reference.control_points,
                               atol=atol)
    np.testing.assert_allclose(float(scaled.rms), float(reference.rms), rtol=10 * atol)


def test_repeated_samples_are_fine():
    target = np.repeat(blob(100), 2, axis=0)
    result = fitting.fit(target, js.CubicBSpline(), 8)
    assert bool(result.converged) and np.isfinite(float(result.rms))


def test_unordered_under_tracing_is_a_clear_error():
    with pytest.raises(ValueError, match="order_samples"):
        jax.grad(lambda t: fitting.fit(t, js.CubicBSpline(), 8, ordered=False).rms)(
            jnp.asarray(blob(100))
        )


# --------------------------------------------------------------------------------------
# Progress display


def test_progress_is_off_by_default_and_one_line_for_a_batch(capfd, monkeypatch):
    import fitting._progress as progress

    calls = []
    monkeypatch.setattr(progress, "_show", lambda step, loss: calls.append(int(step)))
    samples = blob(90, seed=13)
    fitting.fit(samples, js.CubicBSpline(), 9)
    assert capfd.readouterr().err == "" and calls == []
    single = fitting.fit(samples, js.CubicBSpline(), 9, progress=True)
    # One update per solver step, counted from 0.
    assert calls == list(range(int(single.num_steps)))
    calls.clear()
    items = []
    monkeypatch.setattr(progress, "_show_items", lambda done, total: items.append((int(done), int(total))))
    fitting.fit_batch([samples, blob(90, seed=14), blob(90, seed=15)], js.CubicBSpline(), 9,
                      progress=True)
    # One line for the batch, counting outlines done, and no per-step updates.
    assert items == [(1, 3), (2, 3), (3, 3)] and calls == []


def test_progress_lines_name_the_phase(capfd, monkeypatch):
    """`fit(phases=2, progress=True)` off a terminal: one line per phase, each naming
    it, its last step the phase's own count; then plain "fitting" lines again."""
    import fitting._progress as progress

    monkeypatch.setattr(progress, "_live", lambda: False)
    samples = blob(90, seed=13)
    steps = []
    original = progress._show
    monkeypatch.setattr(progress, "_show", lambda step, loss: (steps.append(int(step)),
                                                               original(step, loss)))
    fitting.fit(samples, js.CubicBSpline(), 9, phases=2, progress=True)
    lines = capfd.readouterr().err.splitlines()
    shown = [line for line in lines if ": step" in line]
    assert [re.match(r"  (fitting, phase \d of 2): step", line)[1] for line in shown] == [
        "fitting, phase 1 of 2", "fitting, phase 2 of 2"]
    # Each phase's line ends at its last step (steps restart from 0 for the second).
    restart = steps.index(0, 1)
    assert [int(re.search(r"step +(\d+)", line)[1]) for line in shown] == [
        steps[restart - 1], steps[-1]]
    fitting.fit(samples, js.CubicBSpline(), 9, progress=True)
    assert re.match(r"  fitting: step", capfd.readouterr().err.splitlines()[-1])


@pytest.mark.parametrize("terminal", [True, False])
def test_elapsed_time_rewrites_a_line_only_on_a_terminal(capfd, monkeypatch, terminal):
    import time

    import fitting._progress as progress

    monkeypatch.setattr(progress, "_live", lambda: terminal)
    with progress.elapsed(interval=0.01):
        time.sleep(0.2)
    err = capfd.readouterr().err
    assert re.fullmatch(r"(\r  fitting: +[0-9.]+ s)+\r  fitting: +[0-9.]+ s, done\n" if terminal
                        else r"  fitting: +[0-9.]+ s, done\n", err), err
    # A fit's steps: the last one stays, written once as a line off a terminal.
    for step, loss in ((0, 2.0), (1, 1.0), (5, 0.5)):
        progress._show(step, loss)
    progress.finish()
    err = capfd.readouterr().err
    assert re.search(r"  fitting: step    5  loss 5\.000e-01 +[0-9.]+ s\n$", err), err
    assert ("\r" in err) == terminal and err.count("\n") == 1 and err.count("step    0") == terminal
    # A batch's count: rewritten on a terminal; elsewhere only the last, as a line (once,
    # however many shares report their last item).
    progress.begin()
    for done in (1, 2, 3, 3):
        progress._show_items(done, 3)
    progress.finish()
    err = capfd.readouterr().err
    assert re.search(r"  fitting: +3 / 3 outlines +[0-9.]+ s\n$", err), err
    assert ("\r" in err) == terminal and err.count("\n") == 1
    assert err.count("3 / 3") == (3 if terminal else 1)  # twice in place, then the end


# --------------------------------------------------------------------------------------
# Compile once: shape buckets and traced settings


def _bumpy(m, phase=0.0):
    angle = 2 * np.pi * (np.arange(m) + phase) / m
    radius = 1 + 0.25 * np.cos(3 * angle)
    return np.stack([radius * np.cos(angle), 0.8 * radius * np.sin(angle)], 1)


def test_new_values_and_lengths_in_one_bucket_compile_nothing(caplog):
    """After one fit, other outlines of other lengths in the same sample-count bucket
    (400 and 440 samples pad to 448; 200 with `pad_to=430`), and new `tol`, `max_steps`,
    `smoothing`, `weights` and four-point `w`, reuse the compiled programs: no XLA
    compilation at all. Fits of other settings share the errors' program."""
    from fitting._params import uses_tangents

    scheme = js.FourPoint(0.06)
    fitting.fit(_bumpy(400), scheme, 10, tol=1e-6, on_failure="ignore")
    # The host's C1 certificate of the new w (eager JAX operations, compiled again after
    # the suite's `jax.clear_caches()` evicts them: seen in full parallel runs) is not
    # the fit: taken before counting.
    uses_tangents(js.FourPoint(0.1), (), "closed")
    with CompileCounter() as compiled:
        for m, options in [
            (440, {}),
            (401, dict(tol=3e-5)),
            (420, dict(max_steps=9)),
            (400, dict(smoothing=0.01)),
            (400, dict(weights=np.linspace(0.5, 2.0, 400))),
            (200, dict(pad_to=430)),  # 200 alone would be the bucket 224
        ]:
            fitting.fit(_bumpy(m, 0.3), scheme, 10, on_failure="ignore", **options)
        fitting.fit(_bumpy(430), js.FourPoint(0.1), 10, on_failure="ignore")
    assert compiled.count == 0
    # Another scheme and control-point count with as many curve samples (20 x 2^6 =
    # 10 x 2^7): a new solve, but the errors' measurement is the same program.
    caplog.set_level(logging.DEBUG)
    with jax.log_compiles():
        result = fitting.fit(_bumpy(430), js.CubicBSpline(), 20, on_failure="ignore")
    compiled = [r.getMessage().split(" with ")[0] for r in caplog.records
                if r.getMessage().startswith("Compiling ")]
    assert result.curve.shape[0] == 1280
    assert "Compiling jit(solve_one)" in compiled, compiled
    assert "Compiling jit(measure_one)" not in compiled, compiled


def test_optimistix_solver_tolerance_and_smoothing_are_data():
    """With one of optimistix's solvers, `tol` (its rtol and atol, array fields of the
    solver), `smoothing` and new samples of the same bucket compile nothing either (its
    step limit is static: optimistix builds its loop from a Python int)."""
    scheme = js.CubicBSpline()
    options = dict(solver="gauss-newton", levels=5, on_failure="ignore")
    fitting.fit(_bumpy(100), scheme, 8, tol=1e-6, **options)
    with CompileCounter() as compiled:
        fitting.fit(_bumpy(100, 0.3), scheme, 8, tol=1e-8, smoothing=0.01, **options)
    assert compiled.count == 0


def test_fit_batch_has_the_defaults_of_fit():
    """A batch item is fitted as `fit` fits it: the arguments both take have the same
    defaults (fit_batch's step limit was 200 against fit's 500, and ended fits that
    `fit` converges: `benchmarks/results/batch_step_limit.md`)."""
    import inspect

    one, batch = (inspect.signature(f).parameters for f in (fitting.fit, fitting.fit_batch))
    shared = sorted(set(one) & set(batch) - {"scheme"})
    assert "max_steps" in shared and "tol" in shared
    assert {k: batch[k].default for k in shared} == {k: one[k].default for k in shared}


def _judge_state(loss, checkpoint, num_steps):
    from fitting._solver import _State

    zero = jnp.zeros(2)
    return _State(hint=None, loss=jnp.asarray(loss), gradient=zero, hessian=jnp.eye(2),
                  damping=jnp.asarray(1e-3), growth=jnp.asarray(2.0),
                  num_steps=jnp.asarray(num_steps), small=jnp.asarray(False),
                  checkpoint=jnp.asarray(checkpoint), terminate=jnp.asarray(False),
                  result=optx.RESULTS.successful)


@pytest.mark.parametrize("num_steps, new_loss, plateau", [
    (49, 1.0 - 0.9e-4, True),   # 50 steps: the loss fell by 0.9e-4 < sqrt(1e-8) = 1e-4
    (49, 1.0 - 1.1e-4, False),  # ... by 1.1e-4: not flat
    (48, 1.0 - 0.9e-4, False),  # checked only every 50 steps
    (99, 1.0 - 0.9e-4, True),
])
def test_a_plateau_of_the_loss_ends_the_fit_as_success(num_steps, new_loss, plateau):
    """The solver's rule (`_solver.judge`): every 50 steps, if the loss fell by at most
    sqrt(rtol) of itself since the last check, the fit has converged. Here the loss
    was 1.0 at the last check, the step (accepted, a decrease well above rtol = 1e-8,
    so the per-step rule does not end it) reaches `new_loss`."""
    from fitting._solver import judge

    state = _judge_state(loss=new_loss + 1e-6, checkpoint=1.0, num_steps=num_steps)
    delta = jnp.array([1e-3, 0.0])
    state = eqx.tree_at(lambda s: s.gradient, state, jnp.array([-1.0, 0.0]))
    verdict = judge(state, delta, state.damping, jnp.asarray(new_loss), jnp.asarray(1e-8),
                    jnp.asarray(0.0), jnp.asarray(500))
    assert bool(verdict.accept)
    assert bool(verdict.terminate) == plateau
    assert verdict.result == optx.RESULTS.successful


@pytest.mark.parametrize("gain, definite, expected", [
    # Close to 1 on both sides: a factor 2 (full against half gradient and Hessian)
    # would move the boundary past one of them.
    (0.9, True, "successful"),  # the Newton step would gain 0.9 of rtol of the loss
    (1.1, True, "nonlinear_divergence"),  # 1.1 of it: more to gain than the tolerance
    (0.5, False, "nonlinear_divergence"),  # an indefinite Hessian: no Newton step
])
def test_a_fit_stuck_within_its_tolerance_of_the_newton_step_converged(gain, definite,
                                                                       expected):
    """The solver's rule (`_solver.settled`, after its loop): a fit that stopped because
    no step lowered the loss has converged if the full Newton step would gain at most
    rtol of the loss (`gain` times that here; the decrement g H^-1 g by numpy), else it
    failed; other results are kept. Float32 fits of smooth blobs stopped so at good
    fits and reported divergence (`benchmarks/results/float32_status.md`)."""
    from fitting._solver import settled

    rng = np.random.default_rng(5)
    a = rng.standard_normal((4, 4))
    H = a @ a.T + np.eye(4) if definite else np.diag([3.0, 1.0, -0.5, 2.0])
    direction = rng.standard_normal(4)
    loss, rtol = 2.0, 1e-5
    target = gain * rtol * loss
    g = direction * np.sqrt(target / abs(direction @ np.linalg.solve(H, direction)))
    if definite:
        np.testing.assert_allclose(g @ np.linalg.solve(H, g), target, rtol=1e-12)
    model = tuple(map(jnp.asarray, (loss, g, H)))
    settle = jax.jit(lambda result: settled(result, model, jnp.asarray(rtol), 0.0))
    assert settle(optx.RESULTS.nonlinear_divergence) == getattr(optx.RESULTS, expected)
    for other in ("successful", "nonlinear_max_steps_reached"):
        assert settle(getattr(optx.RESULTS, other)) == getattr(optx.RESULTS, other)
    # A loss that overflowed is no minimum (inf <= rtol * inf would say it is).
    overflowed = (jnp.asarray(jnp.inf), *model[1:])
    assert (settled(optx.RESULTS.nonlinear_divergence, overflowed, jnp.asarray(rtol), 0.0)
            == optx.RESULTS.nonlinear_divergence)


_FLOAT32_STOPS = """
import json, sys
import numpy as np
import jax
assert not jax.config.jax_enable_x64  # float32 solved in float32
import jaxsubdiv as js, fitting
from fitting import _core
sys.path.insert(0, sys.argv[1])
from _common import blob
targets = [blob(seed, 120) for seed in range(12)]
fit = lambda t: fitting.fit(t, js.CubicBSpline(), 10, on_failure="ignore")
settled = _core.settled
_core.settled = lambda result, *_: result  # the solver's own results
raw = [fitting.STATUSES[int(fit(t).status)] for t in targets]
_core.settled = settled
jax.clear_caches()  # (else the programs compiled without it are used again)
print(json.dumps([raw, [fitting.STATUSES[int(fit(t).status)] for t in targets]]))
"""


def test_float32_fits_stopped_by_rounding_are_settled_by_the_fit():
    """End to end, in float32 (a fresh interpreter without x64, where float32 is
    solved in float32): smooth blobs whose solver stopped with no step lowering the
    loss (`nonlinear_divergence`: 4 of these 12 on this machine, 3 of them settled as
    converged, `benchmarks/results/float32_status.md`) get `_solver.settled`'s verdict
    in `fit`, and no other status changes. The solver's own results come from the same
    fits with `settled` replaced by the identity; its criterion is checked against
    numpy above."""
    # Optimised programs, as users run them (and the benchmark): the suite's level 0
    # rounds differently, and none of these stopped so there.
    env = {k: v for k, v in os.environ.items() if k not in ("JAX_ENABLE_X64", "XLA_FLAGS")}
    bench = str(Path(__file__).resolve().parent.parent / "benchmarks")
    out = subprocess.run([sys.executable, "-c", _FLOAT32_STOPS, bench], env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    raw, settled = json.loads(out.stdout.strip().splitlines()[-1])
    stopped = [i for i, status in enumerate(raw) if status == "nonlinear_divergence"]
    assert stopped, raw  # rounding stopped some (else this checks nothing)
    changed = [i for i in range(12) if settled[i] != raw[i]]
    assert changed and set(changed) <= set(stopped), (raw, settled)
    assert all(settled[i] == "successful" for i in changed), (raw, settled)


def test_a_stuck_fit_with_an_overflowed_loss_did_not_converge():
    """`_solver.judge`: no step lowers the loss, the damping passes its limit, and the
    loss is inf (a start 1e19 times too large in float32): a failure, not the flat
    gradient of a minimum (1e-6 of sqrt(inf) let any gradient pass, and such a fit
    reported converged with an infinite RMS; found in review)."""
    from fitting._solver import judge

    state = eqx.tree_at(lambda s: (s.gradient, s.damping),
                        _judge_state(loss=jnp.inf, checkpoint=jnp.inf, num_steps=7),
                        (jnp.array([6e20, 1.0]), jnp.asarray(1e16)))
    verdict = judge(state, jnp.array([-1e-30, 0.0]), state.damping, jnp.asarray(jnp.inf),
                    jnp.asarray(1e-5), jnp.asarray(0.0), jnp.asarray(500))
    assert not bool(verdict.accept) and bool(verdict.terminate)
    assert verdict.result == optx.RESULTS.nonlinear_divergence


def test_safe_sqrt_keeps_nan_and_has_a_zero_derivative_at_zero():
    """`_curve.safe_sqrt` (every distance the fit reports goes through it): the square
    root where positive, 0 with derivative 0 at 0, and NaN where its input is NaN (it
    returned 0 there, so an overflowed fit reported an RMS of exactly 0)."""
    from fitting._curve import safe_sqrt

    x = jnp.array([4.0, 0.0, jnp.nan, 2.25])
    np.testing.assert_array_equal(np.asarray(safe_sqrt(x)), [2.0, 0.0, np.nan, 1.5])
    slopes = np.asarray(jax.vmap(jax.grad(safe_sqrt))(x))
    np.testing.assert_allclose(slopes[[0, 1, 3]], [0.25, 0.0, 1 / 3])


def test_an_overflowed_fit_reports_no_zero_errors():
    """A start 1e200 times the outline's size (float64): the curve's evaluation
    overflows and the fit stops as a divergence. Its errors are unknown (NaN) or
    infinite, never 0: they read 0.0 while the distances' NaN was mapped to 0."""
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    target = np.stack([np.cos(t), 0.6 * np.sin(t)], -1)
    init = 1e200 * np.stack([np.cos(t[::6]), np.sin(t[::6])], -1)
    result = fitting.fit(target, js.CubicBSpline(), 10, init=init, on_failure="ignore")
    assert int(result.status) != 0
    for name in ("rms", "max_error", "rms_target_to_curve", "rms_curve_to_target",
                 "max_target_to_curve", "max_curve_to_target"):
        value = float(getattr(result, name))
        assert not value < 1e100, (name, value)


def test_a_glyph_sliding_along_a_flat_valley_converges():
    """STIXGeneral 'a' at n = 32 (its outer contour, 400 samples by arc length from its
    first point, as `benchmarks/bench_fit_quality.py` samples it) crawls: every step
    lowers the loss by a little more than tol (1e-7) of itself, with the Hessian
    indefinite, and it ran out of its 500 steps (issue #14; the per-step rule ended it
    at step 1,313, the RMS 4e-4 lower). The plateau rule ended it as converged at step
    100; going on from there (a new fit started at its control points, up to 300 more
    steps, the plateau rule off) lowered the RMS by 0.33% (measured), under 1%. Whether
    it crawls follows the compiled program's rounding: on another machine on 2026-12-07
    the same code converged by the per-step rule at step 39, and reading the curve from
    its stencil tables at step 46, so the steps are not asserted here (the plateau rule
    has its own test above); that it ends within the limit, as converged, and within 1%
    of going on, is."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    path = TextPath((0, 0), "a", size=1.0, prop=FontProperties(family="STIXGeneral"))
    polygons = path.to_polygons(closed_only=True)
    outer = max(polygons, key=lambda p: abs(np.sum(p[:, 0] * np.roll(p[:, 1], -1)
                                                     - np.roll(p[:, 0], -1) * p[:, 1])))
    outer = outer[:-1] if np.allclose(outer[0], outer[-1]) else outer
    samples = resample_closed(outer, 400, offset=0.0)
    result = fitting.fit(samples, js.CubicBSpline(), 32)
    assert bool(result.converged) and int(result.num_steps) < 500
    more = fitting.fit(samples, js.CubicBSpline(), 32, init=result.control_points,
                       max_steps=300, tol=1e-30, on_failure="ignore")
    assert 0 <= float(result.rms - more.rms) < 1e-2 * float(result.rms)


def test_max_steps_is_honoured_as_data():
    result = fitting.fit(_bumpy(300), js.CubicBSpline(), 10, max_steps=4, on_failure="ignore")
    assert int(result.num_steps) == 4 and not bool(result.converged)
    assert "max_steps" in result.message
    # `status` numbers the `fitting.FitStatus` entry, named by `fitting.STATUSES`.
    assert fitting.STATUSES[int(result.status)] == "nonlinear_max_steps_reached"
    assert result.message.startswith("nonlinear_max_steps_reached: ")


@pytest.mark.parametrize("boundary", ["closed", "open"])
@pytest.mark.parametrize("scheme", [js.CubicBSpline(), js.Chaikin()], ids=["hermite", "chords"])
def test_padding_to_a_bucket_does_not_change_the_fit(monkeypatch, boundary, scheme):
    """The same outline fitted padded (to the bucket of 330 samples, 384; closed also to
    3x that) and unpadded gives the same curve and errors: the padding's samples are
    ignored, and a closed outline's seam (the closing chord after the padding) is
    searched as without it. (An open outline has no seam: 3x would test nothing more and
    compile one more program.)"""
    import fitting._fit as fit_module

    samples = _bumpy(330, 0.4)
    if boundary == "open":
        samples = samples[:250]
    # A curve the scheme represents well, so that the optimum is sharp.
    run = lambda: fitting.fit(samples, scheme, 12, boundary=boundary, tol=1e-10, levels=6,
                              on_failure="ignore")
    padded = run()
    bucket = fit_module.bucket
    monkeypatch.setattr(fit_module, "bucket", lambda m, smallest=16: m)
    exact = run()
    others = [padded]
    if boundary == "closed":
        monkeypatch.setattr(fit_module, "bucket", lambda m, smallest=16: 3 * bucket(m, smallest))
        others.append(run())
    for other in others:
        assert bool(other.converged) == bool(exact.converged)
        np.testing.assert_allclose(other.curve, exact.curve, atol=1e-6)
        np.testing.assert_allclose(other.rms, exact.rms, rtol=1e-4)
        np.testing.assert_allclose(other.max_error, exact.max_error, rtol=1e-4)


def test_bucket_sizes():
    from fitting._checks import bucket

    sizes = [bucket(m) for m in range(1, 3000)]
    assert sorted(set(sizes))[:12] == [16, 20, 24, 28, 32, 40, 48, 56, 64, 80, 96, 112]
    assert all(m <= b <= 1.25 * max(m, 13) for m, b in zip(range(1, 3000), sizes))
    assert [bucket(k, smallest=1) for k in range(1, 12)] == [1, 2, 3, 4, 5, 6, 7, 8, 10, 10, 12]


@pytest.fixture
def exported_programs(tmp_path):
    """JAX's compilation cache folder set to a fresh one for this test only: `fit` then
    runs exported programs (`fitting._exported`), kept in it. (JAX itself reads the
    folder once per process, so its compiled programs still go to the suite's cache,
    `conftest.py`.)"""
    import fitting._exported as exported

    previous = jax.config.jax_compilation_cache_dir
    jax.config.update("jax_compilation_cache_dir", str(tmp_path))
    exported._LOADED.clear()
    yield tmp_path / "jaxsubdiv-exported"
    jax.config.update("jax_compilation_cache_dir", previous)
    exported._LOADED.clear()


def test_the_suites_cache_does_not_switch_fits_to_exported_programs():
    """`conftest.py` points JAX at a cache of the suite's own but keeps `fit` on its
    jitted programs (`fitting._exported.folder` is None for that folder): if `fitting`
    stopped looking the folder up through the module, the suite would silently test
    exported programs instead. A fit leaves nothing exported in the suite's folder."""
    import fitting._exported as exported

    folder = Path(jax.config.jax_compilation_cache_dir)
    assert folder.name == "xla" and exported.folder() is None
    fitting.fit(blob(100), js.CubicBSpline(), 8)
    assert not (folder / "jaxsubdiv-exported").exists()


class _Stop(Exception):
    pass


_CIRCLE_8 = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], -1)
exported_structure_cases = [
    (js.CubicBSpline(), {}), (js.Chaikin(), {}), (js.CubicBSpline(), dict(boundary="open")),
    (js.CubicBSpline(), dict(boundary="clamped", pin_ends=True)),
    (js.FourPoint(0.07), dict(fit_params=True, profile=2)),
    # Corners at 4 of the samples: a creased Hermite curve (tangents a pair), and chords.
    (js.CubicBSpline(), dict(corners=[0, 30, 60, 90])),
    (js.FourPoint(0.07), dict(corners=[0, 30, 60, 90])),
    # Fitted parameters without a profile (no fit at the start), on chords, pinned.
    (js.FourPoint(0.07), dict(fit_params=True, profile=0)),
    (js.CornerCutting(), dict(fit_params=True, profile=2)),
    (js.SplitTweak(), dict(fit_params=True, profile=2, boundary="clamped", pin_ends=True)),
    # A given start (its linear start is measured too), alone and with the profile.
    (js.CubicBSpline(), dict(init=_CIRCLE_8)),
    (js.FourPoint(0.07), dict(fit_params=True, profile=2, init=_CIRCLE_8)),
]


@pytest.mark.parametrize("scheme, options", exported_structure_cases,
                         ids=["closed-hermite", "closed-chords", "open-hermite",
                              "clamped-pinned", "fit-params", "creased-hermite",
                              "creased-chords", "fit-params-no-profile",
                              "fit-params-chords", "fit-params-pinned", "init",
                              "fit-params-init"])
def test_exported_solve_structure_is_the_traced_one(monkeypatch, scheme, options):
    """The exported solve returns leaves only; the structure they are put back into is
    built by hand (`_core.solved_structure`). It must be the structure `solve_one`
    returns (traced with `eqx.filter_eval_shape`, nothing compiled) in every configuration,
    or arrays would land in the wrong fields."""
    import fitting._fit as fit_module
    from fitting import _core, _params

    monkeypatch.setattr(_params, "CREASED_HERMITE", True)  # the creased Hermite case
    seen = {}

    def capture(data, init, tol, max_steps, *, objective, solver=None, progress=False):
        traced = eqx.filter_eval_shape(_core.solve_one, data, init, tol, max_steps,
                                       objective=objective, solver=solver)
        seen["traced"] = jax.tree.structure(traced)
        seen["built"] = _core.solved_structure(data.scheme, objective, data.count is not None,
                                               init is not None)
        raise _Stop

    monkeypatch.setattr(fit_module, "run", capture)
    with pytest.raises(_Stop):
        fitting.fit(_bumpy(120), scheme, 8, **options)
    assert seen["traced"] == seen["built"]


def test_exported_program_gives_the_jitted_fit_and_loads_without_tracing(exported_programs):
    """A fit through the program exported to disk equals the jitted fit; a new process
    (here: a cleared in-memory table) loads it without tracing the fit; a damaged file
    is replaced; traced calls (under `jit`) keep the Python path."""
    import fitting._exported as exported

    samples = _bumpy(300, 0.2)
    scheme = js.FourPoint(0.07)
    jax.config.update("jax_compilation_cache_dir", None)
    plain = fitting.fit(samples, scheme, 10, smoothing=1e-3)
    jax.config.update("jax_compilation_cache_dir", str(exported_programs.parent))
    first = fitting.fit(samples, scheme, 10, smoothing=1e-3)
    stored = list(exported_programs.iterdir())
    assert len(stored) == 2  # the solve and the errors' measurement
    for a, b in zip(jax.tree.leaves(first), jax.tree.leaves(plain)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)
    assert first.boundary == plain.boundary and first.levels == plain.levels
    assert float(first.scheme.w) == float(plain.scheme.w)

    exported._LOADED.clear()
    # The host's C1 certificate of the new value (`_params.uses_tangents`, eager JAX
    # operations, which JAX traces again once its own caches have evicted them: seen
    # in a parallel run) is not the fit: taken before listening.
    from fitting._params import uses_tangents

    uses_tangents(js.FourPoint(0.08), (), "closed")
    traces = []
    listen = lambda event, seconds, **kw: traces.append(kw.get("fun_name")) if "trace" in event else None
    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        again = fitting.fit(samples, js.FourPoint(0.08), 10, smoothing=1e-3)
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    assert set(traces) <= {"call_exported"}  # JAX's small wrapper, not the fit
    assert float(again.rms) < 1.5 * float(first.rms)

    exported._LOADED.clear()
    for path in stored:
        path.write_bytes(b"not a program")
    repaired = fitting.fit(samples, scheme, 10, smoothing=1e-3)
    np.testing.assert_allclose(repaired.control_points, first.control_points, rtol=1e-12)
    np.testing.assert_allclose(repaired.rms, first.rms, rtol=1e-12)
    assert all(path.stat().st_size > 1000 for path in stored)

    jitted = eqx.filter_jit(lambda t: fitting.fit(t, scheme, 10, smoothing=1e-3, tol=1e-12).rms)
    # Compiled inside another program, the fit rounds otherwise and stops elsewhere
    # within its tolerance, in a flat valley (a nearly free sliding of the control
    # points): at the default tol (`newton_step` 3e-5, 16 steps) the RMS were 1.6e-7
    # apart, at 1e-10 8e-8 (`newton_step` 2e-6). Converged to 1e-12 (25 steps), measured
    # 2.9e-9 apart; `tol` is traced: the exported program serves this fit too.
    tight = fitting.fit(samples, scheme, 10, smoothing=1e-3, tol=1e-12)
    np.testing.assert_allclose(jitted(samples), tight.rms, rtol=1e-8)
    assert len(list(exported_programs.iterdir())) == 2  # nothing exported under `jit`
