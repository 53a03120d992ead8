"""The shipped method shaders' texture options, each against its current (hashed) form: WB16's noise read
from a real 3D noise texture (WB16_NOISE_TEXTURE 1) and DB23's random numbers read from a texture of
precomputed random numbers (db23_method(..., random_texture=...))."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scipy import stats

import glintlab as gl
from glintlab.api import counting_shaders as CS
from glintlab.api import method_shaders as MS
from glintlab.api.glinty_ndf import Material
from glintlab.validation import scene_images as si

sys.path.insert(0, str(Path(__file__).parent))
from test_method_shaders import _wb16_frames  # noqa: E402 -- the two small WB16 frames (seed 7)

pytestmark = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

# What agreement is expected: the texture holds the hashed noise's cell values for the frames' seed, and
# the hashed noise is that texture's trilinear filtering written out, so the images differ only by the
# device's filtering arithmetic. lavapipe filters in float32 (measured: mean |difference| 1.4e-7 of the
# mean intensity); a GPU may weight with 8-bit fractions, moving the noise by up to 1/256 and a sparkle's
# centre by 1/512 cell, which changes a pixel by at most about 0.013 (the kernel is 1 - dist2 / 0.1).
# So: no pixel may differ by more than 0.05, and the mean difference stays under 1% of the mean.
MAX_PIXEL, MAX_MEAN = 0.05, 0.01


def _texture_noise(rows, seed, language="glsl", filter="linear"):
    if filter == "linear":  # the shipped option
        return MS.wb16_method(language, noise_texture=seed).shade(rows)
    samplers = {"WB16NoiseSampler": {"filter": filter}} if language == "hlsl" else None
    m = gl.shader_method(MS.wb16_shader(language), language=language, defines={"WB16_NOISE_TEXTURE": 1},
                         register=False, samplers=samplers,
                         textures={"WB16NoiseTex": (MS.wb16_noise_texture(seed=seed), {"filter": filter})})
    return m.shade(rows)


def _differ(a, b):
    d = np.abs(a - b)
    return (d > MAX_PIXEL).mean(), d.mean() / b.mean()


def test_wb16_texture_noise_is_the_hashed_noise():
    rows = _wb16_frames()
    hashed = MS.wb16_method().shade(rows)
    assert 0.02 < (hashed > 0).mean() < 0.6  # sparkles, not a blank image
    for language in ("glsl", "hlsl"):
        share, mean = _differ(_texture_noise(rows, 7, language), hashed)
        assert share == 0 and mean < MAX_MEAN, (language, share, mean)
    # The same check rejects a texture of another seed, and one read without filtering.
    for wrong in (_texture_noise(rows, 8), _texture_noise(rows, 7, filter="nearest")):
        share, mean = _differ(wrong, hashed)
        assert share > 0.1 and mean > 10 * MAX_MEAN, (share, mean)


def test_wb16_noise_texture_holds_the_cell_values():
    tex = MS.wb16_noise_texture(seed=3, size=8)
    assert tex.shape == (8, 8, 8, 3) and tex.dtype == np.float32
    # texel (z, y, x) is cell (x, y, z)
    np.testing.assert_array_equal(tex[5, 2, 1], MS.cell_values(np.array([[1, 2, 5]]), np.array([3], np.uint32))[0])
    with pytest.raises(ValueError, match="seed"):
        MS.wb16_noise_texture(seed=-1)


# DB23: the texture form reads other random numbers than the hashed form, so the images differ pixel by
# pixel; what must agree is the law. Per frame seed, the mean of D over the lit pixels of a small sphere
# frame, for 12 seeds; the texture form gets a texture of its own per seed (independent samples). Two
# tests compare the two sets of per-frame means: Welch's t-test (their mean) and the Brown-Forsythe test
# (their spread: numbers that repeat across cells spread the frames' means); each fails with probability
# 1e-3 under the same law (the per-frame means are averages over ~3,000 pixels: normal by the central
# limit theorem), so the check's false-failure rate is at most 2e-3. Measured (lavapipe): p = 0.86 (mean)
# and 0.81 (spread); a texture of squared uniforms (biased numbers) fails the mean (p = 5e-28), one of a
# single texel (every cell reads the same pair) the spread (p = 1.3e-4; 2 x 2 texels gave 0.0013, too
# close to call with 12 frames).
SEEDS = range(12)
ALPHA = 1e-3


def _frame_means(make, inp):
    return np.array([np.nanmean(make(seed).image(inp, seed=seed)[inp.mask]) for seed in SEEDS])


def _same_law(a, b) -> tuple[float, float]:
    return (stats.ttest_ind(a, b, equal_var=False).pvalue, stats.levene(a, b, center="median").pvalue)


def test_db23_texture_of_random_numbers_follows_the_hashed_forms_law():
    sc = si.with_directional_light(si.resolve_scene("sphere").scaled(0.1, keep_n=True))
    mat, inp = Material.of(sc), si.frame_inputs(si.camera_at(sc, 8, 0))
    hashed = _frame_means(lambda seed: CS.db23_method(mat), inp)

    def texture_means(texture_of):
        return _frame_means(lambda seed: CS.db23_method(mat, random_texture=texture_of(seed)), inp)

    p_mean, p_spread = _same_law(hashed, texture_means(lambda seed: CS.db23_random_texture(64, 100 + seed)))
    assert p_mean > ALPHA and p_spread > ALPHA, (p_mean, p_spread)
    biased = _same_law(hashed, texture_means(lambda seed: CS.db23_random_texture(64, 100 + seed) ** 2))
    assert biased[0] < ALPHA, biased
    tiny = _same_law(hashed, texture_means(lambda seed: CS.db23_random_texture(1, 100 + seed)))
    assert tiny[1] < ALPHA, tiny
    print(f"DB23 texture form: p = {p_mean:.3g} (mean), {p_spread:.3g} (spread); biased: {biased[0]:.3g}; "
          f"one texel: {tiny[1]:.3g}")


def test_db23_random_texture_is_checked():
    mat = Material(4194304.0, "beckmann", 1.0, 0.5)
    with pytest.raises(ValueError, match="random_texture"):
        CS.db23_method(mat, random_texture=np.zeros((4, 4, 2), np.float32))
    with pytest.raises(ValueError, match="random_texture"):
        CS.db23_method(mat, random_texture=np.full((4, 5, 2), 0.5, np.float32))
