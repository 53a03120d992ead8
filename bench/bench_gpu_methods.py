#!/usr/bin/env python3
"""Every method shader of DB23's Table 1 and KPT25's Table 3 timed on the Vulkan device the runner finds,
against the per-wave GPU cost model's prediction (docs/guide/gpu_cost.md#the-per-wave-cost-model).

On a machine with a GPU: ``python bench/bench_gpu_methods.py --arch navi21`` times each method shader
(no glints, DB23, ZK16, ZK16*, KPT25) on each shipped scene at 1080p (``--scale 1``), the best of
``--repeats`` calls of the runner (wall clock around one dispatch of every lit pixel, upload and read-back
included: the runner has no timestamp queries yet), and prints the model's ms for ``--arch`` beside it and
the Spearman rank correlation of the two per scene and overall: does the model order the methods as the
device does? An AMD GPU of the named architecture is the fair test; another vendor's ranks say how far
the model carries. Without a GPU it runs on lavapipe (use a small ``--scale``: lavapipe is the CPU).
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np
import pandas as pd
from scipy.stats import spearmanr

import glintlab as gl
from glintlab.api.glinty_ndf import Material, make_method
from glintlab.validation import method_twins as MT
from glintlab.validation.gpu_frames import METHODS, frame_cost, pixels_of
from glintlab.validation.gpu_model import KernelCost

SCENES = ("sphere", "plane_90", "plane_25", "heightfield_90", "heightfield_25")


def measure(method, rows, repeats: int) -> float:
    method.shade(rows[:64])  # compiled and warm
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        method.shade(rows)
        best = min(best, time.perf_counter() - t)
    return best


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
            rows_out.append({"scene": scene, "method": label, "measured_ms": 1e3 * measure(method, rows, args.repeats),
                             "model_ms": model, "device": method.device})
            print(f"{scene:15s} {label:14s} measured {rows_out[-1]['measured_ms']:9.3f} ms   model {model:8.4f} ms",
                  flush=True)
    table = pd.DataFrame(rows_out)
    per_scene = {s: float(spearmanr(g.measured_ms, g.model_ms)[0]) for s, g in table.groupby("scene")}
    overall = float(spearmanr(table.measured_ms, table.model_ms)[0])
    print(f"device: {table.device.iloc[0]}; model: {args.arch} ({arch['gpu']}); scale {args.scale}")
    print("Spearman rank correlation, model against measured: " +
          ", ".join(f"{s} {r:+.2f}" for s, r in per_scene.items()) + f"; overall {overall:+.2f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows_out, "spearman_per_scene": per_scene, "spearman": overall}, f, indent=1)
    return 0 if np.isfinite(overall) else 1


if __name__ == "__main__":
    sys.exit(main())
