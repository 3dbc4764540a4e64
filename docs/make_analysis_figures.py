"""Regenerate the figures and the table of docs/analysis.md.

    python docs/make_analysis_figures.py          # writes docs/images/*.png, prints tables

Uses matplotlib with the Agg backend; each PNG stays well under 200 KB.
"""

import collections
import math
import pathlib
import time
import warnings

import jax
import matplotlib


matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import jaxsubdiv as js  # noqa: E402


jax.config.update("jax_enable_x64", True)
IMAGES = pathlib.Path(__file__).parent / "images"


def four_point_figure():
    """Hölder exponent against w over (-0.55, 0.55), beyond where the scheme converges;
    prints the brackets' widths, the methods and the time per value."""
    ws = np.linspace(-0.55, 0.55, 221)
    ws = np.sort(np.concatenate([ws, [1 / 16, (math.sqrt(5) - 1) / 8]]))
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", js.DivergenceWarning)  # |w| >= 1/2 on purpose
        results = [js.smoothness(js.FourPoint(w)) for w in ws]
    seconds = time.perf_counter() - start
    lo = np.array([r.holder_lower for r in results])
    hi = np.array([r.holder_upper for r in results])
    methods = collections.Counter(r.method for r in results)
    print(f"four-point, {len(ws)} values of w in [-0.55, 0.55]: {seconds:.1f} s, widest "
          f"bracket {np.max(hi - lo):.2g}, undecided {sum(not r.decided for r in results)}, "
          f"methods {dict(methods)}")
    converging = ws[[r.converges for r in results]]
    print(f"  converges for w in [{converging.min():.4f}, {converging.max():.4f}] of the grid")
    fig, ax = plt.subplots(figsize=(7, 5), dpi=100)
    ax.fill_between(ws, lo, hi, color="tab:blue", alpha=0.3, label="rigorous bounds")
    ax.plot(ws, lo, color="tab:blue", lw=1, label="Hölder exponent (exact where the polytope closes)")
    ax.axhline(1, color="k", lw=0.6)
    ax.axhline(0, color="k", lw=0.6)
    ax.axvspan(-0.25, 0.25, color="0.9", zorder=0, label="DLG 1987 sufficient |w| < 1/4")
    for end in (-0.5, 0.5):
        ax.axvline(end, color="tab:green", ls="--", lw=1,
                   label="converges exactly for |w| < 1/2" if end > 0 else None)
    ax.axvline((math.sqrt(5) - 1) / 8, color="tab:orange", ls="--", lw=1,
               label="DLG 1987 sufficient C1 bound (√5-1)/8")
    ax.axvline(0.19273, color="tab:red", ls=":", lw=1, label="C1 limit ≈ 0.19273 (HMR 2009)")
    ax.plot([1 / 16], [2], "ko", ms=4, label="w = 1/16: exponent 2")
    ax.set_xlabel("tension w")
    ax.set_ylabel("Hölder exponent of the basis function")
    ax.set_title("Four-point scheme: smoothness against w")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2)
    fig.tight_layout()
    fig.savefig(IMAGES / "analysis_four_point_holder.png")
    plt.close(fig)


def near_one_sixteenth():
    """The brackets at w = 1/16 +- 10^-k, where the symbol almost gains two factors."""
    from jaxsubdiv._analysis.smoothness import factor_symbol, transition_matrices

    print("four-point near w = 1/16:")
    for epsilon in (1e-3, 1e-4):
        w = 1 / 16 + epsilon
        _, q = factor_symbol(np.array([0, -w, 0, 0.5 + w, 1, 0.5 + w, 0, -w]))
        t0, t1 = transition_matrices(q)
        smp = np.abs(np.linalg.eigvals(t1 @ t0)).max() ** 0.5
        pair = max(np.linalg.eigvals(t0), key=lambda z: (abs(z), z.imag))
        print(f"  epsilon {epsilon:g}: (rho(T1 T0)^(1/2) - 1/2)/epsilon = "
              f"{(smp - 0.5) / epsilon:.2f}; T0's pair: (|z| - 1/2)/epsilon = "
              f"{(abs(pair) - 0.5) / epsilon:.2f}, turning {abs(np.angle(pair)):.4f} rad "
              f"= {abs(np.angle(pair)) / epsilon**0.5:.2f} sqrt(epsilon)")
    for k in range(3, 10):
        for sign in (1, -1):
            w = 1 / 16 + sign * 10.0**-k
            start = time.perf_counter()
            r = js.smoothness(js.FourPoint(w))
            print(f"  1/16 {'+-'[sign < 0]} 1e-{k}: [{r.holder_lower:.4f}, {r.holder_upper:.4f}] "
                  f"({r.method}, {time.perf_counter() - start:.2f} s)")


def split_tweak_ranges():
    """Where split-and-tweak is C^k: the class of 1,601 values of t in [-10, 8]."""
    ts = np.linspace(-10, 8, 1601)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", js.DivergenceWarning)
        results = [js.smoothness(js.SplitTweak(t)) for t in ts]
    classes = np.array([r.continuity for r in results])
    print(f"split-and-tweak, {len(ts)} values of t in [-10, 8]: widest bracket "
          f"{max(r.holder_upper - r.holder_lower for r in results):.2g}, undecided "
          f"{sum(not r.decided for r in results)}")
    for k in range(0, classes.max() + 1):
        inside = ts[classes >= k]
        print(f"  C^{k} for t in [{inside.min():.4g}, {inside.max():.4g}] of the grid "
              f"({'an interval' if len(inside) == np.ptp(np.flatnonzero(classes >= k)) + 1 else 'not an interval'})")


def corner_cutting_figure():
    grid = np.linspace(0.0, 1.0, 61)[1:-1]
    values = np.full((len(grid), len(grid)), np.nan)
    widest = 0.0
    for i, s in enumerate(grid):
        for j, r in enumerate(grid):
            if r < s:
                result = js.smoothness(js.CornerCutting(r, s))
                values[i, j] = result.holder_lower
                widest = max(widest, result.holder_upper - result.holder_lower)
    print(f"corner cutting, {np.isfinite(values).sum()} pairs: widest bracket {widest:.2g}")
    fig, ax = plt.subplots(figsize=(5.5, 4.5), dpi=100)
    mesh = ax.pcolormesh(grid, grid, values, shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="Hölder exponent (lower bound)")
    line = np.linspace(0, 0.5, 2)
    ax.plot(line, line + 0.5, "w--", lw=1.2, label="s - r = 1/2: the only C1 pairs")
    ax.plot([0.25], [0.75], "r*", ms=9, label="Chaikin (1/4, 3/4)")
    ax.plot([1 / 3], [2 / 3], "wx", ms=7, label="de Rham trisection (1/3, 2/3)")
    ax.set_xlabel("r")
    ax.set_ylabel("s")
    ax.set_title("Corner cutting: Hölder exponent over 0 < r < s < 1")
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(IMAGES / "analysis_corner_cutting_holder.png")
    plt.close(fig)


def table():
    schemes = [
        js.Chaikin(), js.CornerCutting(0.2, 0.65), js.CornerCutting(0.1, 0.6),
        js.CornerCutting(1 / 3, 2 / 3), js.FourPoint(1 / 16), js.FourPoint(0.1),
        js.CubicBSpline(), *[js.LaneRiesenfeld(d) for d in range(1, 7)], js.SplitTweak(0.3),
        js.Jarek(), js.Daubechies(),
    ]
    for s in schemes:
        print(js.analyze(s))
        if not s.is_primal and js.smoothness(s).converges:
            print("  vertex limit stencil", np.round(np.asarray(js.limit_stencil(s, at="vertex")), 6))
        print()


if __name__ == "__main__":
    IMAGES.mkdir(exist_ok=True)
    four_point_figure()
    near_one_sixteenth()
    split_tweak_ranges()
    corner_cutting_figure()
    table()
