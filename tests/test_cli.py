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
