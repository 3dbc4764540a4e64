"""Fits of many samples: traced 1024-px bitmaps and long smooth outlines, this tree
against a git revision, in one run.

    python benchmarks/bench_fit_samples.py --before a32b9f9   # about 15 minutes on 2 cores
    python benchmarks/bench_fit_samples.py --smoke            # one small image, seconds

A fit's foot-point searches and its error measurement compare every sample with every
`coarse`-th curve point (`fitting._curve`): at 5,000 samples on a 46,000-point curve
that was most of the time (compare the versions). Measured:

- **images**: bitmaps of glyphs (DejaVu Serif 'S', 'g', '&'; STIXGeneral 'S', 'Q') and
  a five-point star, scaled to 80% of a 1024-px square (and 'S' and the star at 256 px)
  and rasterised as `bench_potrace.py` does; the PNG read by `jaxsubdiv.io.read_image`;
  each contour fitted by `fitting.fit(points, CubicBSpline(), n,
  corners=fitting.find_corners(points, pixel=1.0)[:n])` with n = m // 60 clipped to
  12 ... 64 for m samples (what `jaxsubdiv fit` does for a PNG, at a count close to
  potrace's). Time: all contours of the image, warm (median of `--repeats` after a
  call that compiles), reading the image excluded.
- **smooth**: a closed wavy outline (r = 1 + 0.3 cos 5t) of m = 2,000, 8,000 and 16,000
  samples, n = 45, no corners.
- **shapes**: the built-in shape 'rabbit' resampled to m = 2,000, 8,000 and 20,000
  samples, n = 32, corners by `fitting.find_corners` (what `jaxsubdiv fit --shape
  rabbit --samples m` fits). Its fit stays a few thousandths of the size from the
  samples, farther than the window around a sample's nearest coarse curve point
  reaches on a curve of 4 points per sample, so the error measurement's certificate
  leaves most points unsure: checked against every segment, that made a warm fit of
  20,000 samples take 56 s (`results/fit_samples.md`, 2026-12-08; now by blocks of
  segments, `fitting._curve._block_nearest`).
- **glyphs**: fits of the usual size, which must not get slower: the outer contour of
  DejaVu Sans 'S' and 'a' (400 samples, `tests/helpers.py`) at n = 16, 32, 64, and 'S'
  at 1,500 samples, n = 32 (median of `--repeats`, at least 15, warm calls).
- **searches** (this tree only; random points and anchors, one block of
  `_curve.BLOCK_PAIRS` pairs each, in the two shapes the glyph's fit and its error
  measurement use: 1,456 points x 2,880 anchors and 5,461 x 768): the nearest anchor
  by one `jnp.argmin` over the points x anchors array against
  `_curve._grouped_nearest_anchor`'s two levels; and a simplified certificate test (a masked
  `jnp.any`, without the square roots of the code before) against
  `_curve._smallest_outside`. Isolated like this the gain is smaller, and varies more
  from run to run, than inside the fits.

Each version runs in fresh interpreters (float64), `--rounds` of them, the versions
alternating (in turn first). Reported per case: warm seconds (median over rounds), the
samples, the fits' steps summed, their largest reported RMS (the same in both versions
when the change is a pure speed-up) and whether all converged.

Writes `benchmarks/results/fit_samples.json` and `.md` (`--output` sets the JSON path).
"""

import json
import pathlib
import statistics
import sys
import tempfile
import time


BENCH = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))
import _common  # noqa: E402


IMAGES = [("DejaVu Serif", "S", 1024), ("DejaVu Serif", "g", 1024),
          ("DejaVu Serif", "&", 1024), ("STIXGeneral", "S", 1024),
          ("STIXGeneral", "Q", 1024), ("analytic", "star", 1024),
          ("DejaVu Serif", "S", 256), ("analytic", "star", 256)]
SMOOTH = [2000, 8000, 16000]
SHAPES = [("rabbit", 2000, 32), ("rabbit", 8000, 32), ("rabbit", 20000, 32)]
#: (glyph, samples, control points): fits of the usual size, which must not get slower.
GLYPHS = [("S", 400, 16), ("S", 400, 32), ("S", 400, 64), ("a", 400, 16), ("a", 400, 32),
          ("a", 400, 64), ("S", 1500, 32)]
SMOKE_IMAGES = [("analytic", "star", 256)]
SMOKE_SMOOTH = [2000]
SMOKE_SHAPES = [("rabbit", 2000, 32)]
SMOKE_GLYPHS = [("S", 400, 16)]

# The child: `child(spec)` in a fresh interpreter whose path starts with the version's
# source tree, then this folder (for `bench_potrace`'s rasteriser).
CHILD = ("import sys; sys.path[:0] = [sys.argv[1], sys.argv[2], sys.argv[2] + '/../tests']; "
         "import bench_fit_samples as b; b.child(sys.argv[3])")


def count_for(m: int) -> int:
    return int(min(64, max(12, m // 60)))


def child(spec_json: str) -> None:
    """Time the cases of `spec` with the `fitting` and `jaxsubdiv` first on the path;
    print one JSON line."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import matplotlib.image
    import numpy as np

    import fitting
    import jaxsubdiv as js

    spec = json.loads(spec_json)
    repeats = spec["repeats"]
    scheme = js.CubicBSpline()
    out = {"fitting": str(pathlib.Path(fitting.__file__).parent), "cases": []}

    def timed(run):
        results = jax.block_until_ready(run())  # compiles
        times = []
        # Fits of milliseconds: more calls, so that the median is steady.
        for _ in range(repeats if results[0].curve.shape[0] > 4096 else max(15, repeats)):
            start = time.perf_counter()
            results = jax.block_until_ready(run())
            times.append(time.perf_counter() - start)
        return statistics.median(times), results

    def record(name, samples, seconds, results):
        out["cases"].append(dict(
            case=name, samples=samples, seconds=seconds,
            steps=sum(int(r.num_steps) for r in results),
            rms=[float(r.rms) for r in results],
            converged=all(bool(r.converged) for r in results)))

    import bench_potrace as potrace

    with tempfile.TemporaryDirectory() as tmp:
        for family, char, size in spec["images"]:
            raw = (potrace.analytic_contours(char) if family == "analytic"
                   else potrace.glyph_contours(family, char))
            bitmap = potrace.rasterise(potrace.place(raw, size), size)
            png = pathlib.Path(tmp) / "image.png"
            matplotlib.image.imsave(png, ~bitmap, cmap="gray", vmin=0, vmax=1)
            contours = [c.points for c in js.io.read_image(png)]

            def fit_all():
                results = []
                for points in contours:
                    n = count_for(len(points))
                    corners = fitting.find_corners(points, pixel=1.0)
                    results.append(fitting.fit(points, scheme, n, corners=corners[:n],
                                               on_failure="ignore"))
                return results

            seconds, results = timed(fit_all)
            name = char if family == "analytic" else f"{family} '{char}'"
            record(f"{name}, {size} px", sum(len(c) for c in contours), seconds, results)
        for m in spec["smooth"]:
            t = np.linspace(0, 2 * np.pi, m, endpoint=False)
            radius = 1 + 0.3 * np.cos(5 * t)
            points = 400 * np.stack([radius * np.cos(t), radius * np.sin(t)], 1)
            seconds, results = timed(lambda: [fitting.fit(points, scheme, 45,
                                                          on_failure="ignore")])
            record(f"wavy outline, m = {m}", m, seconds, results)
        from jaxsubdiv._io.common import resample_polyline

        for name, m, n in spec.get("shapes", []):
            points = resample_polyline(js.shapes.get(name), m, True)
            corners = fitting.find_corners(points)
            seconds, results = timed(lambda: [fitting.fit(points, scheme, n, corners=corners,
                                                          on_failure="ignore")])
            record(f"shape '{name}', m = {m}, n = {n}, {len(corners)} corners", m, seconds,
                   results)
        from helpers import glyph_outline  # this repository's tests/helpers.py

        for char, m, n in spec["glyphs"]:
            points = glyph_outline(char, m)
            seconds, results = timed(lambda: [fitting.fit(points, scheme, n)])
            record(f"DejaVu Sans '{char}', m = {m}, n = {n}", m, seconds, results)
        if spec["searches"]:
            out["searches"] = searches(repeats)
    print(json.dumps(out))


def searches(repeats: int) -> list:
    """One block's nearest-anchor search and certificate test, one pass against two."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    from fitting import _curve

    def median_ms(f, *args):
        f = jax.jit(f)
        jax.block_until_ready(f(*args))
        times = []
        for _ in range(max(5, repeats)):
            start = time.perf_counter()
            jax.block_until_ready(f(*args))
            times.append(time.perf_counter() - start)
        return 1e3 * statistics.median(times)

    rng = np.random.default_rng(0)
    rows = []
    for m, k in ((1456, 2880), (5461, 768)):
        points = jnp.asarray(rng.standard_normal((m, 2)))
        anchors = jnp.asarray(rng.standard_normal((k, 2)))
        one = median_ms(lambda p, a: jnp.argmin(_curve._anchor_distance2(p, a), axis=1),
                        points, anchors)
        two = median_ms(lambda p, a: _curve._grouped_nearest_anchor(p, a)[0], points, anchors)
        rows.append(dict(search="nearest anchor", points=m, anchors=k, one_pass_ms=one,
                         two_level_ms=two))
        rows3 = jnp.asarray(rng.standard_normal((m, 3)))
        columns = jnp.asarray(rng.standard_normal((k, 3)))
        norms = jnp.asarray(rng.standard_normal(k))
        near = jnp.asarray(rng.integers(0, k, (m, 2)))
        group = jnp.arange(k)

        def masked(r, c, n, near):
            value = n[None, :] - 2 * r @ c.T
            excluded = jnp.any(group[None, :, None] == near[:, None, :], axis=2)
            return jnp.any(~excluded & (value < 0), axis=1)

        def two_level(r, c, n, near):
            return _curve._smallest_outside(
                r, c, n, near, lambda j: jnp.any(j[..., None] == near[:, None, None, :], -1)) < 0

        rows.append(dict(search="certificate", points=m, anchors=k,
                         one_pass_ms=median_ms(masked, rows3, columns, norms, near),
                         two_level_ms=median_ms(two_level, rows3, columns, norms, near)))
    return rows


def markdown(run: dict) -> str:
    versions = run["versions"]
    before = "before" in versions
    lines = [
        "# Fits of many samples (`benchmarks/bench_fit_samples.py`)", "",
        f"{run['date']}; {run['machine']}; load average at the start {run['load_start']}, "
        f"at the end {run['load_end']} (1, 5, 15 min). `{run['command']}`; versions: "
        + ", ".join(f"{k} = `{v}`" for k, v in versions.items())
        + f"; {run['rounds']} fresh interpreter(s) per version"
        + (", alternating" if before else "") + f", {run['repeats']} warm call(s) in each "
        "(median over all). Closed cubic B-splines, float64; images: every contour of the "
        "traced bitmap, n = m // 60 clipped to 12-64, corners in pixels; wavy outlines: "
        "n = 45, no corners; shapes: corners found in the samples.", "",
    ]
    head = ["case", "samples", "after (s)", "steps", "largest RMS", "converged"]
    if before:
        head[3:3] = ["before (s)", "after / before", "steps before"]
        head += ["largest RMS before", "converged before"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in run["cases"]:
        after = row["after"]
        cells = [row["case"], str(after["samples"]), f"{after['seconds']:.3f}",
                 str(after["steps"]), f"{max(after['rms']):.4g}",
                 "yes" if after["converged"] else "no"]
        if before:
            old = row["before"]
            cells[3:3] = [f"{old['seconds']:.3f}", f"{after['seconds'] / old['seconds']:.2f}",
                          str(old["steps"])]
            cells += [f"{max(old['rms']):.4g}", "yes" if old["converged"] else "no"]
        lines.append("| " + " | ".join(cells) + " |")
    if run.get("searches"):
        lines += ["", "One block of a search (this tree), ms (median):", "",
                  "| search | points | anchors | one pass | two levels | ratio |",
                  "|---|---:|---:|---:|---:|---:|"]
        for s in run["searches"]:
            lines.append(f"| {s['search']} | {s['points']} | {s['anchors']} | "
                         f"{s['one_pass_ms']:.2f} | {s['two_level_ms']:.2f} | "
                         f"{s['one_pass_ms'] / s['two_level_ms']:.1f}x |")
    return "\n".join(lines) + "\n"


def main() -> None:
    args, output, rounds, repeats = _common.versions_arguments(
        __doc__, "fit_samples", rounds=(1, 2), repeats=(1, 3),
        smoke_help="one small image (for CI)")

    run = _common.header(command=" ".join(["python", "benchmarks/bench_fit_samples.py",
                                           *sys.argv[1:]]), rounds=rounds, repeats=repeats)
    spec = dict(images=SMOKE_IMAGES if args.smoke else IMAGES,
                smooth=SMOKE_SMOOTH if args.smoke else SMOOTH,
                shapes=SMOKE_SHAPES if args.smoke else SHAPES,
                glyphs=SMOKE_GLYPHS if args.smoke else GLYPHS, repeats=repeats)
    describe = lambda result: ", ".join(f"{c['case']} {c['seconds']:.2f}s"
                                        for c in result["cases"])
    run["versions"], measured = _common.run_versions(
        args.before, rounds, CHILD,
        lambda name, r: dict(spec, searches=name == "after" and r == 0),
        describe=describe, timeout=3600)
    run["cases"] = _common.median_cases(measured, "seconds")
    run["searches"] = measured["after"][0].get("searches")
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)


if __name__ == "__main__":
    main()
