"""gl.light_response: a method's image moved with the light and the view beside its truth's, and its
mean D across the lobe against D(h) (docs/math/glint_images.md#glint-light-response). The shipped NDF
methods pass; the deliberately wrong variants (h read as one float, only the angular texel read so, a
lobe 1.3 times too wide), in Python and as method shaders a user would write, fail, each on the check
meant to catch it. Seed 1 throughout (the false-failure rates: the docs' section)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.glinty_ndf import IMAGE_METHODS, register_image_method
from glintlab.cli.main import main
from glintlab.resources import data_path
from glintlab.studies import scene_images as study
from glintlab.studies.base import Context
from glintlab.validation import light_response as LR
from glintlab.validation.scene import table1_scenes

needs_vulkan = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")
SHADERS = Path(__file__).parent / "data" / "light_response"


@pytest.fixture(scope="module")
def sphere():
    return LR.response_setup("sphere", seed=1)


def _failed(r, prefix):
    c = r.checks[r.checks.check.str.startswith(prefix)]
    return int((c.applies & ~c.passed).sum())


# kpt25_shader: its float32 compensation was negative on 2 of the sphere's 1114 pixels before it was
# written as a sum (docs/math/glint_images.md#glint-kpt25-shader): the output check failed.
@pytest.mark.parametrize("name", ["truth", "db23_trilinear[gated]", "db23_shader_48[gated]", "zk16", "kpt25",
                                  pytest.param("kpt25_shader", marks=needs_vulkan)])
def test_shipped_ndf_methods_pass(sphere, name):
    r = gl.light_response(name, "sphere", setup=sphere)
    assert r.passed, r.notes
    # Checked, not skipped: the truth decorrelates along t and b (KPT25's reference, whose lobes move
    # smoothly, may not reach TRUTH_RESPONDS along n), and every checked slope of the lobe has its pixels.
    c = r.checks.set_index("check")
    assert all(c.applies[f"{m} along {a}"] for m in ("light", "view") for a in ("t", "b"))
    assert c.applies[c.index.str.startswith("lobe along")].sum() == 7
    assert set(r.table.move) == {"light", "view"} and set(r.table.axis) == {"t", "b", "n"}
    assert {"method_r", "truth_r", "offset"} <= set(r.table.columns)
    assert np.isfinite(r.lobe.ratio).all()


def test_a_method_without_glints_is_not_read_as_ignoring_h(sphere):
    r = gl.light_response("smooth", "sphere", setup=sphere)
    assert r.passed and not r.checks[~r.checks.check.str.startswith("lobe")].applies.any()
    assert any("no glints" in n for n in r.notes)


def _variant(label):
    def factory(material):
        return LR.wrong_variants(material)[label]
    return factory


def test_h_read_as_one_float_fails_both_checks(sphere):
    r = gl.light_response(_variant("h read as (h.x, h.x, h.x)"), "sphere", setup=sphere)
    assert not r.passed
    assert _failed(r, "light along b") == 1 and _failed(r, "view along b") == 1
    assert _failed(r, "lobe along") >= 4


def test_a_texel_read_from_one_float_fails_the_decorrelation_only(sphere):
    """The engine port's bug where D(h) is right: its mean follows the lobe, its glints never move."""
    r = gl.light_response(_variant("angular texel read from (h.x, h.x, h.x)"), "sphere", setup=sphere)
    assert not r.passed
    assert _failed(r, "light along") == 3 and _failed(r, "view along") == 3
    assert _failed(r, "lobe along") == 0


def test_a_lobe_of_the_wrong_width_fails_the_lobe(sphere):
    r = gl.light_response(_variant(f"lobe {LR.WIDE_LOBE:g} x too wide"), "sphere", setup=sphere)
    assert not r.passed and _failed(r, "lobe along") >= 2
    assert any("shape is not the target's" in n for n in r.notes)


@needs_vulkan
def test_user_method_shaders_correct_port_passes_and_wrong_ones_fail(sphere):
    """The three method shaders of tests/python/data/light_response as a user passes them (by name, so
    that each scene material compiles its own): the correct DB23 port passes; the one-float half vector
    fails both checks; the wide lobe fails the lobe."""
    names = []
    try:
        for stem in ("db23_port", "hx_bug", "wide_lobe"):
            names.append(gl.shader_method(SHADERS / f"{stem}.glsl", returns="ndf").name)
        port, hx, wide = (gl.light_response(n, "sphere", setup=sphere) for n in names)
        assert port.passed, port.notes
        assert not hx.passed and _failed(hx, "light along b") == 1 and _failed(hx, "lobe along") >= 4
        assert not wide.passed and _failed(wide, "lobe along") >= 2
    finally:
        for n in names:
            IMAGE_METHODS._items.pop(n, None)


@needs_vulkan
def test_a_user_ndf_shader_object_is_compiled_for_each_material(sphere):
    """gl.shader_method(..., returns="ndf") returns the method for one material (the sphere file's density);
    light_response compiles it for each of its two scenes' materials, as its registered name would be: the
    object and the name give the same curves (an object used as built would run at 1/16 x scale^-2 the
    facets per pixel of the truth's, and read its glints wrongly)."""
    obj = gl.shader_method(SHADERS / "wide_lobe.glsl", returns="ndf", register=False)
    assert obj.spirv  # compiled before use: its spec now carries its #included files' bytes
    try:
        by_name = gl.light_response(gl.shader_method(SHADERS / "wide_lobe.glsl", returns="ndf").name, "sphere",
                                    setup=sphere)
        by_object = gl.light_response(obj, "sphere", setup=sphere)
        assert by_object.table.equals(by_name.table) and by_object.lobe.equals(by_name.lobe)
        assert not by_object.passed and _failed(by_object, "light along") == 0
    finally:
        IMAGE_METHODS._items.pop("wide_lobe", None)


@needs_vulkan
def test_an_intensity_method_is_reported_not_checked(sphere):
    r = gl.light_response("wb16", "sphere", setup=sphere)
    assert r.passed and not r.checks.applies.any() and r.lobe is None
    assert len(r.table) == 2 * 3 * LR.STEPS
    assert any("no target NDF" in n for n in r.notes)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="^step = "):
        gl.light_response("truth", "sphere", step=0.5, steps=3)
    with pytest.raises(ValueError, match="^moves = "):
        gl.light_response("truth", "sphere", moves=("light", "sun"))
    with pytest.raises(ValueError, match="^scale = "):
        gl.light_response("truth", "sphere", scale=0)
    with pytest.raises(ValueError, match="^method = "):
        gl.light_response(42, "sphere")
    with pytest.raises(ValueError, match="^scene = "):
        gl.light_response("truth", "no_such_scene")


def test_same_seed_same_result(sphere):
    a = gl.light_response("db23_trilinear[gated]", "sphere", setup=sphere)
    b = gl.light_response("db23_trilinear[gated]", "sphere", setup=LR.response_setup("sphere", seed=1))
    assert a.table.equals(b.table) and a.lobe.equals(b.lobe)


@needs_vulkan
def test_images_command_fails_a_method_that_ignores_a_component_of_h(tmp_path, capsys):
    """`glintlab images --method FILE` runs the light response on every method it renders: the correct port
    exits 0 with its row in scene_images_light_response.csv; the one-float half vector exits 1 naming it."""
    scene = str(data_path("scenes", "plane_90.json"))
    common = [scene, "--scale", "0.03", "--frames", "2", "--timing-scale", "0.03", "--quiet", "--method-returns", "ndf"]
    try:
        assert main(["images", *common, "--method", str(SHADERS / "db23_port.glsl"), "--out", str(tmp_path / "a")]) == 0
        assert "db23_port" in (tmp_path / "a" / "scene_images_light_response.csv").read_text()
        assert main(["images", *common, "--method", str(SHADERS / "hx_bug.glsl"), "--out", str(tmp_path / "b")]) == 1
        err = capsys.readouterr().err
        assert "FAIL light response of hx_bug on plane_90" in err and "light along b" in err
    finally:
        for n in ("db23_port", "hx_bug"):
            IMAGE_METHODS._items.pop(n, None)


def test_the_section_reports_a_failing_method_as_a_failure(tmp_path):
    """The scene_images section's light response: a registered method that reads h as one float becomes one
    of the section's failures (the report exits 1), the shipped truth does not."""
    name = "x_one_float_h"
    register_image_method(name, _variant("h read as (h.x, h.x, h.x)"), panel=False)
    try:
        scenes = [s for s in table1_scenes() if s.name == "sphere"]
        params = {**study.DEFAULTS, **study.QUICK}
        stats, tables = {}, {}
        extra, failures = study._light_response(scenes, ["truth", name], params, Context(tmp_path, 1), stats, tables)
        summary = tables["scene_images_light_response"]
        assert list(summary.passed) == [True, False]
        assert len(failures) == 1 and name in failures[0] and "light along b" in failures[0]
        assert set(extra) == {"scene_images_light_curves", "scene_images_lobe_sweep"}
        assert "1 of 2" in next(v for k, v in stats.items() if k.startswith("light response"))
    finally:
        IMAGE_METHODS._items.pop(name, None)


def test_wwh18_keeps_its_glints_in_place_and_the_note_says_why(sphere):
    """WWH18 fails the decorrelation by its model's design, not by a port's bug: its flakes' lambda is
    fixed whatever the directions (docs/math/wwh18.md#wwh18-light); the note names that cause."""
    r = gl.light_response("wwh18", "sphere", setup=sphere)
    c = r.checks.set_index("check")
    assert not r.passed and not c.passed["light along t"] and c.value["light along t"] < 0.01
    failed = [n for n in r.notes if n.startswith(("light along", "view along")) and "FAIL" in n]
    assert failed and all("by its model's design" in n and "wwh18-light" in n for n in failed), failed
    # The deliberately wrong one-float variant fails without that note: its cause is a bug.
    bad = gl.light_response(_variant("h read as (h.x, h.x, h.x)"), "sphere", setup=sphere)
    assert any("ignores this component of h" in n for n in bad.notes)
