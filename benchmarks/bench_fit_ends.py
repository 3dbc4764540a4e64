"""Open strokes with and without pinned ends (`fitting.fit(pin_ends=...)`, issue #14).

    python benchmarks/bench_fit_ends.py           # 30 strokes x 3 models x 2 (~3 min)
    python benchmarks/bench_fit_ends.py --smoke   # 2 strokes, one model

Strokes nobody here drew: the first 40% (by arc length) of the outer contour of '8', 'g',
'&', 'Q', 'S', 'a' in five fonts shipped with matplotlib (`bench_fit_quality.glyph`),
resampled to 200 points, fitted as open curves with 16 control points: the cubic
B-spline (Hermite curve model) and Chaikin (chords) with `boundary="open"`, and the
four-point scheme with `boundary="clamped"`, each with `pin_ends` False and True.

Per fit: the gap between the curve's ends and the first and last samples (the larger,
over the size: the larger side of the bounding box), measured on the limit points of
`jaxsubdiv.refine`'s polygon at the fit's `levels`, not on the fit's own curve; the
reported two-sided RMS;
the status; the warm time (median of 3). Writes `benchmarks/results/fit_ends.json`
and `.md` (`--output` sets the JSON path).
"""

import json
import pathlib
import statistics
import sys
import time


sys.path.insert(0, str(pathlib.Path(__file__).parent))
import _common  # noqa: E402
import bench_fit_quality as quality  # noqa: E402  (also: x64 on, one OpenBLAS thread)
import jax  # noqa: E402
import numpy as np  # noqa: E402

import fitting  # noqa: E402
import jaxsubdiv as js  # noqa: E402


MODELS = (("CubicBSpline", "open"), ("Chaikin", "open"), ("FourPoint", "clamped"))
SAMPLES, N, SHARE = 200, 16, 0.4


def stroke(outline):
    """The first `SHARE` of a closed outline by arc length, resampled to `SAMPLES`."""
    closed = np.concatenate([outline, outline[:1]])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    at = np.linspace(0.0, SHARE * arc[-1], SAMPLES)
    return np.stack([np.interp(at, arc, closed[:, k]) for k in range(2)], 1)


def glyph_strokes(smoke: bool) -> dict:
    """The strokes by name: every font and glyph of `bench_fit_quality`, or two for a
    smoke run."""
    fonts, chars = ((quality.FONTS[:1], quality.CHARS[:2]) if smoke
                    else (quality.FONTS, quality.CHARS))
    return {f"{family} '{char}'": stroke(quality.glyph(family, char))
            for family in fonts for char in chars}


def end_gap(result, samples, boundary):
    # At the fit's own levels: an open Chaikin curve's first kept point moves towards
    # the limit curve's end as levels grow (weights 0.47/0.53 at 4 levels, 0.5/0.5 in
    # the limit), so the curve the fit returns is the one at `result.levels`.
    polygon = js.refine(result.control_points, result.scheme, result.levels,
                        boundary=boundary)
    curve = np.asarray(js.limit_points(polygon, result.scheme, boundary=boundary))
    size = np.ptp(samples, axis=0).max()
    return float(np.max(np.linalg.norm(curve[[0, -1]] - samples[[0, -1]], axis=1)) / size)


def run(strokes, models, repeats, log):
    rows = []
    for name, samples in strokes.items():
        for scheme_name, boundary in models:
            scheme = getattr(js, scheme_name)()
            for pin in (False, True):
                fit = lambda: fitting.fit(samples, scheme, N, boundary=boundary,  # noqa: E731
                                          pin_ends=pin, on_failure="ignore")
                result = jax.block_until_ready(fit())
                times = []
                for _ in range(repeats):
                    start = time.perf_counter()
                    jax.block_until_ready(fit())
                    times.append(time.perf_counter() - start)
                rows.append(dict(
                    stroke=name, scheme=scheme_name, boundary=boundary, pin_ends=pin,
                    end_gap=end_gap(result, samples, boundary),
                    rms=float(result.rms) / np.ptp(samples, axis=0).max(),
                    status=fitting.STATUSES[int(result.status)],
                    steps=int(result.num_steps), seconds=statistics.median(times),
                ))
        log(f"{name} done")
    return rows


def summarise(rows):
    out = []
    for scheme_name, boundary in {(r["scheme"], r["boundary"]) for r in rows}:
        free = [r for r in rows if r["scheme"] == scheme_name and not r["pin_ends"]]
        pinned = [r for r in rows if r["scheme"] == scheme_name and r["pin_ends"]]
        rms = np.array([p["rms"] / f["rms"] for f, p in zip(free, pinned)])
        time_ratio = np.array([p["seconds"] / f["seconds"] for f, p in zip(free, pinned)])
        out.append(dict(
            scheme=scheme_name, boundary=boundary, strokes=len(free),
            gap_free_median=float(np.median([r["end_gap"] for r in free])),
            gap_free_max=float(np.max([r["end_gap"] for r in free])),
            gap_pinned_max=float(np.max([r["end_gap"] for r in pinned])),
            rms_ratio_median=float(np.median(rms)), rms_ratio_max=float(rms.max()),
            rms_ratio_min=float(rms.min()),
            time_ratio_median=float(np.median(time_ratio)),
            not_converged=[sum(r["status"] != "successful" for r in group)
                           for group in (free, pinned)],
        ))
    return sorted(out, key=lambda s: s["scheme"])


def markdown(data):
    h = data["header"]
    lines = [
        "# Open strokes with pinned ends (`fit(pin_ends=True)`)", "",
        f"{h['date']}; {h['machine']}; load {h['load_start']} at start, {h['load_end']} at "
        f"end (1, 5, 15 min); jax {h['jax']}; git {h['git']}. Wall time "
        f"{h['wall_seconds']:.0f} s.", "",
        f"{len(data['strokes'])} strokes: the first {SHARE:.0%} by arc length of the outer "
        f"contour of glyphs in five fonts shipped with matplotlib, {SAMPLES} samples each; "
        f"n = {N}. `end gap`: the larger distance from the curve's ends (limit points of "
        "`jaxsubdiv.refine`'s polygon) to the first and last samples, over the size (the "
        "larger bounding-box side). `RMS pinned / free`: the reported two-sided RMS "
        f"with the ends pinned over without. `time`: warm medians of {h['repeats']}, "
        "pinned over free.",
        "",
        "| scheme | boundary | end gap free: median | max | end gap pinned: max | "
        "RMS pinned / free: median | min | max | time pinned / free | not converged "
        "(free, pinned) |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for s in data["summary"]:
        lines.append(
            f"| {s['scheme']} | {s['boundary']} | {s['gap_free_median']:.2e} | "
            f"{s['gap_free_max']:.2e} | {s['gap_pinned_max']:.1e} | "
            f"{s['rms_ratio_median']:.3f} | {s['rms_ratio_min']:.3f} | "
            f"{s['rms_ratio_max']:.3f} | {s['time_ratio_median']:.2f} | "
            f"{s['not_converged'][0]}, {s['not_converged'][1]} |")
    return "\n".join(lines) + "\n"


def main():
    args, output = _common.arguments(__doc__, "fit_ends")
    begin = time.perf_counter()
    log = lambda text: print(f"[{time.perf_counter() - begin:6.0f} s] {text}",  # noqa: E731
                             file=sys.stderr, flush=True)
    header = _common.header(jax=jax.__version__, git=quality.git_revision(fitting.__file__))
    strokes = glyph_strokes(args.smoke)
    header["repeats"] = 1 if args.smoke else 3
    rows = run(strokes, MODELS[:1] if args.smoke else MODELS, header["repeats"], log)
    header["load_end"] = _common.load()
    header["wall_seconds"] = time.perf_counter() - begin
    data = {"header": header, "strokes": list(strokes), "rows": rows,
            "summary": summarise(rows)}
    output.write_text(json.dumps(data, indent=1))
    output.with_suffix(".md").write_text(markdown(data))
    log(f"wrote {output} and {output.with_suffix('.md')}")


if __name__ == "__main__":
    main()
