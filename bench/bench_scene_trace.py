#!/usr/bin/env python3
"""`make bench`: the per-frame inputs' ray tracing, ``Scene.trace`` (C++, core/src/scene/scene_trace.cpp), over every
pixel of each shipped scene at 1920 x 1080, against one per-pixel gated evaluation per pixel
(``gl.law("gated").sample(n_array, p_array)`` on as many random (n, p) of the standard grid: what the
issue's goal is stated in, trace within 2x of it), beside the numpy form ``Scene.trace_numpy`` and the
largest relative difference between the two (float64 rounding: numpy's vector sin, cos and atan2 are
not the C library's).

Prints seconds per frame (best of --repeats) and the ratios, on glintlab's default threads. A
benchmark, not a test: exits 0 when the measurements complete (each row says PASS or FAIL).
"""
from __future__ import annotations

import argparse

import numpy as np

import glintlab as gl
from glintlab.resources import data_path
from glintlab.validation.scene import TABLE1_SCENES, load_scene

from timing import best


def rel_diff(a, b, hit):
    worst = 0.0
    for key in ("t", "x", "uv", "J", "shading_normal", "dxdpx", "dxdpy"):
        va, vb = a[key][hit], b[key][hit]
        scale = np.abs(vb).max(axis=-1, keepdims=True) if vb.ndim > 1 else np.abs(vb)
        worst = max(worst, float(np.max(np.abs(va - vb) / np.maximum(scale, 1e-300), initial=0.0)))
    return worst


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scale", type=float, default=1.0, help="resolution factor per side (1: 1920 x 1080)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-numpy", action="store_true", help="skip the numpy form (tens of seconds per heightfield)")
    args = ap.parse_args()
    scenes = [load_scene(data_path("scenes", f"{stem}.json")).scaled(args.scale) for stem in TABLE1_SCENES]
    w, h = scenes[0].width, scenes[0].height
    gn, gp = gl.standard_grid()
    pick = np.random.default_rng(1).integers(0, gn.size * gp.size, w * h)
    pix_n, pix_p = gn[pick // gp.size], gp[pick % gp.size]
    gated = gl.law("gated")
    _, t_gated = best(lambda: gated.sample(pix_n, pix_p, seed=1), args.repeats)
    print(f"Scene.trace over {w} x {h} pixels, {gl.get_num_threads()} threads")
    print(f"  one per-pixel gated evaluation per pixel   {t_gated:8.3f} s")
    ok = True
    for sc in scenes:
        y, x = np.mgrid[0:sc.height, 0:sc.width].astype(np.float64)
        tr = ref = None
        tr, t_cpp = best(lambda: sc.trace(x + 0.5, y + 0.5), args.repeats)
        line = f"  {sc.name:16s} C++ {t_cpp:7.3f} s   trace / gated = {t_cpp / t_gated:5.2f} (target <= 2)"
        ok &= t_cpp / t_gated <= 2
        if not args.no_numpy:
            ref, t_np = best(lambda: sc.trace_numpy(x + 0.5, y + 0.5), 1)
            same_hit = bool(np.array_equal(tr["hit"], ref["hit"]))
            line += (f"   numpy {t_np:7.3f} s ({t_np / t_cpp:5.1f}x)   hit mask {'equal' if same_hit else 'DIFFERS'},"
                     f" largest relative difference {rel_diff(tr, ref, tr['hit'] & ref['hit']):.1e}")
        print(line)
    print("PASS" if ok else "FAIL")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
