"""Read-only resources in every shader kind (docs/guide/shaders.md#textures-buffers-and-uniforms): textures
(1D, 2D, 3D, arrays; nearest/linear, wrap/clamp, mip levels), HLSL's separate samplers, storage buffers and
uniform blocks bound by name from numpy arrays, each read back through a shader and compared with what numpy
computes from the same data; and every mismatch refused in one line naming the resource."""
from __future__ import annotations

import pickle

import numpy as np
import OpenImageIO as oiio
import pytest
from PIL import Image

import glintlab as gl
from glintlab.api import method_shaders as MS
from glintlab.api import shaders as S
from glintlab.api.glinty_ndf import IMAGE_METHODS
from glintlab.api.shader_resources import SamplerState, read_image
from glintlab.cli.main import main
from glintlab.resources import data_path

pytestmark = pytest.mark.skipif(not S.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")
RNG = np.random.default_rng(38)


def law(code, language="glsl", **resources):
    return gl.shader_law(code, language=language, register=False, **resources)


def run(law_, u):
    """The law's raw output at uniforms u (rows of 2), n = 1, p = 0.5."""
    return law_.evaluate_raw(1.0, 0.5, np.asarray(u, float))


def centres(n):
    return (np.arange(n) + 0.5) / n


# ---------------------------------------------------------------- what each kind of resource reads

def test_storage_buffer_is_read_element_by_element():
    table = RNG.uniform(0, 10, (64, 4)).astype(np.float32)
    src = ("layout(std430) readonly buffer Table { vec4 table[]; };\n"
           "float count(float n, float p, vec4 u) { uint i = uint(u.x * 64.0); return table[i].y + table[i].w; }")
    u = np.column_stack([centres(64), np.full(64, 0.5)])
    got = run(law(src, buffers={"Table": table}), u)
    np.testing.assert_array_equal(got, table[:, 1] + table[:, 3])
    # The HLSL spelling, a StructuredBuffer of float2.
    hsrc = ("StructuredBuffer<float2> pairs;\n"
            "float count(float n, float p, float4 u) { uint i = uint(u.x * 64.0); return pairs[i].x - pairs[i].y; }")
    got = run(law(hsrc, "hlsl", buffers={"pairs": table[:, :2]}), u)
    np.testing.assert_array_equal(got, table[:, 0] - table[:, 1])


@pytest.mark.parametrize("language,src", [
    ("glsl", "uniform sampler2D tex;\n"
             "float count(float n, float p, vec4 u) { return textureLod(tex, u.xy, 0.0).g; }"),
    ("hlsl", "Texture2D<float4> tex; SamplerState smp;\n"
             "float count(float n, float p, float4 u) { return tex.SampleLevel(smp, u.xy, 0).g; }"),
])
def test_2d_texture_nearest_at_texel_centres_and_linear_between(language, src):
    img = RNG.uniform(0, 1, (8, 16, 3)).astype(np.float32)  # (height, width, channels)
    y, x = np.meshgrid(np.arange(8), np.arange(16), indexing="ij")
    u = np.column_stack([((x + 0.5) / 16).ravel(), ((y + 0.5) / 8).ravel()])
    nearest = SamplerState(filter="nearest")
    extra = {"samplers": {"smp": nearest}} if language == "hlsl" else {}
    got = run(law(src, language, textures={"tex": (img, nearest)}, **extra), u)
    np.testing.assert_array_equal(got, img[..., 1].ravel())
    # Linear, halfway between texels (x + 1) / 16 in u: the mean of the two neighbours.
    linear = SamplerState(filter="linear", address="clamp")
    extra = {"samplers": {"smp": linear}} if language == "hlsl" else {}
    mid = np.column_stack([((x[:, :-1] + 1.0) / 16).ravel(), ((y[:, :-1] + 0.5) / 8).ravel()])
    got = run(law(src, language, textures={"tex": (img, linear)}, **extra), mid)
    want = 0.5 * (img[:, :-1, 1] + img[:, 1:, 1]).ravel()
    np.testing.assert_allclose(got, want, atol=1.0 / 256)  # GPUs filter with 8-bit weights; exact halves here
    assert not np.allclose(got, img[:, :-1, 1].ravel(), atol=1.0 / 256)  # and not the nearest texel


def test_wrap_and_clamp_address_modes():
    row = np.arange(1, 9, dtype=np.float32)  # a 1D texture of 8 texels
    src = ("uniform sampler1D line;\n"
           "float count(float n, float p, vec4 u) { return textureLod(line, u.x * 4.0 - 1.0, 0.0).r; }")
    u = np.column_stack([np.full(2, (1.0 + 1.25) / 4.0), [0.5, 0.5]])  # texture coordinate 1.25
    wrap = run(law(src, textures={"line": (row, {"filter": "nearest", "address": "wrap"})}), u)
    clamp = run(law(src, textures={"line": (row, {"filter": "nearest", "address": "clamp"})}), u)
    assert wrap[0] == row[2] and clamp[0] == row[-1]  # 1.25 wraps to 0.25 (texel 2); clamps to the last


def test_mip_levels_are_box_averages():
    img = RNG.uniform(0, 1, (8, 8)).astype(np.float32)
    src = ("uniform sampler2D tex;\n"
           "float count(float n, float p, vec4 u) { return textureLod(tex, u.xy, 1.0).r; }")
    y, x = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    u = np.column_stack([((x + 0.5) / 4).ravel(), ((y + 0.5) / 4).ravel()])
    got = run(law(src, textures={"tex": (img, SamplerState("nearest", "clamp", mips=True))}), u)
    box = img.reshape(4, 2, 4, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(got, box.ravel(), rtol=1e-6)
    one = run(law(src, textures={"tex": (img, SamplerState("nearest", "clamp", mips=False))}), u)
    assert not np.allclose(one, box.ravel())  # one level: lod 1 reads level 0


def test_3d_texture_and_2d_texture_array():
    vol = RNG.uniform(0, 1, (4, 8, 16)).astype(np.float32)  # depth, height, width
    src3 = ("uniform sampler3D vol;\n"
            "float count(float n, float p, vec4 u) { return texelFetch(vol, ivec3(int(u.x * 16.0), "
            "int(u.y * 8.0), 3), 0).r; }")
    y, x = np.meshgrid(np.arange(8), np.arange(16), indexing="ij")
    u = np.column_stack([((x + 0.5) / 16).ravel(), ((y + 0.5) / 8).ravel()])
    np.testing.assert_array_equal(run(law(src3, textures={"vol": vol}), u), vol[3].ravel())
    layers = RNG.uniform(0, 1, (3, 8, 16, 2)).astype(np.float32)
    srca = ("Texture2DArray<float2> layers; SamplerState s;\n"
            "float count(float n, float p, float4 u) { return layers.SampleLevel(s, float3(u.xy, 2.0), 0).y; }")
    got = run(law(srca, "hlsl", textures={"layers": layers}, samplers={"s": {"filter": "nearest"}}), u)
    np.testing.assert_array_equal(got, layers[2, ..., 1].ravel())


def test_uniform_blocks_are_filled_by_member_name():
    hsrc = ("cbuffer Material { float roughness; float3 tint; float weights[3]; int mode; };\n"
            "float count(float n, float p, float4 u) { return roughness + tint.z + weights[2] + mode; }")
    vals = {"roughness": 0.25, "tint": [1.0, 2.0, 4.0], "weights": [0.5, 1.5, 8.0], "mode": 3}
    assert run(law(hsrc, "hlsl", uniforms=vals), [[0.5, 0.5]])[0] == np.float32(0.25 + 4.0 + 8.0 + 3)
    # HLSL's loose globals ($Global) and a GLSL block alike.
    g = law("float scale;\nfloat count(float n, float p, float4 u) { return scale * n; }", "hlsl",
            uniforms={"scale": 1.0 / 3.0})
    assert run(g, [[0.5, 0.5]])[0] == np.float32(1.0 / 3.0)
    b = law("layout(std140) uniform Params { vec2 offset; float gain; };\n"
            "float count(float n, float p, vec4 u) { return offset.y * gain; }",
            uniforms={"offset": [0.0, 3.0], "gain": 2.0})
    assert run(b, [[0.5, 0.5]])[0] == 6.0


def test_method_and_sampler_shaders_read_textures_too():
    table = RNG.uniform(0.1, 1, 32).astype(np.float32)
    m = gl.shader_method("StructuredBuffer<float> lut;\n"
                         "float glint(GlintInput g) { return lut[g.pixel.x % 32u]; }",
                         language="hlsl", register=False, buffers={"lut": table})
    pixel = np.column_stack([np.arange(64), np.zeros(64)]).astype(np.uint32)
    out = m.shade(MS.pack_inputs(64, pixel=pixel))
    np.testing.assert_array_equal(out, table[np.arange(64) % 32])
    scale = gl.shader_sampler(
        "Texture1D<float> k; SamplerState s;\n"
        "float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return float4(0, 0, 1, k.SampleLevel(s, 0.5, 0)); }\n"
        "float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return k.SampleLevel(s, 0.5, 0); }",
        textures={"k": np.array([2.0, 2.0], np.float32)}, samplers={"s": SamplerState()})
    assert np.allclose(scale.pdf(np.array([[0.0, 0.0, 1.0]])), 2.0)


# ---------------------------------------------------------------- pickles and identities

def test_resources_travel_in_pickles_and_enter_the_identity():
    src = ("uniform sampler2D tex;\n"
           "float count(float n, float p, vec4 u) { return textureLod(tex, u.xy, 0.0).r; }")
    img = RNG.uniform(0, 1, (4, 4)).astype(np.float32)
    a = law(src, textures={"tex": img})
    b = pickle.loads(pickle.dumps(a))
    u = RNG.uniform(0, 1, (50, 2))
    np.testing.assert_array_equal(run(a, u), run(b, u))
    assert a.identity == b.identity
    assert law(src, textures={"tex": img + 1}).identity != a.identity


# ---------------------------------------------------------------- one line naming what does not fit

TEX = "uniform sampler2D tex;\nfloat count(float n, float p, vec4 u) { return textureLod(tex, u.xy, 0.0).r; }"
BUF = ("layout(std430) readonly buffer Table { vec4 table[]; };\n"
       "float count(float n, float p, vec4 u) { return table[0].x; }")
UBO = "cbuffer M { float gain; };\nfloat count(float n, float p, float4 u) { return gain; }"


@pytest.mark.parametrize("src,language,resources,words", [
    (TEX, "glsl", {}, ["textures", "'tex'", "declares"]),  # declared, left unbound
    (TEX, "glsl", {"textures": {"tex": np.ones((4, 4)), "other": np.ones(4)}}, ["'other'", "declares"]),
    (TEX, "glsl", {"textures": {"tex": np.ones(4)}}, ["'tex'", "shape (4,)", "(height, width[, channels])"]),
    (TEX, "glsl", {"textures": {"tex": np.ones((4, 4, 5))}}, ["'tex'", "5 channels"]),
    (TEX, "glsl", {"textures": {"tex": np.ones((4, 4), np.int32)}}, ["'tex'", "int32", "float"]),
    (BUF, "glsl", {}, ["buffers", "'Table'"]),
    (BUF, "glsl", {"buffers": {"Table": np.ones((8, 3), np.float32)}}, ["'Table'", "(8, 3)", "4 32-bit word"]),
    (UBO, "hlsl", {}, ["uniforms", "'gain'"]),
    (UBO, "hlsl", {"uniforms": {"gain": 1.0, "gian": 2.0}}, ["'gian'", "declares"]),
    (UBO, "hlsl", {"uniforms": {"gain": [1.0, 2.0]}}, ["'gain'", "shape (2,)"]),
])
def test_mismatches_are_one_line_naming_the_resource(src, language, resources, words):
    with pytest.raises(ValueError) as e:
        law(src, language, **resources)
    msg = str(e.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_a_storage_image_is_refused_as_not_read_only():
    with pytest.raises(ValueError, match="'img'.*storage image.*read-only"):
        law("layout(r32f) uniform image2D img;\n"
            "float count(float n, float p, vec4 u) { return imageLoad(img, ivec2(0)).r; }")


def test_sampler_state_arguments_are_checked():
    with pytest.raises(ValueError, match="filter = 'cubic'"):
        SamplerState(filter="cubic")
    with pytest.raises(ValueError, match="mips"):
        law(TEX, textures={"tex": (np.ones((4, 4)), {"mips": 0})})
    with pytest.raises(ValueError, match="'bias'"):
        law(TEX, textures={"tex": (np.ones((4, 4)), {"bias": 1})})


# ---------------------------------------------------------------- files and the command line

def test_png_exr_and_npy_files_read_as_float_textures(tmp_path):
    rgb = (np.arange(4 * 6 * 3).reshape(4, 6, 3) * 3 % 256).astype(np.uint8)
    Image.fromarray(rgb).save(tmp_path / "t.png")
    np.testing.assert_array_equal(read_image(tmp_path / "t.png"), rgb.astype(np.float32) / np.float32(255))
    exr = RNG.uniform(-2, 2, (5, 3, 2)).astype(np.float32)
    out = oiio.ImageOutput.create(str(tmp_path / "t.exr"))
    out.open(str(tmp_path / "t.exr"), oiio.ImageSpec(3, 5, 2, "float"))
    out.write_image(exr)
    out.close()
    np.testing.assert_array_equal(read_image(tmp_path / "t.exr"), exr)
    np.save(tmp_path / "v.npy", np.ones((2, 2, 2)))
    assert read_image(tmp_path / "v.npy").shape == (2, 2, 2)
    with pytest.raises(ValueError, match="texture file"):
        read_image(tmp_path / "t.tga")


def test_images_command_binds_textures_and_uniforms(tmp_path, capsys):
    scene = str(data_path("scenes", "plane_90.json"))
    Image.fromarray(np.full((8, 8), 255, np.uint8)).save(tmp_path / "white.png")
    method = tmp_path / "lit_by_texture.glsl"
    method.write_text("uniform sampler2D Tint;\nlayout(std140) uniform Material { float gain; };\n"
                      "float glint(GlintInput g) { return gain * textureLod(Tint, g.uv, 0.0).r; }\n")
    common = [scene, "--scale", "0.03", "--frames", "2", "--timing-scale", "0.03", "--quiet", "--method", str(method)]
    try:
        assert main(["images", *common, "--texture", f"Tint={tmp_path / 'white.png'}", "--uniform", "gain=2",
                     "--out", str(tmp_path / "a")]) == 0
        assert main(["images", *common, "--uniform", "gain=2", "--out", str(tmp_path / "b")]) == 2
        assert "'Tint'" in capsys.readouterr().err
        assert main(["images", *common, "--texture", f"Tint={tmp_path / 'white.png'}", "--uniform", "gain=2",
                     "--uniform", "gian=1", "--out", str(tmp_path / "c")]) == 2
        assert "'gian'" in capsys.readouterr().err
        assert main(["images", *common, "--uniform", "gain", "--out", str(tmp_path / "d")]) == 2
        assert "--uniform" in capsys.readouterr().err
        # A .npy file given for a name the shader declares as a storage buffer binds as that buffer.
        np.save(tmp_path / "lut.npy", np.full(4, 0.5, np.float32))
        table = tmp_path / "table_method.glsl"
        table.write_text("layout(std430) readonly buffer Lut { float lut[]; };\n"
                         "float glint(GlintInput g) { return lut[3]; }\n")
        assert main(["images", scene, "--scale", "0.03", "--frames", "2", "--timing-scale", "0.03", "--quiet",
                     "--method", str(table), "--texture", f"Lut={tmp_path / 'lut.npy'}",
                     "--out", str(tmp_path / "e")]) == 0
        assert main(["images", scene, "--scale", "0.03", "--frames", "2", "--quiet", "--texture",
                     f"Lut={tmp_path / 'lut.npy'}", "--out", str(tmp_path / "f")]) == 2
        assert "--texture" in capsys.readouterr().err  # no --method to bind it to
    finally:
        IMAGE_METHODS._items.pop("lit_by_texture", None)
        IMAGE_METHODS._items.pop("table_method", None)


def test_shader_and_sampler_commands_take_the_same_options(tmp_path, capsys):
    law_file = tmp_path / "scaled.glsl"
    law_file.write_text("layout(std140) uniform Params { float scale; };\n"
                        "float count(float n, float p, vec4 u) { return scale * n * p; }\n")
    assert main(["shader", str(law_file), "--out", str(tmp_path / "s"), "--quiet"]) == 2
    assert "'scale'" in capsys.readouterr().err
    sampler_file = tmp_path / "textured.hlsl"
    sampler_file.write_text(
        "Texture1D<float> k; SamplerState s;\n"
        "float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return float4(0, 0, 1, k.SampleLevel(s, 0.5, 0)); }\n"
        "float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return k.SampleLevel(s, 0.5, 0); }\n")
    assert main(["sampler", str(sampler_file), "--samples", "1000", "--out", str(tmp_path / "p")]) == 2
    assert "'k'" in capsys.readouterr().err
    # A registered sampler compiles nothing: resources for it are refused by flag.
    assert main(["sampler", "ggx", "--uniform", "a=1", "--samples", "1000", "--out", str(tmp_path / "q")]) == 2
    assert "--uniform" in capsys.readouterr().err
