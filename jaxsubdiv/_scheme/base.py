import abc
import math
from typing import ClassVar, Literal

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float


class AbstractCurveScheme(eqx.Module):
    r"""A binary, stationary, linear subdivision scheme for curves.

    Every curve scheme in jaxsubdiv is described by its *mask* (the coefficients of its
    symbol $a(z) = \sum_k a_k z^k$): one level of refinement maps control points $P_j$ to

    $$Q_K = \sum_j a_{K - 2j} P_j,$$

    so the even outputs $Q_{2i}$ use the even-indexed coefficients and the odd outputs
    $Q_{2i+1}$ the odd-indexed ones (the two *sub-masks*). A single mask-driven kernel
    refines every scheme; subclasses only say what their mask is.

    Subclasses implement [`jaxsubdiv.AbstractCurveScheme.mask`][] and
    `mask_start` (the index $k$ of the first coefficient), and may set the class
    variable `clamp_ghost` to support `boundary="clamped"`.

    Numeric parameters (`r`, `s`, `w`, `t`, a user mask) are JAX array fields: they can be
    traced, differentiated and vmapped. Shape-setting integers (a degree) are static.
    """

    #: How ghost points are made beyond the ends for ``boundary="clamped"``:
    #: ``"reflect"`` ($P_{-q} = 2P_0 - P_q$, reproduces lines), ``"repeat"``
    #: ($P_{-q} = P_0$), or ``None`` when the scheme has no clamped rule.
    clamp_ghost: ClassVar[Literal["reflect", "repeat"] | None] = None

    @abc.abstractmethod
    def mask(self) -> Float[Array, " L"]:
        """The mask coefficients $a_k$ for $k$ = `mask_start`, ..., `mask_start + L - 1`.

        Built with `jax.numpy` from the scheme's parameters, so it is differentiable in
        them. Its length `L` is static.
        """

    def host_mask(self) -> np.ndarray:
        """The mask as a NumPy array, for the host-side analysis (`smoothness`).

        Needs concrete parameters. By default `np.asarray(self.mask())`, in the mask's
        dtype; a scheme whose mask is a constant may return it in float64 whatever
        JAX's default dtype, so its analysis is exact with x64 off too.
        """
        return np.asarray(self.mask())

    @property
    @abc.abstractmethod
    def mask_start(self) -> int:
        """The index $k$ of the first mask coefficient (a static Python int)."""

    @property
    @abc.abstractmethod
    def mask_length(self) -> int:
        """Number of mask coefficients (a static Python int; no array is built)."""

    @property
    def center(self) -> float:
        """Symmetry center $c$ of the mask, $(\\text{first} + \\text{last})/2$.

        Output $Q^{(k)}_K$ after $k$ levels sits at curve parameter
        $K/2^k - c(1 - 2^{-k})$ when control point $P_j$ sits at parameter $j$.
        An integer center is a *primal* scheme (outputs at vertices and edge midpoints),
        a half-integer center a *dual* one (two outputs inside every edge).
        """
        return self.mask_start + (self.mask_length - 1) / 2

    @property
    def is_primal(self) -> bool:
        return float(self.center).is_integer()

    def __check_init__(self):
        # `mask_start` must be a plain int; it sets shapes.
        if not isinstance(self.mask_start, int):
            raise TypeError(f"{type(self).__name__}.mask_start must be an int.")


def binomial_row(n: int) -> list[int]:
    return [math.comb(n, k) for k in range(n + 1)]
