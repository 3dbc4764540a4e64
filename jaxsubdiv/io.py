"""Reading outlines and writing outlines, curves and fit results.

Outlines (the data a curve is fitted to) come from point lists (CSV/TXT, NPY/NPZ, JSON),
vector drawings (SVG), a text glyph (any font matplotlib can find) or a silhouette image
(PNG). Curves are written as SVG, with exact Bezier segments where the limit curve is a
uniform B-spline. Fit results are written as JSON that rebuilds the scheme and the
control polygon. Every problem with a file is an [`jaxsubdiv.io.OutlineError`][] with a
one-line message that names the file and says what is wrong.

Reading is bounded in memory and time before anything large is allocated: a file may
have at most `MAX_FILE_BYTES` bytes (64 MiB), `MAX_CONTOURS` contours (10,000) and
`MAX_POINTS` points in all (about 16.8 million, counting resampled ones); a PNG at most
`MAX_PIXELS` pixels (25 million), read from its header before it is decoded; an NPY
array, or the NPZ members read, at most `MAX_ARRAY_BYTES` (256 MiB) as float64 and, for
NPZ, as declared uncompressed sizes, checked before decompressing. Beyond a limit the
read fails with an `OutlineError` that gives the size, the limit and what to do. (The
constants here document the limits; the readers do not read them back, so assigning to
them changes nothing.)

Coordinates are y-up everywhere; SVG and PNG (y-down) are flipped on the way in and out.
"""

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np
from jaxtyping import ArrayLike, Float

from ._io.common import (
    DEFAULT_SAMPLES as DEFAULT_SAMPLES,
    MAX_ARRAY_BYTES as MAX_ARRAY_BYTES,
    MAX_CONTOURS as MAX_CONTOURS,
    MAX_FILE_BYTES as MAX_FILE_BYTES,
    MAX_PIXELS as MAX_PIXELS,
    MAX_POINTS as MAX_POINTS,
    Outline as Outline,
    OutlineError as OutlineError,
    check_contours,
    check_path,
    check_points,
    check_samples,
    fail,
    make_outline,
    resample_polyline,
)
from ._io.curve import (
    bezier_segments,
    bspline_degree,
    creased_bezier_segments,
    dense_curve,
)
from ._io.points import (
    load_json as _load_json,
    read_json,
    read_npy,
    read_npz,
    read_table,
    write_json,
    write_npy,
    write_npz,
    write_table,
)
from ._io.raster import read_glyph, read_image
from ._io.result import (
    FORMAT as _RESULT_FORMAT,
    SavedResult as SavedResult,
    read_result_json as _read_result,
    write_result_json as _write_result,
)
from ._io.svg import (
    bezier_subpath,
    polyline_subpath,
    read_svg,
    write_drawing,
    write_svg,
)
from ._refine import _check_boundary
from ._scheme.base import AbstractCurveScheme


#: The file kinds `read_outlines` and `write_outlines` know, by file extension.
KINDS = ("csv", "txt", "npy", "npz", "json", "svg", "png")
_WRITABLE = ("csv", "txt", "npy", "npz", "json", "svg")


def _kind(path, kind, allowed) -> str:
    if kind is None:
        kind = Path(path).suffix.lstrip(".").lower()
        if kind not in allowed:
            raise fail(
                path,
                f"cannot tell the format from the extension {Path(path).suffix!r}; name "
                f"the file with one of {', '.join('.' + k for k in allowed)} (or, from "
                "Python, pass `kind=`).",
            )
        return kind
    if kind not in allowed:
        raise fail(path, f"unknown kind {kind!r}; expected one of {', '.join(allowed)}.")
    return kind


def read_outlines(
    path: str | os.PathLike | None = None,
    *,
    kind: Literal["csv", "txt", "npy", "npz", "json", "svg", "png"] | None = None,
    samples: int | None = None,
    text: str | None = None,
    font: str | None = None,
    threshold: float = 0.5,
    nodes: bool = False,
) -> list[Outline]:
    """Read the outlines (contours) of a file, or of a text glyph.

    Use it to get the target of a fit from whatever the user has. Several contours in one
    input (the letter "o", a drawing with several paths) come back as several outlines,
    each to be fitted separately.

    **Arguments:**

    - `path`: the file. The format comes from its extension (`.csv`, `.txt`, `.npy`,
      `.npz`, `.json`, `.svg`, `.png`) unless `kind` is given:
        - CSV/TXT: `x, y` per line (commas, semicolons or whitespace), `#` comments, an
          optional header line. Blank lines separate outlines; a comment
          `# closed: false` marks an open one.
        - NPY: an `(m, 2)` array (or `(k, m, 2)` for k outlines), closed. NPZ: as
          written by `write_outlines`, or any archive with a single `(m, 2)` array.
        - JSON: `{"points": [[x, y], ...], "closed": true}` (optionally with
          `"group": k`), a bare list of pairs, or `{"outlines": [...]}` of such
          objects; or a saved result (`write_result_json`: `jaxsubdiv fit -o x.json`,
          the editor's saved JSON), read as its curve, the control polygon refined
          with the saved scheme, boundary, creases and levels (`RESULT_LEVELS` = 6 if
          none), and with `nodes=True` as its control polygon.
        - SVG: every `<path>` (all commands of SVG 1.1, absolute and relative;
          arcs by the specification's endpoint-to-center conversion), `<polygon>`,
          `<polyline>`, `<rect>` (rounded too), `<circle>`, `<ellipse>` and `<line>`,
          in groups, nested `<svg>` viewports and `<use>` instances (of any element or
          `<symbol>`), with their `transform`s and lengths in any unit; one outline per
          subpath, in the root's user coordinates. A subpath is closed if it ends with
          `Z` or returns exactly to its start. Shapes that draw nothing (no fill and no
          stroke, transparent, hidden, `display: none`) are skipped, as decided by
          their own or inherited attributes, `style`, and the `<style>` sheets' rules
          with simple selectors (type, class, id, descendant and child; not `@media`).
          Each `<path>` or shape is one `group`. Not applied: `clip-path`, masks,
          `<use>` of another file; `em`/`ex` are taken at 16/8 px.
        - PNG: the contours of a silhouette and its holes (see `threshold`), in pixels.
    - `kind`: the format, overriding the extension.
    - `samples`: points per outline, spaced equally by arc length. Curved SVG
      segments and glyphs are sampled exactly on the curve (default
      `DEFAULT_SAMPLES` = 400); point lists, polygons and PNG contours are resampled
      along their polyline only if `samples` is given (else kept as they are).
    - `text`: instead of `path`, the characters whose glyph outlines to read, e.g.
      `"&"`; the font size is 1.
    - `font`: with `text`, a font family known to matplotlib's font manager or a font
      file; default matplotlib's default font (DejaVu Sans).
    - `nodes`: for SVG and glyphs, each contour's nodes (the points where its segments
      meet, as a vector editor shows them; Bezier handles are not nodes, so a circle
      drawn as four arcs is four points) instead of points sampled on its curves: the
      polygon the drawing was made on, e.g. to refine it. A closed contour of one or
      two curves adds their control points (and two inner points of each arc), to
      make a polygon. Point lists and PNG contours are their own nodes. Not with
      `samples`.
    - `threshold`: for PNG, the gray level (or alpha level, for an image whose alpha
      channel holds the silhouette) between 0 and 1 that separates the silhouette from
      the background. Which side is the background is decided by the image border. An
      alpha channel that puts under 0.1% of the pixels on the silhouette's side (only a
      few pixels partly transparent) is not the silhouette; the luminance is read.

    **Returns:** a list of [`jaxsubdiv.io.Outline`][] (`points` `(m, 2)`, `closed`, and
    the `group` of contours that make one shape), at least one.

    **Raises:** [`jaxsubdiv.io.OutlineError`][] for a missing, unreadable, empty or
    malformed file, one with no contours, or one beyond a limit of this module
    (`MAX_FILE_BYTES`, `MAX_CONTOURS`, `MAX_POINTS`, `MAX_PIXELS`, `MAX_ARRAY_BYTES`;
    a JSON file nested deeper than Python's recursion limit; a text of more than
    `MAX_CONTOURS` characters), with the file (and line) and the problem in one line.
    `ValueError` or `TypeError` for a bad argument (`samples` above `MAX_POINTS`, ...).
    """
    samples = check_samples(samples)
    if not isinstance(nodes, (bool, np.bool_)):
        raise TypeError(f"`nodes` must be True or False, got {nodes!r}.")
    if nodes and samples is not None:
        raise ValueError("pass `nodes=True` or `samples`, not both: nodes are not resampled.")
    if text is not None:
        if path is not None:
            raise ValueError("pass either `path` or `text=`, not both.")
        return read_glyph(text, font=font, samples="nodes" if nodes else samples)
    if path is None:
        raise ValueError("pass a file `path`, or `text=` for a glyph.")
    check_path(path)
    if font is not None:
        raise ValueError("`font` is only used with `text=`.")
    kind = _kind(path, kind, KINDS)
    if kind == "svg":
        return _at_least_one(path, read_svg(path, "nodes" if nodes else samples))
    if kind == "png":
        return _at_least_one(path, read_image(path, threshold=threshold, samples=samples))
    reader = {
        "csv": read_table,
        "txt": read_table,
        "npy": read_npy,
        "npz": read_npz,
        "json": read_json,
    }[kind]
    outlines = _saved_result_outlines(path, nodes) if kind == "json" else reader(path)
    check_contours(path, len(outlines))
    if samples is not None:
        check_points(path, samples * len(outlines))
        outlines = [
            Outline(resample_polyline(o.points, samples, o.closed), o.closed) for o in outlines
        ]
    return outlines


#: The refinement levels of a saved result's curve when the file has none.
RESULT_LEVELS = 6


def _saved_result_outlines(path, nodes: bool) -> list[Outline]:
    """A JSON file's outlines: a point list's (`read_json`), or a saved result's
    (`write_result_json`: the command's `fit -o x.json`, the editor's saved JSON), its
    curve (the control polygon refined with the saved scheme, boundary, creases and
    levels) or, with `nodes`, its control polygon."""
    if not _is_result(path):
        return read_json(path)
    saved = _read_result(path)
    closed = saved.boundary == "closed"
    if nodes:
        return [Outline(np.asarray(saved.control_points, np.float64), closed)]
    from ._refine import refine

    levels = RESULT_LEVELS if saved.levels is None else saved.levels
    curve = refine(np.asarray(saved.control_points, np.float64), saved.scheme, levels,
                   boundary=saved.boundary, creases=saved.creases or None)
    return [Outline(np.asarray(curve, np.float64), closed)]


def _is_result(path) -> bool:
    """Whether the JSON file is a saved result (its "format" says so)."""
    data = _load_json(path)
    return isinstance(data, dict) and data.get("format") == _RESULT_FORMAT


def _at_least_one(path, outlines: list[Outline]) -> list[Outline]:
    check_contours(path, len(outlines))
    return outlines


def _is_array(value) -> bool:
    return hasattr(value, "shape") and hasattr(value, "dtype")


def write_outlines(
    path: str | os.PathLike,
    outlines: list[Outline],
    *,
    kind: Literal["csv", "txt", "npy", "npz", "json", "svg"] | None = None,
    like: str | os.PathLike | None = None,
) -> None:
    """Write outlines in any format `read_outlines` reads (except PNG).

    Numbers are written in full precision, so reading the file back gives the same
    numbers. A `.npy` file holds one outline and no `closed` flag (it reads back
    closed); the other formats hold several and keep the flag. SVG gets one `<path>`
    of polylines per shape (the outlines of one `group`, see
    [`jaxsubdiv.io.Outline`][]; an outline without a group is a shape of its own),
    filled by the even-odd rule when all its outlines are closed, else stroked.

    **Arguments:**

    - `path`: the file; the format comes from its extension unless `kind` is given.
    - `outlines`: a list of [`jaxsubdiv.io.Outline`][] and `(m, 2)` arrays (NumPy, JAX or
      nested lists); an array is a closed outline, as `Outline(points)`. A single
      `Outline` or `(m, 2)` array is one outline.
    - `kind`: the format, overriding the extension.
    - `like`: for SVG, the SVG or PNG file the outlines came from, whose page and
      coordinates to take (as for [`jaxsubdiv.io.write_curve_svg`][]).

    **Raises:** `TypeError` if `outlines` is not a list (or other sequence) of them;
    `ValueError` if it is empty; [`jaxsubdiv.io.OutlineError`][] for points that are
    not a finite `(m, 2)` array of at least 2 points (naming the file and the outline)
    or a file that cannot be written.
    """
    check_path(path)
    kind = _kind(path, kind, _WRITABLE)
    if isinstance(outlines, Outline) or _is_array(outlines):
        outlines = [outlines]
    elif isinstance(outlines, (str, bytes, dict)) or not hasattr(outlines, "__iter__"):
        raise TypeError(
            "`outlines` must be a list of Outline or (m, 2) arrays, got "
            f"{type(outlines).__name__}."
        )
    outlines = list(outlines)
    if not outlines:
        raise ValueError("`outlines` is empty: nothing to write.")
    if like is not None and kind != "svg":
        raise ValueError(f"`like` is only used for SVG files, not {kind.upper()}.")
    outlines = [
        make_outline(path, o.points, o.closed, f"outline {i}", o.group)
        if isinstance(o, Outline)
        else make_outline(path, o, True, f"outline {i}")
        for i, o in enumerate(outlines)
    ]
    if kind in ("csv", "txt"):
        write_table(path, outlines, kind)
    elif kind == "npy":
        write_npy(path, outlines)
    elif kind == "npz":
        write_npz(path, outlines)
    elif kind == "json":
        write_json(path, outlines)
    else:
        write_svg(path, outlines, like)


def write_points(
    path: str | os.PathLike,
    points: Float[ArrayLike, "m 2"],
    *,
    closed: bool = True,
    kind: Literal["csv", "txt", "npy", "npz", "json", "svg"] | None = None,
) -> None:
    """Write one polygon or polyline, e.g. a control polygon or the samples of a curve.

    Shorthand for `write_outlines(path, [Outline(points, closed)], kind=kind)`.
    """
    if not isinstance(closed, (bool, np.bool_)):
        raise TypeError(f"`closed` must be True or False, got {closed!r}.")
    write_outlines(path, [Outline(points, bool(closed))], kind=kind)


def write_curve_svg(
    path: str | os.PathLike,
    control_points: Float[ArrayLike, "n 2"] | list[Float[ArrayLike, "_ 2"]],
    scheme: AbstractCurveScheme | list[AbstractCurveScheme],
    *,
    boundary: Literal["closed", "open", "clamped"] | list[str] = "closed",
    levels: int | None = None,
    groups: list[int | None] | None = None,
    like: str | os.PathLike | None = None,
    creases: Sequence[int] | list[Sequence[int] | None] | None = None,
) -> bool:
    """Write the limit curve of a control polygon, or of several, as one SVG file.

    When the limit curve is a uniform B-spline of degree at most 3 (the mask is
    $\\binom{d+1}{k}/2^d$: [`jaxsubdiv.CubicBSpline`][], [`jaxsubdiv.Chaikin`][],
    `LaneRiesenfeld(1, 2 or 3)`, ...) its path is the exact curve: one cubic (or
    quadratic, or straight) Bezier segment per span, for every boundary. Otherwise it is
    a dense polyline through exact limit points ([`jaxsubdiv.limit_points`][] of
    `refine(control_points, scheme, levels)`).

    Several curves are the subpaths of one shape (a glyph's outer contour and its
    holes), written as one `<path>` filled by the even-odd rule, so that a vector
    editor opens the fitted shape with its holes; a shape with an open curve is stroked
    instead of filled. `groups` splits the curves into several shapes.

    **Arguments:**

    - `path`: the SVG file to write.
    - `control_points`: the control polygon, `(n, 2)`, or a list of them (or a
      `(k, n, 2)` array of k).
    - `scheme`: the subdivision scheme, or a list of them, one per polygon.
    - `boundary`: `"closed"`, `"open"` or `"clamped"`, as for [`jaxsubdiv.refine`][];
      or a list of them, one per polygon.
    - `levels`: refinement levels for the polylines (default: enough for about 2048
      points); not used for exact curves.
    - `groups`: with several polygons, the shape each belongs to (an int, or None for a
      shape of its own; see [`jaxsubdiv.io.Outline`][]'s `group`): one `<path>` per
      shape. Default: all in one shape.
    - `like`: the SVG or PNG file the outline came from. The file written takes its
      page (`width`, `height`, `viewBox`; a PNG's pixels) and puts the curves in its
      coordinates, so that they lie exactly over the input in a vector editor.
      Default: a page fitted around the curves.
    - `creases`: a closed curve's creased control points (indices, as for
      [`jaxsubdiv.refine`][]; a `fitting.FitResult`'s `np.flatnonzero(result.creases)`),
      or a list of them (or None) per polygon: the curve is cut there into clamped
      pieces, exact Bezier segments for uniform B-splines as above.

    **Returns:** True when the file holds the exact curves (Bezier segments), False
    when some curve is a polyline.
    """
    check_path(path)
    polygons = _polygons(control_points)
    count = len(polygons)

    def per_curve(value, name, single):
        if not isinstance(value, (list, tuple)):
            return [value] * count
        if len(value) != count:
            raise ValueError(
                f"`{name}` must be one {single} or a list of one per control polygon "
                f"({count}), got a list of {len(value)}."
            )
        return list(value)

    schemes = per_curve(scheme, "scheme", "scheme")
    boundaries = per_curve(boundary, "boundary", "boundary")
    if creases is None or len(creases) == 0:
        crease_lists = [None] * count
    elif all(isinstance(c, (int, np.integer)) for c in creases):  # one polygon's indices
        if count != 1:
            raise ValueError(
                f"`creases` must be a list of one index list (or None) per control polygon "
                f"({count}), got one list of indices."
            )
        crease_lists = [list(creases)]
    else:
        crease_lists = per_curve(list(creases), "creases", "list of indices")
    if groups is None:
        groups = [0] * count
    elif not isinstance(groups, (list, tuple)) or len(groups) != count:
        raise ValueError(
            f"`groups` must be a list of one int (or None) per control polygon ({count})."
        )
    for g in groups:
        if g is not None and (isinstance(g, bool) or not isinstance(g, (int, np.integer))):
            raise TypeError(f"`groups` must hold ints or None, got {g!r}.")
    subpaths, exact = [], True
    for i, (polygon, scheme, boundary, group, creased) in enumerate(
        zip(polygons, schemes, boundaries, groups, crease_lists)
    ):
        what = "the control points" if count == 1 else f"control polygon {i}"
        points = make_outline(path, polygon, False, what).points
        boundary = _check_boundary(boundary, scheme)
        closed = boundary == "closed"
        creased = None if creased is None or len(creased) == 0 else list(creased)
        if creased is not None and not closed:
            raise ValueError(f"`creases` of {what} need boundary='closed', got {boundary!r}.")
        degree = bspline_degree(scheme)
        minimum = {1: 2, 2: 3, 3: 4}.get(degree, 0) if boundary == "open" else 2
        if degree is not None and len(points) >= minimum:
            with np.errstate(over="ignore", invalid="ignore"):  # checked by write_drawing
                beziers = (bezier_segments(points, degree, boundary) if creased is None
                           else creased_bezier_segments(points, degree, creased))
            subpaths.append(bezier_subpath(beziers, closed, group))
        else:
            curve = dense_curve(points, scheme, boundary, levels, creased)
            subpaths.append(polyline_subpath(curve, closed, group))
            exact = False
    write_drawing(path, subpaths, like, "the curve")
    return exact


def _polygons(control_points) -> list:
    """One control polygon (an `(n, 2)` array or nested list) as a list of one; a list
    or tuple of them, or a `(k, n, 2)` array, as a list of k."""
    if _is_array(control_points):
        several = np.ndim(control_points) == 3
    elif isinstance(control_points, (list, tuple)):
        if not control_points:
            raise ValueError("`control_points` is empty: no curve to write.")
        try:
            several = np.ndim(control_points[0]) == 2
        except ValueError:  # a ragged first polygon: several, checked one by one
            several = True
    else:
        several = False
    return list(control_points) if several else [control_points]


def write_result_json(path: str | os.PathLike, result, *, info: dict | None = None) -> None:
    """Save a fit so that it can be reproduced and its curve redrawn.

    The file records the scheme (its class and constructor arguments, e.g. the fitted
    `w`), the boundary and levels, the control points, the error measures, and the
    solver's status, message and number of steps (and, of a fit with `fit_params`,
    `params_held`: whether the parameters were kept at their start, `FitResult`), all
    under `info`; and a closed curve's creases (a fit
    with corners: `creases`, indices or a boolean mask), as format version 2, which
    readers of version 1 refuse rather than draw the curve without its corners.

    **Arguments:**

    - `path`: the JSON file to write.
    - `result`: a single (not batched) `fitting.FitResult`, or a dict with at least
      `control_points` and `scheme` and optionally `boundary`, `levels`, `errors` (a
      dict of numbers) and anything else JSON can hold (saved under `info`).
    - `info`: more JSON values to save, such as the run's input file and options.
    """
    check_path(path)
    _write_result(path, result, info=info)


def read_result_json(path: str | os.PathLike) -> SavedResult:
    """Read a file written by [`jaxsubdiv.io.write_result_json`][].

    **Returns:** a [`jaxsubdiv.io.SavedResult`][] with the rebuilt scheme, the control
    points, boundary, levels, errors and the other saved information.
    """
    check_path(path)
    return _read_result(path)
