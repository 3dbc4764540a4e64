"""`jaxsubdiv fit` on real files nobody here made, as a user runs it: this tree against a
git revision, in one run.

    python benchmarks/bench_cli_files.py --before 649433f   # about 25 minutes on 2 cores
    python benchmarks/bench_cli_files.py --smoke            # two small inputs (for CI)

The files: matplotlib's toolbar icons as PNG and SVG (`mpl-data/images`, shipped with
matplotlib), scikit-image's sample images (`skimage/data`: silhouettes, a logo, photos),
and `--text` glyphs, each fitted with the command's defaults (`jaxsubdiv fit FILE
--quiet -o out.json`: 32 control points, corners on). Each run is a fresh process with
the compilation cache off (`--no-compilation-cache`), so its time includes compiling,
as on a first run; the versions alternate file by file. Recorded per file and version:
the exit status (0 every contour converged, 1 some did not, 2 bad input or a refusal,
`timeout` past 240 s), the wall time, the peak memory of the process (`ru_maxrss` of
the children of a process that runs only it), the contours fitted, those not converged, the contours
given fewer control points than asked (a `note` line), and the median over contours of
the two-sided max error relative to the contour's size, as printed.

Writes `benchmarks/results/cli_files.json` and `.md` (`--output` sets the JSON path).
"""

import json
import os
import pathlib
import re
import statistics
import subprocess
import sys
import tempfile
import time


BENCH = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))
import _common  # noqa: E402


def _inputs(smoke: bool) -> list[tuple[str, list[str]]]:
    """(label, command-line arguments) of each input."""
    glyphs = [("text E", ["--text", "E"]), ("text .", ["--text", "."])]
    if smoke:
        return glyphs
    import matplotlib
    import skimage  # the bench extra

    icons = pathlib.Path(matplotlib.get_data_path()) / "images"
    data = pathlib.Path(skimage.__file__).parent / "data"
    names = ["back", "filesave", "help", "home", "subplots", "zoom_to_rect", "hand", "move"]
    files = ([icons / f"{n}.png" for n in names] + [icons / f"{n}_large.png" for n in names[:6]]
             + [icons / f"{n}.svg" for n in names]
             + [data / f"{n}.png" for n in ("horse", "coins", "logo", "page", "moon",
                                             "camera", "phantom", "brick")])
    return [(f.name, [str(f)]) for f in files] + glyphs + [
        ("text B8%", ["--text", "B8%"]), ("text &", ["--text", "&"])]


def _run(tree: pathlib.Path, arguments: list[str], timeout: float) -> dict:
    """One command in a fresh interpreter importing `tree`'s packages."""
    with tempfile.TemporaryDirectory() as folder:
        output = pathlib.Path(folder) / "out.json"
        code = ("import sys; from jaxsubdiv._cli import main; "
                "sys.exit(main(sys.argv[1:]))")
        command = [sys.executable, "-c", code, "--no-compilation-cache", "fit", *arguments,
                   "--quiet", "-o", str(output)]
        environment = dict(os.environ, PYTHONPATH=str(tree))
        start = time.perf_counter()
        process = subprocess.Popen(command, cwd=folder, env=environment, text=True,
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            out, err = process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            out, err = process.communicate()
            status = "timeout"
        else:
            status = process.returncode
        seconds = time.perf_counter() - start
    relative = [float(v) for v in re.findall(r"max error +\S+ \((\S+) of the size", out)]
    return dict(
        status=status, seconds=seconds,
        contours=len(re.findall(r"^contour \d+ of", out, re.M)),
        not_converged=len(re.findall(r"^  status     (?!converged)", out, re.M)),
        fewer=len(re.findall(r"^  note       \d+ control points, not", out, re.M)),
        resampled=out.count("resampled along its polyline"),
        smooth_for_corners=out.count("corners found, more than"),
        max_error=statistics.median(relative) if relative else None,
        error=err.strip().splitlines()[-1] if err.strip() else "",
    )


def _measure(spec_json: str) -> None:
    """Child: run one command and print its record with the peak memory (this process
    only waits; `RUSAGE_CHILDREN` is the command's)."""
    import resource

    spec = json.loads(spec_json)
    record = _run(pathlib.Path(spec["tree"]), spec["arguments"], spec["timeout"])
    record["peak_mb"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(json.dumps(record))


def markdown(run: dict) -> str:
    versions = run["versions"]
    names = list(versions)
    lines = [
        "# `jaxsubdiv fit` on real files, with its defaults",
        "",
        f"{run['date']}; {run['machine']}; load average at the start {run['load_start']}, "
        f"at the end {run['load_end']}. Produced by `{run['command']}`.",
        "",
        "Versions: " + ", ".join(f"{n} = `{c}`" for n, c in versions.items()) + ". Each "
        "file in a fresh process, compilation cache off (times include compiling), the "
        f"versions alternating; timeout {run['timeout']} s. Status: 0 every contour "
        "converged, 1 some did not, 2 refused (bad input). `fewer`: contours given fewer "
        "control points than asked (and resampled); `max err`: the median over contours "
        "of the printed two-sided max error relative to the contour's size.",
        "",
    ]
    head = ["input"]
    for n in names:
        head += [f"{n}: status", f"{n}: s", f"{n}: MB", f"{n}: contours (not conv.)",
                 f"{n}: fewer", f"{n}: max err"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in run["rows"]:
        cells = [row["input"]]
        for n in names:
            r = row[n]
            cells += [str(r["status"]), f"{r['seconds']:.1f}", f"{r['peak_mb']:.0f}",
                      f"{r['contours']} ({r['not_converged']})",
                      f"{r['fewer']}" + (f" ({r['resampled']})" if r["resampled"] else ""),
                      "-" if r["max_error"] is None else f"{r['max_error']:.2g}"]
        lines.append("| " + " | ".join(cells) + " |")
    lines += [""]
    for n in names:
        rows = [row[n] for row in run["rows"]]
        ok = sum(r["status"] == 0 for r in rows)
        refused = sum(r["status"] == 2 for r in rows)
        late = sum(r["status"] == "timeout" for r in rows)
        lines.append(f"- **{n}**: {ok} of {len(rows)} exit 0, {refused} refused (status 2), "
                     f"{late} past the timeout; median time "
                     f"{statistics.median(r['seconds'] for r in rows):.1f} s.")
    return "\n".join(lines) + "\n"


def main() -> None:
    if len(sys.argv) > 2 and sys.argv[1] == "--child":
        _measure(sys.argv[2])
        return
    args, output, _, _ = _common.versions_arguments(
        __doc__, "cli_files", rounds=(1, 1), repeats=(1, 1),
        smoke_help="two glyphs (for CI)")
    timeout = 60.0 if args.smoke else 240.0

    run = _common.header(command=" ".join(["python", "benchmarks/bench_cli_files.py",
                                           *sys.argv[1:]]), timeout=timeout)
    inputs = _inputs(args.smoke)
    with tempfile.TemporaryDirectory() as tmp:
        versions = _common.versions(args.before, pathlib.Path(tmp))
        run["versions"] = {name: commit for name, (_, commit) in versions.items()}
        run["rows"] = []
        for i, (label, arguments) in enumerate(inputs):
            row = {"input": label}
            order = list(versions) if i % 2 == 0 else list(reversed(versions))
            for name in order:
                spec = dict(tree=str(versions[name][0]), arguments=arguments, timeout=timeout)
                done = subprocess.run([sys.executable, __file__, "--child", json.dumps(spec)],
                                      capture_output=True, text=True, check=True)
                row[name] = json.loads(done.stdout.strip().splitlines()[-1])
                print(f"{label}, {name}: status {row[name]['status']}, "
                      f"{row[name]['seconds']:.1f} s, {row[name]['peak_mb']:.0f} MB", flush=True)
            run["rows"].append(row)
    run["load_end"] = _common.load()
    _common.write_results(output, run, markdown)


if __name__ == "__main__":
    main()
