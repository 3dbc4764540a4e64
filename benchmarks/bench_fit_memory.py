"""Peak memory of one fit against its sample count, in fresh processes.

    python benchmarks/bench_fit_memory.py                  # -> results/fit_memory.md
    python benchmarks/bench_fit_memory.py --src OLD --label before --output x.json

Each row is a new Python process that imports jax (float64), fits a closed cubic
B-spline with 32 control points to `m` samples of a three-lobed outline (3 solver
steps: memory is set by the arrays, not the iterations) at the default `levels`, and
reports its peak resident memory (`ru_maxrss`) and `fitting.fit_memory`'s estimate.
The peak includes JAX, the compiler and Python (about 0.6 GB): the column "above
400" subtracts the smallest case's peak. Also the wall time of the whole process
(import, compilation and 3 steps). Writes JSON and a Markdown table beside it.
"""

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import textwrap
from pathlib import Path


HERE = Path(__file__).resolve().parent
SIZES = (400, 4000, 16000, 32000)

CHILD = textwrap.dedent(
    """
    import json, resource, sys, time
    import numpy as np, jax
    jax.config.update("jax_enable_x64", True)
    import fitting, jaxsubdiv as js
    m = int(sys.argv[1])
    a = 2 * np.pi * np.arange(m) / m
    r = 1 + 0.25 * np.cos(3 * a)
    X = np.stack([r * np.cos(a), 0.8 * r * np.sin(a)], 1)
    kwargs = dict(max_steps=3, on_failure="ignore")
    try:
        f = fitting.fit(X, js.CubicBSpline(), 32, memory_budget=2**40, **kwargs)
    except TypeError:  # a version without memory_budget
        f = fitting.fit(X, js.CubicBSpline(), 32, **kwargs)
    estimate = None
    if hasattr(fitting, "fit_memory"):
        estimate = fitting.fit_memory(m, 32, f.levels, js.CubicBSpline(), "closed", np.float64)
    print(json.dumps(dict(m=m, levels=f.levels, curve_samples=int(f.curve.shape[0]),
                          peak=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                          estimate=estimate, rms=float(f.rms))))
    """
)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", type=Path, help="another source tree to measure")
    parser.add_argument("--label", default="this tree")
    parser.add_argument("--sizes", default=",".join(map(str, SIZES)))
    parser.add_argument("--output", type=Path, default=HERE / "results" / "fit_memory.json")
    args = parser.parse_args()
    env = dict(os.environ, JAXSUBDIV_COMPILATION_CACHE="off")
    if args.src:
        env["PYTHONPATH"] = str(args.src) + os.pathsep + env.get("PYTHONPATH", "")
    started = datetime.datetime.now().isoformat(timespec="seconds")
    load = os.getloadavg()[0]
    rows = []
    for m in map(int, args.sizes.split(",")):
        start = datetime.datetime.now()
        out = subprocess.run([sys.executable, "-c", CHILD, str(m)], env=env, capture_output=True,
                             text=True, cwd="/tmp")
        seconds = (datetime.datetime.now() - start).total_seconds()
        if out.returncode:
            rows.append(dict(m=m, error=out.stderr.strip().splitlines()[-1][:200], seconds=seconds))
        else:
            rows.append(dict(json.loads(out.stdout.strip().splitlines()[-1]), seconds=seconds))
        print(rows[-1], flush=True)
    info = dict(started=started, label=args.label, src=str(args.src or ""), load_start=load,
                load_end=os.getloadavg()[0], python=platform.python_version(),
                machine=f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(dict(info=info, rows=rows), indent=1))
    base = next((r["peak"] for r in rows if "peak" in r), 0)
    mb = lambda b: f"{b / 1e6:,.0f}" if b is not None else "-"
    lines = [
        f"# Peak memory of a fit against its samples ({args.label})", "",
        f"{started}; {info['machine']}; Python {info['python']}; load {load:.1f} at start, "
        f"{info['load_end']:.1f} at end. Closed cubic B-spline, n = 32, default levels, 3 "
        "steps, float64, one fresh process per row (`benchmarks/bench_fit_memory.py`"
        + (f", source `{args.src}`" if args.src else "") + ").", "",
        "| samples | levels | curve samples | peak MB | above the first row, MB | "
        "fit_memory estimate, MB | process s |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['m']:,} | | | | | | {r['seconds']:.0f} ({r['error']}) |")
        else:
            lines.append(f"| {r['m']:,} | {r['levels']} | {r['curve_samples']:,} | {mb(r['peak'])} | "
                         f"{mb(r['peak'] - base)} | {mb(r['estimate'])} | {r['seconds']:.0f} |")
    args.output.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.output} and {args.output.with_suffix('.md')}")


if __name__ == "__main__":
    main()
