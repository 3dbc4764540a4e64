"""The worked design study of docs/fitting.md: how a fit responds to its data.

    python docs/make_fitting_figures.py      # writes docs/images/fit_sensitivity.png, prints figures

A four-point curve with a fitted tension w is fitted to the outer contour of DejaVu Sans
'o' (smooth: at sharp corners, such as those of 'S', samples switch between branches of
the curve and the fit is not a differentiable function of the data at the scale of finite
differences).
Implicit differentiation (`jax.grad` through `fitting.fit`) gives, in one backward pass,
the sensitivity of the fitted w to every sample; it is checked against a central finite
difference for one design change (pushing the upper arc of the S outwards). Then
`jax.jacfwd` gives the sensitivity of the fitted control polygon to the smoothing weight.
"""

import pathlib
import time

import jax
import matplotlib


matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import fitting  # noqa: E402
import jaxsubdiv as js  # noqa: E402


jax.config.update("jax_enable_x64", True)
IMAGES = pathlib.Path(__file__).parent / "images"


def main():
    outline = js.io.read_outlines(text="o", font="DejaVu Sans", samples=300)[0].points
    target = jax.numpy.asarray(outline)

    # A tight tolerance, so that the finite differences below measure the optimum's
    # change and not where the solver happened to stop.
    settings = dict(fit_params=True, tol=1e-12, max_steps=2000)

    def fitted_w(samples):
        return fitting.fit(samples, js.FourPoint(1 / 16), 16, **settings).scheme.w

    start = time.perf_counter()
    result = fitting.fit(target, js.FourPoint(1 / 16), 16, **settings)
    print(f"fit: w = {float(result.scheme.w):.5f}, rms {float(result.rms):.2e}, "
          f"{int(result.num_steps)} steps, {result.message}")
    sensitivity = np.asarray(jax.grad(fitted_w)(target))  # dw / d(sample), shape (m, 2)
    print(f"grad of fitted w w.r.t. all {len(outline)} samples: "
          f"{time.perf_counter() - start:.1f} s including compilation")

    # The design change: push the samples of the upper arc outwards (away from the
    # outline's center), by a smooth bump; predict the change of w and check it.
    center = outline.mean(0)
    upper = outline[:, 1] > np.quantile(outline[:, 1], 0.75)
    bump = np.where(upper, 1.0, 0.0)[:, None] * (outline - center)
    bump /= np.abs(bump).max()
    predicted = float(np.sum(sensitivity * bump))
    print(f"dw/d(push of the upper arc): implicit {predicted:.6g}")
    for h in (1e-4, 1e-5):
        finite = (float(fitted_w(target + h * bump)) - float(fitted_w(target - h * bump))) / (2 * h)
        print(f"  central difference, h = {h:g}: {finite:.6g}")

    def control_given_smoothing(smoothing):
        return fitting.fit(target, js.FourPoint(1 / 16), 16, smoothing=smoothing,
                           tol=1e-10).control_points

    velocity = np.asarray(jax.jacfwd(control_given_smoothing)(0.01))  # dP / d smoothing
    print(f"largest |dP/d smoothing| at smoothing 0.01: {np.abs(velocity).max():.3g}")

    fig, axes = plt.subplots(1, 2, figsize=(10, 5.5), dpi=100)
    ax = axes[0]
    magnitude = np.linalg.norm(sensitivity, axis=1)
    dots = ax.scatter(*outline.T, c=magnitude, s=8, cmap="viridis")
    fig.colorbar(dots, ax=ax, shrink=0.8, label="|dw / d sample|")
    curve = np.asarray(result.curve)
    ax.plot(*np.vstack([curve, curve[:1]]).T, color="0.3", lw=0.6)
    ax.quiver(*outline[upper].T, *bump[upper].T, color="tab:red", scale=12, width=0.004,
              label="design change: push the upper arc out")
    ax.set_title(f"fitted tension w = {float(result.scheme.w):.4f}: where it comes from\n"
                 f"dw/d(push) = {predicted:.4g} (finite difference {finite:.4g})", fontsize=9)
    ax.set_aspect("equal")
    ax.legend(loc="lower left", fontsize=7)
    ax = axes[1]
    control = np.asarray(control_given_smoothing(0.01))
    ax.plot(*np.vstack([control, control[:1]]).T, "o--", ms=3, lw=0.8, color="tab:orange",
            label="control polygon, smoothing 0.01")
    ax.quiver(*control.T, *velocity.T, color="tab:blue", angles="xy", width=0.004,
              label="dP / d smoothing")
    ax.plot(*outline.T, ".", ms=1.5, color="0.6")
    ax.set_title("how the control polygon moves as smoothing grows", fontsize=9)
    ax.set_aspect("equal")
    ax.legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    path = IMAGES / "fit_sensitivity.png"
    fig.savefig(path, bbox_inches="tight")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
