"""The scheme registry (`jaxsubdiv.schemes()`, `jaxsubdiv.scheme_info`): every entry
builds, its ranges are the papers', its fit bijection maps onto the C1 interval and
inverts, and every scheme survives the result JSON.

Ranges and intervals are written here from the papers and the schemes' docstrings, not
read from the registry: the registry is checked against them.
"""

import inspect
import json
import math
import sys
import warnings
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

import jaxsubdiv as js
import jaxsubdiv.io as jio
from jaxsubdiv._scheme.registry import declarations, markdown_table


# (registry name, parameter) -> (low, high, low_open, high_open): the valid ranges
# (None: unbounded, any finite value).
PAPER_RANGES = {
    # Any w: where it converges (-1/2 < w < 1/2) is the analysis' to say (#20), beyond
    # Dyn, Levin and Gregory's (1987) sufficient |w| < 1/4.
    ("four-point", "w"): (None, None, True, True),
    # de Rham 1947; Gregory and Qu 1996: 0 < r < s < 1 (each ratio inside (0, 1)).
    ("corner-cutting", "r"): (0, 1, True, True),
    ("corner-cutting", "s"): (0, 1, True, True),
    # Any t: Rossignac's (2004) family is 0 <= t <= 1 (the cubic B-spline to the
    # four-point scheme); it converges on -9 < t < 7 (test_analysis).
    ("split-tweak", "t"): (None, None, True, True),
    # Lane-Riesenfeld: degree >= 1; exact float64 mask up to 55 (MAX_DEGREE's note).
    ("lane-riesenfeld", "degree"): (1, 55, False, False),
}
# Defaults: w = 1/16 reproduces cubics (Dyn, Levin, Gregory 1987); r, s = 1/4, 3/4 is
# Chaikin; t = 1/2 is Rossignac's Jarek; degree 3 the cubic B-spline.
PAPER_DEFAULTS = {
    ("four-point", "w"): 1 / 16,
    ("corner-cutting", "r"): 1 / 4,
    ("corner-cutting", "s"): 3 / 4,
    ("split-tweak", "t"): 1 / 2,
    ("lane-riesenfeld", "degree"): 3,
}
# The range text each error must show (the docstrings' spelling).
RANGE_TEXT = {
    ("four-point", "w"): "any finite w",
    ("corner-cutting", "r"): "0 < r < 1",
    ("corner-cutting", "s"): "0 < s < 1",
    ("split-tweak", "t"): "any finite t",
    ("lane-riesenfeld", "degree"): "1 <= degree <= 55",
}
# Where a fit keeps each fittable parameter: four-point is C1 for 0 < w < 0.1927...
# (Hechler, Mößner, Reif 2009), fitted in (0, 0.19); split-and-tweak is C1 on (-5, 3)
# and fitted in (0, 1), Rossignac's family;
# corner cutting is fitted in 0 < r < s < 1 (with chords: C1 only on s = r + 1/2).
FIT_INTERVALS = {
    ("four-point", "w"): (0, 0.19),
    ("split-tweak", "t"): (0, 1),
    ("corner-cutting", "r"): (0, 1),
    ("corner-cutting", "s"): (0, 1),
}
C1_PARAMETERS = {("four-point", "w"), ("split-tweak", "t")}
CLASSES = {
    "chaikin": "Chaikin", "corner-cutting": "CornerCutting", "cubic-bspline": "CubicBSpline",
    "daubechies": "Daubechies", "four-point": "FourPoint",
    "lane-riesenfeld": "LaneRiesenfeld", "split-tweak": "SplitTweak", "jarek": "Jarek",
}

ENTRIES = list(js.schemes().items())
PARAMETERS = [(name, p) for name, info in ENTRIES for p in info.parameters]


def _ids(value):
    if isinstance(value, js.Parameter):
        return value.name
    return value if isinstance(value, str) else None


def test_the_registry_lists_the_built_in_schemes_in_module_order():
    assert list(js.schemes()) == [
        "chaikin", "corner-cutting", "cubic-bspline", "daubechies", "four-point",
        "lane-riesenfeld", "split-tweak", "jarek",
    ]
    for name, info in ENTRIES:
        assert info.cls is getattr(js, CLASSES[name])
        assert info.name == name
    assert {(name, p.name) for name, p in PARAMETERS} == set(PAPER_RANGES)


@pytest.mark.parametrize("name, info", ENTRIES, ids=[n for n, _ in ENTRIES])
def test_every_entry_builds_with_defaults(name, info):
    scheme = info.make()
    assert type(scheme) is info.cls
    for p in info.parameters:
        value = getattr(scheme, p.name)
        if p.integer:
            assert value == p.default and isinstance(value, int)
        else:
            np.testing.assert_allclose(float(value), p.default, rtol=1e-15)
    # The same entry from the instance, the class and the name.
    assert js.scheme_info(scheme) is js.scheme_info(info.cls) is js.scheme_info(name) is info


@pytest.mark.parametrize("name, p", PARAMETERS, ids=_ids)
def test_ranges_are_the_papers_and_defaults_lie_inside(name, p):
    low, high, low_open, high_open = PAPER_RANGES[name, p.name]
    assert (p.low, p.high, p.low_open, p.high_open) == (low, high, low_open, high_open)
    assert low is None or (low < p.default if low_open else low <= p.default)
    assert high is None or (p.default < high if high_open else p.default <= high)
    assert p.range_text() == RANGE_TEXT[name, p.name]
    p.check(p.default)
    assert p.default == PAPER_DEFAULTS[name, p.name]
    # The constructor's default is the same (declared once).
    cls = js.scheme_info(name).cls
    assert inspect.signature(cls.__init__).parameters[p.name].default == p.default


def _outside(low, high, low_open, high_open, integer):
    step = 1 if integer else 1e-9
    if low is None and high is None:
        return [math.nan, math.inf, -math.inf]
    return [low if low_open else low - step, high if high_open else high + step]


def _inside(low, high, low_open, high_open, integer):
    step = 1 if integer else 1e-9
    if low is None and high is None:
        return [-1e300, 1e300]  # valid, if far outside where the scheme converges
    return [low + step if low_open else low, high - step if high_open else high]


@pytest.mark.parametrize("name, p", PARAMETERS, ids=_ids)
def test_values_just_outside_the_range_are_a_clear_error(name, p):
    info = js.scheme_info(name)
    bounds = (*PAPER_RANGES[name, p.name], p.integer)
    for value in _outside(*bounds):
        with pytest.raises(ValueError) as error:
            info.make(**{p.name: value})
        message = str(error.value)
        assert f"{info.cls.__name__}({p.name})" in message and RANGE_TEXT[name, p.name] in message
        # The constructor itself refuses it too (the range it checks is the same).
        others = {q.name: q.default for q in info.parameters if q.name != p.name}
        with pytest.raises(ValueError, match=p.name):
            info.cls(**others, **{p.name: value})
    for value in _inside(*bounds):
        # Corner cutting's other ratio moves out of the way of r < s.
        others = {}
        if name == "corner-cutting":
            others = {"s": 1 - 1e-10} if p.name == "r" else {"r": 1e-10}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", js.DivergenceWarning)
            scheme = info.make(**others, **{p.name: value})
        assert info.values(scheme)[p.name] == value


def test_corner_cutting_needs_r_below_s():
    info = js.scheme_info("corner-cutting")
    for r, s in ((0.6, 0.4), (0.5, 0.5)):
        with pytest.raises(ValueError, match="0 < r < s < 1"):
            info.make(r=r, s=s)


def test_make_refuses_unknown_parameters_and_types():
    with pytest.raises(TypeError, match="no parameter 'x'"):
        js.scheme_info("four-point").make(x=0.1)
    with pytest.raises(TypeError, match="must be an int"):
        js.scheme_info("lane-riesenfeld").make(degree=2.5)
    with pytest.raises(TypeError, match=r"FourPoint\(w\)"):
        js.scheme_info("four-point").make(w="0.1")
    with pytest.raises(TypeError, match=r"`FourPoint\(w\)` must be a real number"):
        js.scheme_info("four-point").parameter("w").check("0.1")


@pytest.mark.parametrize("name, info", ENTRIES, ids=[n for n, _ in ENTRIES])
def test_values_of_make_are_the_values_given(name, info):
    rng = np.random.default_rng(len(name))
    values = {}
    for p in info.parameters:
        low, high, _, _ = PAPER_RANGES[name, p.name]
        low, high = p.converges or (low, high)
        values[p.name] = int(rng.integers(low, high + 1)) if p.integer else float(
            rng.uniform(low + 0.01, high - 0.01))
    if name == "corner-cutting":
        values["r"], values["s"] = sorted((values["r"], values["s"]))
    scheme = info.make(**values)
    got = info.values(scheme)
    assert got == values
    assert all(type(got[k]) is type(values[k]) for k in values)


def test_scheme_info_errors_and_the_mask_scheme_entry():
    with pytest.raises(ValueError, match="unknown scheme 'nope'.*four-point"):
        js.scheme_info("nope")
    with pytest.raises(TypeError, match="scheme_info"):
        js.scheme_info(3.5)
    mask = js.MaskScheme([0.25, 0.75, 0.75, 0.25], -2)
    info = js.scheme_info(mask)
    assert info.cls is js.MaskScheme and info.parameters == () and not info.listed
    assert js.MaskScheme not in [i.cls for i in js.schemes().values()]
    with pytest.raises(TypeError, match="MaskScheme"):
        info.make()


def test_declarations_read_without_jax_equal_the_classes():
    """The command line reads the declarations from source, without importing JAX."""
    read = declarations()
    assert list(read) == list(js.schemes())
    for name, info in js.schemes().items():
        d = read[name]
        assert (d.title, d.class_name, d.parameters, d.listed) == (
            info.title, info.cls.__name__, info.parameters, info.listed)
        assert d.module == info.cls.__module__
    import subprocess

    code = (
        "import sys; from jaxsubdiv._scheme.registry import declarations; "
        "assert declarations()['four-point'].parameters[0].default == 1/16; "
        "print(sorted(m for m in ('jax', 'numpy', 'equinox') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


# --- the fit's bijection -----------------------------------------------------------


FITTABLE = [(name, p) for name, p in PARAMETERS if p.fit_interval is not None]


def test_fittable_parameters():
    assert {(name, p.name) for name, p in FITTABLE} == set(FIT_INTERVALS)
    assert {(name, p.name) for name, p in PARAMETERS if p.c1 is not None} == C1_PARAMETERS
    assert js.scheme_info("corner-cutting").fittable == ("r", "s")
    assert js.scheme_info("four-point").fittable == ("w",)
    assert js.scheme_info("lane-riesenfeld").fittable == ()


def _logistic(u):
    return 1 / (1 + np.exp(-u))


@pytest.mark.parametrize("name, p", FITTABLE, ids=_ids)
def test_bijection_maps_reals_into_the_interval_and_inverts(name, p):
    info = js.scheme_info(name)
    start = info.make()
    low, high = FIT_INTERVALS[name, p.name]
    # Far out, the logistic saturates (to the interval's closure in float64).
    for u in np.linspace(-6.0, 6.0, 25):
        scheme = start.from_unconstrained((p.name,), {p.name: np.float64(u)})
        value = float(getattr(scheme, p.name))
        if name == "corner-cutting":
            # One ratio fitted, the other fixed: r = s sigma(a), s = r + (1 - r) sigma(b).
            r0, s0 = 1 / 4, 3 / 4
            expected = s0 * _logistic(u) if p.name == "r" else r0 + (1 - r0) * _logistic(u)
            assert 0 < scheme.r < scheme.s < 1
        else:
            expected = low + (high - low) * _logistic(u)
            assert low < value < high
        assert value == pytest.approx(expected, rel=1e-14, abs=1e-15)
        back = scheme.to_unconstrained((p.name,))[p.name]
        assert float(back) == pytest.approx(u, abs=1e-12)


def test_corner_cutting_bijection_with_both_ratios():
    start = js.CornerCutting(0.25, 0.75)
    rng = np.random.default_rng(0)
    for a, b in rng.normal(0, 3, (20, 2)):
        scheme = start.from_unconstrained(("r", "s"), {"r": a, "s": b})
        r = _logistic(a)
        assert float(scheme.r) == pytest.approx(r, rel=1e-14)
        assert float(scheme.s) == pytest.approx(r + (1 - r) * _logistic(b), rel=1e-14)
        back = scheme.to_unconstrained(("r", "s"))
        assert float(back["r"]) == pytest.approx(a, abs=1e-12)
        assert float(back["s"]) == pytest.approx(b, abs=1e-12)


@pytest.mark.parametrize("name, p", [(n, p) for n, p in FITTABLE if p.c1], ids=_ids)
def test_c1_interval_is_c1(name, p):
    """Inside its c1 interval the scheme is C1, as `jaxsubdiv.smoothness` certifies."""
    start = js.scheme_info(name).make()
    for u in (-2.0, 0.0, 2.0):
        scheme = start.from_unconstrained((p.name,), {p.name: np.float64(u)})
        assert js.smoothness(scheme).continuity >= 1, (name, u)


def test_fit_start_outside_the_c1_interval_is_refused():
    with pytest.raises(ValueError, match=r"\(0, 0\.19"):
        js.FourPoint(0.2).to_unconstrained(("w",))
    with pytest.raises(ValueError, match=r"FourPoint\(1/16\)"):
        js.FourPoint(0.0).to_unconstrained(("w",))
    # On a closed end of its valid range a parameter starts just inside the interval.
    assert float(js.SplitTweak(0.0).to_unconstrained(("t",))["t"]) < -13


def test_uses_tangents_follows_the_c1_ranges():
    from fitting._params import uses_tangents

    # The schemes' own smoothness: four-point is C1 for 0 < w < 0.1927 (Hechler et al.),
    # corner cutting only on s = r + 1/2 (Chaikin), Daubechies D4 is not C1.
    assert uses_tangents(js.FourPoint(1 / 16), (), "closed")
    assert uses_tangents(js.FourPoint(1 / 16), ("w",), "open")
    assert not uses_tangents(js.FourPoint(0.2), (), "closed")
    assert not uses_tangents(js.FourPoint(1 / 16), (), "clamped")  # repeated end points
    # Clamped ends reflected through the end point: exact tangents there.
    assert uses_tangents(js.CubicBSpline(), (), "clamped")
    assert uses_tangents(js.SplitTweak(0.4), ("t",), "clamped")
    assert not uses_tangents(js.Chaikin(), (), "clamped")  # a dual scheme's end
    assert uses_tangents(js.CornerCutting(0.25, 0.75), (), "closed")
    assert not uses_tangents(js.CornerCutting(0.25, 0.75), ("r",), "closed")
    assert not uses_tangents(js.CornerCutting(0.3, 0.7), (), "closed")
    assert uses_tangents(js.Jarek(), (), "closed")
    assert not uses_tangents(js.Daubechies(), (), "closed")
    assert uses_tangents(js.MaskScheme([0.25, 0.75, 0.75, 0.25], -2), (), "closed")


# --- Jarek, MaskScheme ---------------------------------------------------------------


def test_jarek_is_split_and_tweak_at_one_half():
    # Rossignac's rule at t = 1/2: Q_2j = (V_{j-1} + V_{j+1})/16 + 7/8 V_j,
    # Q_2j+1 = 17/32 (V_j + V_{j+1}) - 1/32 (V_{j-1} + V_{j+2}).
    expected = np.array([-1, 2, 17, 28, 17, 2, -1]) / 32
    jarek = js.Jarek()
    assert type(jarek) is js.Jarek and jarek.mask_start == -3
    np.testing.assert_array_equal(jarek.host_mask(), expected)
    assert jarek.host_mask().dtype == np.float64
    np.testing.assert_allclose(np.asarray(js.SplitTweak(0.5).mask()), expected, atol=1e-16)
    P = np.random.default_rng(1).normal(size=(9, 2))
    np.testing.assert_allclose(np.asarray(js.refine(P, jarek, 3)),
                               np.asarray(js.refine(P, js.SplitTweak(0.5), 3)), atol=1e-14)


def test_mask_scheme_coefficients_and_the_deprecated_mask_alias():
    coefficients = [0.25, 0.75, 0.75, 0.25]
    new = js.MaskScheme(coefficients=coefficients, start=-2)
    with pytest.warns(DeprecationWarning, match="coefficients"):
        old = js.MaskScheme(mask=coefficients, start=-2)
    np.testing.assert_array_equal(np.asarray(old.coefficients), coefficients)
    np.testing.assert_array_equal(np.asarray(new.coefficients), coefficients)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        js.MaskScheme(coefficients, -2)  # positional: no warning
    with pytest.raises(TypeError, match="both"):
        js.MaskScheme(coefficients, -2, mask=coefficients)
    with pytest.raises(TypeError, match="start"):
        js.MaskScheme(coefficients)


# --- result JSON ---------------------------------------------------------------------


POLYGON = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.5], [0.5, 2.0]])
JSON_CASES = [
    (js.FourPoint(0.07), "FourPoint", {"w": 0.07}),
    (js.CornerCutting(0.2, 0.65), "CornerCutting", {"r": 0.2, "s": 0.65}),
    (js.SplitTweak(0.3), "SplitTweak", {"t": 0.3}),
    (js.LaneRiesenfeld(4), "LaneRiesenfeld", {"degree": 4}),
    (js.Chaikin(), "Chaikin", {}),
    (js.CubicBSpline(), "CubicBSpline", {}),
    (js.Daubechies(), "Daubechies", {}),
    (js.Jarek(), "Jarek", {}),
    (js.MaskScheme([0.25, 0.75, 0.75, 0.25], -2), "MaskScheme",
     {"coefficients": [0.25, 0.75, 0.75, 0.25], "start": -2}),
]


def test_json_cases_cover_every_entry():
    assert {name for _, name, _ in JSON_CASES} == set(CLASSES.values()) | {"MaskScheme"}


@pytest.mark.parametrize("scheme, type_name, parameters", JSON_CASES,
                         ids=[c[1] for c in JSON_CASES])
def test_result_json_round_trip_names_the_class(tmp_path, scheme, type_name, parameters):
    path = tmp_path / "result.json"
    jio.write_result_json(path, {"control_points": POLYGON, "scheme": scheme})
    written = json.loads(Path(path).read_text())["scheme"]
    assert written == {"type": type_name, "parameters": parameters}
    saved = jio.read_result_json(path).scheme
    assert type(saved) is type(scheme)
    np.testing.assert_array_equal(np.asarray(saved.mask()), np.asarray(scheme.mask()))
    assert saved.mask_start == scheme.mask_start


def test_result_json_reads_old_mask_files_and_checks_parameters(tmp_path):
    head = '{"format": "jaxsubdiv.result", "version": 1, "control_points": [[0, 0], [1, 1]], '
    path = tmp_path / "r.json"
    path.write_text(head + '"scheme": {"type": "MaskScheme", "parameters": '
                    '{"mask": [0.25, 0.75, 0.75, 0.25], "start": -2}}}')
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an old file is no deprecated call
        scheme = jio.read_result_json(path).scheme
    np.testing.assert_array_equal(np.asarray(scheme.coefficients), [0.25, 0.75, 0.75, 0.25])
    for parameters, words in [
        ('{"w": 1e999}', ["FourPoint", "any finite w"]),
        ('{"w": 0.1, "x": 1}', ["FourPoint", "unknown", "x"]),
        ("{}", ["FourPoint", "missing", "w"]),
        ('{"w": true}', ["FourPoint", "real number"]),
    ]:
        path.write_text(head + f'"scheme": {{"type": "FourPoint", "parameters": {parameters}}}}}')
        with pytest.raises(jio.OutlineError) as error:
            jio.read_result_json(path)
        assert all(w in str(error.value) for w in words), str(error.value)
        assert "\n" not in str(error.value)


class _UserChaikin(js.AbstractCurveScheme):
    """A scheme defined outside jaxsubdiv (the mask of Chaikin's scheme)."""

    def mask(self):
        return jnp.asarray([0.25, 0.75, 0.75, 0.25])

    mask_start = -2
    mask_length = 4


def test_result_json_refuses_a_scheme_it_could_not_read_back(tmp_path):
    """The reader rebuilds jaxsubdiv's schemes by class name, so the writer refuses a
    user's class (with the MaskScheme way out) instead of writing an unreadable file."""
    path = tmp_path / "user.json"
    with pytest.raises(ValueError) as error:
        jio.write_result_json(path, {"control_points": POLYGON, "scheme": _UserChaikin()})
    assert "_UserChaikin" in str(error.value) and "MaskScheme" in str(error.value)
    assert not path.exists()


def test_saved_result_is_not_a_pytree_of_strings(tmp_path):
    import jax

    path = tmp_path / "result.json"
    jio.write_result_json(path, {"control_points": POLYGON, "scheme": js.FourPoint(0.07),
                                 "boundary": "open", "levels": 3}, info={"input": "x"})
    saved = jio.read_result_json(path)
    assert jax.tree.leaves(saved) == [saved]  # one host object, no string leaves
    with pytest.raises(AttributeError):
        saved.boundary = "closed"  # frozen
    assert (saved.boundary, saved.levels, saved.info) == ("open", 3, {"input": "x"})


# --- docs ----------------------------------------------------------------------------


def test_readme_scheme_table_is_the_generated_one():
    readme = (Path(__file__).parents[1] / "README.md").read_text(encoding="utf-8")
    assert markdown_table() in readme, (
        "README.md's scheme table differs from the registry: paste "
        "jaxsubdiv._scheme.registry.markdown_table() between its markers"
    )
    # Every class appears in it, and the ranges the papers give.
    for name in [*CLASSES.values(), "MaskScheme"]:
        assert f"`{name}(" in readme
    for text in RANGE_TEXT.values():
        assert text in readme
