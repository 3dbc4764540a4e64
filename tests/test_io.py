"""jaxsubdiv.io: outline formats, SVG paths, glyphs, silhouettes, curve SVG, result JSON.

Expected numbers come from closed forms written out here (circle and ellipse equations,
the Bernstein form of a Bezier curve, SVG's own definitions of S, T and transforms), from
the B-spline parametrization of the limit curve, and from `jaxsubdiv.limit_points`.
"""

import re

import matplotlib.image
import numpy as np
import pytest

import jaxsubdiv as js
import jaxsubdiv.io as jio


POLYGON = np.array([[0.0, 0.0], [1.0, -0.1], [1.7, 0.6], [1.1, 1.3], [0.2, 1.1], [-0.4, 0.5]])
OPEN = np.array([[0.1, 0.2], [1 / 3, 2.0], [np.pi, -1e-7], [5e8, 1e-300]])


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def _svg(body: str) -> str:
    return f'<svg xmlns="http://www.w3.org/2000/svg">{body}</svg>'


# --- round trips ---------------------------------------------------------------------


@pytest.mark.parametrize("ext", ["csv", "txt", "npz", "json", "svg"])
def test_round_trip_several_outlines(tmp_path, ext):
    path = tmp_path / f"outlines.{ext}"
    outlines = [jio.Outline(POLYGON, True), jio.Outline(OPEN, False)]
    jio.write_outlines(path, outlines)
    back = jio.read_outlines(path)
    assert [o.closed for o in back] == [True, False]
    for a, b in zip(back, outlines):
        np.testing.assert_array_equal(a.points, b.points)


@pytest.mark.parametrize("ext", ["csv", "txt", "npy", "npz", "json", "svg"])
def test_round_trip_write_points(tmp_path, ext):
    path = tmp_path / f"points.{ext}"
    jio.write_points(path, POLYGON)
    (back,) = jio.read_outlines(path)
    assert back.closed
    assert back.points.dtype == np.float64
    np.testing.assert_array_equal(back.points, POLYGON)


def test_kind_overrides_extension(tmp_path):
    path = tmp_path / "points.dat"
    jio.write_points(path, POLYGON, kind="json")
    np.testing.assert_array_equal(jio.read_outlines(path, kind="json")[0].points, POLYGON)


def test_csv_conventions(tmp_path):
    path = _write(
        tmp_path,
        "conventions.csv",
        "# a comment\nx;y\n0;0  # trailing comment\n2\t0\n2, 1\n0 0\n\n\n"
        "# closed: false\n5,5\n6,5e-1\n",
    )
    first, second = jio.read_outlines(path)
    # The repeated first point of a closed outline is dropped.
    np.testing.assert_array_equal(first.points, [[0, 0], [2, 0], [2, 1]])
    assert first.closed
    np.testing.assert_array_equal(second.points, [[5, 5], [6, 0.5]])
    assert not second.closed


def test_npy_stack_and_plain_npz(tmp_path):
    np.save(tmp_path / "stack.npy", np.stack([POLYGON, POLYGON + 1]))
    outlines = jio.read_outlines(tmp_path / "stack.npy")
    assert len(outlines) == 2
    np.testing.assert_array_equal(outlines[1].points, POLYGON + 1)
    np.savez(tmp_path / "plain.npz", anything=POLYGON.astype(np.float32))
    (outline,) = jio.read_outlines(tmp_path / "plain.npz")
    np.testing.assert_array_equal(outline.points, POLYGON.astype(np.float32))


def test_json_variants(tmp_path):
    bare = _write(tmp_path, "bare.json", "[[0, 0], [1, 0], [1, 1]]")
    np.testing.assert_array_equal(jio.read_outlines(bare)[0].points, [[0, 0], [1, 0], [1, 1]])
    spec = _write(tmp_path, "spec.json", '{"points": [[0, 0], [1, 0], [1, 1]], "closed": false}')
    assert not jio.read_outlines(spec)[0].closed


@pytest.mark.parametrize("ext", ["csv", "json", "svg"])
def test_resampling_by_arc_length(tmp_path, ext):
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    jio.write_points(tmp_path / f"square.{ext}", square)
    (outline,) = jio.read_outlines(tmp_path / f"square.{ext}", samples=8)
    expected = [[0, 0], [0.5, 0], [1, 0], [1, 0.5], [1, 1], [0.5, 1], [0, 1], [0, 0.5]]
    np.testing.assert_allclose(outline.points, expected, atol=1e-15)


# --- SVG paths -----------------------------------------------------------------------


def _distance_to_bezier(points, control):
    """Distance of each point to a Bezier curve (Bernstein form, Newton projection)."""
    degree = len(control) - 1
    from math import comb

    def curve(t, derivative=0):
        t = t[:, None]
        out = 0
        for i, p in enumerate(control):
            if derivative == 0:
                b = comb(degree, i) * t**i * (1 - t) ** (degree - i)
            else:
                b = comb(degree, i) * (
                    (i * t ** max(i - 1, 0) if i else 0) * (1 - t) ** (degree - i)
                    - t**i * ((degree - i) * (1 - t) ** max(degree - i - 1, 0) if degree - i else 0)
                )
            out = out + b * p
        return out

    grid = np.linspace(0, 1, 4001)
    dense = curve(grid)
    t = grid[np.argmin(np.linalg.norm(points[:, None] - dense[None], axis=-1), axis=1)]
    for _ in range(20):
        r, d = curve(t) - points, curve(t, 1)
        h = 1e-6
        d2 = (curve(np.clip(t + h, 0, 1), 1) - curve(np.clip(t - h, 0, 1), 1)) / (2 * h)
        g, gg = np.sum(r * d, axis=1), np.sum(d * d + r * d2, axis=1)
        t = np.clip(t - g / gg, 0, 1)
    return np.linalg.norm(curve(t) - points, axis=1)


def test_svg_arcs_make_a_circle(tmp_path):
    # Two half circles of radius 1.5 around (2, 3): one absolute arc, one relative.
    path = _write(
        tmp_path,
        "circle.svg",
        _svg('<path d="M 3.5 3 A 1.5 1.5 0 0 1 0.5 3 a1.5,1.5 0 01 3,0 z"/>'),
    )
    (outline,) = jio.read_outlines(path, samples=101)
    p = outline.points
    assert outline.closed and p.shape == (101, 2)
    # SVG's y axis points down; read_outlines returns y up, so the center is (2, -3).
    np.testing.assert_allclose(np.hypot(p[:, 0] - 2, p[:, 1] + 3), 1.5, rtol=0, atol=1e-9)
    chords = np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1)
    np.testing.assert_allclose(chords, 2 * 1.5 * np.sin(np.pi / 101), rtol=1e-6)


def test_svg_rotated_elliptical_arc(tmp_path):
    # Ellipse with semi-axes 2 and 1 rotated by 30 degrees, centered at the origin,
    # drawn as two arcs between the ends of its major axis.
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    a = (2 * c, 2 * s)
    d = f"M {a[0]} {a[1]} A 2 1 30 1 1 {-a[0]} {-a[1]} A 2 1 30 1 1 {a[0]} {a[1]} Z"
    (outline,) = jio.read_outlines(_write(tmp_path, "ellipse.svg", _svg(f'<path d="{d}"/>')))
    x, y = outline.points[:, 0], -outline.points[:, 1]  # back to SVG coordinates
    u, v = c * x + s * y, -s * x + c * y
    np.testing.assert_allclose((u / 2) ** 2 + v**2, 1, atol=1e-9)


def test_svg_arc_radii_scaled_up(tmp_path):
    # Radii too small for the end points are scaled up (SVG 1.1 F.6.6): a half circle.
    (outline,) = jio.read_outlines(
        _write(tmp_path, "small.svg", _svg('<path d="M 0 0 A 0.1 0.1 0 0 0 2 0"/>'))
    )
    p = outline.points
    np.testing.assert_allclose(np.hypot(p[:, 0] - 1, p[:, 1]), 1, atol=1e-9)
    assert not outline.closed


def test_svg_cubic_matches_bernstein(tmp_path):
    control = np.array([[0.0, 0.0], [1.0, 3.0], [4.0, -2.0], [5.0, 1.0]])
    d = "M " + " C ".join([" ".join(map(str, control[0])), " ".join(map(str, control[1:].ravel()))])
    (outline,) = jio.read_outlines(
        _write(tmp_path, "cubic.svg", _svg(f'<path d="{d}"/>')), samples=50
    )
    points = outline.points * [1, -1]
    assert np.max(_distance_to_bezier(points, control)) < 1e-9
    np.testing.assert_allclose(points[[0, -1]], control[[0, 3]], atol=1e-12)
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    # Equal arc lengths; chords are shorter than arcs by about (kappa h)^2 / 24.
    assert np.ptp(chords) < 1e-2 * chords.mean()


def test_svg_quadratic_matches_bernstein(tmp_path):
    control = np.array([[0.0, 0.0], [2.0, 4.0], [5.0, 0.5]])
    d = "M 0 0 Q 2 4 5 0.5"
    (outline,) = jio.read_outlines(
        _write(tmp_path, "quad.svg", _svg(f'<path d="{d}"/>')), samples=40
    )
    assert np.max(_distance_to_bezier(outline.points * [1, -1], control)) < 1e-9


ABSOLUTE = (
    "M 10 10 L 20 10 H 30 V 20 C 30 25 25 30 20 30 S 10 25 10 20 Q 5 15 10 10 "
    "T 10 0 A 5 5 0 0 1 20 0 L 40 0 50 5 Z M 60 60 L 70 60 L 70 70"
)
RELATIVE = (
    "m 10 10 l 10 0 h 10 v 10 c 0 5 -5 10 -10 10 s -10 -5 -10 -10 q -5 -5 0 -10 "
    "t 0 -10 a 5 5 0 0 1 10 0 l 20 0 10 5 z m 50 50 l 10 0 0 10"
)
# S and T spelled out by their definition (reflect the previous control point).
EXPLICIT = (
    "M 10 10 L 20 10 L 30 10 L 30 20 C 30 25 25 30 20 30 C 15 30 10 25 10 20 "
    "Q 5 15 10 10 Q 15 5 10 0 A 5 5 0 0 1 20 0 L 40 0 L 50 5 Z M 60 60 L 70 60 L 70 70"
)


@pytest.mark.parametrize(
    "d",
    [
        RELATIVE,
        EXPLICIT,
        ABSOLUTE.replace(" ", ","),
        "M10,10L20,10H30V20C30,25,25,30,20,30S10,25,10,20Q5,15,10,10T10,0A5,5,0,0,1,20,0"
        "L40,0,50,5ZM60,60L70,60L70,70",
    ],
)
def test_svg_relative_and_shorthand_commands(tmp_path, d):
    expected = jio.read_outlines(
        _write(tmp_path, "a.svg", _svg(f'<path d="{ABSOLUTE}"/>')), samples=64
    )
    got = jio.read_outlines(_write(tmp_path, "b.svg", _svg(f'<path d="{d}"/>')), samples=64)
    assert [o.closed for o in got] == [True, False]
    for a, b in zip(got, expected):
        np.testing.assert_allclose(a.points, b.points, rtol=0, atol=1e-10)


def test_svg_compact_arc_flags(tmp_path):
    # Flags need no separators: "a1 1 0 011 1" is rx=1 ry=1 angle=0 large=0 sweep=1 to (1, 1).
    a = jio.read_outlines(
        _write(tmp_path, "a.svg", _svg('<path d="M0 0a1 1 0 011 1"/>')), samples=9
    )
    b = jio.read_outlines(
        _write(tmp_path, "b.svg", _svg('<path d="M0 0 a 1 1 0 0 1 1 1"/>')), samples=9
    )
    np.testing.assert_array_equal(a[0].points, b[0].points)
    # Quarter circle around (0, 1) (SVG coordinates): every point at distance 1.
    np.testing.assert_allclose(np.hypot(a[0].points[:, 0], -a[0].points[:, 1] - 1), 1, atol=1e-12)


def test_svg_polygons_polylines_and_transforms(tmp_path):
    body = (
        '<polygon points="0,0 1,0 1,1"/>'
        '<g transform="translate(10, 0) scale(2)"><polyline points="0 0 1 0 1 1"/></g>'
        '<defs><path d="M 0 0 L 9 9"/></defs>'
        '<path transform="rotate(90)" d="M 1 0 L 2 0"/>'
        '<path transform="matrix(1 0 0 1 5 6)" d="M 0 0 L 1 0"/>'
    )
    outlines = jio.read_outlines(_write(tmp_path, "shapes.svg", _svg(body)))
    assert [o.closed for o in outlines] == [True, False, False, False]
    # y is negated: SVG's y points down, jaxsubdiv's up.
    np.testing.assert_allclose(outlines[0].points, [[0, 0], [1, 0], [1, -1]])
    np.testing.assert_allclose(outlines[1].points, [[10, 0], [12, 0], [12, -2]])
    np.testing.assert_allclose(outlines[2].points, [[0, -1], [0, -2]], atol=1e-15)
    np.testing.assert_allclose(outlines[3].points, [[5, -6], [6, -6]])


# --- curve SVG -----------------------------------------------------------------------


def _svg_beziers(path):
    """Parse the path written by write_curve_svg: 'M x y' then C/Q/L groups, optional Z."""
    d = re.search(r'<path d="([^"]*)"', path.read_text()).group(1)
    tokens = d.split()
    assert tokens[0] == "M"
    current = np.array([float(tokens[1]), float(tokens[2])])
    segments, i = [], 3
    while i < len(tokens) and tokens[i] != "Z":
        count = {"L": 1, "Q": 2, "C": 3}[tokens[i]]
        values = np.array([float(v) for v in tokens[i + 1 : i + 1 + 2 * count]]).reshape(-1, 2)
        segments.append(np.vstack([current, values]))
        current, i = values[-1], i + 1 + 2 * count
    return segments, tokens[-1] == "Z"


def _bernstein(control, t):
    from math import comb

    degree = len(control) - 1
    return sum(
        comb(degree, i) * t[:, None] ** i * (1 - t[:, None]) ** (degree - i) * p
        for i, p in enumerate(control)
    )


@pytest.mark.parametrize(
    "scheme, letter, offset",
    [
        # The cubic B-spline is primal: level-k point K sits at parameter K / 2^k.
        (js.CubicBSpline(), "C", 0.0),
        # Chaikin is dual (center -1/2): level-k points sit at odd multiples of 2^-(k+1),
        # and its Bezier spans run between edge midpoints.
        (js.Chaikin(), "Q", 0.5),
    ],
)
def test_curve_svg_closed_bezier_is_the_limit_curve(tmp_path, scheme, letter, offset):
    k = 4
    path = tmp_path / "curve.svg"
    assert jio.write_curve_svg(path, POLYGON, scheme) is True
    segments, closed = _svg_beziers(path)
    assert closed and len(segments) == len(POLYGON)
    assert letter in path.read_text()
    t = (np.arange(2**k) + (0.5 if offset else 0.0)) / 2**k
    sampled = np.concatenate([_bernstein(b, t) for b in segments])
    limit = np.asarray(js.limit_points(js.refine(POLYGON, scheme, k), scheme))
    assert sampled.shape == limit.shape
    # Same points in the same cyclic order, up to where the closed path starts.
    shift = int(np.argmin(np.linalg.norm(limit - sampled[0], axis=1)))
    size = np.ptp(POLYGON, axis=0).max()
    np.testing.assert_allclose(np.roll(limit, -shift, axis=0), sampled, rtol=0, atol=1e-9 * size)


@pytest.mark.parametrize("boundary", ["open", "clamped"])
@pytest.mark.parametrize(
    "scheme",
    [js.CubicBSpline(), js.Chaikin(), js.LaneRiesenfeld(3)],
    ids=["cubic", "chaikin", "lr3"],
)
def test_curve_svg_open_bezier_is_the_limit_curve(tmp_path, scheme, boundary):
    path = tmp_path / "curve.svg"
    assert jio.write_curve_svg(path, POLYGON, scheme, boundary=boundary) is True
    segments, closed = _svg_beziers(path)
    assert not closed
    limit = np.asarray(
        js.limit_points(js.refine(POLYGON, scheme, 4, boundary=boundary), scheme, boundary=boundary)
    )
    size = np.ptp(POLYGON, axis=0).max()
    # Every exact limit point lies on the path ...
    distance = np.min([_distance_to_bezier(limit, b) for b in segments], axis=0)
    assert np.max(distance) < 1e-9 * size
    # ... and the path ends where the limit curve does (the ends of the open curve are
    # the limits of the first and last refined points).
    refined = np.asarray(js.refine(POLYGON, scheme, 12, boundary=boundary))
    np.testing.assert_allclose(segments[0][0], refined[0], atol=1e-3 * size)
    np.testing.assert_allclose(segments[-1][-1], refined[-1], atol=1e-3 * size)


def test_curve_svg_linear_is_the_polygon(tmp_path):
    path = tmp_path / "curve.svg"
    assert jio.write_curve_svg(path, POLYGON, js.LaneRiesenfeld(1)) is True
    segments, closed = _svg_beziers(path)
    assert closed
    np.testing.assert_array_equal([s[0] for s in segments], POLYGON)


def test_curve_svg_polyline_otherwise(tmp_path):
    path = tmp_path / "curve.svg"
    assert jio.write_curve_svg(path, POLYGON, js.FourPoint(), levels=3) is False
    (outline,) = jio.read_outlines(path)
    # An interpolating scheme: the control points are on the polyline, every 8th point.
    np.testing.assert_allclose(outline.points[::8], POLYGON, atol=1e-12)
    assert outline.closed and len(outline.points) == 8 * len(POLYGON)


def test_curve_svg_reads_back_onto_the_curve(tmp_path):
    path = tmp_path / "curve.svg"
    jio.write_curve_svg(path, POLYGON, js.CubicBSpline())
    (outline,) = jio.read_outlines(path, samples=300)
    limit = np.asarray(js.limit_points(js.refine(POLYGON, js.CubicBSpline(), 8), js.CubicBSpline()))
    gaps = np.min(np.linalg.norm(outline.points[:, None] - limit[None], axis=-1), axis=1)
    assert np.max(gaps) < 2e-2  # within the spacing of the level-8 points


# --- glyphs and images ---------------------------------------------------------------


def _signed_area(p):
    return 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - p[:, 1] * np.roll(p[:, 0], -1))


@pytest.mark.parametrize("text, contours", [("a", 2), ("o", 2), ("S", 1), ("8", 3), ("io", 4)])
def test_glyph_contours(text, contours):
    outlines = jio.read_outlines(text=text, samples=50)
    assert len(outlines) == contours
    assert all(o.closed and o.points.shape == (50, 2) for o in outlines)


def test_glyph_hole_runs_the_other_way():
    outer, hole = sorted(jio.read_outlines(text="o"), key=lambda o: -abs(_signed_area(o.points)))
    assert np.sign(_signed_area(outer.points)) == -np.sign(_signed_area(hole.points))
    # The hole is inside the outer contour's bounding box, and the size is about 1 em.
    assert np.all(hole.points.min(0) > outer.points.min(0))
    assert 0.3 < np.ptp(outer.points[:, 1]) < 1.0


def _disk_image(height, width, center, radius, foreground, background):
    rows, cols = np.mgrid[0:height, 0:width]
    # Fraction of each pixel inside the disk (4 x 4 supersampling): an anti-aliased edge.
    sub = (np.arange(4) + 0.5) / 4 - 0.5
    inside = np.zeros((height, width))
    for dy in sub:
        for dx in sub:
            inside += np.hypot(rows + dy - center[0], cols + dx - center[1]) <= radius
    inside /= 16
    return inside * foreground + (1 - inside) * background


@pytest.mark.parametrize("foreground, background", [(0.0, 1.0), (1.0, 0.0)])
def test_png_disk(tmp_path, foreground, background):
    image = _disk_image(60, 80, (25.0, 40.0), 17.0, foreground, background)
    path = tmp_path / "disk.png"
    matplotlib.image.imsave(path, image, cmap="gray", vmin=0, vmax=1)
    (outline,) = jio.read_outlines(path)
    # Pixel (row r, column c) is the point (c, H - 1 - r): the center is (40, 34).
    radius = np.hypot(outline.points[:, 0] - 40, outline.points[:, 1] - 34)
    assert np.max(np.abs(radius - 17)) < 1.0
    assert outline.closed and len(outline.points) > 50


def test_png_ring_keeps_outer_contour_and_alpha(tmp_path):
    ring = _disk_image(50, 50, (24.5, 24.5), 20, 1.0, 0.0) - _disk_image(
        50, 50, (24.5, 24.5), 8, 1.0, 0.0
    )
    rgba = np.zeros((50, 50, 4))
    rgba[..., 3] = ring  # black ink on a transparent background
    path = tmp_path / "ring.png"
    matplotlib.image.imsave(path, rgba)
    (outline,) = jio.read_outlines(path, samples=64)
    radius = np.hypot(outline.points[:, 0] - 24.5, outline.points[:, 1] - 24.5)
    assert np.max(np.abs(radius - 20)) < 1.0
    assert outline.points.shape == (64, 2)


# --- result JSON ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "scheme",
    [
        js.FourPoint(0.07),
        js.CornerCutting(0.2, 0.65),
        js.LaneRiesenfeld(4),
        js.Jarek(),
        js.CubicBSpline(),
        js.MaskScheme([0.25, 0.75, 0.75, 0.25], -2),
    ],
    ids=lambda s: type(s).__name__,
)
def test_result_json_round_trip(tmp_path, scheme):
    path = tmp_path / "result.json"
    record = {
        "control_points": POLYGON,
        "scheme": scheme,
        "boundary": "open",
        "levels": 5,
        "errors": {"rms": 0.25},
    }
    jio.write_result_json(path, record, info={"input": "hand.svg", "samples": 400})
    saved = jio.read_result_json(path)
    assert type(saved.scheme) is type(scheme)
    np.testing.assert_array_equal(np.asarray(saved.scheme.mask()), np.asarray(scheme.mask()))
    assert saved.scheme.mask_start == scheme.mask_start
    np.testing.assert_array_equal(saved.control_points, POLYGON)
    assert (saved.boundary, saved.levels, saved.errors) == ("open", 5, {"rms": 0.25})
    assert saved.info == {"input": "hand.svg", "samples": 400}


def test_result_json_from_a_fit_result(tmp_path):
    import fitting

    value = lambda x: np.asarray(x, dtype=np.float64)
    result = fitting.FitResult(
        control_points=value(POLYGON),
        scheme=js.FourPoint(0.0712),
        curve=value(POLYGON),
        rms=value(0.01),
        max_error=value(0.03),
        rms_target_to_curve=value(0.01),
        max_target_to_curve=value(0.02),
        rms_curve_to_target=value(0.005),
        max_curve_to_target=value(0.03),
        num_steps=np.asarray(12),
        status=np.asarray(0),
        newton_step=value(1e-9),
        boundary="closed",
        levels=4,
    )
    path = tmp_path / "fit.json"
    jio.write_result_json(path, result, info={"input": "mango.csv"})
    saved = jio.read_result_json(path)
    np.testing.assert_array_equal(saved.control_points, POLYGON)
    assert float(saved.scheme.w) == 0.0712
    assert saved.errors["rms"] == 0.01 and saved.errors["max_curve_to_target"] == 0.03
    assert saved.info == {
        "status": 0,
        "num_steps": 12,
        "message": "converged",
        "input": "mango.csv",
    }
    assert (saved.boundary, saved.levels) == ("closed", 4)


def test_result_json_refuses_a_batch(tmp_path):
    record = {"control_points": np.stack([POLYGON, POLYGON]), "scheme": js.Chaikin()}
    with pytest.raises(ValueError, match="write one result at a time"):
        jio.write_result_json(tmp_path / "batch.json", record)


# --- errors for people ---------------------------------------------------------------


ERRORS = [
    ("missing.csv", None, "no such file"),
    ("empty.csv", "", "empty"),
    ("blank.txt", "  \n\n", "empty"),
    ("header_only.csv", "# just a comment\nx,y\n", "no points"),
    ("columns.csv", "0,0\n1,0\n1,1,1\n", "line 3: expected 2 values (x, y), got 3"),
    ("one_column.txt", "x y\n0 0\n1\n", "line 3: expected 2 values (x, y), got 1"),
    ("words.csv", "0,0\n1,zero\n", "line 2: 'zero' is not a number"),
    ("nan.csv", "0,0\nnan,1\n", "line 2: 'nan' is not a finite number"),
    ("one_point.csv", "1,2\n", "at least 2 points"),
    ("closed.csv", "# closed: maybe\n0,0\n1,1\n", "line 1: `closed:` must be true or false"),
    ("nopath.svg", _svg('<circle cx="0" cy="0" r="1"/>'), "no <path>, <polygon> or <polyline>"),
    ("broken.svg", "<svg><path d='M 0 0 L 1 1'></svg>", "not valid XML"),
    ("html.svg", "<html><body/></html>", "not an SVG file"),
    ("baddata.svg", _svg('<path d="M 0 0 L 1 x"/>'), "bad path data at character"),
    ("noM.svg", _svg('<path d="L 0 0 1 1"/>'), "must start with 'M'"),
    ("badflag.svg", _svg('<path d="M 0 0 A 1 1 0 2 1 1 1"/>'), "expected a flag 0 or 1"),
    ("badpoly.svg", _svg('<polygon points="0,0 1"/>'), "at least two x,y pairs"),
    ("bad.json", '{"points": [[0, 0], [1, 0]', "not valid JSON"),
    ("text.json", '{"points": [[0, 0], ["a", 0]]}', "is not a number"),
    ("triple.json", '{"points": [[0, 0], [1, 0, 2]]}', "must be a pair [x, y]"),
    (
        "flag.json",
        '{"points": [[0, 0], [1, 0]], "closed": "yes"}',
        '"closed"] must be true or false',
    ),
    ("noext.xyz", "0,0\n", "cannot tell the format from the extension '.xyz'"),
    ("bad.npy", "not numpy", "not a readable .npy file"),
    ("bad.npz", "not numpy", "not a readable .npz archive"),
    ("bad.png", "not an image", "not a readable PNG image"),
]


@pytest.mark.parametrize("name, content, message", ERRORS, ids=[e[0] for e in ERRORS])
def test_errors_name_the_file_and_the_problem(tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    with pytest.raises(jio.OutlineError) as info:
        jio.read_outlines(path)
    text = str(info.value)
    assert text.startswith(str(path)), text
    assert message in text, text
    assert "\n" not in text


def test_more_errors(tmp_path):
    np.save(tmp_path / "shape.npy", np.zeros((4, 3)))
    with pytest.raises(jio.OutlineError, match=r"shape\.npy: the array must have shape \(m, 2\)"):
        jio.read_outlines(tmp_path / "shape.npy")
    np.save(tmp_path / "strings.npy", np.array([["a", "b"], ["c", "d"]]))
    with pytest.raises(jio.OutlineError, match="not real numbers"):
        jio.read_outlines(tmp_path / "strings.npy")
    with pytest.raises(jio.OutlineError, match=r"is a directory"):
        jio.read_outlines(tmp_path, kind="csv")
    with pytest.raises(jio.OutlineError, match="unknown kind 'xls'"):
        jio.read_outlines(tmp_path / "a.csv", kind="xls")
    with pytest.raises(jio.OutlineError, match="font 'No Such Font Family' not found"):
        jio.read_outlines(text="a", font="No Such Font Family")
    with pytest.raises(jio.OutlineError, match="no visible characters"):
        jio.read_outlines(text="  ")
    with pytest.raises(jio.OutlineError, match="a .npy file holds one outline"):
        jio.write_outlines(tmp_path / "two.npy", [jio.Outline(POLYGON), jio.Outline(OPEN)])
    with pytest.raises(jio.OutlineError, match="contain NaN"):
        jio.write_points(tmp_path / "nan.csv", [[0, 0], [np.nan, 1]])
    blank = np.ones((10, 10))
    matplotlib.image.imsave(tmp_path / "blank.png", blank, cmap="gray", vmin=0, vmax=1)
    with pytest.raises(jio.OutlineError, match="has no silhouette"):
        jio.read_outlines(tmp_path / "blank.png")
    (tmp_path / "other.json").write_text('{"points": [[0, 0], [1, 1]]}')
    with pytest.raises(jio.OutlineError, match="not a jaxsubdiv result file"):
        jio.read_result_json(tmp_path / "other.json")
    (tmp_path / "scheme.json").write_text(
        '{"format": "jaxsubdiv.result", "version": 1, "scheme": {"type": "Bogus"}, '
        '"control_points": [[0, 0], [1, 1]]}'
    )
    with pytest.raises(jio.OutlineError, match="unknown scheme 'Bogus'"):
        jio.read_result_json(tmp_path / "scheme.json")
    with pytest.raises(ValueError, match="`samples` must be at least 3"):
        jio.read_outlines(tmp_path / "a.csv", samples=2)
    with pytest.raises(ValueError, match="`threshold` must be between 0 and 1"):
        jio.read_outlines(tmp_path / "blank.png", threshold=1.5)
