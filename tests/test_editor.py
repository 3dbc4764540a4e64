"""The interactive editor: its headless state driven by its methods, and the matplotlib
view driven by synthetic matplotlib events (Agg)."""

import argparse
import json
import os
import subprocess
import sys

import equinox as eqx
import jax
import matplotlib.image
import numpy as np
import pytest
from helpers import chaikin_python, four_point_numpy, polyline_distances, superellipse
from matplotlib.backend_bases import KeyEvent, MouseEvent
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import jaxsubdiv as js
from jaxsubdiv import editor as editor_module
from jaxsubdiv._editor_cli import add_parser, run
from jaxsubdiv._refine import _refine_jit
from jaxsubdiv.editor import Editor, EditorState


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
    ed.state.smoothness_seconds = 1.0  # as if the last smoothness call had been slow
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
    # --samples resamples a shape (40 points, not its 10 corners); --fit samples it at
    # 400 points by default, as `jaxsubdiv fit --shape` does (its 10 corners were fewer
    # than a fit's unknowns: an error).
    assert run(parser.parse_args(["edit", "--shape", "star", "--samples", "40",
                                  "--png", str(png)])) == 0
    assert "40 control points" in capsys.readouterr().out
    assert run(parser.parse_args(["edit", "--shape", "star", "--fit", "--png", str(png)])) == 0
    assert "16 control points" in capsys.readouterr().out
    # No display (Agg) and no --png: a clear error naming the fix.
    with pytest.raises(ValueError, match="--png"):
        run(parser.parse_args(["edit"]))
    with pytest.raises(ValueError, match="not both"):
        run(parser.parse_args(["edit", "x.csv", "--shape", "star", "--png", str(png)]))
    with pytest.raises(SystemExit):
        parser.parse_args(["edit", "--curves", "spline"])


# The headless state -------------------------------------------------------------------


def periodic_subdivide(P, even, odd, levels):
    """One binary subdivision rule applied `levels` times to a closed polygon, written
    as plain stencils: Q[2i] = sum_k even[k] P[i + k], Q[2i + 1] = sum_k odd[k] P[i + k]
    (`even`, `odd`: dicts offset -> weight)."""
    for _ in range(levels):
        Q = np.empty((2 * len(P), 2))
        Q[0::2] = sum(w * np.roll(P, -k, 0) for k, w in even.items())
        Q[1::2] = sum(w * np.roll(P, -k, 0) for k, w in odd.items())
        P = Q
    return P


def holder(label):
    """The Hölder exponent in a smoothness label (`C¹, α ≈ 2.000` -> 2.0)."""
    return float(label.split("α")[1].split()[1])


def test_state_curves_follow_edits_against_plain_subdivision_rules():
    P = wavy(11, seed=3)
    state = EditorState(P, curves=ALL, levels=4)
    # Cubic B-spline (Lane-Riesenfeld): Q2i = (P[i-1] + 6 P[i] + P[i+1]) / 8, Q2i+1 = (P[i] + P[i+1]) / 2.
    bspline = lambda Q: periodic_subdivide(Q, {-1: 1 / 8, 0: 6 / 8, 1: 1 / 8}, {0: 0.5, 1: 0.5}, 4)
    references = {
        "cubic-bspline": bspline,
        "four-point": lambda Q: four_point_numpy(Q, 1 / 16, 4),
        "jarek": lambda Q: split_tweak_numpy(Q, 0.5, 4),
        "chaikin": lambda Q: np.asarray(chaikin_python(Q, 4, closed=True)),
        "corner-cutting": lambda Q: corner_cutting_numpy(Q, 0.25, 0.75, 4),
    }

    def check():
        for name, reference in references.items():
            np.testing.assert_allclose(
                state.curve_points[name], reference(state.points), rtol=0, atol=1e-12, err_msg=name
            )

    check()
    state.move_vertex(4, (0.3, -0.2))
    np.testing.assert_array_equal(state.points[4], [0.3, -0.2])
    check()
    assert state.insert_vertex(10, (1.2, -0.1)) == 11  # on the closing edge (10, 0)
    np.testing.assert_array_equal(state.points[11], [1.2, -0.1])
    check()
    assert state.delete_vertex(0)
    assert len(state.points) == 11
    check()
    state.set_parameter("w", 0.1)
    state.set_parameter("t", 0.3)
    references["four-point"] = lambda Q: four_point_numpy(Q, 0.1, 4)
    references["jarek"] = lambda Q: split_tweak_numpy(Q, 0.3, 4)
    check()
    state.set_points(P)
    check()
    # Hidden curves hold no points; shown again, they are computed for the current polygon.
    assert not state.toggle("chaikin") and "chaikin" not in state.curve_points
    state.move_vertex(0, (1.4, 0.1))
    assert state.toggle("chaikin")
    check()
    # Open: clamped ends, so every curve starts at the first vertex and ends at the last.
    assert state.set_closed(False) and state.boundary == "clamped"
    for name in ALL:
        np.testing.assert_allclose(state.curve_points[name][[0, -1]], state.points[[0, -1]], atol=1e-12)
    state.set_level(2)
    assert len(state.curve_points["four-point"]) == js.refined_count(11, js.FourPoint(0.1), 2, "clamped")
    state.reset()
    np.testing.assert_array_equal(state.points, P)
    assert state.closed and state.status == "reset"


def test_state_smoothness_labels_against_published_exponents():
    state = EditorState(SQUARE, curves=ALL)
    # Cubic B-spline: C², Hölder exponent 3 exactly; Chaikin and corner cutting at
    # (1/4, 3/4) (the same scheme): quadratic B-spline, C¹, exponent 2.
    assert state.smoothness["cubic-bspline"] == "C², α = 3.000"
    for name in ("chaikin", "corner-cutting"):
        assert state.smoothness[name] == "C¹, α = 2.000", name
    # Four-point at w = 1/16: C¹ and not C², Hölder exponent 2 - ε (Dyn, Levin, Gregory
    # 1987; Daubechies and Lagarias 1992).
    label = state.smoothness["four-point"]
    assert label.startswith("C¹,") and abs(holder(label) - 2.0) < 1e-3
    # t = 0 is the cubic B-spline (Luffel and Rossignac): C², exponent 3.
    state.set_parameter("t", 0.0)
    assert state.smoothness["jarek"].startswith("C²,") and abs(holder(state.smoothness["jarek"]) - 3) < 1e-3
    # Deferred: the label waits for update_smoothness().
    state.set_parameter("w", 0.0, defer_smoothness=True)
    assert state.stale_smoothness == {"four-point"} and state.smoothness["four-point"] == label
    state.update_smoothness()
    # w = 0: piecewise-linear interpolation, C⁰ with Hölder exponent 1.
    assert state.stale_smoothness == set()
    assert state.smoothness["four-point"].startswith("C⁰,") and holder(state.smoothness["four-point"]) == 1.0


def test_parameters_out_of_range_are_clear_errors():
    # The editor draws limit curves, so its ranges are where the schemes converge:
    # four-point -1/2 < w < 1/2 and split-tweak -9 < t < 7 (test_analysis checks both
    # against the transition matrices' eigenvalues); corner cutting needs 0 < r < s < 1.
    state = EditorState(SQUARE, curves=ALL, levels=2)
    for name, bad in (("w", 0.5), ("w", 0.6), ("w", -0.5), ("r", 0.0), ("s", 1.0), ("t", 7.0),
                      ("t", -9.5), ("w", float("nan"))):
        with pytest.raises(ValueError, match=rf"`{name}`.*{name} <") as error:
            state.set_parameter(name, bad)
        assert "1" in str(error.value) or "9" in str(error.value)  # the bounds are named
    assert state.parameters == {"w": 1 / 16, "r": 0.25, "s": 0.75, "t": 0.5}
    with pytest.raises(ValueError, match=r"`w`.*-1/2 < w < 1/2 \(where the scheme converges\)"):
        state.set_parameter("w", 0.6)
    for name, good in (("w", 0.4999), ("w", -0.4999), ("t", 1.0), ("t", 0.0), ("t", 6.9),
                       ("r", 0.01)):
        state.set_parameter(name, good)
        assert state.parameters[name] == good
    with pytest.raises(ValueError, match="name"):
        state.set_parameter("q", 0.1)
    with pytest.raises(TypeError, match="w"):
        state.set_parameter("w", "big")
    with pytest.raises(ValueError, match=r"`w`.*1/2"):
        EditorState(SQUARE, w=0.6)
    with pytest.raises(TypeError, match="q"):
        EditorState(SQUARE, q=0.3)
    # The view: the same error, and neither the slider nor the curve moved.
    ed = make(SQUARE, levels=2)
    before = ed.curve_points["four-point"].copy()
    with pytest.raises(ValueError, match=r"`w`.*-1/2 < w < 1/2"):
        ed.set_parameter("w", 0.6)
    assert ed.sliders["w"].val == 1 / 16 and ed.parameters["w"] == 1 / 16
    np.testing.assert_array_equal(ed.curve_points["four-point"], before)
    with pytest.raises(ValueError, match=r"`w`.*1/2"):
        make(SQUARE, w=0.6)
    # The sliders stay inside the ranges (open ends nudged inside by 1%).
    for name, (low, high, default) in editor_module.PARAMETERS.items():
        assert low < default < high
        EditorState(SQUARE, **{name: low}), EditorState(SQUARE, **{name: high})
    assert editor_module.PARAMETERS["t"][:2] == (0.0, 1.0)  # Rossignac's family
    assert editor_module.PARAMETERS["w"][:2] == pytest.approx((-0.49, 0.49))


def test_state_save_writes_files_that_read_back(tmp_path):
    P = wavy(7)
    state = EditorState(P, levels=3, curves=("four-point", "chaikin"), w=0.1, save_prefix=tmp_path / "s")
    written = state.save()
    assert sorted(os.path.basename(p) for p in written) == [
        "s-chaikin.svg", "s-four-point.svg", "s-polygon.svg", "s.json"
    ]
    saved = js.io.read_result_json(tmp_path / "s.json")
    np.testing.assert_array_equal(saved.control_points, P)
    assert isinstance(saved.scheme, js.FourPoint) and float(saved.scheme.w) == 0.1
    assert saved.info["editor"]["parameters"]["w"] == 0.1
    assert json.loads((tmp_path / "s.json").read_text())["info"]["editor"]["closed"] is True
    assert "saved 4 files" in state.status
    pictures = []
    state.save(tmp_path / "t", picture=pictures.append)
    assert pictures == [os.fspath(tmp_path / "t.png")]


def test_state_runs_without_matplotlib(tmp_path):
    script = f"""
import sys
import numpy as np
from jaxsubdiv.editor import EditorState
state = EditorState(np.array([[0., 0.], [1., 0.], [1., 1.], [0., 1.]]), levels=3,
                    curves=("four-point", "corner-cutting"))
state.move_vertex(0, (0.1, 0.1))
state.insert_vertex(0, (0.5, -0.1))
assert state.delete_vertex(4)
state.set_closed(False); state.set_level(2); state.toggle("chaikin")
state.set_parameter("w", 0.1); state.set_parameter("r", 0.3)
state.save({os.fspath(tmp_path / "x")!r})
assert len(state.curve_points["chaikin"]) > 0 and state.smoothness["four-point"]
print(sorted(m for m in sys.modules if m.split(".")[0] == "matplotlib"))
"""
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
        cwd=tmp_path, env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
    assert (tmp_path / "x.json").exists()


# The view's key table ------------------------------------------------------------------


def test_key_table_drives_the_same_actions_as_the_state_methods(tmp_path):
    P = wavy(10, seed=1)
    ed = make(P, levels=2, save_prefix=tmp_path / "view")
    state = EditorState(P, levels=2, save_prefix=tmp_path / "state")
    ed.move_vertex(3, P[3] + 0.2)
    state.move_vertex(3, P[3] + 0.2)
    at_vertex_5 = pixel(ed, ed.points[5])

    def same():
        np.testing.assert_array_equal(ed.points, state.points)
        assert (ed.closed, ed.levels, ed.shown, ed.parameters, ed.status) == (
            state.closed, state.levels, state.shown, state.parameters, state.status
        )
        assert ed.curve_points.keys() == state.curve_points.keys()
        for name in state.curve_points:
            np.testing.assert_array_equal(ed.curve_points[name], state.curve_points[name])

    # What each key must do, written from the documented key map (docs/editor.md).
    state_actions = {
        **{k: (lambda n=n: state.toggle(n)) for k, n in zip("bfjkx", ALL)},
        **{str(i): (lambda i=i: state.set_level(i)) for i in range(1, 10)},
        "d": lambda: state.delete_vertex(5),
        "delete": lambda: state.delete_vertex(5),
        "backspace": lambda: state.delete_vertex(5),
        "o": lambda: state.set_closed(not state.closed),
        " ": state.reset,
        "s": lambda: state.save(),
        "r": state.refit,
    }

    def view_only(name):
        """Prepare for a key that changes only the view; returns the check after it."""
        if name in ("c", "h"):
            artist = ed.polygon_line if name == "c" else ed._help_text
            visible = artist.get_visible()
            return lambda: artist.get_visible() is (not visible)
        if name == "a":
            ed.ax.set_xlim(-5.0, 5.0)
            low, high = state.bounds()
            return lambda: ed.ax.get_xlim()[0] < low[0] and high[0] < ed.ax.get_xlim()[1] < 5.0
        assert name == "t"
        return lambda: ed.target_line is None and ed.toggle("target") is False

    assert set(ed.keys) == set(state_actions) | {"c", "h", "a", "t"}
    for name in ed.keys:
        check = None if name in state_actions else view_only(name)
        key(ed, name, at_vertex_5 if name in ("d", "delete", "backspace") else None)
        if check is not None:
            assert check(), name
        else:
            state_actions[name]()
        if name == "s":  # each names its own prefix, and the view adds its picture
            assert ed.status.startswith("saved 5 files") and state.status.startswith("saved 4 files")
            state.status = ed.status
        same()
        if name in ("d", "delete", "backspace"):
            at_vertex_5 = pixel(ed, ed.points[5])
    saved = js.io.read_result_json(tmp_path / "view.json")
    np.testing.assert_array_equal(saved.control_points, js.io.read_result_json(tmp_path / "state.json").control_points)
    assert "no target to refit" in ed.status


@pytest.mark.parametrize("fit", [False, True])
def test_help_lines_fit_the_default_figure_and_come_from_the_key_table(fit):
    figure = Figure(figsize=(11, 7.5), dpi=100)  # the size of Editor(figure=None)
    FigureCanvasAgg(figure)
    target = superellipse(50) if fit else None
    ed = Editor(wavy(10), figure=figure, target=target)
    figure.canvas.draw()
    help_text = ed._help_text
    assert not help_text.get_wrap()
    lines = help_text.get_text().split("\n")
    assert len(lines) == 2
    extent = help_text.get_window_extent(figure.canvas.get_renderer())
    assert 0 <= extent.x0 and extent.x1 <= figure.bbox.width, (extent, figure.bbox)
    assert extent.y1 <= figure.bbox.height
    # Not over the drawing axes either.
    assert extent.y0 >= ed.ax.get_position().y1 * figure.bbox.height
    # Every key of the table is described, with its description.
    text = help_text.get_text()
    for name, (description, _) in ed.keys.items():
        if name in editor_module.FIT_KEYS and not fit:
            assert f"{name} {description}" not in text
            continue
        if name.isdigit():
            continue  # "1-9 level", below
        shown = {" ": "space"}.get(name, name)
        assert description in text and shown in text, name
    assert "1-9 level" in text and "d/delete/backspace delete vertex" in text


def test_the_docs_key_table_lists_exactly_the_editor_keys():
    """docs/editor.md's table of keys names every key of the editor's table, and no other."""
    path = os.path.join(os.path.dirname(__file__), "..", "docs", "editor.md")
    with open(path, encoding="utf-8") as file:
        text = file.read()
    section = text.split("## Keys")[1].split("\n## ")[0]
    documented = set()
    for row in section.splitlines():
        if not row.startswith("| ") or row.startswith("| key"):
            continue
        cell = row.split("|")[1].replace("`1`-`9`", "1-9")
        for name in cell.replace("`", " ").replace(",", " ").split():
            if name == "1-9":
                documented.update(str(i) for i in range(1, 10))
            else:
                documented.add({"space": " "}.get(name, name))
    assert documented == set(editor_module.KEYS)


def test_schemes_map_to_the_editor_curves_that_draw_them():
    from jaxsubdiv._editor_state import scheme_curve

    assert scheme_curve(js.CubicBSpline()) == ("cubic-bspline", {})
    assert scheme_curve(js.FourPoint(0.1)) == ("four-point", {"w": 0.1})
    assert scheme_curve(js.SplitTweak(0.3)) == ("jarek", {"t": 0.3})
    # Jarek's scheme is split-and-tweak at t = 1/2 (Luffel and Rossignac).
    assert scheme_curve(js.Jarek()) == ("jarek", {"t": 0.5})
    assert scheme_curve(js.Chaikin()) == ("chaikin", {})
    assert scheme_curve(js.CornerCutting(0.1, 0.6)) == ("corner-cutting", {"r": 0.1, "s": 0.6})
    for scheme in (js.Daubechies(), js.LaneRiesenfeld(4), js.MaskScheme([0.5, 1, 0.5], -1)):
        with pytest.raises(ValueError, match="the editor draws"):
            scheme_curve(scheme)
    assert [c.label for c in editor_module.CURVES.values()] == [
        "cubic B-spline", "four-point", "Jarek (split-tweak t)", "Chaikin", "corner cutting (r, s)"
    ]


def test_outline_is_counted_from_1(tmp_path, capsys):
    """--outline K picks the K-th contour counted from 1, as `jaxsubdiv fit` reports
    them (issue #18: it counted from 0); 0 and K past the last are errors naming the
    range."""
    svg = tmp_path / "two.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg">'
                   '<polygon points="0,0 4,0 4,4 0,4"/>'
                   '<polygon points="10,0 14,0 15,2 14,4 10,4 9,2"/></svg>')
    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(dest="command"))
    png = tmp_path / "two.png"
    for k, count in ((1, 4), (2, 6)):
        args = parser.parse_args(["edit", str(svg), "--outline", str(k), "--png", str(png)])
        assert run(args) == 0
        assert f"{count} control points, closed" in capsys.readouterr().out
    for k in (0, 3):
        args = parser.parse_args(["edit", str(svg), "--outline", str(k), "--png", str(png)])
        with pytest.raises(ValueError, match=r"--outline must be in \[1, 2\]"):
            run(args)
