"""`jaxsubdiv edit [INPUT]`: the interactive editor from the command line.

Wired into `jaxsubdiv._cli` with `add_parser(subparsers)`; `run(args)` returns the exit
status (a `ValueError`/`OSError` it raises becomes one line on stderr and status 2 there).
"""

import argparse


_CURVE_NAMES = ("cubic-bspline", "four-point", "jarek", "chaikin", "corner-cutting")
_FIT_SCHEMES = _CURVE_NAMES
# The editor's curves are registry schemes; its "jarek" curve is the split-and-tweak
# family with a t slider (t = 1/2 is Jarek's scheme), so --scheme jarek fits SplitTweak(t).
_REGISTRY_NAME = {"jarek": "split-tweak"}
# The parameters the editor has sliders for, each with an option of its name.
_PARAMETER_SCHEMES = ("four-point", "corner-cutting", "split-tweak")


def _parameters():
    """The declared parameters of the editor's schemes (no JAX import)."""
    from ._scheme.registry import declarations

    declared = declarations()
    return [p for name in _PARAMETER_SCHEMES for p in declared[name].parameters]


def _number(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _check_parameters(args) -> None:
    """Each of --w, --r, --s, --t in its declared range and where its scheme converges
    (the editor draws limit curves; one line naming the option), and corner cutting's
    r < s."""
    for p in _parameters():
        value = getattr(args, p.name)
        if not bool(p.valid(value)):
            raise ValueError(
                f"--{p.name} {_number(value)} is out of range: {p.label} needs "
                f"{p.range_text()}"
            )
        if not bool(p.converges_at(value)):
            raise ValueError(
                f"--{p.name} {_number(value)} is out of range: the editor draws limit "
                f"curves, and {p.label} converges only for {p.converges_text()}"
            )
    from ._scheme.registry import scheme_info

    try:  # the relation between the ratios, as the constructor checks it
        scheme_info("corner-cutting").make(r=args.r, s=args.s)
    except ValueError as e:
        raise ValueError(f"--r {_number(args.r)}, --s {_number(args.s)}: {e}") from None


def _curves(text: str) -> tuple[str, ...]:
    names = tuple(name.strip() for name in text.split(",") if name.strip())
    bad = [name for name in names if name not in _CURVE_NAMES]
    if bad:
        raise argparse.ArgumentTypeError(
            f"unknown curve {bad[0]!r}; choose from {', '.join(_CURVE_NAMES)}"
        )
    return names


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the `edit` subcommand to an argparse `subparsers` object and return it."""
    parser = subparsers.add_parser(
        "edit",
        help="interactive editor: drag control points, watch the curves and their smoothness",
        description=(
            "Open the interactive subdivision-curve editor on INPUT (its largest outline "
            "becomes the control polygon), a built-in --shape, or a default star. With "
            "--fit, fit --n control points to the outline first and edit the fit. With "
            "--png, draw the editor into a PNG and exit (no display needed). Keys: press h "
            "in the window; see docs/editor.md."
        ),
    )
    parser.add_argument("input", nargs="?", help="CSV/TXT, NPY/NPZ, JSON, SVG or PNG outline")
    parser.add_argument("--shape", help="a built-in shape instead of INPUT (jaxsubdiv.shapes)")
    parser.add_argument("--fit", action="store_true",
                        help="fit the outline with --n control points, then edit the fit")
    parser.add_argument("--n", type=int, default=16,
                        help="control points of the fit (with --fit; default: 16)")
    parser.add_argument("--scheme", default="cubic-bspline", choices=_FIT_SCHEMES,
                        help="scheme fitted with --fit (default: cubic-bspline)")
    parser.add_argument("--samples", type=int,
                        help="resample the outline to this many points by arc length "
                        "(default: as given; with --fit, a --shape or an SVG at 400)")
    parser.add_argument("--outline", type=int,
                        help="which outline of a file with several, counted from 1 as "
                        "`jaxsubdiv fit` reports contours (default: the largest)")
    parser.add_argument("--open", action="store_true",
                        help="edit an open polygon (the curves end at its end points)")
    parser.add_argument("--curves", type=_curves, default=("cubic-bspline", "four-point", "jarek"),
                        help="comma-separated curves shown at the start (default: "
                             "cubic-bspline,four-point,jarek; others: chaikin,corner-cutting)")
    parser.add_argument("--levels", type=int, default=5, help="refinement level 0-9 (default: 5)")
    from ._scheme.parameter import number_text

    for p in _parameters():
        parser.add_argument(
            f"--{p.name}", type=int if p.integer else float, default=p.default,
            help=f"{p.help} (default {number_text(p.default)}; "
                 f"{p.converges_text() or p.range_text()})",
        )
    parser.add_argument("--save-prefix", default="jaxsubdiv-edit",
                        help="path prefix of the files the s key writes (default: jaxsubdiv-edit)")
    parser.add_argument("--png", help="write a picture of the editor to this PNG and exit")
    parser.set_defaults(run=run)
    return parser


def _interactive_backend() -> bool:
    import matplotlib
    from matplotlib.backends import BackendFilter, backend_registry

    backend = matplotlib.get_backend().lower()
    return backend not in backend_registry.list_builtin(BackendFilter.NON_INTERACTIVE)


def run(args) -> int:
    """Run `jaxsubdiv edit` with parsed arguments; returns the exit status."""
    import jax

    # Files and analysis in float64, like the other commands (an application may set
    # this; the library does not).
    jax.config.update("jax_enable_x64", True)
    import numpy as np

    import jaxsubdiv as js

    from ._editor import Editor

    if args.input is not None and args.shape is not None:
        raise ValueError("give an INPUT file or --shape NAME, not both")
    if args.fit and args.input is None and args.shape is None:
        raise ValueError("--fit needs an INPUT file or --shape NAME to fit")
    _check_parameters(args)
    if not 0 <= args.levels <= 9:
        raise ValueError(f"--levels must be from 0 to 9, got {args.levels}")
    if args.n < 3:
        raise ValueError(f"--n must be at least 3, got {args.n}")
    figure = None
    if args.png:
        # Drawn off-screen: no pyplot window, no display, no change of backend.
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        figure = Figure(figsize=(11, 7.5))
        FigureCanvasAgg(figure)
    elif not _interactive_backend():
        raise ValueError(
            "no interactive matplotlib backend (no display?); use --png PATH to draw the "
            "editor into a file, or set MPLBACKEND (e.g. TkAgg, QtAgg)"
        )
    options = dict(
        curves=args.curves, levels=args.levels, w=args.w, r=args.r, s=args.s, t=args.t,
        save_prefix=args.save_prefix, figure=figure,
    )
    if args.shape is not None:
        from ._io.common import check_samples, resample_polyline

        points = np.asarray(js.shapes.get(args.shape))
        # As `jaxsubdiv fit --shape`: --samples resamples the shape, and a fit samples it
        # at 400 points by default (a star's 10 corners are fewer than a fit's unknowns).
        samples = check_samples(args.samples) or (400 if args.fit else None)
        if samples is not None:
            points = resample_polyline(points, samples, True)
        outlines = [js.io.Outline(points=points, closed=True)]
    elif args.input is not None:
        samples = args.samples
        if samples is None and args.fit and str(args.input).lower().endswith(".svg"):
            samples = 400  # as `jaxsubdiv fit`: a straight-line contour's corners are too few
        # A JSON point list is its own nodes; a saved result's (`fit -o x.json`, this
        # editor's save) are its control polygon: edited as it is, not its curve.
        nodes = not args.fit and samples is None and str(args.input).lower().endswith(".json")
        outlines = js.io.read_outlines(args.input, samples=samples, nodes=nodes)
    else:
        outlines = [js.io.Outline(points=np.asarray(js.shapes.get("star")), closed=True)]
    if args.outline is not None and not 1 <= args.outline <= len(outlines):
        raise ValueError(
            f"--outline must be in [1, {len(outlines)}] (the input has {len(outlines)} "
            f"outlines, counted from 1), got {args.outline}"
        )
    if args.outline is not None:
        chosen = outlines[args.outline - 1]
    else:
        chosen = max(outlines, key=lambda o: float(np.prod(np.ptp(o.points, axis=0))))
    if args.open:
        chosen = js.io.Outline(points=chosen.points, closed=False)
    if args.fit:
        info = js.scheme_info(_REGISTRY_NAME.get(args.scheme, args.scheme))
        scheme = info.make(**{p.name: getattr(args, p.name) for p in info.parameters})
        editor = Editor.from_fit(chosen, n_control=args.n, scheme=scheme, **options)
        print(editor.status)
    else:
        editor = Editor(chosen.points, closed=chosen.closed, **options)
    print(f"{len(editor.points)} control points, {editor.boundary}, level {editor.levels}")
    if args.png:
        editor.savefig(args.png, dpi=100)
        print(f"wrote {args.png}")
        return 0
    print("keys: press h in the window for help (docs/editor.md)")
    editor.show(block=True)
    return 0
