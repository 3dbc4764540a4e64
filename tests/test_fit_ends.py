"""Open strokes with pinned ends (`fitting.fit(pin_ends=True)`, issue #14): the curve
starts at the first sample and ends at the last, exactly, on every curve model (Hermite,
chords, clamped ends, scheme parameters fitted), with derivatives through the constraint.

References are independent of `fitting`: the samples themselves, the limit points of
`jaxsubdiv.refine`'s polygon (the kernel's path, not the fit's stencil tables), scipy's
`BSpline`, and finite differences.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_one_clear_error, glyph_outline
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

import fitting
import jaxsubdiv as js


def _stroke(m=160, seed=0):
    """An open stroke nobody drew for this library: the first 40% of DejaVu Sans 'S'
    (a glyph outline), resampled, with noise, so the first and last samples are noisy."""
    outline = glyph_outline("S", m=400)[:m]
    return outline + 1e-3 * np.random.default_rng(seed).standard_normal(outline.shape)


#: (id, scheme, boundary, fit_params): each curve model the pinned ends must hold on.
pinned_cases = [
    ("bspline_open", js.CubicBSpline(), "open", False),  # Hermite curve
    ("chaikin_open", js.Chaikin(), "open", False),  # chords
    ("four_point_clamped", js.FourPoint(), "clamped", False),  # clamped end rule
    ("four_point_w_open", js.FourPoint(), "open", True),  # the ends' rows depend on w
    ("corner_cutting_rs_clamped", js.CornerCutting(), "clamped", True),
]


@pytest.mark.parametrize("scheme, boundary, fit_params", [c[1:] for c in pinned_cases],
                         ids=[c[0] for c in pinned_cases])
def test_pinned_ends_are_the_end_samples(scheme, boundary, fit_params):
    """The fitted polygon's limit curve, computed by the refinement kernel, starts at the
    first sample of non-zero weight and ends at the last (to rounding); unpinned it
    misses them by 1e-4 to 1e-3 of the size."""
    samples = _stroke()
    weights = np.ones(len(samples))
    weights[0] = 0.0  # switched off: the curve must start at the next sample
    size = np.ptp(samples, 0).max()
    ends = {}
    for pin in (False, True):
        result = fitting.fit(samples, scheme, 10, boundary=boundary, fit_params=fit_params,
                             weights=weights, pin_ends=pin, on_failure="ignore")
        assert np.isfinite(float(result.rms))
        fitted = result.scheme
        polygon = js.refine(result.control_points, fitted, result.levels, boundary=boundary)
        curve = np.asarray(js.limit_points(polygon, fitted, boundary=boundary))
        ends[pin] = np.linalg.norm(curve[[0, -1]] - samples[[1, -1]], axis=-1) / size
        if pin:
            np.testing.assert_allclose(np.asarray(result.curve)[[0, -1]], samples[[1, -1]],
                                       rtol=0, atol=1e-12 * size)
    assert np.all(ends[True] < 1e-12), ends[True]
    assert np.max(ends[False]) > 1e-5, ends[False]  # the test can fail without the pin


def test_pinned_fit_recovers_an_open_bspline():
    """Noise-free samples of an open uniform cubic B-spline (scipy, on its knots' valid
    interval, both ends included; uneven spacing): the pinned fit with as many control
    points recovers the curve to 1e-6 of its size."""
    rng = np.random.default_rng(4)
    n = 10
    angle = np.linspace(0.3, 2.2 * np.pi, n)
    control = np.stack([np.cos(angle) * (1 + 0.1 * angle), np.sin(angle)], 1)
    control += 0.05 * rng.standard_normal(control.shape)
    spline = BSpline(np.arange(n + 4, dtype=float), control, 3)
    u = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 298) ** 1.5]))
    samples = spline(3 + (n - 3) * u)
    result = fitting.fit(samples, js.CubicBSpline(), n, boundary="open", pin_ends=True,
                         tol=1e-12)
    fitted = BSpline(np.arange(n + 4, dtype=float), np.asarray(result.control_points), 3)
    dense = np.linspace(3, n, 200_001)
    true_curve, fitted_curve = spline(dense), fitted(dense)
    gap = max(cKDTree(true_curve).query(fitted_curve)[0].max(),
              cKDTree(fitted_curve).query(true_curve)[0].max())
    assert gap < 1e-6 * np.ptp(samples, 0).max(), gap


def test_derivatives_through_the_pinned_ends():
    """The curve's ends are the end samples (also under `jax.jit`), so their Jacobian
    with respect to the samples is the identity on those two and zero elsewhere (a
    closed form); the control points' derivative along a random direction matches
    central differences."""
    samples = jnp.asarray(_stroke(120, seed=3))
    options = dict(boundary="open", pin_ends=True, tol=1e-12, max_steps=400)
    ends = jax.jacrev(lambda t: fitting.fit(t, js.CubicBSpline(), 8, **options).curve[
        jnp.array([0, -1])])(samples)
    expected = np.zeros((2, 2, 120, 2))
    for k, i in enumerate((0, 119)):
        expected[k, :, i, :] = np.eye(2)
    np.testing.assert_allclose(np.asarray(ends), expected, atol=1e-9)
    # Under `jax.jit` too (the pivots' table was built under the trace and failed).
    jitted = jax.jit(lambda t: fitting.fit(t, js.CubicBSpline(), 8, **options).curve[
        jnp.array([0, -1])])(samples)
    np.testing.assert_allclose(np.asarray(jitted), np.asarray(samples)[[0, -1]], atol=1e-12)

    direction = np.random.default_rng(5).standard_normal(samples.shape)
    weights = np.random.default_rng(6).standard_normal((8, 2))

    def loss(t):
        return jnp.sum(fitting.fit(t, js.CubicBSpline(), 8, **options).control_points
                       * weights)

    derivative = float(jnp.sum(jax.grad(loss)(samples) * direction))
    quotients = [(float(loss(samples + h * direction)) - float(loss(samples - h * direction)))
                 / (2 * h) for h in (1e-4, 1e-5, 1e-6)]
    assert min(abs(derivative - q) for q in quotients) <= 1e-3 * abs(derivative), (
        derivative, quotients)


def test_pinned_batch_matches_single_fits():
    strokes = [_stroke(120, seed=k) for k in range(3)]
    options = dict(boundary="open", pin_ends=True, on_failure="ignore")
    batch = fitting.fit_batch(strokes, js.CubicBSpline(), 8, max_steps=500, **options)
    for k, stroke in enumerate(strokes):
        single = fitting.fit(stroke, js.CubicBSpline(), 8, pad_to=120, **options)
        np.testing.assert_allclose(np.asarray(batch.control_points[k]),
                                   np.asarray(single.control_points), rtol=0, atol=1e-9)
        np.testing.assert_allclose(np.asarray(batch.curve[k])[[0, -1]], stroke[[0, -1]],
                                   rtol=0, atol=1e-12)


#: Bad `pin_ends` values: (keyword arguments, error, words the message must contain).
bad_pins = [
    (dict(pin_ends=True), ValueError, ["pin_ends=True", "boundary='open'"]),
    (dict(pin_ends="yes", boundary="open"), TypeError, ["pin_ends", "True or False"]),
]


@pytest.mark.parametrize("options, error, words", bad_pins, ids=["closed", "not_bool"])
def test_bad_pin_ends_is_a_clear_error(options, error, words):
    outline = glyph_outline("o", m=100)
    assert_one_clear_error(lambda: fitting.fit(outline, js.CubicBSpline(), 8, **options),
                           error, words)
