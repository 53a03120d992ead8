"""The GPU compiler statistics (RADV null devices, docs/guide/gpu_cost.md) and the per-wave cost model
(docs/guide/gpu_cost.md#the-per-wave-cost-model), each part on shaders with known answers."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.gpu_cost import compile_stats, gpu_driver
from glintlab.validation import gpu_model as M

needs_radv = pytest.mark.skipif(bool(gpu_driver()["error"]) or not gl.vulkan_devices(),
                                reason="no RADV (mesa-vulkan-drivers) or no Vulkan device to build the kernel")

LOOP = """float count(float n, float p, float4 u) {
  float acc = u.x;
  for (int i = 0; i < int(n); ++i) acc = sin(acc * 1.37 + p) * u.y + cos(acc);
  return acc; }"""


def _pressure(k):
    """A law keeping k values live at once: more VGPRs as k grows."""
    body = [f"  float a{i} = sin(u.x * {i + 1}.37 + p) * n;" for i in range(k)]
    body += ["  float s = 0.0;"] + [f"  s = s * a{(i * 7) % k} + a{i} * a{k - 1 - i};" for i in range(k)]
    return "float count(float n, float p, float4 u) {\n" + "\n".join(body) + "\n  return s; }"


@needs_radv
def test_statistics_per_architecture_with_the_wrapper_apart():
    t = gl.gpu_cost("gated", arch=["navi21", "gfx1100", "polaris10"])
    assert list(t.arch) == ["navi21", "gfx1100", "polaris10"]
    for col in ("instructions", "vgprs", "sgprs", "spilled_vgprs", "waves_per_simd", "latency", "inverse_throughput",
                "code_size", "driver"):
        assert col in t.columns, col
    assert t.driver.str.startswith("radv Mesa").all()
    assert list(t.wave_size) == [32, 32, 64]  # RDNA compiled for wave32, GCN for wave64
    assert (t.wrapper_latency > 0).all() and (t.function_latency > 0).all()
    np.testing.assert_array_equal(t.function_latency, t.latency - t.wrapper_latency)
    # A heavier function over the same wrapper: the wrapper's share is the same, the function's grows.
    heavy = gl.gpu_cost("db23_shader", arch=["gfx1100"])
    assert heavy.function_latency.iloc[0] > 10 * t.function_latency.iloc[1]


@needs_radv
def test_unknown_architecture_and_missing_driver_are_one_line_exit_2():
    with pytest.raises(ValueError, match="unknown architecture 'navi99'; known: polaris10"):
        gl.gpu_cost("gated", arch="navi99")
    env = dict(os.environ, GLINTLAB_RADV_LIBRARY="/nonexistent/libvulkan_radeon.so")
    for argv, env_ in ((["gated", "--arch", "navi99"], None), (["gated"], env)):
        r = subprocess.run([sys.executable, "-m", "glintlab.cli.main", "cost", *argv], capture_output=True,
                           text=True, env=env_)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert "gfx1100" in r.stderr and "Traceback" not in r.stderr


@needs_radv
def test_a_loop_of_n_iterations_costs_linearly_in_n():
    row = gl.gpu_cost(gl.shader_law(LOOP, register=False), arch="gfx1100", isa=True, wrapper=False).iloc[0]
    k = M.KernelCost.from_stats(row.to_dict())
    assert k.n_loops == 1
    fixed, per = k.loop_cycles()
    assert fixed > 0 and per[0] > 0
    cost = [float(k.wave_cycles([np.full((1, 32), n)])[0]) for n in (1, 2, 4, 8, 16)]
    np.testing.assert_allclose(np.diff(cost) / np.diff([1, 2, 4, 8, 16]), per[0])
    assert cost[3] == pytest.approx(row.inverse_throughput)  # ACO assumes 8 iterations: its own estimate back
    # A wave costs its slowest lane: one lane at 16 iterations costs the wave 16.
    lanes = np.ones((1, 32))
    lanes[0, 5] = 16
    assert float(k.wave_cycles([lanes])[0]) == pytest.approx(cost[4])


@needs_radv
def test_more_registers_fewer_waves_and_a_costlier_frame():
    rows = [gl.gpu_cost(gl.shader_law(_pressure(k), register=False), arch="navi21", wrapper=False).iloc[0]
            for k in (8, 64, 128)]
    vgprs = [r.vgprs for r in rows]
    waves = [r.waves_per_simd for r in rows]
    assert vgprs[0] < vgprs[1] < vgprs[2] and waves[0] > waves[1] > waves[2], (vgprs, waves)
    assert rows[0].inverse_throughput < rows[1].inverse_throughput < rows[2].inverse_throughput


def test_waves_tile_the_screen_and_spread_over_the_gpu():
    mask = np.zeros((8, 16), bool)
    mask[:4, :8] = True  # one wave32 tile lit
    vals, lanes = M.tiles(np.arange(128.0).reshape(8, 16), mask, 32)
    assert vals.shape == (1, 32) and lanes.all()
    assert M.tiles(np.ones((8, 16)), np.ones((8, 16), bool), 64)[0].shape == (2, 64)
    arch = {"compute_units": 10, "simds_per_cu": 2, "clock_mhz": 1000.0}
    cycles = np.full(40, 1000.0)
    assert M.frame_seconds(cycles, arch) == pytest.approx(2e-6)
    assert M.frame_seconds(cycles, dict(arch, compute_units=20)) == pytest.approx(1e-6)


def test_isa_blocks_and_nested_loops():
    isa = "\n".join(["BB0:", "v_add_f32 v0, v1, v2", "BB1:", "v_sin_f32 v0, v0", "BB2:", "s_add_u32 s0, s0, 1",
                     "s_cbranch_scc1 BB2", "s_waitcnt vmcnt(0)", "s_branch BB1", "BB3:", "s_endpgm"])
    k = M.parse_isa(isa, 32)
    assert [(lp.start, lp.end, lp.depth, lp.parent) for lp in k.loops] == [(1, 2, 1, -1), (2, 2, 2, 0)]
    np.testing.assert_array_equal(k.cycles, [1, 4, 3, 0])
    assert M.parse_isa(isa, 64).cycles[1] == 16  # a quarter-rate op of a wave64 on GCN's SIMD16


def test_zk16_trip_counts_are_the_twins():
    # The model's probes are the C++ zk16_aniso scheme's terms (2 evaluations each, one per level) and its
    # trials the zk16 law's own work units at each level's trial count, pixel for pixel.
    from glintlab.api import counting_shaders as CS
    from glintlab.api import zk16_shaders as Z
    from glintlab.validation import gpu_frames as F
    from glintlab.validation import method_twins as MT
    rows, material = MT.scene_rows("heightfield_25", 0.03, seed=1)
    px = F.pixels_of(rows, material)
    probes, lower, upper = F.zk16_trip_counts(px, material.density)
    uv, J, _, _ = CS.tangent_inputs(rows)
    counts = Z.zk16_twin_ndf(material).counter.count_image(uv, J, material.density, px.p, seed=0)
    ok = counts.status == 0
    assert ok.mean() > 0.9 and probes.max() > 1  # anisotropic footprints among them
    np.testing.assert_array_equal(counts.evaluations[ok], 2 * probes[ok])
    law = gl.law("zk16")
    major, minor, _ = F._axes(px.J)
    area = np.pi * major * np.maximum(minor, major / 16) / probes
    lo = np.floor(0.5 * np.log2(area * material.density))
    for lv, trials in ((0, lower), (1, upper)):
        expected = [law.work_units(4.0 ** (lv + lev), p) for lev, p in zip(lo[ok], px.p[ok])]
        np.testing.assert_array_equal(trials[ok], expected)
    # A wrong trip count (one probe per pixel) is caught by the same comparison.
    assert not np.array_equal(counts.evaluations[ok], 2 * np.ones(ok.sum()))


@needs_radv
def test_architectures_on_threads_give_the_single_compiles_statistics():
    # gpu_cost compiles every architecture on a thread of its own (compile_stats_many); each row must be
    # what one compile on this thread gives (same SPIR-V, same driver: the same statistics).
    law = gl.shader_law(LOOP, register=False)
    archs = ["navi21", "polaris10", "gfx1100"]
    table = gl.gpu_cost(law, arch=archs, wrapper=False)
    for arch, row in zip(archs, table.itertuples()):
        one = compile_stats(law.spirv, arch)
        assert row.arch == arch
        for col in ("instructions", "vgprs", "sgprs", "waves_per_simd", "latency", "inverse_throughput", "code_size"):
            assert getattr(row, col) == one[col], (arch, col)
