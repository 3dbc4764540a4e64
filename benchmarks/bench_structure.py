"""Measure the code's structure: module sizes, the import graph, start-up and the test suite.

    python benchmarks/bench_structure.py                          # this tree
    python benchmarks/bench_structure.py --src /other/tree --label before
    python benchmarks/bench_structure.py --pytest-log ci.log      # also the suite's figures

Issue #13 asks for these before and after a restructuring, measured in one run:

- the largest modules of `jaxsubdiv/` and `fitting/` (lines);
- the import graph of both packages, read statically (every `import` anywhere in a
  module, inside functions too, except `if TYPE_CHECKING:` blocks): its cycles
  (strongly connected components of more than one module) and the places where
  `fitting` imports a private `jaxsubdiv._x` module;
- `python -X importtime -c "import jaxsubdiv"`: the total, and whether jax, equinox,
  matplotlib or `fitting` were loaded;
- `jaxsubdiv --help`: the wall time of a fresh process (`jaxsubdiv._cli.main`, so `--src`
  measures another tree the same way) and whether it imported jax;
- the `duplicates` tool's pair count, when that tool is on the PATH;
- with `--pytest-log`: the suite's pass line and the XLA compilation count printed by
  `tests/conftest.py`.

Timings are medians of `--repeat` fresh processes. Writes `results/structure.json` and
`results/structure.md` (or `--output`'s stem). Standard library only.
"""

import argparse
import ast
import datetime
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path


HERE = Path(__file__).resolve().parent
PACKAGES = ("jaxsubdiv", "fitting")
HEAVY = ("jax", "equinox", "matplotlib", "fitting", "jaxsubdiv.editor", "jaxsubdiv._editor")


def modules(src: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every module of the two packages."""
    found = {}
    for package in PACKAGES:
        for path in sorted((src / package).rglob("*.py")):
            parts = path.relative_to(src).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imports(name: str, path: Path, known: dict) -> set[str]:
    """The modules of `known` that module `name` imports, outside TYPE_CHECKING blocks."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()

    def visit(node):
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        targets = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                # `from p import m` depends on the module p.m when there is one, else on p
                submodule = f"{module}.{alias.name}"
                targets.append(submodule if submodule in known else module)
        found.update(t for t in targets if t in known and t != name)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text(encoding="utf-8")))
    return found


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, on_stack, stack, result = {}, {}, set(), [], []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            advanced = False
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    advanced = True
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    result.append(sorted(component))
    return result


def _child_env(src: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(src) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _median_run(command: list[str], src: Path, repeat: int) -> tuple[float, str]:
    times, output = [], ""
    for _ in range(repeat):
        start = time.perf_counter()
        done = subprocess.run(command, env=_child_env(src), capture_output=True, text=True,
                              cwd=HERE.anchor)
        times.append(time.perf_counter() - start)
        output = done.stdout + done.stderr
    return statistics.median(times), output


def start_up(src: Path, repeat: int) -> dict:
    probe = (f"import sys, jaxsubdiv; print('LOADED', sorted(m for m in {HEAVY} "
             "if m in sys.modules))")
    import_seconds, output = _median_run([sys.executable, "-c", probe], src, repeat)
    loaded = re.search(r"LOADED (\[.*\])", output)
    _, timing = _median_run([sys.executable, "-X", "importtime", "-c", "import jaxsubdiv"],
                            src, 1)
    total = [int(m.group(1)) for m in re.finditer(r"\|\s+(\d+) \| jaxsubdiv$", timing, re.M)]
    helper = ("import sys; from jaxsubdiv._cli import main; sys.argv = ['jaxsubdiv', "
              "'--help']; code = main(); print('JAX', 'jax' in sys.modules); sys.exit(code)")
    help_seconds, output = _median_run([sys.executable, "-c", helper], src, repeat)
    return {
        "import_seconds": import_seconds,
        "import_loaded": ast.literal_eval(loaded.group(1)) if loaded else None,
        "importtime_us": total[-1] if total else None,
        "help_seconds": help_seconds,
        "help_imported_jax": "JAX True" in output,
    }


def duplicate_pairs(src: Path) -> int | None:
    if shutil.which("duplicates") is None:
        return None
    done = subprocess.run(["duplicates", "--most", "200", "--seconds", "120"], cwd=src,
                          capture_output=True, text=True)
    rows = len(re.findall(r"^D\d+ ", done.stdout, re.M))
    more = re.search(r"\(\+(\d+) more pairs\)", done.stdout)
    return rows + (int(more.group(1)) if more else 0)


def suite(log: Path) -> dict:
    text = log.read_bytes().replace(b"\0", b"").decode("utf-8", "replace")
    passed = re.findall(r"^(\d+ passed.*in [\d.]+s.*)$", text, re.M)
    compiled = re.search(r"XLA compilations in this process: (\d+) \(([\d.]+) s compiling",
                         text)
    return {
        "pytest": passed[-1] if passed else None,
        "compilations": int(compiled.group(1)) if compiled else None,
        "compile_seconds": float(compiled.group(2)) if compiled else None,
    }


def measure(src: Path, repeat: int, log: Path | None) -> dict:
    known = modules(src)
    graph = {name: imports(name, path, known) for name, path in known.items()}
    sizes = sorted(((len(path.read_text(encoding="utf-8").splitlines()), name)
                    for name, path in known.items()), reverse=True)
    private = sorted(f"{name} -> {target}" for name, targets in graph.items()
                     if name.split(".")[0] == "fitting" for target in targets
                     if target.startswith("jaxsubdiv.") and
                     any(part.startswith("_") for part in target.split(".")[1:]))
    result = {
        "largest_modules": [{"module": name, "lines": lines} for lines, name in sizes[:5]],
        "modules": len(known),
        "cycles": cycles(graph),
        "fitting_private_imports": private,
        "duplicate_pairs": duplicate_pairs(src),
        **start_up(src, repeat),
    }
    if log is not None:
        result.update(suite(log))
    return result


def markdown(record: dict) -> str:
    r = record["result"]
    lines = [
        f"# Code structure ({record['label']})",
        "",
        f"{record['date']}, `{record['src']}`, load {record['load']}, "
        f"{record['repeat']} runs per timing (median). Made by `benchmarks/bench_structure.py`.",
        "",
        "| figure | value |",
        "| --- | --- |",
        "| largest modules | " + ", ".join(f"`{m['module']}` {m['lines']}"
                                         for m in r["largest_modules"][:3]) + " |",
        f"| modules | {r['modules']} |",
        f"| import cycles | {len(r['cycles'])}: "
        + ("; ".join(" <-> ".join(c) for c in r["cycles"]) or "none") + " |",
        f"| `fitting` importing private jaxsubdiv modules | {len(r['fitting_private_imports'])}"
        + (": " + ", ".join(f"`{p}`" for p in r["fitting_private_imports"])
           if r["fitting_private_imports"] else "") + " |",
        f"| `import jaxsubdiv` | {r['import_seconds']:.3f} s wall, "
        f"{(r['importtime_us'] or 0) / 1e3:.1f} ms by -X importtime; loaded: "
        f"{', '.join(r['import_loaded'] or []) or 'none of ' + ', '.join(HEAVY)} |",
        f"| `jaxsubdiv --help` | {r['help_seconds']:.3f} s wall; imported jax: "
        f"{r['help_imported_jax']} |",
        f"| duplicate pairs (`duplicates`) | {r['duplicate_pairs']} |",
    ]
    if "pytest" in r:
        lines += [
            f"| test suite | {r['pytest']} |",
            f"| XLA compilations in the suite | {r['compilations']} "
            f"({r['compile_seconds']} s compiling) |",
        ]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--src", type=Path, default=HERE.parent, help="the source tree")
    parser.add_argument("--label", default="this tree")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--pytest-log", type=Path, help="a log of the test suite's run")
    parser.add_argument("--output", type=Path, default=HERE / "results" / "structure.json")
    args = parser.parse_args(argv)
    src = args.src.resolve()
    record = {
        "label": args.label,
        "src": str(src),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "load": " ".join(f"{x:.2f}" for x in os.getloadavg()),
        "repeat": args.repeat,
        "result": measure(src, args.repeat, args.pytest_log),
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(record, indent=2) + "\n")
    args.output.with_suffix(".md").write_text(markdown(record))
    print(markdown(record))
    return 0


if __name__ == "__main__":
    sys.exit(main())
