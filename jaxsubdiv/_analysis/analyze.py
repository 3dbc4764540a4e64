"""`analyze`: everything jaxsubdiv knows about a scheme, in one immutable result."""

import dataclasses
from fractions import Fraction

import numpy as np
from jaxtyping import Float, Inexact

from .._misc import is_traced
from .._scheme.base import AbstractCurveScheme
from .describe import describe as describe
from .local import (
    check_scheme,
    eigen,
    local_matrix,
    natural_location,
    neighborhood,
    stencil_values,
)
from .smoothness import Smoothness, smoothness


def is_interpolating(scheme: AbstractCurveScheme, tol: float = 1e-12) -> bool:
    r"""True when every level keeps the old points: a primal scheme with
    $a_{c + 2m} = \delta_{m0}$ (needs concrete parameters)."""
    if not scheme.is_primal:
        return False
    mask = np.asarray(scheme.mask(), dtype=np.float64)
    c, start = int(scheme.center), scheme.mask_start
    for k in range(start, start + len(mask)):
        if (k - c) % 2 == 0 and abs(mask[k - start] - (k == c)) > tol:
            return False
    return True


def _fmt(values) -> str:
    if values is None:
        return "none"
    array = np.asarray(values)
    # Rounding noise (e.g. 1e-16 where the exact weight is 0) is shown as 0.
    array = np.where(np.abs(array) < 1e-12 * max(1.0, float(np.abs(array).max())), 0, array)
    if np.iscomplexobj(array):
        return "[" + ", ".join(f"{complex(x):.4g}" for x in array) + "]"
    return "[" + ", ".join(f"{float(x) + 0.0:.6g}" for x in array) + "]"


_ARRAY_FIELDS = (
    "mask", "local_matrix", "eigenvalues", "limit_stencil", "tangent_stencil",
    "curvature_stencil",
)


def _hashable(value):
    if isinstance(value, np.ndarray):  # by dtype, shape and bits, as `__eq__` compares
        return (value.dtype.str, value.shape, value.tobytes())
    return value


# A frozen dataclass, not an `eqx.Module`: the report is host data (a name, a location,
# Fractions, NumPy arrays, a `Smoothness`) computed on concrete parameters, never traced,
# so it is one pytree leaf (`jax.tree.map` passes it through whole instead of mapping over
# its strings and numbers), and it is hashable and compares by value.
@dataclasses.dataclass(frozen=True, eq=False)
class Analysis:
    r"""The properties of a curve scheme, as computed by [`jaxsubdiv.analyze`][].

    An immutable value computed on the host (not a JAX pytree: `jax.tree.map` treats it
    as one leaf); its arrays are read-only NumPy arrays. Two results are equal (and hash
    alike) when every field is, the arrays bit for bit.

    - `name`: the scheme with its parameter values, e.g. `FourPoint(w=0.0625)`.
    - `mask`, `mask_start`: the coefficients $a_k$ and the index of the first one.
    - `support`: the open interval, in curve parameter relative to a control point, where
      that point's basis function can be nonzero (e.g. `(-2, 2)` for the cubic B-spline).
    - `primal`, `interpolating`: whether refined points sit at the old vertices, and
      whether they are the old vertices.
    - `location`, `neighborhood`: where the local analysis is done (`"vertex"` for
      primal, `"edge"` for dual schemes) and the relative positions of its points.
    - `local_matrix`, `eigenvalues`: [`jaxsubdiv.local_matrix`][] and its eigenvalues
      sorted by modulus.
    - `limit_stencil`, `tangent_stencil`, `curvature_stencil`: at `location`, or `None`
      where the quantity does not exist (the scheme is not $C^0$, $C^1$, $C^2$).
    - `smoothness`: the [`jaxsubdiv.Smoothness`][] result.

    `str(analysis)` (or `analysis.summary()`) is a readable report.
    """

    name: str
    mask: Float[np.ndarray, " L"]
    mask_start: int
    support: tuple[float, float]
    primal: bool
    interpolating: bool
    location: str
    neighborhood: tuple[Fraction, ...]
    local_matrix: Float[np.ndarray, "m m"]
    eigenvalues: Inexact[np.ndarray, " m"]
    limit_stencil: Float[np.ndarray, " m"] | None
    tangent_stencil: Float[np.ndarray, " m"] | None
    curvature_stencil: Float[np.ndarray, " m"] | None
    smoothness: Smoothness

    def __post_init__(self):
        # Own read-only host copies, so the value (and its hash) cannot change later.
        for name in _ARRAY_FIELDS:
            value = getattr(self, name)
            if value is not None:
                array = np.array(value)
                array.setflags(write=False)
                object.__setattr__(self, name, array)

    def _key(self) -> tuple:
        return tuple(_hashable(getattr(self, f.name)) for f in dataclasses.fields(self))

    def __eq__(self, other) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def summary(self) -> str:
        """A multi-line, human-readable report."""
        lo, hi = self.support
        positions = ", ".join(str(u) for u in self.neighborhood)
        lines = [
            self.name,
            f"  mask               {_fmt(self.mask)} on k = {self.mask_start}.."
            f"{self.mask_start + len(self.mask) - 1}",
            f"  support            ({lo:g}, {hi:g}) around each control point",
            f"  type               {'primal' if self.primal else 'dual'}, "
            f"{'interpolating' if self.interpolating else 'approximating'}",
            f"  neighborhood       {self.location}: ({positions})",
            f"  eigenvalues        {_fmt(self.eigenvalues)}",
            f"  limit stencil      {_fmt(self.limit_stencil)}",
            f"  tangent stencil    {_fmt(self.tangent_stencil)}",
            f"  curvature stencil  {_fmt(self.curvature_stencil)}",
            f"  smoothness         {self.smoothness}",
        ]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def analyze(scheme: AbstractCurveScheme) -> Analysis:
    """Analyze a curve scheme: mask, support, interpolation, local eigenvalues, limit,
    tangent and curvature stencils, and smoothness, in one immutable result.

    The entry point for a report (`print(jaxsubdiv.analyze(jaxsubdiv.FourPoint()))`) and
    for the command line. Each quantity is also available on its own
    ([`jaxsubdiv.local_matrix`][], [`jaxsubdiv.eigen`][], [`jaxsubdiv.limit_stencil`][],
    [`jaxsubdiv.tangent_stencil`][], [`jaxsubdiv.curvature_stencil`][],
    [`jaxsubdiv.smoothness`][]); use those in differentiable code.

    **Arguments:**

    - `scheme`: a curve scheme with concrete parameter values (the analysis runs on the
      host).

    **Returns:** an [`jaxsubdiv.Analysis`][]. Stencils that do not exist (a scheme that
    is not $C^1$ has no tangent stencil) are `None`; a scheme that does not converge is
    analyzed too, with `smoothness.converges == False`.
    """
    scheme = check_scheme(scheme, "analyze")
    if is_traced(scheme.mask()):
        raise TypeError(
            "`analyze` needs concrete parameter values (it runs on the host); call it "
            "outside `jit`/`vmap`/`grad`."
        )
    smooth = smoothness(scheme)
    location = natural_location(scheme)
    stencils = [
        stencil_values(scheme, order, location) if smooth.continuity >= order else None
        for order in (0, 1, 2)
    ]
    h = (scheme.mask_length - 1) / 2
    return Analysis(
        name=describe(scheme),
        mask=scheme.mask(),
        mask_start=scheme.mask_start,
        support=(-h, h),
        primal=scheme.is_primal,
        interpolating=is_interpolating(scheme),
        location=location,
        neighborhood=neighborhood(scheme, location),
        local_matrix=local_matrix(scheme),
        eigenvalues=eigen(scheme).values,
        limit_stencil=stencils[0],
        tangent_stencil=stencils[1],
        curvature_stencil=stencils[2],
        smoothness=smooth,
    )
