r"""Convergence, Hölder exponent and $C^k$ class of a binary curve scheme.

Method (Dyn and Levin 2002, sections 4-5; Rioul 1992; Daubechies and Lagarias 1992):

1. A scheme is affine invariant iff its two sub-masks sum to one, i.e. $a(1) = 2$ and
   $a(-1) = 0$; otherwise it does not converge.
2. Factor the symbol as $a(z) = 2\,(\tfrac{1+z}{2})^N q(z)$ with $N$ as large as
   possible (so $q(1) = 1$, $q(-1) \ne 0$).
3. With $q$ supported on $0..M$, let $(T_\varepsilon)_{ij} = q_{2i - j + \varepsilon}$
   ($\varepsilon = 0, 1$; $i, j = 0..M-1$) and $\rho$ their joint spectral radius. The
   Hölder exponent of the basis function is $\alpha = N - 1 - \log_2 \rho$ (Rioul 1992,
   Daubechies and Lagarias 1992; $\rho = 1$ when $M = 0$, the B-splines). The scheme is
   $C^m$ iff $\alpha > m$: $C^m$ iff the scheme for the $m$-th divided differences,
   $2^m a(z) / (1+z)^m$, converges (Dyn and Levin 2002, Thm 4.5), iff its difference
   scheme is contractive, i.e. has joint spectral radius below one (Thm 4.3).
4. $\rho$ is bracketed by a branch-and-bound over products of $T_0, T_1$ (Gripenberg
   1996): the lower bound is the largest $\rho(P)^{1/k}$ over the products $P$ met, the
   upper bound $\max(\text{lower} + \delta, \max_P \|P\|^{1/k})$ over the products of
   length $k$ whose every prefix survived pruning, in the spectral norm of an adapted
   basis. Both are rigorous (up to floating-point rounding) and tighten as the search
   deepens. When a fast pass is not exact, the invariant polytope algorithm
   (`polytope.py`; Guglielmi and Protasov 2013) tries to prove the best product found
   spectrum-maximizing, which makes $\rho$ exact when it succeeds.

References: N. Dyn, D. Levin, "Subdivision schemes in geometric modelling", Acta Numerica
11 (2002) 73-144. O. Rioul, "Simple regularity criteria for subdivision schemes", SIAM J.
Math. Anal. 23 (1992) 1544-1576. I. Daubechies, J. C. Lagarias, "Two-scale difference
equations II. Local regularity, infinite products of matrices and fractals", SIAM J. Math.
Anal. 23 (1992) 1031-1079. G. Gripenberg, "Computing the joint spectral radius", Linear
Algebra Appl. 234 (1996) 43-60. N. Guglielmi, V. Yu. Protasov, "Exact computation of
joint spectral characteristics of linear operators", Found. Comput. Math. 13 (2013)
37-97.
"""

import dataclasses
import functools as ft
import math

import numpy as np

from .._misc import is_traced
from .._scheme.base import AbstractCurveScheme
from .polytope import MAX_HULL_DIMENSION, polytope_upper_bound


# A frozen dataclass, not an `eqx.Module`: the result is host data (Python bools, floats,
# a sentence), computed with NumPy and never traced, so it is a single pytree leaf that
# `jax.tree.map` passes through whole instead of mapping over its numbers and string; it
# is also hashable and compares by value.
@dataclasses.dataclass(frozen=True)
class Smoothness:
    r"""What [`jaxsubdiv.smoothness`][] found out about a scheme.

    An immutable, hashable value computed on the host (not a JAX pytree: `jax.tree.map`
    treats it as one leaf). Two results are equal when every field is.

    - `converges`: True when the scheme is proven to converge to continuous limits
      ($\alpha > 0$). False when it is proven not to, or when that could not be decided
      (then `decided` is False).
    - `holder_lower`, `holder_upper`: bounds on the Hölder exponent $\alpha$ of the basis
      function (the limit of a single nonzero control point): $\alpha$ = `k + β` means
      the $k$-th derivative is Hölder continuous with exponent β. Equal when $\alpha$ is
      known exactly (B-splines: $\alpha$ = degree). `-inf` when the mask is not affine
      invariant.
    - `continuity`: the largest $k$ for which the limit is proven $C^k$, or -1.
    - `decided`: True when the bounds also prove that the limit is *not* $C^{k+1}$, so
      `continuity` is exact; False when the bounds straddle $k + 1$ (a borderline
      parameter value; the class is then at least `continuity`).
    - `factors`: $N$, the power of $(1+z)$ in the symbol.
    - `jsr_lower`, `jsr_upper`: the bounds on the joint spectral radius $\rho$.
    - `reason`: a sentence saying why a scheme does not converge (empty otherwise).
    - `method`: how the bounds were found: `"closed form"` (no factor $q$ left: the
      B-splines), `"branch and bound"` (Gripenberg 1996), `"invariant polytope"`
      (Guglielmi and Protasov 2013: exact, the bracket is the hull test's
      tolerance, about $10^{-9}$ wide), or `"sub-mask sums"` (not affine invariant).
    """

    converges: bool
    holder_lower: float
    holder_upper: float
    continuity: int
    decided: bool
    factors: int
    jsr_lower: float
    jsr_upper: float
    reason: str = ""
    method: str = ""

    def __str__(self) -> str:
        if self.holder_lower == -math.inf:
            verdict = "does not converge" if self.decided else "undecided"
            return f"{verdict}: {self.reason}"
        if self.holder_lower == self.holder_upper or self.method == "invariant polytope":
            holder = f"Hölder exponent {self.holder_lower:.4f} (exact, {self.method})"
        else:
            holder = f"Hölder exponent in [{self.holder_lower:.4f}, {self.holder_upper:.4f}]"
        if not self.converges:
            verdict = "does not converge" if self.decided else "convergence undecided"
        elif self.decided:
            verdict = f"C^{self.continuity}, not C^{self.continuity + 1}"
        else:
            verdict = f"at least C^{self.continuity} (C^{self.continuity + 1} undecided)"
        return f"{verdict}; {holder}"


def factor_symbol(mask: np.ndarray, tol: float = 1e-10) -> tuple[int, np.ndarray]:
    r"""$N$ and $q$ with $a(z) = 2 ((1+z)/2)^N q(z)$ (coefficients in increasing powers)."""
    b = np.trim_zeros(np.asarray(mask, dtype=np.float64))
    scale = np.abs(b).sum()
    n = 0
    while len(b) > 1:
        # b(z) = (1 + z) c(z) + r, by synthetic division from the top coefficient.
        c = np.empty(len(b) - 1)
        c[-1] = b[-1]
        for k in range(len(b) - 2, 0, -1):
            c[k - 1] = b[k] - c[k]
        remainder = b[0] - c[0]
        if abs(remainder) > tol * scale:
            break
        b, n = c, n + 1
    return n, b * 2.0 ** (n - 1)


def transition_matrices(q: np.ndarray) -> np.ndarray:
    r"""$(T_\varepsilon)_{ij} = q_{2i - j + \varepsilon}$, shape `(2, M, M)`."""
    m = len(q) - 1
    out = np.zeros((2, m, m))
    for e in (0, 1):
        for i in range(m):
            for j in range(m):
                k = 2 * i - j + e
                if 0 <= k <= m:
                    out[e, i, j] = q[k]
    return out


def _spectral_radius(products: np.ndarray) -> np.ndarray:
    return np.abs(np.linalg.eigvals(products)).max(axis=-1)


def _norm(products: np.ndarray) -> np.ndarray:
    # Spectral norm; for 1x1 and 2x2 a closed form is much faster than an SVD.
    m = products.shape[-1]
    if m == 1:
        return np.abs(products[..., 0, 0])
    if m == 2:
        a, b = products[..., 0, 0], products[..., 0, 1]
        c, d = products[..., 1, 0], products[..., 1, 1]
        s = a * a + b * b + c * c + d * d
        det = a * d - b * c
        return np.sqrt(0.5 * (s + np.sqrt(np.maximum(s * s - 4 * det * det, 0.0))))
    return np.linalg.norm(products, ord=2, axis=(-2, -1))


def _adapted_basis(matrices: np.ndarray, best: np.ndarray) -> np.ndarray:
    """A basis change that makes the spectral norm tight for the leading product.

    Uses the (real) eigenvectors of the best product found so far, when they are well
    conditioned; the bounds stay rigorous whatever basis is used.
    """
    m = matrices.shape[-1]
    try:
        values, vectors = np.linalg.eig(best)
    except np.linalg.LinAlgError:
        return np.eye(m)
    # Real basis from complex pairs: (Re v, Im v).
    basis, seen = [], set()
    for i, v in enumerate(vectors.T):
        if i in seen:
            continue
        if abs(values[i].imag) > 1e-12:
            partner = int(np.argmin(np.abs(values - values[i].conjugate())))
            seen.add(partner)
            basis += [v.real, v.imag]
        else:
            basis.append(v.real)
    basis = np.array(basis[:m]).T
    if basis.shape != (m, m) or np.linalg.cond(basis) > 1e6:
        return np.eye(m)
    return basis


def jsr_bounds(
    matrices: np.ndarray, *, delta: float, max_length: int, max_products: int
) -> tuple[float, float, np.ndarray]:
    """Rigorous lower and upper bounds on the joint spectral radius (Gripenberg 1996),
    and the product that gave the lower bound, $\\rho(P)^{1/k}$ (in the given basis):
    long products that survive the pruning are candidates for the polytope too."""
    m = matrices.shape[-1]
    if m == 0:
        return 1.0, 1.0, np.eye(0)
    # Seed the lower bound with every product of length <= 4.
    lower, best = 0.0, matrices[0]
    level = matrices
    for k in range(1, 5):
        radii = _spectral_radius(level) ** (1.0 / k)
        i = int(np.argmax(radii))
        if radii[i] > lower:
            lower, best = float(radii[i]), level[i]
        level = np.concatenate([level @ matrices[0], level @ matrices[1]])
    basis = _adapted_basis(matrices, best)
    mats = np.linalg.solve(basis, matrices @ basis)  # V^{-1} T V
    if lower == 0.0:
        # Both matrices nilpotent-like at short lengths; fall back on the plain norm.
        mats = matrices
    upper = float(_norm(mats).max())
    products = mats
    for k in range(1, max_length + 1):
        norms = _norm(products) ** (1.0 / k)
        radii = _spectral_radius(products) ** (1.0 / k)
        i = int(np.argmax(radii))
        if radii[i] > lower * (1 + 1e-10):  # a longer product only when it is better
            lower = float(radii[i])
            best = products[i] if mats is matrices else basis @ products[i] @ np.linalg.inv(basis)
        upper = min(upper, max(lower + delta, float(norms.max())))
        keep = norms > lower + delta
        if not keep.any() or upper <= lower + delta:
            upper = min(upper, lower + delta)
            break
        survivors = products[keep]
        if 2 * len(survivors) > max_products:
            break
        products = np.concatenate([survivors @ mats[0], survivors @ mats[1]])
    return lower, max(upper, lower), best


# Effort levels: a fast first pass, then deeper passes only when the class is undecided.
_PASSES = (
    dict(delta=2e-3, max_length=40, max_products=512),
    dict(delta=2e-4, max_length=80, max_products=8192),
)

#: The largest transition matrices (`M x M`, `M` the degree of the factor `q` left after
#: dividing the symbol by $(1+z)^N$) that `smoothness` searches. A product of two costs
#: $O(M^3)$ and each pass evaluates up to `max_length x max_products` of them (eigenvalues
#: and norms too): measured 28 us per product at M = 8, 1.2 ms at M = 64, and a random
#: 128-coefficient mask (M = 123) ran for more than 3 minutes. Above `MAX_JSR_SIZE` the
#: bounds would need hours to be useful, so it is an error.
MAX_JSR_SIZE = 64

#: Masks longer than this are an error in every analysis function: factoring the symbol
#: and building the local matrices are Python loops over the coefficients (quadratic in
#: the length), and a longer mask cannot be analyzed to working precision anyway (it
#: needs either $N > 55$ factors $(1+z)$, which are not exact in float64, or transition
#: matrices larger than `MAX_JSR_SIZE`).
MAX_MASK_LENGTH = 256

# Work per pass is capped at what the passes cost at M = 8: beyond that the number of
# products kept per length shrinks like M^-3 (at least 16), so the worst case stays
# within seconds; the bounds stay rigorous, only less tight (`decided` may be False).
_WORK_SIZE = 8


def _effort(effort: dict, m: int) -> dict:
    if m <= _WORK_SIZE:
        return effort
    scaled = int(effort["max_products"] * (_WORK_SIZE / m) ** 3)
    return {**effort, "max_products": max(16, scaled)}


#: The Hölder bracket the first, fast pass must reach for `smoothness` to stop there
#: (in effect: exact, as for the B-splines and the corner-cutting line); anything wider
#: goes to the invariant polytope, which is exact when it closes and costs 1-150 ms
#: (one to a few hundred convex hulls).
FAST_WIDTH = 1e-6


def best_product(matrices: np.ndarray, *, max_products: int = 512) -> tuple[float, np.ndarray]:
    r"""The product $\Pi$ of length $k$ with the largest $\rho(\Pi)^{1/k}$ among all
    products of `matrices` up to the length where their number reaches `max_products`
    (the shortest one among near-ties): a lower bound on the joint spectral radius and
    the candidate spectrum-maximizing product for the polytope algorithm."""
    m = matrices.shape[-1]
    best, best_product_ = -1.0, matrices[0]
    level = np.eye(m)[None]
    length = 0
    while 2 * len(level) <= max_products:
        level = np.concatenate([level @ matrices[0], level @ matrices[1]])
        length += 1
        radii = _spectral_radius(level) ** (1.0 / length)
        i = int(np.argmax(radii))
        if radii[i] > best * (1 + 1e-10):
            best, best_product_ = float(radii[i]), level[i]
    return best, best_product_


def _holder_bracket(n: int, lo: float, hi: float) -> tuple[float, float]:
    return n - 1 - math.log2(hi), (n - 1 - math.log2(lo) if lo > 0 else math.inf)


def _decided(low_alpha: float, high_alpha: float) -> bool:
    """Whether a Hölder bracket fixes the class: no integer strictly inside
    (`continuity` is the largest k < `low_alpha`; not C^{k+1} needs `high_alpha` <= k+1)."""
    return high_alpha <= math.ceil(low_alpha)


def jsr_search(matrices: np.ndarray, n: int) -> tuple[float, float, str]:
    """Bounds on the joint spectral radius of `matrices` (the factor $q$'s transition
    matrices, for a symbol with `n` factors $(1+z)$), and the method that gave them.

    A fast branch-and-bound pass first (`jsr_bounds`), kept when its Hölder bracket is
    at most `FAST_WIDTH` wide and decides the class; otherwise the invariant polytope
    algorithm (exact when it closes); when that does not close, a deeper
    branch-and-bound pass, keeping the tightest bounds of all."""
    m = matrices.shape[-1]
    if m == 0:
        return 1.0, 1.0, "closed form"
    # The joint spectral radius is homogeneous: matrices of large entries (a parameter
    # far outside a scheme's range) are divided by a power of two near their largest
    # norm, exactly, so that products of up to 80 of them do not overflow (four-point at
    # w = 1e8: inf, then LAPACK's complaints on stdout and a LinAlgError); the bounds are
    # multiplied back. Matrices of norm up to 2 (every scheme in its range) are as given.
    largest = float(np.max(_norm(matrices)))
    scale = 2.0 ** math.ceil(math.log2(largest)) if largest > 2 else 1.0
    if scale != 1.0:
        lo, hi, method = jsr_search(matrices / scale, n)
        return lo * scale, hi * scale, method
    lo, hi, searched = jsr_bounds(matrices, **_effort(_PASSES[0], m))
    low_alpha, high_alpha = _holder_bracket(n, lo, hi)
    if lo == hi or (high_alpha - low_alpha <= FAST_WIDTH and _decided(low_alpha, high_alpha)):
        return lo, hi, "branch and bound"
    if 1 < m <= MAX_HULL_DIMENSION:
        # The candidate: the best of all short products, unless the branch and bound
        # met a longer, better one (corner cutting near r = 0: length 12).
        radius, product = best_product(matrices)
        if lo > radius * (1 + 1e-9):
            radius, product = lo, searched
        bound, exact = polytope_upper_bound(matrices, product, radius)
        if exact:
            return radius, bound, "invariant polytope"
        lo, hi = max(lo, radius), min(hi, bound)
    for effort in _PASSES[1:]:
        deeper_lo, deeper_hi, _ = jsr_bounds(matrices, **_effort(effort, m))
        lo, hi = max(lo, deeper_lo), min(hi, deeper_hi)
    return lo, max(hi, lo), "branch and bound"


@ft.lru_cache(maxsize=4096)
def _smoothness_cached(mask: tuple[float, ...], tol: float = 1e-9,
                       dtype: str = "float64") -> Smoothness:
    a = np.asarray(mask)
    # Exact sums of the coefficients (`math.fsum`), parity relative to the first index.
    even, odd = math.fsum(a[0::2]), math.fsum(a[1::2])
    if not (abs(even - 1) < tol and abs(odd - 1) < tol):
        # The coefficients were rounded to `dtype` one by one (-w and 1/2 + w): sums off
        # from 1 by no more than that rounding cannot tell a scheme that is not affine
        # invariant from one whose mask rounds (four-point at w = 1e16 in float64, or
        # 1e7 in float32: 1/2 + w rounds to w, the sums to 0 and 1).
        largest = float(np.max(np.abs(a)))
        rounding = len(a) * float(np.finfo(dtype).eps) * largest
        if max(abs(even - 1), abs(odd - 1)) <= rounding:
            return Smoothness(
                converges=False,
                holder_lower=-math.inf,
                holder_upper=math.inf,
                continuity=-1,
                decided=False,
                factors=0,
                jsr_lower=0.0,
                jsr_upper=math.inf,
                method="none",
                reason=(
                    f"the sub-masks sum to {even:.6g} and {odd:.6g}, off from 1 by no more "
                    f"than the rounding of {dtype} coefficients as large as {largest:.3g} "
                    f"(up to {rounding:.2g}), so whether the scheme reproduces constants "
                    "cannot be seen (parameters this large are far outside the range where "
                    "a scheme converges)"
                ),
            )
        return Smoothness(
            converges=False,
            holder_lower=-math.inf,
            holder_upper=-math.inf,
            continuity=-1,
            decided=True,
            factors=0,
            jsr_lower=math.inf,
            jsr_upper=math.inf,
            method="sub-mask sums",
            reason=(
                f"the sub-masks sum to {even:.6g} and {odd:.6g}, not 1 and 1, so the "
                "scheme does not reproduce constants (not affine invariant)"
            ),
        )
    n, q = factor_symbol(a, tol=0.1 * tol)
    if len(q) - 1 > MAX_JSR_SIZE:
        raise ValueError(
            f"`smoothness(scheme=...)`: after factoring out (1+z)^{n} the mask leaves a "
            f"factor of degree {len(q) - 1}, whose {len(q) - 1} x {len(q) - 1} transition "
            f"matrices are above the limit of {MAX_JSR_SIZE} x {MAX_JSR_SIZE}: the joint "
            "spectral radius search costs O(M^3) per matrix product and would run for "
            "minutes to hours. Analyze a shorter mask (or one with more (1+z) factors)."
        )
    lo, hi, method = jsr_search(transition_matrices(q), n)
    holder_lower, holder_upper = _holder_bracket(n, lo, hi)
    k = math.ceil(holder_lower) - 1  # largest integer strictly below holder_lower
    decided = _decided(holder_lower, holder_upper)
    if lo == hi:
        holder_upper = holder_lower
    k = max(k, -1)
    if k < 0:
        # Not C^0 is proven by an exponent at most 0, whatever integers the bracket
        # holds below it (four-point at w = 2: [-2 - 1.4e-9, -2], read as undecided).
        decided = holder_upper <= 0
    reason = ""
    if k < 0:
        reason = (
            f"the difference scheme is not contractive (joint spectral radius >= "
            f"{lo / 2 ** (n - 1):.6g} >= 1)"
            if decided
            else "convergence could not be decided (the bounds straddle the threshold)"
        )
    return Smoothness(
        converges=k >= 0,
        holder_lower=float(holder_lower),
        holder_upper=float(holder_upper),
        continuity=int(k),
        decided=bool(decided),
        factors=int(n),
        jsr_lower=float(lo),
        jsr_upper=float(hi),
        reason=reason,
        method=method,
    )


def smoothness(scheme: AbstractCurveScheme) -> Smoothness:
    r"""Convergence, Hölder exponent and $C^k$ class of a scheme's limit curves.

    Works for any binary mask (use [`jaxsubdiv.MaskScheme`][] for your own): it factors
    the symbol by the largest power $N$ of $(1+z)$ and brackets the joint spectral radius
    $\rho$ of the two matrices of the remaining factor, so the Hölder exponent
    $\alpha = N - 1 - \log_2\rho$ comes with rigorous lower and upper bounds, and the
    scheme is $C^k$ exactly for $k < \alpha$ (see the module notes for the theory and the
    references: Dyn and Levin 2002, Rioul 1992, Daubechies and Lagarias 1992). A fast
    branch-and-bound pass answers when it is already exact; otherwise the invariant polytope algorithm (Guglielmi and Protasov 2013)
    finds $\rho$ exactly when it closes (`method` says which; `docs/analysis.md`). Every
    built-in scheme at every value of the benchmark's sweeps is bracketed within 0.01,
    except the four-point scheme just above $w = 1/16$ (up to $10^{-4}$ above: brackets
    up to 0.23 wide, the class still decided).

    When to use it: to choose or tune a parameter (is `FourPoint(w)` still $C^1$ at this
    `w`?), before asking for tangents, or to sweep a parameter: a fast pass takes a few
    milliseconds, the polytope 10-150 ms (`benchmarks/bench_analysis.py`), and results
    are cached per mask.

    The exponent is that of the basis function $\varphi$ (the limit of a single control
    point), which bounds the smoothness of every limit curve. The formula is exact when
    the integer shifts of $\varphi$ are stable (all built-in schemes) and otherwise
    `holder_lower` is still a valid lower bound. Smoothness here is parametric (in the
    uniform parameter of the subdivision), not geometric ($G^1$) smoothness.

    **Arguments:**

    - `scheme`: a curve scheme with concrete parameter values. Runs on the host with
      NumPy in float64; traced parameters (inside `jit`, `vmap`, `grad`) are an error.

    **Limits:** masks of at most 256 coefficients (`MAX_MASK_LENGTH`), and after
    factoring out $(1+z)^N$ a factor of degree at most 64 (`MAX_JSR_SIZE`); larger ones
    are a `ValueError` (the search costs $O(M^3)$ per matrix product: a
    128-coefficient random mask ran for over 3 minutes). Above degree 8 the search keeps
    fewer products per length (its work is capped at what degree 8 costs), so the bounds
    are looser and `decided` is more often False; above degree 4 the polytope is not
    tried (its facets multiply: a review measured 100 s and 1.2 GB at degree 6). A worst
    case takes seconds.

    **Returns:** a [`jaxsubdiv.Smoothness`][] with `converges`, `holder_lower`,
    `holder_upper`, `continuity` (the largest $k$ with a $C^k$ limit, -1 if it does not
    converge), `decided`, `factors`, `jsr_lower`, `jsr_upper`, `reason` and `method`.
    A non-convergent scheme is reported (`converges=False`), not raised.
    """
    if not isinstance(scheme, AbstractCurveScheme):
        raise TypeError(
            "`smoothness(scheme=...)` must be a jaxsubdiv curve scheme; for a raw mask use "
            f"`jaxsubdiv.MaskScheme(coefficients, start)`. Got {type(scheme).__name__}."
        )
    if scheme.mask_length > MAX_MASK_LENGTH:
        raise ValueError(
            f"`smoothness(scheme=...)`: {type(scheme).__name__} has a mask of "
            f"{scheme.mask_length:,} coefficients, above the limit of {MAX_MASK_LENGTH} for "
            "analysis (its cost grows with the square of the length and longer masks cannot "
            "be analyzed to working precision). Analyze a shorter mask."
        )
    mask = scheme.mask()
    if is_traced(mask):
        raise TypeError(
            "`smoothness` runs on the host with NumPy and needs concrete parameter values, "
            "not traced ones: call it outside `jit`/`vmap`/`grad` (for a sweep, loop over "
            "the values in Python; each call takes milliseconds)."
        )
    if mask.ndim != 1:
        raise ValueError(
            f"`smoothness`: {type(scheme).__name__} holds a batch of parameter values (mask "
            f"shape {mask.shape}); call `smoothness` once per value."
        )
    # The mask's rounding sets how exactly its sums and factors can hold: 1e-9 in
    # float64, about 1e-5 for a float32 mask (e.g. with x64 off), whose coefficients
    # (such as -w and 1/2 + w) round separately.
    host = scheme.host_mask()
    tol = max(1e-9, 128 * float(np.finfo(host.dtype).eps))
    values = np.asarray(host, dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise ValueError(f"`smoothness`: the mask has non-finite coefficients: {values}.")
    # Parity of the first coefficient: rotate so index 0 of the tuple is an even index.
    if scheme.mask_start % 2:
        values = np.concatenate([[0.0], values])
    return _smoothness_cached(tuple(float(v) for v in values), tol, str(host.dtype))
