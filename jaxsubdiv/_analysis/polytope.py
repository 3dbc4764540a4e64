r"""The joint spectral radius by the invariant polytope algorithm.

For matrices $T_0, T_1$ and a candidate spectrum-maximizing product $\Pi$ (s.m.p.) of
length $L$, with $\lambda = \rho(\Pi)^{1/L}$ and $A_i = T_i / \lambda$: start a set of
vertices with the leading eigenvector $v$ of $\Pi$, and add $A_i u$ for every new vertex
$u$ unless it already lies in the absolutely convex hull $P = \mathrm{absconv}(V)$. When
no vertex is added, $A_i P \subset P$, so $\|A_i\|_P \le 1$ in the norm whose unit ball
is $P$, and $\rho(T_0, T_1) \le \lambda$: with the lower bound $\rho \ge \lambda$ the
joint spectral radius is exactly $\lambda$ (Guglielmi and Protasov 2013, 2016).

The algorithm stops when the candidate is a dominant s.m.p. whose leading eigenvalue is
simple and real (the case for the four-point scheme at every $w$ swept, see
`docs/analysis.md`), or when the matrices generate a finite group. Otherwise it is
stopped at a budget of vertices (and of generations); the polytope is still a norm when
its vertices span the space, and $\lambda \max_{u, i} \|A_i u\|_P$ over the last
vertices is then a rigorous (if not tight) upper bound. An s.m.p. that another product
nearly matches with a slowly turning complex pair (the four-point scheme just above
$w = 1/16$) needs more vertices than the budget: there the result stays a bracket.

Whether $x \in P$: Qhull's facets of $\mathrm{conv}(\pm V)$ (scipy.spatial, rebuilt each
generation from the extreme vertices) give $\|x\|_P = \max_f y_f \cdot x$, to
`LP_TOLERANCE`. Only up to `MAX_HULL_DIMENSION` dimensions and `MAX_FACETS` facets:
beyond, the polytope gives up and branch and bound answers. (Linear programs instead of
facets were tried: HiGHS's absolute tolerances made thin polytopes claim closure
wrongly, and Qhull's incremental mode aborted the interpreter on some inputs.)

References: N. Guglielmi, V. Yu. Protasov, "Exact computation of joint spectral
characteristics of linear operators", Found. Comput. Math. 13 (2013) 37-97.
N. Guglielmi, V. Yu. Protasov, "Invariant polytopes of sets of matrices: application to
the regularity of wavelets and subdivisions", SIAM J. Matrix Anal. Appl. 37 (2016)
18-52.
"""

import numpy as np


#: The relative tolerance to which a point is decided inside the polytope by the hull's
#: facets; an exact result is reported as $[\lambda, \lambda (1 + \text{LP\_TOLERANCE})]$.
LP_TOLERANCE = 1e-9

# Measured on the four-point scheme: the polytope closes with 8-44 vertices for
# -0.49 <= w <= 0.49, and with about 300 at w = 1/16 + 1e-4 (1 s). A candidate that is
# not an s.m.p. grows vertices without end, so the search stops at twice this many.
MAX_VERTICES = 160


class _Polytope:
    """The absolutely convex hull $P$ of a growing set of vertices.

    It keeps Qhull's facets of $\\mathrm{conv}(\\pm V)$ in the span of the vertices,
    rebuilt each generation, so that norms are one matrix product, and only the extreme
    vertices (the others change nothing: closure needs the children of the extreme ones
    inside)."""

    def __init__(self, vertices: np.ndarray):
        self.vertices = np.zeros((vertices.shape[0], 0))
        self.add(vertices)

    def add(self, points: np.ndarray) -> np.ndarray:
        """Add the columns of `points` as vertices; return those that are extreme."""
        from scipy.spatial import ConvexHull, QhullError

        m, k = points.shape[0], self.vertices.shape[1]
        if not points.shape[1]:
            return points
        self.vertices = np.concatenate([self.vertices, points], axis=1)
        self.basis, rest = _split(self.vertices)
        self.full = not rest.shape[1]
        if self.full:
            self.basis = np.eye(m)
        self.facets = None  # functionals y_f (rows, in basis coordinates): y_f . p <= 1
        rank = self.basis.shape[1]
        if not 2 <= rank <= MAX_HULL_DIMENSION:
            return points
        old, new = self.basis.T @ self.vertices[:, :k], self.basis.T @ points
        # Rebuilt each generation from the extreme vertices: Qhull's incremental mode
        # (`add_points`) aborted the process on near-degenerate input (a review found
        # inputs that kill the interpreter), and was no faster here.
        try:
            hull = ConvexHull(np.concatenate([old, -old, new, -new], axis=1).T)
        except (QhullError, ValueError):  # degenerate: no facets, the search gives up
            return points
        # Facet f: normal . p + offset <= 0 inside, offset < 0 (the origin is inside).
        normals, offsets = hull.equations[:, :-1], hull.equations[:, -1]
        if not np.all(offsets < 0):
            return points
        if len(offsets) > MAX_FACETS:
            raise _GiveUp
        self.facets = normals / -offsets[:, None]
        # Input columns: the old vertices, their negatives, the new, their negatives.
        c = points.shape[1]
        index = hull.vertices
        owner = np.where(index < 2 * k, index % max(k, 1), k + (index - 2 * k) % c)
        keep = np.zeros(k + c, bool)
        keep[owner] = True
        self.vertices = self.vertices[:, keep]
        return points[:, keep[k:]]

    def norms(self, points: np.ndarray) -> np.ndarray | None:
        """$\\|x\\|_P$ for the columns of `points`, which lie in the vertices' span
        (None when the hull's facets are not available: see `polytope_upper_bound`)."""
        inner = self.basis.T @ points
        if self.facets is not None:
            return np.abs(self.facets @ inner).max(axis=0)
        if self.basis.shape[1] == 1:
            return np.abs(inner[0]) / np.abs(self.basis.T @ self.vertices).max()
        return None

    def outside(self, points: np.ndarray) -> np.ndarray:
        """The columns of `points` that lie outside the polytope (beyond its tolerance)."""
        # Outside the span of the vertices (a young polytope is flat): outside P.
        residual = points - self.basis @ (self.basis.T @ points)
        out = np.linalg.norm(residual, axis=0) > 1e-9 * np.linalg.norm(points, axis=0)
        rest = np.flatnonzero(~out)
        if rest.size:
            norms = self.norms(points[:, rest])
            if norms is None:
                raise _GiveUp
            out[rest] = norms > 1 + LP_TOLERANCE
        return points[:, out]


#: The largest dimension the polytope is tried in. Its facets multiply with the
#: dimension: a review measured 1.1 million facets, 100 s and 1.2 GB for a 6x6 pair.
#: Every built-in scheme's matrices are at most 4x4.
MAX_HULL_DIMENSION = 4

#: Above this many facets the polytope gives up (branch and bound answers instead);
#: closing at w = 1/16 + 1e-4 needs more than 20,000 (1.3 s).
MAX_FACETS = 60_000


class _GiveUp(Exception):
    """The polytope cannot decide rigorously and cheaply: no hull's facets to measure
    with (a linear program with HiGHS's absolute tolerances is not rigorous for thin
    polytopes, a review showed), or too many facets."""


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
    if not lam > 0 or m > MAX_HULL_DIMENSION:
        return np.inf, False
    try:
        return _grow(matrices / lam, _Polytope(_leading_vectors(product)), lam, m,
                     2 * max_vertices)
    except _GiveUp:
        return np.inf, False


def _grow(normalised, polytope, lam, m, budget):
    new = polytope.vertices
    # Vertices that stop being extreme are dropped, so an orbit that spirals outwards
    # can run for ever without reaching the budget: the generations are capped too.
    for _ in range(budget):
        was_full = polytope.full
        # Each generation's children are measured together against the polytope before
        # it: a child that a sibling would have covered becomes a (redundant) vertex,
        # which changes nothing proven. (Measuring grandchildren too, to save work, was
        # 3x slower on the four-point scheme: the vertices multiply.)
        new = polytope.add(polytope.outside(np.concatenate([a @ new for a in normalised], axis=1)))
        if not new.shape[1]:
            # Closed: ||A_i||_P <= 1, but only on the span of the vertices. A common
            # invariant subspace would hide the rest of the space, so the missing
            # directions join (small, so that they do not enlarge P needlessly) until
            # the polytope is a body.
            if polytope.full:
                return lam * (1 + LP_TOLERANCE), True
            missing = _complement(polytope.vertices, m)
            polytope.add(1e-3 * np.linalg.norm(polytope.vertices, axis=0).min() * missing)
        if polytope.full and not was_full:
            # While flat, children were measured by their projection on the span; now
            # that P is a body, every vertex's children are measured in full again.
            new = polytope.vertices
        if polytope.vertices.shape[1] > budget:
            break
    if not polytope.full:
        return np.inf, False
    # The operator norms in P: every vertex's children, measured against P as it is.
    children = np.concatenate([a @ polytope.vertices for a in normalised], axis=1)
    norms = polytope.norms(children)
    if norms is None:
        return np.inf, False
    return lam * max(1.0, float(norms.max())) * (1 + LP_TOLERANCE), False


def _split(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal bases (columns) of the span of the vertices and of its complement."""
    u, singular, _ = np.linalg.svd(vertices, full_matrices=True)
    # NumPy's `matrix_rank` threshold: a thin but full polytope (the four-point scheme
    # at w = 1e-4 has a direction 1e-8 of the others) spans the space.
    threshold = max(vertices.shape) * np.finfo(float).eps * singular.max() if singular.size else 0
    rank = int((singular > threshold).sum())
    return u[:, :rank], u[:, rank:]


def _complement(vertices: np.ndarray, m: int) -> np.ndarray:
    """An orthonormal basis (columns) of the directions the vertices do not span."""
    return _split(vertices)[1][:, :m]
