"""The `jaxsubdiv` command: every subcommand and input format driven, outputs read back
(with parsers written here, not jaxsubdiv's) and checked against independent references.

Most cases call `main([...])` in this process (a subprocess costs ~3 s of imports); a few
run the installed `jaxsubdiv` script.
"""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest
from helpers import (
    bezier_evaluate,
    chaikin_python,
    periodic_bspline,
    polyline_distances,
    svg_bezier_paths,
    uneven_samples,
    wobbly_polygon,
)
from scipy.interpolate import BSpline

import fitting
import jaxsubdiv as js
from jaxsubdiv._cli import main


SCRIPT = Path(sys.executable).with_name("jaxsubdiv")


def run(*args, timeout=600):
    """The installed console script in a subprocess."""
    return subprocess.run([str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


def cli(capsys, *args):
    """`main` in this process: (exit status, stdout, stderr). Without the persistent
    compilation cache, which would stay switched on for the rest of the test process
    (`test_startup.py` tests it in subprocesses)."""
    try:
        status = main(["--no-compilation-cache", *(str(a) for a in args)])
    except SystemExit as e:  # argparse: usage errors and --help
        status = e.code
    out = capsys.readouterr()
    return status, out.out, out.err


def _pixels_vary(path):
    return matplotlib.image.imread(path)[..., :3].std() > 0.05


def _table(path):
    """x, y rows of a CSV/TXT file (commas or whitespace, `#` comments)."""
    rows = [line for line in Path(path).read_text().splitlines()
            if line.strip() and not line.lstrip().startswith("#")]
    return np.array([[float(v) for v in re.split(r"[,\s]+", line.strip())] for line in rows])


def _circle(m, radius=2.0, center=(1.0, -0.5)):
    angle = 2 * np.pi * (np.arange(m) + 0.3) / m
    return np.stack([center[0] + radius * np.cos(angle), center[1] + radius * np.sin(angle)], 1)


def _parameter_shift(curve, point, period, step):
    """The parameter in [0, period) on the grid `step` where `curve` is nearest `point`."""
    grid = np.arange(0, period, step)
    return grid[np.argmin(np.linalg.norm(curve(grid) - point, axis=1))]


def _check_bezier_svg(svg_path, control, degree, subpath=None):
    """The SVG's Bezier segments (of its only subpath, or of subpath `subpath`) sampled
    by de Casteljau against scipy's periodic B-spline of `control`; returns the largest
    distance relative to the curve's size."""
    subpaths = svg_bezier_paths(Path(svg_path).read_text())
    if subpath is None:
        (segments,) = subpaths
    else:
        segments = subpaths[subpath]
    assert len(segments) == len(control)
    assert all(len(s) == degree + 1 for s in segments)  # cubic: C, quadratic: Q
    curve = periodic_bspline(control, degree)
    shift = _parameter_shift(curve, segments[0][0], len(control), 0.5)
    u = np.linspace(0, 1, 41)
    worst = 0.0
    for i, segment in enumerate(segments):
        error = bezier_evaluate(segment, u) - curve(shift + i + u)
        worst = max(worst, float(np.abs(error).max()))
    size = np.linalg.norm(np.ptp(curve(np.linspace(0, len(control), 2000)), axis=0))
    return worst / size


# ----------------------------------------------------------------------------- fit


def test_fit_circle_from_csv_with_the_installed_script(tmp_path):
    """A circle of radius 2 sampled in a CSV, fitted with Chaikin's scheme: the fitted
    curve (scipy's periodic quadratic B-spline of the written control points) stays
    within 1e-3 of the radius, the SVG's quadratic Beziers are that curve to 1e-9, and
    the progress display shows on stderr."""
    samples = _circle(200)
    source = tmp_path / "circle.csv"
    rows = "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in samples)
    source.write_text("# a circle\nx,y\n" + rows)
    out, svg, png = tmp_path / "fit.json", tmp_path / "fit.svg", tmp_path / "fit.png"
    result = run("fit", source, "--scheme", "chaikin", "--n", 16, "-o", out, "--svg", svg,
                 "--plot", png)
    assert result.returncode == 0, result.stderr
    # The progress display: a first-use note, then the elapsed time of each phase of the
    # start searched (`--phases`, default 4 for a closed contour without corners).
    assert "preparing the fit for 224 samples" in result.stderr
    assert re.findall(r"fitting, phase (\d) of 4: +[0-9.]+ s, done", result.stderr) == list("1234")
    # stderr is a pipe here, not a terminal: one final line each, no rewrites piling up.
    assert "\r" not in result.stderr and result.stderr.count("fitting") == 4
    assert json.loads(out.read_text())["info"]["phases"] == 4
    assert "contour 1 of 1: 200 samples, closed" in result.stdout
    assert "status     converged" in result.stdout
    saved = json.loads(out.read_text())
    assert saved["scheme"]["type"] == "Chaikin" and saved["boundary"] == "closed"
    control = np.array(saved["control_points"])
    assert control.shape == (16, 2)
    curve = periodic_bspline(control, 2)(np.linspace(0, 16, 4000, endpoint=False))
    radius = np.linalg.norm(curve - [1.0, -0.5], axis=1)
    assert np.abs(radius - 2.0).max() < 1e-3
    # The printed errors are the saved ones, and relative to the size (the diagonal of
    # the bounding box, 4 sqrt 2 here).
    rms = float(re.search(r"rms error  (\S+) \((\S+) of the size", result.stdout).group(1))
    relative = float(re.search(r"rms error  \S+ \((\S+) of the size", result.stdout).group(1))
    np.testing.assert_allclose(rms, saved["errors"]["rms"], rtol=5e-3)  # 3 digits
    size = np.linalg.norm(np.ptp(samples, axis=0))
    np.testing.assert_allclose(relative, rms / size, rtol=1e-2)
    assert saved["errors"]["max_error"] < 1e-3
    assert _check_bezier_svg(svg, control, 2) < 1e-9
    assert "exact Bezier segments" in result.stdout
    assert _pixels_vary(png)


def test_fit_glyph_with_a_hole_json_reproduces_the_curve(capsys, tmp_path):
    """'o' has two contours, fitted separately; each JSON rebuilds the written curve, and
    the SVG is one path of two subpaths, exact cubic Beziers, filled even-odd (the hole
    stays a hole). (The same fit settings as the demo test below, so the two share one
    compilation.)"""
    args = ("fit", "--text", "o", "--n", 16, "--samples", 200, "--quiet")
    status, out, err = cli(capsys, *args, "-o", tmp_path / "o.json", "--svg",
                           tmp_path / "o.svg", "--plot", tmp_path / "o.png")
    assert status == 0, err
    assert err == ""  # --quiet: no progress display
    assert "contour 1 of 2: 200 samples" in out and "contour 2 of 2: 200 samples" in out
    assert out.count("status     converged") == 2
    status, out2, err = cli(capsys, *args, "-o", tmp_path / "o.csv")
    assert status == 0, err
    written = (tmp_path / "o.csv").read_text().split("\n\n")
    assert len(written) == 2
    for i, block in enumerate(written):
        saved = json.loads((tmp_path / f"o-{i + 1}.json").read_text())
        assert saved["scheme"]["type"] == "CubicBSpline"
        assert saved["info"]["contour"] == i + 1 and saved["info"]["contours"] == 2
        control = np.array(saved["control_points"])
        # The second run fitted the same control points.
        rebuilt = js.io.read_result_json(tmp_path / f"o-{i + 1}.json")
        np.testing.assert_array_equal(rebuilt.control_points, control)
        # The curve written by the second run is the limit curve of the saved control
        # points at the dyadic parameters of the saved levels, by library ...
        points = np.array([[float(v) for v in line.split(",")]
                           for line in block.splitlines() if line and not line.startswith("#")])
        again = js.limit_points(js.refine(control, rebuilt.scheme, rebuilt.levels),
                                rebuilt.scheme)
        np.testing.assert_allclose(points, np.asarray(again), rtol=0, atol=1e-12)
        # ... and by scipy's cubic B-spline.
        spline = periodic_bspline(control, 3)
        per_unit = len(points) // len(control)
        shift = _parameter_shift(spline, points[0], len(control), 0.5 / per_unit)
        expected = spline(shift + np.arange(len(points)) / per_unit)
        assert np.abs(points - expected).max() < 1e-12
        assert _check_bezier_svg(tmp_path / "o.svg", control, 3, subpath=i) < 1e-9
    svg = (tmp_path / "o.svg").read_text()
    assert svg.count("<path") == 1 and 'fill-rule="evenodd"' in svg
    assert len(svg_bezier_paths(svg)) == 2
    assert _pixels_vary(tmp_path / "o.png")


def test_fit_open_stroke_with_pinned_ends(capsys, tmp_path):
    """An open CSV stroke (`# closed: false`) with --pin-ends: the saved control points'
    curve (scipy's open cubic B-spline on its knots' valid interval) starts at the
    first sample and ends at the last, and the JSON records the pin."""
    t = np.linspace(0, 1, 150)
    stroke = np.stack([3 * t, np.sin(5 * t) + 0.01 * np.cos(40 * t)], 1)
    source = tmp_path / "stroke.csv"
    rows = "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in stroke)
    source.write_text("# closed: false\n" + rows)
    status, out, err = cli(capsys, "fit", source, "--n", 10, "--pin-ends", "--quiet",
                           "-o", tmp_path / "stroke.json")
    assert status == 0, err
    assert "contour 1 of 1: 150 samples, open (ends pinned)" in out
    saved = json.loads((tmp_path / "stroke.json").read_text())
    assert saved["boundary"] == "open" and saved["info"]["pin_ends"] is True
    control = np.array(saved["control_points"])
    spline = BSpline(np.arange(len(control) + 4, dtype=float), control, 3)
    np.testing.assert_allclose(spline([3.0, len(control)]), stroke[[0, -1]], rtol=0,
                               atol=1e-12)


def test_a_saved_fit_reopens_in_every_command(capsys, tmp_path):
    # `fit -o x.json` wrote a file that `refine`, `fit` and `edit` refused (found by a
    # user try-out). Now `refine` and `edit` take its control polygon, `fit` its curve.
    saved = tmp_path / "fit.json"
    status, _, err = cli(capsys, "fit", "--shape", "star", "--n", 16, "--quiet", "-o", saved)
    assert status == 0, err
    control = np.array(json.loads(saved.read_text())["control_points"])
    refined = tmp_path / "refined.csv"
    status, out, err = cli(capsys, "refine", saved, "--levels", 2, "-o", refined)
    assert status == 0 and "16 -> 64 points (closed)" in out, err
    status, out, err = cli(capsys, "fit", saved, "--n", 16, "--quiet")
    assert status == 0 and "status     converged" in out, err
    relative = float(re.search(r"rms error  [0-9.e-]+ \(([0-9.e-]+) of the size", out).group(1))
    assert relative < 1e-3
    status, out, err = cli(capsys, "edit", saved, "--png", tmp_path / "edit.png")
    assert status == 0 and f"{len(control)} control points, closed" in out, err


def test_fit_with_a_scheme_without_a_limit_curve_says_so(capsys):
    # Four-point at w = 0.6 does not converge (|w| < 1/2 is needed; Hölder exponent
    # below 0): its fit is of a refined polygon. It said "converged" and nothing else
    # on stdout (found by a user try-out); the warning goes to stderr.
    status, out, err = cli(capsys, "fit", "--shape", "star", "--scheme", "four-point",
                           "--w", 0.6, "--quiet")
    assert status == 0, err
    assert "note       no limit curve (jaxsubdiv.smoothness: does not converge)" in out
    assert "changes with --levels" in out
    status, out, _ = cli(capsys, "fit", "--shape", "star", "--scheme", "four-point", "--quiet")
    assert status == 0 and "limit curve" not in out


def test_fit_with_phases_recovers_a_known_curve(capsys, tmp_path):
    """The command's default (4 phases) and --phases 4 reach the curve a CSV's samples
    were drawn from (a closed cubic B-spline of a known 16-point polygon, scipy's;
    samples spaced unevenly), where one start (--phases 1, `fitting.fit`'s default)
    stops in a local minimum: the saved control points' curve within 1e-5 of the size
    of the truth, against 1e-4 or more from one. The JSON records the phases searched;
    with --fit-params they are not searched, and by default that is no error."""
    polygon = wobbly_polygon(0)
    dense = lambda P: periodic_bspline(np.asarray(P), 3)(np.linspace(0, 16, 2**12, endpoint=False))
    truth = dense(polygon)
    size = np.ptp(truth, axis=0).max()
    source = tmp_path / "known.csv"
    source.write_text("".join(f"{float(x)!r},{float(y)!r}\n" for x, y in uneven_samples(truth, 0)))
    gaps = {}
    for phases in (1, 4, None):
        option = () if phases is None else ("--phases", phases)
        saved = tmp_path / f"p{phases}.json"
        status, out, err = cli(capsys, "fit", source, "--n", 16, "--corners", "none",
                               *option, "--quiet", "-o", saved)
        assert status == 0, err
        written = json.loads(saved.read_text())
        assert written["info"]["phases"] == (phases or 4)
        fitted = dense(written["control_points"])
        gaps[phases] = max(polyline_distances(fitted, truth).max(),
                           polyline_distances(truth, fitted).max()) / size
    assert max(gaps[4], gaps[None]) < 1e-5 < 1e-4 < gaps[1], gaps
    saved = tmp_path / "params.json"
    status, _, err = cli(capsys, "fit", source, "--n", 16, "--scheme", "four-point",
                         "--fit-params", "--quiet", "-o", saved)
    assert status in (0, 1) and "error" not in err, err
    assert json.loads(saved.read_text())["info"]["phases"] == 1
    for bad in (("--phases", 0), ("--phases", 4, "--fit-params", "--scheme", "four-point"),
                ("--phases", 4, "--boundary", "open")):
        status, _, err = cli(capsys, "fit", source, *bad)
        assert status == 2 and "--phases" in err and "Traceback" not in err, err
    # Corners found: said, not silently ignored.
    status, out, err = cli(capsys, "fit", "--shape", "star", "--phases", 4, "--quiet")
    assert status == 0, err
    assert "--phases 4 not searched: the corners place the spans" in out


def test_fit_a_matplotlib_icon_by_default(capsys):
    """matplotlib's home icon (a file nobody here drew): its transparent background
    rectangle is skipped and its straight-line contours are sampled along their edges,
    so the default fit works (issue #18: it stopped at 'its 4 points are fewer than the
    64 unknowns'). Two contours, the house's outer and inner outline, each converged
    within 1e-3 of its size (RMS)."""
    import matplotlib

    icon = Path(matplotlib.get_data_path()) / "images" / "home.svg"
    status, out, err = cli(capsys, "fit", icon, "--quiet")
    assert status == 0, err
    assert "2 contours" in out and out.count("status     converged") == 2
    relative = [float(v) for v in re.findall(r"rms error +\S+ \((\S+) of the size", out)]
    assert len(relative) == 2 and max(relative) < 1e-3, relative


def test_fit_a_glyph_of_straight_contours_by_default(capsys):
    """DejaVu Sans 'E' and '.' are drawn with straight segments only: fitted, they are
    sampled at 400 points like curved glyphs (they were read as their 12 and 4 corners
    and the command stopped at 'its 4 points are fewer than the 64 unknowns'). The
    square dot's four corners are found and kept: max error within 1% of its size."""
    for text, corners in (("E", 12), (".", 4)):
        status, out, err = cli(capsys, "fit", "--text", text, "--quiet")
        assert status == 0, err
        assert "contour 1 of 1: 400 samples" in out and "status     converged" in out
        assert f"corners    {corners} " in out
        relative = float(re.search(r"max error +\S+ \((\S+) of the size", out)[1])
        assert relative < 1e-2, (text, relative)


def test_fit_that_does_not_converge_exits_1_and_says_which(capsys, tmp_path):
    source = tmp_path / "circle.npy"
    np.save(source, _circle(100))
    status, out, err = cli(capsys, "fit", source, "--scheme", "four-point", "--fit-params",
                           "--n", 10, "--max-steps", 3, "--quiet", "-o", tmp_path / "w.json")
    assert status == 1
    (line,) = err.strip().splitlines()
    assert line.startswith("jaxsubdiv fit: contour 1 of 1 did not converge (")
    assert line.endswith(") after 3 steps")
    w = float(re.search(r"scheme     four-point \(w=(\S+)\)", out).group(1))
    saved = json.loads((tmp_path / "w.json").read_text())
    assert saved["scheme"]["type"] == "FourPoint"
    np.testing.assert_allclose(saved["scheme"]["parameters"]["w"], w, rtol=1e-5)
    assert 0 < w < 0.19 and saved["info"]["status"] != 0 and saved["info"]["num_steps"] == 3
    # Whether the start's fit was kept: printed and saved alike.
    assert isinstance(saved["info"]["params_held"], bool)
    assert ("kept at the start" in out) == saved["info"]["params_held"]


@pytest.mark.parametrize("held, kept", [(True, True), (False, False), (None, False)])
def test_the_scheme_line_says_when_fit_params_kept_the_start(held, kept):
    """`--fit-params` prints the scheme with its values, and says when they are the
    given ones because the fit with them held had the lower error
    (`FitResult.params_held`; the run above covers False, the horse of
    `tests/test_fit.py` is held but 20 s to compile on the command line)."""
    from types import SimpleNamespace

    from jaxsubdiv import _cli

    result = SimpleNamespace(scheme=js.FourPoint(), params_held=None if held is None
                             else np.asarray(held))
    line = _cli._fitted_scheme_text("four-point", result)
    assert line.startswith("four-point (w=0.0625)")
    assert ("kept at the start" in line) == kept


def test_demo_fits_prints_its_error_and_writes_a_picture(capsys, tmp_path):
    png = tmp_path / "demo.png"
    status, out, err = cli(capsys, "demo", "--n", 16, "--samples", 200, "-o", png)
    assert status == 0, err
    assert "status     converged" in out
    size = float(re.search(r"size ([0-9.e-]+)\)", out).group(1))
    rms = float(re.search(r"rms error  ([0-9.e-]+) \(([0-9.e-]+) of the size", out).group(1))
    relative = float(re.search(r"rms error  [0-9.e-]+ \(([0-9.e-]+) of the size", out).group(1))
    # The DejaVu 'S' is about 0.91 units tall and wide; 16 control points fit it to
    # well under 1% (scipy's splprep with 16 coefficients: ~1e-2 of the size).
    assert 0.5 < size < 1.5
    assert 0 < rms < 1e-2 * size
    np.testing.assert_allclose(relative, rms / size, rtol=1e-2)
    image = matplotlib.image.imread(png)
    assert image.shape[0] > 200 and image.shape[1] > 200
    assert _pixels_vary(png)


# -------------------------------------------------------------------------- refine


STAR = js.shapes.get("star")


def _write_input(path, kind, points):
    """`points` (closed) in each input format, written without jaxsubdiv."""
    if kind == "csv":
        rows = "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in points)
        path.write_text("# star\nx,y\n" + rows)
    elif kind == "txt":
        path.write_text("".join(f"{float(x)!r}   {float(y)!r}\n" for x, y in points))
    elif kind == "npy":
        np.save(path, points)
    elif kind == "npz":
        np.savez(path, outline=points)
    elif kind == "json":
        path.write_text(json.dumps({"points": points.tolist(), "closed": True}))
    elif kind == "svg":  # y down in SVG: flip; a relative path
        start, steps = points[0] * [1, -1], np.diff(points * [1, -1], axis=0)
        lines = " ".join(f"l {float(x)!r} {float(y)!r}" for x, y in steps)
        d = f"m {float(start[0])!r},{float(start[1])!r} {lines} z"
        path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg"><path d="{d}"/></svg>')
    elif kind == "svg-polygon":
        flipped = " ".join(f"{float(x)!r},{float(-y)!r}" for x, y in points)
        path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg"><g><polygon points="{flipped}"/>'
                        "</g></svg>")


def _read_output(path):
    """The single outline of an output file, parsed without jaxsubdiv."""
    kind = path.suffix[1:]
    if kind in ("csv", "txt"):
        return _table(path)
    if kind == "npy":
        return np.load(path)
    if kind == "npz":
        return np.load(path)["points"]
    if kind == "json":
        return np.array(json.loads(path.read_text())["points"])
    (segments,) = svg_bezier_paths(path.read_text())  # straight segments: the polyline
    return np.array([s[0] for s in segments])


@pytest.mark.parametrize(
    ("kind", "output"),
    [("csv", "csv"), ("txt", "txt"), ("npy", "npy"), ("npz", "npz"), ("json", "json"),
     ("svg", "svg"), ("svg-polygon", "csv")],
)
def test_refine_reads_and_writes_every_point_format(capsys, tmp_path, kind, output):
    source = tmp_path / f"star.{kind.split('-')[0]}"
    _write_input(source, kind, STAR)
    out = tmp_path / f"refined.{output}"
    status, stdout, err = cli(capsys, "refine", source, "--scheme", "chaikin", "--levels", 2,
                              "-o", out)
    assert status == 0, err
    count = js.refined_count(len(STAR), js.Chaikin(), 2)
    assert stdout.splitlines()[0] == f"10 -> {count} points (closed)"
    np.testing.assert_allclose(_read_output(out), chaikin_python(STAR, 2, closed=True),
                               rtol=0, atol=1e-12)


def test_refine_png_silhouette(capsys, tmp_path):
    # A dark 40 x 40 square on white, rows 10-49 and columns 20-59 of a 60 x 80 image:
    # its outline (y up: pixel (r, c) is (c, 59 - r)) runs half a pixel outside them.
    image = np.ones((60, 80, 3))
    image[10:50, 20:60] = 0.0
    source = tmp_path / "square.png"
    matplotlib.image.imsave(source, image)
    out = tmp_path / "refined.npy"
    status, stdout, err = cli(capsys, "refine", source, "--scheme", "chaikin", "--levels", 1,
                              "-o", out, "--plot", tmp_path / "plot.png")
    assert status == 0, err
    before, after = map(int, re.match(r"(\d+) -> (\d+) points", stdout).groups())
    assert after == js.refined_count(before, js.Chaikin(), 1) == 2 * before
    points = np.load(out)
    assert len(points) == after
    # Chaikin keeps the middles of the straight edges: the box is the square's outline.
    np.testing.assert_allclose(points.min(axis=0), [19.5, 9.5], atol=1e-9)
    np.testing.assert_allclose(points.max(axis=0), [59.5, 49.5], atol=1e-9)
    assert _pixels_vary(tmp_path / "plot.png")


def test_refine_text_glyph_refines_its_nodes(capsys, tmp_path):
    """`refine --text o` refines the glyph's own nodes (the on-curve points of its font
    outline, read here from matplotlib's path codes): one level of the cubic B-spline
    gives the (1, 6, 1) / 8 vertex points and the edge midpoints of that polygon."""
    from matplotlib.path import Path as MplPath
    from matplotlib.textpath import TextPath

    contours = []
    for vertices, code in TextPath((0, 0), "o", size=1.0).iter_segments(
        curves=True, simplify=False
    ):
        if code == MplPath.MOVETO:
            contours.append([vertices[-2:]])
        elif code != MplPath.CLOSEPOLY:
            contours[-1].append(vertices[-2:])  # a segment's last point is on the curve
    contours = [np.array(c[:-1] if np.allclose(c[0], c[-1]) else c) for c in contours]
    out = tmp_path / "o.npz"
    status, stdout, err = cli(capsys, "refine", "--text", "o", "--font", "DejaVu Sans",
                              "--scheme", "cubic-bspline", "--levels", 1, "-o", out)
    assert status == 0, err
    assert stdout.splitlines()[:2] == [f"{len(c)} -> {2 * len(c)} points (closed)"
                                       for c in contours]
    data = np.load(out)
    for i, nodes in enumerate(contours):
        before, after = np.roll(nodes, 1, axis=0), np.roll(nodes, -1, axis=0)
        expected = np.empty((2 * len(nodes), 2))
        expected[0::2] = (before + 6 * nodes + after) / 8
        expected[1::2] = (nodes + after) / 2
        np.testing.assert_allclose(data[f"points_{i}"], expected, rtol=0, atol=1e-12)


def test_refine_file_matches_plain_python_chaikin(capsys, tmp_path):
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    source = tmp_path / "square.csv"
    source.write_text("x,y\n" + "".join(f"{x},{y}\n" for x, y in square))
    out, png = tmp_path / "out.csv", tmp_path / "plot.png"
    status, _, err = cli(capsys, "refine", source, "--scheme", "chaikin", "--levels", 3,
                         "-o", out, "--plot", png)
    assert status == 0, err
    np.testing.assert_allclose(_table(out), chaikin_python(square, 3, closed=True), atol=1e-12)
    assert _pixels_vary(png)


def test_refine_that_overflows_is_an_error_not_a_picture(capsys, tmp_path):
    # Split-and-tweak at t = -1e300 (it converges for -9 < t < 7) grows the points by
    # about 1e300 per level: inf and NaN by level 5. It printed "10 -> 320 points",
    # exit 0, and plotted NaN (found by a user try-out); now one line, status 2, naming
    # the fix, and no picture.
    png = tmp_path / "r.png"
    status, out, err = cli(capsys, "refine", "--shape", "star", "--scheme", "split-tweak",
                           "--t=-1e300", "--plot", png)
    assert status == 2 and not png.exists(), (out, err)
    assert "overflow to inf or NaN by level 5" in err and "--levels" in err
    assert "outside -9 < t < 7" in err  # the divergence warning, one line before


@pytest.mark.parametrize("arguments, words", [
    (("refine", "--shape", "star", "--levels", 26),
     ["refining 10 points by 26 levels would need about", "GiB, above the command's memory "
      "limit of 2 GiB", "--levels 21 or fewer"]),
    (("refine", "--shape", "star", "--levels", 80),
     ["more than the command's memory limit of 2 GiB", "--levels 21 or fewer"]),
    (("fit", "--shape", "star", "--samples", 3_000_000, "-q"),
     ["contour 1 of 1: fitting 3,000,000 samples with 32 control points", "--samples"]),
])
def test_too_large_for_memory_is_said_in_the_commands_terms(capsys, arguments, words):
    # The library's message names `memory_budget=` and `levels=`, which the command does
    # not take (found by a user try-out); the command names its own options. A 10-point
    # star refined 26 times is 671 million points, 10 GiB of float64 before any working
    # array.
    status, out, err = cli(capsys, *arguments)
    assert status == 2 and err.count("\n") == 1, err
    assert all(w in err for w in words) and "memory_budget" not in err and "levels=" not in err


def test_refine_builtin_shape_four_point_keeps_its_points(capsys, tmp_path):
    out = tmp_path / "star.json"
    status, _, err = cli(capsys, "refine", "--shape", "star", "--scheme", "four-point",
                         "--w", 0.1, "--levels", 3, "-o", out)
    assert status == 0, err
    points = np.array(json.loads(out.read_text())["points"])
    assert points.shape == (8 * len(STAR), 2)
    np.testing.assert_allclose(points[::8], STAR, atol=1e-12)  # interpolating scheme


# ---------------------------------------------------------------- analyze, gallery


def test_analyze_prints_closed_forms(capsys):
    status, out, _ = cli(capsys, "analyze", "--scheme", "cubic-bspline")
    assert status == 0
    assert "eigenvalues        [1, 0.5, 0.25]" in out
    assert "limit stencil      [0.166667, 0.666667, 0.166667]" in out
    assert "C^2, not C^2" not in out and "C^2, not C^3" in out
    # Corner cutting off the line s - r = 1/2 is continuous but not C1.
    status, out, _ = cli(capsys, "analyze", "--scheme", "corner-cutting", "--r", 0.3,
                         "--s", 0.7)
    assert status == 0 and "C^0, not C^1" in out


def test_gallery_writes_rows_and_an_index(capsys, tmp_path):
    # U is the paper's (four-point, Figure 5.2); the square is not, so it gets all three.
    status, out, err = cli(capsys, "gallery", "-o", tmp_path / "g", "--shapes", "U",
                           "--shapes", "square", "--levels", "0,14")
    assert status == 0, err
    names = ["U-four-point", "square-chaikin", "square-corner-cutting", "square-four-point"]
    assert sorted(p.name for p in (tmp_path / "g").iterdir()) == sorted(
        [f"{n}.png" for n in names] + ["index.md"]
    )
    for name in names:
        image = matplotlib.image.imread(tmp_path / "g" / f"{name}.png")
        assert image.shape[1] > 1.5 * image.shape[0]  # a row of two panels
        assert image[..., :3].std() > 0.05
    index = (tmp_path / "g" / "index.md").read_text()
    assert "## U, four-point (seed paper, Figure 5.2)" in index
    assert "## square, corner cutting\n" in index
    assert all(f"({n}.png)" in index for n in names)
    # Level 14 has 229,376 points for U and 65,536 for the square: more than the 50,000
    # refined outright, so drawn from limit points.
    assert index.count("level 14 (229,376 points) drawn as the exact limit curve") == 1
    assert index.count("level 14 (65,536 points) drawn as the exact limit curve") == 3
    assert "below a pixel" in index and index.count("the scheme interpolates") == 2
    assert "C^0, not C^1" in index  # corner cutting (0.3, 0.7), as jaxsubdiv.smoothness says


def test_every_subcommand_has_help(capsys):
    for command in ("refine", "fit", "analyze", "gallery", "demo"):
        status, out, _ = cli(capsys, command, "--help")
        assert status == 0 and out.startswith(f"usage: jaxsubdiv {command}")


def test_a_closed_output_pipe_stops_quietly():
    # `jaxsubdiv ... | head`: the reader goes away. Here it has gone before the command
    # starts (the pipe's reading end closed), so its first write fails, as a Unix tool
    # killed by SIGPIPE: status 141 and nothing on stderr (it was "error: [Errno 32]
    # Broken pipe", status 2).
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        done = subprocess.run([str(SCRIPT), "analyze", "--scheme", "chaikin"], stdout=write_end,
                              stderr=subprocess.PIPE, text=True, timeout=600)
    finally:
        os.close(write_end)
    assert (done.returncode, done.stderr) == (141, "")


# ------------------------------------------------------------------------- errors


def test_bad_input_is_one_line_and_status_2(capsys, tmp_path):
    files = {
        "empty.csv": "",
        "comments.csv": "# nothing here\nx,y\n",
        "three.csv": "0,0,0\n1,0,0\n1,1,0\n",
        "words.csv": "0,0\n1,zero\n1,1\n",
        "nopath.svg": '<svg xmlns="http://www.w3.org/2000/svg"><text>no shape</text></svg>',
        "notxml.svg": "<svg",
        "nopoints.json": '{"closed": true}',
        "garbage.png": "not a png",
        "binary.csv": None,
        "few.csv": "0,0\n1,0\n1,1\n0,1\n",
    }
    for name, text in files.items():
        if text is None:
            (tmp_path / name).write_bytes(b"\xff\xfe\x00\x01" * 8)
        else:
            (tmp_path / name).write_text(text)
    np.save(tmp_path / "cols.npy", np.zeros((5, 3)))
    (tmp_path / "dir.csv").mkdir()
    ok, shape = str(tmp_path / "few.csv"), ("--shape", "star")
    cases = [
        ("refine", tmp_path / "missing.csv"),
        ("fit", tmp_path / "missing.csv"),
        ("refine", tmp_path / "dir.csv"),  # unreadable: a directory
        ("refine", tmp_path / "binary.csv"),  # unreadable: not text
        ("refine", tmp_path / "empty.csv"),
        ("fit", tmp_path / "comments.csv"),
        ("refine", tmp_path / "three.csv"),  # wrong column count
        ("refine", tmp_path / "cols.npy"),
        ("refine", tmp_path / "words.csv"),  # non-numeric
        ("refine", tmp_path / "nopath.svg"),
        ("fit", tmp_path / "notxml.svg"),
        ("refine", tmp_path / "nopoints.json"),
        ("refine", tmp_path / "garbage.png"),
        ("refine", tmp_path / "outline.xyz"),  # unknown format
        ("refine", "--shape", "teapot"),
        ("refine", *shape, "--scheme", "nope"),  # unknown scheme
        ("fit", *shape, "--frobnicate"),  # unknown option
        ("fit", *shape, "--n", "many"),
        ("refine", *shape, "--scheme", "chaikin", "--w", 0.1),  # impossible combinations
        ("fit", *shape, "--scheme", "cubic-bspline", "--r", 0.2),
        ("fit", *shape, "--fit-params"),  # cubic B-spline has no parameters
        ("fit", *shape, "--boundary", "closed", "--pin-ends"),  # a closed curve has no ends
        ("fit", *shape, "--samples", 20, "--n", 16),  # more control points than samples
        ("fit", ok, *shape),  # two inputs
        ("fit",),  # no input
        ("refine", "--text", "o", "--font", "No Such Font Family"),
        ("refine", ok, "--font", "DejaVu Sans"),  # --font without --text
        ("refine", "--text", "   "),
        ("refine", ok, "--scheme", "daubechies", "--boundary", "clamped"),
        ("fit", *shape, "-o", tmp_path / "out.xyz"),
        ("fit", *shape, "-o", tmp_path / "nowhere" / "out.json"),
        ("fit", *shape, "--plot", tmp_path / "fit.doc"),
        ("fit", "--text", "o", "-o", tmp_path / "two.npy"),  # two contours, one .npy
        ("analyze", "--scheme", "four-point", "--w", "nan"),
        ("gallery", "-o", tmp_path / "g", "--shapes", "teapot"),
        ("gallery", "-o", tmp_path / "g", "--levels", "0,x"),
        ("gallery",),  # -o is required
        ("gallery", "-o", tmp_path / "g", "--max-points", -1),
        ("gallery", "-o", tmp_path / "g", "--dpi", 0),
        ("demo", "--n", 64, "--samples", 100, "-o", tmp_path / "x.png"),
        ("demo", "--text", " ", "-o", tmp_path / "x.png"),
    ]
    for args in cases:
        status, out, err = cli(capsys, *args)
        assert status == 2, (args, out, err)
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("jaxsubdiv"), (args, err)
        assert "Traceback" not in err
    # The messages say what is wrong.
    assert "no such file" in cli(capsys, "refine", tmp_path / "missing.csv")[2]
    assert "expected 2 values" in cli(capsys, "refine", tmp_path / "three.csv")[2]
    assert "--w does not apply to --scheme chaikin" in cli(
        capsys, "refine", *shape, "--scheme", "chaikin", "--w", 0.1)[2]
    assert "--n 16 is too many control points for --samples 20" in cli(
        capsys, "fit", *shape, "--samples", 20, "--n", 16)[2]


# The valid ranges as the docstrings give them (not read from the registry): any finite
# w and t (where they converge is the analysis' to say, #20), corner cutting
# 0 < r < s < 1, Lane-Riesenfeld 1 <= degree <= 55.
_OUT_OF_RANGE = [
    (("--scheme", "four-point", "--w", "inf"), "--w inf", "any finite w"),
    (("--scheme", "four-point", "--w", "nan"), "--w nan", "any finite w"),
    (("--scheme", "corner-cutting", "--r", 0), "--r 0", "0 < r < 1"),
    (("--scheme", "corner-cutting", "--s", 1), "--s 1", "0 < s < 1"),
    (("--scheme", "corner-cutting", "--r", 0.8, "--s", 0.75), "--r 0.8, --s 0.75",
     "0 < r < s < 1"),
    (("--scheme", "split-tweak", "--t", "inf"), "--t inf", "any finite t"),
    (("--scheme", "lane-riesenfeld", "--degree", 0), "--degree 0", "1 <= degree <= 55"),
    (("--scheme", "lane-riesenfeld", "--degree", 56), "--degree 56", "1 <= degree <= 55"),
]


@pytest.mark.parametrize("command", ["refine", "fit", "analyze", "gallery", "edit"])
def test_out_of_range_scheme_options_are_one_line_naming_the_option(capsys, tmp_path,
                                                                     command):
    output = tmp_path / "out"
    if command in ("refine", "fit"):
        head, cases = (command, "--shape", "star", "-o", output.with_suffix(".csv")), _OUT_OF_RANGE
    elif command == "analyze":
        head, cases = (command,), _OUT_OF_RANGE
    else:  # gallery and edit take --r --s --w (and edit --t) without --scheme
        head = (command, "-o", output) if command == "gallery" else (
            command, "--shape", "star", "--png", output.with_suffix(".png"))
        cases = [(args[2:], shown, text) for args, shown, text in _OUT_OF_RANGE
                 if args[1] in ("four-point", "corner-cutting")
                 or (command == "edit" and args[1] == "split-tweak")]
    for args, shown, text in cases:
        status, out, err = cli(capsys, *head, *args)
        assert status == 2, (args, out, err)
        (line,) = err.strip().splitlines()
        assert line.startswith(f"jaxsubdiv {command}: error: {shown}"), line
        assert text in line, line
        assert not list(tmp_path.iterdir())  # refused before any work


def test_a_divergent_parameter_refines_with_one_warning_line(capsys, tmp_path):
    """w = 0.6 is valid but outside -1/2 < w < 1/2, where four-point converges: the
    command refines and says so in one line; analyze reports the divergence."""
    status, out, err = cli(capsys, "refine", "--shape", "star", "--scheme", "four-point",
                           "--w", 0.6, "-o", tmp_path / "out.csv")
    assert status == 0, err
    (line,) = err.strip().splitlines()
    assert line.startswith("jaxsubdiv refine: warning: `FourPoint(w)` = 0.6 is outside "
                           "-1/2 < w < 1/2"), line
    status, out, err = cli(capsys, "analyze", "--scheme", "four-point", "--w", 0.6)
    assert status == 0 and "does not converge" in out, (out, err)
    status, out, err = cli(capsys, "edit", "--shape", "star", "--w", 0.6, "--png",
                           tmp_path / "e.png")
    assert status == 2 and "converges only for -1/2 < w < 1/2" in err, err


def test_bad_input_from_the_installed_script(tmp_path):
    result = run("fit", tmp_path / "missing.csv", "--n", 8)
    assert result.returncode == 2
    assert result.stderr == f"jaxsubdiv fit: error: {tmp_path / 'missing.csv'}: no such file.\n"
    assert result.stdout == ""


def test_contours_of_different_lengths_share_one_compiled_fit(capsys, tmp_path):
    """Two closed contours of 300 and 517 samples: the second reuses the first one's
    program (both padded to the longer one's bucket), so only the first line says
    "including compilation"; the fits are those of each contour alone (same errors).
    Their SVG is one shape."""
    outlines = [_circle(300).tolist(), (0.5 * _circle(517, center=(5.0, 1.0))).tolist()]
    source = tmp_path / "two.json"
    source.write_text(json.dumps({"outlines": [{"points": p, "closed": True}
                                               for p in outlines]}))
    status, out, err = cli(capsys, "fit", source, "--n", 12, "--quiet", "--svg",
                           tmp_path / "two.svg")
    assert status == 0, err
    times = re.findall(r"time +[0-9.]+ s(.*)", out)
    assert times == [" (including compilation)", ""]
    # A point list has no shapes: its closed contours are one, as a glyph and its holes.
    svg = (tmp_path / "two.svg").read_text()
    assert svg.count("<path") == 1 and 'fill-rule="evenodd"' in svg
    assert len(svg_bezier_paths(svg)) == 2 and "(exact Bezier segments, 1 shape)" in out
    # An open contour is a stroked shape of its own; the closed ones stay filled; and
    # only the SVG is grouped (a refined JSON keeps the input's no-group).
    mixed = tmp_path / "mixed.json"
    mixed.write_text(json.dumps({"outlines": [
        {"points": outlines[0], "closed": True},
        {"points": (np.array(outlines[1])[:40] + 9).tolist(), "closed": False}]}))
    for out_file in ("mixed.svg", "mixed-out.json"):
        status, _, err = cli(capsys, "refine", mixed, "--levels", 1, "-o", tmp_path / out_file)
        assert status == 0, err
    paths = re.findall(r"<path [^>]*>", (tmp_path / "mixed.svg").read_text())
    assert len(paths) == 2 and "evenodd" in paths[0] and 'fill="none"' in paths[1]
    assert "group" not in (tmp_path / "mixed-out.json").read_text()
    rms = lambda text: re.findall(r"rms error  (\S+)", text)
    for k, points in enumerate(outlines):
        single = tmp_path / f"{k}.csv"
        single.write_text("".join(f"{x!r},{y!r}\n" for x, y in points))
        status, alone, err = cli(capsys, "fit", single, "--n", 12, "--quiet")
        assert status == 0, err
        assert rms(alone) == [rms(out)[k]]


def test_an_output_never_replaces_the_input_or_another_output(capsys, tmp_path):
    """`-o` equal to the input (also by another spelling of its path), or two outputs
    to one file, are refused before any work and leave every file as it was; `--force`
    allows them."""
    source = tmp_path / "in.csv"
    source.write_text("".join(f"{x}, {y}\n" for x, y in _circle(12)))
    before = source.read_text()
    other = tmp_path / "sub" / ".." / "in.csv"
    (tmp_path / "sub").mkdir()
    two = tmp_path / "c-2.json"
    two.write_text(json.dumps({"outlines": [_circle(12).tolist(), _circle(12, 1.0).tolist()]}))
    refused = [
        (("refine", source, "-o", source), "-o", "is the input file"),
        (("refine", source, "-o", other), "-o", "is the input file"),
        (("fit", source, "--n", 4, "-o", source), "-o", "is the input file"),
        (("fit", source, "--n", 4, "-o", tmp_path / "c.svg", "--svg", tmp_path / "c.svg"),
         "-o and --svg", "both write"),
        (("refine", source, "-o", tmp_path / "r.svg", "--plot", tmp_path / "r.svg"),
         "-o and --plot", "both write"),
        # Two contours: -o numbers its JSON files c-1.json, c-2.json, and c-2.json is
        # the input.
        (("fit", two, "--n", 4, "-o", tmp_path / "c.json"), "-o", "is the input file"),
    ]
    for args, options, words in refused:
        status, out, err = cli(capsys, *args)
        assert status == 2 and options in err and words in err and "--force" in err, (args, err)
        assert len(err.strip().splitlines()) == 1 and out == ""
    assert source.read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c-2.json", "in.csv", "sub"]
    status, out, err = cli(capsys, "refine", source, "--levels", 1, "-o", source, "--force")
    assert status == 0, err
    assert len(_table(source)) == 24  # 12 points, one cubic B-spline level


def test_an_input_without_contours_is_an_error(capsys, tmp_path, monkeypatch):
    import jaxsubdiv.io

    source = tmp_path / "in.csv"
    source.write_text("0, 0\n1, 0\n1, 1\n")
    # Whatever a reader returns: the command itself refuses an empty list.
    monkeypatch.setattr(jaxsubdiv.io, "read_outlines", lambda *a, **k: [])
    for command in ("refine", "fit"):
        status, out, err = cli(capsys, command, source)
        assert status == 2 and "no contours" in err and str(source) in err, err


def test_a_defect_is_one_line_status_3_and_the_traceback_on_request(capsys, tmp_path, monkeypatch):
    import jaxsubdiv.io

    def broken(*args, **kwargs):
        raise KeyError("a key nobody expected")

    monkeypatch.setattr(jaxsubdiv.io, "read_outlines", broken)
    source = tmp_path / "in.csv"
    source.write_text("0, 0\n1, 0\n1, 1\n")
    status, out, err = cli(capsys, "refine", source)
    assert status == 3 and len(err.strip().splitlines()) == 1
    assert "internal error (KeyError" in err and "bug" in err and "JAXSUBDIV_TRACEBACK" in err
    for error, words in [(MemoryError(), "not enough memory"),
                         (RecursionError("deep"), "too deeply nested")]:
        monkeypatch.setattr(jaxsubdiv.io, "read_outlines",
                            lambda *a, error=error, **k: (_ for _ in ()).throw(error))
        status, out, err = cli(capsys, "refine", source)
        assert status == 2 and words in err and len(err.strip().splitlines()) == 1, err
    monkeypatch.setattr(jaxsubdiv.io, "read_outlines", broken)
    monkeypatch.setenv("JAXSUBDIV_TRACEBACK", "1")
    with pytest.raises(KeyError):
        main(["--no-compilation-cache", "refine", str(source)])


@pytest.mark.parametrize("scale", [1e300, 1e-300])
def test_fit_at_extreme_scales_prints_true_figures(capsys, tmp_path, scale):
    """A circle of radius 2e300 or 2e-300 (once: "status converged, rms error nan", and
    a ZeroDivisionError): the same relative errors as at radius 2, in range."""
    source = tmp_path / "circle.csv"
    source.write_text("".join(f"{float(x)!r}, {float(y)!r}\n" for x, y in scale * _circle(517)))
    status, out, err = cli(capsys, "fit", source, "--n", 12, "--quiet")
    assert status == 0, err
    assert "status     converged" in out
    size = float(re.search(r"size (\S+)", out).group(1))
    np.testing.assert_allclose(size / scale, 4 * np.sqrt(2), rtol=1e-2)  # 3 digits
    absolute, relative = re.search(r"rms error  (\S+) \((\S+) of the size", out).groups()
    # A circle is not a cubic B-spline: 12 control points leave ~1e-4 of the radius.
    assert 0 < float(relative) < 1e-3
    np.testing.assert_allclose(float(absolute) / scale, float(relative) * size / scale, rtol=1e-2)


def test_every_hostile_file_is_one_line_through_the_command(capsys, tmp_path):
    """Every hostile file of `test_io.HOSTILE` (numbers past float64, nesting past the
    recursion limit, corrupt or bomb archives, headers that lie, huge images, ...),
    given to the command: status 2, one line naming the file and the problem, never a
    traceback."""
    from test_io import HOSTILE

    for name, content, words in HOSTILE:
        path = tmp_path / name
        path.write_bytes(content() if callable(content) else content)
        status, out, err = cli(capsys, "refine", path, "--levels", 0)
        lines = err.strip().splitlines()
        assert status == 2 and len(lines) == 1 and "Traceback" not in err, (name, err)
        assert lines[0].startswith(f"jaxsubdiv refine: error: {path}"), (name, err)
        for word in [words] if isinstance(words, str) else words:
            assert word in lines[0], (name, word, err)


def test_fit_gives_small_contours_fewer_control_points(capsys, tmp_path):
    """A file of a small circle of 30 points and a triangle of 3 (a hole and a speck of
    an icon). With --n 20 (40 unknowns) the circle gets 14 control points, the largest
    count of the tolerance search's ladder (4, 5, 6, 7, 8, 10, 12, 14, 16, 20, ...) its
    30 samples determine, and the triangle, too small for the fewest (4 points, 8
    unknowns), gets 5 more points on its polyline, its own kept; the command used to
    fail for the whole file. (Contours with enough samples keep --n: every other fit test.)"""
    s = 2 * np.pi * np.arange(30) / 30
    small = np.stack([3 + 0.2 * np.cos(s), 0.2 * np.sin(s)], 1)
    triangle = np.array([[5.0, 0.0], [5.3, 0.0], [5.0, 0.3]])
    blocks = ["\n".join(f"{float(x)!r},{float(y)!r}" for x, y in c) for c in (small, triangle)]
    (tmp_path / "two.csv").write_text("\n\n".join(blocks) + "\n")
    status, out, err = cli(capsys, "fit", tmp_path / "two.csv", "--n", 20, "--corners",
                           "none", "-q", "-o", tmp_path / "fit.json")
    assert status == 0, err
    assert "14 control points, not 20: the contour's 30 samples determine at most 15" in out
    assert "5 points added along its polyline (its 3 kept)" in out
    assert "lie on one line" not in out  # a triangle encloses something
    saved = [js.io.read_result_json(tmp_path / f"fit-{i}.json") for i in (1, 2)]
    assert [len(r.control_points) for r in saved] == [14, 4]
    assert [r.info["samples"] for r in saved] == [30, 8]
    # The circle is fitted as well as its 30 samples allow (scipy's B-spline).
    curve = periodic_bspline(saved[0].control_points, 3)(np.linspace(0, 14, 1401))
    radius = np.hypot(curve[:, 0] - 3, curve[:, 1])
    assert np.abs(radius - 0.2).max() < 0.2 * 1e-3


def test_fit_of_a_closed_contour_on_one_line_says_to_fit_a_stroke(capsys, tmp_path):
    """A CSV of two points is a closed contour by default: the fit is a thin loop around
    the segment, which encloses nothing; the command says so and how to fit a stroke."""
    (tmp_path / "segment.csv").write_text("0,0\n1,0.5\n")
    status, out, err = cli(capsys, "fit", tmp_path / "segment.csv", "--n", 4, "--corners",
                           "none", "-q", "-o", tmp_path / "fit.json")
    assert status in (0, 1), err
    assert ("note       4 control points; 6 points added along its polyline (its 2 kept), "
            "as many as the unknowns; its points lie on one line, so a closed curve through "
            "them encloses nothing; for a stroke, use --boundary open") in out


def test_a_contour_of_too_few_points_keeps_them_and_its_error_is_honest(capsys, tmp_path):
    """A triangle of 3 points (fewer than 4 control points' 8 unknowns) gets points added
    along its edges with its vertices kept, so the fit of its corners is charged against
    the triangle the user gave: the saved creased polygon's curve (scipy's B-spline, the
    creases as tripled control points) passes within 1e-6 of the size of all 3 vertices
    and the reported max error is below 1e-5 of the size. (Resampled by arc length alone,
    the 8 points cut the corners, and the exact fit reported 9.9e-2 of the size.)"""
    triangle = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    (tmp_path / "three.csv").write_text("0,0\n1,0\n1,1\n")
    status, out, err = cli(capsys, "fit", tmp_path / "three.csv", "-q", "-o", tmp_path / "t.json")
    assert status == 0, err
    assert "5 points added along its polyline (its 3 kept)" in out
    relative = float(re.search(r"max error +\S+ \((\S+) of the size", out).group(1))
    assert relative < 1e-5, out
    result = js.io.read_result_json(tmp_path / "t.json")
    curve = np.asarray(js.limit_curve(result.control_points, js.CubicBSpline(), 8,
                                      creases=list(result.creases)))
    gaps = np.linalg.norm(curve[None, :, :] - triangle[:, None, :], axis=2).min(axis=1)
    assert gaps.max() < 1e-6 * np.sqrt(2), gaps


def test_fit_pads_contours_of_similar_lengths_together():
    """The contours of a file are padded in groups, from the longest down: each group
    the lengths above half its longest, padded to that (a photo's contours of 214
    samples were padded to its longest, 9,812, and the command ran for half an hour)."""
    from jaxsubdiv._cli import _padded_lengths

    lengths = [9812, 5000, 4906, 214, 300, 100, 151]
    assert _padded_lengths(lengths) == [9812, 9812, 4906, 300, 300, 100, 300]
    assert _padded_lengths([400, 400, 400]) == [400, 400, 400]


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="Linux /proc only")
def test_fit_frees_compiled_programs_when_memory_mappings_crowd(monkeypatch):
    """The command clears JAX's caches before a contour once the process's memory
    mappings pass a share of vm.max_map_count: not at 100% of it, at once at 0%. (The
    clearing itself is recorded, not done: the other tests' programs stay.)"""
    import jax

    from jaxsubdiv._cli import _free_programs_if_crowded

    cleared = []
    monkeypatch.setattr(jax, "clear_caches", lambda: cleared.append(True))
    assert not _free_programs_if_crowded(1.0) and not cleared
    assert _free_programs_if_crowded(0.0) and cleared == [True]


def test_fit_with_more_corners_than_control_points_is_smooth(capsys, tmp_path):
    """A star has 10 corners; with --n 8 creasing every control point would make an
    octagon through 8 of its tips, so the fit is smooth and says why."""
    status, out, err = cli(capsys, "fit", "--shape", "star", "--n", 8, "-q",
                           "-o", tmp_path / "star.json")
    assert status == 0, err
    assert "10 corners found, more than the 8 control points: fitted without corners" in out
    assert "corners    " not in out
    assert len(js.io.read_result_json(tmp_path / "star.json").creases) == 0


def test_fit_png_finds_a_traced_pentagons_corners_in_pixels(capsys, tmp_path):
    """A regular pentagon of radius 40 px (its corners turn 72 degrees), rotated 0.3
    rad, as a bitmap: a pixel is black when its centre is inside (matplotlib's
    point-in-polygon test). Measured over 3 sample spacings its staircase hides 3 of
    the corners; measured in pixels (`find_corners(pixel=1)`, which the command uses
    for a PNG) all five are creases, each within 1.5 px of its vertex (the traced
    contour cuts a corner by about half a pixel)."""
    from matplotlib.path import Path as PolygonPath

    size, angle = 100, 0.3 + 2 * np.pi * np.arange(5) / 5
    vertices = 50 + 40 * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    rows, columns = np.mgrid[:size, :size]
    # read_image's coordinates: pixel (r, c) is the point (c, size - 1 - r).
    centres = np.stack([columns.ravel(), size - 1 - rows.ravel()], axis=1)
    inside = PolygonPath(vertices).contains_points(centres).reshape(size, size)
    source = tmp_path / "pentagon.png"
    matplotlib.image.imsave(source, np.where(inside, 0.0, 1.0), cmap="gray", vmin=0, vmax=1)
    contour = js.io.read_image(source)[0].points
    assert len(fitting.find_corners(contour)) < 5  # what the sample-spacing default sees
    status, out, err = cli(capsys, "fit", source, "--n", 10, "-q", "-o", tmp_path / "p.json")
    assert status == 0, err
    assert "corners    5" in out
    saved = js.io.read_result_json(tmp_path / "p.json")
    creased = saved.control_points[np.asarray(saved.creases)]
    gaps = np.linalg.norm(creased[:, None] - vertices[None], axis=-1)
    assert gaps.min(axis=0).max() < 1.5 and len(set(gaps.argmin(axis=0))) == 5


def test_fit_tolerance_chooses_a_stars_ten_vertices(capsys, tmp_path):
    # A five-point star's outline is exactly the creased cubic B-spline on its 10
    # vertices; with fewer control points some corner is rounded, far beyond 1e-3.
    status, out, err = cli(capsys, "fit", "--shape", "star", "--tolerance", "1e-3", "-q",
                           "-o", tmp_path / "star.json")
    assert status == 0, err
    assert "control    10 points" in out and "corners    10" in out
    saved = js.io.read_result_json(tmp_path / "star.json")
    angle = np.pi / 2 + np.arange(10) * np.pi / 5
    radius = np.where(np.arange(10) % 2 == 0, 1.0, 0.45)
    vertices = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    gaps = np.linalg.norm(saved.control_points[:, None] - vertices[None], axis=-1)
    assert gaps.min(axis=1).max() < 1e-6 and len(set(gaps.argmin(axis=1))) == 10
    assert sorted(saved.creases) == list(range(10))


@pytest.mark.parametrize("args,match", [
    (("--n", "8", "--tolerance", "0.1"), "--n and --tolerance"),
    (("--tolerance", "0"), "--tolerance must be a number > 0"),
    (("--tolerance", "nan"), "--tolerance must be a number > 0"),
])
def test_fit_tolerance_bad_arguments(capsys, args, match):
    status, out, err = cli(capsys, "fit", "--shape", "star", *args)
    assert status == 2 and match in err and "Traceback" not in err


def test_fit_tolerance_not_reached_exits_1_and_says_why(capsys, tmp_path):
    # 40 noisy samples of a circle: counts up to 10 (a quarter of them), none within 1e-6.
    rng = np.random.default_rng(1)
    t = 2 * np.pi * np.arange(40) / 40
    points = np.stack([np.cos(t), np.sin(t)], 1) + 0.01 * rng.standard_normal((40, 2))
    np.savetxt(tmp_path / "noisy.csv", points, delimiter=",")
    status, out, err = cli(capsys, "fit", tmp_path / "noisy.csv", "--tolerance", "1e-6", "-q",
                           "--corners", "none")
    assert status == 1
    assert "control    10 points" in out
    assert "no count of control points tried fitted within --tolerance 1e-06" in err
    assert "n_max=10" in err  # why: a quarter of the 40 samples
    assert "Traceback" not in err
