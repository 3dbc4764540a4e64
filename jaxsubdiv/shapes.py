"""Built-in control polygons.

`names()` lists them and `get(name)` returns one as a float array of shape `(n, 2)`.
"""

import numpy as np


def _star(points: int = 5, inner: float = 0.45) -> np.ndarray:
    angles = np.pi / 2 + np.arange(2 * points) * np.pi / points
    radii = np.where(np.arange(2 * points) % 2 == 0, 1.0, inner)
    return np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=-1)


_SHAPES = {
    # A five-pointed star: sharp corners that each scheme rounds differently.
    "star": _star(),
    # The unit square.
    "square": np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
}


def names() -> list[str]:
    """Names of the built-in shapes."""
    return sorted(_SHAPES)


def get(name: str) -> np.ndarray:
    """The control polygon of a built-in shape, shape `(n, 2)` (a copy)."""
    try:
        return _SHAPES[name].copy()
    except KeyError:
        raise ValueError(f"unknown shape {name!r}; the built-in shapes are {names()}.") from None
