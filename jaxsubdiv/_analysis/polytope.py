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

Whether $x \in P$: in spans of dimension up to `MAX_HULL_DIMENSION`, Qhull's facets of
$\mathrm{conv}(\pm V)$ give $\|x\|_P = \max_f y_f \cdot x$ (scipy.spatial, rebuilt each
generation from the extreme vertices); above it, a linear
program $\|x\|_P = \min \|c\|_1$ subject to $V c = x$ (HiGHS through
`scipy.optimize.linprog`), one per generation. Both decide to `LP_TOLERANCE`.

References: N. Guglielmi, V. Yu. Protasov, "Exact computation of joint spectral
characteristics of linear operators", Found. Comput. Math. 13 (2013) 37-97.
N. Guglielmi, V. Yu. Protasov, "Invariant polytopes of sets of matrices: application to
the regularity of wavelets and subdivisions", SIAM J. Matrix Anal. Appl. 37 (2016)
18-52.
"""

import numpy as np


#: The relative accuracy to which a point is decided inside the polytope (the hull's
#: facets and the linear programs are accurate well below it); an exact result is
#: reported as the interval $[\lambda, \lambda (1 + \text{LP\_TOLERANCE})]$.
LP_TOLERANCE = 1e-9

# Measured on the four-point scheme: the polytope closes with 8-44 vertices for
# -0.49 <= w <= 0.49, and with about 300 at w = 1/16 + 1e-4 (1 s). A candidate that is
# not an s.m.p. grows vertices without end, so the search stops at this many (twice as
# many with Qhull's facets, which are cheaper than linear programs).
MAX_VERTICES = 160


def _polytope_norms(vertices: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """$\\|x\\|_P$ for each column $x$ of `points`, and the dual solutions $y$ (columns;
    $|V^T y| \\le 1$, so each is a supporting hyperplane of $P$). The points must lie in
    the span of the vertices (`_Polytope.outside` sorts out the others first).

    One linear program for all points: their problems are independent blocks, so the
    block-diagonal program's optimum is each block's (one solver call instead of one
    per point: the calls' overhead dominates at these sizes). Should the solver fail
    (a point numerically outside the span), each point gets a program of its own, and
    a failed one the norm `inf` (outside: the safe side, it only adds a vertex)."""
    from scipy.optimize import linprog
    from scipy.sparse import block_diag, csr_matrix

    m, k = vertices.shape
    count = points.shape[1]
    if count > _CHUNK:  # HiGHS slows down more than linearly on large programs
        parts = [_polytope_norms(vertices, points[:, j:j + _CHUNK])
                 for j in range(0, count, _CHUNK)]
        return (np.concatenate([p[0] for p in parts]),
                np.concatenate([p[1] for p in parts], axis=1))
    block = csr_matrix(np.hstack([vertices, -vertices]))
    result = linprog(
        np.ones(2 * k * count), A_eq=block_diag([block] * count, format="csr"),
        b_eq=points.T.reshape(-1), bounds=(0, None), method="highs", options=_LP_OPTIONS,
    )
    if result.status == 0:
        norms = result.x.reshape(count, 2 * k).sum(axis=1)
        return norms, np.asarray(result.eqlin.marginals).reshape(count, m).T
    if count == 1:
        return np.array([np.inf]), np.zeros((m, 1))
    parts = [_polytope_norms(vertices, points[:, [j]]) for j in range(count)]
    return (np.concatenate([p[0] for p in parts]),
            np.concatenate([p[1] for p in parts], axis=1))


# Points per linear program: one program for 256 points against 252 vertices took 20 s,
# sixteen programs of 16 points well under a second.
_CHUNK = 16

_LP_OPTIONS = dict(primal_feasibility_tolerance=1e-10, dual_feasibility_tolerance=1e-10)


class _Polytope:
    """The absolutely convex hull $P$ of a growing set of vertices.

    In spans of dimension up to `MAX_HULL_DIMENSION` it keeps Qhull's facets of
    $\\mathrm{conv}(\\pm V)$, rebuilt each generation, so that norms are one matrix
    product, and only the extreme vertices (the others change nothing: closure needs
    the children of the extreme ones inside). Otherwise norms are linear programs, and
    the supporting hyperplanes they return show later points outside without one."""

    def __init__(self, vertices: np.ndarray):
        self.vertices = np.zeros((vertices.shape[0], 0))
        self.normals = np.zeros((vertices.shape[0], 0))
        self.add(vertices)

    @property
    def size(self) -> int:
        """The number of vertices (the extreme ones when Qhull keeps the hull)."""
        return self.vertices.shape[1]

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
        except (QhullError, ValueError):  # degenerate: linear programs instead
            return points
        # Facet f: normal . p + offset <= 0 inside, offset < 0 (the origin is inside).
        normals, offsets = hull.equations[:, :-1], hull.equations[:, -1]
        if not np.all(offsets < 0):
            return points
        self.facets = normals / -offsets[:, None]
        # Input columns: the old vertices, their negatives, the new, their negatives.
        c = points.shape[1]
        index = hull.vertices
        owner = np.where(index < 2 * k, index % max(k, 1), k + (index - 2 * k) % c)
        keep = np.zeros(k + c, bool)
        keep[owner] = True
        self.vertices = self.vertices[:, keep]
        return points[:, keep[k:]]

    def norms_at_least(self, points: np.ndarray) -> np.ndarray:
        """Lower bounds on $\\|x\\|_P$ for the columns of `points`, from the stored
        hyperplanes (0 without any)."""
        if not self.normals.shape[1]:
            return np.zeros(points.shape[1])
        # Rescaled so that every vertex satisfies |v . y| <= 1: valid for the grown P.
        scale = np.abs(self.vertices.T @ self.normals).max(axis=0)
        useful = scale > 0
        ratios = np.abs(points.T @ self.normals[:, useful]) / scale[useful]
        return ratios.max(axis=1) if ratios.shape[1] else np.zeros(points.shape[1])

    def norms(self, points: np.ndarray) -> np.ndarray:
        """$\\|x\\|_P$ for the columns of `points`, which lie in the vertices' span."""
        inner = self.basis.T @ points
        if self.facets is not None:
            return np.abs(self.facets @ inner).max(axis=0)
        if self.basis.shape[1] == 1:
            return np.abs(inner[0]) / np.abs(self.basis.T @ self.vertices).max()
        values, normals = _polytope_norms(self.vertices, points)
        self.normals = np.concatenate([self.normals, normals], axis=1)
        return values

    def outside(self, points: np.ndarray) -> np.ndarray:
        """The columns of `points` that lie outside the polytope (beyond its tolerance)."""
        out = self.norms_at_least(points) > 1 + LP_TOLERANCE
        # Outside the span of the vertices (a young polytope is flat): outside P.
        residual = points - self.basis @ (self.basis.T @ points)
        out |= np.linalg.norm(residual, axis=0) > 1e-9 * np.linalg.norm(points, axis=0)
        rest = np.flatnonzero(~out)
        if rest.size:
            out[rest] = self.norms(points[:, rest]) > 1 + LP_TOLERANCE
        return points[:, out]


#: The largest span dimension in which Qhull's facets replace linear programs (facets
#: multiply with the dimension; the four-point scheme's polytopes, dimension 4, have a
#: few hundred).
MAX_HULL_DIMENSION = 6


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
    budget = max_vertices if m > MAX_HULL_DIMENSION else 2 * max_vertices
    # Vertices that stop being extreme are dropped, so an orbit that spirals outwards
    # can run for ever without reaching the budget: the generations are capped too.
    for _ in range(budget):
        # Each generation's children are measured together against the polytope before
        # it (one linear program, or the hull's facets): a child that a sibling would
        # have covered becomes a (redundant) vertex, which changes nothing proven.
        # (Measuring grandchildren too, to save programs, was 3x slower on the
        # four-point scheme: most of them are outside and the vertices multiply.)
        new = polytope.add(polytope.outside(np.concatenate([a @ new for a in normalised], axis=1)))
        if not new.shape[1]:
            # Closed: ||A_i||_P <= 1, but only on the span of the vertices. A common
            # invariant subspace would hide the rest of the space, so the missing
            # directions join (small, so that they do not enlarge P needlessly) until
            # the polytope is a body.
            if polytope.full:
                return lam * (1 + LP_TOLERANCE), True
            missing = _complement(polytope.vertices, m)
            new = polytope.add(1e-3 * np.linalg.norm(polytope.vertices, axis=0).min() * missing)
        if polytope.size > budget:
            break
    if not polytope.full:
        return np.inf, False
    # Every earlier child lies in the (grown) polytope; only the newest vertices'
    # children remain to be measured.
    children = np.concatenate([a @ new for a in normalised], axis=1)
    worst = float(polytope.norms(children).max()) if children.shape[1] else 1.0
    return lam * max(1.0, worst) * (1 + LP_TOLERANCE), False


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
