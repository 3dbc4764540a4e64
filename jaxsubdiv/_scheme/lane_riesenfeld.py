from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._misc import static_int
from .base import AbstractCurveScheme, binomial_row
from .parameter import Parameter


#: The largest `LaneRiesenfeld` degree. The mask is $\binom{d+1}{k} / 2^d$, and the
#: binomials stay below $2^{53}$ up to $d = 55$, so up to there the mask is exact in
#: float64. From $d = 56$ it is rounded, and the rounded mask is no longer divisible by
#: $(1+z)^{d+1}$ to working precision: it is not the degree-$d$ B-spline scheme any more
#: (`smoothness` then reports $C^8$ for $d = 56$, where the B-spline is $C^{55}$). The
#: integer binomials overflowed JAX's int32/int64 arrays from $d = 31$ / $63$; they are
#: now divided in Python. A $C^{54}$ limit is far past any practical use anyway.
MAX_DEGREE = 55

#: The degree: static (it sets the mask length), so not fittable.
DEGREE = Parameter(
    "degree", default=3, low=1, high=MAX_DEGREE, low_open=False, high_open=False, c1=None,
    help="Lane-Riesenfeld degree", integer=True,
)


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

    - `degree`: the B-spline degree, $1 \le d \le 55$ (default 3; static: it sets the mask
      length). Up to 55 the mask is exact in float64 (see `MAX_DEGREE`); in float32
      (JAX's default) it is exact up to degree 26 and rounded above, which is fine for
      refining but not for analysis: `smoothness` and `analyze` use the exact float64
      mask.

    Boundaries: `"closed"`, `"open"` ($n \to 2n - d$), `"clamped"` (reflected ghost
    points, ends kept), and creases.

    Reference: J. M. Lane, R. F. Riesenfeld (1980), IEEE PAMI 2, 35-46.
    """

    degree: int = eqx.field(static=True)
    clamp_ghost: ClassVar[str] = "reflect"
    scheme_name: ClassVar[str] = "lane-riesenfeld"
    scheme_title: ClassVar[str] = "Lane-Riesenfeld"
    scheme_parameters: ClassVar[tuple[Parameter, ...]] = (DEGREE,)

    def __init__(self, degree: int = DEGREE.default):
        self.degree = static_int(
            degree,
            "LaneRiesenfeld(degree)",
            minimum=DEGREE.low,
            maximum=DEGREE.high,
            why=(
                f": above it the mask binomial(degree+1, k) / 2^degree is no longer exact "
                f"in float64, so it is not that B-spline scheme; use a degree <= {MAX_DEGREE}"
            ),
        )

    def mask(self) -> Float[Array, " degree+2"]:
        # Exact integer binomials divided by 2^d in Python (int / int is correctly
        # rounded), so no integer array overflows int32/int64 (from d = 31 / 63).
        scale = 2**self.degree
        return jnp.array([c / scale for c in binomial_row(self.degree + 1)])

    def host_mask(self) -> np.ndarray:
        # Exact in float64 whatever JAX's default dtype (the float32 mask is rounded
        # from degree 27 on, and its analysis would then see a different scheme).
        scale = 2**self.degree
        return np.array([c / scale for c in binomial_row(self.degree + 1)], np.float64)

    @property
    def mask_length(self) -> int:
        return self.degree + 2

    @property
    def mask_start(self) -> int:
        return -self.degree
