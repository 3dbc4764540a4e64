"""A one-line progress display for long fits and batches (off by default).

A single fit: optimistix calls a solver's `verbose` callable while tracing, with the
step count and loss as traced values; a `jax.debug.callback` then prints them on the
host at every step (under `vmap` reduced over the batch first, so one line). A batch:
one line counting the outlines done, updated as each finishes (`items_done`).

Host callbacks keep JAX from writing a program to its persistent compilation cache, so
`fit(progress="time")` shows only the elapsed time instead, from a host thread
(`elapsed`): the compiled program is then the same as without progress, and cacheable.
"""

import contextlib
import sys
import threading
import time

import equinox.internal as eqxi
import jax
import jax.numpy as jnp


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


def items_done(index, devices: int, total):
    """Report that item `index` (counted from 0) of each of `devices` shares is done, of
    `total` (traced: the real items, without the padding to a bucket)."""
    done = jnp.minimum((eqxi.unvmap_max(index) + 1) * devices, total)
    # Unordered: ordered effects are not supported across several devices.
    jax.debug.callback(_show_items, done, total, ordered=False)


_compiled: set = set()


def compiling(key, samples: int) -> None:
    """Say on stderr, once per program `key` in this process, that the fit's program is
    being prepared (compiled, or loaded from JAX's persistent compilation cache): the
    first call waits for it, seconds on a small machine, with no step to show."""
    if key in _compiled:
        return
    _compiled.add(key)
    cached = jax.config.jax_compilation_cache_dir is not None
    sys.stderr.write(
        f"  preparing the fit for {samples} samples: "
        + ("compiling, or loading it from the compilation cache" if cached else "compiling")
        + " (first use in this process)\n"
    )
    sys.stderr.flush()


def finish():
    """End the progress line."""
    sys.stderr.write("\n")
    sys.stderr.flush()


@contextlib.contextmanager
def elapsed(interval: float = 0.25):
    """While the block runs, a line on stderr with the seconds since it began, updated
    every `interval` seconds from a host thread (nothing enters the compiled program)."""
    start = time.perf_counter()
    stop = threading.Event()

    def show():
        while not stop.wait(interval):
            sys.stderr.write(f"\r  fitting: {time.perf_counter() - start:6.1f} s")
            sys.stderr.flush()

    thread = threading.Thread(target=show, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
        sys.stderr.write(f"\r  fitting: {time.perf_counter() - start:6.1f} s, done\n")
        sys.stderr.flush()
