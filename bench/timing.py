"""The helpers the bench scripts share: timing, and the method-shader benches' command line and scene
(imported as ``from timing import best``: a script's own folder is on ``sys.path`` when it runs as
``python bench/<script>.py``)."""
from __future__ import annotations

import argparse
import time

import glintlab as gl
from glintlab.resources import data_path
from glintlab.validation import scene_images as si
from glintlab.validation.scene import load_scene


def best(fn, repeats: int):
    """(last result, best seconds of ``repeats`` calls). The previous result is dropped before each call, so
    that its memory is reused as in a render loop: a first call also pays the kernel's zeroing of fresh
    pages (Scene.trace: 23 float64 per pixel, 380 MB at 1080p), which ``repeats=1`` shows."""
    out, t = None, float("inf")
    for _ in range(repeats):
        out = None
        t0 = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
    return out, t


def lit_scene_from_args(description: str):
    """The method-shader benches' command line (--scene, --scale, --repeats) and their scene with its
    directional light: (args, scene), or None (after saying so) when there is no Vulkan device."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--scene", default="plane_25")
    ap.add_argument("--scale", type=float, default=1.0, help="resolution factor per side (1: 1920 x 1080)")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    if not gl.vulkan_devices():
        print("no Vulkan device: install mesa-vulkan-drivers")
        return None
    return args, si.with_directional_light(load_scene(data_path("scenes", f"{args.scene}.json")).scaled(args.scale))
