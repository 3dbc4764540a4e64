"""Compare the `jaxsubdiv` command's start-up between variants, interleaved in one run.

    python benchmarks/bench_startup_compare.py before=/tmp/before after=. \\
        --rounds 4 --scenarios demo,fit-glyph --output benchmarks/results/startup_compare.json

A variant is `LABEL=PATH[,PATH...]`: the paths go in front of `PYTHONPATH` in its
children (a source tree, and perhaps a folder of other package versions, such as
`pip install --target DIR ml_dtypes==0.6.0`); `--env LABEL:NAME=VALUE` sets an
environment variable for one variant's children (the same tree with other XLA flags). Each round runs every scenario of
`bench_startup.py` (its `SCENARIOS`, cold and warm, by its `measure`: one timed run, and
its counting probe) for every variant back to back, the variants' order rotated by one
each round (a round count that is a multiple of the number of variants puts each variant
in each position equally often), so that a shared machine's drift falls on all alike.
Reported per variant: the median (min-max) wall time over the rounds and its ratio to the
first variant's median, the median (min-max) XLA compile seconds of the probes, the
versions of jaxsubdiv, fitting, jaxlib, ml_dtypes and numpy the children imported, the
`XLA_FLAGS` they inherited, and the value the command left in it (the probe reads it at
exit).

Writes the JSON and a Markdown table beside it, at the end of the run.
"""

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import median_range, write_results  # noqa: E402
from bench_startup import (  # noqa: E402
    IMPORT,
    SCENARIOS,
    Runner,
    _cpu_model,
    _git_state,
    measure,
    write_two_contours,
)


_VERSIONS = ("import json, importlib.metadata as m, jaxsubdiv, fitting; print(json.dumps("
             "[jaxsubdiv.__file__, fitting.__file__]"
             " + [m.version(p) for p in ('jaxlib', 'ml_dtypes', 'numpy')]))")


def _variant(text: str) -> tuple[str, list[Path]]:
    label, sep, paths = text.partition("=")
    if not sep or not label or not paths:
        raise argparse.ArgumentTypeError(f"expected LABEL=PATH[,PATH...], got {text!r}")
    return label, [Path(p).resolve() for p in paths.split(",")]


def _runner(scratch: Path, paths: list[Path]) -> Runner:
    runner = Runner(scratch, None)
    given = [runner.env["PYTHONPATH"]] if runner.env.get("PYTHONPATH") else []
    runner.env["PYTHONPATH"] = os.pathsep.join([*map(str, paths), *given])
    return runner


def _spread(values: list[float]) -> str:
    return median_range(values) if values else ""


def _markdown(report: dict) -> str:
    meta, variants = report["meta"], report["variants"]
    first = variants[0]["label"]
    lines = [
        "# Start-up of the `jaxsubdiv` command: variants compared in one run",
        "",
        f"{meta['date']}; {meta['machine']}; Python {meta['python']}; load average "
        f"{meta['load_average_at_start'][0]:.1f} at start, "
        f"{meta['load_average_at_end'][0]:.1f} at end; {meta['rounds']} rounds, the "
        "variants' order rotated each round; one timed fresh process per variant, "
        "scenario and condition in each round (`bench_startup.py`'s scenarios: `cold` "
        "with an empty compilation cache, `warm` with one an untimed run filled). Wall "
        "seconds, median (min-max) over the rounds; ratio = median / the "
        f"`{first}` variant's median; compile s: XLA compile seconds of each round's "
        "counting run, median (min-max). XLA_FLAGS inherited by the children: "
        f"`{meta['xla_flags_given'] or '(unset)'}`.",
        "",
        "Variants:",
        "",
    ]
    for v in variants:
        env = "".join(f"; {k}=`{val}`" for k, val in v.get("env", {}).items())
        lines.append(f"- `{v['label']}`: PYTHONPATH {', '.join(v['paths'])}{env}; jaxsubdiv "
                     f"{v['source']}, jaxlib {v['jaxlib']}, ml_dtypes {v['ml_dtypes']}, numpy "
                     f"{v['numpy']}; XLA_FLAGS the command left: "
                     f"`{v.get('xla_flags_in_command') or '(unset)'}`")
    lines += ["", "| scenario | condition | " + " | ".join(
        f"{v['label']} s | ratio | compile s" for v in variants) + " |",
        "|---|---|" + "---:|---:|---:|" * len(variants)]
    keys = [(r["scenario"], r["condition"]) for r in report["rows"][first]]
    for scenario, condition in keys:
        cells = []
        base = None
        for v in variants:
            row = next(r for r in report["rows"][v["label"]]
                       if (r["scenario"], r["condition"]) == (scenario, condition))
            median = statistics.median(row["walls"])
            base = median if base is None else base
            cells += [_spread(row["walls"]) + ("" if row["ok"] else " (!)"),
                      f"{median / base:.2f}", _spread(row["compile_s"])]
        lines.append(f"| {scenario} | {condition} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("variants", nargs="+", type=_variant, help="LABEL=PATH[,PATH...]")
    parser.add_argument("--env", action="append", default=[], metavar="LABEL:NAME=VALUE",
                        help="an environment variable for one variant's children "
                        "(e.g. 'on:XLA_FLAGS=--xla_cpu_use_fusion_emitters=true'); repeatable")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--scenarios", default="demo,fit-glyph")
    parser.add_argument("--output", type=Path, required=True, help="JSON path (.md beside it)")
    args = parser.parse_args(argv)
    labels = [label for label, _ in args.variants]
    if len(set(labels)) != len(labels):
        parser.error(f"variant labels must differ; got {labels}")
    extra_env = {label: {} for label in labels}
    for item in args.env:
        label, _, assignment = item.partition(":")
        name, sep, value = assignment.partition("=")
        if label not in extra_env or not name or not sep:
            parser.error(f"--env {item!r}: expected LABEL:NAME=VALUE with LABEL one of {labels}")
        extra_env[label][name] = value
    chosen = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    unknown = [s for s in chosen if s not in SCENARIOS]
    if unknown:
        parser.error(f"unknown scenario(s) {', '.join(unknown)}; choose from {', '.join(SCENARIOS)}")

    load_at_start = list(os.getloadavg())
    rows = {label: {} for label in labels}
    variants = []
    with tempfile.TemporaryDirectory(prefix="bench-startup-compare-") as scratch:
        runners = {}
        for label, paths in args.variants:
            folder = Path(scratch) / label
            folder.mkdir()
            write_two_contours(folder / "two.json")
            runner = runners[label] = _runner(folder, paths)
            runner.env.update(extra_env[label])
            warmup = runner.run(IMPORT + "; import matplotlib.font_manager", [],
                                runner.fresh_cache())
            if warmup["exit_code"] != 0:
                print(f"{label}: `import jaxsubdiv` fails:\n{warmup['stderr']}", file=sys.stderr)
                return 1
            found = subprocess.run([sys.executable, "-c", _VERSIONS], env=runner.env,
                                   cwd=folder, capture_output=True, text=True, check=True)
            file, fitting_file, jaxlib, ml_dtypes, numpy = json.loads(found.stdout)
            tree = Path(file).parent.parent
            if Path(fitting_file).parent.parent != tree:
                print(f"{label}: jaxsubdiv from {file} but fitting from {fitting_file}",
                      file=sys.stderr)
                return 1
            variants.append({"label": label, "paths": [str(p) for p in paths],
                             "env": extra_env[label],
                             "jaxsubdiv_file": file, "fitting_file": fitting_file,
                             "source": _git_state(tree), "jaxlib": jaxlib,
                             "ml_dtypes": ml_dtypes, "numpy": numpy})
        for round_ in range(args.rounds):
            shift = round_ % len(args.variants)
            order = args.variants[shift:] + args.variants[:shift]
            for name in chosen:
                for condition in ("cold", "warm") if SCENARIOS[name][3] else ("-",):
                    for label, _ in order:
                        result = measure(runners[label], name, condition, 1)
                        row = rows[label].setdefault((name, condition), {
                            "scenario": name, "condition": condition, "walls": [],
                            "compile_s": [], "ok": True, "probes": []})
                        row["walls"].append(result["median_wall_s"])
                        row["ok"] = row["ok"] and result["ok"]
                        probe = {k: v for k, v in result["probe"].items() if k != "compiled"}
                        row["probes"].append(probe)
                        if probe.get("compile_s") is not None:
                            row["compile_s"].append(probe["compile_s"])
                        if probe.get("xla_flags") is not None:
                            next(v for v in variants if v["label"] == label)[
                                "xla_flags_in_command"] = probe["xla_flags"]
                        print(f"round {round_ + 1} {label:12s} {name:16s} {condition:5s} "
                              f"{result['median_wall_s']:6.2f} s"
                              + ("" if result["ok"] else "  UNEXPECTED EXIT CODE"), flush=True)
    report = {
        "meta": {
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "xla_flags_given": os.environ.get("XLA_FLAGS"),
            "machine": f"{_cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
            "python": platform.python_version(),
            "rounds": args.rounds,
            "scenarios": chosen,
            "load_average_at_start": load_at_start,
            "load_average_at_end": list(os.getloadavg()),
        },
        "variants": variants,
        "rows": {label: list(by_key.values()) for label, by_key in rows.items()},
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    print()
    print(_markdown(report))
    write_results(args.output, report, _markdown)
    return 0 if all(r["ok"] for by_key in rows.values() for r in by_key.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
