"""XLA flags the `jaxsubdiv` command sets for its own process: programs that compile faster.

A command is a new process that compiles its programs and runs them for milliseconds, so
compile time is most of what a user waits for. XLA's CPU fusion emitters (MLIR, its
default) cost more compile time than they save there: with them off, a fit's programs
compiled in 0.62-0.82x the time, the fixed fit running as fast
(`benchmarks/bench_fit_compile.py --xla-flags`, `results/fit_compile_xla_flags.md`);
the command's cold runs: `benchmarks/results/startup.md`.

XLA stops the process (a fatal error, not an exception) at a flag it does not know, and
older releases lack this one (a later one may drop it with the older emitters), so the
flag is set only for the jaxlib releases it was tried on (`VERIFIED_JAXLIB`); any other
release compiles with XLA's defaults. A value the
user gave in `XLA_FLAGS` is kept: `XLA_FLAGS=--xla_cpu_use_fusion_emitters=true` keeps
XLA's default emitters.

This is the command's choice for its process, not the library's: `import jaxsubdiv` and
`fitting` leave XLA's configuration alone.
"""

import contextlib
import os
import re


#: The flag and the value the command sets.
FUSION_EMITTERS_OFF = "--xla_cpu_use_fusion_emitters=false"
#: jaxlib releases (first, last; inclusive) whose XLA was run with the flag and took it:
#: each release from 0.4.30 to 0.10.2 installed and run with it and with an invented
#: flag, 2026-12-07; 0.5.3 to 0.10.2 took it (and stopped at the invented one), 0.5.1
#: and older stopped at it.
VERIFIED_JAXLIB = ((0, 5, 3), (0, 10, 2))


def release(text: str) -> tuple[int, int, int] | None:
    """A version string's release as three numbers ("0.10.2", "0.5.0rc1" and
    "0.4.36.dev20241122" give (0, 10, 2), (0, 5, 0), (0, 4, 36)), or None."""
    match = re.match(r"(\d+)\.(\d+)\.(\d+)", text)
    return tuple(int(part) for part in match.groups()) if match else None


def _jaxlib_release() -> tuple[int, int, int] | None:
    """The installed jaxlib's release, or None if it is not installed as a package."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return release(version("jaxlib"))
    except PackageNotFoundError:
        return None


def command_xla_flags(environ: dict[str, str], jaxlib: tuple[int, ...] | None) -> str | None:
    """The `XLA_FLAGS` value the command runs with, or None to leave it as it is: the
    user's flags plus the fusion emitters off, when the user did not set that flag and
    `jaxlib` (a release as numbers) is in `VERIFIED_JAXLIB`."""
    given = environ.get("XLA_FLAGS", "")
    name = FUSION_EMITTERS_OFF.split("=")[0]
    if any(flag.split("=")[0] == name for flag in given.split()):
        return None
    first, last = VERIFIED_JAXLIB
    if jaxlib is None or not first <= jaxlib <= last:
        return None
    return f"{given} {FUSION_EMITTERS_OFF}".strip()


@contextlib.contextmanager
def command_compile_flags():
    """Run the block with the command's XLA flags (`command_xla_flags`) in `XLA_FLAGS`,
    and give the variable back its value after it.

    XLA reads its flags once, when JAX first starts its backend, and JAX's persistent
    cache keys programs by them at each compilation; so the flags apply to a command run
    in a new process (the `jaxsubdiv` script), and to nothing in a process whose JAX
    backend had already started (a test calling `main`, which is left as it was), and
    no other code of the process sees the variable changed afterwards."""
    flags = command_xla_flags(os.environ, _jaxlib_release())
    if flags is None or _backend_started():
        yield
        return
    before = os.environ.get("XLA_FLAGS")
    os.environ["XLA_FLAGS"] = flags
    try:
        yield
    finally:
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
