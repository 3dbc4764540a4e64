"""What float32 fits report: the default solver's status on smooth outlines fitted in
float32 (JAX's default dtype, x64 off), and how close those fits are to the float64
optimum next to them.

    python benchmarks/bench_float32_status.py --before REV   # about 2 minutes on 2 cores
    python benchmarks/bench_float32_status.py --smoke        # four fits

In float32 the loss's rounding can hide a gain the solver's model still predicts: no
step lowers the loss, the damping grows to its limit, and the solver stops. It used to
call every such stop `nonlinear_divergence` unless the gradient was below 1e-6; since
2026-12-07 it is a success when the full Newton step would gain at most `tol` of the
loss (`fitting._solver.settled`). The iterates are the same either way (the solver stops
there in both): only the status differs.

Each tree (`--before REV` extracted, and this work tree) fits every case in a fresh
interpreter with x64 off: smooth random blobs (three harmonics of random amplitude and
phase, 120 samples) and glyph outlines of the fonts matplotlib ships (400 samples),
cubic B-spline and four-point schemes, `fit`'s defaults (float32: `tol` 1e-5). Then a
fresh interpreter with x64 on fits the same float32 samples in float64, started from
this tree's float32 control points (`init`), to the default float64 `tol`: `rms32 /
rms64` is how much the float32 stop loses against the optimum it was heading for, both
figures measured by `fit`'s own two-sided RMS in float64 (the float32 control points
measured again in float64, as a fit of 0 steps). The steps and RMS of the two versions
are compared fit by fit.

Writes `benchmarks/results/float32_status.json` and `.md` (`--output` sets the JSON
path).
"""

import collections
import json
import os
import pathlib
import sys
import tempfile


BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(BENCH), str(BENCH.parent)]
import _common  # noqa: E402


FONTS = ("DejaVu Sans", "DejaVu Serif")
GLYPHS = "S&gQ8a"

CASES_CODE = f"BENCH = {str(BENCH)!r}\n" + r'''
import numpy as np

def resample_closed(points, m):
    closed = np.vstack([points, points[:1]])
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    t = np.linspace(0, s[-1], m, endpoint=False)
    return np.stack([np.interp(t, s, closed[:, k]) for k in range(2)], -1)

def blob(seed, m=120):
    import sys
    sys.path.insert(0, BENCH)
    from _common import blob as smooth_blob
    return smooth_blob(seed, m)

def glyph(family, char, m=400):
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath
    path = TextPath((0, 0), char, size=1.0, prop=FontProperties(family=family))
    outer = max(path.to_polygons(closed_only=True), key=lambda p: np.ptp(p, axis=0).prod())
    if np.allclose(outer[0], outer[-1]):
        outer = outer[:-1]
    return resample_closed(outer, m)

def cases(smoke):
    out = []
    seeds = range(2) if smoke else range(12)
    for scheme in ("CubicBSpline", "FourPoint"):
        for n in ((10,) if smoke else (10, 16)):
            out += [(f"blob {seed}", scheme, n, blob(seed)) for seed in seeds]
    if not smoke:
        for family in FONTS:
            for char in GLYPHS:
                out += [(f"{family} {char!r}", "CubicBSpline", n, glyph(family, char))
                        for n in (16, 32)]
    return [(name, scheme, n, np.asarray(points, np.float32))
            for name, scheme, n, points in out]
'''

FLOAT32_CODE = CASES_CODE + r'''
import json, sys
import jax
import jaxsubdiv as js, fitting
FONTS = tuple(json.loads(sys.argv[2]))
GLYPHS = sys.argv[3]
assert not jax.config.jax_enable_x64
rows = []
for name, scheme, n, points in cases(sys.argv[1] == "smoke"):
    r = fitting.fit(points, getattr(js, scheme)(), n, on_failure="ignore")
    rows.append(dict(case=name, scheme=scheme, n=n, status=fitting.STATUSES[int(r.status)],
                     steps=int(r.num_steps), rms=float(r.rms),
                     newton_step=float(r.newton_step),
                     control=np.asarray(r.control_points, float).tolist()))
print(json.dumps(rows))
'''

FLOAT64_CODE = CASES_CODE + r'''
import json, sys
import jax
jax.config.update("jax_enable_x64", True)
import jaxsubdiv as js, fitting
FONTS = tuple(json.loads(sys.argv[2]))
GLYPHS = sys.argv[3]
starts = json.loads(open(sys.argv[4]).read())
rows = []
for (name, scheme, n, points), control in zip(cases(sys.argv[1] == "smoke"), starts):
    points, control = np.asarray(points, np.float64), np.asarray(control, np.float64)
    s = getattr(js, scheme)()
    # The float32 fit's control points measured in float64 (a fit of no steps).
    at = fitting.fit(points, s, n, init=control, max_steps=1, on_failure="ignore")
    best = fitting.fit(points, s, n, init=control, on_failure="ignore")
    rows.append(dict(rms32=float(at.rms), rms64=float(best.rms),
                     status64=fitting.STATUSES[int(best.status)]))
print(json.dumps(rows))
'''


def run_tree(tree: pathlib.Path, code: str, smoke: bool, *extra: str) -> list:
    env = dict(os.environ, PYTHONPATH=str(tree), JAX_ENABLE_X64="0")
    return _common.child_json(code, "smoke" if smoke else "full", json.dumps(FONTS), GLYPHS,
                              *extra, what=f"fits of {tree}", env=env, cwd=tempfile.gettempdir())


def markdown(run: dict) -> str:
    lines = [
        "# What float32 fits report (`bench_float32_status.py`)", "",
        f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
        f"{run['load_end']} at end (1, 5, 15 min). Versions: "
        + ", ".join(f"{k} = `{v}`" for k, v in run["commits"].items()) + ".", "",
        __doc__.split("\n\n", 2)[2].split("\n\nWrites")[0].replace("\n\n", " ").replace("\n", " "), "",
        "## Statuses by version", "",
        "| version | " + " | ".join(run["statuses"]) + " |",
        "| --- | " + " | ".join("---:" for _ in run["statuses"]) + " |",
    ]
    for version, counts in run["counts"].items():
        lines.append(f"| {version} | " + " | ".join(str(counts.get(s, 0)) for s in run["statuses"])
                     + " |")
    lines += ["", "## Fits whose status differs, and every fit not reported a success", "",
              "`rms32 / rms64`: the float32 fit's RMS against that of the float64 fit started "
              "from it (both measured in float64).", "",
              "| case | scheme | n | " + " | ".join(run["counts"]) + " | steps | newton step "
              "| rms32 / rms64 |", "| --- | --- | ---: |" + " --- |" * len(run["counts"])
              + " ---: | ---: | ---: |"]
    versions = list(run["counts"])
    for row in run["rows"]:
        statuses = [row["status"][v] for v in versions]
        if len(set(statuses)) > 1 or "successful" not in statuses:
            lines.append(f"| {row['case']} | {row['scheme']} | {row['n']} | "
                         + " | ".join(statuses) + f" | {row['steps']} | "
                         f"{row['newton_step']:.2g} | {row['rms32'] / row['rms64']:.4f} |")
    ratios = sorted(row["rms32"] / row["rms64"] for row in run["rows"])
    lines += ["", f"Over all {len(ratios)} fits, `rms32 / rms64`: median "
              f"{ratios[len(ratios) // 2]:.4f}, max {ratios[-1]:.4f}. Fits whose steps or "
              f"RMS differ between the versions: {run['differ']}.", ""]
    return "\n".join(lines)


def main():
    args, output, _, _ = _common.versions_arguments(__doc__, "float32_status", (1, 1), (1, 1))
    run = _common.header()
    with tempfile.TemporaryDirectory() as scratch:
        trees = _common.versions(args.before, pathlib.Path(scratch))
        results = {name: run_tree(tree, FLOAT32_CODE, args.smoke) for name, (tree, _) in
                   trees.items()}
        after = results["after"]
        starts = pathlib.Path(scratch) / "starts.json"
        starts.write_text(json.dumps([row["control"] for row in after]))
        env = dict(os.environ, PYTHONPATH=str(trees["after"][0]))
        float64 = _common.child_json(FLOAT64_CODE, "smoke" if args.smoke else "full",
                                     json.dumps(FONTS), GLYPHS, str(starts),
                                     what="float64 fits", env=env, cwd=scratch)
    run["commits"] = {name: commit for name, (_, commit) in trees.items()}
    run["rows"] = [
        dict(case=row["case"], scheme=row["scheme"], n=row["n"], steps=row["steps"],
             newton_step=row["newton_step"], rms32=wide["rms32"], rms64=wide["rms64"],
             status={name: results[name][i]["status"] for name in results},
             status64=wide["status64"])
        for i, (row, wide) in enumerate(zip(after, float64))
    ]
    run["differ"] = sum(
        len({(rows[i]["steps"], rows[i]["rms"]) for rows in results.values()}) > 1
        for i in range(len(after)))
    run["counts"] = {name: dict(collections.Counter(r["status"] for r in rows))
                     for name, rows in results.items()}
    run["statuses"] = sorted({s for counts in run["counts"].values() for s in counts},
                             key=lambda s: (s != "successful", s))
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)
    print(markdown(run))


if __name__ == "__main__":
    main()
