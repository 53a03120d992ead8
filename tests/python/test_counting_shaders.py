"""DB23's counting pipeline and KPT25's Algorithm 1 as method shaders against their C++ twins
(docs/math/glint_images.md#glint-db23-shader, docs/math/glint_images.md#glint-kpt25-shader): pixel by pixel on a
scene's float32 rows, deliberately wrong variants (a wrong LOD, a wrong hash key) rejected by the same
comparison, determinism, and the float32 study's cases."""
from __future__ import annotations

import dataclasses
import pickle
import re

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import counting_shaders as CS
from glintlab.api.glinty_ndf import IMAGE_METHODS, method_density
from glintlab.api.method_shaders import pack_inputs
from glintlab.validation import method_twins as MT
from glintlab.validation import scene_images as si

needs_vulkan = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

# Shader and twin read the same float32 rows and the same per-cell random numbers, so a pixel differs
# beyond the allowance only where a float32 rounding moves a grid coordinate across a cell boundary or
# the gated law's floor across an integer (DB23), or a point across the filter's edge (KPT25). Measured
# on lavapipe (plane_25, plane_90, sphere, heightfield_25 at 0.06 and 0.1 scale, seeds 0 and 5): 0 to
# 0.02 % of the pixels for DB23, 0 to 0.13 % for KPT25; MAX_SHARE leaves room for another device's
# transcendentals.
MAX_SHARE = 0.005


@pytest.fixture(scope="module")
def plane_rows():
    # At 0.06 scale the middle column sees u = 0 exactly: the grids at a quarter turn put a cell
    # boundary there (a shader taking float32's cos(pi/2) reads the wrong cells on 1.6 % of the pixels).
    return MT.scene_rows("plane_25", 0.06, seed=5)


@needs_vulkan
def test_db23_shader_agrees_with_its_twin_and_wrong_variants_do_not(plane_rows):
    rows, material = plane_rows
    assert rows.shape[0] > 7000
    twin = CS.db23_twin(rows, material)
    assert 0.5 < (twin > 0).mean() and np.isfinite(twin).all()  # glints counted, not a blank image
    r = MT.compare(rows, material, explain_limit=0)
    assert r["share"] <= MAX_SHARE and r["share_1pct"] <= MAX_SHARE, r
    # The same comparison rejects a shader one LOD level off (the grids one scale coarser) and one whose
    # cells read other keys (its counts are another realization of the same law), by far: the wrong
    # variants its registry entry declares (test_extension_registries.py runs them at 10 x MAX_SHARE).
    for label, wrong in IMAGE_METHODS.get("db23_shader").shader.wrong(material).items():
        bad = CS.twin_mismatch(wrong.shade(rows), twin, rows, material)
        assert bad["share"] > 50 * MAX_SHARE and bad["share_1pct"] > 50 * MAX_SHARE, (label, bad["share"])


@needs_vulkan
def test_db23_shader_is_deterministic_and_an_ndf_image_method(plane_rows):
    rows, material = plane_rows
    m = CS.db23_method(material)
    a, b = m.shade(rows), m.shade(rows[::-1].copy())[::-1]  # another order, other work groups
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(m)).shade(rows[:200]), a[:200])  # travels by value
    assert "db23_shader" in gl.image_methods(returns="ndf") and "db23_shader" not in si.panel_methods()
    # evaluate() on tangent-frame inputs is the same pixel as the row with the world frame.
    uv, J, h, seed = CS.tangent_inputs(rows[:500])
    np.testing.assert_allclose(m.evaluate(uv, J, h, seed=seed), a[:500], rtol=1e-4, atol=0)
    np.testing.assert_array_equal(m.smooth(np.array([[0.0, 0.0, 1.0]])), [1.0 / np.pi / material.alpha**2])
    with pytest.raises(ValueError, match=r"J\[1, 2\]"):
        m.evaluate(uv[:3], np.where(np.arange(12).reshape(3, 4) == 6, np.nan, J[:3]), h[:3])
    with pytest.raises(ValueError, match="seed"):
        m.evaluate(uv[:3], J[:3], h[:3], seed=2**40)


@needs_vulkan
def test_float32_study_finds_the_offsets_and_explains_them():
    t = MT.float32_study("sphere", 0.1, cases=MT.CASES[:1] + MT.CASES[3:4], explain_limit=16)
    t = t.set_index(["method", "case"])
    for method in ("db23_shader", "kpt25_shader"):
        assert t.loc[(method, "as rendered"), "mismatch_share"] <= MAX_SHARE
        # 1e6 cells from the origin a float32 coordinate keeps 1/16 of a finest cell: cells move (DB23),
        # points cross the filter's edge (KPT25).
        far = t.loc[(method, "uv + 1e6 texels")]
        assert far.mismatch_share > 4 * MAX_SHARE and far.examined == 16, far
    reasons = t.loc[("db23_shader", "uv + 1e6 texels"), "reasons"]
    assert int(re.search(r"cell boundary (\d+)", reasons).group(1)) >= 13, reasons


@needs_vulkan
def test_kpt25_shader_agrees_with_its_twin_and_wrong_variants_do_not():
    rows, facets = MT.scene_rows("sphere", 0.1, seed=3)
    material = dataclasses.replace(facets, density=method_density("kpt25_shader", facets))
    twin = CS.kpt25_twin(rows, material)
    d = CS.kpt25_twin_ndf(material).smooth(CS.tangent_inputs(rows)[2])
    assert np.isfinite(twin).all() and (twin > 3 * d).sum() >= 2  # glints, not only the compensation
    m = CS.kpt25_method(material)
    ok = CS.kpt25_mismatch(m.shade(rows), twin, rows, material)
    assert ok["share"] <= MAX_SHARE and ok["share_1pct"] <= MAX_SHARE, ok
    np.testing.assert_array_equal(m.shade(rows), m.shade(rows))  # determinism
    # (Its wrong variants, half a MIP level off and another key, are its registry entry's:
    # test_extension_registries.py shows the comparison rejects them.)
    assert "kpt25_shader" in gl.image_methods(returns="ndf") and si.truth_kind("kpt25_shader") == "reference"


@needs_vulkan
def test_kpt25_shader_is_never_negative_where_the_lobe_meets_the_square_edge():
    """Grazing half vectors (60-80 degrees, Beckmann alpha 1) along the four axes put T(h) within a few
    lobe stds (1e-5 to 1e-3) of the unit square's edge, inside B(k): eq. 10's compensation is then the
    difference of two nearly equal masses, and the device evaluates the shared edge (1, the block's end)
    an ulp apart in the two (lavapipe: 3 % of the pixels negative, down to -0.04 D(h), before the shader
    wrote it as a sum of the masses outside B(k)). K_P is the sphere's light-response density."""
    material = gl.api.glinty_ndf.Material(204800.0, "beckmann", 1.0, 0.5)
    rng = np.random.default_rng(7)
    m = 4000
    theta = np.radians(rng.uniform(60, 80, m))
    phi = rng.integers(0, 4, m) * np.pi / 2 + rng.uniform(-0.02, 0.02, m)
    h = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    scale, turn = np.exp(rng.uniform(np.log(0.04), np.log(0.6), m)), rng.uniform(0, np.pi, m)  # MIP levels 5-9
    J = scale[:, None] * np.stack([np.cos(turn), np.sin(turn), -0.7 * np.sin(turn), 0.7 * np.cos(turn)], axis=1)
    rows = pack_inputs(m, uv=rng.uniform(0, 10, (m, 2)), J=J, n=[0, 0, 1], t=[1, 0, 0], b=[0, 1, 0], h=h,
                       view=[0, 0, 1], light=[0, 0, 1], seed=1)
    shader = CS.kpt25_method(material).run(rows)[:, 0]
    assert (shader >= 0).all(), (shader.min(), int((shader < 0).sum()))
    twin = CS.kpt25_twin(rows, material)
    assert (twin > 0).mean() > 0.5  # the compensation is read, not a blank image
    r = CS.kpt25_mismatch(shader, twin, rows, material)
    assert r["share"] <= MAX_SHARE, r  # 0.05 % (one point across the filter's edge); 6 % before


@needs_vulkan
def test_ggx_targets_agree_too():
    """The GGX branches (DB23's p, KPT25's map T and D) against the twins on a GGX material."""
    rows, facets = MT.scene_rows("sphere", 0.1, seed=2)
    ggx = dataclasses.replace(facets, target="ggx", alpha=0.5)
    assert MT.compare(rows, ggx, explain_limit=0)["share"] <= MAX_SHARE
    kpt = dataclasses.replace(ggx, density=method_density("kpt25_shader", ggx))
    assert MT.kpt25_compare(rows, kpt, explain_limit=0)["share"] <= MAX_SHARE
    # ... and the Beckmann shaders on the GGX material are not (the comparison sees the target).
    wrong = CS.kpt25_method(dataclasses.replace(kpt, target="beckmann")).shade(rows)
    assert CS.kpt25_mismatch(wrong, CS.kpt25_twin(rows, kpt), rows, kpt)["share"] > 10 * MAX_SHARE


@needs_vulkan
def test_hlsl_and_glsl_are_one_body(plane_rows):
    """Each method shader is one body in the subset both languages share: the HLSL and GLSL wrappers
    compute the same bits (the HLSL one multiplies 32-bit words by halves and builds ldexp's powers of two)."""
    rows, material = plane_rows
    kpt = dataclasses.replace(material, density=method_density("kpt25_shader", material))
    for make, mat in ((CS.db23_method, material), (CS.kpt25_method, kpt)):
        np.testing.assert_array_equal(make(mat, language="hlsl").shade(rows), make(mat, language="glsl").shade(rows))
    for name in ("db23", "kpt25"):
        for lang in CS.METHOD_LANGUAGES:
            code = [ln for ln in (CS.db23_shader if name == "db23" else CS.kpt25_shader)(lang).read_text().splitlines()
                    if ln.strip() and not ln.lstrip().startswith("//")]
            assert code == [f"#define GLINTLAB_{lang.upper()}", '#include "glintlab_method_prelude.h"',
                            f'#include "{name}_method_body.h"'], code


def test_db23_defines_refuse_bad_variants():
    m = gl.api.glinty_ndf.Material(4194304.0, "beckmann", 1.0, 0.5)
    with pytest.raises(ValueError, match="lod_bias"):
        CS.db23_defines(m, lod_bias=99)
    with pytest.raises(ValueError, match="material"):
        CS.db23_method("plane_25")
    with pytest.raises(ValueError, match="language"):
        CS.kpt25_method(m, language="wgsl")
