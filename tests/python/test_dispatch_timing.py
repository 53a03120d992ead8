"""Device timings of the runner's dispatches (Vulkan timestamp queries, docs/guide/gpu_cost.md#timings-on-a-device),
on whatever device the runner finds (lavapipe here: the CPU threads' time of each dispatch)."""
from __future__ import annotations

import time

import numpy as np
import pytest

import glintlab as gl
from glintlab import _core

needs_vulkan = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (mesa-vulkan-drivers)")

# A method whose work per pixel is N iterations of a dependent chain (N a define): its time grows as N.
LOOP = """float glint(GlintInput g) {
  float acc = g.uv.x + 0.5;
  for (int i = 0; i < N; ++i) acc = sin(acc * 1.37 + g.uv.y) + cos(acc);
  return abs(acc); }"""
ROWS_PER_DISPATCH = 1 << 18  # the row kinds' chunk (shader_runner.cpp: kChunkRows / 4)


def _method(n: int):
    return gl.shader_method(LOOP, defines={"N": n}, register=False)


def _rows(m: int) -> np.ndarray:
    return np.zeros((m, _core.METHOD_INPUT_WORDS), dtype=np.uint32)


def _best_ms(method, rows, repeats: int = 3) -> float:
    method.run(rows[:64])  # lavapipe compiles the kernel at its first dispatch: not part of a timing
    return min(float(method.run(rows, timing=True)[1].sum()) for _ in range(repeats))


@needs_vulkan
def test_one_timing_per_dispatch_and_the_same_output():
    method = _method(4)
    rows = _rows(2 * ROWS_PER_DISPATCH + 1000)  # three dispatches
    plain = method.run(rows)  # no timing unless asked: the output alone
    assert isinstance(plain, np.ndarray)
    t0 = time.perf_counter()
    out, ms = method.run(rows, timing=True)
    wall_ms = 1e3 * (time.perf_counter() - t0)
    np.testing.assert_array_equal(out, plain)
    assert ms.shape == (3,) and np.all(np.isfinite(ms)) and np.all(ms >= 0)
    # The timestamps lie inside the call: their sum cannot exceed its wall time (a wrong tick period, or
    # raw ticks taken for milliseconds, would).
    assert ms.sum() <= wall_ms


@needs_vulkan
def test_a_dispatch_time_grows_with_its_work():
    # 16 times the iterations: the dispatch's time (the best of three, so that another process's use of
    # the cores does not decide it) at least 4 times the shorter one's, at most 64 times. Timestamps
    # written both before the dispatch (or read before the fence) would give a ratio near 1.
    rows = _rows(1 << 15)
    short, long_ = _best_ms(_method(64), rows), _best_ms(_method(1024), rows)
    assert 4 * short <= long_ <= 64 * short, (short, long_)
