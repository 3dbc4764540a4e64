"""[`fitting.fit_batch`][]: many outlines, over devices or threads, with one progress line.

Every item is checked on the host (`_checks.prepare`) and padded to one sample-count
bucket; the stacked batch is split into equal shares, one per device (`shard_map`) or,
on one CPU device, one per thread; each share runs one compiled program that fits its
items one after another (`lax.map` of `_core.fit_one`).
"""

import concurrent.futures
import hashlib
import os
import re
import warnings
from collections.abc import Sequence
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

import jaxsubdiv as js
from jaxsubdiv.validation import (
    DEFAULT_MEMORY_BUDGET,
    checked_budget,
    is_traced,
    static_int,
)

from . import _progress
from ._checks import (
    bucket,
    check_memory,
    check_on_failure,
    check_phases,
    check_tol,
    default_levels,
    default_tol,
    float_array,
    pad,
    prepare,
)
from ._core import fit_one, make_objective, traced_settings
from ._corners import corner_flags
from ._objective import FitData, Objective
from ._params import uses_tangents
from ._result import FitResult, FitStatus, report, status_code
from ._solver import make_solver
from ._threads import one_blas_thread


def _fit_items(targets, weights, counts, corners, steps, scheme, root_smoothing, tol, total,
               *, objective: Objective, solver, devices: int, progress: bool):
    """Fit `(k, m, d)` targets one after another (`lax.map`, a scan of single solves).

    One after another rather than `vmap` over the items: a batched solver loop runs every
    item until the slowest converges, and its batched gathers and factorizations ran
    slower per item on CPU; measured 1.9x slower than a Python loop of single fits (64
    items), where `lax.map` matches the loop with one dispatch for the whole batch.
    `corners`: each item's corner flags `(k, m)` with `objective.corners`, else None.
    `steps`: each item's step limit `(k,)`, or one static int for optimistix's solvers;
    `total`: the number of real items in this call's batch (this process's share, with
    several processes), for the progress line.
    """
    per_item = eqx.is_array(steps)

    def solve(item):
        index, target, weight, count, flags, *limit = item
        data = FitData(target=target, weights=weight, scheme=scheme,
                       root_smoothing=root_smoothing, count=count, corners=flags)
        result = fit_one(data, None, tol, limit[0] if per_item else steps,
                         objective=objective, solver=solver, progress=False)
        if progress:  # one line for the batch: outlines done, not every solver step
            _progress.items_done(index, devices, total)
        return result

    items = (jnp.arange(targets.shape[0]), targets, weights, counts, corners)
    return jax.lax.map(solve, items + ((steps,) if per_item else ()))


def _batched(targets, weights, counts, corners, steps, scheme, root_smoothing, tol, total, *,
             objective: Objective, solver, shares: int, progress: bool, mesh=None):
    """Fit `(devices, per_device, m, d)` targets: on each device its slice, one item after
    another (`_fit_items`).

    With several devices (`mesh`, one axis "batch" over them) the program is a
    `jax.shard_map`: each device runs its own solver loops on its own items and never
    waits for another's (the program has no collectives). A `vmap` over the device
    axis instead made the devices step together (its loops' stopping tests reduced over
    the axis) and ran both branches of the solver's `lax.cond`s (the global foot-point
    search) at every step: measured 0.24x the throughput of one device, across two
    processes. That `vmap` remains for optimistix's own solvers (`solver` not None):
    lineax, which they solve with, rejects the arrays of a `shard_map` (their sharding
    is part of the structure it compares). `shares`: concurrent calls of this program
    (threads), for the progress line only.
    """
    per_item = eqx.is_array(steps)
    devices = 1 if mesh is None else mesh.size

    def one_device(t, w, c, f, k):
        return _fit_items(t, w, c, f, k if per_item else steps, scheme, root_smoothing, tol,
                          total, objective=objective, solver=solver,
                          devices=devices * shares, progress=progress)

    def items(*arrays):
        # A device's slice, with its leading axis of one; the results get it back.
        result = one_device(*(None if x is None else x[0] for x in arrays))
        return jax.tree.map(lambda x: x[None], result)

    limits = steps if per_item else jnp.zeros(targets.shape[:1], jnp.int32)
    if mesh is None:
        return items(targets, weights, counts, corners, limits)
    if solver is not None:
        return jax.vmap(one_device)(targets, weights, counts, corners, limits)
    spec = jax.sharding.PartitionSpec("batch")
    # check_vma=False: the solver's loops start from constants (the same on every
    # device) and carry values that differ per device, which the varying-axis check
    # rejects; there are no collectives inside for it to guard.
    return jax.shard_map(items, mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False)(
        targets, weights, counts, corners, limits)


# Module level, so that repeated calls with the same shapes and settings reuse the
# compiled program.
_batched_jit = eqx.filter_jit(_batched)


def _available_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        return os.cpu_count() or 1


def _run_batch(targets, weights, counts, corners, scheme, settings, *, objective, solver,
               progress, devices, threads):
    """Fit the stacked batch over `devices`, or on one CPU device from `threads` threads.

    Each device's (or thread's) share is padded to an item-count bucket (`bucket(...,
    smallest=1)`), so batches of similar sizes share one compiled program; the padding
    items are copies of the first, stopped after one step by the default solver.
    `settings = (root_smoothing, tol, max_steps)` (`_core.traced_settings`); `corners`:
    the items' corner flags `(B, m)`, or None for smooth fits.
    """
    size = targets.shape[0]
    root_smoothing, tol, max_steps = settings
    per_item = solver is None  # else max_steps is optimistix's static limit
    # Threads only for concrete arrays: inside a trace (`jit`, `grad` of the batch) the
    # whole batch is one program anyway, and tracing is not shared across threads.
    threaded = (not is_traced(targets) and len(devices) == 1
                and devices[0].platform == "cpu" and 1 < threads <= size // 2)
    parts = threads if threaded else len(devices)
    share = bucket(-(-size // parts), smallest=1)
    extra = parts * share - size
    xp = jnp if is_traced(targets) or is_traced(weights) else np  # as in `pad`
    grow = lambda x: xp.concatenate([x, xp.repeat(x[:1], extra, axis=0)]) if extra else x
    arrays = [grow(x) for x in (targets, weights, counts)]
    arrays.append(None if corners is None else grow(corners))
    if per_item:
        arrays.append(np.concatenate([np.full((size,), max_steps, np.int32),
                                      np.ones((extra,), np.int32)]))
    # (parts, share, ...): one slice per device, or per thread.
    arrays = [None if x is None else x.reshape((parts, share) + x.shape[1:]) for x in arrays]
    steps = arrays.pop() if per_item else max_steps
    total = np.int32(size)

    several = parts > 1 and not threaded
    mesh = jax.sharding.Mesh(np.array(devices), ("batch",)) if several else None

    def program(t, w, c, f, k, shares=1):
        return _batched_jit(t, w, c, f, k, scheme, root_smoothing, tol, total,
                            objective=objective, solver=solver, shares=shares,
                            progress=progress, mesh=mesh)

    if threaded:
        # The same compiled program from `threads` Python threads, one share each: XLA's
        # CPU client runs them concurrently (JAX releases the GIL while a program runs).
        # Measured on 2 cores: 40 outlines in 0.32 s instead of 0.57 s in one call.
        # Concurrent first calls compile the program once (checked with
        # `jax_log_compiles`). Each share keeps a leading device axis of one.
        def run(k):
            t, w, c, f = (None if x is None else x[k:k + 1] for x in arrays)
            limit = steps[k:k + 1] if per_item else steps
            return jax.block_until_ready(program(t, w, c, f, limit, shares=threads))

        with concurrent.futures.ThreadPoolExecutor(threads) as pool:
            done = list(pool.map(run, range(threads)))
        merge = lambda *x: jnp.concatenate([p.reshape((-1,) + p.shape[2:]) for p in x])[:size]
        return jax.tree.map(lambda *x: merge(*x) if eqx.is_array(x[0]) else x[0], *done)
    if len(devices) == 1:
        arrays = jax.device_put(arrays, devices[0])
    else:
        # The device axis is split over the devices: one slice each (`_batched`).
        sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("batch"))
        arrays = jax.device_put(arrays, sharding)
    result = program(*arrays, steps)
    if not is_traced(targets) and any(d.process_index != jax.process_index()
                                      for d in devices):
        # Devices of other processes hold parts of the result, which this process cannot
        # read: every process gets the whole (`process_allgather` of the global arrays).
        # Inside a trace the caller's program holds the global arrays instead.
        from jax.experimental import multihost_utils

        result = jax.tree.map(
            lambda x: jnp.asarray(multihost_utils.process_allgather(x, tiled=True))
            if eqx.is_array(x) else x, result)  # fmt: skip
    merge = lambda x: x.reshape((-1,) + x.shape[2:])[:size]
    return jax.tree.map(lambda x: merge(x) if eqx.is_array(x) else x, result)


def _fingerprint(targets, weights, counts, corners, modules, settings, extra) -> np.ndarray:
    """What every process of a multi-process batch must agree on: a BLAKE2b digest of the
    batch's samples, weights, counts and corner flags (with their shapes and dtypes;
    `corners` may be None), the `modules`
    (the scheme, an optimistix solver: their types, static fields and numbers) and the
    settings, as 8 uint32 words (a fixed size, so that the gather that compares them
    works whatever differs). Compared across processes before fitting
    (`_run_across_processes`)."""
    digest = hashlib.blake2b(digest_size=32)
    numbers, static = eqx.partition(modules, eqx.is_array)
    # The static part's description (types and static fields), without memory addresses
    # (a function's repr holds one, which differs between processes).
    described = re.sub(r" at 0x[0-9a-f]+", "", str(jax.tree.structure(static)))
    digest.update(repr((described, extra)).encode())
    for x in (targets, weights, counts, *jax.tree.leaves((corners, numbers)), *settings):
        x = np.ascontiguousarray(np.asarray(x))
        digest.update(repr((x.shape, x.dtype.str)).encode())
        digest.update(x)  # the buffer itself: no copy of the batch
    return np.frombuffer(digest.digest(), np.uint32).copy()


def _run_across_processes(targets, weights, counts, corners, scheme, settings, *, extra,
                          **options):
    """Fit the stacked batch across the processes of a multi-process JAX program
    (`jax.distributed.initialize` called in each): process `p` of `P` fits the items
    `[p k, (p + 1) k)`, `k = ceil(B / P)`, on its own devices (`_run_batch`), and the
    results are gathered so that every process returns the whole batch's (and holds it:
    on each of its devices, as `process_allgather` leaves it).

    Each process fits its share with no communication until the end, on its own devices
    or, with one CPU device, from one thread per core (`_run_batch`): one program over
    all processes' devices (`devices=jax.devices()`) would give each process one device,
    and so one core, on a CPU. Every process must call `fit_batch` with the same batch
    and settings (three gathers are collectives): checked first (`_fingerprint`), as a
    mismatch would otherwise give wrong items; a process whose fit raises makes every
    process raise, instead of leaving the others waiting in the last gather. `extra`:
    settings not in `settings` that change the fit (n, levels, solver, ...).
    """
    # Imported here: only a multi-process batch needs it.
    from jax.experimental import multihost_utils

    size, processes, me = targets.shape[0], jax.process_count(), jax.process_index()
    mine = _fingerprint(targets, weights, counts, corners, (scheme, options["solver"]),
                        settings, extra)
    every = np.asarray(multihost_utils.process_allgather(
        np.concatenate([np.array([me], np.uint32), mine])))  # fmt: skip
    # The gathers' rows follow the devices' order; put them in process order.
    order = np.argsort(every[:, 0], kind="stable")
    every = every[order, 1:]
    differ = [p for p in range(processes) if not np.array_equal(every[p], every[0])]
    if differ:
        raise ValueError(
            f"fit_batch across {processes} processes: process {differ[0]} passed other "
            "targets, weights or settings than process 0. Every process must call "
            "`fit_batch` with the same batch; each fits its share and all get every "
            "result. (To fit a different batch in each process, pass "
            "`devices=jax.local_devices()`.)"
        )
    share = -(-size // processes)
    start, stop = min(me * share, size), min((me + 1) * share, size)
    # A process without items (fewer items than processes) fits item 0, discarded.
    part = slice(start, stop) if stop > start else slice(0, 1)
    try:
        result, error = _run_batch(targets[part], weights[part], counts[part],
                                   None if corners is None else corners[part], scheme,
                                   settings, devices=jax.local_devices(), **options), None
    except Exception as raised:  # re-raised below, after telling the other processes
        result, error = None, raised
    failed = np.asarray(multihost_utils.process_allgather(np.int32(error is not None)))
    if error is not None:
        raise error
    if failed.any():
        raise RuntimeError(
            f"fit_batch across {processes} processes: process "
            f"{int(np.flatnonzero(failed[order])[0])} failed while fitting its share; "
            "its own error says why."
        )
    arrays, static = eqx.partition(result, eqx.is_array)
    fitted = part.stop - part.start
    grow = lambda x: np.concatenate([x, np.repeat(x[:1], share - fitted, axis=0)])
    arrays = jax.tree.map(lambda x: grow(np.asarray(x)), arrays)
    # (P, share, ...); in process order, item p k + j is process p's j-th.
    gathered = multihost_utils.process_allgather(arrays)
    merge = lambda x: jnp.asarray(x[order].reshape((-1,) + x.shape[2:])[:size])
    return eqx.combine(jax.tree.map(merge, gathered), static)


def fit_batch(
    targets,
    scheme: js.AbstractCurveScheme,
    n_control: int,
    *,
    levels: int | None = None,
    boundary: Literal["closed", "open", "clamped"] = "closed",
    pin_ends: bool = False,
    corners: None | Literal["auto"] | Sequence[None | str | Sequence[int]] = None,
    fit_params: bool | str | tuple[str, ...] = False,
    profile: int | None = None,
    phases: int | None = None,
    solver=None,
    max_steps: int = 500,
    tol: float | None = None,
    weights=None,
    smoothing: float = 0.0,
    ordered: bool = True,
    devices=None,
    threads: int | None = None,
    progress: bool = False,
    on_failure: Literal["raise", "warn", "ignore"] = "warn",
    memory_budget: float = DEFAULT_MEMORY_BUDGET,
) -> FitResult:
    """Fit many outlines at once; the same settings as [`fitting.fit`][].

    The batch is split evenly over `devices` (default: all of `jax.devices()`; one
    `jax.shard_map` program), and each device fits its share one item after another in
    its own compiled loop (`lax.map`), without waiting for the others, so several
    devices scale without code changes. On one CPU device (JAX's default on a CPU), the
    batch is instead split into `threads` shares fitted concurrently, one per core.
    In a program of several processes (`jax.distributed.initialize` in each, on one
    machine or many), call `fit_batch` with the same batch and settings in every
    process: with `devices=None` each process fits its contiguous share on its own
    devices (as above) without waiting for the others, and every process returns the
    whole batch's result (checked: a process that passes another batch raises).
    One item that
    fails does not spoil the others: see `result.converged[i]` and `result.message[i]`.
    Items whose samples are not finite get the status `nonfinite_input`; items that are
    not valid outlines for the settings (a wrong shape such as a 1-D array, all samples
    equal, fewer samples than unknowns, an open-looking outline with
    `boundary="closed"`, more samples than `memory_budget` allows) get `invalid_input`,
    with one warning that says why (`on_failure="warn"`), or raise that `ValueError`
    before anything is fitted (`on_failure="raise"`). Neither is fitted: their numbers
    are NaN, their step count 0, and they take the place of a valid item, so that the
    others' results do not depend on them. An error that every item has (a wrong
    setting) raises. Under `jax.jit` only shapes can be checked: values are not.

    **Arguments:**

    - `targets`: an array `(B, m, d)`, or a list of `B` arrays `(m_i, d)` of different
      lengths (padded internally with zero-weight samples).
    - `weights`: `None`, an array `(B, m)`, or a list of `(m_i,)` arrays.
    - `corners`: `None` (smooth curves), `"auto"` (every item's corners found by
      [`fitting.find_corners`][] with its defaults), or a list of `B` entries, each
      `None`, `"auto"` or that item's corner sample indices (as for `fit`, whose
      `corners` documents the creased fit). With corners in any item, every item is
      modelled as `fit` models a creased curve (by chords, default `levels` as for non-C1
      schemes), and an item without corners gets a smooth curve of that model (no
      creases), which can differ from its smooth fit by the model's accuracy.
      `result.creases` is then `(B, n)`.
    - `max_steps`: solver step limit per item (default 500, as `fit`'s: at 200,
      until 2026-12-07, 26 of 32 smooth blobs at n = 48 ended unconverged, 5 at 500:
      `benchmarks/results/batch_step_limit.md`).
    - `devices`: the devices to split the batch over (default: this process's devices,
      or, with several processes, each process its own; devices of several processes
      make one program across them instead, one device per process on CPUs).
    - `threads`: with a single CPU device, the batch is split into this many equal shares,
      fitted concurrently by one compiled program from as many threads (default: the
      CPU cores available to this process; 1.75x a single share's throughput measured
      on 2 cores). Results do not depend on it.
    - `progress`: one line on stderr for the whole batch, counting outlines done (with
      several processes, each shows its own share's).
    - `phases`: as for `fit`, each item's phases fitted and measured in one program
      (`_core.phase_solve`, whose first call compiles about 1.5x as long as one phase's:
      `benchmarks/results/fit_phases_in_one_program.md`); with corners in any item, no
      item's phases are searched (every item is then fitted with the creased model).
    - `memory_budget`: as for `fit`, checked per outline (one outline is fitted at a
      time in each thread or device, so the batch needs up to that many times it).
    - others: as for [`fitting.fit`][].

    **Returns:** one [`fitting.FitResult`][] whose array fields have a leading batch axis
    (for a ragged list, `curve` and the control points have the common shapes).
    """
    checked_budget(memory_budget, "fit_batch(memory_budget=...)")
    check_on_failure(on_failure)
    if isinstance(targets, (list, tuple)):
        items = [float_array(t, "targets[i]") for t in targets]
    else:
        array = float_array(targets, "targets")
        if array.ndim != 3:
            raise ValueError(
                f"`fit_batch(targets=...)` must be an array of shape (B, m, d) or a list of "
                f"(m_i, d) arrays; got shape {array.shape}."
            )
        items = list(array)
    if not items:
        raise ValueError("`fit_batch(targets=...)` is empty.")
    if weights is None:
        weights = [None] * len(items)
    elif (
        not isinstance(weights, (list, tuple)) and np.ndim(weights) == 0
    ) or len(weights) != len(items):
        raise ValueError(
            f"`fit_batch(weights=...)` needs one weight array per target ({len(items)}): "
            "an array (B, m) or a list of (m_i,) arrays."
        )
    dims = sorted({int(t.shape[-1]) for t in items if t.ndim == 2 and t.shape[-1] >= 2})
    if len(dims) > 1:
        raise ValueError(
            f"`fit_batch(targets=...)` mixes points of dimensions {dims}; fit each "
            "dimension in its own batch."
        )
    several_processes = devices is None and jax.process_count() > 1
    devices = jax.devices() if devices is None else list(devices)
    if not devices:
        raise ValueError("`fit_batch(devices=...)` is empty; pass None for all devices.")
    dimension = dims[0] if dims else 2
    if corners is None or isinstance(corners, str):
        corners = [corners] * len(items)
    elif not isinstance(corners, (list, tuple)) or len(corners) != len(items):
        raise ValueError(
            f"`fit_batch(corners=...)` must be None, 'auto' or a list of one entry per "
            f"target ({len(items)}), each None, 'auto' or sample indices; got {corners!r}."
        )
    prepared, bad, invalid, first_error = [], [], {}, None
    for i, (t, w, c) in enumerate(zip(items, weights, corners)):
        # Items that cannot be fitted are not fitted: their outputs become NaN and their
        # status nonfinite_input or invalid_input below, the other items unaffected.
        well_formed = t.ndim == 2 and t.shape[-1] >= 2
        if well_formed and not is_traced(t) and not np.all(np.isfinite(np.asarray(t))):
            bad.append(i)
            t, w = _stand_in(t.shape[0], dimension, t.dtype), None
        try:
            t, w, n, _, names, values = prepare(
                t, scheme, n_control, levels=levels, boundary=boundary,
                fit_params=fit_params, weights=w, ordered=ordered, smoothing=smoothing,
                caller=f"fit_batch(targets[{i}])", memory_budget=memory_budget,
                profile=profile, pin_ends=pin_ends,
            )  # fmt: skip
            # A non-finite item's stand-in has no corners to find.
            c = corner_flags(None if i in bad else c, t, w, scheme, n, boundary, pin_ends,
                             ordered, caller=f"fit_batch(corners[{i}])")
        except ValueError as error:
            if on_failure == "raise" or is_traced(t):
                raise
            invalid[i], first_error = str(error), first_error or error
            t = w = c = None
        prepared.append((t, w, c))
    valid = [i for i, (t, _, _) in enumerate(prepared) if t is not None and i not in bad]
    if invalid and not valid and not bad:
        # A wrong setting fails every item; so does a batch of invalid items.
        raise first_error
    # Items not fitted take the place of the first valid one (or of a non-finite item's
    # stand-in), so that they change neither the batch's bucket, dtype nor levels.
    if valid or bad:
        stand_in = prepared[valid[0] if valid else bad[0]]
        prepared = [stand_in if i in invalid or i in bad else item
                    for i, item in enumerate(prepared)]  # fmt: skip
    # One sample-count bucket for the whole batch: every item padded to it.
    size = bucket(max(t.shape[0] for t, _, _ in prepared))
    creased = any(c is not None for _, _, c in prepared)
    # A creased curve is modelled as in `fit` (`uses_tangents(..., creased=True)`).
    hermite = uses_tangents(scheme, names, boundary, creased=creased)
    if levels is None:
        levels = default_levels(n, size, hermite)
        if creased:
            check_memory("fit_batch", size, 0, n, levels, scheme, boundary,
                         prepared[0][0].dtype, memory_budget, ordered)
    padded = [pad(t, w, size) for t, w, _ in prepared]
    flags = None
    if creased:
        flags = np.zeros((len(prepared), size), bool)
        for i, (t, _, c) in enumerate(prepared):
            if c is not None:
                flags[i, : t.shape[0]] = c
    xp = jnp if any(is_traced(x) for item in padded for x in item) else np
    stacked = xp.stack([t for t, _ in padded])
    stacked_weights = xp.stack([w for _, w in padded])
    counts = np.array([t.shape[0] for t, _, _ in prepared], np.int32)
    max_steps = static_int(max_steps, "max_steps", minimum=1)
    tol = default_tol(stacked.dtype) if tol is None else check_tol(tol, "fit_batch")
    objective = make_objective(scheme, n=n, levels=levels, boundary=boundary, names=names,
                               hermite=hermite, size=size, profile=values,
                               pin_ends=pin_ends, corners=creased,
                               phases=check_phases(phases, boundary=boundary,
                                                   fit_params=bool(names), init=False,
                                                   solver=solver not in (None, "levenberg-marquardt"),
                                                   who="fit_batch"))
    own = make_solver(solver, tol, tol, progress)
    if progress:
        _progress.begin()
    settings = traced_settings(smoothing, tol, max_steps, stacked.dtype, own is None)
    options = dict(objective=objective, solver=own, progress=progress,
                   threads=_available_cores() if threads is None
                   else static_int(threads, "threads", minimum=1))
    concrete = not any(
        is_traced(x) for x in jax.tree.leaves((stacked, stacked_weights, scheme, settings))
    )
    # One BLAS thread while the programs run (`fitting._threads`), which must have
    # finished inside the block: a concrete batch is waited for here.
    with one_blas_thread():
        # Several processes (`jax.distributed`), no devices given, nothing traced: each
        # process fits its share on its own devices (`_run_across_processes`).
        if several_processes and concrete:
            extra = (n, levels, boundary, pin_ends, names, repr(values), ordered,
                     objective.phases,
                     "levenberg-marquardt" if solver is None else
                     solver if isinstance(solver, str) else "instance")
            result = _run_across_processes(stacked, stacked_weights, counts, flags, scheme,
                                           settings, extra=extra, **options)
        else:
            result = _run_batch(stacked, stacked_weights, counts, flags, scheme, settings,
                                devices=devices, **options)
        if progress or concrete:
            jax.block_until_ready(result)
    if progress:
        _progress.finish()
    for items_, status in ((bad, FitStatus.nonfinite_input), (list(invalid), FitStatus.invalid_input)):
        if items_:
            index = jnp.array(items_)
            blank = (lambda x: x.at[index].set(jnp.nan) if eqx.is_inexact_array(x)
                     else x.at[index].set(False) if eqx.is_array(x) and x.dtype == bool
                     else x)  # fmt: skip
            result = jax.tree.map(blank, result)
            result = eqx.tree_at(
                lambda r: (r.status, r.num_steps), result,
                (result.status.at[index].set(status_code(status)), result.num_steps.at[index].set(0)),
            )  # fmt: skip
    if invalid and on_failure == "warn":
        reasons = "; ".join(f"item {i}: {why}" for i, why in list(invalid.items())[:3])
        more = f" (and {len(invalid) - 3} more)" if len(invalid) > 3 else ""
        warnings.warn(
            f"fit_batch: {len(invalid)} of {len(items)} items are not valid outlines for "
            f"these settings and were not fitted (status invalid_input, numbers NaN): "
            f"{reasons}{more}",
            RuntimeWarning,
            stacklevel=2,
        )
    report(result, on_failure, caller="fit_batch")
    return result


def _stand_in(samples: int, dimension: int, dtype) -> Array:
    """A circle of `samples` points in the first two of `dimension` coordinates: a valid
    outline in the place of an item that is not fitted."""
    angle = 2 * np.pi * np.arange(samples) / samples
    circle = np.zeros((samples, dimension))
    circle[:, 0], circle[:, 1] = np.cos(angle), np.sin(angle)
    return jnp.asarray(circle, dtype)
