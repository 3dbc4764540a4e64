"""fitting: invert subdivision with optimistix.

Fit control polygons, and scheme parameters such as `r`, `s`, `w` and `t`, to sampled
outlines; one at a time or in batches; differentiably.
"""

from ._batch import fit_batch as fit_batch
from ._checks import (
    ORDER_SAMPLES_LIMIT as ORDER_SAMPLES_LIMIT,
    fit_memory as fit_memory,
)
from ._core import PHASES as PHASES
from ._corners import find_corners as find_corners
from ._fit import fit as fit
from ._init import order_samples as order_samples
from ._pixels import (
    PixelError as PixelError,
    pixel_error as pixel_error,
)
from ._progress import progress_verbose as progress_verbose
from ._result import (
    STATUSES as STATUSES,
    FitResult as FitResult,
    FitStatus as FitStatus,
)
from ._tolerance import fit_tolerance as fit_tolerance
