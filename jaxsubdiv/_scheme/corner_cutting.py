from collections.abc import Collection, Mapping
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._misc import checked_parameter, real_array
from .base import AbstractCurveScheme, clipped_logit
from .parameter import Parameter


# The limit is C1 only on the line s = r + 1/2 (the symbol must be divisible by
# (1 + z)^2), so with the other ratio at its default neither has a C1 interval: a fit of
# r or s keeps them in the triangle 0 < r < s < 1 and uses the chord model.
RATIO_R = Parameter(
    "r", default=1 / 4, low=0, high=1, low_open=True, high_open=True, c1=None,
    help="corner-cutting ratio r, below s", fit_interval=(0, 1),
)
RATIO_S = Parameter(
    "s", default=3 / 4, low=0, high=1, low_open=True, high_open=True, c1=None,
    help="corner-cutting ratio s, above r", fit_interval=(0, 1),
)


def _ordered(r, s):
    return RATIO_R.valid(r) & (r < s) & RATIO_S.valid(s)


class CornerCutting(AbstractCurveScheme):
    r"""General corner cutting with two ratios $0 < r < s < 1$.

    Each edge $(P_i, P_{i+1})$ is replaced by two points:

    $$Q_{2i} = (1-r) P_i + r P_{i+1}, \qquad Q_{2i+1} = (1-s) P_i + s P_{i+1}.$$

    Mask $(r, s, 1-r, 1-s)$ on $k = -2, \dots, 1$. `CornerCutting(1/4, 3/4)` is
    [`jaxsubdiv.Chaikin`][]. Every $0 < r < s < 1$ gives a continuous limit
    (de Rham 1947; Gregory and Qu 1996), but the limit is $C^1$ only on part of that
    triangle ($C^1$ needs the symbol to be divisible by $(1+z)^2$, that is $s = r + 1/2$,
    as for Chaikin); use `jaxsubdiv.smoothness` to check a pair rather than assuming it.

    **Arguments:**

    - `r`, `s`: the two ratios, $0 < r < s < 1$ (default 1/4 and 3/4: Chaikin); real numbers (complex ones are a
      `TypeError`); JAX scalars are fine (traced, differentiable, vmappable).

    Boundaries: `"closed"`, `"open"` ($n \to 2(n-1)$), `"clamped"` (end points kept:
    $n \to 2n$), and creases.
    """

    r: Float[Array, ""]
    s: Float[Array, ""]
    clamp_ghost: ClassVar[str] = "reflect"
    scheme_name: ClassVar[str] = "corner-cutting"
    scheme_title: ClassVar[str] = "corner cutting"
    scheme_parameters: ClassVar[tuple[Parameter, ...]] = (RATIO_R, RATIO_S)
    #: The relation between the parameters, beyond their ranges (for messages, docs).
    scheme_relation: ClassVar[str] = "0 < r < s < 1"

    def __init__(self, r: ArrayLike = RATIO_R.default, s: ArrayLike = RATIO_S.default):
        message = f"`CornerCutting(r, s)` needs {self.scheme_relation}."
        r, s = real_array(r, "CornerCutting(r)"), real_array(s, "CornerCutting(s)")
        self.r = checked_parameter(r, _ordered, message, s, name="CornerCutting(r)")
        self.s = checked_parameter(
            s, lambda s_, r_: _ordered(r_, s_), message, r, name="CornerCutting(s)"
        )

    def to_unconstrained(self, names: Collection[str]) -> dict[str, Array]:
        r"""Unconstrained reals for the fitted ratios, keeping $0 < r < s < 1$:
        $r = \sigma(a)$, $s = r + (1 - r)\sigma(b)$ when both are fitted; with one of them
        fixed, the other ranges over its open interval ($r = s\,\sigma(a)$,
        $s = r + (1 - r)\sigma(b)$). Inverse of `from_unconstrained`."""
        r, s = self.r, self.s
        out = {}
        if "r" in names:
            # r = s * sigma(a) when s is fixed; sigma(a) when both are fitted.
            out["r"] = clipped_logit(r) if "s" in names else clipped_logit(r / s)
        if "s" in names:
            out["s"] = clipped_logit((s - r) / (1 - r))
        return out

    def from_unconstrained(
        self, names: Collection[str], raw: Mapping[str, Array]
    ) -> "CornerCutting":
        if "r" not in names and "s" not in names:
            return self
        sig = jax.nn.sigmoid
        r, s = self.r, self.s
        if "r" in names and "s" in names:
            r = sig(raw["r"])
            s = r + (1 - r) * sig(raw["s"])
        elif "r" in names:
            r = s * sig(raw["r"])
        else:
            s = r + (1 - r) * sig(raw["s"])
        # tree_at keeps the values as computed (valid by construction; no range check).
        return eqx.tree_at(lambda m: (m.r, m.s), self, (r, s))

    def mask(self) -> Float[Array, " 4"]:
        return jnp.stack([self.r, self.s, 1 - self.r, 1 - self.s])

    @property
    def mask_length(self) -> int:
        return 4

    @property
    def mask_start(self) -> int:
        return -2
