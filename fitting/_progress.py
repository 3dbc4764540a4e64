"""A one-line progress display for long fits and batches (off by default).

A single fit: optimistix calls a solver's `verbose` callable while tracing, with the
step count and loss as traced values; a `jax.debug.callback` then prints them on the
host at every step (under `vmap` reduced over the batch first, so one line). A batch:
one line counting the outlines done, updated as each finishes (`items_done`).

On a terminal the line is rewritten in place (`\r`); when stderr is a file or a pipe,
rewrites would pile up in it (15 lines for a 4 s fit), so only the final state is
written there (`_live`).

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


def _live() -> bool:
    """Whether stderr is a terminal, where a line can be rewritten in place."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced by an object without it, or closed
        return False


def _show(step, loss):
    if not _live():  # no final step is known here: the caller reports the result
        return
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
    finished = int(done) >= int(total)
    # (The first report of a sharded batch already counts one outline per device.)
    if not finished and (now - _state["last"] < 0.1 or not _live()):
        return
    _state["last"] = now
    begin, end = ("\r", "") if _live() else ("", "\n")  # rewritten in place, or a line
    sys.stderr.write(
        f"{begin}  fitting: {int(done):6d} / {int(total)} outlines  "
        f"{now - _state['start']:6.1f} s{end}"
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
    """End the progress line (on a terminal; elsewhere per-step lines were not written)."""
    if not _live():
        return
    sys.stderr.write("\n")
    sys.stderr.flush()


@contextlib.contextmanager
def elapsed(interval: float = 0.25):
    """While the block runs, a line on stderr with the seconds since it began, updated
    every `interval` seconds from a host thread (nothing enters the compiled program);
    when stderr is not a terminal, only the final line."""
    start = time.perf_counter()
    stop = threading.Event()
    live = _live()

    def show():
        while not stop.wait(interval):
            sys.stderr.write(f"\r  fitting: {time.perf_counter() - start:6.1f} s")
            sys.stderr.flush()

    thread = threading.Thread(target=show, daemon=True)
    if live:
        thread.start()
    try:
        yield
    finally:
        stop.set()
        if live:
            thread.join()
        begin = "\r" if live else ""
        sys.stderr.write(f"{begin}  fitting: {time.perf_counter() - start:6.1f} s, done\n")
        sys.stderr.flush()
