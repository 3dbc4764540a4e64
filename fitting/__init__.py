"""fitting: invert subdivision with optimistix.

Fit control polygons, and scheme parameters such as `r`, `s` and `w`, to sampled
outlines. Not implemented yet: see the project's issue on fitting.
"""
