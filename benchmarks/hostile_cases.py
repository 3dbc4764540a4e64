"""Issue 17's hostile and careless inputs, each run in a fresh process, classified.

    python benchmarks/hostile_cases.py                      # this tree -> results/hostile.md
    python benchmarks/hostile_cases.py --src OLD --label before --output results/hostile_before.json

Every case is what an attacker or a careless user does (the list in `CASES`): a
command line, or a few lines of Python against the library. Each runs in a new
process with a time limit (`TIMEOUT` s) and an address-space limit (`MEMORY` bytes, so
that an unbounded allocation fails fast instead of swapping), in a scratch folder, and
is classified:

- `answered`: the documented result (the case's own check printed `OK`);
- `clear error`: one line naming the file or argument: exit status 2 from the command,
  or the documented exception type (`ValueError`, `TypeError`, `OutlineError`) from the
  library, caught by the case;
- `vague error`: exit status 2 and one line, but naming neither the file nor an option;
- `defect`: anything else: another exception or a traceback, a wrong result (the case
  printed `WRONG`), a hang (time limit), memory exhausted, or, whatever the answer, a
  peak resident memory above `PEAK_LIMIT` (measured by `/usr/bin/time`) or more than
  `SLOW` seconds.

Writes the JSON of every case and a Markdown table beside it (`results/hostile.*`).
`--src DIR` runs another source tree (prepended to `PYTHONPATH`). Standard library only.
"""

import argparse
import datetime
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path


HERE = Path(__file__).resolve().parent
TIMEOUT = 120
MEMORY = 8 * 1024**3
#: A case whose process peaks above this (resident) is a defect whatever it printed: the
#: inputs are small, and every entry point should bound its memory before allocating.
PEAK_LIMIT = 3 * 1024**3
#: ... or takes longer than this, in seconds (a fit that compiles takes about 10).
SLOW = 40

# Python run before every library case: float64 as the command uses, and the verdict
# helpers. `clear(e)` accepts the documented error types with a one-line message.
PRELUDE = """
import math, sys, numpy as np, jax
jax.config.update("jax_enable_x64", True)
import jaxsubdiv as js
def ok(why=""): print("OK", why); sys.exit(0)
def wrong(why): print("WRONG", why); sys.exit(0)
def clear(e, *names):
    # The documented types, one line, naming `names` (the file, where there is one).
    if (isinstance(e, (ValueError, TypeError)) and "\\n" not in str(e).strip()
            and all(n in str(e) for n in names)):
        print("CLEAR", type(e).__name__, str(e)[:200]); sys.exit(0)
    raise e
"""


def _png_bytes(width, height):
    """A PNG header claiming `width` x `height` grey pixels, with little data."""
    import struct
    import zlib

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    rows = zlib.compress(b"\x00" * (width + 1) * min(height, 64), 9)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", rows)
            + chunk(b"IEND", b""))


def _checkerboard_png(cells):
    import struct
    import zlib

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    size = 4 * cells
    rows = b"".join(
        b"\x00" + bytes(255 * (((x // 4) + (y // 4)) % 2) for x in range(size))
        for y in range(size)
    )
    header = struct.pack(">IIBBBBB", size, size, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows))
            + chunk(b"IEND", b""))


def _npy_header(shape):
    import io

    import numpy as np

    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return buffer.getvalue() + b"\x00" * 64


def _corrupt_npz():
    import io
    import zipfile

    import numpy as np

    buffer = io.BytesIO()
    np.savez_compressed(buffer, points=np.random.default_rng(0).standard_normal((500, 2)))
    data = bytearray(buffer.getvalue())
    start = data.index(b"points.npy") + len(b"points.npy") + 20
    data[start:start + 40] = b"\x00" * 40  # damage the deflated member only
    with zipfile.ZipFile(io.BytesIO(bytes(data))):
        pass  # the directory is intact
    return bytes(data)


def _npz_bomb():
    import io
    import zipfile

    # 1 GiB of zeros in about 1 MB (deflate's ratio is at most about 1000:1); the issue's
    # case expanded to 4.5 GB, which takes a minute to compress here.
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        with archive.open("points.npy", "w", force_zip64=True) as member:
            member.write(_npy_header((2**26, 2))[:-64])
            zeros = b"\x00" * 2**24
            for _ in range(64):
                member.write(zeros)
    return buffer.getvalue()


def _circle_csv(radius, m=200):
    import math

    return "".join(
        f"{radius * math.cos(2 * math.pi * k / m)!r}, {radius * math.sin(2 * math.pi * k / m)!r}\n"
        for k in range(m)
    ).encode()


# (area, name, files {name: bytes or a function returning bytes}, how: "cli ARGS..." or
# python source run after PRELUDE)
CASES = [
    # ---- readers through the command
    ("readers", "JSON number with 400 digits",
     {"big.json": b'{"points": [[1, 2], [3, ' + b"9" * 400 + b'], [0, 1]]}'},
     "cli refine big.json"),
    ("readers", "JSON nested 200,000 deep", {"deep.json": b"[" * 200_000 + b"]" * 200_000},
     "cli refine deep.json"),
    ("readers", "SVG with 5,000 nested groups",
     {"deep.svg": b'<svg xmlns="http://www.w3.org/2000/svg">' + b"<g>" * 5000
      + b'<path d="M0 0 L1 0 L1 1 Z"/>' + b"</g>" * 5000 + b"</svg>"},
     "cli refine deep.svg"),
    ("readers", "corrupt .npz member", {"bad.npz": _corrupt_npz}, "cli refine bad.npz"),
    ("readers", ".npy header claiming shape (1e10, 2)",
     {"huge.npy": lambda: _npy_header((10_000_000_000, 2))}, "cli refine huge.npy"),
    ("readers", ".npz of 1 MB expanding to 1 GiB", {"bomb.npz": _npz_bomb}, "cli refine bomb.npz"),
    ("readers", "PNG claiming 30,000 x 30,000 pixels", {"huge.png": lambda: _png_bytes(30000, 30000)},
     "cli refine huge.png"),
    ("readers", "PNG of 12,000 x 12,000 pixels", {"big.png": lambda: _png_bytes(12000, 12000)},
     "cli refine big.png"),
    ("readers", "dithered PNG, 48 x 48 checkerboard", {"noise.png": lambda: _checkerboard_png(48)},
     "cli refine noise.png --levels 0"),
    ("readers", "--text with only a zero-width character", {}, "cli refine --text \u200b"),
    ("readers", "binary PLY mesh",
     {"mesh.ply": b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      b"property float y\nproperty float z\nelement face 1\nproperty list uchar int "
      b"vertex_indices\nend_header\n" + bytes(range(256)) * 2},
     "try:\n    js.surfaces.read_mesh('mesh.ply')\nexcept Exception as e:\n    clear(e, 'mesh.ply')\n"
     "wrong('read')"),
    ("readers", "OBJ with NaN vertices",
     {"nan.obj": b"v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n"},
     "try:\n    m = js.surfaces.read_mesh('nan.obj')\nexcept Exception as e:\n    clear(e, 'nan.obj')\n"
     "wrong('NaN vertices accepted')"),
    ("readers", "write_outlines with a bare array", {},
     "try:\n    js.io.write_outlines('out.csv', [np.zeros((3, 2))])\nexcept Exception as e:\n"
     "    clear(e)\nok('written')"),
    ("readers", "SVG without a drawable contour",
     {"empty.svg": b'<svg xmlns="http://www.w3.org/2000/svg"><g/></svg>'}, "cli refine empty.svg"),
    # ---- kernels and analysis
    ("kernels", "LaneRiesenfeld(31) in float32",
     {}, "jax.config.update('jax_enable_x64', False)\ntry:\n    s = js.LaneRiesenfeld(31)\n"
     "    np.asarray(js.refine(np.eye(40, 2), s, 1))\nexcept Exception as e:\n    clear(e)\nok()"),
    ("kernels", "LaneRiesenfeld(63)", {},
     "try:\n    s = js.LaneRiesenfeld(63)\n    np.asarray(js.refine(np.eye(80, 2), s, 1))\n"
     "except Exception as e:\n    clear(e)\nok()"),
    ("kernels", "LaneRiesenfeld(100000)", {},
     "try:\n    js.LaneRiesenfeld(100000)\nexcept Exception as e:\n    clear(e)\nwrong('built')"),
    ("kernels", "refine levels=10**6, clamped", {},
     "try:\n    js.refine(np.eye(5, 2), js.CubicBSpline(), 10**6, boundary='clamped')\n"
     "except Exception as e:\n    clear(e)\nwrong('refined')"),
    ("kernels", "refine levels=10**6, open", {},
     "try:\n    js.refine(np.eye(5, 2), js.CubicBSpline(), 10**6, boundary='open')\n"
     "except Exception as e:\n    clear(e)\nwrong('refined')"),
    ("kernels", "refine levels=14,000, closed", {},
     "try:\n    js.refine(np.eye(5, 2), js.CubicBSpline(), 14000)\n"
     "except Exception as e:\n    clear(e)\nwrong('refined')"),
    ("kernels", "refined_count of too few open points", {},
     "try:\n    c = js.refined_count(2, js.CubicBSpline(), 3, 'open')\nexcept Exception as e:\n"
     "    clear(e)\nok() if c >= 0 else wrong(c)"),
    ("kernels", "memory_budget=nan", {},
     "try:\n    js.refine(np.eye(5, 2), js.CubicBSpline(), 40, memory_budget=float('nan'))\n"
     "except Exception as e:\n    clear(e)\nwrong('no check')"),
    ("kernels", "complex scheme parameter", {},
     "try:\n    s = js.FourPoint(0.05 + 0.01j)\nexcept Exception as e:\n    clear(e)\n"
     "wrong(f'w = {s.w}')"),
    ("kernels", "subdivision_matrix(100000, Chaikin(), 3)", {},
     "try:\n    js.subdivision_matrix(100000, js.Chaikin(), 3)\nexcept Exception as e:\n"
     "    clear(e)\nwrong('built')"),
    ("kernels", "refine_mesh(cube, CatmullClark(), 12)", {},
     "from jaxsubdiv import surfaces as S\nv = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) "
     "for z in (0, 1)], float)\nf = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], "
     "[0, 2, 6, 4], [1, 5, 7, 3]]\ntry:\n    S.refine_mesh(S.Mesh(v, f), S.CatmullClark(), 12)\n"
     "except Exception as e:\n    clear(e)\nwrong('refined')"),
    ("kernels", "smoothness of a 128-coefficient mask", {},
     "mask = np.convolve(np.ones(64), np.ones(65)) ; mask = mask / mask.sum() * 2\ntry:\n"
     "    js.smoothness(js.MaskScheme(mask.tolist(), -64))\nexcept Exception as e:\n    clear(e)\nok()"),
    # ---- fitting
    ("fitting", "fit of 20,000 samples", {},
     "import fitting\nt = np.linspace(0, 2*np.pi, 20000, endpoint=False)\nX = np.stack([np.cos(t), "
     "np.sin(t)], 1)\ntry:\n    r = fitting.fit(X, js.CubicBSpline(), 32, max_steps=2, on_failure='ignore')\n"
     "except Exception as e:\n    clear(e)\nok()"),
    ("fitting", "fit(levels=18)", {},
     "import fitting\nt = np.linspace(0, 2*np.pi, 400, endpoint=False)\nX = np.stack([np.cos(t), "
     "np.sin(t)], 1)\ntry:\n    fitting.fit(X, js.CubicBSpline(), 32, levels=18, max_steps=2)\n"
     "except Exception as e:\n    clear(e)\nok()"),
    ("fitting", "fit(ordered=False) on 30,000 samples", {},
     "import fitting\nt = np.random.default_rng(0).uniform(0, 2*np.pi, 30000)\nX = np.stack([np.cos(t), "
     "np.sin(t)], 1)\ntry:\n    fitting.fit(X, js.CubicBSpline(), 16, ordered=False, max_steps=2)\n"
     "except Exception as e:\n    clear(e)\nok()"),
    ("fitting", "fit --samples 300000000", {}, "cli fit --shape star --samples 300000000"),
    ("fitting", "fit of an outline of size 1e160", {},
     "import fitting\nt = np.linspace(0, 2*np.pi, 300, endpoint=False)\nX = np.stack([np.cos(t), "
     "0.5*np.sin(t)], 1)\nr = fitting.fit(1e160 * X, js.CubicBSpline(), 12)\na = fitting.fit(X, "
     "js.CubicBSpline(), 12)\nq = float(r.rms) / 1e160 / float(a.rms)\n"
     "ok(q) if bool(r.converged) and abs(q - 1) < 1e-3 else wrong(f'{r.message[:30]} rms ratio {q}')"),
    ("fitting", "fit of an outline of size 1e-160", {},
     "import fitting\nt = np.linspace(0, 2*np.pi, 300, endpoint=False)\nX = np.stack([np.cos(t), "
     "0.5*np.sin(t)], 1)\nr = fitting.fit(1e-160 * X, js.CubicBSpline(), 12)\na = fitting.fit(X, "
     "js.CubicBSpline(), 12)\nq = float(r.rms) / 1e-160 / float(a.rms)\n"
     "ok(q) if bool(r.converged) and abs(q - 1) < 1e-3 else wrong(f'{r.message[:30]} rms ratio {q}')"),
    ("fitting", "command: circle of radius 1e300", {"c.csv": lambda: _circle_csv(1e300)},
     "cli fit c.csv --n 12 -q"),
    ("fitting", "command: circle of radius 1e-300", {"c.csv": lambda: _circle_csv(1e-300)},
     "cli fit c.csv --n 12 -q"),
    # ---- outputs
    ("outputs", "refine in.csv -o in.csv", {"in.csv": lambda: _circle_csv(1.0, 12)},
     "cli refine in.csv -o in.csv"),
    ("outputs", "fit in.csv -o in.csv", {"in.csv": lambda: _circle_csv(1.0, 40)},
     "cli fit in.csv --n 6 -o in.csv"),
    ("outputs", "fit -o c.svg --svg c.svg", {"in.csv": lambda: _circle_csv(1.0, 40)},
     "cli fit in.csv --n 6 -o c.svg --svg c.svg"),
]


VERDICTS = ("answered", "clear error", "vague error", "defect")
CLI = "import sys; from jaxsubdiv._cli import main; sys.exit(main())"


def _limit():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def run_case(case, src):
    area, name, files, how = case
    with tempfile.TemporaryDirectory(prefix="hostile-") as folder:
        folder = Path(folder)
        for file, data in files.items():
            (folder / file).write_bytes(data() if callable(data) else data)
        before = {f: (folder / f).read_bytes() for f in files}
        env = dict(os.environ, XDG_CACHE_HOME=str(folder / "cache"), MPLBACKEND="Agg",
                   JAXSUBDIV_COMPILATION_CACHE="off")
        if src:
            env["PYTHONPATH"] = str(src) + os.pathsep + env.get("PYTHONPATH", "")
        if how.startswith("cli "):
            import shlex

            argv = [sys.executable, "-c", CLI, *shlex.split(how[4:])]
        else:
            argv = [sys.executable, "-c", PRELUDE + textwrap.dedent(how)]
        start, peak = time.perf_counter(), None
        try:
            out = subprocess.run(["/usr/bin/time", "-f", "PEAK-KB %M", *argv], cwd=folder,
                                 env=env, capture_output=True, text=True, timeout=TIMEOUT,
                                 preexec_fn=_limit)
            code, stdout, stderr = out.returncode, out.stdout, out.stderr
            lines = stderr.rstrip("\n").split("\n")
            if lines and lines[-1].startswith("PEAK-KB "):
                peak = int(lines[-1].split()[1]) * 1024
                stderr = "\n".join(lines[:-1]) + ("\n" if len(lines) > 1 else "")
            if code and "Command exited with non-zero status" in stderr:
                stderr = "\n".join(line for line in stderr.split("\n")
                                   if not line.startswith("Command exited with"))
        except subprocess.TimeoutExpired:
            code, stdout, stderr = None, "", f"no answer within {TIMEOUT} s"
        seconds = time.perf_counter() - start
        changed = [f for f in files if (folder / f).read_bytes() != before[f]]
    verdict, why = _classify(how, files, code, stdout, stderr, changed)
    if peak is not None and peak > PEAK_LIMIT and verdict != "defect":
        verdict, why = "defect", f"peak memory {peak / 1024**3:.1f} GiB; {why}"
    if seconds > SLOW and verdict != "defect":
        verdict, why = "defect", f"slow ({seconds:.0f} s); {why}"
    return dict(area=area, name=name, how=how[:200], exit=code, seconds=round(seconds, 2),
                peak_bytes=peak,
                verdict=verdict, why=why, stdout=stdout[-600:], stderr=stderr[-600:])


def _classify(how, files, code, stdout, stderr, changed):
    errors = [line for line in stderr.strip().splitlines() if "Error" in line]
    last = (errors or stderr.strip().splitlines() or [""])[-1][:240]
    if code is None:
        return "defect", "hang: " + stderr
    if "MemoryError" in stderr or code < 0:
        return "defect", f"memory or signal (exit {code}): {last}"
    if changed:
        return "defect", f"input overwritten: {', '.join(changed)}"
    if how.startswith("cli "):
        if "Traceback" in stderr:
            return "defect", "traceback: " + last
        if code == 2 and len(stderr.strip().splitlines()) == 1:
            names = [f for f in files if f in last] or [
                w for w in how.split() if w.startswith("-") and f"{w.lstrip('-')}`" in last
                or w.startswith("-") and w in last]
            return ("clear error" if names or "--text" in how else "vague error"), last
        if code in (0, 1) and " nan" not in stdout:
            return "answered", (stdout.strip().splitlines() or [""])[-1][:200]
        return "defect", f"exit {code}: " + (last or stdout.strip()[-200:])
    first = (stdout.strip().splitlines() or [""])[0]
    if first.startswith("OK"):
        return "answered", first[3:200]
    if first.startswith("CLEAR"):
        return "clear error", first[6:240]
    if first.startswith("WRONG"):
        return "defect", "wrong: " + first[6:200]
    return "defect", last or f"exit {code}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", type=Path, help="another source tree to run")
    parser.add_argument("--label", default="this tree")
    parser.add_argument("--output", type=Path, default=HERE / "results" / "hostile.json")
    parser.add_argument("--only", help="run the cases whose name contains this text")
    args = parser.parse_args()
    cases = [c for c in CASES if not args.only or args.only in c[1]]
    started = datetime.datetime.now().isoformat(timespec="seconds")
    load = os.getloadavg()[0]
    rows = []
    for case in cases:
        row = run_case(case, args.src)
        print(f"{row['verdict']:12s} {row['seconds']:7.1f} s  {row['area']:8s} {row['name']}: "
              f"{row['why'][:110]}", flush=True)
        rows.append(row)
    info = dict(started=started, label=args.label, src=str(args.src or ""), load_start=load,
                load_end=os.getloadavg()[0], machine=f"{platform.processor() or platform.machine()}, "
                f"{os.cpu_count()} CPUs", python=platform.python_version(), timeout=TIMEOUT,
                memory_limit=MEMORY)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(dict(info=info, cases=rows), indent=1))
    counts = {}
    for row in rows:
        counts.setdefault(row["area"], dict.fromkeys(VERDICTS, 0))
        counts[row["area"]][row["verdict"]] += 1
    lines = [
        f"# Hostile inputs (issue 17), {args.label}", "",
        f"{started}; {info['machine']}; Python {info['python']}; load {load:.1f} at start, "
        f"{info['load_end']:.1f} at end. Each case in a fresh process, time limit {TIMEOUT} s, "
        f"address space {MEMORY / 1024**3:.0f} GiB; a peak resident above "
        f"{PEAK_LIMIT / 1024**3:.0f} GiB or more than {SLOW} s is a defect "
        f"(`benchmarks/hostile_cases.py`"
        + (f", source `{args.src}`" if args.src else "") + ").", "",
        "| area | " + " | ".join(VERDICTS) + " |", "|---|" + "---:|" * len(VERDICTS),
        *(f"| {a} | " + " | ".join(str(c[v]) for v in VERDICTS) + " |" for a, c in counts.items()),
        "", "| area | case | verdict | s | peak GiB | what happened |",
        "|---|---|---|---:|---:|---|",
        *(f"| {r['area']} | {r['name']} | {r['verdict']} | {r['seconds']:.1f} | "
          f"{(r['peak_bytes'] or 0) / 1024**3:.2f} | {r['why'].replace('|', '/')[:160]} |"
          for r in rows),
    ]
    args.output.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.output} and {args.output.with_suffix('.md')}")


if __name__ == "__main__":
    main()
