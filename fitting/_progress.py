"""A one-line progress display for long fits and batches (off by default).

A single fit: optimistix calls a solver's `verbose` callable while tracing, with the
step count and loss as traced values; a `jax.debug.callback` then prints them on the
host at every step (under `vmap` reduced over the batch first, so one line). A batch:
one line counting the outlines done, updated as each finishes (`items_done`).

On a terminal (or in Jupyter) the line is rewritten in place (`\r`); when stderr is a
file or a pipe, rewrites would pile up in it (15 lines for a 4 s fit), so only the
final state is written there, once, when the fit or batch ends (`_live`, `finish`).

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


_state = {"last": 0.0, "start": 0.0, "line": "", "label": "fitting"}


def _live() -> bool:
    """Whether stderr shows a line rewritten in place (`\r`): a terminal, or a Jupyter
    kernel's stream (which reports no terminal but renders `\r`)."""
    try:
        return sys.stderr.isatty() or type(sys.stderr).__module__.startswith("ipykernel")
    except (AttributeError, ValueError):  # replaced by an object without it, or closed
        return False


def _update(line: str, now: float, force: bool = False) -> None:
    """Keep `line` as the display's state; on a live stream, show it in place (at most
    ten times a second, unless `force`). Elsewhere `finish` writes the last one."""
    _state["line"] = line
    if _live() and (force or now - _state["last"] >= 0.1):
        _state["last"] = now
        sys.stderr.write("\r" + line)
        sys.stderr.flush()


def _show(step, loss):
    now = time.perf_counter()
    if int(step) == 0:
        _state["start"], _state["last"] = now, 0.0
    _update(f"  {_state['label']}: step {int(step):4d}  loss {float(loss):.3e}  "
            f"{now - _state['start']:6.1f} s", now)


def step_label(label: str = "fitting") -> None:
    """Name the fit whose steps the next lines show (`fit(phases=K)`: each phase's)."""
    _state["label"] = label


def progress_verbose(**kwargs):
    """A `verbose=` callable for optimistix solvers (module level, so it is hashable and
    the compiled solve is reused)."""
    if "num_steps" not in kwargs:  # e.g. BFGS reports fewer fields: show nothing
        return
    step = eqxi.unvmap_max(kwargs["num_steps"][1])
    loss = eqxi.unvmap_max(kwargs["loss_this_step"][1])
    # `_show` looked up at each call, not baked into the compiled program (a replaced
    # `_show`, as tests do, applies to programs compiled before).
    jax.debug.callback(lambda step, loss: _show(step, loss), step, loss, ordered=True)


def begin():
    """Start the clock of a batch's progress line."""
    _state["start"] = _state["last"] = time.perf_counter()
    _state["line"] = ""


def _show_items(done, total):
    # (The first report of a sharded batch already counts one outline per device.)
    now = time.perf_counter()
    _update(f"  fitting: {int(done):6d} / {int(total)} outlines  "
            f"{now - _state['start']:6.1f} s", now, force=int(done) >= int(total))


def items_done(index, devices: int, total):
    """Report that item `index` (counted from 0) of each of `devices` shares is done, of
    `total` (traced: the real items, without the padding to a bucket)."""
    done = jnp.minimum((eqxi.unvmap_max(index) + 1) * devices, total)
    # Unordered: ordered effects are not supported across several devices.
    # (`_show_items` looked up at each call, as `_show` in `progress_verbose`.)
    jax.debug.callback(lambda done, total: _show_items(done, total), done, total,
                       ordered=False)


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
    """End the progress line with its last state: rewritten in place on a live stream,
    else written once, as one line (so a file or pipe gets one line per fit or batch,
    however many updates or shares reported)."""
    if _state["line"]:
        sys.stderr.write(("\r" if _live() else "") + _state["line"] + "\n")
        sys.stderr.flush()
    _state["line"], _state["label"] = "", "fitting"


@contextlib.contextmanager
def elapsed(interval: float = 0.25, label: str = "fitting"):
    """While the block runs, a line on stderr (`label`: seconds) with the seconds since
    it began, updated every `interval` seconds from a host thread (nothing enters the
    compiled program); when stderr is not a terminal, only the final line."""
    start = time.perf_counter()
    stop = threading.Event()

    def show():
        while not stop.wait(interval):
            now = time.perf_counter()
            _update(f"  {label}: {now - start:6.1f} s", now, force=True)

    # Off a live stream nothing is shown until the end: no thread.
    thread = threading.Thread(target=show, daemon=True) if _live() else None
    if thread is not None:
        thread.start()
    try:
        yield
    finally:
        stop.set()
        if thread is not None:
            thread.join()
        _state["line"] = f"  {label}: {time.perf_counter() - start:6.1f} s, done"
        finish()
