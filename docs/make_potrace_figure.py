"""Traced bitmaps side by side: potrace and our fit against the true outline (issue #21).

    python docs/make_potrace_figure.py   # writes docs/images/potrace_side_by_side.png, prints figures

Needs the `potrace` program (Debian's package). The same pipeline as
`benchmarks/bench_potrace.py` at equal segments, for four of its images (the star,
STIXGeneral 'S' and DejaVu Serif '&' at 256 px, where we are closer to the truth, and
STIXGeneral 'Q' at 1024 px, where potrace is: its tail's 33-degree corner is not
found in pixels): each shape scaled to 80% of the image
and rasterised (pixel centers inside); potrace with its defaults on the bitmap; ours,
`fitting.fit(points, CubicBSpline(), n, corners=find_corners(points, pixel=1.0)[:n])`
on each contour `jaxsubdiv.io.read_image` traces, n the number of segments potrace used
for it. Top row: the whole image (the true outline in black, potrace in red, ours in
blue, the bitmap in grey); bottom row: a 24-px window around the point where the larger
of the two Hausdorff distances is attained. The printed errors are two-sided against
the exact outline, in pixels (the benchmark's `errors`).
"""

import pathlib
import subprocess
import sys
import tempfile
import warnings

import jax
import matplotlib


matplotlib.use("Agg")
import matplotlib.image  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_potrace import (  # noqa: E402
    analytic_contours,
    distances,
    errors,
    glyph_contours,
    match,
    place,
    potrace_paths,
    rasterise,
)

import fitting  # noqa: E402
import jaxsubdiv as js  # noqa: E402


jax.config.update("jax_enable_x64", True)
IMAGES = pathlib.Path(__file__).parent / "images"
CASES = [("analytic", "star", 256), ("STIXGeneral", "S", 256), ("DejaVu Serif", "&", 256),
         ("STIXGeneral", "Q", 1024)]
WINDOW = 24  # px, the zoomed panels


def trace(family, char, size, folder):
    """The true contours, the bitmap, potrace's subpaths and our fitted curves."""
    raw = analytic_contours(char) if family == "analytic" else glyph_contours(family, char)
    truth = place(raw, size)
    bitmap = rasterise(truth, size)
    pbm, png, svg = (folder / f"{char}.{e}" for e in ("pbm", "png", "svg"))
    pbm.write_text(f"P1\n{size} {size}\n" + "\n".join(
        " ".join("1" if v else "0" for v in row) for row in bitmap) + "\n")
    matplotlib.image.imsave(png, ~bitmap, cmap="gray", vmin=0, vmax=1)
    subprocess.run(["potrace", "-b", "svg", "-u", "100", "-o", str(svg), str(pbm)], check=True)
    theirs = potrace_paths(svg.read_text())
    contours = [o.points + 0.5 for o in js.io.read_image(png)]  # the bench's frame
    curves = []
    for points, j in zip(contours, match(contours, theirs)):
        n = max(4, theirs[j][1])
        corners = fitting.find_corners(points, pixel=1.0)[:n]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = fitting.fit(points, js.CubicBSpline(), n, corners=corners,
                                 on_failure="ignore")
        curves.append(np.asarray(result.curve))
    return truth, bitmap, [p for p, _ in theirs], curves, sum(c for _, c in theirs)


def worst_point(curves, truth):
    """Where a closed polyline set is farthest from the other, either way."""
    a, b = np.concatenate(curves), np.concatenate(truth)
    to_truth, to_curves = distances(a, truth), distances(b, curves)
    if to_truth.max() >= to_curves.max():
        return a[np.argmax(to_truth)], to_truth.max()
    return b[np.argmax(to_curves)], to_curves.max()


def main():
    IMAGES.mkdir(exist_ok=True)
    fig, axes = plt.subplots(2, len(CASES), figsize=(4.2 * len(CASES), 8.6), dpi=100)
    with tempfile.TemporaryDirectory() as name:
        folder = pathlib.Path(name)
        for k, (family, char, size) in enumerate(CASES):
            truth, bitmap, theirs, ours, segments = trace(family, char, size, folder)
            p_rms, p_h = errors(theirs, truth)
            o_rms, o_h = errors(ours, truth)
            label = char if family == "analytic" else f"{family} '{char}'"
            print(f"{label} at {size} px, {segments} segments: Hausdorff potrace {p_h:.2f} px, "
                  f"ours {o_h:.2f} px; RMS {p_rms:.3f} and {o_rms:.3f} px")
            (pa, da), (oa, do) = worst_point(theirs, truth), worst_point(ours, truth)
            focus = pa if da >= do else oa
            for row, ax in enumerate(axes[:, k]):
                ax.imshow(~bitmap, cmap="gray", vmin=-1.5, vmax=1,
                          extent=(0, size, 0, size), interpolation="nearest")
                for polylines, color, width, name_ in (
                        (truth, "black", 0.8, "true outline"),
                        (theirs, "tab:red", 1.2, "potrace"),
                        (ours, "tab:blue", 1.2, "ours (fitting.fit)")):
                    for i, p in enumerate(polylines):
                        ax.plot(*np.vstack([p, p[:1]]).T, color=color, lw=width,
                                label=name_ if i == 0 else None)
                ax.set_aspect("equal")
                ax.set_xticks([])
                ax.set_yticks([])
                if row == 0:
                    ax.set_title(f"{label}, {size} px, {segments} segments\nHausdorff to the "
                                 f"truth: potrace {p_h:.2f} px, ours {o_h:.2f} px", fontsize=10)
                else:
                    ax.set_xlim(focus[0] - WINDOW / 2, focus[0] + WINDOW / 2)
                    ax.set_ylim(focus[1] - WINDOW / 2, focus[1] + WINDOW / 2)
                    ax.set_title(f"{WINDOW} px around the larger error", fontsize=9)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=9)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    out = IMAGES / "potrace_side_by_side.png"
    fig.savefig(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
