from typing import ClassVar

import numpy as np

from ._base import AbstractSurfaceScheme, Counts, Level
from ._stencil import Sparse
from ._topology import CORNER, CREASE, Topology, pad_faces


def doo_sabin_weights(k: int) -> np.ndarray:
    r"""`W[i, j]`: weight of face vertex $j$ in the new point of corner $i$ of a $k$-gon.

    $\alpha_{ii} = \frac{k + 5}{4k}$ and $\alpha_{ij} = \frac{3 + 2\cos(2\pi(i - j)/k)}{4k}$
    (Doo and Sabin 1978). For $k = 4$ these are the biquadratic B-spline weights
    $(9, 3, 1, 3)/16$.
    """
    i = np.arange(k)
    w = (3 + 2 * np.cos(2 * np.pi * (i[:, None] - i[None, :]) / k)) / (4 * k)
    w[i, i] = (k + 5) / (4 * k)
    return w


class DooSabin(AbstractSurfaceScheme):
    r"""Doo-Sabin subdivision (1978): the dual scheme, Chaikin's surface generalization.

    Every corner $i$ of every $k$-gon gets a new vertex
    $\sum_j \alpha_{ij} v_j$ with $\alpha_{ii} = \frac{k+5}{4k}$,
    $\alpha_{ij} = \frac{3 + 2\cos(2\pi(i-j)/k)}{4k}$. The new points of a face form a
    smaller copy of it (an *F-face*); each smooth edge gets a quad joining the four
    new points next to it (an *E-face*); each smooth vertex of valence $n$ gets an
    $n$-gon of the new points around it (a *V-face*). On a regular quad grid the limit
    is the biquadratic tensor-product B-spline ($C^1$).

    Boundaries and tagged creases (sharp edges) follow Chaikin's curve: every sharp
    edge $(a, b)$ gets the two new vertices $\frac34 a + \frac14 b$ and
    $\frac14 a + \frac34 b$, shared by the faces on both sides, and each face side of
    it an E-face quad made of those two points and the face's two corner points on
    the edge. Around a vertex on sharp edges, each fan of faces between two sharp
    edges (a *sector*) gets its own V-face: the Chaikin point of the first sharp edge,
    the sector's corner points, the Chaikin point of the last sharp edge. A *corner*
    (tagged, a boundary vertex in a single face, or a vertex on three or more sharp
    edges) is kept as a vertex of each of its V-faces, between the two Chaikin points.
    So the refined boundary and creases are exactly the refined Chaikin polygons
    (clamped at corners), and on a regular quad grid with corners the result is the
    tensor product of the clamped Chaikin curve rule in both directions (a boundary
    row acts as a doubled control row, the dual analog of the clamped end of
    [`jaxsubdiv.Chaikin`][]). This is Nasri's (1987) boundary construction in
    quad form; the interior corner rule is used unchanged in every face.

    A tagged corner must lie on two or more sharp edges (a dual scheme has no vertex
    point to keep elsewhere); other tagged corners raise a `ValueError`. A vertex on
    one crease (a *dart*) gets one V-face that starts and ends at the crease's
    Chaikin point. No limit stencils.

    A smooth vertex of valence 2 gets no V-face (it would be a 2-gon whose two sides
    are one edge); the E-faces of its two edges meet along that edge instead. A vertex
    in no face is kept as it is, as Loop and Catmull-Clark keep it.

    Refined vertex order: one vertex per face corner, in face order (face 0's corners,
    then face 1's, ...); then two per sharp edge, in the edge order of `Mesh.edges`
    (the point near the smaller vertex index first); then one per kept corner or
    vertex in no face, in vertex order. Refined faces: F-faces, smooth E-faces, sharp
    E-faces, V-faces of smooth vertices, sector V-faces.

    References: D. Doo and M. Sabin, "Behaviour of recursive division surfaces near
    extraordinary points", Computer-Aided Design 10 (1978) 356-360; A. H. Nasri,
    "Polyhedral subdivision methods for free-form surfaces", ACM Transactions on
    Graphics 6 (1987) 29-73.
    """

    bytes_per_half_edge: ClassVar[int] = 200  # measured 130-230

    def refined_counts(self, c: Counts) -> Counts:
        # A vertex per face corner, two per sharp edge, one per kept corner; F-faces,
        # E-faces (one per smooth edge, one per face side of a sharp edge) and V-faces
        # (one per smooth vertex, one per sector). Half-edges: 4H, plus at most 8 per
        # sharp edge and one per sharp-edge end at a corner; sharp edges: two halves
        # each, plus one per end at a corner. Exact on closed meshes without tags,
        # upper estimates where boundaries, creases, corners, smooth vertices of valence
        # 2 (no V-face) and vertices in no face (kept, no faces) enter.
        half_edges = 4 * c.half_edges + 8 * c.sharp + c.corner_ends
        sharp = 2 * c.sharp + c.corner_ends
        return Counts(
            c.half_edges + 2 * c.sharp + c.corner_ends + c.isolated, (half_edges + sharp) // 2,
            c.faces + c.edges + c.vertices + 2 * c.sharp + c.corner_ends, half_edges, sharp,
            c.corner_ends, c.isolated,
        )  # fmt: skip

    def level(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> Level:
        topo = topology
        V, E, H = topo.num_vertices, topo.num_edges, topo.num_half_edges
        nsharp = topo.num_sharp()
        isolated = topo.valence == 0  # in no face: kept as it is, like Loop and CC keep it
        bad = np.zeros(V, bool)
        bad[np.asarray(corners, np.int64)] = True
        bad &= (nsharp < 2) & ~isolated
        if np.any(bad):
            v = int(np.argmax(bad))
            raise ValueError(
                f"`corners`: vertex {v} is on {int(nsharp[v])} sharp (boundary or crease) "
                "edges; `DooSabin()` keeps a corner only where two or more sharp edges "
                "meet (a dual scheme has no vertex point elsewhere). Tag creases through "
                "it, or use `Loop()` or `CatmullClark()`."
            )
        kept = ((topo.vertex_type == CORNER) & (nsharp >= 2)) | isolated
        sharp = np.flatnonzero(topo.sharp_edge)
        S = len(sharp)
        sharp_rank = np.full(E, -1, np.int64)
        sharp_rank[sharp] = np.arange(S)
        kept_ids = np.flatnonzero(kept)
        kept_new = np.full(V, -1, np.int64)
        kept_new[kept_ids] = H + 2 * S + np.arange(len(kept_ids))

        def chaikin_point(e, v):  # new vertex of sharp edge e next to its end v
            return H + 2 * sharp_rank[e] + (topo.edges[e, 1] == v)

        # Stencil: corner points, Chaikin points, kept corners.
        rows, cols, weights = [], [], []
        for k in np.unique(topo.sizes):  # one vectorized pass per distinct face size
            first = topo.offsets[:-1][topo.sizes == k]
            corner = first[:, None] + np.arange(k)  # (F_k, k) half-edge = new vertex
            w = doo_sabin_weights(int(k))
            rows.append(np.broadcast_to(corner[:, :, None], (len(first), k, k)))
            cols.append(np.broadcast_to(topo.origin[corner][:, None, :], (len(first), k, k)))
            weights.append(np.broadcast_to(w, (len(first), k, k)))
        a, b = topo.edges[sharp, 0], topo.edges[sharp, 1]
        near_a, near_b = H + 2 * np.arange(S), H + 2 * np.arange(S) + 1
        rows += [near_a, near_a, near_b, near_b, kept_new[kept_ids]]
        cols += [a, b, a, b, kept_ids]
        weights += [np.full(S, 3 / 4), np.full(S, 1 / 4), np.full(S, 1 / 4), np.full(S, 3 / 4),
                    np.ones(len(kept_ids))]  # fmt: skip
        stencil = Sparse.build(
            np.concatenate([np.reshape(r, -1) for r in rows]),
            np.concatenate([np.reshape(c, -1) for c in cols]),
            np.concatenate([np.reshape(w, -1) for w in weights]),
            (H + 2 * S + len(kept_ids), V),
        )

        # F-faces: the face's own corners, in order.
        flat, sizes = [np.arange(H)], [topo.sizes]
        # Smooth E-faces: one quad per smooth edge.
        h = topo.edge_half[~topo.sharp_edge]
        t = topo.twin[h]
        flat.append(np.stack([topo.next[h], h, topo.next[t], t], 1).reshape(-1))
        sizes.append(np.full(len(h), 4))
        # Sharp E-faces: one quad per face side of a sharp edge, closed by the edge's
        # two Chaikin points.
        h = np.flatnonzero(topo.sharp_edge[topo.edge])
        e, nh = topo.edge[h], topo.next[h]
        quads = [nh, h, chaikin_point(e, topo.origin[h]), chaikin_point(e, topo.origin[nh])]
        flat.append(np.stack(quads, 1).reshape(-1))
        sizes.append(np.full(len(h), 4))
        # V-faces of vertices on no sharp edge: the corners around them, in ring order.
        # A vertex of valence 2 would get a 2-gon, whose two sides are one edge: it is
        # left out, and the two E-faces of its edges meet along that edge instead.
        order, start = topo.ring()
        counts = np.diff(start)
        polygon = (counts > 2) & (nsharp == 0)
        flat.append(order[polygon[topo.origin[order]]])
        sizes.append(counts[polygon])
        # Sector V-faces: [first Chaikin point, corners, last Chaikin point, kept vertex].
        order, start = topo.sectors()
        counts = np.diff(start)
        sector = np.repeat(np.arange(len(counts)), counts)
        first, last = order[start[:-1]], order[start[1:] - 1]
        v = topo.origin[first]
        e1, e2 = topo.edge[first], topo.edge[topo.prev[last]]
        closes = e2 != e1  # a dart's sector starts and ends at the same point
        ids = np.arange(len(counts))
        big = int(counts.max(initial=0))
        parts = [  # (sector, sort key, new vertex)
            (ids, np.full(len(ids), -1), chaikin_point(e1, v)),
            (sector, np.arange(len(order)) - start[sector], order),
            (ids[closes], np.full(closes.sum(), big), chaikin_point(e2, v)[closes]),
            (ids[kept[v]], np.full(kept[v].sum(), big + 1), kept_new[v[kept[v]]]),
        ]
        sec, key, vert = (np.concatenate([p[i] for p in parts]) for i in range(3))
        flat.append(vert[np.lexsort((key, sec))])
        sizes.append(counts + 1 + closes + kept[v])
        faces = pad_faces(np.concatenate(flat), np.concatenate(sizes))

        # Tags of the refined mesh: each crease edge's Chaikin edge, the edge joining a
        # (non-corner) crease vertex's two Chaikin points, and the edges from a kept
        # corner to the Chaikin points of its creases.
        crease = np.flatnonzero(topo.sharp_edge & ~topo.boundary_edge)
        ca, cb = chaikin_point(crease, topo.edges[crease, 0]), chaikin_point(crease, topo.edges[crease, 1])
        end_e = np.concatenate([crease, crease])
        end_v = np.concatenate([topo.edges[crease, 0], topo.edges[crease, 1]])
        pairs = [np.stack([ca, cb], 1)]
        at = np.flatnonzero((topo.vertex_type[end_v] == CREASE) & ~topo.boundary_vertex[end_v])
        at = at[np.argsort(end_v[at], kind="stable")]  # two crease edges per vertex
        pairs.append(chaikin_point(end_e[at], end_v[at]).reshape(-1, 2))
        at = np.flatnonzero(kept[end_v])
        pairs.append(np.stack([chaikin_point(end_e[at], end_v[at]), kept_new[end_v[at]]], 1))
        new_creases = np.sort(np.concatenate(pairs), axis=1)
        return Level(stencil, faces, new_creases, kept_new[kept_ids])
