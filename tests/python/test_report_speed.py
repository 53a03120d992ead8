"""The report's budget (issue 32): KPT25's reference to a stated tolerance (the scene images' own truth of
KPT25) and the CPU seconds the report records per section. No timing is asserted here: the cost is
checked through the points each reference sums, which does not depend on the machine's load."""
import json
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.glinty_ndf import IMAGE_REFERENCE_TOL
from glintlab.resources import data_path
from glintlab.validation import scene_images as si
from glintlab.validation.scene import table1_scenes

# |tol reference - exact| <= tol x D(h) x W / K_P (docs/math/glinty_ndf.md#glinty-reference-reach), W / K_P
# the pixel's summed filter weight: pi / 4 in expectation, and below 2 on every pixel of these footprints
# (hundreds of points per footprint keep its spread to a few per cent).
W_OVER_KP_MAX = 2.0


def _sphere_pixels(scale=0.05):
    """The lit pixels of the sphere scene's first frame (the report's density) and KPT25's image method."""
    sc = {s.name: s for s in table1_scenes(data_path("scenes"))}["sphere"]
    small = si.with_directional_light(si.with_density(sc.scaled(scale, keep_n=True), 0.0625))
    ev = si.make_method("kpt25", si.Material.of(small))
    inp = si.frame_inputs(small)
    m = inp.mask
    return ev, inp, inp.uv[m], inp.J[m], inp.h[m]


def test_reference_to_a_tolerance_stays_within_its_bound_and_sums_a_fraction_of_the_points():
    ev, _, uv, J, h = _sphere_pixels()
    assert ev.reference_tol == IMAGE_REFERENCE_TOL  # the scene images' own truth uses the tolerance
    exact, p_exact = ev.reference(uv, J, h, seed=1, tol=0.0, return_points=True)
    fast, p_fast = ev.reference(uv, J, h, seed=1, return_points=True)
    D = ev.smooth(h)
    assert len(D) > 500 and np.count_nonzero(exact) > 0.9 * len(D)
    bound = IMAGE_REFERENCE_TOL * D * W_OVER_KP_MAX
    assert np.all(np.abs(fast - exact) <= bound)
    # At 1e-15 most pixels are bit for bit: the skipped terms are below an ulp.
    assert np.mean(ev.reference(uv, J, h, seed=1, tol=1e-15) == exact) > 0.9
    # The cost: far fewer points visited (the exact sum reaches 39 sigma, nearly the whole disk here).
    assert p_fast.sum() < 0.2 * p_exact.sum()
    # The same bound fails for a reach too short (tol 0.5: r about 1.2 sigma), so the check can fail.
    short = ev.reference(uv, J, h, seed=1, tol=0.5)
    assert np.any(np.abs(short - exact) > bound)
    # tol = 0 is the exact sum, bit for bit, as the default of a KPT25 built without reference_tol.
    plain = gl.glinty_ndf("kpt25", density=ev.density, target=ev.target, alpha=ev.alpha, alpha_star=0.02, k=4,
                          epsilon=0.1)
    assert plain.reference_tol == 0.0
    np.testing.assert_array_equal(plain.reference(uv, J, h, seed=1), exact)


def test_reference_tolerance_bound_holds_at_grazing_and_anisotropic_lobes():
    # Narrow lobes (D(h) small at grazing: sigma = alpha_star sqrt(D) tiny, r grows as log(1 / sigma^2))
    # and anisotropic glints (sigma_x != sigma_y).
    rng = np.random.default_rng(4)
    n = 300
    uv = rng.uniform(0, 3, size=(n, 2))
    J = np.tile([0.02, 0.0, 0.005, 0.03], (n, 1))
    theta = rng.uniform(0, 1.35, n)
    h = np.stack([np.sin(theta), np.zeros(n), np.cos(theta)], axis=-1)
    for kw in ({}, {"anisotropy": (2.0, 0.5)}):
        nd = gl.glinty_ndf("kpt25", density=2e4, alpha=0.4, alpha_star=0.05, **kw)
        exact = nd.reference(uv, J, h, seed=3)
        fast = nd.reference(uv, J, h, seed=3, tol=1e-15)
        assert np.all(np.abs(fast - exact) <= 1e-15 * nd.smooth(h) * W_OVER_KP_MAX)


@pytest.mark.parametrize("tol", [-1e-9, 1.0, math.nan, math.inf])
def test_bad_tolerance_is_refused_by_name(tol):
    nd = gl.glinty_ndf("kpt25", density=1e4, alpha=0.5)
    with pytest.raises(ValueError, match="tol"):
        nd.reference([[0.1, 0.2]], [[0.01, 0, 0, 0.01]], [[0, 0, 1.0]], tol=tol)
    with pytest.raises(ValueError, match="reference_tol"):
        gl.glinty_ndf("kpt25", density=1e4, alpha=0.5, reference_tol=tol)


def test_rgb_reference_is_only_exact():
    with pytest.raises(ValueError, match="tol"):
        gl.glinty_ndf("kpt25", density=1e4, alpha=0.5, colors=[[1, 1, 1]]).reference(
            [[0.1, 0.2]], [[0.01, 0, 0, 0.01]], [[0, 0, 1.0]], tol=1e-15)


def test_report_records_cpu_seconds_per_section(tmp_path):
    from glintlab.report.runner import run
    summary = run(tmp_path, quick=True, quiet=True, only=["exact_laws"])
    sec = summary["sections"]["exact_laws"]
    assert sec["cpu_seconds"] > 0 and summary["cpu_seconds"] >= sec["cpu_seconds"]
    record = json.loads((tmp_path / "sections" / "exact_laws.json").read_text())
    assert record["cpu_seconds"] == sec["cpu_seconds"]
    assert "s CPU" in (tmp_path / "index.html").read_text()


@pytest.mark.parametrize("section, key", [("scenes", "scale"), ("glinty_ndf", "reference_tol")])
def test_report_size_parameters_refuse_bad_values_by_name(tmp_path, section, key):
    from glintlab.report.sections import SECTIONS
    from glintlab.studies.base import Context
    sec = SECTIONS.get(section)
    for bad in (1.5, -0.1):
        with pytest.raises(ValueError, match=key):
            sec.compute({**sec.defaults, key: bad}, Context(tmp_path, 1))
