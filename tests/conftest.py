import atexit
import gc
import os
import shutil
import tempfile

import jax
import pytest


# Tests run in float64; float32 is tested explicitly where it matters.
jax.config.update("jax_enable_x64", True)
# No display is needed anywhere in the test suite.
os.environ.setdefault("MPLBACKEND", "Agg")
# The `jaxsubdiv` command keeps compiled programs in a persistent cache: in the tests, a
# fresh folder of this run's own (never the user's cache, whose contents would make
# results and timings depend on earlier runs), shared by the command's subprocesses.
_CACHE = tempfile.mkdtemp(prefix="jaxsubdiv-test-cache-")
atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)
os.environ["JAXSUBDIV_COMPILATION_CACHE"] = _CACHE


def _mappings() -> int:
    try:
        with open("/proc/self/maps") as f:
            return sum(1 for _ in f)
    except OSError:  # not Linux
        return 0


@pytest.fixture(autouse=True)
def _release_compiled_programs():
    """Every compiled XLA program holds memory mappings. The whole suite in one process
    passed the kernel's limit of 65,530 mappings (`vm.max_map_count`; `test_fit.py`
    alone reached 54,000), and XLA's compiler then crashed with a segmentation fault.
    Past 30,000, drop the compiled programs (measured: 300 small programs took 970
    mappings, and `jax.clear_caches()` gave back 880 of them)."""
    yield
    if _mappings() > 30_000:
        jax.clear_caches()
        gc.collect()


# How much of the suite's time goes to compiling: JAX's monitoring events, summed and
# reported at the end of the run (`-p no:terminal` silences it with the rest).
_COMPILATIONS = {"count": 0, "seconds": 0.0}


def _count_compilation(event, seconds, **_):
    if event == "/jax/core/compile/backend_compile_duration":
        _COMPILATIONS["count"] += 1
        _COMPILATIONS["seconds"] += seconds


jax.monitoring.register_event_duration_secs_listener(_count_compilation)


def pytest_terminal_summary(terminalreporter):
    terminalreporter.write_line(
        f"XLA compilations in this process: {_COMPILATIONS['count']} "
        f"({_COMPILATIONS['seconds']:.0f} s)"
    )
