r"""Local analysis of a curve scheme: invariant neighborhoods, local subdivision
matrices, eigen-structure, and limit/derivative stencils.

Conventions (shared with the refinement kernel). A scheme with mask $a_k$ refines by
$Q_K = \sum_j a_{K-2j} P_j$. Its basis function $\varphi$ solves the refinement equation
$\varphi(x) = \sum_k a_k \varphi(2x - k)$, is supported on $[k_0, k_1]$ (the first and
last mask index) and is centered at $c$ = `scheme.center`. The limit curve of control
points $P_j$ is

$$C(t) = \sum_j P_j\, \varphi(t + c - j),$$

so control point $P_j$ sits at curve parameter $t = j$, and the limit curve has unit
parameter spacing per control point. The *limit position* of $P_j$ is $C(j)$ and the
limit of an edge $(P_j, P_{j+1})$ is $C(j + \tfrac12)$. A stencil lists the weights of
the points around the vertex (edge) at relative positions $u$, and the weight of the
point at position $u$ is $\varphi^{(p)}(c - u)$ for the $p$-th derivative.

The values of $\varphi^{(p)}$ at the integers are the eigenvector of
$A_{ij} = a_{2i - j}$ for the eigenvalue $2^{-p}$, normalised by
$\sum_m (-m)^p \varphi^{(p)}(m) = p!$ (which holds because a $C^p$ scheme generates
polynomials of degree $p$ with leading coefficient one); values at half-integers
follow from one application of the refinement equation. The eigenvector is found by a
linear least-squares solve, not by `jnp.linalg.eig`, so it is differentiable in the
scheme's parameters. See N. Dyn, D. Levin, "Subdivision schemes in geometric modelling",
Acta Numerica 11 (2002) 73-144, section 2.
"""

import math
from fractions import Fraction
from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Inexact

from .._misc import is_traced
from .._scheme.base import AbstractCurveScheme
from .describe import describe
from .smoothness import MAX_MASK_LENGTH, smoothness


At = Literal["vertex", "edge"]


def check_scheme(scheme, caller: str) -> AbstractCurveScheme:
    if not isinstance(scheme, AbstractCurveScheme):
        raise TypeError(
            f"`{caller}(scheme=...)` must be a jaxsubdiv curve scheme such as "
            "`jaxsubdiv.FourPoint(w)` or `jaxsubdiv.MaskScheme(coefficients, start)`; got "
            f"{type(scheme).__name__}."
        )
    if scheme.mask_length > MAX_MASK_LENGTH:
        raise ValueError(
            f"`{caller}(scheme=...)`: {type(scheme).__name__} has a mask of "
            f"{scheme.mask_length:,} coefficients, above the limit of {MAX_MASK_LENGTH} for "
            "analysis (the local matrices are dense and built by loops quadratic in the "
            "length). Analyze a shorter mask."
        )
    if scheme.mask().ndim != 1:
        raise ValueError(
            f"`{caller}`: {type(scheme).__name__} holds a batch of parameter values (mask "
            f"shape {scheme.mask().shape}); pass one scheme, or `jax.vmap` over the "
            "scheme where the function supports it."
        )
    if scheme.mask_length < 3:
        raise ValueError(
            f"`{caller}`: a mask with {scheme.mask_length} coefficients has a "
            "discontinuous (box) or no basis function; the limit does not converge to a "
            "continuous curve, so it has no limit stencils."
        )
    return scheme


def natural_location(scheme: AbstractCurveScheme) -> At:
    """`"vertex"` for primal schemes, `"edge"` for dual ones: where the refined points of
    one level sit at the same place as the coarse ones, so the neighborhood is invariant."""
    return "vertex" if scheme.is_primal else "edge"


def check_at(at, scheme: AbstractCurveScheme, caller: str) -> At:
    if at is None:
        return natural_location(scheme)
    if at not in ("vertex", "edge"):
        raise ValueError(f"`{caller}(at=...)` must be 'vertex', 'edge' or None, got {at!r}.")
    return at


def neighborhood(scheme: AbstractCurveScheme, at: At | None = None) -> tuple[Fraction, ...]:
    r"""Relative positions $u$ of the points in the neighborhood of a vertex or an edge.

    These are the points whose basis function's open support contains the vertex
    (parameter $t = j$) or the edge midpoint ($t = j + \frac12$): with half-width
    $h = (L - 1)/2$ of a mask of length $L$, the positions $|u| < h$ that are integers
    (vertex) or half-integers (edge). The point at position $u$ is $P_{j + u}$ for a
    vertex and $P_{j + 1/2 + u}$ for an edge. For example the cubic B-spline's vertex
    neighborhood is $(-1, 0, 1)$, the four-point scheme's $(-2, \dots, 2)$, Chaikin's
    edge neighborhood $(-\frac12, \frac12)$.

    At its natural location (a vertex of a primal scheme, an edge of a dual one) the
    neighborhood is invariant: after one level, the points at the same relative
    positions (in the finer spacing) depend only on it.

    **Returns:** a tuple of `fractions.Fraction`, increasing.
    """
    at = check_at(at, scheme, "neighborhood")
    h = Fraction(scheme.mask_length - 1, 2)
    offset = Fraction(0) if at == "vertex" else Fraction(1, 2)
    first = math.floor(-h - offset) + 1  # the smallest integer m with m + offset > -h
    out = []
    m = first
    while m + offset < h:
        out.append(m + offset)
        m += 1
    return tuple(out)


def _neighborhood_checked(scheme, at):
    nbhd = neighborhood(scheme, at)
    if not nbhd:
        raise ValueError(f"{type(scheme).__name__} has an empty neighborhood at an {at}.")
    return nbhd


def local_matrix(scheme: AbstractCurveScheme) -> Float[Array, "m m"]:
    r"""The subdivision matrix of the invariant neighborhood of a vertex (primal schemes)
    or an edge (dual schemes).

    Entry $(u, v)$ is the weight of the coarse point at relative position $v$ in the fine
    point at relative position $u$ (in the fine spacing): $M_{uv} = a_{u - 2v + c}$, with
    $u, v$ running over [`jaxsubdiv.neighborhood`][] at the scheme's natural location
    and $c$ the scheme's center. Repeated refinement maps the neighborhood's points by
    $M^k$, so its eigenvalues (1, then $\frac12$, $\frac14$, ... for a smooth scheme) and
    left eigenvectors give the limit and derivative stencils (Dyn and Levin 2002,
    section 2.3). For example the cubic B-spline gives
    $\frac18\begin{pmatrix}4&4&0\\1&6&1\\0&4&4\end{pmatrix}$ on $(-1, 0, 1)$ and Chaikin
    gives $\frac14\begin{pmatrix}3&1\\1&3\end{pmatrix}$ on $(-\frac12, \frac12)$.

    **Arguments:**

    - `scheme`: a curve scheme; its parameters may be traced (the matrix is built with
      `jax.numpy` from the mask, so it is differentiable).

    **Returns:** an `(m, m)` array, `m = len(neighborhood(scheme))`.
    """
    scheme = check_scheme(scheme, "local_matrix")
    nbhd = _neighborhood_checked(scheme, natural_location(scheme))
    c = Fraction(scheme.mask_start * 2 + scheme.mask_length - 1, 2)
    mask = scheme.mask()
    start, length = scheme.mask_start, scheme.mask_length
    padded = jnp.concatenate([mask, jnp.zeros((1,), mask.dtype)])
    index = np.full((len(nbhd), len(nbhd)), length)  # `length` points at the zero
    for r, u in enumerate(nbhd):
        for col, v in enumerate(nbhd):
            k = u - 2 * v + c
            assert k.denominator == 1
            if start <= k < start + length:
                index[r, col] = int(k) - start
    return padded[index]


class Eigen(eqx.Module):
    """Eigen-decomposition of a local subdivision matrix (see [`jaxsubdiv.eigen`][]).

    - `values`: eigenvalues sorted by decreasing modulus (ties: larger real part first).
    - `right`: right eigenvectors as columns, `matrix @ right[:, i] = values[i] * right[:, i]`.
    - `left`: left eigenvectors as rows, `left[i] @ matrix = values[i] * left[i]`, scaled so
      that `left[i] @ right[:, i] = 1` where that product is not zero (a defective
      eigenvalue, i.e. a Jordan block, makes it zero).
    - `neighborhood`: the relative positions the rows and columns refer to.
    """

    values: Inexact[Array, " m"]
    right: Inexact[Array, "m m"]
    left: Inexact[Array, "m m"]
    neighborhood: tuple[Fraction, ...] = eqx.field(static=True)


def _sorted_eig(matrix: np.ndarray):
    values, vectors = np.linalg.eig(matrix)
    # (Python's `round` of a float: NumPy's overflowed on 1e300 * 1e12, with a warning.)
    order = sorted(range(len(values)),
                   key=lambda i: (-round(float(abs(values[i])), 12), -values[i].real))
    return values[order], vectors[:, order]


def _real_vectors(vectors: np.ndarray) -> np.ndarray:
    """Columns rotated to be real (each complex column scaled by its largest entry's phase)."""
    out = np.empty(vectors.shape)
    for i, v in enumerate(vectors.T):
        k = int(np.argmax(np.abs(v)))
        phase = v[k] / abs(v[k]) if abs(v[k]) > 0 else 1.0
        out[:, i] = (v / phase).real
    return out


def eigen(scheme: AbstractCurveScheme) -> Eigen:
    r"""Eigenvalues and left and right eigenvectors of [`jaxsubdiv.local_matrix`][].

    Computed on the host with NumPy (`numpy.linalg.eig`), so the scheme's parameters must
    be concrete values. (Eigenvectors of a non-symmetric matrix have no derivative in JAX
    on CPU; the differentiable quantities, the stencils, are computed by linear solves.)
    Eigenvalues that are real to rounding are returned as a real array.

    For example the cubic B-spline has eigenvalues $1, \frac12, \frac14$, the four-point
    scheme with $w = \frac1{16}$ has $1, \frac12, \frac14, \frac14, \frac18$, and the
    left eigenvector for eigenvalue 1, scaled to sum to one, is the limit stencil.

    **Returns:** an [`jaxsubdiv.Eigen`][] with `values`, `right`, `left` and `neighborhood`.
    """
    scheme = check_scheme(scheme, "eigen")
    matrix = local_matrix(scheme)
    if is_traced(matrix):
        raise TypeError(
            "`eigen` runs on the host with NumPy and needs concrete parameter values; "
            "call it outside `jit`/`vmap`/`grad`. For differentiable quantities use "
            "`limit_stencil`/`tangent_stencil`."
        )
    m = np.asarray(matrix, dtype=np.float64)
    values, right = _sorted_eig(m)
    lvalues, left_t = _sorted_eig(m.T)
    # Pair each eigenvalue with the closest unused left eigenvalue (they are equal sets).
    left = np.empty(left_t.T.shape, dtype=np.complex128)
    used = set()
    for i, value in enumerate(values):
        choices = [k for k in range(len(lvalues)) if k not in used]
        k = min(choices, key=lambda k: abs(lvalues[k] - value))
        used.add(k)
        left[i] = left_t[:, k]
    right = right.astype(np.complex128)
    for i in range(len(values)):
        dot = left[i] @ right[:, i]
        if abs(dot) > 1e-8 * np.linalg.norm(left[i]) * np.linalg.norm(right[:, i]):
            left[i] = left[i] / dot
    # A defective eigenvalue (a Jordan block, e.g. 1/4 for the four-point scheme) is
    # computed with an error of order sqrt(eps) and may come out as a complex pair.
    scale = max(1.0, float(np.abs(values).max()))
    if np.all(np.abs(values.imag) <= 1e-6 * scale):
        values = values.real
        right, left = _real_vectors(right), _real_vectors(left.T).T
        dtype = matrix.dtype
        cast = lambda x: jnp.asarray(x, dtype)
    else:
        cast = jnp.asarray
    return Eigen(cast(values), cast(right), cast(left), neighborhood(scheme))


# --------------------------------------------------------------------------------------
# Values of the basis function and its derivatives at integers and half-integers.


def basis_at_integers(mask: Array, start: int, order: int) -> Array:
    r"""$\varphi^{(p)}(m)$ for $m$ = `start + 1`, ..., `start + L - 2` ($p$ = `order`).

    The eigenvector of $A_{ij} = a_{2i - j}$ for eigenvalue $2^{-p}$, normalised by
    $\sum_m (-m)^p \varphi^{(p)}(m) = p!$, from the normal equations of the stacked
    system (differentiable; no `eig`). The caller must make sure the scheme is $C^p$.
    """
    length = mask.shape[-1]
    points = list(range(start + 1, start + length - 1))
    size = len(points)
    padded = jnp.concatenate([mask, jnp.zeros((1,), mask.dtype)])
    index = np.full((size, size), length)
    for r, i in enumerate(points):
        for col, j in enumerate(points):
            k = 2 * i - j
            if start <= k < start + length:
                index[r, col] = k - start
    a = padded[index]
    eigenvalue = 2.0**-order
    norm_row = jnp.asarray([float((-m) ** order) for m in points], mask.dtype)
    system = jnp.concatenate([a - eigenvalue * jnp.eye(size, dtype=mask.dtype), norm_row[None]])
    rhs = jnp.zeros((size + 1,), mask.dtype).at[-1].set(math.factorial(order))
    return jnp.linalg.solve(system.T @ system, system.T @ rhs)


def basis_values(mask: Array, start: int, order: int, where) -> Array:
    r"""$\varphi^{(p)}(x)$ at the integers or half-integers `where` (Fractions)."""
    length = mask.shape[-1]
    at_int = basis_at_integers(mask, start, order)
    # Index into [phi(start), ..., phi(start + L - 1)] with zeros at the support ends.
    full = jnp.concatenate([jnp.zeros((1,), mask.dtype), at_int, jnp.zeros((1,), mask.dtype)])
    values = []
    for x in where:
        if x.denominator == 1:
            x = int(x)
            values.append(full[x - start] if start <= x < start + length else full[0] * 0)
            continue
        # phi^(p)(m + 1/2) = 2^p sum_j a_{2m+1-j} phi^(p)(j).
        twice = int(2 * x)
        terms = [
            mask[twice - j - start] * full[j - start]
            for j in range(start + 1, start + length - 1)
            if start <= twice - j < start + length
        ]
        values.append(2.0**order * sum(terms) if terms else full[0] * 0)
    return jnp.stack(values)


def stencil_values(scheme: AbstractCurveScheme, order: int, at: At) -> Array:
    """Weights $\\varphi^{(p)}(c - u)$ over the neighborhood at `at` (no smoothness check)."""
    nbhd = _neighborhood_checked(scheme, at)
    c = Fraction(scheme.mask_start * 2 + scheme.mask_length - 1, 2)
    return basis_values(scheme.mask(), scheme.mask_start, order, [c - u for u in nbhd])


_NAMES = {0: "limit", 1: "tangent", 2: "curvature (second-derivative)"}


def require_smoothness(scheme: AbstractCurveScheme, order: int, caller: str) -> None:
    """Raise a clear error when a concrete scheme is not certified $C^p$, `p = order`.

    Traced parameters cannot be checked (the check runs on the host); then the caller's
    docstring says the parameter range is the user's responsibility.
    """
    if is_traced(scheme.mask()):
        return
    result = smoothness(scheme)
    if result.continuity >= order:
        return
    what = "converge to a continuous limit" if order == 0 else f"have a C{order} limit"
    proof = (
        "it is not" if result.decided else "this could not be certified (the Hölder bounds "
        "straddle the threshold)"
    )
    raise ValueError(
        f"`{caller}`: {describe(scheme)} does not {what}: {proof}; smoothness gives "
        f"continuity C^{result.continuity}, Hölder exponent in "
        f"[{result.holder_lower:.4f}, {result.holder_upper:.4f}]. A {_NAMES[order]} "
        f"stencil needs a C^{order} scheme."
    )


def _stencil(scheme, order, at, caller):
    scheme = check_scheme(scheme, caller)
    at = check_at(at, scheme, caller)
    require_smoothness(scheme, order, caller)
    return stencil_values(scheme, order, at)


def limit_stencil(scheme: AbstractCurveScheme, *, at: At | None = None) -> Float[Array, " m"]:
    r"""Weights that map the points around a vertex (or an edge) to its limit position.

    The limit of vertex $P_j$ is $C(j) = \sum_u w_u P_{j+u}$ and the limit of edge
    $(P_j, P_{j+1})$ is $C(j + \frac12) = \sum_u w_u P_{j + 1/2 + u}$, with $u$ running over
    [`jaxsubdiv.neighborhood`][]`(scheme, at)` and $w_u = \varphi(c - u)$. The weights are
    the left eigenvector of [`jaxsubdiv.local_matrix`][] for eigenvalue 1 (at the natural
    location), scaled to sum to one. Examples: cubic B-spline $(1, 4, 1)/6$; Chaikin at an
    edge $(\frac12, \frac12)$, at a vertex $(1, 6, 1)/8$; interpolating schemes
    $(0, \dots, 1, \dots, 0)$.

    Use it to snap a point of any level to the limit curve without refining.

    **Arguments:**

    - `scheme`: a convergent curve scheme (parameters may be traced: the weights are
      differentiable in them; a concrete scheme that does not converge is an error).
    - `at`: `"vertex"`, `"edge"`, or `None` for the natural location (vertex for primal
      schemes, edge for dual ones). Keyword only.

    **Returns:** a 1-D array over the neighborhood.
    """
    return _stencil(scheme, 0, at, "limit_stencil")


def tangent_stencil(scheme: AbstractCurveScheme, *, at: At | None = None) -> Float[Array, " m"]:
    r"""Weights of the first derivative $dC/dt$ of the limit curve at a vertex (edge).

    As [`jaxsubdiv.limit_stencil`][] with $w_u = \varphi'(c - u)$: the derivative with
    respect to a parameter with unit spacing per control point (for points of refinement
    level $k$ of a level-0 polygon, multiply by $2^k$ for the level-0 parameter). The
    weights sum to zero. Cubic B-spline: $(-1, 0, 1)/2$; Chaikin at an edge $(-1, 1)$.

    **Arguments:** as for `limit_stencil`. A concrete scheme that is not $C^1$ is an
    error (the tangent does not exist); with traced parameters the check is skipped, so
    check the range once with [`jaxsubdiv.smoothness`][].

    **Returns:** a 1-D array over the neighborhood.
    """
    return _stencil(scheme, 1, at, "tangent_stencil")


def curvature_stencil(
    scheme: AbstractCurveScheme, *, at: At | None = None
) -> Float[Array, " m"]:
    r"""Weights of the second derivative $d^2C/dt^2$ of the limit curve at a vertex (edge).

    As [`jaxsubdiv.tangent_stencil`][] with $w_u = \varphi''(c - u)$; exists for $C^2$
    schemes only (cubic B-spline: $(1, -2, 1)$). The curvature of a planar limit curve is
    $\kappa = (C' \times C'')/|C'|^3$; see [`jaxsubdiv.limit_curvature`][].

    **Returns:** a 1-D array over the neighborhood.
    """
    return _stencil(scheme, 2, at, "curvature_stencil")
