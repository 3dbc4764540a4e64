"""Corners found in traced bitmaps: `fitting.find_corners` at its sample-spacing default
against `pixel=1.0` (issue #21).

    python benchmarks/bench_corners.py           # full run (~5 min on 2 cores)
    python benchmarks/bench_corners.py --smoke   # fewer polygons, glyphs at 256 px only

Three sets, each traced the way `jaxsubdiv.io.read_image` traces a PNG (level-0.5
contours between pixel centres; a pixel is black when its centre is inside the shape):

- polygons whose corners are known exactly: a five-point star (inner radius 0.45: tips
  turning 135 degrees, inner corners 63), a seven-point star (inner radius 0.6: 121
  and 69), regular triangle, square, pentagon and hexagon (120, 90, 72, 60), at radii
  30, 60, 100, 200 and 400 px and 6 rotations (0 to 0.5 rad). A corner is found when a
  detection lies within 2.5 px of the vertex; a detection farther than that from every
  vertex is spurious.
- smooth shapes: disks and ellipses (axes 1 : 0.5) of radius 8 to 400 px, where every
  detection is spurious (the smallest ellipses bend with radii of 2 and 4 px, corners
  at the pixel scale).
- the glyph bitmaps of `bench_potrace.py` (DejaVu Serif and STIXGeneral S, g, &, Q and
  the star, at 256 and 1024 px): the true corners are the joints of the glyphs' Bezier
  segments where the tangent turns by 30 degrees or more (turns of 15-30 degrees
  neither count as missed nor make a detection spurious), within 3 px.

Times: `find_corners` per contour, median over the glyph contours. Writes
`results/corners.json` and `.md`.
"""

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))
from _common import arguments, header, load, write_results  # noqa: E402


MODES = {"default": {}, "pixel": {"pixel": 1.0}}
POLYGONS = ["star5", "star7", "triangle", "square", "pentagon", "hexagon"]
RADII = (30, 60, 100, 200, 400)
ROTATIONS = np.linspace(0.0, 0.5, 6)


def polygon(name, rotation):
    if name.startswith("star"):
        k, inner = (5, 0.45) if name == "star5" else (7, 0.6)
        angle = np.pi / 2 + rotation + np.arange(2 * k) * np.pi / k
        radius = np.where(np.arange(2 * k) % 2 == 0, 1.0, inner)
    else:
        k = {"triangle": 3, "square": 4, "pentagon": 5, "hexagon": 6}[name]
        angle = rotation + 2 * np.pi * np.arange(k) / k
        radius = np.ones(k)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def turning_degrees(vertices):
    a = vertices - np.roll(vertices, 1, axis=0)
    b = np.roll(vertices, -1, axis=0) - vertices
    cosine = np.sum(a * b, 1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
    return np.degrees(np.arccos(np.clip(cosine, -1, 1)))


def trace(inside_of, size):
    """The contours of the pixels whose centres `inside_of` accepts, as `read_image`
    gives them for a PNG of that bitmap (pixel (r, c) is the point (c, size - 1 - r))."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image

    import jaxsubdiv as js

    rows, columns = np.mgrid[:size, :size]
    centres = np.stack([columns.ravel(), size - 1 - rows.ravel()], axis=1).astype(float)
    bitmap = inside_of(centres).reshape(size, size)
    with tempfile.TemporaryDirectory() as folder:
        png = Path(folder) / "bitmap.png"
        matplotlib.image.imsave(png, np.where(bitmap, 0.0, 1.0), cmap="gray", vmin=0, vmax=1)
        return [outline.points for outline in js.io.read_image(png)]


def score(found, required, optional, tolerance):
    """(missed, spurious): required points with no detection within `tolerance`, and
    detections farther than that from every required or optional point."""
    found = np.asarray(found).reshape(-1, 2)
    every = np.concatenate([required, optional]).reshape(-1, 2)
    if len(found) == 0:
        return len(required), 0
    missed = int(np.sum(np.linalg.norm(required[:, None] - found[None], axis=2).min(1)
                        > tolerance)) if len(required) else 0
    spurious = int(np.sum(np.linalg.norm(found[:, None] - every[None], axis=2).min(1)
                          > tolerance)) if len(every) else len(found)
    return missed, spurious


def detections(contours, options, times=None):
    import fitting

    found = []
    for points in contours:
        start = time.perf_counter()
        index = fitting.find_corners(points, **options)
        if times is not None:
            times.append(time.perf_counter() - start)
        found += [points[i] for i in index]
    return np.asarray(found).reshape(-1, 2)


def polygon_rows(smoke):
    from matplotlib.path import Path as PolygonPath

    rows = []
    for name in POLYGONS[:3] if smoke else POLYGONS:
        for radius in RADII[1:3] if smoke else RADII:
            counts = {mode: [0, 0] for mode in MODES}
            total = 0
            for rotation in ROTATIONS[:2] if smoke else ROTATIONS:
                size = int(2 * radius) + 10
                vertices = polygon(name, rotation) * radius + size / 2
                contours = trace(PolygonPath(vertices).contains_points, size)
                total += len(vertices)
                for mode, options in MODES.items():
                    missed, spurious = score(detections(contours, options), vertices,
                                             np.zeros((0, 2)), 2.5)
                    counts[mode][0] += missed
                    counts[mode][1] += spurious
            rows.append(dict(shape=name, turning=sorted(set(np.round(turning_degrees(
                polygon(name, 0.0))).astype(int).tolist()), reverse=True), radius=radius,
                corners=total, **{m: dict(missed=c[0], spurious=c[1]) for m, c in counts.items()}))
            print(rows[-1], flush=True)
    return rows


def smooth_rows(smoke):
    rows = []
    for radius in (8, 30) if smoke else (8, 15, 30, 60, 100, 200, 400):
        for ratio in (1.0, 0.5):
            size = int(2 * radius) + 10

            def inside(p, radius=radius, ratio=ratio, size=size):
                # Off-centre by a fraction of a pixel: no symmetric staircase.
                x, y = (p[:, 0] - size / 2 - 0.3) / radius, (p[:, 1] - size / 2 - 0.1) / radius
                return x**2 + (y / ratio) ** 2 <= 1

            contours = trace(inside, size)
            rows.append(dict(shape="disk" if ratio == 1 else "ellipse", radius=radius,
                             **{m: dict(spurious=len(detections(contours, o)))
                                for m, o in MODES.items()}))
            print(rows[-1], flush=True)
    return rows


def glyph_rows(smoke):
    import bench_potrace as bp
    from matplotlib.path import Path as PolygonPath

    shapes = [("analytic", "star"), ("DejaVu Serif", "S")] if smoke else \
        [("analytic", "star")] + bp.GLYPHS
    rows = []
    times = {mode: [] for mode in MODES}
    for family, char in shapes:
        raw = bp.analytic_contours(char) if family == "analytic" else bp.glyph_contours(family, char)
        per = 2000 if family == "analytic" else 200  # samples per segment of `raw`
        for size in (256,) if smoke else bp.SIZES:
            # bench_potrace's frame: pixel squares [c, c+1]; read_image's points are the
            # pixel centres, half a pixel less.
            truth = [c - 0.5 for c in bp.place(raw, size)]
            joints, turns = [], []
            for contour in truth:
                index = np.arange(0, len(contour), per)
                before = contour[index] - contour[index - 1]
                after = contour[(index + 1) % len(contour)] - contour[index]
                cosine = np.sum(before * after, 1) / np.maximum(
                    np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1), 1e-300)
                joints.append(contour[index])
                turns.append(np.degrees(np.arccos(np.clip(cosine, -1, 1))))
            joints, turns = np.concatenate(joints), np.concatenate(turns)
            required, optional = joints[turns >= 30], joints[(turns >= 15) & (turns < 30)]

            def inside(p, truth=truth):
                result = np.zeros(len(p), bool)
                for contour in truth:
                    result ^= PolygonPath(contour).contains_points(p)
                return result

            contours = trace(inside, size)
            row = dict(shape=char if family == "analytic" else f"{family} '{char}'",
                       size=size, corners=len(required))
            for mode, options in MODES.items():
                missed, spurious = score(detections(contours, options, times[mode]),
                                         required, optional, 3.0)
                row[mode] = dict(missed=missed, spurious=spurious)
            rows.append(row)
            print(row, flush=True)
    return rows, {mode: statistics.median(t) for mode, t in times.items()}


def main():
    args, output = arguments(__doc__, "corners")
    import numpy

    run = header(python=sys.version.split()[0], numpy=numpy.__version__)
    start = time.perf_counter()
    run["polygons"] = polygon_rows(args.smoke)
    run["smooth"] = smooth_rows(args.smoke)
    run["glyphs"], run["seconds_per_contour"] = glyph_rows(args.smoke)
    run.update(load_end=load(), wall_seconds=round(time.perf_counter() - start, 1))
    write_results(output, run, markdown)


def markdown(run) -> str:
    def pair(row, mode):
        return f"{row[mode]['missed']} / {row[mode]['spurious']}"

    lines = [
        "# Corners of traced bitmaps: sample spacings against pixels (issue #21)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); numpy {run['numpy']}. Wall time "
        f"{run['wall_seconds']} s. `benchmarks/bench_corners.py`: `fitting.find_corners` "
        "on contours traced like `read_image`'s, at its default (turning over 3 median "
        "sample spacings) and with `pixel=1.0` (chords from 1 to 4 px on each side). "
        "Each cell: corners missed / detections that are no corner.",
        "",
        "## Polygons (6 rotations each; found within 2.5 px)",
        "",
        "| shape | turning (degrees) | radius px | corners | default | pixel |",
        "| --- | --- | ---: | ---: | ---: | ---: |",
    ]
    for r in run["polygons"]:
        lines.append(f"| {r['shape']} | {', '.join(map(str, r['turning']))} | {r['radius']} | "
                     f"{r['corners']} | {pair(r, 'default')} | {pair(r, 'pixel')} |")
    lines += ["", "## Smooth shapes (every detection is spurious)", "",
              "| shape | radius px | default | pixel |", "| --- | ---: | ---: | ---: |"]
    for r in run["smooth"]:
        lines.append(f"| {r['shape']} | {r['radius']} | {r['default']['spurious']} | "
                     f"{r['pixel']['spurious']} |")
    lines += ["", "## Glyph bitmaps of bench_potrace.py (corners turning 30 degrees or "
              "more, found within 3 px)", "",
              "| shape | px | corners | default | pixel |", "| --- | ---: | ---: | ---: | ---: |"]
    for r in run["glyphs"]:
        lines.append(f"| {r['shape']} | {r['size']} | {r['corners']} | {pair(r, 'default')} | "
                     f"{pair(r, 'pixel')} |")
    lines.append("")
    for label, rows, key in (("polygons", run["polygons"], "corners"),
                             ("glyph bitmaps", run["glyphs"], "corners")):
        total = sum(r[key] for r in rows)
        text = "; ".join(
            f"{mode}: {sum(r[mode]['missed'] for r in rows)} missed, "
            f"{sum(r[mode]['spurious'] for r in rows)} spurious" for mode in MODES)
        lines.append(f"Totals, {label} ({total} corners): {text}.")
    text = "; ".join(f"{mode}: {sum(r[mode]['spurious'] for r in run['smooth'])}"
                     for mode in MODES)
    lines.append(f"Totals, smooth shapes (spurious): {text}.")
    times = "; ".join(f"{mode} {1e3 * t:.2f} ms" for mode, t in run["seconds_per_contour"].items())
    lines.append(f"Time per glyph contour, median: {times}.")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
