"""Fits with corners (`fitting.fit(corners=...)`, `fitting.find_corners`), issue #21.

The references are closed forms: a five-point star's vertices (the fitted curve must pass
through them, to the solver's tolerance), a polygon's exact representation by creased
control points, a circular sector's exact distance, and shapes without corners
(ellipse, superellipse, a traced disk's pixel staircase) on which no corner may be
found.
"""

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import fitting
import jaxsubdiv as js


def polygon_samples(vertices, m, phase=0.0):
    """`m` samples evenly spaced by arc length along a closed polygon, the first at
    fraction `phase` of its length from vertex 0 (so samples miss the vertices)."""
    V = np.asarray(vertices, float)
    edges = np.roll(V, -1, axis=0) - V
    length = np.linalg.norm(edges, axis=1)
    cumulative = np.concatenate([[0.0], np.cumsum(length)])
    s = np.mod(np.arange(m) / m + phase, 1.0) * cumulative[-1]
    i = np.searchsorted(cumulative, s, side="right") - 1
    return V[i] + ((s - cumulative[i]) / length[i])[:, None] * edges[i]


def star(k=5, outer=1.0, inner=0.45):
    angle = np.pi / 2 + np.arange(2 * k) * np.pi / k
    radius = np.where(np.arange(2 * k) % 2 == 0, outer, inner)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def sector_samples(angle, m, phase=0.0):
    """`m` samples evenly spaced by arc length along the outline of a circular sector of
    radius 1 and opening `angle` (radians): the radius along x, the arc, the radius
    back; the first at fraction `phase` of the perimeter from the centre."""
    s = np.mod(np.arange(m) / m + phase, 1.0) * (2 + angle)
    on_arc = s - 1
    back = 2 + angle - s
    direction = np.array([np.cos(angle), np.sin(angle)])
    return np.where((s < 1)[:, None], s[:, None] * [1.0, 0.0],
                    np.where((s < 1 + angle)[:, None],
                             np.stack([np.cos(on_arc), np.sin(on_arc)], axis=1),
                             back[:, None] * direction))


def sector_distance(points, angle):
    """Each point's exact distance to that sector's outline."""
    direction = np.array([np.cos(angle), np.sin(angle)])
    radii = [np.linalg.norm(points - np.clip(points @ e, 0, 1)[:, None] * e, axis=1)
             for e in (np.array([1.0, 0.0]), direction)]
    phi = np.arctan2(points[:, 1], points[:, 0])
    ends = np.minimum(np.linalg.norm(points - [1.0, 0.0], axis=1),
                      np.linalg.norm(points - direction, axis=1))
    arc = np.where((phi >= 0) & (phi <= angle), np.abs(np.linalg.norm(points, axis=1) - 1), ends)
    return np.minimum(np.minimum(*radii), arc)


def smooth_shapes():
    t = 2 * np.pi * np.arange(400) / 400
    ellipse = np.stack([np.cos(t), 0.4 * np.sin(t)], axis=1)
    c, s = np.cos(t), np.sin(t)
    superellipse = np.stack([np.sign(c) * np.abs(c) ** 0.5, np.sign(s) * np.abs(s) ** 0.5], 1)
    return [("ellipse", ellipse), ("superellipse_4", superellipse)]


def traced_disk(radius=40.5):
    """The outline of a disk's pixels (a 4-connected staircase) through the pixel-edge
    midpoints, as a marching-squares contour of a binary image gives it."""
    contourpy = pytest.importorskip("contourpy")
    size = int(2 * radius) + 8
    y, x = np.mgrid[:size, :size]
    image = ((x - size / 2) ** 2 + (y - size / 2) ** 2 <= radius**2).astype(float)
    lines = contourpy.contour_generator(z=image).lines(0.5)
    return max(lines, key=len)[:-1]


def distance_to_curve(points, curve):
    """Each point's distance to the closed polyline `curve` (dense: within its chords'
    sagitta of the curve)."""
    a, b = curve, np.roll(curve, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("pij,ij->pi", points[:, None] - a, ab)
                / np.maximum(np.sum(ab**2, 1), 1e-300), 0, 1)
    foot = a + t[..., None] * ab
    return np.min(np.linalg.norm(points[:, None] - foot, axis=2), axis=1)


def test_find_corners_on_a_star_and_a_square():
    V = star()
    samples = polygon_samples(V, 400, phase=0.013)
    found = fitting.find_corners(samples)
    assert len(found) == 10
    # Each vertex's nearest sample is a corner (samples miss the vertices by < spacing).
    nearest = np.argmin(np.linalg.norm(samples[:, None] - V[None], axis=2), axis=0)
    assert sorted(found.tolist()) == sorted(nearest.tolist())
    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    samples = polygon_samples(square, 97, phase=0.3)
    found = fitting.find_corners(samples)
    nearest = np.argmin(np.linalg.norm(samples[:, None] - np.array(square)[None], axis=2), 0)
    assert sorted(found.tolist()) == sorted(nearest.tolist())
    # A square sampled from its vertices, 4 samples a side: each vertex.
    assert sorted(fitting.find_corners(polygon_samples(square, 16)).tolist()) == [0, 4, 8, 12]
    # A 40-degree turn (at vertex 1) is not a corner at the default 50, and is at 30.
    bent = [[0, 0], [1, 0], [1 + np.cos(0.7), np.sin(0.7)], [0, 2]]
    samples = polygon_samples(bent, 300, 0.1)
    turn = np.argmin(np.linalg.norm(samples - np.array(bent[1]), axis=1))
    assert turn not in fitting.find_corners(samples)
    assert turn in fitting.find_corners(samples, angle=30)


@pytest.mark.parametrize("name, samples", smooth_shapes())
def test_no_corners_on_smooth_shapes(name, samples):
    assert fitting.find_corners(samples).size == 0


def test_no_corners_on_a_pixel_staircase():
    """A traced disk of radius 40.5 px: its staircase turns 90 degrees at every step,
    but over 3 sample spacings it averages out."""
    assert fitting.find_corners(traced_disk()).size == 0


def regular_polygon(k, rotation):
    angle = rotation + 2 * np.pi * np.arange(k) / k
    return np.stack([np.cos(angle), np.sin(angle)], axis=1)


def traced_polygon(vertices, radius):
    """A polygon scaled to `radius` pixels, rasterised (a pixel is black when its centre
    is inside, matplotlib's point-in-polygon test) and traced by marching squares
    through the pixel-edge midpoints (`contourpy`, as `read_image` does); returns the
    contour and the vertices in its pixel units."""
    contourpy = pytest.importorskip("contourpy")
    from matplotlib.path import Path as PolygonPath

    size = int(2 * radius) + 10
    y, x = np.mgrid[:size, :size]
    corners = np.asarray(vertices) * radius + size / 2
    inside = PolygonPath(corners).contains_points(np.stack([x.ravel(), y.ravel()], 1))
    lines = contourpy.contour_generator(z=inside.reshape(size, size).astype(float)).lines(0.5)
    return max(lines, key=len)[:-1], corners


TRACED_POLYGONS = [
    (name, vertices, radius)
    for name, make in [("star", lambda r: star(k=5, inner=0.45) @ [[np.cos(r), np.sin(r)],
                                                                   [-np.sin(r), np.cos(r)]]),
                       ("triangle", lambda r: regular_polygon(3, r)),
                       ("square", lambda r: regular_polygon(4, r)),
                       ("pentagon", lambda r: regular_polygon(5, r))]
    for radius in (60, 200)
    for rotation in (0.0, 0.1, 0.3)
    for vertices in [make(rotation)]
]


@pytest.mark.parametrize("name, vertices, radius", TRACED_POLYGONS,
                         ids=[f"{n}-{r}px-{i % 3}" for i, (n, _, r) in enumerate(TRACED_POLYGONS)])
def test_corners_of_a_traced_bitmap_in_pixels(name, vertices, radius):
    """Polygons whose corners turn 63 degrees or more (a star's inner corners; its tips
    135, a pentagon's 72), traced from bitmaps at 60 and 200 px and three rotations:
    `pixel=1` finds one corner within 2.5 px of every vertex and nothing else. (The
    staircase of an edge near an axis tilts a 3-px chord by up to 18 degrees: corners
    within about 10 degrees of `angle`, a hexagon's 60, can be missed; the benchmark
    `benchmarks/bench_corners.py` counts them.)"""
    contour, corners = traced_polygon(vertices, radius)
    found = contour[fitting.find_corners(contour, pixel=1.0)]
    distance = np.linalg.norm(found[:, None] - corners[None], axis=2)
    assert len(found) == len(corners)
    assert distance.min(axis=0).max() < 2.5  # every vertex found
    assert distance.min(axis=1).max() < 2.5  # nothing else


@pytest.mark.parametrize("radius", [30.5, 100.5])
def test_no_corners_on_a_traced_disk_in_pixels(radius):
    """Disks traced at 30 and 100 px radius: no corners with `pixel=1` either (a bend
    of radius R turns about (scale + skip) / R = 5 / R radians, 10 degrees at 30 px)."""
    assert fitting.find_corners(traced_disk(radius), pixel=1.0).size == 0


def test_pixel_scales_with_the_pixel_size():
    """`pixel=` is a length in the samples' units: the same traced star in units of
    128 pixels with `pixel=1/128` gives the same corners (a power of two: the same
    rounding; staircase samples tie in turning, so other units may pick a neighbour);
    `scale` and `skip` given explicitly override the pixel defaults."""
    contour, _ = traced_polygon(star(), 60)
    found = fitting.find_corners(contour, pixel=1.0)
    assert len(found) == 10
    np.testing.assert_array_equal(fitting.find_corners(contour / 128, pixel=1 / 128), found)
    np.testing.assert_array_equal(
        fitting.find_corners(contour, scale=4.0, skip=1.0), found)


def traced_glyph(family, char, size):
    """A glyph's exact outline (its Bezier segments from matplotlib's `TextPath`,
    evaluated at 200 parameters each), scaled to 80% of a `size`-px square, and the
    contours of its bitmap (a pixel black when its centre is inside, even-odd) traced
    by marching squares as `read_image` does; with the joints of its segments where
    the outline turns by 30 degrees or more (its corners)."""
    contourpy = pytest.importorskip("contourpy")
    from matplotlib.font_manager import FontProperties
    from matplotlib.path import Path as PolygonPath
    from matplotlib.textpath import TextPath

    path = TextPath((0, 0), char, size=1.0, prop=FontProperties(family=family))
    u = np.linspace(0, 1, 200, endpoint=False)
    outline, current = [], []
    for segment, code in path.iter_bezier():
        if code == path.MOVETO and current:
            outline.append(np.concatenate(current))
            current = []
        elif code not in (path.MOVETO, path.CLOSEPOLY):
            current.append(segment(u))
    outline.append(np.concatenate(current))
    points = np.concatenate(outline)
    low, high = points.min(0), points.max(0)
    outline = [(c - (low + high) / 2) * (0.8 * size / (high - low).max()) + size / 2
               for c in outline]
    corners = []
    for c in outline:
        joint = np.arange(0, len(c), 200)
        before, after = c[joint] - c[joint - 1], c[(joint + 1) % len(c)] - c[joint]
        cosine = np.sum(before * after, 1) / np.maximum(
            np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1), 1e-300)
        corners.append(c[joint[cosine < np.cos(np.radians(30))]])
    y, x = np.mgrid[:size, :size]
    centres = np.stack([x.ravel(), y.ravel()], 1).astype(float)
    inside = np.zeros(len(centres), bool)
    for c in outline:
        inside ^= PolygonPath(c).contains_points(centres)
    lines = contourpy.contour_generator(z=inside.reshape(size, size).astype(float)).lines(0.5)
    # y negated: outer contours then run clockwise, as `read_image` gives them.
    flip = np.array([1.0, -1.0])
    return ([c * flip for c in outline], np.concatenate(corners) * flip,
            [line[:-1] * flip for line in lines])


def test_creases_stay_at_the_corners_of_a_traced_glyph():
    """STIXGeneral 'S' traced from a 256-px bitmap, corners measured in pixels, 39
    control points (potrace's count for it): every crease within 2 px of its corner
    sample, and the curve within 1 px of the glyph's exact outline (potrace: 1.11 px;
    measured 1.43 and 0.63 px). While a corner sample's foot could slide anywhere
    along the curve, creases drifted off their corners (2.8 px) and the error was
    1.91 px."""
    outline, corners, (contour,) = traced_glyph("STIXGeneral", "S", 256)
    found = fitting.find_corners(contour, pixel=1.0)
    # The corners found are within 2 px of the glyph's (measured up to 1.7 px), but for
    # one tight bend, 10 px from any joint that turns 30 degrees or more.
    near = np.linalg.norm(contour[found][:, None] - corners[None], axis=2).min(1)
    assert np.sum(near > 2.0) <= 1
    result = fitting.fit(contour, js.CubicBSpline(), 39, corners=found, on_failure="ignore")
    creased = np.asarray(result.control_points)[np.asarray(result.creases)]
    assert len(creased) == len(found)
    assert np.linalg.norm(creased[:, None] - contour[found][None], axis=2).min(1).max() < 2.0
    truth = np.concatenate(outline)
    curve = np.asarray(result.curve)
    hausdorff = max(distance_to_curve(curve, truth).max(),
                    distance_to_curve(truth[::4], curve).max())
    assert hausdorff < 1.0


def test_a_mirror_image_fits_alike():
    """The traced STIXGeneral 'S' of the test above and its mirror image (y negated;
    the same corners): the fitted curves are equally far from the exact outline, and
    each piece between corners gets the same spans. While the spans came from rounding
    cumulative shares from the first corner in the samples' canonical order (which a
    mirror image changes), one moved between pieces ([.., 15, 1, 1, ..] against
    [.., 1, 14, 1, 2, ..]) and the errors were 0.63 and 1.86 px."""
    outline, _, (contour,) = traced_glyph("STIXGeneral", "S", 256)
    found = fitting.find_corners(contour, pixel=1.0)
    flip = np.array([1.0, -1.0])
    first = fitting.fit(contour, js.CubicBSpline(), 39, corners=found, on_failure="ignore")
    mirror = fitting.fit(contour * flip, js.CubicBSpline(), 39, corners=found,
                         on_failure="ignore")
    truth = np.concatenate(outline)
    errors = [max(distance_to_curve(curve, truth).max(), distance_to_curve(truth[::4], curve).max())
              for curve in (np.asarray(first.curve), np.asarray(mirror.curve) * flip)]
    assert abs(errors[0] - errors[1]) < 0.01, errors
    # The spans between consecutive creases: the same cyclic sequence, run backwards.
    gaps = []
    for result in (first, mirror):
        creases = np.flatnonzero(np.asarray(result.creases))
        gaps.append(np.diff(np.append(creases, creases[0] + 39)))
    assert any(np.array_equal(np.roll(gaps[0], k), gaps[1][::-1]) for k in range(len(gaps[0]))), gaps


def test_star_corners_are_exact_points_of_the_fitted_curve():
    """n = 20 for the 10 corners: two spans per edge, and a clamped cubic piece through
    three collinear control points is the straight edge, so the star is representable
    exactly. The fitted curve passes through every vertex to the solver's tolerance,
    the creased control points are the vertices, and the smooth fit misses them."""
    V = star()
    samples = polygon_samples(V, 400, phase=0.013)
    smooth = fitting.fit(samples, js.CubicBSpline(), 20)
    result = fitting.fit(samples, js.CubicBSpline(), 20, corners="auto")
    assert bool(result.converged)
    creased = np.asarray(result.control_points)[np.asarray(result.creases)]
    assert creased.shape == (10, 2)
    # The fitted curve through each vertex (the creased points are curve points).
    size = np.ptp(V, axis=0).max()
    vertex_error = distance_to_curve(V, np.asarray(result.curve))
    assert vertex_error.max() < 1e-6 * size
    assert distance_to_curve(V, creased).max() < 1e-6 * size
    # Every sample on the curve.
    assert float(result.rms_target_to_curve) < 1e-6 * size
    assert distance_to_curve(V, np.asarray(smooth.curve)).max() > 1e-3 * size


def test_feet_on_a_creased_hermite_curve_are_its_nearest_points():
    """The creased cubic B-spline modelled as the fit models it (exact limit samples,
    Hermite segments with one-sided tangents at the creases: the exact curve, piecewise
    cubic with knots at the samples) and the global nearest point on it
    (`_curve.nearest_on_curve`): each point's distance is at least its distance to the
    curve refined 12 levels (brute force; chords 2^-12 of a span) and at most that
    plus the documented bound, twice the largest distance of a segment from its chord
    (4/27 of its tangents' differences from the chord, where two branches nearly tie;
    equal on most points), and points just outside a corner have their foot exactly
    at that corner's sample (where Newton's method alone only approaches it)."""
    from fitting import _curve

    P = star()
    n, levels = len(P), 4
    creases = np.zeros(n, bool)
    creases[::2] = True  # the tips
    position, tangents = _curve.creased_tables(js.CubicBSpline(), n, levels, creases,
                                               np.float64, True)
    X = position.apply(P)
    V = tuple(t.apply(P) for t in tangents)
    rng = np.random.default_rng(0)
    tips = P[::2] * 1.05  # in the normal cones of the tips
    points = np.concatenate([rng.uniform(-1.1, 1.1, (300, 2)), tips])
    tau = _curve.nearest_on_curve(jnp.asarray(points), X, V, True)
    (foot,) = _curve.evaluate(X, V, tau, True, order=0)
    dense = np.asarray(js.limit_curve(P, js.CubicBSpline(), 12, creases=creases))
    want = distance_to_curve(points, dense)
    got = np.linalg.norm(np.asarray(foot) - points, axis=1)
    chord = np.roll(np.asarray(X), -1, axis=0) - np.asarray(X)
    after, before = (np.asarray(v) for v in V)
    bound = 2 * 4 / 27 * np.max(np.linalg.norm(after - chord, axis=1)
                                + np.linalg.norm(np.roll(before, -1, axis=0) - chord, axis=1))
    sagitta = 1e-7  # of the dense chords (spans up to 0.6 long, curvature up to ~10)
    assert np.all(got >= want - sagitta) and np.all(got <= want + bound)
    assert np.mean(np.abs(got - want) < sagitta) > 0.8
    corner_samples = np.flatnonzero(creases) * 2**levels
    np.testing.assert_array_equal(np.asarray(tau)[-len(tips):], corner_samples)
    # Tracked from nearby positions on either side (as the solver's steps track feet),
    # Newton's steps alone cross the corner back and forth; they end at it.
    previous = np.concatenate([corner_samples - 0.4, corner_samples + 0.3]).astype(float)
    tracked = _curve.locate(jnp.asarray(np.concatenate([tips, tips])), X, V, True, 4,
                            previous=jnp.asarray(previous))
    np.testing.assert_array_equal(np.asarray(tracked), np.concatenate([corner_samples] * 2))


@pytest.mark.parametrize("m, phase", [(200, 0.013), (200, 0.37), (400, 0.2)])
def test_sparse_samples_do_not_pull_the_corners_in(m, phase):
    """The samples next to a corner cut it; the curve-to-samples term once pulled the
    fitted corner towards that chord (200 samples: tips 0.35% of the size inside).
    The chords at corner samples now leave the curve free by their length."""
    V = star()
    result = fitting.fit(polygon_samples(V, m, phase), js.CubicBSpline(), 20, corners="auto")
    assert bool(result.converged)
    size = np.ptp(V, axis=0).max()
    assert distance_to_curve(V, np.asarray(result.curve)).max() < 1e-6 * size


@pytest.mark.parametrize("scale", [1e-150, 1e150])
def test_corners_at_any_finite_scale(scale):
    """The same star at 1e-150 and 1e150: the same creases and the same curve, scaled."""
    samples = polygon_samples(star(), 200, 0.2)
    unit = fitting.fit(samples, js.CubicBSpline(), 20, corners="auto")
    scaled = fitting.fit(samples * scale, js.CubicBSpline(), 20, corners="auto")
    np.testing.assert_array_equal(np.asarray(scaled.creases), np.asarray(unit.creases))
    np.testing.assert_allclose(np.asarray(scaled.curve) / scale, np.asarray(unit.curve),
                               atol=1e-9)


def test_corners_at_samples_of_weight_zero_are_dropped():
    """A corner at an ignored sample is not data: with none left, the smooth fit."""
    V = star()
    samples = polygon_samples(V, 200, 0.2)
    weights = np.ones(200)
    corners = fitting.find_corners(samples)
    weights[corners[0]] = 0.0
    result = fitting.fit(samples, js.CubicBSpline(), 20, corners=list(corners), weights=weights)
    assert int(np.sum(result.creases)) == len(corners) - 1
    only = fitting.fit(samples, js.CubicBSpline(), 20, corners=[int(corners[0])],
                       weights=weights)
    assert only.creases is None


def test_corners_do_not_depend_on_where_the_samples_start():
    """The same star samples, cyclically shifted and reversed: the same curve."""
    samples = polygon_samples(star(), 400, phase=0.013)
    first = fitting.fit(samples, js.CubicBSpline(), 20, corners="auto")
    for variant in (np.roll(samples, 137, axis=0), samples[::-1]):
        other = fitting.fit(variant, js.CubicBSpline(), 20, corners="auto")
        np.testing.assert_allclose(np.asarray(other.curve), np.asarray(first.curve),
                                   atol=1e-8)


def test_refine_with_the_creases_gives_the_fitted_curve():
    """`result.creases` as `refine(creases=...)` indices: the fitted polygon refined and
    pushed to its limit piece by piece is `result.curve` (the fit's own samples)."""
    samples = polygon_samples(star(inner=0.6), 400, phase=0.2)
    result = fitting.fit(samples, js.CubicBSpline(), 20, corners="auto")
    creases = np.flatnonzero(np.asarray(result.creases)).tolist()
    P = np.asarray(result.control_points)
    n, rows = len(P), 2**result.levels
    pieces = []
    for k, c in enumerate(creases):
        end = creases[k + 1] if k + 1 < len(creases) else creases[0] + n
        piece = P[np.arange(c, end + 1) % n]
        refined = js.refine(piece, js.CubicBSpline(), result.levels, boundary="clamped")
        pieces.append(np.asarray(js.limit_points(refined, js.CubicBSpline(),
                                                 boundary="clamped"))[:-1])
    curve = np.roll(np.concatenate(pieces), creases[0] * rows, axis=0)
    np.testing.assert_allclose(curve, np.asarray(result.curve), atol=1e-12)


def test_corners_compile_once():
    """Stars of other sizes and phases (other corners) reuse the compiled programs."""
    from helpers import CompileCounter

    fitting.fit(polygon_samples(star(), 400, 0.01), js.CubicBSpline(), 20, corners="auto")
    with CompileCounter() as compiled:
        for inner, phase in ((0.3, 0.2), (0.6, 0.7)):
            samples = polygon_samples(star(inner=inner), 400, phase)
            fitting.fit(samples, js.CubicBSpline(), 20, corners="auto")
        square = polygon_samples([[0, 0], [2, 0], [2, 1], [0, 1]], 400, 0.05)
        fitting.fit(square, js.CubicBSpline(), 20, corners="auto")
    assert compiled.count == 0


def test_no_corners_found_is_the_smooth_fit():
    name, samples = smooth_shapes()[0]
    a = fitting.fit(samples, js.CubicBSpline(), 20, corners="auto")
    b = fitting.fit(samples, js.CubicBSpline(), 20)
    assert a.creases is None
    np.testing.assert_array_equal(np.asarray(a.control_points), np.asarray(b.control_points))


def test_corner_errors():
    samples = polygon_samples(star(), 200, 0.1)
    with pytest.raises(ValueError, match="boundary='closed'"):
        fitting.fit(samples, js.CubicBSpline(), 20, boundary="open", corners="auto")
    with pytest.raises(ValueError, match="primal"):
        fitting.fit(samples, js.Chaikin(), 20, corners="auto")
    with pytest.raises(ValueError, match="center"):
        fitting.fit(samples, js.LaneRiesenfeld(3), 20, corners="auto")
    with pytest.raises(ValueError, match="at least as many control points as corners"):
        fitting.fit(samples, js.CubicBSpline(), 4, corners=[0, 20, 40, 60, 80])
    with pytest.raises(ValueError, match="None, 'auto' or sample indices"):
        fitting.fit(samples, js.CubicBSpline(), 20, corners="yes")
    with pytest.raises(ValueError, match="angle"):
        fitting.find_corners(samples, angle=200)
    for bad in ({"pixel": 0.0}, {"pixel": np.nan}, {"scale": -1.0}, {"skip": -0.5},
                {"skip": 0.1, "scale": 0.1}):
        with pytest.raises(ValueError, match=f"find_corners\\({next(iter(bad))}=") as raised:
            fitting.find_corners(samples, **bad)
        assert str(raised.value)
    with pytest.raises(ValueError, match="traced"):
        jax.jit(lambda t: fitting.fit(t, js.CubicBSpline(), 20, corners="auto").rms)(samples)


def test_corners_with_64_bit_floats_off():
    """JAX's default precision (float32): the reach of a crease is measured in float64
    regardless (in float32 every row differed, and every creased call, fits with corners
    included, failed)."""
    import subprocess
    import sys

    code = (
        "import numpy as np, jaxsubdiv as js, fitting\n"
        "c = js.limit_curve(np.eye(5, 2, dtype=np.float32), js.FourPoint(), 2, creases=[0, 3])\n"
        "print(c.shape, c.dtype)\n"
        "t = js.curve_stencil(js.CubicBSpline(), 6, 3, creases=np.eye(6, dtype=bool)[2])\n"
        "print(t.weights.dtype, t.width)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600, env={k: v for k, v in __import__("os").environ.items()
                                            if k != "JAX_ENABLE_X64"})
    assert done.returncode == 0, done.stderr
    first, second = done.stdout.split("\n")[:2]
    assert first == "(20, 2) float32", done.stdout
    assert second.startswith("float32 "), done.stdout


@pytest.mark.parametrize("phase, step, n",
                         [(0.013, False, 6), (0.37, False, 6), (0.013, True, 14)])
def test_a_short_bent_piece_between_corners_gets_a_free_control_point(phase, step, n):
    """A 20-degree sector of the unit disk, n = 6: its arc is 15% of the outline, less
    than one span's share, and one span between two creases is a straight segment,
    whose maximum distance from the arc is at least half the arc's sagitta (1.5e-2).
    The arc, being bent (at 400 samples it strays 2.6 spacings from its chord), gets
    two spans (a free control point between its creases): the two-sided maximum error
    against the exact sector is below a fifth of the sagitta (measured 1.0e-3; 1.06e-2
    when it got one span). `step`: a fourth corner, given, 0.03 before the arc on the
    radius, and n = 14: the arc's share is 2.09 spans, but rounding gives the tiny
    straight piece before it (0.18) a span, which once came from the arc."""
    angle = np.radians(20.0)
    samples = sector_samples(angle, 400, phase)
    corners = "auto"
    if step:
        vertices = np.array([[0.0, 0.0], [0.97, 0.0], [1.0, 0.0], [np.cos(angle), np.sin(angle)]])
        corners = sorted(np.argmin(np.linalg.norm(samples[:, None] - vertices, axis=2), 0))
    result = fitting.fit(samples, js.CubicBSpline(), n, corners=corners)
    assert bool(result.converged)
    assert int(np.sum(np.asarray(result.creases))) == (4 if step else 3)
    curve = np.asarray(result.curve)
    error = max(sector_distance(curve, angle).max(),
                distance_to_curve(sector_samples(angle, 4000), curve).max())
    assert error < (1 - np.cos(angle / 2)) / 5


def test_creases_share_the_control_points_by_arc_length():
    """matplotlib's home icon, inner outline (5 corners found): the control points
    between consecutive creases are n times the arc-length share of the outline
    between their corner samples, to within one (rounding; the pieces with shares
    below two are straight edges, whose floor is one span). A regression: under jit
    the first corner's own fraction came out as -1e-17, wrapped to 1, and the creases
    were allocated from the wrong corner (gaps 15, 2, 3, 11, 1 against shares of 12.3,
    2.8, 1.8, 2.7, 12.3 at n = 32)."""
    import matplotlib

    import jaxsubdiv.io as jio

    path = Path(matplotlib.get_data_path()) / "images" / "home.svg"
    samples = np.asarray(jio.read_outlines(path)[0].points)
    corners = np.sort(fitting.find_corners(samples))
    assert len(corners) >= 4
    n = 20  # (the other tests' program)
    result = fitting.fit(samples, js.CubicBSpline(), n, corners=list(corners), max_steps=2,
                         on_failure="ignore")
    creases = np.flatnonzero(np.asarray(result.creases))
    gaps = np.diff(np.append(creases, creases[0] + n))
    chords = np.linalg.norm(np.roll(samples, -1, axis=0) - samples, axis=1)
    s = np.concatenate([[0.0], np.cumsum(chords)])
    arcs = np.diff(np.append(s[corners], s[corners[0]] + s[-1])) / s[-1] * n
    # The same cyclic sequence of pieces, in either direction (the fit orders the
    # samples counter-clockwise), from some corner.
    matches = [np.all(np.abs(np.roll(g, k) - arcs) <= 1.0)
               for g in (gaps, gaps[::-1]) for k in range(len(gaps))]
    assert any(matches), (gaps, arcs)


def test_a_batch_with_corners():
    """`fit_batch(corners=...)`: two stars (the second rotated, scaled and moved, at
    another phase), a star whose corners are given as indices, and a circle (no
    corners). Each star's curve passes through its vertices to the solver's
    tolerance and its creased control points are the vertices; the disk gets no
    crease and is as close to the circle as its smooth fit; every star is the curve
    `fit` gives it alone, to the solver's tolerance (400 samples each: the programs of
    the tests above)."""
    V = star()
    turn = np.array([[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]])
    stars = [V, 3.0 * V @ turn.T + [1.0, -2.0], V]
    targets = [polygon_samples(stars[0], 400, 0.013), polygon_samples(stars[1], 400, 0.37),
               polygon_samples(stars[2], 400, 0.2)]
    given = sorted(np.argmin(np.linalg.norm(targets[2][:, None] - V, axis=2), 0))
    angle = 2 * np.pi * np.arange(400) / 400
    targets.append(np.stack([np.cos(angle), np.sin(angle)], 1))
    corners = ["auto", "auto", list(given), None]
    result = fitting.fit_batch(targets, js.CubicBSpline(), 20, corners=corners)
    assert np.all(np.asarray(result.converged))
    creases = np.asarray(result.creases)
    assert creases.shape == (4, 20)
    assert creases.sum(1).tolist() == [10, 10, 10, 0]
    for i, vertices in enumerate(stars):
        size = np.ptp(vertices, axis=0).max()
        curve = np.asarray(result.curve[i])
        assert distance_to_curve(vertices, curve).max() < 1e-6 * size
        creased = np.asarray(result.control_points[i])[creases[i]]
        assert distance_to_curve(vertices, creased).max() < 1e-6 * size
    for i, (target, c) in enumerate(zip(targets[:3], corners)):
        alone = fitting.fit(target, js.CubicBSpline(), 20, corners=c)
        np.testing.assert_allclose(np.asarray(result.curve[i]), np.asarray(alone.curve),
                                   atol=1e-6)
    # The disk by chords: as close to the circle as its smooth fit.
    smooth = fitting.fit(targets[3], js.CubicBSpline(), 20)
    radial = [np.abs(np.linalg.norm(np.asarray(c), axis=1) - 1).max()
              for c in (result.curve[3], smooth.curve)]
    assert radial[0] <= 1.05 * radial[1], radial  # measured 1.44e-5 and 1.38e-5


def test_batch_corner_errors():
    samples = polygon_samples(star(), 200, 0.1)
    with pytest.raises(ValueError, match="one entry per target"):
        fitting.fit_batch([samples, samples], js.CubicBSpline(), 20, corners=["auto"])
    with pytest.raises(ValueError, match="primal"):
        fitting.fit_batch([samples], js.Chaikin(), 20, corners="auto")
    with pytest.warns(RuntimeWarning, match=r"fit_batch\(corners\[1\]\)"):
        result = fitting.fit_batch([samples, samples], js.CubicBSpline(), 8,
                                   corners=["auto", list(range(0, 200, 20))])
    assert fitting.STATUSES[int(result.status[1])] == "invalid_input"
    assert not np.asarray(result.creases[1]).any()


def hamilton(shares, total):
    """Largest-remainder apportionment of `total` seats to real `shares`, plainly."""
    seats = [int(np.floor(s)) for s in shares]
    order = sorted(range(len(shares)), key=lambda i: -(shares[i] - seats[i]))
    for i in order[: total - sum(seats)]:
        seats[i] += 1
    return seats


@pytest.mark.parametrize("n", [9, 13, 23])
def test_creases_are_apportioned_by_largest_remainders(n):
    """An irregular hexagon (straight pieces, every share at least one span), its
    vertices the corner samples: the spans between consecutive creases are Hamilton's
    apportionment of n by edge length, computed here plainly, edge by edge, for the
    samples started at several places, and reversed (which is what a mirror image
    changes once `fit` has put its samples in their canonical order). Rounding the
    cumulative shares from the first corner instead gives spans that depend on it."""
    from fitting._init import corner_creases

    V = np.array([[0.0, 0.0], [2.3, -0.4], [3.1, 1.2], [2.2, 2.9], [0.4, 2.6], [-0.7, 1.1]])
    edges = np.linalg.norm(np.roll(V, -1, axis=0) - V, axis=1)
    expected = hamilton(n * edges / edges.sum(), n)
    per_edge = 40
    u = np.arange(per_edge)[:, None] / per_edge
    samples = np.concatenate([V[i] + u * (V[(i + 1) % 6] - V[i]) for i in range(6)])
    flags = np.zeros(len(samples), bool)
    flags[::per_edge] = True
    allocate = jax.jit(corner_creases, static_argnums=2)
    for shift in (0, 7, 85, 170):
        for reverse in (False, True):
            points, corner = np.roll(samples, shift, axis=0), np.roll(flags, shift)
            if reverse:
                points, corner = points[::-1], corner[::-1]
            creases, position = allocate(points, corner, n)
            # Each edge's spans: from its first vertex's crease to the next's (the
            # other way round when the samples run backwards).
            at = np.round(np.asarray(position)[corner]).astype(int)
            vertex = np.argmin(np.linalg.norm(points[corner][:, None] - V, axis=2), 1)
            crease_of = dict(zip(vertex, at))
            step = -1 if reverse else 1
            spans = [step * (crease_of[(i + 1) % 6] - crease_of[i]) % n for i in range(6)]
            assert spans == expected, (shift, reverse, spans, expected)
            assert np.sum(np.asarray(creases)) == 6
