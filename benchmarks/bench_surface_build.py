"""Refining a mesh once: jaxsubdiv's host-side cost against CGAL and trimesh.

    python benchmarks/bench_surface_build.py                   # this tree, a few minutes
    python benchmarks/bench_surface_build.py --before f9557a0  # and a git revision, one run
    python benchmarks/bench_surface_build.py --smoke           # tiny mesh, no CGAL (seconds)

Meshes (built with numpy here): a quad torus on a 64 x 128 grid (8,192 quads) for
Catmull-Clark and Doo-Sabin, and its triangulation (16,384 triangles, each quad split
along one diagonal) for Loop; the same torus on a 16 x 32 grid (512 quads, 1,024
triangles) shows the per-call overhead. Levels 1, 2 and 3.

Measured, in one run:

- `Refiner build`: `jaxsubdiv.surfaces.Refiner(mesh, scheme, levels)`, the host-side
  topology build and per-level stencil tables, after one warm-up call;
- `first build, new size`: one `Refiner` build for a torus with one more row per case
  than any case before it (a mesh size the process has not seen), before the warm-up:
  anything compiled per array shape shows here;
- `refine_mesh`: a warm one-shot `jaxsubdiv.surfaces.refine_mesh(mesh, scheme,
  levels).vertices.block_until_ready()` (called once first, so that the jitted kernels
  are compiled): what a user refining a mesh once pays, the build included;
- `CGAL`: `CGAL::Subdivision_method_3`'s `CatmullClark_subdivision`,
  `Loop_subdivision` or `DooSabin_subdivision` on a `CGAL::Surface_mesh` (copy the mesh,
  subdivide in place; the file read is not timed), from `benchmarks/cgal_subdivide.cpp`,
  compiled once with `g++ -O2 -DNDEBUG -std=c++17` and kept under
  `$XDG_CACHE_HOME/jaxsubdiv/bench/`. Needs g++ and CGAL's headers (Debian:
  `apt-get install libcgal-dev`); without them the column says why and the rest runs;
- `trimesh` (Loop only): `trimesh.remesh.subdivide_loop(vertices, faces, iterations)`.

jaxsubdiv runs in fresh interpreters (float64, `jax_enable_x64`), `--rounds` of them per
version; each times every case `--repeats` times (once for level 3 of the large mesh).
With `--before REV` the revision is extracted with `git archive` and measured too, the
versions alternating round by round (in turn first), so the after/before ratios come
from one run on the same machine state; CGAL and trimesh run in every round as well.
Times are medians (min-max) over all rounds and repeats. The output vertex and face
counts of every library are compared with ours; a mismatch is shown in the table.

Writes `benchmarks/results/surface_build.json` and `.md` (`surface_build_smoke.*` with
`--smoke`; `--output` sets the JSON path, the Markdown goes beside it).
"""

import hashlib
import json
import os
import pathlib
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np


BENCH = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))
import _common  # noqa: E402


ROOT = BENCH.parent
CGAL_SOURCE = BENCH / "cgal_subdivide.cpp"
CGAL_FLAGS = ["-O2", "-DNDEBUG", "-std=c++17"]
SCHEMES = ("CatmullClark", "Loop", "DooSabin")
MESHES = {"large": (64, 128), "small": (16, 32)}
SMOKE_MESHES = {"tiny": (6, 8)}
# The child: this file's `child`, in a fresh interpreter whose path starts with the
# version's source tree (see `_run_ours`).
CHILD = "import sys, bench_surface_build as b; b.child(sys.argv[1])"


def torus(m: int, n: int, triangles: bool):
    """Vertices and faces of an `m x n` quad torus, or its triangulation."""
    i, j = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    u, v = 2 * np.pi * i.ravel() / m, 2 * np.pi * j.ravel() / n
    points = np.stack([(2 + np.cos(v)) * np.cos(u), (2 + np.cos(v)) * np.sin(u), np.sin(v)], 1)
    i, j = i.ravel(), j.ravel()
    index = lambda a, b: (a % m) * n + (b % n)  # noqa: E731
    quads = np.stack([index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)], 1)
    if not triangles:
        return points, quads
    a, b, c, d = quads.T
    return points, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def _cases(smoke: bool, repeats: int) -> list[dict]:
    meshes, levels = (SMOKE_MESHES, (1,)) if smoke else (MESHES, (1, 2, 3))
    return [dict(scheme=scheme, mesh=mesh, grid=grid, levels=level,
                 repeats=1 if (mesh == "large" and level == 3) else repeats)
            for mesh, grid in meshes.items() for scheme in SCHEMES for level in levels]


def child(cases_json: str) -> None:
    """Time every case with the `jaxsubdiv` found first on the path; print one JSON line."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxsubdiv
    import jaxsubdiv.surfaces as S

    # The process's first build pays imports and caches (scipy.sparse, the first device
    # transfers): paid here, untimed, on a size no case uses.
    for name in SCHEMES:
        S.Refiner(S.Mesh(*torus(3, 5, triangles=name == "Loop")), getattr(S, name)(), 1)
    results = []
    for index, case in enumerate(json.loads(cases_json)):
        mesh = S.Mesh(*torus(*case["grid"], triangles=case["scheme"] == "Loop"))
        scheme, levels = getattr(S, case["scheme"])(), case["levels"]
        # A mesh of a size no earlier case had (one more row per case): its first build,
        # what a user meets on a new mesh (anything compiled per array shape shows here).
        m, n = case["grid"]
        points, faces = torus(m + 1 + index, n, triangles=case["scheme"] == "Loop")
        start = time.perf_counter()
        S.Refiner(S.Mesh(points, faces), scheme, levels)
        first = time.perf_counter() - start
        warm = S.refine_mesh(mesh, scheme, levels)  # compiles the kernels
        warm.vertices.block_until_ready()
        build, refine = [], []
        for _ in range(case["repeats"]):
            start = time.perf_counter()
            S.Refiner(mesh, scheme, levels)
            build.append(time.perf_counter() - start)
            start = time.perf_counter()
            S.refine_mesh(mesh, scheme, levels).vertices.block_until_ready()
            refine.append(time.perf_counter() - start)
        results.append(dict(build_s=build, refine_s=refine, first_build_s=[first],
                            vertices=warm.num_vertices, faces=warm.num_faces))
    print(json.dumps(dict(source=jaxsubdiv.__file__, jax=jax.__version__, results=results)))


def _run_ours(source: pathlib.Path, cases: list[dict], what: str) -> dict:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(source), str(BENCH), os.environ.get("PYTHONPATH", "")])}
    # cwd = the source tree: `-c` puts the working directory first on the path.
    done = _common.child_json(CHILD, json.dumps(cases), what=what, env=env, cwd=source)
    if not pathlib.Path(done["source"]).resolve().is_relative_to(source.resolve()):
        raise SystemExit(f"{what} imported jaxsubdiv from {done['source']}, not {source}")
    return done


def _write_off(path: pathlib.Path, points: np.ndarray, faces: np.ndarray) -> None:
    lines = [f"OFF\n{len(points)} {len(faces)} 0"]
    lines += [f"{x!r} {y!r} {z!r}" for x, y, z in points.tolist()]
    lines += [f"{len(f)} " + " ".join(map(str, f)) for f in faces.tolist()]
    path.write_text("\n".join(lines) + "\n")


def _cgal_driver(scratch: pathlib.Path) -> tuple[str | None, str]:
    """`(executable, CGAL version)`, compiling `cgal_subdivide.cpp` unless a build of the
    same source, flags, compiler and CGAL is cached; `(None, why not)` without them."""
    compiler = shutil.which("g++")
    if compiler is None:
        return None, "not installed (no g++)"
    probe = subprocess.run([compiler, "-E", "-P", "-x", "c++", "-"], capture_output=True,
                           text=True, input="#include <CGAL/version.h>\nCGAL_VERSION_STR\n")
    if probe.returncode != 0:
        return None, "not installed (no CGAL headers; apt-get install libcgal-dev)"
    version = probe.stdout.strip().splitlines()[-1].strip().strip('"')
    compiler_version = subprocess.run([compiler, "--version"], capture_output=True,
                                      text=True).stdout.splitlines()[0]
    key = hashlib.sha256("\n".join([CGAL_SOURCE.read_text(), " ".join(CGAL_FLAGS),
                                    compiler_version, version]).encode()).hexdigest()[:16]
    cache = pathlib.Path(os.environ.get("XDG_CACHE_HOME", "").strip()
                         or pathlib.Path.home() / ".cache") / "jaxsubdiv" / "bench"
    try:
        cache.mkdir(parents=True, exist_ok=True)
    except OSError:
        cache = scratch
    executable = cache / f"cgal_subdivide-{key}"
    if not executable.exists():
        print(f"compiling {CGAL_SOURCE.name} against CGAL {version} ...", flush=True)
        partial = scratch / executable.name
        done = subprocess.run([compiler, *CGAL_FLAGS, str(CGAL_SOURCE), "-o", str(partial)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            print(done.stderr[-3000:], file=sys.stderr)
            return None, f"not available (compiling against CGAL {version} failed)"
        shutil.copy2(partial, executable)
    return str(executable), version


def _run_cgal(executable: str, case: dict, off: pathlib.Path) -> dict:
    done = subprocess.run([executable, case["scheme"], str(case["levels"]),
                           str(case["repeats"]), str(off)],
                          capture_output=True, text=True, timeout=900)
    if done.returncode != 0:
        return dict(error=done.stderr.strip()[-500:] or f"exit {done.returncode}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _run_trimesh(trimesh, points, faces, case: dict) -> dict:
    seconds = []
    for _ in range(case["repeats"]):
        start = time.perf_counter()
        vertices, out = trimesh.remesh.subdivide_loop(points, faces, iterations=case["levels"])
        seconds.append(time.perf_counter() - start)
    return dict(seconds=seconds, vertices=len(vertices), faces=len(out))


def _ms(values) -> str:
    return _common.median_range([1e3 * x for x in values]) if values else "-"


def _ratio(numerator, denominator) -> str:
    if not numerator or not denominator:
        return "-"
    return f"{statistics.median(numerator) / statistics.median(denominator):.2f}"


def _counts(row: dict) -> str:
    """`ok`, or every output whose vertex and face counts differ from ours (after)."""
    ours = row["ours"]["after"]
    expected = (ours["vertices"], ours["faces"])
    odd = []
    for name, got in [(f"ours {v}", row["ours"][v]) for v in row["ours"] if v != "after"] + \
                     [("CGAL", row.get("cgal", {})), ("trimesh", row.get("trimesh", {}))]:
        if "vertices" in got and (got["vertices"], got["faces"]) != expected:
            odd.append(f"{name} {got['vertices']} v / {got['faces']} f")
    return "ok" if not odd else f"**mismatch** (ours {expected[0]} v / {expected[1]} f): " + \
        ", ".join(odd)


def _markdown(report: dict) -> str:
    before = "before" in report["versions"]
    versions = ", ".join(f"{name} = `{commit}`" for name, commit in report["versions"].items())
    lines = [
        "# Refining a mesh once: jaxsubdiv against CGAL and trimesh", "",
        f"{report['date']}; {report['machine']}; load average at the start "
        f"{report['load_start']}, at the end {report['load_end']}. Produced by "
        f"`{report['command']}`.", "",
        f"jax {report['jax']}, float64; {versions}; CGAL {report['cgal']}"
        + (f" (`g++ {' '.join(CGAL_FLAGS)}`)" if report["cgal"][:1].isdigit() else "")
        + f"; trimesh {report['trimesh']}. {report['rounds']} round(s) of fresh "
        "interpreters per version" + (", alternating" if before else "")
        + f", {report['repeats']} timed call(s) in each per case"
        + ("" if report["smoke"] else " (1 for level 3 of the large mesh)")
        + "; CGAL and trimesh in every round. "
        "Times in ms, median (min-max). `refine_mesh` is warm (kernels compiled) and "
        "includes the build; CGAL copies and subdivides a `Surface_mesh`; ratios are of "
        "medians (below 1: ours is faster).", "",
    ]
    head = ["scheme", "mesh", "faces", "levels", "out vertices", "out faces",
            "Refiner build ms", "refine_mesh ms", "first build, new size ms"]
    if before:
        head += ["build before ms", "refine_mesh before ms", "first build before ms",
                 "build after/before", "refine_mesh after/before", "first build after/before"]
    head += ["CGAL ms", "trimesh ms", "refine_mesh / CGAL", "build / CGAL",
             "refine_mesh / trimesh", "counts"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * 4 + "---:|" * (len(head) - 5)
              + "---|"]
    for row in report["rows"]:
        after = row["ours"]["after"]
        cgal, tri = row.get("cgal", {}), row.get("trimesh", {})
        cells = [row["scheme"], f"{row['mesh']} {row['grid'][0]}x{row['grid'][1]}",
                 row["faces"], row["levels"], after["vertices"], after["faces"],
                 _ms(after["build_s"]), _ms(after["refine_s"]), _ms(after.get("first_build_s"))]
        if before:
            old = row["ours"]["before"]
            cells += [_ms(old["build_s"]), _ms(old["refine_s"]), _ms(old.get("first_build_s")),
                      _ratio(after["build_s"], old["build_s"]),
                      _ratio(after["refine_s"], old["refine_s"]),
                      _ratio(after.get("first_build_s"), old.get("first_build_s"))]
        cgal_cell = _ms(cgal["seconds"]) if "seconds" in cgal else cgal.get("status", "-")
        cells += [cgal_cell, _ms(tri.get("seconds")),
                  _ratio(after["refine_s"], cgal.get("seconds")),
                  _ratio(after["build_s"], cgal.get("seconds")),
                  _ratio(after["refine_s"], tri.get("seconds")), _counts(row)]
        lines.append("| " + " | ".join(map(str, cells)) + " |")
    return "\n".join(lines) + "\n"


def main() -> int:
    args, output, rounds, repeats = _common.versions_arguments(
        __doc__, "surface_build", rounds=(1, 3), repeats=(1, 2),
        smoke_help="tiny mesh, level 1, one call, no CGAL (for CI)")
    cases = _cases(args.smoke, repeats)
    from bench_analysis import _commit, _extract  # the `--before` tree, as it makes it

    report = _common.header(command=" ".join(["python", "benchmarks/bench_surface_build.py",
                                              *sys.argv[1:]]),
                            smoke=args.smoke, rounds=rounds, repeats=repeats)
    try:
        import trimesh
    except ImportError:
        trimesh = None
    with tempfile.TemporaryDirectory() as tmp:
        scratch = pathlib.Path(tmp)
        versions = {"after": (ROOT, _commit("HEAD") + "+worktree")}
        if args.before:
            versions = {"before": (_extract(args.before, scratch), _commit(args.before)),
                        **versions}
        report["versions"] = {name: commit for name, (_, commit) in versions.items()}
        meshes = {}
        for case in cases:
            kind = (case["mesh"], case["scheme"] == "Loop")
            if kind not in meshes:
                points, faces = torus(*case["grid"], triangles=kind[1])
                off = scratch / f"{case['mesh']}_{'tri' if kind[1] else 'quad'}.off"
                _write_off(off, points, faces)
                meshes[kind] = points, faces, off
            case["faces"] = len(meshes[kind][1])
        if args.smoke:
            executable, report["cgal"] = None, "skipped (--smoke)"
        else:
            executable, report["cgal"] = _cgal_driver(scratch)
            if executable is None:
                print(f"CGAL: {report['cgal']}", flush=True)
        report["trimesh"] = trimesh.__version__ if trimesh else "not installed"
        if trimesh:  # its first call's imports and caches, untimed
            trimesh.remesh.subdivide_loop(*torus(4, 6, triangles=True), iterations=1)
        rows = [dict(case, ours={name: dict(build_s=[], refine_s=[], first_build_s=[])
                                 for name in versions},
                     cgal=dict(seconds=[]) if executable else dict(status=report["cgal"]),
                     trimesh=dict(seconds=[]) if trimesh and case["scheme"] == "Loop" else {})
                for case in cases]
        for turn in range(rounds):
            order = list(versions.items())
            for name, (source, _) in order if turn % 2 == 0 else order[::-1]:
                done = _run_ours(source, cases, what=f"jaxsubdiv {name}")
                report["jax"] = done["jax"]
                for row, result in zip(rows, done["results"]):
                    ours = row["ours"][name]
                    ours["build_s"] += result["build_s"]
                    ours["refine_s"] += result["refine_s"]
                    ours["first_build_s"] += result["first_build_s"]
                    ours.update(vertices=result["vertices"], faces=result["faces"])
            for row, case in zip(rows, cases):
                points, faces, off = meshes[case["mesh"], case["scheme"] == "Loop"]
                if executable and "seconds" in row["cgal"]:
                    result = _run_cgal(executable, case, off)
                    if "error" in result:
                        row["cgal"] = dict(status=f"failed: {result['error']}")
                    else:
                        row["cgal"]["seconds"] += result["seconds"]
                        row["cgal"].update(vertices=result["vertices"], faces=result["faces"])
                if "seconds" in row["trimesh"]:
                    result = _run_trimesh(trimesh, points, faces, case)
                    row["trimesh"]["seconds"] += result.pop("seconds")
                    row["trimesh"].update(result)
            print(f"round {turn + 1}/{rounds} done", flush=True)
    for row in rows:
        row["counts"] = _counts(row)
    report["rows"], report["load_end"] = rows, _common.load()
    output.write_text(json.dumps(report, indent=1))
    output.with_suffix(".md").write_text(_markdown(report))
    print(_markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
