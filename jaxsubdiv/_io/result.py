"""Fit results as JSON: enough to rebuild the scheme and the control polygon."""

import dataclasses
import inspect
import json
import math

import numpy as np
from jaxtyping import Float

from .._refine import BOUNDARIES
from .._scheme.base import AbstractCurveScheme
from .._scheme.registry import by_class_name, scheme_info
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


@dataclasses.dataclass(frozen=True, eq=False)
class SavedResult:
    """What [`jaxsubdiv.io.read_result_json`][] returns.

    A frozen dataclass, not a pytree: it holds host data (strings, dicts, a NumPy
    array), so `jax.tree.map` treats it as one leaf; use `result.scheme` and
    `result.control_points` in JAX code.

    **Fields:**

    - `scheme`: the scheme, rebuilt with its saved parameters.
    - `control_points`: the control polygon, a float64 NumPy array `(n, d)`.
    - `boundary`: `"closed"`, `"open"` or `"clamped"`.
    - `levels`: refinement levels used for the curve, or None.
    - `creases`: a closed curve's creased control points (indices, as for
      [`jaxsubdiv.refine`][]; a fit with corners), else `()`.
    - `errors`: the saved error measures (`rms`, `max_error`, ...) by name.
    - `info`: everything else that was saved (solver status, the run's options, ...).
    """

    scheme: AbstractCurveScheme
    control_points: Float[np.ndarray, "n d"]
    boundary: str
    levels: int | None
    errors: dict
    info: dict
    creases: tuple[int, ...] = ()


def scheme_to_json(scheme: AbstractCurveScheme) -> dict:
    """`{"type": class name, "parameters": {constructor argument: value}}`.

    The parameters are the registry's (`jaxsubdiv.scheme_info(scheme).values`); a scheme
    the registry does not list (`MaskScheme`) saves its constructor's arguments, read
    from the fields of the same names. A scheme class that is not jaxsubdiv's is refused
    (the reader could not rebuild it).
    """
    known = by_class_name().get(type(scheme).__name__)
    if known is None or known.cls is not type(scheme):
        # read_result_json rebuilds schemes by class name from jaxsubdiv's own.
        raise ValueError(
            f"result files record jaxsubdiv's schemes only, and {type(scheme).__name__} is "
            "not one, so the file could not be read back; save its mask as "
            "`jaxsubdiv.MaskScheme(scheme.mask(), scheme.mask_start)`."
        )
    info = scheme_info(scheme)
    if info.listed:
        try:
            parameters = info.values(scheme)
        except (TypeError, ValueError):
            raise ValueError(
                f"the {type(scheme).__name__} scheme holds a batch of parameter values or "
                "traced ones; write one result at a time, with concrete parameters."
            ) from None
    else:
        parameters = {}
        for name, argument in inspect.signature(type(scheme).__init__).parameters.items():
            if name == "self" or argument.kind is inspect.Parameter.KEYWORD_ONLY:
                continue  # keyword-only arguments are aliases (MaskScheme's `mask`)
            parameters[name] = np.asarray(getattr(scheme, name)).tolist()
    return {"type": type(scheme).__name__, "parameters": parameters}


# Parameters renamed since files were written: old name -> new name, per class.
_RENAMED = {"MaskScheme": {"mask": "coefficients"}}


def scheme_from_json(value, path) -> AbstractCurveScheme:
    if not isinstance(value, dict) or not isinstance(value.get("type"), str):
        raise fail(path, '"scheme" must be {"type": name, "parameters": {...}}.')
    type_name = value["type"]
    info = by_class_name().get(type_name)
    if info is None:
        raise fail(
            path,
            f"unknown scheme {type_name!r}; the schemes are "
            f"{', '.join(by_class_name())}.",
        )
    parameters = value.get("parameters", {})
    if not isinstance(parameters, dict):
        raise fail(path, '"scheme"["parameters"] must be an object {"name": value, ...}.')
    renamed = _RENAMED.get(type_name, {})
    parameters = {renamed.get(k, k): v for k, v in parameters.items()}
    try:
        if not info.listed:
            return info.cls(**parameters)
        names = [p.name for p in info.parameters]
        unknown = [k for k in parameters if k not in names]
        missing = [k for k in names if k not in parameters]
        if unknown or missing:
            raise ValueError(
                f"{type_name} takes the parameters {names or 'none'}"
                + (f"; unknown: {unknown}" if unknown else "")
                + (f"; missing: {missing}" if missing else "")
            )
        return info.make(**parameters)
    except (TypeError, ValueError, ArithmeticError) as e:
        raise fail(
            path, f"cannot rebuild {type_name} from {show_json(parameters)}: {one_line(e)}"
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
    creases = get("creases")
    if creases is not None:
        creases = np.asarray(creases)
        if creases.dtype == bool and creases.shape != (len(points),):
            raise ValueError(
                f"`creases` as a boolean mask must have shape ({len(points)},), one entry per "
                f"control point; got {creases.shape}."
            )
        index = np.flatnonzero(creases) if creases.dtype == bool else creases.reshape(-1)
        if index.size and (not np.issubdtype(index.dtype, np.integer) or np.any(
                (index < 0) | (index >= len(points)))):
            raise ValueError(
                f"`creases` must be control point indices in [0, {len(points) - 1}] (or a "
                f"boolean mask); got {creases.tolist()}."
            )
        if index.size and data["boundary"] != "closed":
            raise ValueError(
                f"`creases` need boundary='closed' (a creased closed curve); got "
                f"{data['boundary']!r}."
            )
        if index.size:
            # Version 2: a reader of version 1 would draw the curve without its corners.
            data["version"] = 2
            data["creases"] = [int(i) for i in index]
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
        if getattr(result, "params_held", None) is not None:
            extra["params_held"] = bool(_scalar(result.params_held, "params_held"))
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
    if data.get("version") not in (VERSION, 2):
        raise fail(
            path,
            f"has result format version {data.get('version')!r}; this jaxsubdiv reads "
            f"{VERSION} and 2.",
        )
    boundary = data.get("boundary", "closed")
    if boundary not in BOUNDARIES:
        raise fail(path, f'"boundary" must be one of {BOUNDARIES}, got {boundary!r}.')
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
    points = _control_points(path, data.get("control_points"))
    creases = data.get("creases", [])
    if (not isinstance(creases, list) or not all(
            isinstance(c, int) and not isinstance(c, bool) and 0 <= c < len(points)
            for c in creases) or (creases and boundary != "closed")):
        raise fail(path, f'"creases" must be a list of control point indices in '
                   f"[0, {len(points) - 1}] of a closed curve, got {creases!r}.")
    return SavedResult(
        scheme=scheme_from_json(data.get("scheme"), path),
        control_points=points,
        boundary=boundary,
        levels=levels,
        errors={k: (math.nan if v is None else float(v)) for k, v in errors.items()},
        info=info,
        creases=tuple(creases),
    )
