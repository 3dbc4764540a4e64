r"""The joint spectral radius by the invariant polytope algorithm.

For matrices $T_0, T_1$ and a candidate spectrum-maximizing product $\Pi$ (s.m.p.) of
length $L$, with $\lambda = \rho(\Pi)^{1/L}$ and $A_i = T_i / \lambda$: start a set of
vertices with the leading eigenvector $v$ of $\Pi$, and add $A_i u$ for every new vertex
$u$ unless it already lies in the absolutely convex hull $P = \mathrm{absconv}(V)$. When
no vertex is added, $A_i P \subset P$, so $\|A_i\|_P \le 1$ in the norm whose unit ball
is $P$, and $\rho(T_0, T_1) \le \lambda$: with the lower bound $\rho \ge \lambda$ the
joint spectral radius is exactly $\lambda$ (Guglielmi and Protasov 2013, 2016).

The algorithm stops when the candidate is a dominant s.m.p. whose leading eigenvalue is
simple and real (the case for the four-point scheme at every $w$ tried, see
`docs/analysis.md`), or when the matrices generate a finite group.
Otherwise it is stopped at a vertex budget; the polytope is still a norm when its
vertices span the space, and $\lambda \max_{u, i} \|A_i u\|_P$ over the last vertices
is then a rigorous (if not tight) upper bound.

Whether $x \in P$ is a linear program: $\|x\|_P = \min \|c\|_1$ subject to $V c = x$
(HiGHS through `scipy.optimize.linprog`, to a tolerance of `LP_TOLERANCE`).

References: N. Guglielmi, V. Yu. Protasov, "Exact computation of joint spectral
characteristics of linear operators", Found. Comput. Math. 13 (2013) 37-97.
N. Guglielmi, V. Yu. Protasov, "Invariant polytopes of sets of matrices: application to
the regularity of wavelets and subdivisions", SIAM J. Matrix Anal. Appl. 37 (2016)
18-52.
"""

import numpy as np


#: The relative accuracy to which a vertex is decided inside the polytope: the linear
#: programs are solved to a feasibility tolerance well below it, and an exact result is
#: reported as the interval $[\lambda, \lambda (1 + \text{LP\_TOLERANCE})]$.
LP_TOLERANCE = 1e-9

# Measured on the four-point scheme: the polytope closes with 8-44 vertices for
# -0.49 <= w <= 0.49 (one linear program each for about 1-2 ms). A candidate that is not
# an s.m.p. grows vertices without end, so the search stops at this many.
MAX_VERTICES = 160


def _polytope_norm(vertices: np.ndarray, x: np.ndarray) -> tuple[float, np.ndarray | None]:
    """$\\|x\\|_P$ and the dual solution $y$ ($\\|x\\|_P = x \\cdot y$ with
    $|V^T y| \\le 1$, a supporting hyperplane); `(inf, None)` when `x` is not in the
    span of the vertices."""
    from scipy.optimize import linprog

    k = vertices.shape[1]
    result = linprog(
        np.ones(2 * k), A_eq=np.hstack([vertices, -vertices]), b_eq=x, bounds=(0, None),
        method="highs", options=_LP_OPTIONS,
    )
    if result.status != 0:
        return np.inf, None
    return float(result.fun), np.asarray(result.eqlin.marginals)


_LP_OPTIONS = dict(primal_feasibility_tolerance=1e-10, dual_feasibility_tolerance=1e-10)


class _Polytope:
    """The absolutely convex hull of a growing set of vertices, with the supporting
    hyperplanes met so far: a child that one of them shows outside needs no linear
    program (most children of a young polytope are outside)."""

    def __init__(self, vertices: np.ndarray):
        self.vertices = vertices
        self.normals: list[np.ndarray] = []

    def norm_at_least(self, x: np.ndarray) -> float:
        """A lower bound on $\\|x\\|_P$ from the stored hyperplanes (0 without any)."""
        if not self.normals:
            return 0.0
        normals = np.stack(self.normals, axis=1)
        # Rescaled so that every vertex satisfies |v . y| <= 1: valid for the grown P.
        scale = np.abs(self.vertices.T @ normals).max(axis=0)
        return float(np.max(np.abs(x @ normals) / np.maximum(scale, 1e-300)))

    def norm(self, x: np.ndarray) -> float:
        value, normal = _polytope_norm(self.vertices, x)
        if normal is not None:
            self.normals.append(normal)
        return value

    def add(self, x: np.ndarray) -> None:
        self.vertices = np.concatenate([self.vertices, x[:, None]], axis=1)


def _leading_vectors(product: np.ndarray) -> np.ndarray:
    """The starting vertices: the real leading eigenvector of `product` when its leading
    eigenvalue is simple and real (the case where the algorithm can close), otherwise
    the real and imaginary parts of every eigenvector of largest modulus (e.g. for a
    finite group of matrices, whose orbits are finite; a rotation never closes, but the
    budget's bound still holds)."""
    values, vectors = np.linalg.eig(product)
    modulus = np.abs(values)
    leading = modulus >= modulus.max() * (1 - 1e-9)
    parts = [vectors[:, leading].real, vectors[:, leading].imag]
    columns = np.concatenate(parts, axis=1)
    lengths = np.linalg.norm(columns, axis=0)
    columns = columns[:, lengths > 1e-9] / lengths[lengths > 1e-9]
    return columns


def polytope_upper_bound(
    matrices: np.ndarray, product: np.ndarray, lam: float, *, max_vertices: int = MAX_VERTICES
) -> tuple[float, bool]:
    """An upper bound on the joint spectral radius of `matrices`, and whether it is exact.

    `product` is the candidate s.m.p. and `lam` its normalised spectral radius
    $\\rho(\\Pi)^{1/L}$ (a lower bound). Returns `(lam * (1 + LP_TOLERANCE), True)` when
    the polytope closes, `(bound, False)` with a rigorous bound otherwise (`inf` when
    none could be made).
    """
    m = matrices.shape[-1]
    if not lam > 0:
        return np.inf, False
    normalised = matrices / lam
    polytope = _Polytope(_leading_vectors(product))
    new = polytope.vertices
    while True:
        first = polytope.vertices.shape[1]
        for x in np.concatenate([a @ new for a in normalised], axis=1).T:
            if polytope.norm_at_least(x) > 1 + LP_TOLERANCE or polytope.norm(x) > 1 + LP_TOLERANCE:
                polytope.add(x)
        new = polytope.vertices[:, first:]
        if not new.shape[1]:
            # Closed: ||A_i||_P <= 1, but only on the span of the vertices. A common
            # invariant subspace would hide the rest of the space, so the missing
            # directions join (small, so that they do not enlarge P needlessly) until
            # the polytope is a body.
            missing = _complement(polytope.vertices, m)
            if not missing.shape[1]:
                return lam * (1 + LP_TOLERANCE), True
            scale = 1e-3 * np.linalg.norm(polytope.vertices, axis=0).min()
            for x in (scale * missing).T:
                polytope.add(x)
            new = polytope.vertices[:, -missing.shape[1]:]
        if polytope.vertices.shape[1] > max_vertices:
            if _complement(polytope.vertices, m).shape[1]:
                return np.inf, False
            # Every earlier child lies in the (grown) polytope; only the newest
            # vertices' children remain to be measured.
            children = np.concatenate([a @ new for a in normalised], axis=1)
            worst = max(polytope.norm(x) for x in children.T)
            return lam * max(1.0, worst) * (1 + LP_TOLERANCE), False


def _complement(vertices: np.ndarray, m: int) -> np.ndarray:
    """An orthonormal basis (columns) of the directions the vertices do not span."""
    u, singular, _ = np.linalg.svd(vertices, full_matrices=True)
    rank = int((singular > 1e-10 * singular.max()).sum()) if singular.size else 0
    return u[:, rank:m]
