r"""Curve stencil tables of closed curves whose creases are data: a boolean mask, traceable.

[`jaxsubdiv.refine`][] cuts a closed curve at its creases into clamped pieces, so the
curve passes through every creased control point with a corner. Which points are
creased sets `refine`'s shapes there (static). The limit curve at the dyadic parameters
of $L$ levels of a *primal* scheme has $2^L n$ samples whatever the creases are (a
clamped piece of $D$ spans has $2^L D + 1$, its last shared with the next piece), and
every sample reads a window of consecutive control points; only the weights depend on
the creases, and only on the nearest crease on each side, within a few spans:

- a sample at dyadic position $K = 2^L i + \phi$ ($0 \le \phi < 2^L$) lies in the piece
  from the last crease $i - a$ ($a \ge 0$) to the next one $i + b$ ($b \ge 1$), of
  $D = a + b$ spans, at row $2^L a + \phi$ of that piece's clamped table;
- a clamped end changes the rows within its *reach* $\rho$ spans of it (measured, on
  the host: 1 for the cubic B-spline, 2 for the four-point scheme); farther rows are the
  closed curve's periodic rows.

So the rows of every possible piece are few: the clamped tables of pieces of $1, \dots,
2\rho - 1$ spans (both ends may reach a row), the $\rho$ spans of rows at each end of a
piece of $2 \rho$ spans (one end reaches), and the $2^L$ periodic rows. This module
builds that library from the library's own clamped and closed tables
([`jaxsubdiv.curve_stencil`][], differentiable in the scheme's parameters) and gathers each
sample's row by its $(a, b, \phi)$, computed from the mask with cumulative maxima. The
table's layout (`first`, `width`) depends on $n$ and $L$ only: a fit with creases found
in its data compiles once for any number and placement of them.
"""

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._curve_stencil import CurveStencil, HostIndex
from .._misc import check_creasable as check_creasable
from .._scheme.base import AbstractCurveScheme


#: Rows that differ from the periodic ones by less than this (relative to the largest
#: weight) count as equal when the reach is measured: the clamped and closed tables are
#: computed by different refinements, which round differently.
_REACH_TOLERANCE = 1e-12
#: Levels and piece length at which the reach is measured (the reach in spans grows
#: towards its limit from below with the levels, so its ceiling at 5 levels holds at all).
_REACH_LEVELS = 5
_REACH_SPANS = 12


def _concrete(scheme: AbstractCurveScheme) -> bool:
    leaves = jax.tree.leaves(scheme)
    return not any(isinstance(x, jax.core.Tracer) for x in leaves)


#: `(scheme, n, levels, boundary, derivative, dtype) -> CurveStencil`: the library's
#: tables (`limit._stencil`), passed in so that this module does not import `limit`.
Tables = Callable[..., CurveStencil]


def crease_reach(scheme: AbstractCurveScheme, tables: Tables) -> int:
    r"""How many spans from a clamped end its rules change the limit curve's samples:
    the smallest integer $\rho$ such that every sample at least $\rho$ spans from the
    end of a clamped piece equals the closed curve's. Measured on the host, in float64
    whatever JAX's precision setting, from a piece of 12 spans at 5 levels, once per
    scheme type: at the type's default values (a scheme without defaults, such as a
    `MaskScheme`, at its own). A reach that is too large is still exact (the library
    then holds rows that equal the periodic ones), and other values do not reach
    farther: 2 spans for the four-point and split-and-tweak schemes at every w in
    (0, 0.3] and t in [-8, 6.5] tried, 1 at w = 0 or t = 0; 1 for the cubic B-spline.
    So new values compile nothing. One small program, compiled ahead and run at once,
    also inside a caller's trace. Cached.

    Raises `ValueError` for schemes whose clamped pieces are not the closed curve's
    refinement away from their ends (nothing to gather then)."""
    # Concrete values even inside a caller's trace (a default scheme's constructor runs
    # jax.numpy, which a trace would otherwise stage out).
    with jax.ensure_compile_time_eval():
        try:
            measured = type(scheme)()
        except TypeError:
            if not _concrete(scheme):
                raise ValueError(
                    f"creases as a mask measure how far {type(scheme).__name__}'s clamped "
                    "ends reach on the host; its parameters are traced and it has no "
                    "default values to measure at. Build the table outside the trace."
                ) from None
            measured = scheme
        leaves, structure = jax.tree.flatten(measured)
        leaves = [np.asarray(x, np.float64) for x in leaves]
    key = (structure, tuple(x.tobytes() for x in leaves))
    if key not in _REACHES:
        _REACHES[key] = _measured_reach(leaves, structure, tables, type(scheme).__name__)
    return _REACHES[key]


_REACHES: dict = {}


def _measured_reach(leaves, structure, tables: Tables, name: str) -> int:
    levels, spans, rows = _REACH_LEVELS, _REACH_SPANS, 2**_REACH_LEVELS

    def dense(leaves):
        scheme = jax.tree.unflatten(structure, leaves)
        # A closed polygon twice as long, so that its rows over the piece's span read
        # the infinite refinement's windows (those near P_0 read P_{-1}, ... as
        # P_{2s+1}, ...).
        return (tables(scheme, spans + 1, levels, "clamped", 0, np.float64).dense(),
                tables(scheme, 2 * spans + 2, levels, "closed", 0, np.float64).dense())

    # Compiled ahead and called with host arrays: it runs now, also when the caller is
    # tracing (a jitted call would be staged into the caller's program). In float64:
    # float32 rounding would make every row differ.
    with jax.enable_x64(True):
        clamped, closed = jax.jit(dense).lower(leaves).compile()(leaves)
    clamped, closed = np.asarray(clamped), np.asarray(closed)
    periodic = closed[: clamped.shape[0]]
    clamped = np.concatenate([clamped, np.zeros((clamped.shape[0], spans + 1))], axis=1)
    scale = np.max(np.abs(periodic))
    differs = np.max(np.abs(clamped - periodic), axis=1) > _REACH_TOLERANCE * scale
    x = np.arange(clamped.shape[0])
    half = x < clamped.shape[0] // 2
    # The reach from each end: rows x < rho 2^L from the first point, and rows whose
    # distance y = 2^L spans - x to the last point is at most rho 2^L.
    from_left = int(np.max(x[differs & half], initial=-1)) + 1
    from_right = int(np.max((spans * rows - x)[differs & ~half], initial=0))
    reach = max(-(-from_left // rows), -(-from_right // rows), 1)
    if 2 * reach >= spans:
        raise ValueError(
            f"{name}'s clamped pieces differ from its closed curve "
            f"farther than {spans // 2} spans from their ends, so their creases cannot be "
            "gathered from a library of rows. Pass the creases to "
            "`jaxsubdiv.refine(creases=...)` instead."
        )
    return reach


def _piece_rows(table: Float[Array, "N k"], rows: np.ndarray, levels: int, lo: int,
                width: int) -> Float[Array, "r width"]:
    """Rows `rows` of a dense clamped table, as weights on the columns `lo ... lo + width
    - 1` relative to each row's own control point (`row // 2^L`)."""
    own = rows // 2**levels
    column = own[:, None] + lo + np.arange(width)[None, :]  # piece columns
    inside = (column >= 0) & (column < table.shape[1])
    padded = jnp.concatenate([table, jnp.zeros((table.shape[0], 1), table.dtype)], axis=1)
    return padded[rows[:, None], np.where(inside, column, table.shape[1])]


def creased_stencil(
    scheme: AbstractCurveScheme,
    n: int,
    levels: int,
    creases: Bool[Array, " n"],
    reach: int,
    dtype,
    _stencil: Tables,
    derivative: int = 0,
    side: str = "right",
) -> CurveStencil:
    """The closed curve's limit table with creases at the control points where the mask
    `creases` is True (traceable; see the module's docstring). `reach` from
    `crease_reach`; `_stencil` the library's tables (`Tables`). No checks:
    `jaxsubdiv.curve_stencil(creases=...)` makes them.

    `derivative` 1 or 2: the pieces' clamped derivative tables (the schemes of
    `jaxsubdiv.supports_clamped_derivatives`), one-sided at the creases: `side="right"`
    the derivative of the piece that starts there (row 0 of its table), `"left"` that of
    the piece that ends there (its last row). Elsewhere both sides are the same rows."""
    rows = 2**levels
    spans = list(range(1, 2 * reach)) + [2 * reach]
    pieces = [_stencil(scheme, D + 1, levels, "clamped", derivative, dtype).dense()
              for D in spans]
    closed = _stencil(scheme, 2 * reach + 4, levels, "closed", derivative, dtype)
    # Columns relative to a sample's own control point: every piece's rows read at most
    # its whole piece; the periodic rows their window.
    f0 = closed.first[:rows].astype(np.int64)
    f0 = np.where(f0 > closed.n // 2, f0 - closed.n, f0)  # unwrapped, around point 0
    lo = min(-(2 * reach), int(f0.min()))
    hi = max(2 * reach, int(f0.max()) + closed.width - 1)
    width = hi - lo + 1
    library, offsets = [], {}
    # Every row of the short pieces, their last (a crease's, from the left) included.
    for D, table in zip(spans[:-1], pieces[:-1]):  # both ends may reach
        offsets[D] = sum(x.shape[0] for x in library)
        library.append(_piece_rows(table, np.arange(D * rows + 1), levels, lo, width))
    long = pieces[-1]
    offsets["left"] = sum(x.shape[0] for x in library)
    library.append(_piece_rows(long, np.arange(reach * rows), levels, lo, width))
    offsets["right"] = sum(x.shape[0] for x in library)  # y = 0 ... reach 2^L from the end
    library.append(_piece_rows(long, 2 * reach * rows - np.arange(reach * rows + 1),
                               levels, lo, width))
    offsets["periodic"] = sum(x.shape[0] for x in library)
    column = f0[:, None] - lo + np.arange(closed.width)[None, :]
    periodic = jnp.zeros((rows, width), dtype).at[np.arange(rows)[:, None], column].set(
        closed.weights[:rows].astype(dtype))
    library.append(periodic)
    library = jnp.concatenate(library)

    # Each sample's (a, b, phi): the last crease at or before its control point i and
    # the next one after it, cyclically (cumulative maxima over two turns).
    creases = jnp.asarray(creases, bool)
    index = jnp.arange(2 * n)
    marked = jnp.concatenate([creases, creases])
    last = jax.lax.cummax(jnp.where(marked, index, -1))[n:]
    following = jax.lax.cummin(jnp.where(marked, index, 3 * n), reverse=True)
    following = jnp.concatenate([following[1:], jnp.array([3 * n])])[:n]  # strictly after
    # Without any crease, distances beyond every reach: the periodic rows.
    far = 2 * reach * rows
    a = jnp.where(last >= 0, jnp.arange(n) + n - last, far)  # >= 0
    b = jnp.where(last >= 0, following - jnp.arange(n), far)  # >= 1
    K = np.arange(n * rows)
    i, phi = K // rows, jnp.asarray(K % rows)
    a, b = a[i], b[i]
    if side == "left":
        # At a crease the piece that ends there: from the crease before (one turn back
        # when it is the only one) to this one, its last row (b = 0).
        before = jax.lax.cummax(jnp.where(marked, index, -1))[n - 1 : 2 * n - 1]
        at_crease = creases[i] & (phi == 0)
        a = jnp.where(at_crease, (jnp.arange(n) + n - before)[i], a)
        b = jnp.where(at_crease, 0, b)
    x, y = a * rows + phi, b * rows - phi  # samples from the last and to the next crease
    D = a + b
    exact = jnp.zeros_like(x)
    for Dk in spans[:-1]:
        exact = jnp.where(D == Dk, offsets[Dk] + x, exact)
    row = jnp.where(
        D < 2 * reach, exact,
        jnp.where(x < reach * rows, offsets["left"] + x,
                  jnp.where(y <= reach * rows, offsets["right"] + y,
                            offsets["periodic"] + phi)))
    first = (i + lo) % n
    return CurveStencil(HostIndex(first), library[row], n, True)
