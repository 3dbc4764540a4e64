"""jaxsubdiv: differentiable, batched subdivision curves and surfaces in JAX."""

import importlib.metadata

from . import (
    editor as editor,
    io as io,
    plot as plot,
    shapes as shapes,
    surfaces as surfaces,
)
from ._analysis.analyze import Analysis as Analysis, analyze as analyze
from ._analysis.limit import (
    limit_curvature as limit_curvature,
    limit_points as limit_points,
    limit_second_derivatives as limit_second_derivatives,
    limit_tangents as limit_tangents,
)
from ._analysis.local import (
    Eigen as Eigen,
    curvature_stencil as curvature_stencil,
    eigen as eigen,
    limit_stencil as limit_stencil,
    local_matrix as local_matrix,
    neighborhood as neighborhood,
    tangent_stencil as tangent_stencil,
)
from ._analysis.smoothness import Smoothness as Smoothness, smoothness as smoothness
from ._refine import (
    DEFAULT_MEMORY_BUDGET as DEFAULT_MEMORY_BUDGET,
    refine as refine,
    refined_count as refined_count,
    subdivision_matrix as subdivision_matrix,
)
from ._scheme.base import AbstractCurveScheme as AbstractCurveScheme
from ._scheme.chaikin import Chaikin as Chaikin
from ._scheme.corner_cutting import CornerCutting as CornerCutting
from ._scheme.cubic_bspline import CubicBSpline as CubicBSpline
from ._scheme.daubechies import Daubechies as Daubechies
from ._scheme.four_point import FourPoint as FourPoint
from ._scheme.lane_riesenfeld import LaneRiesenfeld as LaneRiesenfeld
from ._scheme.mask_scheme import MaskScheme as MaskScheme
from ._scheme.split_tweak import Jarek as Jarek, SplitTweak as SplitTweak


try:
    __version__ = importlib.metadata.version("jaxsubdiv")
except importlib.metadata.PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"
