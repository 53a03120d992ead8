"""gl.sweep: exact and sampled rows, determinism, Monte Carlo noise floor, resumable stores."""
import json
import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import glintlab as gl
from glintlab.validation.store import STORE_FORMAT
from glintlab.validation.rows import row_seed, tv_noise

ROOT = Path(__file__).resolve().parents[2]
PYTHON = str(ROOT / ".venv" / "bin" / "python")


def test_exact_sweep_matches_direct_computation():
    df = gl.sweep(["gated", "head_cf"], n=[16, 1e3], p=[0.01, 0.5], metrics=["tv", "hellinger", "mean_rel_err"])
    assert list(df.columns[:3]) == ["law", "n", "p"]
    assert len(df) == 8 and list(df.law[:4]) == ["gated"] * 4
    b = gl.law("binomial")
    for r in df.itertuples():
        d, ref = gl.law(r.law).pmf(r.n, r.p), b.pmf(r.n, r.p)
        assert r.tv == gl.distance(d, ref, "tv")
        assert r.mean_rel_err == pytest.approx(abs(d.mean - ref.mean) / ref.mean, rel=1e-12)


def test_standard_grid_default_and_points():
    df = gl.sweep("head_cf", metrics="tv")
    n, p = gl.standard_grid()
    assert len(df) == n.size * p.size and df.tv.max() < 0.01
    pts = gl.sweep("head_cf", points=[(16, 0.1), (1e6, 0.3)], metrics="tv")
    assert list(pts.n) == [16, 1e6] and list(pts.p) == [0.1, 0.3]


def test_sampled_rows_are_independent_of_grid_threads_and_order():
    a = gl.sweep(["gated", "binomial"], n=[16], p=[0.1], metrics=["tv", "chi2_pvalue"], samples=20000, seed=5,
                 threads=1)
    b = gl.sweep(["binomial", "gated"], n=[1e3, 16], p=[0.5, 0.1], metrics=["tv", "chi2_pvalue"], samples=20000,
                 seed=5, threads=2)
    gl.set_num_threads(1)
    try:
        c = gl.sweep(["gated", "binomial"], n=[16], p=[0.1], metrics=["tv", "chi2_pvalue"], samples=20000, seed=5)
    finally:
        gl.set_num_threads(os.cpu_count() or 2)
    for lw in ("gated", "binomial"):
        ra = a[a.law == lw].iloc[0]
        rb = b[(b.law == lw) & (b.n == 16) & (b.p == 0.1)].iloc[0]
        rc = c[c.law == lw].iloc[0]
        assert ra.equals(rb) and ra.equals(rc)
    assert a.seed.iloc[0] == row_seed(5, "gated", 16, 0.1)
    # The binomial sampler passes its chi-square test, gated (DB23's law) fails it at n = 16.
    assert a[a.law == "binomial"].chi2_pvalue.iloc[0] > 1e-3
    assert a[a.law == "gated"].chi2_pvalue.iloc[0] < 1e-6


def test_tv_noise_is_the_expected_tv_of_pure_sampling_noise():
    d = gl.law("binomial").pmf(50, 0.3)
    m = 2000
    tvs = [gl.distance(gl.law("binomial").sample(50, 0.3, size=m, seed=s), d, "tv") for s in range(300)]
    se = np.std(tvs) / np.sqrt(len(tvs))
    assert abs(np.mean(tvs) - tv_noise(d, m)) < 4 * se
    # and a sampled sweep of the exact law sits at that floor, not above it
    row = gl.sweep("binomial", n=[1e3], p=[0.1], metrics=["tv"], samples=50000).iloc[0]
    assert row.tv < 2 * row.tv_noise


def test_sampled_sweep_of_a_custom_law_and_another_reference():
    mine = gl.custom_law(lambda n, p, u: np.floor(n * p + 4 * (u[:, 0] - 0.5)), 1, "sweep_mine")
    df = gl.sweep([mine], n=[100], p=[0.3], metrics=["tv", "mean_rel_err"], samples=10000, reference="poisson")
    assert df.law.iloc[0] == "sweep_mine" and df.tv.iloc[0] > 0.5
    assert df.mean_rel_err_se.iloc[0] > 0


def test_ground_truth_reference():
    # The Poisson layout's count is exactly Poisson(n p); the uniform layout's is Binomial(N, A p).
    df = gl.sweep("poisson", n=[16, 64], p=[0.3], metrics=["tv"],
                  reference={"ground_truth": {"layout": "poisson", "density": 4096}})
    assert df.tv.max() < 1e-9
    uni = gl.sweep("binomial", n=[16], p=[0.3], metrics=["tv"],
                   reference={"ground_truth": {"layout": "uniform", "density": 4096}})
    b = gl.law("binomial")
    direct = gl.distance(b.pmf(16, 0.3), b.pmf(4096, 16 / 4096 * 0.3), "tv")
    assert uni.tv.iloc[0] == pytest.approx(direct, rel=1e-9, abs=1e-12)
    with pytest.raises(ValueError, match="area"):
        gl.sweep("binomial", n=[5000], p=[0.3], reference={"ground_truth": {"layout": "uniform", "density": 4096}})


def test_bad_arguments_name_the_parameter():
    with pytest.raises(ValueError, match="metric = 'tvv'"):
        gl.sweep("gated", n=[16], p=[0.1], metrics=["tvv"])
    with pytest.raises(ValueError, match="chi2_pvalue"):
        gl.sweep("gated", n=[16], p=[0.1], metrics=["chi2_pvalue"])
    with pytest.raises(ValueError, match=r"p\[1\] = 1.5"):
        gl.sweep("gated", n=[16], p=[0.1, 1.5])
    with pytest.raises(ValueError, match="samples = 0"):
        gl.sweep("gated", n=[16], p=[0.1], samples=0)
    with pytest.raises(ValueError, match="no exact distribution"):
        gl.sweep([gl.custom_law(lambda n, p, u: n * p, 0, "sweep_nopmf")], n=[16], p=[0.1])
    with pytest.raises(ValueError, match="unknown law|gatd"):
        gl.sweep("gatd", n=[16], p=[0.1])


def test_store_resumes_and_refuses_another_sweep(tmp_path):
    store = tmp_path / "s.jsonl"
    full = gl.sweep(["gated", "head_cf"], n=[16, 1e3, 1e5], p=[0.01, 0.3], metrics=["tv", "mean_rel_err"],
                    samples=5000, seed=2)
    first = gl.sweep(["gated", "head_cf"], n=[16, 1e3, 1e5], p=[0.01, 0.3], metrics=["tv", "mean_rel_err"],
                     samples=5000, seed=2, store=store)
    pd.testing.assert_frame_equal(full, first)
    lines = store.read_text().splitlines()
    assert len(lines) == 1 + 12
    # Cut the file inside the last row, as a kill during a write would, and drop three rows.
    store.write_text("\n".join(lines[:-3]) + "\n" + lines[-3][: len(lines[-3]) // 2])
    again = gl.sweep(["gated", "head_cf"], n=[16, 1e3, 1e5], p=[0.01, 0.3], metrics=["tv", "mean_rel_err"],
                     samples=5000, seed=2, store=store)
    assert again.attrs["resumed_rows"] == 9 and again.attrs["computed_rows"] == 3
    pd.testing.assert_frame_equal(full, again)
    assert len(store.read_text().splitlines()) == 13
    with pytest.raises(ValueError, match="different sweep.*seed"):
        gl.sweep(["gated", "head_cf"], n=[16, 1e3, 1e5], p=[0.01, 0.3], metrics=["tv", "mean_rel_err"],
                 samples=5000, seed=3, store=store)

    # A store of an older format (whose rows this version would not reproduce) is refused, saying why.
    header = json.loads(store.read_text().splitlines()[0])
    assert header["glintlab_store"] == STORE_FORMAT
    old = tmp_path / "old.jsonl"
    old.write_text(json.dumps(dict(header, glintlab_store=2)) + "\n")
    with pytest.raises(ValueError, match="store format 2.*roulette"):
        gl.sweep(["gated", "head_cf"], n=[16, 1e3, 1e5], p=[0.01, 0.3], metrics=["tv", "mean_rel_err"],
                 samples=5000, seed=2, store=old)


SLOW_LAW = '''
import time
import numpy as np
def law(n, p, u):
    time.sleep(0.15)
    return np.floor(n * p + u[:, 0])
'''

SWEEP_SCRIPT = '''
import sys
import glintlab as gl
from glintlab.validation.references import resolve_law
law = resolve_law({{"name": "slow_law", "python": "{law}:law", "n_uniforms": 1}})
gl.sweep([law], n=[1, 2, 4, 8, 16, 32], p=[0.1, 0.2, 0.3, 0.4], metrics=["tv"], samples=100, seed=4,
         store="{store}", threads=2, progress=False)
'''


def _start_sweep(tmp_path, store):
    law_file = tmp_path / "slow_law.py"
    law_file.write_text(SLOW_LAW)
    script = tmp_path / "run.py"
    script.write_text(SWEEP_SCRIPT.format(law=law_file, store=store))
    return subprocess.Popen([PYTHON, str(script)], stderr=subprocess.PIPE, text=True), law_file


def _wait_rows(store, rows, proc, timeout=60):
    t0 = time.time()
    while time.time() - t0 < timeout:
        if store.exists() and len(store.read_text().splitlines()) >= 1 + rows:
            return
        assert proc.poll() is None, proc.stderr.read()
        time.sleep(0.05)
    raise AssertionError("the sweep wrote no rows")


@pytest.mark.parametrize("how", ["kill -9", "ctrl-c"])
def test_interrupted_sweep_loses_nothing_and_recomputes_nothing(tmp_path, how):
    store = tmp_path / "store.jsonl"
    proc, law_file = _start_sweep(tmp_path, store)
    _wait_rows(store, 6, proc)
    proc.send_signal(signal.SIGKILL if how == "kill -9" else signal.SIGINT)
    proc.wait(timeout=30)
    err = proc.stderr.read()
    if how == "ctrl-c":
        assert "run the same sweep again" in err
    kept = len(store.read_text().splitlines()) - 1
    assert 6 <= kept < 24
    from glintlab.validation.references import resolve_law
    law = resolve_law({"name": "slow_law", "python": f"{law_file}:law", "n_uniforms": 1})
    resumed = gl.sweep([law], n=[1, 2, 4, 8, 16, 32], p=[0.1, 0.2, 0.3, 0.4], metrics=["tv"], samples=100, seed=4,
                       store=store, threads=2)
    assert resumed.attrs["resumed_rows"] >= kept - 0 and resumed.attrs["computed_rows"] == 24 - resumed.attrs["resumed_rows"]
    fresh = gl.sweep([law], n=[1, 2, 4, 8, 16, 32], p=[0.1, 0.2, 0.3, 0.4], metrics=["tv"], samples=100, seed=4,
                     threads=2)
    pd.testing.assert_frame_equal(fresh, resumed)
    rows = [json.loads(x) for x in store.read_text().splitlines()[1:]]
    assert len(rows) == 24 and len({(r["n"], r["p"]) for r in rows}) == 24  # nothing stored twice
