#!/usr/bin/env python3
"""Every method shader of DB23's Table 1 and KPT25's Table 3 timed on the Vulkan device the runner finds,
against the per-wave GPU cost model's prediction (docs/guide/gpu_cost.md#the-per-wave-cost-model).

On a machine with a GPU: ``python bench/bench_gpu_methods.py --arch navi21`` times each method shader
(no glints, DB23, ZK16, ZK16*, KPT25) on each shipped scene at 1080p (``--scale 1``): the device's own
time of its dispatches, from Vulkan timestamps written before and after each (``ShaderMethod.run(rows,
timing=True)``; the upload and read-back outside), the best of ``--repeats`` calls, with the call's wall
time beside it. It prints the model's ms for ``--arch`` beside the measured ms and the rank agreement of the
two (Spearman's rho and Kendall's tau, scipy.stats) per scene and overall: does the model order the methods
and scenes as the device does? An AMD GPU of the named architecture is the fair test; another vendor's ranks
say how far the model carries. Without a GPU it runs on lavapipe (use a small ``--scale``): its timestamps
are then the time llvmpipe's CPU threads took for each dispatch, so the ranks compare the model with a CPU
running the same SPIR-V, not with a GPU.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np
import pandas as pd
from scipy.stats import kendalltau, spearmanr

import glintlab as gl
from glintlab.api.glinty_ndf import Material, make_method
from glintlab.validation import method_twins as MT
from glintlab.validation.gpu_frames import METHODS, frame_cost, pixels_of
from glintlab.validation.gpu_model import KernelCost

SCENES = ("sphere", "plane_90", "plane_25", "heightfield_90", "heightfield_25")


def measure(method, rows, repeats: int) -> tuple[float, float]:
    """(device ms, wall ms): the best of ``repeats`` calls, the device's time summed over the call's dispatches."""
    method.shade(rows[:64])  # compiled and warm (lavapipe compiles at the first dispatch)
    device, wall = float("inf"), float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        _, ms = method.run(rows, timing=True)
        wall = min(wall, 1e3 * (time.perf_counter() - t))
        device = min(device, float(ms.sum()))
    return device, wall


def agreement(measured, model) -> dict:
    """Spearman's rho and Kendall's tau of the model's ms against the measured ms."""
    return {"spearman": float(spearmanr(measured, model)[0]), "kendall": float(kendalltau(measured, model)[0])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", default="gfx1100", help="the architecture the model costs (default: gfx1100)")
    ap.add_argument("--scale", type=float, default=1.0, help="share of 1080p per axis (default: 1)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", help="also write the table as JSON")
    args = ap.parse_args(argv)
    arch = gl.gpu_architectures().set_index("arch").loc[args.arch].to_dict() | {"arch": args.arch}
    kernels = {m: KernelCost.from_stats(gl.gpu_cost(m, arch=args.arch, isa=True, wrapper=False).iloc[0].to_dict())
               for m in METHODS}
    rows_out = []
    for scene in SCENES:
        rows, material = MT.scene_rows(scene, args.scale, seed=1)
        px = pixels_of(rows, material)
        for name, label in METHODS.items():
            method = make_method(name, Material(material.density, material.target, material.alpha, material.R,
                                                material.angular_texel))
            model = frame_cost(name, kernels[name], px, material.density, arch)["seconds"] * 1e3
            device_ms, wall_ms = measure(method, rows, args.repeats)
            rows_out.append({"scene": scene, "method": label, "measured_ms": device_ms, "wall_ms": wall_ms,
                             "model_ms": model, "device": method.device, "device_type": method.device_type})
            print(f"{scene:15s} {label:14s} measured {device_ms:9.3f} ms (call {wall_ms:9.3f} ms)   "
                  f"model {model:8.4f} ms", flush=True)
    table = pd.DataFrame(rows_out)
    per_scene = {s: agreement(g.measured_ms, g.model_ms) for s, g in table.groupby("scene")}
    overall = agreement(table.measured_ms, table.model_ms)
    cpu = table.device_type.iloc[0] == "cpu"
    print(f"device: {table.device.iloc[0]} ({table.device_type.iloc[0]}"
          f"{': its timestamps are CPU time, not a GPU' if cpu else ''}); model: {args.arch} ({arch['gpu']}); "
          f"scale {args.scale}")
    print("rank agreement, model against measured (Spearman / Kendall): " +
          ", ".join(f"{s} {a['spearman']:+.2f}/{a['kendall']:+.2f}" for s, a in per_scene.items()) +
          f"; overall {overall['spearman']:+.2f}/{overall['kendall']:+.2f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows_out, "per_scene": per_scene, "overall": overall}, f, indent=1)
    return 0 if np.isfinite(overall["spearman"]) else 1


if __name__ == "__main__":
    sys.exit(main())
