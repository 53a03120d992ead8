"""``glintlab images``: glint images of scenes per method, their flicker and an animation."""
from __future__ import annotations

import sys
import time

import numpy as np

from ..api.method_shaders import shader_method
from ..api import checks as V
from ..report.runner import write_section_files
from ..studies import scene_images as image_study
from ..studies.base import Context
from ..validation.scene import load_scene
from ..validation.scene_images import Material, frame_inputs, make_method, with_directional_light
from .common import add_outputs, add_scale, add_scenes, add_seed, print_table


def add_parser(sub):
    p = sub.add_parser("images", help="glint images of scenes per method, their flicker, an animation",
                       description="Per scene (data/schema/scene.schema.json), under one directional light: the glint "
                                   "image (NDF term) of each image method along a camera path of sub-pixel pans and "
                                   "zoom steps, the flicker of each against the facet ground truth "
                                   "(docs/math/glint_images.md), a PNG panel, a flicker plot, a GIF of the first scene "
                                   "and seconds per image. Writes CSV tables and the figures.")
    add_scenes(p)
    add_scale(p, 0.2, "resolution factor per side; the density follows so n per pixel is kept (default: 0.2)")
    p.add_argument("--frames", type=int, default=8, help="frames of the camera path (default: 8)")
    p.add_argument("--pan-px", type=float, default=0.25, help="pan step in pixels (default: 0.25)")
    p.add_argument("--zoom", type=float, default=0.99, help="distance factor per zoom step (default: 0.99)")
    p.add_argument("--density-factor", type=float, default=0.0625,
                   help="facet density x this (default: 1/16, sparse glints; 1: the files' N)")
    p.add_argument("--tau", type=float, default=2.0, help="glint threshold in units of D(h) (default: 2)")
    p.add_argument("--methods", help="comma-separated image methods (default: all registered; must include truth)")
    p.add_argument("--method", action="append", metavar="FILE.hlsl",
                   help="your own method shader (float glint(GlintInput g), docs/guide/shaders.md), rendered "
                        "beside the truth and the smooth image; repeatable")
    p.add_argument("--method-returns", choices=("intensity", "ndf"), default="intensity",
                   help="what the --method shaders return: an intensity (default), or a glinty NDF value D that "
                        "is shaded with the microfacet BRDF as the built-in NDF methods (the material as defines "
                        "GLINTLAB_DENSITY, GLINTLAB_ALPHA, GLINTLAB_GGX, GLINTLAB_R)")
    p.add_argument("--timing-scale", type=float, default=1.0,
                   help="resolution factor of the timed image of the first scene (default: 1, 1920 x 1080)")
    add_seed(p)
    add_outputs(p, "out/images", plugins=False)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    scenes = [load_scene(path) for path in args.scenes]  # all validated before any work
    params = {"scale": args.scale, "frames": args.frames, "pan_px": args.pan_px, "zoom": args.zoom,
              "density_factor": args.density_factor, "tau": args.tau, "timing_scale": args.timing_scale}
    if args.methods:
        params["methods"] = args.methods
        params["animation_methods"] = args.methods
    if args.method:
        bad = check_method_shaders(args, scenes, params)
        if bad:
            return bad
    t0 = time.perf_counter()
    ctx = Context(args.out, V.seed(args.seed))
    tables = image_study.compute_scenes(scenes, image_study.command_params(scenes, **params), ctx)
    paths = write_section_files(tables, image_study.figures, ctx)
    if not args.quiet:
        print_table(tables["scene_images_flicker"][["scene", "method", "std_ratio", "pop_rate", "change_rate",
                                                    "truth_change_rate", "mean_ratio"]], args.quiet)
        print_table(tables["scene_images_timing"], args.quiet)
        print(f"\nwrote {', '.join(str(p) for p in paths)} and CSV tables in {args.out} "
              f"({time.perf_counter() - t0:.1f} s)")
    return 0


def check_method_shaders(args, scenes, params) -> int:
    """``images --method FILE``: compiles each user method shader (a compile error is bad input, exit 2),
    adds it to the methods (beside the truth and the smooth image unless --methods names others) and
    checks that it returns finite values on the first frame of every scene (exit 1 otherwise)."""
    names = []
    for path in args.method:
        names.append(shader_method(path, returns=args.method_returns).name)
    base = args.methods or "truth,smooth"
    params["methods"] = params["animation_methods"] = ",".join(dict.fromkeys(base.split(",") + names))
    for sc in scenes:
        small = with_directional_light(sc.scaled(args.scale, keep_n=True))
        inp = frame_inputs(small)
        for name in names:
            vals = make_method(name, Material.of(small)).image(inp, seed=args.seed)[inp.hit]
            if not np.isfinite(vals).all():
                print(f"method {name}: non-finite values on {int((~np.isfinite(vals)).sum())} of {vals.size} "
                      f"hit pixel values of scene {sc.name} (frame 0)", file=sys.stderr)
                return 1
    return 0
