from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, Float

from .base import AbstractCurveScheme


class CubicBSpline(AbstractCurveScheme):
    r"""Uniform cubic B-spline subdivision (primal form).

    $$Q_{2i} = \tfrac18 (P_{i-1} + 6 P_i + P_{i+1}), \qquad
      Q_{2i+1} = \tfrac12 (P_i + P_{i+1}).$$

    Mask $(1, 4, 6, 4, 1)/8$ on $k = -2, \dots, 2$. The limit is the uniform cubic
    B-spline with control points $P$ ($C^2$). Equals `LaneRiesenfeld(3)` up to a shift
    of index and `SplitTweak(0)`.

    Boundaries: `"closed"`, `"open"` ($n \to 2n - 3$), `"clamped"` (end points kept,
    from reflected ghost points $2P_0 - P_1$: $n \to 2n - 1$, the curve interpolates
    the ends), and creases.

    Reference: J. M. Lane, R. F. Riesenfeld, "A theoretical development for the
    computer generation and display of piecewise polynomial surfaces", IEEE PAMI 2
    (1980) 35-46.
    """

    clamp_ghost: ClassVar[str] = "reflect"
    scheme_name: ClassVar[str] = "cubic-bspline"
    scheme_title: ClassVar[str] = "cubic B-spline"

    def mask(self) -> Float[Array, " 5"]:
        return jnp.array([1.0, 4.0, 6.0, 4.0, 1.0]) / 8

    @property
    def mask_length(self) -> int:
        return 5

    @property
    def mask_start(self) -> int:
        return -2
