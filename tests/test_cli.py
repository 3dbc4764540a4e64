"""The `jaxsubdiv` command, driven in a subprocess."""

import re
import subprocess
import sys

import matplotlib.image
import numpy as np


def run(*args, timeout=600):
    return subprocess.run(
        [sys.executable, "-m", "jaxsubdiv._cli", *args],
        capture_output=True, text=True, timeout=timeout,
    )


def test_demo_fits_prints_its_error_and_writes_a_picture(tmp_path):
    png = tmp_path / "demo.png"
    out = run("demo", "--n", "16", "--samples", "200", "-o", str(png))
    assert out.returncode == 0, out.stderr
    assert "status     converged" in out.stdout
    size = float(re.search(r"size ([0-9.e-]+)\)", out.stdout).group(1))
    rms = float(re.search(r"rms error  ([0-9.e-]+) \(([0-9.e-]+) of the size", out.stdout).group(1))
    relative = float(re.search(r"rms error  [0-9.e-]+ \(([0-9.e-]+) of the size", out.stdout).group(1))
    # The DejaVu 'S' is about 0.91 units tall and wide; 16 control points fit it to
    # well under 1% (scipy's splprep with 16 coefficients: ~1e-2 of the size).
    assert 0.5 < size < 1.5
    assert 0 < rms < 1e-2 * size
    np.testing.assert_allclose(relative, rms / size, rtol=1e-2)
    image = matplotlib.image.imread(png)
    assert image.shape[0] > 200 and image.shape[1] > 200
    assert image[..., :3].std() > 0.05  # not blank


def test_bad_arguments_give_one_line_and_status_2(tmp_path):
    out = run("demo", "--n", "64", "--samples", "100", "-o", str(tmp_path / "x.png"))
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "--samples" in lines[0]
    out = run("demo", "--text", " ", "-o", str(tmp_path / "x.png"))
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1


def _csv_points(path):
    lines = path.read_text().splitlines()
    rows = [line for line in lines if line.strip() and not line.startswith("#")]
    return np.array([[float(v) for v in line.split(",")] for line in rows])


def test_refine_file_matches_plain_python_chaikin(tmp_path):
    from helpers import chaikin_python

    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    source = tmp_path / "square.csv"
    source.write_text("x,y\n" + "".join(f"{x},{y}\n" for x, y in square))
    out, png = tmp_path / "out.csv", tmp_path / "plot.png"
    result = run("refine", str(source), "--scheme", "chaikin", "--levels", "3",
                 "-o", str(out), "--plot", str(png))
    assert result.returncode == 0, result.stderr
    np.testing.assert_allclose(_csv_points(out), chaikin_python(square, 3, closed=True), atol=1e-12)
    assert matplotlib.image.imread(png)[..., :3].std() > 0.05


def test_refine_builtin_shape_four_point_keeps_its_points(tmp_path):
    import json

    import jaxsubdiv as js

    out = tmp_path / "star.json"
    result = run("refine", "--shape", "star", "--scheme", "four-point", "--w", "0.1",
                 "--levels", "3", "-o", str(out))
    assert result.returncode == 0, result.stderr
    points = np.array(json.loads(out.read_text())["points"])
    star = js.shapes.get("star")
    assert points.shape == (8 * len(star), 2)
    np.testing.assert_allclose(points[::8], star, atol=1e-12)  # interpolating scheme


def test_analyze_prints_closed_forms():
    result = run("analyze", "--scheme", "cubic-bspline")
    assert result.returncode == 0, result.stderr
    assert "eigenvalues        [1, 0.5, 0.25]" in result.stdout
    assert "limit stencil      [0.166667, 0.666667, 0.166667]" in result.stdout
    assert "C^2, not C^3" in result.stdout
    # Corner cutting off the line s - r = 1/2 is continuous but not C1.
    result = run("analyze", "--scheme", "corner-cutting", "--r", "0.3", "--s", "0.7")
    assert result.returncode == 0 and "C^0, not C^1" in result.stdout


def test_command_errors_are_one_line_with_status_2(tmp_path):
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("1,2\n3,x\n")
    clamped = tmp_path / "ok.csv"
    clamped.write_text("0,0\n1,0\n1,1\n0,1\n")
    cases = [
        ("refine", str(tmp_path / "missing.csv")),
        ("refine", str(bad_csv)),
        ("refine", "--shape", "teapot"),
        ("refine", "--shape", "star", "--scheme", "nope"),
        ("refine", "--shape", "star", "--scheme", "chaikin", "--w", "0.1"),
        ("refine", str(clamped), "--scheme", "daubechies", "--boundary", "clamped"),
        ("refine",),
        ("analyze", "--scheme", "four-point", "--w", "0.3"),
    ]
    for args in cases:
        result = run(*args)
        assert result.returncode == 2, (args, result.stdout, result.stderr)
        assert len(result.stderr.strip().splitlines()) == 1, (args, result.stderr)
