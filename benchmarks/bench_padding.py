"""What a fit pays for the padding to its sample-count bucket (`fitting._fit.bucket`).

    python benchmarks/bench_padding.py            # about a minute on 2 cores
    python benchmarks/bench_padding.py --output /some/dir/padding.json

The outer contours of DejaVu Sans 'a' and 'S' (400 samples, `tests/helpers.py`), closed
cubic B-spline, n = 16 and 32, float64, fitted warm in one process: padded to the bucket
(448, what `fitting.fit` does), to 512, and not at all (the bucket forced to the exact
sample count, which only this benchmark does). Per case: the median of 9 warm fits,
their steps, the median of 9 one-step calls (the fixed cost: initial fit, curve basis,
errors), and the time per step, (fit - one step) / (steps - 1). Padding changes the
fit's path slightly (other stopping points in flat valleys), so compare per-step times.
Writes `benchmarks/results/padding.json` and `padding.md`.
"""

import argparse
import datetime
import json
import os
import statistics
import sys
import time
from pathlib import Path


HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

import jax  # noqa: E402


jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from helpers import glyph_outline  # noqa: E402

import fitting  # noqa: E402
import fitting._fit as fit_module  # noqa: E402
import jaxsubdiv as js  # noqa: E402


REPEAT = 9
SIZES = {"exact (400)": lambda m, smallest=16: m, "bucket (448)": fit_module.bucket,
         "512": lambda m, smallest=16: max(m, 512)}


def timed(call) -> float:
    start = time.perf_counter()
    jax.block_until_ready(call().rms)
    return time.perf_counter() - start


def measure(samples, n: int, size) -> dict:
    fit_module.bucket = size
    fit = lambda **kw: fitting.fit(samples, js.CubicBSpline(), n, on_failure="ignore", **kw)
    steps = int(fit().num_steps)
    fit(max_steps=1)  # compile both (one program: max_steps is data)
    whole = statistics.median(timed(fit) for _ in range(REPEAT))
    one = statistics.median(timed(lambda: fit(max_steps=1)) for _ in range(REPEAT))
    return {"fit_s": whole, "steps": steps, "one_step_s": one,
            "per_step_ms": 1e3 * (whole - one) / max(steps - 1, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--output", default=str(HERE / "results" / "padding.json"))
    args = parser.parse_args()
    original = fit_module.bucket
    rows = []
    try:
        for char in ("a", "S"):
            samples = np.asarray(glyph_outline(char, 400))
            for n in (16, 32):
                for label, size in SIZES.items():
                    rows.append({"shape": char, "n": n, "padding": label,
                                 **measure(samples, n, size)})
                    print(rows[-1])
    finally:
        fit_module.bucket = original
    output = Path(args.output)
    output.parent.mkdir(parents=True, exist_ok=True)
    header = (f"{datetime.datetime.now().isoformat(timespec='seconds')}; {os.cpu_count()} "
              f"CPUs; jax {jax.__version__}; load average {os.getloadavg()[0]:.1f} at the end")
    output.write_text(json.dumps({"header": header, "rows": rows}, indent=1))
    lines = ["# Cost of padding a fit to its sample-count bucket", "", header, "",
             "| shape | n | padded to | warm fit (ms) | steps | one-step call (ms) | ms / step |",
             "| --- | ---: | --- | ---: | ---: | ---: | ---: |"]
    lines += [f"| {r['shape']} | {r['n']} | {r['padding']} | {1e3 * r['fit_s']:.1f} | "
              f"{r['steps']} | {1e3 * r['one_step_s']:.1f} | {r['per_step_ms']:.2f} |"
              for r in rows]
    output.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {output} and {output.with_suffix('.md')}")


if __name__ == "__main__":
    main()
