"""Compile cost of the fit's programs, in fresh processes, for one or more source trees.

    python benchmarks/bench_fit_compile.py                         # the installed tree, 3 runs
    python benchmarks/bench_fit_compile.py --src /tmp/before --src . --repeat 3
    python benchmarks/bench_fit_compile.py --smoke                 # 1 run, fixed program only
    python benchmarks/bench_fit_compile.py --xla-flags= --label default \
        --xla-flags=--xla_cpu_use_fusion_emitters=false --label no-emitters \
        --output benchmarks/results/fit_compile_xla_flags.json

Each run is a new Python process (no persistent compilation cache) that builds one of
the fit's programs and calls it twice: the first call traces, lowers and compiles it,
the second and later are warm. Programs (`PROGRAMS`): `fixed`, a closed cubic B-spline with 32
control points fitted to DejaVu Sans 'S' (400 samples); `params`, the four-point scheme
with 16 control points and `fit_params=True` on the same samples; `grad`, the gradient
of a 16-point cubic B-spline fit's `rms` with respect to the samples; `other`, a fit
with other settings (the four-point scheme, 16 control points, parameters fixed) in a
process that has run `fixed` first (untimed): what a user exploring settings meets,
where programs may share parts (the errors' measurement). Per run: the first
and the warm call's wall time, and JAX's own durations of tracing, lowering to MLIR and
XLA's compilation (`jax.monitoring` events, summed over the programs it compiled), the
median of five warm calls, and the value computed (to see that every variant agrees).

`--xla-flags=FLAGS` (with `=`, as the value starts with dashes) runs the children with
`XLA_FLAGS` set to the given flags instead of inherited (`--xla-flags=`: none), to
compare XLA's compile options (the test suite's, say) on one tree; with several `--src`
trees, one `--xla-flags` applies to all, or give one per tree. Each tree and flag set
is a variant.

With several variants the runs interleave (run 1 of every tree and program, then run
2, ...), so that the machine's drift over the minutes of a run touches all alike;
compare the trees' medians within one run. The children prepend the tree to
`PYTHONPATH`, and report the file they imported `fitting` from.

Writes `benchmarks/results/fit_compile.json` (every run) and `fit_compile.md` (medians);
`--output` sets the JSON path (the Markdown goes beside it).
"""

import argparse
import datetime
import json
import os
import platform
import statistics
import sys
import tempfile
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))
import _common  # noqa: E402


HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
PROGRAMS = ("fixed", "params", "grad", "other")

CHILD = r"""
import json, sys, time
from collections import defaultdict
import jax
durations = defaultdict(float)
jax.monitoring.register_event_duration_secs_listener(
    lambda event, secs, **kwargs: durations.__setitem__(event, durations[event] + secs))
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
import fitting
import jaxsubdiv as js
from jaxsubdiv.io import read_glyph

samples = jnp.asarray(read_glyph("S")[0].points)
program = sys.argv[1]

def call():
    if program == "fixed":
        return fitting.fit(samples, js.CubicBSpline(), 32).rms
    if program == "params":
        return fitting.fit(samples, js.FourPoint(1 / 16), 16, fit_params=True).rms
    if program == "other":
        return fitting.fit(samples, js.FourPoint(1 / 16), 16).rms
    return jax.grad(lambda x: fitting.fit(x, js.CubicBSpline(), 16).rms)(samples)

if program == "other":  # a process that has run the fixed program first
    fitting.fit(samples, js.CubicBSpline(), 32).rms.block_until_ready()
    durations.clear()

start = time.perf_counter(); jax.block_until_ready(call()); first = time.perf_counter() - start
value = call()
warm = []
for _ in range(5):
    start = time.perf_counter(); jax.block_until_ready(call()); warm.append(time.perf_counter() - start)
warm = sorted(warm)[2]
pick = lambda name: sum(v for k, v in durations.items() if k.endswith(name))
print(json.dumps({"first": first, "warm": warm, "trace": pick("jaxpr_trace_duration"),
                  "lower": pick("jaxpr_to_mlir_module_duration"),
                  "compile": pick("backend_compile_duration"), "module": fitting.__file__,
                  "value": float(jax.numpy.ravel(value)[0])}))
"""


def run_child(program: str, src: Path | None, xla_flags: str | None, scratch: Path) -> dict:
    env = dict(os.environ, JAXSUBDIV_COMPILATION_CACHE="off", XDG_CACHE_HOME=str(scratch))
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    if xla_flags is not None:  # (XLA reads a value that is not flags as a file name)
        env.pop("XLA_FLAGS", None)
        if xla_flags.strip():
            env["XLA_FLAGS"] = xla_flags.strip()
    if src is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(src)] + ([env["PYTHONPATH"]]
                                                           if env.get("PYTHONPATH") else []))
    return _common.child_json(CHILD, program, env=env, cwd=scratch,
                              what=f"{program} in {src or 'the installed tree'}")


def markdown(report: dict) -> str:
    lines = [f"# Compile cost of the fit's programs ({report['date']})", "",
             f"Machine: {report['machine']}; load average before {report['load_before']}, "
             f"after {report['load_after']}; {report['repeat']} fresh processes per tree and "
             "program, interleaved. Medians (min-max) in seconds; `first` is the first call "
             "(trace, lower, compile, run), `warm` the median of five later calls, `value` "
             "what the program computed (`rms`, or the gradient's first entry; in the first "
             "of the runs).", ""]
    labels = [tree["label"] for tree in report["trees"]]
    lines += ["| program | tree | first | trace | lower | compile | warm | first / "
              f"{labels[0]} | value |", "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    fmt = _common.median_range
    for program in report["programs"]:
        base = None
        for tree in report["trees"]:
            runs = [r for r in report["runs"] if r["program"] == program
                    and r["tree"] == tree["label"]]
            first = statistics.median(r["first"] for r in runs)
            base = first if base is None else base
            lines.append(f"| {program} | {tree['label']} | {fmt([r['first'] for r in runs])} | "
                         f"{fmt([r['trace'] for r in runs])} | {fmt([r['lower'] for r in runs])} | "
                         f"{fmt([r['compile'] for r in runs])} | "
                         f"{statistics.median(r['warm'] for r in runs):.3f} | "
                         f"{first / base:.2f} | {runs[0]['value']:.10g} |")
    lines += ["", "Trees: " + "; ".join(
        f"`{t['label']}`: {t['module']}"
        + ("" if t.get("xla_flags") is None else f", XLA_FLAGS `{t['xla_flags'] or '(none)'}`")
        for t in report["trees"]), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--src", type=Path, action="append",
                        help="a source tree to measure (repeatable; default: the installed one)")
    parser.add_argument("--xla-flags", action="append",
                        help="XLA_FLAGS for the children (repeatable: one variant each; "
                             "default: inherited)")
    parser.add_argument("--label", action="append",
                        help="a name for each variant (--src or --xla-flags), in order")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--programs", default=",".join(PROGRAMS))
    parser.add_argument("--smoke", action="store_true", help="1 run of the fixed program")
    parser.add_argument("--output", type=Path, default=RESULTS / "fit_compile.json")
    args = parser.parse_args(argv)
    sources = [s.resolve() for s in args.src] if args.src else [None]
    flag_sets = args.xla_flags or [None]
    if len(sources) > 1 and len(flag_sets) > 1 and len(sources) != len(flag_sets):
        parser.error("give one --xla-flags for all --src trees, or one per tree")
    count = max(len(sources), len(flag_sets))
    sources, flag_sets = sources * (count // len(sources)), flag_sets * (count // len(flag_sets))
    labels = args.label or [(s.name if s else "installed")
                            + ("" if f is None else f" {f.strip() or '(no XLA_FLAGS)'}")
                            for s, f in zip(sources, flag_sets)]
    if len(labels) != count:
        parser.error("give one --label per variant (--src or --xla-flags)")
    if len(set(labels)) != count:
        parser.error(f"the variants' labels must differ (got {labels}); give --label")
    programs = ["fixed"] if args.smoke else args.programs.split(",")
    repeat = 1 if args.smoke else args.repeat
    load_before = " ".join(f"{x:.2f}" for x in os.getloadavg())
    runs, modules = [], {}
    with tempfile.TemporaryDirectory() as scratch:
        for index in range(repeat):
            for program in programs:
                for src, flags, label in zip(sources, flag_sets, labels):
                    result = run_child(program, src, flags, Path(scratch))
                    modules[label] = result.pop("module")
                    runs.append({"program": program, "tree": label, "run": index, **result})
                    print(f"run {index + 1}/{repeat} {program:6s} {label:12s} first "
                          f"{result['first']:.2f} s, compile {result['compile']:.2f} s",
                          flush=True)
    report = {
        "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python "
                   f"{platform.python_version()}",
        "load_before": load_before,
        "load_after": " ".join(f"{x:.2f}" for x in os.getloadavg()),
        "repeat": repeat, "programs": programs,
        "trees": [{"label": label, "module": modules[label], "xla_flags": flags}
                  for label, flags in zip(labels, flag_sets)],
        "runs": runs,
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=1))
    args.output.with_suffix(".md").write_text(markdown(report))
    print(markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
