"""Fit programs kept on disk as exported StableHLO, so a new process neither traces nor
lowers them.

JAX's persistent compilation cache (`jaxsubdiv.enable_compilation_cache`) saves the XLA
compilation of a program, but every process still traces the Python code into a jaxpr
and lowers it to StableHLO before it can look the program up: about two seconds for a
fit on a 2-core machine, most of a warm command's time. `jax.export` serialises the
lowered program; loading it takes milliseconds, and calling it compiles (or loads from
the persistent cache) the same XLA program every time.

Used by `fitting.fit` when the persistent cache is on and the call is concrete (not
under `jit` or `grad`, whose traces need the Python function itself). Programs live in
`<compilation cache>/jaxsubdiv-exported/`, one file per key: the static settings, the
argument structure, shapes and dtypes, the backend, JAX's version, and a digest of
`fitting`'s and `jaxsubdiv`'s source, so that a changed library never runs an old
program. A file that cannot be read is replaced; one that cannot be written is skipped.
"""

import functools
import hashlib
import os
import tempfile
from pathlib import Path

import jax


# key -> Exported; its `call` compiles once per process, like a jitted function.
_LOADED: dict = {}


def folder() -> Path | None:
    """Where exported programs are kept: beside JAX's compiled ones, or None when the
    persistent compilation cache is off."""
    base = jax.config.jax_compilation_cache_dir
    return Path(base) / "jaxsubdiv-exported" if base else None


@functools.cache
def _source_digest() -> str:
    """A digest of the Python source of `fitting` and `jaxsubdiv`, and JAX's version."""
    import jaxsubdiv

    digest = hashlib.sha256(jax.__version__.encode())
    for package in (Path(__file__).parent, Path(jaxsubdiv.__file__).parent):
        for path in sorted(package.rglob("*.py")):
            digest.update(path.relative_to(package.parent).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _key(name: str, static: dict, treedef, leaves) -> str:
    shapes = tuple((jax.numpy.shape(x), str(jax.numpy.result_type(x))) for x in leaves)
    text = repr((name, sorted(static.items()), str(treedef), shapes, jax.default_backend(),
                 _source_digest()))
    return hashlib.sha256(text.encode()).hexdigest()[:40]


def _load(path: Path):
    try:
        return jax.export.deserialize(bytearray(path.read_bytes()))
    except FileNotFoundError:
        return None
    except Exception:  # noqa: BLE001  (a truncated or foreign file: export again)
        return None


def _store(path: Path, exported) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # Written whole, then renamed: a concurrent reader never sees half a file.
        handle, temporary = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(handle, "wb") as f:
            f.write(exported.serialize())
        os.replace(temporary, path)
    except OSError:
        pass  # a read-only cache: the program is still used in this process


def call(function, args: tuple, static: dict, out_treedef):
    """`function(*args, **static)` through an exported program (`args` concrete).

    `out_treedef` is the structure of the result: an exported program returns its
    leaves only."""
    leaves, treedef = jax.tree.flatten(args)
    key = _key(function.__qualname__, static, treedef, leaves)
    exported = _LOADED.get(key)
    if exported is None:
        path = folder() / f"{key}.jaxexport"
        exported = _load(path)
        if exported is None:
            def flat(*leaves):
                return jax.tree.leaves(function(*jax.tree.unflatten(treedef, leaves), **static))

            exported = jax.export.export(jax.jit(flat))(*leaves)
            _store(path, exported)
        _LOADED[key] = exported
    outputs = exported.call(*leaves)
    if len(outputs) != out_treedef.num_leaves:  # static structure: a defect, never data
        raise AssertionError(f"exported {function.__qualname__} returned {len(outputs)} "
                             f"leaves for a structure of {out_treedef.num_leaves}")
    return jax.tree.unflatten(out_treedef, outputs)
