from typing import ClassVar

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._misc import checked_parameter, is_traced
from .base import AbstractCurveScheme
from .parameter import Parameter


#: The tweak `t`: any real number; 0 is the cubic B-spline ($C^2$), 1 the four-point
#: scheme with $w = 1/16$ ($C^1$), 1/2 Rossignac's Jarek scheme (the default). The symbol
#: is $2((1+z)/2)^4 q(z)$ with $q = (-t/2, 1 + t, -t/2)$ for every `t`, so the transition
#: matrices have the eigenvalue $1 + t$ and the Hölder exponent is at most
#: $3 - \log_2|1+t|$; `jaxsubdiv.smoothness` (exact by the invariant polytope algorithm)
#: finds that bound attained at the class boundaries: the scheme converges for
#: $-9 < t < 7$, is $C^1$ for $-5 < t < 3$ and $C^2$ for $-3 < t < 1$. The fit keeps `t`
#: in $(0, 1)$ and the editor's slider covers $[0, 1]$, the family between its two
#: classic ends.
TWEAK = Parameter(
    "t", default=1 / 2, low=None, high=None, low_open=True, high_open=True, c1=(-5, 3),
    fit_interval=(0, 1), converges=(-9, 7), slider=(0, 1),
    help="split-and-tweak parameter t (0: cubic B-spline, 1/2: Jarek, 1: four-point)",
)


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

    - `t`: the tweak, any real number (default 1/2, Jarek's scheme; traced,
      differentiable, vmappable). Rossignac's family is $0 \le t \le 1$; the scheme
      converges for $-9 < t < 7$ (see `TWEAK`), and a concrete `t` outside that builds
      it with a [`jaxsubdiv.DivergenceWarning`][].

    Boundaries: `"closed"`, `"open"` ($n \to 2n - 5$), `"clamped"` (reflected ghost
    points, ends kept; note `FourPoint`'s classic clamped rule repeats the end points
    instead, so `SplitTweak(1)` and `FourPoint(1/16)` differ near clamped ends), creases.

    Reference: J. Rossignac, "Education-driven research in CAD", Computer-Aided Design
    36 (2004) 1461-1469.
    """

    t: Float[Array, ""]
    clamp_ghost: ClassVar[str] = "reflect"
    scheme_name: ClassVar[str] = "split-tweak"
    scheme_title: ClassVar[str] = "split-and-tweak"
    scheme_parameters: ClassVar[tuple[Parameter, ...]] = (TWEAK,)

    def __init__(self, t: ArrayLike = TWEAK.default):
        self.t = checked_parameter(
            t, TWEAK.valid, "`SplitTweak(t)` needs a finite real number.", name="SplitTweak(t)"
        )
        if not is_traced(self.t):
            TWEAK.warn_if_divergent(self.t, "SplitTweak")

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


# Jarek's mask: SplitTweak's at t = 1/2, exact in binary.
_JAREK_MASK = (-1 / 32, 1 / 16, 17 / 32, 7 / 8, 17 / 32, 1 / 16, -1 / 32)


class Jarek(AbstractCurveScheme):
    r"""Rossignac's "Jarek" scheme: the split-and-tweak scheme at $t = 1/2$.

    $$Q_{2j} = \tfrac1{16}(V_{j-1} + V_{j+1}) + \tfrac78 V_j, \qquad
      Q_{2j+1} = \tfrac{17}{32}(V_j + V_{j+1}) - \tfrac1{32}(V_{j-1} + V_{j+2}).$$

    Mask $(-1, 2, 17, 28, 17, 2, -1)/32$ on $k = -3, \dots, 3$: the average of the cubic
    B-spline and four-point ($w = 1/16$) masks, so the same curve as
    [`jaxsubdiv.SplitTweak`][]`(1/2)`, but a class of its own without parameters (a
    constant mask, exact in float64 for the analysis, and saved as `Jarek` in result
    files). Its limit lies between the cubic B-spline and the four-point curves and stays
    close to the control polygon; it is $C^2$ (Hölder exponent $3 - \log_2 1.5$).

    Boundaries: as `SplitTweak`: `"closed"`, `"open"` ($n \to 2n - 5$), `"clamped"`
    (reflected ghost points), creases.

    Reference: J. Rossignac, "Education-driven research in CAD", Computer-Aided Design
    36 (2004) 1461-1469.
    """

    clamp_ghost: ClassVar[str] = "reflect"
    scheme_name: ClassVar[str] = "jarek"
    scheme_title: ClassVar[str] = "Jarek (split-and-tweak, t = 1/2)"

    def mask(self) -> Float[Array, " 7"]:
        return jnp.array(_JAREK_MASK)

    def host_mask(self) -> np.ndarray:
        # Exact in float64 whatever JAX's default dtype.
        return np.array(_JAREK_MASK, np.float64)

    @property
    def mask_length(self) -> int:
        return 7

    @property
    def mask_start(self) -> int:
        return -3
