"""The `jaxsubdiv` command."""

import argparse
import sys
import time


def _glyph_outline(char: str, samples: int):
    """Outer contour of a DejaVu Sans glyph (bundled with matplotlib), `samples` points
    evenly spaced by arc length."""
    import numpy as np
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    if not char.strip():
        raise ValueError(f"--text {char!r} has no outline to fit; give a visible glyph")
    path = TextPath((0, 0), char, size=1.0, prop=FontProperties(family="DejaVu Sans"))
    polygons = path.to_polygons(closed_only=True)
    if not polygons:
        raise ValueError(f"the glyph {char!r} has no closed outline")
    outer = max(polygons, key=lambda p: np.ptp(p, axis=0).prod())
    closed = np.vstack([outer, outer[:1]]) if not np.allclose(outer[0], outer[-1]) else outer
    s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
    t = (np.arange(samples) + 0.5) / samples * s[-1]
    return np.stack([np.interp(t, s, closed[:, k]) for k in range(2)], axis=-1)


def _demo(args) -> int:
    import jax

    # Fitting is done in float64 (the command is an application; the library leaves
    # JAX's global configuration alone).
    jax.config.update("jax_enable_x64", True)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    import fitting
    import jaxsubdiv as js

    if args.samples < 4 * args.n:
        raise ValueError(f"--samples must be at least 4 x --n = {4 * args.n}")
    target = _glyph_outline(args.text, args.samples)
    size = float(np.linalg.norm(np.ptp(target, axis=0)))
    print(
        f"fitting a closed cubic B-spline with {args.n} control points to the outline of "
        f"{args.text!r} (DejaVu Sans, {len(target)} samples, size {size:.3g})"
    )
    start = time.perf_counter()
    result = fitting.fit(target, js.CubicBSpline(), args.n, on_failure="ignore")
    rms, worst = float(result.rms), float(result.max_error)
    elapsed = time.perf_counter() - start
    print(f"  status     {result.message.split('.')[0]}")
    print(f"  steps      {int(result.num_steps)}")
    print(f"  rms error  {rms:.3g} ({rms / size:.2e} of the size; two-sided)")
    print(f"  max error  {worst:.3g} ({worst / size:.2e} of the size; two-sided)")
    print(f"  time       {elapsed:.2f} s (including compilation)")

    curve = np.asarray(result.curve)
    control = np.asarray(result.control_points)
    fig, ax = plt.subplots(figsize=(5, 6))
    ax.plot(*target.T, ".", ms=2.5, color="0.55", label=f"{len(target)} samples")
    ax.plot(*np.vstack([control, control[:1]]).T, "o--", ms=3, lw=0.8, color="tab:orange",
            label=f"{args.n} control points")
    ax.plot(*np.vstack([curve, curve[:1]]).T, color="tab:blue", lw=1.5, label="limit curve")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=7)
    ax.set_title(f"cubic B-spline fit: rms {rms / size:.1e}, max {worst / size:.1e} of size",
                 fontsize=9)
    fig.savefig(args.output, dpi=130, bbox_inches="tight")
    print(f"wrote {args.output}")
    return 0 if bool(result.converged) else 1


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="jaxsubdiv", description="Differentiable subdivision curves: refine, analyze, fit."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser(
        "demo", help="fit a subdivision curve to a glyph's outline; print its error, plot it"
    )
    demo.add_argument("--text", default="S", help="the glyph to fit (default: S)")
    demo.add_argument("--n", type=int, default=32, help="control points (default: 32)")
    demo.add_argument("--samples", type=int, default=400, help="outline samples (default: 400)")
    demo.add_argument("--output", "-o", default="demo.png", help="PNG to write (default: demo.png)")
    demo.set_defaults(run=_demo)
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (ValueError, TypeError, OSError) as e:
        print(f"jaxsubdiv {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
