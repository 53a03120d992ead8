"""Python surface of the ground truth (gl.Rect, gl.Ellipse, gl.ground_truth, gl.joint_counts)."""
import math

import numpy as np
import pytest

import glintlab as gl


def test_api_and_exact_agreement():
    gt = gl.ground_truth("stratified", density=100**2, footprint=gl.Rect(0.1, 0.07, angle=0.3), p=0.3)
    assert gt.n == pytest.approx(70.0)
    assert gt.grid_side == 100 and gt.center is None and gt.layout == "stratified"
    d = gt.pmf()
    assert d.mean == pytest.approx(21.0, rel=1e-12)
    k = gt.sample(size=50_000, seed=1)
    assert k.shape == (50_000,) and k.dtype == np.float64
    # Fixed seed; the false-failure rate of this check is 1e-4.
    assert gl.chi2_test(k, d).pvalue > 1e-4
    np.testing.assert_array_equal(k, gt.sample(size=50_000, seed=1))


def test_quadrature_converges_for_a_random_centre():
    gt = gl.ground_truth("stratified", density=50**2, footprint=gl.Ellipse(0.05, 0.03, angle=0.4), p=0.5)
    coarse, fine = gt.pmf(quadrature=8), gt.pmf(quadrature=32)
    assert gl.distance(coarse, fine, "tv") < 1e-3
    assert fine.mean == pytest.approx(0.5 * gt.n, rel=1e-12)


def test_uniform_and_poisson_laws_are_the_closed_forms():
    fp = gl.Ellipse(0.02, 0.01)
    u = gl.ground_truth("uniform", density=10**6, footprint=fp, p=0.2).pmf()
    b = gl.law("binomial").pmf(10**6, fp.area * 0.2)
    assert gl.distance(u, b, "tv") < 1e-12
    pz = gl.ground_truth("poisson", density=2.5e5, footprint=fp, p=0.2).pmf()
    assert pz.mean == pytest.approx(2.5e5 * fp.area * 0.2, rel=1e-12)


def test_uv_derivative_footprint():
    e = gl.Ellipse.from_uv_derivatives(0.01, 0.002, -0.001, 0.005)
    assert e.area == pytest.approx(abs(0.01 * 0.005 - (-0.001) * 0.002), rel=1e-12)
    t = np.linspace(0, 2 * math.pi, 50)
    r = 1 / math.sqrt(math.pi)
    jx, jy = 0.01 * np.cos(t) - 0.001 * np.sin(t), 0.002 * np.cos(t) + 0.005 * np.sin(t)
    assert e.contains(0.999 * r * jx, 0.999 * r * jy).all()
    assert not e.contains(1.001 * r * jx, 1.001 * r * jy).any()


def test_joint_counts_on_one_realization():
    fps = [gl.Rect(0.03, 0.03), gl.Rect(0.05, 0.05)]
    k = gl.joint_counts("stratified", 10**4, 0.4, fps, [(0.5, 0.5), (0.5, 0.5)], size=2000, seed=3)
    assert k.shape == (2000, 2)
    assert (k[:, 0] <= k[:, 1]).all()
    assert np.corrcoef(k[:, 0], k[:, 1])[0, 1] > 0.5


@pytest.mark.parametrize("kwargs, name", [
    (dict(layout="grid"), "layout"),
    (dict(density=10), "density = 10"),
    (dict(density=-1.0), "density = -1"),
    (dict(density=float("nan")), "density = nan"),
    (dict(p=1.5), "p = 1.5"),
    (dict(center=(float("inf"), 0.0)), "center[0]"),
    (dict(center="middle"), "center"),
    (dict(footprint=(0.1, 0.1)), "footprint"),
    (dict(footprint=None), "footprint"),
])
def test_bad_input_names_the_parameter(kwargs, name):
    args = dict(layout="stratified", density=10**4, footprint=gl.Rect(0.1, 0.1), p=0.3)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name.replace("[", r"\[").replace("]", r"\]")):
        gl.ground_truth(**args)


@pytest.mark.parametrize("make, name", [
    (lambda: gl.Rect(-1, 1), "width = -1"),
    (lambda: gl.Rect(1, float("nan")), "height = nan"),
    (lambda: gl.Ellipse(0.1, 0.0), "b = 0"),
    (lambda: gl.Ellipse.from_uv_derivatives(1, 2, 2, 4), "det"),
    (lambda: gl.ground_truth("poisson", 100, gl.Rect(1.5, 0.1), 0.5), "bounding box"),
    (lambda: gl.ground_truth("poisson", 100, gl.Rect(0.1, 0.1), 0.5).sample(size=-1), "size"),
    (lambda: gl.joint_counts("poisson", 100, 0.5, [gl.Rect(0.1, 0.1)], [], 10), "centers"),
])
def test_bad_shapes_and_calls(make, name):
    with pytest.raises(ValueError, match=name):
        make()
