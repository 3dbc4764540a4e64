"""Curve stencil tables (`jaxsubdiv.curve_stencil`, `jaxsubdiv.limit_curve`).

Checked against refine + limit_points/limit_tangents, against plain numpy written here
(refinement by the mask's definition, limit stencils from numpy's eigenvectors), against
scipy's B-splines for the B-spline schemes, against central finite differences, and for
affine invariance. Cases share shapes (n is the minimum or 9) to keep the number of
compiled programs small.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import (
    all_schemes,
    bspline_schemes,
    parametrised_schemes,
    refine_by_definition,
)

import jaxsubdiv as js


def _limit_minimum(scheme, boundary, levels):
    """The fewest control points whose refined polygon still has limit samples."""
    reach = len(js.neighborhood(scheme, "vertex")) // 2
    for n in range(2 if boundary != "closed" else 3, 40):
        try:
            count = js.refined_count(n, scheme, levels, boundary)
        except ValueError:
            continue
        if boundary == "open" and count - 2 * reach < 1:
            continue
        reflects = scheme.is_primal and scheme.clamp_ghost == "reflect"
        if boundary == "clamped" and reflects and count <= reach:
            continue  # derivatives: the reflection through one end must not pass the other
        return n
    raise AssertionError("no n found")


def _cases():
    """(id, scheme, boundary, n, levels): every built-in scheme with each boundary it
    supports, the fewest control points and 9, levels 1..4 in turn."""
    cases = []
    for name, scheme in all_schemes():
        for boundary in ("closed", "open", "clamped"):
            if boundary == "clamped" and scheme.clamp_ghost is None:
                continue
            levels = 1 + len(cases) % 4
            for n in sorted({_limit_minimum(scheme, boundary, levels), 9}):
                cases.append(
                    pytest.param(scheme, boundary, n, levels,
                                 id=f"{name}-{boundary}-n{n}-L{levels}")
                )
    return cases


CASES = _cases()
_SMOOTHNESS = {}


def _continuity(scheme) -> int:
    key = repr(scheme)
    if key not in _SMOOTHNESS:
        _SMOOTHNESS[key] = js.smoothness(scheme).continuity
    return _SMOOTHNESS[key]


def _orders(scheme, boundary):
    """Derivative orders the scheme has (clamped ends: positions only, but for primal
    schemes whose clamped rule reflects the polygon through its ends)."""
    if boundary == "clamped" and not (scheme.is_primal and scheme.clamp_ghost == "reflect"):
        return [0]
    return list(range(min(_continuity(scheme), 2) + 1))


def _points(n, seed=0):
    return np.random.default_rng(seed).standard_normal((n, 2))


# --------------------------------------------------------------------------------------
# Plain numpy references.


def _basis_at_integers(mask, start, order):
    """phi^(p) at the integers inside its support: the eigenvector of A_ij = a_{2i-j}
    for eigenvalue 2^-p (numpy's eig), normalised by sum_m (-m)^p phi^(p)(m) = p!."""
    length = len(mask)
    points = list(range(start + 1, start + length - 1))
    A = np.array([[mask[2 * i - j - start] if 0 <= 2 * i - j - start < length else 0.0
                   for j in points] for i in points])
    values, vectors = np.linalg.eig(A)
    v = np.real(vectors[:, np.argmin(np.abs(values - 2.0**-order))])
    norm = sum((-m) ** order * x for m, x in zip(points, v))
    return dict(zip(points, v * math.factorial(order) / norm))


def _basis(mask, start, order, x2):
    """phi^(p)(x2 / 2), from the integers by the refinement equation at half-integers."""
    at = _basis_at_integers(mask, start, order)
    if x2 % 2 == 0:
        return at.get(x2 // 2, 0.0)
    total = 0.0
    for j, value in at.items():
        k = x2 - j  # phi(m + 1/2) = 2^p sum_j a_{2m+1-j} phi(j)
        if 0 <= k - start < len(mask):
            total += mask[k - start] * value
    return 2.0**order * total


def _numpy_limit(Q, mask, start, order, boundary):
    """The vertex limit stencil phi^(p)(c - u), |u| < (L-1)/2, over the refined polygon."""
    length = len(mask)
    c2 = 2 * start + length - 1  # twice the center
    offsets = [u for u in range(-length, length + 1) if 2 * abs(u) < length - 1]
    weights = [_basis(mask, start, order, c2 - 2 * u) for u in offsets]
    N = len(Q)
    if boundary == "closed":
        return sum(w * np.roll(Q, -u, axis=0) for w, u in zip(weights, offsets))
    a = max(offsets)
    return sum(w * Q[a + u : N - a + u] for w, u in zip(weights, offsets))


def _mask(scheme):
    return np.asarray(scheme.mask(), np.float64)


# --------------------------------------------------------------------------------------
# The table against refine + limit stencils.


@pytest.mark.parametrize("scheme, boundary, n, levels", CASES)
def test_table_against_refine_plain_numpy_and_affine_invariance(scheme, boundary, n, levels):
    """One table per derivative order, checked three ways (one test, so each table's
    programs are compiled once):

    - `limit_curve` = `limit_points(refine(P, L))`, and its derivatives 2^L and 4^L times
      `limit_tangents` and `limit_second_derivatives` of `refine(P, L)`;
    - closed and open curves against numpy: refinement by the definition
      Q_K = sum_j a_{K-2j} P_j, then the limit stencils from numpy's eigenvectors; the
      refined-points table (`derivative=None`) against the refinement alone;
    - every position row (limit and refined) sums to 1, every derivative row to 0:
      translating the control points translates the curve and leaves its derivatives.
    """
    P = _points(n)
    mask, start = _mask(scheme), scheme.mask_start
    Q = js.refine(P, scheme, levels, boundary=boundary)
    library = [js.limit_points, js.limit_tangents, js.limit_second_derivatives]
    for order in [None, *_orders(scheme, boundary)]:
        table = js.curve_stencil(scheme, n, levels, boundary=boundary, derivative=order)
        got = table.apply(P)
        assert table.weights.shape == (len(table.first), table.width)
        if order is None:
            expected = (refine_by_definition(P, mask, start, levels, boundary)
                        if boundary != "clamped" else np.asarray(Q))
            np.testing.assert_allclose(got, expected, atol=1e-12)
        else:
            expected = 2.0 ** (order * levels) * library[order](Q, scheme, boundary=boundary)
            scale = 1 + float(jnp.max(jnp.abs(expected)))
            np.testing.assert_allclose(got, expected, atol=1e-12 * scale)
            np.testing.assert_allclose(
                js.limit_curve(P, scheme, levels, boundary=boundary, derivative=order),
                expected, atol=1e-12 * scale)
            if boundary != "clamped":
                plain = refine_by_definition(P, mask, start, levels, boundary)
                expected = 2.0 ** (order * levels) * _numpy_limit(plain, mask, start, order,
                                                                   boundary)
                np.testing.assert_allclose(got, expected,
                                           atol=1e-9 * (1 + np.max(np.abs(expected))))
        sums = np.asarray(jnp.sum(table.weights, axis=1))
        target = 1.0 if order in (None, 0) else 0.0
        np.testing.assert_allclose(sums, target, atol=1e-12 * 2.0 ** ((order or 0) * levels))


@pytest.mark.parametrize("name, scheme, degree", bspline_schemes)
@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
def test_bspline_schemes_match_scipy(name, scheme, degree, boundary):
    """Uniform B-spline schemes: samples and derivatives of scipy's BSpline at the dyadic
    parameters t_K = K / 2^L - c (1 - 2^-L) (closed); open curves keep those where the
    curve is complete; a clamped B-spline of odd degree p is the open curve of the
    polygon with (p - 1) / 2 reflected ghost points 2 P_0 - P_q, 2 P_{n-1} - P_{n-1-q}
    at each end, derivatives included."""
    from scipy.interpolate import BSpline

    if boundary == "clamped" and degree % 2 == 0:
        pytest.skip("the ghost-point closed form is the primal (odd-degree) schemes'")
    levels, n = 3, 9
    P = _points(n, seed=2)
    c = scheme.center
    shift = c - scheme.mask_start  # phi(x) = B(x + shift), B on knots 0..degree+1
    R = 2**levels
    if boundary == "closed":
        pad = degree + 3
        ext = np.array([P[(i - pad) % n] for i in range(n + 2 * pad)])
        t = np.arange(n * R) / R - c * (1 - 1 / R)
        u = t + shift + pad
    elif boundary == "open":
        # The dyadic parameters where every basis function phi(x - j) that is not zero
        # has 0 <= j < n: x in [start + L - 2, n + start] for a mask of length L.
        ext = P
        low, high = scheme.mask_start + scheme.mask_length - 2, n + scheme.mask_start
        t = np.arange(-4 * n * R, 4 * n * R) / R - c * (1 - 1 / R)
        u = t[(t >= low - 1e-12) & (t <= high + 1e-12)] - scheme.mask_start
    else:
        ghosts = (degree - 1) // 2
        ext = np.concatenate([2 * P[:1] - P[ghosts:0:-1], P,
                              2 * P[-1:] - P[-2:-2 - ghosts:-1]])
        u = np.arange((n - 1) * R + 1) / R + shift + ghosts
    spline = BSpline(np.arange(len(ext) + degree + 1, dtype=float), ext, degree)
    orders = range(min(degree - 1, 2) + 1)
    for order in orders:
        expected = spline.derivative(order)(u) if order else spline(u)
        got = js.limit_curve(P, scheme, levels, boundary=boundary, derivative=order)
        np.testing.assert_allclose(got, expected, atol=1e-11 * 2.0 ** (order * levels))


@pytest.mark.parametrize("name, make, x", parametrised_schemes)
@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
def test_gradient_matches_finite_differences(name, make, x, boundary):
    """d/dx of a random projection of the limit points (and tangents, for C1 schemes;
    at clamped ends for split-and-tweak), x = w, r, s, t or a mask entry, against
    central differences."""
    if boundary == "clamped" and make(x).clamp_ghost is None:
        pytest.skip("no clamped rule")
    n, levels = 9, 2
    P = _points(n, seed=3)
    for order in _orders(make(x), boundary)[:2]:
        N = len(js.limit_curve(P, make(x), levels, boundary=boundary, derivative=order))
        G = np.random.default_rng(4).standard_normal((N, 2))
        f = lambda x: jnp.sum(G * js.limit_curve(P, make(x), levels, boundary=boundary,
                                                 derivative=order))
        h = 1e-6
        central = (float(f(x + h)) - float(f(x - h))) / (2 * h)
        np.testing.assert_allclose(float(jax.grad(f)(x)), central, rtol=1e-6, atol=1e-8)


def test_vmap_and_jit_over_a_parameter():
    P = _points(9, seed=5)
    ws = jnp.asarray([0.03, 0.05, 0.07])
    batched = jax.vmap(lambda w: js.limit_curve(P, js.FourPoint(w), 3, derivative=1))(ws)
    for w, got in zip(ws, batched):
        Q = js.refine(P, js.FourPoint(float(w)), 3)
        np.testing.assert_allclose(got, 8 * js.limit_tangents(Q, js.FourPoint(float(w))),
                                   atol=1e-12)
    jitted = jax.jit(lambda w: js.curve_stencil(js.FourPoint(w), 9, 3).apply(P))(0.05)
    np.testing.assert_allclose(jitted, js.limit_points(js.refine(P, js.FourPoint(0.05), 3),
                                                       js.FourPoint(0.05)), atol=1e-12)


def test_width_does_not_grow_with_the_polygon():
    """O(N width) storage: the windows are as wide for 40 control points as for 9 (the
    cubic B-spline's limit point reads at most 4 consecutive control points)."""
    for boundary in ("closed", "open", "clamped"):
        small = js.curve_stencil(js.CubicBSpline(), 9, 5, boundary=boundary)
        large = js.curve_stencil(js.CubicBSpline(), 40, 5, boundary=boundary)
        assert small.width == large.width <= 4 + 2 * (boundary == "clamped")
        assert large.weights.shape == (js.refined_count(40, js.CubicBSpline(), 5, boundary)
                                       - 2 * (boundary == "open"), large.width)


def test_clear_errors():
    P = _points(9)
    with pytest.raises(ValueError, match="derivative"):
        js.limit_curve(P, js.CubicBSpline(), 2, derivative=3)
    for scheme in (js.FourPoint(), js.Chaikin()):  # clamped ends of their own
        with pytest.raises(ValueError, match="boundary='clamped' for"):
            js.limit_curve(P, scheme, 2, boundary="clamped", derivative=1)
    with pytest.raises(ValueError, match="C2"):
        js.limit_curve(P, js.Chaikin(), 2, derivative=2)
    with pytest.raises(ValueError, match="too few"):
        js.curve_stencil(js.Chaikin(), 2, 2, boundary="open")
    with pytest.raises(ValueError, match="n=9"):
        js.curve_stencil(js.CubicBSpline(), 9, 2).apply(_points(8))
    with pytest.raises(ValueError, match="boundary"):
        js.limit_curve(P, js.CubicBSpline(), 2, boundary="periodic")


# --------------------------------------------------------------------------------------
# The fit's Hessian assembly, on the stencil tables, against the dense sums.


# The cubic B-spline with windows wrapping around most of the polygon (n = 8) and not
# (n = 24), and masks wider than the polygon is long (the `% n` of closed windows).
_ASSEMBLY_CASES = [
    *[pytest.param(js.CubicBSpline(), n, boundary, id=f"bspline-{boundary}-{n}")
      for n in (8, 24) for boundary in ("closed", "open", "clamped")],
    pytest.param(js.LaneRiesenfeld(5), 5, "closed", id="lane_riesenfeld_5-closed-5"),
    pytest.param(js.LaneRiesenfeld(5), 7, "open", id="lane_riesenfeld_5-open-7"),
    pytest.param(js.FourPoint(1 / 16), 6, "open", id="four_point-open-6"),
]


@pytest.mark.parametrize("scheme, n, boundary", _ASSEMBLY_CASES)
def test_fit_model_equals_dense_assembly(scheme, n, boundary):
    """`Objective.quadratic_model` (assembled by windows of the stencil tables) against
    the dense sums written here, with the basis built densely by refining the identity:
    loss B^T W B, gradient and Hessian B^T W B - U^T diag(w / kappa) U plus the
    curve-to-target and smoothing terms."""
    from fitting import _curve
    from fitting._init import second_differences
    from fitting._objective import BACK_WEIGHT, FitData, Objective

    hermite = boundary != "clamped"
    t = np.linspace(0, 2 * np.pi, 60, endpoint=boundary != "closed")[: 60 if boundary == "closed" else 45]
    samples = jnp.asarray(np.stack([np.cos(t) + 0.2 * np.cos(3 * t), np.sin(t)], -1))
    m = samples.shape[0]
    levels = 4
    N = _curve.curve_samples(scheme, n, levels, boundary)
    objective = Objective(n=n, levels=levels, boundary=boundary, names=(), hermite=hermite,
                          num_curve=N, num_target=m)
    weights = jnp.asarray(np.random.default_rng(3).uniform(0.5, 1.5, m))
    args = FitData(samples, weights, scheme, jnp.sqrt(0.01), objective.basis_of(scheme, jnp.float64), None)
    # The dense basis, independently: refine the identity, push it to the limit.
    refined = js.refine(jnp.eye(n), scheme, levels, boundary=boundary)
    A = js.limit_points(refined, scheme, boundary=boundary)
    V = js.limit_tangents(refined, scheme, boundary=boundary) if hermite else None
    np.testing.assert_allclose(args.basis[0].dense(), A, atol=1e-13)
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False)
    P = jnp.asarray(np.stack([np.cos(theta), 0.9 * np.sin(theta)], -1))
    # One compiled program for the library's model and one for the dense sums (op by
    # op, this test compiled over 200 small programs per case).
    @jax.jit
    def model_and_dense(P, A, V):
        y = {"control": P, "params": {}}
        feet = objective.feet(y, args)
        loss, gradient, hessian = objective.quadratic_model(y, args, feet)

        tau, segment, fraction = feet
        closed = boundary == "closed"
        rows, slope_rows, bend_rows = _curve.evaluate(A, V, tau, closed, order=2)
        w = weights * (m / jnp.sum(weights))
        eye = jnp.eye(2)
        gap = rows @ P - samples
        slope, bend = slope_rows @ P, bend_rows @ P
        line, speed2 = objective._line(tau, slope)
        kappa = jnp.maximum(speed2 + jnp.sum(gap * bend, -1), 0.5 * speed2)
        inverse = jnp.where(line, w / jnp.where(line, kappa, 1.0), 0.0)
        U = (rows[:, :, None] * slope[:, None, :] + slope_rows[:, :, None] * gap[:, None, :])
        U = U.reshape(m, -1)
        held = A[objective.held]
        nxt = (segment + 1) % m if closed else jnp.minimum(segment + 1, m - 1)
        direction = samples[nxt] - samples[segment]
        length2 = jnp.sum(direction**2, -1)
        inside = (fraction > 0) & (fraction < 1) & (length2 > 0)
        unit = direction / jnp.sqrt(jnp.where(inside, length2, 1.0))[:, None]
        normal = jnp.where(inside[:, None, None], eye - unit[:, :, None] * unit[:, None, :], eye)
        foot = samples[segment] + fraction[:, None] * direction
        weight = BACK_WEIGHT * m / held.shape[0]
        back = jnp.einsum("kac,kc->ka", normal, held @ P - foot)
        band = objective._band(samples, segment, None)
        square = jnp.sum(back**2, -1)
        active = square > band**2
        length = jnp.sqrt(jnp.where(active, square, 1.0))
        excess = jnp.where(active, length - band, 0.0)
        unit_back = back / length[:, None]
        spread = (held[:, :, None] * jnp.where(active[:, None], unit_back, 0.0)[:, None, :])
        spread = spread.reshape(held.shape[0], -1)
        D = second_differences(n, closed, jnp.float64)
        dense_loss = w @ jnp.sum(gap**2, -1) + weight * jnp.sum(excess**2)
        dense_loss += (0.01 / n) * jnp.sum((D @ P) ** 2)
        dense_gradient = (rows.T @ (w[:, None] * gap)).reshape(-1)
        dense_gradient += weight * (held.T @ (excess[:, None] * unit_back)).reshape(-1)
        dense_gradient += (0.01 / n) * (D.T @ (D @ P)).reshape(-1)
        dense_hessian = jnp.kron(rows.T @ (w[:, None] * rows), eye) - U.T @ (inverse[:, None] * U)
        dense_hessian += weight * (spread.T @ spread) + (0.01 / n) * jnp.kron(D.T @ D, eye)

        return (loss, gradient, hessian), (dense_loss, dense_gradient, dense_hessian)

    (loss, gradient, hessian), (dense_loss, dense_gradient, dense_hessian) = (
        model_and_dense(P, A, V))
    scale = float(jnp.max(jnp.abs(dense_hessian)))
    np.testing.assert_allclose(loss, dense_loss, rtol=1e-12)
    np.testing.assert_allclose(gradient, dense_gradient, atol=1e-12 * scale)
    np.testing.assert_allclose(hessian, dense_hessian, atol=1e-12 * scale)


# --------------------------------------------------------------------------------------
# Creases as a (traced) mask: `curve_stencil(creases=...)`.

# Crease sets on 3, 5 and 9 points: none, one (the piece wraps onto itself), neighbours
# (pieces of one span), every point, and uneven gaps.
# (Few piece lengths: the reference compiles refine and limit_points for each.)
_CREASE_SETS = [(3, (1,)), (3, (0, 1, 2)), (5, (0, 1)), (5, (2,)), (9, ()), (9, (0, 3, 4, 8)),
                (9, (0, 1, 5)), (9, tuple(range(9)))]
# Reach 1 and 2 (split-and-tweak's is 2 as the four-point scheme's).
_CREASE_SCHEMES = [("cubic_bspline", js.CubicBSpline()), ("four_point", js.FourPoint(0.1))]
_CREASE_LEVELS = 3


def _crease_mask(n, creases):
    mask = np.zeros(n, bool)
    mask[list(creases)] = True
    return mask


def _pieces_by_refine(P, scheme, levels, creases):
    """The creased closed curve's limit samples piece by piece: each clamped piece
    refined and pushed to its limit (`refine` + `limit_points`, the kernel's own clamped
    rules), the pieces joined at their shared creases, from control point 0."""
    n = len(P)
    if not creases:
        return np.asarray(js.limit_points(js.refine(P, scheme, levels), scheme))
    cuts = sorted(creases)
    out = []
    for k, c in enumerate(cuts):
        end = cuts[k + 1] if k + 1 < len(cuts) else cuts[0] + n
        piece = P[np.arange(c, end + 1) % n]
        refined = js.refine(piece, scheme, levels, boundary="clamped")
        out.append(np.asarray(js.limit_points(refined, scheme, boundary="clamped"))[:-1])
    return np.roll(np.concatenate(out), cuts[0] * 2**levels, axis=0)


def _bspline_pieces_by_scipy(P, levels, creases, derivative=0, side="right"):
    """The creased closed cubic B-spline by scipy: each piece between creases is a
    uniform cubic B-spline whose polygon is extended by the reflections 2 P_0 - P_1 and
    2 P_D - P_{D-1} (the clamped end's ghost points), from its first to its last point;
    its `derivative` (`BSpline(nu=...)`), at a crease from the piece that starts there
    (`side="right"`) or ends there (`"left"`)."""
    from scipy.interpolate import BSpline

    n, rows = len(P), 2**levels
    cuts = sorted(creases)
    out = []
    shift = 0 if side == "right" else 1  # "left": each piece's samples (0, D], not [0, D)
    for k, c in enumerate(cuts):
        end = cuts[k + 1] if k + 1 < len(cuts) else cuts[0] + n
        piece = P[np.arange(c, end + 1) % n]
        D = len(piece) - 1
        ghosts = np.vstack([2 * piece[0] - piece[1], piece, 2 * piece[-1] - piece[-2]])
        knots = np.arange(len(ghosts) + 4) - 3.0  # piece point p (ghost index p + 1) at t = p
        u = (np.arange(D * rows) + shift) / rows
        out.append(BSpline(knots, ghosts, 3)(u, nu=derivative))
    return np.roll(np.concatenate(out), cuts[0] * rows + shift, axis=0)


@pytest.mark.parametrize("name, scheme", _CREASE_SCHEMES)
def test_creased_table_equals_its_pieces(name, scheme):
    """One table per (scheme, n), the mask traced: every crease set of that size gives
    the pieces' curve (to 1e-12), compiling nothing new after the first."""
    from helpers import CompileCounter

    rng = np.random.default_rng(len(name))
    for size in sorted({n for n, _ in _CREASE_SETS}):
        sets = [c for n, c in _CREASE_SETS if n == size]
        P = rng.normal(size=(size, 2))
        js.curve_stencil(scheme, size, _CREASE_LEVELS,
                         creases=jnp.asarray(_crease_mask(size, ())))
        for creases in sets:
            table = js.curve_stencil(scheme, size, _CREASE_LEVELS,
                                     creases=jnp.asarray(_crease_mask(size, creases)))
            got = np.asarray(table.apply(P))
            want = _pieces_by_refine(P, scheme, _CREASE_LEVELS, creases)
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, atol=1e-12, err_msg=str(creases))
            if isinstance(scheme, js.CubicBSpline) and creases:
                np.testing.assert_allclose(
                    got, _bspline_pieces_by_scipy(P, _CREASE_LEVELS, creases), atol=1e-12)
        # The tables compiled nothing (the reference's refine and limit_points did,
        # once per piece length): count those by building the tables alone again.
        with CompileCounter() as tables:
            for creases in sets:
                js.curve_stencil(scheme, size, _CREASE_LEVELS,
                                 creases=jnp.asarray(_crease_mask(size, creases)))
        assert tables.count == 0


# Derivatives of creased curves: the schemes whose clamped pieces have exact end
# derivatives (`supports_clamped_derivatives`), reach 1 and 2.
_CREASE_DERIVATIVE_SCHEMES = [("cubic_bspline", js.CubicBSpline()),
                              ("split_tweak", js.SplitTweak(0.3)), ("jarek", js.Jarek())]
# One crease (the piece wraps onto itself), neighbours (a piece of one span), uneven gaps.
_CREASE_DERIVATIVE_SETS = [(5, (2,)), (9, (0, 3, 4, 8)), (9, (0, 1, 5))]


def _one_sided_differences(C, K, h, derivative, side):
    """Second-order one-sided differences at samples `K` of the closed sampled curve `C`
    (spacing h), from the samples after K (`side="right"`) or before it."""
    s = 1 if side == "right" else -1
    c = lambda o: C[(K + s * o) % len(C)]
    if derivative == 1:
        return s * (-3 * c(0) + 4 * c(1) - c(2)) / (2 * h)
    return (2 * c(0) - 5 * c(1) + 4 * c(2) - c(3)) / h**2


@pytest.mark.parametrize("name, scheme", _CREASE_DERIVATIVE_SCHEMES)
def test_creased_derivatives_are_one_sided_at_the_creases(name, scheme):
    """`curve_stencil(creases=mask, derivative=1 or 2, side=...)` against one-sided
    differences (spacing 2^-10) of the pieces' limit points (`_pieces_by_refine`: each
    clamped piece refined by the kernel's own rules), on both sides of every sample:
    tangents for every scheme, second derivatives for the cubic B-spline (the others'
    are only Hoelder continuous, and differences converge too slowly to test); for the
    cubic B-spline also against scipy's BSpline of the reflected pieces. At the creases
    the two sides differ; elsewhere they are the same rows."""
    rng = np.random.default_rng(len(name))
    levels, fine = 3, 10
    orders = (1, 2) if isinstance(scheme, js.CubicBSpline) else (1,)
    for size, creases in _CREASE_DERIVATIVE_SETS:
        P = rng.normal(size=(size, 2))
        mask = jnp.asarray(_crease_mask(size, creases))
        dense = _pieces_by_refine(P, scheme, fine, creases)
        K = np.arange(size * 2**levels)
        at_crease = np.isin(K, np.asarray(creases) * 2**levels)
        for derivative in orders:
            sides = {}
            for side in ("right", "left"):
                table = js.curve_stencil(scheme, size, levels, derivative=derivative,
                                         creases=mask, side=side)
                got = sides[side] = np.asarray(table.apply(P))
                want = _one_sided_differences(dense, K * 2 ** (fine - levels), 2.0**-fine,
                                              derivative, side)
                scale = np.max(np.abs(got))
                np.testing.assert_allclose(got, want, atol=2e-4 * scale,
                                           err_msg=f"{creases} {derivative} {side}")
                if isinstance(scheme, js.CubicBSpline):
                    np.testing.assert_allclose(
                        got, _bspline_pieces_by_scipy(P, levels, creases, derivative, side),
                        atol=1e-12, err_msg=f"{creases} {derivative} {side}")
            np.testing.assert_array_equal(sides["right"][~at_crease], sides["left"][~at_crease])
            if derivative == 1:
                assert np.all(np.linalg.norm(sides["right"] - sides["left"], axis=1)[at_crease]
                              > 1e-3 * scale)


def test_creased_table_is_differentiable_in_the_parameter():
    """d/dw of a creased four-point curve against central finite differences."""
    P = np.random.default_rng(3).normal(size=(9, 2))
    mask = jnp.asarray(_crease_mask(9, (0, 3, 4)))

    def curve(w):
        return js.curve_stencil(js.FourPoint(w), 9, 2, creases=mask).apply(P)

    w, h = 0.07, 1e-6
    derivative = jax.jacfwd(curve)(w)
    difference = (curve(w + h) - curve(w - h)) / (2 * h)
    np.testing.assert_allclose(derivative, difference, atol=1e-8)


def test_creased_table_errors():
    mask = jnp.zeros(6, bool)
    with pytest.raises(ValueError, match="dual"):
        js.curve_stencil(js.Chaikin(), 6, 2, creases=mask)
    with pytest.raises(ValueError, match="boundary='closed'"):
        js.curve_stencil(js.CubicBSpline(), 6, 2, boundary="open", creases=mask)
    with pytest.raises(ValueError, match="boolean mask of shape"):
        js.curve_stencil(js.CubicBSpline(), 6, 2, creases=jnp.array([0, 2]))
    with pytest.raises(ValueError, match="clamped end rule"):
        js.curve_stencil(js.Daubechies(), 6, 2, creases=mask)
    with pytest.raises(ValueError, match="center"):
        js.curve_stencil(js.LaneRiesenfeld(3), 6, 2, creases=mask)
    # Derivatives: only where the pieces' clamped ends have them, and a side that exists.
    with pytest.raises(ValueError, match="does not support boundary='clamped' for FourPoint"):
        js.curve_stencil(js.FourPoint(0.05), 6, 2, derivative=1, creases=mask)
    with pytest.raises(ValueError, match="side"):
        js.curve_stencil(js.CubicBSpline(), 6, 2, derivative=1, creases=mask, side="both")
    P = np.random.default_rng(0).normal(size=(6, 2))
    plain = js.limit_curve(P, js.CubicBSpline(), 2)
    # No creases, one as an int, and a list of bools: as refine takes them.
    np.testing.assert_array_equal(js.limit_curve(P, js.CubicBSpline(), 2, creases=[]), plain)
    np.testing.assert_array_equal(
        js.limit_curve(P, js.CubicBSpline(), 2, creases=2),
        js.limit_curve(P, js.CubicBSpline(), 2, creases=[False, False, True, False, False,
                                                          False]))
    with pytest.raises(ValueError, match="indices in"):
        js.limit_curve(P, js.CubicBSpline(), 2, creases=[7])
    with pytest.raises(ValueError, match="traced `creases`"):
        jax.jit(lambda c: js.limit_curve(P, js.CubicBSpline(), 2, creases=c))(jnp.array([1]))


_ROW_CASES = [(js.CubicBSpline(), 3, "closed"), (js.CubicBSpline(), 9, "closed"),
              (js.FourPoint(0.1), 9, "open"), (js.CubicBSpline(), 9, "clamped")]


@pytest.mark.parametrize("scheme, n, boundary", _ROW_CASES)
def test_fit_rows_from_tables_match_the_refined_identity(scheme, n, boundary):
    """The fit reads rows of its curve table without forming the dense `(N, n)` basis
    (`_curve.stencil_rows`, and `_init.interpolate_rows` for its linear start): the
    rows of the basis built independently (the identity refined and pushed to the
    limit), and their linear interpolation in plain numpy. A closed curve of 3 control
    points has windows wider than the polygon, whose repeated columns add up."""
    from fitting._curve import stencil_rows
    from fitting._init import interpolate_rows

    levels, closed = 3, boundary == "closed"
    table = js.curve_stencil(scheme, n, levels, boundary=boundary)
    A = np.asarray(js.limit_points(js.refine(jnp.eye(n), scheme, levels, boundary=boundary),
                                   scheme, boundary=boundary))
    N = A.shape[0]
    index = np.array([0, 1, N // 2, N - 1])
    np.testing.assert_allclose(stencil_rows(table, index), A[index], atol=1e-13)
    traced = jax.jit(lambda i: stencil_rows(table, i))(jnp.asarray(index))
    np.testing.assert_allclose(traced, A[index], atol=1e-13)
    position = np.array([0.0, 0.25, N / 3 + 0.5, N - 1.0 - 0.125 * (not closed)])
    if closed:
        position[-1] = N - 0.5  # between the last sample and the first
    low = np.floor(position).astype(int)
    high = (low + 1) % N if closed else np.minimum(low + 1, N - 1)
    fraction = (position - low)[:, None]
    expected = (1 - fraction) * A[low % N] + fraction * A[high]
    got = interpolate_rows(table, jnp.asarray(position), closed)
    np.testing.assert_allclose(got, expected, atol=1e-13)


@pytest.mark.parametrize("n, creases", [(9, (0, 3, 4)), (5, (2,)), (4, (1,))])
def test_kinks_of_creased_tables_are_the_creases(n, creases):
    """`_curve.kinks` on a creased curve's pair of tangent tables (from after and from
    before each sample, read off the tables' weights) marks exactly the limit points of
    the creased control points, sample 2^levels c of a primal scheme: the same rows as
    the tangents those tables give for random control points (4 control points: windows
    wider than the polygon, compared as dense rows)."""
    from fitting._curve import creased_tables, kinks

    levels = 3
    mask = jnp.zeros(n, bool).at[jnp.asarray(creases)].set(True)
    _, tangents = creased_tables(js.CubicBSpline(), n, levels, mask, jnp.float64, True)
    got = np.asarray(kinks(tangents))
    expected = np.zeros(n * 2**levels, bool)
    expected[np.asarray(creases) * 2**levels] = True
    np.testing.assert_array_equal(got, expected)
    P = jnp.asarray(_points(n, seed=5))
    np.testing.assert_array_equal(kinks(tuple(t.apply(P) for t in tangents)), expected)
