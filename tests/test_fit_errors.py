"""The fit's reported errors against independent dense measurements (issue #14).

The reference curve is scipy's B-spline of the fitted control points (the limit curve of
`CubicBSpline` and `Chaikin`), evaluated at 400,000 parameters; its distances are
measured with scipy's k-d tree and plain numpy, and its arc length by the dense
polyline. Nothing here calls the fit's own distance code.
"""

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import glyph_outline, periodic_bspline, polyline_distances, superellipse
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

import fitting
import jaxsubdiv as js
from fitting import _curve


DENSE = 400_000


def _dense(control, degree, closed):
    """The limit curve at `DENSE` parameters: the closed (periodic) uniform B-spline, or
    the open one on its knots' valid interval (the `open` boundary's limit curve)."""
    control = np.asarray(control)
    n = len(control)
    if closed:
        return periodic_bspline(control, degree)(np.arange(DENSE) * (n / DENSE))
    spline = BSpline(np.arange(n + degree + 1, dtype=float), control, degree)
    return spline(np.linspace(degree, n, DENSE))


def _distance_to_dense(points, dense, closed=True):
    """Each point's distance to the dense polyline: the two chords at its nearest dense
    point (exact for a polyline this fine, whose chords are far shorter than the
    curve's radius of curvature)."""
    _, i = cKDTree(dense).query(points)
    k = len(dense)
    best = np.full(len(points), np.inf)
    before, after = (i - 1) % k, (i + 1) % k
    if not closed:  # the ends have one chord
        before, after = np.maximum(i - 1, 0), np.minimum(i + 1, k - 1)
    for a, b in ((dense[before], dense[i]), (dense[i], dense[after])):
        ab = b - a
        length2 = np.sum(ab**2, -1)
        u = np.clip(np.sum((points - a) * ab, -1) / np.where(length2 > 0, length2, 1), 0, 1)
        best = np.minimum(best, np.linalg.norm(points - a - u[:, None] * ab, axis=-1))
    return best


def independent_errors(control, degree, samples, closed=True):
    """(rms and max target to curve, rms by arc length and max curve to target)."""
    dense = _dense(control, degree, closed)
    to_curve = _distance_to_dense(np.asarray(samples), dense, closed)
    to_target = polyline_distances(dense, samples, closed=closed)
    # Each dense point's share of the arc length: half of each chord it ends.
    if closed:
        chord = np.linalg.norm(np.roll(dense, -1, axis=0) - dense, axis=-1)
        length = 0.5 * (chord + np.roll(chord, 1))
    else:
        chord = np.linalg.norm(np.diff(dense, axis=0), axis=-1)
        length = 0.5 * (np.r_[chord, 0.0] + np.r_[0.0, chord])
    return (np.sqrt(np.mean(to_curve**2)), to_curve.max(),
            np.sqrt(length @ to_target**2 / length.sum()), to_target.max())


# (name, samples, scheme, degree of its limit B-spline, n, boundary): a glyph with a
# narrow waist (tracked feet on the wrong branch), one with many corners, a smooth shape
# on the quadratic B-spline, and an open stroke (the `open` boundary's own ends).
cases = [
    ("glyph_8", lambda: glyph_outline("8"), js.CubicBSpline(), 3, 32, "closed"),
    ("glyph_g", lambda: glyph_outline("g"), js.CubicBSpline(), 3, 32, "closed"),
    ("superellipse_chaikin", lambda: superellipse(300), js.Chaikin(), 2, 16, "closed"),
    ("stroke_open", lambda: glyph_outline("S")[:250], js.CubicBSpline(), 3, 16, "open"),
]


@pytest.mark.parametrize("name, make, scheme, degree, n, boundary", cases,
                         ids=[c[0] for c in cases])
def test_reported_errors_match_a_dense_arc_length_measurement(name, make, scheme, degree, n,
                                                              boundary):
    samples = make()
    result = fitting.fit(jnp.asarray(samples), scheme, n, boundary=boundary)
    reported = [float(getattr(result, field)) for field in (
        "rms_target_to_curve", "max_target_to_curve", "rms_curve_to_target",
        "max_curve_to_target")]
    reference = independent_errors(result.control_points, degree, samples,
                                   closed=boundary == "closed")
    # Measured: within 0.12% on the closed glyphs and the superellipse (the issue asks
    # for 2%); on the open stroke the curve-to-samples max is 0.94% under, a peak at a
    # kink of the samples away from the largest sampled value, which the refinement
    # (near that value only) does not visit. The old curve-to-target RMS,
    # a mean over curve samples uniform in parameter, was 2.2-2.9x this one on glyphs
    # 'S' and 'g' (DejaVu Sans, n = 32), and a tracked foot on the wrong branch of an
    # '8' reported up to 1.8x the true distance (issue #14).
    np.testing.assert_allclose(reported, reference, rtol=1e-2)
    assert float(result.rms) == pytest.approx(max(reference[0], reference[2]), rel=1e-2)
    assert float(result.max_error) == pytest.approx(max(reference[1], reference[3]), rel=1e-2)


def _waist_curve():
    """A closed cubic B-spline shaped like an hourglass lying on its side: two lobes
    joined by a waist 0.04 wide (control points crossed at x = 0), sampled (positions
    and tangents per sample) at the dyadic parameters of 5 levels, as the fit samples
    it: its Hermite interpolant is then the spline itself (a cubic between knots)."""
    control = np.array([[-2, 0], [-1.5, 1], [-0.5, 0.6], [0, -0.27], [0.5, 0.6], [1.5, 1],
                        [2, 0], [1.5, -1], [0.5, -0.6], [0, 0.27], [-0.5, -0.6],
                        [-1.5, -1]], float)
    spline = periodic_bspline(control, 3)
    n = len(control)
    N = n * 2**5
    u = np.arange(N) * (n / N)
    return control, spline(u), spline.derivative()(u) * (n / N)


def test_nearest_point_is_global_where_a_tracked_foot_is_on_the_wrong_branch():
    control, X, V = _waist_curve()
    # Points just above the waist's upper branch (y = 0.02 at x = 0), given feet on the
    # lower branch (y = -0.02): the nearest points of the lower half, as a foot tracked
    # from an earlier curve can be.
    assert np.abs(X[np.argmin(np.abs(X[:, 0])), 1]) == pytest.approx(0.02, abs=1e-3)
    points = np.stack([np.linspace(-0.05, 0.05, 9), np.full(9, 0.04)], -1)
    lower = np.flatnonzero(X[:, 1] < -0.01)  # positions on the lower half
    wrong = lower[np.argmin(np.linalg.norm(points[:, None] - X[lower][None], axis=-1), axis=1)]
    truth = _distance_to_dense(points, _dense(control, 3, closed=True))
    on = lambda tau: _curve.evaluate(jnp.asarray(X), jnp.asarray(V), tau, True, order=0)[0]
    wrong_distance = np.linalg.norm(np.asarray(on(jnp.asarray(wrong, float))) - points, axis=-1)
    assert np.all(wrong_distance > 2 * truth)  # the premise: those feet are far off
    for previous in (None, jnp.asarray(wrong, float)):
        tau = _curve.nearest_on_curve(jnp.asarray(points), jnp.asarray(X), jnp.asarray(V),
                                      True, previous=previous)
        found = np.linalg.norm(np.asarray(on(tau)) - points, axis=-1)
        np.testing.assert_allclose(found, truth, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("closed", [True, False], ids=["closed", "open"])
def test_all_distances_to_a_padded_target_match_brute_force(closed, monkeypatch):
    # The reported maximum's refinement measures a few curve points to every chord of
    # the samples, padded to the program's bucket with copies of the last sample (whose
    # chords have length zero; a closed outline's last closes it), in blocks of points.
    rng = np.random.default_rng(3)
    count, padded = 37, 48
    target = np.cumsum(rng.standard_normal((count, 2)), axis=0)
    target = np.concatenate([target, np.repeat(target[-1:], padded - count, axis=0)])
    points = rng.standard_normal((5, 2)) * 4
    expected = polyline_distances(points, target[:count], closed=closed)
    for block_pairs in (2**22, padded):  # all points at once; one point a block
        monkeypatch.setattr(_curve, "BLOCK_PAIRS", block_pairs)
        segment, fraction = _curve.all_distances(jnp.asarray(points), jnp.asarray(target),
                                                 closed, chunk=64)
        found = _curve.safe_norm(_curve.foot_residual(
            jnp.asarray(points), jnp.asarray(target), segment, fraction, closed))
        np.testing.assert_allclose(np.asarray(found), expected, rtol=1e-12)
