"""Properties of refinement over random schemes, polygons and boundaries (hypothesis).

Every built-in curve scheme with parameters drawn from its valid range (and random
`MaskScheme`s whose two sub-masks each sum to one), closed/open/clamped curves, point
counts and dimensions:

- affine invariance, `refine(P A^T + b) == refine(P) A^T + b` (the sub-masks sum to one);
- reversal: for a symmetric mask, refining the reversed polygon gives the reversed
  refinement, on closed curves up to the cyclic shift derived below;
- linearity: `refine(P, L) == S @ P` for the matrix `S` built here by a plain NumPy
  convolution of the mask (`Q_K = sum_j a_{K-2j} P_j`, level by level), which is also
  what `subdivision_matrix` must return;
- round trips through `jaxsubdiv.io`: outlines through CSV, JSON, NPY and NPZ, and a
  scheme with its control points through the result JSON.

To keep the number of compiled programs small, point counts come from (8, 13),
dimensions from (2, 3) and levels from (1, 2); the examples are derandomized.
"""

import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import jaxsubdiv as js
import jaxsubdiv.io as jio


PROPERTY = settings(max_examples=25, deadline=None, derandomize=True)

counts = st.sampled_from([8, 13])
dims = st.sampled_from([2, 3])
levels_ = st.sampled_from([1, 2])
seeds = st.integers(0, 2**32 - 1)

# Parameters strictly inside their ranges, away from the ends by a margin the checks
# accept in float32 as well.
four_point = st.floats(-0.249, 0.249).map(js.FourPoint)
corner_cutting = st.tuples(st.floats(0.01, 0.97), st.floats(0.01, 0.99)).map(
    lambda rs: js.CornerCutting(rs[0], rs[0] + (1 - rs[0]) * rs[1] * 0.98 + 0.001)
)
split_tweak = st.floats(0.0, 1.0).map(js.SplitTweak)
lane_riesenfeld = st.integers(1, 6).map(js.LaneRiesenfeld)
fixed = st.sampled_from([js.Chaikin(), js.CubicBSpline(), js.Daubechies(), js.Jarek()])


def _normalised(mask: np.ndarray) -> np.ndarray:
    """Scale the even- and odd-position coefficients to sum to one each."""
    mask = mask.copy()
    mask[0::2] /= mask[0::2].sum()
    mask[1::2] /= mask[1::2].sum()
    return mask


@st.composite
def random_masks(draw, symmetric=False):
    """A `MaskScheme` of 3 to 7 coefficients: 1/k per sub-mask of k coefficients plus
    a perturbation of at most 0.2 each, so each sum stays above 0.2 before scaling. A
    symmetric one mirrors its first half (each sub-mask keeps the symmetry, or the two
    are mirror images with equal sums, so the scaling keeps it)."""
    length = draw(st.integers(3, 7))
    start = draw(st.integers(-length + 1, 0))
    wiggle = st.floats(-0.2, 0.2)
    if symmetric:
        half = draw(st.lists(wiggle, min_size=(length + 1) // 2, max_size=(length + 1) // 2))
        perturbation = np.array(half + half[: length // 2][::-1])
    else:
        perturbation = np.array(draw(st.lists(wiggle, min_size=length, max_size=length)))
    base = np.empty(length)
    base[0::2] = 1 / len(base[0::2])
    base[1::2] = 1 / len(base[1::2])
    return js.MaskScheme(_normalised(base + perturbation), start)


any_scheme = st.one_of(
    four_point, corner_cutting, split_tweak, lane_riesenfeld, fixed, random_masks()
)
symmetric_scheme = st.one_of(
    four_point,
    st.floats(0.01, 0.49).map(lambda r: js.CornerCutting(r, 1 - r)),
    split_tweak,
    lane_riesenfeld,
    st.sampled_from([js.Chaikin(), js.CubicBSpline(), js.Jarek()]),
    random_masks(symmetric=True),
)


# The classes `any_scheme` draws; a scheme added to the registry needs a strategy here.
DRAWN = {js.FourPoint, js.CornerCutting, js.SplitTweak, js.LaneRiesenfeld, js.Chaikin,
         js.CubicBSpline, js.Daubechies, js.Jarek, js.MaskScheme}  # fmt: skip


def test_every_registered_scheme_is_drawn():
    if not hasattr(js, "schemes"):
        pytest.skip("no scheme registry (`jaxsubdiv.schemes`) in this version")
    registered = {info.cls for info in js.schemes().values()}
    assert registered <= DRAWN, f"add a strategy for {registered - DRAWN} to this file"


@st.composite
def boundaries(draw, scheme):
    return draw(st.sampled_from(["closed", "open", "clamped"] if scheme.clamp_ghost else
                                ["closed", "open"]))


def _host_mask(scheme) -> tuple[np.ndarray, int]:
    return np.asarray(scheme.mask(), dtype=np.float64), scheme.mask_start


def _polygon(seed: int, n: int, d: int) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(n, d))


def _close(actual, expected, scale=1.0):
    np.testing.assert_allclose(np.asarray(actual), expected, rtol=0, atol=1e-10 * scale)


# ----------------------------------------------------------- the reference convolution


def _closed_level(n: int, mask: np.ndarray, start: int) -> np.ndarray:
    """One closed level, (2n, n): Q_K = sum_j a_{K-2j} P_{j mod n}, K = 0..2n-1."""
    matrix = np.zeros((2 * n, n))
    for K in range(2 * n):
        for i, a in enumerate(mask):
            if (K - start - i) % 2 == 0:
                matrix[K, ((K - start - i) // 2) % n] += a
    return matrix


def _open_level(n: int, mask: np.ndarray, start: int) -> np.ndarray:
    """One open level: the rows K (increasing) whose every mask index k has its point
    j = (K - k)/2 inside 0..n-1 (the whole stencil lies inside the polygon)."""
    rows = []
    for K in range(start, start + len(mask) + 2 * (n - 1)):
        row, inside = np.zeros(n), True
        for i, a in enumerate(mask):
            if (K - start - i) % 2 == 0:
                j = (K - start - i) // 2
                inside &= 0 <= j < n
                if 0 <= j < n:
                    row[j] += a
        if inside:
            rows.append(row)
    return np.array(rows).reshape(-1, n)


def reference_matrix(n: int, scheme, levels: int, boundary: str) -> np.ndarray:
    mask, start = _host_mask(scheme)
    level = _closed_level if boundary == "closed" else _open_level
    matrix = np.eye(n)
    for _ in range(levels):
        matrix = level(matrix.shape[0], mask, start) @ matrix
    return matrix


def test_reference_convolution_on_known_matrices():
    """The reference itself, on matrices written out by hand: Chaikin's closed level
    (3/4, 1/4 on each edge) and the open cubic B-spline on 4 points (n -> 2n - 3)."""
    chaikin = reference_matrix(3, js.Chaikin(), 1, "closed")
    expected = np.array([[3, 1, 0], [1, 3, 0], [0, 3, 1], [0, 1, 3], [1, 0, 3], [3, 0, 1]]) / 4
    np.testing.assert_allclose(chaikin, expected, atol=1e-15)
    cubic = reference_matrix(4, js.CubicBSpline(), 1, "open")
    expected = np.array([[4, 4, 0, 0], [1, 6, 1, 0], [0, 4, 4, 0], [0, 1, 6, 1], [0, 0, 4, 4]]) / 8
    np.testing.assert_allclose(cubic, expected, atol=1e-15)


# ------------------------------------------------------------------------- properties


@PROPERTY
@given(data=st.data(), scheme=any_scheme, n=counts, d=dims, levels=levels_, seed=seeds)
def test_refinement_is_affine_invariant(data, scheme, n, d, levels, seed):
    boundary = data.draw(boundaries(scheme))
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(n, d))
    linear = rng.normal(size=(d, d))
    shift = rng.normal(size=d) * 10
    both = js.refine(np.stack([points, points @ linear.T + shift]), scheme, levels,
                     boundary=boundary)
    refined, moved = np.asarray(both[0]), np.asarray(both[1])
    _close(moved, refined @ linear.T + shift, scale=100)


@PROPERTY
@given(data=st.data(), scheme=symmetric_scheme, n=counts, d=dims, levels=levels_,
       seed=seeds)
def test_reversed_polygon_refines_to_the_reversed_curve(data, scheme, n, d, levels, seed):
    """A symmetric mask, a_k = a_{2c-k} (c the centre), gives after L levels, with the
    composite mask A (centre c_L = c (2^L - 1)) and Q_K = sum_j A_{K - 2^L j} P_j, for
    the reversed polygon P'_j = P_{n-1-j}:
        Q'_K = sum_i A_{K - 2^L (n-1-i)} P_i = sum_i A_{2 c_L - K + 2^L (n-1) - 2^L i} P_i
             = Q_{2 c_L + 2^L (n-1) - K},
    indices modulo N = 2^L n. The reversed refinement is R_m = Q_{N-1-m}, so
    Q'_K = R_{K - s} with s = 2 c_L - 2^L + 1 = (2c - 1)(2^L - 1): a cyclic shift by s.
    Open and clamped curves keep a run symmetric about the polygon's middle: no shift."""
    mask, start = _host_mask(scheme)
    np.testing.assert_allclose(mask, mask[::-1], atol=1e-12)  # the drawn scheme is symmetric
    boundary = data.draw(boundaries(scheme))
    points = _polygon(seed, n, d)
    both = np.asarray(js.refine(np.stack([points, points[::-1]]), scheme, levels,
                                boundary=boundary))
    refined, of_reversed = both[0], both[1]
    expected = refined[::-1]
    if boundary == "closed":
        twice_centre = 2 * start + len(mask) - 1  # 2c, an integer
        shift = (twice_centre - 1) * (2**levels - 1)
        expected = np.roll(expected, shift, axis=0)
    _close(of_reversed, expected, scale=10)


@PROPERTY
@given(data=st.data(), scheme=any_scheme, n=counts, d=dims, levels=levels_, seed=seeds)
def test_refine_is_the_convolution_matrix(data, scheme, n, d, levels, seed):
    boundary = data.draw(st.sampled_from(["closed", "open"]))
    matrix = reference_matrix(n, scheme, levels, boundary)
    assert matrix.shape[0] == js.refined_count(n, scheme, levels, boundary)
    points = _polygon(seed, n, d)
    _close(js.refine(points, scheme, levels, boundary=boundary), matrix @ points, scale=10)
    _close(js.subdivision_matrix(n, scheme, levels, boundary), matrix)


# ------------------------------------------------------------------------ round trips

outline_points = st.tuples(counts, seeds, st.sampled_from([1.0, 1e-7, 1e9])).map(
    lambda t: np.random.default_rng(t[1]).normal(size=(t[0], 2)) * t[2]
)
outlines = st.lists(st.tuples(outline_points, st.booleans()), min_size=1, max_size=3)


@PROPERTY
@given(items=outlines, kind=st.sampled_from(["csv", "json", "npz", "npy"]))
def test_outlines_round_trip_through_files(items, kind):
    if kind == "npy":  # one closed outline per file
        items = items[:1]
        items = [(items[0][0], True)]
    written = [jio.Outline(points, closed) for points, closed in items]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"outlines.{kind}"
        jio.write_outlines(path, written)
        read = jio.read_outlines(path)
    assert len(read) == len(written)
    for got, sent in zip(read, written):
        assert got.closed == sent.closed
        np.testing.assert_array_equal(got.points, sent.points)  # bit for bit


@PROPERTY
@given(scheme=any_scheme, n=counts, d=dims, seed=seeds, levels=st.none() | levels_,
       boundary=st.sampled_from(["closed", "open"]))
def test_scheme_and_control_points_round_trip_through_result_json(
    scheme, n, d, seed, levels, boundary
):
    points = _polygon(seed, n, d)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "result.json"
        jio.write_result_json(path, {"control_points": points, "scheme": scheme,
                                     "boundary": boundary, "levels": levels})
        saved = jio.read_result_json(path)
    assert type(saved.scheme) is type(scheme)
    assert saved.scheme.mask_start == scheme.mask_start
    np.testing.assert_array_equal(np.asarray(saved.scheme.mask()), np.asarray(scheme.mask()))
    np.testing.assert_array_equal(saved.control_points, points)
    assert (saved.boundary, saved.levels) == (boundary, levels)
