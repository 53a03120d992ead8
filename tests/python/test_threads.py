"""The package makes idle OpenMP workers sleep (OMP_WAIT_POLICY=passive, glintlab/_openmp.py) before the
OpenMP runtime loads, unless the environment chose a policy; results do not depend on the thread count."""
import os
import subprocess
import sys

import numpy as np

import glintlab as gl
from glintlab import _core


def policy_after_import(env_value):
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if env_value is not None:
        env["OMP_WAIT_POLICY"] = env_value
    code = ("import os, glintlab\n"
            "maps = open('/proc/self/maps').read()\n"
            "print(os.environ.get('OMP_WAIT_POLICY'), 'libgomp' in maps or 'libomp' in maps)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    return out.split()


def test_import_sets_a_passive_wait_policy_before_the_runtime_loads():
    assert policy_after_import(None) == ["passive", "True"]


def test_a_policy_the_environment_chose_is_kept():
    assert policy_after_import("active") == ["active", "True"]


def test_short_and_long_batches_give_the_same_bits_on_one_and_two_threads():
    lw = gl.law("gated")
    rng = np.random.default_rng(4)
    before = _core.num_threads()
    try:
        for size in (1000, 16383, 16384, 100_000):  # below, at and above the drivers' serial threshold
            n, p = np.exp(rng.uniform(0, 8, size)), rng.uniform(0, 0.5, size)
            runs = []
            for threads in (1, 2):
                _core.set_num_threads(threads)
                runs.append((lw.sample(30.0, 0.2, size=size, seed=9), lw.sample(n, p, seed=9)))
            assert all(np.array_equal(a, b) for a, b in zip(*runs))
    finally:
        _core.set_num_threads(before)
