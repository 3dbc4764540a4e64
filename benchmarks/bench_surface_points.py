"""The Catmull-Clark and Loop limit at any (face, u, v): `SurfacePoints` build and evaluation
costs, how deep faces are refined, and the normals at extraordinary vertices.

In one run, for Catmull-Clark on Suzanne (`tests/data/suzanne.obj`, 500 faces) and on
Suzanne refined twice (the refined mesh as a base mesh, 7,872 quads), and for Loop on
Suzanne triangulated (968 triangles):

- `build`: `SurfacePoints(mesh, CatmullClark(), faces, uv)` for N uniform random
  points (random faces, (u, v) uniform in the unit square), median of 3 runs; against
  the baseline a user has without it, the limit at the vertices of a refined mesh
  (`Refiner(mesh, levels)` + `Limit(refined mesh)`, built the same way), per point;
- `evaluate`: the warm, jitted `positions` and `normals` for new vertex positions,
  median of 20 calls, against `Limit.positions` after `Refiner` for the baseline;
- `depth`: how many levels the points needed (0: a regular face);
- `compilations`: XLA compilations while evaluating 5 different vertex arrays under
  one `jax.jit` (JAX's monitoring events);
- `semi_sharp_limits`: `Limit` on a cube with one semi-sharp edge, refining the
  tagged vertices' 1-rings against refining the whole mesh, time and peak memory;
- `normals`: at the corners of faces at interior extraordinary vertices (Suzanne's
  quads for Catmull-Clark, triangulated Suzanne for Loop), the angle to
  `Limit.normals` for `max_depth` 10 to 24, with the exact tangents `SurfacePoints`
  uses there and with the secant over the last sub-face instead.

Writes `surface_points.json` and `.md` (or `*_smoke.*` with `--smoke`).
"""

import json
import pathlib
import sys
import time

import jax


jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402


sys.path.insert(0, str(pathlib.Path(__file__).parent))
from _common import arguments, header, load, timed  # noqa: E402

import jaxsubdiv.surfaces as jss  # noqa: E402


SUZANNE = pathlib.Path(__file__).parent.parent / "tests" / "data" / "suzanne.obj"
CC = jss.CatmullClark()


def random_points(mesh, n, seed=0):
    rng = np.random.default_rng(seed)
    sizes = mesh.face_sizes()
    face = rng.integers(0, mesh.num_faces, n)
    uv = rng.uniform(size=(n, 2))
    subface = np.where(sizes[face] == 4, -1, rng.integers(0, 12, n) % sizes[face])
    return face, uv, subface


def build_and_evaluate(mesh, scheme, n, baseline_levels, repeats):
    face, uv, subface = random_points(mesh, n)
    if isinstance(scheme, jss.Loop):  # into the triangle; no sub-faces
        uv = np.where(uv.sum(1, keepdims=True) > 1, 1 - uv, uv)
        subface = np.full(n, -1)
    build, points = timed(lambda: jss.SurfacePoints(mesh, scheme, face, uv, subfaces=subface),
                          repeats)  # fmt: skip
    vertices = np.asarray(mesh.vertices) + 0.01
    # The tables are arguments, not constants folded into the programs.
    positions = jax.jit(lambda p, v: p.positions(v))
    normals = jax.jit(lambda p, v: p.normals(v))
    positions(points, vertices), normals(points, vertices)
    evaluate, _ = timed(lambda: positions(points, vertices), 20)
    evaluate_normals, _ = timed(lambda: normals(points, vertices), 20)

    def baseline():
        refiner = jss.Refiner(mesh, scheme, baseline_levels)
        return refiner, jss.Limit(refiner.mesh(mesh.vertices), scheme)

    base_build, (refiner, limit) = timed(baseline, repeats)
    base_points = refiner.num_vertices
    limit_positions = jax.jit(lambda r, lim, v: lim.positions(r(v)))
    limit_positions(refiner, limit, vertices)
    base_evaluate, _ = timed(lambda: limit_positions(refiner, limit, vertices), 20)
    depth = np.bincount(np.asarray(points.depth)).tolist()
    return {
        "points": n,
        "build_s": build,
        "build_us_per_point": 1e6 * build / n,
        "evaluate_ms": 1e3 * evaluate,
        "evaluate_ns_per_point": 1e9 * evaluate / n,
        "normals_ms": 1e3 * evaluate_normals,
        "weights_per_point": (len(points.position.rows) + len(points.first.rows)
                              + len(points.second.rows)) / n,  # fmt: skip
        "depth_histogram": depth,
        "baseline_levels": baseline_levels,
        "baseline_points": base_points,
        "baseline_build_s": base_build,
        "baseline_build_us_per_point": 1e6 * base_build / base_points,
        "baseline_evaluate_ms": 1e3 * base_evaluate,
        "baseline_evaluate_ns_per_point": 1e9 * base_evaluate / base_points,
    }


def compilations(mesh):
    face, uv, subface = random_points(mesh, 1000, seed=1)
    points = jss.SurfacePoints(mesh, CC, face, uv, subfaces=subface)
    count = [0]

    def listen(event, *_, **__):
        if event == "/jax/core/compile/backend_compile_duration":
            count[0] += 1

    f = jax.jit(lambda p, v: jnp.sum(p.normals(v)) + jnp.sum(p.positions(v)))
    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        for k in range(5):
            f(points, np.asarray(mesh.vertices) * (1 + 0.1 * k)).block_until_ready()
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    return count[0]


def normals_at_extraordinary_vertices(mesh, scheme, depths):
    faces = mesh.faces
    rows = [row[row >= 0] for row in faces]
    edges = np.sort(np.stack([np.concatenate(rows),
                              np.concatenate([np.roll(r, -1) for r in rows])], 1), 1)  # fmt: skip
    unique, count = np.unique(edges, axis=0, return_counts=True)
    valence = np.bincount(unique.reshape(-1))
    boundary = np.zeros(len(valence), bool)
    boundary[unique[count == 1].reshape(-1)] = True
    loop = isinstance(scheme, jss.Loop)
    corners, regular = (3, 6) if loop else (4, 4)
    corner_uv = np.array([[0, 0], [1, 0], [0, 1]] if loop else [[0, 0], [1, 0], [1, 1], [0, 1]],
                         float)  # fmt: skip
    face, uv, vertex = [], [], []
    for f, row in enumerate(rows):
        if len(row) == corners:
            for c in range(corners):
                if valence[row[c]] != regular and not boundary[row[c]]:
                    face.append(f), uv.append(corner_uv[c]), vertex.append(row[c])
    vertex = np.array(vertex)
    want = np.asarray(jss.Limit(mesh, scheme).normals(mesh.vertices))[vertex]
    out = []
    for depth in depths:
        points = jss.SurfacePoints(mesh, scheme, np.array(face), np.array(uv), max_depth=depth)
        du, dv = (np.asarray(d) for d in points.derivatives(mesh.vertices))
        secant = np.cross(du, dv)
        secant /= np.linalg.norm(secant, axis=1, keepdims=True)
        exact = np.asarray(points.normals(mesh.vertices))
        row = {"max_depth": depth}
        for name, normal in (("normals", exact), ("secant", secant)):
            angle = np.degrees(np.arccos(np.clip(np.sum(normal * want, 1), -1, 1)))
            for v in np.unique(valence[vertex]):
                row[f"{name}_valence_{v}"] = float(angle[valence[vertex] == v].max())
        out.append(row)
    # The normals of exact patches near the vertex, along the face's diagonal.
    at = np.asarray(jss.SurfacePoints(mesh, scheme, np.array(face), np.array(uv)).normals(mesh.vertices))
    towards = corner_uv.mean(axis=0) - np.array(uv)
    for distance in (2.0**-8, 2.0**-12, 2.0**-14):
        near = jss.SurfacePoints(mesh, scheme, np.array(face), np.array(uv) + distance * towards)
        normal = np.asarray(near.normals(mesh.vertices))
        angle = np.degrees(np.arccos(np.clip(np.sum(normal * at, 1), -1, 1)))
        row = {"max_depth": f"nearby, 2^{int(np.log2(distance))}, exact: {bool(np.all(near.exact))}"}
        for v in np.unique(valence[vertex]):
            row[f"normals_valence_{v}"] = float(angle[valence[vertex] == v].max())
            row[f"secant_valence_{v}"] = float("nan")
        out.append(row)
    return out, {int(v): int((valence[vertex] == v).sum()) for v in np.unique(valence[vertex])}


def semi_sharp_limits():
    """`Limit` on a cube with one edge of each sharpness: wall time and peak host memory
    (tracemalloc) of the local refinement of the tagged vertices' 1-rings against
    refining the whole mesh (where it fits in 2 GiB)."""
    import tracemalloc

    from jaxsubdiv.surfaces._refine import _semi_sharp_limit

    v = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    f = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    rows = []
    _semi_sharp_limit(jss.Mesh(v, f, creases=[[0, 2]], crease_sharpness=[1.5]), CC, 2**31)  # imports
    for sharpness in (2.5, 4.5, 6.5, 9.99):
        mesh = jss.Mesh(v, f, creases=[[0, 2]], crease_sharpness=[sharpness])
        row = {"sharpness": sharpness}
        for name, local in (("local", True), ("whole", False)):
            tracemalloc.start()
            start = time.perf_counter()
            try:
                _semi_sharp_limit(mesh, CC, 2**31, local=local)
                row[f"{name}_s"] = time.perf_counter() - start
                row[f"{name}_peak_mb"] = tracemalloc.get_traced_memory()[1] / 1e6
            except ValueError:
                row[f"{name}_s"], row[f"{name}_peak_mb"] = None, "above 2 GiB"
            tracemalloc.stop()
        rows.append(row)
    return rows


def markdown(results) -> str:
    lines = [
        "# SurfacePoints: the Catmull-Clark and Loop limit at any (face, u, v)",
        "",
        f"{results['date']}, {results['machine']}, load {results['load_start']} at the start, "
        f"{results['load_end']} at the end; jax {results['jax']}, float64. "
        "`python benchmarks/bench_surface_points.py`.",
        "",
        "Build (host, median of 3) and warm jitted evaluation (median of 20) for N uniform "
        "random points, against the limit at the vertices of a refined mesh (`Refiner` + "
        "`Limit`, the same host build and kernel), per point.",
        "",
        "| scheme, mesh | N | build s | us/point | positions ms | ns/point | normals ms | weights/point "
        "| baseline: levels, points | build us/point | ns/point | levels refined (points at 0, 1, 2, ...) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---|",
    ]
    for r in results["sizes"]:
        lines.append(
            f"| {r['mesh']} | {r['points']:,} | {r['build_s']:.3f} | {r['build_us_per_point']:.1f} "
            f"| {r['evaluate_ms']:.2f} | {r['evaluate_ns_per_point']:.0f} | {r['normals_ms']:.2f} "
            f"| {r['weights_per_point']:.0f} | {r['baseline_levels']}, {r['baseline_points']:,} "
            f"| {r['baseline_build_us_per_point']:.1f} | {r['baseline_evaluate_ns_per_point']:.0f} "
            f"| {', '.join(map(str, r['depth_histogram']))} |"
        )
    lines += [
        "",
        f"XLA compilations while evaluating positions and normals for 5 different vertex "
        f"arrays under one `jax.jit`: **{results['compilations']}**.",
        "",
        "Normals at the corners of faces at interior extraordinary vertices, largest angle "
        "to `Limit.normals`, degrees, by `max_depth`: what `normals` returns there (the "
        "vertex's exact limit tangents; at valence 2, which has no tangent plane, the "
        "secant) and the secant over the last sub-face. Rows *nearby*: the largest angle "
        "between that normal and the normals of points at 2^-8, 2^-12, 2^-14 of the "
        "face's size from the vertex along the face's diagonal (all on exact patches).",
    ]
    lines += ["", "`Limit` on a cube with one semi-sharp edge (Catmull-Clark): the local "
              "refinement of the tagged vertices' 1-rings against the whole mesh refined "
              "until the sharpness decays; wall time and peak host memory (tracemalloc).", "",
              "| sharpness | local s | local peak MB | whole s | whole peak MB |",
              "|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in results["semi_sharp_limits"]:
        cell = lambda x, f: "-" if x is None else (x if isinstance(x, str) else f.format(x))
        lines.append(f"| {r['sharpness']} | {cell(r['local_s'], '{:.3f}')} | "
                     f"{cell(r['local_peak_mb'], '{:.2f}')} | {cell(r['whole_s'], '{:.3f}')} | "
                     f"{cell(r['whole_peak_mb'], '{:.1f}')} |")  # fmt: skip
    for scheme, rows in results["normals"].items():
        keys = [k for k in rows[0] if k != "max_depth"]
        lines += ["", f"{scheme}, corners at extraordinary vertices by valence: "
                  f"{results['normal_corners'][scheme]}", ""]  # fmt: skip
        lines.append("| max_depth | " + " | ".join(k.replace("_", " ") for k in keys) + " |")
        lines.append("|---:|" + "---:|" * len(keys))
        for row in rows:
            lines.append(f"| {row['max_depth']} | "
                         + " | ".join("-" if row[k] != row[k] else f"{row[k]:.1e}"
                                      for k in keys) + " |")  # fmt: skip
    return "\n".join(lines) + "\n"


def main():
    args, output = arguments(__doc__, "surface_points")
    results = header(jax=jax.__version__)
    suzanne = jss.read_mesh(SUZANNE)
    refined = jss.refine_mesh(suzanne, CC, 2)
    rows = [r[r >= 0] for r in suzanne.faces]
    triangles = np.array([[r[0], r[k], r[k + 1]] for r in rows for k in range(1, len(r) - 1)])
    triangulated = jss.Mesh(suzanne.vertices, triangles)
    repeats = 1 if args.smoke else 3
    sizes = [(1_000,)] if args.smoke else [(1_000,), (10_000,), (100_000,)]
    results["sizes"] = []
    for name, mesh, scheme, levels in (
        ("Catmull-Clark, Suzanne (500 faces)", suzanne, CC, 3),
        ("Catmull-Clark, Suzanne x2 (7,872 quads)", refined, CC, 1),
        (f"Loop, Suzanne triangulated ({len(triangles)} triangles)", triangulated, jss.Loop(), 3),
    ):
        for (n,) in sizes:
            row = build_and_evaluate(mesh, scheme, n, levels, repeats)
            results["sizes"].append({"mesh": name, **row})
            print(name, row, flush=True)
    results["compilations"] = compilations(suzanne)
    depths = [10, 16] if args.smoke else [10, 12, 16, 20, 24]
    results["normals"], results["normal_corners"] = {}, {}
    for name, mesh, scheme in (("Catmull-Clark, Suzanne", suzanne, CC),
                               ("Loop, Suzanne triangulated", triangulated, jss.Loop())):  # fmt: skip
        rows, counts = normals_at_extraordinary_vertices(mesh, scheme, depths)
        results["normals"][name], results["normal_corners"][name] = rows, counts
    results["semi_sharp_limits"] = semi_sharp_limits()
    results["load_end"] = load()
    output.write_text(json.dumps(results, indent=1))
    output.with_suffix(".md").write_text(markdown(results))
    print(markdown(results))


if __name__ == "__main__":
    main()
