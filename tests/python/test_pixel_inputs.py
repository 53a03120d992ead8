"""One bad-input contract for every glinty NDF and every image method (issue 31, item 10;
docs/math/glinty_ndf.md#glinty-inputs): NaN or infinity in uv, J or h, a zero h and a singular J are
refused with a ValueError naming the array, the element's multi-index and its value; h below the
horizon gives 0. The cases iterate the registries, so a new NDF or image method is covered without an
edit here."""
from __future__ import annotations

import inspect
import re

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.glinty_ndf import GLINTY_NDFS
from glintlab.api.glinty_ndf import image_methods
from glintlab.validation.scene_images import Material, make_method

# Small densities keep every method cheap at three pixels.
MATERIAL = Material(density=1e4, target="beckmann", alpha=0.5, R=0.5)


def _evaluators():
    for name in GLINTY_NDFS.names():
        # The smooth NDF has no density: every other one gets a small one.
        kw = {"density": 1e4} if "density" in inspect.signature(GLINTY_NDFS.get(name)).parameters else {}
        yield f"glinty_ndf:{name}", (lambda name=name, kw=kw: gl.glinty_ndf(name, **kw))
    # Methods that return an NDF per (uv, J, h); intensity methods (WB16, user method shaders) take the whole
    # GlintInput of a scene's pixel and are checked by render() (tests/python/test_method_shaders.py).
    for name in image_methods(returns="ndf"):
        yield f"image_method:{name}", (lambda name=name: make_method(name, MATERIAL))


EVALUATORS = dict(_evaluators())


def _good():
    uv = np.array([[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]])
    J = np.tile([0.01, 0.002, -0.001, 0.012], (3, 1))
    h = np.array([[0.1, 0.0, 1.0], [0.0, 0.2, 1.0], [0.3, -0.1, 0.9]])
    return uv, J, h


def _bad(case):
    """(uv, J, h, expected message pattern) with one bad element at pixel 1."""
    uv, J, h = _good()
    if case == "nan_uv":
        uv[1, 0] = np.nan
        return uv, J, h, r"uv\[1, 0\] = nan"
    if case == "inf_J":
        J[1, 2] = -np.inf
        return uv, J, h, r"J\[1, 2\] = -inf"
    if case == "nan_h":
        h[1, 1] = np.nan
        return uv, J, h, r"h\[1, 1\] = nan"
    if case == "inf_h":
        h[2, 2] = np.inf
        return uv, J, h, r"h\[2, 2\] = inf"
    if case == "zero_h":
        h[1] = 0.0
        return uv, J, h, r"h\[1\] = \(0\.0, 0\.0, 0\.0\).*nonzero"
    if case == "singular_J":
        J[1] = [0.01, 0.02, 0.005, 0.01]  # rows proportional: det J = 0
        return uv, J, h, r"J\[1\] = \(0\.01, 0\.02, 0\.005, 0\.01\).*det J"
    raise AssertionError(case)


CASES = ["nan_uv", "inf_J", "nan_h", "inf_h", "zero_h", "singular_J"]


@pytest.mark.parametrize("method", sorted(EVALUATORS))
def test_every_glinty_ndf_and_image_method_shares_one_bad_input_contract(method):
    ev = EVALUATORS[method]()
    uv, J, h = _good()
    good = ev.evaluate(uv, J, h, seed=1)
    assert good.shape == (3,) and np.all(np.isfinite(good)) and np.all(good >= 0), (method, good)
    # Below the horizon: a defined 0, not an error.
    low = h.copy()
    low[0, 2] = -0.5
    assert ev.evaluate(uv, J, low, seed=1)[0] == 0.0, method
    # A multi-dimensional batch names the element by its multi-index.
    uv2, J2, h2 = (a.reshape(1, 3, -1) for a in _good())
    h2[0, 2, 0] = np.nan
    with pytest.raises(ValueError, match=re.escape("h[0, 2, 0] = nan")):
        ev.evaluate(uv2, J2, h2, seed=1)
    for case in CASES:
        uv, J, h, pattern = _bad(case)
        with pytest.raises(ValueError, match=pattern):
            ev.evaluate(uv, J, h, seed=1)


@pytest.mark.parametrize("method", sorted(EVALUATORS))
def test_the_contract_scales_with_h(method):
    # A valid direction at any scale: h 2^-700 (whose plain norm underflows to 0) is the same half
    # vector as h, not a "zero" one, and h 2^700 is not an overflow: scales by a power of two are
    # exact, so the results are equal bit for bit. Other scales move the direction by an ulp, which
    # can flip a glint (counts jump with h): they must only be accepted.
    ev = EVALUATORS[method]()
    uv, J, h = _good()
    a = ev.evaluate(uv, J, h, seed=3)
    np.testing.assert_array_equal(ev.evaluate(uv, J, h * 2.0**-700, seed=3), a)
    np.testing.assert_array_equal(ev.evaluate(uv, J, h * 2.0**700, seed=3), a)
    for s in (1e-200, 1e200):
        out = ev.evaluate(uv, J, h * s, seed=3)
        assert out.shape == a.shape and np.all(np.isfinite(out)) and np.all(out >= 0), (method, s, out)


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

BUDGET = settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
_BUILT = {}


def _method(name):
    if name not in _BUILT:
        _BUILT[name] = EVALUATORS[name]()
    return _BUILT[name]


@BUDGET
@given(method=st.sampled_from(sorted(EVALUATORS)), array=st.sampled_from(["uv", "J", "h"]),
       pixel=st.integers(0, 2), component=st.integers(0, 3), value=st.sampled_from([np.nan, np.inf, -np.inf]),
       scale=st.sampled_from([1e-150, 1e-3, 1.0, 1e150]))
def test_property_a_non_finite_element_is_named_by_its_index(method, array, pixel, component, value, scale):
    """Any one NaN or infinity anywhere in uv, J or h: a ValueError naming exactly that element; any
    scale of h is accepted otherwise."""
    uv, J, h = _good()
    h = h * scale
    arrays = {"uv": uv, "J": J, "h": h}
    a = arrays[array]
    component %= a.shape[1]
    ev = _method(method)
    out = ev.evaluate(uv, J, h, seed=1)
    assert np.all(np.isfinite(out)) and np.all(out >= 0), (method, out)
    a[pixel, component] = value
    with pytest.raises(ValueError, match=re.escape(f"{array}[{pixel}, {component}] = {value!r}")):
        ev.evaluate(uv, J, h, seed=1)
