"""How long `jaxsubdiv.plot.plot_fit` takes to measure its samples' distances (issue #18).

    python benchmarks/bench_plot.py           # 3 sizes (~3 min: the brute force at 10,000)
    python benchmarks/bench_plot.py --smoke   # one small size

`plot_fit` colours each sample by its distance to a dense polyline of the fitted
curve's exact limit points (max(16384, 16 m) of them, then the next refinement level).
Before 2026-12-03 it measured every sample against every segment; `--plot` on a
2,644-sample silhouette then added 26-35 s (issue #18). Now only the blocks of segments
that can hold a sample's nearest point are measured. Baseline, in the same run: the
brute force, every segment checked (numpy, written here). Both must give the same
distances (checked). Writes `benchmarks/results/plot.json` and `.md`.
"""

import json
import pathlib
import statistics
import sys
import time

import numpy as np

import jaxsubdiv as js
from jaxsubdiv._plot import _limit_curve, _segment_distances


sys.path.insert(0, str(pathlib.Path(__file__).parent))
import _common  # noqa: E402


def brute_force(samples, polyline):
    """Every sample against every segment of the closed polyline (numpy, in chunks)."""
    a, b = polyline, np.roll(polyline, -1, axis=0)
    ab = b - a
    length2 = np.maximum(np.sum(ab**2, axis=-1), np.finfo(np.float64).tiny)
    out = np.empty(len(samples))
    chunk = max(1, 2_000_000 // len(a))
    for start in range(0, len(samples), chunk):
        p = samples[start : start + chunk, None, :]
        t = np.clip(np.sum((p - a) * ab, axis=-1) / length2, 0.0, 1.0)
        out[start : start + chunk] = np.sqrt(np.min(np.sum((p - a - t[..., None] * ab) ** 2,
                                                           axis=-1), axis=-1))
    return out


def silhouette(m, seed=1):
    """A wobbly closed outline of `m` noisy samples, a few hundred pixels across."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0, 2 * np.pi, m, endpoint=False)
    outline = np.stack([300 * np.cos(theta) * (1 + 0.2 * np.cos(7 * theta)),
                        200 * np.sin(theta)], 1)
    return outline + rng.standard_normal((m, 2))


def median_time(function, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main():
    args, output = _common.arguments(__doc__, "plot")
    header = _common.header()
    rows = []
    for m in (400,) if args.smoke else (400, 2644, 10_000):
        samples = silhouette(m)
        curve = _limit_curve(samples[:: max(1, m // 64)], js.CubicBSpline(),
                             count=max(16384, 16 * m))
        repeats = 1 if args.smoke or m > 5000 else 3
        brute, reference = median_time(lambda: brute_force(samples, curve), repeats)
        blocks, distances = median_time(lambda: _segment_distances(samples, curve, True),
                                        repeats)
        gap = float(np.max(np.abs(distances - reference)))
        if gap > 1e-9:
            raise AssertionError(f"the block search differs from the brute force by {gap}")
        rows.append(dict(samples=m, curve_points=len(curve), brute_force=brute,
                         blocks=blocks, speedup=brute / blocks, largest_difference=gap,
                         repeats=repeats))
        print(f"{m} samples, {len(curve)} curve points: brute force {brute:.3f} s, blocks "
              f"{blocks:.3f} s ({brute / blocks:.0f}x), same distances to {gap:.1e}")
    header["load_end"] = _common.load()
    output.write_text(json.dumps({"header": header, "rows": rows}, indent=1))
    lines = [
        "# `plot_fit`'s sample distances: block search against brute force", "",
        f"{header['date']}; {header['machine']}; load {header['load_start']} at start, "
        f"{header['load_end']} at end (1, 5, 15 min). A wobbly closed outline of m noisy "
        "samples; the curve: the exact limit points of a cubic B-spline through every "
        "(m/64)-th sample, as many as `plot_fit` uses. Medians of the repeats, in one run.",
        "",
        "| samples | curve points | brute force (s) | blocks (s) | speed-up | largest difference |",
        "| ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    lines += [f"| {r['samples']} | {r['curve_points']} | {r['brute_force']:.3f} | "
              f"{r['blocks']:.3f} | {r['speedup']:.0f}x | {r['largest_difference']:.1e} |"
              for r in rows]
    output.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {output} and {output.with_suffix('.md')}")


if __name__ == "__main__":
    main()
