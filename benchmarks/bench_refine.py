"""Benchmark `jaxsubdiv.refine` on closed curves against numpy and pure-Python baselines.

Every case is measured in one run, and every figure reported is a median:

- `python`: the pure-Python Chaikin loop `chaikin_python` from `tests/helpers.py`;
- `numpy_roll`: numpy, one level at a time, each level a sum of `np.roll`-shifted copies
  weighted by the scheme's mask;
- `numpy_matmul`: numpy applying the dense composite subdivision matrix (N x n), built
  independently by refining the identity with `numpy_roll`. Batches use the batched
  `np.matmul(S, P)`; the same product as one GEMM with the batch folded into the
  columns is recorded as `numpy_gemm`;
- `jaxsubdiv`: the public `jaxsubdiv.refine` (jitted once per shape; the first call is
  reported separately as compile time); `jaxsubdiv_direct`: a `jax.jit` of the internal
  function that `refine` calls, so the difference is the public wrapper's Python cost;
- `copy`: `np.copy` of an array with the output's size and dtype, the memory ceiling
  (`copy_into`, a copy into a preallocated array, is recorded too).

Usage: `python benchmarks/bench_refine.py [--smoke] [--output PATH]`. Results go to
`PATH` (JSON, default `benchmarks/results/refine.json`) and to a Markdown table next to
it with the same stem. `--smoke` runs tiny cases in a few seconds (CI runs it).
"""

import argparse
import datetime
import json
import math
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import jax


jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxsubdiv as js  # noqa: E402
from jaxsubdiv._refine import _refine_static  # noqa: E402


sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from helpers import chaikin_python  # noqa: E402


HERE = Path(__file__).resolve().parent
DEFAULT_OUTPUT = HERE / "results" / "refine.json"

#: The composite matrix is not built when it would exceed this many bytes.
MATRIX_LIMIT = 2**30
#: The pure-Python loop is not run when one call is predicted to take longer (seconds).
PYTHON_LIMIT = 10.0

SCHEMES = {
    "chaikin": js.Chaikin(),
    "cubic_bspline": js.CubicBSpline(),
    "four_point": js.FourPoint(1 / 16),
}


# --------------------------------------------------------------------------------------
# Baselines.


def numpy_roll(points: np.ndarray, mask: np.ndarray, start: int, levels: int) -> np.ndarray:
    """Closed refinement, one level at a time: $Q_{2i+p} = \\sum a_k P_{i-(k-p)/2}$ over
    the mask indices $k$ of parity $p$."""
    for _ in range(levels):
        n, d = points.shape[-2:]
        out = np.empty(points.shape[:-2] + (2 * n, d), points.dtype)
        for parity in (0, 1):
            acc = None
            for k, a in enumerate(mask, start):
                if (k - parity) % 2:
                    continue
                term = a * np.roll(points, (k - parity) // 2, axis=-2)
                if acc is None:
                    acc = term
                else:
                    acc += term
            out[..., parity::2, :] = acc
        points = out
    return points


def composite_matrix(n: int, mask: np.ndarray, start: int, levels: int) -> np.ndarray:
    """The dense N x n matrix of `levels` closed levels, by refining the identity."""
    return numpy_roll(np.eye(n)[:, :, None], mask, start, levels)[..., 0].T.copy()


def numpy_gemm(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """`matrix @ points` for a batch (B, n, d) as one (N, n) @ (n, B d) GEMM."""
    batch, n, d = points.shape
    folded = points.transpose(1, 0, 2).reshape(n, batch * d)
    out = (matrix @ folded).reshape(-1, batch, d)
    return np.ascontiguousarray(out.transpose(1, 0, 2))


def python_batch(points: np.ndarray, levels: int) -> list:
    if points.ndim == 2:
        return chaikin_python(points, levels, closed=True)
    return [chaikin_python(p, levels, closed=True) for p in points]


# --------------------------------------------------------------------------------------
# Timing.


def measure(fn, budget: float, min_repeats: int = 5, max_repeats: int = 25) -> dict:
    """Median seconds per call of one slow `fn()` (used for the pure-Python loop).

    Calls slower than 0.5 s are sampled 3 times; faster ones as in `measure_all`.
    """
    start = time.perf_counter()
    fn()
    first = time.perf_counter() - start
    if first > 0.5:
        samples = [first]
        for _ in range(2):
            start = time.perf_counter()
            fn()
            samples.append(time.perf_counter() - start)
        return {"median_s": statistics.median(samples), "calls": 1, "samples": 3}
    return measure_all({"fn": fn}, budget, min_repeats, max_repeats)["fn"]


def measure_all(fns: dict, budget: float, min_repeats: int = 5, max_repeats: int = 25) -> dict:
    """Median seconds per call of each `fns[name]()`, sampled in interleaved rounds.

    Each sample runs a function enough times to take about 5 ms, so sub-millisecond
    calls are not dominated by timer resolution. Every round takes one sample of every
    function, so a slow spell of a shared machine hits all methods alike; rounds are
    repeated within `budget` seconds (at least `min_repeats`, at most `max_repeats`).
    """
    numbers, round_time = {}, 0.0
    for name, fn in fns.items():
        start = time.perf_counter()
        fn()
        first = max(time.perf_counter() - start, 1e-9)
        numbers[name] = max(1, math.ceil(0.005 / first))
        round_time += first * numbers[name]
    repeats = int(min(max_repeats, max(min_repeats, budget / round_time)))
    samples = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            number = numbers[name]
            start = time.perf_counter()
            for _ in range(number):
                fn()
            samples[name].append((time.perf_counter() - start) / number)
    return {
        name: {
            "median_s": statistics.median(samples[name]),
            "calls": numbers[name],
            "samples": repeats,
        }
        for name in fns
    }


def check(name: str, got, want) -> None:
    got, want = np.asarray(got), np.asarray(want)
    if got.shape != want.shape or not np.allclose(got, want, rtol=1e-9, atol=1e-9):
        raise AssertionError(f"{name} disagrees with jaxsubdiv.refine")


# --------------------------------------------------------------------------------------
# One case.


def run_case(
    name: str,
    shape: tuple[int, ...],
    levels: int,
    scheme_name: str,
    methods: set[str],
    budget: float,
    python_cost: dict,
) -> dict:
    scheme = SCHEMES[scheme_name]
    mask = np.asarray(scheme.mask(), dtype=np.float64)
    start = scheme.mask_start
    rng = np.random.default_rng(0)
    points_np = rng.standard_normal(shape)
    points = jnp.asarray(points_np)
    n, d = shape[-2:]
    batch = math.prod(shape[:-2])
    count = js.refined_count(n, scheme, levels)
    result = {
        "case": name,
        "scheme": scheme_name,
        "shape": list(shape),
        "levels": levels,
        "output_points": count * batch,
        "output_bytes": count * batch * d * 8,
        "methods": {},
    }
    timings = result["methods"]

    # jaxsubdiv: the first call (compile + one run) is timed on its own.
    start_time = time.perf_counter()
    reference = js.refine(points, scheme, levels).block_until_ready()
    first_call = time.perf_counter() - start_time
    reference = np.asarray(reference)
    direct = jax.jit(_refine_static, static_argnums=(2, 3, 4))
    start_time = time.perf_counter()
    check("jaxsubdiv_direct", direct(points, scheme, levels, "closed", ()), reference)
    direct_first_call = time.perf_counter() - start_time

    source = np.array(reference)
    target = np.empty_like(source)
    fns = {
        "jaxsubdiv": lambda: js.refine(points, scheme, levels).block_until_ready(),
        "jaxsubdiv_direct": lambda: direct(
            points, scheme, levels, "closed", ()
        ).block_until_ready(),
        "copy": lambda: np.copy(source),
        "copy_into": lambda: np.copyto(target, source),
    }
    if "numpy_roll" in methods:
        check("numpy_roll", numpy_roll(points_np, mask, start, levels), reference)
        fns["numpy_roll"] = lambda: numpy_roll(points_np, mask, start, levels)
    skipped = {}
    if "numpy_matmul" in methods:
        matrix_bytes = count * n * 8
        if matrix_bytes > MATRIX_LIMIT:
            skipped["numpy_matmul"] = {
                "skipped": f"composite matrix {count:,} x {n:,} = "
                f"{matrix_bytes / 2**30:.1f} GiB > {MATRIX_LIMIT / 2**30:.0f} GiB"
            }
        else:
            matrix = composite_matrix(n, mask, start, levels)
            check("numpy_matmul", np.matmul(matrix, points_np), reference)
            fns["numpy_matmul"] = lambda: np.matmul(matrix, points_np)
            if batch > 1:
                check("numpy_gemm", numpy_gemm(matrix, points_np), reference)
                fns["numpy_gemm"] = lambda: numpy_gemm(matrix, points_np)

    timings.update(measure_all(fns, budget * len(fns)))
    timings.update(skipped)
    timings["jaxsubdiv"]["first_call_s"] = first_call
    timings["jaxsubdiv"]["compile_s"] = first_call - timings["jaxsubdiv"]["median_s"]
    timings["jaxsubdiv_direct"]["compile_s"] = (
        direct_first_call - timings["jaxsubdiv_direct"]["median_s"]
    )
    if "numpy_matmul" in timings and "skipped" not in timings["numpy_matmul"]:
        timings["numpy_matmul"]["matrix_shape"] = [count, n]
    fns.clear()  # frees the composite matrix

    if "python" in methods:
        timings["python"] = time_python(points_np, levels, reference, python_cost)

    result["ratios"] = ratios(timings)
    return result


def time_python(points_np, levels, reference, python_cost: dict) -> dict:
    """Time the pure-Python loop, or estimate it from its cost per point-level.

    The loop's work is the number of points it creates, summed over the levels. When a
    call is predicted to exceed `PYTHON_LIMIT` seconds, the loop is timed on a smaller
    problem (fewer polygons, else fewer levels) and scaled linearly by the work.
    """
    n = points_np.shape[-2]
    batch = math.prod(points_np.shape[:-2])
    work = batch * n * (2 ** (levels + 1) - 2)
    per_unit = python_cost.get("per_unit")
    if per_unit is None or per_unit * work <= python_cost["limit"]:
        check("python", python_batch(points_np, levels), reference)
        timing = measure(lambda: python_batch(points_np, levels), budget=1.0, max_repeats=5)
        python_cost["per_unit"] = timing["median_s"] / work
        timing["estimate"] = False
        return timing
    # Shrink the problem until it is predicted to fit the limit, then scale up.
    small, small_levels = points_np, levels
    while per_unit * math.prod(small.shape[:-2]) * n * (2 ** (small_levels + 1) - 2) > (
        python_cost["limit"] / 4
    ):
        if small.ndim > 2 and small.shape[0] > 1:
            small = small[: max(1, small.shape[0] // 4)]
        elif small_levels > 2:
            small_levels -= 2
        else:
            break
    small_batch = math.prod(small.shape[:-2])
    small_work = small_batch * n * (2 ** (small_levels + 1) - 2)
    timing = measure(lambda: python_batch(small, small_levels), budget=1.0, max_repeats=5)
    if small_levels == levels:
        check("python", python_batch(small, levels), reference[: small.shape[0]])
    scale = work / small_work
    return {
        "median_s": timing["median_s"] * scale,
        "estimate": True,
        "note": f"estimate: timed on {small_batch:,} polygon(s) at {small_levels} levels "
        f"({timing['median_s']:.3g} s) and scaled by the work ratio {scale:.4g}",
    }


def ratios(timings: dict) -> dict:
    def median(method):
        entry = timings.get(method, {})
        return entry.get("median_s")

    jax_time = median("jaxsubdiv")
    copy_time = median("copy")
    out = {"fraction_of_ceiling": {}, "jaxsubdiv_speedup": {}}
    for method, entry in timings.items():
        if entry.get("median_s") is None or method.startswith("copy"):
            continue
        out["fraction_of_ceiling"][method] = copy_time / entry["median_s"]
        if method != "jaxsubdiv":
            out["jaxsubdiv_speedup"][method] = entry["median_s"] / jax_time
    out["wrapper_overhead_s"] = jax_time - median("jaxsubdiv_direct")
    return out


# --------------------------------------------------------------------------------------
# Plan, targets and report.


def plan(smoke: bool) -> list[tuple]:
    """(name, shape, levels, scheme, methods) for every case."""
    everything = {"python", "numpy_roll", "numpy_matmul"}
    if smoke:
        return [
            ("n=16, k=4", (16, 2), 4, "chaikin", everything),
            ("n=1000, k=2", (1000, 2), 2, "chaikin", everything),
            ("batch 100x16, k=3", (100, 16, 2), 3, "chaikin", everything),
            ("batch 100x16, k=3", (100, 16, 2), 3, "four_point", {"numpy_roll"}),
        ]
    cases = [(f"n=16, k={k}", (16, 2), k, "chaikin", everything) for k in (4, 8, 12, 16)]
    cases += [(f"n=1000, k={k}", (1000, 2), k, "chaikin", everything) for k in range(1, 11)]
    cases += [("batch 10000x16, k=5", (10000, 16, 2), 5, "chaikin", everything)]
    for scheme in ("cubic_bspline", "four_point"):
        cases += [
            ("n=1000, k=10", (1000, 2), 10, scheme, {"numpy_roll"}),
            ("batch 10000x16, k=5", (10000, 16, 2), 5, scheme, {"numpy_roll", "numpy_matmul"}),
        ]
    return cases


def targets(results: list[dict]) -> list[dict]:
    """The issue's performance targets, checked against this run's medians."""
    chaikin = [r for r in results if r["scheme"] == "chaikin"]
    out = []
    for method in ("jaxsubdiv", "jaxsubdiv_direct"):
        speedups = [
            (
                r["case"] + (" (est.)" if r["methods"]["python"]["estimate"] else ""),
                r["methods"]["python"]["median_s"] / r["methods"][method]["median_s"],
            )
            for r in chaikin
            if "python" in r["methods"]
        ]
        if not speedups:
            continue
        met = [c for c, s in speedups if s >= 1000]
        worst = min(speedups, key=lambda cs: cs[1])
        best = max(speedups, key=lambda cs: cs[1])
        out.append(
            {
                "target": ">= 1000x the pure-Python loop (Chaikin)"
                + (", public `refine`" if method == "jaxsubdiv" else ", direct jit"),
                "met": len(met) == len(speedups),
                "detail": f"met in {len(met)} of {len(speedups)} cases; lowest "
                f"{worst[1]:,.1f}x ({worst[0]}), highest {best[1]:,.0f}x ({best[0]})",
            }
        )
    large = [r for r in results if r["output_points"] >= 10**6]
    if large:
        fractions = [
            (f"{r['case']} {r['scheme']}", r["ratios"]["fraction_of_ceiling"]["jaxsubdiv"])
            for r in large
        ]
        met = [c for c, f in fractions if f >= 0.5]
        out.append(
            {
                "target": ">= 0.5 of the copy ceiling at >= 1M output points",
                "met": len(met) == len(fractions),
                "detail": f"met in {len(met)} of {len(fractions)} cases; "
                + ", ".join(f"{c}: {f:.2f}" for c, f in fractions),
            }
        )
    batches = [
        r
        for r in results
        if len(r["shape"]) == 3 and "numpy_matmul" in r["ratios"]["jaxsubdiv_speedup"]
    ]
    if batches:
        speed = [(r["scheme"], r["ratios"]["jaxsubdiv_speedup"]["numpy_matmul"]) for r in batches]
        out.append(
            {
                "target": "batch: faster than numpy's batched matmul with the composite matrix",
                "met": all(s > 1 for _, s in speed),
                "detail": ", ".join(f"{c}: {s:.2f}x" for c, s in speed),
            }
        )
    return out


def fmt_time(entry: dict | None) -> str:
    if not entry:
        return ""
    if "skipped" in entry:
        return "skipped"
    seconds = entry["median_s"]
    if seconds < 1e-3:
        text = f"{seconds * 1e6:.3g} us"
    elif seconds < 1:
        text = f"{seconds * 1e3:.3g} ms"
    else:
        text = f"{seconds:.3g} s"
    return f"~{text} (est.)" if entry.get("estimate") else text


def fmt_ratio(value: float | None, suffix: str = "x") -> str:
    if value is None:
        return ""
    return f"{value:,.0f}{suffix}" if value >= 100 else f"{value:.3g}{suffix}"


def markdown(report: dict) -> str:
    meta = report["meta"]
    lines = [
        "# `jaxsubdiv.refine` benchmark (closed curves, float64, d = 2)",
        "",
        f"{meta['date']}; {meta['machine']}; jax {meta['jax']}, numpy {meta['numpy']}; "
        f"transparent huge pages `{meta['transparent_hugepage']}`; "
        f"GLIBC_TUNABLES `{meta['GLIBC_TUNABLES'] or '(unset)'}`; load average at end "
        f"{meta['load_average_at_end'][0]:.1f}"
        + ("; **smoke run**" if meta["smoke"] else "")
        + ".",
        "Medians of repeated calls. `fraction of ceiling` = copy time / method time "
        "(1.0 = as fast as `np.copy` of the output). Speedups are baseline time / "
        "jaxsubdiv time.",
        "",
        "## Medians",
        "",
        "| scheme | case | output points | copy | python | numpy roll | numpy matmul "
        "| jaxsubdiv | direct jit | wrapper overhead | compile |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in report["results"]:
        t = r["methods"]
        lines.append(
            f"| {r['scheme']} | {r['case']} | {r['output_points']:,} | {fmt_time(t['copy'])} "
            f"| {fmt_time(t.get('python'))} | {fmt_time(t.get('numpy_roll'))} "
            f"| {fmt_time(t.get('numpy_matmul'))} | {fmt_time(t['jaxsubdiv'])} "
            f"| {fmt_time(t['jaxsubdiv_direct'])} "
            f"| {r['ratios']['wrapper_overhead_s'] * 1e6:.0f} us "
            f"| {t['jaxsubdiv']['compile_s']:.2f} s |"
        )
    lines += [
        "",
        "## Ratios",
        "",
        "| scheme | case | vs python | vs numpy roll | vs numpy matmul "
        "| ceiling: jaxsubdiv | direct jit | numpy roll | numpy matmul |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in report["results"]:
        s, f = r["ratios"]["jaxsubdiv_speedup"], r["ratios"]["fraction_of_ceiling"]
        estimate = r["methods"].get("python", {}).get("estimate")
        lines.append(
            f"| {r['scheme']} | {r['case']} "
            f"| {fmt_ratio(s.get('python'))}{' (est.)' if estimate else ''} "
            f"| {fmt_ratio(s.get('numpy_roll'))} | {fmt_ratio(s.get('numpy_matmul'))} "
            f"| {fmt_ratio(f['jaxsubdiv'], '')} | {fmt_ratio(f['jaxsubdiv_direct'], '')} "
            f"| {fmt_ratio(f.get('numpy_roll'), '')} "
            f"| {fmt_ratio(f.get('numpy_matmul'), '')} |"
        )
    notes = []
    for r in report["results"]:
        for method, entry in r["methods"].items():
            if "skipped" in entry:
                notes.append(f"- {r['scheme']} {r['case']}, {method}: {entry['skipped']}.")
            elif "note" in entry:
                notes.append(f"- {r['scheme']} {r['case']}, {method}: {entry['note']}.")
            if method == "numpy_gemm":
                notes.append(
                    f"- {r['scheme']} {r['case']}: the same product as one folded GEMM "
                    f"took {fmt_time(entry)} "
                    f"({r['ratios']['fraction_of_ceiling']['numpy_gemm']:.2f} of ceiling)."
                )
    if notes:
        lines += ["", "## Notes", "", *notes]
    lines += ["", "## Targets", ""]
    for t in report["targets"]:
        lines.append(f"- {'met' if t['met'] else 'NOT met'}: {t['target']} ({t['detail']}).")
    return "\n".join(lines) + "\n"


def _cpu_model() -> str:
    for line in _read("/proc/cpuinfo").splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.machine()


def _read(path: str) -> str:
    try:
        return Path(path).read_text().strip()
    except OSError:
        return "unknown"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--smoke", action="store_true", help="tiny cases, a few seconds")
    parser.add_argument(
        "--output", type=Path, default=DEFAULT_OUTPUT, help="JSON path (.md goes beside it)"
    )
    args = parser.parse_args(argv)

    budget = 0.05 if args.smoke else 1.0
    python_cost = {"limit": 0.5 if args.smoke else PYTHON_LIMIT}
    jnp.zeros(1).block_until_ready()  # backend start-up is not anyone's compile time

    results = []
    for name, shape, levels, scheme, methods in plan(args.smoke):
        began = time.perf_counter()
        results.append(run_case(name, shape, levels, scheme, methods, budget, python_cost))
        print(f"{scheme:14s} {name:22s} {time.perf_counter() - began:6.1f} s", flush=True)

    report = {
        "meta": {
            "date": datetime.datetime.now().isoformat(timespec="seconds"),
            "machine": f"{_cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
            "python": platform.python_version(),
            "jax": jax.__version__,
            "numpy": np.__version__,
            "jaxsubdiv": js.__version__,
            "dtype": "float64",
            "smoke": args.smoke,
            "transparent_hugepage": _read("/sys/kernel/mm/transparent_hugepage/enabled"),
            "GLIBC_TUNABLES": os.environ.get("GLIBC_TUNABLES", ""),
            "load_average_at_end": list(os.getloadavg()),
            "matrix_limit_bytes": MATRIX_LIMIT,
            "python_limit_s": python_cost["limit"],
        },
        "results": results,
        "targets": targets(results),
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=2) + "\n")
    args.output.with_suffix(".md").write_text(markdown(report))
    print(f"wrote {args.output} and {args.output.with_suffix('.md')}")


if __name__ == "__main__":
    main()
