"""Where a fit of a traced 1024-px glyph spends its time: the solve and the error
measurement, and inside them the foot-point searches, timed part by part.

    python benchmarks/bench_fit_step.py            # about 3 minutes on 2 cores
    python benchmarks/bench_fit_step.py --smoke    # the star at 256 px, seconds

Each case is one bitmap, rasterised and read as `bench_fit_samples.py` does, of which the
contour with the most samples is fitted as `jaxsubdiv fit` fits a PNG
(`fitting.fit(points, CubicBSpline(), n, corners=fitting.find_corners(points,
pixel=1.0)[:n])`, n = m // 60 clipped to 12 ... 64). The fit's own arguments are
captured on their way into `fitting._core.run`, and then timed warm (median of
`--repeats` after a call that compiles):

- **solve** (`_core.solve_jit`: every solver step) and **measure** (`_core.measure_jit`:
  the two-sided errors, once), with the solver's steps, and the solve's time per step.
- **global searches**: how many of the solve's calls of the foot-point search
  (`Objective.feet`) ran the global search for the samples (`_curve.project` on the
  samples' count of points, counted by a host callback in a separate, untimed run that
  compiles its own program; the first step's feet are always global).
- **searches at the solution**, each its own jitted program on the fitted curve: the
  samples' feet by the global search (`_curve.locate` without previous feet), by the
  tracked search from the fitted feet with the corner samples skipped (what the fit
  does since 2026-12-05) and without (before: whether the check for lost feet then
  fires, which costs the global search too); the check for lost feet alone
  (`_curve._lost`).
- **measurement halves** (`_curve.nearest_on_polyline`'s two paths on the same inputs):
  the curve's samples and midpoints against the outline's samples, in clusters
  (`_curve._clustered`, what `measure` runs there) and point by point
  (`_curve._pointwise`, before 2026-12-05), with the share of clusters the certificate
  leaves unsure (searched again point by point); and the samples against the curve
  (point by point), with the share of clusters that would be unsure there.

Writes `benchmarks/results/fit_step.json` and `.md` (`--output` sets the JSON path).
"""

import json
import pathlib
import sys
import tempfile
import time


BENCH = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))
import _common  # noqa: E402


CASES = [("STIXGeneral", "S", 1024), ("DejaVu Serif", "S", 1024), ("analytic", "star", 1024)]
SMOKE_CASES = [("analytic", "star", 256)]


def count_for(m: int) -> int:
    """The control points `bench_fit_samples` gives m samples (close to potrace's)."""
    return int(min(64, max(12, m // 60)))


def contour(family: str, char: str, size: int):
    """The traced bitmap's contour with the most samples, as `read_image` gives it."""
    import bench_potrace as potrace
    import matplotlib.image
    import numpy as np

    import jaxsubdiv as js

    raw = (potrace.analytic_contours(char) if family == "analytic"
           else potrace.glyph_contours(family, char))
    bitmap = potrace.rasterise(potrace.place(raw, size), size)
    with tempfile.TemporaryDirectory() as tmp:
        png = pathlib.Path(tmp) / "image.png"
        matplotlib.image.imsave(png, ~bitmap, cmap="gray", vmin=0, vmax=1)
        contours = [np.asarray(c.points) for c in js.io.read_image(png)]
    return max(contours, key=len)


def captured_fit(points):
    """`fitting.fit`'s arguments to `_core.run` for `points`, as the benchmark fits them:
    `(data, init, tol, max_steps, objective)`."""
    import fitting
    import jaxsubdiv as js
    from fitting import _fit

    seen = {}
    original = _fit.run

    def capture(data, init, tol, max_steps, *, objective, solver=None, progress=False):
        seen.update(data=data, init=init, tol=tol, max_steps=max_steps, objective=objective,
                    solver=solver)
        return original(data, init, tol, max_steps, objective=objective, solver=solver,
                        progress=progress)

    _fit.run = capture
    try:
        n = count_for(len(points))
        corners = fitting.find_corners(points, pixel=1.0)[:n]
        fitting.fit(points, js.CubicBSpline(), n, corners=corners, on_failure="ignore")
    finally:
        _fit.run = original
    if seen["solver"] is not None:
        raise SystemExit("the fit did not use the default solver")
    return seen, n, len(corners)


def global_searches(family: str, char: str, size: int) -> int:
    """How many of the solve's foot-point searches ran the global search for the
    samples: calls of `_curve.project` on as many points as the padded samples, counted
    by a host callback. Patched in before the fit is first traced (JAX reuses the traces
    of the solver's loop for an equal objective), so this runs in a process of its own,
    apart from the timed one."""
    import jax

    from fitting import _curve

    calls = []
    original = _curve.project

    def counted(points, curve, closed, coarse, count=None):
        if points.shape[0] == sizes[0]:
            jax.debug.callback(lambda: calls.append(1))
        return original(points, curve, closed, coarse, count)

    points = contour(family, char, size)
    sizes = [_bucket(len(points))]
    _curve.project = counted
    try:
        captured_fit(points)  # one solve, traced with the counter
        jax.effects_barrier()
    finally:
        _curve.project = original
    return len(calls)


def _bucket(m: int) -> int:
    from fitting import _checks

    return int(_checks.bucket(m))


def one_case(family: str, char: str, size: int, repeats: int) -> dict:
    import jax
    import jax.numpy as jnp

    from fitting import _core, _curve

    points = contour(family, char, size)
    seen, n, num_corners = captured_fit(points)
    data, objective = seen["data"], seen["objective"]
    args = (data, seen["init"], seen["tol"], seen["max_steps"])

    def warm(call):
        jax.block_until_ready(call())  # compiles
        return _common.timed(call, repeats)

    solve_s, solved = warm(lambda: _core.solve_jit(*args, objective=objective))
    measure_s, _ = warm(lambda: _core.measure_jit(*_core.measure_arguments(solved),
                                                  closed=objective.closed))
    steps = int(solved.num_steps)

    # The samples and the fitted curve in units of the outline's size, as the solver
    # sees them; the fitted feet, as the last step left them.
    problem = jax.jit(lambda d: _core.set_up(d, None, objective))(data)
    scaled = problem.data
    P = (solved.control_points - problem.center) / problem.scale
    y = {"control": objective.unknowns(P), "params": problem.start["params"]}
    X, _ = objective.curve(y, scaled)
    target, count = scaled.target, scaled.count
    corners = scaled.corners & (scaled.weights > 0)
    feet = jax.jit(lambda y: objective.feet(y, scaled))(y)
    coarse = max(1, min(8, objective.num_curve // 64))
    closed = objective.closed

    def ms(function, *inputs):
        program = jax.jit(function)
        seconds, out = warm(lambda: program(*inputs))
        return 1e3 * seconds, out

    global_ms, _ = ms(lambda t, X: _curve.locate(t, X, None, closed, coarse), target, X)
    tracked_ms, _ = ms(lambda t, X, f, s: _curve.locate(t, X, None, closed, coarse,
                                                        previous=f, skip=s),
                       target, X, feet[0], corners)
    unskipped_ms, _ = ms(lambda t, X, f: _curve.locate(t, X, None, closed, coarse,
                                                       previous=f),
                         target, X, feet[0])

    def lost(t, X, f, s):
        segment = jnp.floor(f).astype(jnp.int32)
        near, fraction = _curve._window_project(
            t, X, closed, segment[:, None] + jnp.arange(-2, 3)[None, :])
        a, b = _curve._segment_ends(X, closed)
        found2 = jnp.sum((t - a[near] - fraction[:, None] * (b[near] - a[near])) ** 2, -1)
        anchors = _curve._anchors(X, closed, coarse)[1]
        return (jnp.sum(_curve._lost(t, anchors, _curve._unless(s, found2))),
                jnp.sum(_curve._lost(t, anchors, found2)))

    _, (lost_skipped, lost_all) = ms(lost, target, X, feet[0], corners)
    check_ms, _ = ms(lambda t, X: _curve._lost(
        t, _curve._anchors(X, closed, coarse)[1], jnp.zeros(t.shape[0], t.dtype)), target, X)

    # The measurement's two halves (`_objective.curve_errors`: chords, default coarse).
    middle = jnp.arange(X.shape[0], dtype=X.dtype) + 0.5
    (midpoint,) = _curve.evaluate(X, None, middle, closed, order=0)
    dense = jnp.concatenate([X, midpoint])
    halves = {}
    for name, (p, q, c) in {"curve to samples": (dense, target, count),
                            "samples to curve": (target, X, None)}.items():
        clustered_ms, _ = ms(lambda p, q: _curve._clustered(p, q, closed, 8, 256, c), p, q)
        pointwise_ms, _ = ms(lambda p, q: _curve._pointwise(p, q, closed, 8, 256, c), p, q)
        halves[name] = dict(points=int(p.shape[0]), polyline=int(q.shape[0]),
                            clustered_ms=clustered_ms, pointwise_ms=pointwise_ms,
                            unsure_clusters=unsure_share(p, q, closed, c),
                            path=("clustered" if _curve._anchors(q, closed, 8)[1].shape[0]
                                  >= _curve.TWO_LEVELS_FROM
                                  and p.shape[0] >= max(q.shape[0], 2 * _curve.CLUSTER)
                                  else "point by point"))
    name = char if family == "analytic" else f"{family} '{char}'"
    return dict(
        case=f"{name}, {size} px", samples=len(points), padded=int(target.shape[0]),
        curve_points=int(X.shape[0]), n=n, corners=num_corners, steps=steps,
        solve_s=solve_s, measure_s=measure_s, ms_per_step=1e3 * solve_s / max(steps, 1),
        global_ms=global_ms, tracked_ms=tracked_ms,
        unskipped_ms=unskipped_ms, lost_skipped=int(lost_skipped), lost_all=int(lost_all),
        check_ms=check_ms, halves=halves, converged=bool(solved.status == 0))


def unsure_share(points, curve, closed: bool, count) -> float:
    """The share of `_curve._clustered`'s clusters that its certificate leaves unsure."""
    import jax.numpy as jnp

    from fitting import _curve

    _, _, unsure = _curve.cluster_certificate(points, curve, closed, 8, count)
    return float(jnp.mean(unsure))


def child(spec_json: str) -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    spec = json.loads(spec_json)
    if spec["count"]:
        print(json.dumps(dict(global_searches=global_searches(*spec["case"]))))
    else:
        print(json.dumps(one_case(*spec["case"], spec["repeats"])))


CHILD = ("import sys; sys.path[:0] = [sys.argv[1], sys.argv[1] + '/..']; "
         "import bench_fit_step as b; b.child(sys.argv[2])")


def markdown(run: dict) -> str:
    lines = [
        "# Where a traced glyph's fit spends its time (`benchmarks/bench_fit_step.py`)", "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min); jax {run['jax']}, float64. Each case "
        f"in a fresh interpreter; the largest contour of the bitmap, fitted as "
        f"`bench_fit_samples.py` fits it; warm medians of {run['repeats']} calls.", "",
        "| case | samples (padded) | curve points | n | corners | steps | solve (s) | "
        "per step (ms) | global searches | measure (s) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for c in run["cases"]:
        lines.append(
            f"| {c['case']} | {c['samples']:,} ({c['padded']:,}) | {c['curve_points']:,} | "
            f"{c['n']} | {c['corners']} | {c['steps']} | {c['solve_s']:.2f} | "
            f"{c['ms_per_step']:.1f} | {c['global_searches']} of {c['steps'] + 1} | "
            f"{c['measure_s']:.3f} |")
    lines += [
        "", "Global searches: calls of the global search for the samples among the solve's "
        "foot-point searches (the steps and the first, global, search).", "",
        "## The samples' feet at the solution (ms)", "",
        "| case | global search | tracked, corners skipped (now) | tracked, corners "
        "checked (before) | lost feet: skipped / checked | the check alone |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for c in run["cases"]:
        lines.append(
            f"| {c['case']} | {c['global_ms']:.1f} | {c['tracked_ms']:.1f} | "
            f"{c['unskipped_ms']:.1f} | {c['lost_skipped']} / {c['lost_all']} | "
            f"{c['check_ms']:.1f} |")
    lines += [
        "", "Lost feet: samples whose tracked foot has a coarse curve point nearer (any one "
        "sends every sample into the global search), with the corner samples skipped and "
        "counted.", "",
        "## The error measurement's halves (ms)", "",
        "| case | half | points x polyline | path taken | in clusters | point by point | "
        "clusters unsure |",
        "| --- | --- | --- | --- | ---: | ---: | ---: |",
    ]
    for c in run["cases"]:
        for half, h in c["halves"].items():
            lines.append(
                f"| {c['case']} | {half} | {h['points']:,} x {h['polyline']:,} | {h['path']} "
                f"| {h['clustered_ms']:.0f} | {h['pointwise_ms']:.0f} | "
                f"{100 * h['unsure_clusters']:.2f}% |")
    return "\n".join(lines) + "\n"


def main() -> None:
    import jax

    args, output = _common.arguments(__doc__, "fit_step")
    cases = SMOKE_CASES if args.smoke else CASES
    run = _common.header(jax=jax.__version__, repeats=3 if args.smoke else 7, cases=[])
    start = time.perf_counter()
    for case in cases:
        result = {}
        for count in (False, True):
            spec = json.dumps(dict(case=case, repeats=run["repeats"], count=count))
            result.update(_common.child_json(CHILD, str(BENCH), spec,
                                             what=f"bench_fit_step {case}"))
        run["cases"].append(result)
        print(json.dumps(run["cases"][-1]), flush=True)
    run["wall_s"] = time.perf_counter() - start
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)


if __name__ == "__main__":
    main()
