"""ZK16 (as DB23 describes it), its gated variant (KPT25's Table 3 footnote) and the no-glints baseline as
method shaders against their C++ twins (docs/guide/gpu_cost.md#the-method-shaders-of-the-two-tables):
pixel by pixel on scene rows, deliberately wrong variants rejected by the same comparison, HLSL = GLSL."""
from __future__ import annotations

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import counting_shaders as CS
from glintlab.api import zk16_shaders as Z
from glintlab.validation import method_twins as MT

needs_vulkan = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

# Shader and twin read the same float32 rows and the same per-cell random numbers; a pixel differs only
# where float32 moves a probe across a cell edge or a count across a floor. Measured on lavapipe
# (plane_25 at 0.04 and 0.06, plane_90 at 0.05, heightfield_25 at 0.05, sphere at 0.06; both laws): 0 pixels.
MAX_SHARE = 0.005


@pytest.fixture(scope="module")
def plane_rows():
    return MT.scene_rows("plane_25", 0.04, seed=5)


@needs_vulkan
@pytest.mark.parametrize("gated", [False, True])
def test_zk16_shader_agrees_with_its_twin_and_wrong_variants_do_not(plane_rows, gated):
    rows, material = plane_rows
    twin, ok = Z.zk16_twin(rows, material, gated)
    assert ok.mean() > 0.9 and (twin[ok] > 0).mean() > 0.5  # glints counted on most pixels, none widened
    r = CS.twin_mismatch(Z.zk16_method(material, gated=gated).shade(rows)[ok], twin[ok], rows[ok], material)
    assert r["share"] <= MAX_SHARE and r["share_1pct"] <= MAX_SHARE, r
    # The same comparison rejects fewer probes (maximum anisotropy 4) and the other law.
    for wrong in (Z.zk16_variant(material, ZK16_MAX_ANISO=4, ZK16_GATED=int(gated)),
                  Z.zk16_variant(material, ZK16_GATED=int(not gated))):
        bad = CS.twin_mismatch(wrong.shade(rows)[ok], twin[ok], rows[ok], material)
        assert bad["share"] > 20 * MAX_SHARE, bad


@needs_vulkan
def test_zk16_hlsl_and_glsl_agree_and_the_baseline_is_the_smooth_ndf(plane_rows):
    rows, material = plane_rows
    np.testing.assert_array_equal(Z.zk16_method(material, language="hlsl").shade(rows[:500]),
                                  Z.zk16_method(material).shade(rows[:500]))
    _, _, h, _ = CS.tangent_inputs(rows)
    smooth = Z.smooth_method(material).shade(rows)
    ref = Z.zk16_twin_ndf(material).smooth(h)
    np.testing.assert_allclose(smooth, ref, rtol=1e-4)
    for name in ("zk16_shader", "zk16_gated_shader", "smooth_shader"):
        assert name in gl.image_methods(returns="ndf")
