"""Tracing bitmaps: our fit against potrace, errors against the true outlines (issue #21).

    python benchmarks/bench_potrace.py           # full run (~60 min on 2 cores)
    python benchmarks/bench_potrace.py --smoke   # the star and DejaVu Serif 'S' at 256 px

Needs the `potrace` program (Debian's package; a benchmark-only reference).

Shapes with exact outlines: glyphs of DejaVu Serif and STIXGeneral (S, g, &, Q; every
contour, holes too, from matplotlib's `TextPath`, Bezier segments evaluated exactly), a
disk, an ellipse, a superellipse (|x|^4 + |y|^4 = 1) and a five-point star. Each is
scaled to 80% of a square image of 256 or 1024 px and rasterised: a pixel is black when
its center is inside the outline (even-odd). Both tracers get that same bitmap:

- potrace 1.16 with its defaults (corner threshold alphamax 1, opttolerance 0.2, specks
  of up to 2 px dropped), SVG output quantized to 1/100 px; its paths are read back
  (cubic Bezier and line segments) and each segment evaluated exactly.
- ours: the PNG read by `jaxsubdiv.io.read_image` (the level-0.5 contours between pixel
  centers), each contour fitted by `fitting.fit(points, CubicBSpline(), n,
  corners=fitting.find_corners(points, pixel=1.0)[:n])` (corners measured in pixels,
  as the command does for a PNG; since 2026-12-05, before which `corners="auto"`, the
  sample-spacing default), its curve the exact limit points (2^levels per span) joined
  by chords. "Equal segments": n for each contour is the number of segments potrace used
  for it (contours matched by their centroid and area); a closed cubic B-spline of n
  control points is n cubic Bezier segments, creased or not. "Equal error":
  `fitting.fit_tolerance` per contour with potrace's Hausdorff distance to the truth as
  the tolerance, bounding the error against the pixels (`error="pixel"`, since
  2026-12-05 evening; before, against the traced samples), not against the truth.

Errors in pixels against the exact outline (all its contours), both ways, each point's
distance to the other's polylines by brute force: Hausdorff (the larger maximum) and
RMS (the larger RMS over points dense and even along each). Times: potrace's process,
median of 5 runs; our warm fits of all contours of the image (median of 3 after a call
that compiles), reading the image excluded. Each image runs in a process of its own
(the programs of many sizes and counts would exhaust one process's memory mappings,
vm.max_map_count), sharing a compilation cache on disk.

Writes `results/potrace.json` and `.md` (`--output` sets the JSON path).
"""

import json
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))
from _common import arguments, header, load, write_results  # noqa: E402
from bench_fit_corners import glyph_contours, to_polyline  # noqa: E402


GLYPHS = [(family, char) for family in ("DejaVu Serif", "STIXGeneral") for char in "Sg&Q"]
ANALYTIC = ["disk", "ellipse", "superellipse", "star"]
SIZES = (256, 1024)
DENSE = 0.25  # spacing of the dense points on every outline, in px


def analytic_contours(name):
    t = np.linspace(0, 2 * np.pi, 20000, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    if name == "disk":
        return [np.stack([c, s], 1)]
    if name == "ellipse":
        return [np.stack([c, 0.5 * s], 1)]
    if name == "superellipse":
        return [np.stack([np.sign(c) * np.abs(c) ** 0.5, np.sign(s) * np.abs(s) ** 0.5], 1)]
    angle = np.pi / 2 + np.arange(10) * np.pi / 5
    radius = np.where(np.arange(10) % 2 == 0, 1.0, 0.45)
    V = np.stack([radius * np.cos(angle), radius * np.sin(angle)], 1)
    u = np.linspace(0, 1, 2000, endpoint=False)[:, None]
    return [np.concatenate([V[i] + u * (V[(i + 1) % 10] - V[i]) for i in range(10)])]


def place(contours, size):
    """Scale and center the contours into 80% of a size x size image (pixel squares,
    y up: pixel (row r, column c) is [c, c+1] x [size-1-r, size-r])."""
    points = np.concatenate(contours)
    low, high = points.min(0), points.max(0)
    scale = 0.8 * size / (high - low).max()
    center = (low + high) / 2
    return [(p - center) * scale + size / 2 for p in contours]


def rasterise(contours, size):
    """Black where the pixel's center is inside the outline (even-odd), rows top down."""
    from matplotlib.path import Path as MplPath

    y, x = np.mgrid[:size, :size]
    centers = np.stack([x.ravel() + 0.5, size - y.ravel() - 0.5], 1)
    inside = np.zeros(len(centers), bool)
    for contour in contours:
        inside ^= MplPath(contour).contains_points(centers)
    return inside.reshape(size, size)


def densify(polyline, spacing=DENSE):
    """Points every `spacing` along a closed polyline."""
    closed = np.vstack([polyline, polyline[:1]])
    s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
    t = np.arange(0, s[-1], spacing)
    return np.stack([np.interp(t, s, closed[:, k]) for k in range(2)], 1)


def distances(points, polylines):
    return np.min([to_polyline(points, p) for p in polylines], axis=0)


def errors(curves, truth):
    """Two-sided errors (px) between closed polylines `curves` and `truth`."""
    a = [densify(c) for c in curves]
    b = [densify(t) for t in truth]
    a_to_b = distances(np.concatenate(a), truth)
    b_to_a = distances(np.concatenate(b), curves)
    rms = max(np.sqrt(np.mean(a_to_b**2)), np.sqrt(np.mean(b_to_a**2)))
    return float(rms), float(max(a_to_b.max(), b_to_a.max()))


def potrace_paths(svg_text):
    """potrace's SVG path: a list of subpaths, each (dense polyline, segment count), in
    pixel units, y up. potrace writes `M` then relative `c`, `l`, `m` and `z`, inside
    `translate(0, H) scale(k, -k)`: a point (X, Y) of the path is (k X, k Y), y up."""
    k = float(re.search(r"scale\(([-0-9.]+),", svg_text).group(1))
    subpaths = []
    u = np.linspace(0, 1, 64, endpoint=False)[:, None]
    for d in re.findall(r'\sd="([^"]+)"', svg_text):
        tokens = re.findall(r"[MmCcLlZz]|-?[0-9.]+", d)
        position, command, numbers = np.zeros(2), None, []
        points, count, start = [], 0, None

        def flush():
            nonlocal points, count
            if points:
                subpaths.append((np.concatenate(points) * k, count))
            points, count = [], 0

        for token in tokens + ["Z"]:
            if token in "MmCcLlZz":
                command, numbers = token, []
                if token in "Zz":
                    flush()
                    position = start  # a closed subpath ends where it started
                continue
            numbers.append(float(token))
            if command in "Mm" and len(numbers) == 2:
                flush()
                xy = np.array(numbers)
                position = xy if command == "M" else position + xy
                start, numbers = position.copy(), []
                command = "l" if command == "m" else "L"
            elif command == "c" and len(numbers) == 6:
                p1, p2, p3 = (position + np.array(numbers[i:i + 2]) for i in (0, 2, 4))
                p0 = position
                points.append((1 - u) ** 3 * p0 + 3 * (1 - u) ** 2 * u * p1
                              + 3 * (1 - u) * u**2 * p2 + u**3 * p3)
                position, numbers, count = p3, [], count + 1
            elif command in "lL" and len(numbers) == 2:
                end = np.array(numbers) + (position if command == "l" else 0)
                points.append(position + u * (end - position))
                position, numbers, count = end, [], count + 1
    return subpaths


def match(ours, theirs):
    """For each of our contours, the index of potrace's subpath of nearest centroid and
    area (signed areas' absolute values)."""
    def key(p):
        area = 0.5 * abs(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
        return p.mean(0), area

    out = []
    for p in ours:
        c, a = key(p)
        cost = [np.linalg.norm(c - key(q)[0]) + abs(np.sqrt(a) - np.sqrt(key(q)[1]))
                for q, _ in theirs]
        out.append(int(np.argmin(cost)))
    return out


def measure(family, char, size, folder):
    """One image: potrace, then our fits (this process compiles; see `main`)."""
    import equinox as eqx
    import jax

    jax.config.update("jax_enable_x64", True)
    import matplotlib.image

    import fitting
    import jaxsubdiv as js

    js.enable_compilation_cache(Path(folder) / "cache")
    scheme = js.CubicBSpline()
    raw = analytic_contours(char) if family == "analytic" else glyph_contours(family, char)
    truth = place(raw, size)
    bitmap = rasterise(truth, size)
    pbm, png, svg = (Path(folder) / f"image.{e}" for e in ("pbm", "png", "svg"))
    pbm.write_text(f"P1\n{size} {size}\n" + "\n".join(
        " ".join("1" if v else "0" for v in row) for row in bitmap) + "\n")
    matplotlib.image.imsave(png, ~bitmap, cmap="gray", vmin=0, vmax=1)
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        subprocess.run(["potrace", "-b", "svg", "-u", "100", "-o", str(svg), str(pbm)],
                       check=True)
        times.append(time.perf_counter() - t0)
    theirs = potrace_paths(svg.read_text())
    p_rms, p_hausdorff = errors([p for p, _ in theirs], truth)
    # Ours: pixel centers (c, size-1-r) -> the squares' frame, + 0.5.
    contours = [o.points + 0.5 for o in js.io.read_image(png)]
    counts = [max(4, theirs[j][1]) for j in match(contours, theirs)]

    def fit_all(kind):
        results = []
        for points, n in zip(contours, counts):
            # Corners measured in pixels (the command does this for a PNG), timed too.
            corners = fitting.find_corners(points, pixel=1.0)
            if kind == "segments":
                results.append(fitting.fit(points, scheme, n, corners=corners[:n],
                                           on_failure="ignore"))
            else:
                # Against the pixels (read_image's frame: pixel centres at integers).
                result = fitting.fit_tolerance(
                    points - 0.5, scheme, p_hausdorff, corners=corners, error="pixel",
                    on_failure="ignore")
                results.append(eqx.tree_at(lambda r: r.curve, result, result.curve + 0.5))
        return jax.block_until_ready(results)

    row = dict(shape=char if family == "analytic" else f"{family} '{char}'",
               size=size, contours=len(contours),
               potrace=dict(segments=sum(c for _, c in theirs), rms=p_rms,
                            hausdorff=p_hausdorff, seconds=statistics.median(times)))
    for kind in ("segments", "error"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            results = fit_all(kind)
            ours_times = []
            for _ in range(3 if kind == "segments" else 1):
                t0 = time.perf_counter()
                results = fit_all(kind)
                ours_times.append(time.perf_counter() - t0)
        rms, hausdorff = errors([np.asarray(r.curve) for r in results], truth)
        row[kind] = dict(
            segments=sum(int(r.control_points.shape[0]) for r in results),
            rms=rms, hausdorff=hausdorff, seconds=statistics.median(ours_times),
            converged=all(bool(r.converged) for r in results),
            corners=sum(0 if r.creases is None else int(np.sum(r.creases))
                        for r in results))
    return row


def main():
    if sys.argv[1:2] == ["--image"]:  # a child: one image, its row as JSON
        family, char, size, folder = sys.argv[2:6]
        print(json.dumps(measure(family, char, int(size), folder)))
        return
    args, output = arguments(__doc__, "potrace")
    if shutil.which("potrace") is None:
        sys.exit("bench_potrace: the `potrace` program is not installed "
                 "(Debian: apt-get install potrace)")
    import jax

    version = " ".join(subprocess.run(["potrace", "--version"], capture_output=True,
                                      text=True).stdout.split()[:2]).rstrip(".")
    shapes = ([("analytic", "star"), ("DejaVu Serif", "S")] if args.smoke
              else [("analytic", a) for a in ANALYTIC] + GLYPHS)
    sizes = SIZES[:1] if args.smoke else SIZES
    run = header(python=sys.version.split()[0], jax=jax.__version__, potrace=version,
                 corners="fitting.find_corners(points, pixel=1.0)",
                 equal_error='(against the pixels: `error="pixel"`)')
    rows = []
    start = time.perf_counter()
    folder = Path(tempfile.mkdtemp())
    # One process per image: the fits of many sizes and counts compile more programs
    # than one process can map (vm.max_map_count); a shared compilation cache on disk
    # lets later images load the programs earlier ones compiled.
    for family, char in shapes:
        for size in sizes:
            done = subprocess.run([sys.executable, __file__, "--image", family, char,
                                   str(size), str(folder)], capture_output=True, text=True,
                                  timeout=3600)
            if done.returncode != 0:
                raise SystemExit(f"{family} {char!r} at {size} px failed:\n{done.stderr}")
            row = json.loads(done.stdout.strip().splitlines()[-1])
            rows.append(row)
            print(row, flush=True)
    run.update(load_end=load(), wall_seconds=round(time.perf_counter() - start, 1), rows=rows)
    write_results(output, run, markdown)


def markdown(run) -> str:
    lines = [
        "# Tracing bitmaps: fit against potrace (issue #21)",
        "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}, float64; "
        f"{run['potrace']} with its defaults. Wall time {run['wall_seconds']} s. "
        "`benchmarks/bench_potrace.py`: the same binary bitmap to both; errors in pixels "
        "against the exact outline (all contours), two-sided. Equal segments: each contour "
        "fitted with as many control points (cubic Bezier segments) as potrace used for it. "
        "Equal error: `fitting.fit_tolerance` with potrace's Hausdorff as the tolerance "
        + run.get("equal_error", "(against the traced samples)") + ". Times: potrace's process (median of 5); our warm fits "
        "of all contours (median of 3; the tolerance search once, warm). Our corners: "
        + run.get("corners", '`corners="auto"` (sample spacings)') + ".",
        "",
        "| shape | px | segments | potrace RMS | ours RMS | ratio | potrace Hausdorff | "
        "ours Hausdorff | ratio | corners | equal error: our segments | its Hausdorff | "
        "potrace (s) | ours (s) | ratio |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | "
        "---: | ---: | ---: |",
    ]
    for r in run["rows"]:
        p, s, e = r["potrace"], r["segments"], r["error"]
        lines.append(
            f"| {r['shape']} | {r['size']} | {p['segments']} | {p['rms']:.3g} | {s['rms']:.3g} "
            f"| {s['rms'] / p['rms']:.2g} | {p['hausdorff']:.3g} | {s['hausdorff']:.3g} | "
            f"{s['hausdorff'] / p['hausdorff']:.2g} | {s['corners']} | {e['segments']} | "
            f"{e['hausdorff']:.3g} | {p['seconds']:.3f} | {s['seconds']:.3f} | "
            f"{s['seconds'] / p['seconds']:.2g} |")
    rows = run["rows"]
    for label, pick in (("with corners (star, glyphs)", lambda r: r["shape"] not in
                         ("disk", "ellipse", "superellipse")),
                        ("smooth (disk, ellipse, superellipse)", lambda r: r["shape"] in
                         ("disk", "ellipse", "superellipse"))):
        chosen = [r for r in rows if pick(r)]
        if not chosen:
            continue
        h = [r["segments"]["hausdorff"] / r["potrace"]["hausdorff"] for r in chosen]
        q = [r["segments"]["rms"] / r["potrace"]["rms"] for r in chosen]
        t = [r["segments"]["seconds"] / r["potrace"]["seconds"] for r in chosen]
        worse = sum(x > 1 for x in h)
        lines += ["", f"Shapes {label}, {len(chosen)} images, equal segments, ours / "
                  f"potrace: Hausdorff median {statistics.median(h):.2g} ({min(h):.2g}-"
                  f"{max(h):.2g}; worse than potrace on {worse}); RMS median "
                  f"{statistics.median(q):.2g} ({min(q):.2g}-{max(q):.2g}); time median "
                  f"{statistics.median(t):.2g}x ({min(t):.2g}-{max(t):.2g})."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
