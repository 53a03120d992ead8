"""The image viewer of the glint images (glintlab/report/viewer.py, data/report/viewer.js;
docs/guide/scenes.md#the-image-viewer), opened in Debian's headless chromium and driven through its own
controls (clicks, keys, the mouse wheel over the DevTools protocol, tests/python/chromium_cdp.py): the canvas
must show the stored float16 radiance at the chosen exposure and tone curve, pixel for pixel, for every
default image method, flip to the truth while a key is held, show differences in false colour, zoom with
nearest-neighbour pixels and play the camera path's animation with the pops the flicker table counts; no
request may leave the file. A small section (two scenes, 80 x 45 paths, 160 x 90 viewer frames) keeps it
to seconds."""
import json
import re

import numpy as np
import pytest
from chromium_cdp import Browser

import glintlab as gl
from glintlab.report import html as report_html
from glintlab.report import viewer
from glintlab.studies import scene_images as image_study
from glintlab.studies.base import Context
from glintlab.studies.scene_frames import display_bytes, pop_pixels, srgb_encode, tone_curve
from glintlab.validation.scene import table1_scenes
from glintlab.api.glinty_ndf import panel_methods


@pytest.fixture(scope="module")
def section(tmp_path_factory):
    out = tmp_path_factory.mktemp("viewer")
    scenes = [s for s in table1_scenes() if s.name in ("sphere", "plane_25")]
    prm = image_study.command_params(scenes, scale=1 / 24, viewer_scale=1 / 12, timing_scale=1 / 12, frames=3,
                                     aliasing_methods="", sparkle_scene="")
    tables = image_study.compute_scenes(scenes, prm, Context(out, 1))
    page = report_html.scene_images_viewer(tables, out)
    return tables, page


@pytest.fixture(scope="module")
def browser(section):
    _, page = section
    b = Browser(1400, 1000)
    b.open(page.as_uri())
    state(b, "v => v.rendered >= 1")
    yield b
    b.close()


def state(b, until: str = "v => true", timeout: float = 30) -> dict:
    """The viewer's state once the JavaScript predicate ``until`` holds (the canvas carries it as JSON after
    each picture it draws)."""
    return json.loads(b.wait("(() => { const s = document.getElementById('gv-canvas').dataset.state;"
                             f" return s && ({until})(JSON.parse(s)) ? s : null; }})()", timeout))


def shown(b) -> tuple:
    """(the image's pixels as the canvas shows them (H, W, 3), the zoom, the offsets): one canvas pixel per
    image pixel, at the top left of its s x s block."""
    s, ox, oy = (float(v) for v in b.eval("document.getElementById('gv-canvas').dataset.view").split(","))
    W, H = (b.eval(f"(() => {{ const c = JSON.parse(document.getElementById('gv-manifest').textContent).scenes.find("
                   f"d => d.name === JSON.parse(document.getElementById('gv-canvas').dataset.state).scene);"
                   f" return c.{k}; }})()") for k in ("width", "height"))
    assert s == int(s) and ox >= 0 and oy >= 0  # the whole image on the canvas, whole canvas pixels per image pixel
    return b.canvas("#gv-canvas", int(ox), int(oy), int(W * s), int(H * s), int(s))[..., :3], s, ox, oy


def scene_of(page, scene: str) -> dict:
    return next(d for d in viewer.manifest_of(page)["scenes"] if d["name"] == scene)


def stored(page, scene: str, key: str) -> np.ndarray:
    """The radiance of image ``key`` of ``scene`` as the page stores it (decoded here, independently of the
    page's script)."""
    d = scene_of(page, scene)
    return viewer.decode_image(viewer.blob_of(page, d["images"][key]), d["scale_log2"], (d["height"], d["width"]))


def false_colour(method, truth, exposure, tone):
    """The difference mode's colours: |method - truth| x 2^exposure through the tone curve and sRGB, on a
    black-red-yellow-white ramp where the method is brighter and black-blue-cyan-white where darker."""
    d = method - truth
    c = srgb_encode(tone_curve(np.abs(d) * 2.0 ** exposure, tone))
    a, b_, e = (np.floor(255 * np.clip(v, 0, 1) + 0.5) for v in (np.minimum(1, 3 * c), 3 * c - 1, 3 * c - 2))
    return np.where((d > 0)[..., None], np.stack([a, b_, e], -1), np.stack([e, b_, a], -1)).astype(np.uint8)


def assert_matches(got, want, what):
    diff = np.abs(got.astype(int) - want.astype(int))
    assert diff.max() <= 1 and (diff == 0).mean() > 0.999, (what, diff.max(), (diff > 0).mean())


# ------------------------------------------------------------------------------------------- the data

def test_stored_images_are_the_float16_radiance(section):
    tables, page = section
    view = tables["views"]["plane_25"]
    k = viewer.scale_log2(view)
    for key, img in view.images.items():
        back = viewer.decode_image(viewer.encode_image(img, k), k, img.shape)
        assert np.array_equal(back, viewer.stored_half(img, k).astype(np.float64) * 2.0 ** -k)
        # Within 2^-(MANTISSA_BITS + 1) relative, plus float16's own rounding, where float16 is normal.
        normal = np.abs(img) * 2.0 ** k >= 2.0 ** -14
        rel = np.abs(back[normal] - img[normal]) / np.abs(img[normal])
        assert rel.max() <= 2.0 ** -(viewer.MANTISSA_BITS + 1) + 2.0 ** -11, (key, rel.max())
        assert (back[img == 0] == 0).all() and (back[normal] != 0).all()  # no glint lost, none made
    # The smooth lobe sits near 1 after the power of two, inside float16's normal range.
    assert 2 ** -14 < np.percentile(view.images["smooth"][view.images["smooth"] > 0] * 2.0 ** k, 50) < 4


def test_pops_drawn_are_the_pixel_frames_the_table_counts(section):
    tables, _ = section
    flicker = tables["scene_images_flicker"].set_index(["scene", "method"])
    for name, view in tables["views"].items():
        for m in view.path["pop_rate"]:
            assert view.path["pop_rate"][m] == flicker.loc[(name, m), "own_pop_rate"], (name, m)
    # Not blind: KPT25's pops counted against the facets (not its own truth, the reference) are the table's
    # pop_rate, another number.
    path = tables["paths"]["plane_25"]
    pops = pop_pixels("kpt25", path.images["kpt25"], path.images["truth"], path.target, path.mask, 2.0)
    rate = sum(len(p) for p in pops) / tables["views"]["plane_25"].path["valid"] / (path.target.shape[0] - 1)
    assert rate == flicker.loc[("plane_25", "kpt25"), "pop_rate"] != flicker.loc[("plane_25", "kpt25"), "own_pop_rate"]


def test_video_codes_round_trip_within_half_a_code():
    v = np.concatenate([[0.0], 2.0 ** np.linspace(-14, 0, 1000)])
    c = viewer.video_codes(v, -14.0, 0.0)
    assert c[0] == 0 and c[1:].min() >= 1
    back = viewer.video_values(c, -14.0, 0.0)
    assert back[0] == 0 and np.abs(np.log2(back[1:] / v[1:])).max() <= 0.5 * 14 / 254 + 1e-12


def test_the_page_is_one_self_contained_file(section):
    _, page = section
    text = page.read_text()
    assert "Content-Security-Policy" in text and "default-src 'none'" in text
    assert not re.search(r"""(src|href|url)\s*[=(]\s*["']?\s*(https?:|//)""", text, re.I)
    script = (viewer.data_path("report", "viewer.js")).read_text()
    for word in ("fetch(", "XMLHttpRequest", "import(", "WebSocket", "EventSource", "sendBeacon"):
        assert word not in script, word


def test_every_default_method_has_a_tab_and_its_own_truth(section):
    tables, page = section
    for d in viewer.manifest_of(page)["scenes"]:
        assert [c["method"] for c in d["columns"]] == panel_methods()
        assert set(d["images"]) >= set(panel_methods()) | {"truth", "smooth", "kpt25: reference"}
        assert d["video"]["id"] and set(d["video"]["at"]) >= set(panel_methods()) - {"smooth"} | {"kpt25: reference"}


# ------------------------------------------------------------------------------------------- in the browser

def test_canvas_shows_each_method_at_the_exposure_and_tone_chosen(section, browser):
    tables, page = section
    b = browser
    st = state(b)
    sc = scene_of(page, st["scene"])
    e0 = sc["exposure"]
    assert st["mode"] == "image" and st["tone"] == "aces" and st["exposure"] == round(e0, 2)
    before = None
    # Every default method through its tab: the canvas is the stored image at the scene's default exposure.
    for m in panel_methods():
        b.click(f"button[data-method='{m}']")
        st = state(b, f"v => v.method === {json.dumps(m)}")
        got, s, _, _ = shown(b)
        assert s >= 1 and (got[..., 0] == got[..., 1]).all() and (got[..., 1] == got[..., 2]).all()
        assert_matches(got[..., 0], display_bytes(stored(page, sc["name"], m), st["exposure"], "aces"), m)
        if before is not None and m != "smooth":
            assert (got != before).any(), m  # the canvas changed with the method
        before = got
    # The exposure's + button twice: one stop up; the canvas follows.
    b.click("#gv-exp-up")
    b.click("#gv-exp-up")
    st = state(b, f"v => Math.abs(v.exposure - {round(e0, 2) + 1}) < 1e-9")
    got, _, _, _ = shown(b)
    assert (got != before).any()
    assert_matches(got[..., 0], display_bytes(stored(page, sc["name"], "kpt25"), st["exposure"], "aces"), "exposure")
    # The tone curve by its key (t): Reinhard.
    b.key("t", "KeyT", text="t")
    st = state(b, "v => v.tone === 'reinhard'")
    got, _, _, _ = shown(b)
    assert_matches(got[..., 0], display_bytes(stored(page, sc["name"], "kpt25"), st["exposure"], "reinhard"), "tone")
    # Held space: KPT25's own truth (its reference) while held, KPT25 again after.
    b.key(" ", "Space", "down", text=" ")
    st = state(b, "v => v.shown === 'kpt25: reference'")
    got, _, _, _ = shown(b)
    assert_matches(got[..., 0], display_bytes(stored(page, sc["name"], "kpt25: reference"), st["exposure"], "reinhard"),
                   "flip")
    b.key(" ", "Space", "up")
    state(b, "v => v.shown === 'kpt25'")
    # Difference against the facet truth in false colour (d twice: the second mode after the image).
    b.key("d", "KeyD", text="d")
    b.key("d", "KeyD", text="d")
    st = state(b, "v => v.mode === 'diff-facets'")
    got, _, _, _ = shown(b)
    want = false_colour(stored(page, sc["name"], "kpt25"), stored(page, sc["name"], "truth"), st["exposure"], "reinhard")
    assert_matches(got, want, "difference")
    for _ in range(3):  # back to the image (five modes)
        b.key("d", "KeyD", text="d")
    state(b, "v => v.mode === 'image'")


def test_wheel_zooms_to_nearest_neighbour_pixels(browser):
    b = browser
    s0, ox, oy = (float(v) for v in b.eval("document.getElementById('gv-canvas').dataset.view").split(","))
    W, H = (b.eval(f"JSON.parse(document.getElementById('gv-manifest').textContent).scenes[0].{k}") for k in ("width", "height"))
    cx, cy = ox + s0 * W / 2, oy + s0 * H / 2  # the image's centre stays where the wheel turns (device pixel ratio 1)
    for _ in range(3):
        b.wheel("#gv-canvas", cx, cy, -100)
    s, ox, oy = (float(v) for v in b.wait(
        f"(() => {{ const v = document.getElementById('gv-canvas').dataset.view; return +v.split(',')[0] > {s0} ? v : null; }})()"
    ).split(","))
    assert s >= 2 * s0 and s == int(s)
    # Around the centre, each s x s block of canvas pixels is one colour (no smoothing between pixels).
    si = int(s)
    x0, y0 = int(ox + si * (W // 2 - 4)), int(oy + si * (H // 2 - 4))
    block = b.canvas("#gv-canvas", x0, y0, 8 * si, 8 * si)[..., :3].reshape(8, si, 8, si, 3)
    assert (block == block[:, :1, :, :1]).all() and (block != block[0, 0, 0, 0]).any()
    b.click("#gv-fit")


def test_flicker_video_plays_at_the_same_exposure_with_the_pops(section, browser):
    tables, page = section
    b = browser
    b.wait("+(document.getElementById('gv-flicker').dataset.rendered || 0) >= 1")
    b.click("button[data-method='db23_trilinear[gated]']")
    st = state(b, "v => v.method === 'db23_trilinear[gated]'")
    b.click("#gv-next")
    view = b.wait("(() => { const v = document.getElementById('gv-flicker').dataset.view;"
                  " return v.split(',')[4] === '1' ? v : null; })()")
    s, x0, head, gap, _, cx, cy, w, h = (int(float(v)) for v in view.split(","))
    sc = scene_of(page, st["scene"])
    v = sc["video"]
    assert (cx, cy, w, h) == (0, 0, v["width"], v["height"])  # the whole frame at zoom 1
    # The truth's tile (right of the method's): the path's frame 2 of the facet truth through the animation's
    # log encoding (lossless WebP), at the viewer's exposure and tone curve.
    k = sc["scale_log2"]
    truth = tables["views"][sc["name"]].path["tiles"]["truth"][1]
    want = display_bytes(viewer.video_values(viewer.video_codes(truth * 2.0 ** k, v["lo"], v["hi"]), v["lo"], v["hi"])
                         * 2.0 ** -k, st["exposure"], st["tone"])
    got = b.canvas("#gv-flicker", x0 + w * s + gap, head, w * s, h * s, s)[..., 0]
    assert_matches(got, want, "the path's frame 2")
    # The method's tile: red exactly on the pixels where the table counts a pop between frames 1 and 2.
    tile = b.canvas("#gv-flicker", x0, head, w * s, h * s, s)[..., :3].astype(int)
    red = (tile[..., 0] - tile[..., 1] > 100) & (tile[..., 0] - tile[..., 2] > 100)
    path = tables["paths"][sc["name"]]
    pops = pop_pixels("db23_trilinear[gated]", path.images["db23_trilinear[gated]"], path.images["truth"],
                      path.target, path.mask, 2.0)[0]
    assert len(pops) > 0 and np.array_equal(np.flatnonzero(red), pops)
    # Play: the frame advances by itself; pause stops it.
    b.click("#gv-play")
    b.wait("document.getElementById('gv-flicker').dataset.view.split(',')[4] !== '1'")
    b.click("#gv-play")


def test_no_request_leaves_the_file_and_nothing_failed(section, browser):
    _, page = section
    b = browser
    assert b.requests and b.requests[0] == page.as_uri()
    assert all(u == page.as_uri() or u.startswith(("blob:", "data:")) for u in b.requests), b.requests
    assert b.errors == []


def test_a_request_out_of_the_file_would_be_seen(section, tmp_path):
    # Not blind: an image from outside shows as a request to http and an error, with the page's policy
    # (which blocks it) and without (port 9 is refused).
    _, page = section
    text = page.read_text().replace("<main id='gv'></main>", "<main id='gv'></main><img src='http://127.0.0.1:9/x.png'>")
    for name, html in (("csp", text), ("open", re.sub(r"<meta http-equiv='Content-Security-Policy'[^>]*>", "", text))):
        bad = tmp_path / f"{name}.html"
        bad.write_text(html)
        b = Browser(800, 600)
        try:
            b.open(bad.as_uri())
            state(b, "v => v.rendered >= 1")
            outside = [u for u in b.requests if not (u == bad.as_uri() or u.startswith(("blob:", "data:")))]
            assert outside == ["http://127.0.0.1:9/x.png"] and b.errors, (name, b.errors)
            assert ("Content Security Policy" in b.errors[0]) == (name == "csp"), b.errors
        finally:
            b.close()


@pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")
def test_images_command_writes_the_viewer_with_a_users_method(tmp_path):
    from glintlab.api.glinty_ndf import IMAGE_METHODS
    from glintlab.cli.main import main
    from glintlab.resources import data_path
    mine = tmp_path / "mine.hlsl"
    mine.write_text("float glint(GlintInput g) { return frac(g.uv.x * 7.0) < 0.1 ? 1.0 : 0.0; }\n")
    try:
        assert main(["images", str(data_path("scenes", "plane_90.json")), "--scale", "0.03", "--frames", "2",
                     "--timing-scale", "0.03", "--quiet", "--method", str(mine), "--out", str(tmp_path / "a")]) == 0
    finally:
        IMAGE_METHODS._items.pop("mine", None)
    m = viewer.manifest_of(tmp_path / "a" / "scene_images.html")
    d = m["scenes"][0]
    assert [c["method"] for c in d["columns"]] == ["truth", "smooth", "mine"]
    assert {"mine", "mine: supersampled"} <= set(d["images"]) and "mine" in d["video"]["at"]
