import abc
import math
from collections.abc import Collection, Mapping
from typing import ClassVar, Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .parameter import Parameter, number_text


# How far inside its fit interval a parameter on the interval's edge starts (e.g.
# `SplitTweak(0)`): the logistic reaches the edge only at infinity.
_EDGE = 1e-6


def clipped_logit(p):
    """The inverse of the logistic function, with `p` clipped just inside (0, 1)."""
    p = jnp.clip(p, _EDGE, 1 - _EDGE)
    return jnp.log(p) - jnp.log1p(-p)


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

    A scheme declares itself to the registry (`jaxsubdiv.schemes()`,
    `jaxsubdiv.scheme_info`) with the class variables `scheme_name` (command-line name),
    `scheme_title` and `scheme_parameters` (one [`jaxsubdiv.Parameter`][] per
    constructor argument: default, valid range, $C^1$ interval, help). They are plain
    data, read without importing JAX by the command line.
    """

    #: The scheme's parameters, in constructor order (see `jaxsubdiv.Parameter`).
    scheme_parameters: ClassVar[tuple[Parameter, ...]] = ()
    #: Whether `jaxsubdiv.schemes()` lists the scheme (False: built by its constructor
    #: only, like `MaskScheme`).
    scheme_listed: ClassVar[bool] = True

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

    def to_unconstrained(self, names: Collection[str]) -> dict[str, Array]:
        r"""Unconstrained reals for the parameters `names`, for a fit.

        optimistix has no bound constraints for least squares, so a fitted parameter $p$
        with fit interval $(a, b)$ (its `Parameter.c1` interval) is
        $p = a + (b - a)\,\sigma(u)$, $\sigma$ the logistic function, and this returns
        $u$. A value on the edge of the interval (e.g. `SplitTweak(0)`) starts just inside
        it; a concrete value outside it is a `ValueError` (the fit would start where the
        scheme is not known to be $C^1$). Inverse of `from_unconstrained`.
        """
        out = {}
        for p in type(self).scheme_parameters:
            if p.name in names:
                low, high = p.fit_interval
                value = getattr(self, p.name)
                self._check_fit_start(p, value)
                out[p.name] = clipped_logit((value - low) / (high - low))
        return out

    def from_unconstrained(self, names: Collection[str], raw: Mapping[str, Array]):
        """The scheme with the parameters `names` set from their unconstrained values
        `raw` (see `to_unconstrained`). The values are valid by construction, so they are
        set with `eqx.tree_at`, without the constructor's range check."""
        fitted = [p for p in type(self).scheme_parameters if p.name in names]
        if not fitted:
            return self
        values = tuple(
            p.fit_interval[0]
            + (p.fit_interval[1] - p.fit_interval[0]) * jax.nn.sigmoid(raw[p.name])
            for p in fitted
        )
        return eqx.tree_at(lambda m: tuple(getattr(m, p.name) for p in fitted), self, values)

    def _check_fit_start(self, p: Parameter, value) -> None:
        # A value on an end of the fit interval where the scheme is still C1
        # (SplitTweak(0), the cubic B-spline) starts just inside; any other value outside
        # it is an error.
        if isinstance(value, jax.core.Tracer):
            return
        low, high = p.fit_interval
        value = np.asarray(value)
        inside = (low < value) & (value < high)
        c1_low, c1_high = p.c1 if p.c1 is not None else (np.inf, -np.inf)
        on_edge = ((value == low) | (value == high)) & (c1_low < value) & (value < c1_high)
        if not bool(np.all(inside | on_edge)):
            title = getattr(type(self), "scheme_title", type(self).__name__)
            why = (f", where the {title} scheme is known to be C1" if p.c1 == p.fit_interval
                   else "")
            raise ValueError(
                f"fitting `{p.name}` starts from the scheme's {p.name} = "
                f"{float(np.max(value)) if value.ndim else float(value):.4g}; it must lie in "
                f"({number_text(low)}, {number_text(high)}) (the interval the fit keeps it "
                f"in{why}). Start from e.g. {type(self).__name__}({number_text(p.default)})."
            )

    def __check_init__(self):
        # `mask_start` must be a plain int; it sets shapes.
        if not isinstance(self.mask_start, int):
            raise TypeError(f"{type(self).__name__}.mask_start must be an int.")


def binomial_row(n: int) -> list[int]:
    return [math.comb(n, k) for k in range(n + 1)]
