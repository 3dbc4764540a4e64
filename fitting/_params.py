"""Scheme parameters as unconstrained variables, so the solver stays in valid ranges.

optimistix has no bound or ordering constraints for least squares, so each fitted
parameter is a smooth bijection of an unconstrained real. The bijections are declared
with the schemes (`jaxsubdiv.AbstractCurveScheme.to_unconstrained` and
`from_unconstrained`): by default $p = a + (b - a)\\,\\sigma(u)$ onto the parameter's
fit interval $(a, b)$ (its `jaxsubdiv.Parameter.c1` interval), $\\sigma$ the logistic
function; `CornerCutting` keeps $0 < r < s < 1$. Which parameters a scheme can fit is
`jaxsubdiv.scheme_info(scheme).fittable`:

- `CornerCutting`: $r$, $s$ (with the chord model: corner cutting is $C^1$ only on the
  line $s = r + 1/2$);
- `FourPoint`: $w \\in (0, 0.19)$: the scheme is $C^1$ for $0 < w < 0.1927...$
  (Hechler, Mößner, Reif 2009; `jaxsubdiv.smoothness` certifies 0.19);
- `SplitTweak`: $t \\in (0, 1)$.

Parameters at the edge of their range (e.g. `SplitTweak(0)`) start just inside it.
"""

import equinox as eqx
import jax
import numpy as np

import jaxsubdiv as js


def _fittable(scheme) -> tuple[str, ...]:
    try:
        return js.scheme_info(scheme).fittable
    except ValueError:  # a user scheme outside the registry: nothing to fit
        return ()


def fitted_names(scheme, fit_params) -> tuple[str, ...]:
    """Resolve `fit_params` (False, True or names) against the scheme's parameters."""
    available = _fittable(scheme)
    if isinstance(fit_params, (bool, np.bool_)):
        fit_params = bool(fit_params)
    elif fit_params is not None and not isinstance(fit_params, (str, tuple, list)):
        raise TypeError(
            f"`fit_params` must be False, True, a parameter name or a tuple of names; got "
            f"{fit_params!r}."
        )
    if fit_params is False or fit_params is None:
        return ()
    if fit_params is True:
        if not available and isinstance(scheme, js.MaskScheme):
            raise ValueError(
                "fit_params=True is not supported for MaskScheme: a free mask would have "
                "to keep its sub-masks summing to one. Fit a built-in scheme's parameters."
            )
        if not available:
            # Silently fitting nothing would look like a successful parameter fit.
            hint = (" `Jarek()` is `SplitTweak(1/2)` with t fixed; fit t with "
                    "`SplitTweak(0.5)`." if isinstance(scheme, js.Jarek) else "")
            raise ValueError(
                f"fit_params=True: {type(scheme).__name__} has no parameters to fit; the "
                f"schemes with fittable parameters are "
                f"{', '.join(info.cls.__name__ for info in js.schemes().values() if info.fittable)}."
                + hint
            )
        return available
    names = (fit_params,) if isinstance(fit_params, str) else tuple(fit_params)
    unknown = [n for n in names if n not in available]
    if unknown:
        raise ValueError(
            f"fit_params={fit_params!r}: {type(scheme).__name__} has no fittable "
            f"parameter {unknown}; its fittable parameters are {available or 'none'}."
        )
    return tuple(n for n in available if n in names)


def to_unconstrained(scheme, names) -> dict:
    """Initial unconstrained values for the fitted parameters (checks the start)."""
    if not names:
        return {}
    return scheme.to_unconstrained(names)


def from_unconstrained(scheme, names, raw: dict):
    """The scheme with the fitted parameters set from their unconstrained values."""
    if not names:
        return scheme
    return scheme.from_unconstrained(names, raw)


#: Whether a creased closed curve of a scheme whose clamped ends have tangents is
#: modelled by Hermite segments (exact one-sided tangents at the creases) instead of
#: chords. Measured, not yet the default (2026-12-06, `benchmarks/results/
#: fit_corner_model.md`): 0.35-0.56 of the time on traced 1024-px glyphs, but at the
#: C^1 default levels with 16 samples per span (n = 64 on 400 samples) fits took
#: 3-5x the steps, and matplotlib's hand icon ran to `max_steps` at 5 levels where
#: chords at 6 converged. `benchmarks/bench_fit_corner_model.py` switches it.
CREASED_HERMITE = False


def uses_tangents(scheme, names, boundary, creased: bool = False) -> bool:
    """Whether the fit can use the scheme's exact limit tangents (a C1 Hermite curve).

    Needs a C^1 limit at every parameter the solver may visit. Fitted parameters stay in
    their fit interval by construction, so each must have a C^1 interval in the registry
    (`jaxsubdiv.Parameter.fit_interval`: four-point w in (0, 0.19), split-and-tweak t in
    (0, 1));
    corner cutting has none (it is C^1 only on the line s = r + 1/2), so fitting r or s
    uses chords. Traced parameter values are assumed to lie in their C^1 intervals (so
    that the model, and the optimum, are the same as for concrete values there). A
    concrete scheme is checked with `jaxsubdiv.smoothness`. Clamped ends need a tangent
    rule there ([`jaxsubdiv.supports_clamped_derivatives`][]: the primal schemes whose
    clamped rule reflects the polygon; not the four-point scheme or dual ones), and so
    do the corners of a `creased` closed curve, whose pieces are clamped curves: that
    model is used only with `CREASED_HERMITE` (not yet the default).
    """
    if creased and not CREASED_HERMITE:
        return False
    if (boundary == "clamped" or creased) and not js.supports_clamped_derivatives(scheme):
        return False
    try:
        parameters = js.scheme_info(scheme).parameters
    except ValueError:  # a user scheme outside the registry: no declared C^1 ranges
        parameters = None
    if names and (parameters is None or any(
        p.c1 is None for p in parameters if p.name in names
    )):
        return False
    leaves = jax.tree.leaves(eqx.filter(scheme, eqx.is_array))
    if any(isinstance(leaf, jax.core.Tracer) for leaf in leaves):
        # Values unknown (e.g. differentiating the fit with respect to w): assume each
        # traced parameter lies in its C^1 interval, when it has one.
        numeric = [p for p in parameters or () if not p.integer]
        return bool(numeric) and all(p.c1 is not None for p in numeric)
    # Concrete parameters: certify on the host, also when called inside a trace. Cached
    # (fit and each item of fit_batch ask again; building the mask costs ~0.5 ms).
    key = (type(scheme), jax.tree.structure(scheme),
           tuple(np.asarray(leaf).tobytes() for leaf in leaves))
    if key not in _C1_CACHE:
        if len(_C1_CACHE) > 256:
            _C1_CACHE.clear()
        with jax.ensure_compile_time_eval():
            _C1_CACHE[key] = js.smoothness(scheme).continuity >= 1
    return _C1_CACHE[key]


_C1_CACHE: dict = {}
