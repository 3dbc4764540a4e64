"""Small validation helpers shared by the schemes and the kernels."""

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike


def as_float_array(value: ArrayLike, name: str) -> Array:
    """Convert `value` to a JAX floating array; integers and bools are promoted."""
    try:
        array = jnp.asarray(value)
    except TypeError as e:
        raise TypeError(f"`{name}` must be array-like, got {type(value).__name__}.") from e
    if not jnp.issubdtype(array.dtype, jnp.inexact):
        array = array.astype(jnp.result_type(float))
    return array


def is_traced(value) -> bool:
    return isinstance(value, jax.core.Tracer)


def checked_parameter(
    value: ArrayLike,
    valid: Callable[..., ArrayLike],
    message: str,
    *others: ArrayLike,
) -> Array:
    """Return `value` as a float array after checking `valid(value, *others)`.

    Concrete values are checked now, with a `ValueError`; traced values (inside `jit`,
    `vmap` or `grad`) get an `eqx.error_if`, which raises when the computation runs.
    The returned array must be the one stored, or the traced check is dropped.
    """
    array = as_float_array(value, "parameter")
    if is_traced(array) or any(is_traced(o) for o in others):
        others = tuple(jnp.asarray(o) for o in others)
        return eqx.error_if(array, jnp.logical_not(jnp.all(valid(array, *others))), message)
    concrete = np.asarray(array)
    if not np.all(valid(concrete, *(np.asarray(o) for o in others))):
        raise ValueError(f"{message} Got {concrete.tolist()}.")
    return array


def static_int(value, name: str, *, minimum: int) -> int:
    """Check a shape-setting integer (number of levels, degree, ...) and return it."""
    if is_traced(value):
        raise TypeError(
            f"`{name}` sets array shapes, so it must be a Python int, not a traced "
            f"value. Pass it as a static argument (e.g. `eqx.filter_jit`, or "
            f"`jax.jit(..., static_argnames=...)`)."
        )
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"`{name}` must be an int, got {value!r} of type {type(value).__name__}.")
    if value < minimum:
        raise ValueError(f"`{name}` must be >= {minimum}, got {value}.")
    return int(value)
