"""The advisor's GPU axis (docs/guide/gpu_cost.md#the-advisor-on-the-gpu-axis): a law's cost per evaluation is its
shader twin's ACO latency on an RDNA3 null device, times the scheme's evaluations per pixel."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.gpu_cost import gpu_driver
from glintlab.cli.main import main
from glintlab.validation import profile as P
from glintlab.validation.advisor import gpu_law_cycles

needs_radv = pytest.mark.skipif(bool(gpu_driver()["error"]) or not gl.vulkan_devices(),
                                reason="no RADV (mesa-vulkan-drivers) or no Vulkan device to build the kernels")

LAWS = ["binomial", "gated_shader", "head_cf", "dual_gated"]
# CPU costs in another order than the GPU's (fixed: no timing), so that an advisor that kept the CPU costs
# on the GPU axis would rank the laws differently.
COSTS = {"binomial": 1.0, "gated_shader": 50.0, "head_cf": 2.0, "dual_gated": 3.0}
SCHEME = "db23_tetrahedral"


def scene_doc():
    """A small grazing plane (n p from 0 to about 40: every regime of the laws)."""
    e = math.radians(25)
    pos = [0.0, -2 * math.cos(e), 2 * math.sin(e)]
    return {"camera": {"resolution": [48, 27], "fov_deg": 60, "position": pos, "look_at": [0, 0, 0], "up": [0, 0, 1]},
            "primitive": {"type": "plane"}, "light": {"type": "point", "position": [0.5, pos[1], pos[2] + 0.5]},
            "material": {"density": 40 * 4194304.0 / 900}}


@pytest.fixture(scope="module")
def profile():
    return P.profile_scene(scene_doc(), laws=LAWS, costs=COSTS, seed=3, schemes=(SCHEME,))


@needs_radv
def test_gpu_costs_are_the_shader_twins_cycles_times_the_evaluations(profile):
    cycles = gpu_law_cycles("gfx1100")
    assert set(cycles) == {"dual_gated", "gated_continuous", "gated_shader", "head_cf"}  # the shader twins
    a = gl.advise(profile, max_tv=math.inf, cost_axis="gpu")
    cand = a.candidates.set_index("law")
    assert "binomial" not in cand.index  # no shader: no GPU cost
    for law in cand.index:  # one evaluations map for every law: the group cost is cycles x its group's evaluations
        group = P.simd_stats(np.where(profile.valid, profile.evaluations[SCHEME] * cycles[law], 0.0), profile.valid)
        assert cand.loc[law, "cost_mean_group"] == pytest.approx(group["mean_group"], rel=1e-12)
    assert a.law == min((cycles[law], law) for law in cand.index)[1]
    assert gl.advise(profile, max_tv=math.inf).law == "binomial"  # the CPU axis keeps its own costs
    assert a.cost_axis == "gpu" and "ACO cycles on gfx1100" in str(a)


@needs_radv
def test_a_budget_no_shader_law_meets_is_refused_naming_it(profile):
    with pytest.raises(ValueError, match=r"max_tv = 0.0 is invalid; expected a budget one of the laws with a GPU cost"):
        gl.advise(profile, max_tv=0.0, cost_axis="gpu")
    with pytest.raises(ValueError, match="cost_axis"):
        gl.advise(profile, max_tv=0.1, cost_axis="tpu")


@needs_radv
def test_advise_cli_cost_axis(tmp_path, capsys):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene_doc()))
    assert main(["advise", str(path), "--max-tv", "inf", "--json", "--cost-axis", "gpu", "--scheme", SCHEME]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cost_axis"] == "gpu" and out["gpu_arch"] == "gfx1100"
    assert out["law"] in gpu_law_cycles("gfx1100")
