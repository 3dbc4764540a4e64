"""The fitted curve as a fine polyline of exact limit points, and projection onto it.

The fit measures distances to the *limit* curve. It evaluates the curve at the dyadic
parameters of `levels` levels: refine `levels` times, then push every refined point to
its limit position with the scheme's limit stencil (exact, and differentiable in the
points and the scheme's parameters). Between those points the curve is replaced by its
chords, whose distance to the curve is about h^2 kappa / 8 for spacing h and curvature
kappa; `levels` is chosen so that this is far below the data's own error.
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

import jaxsubdiv as js
from jaxsubdiv._analysis.limit import limit_points


def curve_polyline(
    control: Float[Array, "*batch n d"], scheme, levels: int, boundary: str
) -> Float[Array, "*batch N d"]:
    """Points of the limit curve at the dyadic parameters of `levels` levels."""
    refined = js.refine(control, scheme, levels, boundary=boundary)
    return limit_points(refined, scheme, boundary=boundary)


def _segment_ends(curve, closed):
    nxt = jnp.roll(curve, -1, axis=0) if closed else curve[1:]
    return (curve if closed else curve[:-1]), nxt


def project(
    points: Float[Array, "m d"], curve: Float[Array, "N d"], closed: bool, coarse: int
) -> tuple[Int[Array, " m"], Float[Array, " m"]]:
    """Nearest point of the polyline `curve` to each of `points`: (segment, fraction).

    Coarse to fine: the nearest of every `coarse`-th vertex first, then exact projection
    onto the segments within `coarse` vertices of it either way. Exact for curves whose
    vertices are at most ~`coarse` segments away from the nearest coarse vertex, which
    holds for refined curves sampled densely enough. Not differentiated (the fit treats
    the foot points as fixed, see `foot_residual`).
    """
    points, curve = jax.lax.stop_gradient((points, curve))
    N = curve.shape[0]
    segments = N if closed else N - 1
    coarse = max(1, min(coarse, segments // 4 or 1))
    anchors = curve[::coarse]
    # argmin |p - a|^2 = argmin (|a|^2 - 2 p.a): one matrix product instead of an
    # (m, anchors, d) difference array (measured 2.6x faster for the anchor search).
    nearest = jnp.argmin(jnp.sum(anchors**2, -1)[None, :] - 2 * points @ anchors.T, axis=1)
    offsets = jnp.arange(-coarse - 1, coarse + 1)
    window = nearest[:, None] * coarse + offsets[None, :]  # (m, w) segment indices
    window = window % segments if closed else jnp.clip(window, 0, segments - 1)
    a, b = _segment_ends(curve, closed)
    A, B = a[window], b[window]  # (m, w, d)
    AB = B - A
    length2 = jnp.sum(AB**2, -1)
    safe = jnp.where(length2 > 0, length2, 1.0)
    u = jnp.clip(jnp.sum((points[:, None, :] - A) * AB, -1) / safe, 0.0, 1.0)
    u = jnp.where(length2 > 0, u, 0.0)
    foot = A + u[..., None] * AB
    best = jnp.argmin(jnp.sum((points[:, None, :] - foot) ** 2, -1), axis=1)
    pick = lambda x: jnp.take_along_axis(x, best[:, None], axis=1)[:, 0]
    return pick(window), pick(u)


def foot_residual(
    points: Float[Array, "m d"],
    curve: Float[Array, "N d"],
    segment: Int[Array, " m"],
    fraction: Float[Array, " m"],
    closed: bool,
) -> Float[Array, "m d"]:
    """Distance vector from the polyline `curve` to each point, given its foot point.

    For a foot point inside a segment, the vector from the line through that segment
    (exactly the distance vector, and differentiable in the segment's ends, so its
    Jacobian includes the segment turning: tangent-distance minimisation, see W. Wang,
    H. Pottmann, Y. Liu, "Fitting B-spline curves to point clouds by curvature-based
    squared distance minimization", ACM TOG 25 (2006)); at a segment end, the vector
    from that vertex. The choice of segment is not differentiated.
    """
    N = curve.shape[0]
    a = curve[segment]
    b = curve[(segment + 1) % N] if closed else curve[jnp.minimum(segment + 1, N - 1)]
    u = jax.lax.stop_gradient(fraction)
    ab = b - a
    ap = points - a
    length2 = jnp.sum(ab**2, -1)
    interior = (u > 0) & (u < 1) & (jax.lax.stop_gradient(length2) > 0)
    safe = jnp.where(interior, length2, 1.0)  # no division by zero, even in gradients
    line = ap - ab * (jnp.sum(ab * ap, -1) / safe)[:, None]
    vertex = points - jnp.where((u >= 1)[:, None], b, a)
    return jnp.where(interior[:, None], line, vertex)


def distances(
    points: Float[Array, "m d"], curve: Float[Array, "N d"], closed: bool, chunk: int = 256
) -> Float[Array, " m"]:
    """Exact distance from each point to the polyline `curve` (all segments checked).

    Chunks of `chunk` points at a time bound the memory to chunk x N x d.
    """
    a, b = _segment_ends(curve, closed)
    ab = b - a
    length2 = jnp.sum(ab**2, -1)
    safe = jnp.where(length2 > 0, length2, 1.0)

    def block(p):
        ap = p[:, None, :] - a[None]
        u = jnp.clip(jnp.sum(ap * ab, -1) / safe, 0.0, 1.0)
        gap = ap - u[..., None] * ab
        return jnp.sqrt(jnp.min(jnp.sum(gap**2, -1), axis=1))

    m = points.shape[0]
    pad = -m % chunk
    padded = jnp.concatenate([points, jnp.repeat(points[-1:], pad, axis=0)])
    out = jax.lax.map(block, padded.reshape(-1, chunk, points.shape[-1]))
    return out.reshape(-1)[:m]
