import atexit
import gc
import os
import shutil
import tempfile


# Most of the suite's time is XLA compiling (see the summary at the end of a run), so
# programs are compiled at LLVM's optimisation level 0 (measured 2026-12-06, 2 cores:
# 21 of the heaviest tests compiled in 0.68x the time and ran in 0.78x; whole runs took
# 0.81x, 1908 s against 2361 s under similar load; the programs ran 2-5x slower).
# Tests check values, not speed; the demo and the benchmarks run fully optimised
# programs. Set before JAX starts its backend; subprocesses inherit it.
_O0 = "--xla_backend_optimization_level=0"
if _O0 not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {_O0}".strip()

import jax  # noqa: E402
import pytest  # noqa: E402


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


# How much of the suite's time goes to compiling: JAX's monitoring events, summed per test
# and reported at the end of the run (`-p no:terminal` silences it with the rest), with
# the tests that spend most on tracing, lowering and compiling: the candidates for
# sharing programs through module-scoped fixtures.
_EVENTS = {
    "/jax/core/compile/jaxpr_trace_duration": "trace",
    "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
    "/jax/core/compile/backend_compile_duration": "compile",
}
_TOTALS = {"count": 0, "trace": 0.0, "lower": 0.0, "compile": 0.0}
_PER_TEST: dict[str, dict[str, float]] = {}


def _record_event(event, seconds, **_):
    kind = _EVENTS.get(event)
    if kind is None:
        return
    _TOTALS[kind] += seconds
    if kind == "compile":
        _TOTALS["count"] += 1


jax.monitoring.register_event_duration_secs_listener(_record_event)


@pytest.fixture(autouse=True)
def _compilation_time_per_test(request):
    before = dict(_TOTALS)
    yield
    _PER_TEST[request.node.nodeid] = {k: _TOTALS[k] - before[k] for k in _TOTALS}


def pytest_terminal_summary(terminalreporter):
    terminalreporter.write_line(
        f"XLA compilations in this process: {_TOTALS['count']} "
        f"({_TOTALS['compile']:.0f} s compiling, {_TOTALS['trace']:.0f} s tracing, "
        f"{_TOTALS['lower']:.0f} s lowering; nested traces count in each enclosing one)"
    )
    def cost(item):
        return item[1]["trace"] + item[1]["lower"] + item[1]["compile"]
    heaviest = sorted(_PER_TEST.items(), key=cost, reverse=True)[:15]
    if heaviest and cost(heaviest[0]) > 0:
        terminalreporter.write_line("tests that spend most on tracing, lowering, compiling:")
        for nodeid, spent in heaviest:
            terminalreporter.write_line(
                f"  {cost((nodeid, spent)):6.1f} s  {int(spent['count']):4d} programs  {nodeid}"
            )
