"""`fitting.pixel_error` and `fit_tolerance(error="pixel")`: errors against the pixels
a contour was traced from (issue #21).

References from elsewhere: bitmaps rasterised here by the pixel-centre test (a pixel is
inside when its centre is: closed-form for a disk and a square, matplotlib's
point-in-polygon for a star); the exact outlines as dense polylines; the distances an
offset square must have, in closed form; the fitted B-spline evaluated by scipy.
"""

import math

import matplotlib.image
import numpy as np
import pytest
from helpers import periodic_bspline, polyline_distances

import fitting
import jaxsubdiv as js


SIZE = 120


def _centres():
    """read_image's coordinates of every pixel centre: pixel (r, c) is (c, SIZE-1-r)."""
    rows, columns = np.mgrid[:SIZE, :SIZE]
    return np.stack([columns.ravel(), SIZE - 1 - rows.ravel()], axis=1).astype(float)


def _traced(tmp_path, inside):
    """The contour `read_image` traces from the bitmap whose pixels `inside` are black."""
    path = tmp_path / "shape.png"
    image = np.where(inside.reshape(SIZE, SIZE), 0.0, 1.0)
    matplotlib.image.imsave(path, image, cmap="gray", vmin=0, vmax=1)
    (outline,) = js.io.read_image(path)
    return outline.points


def _disk(points, radius=30.3, centre=(60.2, 59.7)):
    return np.hypot(points[:, 0] - centre[0], points[:, 1] - centre[1]) < radius


def _disk_outline(radius=30.3, centre=(60.2, 59.7), count=4000):
    angle = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return np.stack([centre[0] + radius * np.cos(angle), centre[1] + radius * np.sin(angle)], 1)


# The square of pixels [20, 79]^2: its true outline is the square [19.5, 79.5]^2.
def _square(points):
    return np.all((points >= 20) & (points <= 79), axis=1)


def _square_outline(offset=0.0):
    low, high = 19.5 - offset, 79.5 + offset
    return np.array([[low, low], [high, low], [high, high], [low, high]])


def _star_vertices():
    # Turned off the grid's axes (0.3 rad), its centre between pixel centres.
    angle = 0.3 + np.arange(10) * np.pi / 5
    radius = np.where(np.arange(10) % 2 == 0, 50.0, 22.5)
    return [60.3, 59.6] + np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def _star(points):
    from matplotlib.path import Path as PolygonPath

    return PolygonPath(_star_vertices()).contains_points(points)


# Shapes whose true outline the pixels do not contradict: pixel error about 0 (it
# crosses every pixel segment and leaves the band of cells the traced contour runs
# through only by its sagitta over a pixel, 1/(8R) = 0.004 px for the disk), while its
# two-sided error against the traced samples is the chamfers' (the square's corner is
# cut by sqrt(2)/4 = 0.354 px).
TRUE_OUTLINES = [
    ("disk", _disk, _disk_outline(), 0.45),
    ("square", _square, _square_outline(), math.sqrt(2) / 4 - 1e-3),
]


@pytest.mark.parametrize("name,inside,outline,sample_error", TRUE_OUTLINES,
                         ids=[case[0] for case in TRUE_OUTLINES])
def test_the_true_outline_has_no_pixel_error(tmp_path, name, inside, outline, sample_error):
    samples = _traced(tmp_path, inside(_centres()))
    error = fitting.pixel_error(outline, samples)
    # Both halves measured on a polyline at 0.05 px spacing: to within 0.025 px.
    assert error.max_error < 0.03
    two_sided = max(polyline_distances(samples, outline).max(),
                    polyline_distances(outline, samples).max())
    assert two_sided > sample_error


# The square's outline moved out (or in) by `offset`: the pixels allow half a pixel.
# Beyond it the curve misses the pixel segments along the sides by |offset| - 1/2, as
# far from the band's cells there; moved out, its corner is sqrt(2) (|offset| - 1/2)
# from the band's corner cell, diagonally; moved in, as far from the two pixel segments
# of the traced contour's chamfer.
OFFSETS = [(0.3, 0.0, 0.0), (1.4, 0.9, 0.9 * math.sqrt(2)), (-1.4, 0.9 * math.sqrt(2), 0.9)]


@pytest.mark.parametrize("offset,segments,band", OFFSETS)
def test_an_offset_square_has_the_closed_form_pixel_error(tmp_path, offset, segments, band):
    samples = _traced(tmp_path, _square(_centres()))
    error = fitting.pixel_error(_square_outline(offset), samples)
    assert error.max_segment_distance == pytest.approx(segments, abs=0.03)
    assert error.max_band_distance == pytest.approx(band, abs=0.03)
    assert error.max_error == max(error.max_segment_distance, error.max_band_distance)


def test_a_fits_pixel_error_is_that_of_its_curve_evaluated_by_scipy(tmp_path):
    """A FitResult is measured on its limit curve, evaluated more densely than its own
    `curve` (levels=2 here: 4 points per span): the same figure as scipy's closed cubic
    B-spline of its control points, densely sampled; and no more than its error against
    the samples (which lie on their pixel segments, in the band)."""
    samples = _traced(tmp_path, _disk(_centres()))
    result = fitting.fit(samples, js.CubicBSpline(), 12, levels=2, on_failure="ignore")
    curve = periodic_bspline(np.asarray(result.control_points, dtype=float), 3)
    dense = curve(np.linspace(0, 12, 12 * 400, endpoint=False))
    ours, theirs = fitting.pixel_error(result, samples), fitting.pixel_error(dense, samples)
    assert ours.max_error == pytest.approx(theirs.max_error, abs=0.03)
    assert ours.max_band_distance == pytest.approx(theirs.max_band_distance, abs=0.03)
    assert ours.max_error <= float(result.max_error) + 0.03
    assert fitting.pixel_error(result.curve, samples).max_error != pytest.approx(
        ours.max_error, abs=0.03)  # its own 48 points would not do


def test_a_creased_fits_pixel_error_is_that_of_its_refined_polygon(tmp_path):
    """With creases (the square's four corners), the limit curve measured is the creased
    one: as the control polygon refined 8 times with `jaxsubdiv.refine` (its pieces
    between creases, within 1e-3 px of their limit)."""
    samples = _traced(tmp_path, _square(_centres()))
    corners = fitting.find_corners(samples, pixel=1.0)
    result = fitting.fit(samples, js.CubicBSpline(), 8, levels=2, corners=corners,
                         on_failure="ignore")
    creases = np.flatnonzero(np.asarray(result.creases))
    assert len(creases) == 4
    refined = js.refine(np.asarray(result.control_points, dtype=float), js.CubicBSpline(), 8,
                        creases=creases.tolist())
    ours = fitting.pixel_error(result, samples)
    theirs = fitting.pixel_error(np.asarray(refined), samples)
    assert ours.max_error == pytest.approx(theirs.max_error, abs=0.03)
    assert ours.max_band_distance == pytest.approx(theirs.max_band_distance, abs=0.03)


def test_a_star_fitted_to_a_pixel_tolerance_its_samples_cannot_give(tmp_path, capsys):
    """The traced star's tips are cut short by about a pixel, so no curve with sharp
    tips is within 0.3 px of the samples; against the pixels the creased 10-point
    curve is, with its creases within half a pixel of the true vertices."""
    from test_cli import cli

    samples = _traced(tmp_path, _star(_centres()))
    assert fitting.pixel_error(_star_vertices(), samples).max_error < 0.15
    assert polyline_distances(_star_vertices(), samples).max() > 0.6  # the tips' chamfer
    status, out, err = cli(capsys, "fit", tmp_path / "shape.png", "--tolerance", 0.3, "-q",
                           "-o", tmp_path / "star.json")
    assert status == 0, err
    assert "within 0.3 (max error; a PNG's traced contours against its pixels)" in out
    assert "control    10 points (pixel error by count tried:" in out
    saved = js.io.read_result_json(tmp_path / "star.json")
    pixel = float(out.split("  vs pixels  ")[1].split()[0])
    assert pixel <= 0.3
    assert saved.info["pixel_error"] == pytest.approx(pixel, rel=1e-2)
    gaps = np.linalg.norm(saved.control_points[:, None] - _star_vertices()[None], axis=-1)
    assert gaps.min(axis=1).max() < 0.5 and len(set(gaps.argmin(axis=1))) == 10
    maximum = float(out.split("  max error  ")[1].split()[0])
    assert maximum > 0.6  # its error against the samples: the tolerance could not be met


def test_samples_not_as_traced_are_refused_before_any_fit(tmp_path, monkeypatch):
    samples = _traced(tmp_path, _disk(_centres()))
    resampled = js.io.resample_polyline(samples, 300, True)
    with pytest.raises(ValueError, match=r"lie between no two pixel centres.*read_image"):
        fitting.pixel_error(_disk_outline(), resampled)
    # Every third sample: still on rows and columns of pixel centres, but each chord
    # crosses cells, and the samples' own polyline would leave the band.
    with pytest.raises(ValueError, match=r"cross more than one pixel cell.*subsampled"):
        fitting.pixel_error(_disk_outline(), samples[::3])
    monkeypatch.setattr(fitting._tolerance, "fit", lambda *a, **k: pytest.fail("fitted"))
    with pytest.raises(ValueError, match=r"fit_tolerance\(target=...\)` with `error='pixel'"):
        fitting.fit_tolerance(resampled, js.CubicBSpline(), 0.5, error="pixel")
    with pytest.raises(ValueError, match=r"closed traced contours.*error='max_error'"):
        fitting.fit_tolerance(samples, js.CubicBSpline(), 0.5, error="pixel", boundary="open")
    with pytest.raises(ValueError, match=r"must be 'max_error', 'rms' or 'pixel'"):
        fitting.fit_tolerance(samples, js.CubicBSpline(), 0.5, error="hausdorff")


def test_samples_near_a_pixel_centre_keep_their_pixel_segment(tmp_path):
    """An antialiased ring of grey 128/255 around the square, thresholded at 0.50156:
    the contour passes 8e-4 px from the grey pixels' centres, still between them and
    the background's. The square through the middle of those pixel segments (its sides
    1.5 px out) crosses every one of them: pixel error 0, not half a pixel."""
    from PIL import Image

    image = np.zeros((SIZE, SIZE), np.uint8)
    image[19:81, 19:81] = 128
    image[20:80, 20:80] = 255  # pixels 20..79 of the square, rows and columns alike
    path = tmp_path / "ring.png"
    Image.fromarray(image, "L").save(path)
    (outline,) = js.io.read_image(path, threshold=0.50156)
    samples = outline.points
    fraction = np.abs(samples - np.round(samples))
    assert 5e-4 < fraction.max(axis=1).min() < 1e-3  # the premise: near, not at, centres
    # Columns 19..80 are x = 19..80; rows 19..80 are y = SIZE - 1 - row = 39..100. The
    # pixel segments run from the grey centres one pixel out: their middles are 0.5 out.
    square = np.array([[18.5, 38.5], [80.5, 38.5], [80.5, 100.5], [18.5, 100.5]])
    assert fitting.pixel_error(square, samples).max_error < 0.03


@pytest.mark.parametrize("curve,match", [
    (np.zeros((5, 3)), r"FitResult or the points \(N, 2\)"),
    (np.array([[0.0, 0.0], [np.nan, 1.0]]), "non-finite"),
])
def test_bad_curves_are_named(tmp_path, curve, match):
    samples = _traced(tmp_path, _square(_centres()))
    with pytest.raises(ValueError, match=match):
        fitting.pixel_error(curve, samples)


def test_a_failed_fit_is_a_miss_of_the_pixel_search(tmp_path, monkeypatch):
    """A fit whose curve is not finite (its status says why) is a miss of the search,
    not an error of `pixel_error`; the others are measured against the pixels (stubbed
    here: an error of 40/n px, so n = 40 is the smallest ladder count within 1 px)."""
    import equinox as eqx
    import jax.numpy as jnp

    import fitting._tolerance as search

    class Stub(eqx.Module):
        control_points: np.ndarray
        curve: np.ndarray
        status: jnp.ndarray
        max_error: float = 99.0

        @property
        def converged(self):
            return self.status == 0

    samples = _traced(tmp_path, _disk(_centres()))
    calls = []

    def fake_fit(target, scheme, n, **options):
        calls.append(n)
        curve = np.full((4, 2), np.nan if n in (16, 20) else 0.0)
        return Stub(np.zeros((n, 2)), curve, jnp.asarray(0, jnp.int32))

    def fake_pixel_error(result, points):
        if not np.all(np.isfinite(result.curve)):  # as the real one refuses it
            raise ValueError("the fit's curve has non-finite points")
        return fitting.PixelError(*[40 / len(result.control_points)] * 3)

    monkeypatch.setattr(search, "fit", fake_fit)
    monkeypatch.setattr(search, "pixel_error", fake_pixel_error)
    result = fitting.fit_tolerance(samples, js.CubicBSpline(), 1.0, error="pixel")
    assert result.control_points.shape[0] == 40 and 16 in calls and 32 in calls
