"""Benchmark start-up and compile cost of the `jaxsubdiv` command, in fresh processes.

    python benchmarks/bench_startup.py                 # 5 runs per case (10-15 min, 2 cores)
    python benchmarks/bench_startup.py --smoke         # 1 run per case (about 4 minutes)
    python benchmarks/bench_startup.py --src /other/tree --label before --output x.json
    python benchmarks/bench_startup.py --scenarios import,help,fit-glyph

Every figure is what a user waits for when typing a command: a new Python process that
imports the library, parses the command line, traces and compiles, runs and exits.
Scenarios (`SCENARIOS` below): `import jaxsubdiv`; `import jax` (what any command
that computes pays first: its dependencies' versions matter, see `pyproject.toml`); `--help`; a usage error; `demo`; a
fit of the glyph 'S'; a fit of a file with two contours of different lengths (300 and
517 samples). The last three run under two conditions of the persistent compilation
cache, selected by `JAXSUBDIV_COMPILATION_CACHE`: `cold` (a fresh empty folder per run)
and `warm` (a folder filled by one untimed earlier run of the same command). A library
that ignores the variable has no persistent cache, and then cold and warm agree.

Per scenario and condition: the median, min and max wall time of `--repeat` runs
(`time.perf_counter` around `subprocess.run`), the median user + sys CPU time of the
child (`RUSAGE_CHILDREN`), and the exit codes. One extra, untimed run through a probe
(`PROBE` below) counts JAX's tracing, lowering and XLA compilation events and the
persistent cache's hits and misses with `jax.monitoring` listeners. The probe imports
jax before the command does, so it is not timed and, for `--help` and the usage error,
does not listen: it only records whether the command imported jax at all.

The command always runs as `python -c "...; sys.exit(main())" ARGS` with
`jaxsubdiv._cli.main`, never through the installed `jaxsubdiv` script, so that `--src DIR`
(prepended to `PYTHONPATH` in the children) measures another source tree exactly as it
measures the installed one. Children use this script's interpreter and run in a scratch
folder (the working directory would come first on `sys.path`). Every child gets a private `XDG_CACHE_HOME` (and no
`MPLCONFIGDIR`), so a user's real caches are neither used nor touched.

Writes `benchmarks/results/startup.json` (every run) and `startup.md` (the table);
`--output` sets the JSON path and the Markdown goes beside it with the same stem;
`--smoke` writes `startup_smoke.*` unless `--output` is given. Standard library only:
jax is imported by the probe, in the children.
"""

import argparse
import datetime
import importlib.metadata
import json
import math
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
CACHE_VARIABLE = "JAXSUBDIV_COMPILATION_CACHE"
#: A child that takes longer than this (seconds) is stopped and reported as failed.
TIMEOUT = 900

IMPORT = "import jaxsubdiv"
CLI = "import sys; from jaxsubdiv._cli import main; sys.exit(main())"

# Put in front of a scenario's code for the counting run. It writes one JSON object to
# the file named by JAXSUBDIV_BENCH_PROBE at exit (also after SystemExit from argparse).
# With JAXSUBDIV_BENCH_MONITOR=1 it imports jax first, to listen to every compilation.
PROBE = """\
import atexit, json, os, sys
_probe = {"monitored": os.environ["JAXSUBDIV_BENCH_MONITOR"] == "1"}
if _probe["monitored"]:
    import jax.monitoring
    _names = {
        "/jax/core/compile/jaxpr_trace_duration": "trace",
        "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
        "/jax/core/compile/backend_compile_duration": "compile",
    }
    # JAX records a miss only when it writes the entry (compilations of at least
    # jax_persistent_cache_min_compile_time_secs), and only with a cache folder set.
    _counts = {"/jax/compilation_cache/cache_hits": "cache_hits",
               "/jax/compilation_cache/cache_misses": "cache_misses"}
    for _key in _names.values():
        _probe[_key] = 0
        _probe[_key + "_s"] = 0.0
    for _key in _counts.values():
        _probe[_key] = 0
    _probe["compiled"] = []  # (function, seconds) of every XLA compilation
    def _on_duration(event, secs, **kwargs):
        key = _names.get(event)
        if key:
            _probe[key] += 1
            _probe[key + "_s"] += secs
            if key == "compile":
                _probe["compiled"].append([kwargs.get("fun_name", "?"), secs])
    def _on_event(event, **kwargs):
        if event in _counts:
            _probe[_counts[event]] += 1
    jax.monitoring.register_event_duration_secs_listener(_on_duration)
    jax.monitoring.register_event_listener(_on_event)
def _dump():
    _probe["jax_imported"] = "jax" in sys.modules
    _probe["xla_flags"] = os.environ.get("XLA_FLAGS")
    _module = sys.modules.get("jaxsubdiv")
    _probe["jaxsubdiv_file"] = getattr(_module, "__file__", None)
    if _probe["monitored"]:
        _probe["any"] = any(_probe[k] for k in ("trace", "lower", "compile"))
        _probe["compiled"].sort(key=lambda item: -item[1])
    with open(os.environ["JAXSUBDIV_BENCH_PROBE"], "w") as f:
        f.write(json.dumps(_probe) + "\\n")
atexit.register(_dump)
"""


# name -> (code, arguments (with {tmp} for the scratch folder), accepted exit codes,
# whether it runs cold and warm, whether the probe listens to compilations).
# Exit code 1 of `fit` and `demo` means "did not converge": recorded, not a failure.
SCENARIOS = {
    "import": (IMPORT, [], (0,), False, True),
    "import-jax": ("import jax", [], (0,), False, False),
    "help": (CLI, ["--help"], (0,), False, False),
    "usage-error": (CLI, ["fit", "--n", "notanumber"], (2,), False, False),
    "demo": (CLI, ["demo", "-o", "{tmp}/demo.png"], (0, 1), True, True),
    "fit-glyph": (CLI, ["fit", "--text", "S", "-q"], (0, 1), True, True),
    "fit-two-lengths": (CLI, ["fit", "{tmp}/two.json", "-q"], (0, 1), True, True),
}


def write_two_contours(path: Path) -> None:
    """Two closed ellipses of 300 and 517 samples (the default n = 32 needs >= 64)."""

    def ellipse(count, a, b, cx):
        return [
            [cx + a * math.cos(2 * math.pi * i / count), b * math.sin(2 * math.pi * i / count)]
            for i in range(count)
        ]

    outlines = [ellipse(300, 1.0, 0.6, 0.0), ellipse(517, 0.8, 1.1, 3.0)]
    path.write_text(json.dumps({"outlines": [{"points": p, "closed": True} for p in outlines]}))


# --------------------------------------------------------------------------------------
# Running children.


class Runner:
    """Runs scenario commands in fresh processes with a controlled environment."""

    def __init__(self, scratch: Path, src: Path | None):
        self.scratch = scratch
        self.env = dict(os.environ)
        # Caches the benchmark controls: matplotlib's goes under XDG_CACHE_HOME, and a
        # user's own JAX cache would make every run warm.
        for name in ("MPLCONFIGDIR", "JAX_COMPILATION_CACHE_DIR", CACHE_VARIABLE):
            self.env.pop(name, None)
        self.env["XDG_CACHE_HOME"] = str(scratch / "xdg-cache")
        if src is not None:
            self.env["PYTHONPATH"] = os.pathsep.join(
                [str(src)] + ([self.env["PYTHONPATH"]] if self.env.get("PYTHONPATH") else [])
            )

    def command(self, code: str, arguments: list[str]) -> list[str]:
        return [sys.executable, "-c", code] + [a.format(tmp=self.scratch) for a in arguments]

    def run(self, code: str, arguments: list[str], cache: Path, extra_env=None) -> dict:
        """One child, timed; `cache` is its JAXSUBDIV_COMPILATION_CACHE."""
        env = self.env | {CACHE_VARIABLE: str(cache)} | (extra_env or {})
        # The child runs in the scratch folder: `python -c` puts the working directory
        # first on sys.path, which would shadow the tree under test.
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        try:
            done = subprocess.run(
                self.command(code, arguments), env=env, cwd=self.scratch,
                capture_output=True, text=True, timeout=TIMEOUT,
            )
            exit_code, stderr = done.returncode, done.stderr
        except subprocess.TimeoutExpired as e:
            # (its captured output is bytes even with text=True)
            tail = (e.stderr or b"").decode(errors="replace")
            exit_code, stderr = None, f"timed out after {TIMEOUT} s; {tail}"
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        return {"wall_s": wall, "cpu_s": cpu, "exit_code": exit_code, "stderr": stderr}

    def probe(self, code: str, arguments: list[str], cache: Path, monitor: bool) -> dict:
        """The untimed counting run: what the probe wrote, or why it wrote nothing."""
        out = self.scratch / "probe.json"
        out.unlink(missing_ok=True)
        extra = {"JAXSUBDIV_BENCH_PROBE": str(out), "JAXSUBDIV_BENCH_MONITOR": str(int(monitor))}
        run = self.run(PROBE + code, arguments, cache, extra)
        report = json.loads(out.read_text()) if out.exists() else {"error": "no probe output"}
        report["exit_code"] = run["exit_code"]
        if "error" in report:
            report["stderr_tail"] = run["stderr"][-2000:]
        return report

    def fresh_cache(self) -> Path:
        return Path(tempfile.mkdtemp(prefix="cache-", dir=self.scratch))


def measure(runner: Runner, name: str, condition: str, repeat: int) -> dict:
    """`repeat` timed runs of one scenario under one cache condition, then the probe."""
    code, arguments, accepted, _, monitor = SCENARIOS[name]
    warm = runner.fresh_cache() if condition == "warm" else None
    populate = runner.run(code, arguments, warm) if warm else None
    # What one run of the command leaves in the cache folder (bytes; exported fits apart).
    files = [f for f in warm.rglob("*") if f.is_file()] if warm else []
    cache_bytes = sum(f.stat().st_size for f in files)
    exported_bytes = sum(f.stat().st_size for f in files if f.suffix == ".jaxexport")
    runs = []
    for _ in range(repeat):
        cache = warm or runner.fresh_cache()
        runs.append(runner.run(code, arguments, cache))
        if not warm:
            shutil.rmtree(cache)
    cache = warm or runner.fresh_cache()
    probe = runner.probe(code, arguments, cache, monitor)
    shutil.rmtree(cache)

    walls = [r["wall_s"] for r in runs]
    every = runs + ([populate] if populate else [])
    unexpected = [r for r in every if r["exit_code"] not in accepted]
    return {
        "scenario": name,
        "condition": condition,
        "command": runner.command(code, arguments)[1:],
        "accepted_exit_codes": list(accepted),
        "median_wall_s": statistics.median(walls),
        "min_wall_s": min(walls),
        "max_wall_s": max(walls),
        "median_cpu_s": statistics.median(r["cpu_s"] for r in runs),
        "exit_codes": sorted({r["exit_code"] for r in every}, key=str),
        "ok": not unexpected and probe["exit_code"] in accepted,
        "failure": unexpected[0]["stderr"][-2000:] if unexpected else None,
        "runs": [{k: r[k] for k in ("wall_s", "cpu_s", "exit_code")} for r in runs],
        "cache_bytes": cache_bytes if warm else None,
        "exported_bytes": exported_bytes if warm else None,
        "populate_run": {k: populate[k] for k in ("wall_s", "cpu_s", "exit_code")}
        if populate else None,
        "probe": probe,
    }


# --------------------------------------------------------------------------------------
# Report.


def markdown(report: dict) -> str:
    meta = report["meta"]
    lines = [
        f"# Start-up and compile cost of the `jaxsubdiv` command ({meta['label']})",
        "",
        f"{meta['date']}; {meta['machine']}; Python {meta['python']}, jax {meta['jax']}; "
        f"jaxsubdiv from `{meta['jaxsubdiv_file']}` ({meta['source']}); load average "
        f"{meta['load_average_at_start'][0]:.1f} at start, "
        f"{meta['load_average_at_end'][0]:.1f} at end"
        + ("; **smoke run**" if meta["smoke"] else "")
        + ".",
        f"Fresh processes, {meta['repeat']} timed run(s) per row. Each runs "
        "`python -c \"import sys; from jaxsubdiv._cli import main; sys.exit(main())\" ARGS` "
        "(`import`: `python -c \"import jaxsubdiv\"`) with a private `XDG_CACHE_HOME`; "
        f"`{CACHE_VARIABLE}` is a fresh empty folder per run (`cold`, and `-`), or one "
        "filled by an untimed run of the same command (`warm`). CPU = user + sys of the "
        "child. Compilation columns come from one extra untimed run with `jax.monitoring` "
        "listeners: counts of XLA compilations (including persistent-cache retrievals) and "
        "summed seconds of tracing, lowering to MLIR and XLA compilation (nested traces "
        "are counted in each enclosing trace too).",
        "",
        "| scenario | condition | median wall s | min-max | CPU s | exit | compiles "
        "| trace s | lower s | compile s | cache hits / misses |",
        "|---|---|---:|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    notes = []
    for r in report["results"]:
        p = r["probe"]
        if p.get("monitored"):
            counts = [str(p["compile"]), f"{p['trace_s']:.2f} ({p['trace']})",
                      f"{p['lower_s']:.2f} ({p['lower']})", f"{p['compile_s']:.2f}",
                      f"{p['cache_hits']} / {p['cache_misses']}"]
        else:
            counts = ["", "", "", "", ""]
            if "jax_imported" in p:
                notes.append(f"- `{r['scenario']}` imports jax: "
                             f"{'yes' if p['jax_imported'] else 'no'}.")
        exits = ", ".join(str(c) for c in r["exit_codes"]) + ("" if r["ok"] else " (!)")
        lines.append(
            f"| {r['scenario']} | {r['condition']} | {r['median_wall_s']:.2f} "
            f"| {r['min_wall_s']:.2f}-{r['max_wall_s']:.2f} | {r['median_cpu_s']:.2f} "
            f"| {exits} | " + " | ".join(counts) + " |"
        )
        if r.get("cache_bytes"):
            notes.append(f"- `{r['scenario']}` leaves {r['cache_bytes'] / 1e3:.0f} kB in the "
                         f"cache folder, {r['exported_bytes'] / 1e3:.0f} kB of it exported "
                         "fit programs.")
        if not r["ok"]:
            notes.append(f"- `{r['scenario']}` ({r['condition']}): unexpected exit code or "
                         f"probe failure; see the JSON for stderr.")
        elif 1 in r["exit_codes"]:  # accepted only where it means "did not converge"
            notes.append(f"- `{r['scenario']}` ({r['condition']}): a fit did not converge "
                         "(exit code 1).")
    lines += ["", "Trace and lower columns: seconds (number of events). Cache misses are "
              "entries JAX wrote: none without a cache folder, nor (by JAX's default) for "
              "compilations under 1 s (`jax_persistent_cache_min_compile_time_secs`)."]
    if notes:
        lines += ["", *notes]
    return "\n".join(lines) + "\n"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.machine()


def _git_state(tree: Path) -> str:
    """`commit` or `commit + uncommitted changes`: which code a run measured."""
    try:
        commit = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(tree), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "not a git tree"
    return f"git {commit}" + (" + uncommitted changes" if dirty else "")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--smoke", action="store_true", help="one run per case")
    parser.add_argument("--repeat", type=int, help="timed runs per case (default 5; smoke 1)")
    parser.add_argument("--src", type=Path,
                        help="source tree to measure (prepended to PYTHONPATH in the children)")
    parser.add_argument("--label", default="", help="a name for this run, kept in the output")
    parser.add_argument("--scenarios", default=",".join(SCENARIOS),
                        help=f"comma-separated subset of {', '.join(SCENARIOS)}")
    parser.add_argument("--output", type=Path, help="JSON path (.md goes beside it)")
    args = parser.parse_args(argv)
    chosen = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    unknown = [s for s in chosen if s not in SCENARIOS]
    if unknown:
        parser.error(f"unknown scenario(s) {', '.join(unknown)}; choose from {', '.join(SCENARIOS)}")
    repeat = args.repeat or (1 if args.smoke else 5)
    src = args.src.resolve() if args.src else None
    output = args.output or RESULTS / ("startup_smoke.json" if args.smoke else "startup.json")

    load_at_start = list(os.getloadavg())
    results = []
    with tempfile.TemporaryDirectory(prefix="bench-startup-") as scratch:
        runner = Runner(Path(scratch), src)
        write_two_contours(Path(scratch) / "two.json")
        # Untimed: builds matplotlib's font cache in the private XDG_CACHE_HOME (a user
        # has one already) and brings the libraries into the OS file cache, so the first
        # scenario does not pay for either.
        warmup = runner.run(IMPORT + "; import matplotlib.font_manager", [], runner.fresh_cache())
        if warmup["exit_code"] != 0:
            print(f"`import jaxsubdiv` fails:\n{warmup['stderr']}", file=sys.stderr)
            return 1
        for name in chosen:
            for condition in ("cold", "warm") if SCENARIOS[name][3] else ("-",):
                began = time.perf_counter()
                result = measure(runner, name, condition, repeat)
                results.append(result)
                print(f"{name:16s} {condition:5s} median {result['median_wall_s']:6.2f} s  "
                      f"({time.perf_counter() - began:5.1f} s)"
                      + ("" if result["ok"] else "  UNEXPECTED EXIT CODE"), flush=True)

    # The tree the children imported (the probe saw it), whether or not --src was given.
    probed = next((r["probe"]["jaxsubdiv_file"] for r in results
                   if r["probe"].get("jaxsubdiv_file")), None)
    tree = Path(probed).parent.parent if probed else src
    report = {
        "meta": {
            "label": args.label or "(no label)",
            "date": datetime.datetime.now().isoformat(timespec="seconds"),
            "machine": f"{_cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
            "python": platform.python_version(),
            "jax": importlib.metadata.version("jax"),
            "jaxlib": importlib.metadata.version("jaxlib"),
            "jaxsubdiv_file": probed,
            "src": str(src) if src else None,
            "source": _git_state(tree) if tree else "unknown",
            "smoke": args.smoke,
            "repeat": repeat,
            "scenarios": chosen,
            "load_average_at_start": load_at_start,
            "load_average_at_end": list(os.getloadavg()),
            "cache_variable": CACHE_VARIABLE,
        },
        "results": results,
    }
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(json.dumps(report, indent=2) + "\n")
    table = markdown(report)
    output.with_suffix(".md").write_text(table)
    print()
    print(table)
    print(f"wrote {output} and {output.with_suffix('.md')}")
    return 0 if all(r["ok"] for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
