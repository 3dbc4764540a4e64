"""XLA flags the `jaxsubdiv` command sets for its own process: programs that compile faster.

A command is a new process that compiles its programs and runs them for milliseconds, so
compile time is most of what a user waits for. XLA's CPU fusion emitters (MLIR, its
default) cost more compile time than they save there: with them off, a fit's programs
compiled in 0.62-0.82x the time, the fixed fit running as fast and the `fit_params` and
gradient programs 1.17x and 1.3x slower (`benchmarks/results/fit_compile_xla_flags.md`);
the command itself, the same code with them on and off, interleaved:
`benchmarks/results/startup_emitters_same_tree.md` (cold runs in 0.74-0.87x the time on
two machines; runs from a warm cache 0.97-0.98x on one, 1.13-1.18x slower, not
explained, on the other: `docs/cli.md`).

Why an environment variable: XLA reads `XLA_FLAGS` when JAX starts its backend, so one
setting covers every program of the command's process, the library's and JAX's own, and
`import jaxsubdiv` or `fitting` in a user's process changes nothing. (`jax.jit`'s
`compiler_options` would need passing through every jit site of the library, and would
change its programs for library users too.) But XLA stops the process (a fatal error,
not an exception) at a flag it does not know, and older releases lack this one (a later
one may drop it with the older emitters), so the flag is set only for the jaxlib
releases it was run with (`VERIFIED_JAXLIB`; `benchmarks/check_xla_flag_support.py`);
any other release compiles with XLA's defaults. A value the user gave in `XLA_FLAGS` is
kept (`XLA_FLAGS=--xla_cpu_use_fusion_emitters=true` keeps XLA's default emitters), as
are flags read from a file (an `XLA_FLAGS` that does not start with `-` names one).
"""

import contextlib
import os
import re


#: The flag and the value the command sets.
FUSION_EMITTERS_OFF = "--xla_cpu_use_fusion_emitters=false"
#: jaxlib releases (first, last; inclusive) whose XLA was run with the flag and took it:
#: each release from 0.4.30 to 0.10.2 installed and run with it and with an invented
#: flag on 2026-12-07; 0.5.3 to 0.10.2 took it (and stopped at the invented one), 0.5.1
#: and older stopped at it (there is no 0.5.2): `benchmarks/results/xla_flag_support.md`.
VERIFIED_JAXLIB = ((0, 5, 3), (0, 10, 2))


def release(text: str) -> tuple[int, int, int] | None:
    """A version string's release as three numbers ("0.10.2", "0.5.0rc1" and
    "0.4.36.dev20241122" give (0, 10, 2), (0, 5, 0), (0, 4, 36)), or None."""
    match = re.match(r"(\d+)\.(\d+)\.(\d+)", text)
    return tuple(int(part) for part in match.groups()) if match else None


def _jaxlib_release() -> tuple[int, int, int] | None:
    """The installed jaxlib's release, or None without one (from `jaxlib.version`,
    which JAX imports anyway, rather than the slower search of package metadata)."""
    try:
        from jaxlib.version import __version__
    except ImportError:
        return None
    return release(__version__)


def command_xla_flags(environ: dict[str, str], jaxlib: tuple[int, ...] | None) -> str | None:
    """The `XLA_FLAGS` value the command runs with, or None to leave it as it is: the
    user's flags plus the fusion emitters off, when `jaxlib` (a release as numbers) is in
    `VERIFIED_JAXLIB` and the user's value neither sets that flag, nor names a file of
    flags (XLA reads a value that does not start with `-` as a file name), nor has an
    unpaired quote (which would take the added flag into the quoted value)."""
    given = environ.get("XLA_FLAGS", "")
    first, last = VERIFIED_JAXLIB
    if jaxlib is None or not first <= jaxlib <= last:
        return None
    if given.strip() and not given.lstrip().startswith("-"):
        return None
    if given.count('"') % 2 or given.count("'") % 2:
        return None
    name = FUSION_EMITTERS_OFF.split("=")[0]
    if any(flag.split("=")[0] == name for flag in given.split()):
        return None
    return f"{given} {FUSION_EMITTERS_OFF}".strip()


@contextlib.contextmanager
def command_compile_flags():
    """Run the block with the command's XLA flags (`command_xla_flags`) in `XLA_FLAGS`.

    XLA reads its flags once, when JAX first starts its backend, and JAX's persistent
    cache keys programs by the variable's value at each compilation. So the flags are set
    only if the backend has not started (a command run as a new process, the `jaxsubdiv`
    script); a process whose backend had started (a test calling `main`) is left as it
    was. After the block the variable gets its value back if the backend still has not
    started; if the block started it, the flags stay, so that the process's later
    compilations are cached under the flags XLA compiles them with. (After
    `jax.clear_backends()` the backend counts as not started, but XLA keeps the flags it
    read: the variable would then say more than XLA does.)"""
    flags = command_xla_flags(os.environ, _jaxlib_release())
    if flags is None or _backend_started():
        yield
        return
    before = os.environ.get("XLA_FLAGS")
    os.environ["XLA_FLAGS"] = flags
    try:
        yield
    finally:
        if not _backend_started():
            if before is None:
                os.environ.pop("XLA_FLAGS", None)
            else:
                os.environ["XLA_FLAGS"] = before


def _backend_started() -> bool:
    """Whether JAX has started its backend in this process (its XLA flags are read)."""
    import sys

    if "jax" not in sys.modules:
        return False
    try:
        from jax._src.xla_bridge import backends_are_initialized
    except ImportError:  # a JAX without it: assume started, change nothing
        return True
    return backends_are_initialized()
