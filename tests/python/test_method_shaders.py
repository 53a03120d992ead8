"""One glinty-NDF abstraction and method shaders (docs/math/glint_images.md#glint-methods,
docs/math/glint_images.md#glint-contract, docs/math/glint_images.md#glint-wb16): the one registry of image
methods, the GlintInput contract field by field, gl.render, WB16's shader against its numpy twin (and a
broken WB16 that the comparison catches), and `glintlab images --method`."""
from __future__ import annotations

import pickle
import re

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import method_shaders as MS
from glintlab.api.glinty_ndf import IMAGE_METHODS, GlintyNDF, Material, make_method
from glintlab.validation import scene_images as si
from glintlab.validation.scene import load_scene
from glintlab.resources import data_path

needs_vulkan = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

# WB16 twin agreement (docs/math/glint_images.md#glint-wb16): the allowance of its registry entry
# (method_shaders.WB16_ULPS float32 spacings of the lookup position times the kernel's largest slope), beyond
# it on at most MAX_SHARE of the hit pixels. Measured here on lavapipe: 0 to 0.1 % of the pixels.
MAX_SHARE = MS.WB16_MAX_SHARE


def test_every_image_method_is_a_registered_glinty_ndf():
    names = gl.image_methods()
    assert set(si.panel_methods()) <= set(names) and "wb16" in names
    assert si.IMAGE_METHODS is IMAGE_METHODS and si.image_methods is gl.image_methods
    mat = Material(density=1e4, target="beckmann", alpha=0.5, R=0.5)
    for name in gl.image_methods(returns="ndf"):
        assert isinstance(make_method(name, mat), GlintyNDF), name
    assert gl.image_methods(returns="intensity") == [n for n in names if IMAGE_METHODS.get(n).returns == "intensity"]
    # The truth and the smooth NDF are glinty NDFs by name too, with the same numbers as the image methods.
    rng = np.random.default_rng(1)
    uv, J = rng.uniform(0, 3, (500, 2)), np.tile([0.05, 0.01, -0.01, 0.04], (500, 1))
    h = np.column_stack([rng.normal(0, 0.3, (500, 2)), np.ones(500)])
    truth = make_method("truth", mat).evaluate(uv, J, h, seed=3)
    assert np.array_equal(gl.glinty_ndf("facets", density=1e4, R=0.5).evaluate(uv, J, h, seed=3), truth)
    assert np.array_equal(gl.glinty_ndf("smooth").evaluate(uv, J, h), make_method("smooth", mat).evaluate(uv, J, h))
    with pytest.raises(ValueError, match="returns"):
        gl.image_methods(returns="colour")


def test_one_d_p_and_one_pixel_check():
    f = gl.glinty_ndf("facets", density=1e4)
    d = gl.glinty_ndf("db23", density=1e4)
    for nd in (f, d):  # D_P = (D(n) / R) K / (N P), one formula for every counting method
        assert nd.d_p(np.array([3.0]), np.array([2e-3]), 0.5)[0] == pytest.approx(
            nd.smooth_ndf.D_normal / 0.5 * 3 / (1e4 * 2e-3), rel=1e-15)
    uv, J, h = [[0.0, 0.0]], [[1e-3, 0, 0, 1e-3]], [[0.0, 0.0, 1.0]]
    for nd in (f, d, gl.glinty_ndf("smooth")):
        with pytest.raises(ValueError, match="J = "):
            nd.evaluate(uv, [[1e-3, 0, 0]], h)
        with pytest.raises(ValueError, match="uv = "):
            nd.evaluate([[0.0, 0.0, 0.0]], J, h)


# ---------------------------------------------------------------------------------------------- contract

_FIELDS_HLSL = """
float3 probe(GlintInput g) {
  float r = dot(g.world_pos, float3(1.0, 2.0, 3.0)) + dot(g.uv, float2(5.0, 7.0)) + dot(g.J, float4(11.0, 13.0, 17.0, 19.0));
  float s = dot(g.n, float3(1.0, 3.0, 5.0)) + dot(g.t, float3(7.0, 11.0, 13.0)) + dot(g.b, float3(17.0, 19.0, 23.0))
          + float(g.light_kind) * 0.125 + g.light_radiance * 29.0 + dot(g.light_size, float2(31.0, 37.0))
          + dot(g.light_edge, float3(41.0, 43.0, 47.0));
  float t = dot(g.view, float3(1.0, 2.0, 4.0)) + dot(g.light, float3(8.0, 16.0, 32.0)) + dot(g.h, float3(3.0, 9.0, 27.0))
          + float(g.pixel.x) * 1000.0 + float(g.pixel.y) * 100000.0 + float(g.frame) * 0.5 + float(g.seed) * 0.25;
  return float3(r, s, t);
}"""
_FIELDS_GLSL = _FIELDS_HLSL.replace("float3", "vec3").replace("float2", "vec2").replace("float4", "vec4")


@needs_vulkan
@pytest.mark.parametrize("language, src", [("hlsl", _FIELDS_HLSL), ("glsl", _FIELDS_GLSL)], ids=["hlsl", "glsl"])
def test_glint_input_fields_arrive_in_place(language, src):
    rng = np.random.default_rng(5)
    m = 300
    f = {k: rng.uniform(-1, 1, (m, w)) for k, _, w in MS.GLINT_INPUT_FIELDS
         if k not in ("pixel", "frame", "seed", "light_kind")}
    kind = rng.integers(0, 3, m).astype(np.uint32)
    pixel = rng.integers(0, 64, (m, 2)).astype(np.uint32)
    frame, seed = rng.integers(0, 9, m).astype(np.uint32), rng.integers(0, 99, m).astype(np.uint32)
    meth = gl.shader_method(src, language=language, entry="probe", name=f"probe_{language}", register=False)
    out = meth.shade(MS.pack_inputs(m, pixel=pixel, frame=frame, seed=seed, light_kind=kind, **f))
    assert out.shape == (m, 3)
    r = f["world_pos"] @ [1, 2, 3] + f["uv"] @ [5, 7] + f["J"] @ [11, 13, 17, 19]
    s = f["n"] @ [1, 3, 5] + f["t"] @ [7, 11, 13] + f["b"] @ [17, 19, 23] + kind * 0.125 + f["light_radiance"][:, 0] * 29 \
        + f["light_size"] @ [31, 37] + f["light_edge"] @ [41, 43, 47]
    t = f["view"] @ [1, 2, 4] + f["light"] @ [8, 16, 32] + f["h"] @ [3, 9, 27] + pixel[:, 0] * 1000.0 \
        + pixel[:, 1] * 1e5 + frame * 0.5 + seed * 0.25
    np.testing.assert_allclose(out, np.column_stack([r, s, t]), rtol=2e-6, atol=2e-4)
    # A swapped field is caught: the check is not blind to the layout.
    assert not np.allclose(out[:, 0], f["world_pos"] @ [1, 2, 3] + f["uv"] @ [7, 5] + f["J"] @ [11, 13, 17, 19],
                           rtol=2e-6, atol=2e-4)


@needs_vulkan
def test_frame_inputs_carry_the_world_fields_and_render_is_nan_off_the_surface():
    sc = load_scene(data_path("scenes", "sphere.json")).scaled(0.04, keep_n=True)
    inp = si.frame_inputs(si.with_directional_light(sc))
    hit = inp.hit
    assert hit.any() and (~hit).any()
    # view is unnormalised (surface to camera), n t b orthonormal, h the unit half vector of view and light.
    np.testing.assert_allclose(inp.world_pos[hit] + inp.view[hit], np.broadcast_to(sc.position, inp.view[hit].shape),
                               atol=1e-12)
    for a, b in (("n", "t"), ("n", "b"), ("t", "b")):
        assert np.abs((getattr(inp, a)[hit] * getattr(inp, b)[hit]).sum(-1)).max() < 1e-9
    v = inp.view[hit] / np.linalg.norm(inp.view[hit], axis=-1, keepdims=True)
    hw = v + inp.light[hit]
    np.testing.assert_allclose(inp.h_world[hit], hw / np.linalg.norm(hw, axis=-1, keepdims=True), atol=1e-12)
    img = gl.render("smooth", sc, frame=0, seed=0)
    assert img.shape == (sc.height, sc.width)
    assert np.array_equal(np.isnan(img), ~hit)
    np.testing.assert_array_equal(img[hit], si.render(make_method("smooth", Material.of(sc)), inp)[hit])
    src = "float glint(GlintInput g) { return float(g.pixel.x) + 1000.0 * float(g.pixel.y) + 0.5 * float(g.frame); }"
    gl.shader_method(src, language="hlsl", name="test_pixels")
    try:
        img = gl.render("test_pixels", sc, frame=3)
        rows, cols = np.nonzero(~np.isnan(img))
        np.testing.assert_array_equal(img[rows, cols], cols + 1000.0 * rows + 1.5)
        assert "test_pixels" in gl.image_methods()
        # uv is negative on part of the sphere, and an intensity must be >= 0: |uv| per channel.
        colour = gl.shader_method("vec3 glint(GlintInput g) { return vec3(abs(g.uv), float(g.seed)); }",
                                  language="glsl", name="test_colour")
        img = gl.render(colour, sc, seed=5)
        assert img.shape == (sc.height, sc.width, 3) and np.array_equal(np.isnan(img).all(-1), ~hit)
        np.testing.assert_array_equal(img[hit][:, :2], np.abs(inp.uv[hit].astype(np.float32)))
        assert (img[hit][:, 2] == 5).all()
    finally:
        IMAGE_METHODS._items.pop("test_pixels")
        IMAGE_METHODS._items.pop("test_colour", None)
    with pytest.raises(ValueError, match="frame"):
        gl.render("smooth", sc, frame=8)


@needs_vulkan
def test_bad_method_shaders_are_refused_with_the_compilers_words():
    with pytest.raises(ValueError, match=r"^method shader does not compile \(hlsl\): <string>:1: error: 'nope'") as e:
        gl.shader_method("float glint(GlintInput g) { return nope; }", language="hlsl", register=False)
    assert "\n" not in str(e.value) and "unknown variable" in e.value.messages  # one line; the compiler's text kept
    with pytest.raises(ValueError, match=r"GlintInput"):
        gl.shader_method("float glint(float x) { return x; }", language="glsl", register=False)
    with pytest.raises(ValueError, match="name = 'truth' is invalid; expected a name of your own"):
        gl.shader_method("float glint(GlintInput g) { return 0.0; }", name="truth")
    with pytest.raises(ValueError, match="language"):
        gl.shader_method("float glint(GlintInput g) { return 0.0; }", language="cuda")
    with pytest.raises(ValueError, match="unknown image method"):
        gl.render("nope", "sphere", scale=0.02)


# ---------------------------------------------------------------------------------------------- WB16

def _wb16_frames():
    """Packed rows of two small frames (a sphere and the grazing plane) and their hit masks."""
    out = []
    for stem, frame in (("sphere", 0), ("plane_25", 5)):
        sc = si.with_directional_light(load_scene(data_path("scenes", f"{stem}.json")).scaled(0.08, keep_n=True))
        inp = si.frame_inputs(si.camera_path(sc, 8)[frame])
        out.append(MS.frame_rows(inp, seed=7, frame=frame)[0])
    return np.concatenate(out)


def _beyond(a, b, pos, **params):
    """Per pixel: a and b (two computations of WB16 with ``params``) differ beyond the float32
    allowance of the lookup position ``pos`` (the allowance of WB16's registry entry)."""
    return MS.wb16_beyond(a, b, pos, **params)


def _disagreement(shader_out, rows, twin=MS.wb16_twin, **params):
    """Share of pixels where the shader and the twin as printed (``params``; the C++ twin unless
    ``twin`` says otherwise) differ beyond the float32 allowance of the lookup position."""
    value, pos = twin(rows, return_lookup=True, **params)
    return _beyond(shader_out, value, pos, **params).mean()


@needs_vulkan
def test_wb16_shader_agrees_with_its_twin_and_a_broken_kernel_does_not():
    rows = _wb16_frames()
    assert rows.shape[0] > 3000
    for params in ({}, {"shape": 1}, {"noise": 1}, {"anisotropic": 0}):
        shader = MS.wb16_method(**params).shade(rows)
        assert _disagreement(shader, rows, **params) <= MAX_SHARE, params
        lit = np.nan_to_num(MS.wb16_twin(rows, **params)) > 0
        assert 0.02 < lit.mean() < 0.6, params  # sparkles, not a blank or a flat image
    # (The paper's method with a kernel radius off by sqrt(1.2), and the baselines against the paper's twin,
    # are the wrong variants WB16's registry entry declares: test_extension_registries.py shows the same
    # comparison rejects them.)
    # The first, numpy, twin still agrees too (it differs from the C++ one in numpy's float32 pow, an ulp).
    assert _disagreement(MS.wb16_method().shade(rows), rows, twin=MS.wb16_twin_numpy) <= MAX_SHARE


@needs_vulkan
def test_wb16_hlsl_gives_the_glsl_image():
    """wb16.hlsl and wb16.glsl wrap one body (wb16_body.h, glintlab_method_body.h): on every pixel the
    two languages agree within the float32 allowance (on lavapipe: bit for bit)."""
    rows = _wb16_frames()
    for params in ({}, {"shape": 1}, {"noise": 1}, {"anisotropic": 0}):
        hlsl, glsl = MS.wb16_method("hlsl", **params), MS.wb16_method("glsl", **params)
        assert hlsl.language == "hlsl" and glsl.language == "glsl"
        _, pos = MS.wb16_twin(rows, return_lookup=True, **params)
        a, b = hlsl.shade(rows), glsl.shade(rows)
        assert not _beyond(a, b, pos, **params).any(), params
    # Not blind: the HLSL star against the GLSL round kernel differs on many pixels.
    assert _beyond(MS.wb16_method("hlsl", shape=1).shade(rows), glsl.shade(rows), pos).mean() > 10 * MAX_SHARE
    with pytest.raises(ValueError, match="language"):
        MS.wb16_method("cuda")


def test_wb16_cpp_twin_is_the_numpy_twin_and_checks_its_arguments():
    """The C++ twin computes the numpy twin's float32 arithmetic: lookup positions within WB16_ULPS float32
    spacings (numpy's float32 pow and log2 are not the C library's: measured at most 2, and 9 on 0.6 % of
    the pixels with lookup jitter, whose noise magnifies the level's last bit), values within the
    allowance on all but MAX_SHARE of the pixels; the thread count changes nothing."""
    rows = _wb16_frames()
    for params in ({}, {"shape": 1}, {"noise": 1}, {"anisotropic": 0}, {"kernel_scale": 1.2}):
        c, pc = MS.wb16_twin(rows, return_lookup=True, **params)
        n, pn = MS.wb16_twin_numpy(rows, return_lookup=True, **params)
        assert c.dtype == np.float32 and pc.shape == (rows.shape[0], 3)
        ulps = np.abs(pc.astype(np.float64) - pn) / np.spacing(np.abs(pn).max(axis=1))[:, None]
        assert np.mean(ulps.max(axis=1) > MS.WB16_ULPS) <= MAX_SHARE, params
        assert _beyond(c, n, pc, **params).mean() <= MAX_SHARE, params
    # A broken twin is caught by the same comparison (the kernel's threshold off by 1.2).
    assert _beyond(MS.wb16_twin(rows, kernel_scale=1.2), MS.wb16_twin_numpy(rows), pc).mean() > 10 * MAX_SHARE
    many = np.tile(rows, (3, 1))  # above the serial threshold: the rows are split between threads
    split, old = MS.wb16_twin(many), gl.get_num_threads()
    gl.set_num_threads(1)
    try:
        assert np.array_equal(MS.wb16_twin(many).view(np.uint32), split.view(np.uint32))
    finally:
        gl.set_num_threads(old)
    with pytest.raises(ValueError, match="shape"):
        MS.wb16_twin(rows, shape=2)
    with pytest.raises(ValueError, match="sparkle_sise"):
        MS.wb16_twin(rows, sparkle_sise=0.9)
    with pytest.raises(ValueError, match="rows"):
        MS.wb16_twin(rows[:, :8])


def test_wb16_noise_is_a_wrapped_trilinear_texture():
    seed = np.zeros(4, np.uint32)
    # At texel centres the noise is the texel's value; one period (1.0) later the same value (wrap).
    c = np.array([[3, 5, 7], [0, 0, 0], [127, 1, 64], [-1, 2, 3]])
    p = (c + 0.5) / 128.0
    np.testing.assert_allclose(MS.noise3(p.astype(np.float32), seed), MS.cell_values(c & 127, seed), atol=1e-6)
    np.testing.assert_allclose(MS.noise3((p + 1.0).astype(np.float32), seed), MS.cell_values(c & 127, seed), atol=2e-5)
    v = MS.cell_values(np.random.default_rng(1).integers(0, 128, (20000, 3)), np.zeros(20000, np.uint32))
    assert v.min() >= 0 and v.max() < 1 and abs(v.mean() - 0.5) < 0.01


# ---------------------------------------------------------------------------------------------- CLI

@needs_vulkan
def test_images_command_runs_a_users_method(tmp_path, capsys):
    from glintlab.cli.main import main
    scene = str(data_path("scenes", "plane_90.json"))
    good = tmp_path / "mine.hlsl"
    good.write_text("float glint(GlintInput g) { return frac(g.uv.x * 7.0) < 0.1 ? 1.0 : 0.0; }\n")
    common = [scene, "--scale", "0.03", "--frames", "2", "--timing-scale", "0.03", "--quiet"]
    try:
        assert main(["images", *common, "--method", str(good), "--out", str(tmp_path / "a")]) == 0
        assert "mine" in (tmp_path / "a" / "scene_images_flicker.csv").read_text()
        bad = tmp_path / "bad.hlsl"
        bad.write_text("float glint(GlintInput g) {\n  return undefined_thing;\n}\n")
        assert main(["images", *common, "--method", str(bad), "--out", str(tmp_path / "b")]) == 2
        err = capsys.readouterr().err
        assert "bad.hlsl" in err and "does not compile" in err
        nan = tmp_path / "nan.glsl"
        nan.write_text("float glint(GlintInput g) { return uintBitsToFloat(0x7fc00000u) + g.uv.x; }\n")
        assert main(["images", *common, "--method", str(nan), "--out", str(tmp_path / "c")]) == 1
        assert "non-finite" in capsys.readouterr().err
    finally:
        for n in ("mine", "bad", "nan"):
            IMAGE_METHODS._items.pop(n, None)


# A user's glinty-NDF shader: it returns D, reads the scene material as defines, and is shaded with the
# same BRDF as the built-in NDF methods. The smooth Beckmann NDF written as a shader must render as the
# built-in smooth method (float32 arithmetic: 1e-4 relative, 1e-6 of the peak where float32 underflows);
# the same shader without its cos^4 factor must not (the comparison can fail).
_USER_NDF = """
float glint(GlintInput g) {
  float c = dot(normalize(g.h), g.n);
  if (c <= 0.0) return 0.0;
  float a2 = GLINTLAB_ALPHA * GLINTLAB_ALPHA, c2 = c * c;
  return exp((c2 - 1.0) / (c2 * a2)) / (3.14159265 * a2 * c2 * COS4);
}
"""


@pytest.mark.parametrize("cos4, matches", [("c2", True), ("1.0", False)])
def test_a_user_ndf_shader_is_shaded_as_the_builtin_ndf_methods(cos4, matches):
    name = f"user_beckmann_{'ok' if matches else 'wrong'}"
    m = gl.shader_method(_USER_NDF, language="glsl", name=name, returns="ndf", defines={"COS4": cos4})
    assert m.returns == "ndf" and name in gl.image_methods("ndf")
    img = gl.render(name, "sphere", scale=0.05)
    ref = gl.render("smooth", "sphere", scale=0.05)
    assert np.array_equal(np.isnan(img), np.isnan(ref))
    # float32 underflows where the lobe is 1e-300 of its peak: those pixels are measured against the peak.
    lit = np.isfinite(ref)
    rel = np.abs(img[lit] - ref[lit]) / np.maximum(ref[lit], 1e-6 * ref[lit].max())
    assert (rel.max() < 1e-4) == matches, rel.max()
    h = np.array([0.1, 0.05, 1.0]) / np.linalg.norm([0.1, 0.05, 1.0])
    assert (abs(m.evaluate([0.3, 0.4], [1e-3, 0, 0, 1e-3], h) / m.smooth(h) - 1) < 1e-5) == matches


def test_a_user_ndf_shader_refuses_bad_switches():
    with pytest.raises(ValueError, match="returns = 'd' is invalid"):
        gl.shader_method(_USER_NDF, language="glsl", name="user_bad", returns="d", defines={"COS4": "c2"})
    with pytest.raises(ValueError, match="GLINTLAB_ALPHA"):
        gl.shader_method(_USER_NDF, language="glsl", name="user_bad", returns="ndf",
                         defines={"COS4": "c2", "GLINTLAB_ALPHA": 0.5})


# ---------------------------------------------------------------------------------------------- issue 37 edges
# Each test below fails on the code before issue 37: seeds >= 2^32 aliased onto smaller ones, negative and
# later frames' faulty outputs passed, shipped names were replaced silently, False became text.

# The seed's low and high 16 bits as two channels (float32 holds each exactly).
_SEED_PROBE = "float3 glint(GlintInput g) { return float3(float(g.seed & 65535u), float(g.seed >> 16u), 0.0); }"


def _seed_of(img):
    lit = ~np.isnan(img).any(-1)
    low, high = img[lit][:, 0], img[lit][:, 1]
    assert (low == low[0]).all() and (high == high[0]).all()
    return int(low[0]) + 65536 * int(high[0])


@needs_vulkan
def test_seeds_reach_the_shader_whole_or_are_refused():
    """GlintInput's seed is 32 bits: seeds below 2^32 arrive as they are (the images of the seeds accepted
    before are unchanged); 2^32 and 2^64 - 1 are refused by name instead of rendering seed 0's and seed
    2^32 - 1's image."""
    gl.shader_method(_SEED_PROBE, language="hlsl", name="test_seed_probe")
    for seed in (0, 5, 2**31 + 3, 2**32 - 1):
        assert _seed_of(gl.render("test_seed_probe", "sphere", seed=seed, scale=0.02)) == seed
    for seed in (2**32, 2**32 + 5, 2**64 - 1):
        with pytest.raises(ValueError, match=r"seed = \d+ is invalid; expected an integer in \[0, 2\^32\) for method "
                                             r"shader 'test_seed_probe'"):
            gl.render("test_seed_probe", "sphere", seed=seed, scale=0.02)
    assert 0 <= _seed_of(gl.render("test_seed_probe", "sphere", seed=None, scale=0.02)) < 2**32  # the OS's seed
    # An NDF shader too, and a path of several methods refuses before rendering any frame.
    gl.shader_method("float glint(GlintInput g) { return 1.0; }", language="hlsl", name="test_seed_ndf", returns="ndf")
    with pytest.raises(ValueError, match="seed = 4294967296 is invalid.*'test_seed_ndf'"):
        gl.render("test_seed_ndf", "sphere", seed=2**32, scale=0.02)
    sc = load_scene(data_path("scenes", "sphere.json")).scaled(0.02, keep_n=True)
    with pytest.raises(ValueError, match="seed = 4294967296 is invalid.*'test_seed_probe'"):
        si.render_path(sc, ["smooth", "test_seed_probe"], frames=2, seed=2**32)


@needs_vulkan
def test_faulty_outputs_fail_on_every_frame():
    """A negative intensity, a negative D, or a NaN on a frame after the first is a failed check naming
    the method, the frame and the pixels (before: negative values passed, and only frame 0 was looked at)."""
    later = "float glint(GlintInput g) { return g.frame == 3u ? (g.pixel.x % 2u == 0u ? -1.0 : 0.5) : 0.5; }"
    gl.shader_method(later, language="hlsl", name="test_neg_later")
    assert np.nanmin(gl.render("test_neg_later", "sphere", frame=2, scale=0.02)) == 0.5
    with pytest.raises(gl.ShaderOutputError,
                       match=r"method shader 'test_neg_later' returned \d+ negative intensity values on \d+ of \d+ "
                             r"pixels of frame 3"):
        gl.render("test_neg_later", "sphere", frame=3, scale=0.02)
    gl.shader_method("float glint(GlintInput g) { return -2.0; }", language="hlsl", name="test_neg_d", returns="ndf")
    with pytest.raises(ValueError, match=r"'test_neg_d' returned \d+ negative NDF values .* frame 0"):
        gl.render("test_neg_d", "sphere", scale=0.02)
    nan = "float glint(GlintInput g) { return g.frame == 1u ? uintBitsToFloat(0x7fc00000u) : 0.0; }"
    gl.shader_method(nan, language="glsl", name="test_nan_later")
    with pytest.raises(ValueError, match=r"'test_nan_later' returned \d+ non-finite intensity values .* frame 1"):
        gl.render("test_nan_later", "sphere", frame=1, scale=0.02)


@needs_vulkan
def test_images_fails_a_method_that_goes_wrong_after_the_first_frame(tmp_path, capsys):
    from glintlab.cli.main import main
    neg = tmp_path / "neg.hlsl"
    neg.write_text("float glint(GlintInput g) { return g.frame == 1u ? -1.0 : 0.5; }\n")
    common = ["plane_90", "--scale", "0.03", "--frames", "2", "--timing-scale", "0.03", "--quiet"]
    assert main(["images", *common, "--method", str(neg), "--out", str(tmp_path / "a")]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "method shader 'neg' returned" in err and "negative" in err and "frame 1" in err


@needs_vulkan
def test_images_refuses_seeds_beyond_32_bits_and_two_files_of_one_name(tmp_path, capsys):
    from glintlab.cli.main import main
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "mine.hlsl").write_text("float glint(GlintInput g) { return 0.5; }\n")
    common = ["plane_90", "--scale", "0.03", "--frames", "2", "--timing-scale", "0.03", "--quiet"]
    one = str(tmp_path / "a" / "mine.hlsl")
    assert main(["images", *common, "--method", one, "--seed", "4294967296", "--out", str(tmp_path / "o1")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "seed = 4294967296 is invalid" in err
    two = str(tmp_path / "b" / "mine.hlsl")
    assert main(["images", *common, "--method", one, "--method", two, "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--method" in err and "'mine'" in err and "a/mine.hlsl" in err.replace("\\", "/")


def test_images_without_a_vulkan_device_is_one_line(tmp_path):
    """As `glintlab shader`: no device is the environment, exit 2 with one line (before: a traceback, exit 1)."""
    import os
    import subprocess
    import sys
    src = tmp_path / "mine.hlsl"
    src.write_text("float glint(GlintInput g) { return 0.5; }\n")
    env = {**os.environ, "VK_ICD_FILENAMES": "/nonexistent.json", "VK_DRIVER_FILES": "/nonexistent.json"}
    r = subprocess.run([sys.executable, "-m", "glintlab.cli.main", "images", "plane_90", "--scale", "0.03",
                        "--frames", "2", "--timing-scale", "0.03", "--quiet", "--method", str(src),
                        "--out", str(tmp_path / "out")], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "glintlab images:" in r.stderr and "Vulkan" in r.stderr


@needs_vulkan
def test_method_shader_names_replace_only_the_users_own():
    """One's own method shader may be registered again under its name (either kind); a shipped method
    ("wb16" was replaced silently, "truth" refused with a misleading message) never is."""
    ndf = "float glint(GlintInput g) { return 1.0; }"
    for returns in ("ndf", "ndf", "intensity", "ndf"):
        gl.shader_method(ndf, language="hlsl", name="test_mine_again", returns=returns)
        assert IMAGE_METHODS.get("test_mine_again").returns == returns
    wb16 = IMAGE_METHODS.get("wb16")
    for shipped in ("wb16", "wb16_star", "truth", "kpt25_shader", "db23_shader", "smooth"):
        for returns in ("intensity", "ndf"):
            with pytest.raises(ValueError, match=f"name = '{re.escape(shipped)}' is invalid; expected a name of your "
                                                 "own: .* glintlab ships"):
                gl.shader_method(ndf, language="hlsl", name=shipped, returns=returns)
    assert IMAGE_METHODS.get("wb16") is wb16
    si.register_image_method("test_python_method", lambda m: gl.glinty_ndf("smooth"))
    with pytest.raises(ValueError, match="registered by register_image_method"):
        gl.shader_method(ndf, language="hlsl", name="test_python_method")
    assert "wb16" in gl.api.glinty_ndf.shipped_image_methods() and "test_mine_again" not in \
        gl.api.glinty_ndf.shipped_image_methods()


@needs_vulkan
def test_method_shader_defines_are_numbers_or_refused():
    """True/False are 1/0 (before: the text "False", a compile error); None is refused by name."""
    src = "float glint(GlintInput g) { return FLAG ? 1.0 : 0.25; }"
    for flag, value in ((False, 0.25), (True, 1.0), (0, 0.25), (np.bool_(True), 1.0)):
        m = gl.shader_method(src, language="hlsl", name="test_flag", defines={"FLAG": flag})
        assert np.nanmax(gl.render(m, "sphere", scale=0.02)) == value
    with pytest.raises(ValueError, match=r"defines\['FLAG'\] = None is invalid"):
        gl.shader_method(src, language="hlsl", name="test_flag", defines={"FLAG": None})
    with pytest.raises(ValueError, match=r"defines\['FLAG'\] = nan is invalid"):
        gl.shader_method(src, language="hlsl", name="test_flag", defines={"FLAG": float("nan")})


@needs_vulkan
@pytest.mark.parametrize("language", ["hlsl", "glsl"])
def test_unfinished_method_shaders_say_what_they_are(language):
    """A prototype without a body and a declaration left unfinished were both "no function glint with the
    expected signature"; now each is named, in one line (the sampler path's wording, one implementation)."""
    with pytest.raises(ValueError, match=r"^method shader does not compile \(\w+\): function glint is declared in "
                                         r"<string> but has no body \(a prototype without its definition; define "
                                         r"float glint\(GlintInput g\)") as e:
        gl.shader_method("float glint(GlintInput g);", language=language, register=False)
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match=r"in glintlab's wrapper, after the end of <string> \(a declaration left "
                                         r"unfinished\?\)"):
        gl.shader_method("float glint(GlintInput g", language=language, register=False)
    with pytest.raises(ValueError, match=r"no function glint with the expected signature float glint\(GlintInput g\)"):
        gl.shader_method("float glint(float x) { return x; }", language=language, register=False)


@needs_vulkan
def test_shader_backed_objects_share_one_base(tmp_path):
    """A shader law, a method shader, an NDF method shader and a shader sampler are one kind of object
    (shaders.ShaderBacked):
    the same kernel properties, the same device choice, and pickles that carry the code and the files it
    included, so a copy computes the same after the files change (a method shader's too)."""
    from glintlab.api.counting_shaders import NdfShaderMethod
    from glintlab.api.shaders import ShaderBacked, ShaderLaw
    (tmp_path / "scale.h").write_text("#define GLINT_SCALE 2.0\n")
    src = tmp_path / "scaled.glsl"
    src.write_text('#include "scale.h"\nfloat glint(GlintInput g) { return GLINT_SCALE * abs(g.view.x); }\n')
    method = gl.shader_method(src, register=False, device=0)  # an index, as shader laws take it
    law = gl.shader_law(gl.shipped_shader("gated", "glsl"), register=False)
    ndf = gl.shader_method("float glint(GlintInput g) { return GLINTLAB_ALPHA; }", language="glsl", register=False,
                           returns="ndf")
    sampler = gl.shader_sampler(gl.shipped_sampler("ggx_vndf", "glsl"))
    assert isinstance(ndf, NdfShaderMethod) and isinstance(law, ShaderLaw)
    rows = MS.pack_inputs(4, view=[[1.0, 0, 0], [-2.0, 0, 0], [0.5, 1, 0], [3.0, 0, 1]])
    for obj, kind in ((law, "shader law"), (method, "method shader"), (ndf, "method shader"),
                      (sampler, "shader sampler")):
        assert isinstance(obj, ShaderBacked) and obj.kind == kind
        assert obj.device and obj.device_type and obj.spirv[:4] == b"\x03\x02\x23\x07" and obj.unbounded_loops == 0
        assert obj.language == "glsl" and obj.loop_caveat is None
    assert str(tmp_path / "scale.h") in method.included_files  # beside glintlab_method_glsl.h and its own
    before = method.shade(rows)
    np.testing.assert_array_equal(before, [2.0, 4.0, 1.0, 6.0])
    (tmp_path / "scale.h").write_text("#define GLINT_SCALE 3.0\n")
    back = pickle.loads(pickle.dumps(method))
    assert back.identity == method.identity
    np.testing.assert_array_equal(back.shade(rows), before)  # the recorded header, not the edited one
    np.testing.assert_array_equal(gl.shader_method(src, register=False).shade(rows), 1.5 * before)  # a new one reads it
    assert pickle.loads(pickle.dumps(sampler)).identity == sampler.identity
    ndf_back = pickle.loads(pickle.dumps(ndf))
    assert ndf_back.alpha == ndf.alpha and np.array_equal(ndf_back.shade(rows), ndf.shade(rows))
    with pytest.raises(ValueError, match="device"):
        gl.shader_method(src, register=False, device=-1)
