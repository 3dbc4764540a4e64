"""Fits with corners: the Hermite curve model (exact one-sided tangents at the creases,
not yet the default) against the chords model creased fits use, in one run (issue #21).

    python benchmarks/bench_fit_corner_model.py           # 11 outlines x 2 counts, 3 traced glyphs (~6 min)
    python benchmarks/bench_fit_corner_model.py --smoke   # the star and one glyph, n = 32

A closed curve creased at its corners is cut there into clamped pieces; for the schemes
whose clamped rule reflects the polygon (here the cubic B-spline) each piece's end has
an exact tangent, so the curve between its limit samples can be modelled by cubic
Hermite segments, with the tangents from after and from before each crease
(`fitting._curve.creased_tables`), at the default levels of $C^1$ curves ("hermite",
`fitting._params.CREASED_HERMITE = True`), instead of the chords at their own default
levels, one level more ("chords", the default). (The run in `results/` was made while
the Hermite model was briefly the default, at 63c18d0, with the chords restored by
replacing `fitting._fit.uses_tangents`: the same two models.)

- **Exact outlines** (`bench_fit_corners.py`'s: a five-point star and glyphs of DejaVu
  Serif, STIXGeneral and DejaVu Sans with their exact Bezier outlines): 400 samples
  evenly spaced by arc length, `corners="auto"`, n = 32 and 64. Errors against the
  true outline, in units of the em (star: its outer radius), of the fitted *limit
  curve* (`jaxsubdiv.limit_curve` at 10 levels with the fit's creases: not
  `result.curve`, whose chords at the fit's own levels would charge the model with
  fewer levels for its display), both ways to the other polyline by brute force:
  Hausdorff and the larger RMS.
- **Traced glyphs** (`bench_fit_step.py`'s cases: the largest contour of a 1024-px
  bitmap as `jaxsubdiv.io.read_image` traces it, 3,800-5,200 samples, corners
  found with `pixel=1`, n from `count_for`): the reported two-sided RMS and maximum
  against the samples (`docs/fitting.md`, "Reported errors").

Times: warm medians of 3 calls per model, the models alternating (first calls, which
compile, excluded). Writes `benchmarks/results/fit_corner_model.json` and `.md`.
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))
from _common import arguments, header, load, write_results  # noqa: E402


TRACED = [("STIXGeneral", "S"), ("DejaVu Serif", "S"), ("analytic", "star")]


def fit_with(model, call):
    """`call()` with the creased curve modelled as `model` says ("hermite" or "chords",
    `fitting._params.CREASED_HERMITE`)."""
    from fitting import _params

    original = _params.CREASED_HERMITE
    _params.CREASED_HERMITE = model == "hermite"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return call()
    finally:
        _params.CREASED_HERMITE = original


def timed_models(call, repeats=3):
    """Each model's result and warm median time, the models alternating."""
    import jax

    results, times = {}, {"hermite": [], "chords": []}
    for model in times:  # the first calls compile
        results[model] = jax.block_until_ready(fit_with(model, call))
    for _ in range(repeats):
        for model in times:
            t0 = time.perf_counter()
            results[model] = jax.block_until_ready(fit_with(model, call))
            times[model].append(time.perf_counter() - t0)
    return {m: (results[m], statistics.median(times[m])) for m in times}


def summary(result, seconds) -> dict:
    return dict(levels=int(result.levels), steps=int(result.num_steps),
                status=result.message, seconds=seconds,
                rms=float(result.rms), max_error=float(result.max_error),
                creases=0 if result.creases is None else int(np.sum(result.creases)))


def main():
    args, output = arguments(__doc__, "fit_corner_model")
    import jax

    jax.config.update("jax_enable_x64", True)
    import bench_fit_corners as corners
    import bench_fit_step as step

    import fitting
    import jaxsubdiv as js

    shapes = corners.SHAPES[:2] if args.smoke else corners.SHAPES
    counts = (32,) if args.smoke else (32, 64)
    traced = [] if args.smoke else TRACED
    scheme = js.CubicBSpline()
    run = header(python=sys.version.split()[0], jax=jax.__version__)
    start = time.perf_counter()
    exact_rows, traced_rows = [], []
    for family, char in shapes:
        truth = corners.star_outline() if char is None else corners.glyph_outline(family, char)
        name = "star" if char is None else f"{family} '{char}'"
        samples = corners.resample(truth, 400)
        for n in counts:
            row = dict(shape=name, n=n)
            for model, (result, seconds) in timed_models(
                    lambda: fitting.fit(samples, scheme, n, corners="auto",
                                        on_failure="ignore")).items():
                creases = None if result.creases is None else np.asarray(result.creases)
                dense = np.asarray(js.limit_curve(np.asarray(result.control_points), scheme,
                                                  10, creases=creases))
                rms, hausdorff = corners.errors(dense, truth)
                row[model] = dict(summary(result, seconds), truth_rms=rms,
                                  truth_hausdorff=hausdorff)
            exact_rows.append(row)
            print(name, n, row, flush=True)
    for family, char in traced:
        points = step.contour(family, char, 1024)
        n = step.count_for(len(points))
        found = fitting.find_corners(points, pixel=1.0)[:n]
        row = dict(shape=f"{family} '{char}', 1024 px", n=n, samples=len(points),
                   corners=len(found))
        for model, (result, seconds) in timed_models(
                lambda: fitting.fit(points, scheme, n, corners=found,
                                    on_failure="ignore")).items():
            row[model] = summary(result, seconds)
        traced_rows.append(row)
        print(row, flush=True)
    run.update(load_end=load(), wall_seconds=round(time.perf_counter() - start, 1),
               exact=exact_rows, traced=traced_rows)
    write_results(output, run, markdown)


def _ratio(row, key):
    return row["hermite"][key] / row["chords"][key] if row["chords"][key] > 0 else float("nan")


def markdown(run) -> str:
    lines = [
        "# Creased fits: Hermite segments against chords (`benchmarks/bench_fit_corner_model.py`)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, {run['load_end']} at "
        f"end (1, 5, 15 min); jax {run['jax']}, float64. Wall time {run['wall_seconds']} s. "
        "Cubic B-spline, `corners` found by `fitting.find_corners`; times are warm medians "
        "of 3, the models alternating.",
        "",
        "## Exact outlines (400 samples; errors against the true outline, units of the em)",
        "",
        "| outline | n | levels H / C | steps H / C | time H / C (s) | ratio | truth RMS H / C | "
        "truth Hausdorff H / C | reported RMS H / C |",
        "| --- | ---: | --- | --- | --- | ---: | --- | --- | --- |",
    ]
    for r in run["exact"]:
        h, c = r["hermite"], r["chords"]
        lines.append(
            f"| {r['shape']} | {r['n']} | {h['levels']} / {c['levels']} | {h['steps']} / "
            f"{c['steps']} | {h['seconds']:.3f} / {c['seconds']:.3f} | "
            f"{_ratio(r, 'seconds'):.2f} | {h['truth_rms']:.3g} / {c['truth_rms']:.3g} | "
            f"{h['truth_hausdorff']:.3g} / {c['truth_hausdorff']:.3g} | "
            f"{h['rms']:.3g} / {c['rms']:.3g} |")
    if run["exact"]:
        rows = run["exact"]
        t = [_ratio(r, "seconds") for r in rows]
        e = [_ratio(r, "truth_rms") for r in rows]
        hd = [_ratio(r, "truth_hausdorff") for r in rows]
        lines += ["", f"Hermite / chords over {len(rows)} fits: time median {np.median(t):.2f} "
                  f"({min(t):.2f}-{max(t):.2f}); truth RMS median {np.median(e):.2f} "
                  f"({min(e):.2f}-{max(e):.2f}); truth Hausdorff median {np.median(hd):.2f} "
                  f"({min(hd):.2f}-{max(hd):.2f}). Statuses: Hermite "
                  f"{sorted({r['hermite']['status'] for r in rows})}, chords "
                  f"{sorted({r['chords']['status'] for r in rows})}."]
    if run["traced"]:
        lines += [
            "", "## Traced glyphs (1024 px; errors reported against the samples, pixels)", "",
            "| contour | samples | n | corners | levels H / C | steps H / C | time H / C (s) | "
            "ratio | RMS H / C | max H / C |",
            "| --- | ---: | ---: | ---: | --- | --- | --- | ---: | --- | --- |",
        ]
        for r in run["traced"]:
            h, c = r["hermite"], r["chords"]
            lines.append(
                f"| {r['shape']} | {r['samples']:,} | {r['n']} | {r['corners']} | "
                f"{h['levels']} / {c['levels']} | {h['steps']} / {c['steps']} | "
                f"{h['seconds']:.2f} / {c['seconds']:.2f} | {_ratio(r, 'seconds'):.2f} | "
                f"{h['rms']:.3g} / {c['rms']:.3g} | {h['max_error']:.3g} / "
                f"{c['max_error']:.3g} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
