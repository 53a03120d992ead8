#!/usr/bin/env python3
"""`make bench`: DB23's counting pipeline and KPT25's Algorithm 1 as method shaders (db23_method.glsl,
kpt25_method.glsl, one body each with their .hlsl wrappers; docs/math/glint_images.md#glint-db23-shader,
docs/math/glint_images.md#glint-kpt25-shader)
over a 1920 x 1080 frame on the Vulkan device (lavapipe without a GPU), each against its C++ twin
(glintlab's DB23 on the trilinear grids with the gated_shader law; glintlab's KPT25) on the same packed
float32 rows, all threads.

Prints seconds per frame (best of --repeats), the ratio shader / twin (issue goal: within 10x), the
share of pixels beyond the float32 allowance of the tests, and the device's name. Exits 0 when the
measurements complete (FAIL is printed, not returned, where a ratio exceeds 10).
"""
from __future__ import annotations

import dataclasses

from glintlab.api import counting_shaders as CS
from glintlab.api.glinty_ndf import Material, method_density
from glintlab.api.method_shaders import frame_rows
from glintlab.validation import scene_images as si

from timing import best, lit_scene_from_args


def main() -> int:
    setup = lit_scene_from_args(__doc__)
    if setup is None:
        return 0
    args, sc = setup
    inp = si.frame_inputs(sc)
    rows, _ = frame_rows(dataclasses.replace(inp, hit=inp.mask), seed=1)
    facets = Material.of(sc)
    kpt = dataclasses.replace(facets, density=method_density("kpt25_shader", facets))
    ok = True
    for name, material, method, twin, mismatch in (
            ("DB23", facets, CS.db23_method(facets), CS.db23_twin, CS.twin_mismatch),
            ("KPT25", kpt, CS.kpt25_method(kpt), CS.kpt25_twin, CS.kpt25_mismatch)):
        method.shade(rows[:64])  # compile and warm the pipeline outside the timing
        shader, t_sh = best(lambda: method.shade(rows), args.repeats)
        value, t_tw = best(lambda: twin(rows, material), args.repeats)
        r = mismatch(shader, value, rows, material)
        ratio = t_sh / t_tw
        ok &= ratio <= 10
        print(f"{name} method shader on {method.device}, {args.scene} {sc.width} x {sc.height} ({rows.shape[0]} lit pixels)")
        print(f"  shader (transfers + kernel)          {t_sh:8.3f} s")
        print(f"  C++ twin (all threads)               {t_tw:8.3f} s   shader / twin = {ratio:.2f} (target <= 10)")
        print(f"  pixels beyond the float32 allowance  {r['share']:.5%} (beyond 1 %: {r['share_1pct']:.5%})")
    print("PASS" if ok else "FAIL")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
