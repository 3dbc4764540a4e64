"""Built-in control polygons.

`names()` lists them and `get(name)` returns one as a float array of shape `(n, 2)`.

The shapes of the seed paper's figures (jar, mango, pi, car, rabbit, five-fingered hand,
U, mug) were drawn for jaxsubdiv after those figures: the paper gives pictures, not
coordinates, so these are new polygons, designed to be recognizable both as polygons and
after smoothing with approximating (cubic B-spline, Chaikin) and interpolating
(four-point) schemes. All are closed, simple (not self-intersecting), counter-clockwise
polygons of 10-40 points, roughly 2 units across and centered at the origin, with y up.
"""

import numpy as np


def _star(points: int = 5, inner: float = 0.45) -> np.ndarray:
    angles = np.pi / 2 + np.arange(2 * points) * np.pi / points
    radii = np.where(np.arange(2 * points) % 2 == 0, 1.0, inner)
    return np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=-1)


def _mirrored(right_half: list[tuple[float, float]]) -> np.ndarray:
    """A left-right symmetric polygon from its right half, listed bottom to top.

    Points on the axis (x = 0) are not repeated.
    """
    right = np.array(right_half, dtype=np.float64)
    left = right[::-1] * [-1, 1]
    left = left[1:] if right[-1, 0] == 0 else left
    left = left[:-1] if right[0, 0] == 0 else left
    return np.concatenate([right, left])


def _hand() -> np.ndarray:
    """A right hand, palm facing us: four fingers fanned out above the palm, thumb out
    to the right, wrist at the bottom."""
    # Finger: base center, direction (degrees from +x), length, half width.
    fingers = [
        ((-0.42, 0.15), 112, 0.65, 0.1),  # little finger
        ((-0.17, 0.25), 98, 0.9, 0.11),  # ring finger
        ((0.1, 0.27), 88, 0.98, 0.11),  # middle finger
        ((0.36, 0.2), 75, 0.85, 0.1),  # index finger
    ]
    points = [(-0.35, -1.0), (0.3, -1.0)]
    # Thumb, pointing up and out from the right of the palm.
    points += [
        (0.38, -0.55),
        (0.62, -0.3),
        (0.85, -0.05),
        (0.93, 0.08),
        (0.83, 0.15),
        (0.62, -0.02),
        (0.45, -0.1),
    ]
    for (x, y), angle, length, half in reversed(fingers):
        a = np.radians(angle)
        d, n = np.array([np.cos(a), np.sin(a)]), np.array([np.sin(a), -np.cos(a)])
        base = np.array([x, y])
        tip = base + length * d
        points += [
            tuple(base + half * n),
            tuple(tip + half * n),
            tuple(tip + 0.6 * half * d),
            tuple(tip - half * n),
            tuple(base - half * n),
        ]
    points += [(-0.55, -0.2), (-0.4, -0.6)]
    return np.array(points)


_SHAPES = {
    # A five-pointed star: sharp corners that each scheme rounds differently.
    "star": _star(),
    # The unit square.
    "square": np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
    # A jar: flat foot, round belly, narrow neck and a flared lip (after the seed
    # paper's Fig. 3.2).
    "jar": _mirrored(
        [
            (0.0, -1.0),
            (0.4, -1.0),
            (0.62, -0.85),
            (0.78, -0.45),
            (0.78, 0.05),
            (0.62, 0.4),
            (0.32, 0.58),
            (0.3, 0.78),
            (0.46, 0.88),
            (0.46, 1.0),
            (0.0, 1.0),
        ]
    ),
    # A mango: a lopsided oval with a hooked beak at the bottom left and a stalk on top
    # (Fig. 3.3).
    "mango": np.array(
        [
            (-0.05, -1.0),
            (0.35, -0.95),
            (0.7, -0.65),
            (0.88, -0.2),
            (0.85, 0.3),
            (0.65, 0.7),
            (0.32, 0.92),
            (0.08, 0.97),
            (0.06, 1.12),
            (-0.02, 1.12),
            (-0.05, 0.97),
            (-0.35, 0.85),
            (-0.6, 0.55),
            (-0.62, 0.1),
            (-0.5, -0.35),
            (-0.45, -0.7),
            (-0.55, -0.95),
            (-0.35, -1.0),
        ]
    ),
    # The letter pi: a top bar over a straight left leg and a right leg whose foot
    # curls out to the right (Figs. 3.4, 4.4, 5.4).
    "pi": np.array(
        [
            (-0.95, 0.55),
            (-0.45, 0.55),
            (-0.5, -0.45),
            (-0.65, -0.8),
            (-0.5, -0.92),
            (-0.3, -0.75),
            (-0.22, -0.4),
            (-0.2, 0.55),
            (0.22, 0.55),
            (0.22, -0.62),
            (0.35, -0.88),
            (0.62, -0.92),
            (0.85, -0.78),
            (0.8, -0.68),
            (0.58, -0.72),
            (0.47, -0.55),
            (0.47, 0.55),
            (0.95, 0.55),
            (1.0, 0.8),
            (-0.9, 0.8),
        ]
    ),
    # A car, side view: bumpers, two wheel arches, hood, windshield, roof and trunk
    # (Fig. 3.5).
    "car": np.array(
        [
            (-1.0, -0.3),
            (-0.82, -0.3),
            (-0.8, -0.08),
            (-0.62, 0.02),
            (-0.44, -0.08),
            (-0.42, -0.3),
            (0.42, -0.3),
            (0.44, -0.08),
            (0.62, 0.02),
            (0.8, -0.08),
            (0.82, -0.3),
            (1.0, -0.3),
            (1.05, -0.05),
            (0.95, 0.12),
            (0.45, 0.18),
            (0.22, 0.48),
            (-0.38, 0.5),
            (-0.65, 0.22),
            (-0.95, 0.18),
            (-1.05, 0.0),
        ]
    ),
    # A sitting rabbit facing right: body, round tail, head and two long ears
    # (Fig. 4.2).
    "rabbit": np.array(
        [
            (-0.55, -0.9),
            (0.55, -0.9),
            (0.62, -0.78),
            (0.4, -0.72),
            (0.45, -0.35),
            (0.42, 0.05),
            (0.68, 0.12),
            (0.82, 0.3),
            (0.72, 0.5),
            (0.45, 0.58),
            (0.42, 1.1),
            (0.3, 1.3),
            (0.22, 1.1),
            (0.28, 0.62),
            (0.2, 0.62),
            (0.05, 1.05),
            (-0.08, 1.15),
            (-0.08, 0.95),
            (0.1, 0.5),
            (0.05, 0.3),
            (-0.35, 0.25),
            (-0.65, 0.05),
            (-0.78, -0.3),
            (-0.95, -0.35),
            (-1.0, -0.55),
            (-0.82, -0.65),
            (-0.72, -0.85),
        ]
    ),
    # A right hand with five fingers spread (Fig. 4.3).
    "hand": _hand(),
    # The letter U as a thick outline (Fig. 5.2).
    "U": _mirrored(
        [
            (0.0, -0.9),
            (0.45, -0.78),
            (0.65, -0.4),
            (0.65, 0.9),
            (0.32, 0.9),
            (0.32, -0.35),
            (0.2, -0.52),
            (0.0, -0.56),
        ]
    ),
    # A mug, side view: straight body with a rim and a C-shaped handle on the right,
    # attached at the top and nearly touching at the bottom (Fig. 5.3).
    "mug": np.array(
        [
            (-0.7, -0.85),
            (-0.15, -0.88),
            (0.4, -0.85),
            (0.42, -0.45),
            (0.42, 0.28),
            (0.64, 0.32),
            (0.78, 0.06),
            (0.68, -0.24),
            (0.5, -0.36),
            (0.56, -0.52),
            (0.88, -0.42),
            (1.04, 0.0),
            (1.0, 0.35),
            (0.8, 0.56),
            (0.45, 0.56),
            (0.45, 0.8),
            (-0.15, 0.82),
            (-0.7, 0.8),
            (-0.72, -0.02),
        ]
    ),
}
for _points in _SHAPES.values():
    _points.setflags(write=False)
del _points


def names() -> list[str]:
    """Names of the built-in shapes, sorted."""
    return sorted(_SHAPES)


def get(name: str) -> np.ndarray:
    """The control polygon of a built-in shape.

    **Arguments:**

    - `name`: one of [`jaxsubdiv.shapes.names`][].

    **Returns:** a new float64 array of shape `(n, 2)`: a closed, counter-clockwise
    polygon (do not repeat the first point to close it; use `boundary="closed"`).
    """
    try:
        return np.array(_SHAPES[name], dtype=np.float64)
    except KeyError:
        raise ValueError(f"unknown shape {name!r}; the built-in shapes are {names()}.") from None
