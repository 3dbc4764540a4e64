import numpy as np

from ._base import AbstractSurfaceScheme, Level
from ._stencil import Sparse
from ._topology import Topology, pad_faces


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
    smaller copy of it (an *F-face*); each interior edge gets a quad joining the four
    new points next to it (an *E-face*); each interior vertex of valence $n$ gets an
    $n$-gon of the new points around it (a *V-face*). On a regular quad grid the limit
    is the biquadratic tensor-product B-spline ($C^1$).

    Boundaries: the same corner rule is used in boundary faces; no E-face is made for a
    boundary edge and no V-face for a boundary vertex. The refined surface therefore
    pulls in from the boundary polygon like an open Chaikin curve without end rule: it
    does not interpolate or follow the boundary curve. Creases and corners are not
    supported (a tagged mesh raises a `ValueError`), and there are no limit stencils.

    Refined vertex order: one vertex per face corner, in face order (face 0's corners,
    then face 1's, ...). Refined faces: F-faces, then E-faces, then V-faces.

    Reference: D. Doo and M. Sabin, "Behaviour of recursive division surfaces near
    extraordinary points", Computer-Aided Design 10 (1978) 356-360.
    """

    def level(self, topology: Topology, creases: np.ndarray, corners: np.ndarray) -> Level:
        topo = topology
        if len(creases) or len(corners):
            raise ValueError(
                "`DooSabin()` has no crease or corner rules; tagged creases and corners "
                "need `Loop()` or `CatmullClark()`."
            )
        rows, cols, weights = [], [], []
        for k in np.unique(topo.sizes):  # one vectorized pass per distinct face size
            first = topo.offsets[:-1][topo.sizes == k]
            corner = first[:, None] + np.arange(k)  # (F_k, k) half-edge = new vertex
            w = doo_sabin_weights(int(k))
            rows.append(np.broadcast_to(corner[:, :, None], (len(first), k, k)))
            cols.append(np.broadcast_to(topo.origin[corner][:, None, :], (len(first), k, k)))
            weights.append(np.broadcast_to(w, (len(first), k, k)))
        H = topo.num_half_edges
        stencil = Sparse.build(
            np.concatenate([r.reshape(-1) for r in rows]),
            np.concatenate([c.reshape(-1) for c in cols]),
            np.concatenate([w.reshape(-1) for w in weights]),
            (H, topo.num_vertices),
        )
        # F-faces: the face's own corners, in order.
        flat, sizes = [np.arange(H)], [topo.sizes]
        # E-faces: one quad per interior edge.
        h = topo.edge_half[~topo.boundary_edge]
        t = topo.twin[h]
        flat.append(np.stack([topo.next[h], h, topo.next[t], t], 1).reshape(-1))
        sizes.append(np.full(len(h), 4))
        # V-faces: the corners around each interior vertex, in ring order.
        order, start = topo.ring()
        counts = np.diff(start)
        flat.append(order)
        sizes.append(counts[counts > 0])
        faces = pad_faces(np.concatenate(flat), np.concatenate(sizes))
        empty = np.zeros((0,), np.int64)
        return Level(stencil, faces, np.zeros((0, 2), np.int64), empty)
