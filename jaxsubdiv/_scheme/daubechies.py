import math
from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, Float

from .base import AbstractCurveScheme


_SQRT3 = math.sqrt(3.0)


class Daubechies(AbstractCurveScheme):
    r"""The Daubechies D4 refinement mask $((1+\sqrt3), (3+\sqrt3), (3-\sqrt3), (1-\sqrt3))/4$.

    Placed on $k = -2, \dots, 1$ like Chaikin's mask, so $Q_{2i}$ and $Q_{2i+1}$ are
    combinations of $P_i$ and $P_{i+1}$:
    $Q_{2i} = \tfrac{3-\sqrt3}{4} P_i + \tfrac{1+\sqrt3}{4} P_{i+1}$ and
    $Q_{2i+1} = \tfrac{1-\sqrt3}{4} P_i + \tfrac{3+\sqrt3}{4} P_{i+1}$.
    The limit is continuous but not $C^1$ (Hölder exponent about 0.55): a fractal-like
    curve, useful as a test of rough schemes.

    Boundaries: `"closed"` and `"open"` ($n \to 2(n-1)$). No clamped rule.

    Reference: I. Daubechies, "Orthonormal bases of compactly supported wavelets",
    Comm. Pure Appl. Math. 41 (1988) 909-996.
    """

    scheme_name: ClassVar[str] = "daubechies"
    scheme_title: ClassVar[str] = "Daubechies D4"

    def mask(self) -> Float[Array, " 4"]:
        return jnp.array([1 + _SQRT3, 3 + _SQRT3, 3 - _SQRT3, 1 - _SQRT3]) / 4

    @property
    def mask_length(self) -> int:
        return 4

    @property
    def mask_start(self) -> int:
        return -2
