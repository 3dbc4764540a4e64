"""What the newer benchmark scripts share: their `--smoke`/`--output` arguments, where
their results go, the header that dates a run and records the machine's load, and a
fresh-process runner."""

import argparse
import datetime
import json
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import time


RESULTS = pathlib.Path(__file__).parent / "results"


def arguments(doc: str, name: str):
    """`(args, output)`: the parsed `--smoke` and `--output`, and the JSON path
    (`results/<name>.json`, or `<name>_smoke.json` for a smoke run) with its folder made."""
    parser = argparse.ArgumentParser(description=doc.split("\n")[0])
    parser.add_argument("--smoke", action="store_true", help="a small run, for CI")
    parser.add_argument("--output", type=pathlib.Path, default=None, help="JSON path")
    args = parser.parse_args()
    output = args.output or RESULTS / (f"{name}_smoke.json" if args.smoke else f"{name}.json")
    output.parent.mkdir(parents=True, exist_ok=True)
    return args, output


def versions_arguments(doc: str, name: str, rounds: tuple[int, int], repeats: tuple[int, int],
                       smoke_help: str = "a small run, for CI"):
    """`(args, output, rounds, repeats)` for a benchmark that measures this tree, and
    with `--before REV` a git revision too, in fresh interpreters: `--smoke`,
    `--before`, `--rounds`, `--repeats` and `--output` (the JSON path, as `arguments`
    makes it). `rounds` and `repeats` are the defaults `(with --smoke, without)`."""
    parser = argparse.ArgumentParser(description=doc.split("\n")[0])
    parser.add_argument("--smoke", action="store_true", help=smoke_help)
    parser.add_argument("--before", help="a git revision to measure too, in the same run")
    parser.add_argument("--rounds", type=int, default=None,
                        help=f"fresh interpreters per version (default {rounds[1]}; "
                             f"{rounds[0]} with --smoke)")
    parser.add_argument("--repeats", type=int, default=None,
                        help=f"timed calls per case in each (default {repeats[1]}; "
                             f"{repeats[0]} with --smoke)")
    parser.add_argument("--output", type=pathlib.Path, default=None, help="JSON path")
    args = parser.parse_args()
    output = args.output or RESULTS / (f"{name}_smoke.json" if args.smoke else f"{name}.json")
    output.parent.mkdir(parents=True, exist_ok=True)
    return (args, output, args.rounds or rounds[not args.smoke],
            args.repeats or repeats[not args.smoke])


def versions(before: str | None, scratch: pathlib.Path) -> dict:
    """`{name: (tree, commit)}` to measure: "after", this work tree (`HEAD+worktree`),
    and with `before` that git revision too, extracted under `scratch` (listed first)."""
    from bench_analysis import _commit, _extract

    after = {"after": (pathlib.Path(__file__).resolve().parent.parent,
                       _commit("HEAD") + "+worktree")}
    if not before:
        return after
    return {"before": (_extract(before, scratch), _commit(before)), **after}


def run_versions(before: str | None, rounds: int, code: str, spec_of, *,
                 describe=None, timeout: float = 900) -> tuple[dict, dict]:
    """Run `code` in fresh interpreters for this tree and, with `before`, that git
    revision (`versions`), alternating round by round (in turn first): `(commits,
    measured)`, `measured[name]` the child's JSON of each round. The child gets the
    version's tree, this folder and `json.dumps(spec_of(name, round))` as its
    arguments, and must report the folder it imported `fitting` from (`"fitting"`),
    which is checked; `describe(result)` gives a progress line."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        trees = versions(before, pathlib.Path(tmp))
        measured = {name: [] for name in trees}
        for r in range(rounds):
            for name in list(trees) if r % 2 == 0 else list(reversed(trees)):
                tree = trees[name][0]
                result = child_json(code, str(tree), str(pathlib.Path(__file__).parent),
                                    json.dumps(spec_of(name, r)),
                                    what=f"{name} (round {r + 1})", timeout=timeout)
                if pathlib.Path(result["fitting"]).resolve() != (tree / "fitting").resolve():
                    raise SystemExit(f"{name} imported fitting from {result['fitting']}")
                measured[name].append(result)
                if describe is not None:
                    print(f"round {r + 1}, {name}: {describe(result)}", flush=True)
    return {name: commit for name, (_, commit) in trees.items()}, measured


def median_cases(measured: dict, key: str) -> list[dict]:
    """One row per case of `run_versions`' results (each child's `"cases"`, in the same
    order): the first round's entry for each version, with `key` the median over
    rounds."""
    rows = []
    for i, case in enumerate(measured["after"][0]["cases"]):
        row = {"case": case["case"]}
        for name, results in measured.items():
            row[name] = dict(results[0]["cases"][i],
                             **{key: statistics.median(r["cases"][i][key] for r in results)})
        rows.append(row)
    return rows


def blob(seed: int, m: int):
    """A smooth random closed outline of `m` samples (numpy, float64): a unit circle's
    radius perturbed by three harmonics (2, 3, 5) of amplitudes in [0.05, 0.25) and
    random phases, from `numpy.random.default_rng(seed)`."""
    import numpy as np

    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, m, endpoint=False)
    a, phase = rng.uniform(0.05, 0.25, 3), rng.uniform(0, 6, 3)
    r = (1 + a[0] * np.sin(3 * t + phase[0]) + a[1] * np.cos(5 * t + phase[1])
         + a[2] * np.sin(2 * t + phase[2]))
    return np.stack([r * np.cos(t), r * np.sin(t)], -1)


def header(**extra) -> dict:
    """The run's date (UTC), machine and load average at the start (1, 5, 15 min);
    record `load_end` with `load()` when the run ends."""
    return {
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs",
        "load_start": load(),
        **extra,
    }


def median_range(values) -> str:
    """`median (min-max)` of seconds, two decimals: how the results tables show runs."""
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def timed(call, repeats: int):
    """`(median seconds, last result)` of `repeats` calls, each waited for
    (`jax.block_until_ready`)."""
    import jax

    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = jax.block_until_ready(call())
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def write_results(output: pathlib.Path, run: dict, markdown) -> None:
    """Write the run as JSON at `output` and as `markdown(run)` next to it (.md)."""
    output.write_text(json.dumps(run, indent=1))
    output.with_suffix(".md").write_text(markdown(run))
    print(f"wrote {output} and {output.with_suffix('.md')}")


def load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def child_json(code: str, *args: str, what: str, **run) -> dict:
    """Run `code` with `args` in a fresh interpreter (this one's; `run`: more arguments
    of `subprocess.run`, such as `env` and `cwd`) and parse its last line of output as
    JSON; a failed child stops the benchmark with its stderr, named by `what`."""
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          timeout=run.pop("timeout", 900), **run)
    if done.returncode != 0:
        raise SystemExit(f"{what} failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])
