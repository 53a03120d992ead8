#!/usr/bin/env python3
"""`make bench`: the direction-sampler harness on a spiky pdf (docs/math/sampling.md).

1e7 samples of the synthetic glinty pdf (200 von Mises-Fisher lobes 0.3 degree wide on the hemisphere,
``gl.sampler("vmf_mixture")``) through ``gl.sampler_test`` with adaptive bins: the time split
(sampling, binning, cubature, the pdf check), the bins and pdf evaluations, and the verdict. The goal is
under 30 s on 2 cores, cubature included. The same run at 1 thread and at all threads must give the
same p-value (determinism), checked at 1e6 samples. When a Vulkan device is present, also the shipped
GGX visible-normal shader sampler (docs/math/sampling.md#shader-samplers) against the numpy reference
``ggx_vndf``: draws per second (sample, with pdf) and pdf evaluations per second, as ratios. Writes
out/bench/sampler_test.json; exits 1 when the correct sampler fails or the two thread counts disagree.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import glintlab as gl


def _rate(fn, n: int, repeats: int = 3) -> float:
    """Calls per second of fn(n) (best of `repeats`), in items per second."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(n)
        best = min(best, time.perf_counter() - t0)
    return n / best


def shader_vs_reference(n: int = 10**6) -> dict | None:
    """The shipped GGX VNDF shader sampler (HLSL) against gl.sampler("ggx_vndf") at alpha 0.3,
    wo = (0.6, 0, 0.8): samples/s and pdf evaluations/s of each, and their ratios (shader / numpy)."""
    if not gl.vulkan_devices():
        return None
    wo = (0.6, 0.0, 0.8)
    shader = gl.shader_sampler(gl.shipped_sampler("ggx_vndf", "hlsl"), wo=wo)
    ref = gl.sampler("ggx_vndf", alpha=0.3, wo=wo)
    h, _ = ref.sample(n, seed=1)
    out = {"device": shader.device, "rows": n,
           "shader_samples_per_s": _rate(lambda m: shader.sample(m, seed=1), n),
           "numpy_samples_per_s": _rate(lambda m: ref.sample(m, seed=1), n),
           "shader_pdf_per_s": _rate(lambda m: shader.pdf(h[:m]), n),
           "numpy_pdf_per_s": _rate(lambda m: ref.pdf(h[:m]), n)}
    out["sample_ratio"] = out["shader_samples_per_s"] / out["numpy_samples_per_s"]
    out["pdf_ratio"] = out["shader_pdf_per_s"] / out["numpy_pdf_per_s"]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10**7)
    ap.add_argument("--out", default="out/bench")
    args = ap.parse_args()
    s = gl.sampler("vmf_mixture", lobes=200, width_deg=0.3)
    t0 = time.perf_counter()
    res = gl.sampler_test(s, samples=args.samples, seed=1)
    wall = time.perf_counter() - t0
    print(repr(res))
    before = gl.get_num_threads()
    gl.set_num_threads(1)
    one = gl.sampler_test(s, samples=min(args.samples, 10**6), seed=2)
    gl.set_num_threads(before)
    many = gl.sampler_test(s, samples=min(args.samples, 10**6), seed=2)
    record = {"samples": args.samples, "threads": before, "wall_s": wall, "goal_s": 30.0, **res.summary(),
              "deterministic": one.pvalue == many.pvalue and bool((one.observed == many.observed).all())}
    shader = shader_vs_reference()
    if shader is not None:
        record["shader_sampler"] = shader
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "sampler_test.json").write_text(json.dumps(record, indent=1, default=float))
    print(f"sampler_test: {args.samples:.3g} samples of a 200-lobe pdf in {wall:.1f} s (goal 30 s on 2 cores): "
          + ", ".join(f"{k} {v:.1f} s" for k, v in res.times.items()) + f"; {res.bins} bins, "
          f"{res.evaluations} pdf evaluations in the cubature; p = {res.pvalue:.3g}; "
          f"deterministic across threads: {record['deterministic']}")
    if shader is not None:
        print(f"shader sampler (ggx_vndf.hlsl on {shader['device']}) / numpy ggx_vndf: "
              f"{shader['sample_ratio']:.2f}x the samples/s ({shader['shader_samples_per_s']:.3g} vs "
              f"{shader['numpy_samples_per_s']:.3g}), {shader['pdf_ratio']:.2f}x the pdf evaluations/s "
              f"({shader['shader_pdf_per_s']:.3g} vs {shader['numpy_pdf_per_s']:.3g})")
    return 0 if res.passed and record["deterministic"] else 1


if __name__ == "__main__":
    sys.exit(main())
