"""What a user meets first: `import jaxsubdiv` and `jaxsubdiv --help` without JAX, and
the persistent compilation cache the command keeps (each case in a fresh process)."""

import json
import os
import subprocess
import sys
import textwrap

import jax
import numpy as np
import pytest

import jaxsubdiv as js


def _python(code, env=None, timeout=600):
    """Run `code` in a fresh interpreter; its stdout's last line, parsed as JSON."""
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                            text=True, timeout=timeout, env={**os.environ, **(env or {})})
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1]), result


HEAVY = ("jax", "jaxlib", "equinox", "optimistix", "lineax", "matplotlib", "fitting", "numpy")


def test_import_loads_no_heavy_module():
    loaded, _ = _python(f"""
        import json, sys
        import jaxsubdiv
        print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))
    """)
    assert loaded == []


@pytest.mark.parametrize("argv", [["--help"], ["fit", "--help"], ["fit", "--n", "many"],
                                  ["refine", "--scheme", "nope"], []])
def test_help_and_usage_errors_answer_without_jax(argv):
    """`--help` exits 0 and a usage error exits 2 with one line, before JAX is imported."""
    (code, loaded), result = _python(f"""
        import json, sys
        from jaxsubdiv._cli import main
        try:
            code = main({argv!r})
        except SystemExit as e:
            code = e.code
        print()
        print(json.dumps([code, [m for m in {HEAVY!r} if m in sys.modules]]))
    """)
    assert loaded == []
    if argv and argv[-1] == "--help":
        assert code == 0 and "usage: jaxsubdiv" in result.stdout
    else:
        assert code == 2
        (line,) = result.stderr.strip().splitlines()[-1:]
        assert line.startswith("jaxsubdiv") and "error" in line


def test_public_names_resolve_lazily():
    """Every advertised name resolves, and an unknown one is an AttributeError."""
    for name in js.__all__:
        assert getattr(js, name) is not None
    assert set(js.__all__) <= set(dir(js))
    assert js.__version__
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        js.nonsense  # noqa: B018


# A fit through the command in a fresh process, reporting the compilations it made and
# how many programs came from the persistent cache (JAX's monitoring events).
_FIT_COUNTING = """
    import json, sys
    import jax
    counts = {"compiled": 0, "hits": 0}
    def duration(event, seconds, **_):
        if event == "/jax/core/compile/backend_compile_duration":
            counts["compiled"] += 1
    def event(name, **_):
        if name == "/jax/compilation_cache/cache_hits":
            counts["hits"] += 1
    jax.monitoring.register_event_duration_secs_listener(duration)
    jax.monitoring.register_event_listener(event)
    from jaxsubdiv._cli import main
    status = main(ARGS)
    print()
    print(json.dumps([status, counts["compiled"], counts["hits"]]))
"""


def _fit_in_new_process(cache, args):
    code = _FIT_COUNTING.replace("ARGS", repr(args))
    return _python(code, env={"JAXSUBDIV_COMPILATION_CACHE": str(cache)})


def test_second_process_loads_every_program_from_the_cache(tmp_path):
    """Run 1 fills a fresh cache folder (some small program may already be read back
    from it within the run, when it is compiled twice) and exports the fit; run 2 of
    the same fit loads every program it needs from it (hits = programs), and answers
    the same."""
    cache = tmp_path / "cache"
    args = ["fit", "--shape", "star", "--n", "12", "--samples", "150", "-q"]
    (status, compiled, hits), first = _fit_in_new_process(cache, args)
    assert status == 0 and compiled > hits
    # The fit, exported as its two programs: the solve, and its errors' measurement.
    assert len(list((cache / "jaxsubdiv-exported").iterdir())) == 2
    assert len(list(cache.glob("*-cache"))) >= compiled - hits  # JAX's compiled programs
    (status, compiled_again, hits), second = _fit_in_new_process(cache, args)
    assert status == 0
    assert 0 < hits == compiled_again <= compiled  # nothing compiled: all from the cache
    assert second.stdout.split("time")[0] == first.stdout.split("time")[0]


def test_cache_can_be_switched_off_and_a_bad_folder_is_a_warning(tmp_path):
    args = ["fit", "--shape", "star", "--n", "12", "--samples", "150", "-q"]
    off = tmp_path / "unused"
    (status, _, hits), _ = _python(_FIT_COUNTING.replace("ARGS", repr(args)),
                                   env={"JAXSUBDIV_COMPILATION_CACHE": "off"})
    assert status == 0 and hits == 0 and not off.exists()
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    (status, _, _), result = _fit_in_new_process(blocker / "cache", args)
    assert status == 0
    assert "warning: compilation cache: cannot create the folder" in result.stderr
    assert "JAXSUBDIV_COMPILATION_CACHE" in result.stderr


def test_cache_folder_default_and_arguments(tmp_path, monkeypatch):
    from jaxsubdiv import compilation_cache_dir

    monkeypatch.delenv("JAXSUBDIV_COMPILATION_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert compilation_cache_dir() == tmp_path / "jaxsubdiv" / "xla"
    monkeypatch.setenv("JAXSUBDIV_COMPILATION_CACHE", "OFF")
    assert compilation_cache_dir() is None and js.enable_compilation_cache() is None
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="max_size"):
            js.enable_compilation_cache(tmp_path, max_size=bad)


# The command's XLA flags (jaxsubdiv._xla_flags): XLA's CPU fusion emitters off in the
# command's own process, for the jaxlib releases it was tried on, unless the user chose.
_EMITTERS_OFF = "--xla_cpu_use_fusion_emitters=false"
_FLAG_CASES = [
    # (XLA_FLAGS given, jaxlib release, XLA_FLAGS the command runs with; None: as given)
    (None, (0, 10, 2), _EMITTERS_OFF),
    ("--xla_backend_optimization_level=0", (0, 10, 2),
     "--xla_backend_optimization_level=0 " + _EMITTERS_OFF),
    ("--xla_cpu_use_fusion_emitters=true", (0, 10, 2), None),  # the user's choice
    ("  --xla_cpu_use_fusion_emitters  ", (0, 10, 2), None),
    (None, (0, 5, 3), _EMITTERS_OFF),  # the first release that takes it (tried)
    (None, (0, 5, 1), None),  # XLA of jaxlib 0.5.1 stops at the flag (tried)
    (None, (0, 10, 3), None),  # a release nobody tried: XLA may not know the flag
    (None, (99, 0, 0), None),
    ("/home/me/xla_flags.txt", (0, 10, 2), None),  # XLA reads its flags from that file
    ('--xla_dump_to="/tmp/my dumps', (0, 10, 2), None),  # an unpaired quote
    (None, None, None),  # jaxlib not installed as a package
]


@pytest.mark.parametrize("given, jaxlib, expected", _FLAG_CASES)
def test_command_xla_flags(given, jaxlib, expected):
    from jaxsubdiv._xla_flags import VERIFIED_JAXLIB, command_xla_flags

    if jaxlib == (0, 10, 2):
        assert VERIFIED_JAXLIB[0] <= jaxlib <= VERIFIED_JAXLIB[1]  # the case's premise
    environ = {} if given is None else {"XLA_FLAGS": given}
    assert command_xla_flags(environ, jaxlib) == expected


@pytest.mark.parametrize("text, expected", [
    ("0.10.2", (0, 10, 2)), ("0.5.0rc1", (0, 5, 0)), ("0.4.36.dev20241122", (0, 4, 36)),
    ("1.2", None), ("unknown", None)])
def test_jaxlib_release(text, expected):
    from jaxsubdiv._xla_flags import release

    assert release(text) == expected


def test_command_compile_flags_are_given_back(monkeypatch):
    """Set for the command's block, and removed (or restored) after it, also after an
    error, if the backend has not started; kept if the block started it (XLA compiles
    with them from then on, and JAX's cache keys must say so); left alone in a process
    whose JAX backend had started (XLA has read its flags)."""
    from jaxsubdiv import _xla_flags

    monkeypatch.setattr(_xla_flags, "_jaxlib_release", lambda: (0, 10, 2))
    for before in (None, "--xla_backend_optimization_level=0"):
        if before is None:
            monkeypatch.delenv("XLA_FLAGS", raising=False)
        else:
            monkeypatch.setenv("XLA_FLAGS", before)
        expected = f"{before or ''} {_EMITTERS_OFF}".strip()
        # (backend started before the block, after it) -> XLA_FLAGS inside, and after
        for started, inside_expected, after_expected in [
            ((False, False), expected, before),
            ((False, True), expected, expected),
            ((True, True), before, before),
        ]:
            answers = iter(started)
            with monkeypatch.context() as m:
                m.setattr(_xla_flags, "_backend_started", lambda: next(answers))
                with _xla_flags.command_compile_flags():
                    inside = os.environ.get("XLA_FLAGS")
                assert inside == inside_expected
                assert os.environ.get("XLA_FLAGS") == after_expected
            if before is None:
                monkeypatch.delenv("XLA_FLAGS", raising=False)
            else:
                monkeypatch.setenv("XLA_FLAGS", before)
        with monkeypatch.context() as m:
            m.setattr(_xla_flags, "_backend_started", lambda: False)
            with pytest.raises(KeyError):
                with _xla_flags.command_compile_flags():
                    raise KeyError("the command failed")
            assert os.environ.get("XLA_FLAGS") == before
    jax.numpy.zeros(1).block_until_ready()
    assert _xla_flags._backend_started()


def test_the_command_runs_with_the_fusion_emitters_off_where_jaxlib_knows_the_flag(tmp_path):
    """The `jaxsubdiv` command in a fresh process with the user's XLA_FLAGS lacking the
    flag: XLA takes it (it stops the process at a flag it does not know) on the installed
    jaxlib where that release was tried, and the refined points are right (Chaikin's
    rule, written here)."""
    from importlib.metadata import version

    from jaxsubdiv._xla_flags import VERIFIED_JAXLIB, release

    code = """
        import json, os
        import jaxsubdiv._cli as cli
        seen = []
        run = cli._run
        def spy(args):
            seen.append(os.environ.get("XLA_FLAGS"))
            return run(args)
        cli._run = spy
        status = cli.main(["refine", "--shape", "square", "--scheme", "chaikin",
                           "--levels", "1", "-o", OUT])
        from jax._src.xla_bridge import backends_are_initialized
        print(json.dumps([status, seen[0], os.environ.get("XLA_FLAGS"),
                          backends_are_initialized()]))
    """.replace("OUT", repr(str(tmp_path / "refined.csv")))
    given = "--xla_backend_optimization_level=0"
    (status, inside, after, started), _ = _python(code, env={"XLA_FLAGS": given})
    # The command started XLA, which took the flags; they stay for the process.
    assert status == 0 and started and after == inside
    first, last = VERIFIED_JAXLIB
    tried = first <= release(version("jaxlib")) <= last
    assert inside == (f"{given} {_EMITTERS_OFF}" if tried else given)
    square = np.loadtxt(tmp_path / "refined.csv", delimiter=",")
    polygon = np.array(js.shapes.get("square"))
    chaikin = [w for p, q in zip(polygon, np.roll(polygon, -1, axis=0))
               for w in (0.75 * p + 0.25 * q, 0.25 * p + 0.75 * q)]
    np.testing.assert_allclose(square, chaikin, rtol=0, atol=1e-12)
