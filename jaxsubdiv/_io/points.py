"""Point lists: CSV/TXT, NPY/NPZ and JSON."""

import io
import json
import math
import re
import struct
import zipfile
import zlib

import numpy as np

from . import common
from .common import (
    Outline,
    check_contours,
    checked_points,
    fail,
    make_outline,
    one_line,
    open_for_writing,
    quote,
    read_bytes,
    read_text,
    size_text,
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
            if len(blocks) == common.MAX_CONTOURS:
                check_contours(path, len(blocks) + 1, counted=False)
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
                got = quote(directive.group(1))
                raise fail(path, f"`closed:` must be true or false, got {got}.", number)
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
            raise fail(
                path, f"expected 2 values (x, y), got {len(tokens)}: {quote(text, 60)}.", number
            )
        for token, value in zip(tokens, values):
            if value is None:
                raise fail(path, f"{quote(token)} is not a number.", number)
            if not math.isfinite(value):
                raise fail(path, f"{quote(token)} is not a finite number.", number)
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


_NPY_MAGIC = b"\x93NUMPY"


def _is_real(dtype: np.dtype) -> bool:
    return np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.floating)


def _npy_array(
    path, data: bytes, what: str, kind: str = ".npy file", used: int = 0, bools: bool = False
) -> np.ndarray:
    """The array of the NPY bytes `data`, read from its header first: the data the header
    claims must be in `data` and, as float64 and with `used` bytes of arrays already
    read, within `MAX_ARRAY_BYTES`, before any of it is used. The array is a read-only
    view of `data` (nothing is allocated)."""
    stream = io.BytesIO(data)
    try:
        version = np.lib.format.read_magic(stream)
        if version not in ((1, 0), (2, 0), (3, 0)):
            raise ValueError(f"unsupported format version {version}")
        # Versions 2.0 and 3.0 have the same layout (3.0 allows UTF-8 field names).
        read_header = (
            np.lib.format.read_array_header_1_0
            if version == (1, 0)
            else np.lib.format.read_array_header_2_0
        )
        shape, fortran_order, dtype = read_header(stream)
    except MemoryError:
        raise
    except Exception as e:  # numpy's header parser raises many types for a bad header
        raise fail(path, f"{what} is not a readable {kind} ({one_line(e, 120)}).") from None
    if dtype.hasobject or not (_is_real(dtype) or bools and dtype == np.bool_):
        raise fail(path, f"{what} holds values of type {one_line(dtype, 60)}, not real numbers.")
    if len(shape) > 3 or any(d < 0 for d in shape):
        raise fail(path, f"{what} has shape {shape}, not (m, 2) or (k, m, 2).")
    count = math.prod(shape)
    offset = stream.tell()
    claimed, held = count * dtype.itemsize, len(data) - offset
    if claimed > held:
        raise fail(
            path,
            f"{what} claims shape {shape} ({size_text(claimed)}) but holds only "
            f"{size_text(held)} of data: the file is truncated or corrupt.",
        )
    if used + count * 8 > common.MAX_ARRAY_BYTES:
        raise fail(
            path,
            f"{what} has shape {shape}: {size_text(used + count * 8)} as float64"
            f"{' with the arrays before it' if used else ''}, more than the "
            f"{size_text(common.MAX_ARRAY_BYTES)} limit (jaxsubdiv.io.MAX_ARRAY_BYTES); "
            "thin out the points or split the array.",
        )
    array = np.frombuffer(data, dtype=dtype, count=count, offset=offset)
    return array.reshape(shape, order="F" if fortran_order else "C")


def _array_outlines(path, array: np.ndarray, what: str) -> list[Outline]:
    if array.ndim == 3:
        check_contours(path, len(array))
        return [make_outline(path, a, True, f"outline {i}") for i, a in enumerate(array)]
    return [make_outline(path, array, True, what)]


def read_npy(path) -> list[Outline]:
    """An array of shape `(m, 2)` (one closed outline) or `(k, m, 2)` (k of them).

    The header is read first: an array larger than the file holds, or larger than
    `MAX_ARRAY_BYTES` as float64, is refused before anything is allocated."""
    data = read_bytes(path)
    if data.startswith(b"PK\x03\x04") or data.startswith(b"PK\x05\x06"):
        raise fail(path, "is a .npz archive, not a .npy file; name it .npz.")
    return _array_outlines(path, _npy_array(path, data, "the array"), "the array")


# What a corrupt or unusual member raises while it is decompressed.
_MEMBER_ERRORS = (
    zipfile.BadZipFile,
    zipfile.LargeZipFile,
    zlib.error,
    EOFError,
    OSError,
    ValueError,
    RuntimeError,
    NotImplementedError,  # an unknown compression method
    struct.error,
)
_CHUNK = 1 << 20


def _member_bytes(path, archive: zipfile.ZipFile, info: zipfile.ZipInfo, name: str) -> bytearray:
    """A member's bytes, decompressed in bounded chunks and never past its declared size."""
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise fail(
            path,
            f"member {quote(name)} uses zip compression method {info.compress_type}; "
            "write the archive with numpy.savez or numpy.savez_compressed.",
        )
    if info.flag_bits & 0x1:
        raise fail(
            path, f"member {quote(name)} is encrypted; write the archive without a password."
        )
    data, total = bytearray(info.file_size), 0  # the declared size was checked
    try:
        with archive.open(info) as member:
            while chunk := member.read(_CHUNK):
                if total + len(chunk) > info.file_size:  # zipfile stops there; be sure
                    raise zipfile.BadZipFile("more data than its declared size")
                data[total : total + len(chunk)] = chunk
                total += len(chunk)
        if total != info.file_size:
            raise zipfile.BadZipFile(f"{total} bytes instead of the declared {info.file_size}")
    except _MEMBER_ERRORS as e:
        raise fail(
            path,
            f"member {quote(name)} is corrupt ({type(e).__name__}: {one_line(e, 100)}); "
            "write the archive again.",
        ) from None
    return data


def _member_key(name: str) -> str:
    return name[:-4] if name.endswith(".npy") else name


def read_npz(path) -> list[Outline]:
    """An archive written by `write_outlines`, or any archive with one `(m, 2)` array.

    `write_outlines` stores `points` and `closed` for one outline, `points_0`,
    `points_1`, ... and a boolean array `closed` for several. The members' declared
    uncompressed sizes are checked against `MAX_ARRAY_BYTES` before anything is
    decompressed, and each member's header against its data.
    """
    data = read_bytes(path)
    if data.startswith(_NPY_MAGIC):
        raise fail(path, "is a .npy file, not a .npz archive; name it .npy.")
    # The number of members from the end record, before zipfile builds one object for
    # each (65535 stands for "more", in a zip64 archive).
    end = data.rfind(b"PK\x05\x06", max(0, len(data) - 65_557))
    if end >= 0 and end + 12 <= len(data):
        entries = struct.unpack_from("<H", data, end + 10)[0]
        if entries > common.MAX_CONTOURS + 1:  # the outlines and 'closed'
            check_contours(path, entries, counted=False)
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
    except _MEMBER_ERRORS as e:
        raise fail(path, f"is not a readable .npz archive ({one_line(e, 120)}).") from None
    with archive:
        members = {}
        for info in archive.infolist():
            members.setdefault(_member_key(info.filename), info)
        keys = list(members)
        if not keys:
            raise fail(path, "has no contours: the archive holds no arrays.")
        indexed = sorted(
            (len(m.group(1)), m.group(1), k)
            for k in keys
            if (m := re.fullmatch(r"points_(\d+)", k))
        )
        if "points" in keys:
            names = ["points"]
        elif indexed:
            names = [k for *_, k in indexed]
        elif len(keys) == 1:
            names = keys
        else:
            raise fail(
                path,
                "expected an array named 'points' (or points_0, ...), found "
                f"{one_line(keys[:10], 120)}{' ...' if len(keys) > 10 else ''}.",
            )
        check_contours(path, len(names))
        wanted = names + (["closed"] if "closed" in keys else [])
        declared = sum(members[k].file_size for k in wanted)
        if declared > common.MAX_ARRAY_BYTES:
            raise fail(
                path,
                f"its arrays are {size_text(declared)} uncompressed, more than the "
                f"{size_text(common.MAX_ARRAY_BYTES)} limit (jaxsubdiv.io.MAX_ARRAY_BYTES); "
                "thin out the points or split the archive.",
            )

        used = 0

        def array(key: str, bools: bool = False) -> np.ndarray:
            nonlocal used
            member = _member_bytes(path, archive, members[key], key)
            if not member.startswith(_NPY_MAGIC):
                raise fail(path, f"member {quote(key)} is not a NumPy array (.npy).")
            result = _npy_array(path, member, f"member {quote(key)}", ".npy array", used, bools)
            used += result.size * 8
            return result

        closed = np.ones(len(names), bool)
        if "closed" in keys:
            flags = np.atleast_1d(array("closed", bools=True))
            if flags.dtype != bool or flags.ndim != 1 or len(flags) != len(names):
                raise fail(
                    path,
                    f"'closed' must hold {len(names)} booleans, got {flags.dtype} of shape "
                    f"{flags.shape}.",
                )
            closed = flags
        return [make_outline(path, array(n), bool(c), repr(n)) for n, c in zip(names, closed)]


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


def _json_int(text: str):
    # A JSON integer too long to be a float64 (or, past 4300 digits, to be an int at
    # all) becomes infinite and is refused as such, instead of raising OverflowError.
    return int(text) if len(text) < 300 else float(text)


def load_json(path):
    text = read_text(path)
    try:
        return json.loads(text, parse_int=_json_int)
    except json.JSONDecodeError as e:
        raise fail(path, f"is not valid JSON: {e.msg} (column {e.colno}).", e.lineno) from None
    except RecursionError:
        raise fail(
            path,
            "nests lists or objects too deeply to read (deeper than Python's recursion "
            'limit); outlines need 4 levels: {"outlines": [{"points": [[x, y], ...]}]}.',
        ) from None


def show_json(value) -> str:
    """A short, one-line JSON rendering of `value` for a message."""
    try:
        text = json.dumps(value)
    except (RecursionError, ValueError, TypeError):
        text = type(value).__name__
    return text if len(text) <= 40 else text[:37] + "..."


def json_points(path, value, what: str) -> np.ndarray:
    if not isinstance(value, list):
        raise fail(path, f"{what} must be a list of [x, y] pairs.")
    for i, p in enumerate(value):
        if not isinstance(p, list) or len(p) != 2:
            raise fail(path, f"{what}[{i}] must be a pair [x, y], got {show_json(p)}.")
        for v in p:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise fail(path, f"{what}[{i}] holds {show_json(v)}, which is not a number.")
            if not math.isfinite(v):
                raise fail(
                    path,
                    f"{what}[{i}] holds a number that is not finite or too large for a float64 "
                    "(above 1.8e308).",
                )
    return checked_points(path, np.array(value, dtype=np.float64).reshape(-1, 2), what)


def _json_outline(path, value, what: str) -> Outline:
    if isinstance(value, list):
        return make_outline(path, json_points(path, value, what), True, what)
    if not isinstance(value, dict) or "points" not in value:
        raise fail(path, f'{what} must be {{"points": [[x, y], ...], "closed": true}}.')
    closed = value.get("closed", True)
    if not isinstance(closed, bool):
        raise fail(path, f'{what}["closed"] must be true or false, got {show_json(closed)}.')
    group = value.get("group")
    if group is not None and (isinstance(group, bool) or not isinstance(group, int)):
        raise fail(path, f'{what}["group"] must be an integer or null, got {show_json(group)}.')
    points = json_points(path, value["points"], f'{what}["points"]')
    return make_outline(path, points, closed, what, group)


def read_json(path) -> list[Outline]:
    """`{"points": [[x, y], ...], "closed": true}` (and optionally `"group": k`), a bare
    list of pairs, or `{"outlines": [{"points": ..., "closed": ...}, ...]}` for several."""
    data = load_json(path)
    if isinstance(data, dict) and "outlines" in data:
        items = data["outlines"]
        if not isinstance(items, list):
            raise fail(path, '"outlines" must be a list of outlines.')
        if not items:
            raise fail(path, 'has no contours: "outlines" is an empty list.')
        check_contours(path, len(items))
        return [_json_outline(path, item, f'"outlines"[{i}]') for i, item in enumerate(items)]
    return [_json_outline(path, data, "the file")]


def write_json(path, outlines: list[Outline]) -> None:
    items = [{"points": o.points.tolist(), "closed": o.closed}
             | ({} if o.group is None else {"group": int(o.group)}) for o in outlines]
    data = items[0] if len(items) == 1 else {"outlines": items}
    with open_for_writing(path) as f:
        f.write(json.dumps(data).encode())
