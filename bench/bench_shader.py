#!/usr/bin/env python3
"""`make bench`: the shipped shaders on the Vulkan device against their C++ twins (issue: shader laws).

One run measures, on the default device (lavapipe without a GPU; the same script prints a GPU's figure
where there is one):
  compile    gl.shader_law(gated.hlsl) in a fresh process: shaderc's compile and the pipeline's
             creation (target: under 1 s), and the same call again (the cache by hash: a preprocess);
  batch      law.sample(n, p, size=--size) of the shader (Philox uniforms, their float32 conversion,
             the transfers to and from the device and the kernel) against law.sample(..., precision=
             "float32") of its C++ twin (the same uniforms and arithmetic on the CPU, all threads),
             and the twin's default law.sample (float64: for gated_shader the same values, which
             it computes in float; for head_cf its double-precision law with table inversion), at
             DB23's Figure 9 points; the ratios shader / twin (target for gated: at most 10).
Each time is the best of --repeats calls, shader and twin interleaved. Reported as ns per evaluation
and ratios, with the device's name; PASS/FAIL is printed, and the script exits 0 when measurements
complete.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

import glintlab as gl
from glintlab.api.shaders import shipped_shader, shipped_shaders, shipped_twin

POINTS = [(8, 0.1), (8, 0.5), (1000, 0.002), (1000, 0.5)]

COMPILE = """
import time, glintlab as gl
path = gl.shipped_shader("gated")
t0 = time.perf_counter(); law = gl.shader_law(path, name="bench_a"); t1 = time.perf_counter()
gl.shader_law(path, name="bench_b"); t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=10**7)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default="out/bench")
    args = ap.parse_args()
    first, cached = map(float, subprocess.run([sys.executable, "-c", COMPILE], capture_output=True, text=True,
                                              check=True).stdout.split())
    rows = []
    for name in shipped_shaders():
        for language in ("hlsl", "glsl"):
            law = gl.shader_law(shipped_shader(name, language), name=f"bench_{name}.{language}")
            twin = shipped_twin(name)
            for n, p in POINTS:
                law.sample(n, p, size=1024, seed=1)
                ts, tc, td = [], [], []
                for r in range(args.repeats):
                    t0 = time.perf_counter()
                    law.sample(n, p, size=args.size, seed=r)
                    t1 = time.perf_counter()
                    twin.sample(n, p, size=args.size, seed=r, precision="float32")
                    t2 = time.perf_counter()
                    twin.sample(n, p, size=args.size, seed=r)
                    t3 = time.perf_counter()
                    ts.append(t1 - t0)
                    tc.append(t2 - t1)
                    td.append(t3 - t2)
                rows.append(dict(shader=f"{name}.{language}", twin=twin.name, device=law.device, n=n, p=p,
                                 shader_ns=min(ts) / args.size * 1e9, twin_ns=min(tc) / args.size * 1e9,
                                 twin_default_ns=min(td) / args.size * 1e9))
    table = pd.DataFrame(rows)
    table["ratio"] = table.shader_ns / table.twin_ns
    table["ratio_default"] = table.shader_ns / table.twin_default_ns
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "shader_bench.csv", index=False)
    summary = {"device": table.device[0], "size": args.size, "compile_s": first, "cached_s": cached,
               "gated_hlsl_worst_ratio": float(table[table.shader == "gated.hlsl"].ratio.max()),
               "gated_hlsl_worst_ratio_default": float(table[table.shader == "gated.hlsl"].ratio_default.max())}
    (out / "shader_bench.json").write_text(json.dumps(summary, indent=1) + "\n")
    with pd.option_context("display.width", 200):
        print(table.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"\ndevice: {summary['device']}; {args.size:.0e} evaluations per call")
    print(f"compile + pipeline, fresh process: {first:.3f} s ({'PASS' if first < 1 else 'FAIL'}: target < 1 s); "
          f"again (cache by hash): {cached:.3f} s")
    worst = summary["gated_hlsl_worst_ratio"]
    print(f"gated.hlsl / gated_shader (C++ float32), worst point: {worst:.3g}x "
          f"({'PASS' if worst <= 10 else 'FAIL'}: target at most 10x)")
    worst = summary["gated_hlsl_worst_ratio_default"]
    print(f"gated.hlsl / gated_shader (C++ default sample), worst point: {worst:.3g}x "
          f"({'PASS' if worst <= 10 else 'FAIL'}: target at most 10x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
