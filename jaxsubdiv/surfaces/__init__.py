"""Differentiable, batched subdivision surfaces: Loop, Catmull-Clark and Doo-Sabin.

Topology is refined once on the host (numpy) into stencil tables; vertex data is then
refined or evaluated at the limit by one jitted kernel, so it is differentiable and
vmappable, and the tables are reused for every call on the same mesh.
"""

from ._base import AbstractSurfaceScheme as AbstractSurfaceScheme
from ._catmull_clark import CatmullClark as CatmullClark
from ._doo_sabin import DooSabin as DooSabin
from ._evaluate import SurfacePoints as SurfacePoints
from ._face_varying import FaceVarying as FaceVarying
from ._io import read_mesh as read_mesh, read_uvs as read_uvs, write_mesh as write_mesh
from ._loop import Loop as Loop
from ._mesh import Mesh as Mesh
from ._refine import (
    Limit as Limit,
    Refiner as Refiner,
    limit_normals as limit_normals,
    limit_positions as limit_positions,
    refine_mesh as refine_mesh,
)
from ._stencil import StencilTable as StencilTable
