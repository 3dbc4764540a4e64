"""Scheme lists the tests parametrise over, and independent references."""

import numpy as np

import jaxsubdiv as js


def all_schemes():
    """One instance of every built-in scheme, with ids."""
    return [
        ("chaikin", js.Chaikin()),
        ("corner_cutting", js.CornerCutting(0.2, 0.65)),
        ("four_point", js.FourPoint(0.05)),
        ("cubic_bspline", js.CubicBSpline()),
        ("lane_riesenfeld_1", js.LaneRiesenfeld(1)),
        ("lane_riesenfeld_4", js.LaneRiesenfeld(4)),
        ("lane_riesenfeld_5", js.LaneRiesenfeld(5)),
        ("split_tweak", js.SplitTweak(0.3)),
        ("jarek", js.Jarek()),
        ("daubechies", js.Daubechies()),
        ("mask", js.MaskScheme([-1 / 16, 0, 9 / 16, 1, 9 / 16, 0, -1 / 16], -3)),
    ]


def schemes_with(boundary):
    return [(name, s) for name, s in all_schemes() if boundary != "clamped" or s.clamp_ghost]


# Schemes whose limit is a uniform B-spline, with its degree.
bspline_schemes = [
    ("chaikin", js.Chaikin(), 2),
    ("cubic_bspline", js.CubicBSpline(), 3),
    *[(f"lane_riesenfeld_{d}", js.LaneRiesenfeld(d), d) for d in range(2, 7)],
]

# Schemes with a parameter, how to build them, and a valid value to differentiate at.
parametrised_schemes = [
    ("corner_cutting_r", lambda x: js.CornerCutting(x, 0.7), 0.3),
    ("corner_cutting_s", lambda x: js.CornerCutting(0.2, x), 0.6),
    ("four_point", js.FourPoint, 0.07),
    ("split_tweak", js.SplitTweak, 0.4),
    ("mask", lambda x: js.MaskScheme([x, 1 - x, 1 - x, x], -2), 0.2),
]


def chaikin_python(points, levels, closed):
    """Quarter-point corner cutting as a deliberately plain Python loop.

    For each edge, the points 1/4 and 3/4 of the way along it; an open curve skips the
    closing edge. This is the regression reference for `Chaikin` and the benchmarks'
    pure-Python baseline; it shares no code with jaxsubdiv.
    """
    current = [tuple(float(x) for x in p) for p in points]
    for _ in range(levels):
        refined = []
        count = len(current)
        for i in range(count):
            j = i + 1
            if j == count:
                if not closed:
                    continue
                j = 0
            a, b = current[i], current[j]
            refined.append(tuple(0.75 * x + 0.25 * y for x, y in zip(a, b)))
            refined.append(tuple(0.25 * x + 0.75 * y for x, y in zip(a, b)))
        current = refined
    return np.array(current)


def refine_by_definition(points, mask, start, levels, boundary):
    """Level-by-level refinement straight from the definition Q_K = sum_j a_{K-2j} P_j,
    in numpy with explicit loops over outputs. Independent of jaxsubdiv's kernel.

    Open curves keep the longest run of outputs whose stencil (all mask positions)
    lies inside the polygon.
    """
    mask = np.asarray(mask, dtype=float)
    P = np.asarray(points, dtype=float)
    end = start + len(mask) - 1
    for _ in range(levels):
        n = len(P)
        if boundary == "closed":
            Q = np.zeros((2 * n,) + P.shape[1:])
            for K in range(2 * n):
                for k in range(start, end + 1):
                    if (K - k) % 2 == 0:
                        Q[K] += mask[k - start] * P[((K - k) // 2) % n]
            P = Q
            continue
        valid = {}
        for K in range(2 * start - 4, 2 * n + 2 * abs(end) + 4):
            js_ = [(K - k) // 2 for k in range(start, end + 1) if (K - k) % 2 == 0]
            if all(0 <= j < n for j in js_):
                valid[K] = sum(
                    mask[k - start] * P[(K - k) // 2]
                    for k in range(start, end + 1)
                    if (K - k) % 2 == 0
                )
        # longest run of consecutive valid outputs
        best, run = [], []
        for K in sorted(valid):
            run = run + [K] if run and K == run[-1] + 1 else [K]
            if len(run) > len(best):
                best = run
        P = np.array([valid[K] for K in best])
    return P


# --------------------------------------------------------------------------------------
# Outlines and distances for the fitting tests (numpy only; independent of jaxsubdiv).


def resample_closed(polygon, m, offset=0.5):
    """`m` points evenly spaced by arc length along a closed polygon."""
    P = np.vstack([polygon, polygon[:1]])
    s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))]
    t = (np.arange(m) + offset) / m * s[-1]
    return np.stack([np.interp(t, s, P[:, k]) for k in range(P.shape[1])], -1)


def glyph_outline(char, m=400, family="DejaVu Sans"):
    """Outer contour of a glyph of a font matplotlib ships (DejaVu Sans by default),
    resampled."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    path = TextPath((0, 0), char, size=1.0, prop=FontProperties(family=family))
    polygons = path.to_polygons(closed_only=True)
    outer = max(polygons, key=lambda p: np.ptp(p, axis=0).prod())
    if np.allclose(outer[0], outer[-1]):
        outer = outer[:-1]
    return resample_closed(outer, m)


def superellipse(m=400, a=2.0, b=1.0, p=4.0):
    theta = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    r = 1 / (np.abs(np.cos(theta)) ** p + np.abs(np.sin(theta)) ** p) ** (1 / p)
    return resample_closed(np.stack([a * r * np.cos(theta), b * r * np.sin(theta)], -1), m)


def polyline_distances(points, polyline, closed=True):
    """Brute-force distance from each point to a polyline (every segment checked)."""
    points, polyline = np.asarray(points, float), np.asarray(polyline, float)
    a = polyline
    b = np.roll(polyline, -1, axis=0) if closed else polyline[1:]
    a = a if closed else a[:-1]
    ab = b - a
    out = np.empty(len(points))
    for start in range(0, len(points), 256):
        p = points[start : start + 256, None, :]
        u = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab**2).sum(-1), 1e-300), 0, 1)
        out[start : start + 256] = np.sqrt((((p - a) - u[..., None] * ab) ** 2).sum(-1).min(1))
    return out


def two_sided_rms(curve, samples):
    """max(RMS samples -> curve, RMS curve -> polyline through the samples), both
    closed polylines; the curve's half averaged by arc length along the dense `curve`
    (each point weighted by half its two chords), as `fitting.FitResult.rms` is."""
    t2c = polyline_distances(samples, curve)
    c2t = polyline_distances(curve, samples)
    chord = np.linalg.norm(np.roll(curve, -1, axis=0) - curve, axis=-1)
    share = 0.5 * (chord + np.roll(chord, 1))
    return max(np.sqrt(np.mean(t2c**2)), np.sqrt(share @ c2t**2 / share.sum()))


def splprep_curve(samples, n, dense=4096):
    """scipy's periodic cubic least-squares spline with `n` coefficients on uniform knots,
    chord-length parameters, evaluated at `dense` points."""
    import scipy.interpolate as si

    P = np.vstack([samples, samples[:1]])
    u = np.r_[0, np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))]
    u /= u[-1]
    knots = np.arange(-3, n + 4) / n  # the full periodic knot vector
    tck, _ = si.splprep(list(P.T), u=u, k=3, task=-1, t=knots, per=1)
    return np.stack(si.splev(np.arange(dense) / dense, tck), -1)


# --------------------------------------------------------------------------------------
# Meshes for the surface tests.


def corner_value_error(points, faces, corners, values, their_points, their_faces, their_values,
                       point_tolerance):  # fmt: skip
    """The largest difference between refined per-corner values (`values[corners[i][j]]`
    at corner `j` of refined face `faces[i]`, vertices `points`) and another program's
    (`their_values[i][j]` at vertex `their_faces[i][j]`), whose refined vertices are
    numbered its own way: vertices are matched by position (each within
    `point_tolerance` of one of theirs) and faces by their vertex sets, which must be
    the same faces."""
    d = np.linalg.norm(points[:, None] - their_points[None], axis=-1)
    to_theirs = d.argmin(axis=1)
    assert d.min(axis=1).max() < point_tolerance
    theirs = {frozenset(list(f)): (list(f), u) for f, u in zip(their_faces, their_values)}
    assert len(theirs) == len(faces) == len(corners)
    worst = 0.0
    for face, face_corners in zip(faces, corners):
        order, their = theirs[frozenset(to_theirs[face].tolist())]
        for vertex, value in zip(to_theirs[face], face_corners):
            worst = max(worst, float(np.abs(values[value] - their[order.index(vertex)]).max()))
    return worst


def prism():
    """A closed pentagonal prism: two pentagons and five quads (mixed polygons)."""
    t = 2 * np.pi * np.arange(5) / 5
    v = np.concatenate([np.stack([np.cos(t), np.sin(t), -np.ones(5)], 1),
                        np.stack([np.cos(t), np.sin(t), np.ones(5)], 1)])  # fmt: skip
    faces = [[4, 3, 2, 1, 0], [5, 6, 7, 8, 9]]
    faces += [[i, (i + 1) % 5, 5 + (i + 1) % 5, 5 + i] for i in range(5)]
    return v, faces


# --------------------------------------------------------------------------------------
# Curves for the command-line and plotting tests (scipy and numpy; independent of
# jaxsubdiv).


def four_point_numpy(P, w, levels):
    """Dyn-Levin-Gregory on a closed polygon: keep P_i, insert (1/2 + w)(P_i + P_i+1) -
    w(P_i-1 + P_i+2); interpolating, so the refined points lie on the limit curve."""
    for _ in range(levels):
        prev, nxt, nxt2 = np.roll(P, 1, 0), np.roll(P, -1, 0), np.roll(P, -2, 0)
        Q = np.empty((2 * len(P), 2))
        Q[0::2] = P
        Q[1::2] = (0.5 + w) * (P + nxt) - w * (prev + nxt2)
        P = Q
    return P


def wobbly_polygon(seed, n=16):
    """A smooth closed control polygon (a wobbly ellipse), as `bench_fit_quality.py`'s
    recovery curves."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False) + rng.uniform(-0.1, 0.1, n)
    radius = 1 + 0.25 * np.sin(3 * theta + seed) + rng.uniform(-0.05, 0.05, n)
    return np.stack([1.5 * radius * np.cos(theta), radius * np.sin(theta)], -1)


def uneven_samples(curve, seed, m=400, phase=0.37 / 16):
    """At most `m` points of a dense closed curve (repeats dropped), spaced unevenly
    (3:1), their parameters shifted by `phase` of the way round (so that no sample
    need sit at a control point's limit point), in order along it. As
    `bench_fit_quality.recovery_samples`."""
    k = np.arange(m)
    u = (k + 0.3 * m / (6 * np.pi) * np.sin(6 * np.pi * k / m + seed)) / m
    index = np.unique(np.round(((u + phase) % 1.0) * len(curve)).astype(int) % len(curve))
    return curve[index]


def periodic_bspline(control, degree):
    """The closed uniform B-spline of a control polygon as a `scipy.interpolate.BSpline`
    on the periodic knot vector -degree, ..., n + degree (integer knots), so that
    `curve(u)` for u in [0, n) traces it once. The limit curve of `CubicBSpline`
    (degree 3) and `Chaikin` (degree 2)."""
    from scipy.interpolate import BSpline

    control = np.asarray(control, dtype=float)
    n = len(control)
    knots = np.arange(-degree, n + degree + 1, dtype=float)
    coefficients = np.concatenate([control, control[:degree]])
    return BSpline(knots, coefficients, degree, extrapolate="periodic")


def svg_bezier_paths(text):
    """Every subpath of every `<path d=...>` of an SVG, in order, as a list of Bezier
    segments, each an array `(degree + 1, 2)` in the path's own coordinates. Knows the
    absolute M, L, Q, C and Z that `jaxsubdiv.io` writes, and nothing else (anything else
    fails the test)."""
    import re

    subpaths = []
    for d in re.findall(r'<path[^>]*\sd="([^"]*)"', text):
        tokens = re.findall(r"[A-Za-z]|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", d)
        segments, i, current, start = None, 0, None, None
        arity = {"L": 1, "Q": 2, "C": 3}
        while i < len(tokens):
            letter = tokens[i]
            i += 1
            if letter == "M":
                current = start = np.array([float(tokens[i]), float(tokens[i + 1])])
                segments = []
                subpaths.append(segments)
                i += 2
            elif letter in arity:
                k = arity[letter]
                points = np.array([float(v) for v in tokens[i : i + 2 * k]]).reshape(k, 2)
                i += 2 * k
                segments.append(np.vstack([current, points]))
                current = points[-1]
            elif letter == "Z":
                if not np.array_equal(current, start):
                    segments.append(np.vstack([current, start]))
                current = start
            else:
                raise AssertionError(f"unexpected path command {letter!r} in {d[:80]!r}")
    return subpaths


def svg_transform_matrix(transform):
    """SVG's `matrix(a b c d e f)` or `scale(1,-1)` (what `jaxsubdiv.io` writes on its
    group) as a 3 x 3 matrix, SVG 1.1 section 7.4."""
    import re

    if transform.replace(" ", "") == "scale(1,-1)":
        return np.diag([1.0, -1.0, 1.0])
    a, b, c, d, e, f = (float(v) for v in re.split(r"[\s,]+", transform[7:-1].strip()))
    return np.array([[a, c, e], [b, d, f], [0, 0, 1]])


def apply_affine(matrix, points):
    """A 3 x 3 affine matrix applied to `(m, 2)` points."""
    return np.asarray(points, float) @ matrix[:2, :2].T + matrix[:2, 2]


def bezier_evaluate(segment, u):
    """de Casteljau evaluation of one Bezier segment `(degree + 1, 2)` at parameters u."""
    u = np.asarray(u, dtype=float)[:, None, None]
    points = np.asarray(segment, dtype=float)[None]
    while points.shape[1] > 1:
        points = (1 - u) * points[:, :-1] + u * points[:, 1:]
    return points[:, 0]


class CompileCounter:
    """Counts XLA compilations (JAX's `backend_compile_duration` monitoring events, one
    per program compiled or loaded from the persistent cache) while active:

        with CompileCounter() as compiled:
            ...
        assert compiled.count == 0
    """

    EVENT = "/jax/core/compile/backend_compile_duration"

    def __init__(self):
        self.count = 0

    def _listen(self, event, duration, **_):
        if event == self.EVENT:
            self.count += 1

    def __enter__(self):
        import jax

        jax.monitoring.register_event_duration_secs_listener(self._listen)
        return self

    def __exit__(self, *exc):
        import jax

        jax.monitoring.unregister_event_duration_listener(self._listen)


def assert_one_clear_error(call, error, words):
    """`call()` raises `error` with a one-line message that contains every one of `words`
    (the argument it names and the fix): the contract for bad input (issue 17)."""
    import pytest

    with pytest.raises(error) as info:
        call()
    message = str(info.value)
    assert "\n" not in message, message
    for word in words:
        assert word in message, (word, message)
