"""Refiners and limit evaluators: topology once on the host, a stencil kernel per call."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .._misc import (
    DEFAULT_MEMORY_BUDGET,
    as_float_array,
    checked_budget,
    format_bytes,
    static_int,
)
from ._base import APPROXIMATE, CORNER_TANGENTS, AbstractSurfaceScheme, Counts
from ._catmull_clark import CatmullClark
from ._local import Patches, _level, refine_patches, vertex_rings
from ._loop import Loop
from ._mesh import Mesh, StaticArray
from ._stencil import Sparse, StencilTable
from ._topology import build_topology


def _check(mesh, scheme) -> None:
    if not isinstance(mesh, Mesh):
        raise TypeError(
            "`mesh` must be a `jaxsubdiv.surfaces.Mesh(vertices, faces)`, got "
            f"{type(mesh).__name__}."
        )
    if not isinstance(scheme, AbstractSurfaceScheme):
        raise TypeError(
            "`scheme` must be a surface scheme: `Loop()`, `CatmullClark()` or "
            f"`DooSabin()`; got {type(scheme).__name__}."
        )
    if mesh.semi_sharp and not isinstance(scheme, (Loop, CatmullClark)):
        raise ValueError(
            f"The mesh has semi-sharp tags (a `crease_sharpness` or `corner_sharpness` "
            f"below 10), which {type(scheme).__name__}() does not take: OpenSubdiv's "
            "semi-sharp rules are defined for `Loop()` and `CatmullClark()`. Use one of "
            "those, or leave the sharpness out (infinitely sharp tags)."
        )


#: The most levels a `Refiner` takes: each level multiplies the half-edges by four, so 30
#: levels make 4^30 (10^18) times as many, beyond any `memory_budget` (at most 2^60
#: bytes); the bound also keeps a mesh without faces from looping for ever.
MAX_LEVELS = 30


def _check_surface_memory(topo, scheme, levels: int, budget: float, who: str = "Refiner",
                          factor: int = 1) -> None:  # fmt: skip
    """Predict the sizes level by level from the counts (nothing is refined) and raise
    the memory-budget error, naming `who`, before anything is built; `factor`: how many
    such refinements are built side by side."""
    base = counts = Counts.of(topo)
    per = scheme.bytes_per_half_edge * factor
    for level in range(1, levels + 1):
        counts = scheme.refined_counts(counts)
        need = counts.half_edges * per
        if need > budget:
            raise ValueError(
                f"{who}: {levels} levels of {type(scheme).__name__} on a mesh of "
                f"{base.faces:,} faces are above memory_budget={budget:,} bytes: level "
                f"{level} would make about {counts.faces:,} faces and {counts.vertices:,} "
                f"vertices and need about {format_bytes(need)} for its topology and stencil "
                f"tables ({per} bytes per half-edge, measured). Use at most {level - 1} "
                f"level{'' if level == 2 else 's'} here, or raise `memory_budget` (a finite "
                "number of bytes)."
            )


def _topology(mesh: Mesh, scheme: AbstractSurfaceScheme):
    return build_topology(mesh.faces, mesh.num_vertices, mesh.creases, mesh.corners,
                          scheme.boundary_corners)


class Refiner(eqx.Module):
    """Refine vertex data on a fixed mesh topology by a given number of levels.

    The topology is refined once, on the host, into one
    [`jaxsubdiv.surfaces.StencilTable`][] per level (each level's vertices as weighted
    sums of the previous level's), the split OpenSubdiv makes between topology
    refinement and stencil evaluation. Calling the refiner applies the tables in turn,
    so new positions or per-vertex features on the same mesh cost one jitted kernel per
    level: use it inside an optimization loop, under `jax.grad`, or on batches with
    `jax.vmap` or leading axes.

    The per-level tables hold fewer entries in total than the single composite table
    (base vertices straight to level `levels`, available from `composite()`), and are
    much cheaper to build; the benchmark compares both (`docs/surfaces.md`).

    ```python
    refiner = Refiner(mesh, CatmullClark(), levels=2)
    loss = lambda v: jnp.sum(refiner(v) ** 2)
    jax.grad(loss)(mesh.vertices)
    ```

    Attributes: `tables` (one stencil table per level), `levels`, `scheme`, and the
    refined topology as `faces`, `creases`, `corners` (numpy).
    """

    tables: tuple[StencilTable, ...]
    scheme: AbstractSurfaceScheme
    levels: int = eqx.field(static=True)
    num_base_vertices: int = eqx.field(static=True)
    memory_budget: float = eqx.field(static=True)
    _template: Mesh

    def __init__(
        self,
        mesh: Mesh,
        scheme: AbstractSurfaceScheme,
        levels: int = 1,
        *,
        memory_budget: float = DEFAULT_MEMORY_BUDGET,
    ):
        """**Arguments:**

        - `mesh`: the base [`jaxsubdiv.surfaces.Mesh`][]. Only its topology (faces,
          tags, number of vertices) is used; its vertex data may be anything.
        - `scheme`: `Loop()`, `CatmullClark()` or `DooSabin()`.
        - `levels`: number of refinement levels (a Python int, 0 to 30).
        - `memory_budget`: the most memory, in bytes, the refiner may use (default
          2 GiB; a finite number > 0). Each level multiplies the faces by about four:
          before anything is built, the sizes of every level are predicted from the
          counts of vertices, edges, faces and half-edges (exactly for Loop and
          Catmull-Clark, an upper estimate for Doo-Sabin near sharp edges), and the
          building cost estimated at the measured `scheme.bytes_per_half_edge`
          (Catmull-Clark 400, Loop and Doo-Sabin 200) per half-edge of the refined
          mesh; above the budget is a `ValueError` naming the most levels that fit.
          Calls check their output (`batch x N x C` numbers) against it too.
          Keyword only.
        """
        _check(mesh, scheme)
        levels = static_int(
            levels,
            "levels",
            minimum=0,
            maximum=MAX_LEVELS,
            why=" (each level multiplies the faces by about 4)",
        )
        memory_budget = checked_budget(memory_budget)
        count = mesh.num_vertices
        faces, creases, corners = mesh.faces, mesh.creases, mesh.corners
        sharpness = mesh.crease_sharpness, mesh.corner_sharpness
        stencils = []
        topo = build_topology(faces, count, creases, corners, scheme.boundary_corners)
        _check_surface_memory(topo, scheme, levels, memory_budget)
        for level in range(levels):
            # Levels after the first refine a refined mesh: only its edges are checked.
            try:
                step = _level(scheme, faces, count, creases, corners, *sharpness,
                              topo=None if level else topo, validate=False)  # fmt: skip
            except ValueError as error:
                if not level or "not manifold" not in str(error):
                    raise
                raise ValueError(
                    f"Refiner: {type(scheme).__name__}() made a mesh that is not manifold "
                    f"at level {level} ({error}) from this valid one. Loop does this to "
                    "two triangles glued along all three edges: its first level has their "
                    "middle triangle twice. Use a mesh of more faces, or `CatmullClark()`."
                ) from None
            stencils.append(step.stencil)
            count = step.stencil.shape[0]
            faces, creases, corners = step.faces, step.creases, step.corners
            sharpness = step.crease_sharpness, step.corner_sharpness
        # Every level's table and the template's (empty) vertices in one transfer.
        tables, vertices = StencilTable.from_built(stencils, np.zeros((count, 0)))
        self.tables = tuple(tables)
        self.scheme = scheme
        self.levels = levels
        self.num_base_vertices = mesh.num_vertices
        self.memory_budget = memory_budget
        # The refined faces are checked by construction and ours: no check, no copy.
        faces = StaticArray.owned(faces) if levels and faces.size else faces
        self._template = Mesh(vertices, faces, creases=creases, corners=corners,
                              crease_sharpness=sharpness[0], corner_sharpness=sharpness[1])

    def __call__(self, vertices: Float[ArrayLike, "*batch V C"]) -> Float[Array, "*batch N C"]:
        """The refined vertex data, `(..., N, C)` for `(..., V, C)` base data."""
        return apply_tables(self.tables, vertices, self.num_base_vertices, self.num_vertices,
                            self.memory_budget, "Refiner", "vertices")  # fmt: skip

    def composite(self) -> StencilTable:
        """One table from the base vertices straight to the refined ones (host-built)."""
        return StencilTable.from_sparse(self._composite_sparse())

    def _composite_sparse(self) -> Sparse:
        total = Sparse.identity(self.num_base_vertices)
        for table in self.tables:
            step = Sparse(*(np.asarray(a) for a in (table.rows, table.cols, table.weights)),
                          (table.num_rows, table.num_cols))  # fmt: skip
            total = step @ total
        return total

    def mesh(self, vertices: Float[ArrayLike, "V C"]) -> Mesh:
        """The refined [`jaxsubdiv.surfaces.Mesh`][] for base vertex data `vertices`."""
        refined = self(vertices)
        if refined.ndim != 2:
            raise ValueError("`Refiner.mesh` takes one `(V, C)` vertex array; call the refiner for batches.")
        return eqx.tree_at(lambda m: m.vertices, self._template, refined)

    @property
    def faces(self) -> np.ndarray:
        """Faces of the refined mesh (`-1`-padded, read-only numpy)."""
        return self._template.faces

    @property
    def creases(self) -> np.ndarray:
        return self._template.creases

    @property
    def corners(self) -> np.ndarray:
        return self._template.corners

    @property
    def crease_sharpness(self) -> np.ndarray:
        """Sharpness of the refined mesh's creases (decayed; `inf`: infinitely sharp)."""
        return self._template.crease_sharpness

    @property
    def corner_sharpness(self) -> np.ndarray:
        """Sharpness of the refined mesh's corners (decayed; `inf`: infinitely sharp)."""
        return self._template.corner_sharpness

    @property
    def num_vertices(self) -> int:
        """Number of refined vertices."""
        return self._template.num_vertices


def apply_tables(tables, data, num_base: int, num_out: int, budget: float, who: str, name: str):
    """Check `(..., num_base, C)` data and the output's size against `budget`, then apply
    the per-level tables in turn (a fixed chain of kernels: the count is static)."""
    data = as_float_array(data, name)
    if data.ndim < 2 or data.shape[-2] != num_base:
        raise ValueError(
            f"`{name}` must have shape (..., {num_base}, channels) for this mesh, got "
            f"{data.shape}."
        )
    batch = math.prod(data.shape[:-2])
    size = batch * num_out * data.shape[-1] * data.dtype.itemsize
    if size > budget:
        raise ValueError(
            f"{who} would return {batch:,} x {num_out:,} {name} x {data.shape[-1]} channels "
            f"= {format_bytes(size)}, above memory_budget={budget:,} bytes. Refine fewer "
            f"items at a time, or build the {who} with a larger `memory_budget`."
        )
    for table in tables:
        data = table(data)
    return data


def refine_mesh(
    mesh: Mesh,
    scheme: AbstractSurfaceScheme,
    levels: int = 1,
    *,
    memory_budget: float = DEFAULT_MEMORY_BUDGET,
) -> Mesh:
    """Refine `mesh` by `levels` levels of `scheme`.

    A convenience for `Refiner(mesh, scheme, levels).mesh(mesh.vertices)`: the topology
    is analyzed on every call, so to refine new positions on the same mesh repeatedly
    keep a [`jaxsubdiv.surfaces.Refiner`][] instead. Works under `eqx.filter_jit`
    (the topology is static), `jax.grad` and `jax.vmap` with respect to the vertices.

    **Arguments:**

    - `mesh`: a [`jaxsubdiv.surfaces.Mesh`][].
    - `scheme`: `Loop()`, `CatmullClark()` or `DooSabin()`.
    - `levels`: number of levels, a Python int from 0 to 30.
    - `memory_budget`: the most memory, in bytes, refining may use (default 2 GiB), as
      for [`jaxsubdiv.surfaces.Refiner`][]: checked before anything is built (the
      cube refined 12 times by Catmull-Clark would need about 150 GiB). Keyword only.

    **Returns:**

    The refined `Mesh`, with tagged creases and corners carried over.
    """
    return Refiner(mesh, scheme, levels, memory_budget=memory_budget).mesh(mesh.vertices)


def _semi_sharp_levels(mesh: Mesh, topo, boundary_corners: bool) -> int:
    """Levels until every semi-sharp tag that matters has decayed: tags on boundary
    edges (always sharp) and on vertices that are corners without their tag (in no
    face, a boundary vertex in one face, on three or more infinitely sharp edges) do
    not count."""
    edges = topo.edge_ids(mesh.creases, "creases") if len(mesh.creases) else np.zeros(0, int)
    creases = mesh.crease_sharpness[~topo.boundary_edge[edges]]
    infinite = topo.boundary_edge.copy()
    infinite[edges[np.isinf(mesh.crease_sharpness)]] = True
    ends = np.bincount(topo.edges[infinite].reshape(-1), minlength=topo.num_vertices)
    fixed = (topo.valence == 0) | (ends > 2)
    if boundary_corners:
        fixed |= topo.boundary_vertex & (np.bincount(topo.origin, minlength=topo.num_vertices) == 1)
    corners = mesh.corner_sharpness[~fixed[mesh.corners]]
    finite = np.concatenate([creases, corners])
    finite = finite[np.isfinite(finite)]
    return int(np.ceil(finite.max())) if len(finite) else 0


def _semi_sharp_vertices(mesh: Mesh, topo) -> np.ndarray:
    """The vertices on a semi-sharp edge or with a semi-sharp corner tag: the others'
    limit stencils depend only on their 1-ring's topology and rules, which no
    semi-sharp tag touches at any level."""
    mark = np.zeros(mesh.num_vertices, bool)
    finite = np.isfinite(mesh.crease_sharpness)
    mark[mesh.creases[finite].reshape(-1)] = True
    mark[mesh.corners[np.isfinite(mesh.corner_sharpness)]] = True
    return np.flatnonzero(mark)


def _semi_sharp_limit(mesh: Mesh, scheme: AbstractSurfaceScheme, budget: float,
                      local: bool = True):  # fmt: skip
    """Limit stencils of a mesh with semi-sharp tags, as OpenSubdiv evaluates the limit
    once the sharpness is gone: the limit stencils after refining until every finite
    sharpness that matters has decayed (up to 10 levels), composed with the refinement
    (vertex `v` keeps its index through primal levels).

    `local` (the default): only the vertices on semi-sharp tags need the refinement,
    and each only its 1-ring (a vertex's limit depends on its 1-ring, and its 1-ring
    after a level on its 1-ring before), so the disjoint union of those rings is
    refined, level by level, its size bounded instead of growing 4x per level; the
    other vertices take the stencils of the base mesh. `local=False` refines the whole
    mesh (also the fallback where the rings are not disks)."""
    topo = _topology(mesh, scheme)
    levels = _semi_sharp_levels(mesh, topo, scheme.boundary_corners)
    if local and levels:
        vertices = _semi_sharp_vertices(mesh, topo)
        current = Patches(mesh.faces, mesh.num_vertices, mesh.creases, mesh.corners,
                          mesh.crease_sharpness, mesh.corner_sharpness, None)  # fmt: skip
        centres = vertices
        try:
            for _ in range(levels):
                current, centres = vertex_rings(current, centres)
                ring_topo = build_topology(current.faces, current.count, current.creases,
                                           current.corners, scheme.boundary_corners)  # fmt: skip
                try:
                    _check_surface_memory(ring_topo, scheme, 1, budget)
                except ValueError:
                    raise ValueError(
                        f"Limit: refining the 1-rings of the {len(vertices):,} vertices on "
                        f"semi-sharp tags ({ring_topo.num_faces:,} faces) one level is above "
                        f"memory_budget={budget:,} bytes. Pass a larger `memory_budget`."
                    ) from None
                current = refine_patches(scheme, current, ring_topo)
            current, centres = vertex_rings(current, centres)
            fine = build_topology(current.faces, current.count, current.creases,
                                  current.corners, scheme.boundary_corners)  # fmt: skip
        except ValueError as error:
            if "memory_budget" in str(error):
                raise
            # A ring that is not a disk (fans meeting at an outer vertex): whole mesh.
        else:
            near = scheme.limit(fine, current.creases, current.corners)
            base = scheme.limit(topo, mesh.creases, mesh.corners)
            return base.replace(vertices, near.compose(centres, current.weights))
    try:
        _check_surface_memory(topo, scheme, levels, budget)
    except ValueError:
        raise ValueError(
            f"Limit: the largest semi-sharp tag of this mesh lasts {levels} levels, and "
            f"limit stencils are taken after refining the whole mesh that far, which is "
            f"above memory_budget={budget:,} bytes for {topo.num_faces:,} faces. Pass a "
            "larger `memory_budget`, or lower the sharpness (values of 10 or more are "
            "infinitely sharp and cost nothing)."
        ) from None
    refiner = Refiner(mesh, scheme, levels, memory_budget=budget)
    fine = build_topology(refiner.faces, refiner.num_vertices, refiner.creases,
                          refiner.corners, scheme.boundary_corners, validate=False)  # fmt: skip
    stencils = scheme.limit(fine, refiner.creases, refiner.corners)
    return stencils.compose(np.arange(mesh.num_vertices), refiner._composite_sparse())


def _safe_normalize(x: Float[Array, "... 3"]) -> Float[Array, "... 3"]:
    """`x / |x|`, and zero (with zero gradient, not NaN) where `x` is zero; NaN stays
    NaN (a NaN vertex must not give a clean normal)."""
    sq = jnp.sum(x * x, axis=-1, keepdims=True)
    zero = sq == 0
    return jnp.where(zero, 0.0, x / jnp.sqrt(jnp.where(zero, 1.0, sq)))


class Limit(eqx.Module):
    """Limit positions, tangents and normals at the vertices of a fixed mesh topology.

    The limit of subdivision at each base vertex (where the infinitely refined surface
    passes through the point that vertex becomes) is a fixed linear combination of
    nearby base vertices, given by the left eigenvectors of the local subdivision
    matrix. These combinations are stored as stencil tables, so evaluating them for new
    positions is one kernel, differentiable and batched like
    [`jaxsubdiv.surfaces.Refiner`][].

    Positions are exact at every vertex. Normals (`docs/surfaces.md` has the table):

    - *smooth* vertices of valence 3 and more: exact, from the closed-form tangent
      stencils; at *darts* (interior, on one crease edge) from the eigenvectors of the
      dart's local subdivision matrix (positions too, at every valence);
    - interior vertices of valence 2 (smooth, dart or tagged corner): no tangent
      plane exists; the normalized sum of the two faces' Newell normals of limit
      points, zero tangents;
    - boundary and crease vertices: each *sector* (the faces between the two sharp
      edges on one side) has its own limit tangent plane, spanned by the crease curve's
      tangent $p_0 - p_k$ and a cross tangent, the dominant symmetric left eigenvector
      of the sector's local subdivision matrix (computed once per sector size on the
      host). This is exact where the eigenvalue condition for a tangent plane holds
      with these rules: sectors of 2 to 5 triangles (Loop) and 2 or 3 quads
      (Catmull-Clark), and sectors of one face, whose tangent plane is the control
      triangle's $(v, p_0, p_1)$ (a boundary vertex in one face under "edge only", a
      crease turning within a face; zero when $v$ lies on the chord $p_0 p_1$). A
      boundary vertex has one sector, and its normal is that
      sector's; an interior crease vertex has two, and `normals` returns the
      normalized sum of the two unit sector normals (the surface has two tangent
      planes there);
    - corners: per sector, the cross product of the two crease-curve tangents
      $p_0 - v$ and $p_k - v$ (the limit tangents at a clamped curve end), oriented
      like the faces; the sum over sectors, normalized;
    - other sectors (more faces than above): the approximation of the normalized sum
      of the cross products of the limit positions' face edges.

    `tangents` returns the two exact tangents at smooth vertices (valence 3 and
    more) and at boundary vertices with an exact sector (along the boundary, across
    it), zeros elsewhere.

    Available for `Loop()` and `CatmullClark()`.
    """

    position: StencilTable
    tangent_u: StencilTable
    tangent_v: StencilTable
    smooth: Bool[Array, " V"]
    sector_u: StencilTable
    sector_v: StencilTable
    sector_vertex: Int[Array, " S"]
    sector_kind: Int[Array, " S"]
    corner_points: StencilTable
    corner_sector: Int[Array, " T"]

    def __init__(
        self,
        mesh: Mesh,
        scheme: AbstractSurfaceScheme,
        *,
        memory_budget: float = DEFAULT_MEMORY_BUDGET,
    ):
        """**Arguments:**

        - `mesh`: the base [`jaxsubdiv.surfaces.Mesh`][] (only its topology is used).
        - `scheme`: `Loop()` or `CatmullClark()`.
        - `memory_budget`: for meshes with semi-sharp tags, whose limit is taken after
          the sharpness has decayed (as many levels as the largest sharpness that
          matters, rounded up; tags on boundary edges and on vertices that are corners
          anyway do not count), refining the 1-rings of the vertices on those tags
          (the whole mesh where a ring is not a disk): the most memory, in bytes, that
          refinement may use, checked before each level. Keyword only.
        """
        _check(mesh, scheme)
        memory_budget = checked_budget(memory_budget)
        if mesh.semi_sharp:
            stencils = _semi_sharp_limit(mesh, scheme, memory_budget)
        else:
            topo = _topology(mesh, scheme)
            stencils = scheme.limit(topo, mesh.creases, mesh.corners)
        self.position = StencilTable.from_sparse(stencils.position)
        self.tangent_u = StencilTable.from_sparse(stencils.tangent_u)
        self.tangent_v = StencilTable.from_sparse(stencils.tangent_v)
        self.smooth = jax.device_put(np.asarray(stencils.smooth))
        self.sector_u = StencilTable.from_sparse(stencils.sector_u)
        self.sector_v = StencilTable.from_sparse(stencils.sector_v)
        self.sector_vertex = jax.device_put(np.asarray(stencils.sector_vertex, np.int32))
        self.sector_kind = jax.device_put(np.asarray(stencils.sector_kind, np.int32))
        self.corner_points = StencilTable.from_sparse(stencils.corner_points)
        self.corner_sector = jax.device_put(np.asarray(stencils.corner_sector, np.int32))

    def positions(self, vertices: Float[ArrayLike, "*batch V C"]) -> Float[Array, "*batch V C"]:
        """Limit positions (any channels), one per base vertex, same order."""
        return self.position(vertices)

    def tangents(
        self, vertices: Float[ArrayLike, "*batch V C"]
    ) -> tuple[Float[Array, "*batch V C"], Float[Array, "*batch V C"]]:
        """Two limit tangent vectors per vertex (unnormalized).

        Exact at smooth vertices of valence 3 and more and at boundary vertices whose
        sector has a tangent plane (there: along the boundary, and across it into the
        surface); zero elsewhere. Their cross product points to the side the faces'
        counter-clockwise orientation points to.
        """
        return self.tangent_u(vertices), self.tangent_v(vertices)

    def normals(self, vertices: Float[ArrayLike, "*batch V 3"]) -> Float[Array, "*batch V 3"]:
        """Unit limit normals, one per base vertex (`C = 3` only); see the class
        docstring for what is returned at boundary, crease and corner vertices."""
        vertices = as_float_array(vertices, "vertices")
        if vertices.shape[-1] != 3:
            raise ValueError(f"`normals` needs 3-d positions, got {vertices.shape[-1]} channels.")
        if vertices.ndim < 2 or vertices.shape[-2] != self.position.num_cols:
            raise ValueError(
                f"`vertices` must have shape (..., {self.position.num_cols}, 3) for this "
                f"mesh, got {vertices.shape}."
            )
        return _normals(self, vertices)


@eqx.filter_jit
def _normals(limit: Limit, vertices: Float[Array, "*batch V 3"]) -> Float[Array, "*batch V 3"]:
    # One compiled computation per mesh and shape (eagerly, each small op would compile).
    tu, tv = limit.tangents(vertices)
    smooth = jnp.cross(tu, tv)
    sector = jnp.cross(limit.sector_u(vertices), limit.sector_v(vertices))
    points = limit.corner_points(vertices)
    points = points.reshape(*points.shape[:-2], limit.corner_sector.shape[0], 3, 3)
    prev, center, nxt = points[..., 0, :], points[..., 1, :], points[..., 2, :]
    corners = jnp.cross(nxt - center, prev - center)
    approx = jnp.zeros_like(sector).at[..., limit.corner_sector, :].add(corners)
    # Terms that cancel (the two faces of a pillow are one triangle, either way round)
    # leave rounding noise, which must give no normal rather than a random one.
    magnitude = jnp.zeros_like(sector).at[..., limit.corner_sector, :].add(jnp.abs(corners))
    noise = 16 * jnp.finfo(sector.dtype).eps * jnp.sum(magnitude, -1, keepdims=True)
    approx = jnp.where(jnp.sum(jnp.abs(approx), -1, keepdims=True) <= noise, 0.0, approx)
    kind = limit.sector_kind[:, None]
    flip = (kind == CORNER_TANGENTS) & (jnp.sum(sector * approx, -1, keepdims=True) < 0)
    sector = jnp.where(flip, -sector, sector)
    sector = _safe_normalize(jnp.where(kind == APPROXIMATE, approx, sector))
    summed = jnp.zeros_like(smooth).at[..., limit.sector_vertex, :].add(sector)
    return _safe_normalize(jnp.where(limit.smooth[:, None], smooth, summed))


def limit_positions(
    mesh: Mesh, scheme: AbstractSurfaceScheme, *, memory_budget: float = DEFAULT_MEMORY_BUDGET
) -> Float[Array, "V C"]:
    """The limit position of every vertex of `mesh` under `scheme`, in vertex order.

    A convenience for `Limit(mesh, scheme).positions(mesh.vertices)`; keep a
    [`jaxsubdiv.surfaces.Limit`][] to evaluate new positions on the same topology.

    **Arguments:**

    - `mesh`: a [`jaxsubdiv.surfaces.Mesh`][].
    - `scheme`: `Loop()` or `CatmullClark()`.
    - `memory_budget`: as for [`jaxsubdiv.surfaces.Limit`][] (semi-sharp tags). Keyword only.

    **Returns:**

    `(V, C)` limit points.
    """
    return Limit(mesh, scheme, memory_budget=memory_budget).positions(mesh.vertices)


def limit_normals(
    mesh: Mesh, scheme: AbstractSurfaceScheme, *, memory_budget: float = DEFAULT_MEMORY_BUDGET
) -> Float[Array, "V 3"]:
    """Unit limit normals at the vertices of `mesh` (see [`jaxsubdiv.surfaces.Limit`][]).

    **Arguments:**

    - `mesh`: a [`jaxsubdiv.surfaces.Mesh`][] with 3-d vertices.
    - `scheme`: `Loop()` or `CatmullClark()`.
    - `memory_budget`: as for [`jaxsubdiv.surfaces.Limit`][] (semi-sharp tags). Keyword only.

    **Returns:**

    `(V, 3)` unit normals: exact at smooth vertices and at boundary and crease
    vertices whose sectors have a limit tangent plane (see [`jaxsubdiv.surfaces.Limit`][]).
    """
    return Limit(mesh, scheme, memory_budget=memory_budget).normals(mesh.vertices)
