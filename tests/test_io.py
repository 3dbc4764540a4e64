"""jaxsubdiv.io: outline formats, SVG paths, glyphs, silhouettes, curve SVG, result JSON.

Expected numbers come from closed forms written out here (circle and ellipse equations,
the Bernstein form of a Bezier curve, SVG's own definitions of S, T and transforms), from
the B-spline parametrization of the limit curve, and from `jaxsubdiv.limit_points`.
"""

import io
import json
import re
import struct
import zipfile
import zlib

import matplotlib.image
import numpy as np
import pytest
from helpers import apply_affine, svg_bezier_paths, svg_transform_matrix

import jaxsubdiv as js
import jaxsubdiv.io as jio
from jaxsubdiv._io import common, raster, svg


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


def _boxes(outlines):
    """Each outline's bounding box (x0, y0, x1, y1), rounded, y up."""
    return [tuple(np.round(np.concatenate([o.points.min(0), o.points.max(0)]), 9).tolist())
            for o in outlines]


def test_svg_basic_shapes_and_lengths(tmp_path):
    """`<rect>` (square and rounded corners), `<circle>`, `<ellipse>` and `<line>` (SVG
    1.1, chapter 9): every sample on the closed form of its shape; lengths in mm (96 px
    to the inch) and % of the viewBox (r: of its diagonal / sqrt 2); a zero size draws
    nothing."""
    body = (
        '<rect x="1" y="2" width="3" height="4"/>'
        '<rect x="10" y="0" width="8" height="6" rx="2" transform="translate(0,1)"/>'
        '<circle cx="5" cy="-5" r="2"/>'
        '<ellipse cx="0" cy="0" rx="3" ry="1"/>'
        '<line x1="0" y1="0" x2="10mm" y2="0" stroke="black"/>'
        '<circle cx="0" cy="0" r="10%"/>'
        '<rect width="0" height="5"/><circle r="0"/>'
    )
    source = _write(tmp_path, "shapes.svg", _svg(body).replace(
        "<svg ", '<svg viewBox="0 0 300 400" '))
    rect, rounded, circle, ellipse, line, percent = jio.read_outlines(source, samples=200)
    assert _boxes([rect]) == [(1.0, -6.0, 4.0, -2.0)]
    x, y = rect.points.T
    assert np.all(np.isclose(x, 1) | np.isclose(x, 4) | np.isclose(y, -2) | np.isclose(y, -6))
    # Rounded: inside the rectangle, and on a quarter circle of radius 2 at each corner.
    x, y = rounded.points[:, 0], -rounded.points[:, 1] - 1
    cx, cy = np.clip(x, 12, 16), np.clip(y, 2, 4)
    corner = (x != cx) & (y != cy)
    np.testing.assert_allclose(np.hypot(x - cx, y - cy)[corner], 2, atol=1e-12)
    assert _boxes([rounded]) == [(10.0, -7.0, 18.0, -1.0)]
    np.testing.assert_allclose(np.hypot(circle.points[:, 0] - 5, circle.points[:, 1] - 5), 2,
                               atol=1e-12)
    np.testing.assert_allclose((ellipse.points[:, 0] / 3) ** 2 + ellipse.points[:, 1] ** 2, 1,
                               atol=1e-12)
    assert not line.closed and rect.closed
    np.testing.assert_allclose(line.points[[0, -1]], [[0, 0], [10 * 96 / 25.4, 0]], atol=1e-12)
    np.testing.assert_allclose(np.hypot(*percent.points.T), 0.1 * 500 / np.sqrt(2), atol=1e-9)


def test_svg_style_sheets(tmp_path):
    """`<style>` rules (CSS 2.1's cascade): class, id, type and descendant selectors, a
    sheet after the shapes it styles, specificity over order, `style` over sheets, rules
    inside `@media` not applied, unsupported selectors not applied."""
    sheet = """
        #keep { fill: black }  /* an id, before the class rule: it still wins */
        .off { fill: none } g.layer > path.ghost { display: none } .off { stroke: none }
        .a > .b .c { display: none }  .font { font-family: "}"; display: none }
        .must { display: none ! important }
        @media (prefers-color-scheme: dark) { path { display: none } }
        path:hover { display: none } path[d] { display: none } .x, { display: none }
        .last { display: none
    """
    tri = lambda x: f'd="M {x} 0 L {x + 1} 0 L {x + 1} 1 Z"'
    body = (
        f'<path class="off" {tri(0)}/>'  # no fill, no stroke: skipped
        f'<path class="off" id="keep" {tri(2)}/>'  # id beats class
        f'<g class="layer"><path class="ghost" {tri(4)}/></g>'  # hidden
        f'<g class="layer"><g><path class="ghost" {tri(6)}/></g></g>'  # not a child
        f'<path class="off" style="fill: red" {tri(8)}/>'  # style beats the sheet
        f'<path class="off" fill="red" {tri(10)}/>'  # the sheet beats an attribute
        f'<g class="a"><g class="b"><g class="b"><path class="c" {tri(12)}/></g></g></g>'
        f'<path class="font" {tri(14)}/>'  # a brace in a string does not end the rule
        f'<path class="must" style="display: inline" {tri(16)}/>'  # important wins
        f'<path class="x" {tri(18)}/>'  # a malformed selector list drops the rule
        f'<path class="last" {tri(20)}/>'  # a block open at the end closes there
        f'<style>{sheet}</style><style media="print">path {{ display: none }}</style>'
    )
    outlines = jio.read_outlines(_write(tmp_path, "styled.svg", _svg(body)))
    assert [o.points[0, 0] for o in outlines] == [2.0, 6.0, 8.0, 18.0]


def test_svg_use_is_styled_where_its_target_stands(tmp_path):
    """Sheet rules match a `<use>`'s target in the document tree, not under the `<use>`
    (SVG 1.1, 5.6); the instance inherits the `<use>`'s own properties; a `<use>` of
    nothing, or of another file, draws nothing."""
    body = (
        "<style>.hide path { display: none } use path { display: none }</style>"
        '<defs><g class="hide"><path id="hidden" d="M 0 0 L 1 0 L 1 1 Z"/></g>'
        '<path id="shown" d="M 2 0 L 3 0 L 3 1 Z"/></defs>'
        '<use href="#hidden"/>'
        '<g class="hide"><use href="#shown"/></g>'
        '<use href="#shown" fill="none"/>'  # inherited: no fill, no stroke
        '<use href="#nothing"/><use href="other.svg#shown"/>'
    )
    (outline,) = jio.read_outlines(_write(tmp_path, "use.svg", _svg(body)))
    assert outline.points[0, 0] == 2.0


@pytest.mark.parametrize(
    "align, box",
    [
        ("", (110, -20, 130, 0)),  # xMidYMid meet: scale 2, centred in x
        ("xMinYMin meet", (100, -20, 120, 0)),
        ("xMaxYMax meet", (120, -20, 140, 0)),
        ("xMidYMid slice", (100, -30, 140, 10)),  # scale 4, centred in y: -10 + ...
        ("xMinYMin slice", (100, -40, 140, 0)),
        ("none", (100, -20, 140, 0)),  # 4 in x, 2 in y
    ],
)
def test_svg_symbol_preserve_aspect_ratio(tmp_path, align, box):
    """A 10 x 10 `<symbol>` square used at x = 100 in a 40 x 20 viewport, by SVG 1.1's
    viewBox mapping (7.8): the square's bounding box, worked out here by hand (y up)."""
    attribute = f' preserveAspectRatio="{align}"' if align else ""
    body = (f'<symbol id="s" viewBox="0 0 10 10"{attribute}><rect width="10" height="10"/>'
            '</symbol><use href="#s" x="100" width="40" height="20"/>')
    (outline,) = jio.read_outlines(_write(tmp_path, "symbol.svg", _svg(body)))
    assert _boxes([outline]) == [tuple(float(v) for v in box)]


def test_svg_viewports_of_no_size_and_rect_radii(tmp_path):
    """A zero-sized nested `<svg>` or `<use>` of a `<symbol>` draws nothing and a negative
    size is an error naming it; rounded rectangles: `ry` alone sets `rx`, radii are
    clamped to half the side; `x`/`y` percentages of the viewBox."""
    body = ('<symbol id="s" viewBox="0 0 1 1"><rect width="1" height="1"/></symbol>'
            '<use href="#s" width="0" height="5"/>'
            '<svg width="0" height="10"><rect width="1" height="1"/></svg>'
            '<rect x="10%" y="50%" width="20" height="10" ry="3"/>'
            '<rect x="0" y="0" width="4" height="2" rx="9"/>')
    source = _write(tmp_path, "sizes.svg",
                    _svg(body).replace("<svg ", '<svg viewBox="0 0 300 40" ', 1))
    small, wide = jio.read_outlines(source, samples=400)
    assert _boxes([small]) == [(30.0, -30.0, 50.0, -20.0)]
    # rx = ry = 3: the corner at (30, 20) (y down) is a quarter circle about (33, 23).
    x, y = small.points[:, 0], -small.points[:, 1]
    corner = (x < 33) & (y < 23)
    np.testing.assert_allclose(np.hypot(x - 33, y - 23)[corner], 3, atol=1e-12)
    # rx = 9 clamped to 2, ry = rx clamped to 1: a stadium; its ends are half ellipses.
    x, y = wide.points[:, 0], -wide.points[:, 1]
    end = x < 2
    np.testing.assert_allclose((((x - 2) / 2) ** 2 + (y - 1) ** 2)[end], 1, atol=1e-12)
    negative = _svg('<svg width="-5" height="10"><rect width="1" height="1"/></svg>')
    with pytest.raises(jio.OutlineError, match='<svg> width=.-5. is negative'):
        jio.read_outlines(_write(tmp_path, "negative.svg", negative))


def test_nodes_of_a_loop_of_one_curve(tmp_path):
    """A closed contour of one cubic has one node: its Bezier control points make the
    polygon instead (and `refine` then works on it)."""
    path = _write(tmp_path, "loop.svg", _svg('<path d="M 0 0 C 5 5 5 -5 0 0 Z"/>'))
    (outline,) = jio.read_outlines(path, nodes=True)
    np.testing.assert_array_equal(outline.points, [[0, 0], [5, -5], [5, 5]])


def test_one_polygon_with_per_curve_arguments_and_a_stack(tmp_path):
    """One polygon may come with one-element lists; a `(k, n, 2)` array is k polygons;
    bad `groups` are clear errors."""
    path = tmp_path / "one.svg"
    assert jio.write_curve_svg(path, POLYGON, js.CubicBSpline(), boundary=["closed"],
                               groups=[None]) is True
    assert len(svg_bezier_paths(path.read_text())) == 1
    jio.write_curve_svg(path, np.stack([POLYGON, POLYGON + 5]), js.CubicBSpline())
    assert len(svg_bezier_paths(path.read_text())) == 2
    with pytest.raises(TypeError, match="`groups` must hold ints or None"):
        jio.write_curve_svg(path, [POLYGON, POLYGON], js.CubicBSpline(), groups=[[1], [2]])
    with pytest.raises(jio.OutlineError, match="control polygon 0 must be an"):
        jio.write_curve_svg(path, [[[0, 0], [1]], POLYGON], js.CubicBSpline())


def test_json_keeps_the_shapes(tmp_path):
    """Groups survive a JSON round trip, so an SVG written after it has the glyph's hole
    in the glyph's path."""
    outlines = jio.read_outlines(text="o")
    path = tmp_path / "o.json"
    jio.write_outlines(path, outlines)
    again = jio.read_outlines(path)
    assert [o.group for o in again] == [o.group for o in outlines] == [0, 0]
    jio.write_outlines(tmp_path / "o.svg", again)
    assert (tmp_path / "o.svg").read_text().count("<path") == 1


def test_svg_use_symbol_and_nested_viewports(tmp_path):
    """`<use>` of a path (x, y, then its transform), of a `<symbol>` with a viewBox scaled
    into the use's width and height (xMidYMid meet), a nested `<svg>`'s viewport; and
    a `<use>` cycle is an error naming it."""
    body = (
        '<defs><path id="tri" d="M 0 0 L 1 0 L 0 1 Z"/>'
        '<symbol id="box" viewBox="0 0 10 10"><path d="M 0 0 L 10 0 L 10 10 Z"/></symbol></defs>'
        '<use href="#tri" x="5" y="6" transform="scale(2)"/>'
        '<use xlink:href="#box" x="100" width="40" height="20" '
        'xmlns:xlink="http://www.w3.org/1999/xlink"/>'
        '<svg x="10" y="20" width="100" height="50" viewBox="0 0 10 10">'
        '<path d="M 1 1 L 2 1 L 2 2 Z"/></svg>'
    )
    used, symbol, nested = jio.read_outlines(_write(tmp_path, "use.svg", _svg(body)))
    # scale(2) then translate(5, 6): (p + (5, 6)) * 2, y negated.
    np.testing.assert_allclose(used.points, [[10, -12], [12, -12], [10, -14]])
    # A 10 x 10 box into 40 x 20, meet: scale 2, centred: x offset (40 - 20) / 2 = 10.
    np.testing.assert_allclose(symbol.points, [[110, 0], [130, 0], [130, -20]])
    # 10 x 10 into 100 x 50 at (10, 20): scale 5, x offset (100 - 50) / 2 = 25.
    np.testing.assert_allclose(nested.points, [[40, -25], [45, -25], [45, -30]])
    cycle = _svg('<g id="a"><path d="M 0 0 L 1 0 L 0 1 Z"/><use href="#a"/></g>')
    with pytest.raises(jio.OutlineError, match=r"loop\.svg: <use> of '#a' refers to an "
                       r"element that contains it"):
        jio.read_outlines(_write(tmp_path, "loop.svg", cycle))


def test_svg_use_explosion_is_bounded(tmp_path, monkeypatch):
    """Nested `<use>`s of groups of `<use>`s multiply: the walk stops at a bound with a
    clear error before it runs for hours (lowered here, so that the test is quick)."""
    monkeypatch.setattr(svg, "_MAX_ELEMENTS", 1000)
    levels = ['<path id="l0" d="M 0 0 L 1 0 L 0 1 Z"/>']
    for k in range(1, 5):
        levels.append(f'<g id="l{k}">' + f'<use href="#l{k - 1}"/>' * 10 + "</g>")
    path = _write(tmp_path, "laughs.svg", _svg("<defs>" + "".join(levels) + "</defs>"
                                               '<use href="#l4"/>'))
    with pytest.raises(jio.OutlineError, match="more than 1,000 elements to draw"):
        jio.read_outlines(path)


def test_svg_shapes_that_draw_nothing_are_skipped(tmp_path):
    """Shapes a renderer would not draw are not outlines (issue #18: matplotlib's icons
    start with a transparent background rectangle, which made every icon fail); shapes
    with a visible fill or stroke are kept, in document order."""
    body = (
        '<path d="M 0 0 L 72 0 L 72 72 Z" style="fill:none;opacity:0;"/>'  # the icons'
        '<path d="M 0 0 L 1 0 L 1 1 Z" fill="none"/>'  # no fill, no stroke
        '<path d="M 0 0 L 2 0 L 2 2 Z" fill="none" stroke="black"/>'  # a stroke: kept
        '<g style="display:none"><path d="M 0 0 L 3 0 L 3 3 Z"/></g>'  # hidden subtree
        '<g fill="none"><polygon points="0,0 4,0 4,4"/>'  # inherits no fill
        '<polygon points="0,0 5,0 5,5" fill="red"/></g>'  # overrides it: kept
        '<polygon points="0,0 6,0 6,6" visibility="hidden"/>'
        '<polygon points="0,0 7,0 7,7" style="fill-opacity:0"/>'
        '<polygon points="0,0 8,0 8,8" stroke="blue" stroke-width="0" fill="none"/>'
        '<g opacity="0"><polygon points="0,0 9,0 9,9"/></g>'
        '<polygon points="0,0 11,0 11,11" fill="transparent"/>'
        '<polygon points="0,0 12,0 12,12" style="FILL: None"/>'  # keywords: any case
        '<polygon points="0,0 10,0 10,10"/>'  # the initial fill is black: kept
    )
    outlines = jio.read_outlines(_write(tmp_path, "icon.svg", _svg(body)))
    assert [float(np.ptp(o.points[:, 0])) for o in outlines] == [2.0, 5.0, 10.0]
    nothing = _svg('<path d="M 0 0 L 1 0 L 1 1 Z" style="fill:none"/>'
                   '<g display="none"><path d="M 0 0 L 2 0 L 2 2 Z"/></g>')
    with pytest.raises(ValueError, match=r"that draws anything \(2 shapes or groups .* skipped\)"):
        jio.read_outlines(_write(tmp_path, "blank.svg", nothing))


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


def _page(text):
    """The root's attributes and the group transform of an SVG written here."""
    root = re.search(r"<svg ([^>]*)>", text).group(1)
    attributes = dict(re.findall(r'(\w+)="([^"]*)"', root))
    return attributes, re.search(r'<g transform="([^"]*)"', text).group(1)


def _apply(transform, points):
    return apply_affine(svg_transform_matrix(transform), points)


def test_several_curves_are_one_shape_with_holes(tmp_path):
    """Several control polygons are the subpaths of one `<path>` filled even-odd, each
    exact and in order; `groups` makes one `<path>` per shape; per-curve schemes and
    boundaries; an open curve's shape is stroked, not filled."""
    hole = 0.3 * POLYGON + 0.4
    path = tmp_path / "shape.svg"
    assert jio.write_curve_svg(path, [POLYGON, hole], js.CubicBSpline()) is True
    text = path.read_text()
    assert text.count("<path") == 1 and 'fill-rule="evenodd"' in text
    subpaths = svg_bezier_paths(text)
    for segments, polygon in zip(subpaths, [POLYGON, hole]):
        # Uniform cubic B-spline: span i starts at (p[i-1] + 4 p[i] + p[i+1]) / 6.
        starts = (np.roll(polygon, 1, 0) + 4 * polygon + np.roll(polygon, -1, 0)) / 6
        np.testing.assert_allclose([s[0] for s in segments], starts, rtol=0, atol=1e-12)
    assert jio.write_curve_svg(
        path, [POLYGON, hole, POLYGON + 3], [js.CubicBSpline(), js.Chaikin(), js.FourPoint()],
        boundary=["closed", "closed", "open"], groups=[0, 0, 1], levels=3,
    ) is False  # the four-point curve is a polyline
    text = path.read_text()
    paths = re.findall(r"<path [^>]*>", text)
    assert len(paths) == 2 and "evenodd" in paths[0] and 'fill="none"' in paths[1]
    assert [len(s) for s in svg_bezier_paths(text)[:2]] == [len(POLYGON), len(hole)]
    assert " Q " in paths[0] and " C " in paths[0]
    with pytest.raises(ValueError, match=r"`scheme` must be one scheme or a list of one per "
                       r"control polygon \(2\), got a list of 3"):
        jio.write_curve_svg(path, [POLYGON, hole], [js.Chaikin()] * 3)


def test_svg_output_keeps_an_svg_inputs_page_and_coordinates(tmp_path):
    """Written `like` the SVG it was read from, a drawing lies over it: the root's page
    attributes are copied, and the written points, mapped by the written transform, are
    the input's own coordinates after its transforms (written out here by hand)."""
    source = _write(tmp_path, "in.svg", (
        '<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="30mm" '
        'viewBox="-5 0 80 60" preserveAspectRatio="xMinYMin">'
        '<g transform="translate(10,20)"><path d="M 0 0 C 10 0 20 10 20 20 L 0 20 Z"/>'
        '<path d="M 30 0 L 40 0 L 40 10 Z"/></g></svg>'))
    outlines = jio.read_outlines(source, nodes=True)
    assert [o.group for o in outlines] == [0, 1]
    np.testing.assert_array_equal(outlines[0].points, [[10, -20], [30, -40], [10, -40]])
    out = tmp_path / "out.svg"
    jio.write_outlines(out, outlines, like=source)
    text = out.read_text()
    attributes, transform = _page(text)
    assert {k: attributes[k] for k in ("width", "height", "viewBox", "preserveAspectRatio")} \
        == {"width": "40mm", "height": "30mm", "viewBox": "-5 0 80 60",
            "preserveAspectRatio": "xMinYMin"}
    (first,), (second,) = svg_bezier_paths(text)[:1], svg_bezier_paths(text)[1:]
    np.testing.assert_array_equal(_apply(transform, np.array([s[0] for s in first])),
                                  [[10, 20], [30, 40], [10, 40]])
    np.testing.assert_array_equal(_apply(transform, np.array([s[0] for s in second])),
                                  [[40, 20], [50, 20], [50, 30]])
    assert text.count("<path") == 2  # one per input shape
    # Read back: the same outlines and shapes.
    again = jio.read_outlines(out, nodes=True)
    assert [o.group for o in again] == [0, 1]
    for a, b in zip(again, outlines):
        np.testing.assert_array_equal(a.points, b.points)


def test_svg_output_keeps_a_png_inputs_pixels(tmp_path):
    """A silhouette's fitted outline written `like` its PNG is on the image's pixel
    grid: a filled block of rows 10-29 and columns 5-44 is the page's rectangle
    [5, 45] x [10, 30] (its contour runs halfway between pixel centers, i.e. on the
    pixels' edges), on a page of the image's size."""
    image = np.ones((40, 60))
    image[10:30, 5:45] = 0.0
    source = tmp_path / "block.png"
    matplotlib.image.imsave(source, image, cmap="gray", vmin=0, vmax=1)
    (outline,) = jio.read_outlines(source)
    out = tmp_path / "block.svg"
    jio.write_outlines(out, [outline], like=source)
    attributes, transform = _page(out.read_text())
    assert (attributes["width"], attributes["height"], attributes["viewBox"]) == \
        ("60", "40", "0 0 60 40")
    (segments,) = svg_bezier_paths(out.read_text())
    page = _apply(transform, np.array([s[0] for s in segments]))
    np.testing.assert_allclose(page.min(axis=0), [5, 10], atol=1e-12)
    np.testing.assert_allclose(page.max(axis=0), [45, 30], atol=1e-12)


def test_nodes_are_where_segments_meet(tmp_path):
    """`nodes=True`: an SVG contour's on-curve points as written in the file (curves,
    arcs, lines; relative commands), not samples; refused together with `samples`."""
    d = "M 0 0 C 1 0 2 1 2 2 Q 1 3 0 2 A 1 1 0 0 1 -1 1 l 0 -1 z M 5 5 L 6 5 L 6 7"
    path = _write(tmp_path, "nodes.svg", _svg(f'<path d="{d}"/>'))
    closed, open_ = jio.read_outlines(path, nodes=True)
    np.testing.assert_allclose(closed.points, [[0, 0], [2, -2], [0, -2], [-1, -1], [-1, 0]],
                               atol=1e-15)
    assert closed.closed and not open_.closed
    np.testing.assert_array_equal(open_.points, [[5, -5], [6, -5], [6, -7]])
    with pytest.raises(ValueError, match="`nodes=True` or `samples`"):
        jio.read_outlines(path, nodes=True, samples=10)


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


def test_png_ring_keeps_its_hole_and_alpha(tmp_path):
    """A ring (radii 20 and 8) in the alpha channel: the outer contour, clockwise, then
    the hole, counter-clockwise, as a glyph's (issue #18: the hole was dropped)."""
    ring = _disk_image(50, 50, (24.5, 24.5), 20, 1.0, 0.0) - _disk_image(
        50, 50, (24.5, 24.5), 8, 1.0, 0.0
    )
    rgba = np.zeros((50, 50, 4))
    rgba[..., 3] = ring  # black ink on a transparent background
    path = tmp_path / "ring.png"
    matplotlib.image.imsave(path, rgba)
    outer, hole = jio.read_outlines(path, samples=64)
    for outline, expected, sign in ((outer, 20, -1), (hole, 8, 1)):
        radius = np.hypot(outline.points[:, 0] - 24.5, outline.points[:, 1] - 24.5)
        assert np.max(np.abs(radius - expected)) < 1.0
        assert outline.points.shape == (64, 2) and outline.closed
        assert np.sign(_signed_area(outline.points)) == sign


def test_png_alpha_marking_only_specks_is_not_the_silhouette(tmp_path):
    """An opaque disk image whose alpha channel only rounds off its four corner pixels
    (as scikit-image's horse.png): the disk in the luminance is the silhouette, not the
    four specks in the alpha channel (which gave four 4-point contours)."""
    gray = _disk_image(60, 80, (25.0, 40.0), 17.0, 0.0, 1.0)
    rgba = np.ones((60, 80, 4))
    rgba[..., :3] = gray[..., None]
    rgba[[0, 0, -1, -1], [0, -1, 0, -1], 3] = 0.43
    path = tmp_path / "rounded.png"
    matplotlib.image.imsave(path, rgba)
    (outline,) = jio.read_outlines(path)
    radius = np.hypot(outline.points[:, 0] - 40, outline.points[:, 1] - 34)
    assert np.max(np.abs(radius - 17)) < 1.0


def test_png_small_alpha_silhouette_without_luminance_is_read(tmp_path):
    """A dot covering under 0.1% of the pixels in the alpha channel of an image of one
    colour: the luminance holds no silhouette, so the alpha channel is still read."""
    rgba = np.zeros((100, 100, 4))
    rgba[..., 3] = _disk_image(100, 100, (50.0, 50.0), 1.5, 1.0, 0.0)
    assert np.count_nonzero(rgba[..., 3] > 0.5) < 10
    path = tmp_path / "dot.png"
    matplotlib.image.imsave(path, rgba)
    (outline,) = jio.read_outlines(path)
    radius = np.hypot(outline.points[:, 0] - 50, outline.points[:, 1] - 49)
    assert np.max(np.abs(radius - 1.5)) < 1.0


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


def _cubic_bspline_refined(P, levels):
    """Closed cubic B-spline subdivision in plain numpy (vertex points
    (P[i-1] + 6 P[i] + P[i+1]) / 8, edge points (P[i] + P[i+1]) / 2), vertex first."""
    for _ in range(levels):
        before, after = np.roll(P, 1, axis=0), np.roll(P, -1, axis=0)
        out = np.empty((2 * len(P), P.shape[1]))
        out[0::2] = (before + 6 * P + after) / 8
        out[1::2] = (P + after) / 2
        P = out
    return P


def test_a_saved_result_reads_as_its_curve_or_its_control_polygon(tmp_path):
    # A result file written by hand (the format `fit -o x.json` and the editor write):
    # `read_outlines` gives its curve, the control polygon refined with the saved scheme
    # and levels, and with `nodes=True` the control polygon; both closed as saved. It
    # was "the file must be {"points": ...}" (found by a user try-out).
    polygon = np.array([[0.0, 0.0], [2.0, 0.0], [3.0, 1.5], [1.0, 2.5], [-0.5, 1.0]])
    path = tmp_path / "saved.json"
    path.write_text(json.dumps({
        "format": "jaxsubdiv.result", "version": 1, "boundary": "closed", "levels": 3,
        "scheme": {"type": "CubicBSpline", "parameters": {}},
        "control_points": polygon.tolist(),
    }))
    (curve,) = js.io.read_outlines(path)
    (nodes,) = js.io.read_outlines(path, nodes=True)
    assert curve.closed and nodes.closed
    np.testing.assert_array_equal(nodes.points, polygon)
    expected = _cubic_bspline_refined(polygon, 3)
    # (Up to the rotation of the refined polygon's first point.)
    shift = int(np.argmin(np.linalg.norm(curve.points - expected[0], axis=1)))
    np.testing.assert_allclose(np.roll(curve.points, -shift, axis=0), expected, atol=1e-12)
    (resampled,) = js.io.read_outlines(path, samples=100)
    assert resampled.points.shape == (100, 2)


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
    ("nopath.svg", _svg('<text x="0" y="0">A</text>'), "no <path>, <polygon>, <polyline>, <rect>"),
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
    with pytest.raises(jio.OutlineError, match="must not contain NaN"):
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


# --- hostile input and resource limits -----------------------------------------------
# Each hostile file is built here in a few KB: a header that claims a huge size, a
# corrupt byte, a deep nesting. Every one must give one OutlineError line that names the
# file and the problem, quickly and without allocating what it claims.


def _npy_header(shape, descr="<f8") -> bytes:
    out = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        out, {"descr": descr, "fortran_order": False, "shape": shape}
    )
    return out.getvalue()


def _npy(array) -> bytes:
    out = io.BytesIO()
    np.save(out, np.asarray(array), allow_pickle=False)
    return out.getvalue()


def _zip(members: dict, method=zipfile.ZIP_DEFLATED) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", method) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return out.getvalue()


def _npz_declaring(size: int) -> bytes:
    """A small archive whose member declares `size` uncompressed bytes (a zip bomb's
    central directory), in the local header and the central directory."""
    data = bytearray(_zip({"points.npy": _npy(np.zeros((100, 2)))}))
    struct.pack_into("<I", data, 22, size)
    struct.pack_into("<I", data, data.rfind(b"PK\x01\x02") + 24, size)
    return bytes(data)


def _npz_corrupt_deflate() -> bytes:
    data = bytearray(_zip({"points.npy": _npy(np.random.default_rng(0).random((200, 2)))}))
    data[100:110] = b"\xff" * 10  # inside the compressed stream
    return bytes(data)


def _npz_bad_crc() -> bytes:
    data = bytearray(_zip({"points.npy": _npy(POLYGON)}, zipfile.ZIP_STORED))
    data[-200] ^= 0xFF  # a byte of the stored array
    return bytes(data)


def _npz_encrypted() -> bytes:
    data = bytearray(_zip({"points.npy": _npy(POLYGON)}))
    struct.pack_into("<H", data, 6, 1)  # the "encrypted" flag bit
    struct.pack_into("<H", data, data.rfind(b"PK\x01\x02") + 8, 1)
    return bytes(data)


def _png_header(width: int, height: int, color: int = 0) -> bytes:
    """A PNG that claims `width` x `height` pixels; a few rows of zlib-compressed zeros."""

    def chunk(kind, data):
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    ihdr = struct.pack(">IIBBBBB", width, height, 8, color, 0, 0, 0)
    rows = zlib.compress(bytes((1 + width * (3 if color == 2 else 1)) * 4))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", rows) + chunk(b"IEND", b"")


def _png_dots(count: int) -> bytes:
    """A white image with `count` x `count` black 2 x 2 dots: as many equal blobs."""
    image = np.ones((3 * count + 1, 3 * count + 1))
    for i in (1, 2):
        for j in (1, 2):
            image[i::3, j::3] = 0
    out = io.BytesIO()
    matplotlib.image.imsave(out, image, cmap="gray", vmin=0, vmax=1, format="png")
    return out.getvalue()


_TRIANGLE = "M 0 0 L 1 0 L 1 1 Z"

HOSTILE = [
    # JSON: numbers past float64, nesting past the recursion limit, no contours
    ("digits.json", b"[[0, 0], [1, " + b"9" * 400 + b"], [1, 1]]", "too large for a float64"),
    ("digits_5000.json", b"[[0, 0], [1, " + b"9" * 5000 + b"]]", "too large for a float64"),
    ("nan.json", b"[[0, 0], [1, NaN], [1, 1]]", "not finite"),
    ("deep.json", b"[" * 200_000 + b"]" * 200_000, "nests lists or objects too deeply"),
    ("empty.json", b'{"outlines": []}', "has no contours"),
    (
        "many.json",
        b'{"outlines": [' + b",".join([b"[[0,0],[1,1]]"] * 10_001) + b"]}",
        "10,001 contours, more than the limit of 10,000",
    ),
    (
        "long_pair.json",
        b'{"points": [[0, 0], [' + b"1," * 50_000 + b"1]]}",
        "must be a pair [x, y]",
    ),
    # CSV: long lines are quoted short; too many contours
    ("long_line.csv", b"0,0\n" + b"1 " * 50_000 + b"\n", "expected 2 values (x, y), got 50000"),
    ("blocks.csv", b"0,0\n1,1\n\n" * 10_001, "more contours than the limit of 10,000"),
    # SVG: numbers and transforms that do not fit a float64, arcs out of range, no contours
    ("no_contours.svg", _svg('<path d="M 0 0"/><circle r="0"/>').encode(), "has no contours"),
    (
        "rotate.svg",
        _svg(f'<path d="{_TRIANGLE}" transform="rotate(1e400)"/>').encode(),
        "bad transform rotate('1e400'): a number is not finite",
    ),
    (
        "skew.svg",
        _svg(f'<path d="{_TRIANGLE}" transform="skewX(inf)"/>').encode(),
        "bad transform skewX('inf')",
    ),
    (
        "number.svg",
        _svg('<path d="M 0 0 L 1e999 0 L 1 1 Z"/>').encode(),
        "'1e999' is too large for a float64",
    ),
    (
        "scale.svg",
        _svg(
            f'<g transform="scale(1e300)"><path d="{_TRIANGLE}" transform="scale(1e300)"/></g>'
        ).encode(),
        "contour 0: its coordinates overflow a float64",
    ),
    (
        "arc.svg",
        _svg('<path d="M 0 0 A 1e-308 1e-308 0 0 1 1e308 1e308"/>').encode(),
        "the arc cannot be computed in float64",
    ),
    (
        "points.svg",
        _svg('<polygon points="' + "1,2 " * 20_000 + 'x"/>').encode(),
        "has a non-numeric value in points='1,2 1,2",
    ),
    (
        "paths.svg",
        _svg(f'<path d="{_TRIANGLE}"/>' * 10_001).encode(),
        "more contours than the limit",
    ),
    # NPY: headers that claim more than the file holds, bad headers, no contours
    (
        "claims.npy",
        _npy_header((10**10, 2)) + bytes(64),
        "the array claims shape (10000000000, 2) (149 GiB) but holds only 64 bytes",
    ),
    ("claims_2_62.npy", _npy_header((2**62, 2**62)) + bytes(64), "truncated or corrupt"),
    ("bad_header.npy", b"\x93NUMPY\x01\x00\x10\x00{'descr': 'xxxx\n", "not a readable .npy file"),
    ("version.npy", b"\x93NUMPY\x09\x00" + bytes(100), "unsupported format version"),
    ("objects.npy", _npy_header((3, 2), "|O") + bytes(48), "holds values of type object"),
    ("empty_stack.npy", _npy_header((0, 5, 2)), "has no contours"),
    ("negative.npy", _npy_header((-1, 2)) + bytes(64), "has shape (-1, 2), not (m, 2)"),
    ("stack.npy", _npy_header((10_001, 2, 2), "|i1") + bytes(40_004), "10,001 contours"),
    # NPZ: corrupt members, a declared size past the limit (a zip bomb), odd members
    ("corrupt.npz", _npz_corrupt_deflate, "member 'points' is corrupt"),
    ("crc.npz", _npz_bad_crc, "member 'points' is corrupt (BadZipFile: Bad CRC-32"),
    (
        "bomb.npz",
        lambda: _npz_declaring(0xFFFF_FFF0),
        "its arrays are 4 GiB uncompressed, more than the 256 MiB limit",
    ),
    (
        "claims.npz",
        lambda: _zip({"points.npy": _npy_header((2**28, 2)) + bytes(4096)}),
        "member 'points' claims shape (268435456, 2) (4 GiB)",
    ),
    (
        "bzip2.npz",
        lambda: _zip({"points.npy": _npy(POLYGON)}, zipfile.ZIP_BZIP2),
        "uses zip compression method 12",
    ),
    ("encrypted.npz", _npz_encrypted, "member 'points' is encrypted"),
    ("text.npz", lambda: _zip({"points": b"hello"}), "member 'points' is not a NumPy array"),
    ("npy.npz", lambda: _npy(POLYGON), "is a .npy file, not a .npz archive"),
    # PNG: sizes from the header, refused before decoding; noise with too many blobs
    (
        "huge.png",
        lambda: _png_header(30_000, 30_000),
        "30,000 x 30,000 = 900,000,000 pixels, more than the limit of 25,000,000 "
        "(jaxsubdiv.io.MAX_PIXELS); scale the image down",
    ),
    (
        "huge_rgb.png",
        lambda: _png_header(12_000, 12_000, color=2),
        "12,000 x 12,000 = 144,000,000 pixels",
    ),
    ("jpeg.png", b"\xff\xd8\xff\xe0" + bytes(100), "not a readable PNG image"),
    (
        "dots.png",
        lambda: _png_dots(101),
        "10,201 contours, more than the limit of 10,000 (jaxsubdiv.io.MAX_CONTOURS); blur, "
        "threshold or scale down the image",
    ),
]


@pytest.mark.parametrize("name, content, words", HOSTILE, ids=[h[0] for h in HOSTILE])
def test_hostile_files_get_one_line(tmp_path, name, content, words):
    path = tmp_path / name
    path.write_bytes(content() if callable(content) else content)
    with pytest.raises(jio.OutlineError) as info:
        jio.read_outlines(path)
    text = str(info.value)
    assert text.startswith(str(path)), text
    assert words in text, text
    assert "\n" not in text and len(text) < 400, text


def test_deep_svg_groups_are_read(tmp_path):
    path = tmp_path / "deep.svg"
    depth = 5000  # deeper than Python's recursion limit
    groups = '<g transform="translate(1, 0)">' * depth + f'<path d="{_TRIANGLE}"/>' + "</g>" * depth
    path.write_text(_svg(groups))
    (outline,) = jio.read_outlines(path)
    np.testing.assert_array_equal(outline.points, [[depth, 0], [depth + 1, 0], [depth + 1, -1]])


def test_svg_arcs_at_the_edge_of_float64(tmp_path):
    # End points 1e-300 apart: the squares in the specification's formulas underflow,
    # and the angles round to equal; the large arc is still the whole unit circle.
    path = _write(tmp_path, "tiny.svg", _svg('<path d="M 0 0 A 1 1 0 1 1 1e-300 0"/>'))
    (outline,) = jio.read_outlines(path, samples=64)
    np.testing.assert_allclose(np.ptp(outline.points, axis=0), [2, 2], atol=0.01)
    center = np.array([0.0, np.sign(outline.points[:, 1].mean())])
    np.testing.assert_allclose(np.hypot(*(outline.points - center).T), 1, atol=1e-9)
    # Radii of 1e308 for a chord of 1.4: the center form loses the end points; the arc
    # is its chord to float64's precision.
    path = _write(tmp_path, "flat.svg", _svg('<path d="M 0 0 A 1e308 1e308 0 0 1 1 1"/>'))
    (outline,) = jio.read_outlines(path, samples=5)
    np.testing.assert_allclose(outline.points, np.linspace([0, 0], [1, -1], 5), atol=1e-12)


def test_text_without_visible_characters():
    for text in ["\u200b", " \u200b "]:
        with pytest.raises(jio.OutlineError, match="no visible characters"):
            jio.read_outlines(text=text)
    with pytest.raises(jio.OutlineError, match="lone surrogate"):
        jio.read_outlines(text="a\ud800")
    with pytest.raises(jio.OutlineError, match="10,001 characters, more than the limit"):
        jio.read_outlines(text="a" * 10_001)
    with pytest.raises(TypeError, match="`text` must be a string"):
        jio.read_outlines(text=5)


def test_write_outlines_takes_arrays(tmp_path):
    triangle = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    path = tmp_path / "arrays.json"
    jio.write_outlines(path, [triangle, jio.Outline(OPEN, False), triangle.tolist()])
    back = jio.read_outlines(path)
    assert [o.closed for o in back] == [True, False, True]
    np.testing.assert_array_equal(back[0].points, triangle)
    jio.write_outlines(path, triangle)  # one bare (m, 2) array: one outline
    np.testing.assert_array_equal(jio.read_outlines(path)[0].points, triangle)
    for bad in ["abc", None, {"points": triangle}]:
        with pytest.raises(TypeError, match="`outlines` must be a list of Outline or"):
            jio.write_outlines(path, bad)
    with pytest.raises(jio.OutlineError, match=r"outline 1 must have shape \(m, 2\)"):
        jio.write_outlines(path, [triangle, np.zeros((3, 3))])


def test_writers_at_the_edge_of_float64(tmp_path):
    huge = np.array([[-1e308, 0.0], [1e308, 1e308], [0.0, -1e308]])
    jio.write_points(tmp_path / "huge.svg", huge)
    text = (tmp_path / "huge.svg").read_text()
    assert "inf" not in text and "nan" not in text
    np.testing.assert_array_equal(jio.read_outlines(tmp_path / "huge.svg")[0].points, huge)
    with pytest.raises(jio.OutlineError, match="the curve's coordinates overflow a float64"):
        jio.write_curve_svg(tmp_path / "curve.svg", np.vstack([huge, [1, 1]]), js.CubicBSpline())


def test_result_json_bad_parameters_and_info(tmp_path):
    head = '{"format": "jaxsubdiv.result", "version": 1, "control_points": [[0, 0], [1, 1]], '
    scheme = '"scheme": {"type": "CubicBSpline", "parameters": [1]}}'
    path = _write(tmp_path, "r.json", head + scheme)
    with pytest.raises(jio.OutlineError, match=r'"scheme"\["parameters"\] must be an object'):
        jio.read_result_json(path)
    path = _write(tmp_path, "r.json", head + '"scheme": {"type": "CubicBSpline"}, "info": [1]}')
    with pytest.raises(jio.OutlineError, match='"info" must be an object'):
        jio.read_result_json(path)


# Each limit: a file just inside it reads, one just past it is refused (the limits are
# lowered so that the files stay small).


def test_limit_file_bytes(tmp_path, monkeypatch):
    path = _write(tmp_path, "points.csv", "0,0\n1,0\n1,1\n")
    monkeypatch.setattr(common, "MAX_FILE_BYTES", path.stat().st_size)
    assert len(jio.read_outlines(path)) == 1
    monkeypatch.setattr(common, "MAX_FILE_BYTES", path.stat().st_size - 1)
    with pytest.raises(jio.OutlineError, match=r"the file is 12 bytes, more than the 11 bytes"):
        jio.read_outlines(path)


def test_limit_array_bytes(tmp_path, monkeypatch):
    np.save(tmp_path / "p.npy", POLYGON)  # 6 x 2 float64: 96 bytes
    monkeypatch.setattr(common, "MAX_ARRAY_BYTES", 96)
    assert len(jio.read_outlines(tmp_path / "p.npy")) == 1
    monkeypatch.setattr(common, "MAX_ARRAY_BYTES", 95)
    with pytest.raises(jio.OutlineError, match=r"96 bytes as float64, more than the 95 bytes"):
        jio.read_outlines(tmp_path / "p.npy")
    # An int8 array is limited by its size as float64, 8 times its size in the file.
    np.save(tmp_path / "small.npy", np.zeros((6, 2), np.int8) + np.arange(6)[:, None])
    with pytest.raises(jio.OutlineError, match="MAX_ARRAY_BYTES"):
        jio.read_outlines(tmp_path / "small.npy")


def test_limit_npz_declared_size(tmp_path, monkeypatch):
    jio.write_outlines(tmp_path / "p.npz", [jio.Outline(POLYGON), jio.Outline(OPEN, False)])
    with zipfile.ZipFile(tmp_path / "p.npz") as archive:
        declared = sum(info.file_size for info in archive.infolist())
    monkeypatch.setattr(common, "MAX_ARRAY_BYTES", declared)
    assert len(jio.read_outlines(tmp_path / "p.npz")) == 2
    monkeypatch.setattr(common, "MAX_ARRAY_BYTES", declared - 1)
    with pytest.raises(jio.OutlineError, match="uncompressed, more than the"):
        jio.read_outlines(tmp_path / "p.npz")


def test_limit_pixels(tmp_path, monkeypatch):
    path = tmp_path / "disk.png"
    matplotlib.image.imsave(path, _disk_image(20, 30, (10, 15), 6, 0.0, 1.0), cmap="gray")
    monkeypatch.setattr(common, "MAX_PIXELS", 600)
    assert len(jio.read_outlines(path)) == 1
    monkeypatch.setattr(common, "MAX_PIXELS", 599)
    with pytest.raises(jio.OutlineError, match=r"30 x 20 = 600 pixels, more than the limit of 599"):
        jio.read_outlines(path)


def test_limit_contours_and_points(tmp_path, monkeypatch):
    path = _write(tmp_path, "three.csv", "0,0\n1,1\n\n0,0\n1,1\n\n0,0\n1,1\n")
    monkeypatch.setattr(common, "MAX_CONTOURS", 3)
    assert len(jio.read_outlines(path)) == 3
    monkeypatch.setattr(common, "MAX_POINTS", 30)
    assert len(jio.read_outlines(path, samples=10)) == 3
    with pytest.raises(jio.OutlineError, match="33 points, more than the limit of 30"):
        jio.read_outlines(path, samples=11)
    with pytest.raises(ValueError, match="`samples` must be at most 30"):
        jio.read_outlines(path, samples=31)
    monkeypatch.setattr(common, "MAX_CONTOURS", 2)
    with pytest.raises(jio.OutlineError, match="more contours than the limit of 2"):
        jio.read_outlines(path)


def test_png_dots_read_fast_with_the_same_nesting(tmp_path):
    # 400 equal blobs, all kept: every pair used to be tested (4 s); the result must be
    # the one the pairwise even-odd test gives.
    path = tmp_path / "dots.png"
    path.write_bytes(_png_dots(20))
    outlines = jio.read_outlines(path)
    assert len(outlines) == 400
    assert all(len(o.points) == 8 for o in outlines)  # the contour of a 2 x 2 dot


def test_nesting_depths_match_the_pairwise_test():
    rng = np.random.default_rng(0)
    loops = []
    for _ in range(60):  # random star-shaped loops, some nested, some overlapping
        center, radius = rng.uniform(0, 10, 2), rng.uniform(0.2, 6)
        angles = np.sort(rng.uniform(0, 2 * np.pi, rng.integers(3, 40)))
        r = radius * rng.uniform(0.5, 1, len(angles))
        loops.append(center + np.stack([r * np.cos(angles), r * np.sin(angles)], axis=-1))
    loops.append(np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]]))  # first points on edges
    loops.append(np.array([[4.0, 2], [6, 2], [6, 3]]))
    expected = [
        sum(raster._inside(p[0], q) for j, q in enumerate(loops) if j != i)
        for i, p in enumerate(loops)
    ]
    np.testing.assert_array_equal(raster._depths(loops), expected)
    points = rng.uniform(-1, 11, (500, 2))
    for q in loops[:10]:
        np.testing.assert_array_equal(
            raster._inside_all(points, q, pairs=7), [raster._inside(p, q) for p in points]
        )


@pytest.mark.parametrize(
    "call, error, words",
    [
        (lambda p: jio.read_outlines(123), TypeError, "`path` must be a file path"),
        (lambda p: jio.read_outlines(p / "a.png", threshold="x"), TypeError, "`threshold`"),
        (lambda p: jio.read_outlines(text="a", font=5), TypeError, "`font` must be"),
        (lambda p: jio.write_outlines(5, [POLYGON]), TypeError, "`path` must be a file path"),
        (lambda p: jio.write_points(p / "a.csv", POLYGON, closed="no"), TypeError, "`closed`"),
        (lambda p: jio.read_result_json(None), TypeError, "`path` must be a file path"),
        (lambda p: jio.write_points(p / "a.csv", "abc"), jio.OutlineError, "outline 0 must be"),
    ],
)
def test_bad_arguments_are_named(tmp_path, call, error, words):
    with pytest.raises(error, match=re.escape(words)):
        call(tmp_path)


# --- creased curves (fits with corners, #21) -------------------------------------------


def test_curve_svg_creased_bezier_is_the_creased_limit_curve(tmp_path):
    """A creased closed cubic B-spline: one closed run of Bezier segments through its
    clamped pieces, sampled at the dyadic parameters, equals `limit_curve(creases=...)`
    (whose pieces tests/test_curve_stencil.py checks against scipy's B-spline)."""
    k, creases = 3, [1, 4]
    path = tmp_path / "creased.svg"
    assert jio.write_curve_svg(path, POLYGON, js.CubicBSpline(), creases=creases) is True
    segments, closed = _svg_beziers(path)
    assert closed and len(segments) == len(POLYGON)
    t = np.arange(2**k) / 2**k
    sampled = np.concatenate([_bernstein(b, t) for b in segments])
    limit = np.asarray(js.limit_curve(POLYGON, js.CubicBSpline(), k, creases=creases))
    # The path starts at the first crease: control point 1's sample.
    size = np.ptp(POLYGON, axis=0).max()
    np.testing.assert_allclose(np.roll(limit, -creases[0] * 2**k, axis=0), sampled, rtol=0,
                               atol=1e-9 * size)
    # Through the creased points themselves.
    assert np.allclose(limit[np.array(creases) * 2**k], POLYGON[creases], atol=1e-12)


def test_result_json_keeps_the_creases(tmp_path):
    """Creases are saved (format version 2, which an older reader refuses rather than
    drawing the curve without corners), read back, and checked."""
    result = {"control_points": POLYGON, "scheme": js.CubicBSpline(), "boundary": "closed",
              "creases": np.array([False, True, False, False, True] + [False] * (len(POLYGON) - 5))}
    path = tmp_path / "creased.json"
    jio.write_result_json(path, result)
    data = json.loads(path.read_text())
    assert data["version"] == 2 and data["creases"] == [1, 4]
    assert jio.read_result_json(path).creases == (1, 4)
    plain = tmp_path / "plain.json"
    jio.write_result_json(plain, {"control_points": POLYGON, "scheme": js.CubicBSpline()})
    assert json.loads(plain.read_text())["version"] == 1
    assert jio.read_result_json(plain).creases == ()
    data["creases"] = [1, 99]
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="creases"):
        jio.read_result_json(path)
