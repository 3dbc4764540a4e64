"""The `jaxsubdiv` command."""

import argparse
import sys
import time


# CLI name -> (constructor, the parameter options it takes)
_SCHEMES = {
    "chaikin": (lambda a: _js().Chaikin(), ()),
    "corner-cutting": (lambda a: _js().CornerCutting(a.r, a.s), ("r", "s")),
    "four-point": (lambda a: _js().FourPoint(a.w), ("w",)),
    "cubic-bspline": (lambda a: _js().CubicBSpline(), ()),
    "lane-riesenfeld": (lambda a: _js().LaneRiesenfeld(a.degree), ("degree",)),
    "split-tweak": (lambda a: _js().SplitTweak(a.t), ("t",)),
    "jarek": (lambda a: _js().Jarek(), ()),
    "daubechies": (lambda a: _js().Daubechies(), ()),
}
_DEFAULTS = {"r": 0.25, "s": 0.75, "w": 1 / 16, "t": 0.5, "degree": 3}


def _js():
    import jaxsubdiv

    return jaxsubdiv


def _scheme(args):
    """The scheme named by --scheme, with its parameter options (others are an error)."""
    make, takes = _SCHEMES[args.scheme]
    extra = [name for name in _DEFAULTS if getattr(args, name) is not None and name not in takes]
    if extra:
        raise ValueError(
            f"--{extra[0]} does not apply to --scheme {args.scheme}"
            + (f" (it takes {', '.join('--' + t for t in takes)})" if takes else "")
        )
    for name in takes:
        if getattr(args, name) is None:
            setattr(args, name, _DEFAULTS[name])
    return make(args)


def _add_scheme_options(parser, default):
    parser.add_argument("--scheme", default=default, choices=sorted(_SCHEMES),
                        help=f"subdivision scheme (default: {default})")
    parser.add_argument("--r", type=float, help="corner-cutting ratio r (default 1/4)")
    parser.add_argument("--s", type=float, help="corner-cutting ratio s (default 3/4)")
    parser.add_argument("--w", type=float, help="four-point tension w (default 1/16)")
    parser.add_argument("--t", type=float, help="split-tweak parameter t (default 1/2)")
    parser.add_argument("--degree", type=int, help="Lane-Riesenfeld degree (default 3)")


def _read_inputs(args):
    js = _js()
    if (args.input is None) == (args.shape is None):
        raise ValueError("give an INPUT file or --shape NAME (one of them)")
    if args.shape is not None:
        return [js.io.Outline(points=js.shapes.get(args.shape), closed=True)]
    return js.io.read_outlines(args.input)


def _refine(args) -> int:
    import numpy as np

    js = _js()
    scheme = _scheme(args)
    outlines = _read_inputs(args)
    refined = []
    for outline in outlines:
        boundary = args.boundary or ("closed" if outline.closed else "open")
        points = np.asarray(js.refine(outline.points, scheme, args.levels, boundary=boundary))
        refined.append(js.io.Outline(points=points, closed=boundary == "closed"))
        print(f"{len(outline.points)} -> {len(points)} points ({boundary})")
    if args.output:
        js.io.write_outlines(args.output, refined)
        print(f"wrote {args.output}")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 6))
        for before, after in zip(outlines, refined):
            close = lambda o: np.vstack([o.points, o.points[:1]]) if o.closed else o.points
            ax.plot(*close(before).T, "o--", ms=3, lw=0.8, color="0.6")
            ax.plot(*close(after).T, lw=1.4, color="tab:blue")
        ax.set_aspect("equal")
        ax.set_title(f"{args.scheme}, {args.levels} levels", fontsize=9)
        fig.savefig(args.plot, dpi=120, bbox_inches="tight")
        print(f"wrote {args.plot}")
    return 0


def _analyze(args) -> int:
    print(_js().analyze(_scheme(args)))
    return 0


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
    outlines = js.io.read_outlines(text=args.text, font="DejaVu Sans", samples=args.samples)
    # A glyph with holes has several contours: fit the outer one (the largest).
    target = max((o.points for o in outlines), key=lambda p: np.ptp(p, axis=0).prod())
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


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line on stderr and exit status 2."""

    def error(self, message):
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        sys.exit(2)


def main(argv=None) -> int:
    parser = _Parser(
        prog="jaxsubdiv", description="Differentiable subdivision curves: refine, analyze, fit."
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    refine = sub.add_parser("refine", help="refine an outline file or a built-in shape")
    refine.add_argument("input", nargs="?", help="CSV/TXT, NPY/NPZ, JSON, SVG or PNG outline")
    refine.add_argument("--shape", help="a built-in shape instead of INPUT (jaxsubdiv.shapes)")
    _add_scheme_options(refine, "cubic-bspline")
    refine.add_argument("--levels", type=int, default=5, help="refinement levels (default: 5)")
    refine.add_argument("--boundary", choices=["closed", "open", "clamped"],
                        help="default: closed for closed outlines, open otherwise")
    refine.add_argument("--output", "-o", help="file for the refined points (format by suffix)")
    refine.add_argument("--plot", help="PNG of the polygon and the refined curve")
    refine.set_defaults(run=_refine)
    analyze = sub.add_parser("analyze", help="eigenvalues, stencils and smoothness of a scheme")
    _add_scheme_options(analyze, "four-point")
    analyze.set_defaults(run=_analyze)
    demo = sub.add_parser(
        "demo", help="fit a subdivision curve to a glyph's outline; print its error, plot it"
    )
    demo.add_argument("--text", default="S", help="the glyph to fit (default: S)")
    demo.add_argument("--n", type=int, default=32, help="control points (default: 32)")
    demo.add_argument("--samples", type=int, default=400, help="outline samples (default: 400)")
    demo.add_argument("--output", "-o", default="demo.png", help="PNG to write (default: demo.png)")
    demo.set_defaults(run=_demo)
    args = parser.parse_args(argv)
    import jax

    # Files and analysis in float64 (an application may set this; the library does not).
    jax.config.update("jax_enable_x64", True)
    try:
        return args.run(args)
    except (ValueError, TypeError, OSError) as e:
        print(f"jaxsubdiv {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
