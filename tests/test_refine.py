"""`refine`, `refined_count` and `subdivision_matrix` against independent references."""

import math
import re

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.interpolate as si
from helpers import (
    all_schemes,
    assert_one_clear_error,
    bspline_schemes,
    chaikin_python,
    parametrised_schemes,
    refine_by_definition,
    schemes_with,
)

import jaxsubdiv as js


def polygon(n, d=2, seed=0):
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0, 2 * np.pi, n))
    radius = 1 + 0.3 * rng.standard_normal(n)
    base = np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=-1)
    if d > 2:
        base = np.concatenate([base, rng.standard_normal((n, d - 2))], axis=-1)
    return base[:, :d]


ids = lambda cases: [c[0] for c in cases]


# --------------------------------------------------------------------------------------
# Plain-Python and by-definition references


@pytest.mark.parametrize("closed", [True, False])
@pytest.mark.parametrize("levels", [0, 1, 2, 5])
def test_chaikin_matches_plain_python_loop(closed, levels):
    P = polygon(7)
    out = js.refine(P, js.Chaikin(), levels, boundary="closed" if closed else "open")
    np.testing.assert_allclose(out, chaikin_python(P, levels, closed), rtol=0, atol=1e-14)


@pytest.mark.parametrize("boundary", ["closed", "open"])
@pytest.mark.parametrize("name,scheme", all_schemes(), ids=ids(all_schemes()))
def test_multilevel_matches_definition(name, scheme, boundary):
    # The composite (polyphase) kernel against the definition applied level by level.
    P = polygon(9, d=3)
    for levels in (1, 2, 4):
        expected = refine_by_definition(P, scheme.mask(), scheme.mask_start, levels, boundary)
        out = js.refine(P, scheme, levels, boundary=boundary)
        assert out.shape == expected.shape
        assert js.refined_count(9, scheme, levels, boundary) == expected.shape[0]
        np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)


# --------------------------------------------------------------------------------------
# The B-spline family against scipy


def bspline_curve(control, degree, mask_start, spacing, x):
    """Periodic uniform B-spline with these control points evaluated at x by scipy.

    Basis function j is supported on [(j + mask_start) h, (j + mask_start + degree + 1) h]
    (the support of the refinable function of the scheme's mask), h = `spacing`.
    """
    n = len(control)
    j = np.arange(-2 * (degree + 1), n + 2 * (degree + 1))
    coefficients = control[j % n]
    knots = (np.arange(j[0], j[-1] + degree + 2) + mask_start) * spacing
    return si.BSpline(knots, coefficients, degree, extrapolate=False)(x)


@pytest.mark.parametrize("name,scheme,degree", bspline_schemes, ids=ids(bspline_schemes))
def test_bspline_family_refined_points_are_control_points_of_same_spline(name, scheme, degree):
    P = polygon(8)
    x = np.linspace(0, 8, 97)
    reference = bspline_curve(P, degree, scheme.mask_start, 1.0, x)
    for levels in (1, 2, 3, 5):
        Q = np.asarray(js.refine(P, scheme, levels))
        same = bspline_curve(Q, degree, scheme.mask_start, 2.0**-levels, x)
        np.testing.assert_allclose(same, reference, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name,scheme,degree", bspline_schemes, ids=ids(bspline_schemes))
def test_bspline_family_polygon_converges_to_curve(name, scheme, degree):
    P = polygon(8)
    c = scheme.center
    errors = []
    for levels in (3, 4, 5, 6):
        Q = np.asarray(js.refine(P, scheme, levels))
        K = np.arange(len(Q))
        # Q_K sits at parameter K / 2^k - c (1 - 2^-k); the curve point there is
        # sum_j P_j phi(x - j) with phi centered at c, i.e. scipy's curve at x + c.
        t = K / 2**levels - c * (1 - 2.0**-levels)
        on_curve = bspline_curve(P, degree, scheme.mask_start, 1.0, (t + c) % 8)
        errors.append(np.abs(Q - on_curve).max())
    errors = np.array(errors)
    if degree >= 2:
        # Second-order convergence: each level divides the distance by about 4.
        assert np.all(errors[1:] < errors[:-1] / 3.5), errors
    assert errors[-1] < 2e-3


def test_cubic_clamped_is_bspline_with_reflected_phantom_points():
    # Clamped cubic = the uniform cubic B-spline with phantom points 2P0 - P1 and
    # 2P[n-1] - P[n-2]; check the refined points against scipy on [0, n-1].
    P = polygon(6)
    ext = np.vstack([2 * P[0] - P[1], P, 2 * P[-1] - P[-2]])
    x = np.linspace(0, 5, 41)

    def clamped_curve(control, h):
        m = len(control)
        knots = (np.arange(m + 4) - 3) * h  # control m (index m - 1) on [(m-3)h, (m+1)h]
        return si.BSpline(knots, control, 3, extrapolate=False)(x)

    reference = clamped_curve(ext, 1.0)
    np.testing.assert_allclose(reference[0], P[0], atol=1e-14)
    for levels in (1, 2, 4):
        Q = np.asarray(js.refine(P, js.CubicBSpline(), levels, boundary="clamped"))
        assert len(Q) == js.refined_count(6, js.CubicBSpline(), levels, "clamped")
        np.testing.assert_allclose(Q[[0, -1]], P[[0, -1]], atol=1e-15)
        Qext = np.vstack([2 * Q[0] - Q[1], Q, 2 * Q[-1] - Q[-2]])
        np.testing.assert_allclose(clamped_curve(Qext, 2.0**-levels), reference, atol=1e-12)


# --------------------------------------------------------------------------------------
# Scheme identities


@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
def test_four_point_keeps_old_points(boundary):
    P = polygon(9)
    levels = 3
    Q = np.asarray(js.refine(P, js.FourPoint(0.1), levels, boundary=boundary))
    if boundary != "open":
        np.testing.assert_array_equal(Q[:: 2**levels], P)
        return
    # Open curves lose points at the ends; the old points that remain are still there
    # exactly, consecutive, and 2^k outputs apart.
    where, which = np.nonzero(np.all(Q[:, None, :] == P[None, :, :], axis=-1))
    assert len(where) >= 3
    assert np.all(np.diff(where) == 2**levels) and np.all(np.diff(which) == 1)


def test_four_point_reproduces_cubics():
    # w = 1/16: samples of a cubic stay on the cubic (open curve; x is linear in j).
    j = np.arange(10.0)
    p = lambda x: 0.3 * x**3 - 2 * x**2 + x - 4
    P = np.stack([j, p(j)], axis=-1)
    Q = np.asarray(js.refine(P, js.FourPoint(1 / 16), 4, boundary="open"))
    np.testing.assert_allclose(Q[:, 1], p(Q[:, 0]), rtol=1e-12, atol=1e-10)
    # ... and not for another w.
    Q = np.asarray(js.refine(P, js.FourPoint(0.1), 4, boundary="open"))
    assert np.abs(Q[:, 1] - p(Q[:, 0])).max() > 1e-3


@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
def test_identities_between_schemes(boundary):
    P = polygon(11)
    r = lambda s, k=3: np.asarray(js.refine(P, s, k, boundary=boundary))
    np.testing.assert_allclose(r(js.CornerCutting(0.25, 0.75)), r(js.Chaikin()), atol=1e-15)
    np.testing.assert_allclose(r(js.LaneRiesenfeld(2)), r(js.Chaikin()), atol=1e-15)
    if boundary == "open":
        # SplitTweak's stencil has the four-point's static width for every t (shapes can't
        # depend on a traced t), so its open run is a shorter part of the cubic's.
        tweak, cubic = r(js.SplitTweak(0.0)), r(js.CubicBSpline())
        offset = (len(cubic) - len(tweak)) // 2
        np.testing.assert_allclose(tweak, cubic[offset : offset + len(tweak)], atol=1e-15)
    else:
        np.testing.assert_allclose(r(js.SplitTweak(0.0)), r(js.CubicBSpline()), atol=1e-15)
    if boundary != "clamped":  # FourPoint's classic clamped rule repeats end points
        np.testing.assert_allclose(r(js.SplitTweak(1.0)), r(js.FourPoint(1 / 16)), atol=1e-15)
    if boundary == "clamped":
        return
    # Jarek is the average of the two, level by level (one level from any polygon).
    for Pk in (P, r(js.Jarek(), 1), r(js.Jarek(), 2)):
        one = lambda s: np.asarray(js.refine(Pk, s, 1, boundary=boundary))
        cubic = one(js.CubicBSpline())
        if boundary == "open":  # the four-point run is one point shorter at each end
            cubic = cubic[1:-1]
        avg = (cubic + one(js.FourPoint(1 / 16))) / 2
        np.testing.assert_allclose(one(js.Jarek()), avg, atol=1e-14)


def test_lane_riesenfeld_3_is_cubic_shifted_by_one():
    P = polygon(7)
    for levels in (1, 3):
        lr = np.asarray(js.refine(P, js.LaneRiesenfeld(3), levels))
        cubic = np.asarray(js.refine(P, js.CubicBSpline(), levels))
        # Shift of index: LR output K is the cubic output K + (2^k - 1) (center -1 vs 0).
        np.testing.assert_allclose(lr, np.roll(cubic, -(2**levels - 1), axis=0), atol=1e-14)


def test_mask_scheme_from_rules_equals_builtin():
    w = 0.07
    four = js.MaskScheme.from_rules([1.0], [-w, 0.5 + w, 0.5 + w, -w], 0, -1)
    chaikin = js.MaskScheme.from_rules([0.75, 0.25], [0.25, 0.75], 0, 0)
    P = polygon(8)
    np.testing.assert_allclose(js.refine(P, four, 3), js.refine(P, js.FourPoint(w), 3), atol=1e-15)
    np.testing.assert_allclose(js.refine(P, chaikin, 3), js.refine(P, js.Chaikin(), 3), atol=1e-15)


def test_documented_counts():
    c = js.refined_count
    assert c(10, js.Chaikin(), 1, "open") == 18
    assert c(10, js.CubicBSpline(), 1, "open") == 17
    assert c(10, js.CubicBSpline(), 1, "clamped") == 19
    assert c(10, js.FourPoint(), 1, "clamped") == 19
    assert c(10, js.FourPoint(), 1, "open") == 15
    assert c(10, js.Chaikin(), 1, "clamped") == 20
    assert c(10, js.LaneRiesenfeld(5), 1, "open") == 15
    assert c(10, js.Chaikin(), 3) == 80


def test_clamped_cubic_one_level_by_hand():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    expected = [[0, 0], [0.5, 0], [0.875, 0.125], [1, 0.5], [0.875, 0.875], [0.5, 1], [0, 1]]
    np.testing.assert_allclose(js.refine(P, js.CubicBSpline(), 1, boundary="clamped"), expected)


def test_clamped_four_point_one_level_by_hand():
    P = np.array([[0.0, 0.0], [1.0, 2.0], [3.0, 3.0], [4.0, 1.0]])
    w = 1 / 16
    ghost0, ghost3 = P[0], P[3]  # the classic rule repeats the end points
    e0 = (0.5 + w) * (P[0] + P[1]) - w * (ghost0 + P[2])
    e1 = (0.5 + w) * (P[1] + P[2]) - w * (P[0] + P[3])
    e2 = (0.5 + w) * (P[2] + P[3]) - w * (P[1] + ghost3)
    expected = [P[0], e0, P[1], e1, P[2], e2, P[3]]
    np.testing.assert_allclose(js.refine(P, js.FourPoint(w), 1, boundary="clamped"), expected)


@pytest.mark.parametrize("name,scheme", schemes_with("clamped"), ids=ids(schemes_with("clamped")))
def test_clamped_interpolates_ends(name, scheme):
    P = polygon(7)
    for levels in (1, 2, 4):
        Q = np.asarray(js.refine(P, scheme, levels, boundary="clamped"))
        assert len(Q) == js.refined_count(7, scheme, levels, "clamped")
        np.testing.assert_array_equal(Q[0], P[0])
        np.testing.assert_array_equal(Q[-1], P[-1])


@pytest.mark.parametrize("name,scheme", schemes_with("clamped"), ids=ids(schemes_with("clamped")))
def test_creases_are_sharp_points(name, scheme):
    P = polygon(9)
    creases = [2, 6]
    for boundary in ("closed", "clamped"):
        Q = np.asarray(js.refine(P, scheme, 3, boundary=boundary, creases=creases))
        assert len(Q) == js.refined_count(9, scheme, 3, boundary, creases=creases)
        for c in creases:
            assert np.any(np.all(Q == P[c], axis=1)), f"crease {c} not on the curve"
    # A closed curve with creases is the clamped pieces between them, joined.
    Q = np.asarray(js.refine(P, scheme, 2, creases=creases))
    piece1 = np.asarray(js.refine(P[2:7], scheme, 2, boundary="clamped"))
    piece2 = np.asarray(js.refine(P[[6, 7, 8, 0, 1, 2]], scheme, 2, boundary="clamped"))
    np.testing.assert_allclose(Q, np.vstack([piece1, piece2[1:-1]]), atol=1e-15)


# --------------------------------------------------------------------------------------
# Symmetries


@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
@pytest.mark.parametrize("name,scheme", all_schemes(), ids=ids(all_schemes()))
def test_affine_invariance(name, scheme, boundary):
    if boundary == "clamped" and scheme.clamp_ghost is None:
        pytest.skip("no clamped rule")
    P = polygon(8, d=3)
    A = np.array([[1.0, 2.0, 0.5], [-0.3, 1.0, 0.0], [0.2, 0.1, 3.0]])
    b = np.array([5.0, -1.0, 2.0])
    Q = np.asarray(js.refine(P, scheme, 3, boundary=boundary))
    QA = np.asarray(js.refine(P @ A + b, scheme, 3, boundary=boundary))
    np.testing.assert_allclose(QA, Q @ A + b, atol=1e-12)


@pytest.mark.parametrize("name,scheme", all_schemes(), ids=ids(all_schemes()))
def test_cyclic_shift_equivariance(name, scheme):
    P = polygon(8)
    levels = 3
    Q = np.asarray(js.refine(P, scheme, levels))
    Qs = np.asarray(js.refine(np.roll(P, 3, axis=0), scheme, levels))
    np.testing.assert_allclose(Qs, np.roll(Q, 3 * 2**levels, axis=0), atol=1e-14)


# Masks symmetric about their center (corner cutting only when r + s = 1).
symmetric = [(n, s) for n, s in all_schemes() if n not in ("daubechies", "corner_cutting")]


@pytest.mark.parametrize("name,scheme", symmetric, ids=ids(symmetric))
def test_reversal_symmetry(name, scheme):
    P = polygon(8)
    levels = 3
    n, N = 8, 8 * 2**levels
    c = scheme.center
    Q = np.asarray(js.refine(P, scheme, levels))
    Qr = np.asarray(js.refine(P[::-1], scheme, levels))
    # With a symmetric mask a_k = a_{2c-k}: Q'_K = Q_{2^k (n-1) + 2c(2^k - 1) - K}.
    K = np.arange(N)
    index = (2**levels * (n - 1) + int(2 * c * (2**levels - 1)) - K) % N
    np.testing.assert_allclose(Qr, Q[index], atol=1e-14)
    for boundary in ("open", "clamped"):
        if boundary == "clamped" and scheme.clamp_ghost is None:
            continue
        Q = np.asarray(js.refine(P, scheme, levels, boundary=boundary))
        Qr = np.asarray(js.refine(P[::-1], scheme, levels, boundary=boundary))
        np.testing.assert_allclose(Qr, Q[::-1], atol=1e-14)


def test_daubechies_is_not_symmetric():
    P = polygon(8)
    Q = np.asarray(js.refine(P, js.Daubechies(), 2, boundary="open"))
    Qr = np.asarray(js.refine(P[::-1], js.Daubechies(), 2, boundary="open"))
    assert np.abs(Qr - Q[::-1]).max() > 1e-3


# --------------------------------------------------------------------------------------
# The subdivision matrix


@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
@pytest.mark.parametrize("name,scheme", all_schemes(), ids=ids(all_schemes()))
def test_subdivision_matrix(name, scheme, boundary):
    if boundary == "clamped" and scheme.clamp_ghost is None:
        pytest.skip("no clamped rule")
    P = polygon(8)
    S = np.asarray(js.subdivision_matrix(8, scheme, 3, boundary))
    np.testing.assert_allclose(S @ P, js.refine(P, scheme, 3, boundary=boundary), atol=1e-13)
    # Rows sum to one: constants are reproduced (affine invariance), independently of P.
    np.testing.assert_allclose(S.sum(axis=1), 1.0, atol=1e-13)


def test_subdivision_matrix_single_level_is_the_mask():
    # Closed Chaikin, one level, n = 5: row 2i = 3/4 e_i + 1/4 e_{i+1}, row 2i+1 the mirror.
    S = np.asarray(js.subdivision_matrix(5, js.Chaikin(), 1))
    expected = np.zeros((10, 5))
    for i in range(5):
        expected[2 * i, [i, (i + 1) % 5]] = [0.75, 0.25]
        expected[2 * i + 1, [i, (i + 1) % 5]] = [0.25, 0.75]
    np.testing.assert_array_equal(S, expected)


# --------------------------------------------------------------------------------------
# Differentiation


def central_difference(f, x, step):
    return (f(x + step) - f(x - step)) / (2 * step)


@pytest.mark.parametrize("name,make,value", parametrised_schemes, ids=ids(parametrised_schemes))
@pytest.mark.parametrize("boundary", ["closed", "open"])
def test_gradient_in_scheme_parameter(name, make, value, boundary):
    P = jnp.asarray(polygon(7))
    weights = jnp.asarray(np.random.default_rng(1).standard_normal((200, 2)))

    def loss(x):
        Q = js.refine(P, make(x), 3, boundary=boundary)
        return jnp.sum(jnp.sin(Q) * weights[: Q.shape[0]])

    fd = central_difference(lambda x: float(loss(x)), value, 1e-6)
    x = jnp.asarray(value)
    np.testing.assert_allclose(jax.grad(loss)(x), fd, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(jax.jacfwd(loss)(x), fd, rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
def test_gradient_in_points(boundary):
    P = jnp.asarray(polygon(6))
    scheme = js.FourPoint(0.1)

    def loss(P):
        return jnp.sum(js.refine(P, scheme, 3, boundary=boundary) ** 3)

    g = np.asarray(jax.grad(loss)(P))
    for i, k in [(0, 0), (2, 1), (5, 0)]:
        e = jnp.zeros_like(P).at[i, k].set(1.0)
        fd = central_difference(lambda t: float(loss(P + t * e)), 0.0, 1e-6)
        np.testing.assert_allclose(g[i, k], fd, rtol=1e-7, atol=1e-8)
    # jacrev and jacfwd of the (linear) map agree with the subdivision matrix.
    S = np.asarray(js.subdivision_matrix(6, scheme, 3, boundary))
    J = jax.jacrev(lambda P: js.refine(P, scheme, 3, boundary=boundary)[:, 0])(P)[:, :, 0]
    np.testing.assert_allclose(J, S, atol=1e-14)
    J = jax.jacfwd(lambda P: js.refine(P, scheme, 3, boundary=boundary)[:, 1])(P)[:, :, 1]
    np.testing.assert_allclose(J, S, atol=1e-14)


# --------------------------------------------------------------------------------------
# Transformations: jit, vmap, batch axes, dtypes


@pytest.mark.parametrize("name,scheme", all_schemes(), ids=ids(all_schemes()))
def test_jit_equals_eager(name, scheme):
    P = jnp.asarray(polygon(8))
    jitted = jax.jit(lambda P, s: js.refine(P, s, 3))(P, scheme)
    with jax.disable_jit():
        eager = js.refine(P, scheme, 3)
    np.testing.assert_allclose(jitted, eager, atol=1e-14)


def test_vmap_over_points_equals_loop_and_batch_axes():
    batch = jnp.asarray(np.stack([polygon(8, seed=s) for s in range(6)]).reshape(2, 3, 8, 2))
    scheme = js.CornerCutting(0.2, 0.7)
    looped = np.stack([[js.refine(p, scheme, 3) for p in row] for row in batch])
    np.testing.assert_allclose(js.refine(batch, scheme, 3), looped, atol=1e-15)
    vmapped = jax.vmap(jax.vmap(lambda p: js.refine(p, scheme, 3)))(batch)
    np.testing.assert_allclose(vmapped, looped, atol=1e-15)


def test_vmap_over_parameter_values():
    P = jnp.asarray(polygon(8))
    ws = jnp.linspace(-0.2, 0.2, 200)
    out = jax.vmap(lambda w: js.refine(P, js.FourPoint(w), 4))(ws)
    assert out.shape == (200, 128, 2)
    for i in (0, 77, 199):
        np.testing.assert_allclose(out[i], js.refine(P, js.FourPoint(float(ws[i])), 4), atol=1e-14)
    # A scheme holding a batch of parameters can be vmapped over directly.
    schemes = js.CornerCutting(jnp.full(5, 0.2), jnp.linspace(0.3, 0.9, 5))
    out = jax.vmap(lambda s: js.refine(P, s, 2))(schemes)
    np.testing.assert_allclose(out[3], js.refine(P, js.CornerCutting(0.2, 0.75), 2), atol=1e-14)


@pytest.mark.parametrize("boundary", ["closed", "open", "clamped"])
def test_float32_and_float64(boundary):
    P = polygon(9)
    scheme = js.SplitTweak(0.3)
    out64 = js.refine(jnp.asarray(P, jnp.float64), scheme, 4, boundary=boundary)
    out32 = js.refine(jnp.asarray(P, jnp.float32), scheme, 4, boundary=boundary)
    assert out64.dtype == jnp.float64 and out32.dtype == jnp.float32
    np.testing.assert_allclose(out32, out64, rtol=0, atol=1e-6)
    grad = jax.grad(lambda t: js.refine(jnp.asarray(P, jnp.float32), js.SplitTweak(t), 2).sum())
    assert jnp.isfinite(grad(jnp.float32(0.3)))


def test_integer_points_are_promoted_not_truncated():
    P = np.array([[0, 0], [3, 0], [3, 3], [0, 3]])
    out = js.refine(P, js.Chaikin(), 1)
    assert jnp.issubdtype(out.dtype, jnp.floating)
    np.testing.assert_allclose(out[0], [0.75, 0.0])


def test_any_number_of_coordinates():
    for d in (1, 3, 7):
        P = polygon(6, d=max(d, 2))[:, :d]
        out = js.refine(P, js.CubicBSpline(), 2)
        expected = refine_by_definition(P, js.CubicBSpline().mask(), -2, 2, "closed")
        np.testing.assert_allclose(out, expected, atol=1e-14)


def test_no_recompilation_for_new_values(monkeypatch):
    # The kernel's Python body runs only while tracing, so count its calls.
    traces = []
    original = js._refine.apply_periodic
    monkeypatch.setattr(js._refine, "apply_periodic", lambda *a: traces.append(1) or original(*a))
    P = polygon(13)
    js.refine(P, js.FourPoint(0.05), 3)
    assert len(traces) == 1
    js.refine(P + 1.0, js.FourPoint(0.1), 3)
    js.refine(P * 2.0, js.FourPoint(-0.1), 3)
    assert len(traces) == 1
    js.refine(P, js.FourPoint(0.1), 4)  # a new number of levels is a new compilation
    assert len(traces) == 2


# --------------------------------------------------------------------------------------
# Bad input


@pytest.mark.parametrize(
    "kwargs, error, words",
    [
        (dict(points=np.zeros(5)), ValueError, "shape (..., n, d)"),
        (dict(levels=-1), ValueError, "levels"),
        (dict(levels=1.5), TypeError, "levels"),
        (dict(boundary="periodic"), ValueError, "boundary"),
        (dict(scheme="chaikin"), TypeError, "scheme"),
        (dict(points=np.zeros((2, 2))), ValueError, "at least 3 control points"),
        (dict(scheme=js.Daubechies(), boundary="clamped"), ValueError, "no clamped"),
        (dict(boundary="open", creases=[2]), ValueError, "creases"),
        (dict(creases=[9]), ValueError, "creases"),
        (dict(creases=[1.5]), TypeError, "creases"),
        (dict(levels=40), ValueError, "memory_budget"),
    ],
)
def test_bad_input_is_a_clear_error(kwargs, error, words):
    args = dict(points=polygon(6), scheme=js.Chaikin(), levels=2)
    args.update(kwargs)
    with pytest.raises(error, match=None) as info:
        js.refine(args.pop("points"), args.pop("scheme"), args.pop("levels"), **args)
    assert words in str(info.value)


def test_memory_budget_is_configurable_and_states_size():
    P = polygon(16)
    with pytest.raises(ValueError, match=r"1,048,576 points x 2 coordinates"):
        js.refine(P, js.Chaikin(), 16, memory_budget=1024)
    assert js.refine(P, js.Chaikin(), 5, memory_budget=10**6).shape == (512, 2)


def test_open_needs_enough_points():
    with pytest.raises(ValueError, match="at least 5 control points"):
        js.refine(polygon(4), js.FourPoint(), 1, boundary="open")


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: js.CornerCutting(0.6, 0.4), "0 < r < s < 1"),
        (lambda: js.CornerCutting(0.0, 0.5), "0 < r < s < 1"),
        (lambda: js.FourPoint(float("nan")), "finite"),
        (lambda: js.SplitTweak(float("inf")), "finite"),
        (lambda: js.LaneRiesenfeld(0), "degree"),
        (lambda: js.LaneRiesenfeld(2.5), "degree"),
        (lambda: js.MaskScheme([0.5, 0.5, 0.5, 0.6], -2), "sum to 1"),
        (lambda: js.MaskScheme([[0.5, 0.5]], 0), "1-D"),
    ],
)
def test_bad_parameters_concrete(make, words):
    with pytest.raises((ValueError, TypeError), match=None) as info:
        make()
    assert words in str(info.value)


def test_bad_parameters_traced_raise_at_run_time():
    P = jnp.asarray(polygon(6))
    f = eqx.filter_jit(lambda w: js.refine(P, js.FourPoint(w), 2))
    assert f(0.1).shape == (24, 2)
    assert f(0.3).shape == (24, 2)  # any finite w (traced: no divergence warning)
    with pytest.raises(eqx.EquinoxRuntimeError, match="finite"):
        f(float("nan")).block_until_ready()
    g = eqx.filter_jit(lambda r, s: js.refine(P, js.CornerCutting(r, s), 2))
    with pytest.raises(eqx.EquinoxRuntimeError, match="0 < r < s < 1"):
        g(0.7, 0.2).block_until_ready()


def test_batched_scheme_without_vmap_is_a_clear_error():
    with pytest.raises(ValueError, match="vmap"):
        js.refine(polygon(6), js.FourPoint(jnp.array([0.0, 0.1])), 2)


# --------------------------------------------------------------------------------------
# Hostile input and resource bounds (#17): one clear error, before allocating


def _budget_cases():
    P = polygon(8)
    cases = []
    for value, error in [(float("nan"), ValueError), (float("inf"), ValueError),
                         (0, ValueError), (-1.0, ValueError), (2**61, ValueError),
                         ("1e9", TypeError), (None, TypeError), (True, TypeError),
                         (1e9 + 1j, TypeError)]:  # fmt: skip
        cases.append((f"refine_budget_{value!r}",
                      lambda v=value: js.refine(P, js.Chaikin(), 2, memory_budget=v),
                      error, ["memory_budget"]))  # fmt: skip
        cases.append((f"matrix_budget_{value!r}",
                      lambda v=value: js.subdivision_matrix(8, js.Chaikin(), 2, memory_budget=v),
                      error, ["memory_budget"]))  # fmt: skip
    return cases


# (id, call, error type, words the message must contain)
HOSTILE = [
    ("lane_riesenfeld_56", lambda: js.LaneRiesenfeld(56), ValueError,
     ["LaneRiesenfeld(degree)", "<= 55", "float64"]),
    ("lane_riesenfeld_100000", lambda: js.LaneRiesenfeld(100_000), ValueError,
     ["LaneRiesenfeld(degree)", "<= 55"]),
    ("clamped_1e6_levels", lambda: js.refine(polygon(8), js.Chaikin(), 10**6, boundary="clamped"),
     ValueError, ["2^1000000 points", "memory_budget", "at most 22 levels"]),
    ("closed_14000_levels", lambda: js.refine(polygon(8), js.Chaikin(), 14_000), ValueError,
     ["2^14000 points", "memory_budget"]),
    ("open_1e6_levels", lambda: js.refine(polygon(8), js.Chaikin(), 10**6, boundary="open"),
     ValueError, ["memory_budget", "levels"]),
    # Two points stay two points (n -> 2(n - 1)), but the composite mask's table has
    # 2^40 rows: the budget counts it.
    ("open_fixed_point_40_levels",
     lambda: js.refine(polygon(2), js.Chaikin(), 40, boundary="open"), ValueError,
     ["2 points x 2 coordinates", "working arrays", "memory_budget"]),
    ("batch_of_curves",  # a broadcast view: nothing allocated
     lambda: js.refine(np.broadcast_to(polygon(8), (10**6, 8, 2)), js.Chaikin(), 10),
     ValueError, ["x 1,000,000 curves", "memory_budget"]),
    ("refined_count_too_few_points", lambda: js.refined_count(2, js.CubicBSpline(), 3, "open"),
     ValueError, ["CubicBSpline", "at least 3 control points", "n=2"]),
    ("refined_count_huge_levels", lambda: js.refined_count(8, js.Chaikin(), 10**6), ValueError,
     ["levels", "10,000"]),
    ("subdivision_matrix_100000", lambda: js.subdivision_matrix(100_000, js.Chaikin(), 3),
     ValueError, ["subdivision_matrix", "100000 coordinates", "memory_budget"]),
    ("four_point_complex", lambda: js.FourPoint(0.05 + 1j), TypeError,
     ["FourPoint(w)", "must be real", "imaginary"]),
    ("corner_cutting_complex_r", lambda: js.CornerCutting(0.2 + 1j, 0.5), TypeError,
     ["CornerCutting(r)", "must be real"]),
    ("corner_cutting_complex_s", lambda: js.CornerCutting(0.2, 0.5 + 0.1j), TypeError,
     ["CornerCutting(s)", "must be real"]),
    ("split_tweak_complex", lambda: js.SplitTweak(np.complex128(0.5)), TypeError,
     ["SplitTweak(t)", "must be real"]),
    ("mask_complex", lambda: js.MaskScheme([0.25 + 0j, 0.75, 0.75, 0.25j], -2), TypeError,
     ["MaskScheme(coefficients)", "must be real"]),
    ("from_rules_complex", lambda: js.MaskScheme.from_rules([0.75j, 0.25], [0.25, 0.75], 0, 0),
     TypeError, ["MaskScheme(coefficients)", "must be real"]),
    ("four_point_string", lambda: js.FourPoint("0.1"), TypeError, ["FourPoint(w)"]),
    ("split_tweak_none", lambda: js.SplitTweak(None), TypeError, ["SplitTweak(t)"]),
    ("four_point_complex_traced", lambda: jax.jit(lambda w: js.FourPoint(w).w)(0.05 + 1j),
     TypeError, ["FourPoint(w)", "must be real"]),
    # Integers past Python's 4,300-digit limit for str(): named, not that limit's message.
    ("lane_riesenfeld_5001_digits", lambda: js.LaneRiesenfeld(10**5000), ValueError,
     ["LaneRiesenfeld(degree)", "64-bit integer", "5001 digits"]),
    ("refine_5001_digit_levels", lambda: js.refine(polygon(8), js.Chaikin(), 10**5000),
     ValueError, ["`levels`", "64-bit integer"]),
    ("budget_401_digits", lambda: js.refine(polygon(8), js.Chaikin(), 1, memory_budget=10**400),
     ValueError, ["memory_budget", "at most 2^60", "401 digits"]),
    *_budget_cases(),
]  # fmt: skip


@pytest.mark.parametrize("call, error, words", [c[1:] for c in HOSTILE], ids=ids(HOSTILE))
def test_hostile_input_is_one_clear_error(call, error, words):
    assert_one_clear_error(call, error, words)


def test_subdivision_matrix_checks_the_budget_before_building_the_identity(monkeypatch):
    def eye(*args, **kwargs):
        raise AssertionError("the identity was built before the budget check")

    monkeypatch.setattr(jnp, "eye", eye)
    with pytest.raises(ValueError, match="memory_budget"):
        js.subdivision_matrix(100_000, js.Chaikin(), 3)


def test_budget_just_inside_the_bound_works():
    # The error names the most levels that fit; those levels then run under that budget.
    P, budget = polygon(16), 10**6
    with pytest.raises(ValueError, match=r"at most (\d+) levels") as info:
        js.refine(P, js.Chaikin(), 30, memory_budget=budget)
    most = int(re.search(r"at most (\d+) levels", str(info.value)).group(1))
    assert js.refine(P, js.Chaikin(), most, memory_budget=budget).shape == (16 * 2**most, 2)
    with pytest.raises(ValueError, match="memory_budget"):
        js.refine(P, js.Chaikin(), most + 1, memory_budget=budget)
    assert js.subdivision_matrix(8, js.Chaikin(), 2, memory_budget=np.float64(1e6)).shape == (32, 8)
    assert js.refine(P, js.Chaikin(), 1, memory_budget=2**60).shape == (32, 2)  # the largest


def test_lane_riesenfeld_at_the_largest_degree():
    scheme = js.LaneRiesenfeld(55)
    mask = np.asarray(scheme.mask())
    expected = np.array([math.comb(56, k) / 2**55 for k in range(57)])
    np.testing.assert_array_equal(mask, expected)  # exact in float64
    np.testing.assert_array_equal(scheme.host_mask(), expected)
    assert mask[0::2].sum() == mask[1::2].sum() == 1.0
    P = polygon(12)
    out = js.refine(P, scheme, 1)
    reference = refine_by_definition(P, mask, scheme.mask_start, 1, "closed")
    np.testing.assert_allclose(out, reference, atol=1e-12)
    # Degrees 31 and 63 overflowed int32/int64 binomials; 31 is now an ordinary mask.
    assert np.isclose(float(np.sum(js.LaneRiesenfeld(31).mask())), 2.0)


@pytest.mark.parametrize("name, scheme", all_schemes(), ids=[s[0] for s in all_schemes()])
@pytest.mark.parametrize("boundary", ["open", "clamped"])
def test_closed_form_counts_match_level_by_level_counts(name, scheme, boundary):
    if boundary == "clamped" and scheme.clamp_ghost is None:
        pytest.skip("no clamped rule")
    n0 = js.min_points(scheme, boundary)
    for n in (n0, n0 + 1, n0 + 5):
        count = n
        for levels in range(6):
            assert js.refined_count(n, scheme, levels, boundary) == count
            if boundary == "open":
                count = js._kernel.open_run(count, scheme.mask_start, scheme.mask_length)[1]
            else:
                count = js._kernel.clamped_count(count, scheme.center)
    # Thousands of levels are a few integer operations (the old loop took minutes).
    assert js.refined_count(8, scheme, 10_000, boundary) > 2**10_000
