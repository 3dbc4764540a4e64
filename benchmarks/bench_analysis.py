"""Benchmark `jaxsubdiv.smoothness` parameter sweeps: time and tightness, before/after.

    python benchmarks/bench_analysis.py                    # this tree only
    python benchmarks/bench_analysis.py --before b9565ff   # and a git revision, one run
    python benchmarks/bench_analysis.py --smoke            # a few values, seconds

Cases (each value analysed once, the cache cleared before each repeat):

- `four_point_w`: 200 values of the four-point tension w on [-0.55, 0.55] (beyond where
  it converges, -1/2 < w < 1/2), built as `MaskScheme`s so that revisions whose
  `FourPoint` refused |w| >= 1/4 analyse the same masks;
- `four_point_near_1_16`: 40 values of w at 1/16 +- 10^-9 .. 10^-2 (log-spaced), where
  the symbol almost gains two factors (1 + z) and the brackets are hardest;
- `split_tweak_t`: 100 values of t on [-10, 8] (converges on -9 < t < 7), as masks;
- `corner_cutting_rs`: a 40 x 40 grid of the triangle 0 < r < s < 1 (780 pairs).

For each: the median total time over the repeats, the slowest single value, and the
Hölder brackets: median and largest width, how many are wider than 0.01 (the target of
issue #20), how many leave the C^k class undecided, and which method gave them. Every
version runs in a fresh interpreter (`--before` extracts the revision with `git archive`
and puts it first on `sys.path`), alternating before/after repeat by repeat, so the
ratios come from one run on the same machine state. Writes
benchmarks/results/analysis.json and analysis.md (`_smoke` suffix with --smoke).
"""

import argparse
import collections
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time

from _common import load, median_range


RESULTS = pathlib.Path(__file__).parent / "results"
ROOT = pathlib.Path(__file__).resolve().parents[1]
TARGET_WIDTH = 0.01


def _schemes(case: str, smoke: bool):
    """`(label, scheme)` pairs of a case (imports the `jaxsubdiv` found first)."""
    import numpy as np

    import jaxsubdiv as js

    if case == "four_point_w":
        return [(f"w={w:.6g}", js.MaskScheme(np.array([-w, 0, 0.5 + w, 1, 0.5 + w, 0, -w]), -3))
                for w in np.linspace(-0.55, 0.55, 12 if smoke else 200)]
    if case == "four_point_near_1_16":
        offsets = np.logspace(-9, -2, 4 if smoke else 20)
        ws = np.sort(np.concatenate([1 / 16 - offsets, 1 / 16 + offsets]))
        return [(f"w=1/16{w - 1 / 16:+.1e}",
                 js.MaskScheme(np.array([-w, 0, 0.5 + w, 1, 0.5 + w, 0, -w]), -3)) for w in ws]
    if case == "split_tweak_t":
        bspline = np.array([0, 1, 4, 6, 4, 1, 0]) / 8
        four = np.array([-1, 0, 9, 16, 9, 0, -1]) / 16
        return [(f"t={t:.6g}", js.MaskScheme((1 - t) * bspline + t * four, -3))
                for t in np.linspace(-10, 8, 8 if smoke else 100)]
    grid = np.linspace(0, 1, (6 if smoke else 40) + 2)[1:-1]
    return [(f"r={r:.4g} s={s:.4g}", js.CornerCutting(r, s))
            for r in grid for s in grid if r < s]


def _worker(case: str, smoke: bool) -> dict:
    """Run one case once in this interpreter; the timings and the brackets."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxsubdiv as js
    from jaxsubdiv._analysis.smoothness import _smoothness_cached

    schemes = _schemes(case, smoke)
    js.smoothness(js.CornerCutting(0.2, 0.65))  # imports (scipy's LP too, if used)
    _smoothness_cached.cache_clear()
    results, slowest = [], (0.0, "")
    start = time.perf_counter()
    for label, scheme in schemes:
        one = time.perf_counter()
        results.append(js.smoothness(scheme))
        seconds = time.perf_counter() - one
        slowest = max(slowest, (seconds, label))
    total = time.perf_counter() - start
    widths = sorted(r.holder_upper - r.holder_lower for r in results
                    if r.holder_lower > -float("inf"))
    return dict(
        values=len(schemes),
        seconds=total,
        slowest_seconds=slowest[0],
        slowest_value=slowest[1],
        median_width=widths[len(widths) // 2],
        max_width=widths[-1],
        wider_than_target=sum(w > TARGET_WIDTH for w in widths),
        undecided=sum(not r.decided for r in results),
        methods=dict(collections.Counter(getattr(r, "method", "") or "branch and bound"
                                         for r in results)),
        source=js.__file__,
    )


def _run_worker(source: pathlib.Path, case: str, smoke: bool) -> dict:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(source), str(pathlib.Path(__file__).parent), os.environ.get("PYTHONPATH", "")])}
    command = [sys.executable, __file__, "--worker", case] + (["--smoke"] if smoke else [])
    out = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _extract(revision: str, into: pathlib.Path) -> pathlib.Path:
    archive = into / "source.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", "-o", str(archive),
                    revision], check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(into / "tree", filter="data")
    return into / "tree"


def _commit(revision: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", revision],
                          capture_output=True, text=True, check=True).stdout.strip()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--smoke", action="store_true", help="a few values, seconds")
    parser.add_argument("--before", help="a git revision to compare with, in the same run")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--output", help="results file stem (default: results/analysis)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(_worker(args.worker, args.smoke)))
        return
    repeats = args.repeats or (1 if args.smoke else 3)
    cases = ["four_point_w", "four_point_near_1_16", "split_tweak_t", "corner_cutting_rs"]
    with tempfile.TemporaryDirectory() as tmp:
        versions = {"after": (ROOT, _commit("HEAD") + "+worktree")}
        if args.before:
            versions = {"before": (_extract(args.before, pathlib.Path(tmp)),
                                   _commit(args.before)), **versions}
        runs = collections.defaultdict(list)
        for case in cases:
            for _ in range(repeats):  # alternate versions repeat by repeat
                for name, (source, _) in versions.items():
                    runs[case, name].append(_run_worker(source, case, args.smoke))
    rows = []
    for case in cases:
        for name, (_, commit) in versions.items():
            done = runs[case, name]
            seconds = [r["seconds"] for r in done]
            rows.append(dict(case=case, version=name, commit=commit, repeats=seconds,
                             median_seconds=statistics.median(seconds),
                             **{k: v for k, v in done[0].items() if k != "seconds"}))
    meta = dict(date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                load=load(), cpus=os.cpu_count(), repeats=repeats)
    stem = pathlib.Path(args.output) if args.output else (
        RESULTS / ("analysis_smoke" if args.smoke else "analysis"))
    stem.parent.mkdir(parents=True, exist_ok=True)
    stem.with_suffix(".json").write_text(json.dumps(dict(meta=meta, rows=rows), indent=2))
    lines = [
        "| case | version | values | time (s), median (min-max) | s/value | slowest value (s) "
        "| bracket width: median | max | > 0.01 | undecided | methods |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for r in rows:
        methods = ", ".join(f"{k} {v}" for k, v in sorted(r["methods"].items()))
        lines.append(
            f"| {r['case']} | {r['version']} ({r['commit']}) | {r['values']} | "
            f"{median_range(r['repeats'])} | {r['median_seconds'] / r['values']:.4f} | "
            f"{r['slowest_seconds']:.3f} ({r['slowest_value']}) | {r['median_width']:.2g} | "
            f"{r['max_width']:.3g} | {r['wider_than_target']} | {r['undecided']} | {methods} |"
        )
    for case in cases if args.before else []:
        before, after = (next(r for r in rows if r["case"] == case and r["version"] == v)
                         for v in ("before", "after"))
        lines.append(f"\n{case}: after/before time ratio "
                     f"{after['median_seconds'] / before['median_seconds']:.2f}")
    table = "\n".join(lines)
    stem.with_suffix(".md").write_text(
        "# smoothness sweeps: time and bracket widths\n\n"
        f"{meta['date']}, {meta['cpus']} CPUs, load average {meta['load']} at the end; "
        f"{repeats} repeats per version, alternating, each in a fresh interpreter, cache "
        "cleared. Produced by `python benchmarks/bench_analysis.py"
        + (f" --before {args.before}" if args.before else "") + "`.\n\n" + table + "\n"
    )
    print(table)


if __name__ == "__main__":
    main()
