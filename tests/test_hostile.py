"""Hostile and careless input, generated (hypothesis): every call gives a result that
keeps the documented contract, or one clear error; never a raw exception of another
type, a hang, or NaN reported as success.

The contracts checked, by area:

- readers (`jaxsubdiv.io.read_outlines`): outlines of finite float64 `(m, 2)` points, or
  an `OutlineError` whose one-line message begins with the file's name; for mutated
  valid files and for random bytes in every format;
- the command (`jaxsubdiv refine` on such files): status 0, or 2 with one line on
  stderr and no traceback;
- `refine`: an array of the documented shape, finite for finite points, or a
  `ValueError`/`TypeError` naming the argument; over shapes, dtypes, scales, levels,
  boundaries and scheme parameters;
- `fitting.fit`: converged with finite errors (relative to the outline's size, at
  every scale), or not converged and saying so, or a clear error; never NaN with
  success.

Examples are few and shapes are drawn from short lists, so the battery compiles a
handful of programs and stays fast; `derandomize=True` makes every run check the same
examples (a failure found once is found again).
"""

import io
import json
import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import fitting
import jaxsubdiv as js
from jaxsubdiv._cli import main


BATTERY = settings(
    max_examples=40, deadline=None, derandomize=True, database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


# ------------------------------------------------------------------------------ files


def _png(width, height, rows=None):
    """A grey PNG written here (zlib and the chunk layout of the PNG specification)."""
    import struct
    import zlib

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    if rows is None:
        rows = np.zeros((height, width), np.uint8)
    raw = b"".join(b"\x00" + bytes(row) for row in rows)
    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def _valid_files():
    """One small valid file per format: the seeds that mutations start from."""
    angle = 2 * np.pi * np.arange(12) / 12
    points = np.stack([np.cos(angle), np.sin(angle)], 1)
    npy, npz = io.BytesIO(), io.BytesIO()
    np.save(npy, points)
    np.savez(npz, points=points, closed=np.array([True]))
    disk = np.zeros((24, 24), np.uint8)
    yy, xx = np.mgrid[:24, :24]
    disk[(yy - 11.5) ** 2 + (xx - 11.5) ** 2 < 64] = 255
    return {
        "csv": "".join(f"{x}, {y}\n" for x, y in points).encode(),
        "txt": "".join(f"{x} {y}\n" for x, y in points).encode(),
        "json": json.dumps({"points": points.tolist(), "closed": True}).encode(),
        "npy": npy.getvalue(),
        "npz": npz.getvalue(),
        "svg": b'<svg xmlns="http://www.w3.org/2000/svg"><path d="M 0 0 C 10 0 10 10 0 10 '
               b'L -5 5 Z"/><g transform="scale(2)"><polygon points="1,1 3,1 2,4"/></g></svg>',
        "png": _png(24, 24, disk),
    }


VALID = _valid_files()


def _mutated(data: bytes, draw_ops) -> bytes:
    data = bytearray(data)
    for op, where, value in draw_ops:
        if not data:
            break
        i = where % len(data)
        if op == "flip":
            data[i] ^= value % 256 or 1
        elif op == "cut":
            del data[i:]
        elif op == "insert":
            data[i:i] = bytes([value % 256]) * (1 + value % 7)
        else:  # "repeat": a slice copied many times (nesting, long numbers)
            data[i:i] = bytes(data[i:i + 1 + value % 8]) * (1 + value % 500)
    return bytes(data)


mutation = st.lists(
    st.tuples(st.sampled_from(["flip", "cut", "insert", "repeat"]),
              st.integers(0, 10**6), st.integers(0, 10**4)),
    min_size=1, max_size=4,
)


def _check_read(path):
    try:
        outlines = js.io.read_outlines(path)
    except js.io.OutlineError as e:
        message = str(e)
        assert "\n" not in message and message.startswith(str(path)), message
        return None
    assert isinstance(outlines, list) and outlines  # no contours is an OutlineError
    for outline in outlines:
        points = outline.points
        assert points.dtype == np.float64 and points.ndim == 2 and points.shape[1] == 2
        assert np.all(np.isfinite(points))
    return outlines


@pytest.mark.parametrize("kind", sorted(VALID))
@BATTERY
@given(ops=mutation)
def test_mutated_files_read_or_fail_clearly(tmp_path, kind, ops):
    path = tmp_path / f"mutated.{kind}"
    path.write_bytes(_mutated(VALID[kind], ops))
    _check_read(path)


@pytest.mark.parametrize("kind", sorted(VALID))
@BATTERY
@given(data=st.binary(max_size=600))
def test_random_bytes_read_or_fail_clearly(tmp_path, kind, data):
    path = tmp_path / f"random.{kind}"
    path.write_bytes(data)
    _check_read(path)


def test_the_valid_seeds_read():
    # The mutations start from files that do read (so they explore near valid input).
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        for kind, data in VALID.items():
            path = Path(folder) / f"seed.{kind}"
            path.write_bytes(data)
            assert _check_read(path), kind


@pytest.mark.parametrize("kind", ["csv", "json", "svg", "npz"])
@settings(BATTERY, max_examples=10)
@given(ops=mutation)
def test_the_command_answers_mutated_files_in_one_line(tmp_path, capsys, kind, ops):
    path = tmp_path / f"mutated.{kind}"
    path.write_bytes(_mutated(VALID[kind], ops))
    # --levels 0: the refined polygon is the input; its program is tiny.
    try:
        status = main(["--no-compilation-cache", "refine", str(path), "--levels", "0"])
    except SystemExit as e:
        status = e.code
    err = capsys.readouterr().err
    assert status in (0, 2), err
    assert "Traceback" not in err
    if status == 2:
        assert len(err.strip().splitlines()) == 1 and err.startswith("jaxsubdiv refine:"), err


# ------------------------------------------------------------------------------- fit


def _blob(m, seed):
    rng = np.random.default_rng(seed)
    theta = np.sort(rng.uniform(0, 2 * np.pi, m))
    radius = 1 + 0.2 * np.sin(3 * theta + rng.uniform(0, 6)) + 0.1 * np.cos(5 * theta)
    return np.stack([radius * np.cos(theta), radius * np.sin(theta)], -1)


@settings(BATTERY, max_examples=25)
@given(
    seed=st.integers(0, 2**16),
    exponent=st.sampled_from([-300, -160, -20, 0, 20, 160, 300]),
    noise=st.sampled_from([0.0, 1e-3, 0.05]),
    weights=st.sampled_from(["none", "random", "some zero"]),
    smoothing=st.sampled_from([0.0, 1e-3, 0.1]),
    tol=st.sampled_from([None, 1e-12, 1e-3]),
    max_steps=st.sampled_from([1, 5, 500]),
)
def test_fits_are_finite_or_say_why(seed, exponent, noise, weights, smoothing, tol, max_steps):
    """One shape (100 samples, 8 control points): one program, many values."""
    rng = np.random.default_rng(seed)
    scale = 10.0**exponent
    target = _blob(100, seed) + noise * rng.standard_normal((100, 2))
    w = {"none": None, "random": rng.uniform(0.1, 3.0, 100),
         "some zero": np.where(rng.uniform(size=100) < 0.3, 0.0, 1.0)}[weights]
    result = fitting.fit(scale * target, js.CubicBSpline(), 8, weights=w, smoothing=smoothing,
                         tol=tol, max_steps=max_steps, on_failure="ignore")
    size = math.hypot(*np.ptp(target, axis=0))
    relative = [float(getattr(result, name)) / scale / size
                for name in ("rms", "max_error", "rms_target_to_curve", "rms_curve_to_target")]
    control = np.asarray(result.control_points) / scale
    converged = bool(result.converged)
    if converged:
        assert np.all(np.isfinite(relative)) and np.all(np.isfinite(control)), relative
        # A blob with 8 control points: errors a few percent of its size at most.
        assert max(relative) < 0.2, relative
    else:
        assert result.message and not result.message.startswith("converged"), result.message
    assert int(result.num_steps) <= max_steps


# ---------------------------------------------------------------------------- refine


def _scheme_or_error(name, value):
    makers = {
        "four_point": lambda v: js.FourPoint(v),
        "corner_cutting": lambda v: js.CornerCutting(v, 0.75),
        "split_tweak": lambda v: js.SplitTweak(v),
        "lane_riesenfeld": lambda v: js.LaneRiesenfeld(v),
        "chaikin": lambda v: js.Chaikin(),
        "cubic_bspline": lambda v: js.CubicBSpline(),
    }
    with warnings.catch_warnings():
        # A valid value where the scheme diverges (w = -1) builds it, with a warning.
        warnings.simplefilter("ignore", js.DivergenceWarning)
        return makers[name](value)


@settings(BATTERY, max_examples=60)
@given(
    m=st.sampled_from([0, 1, 2, 3, 5, 8]),
    d=st.sampled_from([1, 2, 3]),
    dtype=st.sampled_from(["float64", "float32", "int64", "complex128", "bool", "object"]),
    exponent=st.sampled_from([-300, -30, 0, 30, 300]),
    levels=st.sampled_from([-1, 0, 1, 3, 10**6]),
    boundary=st.sampled_from(["closed", "open", "clamped", "periodic"]),
    scheme=st.sampled_from(["four_point", "corner_cutting", "split_tweak", "lane_riesenfeld",
                            "chaikin", "cubic_bspline"]),
    value=st.sampled_from([0.05, 0.3, -1.0, float("nan"), float("inf"), 0.05 + 0.01j, 2, 40,
                           10**5, "0.1"]),
)
def test_refine_answers_or_names_the_argument(m, d, dtype, exponent, levels, boundary, scheme,
                                              value):
    rng = np.random.default_rng(m * 7 + d)
    points = (10.0**exponent * rng.standard_normal((m, d)))
    if dtype == "object":
        points = points.astype(object)
    elif dtype == "bool":
        points = points > 0
    else:
        with np.errstate(over="ignore", invalid="ignore"):  # 1e300 as float32: inf
            points = points.astype(dtype)
    try:
        made = _scheme_or_error(scheme, value)
        refined = np.asarray(js.refine(points, made, levels, boundary=boundary))
    except (ValueError, TypeError) as e:
        message = str(e).strip()
        assert message and "\n" not in message, message
        return
    if scheme not in ("chaikin", "cubic_bspline"):  # the value was used: it must be valid
        assert isinstance(value, (int, float)) and math.isfinite(value), (scheme, value)
    expected = js.refined_count(m, made, levels, boundary)
    assert expected >= 0 and refined.shape == (expected, d), (refined.shape, expected)
    if np.all(np.isfinite(np.asarray(points, np.complex128))):
        # Refinement is an affine combination of the points: bounded by their extent
        # (a sum of |weights| of a few at most), hence finite unless the scale is at the
        # edge of the floats.
        if exponent < 300:
            assert np.all(np.isfinite(refined)), (scheme, value)
