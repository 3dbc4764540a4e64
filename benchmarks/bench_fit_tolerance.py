"""Fits to a tolerance (`fitting.fit_tolerance`) on glyphs of several fonts (issue #21).

    python benchmarks/bench_fit_tolerance.py           # full run (~5 min on 2 cores)
    python benchmarks/bench_fit_tolerance.py --smoke   # one glyph, one tolerance

Glyphs with exact outlines (matplotlib's `TextPath`, the outer contour, Bezier segments
evaluated exactly; `bench_fit_corners.glyph_outline`), resampled to 400 points evenly by
arc length, fitted with `fitting.fit_tolerance(samples, CubicBSpline(), tol,
corners="auto")` at tolerances of 1e-2 and 3e-3 em (two-sided max error against the
samples' polyline, the figure the tolerance bounds).

Per search: the count chosen, the counts tried, whether the tolerance was met, the
reported max error, the Hausdorff distance to the exact outline (brute force, dense), the
warm time of the whole search (median of 3, after one call that compiles every count
it tries) and of one `fitting.fit` at the chosen count (their ratio: the search's cost),
and the Hausdorff distance of the default fit (`n = 32`, corners on) for comparison.

Writes `results/fit_tolerance.json` and `.md` (`--output` sets the JSON path).
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))
from _common import arguments, header, load, write_results  # noqa: E402
from bench_fit_corners import errors, glyph_outline, resample  # noqa: E402


GLYPHS = [("DejaVu Serif", "S"), ("DejaVu Serif", "g"), ("DejaVu Serif", "&"),
          ("DejaVu Serif", "Q"), ("STIXGeneral", "S"), ("STIXGeneral", "&"),
          ("STIXGeneral", "a"), ("DejaVu Sans", "g"), ("DejaVu Sans", "O"),
          ("DejaVu Sans Mono", "R")]
TOLERANCES = (1e-2, 3e-3)


def main():
    args, output = arguments(__doc__, "fit_tolerance")
    import jax

    jax.config.update("jax_enable_x64", True)
    import fitting
    import jaxsubdiv as js

    glyphs = GLYPHS[:1] if args.smoke else GLYPHS
    tolerances = TOLERANCES[:1] if args.smoke else TOLERANCES
    scheme = js.CubicBSpline()
    run = header(python=sys.version.split()[0], jax=jax.__version__)
    rows = []
    start = time.perf_counter()
    for family, char in glyphs:
        truth = glyph_outline(family, char)
        samples = resample(truth, 400)
        default = fitting.fit(samples, scheme, 32, corners="auto", on_failure="ignore")
        default_hausdorff = errors(np.asarray(default.curve), truth)[1]
        for tol in tolerances:
            tried = []

            def search():
                tried.clear()
                return fitting.fit_tolerance(
                    samples, scheme, tol, corners="auto", on_failure="ignore",
                    on_trial=lambda n, r: tried.append((n, float(r.max_error))))

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t0 = time.perf_counter()
                result = jax.block_until_ready(search())
                first = time.perf_counter() - t0
                times, single = [], []
                n = result.control_points.shape[0]
                for _ in range(3):
                    t0 = time.perf_counter()
                    result = jax.block_until_ready(search())
                    times.append(time.perf_counter() - t0)
                    t0 = time.perf_counter()
                    jax.block_until_ready(fitting.fit(samples, scheme, n, corners="auto",
                                                      on_failure="ignore"))
                    single.append(time.perf_counter() - t0)
            rms, hausdorff = errors(np.asarray(result.curve), truth)
            row = dict(glyph=f"{family} '{char}'", tolerance=tol, n=n, tried=list(tried),
                       met=float(result.max_error) <= tol, status=result.message,
                       max_error=float(result.max_error), hausdorff_truth=hausdorff,
                       rms_truth=rms, default_hausdorff_truth=default_hausdorff,
                       first_seconds=first, seconds=statistics.median(times),
                       single_fit_seconds=statistics.median(single))
            rows.append(row)
            print({k: row[k] for k in ("glyph", "tolerance", "n", "tried", "met",
                                       "max_error", "seconds", "single_fit_seconds")},
                  flush=True)
    run.update(load_end=load(), wall_seconds=round(time.perf_counter() - start, 1), rows=rows)
    write_results(output, run, markdown)


def markdown(run) -> str:
    lines = [
        "# Fits to a tolerance (issue #21)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}, float64. Wall time "
        f"{run['wall_seconds']} s. `benchmarks/bench_fit_tolerance.py`: 400 samples evenly "
        "spaced by arc length on each glyph's exact outer contour (em units), "
        "`fitting.fit_tolerance(samples, CubicBSpline(), tol, corners='auto')`; the tolerance "
        "bounds the reported two-sided max error (against the samples' polyline); "
        "Hausdorff also against the exact outline. Times: warm medians of 3 (the first "
        "search, which compiles the counts it tries, separately).",
        "",
        "| glyph | tol | n chosen | counts tried (max error) | met | max error | Hausdorff "
        "to truth | n = 32 Hausdorff | search (s) | one fit at n (s) | ratio | first search (s) |",
        "| --- | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in run["rows"]:
        tried = ", ".join(f"{n}: {e:.2g}" for n, e in r["tried"])
        lines.append(
            f"| {r['glyph']} | {r['tolerance']:g} | {r['n']} | {tried} | "
            f"{'yes' if r['met'] else 'no'} | {r['max_error']:.3g} | "
            f"{r['hausdorff_truth']:.3g} | {r['default_hausdorff_truth']:.3g} | "
            f"{r['seconds']:.3f} | {r['single_fit_seconds']:.3f} | "
            f"{r['seconds'] / r['single_fit_seconds']:.2g} | {r['first_seconds']:.1f} |")
    rows = run["rows"]
    met = [r for r in rows if r["met"]]
    ratio = [r["seconds"] / r["single_fit_seconds"] for r in rows]
    fits = [len(r["tried"]) for r in rows]
    lines += [
        "",
        f"Tolerance met in {len(met)} of {len(rows)} searches; fits per search median "
        f"{statistics.median(fits):g} ({min(fits)}-{max(fits)}); warm search time / one fit "
        f"at the chosen count median {statistics.median(ratio):.2g} "
        f"({min(ratio):.2g}-{max(ratio):.2g}).",
    ]
    missed = [r for r in rows if not r["met"]]
    if missed:
        lines.append("Not met: " + "; ".join(
            f"{r['glyph']} at {r['tolerance']:g} (smallest {r['max_error']:.3g})"
            for r in missed) + ".")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
