"""Sweeps on Dask: a 2-worker LocalCluster on loopback (dask's own scheduler and workers, started by the
test) gives the serial table bit for bit; a worker killed mid-run loses nothing; a scheduler that does
not answer is reported within the timeout; a killed client resumes from the store."""
import os
import signal
import subprocess
import time
from pathlib import Path

import distributed  # python3-distributed: scripts/install-deps.sh installs it, so no skip here
import pandas as pd
import pytest

import glintlab as gl
from glintlab.validation.references import resolve_law

ROOT = Path(__file__).resolve().parents[2]
PYTHON = str(ROOT / ".venv" / "bin" / "python")

SLOW_LAW = '''
import time
import numpy as np
def law(n, p, u):
    time.sleep(0.2)
    return np.floor(n * p + u[:, 0])
'''
GRID = dict(n=[1, 2, 4, 8, 16, 32], p=[0.1, 0.2, 0.3, 0.4], metrics=["tv"], samples=200, seed=4)


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=":0") as c:
        yield c


def test_two_workers_equal_the_serial_run(cluster):
    kw = dict(laws=["gated", "binomial", "head_cf"], n=[16, 1e3, 1e6], p=[0.01, 0.3], metrics=["tv", "chi2_pvalue"],
              samples=20000, seed=11)
    serial = gl.sweep(**kw, threads=1)
    for chunk in (1, 4, None):
        remote = gl.sweep(**kw, engine="dask", scheduler=cluster.scheduler_address, chunk=chunk)
        pd.testing.assert_frame_equal(serial, remote)
    exact = dict(laws=["gated", gl.perturbed_law("head_cf", 1.1)], n=[1, 16, 1e4], p=[1e-4, 0.5], metrics=["tv", "kl"])
    pd.testing.assert_frame_equal(gl.sweep(**exact),
                                  gl.sweep(**exact, engine="dask", scheduler=cluster.scheduler_address))


def test_a_killed_worker_loses_nothing(cluster, tmp_path):
    law_file = tmp_path / "slow_law.py"
    law_file.write_text(SLOW_LAW)
    law = resolve_law({"name": "slow_dask_law", "python": f"{law_file}:law", "n_uniforms": 1})
    serial = gl.sweep([law], **GRID)
    client = distributed.Client(cluster.scheduler_address, set_as_default=False)
    pids = list(client.run(os.getpid).values())
    client.close()
    store = tmp_path / "store.jsonl"
    from concurrent.futures import ThreadPoolExecutor
    with ThreadPoolExecutor(1) as pool:
        fut = pool.submit(gl.sweep, [law], **GRID, engine="dask", scheduler=cluster.scheduler_address, chunk=2,
                          store=store)
        t0 = time.time()
        while len(store.read_text().splitlines()) < 3 if store.exists() else True:
            assert time.time() - t0 < 60
            time.sleep(0.05)
        os.kill(pids[0], signal.SIGKILL)  # a worker dies with chunks in hand; its nanny restarts it
        remote = fut.result(timeout=120)
    pd.testing.assert_frame_equal(serial, remote)
    rows = store.read_text().splitlines()[1:]
    assert len(rows) == 24 and len(set(rows)) == 24


def test_a_killed_client_resumes_from_the_store(cluster, tmp_path):
    law_file = tmp_path / "slow_law.py"
    law_file.write_text(SLOW_LAW)
    store = tmp_path / "store.jsonl"
    script = tmp_path / "client.py"
    script.write_text(
        "import glintlab as gl\nfrom glintlab.validation.references import resolve_law\n"
        "if __name__ == '__main__':\n"
        f"    law = resolve_law({{'name': 'slow_dask_law', 'python': '{law_file}:law', 'n_uniforms': 1}})\n"
        f"    gl.sweep([law], n={GRID['n']}, p={GRID['p']}, metrics=['tv'], samples=200, seed=4, engine='dask',\n"
        f"             scheduler='{cluster.scheduler_address}', chunk=1, store='{store}', progress=False)\n")
    proc = subprocess.Popen([PYTHON, str(script)])
    t0 = time.time()
    while not store.exists() or len(store.read_text().splitlines()) < 5:
        assert proc.poll() is None and time.time() - t0 < 60
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    kept = len(store.read_text().splitlines()) - 1
    law = resolve_law({"name": "slow_dask_law", "python": f"{law_file}:law", "n_uniforms": 1})
    resumed = gl.sweep([law], **GRID, engine="dask", scheduler=cluster.scheduler_address, store=store)
    assert resumed.attrs["resumed_rows"] >= kept and resumed.attrs["computed_rows"] == 24 - resumed.attrs["resumed_rows"]
    pd.testing.assert_frame_equal(gl.sweep([law], **GRID), resumed)


def test_a_scheduler_that_does_not_answer_is_reported_in_bounded_time():
    t0 = time.time()
    with pytest.raises(ValueError, match=r"scheduler = 'tcp://127.0.0.1:9' did not answer within 2 s"):
        gl.sweep("gated", n=[16], p=[0.1], engine="dask", scheduler="tcp://127.0.0.1:9", timeout=2)
    assert time.time() - t0 < 15


def test_local_cluster_from_workers_and_bad_arguments():
    a = gl.sweep(["gated"], n=[16, 1e3], p=[0.1], samples=5000, metrics=["tv"])
    b = gl.sweep(["gated"], n=[16, 1e3], p=[0.1], samples=5000, metrics=["tv"], engine="dask", workers=1)
    pd.testing.assert_frame_equal(a, b)
    with pytest.raises(ValueError, match="engine = 'spark'"):
        gl.sweep("gated", n=[16], p=[0.1], engine="spark")
    with pytest.raises(ValueError, match="engine = 'threads'"):
        gl.sweep("gated", n=[16], p=[0.1], scheduler="tcp://127.0.0.1:9")
    with pytest.raises(ValueError, match="workers = 0"):
        gl.sweep("gated", n=[16], p=[0.1], engine="dask", workers=0)


def test_a_shader_law_runs_on_dask_workers(cluster):
    # A shader law travels to the workers by its code (compiled again there, on their Vulkan device)
    # and gives the local table bit for bit.
    law = gl.shader_law(gl.shipped_shader("gated"), name="gated_hlsl_dask")
    kw = dict(laws=[law], n=[16, 100], p=[0.1, 0.5], metrics=["tv", "chi2_pvalue"], samples=20000, seed=3)
    pd.testing.assert_frame_equal(gl.sweep(**kw), gl.sweep(**kw, engine="dask", scheduler=cluster.scheduler_address))
