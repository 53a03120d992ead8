#!/usr/bin/env python3
"""Writes python/glintlab/data/pipelines/*.json: one pipeline per built-in glint configuration, every stage
bounded, recorded from the values measured now (``glintlab check PIPELINE.json --record``).

The configurations: DB23 as its paper ships it (the gated Gaussian, the distributed blend, the trilinear
grid, its public shader as a method checked against its C++ twin), DB23 with its shader's 48 evaluations
(tetrahedral, log LOD, realizations blended), ZK16 (its law, linear blending of outputs, its anisotropic
mip probes, its method shader), KPT25 (its constant-time NDF, roulette LOD, its method shader) and
WWH18's filtered model. Each pipeline states its margin rule (data/schema/pipeline.schema.json,
"margin"): maximum = (measured + 3 standard errors) x 1.25 + 1e-9, rounded up to 3 significant digits;
a sampler's chi-square p-value keeps its 1e-3 level. Re-running the script re-records every file and
prints what changed; .ci/run checks them (make bench times them: bench/bench_pipeline.py).

Run: .venv/bin/python scripts/make_pipelines.py [NAME ...]  (then review the diff of the files)
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import glintlab as gl
from glintlab.studies import pipeline_metrics  # noqa: F401  (registers the built-in metrics)
from glintlab.validation.pipeline import format_diff, record

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "python" / "glintlab" / "data" / "pipelines"
LAW_BOUNDS = [{"metric": "tv"}, {"metric": "mean_rel_err"}]
SHADER_BOUNDS = [{"metric": "twin_rows"}, {"metric": "gpu_instructions"}, {"metric": "gpu_vgprs"}]
BLEND_BOUNDS = [{"metric": "blend_tv"}, {"metric": "blend_pop_rate"}]
GRID_BOUNDS = [{"metric": "grid_count_bias"}, {"metric": "grid_var_ratio_err"}]
METHOD_BOUNDS = [{"metric": "mean_d_err"}, {"metric": "furnace_err"}, {"metric": "scene_std_ratio_err"},
                 {"metric": "scene_pop_rate"}, {"metric": "light_response"}]
METHOD_SHADER_BOUNDS = [{"metric": "twin_pixels"}, {"metric": "gpu_instructions"}, {"metric": "gpu_vgprs"}]
# The scene metrics' scene: the shipped sphere at a tenth of its resolution per side, 4 frames of its path.
SCENE = {"file": "sphere", "scale": 0.1, "frames": 4}
SAMPLER_BOUNDS = [{"metric": "sampler_pvalue"}, {"metric": "sampler_normalization"}, {"metric": "sampler_pdf_mismatch"}]
# Where the laws are used: a renderer's footprints hold from a few to 10^6 facets, p from 1e-4 to 0.5.
LAW_RANGE = {"n": {"logspace": [0, 6, 13]}, "p": {"logspace": [-4, -0.30103, 9]}}
MATERIAL = {"density": 1e6, "target": "beckmann", "alpha": 0.5, "R": 0.5}
METHOD_RANGE = {"theta_h_deg": [10, 30], "points": [30, 1000], "anisotropy": [1, 4], "theta_o_deg": [0, 60]}


def law(name: str) -> dict:
    """The C++ law over LAW_RANGE narrowed to the regime its code declares it is meant for (its first
    LawTraits bound, as scripts/make_bounds.py): a bound where its error already reaches 1 could never fail."""
    regime = gl.law_traits(name)["bounds"][0]["regime"]
    rng = {**LAW_RANGE, **{key: [float(lo), min(float(hi), 1e300)] for key, (lo, hi) in regime.items()}}
    return {"id": "law", "kind": "law", "law": name, "range": rng, "bounds": list(LAW_BOUNDS)}


def shader(name: str, twin: str) -> dict:
    return {"id": "law_shader", "kind": "law", "law": {"shader": f"../shaders/{name}.hlsl"}, "twin": twin,
            "range": {"n": [8, 1000], "p": [0.1, 0.5]}, "bounds": [{"metric": "tv"}] + SHADER_BOUNDS}


def blend(name: str, inner: str, **params) -> dict:
    spec = {"name": name, "params": params} if params else name
    return {"id": "blend", "kind": "blend", "blend": spec, "inner": inner, "bounds": list(BLEND_BOUNDS),
            "range": {"cases": [[64, 16, 0.1], [64, 16, 0.5], [256, 256, 0.01]], "weights": [0.25, 0.5, 0.75],
                      "paths": 1000, "steps": 32}}


def grid(scheme: str, inner: str) -> dict:
    return {"id": "grid", "kind": "grid", "scheme": scheme, "inner": inner, "bounds": list(GRID_BOUNDS),
            "samples": 20000}


def method(name: str, **extra) -> dict:
    return {"id": "method", "kind": "method", "method": name, "material": MATERIAL, "range": METHOD_RANGE,
            "bounds": list(METHOD_BOUNDS), "pixels": 4000, "scene": SCENE, **extra}


def method_shader(name: str) -> dict:
    """A shipped method shader against its C++ twin on one frame of the plane (pixel by pixel), with its cost."""
    return {"id": "method_shader", "kind": "method", "method": name, "twin": name,
            "scene": {"file": "plane_25", "scale": 0.1, "frames": 2}, "bounds": list(METHOD_SHADER_BOUNDS)}


def sampler(name: str = "beckmann_vndf", alpha: float = 0.5) -> dict:
    return {"id": "sampler", "kind": "sampler", "sampler": {"name": name, "params": {"alpha": alpha}},
            "wo": [0.6, 0.0, 0.8], "samples": 1000000, "bounds": list(SAMPLER_BOUNDS)}


CONFIGURATIONS = {
    "db23_paper": ("DB23 as its paper ships it: the gated Gaussian (C++ and the shipped HLSL shader), the distributed "
                   "binomial blend, the trilinear grid and D_P on it, visible Beckmann normals",
                   [law("gated"), shader("gated", "gated_shader"), blend("distributed", "gated"),
                    grid("db23_trilinear", "gated"), method("db23_trilinear[gated]"), method_shader("db23_shader"),
                    sampler()]),
    "db23_shader_48": ("DB23 as its shader runs: tetrahedral grid with log LOD weights, realizations blended over 3 "
                       "simplex vertices x 4 angular texels (48 evaluations), the gated Gaussian",
                       [law("gated"), shader("gated", "gated_shader"), blend("distributed", "gated"),
                        grid("db23_shader_48", "gated"), method("db23_shader_48[gated]"), sampler()]),
    "zk16": ("ZK16: its counting law, linear blending of outputs between LOD levels, its anisotropic mip probes",
             [law("zk16"), blend("zk16_linear", "zk16"), grid("zk16_aniso", "zk16"), method("zk16"),
              method_shader("zk16_shader"), sampler()]),
    "kpt25": ("KPT25: the constant-time glinty NDF over its own point process, roulette LOD (epsilon 0.1)",
              [blend("roulette", "binomial", epsilon=0.1), method("kpt25"), method_shader("kpt25_shader"),
               sampler("ggx_vndf", 0.3)]),
    "wwh18_filtered": ("WWH18: the discrete-flake model, filtered (its count replaced by its mean) above the "
                       "threshold", [method("wwh18"), sampler()]),
}


def pipeline(name: str) -> dict:
    description, stages = CONFIGURATIONS[name]
    return {"glintlab": 1, "name": name, "description": description + ". Recorded by scripts/make_pipelines.py.",
            "seed": 1, "margin": {"noise": 3, "relative": 0.25, "absolute": 1e-9, "digits": 3}, "stages": stages}


def main(names) -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    for name in names or CONFIGURATIONS:
        path = OUT / f"{name}.json"
        if path.exists():  # re-recording keeps the file's earlier bounds, so the diff shows what moved
            old = json.loads(path.read_text(encoding="utf-8"))
            doc = pipeline(name)
            doc["stages"] = _with_bounds(doc["stages"], old["stages"])
        else:
            doc = pipeline(name)
        path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        _, table, diff = record(path)
        print(f"{name}: {len(table)} bounds, {table.seconds.sum():.1f} s\n{format_diff(diff)}")
    return 0


def _with_bounds(stages: list, old: list) -> list:
    """The configuration's stages with the limits the earlier file recorded (same stage id and metric)."""
    earlier = {(s["id"], b["metric"]): b for s in old for b in s["bounds"]}
    for s in stages:
        s["bounds"] = [dict(earlier.get((s["id"], b["metric"]), b)) for b in s["bounds"]]
    return stages


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
