"""The fragment mode of method shaders (docs/guide/shaders.md#shaders-fragment): GLSL fragment code
as written (#version, in/out, loose uniforms, void main), its derivatives taken across glintlab's quads
(checked against the differentials the rows carry), texture() choosing its mip level from them, and its
image against the same function written in the method contract."""
from __future__ import annotations

import numpy as np
import pytest

import glintlab as gl
from glintlab import _core
from glintlab.api import fragment_shaders as FS
from glintlab.api import method_shaders as MS
from glintlab.resources import data_path
from glintlab.validation import scene_images as si
from glintlab.validation.scene import load_scene

pytestmark = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")
RNG = np.random.default_rng(4)


def rows_with(m, dpdx=0.0, dpdy=0.0, dndx=0.0, dndy=0.0, **fields):
    """Fragment rows: pack_inputs' words, then the differentials."""
    w = _core.METHOD_INPUT_WORDS
    rows = np.zeros((m, _core.FRAGMENT_INPUT_WORDS), np.uint32)
    rows[:, :w] = MS.pack_inputs(m, **fields)
    for k, a in enumerate((dpdx, dpdy, dndx, dndy)):
        rows[:, w + 3 * k:w + 3 + 3 * k] = np.broadcast_to(np.asarray(a, np.float32), (m, 3)).view(np.uint32)
    return rows


def fragment(code, **kw):
    return gl.shader_method(code, mode="fragment", language="glsl", register=False, **kw)


PROBE = """#version 450
precision highp float;
layout(location = 0) in vec2 vUv;
layout(location = 1) in vec3 vWorldPos;
in vec3 vNormal;
layout(location = 0) out vec4 fragColor;
void main() {
  fragColor = vec4(dFdx(vUv).x + 10.0 * dFdy(vUv).y, dFdx(vWorldPos).z, fwidth(vNormal).y + dFdy(vNormal).x, 1.0);
}
"""


def test_derivatives_are_the_differentials_across_the_quad():
    m = 256
    uv, J = RNG.uniform(0, 1, (m, 2)), RNG.uniform(-1e-2, 1e-2, (m, 4))
    pos, dpdx, dpdy = RNG.uniform(-1, 1, (m, 3)), RNG.uniform(-1e-2, 1e-2, (m, 3)), RNG.uniform(-1e-2, 1e-2, (m, 3))
    n, dndx, dndy = RNG.uniform(-1, 1, (m, 3)), RNG.uniform(-1e-2, 1e-2, (m, 3)), RNG.uniform(-1e-2, 1e-2, (m, 3))
    rows = rows_with(m, dpdx, dpdy, dndx, dndy, uv=uv, J=J, world_pos=pos, n=n)
    out = fragment(PROBE).run(rows)
    f = np.float32
    want = np.column_stack([J[:, 0] + 10 * J[:, 3], dpdx[:, 2],
                            np.abs(dndx[:, 1]) + np.abs(dndy[:, 1]) + dndy[:, 0]]).astype(f)
    # float32: uv + J - uv loses the bits of uv below J's (|uv| < 1, so 2^-24 absolute).
    np.testing.assert_allclose(out[:, :3], want, atol=2e-6)
    assert (out[:, 3] == 3.0).all()
    # Not blind: dFdx(vUv).x is not dFdy's, nor 0.
    assert not np.allclose(out[:, 0], (J[:, 2] + 10 * J[:, 3]).astype(f), atol=2e-6)


def test_texture_picks_its_mip_level_from_the_derivatives():
    size = 64
    checker = ((np.indices((size, size)).sum(axis=0)) % 2).astype(np.float32)  # level 0: 0/1, level 1 on: 0.5
    code = ("#version 450\nin vec2 vUv;\nuniform sampler2D checker;\nout vec4 fragColor;\n"
            "void main() { fragColor = texture(checker, vUv); }\n")
    m = 64
    uv = (np.column_stack([RNG.integers(0, size, m), RNG.integers(0, size, m)]) + 0.5) / size
    state = gl.SamplerState("nearest", "wrap", mips=True)
    method = fragment(code, textures={"checker": (checker, state)})
    fine = method.run(rows_with(m, uv=uv, J=[0.2 / size, 0, 0, 0.2 / size]))[:, 0]  # lod log2(0.2) < 0
    coarse = method.run(rows_with(m, uv=uv, J=[4.0 / size, 0, 0, 4.0 / size]))[:, 0]  # lod 2
    assert set(np.unique(fine)) <= {0.0, 1.0} and (coarse == 0.5).all()
    # A texture read without the derivatives (lod 0) would show the checker at both.
    flat = fragment(code.replace("texture(checker, vUv)", "textureLod(checker, vUv, 0.0)"),
                    textures={"checker": (checker, state)})
    assert set(np.unique(flat.run(rows_with(m, uv=uv, J=[4.0 / size, 0, 0, 4.0 / size]))[:, 0])) <= {0.0, 1.0}


def test_uniforms_by_name_and_scene_driven_ones():
    code = ("#version 330 core\nin vec2 uv;\nuniform float gain;\nuniform vec3 lightDir;\nuniform vec2 offsets[2];\n"
            "out vec4 color;\n"
            "void main() { color = vec4(gain * uv.x + offsets[1].y, lightDir.z, 0.0, 1.0); }\n")
    m = 16
    uv, light = RNG.uniform(0, 1, (m, 2)), RNG.uniform(-1, 1, (m, 3))
    method = fragment(code, uniforms={"gain": 2.0, "offsets": [[0.0, 0.0], [0.0, 0.25]]},
                      varyings={"lightDir": "light"})
    out = method.run(rows_with(m, uv=uv, light=light))
    np.testing.assert_allclose(out[:, 0], 2 * uv[:, 0].astype(np.float32) + 0.25, rtol=1e-6)
    np.testing.assert_array_equal(out[:, 1], light[:, 2].astype(np.float32))
    with pytest.raises(ValueError, match="'gain'"):
        fragment(code, varyings={"lightDir": "light"}, uniforms={"offsets": [[0, 0], [0, 0]]})


def test_the_file_is_compiled_line_for_line_and_bad_wiring_is_named():
    bad = "#version 450\nin vec2 vUv;\nout vec4 c;\n\n\nvoid main() {\n  c = vec4(vUv, 0.0 1.0);\n}\n"
    with pytest.raises(ValueError, match=r":7: error"):
        fragment(bad)
    with pytest.raises(ValueError, match="vMystery"):
        fragment("in float vMystery;\nout vec4 c;\nvoid main() { c = vec4(vMystery); }")
    with pytest.raises(ValueError, match="output"):
        fragment("in vec2 vUv;\nout vec4 a;\nout vec4 b;\nvoid main() { a = b = vec4(vUv, 0, 1); }")
    with pytest.raises(ValueError, match="varyings"):
        gl.shader_method("float glint(GlintInput g) { return 1.0; }", varyings={"x": "uv"}, register=False)


def test_a_fragment_image_is_the_method_contracts_image():
    sc = si.with_directional_light(load_scene(data_path("scenes", "sphere.json")).scaled(0.04, keep_n=True))
    inp = si.frame_inputs(sc)
    frag = fragment("#version 450\nin vec2 vUv;\nin vec3 vNormal;\nout vec4 o;\n"
                    "void main() { o = vec4(fract(vUv.x * 8.0), abs(vNormal.z), 0.0, 1.0); }\n")
    meth = gl.shader_method("vec3 glint(GlintInput g) { return vec3(fract(g.uv.x * 8.0), abs(g.n.z), 0.0); }",
                            language="glsl", register=False)
    a, b = frag.image(inp), meth.image(inp)
    assert a.shape == b.shape and inp.hit.sum() > 100
    np.testing.assert_array_equal(a, b)
    rows, hit = FS.fragment_rows(inp)
    assert rows.shape == (hit.sum(), _core.FRAGMENT_INPUT_WORDS)
