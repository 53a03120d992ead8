"""``out=`` on every sampler (issue 21): the same values as a fresh array, written in place into the
caller's buffer, and a ValueError naming ``out`` for a buffer that would need a copy."""
import numpy as np
import pytest

import glintlab as gl


def _samplers():
    gated = gl.law("gated")
    custom = gl.custom_law(lambda n, p, u: np.floor(n * p * u[:, 0]), n_uniforms=1, name="out_test_half")
    blend = gl.blended_law("distributed", inner="gated")
    counter = gl.aniso_counter("db23_trilinear", inner="gated", base_area=1e-4)
    gt = gl.ground_truth("stratified", density=30**2, footprint=gl.Rect(0.1, 0.07, angle=0.3), p=0.3)
    P = np.linspace(0.5, 20, 12).reshape(3, 4)
    return {
        "law batch": ((3, 4), lambda **kw: gated.sample(1e3, 0.01, size=(3, 4), seed=5, **kw)),
        "law per pixel": ((3, 4), lambda **kw: gated.sample(P * 100, 0.01, seed=5, **kw)),
        "binomial": ((1000,), lambda **kw: gl.law("binomial").sample(40.5, 0.3, size=1000, seed=5, **kw)),
        "custom law": ((50,), lambda **kw: custom.sample(10.0, 0.5, size=50, seed=5, **kw)),
        "blend": ((3, 4), lambda **kw: blend.sample(100, P, 0.1, seed=5, **kw)),
        "blend sample_at": ((3, 4), lambda **kw: blend.sample_at(100, P, 0.1, P / 7, P / 11, seed=5, **kw)),
        "aniso": ((20,), lambda **kw: counter.sample(1e4, 0.3, 2.0, 0.5, 0.1, size=20, seed=5, **kw)),
        "ground truth": ((30,), lambda **kw: gt.sample(30, seed=5, **kw)),
    }


@pytest.mark.parametrize("name", list(_samplers()))
def test_out_fills_the_callers_buffer_with_the_same_values(name):
    shape, fn = _samplers()[name]
    fresh = fn()
    buf = np.full(shape, -7.0)
    got = fn(out=buf)
    assert got is buf
    np.testing.assert_array_equal(buf, fresh)


@pytest.mark.parametrize("bad, message", [
    (np.empty((3, 4), dtype=np.float32), "dtype"),
    (np.empty((4, 3)), "shape"),
    (np.empty(12), "shape"),
    (np.empty((3, 8))[:, ::2], "C-contiguous"),
    ([0.0] * 12, "out"),
])
def test_out_refuses_a_buffer_that_would_need_a_copy(bad, message):
    law = gl.law("gated")
    with pytest.raises(ValueError, match=message):
        law.sample(1e3, 0.01, size=(3, 4), seed=1, out=bad)
    with pytest.raises(ValueError, match="out"):
        law.sample(1e3, 0.01, size=(3, 4), seed=1, out=bad)


def test_out_refuses_a_read_only_buffer():
    buf = np.empty(10)
    buf.flags.writeable = False
    with pytest.raises(ValueError, match="out is read-only"):
        gl.law("gated").sample(1e3, 0.01, size=10, seed=1, out=buf)
    with pytest.raises(ValueError, match="out"):
        gl.blended_law("nearest", inner="gated").sample(100, 2.0, 0.1, size=10, seed=1, out=buf)
