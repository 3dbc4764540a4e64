"""Stencil tables: sparse linear maps from base vertices to refined or limit vertices.

Built on the host as a coordinate list (`Sparse`), composed on the host, then frozen into
a [`jaxsubdiv.surfaces.StencilTable`][] whose application is one jitted gather, multiply
and segment-sum.
"""

import dataclasses
import functools as ft
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int, Shaped

from .._misc import as_float_array, device_put_copy, is_traced


@dataclasses.dataclass(frozen=True)
class Sparse:
    """A host-side sparse matrix in coordinate form, rows sorted, duplicates summed.

    Indices are int32 or int64 (scipy's choice for the size)."""

    rows: np.ndarray
    cols: np.ndarray
    weights: np.ndarray
    shape: tuple[int, int]

    @staticmethod
    def build(rows, cols, weights, shape) -> "Sparse":
        """Sum duplicate entries, drop zeros and sort by (row, column)."""
        index = _index_dtype(shape)
        rows = np.asarray(rows, index).reshape(-1)
        cols = np.asarray(cols, index).reshape(-1)
        weights = np.broadcast_to(np.asarray(weights, np.float64), rows.shape).reshape(-1)
        shape = (int(shape[0]), int(shape[1]))
        # scipy's compiled conversion to CSR groups by row in linear time and sorts the
        # few columns of each row: 3-4x faster than a global sort of (row, column) keys
        # (`np.unique`) on Catmull-Clark's level 3 (`benchmarks/bench_surface_build.py`).
        return Sparse._from_csr(_csr((weights, (rows, cols)), shape))

    @staticmethod
    def blocks(rows: list, cols: list, weights: list, shape) -> "Sparse":
        """`build` from lists of equally long blocks, concatenated straight into the
        index dtype (no int64 copies of the whole: less memory to fault in)."""
        index = _index_dtype(shape)
        return Sparse.build(np.concatenate(rows, dtype=index), np.concatenate(cols, dtype=index),
                            np.concatenate(weights, dtype=np.float64), shape)  # fmt: skip

    @staticmethod
    def _from_csr(matrix) -> "Sparse":
        matrix.sum_duplicates()  # sorts the columns of each row too
        if not matrix.data.all():  # a read-only pass, cheaper than the in-place rewrite
            matrix.eliminate_zeros()
        # scipy's index dtype (int32 unless the matrix is huge): no copies, and the
        # stencil tables' int32 indices need none either.
        index = matrix.indices.dtype
        rows = np.repeat(np.arange(matrix.shape[0], dtype=index), np.diff(matrix.indptr))
        return Sparse(rows, matrix.indices, np.asarray(matrix.data, np.float64),
                      (int(matrix.shape[0]), int(matrix.shape[1])))

    def csr(self):
        """The matrix as a `scipy.sparse.csr_matrix`."""
        return _csr((self.weights, self.cols, self.indptr()), self.shape)

    @staticmethod
    def identity(n: int) -> "Sparse":
        i = np.arange(n, dtype=np.int64)
        return Sparse(i, i, np.ones(n), (n, n))

    @staticmethod
    def stack(blocks: list["Sparse"]) -> "Sparse":
        """Rows of `blocks` one after the other (all with the same number of columns)."""
        shift = np.cumsum([0] + [b.shape[0] for b in blocks])
        return Sparse(
            np.concatenate([b.rows + s for b, s in zip(blocks, shift)]),
            np.concatenate([b.cols for b in blocks]),
            np.concatenate([b.weights for b in blocks]),
            (int(shift[-1]), blocks[0].shape[1]),
        )

    def take_rows(self, rows: np.ndarray) -> "Sparse":
        """The sub-matrix made of `rows` (in that order)."""
        indptr = self.indptr()
        counts = indptr[rows + 1] - indptr[rows]
        new_row = np.repeat(np.arange(len(rows)), counts)
        src = np.repeat(indptr[rows], counts) + _ranks(counts)
        return Sparse(new_row, self.cols[src], self.weights[src], (len(rows), self.shape[1]))

    def indptr(self) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(np.bincount(self.rows, minlength=self.shape[0]))])

    def __matmul__(self, other: "Sparse") -> "Sparse":
        """Sparse product on the host (scipy's compiled CSR product)."""
        assert self.shape[1] == other.shape[0]
        return Sparse._from_csr(self.csr() @ other.csr())

    def dense(self) -> np.ndarray:
        out = np.zeros(self.shape)
        np.add.at(out, (self.rows, self.cols), self.weights)
        return out


def _index_dtype(shape) -> type:
    """int32 indices where they fit (scipy's choice too): scipy then skips scanning int64
    ones for their range, and the copies are half the size."""
    return np.int32 if max(shape) < 2**31 - 1 else np.int64


def _csr(*args, **kwargs):
    # Imported when first needed: scipy.sparse costs about 0.1 s to import, and
    # `import jaxsubdiv` stays light. (scipy is a dependency of JAX itself.)
    import scipy.sparse

    return scipy.sparse.csr_matrix(*args, **kwargs)


def _ranks(counts: np.ndarray) -> np.ndarray:
    """`concatenate([arange(c) for c in counts])` without a Python loop."""
    total = int(counts.sum())
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(total) - starts


def _index_array(x) -> Array:
    """An int32 JAX array. Concrete input is converted on the host and transferred
    with `jax.device_put` (`jnp.asarray` compiles a small kernel per new length, which
    made building tables for many small meshes slow), from a private copy (see
    `device_put_copy`)."""
    if is_traced(x) or isinstance(x, jax.Array):
        return jnp.asarray(x, jnp.int32)
    return device_put_copy(x, np.int32)


def _weight_array(x) -> Array:
    """A floating JAX array, transferred like `_index_array`."""
    if is_traced(x) or isinstance(x, jax.Array):
        return as_float_array(x, "weights")
    x = np.asarray(x)
    return device_put_copy(x, None if np.issubdtype(x.dtype, np.floating) else np.float64)


@ft.partial(jax.jit, static_argnums=4)
def _apply(rows, cols, weights, data, num_rows):
    # One compiled computation (also when called eagerly): gather, scale, segment-sum.
    num_cols, channels = data.shape[-2:]
    batch = data.shape[:-2]
    # Fold the batch axes into the channels: one gather of (nnz, batch * C).
    size = math.prod(batch)  # explicit sizes: tables may have no rows
    flat = jnp.moveaxis(data.reshape(size, num_cols, channels), 0, 1).reshape(num_cols, size * channels)
    out = jax.ops.segment_sum(
        weights.astype(data.dtype)[:, None] * flat[cols],
        rows,
        num_segments=num_rows,
        indices_are_sorted=True,
    )
    out = jnp.moveaxis(out.reshape(num_rows, size, channels), 1, 0)
    return out.reshape(*batch, num_rows, channels)


class StencilTable(eqx.Module):
    r"""A sparse linear map from base vertex data to new vertex data, applied in JAX.

    Row $i$ of the table says that new vertex $i$ is $\sum_j w_{ij} P_j$, a weighted
    sum of base vertices. This is OpenSubdiv's *stencil table*: topology is analyzed
    once on the host, and every later evaluation, for any positions or per-vertex
    features on the same mesh, is this one kernel. It is linear in the data, so it is
    differentiable (its transpose is a scatter-add), and it accepts leading batch axes
    or `jax.vmap`.

    The table is stored in coordinate form sorted by row (`rows`, `cols`, `weights`)
    and applied as a gather, multiply and sorted segment-sum. Padded
    `(rows, max width)` gathers and rows grouped by stencil width are the alternative
    layouts; `benchmarks/bench_surfaces.py` measures them against this one, which was
    not slower on CPU (see `docs/surfaces.md`).

    Usually built for you by [`jaxsubdiv.surfaces.Refiner`][] (one per level, or
    `Refiner.composite()`) or [`jaxsubdiv.surfaces.Limit`][];
    `StencilTable(rows, cols, weights, num_rows, num_cols)` builds one from coordinate
    lists.
    """

    rows: Int[Array, " nnz"]
    cols: Int[Array, " nnz"]
    weights: Float[Array, " nnz"]
    num_rows: int = eqx.field(static=True)
    num_cols: int = eqx.field(static=True)

    def __init__(
        self,
        rows: ArrayLike,
        cols: ArrayLike,
        weights: ArrayLike,
        num_rows: int,
        num_cols: int,
        *,
        _owned: bool | str = False,
    ):
        """**Arguments:**

        - `rows`, `cols`: integer arrays of the same length: entry $k$ adds
          `weights[k] * data[cols[k]]` to output row `rows[k]`. Sorted by row.
        - `weights`: float array of the same length.
        - `num_rows`, `num_cols`: the number of output and input vertices.
        """
        if _owned == "device":
            # `from_built`: device arrays of a `Sparse.build`, whose rows are sorted by
            # construction (checking them again was a pass over every entry).
            self.rows, self.cols, self.weights = rows, cols, weights
            self.num_rows, self.num_cols = int(num_rows), int(num_cols)
            return
        rows_np = np.asarray(rows)
        if rows_np.ndim != 1 or np.shape(cols) != rows_np.shape or np.shape(weights) != rows_np.shape:
            raise ValueError("`rows`, `cols` and `weights` must be 1-d arrays of one length.")
        if not isinstance(rows, jax.core.Tracer) and len(rows_np) > 1 and np.any(np.diff(rows_np) < 0):
            raise ValueError("`rows` must be sorted (non-decreasing).")
        if _owned:
            # `from_sparse`: a build's own numpy arrays, which nothing changes afterwards:
            # one `device_put`, without the copies that protect a caller's arrays.
            self.rows, self.cols, self.weights = jax.device_put((rows, cols, weights))
        else:
            self.rows = _index_array(rows)
            self.cols = _index_array(cols)
            self.weights = _weight_array(weights)
        self.num_rows = int(num_rows)
        self.num_cols = int(num_cols)

    @staticmethod
    def from_sparse(sparse: Sparse) -> "StencilTable":
        return StencilTable(np.asarray(sparse.rows, np.int32), np.asarray(sparse.cols, np.int32),
                            np.asarray(sparse.weights, np.float64), *sparse.shape, _owned=True)

    @staticmethod
    def from_built(built: list[Sparse], extra) -> tuple[list["StencilTable"], object]:
        """Tables of `Sparse.build` results (rows sorted: not checked again), and the
        numpy pytree `extra` on the device, in one `device_put`: each call costs about
        0.1 ms of JAX dispatch, as much as building a level of a small mesh."""
        host = [(np.asarray(s.rows, np.int32), np.asarray(s.cols, np.int32),
                 np.asarray(s.weights, np.float64)) for s in built]  # fmt: skip
        device, extra = jax.device_put((host, extra))
        return [StencilTable(*arrays, *s.shape, _owned="device") for arrays, s in zip(device, built)], extra

    def __call__(self, data: Shaped[ArrayLike, "*batch V C"]) -> Float[Array, "*batch N C"]:
        """Apply the table to per-vertex `data`.

        **Arguments:**

        - `data`: `(..., num_cols, C)`: one row per base vertex, any number of channels
          (positions, colors, features) and any leading batch axes.

        **Returns:**

        `(..., num_rows, C)`, in the floating dtype of `data`.
        """
        data = as_float_array(data, "vertices")
        if data.ndim < 2 or data.shape[-2] != self.num_cols:
            raise ValueError(
                f"`vertices` must have shape (..., {self.num_cols}, channels) for this "
                f"mesh, got {data.shape}."
            )
        return _apply(self.rows, self.cols, self.weights, data, self.num_rows)

    def dense(self) -> Float[Array, "N V"]:
        """The table as a dense `(num_rows, num_cols)` matrix (for small meshes)."""
        out = jnp.zeros((self.num_rows, self.num_cols), self.weights.dtype)
        return out.at[self.rows, self.cols].add(self.weights)
