"""jaxsubdiv.shapes: the built-in control polygons."""

import numpy as np
import pytest

import jaxsubdiv as js


SEED_PAPER = ["jar", "mango", "pi", "car", "rabbit", "hand", "U", "mug"]


def _crossings(polygon):
    """Pairs of non-adjacent edges of a closed polygon that intersect (orientation test)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    n = len(polygon)

    def side(p, q, r):  # sign of the turn p -> q -> r, for every edge pair
        return np.sign(
            (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1])
            - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])
        )

    A, B = a[:, None], b[:, None]
    C, D = a[None, :], b[None, :]
    s1, s2, s3, s4 = side(A, B, C), side(A, B, D), side(C, D, A), side(C, D, B)
    cross = (s1 * s2 <= 0) & (s3 * s4 <= 0)
    # Collinear edges (all four turns zero) meet only if their extents overlap.
    collinear = (s1 == 0) & (s2 == 0) & (s3 == 0) & (s4 == 0)
    overlap = np.all(
        (np.maximum(A, B) >= np.minimum(C, D)) & (np.maximum(C, D) >= np.minimum(A, B)), axis=-1
    )
    cross = np.where(collinear, overlap, cross)
    i, j = np.triu_indices(n, k=2)
    adjacent = (j - i) % n == n - 1  # first and last edge share a vertex
    keep = ~adjacent
    return list(zip(i[keep][cross[i, j][keep]], j[keep][cross[i, j][keep]]))


def _signed_area(p):
    return 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - p[:, 1] * np.roll(p[:, 0], -1))


def test_crossing_detector():
    # Independent check of the helper: a bow tie crosses itself, a square does not.
    assert _crossings(np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]])) == [(0, 2)]
    assert _crossings(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])) == []
    # A "U" has two collinear top edges that do not meet; a doubled-back edge does.
    u = np.array([[0, 0], [3, 0], [3, 1], [2, 1], [2, 0.5], [1, 0.5], [1, 1], [0, 1]], float)
    assert _crossings(u) == []
    assert _crossings(np.array([[0, 0], [2, 0], [1, 0], [1, 1]], float)) != []


def test_names():
    names = js.shapes.names()
    assert names == sorted(names)
    assert set(SEED_PAPER) | {"star", "square"} <= set(names)


@pytest.mark.parametrize("name", js.shapes.names())
def test_shape_is_a_simple_closed_polygon(name):
    polygon = js.shapes.get(name)
    assert polygon.dtype == np.float64 and polygon.ndim == 2 and polygon.shape[1] == 2
    assert 4 <= len(polygon) <= 40
    assert np.all(np.isfinite(polygon))
    assert not np.array_equal(polygon[0], polygon[-1])
    assert len(np.unique(polygon, axis=0)) == len(polygon)
    assert _crossings(polygon) == []
    assert _signed_area(polygon) > 0  # counter-clockwise


@pytest.mark.parametrize("name", SEED_PAPER)
def test_seed_shapes_are_unit_sized_and_centered(name):
    polygon = js.shapes.get(name)
    extent = np.ptp(polygon, axis=0)
    assert 1.0 <= extent.max() <= 2.5
    assert np.all(np.abs(polygon.min(0) + polygon.max(0)) / 2 < 0.25)


@pytest.mark.parametrize(
    "scheme",
    [js.CubicBSpline(), js.Chaikin(), js.FourPoint()],
    ids=["cubic", "chaikin", "four_point"],
)
@pytest.mark.parametrize("name", SEED_PAPER)
def test_smoothed_shapes_stay_simple(name, scheme):
    # The shapes are meant to be smoothed: their curves must not cross themselves.
    curve = np.asarray(js.refine(js.shapes.get(name), scheme, 4))
    assert _crossings(curve) == []


def test_get_returns_a_copy():
    a = js.shapes.get("jar")
    a[0] = 99.0
    assert js.shapes.get("jar")[0, 0] != 99.0


def test_unknown_shape():
    with pytest.raises(
        ValueError, match=r"unknown shape 'teapot'; the built-in shapes are \[.*'jar'.*\]"
    ):
        js.shapes.get("teapot")
