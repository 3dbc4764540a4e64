import math
from collections.abc import Sequence
from typing import Literal

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._kernel import (
    apply_periodic,
    apply_window,
    clamped_level,
    clamped_levels,
    open_levels,
    polyphase,
)
from ._misc import (
    DEFAULT_MEMORY_BUDGET as DEFAULT_MEMORY_BUDGET,
    MemoryBudgetError,
    as_float_array,
    checked_budget,
    format_bytes,
    is_traced,
    static_int,
)
from ._scheme.base import AbstractCurveScheme


Boundary = Literal["closed", "open", "clamped"]
BOUNDARIES = ("closed", "open", "clamped")

#: The most levels `refined_count` counts: the count has about 0.3 x `levels` decimal
#: digits, so beyond this it would not even print (Python's 4,300-digit limit), and no
#: memory could hold such a curve.
MAX_COUNT_LEVELS = 10_000


def _check_scheme(scheme) -> AbstractCurveScheme:
    if not isinstance(scheme, AbstractCurveScheme):
        raise TypeError(
            "`scheme` must be a jaxsubdiv curve scheme such as `jaxsubdiv.Chaikin()`, "
            f"`jaxsubdiv.FourPoint(w)` or `jaxsubdiv.MaskScheme(coefficients, start)`; got "
            f"{type(scheme).__name__}."
        )
    return scheme


def _check_boundary(boundary, scheme: AbstractCurveScheme) -> str:
    if boundary not in BOUNDARIES:
        raise ValueError(f"`boundary` must be one of {BOUNDARIES}, got {boundary!r}.")
    if boundary == "clamped" and scheme.clamp_ghost is None:
        raise ValueError(
            f"{type(scheme).__name__} has no clamped end rule; use boundary='closed' or "
            "boundary='open'."
        )
    return boundary


def _check_creases(creases, n: int, boundary: str) -> tuple[int, ...]:
    if creases is None:
        return ()
    if is_traced(creases):
        raise TypeError("`creases` sets array shapes, so it must be a list of Python ints.")
    values = np.asarray(creases).reshape(-1) if not isinstance(creases, int) else [creases]
    if len(values) and not np.issubdtype(np.asarray(values).dtype, np.integer):
        raise TypeError(f"`creases` must be control point indices (ints), got {creases!r}.")
    values = sorted({int(c) for c in values})
    if boundary == "open":
        raise ValueError(
            "`creases` need boundary='closed' or boundary='clamped' (a crease splits the "
            "curve into clamped pieces); with boundary='open' use 'clamped' instead."
        )
    bad = [c for c in values if not 0 <= c < n]
    if bad:
        raise ValueError(f"`creases` must be indices in [0, {n - 1}], got {bad}.")
    if boundary == "clamped":
        values = [c for c in values if 0 < c < n - 1]  # the ends are sharp already
    return tuple(values)


def _segments(n: int, boundary: str, creases: tuple[int, ...]) -> list[list[int]]:
    """Control point indices of the clamped pieces a creased curve is cut into."""
    if boundary == "clamped":
        cuts = [0, *creases, n - 1]
        return [list(range(a, b + 1)) for a, b in zip(cuts[:-1], cuts[1:])]
    # Closed: pieces run from crease to crease, the last one wrapping around.
    cuts = [*creases, creases[0] + n]
    return [[j % n for j in range(a, b + 1)] for a, b in zip(cuts[:-1], cuts[1:])]


def _min_points(scheme: AbstractCurveScheme, boundary: str) -> int:
    if boundary == "closed":
        return 3
    if boundary == "clamped":
        return 2
    # Open: the smallest n whose open level does not shrink the polygon.
    start, length = scheme.mask_start, scheme.mask_length
    n = 2
    while open_levels(n, start, length, 1)[1] < n:
        n += 1
    return n


def _check_enough_points(n: int, scheme: AbstractCurveScheme, boundary: str) -> None:
    needed = _min_points(scheme, boundary)
    if n < needed:
        raise ValueError(
            f"{type(scheme).__name__} with boundary={boundary!r} needs at least {needed} "
            f"control points, got n={n}."
        )


def refined_count(
    n: int,
    scheme: AbstractCurveScheme,
    levels: int,
    boundary: Boundary = "closed",
    *,
    creases: Sequence[int] | None = None,
) -> int:
    """Number of points `refine` returns for `n` control points.

    **Arguments:** as for [`jaxsubdiv.refine`][], with the number of control points `n`
    in place of the points; `levels` up to 10,000 (`MAX_COUNT_LEVELS`: the count then has
    about 3,000 digits).

    **Returns:** a Python int. Closed curves give $2^k n$; open, clamped and creased
    curves follow the rules documented on each scheme.

    **Raises:** the `ValueError` of `refine` when `n` is too small for the scheme and
    boundary (e.g. the open cubic B-spline needs 3 points).
    """
    scheme = _check_scheme(scheme)
    levels = static_int(
        levels,
        "levels",
        minimum=0,
        maximum=MAX_COUNT_LEVELS,
        why=" for refined_count: the count would have more than 3,000 digits",
    )
    n = static_int(n, "n", minimum=1)
    boundary = _check_boundary(boundary, scheme)
    creases = _check_creases(creases, n, boundary)
    _check_enough_points(n, scheme, boundary)
    return _count(n, scheme, levels, boundary, creases)


def _count(n, scheme, levels, boundary, creases) -> int:
    """Closed forms: a few integer operations for any number of levels."""
    if creases:
        pieces = _segments(n, boundary, creases)
        total = sum(_count(len(p), scheme, levels, "clamped", ()) for p in pieces)
        # Neighboring pieces share their crease point; a closed curve shares one more.
        return total - (len(pieces) - 1) - (boundary == "closed")
    if boundary == "closed":
        return n * 2**levels
    if boundary == "open":
        return open_levels(n, scheme.mask_start, scheme.mask_length, levels)[1]
    return clamped_levels(n, scheme.center, levels)


def _work_bytes(n, d, batch, itemsize, scheme, levels, boundary, creases) -> tuple[int, int, int]:
    """(count, output bytes, estimated peak bytes) of a refinement, from shapes only.

    The estimate (measured on CPU, float64) is twice the output (the result and XLA's
    working copy); closed and open curves add eight times the polyphase table of the
    composite mask (about `mask_length x 2^levels` numbers, which XLA also folds as a
    constant while compiling), and open curves the padded run of whole filter blocks.
    Clamped ends and creases, refined level by level with ghost points: four times the
    output.
    """
    count = _count(n, scheme, levels, boundary, creases)
    values = max(1, batch * d)  # an empty batch still builds the table and compiles
    out = count * values * itemsize
    if boundary == "clamped" or creases:
        return count, out, 4 * out
    rows = 2**levels
    table = (scheme.mask_length + 1) * rows * itemsize
    window = (count + 2 * rows) * values * itemsize if boundary == "open" else out
    return count, out, 2 * window + 8 * table


def _check_memory(
    n, d, batch, itemsize, scheme, levels, boundary, creases, budget, extra=0, caller="refine"
):
    """Raise the memory-budget error before anything is allocated; return the count.

    Every refinement needs at least `2^levels` numbers (closed and clamped outputs grow
    by two per level, open curves build a table of `2^levels` rows), so a `levels` with
    `2^levels` numbers above the budget is refused from its bit length alone, without
    building a huge integer (`levels=10**6` would otherwise hang or overflow).
    """
    smallest = max(1, batch * d) * itemsize  # bytes per point of 2^levels
    # (Up to 64 levels the exact count below is cheap; math.log2 takes huge ints.)
    if levels > 64 and levels > math.log2(budget) - math.log2(smallest) + 1:
        most, advice = _advice(n, d, batch, itemsize, scheme, levels, boundary, creases,
                               budget, extra)
        raise MemoryBudgetError(
            f"{caller} would build more than 2^{levels} points x {d} coordinates"
            + (f" x {batch:,} curves" if batch > 1 else "")
            + f" ({levels:,} levels), above memory_budget={budget:,} bytes. " + advice,
            need=None, budget=budget, most_levels=most,
        )
    count, out, peak = _work_bytes(n, d, batch, itemsize, scheme, levels, boundary, creases)
    if peak + extra > budget:
        with_work = (
            f" and use about {format_bytes(peak + extra)} in all with its working arrays"
            if peak + extra > out
            else ""
        )
        most, advice = _advice(n, d, batch, itemsize, scheme, levels, boundary, creases,
                               budget, extra)
        raise MemoryBudgetError(
            f"{caller} would build {count:,} points x {d} coordinates"
            + (f" x {batch:,} curves" if batch > 1 else "")
            + f" = {format_bytes(out)}{with_work}, above memory_budget={budget:,} bytes. "
            + advice,
            need=peak + extra, budget=budget, most_levels=most,
        )
    return count


def _advice(n, d, batch, itemsize, scheme, levels, boundary, creases, budget, extra
            ) -> tuple[int | None, str]:
    """The most levels within the budget (None: not even 0), and the advice."""
    # The most levels that fit (the estimate grows with the levels): a bisection.
    smallest = max(1, batch * d) * itemsize
    lo, hi = -1, min(levels, int(math.log2(budget) - math.log2(smallest)) + 2)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        peak = _work_bytes(n, d, batch, itemsize, scheme, mid, boundary, creases)[2]
        lo, hi = (mid, hi) if peak + extra <= budget else (lo, mid)
    plural = "" if lo == 1 else "s"
    fewer = f"Use at most {lo} level{plural} here" if lo >= 0 else "Use fewer points or levels"
    return lo if lo >= 0 else None, (
        f"{fewer}, refine in chunks, evaluate the limit curve at the resolution you need, "
        "or raise `memory_budget` (a finite number of bytes)."
    )


def _refine_static(points, scheme, levels, boundary, creases):
    """The jitted body; `levels`, `boundary` and `creases` are static."""
    mask = scheme.mask().astype(points.dtype)
    if mask.ndim != 1:  # checked while tracing: no cost per call
        raise ValueError(
            f"{type(scheme).__name__} holds a batch of parameter values (mask shape "
            f"{mask.shape}); refine takes one scheme. To refine with many parameter "
            "values, `jax.vmap` over the scheme."
        )
    start = scheme.mask_start
    n = points.shape[-2]
    if levels == 0:
        return points
    if creases:
        pieces = [
            _refine_static(points[..., idx, :], scheme, levels, "clamped", ())
            for idx in _segments(n, boundary, creases)
        ]
        joined = [pieces[0]] + [p[..., 1:, :] for p in pieces[1:]]
        out = jnp.concatenate(joined, axis=-2)
        return out[..., :-1, :] if boundary == "closed" else out
    if boundary == "closed":
        return apply_periodic(points, polyphase(mask, start, levels))
    if boundary == "open":
        first, count = open_levels(n, start, mask.shape[-1], levels)
        return apply_window(points, polyphase(mask, start, levels), first, count)
    for _ in range(levels):
        points = clamped_level(points, mask, start, scheme.center, scheme.clamp_ghost)
    return points


# jax.jit rather than eqx.filter_jit: the scheme is a pytree of arrays with its
# shape-setting integers in the treedef, and jax.jit's C++ dispatch is ~5x cheaper per
# call (measured 25 us vs 137 us), which dominates small refinements.
_refine_jit = jax.jit(_refine_static, static_argnums=(2, 3, 4))


def refine(
    points: Float[ArrayLike, "*batch n d"],
    scheme: AbstractCurveScheme,
    levels: int,
    *,
    boundary: Boundary = "closed",
    creases: Sequence[int] | None = None,
    memory_budget: int = DEFAULT_MEMORY_BUDGET,
) -> Float[Array, "*batch N d"]:
    """Refine a control polygon `levels` times with a subdivision scheme.

    All `levels` levels are applied as one polyphase filter built from the scheme's
    composite mask (closed and open curves), or level by level with ghost points
    (clamped ends and creases). The result is differentiable in `points` and in the
    scheme's parameters, and `refine` works under `jax.jit`, `jax.vmap` and `jax.grad`.
    It is compiled once per (scheme type, shape, dtype, `levels`, `boundary`,
    `creases`); new point or parameter values do not recompile.

    **Arguments:**

    - `points`: control points, shape `(..., n, d)` for any `d >= 1` (2-D outlines,
      3-D space curves, extra channels such as colour or width); leading axes are
      batch axes. Integer input is promoted to floating point. The output has the
      dtype JAX gives `points`: float32 stays float32; float64 stays float64 only when
      `jax_enable_x64` is on (otherwise JAX, like every JAX function, converts float64
      input to float32).
    - `scheme`: a curve scheme, e.g. `Chaikin()`, `CornerCutting(r, s)`,
      `FourPoint(w)`, `CubicBSpline()`, `LaneRiesenfeld(degree)`, `SplitTweak(t)`,
      `Jarek()`, `Daubechies()`, `MaskScheme(coefficients, start)`.
    - `levels`: number of refinement levels, a Python int >= 0 (static).
    - `boundary`: `"closed"` (periodic: $n \\to 2n$ per level); `"open"` (keep only the
      outputs whose whole stencil lies inside the polygon, e.g. Chaikin
      $n \\to 2(n-1)$, cubic B-spline $n \\to 2n - 3$); `"clamped"` (end points kept,
      so the curve interpolates them; see each scheme for its end rule). Static.
    - `creases`: indices of control points that stay sharp (static). The curve is cut
      at them into clamped pieces, so it passes through each crease with a corner.
      Allowed with `"closed"` (the output then starts at the first crease) and
      `"clamped"`.
    - `memory_budget`: the most memory, in bytes, `refine` may use (default 2 GiB): a
      finite number > 0. The peak is estimated from the shapes before anything is
      allocated: for closed and open curves twice the output plus eight times the
      composite mask's table (`mask_length x 2^levels` numbers), for clamped ends and
      creases four times the output (measured peaks on CPU). A larger request is an error that states the size and the most
      levels that fit; so is any `levels` whose `2^levels` numbers alone exceed it (e.g.
      `levels=10**6`).

    **Returns:** the refined points, shape `(..., N, d)` with
    `N = refined_count(n, scheme, levels, boundary, creases=creases)`.

    Index convention (closed curves, one level): for dual (corner-cutting) schemes
    `Q[2i]` and `Q[2i+1]` are the two new points on edge `(i, i+1)`; for primal schemes
    `Q[2i]` is the vertex point of `P[i]` and `Q[2i+1]` the edge point of `(i, i+1)`;
    for `LaneRiesenfeld`, `Q[2i]` and `Q[2i+1]` are the points that sat at those
    indices after the split, before the averaging passes. In general
    `Q[K] = sum_j a[K - 2j] P[j]` with `a` the scheme's mask.

    Non-finite values in `points` propagate to the outputs they touch (refinement is
    linear); scheme parameters are range-checked when the scheme is built.
    """
    if isinstance(points, np.ndarray) and np.issubdtype(points.dtype, np.floating):
        # jax.jit transfers numpy arrays itself, faster than an eager jnp.asarray.
        pass
    else:
        points = as_float_array(points, "points")
    scheme = _check_scheme(scheme)
    levels = static_int(levels, "levels", minimum=0)
    memory_budget = checked_budget(memory_budget)
    if points.ndim < 2:
        raise ValueError(
            f"`points` must have shape (..., n, d), got shape {points.shape}. For a "
            "sequence of scalars use `points[:, None]`."
        )
    n, d = points.shape[-2:]
    if d < 1:
        raise ValueError("`points` must have at least one coordinate (d >= 1).")
    boundary = _check_boundary(boundary, scheme)
    creases = _check_creases(creases, n, boundary)
    _check_enough_points(n, scheme, boundary)
    _check_memory(
        n, d, math.prod(points.shape[:-2]), jnp.dtype(points.dtype).itemsize, scheme, levels,
        boundary, creases, memory_budget,
    )  # fmt: skip
    return _refine_jit(points, scheme, levels, boundary, creases)


def subdivision_matrix(
    n: int,
    scheme: AbstractCurveScheme,
    levels: int,
    boundary: Boundary = "closed",
    *,
    creases: Sequence[int] | None = None,
    memory_budget: int = DEFAULT_MEMORY_BUDGET,
) -> Float[Array, "N n"]:
    """The linear map $S$ with `refine(P, ...) == S @ P` for `n` control points.

    Built by refining the identity, so it is exact, differentiable in the scheme's
    parameters, and in the dtype of the scheme's mask. It is dense (`N x n`): use it for
    analysis and small fits, and `refine` for large curves.

    **Arguments:** as for [`jaxsubdiv.refined_count`][], and `memory_budget` as for
    [`jaxsubdiv.refine`][] (default 2 GiB), which here also counts the `n x n` identity;
    the check runs before the identity is built.

    **Returns:** an array of shape `(N, n)`.
    """
    scheme = _check_scheme(scheme)
    n = static_int(n, "n", minimum=1)
    levels = static_int(levels, "levels", minimum=0)
    memory_budget = checked_budget(memory_budget)
    boundary = _check_boundary(boundary, scheme)
    checked = _check_creases(creases, n, boundary)
    _check_enough_points(n, scheme, boundary)
    dtype = scheme.mask().dtype
    itemsize = jnp.dtype(dtype).itemsize
    identity = n * n * itemsize
    _check_memory(
        n, n, 1, itemsize, scheme, levels, boundary, checked, memory_budget,
        extra=identity, caller="subdivision_matrix",
    )  # fmt: skip
    eye = jnp.eye(n, dtype=dtype)
    return refine(
        eye, scheme, levels, boundary=boundary, creases=creases, memory_budget=memory_budget
    )
