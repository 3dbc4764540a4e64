"""The `jaxsubdiv` command."""

import argparse
import sys
import time


def _demo(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    import jaxsubdiv as js

    polygon = js.shapes.get(args.shape)
    schemes = {
        "Chaikin": js.Chaikin(),
        "cubic B-spline": js.CubicBSpline(),
        "four-point (w=1/16)": js.FourPoint(),
        "Jarek (t=1/2)": js.Jarek(),
    }
    fig, ax = plt.subplots(figsize=(6, 6))
    closed = list(polygon) + [polygon[0]]
    ax.plot(*zip(*closed), "o--", color="0.6", label="control polygon")
    start = time.perf_counter()
    for label, scheme in schemes.items():
        curve = np.asarray(js.refine(polygon, scheme, args.levels))
        ax.plot(*np.vstack([curve, curve[:1]]).T, label=label)
        print(f"{label:22s} {len(polygon)} -> {len(curve)} points")
    print(f"refined in {time.perf_counter() - start:.2f} s (including compilation)")
    ax.set_aspect("equal")
    ax.legend(loc="lower left", fontsize=8)
    ax.set_title(f"'{args.shape}' refined {args.levels} levels")
    fig.savefig(args.output, dpi=120, bbox_inches="tight")
    print(f"wrote {args.output}")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="jaxsubdiv", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="refine a built-in shape with several schemes and plot it")
    demo.add_argument("--shape", default="star", help="built-in shape (default: star)")
    demo.add_argument("--levels", type=int, default=5, help="refinement levels (default: 5)")
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
