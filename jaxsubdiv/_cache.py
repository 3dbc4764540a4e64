"""JAX's persistent compilation cache, switched on for jaxsubdiv's programs.

A fit compiles an XLA program of a few megabytes in 3-10 s; the cache keeps it on disk,
so a later process that runs the same program (same shapes, scheme type and static
settings; see the shape buckets in `fitting`) loads it instead. Tracing and lowering are
not cached by JAX and are still paid once per process.
"""

import os
from pathlib import Path


#: Environment variable: a folder for the cache, or `off` to switch it off.
ENVIRONMENT_VARIABLE = "JAXSUBDIV_COMPILATION_CACHE"
#: Largest size of the cache folder; JAX deletes the least recently used entries beyond.
DEFAULT_MAX_SIZE = 2**30
_OFF = ("off", "0", "false", "no", "none")


def compilation_cache_dir() -> Path | None:
    """The folder the cache uses: `$JAXSUBDIV_COMPILATION_CACHE` if set, else
    `jaxsubdiv/xla` under `$XDG_CACHE_HOME` (default `~/.cache`); None if the variable
    is `off` (or `0`, `false`, `no`, `none`)."""
    value = os.environ.get(ENVIRONMENT_VARIABLE, "").strip()
    if value.lower() in _OFF:
        return None
    if value:
        return Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME", "").strip() or Path.home() / ".cache"
    return Path(base) / "jaxsubdiv" / "xla"


def enable_compilation_cache(
    path: str | os.PathLike | None = None, *, max_size: int = DEFAULT_MAX_SIZE
) -> Path | None:
    """Keep compiled XLA programs on disk, so that later processes load them instead of
    compiling again (JAX's persistent compilation cache).

    Call it once, before the first JAX computation of the process (JAX reads these
    settings when it first compiles). The `jaxsubdiv` command calls it unless
    `$JAXSUBDIV_COMPILATION_CACHE` is `off` or `--no-compilation-cache` is given.

    **Arguments:**

    - `path`: the folder; default [`jaxsubdiv.compilation_cache_dir`][] (which honours
      `$JAXSUBDIV_COMPILATION_CACHE`). Created if missing.
    - `max_size`: bytes; beyond it JAX deletes the least recently used programs. One
      `jaxsubdiv fit` of a glyph leaves about 0.4 MB (`benchmarks/bench_startup.py`).

    **Returns:** the folder in use, or None when the cache is switched off through the
    environment variable.

    Every program is cached, however short its compilation (JAX's default keeps only
    those over a second), since a command compiles several small ones too.
    """
    import jax

    if isinstance(max_size, bool) or not isinstance(max_size, int) or max_size <= 0:
        raise ValueError(
            f"`enable_compilation_cache(max_size=...)` must be a positive number of bytes; "
            f"got {max_size!r}."
        )
    folder = compilation_cache_dir() if path is None else Path(path).expanduser()
    if folder is None:
        return None
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OSError(
            f"compilation cache: cannot create the folder {folder} ({e.strerror or e}); "
            f"set {ENVIRONMENT_VARIABLE} to a writable folder, or to 'off'."
        ) from None
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    jax.config.update("jax_compilation_cache_max_size", max_size)
    return folder
