"""The phase of a closed fit's start: `fitting.fit(phases=4)` against the default (1).

    python benchmarks/bench_fit_phases.py            # about 5 min on 2 cores
    python benchmarks/bench_fit_phases.py --smoke    # two outlines, two known curves

A closed curve's linear start puts its control polygon's first span at the first sample
(in the samples' canonical order), and which local minimum the fit then reaches depends
on that phase. `phases=K` fits K starts, the polygon's phase shifted by j/K of a span,
each to `tol`, and returns the converged one of least two-sided RMS (`fit` runs them one
by one, `fitting._core.run_phases`; until 2026-12-07 23:00 UTC the one of least loss:
`results/fit_phases_by_loss.md`). Both settings run in this one process, alternating, on:

- **curves made from known polygons** (noise-free, exactly representable): the
  wobbly-ellipse polygons of 16 points and the uneven samples of
  `bench_fit_quality.py`'s recovery table, for the closed cubic B-spline (curve by its
  basis functions in numpy) and the four-point, split-and-tweak and corner-cutting
  schemes at fixed parameters (numpy refinement by the published rules, exact limit
  stencils): the two-sided max distance between the fitted and the true curve, in units
  of the size (the larger bounding-box side), and the floor: the same fit started at the
  true polygon (`init`), which no start beats;
- **real outlines**: `bench_fit_quality.py`'s 38 (glyphs of five fonts, two silhouettes,
  six icons; 400 samples each) at n = 32 and 64, with the closed cubic B-spline: the
  two-sided RMS measured independently of the fit (`bench_fit_quality.measure`), the
  status, and the warm time (median of `REPEATS` calls, both settings compiled first).

and the **first call** of each setting in fresh interpreters (`FIRST_ROUNDS` rounds,
alternating): DejaVu Sans 'S' with 32 control points, no compilation cache, the
command's XLA flags (the fusion emitters off), as a first `jaxsubdiv fit` compiles it.

Writes `benchmarks/results/fit_phases.json` and `.md`.
"""

import argparse
import os
import pathlib
import statistics
import sys
import time

import jax
import numpy as np


jax.config.update("jax_enable_x64", True)
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import bench_fit_quality as quality  # noqa: E402
from _common import child_json, header, load, median_range, write_results  # noqa: E402

import fitting  # noqa: E402
import jaxsubdiv as js  # noqa: E402


REPEATS = 3
FIRST_ROUNDS = 3
#: A first fit in a fresh interpreter, timed from before the call (what it compiles).
FIRST = (
    "import sys, time, json, warnings, jax; jax.config.update('jax_enable_x64', True); "
    "import bench_fit_quality as q, fitting, jaxsubdiv as js; "
    "s = q.resample_closed(q.glyph('DejaVu Sans', 'S')); warnings.simplefilter('ignore'); "
    "t = time.perf_counter(); "
    "r = fitting.fit(s, js.CubicBSpline(), 32, phases=int(sys.argv[1]), on_failure='ignore'); "
    "jax.block_until_ready(r); print(json.dumps([time.perf_counter() - t, float(r.rms)]))"
)
#: (scheme name, parameter values): the known curves' schemes, parameters held fixed.
KNOWN = [("CubicBSpline", {}), ("FourPoint", {"w": 0.04}), ("FourPoint", {"w": 0.1}),
         ("SplitTweak", {"t": 0.25}), ("SplitTweak", {"t": 0.75}),
         ("CornerCutting", {"r": 0.25, "s": 0.75})]
POLYGONS = 6  # seeds of `quality.recovery_polygon` per scheme
SCHEMES = dict(quality.SCHEMES, CubicBSpline=js.CubicBSpline)


def scheme_of(name, values):
    return SCHEMES[name](**values)


def known_curve_rows(cases, seeds, log):
    rows = []
    for name, values in cases:
        for seed in range(seeds):
            polygon = quality.recovery_polygon(seed)
            truth = quality.dense_curve(polygon, name, values,
                                        points=len(polygon) * 2**quality.RECOVERY_LEVELS)
            samples = quality.recovery_samples(truth, seed)
            size = float(np.ptp(truth, axis=0).max())

            def error(result):
                curve = quality.dense_curve(result.control_points, name, values,
                                            points=len(polygon) * 2**quality.RECOVERY_LEVELS)
                return float(max(quality.points_to_dense_curve(curve, truth).max(),
                                 quality.points_to_dense_curve(truth, curve).max()) / size)

            scheme = scheme_of(name, values)
            n = len(polygon)
            row = {"scheme": name, "values": values, "seed": seed,
                   "floor": error(quality.quiet_fit(samples, scheme, n, init=polygon))}
            for phases in (1, 4):
                result = quality.quiet_fit(samples, scheme, n, phases=phases)
                row[f"error_{phases}"] = error(result)
                row[f"status_{phases}"] = fitting.STATUSES[int(result.status)]
            rows.append(row)
            log(f"{name} {values} seed {seed}: floor {row['floor']:.1e}, one phase "
                f"{row['error_1']:.1e}, four {row['error_4']:.1e}")
    return rows


def outline_rows(shapes, ns, log):
    rows = []
    scheme = js.CubicBSpline()
    for label, samples in shapes.items():
        for n in ns:
            row = {"outline": label, "n": n}
            results = {}
            for phases in (1, 4):  # compiled (and warmed) before timing
                results[phases] = quality.quiet_fit(samples, scheme, n, phases=phases)
            times = {1: [], 4: []}
            for _ in range(REPEATS):
                for phases in (1, 4):
                    start = time.perf_counter()
                    quality.quiet_fit(samples, scheme, n, phases=phases)
                    times[phases].append(time.perf_counter() - start)
            for phases, result in results.items():
                curve = quality.dense_curve(result.control_points)
                row[f"rms_{phases}"] = quality.measure(curve, samples)["rms"]
                row[f"seconds_{phases}"] = statistics.median(times[phases])
                row[f"status_{phases}"] = fitting.STATUSES[int(result.status)]
                row[f"steps_{phases}"] = int(result.num_steps)
            rows.append(row)
            log(f"{label} n={n}: rms {row['rms_1']:.3g} -> {row['rms_4']:.3g}, "
                f"{row['seconds_1'] * 1e3:.0f} -> {row['seconds_4'] * 1e3:.0f} ms")
    return rows


def first_calls(rounds, log):
    """Seconds of a first fit in fresh interpreters, per setting, alternating."""
    here = pathlib.Path(__file__).resolve().parent
    env = dict(os.environ, XLA_FLAGS=(os.environ.get("XLA_FLAGS", "")
                                      + " --xla_cpu_use_fusion_emitters=false").strip())
    env.pop("JAXSUBDIV_COMPILATION_CACHE", None)
    out = {"1": [], "4": []}  # (str keys: the JSON's)
    for _ in range(rounds):
        for phases in (1, 4):
            seconds, rms = child_json(FIRST, str(phases), what="first fit", cwd=here, env=env)
            out[str(phases)].append(seconds)
            log(f"first fit, phases={phases}: {seconds:.2f} s (rms {rms:.3g})")
    return out


def markdown(run) -> str:
    out = [
        "# The phase of a closed fit's start (`benchmarks/bench_fit_phases.py`)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {jax.__version__}, float64; "
        f"`fitting` from `{run['fitting']}`. `phases=1`: the linear start at the samples' "
        "chord-length positions alone (the default); `phases=4`: four phases. Both "
        "in this process, alternating.",
        "",
        "## A first fit (compilation included)",
        "",
        f"DejaVu Sans 'S', n = 32, fresh interpreters, no cache, fusion emitters off: "
        f"one phase {median_range(run['first']['1'])} s, four "
        f"{median_range(run['first']['4'])} s (median (min-max) of "
        f"{len(run['first']['1'])}); ratio "
        f"{statistics.median(run['first']['4']) / statistics.median(run['first']['1']):.2f}.",
        "",
        "## Curves made from known polygons (parameters held at the truth)",
        "",
        "Max two-sided distance between the fitted and the true curve / the size. "
        "`floor`: the fit started at the true polygon. Reached: within 10x the floor "
        "(or 1e-6).",
        "",
        "| scheme | cases | reached, one phase | reached, four | median error, one phase "
        "| median, four | worse with four (> 1.1x) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    known = run["known"]
    for name, values in KNOWN:
        rows = [r for r in known if r["scheme"] == name and r["values"] == values]
        if not rows:
            continue

        def reached(r, k):
            return r[f"error_{k}"] <= max(10 * r["floor"], 1e-6)

        label = name + (" " + ", ".join(f"{k} = {v}" for k, v in values.items())
                        if values else "")
        out.append(
            f"| {label} | {len(rows)} | {sum(reached(r, 1) for r in rows)} "
            f"| {sum(reached(r, 4) for r in rows)} "
            f"| {statistics.median(r['error_1'] for r in rows):.1e} "
            f"| {statistics.median(r['error_4'] for r in rows):.1e} "
            f"| {sum(r['error_4'] > 1.1 * r['error_1'] and not reached(r, 4) for r in rows)} |")
    out += ["", "| scheme | seed | floor | one phase | four | status (one, four) |",
            "| --- | ---: | ---: | ---: | ---: | --- |"]
    for r in known:
        label = r["scheme"] + (" " + ", ".join(f"{k} = {v}" for k, v in r["values"].items())
                               if r["values"] else "")
        out.append(f"| {label} | {r['seed']} | {r['floor']:.1e} | {r['error_1']:.1e} "
                   f"| {r['error_4']:.1e} | {r['status_1']}, {r['status_4']} |")
    rows = run["outlines"]
    if rows:
        ratio = [r["rms_4"] / r["rms_1"] for r in rows]
        slower = [r["seconds_4"] / r["seconds_1"] for r in rows]
        converged = {k: sum(r[f"status_{k}"] == "successful" for r in rows) for k in (1, 4)}
        out += [
            "", "## Real outlines (closed cubic B-spline)", "",
            "Two-sided RMS measured independently (`bench_fit_quality.measure`); "
            f"ratio = four phases / one. {len(rows)} fits.", "",
            f"- RMS ratio: median {statistics.median(ratio):.3f}, range "
            f"{min(ratio):.3f}-{max(ratio):.3f}; better by more than 5%: "
            f"{sum(x < 0.95 for x in ratio)}, worse by more than 1%: "
            f"{sum(x > 1.01 for x in ratio)}, by more than 5%: {sum(x > 1.05 for x in ratio)}.",
            f"- Time ratio (warm, median of {REPEATS}): median "
            f"{statistics.median(slower):.2f}, range {min(slower):.2f}-{max(slower):.2f}.",
            f"- Converged: {converged[1]} of {len(rows)} with one phase, {converged[4]} "
            "with four.",
            "", "| outline | n | RMS, one phase | four | ratio | ms, one | four | steps (one, "
            "four's chosen fit) |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
        for r in sorted(rows, key=lambda r: r["rms_4"] / r["rms_1"]):
            out.append(f"| {r['outline']} | {r['n']} | {r['rms_1']:.4g} | {r['rms_4']:.4g} "
                       f"| {r['rms_4'] / r['rms_1']:.3f} | {r['seconds_1'] * 1e3:.0f} "
                       f"| {r['seconds_4'] * 1e3:.0f} | {r['steps_1']}, {r['steps_4']} |")
    return "\n".join(out) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="two outlines, two known curves")
    parser.add_argument("--output", type=pathlib.Path,
                        default=pathlib.Path(__file__).resolve().parent / "results"
                        / "fit_phases.json")
    args = parser.parse_args()
    output = args.output
    if args.smoke and output.name == "fit_phases.json":
        output = output.with_name("fit_phases_smoke.json")
    run = header(fitting=fitting.__file__)
    started = time.perf_counter()
    log = lambda text: print(f"[{time.perf_counter() - started:6.0f} s] {text}", flush=True)
    run["first"] = first_calls(1 if args.smoke else FIRST_ROUNDS, log)
    cases = KNOWN[:2] if args.smoke else KNOWN
    run["known"] = known_curve_rows(cases, 1 if args.smoke else POLYGONS, log)
    shapes = quality.outlines(args.smoke)
    if args.smoke:
        shapes = dict(list(shapes.items())[:2])
    run["outlines"] = outline_rows(shapes, (16,) if args.smoke else (32, 64), log)
    run["load_end"] = load()
    run["wall_seconds"] = round(time.perf_counter() - started, 1)
    write_results(output, run, markdown)


if __name__ == "__main__":
    main()
