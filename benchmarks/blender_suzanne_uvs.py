"""A real OBJ file with UVs, and Blender's refinement of it: the data of
`tests/test_surfaces_io.py::test_suzanne_obj_uvs_match_blender`.

Standalone, like ``blender_uvs.py`` (see there and ``blender_creases.py`` for the
environment and Blender's conventions)::

    nice -n 10 /work/bpy-venv/bin/python benchmarks/blender_suzanne_uvs.py

Blender 5.0.1 adds its monkey, Suzanne (507 vertices, 500 faces: quads and triangles,
with its own UV map, seams included), and exports it with its exporter
(``wm.obj_export``, UVs on, no normals or materials) to ``tests/data/suzanne.obj``. The
file is then imported again with Blender's importer, refined one level by the Subdivision
Surface modifier (Catmull-Clark, ``blender_creases.evaluate``) under four ``uv_smooth``
options, and the refined positions and per-loop UVs, with each loop's vertex and each
face's first loop, are written to ``tests/data/blender_suzanne_uvs.npz``
(``<option>_L1_pos``, ``_uvs``, ``_loopv``, ``_start``).
"""

import os
import sys

import bpy
import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_creases import evaluate  # noqa: E402


DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data")
OPTIONS = ("NONE", "PRESERVE_CORNERS_AND_JUNCTIONS", "PRESERVE_BOUNDARIES", "SMOOTH_ALL")


def main():
    obj = os.path.join(DATA, "suzanne.obj")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add(calc_uvs=True)
    bpy.ops.wm.obj_export(filepath=obj, export_selected_objects=True, export_uv=True,
                          export_normals=False, export_materials=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.obj_import(filepath=obj)
    me = bpy.context.selected_objects[0].data
    data = {}
    for option in OPTIONS:
        ob, ev, out = evaluate(me, 1, option)
        n, loops = len(out.vertices), len(out.loops)
        pos = np.empty(3 * n, np.float32)
        out.vertices.foreach_get("co", pos)
        uvs = np.empty(2 * loops, np.float32)
        out.uv_layers[0].data.foreach_get("uv", uvs)
        loop_vertex = np.empty(loops, np.int32)
        out.loops.foreach_get("vertex_index", loop_vertex)
        start = np.empty(len(out.polygons), np.int32)
        out.polygons.foreach_get("loop_start", start)
        data.update({f"{option}_L1_pos": pos.reshape(-1, 3), f"{option}_L1_uvs": uvs.reshape(-1, 2),
                     f"{option}_L1_loopv": loop_vertex, f"{option}_L1_start": start})
        ev.to_mesh_clear()
        bpy.data.objects.remove(ob)
    path = os.path.join(DATA, "blender_suzanne_uvs.npz")
    np.savez_compressed(path, **data)
    print(f"wrote {obj} and {path}: {len(me.vertices)} vertices, {len(me.polygons)} faces")


if __name__ == "__main__":
    main()
