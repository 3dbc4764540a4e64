"""Clamped strokes: the Hermite curve model (exact tangents at clamped ends) against the
chords model clamped fits used before, and against open fits, in one run (issue #14).

    python benchmarks/bench_fit_clamped.py           # 30 strokes x 3 schemes (~4 min)
    python benchmarks/bench_fit_clamped.py --smoke   # 2 strokes, one scheme

The strokes of `bench_fit_ends.py` (the first 40% by arc length of the outer contour of
'8', 'g', '&', 'Q', 'S', 'a' in five fonts shipped with matplotlib, 200 samples),
fitted with 16 control points by the cubic B-spline, `SplitTweak(0.4)` and `Jarek`:

- **clamped, Hermite**: `fitting.fit(..., boundary="clamped")` as it is now: the curve
  between samples modelled by cubic Hermite segments with the exact limit tangents,
  which clamped ends now have for these schemes
  (`jaxsubdiv.supports_clamped_derivatives`);
- **clamped, chords**: the same fit with the chords model, as clamped fits were before
  (`fitting._fit.uses_tangents` replaced by one that says False for clamped ends, which
  is all the change did in `fitting`; its default `levels` are the chords' own);
- **open**: `boundary="open"` (Hermite), for reference.

Per fit: the two-sided RMS and maximum error measured independently of the fit, on the
clamped (or open) limit curve at 10 levels (`jaxsubdiv.limit_curve`, 2^10 points per
span) against the samples' polyline, plain numpy (the curve-to-samples half averaged by
arc length along the dense curve, trapezoidal rule); the reported RMS; steps, status and
warm time (median of 3). Writes `benchmarks/results/fit_clamped.json` and `.md`.
"""

import pathlib
import statistics
import sys
import time


sys.path.insert(0, str(pathlib.Path(__file__).parent))
import _common  # noqa: E402
import bench_fit_ends as ends  # noqa: E402
import bench_fit_quality as quality  # noqa: E402  (also: x64 on, one OpenBLAS thread)
import jax  # noqa: E402
import numpy as np  # noqa: E402

import fitting  # noqa: E402
import jaxsubdiv as js  # noqa: E402
from fitting import _fit  # noqa: E402


SCHEMES = (("CubicBSpline", js.CubicBSpline()), ("SplitTweak(0.4)", js.SplitTweak(0.4)),
           ("Jarek", js.Jarek()))
MODELS = ("clamped, Hermite", "clamped, chords", "open")
DENSE_LEVELS = 10


def to_segments(points, polyline):
    """Distance from each point to the polyline (plain numpy, in blocks)."""
    a, b = polyline[:-1], polyline[1:]
    d = b - a
    length2 = np.maximum(np.sum(d * d, 1), 1e-300)
    out = np.empty(len(points))
    for i in range(0, len(points), 256):
        p = points[i:i + 256, None, :]
        u = np.clip(np.sum((p - a) * d, -1) / length2, 0.0, 1.0)
        out[i:i + 256] = np.sqrt(np.min(np.sum((a + u[..., None] * d - p) ** 2, -1), 1))
    return out


def independent_errors(result, samples, boundary):
    """(two-sided RMS, max) of the fitted curve, from its dense limit curve."""
    curve = np.asarray(js.limit_curve(result.control_points, result.scheme, DENSE_LEVELS,
                                      boundary=boundary))
    to_curve = to_segments(samples, curve)
    to_samples = to_segments(curve, samples)
    length = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    mean_square = np.sum(length * (to_samples[:-1] ** 2 + to_samples[1:] ** 2) / 2)
    rms_curve = np.sqrt(mean_square / np.sum(length))
    rms = max(float(np.sqrt(np.mean(to_curve**2))), float(rms_curve))
    return rms, float(max(to_curve.max(), to_samples.max()))


def fit(samples, scheme, model):
    boundary = "open" if model == "open" else "clamped"
    original = _fit.uses_tangents
    if model == "clamped, chords":
        _fit.uses_tangents = lambda s, names, b: b != "clamped" and original(s, names, b)
    try:
        call = lambda: fitting.fit(samples, scheme, ends.N, boundary=boundary,  # noqa: E731
                                   on_failure="ignore")
        result = jax.block_until_ready(call())
        times = []
        for _ in range(3):
            start = time.perf_counter()
            jax.block_until_ready(call())
            times.append(time.perf_counter() - start)
    finally:
        _fit.uses_tangents = original
    return result, statistics.median(times), boundary


def run(strokes, schemes, log):
    rows = []
    for name, samples in strokes.items():
        size = float(np.ptp(samples, axis=0).max())
        for scheme_name, scheme in schemes:
            for model in MODELS:
                result, seconds, boundary = fit(samples, scheme, model)
                rms, largest = independent_errors(result, samples, boundary)
                rows.append(dict(
                    stroke=name, scheme=scheme_name, model=model, levels=int(result.levels),
                    rms=rms / size, max_error=largest / size,
                    reported_rms=float(result.rms) / size,
                    status=fitting.STATUSES[int(result.status)],
                    steps=int(result.num_steps), seconds=seconds))
        log(f"{name} done")
    return rows


def summarise(rows):
    out = []
    for scheme_name in dict.fromkeys(r["scheme"] for r in rows):
        by = {m: [r for r in rows if r["scheme"] == scheme_name and r["model"] == m]
              for m in MODELS}
        hermite, chords, opened = by["clamped, Hermite"], by["clamped, chords"], by["open"]

        def ratio(a, b, key):
            return np.array([x[key] / y[key] for x, y in zip(a, b)])

        rms_chords = ratio(hermite, chords, "rms")
        rms_open = ratio(hermite, opened, "rms")
        out.append(dict(
            scheme=scheme_name, strokes=len(hermite),
            levels=[hermite[0]["levels"], chords[0]["levels"], opened[0]["levels"]],
            rms_vs_chords=[float(np.min(rms_chords)), float(np.median(rms_chords)),
                           float(np.max(rms_chords))],
            max_vs_chords=float(np.median(ratio(hermite, chords, "max_error"))),
            time_vs_chords=float(np.median(ratio(hermite, chords, "seconds"))),
            steps=[int(np.median([r["steps"] for r in g])) for g in (hermite, chords)],
            worse_than_open=[int(np.sum(ratio(g, opened, "rms") > 1)) for g in (hermite, chords)],
            rms_vs_open=float(np.median(rms_open)),
            reported_ratio=[float(x) for x in np.percentile(
                [r["reported_rms"] / r["rms"] for r in hermite], [0, 50, 100])],
            not_converged=[sum(r["status"] != "successful" for r in g)
                           for g in (hermite, chords, opened)],
        ))
    return out


def markdown(data):
    h = data["header"]
    lines = [
        "# Clamped strokes: Hermite against chords (`benchmarks/bench_fit_clamped.py`)", "",
        f"{h['date']}; {h['machine']}; load {h['load_start']} at start, {h['load_end']} at "
        f"end (1, 5, 15 min); jax {h['jax']}; git {h['git']}. Wall time "
        f"{h['wall_seconds']:.0f} s.", "",
        f"{len(data['strokes'])} strokes (`bench_fit_ends.py`'s), n = {ends.N}. Errors "
        f"over the stroke's size, measured on the limit curve at {DENSE_LEVELS} levels "
        "against the samples' polyline, two-sided (plain numpy). Ratios are Hermite over "
        "chords per stroke (min, median, max); `worse than open`: strokes whose clamped "
        "RMS is above the open fit's, for the Hermite and the chords model; `reported / "
        "measured`: the fit's reported RMS over the independent one (Hermite).", "",
        "| scheme | levels (Hermite, chords, open) | RMS Hermite / chords | max error "
        "(median) | time (median) | steps (median) | worse than open | RMS Hermite / open "
        "(median) | reported / measured | not converged (Hermite, chords, open) |",
        "| --- | --- | --- | ---: | ---: | --- | --- | ---: | --- | --- |",
    ]
    for s in data["summary"]:
        lo, mid, hi = s["rms_vs_chords"]
        rlo, rmid, rhi = s["reported_ratio"]
        lines.append(
            f"| {s['scheme']} | {', '.join(map(str, s['levels']))} | {lo:.3f}, {mid:.3f}, "
            f"{hi:.3f} | {s['max_vs_chords']:.3f} | {s['time_vs_chords']:.2f} | "
            f"{s['steps'][0]}, {s['steps'][1]} | {s['worse_than_open'][0]}, "
            f"{s['worse_than_open'][1]} of {s['strokes']} | {s['rms_vs_open']:.3f} | "
            f"{rlo:.3f}, {rmid:.3f}, {rhi:.3f} | "
            f"{', '.join(map(str, s['not_converged']))} |")
    return "\n".join(lines) + "\n"


def main():
    args, output = _common.arguments(__doc__, "fit_clamped")
    begin = time.perf_counter()
    log = lambda text: print(f"[{time.perf_counter() - begin:6.0f} s] {text}",  # noqa: E731
                             file=sys.stderr, flush=True)
    header = _common.header(jax=jax.__version__, git=quality.git_revision(fitting.__file__))
    strokes = ends.glyph_strokes(args.smoke)
    rows = run(strokes, SCHEMES[:1] if args.smoke else SCHEMES, log)
    header["load_end"] = _common.load()
    header["wall_seconds"] = time.perf_counter() - begin
    data = {"header": header, "strokes": list(strokes), "rows": rows,
            "summary": summarise(rows)}
    _common.write_results(output, data, markdown)


if __name__ == "__main__":
    main()
