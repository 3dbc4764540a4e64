"""What the check of a given start costs: `fit(init=...)` before and after it.

    python benchmarks/bench_init_check.py --before f7545ee   # about 4 minutes on 2 cores
    python benchmarks/bench_init_check.py --smoke            # this tree, one case

Since 2026-12-07 a fit from a given `init` also evaluates the loss at the start it takes
without `init` and measures that start's errors (`_core.poor_start`,
`_core.flag_poor_start`): work a warm start pays on every call. Each case is a warm
start at the optimum (the default fit's control points: the cheapest fit there is, so
the check's largest share), closed cubic B-spline, float64: DejaVu Sans 'S' and 'a'
(300 samples by arc length) at n = 16 and 32, and 'a' at 2,000 samples, n = 32. Each
version runs in fresh interpreters (`--rounds`, alternating, in turn first), which
compile once and then time the warm call (median of 15); the table gives the medians
over rounds and the after/before ratio from the same run.

Writes `benchmarks/results/init_check.json` and `.md` (`--output` sets the JSON path).
"""

import json
import pathlib
import statistics
import sys
import time


BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(BENCH), str(BENCH.parent)]
import _common  # noqa: E402


CASES = [("S", 300, 16), ("S", 300, 32), ("a", 300, 16), ("a", 300, 32), ("a", 2000, 32)]
# The version's tree goes first on the path after this folder's modules put the work tree
# there (they insert it on import); `child` checks where `fitting` came from.
CHILD = ("import sys; sys.path[:0] = [sys.argv[2]]; import bench_init_check as b; "
         "import bench_bad_starts; sys.path.insert(0, sys.argv[1]); b.child(sys.argv[3])")


def child(spec_json: str) -> None:
    """Time the cases of `spec` with the tree's `fitting` first on the path; print one
    JSON line."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import numpy as np
    from bench_bad_starts import glyph

    import fitting
    import jaxsubdiv as js

    spec = json.loads(spec_json)
    out = {"fitting": str(pathlib.Path(fitting.__file__).parent), "cases": []}
    for char, m, n in spec["cases"]:
        samples = glyph(char, m)
        warm = np.asarray(fitting.fit(samples, js.CubicBSpline(), n).control_points)
        call = lambda: fitting.fit(samples, js.CubicBSpline(), n, init=warm)
        result = jax.block_until_ready(call())  # compiles
        times = []
        for _ in range(spec["repeats"]):
            start = time.perf_counter()
            jax.block_until_ready(call())
            times.append(time.perf_counter() - start)
        out["cases"].append(dict(case=f"{char!r} m={m} n={n}", ms=1e3 * statistics.median(times),
                                 steps=int(result.num_steps),
                                 status=fitting.STATUSES[int(result.status)]))
    print(json.dumps(out))


def markdown(run: dict) -> str:
    names = list(run["versions"])
    lines = ["# The check of a given start: what a warm `fit(init=...)` pays "
             "(`bench_init_check.py`)", "",
             f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
             f"{run['load_end']} at end (1, 5, 15 min); versions: "
             + ", ".join(f"{k} = `{v}`" for k, v in run["versions"].items())
             + f"; {run['rounds']} rounds.", "",
             __doc__.split("\n\n", 2)[2].split("\n\nWrites")[0].replace("\n", " "), "",
             "| case | " + " | ".join(f"{k} ms (steps, status)" for k in names)
             + (" | after / before |" if len(names) == 2 else " |"),
             "|---|" + "---:|" * len(names) + ("---:|" if len(names) == 2 else "")]
    for row in run["cases"]:
        cells = [row["case"]] + [f"{row[k]['ms']:.1f} ({row[k]['steps']}, {row[k]['status']})"
                                 for k in names]
        if len(names) == 2:
            cells.append(f"{row['after']['ms'] / row['before']['ms']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    args, output, rounds, _ = _common.versions_arguments(
        __doc__, "init_check", rounds=(1, 3), repeats=(1, 1), smoke_help="one case (CI)")
    run = _common.header(rounds=rounds)
    spec = dict(cases=CASES[:1] if args.smoke else CASES, repeats=15)
    describe = lambda result: ", ".join(f"{c['case']} {c['ms']:.1f} ms"
                                        for c in result["cases"])
    run["versions"], measured = _common.run_versions(
        None if args.smoke else args.before, rounds, CHILD, lambda name, r: spec,
        describe=describe)
    run["cases"] = _common.median_cases(measured, "ms")
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)
    print(markdown(run))


if __name__ == "__main__":
    main()
