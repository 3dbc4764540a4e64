"""Make docs/images/editor.png: the interactive editor on the built-in star.

    python docs/make_editor_figure.py

The figure of docs/editor.md: B-spline (red), four-point (blue), Jarek (green) and corner
cutting with r = 0.1, s = 0.6 (brown), drawn by `jaxsubdiv.editor.Editor` off screen
(matplotlib's Agg backend), with its key help and smoothness panel as a user sees them.
"""

from pathlib import Path

import matplotlib


matplotlib.use("Agg")

import jaxsubdiv as js  # noqa: E402
from jaxsubdiv.editor import Editor  # noqa: E402


OUTPUT = Path(__file__).resolve().parent / "images" / "editor.png"


def main() -> None:
    editor = Editor(
        js.shapes.get("star"),
        curves=("cubic-bspline", "four-point", "jarek", "corner-cutting"),
        r=0.1,
        s=0.6,
    )
    editor.savefig(OUTPUT, dpi=80)
    print(f"wrote {OUTPUT}")


if __name__ == "__main__":
    main()
