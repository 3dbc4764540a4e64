"""Host-side (numpy) topology of a polygon mesh: half-edges, edges, vertex types.

Everything here is vectorized numpy: one sort builds the edge table, and
pointer jumping orders the one-rings, so a mesh of 100,000 faces needs no Python loop
over its vertices or faces. Nothing here is traced; the results become stencil tables.
"""

import dataclasses

import numpy as np


# Vertex types (Hoppe et al. 1994): smooth (and darts), crease (two sharp edges), corner.
SMOOTH, CREASE, CORNER = 0, 1, 2


def flatten_faces(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Padded `(F, K)` faces (-1 = unused slot) to flat vertex indices and sizes."""
    valid = faces >= 0
    sizes = valid.sum(axis=1)
    return faces[valid].astype(np.int64), sizes.astype(np.int64)


def pad_faces(flat: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Flat vertex indices and face sizes to padded `(F, max size)` faces (-1 padded)."""
    if len(sizes) == 0:
        return np.zeros((0, 3), np.int64)
    width = int(sizes.max())
    out = np.full((len(sizes), width), -1, np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    face = np.repeat(np.arange(len(sizes)), sizes)
    out[face, np.arange(len(flat)) - offsets[face]] = flat
    return out


@dataclasses.dataclass(frozen=True, eq=False)
class Topology:
    """Half-edge description of a manifold polygon mesh (host numpy arrays).

    Half-edge `h` runs from `origin[h]` to `origin[next[h]]` inside face `face[h]`;
    half-edges are numbered in face order, so the half-edges of face `f` are
    `offsets[f]:offsets[f + 1]` and `origin` is the flat list of face vertices.
    """

    num_vertices: int
    origin: np.ndarray  # (H,) vertex each half-edge starts at
    sizes: np.ndarray  # (F,) vertices per face
    offsets: np.ndarray  # (F + 1,)
    face: np.ndarray  # (H,) face of each half-edge
    next: np.ndarray  # (H,)
    prev: np.ndarray  # (H,)
    edge: np.ndarray  # (H,) undirected edge of each half-edge
    twin: np.ndarray  # (H,) opposite half-edge, -1 on the boundary
    edges: np.ndarray  # (E, 2) vertex pairs, sorted within each row
    edge_half: np.ndarray  # (E,) one half-edge of each edge
    boundary_edge: np.ndarray  # (E,) bool
    sharp_edge: np.ndarray  # (E,) bool: boundary or tagged crease
    vertex_type: np.ndarray  # (V,) SMOOTH / CREASE / CORNER
    valence: np.ndarray  # (V,) number of incident edges
    boundary_vertex: np.ndarray  # (V,) bool
    # (E, 2) bool or None: whether the crease vertex rule counts each edge as sharp at
    # its end `edges[e, 0]` and at `edges[e, 1]`; None: at both ends iff `sharp_edge`.
    # Semi-sharp creases under OpenSubdiv's Chaikin method can differ at the two ends.
    crease_end: np.ndarray | None = None

    @property
    def num_faces(self) -> int:
        return len(self.sizes)

    @property
    def num_edges(self) -> int:
        return len(self.edges)

    @property
    def num_half_edges(self) -> int:
        return len(self.origin)

    def edge_ids(self, pairs: np.ndarray, name: str) -> np.ndarray:
        """Edge indices of vertex pairs; a `ValueError` naming `name` if one is absent."""
        pairs = np.sort(np.asarray(pairs, np.int64).reshape(-1, 2), axis=1)
        keys = self.edges[:, 0] * self.num_vertices + self.edges[:, 1]
        wanted = pairs[:, 0] * self.num_vertices + pairs[:, 1]
        if len(keys) == 0:
            missing = np.ones(len(wanted), bool)
            pos = np.zeros(len(wanted), np.int64)
        else:
            pos = np.clip(np.searchsorted(keys, wanted), 0, len(keys) - 1)
            missing = keys[pos] != wanted
        if np.any(missing):
            bad = pairs[np.argmax(missing)].tolist()
            raise ValueError(f"`{name}` lists the vertex pair {bad}, which is not an edge of the mesh.")
        return pos

    def _rounds(self) -> int:
        return int(np.ceil(np.log2(max(2, int(self.valence.max(initial=1)))))) + 1

    def rotation(self) -> tuple[np.ndarray, np.ndarray]:
        """`(rot, label)`: `rot[h] = twin[prev[h]]` around interior vertices (the next
        outgoing half-edge counter-clockwise; `h` itself elsewhere) and the smallest
        half-edge of each rotation cycle, found by pointer jumping."""
        H = self.num_half_edges
        interior = ~self.boundary_vertex[self.origin]
        rot = np.where(interior, self.twin[self.prev], np.arange(H))
        label, jump = np.arange(H), rot.copy()
        for _ in range(self._rounds()):
            label = np.minimum(label, label[jump])
            jump = jump[jump]
        return rot, label

    def ring(self) -> tuple[np.ndarray, np.ndarray]:
        """Outgoing half-edges of every interior vertex in counter-clockwise order.

        Returns `(order, start)`: `order[start[v]:start[v + 1]]` are the half-edges
        leaving `v`, each followed by `twin[prev[h]]` (counter-clockwise seen from the
        side the faces' orientation points to), starting from the smallest index.
        Boundary vertices get an empty range. Computed by list ranking with pointer
        jumping, so it is vectorized.
        """
        H, V = self.num_half_edges, self.num_vertices
        interior = ~self.boundary_vertex[self.origin]
        rot, label = self.rotation()
        ids = np.arange(H)
        # Cut each cycle before its smallest member; rank by distance to the cut.
        succ = np.where(interior & (rot != label), rot, ids)
        dist, jump = (succ != ids).astype(np.int64), succ.copy()
        for _ in range(self._rounds()):
            dist = dist + dist[jump]
            jump = jump[jump]
        sel = np.flatnonzero(interior)
        order = sel[np.lexsort((-dist[sel], self.origin[sel]))]
        counts = np.bincount(self.origin[sel], minlength=V)
        start = np.concatenate([[0], np.cumsum(counts)])
        return order, start

    def num_sharp(self) -> np.ndarray:
        """`(V,)` number of sharp (boundary or tagged crease) edges at every vertex."""
        return np.bincount(self.edges[self.sharp_edge].reshape(-1), minlength=self.num_vertices)

    def sectors(self) -> tuple[np.ndarray, np.ndarray]:
        """The fans of faces between consecutive sharp edges around every vertex that
        is on at least one sharp edge.

        Returns `(order, start)`: `order[start[s]:start[s + 1]]` are the outgoing
        half-edges of sector `s` in counter-clockwise order (each followed by
        `twin[prev[h]]`). The first one lies on a sharp edge (`edge[order[start[s]]]`)
        and the sector ends at the sharp edge `edge[prev[order[start[s + 1] - 1]]]`;
        a vertex with one sharp edge (a dart) has one sector that starts and ends on
        it. Vectorized by pointer jumping; sectors are numbered in no particular order.
        """
        H = self.num_half_edges
        ids = np.arange(H)
        on = self.num_sharp()[self.origin] > 0
        end = self.sharp_edge[self.edge[self.prev]]
        succ = np.where(on & ~end, self.twin[self.prev], ids)
        dist, jump = (succ != ids).astype(np.int64), succ.copy()
        for _ in range(self._rounds()):
            dist = dist + dist[jump]
            jump = jump[jump]
        sel = np.flatnonzero(on)
        order = sel[np.lexsort((-dist[sel], jump[sel]))]
        _, counts = np.unique(jump[order], return_counts=True)
        start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        return order, start


def build_topology(
    faces: np.ndarray,
    num_vertices: int,
    creases: np.ndarray | None = None,
    corners: np.ndarray | None = None,
    boundary_corners: bool = True,
    validate: bool = True,
) -> Topology:
    """Check a padded face array and build its half-edge [`Topology`][].

    Vertex types: a corner is tagged, on three or more sharp edges, isolated, or (when
    `boundary_corners`, OpenSubdiv's "edge and corner" boundary interpolation) a
    boundary vertex in a single face; a crease vertex is on two sharp edges (boundary
    edges are sharp); the rest are smooth.

    Raises a `ValueError` that names the offending face, edge or vertex for faces with
    fewer than three vertices, a repeated vertex or an out-of-range index, for edges
    shared by more than two faces, for neighboring faces of opposite orientation, and for
    non-manifold ("bowtie") vertices. `validate=False` is for the faces of a level of a
    checked mesh: it skips the two costly checks, a vertex repeated in a face (every
    scheme's refined faces list distinct new vertices) and two fans at an interior
    vertex (a child's fans follow its parent's). The cheap edge checks stay: Loop makes
    edges in four faces from two triangles glued along all their edges (a valid mesh).
    """
    faces = np.asarray(faces)
    V = int(num_vertices)
    F, K = faces.shape
    if F and K >= 3 and faces.min() >= 0:
        # No padding (triangles, quads, every refined Catmull-Clark level): the
        # half-edges are the array's slots, and `next`/`prev` are index arithmetic, not
        # masks and gathers (a third of this function's time on refined levels). A
        # level's own faces are shared (`validate=False`), a caller's copied.
        origin = faces.astype(np.int64, copy=validate).reshape(-1)
        if origin.max() >= V:
            raise ValueError(f"`faces` refers to vertex {int(origin.max())}, but there are only {V} vertices.")
        H = F * K
        sizes = np.full(F, K, np.int64)
        offsets = np.arange(0, H + 1, K, dtype=np.int64)
        face = np.repeat(np.arange(F), K)
        nxt = np.arange(1, H + 1)
        nxt[K - 1 :: K] -= K
        prv = np.arange(-1, H - 1)
        prv[::K] += K
    else:
        origin, sizes = flatten_faces(faces)
        if len(sizes) and sizes.min() < 3:
            f = int(np.argmin(sizes))
            raise ValueError(f"`faces`: face {f} has {int(sizes[f])} vertices; every face needs at least 3.")
        if len(origin) and (origin.min() < 0 or origin.max() >= V):
            raise ValueError(
                f"`faces` refers to vertex {int(origin.max())}, but there are only {V} vertices."
            )
        F, H = len(sizes), len(origin)
        offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        face = np.repeat(np.arange(F), sizes)
        local = np.arange(H) - offsets[face]
        nxt = np.where(local + 1 == sizes[face], offsets[face], np.arange(H) + 1)
        prv = np.where(local == 0, offsets[face] + sizes[face] - 1, np.arange(H) - 1)
    dest = origin[nxt]

    # A vertex repeated inside one face: equal neighbours once each face is sorted.
    if validate and faces.shape[1] <= 8:
        # Compare every pair of columns: cheaper than sorting each face when faces are small.
        K = faces.shape[1]
        repeated = np.zeros(len(faces), bool)
        for i in range(K):
            for j in range(i + 1, K):
                repeated |= (faces[:, i] == faces[:, j]) & (faces[:, j] >= 0)
    elif validate:
        ordered = np.sort(faces, axis=1)
        repeated = np.any((ordered[:, 1:] == ordered[:, :-1]) & (ordered[:, 1:] >= 0), axis=1)
    if validate and np.any(repeated):
        f = int(np.argmax(repeated))
        raise ValueError(f"`faces`: face {f} uses the same vertex twice ({faces[f].tolist()}).")

    # One sort of the undirected edge keys gives the edges, their half-edges and counts
    # (`np.unique` would sort again for each of those).
    keys = np.minimum(origin, dest) * V
    keys += np.maximum(origin, dest)  # in place: one temporary fewer
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    starts = np.ones(H, bool)
    starts[1:] = sorted_keys[1:] != sorted_keys[:-1]
    first = np.flatnonzero(starts)
    ukeys = sorted_keys[first]
    ecounts = np.diff(np.append(first, H))
    edge = np.empty(H, np.int64)
    edge[order] = np.cumsum(starts) - 1
    if np.any(ecounts > 2):
        k = ukeys[np.argmax(ecounts > 2)]
        raise ValueError(
            f"The mesh is not manifold: edge ({int(k // V)}, {int(k % V)}) is shared by "
            f"{int(ecounts.max())} faces; subdivision needs every edge in one or two faces."
        )
    pair = ecounts == 2
    a, b = order[first[pair]], order[first[pair] + 1]
    same = origin[a] == origin[b]  # both half-edges run the same way
    if np.any(same):
        h = a[np.argmax(same)]
        raise ValueError(
            f"Faces are not consistently oriented: the directed edge ({int(origin[h])}, "
            f"{int(dest[h])}) appears in two faces. Reverse the vertex order of one of them."
        )
    edges = np.empty((len(ukeys), 2), np.int64)
    edges[:, 0], edges[:, 1] = np.divmod(ukeys, V)  # one pass for both columns
    edge_half = order[first]
    twin = np.full(H, -1, np.int64)
    twin[a], twin[b] = b, a
    boundary_edge = ecounts == 1

    valence = np.bincount(edges.reshape(-1), minlength=V)
    nboundary = np.bincount(edges[boundary_edge].reshape(-1), minlength=V)
    if np.any((nboundary != 0) & (nboundary != 2)):
        v = int(np.argmax((nboundary != 0) & (nboundary != 2)))
        raise ValueError(
            f"The mesh is not manifold at vertex {v}: it touches {int(nboundary[v])} "
            "boundary edges (two fans of faces meet only at this vertex)."
        )
    boundary_vertex = nboundary > 0

    sharp = boundary_edge.copy()
    tagged_corner = np.zeros(V, bool)
    topo = Topology(
        V, origin, sizes, offsets, face, nxt, prv, edge, twin, edges, edge_half,
        boundary_edge, sharp, np.zeros(V, np.int8), valence, boundary_vertex,
    )  # fmt: skip
    if creases is not None and len(creases):
        sharp[topo.edge_ids(creases, "creases")] = True
    if corners is not None and len(corners):
        corners = np.asarray(corners, np.int64).reshape(-1)
        if corners.min() < 0 or corners.max() >= V:
            raise ValueError(f"`corners` must be vertex indices in [0, {V - 1}], got {corners.tolist()}.")
        tagged_corner[corners] = True
    nsharp = np.bincount(edges[sharp].reshape(-1), minlength=V)
    vertex_type = np.full(V, SMOOTH, np.int8)
    vertex_type[nsharp == 2] = CREASE
    single = np.zeros(V, bool)
    if boundary_corners and boundary_vertex.any():  # a closed mesh needs no face counts
        single = boundary_vertex & (np.bincount(origin, minlength=V) == 1)
    corner = tagged_corner | (nsharp > 2) | single | (valence == 0)
    vertex_type[corner] = CORNER
    topo = dataclasses.replace(topo, vertex_type=vertex_type)

    # Interior bowties: the rotation around an interior vertex must be a single cycle.
    if validate and H:
        _, label = topo.rotation()
        interior = ~boundary_vertex[origin]
        cycles = np.bincount(origin[interior & (label == np.arange(H))], minlength=V)
        if np.any(cycles > 1):
            v = int(np.argmax(cycles > 1))
            raise ValueError(
                f"The mesh is not manifold at vertex {v}: its faces form {int(cycles[v])} "
                "separate fans that meet only at this vertex."
            )
    return topo
