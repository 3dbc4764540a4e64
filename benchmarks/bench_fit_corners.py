"""Fits with corners against smooth fits, measured against the true outlines (issue #21).

    python benchmarks/bench_fit_corners.py           # full run (~5 min on 2 cores)
    python benchmarks/bench_fit_corners.py --smoke   # the star and one glyph, n = 32

Shapes with exact outlines, so that errors are measured against the truth and not
against the samples: a five-point star (a polygon) and glyphs of DejaVu Serif and
STIXGeneral (matplotlib's `TextPath`, the outer contour; its quadratic and cubic Bezier
segments evaluated exactly at 200 parameters each). Each outline is resampled to 400
points evenly by arc length (samples lie on the outline but miss its corners by up to
half a spacing), then fitted by `fitting.fit(samples, scheme, n)` with `corners=None`
(the smooth fit) and `corners="auto"` (`fitting.find_corners`' defaults).

Errors, in units of the glyph's em (star: its outer radius 1): the fitted curve
(`result.curve`, the exact limit samples joined by chords) against the dense true
outline, both ways, each point's distance to the other polyline by brute force;
Hausdorff = the larger maximum, RMS = the larger RMS (over the dense points, evenly
spaced along each). Times: warm medians of 3 calls (first call excluded).

A batch: the same outlines' samples (all of them, corners or not) in one
`fitting.fit_batch(samples, CubicBSpline(), 32, corners="auto")` against a loop of
`fitting.fit` over them with the same settings (`max_steps` 200, `fit_batch`'s
default), warm medians of 3; the largest difference between their curves, and each
item's creases against its single fit's.

Writes `results/fit_corners.json` and `.md` (`--output` sets the JSON path).
"""

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))
from _common import arguments, header, load, write_results  # noqa: E402


SHAPES = [("star", None), ("DejaVu Serif", "S"), ("DejaVu Serif", "g"), ("DejaVu Serif", "&"),
          ("DejaVu Serif", "Q"), ("DejaVu Serif", "E"), ("DejaVu Serif", "k"),
          ("STIXGeneral", "S"), ("STIXGeneral", "&"), ("STIXGeneral", "M"),
          ("DejaVu Sans", "O")]


def star_outline():
    angle = np.pi / 2 + np.arange(10) * np.pi / 5
    radius = np.where(np.arange(10) % 2 == 0, 1.0, 0.45)
    V = np.stack([radius * np.cos(angle), radius * np.sin(angle)], 1)
    u = np.linspace(0, 1, 200, endpoint=False)[:, None]
    return np.concatenate([V[i] + u * (V[(i + 1) % 10] - V[i]) for i in range(10)])


def glyph_contours(family, char):
    """Every contour of a glyph (holes too), its Bezier segments evaluated at 200
    parameters each."""
    from matplotlib import font_manager
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    prop = FontProperties(family=family)
    found = font_manager.findfont(prop, fallback_to_default=False)
    if family.replace(" ", "") not in Path(found).stem.replace(" ", ""):
        raise RuntimeError(f"font {family!r} resolved to {found}")
    path = TextPath((0, 0), char, size=1.0, prop=prop)
    contours, current = [], []
    u = np.linspace(0, 1, 200, endpoint=False)
    for segment, code in path.iter_bezier():
        if code == path.MOVETO:
            if current:
                contours.append(np.concatenate(current))
            current = []
            continue
        if code == path.CLOSEPOLY:
            continue
        current.append(segment(u) if code != path.LINETO
                       else segment.control_points[0] + u[:, None]
                       * (segment.control_points[1] - segment.control_points[0]))
    if current:
        contours.append(np.concatenate(current))
    return contours


def glyph_outline(family, char):
    """The outer contour of a glyph, its Bezier segments evaluated at 200 parameters."""

    def area(p):
        return 0.5 * abs(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))

    outline = max(glyph_contours(family, char), key=area)
    keep = np.r_[True, np.linalg.norm(np.diff(outline, axis=0), axis=1) > 1e-12]
    return outline[keep]


def resample(outline, m):
    closed = np.vstack([outline, outline[:1]])
    s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
    t = np.arange(m) * s[-1] / m
    return np.stack([np.interp(t, s, closed[:, k]) for k in range(2)], 1)


def to_polyline(points, polyline):
    """Each point's distance to the closed polyline (brute force, in blocks)."""
    a, b = polyline, np.roll(polyline, -1, axis=0)
    ab = b - a
    length2 = np.maximum(np.sum(ab**2, 1), 1e-300)
    out = []
    for block in np.array_split(points, max(1, len(points) // 256)):
        t = np.clip(np.einsum("pij,ij->pi", block[:, None] - a, ab) / length2, 0, 1)
        foot = a + t[..., None] * ab
        out.append(np.min(np.linalg.norm(block[:, None] - foot, axis=2), axis=1))
    return np.concatenate(out)


def errors(curve, truth):
    c2t, t2c = to_polyline(curve, truth), to_polyline(truth, curve)
    rms = max(np.sqrt(np.mean(c2t**2)), np.sqrt(np.mean(t2c**2)))
    return float(rms), float(max(c2t.max(), t2c.max()))


def main():
    args, output = arguments(__doc__, "fit_corners")
    import jax

    jax.config.update("jax_enable_x64", True)
    import fitting
    import jaxsubdiv as js

    shapes = SHAPES[:2] if args.smoke else SHAPES
    counts = (32,) if args.smoke else (32, 64)
    schemes = [("CubicBSpline", js.CubicBSpline())] + (
        [] if args.smoke else [("FourPoint", js.FourPoint())])
    run = header(python=sys.version.split()[0], jax=jax.__version__)
    rows = []
    start = time.perf_counter()
    for family, char in shapes:
        truth = star_outline() if char is None else glyph_outline(family, char)
        name = "star" if char is None else f"{family} '{char}'"
        samples = resample(truth, 400)
        found = len(fitting.find_corners(samples))
        for scheme_name, scheme in schemes:
            for n in counts:
                row = dict(shape=name, scheme=scheme_name, n=n, corners_found=found)
                for mode in (None, "auto"):
                    call = lambda: fitting.fit(samples, scheme, n, corners=mode,
                                               on_failure="ignore")
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        result = call()
                        times = []
                        for _ in range(3):
                            t0 = time.perf_counter()
                            result = jax.block_until_ready(call())
                            times.append(time.perf_counter() - t0)
                    rms, hausdorff = errors(np.asarray(result.curve), truth)
                    key = "smooth" if mode is None else "corners"
                    row[key] = dict(rms=rms, hausdorff=hausdorff, seconds=statistics.median(times),
                                    steps=int(result.num_steps), status=result.message,
                                    creases=0 if result.creases is None
                                    else int(np.sum(result.creases)))
                rows.append(row)
                print(name, scheme_name, n, {k: row[k] for k in ("smooth", "corners")},
                      flush=True)
    run["batch"] = batch(fitting, js, shapes)
    run.update(load_end=load(), wall_seconds=round(time.perf_counter() - start, 1), rows=rows)
    write_results(output, run, markdown)


def batch(fitting, js, shapes, n=32):
    """`fit_batch` with corners against a loop of `fit` (see the module's docstring)."""
    import jax

    truths = [star_outline() if char is None else glyph_outline(family, char)
              for family, char in shapes]
    targets = [resample(truth, 400) for truth in truths]
    scheme = js.CubicBSpline()
    options = dict(corners="auto", max_steps=200, on_failure="ignore")
    calls = dict(
        batch=lambda: fitting.fit_batch(targets, scheme, n, **options),
        loop=lambda: [fitting.fit(t, scheme, n, **options) for t in targets],
    )
    seconds, results = {}, {}
    for name, call in calls.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            results[name] = jax.block_until_ready(call())
            times = []
            for _ in range(3):
                t0 = time.perf_counter()
                jax.block_until_ready(call())
                times.append(time.perf_counter() - t0)
        seconds[name] = statistics.median(times)
    together, alone = results["batch"], results["loop"]
    # Items with corners: the same model alone and in the batch. Items without: the
    # batch models them by chords (more levels), alone by the smooth model.
    creased = [i for i, r in enumerate(alone) if r.creases is not None]
    difference = max(float(np.abs(np.asarray(together.curve[i]) - np.asarray(alone[i].curve)).max())
                     for i in creased) if creased else 0.0
    same_creases = all(np.array_equal(np.asarray(together.creases[i]), np.asarray(alone[i].creases))
                       for i in creased)
    ratio = [errors(np.asarray(together.curve[i]), truths[i])[1]
             / errors(np.asarray(alone[i].curve), truths[i])[1]
             for i in range(len(targets)) if i not in creased]
    report = dict(items=len(targets), n=n, batch_seconds=seconds["batch"],
                  loop_seconds=seconds["loop"], creased_items=len(creased),
                  max_curve_difference=difference, same_creases=same_creases,
                  smooth_hausdorff_ratios=ratio,
                  converged=int(np.sum(np.asarray(together.converged))))
    print("batch", report, flush=True)
    return report


def markdown(run) -> str:
    lines = [
        "# Fits with corners against smooth fits (issue #21)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}, float64. Wall time "
        f"{run['wall_seconds']} s. `benchmarks/bench_fit_corners.py`: 400 samples evenly "
        "spaced by arc length on each exact outline; errors against the exact outline "
        "(em units; star: outer radius 1), two-sided, RMS and Hausdorff; warm medians.",
        "",
        "| shape | scheme | n | corners found | RMS smooth | RMS corners | ratio | "
        "Hausdorff smooth | Hausdorff corners | ratio | time smooth (s) | time corners (s) | "
        "status corners |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for r in run["rows"]:
        a, b = r["smooth"], r["corners"]
        lines.append(
            f"| {r['shape']} | {r['scheme']} | {r['n']} | {r['corners_found']} | "
            f"{a['rms']:.3g} | {b['rms']:.3g} | {b['rms'] / a['rms']:.3g} | "
            f"{a['hausdorff']:.3g} | {b['hausdorff']:.3g} | {b['hausdorff'] / a['hausdorff']:.3g} | "
            f"{a['seconds']:.3f} | {b['seconds']:.3f} | {b['status']} |")
    with_corners = [r for r in run["rows"] if r["corners_found"]]
    if with_corners:
        h = [r["corners"]["hausdorff"] / r["smooth"]["hausdorff"] for r in with_corners]
        q = [r["corners"]["rms"] / r["smooth"]["rms"] for r in with_corners]
        t = [r["corners"]["seconds"] / r["smooth"]["seconds"] for r in with_corners]
        lines += ["", f"Shapes with corners found ({len(with_corners)} fits): Hausdorff "
                  f"corners / smooth median {statistics.median(h):.3g} (range {min(h):.3g}-"
                  f"{max(h):.3g}); RMS median {statistics.median(q):.3g} ({min(q):.3g}-"
                  f"{max(q):.3g}); time median {statistics.median(t):.3g} ({min(t):.3g}-"
                  f"{max(t):.3g})."]
    b = run.get("batch")
    if b:
        lines += ["", f"A batch of these {b['items']} outlines, CubicBSpline, n = {b['n']}, "
                  f"`corners=\"auto\"`: `fit_batch` {b['batch_seconds']:.3f} s, a loop of "
                  f"`fit` {b['loop_seconds']:.3f} s ({b['loop_seconds'] / b['batch_seconds']:.2f}x); "
                  f"{b['converged']} converged; the {b['creased_items']} with corners within "
                  f"{b['max_curve_difference']:.2g} of their single fits' curves, creases "
                  f"{'the same' if b['same_creases'] else 'DIFFERENT'}; those without corners "
                  "(a smooth curve by chords in the batch): Hausdorff to the truth "
                  + ", ".join(f"{r:.3g}" for r in b["smooth_hausdorff_ratios"])
                  + "x their smooth fits'."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
