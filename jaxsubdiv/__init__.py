"""jaxsubdiv: differentiable, batched subdivision curves and surfaces in JAX.

The public names below are loaded on first use (PEP 562), so that `import jaxsubdiv` is
instant and the `jaxsubdiv` command answers `--help` and usage errors without importing
JAX; `jaxsubdiv.refine` and the rest import what they need when first touched.
"""

import importlib
from typing import TYPE_CHECKING


# Public name -> the module that defines it ("" for a public submodule of that name).
_PUBLIC = {
    # submodules
    "editor": "", "io": "", "plot": "", "shapes": "", "surfaces": "", "validation": "",
    # schemes
    "AbstractCurveScheme": "._scheme.base",
    "Chaikin": "._scheme.chaikin",
    "CornerCutting": "._scheme.corner_cutting",
    "CubicBSpline": "._scheme.cubic_bspline",
    "Daubechies": "._scheme.daubechies",
    "FourPoint": "._scheme.four_point",
    "LaneRiesenfeld": "._scheme.lane_riesenfeld",
    "MaskScheme": "._scheme.mask_scheme",
    "Jarek": "._scheme.split_tweak",
    "SplitTweak": "._scheme.split_tweak",
    # the scheme registry
    "DivergenceWarning": "._scheme.parameter",
    "Parameter": "._scheme.registry",
    "SchemeInfo": "._scheme.registry",
    "scheme_info": "._scheme.registry",
    "schemes": "._scheme.registry",
    # refinement
    "DEFAULT_MEMORY_BUDGET": "._refine",
    "refine": "._refine",
    "refined_count": "._refine",
    "CurveStencil": "._curve_stencil",
    "subdivision_matrix": "._refine",
    "min_points": ".validation",
    # analysis
    "Analysis": "._analysis.analyze",
    "analyze": "._analysis.analyze",
    "curve_stencil": "._analysis.limit",
    "limit_curve": "._analysis.limit",
    "limit_curvature": "._analysis.limit",
    "limit_points": "._analysis.limit",
    "limit_second_derivatives": "._analysis.limit",
    "limit_tangents": "._analysis.limit",
    "supports_clamped_derivatives": "._analysis.limit",
    "Eigen": "._analysis.local",
    "curvature_stencil": "._analysis.local",
    "eigen": "._analysis.local",
    "limit_stencil": "._analysis.local",
    "local_matrix": "._analysis.local",
    "neighborhood": "._analysis.local",
    "tangent_stencil": "._analysis.local",
    "Smoothness": "._analysis.smoothness",
    "smoothness": "._analysis.smoothness",
    # start-up
    "compilation_cache_dir": "._cache",
    "enable_compilation_cache": "._cache",
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    if name == "__version__":
        return _version()
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'jaxsubdiv' has no attribute {name!r}")
    value = importlib.import_module(module or f".{name}", __name__)
    if module:
        value = getattr(value, name)
    globals()[name] = value  # later look-ups are plain attribute reads
    return value


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))


if TYPE_CHECKING:  # what type checkers and IDEs see: the same names, eagerly
    from . import (
        editor as editor,
        io as io,
        plot as plot,
        shapes as shapes,
        surfaces as surfaces,
        validation as validation,
    )
    from ._analysis.analyze import (
        Analysis as Analysis,
        analyze as analyze,
    )
    from ._analysis.limit import (
        curve_stencil as curve_stencil,
        limit_curvature as limit_curvature,
        limit_curve as limit_curve,
        limit_points as limit_points,
        limit_second_derivatives as limit_second_derivatives,
        limit_tangents as limit_tangents,
        supports_clamped_derivatives as supports_clamped_derivatives,
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
    from ._analysis.smoothness import (
        Smoothness as Smoothness,
        smoothness as smoothness,
    )
    from ._cache import (
        compilation_cache_dir as compilation_cache_dir,
        enable_compilation_cache as enable_compilation_cache,
    )
    from ._curve_stencil import (
        CurveStencil as CurveStencil,
    )
    from ._refine import (
        DEFAULT_MEMORY_BUDGET as DEFAULT_MEMORY_BUDGET,
        refine as refine,
        refined_count as refined_count,
        subdivision_matrix as subdivision_matrix,
    )
    from ._scheme.base import (
        AbstractCurveScheme as AbstractCurveScheme,
    )
    from ._scheme.chaikin import (
        Chaikin as Chaikin,
    )
    from ._scheme.corner_cutting import (
        CornerCutting as CornerCutting,
    )
    from ._scheme.cubic_bspline import (
        CubicBSpline as CubicBSpline,
    )
    from ._scheme.daubechies import (
        Daubechies as Daubechies,
    )
    from ._scheme.four_point import (
        FourPoint as FourPoint,
    )
    from ._scheme.lane_riesenfeld import (
        LaneRiesenfeld as LaneRiesenfeld,
    )
    from ._scheme.mask_scheme import (
        MaskScheme as MaskScheme,
    )
    from ._scheme.parameter import DivergenceWarning as DivergenceWarning
    from ._scheme.registry import (
        Parameter as Parameter,
        SchemeInfo as SchemeInfo,
        scheme_info as scheme_info,
        schemes as schemes,
    )
    from ._scheme.split_tweak import (
        Jarek as Jarek,
        SplitTweak as SplitTweak,
    )
    from .validation import (
        min_points as min_points,
    )


def _version() -> str:
    import importlib.metadata  # 40 ms: only when asked

    try:
        return importlib.metadata.version("jaxsubdiv")
    except importlib.metadata.PackageNotFoundError:  # running from a source tree
        return "0.0.0"
