"""A one-line progress display for long fits and batches (off by default).

A single fit: optimistix calls a solver's `verbose` callable while tracing, with the
step count and loss as traced values; a `jax.debug.callback` then prints them on the
host at every step (under `vmap` reduced over the batch first, so one line). A batch:
one line counting the outlines done, updated as each finishes (`items_done`).
"""

import sys
import time

import equinox.internal as eqxi
import jax


_state = {"last": 0.0, "start": 0.0}


def _show(step, loss):
    now = time.perf_counter()
    if int(step) == 0:
        _state["start"] = now
    elif now - _state["last"] < 0.1:  # at most ten updates a second
        return
    _state["last"] = now
    sys.stderr.write(
        f"\r  fitting: step {int(step):4d}  loss {float(loss):.3e}  "
        f"{now - _state['start']:6.1f} s"
    )
    sys.stderr.flush()


def progress_verbose(**kwargs):
    """A `verbose=` callable for optimistix solvers (module level, so it is hashable and
    the compiled solve is reused)."""
    if "num_steps" not in kwargs:  # e.g. BFGS reports fewer fields: show nothing
        return
    step = eqxi.unvmap_max(kwargs["num_steps"][1])
    loss = eqxi.unvmap_max(kwargs["loss_this_step"][1])
    jax.debug.callback(_show, step, loss, ordered=True)


def begin():
    """Start the clock of a batch's progress line."""
    _state["start"] = _state["last"] = time.perf_counter()


def _show_items(done, total):
    now = time.perf_counter()
    # (The first report of a sharded batch already counts one outline per device.)
    if now - _state["last"] < 0.1 and int(done) < int(total):
        return
    _state["last"] = now
    sys.stderr.write(
        f"\r  fitting: {int(done):6d} / {int(total)} outlines  {now - _state['start']:6.1f} s"
    )
    sys.stderr.flush()


def items_done(index, per_device, devices):
    """Report that item `index` (counted from 0) of each device's share is done."""
    done = (eqxi.unvmap_max(index) + 1) * devices
    # Unordered: ordered effects are not supported across several devices.
    jax.debug.callback(_show_items, done, per_device * devices, ordered=False)


def finish():
    """End the progress line."""
    sys.stderr.write("\n")
    sys.stderr.flush()
