"""The `jaxsubdiv` command: refine, fit, analyze, gallery and demo.

Every subcommand is added to the parser by an `_add_<name>(subparsers)` function listed
in `_COMMANDS`, and runs as `args.run(args)`, returning the exit status. Usage errors and
bad input (`ValueError`, `TypeError`, `OSError`, including `jaxsubdiv.io.OutlineError`)
are one line on stderr and exit status 2; any other exception is one line and status 3
(`_report`). Nothing prints a traceback unless JAXSUBDIV_TRACEBACK=1.
"""

import argparse
import contextlib
import os
import shlex
import sys
import time
import warnings
from pathlib import Path


# Scheme names, their parameters (the --r/--s/--w/--t/--degree options), defaults, ranges
# and help come from the scheme registry's declarations, read without importing JAX so
# that --help and usage errors stay fast (`jaxsubdiv._scheme.registry.declarations`).
# Points per contour for a built-in shape's polygon, and an SVG drawing's straight-line
# contours, when they are fitted (sampled along their edges: a polygon's corners alone
# are too few samples; refining uses the polygon itself).
_SHAPE_SAMPLES = 400


#: Phases of a closed contour's start the command searches by default (`--phases`;
#: `fitting.fit(phases=...)`, whose own default is 1): against one phase, on 76 fits of
#: real outlines the two-sided RMS was never higher by over 1% and lower by over 5% in
#: 31, curves of known polygons were recovered in 32 of 36 cases instead of 17, and a
#: first fit took 1.02x as long, a warm one 3.8x (`benchmarks/results/fit_phases.md`,
#: 2026-12-07 23:39 UTC).
COMMAND_PHASES = 4

def _js():
    import jaxsubdiv

    return jaxsubdiv


def _declarations():
    """The listed schemes' declarations by CLI name (no JAX import)."""
    from ._scheme.registry import declarations

    return declarations()


def _parameter_options() -> dict:
    """Option name -> the declared parameters of that name (one per scheme taking it)."""
    options = {}
    for declared in _declarations().values():
        for p in declared.parameters:
            options.setdefault(p.name, []).append(p)
    return options


def _fittable() -> list[str]:
    """The schemes whose parameters `fitting.fit(fit_params=True)` fits."""
    return [name for name, declared in _declarations().items()
            if any(p.fit_interval is not None for p in declared.parameters)]


def _number(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _checked_option(p, value):
    """`value` of option --<p.name>, or a one-line error naming the option and range."""
    if not bool(p.valid(value)):
        raise ValueError(
            f"--{p.name} {_number(value)} is out of range: {p.label} needs {p.range_text()}"
        )
    return value


def _make_scheme(name: str, values: dict):
    """The scheme `name` with option values (checked, each naming its option)."""
    declared = _declarations()[name]
    for p in declared.parameters:
        _checked_option(p, values[p.name])
    try:
        return declared.info().make(**values)
    except ValueError as e:  # a relation between parameters (corner cutting's r < s)
        given = ", ".join(f"--{k} {_number(v)}" for k, v in values.items())
        raise ValueError(f"{given}: {e}") from None


def _scheme(args):
    """The scheme named by --scheme, with its parameter options (others are an error)."""
    takes = [p.name for p in _declarations()[args.scheme].parameters]
    extra = [name for name in _parameter_options()
             if getattr(args, name) is not None and name not in takes]
    if extra:
        raise ValueError(
            f"--{extra[0]} does not apply to --scheme {args.scheme}"
            + (f" (it takes {', '.join('--' + t for t in takes)})" if takes else "")
        )
    for p in _declarations()[args.scheme].parameters:
        if getattr(args, p.name) is None:
            setattr(args, p.name, p.default)
    return _make_scheme(args.scheme, {name: getattr(args, name) for name in takes})


def _outside_convergence(args) -> bool:
    """Whether a parameter of --scheme lies outside the interval where the scheme
    declares it converges (`Parameter.converges`, the others at their defaults)."""
    return any(p.converges is not None and not p.converges_at(getattr(args, p.name))
               for p in _declarations()[args.scheme].parameters)


def _scheme_text(name: str, scheme) -> str:
    """`four-point (w=0.0625)`: the CLI name and the values of its parameters."""
    values = _declarations()[name].info().values(scheme)
    if not values:
        return name
    return f"{name} ({', '.join(f'{t}={float(v):.6g}' for t, v in values.items())})"


def _fitted_scheme_text(name: str, result) -> str:
    """`_scheme_text` of a fit's scheme, saying when `fit_params` kept the given values
    (`FitResult.params_held`)."""
    held = result.params_held is not None and bool(result.params_held)
    return _scheme_text(name, result.scheme) + (
        " (kept at the start: its fit had the lower rms error, or the only finite one)"
        if held else "")


def _option_help(parameters, default=None) -> str:
    """`four-point tension (default 1/16; any finite w, converges for -1/2 < w < 1/2)`,
    from the declarations."""
    from ._scheme.parameter import number_text

    return "; ".join(
        f"{p.help} (default {number_text(p.default if default is None else default)}; "
        f"{p.range_text()}"
        + (f", converges for {p.converges_text()}" if p.converges else "") + ")"
        for p in parameters
    )


def _add_scheme_options(parser, default):
    parser.add_argument("--scheme", default=default, choices=list(_declarations()),
                        help=f"subdivision scheme (default: {default})")
    for name, parameters in _parameter_options().items():
        parser.add_argument(f"--{name}", type=int if parameters[0].integer else float,
                            help=_option_help(parameters))


def _add_force_option(parser):
    parser.add_argument("--force", action="store_true",
                        help="allow an output to replace the input file, or two outputs "
                        "to share a name (refused otherwise)")


def _add_input_options(parser, shape_samples: str, curves: str = "SVG curves and glyphs 400"):
    parser.add_argument(
        "input", nargs="?",
        help="outline file: CSV/TXT (x,y per line), NPY/NPZ, JSON, SVG or PNG silhouette",
    )
    parser.add_argument("--shape", help="a built-in shape instead of INPUT (jaxsubdiv.shapes)")
    parser.add_argument("--text", help='the outlines of a text glyph instead of INPUT, e.g. "&"')
    parser.add_argument("--font", help="with --text: a matplotlib font family or font file "
                        "(default: DejaVu Sans)")
    parser.add_argument(
        "--samples", type=int,
        help=f"points per contour, equally spaced by arc length (default: {curves}; point "
        f"lists and images as they are; --shape {shape_samples})",
    )


def _read_inputs(args, shape_samples: int | None = None, nodes: bool = False):
    """The outlines of INPUT, --shape or --text (exactly one of them). `shape_samples`:
    points per contour for a built-in shape, a glyph and an SVG file's contours when
    --samples is not given (None: the shape's polygon, and an SVG's or a glyph's
    straight-line contours as their corners). `nodes`: without --samples, an SVG's and a glyph's
    contours are their nodes (the polygon it was drawn on) rather than samples."""
    js = _js()
    given = [
        name
        for name, value in (("INPUT", args.input), ("--shape", args.shape), ("--text", args.text))
        if value is not None
    ]
    if len(given) != 1:
        raise ValueError(
            "give one input: an INPUT file, --shape NAME or --text TEXT"
            + (f" (got {' and '.join(given)})" if given else "")
        )
    if args.font is not None and args.text is None:
        raise ValueError("--font applies only to --text")
    if args.shape is not None:
        from ._io.common import check_samples, resample_polyline

        points = js.shapes.get(args.shape)
        samples = check_samples(args.samples) or shape_samples
        if samples is not None:
            points = resample_polyline(points, samples, True)
        return [js.io.Outline(points=points, closed=True)]
    nodes = nodes and args.samples is None
    samples = args.samples
    if args.text is not None:
        # A glyph's straight contours too ('E', '.'): their corners alone are too few
        # samples to fit.
        return js.io.read_outlines(text=args.text, font=args.font,
                                   samples=samples if nodes else samples or shape_samples,
                                   nodes=nodes)
    if samples is None and not nodes and str(args.input).lower().endswith(".svg"):
        samples = shape_samples
    return js.io.read_outlines(args.input, samples=samples, nodes=nodes)


def _page_source(args):
    """The input file whose page an SVG output takes (an SVG or PNG INPUT), or None."""
    if args.input is not None and Path(args.input).suffix.lower() in (".svg", ".png"):
        return args.input
    return None


def _source(args) -> str:
    if args.shape is not None:
        return f"shape {args.shape!r}"
    if args.text is not None:
        return f"text {args.text!r} ({args.font or 'DejaVu Sans'})"
    return args.input


def _check_output(path, suffixes, what: str) -> None:
    """Fail before the work, not after it, on an output that cannot be written.
    `suffixes` may be a function that returns them (called only for a given path)."""
    if path is None:
        return
    suffixes = suffixes() if callable(suffixes) else suffixes
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in suffixes:
        raise ValueError(
            f"{what} {path}: unknown file type {Path(path).suffix or '(none)'!r}; use one of "
            + ", ".join("." + s for s in suffixes)
        )
    parent = Path(path).parent
    if not parent.is_dir():
        raise ValueError(f"{what} {path}: the directory {parent} does not exist")


def _picture_types():
    from matplotlib.figure import Figure

    return tuple(sorted(Figure().canvas.get_supported_filetypes()))


def _numbered(path: str, index: int, count: int) -> str:
    """`path` for one contour; `stem-<index>.suffix` when there are several."""
    if count == 1:
        return path
    p = Path(path)
    return str(p.with_name(f"{p.stem}-{index + 1}{p.suffix}"))


def _check_no_overwrite(args, outputs) -> None:
    """Refuse, before any work, to write over the input file or to write two outputs
    to one file (the first would be lost without a word), unless `--force`.

    `outputs`: (option, path) pairs of every file the command will write, with the
    numbered names of per-contour files already applied."""
    if args.force:
        return
    def same(a, b) -> bool:
        a, b = Path(a), Path(b)
        try:
            if a.exists() and b.exists():
                return a.samefile(b)
        except OSError:
            pass
        return a.resolve() == b.resolve()

    source = getattr(args, "input", None)
    for i, (option, path) in enumerate(outputs):
        if source is not None and same(path, source):
            raise ValueError(
                f"{option} {path} is the input file: writing it would replace the input; "
                "choose another output name, or add --force to overwrite it"
            )
        for other_option, other in outputs[:i]:
            if same(path, other):
                raise ValueError(
                    f"{other_option} and {option} both write {path}, and the second would "
                    "replace the first; give them different names, or add --force"
                )


def _no_contours(args, outlines) -> None:
    if not outlines:
        raise ValueError(f"{_source(args)}: no contours to work on (nothing was drawn)")


def _new_figure(figsize):
    import matplotlib

    matplotlib.use("Agg")  # no display is ever needed
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, dpi=100)


# ---------------------------------------------------------------------------- refine


@contextlib.contextmanager
def _memory_in_options(contour: str, doing: str, what: str):
    """A `MemoryBudgetError` of the library (which names `memory_budget` and `levels=`)
    said in the command's terms: its options, and its fixed budget."""
    from ._misc import MemoryBudgetError, format_bytes

    try:
        yield
    except MemoryBudgetError as e:
        limit = f"the command's memory limit of {format_bytes(e.budget)}"
        need = (f"about {format_bytes(e.need)}, above {limit}" if e.need is not None
                else f"more than {limit}")
        fewer = ("--levels " + str(e.most_levels) + " or fewer" if doing == "refining"
                 and e.most_levels is not None else
                 "fewer --levels" if doing == "refining" else
                 "fewer samples (--samples 2000, say) or fewer --levels")
        raise ValueError(
            f"{contour}{doing} {what} would need {need}: use {fewer}") from None


def _refine(args) -> int:
    import numpy as np

    js = _js()
    scheme = _scheme(args)
    _check_output(args.output, ("csv", "txt", "npy", "npz", "json", "svg"), "-o")
    _check_output(args.plot, _picture_types, "--plot")
    outlines = _read_inputs(args, nodes=True)
    _no_contours(args, outlines)
    _check_no_overwrite(args, [(o, p) for o, p in (("-o", args.output), ("--plot", args.plot))
                               if p])
    refined = []
    for i, outline in enumerate(outlines):
        boundary = args.boundary or ("closed" if outline.closed else "open")
        contour = f"contour {i + 1} of {len(outlines)}: " if len(outlines) > 1 else ""
        with _memory_in_options(contour, "refining", f"{len(outline.points):,} points by "
                                f"{args.levels} levels"):
            points = np.asarray(js.refine(outline.points, scheme, args.levels,
                                          boundary=boundary))
        if not np.all(np.isfinite(points)):
            # Refinement by weights far outside the scheme's range grows the points by a
            # factor per level until they overflow: no output, no picture of NaN.
            raise ValueError(
                f"{contour}the refined points overflow to inf or NaN by level {args.levels}: "
                f"the scheme's parameters are far outside the range where it converges "
                f"(the warning above says which, if any), or the coordinates are too large; "
                f"use parameters in that range, or fewer --levels")
        refined.append(js.io.Outline(points, boundary == "closed", outline.group))
        print(f"{len(outline.points)} -> {len(points)} points ({boundary})")
    if args.output:
        if args.output.lower().endswith(".svg"):
            refined = [js.io.Outline(o.points, o.closed, g)
                       for o, g in zip(refined, _shape_groups(refined))]
            js.io.write_outlines(args.output, refined, like=_page_source(args))
        else:
            js.io.write_outlines(args.output, refined)
        print(f"wrote {args.output}")
    if args.plot:
        figure = _new_figure((6, 6))
        ax = figure.add_subplot()
        for before, after in zip(outlines, refined):
            close = lambda o: np.vstack([o.points, o.points[:1]]) if o.closed else o.points
            ax.plot(*close(before).T, "o--", ms=3, lw=0.8, color="0.6")
            ax.plot(*close(after).T, lw=1.4, color="tab:blue")
        ax.set_aspect("equal")
        ax.set_title(f"{args.scheme}, {args.levels} levels", fontsize=9)
        figure.savefig(args.plot, dpi=120, bbox_inches="tight")
        print(f"wrote {args.plot}")
    return 0


def _add_refine(sub):
    refine = sub.add_parser(
        "refine", help="refine an outline file, a text glyph or a built-in shape",
        description=(
            "Refine the polygons of an outline file, a glyph or a built-in shape. An SVG "
            "drawing's and a glyph's polygons are their nodes (where their segments meet, "
            "as a vector editor shows them), unless --samples is given."
        ),
    )
    _add_input_options(refine, "its polygon as it is", "SVG files and glyphs: their nodes")
    _add_scheme_options(refine, "cubic-bspline")
    refine.add_argument("--levels", type=int, default=5, help="refinement levels (default: 5)")
    refine.add_argument("--boundary", choices=["closed", "open", "clamped"],
                        help="default: closed for closed outlines, open otherwise")
    refine.add_argument("--output", "-o", help="file for the refined points (format by suffix)")
    refine.add_argument("--plot", help="PNG of the polygon and the refined curve")
    _add_force_option(refine)
    refine.set_defaults(run=_refine)


# ---------------------------------------------------------------------------- fit


# XLA programs compiled or loaded from the persistent cache in this process, and the
# latter alone (JAX's monitoring events).
_COMPILED = {"programs": 0, "from_cache": 0}


def _count_compilation(event: str, duration: float, **_) -> None:
    if event == "/jax/core/compile/backend_compile_duration":
        _COMPILED["programs"] += 1


def _count_cache_hit(event: str, **_) -> None:
    if event == "/jax/compilation_cache/cache_hits":
        _COMPILED["from_cache"] += 1


def _compilations():
    """A function that says what preparing programs took since this call: "" (nothing),
    "compilation", or "loading compiled programs" (all from the cache)."""
    import jax

    if not _LISTENING:
        jax.monitoring.register_event_duration_secs_listener(_count_compilation)
        jax.monitoring.register_event_listener(_count_cache_hit)
        _LISTENING.append(True)
    start = dict(_COMPILED)

    def since():
        programs = _COMPILED["programs"] - start["programs"]
        loaded = _COMPILED["from_cache"] - start["from_cache"]
        if programs == 0:
            return ""
        return "loading compiled programs" if loaded == programs else "compilation"

    return since


_LISTENING: list = []


def _size(points) -> float:
    """The diagonal of the bounding box, without overflow or underflow at any scale."""
    import math

    import numpy as np

    with np.errstate(over="ignore"):
        return math.hypot(*np.ptp(points, axis=0).tolist())


def _counts_text(results) -> str:
    counts = sorted({int(r.control_points.shape[0]) for r in results})
    text = str(counts[0]) if len(counts) == 1 else f"{counts[0]}-{counts[-1]}"
    return f"{text} control points"


def _print_errors(result, size: float, elapsed: float, preparing: str) -> None:
    rms, worst = float(result.rms), float(result.max_error)
    print(f"  status     {result.message.split('.')[0]}")
    print(f"  steps      {int(result.num_steps)}")
    print(f"  rms error  {rms:.3g} ({rms / size:.2e} of the size; two-sided)")
    print(f"  max error  {worst:.3g} ({worst / size:.2e} of the size; two-sided)")
    print(f"  time       {elapsed:.2f} s" + (f" (including {preparing})" if preparing else ""))


def _pixel_error(result, points):
    """`fitting.pixel_error` of a fit, all inf for a fit whose curve is not finite (its
    status says why)."""
    import math

    import numpy as np

    import fitting

    if not np.all(np.isfinite(np.asarray(result.curve))):
        return fitting.PixelError(math.inf, math.inf, math.inf)
    return fitting.pixel_error(result, points)


def _free_programs_if_crowded(share: float = 0.5) -> bool:
    """`jax.clear_caches()` when this process's memory mappings pass `share` of the
    kernel's limit (`vm.max_map_count`, Linux). Every compiled fit program holds
    700-1,350 of them and the default limit is 65,530, so a file of many contours of
    different lengths, fitted to a tolerance, could reach it, and XLA then stops the
    process ("LLVM ERROR: Unable to allocate section memory"). Cleared, later fits load
    their programs again (from the compilation cache when it is on). Whether it
    cleared; False where /proc is not there."""
    try:
        with open("/proc/self/maps", "rb") as maps:
            used = sum(1 for _ in maps)
        with open("/proc/sys/vm/max_map_count") as limit:
            most = int(limit.read())
    except (OSError, ValueError):
        return False
    if used <= share * most:
        return False
    import jax

    jax.clear_caches()
    return True


def _padded_lengths(lengths: list[int]) -> list[int]:
    """The sample count each contour's fit is padded to (`fitting.fit(pad_to=...)`):
    the longest length of its group, contours grouped from the longest down, each group
    the lengths above half its longest. Contours of similar lengths share one compiled
    program, and none is padded to twice its length or more (padded to the longest of
    all, a 512 x 512 photo's contours of 214 samples ran at 9,812 and took 50x as long)."""
    padded, longest = [0] * len(lengths), None
    for i in sorted(range(len(lengths)), key=lambda i: -lengths[i]):
        if longest is None or 2 * lengths[i] <= longest:
            longest = lengths[i]
        padded[i] = longest
    return padded


def _on_one_line(points) -> bool:
    """Whether `points` lie on one line (or at one point), up to rounding: their spread
    across the line of best fit is at most 1e-9 of that along it."""
    import numpy as np

    centred = np.asarray(points, np.float64) - np.mean(points, axis=0)
    spread = np.linalg.svd(centred, compute_uv=False)
    return len(spread) < 2 or spread[1] <= 1e-9 * spread[0]


def _fit(args) -> int:
    import math

    import jax
    import numpy as np

    import fitting
    from fitting._tolerance import ladder_floor
    from jaxsubdiv._io.common import densify_polyline
    from jaxsubdiv.validation import check_creasable, min_points

    js = _js()
    scheme = _scheme(args)
    if args.fit_params and args.scheme not in _fittable():
        raise ValueError(
            f"--fit-params: --scheme {args.scheme} has no parameters to fit (these do: "
            f"{', '.join(_fittable())})"
        )
    if args.tolerance is not None:
        if args.n is not None:
            raise ValueError("--n and --tolerance: give one (--tolerance chooses the number "
                             "of control points per contour)")
        if not (math.isfinite(args.tolerance) and args.tolerance > 0):
            raise ValueError(f"--tolerance must be a number > 0 (in the input's units), "
                             f"got {args.tolerance}")
    elif args.n is None:
        args.n = 32
    if args.n is not None and args.n < 1:
        raise ValueError(f"--n must be at least 1, got {args.n}")
    if args.max_steps < 1:
        raise ValueError(f"--max-steps must be at least 1, got {args.max_steps}")
    if args.pin_ends and args.boundary == "closed":
        raise ValueError("--pin-ends: a closed curve has no ends; use --boundary open or "
                         "clamped (or leave --boundary out: open contours are fitted open)")
    _check_phases_option(args)
    if args.phases is not None and args.phases > 1:
        if args.fit_params:
            raise ValueError("--phases applies to fits without --fit-params (whose profile "
                             "starts from one phase); leave one of them out")
        if args.boundary in ("open", "clamped"):
            raise ValueError(f"--phases applies to closed contours (an open curve's ends "
                             f"fix its phase), not to --boundary {args.boundary}")
    _check_output(args.output, ("json", "csv", "txt", "npy", "npz", "svg"), "-o")
    _check_output(args.svg, ("svg",), "--svg")
    _check_output(args.plot, _picture_types, "--plot")
    outlines = _read_inputs(args, shape_samples=_SHAPE_SAMPLES)
    _no_contours(args, outlines)
    count = len(outlines)
    outputs = []
    if args.output:
        per_contour = args.output.lower().endswith(".json")
        outputs += [("-o", _numbered(args.output, i, count) if per_contour else args.output)
                    for i in range(count if per_contour else 1)]
    if args.svg:
        outputs.append(("--svg", args.svg))
    if args.plot:
        outputs.append(("--plot", args.plot))
    _check_no_overwrite(args, outputs)
    if args.output and args.output.lower().endswith(".npy") and count > 1:
        raise ValueError(
            f"-o {args.output}: a .npy file holds one curve and the input has {count} "
            "contours; use .npz, .csv, .txt, .svg or .json"
        )
    fitted = [p for p in _declarations()[args.scheme].parameters if p.fit_interval is not None]
    extra = len(fitted) if args.fit_params else 0
    # Each contour needs at least as many samples as unknowns (2 per control point, and
    # the fitted parameters). With --samples the user chose both numbers, and too few
    # is an error. Otherwise a small contour (a hole or a dot of an icon, a speck of a
    # traced image) gets fewer control points than --n, not a failed command: the
    # largest count of fitting.fit_tolerance's ladder it determines (so that such
    # contours share compiled programs). One too small even for the fewest control
    # points is resampled along its polyline to as many points as those need.
    counts, notes = [], {}
    for i, outline in enumerate(outlines):
        boundary = args.boundary or ("closed" if outline.closed else "open")
        smallest = max(4, min_points(scheme, boundary))
        if args.tolerance is None:
            smallest = min(smallest, args.n)  # a smaller --n is fitting.fit's to judge
        m = len(outline.points)
        n = args.n
        if args.samples is not None and m < 2 * (smallest if n is None else n) + extra:
            if n is None:
                raise ValueError(
                    f"--tolerance: contour {i + 1} has {m} points, fewer than the "
                    f"{2 * smallest + extra} unknowns of the smallest count searched "
                    f"({smallest} control points); use more --samples"
                )
            raise ValueError(
                f"--n {n} is too many control points for --samples {args.samples}: a contour "
                f"of {m} points has fewer than the {2 * n + extra} unknowns; use a smaller "
                "--n or more --samples"
            )
        if n is not None and m < 2 * n + extra:
            n = max(smallest, ladder_floor(max(4, (m - extra) // 2)))
            n = n if 2 * n + extra <= m else smallest
            if n != args.n:
                notes[i] = (f"{n} control points, not {args.n}: the contour's {m} samples "
                            f"determine at most {max(0, (m - extra) // 2)}")
        need = 2 * (smallest if n is None else n) + extra
        if m < need:
            points = densify_polyline(outline.points, need, boundary == "closed")
            outlines[i] = js.io.Outline(points=points, closed=outline.closed, group=outline.group)
            notes[i] = (notes.get(i, f"{n} control points") + f"; {need - m} points added "
                        f"along its polyline (its {m} kept), as many as the unknowns")
            if n is None:
                notes[i] = (f"{need - m} points added along its polyline (its {m} kept), as "
                            f"many as the unknowns of the fewest control points searched "
                            f"({smallest})")
        counts.append(n)
        if boundary == "closed" and _on_one_line(outline.points):
            hint = ("its points lie on one line, so a closed curve through them encloses "
                    "nothing; for a stroke, use --boundary open")
            notes[i] = f"{notes[i]}; {hint}" if i in notes else hint
    # A PNG's contours as traced (not resampled): in pixels, between pixel centres.
    traced_image = (args.input is not None and args.samples is None
                    and Path(args.input).suffix.lower() == ".png")
    print(
        f"fitting {_scheme_text(args.scheme, scheme)} curves with "
        + (f"{args.n} control points" if args.tolerance is None else
           f"the fewest control points within {args.tolerance:g} (max error"
           + ("; a PNG's traced contours against its pixels)" if traced_image else ")"))
        + f" to {_source(args)}: {count} contour{'s' if count > 1 else ''}"
        + (" (scheme parameters fitted too)" if args.fit_params else "")
    )
    if not args.fit_params and _outside_convergence(args):
        # A scheme with no limit curve (the warning above) fits a refined polygon: the
        # status below is the solver's. (Analyzed only outside the declared range: the
        # analysis takes up to 2 s for some values inside it.)
        verdict = js.smoothness(scheme)
        if not verdict.converges:
            print(f"  note       no {'' if verdict.decided else 'proven '}limit curve "
                  f"(jaxsubdiv.smoothness: {str(verdict).split(';')[0]}): the fit is of a "
                  "refined polygon, which changes with --levels")
    results, sizes, pinned, stop_reasons, pixel_errors = [], [], [], {}, {}
    searched = {}  # contour -> the phases its fit searched
    # Corners need a scheme whose closed curves take creases as data.
    try:
        check_creasable(scheme, "fit(corners=...)")
        creasable = True
    except ValueError:
        creasable = False
        if args.corners == "auto":
            print(f"  (smooth curves: corners need a primal scheme with a crease rule "
                  f"sampled at its control points, which {args.scheme} is not)")
    # Contours of similar lengths padded to one sample count: one compiled program each.
    pad_to = _padded_lengths([len(outline.points) for outline in outlines])
    for i, outline in enumerate(outlines):
        boundary = args.boundary or ("closed" if outline.closed else "open")
        pin_ends = args.pin_ends and boundary != "closed"
        size = _size(outline.points)
        print(
            f"contour {i + 1} of {count}: {len(outline.points)} samples, {boundary}"
            f"{' (ends pinned)' if pin_ends else ''}, size {size:.3g}"
        )
        if i in notes:
            print(f"  note       {notes[i]}")
        sys.stdout.flush()  # before the progress line on stderr
        _free_programs_if_crowded()
        start, compiles = time.perf_counter(), _compilations()
        corners = "auto" if args.corners == "auto" and creasable and boundary == "closed" else None
        if corners and (traced_image or args.tolerance is None):
            # A traced bitmap's corners are measured in pixels (its staircase rounds
            # them over about one); strongest first.
            corners = fitting.find_corners(outline.points, pixel=1.0 if traced_image else None)
            if args.tolerance is None and len(corners) > counts[i]:
                # More corners than control points: creasing every control point would
                # make a polygon through the strongest (a photo's silhouette: 156
                # corners, 32 creases, max error 122 px against 17 px smooth).
                print(f"  note       {len(corners)} corners found, more than the {counts[i]} "
                      "control points: fitted without corners (use a larger --n, or "
                      "--tolerance)")
                corners = None
        phases = _phases(args, boundary)
        options = dict(
            levels=args.levels, boundary=boundary, pin_ends=pin_ends,
            fit_params=bool(args.fit_params), max_steps=args.max_steps,
            progress=False if args.quiet else "time", pad_to=pad_to[i], corners=corners,
            phases=phases,
        )
        # A traced contour's error is also measured against its pixels, which do not
        # charge the curve for the corners the contour cuts short; --tolerance then
        # bounds that one (fitting.pixel_error).
        pixels = (traced_image and boundary == "closed"
                  and fitting._pixels.traced_problem(outline.points) is None)
        measured = {}  # count -> its fit's pixel error
        fitting_what = (f"{len(outline.points):,} samples "
                        + (f"with {counts[i]} control points" if args.tolerance is None
                           else f"to --tolerance {args.tolerance:g}"))
        memory = _memory_in_options(f"contour {i + 1} of {count}: ", "fitting", fitting_what)
        if args.tolerance is None:
            with memory:
                result = fitting.fit(outline.points, scheme, counts[i], on_failure="ignore",
                                     **options)
        else:
            tried = []

            def measure(n, r, tried=tried, points=outline.points, pixels=pixels,
                        measured=measured):
                if pixels:
                    measured[n] = _pixel_error(r, points)
                value = measured[n].max_error if pixels else float(r.max_error)
                tried.append(f"{n}: {value:.2g}")

            # The search's warning says why it stopped; it is printed with the failures.
            with warnings.catch_warnings(record=True) as caught, memory:
                warnings.simplefilter("always")
                result = fitting.fit_tolerance(
                    outline.points, scheme, args.tolerance, on_failure="warn",
                    error="pixel" if pixels else "max_error", on_trial=measure, **options,
                )
            stop_reasons[i] = next((str(w.message) for w in caught
                                    if str(w.message).startswith("fit_tolerance: ")), "")
            print(f"  control    {result.control_points.shape[0]} points ("
                  f"{'pixel' if pixels else 'max'} error by count tried: {', '.join(tried)})")
        result = jax.block_until_ready(result)
        # (A creased fit searches no phases: `fitting.fit`'s corners place the spans;
        # with --tolerance, `fit_tolerance` finds them.)
        searched[i] = 1 if phases is None or result.creases is not None else phases
        if args.phases is not None and args.phases > 1 and phases and searched[i] == 1:
            print(f"  note       --phases {args.phases} not searched: the corners place the "
                  "spans (--corners none fits a smooth curve from the phases)")
        if result.creases is not None:
            print(f"  corners    {int(np.sum(result.creases))} (creased control points)")
        elapsed = time.perf_counter() - start
        if args.fit_params:
            print(f"  scheme     {_fitted_scheme_text(args.scheme, result)}")
        # Contours whose sample counts share a bucket reuse the first one's program.
        _print_errors(result, size, elapsed, compiles())
        if pixels:
            against = (measured.get(result.control_points.shape[0])
                       or _pixel_error(result, outline.points))
            pixel_errors[i] = against.max_error
            print(f"  vs pixels  {against.max_error:.3g} px (max error against the pixels: "
                  f"pixel segments {against.max_segment_distance:.2g}, band of pixel "
                  f"cells {against.max_band_distance:.2g})")
        results.append(result)
        sizes.append(size)
        pinned.append(pin_ends)

    if args.output and args.output.lower().endswith(".json"):
        for i, (result, outline, size) in enumerate(zip(results, outlines, sizes)):
            path = _numbered(args.output, i, count)
            info = {
                "command": args.command_line,
                "input": _source(args),
                "contour": i + 1,
                "contours": count,
                "samples": len(outline.points),
                "size": size,
                "pin_ends": pinned[i],
                "phases": searched[i],
            }
            if i in pixel_errors:  # a traced PNG contour: fitting.pixel_error, in pixels
                value = pixel_errors[i]  # (JSON has no inf: a failed fit's is null)
                info["pixel_error"] = value if math.isfinite(value) else None
            js.io.write_result_json(path, result, info=info)
            print(f"wrote {path}")
    elif args.output and not args.output.lower().endswith(".svg"):
        curves = [
            js.io.Outline(points=np.asarray(r.curve, np.float64), closed=r.boundary == "closed")
            for r in results
        ]
        js.io.write_outlines(args.output, curves)
        print(f"wrote {args.output}")
    # An SVG output, by -o or --svg, is the fitted shape: exact curves where there are.
    for path in [p for p in (args.output, args.svg) if p and p.lower().endswith(".svg")]:
        exact = js.io.write_curve_svg(
            path, [np.asarray(r.control_points) for r in results],
            [r.scheme for r in results], boundary=[r.boundary for r in results],
            groups=_shape_groups(outlines), like=_page_source(args),
            creases=[None if r.creases is None else np.flatnonzero(np.asarray(r.creases))
                     .tolist() for r in results],
        )
        kind = "exact Bezier segments" if exact else "polylines of exact limit points"
        print(f"wrote {path} ({kind}, {_shapes(outlines)})")
    if args.plot:
        from .plot import plot_fit

        figure = _new_figure((6.5, 6))
        ax = figure.add_subplot()
        top = max(float(r.max_target_to_curve) for r in results)
        drawn = [plot_fit(result, outline.points, ax, colorbar=i == count - 1,
                          vmax=top or None, legend=False)
                 for i, (result, outline) in enumerate(zip(results, outlines))]
        # One legend for all contours, below the axes (it covers no data there).
        many = count > 1
        ax.legend(
            [drawn[0].curve, drawn[0].control, drawn[0].samples],
            ["limit curves" if many else "limit curve",
             _counts_text(results) + (" per contour" if many else ""),
             f"{sum(len(o.points) for o in outlines)} samples"
             + (f" in {count} contours" if many else "")],
            loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=3, fontsize=7,
            frameon=False,
        )
        worst = max(float(r.rms) / s for r, s in zip(results, sizes))
        largest = max(float(r.max_error) / s for r, s in zip(results, sizes))
        ax.set_title(
            f"{_scheme_text(args.scheme, results[0].scheme)}, {_counts_text(results)}"
            + (f" per contour, {count} contours" if many else "")
            + f"\ntwo-sided rms {worst:.1e}, max {largest:.1e} of the size"
            + (" (the worst contour)" if many else "")
            + f"\ncolours: each sample's distance to the curve (largest {top:.2g})",
            fontsize=8,
        )
        figure.savefig(args.plot, dpi=130, bbox_inches="tight")
        print(f"wrote {args.plot}")
    failed = [i for i, r in enumerate(results) if not bool(r.converged)]
    for i in failed:
        if results[i].message.startswith("tolerance_not_reached"):
            why = stop_reasons.get(i, "").removeprefix("fit_tolerance: ").split("; ")[0]
            kind, value = (("pixel error", pixel_errors[i]) if i in pixel_errors
                           else ("max error", float(results[i].max_error)))
            print(
                f"jaxsubdiv fit: contour {i + 1} of {count}: no count of control points tried "
                f"fitted within --tolerance {args.tolerance:g} ({why}); its result is the fit "
                f"of smallest {kind} ({value:.3g}, "
                f"{results[i].control_points.shape[0]} control points)", file=sys.stderr,
            )
            continue
        print(
            f"jaxsubdiv fit: contour {i + 1} of {count} did not converge "
            f"({results[i].message.split('. ')[0]}) after {int(results[i].num_steps)} steps",
            file=sys.stderr,
        )
    return 1 if failed else 0


def _shape_groups(outlines) -> list[int]:
    """The shape of each contour, for SVG output: the reader's groups. A point list
    (CSV, NPY, ...) has no shapes: its closed contours are taken as one shape filled
    even-odd, as a glyph's outline and its holes are (overlapping closed contours then
    cancel where they overlap), and each open contour is a stroked shape of its own."""
    known = [o.group for o in outlines if o.group is not None]
    fresh = iter(range(max(known, default=-1) + 1, 2**62))
    closed = next(fresh)
    return [o.group if o.group is not None else closed if o.closed else next(fresh)
            for o in outlines]


def _shapes(outlines) -> str:
    """'1 shape', '3 shapes': how many `<path>`s an SVG of these outlines has."""
    count = len(set(_shape_groups(outlines)))
    return f"{count} shape{'s' if count != 1 else ''}"


def _add_fit(sub):
    fit = sub.add_parser(
        "fit", help="fit a subdivision curve to every contour of an outline",
        description=(
            "Fit a subdivision curve's control polygon (and optionally the scheme's "
            "parameters) to each contour of an outline file, a glyph or a built-in shape. "
            "Prints the two-sided rms and max error of each fit, absolute and relative to "
            "the contour's size (its bounding-box diagonal). Exit status: 0 if every "
            "contour converged (and, with --tolerance, met it), 1 if some did not, 2 for "
            "bad input."
        ),
    )
    _add_input_options(fit, f"{_SHAPE_SAMPLES} along its edges")
    _add_scheme_options(fit, "cubic-bspline")
    fit.add_argument("--n", type=int,
                     help="control points per contour (default: 32, unless --tolerance)")
    fit.add_argument("--tolerance", type=float,
                     help="instead of --n: the fewest control points per contour whose "
                     "two-sided max error is within this distance, in the input's units; "
                     "for a PNG, in pixels and against its pixels (fitting.pixel_error: "
                     "corners its traced contour cuts short are not charged); counts from "
                     "4, 5, 6, 7, 8, 10, 12, ... up to a quarter of the contour's samples")
    fittable = "; ".join(
        f"{name} " + ", ".join(p.name for p in _declarations()[name].parameters
                               if p.fit_interval is not None)
        for name in _fittable()
    )
    fit.add_argument("--fit-params", action="store_true",
                     help=f"also fit the scheme's parameters ({fittable}): the best of a few "
                     "values held fixed (and the given ones), then refined jointly")
    fit.add_argument("--levels", type=int,
                     help="levels of the limit-curve polyline the errors are measured to "
                     "(default: enough for max(1024, 4 x samples) points)")
    fit.add_argument("--boundary", choices=["closed", "open", "clamped"],
                     help="default: closed for closed contours, open otherwise")
    fit.add_argument("--phases", type=int,
                     help="closed contours without corners (and without --fit-params): fit "
                     "from this many starts, the control polygon's phase along the samples "
                     "shifted by equal fractions of a span, and keep the one of least "
                     f"two-sided RMS (default {COMMAND_PHASES}; against 1, known curves "
                     "were recovered twice as often and no real outline fitted worse by "
                     "over 1%%, in about 4x the time of a warm fit: docs/fitting.md, 'Phase "
                     "of the start')")
    fit.add_argument("--pin-ends", action="store_true",
                     help="open and clamped contours start at their first sample and end "
                     "at their last, exactly (closed contours have no ends)")
    fit.add_argument("--corners", choices=["auto", "none"], default="auto",
                     help="auto (default): corners found in closed contours (turning by 50 "
                     "degrees or more over 3 sample spacings; for a PNG, between the chords "
                     "from 1 to 4 pixels on each side) become creased control points, "
                     "which the curve passes through with a corner; none: smooth curves. "
                     "Primal schemes (cubic-bspline, four-point, split-tweak, jarek)")
    fit.add_argument("--max-steps", type=int, default=500,
                     help="solver step limit per contour (default: 500)")
    fit.add_argument("--output", "-o",
                     help=".json: the result (scheme, parameters, control points, errors; "
                     "one file per contour, numbered, when there are several); .csv, .txt, "
                     ".npy or .npz: the fitted curves' points; .svg: as --svg")
    fit.add_argument("--svg", help="SVG of the fitted shape: one file, one path per shape of "
                     "the input (holes kept, even-odd fill), exact Bezier segments for "
                     "cubic-bspline, chaikin and lane-riesenfeld up to degree 3; an SVG or PNG "
                     "input's page and coordinates")
    fit.add_argument("--plot", help="picture (PNG, PDF, ...) of the fit: samples colored by "
                     "their distance to the curve, control polygon, curve")
    fit.add_argument("--quiet", "-q", action="store_true",
                     help="no progress display on stderr while fitting")
    _add_force_option(fit)
    fit.set_defaults(run=_fit)


# ---------------------------------------------------------------------------- analyze


def _analyze(args) -> int:
    print(_js().analyze(_scheme(args)))
    return 0


def _add_analyze(sub):
    analyze = sub.add_parser(
        "analyze", help="eigenvalues, stencils and smoothness of a scheme",
        description="Print a scheme's mask, eigenvalues, limit and tangent stencils and "
        "smoothness (jaxsubdiv.analyze).",
    )
    _add_scheme_options(analyze, "four-point")
    analyze.set_defaults(run=_analyze)


# ---------------------------------------------------------------------------- gallery


# The seed paper's figures (Alam 2025, "Study of subdivision curve schemes ..."):
# (shape, scheme, figure). Shapes it does not draw get all three schemes.
_PAPER_ROWS = (
    ("jar", "chaikin", "3.2"),
    ("mango", "chaikin", "3.3"),
    ("pi", "chaikin", "3.4"),
    ("car", "chaikin", "3.5"),
    ("rabbit", "corner-cutting", "4.2"),
    ("hand", "corner-cutting", "4.3"),
    ("pi", "corner-cutting", "4.4"),
    ("U", "four-point", "5.2"),
    ("mug", "four-point", "5.3"),
    ("pi", "four-point", "5.4"),
)
_PAPER_SCHEMES = ("chaikin", "corner-cutting", "four-point")
# The paper's corner-cutting ratios (its figures 4.2-4.4), where the schemes' own
# defaults (1/4, 3/4) would be Chaikin again.
_GALLERY_DEFAULTS = {"r": 0.3, "s": 0.7}


def _gallery_rows(shapes):
    """(shape, scheme, figure) rows: the paper's figures in order, then other shapes."""
    rows = [row for row in _PAPER_ROWS if row[0] in shapes]
    drawn = {row[0] for row in _PAPER_ROWS}
    for shape in shapes:
        if shape not in drawn:
            rows += [(shape, scheme, None) for scheme in _PAPER_SCHEMES]
    return rows


def _gallery(args) -> int:
    js = _js()
    from .plot import plot_levels

    if args.max_points < 1:
        raise ValueError(f"--max-points must be at least 1, got {args.max_points}")
    if args.dpi < 1:
        raise ValueError(f"--dpi must be at least 1, got {args.dpi}")
    names = js.shapes.names()
    shapes = names
    if args.shapes:
        shapes = list(dict.fromkeys(s for item in args.shapes for s in item.split(",") if s))
    unknown = [s for s in shapes if s not in names]
    if unknown:
        raise ValueError(f"--shapes: unknown shape {unknown[0]!r}; the built-in shapes are "
                         f"{', '.join(names)}")
    schemes = {
        name: _make_scheme(name, {p.name: getattr(args, p.name)
                                  for p in _declarations()[name].parameters})
        for name in _PAPER_SCHEMES
    }
    levels = args.levels
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    lines = [
        "# Refinement gallery",
        "",
        "The figure rows of the seed paper (Alam 2025, *Study of subdivision curve schemes "
        "and their impact on CAGD and computer graphics*, Figures 3.2-5.4), reproduced by "
        f"`{args.command_line}` with jaxsubdiv's built-in shapes: each row shows a control "
        f"polygon at levels {', '.join(map(str, levels))}.",
        "",
        f"How the levels are computed: a level with at most {args.max_points:,} points is "
        "refined with `jaxsubdiv.refine`. A deeper one (level 20 of a 20-point polygon has "
        "20,971,520 points) is drawn as exact points of the limit curve: "
        "`jaxsubdiv.limit_points(refine(P, k))` for the first level k with at least 4,096 "
        "points, which is what the level's polygon converges to. Each caption says how far "
        "the level's polygon still is from those points (extrapolated from levels k-1 and "
        "k) and compares that with a pixel.",
        "",
        "The schemes and the smoothness of their limit curves (`jaxsubdiv.smoothness`):",
        "",
        *(f"- {_scheme_text(name, scheme)}: {js.smoothness(scheme)}"
          for name, scheme in schemes.items()),
        "",
    ]
    rows = _gallery_rows(shapes)
    for shape, name, figure_number in rows:
        scheme = schemes[name]
        title = f"{shape}, {_declarations()[name].title}"
        levels_figure = plot_levels(js.shapes.get(shape), scheme, levels, title=title,
                                    max_points=args.max_points)
        file = f"{shape}-{name}.png"
        levels_figure.figure.savefig(out / file, dpi=args.dpi, bbox_inches="tight")
        source = f" (seed paper, Figure {figure_number})" if figure_number else ""
        lines += [
            f"## {title}{source}",
            "",
            f"![{title}]({file})",
            "",
            _sentence(levels_figure.caption.replace(f"{title}: ", "", 1)),
            "",
        ]
        print(f"wrote {out / file}")
    (out / "index.md").write_text("\n".join(lines))
    print(f"wrote {out / 'index.md'} ({len(rows)} rows)")
    return 0


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:]


def _level_list(text: str) -> list[int]:
    try:
        levels = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected levels separated by commas, such as 0,1,2,10,20; got {text!r}"
        ) from None
    if not levels or min(levels) < 0:
        raise argparse.ArgumentTypeError(f"levels must be >= 0, got {text!r}")
    return levels


def _add_gallery(sub):
    gallery = sub.add_parser(
        "gallery", help="the seed paper's refinement figures: one PNG row per shape and scheme",
        description=(
            "Draw each built-in shape with the seed paper's schemes (Chaikin: jar, mango, "
            "pi, car; corner cutting: rabbit, hand, pi; four-point: U, mug, pi; other shapes "
            "with all three) at several levels, one PNG row each, and an index.md with "
            "captions that say how each level was computed."
        ),
    )
    gallery.add_argument("--output", "-o", required=True, help="directory to write into")
    gallery.add_argument("--shapes", nargs="+", action="extend",
                         help="shapes to draw, by name (default: all built-in shapes)")
    gallery.add_argument("--levels", type=_level_list, default=[0, 1, 2, 10, 20],
                         help="levels, separated by commas (default: 0,1,2,10,20)")
    for name in _PAPER_SCHEMES:
        for p in _declarations()[name].parameters:
            default = _GALLERY_DEFAULTS.get(p.name, p.default)
            gallery.add_argument(f"--{p.name}", type=int if p.integer else float,
                                 default=default, help=_option_help([p], default))
    gallery.add_argument("--max-points", type=int, default=50_000,
                         help="deepest refinement computed outright, in points (default: "
                         "50000); deeper levels are drawn as limit points")
    gallery.add_argument("--dpi", type=int, default=100, help="PNG resolution (default: 100)")
    gallery.set_defaults(run=_gallery)


# ---------------------------------------------------------------------------- demo


def _check_phases_option(args) -> None:
    """`--phases` from 1 to `fitting`'s `MAX_PHASES`, or not given."""
    from fitting._checks import MAX_PHASES

    if args.phases is not None and not 1 <= args.phases <= MAX_PHASES:
        raise ValueError(f"--phases must be from 1 to {MAX_PHASES}, got {args.phases}")


def _phases(args, boundary: str) -> int | None:
    """The phases a contour's fit searches (`fitting.fit(phases=...)`): `--phases`, by
    default `COMMAND_PHASES` for a closed contour fitted without `--fit-params`; None
    (one) for open curves and fitted parameters, where the phases are not searched."""
    if boundary != "closed" or getattr(args, "fit_params", False):
        return None
    return COMMAND_PHASES if args.phases is None else args.phases


def _demo(args) -> int:
    import numpy as np

    import fitting
    import jaxsubdiv as js

    from .plot import plot_fit

    if args.samples < 4 * args.n:
        raise ValueError(f"--samples must be at least 4 x --n = {4 * args.n}")
    _check_phases_option(args)
    _check_output(args.output, _picture_types, "-o")
    phases = _phases(args, "closed")
    outlines = js.io.read_outlines(text=args.text, font="DejaVu Sans", samples=args.samples)
    # A glyph with holes has several contours: fit the outer one (the largest).
    target = max((o.points for o in outlines), key=lambda p: np.ptp(p, axis=0).prod())
    size = _size(target)
    print(
        f"fitting a closed cubic B-spline with {args.n} control points to the outline of "
        f"{args.text!r} (DejaVu Sans, {len(target)} samples, size {size:.3g})"
        + (f", the best of {phases} phases of the start" if phases > 1 else "")
    )
    sys.stdout.flush()  # before the progress lines on stderr
    start, compiles = time.perf_counter(), _compilations()
    result = fitting.fit(target, js.CubicBSpline(), args.n, on_failure="ignore",
                         progress=False if args.quiet else "time", phases=phases)
    rms, worst = float(result.rms), float(result.max_error)
    _print_errors(result, size, time.perf_counter() - start, compiles())

    figure = _new_figure((5.5, 6))
    artists = plot_fit(result, target, figure.add_subplot())
    artists.ax.set_title(
        f"cubic B-spline fit: rms {rms / size:.1e}, max {worst / size:.1e} of size", fontsize=9
    )
    figure.savefig(args.output, dpi=130, bbox_inches="tight")
    print(f"wrote {args.output}")
    return 0 if bool(result.converged) else 1


def _add_demo(sub):
    demo = sub.add_parser(
        "demo", help="fit a subdivision curve to a glyph's outline; print its error, plot it",
        description="Fit a closed cubic B-spline to the outer outline of a glyph (DejaVu "
        "Sans), print the status, steps and two-sided errors, and write a picture.",
    )
    demo.add_argument("--text", default="S", help="the glyph to fit (default: S)")
    demo.add_argument("--n", type=int, default=32, help="control points (default: 32)")
    demo.add_argument("--samples", type=int, default=400, help="outline samples (default: 400)")
    demo.add_argument("--phases", type=int,
                      help=f"starts to fit from, the control polygon's phase shifted by "
                      f"equal fractions of a span; the fit of least two-sided RMS is kept "
                      f"(default {COMMAND_PHASES}; 1 is faster: docs/fitting.md, 'Phase of "
                      f"the start')")
    demo.add_argument("--output", "-o", default="demo.png", help="PNG to write (default: demo.png)")
    demo.add_argument("--quiet", "-q", action="store_true",
                      help="no progress display on stderr while fitting")
    demo.set_defaults(run=_demo)


# ---------------------------------------------------------------------------- main


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line on stderr and exit status 2."""

    def error(self, message):
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        sys.exit(2)


# One `_add_<name>(subparsers)` per subcommand, in the order `--help` lists them.
def _add_edit(sub):
    from ._editor_cli import add_parser

    add_parser(sub)


_COMMANDS = [_add_refine, _add_fit, _add_analyze, _add_gallery, _add_edit, _add_demo]


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="jaxsubdiv",
        description="Differentiable subdivision curves: refine, fit, analyze, draw.",
        epilog="Compiled programs are kept on disk (JAX's persistent compilation cache, in "
        "~/.cache/jaxsubdiv/xla or $XDG_CACHE_HOME/jaxsubdiv/xla), so later runs start "
        "faster; set JAXSUBDIV_COMPILATION_CACHE to another folder, or to 'off'.",
    )
    parser.add_argument("--no-compilation-cache", action="store_true",
                        help="do not read or write the compilation cache in this run")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for add in _COMMANDS:
        add(sub)
    return parser


def main(argv=None) -> int:
    """Run the command with `argv` (default: `sys.argv[1:]`); return the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = _parser().parse_args(argv)
        args.command_line = shlex.join(["jaxsubdiv", *argv])
        from ._xla_flags import command_compile_flags

        with command_compile_flags():
            return _run(args)
    except BrokenPipeError:
        return _reader_gone()


def _reader_gone() -> int:
    """The exit status when the reader of the command's output went away
    (`jaxsubdiv edit ... | head`): no error line, as Unix tools stop quietly on a closed
    pipe; 141 (128 + SIGPIPE), the status a shell gives them. Standard output is pointed
    at the null device first, so that the interpreter's final flush of what is still
    buffered does not fail again (the recipe of Python's `signal` documentation)."""
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
    except (OSError, ValueError):  # no file descriptor (an in-memory stdout)
        pass
    return 141


def _run(args: argparse.Namespace) -> int:
    """Run the parsed command; its exit status (errors reported as `_report` says)."""
    import jax

    # Files, analysis and fits in float64 (an application may set this; the library
    # leaves JAX's global configuration alone).
    jax.config.update("jax_enable_x64", True)
    try:
        with warnings.catch_warnings():
            # A warning (e.g. a scheme built where it diverges) is one line, as errors are.
            warnings.showwarning = _one_line_warning(args.command)
            from ._scheme.parameter import DivergenceWarning

            warnings.simplefilter("default", DivergenceWarning)  # shown, not raised
            if not args.no_compilation_cache:
                _enable_cache(args.command)
            return args.run(args)
    except KeyboardInterrupt:
        print(f"jaxsubdiv {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        raise  # not an error of the command: `main` stops quietly
    except Exception as e:
        if os.environ.get("JAXSUBDIV_TRACEBACK", "") not in ("", "0"):
            raise
        return _report(args.command, e)


def _one_line_warning(command: str):
    """A `warnings.showwarning` that prints `jaxsubdiv <command>: warning: <message>`."""

    def show(message, category, filename, lineno, file=None, line=None):
        text = " ".join(str(message).split())
        print(f"jaxsubdiv {command}: warning: {text}", file=sys.stderr)

    return show


def _report(command: str, error: Exception) -> int:
    """One line on stderr for an error that stopped the command; its exit status.

    Bad input (`ValueError`, `TypeError`, `OSError`, with `jaxsubdiv.io.OutlineError`
    naming the file) is status 2, as are inputs too large to handle (`MemoryError`,
    `OverflowError`, `RecursionError`: the readers and kernels bound what they accept,
    so these are the last line of defence). Anything else is a defect of jaxsubdiv:
    status 3, and the line says how to see the traceback."""
    message = " ".join(str(error).split())  # always one line
    if isinstance(error, (ValueError, TypeError, OSError)):
        line, status = f"error: {message}", 2
    elif isinstance(error, MemoryError):
        line, status = ("error: not enough memory for this input; use fewer points "
                        "(--samples, --levels, a smaller image)"), 2
    elif isinstance(error, (OverflowError, RecursionError)):
        line, status = (f"error: the input is too large or too deeply nested to handle "
                        f"({type(error).__name__}: {message})"), 2
    else:
        line, status = (f"internal error ({type(error).__name__}: {message}); this is a bug "
                        "in jaxsubdiv: please report it with the command line (set "
                        "JAXSUBDIV_TRACEBACK=1 to see where it happened)"), 3
    print(f"jaxsubdiv {command}: {line}", file=sys.stderr)
    return status


def _enable_cache(command: str) -> None:
    """The persistent compilation cache, or one line on stderr saying why not."""
    from ._cache import enable_compilation_cache

    try:
        enable_compilation_cache()
    except OSError as e:
        message = " ".join(str(e).split())
        print(f"jaxsubdiv {command}: warning: {message}; running without it", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
