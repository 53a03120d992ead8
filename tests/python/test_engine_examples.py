"""The guide's engine-style examples with resources (docs/guide/engine_code.md): a texture-reading
method shader and a fragment-shader glint function with uniforms, each run by the glue the guide prints
(counted: at most ten lines) and checked against what it must compute."""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import fragment_shaders as FS
from glintlab.api import method_shaders as MS
from glintlab.validation import scene_images as si

pytestmark = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")
ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "guide" / "engine_code.md"


def glue(label: str) -> str:
    """The guide's Python block after the marker ``<!-- glue: label -->``."""
    text = GUIDE.read_text(encoding="utf-8")
    m = re.search(rf"<!-- glue: {label} -->\s*```python\n(.*?)```", text, re.S)
    assert m, f"no glue block {label!r} in {GUIDE}"
    return m.group(1)


def run_glue(label: str) -> dict:
    code = glue(label)
    lines = [ln for ln in code.splitlines() if ln.strip() and not ln.strip().startswith("#")]
    assert len(lines) <= 10, f"{label}: {len(lines)} lines of glue"
    scope: dict = {}
    cwd = os.getcwd()
    os.chdir(ROOT)  # the guide runs its glue from the repository's root
    try:
        exec(compile(code, f"<glue {label}>", "exec"), scope)
    finally:
        os.chdir(cwd)
    return scope


def dictionary_twin(rows, random_tex, dictionary, grid_scale, threshold, intensity):
    """The dictionary method in numpy (float32 where the shader is; cell edges may round apart)."""
    g = MS.unpack_inputs(rows)
    cell = np.floor(g["uv"] * np.float32(grid_scale))
    tile = random_tex.shape[0]
    r = random_tex[cell[:, 1].astype(np.int64) % tile, cell[:, 0].astype(np.int64) % tile]
    h = g["h"] / np.linalg.norm(g["h"], axis=1, keepdims=True)
    n = g["n"] / np.linalg.norm(g["n"], axis=1, keepdims=True)
    theta = np.arccos(np.clip((h * n).sum(1), 0, 1))
    b = np.minimum((theta / (np.pi / 2) * len(dictionary)).astype(np.int64), len(dictionary) - 1)
    return np.where(r < threshold * dictionary[b], intensity, 0.0)


def frame_rows_of(scene_name: str, scale: float, fragment: bool = False):
    """The rows gl.render(method, scene_name, scale=scale) runs (frame 0 of 8, one directional light)."""
    sc = si.with_directional_light(si.resolve_scene(scene_name).scaled(scale, keep_n=True))
    inp = si.frame_inputs(si.camera_at(sc, 8, 0))
    return (FS.fragment_rows if fragment else MS.frame_rows)(inp)[0]


def test_dictionary_method_reads_its_texture_buffer_and_cbuffer():
    s = run_glue("dictionary")
    image, method = s["image"], s["method"]
    lit = np.nan_to_num(image) > 0
    assert 0.001 < lit.mean() < 0.5  # sparkles, not a blank or a flat image
    # The same pixels through numpy: the texture (row = v cell, column = u cell), the table by bin and
    # the cbuffer's values must all arrive as declared.
    rows = frame_rows_of("sphere", 0.1)
    got = method.shade(rows)
    np.testing.assert_array_equal(np.sort(got), np.sort(image[np.isfinite(image)]))  # the glue's image
    want = dictionary_twin(rows, s["random"], s["table"], 256.0, 0.2, 4.0)
    assert (got != want).mean() < 0.01 * max((want > 0).mean(), 1e-3) + 1e-3
    # Not blind: the texture transposed (u and v swapped) is another image.
    assert (dictionary_twin(rows, s["random"].T, s["table"], 256.0, 0.2, 4.0) != got).mean() > 0.1 * (want > 0).mean()


def test_fragment_sparkles_see_the_footprint_through_fwidth():
    s = run_glue("sparkle")
    image = s["image"]
    lit = np.nan_to_num(image[..., 0]) > 0
    assert 0.001 < lit.mean() < 0.5
    source = (ROOT / "examples" / "engine" / "sparkle.frag").read_text()
    assert "fwidth(vUv)" in source
    uniforms = {"uSparkleDensity": 400.0, "uSparkleSize": 0.35, "uShininess": 8.0}

    def variant(footprint):
        code = source.replace("fwidth(vUv)", footprint)
        code = code.replace("layout(location = 0) out", "in vec4 vJ;\nlayout(location = 0) out")
        return gl.shader_method(code, mode="fragment", language="glsl", register=False, uniforms=uniforms,
                                varyings={"uLightDir": "light", "vJ": "J"})

    rows = frame_rows_of("sphere", 0.1, fragment=True)
    got = s["method"].run(rows)[:, 0]
    spelled = variant("(abs(vJ.xy) + abs(vJ.zw))").run(rows)[:, 0]
    flat = variant("vec2(0.0)").run(rows)[:, 0]
    assert (got > 0).sum() > 50
    assert (got != spelled).mean() < 0.01
    assert (got != flat).mean() > 0.05
