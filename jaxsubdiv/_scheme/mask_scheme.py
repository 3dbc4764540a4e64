import warnings
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._misc import as_float_array, checked_parameter
from .base import AbstractCurveScheme


def _sub_mask_sums_ok(mask, start):
    # Affine invariance (and so convergence) needs each sub-mask to sum to one.
    xp = jnp if isinstance(mask, jnp.ndarray) else np
    parity = (start + xp.arange(mask.shape[-1])) % 2
    even = xp.sum(xp.where(parity == 0, mask, 0), axis=-1)
    odd = xp.sum(xp.where(parity == 1, mask, 0), axis=-1)
    return (xp.abs(even - 1) < 1e-6) & (xp.abs(odd - 1) < 1e-6)


class MaskScheme(AbstractCurveScheme):
    r"""Any binary stationary scheme given by its mask.

    One level computes $Q_K = \sum_j a_{K-2j} P_j$ with `mask[m]` $= a_{\text{start}+m}$.
    Equivalently (see [`jaxsubdiv.MaskScheme.from_rules`][]) the even outputs use the
    even sub-mask and the odd outputs the odd sub-mask.

    **Arguments:**

    - `coefficients`: the mask coefficients $a_k$ (real, 1-D, length $L \ge 2$; may be
      traced, so a mask can be differentiated or optimised), stored in the field of that
      name. Each sub-mask must sum to one (the scheme then reproduces constants and is
      affine invariant). `mask=` is a deprecated alias (a `DeprecationWarning`).
    - `start`: the index $k$ of `coefficients[0]` (static int). It fixes where outputs
      sit relative to the control points; for a mask symmetric about $c$,
      `start = c - (L-1)/2`.

    Boundaries: `"closed"` and `"open"`. No clamped rule.
    """

    coefficients: Float[Array, " L"]
    start: int = eqx.field(static=True)
    # In the registry (`scheme_info(MaskScheme)`) but not listed by `schemes()`: its
    # mask is its argument, so there are no parameters with defaults to build it from.
    scheme_name: ClassVar[str] = "mask"
    scheme_title: ClassVar[str] = "mask scheme"
    scheme_listed: ClassVar[bool] = False

    def __init__(
        self,
        coefficients: ArrayLike | None = None,
        start: int | None = None,
        *,
        mask: ArrayLike | None = None,
    ):
        if mask is not None:
            if coefficients is not None:
                raise TypeError(
                    "`MaskScheme` got both `coefficients` and `mask` (its deprecated "
                    "alias); give only `coefficients`."
                )
            warnings.warn(
                "`MaskScheme(mask=...)` is deprecated: the argument is now called "
                "`coefficients`, like the field that holds it; use "
                "`MaskScheme(coefficients=..., start=...)`.",
                DeprecationWarning,
                stacklevel=3,  # the caller, past equinox's __call__
            )
            coefficients = mask
        if coefficients is None or start is None:
            raise TypeError(
                "`MaskScheme(coefficients, start)` needs both the mask coefficients and "
                "`start`, the index k of the first one."
            )
        array = as_float_array(coefficients, "MaskScheme(coefficients)")
        if array.ndim != 1 or array.shape[0] < 2:
            raise ValueError(
                f"`MaskScheme(coefficients=...)` must be 1-D with at least 2 coefficients, "
                f"got shape {array.shape}."
            )
        if isinstance(start, bool) or not isinstance(start, (int, np.integer)):
            raise TypeError(f"`MaskScheme(start=...)` must be an int, got {start!r}.")
        self.start = int(start)
        self.coefficients = checked_parameter(
            array,
            lambda m: _sub_mask_sums_ok(m, self.start),
            "`MaskScheme(coefficients=...)`: the even-indexed and the odd-indexed "
            "coefficients must each sum to 1 (otherwise the scheme is not affine invariant "
            "and does not converge).",
            name="MaskScheme(coefficients)",
        )

    @classmethod
    def from_rules(
        cls, even: ArrayLike, odd: ArrayLike, even_offset: int, odd_offset: int
    ) -> "MaskScheme":
        r"""Build a mask scheme from its two rules

        $$Q_{2i} = \sum_t \mathrm{even}[t]\, P_{i + \mathrm{even\_offset} + t}, \qquad
          Q_{2i+1} = \sum_t \mathrm{odd}[t]\, P_{i + \mathrm{odd\_offset} + t}.$$

        For example Chaikin is `from_rules([3/4, 1/4], [1/4, 3/4], 0, 0)` and the
        four-point scheme `from_rules([1], [-w, 1/2+w, 1/2+w, -w], 0, -1)`.
        """
        even = as_float_array(even, "even")
        odd = as_float_array(odd, "odd")
        if even.ndim != 1 or odd.ndim != 1:
            raise ValueError("`MaskScheme.from_rules`: `even` and `odd` must be 1-D.")
        # Q_{2i+p} = sum_t c_p[t] P_{i+o_p+t}  <=>  a_{p - 2(o_p + t)} = c_p[t].
        positions = {}
        for p, taps, offset in ((0, even, even_offset), (1, odd, odd_offset)):
            for t in range(len(taps)):
                positions[p - 2 * (offset + t)] = (taps, t)
        dtype = jnp.result_type(even, odd)
        lo, hi = min(positions), max(positions)
        entries = []
        for k in range(lo, hi + 1):
            if k in positions:
                taps, t = positions[k]
                entries.append(taps[t])
            else:
                entries.append(jnp.zeros((), dtype=even.dtype))
        return cls(jnp.stack([jnp.asarray(e, dtype) for e in entries]), lo)

    def mask(self) -> Float[Array, " L"]:
        return self.coefficients

    @property
    def mask_length(self) -> int:
        return int(self.coefficients.shape[-1])

    @property
    def mask_start(self) -> int:
        return self.start
