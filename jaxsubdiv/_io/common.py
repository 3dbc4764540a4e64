"""What every reader and writer shares: the `Outline` record, the error type, file access
and resampling by arc length."""

import os
from pathlib import Path

import equinox as eqx
import numpy as np
from jaxtyping import Float


#: Points per contour when a curved outline (SVG curves, a glyph) is sampled and the
#: caller gave no `samples`.
DEFAULT_SAMPLES = 400


class OutlineError(ValueError):
    """An input or output file that cannot be used, with a one-line message for people.

    The message names the file (and the line, for text formats) and the problem, e.g.
    `outline.csv, line 7: expected 2 values (x, y), got 3.` The command-line tool prints
    it as it is and exits with status 2. A subclass of `ValueError`.
    """


class Outline(eqx.Module):
    """One contour read from a file: a polyline and whether it is closed.

    **Fields:**

    - `points`: the points in order, a NumPy float64 array of shape `(m, 2)`. A closed
      outline does not repeat its first point at the end.
    - `closed`: True for a closed contour (the last point joins the first).
    """

    points: Float[np.ndarray, "m 2"]
    closed: bool = eqx.field(static=True, default=True)


def name_of(path) -> str:
    return os.fspath(path)


def fail(path, message: str, line: int | None = None) -> OutlineError:
    where = name_of(path) if line is None else f"{name_of(path)}, line {line}"
    return OutlineError(f"{where}: {message}")


def read_bytes(path) -> bytes:
    """The file's contents, with missing, unreadable and empty files as `OutlineError`."""
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise fail(path, "no such file.") from None
    except IsADirectoryError:
        raise fail(path, "is a directory, not a file.") from None
    except OSError as e:
        raise fail(path, f"cannot read the file ({e.strerror or e}).") from None
    if not data.strip():
        raise fail(path, "the file is empty.")
    return data


def read_text(path) -> str:
    data = read_bytes(path)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise fail(path, "is not a text file (it is not valid UTF-8).") from None


def open_for_writing(path):
    try:
        return open(path, "wb")
    except OSError as e:
        raise fail(path, f"cannot write the file ({e.strerror or e}).") from None


def checked_points(path, points, what: str = "the points") -> np.ndarray:
    """`points` as a finite float64 `(m, 2)` array with m >= 2, else `OutlineError`."""
    array = np.asarray(points)
    if array.dtype == object or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        raise fail(path, f"{what} must be real numbers, got values of type {array.dtype}.")
    if array.ndim != 2 or array.shape[1] != 2:
        raise fail(path, f"{what} must have shape (m, 2) (x, y per point), got {array.shape}.")
    if len(array) < 2:
        raise fail(path, f"{what} must have at least 2 points, got {len(array)}.")
    array = array.astype(np.float64)
    if not np.all(np.isfinite(array)):
        raise fail(path, f"{what} contain NaN or infinite values.")
    return array


def make_outline(path, points, closed: bool, what: str = "the points") -> Outline:
    """A checked `Outline`; a closed one loses a last point that repeats the first."""
    points = checked_points(path, points, what)
    return Outline(drop_closing_point(points) if closed else points, bool(closed))


def drop_closing_point(points: np.ndarray) -> np.ndarray:
    """Remove a last point equal to the first (a closed polyline written out in full)."""
    if len(points) > 2 and np.array_equal(points[0], points[-1]):
        return points[:-1]
    return points


def arc_length_targets(length: float, count: int, closed: bool) -> np.ndarray:
    """`count` arc lengths equally spaced along a curve of total length `length`."""
    if closed:
        return np.arange(count) * (length / count)
    return np.linspace(0.0, length, count)


def resample_polyline(points: np.ndarray, count: int, closed: bool) -> np.ndarray:
    """`count` points equally spaced by arc length along the polyline through `points`.

    Used for data that is already a polyline (CSV, NPY, JSON, a PNG contour); curves
    with an exact form (SVG, glyphs) are resampled on the curve itself instead.
    """
    if closed:
        points = np.concatenate([points, points[:1]])
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(chords)])
    if s[-1] == 0:
        return np.repeat(points[:1], count, axis=0)
    targets = arc_length_targets(s[-1], count, closed)
    return np.stack([np.interp(targets, s, points[:, k]) for k in range(2)], axis=-1)


def check_samples(samples) -> int | None:
    if samples is None:
        return None
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)):
        raise TypeError(f"`samples` must be an int or None, got {samples!r}.")
    if samples < 3:
        raise ValueError(f"`samples` must be at least 3 points per contour, got {samples}.")
    return int(samples)
