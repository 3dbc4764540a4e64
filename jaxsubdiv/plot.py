"""Matplotlib figures: a curve with its control polygon, rows of refinement levels (as in
the seed paper's figures), a fit colored by its error, a loss history, and smoothness
against a scheme parameter.

Importing this module does not import `matplotlib.pyplot` and needs no display: new
figures are `matplotlib.figure.Figure` objects; save one with
`artists.ax.figure.savefig("out.png")`. Every function takes an optional `ax` (or
`axes`) to draw into and returns the artists it drew.
"""

from ._plot import (
    CurveArtists as CurveArtists,
    FitArtists as FitArtists,
    LevelsFigure as LevelsFigure,
    SmoothnessArtists as SmoothnessArtists,
    plot_curve as plot_curve,
    plot_fit as plot_fit,
    plot_levels as plot_levels,
    plot_loss as plot_loss,
    plot_smoothness as plot_smoothness,
)
