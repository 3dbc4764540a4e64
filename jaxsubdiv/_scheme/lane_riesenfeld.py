from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._misc import static_int
from .base import AbstractCurveScheme, binomial_row


class LaneRiesenfeld(AbstractCurveScheme):
    r"""Lane-Riesenfeld subdivision of any degree: split, then average.

    One level splits every edge at its midpoint ($Q_{2i} = P_i$,
    $Q_{2i+1} = (P_i + P_{i+1})/2$) and then makes `degree - 1` passes that replace
    each point by the average of itself and its next neighbor. The mask is the binomial
    row $\binom{d+1}{k} / 2^d$ on $k = -d, \dots, 1$, and the limit is the uniform
    B-spline of degree $d$ (order $d + 1$), which is $C^{d-1}$.

    `degree=1` is piecewise-linear, `degree=2` is [`jaxsubdiv.Chaikin`][], `degree=3` is
    [`jaxsubdiv.CubicBSpline`][] shifted by one index (output $Q_{2i}$ is the edge point
    of $(P_i, P_{i+1})$ and $Q_{2i+1}$ the vertex point of $P_{i+1}$). Index
    convention: output $K$ is the point that sat at index $K$ after the split, before the
    averaging passes.

    **Arguments:**

    - `degree`: the B-spline degree $d \ge 1$ (static: it sets the mask length).

    Boundaries: `"closed"`, `"open"` ($n \to 2n - d$), `"clamped"` (reflected ghost
    points, ends kept), and creases.

    Reference: J. M. Lane, R. F. Riesenfeld (1980), IEEE PAMI 2, 35-46.
    """

    degree: int = eqx.field(static=True)
    clamp_ghost: ClassVar[str] = "reflect"

    def __init__(self, degree: int):
        self.degree = static_int(degree, "LaneRiesenfeld(degree)", minimum=1)

    def mask(self) -> Float[Array, " degree+2"]:
        return jnp.array(binomial_row(self.degree + 1)) / 2**self.degree

    @property
    def mask_length(self) -> int:
        return self.degree + 2

    @property
    def mask_start(self) -> int:
        return -self.degree
