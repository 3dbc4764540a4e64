"""The interactive editor, driven headless by synthetic matplotlib events (Agg)."""

import argparse

import equinox as eqx
import jax
import matplotlib.image
import numpy as np
import pytest
from helpers import chaikin_python, polyline_distances, superellipse
from matplotlib.backend_bases import KeyEvent, MouseEvent
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import jaxsubdiv as js
from jaxsubdiv import editor as editor_module
from jaxsubdiv._editor_cli import add_parser, run
from jaxsubdiv._refine import _refine_jit
from jaxsubdiv.editor import Editor


ALL = ("cubic-bspline", "four-point", "jarek", "chaikin", "corner-cutting")


def make(points, **options) -> Editor:
    figure = Figure(figsize=(8, 6), dpi=60)
    FigureCanvasAgg(figure)
    return Editor(points, figure=figure, **options)


def wavy(n=100, seed=0):
    rng = np.random.default_rng(seed)
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False)
    radius = 1 + 0.15 * np.cos(5 * theta) + 0.02 * rng.standard_normal(n)
    return np.stack([radius * np.cos(theta), radius * np.sin(theta)], axis=1)


SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


# Events -------------------------------------------------------------------------------


def pixel(ed, xy):
    """Screen pixel of a data point, rounded: matplotlib events hold integer pixels."""
    return np.round(ed.ax.transData.transform(np.asarray(xy, dtype=np.float64)))


def data(ed, xy_pixel):
    """The data point at a pixel."""
    return ed.ax.transData.inverted().transform(np.asarray(xy_pixel, dtype=np.float64))


def mouse(ed, name, xy_pixel, button=1):
    canvas = ed.figure.canvas
    event = MouseEvent(name, canvas, *xy_pixel, button=button)
    canvas.callbacks.process(name, event)


def drag(ed, start_pixel, end_pixels, button=1):
    mouse(ed, "button_press_event", start_pixel, button)
    for p in end_pixels:
        mouse(ed, "motion_notify_event", p, button)
    mouse(ed, "button_release_event", end_pixels[-1] if end_pixels else start_pixel, button)


def key(ed, name, xy_pixel=None):
    canvas = ed.figure.canvas
    x, y = xy_pixel if xy_pixel is not None else pixel(ed, ed.points.mean(axis=0))
    canvas.callbacks.process("key_press_event", KeyEvent("key_press_event", canvas, name, x, y))


# Independent references (numpy, from the rules as published) ---------------------------


def four_point_numpy(P, w, levels):
    """Dyn-Levin-Gregory: keep P_i, insert (1/2 + w)(P_i + P_i+1) - w(P_i-1 + P_i+2)."""
    for _ in range(levels):
        prev, nxt, nxt2 = np.roll(P, 1, 0), np.roll(P, -1, 0), np.roll(P, -2, 0)
        Q = np.empty((2 * len(P), 2))
        Q[0::2] = P
        Q[1::2] = (0.5 + w) * (P + nxt) - w * (prev + nxt2)
        P = Q
    return P


def split_tweak_numpy(V, t, levels):
    """Rossignac's split and tweak: split at midpoints, move the old vertices by
    (1 - t) D_j and the midpoints by -t (D_i + D_j) / 2, D_j = V_i/8 + V_k/8 - V_j/4."""
    for _ in range(levels):
        prev, nxt = np.roll(V, 1, 0), np.roll(V, -1, 0)
        D = prev / 8 + nxt / 8 - V / 4
        Q = np.empty((2 * len(V), 2))
        Q[0::2] = V + (1 - t) * D
        Q[1::2] = (V + nxt) / 2 - t * (D + np.roll(D, -1, 0)) / 2
        V = Q
    return V


def corner_cutting_numpy(P, r, s, levels):
    for _ in range(levels):
        nxt = np.roll(P, -1, 0)
        Q = np.empty((2 * len(P), 2))
        Q[0::2] = (1 - r) * P + r * nxt
        Q[1::2] = (1 - s) * P + s * nxt
        P = Q
    return P


# Tests --------------------------------------------------------------------------------


def test_drag_moves_vertex_four_point_passes_through_it_and_nothing_retraces():
    P = wavy(100)
    ed = make(P, curves=ALL, levels=5)
    assert ed.points.dtype == np.float64
    compiled = _refine_jit._cache_size()
    path = [pixel(ed, P[7] + f * np.array([0.13, -0.07])) for f in np.linspace(0.1, 1.0, 6)]
    goal = data(ed, path[-1])
    drag(ed, pixel(ed, P[7]), path)
    # Same shapes while dragging: the jitted kernels are reused, none is traced again.
    assert _refine_jit._cache_size() == compiled
    moved = ed.points
    np.testing.assert_allclose(moved[7], goal, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.delete(moved, 7, 0), np.delete(P, 7, 0))
    # Interpolating: after 5 levels the four-point curve's point 7 * 2**5 is vertex 7.
    curve = ed.curve_points["four-point"]
    np.testing.assert_allclose(curve[7 * 32], moved[7], rtol=0, atol=1e-12)
    np.testing.assert_allclose(curve, four_point_numpy(moved, 1 / 16, 5), rtol=0, atol=1e-12)
    # The drawn line is that curve (closed), and the artists are no longer animated.
    x, y = ed.lines["four-point"].get_data()
    np.testing.assert_allclose(np.stack([x, y], 1)[:-1], curve, rtol=0, atol=0)
    assert not any(line.get_animated() for line in ed.lines.values())


def test_pick_radius_is_in_pixels():
    ed = make(SQUARE, pick_radius=10)
    corner = pixel(ed, SQUARE[2])
    outward = np.array([1.0, 1.0])  # 1.41 px per step
    # 11 px diagonally outside the corner: 15.6 px from the vertex, 11 px from both
    # edges' lines (and farther from the segments): outside the 10 px radius.
    drag(ed, corner + 11 * outward, [corner + 30 * outward])
    np.testing.assert_array_equal(ed.points, SQUARE)
    # 4 px diagonally (5.7 px): picks the corner, which then follows the mouse.
    end = corner + 30 * outward
    drag(ed, corner + 4 * outward, [end])
    np.testing.assert_allclose(ed.points[2], data(ed, end), atol=1e-12)
    assert len(ed.points) == 4


def test_press_near_an_edge_inserts_a_vertex_there_and_drags_it():
    ed = make(SQUARE, curves=("chaikin",))
    compiled = _refine_jit._cache_size()
    on_edge = np.array([0.3, 0.0])  # on edge (0, 1)
    drag(ed, pixel(ed, on_edge) + [0, 3], [])  # 3 px off the edge, no motion
    expected = np.insert(SQUARE, 1, data(ed, pixel(ed, on_edge) + [0, 3]), 0)
    np.testing.assert_allclose(ed.points, expected, atol=1e-12)
    assert len(ed.points) == 5
    # Insert on the closing edge (3, 0) and drag the new vertex to (-0.5, 0.5).
    drag(ed, pixel(ed, [0.0, 0.6]), [pixel(ed, [-0.2, 0.55]), pixel(ed, [-0.5, 0.5])])
    np.testing.assert_allclose(ed.points[:5], expected, atol=1e-12)
    np.testing.assert_allclose(ed.points[5], data(ed, pixel(ed, [-0.5, 0.5])), atol=1e-12)
    # Closed polygons are padded to a bucket of sizes: inserting compiled nothing, and
    # the curves are still the closed refinements (Chaikin: plain Python reference).
    assert _refine_jit._cache_size() == compiled
    np.testing.assert_allclose(
        ed.curve_points["chaikin"], chaikin_python(ed.points, 5, closed=True), atol=1e-12
    )
    # Open polygon: the closing edge is gone, so a press there inserts nothing.
    key(ed, "o")
    assert ed.boundary == "clamped"
    before = ed.points
    drag(ed, pixel(ed, (before[5] + before[0]) / 2), [])
    np.testing.assert_array_equal(ed.points, before)


def test_right_click_and_d_delete_the_nearest_vertex_down_to_the_minimum():
    P = wavy(6)
    ed = make(P, curves=("cubic-bspline",))
    drag(ed, pixel(ed, P[2]) + [2, -2], [], button=3)
    np.testing.assert_array_equal(ed.points, np.delete(P, 2, 0))
    key(ed, "d", pixel(ed, P[4]) + [5, 5])  # nearest to the cursor: old vertex 4
    np.testing.assert_array_equal(ed.points, np.delete(P, [2, 4], 0))
    key(ed, "delete", pixel(ed, P[0]))
    np.testing.assert_array_equal(ed.points, P[[1, 3, 5]])
    # Closed curves need 3 control points (refine's minimum): the next delete is refused.
    key(ed, "d", pixel(ed, P[1]))
    np.testing.assert_array_equal(ed.points, P[[1, 3, 5]])
    assert "at least 3" in ed.status
    # Open (clamped) curves need 2.
    key(ed, "o")
    key(ed, "d", pixel(ed, P[1]))
    np.testing.assert_array_equal(ed.points, P[[3, 5]])
    key(ed, "d", pixel(ed, P[3]))
    assert len(ed.points) == 2
    key(ed, "o")  # cannot close two points
    assert ed.boundary == "clamped"


def test_level_keys_set_the_number_of_curve_points():
    P = wavy(12)
    ed = make(P, curves=ALL, levels=5)
    for level_key, boundary in (("3", "closed"), ("5", "closed"), ("3", "clamped")):
        if boundary != ed.boundary:
            key(ed, "o")
        key(ed, level_key)
        assert ed.levels == int(level_key)
        for name in ALL:
            expected = js.refined_count(12, ed.scheme(name), int(level_key), boundary)
            assert len(ed.curve_points[name]) == expected, (name, boundary)
    # The open curves are refined with clamped ends: they start at the first vertex.
    np.testing.assert_allclose(ed.curve_points["cubic-bspline"][0], P[0], atol=1e-12)


def test_keys_show_and_hide_artists():
    P = wavy(10)
    ed = make(P, levels=3)
    assert ed.shown == ("cubic-bspline", "four-point", "jarek")
    assert not ed.lines["chaikin"].get_visible()
    key(ed, "b")
    assert not ed.lines["cubic-bspline"].get_visible() and "cubic-bspline" not in ed.shown
    key(ed, "b")
    assert ed.lines["cubic-bspline"].get_visible()
    key(ed, "c")
    assert not ed.polygon_line.get_visible()
    key(ed, "c")
    assert ed.polygon_line.get_visible()
    # Chaikin, shown for the first time, is computed: a plain Python Chaikin loop agrees.
    key(ed, "k")
    assert ed.lines["chaikin"].get_visible()
    np.testing.assert_allclose(ed.curve_points["chaikin"], chaikin_python(P, 3, closed=True), atol=1e-12)
    key(ed, "x")
    np.testing.assert_allclose(
        ed.curve_points["corner-cutting"], corner_cutting_numpy(P, 0.25, 0.75, 3), atol=1e-12
    )
    visible = ed._help_text.get_visible()
    key(ed, "h")
    assert ed._help_text.get_visible() is not visible
    # Space restores the initial polygon.
    drag(ed, pixel(ed, P[0]), [pixel(ed, P[0] + 0.3)])
    assert not np.allclose(ed.points, P)
    key(ed, " ")
    np.testing.assert_array_equal(ed.points, P)


def test_sliders_set_the_parameters_and_the_curves_follow():
    P = wavy(16)
    ed = make(P, curves=ALL, levels=3)
    compiled = _refine_jit._cache_size()
    ed.sliders["w"].set_val(0.1)
    assert float(ed.scheme("four-point").w) == 0.1
    np.testing.assert_allclose(ed.curve_points["four-point"], four_point_numpy(P, 0.1, 3), atol=1e-12)
    expected = js.smoothness(js.FourPoint(0.1))
    assert expected.continuity == 1
    assert editor_module.format_smoothness(expected) in ed._texts["four-point"].get_text()
    assert "C¹" in ed._texts["four-point"].get_text()
    ed.sliders["r"].set_val(0.1)
    ed.sliders["s"].set_val(0.6)
    np.testing.assert_allclose(
        ed.curve_points["corner-cutting"], corner_cutting_numpy(P, 0.1, 0.6, 3), atol=1e-12
    )
    # Parameter values are traced: moving a slider compiles nothing.
    assert _refine_jit._cache_size() == compiled
    # r >= s is not a corner-cutting scheme: the curve disappears, the panel says why.
    ed.sliders["r"].set_val(0.7)
    ed.sliders["s"].set_val(0.65)
    assert ed.scheme("corner-cutting") is None
    assert len(ed.curve_points["corner-cutting"]) == 0
    assert "0 < r < s < 1" in ed._texts["corner-cutting"].get_text()
    # The t slider, driven with the mouse: press and drag along it.
    slider = ed.sliders["t"]
    box = slider.ax.bbox
    y = (box.y0 + box.y1) / 2
    at = lambda value: box.x0 + value * (box.x1 - box.x0)
    ed._smooth_seconds = 1.0  # as if the last smoothness call had been slow
    mouse(ed, "button_press_event", (at(0.2), y))
    mouse(ed, "motion_notify_event", (at(0.8), y))
    # While the slider moves after a slow call, the label waits for the release.
    assert slider.drag_active and "updates on release" in ed._texts["jarek"].get_text()
    mouse(ed, "button_release_event", (at(0.8), y))
    t = slider.val
    assert abs(t - 0.8) < 0.01
    assert float(ed.scheme("jarek").t) == t
    np.testing.assert_allclose(ed.curve_points["jarek"], split_tweak_numpy(P, t, 3), atol=1e-12)
    text = ed._texts["jarek"].get_text()
    assert editor_module.format_smoothness(js.smoothness(js.SplitTweak(t))) in text
    assert "release" not in text


def test_save_writes_files_that_read_back_to_the_polygon(tmp_path):
    P = wavy(9)
    ed = make(P, levels=3, save_prefix=tmp_path / "out" / "edit")
    drag(ed, pixel(ed, P[3]), [pixel(ed, P[3] + [0.2, 0.1])])
    key(ed, "s")
    polygon = ed.points
    saved = js.io.read_result_json(tmp_path / "out" / "edit.json")
    np.testing.assert_array_equal(saved.control_points, polygon)
    assert saved.boundary == "closed" and saved.levels == 3
    assert isinstance(saved.scheme, js.CubicBSpline)
    assert saved.info["editor"]["shown"] == ["cubic-bspline", "four-point", "jarek"]
    (outline,) = js.io.read_outlines(tmp_path / "out" / "edit-polygon.svg")
    np.testing.assert_allclose(outline.points, polygon, rtol=0, atol=1e-12)
    assert outline.closed
    # The B-spline SVG is the exact curve: its samples lie on a fine refinement of it.
    (curve,) = js.io.read_outlines(tmp_path / "out" / "edit-cubic-bspline.svg", samples=300)
    fine = np.asarray(js.refine(polygon, js.CubicBSpline(), 9))
    size = np.ptp(polygon, axis=0).max()
    assert polyline_distances(curve.points, fine).max() < 1e-4 * size
    for name in ("four-point", "jarek"):
        assert (tmp_path / "out" / f"edit-{name}.svg").stat().st_size > 0
    assert "saved" in ed.status


def test_picture_of_the_editor_is_not_blank(tmp_path):
    ed = make(wavy(16), curves=ALL)
    ed.savefig(tmp_path / "editor.png", dpi=60)
    image = matplotlib.image.imread(tmp_path / "editor.png")[..., :3]
    assert image.shape[0] > 100 and image.std() > 0.05
    # The curves' colors are in the picture (tab:blue, the four-point curve).
    blue = np.array([0x1F, 0x77, 0xB4]) / 255
    assert (np.abs(image - blue).max(axis=-1) < 0.1).sum() > 50


def test_float32_without_x64_and_the_configuration_is_left_alone():
    with jax.enable_x64(False):
        ed = make(wavy(10), curves=("four-point",), levels=3)
        assert ed.points.dtype == np.float32
        assert ed.curve_points["four-point"].dtype == np.float32
        expected = four_point_numpy(wavy(10), 1 / 16, 3)
        np.testing.assert_allclose(ed.curve_points["four-point"], expected, rtol=0, atol=1e-5)
        assert not jax.config.jax_enable_x64
    assert jax.config.jax_enable_x64


def test_bad_arguments_are_clear_errors():
    with pytest.raises(ValueError, match="at least 3"):
        make(SQUARE[:2])
    with pytest.raises(ValueError, match="shape"):
        make(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="curves"):
        make(SQUARE, curves=("spline",))
    with pytest.raises(ValueError, match="levels"):
        make(SQUARE, levels=12)
    with pytest.raises(ValueError, match="scheme"):
        Editor.from_fit(superellipse(100), scheme=js.Daubechies())


def test_fit_mode_edits_the_fitted_polygon_and_refits(tmp_path, monkeypatch):
    target = superellipse(200)
    figure = Figure()
    FigureCanvasAgg(figure)
    ed = Editor.from_fit(target, n_control=10, figure=figure)
    assert ed.points.shape == (10, 2)
    np.testing.assert_array_equal(ed.points, np.asarray(ed.fit_result.control_points))
    assert ed.target_line.get_visible()
    key(ed, "t")
    assert not ed.target_line.get_visible()
    # The fitted B-spline curve is close to the target samples (measured independently).
    fine = np.asarray(js.refine(ed.points, js.CubicBSpline(), 7))
    size = np.ptp(target, axis=0).max()
    before = polyline_distances(target, fine).max()
    assert before < 0.02 * size
    # `r` refits with the current vertex count, starting from the current polygon. (The
    # fit itself is tested in test_fit.py; a second compilation of it would cost ~10 s
    # here, so the call is recorded instead of run.)
    drag(ed, pixel(ed, ed.points[0]), [pixel(ed, ed.points[0] + [0.3, 0.3])])
    key(ed, "d", pixel(ed, ed.points[5]))
    calls = []

    def fake_fit(target_, scheme, n_control, **options):
        calls.append((target_, scheme, n_control, options))
        return eqx.tree_at(lambda r: r.control_points, ed.fit_result, options["init"] + 1.0)

    monkeypatch.setattr("fitting.fit", fake_fit)
    edited = ed.points
    key(ed, "r")
    ((target_, scheme, n_control, options),) = calls
    np.testing.assert_array_equal(target_, target)
    assert isinstance(scheme, js.CubicBSpline) and n_control == 9
    np.testing.assert_array_equal(options["init"], edited)
    assert options["boundary"] == "closed" and options["on_failure"] == "ignore"
    np.testing.assert_array_equal(ed.points, edited + 1.0)
    monkeypatch.undo()
    # The command line: a parser built here, with the edit subcommand.
    np.savetxt(tmp_path / "outline.csv", target, delimiter=",")
    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(
        ["edit", str(tmp_path / "outline.csv"), "--fit", "--n", "10", "--png", str(tmp_path / "fit.png")]
    )
    assert args.run is run
    assert run(args) == 0
    assert matplotlib.image.imread(tmp_path / "fit.png").std() > 0.05


def test_command_line(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(dest="command"))
    png = tmp_path / "star.png"
    args = parser.parse_args(
        ["edit", "--shape", "star", "--curves", "chaikin,four-point", "--levels", "3", "--png", str(png)]
    )
    assert run(args) == 0
    assert "10 control points, closed, level 3" in capsys.readouterr().out
    assert matplotlib.image.imread(png).std() > 0.05
    args = parser.parse_args(["edit", "--shape", "U", "--open", "--png", str(png)])
    assert run(args) == 0
    assert "clamped" in capsys.readouterr().out
    # No display (Agg) and no --png: a clear error naming the fix.
    with pytest.raises(ValueError, match="--png"):
        run(parser.parse_args(["edit"]))
    with pytest.raises(ValueError, match="not both"):
        run(parser.parse_args(["edit", "x.csv", "--shape", "star", "--png", str(png)]))
    with pytest.raises(SystemExit):
        parser.parse_args(["edit", "--curves", "spline"])
