"""Make the pictures of docs/cli.md by running the commands they show.

    python docs/make_cli_figures.py     # about a minute; writes docs/images/cli_*.png, gallery_*.png

- `cli_fit_ampersand.png`: `jaxsubdiv fit --text "&" --n 32 --plot ...`;
- `cli_refine_hand_icon.png`: `jaxsubdiv refine hand.svg --scheme chaikin --levels 4
  --plot ...` on matplotlib's hand icon (its nodes, refined);
- `gallery_hand_corner_cutting.png`, `gallery_mug_four_point.png`: two rows of
  `jaxsubdiv gallery --shapes hand mug`.

The commands run in this process, as `jaxsubdiv` would run them, without the persistent
compilation cache.
"""

import pathlib
import shutil
import tempfile

import matplotlib

from jaxsubdiv._cli import main


IMAGES = pathlib.Path(__file__).parent / "images"


def run(*args) -> None:
    status = main(["--no-compilation-cache", *map(str, args)])
    if status != 0:
        raise SystemExit(f"jaxsubdiv {' '.join(map(str, args))} exited with {status}")


if __name__ == "__main__":
    run("fit", "--text", "&", "--n", 32, "--quiet", "--plot", IMAGES / "cli_fit_ampersand.png",
        "--force")
    icon = pathlib.Path(matplotlib.get_data_path()) / "images" / "hand.svg"
    run("refine", icon, "--scheme", "chaikin", "--levels", 4,
        "--plot", IMAGES / "cli_refine_hand_icon.png", "--force")
    with tempfile.TemporaryDirectory() as folder:
        run("gallery", "-o", folder, "--shapes", "hand", "mug")
        shutil.copy(pathlib.Path(folder) / "hand-corner-cutting.png",
                    IMAGES / "gallery_hand_corner_cutting.png")
        shutil.copy(pathlib.Path(folder) / "mug-four-point.png",
                    IMAGES / "gallery_mug_four_point.png")
    print(f"wrote the pictures of docs/cli.md in {IMAGES}")
