"""Reference data for face-varying UVs (with seams) from Blender's Subdivision Surface modifier.

Standalone: runs only in an environment that has Blender's ``bpy`` module (it imports nothing from
jaxsubdiv); see ``blender_creases.py`` for the venv. Run::

    nice -n 10 /work/bpy-venv/bin/python benchmarks/blender_uvs.py [OUT.npz]

It writes ``tests/data/blender_uvs.npz`` (or OUT.npz), readable with plain numpy.

Modifier settings: SUBSURF, CATMULL_CLARK, levels 1 and 2, use_limit_surface=False (uniform
refinement; positions and UVs are refined control values, not limit values),
boundary_smooth='PRESERVE_CORNERS' (OpenSubdiv VTX_BOUNDARY_EDGE_AND_CORNER), use_creases=True
(no creases are set here), quality=6 (unused without the limit surface). One run per ``uv_smooth``.

uv_smooth -> OpenSubdiv Sdc::Options::FVarLinearInterpolation (Blender 5.0.1, a3db93c5b259)
--------------------------------------------------------------------------------------------
Chain: source/blender/blenkernel/intern/subdiv_modifier.cc (``settings.fvar_linear_interpolation =
fvar_interpolation_from_uv_smooth(smd->uv_smooth)``) -> source/blender/blenkernel/intern/subdiv.cc
``fvar_interpolation_from_uv_smooth`` (SUBSURF_UV_SMOOTH_* -> SUBDIV_FVAR_LINEAR_INTERPOLATION_*)
-> source/blender/blenkernel/intern/subdiv_converter.cc ``converter_fvar_linear_from_settings``
(-> OSD_FVAR_LINEAR_INTERPOLATION_*) -> intern/opensubdiv/internal/base/type_convert.cc
``getFVarLinearInterpolationFromCAPI`` (-> Sdc::Options::FVAR_LINEAR_*). Net result:

    uv_smooth (RNA identifier)               UI name                            OpenSubdiv
    NONE                                     None                               FVAR_LINEAR_ALL
    PRESERVE_CORNERS                         Keep Corners                       FVAR_LINEAR_CORNERS_ONLY
    PRESERVE_CORNERS_AND_JUNCTIONS           Keep Corners, Junctions            FVAR_LINEAR_CORNERS_PLUS1
    PRESERVE_CORNERS_JUNCTIONS_AND_CONCAVE   Keep Corners, Junctions, Concave   FVAR_LINEAR_CORNERS_PLUS2
    PRESERVE_BOUNDARIES                      Keep Boundaries                    FVAR_LINEAR_BOUNDARIES
    SMOOTH_ALL                               All                                FVAR_LINEAR_NONE

Note the inversion: Blender's 'NONE' ("UVs are not smoothed") is OpenSubdiv's FVAR_LINEAR_ALL
(bilinear UVs) and Blender's 'SMOOTH_ALL' is FVAR_LINEAR_NONE (smooth everywhere). The identifiers
were read from this bpy (``bpy.types.SubsurfModifier.bl_rna.properties['uv_smooth']``). The script
checks that 'NONE' gives bilinear UVs at levels 1 and 2.

How Blender hands the UVs to OpenSubdiv (subdiv_converter_mesh.cc ``precalc_uv_layer``)
----------------------------------------------------------------------------------------
Blender stores UVs per face corner (loop) only, without indices. It rebuilds face-varying indices
with ``BKE_mesh_uv_vert_map_create(..., limit = STD_UV_CONNECT_LIMIT = 1e-4, selected=false,
use_winding=true)``: the corners around one mesh vertex share an OpenSubdiv face-varying value iff
their UVs differ by < 1e-4 in u and in v and their faces have the same UV winding. So the
topology of the face-varying data is given by *values*, not by connectivity. The script asserts
that the explicit indices below agree with that: all UV faces wind counter-clockwise (positive
area), every UV index is used at one mesh vertex only, and distinct indices at one vertex are
> 1e-4 apart. Hence ``<case>_uv_indices`` is exactly the face-varying topology OpenSubdiv saw.
Every UV layer of the mesh is subdivided (one here, "UVMap").

Cases (vertex/face lists in the script; all faces quads, outward/CCW)
---------------------------------------------------------------------
UV values are a layout in units of 1/4 (cube) or 1/8 (grid) plus a small deterministic jitter
(multiples of 1/1024, |jitter| <= 12/1024) so that UVs are not affine within an island (Catmull-
Clark reproduces affine data in the interior, which would hide differences). All inputs are exact
in float32.

(a) ``a_cube_cross``: the 2x2x2 cube of blender_creases.py (vertices 0-3 at z=-1, 4-7 at z=+1;
    faces 0 bottom, 1 top, 2 front y=-1, 3 right x=+1, 4 back y=+1, 5 left x=-1). UVs: the usual
    cross (before the 1/4 scale, in unit squares): column front [1,2]x[0,1], top [1,2]x[1,2], back
    [1,2]x[2,3], bottom [1,2]x[3,4]; arms left [0,1]x[1,2] and right [2,3]x[1,2] hang off the top
    face. Uncut edges (UV-continuous): (4,5), (6,7), (2,3), (4,7), (5,6); the other 7 edges are
    seams; 14 UV points. Face-varying features per vertex (values : number of faces in each
    value's span):
      4, 5, 6, 7: one value over all 3 faces, one seam edge ends there -> interior "darts"
                  (the 4 concave 270-degree corners of the cross);
      0, 1:       three values, 1 face each -> junctions (3 regions), every span a UV corner;
      2, 3:       two values, spans of 1 and 2 faces (a convex corner next to a 180-degree one).
(b) ``b_grid_islands``: open 4x4 quad grid on [0,4]^2, vertex (i, j) = 5 j + i at x = i, y = j,
    a bumpy z; face (i, j) = 4 j + i with corners (i,j), (i+1,j), (i+1,j+1), (i,j+1). Three UV
    islands (``<case>_uv_islands`` per face):
      A = columns i = 0, 1 (8 faces);
      B = an L: i = 2, 3 for j = 0, 1, plus faces (3, 2), (3, 3) (6 faces);
      C = a strip: faces (2, 2), (2, 3) (2 faces).
    Island X has uv = offset_X + (i, j) / 8 + jitter, offsets A (1/16, 1/16), B (1/8, 1/16),
    C (1/2, 1/16), so islands are disjoint in UV space. Seams: the whole line x = 2 (A | B, C),
    the segment y = 2 for x in [2, 3] (B | C) and the segment x = 3 for y in [2, 4] (C | B).
    Face-varying features:
      vertices 7 (2,1), 17 (2,3): straight seam through interior vertices (2 values, 2 faces each);
      vertex 12 (2,2): junction of 3 regions (A spans 2 faces, B 1, C 1);
      vertex 13 (3,2): B's concave corner (B spans 3 faces) against C's convex corner (1 face);
      vertex 18 (3,3): straight seam (2 values, 2 faces each);
      boundary vertices 2 (2,0), 22 (2,4), 23 (3,4): where seams meet the mesh boundary, each
      value spans 1 face (UV corners); the 4 mesh corners are geometric corners (sharp under
      EDGE_AND_CORNER); other boundary vertices have one value.

Observed (Blender 5.0.1): all inputs and weights are dyadic, so the float32 UVs are exact. For
the cube, PRESERVE_CORNERS == PRESERVE_CORNERS_AND_JUNCTIONS (its junctions only have 1-face
spans, already corners) and PRESERVE_CORNERS_JUNCTIONS_AND_CONCAVE == PRESERVE_BOUNDARIES (no mesh
boundary; every seam value is sharp under both) bit for bit; for the grid all six differ.

Order of vertices, faces and loops (same as blender_creases.py, asserted here at every run)
-------------------------------------------------------------------------------------------
Vertices: coarse vertices, then for each coarse edge in Blender's edge order (``<case>_edges``)
its 2**L - 1 interior points from ``edges[e][0]`` to ``edges[e][1]``, then each face's inner
(2**L - 1)**2 points. Level 1: child c of quad f is face 4 f + c with corners rotated so the
coarse vertex is corner c: child 0 = (v0, e01, F, e30), 1 = (e01, v1, e12, F), 2 = (F, e12, v2,
e23), 3 = (e30, F, e23, v3). Loops: refined face k owns loops loop_start[k] .. loop_start[k]+3
(= 4 k .. 4 k + 3), loop j of face k sits at vertex faces[k][j] (= loop_verts[4 k + j]); so the
corner UVs of refined face k are ``uvs[4 k : 4 k + 4]`` in the order of ``faces[k]``.

Keys of the npz
---------------
``cases``, ``uv_smooth_options`` (Blender identifiers), ``fvar_linear_interpolation`` (OpenSubdiv
names, same order), ``levels``, ``meta``: string / int arrays.
Per case: ``<case>_vertices`` (n, 3) float64; ``<case>_faces`` (m, 4) int32;
``<case>_edges`` (e, 2) int32 Blender's edge order; ``<case>_uv_values`` (k, 2) float64;
``<case>_uv_indices`` (m, 4) int32: UV index of each face corner (same order as faces);
``<case>_uv_islands`` (m,) int32.
Per case, option OPT (a uv_smooth identifier) and level L in (1, 2):
``<case>_<OPT>_L<L>_vertices`` (N, 3) float32; ``..._faces`` (M, 4) int32;
``..._uvs`` (4 M, 2) float32 per loop; ``..._loop_start`` (M,) int32; ``..._loop_verts`` (4 M,)
int32. Vertex positions and faces are identical for all options (asserted).
"""

import os
import sys

import bpy
import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_creases import check_order, evaluate  # noqa: E402


LEVELS = (1, 2)
UV_CONNECT_LIMIT = 1e-4  # Blender's STD_UV_CONNECT_LIMIT
# (uv_smooth identifier, OpenSubdiv FVarLinearInterpolation it maps to)
UV_SMOOTH = [
    ("NONE", "FVAR_LINEAR_ALL"),
    ("PRESERVE_CORNERS", "FVAR_LINEAR_CORNERS_ONLY"),
    ("PRESERVE_CORNERS_AND_JUNCTIONS", "FVAR_LINEAR_CORNERS_PLUS1"),
    ("PRESERVE_CORNERS_JUNCTIONS_AND_CONCAVE", "FVAR_LINEAR_CORNERS_PLUS2"),
    ("PRESERVE_BOUNDARIES", "FVAR_LINEAR_BOUNDARIES"),
    ("SMOOTH_ALL", "FVAR_LINEAR_NONE"),
]
BILINEAR_OPTION = "NONE"

CUBE_V = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
          (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
# The cross, in unit squares (scaled by 1/4 below): 14 points, listed by rows.
CUBE_UV_LAYOUT = [(1, 0), (2, 0),
                  (0, 1), (1, 1), (2, 1), (3, 1),
                  (0, 2), (1, 2), (2, 2), (3, 2),
                  (1, 3), (2, 3),
                  (1, 4), (2, 4)]
CUBE_UV_IDX = [(12, 10, 11, 13),   # bottom  [1,2]x[3,4]
               (3, 4, 8, 7),       # top     [1,2]x[1,2]
               (0, 1, 4, 3),       # front   [1,2]x[0,1]
               (5, 9, 8, 4),       # right   [2,3]x[1,2]
               (11, 10, 7, 8),     # back    [1,2]x[2,3]
               (6, 2, 3, 7)]       # left    [0,1]x[1,2]
CUBE_ISLANDS = [0] * 6


def jitter(k):
    """Deterministic jitter of UV point k: multiples of 1/1024, at most 12/1024 per coordinate."""
    du = 2 * (((7 * k + 3) % 13) - 6)
    dv = 2 * (((5 * k + 1) % 11) - 5)
    return du / 1024.0, dv / 1024.0


def cube_case():
    uv = [(0.25 * u + jitter(k)[0], 0.25 * v + jitter(k)[1])
          for k, (u, v) in enumerate(CUBE_UV_LAYOUT)]
    return CUBE_V, CUBE_F, uv, CUBE_UV_IDX, CUBE_ISLANDS


def grid_case():
    bumps = [0.0, 0.1, -0.05, 0.0, 0.05,
             0.05, 0.3, 0.2, -0.1, 0.0,
             -0.1, 0.25, 0.35, 0.05, 0.1,
             0.0, -0.05, 0.1, 0.2, -0.05,
             0.05, 0.0, -0.1, 0.05, 0.0]
    verts = [(float(i), float(j), bumps[5 * j + i]) for j in range(5) for i in range(5)]
    faces, islands = [], []
    for j in range(4):
        for i in range(4):
            faces.append((5 * j + i, 5 * j + i + 1, 5 * (j + 1) + i + 1, 5 * (j + 1) + i))
            if i < 2:
                islands.append(0)                       # A
            elif (i, j) in ((2, 2), (2, 3)):
                islands.append(2)                       # C
            else:
                islands.append(1)                       # B (an L)
    offsets = {0: (1 / 16, 1 / 16), 1: (1 / 8, 1 / 16), 2: (1 / 2, 1 / 16)}
    index, uv, uv_idx = {}, [], []
    for f, face in enumerate(faces):
        isl = islands[f]
        corner_idx = []
        for v in face:
            key = (isl, v)
            if key not in index:
                k = len(uv)
                index[key] = k
                i, j = v % 5, v // 5
                du, dv = jitter(k)
                uv.append((offsets[isl][0] + i / 8 + du, offsets[isl][1] + j / 8 + dv))
            corner_idx.append(index[key])
        uv_idx.append(tuple(corner_idx))
    return verts, faces, uv, uv_idx, islands


CASES = {
    "a_cube_cross": cube_case(),
    "b_grid_islands": grid_case(),
}


def check_inputs(verts, faces, uv, uv_idx):
    """Assert the indices are the face-varying topology Blender rebuilds from the UV values."""
    uv = np.asarray(uv)
    assert np.all(uv.astype(np.float32) == uv), "UVs must be exact in float32"
    owner = {}
    for face, idx in zip(faces, uv_idx):
        q = uv[list(idx)]
        area = 0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])
        assert area > 0, ("UV winding", face, idx)
        for v, k in zip(face, idx):
            assert owner.setdefault(k, v) == v, ("UV index used at two vertices", k)
    assert sorted(owner) == list(range(len(uv))), "unused UV index"
    by_vertex = {}
    for k, v in owner.items():
        by_vertex.setdefault(v, []).append(k)
    for v, ks in by_vertex.items():
        for a in ks:
            for b in ks:
                if a < b:
                    assert np.max(np.abs(uv[a] - uv[b])) >= UV_CONNECT_LIMIT, ("weld", v, a, b)


def build(verts, faces, uv, uv_idx):
    me = bpy.data.meshes.new("coarse")
    me.from_pydata([tuple(map(float, v)) for v in verts], [], [tuple(f) for f in faces])
    me.update()
    loop_verts = np.empty(len(me.loops), dtype=np.int32)
    me.loops.foreach_get("vertex_index", loop_verts)
    assert list(loop_verts) == [v for f in faces for v in f], "coarse loop order"
    layer = me.uv_layers.new(name="UVMap")
    flat = np.asarray(uv, dtype=np.float32)[np.asarray(uv_idx).ravel()]
    layer.data.foreach_set("uv", flat.ravel())
    me.update()
    back = np.empty(2 * len(me.loops), dtype=np.float32)
    me.uv_layers["UVMap"].data.foreach_get("uv", back)
    assert np.array_equal(back.reshape(-1, 2), flat), "coarse UVs not stored exactly"
    edges = np.array([tuple(e.vertices) for e in me.edges], dtype=np.int32)
    return me, edges


def subdivide(me, level, uv_smooth):
    ob, ev, out = evaluate(me, level, uv_smooth)
    n, nl, nf = len(out.vertices), len(out.loops), len(out.polygons)
    pos = np.empty(3 * n, dtype=np.float32)
    out.vertices.foreach_get("co", pos)
    loop_verts = np.empty(nl, dtype=np.int32)
    out.loops.foreach_get("vertex_index", loop_verts)
    loop_start = np.empty(nf, dtype=np.int32)
    out.polygons.foreach_get("loop_start", loop_start)
    loop_total = np.empty(nf, dtype=np.int32)
    out.polygons.foreach_get("loop_total", loop_total)
    assert len(out.uv_layers) == 1 and out.uv_layers[0].name == "UVMap"
    uvs = np.empty(2 * nl, dtype=np.float32)
    out.uv_layers[0].data.foreach_get("uv", uvs)
    polys = [list(p.vertices) for p in out.polygons]
    ev.to_mesh_clear()
    bpy.data.objects.remove(ob)
    assert np.all(loop_total == 4), "non-quad in the result"
    faces = np.array(polys, dtype=np.int32)
    assert np.array_equal(loop_start, 4 * np.arange(nf, dtype=np.int32)), "loop layout"
    assert np.array_equal(loop_verts, faces.ravel()), "loop vertices"
    return pos.reshape(n, 3), faces, uvs.reshape(nl, 2), loop_start, loop_verts


def bilinear_children(corner_uvs):
    """(m, 4, 2) corner UVs -> (4 m, 4, 2) UVs of the level-1 children, in Blender's order."""
    out = []
    for q in corner_uvs:
        centre = q.mean(axis=0)
        for c in range(4):
            quad = [q[c], 0.5 * (q[c] + q[(c + 1) % 4]), centre, 0.5 * (q[c - 1] + q[c])]
            out.append(np.roll(np.array(quad), c, axis=0))
    return np.array(out)


def check_face_points(coarse_uv, uvs):
    """Any option: at level 1 the face-point UV (corner (c + 2) % 4 of child c) is the centroid."""
    corner = uvs.reshape(-1, 4, 4, 2)
    for c in range(4):
        err = np.abs(corner[:, c, (c + 2) % 4] - coarse_uv.mean(axis=1)).max()
        assert err < 1e-6, ("face point", c, err)


def check_bilinear(coarse_uv, l1_uvs, l2_uvs):
    """Level 1: Blender's children are the bilinear children (same order). Level 2: each level-2
    face's corner UVs are, as a set, those of one bilinear child of a level-1 face."""
    expect1 = bilinear_children(coarse_uv)
    err1 = np.abs(expect1 - l1_uvs.reshape(-1, 4, 2)).max()
    assert err1 < 1e-6, ("bilinear level 1", err1)
    expect2 = bilinear_children(l1_uvs.reshape(-1, 4, 2).astype(np.float64))
    got2 = l2_uvs.reshape(-1, 4, 2)
    centres = expect2.mean(axis=1)
    used = np.zeros(len(expect2), dtype=bool)
    err2 = 0.0
    for quad in got2:
        i = int(np.argmin(np.linalg.norm(centres - quad.mean(axis=0), axis=1)))
        assert not used[i], "level-2 faces matched twice"
        used[i] = True
        d = np.linalg.norm(quad[:, None, :] - expect2[i][None, :, :], axis=2)
        err2 = max(err2, float(d.min(axis=1).max()), float(d.min(axis=0).max()))
    assert used.all() and err2 < 1e-6, ("bilinear level 2", err2)
    return max(err1, err2)


def main(out_path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    enum = [it.identifier for it in
            bpy.types.SubsurfModifier.bl_rna.properties["uv_smooth"].enum_items]
    assert enum == [o for o, _ in UV_SMOOTH], ("uv_smooth options changed", enum)
    data = {}
    for name, (verts, faces, uv, uv_idx, islands) in CASES.items():
        check_inputs(verts, faces, uv, uv_idx)
        me, edges = build(verts, faces, uv, uv_idx)
        coarse_uv = np.asarray(uv)[np.asarray(uv_idx)]            # (m, 4, 2)
        data[f"{name}_vertices"] = np.asarray(verts, dtype=np.float64)
        data[f"{name}_faces"] = np.asarray(faces, dtype=np.int32)
        data[f"{name}_edges"] = edges
        data[f"{name}_uv_values"] = np.asarray(uv, dtype=np.float64)
        data[f"{name}_uv_indices"] = np.asarray(uv_idx, dtype=np.int32)
        data[f"{name}_uv_islands"] = np.asarray(islands, dtype=np.int32)
        geometry = {}
        results = {}
        for opt, _ in UV_SMOOTH:
            for level in LEVELS:
                pos, fcs, uvs, loop_start, loop_verts = subdivide(me, level, opt)
                check_order(np.asarray(faces), edges, level, pos, fcs)
                if level in geometry:
                    assert np.array_equal(geometry[level][0], pos), "positions depend on uv_smooth"
                    assert np.array_equal(geometry[level][1], fcs), "faces depend on uv_smooth"
                else:
                    geometry[level] = (pos, fcs)
                if level == 1:
                    check_face_points(coarse_uv, uvs)
                results[opt, level] = uvs
                key = f"{name}_{opt}_L{level}"
                data[f"{key}_vertices"] = pos
                data[f"{key}_faces"] = fcs
                data[f"{key}_uvs"] = uvs
                data[f"{key}_loop_start"] = loop_start
                data[f"{key}_loop_verts"] = loop_verts
        err = check_bilinear(coarse_uv, results[BILINEAR_OPTION, 1], results[BILINEAR_OPTION, 2])
        bpy.data.meshes.remove(me)
        print(f"{name}: L1 {len(geometry[1][0])} verts, L2 {len(geometry[2][0])} verts; "
              f"'{BILINEAR_OPTION}' is bilinear to {err:.1e}")
        for level in LEVELS:
            diffs = []
            for a, _ in UV_SMOOTH:
                row = [float(np.abs(results[a, level] - results[b, level]).max())
                       for b, _ in UV_SMOOTH]
                diffs.append(" ".join(f"{d:7.4f}" for d in row))
            print(f"  L{level} max |uv_a - uv_b| over options {[o for o, _ in UV_SMOOTH]}:")
            for (a, _), row in zip(UV_SMOOTH, diffs):
                print(f"    {a:40s} {row}")
    data["cases"] = np.array(list(CASES))
    data["uv_smooth_options"] = np.array([o for o, _ in UV_SMOOTH])
    data["fvar_linear_interpolation"] = np.array([f for _, f in UV_SMOOTH])
    data["levels"] = np.array(LEVELS, dtype=np.int32)
    data["meta"] = np.array([
        f"blender {bpy.app.version_string} build {bpy.app.build_hash.decode()}",
        "SUBSURF CATMULL_CLARK, use_creases=True, use_limit_surface=False, "
        "boundary_smooth=PRESERVE_CORNERS, quality=6; one run per uv_smooth",
        "uv_smooth -> OpenSubdiv: " + ", ".join(f"{o}={f}" for o, f in UV_SMOOTH),
        "OpenSubdiv CATMARK, CREASE_UNIFORM, VTX_BOUNDARY_EDGE_AND_CORNER, TRI_SUB_CATMARK",
        "loop k of refined face f is uvs[4 f + k] at vertex faces[f][k]",
    ])
    os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
    np.savez_compressed(out_path, **data)
    print(f"wrote {out_path}: {os.path.getsize(out_path)} bytes, {len(data)} arrays")


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    default = os.path.join(here, os.pardir, "tests", "data", "blender_uvs.npz")
    main(os.path.normpath(sys.argv[1] if len(sys.argv) > 1 else default))
