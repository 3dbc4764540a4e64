"""Small validation helpers shared by the schemes and the kernels."""

import math
import numbers
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike


#: Default cap on the memory one call may build, in bytes (2 GiB): the output of
#: `refine` and `subdivision_matrix`, the tables of a surface `Refiner`.
DEFAULT_MEMORY_BUDGET = 2 * 1024**3

#: The largest budget accepted, 2^60 bytes (1 EiB): beyond any machine, and larger sizes
#: would overflow the 64-bit shapes and byte counts of XLA (an `OverflowError` deep in JAX).
MAX_MEMORY_BUDGET = 2**60


def as_float_array(value: ArrayLike, name: str) -> Array:
    """Convert `value` to a JAX floating array; integers and bools are promoted.

    A numpy array is converted on the host and transferred with `device_put`:
    `jnp.asarray` stages it through a small program compiled once per new shape, which
    every new mesh or curve size paid (a `Refiner`'s template `Mesh`, for one:
    `benchmarks/results/surface_build.md`, "first build, new size")."""
    if isinstance(value, np.ndarray | np.generic):
        kind = value.dtype.kind
        if kind not in "biufc":  # strings, objects, dates
            raise TypeError(f"`{name}` must be array-like, got {type(value).__name__} of "
                            f"dtype {value.dtype}.")
        return device_put_copy(value, np.float64 if kind in "biu" else None)
    try:
        array = jnp.asarray(value)
    except (TypeError, ValueError) as e:  # strings, None, objects
        raise TypeError(f"`{name}` must be array-like, got {type(value).__name__}.") from e
    if not jnp.issubdtype(array.dtype, jnp.inexact):
        array = array.astype(jnp.result_type(float))
    return array


def device_put_copy(value, dtype=None) -> Array:
    """A numpy array (or scalar) as a JAX array of `dtype` (default its own; 64-bit
    dtypes become 32-bit without x64, as `jnp.asarray` does), by way of a private host
    copy: `jax.device_put` reads its argument asynchronously, so a caller changing the
    array right after the call could change the result (seen on CPU)."""
    return jax.device_put(np.array(value, dtype=dtype, copy=True))


def is_traced(value) -> bool:
    return isinstance(value, jax.core.Tracer)


def real_array(value: ArrayLike, name: str) -> Array:
    """`value` as a real floating JAX array; complex values and non-numbers are a
    `TypeError` naming `name` (also when traced: the dtype is static)."""
    array = as_float_array(value, name)
    if not jnp.issubdtype(array.dtype, jnp.floating):
        shown = "" if is_traced(array) else f" ({np.asarray(value).tolist()})"
        raise TypeError(
            f"`{name}` must be real, got dtype {array.dtype}{shown}: a complex value would "
            "lose its imaginary part. Pass the real part (`.real`) if that is what you mean."
        )
    return array


def checked_parameter(
    value: ArrayLike,
    valid: Callable[..., ArrayLike],
    message: str,
    *others: ArrayLike,
    name: str = "parameter",
) -> Array:
    """Return `value` as a float array after checking `valid(value, *others)`.

    Concrete values are checked now, with a `ValueError`; traced values (inside `jit`,
    `vmap` or `grad`) get an `eqx.error_if`, which raises when the computation runs.
    The returned array must be the one stored, or the traced check is dropped.

    Parameters must be real numbers: complex values (whose imaginary part refinement
    would drop) and non-numbers are a `TypeError` naming `name`, also when traced (the
    dtype is static).
    """
    array = real_array(value, name)
    if is_traced(array) or any(is_traced(o) for o in others):
        others = tuple(jnp.asarray(o) for o in others)
        return eqx.error_if(array, jnp.logical_not(jnp.all(valid(array, *others))), message)
    concrete = np.asarray(array)
    if not np.all(valid(concrete, *(np.asarray(o) for o in others))):
        raise ValueError(f"{message} Got {concrete.tolist()}.")
    return array


def static_int(value, name: str, *, minimum: int, maximum: int | None = None, why: str = "") -> int:
    """Check a shape-setting integer (number of levels, degree, ...) and return it.

    With `maximum`, larger values are a `ValueError` that states the bound and `why`.
    """
    if is_traced(value):
        raise TypeError(
            f"`{name}` sets array shapes, so it must be a Python int, not a traced "
            f"value. Pass it as a static argument (e.g. `eqx.filter_jit`, or "
            f"`jax.jit(..., static_argnames=...)`)."
        )
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"`{name}` must be an int, got {value!r} of type {type(value).__name__}.")
    if abs(int(value)).bit_length() > 63:  # also keeps `{value:,}` below Python's digit limit
        raise ValueError(
            f"`{name}` must be a 64-bit integer, got one of {_digits(value)} digits."
        )
    if value < minimum:
        raise ValueError(f"`{name}` must be >= {minimum}, got {value}.")
    if maximum is not None and value > maximum:
        raise ValueError(f"`{name}` must be <= {maximum:,}, got {value:,}{why}.")
    return int(value)


def _digits(value: int) -> int:
    """The number of decimal digits of an int of any size (without `str`, which Python
    refuses above 4,300 digits)."""
    return int(abs(int(value)).bit_length() * math.log10(2)) + 1


class MemoryBudgetError(ValueError):
    """Work estimated to need more memory than its `memory_budget`, refused before
    anything is allocated (`jaxsubdiv.refine`, `fitting.fit`). A `ValueError` whose
    message speaks the library's terms; `need` (bytes, None when only a lower bound was
    estimated), `budget` (bytes) and `most_levels` (the most refinement levels within
    the budget, where known; else None) let an application, such as the command line,
    say it in its own terms."""

    def __init__(self, message: str, *, need: float | None = None,
                 budget: float | None = None, most_levels: int | None = None):
        super().__init__(message)
        self.need, self.budget, self.most_levels = need, budget, most_levels


def checked_budget(value, name: str = "memory_budget") -> float:
    """Check a memory budget in bytes: a finite real number, 0 < budget <= 2^60 (not a
    bool, not traced).

    NaN, infinities, zero, negative numbers and non-numbers are errors, so a budget can
    never silently switch its check off.
    """
    if isinstance(value, (jax.Array, np.ndarray)) and not is_traced(value) and value.ndim == 0:
        value = value.item()  # a concrete JAX or NumPy scalar array
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.integer, np.floating)):
        raise TypeError(
            f"`{name}` must be a number of bytes (an int or a float), got {value!r} of type "
            f"{type(value).__name__}."
        )
    if isinstance(value, (int, np.integer)):
        number, ok = int(value), value > 0
    else:
        number = float(value)
        ok = math.isfinite(number) and number > 0
    if not ok:
        raise ValueError(
            f"`{name}` must be a finite number of bytes > 0, got {value!r}; the default is "
            f"{DEFAULT_MEMORY_BUDGET:,} (2 GiB). To allow more, pass a larger finite number."
        )
    if number > MAX_MEMORY_BUDGET:
        raise ValueError(
            f"`{name}` must be at most 2^60 bytes (1 EiB, more than any machine has), got "
            f"a number of {_digits(number) if isinstance(number, int) else f'{number:.3g}'}"
            f"{' digits' if isinstance(number, int) else ''}; pass the memory you actually have."
        )
    return number


def format_bytes(size: int | float) -> str:
    """`size` bytes as GiB ('3.2 GiB'), also for integers too large for a float."""
    if isinstance(size, int) and size.bit_length() > 1000:
        return f"about 10^{math.log10(size) - math.log10(1024**3):.0f} GiB"
    return f"{size / 1024**3:.3g} GiB"


def check_creasable(scheme, caller: str) -> None:
    """A clear error for schemes whose creased closed curves cannot be tables with
    creases as data (`jaxsubdiv.curve_stencil(creases=mask)`, `fitting.fit(corners=...)`):
    those without a clamped end rule, dual ones, and primal ones whose samples are not
    at their control points (`center` not 0: odd `LaneRiesenfeld`, whose clamped
    pieces are shifted against its closed curve)."""
    if scheme.clamp_ghost is None:
        raise ValueError(
            f"`{caller}`: {type(scheme).__name__} has no clamped end rule, which is what a "
            "crease is (the curve is cut there into clamped pieces); use a scheme with "
            "one, such as CubicBSpline or FourPoint."
        )
    if not scheme.is_primal:
        raise ValueError(
            f"`{caller}`: creases as a mask need a primal scheme (one that keeps a point "
            f"at every control point, such as CubicBSpline, FourPoint or SplitTweak); "
            f"{type(scheme).__name__} is dual, and a dual scheme's creased curve has a "
            "number of samples that depends on how many creases there are. Pass the "
            "creases to `jaxsubdiv.refine(creases=...)` instead."
        )
    if float(scheme.center) != 0.0:
        raise ValueError(
            f"`{caller}`: creases as a mask need a scheme whose limit curve passes its "
            f"samples at the control points (center 0); {type(scheme).__name__} has center "
            f"{float(scheme.center):g}, and its clamped pieces are shifted against its "
            "closed curve. Pass the creases to `jaxsubdiv.refine(creases=...)` instead."
        )
