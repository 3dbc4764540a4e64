from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, Float

from .base import AbstractCurveScheme


class Chaikin(AbstractCurveScheme):
    r"""Chaikin's corner cutting (1974): the quadratic uniform B-spline scheme.

    Each edge $(P_i, P_{i+1})$ is replaced by the points at 1/4 and 3/4 along it:

    $$Q_{2i} = \tfrac34 P_i + \tfrac14 P_{i+1}, \qquad Q_{2i+1} = \tfrac14 P_i + \tfrac34 P_{i+1}.$$

    Mask $(1, 3, 3, 1)/4$ on $k = -2, \dots, 1$. The limit is the uniform quadratic
    B-spline of the control polygon: $C^1$, not $C^2$. Same as
    `CornerCutting(1/4, 3/4)` and `LaneRiesenfeld(2)`.

    Boundaries: `"closed"`, `"open"` ($n \to 2(n-1)$), `"clamped"` (end points kept:
    $n \to 2n$), and creases.

    Reference: G. Chaikin, "An algorithm for high-speed curve generation", Computer
    Graphics and Image Processing 3 (1974) 346-349.
    """

    clamp_ghost: ClassVar[str] = "reflect"
    scheme_name: ClassVar[str] = "chaikin"
    scheme_title: ClassVar[str] = "Chaikin"

    def mask(self) -> Float[Array, " 4"]:
        return jnp.array([1.0, 3.0, 3.0, 1.0]) / 4

    @property
    def mask_length(self) -> int:
        return 4

    @property
    def mask_start(self) -> int:
        return -2
