"""Benchmark `jaxsubdiv.smoothness` parameter sweeps.

    python benchmarks/bench_analysis.py           # 200 values of w, a 40x40 (r, s) grid
    python benchmarks/bench_analysis.py --smoke   # a few values, seconds

Reports medians over repeats (the cache is cleared before each repeat, so every call
is computed) and points per second, against a baseline measured in the same run: the
plain construction of the same schemes and their masks (the unavoidable part of a
sweep). Writes benchmarks/results/analysis.json and analysis.md.
"""

import argparse
import json
import pathlib
import statistics
import time

import jax
import numpy as np

import jaxsubdiv as js
from jaxsubdiv._analysis.smoothness import _smoothness_cached


jax.config.update("jax_enable_x64", True)
RESULTS = pathlib.Path(__file__).parent / "results"


def _time(fn, repeats):
    times = []
    for _ in range(repeats):
        _smoothness_cached.cache_clear()
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--smoke", action="store_true", help="tiny case, a few seconds")
    args = parser.parse_args()
    n_w, n_grid, repeats = (10, 6, 1) if args.smoke else (200, 40, 3)

    ws = np.linspace(-0.24, 0.24, n_w)
    grid = np.linspace(0, 1, n_grid + 2)[1:-1]
    pairs = [(r, s) for r in grid for s in grid if r < s]
    four = [js.FourPoint(w) for w in ws]
    corner = [js.CornerCutting(r, s) for r, s in pairs]
    js.smoothness(js.FourPoint(0.1))  # warm up jnp dispatch

    cases = {
        "four_point_w": (lambda: [js.smoothness(js.FourPoint(w)) for w in ws], len(ws)),
        "corner_cutting_rs": (
            lambda: [js.smoothness(js.CornerCutting(r, s)) for r, s in pairs],
            len(pairs),
        ),
    }
    baselines = {
        "four_point_w": lambda: [np.asarray(js.FourPoint(w).mask()) for w in ws],
        "corner_cutting_rs": lambda: [np.asarray(js.CornerCutting(r, s).mask()) for r, s in pairs],
    }
    del four, corner
    rows = []
    for name, (fn, count) in cases.items():
        seconds = _time(fn, repeats)
        base = _time(baselines[name], repeats)
        rows.append(
            dict(
                case=name,
                values=count,
                median_seconds=seconds,
                values_per_second=count / seconds,
                baseline_seconds=base,
                ratio_to_baseline=seconds / base,
            )
        )
    RESULTS.mkdir(exist_ok=True)
    suffix = "_smoke" if args.smoke else ""
    (RESULTS / f"analysis{suffix}.json").write_text(json.dumps(rows, indent=2))
    lines = [
        "| case | values | median (s) | values/s | baseline: build schemes (s) | ratio |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['values']} | {r['median_seconds']:.3f} | "
            f"{r['values_per_second']:.0f} | {r['baseline_seconds']:.3f} | "
            f"{r['ratio_to_baseline']:.1f} |"
        )
    table = "\n".join(lines)
    (RESULTS / f"analysis{suffix}.md").write_text(
        "# smoothness sweeps\n\nMedian of the repeats, cache cleared each time.\n\n" + table + "\n"
    )
    print(table)


if __name__ == "__main__":
    main()
