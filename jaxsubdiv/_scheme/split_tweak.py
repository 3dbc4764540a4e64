from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._misc import checked_parameter
from .base import AbstractCurveScheme


class SplitTweak(AbstractCurveScheme):
    r"""Rossignac's split-and-tweak family, from the cubic B-spline ($t=0$) to the
    four-point scheme ($t=1$).

    Split every edge at its midpoint $M_{ij}$; with $D_j = V_i/8 + V_k/8 - V_j/4$ for
    consecutive $i, j, k$, move each old vertex $V_j$ by $(1-t) D_j$ and each midpoint
    $M_{ij}$ by $-t (D_i + D_j)/2$. Expanded:

    $$Q_{2j} = \tfrac{1-t}{8}(V_{j-1} + V_{j+1}) + \tfrac{3+t}{4} V_j, \qquad
      Q_{2j+1} = (\tfrac12 + \tfrac{t}{16})(V_j + V_{j+1}) - \tfrac{t}{16}(V_{j-1} + V_{j+2}).$$

    The mask is $(1-t)$ times the cubic B-spline mask plus $t$ times the four-point mask
    with $w = 1/16$; [`jaxsubdiv.Jarek`][] is $t = 1/2$.

    **Arguments:**

    - `t`: the tweak, a real number with $0 \le t \le 1$ (traced, differentiable, vmappable).

    Boundaries: `"closed"`, `"open"` ($n \to 2n - 5$), `"clamped"` (reflected ghost
    points, ends kept; note `FourPoint`'s classic clamped rule repeats the end points
    instead, so `SplitTweak(1)` and `FourPoint(1/16)` differ near clamped ends), creases.

    Reference: J. Rossignac, "Education-driven research in CAD", Computer-Aided Design
    36 (2004) 1461-1469.
    """

    t: Float[Array, ""]
    clamp_ghost: ClassVar[str] = "reflect"

    def __init__(self, t: ArrayLike):
        self.t = checked_parameter(
            t,
            lambda t_: (0 <= t_) & (t_ <= 1),
            "`SplitTweak(t)` needs 0 <= t <= 1.",
            name="SplitTweak(t)",
        )

    def mask(self) -> Float[Array, " 7"]:
        t = self.t
        u = t / 16
        return jnp.stack(
            [-u, (1 - t) / 8, 0.5 + u, 1 - (1 - t) / 4, 0.5 + u, (1 - t) / 8, -u]
        )

    @property
    def mask_length(self) -> int:
        return 7

    @property
    def mask_start(self) -> int:
        return -3


def Jarek() -> SplitTweak:
    """Rossignac's "Jarek" scheme: [`jaxsubdiv.SplitTweak`][] with $t = 1/2$.

    Its limit lies between the cubic B-spline and the four-point curves and stays close
    to the control polygon.
    """
    return SplitTweak(0.5)
