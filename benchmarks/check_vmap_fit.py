"""Does a jitted `jax.vmap` of `fit` run? A check, not a timing: fresh interpreters
each compile and call it once, with a time limit, for this tree and `--before REV`.

    python benchmarks/check_vmap_fit.py --before d501424   # about 5 minutes on 2 cores

The program: `jax.jit(jax.vmap(lambda t: fitting.fit(t, CubicBSpline(), 48).rms))`
over 8 smooth random blobs of 400 samples, float64. At d501424 the solver factored a
Newton decrement inside its loop (a `lax.cond`, a select under `vmap`), and this call
hung in XLA on its first call; the decrement is now computed after the loop
(`fitting._solver.settled`). An interpreter that has not printed its result after
`--limit` seconds (default 120; the call takes about 25 s with its compilation) counts
as hung and is killed.

Writes `benchmarks/results/vmap_fit.json` and `.md` (`--output` sets the JSON path).
"""

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time


BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(BENCH), str(BENCH.parent)]
import _common  # noqa: E402


CODE = f"import sys\nsys.path.insert(0, {str(BENCH)!r})\n" + r'''
import numpy as np
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
import jaxsubdiv as js, fitting
from _common import blob

targets = jnp.asarray(np.stack([blob(seed, 400) for seed in range(8)]))
call = jax.jit(jax.vmap(lambda t: fitting.fit(t, js.CubicBSpline(), 48).rms))
print(float(jnp.max(jax.block_until_ready(call(targets)))))
'''


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", help="a git revision to check too")
    parser.add_argument("--runs", type=int, default=3, help="interpreters per version")
    parser.add_argument("--limit", type=float, default=120.0, help="seconds before 'hung'")
    parser.add_argument("--output", type=pathlib.Path, default=_common.RESULTS / "vmap_fit.json")
    args = parser.parse_args()
    run = _common.header(runs=args.runs, limit=args.limit)
    outcomes = {}
    with tempfile.TemporaryDirectory() as scratch:
        trees = _common.versions(args.before, pathlib.Path(scratch))
        for _ in range(args.runs):
            for name, (tree, commit) in trees.items():
                env = dict(os.environ, PYTHONPATH=str(tree))
                start = time.perf_counter()
                try:
                    done = subprocess.run([sys.executable, "-c", CODE], env=env, cwd=scratch,
                                          capture_output=True, text=True, timeout=args.limit)
                    outcome = "ran" if done.returncode == 0 else "failed"
                except subprocess.TimeoutExpired:
                    outcome = "hung"
                seconds = round(time.perf_counter() - start, 1)
                outcomes.setdefault(f"{name} ({commit})", []).append([outcome, seconds])
                print(name, outcome, seconds, flush=True)
    run["outcomes"] = outcomes
    run["load_end"] = _common.load()

    def markdown(run):
        lines = ["# A jitted `jax.vmap` of `fit` (`check_vmap_fit.py`)", "",
                 f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
                 f"{run['load_end']} at end (1, 5, 15 min); limit {run['limit']} s.", "",
                 "| version | ran | hung | failed | seconds per interpreter |",
                 "| --- | ---: | ---: | ---: | --- |"]
        for name, rows in run["outcomes"].items():
            count = lambda kind: sum(r[0] == kind for r in rows)
            lines.append(f"| {name} | {count('ran')} | {count('hung')} | {count('failed')} | "
                         + ", ".join(f"{r[1]:g}" for r in rows) + " |")
        return "\n".join(lines) + "\n"

    _common.write_results(args.output, run, markdown)
    print(markdown(run))


if __name__ == "__main__":
    main()
