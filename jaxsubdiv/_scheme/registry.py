"""The registry of curve schemes: what each one is called, and its parameters.

Each scheme declares itself ONCE, in its own file, with class variables:

```python
class FourPoint(AbstractCurveScheme):
    scheme_name: ClassVar[str] = "four-point"         # command-line name
    scheme_title: ClassVar[str] = "four-point"        # human title
    scheme_parameters: ClassVar[tuple[Parameter, ...]] = (TENSION,)
```

and everything else derives from that: the constructors' range checks, the command
line's options, defaults and help, the editor's sliders, the JSON reader/writer, the fit's
reparameterisation (`AbstractCurveScheme.to_unconstrained`), and the docs' table
(`markdown_table`). A new scheme is one new file in `jaxsubdiv/_scheme/`.

How the schemes are found: every module of the `jaxsubdiv._scheme` package is imported
(`pkgutil`), and every class defined there with a `scheme_name` of its own is an entry.
The order is fixed: by module name, then by order of definition in the module. A module
list would be a second place to edit when adding a scheme, so there is none.

The command line must answer `--help` and usage errors without importing JAX, and
importing a scheme module imports JAX. So `declarations()` reads the same class
variables from the modules' source (`ast`) without running it: declarations are plain
data (numbers, strings, tuples, `Parameter(...)` and module constants built from them).
A test checks that what it reads equals the imported classes' declarations.
"""

import ast
import dataclasses
import functools
import importlib
import pkgutil
from pathlib import Path

from .parameter import Parameter as Parameter, SchemeInfo as SchemeInfo, number_text


_PACKAGE = __name__.rpartition(".")[0]  # "jaxsubdiv._scheme"
# Modules of the package that hold no scheme (skipped when collecting).
_NOT_SCHEMES = frozenset({"base", "parameter", "registry"})


@dataclasses.dataclass(frozen=True)
class Declaration:
    """A scheme's declaration read without importing it (for the command line):
    `SchemeInfo` without the class, which `info()` imports."""

    name: str
    title: str
    class_name: str
    module: str
    parameters: tuple[Parameter, ...]
    listed: bool = True

    def info(self) -> SchemeInfo:
        return scheme_info(self.name)


def _scheme_modules() -> list[str]:
    path = Path(__file__).parent
    return sorted(
        m.name for m in pkgutil.iter_modules([str(path)])
        if not m.ispkg and m.name not in _NOT_SCHEMES
    )


def _info_from_class(cls) -> SchemeInfo:
    own = vars(cls)
    return SchemeInfo(
        name=own["scheme_name"],
        title=own.get("scheme_title", own["scheme_name"]),
        cls=cls,
        parameters=tuple(own.get("scheme_parameters", ())),
        listed=own.get("scheme_listed", True),
    )


@functools.cache
def _all_infos() -> dict[str, SchemeInfo]:
    """Every declared scheme, listed or not, by name (imports JAX)."""
    base = importlib.import_module(f"{_PACKAGE}.base")
    infos = {}
    for module_name in _scheme_modules():
        module = importlib.import_module(f"{_PACKAGE}.{module_name}")
        for value in vars(module).values():
            if (
                isinstance(value, type)
                and issubclass(value, base.AbstractCurveScheme)
                and value.__module__ == module.__name__
                and "scheme_name" in vars(value)
            ):
                info = _info_from_class(value)
                if info.name in infos:
                    raise RuntimeError(
                        f"two schemes are named {info.name!r}: {infos[info.name].cls} and "
                        f"{value}."
                    )
                infos[info.name] = info
    return infos


def schemes() -> dict[str, SchemeInfo]:
    """All built-in curve schemes with parameters the registry can build, by name.

    In a fixed order: by the name of the module that defines them (`chaikin`,
    `corner_cutting`, `cubic_bspline`, `daubechies`, `four_point`, `lane_riesenfeld`,
    `split_tweak`), then in order of definition. `MaskScheme` is not listed (its mask is
    its argument) but has an entry: `scheme_info(MaskScheme)`.
    """
    return {name: info for name, info in _all_infos().items() if info.listed}


def scheme_info(x) -> SchemeInfo:
    """The registry entry of `x`: a scheme instance, a scheme class or a registry name
    (`"four-point"`). A class outside the package that declares `scheme_name` (and
    `scheme_parameters`) gets an entry too."""
    infos = _all_infos()
    if isinstance(x, str):
        if x in infos:
            return infos[x]
        raise ValueError(
            f"unknown scheme {x!r}; the schemes are {', '.join(infos)}."
        )
    cls = x if isinstance(x, type) else type(x)
    for info in infos.values():
        if info.cls is cls:
            return info
    base = importlib.import_module(f"{_PACKAGE}.base")
    if issubclass(cls, base.AbstractCurveScheme) and "scheme_name" in vars(cls):
        return _info_from_class(cls)
    if issubclass(cls, base.AbstractCurveScheme):
        raise ValueError(
            f"{cls.__name__} is not in the scheme registry: declare the class variables "
            "`scheme_name`, `scheme_title` and `scheme_parameters` on it."
        )
    raise TypeError(
        f"`scheme_info` takes a curve scheme, a scheme class or a scheme name (one of "
        f"{', '.join(infos)}); got {x!r}."
    )


# --------------------------------------------------------------- without importing JAX


_DECLARED = ("scheme_name", "scheme_title", "scheme_parameters", "scheme_listed")


def _evaluate(node, namespace):
    code = compile(ast.Expression(node), "<declaration>", "eval")
    return eval(code, {"__builtins__": {}}, namespace)  # our own package's source


def _read_declarations(module_name: str) -> list[Declaration]:
    path = Path(__file__).with_name(f"{module_name}.py")
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    namespace = {"Parameter": Parameter, "True": True, "False": False, "None": None}
    found = []
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            try:  # module constants built from plain data; others are skipped
                value = _evaluate(node.value, namespace)
            except Exception:
                continue
            for target in targets:
                if isinstance(target, ast.Name):
                    namespace[target.id] = value
        elif isinstance(node, ast.ClassDef):
            declared = {}
            for item in node.body:
                if (
                    isinstance(item, (ast.Assign, ast.AnnAssign))
                    and item.value is not None
                ):
                    targets = item.targets if isinstance(item, ast.Assign) else [item.target]
                    for target in targets:
                        if isinstance(target, ast.Name) and target.id in _DECLARED:
                            declared[target.id] = _evaluate(item.value, namespace)
            if "scheme_name" in declared:
                name = declared["scheme_name"]
                found.append(Declaration(
                    name=name,
                    title=declared.get("scheme_title", name),
                    class_name=node.name,
                    module=f"{_PACKAGE}.{module_name}",
                    parameters=tuple(
                        dataclasses.replace(p, scheme=p.scheme or node.name)
                        for p in declared.get("scheme_parameters", ())
                    ),
                    listed=declared.get("scheme_listed", True),
                ))
    return found


@functools.cache
def _all_declarations() -> dict[str, Declaration]:
    return {d.name: d for m in _scheme_modules() for d in _read_declarations(m)}


def declarations() -> dict[str, Declaration]:
    """The listed schemes' declarations, as `schemes()` lists them, read from source
    without importing JAX (for the command line's options and `--help`)."""
    return {name: d for name, d in _all_declarations().items() if d.listed}


# ------------------------------------------------------------------------ docs table


_TABLE_START = "<!-- scheme table: generated by jaxsubdiv._scheme.registry.markdown_table() -->"
_TABLE_END = "<!-- end of scheme table -->"


def markdown_table() -> str:
    """The docs' table of curve schemes and their parameters (README.md), from the
    registry; a test checks that the README holds exactly this text between its markers.
    """
    clamped = {
        "reflect": "closed, open, clamped (reflected ghost points)",
        "repeat": "closed, open, clamped (end points repeated as ghosts)",
        None: "closed, open",
    }
    rows = [
        "| scheme | command line | parameters: default, valid range | a fit keeps | "
        "boundaries |",
        "|---|---|---|---|---|",
    ]
    for info in _all_infos().values():
        if info.listed:
            arguments = ", ".join(p.name for p in info.parameters)
            name = f"`{info.name}`"
        else:
            arguments = "coefficients, start"
            name = "—"
        parameters = "; ".join(
            f"{p.name} = {number_text(p.default)}, {p.range_text()}"
            + (f" (converges for {p.converges_text()})" if p.converges else "")
            for p in info.parameters
        ) or "—"
        relation = getattr(info.cls, "scheme_relation", None)
        if relation:
            parameters += f"; {relation}"
        fitted = "; ".join(
            f"{number_text(p.fit_interval[0])} < {p.name} < {number_text(p.fit_interval[1])}"
            + (" (C1)" if p.c1 is not None else " (chords: not C1)")
            for p in info.parameters if p.fit_interval is not None
        ) or "—"
        rows.append(
            f"| `{info.cls.__name__}({arguments})`: {info.title} | {name} | {parameters} | "
            f"{fitted} | {clamped[info.cls.clamp_ghost]} |"
        )
    return "\n".join([_TABLE_START, *rows, _TABLE_END])


def by_class_name() -> dict[str, SchemeInfo]:
    """Every entry, listed or not, by its class name (`"FourPoint"`): how result files
    name schemes."""
    return {info.cls.__name__: info for info in _all_infos().values()}
