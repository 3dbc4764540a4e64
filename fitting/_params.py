"""Scheme parameters as unconstrained variables, so the solver stays in valid ranges.

optimistix has no bound or ordering constraints for least squares, so each fitted
parameter is a smooth bijection of an unconstrained real:

- `CornerCutting`: $r = \\sigma(a)$, $s = r + (1 - r)\\sigma(b)$, so $0 < r < s < 1$
  (with one of them fixed, the other ranges over its open interval);
- `FourPoint`: $w = w_{\\max}\\,\\sigma(c)$ with $w_{\\max} = 0.19$: the scheme is $C^1$ for
  $0 < w < 0.1927...$ (Hechler, Mößner, Reif 2009; `jaxsubdiv.smoothness` certifies 0.19);
- `SplitTweak`: $t = \\sigma(c)$, $0 < t < 1$.

$\\sigma$ is the logistic function. Parameters at the edge of their range (e.g.
`SplitTweak(0)`) start just inside it.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import jaxsubdiv as js


# C1 up to w ~ 0.1927 (Hechler, Moessner, Reif 2009; certified at 0.19 by
# jaxsubdiv.smoothness). Dyn, Levin and Gregory's (sqrt(5) - 1)/8 is a sufficient bound.
W_MAX = 0.19
_EDGE = 1e-6  # how far inside its range a parameter on the boundary starts


def _logit(p):
    p = jnp.clip(p, _EDGE, 1 - _EDGE)
    return jnp.log(p) - jnp.log1p(-p)


FITTABLE = {
    js.CornerCutting: ("r", "s"),
    js.FourPoint: ("w",),
    js.SplitTweak: ("t",),
}


def fitted_names(scheme, fit_params) -> tuple[str, ...]:
    """Resolve `fit_params` (False, True or names) against the scheme's parameters."""
    available = FITTABLE.get(type(scheme), ())
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
    """Initial unconstrained values for the fitted parameters."""
    if not names:
        return {}
    if isinstance(scheme, js.CornerCutting):
        r, s = scheme.r, scheme.s
        out = {}
        if "r" in names:
            # r = s * sigma(a) when s is fixed; sigma(a) when both are fitted.
            out["r"] = _logit(r) if "s" in names else _logit(r / s)
        if "s" in names:
            out["s"] = _logit((s - r) / (1 - r))
        return out
    if isinstance(scheme, js.FourPoint):
        w = scheme.w
        if not isinstance(w, jax.core.Tracer) and not bool(jnp.all((w > 0) & (w < W_MAX))):
            raise ValueError(
                f"fitting `w` starts from the scheme's w = {float(w):.4g}; it must lie in "
                f"(0, {W_MAX:.6f}) (the range where the four-point scheme is known to be "
                "C1). Start from e.g. FourPoint(1/16)."
            )
        return {"w": _logit(w / W_MAX)}
    return {"t": _logit(scheme.t)}


def from_unconstrained(scheme, names, raw: dict):
    """The scheme with the fitted parameters set from their unconstrained values."""
    if not names:
        return scheme
    sig = jax.nn.sigmoid
    if isinstance(scheme, js.CornerCutting):
        r, s = scheme.r, scheme.s
        if "r" in names and "s" in names:
            r = sig(raw["r"])
            s = r + (1 - r) * sig(raw["s"])
        elif "r" in names:
            r = s * sig(raw["r"])
        else:
            s = r + (1 - r) * sig(raw["s"])
        # tree_at keeps the values as computed (valid by construction; no range check).
        return eqx.tree_at(lambda m: (m.r, m.s), scheme, (r, s))
    if isinstance(scheme, js.FourPoint):
        return eqx.tree_at(lambda m: m.w, scheme, W_MAX * sig(raw["w"]))
    return eqx.tree_at(lambda m: m.t, scheme, sig(raw["t"]))
