"""Refinement on the host, of a whole mesh or locally: one level with semi-sharp tags,
and the disjoint unions of 1-rings (around faces or vertices) that `SurfacePoints` and
`Limit` refine instead of the whole mesh where only some faces or vertices matter."""

import dataclasses

import numpy as np

from ._sharpness import semi_sharp_level
from ._stencil import Sparse, _ranks
from ._topology import Topology, build_topology


def _level(scheme, faces, count, creases, corners, crease_sharpness, corner_sharpness, topo=None,
           validate=True):  # fmt: skip
    """One level: the scheme's own for infinitely sharp tags, else the semi-sharp
    blend; returns the `Level` with the refined tags' sharpness filled in. Without
    `topo`, builds it (`validate=False`: the faces are a level of a checked mesh)."""
    if topo is None:
        topo = build_topology(faces, count, creases, corners, scheme.boundary_corners,
                              validate)  # fmt: skip
    if np.any(np.isfinite(crease_sharpness)) or np.any(np.isfinite(corner_sharpness)):
        return semi_sharp_level(scheme, topo, creases, crease_sharpness, corners,
                                corner_sharpness)  # fmt: skip
    step = scheme.level(topo, creases, corners)
    return dataclasses.replace(step, crease_sharpness=np.full(len(step.creases), np.inf),
                               corner_sharpness=np.full(len(step.corners), np.inf))  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Patches:
    """A mesh at some level (the whole mesh, or a disjoint union of 1-rings) and its
    vertices as rows of weights on the base vertices (`None`: the base vertices)."""

    faces: np.ndarray
    count: int
    creases: np.ndarray
    corners: np.ndarray
    crease_sharpness: np.ndarray
    corner_sharpness: np.ndarray
    weights: Sparse | None

    def topology(self, scheme) -> Topology:
        return build_topology(self.faces, self.count, self.creases, self.corners,
                              scheme.boundary_corners)  # fmt: skip

    def rows(self, rows: np.ndarray, num_base: int) -> Sparse:
        """The weights of vertices `rows` on the base vertices."""
        if self.weights is None:
            return Sparse.build(np.arange(len(rows)), rows, 1.0, (len(rows), num_base))
        return self.weights.take_rows(rows)


def _rings(refined: Patches, corners: np.ndarray) -> tuple[Patches, np.ndarray, np.ndarray]:
    """The disjoint union of the 1-rings (the faces holding any of a row of `corners`,
    `(m, k)` vertices of `refined`), each ring with its own copies of its vertices and
    the tags at its corners (the only ones the limit there depends on). Returns the
    union, its faces' keys `ring * F + face` and its vertices' `ring * V + vertex`
    (both sorted: a face's or vertex's index in the union is its key's rank)."""
    faces, V = refined.faces, refined.count
    F, width = faces.shape
    m, k = corners.shape
    flat = faces.reshape(-1)
    order = np.argsort(flat, kind="stable")
    start = np.searchsorted(flat[order], np.arange(V + 1))
    cv = corners.reshape(-1)
    counts = start[cv + 1] - start[cv]
    ring = np.repeat(np.repeat(np.arange(m), k), counts)
    face = order[np.repeat(start[cv], counts) + _ranks(counts)] // width
    keys = np.unique(ring * F + face)
    ring, face = keys // F, keys % F
    vkeys = ring[:, None] * V + faces[face]
    used, inverse = np.unique(vkeys[faces[face] >= 0], return_inverse=True)
    new_faces = np.full(vkeys.shape, -1, np.int64)
    new_faces[faces[face] >= 0] = inverse.reshape(-1)

    def new_vertex(r, v):
        return np.searchsorted(used, r * V + v)

    creases, crease_sharpness = np.zeros((0, 2), np.int64), np.zeros(0)
    if len(refined.creases):
        ends = refined.creases.reshape(-1)
        eorder = np.argsort(ends, kind="stable")
        estart = np.searchsorted(ends[eorder], np.arange(V + 1))
        ecount = estart[cv + 1] - estart[cv]
        r = np.repeat(np.repeat(np.arange(m), k), ecount)
        c = eorder[np.repeat(estart[cv], ecount) + _ranks(ecount)] // 2
        key = np.unique(r * len(refined.creases) + c)
        r, c = key // len(refined.creases), key % len(refined.creases)
        pairs = refined.creases[c]
        creases = np.stack([new_vertex(r, pairs[:, 0]), new_vertex(r, pairs[:, 1])], 1)
        crease_sharpness = refined.crease_sharpness[c]
    tags, tag_sharpness = np.zeros(0, np.int64), np.zeros(0)
    if len(refined.corners):
        index = np.full(V, -1)
        index[refined.corners] = np.arange(len(refined.corners))
        r, j = np.nonzero(index[corners] >= 0)
        tags = new_vertex(r, corners[r, j])
        tag_sharpness = refined.corner_sharpness[index[corners[r, j]]]
    num_base = refined.count if refined.weights is None else refined.weights.shape[1]
    weights = refined.rows(used % V, num_base)
    rings = Patches(new_faces, len(used), creases, tags, crease_sharpness, tag_sharpness, weights)
    return rings, keys, used


def _one_rings(refined: Patches, targets: np.ndarray) -> tuple[Patches, np.ndarray]:
    """The disjoint union of the 1-rings of the faces `targets` of `refined` (see
    `_rings`), and each target's index there."""
    rings, keys, _ = _rings(refined, refined.faces[targets])
    return rings, np.searchsorted(keys, np.arange(len(targets)) * len(refined.faces) + targets)


def vertex_rings(refined: Patches, centres: np.ndarray) -> tuple[Patches, np.ndarray]:
    """The disjoint union of the 1-rings of the vertices `centres` (the faces around
    each; see `_rings`), and each centre's index there. A vertex's limit stencils
    depend on its 1-ring only, and its 1-ring after one more level on its 1-ring now."""
    rings, _, used = _rings(refined, centres[:, None])
    return rings, np.searchsorted(used, np.arange(len(centres)) * refined.count + centres)


def refine_patches(scheme, p: Patches, topo: Topology) -> Patches:
    """One level of `p` (whose topology is `topo`), its vertices still on the base's."""
    step = _level(scheme, p.faces, p.count, p.creases, p.corners, p.crease_sharpness,
                  p.corner_sharpness, topo=topo)  # fmt: skip
    weights = step.stencil if p.weights is None else step.stencil @ p.weights
    return Patches(step.faces, step.stencil.shape[0], step.creases, step.corners,
                    step.crease_sharpness, step.corner_sharpness, weights)  # fmt: skip
