"""Where the creased Hermite model's extra steps go (issue #21): the error against the
true outline of both creased models after a given number of steps.

    python benchmarks/bench_fit_corner_steps.py           # 2 glyphs x 2 models x 5 budgets (~5 min)
    python benchmarks/bench_fit_corner_steps.py --smoke   # one glyph, two budgets

`bench_fit_corner_model.py` found the Hermite model (`fitting._params.CREASED_HERMITE`,
not yet the default) taking 3-5x the steps of the chords at n = 64 (400 samples, 4
levels against 5) on four DejaVu Serif glyphs, the most on 'g' and 'S'. This asks
whether those steps are a crawl that gains nothing or a slow descent that still
improves the curve: the same fits (`corners="auto"`, cubic B-spline, 400 samples evenly
spaced by arc length along the exact Bezier outline) stopped by `max_steps` at 25, 50,
100, 200 and 500 (the default), each fitted limit curve (`jaxsubdiv.limit_curve` at 8
levels with the fit's creases: 16,384 points, whose chords are within about 2e-7 of the
em of the curve) measured against the true outline both ways by brute force
(`bench_fit_corners.errors`: the larger RMS, and the Hausdorff distance), in units of
the em. Writes `benchmarks/results/fit_corner_steps.json` and `.md`.
"""

import sys
import time
import warnings
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))
from _common import arguments, header, load, write_results  # noqa: E402
from bench_fit_corner_model import fit_with  # noqa: E402


GLYPHS = [("DejaVu Serif", "g"), ("DejaVu Serif", "S")]
BUDGETS = (25, 50, 100, 200, 500)


def main():
    args, output = arguments(__doc__, "fit_corner_steps")
    import jax

    jax.config.update("jax_enable_x64", True)
    import bench_fit_corners as corners

    import fitting
    import jaxsubdiv as js

    glyphs = GLYPHS[:1] if args.smoke else GLYPHS
    budgets = BUDGETS[:2] if args.smoke else BUDGETS
    scheme = js.CubicBSpline()
    run = header(python=sys.version.split()[0], jax=jax.__version__)
    start = time.perf_counter()
    rows = []
    for family, char in glyphs:
        truth = corners.glyph_outline(family, char)
        samples = corners.resample(truth, 400)
        for model in ("hermite", "chords"):
            row = dict(shape=f"{family} '{char}'", n=64, model=model, budgets=[])
            for budget in budgets:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    result = fit_with(model, lambda b=budget: fitting.fit(
                        samples, scheme, 64, corners="auto", max_steps=b,
                        on_failure="ignore"))
                dense = np.asarray(js.limit_curve(np.asarray(result.control_points), scheme,
                                                  8, creases=np.asarray(result.creases)))
                rms, hausdorff = corners.errors(dense, truth)
                row["levels"] = int(result.levels)
                row["budgets"].append(dict(
                    max_steps=budget, steps=int(result.num_steps),
                    converged=bool(result.converged), truth_rms=rms,
                    truth_hausdorff=hausdorff, reported_rms=float(result.rms)))
                print(row["shape"], model, row["budgets"][-1], flush=True)
            rows.append(row)
    run.update(load_end=load(), wall_seconds=round(time.perf_counter() - start, 1), rows=rows)
    write_results(output, run, markdown)


def markdown(run) -> str:
    budgets = [b["max_steps"] for b in run["rows"][0]["budgets"]]
    lines = [
        "# Creased fits by step budget: Hermite segments against chords "
        "(`benchmarks/bench_fit_corner_steps.py`)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, {run['load_end']} "
        f"at end (1, 5, 15 min); jax {run['jax']}, float64. Wall time {run['wall_seconds']} s. "
        "Cubic B-spline, n = 64, 400 samples of the exact outline, `corners=\"auto\"`. Each "
        "cell: the fitted limit curve's RMS / Hausdorff distance to the true outline (units "
        "of the em) after at most `max_steps` steps; where the fit converged, the "
        "steps it took.",
        "",
        "| outline | model | levels | " + " | ".join(f"max_steps {b}" for b in budgets) + " |",
        "| --- | --- | ---: | " + " | ".join("---" for _ in budgets) + " |",
    ]
    for r in run["rows"]:
        cells = []
        for b in r["budgets"]:
            taken = f" (converged, {b['steps']} steps)" if b["converged"] else ""
            cells.append(f"{b['truth_rms']:.3g} / {b['truth_hausdorff']:.3g}{taken}")
        lines.append(f"| {r['shape']} | {r['model']} | {r['levels']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
