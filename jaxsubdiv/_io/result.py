"""Fit results as JSON: enough to rebuild the scheme and the control polygon."""

import inspect
import json
import math

import equinox as eqx
import numpy as np
from jaxtyping import Float

from .._scheme.base import AbstractCurveScheme
from .common import fail, one_line, open_for_writing
from .points import load_json, show_json


FORMAT = "jaxsubdiv.result"
VERSION = 1
_ERRORS = (
    "rms",
    "max_error",
    "rms_target_to_curve",
    "max_target_to_curve",
    "rms_curve_to_target",
    "max_curve_to_target",
)


class SavedResult(eqx.Module):
    """What [`jaxsubdiv.io.read_result_json`][] returns.

    **Fields:**

    - `scheme`: the scheme, rebuilt with its saved parameters.
    - `control_points`: the control polygon, a float64 NumPy array `(n, d)`.
    - `boundary`: `"closed"`, `"open"` or `"clamped"`.
    - `levels`: refinement levels used for the curve, or None.
    - `errors`: the saved error measures (`rms`, `max_error`, ...) by name.
    - `info`: everything else that was saved (solver status, the run's options, ...).
    """

    scheme: AbstractCurveScheme
    control_points: Float[np.ndarray, "n d"]
    boundary: str = eqx.field(static=True)
    levels: int | None = eqx.field(static=True)
    errors: dict
    info: dict


def scheme_to_json(scheme: AbstractCurveScheme) -> dict:
    """`{"type": class name, "parameters": {constructor argument: value}}`.

    The parameters are read back from the scheme by the names of its constructor's
    arguments (a method of that name, such as `MaskScheme.mask`, is called).
    """
    parameters = {}
    for name in inspect.signature(type(scheme).__init__).parameters:
        if name == "self":
            continue
        value = getattr(scheme, name)
        value = np.asarray(value() if callable(value) else value)
        parameters[name] = value.tolist()
    return {"type": type(scheme).__name__, "parameters": parameters}


def scheme_from_json(value, path) -> AbstractCurveScheme:
    import jaxsubdiv

    if not isinstance(value, dict) or not isinstance(value.get("type"), str):
        raise fail(path, '"scheme" must be {"type": name, "parameters": {...}}.')
    cls = getattr(jaxsubdiv, value["type"], None)
    if not (isinstance(cls, type) and issubclass(cls, AbstractCurveScheme)):
        raise fail(path, f"unknown scheme {value['type']!r}.")
    parameters = value.get("parameters", {})
    if not isinstance(parameters, dict):
        raise fail(path, '"scheme"["parameters"] must be an object {"name": value, ...}.')
    try:
        return cls(**parameters)
    except (TypeError, ValueError, ArithmeticError) as e:
        raise fail(
            path, f"cannot rebuild {value['type']} from {show_json(parameters)}: {one_line(e)}"
        ) from None


def _scalar(value, name: str) -> float | int:
    array = np.asarray(value)
    if array.ndim:
        raise ValueError(
            f"`{name}` has shape {array.shape}: write one result at a time (index a batch of "
            "results first)."
        )
    return array.item()


def write_result_json(path, result, *, info: dict | None = None) -> None:
    data = {"format": FORMAT, "version": VERSION}
    if isinstance(result, dict):
        source = dict(result)
        get = lambda name, default=None: source.pop(name, default)
    else:
        source = {}
        get = lambda name, default=None: getattr(result, name, default)
    scheme = get("scheme")
    if not isinstance(scheme, AbstractCurveScheme):
        raise TypeError(f"the result needs a `scheme` (a curve scheme), got {scheme!r}.")
    points = np.asarray(get("control_points"), dtype=np.float64)
    if points.ndim != 2:
        raise ValueError(
            f"`control_points` must have shape (n, d), got {points.shape}: write one "
            "result at a time (index a batch of results first)."
        )
    data["scheme"] = scheme_to_json(scheme)
    data["boundary"] = get("boundary", "closed")
    levels = get("levels")
    data["levels"] = None if levels is None else int(levels)
    data["control_points"] = points.tolist()
    errors = get("errors") or {}
    errors = {k: float(_scalar(v, k)) for k, v in dict(errors).items()}
    for name in _ERRORS:
        value = get(name)
        if value is not None:
            errors[name] = float(_scalar(value, name))
    # A failed fit can have NaN errors; JSON has no NaN, so they are saved as null.
    data["errors"] = {k: (v if math.isfinite(v) else None) for k, v in errors.items()}
    extra = {}
    if not isinstance(result, dict):
        for name in ("status", "num_steps"):
            if getattr(result, name, None) is not None:
                extra[name] = int(_scalar(getattr(result, name), name))
        if getattr(result, "message", None) is not None:
            extra["message"] = str(result.message)
    extra |= source | dict(info or {})
    data["info"] = extra
    if not np.all(np.isfinite(points)):
        raise ValueError("`control_points` contain NaN or infinite values; nothing to save.")
    try:
        text = json.dumps(data, allow_nan=False, indent=1)
    except (TypeError, ValueError) as e:
        raise TypeError(
            f"`info` must hold JSON values (numbers, strings, lists, dicts): {e}"
        ) from None
    with open_for_writing(path) as f:
        f.write(text.encode())


def _control_points(path, value) -> np.ndarray:
    try:
        points = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        points = None
    if points is None or points.ndim != 2 or len(points) < 2 or not np.all(np.isfinite(points)):
        raise fail(
            path,
            '"control_points" must be a list of at least 2 points of equal length, all '
            "finite numbers.",
        )
    return points


def read_result_json(path) -> SavedResult:
    data = load_json(path)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise fail(path, f'is not a jaxsubdiv result file (no "format": "{FORMAT}").')
    if data.get("version") != VERSION:
        raise fail(
            path,
            f"has result format version {data.get('version')!r}; this jaxsubdiv reads {VERSION}.",
        )
    boundary = data.get("boundary", "closed")
    if boundary not in ("closed", "open", "clamped"):
        raise fail(path, f'"boundary" must be "closed", "open" or "clamped", got {boundary!r}.')
    levels = data.get("levels")
    if levels is not None and (isinstance(levels, bool) or not isinstance(levels, int)):
        raise fail(path, f'"levels" must be an integer or null, got {levels!r}.')
    errors = data.get("errors", {})
    if not isinstance(errors, dict) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) or v is None
        for v in errors.values()
    ):
        raise fail(path, '"errors" must map names to numbers.')
    info = data.get("info", {})
    if not isinstance(info, dict):
        raise fail(path, '"info" must be an object {"name": value, ...}.')
    return SavedResult(
        scheme=scheme_from_json(data.get("scheme"), path),
        control_points=_control_points(path, data.get("control_points")),
        boundary=boundary,
        levels=levels,
        errors={k: (math.nan if v is None else float(v)) for k, v in errors.items()},
        info=info,
    )
