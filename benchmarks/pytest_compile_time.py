"""A pytest plugin that records, per test, its wall time and JAX's seconds of tracing,
lowering to MLIR and XLA compiling (`jax.monitoring` duration events), one JSON line per
test, to measure where the suite's time goes and what a compile option saves:

    PYTHONPATH=benchmarks COMPILE_TIME_OUT=/tmp/a.jsonl \\
        python -m pytest -p pytest_compile_time -n 2 tests/test_fit.py
    python benchmarks/pytest_compile_time.py /tmp/a.jsonl /tmp/b.jsonl   # totals

Each xdist worker appends its own tests' lines to the file. Nested traces count in
each enclosing one, so the `trace` column overcounts; `compile` does not nest.
"""

import collections
import json
import os
import sys
import time

import pytest


_EVENTS = {"jaxpr_trace_duration": "trace", "jaxpr_to_mlir_module_duration": "lower",
           "backend_compile_duration": "compile"}
_seconds: collections.Counter = collections.Counter()


def _listener(event: str, duration: float, **kwargs) -> None:
    name = _EVENTS.get(event.rsplit("/", 1)[-1])
    if name:
        _seconds[name] += duration
        _seconds[name + "_count"] += 1


def pytest_configure(config):
    import jax.monitoring

    jax.monitoring.register_event_duration_secs_listener(_listener)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    """Around the test's call (not its fixtures' setup)."""
    _seconds.clear()
    start = time.perf_counter()
    yield
    row = {"test": item.nodeid, "total": time.perf_counter() - start, **_seconds}
    with open(os.environ.get("COMPILE_TIME_OUT", "compile_time.jsonl"), "a") as f:
        f.write(json.dumps(row) + "\n")


def summary(path: str) -> str:
    rows = [json.loads(line) for line in open(path)]
    total = lambda key: sum(r.get(key, 0) for r in rows)
    return (f"{path}: {len(rows)} tests, {total('total'):.0f} s in their calls, "
            f"{total('compile'):.0f} s compiling "
            f"({total('compile_count'):.0f} programs), {total('lower'):.0f} s lowering")


if __name__ == "__main__":
    for path in sys.argv[1:]:
        print(summary(path))
