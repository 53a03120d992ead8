"""Every entry of each Python extension registry is tested, rendered and documented, with no hand list
(the laws have theirs in C++: tests/cpp/test_batch.cpp and tests/cpp/test_registry.cpp run every
registered law): every image method renders a small frame; every shipped one has a section of the docs
that names it; every shipped method shader has its body and thin wrappers, agrees with its C++ twin, and
its comparison rejects each deliberately wrong variant its registrant declares; a method registered
after glintlab's import is in the scene images' default panel. The lists are the registries'
(``gl.image_methods()``, ``shipped_method_shaders()``), read when the tests are collected."""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.glinty_ndf import (IMAGE_METHODS, GlintyNDF, SmoothNDF, method_density, panel_methods,
                                     register_image_method, shipped_image_methods)
from glintlab.api.method_shaders import shipped_method_shaders
from glintlab.validation import method_twins as MT

ROOT = Path(__file__).resolve().parents[2]
VULKAN = bool(gl.vulkan_devices())
SHIPPED = shipped_image_methods()
SHADERS = shipped_method_shaders()


def _needs_vulkan(name: str) -> bool:
    entry = IMAGE_METHODS.get(name)
    return entry.shader is not None or entry.origin == "shader_method"


def test_the_registries_hold_every_kind():
    # Not vacuous: the NDF methods, WB16's shader and the counting method shaders are all there.
    assert {"truth", "smooth", "kpt25", "wwh18", "wb16", "db23_shader", "kpt25_shader"} <= set(SHIPPED)
    assert {"wb16", "wb16_star", "wb16_lookup_noise", "db23_shader", "kpt25_shader"} <= set(SHADERS)


@pytest.mark.parametrize("name", SHIPPED)
def test_every_image_method_renders(name):
    if _needs_vulkan(name) and not VULKAN:
        pytest.skip("no Vulkan device (install mesa-vulkan-drivers)")
    img = gl.render(name, "sphere", scale=0.03, seed=3)
    lit = np.isfinite(img)
    assert img.shape[:2] == (32, 58) and lit.mean() > 0.2, name
    assert np.all(img[lit] >= 0) and np.any(img[lit] > 0), name  # an image, not a blank one


def _slug(heading: str) -> str:  # as tests/python/test_doc_references.py reads a heading's anchor
    return re.sub(r"\s+", "-", re.sub(r"[^\w\s-]", "", heading.strip().lower()))


def _section(doc: str) -> str:
    """The text of a documented section (page#anchor): from its label, to the next label, or from its
    heading, to the next heading of its level or above."""
    path, _, anchor = doc.partition("#")
    text = (ROOT / path).read_text()
    if f"({anchor})=" in text:
        start = text.index(f"({anchor})=")
        nxt = re.search(r"^\([\w-]+\)=\s*$", text[start + 1:], flags=re.M)
        return text[start:start + 1 + nxt.start()] if nxt else text[start:]
    heading = next(m for m in re.finditer(r"^(#+)\s+(.*)$", text, flags=re.M) if _slug(m.group(2)) == anchor)
    nxt = re.search(r"^#{1,%d}\s" % len(heading.group(1)), text[heading.end():], flags=re.M)
    return text[heading.start():heading.end() + nxt.start()] if nxt else text[heading.start():]


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_image_method_is_documented(name):
    doc = IMAGE_METHODS.get(name).doc
    assert doc and re.fullmatch(r"docs/[\w/]+\.md#[\w-]+", doc), f"{name}: no doc section declared"
    section = _section(doc)
    # The section names the method (a family `db23_trilinear[law]` by its stem and bracket).
    stem = name.split("[")[0]
    assert f"`{name}`" in section or f"`{stem}[" in section, f"{doc} does not name {name}"


def test_a_method_registered_later_is_in_the_default_panel():
    from glintlab.studies import scene_images as study

    class Late(GlintyNDF):
        def evaluate(self, uv, J, h, seed=0):
            return SmoothNDF(self.target, self.alpha).evaluate(uv, J, h)

    register_image_method("x_late", lambda m: Late(m.target, m.alpha, m.density), label="late")
    register_image_method("x_late_intensity", lambda m: Late(m.target, m.alpha, m.density), returns="intensity")
    register_image_method("x_late_hidden", lambda m: Late(m.target, m.alpha, m.density), panel=False)
    assert "x_late" in panel_methods() and "x_late" in study._names("methods", study.DEFAULTS["methods"])
    assert "x_late_intensity" not in panel_methods() and "x_late_hidden" not in panel_methods()


@pytest.mark.parametrize("name", sorted(SHADERS))
def test_every_shipped_method_shader_has_one_body_and_thin_wrappers(name):
    entry = SHADERS[name]
    body, *wrappers = entry.paths()
    assert body.is_file(), body
    for wrapper in wrappers:
        code = [ln.strip() for ln in wrapper.read_text().splitlines() if ln.strip() and not ln.strip().startswith("//")]
        assert all(ln.startswith(("#include", "#define")) for ln in code), (wrapper, code)
        assert f'#include "{body.name}"' in code, wrapper


@pytest.fixture(scope="module")
def plane_rows():
    # At 0.06 scale the middle column sees u = 0 exactly: the grids at a quarter turn put a cell boundary
    # there (test_counting_shaders.py); a frame where every comparison has thousands of pixels.
    return MT.scene_rows("plane_25", 0.06, seed=5)


@pytest.mark.skipif(not VULKAN, reason="no Vulkan device (install mesa-vulkan-drivers)")
@pytest.mark.parametrize("name", sorted(SHADERS))
def test_every_shipped_method_shader_agrees_with_its_twin_and_rejects_its_wrong_variants(name, plane_rows):
    rows, facets = plane_rows
    entry = SHADERS[name]
    material = dataclasses.replace(facets, density=method_density(name, facets))  # as its image method runs
    ok = entry.compare(rows, material)
    assert 5000 < ok["pixels"] <= rows.shape[0]  # (a comparison may leave out rows its twin does not define)
    assert ok["share"] <= entry.max_share, (name, {k: v for k, v in ok.items() if k != "beyond"})
    wrong = entry.wrong(material)
    assert wrong, f"{name}: its registrant declares no wrong variant"
    for label, method in wrong.items():
        bad = entry.compare(rows, material, method)
        assert bad["share"] > 10 * entry.max_share, (name, label, bad["share"])


# ---------------------------------------------------------------------------------------------- samplers
# Every registered sampler (``gl.samplers()``, the classes ``@register_sampler`` registers), at its
# default parameters: it passes the harness, and the harness rejects every wrong variant it declares
# (``Sampler.wrong_variants``); its pdf is the one it returns with its samples; its doc section names it.
SAMPLER_NAMES = list(gl.samplers())
SAMPLES = 50_000  # the wrong variants fail by far here (alpha + 2 %: its returned pdf is not pdf(x))
# Every sampler's passing run at one Sidak-corrected level: a false failure of the whole list at 1e-3
# (the runs' seed is fixed, so a given tree passes or fails every time).
SAMPLER_ALPHA = gl.sidak_alpha(1e-3, max(len(SAMPLER_NAMES), 1))


def test_the_sampler_registry_holds_every_reference_sampler():
    assert {"beckmann", "ggx", "ggx_vndf", "beckmann_vndf", "vmf_mixture"} <= set(SAMPLER_NAMES)


@pytest.mark.parametrize("name", SAMPLER_NAMES)
def test_every_sampler_passes_and_its_wrong_variants_fail(name):
    s = gl.sampler(name)
    x, pdf = s.sample(2000, seed=1)
    assert len(x) == 2000 and np.all(pdf > 0) and np.allclose(pdf, s.pdf(x), rtol=1e-9, atol=0)
    res = gl.sampler_test(s, samples=SAMPLES, seed=3, significance=SAMPLER_ALPHA)
    assert res.passed, res
    assert s.wrong_variants, f"{name}: its class declares no wrong variant"
    for kind in s.wrong_variants:
        bad = gl.sampler_test(gl.wrong_sampler(s, kind), samples=SAMPLES, seed=3, significance=SAMPLER_ALPHA)
        assert bad.verdict == "FAIL", (name, kind, bad)


@pytest.mark.parametrize("name", SAMPLER_NAMES)
def test_every_sampler_is_documented(name):
    from glintlab.api.samplers import SAMPLERS
    doc = SAMPLERS.get(name).doc
    assert doc and re.fullmatch(r"docs/[\w/]+\.md#[\w-]+", doc), f"{name}: no doc section declared"
    assert f"`{name}`" in _section(doc), f"{doc} does not name {name}"


# Every shader sampler glintlab ships (``SHIPPED_SAMPLERS``): its body and thin wrappers, the same draws
# in both languages, the harness passes it and fails its wrong variants, the shader samplers' section
# names it.
def _shipped_samplers():
    from glintlab.api.shader_samplers import SHIPPED_SAMPLERS
    return sorted(SHIPPED_SAMPLERS)


@pytest.mark.skipif(not VULKAN, reason="no Vulkan device (install mesa-vulkan-drivers)")
@pytest.mark.parametrize("name", _shipped_samplers())
def test_every_shipped_shader_sampler_passes_in_both_languages(name):
    from glintlab.api.shader_samplers import shipped_sampler
    for language in ("hlsl", "glsl"):
        code = [ln.strip() for ln in shipped_sampler(name, language).read_text().splitlines()
                if ln.strip() and not ln.strip().startswith("//")]
        assert all(ln.startswith(("#include", "#define")) for ln in code) and f'#include "{name}_body.h"' in code
    hlsl, glsl = (gl.shader_sampler(shipped_sampler(name, lang)) for lang in ("hlsl", "glsl"))
    x, pdf = hlsl.sample(2000, seed=1)
    np.testing.assert_array_equal(x, glsl.sample(2000, seed=1)[0])
    assert np.allclose(pdf, hlsl.pdf(x), rtol=1e-5)
    assert gl.sampler_test(hlsl, samples=SAMPLES, seed=3, significance=SAMPLER_ALPHA).passed
    for kind in hlsl.wrong_variants:
        assert gl.sampler_test(gl.wrong_sampler(hlsl, kind), samples=SAMPLES, seed=3).verdict == "FAIL", kind
    assert f"`{name}`" in _section("docs/math/sampling.md#shader-samplers")
