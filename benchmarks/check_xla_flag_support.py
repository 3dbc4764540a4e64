"""Which jaxlib releases take an XLA flag: each release installed and run with it.

    python benchmarks/check_xla_flag_support.py 0.5.1 0.5.3 0.10.2 \\
        --output benchmarks/results/xla_flag_support.json

`jaxsubdiv/_xla_flags.py` sets `--xla_cpu_use_fusion_emitters=false` in the command's
process only for the releases in its `VERIFIED_JAXLIB`, since XLA stops a process at a
flag it does not know. This is the check behind that range. For each release: `pip
install --target` of `jax==V` and `jaxlib==V` into a scratch folder, then fresh
processes (that folder first on `PYTHONPATH`) that compute `sin(arange(3)).sum()` with
`XLA_FLAGS` set to the flag `=false`, `=true`, and to an invented flag (the control:
every release must stop at it, or the check shows nothing). Recorded: each exit status,
the computed value, and the last line of stderr. Needs network access to PyPI and about
300 MB of disk per release at a time (the folder is removed after each).

Writes the JSON and a Markdown table beside it.
"""

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header, load, write_results  # noqa: E402


FLAG = "--xla_cpu_use_fusion_emitters"
SETTINGS = {"=false": f"{FLAG}=false", "=true": f"{FLAG}=true",
            "invented flag": "--xla_invented_flag_for_this_check=1"}
PROGRAM = "import jax, jax.numpy as jnp; print(jax.__version__, float(jnp.sin(jnp.arange(3.0)).sum()))"


def check(version: str, scratch: Path) -> dict:
    target = scratch / f"v{version}"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
         "--target", str(target), f"jax=={version}", f"jaxlib=={version}"],
        capture_output=True, text=True)
    row = {"version": version, "installed": install.returncode == 0}
    if not row["installed"]:
        row["install_error"] = install.stderr.strip().splitlines()[-1:]
        return row
    env = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "PYTHONPATH")}
    env["PYTHONPATH"] = str(target)
    for label, flags in SETTINGS.items():
        run = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True,
                             env=env | {"XLA_FLAGS": flags}, cwd=scratch, timeout=600)
        row[label] = {"exit": run.returncode, "stdout": run.stdout.strip(),
                      "stderr_last": (run.stderr.strip().splitlines() or [""])[-1][:300]}
    shutil.rmtree(target, ignore_errors=True)
    return row


def markdown(report: dict) -> str:
    lines = [f"# Which jaxlib releases take `{FLAG}`", "",
             f"{report['date']}; Python {report['python']}, {report['machine']}; load "
             f"{report['load_start'][0]:.1f} at start, {report['load_end'][0]:.1f} at end. "
             "Produced by "
             "`python benchmarks/check_xla_flag_support.py "
             + " ".join(r["version"] for r in report["rows"]) + "`. Each release installed "
             "with pip into a scratch folder and run in fresh processes with `XLA_FLAGS` "
             "set as the column says; `ok` = exit status 0 (the sum computed); otherwise the exit "
             "status and the last line of stderr.", "",
             "| jaxlib | " + " | ".join(SETTINGS) + " |",
             "|---|" + "---|" * len(SETTINGS)]
    for row in report["rows"]:
        if not row["installed"]:
            lines.append(f"| {row['version']} | not installed: {row['install_error']} |")
            continue
        cells = []
        for label in SETTINGS:
            r = row[label]
            cells.append("ok" if r["exit"] == 0 else f"exit {r['exit']}: `{r['stderr_last']}`")
        lines.append(f"| {row['version']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    started = header()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("versions", nargs="+", help="jaxlib releases, e.g. 0.5.3 0.10.2")
    parser.add_argument("--output", type=Path, required=True, help="JSON path (.md beside it)")
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="xla-flag-support-") as scratch:
        for version in args.versions:
            rows.append(check(version, Path(scratch)))
            print(version, {k: v["exit"] for k, v in rows[-1].items() if isinstance(v, dict)},
                  flush=True)
    report = started | {"python": platform.python_version(), "load_end": load(),
                        "flag": FLAG, "rows": rows}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    write_results(args.output, report, markdown)
    return 0


if __name__ == "__main__":
    sys.exit(main())
