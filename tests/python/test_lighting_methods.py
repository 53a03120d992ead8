"""The registered image methods under an extended light (glintlab.validation.lighting_methods;
docs/math/lighting.md#lighting-methods): the light integral of a glinty NDF by stratified quadrature.

Deterministic checks: the smooth NDF through the quadrature is the exact p (cap: 1e-3 relative at 64
samples, the rectangle 2e-2 at the worst view and 2e-3 p-weighted; both shrink as 1 / S); the point-light
limit (value / (L Omega) -> the density at the centre: as a^2 for the smooth NDF, at least as a for the
glinty ones, whose D_P is only Lipschitz in the half vector).

Statistical check (fixed seeds): a method's lit facets over the plane (sum of value x n over pixels and
frames), divided by its own point-light bias b (its sum over the smooth one's under a cap of 0.02 rad), is
the facets' expectation: z = (F - M / b) / sqrt(2 frames M / b), F the facets lit by the same cap (a Poisson
count whose variance the footprints' overlap at most doubles and the camera path's frames, which see the
same facets, multiply by their number), |z| < 4: a false-failure rate of about 6e-5 under the normal
approximation. The wrong variants (the Jacobian 1 / (4 wo.h) left out; the light's solid angle left out)
fail it.

Under the shipped sky: the smooth NDF per region against the exact p (1e-2 per region, 2e-3 for the value at
the default blocks of 8 cells), and the methods whose bias is 1 (smooth, ZK16, DB23's binomial) within 3 %
of the exact value sum_r L_r p_r over a frame (deterministic given the seed; measured 0.98-1.00)."""
import numpy as np
import pytest

import glintlab as gl
from glintlab.api.method_registry import make_method
from glintlab.validation import lighting_images as LI
from glintlab.validation import lighting_methods as LM
from glintlab.validation.scene_images import frame_inputs, resolve_scene, with_density, with_directional_light

#: The shipped NDF methods checked against the facets. WWH18 is left out: its image method (the flipped
#: threshold test) is not on D(h)'s scale under a point light either (docs/math/glint_images.md#glint-own-truth:
#: its mean is 1.2-2.4 times its own truth's); the path renders it all the same.
METHODS = ("smooth", "db23_trilinear[gated]", "db23_trilinear[binomial]", "db23_shader_48[gated]", "zk16", "kpt25")
UNBIASED = ("smooth", "db23_trilinear[binomial]", "zk16")  # their point-light bias is within 3 % of 1
MAX_Z = 4.5
FRAMES = 2
VARIANCE_FACTOR = 6.0  # var(F) / E[F] of the facets' sum over the path (measured; see the module's docs)


@pytest.fixture(scope="module")
def scene():
    return with_density(resolve_scene("plane_25").scaled(1 / 16, keep_n=True), 0.25)


@pytest.fixture(scope="module")
def frame(scene):
    mat, _ = LI.plane_material(scene)
    _, tbn, wo, uv, J, _ = LI._frame_geometry(frame_inputs(with_directional_light(scene)), mat.density)
    return mat, tbn, wo[::4], uv[::4], J[::4]


def _lit(path, name):
    valid = path.mask.all(axis=0)
    return float((path.images[name][:, valid] * path.n[:, valid]).sum())


@pytest.fixture(scope="module")
def paths(scene):
    kw = dict(frames=FRAMES, seed=3, grid_nodes=9, methods=METHODS)
    small = LM.method_light_path(scene, LI.scene_light(scene, "cap", (0.02, 0.0)), samples=16, **kw)
    big = LM.method_light_path(scene, LI.scene_light(scene, "cap", (0.2, 0.0)), samples=36, **kw)
    wrong = {v: LM.method_light_path(scene, LI.scene_light(scene, "cap", (0.2, 0.0)), samples=36, wrong=v,
                                     **{**kw, "methods": ["zk16"]}) for v in LM.WRONG_VARIANTS}
    return small, big, wrong


def _label(name):
    return gl.api.method_registry.IMAGE_METHODS.get(name).label


def _bias(small, name):
    return _lit(small, _label(name)) / _lit(small, _label("smooth"))


def _z(facets, lit, bias):
    m = lit / bias
    return (facets - m) / np.sqrt(VARIANCE_FACTOR * m)


@pytest.mark.parametrize("kind,size,worst,weighted", [("cap", (0.2, 0.0), 1e-3, 1e-4), ("rect", (0.3, 0.2), 2e-2, 2e-3)])
def test_the_smooth_ndf_through_the_quadrature_is_the_exact_p(scene, frame, kind, size, worst, weighted):
    mat, tbn, wo, _, _ = frame
    light = LI.scene_light(scene, kind, size).in_frame(*tbn)
    views = wo[:: max(1, len(wo) // 150)]
    err = LM.quadrature_error(mat.target, mat.alpha, light, views, LM.SAMPLES)
    assert err["values"] > 100
    assert err["max_rel_error"] < worst and err["weighted_rel_error"] < weighted, err
    coarse, fine = (LM.quadrature_error(mat.target, mat.alpha, light, views, s)["weighted_rel_error"] for s in (16, 144))
    assert fine < coarse / 3  # O(1 / S): 9 times the samples, at least 3 times less error
    dirs, w = LM.light_samples(light, LM.SAMPLES)
    assert w.sum() == pytest.approx(light.solid_angle, rel=1e-12) and np.all(light.contains(dirs))


def test_the_quadrature_without_the_jacobian_is_not_the_exact_p(scene, frame):
    mat, tbn, wo, uv, J = frame
    light = LI.scene_light(scene, "cap", (0.2, 0.0)).in_frame(*tbn)
    exact = gl.reflection_probability(mat.target, mat.alpha, wo[:64], light)
    dirs, w = LM.light_samples(light)
    smooth = make_method("smooth", mat)
    for wrong in LM.WRONG_VARIANTS:
        bad = LM.light_integral(smooth, uv[:64], J[:64], wo[:64], dirs, w, wrong=wrong)
        assert np.median(np.abs(bad / exact - 1)) > 0.3, wrong


def _point_limit_errors(scene, frame, name):
    mat, tbn, wo, uv, J = frame
    f = make_method(name, mat)
    errors = []
    for a in (0.01, 0.005, 0.0025):
        light = LI.scene_light(scene, "cap", (a, 0.0)).in_frame(*tbn)
        v = LM.light_integral(f, uv, J, wo, *LM.light_samples(light, 16), seed=1) / light.solid_angle
        point = LM.light_integral(f, uv, J, wo, light.center[None], np.ones(1), seed=1)
        errors.append(np.abs(v - point).sum() / np.abs(point).sum())
    return errors


def test_point_light_limit_of_the_smooth_ndf_is_second_order(scene, frame):
    e = _point_limit_errors(scene, frame, "smooth")
    assert e[-1] < 1e-4
    assert all(3.5 < e[i] / e[i + 1] < 4.5 for i in range(len(e) - 1)), e


@pytest.mark.parametrize("name", ["zk16", "db23_trilinear[gated]", "kpt25"])
def test_point_light_limit_of_the_glinty_methods(scene, frame, name):
    e = _point_limit_errors(scene, frame, name)
    assert e[-1] < 0.1
    assert all(e[i] / e[i + 1] > 1.8 for i in range(len(e) - 1)), e  # at least first order


@pytest.mark.parametrize("name", METHODS)
def test_each_method_counts_the_facets_lit_by_the_same_cap(paths, name):
    small, big, _ = paths
    b = _bias(small, name)
    if name in UNBIASED:
        assert abs(b - 1) < 0.03, b
    z = _z(_lit(big, "facets"), _lit(big, _label(name)), b)
    assert abs(z) < MAX_Z, (name, b, z)


@pytest.mark.parametrize("variant", LM.WRONG_VARIANTS)
def test_the_wrong_variants_are_rejected_by_the_same_check(paths, variant):
    small, _, wrong = paths
    path = wrong[variant]
    z = _z(_lit(path, "facets"), _lit(path, f"{_label('zk16')} (wrong: {variant})"), _bias(small, "zk16"))
    assert abs(z) > MAX_Z, z


def test_bad_arguments_are_named(scene, frame):
    mat, tbn, *_ = frame
    light = LI.scene_light(scene, "cap", (0.2, 0.0))
    with pytest.raises(ValueError, match="samples"):
        LM.light_samples(light.in_frame(*tbn), 10)
    with pytest.raises(ValueError, match="methods"):
        LM.method_renderers(mat, ["wb16"])
    with pytest.raises(ValueError, match="methods"):
        LM.method_renderers(mat, ["no such method"])
    with pytest.raises(ValueError, match="light"):
        LM.method_light_path(scene, gl.lights.cap([0, 0, 1.0], 0.1))
    with pytest.raises(ValueError, match="block"):
        LM.map_samples(gl.lights.envmap("sky", regions=3), 0)
    with pytest.raises(ValueError, match="wrong"):
        LM.method_renderers(mat, ["zk16"], wrong="no_radiance")
    assert "truth" not in LM.light_methods() and "zk16" in LM.light_methods()


@pytest.fixture(scope="module")
def sky():
    return gl.lights.envmap("sky", regions=3)


def test_the_smooth_ndf_over_the_map_is_the_exact_p_per_region(frame, sky):
    mat, _, wo, _, _ = frame
    views = wo[:: max(1, len(wo) // 60)]
    err = LM.quadrature_error(mat.target, mat.alpha, sky, views, block=LM.MAP_BLOCK)
    assert err["max_rel_error"] < 1e-2 and err["max_value_rel_error"] < 2e-3, err
    fine = LM.quadrature_error(mat.target, mat.alpha, sky, views, block=2)
    assert fine["weighted_rel_error"] < err["weighted_rel_error"] / 4  # 16 times the samples of the large region
    dirs, w, region = LM.map_samples(sky, LM.MAP_BLOCK)
    assert np.allclose(np.bincount(region, weights=w), sky.region_solid_angle, rtol=1e-12)
    assert np.bincount(region)[1:].tolist() == [(sky.labels == r).sum() for r in (1, 2)]  # sun, window: own cells


@pytest.mark.parametrize("name", ["smooth", "zk16", "db23_trilinear[binomial]"])
def test_the_unbiased_methods_average_to_the_exact_value_under_the_map(frame, sky, name):
    """Sum over a frame's pixels of value x n against sum of (sum_r L_r p_r) x n: the methods whose point-light
    bias is 1 are within 3 % (measured 0.98-1.00 on seeds 1 and 3); the wrong variant without the Jacobian
    is off by more than 30 %."""
    mat, _, wo, uv, J = frame
    n = mat.density * np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    exact = (gl.reflection_probability(mat.target, mat.alpha, wo[::8], sky) @ sky.region_radiance * n[::8]).sum()
    render = LM.method_renderers(mat, [name])[_label(name)]
    value = render(sky, wo[::8], uv[::8], J[::8], 3)
    assert abs((value * n[::8]).sum() / exact - 1) < 0.03
    wrong = LM.method_renderers(mat, [name], wrong="no_jacobian")[f"{_label(name)} (wrong: no_jacobian)"]
    assert abs((wrong(sky, wo[::8], uv[::8], J[::8], 3) * n[::8]).sum() / exact - 1) > 0.3


class _Doubled(gl.api.glinty_ndf.SmoothNDF):
    """A user's NDF method: twice the smooth D (a deliberate bias of 2 the path must show)."""

    def evaluate(self, uv, J, h, seed: int = 0):
        return 2.0 * super().evaluate(uv, J, h, seed)


def test_a_user_registered_ndf_method_is_rendered_by_default(scene, frame):
    mat, tbn, wo, uv, J = frame
    registry = gl.api.method_registry.IMAGE_METHODS
    saved = registry.snapshot()
    try:
        gl.api.method_registry.register_image_method("x_doubled", lambda m: _Doubled(m.target, m.alpha), label="x doubled")
        assert "x_doubled" in LM.light_methods()
        renderers = LM.method_renderers(mat)
        light = LI.scene_light(scene, "cap", (0.2, 0.0)).in_frame(*tbn)
        ratio = renderers["x doubled"](light, wo, uv, J, 0) / renderers["smooth D(h)"](light, wo, uv, J, 0)
        assert np.allclose(ratio[np.isfinite(ratio)], 2.0)
    finally:
        registry.restore(saved)


def test_on_the_sphere_each_pixel_sees_the_light_samples_in_its_own_frame():
    # The sphere: the world light's samples seen in each pixel's tangent frame (per-pixel directions) give the
    # smooth NDF's exact p per pixel (the cubature with the light rotated into the frame); the same samples
    # taken in one pixel's frame for every pixel (the plane's path on a curved surface) do not.
    sphere = with_density(resolve_scene("sphere").scaled(1 / 20, keep_n=True), 0.25)
    light = LI.scene_light(sphere, "cap", (0.2, 0.0))
    spec = with_directional_light(sphere).spec
    spec["light"] = {"type": "directional", "direction": list(light.direction)}
    lit = LI.Scene(spec, name="sphere", source="test")
    mat, _ = LI.plane_material(lit)
    inp = LI._narrow_footprints(frame_inputs(lit))
    _, frames, wo, uv, J, _ = LI._frame_geometry(inp, mat.density, per_pixel=True)
    pick = slice(None, None, max(1, len(wo) // 300))
    frames, wo, uv, J = frames[pick], wo[pick], uv[pick], J[pick]
    world = LI._world_light(light)
    exact = gl.reflection_probability(mat.target, mat.alpha, wo, world, frames=frames)
    render = LM.method_renderers(mat, ["smooth"])[_label("smooth")]
    value = render(world, wo, uv, J, 0, frames)
    big = exact > 1e-3 * exact.max()
    assert big.sum() > 100
    weighted = np.abs(value - exact).sum() / exact.sum()
    assert weighted < 1e-4, weighted  # measured 1.6e-6 at the default 64 samples (Beckmann alpha 1: a broad lobe)
    one_frame = render(world, wo, uv, J, 0, np.broadcast_to(frames[0], frames.shape))
    assert np.abs(one_frame - exact).sum() / exact.sum() > 0.3


def test_the_registered_methods_render_on_the_sphere_beside_its_facets():
    sphere = with_density(resolve_scene("sphere").scaled(1 / 40, keep_n=True), 0.25)
    path = LM.method_light_path(sphere, LI.scene_light(sphere, "cap", (0.2, 0.0)), methods=["smooth", "zk16"],
                                samples=16, frames=2, seed=2)
    valid = path.mask.all(axis=0)
    smooth = path.images[_label("smooth")][:, valid]
    assert valid.sum() > 50 and np.all(np.isfinite(path.images[_label("zk16")]))
    # The smooth NDF's quadrature against the exact p per pixel (the path's target): the same 1e-2 check the
    # report makes of its sums.
    assert abs(smooth.sum() / path.target[:, valid].sum() - 1) < 1e-2
