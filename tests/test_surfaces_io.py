"""Mesh files: OBJ, OFF and ASCII PLY reading, writing and errors."""

import pathlib

import helpers
import numpy as np
import pytest

import jaxsubdiv.surfaces as jss


def prism():
    v, faces = helpers.prism()
    return v + np.pi / 100, faces  # coordinates that are not round numbers


@pytest.mark.parametrize("fmt", ["obj", "off", "ply"])
def test_round_trip(tmp_path, fmt):
    v, f = prism()
    mesh = jss.Mesh(v, f)
    path = tmp_path / f"prism.{fmt}"
    jss.write_mesh(path, mesh)
    back = jss.read_mesh(path)
    np.testing.assert_array_equal(np.asarray(back.vertices), v)  # 17 digits: exact
    np.testing.assert_array_equal(back.faces, mesh.faces)


@pytest.mark.parametrize("fmt", ["obj", "off", "ply"])
def test_written_files_read_by_trimesh(tmp_path, fmt):
    trimesh = pytest.importorskip("trimesh")
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.5]])
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    path = tmp_path / f"tet.{fmt}"
    jss.write_mesh(path, jss.Mesh(v, f))
    loaded = trimesh.load(path, process=False)
    np.testing.assert_allclose(loaded.vertices, v)
    np.testing.assert_array_equal(loaded.faces, f)


def test_read_obj_index_forms(tmp_path):
    text = """# a quad and a triangle
mtllib x.mtl
o thing
v 0 0 0
v 1 0 0
v 1 1 0   # trailing comment
v 0 1 0
vt 0 0
vn 0 0 1
f 1/1/1 2/1/1 3//1 4
v 2 0 0
f -4 -1 -3
"""
    path = tmp_path / "m.obj"
    path.write_text(text)
    mesh = jss.read_mesh(path)
    np.testing.assert_allclose(mesh.vertices, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]])
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2, 3], [1, 4, 2, -1]])


def test_read_off_and_ply_with_extras(tmp_path):
    off = tmp_path / "m.off"
    off.write_text("OFF\n# comment\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n")
    np.testing.assert_array_equal(jss.read_mesh(off).faces, [[0, 1, 2, 3]])
    ply = tmp_path / "m.ply"
    ply.write_text(
        "ply\nformat ascii 1.0\ncomment hi\nelement vertex 3\nproperty float y\n"
        "property float x\nproperty float z\nproperty uchar red\nelement face 1\n"
        "property list uchar int vertex_index\nend_header\n1 0 0 9\n0 1 0 9\n1 1 0 9\n3 0 1 2\n"
    )
    mesh = jss.read_mesh(ply)
    np.testing.assert_allclose(mesh.vertices, [[0, 1, 0], [1, 0, 0], [1, 1, 0]])


@pytest.mark.parametrize(
    "name, text, match",
    [
        ("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", r"a\.obj, line 4: face refers to vertex 4"),
        ("b.obj", "v 0 0\n", r"b\.obj, line 1: a vertex needs 3 coordinates"),
        ("c.obj", "v 0 0 0\nv 1 0 x\n", r"c\.obj, line 2: expected numbers"),
        ("d.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", r"d\.obj, line 4: OBJ vertex indices start at 1"),
        ("e.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", r"e\.off, line 6: face index out of range"),
        ("f.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", r"f\.off: the file ends early"),
        ("g.off", "COFF\n", r"g\.off, line 1: an OFF file starts with 'OFF'"),
        ("h.ply", "ply\nformat binary_little_endian 1.0\nend_header\n", r"h\.ply, line 2: only ASCII PLY"),
        ("i.stl", "", r"Cannot tell the mesh format"),
    ],
)
def test_malformed_files(tmp_path, name, text, match):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        jss.read_mesh(path)


def test_non_manifold_file(tmp_path):
    path = tmp_path / "fin.obj"
    # Three triangles on the edge (1, 2).
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nf 1 2 3\nf 2 4 3\nf 3 2 5\n")
    with pytest.raises(ValueError, match=r"fin\.obj: The mesh is not manifold: edge \(1, 2\)"):
        jss.read_mesh(path)
    assert jss.read_mesh(path, check=False).num_faces == 3


def test_write_needs_3d(tmp_path):
    with pytest.raises(ValueError, match="3-d positions"):
        jss.write_mesh(tmp_path / "x.obj", jss.Mesh(np.zeros((3, 2)), [[0, 1, 2]]))


# Hostile files (#17): (id, file name, contents as bytes, words the message must contain)
HOSTILE_FILES = [
    ("binary_ply", "bin.ply",
     b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
     b"property float y\nproperty float z\nelement face 1\n"
     b"property list uchar int vertex_indices\nend_header\n"
     + np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.5], "<f4").tobytes() + b"\x03"
     + np.array([0, 1, 2], "<i4").tobytes() + b"\xff\xfe\x80",
     ["bin.ply", "line 2", "only ASCII PLY", "binary_little_endian"]),
    ("binary_big_endian_ply", "big.ply",
     b"ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n\x80\x81",
     ["big.ply", "only ASCII PLY"]),
    ("nan_vertex_obj", "nan.obj", b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
     ["nan.obj", "vertex 1", "non-finite"]),
    ("inf_vertex_off", "inf.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 -inf 0\n3 0 1 2\n",
     ["inf.off", "vertex 2", "non-finite"]),
    ("overflowing_vertex_ply", "big.ply",
     b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
     b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
     b"0 0 0\n1e400 0 0\n0 1 0\n3 0 1 2\n",
     ["big.ply", "vertex 1", "non-finite"]),
    ("not_text_obj", "bin.obj", b"v 0 0 0\n\xff\xfe\x00\x01",
     ["bin.obj", "not a text OBJ file"]),
]  # fmt: skip


@pytest.mark.parametrize(
    "name, data, words", [c[1:] for c in HOSTILE_FILES], ids=[c[0] for c in HOSTILE_FILES]
)
def test_hostile_files_are_one_clear_error(tmp_path, name, data, words):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(ValueError) as info:
        jss.read_mesh(path)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_finite_extreme_vertices_are_read(tmp_path):
    path = tmp_path / "ok.obj"
    path.write_text("v 0 0 0\nv 1e308 0 0\nv 0 -1e-320 0\nf 1 2 3\n")
    np.testing.assert_array_equal(jss.read_mesh(path).vertices[1], [1e308, 0, 0])


def test_read_uvs_gives_a_face_varying_channel(tmp_path):
    """Texture coordinates of an OBJ, as `FaceVarying` takes them: one value per
    distinct (vertex, vt) pair (the file uses vt 2 at vertices 2 and 4 of one face, a
    repeating texture, and vt 1 at vertices 1 and 5; the faces' shared edge is a seam),
    aligned with `read_mesh`'s faces."""
    path = tmp_path / "uv.obj"
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 0.5\n"
        "f 1/1 2/2 3/3 4/2\nf 2/3 5/1 3/4\n"
    )
    mesh = jss.read_mesh(path)
    values, indices = jss.read_uvs(path)
    # (vertex, vt) pairs in sorted order: (0,0) (1,1) (1,2) (2,2) (2,3) (3,1) (4,0).
    np.testing.assert_array_equal(values, [[0, 0], [1, 0], [1, 1], [1, 1], [0.5, 0.5], [1, 0],
                                           [0, 0]])  # fmt: skip
    np.testing.assert_array_equal(indices, [[0, 1, 3, 5], [2, 6, 4, -1]])
    assert indices.shape == mesh.faces.shape
    channel = jss.FaceVarying(mesh, indices, jss.CatmullClark(), 1)
    assert channel.faces.shape == (7, 4) and channel.num_values == 7 + 7 + 2
    with pytest.raises(ValueError, match=r"uv\.obj: face 1 has a corner without a texture coordinate"):
        path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\n"
                        "f 1/1 2/1 3/1\nf 1/1 3 4/1\n")  # fmt: skip
        jss.read_uvs(path)
    with pytest.raises(ValueError, match=r"uv\.obj, line 5: face refers to texture coordinate 2, but only 1"):
        path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/2 3/1\n")
        jss.read_uvs(path)


SUZANNE = {"NONE": "all", "PRESERVE_CORNERS_AND_JUNCTIONS": "corners_plus1",
           "PRESERVE_BOUNDARIES": "boundaries", "SMOOTH_ALL": "none"}  # fmt: skip


@pytest.mark.parametrize("option", list(SUZANNE))
def test_suzanne_obj_uvs_match_blender(option):
    """A real file: Blender's Suzanne (quads and triangles, its own UV map with seams)
    as Blender's exporter writes it, read by `read_mesh` and `read_uvs` and refined one
    level with `FaceVarying`, against Blender's modifier on the same file
    (`benchmarks/blender_suzanne_uvs.py`): positions and every corner's UV within
    float32 rounding. Faces are matched by their vertices' positions."""
    data = pathlib.Path(__file__).parent / "data"
    mesh = jss.read_mesh(data / "suzanne.obj")
    values, indices = jss.read_uvs(data / "suzanne.obj")
    ref = np.load(data / "blender_suzanne_uvs.npz")
    refiner = jss.Refiner(mesh, jss.CatmullClark(), 1)
    channel = jss.FaceVarying(mesh, indices, jss.CatmullClark(), 1,
                              linear_interpolation=SUZANNE[option])  # fmt: skip
    points, uvs = np.asarray(refiner(mesh.vertices)), np.asarray(channel(values))
    loop_vertex, starts = ref[f"{option}_L1_loopv"], ref[f"{option}_L1_start"]
    their_uvs = ref[f"{option}_L1_uvs"].astype(np.float64)
    ends = np.append(starts[1:], len(loop_vertex))
    worst = helpers.corner_value_error(
        points, refiner.faces, channel.faces, uvs, ref[f"{option}_L1_pos"].astype(np.float64),
        [loop_vertex[a:b].tolist() for a, b in zip(starts, ends)],
        [their_uvs[a:b] for a, b in zip(starts, ends)], point_tolerance=1e-6,
    )  # fmt: skip
    assert worst < 1e-6, worst
