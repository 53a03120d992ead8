"""The direction-sampler harness (gl.sampler_test), the reference samplers and the furnace tests
(docs/math/sampling.md).

Accepted false-failure rate: every test that requires a correct sampler to pass uses a fixed seed and
the significance ALPHA = gl.sidak_alpha(1e-3, N_PASS), N_PASS being the number of such runs below, so
that a correct harness and samplers fail any of them with probability 1e-3 family-wise. With fixed
seeds a run always gives the same p-values: a failure after a change is a real signal at that level.

Power: each wrong variant (alpha 2 % too large, the pdf without its (h . n) Jacobian, one sample in a
thousand dropped, lobes displaced by one lobe width, a disk sampler without its square root) must be
rejected at the sample size the correct one passes with, with a p-value below 1e-6.
"""
from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.ndf import NDF

N = 500_000    # microfacet samplers: alpha 2 % off is a chi-square noncentrality of ~250 (GGX) here
NS = 200_000   # the spiky pdf: 1000 samples per lobe
NO = 100_000   # other domains
REFERENCE = [("beckmann", {"alpha": 0.3}), ("ggx", {"alpha": 0.3}), ("ggx", {"alpha": 0.05}),
             ("ggx_vndf", {"alpha": 0.3, "wo": (0.6, 0.0, 0.8)}),
             ("ggx_vndf", {"alpha": 0.5, "wo": (0.98, 0.1, 0.17)}),
             ("beckmann_vndf", {"alpha": 0.3, "wo": (0.6, 0.0, 0.8)}),
             ("beckmann_vndf", {"alpha": 0.5, "wo": (0.98, 0.1, 0.17)})]
# Runs that must pass: the reference samplers, the spiky pdf (adaptive and grid), the shifted lobes on
# the grid, three other domains, the determinism pair (counted once) and the CLI run.
N_PASS = len(REFERENCE) + 3 + 3 + 1 + 1
ALPHA = gl.sidak_alpha(1e-3, N_PASS)
POWER = 1e-6


@pytest.mark.parametrize("name,params", REFERENCE, ids=[f"{n}-{i}" for i, (n, _) in enumerate(REFERENCE)])
def test_reference_samplers_pass(name, params):
    s = gl.sampler(name, **params)
    res = gl.sampler_test(s, samples=N, seed=11, significance=ALPHA)
    assert res.passed, res
    assert res.mismatches == 0 and res.lost == 0
    assert abs(res.integral - 1) <= res.integral_error + 1e-9 and res.integral_error * N < 0.1 * N**0.5, res
    # The global cubature rule holds: the errors of all bins together move the chi-square statistic by at
    # most 0.1 of its standard deviation (docs/math/sampling.md#cubature-error).
    assert 0 <= res.cubature_shift <= res.cubature_limit == pytest.approx(0.1 * np.sqrt(2 * res.dof)), res


# Every wrong variant each sampler declares (Sampler.wrong_variants), not a hand list.
WRONG = [(name, params, kind) for name, params in (REFERENCE[1], REFERENCE[3], REFERENCE[5])
         for kind in gl.sampler(name, **params).wrong_variants]


@pytest.mark.parametrize("name,params,kind", WRONG, ids=[f"{n}-{k}" for n, _, k in WRONG])
def test_wrong_variants_are_rejected(name, params, kind):
    wrong = gl.wrong_sampler(gl.sampler(name, **params), kind)
    res = gl.sampler_test(wrong, samples=N, seed=11, significance=ALPHA)
    assert not res.passed and res.pvalue < POWER, res
    if kind == "drop_0.1%":
        assert res.lost == N // 1000 and res.pvalue_lost < POWER


def test_spiky_pdf_adaptive_bins_resolve_what_a_grid_cannot(tmp_path):
    good = gl.sampler("vmf_mixture", lobes=200, width_deg=0.3, layout="cell_centres", theta_deg=(30, 80))
    shifted = gl.sampler("vmf_mixture", lobes=200, width_deg=0.3, layout="cell_centres", theta_deg=(30, 80),
                         shift_deg=0.3)
    ok = gl.sampler_test(good, samples=NS, seed=3, significance=ALPHA)
    assert ok.passed, ok
    # The bins follow the lobes: far more bins than a 30 x 60 grid's cells inside the lobes, and cells
    # smaller than a lobe (0.3 deg ~ 5e-3 rad: a square cell of the hemisphere map of side 2^-8 is
    # about 0.01 x 0.025 rad).
    assert ok.bins > 300
    assert (ok.rects[:, 2].min()) <= 2.0**-9
    bad = gl.sampler_test(shifted, samples=NS, seed=3, significance=ALPHA, out=tmp_path)
    assert not bad.passed and bad.pvalue < POWER, bad
    assert {p.rsplit(".", 1)[1] for p in bad.files} == {"npz", "csv", "png"}
    data = np.load(bad.files[0])
    assert data["observed"].sum() == NS and data["rects"].shape == (bad.bins, 4)
    # The fixed (theta, phi) grid of 30 x 60 cells passes both: each lobe stays inside its cell.
    for s in (good, shifted):
        grid = gl.sampler_test(s, samples=NS, seed=3, bins=(30, 60), significance=ALPHA)
        assert grid.passed, grid


def _sphere_sampler(size, seed):
    rng = np.random.default_rng(seed)
    z = rng.uniform(-1, 1, size)
    phi = rng.uniform(0, 2 * np.pi, size)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1), np.full(size, 1 / (4 * np.pi))


def _disk_sampler(jacobian=True):
    def sample(size, seed):
        rng = np.random.default_rng(seed)
        u = rng.random(size)
        r = np.sqrt(u) if jacobian else u   # without the square root: density 1 / (2 pi r)
        phi = rng.uniform(0, 2 * np.pi, size)
        return np.stack([r * np.cos(phi), r * np.sin(phi)], 1), np.full(size, 1 / np.pi)
    return sample


def _square_sampler(size, seed):
    # density 4 x y on [0, 1]^2: x = sqrt(u), y = sqrt(v)
    rng = np.random.default_rng(seed)
    p = np.sqrt(rng.random((size, 2)))
    return p, 4 * p[:, 0] * p[:, 1]


def test_other_domains():
    res = gl.sampler_test(_sphere_sampler, lambda p: np.full(len(p), 1 / (4 * np.pi)), domain="sphere",
                          samples=NO, seed=5, significance=ALPHA)
    assert res.passed, res
    disk_pdf = lambda p: np.full(len(p), 1 / np.pi)  # noqa: E731
    res = gl.sampler_test(_disk_sampler(), disk_pdf, domain="disk", samples=NO, seed=5, significance=ALPHA)
    assert res.passed, res
    res = gl.sampler_test(_disk_sampler(False), disk_pdf, domain="disk", samples=NO, seed=5, significance=ALPHA)
    assert res.pvalue < POWER, res
    res = gl.sampler_test(_square_sampler, lambda p: 4 * p[:, 0] * p[:, 1], domain="square", samples=NO, seed=5,
                          significance=ALPHA)
    assert res.passed, res
    # a pdf that forgets half of the square: the samples land where it has no mass
    res = gl.sampler_test(_square_sampler, lambda p: 8 * p[:, 0] * p[:, 1] * (p[:, 0] < 0.5), domain="square",
                          samples=NO, seed=5)
    assert res.pvalue < POWER, res


def test_same_seed_same_result_whatever_the_threads():
    s = gl.sampler("ggx_vndf", alpha=0.3)
    before = gl.get_num_threads()
    try:
        gl.set_num_threads(1)
        a = gl.sampler_test(s, samples=NO, seed=21, chunk=30_000)
        gl.set_num_threads(2)
        b = gl.sampler_test(s, samples=NO, seed=21, chunk=30_000)
    finally:
        gl.set_num_threads(before)
    assert a.passed
    assert a.pvalue == b.pvalue and np.array_equal(a.observed, b.observed) and np.array_equal(a.expected, b.expected)
    c = gl.sampler_test(s, samples=NO, seed=22, chunk=30_000)
    assert not np.array_equal(a.observed, c.observed)


def test_result_object_and_pdf_consistency():
    s = gl.sampler("ggx", alpha=0.3)

    def sample(size, seed):
        h, p = s.sample(size, seed)
        return h, p * np.where(np.arange(size) % 100 == 0, 1.01, 1.0)   # 1 % of the pdfs off by 1 %

    res = gl.sampler_test(sample, s.pdf, samples=20_000, seed=1)
    assert res.mismatches == 200 and res.checked == 20_000 and abs(res.worst_rel_diff - 0.01 / 1.01) < 1e-9
    assert not res.passed and "rtol" in res.note
    back = pickle.loads(pickle.dumps(res))
    assert back.pvalue == res.pvalue and np.array_equal(back.observed, res.observed)
    text = repr(res)
    assert "FAIL" in text and "mismatches = 200/20000" in text
    assert set(res.times) >= {"sampling", "binning", "integration", "pdf_check", "total"}
    assert res.observed.sum() + res.lost == 20_000
    assert res.merged_observed.sum() == pytest.approx(20_000)


def test_no_power_gives_nan_and_a_note():
    res = gl.sampler_test(gl.sampler("ggx", alpha=0.3), samples=6, seed=1)
    assert math.isnan(res.pvalue) and "no power" in res.note and not res.passed


@pytest.mark.parametrize("kwargs,name", [
    ({"domain": "cube"}, "domain"), ({"samples": 0}, "samples"), ({"bins": "fixed"}, "bins"),
    ({"bins": (0, 4)}, "bins"), ({"significance": 1.5}, "significance"), ({"seed": -1}, "seed")])
def test_bad_input_names_the_parameter(kwargs, name):
    s = gl.sampler("ggx", alpha=0.3)
    with pytest.raises(ValueError, match=name):
        gl.sampler_test(s.sample, s.pdf, **{"samples": 1000, **kwargs})


def test_bad_callables_are_named():
    s = gl.sampler("ggx", alpha=0.3)
    with pytest.raises(ValueError, match="pdf"):
        gl.sampler_test(s.sample, lambda p: -np.ones(len(p)), samples=1000)
    with pytest.raises(ValueError, match="pdf"):
        gl.sampler_test(s.sample, lambda p: np.full(len(p), np.nan), samples=1000)
    with pytest.raises(ValueError, match=r"sample\(\.\.\.\)\[0\]"):
        gl.sampler_test(lambda n, seed: (np.zeros((n, 2)), None), s.pdf, samples=1000)
    with pytest.raises(ValueError, match="unknown sampler"):
        gl.sampler("nope")
    with pytest.raises(ValueError, match="wo"):
        gl.sampler("ggx_vndf", wo=(0, 0, -1))
    assert {"beckmann", "ggx", "ggx_vndf", "beckmann_vndf", "vmf_mixture"} <= set(gl.samplers())


def test_smith_g1_matches_the_visible_normal_normalization():
    # Exact check of G1 against its definition: integral over h of max(0, wo.h) D(h) = cos(theta_o) / G1.
    for name in ("beckmann", "ggx"):
        ndf = NDF(name, 0.4)
        table = gl.furnace(ndf, theta_o_deg=(0.0, 45.0, 85.0))
        assert np.all(np.abs(table["value"][table.quantity != "furnace_g2"] - 1) < 1e-5), table
        g2 = table[table.quantity == "furnace_g2"]
        assert np.all(g2.value < 1) and np.all(g2.value > 0.5)


def test_furnace_rejects_a_wrong_masking_function():
    class Wrong(NDF):
        def smith_lambda(self, cos_theta):   # Lambda of another roughness than D's
            return NDF(self.name, self.alpha * 1.2).smith_lambda(cos_theta)

    table = gl.furnace(Wrong("ggx", 0.4), theta_o_deg=(60.0,))
    weak = table[table.quantity == "weak_furnace"].iloc[0]
    assert abs(weak.value - 1) > 100 * weak.error + 1e-3


def test_furnace_of_a_glinty_ndf_is_about_one():
    nd = gl.glinty_ndf("kpt25", density=1e6, alpha=0.4, alpha_star=0.05)
    table = gl.furnace(nd, theta_o_deg=(30.0,), pixels=64, directions=64, points=(1000.0,), seed=2)
    assert set(table.quantity) == {"projected_area", "weak_furnace", "furnace_g2"}
    area = table[table.quantity == "projected_area"].iloc[0]
    assert abs(area.value - 1) < 0.1 + 5 * area.error


def test_cli_exit_codes(tmp_path, capsys):
    from glintlab.cli.main import main
    assert main(["sampler", "ggx", "--param", "alpha=0.3", "--samples", "50000", "--quiet", "--out", str(tmp_path)]) == 0
    assert main(["sampler", "ggx", "--param", "alpha=0.3", "--samples", "50000", "--quiet", "--wrong", "drop_0.1%",
                 "--out", str(tmp_path)]) == 1
    assert (tmp_path / "sampler_test_ggx_drop_0.1_.png").exists()
    for bad in (["sampler", "nope"], ["sampler", "ggx", "--param", "alpha=-1"], ["sampler", "ggx", "--bins", "3y"],
                ["sampler", "ggx", "--param", "beta=1"], ["sampler", "ggx", "--samples", "0"]):
        assert main(bad) == 2, bad
    err = capsys.readouterr().err
    assert "Traceback" not in err and "sampler = 'nope' is invalid" in err
