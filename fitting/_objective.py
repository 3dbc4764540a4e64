"""The fit's least-squares objective: residuals, foot points and their linearization.

Unknowns `y = {"control": P (n, d), "params": unconstrained scheme parameters}` (with
pinned ends, all control points but two, from which `Objective.control` makes P); the
problem data `args`, a [`FitData`][], all in units of the outline's size. Three groups of
residuals:

- target to curve: each sample's distance vector to the curve at its foot point, measured
  from the curve's tangent line there (tangent-distance minimization: W. Wang,
  H. Pottmann, Y. Liu, "Fitting B-spline curves to point clouds by curvature-based
  squared distance minimization", ACM TOG 25 (2006)), so the correspondence slides along
  the curve instead of being frozen;
- curve to target: every `stride`-th curve sample's distance to the polyline through the
  samples, at weight `BACK_WEIGHT`, so no part of the curve wanders off the data;
- smoothing: second differences of the control points (zero rows at `smoothing=0`; always
  present, so that every value of `smoothing` runs the same compiled program).

The curve is the limit curve sampled exactly at the dyadic parameters of `levels` levels
and, for $C^1$ schemes, interpolated between samples by cubic Hermite segments with the
exact limit tangents (see `_curve.evaluate`): its distance function is then smooth, and
Gauss-Newton-type steps converge fast and to a well-defined optimum. Other schemes (e.g.
corner cutting, which is only $C^0$ for most (r, s)) use the chords between samples.
"""

from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, ArrayLike, Float, Int

from jaxsubdiv import AbstractCurveScheme

from ._curve import (
    Band,
    _newton,
    _segment,
    _window_project,
    all_distances,
    band_basis,
    band_rows,
    chord_band,
    creased_tables,
    curve_tables,
    distances,
    evaluate,
    foot_residual,
    kinks,
    locate,
    nearest_on_curve,
    project,
    safe_norm,
    safe_sqrt,
    stencil_rows,
    tangents_of,
    track,
)
from ._init import second_differences
from ._params import from_unconstrained


#: Weight of the curve-to-target distances (beyond their chord band, `_band`) relative
#: to the target-to-curve ones.
BACK_WEIGHT = 0.1


#: Points of the curve by which `curve_errors` refines its maximum distance to the
#: target near the largest found at the curve samples and midpoints.
REFINE_MAX = 64


def end_samples(weights):
    """Indices of the first and last samples of non-zero weight (an open curve's ends)."""
    index = jnp.arange(weights.shape[0])
    valid = weights > 0
    return jnp.min(jnp.where(valid, index, index.size)), jnp.max(jnp.where(valid, index, -1))


class FitData(eqx.Module):
    """The data of one fit: arrays, traced (new values reuse the compiled program).

    - `target`: `(m, d)` samples (in units of the outline's size inside the solve); the
      first `count` are the outline, the rest padding (copies of the last sample,
      weight 0) up to the program's sample-count bucket.
    - `weights`: `(m,)`, zero for ignored samples and the padding.
    - `scheme`: the scheme at its starting parameters.
    - `root_smoothing`: the square root of the smoothing weight (the residual rows are
      linear in it, so derivatives with respect to everything else stay finite at zero
      smoothing; the derivative with respect to `smoothing` itself is infinite there,
      as the square root's).
    - `basis`: `Objective.basis_of(scheme)` when no scheme parameter is fitted
      (computed once, outside the solver loop), else None.
    - `count`: the number of samples before padding (None: no padding).
    - `corners`: `(m,)` flags of the samples at corners of a closed outline (a creased
      fit, `Objective.corners`), else None.
    - `creases`: `(n,)` flags of the creased control points, set from `corners` by
      `_core.set_up` (`_init.corner_creases`), else None.
    - `phase`: a closed curve's start shifted by this many spans along the samples
      (`_init.initial_control`'s `offset`), or None (0): `_core.run_phases` fits the
      phases of `fit(phases=K)` one by one through it, in one program for any K and
      phase. (Not set for one phase: a program with it rounds differently, and `fit`
      and `fit_batch` of one phase agree to 1e-8, tested.)
    """

    target: Float[Array, "m d"]
    weights: Float[Array, " m"]
    scheme: AbstractCurveScheme
    root_smoothing: Float[ArrayLike, ""]
    basis: Any = None
    count: Int[ArrayLike, ""] | None = None
    corners: Any = None
    creases: Any = None
    phase: Any = None


class TwoSidedErrors(eqx.Module):
    """RMS and largest distances of a fit in each direction (`curve_errors`)."""

    rms_target_to_curve: Float[Array, ""]
    max_target_to_curve: Float[Array, ""]
    rms_curve_to_target: Float[Array, ""]
    max_curve_to_target: Float[Array, ""]


def target_distances(X, VX, target, weights, previous=None, *, closed: bool
                     ) -> Float[Array, " m"]:
    """Each sample's distance to the curve at its global nearest point, 0 for samples
    of weight zero: the target-to-curve half of `curve_errors` (see there)."""
    if VX is not None:
        tau = nearest_on_curve(target, X, VX, closed, previous=previous)
        point, _ = evaluate(X, VX, tau, closed)
        to_curve = safe_norm(point - target)
    else:
        to_curve = distances(target, X, closed)
    return jnp.where(weights > 0, to_curve, 0.0)


def root_mean_square(distances: Float[Array, " m"], weights: Float[Array, " m"]
                     ) -> Float[Array, ""]:
    """The RMS of `distances` over the samples of non-zero weight, each counted once
    (the reported RMS of `curve_errors`' target-to-curve half)."""
    valid = weights > 0
    share = (valid / jnp.sum(valid)).astype(distances.dtype)
    return safe_sqrt(share @ distances**2)


def curve_errors(
    X: Float[Array, "N d"],
    VX: Float[Array, "N d"] | None,
    target: Float[Array, "m d"],
    weights: Float[Array, " m"],
    count: Int[ArrayLike, ""] | None,
    previous: Float[Array, " m"] | None = None,
    *,
    closed: bool,
) -> TwoSidedErrors:
    r"""The two-sided distances between the curve through the samples `X` (with tangents
    `VX`: the Hermite model, else chords) and the `target` samples (the first `count`
    the outline, weights zero for ignored ones), in their units.

    A function of the curve alone, not of the scheme or the fit's settings, so that
    `fitting.fit` runs it as a program of its own that fits of other schemes, control
    point counts and settings with the same shapes share (`_core.measure_one`).

    - Target to curve: each sample's distance to the curve (the Hermite curve of
      `_curve.evaluate` for $C^1$ schemes, else the chords between the curve
      samples) at its global nearest point: certified on the chords
      (`_curve.nearest_on_polyline`), refined by Newton's method on the Hermite curve
      (`_curve.nearest_on_curve`: never below the true distance, and above it by at
      most twice the curve's largest deviation from its chords). RMS over the samples
      with non-zero weight (each counted once, whatever its weight).
    - Curve to target: the distance of each point of the curve to the polyline
      through the first `count` samples, averaged by *arc length* along the
      curve (Simpson's rule on each segment between curve samples, from its ends
      and its midpoint, with the segment's chord as its length: not by parameter,
      which weighs the curve where its samples crowd, at corners, more), and its
      maximum over the curve samples and those midpoints, refined near the largest
      by `REFINE_MAX` more points of the curve (a peak elsewhere, up to a quarter
      segment above its sampled neighbours, can be missed: measured at most 2%).

    Differentiated with the nearest points held (the distance is stationary in them),
    with a zero derivative for a sample exactly on the curve.

    `previous`: the feet a solver tracked on a closed Hermite curve (curve positions
    of the samples), if any: each sample keeps the nearer of its tracked foot and the
    global nearest point (a tracked foot can sit on a branch of the curve that is no
    longer nearest).
    """
    num_curve = X.shape[0]
    to_curve = target_distances(X, VX, target, weights, previous, closed=closed)
    # The curve's segments: ends, midpoints (on the Hermite curve or the chord) and
    # chord lengths, for Simpson's rule in arc length.
    segments = num_curve if closed else num_curve - 1
    middle = jnp.arange(segments, dtype=target.dtype) + 0.5
    (midpoint,) = evaluate(X, VX, middle, closed, order=0)
    ends = jnp.roll(X, -1, axis=0) if closed else X[1:]
    length = safe_norm(ends - X[:segments])
    to_target = distances(jnp.concatenate([X, midpoint]), target, closed, count=count)
    at_vertex, at_middle = to_target[:num_curve] ** 2, to_target[num_curve:] ** 2
    after = jnp.roll(at_vertex, -1) if closed else at_vertex[1:]
    integral = length @ (at_vertex[:segments] + 4 * at_middle + after) / 6
    total = jnp.sum(length)
    # A curve of zero length (all control points equal) has no arc length to
    # average over: then every point is the same point.
    mean_square = jnp.where(total > 0, integral / jnp.where(total > 0, total, 1.0),
                            at_vertex[0])
    # The maximum: refined around the largest of those values, where the distance
    # (1-Lipschitz along the curve) peaks between samples (at a kink of the target,
    # typically), by `REFINE_MAX` more points of the curve within half a segment of
    # it either way, measured to every chord of the target (few points: no search;
    # the padding's chords have length zero at the last sample). A peak elsewhere,
    # up to a quarter segment above its sampled neighbours, can still be missed.
    dtype = target.dtype
    largest = jnp.argmax(to_target)
    centre = jnp.where(largest < num_curve, largest.astype(dtype),
                       (largest - num_curve).astype(dtype) + 0.5)
    around = centre + jnp.linspace(-0.5, 0.5, REFINE_MAX, dtype=dtype)
    if not closed:
        around = jnp.clip(around, 0.0, num_curve - 1.0)
    (near_peak,) = evaluate(X, VX, around, closed, order=0)
    segment, fraction = all_distances(*jax.lax.stop_gradient((near_peak, target)),
                                      closed, chunk=REFINE_MAX)
    peak = jnp.max(safe_norm(foot_residual(near_peak, target, segment, fraction, closed)))
    return TwoSidedErrors(
        rms_target_to_curve=root_mean_square(to_curve, weights),
        max_target_to_curve=jnp.max(to_curve),
        rms_curve_to_target=safe_sqrt(mean_square),
        max_curve_to_target=jnp.maximum(jnp.max(to_target), peak),
    )


class Objective(eqx.Module):
    """The residuals of one fit, and its curve: the static settings, built on the host.

    Every field is static (hashable), so the objective is passed to the compiled fit as
    one static argument: equal settings select the same compiled program, and the data,
    tolerances and smoothing come in as traced arrays (`FitData`).
    """

    n: int = eqx.field(static=True)
    levels: int = eqx.field(static=True)
    boundary: str = eqx.field(static=True)
    names: tuple[str, ...] = eqx.field(static=True)
    hermite: bool = eqx.field(static=True)
    num_curve: int = eqx.field(static=True)  # curve samples N
    num_target: int = eqx.field(static=True)  # target samples m (including padding)
    # Values per fitted parameter held fixed before the joint fit (`_core.profile_start`).
    profile: int = eqx.field(static=True, default=0)
    # Open and clamped curves with pinned ends (`control`): the two control points
    # solved from the end constraints, else (). Chosen on the host (`end_pivots`).
    pivots: tuple[int, ...] = eqx.field(static=True, default=())
    # Closed curves with corners: creased control points (`FitData.creases`).
    corners: bool = eqx.field(static=True, default=False)
    # Closed curves without corners, fitted parameters, `init` or another solver: the
    # phases of the start tried (`_core.phase_solve`, or one by one in `_core.run_phases`);
    # 1 for the linear start alone.
    phases: int = eqx.field(static=True, default=1)

    @property
    def closed(self) -> bool:
        return self.boundary == "closed"

    @property
    def held(self) -> np.ndarray:
        """Indices of the curve samples held to the target: every `stride`-th, and for
        open curves also the last (the end, which is pinned to the last sample)."""
        stride = max(1, self.num_curve // (4 * self.n))
        index = np.arange(0, self.num_curve, stride)
        if not self.closed and index[-1] != self.num_curve - 1:
            index = np.append(index, self.num_curve - 1)
        return index

    def basis_of(self, scheme, dtype, creases=None):
        """The curve's stencil tables for `scheme` (samples, and tangents or None), and
        the same by segments (`_curve.Band`) for the Hessian's assembly
        (`_curve.curve_tables`; with `creases`, a mask of the creased control points, the
        creased closed curve's, `_curve.creased_tables`, whose tangents are a pair: from
        after and from before each sample). The tables, not dense `(N, n)` matrices: the
        curve is `table.apply(P)`, O(N width) (the dense product was 2.5 of the 18 ms of
        a step on a traced 1024-px glyph, N = 32,768, n = 64)."""
        if self.corners:
            position, tangents = creased_tables(scheme, self.n, self.levels, creases, dtype,
                                                self.hermite)
            return position, tangents, band_basis(position, *(tangents or (None,)))
        tables = curve_tables(scheme, self.n, self.levels, self.boundary, dtype, self.hermite)
        return *tables, band_basis(*tables)

    def basis(self, y, args):
        """The scheme at `y`'s parameters and its basis (`basis_of`)."""
        target, base, fixed = args.target, args.scheme, args.basis
        if fixed is not None:
            return base, *fixed
        scheme = from_unconstrained(base, self.names, y["params"])
        return scheme, *self.basis_of(scheme, target.dtype, args.creases)

    @property
    def free(self) -> np.ndarray:
        """Indices of the control points that are unknowns of the solve: all of them,
        or all but the two `pivots` when the ends are pinned."""
        return np.setdiff1d(np.arange(self.n), np.asarray(self.pivots, int))

    def unknowns(self, P):
        """The solve's unknown control points (`free`) of a full polygon `P`."""
        return P[self.free] if self.pivots else P

    def pin_map(self, args, A):
        r"""The full control polygon as an affine map of the unknowns, `P = M Q + b`.

        Without pinned ends, the identity. With them, the curve's first and last points
        (rows 0 and N - 1 of its basis `A`, `C P = s`) must equal the first and last
        samples of non-zero weight `s`: the two `pivots` are solved from those two
        equations, $P_p = C_p^{-1} (s - C_F Q)$ for the free points $F$. An exact
        constraint, not a penalty, and linear in the control points, so the model's
        Hessian in `Q` is $T^T H T$ with $T = M \otimes I_d$ (`quadratic_model`).
        Differentiable in the samples (the ends move with the first and last) and in the
        scheme's parameters (through `A`).
        """
        if not self.pivots:
            return None
        target = args.target
        ends = target[jnp.stack(end_samples(args.weights))]  # (2, d)
        pivots, free = np.asarray(self.pivots), self.free
        C = stencil_rows(A, np.array([0, len(A) - 1]))  # (2, n): the curve's end points
        solved = jnp.linalg.solve(C[:, pivots], jnp.concatenate([C[:, free], ends], 1))
        M = jnp.zeros((self.n, free.size), C.dtype).at[free, np.arange(free.size)].set(1.0)
        M = M.at[pivots].set(-solved[:, : free.size])
        b = jnp.zeros((self.n, target.shape[1]), C.dtype).at[pivots].set(solved[:, free.size:])
        return M, b

    def control(self, y, args, A):
        """The full control polygon `(n, d)` at `y` (`pin_map`), given the curve's table
        `A`."""
        if not self.pivots:
            return y["control"]
        M, b = self.pin_map(args, A)
        return M @ y["control"] + b

    def control_of(self, y, args):
        """`control` with the basis at `y`'s scheme parameters."""
        return self.control(y, args, self.basis(y, args)[1])

    def feet(self, y, args, previous=None):
        """Foot points: each sample's curve position and each held curve sample's
        (segment, fraction) on the target polyline. Not differentiated.

        With the `previous` feet (e.g. the last solver step's), each foot is searched near
        its previous position first (`_curve.track`), globally only where that fails."""
        target, weights = args.target, args.weights
        _, A, V, _ = self.basis(y, args)
        P = self.control(y, args, A)
        X = A.apply(P)
        # The corner samples' feet are replaced below: where the tracked search finds
        # them is no reason for a global search (they were, at every step, before).
        VX = tangents_of(V, P)
        tau = locate(target, X, VX, self.closed,
                     coarse=max(1, min(8, self.num_curve // 64)),
                     previous=None if previous is None else previous[0],
                     skip=(args.corners & (weights > 0)) if self.corners else None)
        held = X[self.held]
        coarse = max(1, min(8, self.num_target // 64))
        if previous is None:
            segment, fraction = project(held, target, self.closed, coarse, args.count)
        else:
            segment, fraction = track(held, target, self.closed, coarse, previous[1], radius=6,
                                      count=args.count)
        if not self.closed:
            tau, segment, fraction = self._pin_ends(weights, tau, segment, fraction)
        if self.corners:
            tau = jnp.where(args.corners & (weights > 0), self._corner_feet(args, X, VX), tau)
        return jax.lax.stop_gradient((tau, segment, fraction))

    def _corner_feet(self, args, X, VX=None):
        """Each sample's foot near the crease of its corner (used at corner samples): the
        nearest point of the curve's chords that lie within the sample's larger gap to
        its neighbours, along the curve, from the crease.

        Left to slide anywhere, as the other feet do (or within the two spans at the
        crease), a corner sample could go to another part of the curve, and its crease
        with it, in a poor local minimum (a traced glyph:
        `test_creases_stay_at_the_corners_of_a_traced_glyph`). Kept this close, it holds
        the crease at the corner without pinning the crease to the sample, which would
        cut a corner lying between samples (`test_sparse_samples_do_not_pull_the_corners_in`
        fails that way). The k-th corner sample has the k-th
        crease (`_init.corner_creases`); there are at most n corner samples, so the
        search is over n x 2 spans' chords. On the Hermite model (tangents `VX`) the
        foot found on the chords is then refined on the curve (`_curve.locate`'s Newton
        steps, which end at the crease when that is nearest).
        """
        target, dtype, N, n = args.target, X.dtype, self.num_curve, self.n
        m = target.shape[0]
        rows = N // n  # curve samples (chords) per span
        corners = args.corners & (args.weights > 0)
        which = jnp.flatnonzero(corners, size=n, fill_value=0)  # the corner samples
        crease = jnp.flatnonzero(args.creases, size=n, fill_value=0) * rows
        # The sample's neighbours along the outline (the padding after `count` skipped).
        count = m if args.count is None else args.count
        before = jnp.where(which == 0, count - 1, which - 1)
        after = jnp.where(which >= count - 1, 0, which + 1)
        reach = jnp.maximum(safe_norm(target[which] - target[before]),
                            safe_norm(target[after] - target[which]))
        # Chords starting at crease - rows, ..., crease + rows - 1, and how far along the
        # curve each one's nearer end is from the crease.
        first = crease[:, None] - rows + jnp.arange(2 * rows)[None, :]
        length = safe_norm(X[(first + 1) % N] - X[first % N])
        right = jnp.cumsum(length[:, rows:], axis=1) - length[:, rows:]
        left = jnp.flip(jnp.cumsum(jnp.flip(length[:, :rows], 1), axis=1), 1) - length[:, :rows]
        near = jnp.concatenate([left, right], axis=1) <= reach[:, None]
        # The nearest point among those chords (the out-of-reach ones replaced by the
        # crease's own chord), by the polyline projection the other feet use.
        window = jnp.where(near, first, crease[:, None])
        segment, fraction = _window_project(target[which], X, True, window)
        foot = segment + fraction
        if VX is not None:
            foot = _newton(target[which], X, VX, foot, True, 4, 1.0)
        # Back to one per sample (the padding rows of `which` dropped).
        valid = jnp.arange(n) < jnp.sum(corners)
        tau = jnp.zeros(m, dtype)
        return tau.at[jnp.where(valid, which, m)].set(jnp.mod(foot, N).astype(dtype),
                                                      mode="drop")

    def _pin_ends(self, weights, tau, segment, fraction):
        # An open curve must start and end where the data do: the first and last
        # (weighted) samples go to its end points, and its end points to them.
        index = jnp.arange(self.num_target)
        first, last = end_samples(weights)
        tau = jnp.where(index <= first, 0.0, jnp.where(index >= last, self.num_curve - 1.0, tau))
        held = jnp.arange(segment.shape[0])
        end = segment.shape[0] - 1
        segment = jnp.where(held == 0, first, jnp.where(held == end, last - 1, segment))
        fraction = jnp.where(held == 0, 0.0, jnp.where(held == end, 1.0, fraction))
        return tau, segment, fraction

    def residuals_at(self, y, args, feet):
        """The residual groups, starting from the foot points `feet` (smooth in `y`).

        Chords: the distance vector from each sample to the line through its segment
        (exactly its distance to the polyline, and differentiable). Hermite curve: the
        gap from the sample to its foot after one more (differentiated) Newton step
        from `feet`: at converged feet this leaves the value unchanged and gives the
        exact first derivative of the foot point, so the Hessian that implicit
        differentiation takes of this residual is the distance's own (feet held fixed,
        it would miss the curvature term).
        """
        target, weights = args.target, args.weights
        tau, segment, fraction = feet
        _, A, V, _ = self.basis(y, args)
        P = self.control(y, args, A)
        X = A.apply(P)
        VX = tangents_of(V, P)
        point, slope, bend = evaluate(X, VX, tau, self.closed, order=2)
        gap = point - target
        line, speed2 = self._line(tau, slope, kinks(V))
        safe = jnp.where(line, speed2, 1.0)  # no division by zero, even in gradients
        along = jnp.sum(gap * slope, -1)
        if self.hermite:
            kappa = jnp.maximum(speed2 + jnp.sum(gap * bend, -1), 0.5 * speed2)
            tau = tau - jnp.where(line, along / jnp.where(line, kappa, 1.0), 0.0)
            point, _ = evaluate(X, VX, tau, self.closed)
            e = point - target
        else:
            e = jnp.where(line[:, None], gap - slope * (along / safe)[:, None], gap)
        # Weights normalised to mean 1 over the valid samples: the loss is a sum (not a
        # mean) of squared distances, which keeps the Levenberg-Marquardt damping scale
        # independent of the sample count's effect on conditioning.
        valid_count = jnp.sum(weights > 0).astype(target.dtype)
        scaled = weights * (valid_count / jnp.sum(weights))
        # The root of the weight plus the smallest normal number, as for the smoothing
        # (`_core.traced_settings`): a finite derivative at zero weights (padding, or
        # samples switched off), where the root's own is infinite and made every
        # weight's implicit derivative NaN.
        e = e * jnp.sqrt(scaled + jnp.finfo(scaled.dtype).tiny)[:, None]
        held = X[self.held]
        back = foot_residual(held, target, segment, fraction, self.closed)
        band = self._band(target, segment, args.count, args.corners)
        square = jnp.sum(back**2, -1)
        beyond = square > band**2  # a double `where`: no 0/0 in the derivative at 0
        length = jnp.sqrt(jnp.where(beyond, square, 1.0))
        back = back * jnp.where(beyond, 1 - band / length, 0.0)[:, None]
        back = back * jnp.sqrt(BACK_WEIGHT * valid_count / held.shape[0])
        D = second_differences(self.n, self.closed, target.dtype, args.creases)
        return e, back, args.root_smoothing / np.sqrt(self.n) * (D @ P)

    def residuals(self, y, args):
        """Residuals with the foot points found at `y` (for optimistix's solvers and the
        implicit adjoint; see `residuals_at` for how the feet enter the derivatives)."""
        return self.residuals_at(y, args, self.feet(y, args))

    def curve(self, y, data: FitData) -> tuple[Array, Array | None]:
        """The curve's samples `(N, d)` at `y`, and its tangents there for the Hermite
        model (else None)."""
        _, A, V, _ = self.basis(y, data)
        P = self.control(y, data, A)
        return A.apply(P), tangents_of(V, P)

    def quadratic_model(self, y, args, feet=None):
        r"""Loss, half gradient and half Hessian of the loss at `y` (flattened in
        `ravel_pytree(y)` order): `loss(y + x) ~ loss + 2 g.x + x.H.x`.

        The loss is the sum of squared residuals at feet found at `y`. Its Hessian is the
        exact one of the squared distances to the curve (not Gauss-Newton's $J^T J$): each
        sample's position on the curve is a variable eliminated at its optimum (variable
        projection; the Schur complement of the lifted problem, cf. Wang, Pottmann and Liu
        2006 on squared-distance minimization). For sample `i` with foot point $C$,
        tangent $C'$, second derivative $C''$, gap $r = C - p$ and Jacobians $B$, $B'$ of
        $C$ and $C'$ with respect to the unknowns,

        $$H_i = B^T B - u u^T / \kappa, \quad u = B^T C' + B'^T r, \quad
        \kappa = |C'|^2 + r \cdot C''.$$

        Gauss-Newton's tangent-distance model drops the terms in $r$, and then leaves the
        points' sliding along the curve almost undamped: it converged only linearly on
        smooth outlines (measured: 100+ steps), this model in a handful. $\kappa$ is kept
        above $|C'|^2 / 2$ (a sample near its foot's center of curvature). The
        control-point blocks are assembled in closed form (the curve is linear in them).
        So are the scheme parameters' (`names`): the curve depends on them only through
        its tables, so their columns of $B$ and $B'$ are the derivatives of the tables'
        rows at the feet times the control points (forward mode through the tables
        alone, `_table_tangents`), with the mixed term $r \cdot \partial^2 C / \partial
        P \partial q$ (the curve is bilinear in rows and points) and without $r \cdot
        \partial^2 C / \partial q^2$ (Gauss-Newton in the parameters: with it, by
        nested forward mode, the one fit tried stopped at a higher loss, 1.02e-2
        against 8.3e-3). A step of the joint fit then costs a median 1.55x
        (1.1-3.6x) a step with the parameters fixed, where autodiff through the
        residuals cost 2.1x (1.3-3.9x); most of the rest is building the tables at the
        parameters' values every step (n = 16, 32; 2026-12-05,
        `benchmarks/results/fit_params_7b3f75b.md` and `fit_params_e1790a5.md`). With
        pinned ends the pin map depends on the parameters too, and `_parameter_blocks`
        (autodiff) assembles them.

        `feet` are the foot points to use (`feet(y, args)` when None).
        """
        if feet is None:
            feet = self.feet(y, args)
        target, weights = args.target, args.weights
        smoothing = args.root_smoothing**2
        tau, segment, fraction = feet
        _, A, V, banded = self.basis(y, args)
        P = self.control(y, args, A)
        m, d = target.shape
        n, dtype = self.n, target.dtype
        eye = jnp.eye(d, dtype=dtype)
        valid_count = jnp.sum(weights > 0).astype(dtype)
        w = weights * (valid_count / jnp.sum(weights))
        # Each row of the curve's basis at a foot point: the (m, width) entries on a
        # window of consecutive control points (`window`), from the stencil tables.
        window, rows, slope_rows, bend_rows = band_rows(banded, tau, n, self.closed,
                                                        self.hermite)
        held_tau = jnp.asarray(self.held, dtype)
        held_window, held_rows, _, _ = band_rows(banded, held_tau, n, self.closed,
                                                 self.hermite)
        at = lambda rows: jnp.einsum("mw,mwd->md", rows, P[window])
        held_at = lambda rows: jnp.einsum("kw,kwd->kd", rows, P[held_window])
        # Target to curve.
        gap = at(rows) - target
        slope, bend = at(slope_rows), at(bend_rows)
        line, speed2 = self._line(tau, slope, kinks(V))
        kappa = jnp.maximum(speed2 + jnp.sum(gap * bend, -1), 0.5 * speed2)
        inverse = jnp.where(line, w / jnp.where(line, kappa, 1.0), 0.0)
        # The loss at these feet: the squared gaps themselves (an upper bound of the
        # squared distances, equal to them at converged feet), so that loss and
        # gradient B^T gap describe the same function of P.
        loss = w @ jnp.sum(gap**2, -1)
        # u_i over (control j, coordinate c): b_ij C'_c + b'_ij r_c.
        U = (rows[:, :, None] * slope[:, None, :] + slope_rows[:, :, None] * gap[:, None, :])
        U = U.reshape(m, -1)
        # Curve to target: linear in P (the target's segments are fixed).
        nxt = (segment + 1) % m if self.closed else jnp.minimum(segment + 1, m - 1)
        direction = target[nxt] - target[segment]
        length2 = jnp.sum(direction**2, -1)
        inside = (fraction > 0) & (fraction < 1) & (length2 > 0)
        unit = direction / jnp.sqrt(jnp.where(inside, length2, 1.0))[:, None]
        normal = jnp.where(inside[:, None, None], eye - unit[:, :, None] * unit[:, None, :], eye)
        foot = target[segment] + fraction[:, None] * direction
        weight = BACK_WEIGHT * valid_count / held_rows.shape[0]
        back = jnp.einsum("kac,kc->ka", normal, held_at(held_rows) - foot)
        # Only the part beyond the chord's sagitta band counts (see `_band`): a scalar
        # residual `excess` along the unit direction of `back`.
        band = self._band(target, segment, args.count, args.corners)
        square = jnp.sum(back**2, -1)
        active = square > band**2
        length = jnp.sqrt(jnp.where(active, square, 1.0))
        excess = jnp.where(active, length - band, 0.0)
        direction = back / length[:, None]
        loss += weight * jnp.sum(excess**2)
        # held_kj direction_ka over (control j, coordinate a), for the Hessian's
        # sum_k held_kj held_kl direction_ka direction_kc
        spread = (held_rows[:, :, None] * jnp.where(active[:, None], direction, 0.0)[:, None, :])
        spread = spread.reshape(held_rows.shape[0], -1)
        # Each sample's (and held point's) contribution on its window, summed per
        # window start, then added into the dense matrix: O(m width^2) instead of
        # O(m n^2) (measured at n = 64: 0.36 ms against 1.03 ms for the dense sums). At
        # n = 8 and 16 a warm 40-step fit measured within the machine's noise of the old
        # dense path (3-14 ms either way, load ~9), so it is the only assembly.
        width = rows.shape[1]
        square_rows = (w[:, None, None] * rows[:, :, None] * rows[:, None, :])
        local = (square_rows[:, :, None, :, None] * eye[None, None, :, None, :])
        local = local.reshape(m, width * d, width * d)
        local -= inverse[:, None, None] * U[:, :, None] * U[:, None, :]
        held_local = weight * spread[:, :, None] * spread[:, None, :]
        local_gradient = (rows[:, :, None] * (w[:, None] * gap)[:, None, :]).reshape(m, -1)
        held_gradient = held_rows[:, :, None] * (excess[:, None] * direction)[:, None, :]
        held_gradient = weight * held_gradient.reshape(-1, width * d)
        starts = jnp.concatenate([window[:, 0], held_window[:, 0]])
        total = lambda x: jax.ops.segment_sum(x, starts, num_segments=n)
        blocks = total(jnp.concatenate([local, held_local]))
        block_gradients = total(jnp.concatenate([local_gradient, held_gradient]))
        # Flat indices of window s: control points s..s+width-1 (cyclically), each
        # with its d coordinates.
        index = (np.arange(n)[:, None] + np.arange(width)[None, :]) % n
        index = (index[:, :, None] * d + np.arange(d)).reshape(n, width * d)
        hessian = jnp.zeros((n * d, n * d), dtype)
        hessian = hessian.at[index[:, :, None], index[:, None, :]].add(blocks)
        gradient = jnp.zeros((n * d,), dtype).at[index].add(block_gradients)
        D = second_differences(n, self.closed, dtype, args.creases)
        loss += (smoothing / n) * jnp.sum((D @ P) ** 2)
        gradient += (smoothing / n) * (D.T @ (D @ P)).reshape(-1)
        hessian += (smoothing / n) * jnp.kron(D.T @ D, eye)
        if self.pivots:  # the chain rule through the linear pin map P = M Q + b
            T = jnp.kron(self.pin_map(args, A)[0], eye)
            gradient, hessian = T.T @ gradient, T.T @ hessian @ T
            if self.names:
                gradient, hessian = self._parameter_blocks(y, args, feet, hessian)
            return loss, gradient, hessian
        if self.names:
            # The parameters' columns, like the control points': the curve depends on
            # them only through its tables, so the derivatives of the tables' rows at
            # the feet (`_table_tangents`) take the place of the rows.
            drows, dslopes, dheld = self._table_tangents(y, args, banded, tau, held_tau)
            Cq = jnp.einsum("pmw,mwd->mpd", drows, P[window])  # dC/dq at each foot
            slope_q = jnp.einsum("pmw,mwd->mpd", dslopes, P[window])  # dC'/dq
            u_q = (jnp.einsum("mpd,md->mp", Cq, slope)
                   + jnp.einsum("mpd,md->mp", slope_q, gap))
            held_q = jnp.einsum("pkw,kwd->kpd", dheld, P[held_window])
            spread_q = jnp.einsum("kd,kpd->kp", jnp.where(active[:, None], direction, 0.0),
                                  held_q)
            # Cross blocks (control point j, coordinate c; parameter k) per window.
            local_cross = (w[:, None, None, None]
                           * (rows[:, :, None, None] * jnp.swapaxes(Cq, 1, 2)[:, None]
                              + jnp.moveaxis(drows, 0, -1)[:, :, None] * gap[:, None, :, None])
                           ).reshape(m, width * d, -1)
            local_cross -= inverse[:, None, None] * U[:, :, None] * u_q[:, None, :]
            held_cross = weight * spread[:, :, None] * spread_q[:, None, :]
            cross_blocks = total(jnp.concatenate([local_cross, held_cross]))
            cross = jnp.zeros((n * d, Cq.shape[1]), dtype).at[index].add(cross_blocks)
            corner = (jnp.einsum("m,mpd,mqd->pq", w, Cq, Cq)
                      - jnp.einsum("m,mp,mq->pq", inverse, u_q, u_q)
                      + weight * spread_q.T @ spread_q)
            gradient_q = (jnp.einsum("m,mpd,md->p", w, Cq, gap)
                          + weight * spread_q.T @ excess)
            gradient = jnp.concatenate([gradient, gradient_q])
            hessian = jnp.block([[hessian, cross], [cross.T, corner]])
        return loss, gradient, hessian

    def _table_tangents(self, y, args, banded, tau, held_tau):
        """Derivatives with respect to the (unconstrained, flattened) scheme parameters
        of the curve's rows at the feet `tau` (position and tangent) and at the held
        curve samples: each `(p, rows, width)`, by forward mode through the tables alone
        (p directions; `band_rows` is linear in the tables)."""
        flat_q, unravel_q = ravel_pytree(y["params"])

        def ends(q):
            scheme = from_unconstrained(args.scheme, self.names, unravel_q(q))
            return self.basis_of(scheme, args.target.dtype, args.creases)[-1].ends

        tangents = jnp.moveaxis(jax.jacfwd(ends)(flat_q), -1, 0)  # (p, N, 4, width)

        def rows_at(ends, at):
            table = Band(start=banded.start, ends=ends)
            return band_rows(table, at, self.n, self.closed, self.hermite)[1:3]

        drows, dslopes = jax.vmap(rows_at, in_axes=(0, None))(tangents, tau)
        dheld, _ = jax.vmap(rows_at, in_axes=(0, None))(tangents, held_tau)
        return drows, dslopes, dheld

    def _parameter_blocks(self, y, args, feet, hessian):
        """The gradient and Hessian with the scheme parameters' rows and columns, in
        Gauss-Newton form `J^T r`, `J^T J` of the residuals `r` (`residuals_at`), the
        control-point block kept exact (`hessian`). `ravel_pytree(y)` puts the control
        points first. Used with pinned ends (`pivots`), whose pin map also depends on
        the parameters; otherwise `quadratic_model` assembles them in closed form.

        The parameter columns `J_q` of the Jacobian come from forward-mode autodiff (one
        direction per parameter), and everything that multiplies the control-point
        columns `J_P` from one reverse-mode linearization (`J_P^T r`, `J_P^T J_q`):
        the full Jacobian by forward mode (n d + p directions, each refining the curve's
        tables again) made a step of the joint fit ~30x a step with the parameters
        fixed (measured at n = 32).
        """
        P = y["control"]
        flat_q, unravel_q = ravel_pytree(y["params"])

        def vector(P, q):
            at = {"control": P, "params": unravel_q(q)}
            return ravel_pytree(self.residuals_at(at, args, feet))[0]

        residual, pullback = jax.vjp(lambda P: vector(P, flat_q), P)
        J_q = jax.jacfwd(lambda q: vector(P, q))(flat_q)  # (residuals, p)
        back = lambda column: pullback(column)[0].reshape(-1)
        cross = jax.vmap(back, in_axes=1, out_axes=1)(J_q)  # J_P^T J_q: (n d, p)
        gradient = jnp.concatenate([back(residual), J_q.T @ residual])
        hessian = jnp.block([[hessian, cross], [cross.T, J_q.T @ J_q]])
        return gradient, hessian

    def _band(self, target, segment, count, corners=None):
        """Tolerance of the curve-to-target distances (`_curve.chord_band`).

        A smooth curve through the samples bulges from the chords between them;
        penalising that (as plain distances to the chords would) pulls the curve inwards
        and biased noise-free recovery to ~2e-5 of the size (measured). The band leaves
        those bulges free and still catches a curve that strays from the data. It is a
        function of the samples like any other part of the loss, and differentiated as
        one: held constant, it made implicit derivatives wrong wherever a held point lies
        beyond its band (measured: d(control points)/d(samples) of a cubic B-spline fit
        0.10 against -1.03 by finite differences).
        """
        band = chord_band(target, self.closed, count)
        if self.corners:
            # The outline's corner lies within a chord of its corner sample, which the
            # two chords there cut: a curve with the corner leaves them by up to about
            # their length, and penalising that pulled the corner in (a star sampled
            # 20 times per edge: its tips 0.35% of the size inside).
            M = target.shape[0]
            index = jnp.arange(M)
            last = M - 1 if count is None else count - 1
            start = jnp.where(index == M - 1, last, index)  # chord j: start -> end
            end = (index + 1) % M
            length = safe_norm(target[end] - target[start])
            band = jnp.where(corners[start] | corners[end], jnp.maximum(band, length), band)
        return band[segment]

    def _line(self, tau, slope, corner=None):
        """Which residuals are measured from the tangent line (else from a point), and the
        squared speed there. `corner`: a creased Hermite curve's corner samples
        (`_curve.kinks` of its tangent basis), where a foot is a point."""
        top = self.num_curve if self.closed else self.num_curve - 1
        frac = tau - jnp.floor(tau)
        if self.hermite:
            at_vertex = jnp.zeros_like(tau, bool) if self.closed else (tau <= 0) | (tau >= top)
            if corner is not None:
                at_vertex |= (frac == 0) & corner[_segment(tau, self.num_curve, True)[0]]
        else:  # a polyline's distance at a vertex is the distance to that vertex
            at_vertex = frac == 0 if self.closed else (frac == 0) | (tau >= top)
        speed2 = jnp.sum(slope**2, -1)
        return ~at_vertex & (jax.lax.stop_gradient(speed2) > 0), speed2
