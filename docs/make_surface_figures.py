"""The pictures of docs/surfaces.md: semi-sharp creases and face-varying UVs.

    python docs/make_surface_figures.py   # writes docs/images/surfaces_*.png (seconds)

1. `surfaces_semi_sharp.png`: a cube refined 4 levels by Catmull-Clark with the four
   edges around its top face tagged at sharpness 0 (no tag), 0.5, 1, 2 and infinite.
2. `surfaces_face_varying.png`: the cube's UVs unwrapped as a cross (every cut edge a
   seam), refined 3 levels with three of OpenSubdiv's face-varying options ("all",
   "corners_only", "none"), drawn in UV space.
"""

import pathlib

import matplotlib


matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

import jaxsubdiv.surfaces as jss  # noqa: E402


IMAGES = pathlib.Path(__file__).parent / "images"
CUBE_V = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
CUBE_F = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4],
                   [1, 5, 7, 3]])  # fmt: skip
TOP = [[1, 3], [3, 7], [7, 5], [5, 1]]  # the four edges around the face z = +1


def shade(ax, mesh: jss.Mesh, title: str) -> None:
    points = np.asarray(mesh.vertices)
    quads = points[mesh.faces]
    normals = np.cross(quads[:, 2] - quads[:, 0], quads[:, 3] - quads[:, 1])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    light = np.clip(normals @ np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]), 0, 1)
    colours = plt.cm.Blues(0.35 + 0.55 * light)
    ax.add_collection3d(Poly3DCollection(quads, facecolors=colours, edgecolors="none"))
    ax.set(xlim=(-1, 1), ylim=(-1, 1), zlim=(-1, 1), title=title)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=22, azim=-60)
    ax.set_axis_off()


def semi_sharp() -> None:
    values = [None, 0.5, 1.0, 2.0, np.inf]
    fig = plt.figure(figsize=(12, 2.8))
    for k, s in enumerate(values):
        tags = {} if s is None else dict(creases=TOP, crease_sharpness=s)
        mesh = jss.refine_mesh(jss.Mesh(CUBE_V, CUBE_F, **tags), jss.CatmullClark(), 4)
        label = "no tag" if s is None else ("infinitely sharp" if np.isinf(s) else f"sharpness {s:g}")
        shade(fig.add_subplot(1, len(values), k + 1, projection="3d"), mesh, label)
    fig.suptitle("Catmull-Clark, 4 levels: the top face's four edges tagged", y=0.98)
    fig.savefig(IMAGES / "surfaces_semi_sharp.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def cross_uvs():
    """The cube unfolded as a cross: the four faces around the z axis in a row (the
    ring cut between x = -1 and y = -1), the top above and the bottom below the y = -1
    face. Returns per-corner value indices and the values; corners that meet in the
    unfolding share a value, so the cut edges are the seams."""
    unfold = {  # face: its (u, v) from the 3-d corner (x, y, z)
        2: lambda x, y, z: (x + 1, z + 1),  # y = -1
        1: lambda x, y, z: (3 + y, z + 1),  # x = +1
        3: lambda x, y, z: (5 - x, z + 1),  # y = +1
        0: lambda x, y, z: (7 - y, z + 1),  # x = -1
        5: lambda x, y, z: (x + 1, 3 + y),  # z = +1, above the y = -1 face
        4: lambda x, y, z: (x + 1, -1 - y),  # z = -1, below it
    }
    layout = {}
    indices = np.array([[layout.setdefault(unfold[f](*CUBE_V[i]), len(layout)) for i in face]
                        for f, face in enumerate(CUBE_F)])  # fmt: skip
    return indices, np.array(sorted(layout, key=layout.get), float) / 2


def face_varying() -> None:
    indices, uvs = cross_uvs()
    mesh = jss.Mesh(CUBE_V, CUBE_F)
    options = ["all", "corners_only", "none"]
    fig, axes = plt.subplots(1, len(options), figsize=(12, 3.6))
    for ax, option in zip(axes, options):
        channel = jss.FaceVarying(mesh, indices, jss.CatmullClark(), 3, linear_interpolation=option)
        values = np.asarray(channel(uvs))
        corners = values[channel.faces]
        edges = np.concatenate([corners, corners[:, :1]], axis=1)
        ax.add_collection(LineCollection(edges, colors="tab:blue", linewidths=0.5))
        ax.plot(*uvs.T, "o", color="black", markersize=3)
        ax.set(xlim=(-0.2, 4.2), ylim=(-1.2, 2.2), aspect="equal", title=f'"{option}"')
        ax.set_axis_off()
    fig.suptitle("FaceVarying: the cube's UV cross (black: the input values), 3 levels", y=1.0)
    fig.savefig(IMAGES / "surfaces_face_varying.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    IMAGES.mkdir(exist_ok=True)
    semi_sharp()
    face_varying()
    print(f"wrote {IMAGES}/surfaces_semi_sharp.png and surfaces_face_varying.png")
