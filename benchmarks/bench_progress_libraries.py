"""Would tqdm or rich do the fit's progress line better than `fitting/_progress.py`?
(issue #18: "a well-kept library if it earns its place over our own line").

    python benchmarks/bench_progress_libraries.py           # needs tqdm and rich installed
    python benchmarks/bench_progress_libraries.py --smoke   # the same (it takes seconds)

For each display, in fresh processes: the import time (`python -X importtime`, median
of 5, cumulative microseconds of the module), and what a 40-update loop of 0.4 s leaves
in a file when stderr is not a terminal (a log, a pipe, CI): the bytes and how many
in-place rewrites (`\\r`) pile up there. Ours is driven the way `fitting.fit_batch`
drives it (`begin`, `_show_items` per item, `finish`). A library that is not installed
is reported as such. Writes `benchmarks/results/progress_libraries.json` and `.md`.
"""

import importlib.util
import json
import pathlib
import statistics
import subprocess
import sys


sys.path.insert(0, str(pathlib.Path(__file__).parent))
import _common  # noqa: E402


ROOT = pathlib.Path(__file__).parent.parent
LOOPS = {
    "ours (fitting._progress)": (
        "fitting._progress",
        "from fitting import _progress as p\n"
        "p.begin()\n"
        "for i in range(40):\n    time.sleep(0.01); p._show_items(i + 1, 40)\n"
        "p.finish()\n",
    ),
    "tqdm": ("tqdm", "import tqdm\nfor i in tqdm.tqdm(range(40)):\n    time.sleep(0.01)\n"),
    "rich": (
        "rich.progress",
        "from rich.progress import track\nfor i in track(range(40)):\n    time.sleep(0.01)\n",
    ),
}


def import_us(module: str) -> int:
    """Median cumulative import time of `module` in a fresh process, microseconds."""
    times = []
    for _ in range(5):
        done = subprocess.run([sys.executable, "-X", "importtime", "-c", f"import {module}"],
                              capture_output=True, text=True, cwd=ROOT, check=True)
        line = [x for x in done.stderr.splitlines() if x.rstrip().endswith(f"| {module}")][-1]
        times.append(int(line.split("|")[1]))
    return int(statistics.median(times))


def written_to_a_file(code: str) -> dict:
    """What the loop writes to stderr and stdout when they are a file (a pipe here)."""
    # Bytes, not text=True: universal newlines would turn each "\r" into a newline.
    done = subprocess.run([sys.executable, "-c", "import time\n" + code],
                          capture_output=True, cwd=ROOT, check=True)
    text = (done.stderr + done.stdout).decode()
    return {"bytes": len(text.encode()), "rewrites": text.count("\r"),
            "lines": text.count("\n"), "last": text.replace("\r", "\n").strip()[-80:]}


def main():
    args, output = _common.arguments(__doc__, "progress_libraries")
    run = _common.header()
    rows = {}
    for name, (module, code) in LOOPS.items():
        if importlib.util.find_spec(module.split(".")[0]) is None:
            rows[name] = {"installed": False}
            continue
        rows[name] = {"installed": True, "import_us": import_us(module),
                      **written_to_a_file(code)}
    # What jaxsubdiv's own line costs to import is its module alone: `fitting` is
    # imported with it (JAX), so that time is the package's, not the display's.
    run["rows"], run["load_end"] = rows, _common.load()
    output.write_text(json.dumps(run, indent=1))
    lines = [
        "# Progress display: ours against tqdm and rich",
        "",
        f"{run['date']}, {run['machine']}, load {run['load_start']} -> {run['load_end']}. "
        "`python benchmarks/bench_progress_libraries.py`.",
        "",
        "| display | import (ms, cumulative) | written to a file by a 40-update loop: bytes "
        "| in-place rewrites piled up | last state |",
        "|---|---:|---:|---:|---|",
    ]
    for name, row in rows.items():
        if not row["installed"]:
            lines.append(f"| {name} | not installed | | | |")
            continue
        lines.append(f"| {name} | {row['import_us'] / 1000:.0f} | {row['bytes']} | "
                     f"{row['rewrites']} | `{row['last'].splitlines()[-1]}` |")
    lines += [
        "",
        "Ours imports `fitting` (and so JAX) with it: that time is the package's import, "
        "not the display's.",
    ]
    output.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
