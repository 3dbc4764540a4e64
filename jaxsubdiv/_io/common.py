"""What every reader and writer shares: the `Outline` record, the error type, file access
and resampling by arc length."""

import os
import struct
from pathlib import Path

import equinox as eqx
import numpy as np
from jaxtyping import Float


#: Points per contour when a curved outline (SVG curves, a glyph) is sampled and the
#: caller gave no `samples`.
DEFAULT_SAMPLES = 400

# Resource limits (re-exported by `jaxsubdiv.io`, which documents them). Every reader
# checks them before it allocates what they bound, and refuses with an `OutlineError`
# that names the file, the size, the limit and the fix. The readers look them up here
# when they run (the tests lower them to build files just inside and just outside).

#: The largest input file, in bytes (64 MiB), checked before it is read. Parsing a text
#: format (CSV, JSON, SVG) takes up to about 12 times the file's size in memory
#: (measured: 7x for CSV, 5x for JSON, 12x for SVG path data) and about 20 s per
#: million SVG path segments.
MAX_FILE_BYTES = 64 * 1024**2

#: The most contours one input may give (10,000): CSV blocks, JSON outlines, NPY/NPZ
#: arrays, SVG subpaths, PNG contours, glyph contours (and characters of a text).
MAX_CONTOURS = 10_000

#: The most points one read may return in all (2**24, about 16.8 million: 256 MiB as
#: float64), counting `samples` per contour when the outlines are resampled.
MAX_POINTS = 2**24

#: The largest array data, in bytes, an NPY file or the NPZ members read may hold as
#: float64 (256 MiB); for NPZ also the members' declared uncompressed size, checked
#: before anything is decompressed.
MAX_ARRAY_BYTES = 256 * 1024**2

#: The largest PNG image, in pixels (25 million, e.g. 5000 x 5000), checked on the
#: image's header before it is decoded. Measured peak memory of a read (ru_maxrss, 3000 x
#: 3000 images): 30 bytes per pixel gray or RGBA, 44 RGB, 48 palette, 46 for 50% random
#: noise, 70 for a one-pixel checkerboard (the most contour points), so at most about
#: 1.75 GB, under `jaxsubdiv.DEFAULT_MEMORY_BUDGET` (2 GiB).
MAX_PIXELS = 25_000_000


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
    - `group`: the shape the contour belongs to, or None for a shape of its own. The
      contours of one shape (a glyph's outer contour and its holes, the subpaths of one
      SVG `<path>`, a silhouette's contours) share a number; an SVG file written from
      them draws each shape as one `<path>` of subpaths, filled by the even-odd rule,
      so the holes stay holes. Set by the SVG, glyph and PNG readers; SVG and JSON
      files keep it, the other point formats do not (their outlines read back as None).
    """

    points: Float[np.ndarray, "m 2"]
    closed: bool = eqx.field(static=True, default=True)
    group: int | None = eqx.field(static=True, default=None)


def check_path(path, name: str = "path") -> None:
    """A `TypeError` naming the argument unless `path` is a file path."""
    if not isinstance(path, (str, bytes, os.PathLike)):
        raise TypeError(
            f"`{name}` must be a file path (str or os.PathLike), got {type(path).__name__}."
        )


def name_of(path) -> str:
    name = os.fspath(path)
    if isinstance(name, bytes):
        name = os.fsdecode(name)
    return name if name.isprintable() else repr(name)


def one_line(text, width: int = 200) -> str:
    """`text` on one line, cut to about `width` characters: safe to put in a message."""
    text = " ".join(str(text).splitlines())
    return text if len(text) <= width else text[: width - 3] + "..."


def quote(text, width: int = 40) -> str:
    """`repr(text)`, cut to about `width` characters (for quoting a file's content)."""
    text = str(text)
    return repr(text) if len(text) <= width else repr(text[: width - 3]) + "..."


def size_text(count: int) -> str:
    """A byte count for people: 149 GiB, 12.5 MiB, 300 bytes."""
    for unit, size in (("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if count >= size:
            return f"{count / size:.3g} {unit}"
    return f"{count} bytes"


def fail(path, message: str, line: int | None = None) -> OutlineError:
    where = name_of(path) if line is None else f"{name_of(path)}, line {line}"
    return OutlineError(f"{where}: {one_line(message, 500)}")


def read_bytes(path) -> bytes:
    """The file's contents, with missing, unreadable, empty and too large files (more
    than `MAX_FILE_BYTES`, checked before reading) as `OutlineError`."""
    limit = MAX_FILE_BYTES
    try:
        with Path(path).open("rb") as f:
            size = os.fstat(f.fileno()).st_size
            # st_size is 0 for pipes and devices: read at most one byte past the limit.
            data = b"" if size > limit else f.read(limit + 1)
    except FileNotFoundError:
        raise fail(path, "no such file.") from None
    except IsADirectoryError:
        raise fail(path, "is a directory, not a file.") from None
    except OSError as e:
        raise fail(path, f"cannot read the file ({e.strerror or e}).") from None
    except ValueError as e:  # a NUL character in the name
        raise fail(path, f"cannot open the file ({e}).") from None
    if size > limit or len(data) > limit:
        raise fail(
            path,
            f"the file is {size_text(size) if size > limit else 'over ' + size_text(limit)}, "
            f"more than the {size_text(limit)} limit for an input file "
            "(jaxsubdiv.io.MAX_FILE_BYTES); thin out or split the data.",
        )
    if not data.strip():
        raise fail(path, "the file is empty.")
    return data


def check_contours(path, count: int, fix: str = "split the file", counted: bool = True) -> None:
    """Refuse an input with more than `MAX_CONTOURS` contours, or none. A reader that
    stops counting past the limit says `counted=False`."""
    if count == 0:
        raise fail(path, "has no contours: there is no outline to read.")
    if count > MAX_CONTOURS:
        many = f"{count:,} contours, more" if counted else "more contours"
        raise fail(
            path,
            f"has {many} than the limit of {MAX_CONTOURS:,} (jaxsubdiv.io.MAX_CONTOURS); {fix}.",
        )


def check_points(path, count: int, what: str = "the outlines") -> None:
    """Refuse a read that would return more than `MAX_POINTS` points in all."""
    if count > MAX_POINTS:
        raise fail(
            path,
            f"{what} would have {count:,} points, more than the limit of {MAX_POINTS:,} "
            "(jaxsubdiv.io.MAX_POINTS); ask for fewer `samples` or split the file.",
        )


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_size(path, data: bytes) -> tuple[int, int]:
    """Width and height from the PNG header (the IHDR chunk that must come first)."""
    if not data.startswith(_PNG_SIGNATURE) or len(data) < 24 or data[12:16] != b"IHDR":
        raise fail(path, "is not a readable PNG image (it has no PNG signature and header).")
    return struct.unpack(">II", data[16:24])


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
    try:
        array = np.asarray(points)
    except (TypeError, ValueError, OverflowError):
        raise fail(path, f"{what} must be an (m, 2) array of real numbers.") from None
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
        raise fail(path, f"{what} must not contain NaN or infinite values.")
    return array


def make_outline(
    path, points, closed: bool, what: str = "the points", group: int | None = None
) -> Outline:
    """A checked `Outline`; a closed one loses a last point that repeats the first."""
    points = checked_points(path, points, what)
    return Outline(drop_closing_point(points) if closed else points, bool(closed), group)


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


def densify_polyline(points: np.ndarray, count: int, closed: bool) -> np.ndarray:
    """`count` points along the polyline through `points` (`count >= len(points)`) that
    keep every one of them: each edge gets new points spaced evenly along it, in
    proportion to its length (largest remainders). For a contour of too few points to
    fit: resampling by arc length alone cuts its corners, and a fit of the corners the
    user gave was then charged for them (a triangle fitted exactly reported a max error
    of 10% of its size)."""
    points = np.asarray(points, float)
    m = len(points)
    ends = np.concatenate([points[1:], points[:1]]) if closed else points[1:]
    edges = len(ends)
    lengths = np.linalg.norm(ends - points[:edges], axis=1)
    extra = count - m
    if extra <= 0 or edges == 0:
        return points
    share = (lengths / lengths.sum() * extra if lengths.sum() > 0
             else np.full(edges, extra / edges))
    added = np.floor(share).astype(int)
    added[np.argsort(-(share - added), kind="stable")[: extra - added.sum()]] += 1
    out = []
    for start, end, k in zip(points[:edges], ends, added):
        fractions = np.arange(k + 1) / (k + 1)  # the edge's start and its k new points
        out.append(start + fractions[:, None] * (end - start))
    if not closed:
        out.append(points[-1:])
    return np.concatenate(out)


def check_samples(samples) -> int | None:
    if samples is None:
        return None
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)):
        raise TypeError(f"`samples` must be an int or None, got {samples!r}.")
    if samples < 3:
        raise ValueError(f"`samples` must be at least 3 points per contour, got {samples}.")
    if samples > MAX_POINTS:
        raise ValueError(
            f"`samples` must be at most {MAX_POINTS:,} (jaxsubdiv.io.MAX_POINTS), got {samples:,}."
        )
    return int(samples)
