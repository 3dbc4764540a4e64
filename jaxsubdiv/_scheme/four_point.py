from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._misc import checked_parameter, is_traced
from .base import AbstractCurveScheme
from .parameter import Parameter


#: The tension `w`: any real number. The scheme converges exactly for $-1/2 < w < 1/2$
#: (`jaxsubdiv.smoothness`, exact by the invariant polytope algorithm; at $w = \pm 1/2$
#: the transition matrices have the eigenvalue $4w = \pm 2$, so the Hölder exponent is
#: $\le 0$ there), well beyond Dyn, Levin and Gregory's sufficient $|w| < 1/4$ (1987).
#: It is $C^1$ exactly for $0 < w < w^* = 0.19273$, the real root of $32w^3 + 4w - 1$
#: (Hechler, Mößner, Reif 2009, "C1-continuity of the generalized four-point scheme",
#: Linear Algebra Appl. 430), which `smoothness` confirms; the fit keeps `w` in
#: $(0, 0.19)$.
TENSION = Parameter(
    "w", default=1 / 16, low=None, high=None, low_open=True, high_open=True,
    c1=(0, 0.19), converges=(-1 / 2, 1 / 2), help="four-point tension",
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

    - `w`: the tension, any real number (default $1/16$; traced, differentiable,
      vmappable). The scheme converges for $-1/2 < w < 1/2$ and is $C^1$ for
      $0 < w < 0.19273$ (see `TENSION` and `docs/analysis.md`); a concrete `w` outside
      $(-1/2, 1/2)$ builds the scheme with a [`jaxsubdiv.DivergenceWarning`][]: the rule
      is applied, but there is no limit curve. Dyn, Levin and Gregory's $|w| < 1/4$,
      where the difference scheme contracts in one step in the max norm
      ($\tfrac12 + 2|w| < 1$), is sufficient only.

    Boundaries: `"closed"`, `"open"` ($n \to 2n - 5$), `"clamped"` (the classic rule:
    the end points are repeated as ghost points at every level; $n \to 2n - 1$), and
    creases. The clamped end is not a regular point of the curve: the rule maps
    $(P_0, P_1, P_2)$ to $(P_0, \tfrac12 P_0 + (\tfrac12 + w) P_1 - w P_2, P_1)$, with
    eigenvalues $1$ and the roots of $\lambda^2 - (\tfrac12 + w)\lambda + w$, not
    $\tfrac12$. For $0 < w < (3 - \sqrt 8)/2 \approx 0.0858$ (so at $w = 1/16$) the
    larger root is below $\tfrac12$ (0.41 at $1/16$): the curve leaves its end
    tangentially but with zero speed, $|C(t) - P_0| \sim t^{1.29}$. From $0.0858$ on
    the roots are complex: the curve winds around its end point without a tangent
    there, although the closed scheme is $C^1$ up to $w = 0.19$ (tested in
    `tests/test_analysis.py`).

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
            "`FourPoint(w)` needs a finite real number.",
            name="FourPoint(w)",
        )
        if not is_traced(self.w):
            TENSION.warn_if_divergent(self.w, "FourPoint")

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
