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
# programs. XLA's CPU fusion emitters (MLIR) are switched off too: the older emitters
# compile the fit's programs at level 0 in 0.35-0.60x the time, warm within 10%
# (`benchmarks/bench_fit_compile.py --xla-flags`, `results/fit_compile_xla_flags.md`;
# the whole suite: `benchmarks/results/test_suite_time.md`). A fit traced into a larger
# program may then round differently from the fit run alone, so tests compare such
# pairs to the solver's accuracy, not bit for bit. A flag the user set in XLA_FLAGS
# (either value) is kept. XLA stops a process at a flag it does not know, so the
# emitters' flag, which older and later XLAs may lack, is tried in a subprocess first
# (once: xdist's workers and other subprocesses inherit the result). Set before JAX
# starts its backend.


def _set_xla_flag(flag: str, probe: bool) -> None:
    given = {f.split("=")[0] for f in os.environ.get("XLA_FLAGS", "").split()}
    if flag.split("=")[0] in given:
        return
    flags = f"{os.environ.get('XLA_FLAGS', '')} {flag}".strip()
    if probe:
        import subprocess
        import sys

        code = "import jax.numpy as jnp; jnp.zeros(1).block_until_ready()"
        known = subprocess.run([sys.executable, "-c", code], capture_output=True,
                               env=dict(os.environ, XLA_FLAGS=flags)).returncode == 0
        if not known:
            return
    os.environ["XLA_FLAGS"] = flags


_set_xla_flag("--xla_backend_optimization_level=0", probe=False)
_set_xla_flag("--xla_cpu_use_fusion_emitters=false", probe=True)

import jax  # noqa: E402
import pytest  # noqa: E402

import fitting._exported  # noqa: E402


# Tests run in float64; float32 is tested explicitly where it matters.
jax.config.update("jax_enable_x64", True)
# No display is needed anywhere in the test suite.
os.environ.setdefault("MPLBACKEND", "Agg")
# A fresh folder of this run's own for compiled programs (never the user's cache, whose
# contents would make results and timings depend on earlier runs). Made by the process
# that loads this file first, which removes it at exit; pytest-xdist's workers, started
# by it, inherit its name through the environment and share it.
_RUN_FOLDER = "JAXSUBDIV_TEST_RUN_FOLDER"
if not os.environ.get(_RUN_FOLDER):
    os.environ[_RUN_FOLDER] = tempfile.mkdtemp(prefix="jaxsubdiv-test-run-")
    atexit.register(shutil.rmtree, os.environ[_RUN_FOLDER], ignore_errors=True)
# The `jaxsubdiv` command keeps compiled programs in a persistent cache: in the tests,
# one in the run's folder, shared by the command's subprocesses.
os.environ["JAXSUBDIV_COMPILATION_CACHE"] = os.path.join(os.environ[_RUN_FOLDER], "command")
# The tests' own programs go to JAX's persistent cache in the run's folder too, so that
# a program one worker compiled is loaded, not compiled again, by the other (the same
# fits recur across test files; measured 2026-12-06 with `-n auto` on 2 cores: 51
# programs loaded, 165 s of the workers' 1835 s of compiling saved by JAX's estimate;
# five fitting test files ran in 0.89x the wall time with it, back to back). Only
# programs that took over half a second to compile are written (fits, not single
# operations); the size limit makes JAX lock the folder, so that a worker never reads a
# program another is still writing.
_XLA_CACHE = os.path.join(os.environ[_RUN_FOLDER], "xla")
_XLA_CACHE_SETTINGS = {"jax_compilation_cache_dir": _XLA_CACHE,
                       "jax_persistent_cache_min_compile_time_secs": 0.5,
                       "jax_compilation_cache_max_size": 2**34}
for _name, _value in _XLA_CACHE_SETTINGS.items():
    jax.config.update(_name, _value)


@pytest.fixture
def suite_cache_environment() -> dict[str, str]:
    """Environment variables that give a Python subprocess the suite's persistent cache
    (JAX reads its settings from them), for tests whose subprocesses compile the
    programs the test compiles too."""
    return {name.upper(): str(value) for name, value in _XLA_CACHE_SETTINGS.items()}


def _exported_folder():
    """`fitting._exported.folder`, but None for the suite's cache: with a persistent
    cache on, `fitting.fit` runs its programs exported to disk (`fitting._exported`);
    the suite's cache is not a request for that. The tests of exported programs point
    JAX at a folder of their own, and get them."""
    if jax.config.jax_compilation_cache_dir == _XLA_CACHE:
        return None
    return _library_exported_folder()


_library_exported_folder = fitting._exported.folder
fitting._exported.folder = _exported_folder


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
_TOTALS = {"count": 0, "hits": 0, "trace": 0.0, "lower": 0.0, "compile": 0.0}
_PER_TEST: dict[str, dict[str, float]] = {}


def _record_event(event, seconds, **_):
    kind = _EVENTS.get(event)
    if kind is None:
        return
    _TOTALS[kind] += seconds
    if kind == "compile":
        _TOTALS["count"] += 1


def _record_hit(event, **_):
    if event == "/jax/compilation_cache/cache_hits":
        _TOTALS["hits"] += 1


jax.monitoring.register_event_duration_secs_listener(_record_event)
jax.monitoring.register_event_listener(_record_hit)


@pytest.fixture(autouse=True)
def _compilation_time_per_test(request):
    before = dict(_TOTALS)
    yield
    _PER_TEST[request.node.nodeid] = {k: _TOTALS[k] - before[k] for k in _TOTALS}


def pytest_terminal_summary(terminalreporter):
    terminalreporter.write_line(
        f"XLA compilations in this process: {_TOTALS['count']}, "
        f"{_TOTALS['hits']} of them loaded from the persistent cache "
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
