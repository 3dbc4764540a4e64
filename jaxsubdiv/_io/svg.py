"""SVG: path data for every command, `<polygon>`, `<polyline>`, transforms; sampling by
arc length on the exact curves, or a contour's nodes; writing outlines and exact Bezier
curves, one `<path>` per shape.

jaxsubdiv's y axis points up and SVG's points down, so reading negates y and writing
wraps the drawing in `<g transform="scale(1,-1)">` (or the map to a PNG's pixels): a
shape reads and draws upright, and a file written here reads back to the same numbers.
"""

import math
import re
import xml.etree.ElementTree as ET
from typing import NamedTuple

import numpy as np

from . import common, css
from .common import (
    DEFAULT_SAMPLES,
    Outline,
    arc_length_targets,
    check_contours,
    check_points,
    fail,
    make_outline,
    one_line,
    open_for_writing,
    png_size,
    quote,
    read_bytes,
)


# A segment is (kind, data): "L" line (2, 2), "Q" quadratic (3, 2), "C" cubic (4, 2)
# control points; "A" an elliptical arc (cx, cy, rx, ry, phi, theta1, dtheta).
Segment = tuple[str, np.ndarray]

# Table points per curved segment used to measure arc length; the samples themselves
# are evaluated exactly on the segment.
_TABLE = 64


def evaluate(segment: Segment, t: np.ndarray) -> np.ndarray:
    """Points of one segment at parameters `t` in [0, 1], shape `(len(t), 2)`."""
    kind, data = segment
    t = np.asarray(t, dtype=np.float64)[:, None]
    s = 1 - t
    if kind == "L":
        return s * data[0] + t * data[1]
    if kind == "Q":
        return s * s * data[0] + 2 * s * t * data[1] + t * t * data[2]
    if kind == "C":
        return s**3 * data[0] + 3 * s * s * t * data[1] + 3 * s * t * t * data[2] + t**3 * data[3]
    cx, cy, rx, ry, phi, theta1, dtheta = data
    theta = theta1 + t[:, 0] * dtheta
    x, y = rx * np.cos(theta), ry * np.sin(theta)
    c, n = math.cos(phi), math.sin(phi)
    return np.stack([cx + c * x - n * y, cy + n * x + c * y], axis=-1)


def arc_segment(p0, rx, ry, angle, large, sweep, p1) -> Segment | None:
    """The SVG arc from `p0` to `p1` by the endpoint-to-center conversion of the SVG 1.1
    specification (implementation notes F.6.5, with the radius correction of F.6.6).
    A zero radius is a straight line; equal end points draw nothing. The result holds
    non-finite numbers when the arc cannot be computed in float64 (the caller checks).
    """
    p0, p1 = (np.asarray(p, dtype=np.float64) for p in (p0, p1))
    if np.array_equal(p0, p1):
        return None
    rx, ry = abs(float(rx)), abs(float(ry))
    if rx == 0 or ry == 0:
        return ("L", np.array([p0, p1]))
    phi = math.radians(angle % 360)
    c, n = math.cos(phi), math.sin(phi)
    hx, hy = float(p0[0] - p1[0]) / 2, float(p0[1] - p1[1]) / 2
    x1, y1 = c * hx + n * hy, -n * hx + c * hy
    # The specification's formulas in terms of the half chord in units of the radii,
    # (u, v) = (x1 / rx, y1 / ry), of length h: no square can overflow or underflow.
    # Its center (F.6.5.2) is c' = sqrt(1 - h^2) (rx v, -ry u) / h.
    u, v = x1 / rx, y1 / ry
    h = math.hypot(u, v)
    if h == 0:  # the end points differ by less than float64 can halve
        return None
    if h > 1:  # F.6.6: the radii are too small; scale them up to just reach
        rx, ry, u, v, h = rx * h, ry * h, u / h, v / h, 1.0
    root = math.sqrt(max(0.0, (1 - h) * (1 + h)))
    if large == sweep:
        root = -root
    uh, vh = u / h, v / h  # a unit vector: root * uh is finite when h is tiny
    cx1, cy1 = rx * (root * vh), -ry * (root * uh)
    cx = c * cx1 - n * cy1 + (float(p0[0]) / 2 + float(p1[0]) / 2)
    cy = n * cx1 + c * cy1 + (float(p0[1]) / 2 + float(p1[1]) / 2)
    theta1 = math.atan2(v + root * uh, u - root * vh)
    theta2 = math.atan2(-v + root * uh, -u - root * vh)
    dtheta = theta2 - theta1
    if sweep and dtheta < 0:
        dtheta += 2 * math.pi
    elif not sweep and dtheta > 0:
        dtheta -= 2 * math.pi
    elif dtheta == 0 and large:  # end points too close for the angles to differ
        dtheta = 2 * math.pi if sweep else -2 * math.pi
    arc = ("A", np.array([cx, cy, rx, ry, phi, theta1, dtheta]))
    # The center form can lose the end points when the radii are far larger than the
    # arc: check them against the arc's own size (and the end points' own rounding).
    with np.errstate(all="ignore"):
        points = evaluate(arc, np.linspace(0.0, 1.0, 9))
    if not np.all(np.isfinite(points)):
        return arc  # the caller reports the overflow
    size = np.ptp(np.vstack([points, p0, p1]), axis=0).max()
    tolerance = 1e-6 * size + 64 * np.finfo(float).eps * np.abs([p0, p1]).max()
    if max(np.abs(points[0] - p0).max(), np.abs(points[-1] - p1).max()) > tolerance:
        if abs(dtheta) < 1e-6:  # the chord is within 1.3e-7 of its length of the arc
            return ("L", np.array([p0, p1]))
        return ("A", np.full(7, np.nan))  # the caller reports it
    return arc


_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_SPACE = re.compile(r"[\s,]*")
_COMMANDS = "MmZzLlHhVvCcSsQqTtAa"
_ARITY = {"M": 2, "L": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4, "T": 2, "A": 7, "Z": 0}


class _Scanner:
    def __init__(self, d: str, path):
        self.d, self.i, self.path = d, 0, path

    def error(self, message: str):
        near = self.d[max(0, self.i - 10) : self.i + 10].strip()
        return fail(self.path, f"bad path data at character {self.i} (near {near!r}): {message}")

    def skip(self) -> bool:
        """Skip separators; True if something is left."""
        self.i = _SPACE.match(self.d, self.i).end()
        return self.i < len(self.d)

    def at_number(self) -> bool:
        return self.skip() and self.d[self.i] in "+-.0123456789"

    def number(self, command: str) -> float:
        self.skip()
        match = _NUMBER.match(self.d, self.i)
        if not match:
            raise self.error(f"expected a number for '{command}'.")
        value = float(match.group())
        if not math.isfinite(value):
            raise self.error(f"{quote(match.group())} is too large for a float64 (1.8e308).")
        self.i = match.end()
        return value

    def flag(self, command: str) -> bool:
        self.skip()
        if self.i < len(self.d) and self.d[self.i] in "01":
            self.i += 1
            return self.d[self.i - 1] == "1"
        raise self.error(f"expected a flag 0 or 1 for '{command}'.")


def parse_path(d: str, path) -> list[tuple[list[Segment], bool]]:
    """Parse SVG path data into subpaths: (segments, closed) in the path's coordinates.

    Every command of SVG 1.1 section 8.3, absolute and relative, with implicit repeats
    (extra pairs after `M` are `L`). `S` and `T` reflect the previous control point when
    the previous command was a cubic (`C`/`S`) or quadratic (`Q`/`T`) one.
    """
    scan = _Scanner(d, path)
    subpaths, segments = [], []
    current = start = np.zeros(2)
    control = None  # (kind, point): last control point, for S and T
    command = None
    while scan.skip():
        letter = scan.d[scan.i]
        if letter in _COMMANDS:
            if command is None and letter not in "Mm":
                raise scan.error("path data must start with 'M'.")
            scan.i += 1
            command = letter
        elif command is None:
            raise scan.error("path data must start with a command (M).")
        elif command in "Zz" or not scan.at_number():
            raise scan.error(f"unexpected {letter!r}.")
        upper, relative = command.upper(), command.islower()
        if upper == "Z":
            if not np.array_equal(current, start):
                segments.append(("L", np.array([current, start])))
            if segments:
                subpaths.append((segments, True))
            segments, current, control = [], start, None
            continue
        if upper == "A":
            rx, ry, angle = scan.number(command), scan.number(command), scan.number(command)
            large, sweep = scan.flag(command), scan.flag(command)
            values = [scan.number(command), scan.number(command)]
        else:
            values = [scan.number(command) for _ in range(_ARITY[upper])]
        base = current if relative else np.zeros(2)
        if upper == "H":
            end = np.array([values[0] + (current[0] if relative else 0), current[1]])
        elif upper == "V":
            end = np.array([current[0], values[0] + (current[1] if relative else 0)])
        else:
            pts = np.array(values, dtype=np.float64).reshape(-1, 2) + base
            end = pts[-1]
        new_control = None
        if upper == "M":
            if segments:
                subpaths.append((segments, False))
            segments, start = [], end
            command = "l" if relative else "L"  # implicit repeats are line-tos
        elif upper in "LHV":
            if not np.array_equal(current, end):
                segments.append(("L", np.array([current, end])))
        elif upper == "C":
            segments.append(("C", np.array([current, pts[0], pts[1], end])))
            new_control = ("C", pts[1])
        elif upper == "S":
            first = 2 * current - control[1] if control and control[0] == "C" else current
            segments.append(("C", np.array([current, first, pts[0], end])))
            new_control = ("C", pts[0])
        elif upper == "Q":
            segments.append(("Q", np.array([current, pts[0], end])))
            new_control = ("Q", pts[0])
        elif upper == "T":
            middle = 2 * current - control[1] if control and control[0] == "Q" else current
            segments.append(("Q", np.array([current, middle, end])))
            new_control = ("Q", middle)
        else:  # A
            arc = arc_segment(current, rx, ry, angle, large, sweep, end)
            if arc is not None and not np.all(np.isfinite(arc[1])):
                raise scan.error(
                    "the arc cannot be computed in float64 (its radii, size and position are "
                    "too far apart); scale the drawing."
                )
            if arc is not None:
                segments.append(arc)
        current, control = end, new_control
    if segments:
        subpaths.append((segments, False))
    return subpaths


def _end(segment: Segment) -> np.ndarray:
    kind, data = segment
    return evaluate(segment, np.ones(1))[0] if kind == "A" else data[-1]


def contour_nodes(segments: list[Segment], closed: bool) -> np.ndarray:
    """The nodes of a contour (where its segments meet, as a vector editor shows them;
    Bezier handles are not nodes), in order; a closed contour's start is not repeated
    at its end. A closed contour of fewer than three segments (a loop of one or two
    curves) has too few nodes for a polygon: its curves' control points (and two
    inner points of each arc) are taken too."""
    few = closed and len(segments) < 3
    nodes = []
    for kind, data in segments:
        if kind == "A":
            nodes.extend(evaluate((kind, data), np.array([0.0, 1 / 3, 2 / 3]) if few
                                  else np.zeros(1)))
        else:
            nodes.extend(data[:-1] if few else data[:1])
    if not closed:
        nodes.append(_end(segments[-1]))
    return np.array(nodes)


def sample_contour(segments: list[Segment], closed: bool, matrix: np.ndarray, samples):
    """Points of a contour after the affine `matrix` (3 x 3), equally spaced by arc length.

    Each sample is evaluated exactly on its segment; arc length is measured on a table
    of `_TABLE` points per curved segment, so the spacing is equal to the accuracy of
    that table. `samples="nodes"` gives the contour's nodes instead; so does None for
    a contour of straight segments (its vertices).
    """
    linear, shift = matrix[:2, :2], matrix[:2, 2]
    transform = lambda p: p @ linear.T + shift
    if samples == "nodes" or (samples is None and all(kind == "L" for kind, _ in segments)):
        return transform(contour_nodes(segments, closed))
    if samples is None:
        samples = DEFAULT_SAMPLES
    tables, lengths = [], []
    for segment in segments:
        t = np.linspace(0.0, 1.0, 2 if segment[0] == "L" else _TABLE + 1)
        s = np.concatenate(
            [
                [0.0],
                np.cumsum(np.linalg.norm(np.diff(transform(evaluate(segment, t)), axis=0), axis=1)),
            ]
        )
        tables.append((t, s))
        lengths.append(s[-1])
    starts = np.concatenate([[0.0], np.cumsum(lengths)])
    targets = arc_length_targets(starts[-1], samples, closed)
    which = np.clip(np.searchsorted(starts, targets, side="right") - 1, 0, len(segments) - 1)
    out = np.empty((samples, 2))
    for k in np.unique(which):
        chosen = which == k
        t, s = tables[k]
        local = (
            np.interp(targets[chosen] - starts[k], s, t) if s[-1] > 0 else np.zeros(chosen.sum())
        )
        out[chosen] = transform(evaluate(segments[k], local))
    return out


_TRANSFORM = re.compile(r"(matrix|translate|scale|rotate|skewX|skewY)\s*\(([^)]*)\)")
_SKIP = {"defs", "clipPath", "mask", "symbol", "marker", "pattern", "metadata", "style", "script"}


def parse_transform(text: str, path) -> np.ndarray:
    """The 3 x 3 matrix of an SVG `transform` attribute (SVG 1.1 section 7.6)."""
    matrix = np.eye(3)
    for name, args in _TRANSFORM.findall(text or ""):
        try:
            v = [float(a) for a in re.split(r"[\s,]+", args.strip()) if a]
        except ValueError:
            raise fail(
                path, f"bad transform {name}({quote(args)}): not a list of numbers."
            ) from None
        if not all(math.isfinite(a) for a in v):
            raise fail(path, f"bad transform {name}({quote(args)}): a number is not finite.")
        m = np.eye(3)
        if name == "matrix" and len(v) == 6:
            m[:2] = [[v[0], v[2], v[4]], [v[1], v[3], v[5]]]
        elif name == "translate" and len(v) in (1, 2):
            m[:2, 2] = [v[0], v[1] if len(v) == 2 else 0.0]
        elif name == "scale" and len(v) in (1, 2):
            m[0, 0], m[1, 1] = v[0], v[1] if len(v) == 2 else v[0]
        elif name == "rotate" and len(v) in (1, 3):
            a = math.radians(v[0])
            m[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
            if len(v) == 3:
                m[:2, 2] = np.array(v[1:]) - m[:2, :2] @ v[1:]
        elif name in ("skewX", "skewY") and len(v) == 1:
            m[0 if name == "skewX" else 1, 1 if name == "skewX" else 0] = math.tan(
                math.radians(v[0])
            )
        else:
            raise fail(path, f"bad transform {name}({quote(args)}): wrong number of values.")
        matrix = matrix @ m
    return matrix


def _points_attribute(text: str, element: str, path) -> np.ndarray:
    try:
        values = [float(v) for v in re.split(r"[\s,]+", text.strip()) if v]
    except ValueError:
        raise fail(path, f"<{element}> has a non-numeric value in points={quote(text)}.") from None
    if len(values) % 2 or len(values) < 4:
        raise fail(path, f"<{element}> needs at least two x,y pairs, got points={quote(text)}.")
    if not all(math.isfinite(v) for v in values):
        raise fail(path, f"<{element}> has a number that is not finite in points={quote(text)}.")
    return np.array(values).reshape(-1, 2)


#: Presentation properties that decide whether an element draws anything: inherited
#: ones (SVG 1.1: fill, stroke, their opacities, stroke-width, visibility) and the two
#: that hide a whole subtree (display: none; opacity: 0).
_INHERITED = ("fill", "fill-opacity", "stroke", "stroke-opacity", "stroke-width", "visibility")
#: The initial values (SVG 1.1, "Painting"): filled black, no stroke.
_INITIAL = {"fill": "black", "fill-opacity": "1", "stroke": "none", "stroke-opacity": "1",
            "stroke-width": "1", "visibility": "visible"}


def _properties(element, styled: dict) -> dict:
    """The element's presentation attributes, overridden by the style sheets' rules that
    match it (`styled`, from `css.cascade`), by its `style` declarations, by the
    sheets' `!important` ones and by its own (CSS 2.1, 6.4.1; values in lower case:
    CSS keywords are case-insensitive)."""
    watched = (*_INHERITED, "display", "opacity")
    found = {name: element.get(name).strip().lower()
             for name in watched if element.get(name) is not None}
    layers = (styled.get(element, {}), css.declarations(element.get("style") or ""))
    for important in (False, True):
        for layer in layers:
            found.update((k, v) for k, (v, i) in layer.items() if i == important and k in watched)
    return found


def _zero(value: str) -> bool:
    """Whether an opacity or width is zero (unparsable values are taken as drawn)."""
    try:
        return float(value.strip().rstrip("%").removesuffix("px")) == 0
    except ValueError:
        return False


def _draws(style: dict, fillable: bool = True) -> bool:
    """Whether an element with these (inherited and own) properties paints anything:
    a visible fill (of a shape with an area) or stroke that is not transparent."""
    if style["visibility"] in ("hidden", "collapse"):
        return False
    unpainted = ("none", "transparent")
    fill = style["fill"] not in unpainted and not _zero(style["fill-opacity"])
    stroke = (style["stroke"] not in unpainted and not _zero(style["stroke-opacity"])
              and not _zero(style["stroke-width"]))
    return (fill and fillable) or stroke


#: Absolute units in user units (px), CSS 2.1 section 4.3.2: 96 px to the inch.
_UNITS = {"": 1.0, "px": 1.0, "in": 96.0, "cm": 96 / 2.54, "mm": 96 / 25.4, "pt": 4 / 3,
          "pc": 16.0, "em": 16.0, "ex": 8.0}
_LENGTH = re.compile(rf"\s*({_NUMBER.pattern})\s*([a-z]*|%)\s*$")


def _length(element, name: str, axis: str, viewport, path, default: str = "0") -> float:
    """A length attribute in user units: a number with an optional unit (`em` and `ex`
    at the initial font size, 16 px), or a percentage of the viewport's width (`x`),
    height (`y`) or normalised diagonal (`r`), SVG 1.1 section 7.10."""
    text = element.get(name, default)
    match = _LENGTH.match(text.lower())
    if match is None or match.group(2) not in (*_UNITS, "%"):
        raise fail(
            path,
            f"<{_tag(element)}> {name}={quote(text)} is not a length (a number, optionally "
            "with a unit: px, mm, cm, in, pt, pc, em, ex or %).",
        )
    value = float(match.group(1))
    if match.group(2) != "%":
        value *= _UNITS[match.group(2)]
    else:
        width, height = viewport
        value *= {"x": width, "y": height}.get(axis, math.hypot(width, height) / math.sqrt(2))
        value /= 100
    if not math.isfinite(value):
        raise fail(path, f"<{_tag(element)}> {name}={quote(text)} is not finite.")
    return value


def _tag(element) -> str:
    return css.local_name(element.tag)


def _line(p, q) -> list[Segment]:
    return [] if np.array_equal(p, q) else [("L", np.array([p, q], dtype=np.float64))]


def _arc(p, rx, ry, q) -> list[Segment]:
    arc = arc_segment(np.asarray(p, float), rx, ry, 0.0, False, True, np.asarray(q, float))
    return [] if arc is None else [arc]


def _basic_shape(element, tag: str, viewport, path) -> tuple[list[Segment], bool] | None:
    """The outline of `<rect>` (rounded too), `<circle>`, `<ellipse>` or `<line>` as
    segments (SVG 1.1 section 9), or None when it has no area or length to draw (a zero
    or negative size, which also disables rendering)."""
    length = lambda name, axis, default="0": _length(element, name, axis, viewport, path,
                                                     default)
    if tag == "line":
        p = np.array([length("x1", "x"), length("y1", "y")])
        q = np.array([length("x2", "x"), length("y2", "y")])
        return (_line(p, q), False) if not np.array_equal(p, q) else None
    if tag == "rect":
        x, y, w, h = length("x", "x"), length("y", "y"), length("width", "x"), length("height", "y")
        if w <= 0 or h <= 0:
            return None
        rx = length("rx", "x") if element.get("rx") is not None else None
        ry = length("ry", "y") if element.get("ry") is not None else None
        rx, ry = (rx if rx is not None else ry) or 0.0, (ry if ry is not None else rx) or 0.0
        rx, ry = min(max(rx, 0.0), w / 2), min(max(ry, 0.0), h / 2)
        corners = [(x + w, y), (x + w, y + h), (x, y + h), (x, y)]
        if rx == 0 or ry == 0:
            ring = [*corners, corners[0]]
            return [s for a, b in zip(ring, ring[1:]) for s in _line(np.array(a), np.array(b))], True
        points = [(x + rx, y), (x + w - rx, y), (x + w, y + ry), (x + w, y + h - ry),
                  (x + w - rx, y + h), (x + rx, y + h), (x, y + h - ry), (x, y + ry)]
        points = [np.array(p) for p in points]
        segments = []
        for k in range(4):
            segments += _line(points[2 * k], points[2 * k + 1])
            segments += _arc(points[2 * k + 1], rx, ry, points[(2 * k + 2) % 8])
        return segments, True
    cx, cy = length("cx", "x"), length("cy", "y")
    if tag == "circle":
        rx = ry = length("r", "r")
    else:
        rx, ry = length("rx", "x"), length("ry", "y")
    if rx <= 0 or ry <= 0:
        return None
    quarter = [np.array(p) for p in ((cx + rx, cy), (cx, cy + ry), (cx - rx, cy), (cx, cy - ry))]
    return [s for k in range(4) for s in _arc(quarter[k], rx, ry, quarter[(k + 1) % 4])], True


def _view_box(element, path) -> tuple[float, float, float, float] | None:
    """An element's `viewBox` (x, y, width, height), or None without one."""
    text = element.get("viewBox")
    if text is None or not text.strip():
        return None
    try:
        x, y, w, h = (float(v) for v in re.split(r"[\s,]+", text.strip()))
    except ValueError:
        raise fail(path, f"<{_tag(element)}> viewBox={quote(text)} is not four numbers.") from None
    if not (w > 0 and h > 0 and all(map(math.isfinite, (x, y, w, h)))):
        raise fail(path, f"<{_tag(element)}> viewBox={quote(text)} needs a positive, finite "
                   "width and height.")
    return x, y, w, h


_ALIGN = re.compile(r"(?:defer\s+)?(none|x(min|mid|max)y(min|mid|max))(?:\s+(meet|slice))?\s*$")


def _viewbox_transform(element, width: float, height: float, path) -> tuple[np.ndarray, tuple]:
    """The transform of a nested `<svg>`'s or a `<symbol>`'s `viewBox` into a viewport
    of `width` x `height` by its `preserveAspectRatio` (SVG 1.1, 7.8: `none` stretches;
    otherwise one scale, the smaller (`meet`, the default) or the larger (`slice`), and
    the box aligned at min, mid or max on each axis), and the viewport size that
    percentages inside then refer to."""
    box = _view_box(element, path)
    if box is None:
        return np.eye(3), (width, height)
    x, y, w, h = box
    text = (element.get("preserveAspectRatio") or "xMidYMid meet").strip().lower()
    match = _ALIGN.match(text)
    if match is None:
        raise fail(path, f"<{_tag(element)}> preserveAspectRatio={quote(text)} is not an "
                   "alignment such as xMidYMid meet, xMinYMin slice or none.")
    sx, sy = width / w, height / h
    if match.group(1) != "none":
        sx = sy = max(sx, sy) if match.group(4) == "slice" else min(sx, sy)
    at = {"min": 0.0, "mid": 0.5, "max": 1.0}
    m = np.diag([sx, sy, 1.0])
    m[:2, 2] = [-x * sx, -y * sy]
    if match.group(1) != "none":
        m[0, 2] += at[match.group(2)] * (width - w * sx)
        m[1, 2] += at[match.group(3)] * (height - h * sy)
    return m, (w, h)


def _translate(x: float, y: float) -> np.ndarray:
    m = np.eye(3)
    m[:2, 2] = [x, y]
    return m


#: The most elements one read may visit, counting each `<use>` instance of them (a few
#: nested `<use>`s of groups of `<use>`s can instantiate billions); about 3 s of work.
_MAX_ELEMENTS = 250_000

_XLINK_HREF = "{http://www.w3.org/1999/xlink}href"


def _root_viewport(root, path) -> tuple[float, float]:
    """The size percentages of the root's children refer to: its viewBox's, else its
    width and height (default 100%, of an unknown window: taken as 100 x 100)."""
    box = _view_box(root, path)
    if box is not None:
        return box[2], box[3]
    size = []
    for name, axis in (("width", "x"), ("height", "y")):
        size.append(_length(root, name, axis, (100.0, 100.0), path, "100%"))
    return size[0], size[1]


def _viewport_size(element, use, viewport, path) -> tuple[float, float] | None:
    """The width and height of a nested `<svg>` or an instanced `<symbol>` (a `<use>`'s
    own, when given, override the `<svg>`'s: SVG 1.1, 5.6); None when one is zero
    (rendering disabled). Negative sizes are errors."""
    size = []
    for name, axis in (("width", "x"), ("height", "y")):
        source = use if use is not None and use.get(name) is not None else element
        value = _length(source, name, axis, viewport, path, "100%")
        if value < 0:
            raise fail(path, f"<{_tag(source)}> {name}={quote(source.get(name))} is negative; "
                       "a viewport's size must be positive.")
        size.append(value)
    return None if 0 in size else (size[0], size[1])


def _contours(root, matrix: np.ndarray, path, found: list) -> int:
    """The drawable contours under `root`, in document order; returns how many shapes
    were skipped because they draw nothing (`display: none`, `opacity: 0`, hidden, no
    fill and no stroke: e.g. the transparent background rectangle of matplotlib's
    icons, which is no outline anyone can see).

    Reads `<path>`, `<polygon>`, `<polyline>`, `<rect>`, `<circle>`, `<ellipse>` and
    `<line>`, inside groups, nested `<svg>`s (their viewBox) and `<use>` instances (of
    any element of the file, `<symbol>`s included), styled by the document's `<style>`
    sheets (`css`). The tree is walked with a stack, not by recursion, so any nesting
    depth works."""
    styled = css.cascade(root, css.parse_sheets(
        [e.text or "" for e in root.iter() if _tag(e) == "style" and css.applies(e)]))
    ids = {}
    for element in root.iter():
        if element.get("id"):
            ids.setdefault(element.get("id"), element)  # the first one, as the DOM does
    # (element, matrix, inherited style, viewport, instanced, use): `instanced` is the
    # linked list (element, rest) of the elements being drawn by `<use>`s (a reference
    # back into one is a cycle); `use` is the `<use>` drawing this element, if any.
    stack = [(root, matrix, _INITIAL, _root_viewport(root, path), None, None)]
    skipped = visited = 0
    while stack:
        element, matrix, inherited, viewport, instanced, use = stack.pop()
        visited += 1
        if visited > _MAX_ELEMENTS:
            raise fail(path, f"has more than {_MAX_ELEMENTS:,} elements to draw, counting "
                       "each <use> of them; simplify the drawing.")
        tag = _tag(element)
        if tag in _SKIP and not (tag == "symbol" and use is not None):
            continue
        own = _properties(element, styled)
        if own.get("display") == "none" or _zero(own.get("opacity", "1")):
            skipped += 1
            continue
        style = {**inherited, **{k: v for k, v in own.items() if k in _INHERITED}}
        matrix = matrix @ parse_transform(element.get("transform"), path)
        children = list(element)
        if tag in ("svg", "symbol") and element is not root:  # a viewport of its own
            size = _viewport_size(element, use, viewport, path)
            if size is None:
                continue
            if tag == "svg":
                matrix = matrix @ _translate(_length(element, "x", "x", viewport, path),
                                             _length(element, "y", "y", viewport, path))
            box, viewport = _viewbox_transform(element, *size, path)
            matrix = matrix @ box
        elif tag == "use":
            href = element.get("href") or element.get(_XLINK_HREF) or ""
            target = ids.get(href.strip().removeprefix("#")) if href.strip().startswith("#") \
                else None  # another file's element is not read
            link = instanced
            while link is not None and link[0] is not target:
                link = link[1]
            if target is not None and (link is not None or target is element):
                raise fail(path, f"<use> of {quote(href)} refers to an element that contains "
                           "it (a cycle).")
            if target is not None:
                matrix = matrix @ _translate(_length(element, "x", "x", viewport, path),
                                             _length(element, "y", "y", viewport, path))
                stack.append((target, matrix, style, viewport, (target, instanced), element))
            continue
        if tag in _DRAWN and not _draws(style, tag != "line"):
            skipped += 1
        else:
            outlines = _element_contours(element, tag, viewport, path)
            shape = found[-1][3] + 1 if found else 0  # this element's number
            found += [(segments, closed, matrix, shape) for segments, closed in outlines]
        if len(found) > common.MAX_CONTOURS:
            check_contours(path, len(found), counted=False)
        stack.extend((child, matrix, style, viewport, instanced, None)
                     for child in reversed(children))
    return skipped


def _element_contours(element, tag: str, viewport, path) -> list[tuple[list[Segment], bool]]:
    """The contours (segments, closed) an element draws, in its own coordinates."""
    if tag == "path" and (element.get("d") or "").strip():
        subpaths = []
        for segments, closed in parse_path(element.get("d"), path):
            # A subpath that returns exactly to its start without `Z` is closed too.
            returns = len(segments) > 1 and np.array_equal(_end(segments[-1]), segments[0][1][0])
            subpaths.append((segments, closed or returns))
        return subpaths
    if tag in ("polygon", "polyline") and (element.get("points") or "").strip():
        p = _points_attribute(element.get("points"), tag, path)
        closed = tag == "polygon" or (len(p) > 2 and np.array_equal(p[0], p[-1]))
        if closed and np.array_equal(p[0], p[-1]):
            p = p[:-1]
        ring = np.concatenate([p, p[:1]]) if closed else p
        return [([("L", ring[i : i + 2]) for i in range(len(ring) - 1)], closed)]
    if tag in _BASIC:
        outline = _basic_shape(element, tag, viewport, path)
        return [outline] if outline is not None and outline[0] else []
    return []


_BASIC = ("rect", "circle", "ellipse", "line")
_DRAWN = ("path", "polygon", "polyline", *_BASIC)


_FLIP = np.diag([1.0, -1.0, 1.0])


def _svg_root(path):
    """The parsed root `<svg>` element of the file, or a clear `OutlineError`."""
    try:
        root = ET.fromstring(read_bytes(path))
    except ET.ParseError as e:
        raise fail(path, f"is not valid XML/SVG ({one_line(e, 120)}).") from None
    if _tag(root) != "svg":
        raise fail(path, f"is not an SVG file (its root element is <{_tag(root)}>).")
    return root


def read_svg(path, samples) -> list[Outline]:
    """Every visible path and basic shape of an SVG file (see `_contours`), one outline
    per subpath, in document order, in the root's user coordinates (its transforms,
    nested viewBoxes and `<use>`s applied), y pointing up. Shapes that draw nothing (no
    fill and no stroke, transparent, hidden, `display: none`, from their attributes,
    the style sheets and `style`, or inherited from their groups) are skipped, as a
    renderer would. Each `<path>` and shape is one group (`Outline.group`)."""
    root = _svg_root(path)
    found = []
    with np.errstate(all="ignore"):  # overflow is checked on the sampled points
        skipped = _contours(root, _FLIP, path, found)
    if not found:
        raise fail(
            path, "has no contours: no <path>, <polygon>, <polyline>, <rect>, <circle>, "
            "<ellipse> or <line> with points to read"
            + (f" that draws anything ({skipped} shapes or groups with no visible fill "
               "or stroke, or hidden, were skipped)." if skipped else ".")
        )
    check_points(
        path,
        sum(
            3 * len(s) + 1  # nodes (a short loop's control points too), or vertices
            if samples == "nodes" or (samples is None and all(k == "L" for k, _ in s))
            else samples or DEFAULT_SAMPLES
            for s, *_ in found
        ),
    )
    outlines = []
    for i, (s, c, m, group) in enumerate(found):
        with np.errstate(all="ignore"):
            points = sample_contour(s, c, m, samples)
        if not np.all(np.isfinite(points)):
            raise fail(
                path,
                f"contour {i}: its coordinates overflow a float64 (after the transforms); "
                "scale the drawing down.",
            )
        outlines.append(make_outline(path, points, c, f"contour {i}", group))
    return outlines


def _number(value) -> str:
    return repr(float(value))


class Page(NamedTuple):
    """Where a written drawing goes: the root's size attributes (`width`, `height`,
    `viewBox`, ...) and the transform from jaxsubdiv's coordinates (y up) to the
    page's user coordinates. None: fitted around the drawing (see `_fitted_page`)."""

    attributes: dict
    transform: str


def page_like(like) -> Page:
    """The page of the SVG or PNG file `like`, so that what is written lies over it.

    SVG: the root's `width`, `height`, `viewBox` and `preserveAspectRatio`, and y
    flipped back (the reader's coordinates are the root's user coordinates with y
    negated). PNG: a `W x H` page in pixels; the reader puts pixel (r, c)'s center
    at (c, H - 1 - r), which is (c + 1/2, r + 1/2) on the page.
    """
    kind = str(like).lower().rsplit(".", 1)[-1]
    if kind == "png":
        width, height = png_size(like, read_bytes(like))
        return Page(
            {"width": str(width), "height": str(height), "viewBox": f"0 0 {width} {height}"},
            f"matrix(1 0 0 -1 0.5 {_number(height - 0.5)})",
        )
    if kind != "svg":
        raise fail(like, "`like` must be an .svg or .png file (whose page to take).")
    root = _svg_root(like)
    names = ("width", "height", "viewBox", "preserveAspectRatio")
    return Page({k: root.get(k) for k in names if root.get(k) is not None}, "scale(1,-1)")


def _fitted_page(points: np.ndarray) -> Page:
    """A page 400 px on its longer side around `points`, with a 5% margin."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    # In halves, so that extents up to twice the largest float64 do not overflow (the
    # same numbers as in full otherwise); a viewBox beyond it is clipped to the largest.
    half = hi / 2 - lo / 2
    size = float(max(half)) or 0.5
    pad = 0.05 * size
    box = np.array([lo[0] / 2 - pad, -hi[1] / 2 - pad, half[0] + 2 * pad, half[1] + 2 * pad])
    width = 400.0 * (box[2] / max(box[2], box[3]))
    height = 400.0 * (box[3] / max(box[2], box[3]))
    with np.errstate(over="ignore"):
        box = np.clip(2 * box, -np.finfo(float).max, np.finfo(float).max)
    attributes = {"width": f"{width:.1f}", "height": f"{height:.1f}",
                  "viewBox": " ".join(_number(v) for v in box)}
    return Page(attributes, "scale(1,-1)")


def _stroke_width(points: np.ndarray) -> str:
    """0.5% of the drawing's larger extent (in halves: no overflow)."""
    half = points.max(axis=0) / 2 - points.min(axis=0) / 2
    return _number(float(max(half)) / 100 or 0.005)


class Subpath(NamedTuple):
    """One contour to write: its path data (M, then L/Q/C, optionally Z), its points
    (for the page's extent and the finiteness check) and its shape."""

    data: str
    points: np.ndarray
    closed: bool
    group: int | None


def polyline_subpath(points: np.ndarray, closed: bool, group=None) -> Subpath:
    d = "M " + " L ".join(f"{_number(x)} {_number(y)}" for x, y in points)
    return Subpath(d + " Z" if closed else d, points, closed, group)


def bezier_subpath(beziers: np.ndarray, closed: bool, group=None) -> Subpath:
    """Bezier segments `(s, degree + 1, 2)`, each starting where the last one ends."""
    letter = {2: "L", 3: "Q", 4: "C"}[beziers.shape[1]]
    parts = [f"M {_number(beziers[0, 0, 0])} {_number(beziers[0, 0, 1])}"]
    for b in beziers:
        parts.append(letter + " " + " ".join(f"{_number(x)} {_number(y)}" for x, y in b[1:]))
    return Subpath(" ".join(parts) + (" Z" if closed else ""), beziers.reshape(-1, 2), closed,
                   group)


def _attribute(value: str) -> str:
    """`value` escaped for a double-quoted XML attribute."""
    return value.replace("&", "&amp;").replace("<", "&lt;").replace('"', "&quot;")


def write_drawing(path, subpaths: list[Subpath], like=None, what: str = "the curve") -> None:
    """An SVG file of the subpaths: one `<path>` per shape (subpaths of one `group`;
    a subpath whose group is None is a shape of its own), in order of first appearance.
    A shape of closed subpaths is filled black by the even-odd rule (its holes stay
    holes, whatever their orientation); one with an open subpath is stroked instead.
    The page is that of the file `like` (`page_like`), else fitted around the drawing.
    """
    points = np.concatenate([s.points for s in subpaths])
    if not np.all(np.isfinite(points)):
        raise fail(
            path,
            f"{what}'s coordinates overflow a float64 (or are NaN); scale the points down.",
        )
    page = _fitted_page(points) if like is None else page_like(like)
    shapes: dict = {}
    for k, s in enumerate(subpaths):
        shapes.setdefault((False, k) if s.group is None else (True, s.group), []).append(s)
    stroke = (f'fill="none" stroke="black" stroke-width="{_stroke_width(points)}" '
              'stroke-linejoin="round"')
    elements = [
        f'<path d="{" ".join(s.data for s in shape)}" '
        + ('fill="black" fill-rule="evenodd"' if all(s.closed for s in shape) else stroke)
        + "/>"
        for shape in shapes.values()
    ]
    root = " ".join(f'{k}="{_attribute(v)}"' for k, v in page.attributes.items())
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" version="1.1" {root}>',
        "<!-- written by jaxsubdiv.io: coordinates are jaxsubdiv's (y up); the group's "
        "transform puts them on the page -->",
        f'<g transform="{page.transform}">',
        *elements,
        "</g>",
        "</svg>",
    ]
    with open_for_writing(path) as f:
        f.write(("\n".join(lines) + "\n").encode())


def write_svg(path, outlines: list[Outline], like=None) -> None:
    """Outlines as polylines, one `<path>` per shape (see `write_drawing`)."""
    write_drawing(path, [polyline_subpath(o.points, o.closed, o.group) for o in outlines],
                  like, "the outlines")
