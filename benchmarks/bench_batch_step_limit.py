"""`fit_batch`'s step limit: its default (500, `fit`'s) against the 200 it had until
2026-12-07, on the same batches in one process.

    python benchmarks/bench_batch_step_limit.py           # about 2 minutes on 2 cores
    python benchmarks/bench_batch_step_limit.py --smoke   # n = 16 only

32 smooth random blobs (three harmonics of random amplitude and phase, 400 samples),
closed cubic B-spline, float64, n = 16, 32 and 48. Each setting is compiled once (the
step limit is traced: one program), then timed three times, alternating the two
settings call by call; the medians are compared. Counted: fits converged, the most
steps any item took, the median two-sided RMS.

Writes `benchmarks/results/batch_step_limit.json` and `.md` (`--output` sets the JSON path).
"""

import pathlib
import statistics
import sys
import time


BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(BENCH), str(BENCH.parent)]
import _common  # noqa: E402


LIMITS = (200, 500)


def markdown(run: dict) -> str:
    lines = [
        "# `fit_batch`'s step limit (`bench_batch_step_limit.py`)", "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}.", "",
        __doc__.split("\n\n", 2)[2].split("\n\nWrites")[0].replace("\n", " "), "",
        "| n | max_steps | converged (of 32) | most steps | median RMS | median time (s) "
        "| time / at 200 |", "| ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in run["rows"]:
        base = next(r for r in run["rows"] if r["n"] == row["n"] and r["max_steps"] == 200)
        lines.append(f"| {row['n']} | {row['max_steps']} | {row['converged']} | "
                     f"{row['most_steps']} | {row['median_rms']:.4g} | {row['seconds']:.3f} | "
                     f"{row['seconds'] / base['seconds']:.2f} |")
    return "\n".join(lines) + "\n"


def main():
    args, output = _common.arguments(__doc__, "batch_step_limit")
    import jax

    jax.config.update("jax_enable_x64", True)
    import numpy as np

    import fitting
    import jaxsubdiv as js

    run = _common.header(jax=jax.__version__)
    targets = np.stack([_common.blob(seed, 400) for seed in range(32)])
    rows = []
    for n in (16,) if args.smoke else (16, 32, 48):
        call = lambda steps: jax.block_until_ready(fitting.fit_batch(
            targets, js.CubicBSpline(), n, max_steps=steps, on_failure="ignore"))
        results = {steps: call(steps) for steps in LIMITS}  # compiles once
        times = {steps: [] for steps in LIMITS}
        for _ in range(1 if args.smoke else 3):
            for steps in LIMITS:
                start = time.perf_counter()
                results[steps] = call(steps)
                times[steps].append(time.perf_counter() - start)
        for steps in LIMITS:
            r = results[steps]
            rows.append(dict(n=n, max_steps=steps, converged=int(np.sum(r.converged)),
                             most_steps=int(np.max(r.num_steps)),
                             median_rms=float(np.median(r.rms)),
                             seconds=statistics.median(times[steps])))
            print(rows[-1], flush=True)
    run["rows"] = rows
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)
    print(markdown(run))


if __name__ == "__main__":
    main()
