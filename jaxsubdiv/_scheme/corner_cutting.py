from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._misc import checked_parameter, real_array
from .base import AbstractCurveScheme


def _ordered(r, s):
    return (0 < r) & (r < s) & (s < 1)


class CornerCutting(AbstractCurveScheme):
    r"""General corner cutting with two ratios $0 < r < s < 1$.

    Each edge $(P_i, P_{i+1})$ is replaced by two points:

    $$Q_{2i} = (1-r) P_i + r P_{i+1}, \qquad Q_{2i+1} = (1-s) P_i + s P_{i+1}.$$

    Mask $(r, s, 1-r, 1-s)$ on $k = -2, \dots, 1$. `CornerCutting(1/4, 3/4)` is
    [`jaxsubdiv.Chaikin`][]. Every $0 < r < s < 1$ gives a continuous limit
    (de Rham 1947; Gregory and Qu 1996), but the limit is $C^1$ only on part of that
    triangle: use `jaxsubdiv.smoothness` to check a pair rather than assuming it.

    **Arguments:**

    - `r`, `s`: the two ratios, $0 < r < s < 1$; real numbers (complex ones are a
      `TypeError`); JAX scalars are fine (traced, differentiable, vmappable).

    Boundaries: `"closed"`, `"open"` ($n \to 2(n-1)$), `"clamped"` (end points kept:
    $n \to 2n$), and creases.
    """

    r: Float[Array, ""]
    s: Float[Array, ""]
    clamp_ghost: ClassVar[str] = "reflect"

    def __init__(self, r: ArrayLike, s: ArrayLike):
        message = "`CornerCutting(r, s)` needs 0 < r < s < 1."
        r, s = real_array(r, "CornerCutting(r)"), real_array(s, "CornerCutting(s)")
        self.r = checked_parameter(r, _ordered, message, s, name="CornerCutting(r)")
        self.s = checked_parameter(
            s, lambda s_, r_: _ordered(r_, s_), message, r, name="CornerCutting(s)"
        )

    def mask(self) -> Float[Array, " 4"]:
        return jnp.stack([self.r, self.s, 1 - self.r, 1 - self.s])

    @property
    def mask_length(self) -> int:
        return 4

    @property
    def mask_start(self) -> int:
        return -2
