"""`SurfacePoints` against OpenSubdiv's own evaluation at (face, u, v) (Bfr, 3.5).

Not a timing benchmark: a verification script that makes the reference data of
`tests/test_surface_points.py::test_matches_opensubdiv_bfr` (`tests/data/osd_surface_points.npz`)
and reports the differences. It compiles `osd_evaluate.cpp` with g++ against Debian's
`libosd-dev` (`apt-get install libosd-dev`), then, for the meshes of the tests (every
kind of corner, semi-sharp creases, both boundary options and crease methods,
Catmull-Clark and Loop), evaluates random points (a third of them within 1e-3 to 0.1 of a
face corner) on quads (Catmull-Clark) and triangles (Loop): position, first and second
derivatives, Bfr with its approximation levels at their maximum (10).

Bfr evaluates the limit exactly where the face becomes a regular patch within 10 levels
of refinement, and approximates it closer to an irregular vertex (Gregory patches);
`SurfacePoints` refines up to `max_depth` (16). So the points `SurfacePoints` puts on a
regular patch within 9 levels are compared exactly; the others are reported apart.

```bash
apt-get install libosd-dev
python benchmarks/osd_surface_points.py     # writes the .npz and results/osd_surface_points.md
```
"""

import datetime
import pathlib
import subprocess
import sys
import tempfile

import jax


jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402


ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from test_surface_points import CASES  # noqa: E402

import jaxsubdiv.surfaces as jss  # noqa: E402


DATA = ROOT / "tests" / "data" / "osd_surface_points.npz"
RESULTS = ROOT / "benchmarks" / "results" / "osd_surface_points.md"


def compile_driver() -> pathlib.Path:
    binary = pathlib.Path(tempfile.mkdtemp()) / "osd_evaluate"
    subprocess.run(["g++", "-O2", "-std=c++17", "-o", str(binary),
                    str(ROOT / "benchmarks" / "osd_evaluate.cpp"), "-losdCPU"], check=True)  # fmt: skip
    return binary


def run_driver(binary, mesh, scheme, level, points=()) -> str:
    """The driver's output for `mesh` under `scheme` (its options by OpenSubdiv's
    names; infinite sharpness as 10): `level` >= 0 evaluates Bfr at `points` (lines
    "face u v"), a negative one refines `-level` levels uniformly."""
    name = "loop" if isinstance(scheme, jss.Loop) else "catmark"
    rows = [r[r >= 0] for r in mesh.faces]
    sharp = lambda s: 10.0 if not np.isfinite(s) else float(s)
    lines = [f"{name} {scheme.boundary_interpolation} {scheme.crease_method} {level}",
             f"{mesh.num_vertices} {len(rows)} {len(mesh.creases)} {len(mesh.corners)} "
             f"{len(points)}"]  # fmt: skip
    lines += [" ".join(f"{x:.17g}" for x in v) for v in np.asarray(mesh.vertices)]
    lines += [f"{len(r)} " + " ".join(map(str, r)) for r in rows]
    lines += [f"{a} {b} {sharp(s)}" for (a, b), s in zip(mesh.creases, mesh.crease_sharpness)]
    lines += [f"{v} {sharp(s)}" for v, s in zip(mesh.corners, mesh.corner_sharpness)]
    lines += list(points)
    return subprocess.run([str(binary)], input="\n".join(lines) + "\n", capture_output=True,
                          text=True, check=True).stdout  # fmt: skip


def run_osd(binary, mesh, scheme, face, uv, level=10):
    """Bfr's position and derivatives `(N, 6, 3)` at the points (NaN: no surface)."""
    order = np.argsort(face, kind="stable")  # one surface per face
    out = run_driver(binary, mesh, scheme, level,
                     [f"{face[i]} {uv[i, 0]:.17g} {uv[i, 1]:.17g}" for i in order])  # fmt: skip
    values = np.full((len(face), 18), np.nan)
    for i, line in zip(order, out.splitlines()):
        if line != "invalid":
            values[i] = np.array(line.split(), float)
    return values.reshape(-1, 6, 3)


def points_for(mesh, scheme, seed=0, count=200):
    corners = 3 if isinstance(scheme, jss.Loop) else 4
    faces = np.flatnonzero(mesh.face_sizes() == corners)
    rng = np.random.default_rng(seed)
    face = rng.choice(faces, count)
    uv = rng.uniform(size=(count, 2))
    if corners == 3:
        uv = np.where(uv.sum(1, keepdims=True) > 1, 1 - uv, uv)
    near = slice(0, count // 3)
    uv[near] *= rng.uniform(1e-3, 0.1, (count // 3, 1))
    return face, uv


def ours(mesh, scheme, face, uv):
    points = jss.SurfacePoints(mesh, scheme, face, uv)
    v = mesh.vertices
    values = [points.positions(v), *points.derivatives(v), *points.second_derivatives(v)]
    return np.stack([np.asarray(x) for x in values], 1), np.asarray(points.depth)


def osd_refine(binary, mesh, scheme, levels):
    """The vertices of `levels` uniform levels of OpenSubdiv (Far::PrimvarRefiner)."""
    out = run_driver(binary, mesh, scheme, -levels)
    return np.array([line.split() for line in out.splitlines()], float)


def refinement_of_cases(binary) -> list[str]:
    """`Refiner` against OpenSubdiv's uniform refinement on every test mesh: the
    vertex counts, and the largest distance from an OpenSubdiv vertex to the nearest of
    ours (a k-d tree), relative to the mesh's size, levels 1 / 2."""
    from scipy.spatial import cKDTree

    out = ["", "`Refiner` against OpenSubdiv's uniform refinement (`Far::PrimvarRefiner`) on "
           "the same meshes: refined vertex counts (ours = OpenSubdiv's) and the largest "
           "distance from an OpenSubdiv vertex to the nearest of ours, relative to the "
           "mesh's size, levels 1 / 2.", "", "| mesh | counts equal | distance |",
           "|---|---|---|"]  # fmt: skip
    for name, mesh, scheme in CASES:
        size = np.ptp(np.asarray(mesh.vertices), axis=0).max()
        equal, gaps = True, []
        for levels in (1, 2):
            theirs = osd_refine(binary, mesh, scheme, levels)
            mine = np.asarray(jss.Refiner(mesh, scheme, levels)(mesh.vertices))
            equal &= len(theirs) == len(mine)
            gaps.append(cKDTree(mine).query(theirs)[0].max() / size)
        out.append(f"| {name} | {'yes' if equal else 'no'} | "
                   + " / ".join(f"{g:.1e}" for g in gaps) + " |")  # fmt: skip
    return out


def chaikin_refinement(binary) -> list[str]:
    """Uniform refinement against OpenSubdiv's, each refined vertex matched to the
    nearest of ours, for semi-sharp creases under both methods; and, where Chaikin
    differs, the weight OpenSubdiv's differing edge point blends the crease and smooth
    rules with."""
    from test_surface_points import GRID

    out = ["", "Uniform refinement against OpenSubdiv's `Far::PrimvarRefiner` (open grid, "
           "creases 7-8, 8-9, 9-10 with the sharpness given): the largest distance from an "
           "OpenSubdiv vertex to the nearest of ours, levels 1 / 2 / 3.", "",
           "| sharpness | uniform | chaikin |", "|---|---|---|"]  # fmt: skip
    for values in ([1.5, 2.25, 0.75], [3.0, 1.0, 0.5], [2.0, 2.0, 2.0]):
        mesh = jss.Mesh(*GRID, creases=[[7, 8], [8, 9], [9, 10]], crease_sharpness=values)
        cells = []
        for method in ("uniform", "chaikin"):
            scheme = jss.CatmullClark(crease_method=method)
            gaps = []
            for levels in (1, 2, 3):
                theirs = osd_refine(binary, mesh, scheme, levels)
                mine = np.asarray(jss.Refiner(mesh, scheme, levels)(mesh.vertices))
                gaps.append(np.abs(theirs[:, None] - mine[None]).max(-1).min(1).max())
            cells.append(" / ".join(f"{g:.1e}" for g in gaps))
        out.append(f"| {values} | " + " | ".join(cells) + " |")
    # The differing point at level 2 of the first case: its OpenSubdiv blend weight.
    mesh = jss.Mesh(*GRID, creases=[[7, 8], [8, 9], [9, 10]], crease_sharpness=[1.5, 2.25, 0.75])
    scheme = jss.CatmullClark(crease_method="chaikin")
    level1 = jss.refine_mesh(mesh, scheme, 1)
    theirs = osd_refine(binary, mesh, scheme, 2)
    mine = np.asarray(jss.Refiner(level1, scheme, 1)(level1.vertices))
    gap = np.abs(theirs[:, None] - mine[None]).max(-1)
    i = int(gap.min(1).argmax())
    j = int(gap[i].argmin())
    e = j - level1.num_vertices  # an edge point of level 1's edge e
    rows = [r[r >= 0] for r in level1.faces]
    edges = np.unique(np.sort(np.concatenate([np.stack([r, np.roll(r, -1)], 1) for r in rows]), 1), axis=0)
    a, b = edges[e]
    tags = [k for k, pair in enumerate(level1.creases.tolist()) if sorted(pair) != [a, b]]
    smooth = jss.Mesh(level1.vertices, level1.faces, creases=level1.creases[tags],
                      crease_sharpness=level1.crease_sharpness[tags])  # fmt: skip
    smooth_point = np.asarray(jss.Refiner(smooth, scheme, 1)(level1.vertices))[j]
    weight = (theirs[i] - smooth_point) @ (mine[j] - smooth_point) / np.sum((mine[j] - smooth_point) ** 2)
    sharpness = level1.crease_sharpness[[k for k in range(len(level1.creases)) if k not in tags]][0]
    out += ["", f"Chaikin, sharpness [1.5, 2.25, 0.75], level 2: the one differing point is "
            f"the edge point of level 1's edge ({a}, {b}), sharpness {sharpness:g}, one of "
            f"whose halves decays; OpenSubdiv's point is the blend of the crease and smooth "
            f"rules with weight {weight:.6f} (ours: 1, the crease rule)."]  # fmt: skip
    return out


def deep_refinement(mesh, scheme, vertices, levels):
    """The positions of `vertices` after `levels` levels of refinement of their 1-rings
    (no limit stencil: the rules alone; they converge to the limit geometrically)."""
    from jaxsubdiv.surfaces._local import Patches, refine_patches, vertex_rings

    current = Patches(mesh.faces, mesh.num_vertices, mesh.creases, mesh.corners,
                      mesh.crease_sharpness, mesh.corner_sharpness, None)  # fmt: skip
    centres = vertices
    for _ in range(levels):
        current, centres = vertex_rings(current, centres)
        current = refine_patches(scheme, current, current.topology(scheme))
    return current.weights.take_rows(centres).dense() @ np.asarray(mesh.vertices)


def second_by_differences(evaluate, face, uv, h=1e-6):
    """Central differences of the first derivatives `evaluate` returns at `uv +- h`:
    d2/du2, d2/dudv, d2/dv2, for checking the second derivatives it returns."""
    steps = [uv + [h, 0], uv - [h, 0], uv + [0, h], uv - [0, h]]
    values = [evaluate(face, np.clip(p, 0, 1)) for p in steps]
    du_u = (values[0][:, 1] - values[1][:, 1]) / (2 * h)
    du_v = (values[2][:, 1] - values[3][:, 1]) / (2 * h)
    dv_v = (values[2][:, 2] - values[3][:, 2]) / (2 * h)
    return np.stack([du_u, du_v, dv_v], 1)


def main():
    binary = compile_driver()
    store, lines = {}, [
        "# `SurfacePoints` against OpenSubdiv's Bfr at (face, u, v)",
        "",
        f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M UTC}; OpenSubdiv 3.5.0 "
        "(Debian's libosd-dev), Bfr in double precision with approximation levels 10; "
        "`python benchmarks/osd_surface_points.py`. 200 random points per mesh (a third "
        "within 1e-3 to 0.1 of a corner), on quads (Catmull-Clark) or triangles (Loop). "
        "Largest difference relative to the mesh's size (position) and to each "
        "derivative's largest magnitude over the points. *Self-check*: the points (of "
        "those within 9 levels and at least 1e-5 inside the face) whose second derivatives "
        "differ from the central differences (h = 1e-6) of the same evaluator's first "
        "derivatives by more than 1e-4 of their magnitude, for Bfr and for ours.",
        "",
        "| mesh | points on a patch within 9 levels | position | d/du, d/dv | second "
        "| points deeper | position | d/du, d/dv | second | self-check: Bfr | ours |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    corner_gap = []
    for k, (name, mesh, scheme) in enumerate(CASES):
        face, uv = points_for(mesh, scheme, seed=k)
        want = run_osd(binary, mesh, scheme, face, uv)
        got, depth = ours(mesh, scheme, face, uv)
        size = np.ptp(np.asarray(mesh.vertices), axis=0).max()
        scale = np.array([size, *[np.abs(want[:, j]).max() for j in range(1, 6)]])
        error = np.abs(got - want).max(-1) / scale  # (N, 6)
        shallow = depth < 10
        cells = []
        for part in (shallow, ~shallow):
            e = error[part]
            cells += [f"{part.sum()}", *(f"{x:.1e}" if len(e) else "-" for x in
                      (e[:, 0].max(initial=0), e[:, 1:3].max(initial=0), e[:, 3:].max(initial=0)))]  # fmt: skip
        far = 1 - 1e-5
        inside = shallow & np.all((uv > 1e-5) & (uv < far), axis=1)
        if isinstance(scheme, jss.Loop):
            inside &= uv.sum(1) < far
        for evaluate, values in ((lambda f, p: run_osd(binary, mesh, scheme, f, p), want),
                                 (lambda f, p: ours(mesh, scheme, f, p)[0], got)):  # fmt: skip
            differences = second_by_differences(evaluate, face[inside], uv[inside])
            gap = np.abs(values[inside, 3:] - differences).max(-1).max(-1)
            magnitude = np.abs(differences).max(-1).max(-1)
            wrong = gap > 1e-4 * np.maximum(magnitude, 1e-3 * scale[3:].max())
            cells.append(f"{int(wrong.sum())} of {int(inside.sum())}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
        store[f"{k}_face"], store[f"{k}_uv"], store[f"{k}_osd"] = face, uv, want
        # Every corner of every face of the patch size: the limit position of its
        # vertex (Bfr's patches interpolate it), a reference for `Limit`.
        corners = 3 if isinstance(scheme, jss.Loop) else 4
        corner_uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)[[0, 1, 3] if corners == 3 else slice(None)]
        faces = np.flatnonzero(mesh.face_sizes() == corners)
        corner_face, corner_k = np.repeat(faces, corners), np.tile(np.arange(corners), len(faces))
        at = run_osd(binary, mesh, scheme, corner_face, corner_uv[corner_k])[:, 0]
        store[f"{k}_corner_vertex"] = mesh.faces[corner_face, corner_k]
        store[f"{k}_corner_osd"] = at
        limit = np.asarray(jss.Limit(mesh, scheme).positions(mesh.vertices))
        vertex = mesh.faces[corner_face, corner_k]
        gap = np.abs(limit[vertex] - at).max(1) / size
        darts = np.unique(vertex[gap > 1e-13])
        row = [name, gap.max(), len(darts)]
        if len(darts):  # which is the limit: 60 levels of the rules alone decide
            deep = deep_refinement(mesh, scheme, darts, 60)
            theirs = np.stack([at[np.flatnonzero(vertex == d)[0]] for d in darts])
            row += [np.abs(limit[darts] - deep).max() / size, np.abs(theirs - deep).max() / size]
        corner_gap.append(row)
    lines += ["", "`Limit.positions` against Bfr at every corner of every face (quads or "
              "triangles), the vertex's limit position; largest difference relative to the "
              "mesh's size. Where they differ by more than 1e-13 (the darts: interior "
              "vertices on one crease edge), both against the vertex after 60 levels of "
              "local refinement by the rules alone (`Refiner`'s rules, equal to "
              "OpenSubdiv's refinement below).", "",
              "| mesh | Limit vs Bfr | vertices differing | Limit vs 60 levels | Bfr vs 60 levels |",
              "|---|---:|---:|---:|---:|"]  # fmt: skip
    for row in corner_gap:
        cells = [f"{x:.1e}" if isinstance(x, float) else str(x) for x in row[1:]]
        lines.append(f"| {row[0]} | " + " | ".join(cells + ["-"] * (4 - len(cells))) + " |")
    lines += refinement_of_cases(binary)
    lines += chaikin_refinement(binary)
    print("\n".join(lines[-8:]))
    store["names"] = np.array([c[0] for c in CASES])
    np.savez_compressed(DATA, **store)
    RESULTS.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
