"""Surface subdivision: topology build, stencil application, trimesh and libigl.

For Loop (triangle torus), Catmull-Clark and Doo-Sabin (quad torus) on about 10,000
faces and 1, 2, 3 levels, measured in one run:

- `build`: host-side topology refinement into a composite stencil table
  (`Refiner(mesh, scheme, levels)`), median wall time;
- `apply`: re-applying the per-level tables to new positions (`jax.jit`-ed
  `refiner(v)`, warm median): the common case inside an optimization loop;
- `apply_grouped`: the per-level tables with rows grouped by stencil width, each group a
  dense `(rows, width)` gather-multiply-sum, then one permutation back to row order
  (an alternative layout tried against the segment-sum; `apply_again` re-measures
  `apply` after it to show the noise);
- `apply_composite`: the single composite table (base -> level `levels`) with the same
  segment-sum kernel, and `apply_composite_padded`: that table as a padded
  `(rows, max width)` gather-multiply-sum, the alternative layouts;
- `trimesh` (`trimesh.remesh.subdivide_loop`) and `libigl` (`igl.loop`) for Loop, each
  refining topology and positions on every call;
- `copy`: a numpy copy of an output-sized float64 array, the memory ceiling, and
  `copy_touched`: a copy of as many bytes as the per-level kernels must touch (table
  entries and each level's output); `fraction_of_* = copy_* / apply`.

Writes `surfaces.json` and `.md` (or `surfaces_smoke.*` with `--smoke`) to `--output`
(default `benchmarks/results/`).
"""

import argparse
import importlib.metadata
import json
import platform
import sys
import time
from pathlib import Path

import jax


jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxsubdiv.surfaces as jss  # noqa: E402


sys.path.insert(0, str(Path(__file__).parent))
from _common import timed  # noqa: E402


def _version(distribution):
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return None


def torus(m, n, triangles):
    i, j = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    u, v = 2 * np.pi * i.ravel() / m, 2 * np.pi * j.ravel() / n
    points = np.stack([(2 + np.cos(v)) * np.cos(u), (2 + np.cos(v)) * np.sin(u), np.sin(v)], 1)
    idx = lambda a, b: (a % m) * n + (b % n)
    quads = np.stack([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)], -1).reshape(-1, 4)
    if not triangles:
        return points, quads
    a, b, c, d = quads.T
    return points, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def median_time(fn, repeats):
    return float(timed(fn, repeats)[0])


def padded(table: jss.StencilTable):
    """The table as padded (rows, width) gather indices and weights."""
    rows, cols, weights = (np.asarray(a) for a in (table.rows, table.cols, table.weights))
    counts = np.bincount(rows, minlength=table.num_rows)
    width = int(counts.max())
    starts = np.concatenate([[0], np.cumsum(counts)])[:-1]
    slot = np.arange(len(rows)) - starts[rows]
    index = np.zeros((table.num_rows, width), np.int32)
    weight = np.zeros((table.num_rows, width))
    index[rows, slot], weight[rows, slot] = cols, weights
    return jnp.asarray(index), jnp.asarray(weight), width


@jax.jit
def apply_padded(index, weight, x):
    return jnp.einsum("rw,rwc->rc", weight, x[index])


def grouped(table: jss.StencilTable):
    """The table's rows grouped by stencil width: per width a dense `(rows, width)`
    gather and weights, and the permutation back to row order."""
    rows, cols, weights = (np.asarray(a) for a in (table.rows, table.cols, table.weights))
    counts = np.bincount(rows, minlength=table.num_rows)
    starts = np.concatenate([[0], np.cumsum(counts)])[:-1]
    groups, order = [], []
    for width in np.unique(counts):  # a handful of widths per table
        r = np.flatnonzero(counts == width)
        slots = starts[r][:, None] + np.arange(width)
        groups.append((jnp.asarray(cols[slots], jnp.int32), jnp.asarray(weights[slots])))
        order.append(r)
    inverse = np.empty(table.num_rows, np.int32)
    inverse[np.concatenate(order)] = np.arange(table.num_rows)
    return groups, jnp.asarray(inverse)


@jax.jit
def apply_grouped_levels(layers, x):
    for groups, inverse in layers:
        x = jnp.concatenate([jnp.einsum("rw,rwc->rc", w, x[i]) for i, w in groups])[inverse]
    return x


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="a tiny case in a few seconds")
    parser.add_argument("--output", type=Path, default=Path(__file__).parent / "results",
                        help="directory for the JSON and Markdown results")  # fmt: skip
    args = parser.parse_args()
    if args.smoke:
        sizes, levels_list, repeats = dict(tri=(6, 8), quad=(6, 8)), (1, 2), 2
    else:
        sizes, levels_list, repeats = dict(tri=(50, 100), quad=(100, 100)), (1, 2, 3), 7
    try:
        import trimesh
    except ImportError:
        trimesh = None
    try:
        import igl
    except ImportError:
        igl = None

    rows = []
    cases = [("Loop", jss.Loop(), "tri"), ("CatmullClark", jss.CatmullClark(), "quad"),
             ("DooSabin", jss.DooSabin(), "quad")]  # fmt: skip
    for name, scheme, kind in cases:
        points, faces = torus(*sizes[kind], triangles=kind == "tri")
        mesh = jss.Mesh(points, faces)
        for levels in levels_list:
            row = dict(scheme=name, faces=len(faces), levels=levels)
            build_repeats = 1 if levels == 3 else min(repeats, 3)
            row["build_s"] = median_time(lambda: jss.Refiner(mesh, scheme, levels), build_repeats)
            refiner = jss.Refiner(mesh, scheme, levels)
            row["out_vertices"] = refiner.num_vertices
            row["nnz_levels"] = int(sum(t.rows.shape[0] for t in refiner.tables))
            start = time.perf_counter()
            composite = refiner.composite()
            row["build_composite_s"] = row["build_s"] + time.perf_counter() - start
            row["nnz_composite"] = int(composite.rows.shape[0])
            apply = jax.jit(lambda r, x: r(x))
            new = jnp.asarray(points + 0.01)
            apply(refiner, new).block_until_ready()
            row["apply_s"] = median_time(lambda: apply(refiner, new), repeats)
            layers = [grouped(t) for t in refiner.tables]
            apply_grouped_levels(layers, new).block_until_ready()
            row["apply_grouped_s"] = median_time(lambda: apply_grouped_levels(layers, new), repeats)
            # Measured twice, interleaved, to see the noise of a shared machine.
            row["apply_again_s"] = median_time(lambda: apply(refiner, new), repeats)
            apply(composite, new).block_until_ready()
            row["apply_composite_s"] = median_time(lambda: apply(composite, new), repeats)
            index, weight, width = padded(composite)
            apply_padded(index, weight, new).block_until_ready()
            row["apply_composite_padded_s"] = median_time(
                lambda: apply_padded(index, weight, new), repeats
            )
            row["padded_width"] = width
            out = np.zeros((refiner.num_vertices, 3))
            row["copy_s"] = median_time(lambda: out.copy(), repeats * 3)
            # What the per-level kernels must at least touch: each table entry (two
            # int32 indices, one float64 weight) and each level's float64 output.
            touched = sum(16 * t.rows.shape[0] + 24 * t.num_rows for t in refiner.tables)
            buffer = np.zeros(touched, np.uint8)
            row["copy_touched_s"] = median_time(lambda: buffer.copy(), repeats * 3)
            row["fraction_of_output_copy"] = row["copy_s"] / row["apply_s"]
            row["fraction_of_touched_copy"] = row["copy_touched_s"] / row["apply_s"]
            if name == "Loop" and trimesh is not None:
                row["trimesh_s"] = median_time(
                    lambda: trimesh.remesh.subdivide_loop(points, faces, iterations=levels),
                    build_repeats,
                )
            if name == "Loop" and igl is not None:
                row["libigl_s"] = median_time(
                    lambda: igl.loop(points, faces.astype(np.int64), levels), build_repeats
                )
            rows.append(row)
            print(json.dumps(row))

    out_dir = args.output
    out_dir.mkdir(exist_ok=True)
    stem = "surfaces_smoke" if args.smoke else "surfaces"
    meta = dict(
        machine=platform.platform(), jax=jax.__version__, devices=str(jax.devices()),
        trimesh=getattr(trimesh, "__version__", None), libigl=_version("libigl") if igl else None,
    )  # fmt: skip
    (out_dir / f"{stem}.json").write_text(json.dumps(dict(meta=meta, rows=rows), indent=2))

    def ms(x):
        return "-" if x is None else f"{1e3 * x:.2f}"

    lines = [
        "| scheme | faces | levels | out vertices | nnz (levels / composite) | build ms "
        "(levels / +composite) | apply ms: levels (again) | levels grouped by width | composite | composite padded | "
        "copy ms: output | touched | fraction of ceiling (output / touched) | trimesh ms | libigl ms |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['scheme']} | {r['faces']} | {r['levels']} | {r['out_vertices']} | "
            f"{r['nnz_levels']} / {r['nnz_composite']} | {ms(r['build_s'])} / "
            f"{ms(r['build_composite_s'])} | {ms(r['apply_s'])} ({ms(r['apply_again_s'])}) | "
            f"{ms(r['apply_grouped_s'])} | {ms(r['apply_composite_s'])} | "
            f"{ms(r['apply_composite_padded_s'])} | {ms(r['copy_s'])} | {ms(r['copy_touched_s'])} | "
            f"{r['fraction_of_output_copy']:.3f} / {r['fraction_of_touched_copy']:.2f} | "
            f"{ms(r.get('trimesh_s'))} | {ms(r.get('libigl_s'))} |"
        )
    note = (
        f"\nfloat64, 3 channels, {meta['devices']}, jax {meta['jax']}, trimesh "
        f"{meta['trimesh']}, libigl {meta['libigl']}. Medians; trimesh and libigl rebuild "
        "topology on every call, so compare them with build + apply.\n"
    )
    (out_dir / f"{stem}.md").write_text("\n".join(lines) + "\n" + note)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
