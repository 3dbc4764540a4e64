"""Reference data for semi-sharp creases from Blender's Subdivision Surface modifier (OpenSubdiv).

Standalone: runs only in an environment that has Blender's ``bpy`` module (it imports nothing from
jaxsubdiv). ``bpy`` pins numpy < 2, so it lives in its own venv, e.g.::

    python3 -m venv /work/bpy-venv
    /work/bpy-venv/bin/pip install bpy==5.0.1      # Python 3.11 wheel, pulls numpy 1.26.4
    nice -n 10 /work/bpy-venv/bin/python benchmarks/blender_creases.py [OUT.npz]

It writes ``tests/data/blender_creases.npz`` (or OUT.npz), readable with plain numpy.

What Blender does (Blender 5.0.1, build a3db93c5b259; source: github.com/blender/blender)
-----------------------------------------------------------------------------------------
* Crease -> sharpness. Edge creases are the float attribute ``crease_edge`` (edge domain), vertex
  creases ``crease_vert`` (point domain), both in [0, 1]. The converter
  (source/blender/blenkernel/intern/subdiv_converter_mesh.cc: ``get_edge_sharpness`` /
  ``get_vertex_sharpness``, in newer trees ``gather_manifold_sharpness``) passes
  ``crease_to_sharpness(crease)`` to OpenSubdiv, defined in BKE_subdiv.hh / subdiv_inline.hh as
  ``edge_crease * edge_crease * 10.0f`` (float32): sharpness = 10 * crease**2, so crease 1 is
  sharpness 10 (= OpenSubdiv's SHARPNESS_INFINITE). The same function is used for vertices.
  Checked here too: crease sqrt(0.05) on one cube edge moves its level-1 edge point exactly half
  way from the smooth point to the midpoint (sharpness 0.5; 10 * crease would give 2.24, i.e. the
  midpoint).
* OpenSubdiv options (intern/opensubdiv/internal/topology/topology_refiner_factory.cc,
  ``getSDCOptions``): ``SetCreasingMethod(Options::CREASE_UNIFORM)`` (not Chaikin);
  ``SetVtxBoundaryInterpolation`` from the modifier's ``boundary_smooth``
  (source/blender/blenkernel/intern/subdiv.cc ``vtx_boundary_interpolation_from_subsurf``:
  PRESERVE_CORNERS -> VTX_BOUNDARY_EDGE_AND_CORNER, ALL -> VTX_BOUNDARY_EDGE_ONLY);
  ``SetFVarLinearInterpolation`` from ``uv_smooth``; triangle subdivision is never set, so it is
  OpenSubdiv's default TRI_SUB_CATMARK. Scheme: always SCHEME_CATMARK (the "Simple" type is
  emulated by making every edge and vertex infinitely sharp).
* Blender-specific extra (same file, ``assignComponentTags``): a vertex with exactly two edges gets
  vertex sharpness += min(sharpness of those two edges) (capped at 10). None of the cases below
  has a valence-2 vertex with creased edges (the grid's corners have valence 2 but their edges
  carry no crease; EDGE_AND_CORNER makes those corners infinitely sharp anyway). Vertices on a
  loose edge are made infinitely sharp (no loose edges here).
* Modifier settings (source/blender/blenkernel/intern/subdiv_modifier.cc
  ``BKE_subsurf_modifier_subdiv_settings_init``): with ``use_limit_surface=False`` the subdivision
  is uniform refinement to level = ``levels`` (``quality`` is used only for the limit surface);
  the vertex positions are the refined control points, not limit points.

Vertex order of the evaluated mesh (checked with Blender 5.0.1)
---------------------------------------------------------------
Blender builds the result straight from the coarse mesh at any level (subdiv_foreach), so at
L >= 2 the order is not OpenSubdiv's level-by-level order:
1. the coarse vertices (their refined positions), in input order;
2. for each coarse edge in Blender's edge order (``<case>_edges``), its 2**L - 1 interior points
   running from ``edges[e][0]`` to ``edges[e][1]`` (the middle one descends from the level-1 edge
   point);
3. for each coarse face in order, its (2**L - 1)**2 inner grid points (for a quad; the middle one
   descends from the level-1 face point).
At level 1 this is exactly: vertex points, edge points in Blender's edge order, face points in
face order. Child quad c of quad f has OpenSubdiv's corners (vertex c, edge point of edge (c, c+1),
face point of f, edge point of edge (c-1, c)) but rotated so that vertex c is corner c (the child
keeps the parent's orientation): child 0 = (v0, e01, F, e30), child 1 = (e01, v1, e12, F),
child 2 = (F, e12, v2, e23), child 3 = (e30, F, e23, v3). ``check_order`` asserts this and the
vertex counts at every run.
Checked once by hand (not at every run): re-subdividing Blender's smooth level-1 result once and
twice reproduces its level-2 and level-3 results to 2e-7 (float32), i.e. uniform refinement, and
gives the layout above. Positions are unique, so a test may also match vertices by position.

Keys of the npz (every case; L = 1, 2, 3)
-----------------------------------------
``<case>_vertices`` (n, 3) float64 input; ``<case>_faces`` (m, 4) int32 input;
``<case>_edges`` (e, 2) int32 in Blender's order; ``<case>_creases`` (k, 2) int32 vertex pairs;
``<case>_crease_values`` (k,) float32 Blender crease; ``<case>_sharpness`` (k,) float64 = the
float32 value 10 * c * c that Blender hands to OpenSubdiv; ``<case>_vertex_sharpness`` (n,) where
vertex creases are used; ``<case>_L<L>_vertices`` (N, 3) float32 as Blender computed them;
``<case>_L<L>_faces`` (M, 4) int32 (padded with -1 if a face had fewer corners; all are quads
here). ``meta`` is a string array describing the run.
"""

import os
import sys

import bpy
import numpy as np


LEVELS = (1, 2, 3)
F32 = np.float32

CUBE_V = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
          (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
# Outward-facing quads; face 1 is the top (z = 1).
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
CUBE_ALL_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
                  (0, 4), (1, 5), (2, 6), (3, 7)]
CUBE_TOP = [(4, 5), (5, 6), (6, 7), (7, 4)]


def grid():
    """Open 3x3 quad grid on [0, 3]^2: vertex (i, j) = 4 j + i at x = i, y = j, a bumpy z."""
    bumps = [0.0, 0.1, -0.05, 0.0,
             0.05, 0.3, 0.2, -0.1,
             -0.1, 0.25, 0.35, 0.05,
             0.0, -0.05, 0.1, 0.0]
    verts = [(float(i), float(j), bumps[4 * j + i]) for j in range(4) for i in range(4)]
    faces = [(4 * j + i, 4 * j + i + 1, 4 * (j + 1) + i + 1, 4 * (j + 1) + i)
             for j in range(3) for i in range(3)]
    return verts, faces


GRID_V, GRID_F = grid()

# case -> (vertices, faces, {edge: sharpness}, {vertex: sharpness})
CASES = {
    # (a) every cube edge semi-sharp
    "a_cube_all_0p5": (CUBE_V, CUBE_F, {e: 0.5 for e in CUBE_ALL_EDGES}, {}),
    # (b), (c) the top face's four edges
    "b_cube_top_1p0": (CUBE_V, CUBE_F, {e: 1.0 for e in CUBE_TOP}, {}),
    "c_cube_top_2p5": (CUBE_V, CUBE_F, {e: 2.5 for e in CUBE_TOP}, {}),
    # (d) different sharpness around the top face: each top vertex sees two different values
    "d_cube_top_mixed": (CUBE_V, CUBE_F, dict(zip(CUBE_TOP, (0.3, 1.0, 1.7, 3.0))), {}),
    # (e) one edge, darts at both ends
    "e_cube_one_edge_1p5": (CUBE_V, CUBE_F, {(4, 5): 1.5}, {}),
    # (f) a vertex crease on one corner, no edge creases
    "f_cube_vertex_2p0": (CUBE_V, CUBE_F, {}, {6: 2.0}),
    # (g) open grid: the two interior edges of the middle row of quads (x = 1 and x = 2,
    #     y in [1, 2]), two separate creased edges with darts at all four ends
    "g_grid_two_edges_1p5": (GRID_V, GRID_F, {(5, 9): 1.5, (6, 10): 1.5}, {}),
    # (h) open grid: a crease chain along the interior line y = 1 from interior vertex 5 (dart)
    #     through 6 (crease) to boundary vertex 7 (two boundary edges + the crease: a corner)
    "h_grid_chain_to_boundary_1p5": (GRID_V, GRID_F, {(5, 6): 1.5, (6, 7): 1.5}, {}),
}


def crease_for(sharpness):
    """Blender crease c (float32) whose 10 c^2, computed in float32 as Blender does, is nearest."""
    c0 = F32(np.sqrt(sharpness / 10.0))
    cands = [c0]
    lo = hi = c0
    for _ in range(16):
        lo = np.nextafter(lo, F32(0))
        hi = np.nextafter(hi, F32(1))
        cands += [lo, hi]
    return min(cands, key=lambda c: abs(float(to_sharpness(c)) - sharpness))


def to_sharpness(c):
    """Blender's crease_to_sharpness: edge_crease * edge_crease * 10.0f in float32."""
    c = F32(c)
    return F32(F32(c * c) * F32(10.0))


def build(verts, faces, edge_sharp, vert_sharp):
    me = bpy.data.meshes.new("coarse")
    me.from_pydata([tuple(map(float, v)) for v in verts], [], [tuple(f) for f in faces])
    me.update()
    edges = np.array([tuple(e.vertices) for e in me.edges], dtype=np.int32)
    index = {tuple(sorted(map(int, e))): i for i, e in enumerate(edges)}
    creases, cvals, sharp = [], [], []
    if edge_sharp:
        attr = me.attributes.new("crease_edge", "FLOAT", "EDGE")
        values = np.zeros(len(edges), dtype=np.float32)
        for (a, b), s in edge_sharp.items():
            c = crease_for(s)
            values[index[tuple(sorted((a, b)))]] = c
            creases.append((a, b))
            cvals.append(c)
            sharp.append(float(to_sharpness(c)))
        attr.data.foreach_set("value", values)
    vsharp = None
    if vert_sharp:
        attr = me.attributes.new("crease_vert", "FLOAT", "POINT")
        values = np.zeros(len(verts), dtype=np.float32)
        vsharp = np.zeros(len(verts))
        for v, s in vert_sharp.items():
            values[v] = crease_for(s)
            vsharp[v] = float(to_sharpness(values[v]))
        attr.data.foreach_set("value", values)
    me.update()
    return me, edges, creases, cvals, sharp, vsharp


def evaluate(me, level, uv_smooth="PRESERVE_BOUNDARIES"):
    """`(object, evaluated object, evaluated mesh)` of `me` under the Subdivision Surface
    modifier at `level` (Catmull-Clark, creases used, no limit surface, edge-and-corner
    boundaries); free them with `ev.to_mesh_clear()` and `bpy.data.objects.remove(ob)`."""
    ob = bpy.data.objects.new("obj", me.copy())
    bpy.context.scene.collection.objects.link(ob)
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.subdivision_type = "CATMULL_CLARK"
    mod.levels = level
    mod.render_levels = level
    mod.use_creases = True
    mod.use_limit_surface = False
    mod.boundary_smooth = "PRESERVE_CORNERS"
    mod.quality = 6
    mod.uv_smooth = uv_smooth
    assert mod.uv_smooth == uv_smooth
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    return ob, ev, ev.to_mesh()


def subdivide(me, level):
    ob, ev, out = evaluate(me, level)
    n = len(out.vertices)
    pos = np.empty(3 * n, dtype=np.float32)
    out.vertices.foreach_get("co", pos)
    polys = [list(p.vertices) for p in out.polygons]
    ev.to_mesh_clear()
    bpy.data.objects.remove(ob)
    width = max(len(p) for p in polys)
    faces = np.full((len(polys), width), -1, dtype=np.int32)
    for i, p in enumerate(polys):
        faces[i, :len(p)] = p
    return pos.reshape(n, 3), faces


def check_order(faces, edges, level, pos, out_faces):
    """Assert the counts of the layout in the module docstring, and at level 1 the child quads."""
    nv, ne, nf = int(np.max(faces)) + 1, len(edges), len(faces)
    k = 2 ** level - 1
    assert len(pos) == nv + ne * k + nf * k * k, "vertex count"
    assert len(out_faces) == nf * 4 ** level, "face count"
    if level != 1:
        return
    edge_index = {tuple(sorted(map(int, e))): i for i, e in enumerate(edges)}
    child = 0
    for f, face in enumerate(faces):
        n = len(face)
        for c in range(n):
            nxt = nv + edge_index[tuple(sorted((face[c], face[(c + 1) % n])))]
            prv = nv + edge_index[tuple(sorted((face[c - 1], face[c])))]
            expected = np.roll([face[c], nxt, nv + ne + f, prv], c)
            assert list(out_faces[child]) == list(expected), (f, c, out_faces[child], expected)
            child += 1


def main(out_path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    data = {}
    for name, (verts, faces, edge_sharp, vert_sharp) in CASES.items():
        me, edges, creases, cvals, sharp, vsharp = build(verts, faces, edge_sharp, vert_sharp)
        data[f"{name}_vertices"] = np.asarray(verts, dtype=np.float64)
        data[f"{name}_faces"] = np.asarray(faces, dtype=np.int32)
        data[f"{name}_edges"] = edges
        data[f"{name}_creases"] = np.asarray(creases, dtype=np.int32).reshape(-1, 2)
        data[f"{name}_crease_values"] = np.asarray(cvals, dtype=np.float32)
        data[f"{name}_sharpness"] = np.asarray(sharp, dtype=np.float64)
        if vsharp is not None:
            data[f"{name}_vertex_sharpness"] = vsharp
        results = {}
        for level in LEVELS:
            pos, fcs = subdivide(me, level)
            check_order(np.asarray(faces), edges, level, pos, fcs)
            results[level] = pos
            data[f"{name}_L{level}_vertices"] = pos
            data[f"{name}_L{level}_faces"] = fcs
        bpy.data.meshes.remove(me)
        print(f"{name}: " + ", ".join(f"L{lv} {len(results[lv])} verts" for lv in LEVELS))
    data["meta"] = np.array([
        f"blender {bpy.app.version_string} build {bpy.app.build_hash.decode()}",
        "SUBSURF CATMULL_CLARK, use_creases=True, use_limit_surface=False, "
        "boundary_smooth=PRESERVE_CORNERS, quality=6",
        "sharpness = float32(10 * c * c) for Blender crease c; OpenSubdiv CREASE_UNIFORM, "
        "VTX_BOUNDARY_EDGE_AND_CORNER, TRI_SUB_CATMARK",
    ])
    os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
    np.savez_compressed(out_path, **data)
    print(f"wrote {out_path}: {os.path.getsize(out_path)} bytes, {len(data)} arrays")


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    default = os.path.join(here, os.pardir, "tests", "data", "blender_creases.npz")
    main(os.path.normpath(sys.argv[1] if len(sys.argv) > 1 else default))
