"""Fits with one BLAS thread while they run (what `fitting` does, `fitting._threads`)
against the BLAS library's own thread count, alternating in one process.

    python benchmarks/bench_blas_threads.py            # about 4 minutes on 2 cores
    python benchmarks/bench_blas_threads.py --smoke    # the star at 256 px, seconds

JAX's CPU Cholesky factorisations and triangular solves (every solver step's damped
step) call scipy's OpenBLAS, whose threads keep spinning after each call. Each case is
warmed up (compiled) once, then timed `--rounds` times each way, alternating the two
settings call by call, so that both see the same machine load; the ratio is of the
medians. "Own threads" replaces the limit with a no-op (`contextlib.nullcontext`); the
BLAS libraries' thread counts are listed in the results.

Cases: the largest contour of a bitmap, traced as `bench_fit_step.py` traces it and
fitted as it fits it (cubic B-spline, corners found at the pixel size, n = samples / 60
clipped to 12 ... 64), for three shapes at 1024 px and two at 256 px; one fit of the
four-point scheme's w (`fit_params=True`, n = 16) at 256 px; and one `fit_batch` of the
four 256-px contours (DejaVu Serif 'S' and 'g', STIXGeneral 'S', the star; n = 24).

Writes `benchmarks/results/blas_threads.json` and `.md` (`--output` sets the JSON path).
"""

import contextlib
import json
import pathlib
import statistics
import sys
import time


BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(BENCH), str(BENCH.parent)]
import _common  # noqa: E402


IMAGES = [("STIXGeneral", "S", 1024), ("DejaVu Serif", "S", 1024), ("analytic", "star", 1024),
          ("STIXGeneral", "S", 256), ("analytic", "star", 256)]
BATCH = [("DejaVu Serif", "S", 256), ("DejaVu Serif", "g", 256), ("STIXGeneral", "S", 256),
         ("analytic", "star", 256)]


def _name(family: str, char: str, size: int) -> str:
    return f"{char if family == 'analytic' else f'{family} {char!r}'}, {size} px"


def cases(smoke: bool) -> list[tuple[str, object]]:
    """`(name, call)` for every case: `call()` runs one fit and returns its result."""
    from bench_fit_step import contour, count_for

    import fitting
    import jaxsubdiv as js

    def traced(spec):
        points = contour(*spec)
        n = count_for(len(points))
        corners = fitting.find_corners(points, pixel=1.0)[:n]
        return lambda: fitting.fit(points, js.CubicBSpline(), n, corners=corners,
                                   on_failure="ignore")

    if smoke:
        return [(_name("analytic", "star", 256), traced(("analytic", "star", 256)))]
    out = [(_name(*spec), traced(spec)) for spec in IMAGES]
    star = contour("analytic", "star", 256)
    out.append(("star, 256 px, fit_params=True (four-point w, n = 16)",
                lambda: fitting.fit(star, js.FourPoint(), 16, fit_params=True,
                                    on_failure="ignore")))
    outlines = [contour(*spec) for spec in BATCH]
    out.append(("fit_batch of 4 contours at 256 px (n = 24)",
                lambda: fitting.fit_batch(outlines, js.CubicBSpline(), 24,
                                          on_failure="ignore")))
    return out


def measure(call, rounds: int) -> dict:
    """Warm `call` up, then time it `rounds` times each way, alternating."""
    import jax

    from fitting import _batch, _core

    def once(limited: bool) -> float:
        if not limited:
            _core.one_blas_thread = _batch.one_blas_thread = contextlib.nullcontext
        try:
            start = time.perf_counter()
            jax.block_until_ready(call())
            return time.perf_counter() - start
        finally:
            _core.one_blas_thread = _batch.one_blas_thread = limit

    limit = _core.one_blas_thread
    once(True)  # compiles
    one, own = [], []
    for _ in range(rounds):
        one.append(once(True))
        own.append(once(False))
    return dict(one_thread_s=one, own_threads_s=own,
                ratio=statistics.median(one) / statistics.median(own))


def markdown(run: dict) -> str:
    blas = "; ".join(f"{b['filepath'].split('/')[-1]} ({b['internal_api']} {b['version']}, "
                     f"{b['num_threads']} threads)" for b in run["blas"])
    lines = [
        "# Fits with one BLAS thread against the BLAS library's own threads "
        "(`benchmarks/bench_blas_threads.py`)", "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}, float64. BLAS: {blas}. "
        f"One process; each case compiled once, then timed {run['rounds']} times each way, "
        "alternating call by call. Seconds, median (min-max).", "",
        "| case | one BLAS thread (s) | own threads (s) | ratio |",
        "| --- | ---: | ---: | ---: |",
    ]
    for c in run["cases"]:
        lines.append(f"| {c['case']} | {_common.median_range(c['one_thread_s'])} | "
                     f"{_common.median_range(c['own_threads_s'])} | {c['ratio']:.2f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    from fitting import _threads

    args, output = _common.arguments(__doc__, "blas_threads")
    rounds = 2 if args.smoke else 7
    run = _common.header(jax=jax.__version__, rounds=rounds, cases=[])
    start = time.perf_counter()
    for name, call in cases(args.smoke):
        run["cases"].append(dict(case=name, **measure(call, rounds)))
        print(json.dumps(run["cases"][-1]), flush=True)
    run["blas"] = [{k: str(v) for k, v in b.items()} for b in _threads._controller().info()]
    run["wall_s"] = time.perf_counter() - start
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)


if __name__ == "__main__":
    main()
