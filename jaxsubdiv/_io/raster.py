"""Outlines from a text glyph (matplotlib's font machinery) and from a silhouette image
(matplotlib's image reader and contour machinery)."""

import io
import os

import numpy as np

from . import common
from .common import (
    DEFAULT_SAMPLES,
    Outline,
    check_contours,
    check_points,
    fail,
    make_outline,
    one_line,
    png_size,
    quote,
    read_bytes,
    resample_polyline,
)
from .svg import sample_contour


def read_glyph(text: str, font=None, size: float = 1.0, samples=None) -> list[Outline]:
    """The outlines of `text` set in `font`, one per closed contour of the glyphs
    (`samples` points on each, or its nodes for `samples="nodes"`), all one shape.

    Uses `matplotlib.textpath.TextPath`; a letter with holes ("a", "o", "8") gives its
    outer contour and one per hole, with their font orientation (TrueType: outer
    contours clockwise, holes counter-clockwise). Units: the font size is `size`.
    """
    from matplotlib.font_manager import FontProperties, findfont
    from matplotlib.path import Path as MplPath
    from matplotlib.textpath import TextPath

    if not isinstance(text, str):
        raise TypeError(f"`text` must be a string, got {type(text).__name__}.")
    if font is not None and not isinstance(font, (str, os.PathLike)):
        raise TypeError(
            f"`font` must be a font family or file name, got {type(font).__name__}."
        )
    where = f"text {quote(text)}"
    if not text.strip():
        raise fail(where, "the text has no visible characters.")
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as e:
        raise fail(
            where,
            f"character {e.start} is a lone surrogate ({quote(text[e.start])}), not a letter.",
        ) from None
    if len(text) > common.MAX_CONTOURS:
        raise fail(
            where,
            f"the text has {len(text):,} characters, more than the limit of "
            f"{common.MAX_CONTOURS:,} (jaxsubdiv.io.MAX_CONTOURS); use a shorter text.",
        )
    if font is None:
        prop = FontProperties()
    elif os.path.isfile(font):
        prop = FontProperties(fname=font)
    else:
        prop = FontProperties(family=font)
        try:
            findfont(prop, fallback_to_default=False)
        except ValueError:
            raise fail(
                where,
                f"font {font!r} not found; pass a font file or a family from "
                "matplotlib.font_manager.get_font_names().",
            ) from None
    nothing = "the text has no visible characters (the font draws nothing for it)."
    try:
        glyphs = TextPath((0, 0), text, size=size, prop=prop)
    except AttributeError:  # matplotlib fails so when no glyph has an outline ("\u200b")
        raise fail(where, nothing) from None
    except (OSError, RuntimeError, ValueError, TypeError) as e:
        # TypeError: a lone surrogate ("\ud800") that FreeType's binding cannot take
        raise fail(
            where,
            f"cannot draw it with font {'(default)' if font is None else quote(font)} "
            f"({type(e).__name__}: {one_line(e, 80)}).",
        ) from None
    if len(glyphs.vertices) == 0:
        raise fail(where, nothing)
    contours, segments, start, current = [], [], None, None
    for vertices, code in glyphs.iter_segments(curves=True, simplify=False):
        points = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
        if code == MplPath.MOVETO:
            if segments:
                contours.append(segments)
            segments, start, current = [], points[0], points[0]
            continue
        if code == MplPath.CLOSEPOLY:
            points = start[None]
        kind = {1: "L", 2: "Q", 3: "C"}[len(points)]
        if kind != "L" or not np.array_equal(current, points[-1]):
            segments.append((kind, np.concatenate([current[None], points])))
        current = points[-1]
    if segments:
        contours.append(segments)
    if not contours:
        raise fail(where, "the font draws no outline for it.")
    check_contours(where, len(contours), "use a shorter text")
    check_points(
        where,
        sum(len(s) for s in contours)
        if samples == "nodes"
        else len(contours) * (samples or DEFAULT_SAMPLES),
    )
    # The text is one shape (group 0): its contours are filled together, holes and all.
    return [
        make_outline(where, sample_contour(s, True, np.eye(3), samples), True, f"contour {i}", 0)
        for i, s in enumerate(contours)
    ]


def read_image(path, threshold: float = 0.5, samples=None) -> list[Outline]:
    """The contours of the silhouette in a PNG image, its holes too, in pixel units, y up.

    The image is reduced to one channel: its alpha channel if that holds a silhouette
    (at least `ALPHA_SILHOUETTE_SHARE`, 0.1%, of the pixels on the other side of
    `threshold` from its background), else its luminance (0.299 R + 0.587 G + 0.114 B);
    an alpha channel that only marks a few pixels (the rounded corners of scikit-image's
    `horse.png`) is not the silhouette, unless the luminance holds none. The background
    of a channel is the side of `threshold` that most border pixels are on; the
    contours are the level-`threshold` lines of that channel (`contourpy`, matplotlib's
    contouring engine, with linear interpolation between pixel centers): the outer contours, clockwise, then the
    holes, counter-clockwise (as glyphs come from their fonts); specks with less than
    1% of the largest area are dropped. Pixel (row r, column c) of an image of height
    H is the point (c, H - 1 - r). All contours are one shape (group 0).

    Limits: an image of more than `MAX_PIXELS` pixels is refused from its header,
    before it is decoded; one with more than `MAX_CONTOURS` contours of at least 0.5%
    of the largest area (noise, dithering) is refused before they are followed.
    """
    import contourpy
    import matplotlib.image

    if isinstance(threshold, bool) or not isinstance(
        threshold, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"`threshold` must be a number, got {type(threshold).__name__}.")
    if not 0 < threshold < 1:
        raise ValueError(f"`threshold` must be between 0 and 1, got {threshold}.")
    data = read_bytes(path)
    width, height = png_size(path, data)
    if width * height > common.MAX_PIXELS:
        raise fail(
            path,
            f"the image is {width:,} x {height:,} = {width * height:,} pixels, more than the "
            f"limit of {common.MAX_PIXELS:,} (jaxsubdiv.io.MAX_PIXELS); scale the image down.",
        )
    try:
        image = matplotlib.image.imread(io.BytesIO(data), format="png")
    except MemoryError:
        raise
    except Exception as e:  # PIL and matplotlib raise many types for a bad image
        raise fail(
            path, f"is not a readable PNG image ({type(e).__name__}: {one_line(e, 120)})."
        ) from None
    # matplotlib gives float32 in [0, 1]; each channel used is converted to float64
    # (exactly) on its own rather than the whole image, to save memory.
    image = np.asarray(image)
    if image.max(initial=0) > 1:
        image = image / 255.0
    if image.ndim == 3:
        channel = None
        if image.shape[2] in (2, 4) and np.ptp(image[..., -1]) > 0:  # gray or RGB + alpha
            alpha = image[..., -1].astype(np.float64)
            if _silhouette_pixels(alpha, threshold) >= ALPHA_SILHOUETTE_SHARE * alpha.size:
                channel = alpha
            else:
                channel = _luminance(image)
                if not _silhouette_pixels(channel, threshold):
                    channel = alpha
            del alpha
        if channel is None:
            channel = _luminance(image)
    else:
        channel = image.astype(np.float64)
    del image
    background_high = _background_high(channel, threshold)
    padded = np.pad(channel, 1, constant_values=1.0 if background_high else 0.0)
    height = channel.shape[0]
    del channel
    generator = contourpy.contour_generator(z=padded, line_type="ChunkCombinedOffset")
    (points,), (offsets,) = generator.lines(threshold)
    del padded, generator
    if points is None:
        points, offsets = np.zeros((0, 2)), np.zeros(1, np.int64)
    # All lines are closed (the padding sees to it) and repeat their first point. To
    # pixel coordinates, y up, in place: (column, row) of the padded image ->
    # (column - 1, height - row), i.e. pixel (r, c) -> (c, height - 1 - r).
    points[:, 0] -= 1
    np.subtract(height, points[:, 1], out=points[:, 1])
    starts, stops = offsets[:-1], offsets[1:] - 1  # stops: the repeated first point
    lines = np.flatnonzero(stops - starts >= 3)  # at least 3 distinct points
    if not len(lines):
        raise fail(
            path,
            f"has no silhouette: no pixel is on the other side of threshold {threshold} "
            "from the background.",
        )
    # The areas of all lines at once, to drop the specks without making a Python object
    # for each (a noisy image has millions); then the exact areas of the rest as before
    # (the cut at half the 1% leaves ample room for the different rounding).
    rough = _rough_areas(points, starts[lines], stops[lines])
    candidates = lines[rough >= 0.005 * rough.max()]
    check_contours(path, len(candidates), "blur, threshold or scale down the image")
    loops = [points[starts[k] : stops[k]] for k in candidates]
    area = np.array([abs(_area(p)) for p in loops])
    # A loop that contains a point of another one contains all of it (contour lines do
    # not cross), so it is at least as large: the loops of the kept sizes are nested only
    # in each other, and their nesting depths need no other loop.
    big = [p for p, a in zip(loops, area) if a >= 0.01 * area.max()]
    depth = _depths(big)
    # Outer contours clockwise and holes counter-clockwise (y up), as glyphs come from
    # their fonts (TrueType); outer contours first, then the holes.
    keep = [p if (_area(p) < 0) == (d % 2 == 0) else p[::-1]
            for even in (True, False) for p, d in zip(big, depth) if (d % 2 == 0) == even]
    check_points(path, len(keep) * samples if samples else sum(len(p) for p in keep))
    return [
        make_outline(
            path,
            p if samples is None else resample_polyline(p, samples, True),
            True,
            f"contour {k}",
            0,  # one silhouette: filled together, holes and all
        )
        for k, p in enumerate(keep)
    ]


#: The least share of an image's pixels that its alpha channel must put on the other
#: side of `threshold` from its background to be read as the silhouette: below it the
#: alpha channel marks only specks (scikit-image's `horse.png` has four corner pixels
#: partly transparent), and the luminance is read instead.
ALPHA_SILHOUETTE_SHARE = 1e-3


def _luminance(image: np.ndarray) -> np.ndarray:
    """0.299 R + 0.587 G + 0.114 B in float64 (the gray channel of a gray image), one
    channel at a time: no float64 copy of the whole image."""
    if image.shape[2] < 3:
        return image[..., 0].astype(np.float64)
    out = np.multiply(image[..., 0], 0.299, dtype=np.float64)
    for index, weight in ((1, 0.587), (2, 0.114)):
        out += np.multiply(image[..., index], weight, dtype=np.float64)
    return out


def _background_high(channel: np.ndarray, threshold: float) -> bool:
    """Whether the background (the side of `threshold` most border pixels are on) is
    the high side."""
    border = np.concatenate([channel[0], channel[-1], channel[:, 0], channel[:, -1]])
    return bool(np.mean(border > threshold) >= 0.5)


def _silhouette_pixels(channel: np.ndarray, threshold: float) -> int:
    """How many pixels are on the other side of `threshold` from the background."""
    above = int(np.count_nonzero(channel > threshold))
    return channel.size - above if _background_high(channel, threshold) else above


def _rough_areas(points: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """Twice the absolute shoelace area of each line `points[starts[k] : stops[k] + 1]`
    (which repeats its first point at `stops[k]`; the lines in increasing order), a block
    of about a million points at a time."""
    out = np.empty(len(starts))
    k = 0
    while k < len(starts):
        m = max(k + 1, int(np.searchsorted(stops, starts[k] + 2**20, "right")))
        block = points[starts[k] : stops[m - 1] + 1]
        x, y = block[:, 0], block[:, 1]
        cross = x[:-1] * y[1:]
        cross -= y[:-1] * x[1:]
        # reduceat at (start, stop) pairs: the even results are the sums over each line.
        bounds = np.stack([starts[k:m], stops[k:m]], axis=-1).ravel() - starts[k]
        out[k:m] = np.abs(np.add.reduceat(np.append(cross, 0.0), bounds)[::2])
        k = m
    return out


def _area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _depths(loops: list[np.ndarray]) -> np.ndarray:
    """For each loop, how many of the others contain its first point (by `_inside`).

    The same answers as `_inside` for every pair, but only for the pairs where it can
    be true: a point outside a loop's bounding box (by more than 1, far more than the
    rounding of the crossing test) is inside it by neither rule, as a horizontal line
    crosses a closed loop an even number of times. The candidates come from the first
    points sorted by y, and each loop tests all of its candidates at once.
    """
    if not loops:
        return np.zeros(0, np.int64)
    first = np.array([p[0] for p in loops])
    order = np.argsort(first[:, 1], kind="stable")
    ys = first[order, 1]
    depth = np.zeros(len(loops), np.int64)
    for j, polygon in enumerate(loops):
        low, high = polygon.min(axis=0), polygon.max(axis=0)
        # _inside is only ever true for low_y <= y < high_y (its crossing test is exact).
        near = order[np.searchsorted(ys, low[1], "left") : np.searchsorted(ys, high[1], "left")]
        x = first[near, 0]
        near = near[(x >= low[0] - 1) & (x <= high[0] + 1) & (near != j)]
        if len(near):
            depth[near] += _inside_all(first[near], polygon)
    return depth


def _inside_all(points: np.ndarray, polygon: np.ndarray, pairs: int = 2**20) -> np.ndarray:
    """`_inside(p, polygon)` for each of `points`, with the same arithmetic, pairing each
    edge only with the points whose horizontal line it crosses (at most `pairs` pairs
    at a time)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    order = np.argsort(points[:, 1], kind="stable")
    ys = points[order, 1]
    # (a_y > y) != (b_y > y) exactly when min(a_y, b_y) <= y < max(a_y, b_y).
    start = np.searchsorted(ys, np.minimum(a[:, 1], b[:, 1]), "left")
    count = np.searchsorted(ys, np.maximum(a[:, 1], b[:, 1]), "left") - start
    ends = np.cumsum(count)
    crossings = np.zeros(len(points), np.int64)
    first = 0
    while first < len(a):
        done = ends[first - 1] if first else 0
        last = max(int(np.searchsorted(ends, done + pairs, "right")), first + 1)
        n = count[first:last]
        edge = np.repeat(np.arange(first, last), n)
        k = order[start[edge] + np.arange(len(edge)) - np.repeat(np.cumsum(n) - n, n)]
        x, y = points[k, 0], points[k, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            # the expression of _inside, term for term, for the same rounding
            xs = a[edge, 0] + (y - a[edge, 1]) * (b[edge, 0] - a[edge, 0]) / (
                b[edge, 1] - a[edge, 1]
            )
        crossings += np.bincount(k[xs > x], minlength=len(points))
        first = last
    return crossings % 2 == 1


def _inside(point: np.ndarray, polygon: np.ndarray) -> bool:
    """Even-odd rule: does a ray from `point` cross the polygon an odd number of times?"""
    x, y = point
    a, b = polygon, np.roll(polygon, -1, axis=0)
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return bool(np.count_nonzero(crosses & (xs > x)) % 2)
