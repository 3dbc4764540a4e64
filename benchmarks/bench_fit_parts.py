"""Where a fit's compile time goes: tracing, lowering and XLA's compilation of the whole
fit and of its two programs, each in a fresh process, with the compiled program's size.

    python benchmarks/bench_fit_parts.py            # 3 runs per program (about 2 minutes)
    python benchmarks/bench_fit_parts.py --smoke    # 1 run per program
    python benchmarks/bench_fit_parts.py --before 8e3bd5d   # that revision too, alternating

The fit (a closed cubic B-spline with 32 control points on DejaVu Sans 'S', 400 samples,
padded to 448) as `fitting.fit` runs it: the solve (`fitting._core.solve_one`) and the
measurement of its two-sided errors (`measure_one`), each its own compiled program; and
as one program (`fit_one`, what a caller's `jit` or `grad` traces). Each program is
traced, lowered and compiled explicitly (`jax.jit(...).trace(...).lower().compile()`),
timed with `time.perf_counter`; its size is the number of instructions and of fused
kernels (`fusion` instructions) in XLA's compiled module, for which XLA generates code
one by one (most of the compile time on CPU, profiled with `perf`).

With `--before REV`, that git revision's `fitting` is measured too (first on the
child's path), the versions alternating round by round.

Writes `benchmarks/results/fit_parts.json` and `fit_parts.md` (`--output` sets the JSON
path; the Markdown goes beside it).
"""

import json
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))
import _common  # noqa: E402


PROGRAMS = ("solve_one", "measure_one", "fit_one")

CHILD = r"""
import json, re, sys, time
import jax
jax.config.update("jax_enable_x64", True)
import numpy as np
import jaxsubdiv as js
from fitting import _checks, _core, _params
from fitting._objective import FitData
from jaxsubdiv.io import read_glyph

program = sys.argv[1]
samples = np.asarray(read_glyph("S")[0].points)
scheme = js.CubicBSpline()
target, weights, n, levels, names, profile = _checks.prepare(
    samples, scheme, 32, levels=None, boundary="closed", fit_params=False, weights=None,
    ordered=True, smoothing=0.0, pad_to=0, memory_budget=2**31, profile=None,
    pin_ends=False)
size = _checks.bucket(target.shape[0])
objective = _core.make_objective(
    scheme, n=n, levels=levels, boundary="closed", names=names, size=size,
    hermite=_params.uses_tangents(scheme, names, "closed"), profile=profile, pin_ends=False)
root_smoothing, tol, max_steps = _core.traced_settings(0.0, 1e-7, 500, target.dtype, True)
padded, weights = _checks.pad(target, weights, size)
data = FitData(target=padded, weights=weights, scheme=scheme,
               root_smoothing=root_smoothing, count=np.int32(target.shape[0]))
if program == "measure_one":  # its arguments: a solve's output
    solved = _core.solve_jit(data, None, tol, max_steps, objective=objective)
    function = lambda *a: _core.measure_one(*a, closed=True)
    arguments = _core.measure_arguments(solved)
else:
    function = lambda *a: getattr(_core, program)(*a, objective=objective)
    arguments = (data, None, tol, max_steps)
jitted = jax.jit(function)
start = time.perf_counter(); traced = jitted.trace(*arguments)
trace = time.perf_counter() - start
start = time.perf_counter(); lowered = traced.lower()
lower = time.perf_counter() - start
start = time.perf_counter(); compiled = lowered.compile()
compile_ = time.perf_counter() - start
text = compiled.as_text()
print(json.dumps({"trace": trace, "lower": lower, "compile": compile_,
                  "instructions": len(re.findall(r"^\s*(?:ROOT )?%\S+ = ", text, re.M)),
                  "kernels": len(re.findall(r" fusion\(", text))}))
"""


def markdown(report: dict) -> str:
    versions = report.get("versions", {"after": "this tree"})
    lines = [f"# Where a fit's compile time goes ({report['date']})", "",
             f"Machine: {report['machine']}; load average at the start {report['load_start']},"
             f" at the end {report['load_end']}; {report['repeat']} fresh process(es) per "
             "program" + (" and version, the versions alternating" if len(versions) > 1 else "")
             + ", interleaved. Medians (min-max) in seconds; sizes of XLA's compiled "
             "module. The fit: a closed cubic B-spline, 32 control points, DejaVu Sans 'S' "
             "(400 samples padded to 448, 1024 curve samples). Versions: "
             + ", ".join(f"{k} = `{v}`" for k, v in versions.items()) + ".", "",
             "| version | program | trace | lower | compile | instructions | fused kernels |",
             "|---|---|---:|---:|---:|---:|---:|"]
    fmt = _common.median_range
    for version in versions:
        for program in PROGRAMS:
            runs = [r for r in report["runs"] if r["program"] == program
                    and r.get("version", "after") == version]
            lines.append(f"| {version} | `{program}` | {fmt([r['trace'] for r in runs])} | "
                         f"{fmt([r['lower'] for r in runs])} | "
                         f"{fmt([r['compile'] for r in runs])} | "
                         f"{runs[0]['instructions']} | {runs[0]['kernels']} |")
    lines += ["", "`fitting.fit` runs `solve_one` then `measure_one`; `fit_one` is both in one "
              "program (what `jit` or `grad` of a fit traces).", ""]
    return "\n".join(lines)


def main() -> int:
    import os
    import tempfile

    args, output, repeat, _ = _common.versions_arguments(__doc__, "fit_parts", rounds=(1, 3),
                                                         repeats=(1, 1))
    report = _common.header(repeat=repeat)
    report["runs"] = []
    with tempfile.TemporaryDirectory() as scratch:
        trees = _common.versions(args.before, Path(scratch))
        report["versions"] = {name: commit for name, (_, commit) in trees.items()}
        for index in range(repeat):
            order = list(trees) if index % 2 == 0 else list(reversed(trees))
            for name in order:
                env = dict(os.environ, PYTHONPATH=str(trees[name][0]))
                for program in PROGRAMS:
                    result = _common.child_json(CHILD, program, what=program,
                                                cwd=Path(__file__).parent, env=env)
                    report["runs"].append({"program": program, "run": index, "version": name,
                                           **result})
                    print(f"run {index + 1}/{repeat} {name} {program:12s} compile "
                          f"{result['compile']:.2f} s", flush=True)
    report["load_end"] = _common.load()
    output.write_text(json.dumps(report, indent=1))
    output.with_suffix(".md").write_text(markdown(report))
    print(markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
