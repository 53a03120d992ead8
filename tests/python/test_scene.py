"""Scene model, profile and advisor (glintlab.scene, glintlab.advisor, glintlab profile / advise)."""
import json
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.validation import profile as P
from glintlab.cli.main import main
from glintlab.validation import scene as scene_module
from glintlab.validation.scene import load_scene

LAWS = ["binomial", ("gaussian", {"rounding": "round"}), "zk16", "gated", "head_cf"]
# Fixed costs (ns per evaluation; ZK16: base and per trial) keep the tests independent of timing.
COSTS = {"binomial": 20.0, "gaussian[rounding=round]": 6.0, "zk16": (2.0, 3.0), "gated": 6.5, "head_cf": 7.0}


def base(kind="plane", elevation_deg=90.0, res=(64, 36)):
    e = math.radians(elevation_deg)
    pos = [0.0, -2 * math.cos(e), 2 * math.sin(e)]
    prim = {"plane": {"type": "plane"},
            "sphere": {"type": "sphere", "center": [0, 0, 0], "radius": 1.0},
            "heightfield": {"type": "heightfield", "height": {"amplitude": 0.02, "frequency": 4.0}}}[kind]
    if kind == "sphere":
        pos = [0.0, -4.5, 0.3]
    return {"camera": {"resolution": list(res), "fov_deg": 60, "position": pos, "look_at": [0, 0, 0],
                       "up": [0, 1, 0] if elevation_deg == 90 else [0, 0, 1]},
            "primitive": prim, "light": {"type": "point", "position": [0.5, pos[1], pos[2] + 0.5]},
            "material": {"density": 4194304.0 / 900}}


def fd_jacobian(scene, px, py, h=1e-3):
    """Central differences of uv over the pixel coordinates."""
    d = {}
    for k, (dx, dy) in enumerate(((h, 0), (0, h))):
        up = scene.trace(px + dx, py + dy)["uv"]
        dn = scene.trace(px - dx, py - dy)["uv"]
        d[k] = (up - dn) / (2 * h)
    return np.concatenate([d[0], d[1]], axis=-1)


@pytest.mark.parametrize("kind,elev", [("plane", 90), ("plane", 35), ("sphere", 90), ("heightfield", 90),
                                       ("heightfield", 40)])
def test_jacobian_matches_finite_differences(kind, elev):
    sc = load_scene(base(kind, elev))
    rng = np.random.default_rng(3)
    px, py = rng.uniform(2, 62, 300), rng.uniform(2, 34, 300)
    tr = sc.trace(px, py)
    fd = fd_jacobian(sc, px, py, h=1e-3 if kind != "heightfield" else 2e-4)
    ok = tr["hit"] & sc.trace(px + 1e-3, py)["hit"] & sc.trace(px - 1e-3, py)["hit"] & \
        sc.trace(px, py + 1e-3)["hit"] & sc.trace(px, py - 1e-3)["hit"]
    if kind == "sphere":  # the lat-long seam (phi = +-pi) jumps by 2 pi s R: keep rays away from it
        ok &= np.abs(np.abs(tr["uv"][:, 0]) - math.pi) > 0.05
    assert ok.sum() > 60
    J = tr["J"][ok]
    err = np.linalg.norm(J - fd[ok], axis=1) / np.linalg.norm(J, axis=1)
    # Heightfield at 40 deg: rays near an occlusion edge jump to another surface point; they are rare.
    # Central differences err by O(h^2) times the third derivative; the heightfield's bumps curve
    # within a pixel at this resolution, hence its looser tolerance.
    q = np.quantile(err, 0.97 if (kind == "heightfield" and elev < 90) else 1.0)
    assert q < (1e-4 if kind == "heightfield" else 1e-5), (kind, elev, q)
    # The check has power: a Jacobian off by 1% fails it.
    bad = np.linalg.norm(J * 1.01 - fd[ok], axis=1) / np.linalg.norm(J, axis=1)
    assert np.quantile(bad, 0.5) > 1e-3


def test_plane_facing_camera_is_isotropic_with_the_pixel_footprint():
    sc = load_scene(base("plane", 90, res=(64, 36)))
    g = sc.geometry()
    assert g.valid.all()
    assert np.max(np.abs(g.r - 1)) < 1e-9
    # Distance 2, uv_scale 1: a pixel spans 2 / focal texture units per side.
    expected = (2.0 / sc.focal) ** 2
    assert g.P[18, 32] == pytest.approx(expected, rel=1e-12)
    assert np.allclose(g.n, sc.density * expected, rtol=1e-12)


@pytest.mark.parametrize("elev", [25.0, 45.0, 70.0])
def test_tilted_plane_centre_ratio(elev):
    # Even resolution: the optical axis passes through a pixel corner; use an odd one so it hits the
    # centre pixel. There the vertical pixel step is stretched by 1 / sin(elevation): r = 1 / sin(e),
    # and P = (D / f)^2 / sin(e) with D = 2 the distance to the look-at point.
    sc = load_scene(base("plane", elev, res=(65, 37)))
    tr = sc.trace(np.array([32.5]), np.array([18.5]))
    fp = gl.footprint_shapes(tr["J"])
    e = math.radians(elev)
    assert fp.r[0] == pytest.approx(1 / math.sin(e), rel=1e-9)
    assert fp.P[0] == pytest.approx((2 / sc.focal) ** 2 / math.sin(e), rel=1e-9)


def test_clamped_p_is_reported_for_beckmann_alpha_1_and_R_1():
    doc = base("plane", 90, res=(64, 36))
    doc["material"].update(R=1.0, alpha=1.0, ndf="beckmann")
    # A light at grazing incidence makes h leave the normal, where D(h) / D(n) peaks at 4 / e.
    doc["light"] = {"type": "directional", "direction": [1.0, 0.0, 0.9]}
    g = load_scene(doc).geometry()
    assert g.clamped.any() and g.p.max() == 1.0 and g.p_raw.max() > 1.0
    assert load_scene(doc).geometry().summary()["p_clamped"] == int(g.clamped.sum())
    doc["material"]["R"] = 0.5  # R <= 1 / max_ratio: never clamped
    assert not load_scene(doc).geometry().clamped.any()


@pytest.fixture(scope="module")
def profile():
    doc = base("plane", 25, res=(96, 54))
    doc["material"]["density"] *= 40  # n p from 0 to about 40: every regime of the laws
    return P.profile_scene(doc, laws=LAWS, costs=COSTS, seed=5, schemes=("db23_tetrahedral", "zk16_aniso"))


def test_advisor_zero_budget_picks_the_exact_law(profile):
    # The scene reaches n p > 16, so no approximate law equals the binomial everywhere.
    assert (profile.maps["n"] * profile.maps["p"] > 16).any()
    assert gl.advise(profile, max_tv=0).law == "binomial"
    assert gl.advise(profile, max_rel_error=0).law == "binomial"


def test_advisor_infinite_budget_picks_the_cheapest(profile):
    a = gl.advise(profile, max_tv=math.inf)
    costs = {lab: P.simd_stats(profile.pixel_cost("db23_tetrahedral", lab), profile.valid)["mean_group"]
             for lab in profile.costs.law}
    assert a.law == min(costs, key=costs.get)


def test_advisor_middle_budget(profile):
    exact = gl.advise(profile, max_tv=0)
    for budget in (0.01, 0.05, 0.2):
        a = gl.advise(profile, max_tv=budget)
        assert a.error["tv_worst"] <= budget
        assert a.cost <= exact.cost
        tv = profile.pixel_error(a.law)
        assert tv.max() <= budget
    r = gl.advise(profile, max_tv=0.05, per_regime=True)
    for row in r.per_regime.itertuples():
        assert row.tv_worst <= 0.05
    assert r.per_regime.attrs["cost_mean_group"] <= r.cost * 2


def test_bad_budget_and_coverage(profile):
    for kwargs in ({"max_tv": -1}, {"max_tv": float("nan")}, {"max_tv": 0.1, "coverage": 0}):
        with pytest.raises(ValueError, match="max_tv|coverage"):
            gl.advise(profile, **kwargs)


def test_profile_is_deterministic():
    doc = base("heightfield", 40, res=(48, 27))
    a = P.profile_scene(doc, laws=LAWS, costs=COSTS, seed=7, schemes=("db23_tetrahedral", "zk16_aniso"))
    b = P.profile_scene(doc, laws=LAWS, costs=COSTS, seed=7, schemes=("db23_tetrahedral", "zk16_aniso"))
    for name in ("regimes", "laws", "costs", "table1"):
        assert a.tables[name].equals(b.tables[name]), name
    sa = a.tables["schemes"].drop(columns="seconds")
    assert sa.equals(b.tables["schemes"].drop(columns="seconds"))


def test_profile_errors_match_direct_pmfs(profile):
    # Pixel-weighted mean TV reproduced from the per-bin points with gl.distance directly.
    e = profile.law_bin_errors
    pts = e[e.law == "gated"].sort_values("point")
    k = int(np.argmax(pts.tv.to_numpy()))
    counts = np.bincount(profile.law_bin)
    assert counts.sum() == profile.valid.sum()
    # Recompute the worst bin's TV at its representative point.
    inv, cnt, rep_n, rep_p = P._bin_pixels(profile.maps["n"][profile.valid], profile.maps["p"][profile.valid], 8)
    d = gl.distance(gl.law("gated").pmf(rep_n[k], rep_p[k]), gl.law("binomial").pmf(rep_n[k], rep_p[k]), "tv")
    assert d == pytest.approx(pts.tv.iloc[k], rel=1e-12)


def test_binning_refinement_changes_little():
    doc = base("plane", 25, res=(96, 54))
    t = P.binning_check(doc, laws=["binomial", "gated", "head_cf"], bins_per_decade=8)
    piv = t.pivot(index="law", columns="bins_per_decade", values="tv_mean")
    assert np.all(np.abs(piv[8] - piv[16]) <= 0.01 + 0.1 * piv[16])


def test_simd_group_cost_two_ways():
    rng = np.random.default_rng(1)
    cost = rng.exponential(size=(13, 21))
    active = rng.random((13, 21)) > 0.2
    g, lanes = P.group_max(cost, active)
    ref = np.zeros((4, 3))
    for gi in range(4):
        for gj in range(3):
            block = [cost[i, j] for i in range(gi * 4, min(gi * 4 + 4, 13)) for j in range(gj * 8, min(gj * 8 + 8, 21))
                     if active[i, j]]
            ref[gi, gj] = max(block) if block else 0.0
    assert np.array_equal(g, ref)
    st = P.simd_stats(cost, active)
    assert st["worst_group"] == ref.max()
    assert st["simd_efficiency"] == pytest.approx(cost[active].mean() / ref[lanes > 0].mean())


def test_zk16_loop_model():
    # The profile charges zk16 the work its law declares (law.work_units): terms of 4, 16 (twice) and
    # 40 trials loop min(ceil n_t, 16) times when n_t p <= 5 (p = 0.5: only the 4; p = 0.2: 4 + 2 x 16;
    # p = 0.01: the 40 too, capped at 16).
    zk16 = gl.law("zk16")
    T, M = np.array([[4.0, 16.0, 40.0]]), np.array([[1.0, 2.0, 1.0]])
    n = np.array([10.0, 10.0, 10.0])
    p = np.array([0.5, 0.2, 0.01])
    loops = P.work_per_pixel(zk16, np.zeros(3, int), np.array([10.0]), T, M, n, p, 1)
    assert list(loops) == [4.0, 4 + 2 * 16, 4 + 2 * 16 + 16]
    # Trials scale with the pixel's n over the bin's: n = 20 doubles them (8, 32, 80) at p = 0.2.
    assert P.work_per_pixel(zk16, np.zeros(1, int), np.array([10.0]), T, M, np.array([20.0]), np.array([0.2]), 3)[0] == 3 * 8
    # A constant-time law does no work on top of its evaluations.
    assert not P.has_cost_model(gl.law("gated"))


BAD = {
    "missing": (lambda d: d["camera"].pop("position"), "/camera/position"),
    "wrong_type": (lambda d: d["camera"].update(fov_deg="wide"), "/camera/fov_deg"),
    "negative_fov": (lambda d: d["camera"].update(fov_deg=-5), "/camera/fov_deg"),
    "unknown_primitive": (lambda d: d["primitive"].update(type="torus"), "/primitive/type"),
    "inside_sphere": (lambda d: d.update(primitive={"type": "sphere", "center": [0, 0, 0], "radius": 10.0}),
                      "/camera/position"),
    "bad_R": (lambda d: d["material"].update(R=1.5), "/material/R"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_scene_files_exit_2_with_pointer(case, tmp_path, capsys):
    doc = base("plane", 90)
    BAD[case][0](doc)
    path = tmp_path / f"{case}.json"
    path.write_text(json.dumps(doc))
    assert main(["advise", str(path), "--max-tv", "0.05"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: at {BAD[case][1]}: expected " in err  # the one document error format


def test_not_json_and_bad_flags(tmp_path, capsys):
    path = tmp_path / "broken.json"
    path.write_text("{camera: ")
    assert main(["advise", str(path), "--max-tv", "0.05"]) == 2
    assert f"{path}: at /: expected valid JSON (" in capsys.readouterr().err
    good = tmp_path / "good.json"
    good.write_text(json.dumps(base("plane", 90)))
    assert main(["advise", str(good), "--max-tv", "-1"]) == 2
    assert "--max-tv" in capsys.readouterr().err


def test_advise_cli_and_python_agree(tmp_path, capsys):
    good = tmp_path / "good.json"
    good.write_text(json.dumps(base("plane", 25, res=(64, 36))))
    costs = tmp_path / "costs.csv"
    P._cost_table(COSTS, list(COSTS)).to_csv(costs, index=False)
    rc = main(["advise", str(good), "--max-tv", "0.05", "--costs", str(costs), "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    prof = P.profile_scene(str(good), laws=LAWS, costs=COSTS, schemes=("db23_tetrahedral", "zk16_aniso"))
    # The CLI profiles every default law; restricted to the same candidates, the pick is the same.
    cands = [c for c in out["candidates"] if c["law"] in COSTS and c["meets_budget"]]
    assert min(cands, key=lambda c: c["cost_mean_group"])["law"] == gl.advise(prof, max_tv=0.05).law


def test_defaults_are_filled_and_documented():
    sc = load_scene(base("plane", 90))
    assert sc.spec["material"]["R"] == 0.5 and sc.spec["material"]["ndf"] == "beckmann"
    assert sc.spec["camera"]["fov_axis"] == "horizontal" and sc.spec["primitive"]["uv_scale"] == 1.0


def test_table1_scene_files_load():
    scenes = scene_module.table1_scenes()
    assert [s.name for s in scenes] == list(scene_module.TABLE1_SCENES)
    assert all((s.width, s.height) == (1920, 1080) for s in scenes)
    assert all(s.ndf.name == "beckmann" and s.ndf.alpha == 1.0 for s in scenes)


def test_a_scene_that_sees_no_surface_is_refused_by_name(tmp_path, capsys):
    doc = base("plane", 25, res=(32, 18))
    doc["camera"]["look_at"] = [doc["camera"]["position"][0], doc["camera"]["position"][1] + 10,
                                doc["camera"]["position"][2] + 8]  # looking up at the sky
    path = tmp_path / "sky.json"
    path.write_text(json.dumps(doc))
    assert main(["advise", str(path), "--max-tv", "0.05"]) == 2
    assert "no pixel sees the plane" in capsys.readouterr().err


# Scene.trace is C++ (core/src/scene/scene_trace.cpp), Scene.trace_numpy its first, numpy form: the same float64
# operations, so they agree to float64 rounding. Measured on the shipped scenes: planes bit for bit,
# the sphere up to 2e-11 and the heightfields 6e-11 relative (numpy's vector sin, cos and atan2 against the
# C library's, amplified in J by the root's conditioning); allowed: 1e-9 of each vector's largest component.
TRACE_RTOL = 1e-9


def _trace_gap(a, b):
    """The hit masks' disagreements and the largest relative gap over the fields where both hit."""
    hit = a["hit"] & b["hit"]
    worst = 0.0
    for key in ("t", "x", "uv", "J", "shading_normal", "direction", "dxdpx", "dxdpy"):
        va, vb = a[key][hit], b[key][hit]
        scale = np.abs(vb).max(axis=-1, keepdims=True) if vb.ndim > 1 else np.abs(vb)
        worst = max(worst, float(np.max(np.abs(va - vb) / np.maximum(scale, 1e-300), initial=0.0)))
    return int((a["hit"] != b["hit"]).sum()), worst


@pytest.mark.parametrize("stem", scene_module.TABLE1_SCENES)
def test_cpp_trace_is_the_numpy_trace(stem):
    sc = load_scene(scene_module.SCENES_DIR / f"{stem}.json").scaled(0.06)
    y, x = np.mgrid[0:sc.height, 0:sc.width].astype(np.float64)
    px, py = x + 0.37, y + 0.61  # off the pixel centres: any coordinates, any shape
    a, b = sc.trace(px, py), sc.trace_numpy(px, py)
    assert set(a) == set(b) and all(a[k].shape == b[k].shape for k in a) and a["hit"].dtype == bool
    assert a["hit"].any()
    miss, gap = _trace_gap(a, b)
    assert miss == 0 and gap <= TRACE_RTOL, (miss, gap)
    # Not blind: a camera turned by 1e-7 rad (the ray directions moved by 1e-7) is caught.
    turned = load_scene(scene_module.SCENES_DIR / f"{stem}.json").scaled(0.06)
    turned.forward = turned.forward + 1e-7 * turned.right
    assert _trace_gap(turned.trace(px, py), b)[1] > 100 * TRACE_RTOL


def test_cpp_trace_threads_and_bad_input():
    sc = load_scene(scene_module.SCENES_DIR / "heightfield_25.json").scaled(0.1)
    y, x = np.mgrid[0:sc.height, 0:sc.width].astype(np.float64)
    split, old = sc.trace(x + 0.5, y + 0.5), gl.get_num_threads()
    gl.set_num_threads(1)
    try:
        one = sc.trace(x + 0.5, y + 0.5)
    finally:
        gl.set_num_threads(old)
    assert all(np.array_equal(split[k], one[k], equal_nan=True) for k in split)
    with pytest.raises(ValueError, match="px has 3 values; py has 2"):
        from glintlab import _core
        _core.scene_trace(np.zeros(3), np.zeros(2), False, 4.0, 4.0, 2.0, (0, 0, 1), (0, 0, -1), (1, 0, 0),
                          (0, 1, 0), (0, 0, 0), 0.0, (0, 0, 0), (0, 0, 1), (1, 0, 0), (0, 1, 0), [], 1.0)
