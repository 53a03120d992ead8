"""DB23's counting pipeline as a method shader against its C++ twin (docs/math/glint_images.md#glint-db23-shader):
pixel by pixel on a scene's float32 rows, deliberately wrong variants (a wrong LOD, a wrong hash key)
rejected by the same comparison, determinism, and the float32 study's cases."""
from __future__ import annotations

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import counting_shaders as CS
from glintlab.validation import method_twins as MT
from glintlab.validation import scene_images as si

needs_vulkan = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

# Shader and twin read the same float32 rows and the same per-cell random numbers, so a pixel differs
# beyond the allowance only where a float32 rounding moves a grid coordinate across a cell boundary or
# the gated law's floor across an integer. Measured on lavapipe (plane_25 and sphere at 0.1 scale, seeds
# 0 and 5): 0 to 0.013 % of the pixels; MAX_SHARE leaves room for another device's transcendentals.
MAX_SHARE = 0.002


@pytest.fixture(scope="module")
def plane_rows():
    return MT.scene_rows("plane_25", 0.1, seed=5)


@needs_vulkan
def test_db23_shader_agrees_with_its_twin_and_wrong_variants_do_not(plane_rows):
    rows, material = plane_rows
    assert rows.shape[0] > 10000
    twin = CS.db23_twin(rows, material)
    assert 0.5 < (twin > 0).mean() and np.isfinite(twin).all()  # glints counted, not a blank image
    r = MT.compare(rows, material, explain_limit=0)
    assert r["share"] <= MAX_SHARE and r["share_1pct"] <= MAX_SHARE, r
    # The same comparison rejects a shader one LOD level off (the grids one scale coarser) and one whose
    # cells read other keys (its counts are another realization of the same law).
    for wrong in (CS.db23_method(material, lod_bias=1), CS.db23_method(material, key_salt=1)):
        bad = CS.twin_mismatch(wrong.shade(rows), twin, rows, material)
        assert bad["share"] > 50 * MAX_SHARE and bad["share_1pct"] > 50 * MAX_SHARE, (wrong, bad)


@needs_vulkan
def test_db23_shader_is_deterministic_and_an_ndf_image_method(plane_rows):
    rows, material = plane_rows
    m = CS.db23_method(material)
    a, b = m.shade(rows), m.shade(rows[::-1].copy())[::-1]  # another order, other work groups
    np.testing.assert_array_equal(a, b)
    assert "db23_shader" in gl.image_methods(returns="ndf") and "db23_shader" not in si.DEFAULT_METHODS
    # evaluate() on tangent-frame inputs is the same pixel as the row with the world frame.
    uv, J, h, seed = CS.tangent_inputs(rows[:500])
    np.testing.assert_allclose(m.evaluate(uv, J, h, seed=seed), a[:500], rtol=1e-4, atol=0)
    np.testing.assert_array_equal(m.smooth(np.array([[0.0, 0.0, 1.0]])), [1.0 / np.pi / material.alpha**2])


@needs_vulkan
def test_float32_study_finds_the_offsets_and_explains_them():
    t = MT.float32_study("sphere", 0.1, cases=MT.CASES[:1] + MT.CASES[3:4]).set_index("case")
    assert t.loc["as rendered", "mismatch_share"] <= MAX_SHARE
    far = t.loc["uv + 1e6 texels"]
    # 1e6 cells from the origin a float32 grid coordinate keeps 1/16 cell: whole cells move.
    assert far.mismatch_share > 10 * MAX_SHARE and far.at_cell_boundary >= 0.8 * far.examined


def test_db23_defines_refuse_bad_variants():
    m = gl.api.glinty_ndf.Material(4194304.0, "beckmann", 1.0, 0.5)
    with pytest.raises(ValueError, match="lod_bias"):
        CS.db23_defines(m, lod_bias=99)
    with pytest.raises(ValueError, match="material"):
        CS.db23_method("plane_25")
