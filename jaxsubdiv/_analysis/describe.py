"""`describe`: the readable name of a scheme with its parameter values.

Its own module, below `local`, `smoothness` and `analyze`, because all of them name the
scheme in their messages and reports; keeping it here lets imports run one way only.
"""

import dataclasses

import numpy as np

from .._misc import is_traced
from .._scheme.base import AbstractCurveScheme


def describe(scheme: AbstractCurveScheme) -> str:
    """`FourPoint(w=0.0625)`-style name of a scheme with its parameter values.

    Traced parameters (inside `jit`, `vmap`, `grad`) are shown as `<traced>`, so error
    messages raised while tracing can still name the scheme.
    """
    parts = []
    for field in dataclasses.fields(scheme):
        value = getattr(scheme, field.name)
        if is_traced(value):
            parts.append(f"{field.name}=<traced>")
            continue
        array = np.asarray(value)
        if array.ndim == 0:
            parts.append(f"{field.name}={array.item():.6g}")
        else:
            parts.append(f"{field.name}=[{', '.join(f'{x:.6g}' for x in array.ravel())}]")
    return f"{type(scheme).__name__}({', '.join(parts)})"
