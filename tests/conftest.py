import gc
import os

import jax
import pytest


# Tests run in float64; float32 is tested explicitly where it matters.
jax.config.update("jax_enable_x64", True)
# No display is needed anywhere in the test suite.
os.environ.setdefault("MPLBACKEND", "Agg")


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
