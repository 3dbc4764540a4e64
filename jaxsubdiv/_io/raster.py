"""Outlines from a text glyph (matplotlib's font machinery) and from a silhouette image
(matplotlib's image reader and contour machinery)."""

import io
import os

import numpy as np

from .common import Outline, fail, make_outline, read_bytes, resample_polyline
from .svg import sample_contour


def read_glyph(text: str, font=None, size: float = 1.0, samples=None) -> list[Outline]:
    """The outlines of `text` set in `font`, one per closed contour of the glyphs.

    Uses `matplotlib.textpath.TextPath`; a letter with holes ("a", "o", "8") gives its
    outer contour and one per hole, with their font orientation (TrueType: outer
    contours clockwise, holes counter-clockwise). Units: the font size is `size`.
    """
    from matplotlib.font_manager import FontProperties, findfont
    from matplotlib.path import Path as MplPath
    from matplotlib.textpath import TextPath

    where = f"text {text!r}"
    if not isinstance(text, str) or not text.strip():
        raise fail(where, "the text has no visible characters.")
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
    try:
        glyphs = TextPath((0, 0), text, size=size, prop=prop)
    except (OSError, RuntimeError, ValueError) as e:
        raise fail(where, f"cannot draw it with font {font!r} ({e}).") from None
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
    return [
        make_outline(where, sample_contour(s, True, np.eye(3), samples), True, f"contour {i}")
        for i, s in enumerate(contours)
    ]


def read_image(path, threshold: float = 0.5, samples=None) -> list[Outline]:
    """The outer contours of the silhouette in a PNG image, in pixel units, y up.

    The image is reduced to one channel: its alpha channel if that is not constant,
    else its luminance (0.299 R + 0.587 G + 0.114 B). The background is the side of
    `threshold` that most border pixels are on; the contours are the level-`threshold`
    lines of that channel (`contourpy`, matplotlib's contouring engine, with linear
    interpolation between pixel centers), and the outer ones are kept: holes are
    dropped, as are specks with less than 1% of the largest area. Pixel (row r,
    column c) of an image of height H is the point (c, H - 1 - r).
    """
    import contourpy
    import matplotlib.image

    if not 0 < threshold < 1:
        raise ValueError(f"`threshold` must be between 0 and 1, got {threshold}.")
    data = read_bytes(path)
    try:
        image = np.asarray(
            matplotlib.image.imread(io.BytesIO(data), format="png"), dtype=np.float64
        )
    except Exception as e:  # PIL and matplotlib raise many types for a bad image
        raise fail(path, f"is not a readable PNG image ({type(e).__name__}: {e}).") from None
    if image.max(initial=0) > 1:
        image = image / 255.0
    if image.ndim == 3:
        if image.shape[2] == 4 and np.ptp(image[..., 3]) > 0:
            channel = image[..., 3]
        else:
            channel = (
                image[..., :3] @ np.array([0.299, 0.587, 0.114])
                if image.shape[2] >= 3
                else image[..., 0]
            )
    else:
        channel = image
    border = np.concatenate([channel[0], channel[-1], channel[:, 0], channel[:, -1]])
    background_high = np.mean(border > threshold) >= 0.5
    padded = np.pad(channel, 1, constant_values=1.0 if background_high else 0.0)
    lines = contourpy.contour_generator(z=padded, line_type="Separate").lines(threshold)
    height = channel.shape[0]
    loops = [
        np.stack([line[:-1, 0] - 1, height - line[:-1, 1]], axis=-1)
        for line in lines
        if len(line) > 3
    ]
    if not loops:
        raise fail(
            path,
            f"has no silhouette: no pixel is on the other side of threshold {threshold} "
            "from the background.",
        )
    area = np.array([abs(_area(p)) for p in loops])
    depth = [
        sum(_inside(p[0], q) for j, q in enumerate(loops) if j != i) for i, p in enumerate(loops)
    ]
    keep = [i for i in range(len(loops)) if depth[i] % 2 == 0 and area[i] >= 0.01 * area.max()]
    return [
        make_outline(
            path,
            loops[i] if samples is None else resample_polyline(loops[i], samples, True),
            True,
            f"contour {k}",
        )
        for k, i in enumerate(keep)
    ]


def _area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _inside(point: np.ndarray, polygon: np.ndarray) -> bool:
    """Even-odd rule: does a ray from `point` cross the polygon an odd number of times?"""
    x, y = point
    a, b = polygon, np.roll(polygon, -1, axis=0)
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return bool(np.count_nonzero(crosses & (xs > x)) % 2)
