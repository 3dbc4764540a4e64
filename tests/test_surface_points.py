"""The Catmull-Clark limit at any (face, u, v): against scipy's tensor-product B-splines on
regular faces, against the limit of refined vertices (`Refiner` then `Limit`) at dyadic
points of every kind of face, and against finite differences for the derivatives."""

import dataclasses
import pathlib

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.interpolate
from helpers import assert_one_clear_error

import jaxsubdiv.surfaces as jss


DATA = pathlib.Path(__file__).parent / "data"
CORNER_UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
TRIANGLE_UV = np.array([[0, 0], [1, 0], [0, 1]], float)


def open_grid(n=6, m=5, seed=3):
    """An open (n x m)-vertex quad grid, z random."""
    x, y = np.meshgrid(np.arange(n), np.arange(m), indexing="xy")
    z = np.random.default_rng(seed).normal(size=n * m) * 0.3
    vertices = np.stack([x.ravel(), y.ravel(), z], 1).astype(float)
    faces = [[j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i]
             for j in range(m - 1) for i in range(n - 1)]  # fmt: skip
    return vertices, np.array(faces)


def l_shape():
    """The open grid without its top-right quarter: a concave boundary corner (a
    boundary vertex in three faces)."""
    vertices, faces = open_grid(7, 7, seed=5)
    keep = ~((faces.min(1) % 7 >= 3) & (faces.min(1) // 7 >= 3))
    used = np.unique(faces[keep])
    remap = np.full(len(vertices), -1)
    remap[used] = np.arange(len(used))
    return vertices[used], remap[faces[keep]]


def pentagon_cap():
    """A pentagon ringed by five quads (an n-gon next to valence-3 vertices)."""
    angles = np.linspace(0, 2 * np.pi, 6)[:-1]
    inner = np.stack([np.cos(angles), np.sin(angles), 0 * angles], 1)
    vertices = np.concatenate([inner, 2 * inner + [0, 0, 0.3]])
    faces = [[0, 1, 2, 3, 4]] + [[(i + 1) % 5, i, 5 + i, 5 + (i + 1) % 5, -1] for i in range(5)]
    return vertices, np.array(faces)


def cube():
    v = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    f = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    return v, np.array(f)


def suzanne():
    return jss.read_mesh(DATA / "suzanne.obj")


LOOP = jss.Loop()
CC, EDGE_ONLY = jss.CatmullClark(), jss.CatmullClark(boundary_interpolation="edge_only")
CHAIKIN = jss.CatmullClark(crease_method="chaikin")
GRID = open_grid()


def triangulated(vertices, faces):
    """Each quad split along its (0, 2) diagonal."""
    return vertices, np.concatenate([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])


def torus_triangles(m=5, n=6):
    """A closed triangle mesh with every vertex of valence 6."""
    i, j = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    idx = lambda a, b: (a % m) * n + (b % n)
    quads = np.stack([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)], -1)
    angle_i, angle_j = 2 * np.pi * i.ravel() / m, 2 * np.pi * j.ravel() / n
    vertices = np.stack([(2 + np.cos(angle_j)) * np.cos(angle_i),
                         (2 + np.cos(angle_j)) * np.sin(angle_i), np.sin(angle_j)], 1)  # fmt: skip
    return triangulated(vertices, quads.reshape(-1, 4))


def icosahedron():
    p = (1 + 5**0.5) / 2
    v = np.array([[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p],
                  [0, -1, -p], [0, 1, -p], [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]])  # fmt: skip
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]  # fmt: skip
    return v, np.array(f)


TRIANGLE_GRID = triangulated(*open_grid())

# (name, mesh, scheme): every kind of corner a patch can have.
CASES = [
    ("suzanne: extraordinary vertices, triangles, valence 2", suzanne(), CC),
    ("open grid, edge and corner", jss.Mesh(*GRID), CC),
    ("open grid, edge only", jss.Mesh(*GRID), EDGE_ONLY),
    ("crease, crease end and corner tag",
     jss.Mesh(*GRID, creases=[[7, 8], [8, 9], [13, 14], [14, 20]], corners=[15]), CC),
    ("dart", jss.Mesh(*GRID, creases=[[7, 8]]), CC),
    ("crease turning (sectors of 1 and 3 faces)", jss.Mesh(*GRID, creases=[[13, 14], [14, 20]]), CC),
    ("concave boundary corner", jss.Mesh(*l_shape()), CC),
    ("concave boundary corner, edge only", jss.Mesh(*l_shape()), EDGE_ONLY),
    ("semi-sharp, uniform",
     jss.Mesh(*GRID, creases=[[7, 8], [8, 9], [9, 10]], crease_sharpness=[1.5, 2.25, 0.75],
              corners=[14], corner_sharpness=[1.25]), CC),
    ("semi-sharp, chaikin",
     jss.Mesh(*GRID, creases=[[7, 8], [8, 9], [9, 10]], crease_sharpness=[3.0, 1.0, 0.5]),
     CHAIKIN),
    ("cube with two creases", jss.Mesh(*cube(), creases=[[0, 2], [2, 3]]), CC),
    ("pentagon", jss.Mesh(*pentagon_cap()), CC),
    ("Loop: regular torus", jss.Mesh(*torus_triangles()), LOOP),
    ("Loop: icosahedron", jss.Mesh(*icosahedron()), LOOP),
    ("Loop: open grid, edge and corner", jss.Mesh(*TRIANGLE_GRID), LOOP),
    ("Loop: open grid, edge only", jss.Mesh(*TRIANGLE_GRID),
     jss.Loop(boundary_interpolation="edge_only")),
    ("Loop: crease, dart, corner tag, semi-sharp",
     jss.Mesh(*TRIANGLE_GRID, creases=[[6, 7], [7, 8], [13, 14]], corners=[15],
              crease_sharpness=[np.inf, 1.5, np.inf]), LOOP),
    ("Loop: crease turning", jss.Mesh(*TRIANGLE_GRID, creases=[[13, 14], [14, 20]]), LOOP),
    ("Loop: concave boundary corner", jss.Mesh(*triangulated(*l_shape())), LOOP),
]  # fmt: skip


class DyadicVertices:
    """Which vertex, after `levels` levels of `Refiner`, a point of a face becomes when
    it is a multiple of 2^-levels. Independent of `SurfacePoints`' own bookkeeping: it
    keeps the (u, v) of the face's vertices at each level (the parametrisation splits
    faces at the midpoints in (u, v): edge points at the middle of their edge, face
    points at the centre), finds the child among the refined faces whose vertices are
    the face's own vertex, edge and face points, and stops when the point is a vertex,
    from the refined vertex order the schemes document (vertex points, edge points by
    sorted edge, then face points; a vertex point keeps its index)."""

    def __init__(self, mesh, scheme, levels):
        self.meshes = [(mesh.faces, mesh.num_vertices)] + [
            (r.faces, r.num_vertices)
            for r in (jss.Refiner(mesh, scheme, k) for k in range(1, levels + 1))
        ]
        self.edges = [{tuple(e): i for i, e in enumerate(np.unique(face_edges(f), axis=0))}
                      for f, _ in self.meshes]  # fmt: skip

    def __call__(self, face, uv, subface):
        faces, count = self.meshes[0]
        row = faces[face][faces[face] >= 0]
        k, E = len(row), len(self.edges[0])
        if subface >= 0:  # the first level's quad at that corner is the face
            c = subface
            mid = lambda a, b: count + self.edges[0][tuple(sorted((row[a], row[b])))]
            ids = [row[c], mid(c, (c + 1) % k), count + E + face, mid(c - 1, c)]
            at = dict(zip(ids, CORNER_UV))
            face = next(f for f, r in enumerate(self.meshes[1][0]) if set(r) == set(ids))
            level = 1
        else:
            at = dict(zip(row, CORNER_UV if k == 4 else TRIANGLE_UV))
            level = 0
        point = np.asarray(uv, float)
        for level in range(level, len(self.meshes)):
            faces, count = self.meshes[level]
            row = faces[face][faces[face] >= 0]
            for vertex in row:
                if np.array_equal(at[vertex], point):
                    return int(vertex)
            assert level + 1 < len(self.meshes), "not a dyadic point of this level"
            edges, E = self.edges[level], len(self.edges[level])
            for a, b in zip(row, np.roll(row, -1)):
                at[count + edges[tuple(sorted((a, b)))]] = (at[a] + at[b]) / 2
            if len(row) == 4:
                at[count + E + face] = np.mean([at[v] for v in row], axis=0)
            refined = self.meshes[level + 1][0]
            children = np.flatnonzero(np.isin(refined, list(at)).all(axis=1))
            face = next(int(f) for f in children
                        if _inside(point, [at[v] for v in refined[f]]))  # fmt: skip
        raise AssertionError


def _inside(point, polygon):
    """Whether `point` is inside or on the convex counter-clockwise `polygon`."""
    polygon = np.asarray(polygon)
    edge = np.roll(polygon, -1, axis=0) - polygon
    to = point - polygon
    return bool(np.all(edge[:, 0] * to[:, 1] - edge[:, 1] * to[:, 0] >= -1e-15))


def face_edges(faces):
    """`(H, 2)` sorted vertex pairs of every face side, in face order."""
    rows = [row[row >= 0] for row in faces]
    return np.sort(np.stack([np.concatenate(rows),
                             np.concatenate([np.roll(r, -1) for r in rows])], 1), axis=1)  # fmt: skip


@pytest.mark.parametrize("name, mesh, scheme", CASES, ids=[c[0] for c in CASES])
def test_dyadic_points_are_limits_of_refined_vertices(name, mesh, scheme):
    """At points that are vertices after a few levels, the evaluated position is the
    limit of that refined vertex (`Refiner` + `Limit`, checked against Blender and by
    eigen-analysis elsewhere), on 6 channels (3 random) so that no other vertex's limit
    can agree by accident; corners of faces at extraordinary vertices included."""
    levels = 2 if mesh.num_faces > 100 else 3
    rng = np.random.default_rng(1)
    sizes = mesh.face_sizes()
    N = 60 if mesh.num_faces > 100 else 8 * mesh.num_faces  # small meshes: every face
    face = rng.integers(0, mesh.num_faces, N) if N == 60 else np.repeat(np.arange(mesh.num_faces), 8)
    uv = rng.integers(0, 2 ** (levels - 1) + 1, (N, 2)) / 2 ** (levels - 1)
    corners = 3 if isinstance(scheme, jss.Loop) else 4
    uv[::7] = (CORNER_UV if corners == 4 else TRIANGLE_UV)[rng.integers(0, corners, len(uv[::7]))]
    if corners == 3:  # into the triangle u + v <= 1
        uv = np.where(uv.sum(1, keepdims=True) > 1, 1 - uv, uv)
    subface = np.where(sizes[face] == corners, -1, rng.integers(0, 5, N) % sizes[face])
    points = jss.SurfacePoints(mesh, scheme, face, uv, subfaces=subface)
    data = np.concatenate([mesh.vertices, rng.normal(size=(mesh.num_vertices, 3))], 1)
    refiner = jss.Refiner(mesh, scheme, levels)
    limits = np.asarray(jss.Limit(refiner.mesh(mesh.vertices), scheme).positions(refiner(data)))
    vertex_of = DyadicVertices(mesh, scheme, levels)
    want = [vertex_of(int(face[i]), uv[i], int(subface[i])) for i in range(N)]
    np.testing.assert_allclose(points.positions(data), limits[want], rtol=0, atol=1e-13)


OSD = np.load(DATA / "osd_surface_points.npz")


@pytest.mark.parametrize("k, name, mesh, scheme", [(k, *c) for k, c in enumerate(CASES)],
                         ids=[c[0] for c in CASES])  # fmt: skip
def test_matches_opensubdiv_bfr(k, name, mesh, scheme):
    """Against OpenSubdiv 3.5's own evaluation at (face, u, v) (Bfr, double precision;
    `benchmarks/osd_surface_points.py` made the data): 200 random points per mesh on
    quads (Catmull-Clark) or triangles (Loop), a third near a corner. Where both are
    exact (a regular patch within 9 levels; Bfr approximates deeper), positions and
    first derivatives agree to 1e-10 of their scale, Catmull-Clark's second derivatives
    to 1e-9. Loop's second derivatives are not compared: Bfr's disagree with the central
    differences of its own first derivatives at up to half of the points (sign flips;
    `benchmarks/results/osd_surface_points.md`), ours with theirs nowhere (tested above)."""
    assert OSD["names"][k] == name, "the reference data is stale: rerun the script"
    face, uv, want = OSD[f"{k}_face"], OSD[f"{k}_uv"], OSD[f"{k}_osd"]
    points = jss.SurfacePoints(mesh, scheme, face, uv)
    v = mesh.vertices
    got = np.stack([np.asarray(x) for x in (points.positions(v), *points.derivatives(v),
                                            *points.second_derivatives(v))], 1)  # fmt: skip
    exact = np.asarray(points.exact) & (np.asarray(points.depth) < 10)  # Bfr: 10 levels
    assert exact.mean() > 0.95
    size = np.ptp(np.asarray(v), axis=0).max()
    np.testing.assert_allclose(got[exact, 0], want[exact, 0], rtol=0, atol=1e-10 * size)
    np.testing.assert_allclose(got[exact, 1:3], want[exact, 1:3], rtol=0,
                               atol=1e-10 * np.abs(want[:, 1:3]).max())  # fmt: skip
    if isinstance(scheme, jss.CatmullClark):
        np.testing.assert_allclose(got[exact, 3:], want[exact, 3:], rtol=0,
                                   atol=1e-9 * np.abs(want[:, 3:]).max())  # fmt: skip


@pytest.mark.parametrize("k, name, mesh, scheme", [(k, *c) for k, c in enumerate(CASES)],
                         ids=[c[0] for c in CASES])  # fmt: skip
def test_limit_positions_match_opensubdiv_at_vertices(k, name, mesh, scheme):
    """`Limit.positions` (the local semi-sharp refinement included) against Bfr at
    every corner of every face: equal to 1e-13 of the size, except at darts (interior
    vertices on one infinitely sharp crease edge), where Bfr approximates (1.6e-8 to
    7.8e-6 off; `results/osd_surface_points.md`): there, against the vertex after 60
    levels of refinement of its 1-ring by the rules alone (which equal OpenSubdiv's
    refinement to 4e-16), to 1e-13."""
    assert OSD["names"][k] == name, "the reference data is stale: rerun the script"
    vertex, want = OSD[f"{k}_corner_vertex"], OSD[f"{k}_corner_osd"]
    got = np.asarray(jss.Limit(mesh, scheme).positions(mesh.vertices))
    size = np.ptp(np.asarray(mesh.vertices), axis=0).max()
    sharp = mesh.creases[np.isinf(mesh.crease_sharpness)].reshape(-1)
    darts = np.flatnonzero((np.bincount(sharp, minlength=mesh.num_vertices) == 1)
                           & ~np.isin(np.arange(mesh.num_vertices), _boundary_vertices(mesh.faces)))  # fmt: skip
    other = ~np.isin(vertex, darts)
    np.testing.assert_allclose(got[vertex[other]], want[other], rtol=0, atol=1e-13 * size)
    darts = np.intersect1d(darts, vertex)
    if len(darts):
        from jaxsubdiv.surfaces._local import Patches, refine_patches, vertex_rings

        current = Patches(mesh.faces, mesh.num_vertices, mesh.creases, mesh.corners,
                          mesh.crease_sharpness, mesh.corner_sharpness, None)  # fmt: skip
        centres = darts
        for _ in range(60):
            current, centres = vertex_rings(current, centres)
            current = refine_patches(scheme, current, current.topology(scheme))
        deep = current.weights.take_rows(centres).dense() @ np.asarray(mesh.vertices)
        np.testing.assert_allclose(got[darts], deep, rtol=0, atol=1e-13 * size)


def bspline_surface(control, x, y, dx=0, dy=0):
    """scipy's bicubic tensor-product B-spline on the uniform knots of a vertex grid
    (control point i centred at parameter i - 1)."""
    n = control.shape[1]
    knots = np.arange(-3, n + 1)
    basis = scipy.interpolate.BSpline(knots, np.eye(n), 3)
    return np.einsum("j,jic,i->c", basis(y, nu=dy), control, basis(x, nu=dx))


def test_regular_faces_are_bicubic_bspline_patches():
    """Interior faces of a quad grid: positions, first and second derivatives are
    scipy's tensor-product cubic B-spline's, at random (u, v)."""
    n = 8
    vertices, faces = open_grid(n, n, seed=0)
    vertices[:, 2] = np.random.default_rng(0).normal(size=n * n)
    rng = np.random.default_rng(2)
    cells = rng.integers(1, n - 2, (40, 2))  # faces whose 16 vertices are interior
    face = cells[:, 1] * (n - 1) + cells[:, 0]
    uv = rng.uniform(size=(40, 2))
    points = jss.SurfacePoints(jss.Mesh(vertices, faces), CC, face, uv)
    assert np.all(points.exact) and np.all(points.depth == 0)
    control = vertices.reshape(n, n, 3)
    x, y = cells[:, 0] - 1 + uv[:, 0], cells[:, 1] - 1 + uv[:, 1]
    derivatives = [*points.derivatives(vertices), *points.second_derivatives(vertices)]
    for got, (dx, dy) in zip([points.positions(vertices), *derivatives],
                             [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]):  # fmt: skip
        want = [bspline_surface(control, a, b, dx, dy) for a, b in zip(x, y)]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def loop_icosphere():
    """The icosahedron refined once by Loop: valence-5 and valence-6 vertices."""
    return jss.refine_mesh(jss.Mesh(*icosahedron()), LOOP, 1)


# (name, mesh, scheme) for points near extraordinary vertices.
IRREGULAR = [
    ("Catmull-Clark, Suzanne", suzanne(), CC),
    ("Loop, icosphere", loop_icosphere(), LOOP),
    ("Loop, open grid with creases",
     jss.Mesh(*TRIANGLE_GRID, creases=[[6, 7], [7, 8], [13, 14], [14, 20]]), LOOP),
]


@pytest.fixture(scope="module", params=IRREGULAR, ids=[c[0] for c in IRREGULAR])
def near_irregular(request):
    """Points on faces of the scheme's size, a third of them within 1e-3 to 0.1 of the
    first corner, with 4 neighbours each at a step h in u and v (one set of tables)."""
    _, mesh, scheme = request.param
    corners = 3 if isinstance(scheme, jss.Loop) else 4
    faces = np.flatnonzero(mesh.face_sizes() == corners)
    rng = np.random.default_rng(0)
    N, h = 120, 1e-6
    face = rng.choice(faces, N)
    uv = rng.uniform(0.05, 0.95, (N, 2)) * (0.5 if corners == 3 else 1)
    uv[:40] *= rng.uniform(1e-3, 0.1, (40, 1))  # at least 2.5e-5 from the sides
    uv[40:60, 1] = 2e-6  # next to side 0 (on a boundary or crease for some faces)
    shifted = [uv, uv + [h, 0], uv - [h, 0], uv + [0, h], uv - [0, h]]
    points = jss.SurfacePoints(mesh, scheme, np.tile(face, 5), np.concatenate(shifted))
    return mesh, points, N, h


def test_derivatives_match_finite_differences(near_irregular):
    """First derivatives against central differences of the positions, second against
    those of the first, near extraordinary vertices too (up to 9 levels deep)."""
    mesh, points, N, h = near_irregular
    assert np.all(points.exact) and points.depth.max() >= 6
    split = lambda a: np.asarray(a).reshape(5, N, 3)
    p = split(points.positions(mesh.vertices))
    du, dv = map(split, points.derivatives(mesh.vertices))
    duu, duv, dvv = map(split, points.second_derivatives(mesh.vertices))

    def close(got, want, rtol):  # relative to each point's largest component
        scale = np.maximum(np.abs(want).max(-1, keepdims=True), 1e-2)
        worst = np.max(np.abs(got - want) / scale)
        assert worst < rtol, worst

    close(du[0], (p[1] - p[2]) / (2 * h), 1e-6)
    close(dv[0], (p[3] - p[4]) / (2 * h), 1e-6)
    close(duu[0], (du[1] - du[2]) / (2 * h), 1e-4)
    close(duv[0], (du[3] - du[4]) / (2 * h), 1e-4)
    close(dvv[0], (dv[3] - dv[4]) / (2 * h), 1e-4)


def test_points_on_shared_edges_agree_from_both_faces():
    """A point on an edge, evaluated on each of its two faces (different patches,
    different parametrisations): the same position, and the same derivative along the
    edge up to its direction; Suzanne's quad-quad edges at random positions."""
    mesh = suzanne()
    faces = mesh.faces
    rng = np.random.default_rng(4)
    pairs = {}
    for f, row in enumerate(faces):
        if (row >= 0).sum() != 4:
            continue
        for s in range(4):
            pairs.setdefault(tuple(sorted((row[s], row[(s + 1) % 4]))), []).append((f, s))
    shared = [p for p in pairs.values() if len(p) == 2]
    t = rng.uniform(size=len(shared))
    face, uv, direction = [], [], []
    for (a, b), x in zip(shared, t):
        for (f, s), along in ((a, x), (b, 1 - x)):
            start, end = CORNER_UV[s], CORNER_UV[(s + 1) % 4]
            face.append(f)
            uv.append(start + along * (end - start))
            direction.append(end - start)
    points = jss.SurfacePoints(mesh, CC, np.array(face), np.array(uv))
    p = np.asarray(points.positions(mesh.vertices)).reshape(-1, 2, 3)
    du, dv = (np.asarray(d) for d in points.derivatives(mesh.vertices))
    direction = np.array(direction)
    along = (du * direction[:, :1] + dv * direction[:, 1:]).reshape(-1, 2, 3)
    np.testing.assert_allclose(p[:, 0], p[:, 1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(along[:, 0], -along[:, 1], rtol=0, atol=1e-10)


@pytest.mark.parametrize("name, mesh, scheme", IRREGULAR[:2], ids=[c[0] for c in IRREGULAR[:2]])
def test_normals_at_extraordinary_vertices_are_limit_normals(name, mesh, scheme):
    """At the interior extraordinary vertices themselves (never on a regular patch):
    the position is the vertex's limit (exact); the normal is `Limit.normals`'s (to
    1e-3 degrees: the same tangent stencils, composed with 16 levels), and the normals
    of exact patches at 2^-8, 2^-12, 2^-14 of the face's size from the vertex, along
    the face's diagonal, approach it (within 0.5 degrees at 2^-14). Valence 2 has no
    tangent plane (nearby normals depend on the direction): not compared."""
    faces = mesh.faces
    corners = 3 if isinstance(scheme, jss.Loop) else 4
    regular = 6 if corners == 3 else 4
    corner_uv = CORNER_UV if corners == 4 else TRIANGLE_UV
    valence = np.bincount(np.unique(face_edges(faces), axis=0).reshape(-1))
    boundary = _boundary_vertices(faces)
    face, uv, vertex = [], [], []
    for f, row in enumerate(faces):
        if (row >= 0).sum() == corners:
            for c in range(corners):
                v = row[c]
                if valence[v] not in (2, regular) and v not in boundary:
                    face.append(f), uv.append(corner_uv[c]), vertex.append(v)
    face, uv, vertex = np.array(face), np.array(uv), np.array(vertex)
    points = jss.SurfacePoints(mesh, scheme, face, uv)
    limit = jss.Limit(mesh, scheme)
    assert not np.any(points.exact) and np.all(points.depth == 16)
    np.testing.assert_allclose(points.positions(mesh.vertices),
                               limit.positions(mesh.vertices)[vertex], rtol=0, atol=1e-14)  # fmt: skip
    normal = np.asarray(points.normals(mesh.vertices))
    angle = lambda a, b: np.degrees(np.arccos(np.clip(np.sum(a * b, -1), -1, 1)))
    assert angle(normal, limit.normals(mesh.vertices)[vertex]).max() < 1e-3
    towards = corner_uv.mean(axis=0) - uv
    largest = []
    for distance in (2.0**-8, 2.0**-12, 2.0**-14):
        near = jss.SurfacePoints(mesh, scheme, face, uv + distance * towards)
        assert np.all(near.exact)
        largest.append(angle(np.asarray(near.normals(mesh.vertices)), normal).max())
    assert largest[0] > largest[1] > largest[2] and largest[2] < 0.5, largest


def _boundary_vertices(faces):
    unique, count = np.unique(face_edges(faces), axis=0, return_counts=True)
    return np.unique(unique[count == 1])


def test_evaluation_is_one_kernel_batched_and_differentiable(near_irregular):
    """Leading batch axes give each item's values; under `jit` new vertex values
    reuse the program; the gradient of a loss on positions is the stencil's transpose
    applied to the loss's gradient (checked against the dense table)."""
    mesh, points, N, _ = near_irregular
    rng = np.random.default_rng(5)
    batch = mesh.vertices + rng.normal(size=(3, *mesh.vertices.shape)) * 0.01
    np.testing.assert_allclose(points.positions(batch)[1], points.positions(batch[1]),
                               rtol=0, atol=1e-15)  # fmt: skip
    f = jax.jit(lambda v: jnp.sum(points.normals(v)[:, 2] + points.positions(v)[:, 0] ** 2))
    compiled = f.lower(batch[0]).compile()
    np.testing.assert_allclose(compiled(batch[1]), f(batch[1]), rtol=1e-14)
    grad = jax.grad(lambda v: jnp.sum(points.positions(v)[:, 0] ** 2))(batch[0])
    dense = np.asarray(points.position.dense())
    want = dense.T @ (2 * (dense @ batch[0])[:, 0])
    np.testing.assert_allclose(grad[:, 0], want, rtol=1e-12, atol=1e-13)
    assert np.all(grad[:, 1:] == 0)


BAD_INPUTS = [
    ("face out of range", dict(faces=[0, 99999], uv=[[0.5, 0.5]] * 2), ["`faces`", "99999"]),
    ("uv outside", dict(faces=[0], uv=[[0.5, 1.5]]), ["`uv`", "[0, 1]"]),
    ("uv NaN", dict(faces=[0], uv=[[np.nan, 0.5]]), ["`uv`", "[0, 1]"]),
    ("uv shape", dict(faces=[0, 1], uv=[[0.5, 0.5]]), ["`uv`", "shape"]),
    ("float faces", dict(faces=[0.5], uv=[[0.5, 0.5]]), ["`faces`", "indices"]),
    ("huge unsigned face", dict(faces=np.array([2**63 + 5], np.uint64), uv=[[0.5, 0.5]]),
     ["`faces`", "9223372036854775813"]),
    ("complex uv", dict(faces=[1], uv=[[0.5 + 1j, 0.5]]), ["`uv`", "real numbers"]),
    ("text uv", dict(faces=[1], uv=[["a", "b"]]), ["`uv`", "real numbers"]),
    ("subface on a quad", dict(faces=[1], uv=[[0.5, 0.5]], subfaces=[2]), ["`subfaces`", "-1"]),
    ("no subface on an n-gon", dict(faces=[0], uv=[[0.5, 0.5]]), ["`subfaces[0]`", "[0, 4]"]),
    ("max_depth", dict(faces=[1], uv=[[0.5, 0.5]], max_depth=3), ["max_depth"]),
    ("memory", dict(faces=[1], uv=[[0.5, 0.5]], memory_budget=100), ["memory_budget"]),
]  # fmt: skip


@pytest.mark.parametrize("name, kwargs, words", BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_bad_points_get_clear_errors(name, kwargs, words):
    mesh = jss.Mesh(*pentagon_cap())
    assert_one_clear_error(lambda: jss.SurfacePoints(mesh, CC, **kwargs), ValueError, words)


def test_no_points_and_rounding_at_the_sides_are_accepted():
    """No points gives empty results; `uv` a rounding error outside the square goes
    back onto its side; integral float face indices are indices."""
    mesh = jss.Mesh(*pentagon_cap())
    empty = jss.SurfacePoints(mesh, CC, [], [])
    assert empty.positions(mesh.vertices).shape == (0, 3)
    points = jss.SurfacePoints(mesh, CC, [1.0, 1], [[1 + 2e-16, 0.5], [1, 0.5]])
    p = np.asarray(points.positions(mesh.vertices))
    np.testing.assert_array_equal(p[0], p[1])


def test_rings_that_are_not_disks_fall_back_to_the_whole_refined_mesh(monkeypatch):
    """If the union of 1-rings is not a manifold (two fans at an outer vertex; no mesh
    tried makes one), refinement goes on with the whole refined mesh: the same values
    (the fallback forced on Suzanne's points near extraordinary vertices)."""
    from jaxsubdiv.surfaces import _evaluate

    mesh = suzanne()
    rng = np.random.default_rng(6)
    quads = np.flatnonzero(mesh.face_sizes() == 4)
    face = rng.choice(quads, 30)
    uv = rng.uniform(0, 0.3, (30, 2))
    want = np.asarray(jss.SurfacePoints(mesh, CC, face, uv).positions(mesh.vertices))
    real = _evaluate._one_rings

    class NotADisk(_evaluate.Patches):
        def topology(self, scheme):
            raise ValueError("not a disk")

    def rings(refined, targets):
        patches, index = real(refined, targets)
        fields = [getattr(patches, f.name) for f in dataclasses.fields(patches)]
        return NotADisk(*fields), index

    monkeypatch.setattr(_evaluate, "_one_rings", rings)
    got = jss.SurfacePoints(mesh, CC, face, uv, max_depth=10)
    np.testing.assert_allclose(got.positions(mesh.vertices), want, rtol=0, atol=1e-14)


def test_doo_sabin_and_loop_on_quads_are_refused_with_the_alternative():
    mesh = jss.Mesh(*cube())
    assert_one_clear_error(lambda: jss.SurfacePoints(mesh, jss.DooSabin(), [0], [[0.5, 0.5]]),
                           ValueError, ["CatmullClark", "Loop", "Refiner"])  # fmt: skip
    assert_one_clear_error(lambda: jss.SurfacePoints(mesh, LOOP, [0], [[0.5, 0.5]]),
                           ValueError, ["triangle", "face 0", "CatmullClark"])  # fmt: skip


def test_loop_points_outside_the_triangle_are_refused():
    mesh = jss.Mesh(*icosahedron())
    assert_one_clear_error(lambda: jss.SurfacePoints(mesh, LOOP, [0, 1], [[0.2, 0.2], [0.6, 0.5]]),
                           ValueError, ["`uv`", "u + v <= 1", "point 1"])  # fmt: skip
