#!/usr/bin/env python3
"""`make bench`: WB16's method shader (wb16.glsl and wb16.hlsl, docs/math/glint_images.md#glint-wb16) over a
1920 x 1080 frame on the Vulkan device (lavapipe without a GPU) against its C++ float32 twin (every core;
the issue's goal: the shader within 10x of it) and its numpy twin on the same packed rows, and the
per-frame inputs it reads (frame_inputs: Scene.trace, the shading frame; frame_rows: the packing).

Prints seconds per frame (best of --repeats), the ratio shader / C++ twin, the share of pixels where the
shader and the C++ twin differ beyond the float32 allowance of the test, and the device's name. Exits 0
when measurements complete.
"""
from __future__ import annotations

import numpy as np

import glintlab as gl
from glintlab.api import method_shaders as MS
from glintlab.validation import scene_images as si

from timing import best, lit_scene_from_args


def main() -> int:
    setup = lit_scene_from_args(__doc__)
    if setup is None:
        return 0
    args, sc = setup
    inp, t_in = best(lambda: si.frame_inputs(sc), 1)
    (rows, _), t_pack = best(lambda: MS.frame_rows(inp, seed=1), args.repeats)
    method = MS.wb16_method()
    shader, t_sh = best(lambda: method.shade(rows), args.repeats)
    hlsl, t_hl = best(lambda: MS.wb16_method("hlsl").shade(rows), args.repeats)
    (value, pos), t_cpp = best(lambda: MS.wb16_twin(rows, return_lookup=True), args.repeats)
    _, t_np = best(lambda: MS.wb16_twin_numpy(rows), 1)
    tol = 8 * np.spacing(np.abs(pos).max(axis=1)) * 2 / np.sqrt(1 - MS.WB16_DEFAULTS["WB16_SPARKLE_SIZE"])
    beyond = ~(np.isnan(shader) & np.isnan(value)) & ~(np.abs(shader.astype(np.float64) - value) <= tol)
    same = np.array_equal(shader.view(np.uint32), hlsl.view(np.uint32))
    print(f"WB16 method shader on {method.device}, {args.scene} {sc.width} x {sc.height} ({rows.shape[0]} hit pixels,"
          f" {gl.get_num_threads()} threads for the C++ twin)")
    print(f"  frame_inputs (trace, shading frame)  {t_in:8.3f} s")
    print(f"  frame_rows (packing 32 words/pixel)  {t_pack:8.3f} s")
    print(f"  shader GLSL (transfers + kernel)     {t_sh:8.3f} s")
    print(f"  shader HLSL (transfers + kernel)     {t_hl:8.3f} s   {'bit-identical to GLSL' if same else 'DIFFERS from GLSL'}")
    print(f"  C++ float32 twin                     {t_cpp:8.3f} s   shader / C++ twin = {t_sh / t_cpp:.2f} (target <= 10)")
    print(f"  numpy float32 twin                   {t_np:8.3f} s   numpy / C++ twin = {t_np / t_cpp:.1f}")
    print(f"  pixels beyond the float32 allowance  {beyond.mean():.5%} (shader against the C++ twin)")
    print("PASS" if t_sh / t_cpp <= 10 else "FAIL")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
