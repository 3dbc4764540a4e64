"""jaxsubdiv.plot: what each helper draws, read back from the artists it returns and
checked against independent references (a plain-Python Chaikin loop, a by-definition
refinement, scipy's B-splines, published Hölder exponents)."""

import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import (
    chaikin_python,
    periodic_bspline,
    polyline_distances,
    refine_by_definition,
)

import jaxsubdiv as js
import jaxsubdiv.plot as jplot


def _closed(points):
    return np.vstack([points, points[:1]])


def _image_std(figure, tmp_path, name="figure.png"):
    import matplotlib.image

    path = tmp_path / name
    figure.savefig(path)
    return float(matplotlib.image.imread(path)[..., :3].std())


def _on_curve(points, curve, period, per_unit):
    """Largest distance of `points` from `curve(offset + i / per_unit)`, for the best
    offset among the points' possible parameters (multiples of 1 / (2 per_unit))."""
    candidates = np.arange(0, period, 0.5 / per_unit)
    offset = candidates[np.argmin(np.linalg.norm(curve(candidates) - points[0], axis=1))]
    expected = curve(offset + np.arange(len(points)) / per_unit)
    return float(np.max(np.linalg.norm(points - expected, axis=1)))


def test_plot_levels_draws_the_polygon_its_refinements_and_its_limit(tmp_path):
    pi = js.shapes.get("pi")
    size = np.linalg.norm(np.ptp(pi, axis=0))
    row = jplot.plot_levels(pi, js.Chaikin(), (0, 1, 2, 20), title="pi, Chaikin")
    assert len(row.panels) == 4
    # Level 0 is exactly the shape's control polygon, closed by its first point.
    np.testing.assert_array_equal(row.panels[0].curve.get_xydata(), _closed(pi))
    np.testing.assert_array_equal(row.panels[0].control.get_xydata(), _closed(pi))
    for panel, level in zip(row.panels[1:3], (1, 2)):
        expected = _closed(chaikin_python(pi, level, closed=True))
        np.testing.assert_allclose(panel.curve.get_xydata(), expected, rtol=0, atol=1e-13)
    # Level 20 (20 million points) is drawn as exact points of the limit curve, the
    # periodic quadratic B-spline of the polygon, at the parameters of a coarser level.
    drawn = row.panels[3].curve.get_xydata()[:-1]
    per_unit = len(drawn) // len(pi)
    assert per_unit >= 64 and per_unit & (per_unit - 1) == 0  # 2^k points per edge
    error = _on_curve(drawn, periodic_bspline(pi, 2), len(pi), per_unit)
    assert error < 1e-12 * size
    assert "level 20 (20,971,520 points) drawn as the exact limit curve" in row.caption
    assert "below a pixel" in row.caption
    assert "levels 0, 1, 2 computed with jaxsubdiv.refine" in row.caption
    assert _image_std(row.figure, tmp_path) > 0.05


def test_plot_levels_interpolating_scheme_keeps_the_polygon_at_every_level():
    U = js.shapes.get("U")
    row = jplot.plot_levels(U, js.FourPoint(1 / 16), (0, 3, 16), max_points=1000)
    for panel in row.panels:
        drawn = panel.curve.get_xydata()[:-1]
        step = len(drawn) // len(U)
        np.testing.assert_allclose(drawn[::step], U, rtol=0, atol=1e-13)
    # Level 3 is refined (112 points); level 16 is drawn from limit points.
    assert len(row.panels[1].curve.get_xydata()) == 8 * len(U) + 1
    assert "limit_points" in row.panels[2].method
    assert "the scheme interpolates" in row.caption


def test_plot_levels_draws_into_given_axes_and_checks_them():
    from matplotlib.figure import Figure

    axes = Figure().subplots(1, 2)
    row = jplot.plot_levels(js.shapes.get("star"), js.CubicBSpline(), (0, 1), axes=axes)
    assert row.panels[1].ax is axes[1]
    with pytest.raises(ValueError, match="one per level"):
        jplot.plot_levels(js.shapes.get("star"), js.CubicBSpline(), (0, 1, 2), axes=axes)
    with pytest.raises(ValueError, match="levels"):
        jplot.plot_levels(js.shapes.get("star"), js.CubicBSpline(), (-1,))


def test_plot_curve_draws_polygon_and_refined_curve():
    star = js.shapes.get("star")
    scheme = js.CubicBSpline()
    artists = jplot.plot_curve(star, scheme, 3)
    np.testing.assert_array_equal(artists.control.get_xydata(), _closed(star))
    expected = refine_by_definition(star, np.asarray(scheme.mask()), scheme.mask_start, 3,
                                    "closed")
    np.testing.assert_allclose(artists.curve.get_xydata(), _closed(expected), atol=1e-13)
    # Open polygons are not closed up.
    artists = jplot.plot_curve(star, js.Chaikin(), 2, closed=False, ax=artists.ax)
    np.testing.assert_allclose(artists.curve.get_xydata(), chaikin_python(star, 2, False),
                               atol=1e-13)


def _circle(m, radius=2.0, center=(1.0, -0.5)):
    angle = 2 * np.pi * (np.arange(m) + 0.3) / m
    return np.stack([center[0] + radius * np.cos(angle), center[1] + radius * np.sin(angle)], 1)


def test_plot_fit_colors_samples_by_their_distance_to_the_curve(tmp_path):
    # A cubic B-spline with 10 control points on a circle and samples of a wobbly circle
    # (a FitResult is drawn in test_cli: `jaxsubdiv fit --plot`; here anything with
    # control points, a scheme and a boundary, so no fit has to be compiled).
    angle = 2 * np.pi * np.arange(10) / 10
    control = np.stack([1 + 2.1 * np.cos(angle), -0.5 + 2.1 * np.sin(angle)], 1)
    samples = _circle(160)
    samples += 0.01 * np.cos(7 * np.linspace(0, 2 * np.pi, 160, endpoint=False))[:, None]
    fit = SimpleNamespace(control_points=control, scheme=js.CubicBSpline(), boundary="closed")
    artists = jplot.plot_fit(fit, samples)
    # Reference: distances to scipy's periodic cubic B-spline of the control points,
    # sampled densely (chords of 3e-4 on a radius of 2: sagittas of 6e-9). plot_fit's
    # polyline has chords of 8e-4: sagittas of 4e-8.
    dense = periodic_bspline(control, 3)(np.linspace(0, 10, 40_000, endpoint=False))
    reference = polyline_distances(samples, dense)
    assert reference.max() > 2 * reference.min() > 0  # far from uniform
    np.testing.assert_allclose(artists.distances, reference, rtol=0, atol=1e-7)
    np.testing.assert_array_equal(np.asarray(artists.samples.get_array()), artists.distances)
    np.testing.assert_array_equal(artists.samples.get_offsets(), samples)
    np.testing.assert_array_equal(artists.control.get_xydata(), _closed(control))
    assert artists.colorbar is not None
    assert _image_std(artists.ax.figure, tmp_path) > 0.05
    # Seen, not hidden (issue #18): the curve and polygon are drawn over the samples, and
    # the legend lies below the axes, over no data.
    assert artists.curve.get_zorder() > artists.samples.get_zorder()
    assert artists.control.get_zorder() > artists.samples.get_zorder()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(artists.ax.figure).get_renderer()
    legend = artists.ax.get_legend().get_window_extent(renderer)
    assert legend.y1 <= artists.ax.get_window_extent(renderer).y0
    # A result saved to JSON and read back draws the same.
    path = tmp_path / "fit.json"
    js.io.write_result_json(path, {"control_points": control, "scheme": js.CubicBSpline()})
    again = jplot.plot_fit(js.io.read_result_json(path), samples, colorbar=False)
    np.testing.assert_allclose(again.distances, artists.distances, rtol=0, atol=1e-15)
    assert again.colorbar is None
    with pytest.raises(ValueError, match="index a batch"):
        jplot.plot_fit(SimpleNamespace(control_points=np.zeros((2, 10, 2)),
                                       scheme=js.CubicBSpline()), samples)


def test_plot_loss_and_its_scale():
    values = 10.0 ** -np.arange(8)
    line = jplot.plot_loss(values)
    np.testing.assert_array_equal(line.get_xdata(), np.arange(8))
    np.testing.assert_array_equal(line.get_ydata(), values)
    assert line.axes.get_yscale() == "log"
    line = jplot.plot_loss([1.0, 0.0, -1.0])
    assert line.axes.get_yscale() == "linear"
    with pytest.raises(ValueError, match="values"):
        jplot.plot_loss(np.zeros((2, 2)))


def test_plot_smoothness_matches_published_exponents():
    # Four-point scheme: w = 0 is piecewise linear (exponent 1); w = 1/16 has exponent 2
    # (Dyn, Gregory and Levin 1987; Daubechies and Lagarias 1992).
    artists = jplot.plot_smoothness(js.FourPoint, [0.0, 1 / 16, 0.1], label="w")
    np.testing.assert_allclose(artists.lower[:2], [1.0, 2.0], atol=1e-3)
    assert np.all(artists.lower <= artists.upper + 1e-12)
    np.testing.assert_array_equal(artists.exponent.get_ydata(), artists.lower)
    assert artists.ax.get_xlabel() == "w"
    # Corner cutting on s = r + 1/2: exponent 1 - log2(max(2r, 1 - 2r)) (Chaikin at 1/4).
    r = np.array([0.1, 0.25, 0.4])
    artists = jplot.plot_smoothness(lambda v: js.CornerCutting(v, v + 0.5), r)
    expected = 1 - np.log2(np.maximum(2 * r, 1 - 2 * r))
    assert np.all(artists.lower - 1e-3 <= expected) and np.all(expected <= artists.upper + 1e-3)


def test_importable_and_usable_without_a_display(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "MPLBACKEND")}
    code = (
        "import sys, jaxsubdiv, jaxsubdiv.plot as p\n"
        "a = p.plot_curve(jaxsubdiv.shapes.get('jar'), jaxsubdiv.Chaikin(), 4)\n"
        f"a.ax.figure.savefig({str(tmp_path / 'jar.png')!r})\n"
        "print('pyplot' if 'matplotlib.pyplot' in sys.modules else 'no pyplot')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "no pyplot"
    import matplotlib.image

    assert matplotlib.image.imread(tmp_path / "jar.png")[..., :3].std() > 0.02


@pytest.mark.parametrize("closed", [True, False], ids=["closed", "open"])
@pytest.mark.parametrize("vertices, samples", [(33, 7), (1001, 3000), (20_000, 1500)])
def test_sample_distances_equal_brute_force(closed, vertices, samples):
    """plot_fit's distances measure only the blocks of segments that can hold a
    sample's nearest point (issue #18: the brute force took 26-35 s for a silhouette's
    picture); the result is the brute force's, every segment checked, to rounding:
    samples near, far (outside the curve's hull) and on it."""
    from jaxsubdiv._plot import _segment_distances

    rng = np.random.default_rng(vertices)
    theta = np.linspace(0, 2 * np.pi, vertices, endpoint=False)
    curve = np.stack([np.cos(theta) * (1 + 0.3 * np.cos(5 * theta)), np.sin(theta)], 1)
    points = curve[rng.integers(0, vertices, samples)] + 0.05 * rng.standard_normal((samples, 2))
    points[:3] = [[5.0, 5.0], [0.0, 0.0], curve[1]]
    np.testing.assert_allclose(_segment_distances(points, curve, closed),
                               polyline_distances(points, curve, closed), rtol=0, atol=1e-14)
