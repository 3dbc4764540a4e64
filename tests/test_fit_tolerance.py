"""`fitting.fit_tolerance`: the fewest control points within a tolerance (issue #21).

References from elsewhere: the ladder of counts written out by hand; each reported error
re-measured by brute force between the fitted curve and the samples' polyline (numpy,
`helpers.polyline_distances`); minimality checked by a separate `fitting.fit` at the
next smaller count of the ladder.
"""

import warnings

import numpy as np
import pytest
from helpers import glyph_outline, polyline_distances

import fitting
import jaxsubdiv as js
from fitting._tolerance import ladder


# Glyphs of three fonts, the tolerance a fraction of the em (the glyphs are ~0.7 em tall).
GLYPHS = [("S", "DejaVu Serif"), ("g", "DejaVu Sans"), ("a", "STIXGeneral")]
TOLERANCE = 0.01


def brute_force_hausdorff(curve, samples):
    """The larger of the two directed maxima between the closed polylines."""
    return max(polyline_distances(samples, curve).max(),
               polyline_distances(curve, samples).max())


def test_ladder_is_four_counts_per_octave():
    assert ladder(4, 130) == [4, 5, 6, 7, 8, 10, 12, 14, 16, 20, 24, 28, 32, 40, 48, 56,
                              64, 80, 96, 112, 128]
    assert ladder(9, 33) == [10, 12, 14, 16, 20, 24, 28, 32]


@pytest.mark.parametrize("char,family", GLYPHS)
def test_tolerance_met_with_fewest_counts_on_glyphs(char, family):
    samples = glyph_outline(char, 400, family)
    tried = {}
    result = fitting.fit_tolerance(samples, js.CubicBSpline(), TOLERANCE, corners="auto",
                                   on_trial=lambda n, r: tried.update({n: r}))
    n = result.control_points.shape[0]
    assert bool(result.converged)
    assert float(result.max_error) <= TOLERANCE
    # The reported figure is the brute-force one (the curve is its exact limit points).
    measured = brute_force_hausdorff(np.asarray(result.curve), samples)
    assert measured <= TOLERANCE
    assert measured == pytest.approx(float(result.max_error), rel=0.02)
    # The next smaller count of the ladder misses it (fitted again, independently).
    smaller = max(k for k in ladder(4, n) if k < n)
    below = fitting.fit(samples, js.CubicBSpline(), smaller, corners="auto")
    assert brute_force_hausdorff(np.asarray(below.curve), samples) > TOLERANCE
    assert n in tried and smaller in tried


def test_tolerance_not_reached_says_so_and_returns_the_best():
    # Noise of 2% of the radius: no curve gets within 1e-4 of every sample.
    rng = np.random.default_rng(0)
    t = 2 * np.pi * np.arange(200) / 200
    samples = np.stack([np.cos(t), np.sin(t)], 1) + 0.02 * rng.standard_normal((200, 2))
    tried = {}
    with pytest.warns(RuntimeWarning, match="n_max=8.*tolerance_not_reached"):
        result = fitting.fit_tolerance(samples, js.CubicBSpline(), 1e-4, n_min=6, n_max=8,
                                       on_trial=lambda n, r: tried.update({n: r}))
    assert fitting.STATUSES[int(result.status)] == "tolerance_not_reached"
    assert not bool(result.converged)
    assert float(result.max_error) == min(float(r.max_error) for r in tried.values())
    with pytest.raises(RuntimeError, match="tolerance_not_reached"):
        fitting.fit_tolerance(samples, js.CubicBSpline(), 1e-4, n_min=6, n_max=8,
                              on_failure="raise")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fitting.fit_tolerance(samples, js.CubicBSpline(), 1e-4, n_min=6, n_max=8,
                              on_failure="ignore")


@pytest.mark.parametrize("kwargs,error,match", [
    ({"tolerance": 0.0}, ValueError, "tolerance.*> 0"),
    ({"tolerance": float("nan")}, ValueError, "tolerance"),
    ({"tolerance": "small"}, TypeError, "tolerance"),
    ({"tolerance": 0.1, "error": "mean"}, ValueError, "error"),
    ({"tolerance": 0.1, "n_control": 8}, TypeError, "n_control"),
    ({"tolerance": 0.1, "n_min": 8, "n_max": 6}, ValueError, "n_max"),
    ({"tolerance": 0.1, "boundary": "loop"}, ValueError, "boundary"),
])
def test_bad_arguments_are_named(kwargs, error, match):
    t = 2 * np.pi * np.arange(100) / 100
    samples = np.stack([np.cos(t), np.sin(t)], 1)
    with pytest.raises(error, match=match):
        fitting.fit_tolerance(samples, js.CubicBSpline(), **kwargs)


def test_not_a_scheme_and_not_under_jit():
    import jax

    t = 2 * np.pi * np.arange(100) / 100
    samples = np.stack([np.cos(t), np.sin(t)], 1)
    with pytest.raises(TypeError, match="curve scheme"):
        fitting.fit_tolerance(samples, "cubic", 0.1)
    with pytest.raises(TypeError, match="on the host"):
        jax.jit(lambda T: fitting.fit_tolerance(T, js.CubicBSpline(), 0.1).rms)(samples)
