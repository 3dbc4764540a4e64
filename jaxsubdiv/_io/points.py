"""Point lists: CSV/TXT, NPY/NPZ and JSON."""

import io
import json
import math
import re
import zipfile

import numpy as np

from .common import (
    Outline,
    checked_points,
    fail,
    make_outline,
    open_for_writing,
    read_bytes,
    read_text,
)


_SEPARATORS = re.compile(r"[\s,;]+")
_CLOSED = re.compile(r"^closed\s*[:=]\s*(\w+)\s*$", re.IGNORECASE)
_TRUE = {"true": True, "yes": True, "1": True, "false": False, "no": False, "0": False}


def _number(token: str) -> float | None:
    try:
        return float(token)
    except ValueError:
        return None


def read_table(path) -> list[Outline]:
    """CSV or whitespace-separated text: one `x, y` pair per line.

    `#` starts a comment; the first line may be a header (a line with no number on it);
    separators are commas, semicolons, spaces or tabs. A comment `# closed: false` makes
    the outline it is in (or the next one) open; outlines are closed by default. Blank
    lines separate outlines, so several contours can share one file.
    """
    blocks, current, closed, pending = [], [], True, None
    seen_data = False

    def finish():
        nonlocal current, closed, pending
        if current:
            blocks.append(make_outline(path, current, closed, "an outline"))
            current, closed = [], True
        if pending is not None:
            closed, pending = pending, None

    for number, raw in enumerate(read_text(path).splitlines(), start=1):
        text, _, comment = raw.partition("#")
        directive = _CLOSED.match(comment.strip())
        if directive:
            value = _TRUE.get(directive.group(1).lower())
            if value is None:
                raise fail(
                    path, f"`closed:` must be true or false, got {directive.group(1)!r}.", number
                )
            if current:
                closed = value
            else:
                pending = value
        text = text.strip()
        if not text:
            if not raw.strip():
                finish()
            continue
        if pending is not None:
            closed, pending = pending, None
        tokens = [t for t in _SEPARATORS.split(text) if t]
        values = [_number(t) for t in tokens]
        if not seen_data and all(v is None for v in values):
            seen_data = True  # a header line
            continue
        seen_data = True
        if len(tokens) != 2:
            raise fail(path, f"expected 2 values (x, y), got {len(tokens)}: {text!r}.", number)
        for token, value in zip(tokens, values):
            if value is None:
                raise fail(path, f"{token!r} is not a number.", number)
            if not math.isfinite(value):
                raise fail(path, f"{token!r} is not a finite number.", number)
        current.append(values)
    finish()
    if not blocks:
        raise fail(path, "no points (only comments or a header).")
    return blocks


def write_table(path, outlines: list[Outline], kind: str) -> None:
    separator = ", " if kind == "csv" else " "
    lines = ["# x, y" if kind == "csv" else "# x y", "# written by jaxsubdiv.io"]
    for i, outline in enumerate(outlines):
        if i:
            lines.append("")
        lines.append(f"# closed: {'true' if outline.closed else 'false'}")
        lines += [separator.join(repr(float(v)) for v in p) for p in outline.points]
    with open_for_writing(path) as f:
        f.write(("\n".join(lines) + "\n").encode())


def _numeric(path, array, what: str) -> np.ndarray:
    if not (np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)):
        raise fail(path, f"{what} holds values of type {array.dtype}, not real numbers.")
    return array


def read_npy(path) -> list[Outline]:
    """An array of shape `(m, 2)` (one closed outline) or `(k, m, 2)` (k of them)."""
    try:
        array = np.load(io.BytesIO(read_bytes(path)), allow_pickle=False)
    except ValueError as e:
        raise fail(path, f"is not a readable .npy file ({e}).") from None
    if not isinstance(array, np.ndarray):
        raise fail(path, "is a .npz archive, not a .npy file; name it .npz.")
    array = _numeric(path, array, "the array")
    if array.ndim == 3:
        return [make_outline(path, a, True, f"outline {i}") for i, a in enumerate(array)]
    return [make_outline(path, array, True, "the array")]


def read_npz(path) -> list[Outline]:
    """An archive written by `write_outlines`, or any archive with one `(m, 2)` array.

    `write_outlines` stores `points` and `closed` for one outline, `points_0`,
    `points_1`, ... and a boolean array `closed` for several.
    """
    try:
        archive = np.load(io.BytesIO(read_bytes(path)), allow_pickle=False)
    except (ValueError, zipfile.BadZipFile) as e:
        raise fail(path, f"is not a readable .npz archive ({e}).") from None
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise fail(path, "is a .npy file, not a .npz archive; name it .npy.")
    with archive:
        keys = list(archive.keys())
        indexed = sorted((int(k[7:]), k) for k in keys if re.fullmatch(r"points_\d+", k))
        if "points" in keys:
            names = ["points"]
        elif indexed:
            names = [k for _, k in indexed]
        elif len(keys) == 1:
            names = keys
        else:
            raise fail(path, f"expected an array named 'points' (or points_0, ...), found {keys}.")
        closed = np.ones(len(names), bool)
        if "closed" in keys:
            flags = np.atleast_1d(archive["closed"])
            if flags.dtype != bool or len(flags) != len(names):
                raise fail(path, f"'closed' must hold {len(names)} booleans, got {flags!r}.")
            closed = flags
        return [
            make_outline(path, _numeric(path, archive[n], n), bool(c), repr(n))
            for n, c in zip(names, closed)
        ]


def write_npy(path, outlines: list[Outline]) -> None:
    if len(outlines) != 1:
        raise fail(
            path,
            f"a .npy file holds one outline, got {len(outlines)}; use .npz, .json, .csv or .svg.",
        )
    with open_for_writing(path) as f:
        np.save(f, outlines[0].points, allow_pickle=False)


def write_npz(path, outlines: list[Outline]) -> None:
    closed = np.array([o.closed for o in outlines])
    if len(outlines) == 1:
        arrays = {"points": outlines[0].points, "closed": closed}
    else:
        arrays = {f"points_{i}": o.points for i, o in enumerate(outlines)} | {"closed": closed}
    with open_for_writing(path) as f:
        np.savez(f, **arrays)


def load_json(path):
    try:
        return json.loads(read_text(path))
    except json.JSONDecodeError as e:
        raise fail(path, f"is not valid JSON: {e.msg} (column {e.colno}).", e.lineno) from None


def json_points(path, value, what: str) -> np.ndarray:
    if not isinstance(value, list):
        raise fail(path, f"{what} must be a list of [x, y] pairs.")
    for i, p in enumerate(value):
        if not isinstance(p, list) or len(p) != 2:
            raise fail(path, f"{what}[{i}] must be a pair [x, y], got {json.dumps(p)}.")
        for v in p:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise fail(path, f"{what}[{i}] holds {json.dumps(v)}, which is not a number.")
    return checked_points(path, np.array(value, dtype=np.float64).reshape(-1, 2), what)


def _json_outline(path, value, what: str) -> Outline:
    if isinstance(value, list):
        return make_outline(path, json_points(path, value, what), True, what)
    if not isinstance(value, dict) or "points" not in value:
        raise fail(path, f'{what} must be {{"points": [[x, y], ...], "closed": true}}.')
    closed = value.get("closed", True)
    if not isinstance(closed, bool):
        raise fail(path, f'{what}["closed"] must be true or false, got {json.dumps(closed)}.')
    return make_outline(path, json_points(path, value["points"], f'{what}["points"]'), closed, what)


def read_json(path) -> list[Outline]:
    """`{"points": [[x, y], ...], "closed": true}`, a bare list of pairs, or
    `{"outlines": [{"points": ..., "closed": ...}, ...]}` for several."""
    data = load_json(path)
    if isinstance(data, dict) and "outlines" in data:
        items = data["outlines"]
        if not isinstance(items, list) or not items:
            raise fail(path, '"outlines" must be a non-empty list.')
        return [_json_outline(path, item, f'"outlines"[{i}]') for i, item in enumerate(items)]
    return [_json_outline(path, data, "the file")]


def write_json(path, outlines: list[Outline]) -> None:
    items = [{"points": o.points.tolist(), "closed": o.closed} for o in outlines]
    data = items[0] if len(items) == 1 else {"outlines": items}
    with open_for_writing(path) as f:
        f.write(json.dumps(data).encode())
