"""Real files through the command, read back, against geometry known from elsewhere
(issue #18): an icon with transforms and an invisible background, a glyph with holes, a
silhouette with holes (a PNG), and an open stroke.

Each case runs `jaxsubdiv fit INPUT --svg out.svg -o out.json` as a user would, reads the
SVG it wrote, maps its exact Bezier subpaths through the written transform onto the
input's page, and measures them against the input's true outline, computed here without
jaxsubdiv: from the icon's path data (its absolute commands and `transform` matrix, SVG
1.1 sections 7.4 and 8.3), from matplotlib's font outline, from matplotlib's
transform of the drawn data. The SVG must be the shape in the input's coordinate system
(page attributes copied, one `<path>` per input shape, holes as even-odd subpaths), and
its distance to the true outline must be what the fit reported, up to the sampling
of the outline (and, for the image, half a pixel).

The inputs are matplotlib's own icon, its DejaVu Sans font, and drawings made by
matplotlib's SVG and PNG writers here: files nobody here wrote by hand.
"""

import json
import re
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from helpers import (
    apply_affine,
    bezier_evaluate,
    polyline_distances,
    svg_bezier_paths,
    svg_transform_matrix,
)

from jaxsubdiv._cli import main


matplotlib.use("Agg")


def _path_segments(d: str) -> list[list[np.ndarray]]:
    """The subpaths of path data with M, L, C, c and z (what the icon uses), each a list
    of Bezier segments: written here from SVG 1.1 section 8.3, for this test alone."""
    tokens = re.findall(r"[MLCcz]|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", d)
    subpaths, i, command, current, start = [], 0, None, None, None
    while i < len(tokens):
        if tokens[i] in "MLCcz":
            command = tokens[i]
            i += 1
            if command == "z":
                if not np.array_equal(current, start):
                    subpaths[-1].append(np.array([current, start]))
                current = start
            continue
        count = 3 if command in "Cc" else 1
        points = np.array([float(v) for v in tokens[i : i + 2 * count]]).reshape(count, 2)
        i += 2 * count
        if command == "c":
            points = points + current
        if command == "M":
            current = start = points[0]
            subpaths.append([])
            command = "L"
            continue
        subpaths[-1].append(np.vstack([current, points]))
        current = points[-1]
    return subpaths


def _dense(segments, per_segment=256) -> np.ndarray:
    u = np.linspace(0, 1, per_segment, endpoint=False)
    return np.concatenate([bezier_evaluate(s, u) for s in segments])


def _hausdorff(a: np.ndarray, b: np.ndarray, closed: bool) -> float:
    """Two-sided largest distance between dense points of two curves, each measured to
    the other's polyline (so the points' spacing does not count, only the chords')."""
    return max(polyline_distances(a, b, closed).max(), polyline_distances(b, a, closed).max())


# --- the inputs ----------------------------------------------------------------------


def _icon(tmp_path):
    """matplotlib's hand.svg: an Illustrator/Sodipodi icon, two paths (a disc in
    relative cubics, a plus in absolute ones), each under its own `transform` matrix."""
    icon = Path(matplotlib.get_data_path()) / "images" / "hand.svg"
    text = icon.read_text()
    truth = []
    for element in re.findall(r"<path\s[^>]*>", text):
        d = re.search(r'\sd="([^"]*)"', element).group(1)
        matrix = svg_transform_matrix(re.search(r'transform="([^"]*)"', element).group(1))
        truth += [apply_affine(matrix, _dense(s)) for s in _path_segments(d)]
    return icon, truth, 2, 2e-4


def _glyph_segments(char: str):
    """The outline of `char` in DejaVu Sans at size 1, y up, from matplotlib's path codes."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.path import Path as MplPath
    from matplotlib.textpath import TextPath

    glyph = TextPath((0, 0), char, size=1.0, prop=FontProperties(family="DejaVu Sans"))
    contours, current, start = [], None, None
    for vertices, code in glyph.iter_segments(curves=True, simplify=False):
        points = np.asarray(vertices, dtype=float).reshape(-1, 2)
        if code == MplPath.MOVETO:
            current = start = points[0]
            contours.append([])
            continue
        if code == MplPath.CLOSEPOLY:
            points = start[None]
        if not np.array_equal(current, points[-1]) or len(points) > 1:
            contours[-1].append(np.vstack([current, points]))
        current = points[-1]
    return contours


def _text(tmp_path):
    """'B' of DejaVu Sans: an outer contour and two holes. The command's page is fitted
    around the glyph with y flipped (scale(1,-1)): truth flipped to the page."""
    flip = np.diag([1.0, -1.0, 1.0])
    truth = [apply_affine(flip, _dense(c)) for c in _glyph_segments("B")]
    return ("--text", "B", "--font", "DejaVu Sans"), truth, 1, 2e-4


def _silhouette(tmp_path):
    """'B' filled black by matplotlib's PNG writer (antialiased) at 240 x 300 pixels.
    Its true outline on the image's pixel page: matplotlib's display coordinates
    (pixels, y up from the bottom edge) with y turned down."""
    from matplotlib.figure import Figure
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath

    width, height = 240, 300
    figure = Figure(figsize=(width / 100, height / 100), dpi=100)
    ax = figure.add_axes([0, 0, 1, 1])
    ax.set_xlim(0.0, 0.8)
    ax.set_ylim(-0.15, 0.85)
    ax.axis("off")
    contours = _glyph_segments("B")
    vertices = np.concatenate([_dense(c, 256) for c in contours])
    codes = np.concatenate([[MplPath.MOVETO] + [MplPath.LINETO] * (256 * len(c) - 1)
                            for c in contours])
    ax.add_patch(PathPatch(MplPath(vertices, codes), facecolor="black", edgecolor="none"))
    source = tmp_path / "B.png"
    figure.savefig(source, dpi=100, facecolor="white")
    truth = []
    for c in contours:
        display = ax.transData.transform(_dense(c))
        truth.append(np.stack([display[:, 0], height - display[:, 1]], axis=1))
    return source, truth, 1, 0.5  # half a pixel: the antialiased edge, thresholded


def _stroke(tmp_path):
    """An open curve plotted by matplotlib's SVG writer (stroke only, under a clip path,
    a `<style>` sheet in the file, a transparent background). Truth: the plotted data
    through matplotlib's own data-to-display transform (1 pt per pixel at 72 dpi),
    y turned down on the 216 pt page."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(4, 3), dpi=72)
    ax = figure.add_axes([0.1, 0.1, 0.8, 0.8])
    ax.set_xlim(0, 2 * np.pi)
    ax.set_ylim(-1.4, 1.4)
    ax.axis("off")
    x = np.linspace(0, 2 * np.pi, 2000)
    data = np.stack([x, np.sin(x) + 0.3 * np.cos(3 * x)], axis=1)
    with matplotlib.rc_context({"path.simplify": False}):
        ax.plot(*data.T)
        source = tmp_path / "stroke.svg"
        figure.savefig(source, transparent=True)
    display = ax.transData.transform(data)
    return source, [np.stack([display[:, 0], 216 - display[:, 1]], axis=1)], 1, 2e-4


CASES = {"icon": _icon, "text": _text, "silhouette": _silhouette, "stroke": _stroke}


@pytest.mark.parametrize("case", list(CASES))
def test_a_real_file_comes_out_as_its_shape(case, tmp_path, capsys):
    source, truth, shapes, slack = CASES[case](tmp_path)
    svg, result = tmp_path / "out.svg", tmp_path / "out.json"
    inputs = list(source) if isinstance(source, tuple) else [str(source)]
    # Without the persistent compilation cache, which would stay on for the process.
    status = main(["--no-compilation-cache", "fit", *inputs, "--quiet", "--svg", str(svg),
                   "-o", str(result)])
    out, err = capsys.readouterr()
    assert status == 0, out + err
    text = svg.read_text()
    if not isinstance(source, tuple):  # the input's page, kept
        page = re.search(r"<svg ([^>]*)>", text).group(1)
        if source.suffix == ".png":
            assert 'width="240" height="300" viewBox="0 0 240 300"' in page
        else:
            original = re.search(r"<svg\s([^>]*)>", source.read_text()).group(1)
            for name in ("width", "height", "viewBox"):
                value = re.search(rf'\s{name}="([^"]*)"', " " + original).group(1)
                assert f'{name}="{value}"' in page
    elements = re.findall(r"<path [^>]*>", text)
    assert len(elements) == shapes
    closed = case != "stroke"
    assert all(('fill-rule="evenodd"' in e) == closed for e in elements)
    matrix = svg_transform_matrix(re.search(r'<g transform="([^"]*)"', text).group(1))
    subpaths = [apply_affine(matrix, _dense(s)) for s in svg_bezier_paths(text)]
    assert len(subpaths) == len(truth)
    size = max(np.linalg.norm(np.ptp(t, axis=0)) for t in truth)
    reports = [tmp_path / "out.json"] if len(truth) == 1 else [
        tmp_path / f"out-{i + 1}.json" for i in range(len(truth))]
    # Each subpath's true contour: the nearest by centroid (a PNG's contours come outer
    # first, then holes), one each.
    nearest = [int(np.argmin([np.linalg.norm(t.mean(0) - f.mean(0)) for t in truth]))
               for f in subpaths]
    assert sorted(nearest) == list(range(len(truth)))
    for i, (fitted, report, k) in enumerate(zip(subpaths, reports, nearest)):
        true = truth[k]
        errors = json.loads(report.read_text())["errors"]
        distance = _hausdorff(fitted, true, closed)
        # The fit's own two-sided maximum is to its samples, on the true outline: the
        # curve in the file is as far from the true outline as it said, up to the
        # chords between samples (2e-4 of the size) or, for the image, half a pixel.
        scale = 1.0 if case == "silhouette" else size
        print(f"{case} contour {i + 1}: {distance:.4g} from the truth, reported "
              f"{errors['max_error']:.4g}, size {size:.4g}")
        assert distance <= errors["max_error"] + slack * scale, (distance, errors)
