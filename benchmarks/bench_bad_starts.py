"""What `fit` reports from bad starts (and from good ones): status, error, Newton step.

    python benchmarks/bench_bad_starts.py           # 2-3 minutes on 2 cores
    python benchmarks/bench_bad_starts.py --smoke   # one glyph, two starts

Issue #14 asks that a fit from a hopeless start not be reported as converged. Each
glyph outline (DejaVu Sans 'S', 'g', '&' and 'a', 300 samples by arc length) is fitted
with 16 control points, closed cubic B-spline, float64, from its default start and
from four given `init`s built from 16 of its samples (every 18th): moved 10 sizes
diagonally, moved 10 sizes along x, scaled 10x about their centre, and a small circle
10 sizes away; and from two good (warm) starts: the default fit's control points moved
by Gaussian noise of 1% of the size, and the default fit of every other sample.
Recorded: the status, steps, two-sided RMS and `newton_step` (the
control points' distance to the optimum the local model estimates; inf where the
Hessian is not positive definite), both in units of the outline's size (the diagonal of
its bounding box), against the default start's RMS and against the linear start's (the
start taken without `init`, before any step: the same fit with max_steps=1).

A second table checks that good starts are not flagged more widely: 48 default fits
(DejaVu Sans and Serif 'S', 'g', 'a', 'Q', 'R', '8', '&' at n = 16 and 32, closed cubic
B-spline; 8 smooth blobs at n = 16; four glyphs with corners="auto", with smoothing
1e-3, and cut open at the first sample, at n = 16) each fitted again from its own
control points (a warm start at the optimum): the status, and the fit's RMS against
the linear start's (the start taken without `init`, the same fit with max_steps=1).

Writes `benchmarks/results/bad_starts.json` and `.md` (`--output` sets the JSON path).
"""

import pathlib
import sys


BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(BENCH), str(BENCH.parent)]
import _common  # noqa: E402


def glyph(char, m=300, family="DejaVu Sans"):
    import numpy as np
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    path = TextPath((0, 0), char, size=1.0, prop=FontProperties(family=family))
    outer = max(path.to_polygons(closed_only=True), key=lambda p: np.ptp(p, axis=0).prod())
    if np.allclose(outer[0], outer[-1]):
        outer = outer[:-1]
    closed = np.vstack([outer, outer[:1]])
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    t = np.linspace(0, s[-1], m, endpoint=False)
    return np.stack([np.interp(t, s, closed[:, k]) for k in range(2)], -1)


def starts(samples, size):
    import numpy as np

    c = samples[:: len(samples) // 16][:16]
    centre = c.mean(0)
    angle = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    circle = 0.3 * size * np.stack([np.cos(angle), np.sin(angle)], -1)
    return {"default": None, "moved 10 sizes": c + 10 * size,
            "moved 10 sizes along x": c + np.array([10 * size, 0.0]),
            "scaled 10x": centre + 10 * (c - centre),
            "circle 10 sizes away": centre + 10 * size + circle}


#: The good starts, from the default fit.
WARM = ("default fit + 1% noise", "fit of every other sample")


def warm_starts(samples, size, default):
    import numpy as np

    import fitting
    import jaxsubdiv as js

    noise = 0.01 * size * np.random.default_rng(0).standard_normal(default.shape)
    other = fitting.fit(samples[1::2], js.CubicBSpline(), 16).control_points
    return dict(zip(WARM, (default + noise, np.asarray(other))))


def markdown(run: dict) -> str:
    lines = [
        "# `fit` from bad starts (`bench_bad_starts.py`)", "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}; `fitting` at "
        f"{run['commit']}.", "",
        __doc__.split("\n\n", 2)[2].split("\n\nWrites")[0].replace("\n", " "), "",
        "| glyph | start | status | steps | RMS / size | RMS / default start's "
        "| RMS / linear start's | Newton step / size |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in run["rows"]:
        lines.append(f"| {row['glyph']} | {row['start']} | {row['status']} | {row['steps']} | "
                     f"{row['rms']:.3g} | {row['rms_ratio']:.3g} | "
                     f"{row['rms_over_linear']:.3g} | {row['newton']:.3g} |")
    bad = [r for r in run["rows"] if r["start"] not in ("default", *WARM)]
    warm = [r for r in run["rows"] if r["start"] in WARM]
    fooled = [r for r in bad if r["status"] == "successful" and r["rms_ratio"] > 2]
    flagged = [r for r in bad if r["status"] == "poor_local_minimum"]
    warm_failed = [r for r in warm if r["status"] != "successful"]
    warm_rows = run.get("at_optimum", [])
    lines += ["", "Warm starts at the optimum (each default fit fitted again from its "
              "control points):", "",
              "| outline | settings | n | status | RMS / linear start's |",
              "| --- | --- | ---: | --- | ---: |"]
    for row in warm_rows:
        lines.append(f"| {row['outline']} | {row['settings']} | {row['n']} | {row['status']} | "
                     f"{row['rms_over_linear']:.3g} |")
    flagged_warm = [r for r in warm_rows if r["status"] != "successful"]
    ratios = [r["rms_over_linear"] for r in warm_rows]
    if ratios:
        lines += ["", f"Not `successful`: {len(flagged_warm)} of {len(warm_rows)}; RMS over the "
                  f"linear start's {min(ratios):.3g}-{max(ratios):.3g}."]
    lines += ["", f"Bad starts reported `successful` with an RMS above twice the default "
              f"start's: {len(fooled)} of {len(bad)}; reported `poor_local_minimum`: "
              f"{len(flagged)} of {len(bad)}. Warm starts not `successful`: "
              f"{len(warm_failed)} of {len(warm)}.", ""]
    return "\n".join(lines)


def at_optimum() -> list[dict]:
    """Default fits fitted again from their own control points (see the docstring)."""
    import numpy as np

    import fitting
    import jaxsubdiv as js

    cases = [(f"{family} {char!r}", glyph(char, family=family), n, {})
             for family in ("DejaVu Sans", "DejaVu Serif") for char in "SgaQR8&"
             for n in (16, 32)]
    cases += [(f"blob {seed}", _common.blob(seed, 300), 16, {}) for seed in range(8)]
    for char in "Sga&":
        outline = glyph(char)
        cases += [(f"DejaVu Sans {char!r}", outline, 16, dict(corners="auto")),
                  (f"DejaVu Sans {char!r}", outline, 16, dict(smoothing=1e-3)),
                  (f"DejaVu Sans {char!r}", outline, 16, dict(boundary="open"))]
    rows = []
    for name, samples, n, settings in cases:
        fit = lambda **more: fitting.fit(samples, js.CubicBSpline(), n, on_failure="ignore",
                                         **settings, **more)
        default = fit()
        warm = fit(init=np.asarray(default.control_points))
        linear = fit(max_steps=1)
        rows.append(dict(outline=name, settings=", ".join(f"{k}={v}" for k, v in settings.items())
                         or "-", n=n, status=fitting.STATUSES[int(warm.status)],
                         rms_over_linear=float(warm.rms) / float(linear.rms)))
        print(rows[-1], flush=True)
    return rows


def main():
    args, output = _common.arguments(__doc__, "bad_starts")
    import jax

    jax.config.update("jax_enable_x64", True)
    import numpy as np
    from bench_analysis import _commit

    import fitting
    import jaxsubdiv as js

    run = _common.header(jax=jax.__version__, commit=_commit("HEAD"))
    rows = []
    for char in "S" if args.smoke else "Sg&a":
        samples = glyph(char)
        size = float(np.linalg.norm(np.ptp(samples, axis=0)))
        default_rms = None
        # The start taken without `init` (the linear fit, before any step).
        linear_rms = float(fitting.fit(samples, js.CubicBSpline(), 16, max_steps=1,
                                       on_failure="ignore").rms) / size
        chosen = starts(samples, size)
        if args.smoke:
            chosen = {k: chosen[k] for k in ("default", "scaled 10x")}
        queue = list(chosen.items())
        while queue:
            name, init = queue.pop(0)
            r = fitting.fit(samples, js.CubicBSpline(), 16, init=init, on_failure="ignore")
            if init is None and not args.smoke:  # the good starts come from the default fit
                queue += warm_starts(samples, size, np.asarray(r.control_points)).items()
            rms = float(r.rms) / size
            default_rms = rms if init is None else default_rms
            rows.append(dict(glyph=f"DejaVu Sans {char!r}", start=name,
                             status=fitting.STATUSES[int(r.status)], steps=int(r.num_steps),
                             rms=rms, rms_ratio=rms / default_rms,
                             rms_over_linear=rms / linear_rms,
                             newton=float(r.newton_step) / size))
            print(rows[-1], flush=True)
    run["rows"] = rows
    run["at_optimum"] = [] if args.smoke else at_optimum()
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)
    print(markdown(run))


if __name__ == "__main__":
    main()
