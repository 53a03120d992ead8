"""``glintlab images``: glint images of scenes per method, their flicker and the image viewer page."""
from __future__ import annotations

import sys
import time
from pathlib import Path

from ..api.method_shaders import shader_method
from ..api.shaders import NoVulkanDevice, ShaderOutputError
from ..api import checks as V
from ..report.html import write_section_pages
from ..report.runner import write_section_files
from ..studies import scene_images as image_study
from ..studies.base import Context
from ..validation.scene_images import Material, frame_inputs, make_method, resolve_scene, with_directional_light
from .common import (add_outputs, add_resource_options, add_scale, add_scenes, add_seed, add_shader_options,
                     given_resource_options, given_shader_options, print_table, resource_options, shader_options)


def add_parser(sub):
    p = sub.add_parser("images", help="glint images of scenes per method, their flicker, an image viewer",
                       description="Per scene (data/schema/scene.schema.json), under one directional light: the glint "
                                   "image (NDF term) of each image method along a camera path of sub-pixel pans and "
                                   "zoom steps, the flicker of each against the facet ground truth "
                                   "(docs/math/glint_images.md), a PNG panel, a flicker plot, the image viewer page "
                                   "(scene_images.html: every render as HDR, the camera path as an animation) and "
                                   "seconds per image. Writes CSV tables and the figures. A scene is a file or a "
                                   "shipped scene's name (sphere, plane_25, ...), as gl.render takes it. Every method "
                                   "rendered, your --method files included, has its light and view response checked on the "
                                   "first scene (docs/math/glint_images.md#glint-light-response): exit 1 naming a "
                                   "method that ignores a component of h or whose lobe has the wrong width.")
    add_scenes(p)
    add_scale(p, 0.2, "resolution factor per side; the density follows so n per pixel is kept (default: 0.2)")
    p.add_argument("--frames", type=int, default=8, help="frames of the camera path (default: 8)")
    p.add_argument("--pan-px", type=float, default=0.25, help="pan step in pixels (default: 0.25)")
    p.add_argument("--zoom", type=float, default=0.99, help="distance factor per zoom step (default: 0.99)")
    p.add_argument("--density-factor", type=float, default=0.0625,
                   help="facet density x this (default: 1/16, sparse glints; 1: the files' N)")
    p.add_argument("--tau", type=float, default=2.0, help="glint threshold in units of D(h) (default: 2)")
    p.add_argument("--look", choices=image_study.LOOKS, default="files",
                   help="'files' (default): each scene file's light and material; 'highlight': lit in the mirror "
                        "direction of the image's centre ray, alpha set to --highlight-alpha, so the lobe's peak and "
                        "falloff are in view (docs/guide/scenes.md#scene-images-look)")
    p.add_argument("--highlight-alpha", type=float, default=image_study.DEFAULTS["highlight_alpha"],
                   help="the material's alpha under --look highlight (default: %(default)s)")
    p.add_argument("--methods", help="comma-separated image methods (default: all registered; must include truth)")
    p.add_argument("--method", action="append", metavar="FILE.hlsl",
                   help="your own method shader (float glint(GlintInput g), docs/guide/shaders.md), rendered "
                        "beside the truth and the smooth image; repeatable")
    add_resource_options(p)
    p.add_argument("--method-returns", choices=("intensity", "ndf"), default="intensity",
                   help="what the --method shaders return: an intensity (default), or a glinty NDF value D that "
                        "is shaded with the microfacet BRDF as the built-in NDF methods (the material as defines "
                        "GLINTLAB_DENSITY, GLINTLAB_ALPHA, GLINTLAB_GGX, GLINTLAB_R)")
    add_shader_options(p)
    p.add_argument("--timing-scale", type=float, default=1.0,
                   help="resolution factor of the timed image of the first scene (default: 1, 1920 x 1080)")
    add_seed(p)
    add_outputs(p, "out/images", plugins=False)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    scenes = [resolve_scene(name) for name in args.scenes]  # all validated before any work
    params = {"scale": args.scale, "frames": args.frames, "pan_px": args.pan_px, "zoom": args.zoom,
              "density_factor": args.density_factor, "tau": args.tau, "timing_scale": args.timing_scale,
              "look": args.look, "highlight_alpha": args.highlight_alpha}
    if args.methods:
        params["methods"] = args.methods
    for flag, value in {**given_shader_options(args), **given_resource_options(args)}.items():
        if not args.method:  # the shader options compile the --method files, and only those
            V.fail(flag, value, f"a --method shader file to compile with {flag}")
    try:
        if args.method:
            add_method_shaders(args, scenes, params)
        t0 = time.perf_counter()
        ctx = Context(args.out, V.seed(args.seed))
        tables = image_study.compute_scenes(scenes, image_study.command_params(scenes, **params), ctx)
    except NoVulkanDevice as exc:  # the environment, not the input's content: one line, as `glintlab shader`
        print(f"glintlab images: {exc}", file=sys.stderr)
        return 2
    except ShaderOutputError as exc:  # a method shader's NaN, infinite or negative value: a failed check
        print(f"glintlab images: FAIL {exc}", file=sys.stderr)
        return 1
    paths = write_section_files(tables, image_study.figures, ctx)
    paths += write_section_pages(image_study.NAME, tables, args.out)  # the image viewer, as the report's
    if not args.quiet:
        print_table(tables["scene_images_flicker"][["scene", "method", "std_ratio", "pop_rate", "change_rate",
                                                    "truth_change_rate", "mean_ratio"]], args.quiet)
        print_table(tables["scene_images_timing"], args.quiet)
        print(f"\nwrote {', '.join(str(p) for p in paths)} and CSV tables in {args.out} "
              f"({time.perf_counter() - t0:.1f} s)")
    return light_response_verdict(tables, args.quiet)


def light_response_verdict(tables, quiet: bool) -> int:
    """The light and view response of every rendered method, your --method files included
    (docs/math/glint_images.md#glint-light-response): its table, and exit 1 naming each method that
    fails (one that ignores a component of h, or whose lobe has the wrong width)."""
    if "scene_images_light_response" not in tables.tables:
        return 0
    resp = tables["scene_images_light_response"]
    if not quiet:
        print_table(resp[["scene", "method", "truth", "passed", "light_t", "light_b", "light_n", "view_t", "view_b",
                          "view_n", "lobe_level", "lobe_shape_dev"]], quiet)
    for row in resp[~resp.passed].itertuples():
        print(f"glintlab images: FAIL light response of {row.method} on {row.scene}: {row.failed} "
              "(scene_images_light_response.csv, scene_images_light_curves.csv)", file=sys.stderr)
    return 1 if (~resp.passed).any() else 0


def add_method_shaders(args, scenes, params) -> None:
    """``images --method FILE``: compiles each user method shader (a compile error is bad input, exit 2;
    two files with one stem, which would take one name, too) and adds it to the methods (beside the
    truth and the smooth image unless --methods names others). Its first frame of every scene is
    rendered here, so that a shader returning NaN, infinite or negative values fails (exit 1) before the
    path is rendered; every later frame is checked as it is rendered (``ShaderMethod.image``)."""
    by_name = {}
    for path in args.method:
        stem = Path(path).stem
        if stem in by_name:
            V.fail("--method", path, f"files with distinct names: {by_name[stem]} has the name {stem!r} too "
                                     "(a method shader is named after its file's stem; rename one)")
        by_name[stem] = path
    names = [shader_method(Path(path), returns=args.method_returns, **shader_options(args), **resource_options(args)).name
             for path in args.method]
    base = args.methods or "truth,smooth"
    params["methods"] = ",".join(dict.fromkeys(base.split(",") + names))
    seed = V.seed(args.seed)
    for sc in scenes:
        small = with_directional_light(sc.scaled(args.scale, keep_n=True))
        inp = frame_inputs(small)
        for name in names:
            make_method(name, Material.of(small)).image(inp, seed=seed, frame=0)
