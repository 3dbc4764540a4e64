"""Reference data for face-varying UVs together with creases, from Blender's modifier.

Standalone, like ``blender_uvs.py`` (whose meshes, UV layouts and modifier run it reuses;
see there and ``blender_creases.py`` for the environment and Blender's conventions)::

    nice -n 10 /work/bpy-venv/bin/python benchmarks/blender_uv_creases.py [OUT.npz]

writes ``tests/data/blender_uv_creases.npz``: the grid of three UV islands and the cube
unwrapped as a cross of ``blender_uvs.py``, with creases and corners where they meet the UV
seams in different ways, every ``uv_smooth`` option, levels 1 and 2. Case names:

- ``g_seam_inf``: infinitely sharp creases along the grid's interior seam (x = 2);
- ``g_inside_inf``: infinitely sharp edges inside islands (ending at a seam);
- ``g_semi_inside``: semi-sharp edges (2.5, 0.5) inside one island, ending at a seam vertex
  where only one of the two regions holds a crease (OpenSubdiv's "dependent sharpness",
  which jaxsubdiv does not implement: documented);
- ``g_semi_seam``: the interior seam semi-sharp (1.5);
- ``g_corner``: vertex creases (infinitely sharp at 7 and 11, 2.0 at 17);
- ``c_inf_inside``, ``c_inf_seam``, ``c_semi``: the cube with infinitely sharp edges
  inside islands, along seams, and semi-sharp ones (2.5, 0.5).

Keys as in ``blender_uvs.py``, plus ``<case>_creases``, ``<case>_sharpness`` (the float32
sharpness Blender derives from the crease value), ``<case>_corners``,
``<case>_corner_sharpness``. Crease values are chosen by ``blender_creases.crease_for``.
The cases were first written by a reviewer to check the face-varying rules.
"""

import os
import sys

import bpy
import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_uvs  # noqa: E402
from blender_creases import crease_for, to_sharpness  # noqa: E402


LEVELS = (1, 2)
SEAM = [(2, 7), (7, 12), (12, 17), (17, 22)]  # the grid's interior seam, x = 2
CASES = {  # name: (mesh, {edge: sharpness}, {vertex: sharpness}); 10 is infinite
    "g_seam_inf": ("grid", {e: 10.0 for e in SEAM}, {}),
    "g_inside_inf": ("grid", {(6, 7): 10.0, (16, 17): 10.0, (8, 13): 10.0}, {}),
    "g_semi_inside": ("grid", {(6, 7): 2.5, (16, 17): 0.5}, {}),
    "g_semi_seam": ("grid", {e: 1.5 for e in SEAM}, {}),
    "g_corner": ("grid", {}, {7: 10.0, 11: 10.0, 17: 2.0}),
    "c_inf_inside": ("cube", {(2, 3): 10.0, (6, 7): 10.0}, {}),
    "c_inf_seam": ("cube", {(0, 1): 10.0, (1, 5): 10.0}, {}),
    "c_semi": ("cube", {(4, 5): 2.5, (5, 6): 0.5}, {}),
}


def add_creases(me, edge_sharpness, vertex_sharpness):
    """Blender crease attributes for the wanted sharpness; returns the tags as OpenSubdiv
    sees them: `(creases, sharpness, corners, corner sharpness)`."""
    edges = np.array([tuple(e.vertices) for e in me.edges], dtype=np.int32)
    index = {tuple(sorted(map(int, e))): i for i, e in enumerate(edges)}
    creases, sharpness, corners, corner_sharpness = [], [], [], []
    for domain, name, tags, out, values in (
        ("EDGE", "crease_edge", edge_sharpness, creases, sharpness),
        ("POINT", "crease_vert", vertex_sharpness, corners, corner_sharpness),
    ):
        if not tags:
            continue
        attribute = me.attributes.new(name, "FLOAT", domain)
        crease = np.zeros(len(edges) if domain == "EDGE" else len(me.vertices), np.float32)
        for key, s in tags.items():
            c = np.float32(1.0) if s >= 10 else crease_for(s)
            crease[index[tuple(sorted(key))] if domain == "EDGE" else key] = c
            out.append(key)
            values.append(float(to_sharpness(c)))
        attribute.data.foreach_set("value", crease)
    me.update()
    return creases, sharpness, corners, corner_sharpness


def main(out_path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    meshes = {"grid": blender_uvs.grid_case(), "cube": blender_uvs.cube_case()}
    data = {}
    for name, (mesh, edge_sharpness, vertex_sharpness) in CASES.items():
        verts, faces, uv, uv_idx, _ = meshes[mesh]
        me, _ = blender_uvs.build(verts, faces, uv, uv_idx)
        creases, sharpness, corners, corner_sharpness = add_creases(
            me, edge_sharpness, vertex_sharpness
        )
        data[f"{name}_vertices"] = np.asarray(verts, float)
        data[f"{name}_faces"] = np.asarray(faces, np.int32)
        data[f"{name}_uv_values"] = np.asarray(uv, float)
        data[f"{name}_uv_indices"] = np.asarray(uv_idx, np.int32)
        data[f"{name}_creases"] = np.asarray(creases, np.int32).reshape(-1, 2)
        data[f"{name}_sharpness"] = np.asarray(sharpness, float)
        data[f"{name}_corners"] = np.asarray(corners, np.int32)
        data[f"{name}_corner_sharpness"] = np.asarray(corner_sharpness, float)
        for option, _ in blender_uvs.UV_SMOOTH:
            for level in LEVELS:
                pos, out_faces, uvs, _, _ = blender_uvs.subdivide(me, level, option)
                key = f"{name}_{option}_L{level}"
                data[f"{key}_vertices"], data[f"{key}_faces"], data[f"{key}_uvs"] = pos, out_faces, uvs
        bpy.data.meshes.remove(me)
        print(f"{name} done", flush=True)
    data["meta"] = np.array([f"blender {bpy.app.version_string} build {bpy.app.build_hash.decode()}"])
    np.savez_compressed(out_path, **data)
    print(f"wrote {out_path}: {os.path.getsize(out_path)} bytes, {len(data)} arrays")


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    main(sys.argv[1] if len(sys.argv) > 1 else
         os.path.join(here, "..", "tests", "data", "blender_uv_creases.npz"))
