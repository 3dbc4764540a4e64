"""Benchmark where a batched fit's time goes: the per-item cost of a solver step's parts
against the batch size, and a fit's solve and error measurement (issue #16).

    python benchmarks/bench_fit_batch.py                  # about 5 minutes
    python benchmarks/bench_fit_batch.py --before 68c689d # and a git revision, one run
    python benchmarks/bench_fit_batch.py --smoke          # seconds, for CI
    python benchmarks/bench_fit_batch.py --processes-only # part 3 alone, 2 minutes

Two parts, each on closed cubic B-spline fits at n = 16 of 400-sample outlines (the
glyphs 'S' and 'a' and a superellipse, perturbed as in `bench_fit.py`), float64:

1. **A step's parts, batched.** The default solver's step at the fit of each outline
   is its foot points (a global search; tracked feet cost about a third of it), the
   model (loss, gradient and Hessian, `Objective.quadratic_model`) and the damped
   Cholesky solve. Each part is `vmap`ped over batches of 1, 10, 100, 1,000 and 10,000
   items (the global search up to 1,000: its distance matrices hold 5 GB at 10,000)
   and timed warm: if a step's time were per-operation overhead, the per-item cost
   would fall with the batch size.
2. **A fit's two programs.** `fitting.fit` runs a solve and a measurement of its
   errors (`_core.solve_jit`, `_core.measure_jit`); both are timed warm per outline,
   and `fitting.fit_batch` on 200 outlines against a loop of `fit`. With `--before`
   the revision is extracted (`git archive`) and measured too, each version in fresh
   interpreters, alternating round by round, and both fit 600 outlines at n = 16 and
   32 once, to compare their errors (a change of the search may lead a fit to another
   local minimum: the distribution of the ratios says whether it is better or worse).

3. **Across processes.** `fitting.fit_batch` of the same 200 outlines in one process
   (one thread, two threads) and in two processes joined by `jax.distributed` on this
   machine: each fitting its share (the default), or one program over both
   processes' devices; fits per second and the results' difference from one process.

Results: `results/fit_batch.{json,md}`; part 3 alone (`--processes-only`, with `--before`
that revision's program over both processes' devices too):
`results/fit_batch_processes.{json,md}`.
"""

import json
import pathlib
import statistics
import sys
import tempfile
import time

import numpy as np


sys.path.insert(0, str(pathlib.Path(__file__).parent))
from _common import RESULTS, child_json, header, load  # noqa: E402


ROOT = pathlib.Path(__file__).resolve().parents[1]

#: Part 2, run in a fresh interpreter with a version's tree first on the path.
PROGRAMS = r"""
import json, sys, time, statistics
sys.path.insert(0, sys.argv[1]); sys.path.insert(1, sys.argv[2])
import jax, numpy as np
jax.config.update("jax_enable_x64", True)
import jaxsubdiv as js, fitting
import fitting._core as core
from bench_fit import perturbed_outlines, glyph_outline, superellipse
count, batch = int(sys.argv[3]), int(sys.argv[4])
targets = perturbed_outlines([glyph_outline("S"), glyph_outline("a"), superellipse()], batch)
scheme = js.CubicBSpline()
captured = []
solve, measure = core.solve_jit, core.measure_jit
core.measure_jit = lambda *a, **k: captured.append((a, k)) or measure(*a, **k)
fitting.fit(targets[0], scheme, 16)  # compile
captured.clear()
start = time.perf_counter()
for t in targets[:count]:
    jax.block_until_ready(fitting.fit(t, scheme, 16, on_failure="ignore").rms)
loop = (time.perf_counter() - start) / count
times = []
for a, k in captured:
    start = time.perf_counter(); jax.block_until_ready(measure(*a, **k))
    times.append(time.perf_counter() - start)
jax.block_until_ready(fitting.fit_batch(targets, scheme, 16, on_failure="ignore").rms)
start = time.perf_counter()
result = fitting.fit_batch(targets, scheme, 16, on_failure="ignore")
jax.block_until_ready(result.rms)
batch_time = time.perf_counter() - start
quality = {}
if int(sys.argv[5]):  # the batch's errors at n = 16 and 32, for comparing versions
    more = perturbed_outlines([glyph_outline("S"), glyph_outline("a"), superellipse()],
                              int(sys.argv[5]))
    for n in (16, 32):
        fitted = fitting.fit_batch(more, scheme, n, on_failure="ignore")
        quality[n] = dict(rms=np.asarray(fitted.rms).tolist(),
                          converged=int(np.sum(np.asarray(fitted.converged))),
                          median_steps=float(np.median(np.asarray(fitted.num_steps))))
print(json.dumps(dict(fit_seconds=loop, measure_seconds=statistics.median(times),
                      batch_fits_per_second=batch / batch_time,
                      rms=[float(x) for x in result.rms[:count]], quality=quality)))
"""

#: Part 3, one process of a run: `<tree> <benchmarks> <process> <processes> <port> <batch>
#: <threads> <mode>`; mode "split" (fit_batch's default across processes) or "spmd" (all
#: devices given).
PROCESSES = r"""
import json, sys, time
process, processes, port, batch, threads, mode = sys.argv[3:9]
process, processes, batch, threads = int(process), int(processes), int(batch), int(threads)
sys.path.insert(0, sys.argv[1]); sys.path.insert(1, sys.argv[2])
import jax, numpy as np
jax.config.update("jax_enable_x64", True)
if processes > 1:
    jax.distributed.initialize(coordinator_address=f"localhost:{port}",
                               num_processes=processes, process_id=process,
                               initialization_timeout=300)
    from jax.experimental import multihost_utils
import jaxsubdiv as js, fitting
from bench_fit import perturbed_outlines, glyph_outline, superellipse
targets = perturbed_outlines([glyph_outline("S"), glyph_outline("a"), superellipse()], batch)
devices = jax.devices() if mode == "spmd" else None
call = lambda: fitting.fit_batch(targets, js.CubicBSpline(), 16, threads=threads,
                                 devices=devices, on_failure="ignore")
jax.block_until_ready(call().rms)  # compile
times = []
for _ in range(3):
    if processes > 1:
        multihost_utils.sync_global_devices("start")  # all processes start together
    start = time.perf_counter()
    result = call()
    control, rms = result.control_points, result.rms
    if processes > 1 and not control.is_fully_addressable:  # older versions: not gathered
        control, rms = (multihost_utils.process_allgather(x, tiled=True) for x in (control, rms))
    control, rms = np.asarray(control), np.asarray(rms)  # on this process's host
    times.append(time.perf_counter() - start)
if processes > 1:
    jax.distributed.shutdown()
print(json.dumps(dict(seconds=sorted(times)[1], control=control.tolist(),
                      rms=rms.tolist())))
"""


def step_parts(sizes, global_sizes, repeats):
    """Part 1: median warm seconds per item of each step part at each batch size."""
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)
    from bench_fit import glyph_outline, perturbed_outlines, superellipse

    import jaxsubdiv as js
    from fitting._checks import bucket, default_levels, pad
    from fitting._core import make_objective, set_up
    from fitting._objective import FitData
    from fitting._solver import damped_step

    largest = max(sizes)
    outlines = perturbed_outlines([glyph_outline("S"), glyph_outline("a"), superellipse()],
                                  min(largest, 300))
    scheme, n, size = js.CubicBSpline(), 16, bucket(400)
    objective = make_objective(scheme, n=n, levels=default_levels(n, size, True),
                               boundary="closed", names=(), hermite=True, size=size)
    padded = [pad(np.asarray(t), np.ones(len(t)), size) for t in outlines]
    basis = objective.basis_of(scheme, jnp.float64)
    root = jnp.sqrt(jnp.finfo(jnp.float64).tiny)

    def data(target, weights):
        return FitData(target=target, weights=weights, scheme=scheme, root_smoothing=root,
                       basis=basis, count=jnp.int32(400))

    def problem(target, weights):
        p = set_up(data(target, weights), None, objective)
        return p.start, p.data.target, p.data.weights

    targets = jnp.stack([t for t, _ in padded])
    weights = jnp.stack([w for _, w in padded])
    starts, scaled, scaled_weights = jax.jit(jax.vmap(problem))(targets, weights)
    feet = jax.jit(jax.vmap(lambda y, t, w: objective.feet(y, data(t, w))))(
        starts, scaled, scaled_weights)
    model = jax.vmap(lambda y, t, w, f: objective.quadratic_model(y, data(t, w), f))
    _, gradients, hessians = jax.jit(model)(starts, scaled, scaled_weights, feet)
    parts = {
        "foot points (global search)": (
            lambda y, t, w, f, g, h: objective.feet(y, data(t, w)), global_sizes),
        "model": (lambda y, t, w, f, g, h: objective.quadratic_model(y, data(t, w), f), sizes),
        "damped Cholesky step": (lambda y, t, w, f, g, h: damped_step(h, g, 1e-3), sizes),
        # A program that returns its input: the cost of one call from Python, which every
        # figure above includes once per batch (inside the solver's loop there is none).
        "a call of an empty program": (lambda y, t, w, f, g, h: g, sizes),
    }
    inputs = (starts, scaled, scaled_weights, feet, gradients, hessians)
    rows = []
    for name, (part, batch_sizes) in parts.items():
        for batch in batch_sizes:
            # Items repeat the outlines cyclically; the batch's arrays are built first.
            take = jnp.arange(batch) % scaled.shape[0]
            args = jax.tree.map(lambda x: x[take], inputs)
            if batch == 1:
                call = jax.jit(part)
                args = jax.tree.map(lambda x: x[0], args)
            else:
                call = jax.jit(jax.vmap(part))
            jax.block_until_ready(call(*args))
            times = []
            for _ in range(repeats if batch < 1000 else max(1, repeats // 4)):
                start = time.perf_counter()
                jax.block_until_ready(call(*args))
                times.append(time.perf_counter() - start)
            per_item = statistics.median(times) / batch
            rows.append(dict(part=name, batch=batch, ms_per_item=1e3 * per_item))
            print(f"{name:28s} batch {batch:6d}: {1e3 * per_item:.4f} ms per item", flush=True)
            if batch == 1:
                looped = 1e3 * in_a_loop(part, args, repeats)
                rows.append(dict(part=name, batch="loop", ms_per_item=looped))
                print(f"{name:28s} in a loop:    {looped:.4f} ms per item", flush=True)
    return rows


def in_a_loop(part, args, repeats, count=20):
    """Median seconds of one call of `part` inside a compiled loop of `count` (as the
    solver calls its parts), without a call from Python each. Each iteration's inputs
    depend on the previous outputs (by a 1e-300 multiple of their sum), so that XLA can
    neither hoist any of the part's work out of the loop nor drop it."""
    import jax
    import jax.numpy as jnp

    dtype = jax.tree.leaves(args[0])[0].dtype

    def loop(*args):  # arguments, not constants, so that XLA folds nothing
        def body(_, carry):
            # Every input depends on the loop's carry: nothing is loop-invariant.
            moved = jax.tree.map(
                lambda x: x + (carry * 1e-300).astype(x.dtype)
                if jnp.issubdtype(x.dtype, jnp.inexact) else x, args)  # fmt: skip
            out = part(*moved)
            # Every output is used (XLA would drop the work of an unused one).
            return sum(jnp.sum(x).astype(dtype) for x in jax.tree.leaves(out))

        return jax.lax.fori_loop(0, count, body, jnp.zeros((), dtype))

    call = jax.jit(loop)
    jax.block_until_ready(call(*args))
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(call(*args))
        times.append(time.perf_counter() - start)
    return statistics.median(times) / count


def programs(versions, rounds, count, batch, quality):
    """Part 2 for each version: `{name: [per-round results]}`, alternating; the first
    round also fits `quality` outlines at n = 16 and 32 (their errors, to compare the
    versions' fits)."""
    out = {name: [] for name in versions}
    for round_ in range(rounds):
        order = list(versions) if round_ % 2 == 0 else list(versions)[::-1]
        for name in order:
            tree, _ = versions[name]
            out[name].append(child_json(PROGRAMS, str(tree), str(ROOT / "benchmarks"),
                                        str(count), str(batch),
                                        str(quality if round_ == 0 else 0),
                                        what=f"{name} programs", timeout=3600))
            r = out[name][-1]
            print(f"{name}: fit {1e3 * r['fit_seconds']:.1f} ms, measure "
                  f"{1e3 * r['measure_seconds']:.2f} ms, fit_batch "
                  f"{r['batch_fits_per_second']:.1f} fits/s", flush=True)
    return out


def processes(batch, before=None):
    """Part 3: `fit_batch` of `batch` outlines, warm (the median of 3 calls), in one
    process and across two (`jax.distributed`, a local coordinator), with each
    configuration's largest control-point difference from one process on one thread.
    `before`: `(tree, name)` of another version, whose one program over both processes'
    devices is measured too."""
    import socket
    import subprocess

    configurations = [  # (name, tree, processes, threads per process, mode)
        ("1 process, 1 thread", ROOT, 1, 1, "split"),
        ("1 process, 2 threads (default)", ROOT, 1, 2, "split"),
        ("2 processes, 1 thread each (default split)", ROOT, 2, 1, "split"),
        ("2 processes, one program over both devices (devices=jax.devices())", ROOT, 2, 1,
         "spmd"),
    ]
    if before:
        configurations.append((f"the same, {before[1]}", before[0], 2, 1, "spmd"))
    rows, reference, reference_rms = [], None, None
    for name, tree, count, threads, mode in configurations:
        with socket.socket() as free:
            free.bind(("localhost", 0))
            port = str(free.getsockname()[1])
        runs = [subprocess.Popen(
            [sys.executable, "-c", PROCESSES, str(tree), str(ROOT / "benchmarks"), str(p),
             str(count), port, str(batch), str(threads), mode],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
            env={**__import__("os").environ, "JAX_PLATFORMS": "cpu"},
        ) for p in range(count)]  # fmt: skip
        outs = []
        for run in runs:
            out, err = run.communicate(timeout=3600)
            if run.returncode:
                raise RuntimeError(f"{name} failed:\n{err[-3000:]}")
            outs.append(json.loads(out.strip().splitlines()[-1]))
        seconds = max(o["seconds"] for o in outs)  # the batch is done when all are
        control, rms = np.asarray(outs[0]["control"]), np.asarray(outs[0]["rms"])
        if reference is None:
            reference, reference_rms = control, rms
        # Per item: the largest control-point difference, and the RMS ratio.
        differences = np.max(np.abs(control - reference), axis=(1, 2))
        ratios = rms / reference_rms
        rows.append(dict(configuration=name, seconds=seconds, fits_per_second=batch / seconds,
                         difference=float(differences.max()),
                         items_differing=int(np.sum(differences > 1e-4)),
                         rms_ratio=[float(ratios.min()), float(ratios.max())]))
        print(f"{name}: {batch / seconds:.1f} fits/s, control points differ from one "
              f"process by {differences.max():.1e}", flush=True)
    return rows


def markdown(report) -> str:
    lines = [
        "# Where a batched fit's time goes (issue #16)",
        "",
        f"{report['date']}, {report['machine']}, load {report['load_start']} at the start and "
        f"{report['load_end']} at the end (1, 5, 15 min). Closed cubic B-spline, n = 16, "
        "400-sample outlines (bucket 512), float64; `benchmarks/bench_fit_batch.py`.",
        "",
        "## A step's parts: per-item cost against the batch size (`vmap`, warm, median)",
        "",
        "Each figure is one jitted call's time divided by the batch size, so it includes "
        "one call from Python per batch: the last row, a program that returns its input, "
        "measures that cost. \"1, in a loop\": one item's part called 20 times inside "
        "one compiled loop, as the solver calls it, per call: the cost of a single fit's "
        "step part.",
        "",
        "| part | 1, in a loop | " + " | ".join(f"{b:,}" for b in report["sizes"]) + " |",
        "| --- | ---: | " + " | ".join("---:" for _ in report["sizes"]) + " |",
    ]
    for part in dict.fromkeys(r["part"] for r in report["steps"]):
        cells = {r["batch"]: f"{r['ms_per_item']:.3f}" for r in report["steps"]
                 if r["part"] == part}
        lines.append(f"| {part} (ms per item) | {cells.get('loop', '')} | "
                     + " | ".join(cells.get(b, "") for b in report["sizes"]) + " |")
    lines += ["", "## A fit's two programs and the batch (warm)", "",
              f"`fit`: a loop over {report['loop_count']} outlines, per outline; its error "
              "measurement: the measurement program alone on the same outlines (median); "
              f"`fit_batch`: {report['batch']} outlines, threads by default. "
              f"{len(next(iter(report['programs'].values())))} rounds per version, "
              "medians.", ""]
    names = list(report["programs"])
    lines += ["| version | fit (ms per outline) | of which error measurement (ms) | "
              f"fit_batch of {report['batch']} (fits/s) |", "| --- | ---: | ---: | ---: |"]
    for name in names:
        rs = report["programs"][name]
        med = lambda key, scale=1.0: statistics.median(r[key] * scale for r in rs)
        lines.append(f"| {name} ({report['versions'][name]}) | {med('fit_seconds', 1e3):.1f} | "
                     f"{med('measure_seconds', 1e3):.2f} | {med('batch_fits_per_second'):.1f} |")
    if len(names) == 2 and report["programs"][names[0]][0]["quality"]:
        lines += ["", f"## The same fits? {report['quality']} outlines fitted by `fit_batch` in "
                  "each version", "",
                  "| n | RMS after / before: min | 5% | median | 95% | max | geometric mean "
                  "| > 1% worse | > 1% better | converged (before, after) | median steps "
                  "(before, after) |", "| ---: | " + "---: | " * 10]
        for n in report["programs"][names[0]][0]["quality"]:
            old, new = (report["programs"][v][0]["quality"][n] for v in names)
            q = np.asarray(new["rms"]) / np.asarray(old["rms"])
            lines.append(
                f"| {n} | " + " | ".join(f"{x:.3f}" for x in np.quantile(q, [0, .05, .5, .95, 1]))
                + f" | {np.exp(np.mean(np.log(q))):.4f} | {int(np.sum(q > 1.01))} | "
                f"{int(np.sum(q < 0.99))} | {old['converged']}, {new['converged']} | "
                f"{old['median_steps']:g}, {new['median_steps']:g} |")
    if len(names) == 2:
        before, after = (report["programs"][n] for n in names)
        ratio = lambda key: statistics.median(a[key] / b[key] for a, b in zip(after, before))
        lines += ["", f"After / before, median of the rounds' ratios: fit "
                  f"{ratio('fit_seconds'):.2f}, measurement {ratio('measure_seconds'):.2f}, "
                  f"fit_batch throughput {ratio('batch_fits_per_second'):.2f}. Largest "
                  "relative difference of the first outlines' RMS between the versions: "
                  f"{report['rms_difference']:.1e}."]
    if report.get("processes"):
        lines += processes_table(report)
    return "\n".join(lines) + "\n"


def processes_table(report) -> list[str]:
    first = report["processes"][0]["fits_per_second"]
    lines = ["", f"## Across processes: `fit_batch` of {report['batch']} outlines (warm, "
             "median of 3)", "",
             "Against 1 process, 1 thread, per item: the largest control-point difference, "
             "the items whose control points differ by more than 1e-4 (a fit that rounds "
             "differently may stop in another local minimum), and the range of the RMS "
             "ratios.", "",
             "| configuration | fits/s | / 1 process, 1 thread | control points: largest "
             "difference | items > 1e-4 | RMS ratio (min, max) |",
             "| --- | ---: | ---: | ---: | ---: | --- |"]
    for r in report["processes"]:
        low, high = r["rms_ratio"]
        lines.append(f"| {r['configuration']} | {r['fits_per_second']:.1f} | "
                     f"{r['fits_per_second'] / first:.2f} | {r['difference']:.1e} | "
                     f"{r['items_differing']} | {low:.4f}, {high:.4f} |")
    return lines


def processes_markdown(report) -> str:
    lines = ["# `fit_batch` across processes (issue #16)", "",
             f"{report['date']}, {report['machine']}, load {report['load_start']} at the start "
             f"and {report['load_end']} at the end (1, 5, 15 min). Closed cubic B-spline, "
             "n = 16, 400-sample outlines, float64; two processes joined by "
             "`jax.distributed` on this machine (a local coordinator); "
             "`benchmarks/bench_fit_batch.py --processes-only`."]
    return "\n".join(lines + processes_table(report)) + "\n"


def main():
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--smoke", action="store_true", help="a small run, for CI")
    parser.add_argument("--before", help="a git revision to measure too, in the same run")
    parser.add_argument("--output", type=pathlib.Path, default=None, help="JSON path")
    parser.add_argument("--processes-only", action="store_true",
                        help="part 3 alone, to results/fit_batch_processes.{json,md}")
    args = parser.parse_args()
    name = "fit_batch_smoke" if args.smoke else "fit_batch"
    if args.processes_only:
        name += "_processes"
    output = args.output or RESULTS / f"{name}.json"
    output.parent.mkdir(parents=True, exist_ok=True)
    from bench_analysis import _commit, _extract

    report = header()
    if args.smoke:
        sizes, global_sizes, repeats, rounds, count, batch = (1, 10), (1, 10), 2, 1, 2, 4
        quality = 4
    else:
        sizes = (1, 10, 100, 1000, 10000)
        global_sizes, repeats, rounds, count, batch = (1, 10, 100, 1000), 8, 3, 20, 200
        quality = 600
    report["sizes"], report["batch"], report["loop_count"] = list(sizes), batch, count
    report["quality"] = quality
    if args.processes_only:
        with tempfile.TemporaryDirectory() as tmp:
            before = args.before and (_extract(args.before, pathlib.Path(tmp)),
                                      f"before ({_commit(args.before)})")
            report["processes"] = processes(batch, before or None)
        report["load_end"] = load()
        output.write_text(json.dumps(report, indent=2))
        output.with_suffix(".md").write_text(processes_markdown(report))
        print(output.with_suffix(".md").read_text())
        return
    report["steps"] = step_parts(sizes, global_sizes, repeats)
    with tempfile.TemporaryDirectory() as tmp:
        versions = {"after": (ROOT, _commit("HEAD") + "+worktree")}
        if args.before:
            versions = {"before": (_extract(args.before, pathlib.Path(tmp)),
                                   _commit(args.before)), **versions}
        report["versions"] = {k: v[1] for k, v in versions.items()}
        report["programs"] = programs(versions, rounds, count, batch, quality)
    report["processes"] = processes(batch)
    if args.before:
        rms = [np.asarray(r["rms"]) for r in (report["programs"]["before"][0],
                                                report["programs"]["after"][0])]
        report["rms_difference"] = float(np.max(np.abs(rms[1] / rms[0] - 1)))
    report["load_end"] = load()
    output.write_text(json.dumps(report, indent=2))
    output.with_suffix(".md").write_text(markdown(report))
    print(output.with_suffix(".md").read_text())


if __name__ == "__main__":
    main()
