"""A tolerance in pixels for traced bitmaps: against the samples or against the pixels
(issue #21).

    python benchmarks/bench_pixel_tolerance.py           # full run (~30 min on 2 cores)
    python benchmarks/bench_pixel_tolerance.py --smoke   # the star at 256 px, 1 px

The shapes, bitmaps and error measure of `bench_potrace.py` (exact outlines of glyphs
and analytic shapes scaled to 80% of the image, a pixel black when its centre is
inside; errors in pixels against the exact outline, two-sided, dense): each contour
traced by `jaxsubdiv.io.read_image` and fitted by `fitting.fit_tolerance(points,
CubicBSpline(), tol, corners=fitting.find_corners(points, pixel=1.0), error=...)` with

- `error="max_error"`: the two-sided max error against the traced samples (what
  `jaxsubdiv fit --tolerance` bounded for a PNG before `fitting.pixel_error`);
- `error="pixel"`: the two-sided max error against the pixels (`fitting.pixel_error`;
  the command's measure for a PNG now).

For each: whether every contour met the tolerance, the control points chosen (all
contours), the fits tried, the figure the search bounded, the error against the true
outline (Hausdorff and RMS, px), the exact outline's own pixel error (what the pixels
cannot show of it: sharp tips thinner than a pixel), and the search's wall time (compilations included:
the first search of an image compiles, the second reuses programs of the counts both
tried; each image in a process of its own with a shared compilation cache on disk, as
in `bench_potrace.py`).

Writes `results/pixel_tolerance.json` and `.md` (`--output` sets the JSON path).
"""

import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))
from _common import arguments, child_json, header, load, write_results  # noqa: E402
from bench_fit_corners import glyph_contours  # noqa: E402
from bench_potrace import analytic_contours, errors, match, place, rasterise  # noqa: E402


IMAGES = ([("analytic", name, 256) for name in ("star", "disk", "superellipse")]
          + [(family, char, 256) for family, chars in (("DejaVu Serif", "Sg&Q"),
                                                        ("STIXGeneral", "SQ"))
             for char in chars]
          + [("analytic", "star", 1024), ("DejaVu Serif", "S", 1024)])
TOLERANCES = (0.5, 1.0)
ERRORS = ("max_error", "pixel")


def measure(family, char, size, folder, tolerances):
    """One image: a search per tolerance and error measure (this process compiles)."""
    import jax
    import matplotlib.image

    import fitting
    import jaxsubdiv as js

    js.enable_compilation_cache(Path(folder) / "cache")
    scheme = js.CubicBSpline()
    raw = analytic_contours(char) if family == "analytic" else glyph_contours(family, char)
    truth = place(raw, size)
    png = Path(folder) / "image.png"
    matplotlib.image.imsave(png, ~rasterise(truth, size), cmap="gray", vmin=0, vmax=1)
    # read_image puts pixel centres at integers; the truth's frame has them at + 0.5.
    contours = [o.points for o in js.io.read_image(png)]
    # The exact outline's own pixel error (each traced contour against the true contour
    # of nearest centroid and area): what the pixels cannot show of it.
    nearest = match(contours, [(t - 0.5, 0) for t in truth])
    truth_pixel_error = max(fitting.pixel_error(truth[j] - 0.5, points).max_error
                            for points, j in zip(contours, nearest))
    rows = []
    for tolerance in tolerances:
        for error in ERRORS:
            results, tried, bounded, met = [], 0, [], True
            start = time.perf_counter()
            for points in contours:
                counts = []
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    result = fitting.fit_tolerance(
                        points, scheme, tolerance, error=error, on_failure="ignore",
                        corners=fitting.find_corners(points, pixel=1.0),
                        on_trial=lambda n, r: counts.append(n))
                result = jax.block_until_ready(result)
                tried += len(counts)
                met &= fitting.STATUSES[int(result.status)] != "tolerance_not_reached"
                value = (fitting.pixel_error(result, points).max_error if error == "pixel"
                         else float(result.max_error))
                bounded.append(value)
                results.append(result)
            seconds = time.perf_counter() - start
            rms, hausdorff = errors([np.asarray(r.curve, np.float64) + 0.5 for r in results],
                                    truth)
            rows.append(dict(
                shape=char if family == "analytic" else f"{family} '{char}'", size=size,
                contours=len(contours), tolerance=tolerance, error=error, met=bool(met),
                control_points=sum(int(r.control_points.shape[0]) for r in results),
                fits=tried, bounded=max(bounded), true_hausdorff=hausdorff, true_rms=rms,
                seconds=round(seconds, 2), truth_pixel_error=truth_pixel_error))
    return rows


#: A child process measures one image (fresh programs: see `bench_potrace.py`).
CHILD = """import json, sys
sys.path.insert(0, {folder!r})
from bench_pixel_tolerance import measure
family, char, size, cache, tolerances = sys.argv[1:6]
print(json.dumps(measure(family, char, int(size), cache,
                         [float(t) for t in tolerances.split(",")])))
"""


def main():
    args, output = arguments(__doc__, "pixel_tolerance")
    import jax

    images = [("analytic", "star", 256)] if args.smoke else IMAGES
    tolerances = TOLERANCES[1:] if args.smoke else TOLERANCES
    run = header(python=sys.version.split()[0], jax=jax.__version__)
    rows, start, folder = [], time.perf_counter(), Path(tempfile.mkdtemp())
    code = CHILD.format(folder=str(Path(__file__).parent))
    for family, char, size in images:
        for row in child_json(code, family, char, str(size), str(folder),
                              ",".join(str(t) for t in tolerances),
                              what=f"{family} {char!r} at {size} px", timeout=3600):
            rows.append(row)
            print(row, flush=True)
    run.update(load_end=load(), wall_seconds=round(time.perf_counter() - start, 1), rows=rows)
    write_results(output, run, markdown)


def markdown(run) -> str:
    lines = [
        "# A tolerance in pixels: against the samples or against the pixels (issue #21)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}. Wall time "
        f"{run['wall_seconds']} s. `benchmarks/bench_pixel_tolerance.py`: "
        "`fitting.fit_tolerance` per contour of the traced bitmap, corners in pixels, "
        "bounding the max error against the samples (`max_error`) or against the pixels "
        "(`pixel`); true errors in px against the exact outline, two-sided. Seconds: the "
        "search's wall time, compilations included (the `max_error` search of each "
        "tolerance runs first and compiles most).",
        "",
        "| shape | px | tol (px) | bounds | met | control points | fits | bounded error | "
        "true Hausdorff | true RMS | s | the truth's pixel error |",
        "| --- | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in run["rows"]:
        lines.append(
            f"| {r['shape']} | {r['size']} | {r['tolerance']:g} | {r['error']} | "
            f"{'yes' if r['met'] else 'no'} | {r['control_points']} | {r['fits']} | "
            f"{r['bounded']:.3g} | {r['true_hausdorff']:.3g} | {r['true_rms']:.3g} | "
            f"{r['seconds']:.1f} | {r['truth_pixel_error']:.2g} |")
    lines.append("")
    for error in ERRORS:
        chosen = [r for r in run["rows"] if r["error"] == error]
        within = [r for r in chosen if r["met"]]
        ratio = [r["true_hausdorff"] / r["tolerance"] for r in within]
        lines.append(
            f"- `{error}`: met on {len(within)} of {len(chosen)} searches; where met, the "
            "true Hausdorff / tolerance " + (
                f"median {statistics.median(ratio):.2g} ({min(ratio):.2g}-{max(ratio):.2g})"
                if ratio else "(none)")
            + f"; fits per search median {statistics.median(r['fits'] for r in chosen):g}.")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
