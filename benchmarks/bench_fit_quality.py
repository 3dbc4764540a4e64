"""How trustworthy `fitting.fit` is on real outlines, measured independently of its report.

    python benchmarks/bench_fit_quality.py            # full run (at most ~15 min on 2 cores)
    python benchmarks/bench_fit_quality.py --smoke    # 2 outlines at n = 16, four-point only
    python benchmarks/bench_fit_quality.py --output /some/dir/fit_quality.json
    python benchmarks/bench_fit_quality.py --only params,recovery  # tables 5 and 6

Issue #14 ("fits that find the right answer and say so"). Uses only the public API that
exists before and after that issue's changes (`fitting.fit`, `FitResult` fields, the
`jaxsubdiv` scheme classes), so the same script measures both trees; run it with
`PYTHONPATH=/other/checkout` from a directory outside this repository to measure another
tree (the header names the `fitting` package that was imported and its git revision).

Outlines, nobody here drew them, each resampled to 400 points by arc length (closed):

- glyphs: the outer contour of '8', 'g', '&', 'Q', 'S', 'a' in DejaVu Sans, DejaVu
  Serif, DejaVu Sans Mono, STIXGeneral and Computer Modern cmr10 (all shipped with
  matplotlib; `TextPath`);
- silhouettes: scikit-image's `data.horse()` and an Otsu threshold of a blurred
  `data.camera()` (the cameraman), traced with
  `skimage.measure.find_contours`, the longest contour;
- icons: matplotlib's own SVG toolbar icons and logo (`mpl-data/images/*.svg`), read by a
  small SVG path reader below (M, L, C, Q, Z, absolute or relative; `matrix`
  transforms); the filled outline with the largest area (invisible, unfilled and
  white-filled paths and background discs skipped: the logo gives one of its polar bars),
  straight and curved segments sampled densely before the resampling.

Independent measurement (`measure`): the fitted control polygon's limit curve is
evaluated by numpy code in this file (the closed uniform cubic B-spline by its basis
functions; the parameterised schemes by refinement with their published rules and the
exact limit-point stencils, see `refine_numpy`), resampled by arc length; curve-to-samples
is the RMS over the resampled points (so an arc-length average) of the distance to the
sample polyline, by brute force, and the max over every point of the dense curve refined
by branch and bound on its chords (the distance is 1-Lipschitz); samples-to-curve is each sample's distance to the
dense curve, from a cKDTree over its points plus the projection onto the chords next to the
nearest few. Two-sided = the larger of the two halves, as the fit defines it.

Tables (see `markdown`): 1 spread over cyclic shift and orientation; 2 n = 64 against
n = 32; 3 statuses; 4 reported figures against the independent measurement; 5
`fit_params=True` against fixed parameters (time and error); 6 recovery of known scheme
parameters from curves made by the numpy refinement here.

Writes `benchmarks/results/fit_quality.json` and `fit_quality.md` (`--output` sets the
JSON path; the Markdown goes beside it with the same stem); `--smoke` writes
`fit_quality_smoke.*` unless `--output` is given.
"""

import argparse
import datetime
import inspect
import json
import os
import pathlib
import platform
import re
import statistics
import subprocess
import sys
import time
import warnings
import xml.etree.ElementTree as ET


# One OpenBLAS thread: the machine has 2 shared cores (see bench_fit.py). Before numpy.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import jax  # noqa: E402


jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

import fitting  # noqa: E402
import jaxsubdiv as js  # noqa: E402


RESULTS = pathlib.Path(__file__).parent / "results"
M = 400  # samples per outline
SHIFTS = (0, M // 4, M // 2, 3 * M // 4)
FONTS = ("DejaVu Sans", "DejaVu Serif", "DejaVu Sans Mono", "STIXGeneral", "cmr10")
CHARS = ("8", "g", "&", "Q", "S", "a")
ICONS = ("home", "back", "hand", "matplotlib", "zoom_to_rect", "filesave")
MAX_STEPS = 500  # fitting.fit's default, passed explicitly so "ended at max_steps" is defined


# --------------------------------------------------------------------------------------
# Outlines


def resample_closed(points, m=M):
    """`m` points equally spaced by arc length along the closed polyline `points`."""
    points = np.asarray(points, float)
    if np.allclose(points[0], points[-1]):
        points = points[:-1]
    closed = np.vstack([points, points[:1]])
    gaps = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    keep = np.r_[True, gaps > 1e-12]  # drop repeated points (zero-length chords)
    closed = closed[keep]
    s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
    u = np.arange(m) * s[-1] / m
    return np.stack([np.interp(u, s, closed[:, k]) for k in range(closed.shape[1])], -1)


def signed_area(polygon):
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def glyph(family, char):
    from matplotlib import font_manager
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    if family == "cmr10":  # by file: matplotlib ships it, but not always under that name
        prop = FontProperties(fname=str(pathlib.Path(font_manager.__file__).parent
                                        / "mpl-data" / "fonts" / "ttf" / "cmr10.ttf"))
    else:
        prop = FontProperties(family=family)
        found = font_manager.findfont(prop, fallback_to_default=False)
        if family.replace(" ", "") not in pathlib.Path(found).stem.replace(" ", ""):
            raise RuntimeError(f"font {family!r} resolved to {found}")
    path = TextPath((0, 0), char, size=1.0, prop=prop)
    polygons = path.to_polygons(closed_only=True)
    return resample_closed(max(polygons, key=lambda p: abs(signed_area(p))))


def silhouette(name):
    from skimage import data, filters, measure

    if name == "horse":
        mask = data.horse().astype(float)
    elif name == "camera":
        image = filters.gaussian(data.camera(), sigma=2)
        mask = (image < filters.threshold_otsu(image)).astype(float)
    else:
        raise ValueError(name)
    mask = np.pad(mask, 1, constant_values=mask[0, 0])  # contours close inside the frame
    contour = max(measure.find_contours(mask, 0.5), key=len)
    return resample_closed(contour[:, ::-1] * [1, -1])  # (row, col) -> (x, y), y up


def svg_subpaths(d):
    """Closed subpaths of an SVG path's `d` (M, L, C, Q, Z, absolute or relative: what
    these files use), each as a dense polygon: 32 points per curve segment, 16 per line."""
    tokens = re.findall(r"[MLCQZmlcqz]|-?\d*\.?\d+(?:[eE][-+]?\d+)?", d)
    out, current, start, pos, i, cmd = [], [], np.zeros(2), np.zeros(2), 0, None
    u = np.linspace(0, 1, 33)[1:, None]
    while i < len(tokens):
        if re.fullmatch(r"[A-Za-z]", tokens[i]):
            cmd = tokens[i]
            i += 1
            if cmd in "Zz":
                if len(current) > 2:
                    out.append(np.array(current))
                current, pos = [], start
                continue
        count = {"M": 2, "L": 2, "C": 6, "Q": 4}[cmd.upper()]
        values = np.array(tokens[i:i + count], float).reshape(-1, 2)
        if cmd.islower():
            values = values + pos
        i += count
        kind = cmd.upper()
        if kind == "M":
            if len(current) > 2:
                out.append(np.array(current))
            pos = start = values[0]
            current = [pos]
            cmd = "l" if cmd.islower() else "L"  # further pairs after M are line-tos
        elif kind == "L":
            current.extend(pos + np.linspace(0, 1, 17)[1:, None] * (values[0] - pos))
            pos = values[0]
        elif kind == "C":
            p0, p1, p2, p3 = pos, *values
            current.extend((1 - u) ** 3 * p0 + 3 * (1 - u) ** 2 * u * p1
                           + 3 * (1 - u) * u**2 * p2 + u**3 * p3)
            pos = p3
        else:
            p0, p1, p2 = pos, *values
            current.extend((1 - u) ** 2 * p0 + 2 * (1 - u) * u * p1 + u**2 * p2)
            pos = p2
    if len(current) > 2:
        out.append(np.array(current))
    return out


def svg_transform(text):
    """The affine map of an SVG `transform="matrix(a,b,c,d,e,f)"` (the only form in
    these files), as a function on (k, 2) points."""
    if not text:
        return lambda p: p
    match = re.fullmatch(r"\s*matrix\(([^)]*)\)\s*", text)
    if not match:
        raise ValueError(f"unsupported SVG transform {text!r}")
    a, b, c, d, e, f = (float(x) for x in re.split(r"[\s,]+", match.group(1).strip()))
    return lambda p: p @ np.array([[a, b], [c, d]]) + [e, f]


def icon(name):
    import matplotlib

    file = pathlib.Path(matplotlib.get_data_path()) / "images" / f"{name}.svg"
    candidates = []
    for element in ET.parse(file).iter():
        if not element.tag.endswith("path") or "d" not in element.attrib:
            continue
        style = element.attrib.get("style", "").replace(" ", "")
        # Invisible (the figure's background rectangle), unfilled (axis lines, spines)
        # and white-filled (the logo's axes disc) paths are not the icon's outline;
        # unstyled paths are filled black.
        if "opacity:0;" in style + ";" or "fill:#ffffff" in style or "fill:none" in style:
            continue
        transform = svg_transform(element.attrib.get("transform"))
        for polygon in svg_subpaths(element.attrib["d"]):
            polygon = transform(polygon)
            # Background discs (the hand's, the logo's outline circle) are not the icon.
            length = np.linalg.norm(np.diff(polygon, axis=0, append=polygon[:1]), axis=1).sum()
            if 4 * np.pi * abs(signed_area(polygon)) / length**2 < 0.98:
                candidates.append(polygon)
    outline = max(candidates, key=lambda p: abs(signed_area(p)))
    return resample_closed(outline * [1, -1])  # SVG's y runs down


def outlines(smoke):
    shapes = {}
    fonts, chars = (FONTS[1:2], CHARS[:1]) if smoke else (FONTS, CHARS)
    for family in fonts:
        for char in chars:
            shapes[f"{family} '{char}'"] = glyph(family, char)
    for name in ("horse",) if smoke else ("horse", "camera"):
        shapes[f"skimage {name}"] = silhouette(name)
    if not smoke:
        for name in ICONS:
            shapes[f"icon {name}"] = icon(name)
    return shapes


# --------------------------------------------------------------------------------------
# Independent curves: numpy only, from the published rules


def bspline_curve(P, per_span):
    """Closed uniform cubic B-spline with control points P at `per_span` parameters per
    span: C(j + u) = sum_k b_k(u) P_{j-1+k}."""
    u = np.arange(per_span)[:, None] / per_span
    b = [(1 - u) ** 3 / 6, (3 * u**3 - 6 * u**2 + 4) / 6,
         (-3 * u**3 + 3 * u**2 + 3 * u + 1) / 6, u**3 / 6]
    spans = sum(bk[None] * np.roll(P, 1 - k, axis=0)[:, None] for k, bk in enumerate(b))
    return spans.reshape(-1, P.shape[1])


def scheme_rules(name, values):
    """(kind, coefficients) of one closed refinement step, from the published rules.

    `"primal"`: Q_2i = a (P_{i-1} + P_{i+1}) + b P_i and
    Q_2i+1 = c (P_i + P_{i+1}) + e (P_{i-1} + P_{i+2}):
    four-point (Dyn, Levin, Gregory 1987): a = 0, b = 1, c = 1/2 + w, e = -w;
    split-and-tweak (Rossignac 2004): split at midpoints, D_j = V_{j-1}/8 + V_{j+1}/8 -
    V_j/4, vertices moved by (1 - t) D_j, midpoints of (j, j+1) by -t (D_j + D_{j+1})/2,
    so a = (1 - t)/8, b = 1 - (1 - t)/4, c = 1/2 + t/16, e = -t/16.
    `"cut"`: corner cutting, Q_2i = (1-r) P_i + r P_{i+1}, Q_2i+1 = (1-s) P_i + s P_{i+1}."""
    if name == "FourPoint":
        w = values["w"]
        return "primal", (0.0, 1.0, 0.5 + w, -w)
    if name == "SplitTweak":
        t = values["t"]
        return "primal", ((1 - t) / 8, 1 - (1 - t) / 4, 0.5 + t / 16, -t / 16)
    if name == "CubicBSpline":
        return "primal", (1 / 8, 3 / 4, 1 / 2, 0.0)
    if name == "CornerCutting":
        return "cut", (values["r"], values["s"])
    raise ValueError(name)


def refine_step(P, kind, coefficients):
    Q = np.empty((2 * len(P), P.shape[1]))
    nxt = np.roll(P, -1, axis=0)
    if kind == "primal":
        a, b, c, e = coefficients
        prv, nxt2 = np.roll(P, 1, axis=0), np.roll(P, -2, axis=0)
        Q[0::2] = a * (prv + nxt) + b * P
        Q[1::2] = c * (P + nxt) + e * (prv + nxt2)
    else:
        r, s = coefficients
        Q[0::2] = (1 - r) * P + r * nxt
        Q[1::2] = (1 - s) * P + s * nxt
    return Q


def limit_stencil(kind, coefficients):
    """Exact limit points of a level's points. Primal: the dominant left eigenvector of
    the 5x5 local subdivision matrix around a vertex (rows: new points 2j-2..2j+2 from
    old j-2..j+2). Corner cutting: the edge (P_i, P_{i+1}) is mapped to (Q_2i, Q_2i+1)
    by [[1-r, r], [1-s, s]], whose fixed point is ((1-s) P_i + r P_{i+1}) / (1 - s + r)."""
    if kind == "cut":
        r, s = coefficients
        return np.array([1 - s, r]) / (1 - s + r)
    a, b, c, e = coefficients
    A = np.array([[a, b, a, 0, 0], [e, c, c, e, 0], [0, a, b, a, 0],
                  [0, e, c, c, e], [0, 0, a, b, a]])
    values, vectors = np.linalg.eig(A.T)
    left = np.real(vectors[:, np.argmin(np.abs(values - 1))])
    return left / left.sum()


def refine_numpy(P, name, values, levels):
    """Exact limit points of the closed curve after `levels` refinements (numpy)."""
    kind, coefficients = scheme_rules(name, values)
    P = np.asarray(P, float)
    for _ in range(levels):
        P = refine_step(P, kind, coefficients)
    stencil = limit_stencil(kind, coefficients)
    if kind == "cut":
        return stencil[0] * P + stencil[1] * np.roll(P, -1, axis=0)
    return sum(w * np.roll(P, 2 - k, axis=0) for k, w in enumerate(stencil))


def check_numpy_curves():
    """The numpy limit points of the cubic B-spline by refinement + stencil agree with
    its basis functions (two independent routes), and Chaikin's limit passes through the
    midpoints of the quadratic B-spline's spans."""
    rng = np.random.default_rng(0)
    P = rng.normal(size=(7, 2))
    via_refinement = refine_numpy(P, "CubicBSpline", {}, 3)
    np.testing.assert_allclose(via_refinement, bspline_curve(P, 8), atol=1e-12)
    chaikin = refine_numpy(P, "CornerCutting", {"r": 0.25, "s": 0.75}, 0)
    np.testing.assert_allclose(chaikin, (P + np.roll(P, -1, axis=0)) / 2, atol=1e-12)
    four = refine_numpy(P, "FourPoint", {"w": 0.05}, 2)
    np.testing.assert_allclose(four[::4], P, atol=1e-12)  # interpolating


def dense_curve(P, name="CubicBSpline", values=None, points=8192):
    P = np.asarray(P, float)
    if name == "CubicBSpline":
        return bspline_curve(P, -(-points // len(P)))
    levels = int(np.ceil(np.log2(points / len(P))))
    return refine_numpy(P, name, values or {}, levels)


def scheme_values(scheme):
    return {k: float(getattr(scheme, k)) for k in ("w", "t", "r", "s") if hasattr(scheme, k)}


# --------------------------------------------------------------------------------------
# Independent measurement


def points_to_polyline(points, polyline):
    """Brute-force distance from each point to the closed polyline (every chord)."""
    a = polyline
    ab = np.roll(polyline, -1, axis=0) - a
    length2 = np.maximum((ab**2).sum(-1), 1e-300)
    out = np.empty(len(points))
    for start in range(0, len(points), 512):
        p = points[start:start + 512, None, :] - a
        u = np.clip((p * ab).sum(-1) / length2, 0, 1)
        out[start:start + 512] = np.sqrt(((p - u[..., None] * ab) ** 2).sum(-1).min(1))
    return out


def points_to_dense_curve(points, curve, k=8):
    """Distance from each point to the closed dense polyline `curve`: its k nearest
    vertices (cKDTree, a global search) and the projection onto the chords on either
    side of each."""
    _, nearest = cKDTree(curve).query(points, k=k)
    best = np.full(len(points), np.inf)
    N = len(curve)
    for side in (-1, 1):
        a = curve[nearest]
        b = curve[(nearest + side) % N]
        ab = b - a
        p = points[:, None, :] - a
        u = np.clip((p * ab).sum(-1) / np.maximum((ab**2).sum(-1), 1e-300), 0, 1)
        best = np.minimum(best, np.sqrt(((p - u[..., None] * ab) ** 2).sum(-1)).min(1))
    return best


def measure(curve, samples, resampled=4096):
    """Independent two-sided figures of a dense closed curve against ordered samples."""
    even = resample_closed(curve, resampled)
    c2t = points_to_polyline(even, samples)
    t2c = points_to_dense_curve(samples, curve)
    # The max: the distance to a polyline peaks at kinks, which points 1/4096 of the
    # length apart miss by up to half that spacing, and chords between them cut the
    # tip of a tight bend (measured: 0.6076 against 0.7389 on the hand icon, 400,000
    # points). So the max is taken over every point of the dense curve, and since the
    # distance is 1-Lipschitz, between neighbours i, i + 1 it stays below
    # (d_i + d_{i+1} + |p_i - p_{i+1}|) / 2: every piece whose bound exceeds the
    # largest found is sampled again at 65 points (branch and bound).
    at_vertices = points_to_polyline(curve, samples)
    following = np.roll(curve, -1, axis=0)
    bound = 0.5 * (at_vertices + np.roll(at_vertices, -1)
                   + np.linalg.norm(following - curve, axis=-1))
    open_pieces = np.flatnonzero(bound > at_vertices.max())
    fraction = np.linspace(0.0, 1.0, 65)[None, :, None]
    dense = curve[open_pieces, None, :] + fraction * (following - curve)[open_pieces, None, :]
    peak = max(at_vertices.max(),
               points_to_polyline(dense.reshape(-1, curve.shape[-1]), samples).max(initial=0.0))
    halves = {
        "rms_target_to_curve": float(np.sqrt(np.mean(t2c**2))),
        "max_target_to_curve": float(t2c.max()),
        "rms_curve_to_target": float(np.sqrt(np.mean(c2t**2))),
        "max_curve_to_target": float(max(c2t.max(), peak)),
    }
    halves["rms"] = max(halves["rms_target_to_curve"], halves["rms_curve_to_target"])
    halves["max_error"] = max(halves["max_target_to_curve"], halves["max_curve_to_target"])
    return halves


REPORTED = ("rms", "max_error", "rms_target_to_curve", "max_target_to_curve",
            "rms_curve_to_target", "max_curve_to_target")


def reported(result):
    return {k: float(getattr(result, k)) for k in REPORTED}


# --------------------------------------------------------------------------------------
# Runs


def quiet_fit(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = fitting.fit(*args, on_failure="ignore", **kwargs)
    jax.block_until_ready(result.control_points)
    return result


def variant(samples, shift, reverse):
    out = np.roll(samples, -shift, axis=0)
    return out[::-1].copy() if reverse else out


def run_spread(shapes, ns, log):
    """Tables 1-4: every outline at each n, 4 cyclic shifts x 2 orientations."""
    rows = []
    for n in ns:
        for label, samples in shapes.items():
            for reverse in (False, True):
                for shift in SHIFTS:
                    target = variant(samples, shift, reverse)
                    start = time.perf_counter()
                    result = quiet_fit(target, js.CubicBSpline(), n, max_steps=MAX_STEPS)
                    seconds = time.perf_counter() - start
                    independent = measure(dense_curve(result.control_points), target)
                    rows.append({
                        "outline": label, "n": n, "shift": shift, "reversed": reverse,
                        "seconds": seconds, "num_steps": int(result.num_steps),
                        "status": int(result.status),
                        "status_name": fitting.STATUSES[int(result.status)],
                        "newton_step": float(result.newton_step),
                        "reported": reported(result), "independent": independent,
                    })
            last = rows[-1]
            log(f"n={n} {label}: {last['seconds']:.2f} s, {last['num_steps']} steps, "
                f"rms {last['independent']['rms']:.2e}")
    return rows


def params_fit_kwargs(name):
    return {"FourPoint": ("w",), "SplitTweak": ("t",), "CornerCutting": ("r", "s")}[name]


SCHEMES = {"FourPoint": js.FourPoint, "SplitTweak": js.SplitTweak,
           "CornerCutting": js.CornerCutting}


#: Whether the measured `fitting` has the profile before the joint fit (issue #14).
HAS_PROFILE = "profile" in inspect.signature(fitting.fit).parameters


def timed_fits(target, scheme, n, fit_params, repeats, **options):
    """First call (compile + fit) and the median of `repeats` warm calls."""
    start = time.perf_counter()
    result = quiet_fit(target, scheme, n, fit_params=fit_params, max_steps=MAX_STEPS,
                       **options)
    first = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = quiet_fit(target, scheme, n, fit_params=fit_params, max_steps=MAX_STEPS,
                           **options)
        times.append(time.perf_counter() - start)
    return first, statistics.median(times), result


def run_params(shapes, labels, ns, repeats, log, schemes):
    """Table 5: fit_params=True against the parameters fixed at their defaults."""
    rows = []
    for name in schemes:
        cls = SCHEMES[name]
        for n in ns:
            for label in labels:
                target = shapes[label]
                scheme = cls()
                fixed_first, fixed_warm, fixed = timed_fits(target, scheme, n, False, repeats)
                fitted_first, fitted_warm, fitted = timed_fits(
                    target, scheme, n, params_fit_kwargs(name), repeats)
                joint = {}
                if HAS_PROFILE:  # the joint fit from the start alone, without the profile
                    _, joint_warm, alone = timed_fits(target, scheme, n,
                                                      params_fit_kwargs(name), repeats,
                                                      profile=0)
                    joint = {"joint_warm": joint_warm, "joint_steps": int(alone.num_steps),
                             "joint_rms": measure(dense_curve(
                                 alone.control_points, name, scheme_values(alone.scheme)),
                                 target)["rms"]}
                fixed_error = measure(dense_curve(fixed.control_points, name,
                                                  scheme_values(scheme)), target)["rms"]
                values = scheme_values(fitted.scheme)
                fitted_error = measure(dense_curve(fitted.control_points, name, values),
                                       target)["rms"]
                rows.append({
                    "scheme": name, "n": n, "outline": label,
                    "fixed_first": fixed_first, "fixed_warm": fixed_warm,
                    "fitted_first": fitted_first, "fitted_warm": fitted_warm,
                    "fixed_steps": int(fixed.num_steps), "fitted_steps": int(fitted.num_steps),
                    "fixed_status": fitting.STATUSES[int(fixed.status)],
                    "fitted_status": fitting.STATUSES[int(fitted.status)],
                    "fitted_values": values, "fixed_rms": fixed_error,
                    "fitted_rms": fitted_error, **joint,
                })
                log(f"{name} n={n} {label}: fixed {fixed_warm:.3f} s, fitted "
                    f"{fitted_warm:.3f} s, rms {fixed_error:.2e} -> {fitted_error:.2e} {values}")
    return rows


# Recovery grid: true values across the valid range (the fit keeps w in (0, 0.19), t in
# (0, 1), 0 < r < s < 1), each started at the far end of the range.
RECOVERY = {
    "FourPoint": [({"w": w}, {"w": 0.18 if w < 0.095 else 0.01})
                  for w in (0.005, 0.04, 1 / 16, 0.1, 0.15, 0.185)],
    "SplitTweak": [({"t": t}, {"t": 0.97 if t < 0.5 else 0.03})
                   for t in (0.02, 0.25, 0.5, 0.75, 0.98)],
    "CornerCutting": [({"r": r, "s": s}, {"r": 0.45 if r < 0.25 else 0.05,
                                          "s": 0.95 if s < 0.75 else 0.55})
                      for r, s in ((0.05, 0.5), (0.1, 0.6), (0.25, 0.75), (0.2, 0.9),
                                   (0.4, 0.6), (0.3, 0.95))],
}
RECOVERY_N = 16
RECOVERY_LEVELS = 10  # 16 * 2^10 exact limit points to draw the samples from


def recovery_polygon(seed):
    """A smooth, star-free closed control polygon of RECOVERY_N points (a wobbly
    ellipse)."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0, 2 * np.pi, RECOVERY_N, endpoint=False) + rng.uniform(-0.1, 0.1,
                                                                               RECOVERY_N)
    radius = 1 + 0.25 * np.sin(3 * theta + seed) + rng.uniform(-0.05, 0.05, RECOVERY_N)
    return np.stack([1.5 * radius * np.cos(theta), radius * np.sin(theta)], -1)


def recovery_samples(curve, seed):
    """M samples of the dense exact limit points at uneven spacing (a smooth density
    variation of 3:1), the first one between control points (a phase of 0.37 of a
    control span)."""
    N = len(curve)
    k = np.arange(M)
    u = (k + 0.3 * M / (2 * np.pi * 3) * np.sin(2 * np.pi * 3 * k / M + seed)) / M
    u = (u + 0.37 / RECOVERY_N) % 1.0
    index = np.unique(np.round(u * N).astype(int) % N)
    index = np.sort(index)
    return curve[index]


def run_recovery(cases_per_scheme, log, schemes):
    """Table 6: curves from known parameters (numpy refinement), recovered by
    `fit_params=True` started at the far end of the range."""
    rows = []
    for name in schemes:
        cases = RECOVERY[name]
        for index, (truth, start) in enumerate(cases[:cases_per_scheme]):
            polygon = recovery_polygon(index)
            true_curve = refine_numpy(polygon, name, truth, RECOVERY_LEVELS)
            samples = recovery_samples(true_curve, index)
            size = float(np.ptp(true_curve, axis=0).max())
            scheme = SCHEMES[name](**start)
            begin = time.perf_counter()
            result = quiet_fit(samples, scheme, RECOVERY_N, fit_params=params_fit_kwargs(name),
                               max_steps=MAX_STEPS)
            seconds = time.perf_counter() - begin
            values = scheme_values(result.scheme)
            fitted_curve = refine_numpy(result.control_points, name, values, RECOVERY_LEVELS)
            gap = max(points_to_dense_curve(fitted_curve, true_curve).max(),
                      points_to_dense_curve(true_curve, fitted_curve).max()) / size
            parameter_error = max(abs(values[k] - truth[k]) for k in truth)
            # The loss's floor: the fit with the parameters held at the truth, started
            # from the true polygon (the curve error no start can beat); and the same
            # from the default (linear) start: a control-point local minimum when worse.
            def held_error(fit):
                curve = refine_numpy(fit.control_points, name, truth, RECOVERY_LEVELS)
                return max(points_to_dense_curve(curve, true_curve).max(),
                           points_to_dense_curve(true_curve, curve).max()) / size

            floor = held_error(quiet_fit(samples, SCHEMES[name](**truth), RECOVERY_N,
                                         init=polygon, max_steps=MAX_STEPS))
            held_default = held_error(quiet_fit(samples, SCHEMES[name](**truth), RECOVERY_N,
                                                max_steps=MAX_STEPS))
            rows.append({
                "scheme": name, "truth": truth, "start": start, "fitted": values,
                "samples": len(samples), "parameter_error": parameter_error,
                "curve_error": float(gap), "floor": float(floor),
                "held_default_start": float(held_default), "seconds": seconds,
                "num_steps": int(result.num_steps),
                "status": fitting.STATUSES[int(result.status)],
                "success": bool(parameter_error <= 1e-3 and gap <= 1e-6),
            })
            log(f"recovery {name} {truth} from {start}: {values}, curve {gap:.1e}, "
                f"{seconds:.1f} s")
    return rows


# --------------------------------------------------------------------------------------
# Summaries and output


def fmt(x, digits=3):
    if x is None:
        return ""
    if isinstance(x, float) and not np.isfinite(x):
        return "inf" if x > 0 else "nan"
    return f"{x:.{digits}g}"


def spread_table(rows):
    groups = {}
    for row in rows:
        groups.setdefault((row["outline"], row["n"]), []).append(row["independent"]["rms"])
    table = []
    for (label, n), errors in groups.items():
        table.append({"outline": label, "n": n, "min": min(errors), "max": max(errors),
                      "ratio": max(errors) / min(errors)})
    return table


def growth_table(rows, small, large):
    base = {(r["outline"], r["n"]): r["independent"]["rms"] for r in rows
            if r["shift"] == 0 and not r["reversed"]}
    return [{"outline": label, "rms_small": base[(label, small)],
             "rms_large": base[(label, large)],
             "ratio": base[(label, large)] / base[(label, small)]}
            for (label, n) in base if n == small and (label, large) in base]


def honesty_table(rows):
    out = {}
    for key in REPORTED:
        ratios = [r["reported"][key] / r["independent"][key] for r in rows
                  if r["independent"][key] > 0]
        finite = [x for x in ratios if np.isfinite(x)]
        out[key] = {"median": statistics.median(finite), "min": min(finite),
                    "max": max(finite), "nonfinite": len(ratios) - len(finite),
                    "off_by_2pct": sum(abs(x - 1) > 0.02 for x in ratios), "count": len(ratios)}
    return out


def summarise(data):
    summary = {}
    if data.get("spread"):
        summary.update(summarise_spread(data["spread"]))
    summarise_params(data, summary)
    return summary


def summarise_spread(rows):
    spread = spread_table(rows)
    ns = sorted({r["n"] for r in rows})
    summary = {"spread": spread,
               "spread_median_ratio": statistics.median(r["ratio"] for r in spread),
               "spread_max_ratio": max(r["ratio"] for r in spread)}
    for n in ns:
        ratios = [r["ratio"] for r in spread if r["n"] == n]
        summary[f"spread_n{n}"] = {"median": statistics.median(ratios), "max": max(ratios)}
    if len(ns) >= 2:
        growth = growth_table(rows, ns[0], ns[-1])
        summary["growth"] = growth
        summary["growth_worse"] = sum(g["ratio"] > 1 for g in growth)
        summary["growth_median"] = statistics.median(g["ratio"] for g in growth)
        summary["growth_max"] = max(g["ratio"] for g in growth)
        # The same comparison paired over every shift and orientation.
        by_variant = {(r["outline"], r["shift"], r["reversed"], r["n"]): r["independent"]["rms"]
                      for r in rows}
        paired = [by_variant[(o, sh, rev, ns[-1])] / rms
                  for (o, sh, rev, n), rms in by_variant.items()
                  if n == ns[0] and (o, sh, rev, ns[-1]) in by_variant]
        summary["growth_paired"] = {"worse": sum(x > 1 for x in paired), "count": len(paired),
                                    "median": statistics.median(paired), "max": max(paired)}
    statuses = {}
    for r in rows:
        statuses[r["status_name"]] = statuses.get(r["status_name"], 0) + 1
    summary["statuses"] = {
        "fits": len(rows), "by_status": statuses,
        "at_max_steps": sum(r["num_steps"] >= MAX_STEPS for r in rows),
        "newton_inf": sum(not np.isfinite(r["newton_step"]) for r in rows),
        "newton_nan": sum(np.isnan(r["newton_step"]) for r in rows),
        "by_n": {n: {"fits": sum(r["n"] == n for r in rows),
                     "at_max_steps": sum(r["n"] == n and r["num_steps"] >= MAX_STEPS
                                         for r in rows),
                     "not_converged": sum(r["n"] == n and r["status"] != 0 for r in rows),
                     "newton_inf": sum(r["n"] == n and not np.isfinite(r["newton_step"])
                                       for r in rows)} for n in ns},
    }
    summary["honesty"] = honesty_table(rows)
    return summary


def summarise_params(data, summary):
    if data.get("params"):
        p = data["params"]
        summary["params"] = {
            "time_ratio_median": statistics.median(r["fitted_warm"] / r["fixed_warm"] for r in p),
            "time_ratio_max": max(r["fitted_warm"] / r["fixed_warm"] for r in p),
            "worse": sum(r["fitted_rms"] > r["fixed_rms"] * (1 + 1e-6) for r in p),
            "count": len(p),
        }
        if all("joint_warm" in r for r in p):
            summary["params"]["joint_ratio_median"] = statistics.median(
                r["joint_warm"] / r["fixed_warm"] for r in p)
            summary["params"]["joint_ratio_max"] = max(r["joint_warm"] / r["fixed_warm"]
                                                       for r in p)
            summary["params"]["joint_worse"] = sum(
                r["joint_rms"] > r["fixed_rms"] * (1 + 1e-6) for r in p)
    if data.get("recovery"):
        per = {}
        for r in data["recovery"]:
            per.setdefault(r["scheme"], []).append(r["success"])
        summary["recovery"] = {k: {"success": sum(v), "cases": len(v)} for k, v in per.items()}
        for r in data["recovery"]:
            entry = summary["recovery"][r["scheme"]]
            entry["parameters"] = entry.get("parameters", 0) + (r["parameter_error"] <= 1e-3)


def markdown(data):
    s = data["summary"]
    h = data["header"]
    lines = [
        "# How trustworthy `fitting.fit` is on real outlines (issue #14)", "",
        f"{h['date']}; {h['machine']}; load {h['load_start']} at start, {h['load_end']} at "
        f"end (1, 5, 15 min); jax {h['jax']}, numpy {h['numpy']}; `fitting` from "
        f"`{h['fitting_file']}`, git {h['git']}. Wall time {h['wall_seconds']:.0f} s.", "",
        f"{len(data['outlines'])} outlines of {M} samples each (arc-length resampled, closed): "
        + ", ".join(data["outlines"]) + ". Closed `CubicBSpline`, default settings, "
        f"`max_steps={MAX_STEPS}` (the default), float64. Every error below is measured "
        "independently of the fit's report: the fitted control polygon's limit curve "
        "evaluated by numpy (B-spline basis, or refinement by the published rules with "
        "exact limit stencils), resampled by arc length; curve-to-samples RMS over it "
        "(arc-length average, distance to the sample polyline, brute force), its max over "
        "every point of the dense curve refined by branch and bound (1-Lipschitz); "
        "samples-to-curve by a global nearest point (cKDTree + chords); two-sided = the "
        "larger RMS. Errors are in the outline's units (glyphs ~0.7 tall; silhouettes "
        "and icons in pixels).", "",
    ]
    if data.get("spread"):
        lines += [
            "## 1. Spread over cyclic shift and orientation", "",
            f"Each outline at each n fitted 8 times: shifts {', '.join(map(str, SHIFTS))} x "
            "forward/reversed. `ratio`: max / min of the 8 two-sided RMS errors (1 = the "
            "result does not depend on where the samples start or which way they run).", "",
            "| n | median ratio | max ratio | outlines with ratio > 1.1 |",
            "| ---: | ---: | ---: | ---: |",
        ]
        for n in sorted({r["n"] for r in s["spread"]}):
            ratios = [r["ratio"] for r in s["spread"] if r["n"] == n]
            lines.append(f"| {n} | {fmt(statistics.median(ratios))} | {fmt(max(ratios))} | "
                         f"{sum(x > 1.1 for x in ratios)} / {len(ratios)} |")
        lines += [f"| all | {fmt(s['spread_median_ratio'])} | {fmt(s['spread_max_ratio'])} | "
                  f"{sum(r['ratio'] > 1.1 for r in s['spread'])} / {len(s['spread'])} |", "",
                  "Per outline (worst first):", "",
                  "| outline | n | min RMS | max RMS | ratio |", "| --- | ---: | ---: | ---: | ---: |"]
        for r in sorted(s["spread"], key=lambda r: -r["ratio"]):
            lines.append(f"| {r['outline']} | {r['n']} | {fmt(r['min'])} | {fmt(r['max'])} | "
                         f"{fmt(r['ratio'])} |")
        if "growth" in s:
            ns = sorted({r["n"] for r in s["spread"]})
            lines += ["", f"## 2. n = {ns[-1]} against n = {ns[0]}", "",
                      f"Shift 0, forward. `ratio` = two-sided RMS at n = {ns[-1]} / at n = "
                      f"{ns[0]}; above 1 the larger fit is worse, although the n = {ns[0]} curve "
                      f"is exactly representable with {ns[-1]} control points. Worse: "
                      f"**{s['growth_worse']} of {len(s['growth'])}**; median ratio "
                      f"{fmt(s['growth_median'])}, max {fmt(s['growth_max'])}. Paired over "
                      f"all {s['growth_paired']['count']} shifts and orientations of table 1: "
                      f"worse in **{s['growth_paired']['worse']}**, median ratio "
                      f"{fmt(s['growth_paired']['median'])}, max "
                      f"{fmt(s['growth_paired']['max'])}.", "",
                      f"| outline | RMS n = {ns[0]} | RMS n = {ns[-1]} | ratio |",
                      "| --- | ---: | ---: | ---: |"]
            for g in sorted(s["growth"], key=lambda g: -g["ratio"]):
                lines.append(f"| {g['outline']} | {fmt(g['rms_small'])} | {fmt(g['rms_large'])} "
                             f"| {fmt(g['ratio'])} |")
        st = s["statuses"]
        lines += ["", "## 3. Statuses", "",
                  f"All {st['fits']} fits of table 1. `at max_steps`: `num_steps` reached "
                  f"`max_steps` ({MAX_STEPS}). `newton_step inf`: the reported Newton step is "
                  "infinite (Hessian not positive definite at the returned point).", "",
                  "| n | fits | at max_steps | not converged (status != 0) | newton_step inf |",
                  "| ---: | ---: | ---: | ---: | ---: |"]
        for n, b in st["by_n"].items():
            lines.append(f"| {n} | {b['fits']} | {b['at_max_steps']} "
                         f"({100 * b['at_max_steps'] / b['fits']:.0f}%) | {b['not_converged']} | "
                         f"{b['newton_inf']} |")
        lines.append(f"| all | {st['fits']} | {st['at_max_steps']} "
                     f"({100 * st['at_max_steps'] / st['fits']:.0f}%) | "
                     f"{st['fits'] - st['by_status'].get('successful', 0)} | {st['newton_inf']} |")
        lines += ["", "Statuses by name: " + ", ".join(f"{k} {v}" for k, v in
                                                      sorted(st["by_status"].items())) + "."]
        lines += ["", "## 4. Reported figures against the independent measurement", "",
                  "`FitResult` field / the same figure measured independently, over the fits "
                  "of table 1. 1 = honest; `off by > 2%`: how many ratios differ from 1 by "
                  "more than 2% (the issue's test tolerance).", "",
                  "| field | median | min | max | off by > 2% | non-finite |",
                  "| --- | ---: | ---: | ---: | ---: | ---: |"]
        for key, v in s["honesty"].items():
            lines.append(f"| `{key}` | {fmt(v['median'], 4)} | {fmt(v['min'], 4)} | "
                         f"{fmt(v['max'], 4)} | {v['off_by_2pct']} / {v['count']} | "
                         f"{v['nonfinite']} |")
    if data.get("params"):
        p = s["params"]
        lines += ["", "## 5. `fit_params=True` against fixed parameters", "",
                  "Warm medians (first call excluded) of `fit` with the scheme's parameters "
                  "fitted (`fit_params` = the scheme's names), started at the defaults (w = "
                  "1/16, t = 1/2, r, s = 1/4, 3/4), and with them fixed at the defaults. "
                  f"Time ratio fitted / fixed: median **{fmt(p['time_ratio_median'])}**, max "
                  f"**{fmt(p['time_ratio_max'])}**. Fitted parameters gave a higher "
                  f"independent RMS than the fixed defaults in **{p['worse']} of "
                  f"{p['count']}**.", ""]
        joint = "joint_ratio_median" in p
        if joint:
            lines += ["`fit_params=True` runs a profile (fits with the parameters held on a "
                      "grid, and at the start) before the joint fit; the joint fit alone "
                      "(`profile=0`, the start's values only) took a median "
                      f"**{fmt(p['joint_ratio_median'])}**, max "
                      f"**{fmt(p['joint_ratio_max'])}** of the fixed fit's time, and gave "
                      f"a higher RMS than the fixed defaults in **{p['joint_worse']} of "
                      f"{p['count']}**.", ""]
        lines += ["| scheme | n | outline | fixed (s) | fitted (s) | ratio | "
                  + ("joint alone (s) | ratio | " if joint else "")
                  + "steps fixed / fitted | status fitted | fitted values | RMS fixed | "
                  "RMS fitted | fitted / fixed RMS |" + (" joint alone / fixed RMS |"
                                                         if joint else ""),
                  "| --- | ---: | --- | ---: | ---: | ---: | " + ("---: | ---: | " if joint
                                                                  else "")
                  + "---: | --- | --- | ---: | ---: | ---: |" + (" ---: |" if joint else "")]
        for r in data["params"]:
            values = ", ".join(f"{k} = {v:.4g}" for k, v in r["fitted_values"].items())
            alone = (f"{fmt(r['joint_warm'])} | {fmt(r['joint_warm'] / r['fixed_warm'])} | "
                     if joint else "")
            lines.append(
                f"| {r['scheme']} | {r['n']} | {r['outline']} | {fmt(r['fixed_warm'])} | "
                f"{fmt(r['fitted_warm'])} | {fmt(r['fitted_warm'] / r['fixed_warm'])} | "
                f"{alone}{r['fixed_steps']} / {r['fitted_steps']} | {r['fitted_status']} | "
                f"{values} | {fmt(r['fixed_rms'])} | {fmt(r['fitted_rms'])} | "
                f"{fmt(r['fitted_rms'] / r['fixed_rms'])} |"
                + (f" {fmt(r['joint_rms'] / r['fixed_rms'])} |" if joint else ""))
    if data.get("recovery"):
        lines += ["", "## 6. Recovery of known scheme parameters", "",
                  f"Curves made in numpy from a wobbly-ellipse control polygon of "
                  f"{RECOVERY_N} points and known parameters (refinement by the published "
                  f"rules, exact limit points at {RECOVERY_LEVELS} levels); {M} samples at "
                  "uneven spacing (3:1), the first between control points; `fit_params=True`"
                  f", n = {RECOVERY_N}, started at the far end of the range. Success: every "
                  "parameter within 1e-3 and the curve within 1e-6 of the size (two-sided "
                  "max distance between the dense fitted and true curves / the larger "
                  "bounding-box side). `floor`: the curve error of the fit with the "
                  "parameters held at the truth and started from the true polygon, which "
                  "no start can beat: a bias of the loss (its curve-to-samples half "
                  "counts distances to the samples' chords beyond a band, and curves of "
                  "low regularity bend beyond it between samples; `tests/test_fit.py` "
                  "measured it falling 11x or more with 4x the samples, except "
                  "1.2x for r, s = 0.6, 0.9). `held, default "
                  "start`: the same fit from the default (linear) start; where it is far "
                  "above `floor`, the control points stop in a local minimum even at the "
                  "true parameters, which no profile over the parameters can cure.", "",
                  "| scheme | success | parameters within 1e-3 |", "| --- | ---: | ---: |"]
        for k, v in s["recovery"].items():
            lines.append(f"| {k} | {v['success']} / {v['cases']} | "
                         f"{v['parameters']} / {v['cases']} |")
        lines += ["", "| scheme | true | start | fitted | parameter error | curve error / "
                  "size | floor | held, default start | steps | status | s |",
                  "| --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | --- | ---: |"]
        for r in data["recovery"]:
            show = lambda d: ", ".join(f"{k} = {v:.4g}" for k, v in d.items())  # noqa: E731
            lines.append(f"| {r['scheme']} | {show(r['truth'])} | {show(r['start'])} | "
                         f"{show(r['fitted'])} | {fmt(r['parameter_error'])} | "
                         f"{fmt(r['curve_error'])} | {fmt(r.get('floor'))} | "
                         f"{fmt(r.get('held_default_start'))} | "
                         f"{r['num_steps']} | {r['status']} | "
                         f"{r['seconds']:.1f} |")
    return "\n".join(lines) + "\n"


def git_revision(path):
    try:
        root = pathlib.Path(path).resolve().parent
        rev = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--",
                                "../fitting", "../jaxsubdiv"],
                               capture_output=True, text=True).stdout.strip()
        return rev + (f" (+{len(dirty.splitlines())} uncommitted files in fitting/, "
                      "jaxsubdiv/)" if dirty else " (clean)")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--smoke", action="store_true", help="tiny case, under a minute")
    parser.add_argument("--output", type=pathlib.Path, default=None, help="JSON path")
    parser.add_argument("--no-cache", action="store_true",
                        help="do not use jaxsubdiv's persistent compilation cache")
    parser.add_argument("--only", default="spread,params,recovery",
                        help="comma-separated sections to run: spread (tables 1-4), "
                             "params (5), recovery (6); default all")
    args = parser.parse_args()
    sections = set(args.only.split(","))
    if not sections <= {"spread", "params", "recovery"}:
        parser.error(f"--only takes spread, params, recovery; got {args.only!r}")
    output = args.output or RESULTS / ("fit_quality_smoke.json" if args.smoke
                                       else "fit_quality.json")
    output.parent.mkdir(parents=True, exist_ok=True)
    if not args.no_cache:
        js.enable_compilation_cache()
    check_numpy_curves()
    begin = time.perf_counter()
    log = lambda text: print(f"[{time.perf_counter() - begin:6.0f} s] {text}",  # noqa: E731
                             file=sys.stderr, flush=True)
    header = {
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs, {platform.node()}",
        "load_start": [round(x, 2) for x in os.getloadavg()],
        "jax": jax.__version__, "numpy": np.__version__,
        "fitting_file": fitting.__file__, "git": git_revision(fitting.__file__),
        "smoke": args.smoke,
    }
    shapes = outlines(args.smoke) if sections - {"recovery"} else {}
    log(f"{len(shapes)} outlines")
    # The smoke run compiles three programs (cubic B-spline n = 16, four-point fixed and
    # fitted n = 16; the recovery grid's samples share the fitted one's bucket).
    ns = (16,) if args.smoke else (32, 64)
    data = {"header": header, "outlines": list(shapes)}
    data["sections"] = sorted(sections)
    if "spread" in sections:
        data["spread"] = run_spread(shapes, ns, log)
    param_labels = (list(shapes)[:1] if args.smoke else
                    ["DejaVu Serif 'Q'", "STIXGeneral '&'", "skimage horse"])
    schemes = ("FourPoint",) if args.smoke else tuple(SCHEMES)
    if "params" in sections:
        data["params"] = run_params(shapes, param_labels, (16,) if args.smoke else (16, 32),
                                    1 if args.smoke else 3, log, schemes)
    if "recovery" in sections:
        data["recovery"] = run_recovery(1 if args.smoke else None, log, schemes)
    header["load_end"] = [round(x, 2) for x in os.getloadavg()]
    header["wall_seconds"] = time.perf_counter() - begin
    data["summary"] = summarise(data)
    output.write_text(json.dumps(data, indent=1, default=float))
    output.with_suffix(".md").write_text(markdown(data))
    log(f"wrote {output} and {output.with_suffix('.md')}")


if __name__ == "__main__":
    main()
