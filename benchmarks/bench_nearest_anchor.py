"""The nearest-anchor search alone: two levels against pruning, to place
`fitting._curve.PRUNED_FROM`.

    python benchmarks/bench_nearest_anchor.py           # about a minute on 2 cores
    python benchmarks/bench_nearest_anchor.py --smoke   # one size

Anchors along DejaVu Sans 'S''s outline (as a fit's curve gives them, every 8th curve
point), points near the same outline (as a fit's samples; 1e-3 of a unit glyph off it),
for 512-4,096 anchors and 1,500 and 6,000 points. Per size, the warm median of 31 calls
of each search, jitted on its own: `_curve._grouped_nearest_anchor` (two levels), and
`_curve._nearest_anchor` with pruning forced (`_pruned_nearest_anchor`, whose uncertain
points take the two-level search), with the share of points the pruning certified.

Writes `benchmarks/results/nearest_anchor.json` and `.md` (`--output` sets the JSON path).
"""

import pathlib
import sys


sys.path.insert(0, str(pathlib.Path(__file__).parent))
sys.path.insert(0, str(pathlib.Path(__file__).parent.parent / "tests"))
import _common  # noqa: E402


def median_ms(function, *args) -> float:
    """Warm median of 31 calls, in ms (the first call, which compiles, not timed)."""
    import jax

    jax.block_until_ready(function(*args))
    return 1e3 * _common.timed(lambda: function(*args), 31)[0]


def measure(sizes) -> list[dict]:
    import jax
    import jax.numpy as jnp
    import numpy as np

    jax.config.update("jax_enable_x64", True)
    from helpers import glyph_outline

    from fitting import _curve

    grouped = jax.jit(_curve._grouped_nearest_anchor)
    pruned = jax.jit(_curve._pruned_nearest_anchor)
    _curve.PRUNED_FROM = 1  # `_nearest_anchor` as it runs from `PRUNED_FROM` on, at any size
    forced = jax.jit(_curve._nearest_anchor)
    rng = np.random.default_rng(0)
    rows = []
    for k, m in sizes:
        anchors = jnp.asarray(glyph_outline("S", k))
        points = jnp.asarray(glyph_outline("S", m) + 1e-3 * rng.standard_normal((m, 2)))
        certain = float(np.mean(np.asarray(pruned(points, anchors)[2])))
        rows.append(dict(anchors=k, points=m, two_levels_ms=median_ms(grouped, points, anchors),
                         pruned_ms=median_ms(forced, points, anchors), certain=certain))
        print(rows[-1], flush=True)
    return rows


def markdown(run: dict) -> str:
    lines = ["# The nearest-anchor search: two levels against pruning "
             "(`benchmarks/bench_nearest_anchor.py`)", "",
             f"{run['date']}; {run['machine']}; load {run['load_start']} at start, "
             f"{run['load_end']} at end (1, 5, 15 min); float64; warm medians of 31 calls.",
             "", "| anchors | points | two levels (ms) | pruned (ms) | pruned / two levels "
             "| certified by pruning |", "| ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in run["rows"]:
        lines.append(f"| {r['anchors']:,} | {r['points']:,} | {r['two_levels_ms']:.2f} | "
                     f"{r['pruned_ms']:.2f} | {r['pruned_ms'] / r['two_levels_ms']:.2f} | "
                     f"{100 * r['certain']:.1f}% |")
    return "\n".join(lines) + "\n"


def main() -> None:
    args, output = _common.arguments(__doc__, "nearest_anchor")
    sizes = ([(1024, 1500)] if args.smoke
             else [(k, m) for k in (512, 1024, 2048, 4096) for m in (1500, 6000)])
    run = _common.header(command="python benchmarks/bench_nearest_anchor.py"
                         + (" --smoke" if args.smoke else ""))
    run["rows"] = measure(sizes)
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)


if __name__ == "__main__":
    main()
