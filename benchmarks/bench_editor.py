"""Responsiveness of the interactive editor (`jaxsubdiv.editor.Editor`), headless (Agg).

    python benchmarks/bench_editor.py                  # 100 control points, level 5
    python benchmarks/bench_editor.py --smoke          # 10 events (10-20 s, mostly compiling)
    python benchmarks/bench_editor.py --output DIR     # where editor.json / editor.md go

The case of the issue: a closed polygon of 100 control points, level 5, all five curves
shown (cubic B-spline, four-point, Jarek, Chaikin, corner cutting: 5 x 3,200 points),
float64, an 11 x 7.5 inch figure at 100 dpi on the Agg canvas. A vertex is grabbed with
a synthetic `button_press_event` and moved with `motion_notify_event`s processed by the
canvas like a GUI's events. Every figure is a median over the events.

Rows:

- `drag event`: one motion event as the editor handles it: the five curves recomputed
  with `jaxsubdiv.refine`, `set_data` on the lines, and the lines and polygon drawn over
  the saved background into the Agg buffer (blitting; a GUI backend then copies that
  region to the screen).
- `curve recompute`: the five `refine` calls and `set_data` only.
- baseline `numpy np.roll`: the same five curves refined level by level in numpy (each
  level a sum of `np.roll`-shifted copies weighted by the mask) and `set_data`.
- baseline `full redraw`: the same update followed by a full `canvas.draw()` of the
  figure, which is what `draw_idle` costs without blitting.
- `insert a vertex`: `Editor.insert_vertex` plus a full draw. Closed polygons are padded
  to a multiple of 32 points, so this compiles nothing (the count of kernels compiled is
  in the row). An open polygon (clamped ends) compiles every shown curve's kernel once
  per new vertex count; the row "count seen before" repeats an insertion into a size
  compiled before.
- `level key (new level)`: `set_level` to a level not compiled yet.
- `slider move`: `Slider.set_val` on `w`: four-point curve, smoothness, full draw.
- `smoothness`: `jaxsubdiv.smoothness(FourPoint(w))` on 41 values of `w`, cache cleared:
  median and maximum per value (why the editor computes it live only while it is fast).
"""

import argparse
import json
import os
import pathlib
import statistics
import time

import jax


jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from matplotlib.backend_bases import MouseEvent  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import jaxsubdiv as js  # noqa: E402
from jaxsubdiv._analysis.smoothness import _smoothness_cached  # noqa: E402
from jaxsubdiv._refine import _refine_jit  # noqa: E402
from jaxsubdiv.editor import CURVES, Editor  # noqa: E402


RESULTS = pathlib.Path(__file__).parent / "results"


def polygon(n, seed=0):
    rng = np.random.default_rng(seed)
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False)
    radius = 1 + 0.15 * np.cos(5 * theta) + 0.02 * rng.standard_normal(n)
    return np.stack([radius * np.cos(theta), radius * np.sin(theta)], axis=1)


def numpy_roll_refine(points, mask, start, levels):
    """Closed refinement, level by level: Q[2i + p] = sum_{k = p mod 2} a_k P[i - (k - p)/2]."""
    P = points
    for _ in range(levels):
        Q = np.empty((2 * len(P), P.shape[1]))
        for p in (0, 1):
            acc = np.zeros_like(P)
            for offset, a in enumerate(mask):
                k = start + offset
                if (k - p) % 2 == 0 and a != 0:
                    acc += a * np.roll(P, (k - p) // 2, axis=0)
            Q[p::2] = acc
        P = Q
    return P


def event(ed, name, xy, button=1):
    canvas = ed.figure.canvas
    canvas.callbacks.process(name, MouseEvent(name, canvas, *xy, button=button))


def median_ms(times):
    return 1e3 * statistics.median(times)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--smoke", action="store_true", help="10 events instead of 120")
    parser.add_argument("--output", type=pathlib.Path, help="directory for the results")
    args = parser.parse_args()
    n, levels = 100, 5
    events = 10 if args.smoke else 120
    out_dir = args.output or RESULTS
    stem = "editor_smoke" if args.smoke and args.output is None else "editor"

    P = polygon(n)
    figure = Figure(figsize=(11, 7.5), dpi=100)
    FigureCanvasAgg(figure)
    start = time.perf_counter()
    ed = Editor(P, curves=tuple(CURVES), levels=levels, figure=figure)
    construct = time.perf_counter() - start
    figure.canvas.draw()

    # The numpy baseline computes the same curves (checked before timing).
    schemes = {name: ed.scheme(name) for name in CURVES}
    masks = {name: (np.asarray(s.mask(), dtype=np.float64), s.mask_start) for name, s in schemes.items()}
    for name, (mask, first) in masks.items():
        np.testing.assert_allclose(
            numpy_roll_refine(P, mask, first, levels), ed.curve_points[name], atol=1e-12
        )

    # Drag: grab vertex 10 and move it along a small circle.
    index = 10
    center = ed.ax.transData.transform(P[index])
    event(ed, "button_press_event", center)
    assert ed._dragging == index
    compiled = _refine_jit._cache_size()
    drag_times = []
    for i in range(events):
        angle = 2 * np.pi * i / 24
        xy = center + 25 * np.array([np.cos(angle), np.sin(angle)])
        t0 = time.perf_counter()
        event(ed, "motion_notify_event", xy)
        drag_times.append(time.perf_counter() - t0)
    retraced = _refine_jit._cache_size() - compiled
    event(ed, "button_release_event", center)

    # Curve recompute alone, and the numpy np.roll baseline of it.
    compute_times, numpy_times, full_times = [], [], []
    for i in range(events):
        ed.state._points[index, 0] += 1e-4 * (-1) ** i
        t0 = time.perf_counter()
        ed.state.update_curves()  # the model: five refine calls
        ed._update_lines()  # the view: set_data
        compute_times.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for name, (mask, first) in masks.items():
            curve = numpy_roll_refine(ed.state._points, mask, first, levels)
            closed = np.concatenate([curve, curve[:1]])
            ed.lines[name].set_data(closed[:, 0], closed[:, 1])
        numpy_times.append(time.perf_counter() - t0)
    for i in range(max(events // 4, 5)):
        ed.state._points[index, 0] += 1e-4 * (-1) ** i
        t0 = time.perf_counter()
        ed.state.update_curves()
        ed._update_lines()
        figure.canvas.draw()
        full_times.append(time.perf_counter() - t0)

    # Shape changes. Closed polygons are padded to a multiple of 32 points, so inserting
    # or deleting a vertex reuses the compiled kernels; open (clamped) ones compile once
    # per new vertex count.
    compiled = _refine_jit._cache_size()
    t0 = time.perf_counter()
    ed.insert_vertex(0, (P[0] + P[1]) / 2)
    insert_closed = time.perf_counter() - t0
    insert_closed_compiled = _refine_jit._cache_size() - compiled
    ed.delete_vertex(1)
    t0 = time.perf_counter()
    ed.set_level(6)
    level_new = time.perf_counter() - t0
    ed.set_level(levels)
    ed.set_closed(False)
    t0 = time.perf_counter()
    ed.insert_vertex(0, (P[0] + P[1]) / 2)
    insert_open_new = time.perf_counter() - t0
    ed.delete_vertex(1)
    t0 = time.perf_counter()
    ed.insert_vertex(0, (P[0] + P[1]) / 2)
    insert_open_seen = time.perf_counter() - t0
    ed.delete_vertex(1)
    ed.set_closed(True)

    slider_times = []
    for i in range(max(events // 10, 3)):
        t0 = time.perf_counter()
        ed.sliders["w"].set_val(0.05 + 0.001 * i)
        slider_times.append(time.perf_counter() - t0)

    smooth_times = []
    for w in np.linspace(-0.2, 0.2, 9 if args.smoke else 41):
        _smoothness_cached.cache_clear()
        t0 = time.perf_counter()
        js.smoothness(js.FourPoint(w))
        smooth_times.append(time.perf_counter() - t0)

    drag_ms = median_ms(drag_times)
    compute_ms, numpy_ms = median_ms(compute_times), median_ms(numpy_times)
    full_ms = median_ms(full_times)
    result = dict(
        case=f"closed polygon, n = {n}, level {levels}, 5 curves x {n * 2**levels} points, float64",
        smoke=args.smoke,
        events=events,
        cpu_count=os.cpu_count(),
        construct_seconds=construct,
        drag_event_ms=drag_ms,
        drag_event_p90_ms=1e3 * float(np.percentile(drag_times, 90)),
        retraced_during_drag=retraced,
        curve_recompute_ms=compute_ms,
        numpy_roll_recompute_ms=numpy_ms,
        numpy_over_jax_recompute=numpy_ms / compute_ms,
        full_redraw_event_ms=full_ms,
        full_redraw_over_drag_event=full_ms / drag_ms,
        insert_vertex_closed_seconds=insert_closed,
        insert_vertex_closed_kernels_compiled=insert_closed_compiled,
        insert_vertex_open_new_count_seconds=insert_open_new,
        insert_vertex_open_seen_count_seconds=insert_open_seen,
        level_key_new_level_seconds=level_new,
        slider_move_ms=median_ms(slider_times),
        smoothness_median_ms=median_ms(smooth_times),
        smoothness_max_ms=1e3 * max(smooth_times),
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / f"{stem}.json").write_text(json.dumps(result, indent=2))
    lines = [
        "# Editor responsiveness",
        "",
        f"{result['case']}; Agg canvas, 11 x 7.5 in at 100 dpi; median of {events} events "
        f"(2-core shared CPU, noisy: compare ratios within the run).",
        "",
        "| what | median | vs editor |",
        "| --- | ---: | ---: |",
        f"| **drag event** (recompute 5 curves + blit into the Agg buffer) | {drag_ms:.1f} ms "
        f"(p90 {result['drag_event_p90_ms']:.1f}) | 1 |",
        f"| curve recompute only (5 x `jaxsubdiv.refine` + `set_data`) | {compute_ms:.2f} ms | |",
        f"| baseline: same recompute in numpy, `np.roll` per level | {numpy_ms:.2f} ms | "
        f"{numpy_ms / compute_ms:.1f}x slower |",
        f"| baseline: same update + full `canvas.draw()` (no blitting) | {full_ms:.1f} ms | "
        f"{full_ms / drag_ms:.1f}x slower |",
        f"| slider move (`w`: curve, smoothness, full draw) | {result['slider_move_ms']:.1f} ms | |",
        f"| insert a vertex, closed polygon ({insert_closed_compiled} kernels compiled) + full draw "
        f"| {insert_closed * 1e3:.0f} ms | |",
        f"| insert a vertex, open polygon, new count (compiles 5 kernels) + full draw | "
        f"{insert_open_new:.2f} s | |",
        f"| insert a vertex, open polygon, count seen before + full draw | "
        f"{insert_open_seen * 1e3:.0f} ms | |",
        f"| level key, new level (compiles 5 kernels) + full draw | {level_new:.2f} s | |",
        f"| `smoothness(FourPoint(w))`, cache cleared, per value | "
        f"{result['smoothness_median_ms']:.1f} ms (max {result['smoothness_max_ms']:.0f}) | |",
        f"| editor construction (compiles 5 kernels) | {construct:.2f} s | |",
        "",
        f"Kernels traced again while dragging: {retraced} (the drag reuses the compiled "
        "kernels: same shapes, new values).",
        "",
    ]
    (out_dir / f"{stem}.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
