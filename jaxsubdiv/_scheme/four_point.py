from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._misc import checked_parameter
from .base import AbstractCurveScheme
from .parameter import Parameter


#: The tension `w`. Valid on $-1/4 < w < 1/4$ (Dyn, Levin, Gregory 1987); $C^1$ for
#: $0 < w < 0.1927...$ (Hechler, Mößner, Reif 2009, "C1-continuity of the generalized
#: four-point scheme", Linear Algebra Appl. 430), and `jaxsubdiv.smoothness` certifies
#: 0.19, so the fit keeps `w` in $(0, 0.19)$. Dyn, Levin and Gregory's
#: $(\sqrt5 - 1)/8$ is a sufficient bound.
TENSION = Parameter(
    "w", default=1 / 16, low=-1 / 4, high=1 / 4, low_open=True, high_open=True,
    c1=(0, 0.19), help="four-point tension",
)


class FourPoint(AbstractCurveScheme):
    r"""The Dyn-Levin-Gregory four-point interpolating scheme with tension `w`.

    Old points are kept and one point is inserted on every edge:

    $$Q_{2i} = P_i, \qquad
      Q_{2i+1} = (\tfrac12 + w)(P_i + P_{i+1}) - w(P_{i-1} + P_{i+2}).$$

    Mask $(-w, 0, \tfrac12 + w, 1, \tfrac12 + w, 0, -w)$ on $k = -3, \dots, 3$.
    At $w = 1/16$ the scheme reproduces cubic polynomials; $w = 0$ is piecewise-linear
    interpolation.

    **Arguments:**

    - `w`: the tension, a real number with $-1/4 < w < 1/4$ (default $1/16$). On that interval the
      difference scheme is contractive in the max norm ($\tfrac12 + 2|w| < 1$), so the
      scheme converges (Dyn, Levin and Gregory 1987); smoothness ($C^1$ or not) depends
      on `w`: see `jaxsubdiv.smoothness`.

    Boundaries: `"closed"`, `"open"` ($n \to 2n - 5$), `"clamped"` (the classic rule:
    the end points are repeated as ghost points at every level; $n \to 2n - 1$), and
    creases.

    Reference: N. Dyn, D. Levin, J. A. Gregory, "A 4-point interpolatory subdivision
    scheme for curve design", Computer Aided Geometric Design 4 (1987) 257-268.
    """

    w: Float[Array, ""]
    clamp_ghost: ClassVar[str] = "repeat"
    scheme_name: ClassVar[str] = "four-point"
    scheme_title: ClassVar[str] = "four-point"
    scheme_parameters: ClassVar[tuple[Parameter, ...]] = (TENSION,)

    def __init__(self, w: ArrayLike = TENSION.default):
        self.w = checked_parameter(
            w,
            TENSION.valid,
            f"`FourPoint(w)` needs {TENSION.range_text()}.",
            name="FourPoint(w)",
        )

    def mask(self) -> Float[Array, " 7"]:
        w = self.w
        zero, one = jnp.zeros_like(w), jnp.ones_like(w)
        return jnp.stack([-w, zero, 0.5 + w, one, 0.5 + w, zero, -w])

    @property
    def mask_length(self) -> int:
        return 7

    @property
    def mask_start(self) -> int:
        return -3
