"""The scene images' shading, each method's own truth, sub-pixel supersampling, aliasing and WB16's
sparkle counts (docs/math/glint_images.md#glint-shading, #glint-own-truth, #glint-aliasing)."""
import math

import numpy as np
import pytest

import glintlab as gl

from glintlab.api.glinty_ndf import IMAGE_METHODS, register_image_method
from glintlab.api.ndf import ndf as smooth_ndf
from glintlab.validation import scene_images as si
from glintlab.validation.scene import table1_scenes

SEED = 5


def _lambda_by_quadrature(target, alpha, theta):
    """Smith's Lambda from its definition: 1 + Lambda(v) = int max(0, v.m) D(m) dm / cos(theta_v)."""
    D = smooth_ndf(target, alpha)
    nt, nphi = 1500, 720
    th = (np.arange(nt) + 0.5) * (math.pi / 2) / nt
    ph = (np.arange(nphi) + 0.5) * 2 * math.pi / nphi
    T, P = np.meshgrid(th, ph, indexing="ij")
    m = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)
    v = np.array([math.sin(theta), 0.0, math.cos(theta)])
    integrand = np.maximum(m @ v, 0) * D.D(np.cos(T)) * np.sin(T)
    return integrand.sum() * (math.pi / 2 / nt) * (2 * math.pi / nphi) / math.cos(theta) - 1


@pytest.mark.parametrize("target", ["beckmann", "ggx"])
def test_smith_lambda_matches_its_definition_and_the_other_ndfs_does_not(target):
    other = "ggx" if target == "beckmann" else "beckmann"
    for alpha, theta in ((0.5, 1.2), (0.3, 1.35)):
        q = _lambda_by_quadrature(target, alpha, theta)
        assert abs(si.smith_lambda(target, alpha, math.cos(theta)) - q) < 2e-3 * max(q, 1e-2), (alpha, theta, q)
        # The wrong NDF's Lambda (a deliberately wrong shading) is far off.
        assert abs(si.smith_lambda(other, alpha, math.cos(theta)) - q) > 0.05 * q


def _frame(name="plane_90", scale=1 / 40):
    sc = {s.name: s for s in table1_scenes()}[name]
    return si.with_directional_light(sc.scaled(scale, keep_n=True))


def test_shading_factor_is_the_brdf_at_normal_incidence_and_zero_off_the_mask():
    inp = si.frame_inputs(_frame())
    mat = si.Material.of(_frame())
    sh = si.shading(inp, mat)
    assert (sh[~inp.mask] == 0).all() and (sh[inp.mask] > 0).all()
    # Where the view, the light and the normal coincide F = F0, G = 1, cos_o = 1: F0 / 4. Forced here.
    one = si.FrameInputs(inp.uv[:1, :1], inp.J[:1, :1], np.array([[[0, 0, 1.0]]]), np.ones((1, 1), bool),
                         view=np.array([[[0, 0, 3.0]]]), n=np.array([[[0, 0, 1.0]]]),
                         light=np.array([[[0, 0, 1.0]]]), h_world=np.array([[[0, 0, 1.0]]]))
    assert si.shading(one, mat)[0, 0] == pytest.approx(si.F0 / 4, rel=1e-12)
    # At grazing view the factor follows F G / (4 cos_o) by hand.
    co, ci = 0.2, 0.9
    v = np.array([math.sqrt(1 - co * co), 0, co])
    lt = np.array([-math.sqrt(1 - ci * ci), 0, ci])
    h = (v + lt) / np.linalg.norm(v + lt)
    one = si.FrameInputs(inp.uv[:1, :1], inp.J[:1, :1], h[None, None], np.ones((1, 1), bool), view=5 * v[None, None],
                         n=np.array([[[0, 0, 1.0]]]), light=lt[None, None], h_world=h[None, None])
    F = si.F0 + (1 - si.F0) * (1 - v @ h) ** 5
    G = 1 / (1 + si.smith_lambda(mat.target, mat.alpha, co) + si.smith_lambda(mat.target, mat.alpha, ci))
    assert si.shading(one, mat)[0, 0] == pytest.approx(F * G / (4 * co), rel=1e-12)


def test_truth_kinds_are_registered_with_the_methods():
    assert si.truth_kind("truth") == "self" and IMAGE_METHODS.get("truth").is_truth
    for name in ("db23_trilinear[gated]", "db23_shader_48[gated]", "zk16", "smooth"):
        assert si.truth_kind(name) == "facets"
    assert si.truth_kind("kpt25") == "reference" and si.truth_kind("wwh18") == "reference"
    for name in ("wb16", "wb16_star", "wb16_lookup_noise"):
        assert si.truth_kind(name) == "supersampled" and IMAGE_METHODS.get(name).returns == "intensity"
    with pytest.raises(ValueError, match="truth = 'exact'"):
        register_image_method("x_bad_truth", lambda m: None, truth="exact")
    assert "x_bad_truth" not in IMAGE_METHODS


def test_own_truths_are_the_exact_models_on_the_same_realization():
    sc = _frame("sphere", 1 / 30)
    path = si.render_path(sc, ["truth", "zk16", "kpt25", "wwh18"], frames=2, seed=SEED, directional=False)
    assert path.truths["zk16"] is path.images["truth"] and path.truths["truth"] is path.images["truth"]
    inp = si.frame_inputs(si.camera_path(sc, 2)[1])
    mat = si.Material.of(sc)
    for name in ("kpt25", "wwh18"):
        ev = si.make_method(name, mat)
        ref = si.reference_image(ev, inp, SEED)
        assert np.array_equal(path.truths[name][1], ref)
        assert not np.array_equal(ref, path.images["truth"][1])  # not the facets
        # Another realization is not the own truth (what a wrong seed would give).
        assert not np.array_equal(si.reference_image(ev, inp, SEED + 1), ref)
    t = si.flicker_table(path).set_index("method")
    # Facet-truth methods: the own-truth columns are the facet columns.
    assert t.loc["zk16", "own_std_ratio"] == t.loc["zk16", "std_ratio"]
    assert t.loc["zk16", "own_pop_rate"] == t.loc["zk16", "pop_rate"]
    assert t.loc["kpt25", "own_truth"] == "reference"
    assert np.isfinite(t.loc["kpt25", "smooth_rel_rmse"]) and t.loc["smooth" if "smooth" in t.index else "truth",
                                                                    "own_std_ratio"] == 1.0


def test_subpixel_inputs_are_first_order_in_the_offset():
    sc = _frame("plane_25", 1 / 40)
    inp = si.frame_inputs(sc)
    y, x = np.mgrid[0:sc.height, 0:sc.width].astype(float)
    errs = {}
    for o in (0.5, 0.25):
        sub = si.subpixel_inputs(inp, o, -o, 4)
        tr = sc.trace(x + 0.5 + o, y + 0.5 - o)
        m = inp.mask & tr["hit"]
        errs[o] = np.abs(sub.world_pos[m] - tr["x"][m]).max()
        assert np.abs(sub.uv[m] - tr["uv"][m]).max() < 0.05 * np.abs(inp.J[m]).max()
        assert np.allclose(sub.J, inp.J / 4)
    # Second-order error: halving the offset divides it by about 4 (a wrong sign or scale would not).
    assert errs[0.25] < 0.3 * errs[0.5], errs
    wrong = inp.world_pos - 0.25 * inp.dxdpx + 0.25 * inp.dxdpy
    tr = sc.trace(x + 0.75, y + 0.25)
    m = inp.mask & tr["hit"]
    assert np.abs(wrong[m] - tr["x"][m]).max() > 10 * errs[0.25]


def test_supersampling_one_subpixel_is_the_image_and_the_facets_barely_alias():
    sc = _frame("plane_90", 1 / 30)
    inp = si.frame_inputs(sc)
    mat = si.Material.of(sc)
    truth = si.make_method("truth", mat)
    assert np.array_equal(si.supersampled(truth, inp, SEED, n=1), si.render(truth, inp, SEED))
    smooth = si.make_method("smooth", mat)
    s4 = si.supersampled(smooth, inp, SEED, n=4)
    m = inp.mask
    assert np.abs(s4[m] / si.render(smooth, inp)[m] - 1).max() < 0.02  # a smooth D(h) is already filtered
    with pytest.raises(ValueError, match="n = 0"):
        si.supersampled(truth, inp, n=0)


class _Dots:
    """A synthetic intensity method: vertical pairs of lit pixels every 6 rows and columns."""
    returns = "intensity"

    def image(self, inputs, seed=0, frame=0):
        H, W = inputs.mask.shape
        r, c = np.mgrid[0:H, 0:W]
        return np.where(inputs.hit & (r % 6 < 2) & (c % 6 == 0), 1.0, 0.0)


def test_sparkle_table_counts_components_and_their_size():
    register_image_method("x_dots", lambda m: _Dots(), returns="intensity", replace=True)
    try:
        sc = {s.name: s for s in table1_scenes()}["plane_90"].scaled(1 / 20)
        t = si.sparkle_table(sc, "x_dots", bins=2, directional=False)
        inp = si.frame_inputs(si.with_directional_light(sc))
        img = _Dots().image(inp)
        # Whole pairs inside the hit region: each a 2-pixel sparkle.
        assert t.sparkles.sum() >= (img.sum() // 2) - sc.width
        assert (t.mean_size_px <= 2).all() and (t.mean_size_px > 1.5).all()
        assert t.pixels.sum() == int(inp.hit.sum())
    finally:
        IMAGE_METHODS._items.pop("x_dots", None)


class _Stripes:
    """A point-sampled intensity method: thin stripes of the texture far finer than a pixel."""
    returns = "intensity"

    def image(self, inputs, seed=0, frame=0):
        period = 0.3 * np.abs(inputs.J[..., 0]).max()
        return np.where(inputs.mask & (np.mod(inputs.uv[..., 0], period) < 0.1 * period), 1.0, 0.0)


def test_aliasing_table_separates_a_filtered_method_from_a_point_sampled_one():
    register_image_method("x_stripes", lambda m: _Stripes(), returns="intensity", replace=True)
    try:
        sc = _frame("plane_90", 1 / 40)
        t = si.aliasing_table(sc, ["smooth", "truth", "x_stripes"], frames=2, n=4, seed=SEED).set_index("method")
        assert t.loc["smooth", "alias_rel_rmse"] < 0.02
        assert np.isfinite(t.loc["truth", "alias_rel_rmse"])
        # Stripes of a third of a pixel: the 1-sample image is 0 or 1, the 4 x 4 filter about 0.1 each.
        assert t.loc["x_stripes", "alias_rel_rmse"] > 1.0
        assert (t.frames == 2).all() and (t.supersample == "4x4").all()
    finally:
        IMAGE_METHODS._items.pop("x_stripes", None)


def test_a_density_mapping_is_applied_and_stated():
    from glintlab.api.glinty_ndf import method_density
    from glintlab.studies.scene_images import density_statement
    mat = si.Material(density=1e4, target="beckmann", alpha=0.5, R=0.5)
    # KPT25's registered mapping: the point density with DB23's expected visible glints per pixel.
    kp = gl.matched_density(1e4, 0.02, "beckmann", 0.5, 0.5)
    assert method_density("kpt25", mat) == kp and si.make_method("kpt25", mat).density == kp
    assert si.make_method("zk16", mat).density == 1e4
    assert "matched to equal expected glint counts: kpt25" in density_statement(["truth", "kpt25"])
    # The mapping is the entry's: the same method registered without one runs at N (the registry is
    # restored after the test).
    entry = IMAGE_METHODS.get("kpt25")
    register_image_method("kpt25", entry.factory, entry.label, entry.truth, replace=True, doc=entry.doc)
    assert si.make_method("kpt25", mat).density == 1e4
    assert "not matched" in density_statement(["truth", "kpt25"])
    with pytest.raises(ValueError, match="nope"):
        method_density("nope", mat)


# ---------------------------------------------------------------------------------------------- isolation
# tests/python/conftest.py restores every registry after each test: the first test registers an image
# method and leaves it, the second (run after it, in file order) must not see it.

def test_isolation_a_test_may_leave_a_registration_behind():
    register_image_method("x_left_behind", lambda m: _Dots(), returns="intensity", density=lambda m: 1.0)
    assert "x_left_behind" in gl.image_methods()


def test_isolation_the_next_test_does_not_see_it():
    assert "x_left_behind" not in gl.image_methods()
