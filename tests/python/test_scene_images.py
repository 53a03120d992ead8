"""Glint images of the scenes (docs/math/glint_images.md): the facet ground truth against a brute-force
count, the image methods' common signature and registry, determinism, the camera path, and the flicker
metric on synthetic sequences whose answers are known."""
import json
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.glinty_ndf import DB23
from glintlab.api.image_ndfs import FacetNDF, SmoothNDF, facet_counts
from glintlab.studies import scene_images as study
from glintlab.studies.base import Context
from glintlab.validation import scene_images as si
from glintlab.validation.scene import table1_scenes
from glintlab.cli.main import main

SEED = 7


def test_facet_counts_match_an_independent_count_of_the_same_facets():
    # p = 1: every facet counts, and the stratified layout's mean is exactly N P; p = 0: none; one uniform
    # per facet makes K monotone in p.
    N = 400.0
    rng = np.random.default_rng(1)
    m = 4000
    uv = rng.uniform(-3, 3, size=(m, 2))
    a, b = rng.uniform(0.05, 0.4, m), rng.uniform(0.05, 0.4, m)
    th = rng.uniform(0, np.pi, m)
    J = np.stack([a * np.cos(th), a * np.sin(th), -b * np.sin(th), b * np.cos(th)], axis=1)
    P = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    K1, st, tested = facet_counts(uv, J, 1.0, N, seed=SEED)
    assert (st == 0).all() and (tested >= K1).all()
    # Stratified facets: E[K] = N P exactly (each cell contributes its covered fraction).
    resid = K1 - N * P
    z = resid.mean() / (resid.std() / math.sqrt(m))
    assert abs(z) < 4, z
    # Stratification: the variance about N P is far below Poisson's N P.
    assert (resid ** 2).mean() < 0.5 * (N * P).mean()
    K0, _, _ = facet_counts(uv, J, 0.0, N, seed=SEED)
    assert (K0 == 0).all()
    Kh, _, _ = facet_counts(uv, J, 0.5, N, seed=SEED)
    Kq, _, _ = facet_counts(uv, J, 0.25, N, seed=SEED)
    assert (Kq <= Kh).all() and (Kh <= K1).all()  # one uniform per facet: monotone in p
    assert abs(Kh.sum() / K1.sum() - 0.5) < 0.02


def test_facet_counts_equal_a_brute_force_sum_over_recovered_facets():
    # Recover the facets' positions from the layout itself with tiny disk footprints on a fine lattice
    # covering [0, 1)^2 (each facet is found by the probes that contain it), then count a large tilted
    # ellipse by brute force over those positions: it must agree with facet_counts.
    N = 64.0  # cells of side 1/8
    c = 1 / 8
    probe = c / 64
    xs = np.arange(0, 1, probe * 1.2) + probe * 0.6
    gx, gy = np.meshgrid(xs, xs)
    uv = np.stack([gx.ravel(), gy.ravel()], axis=1)
    r = probe * 0.6 * math.sqrt(2) * 1.01  # the disks cover the lattice's gaps
    s = r * math.sqrt(math.pi)              # J = s I: a disk of radius s / sqrt(pi) = r
    K, _, _ = facet_counts(uv, np.tile([s, 0, 0, s], (len(uv), 1)), 1.0, N, seed=SEED)
    facets = {}
    for q in uv[K > 0]:
        i, j = (int(v) for v in np.floor(q / c))
        if 0 <= i < 8 and 0 <= j < 8:
            facets.setdefault((i, j), []).append(q)
    assert len(facets) == 64  # one facet per cell
    pos = np.array([np.mean(v, axis=0) for v in facets.values()])
    for a, b, t, centre in ((0.3, 0.15, 0.4, (0.5, 0.5)), (0.2, 0.05, 2.0, (0.45, 0.52)), (0.1, 0.1, 0.0, (0.3, 0.6))):
        Jb = np.array([[a * math.cos(t), a * math.sin(t), -b * math.sin(t), b * math.cos(t)]]) * math.sqrt(math.pi)
        Kb = facet_counts(np.array([centre]), Jb, 1.0, N, seed=SEED)[0][0]
        A = np.array([[Jb[0, 0], Jb[0, 2]], [Jb[0, 1], Jb[0, 3]]])
        y2 = (np.linalg.solve(A, (pos - np.array(centre)).T) ** 2).sum(0) * math.pi
        # Positions are known to within a probe radius: facets within 3 % of the boundary may go either way.
        assert (y2 <= 0.97**2).sum() <= Kb <= (y2 <= 1.03**2).sum()
        assert Kb > 0


def test_same_seed_same_image_whatever_the_threads_and_bad_input_refused():
    sc = table1_scenes()[2]  # plane_25
    small = si.with_directional_light(sc.scaled(1 / 24, keep_n=True))
    inp = si.frame_inputs(small)
    mat = si.Material.of(small)
    before = gl.get_num_threads()
    out = {}
    try:
        for threads in (1, 2):
            gl.set_num_threads(threads)
            out[threads] = {m: si.render(si.make_method(m, mat), inp, seed=3) for m in ("truth", "db23_trilinear[gated]")}
    finally:
        gl.set_num_threads(before)
    for m in out[1]:
        assert np.array_equal(out[1][m], out[2][m]), m
    assert out[1]["truth"].max() > 0
    f = FacetNDF(1e4)
    uv, J, h = np.zeros((1, 2)), np.array([[0.01, 0, 0, 0.01]]), np.array([[0, 0, 1.0]])
    with pytest.raises(ValueError, match="density"):
        FacetNDF(-1.0)
    with pytest.raises(ValueError, match="R = 2"):
        FacetNDF(1e4, R=2)
    with pytest.raises(ValueError, match="angular_texel"):
        FacetNDF(1e4, angular_texel=0)
    with pytest.raises(ValueError, match="scheme"):
        gl.glinty_ndf("db23", density=1e4, scheme="nope")
    with pytest.raises(ValueError, match="ndf"):
        SmoothNDF("phong", 0.5)
    with pytest.raises(ValueError, match="J = "):
        f.evaluate(uv, np.zeros((1, 3)), h)
    with pytest.raises(ValueError, match=r"h\[0\] = \(0\.0, 0\.0, 0\.0\)"):  # one contract: tests/python/test_pixel_inputs.py
        f.evaluate(uv, J, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="seed"):
        f.evaluate(uv, J, h, seed=-1)
    with pytest.raises(ValueError, match="p\\[0\\]"):
        facet_counts(uv, J, 1.5, 1e4)
    with pytest.raises(ValueError, match="frames"):
        si.camera_path(sc, 1)
    with pytest.raises(ValueError, match="zoom"):
        si.camera_path(sc, 4, zoom=0)
    with pytest.raises(ValueError, match="unknown image method 'nope'"):
        si.make_method("nope", mat)
    with pytest.raises(ValueError, match="tau"):
        si.flicker_metrics(np.zeros((2, 2, 2)), np.zeros((2, 2, 2)), np.ones((2, 2, 2)), tau=-1)


def test_methods_share_the_glinty_ndf_signature_and_converge_to_the_target():
    # Every registered method maps (uv, J, h, seed) to one value per pixel; at high density the counting
    # methods' mean over many pixels is D(h) (tetrahedral: its known over-count, docs/math/grids.md).
    rng = np.random.default_rng(2)
    m = 3000
    uv = rng.uniform(0, 50, size=(m, 2))
    J = np.tile([0.02, 0.0, 0.0, 0.02], (m, 1))
    h = np.tile([0.3, 0.1, 1.0], (m, 1))
    mat = si.Material(density=1e6, target="beckmann", alpha=0.5, R=0.5)
    D = gl.ndf("beckmann", 0.5).D(1 / np.linalg.norm([0.3, 0.1, 1.0]))
    for name in si.image_methods(returns="ndf"):
        ev = si.make_method(name, mat)
        v = ev.evaluate(uv, J, h, seed=1)
        assert v.shape == (m,), name
        # A grid scheme's expected count is its mean_bias times N P (the tetrahedral over-count, the
        # shader's log LOD weights: docs/math/grids.md#grid-mean); the truth and the smooth NDF have none.
        bias = ev.counter.mean_bias(mat.density, 4e-4, 1.0, 0.0) if isinstance(ev, DB23) else 1.0
        tol = 0.03
        if name == "wwh18":
            # WWH18 converges to its own truth's exact mean p_gamma(h) / (sigma(gamma) h.n) (docs/math/wwh18.md),
            # not D(h); its table's P is 3.7 % below p_gamma here and Table 2's 10-degree blur takes 3 % more
            # (measured 0.932 of the exact mean at seed 1): 10 % allowed. The printed threshold test gives 30x.
            bias = float(ev.cone_mass(h[:1])[0] / (ev.cone_solid_angle * h[0, 2] / np.linalg.norm(h[0])) / D)
            tol = 0.10
        assert abs(v.mean() / (D * bias) - 1) < tol, (name, v.mean() / D, bias)
    assert si.make_method("truth", mat).evaluate(uv, J, h, seed=1).std() < 0.1 * D  # n p = 200


def test_registry_adds_a_method_as_one_entry():
    name = "test_constant"
    si.register_image_method(name, lambda m: SmoothNDF(m.target, m.alpha), label="constant")
    try:
        path = si.render_path(table1_scenes()[1].scaled(1 / 24, keep_n=True), ["truth", name], frames=3)
        assert set(path.images) == {"truth", name} and path.images[name].shape == path.target.shape
        assert np.allclose(path.images[name], path.target)
    finally:
        si.IMAGE_METHODS._items.pop(name)
    with pytest.raises(ValueError, match="already registered"):
        si.register_image_method("truth", lambda m: None)


def test_camera_path_pans_sub_pixel_then_zooms():
    sc = table1_scenes()[0]
    path = si.camera_path(sc, 6, pan_px=0.25, zoom=0.9)
    pos = np.array([c.position for c in path])
    step = np.linalg.norm(pos[1] - pos[0])
    dist = np.linalg.norm(np.array(sc.spec["camera"]["look_at"]) - sc.position)
    assert step == pytest.approx(0.25 * dist / sc.focal)
    d = [np.linalg.norm(np.array(c.spec["camera"]["look_at"]) - c.position) for c in path]
    assert d[3] == pytest.approx(d[0]) and d[4] == pytest.approx(0.9 * d[0]) and d[5] == pytest.approx(0.81 * d[0])


# ---- the flicker metric on synthetic sequences

def _seq(T=5, H=4, W=5):
    return np.zeros((T, H, W)), np.ones((T, H, W))


def test_flicker_identical_sequences_have_ratio_one_and_no_pops():
    rng = np.random.default_rng(3)
    truth = rng.exponential(size=(6, 8, 8)) * (rng.uniform(size=(6, 8, 8)) < 0.2)
    r = si.flicker_metrics(truth, truth, np.ones_like(truth))
    assert r["std_ratio"] == 1 and r["pop_rate"] == 0 and r["change_rate"] == r["truth_change_rate"] > 0


def test_flicker_std_ratio_is_the_known_amplitude_ratio():
    T = 8
    wave = np.sin(np.arange(T) * 0.9)[:, None, None] * np.ones((T, 3, 3))
    truth, method = 1 + 0.5 * wave, 1 + 1.5 * wave
    r = si.flicker_metrics(method, truth, np.ones_like(truth))
    assert r["std_ratio"] == pytest.approx(3.0)


def test_flicker_counts_pops_exactly():
    zeros, target = _seq()
    T, H, W = zeros.shape
    method = zeros.copy()
    method[::2, 1, 2] = 5.0  # one pixel toggles every frame: T - 1 changes, none in the truth
    r = si.flicker_metrics(method, zeros, target)
    assert r["pop_rate"] == pytest.approx((T - 1) / (H * W * (T - 1)))
    assert r["appear_rate"] == pytest.approx(2 / (H * W * (T - 1)))  # frames 1->2, 3->4
    assert r["disappear_rate"] == pytest.approx(2 / (H * W * (T - 1)))
    # The same changes in the truth are caused: not pops (a metric that ignored the truth fails here).
    r2 = si.flicker_metrics(method, method.copy(), target)
    assert r2["pop_rate"] == 0 and r2["change_rate"] == r["change_rate"]
    # A change next to a truth change is a pop at radius 0 and caused at radius 1.
    truth = zeros.copy()
    truth[::2, 1, 3] = 5.0
    assert si.flicker_metrics(method, truth, target)["pop_rate"] == r["pop_rate"]
    assert si.flicker_metrics(method, truth, target, radius=1)["pop_rate"] == 0
    # Below tau x D(h) nothing is a glint: a faint pixel that flickers does not pop.
    faint = zeros.copy()
    faint[::2, 1, 2] = 1.5
    assert si.flicker_metrics(faint, zeros, target)["pop_rate"] == 0


def test_flicker_metric_detects_a_wrong_sequence():
    # A method equal to the truth except for pops injected at known places: the metric finds exactly those.
    rng = np.random.default_rng(4)
    T, H, W = 7, 10, 12
    truth = 3.0 * (rng.uniform(size=(T, H, W)) < 0.1)
    target = np.ones_like(truth)
    wrong = truth.copy()
    where = [(2, 1, 1), (4, 5, 7), (5, 9, 11)]
    expected = 0
    for t, y, x in where:
        wrong[t, y, x] = 3.0 - wrong[t, y, x]  # flip one frame: two changes, unless the truth flips there too
        for a, b in ((t - 1, t), (t, t + 1)):
            if 0 <= a and b < T and (truth[a, y, x] > 2) == (truth[b, y, x] > 2):
                expected += 1
    r = si.flicker_metrics(wrong, truth, target)
    assert r["pop_rate"] * H * W * (T - 1) == pytest.approx(expected) and expected >= 3
    assert si.flicker_metrics(truth, truth, target)["pop_rate"] == 0


def test_render_path_on_a_scene_gives_flicker_rows():
    sc = table1_scenes()[0].scaled(1 / 24, keep_n=True)  # sphere, 80 x 45
    path = si.render_path(sc, ["truth", "smooth", "db23_trilinear[gated]", "zk16"], frames=4, seed=2)
    t = si.flicker_table(path)
    assert list(t.method) == ["truth", "smooth", "db23_trilinear[gated]", "zk16"]
    row = t.set_index("method")
    assert row.loc["truth", "std_ratio"] == 1 and row.loc["truth", "pop_rate"] == 0
    assert row.loc["smooth", "glint_share"] == 0
    assert path.mask.any(axis=(1, 2)).all() and np.isfinite(path.images["truth"]).all()
    # The glints' mean follows the target (clamped p aside): within 20 % on this small image.
    assert 0.8 < row.loc["db23_trilinear[gated]", "mean_ratio"] < 1.25


def test_report_page_opens_on_the_first_sections_picture(tmp_path):
    from glintlab.report.config import load_config
    from glintlab.report.html import write_report_page
    doc, _ = load_config(None)
    assert doc["sections"][0]["name"] == "scene_images"
    rec = {"title": "t", "meaning": "m", "stats": {"a": 1}, "failures": [], "params": {}, "seed": 1, "seconds": 1,
           "command": "c", "notebook": "", "tables": {}}
    records = [{**rec, "name": "scene_images", "figures": ["scene_images.png"]},
               {**rec, "name": "exact_laws", "figures": ["sampler_vs_exact.png"]}]
    summary = {"glintlab_version": "0", "command": "c", "config": "d", "seed": 1, "quick": True, "failures": []}
    page = write_report_page(tmp_path, summary, records).read_text()
    first_img, toc = page.index('<img src="scene_images.png"'), page.index("<ol class='toc'>")
    assert first_img < toc < page.index('<img src="sampler_vs_exact.png"')
    assert first_img < page.index("<ul class='stats'>")  # the picture before the numbers


def test_images_command_writes_figures_and_refuses_bad_input(tmp_path, capsys):
    from glintlab.cli.main import main
    scene = "sphere"  # a shipped scene's name, as gl.render takes it (before: "no such file")
    out = tmp_path / "img"
    assert main(["images", scene, "--scale", "0.04", "--frames", "3", "--timing-scale", "0.04", "--quiet",
                 "--methods", "truth,db23_tetrahedral[head_cf]", "--out", str(out)]) == 0
    for name in ("scene_images.png", "scene_images_flicker.png", "scene_images.html",
                 "scene_images_flicker.csv", "scene_images_timing.csv"):
        assert (out / name).stat().st_size > 0, name
    assert main(["images", scene, "--methods", "truth,nope", "--quiet", "--out", str(out)]) == 2
    assert "methods = 'truth,nope'" in capsys.readouterr().err
    assert main(["images", scene, "--zoom", "5", "--quiet", "--out", str(out)]) == 2
    assert "zoom = 5.0" in capsys.readouterr().err
    assert main(["images", "sphre", "--quiet", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "scene = 'sphre' is invalid" in err and "plane_25" in err and "sphere" in err


def test_one_scene_resolution_for_render_and_the_command(tmp_path, monkeypatch):
    from glintlab.resources import data_path
    by_name, by_path = si.resolve_scene("plane_25"), si.resolve_scene(data_path("scenes", "plane_25.json"))
    assert by_name.spec == by_path.spec and by_name.name == by_path.name
    mine = tmp_path / "plane_25"  # a file of that name wins over the shipped scene
    mine.write_text(json.dumps({**by_path.spec, "name": "mine"}))
    monkeypatch.chdir(tmp_path)
    assert si.resolve_scene("plane_25").name == "mine"
    with pytest.raises(ValueError, match="shipped scene's name"):
        gl.render("smooth", "no_such_scene")


def test_render_builds_only_the_camera_it_renders(monkeypatch):
    """gl.render(frames=F) built all F cameras of the path (deep copies and scenes) to render one."""
    sc = table1_scenes()[0].scaled(1 / 40, keep_n=True)
    for k in range(6):  # camera_at is camera_path's camera, bit for bit
        assert si.camera_at(sc, 6, k, 0.25, 0.9).spec == si.camera_path(sc, 6, 0.25, 0.9)[k].spec
    built = []  # every camera of a path is a deep copy of the scene's document
    real_deepcopy = si.copy.deepcopy

    def counting_deepcopy(*args, **kwargs):
        built.append(1)
        return real_deepcopy(*args, **kwargs)

    monkeypatch.setattr(si.copy, "deepcopy", counting_deepcopy)
    img = gl.render("smooth", sc, frame=3, frames=100_000)
    assert len(built) <= 3 and np.isfinite(img).any()  # the light, the camera: not 100,000 copies
    monkeypatch.undo()
    assert np.array_equal(img, gl.render("smooth", sc, frame=3, frames=100_000), equal_nan=True)
    with pytest.raises(ValueError, match="frame = 99999 is invalid; expected a frame whose camera has not reached"):
        gl.render("smooth", sc, frame=99_999, frames=100_000)


@pytest.mark.parametrize("viewer_scale", [1.0, 1.5])  # the viewer's frames from the path, or rendered apart
def test_scenes_rendered_two_at_once_are_those_rendered_one_by_one(monkeypatch, viewer_scale):
    scenes = [s.scaled(1 / 40, keep_n=True) for s in table1_scenes()[:4]]
    methods = ["truth", "smooth", "db23_trilinear[gated]", "kpt25"]
    params = {**study.DEFAULTS, "scale": 1.0, "viewer_scale": viewer_scale, "frames": 3,
              "timing_scene": scenes[1].name}
    ctx = Context(".", 3)
    assert study._scene_threads(methods) == 2 and study._scene_threads(methods + ["wb16"]) == 1
    together = study.scenes_rendered(scenes, methods, params, ctx)
    monkeypatch.setattr(study, "SCENE_THREADS", 1)
    alone = {s.name: study.scenes_rendered([s], methods, params, ctx)[s.name] for s in scenes}
    assert list(together) == [s.name for s in scenes]  # the scenes' order, the timing scene's included
    for name, (path, flicker, view) in together.items():
        path1, flicker1, view1 = alone[name]
        assert path.scene == view.name == name and view.width == round(path.target.shape[2] * viewer_scale)
        assert view.path["frames"] == 3 and set(view.path["tiles"]) == set(view1.path["tiles"])
        for key, tiles in view.path["tiles"].items():
            assert np.array_equal(tiles, view1.path["tiles"][key]), (name, key)
        for m in methods:
            assert np.array_equal(path.images[m], path1.images[m]), (name, m)
        assert np.array_equal(path.truths["kpt25"], path1.truths["kpt25"]), name
        assert set(view.images) == set(view1.images)
        for key in view.images:
            assert np.array_equal(view.images[key], view1.images[key]), (name, key)
        cols = [c for c in flicker.columns if "second" not in c]
        assert flicker[cols].equals(flicker1[cols]), name
        assert path.images["truth"].max() > 0, name


def test_highlight_look_puts_the_mirror_direction_at_the_image_centre():
    for sc in table1_scenes():
        assert study.with_look(sc, "files", 0.3) is sc  # the report's default: the files' light and material
        lit = study.with_look(sc.scaled(1 / 40), "highlight", 0.3)
        assert lit.spec["material"]["alpha"] == 0.3 and lit.light["type"] == "directional"
        if sc.kind == "heightfield":
            continue  # mirrored about the base plane: the waves tilt the shading normal
        # The centre ray's half vector is the shading normal: the smooth lobe peaks there (away from grazing).
        tr = lit.trace(np.array([lit.width / 2]), np.array([lit.height / 2]))
        view = lit.position - tr["x"][0]
        h = view / np.linalg.norm(view) + np.asarray(lit.light["direction"])
        assert np.allclose(h / np.linalg.norm(h), tr["shading_normal"][0], atol=1e-12), sc.name
        # The file's light (a point light beside the camera) is not that direction: the check can fail.
        d = np.asarray(sc.light["position"], float) - tr["x"][0]
        h_file = view / np.linalg.norm(view) + d / np.linalg.norm(d)
        assert not np.allclose(h_file / np.linalg.norm(h_file), tr["shading_normal"][0], atol=1e-3), sc.name
    with pytest.raises(ValueError, match="look = 'shiny'"):
        study.with_look(sc, "shiny", 0.3)
    with pytest.raises(ValueError, match="highlight_alpha = 1.5"):
        study.with_look(sc, "highlight", 1.5)


def test_images_command_passes_the_look_to_the_section(monkeypatch, tmp_path):
    seen = {}

    def fake_compute(scenes, params, ctx):
        seen.update(params)
        raise SystemExit(0)  # the wiring is what is tested: stop before any rendering
    monkeypatch.setattr(study, "compute_scenes", fake_compute)
    with pytest.raises(SystemExit):
        main(["images", "plane_25", "--look", "highlight", "--highlight-alpha", "0.2", "--out", str(tmp_path)])
    assert seen["look"] == "highlight" and seen["highlight_alpha"] == 0.2
    with pytest.raises(SystemExit):
        main(["images", "plane_25", "--out", str(tmp_path)])
    assert seen["look"] == "files"  # the default: the report's
