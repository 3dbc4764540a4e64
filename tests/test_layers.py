"""The import graph of `jaxsubdiv` and `fitting` runs one way: from applications down to
the core, never up and never in a circle (#13).

The graph is read statically (`ast`) from every `import` and `from ... import` in every
module, including those inside functions (a deferred import is still a dependency; it
only moves the cost), except inside `if TYPE_CHECKING:` blocks, which run for type
checkers only. `jaxsubdiv/__init__.py` loads its public names lazily from the `_PUBLIC`
table, so a use of `jaxsubdiv.NAME` (`import jaxsubdiv as js; js.refine`, or
`from jaxsubdiv import refine`) is an edge to the module that table names. Each module
gets a layer from the `LAYERS` table below; the test fails on a cycle, on an import of a
higher layer, and on a `fitting` module that imports a private `jaxsubdiv._x` module
(fitting is a client of jaxsubdiv's public API).

Two start-up checks run in fresh interpreters: `import jaxsubdiv` loads no JAX,
matplotlib, equinox, fitting or editor, and the installed `jaxsubdiv --help` command
answers without importing JAX.
"""

import ast
import fnmatch
import importlib.metadata
import json
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest


ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("jaxsubdiv", "fitting")

# Layers, lowest first: a module may import its own layer and lower ones. Patterns are
# `fnmatch` patterns over dotted module names (`*` also matches dots). A new module must
# match exactly one layer: add it here.
LAYERS = (
    ("core", (
        "jaxsubdiv",  # the package itself: a lazy table, it imports nothing eagerly
        "jaxsubdiv._misc",
        "jaxsubdiv._scheme", "jaxsubdiv._scheme.*",
        "jaxsubdiv._kernel",
        "jaxsubdiv._refine",
        "jaxsubdiv._curve_stencil",
        "jaxsubdiv.validation",
    )),
    ("analysis", ("jaxsubdiv._analysis", "jaxsubdiv._analysis.*")),
    ("surfaces", ("jaxsubdiv.surfaces", "jaxsubdiv.surfaces.*")),
    ("fitting", ("fitting", "fitting.*")),
    ("io and plot", (
        "jaxsubdiv.io", "jaxsubdiv._io", "jaxsubdiv._io.*",
        "jaxsubdiv.plot", "jaxsubdiv._plot",
        "jaxsubdiv.shapes",
        "jaxsubdiv._cache",
    )),
    ("applications", (
        "jaxsubdiv._cli", "jaxsubdiv._editor*", "jaxsubdiv.editor",
        "jaxsubdiv._xla_flags",  # the command's own XLA flags
    )),
)  # fmt: skip

# --------------------------------------------------------------------------- the graph


def _module_files() -> dict[str, Path]:
    files = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            files[".".join(parts)] = path
    return files


MODULES = _module_files()


def _is_package(module: str) -> bool:
    return MODULES[module].name == "__init__.py"


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _runtime_nodes(tree: ast.AST):
    """Every node of `tree` except those under an `if TYPE_CHECKING:` (its `else` runs)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            stack.extend(node.orelse)
            continue
        stack.extend(ast.iter_child_nodes(node))


def _public_table() -> dict[str, str]:
    """`jaxsubdiv._PUBLIC`, read from the source: public name -> defining module."""
    tree = ast.parse(MODULES["jaxsubdiv"].read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "_PUBLIC" for t in node.targets
        ):
            table = ast.literal_eval(node.value)
            return {
                name: f"jaxsubdiv{where}" if where else f"jaxsubdiv.{name}"
                for name, where in table.items()
            }
    raise AssertionError("jaxsubdiv/__init__.py has no `_PUBLIC` table")


PUBLIC = _public_table()


def _known(name: str) -> str | None:
    """The longest prefix of a dotted name that is one of our modules."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        prefix = ".".join(parts[:end])
        if prefix in MODULES:
            return prefix
    return None


def _resolve_from(importer: str, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module
    package = importer if _is_package(importer) else importer.rpartition(".")[0]
    for _ in range(node.level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{node.module}" if node.module else package


def _targets(importer: str, spelled: str) -> list[str]:
    """The modules that importing `spelled` runs, as seen from `importer`: the module
    and the packages above it (their `__init__`s run first), except the packages that
    contain `importer` (they are already being imported)."""
    module = _known(spelled)
    if module is None:
        return []
    out = [module]
    parts = module.split(".")
    for end in range(1, len(parts)):
        package = ".".join(parts[:end])
        if not (importer == package or importer.startswith(package + ".")):
            out.append(package)
    return out


def _imports(module: str) -> list[tuple[str, str, str, int]]:
    """(module run, module named, the name as written, line) for every runtime import:
    the module named and the packages above it are run."""
    tree = ast.parse(MODULES[module].read_text(), filename=str(MODULES[module]))
    found = []  # (spelled name, line)
    facade_aliases = set()  # local names bound to the `jaxsubdiv` package
    for node in _runtime_nodes(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found.append((alias.name, node.lineno))
                if alias.name == "jaxsubdiv" or (
                    alias.asname is None and alias.name.startswith("jaxsubdiv.")
                ):
                    facade_aliases.add(alias.asname or "jaxsubdiv")
        elif isinstance(node, ast.ImportFrom):
            base = _resolve_from(module, node)
            for alias in node.names:
                full = f"{base}.{alias.name}"
                if full in MODULES:  # a submodule
                    found.append((full, node.lineno))
                elif base == "jaxsubdiv" and alias.name in PUBLIC:  # a lazy public name
                    found.append((full, node.lineno))
                else:
                    found.append((base, node.lineno))
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
            and not node.args[0].value.startswith(".")
        ):
            found.append((node.args[0].value, node.lineno))
    # `js.NAME` where `js` is the package: the lazy table imports NAME's module.
    for node in _runtime_nodes(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in facade_aliases
        ):
            full = f"jaxsubdiv.{node.attr}"
            if node.attr in PUBLIC or full in MODULES:
                found.append((full, node.lineno))
    edges = []
    for spelled, line in dict.fromkeys(found):  # `from x import a, b`: one edge
        resolved = PUBLIC.get(spelled.removeprefix("jaxsubdiv."), spelled) if (
            spelled.startswith("jaxsubdiv.") and spelled.count(".") == 1
        ) else spelled
        targets = _targets(module, resolved)
        for target in targets:
            if target != module:
                edges.append((target, targets[0], spelled, line))
    return edges


def _graph() -> dict[str, dict[str, list[tuple[str, int]]]]:
    """importer -> imported -> [(name as written, line)]."""
    graph = {}
    for module in MODULES:
        out = graph.setdefault(module, {})
        for target, _, spelled, line in _imports(module):
            out.setdefault(target, []).append((spelled, line))
    return graph


def _layer(module: str) -> int:
    matches = [
        i for i, (_, patterns) in enumerate(LAYERS)
        if any(fnmatch.fnmatchcase(module, p) for p in patterns)
    ]
    assert len(matches) == 1, (
        f"module {module} matches {'no' if not matches else 'more than one'} layer of "
        f"tests/test_layers.py: add it to exactly one layer of the `LAYERS` table "
        f"(matches: {[LAYERS[i][0] for i in matches]})."
    )
    return matches[0]


def _strongly_connected(graph: dict[str, dict]) -> list[list[str]]:
    """Tarjan's algorithm (iterative): the strongly connected components."""
    index, low, on_stack, stack, components = {}, {}, set(), [], []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(graph.get(child, {}))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    components.append(component)
    return components


def _a_cycle(graph, component: list[str]) -> list[str]:
    """One cycle through the component's first module (breadth-first, so a shortest)."""
    members, start = set(component), component[0]
    previous = {start: None}
    queue = [start]
    while queue:
        node = queue.pop(0)
        for child in graph[node]:
            if child == start:
                path = [node]
                while previous[path[-1]] is not None:
                    path.append(previous[path[-1]])
                return [start, *reversed(path[:-1]), start] if node != start else [start, start]
            if child in members and child not in previous:
                previous[child] = node
                queue.append(child)
    raise AssertionError(f"no cycle found in the component {component}")


def _file(module: str) -> str:
    path = MODULES[module]
    return str(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path)


def _where(graph, importer, imported) -> str:
    spelled, line = graph[importer][imported][0]
    return f"{_file(importer)}:{line} ({spelled})"


# ------------------------------------------------------------------------------ the tests


def test_every_module_has_a_layer():
    for module in MODULES:
        _layer(module)


def test_no_import_cycles():
    graph = _graph()
    cycles = []
    for component in _strongly_connected(graph):
        if len(component) > 1 or component[0] in graph[component[0]]:
            cycle = _a_cycle(graph, sorted(component))
            steps = [f"    {a} -> {b} at {_where(graph, a, b)}" for a, b in zip(cycle, cycle[1:])]
            cycles.append(" -> ".join(cycle) + "\n" + "\n".join(steps))
    assert not cycles, "import cycles (move the shared piece down a layer):\n" + "\n".join(cycles)


def test_imports_go_down_the_layers():
    graph = _graph()
    upward = [
        f"{importer} ({LAYERS[_layer(importer)][0]}) imports {imported} "
        f"({LAYERS[_layer(imported)][0]}) at {_where(graph, importer, imported)}"
        for importer, targets in graph.items()
        for imported in targets
        if _layer(imported) > _layer(importer)
    ]
    assert not upward, "imports of a higher layer:\n" + "\n".join(sorted(upward))


def _private(spelled: str) -> bool:
    return spelled.startswith("jaxsubdiv.") and any(
        part.startswith("_") for part in spelled.split(".")[1:]
    )


def test_fitting_uses_only_public_jaxsubdiv():
    graph = _graph()
    private = [
        f"{importer} imports {spelled} at {_file(importer)}:{line}"
        for importer, targets in graph.items()
        if importer.split(".")[0] == "fitting"
        for uses in targets.values()
        for spelled, line in uses
        if _private(spelled)
    ]
    assert not private, (
        "fitting imports private jaxsubdiv modules (use `jaxsubdiv` and its public "
        "submodules):\n" + "\n".join(sorted(set(private)))
    )


# The checker itself, on made-up graphs and sources (so a silent checker cannot pass).


def test_tarjan_finds_the_components_of_a_known_graph():
    graph = {"a": {"b": 0}, "b": {"c": 0}, "c": {"a": 0, "d": 0}, "d": {"e": 0},
             "e": {"d": 0}, "f": {"f": 0}, "g": {}}  # fmt: skip
    components = sorted(sorted(c) for c in _strongly_connected(graph))
    assert components == [["a", "b", "c"], ["d", "e"], ["f"], ["g"]]
    assert _a_cycle(graph, ["a", "b", "c"]) == ["a", "b", "c", "a"]
    assert _a_cycle(graph, ["f"]) == ["f", "f"]


def test_reader_sees_deferred_imports_and_skips_type_checking(tmp_path, monkeypatch):
    source = textwrap.dedent(
        """
        from typing import TYPE_CHECKING
        import jaxsubdiv as js
        from .. import _refine
        from ..plot import plot_curve
        if TYPE_CHECKING:
            from jaxsubdiv._cli import main
        else:
            from .local import eigen
        def f():
            from jaxsubdiv import io
            return js.smoothness, js.surfaces.Mesh
        """
    )
    path = tmp_path / "probe.py"
    path.write_text(source)
    monkeypatch.setitem(MODULES, "jaxsubdiv._analysis.probe", path)
    found = {(target, spelled) for target, _, spelled, _ in _imports("jaxsubdiv._analysis.probe")}
    assert found == {
        ("jaxsubdiv", "jaxsubdiv"),
        ("jaxsubdiv._refine", "jaxsubdiv._refine"),
        ("jaxsubdiv.plot", "jaxsubdiv.plot"),
        ("jaxsubdiv._analysis.local", "jaxsubdiv._analysis.local"),
        ("jaxsubdiv.io", "jaxsubdiv.io"),
        ("jaxsubdiv._analysis.smoothness", "jaxsubdiv.smoothness"),
        ("jaxsubdiv.surfaces", "jaxsubdiv.surfaces"),
    }  # no jaxsubdiv._cli: it is under TYPE_CHECKING


def test_checks_fail_on_planted_violations(tmp_path, monkeypatch):
    """A core module importing the plot layer, two analysis modules importing each other
    from inside functions, and fitting importing `jaxsubdiv._misc` are all caught."""
    planted = {
        "jaxsubdiv._scheme.probe": "from ..plot import plot_curve\n",
        "jaxsubdiv._analysis.probe_a": "def f():\n    from . import probe_b\n",
        "jaxsubdiv._analysis.probe_b": "def g():\n    from .probe_a import f\n",
        "fitting.probe": "import jaxsubdiv as js\nx = js._misc\n",
    }
    for module, source in planted.items():
        path = tmp_path / f"{module}.py"
        path.write_text(source)
        monkeypatch.setitem(MODULES, module, path)
    with pytest.raises(AssertionError, match=r"jaxsubdiv._scheme.probe \(core\) imports "
                       r"jaxsubdiv.plot \(io and plot\)"):
        test_imports_go_down_the_layers()
    with pytest.raises(AssertionError, match=r"jaxsubdiv._analysis.probe_a -> "
                       r"jaxsubdiv._analysis.probe_b -> jaxsubdiv._analysis.probe_a"):
        test_no_import_cycles()
    with pytest.raises(AssertionError, match=r"fitting.probe imports jaxsubdiv._misc"):
        test_fitting_uses_only_public_jaxsubdiv()
    monkeypatch.setitem(MODULES, "jaxsubdiv.nowhere", tmp_path / "nowhere.py")
    with pytest.raises(AssertionError, match="add it to exactly one layer"):
        test_every_module_has_a_layer()


# ---------------------------------------------------------------------- start-up weight


def _loaded_after(code: str) -> list[str]:
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def _heavy(module: str) -> bool:
    """JAX and what needs it, matplotlib, and the fitting package."""
    top = module.split(".")[0]
    return top in ("jax", "jaxlib", "equinox", "optimistix", "lineax", "matplotlib", "fitting")


def _editor(module: str) -> bool:
    return fnmatch.fnmatchcase(module, "jaxsubdiv._editor*") or module == "jaxsubdiv.editor"


def test_import_jaxsubdiv_loads_no_jax_matplotlib_equinox_fitting_or_editor():
    loaded = _loaded_after("""
        import json, sys
        import jaxsubdiv
        print(json.dumps(sorted(sys.modules)))
    """)
    assert [m for m in loaded if _heavy(m) or _editor(m)] == []
    # Only the lazy table of the package itself: no submodule is imported eagerly.
    assert [m for m in loaded if m.startswith("jaxsubdiv.")] == []


def test_console_command_help_answers_without_jax():
    """The installed `jaxsubdiv` command (the entry point pyproject.toml declares), run
    with `-X importtime`, whose report lists every module the process imported."""
    scripts = (ROOT / "pyproject.toml").read_text().split("[project.scripts]")[1]
    declared = dict(re.findall(r'^([\w-]+) = "([^"]+)"$', scripts.split("\n[")[0], re.M))
    (entry,) = importlib.metadata.entry_points(group="console_scripts", name="jaxsubdiv")
    assert entry.value == declared["jaxsubdiv"] == "jaxsubdiv._cli:main"
    script = shutil.which("jaxsubdiv", path=str(Path(sys.executable).parent))
    if script is None:
        pytest.skip("the `jaxsubdiv` command is not installed next to this Python")
    result = subprocess.run([sys.executable, "-X", "importtime", script, "--help"],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: jaxsubdiv")
    imported = {
        line.split("|")[-1].strip()
        for line in result.stderr.splitlines()
        if line.startswith("import time:") and "|" in line
    }
    assert "jaxsubdiv._cli" in imported  # the report is read right
    assert sorted(m for m in imported if _heavy(m)) == []
