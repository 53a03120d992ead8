"""The HLSL dialect glintlab compiles (glslang's, through shaderc), measured: every row of
hlsl_dialect.CONSTRUCTS is compiled as a counting law and must do what the table says; the docs page shows
the same table; a DXC-only construct's compile error says so and how to rewrite it."""
from __future__ import annotations

from pathlib import Path

import pytest

import glintlab as gl
from glintlab.api.hlsl_dialect import CONSTRUCTS, markdown_table
from glintlab.api.shaders import ShaderCompileError

pytestmark = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")
DOCS = Path(__file__).resolve().parents[2] / "docs" / "guide" / "shaders.md"


@pytest.mark.parametrize("row", CONSTRUCTS, ids=[r.name for r in CONSTRUCTS])
def test_each_construct_compiles_as_the_table_says(row):
    uniforms = {"kScale": 2} if "cbuffer" in row.code else None
    if row.compiles:  # every row computes n * p: it compiles and runs as written
        law = gl.shader_law(row.code, language="hlsl", register=False, uniforms=uniforms)
        assert law.evaluate_raw(10.0, 0.5, [[0.5, 0.5]])[0] == 5.0
    else:
        with pytest.raises(ShaderCompileError) as e:
            gl.shader_law(row.code, language="hlsl", register=False)
        msg = str(e.value)
        assert "DXC-only" in msg and row.rewrite in msg and "\n" not in msg, msg


def test_the_docs_show_the_measured_table():
    assert markdown_table() in DOCS.read_text(encoding="utf-8")


def test_an_error_unrelated_to_dxc_gets_no_dxc_advice():
    with pytest.raises(ShaderCompileError) as e:
        gl.shader_law("float count(float n, float p, float4 u) { return n * p +; }", language="hlsl", register=False)
    assert "DXC" not in str(e.value)
