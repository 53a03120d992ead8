"""Glint images of DB23's Table 1 scenes per method and their flicker along a camera path: the report's
opening picture, its image viewer (``scene_frames``; the page: ``report.viewer``) and the print panel
(numbers: ``validation.scene_images``; docs/math/glint_images.md)."""
from __future__ import annotations

import copy
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.glinty_ndf import panel_methods
from ..api.method_shaders import shipped_method_shaders
from ..resources import data_path
from ..validation import light_response as LR
from ..validation.scene import Scene, table1_scenes
from ..validation.scene_images import (ANGULAR_TEXEL, IMAGE_METHODS, SUPERSAMPLE, TAU, aliasing_table,
                                       flicker_table, render_path, sparkle_table, time_methods, with_density)
from .base import Context, Tables
from .scene_frames import (FACETS, frames_of_path, display_bytes, own_truth_key, path_tiles, render_frames,
                           timing_table)

NAME = "scene_images"
TITLE = "Glint images of the Table 1 scenes per method, and their flicker along a camera path"
MEANING = ("The first thing users of glint methods compare: on DB23's Table 1 scenes under one directional light, "
           "the facet ground truth beside DB23's grids (three inner laws, trilinear and tetrahedral, and the 48-evaluation "
           "shader configuration), ZK16 and KPT25's constant-time NDF, "
           "with each method's temporal deviation relative to the truth's and its rate of pops (glints that "
           "appear or vanish with no cause in the truth) along sub-pixel pans and zoom steps. The panel shows renders "
           "(the microfacet BRDF under the scene's light, one exposure fixed on the smooth render), each method beside "
           "its own truth (KPT25: its reference over every point); the aliasing table compares each method, WB16's "
           "sparkle shader and its baselines included, with itself box-filtered over 4 x 4 sub-pixels.")
DEFAULTS = {
    "scenes": str(data_path("scenes")),
    "scale": 0.2,             # images at this fraction of 1920 x 1080 per side, density x scale^2 (same n per pixel)
    "density_factor": 0.0625,  # N x 1/16 of the scene files: n p ~ 0.2 facing, sparse glints (1: the files' N)
    "frames": 8,              # half sub-pixel pans, half zoom steps
    "pan_px": 0.25,
    "zoom": 0.99,
    "angular_texel": ANGULAR_TEXEL,
    "tau": TAU,
    # "panel": every image method whose registry entry is in the panel (panel_methods(), read when the
    # section runs: a method registered after glintlab's import is rendered too), as any other name list.
    "methods": "panel",
    "timing_scene": "plane_25",
    # Seconds per image at 960 x 540 (a quarter of 1920 x 1080's pixels: every method's cost is per pixel,
    # and timing ten methods at full size cost the report about 13 s; `glintlab images` can time any size).
    # At the viewer's scale the timed images are the viewer's own renders of the timing scene.
    "timing_scale": 0.5,
    # The image viewer (scene_images.html): frame 0 of every scene and method at this fraction of
    # 1920 x 1080 per side (density x scale^2 as the path's), every pixel stored as float16 radiance.
    "viewer_scale": 0.5,
    # Display (docs/math/glint_images.md#glint-shading): radiance under the scene's light; each scene's default
    # exposure 2^e, e = -log2(exposure_white x the exposure_percentile of the smooth render), the same for every
    # method: the smooth lobe's bright end at 1/4 before the ACES curve (mid grey), glints several times brighter.
    "exposure_percentile": 99.0,
    "exposure_white": 4.0,
    # Aliasing (docs/math/glint_images.md#glint-aliasing): small frames, each method against itself
    # box-filtered over aliasing_supersample^2 sub-pixels; "" to skip.
    "aliasing_methods": "truth,db23_trilinear[gated],kpt25,wb16,wb16_star,wb16_lookup_noise",
    "aliasing_scale": 0.025,
    "aliasing_frames": 3,
    "aliasing_supersample": SUPERSAMPLE,
    # WB16's density against depth and sparkle size: one frame of this scene at this scale ("" to skip).
    "sparkle_scene": "plane_25",
    "sparkle_scale": 0.25,
    # The light and view response (docs/math/glint_images.md#glint-light-response) of every method rendered
    # ("methods") or of the listed ones ("" to skip), on one frame of this scene: moved images at this scale,
    # the lobe sweep at response_lobe_scale with the scene file's density.
    "response_methods": "methods",
    "response_scene": "sphere",
    "response_scale": 0.05,
    "response_lobe_scale": 0.1,
    # The look (docs/guide/scenes.md#scene-images-look): "files" keeps each scene file's light (as a direction from
    # the look-at point) and material, DB23's Table 1 setups as the `scenes` section profiles them; "highlight"
    # puts a directional light in the mirror direction of the ray through the image's centre and sets the
    # Beckmann/GGX alpha to highlight_alpha, so the highlight and its falloff are in view (at alpha 1 D(h)
    # varies by 4/e at most: there is no highlight). Every figure of the section follows the look chosen.
    "look": "files",
    "highlight_alpha": 0.3,
}
QUICK = {"scale": 1.0 / 12, "frames": 4, "timing_scale": 1.0 / 6, "viewer_scale": 1.0 / 6, "aliasing_scale": 0.02,
         "aliasing_frames": 2, "sparkle_scale": 1.0 / 12, "response_scale": 0.04, "response_lobe_scale": 0.05}
NOTEBOOK = "scene_images.ipynb"
TABLE = {"scene_images_flicker": ["scene", "method", "std_ratio", "pop_rate", "pop_rate_wider", "change_rate",
                                  "truth_change_rate", "mean_ratio"],
         "scene_images_timing": ["scene", "method", "width", "height", "seconds"],
         "scene_images_own_truth": ["scene", "method", "own_truth", "own_std_ratio", "own_pop_rate",
                                    "own_truth_change_rate", "own_mean_ratio", "smooth_mean_ratio", "smooth_rel_rmse"],
         "scene_images_aliasing": ["scene", "method", "supersample", "alias_rel_rmse", "alias_rel_rmse_spread",
                                   "std_ratio_vs_supersampled", "mean_ratio_vs_supersampled"],
         "scene_images_sparkles": ["scene", "method", "width", "height", "distance_lo", "distance_hi",
                                   "sparkles_per_1000_px", "mean_size_px", "p90_size_px"],
         "scene_images_light_response": ["scene", "method", "truth", "passed", "light_t", "light_b", "light_n",
                                         "view_t", "view_b", "view_n", "lobe_level", "lobe_shape_dev", "failed"]}


def _names(param: str, value: str) -> list[str]:
    """The image method names of a comma-separated list, "panel" standing for ``panel_methods()``."""
    names = [s.strip() for s in str(value).split(",") if s.strip()]
    names = list(dict.fromkeys(m for n in names for m in (panel_methods() if n == "panel" else [n])))
    if not names:
        V.fail(param, value, "a comma-separated list of image method names")
    for n in names:
        if n not in IMAGE_METHODS:
            V.fail(param, value, f"image method names among {', '.join(IMAGE_METHODS.names())}")
    return names


def compute(params: dict, ctx: Context) -> Tables:
    return compute_scenes(table1_scenes(ctx.path(params["scenes"])), params, ctx)


LOOKS = ("files", "highlight")


def with_look(scene, look: str, alpha: float):
    """``scene`` as the section renders it: unchanged for look "files"; for "highlight", lit by a directional
    light in the mirror direction (about the surface's normal) of the camera ray through the image's centre,
    its material's alpha set to ``alpha``: the smooth lobe's peak near the centre (at grazing views the
    off-specular peak moves it towards the horizon), its falloff across the image. A centre ray that misses
    the surface (a sphere too small) takes the normal facing the camera."""
    look = V.choice("look", look, LOOKS)
    if look == "files":
        return scene
    alpha = V.real("highlight_alpha", alpha)
    if not 0 < alpha <= 1:
        V.fail("highlight_alpha", alpha, "an alpha in (0, 1]")
    tr = scene.trace(np.array([scene.width / 2]), np.array([scene.height / 2]))
    hit = bool(tr["hit"][0])
    d = tr["x"][0] - scene.position if hit else scene.forward
    d = d / np.linalg.norm(d)
    if scene.kind == "sphere":
        n = tr["shading_normal"][0] if hit else -scene.forward
    else:  # a heightfield: its base plane's normal, the lobe's mean over the waves
        n = scene.normal
    mirror = d - 2 * np.dot(d, n) * n
    spec = copy.deepcopy(scene.spec)
    spec["light"] = {"type": "directional", "direction": [float(x) for x in mirror]}
    spec["material"]["alpha"] = float(alpha)
    return Scene(spec, name=scene.name, source=scene.source)


def compute_scenes(scenes, params: dict, ctx: Context) -> Tables:
    """The section's tables for any list of scenes (``compute`` uses the Table 1 scenes of
    ``params["scenes"]``; ``glintlab images`` the files it is given)."""
    scenes = [with_look(sc, params["look"], params["highlight_alpha"]) for sc in scenes]
    methods = _names("methods", params["methods"])
    if "truth" not in methods:
        V.fail("methods", params["methods"], "a list that includes the ground truth 'truth'")
    scale = V.real("scale", params["scale"])
    by_name = {s.name: s for s in scenes}
    if params["timing_scene"] not in by_name:
        V.fail("timing_scene", params["timing_scene"], f"one of the scenes {', '.join(by_name)}")
    done = scenes_rendered(scenes, methods, params, ctx)
    paths = {n: d[0] for n, d in done.items()}
    views = {n: d[2] for n, d in done.items()}
    flicker = pd.concat([d[1] for d in done.values()], ignore_index=True)
    ctx.progress("timing")
    timing_scale = V.real("timing_scale", params["timing_scale"])
    if timing_scale == V.real("viewer_scale", params["viewer_scale"]):
        timing = timing_table(views, params["timing_scene"])
    else:
        big = with_density(by_name[params["timing_scene"]].scaled(timing_scale, keep_n=True), params["density_factor"])
        timing = time_methods(big, methods, seed=ctx.seed, angular_texel=params["angular_texel"])
    first = next(iter(paths.values()))
    h, w = first.target.shape[1:]
    stats = {"image size": f"{w} x {h} (density x {scale ** 2:.4g}: each pixel keeps the 1920 x 1080 n)",
             "facet density": f"{params['density_factor']:g} x the scene files' N",
             "frames": params["frames"]}
    for name in methods:
        if name in ("truth", "smooth"):
            continue
        g = flicker[flicker.method == name]
        stats[f"{name}: std ratio (min-max over scenes)"] = f"{g.std_ratio.min():.3g}-{g.std_ratio.max():.3g}"
        stats[f"{name}: pops per 1000 pixel-frames (max)"] = float(1000 * g.pop_rate.max())
    t = timing.set_index("method").seconds
    tw, th = int(timing.width.iloc[0]), int(timing.height.iloc[0])
    stats[f"seconds per {tw} x {th} image ({params['timing_scene']})"] = ", ".join(
        f"{m} {t[m]:.2f}" for m in methods)
    own_cols = ["scene", "method", "label"] + TABLE["scene_images_own_truth"][2:]
    own = flicker[[c for c in own_cols if c in flicker.columns]].copy()
    for name in methods:
        g = own[own.method == name]
        if IMAGE_METHODS.get(name).truth in ("reference", "supersampled") and len(g):
            stats[f"{name} against its own truth ({IMAGE_METHODS.get(name).truth}): std ratio, pops per 1000 (max)"] = \
                f"{g.own_std_ratio.min():.3g}-{g.own_std_ratio.max():.3g}, {1000 * g.own_pop_rate.max():.3g}"
    stats["densities"] = density_statement(methods)
    tables = {"scene_images_flicker": flicker, "scene_images_timing": timing, "scene_images_own_truth": own}
    tables.update(_aliasing(scenes, params, ctx, stats))
    extra, failures = _light_response(scenes, methods, params, ctx, stats, tables)
    return Tables(tables, stats, failures, extra,
                  {"paths": paths, "views": views, "methods": methods, "scale": scale,
                        "density_factor": params["density_factor"],
                        "exposure": (V.real("exposure_percentile", params["exposure_percentile"]),
                                     V.real("exposure_white", params["exposure_white"]))})


#: Scenes rendered at once: each render's numpy part runs on one core, its C++ part on every core (OpenMP),
#: so two scenes keep both cores of the report's machine busy. Every pixel's value depends only on the
#: seed and the scene, never on which thread renders it (tests/python/test_scene_images.py). Only when
#: every method is one glintlab ships as C++ or numpy: a method shader's kernel (and a user's method,
#: whose thread safety nobody promised) is called from one thread at a time.
SCENE_THREADS = 2


def _scene_threads(methods) -> int:
    entries = [IMAGE_METHODS.get(m) for m in methods]
    safe = all(e.origin == "glintlab" and e.shader is None and e.returns == "ndf" for e in entries)
    return SCENE_THREADS if safe else 1


def scenes_rendered(scenes, methods, params: dict, ctx: Context) -> dict:
    """Per scene (in ``scenes``' order) its camera path, flicker table and viewer frames, ``SCENE_THREADS``
    scenes at a time. The renders the timing table's seconds come from (the timing scene's viewer frames,
    or its whole path when the viewer takes its frames from the path) run first and alone, so that no
    other scene's render shares the machine with them."""
    from_path = V.real("viewer_scale", params["viewer_scale"]) == V.real("scale", params["scale"])

    def one(sc, view=None):
        ctx.progress(sc.name)
        small = with_density(sc.scaled(V.real("scale", params["scale"]), keep_n=True), params["density_factor"])
        path = render_path(small, methods, params["frames"], params["pan_px"], params["zoom"], seed=ctx.seed,
                           angular_texel=params["angular_texel"])
        view = view or viewer_scene(sc, path, methods, params, ctx)
        view.path = path_tiles(path, methods, view.white, params["tau"])
        return path, flicker_table(path, tau=params["tau"]), view

    timed = [sc for sc in scenes if sc.name == params["timing_scene"]]
    done = {sc.name: one(sc) for sc in timed} if from_path else {}
    views = {} if from_path else {sc.name: viewer_scene(sc, None, methods, params, ctx) for sc in timed}
    with ThreadPoolExecutor(max_workers=_scene_threads(methods)) as pool:
        rest = [sc for sc in scenes if sc.name not in done]
        done.update(zip((sc.name for sc in rest), pool.map(lambda sc: one(sc, views.get(sc.name)), rest)))
    return {sc.name: done[sc.name] for sc in scenes}


def viewer_scene(sc, path, methods, params: dict, ctx: Context):
    """What the image viewer shows of scene ``sc`` (``scene_frames.ViewerScene``) but its camera path:
    frame 0 of every method and own truth at ``viewer_scale``, taken from the camera path ``path`` when
    that is its scale, else rendered once more at the viewer's resolution (``path`` unused)."""
    viewer_scale = V.real("viewer_scale", params["viewer_scale"])
    exposure = (V.real("exposure_percentile", params["exposure_percentile"]),
                V.real("exposure_white", params["exposure_white"]))
    if viewer_scale == V.real("scale", params["scale"]):
        return frames_of_path(path, methods, exposure)
    ctx.progress(f"{sc.name} at the viewer's resolution")
    big = with_density(sc.scaled(viewer_scale, keep_n=True), params["density_factor"])
    return render_frames(big, methods, ctx.seed, params["angular_texel"], exposure)


def density_statement(methods) -> str:
    """What the densities of the methods shown are. Every method runs at the scene's facet density N:
    KPT25's point density K_P = N and WWH18's flake density = N; no mapping to equal expected glint
    counts between KPT25 and DB23 is applied (an image method's registry entry holds its mapping, ``density``:
    KPT25's is ``gl.matched_density``)."""
    mapped = [m for m in methods if IMAGE_METHODS.get(m).density is not None]
    base = "every method at the scene's facet density N (KPT25's point density K_P = N, WWH18's flake density = N)"
    if mapped:
        return (base.replace("every method", "every method not listed") + "; matched to equal expected glint counts: "
                + ", ".join(mapped))
    return base + "; densities not matched to equal expected glint counts (no mapping registered)"


def _aliasing(scenes, params: dict, ctx: Context, stats: dict) -> dict:
    """The aliasing and sparkle tables (empty when their parameters say to skip)."""
    out = {}
    names = [s.strip() for s in str(params["aliasing_methods"]).split(",") if s.strip()]
    if names:
        names = _names("aliasing_methods", params["aliasing_methods"])
        names = _usable(names, stats)
        scale = V.real("aliasing_scale", params["aliasing_scale"])
        rows = []
        for sc in scenes:  # one at a time: a method shader's kernel runs one call at a time
            ctx.progress(f"aliasing {sc.name}")
            small = with_density(sc.scaled(scale, keep_n=True), params["density_factor"])
            rows.append(aliasing_table(small, names, params["aliasing_frames"], int(params["aliasing_supersample"]),
                                       params["pan_px"], params["zoom"], seed=ctx.seed,
                                       angular_texel=params["angular_texel"]))
        al = pd.concat(rows, ignore_index=True)
        out["scene_images_aliasing"] = al
        w, h = small.width, small.height
        stats["aliasing frames"] = (f"{w} x {h}, {params['aliasing_frames']} frames, "
                                    f"{params['aliasing_supersample']}x{params['aliasing_supersample']} sub-pixels")
        for name in names:
            g = al[al.method == name]
            stats[f"{name}: aliasing rel. RMS error (min-max over scenes)"] = \
                f"{g.alias_rel_rmse.min():.3g}-{g.alias_rel_rmse.max():.3g}"
    sp = str(params["sparkle_scene"]).strip()
    if sp:
        by_name = {s.name: s for s in scenes}
        if sp not in by_name:
            V.fail("sparkle_scene", sp, f"one of the scenes {', '.join(by_name)} or ''")
        rows = []
        # WB16's claims, for every image method its shader computes (the paper's method and its baselines).
        wb16 = [n for n, entry in shipped_method_shaders().items() if entry.files == "wb16"]
        for name in _usable(wb16, stats):
            rows.append(sparkle_table(by_name[sp].scaled(V.real("sparkle_scale", params["sparkle_scale"])), name,
                                      seed=ctx.seed))
        if rows:
            st = pd.concat(rows, ignore_index=True)
            out["scene_images_sparkles"] = st
            g = st[st.method == "wb16"]
            if len(g):
                d = g.sparkles_per_1000_px
                stats["wb16 sparkles per 1000 px over depth bins (max / min)"] = \
                    f"{d.max() / d.min():.3g}" if d.min() > 0 else "inf"
                stats[f"wb16 sparkle size, mean px at {int(g.width.iloc[0])} x {int(g.height.iloc[0])}"] = \
                    ", ".join(f"{v:.2g}" for v in g.mean_size_px)
    return out


def _light_response(scenes, methods, params: dict, ctx: Context, stats: dict, tables: dict):
    """The light and view response of the methods on ``response_scene`` (``validation.light_response``):
    adds its summary to ``tables`` and a line to ``stats``; returns (the curves and lobe sweeps as CSV
    tables, the failed methods as the section's failures)."""
    which = str(params["response_methods"]).strip()
    if not which:
        return {}, []
    names = _usable(methods if which == "methods" else _names("response_methods", which), stats)
    by_name = {s.name: s for s in scenes}
    if params["response_scene"] not in by_name:
        V.fail("response_scene", params["response_scene"], f"one of the scenes {', '.join(by_name)}")
    ctx.progress("light response")
    r = LR.response_tables(by_name[params["response_scene"]], names, ctx.seed, scale=params["response_scale"],
                        density_factor=params["density_factor"], lobe_scale=params["response_lobe_scale"])
    summary = r["summary"]
    tables["scene_images_light_response"] = summary
    bad = summary[~summary.passed]
    sc = r["setup"].scene
    stats[f"light response on {sc.name} at {sc.width} x {sc.height}: methods passing"] = \
        f"{int(summary.passed.sum())} of {len(summary)}" + (f" (failed: {', '.join(bad.method)})" if len(bad) else "")
    failures = [f"scene_images light response: {row.method} on {row.scene}: {row.failed}" for row in bad.itertuples()]
    return {"scene_images_light_curves": r["curves"], "scene_images_lobe_sweep": r["lobe"]}, failures


def _usable(names, stats: dict) -> list:
    """``names`` less the method shaders that cannot run here (no Vulkan device), noted in ``stats``."""
    keep = []
    for n in names:
        if IMAGE_METHODS.get(n).returns == "intensity":
            try:
                IMAGE_METHODS.get(n).factory(None)
            except RuntimeError as e:
                stats[f"{n}: not run"] = str(e).splitlines()[0]
                continue
        keep.append(n)
    return keep


def figures(tables: Tables, ctx: Context) -> list:
    methods, flicker = tables["methods"], tables["scene_images_flicker"]
    out = [print_panel(tables["views"], flicker, Path(ctx.out) / "scene_images.png", tables["density_factor"], methods,
                       exposure=tables["exposure"]),
           ctx.save(flicker_figure(flicker), "scene_images_flicker.png", 90)]
    if "scene_images_aliasing" in tables.tables:
        out.append(ctx.save(aliasing_figure(tables["scene_images_aliasing"]), "scene_images_aliasing.png", 90))
    if "scene_images_light_response" in tables.tables:
        out.append(ctx.save(light_response_figure(tables["scene_images_light_response"], tables["scene_images_lobe_sweep"]),
                            "scene_images_light_response.png", 90))
    return out


#: The print panel: at most this many tiles per row, each at most this many pixels wide, labels in points
#: that stay readable when the PNG is shown at a page's width (about half its own).
PANEL_COLUMNS, PANEL_TILE_PX, PANEL_FONT_PX = 6, 320, 24


def _font(size: int, bold: bool = False):
    from matplotlib import font_manager
    from PIL import ImageFont
    return ImageFont.truetype(font_manager.findfont(font_manager.FontProperties(
        family="DejaVu Sans", weight="bold" if bold else "normal")), size)


def _wrap(draw, text: str, font, width: int) -> list:
    """``text`` broken into lines of at most ``width`` pixels in ``font``."""
    lines, line = [], ""
    for word in text.split():
        trial = f"{line} {word}".strip()
        if line and draw.textlength(trial, font=font) > width:
            lines.append(line)
            line = word
        else:
            line = trial
    return lines + ([line] if line else [])


def _tile_caption(view, key: str, flicker: pd.DataFrame) -> tuple:
    """(title, numbers) above a tile: the method's label and its flicker against its own truth, or what
    the truth tile is and how often its glints change."""
    f = flicker.set_index(["scene", "method"])
    for c in view.columns:
        if key == c["method"]:
            r = f.loc[(view.name, key)]
            if key == FACETS:
                return c["label"], f"changes {1000 * r.truth_change_rate:.1f}‰ per frame"
            own = r.get("own_truth", "facets")
            if own not in ("facets", "self") and "own_std_ratio" in r:
                return c["label"], f"vs {own}: σ×{r.own_std_ratio:.2f}, pops {1000 * r.own_pop_rate:.1f}‰"
            return c["label"], f"σ×{r.std_ratio:.2f}, pops {1000 * r.pop_rate:.1f}‰"
        if key == own_truth_key(c["method"]) and key != FACETS:
            r = f.loc[(view.name, c["method"])]
            return f"{c['label']}: {c['truth_kind']}", f"changes {1000 * r.own_truth_change_rate:.1f}‰ per frame"
    return key, ""


def _fitting(draw, text: str, fonts, width: int):
    """The first of ``fonts`` in which ``text`` fits ``width`` pixels (the last if none does)."""
    return next((f for f in fonts if draw.textlength(text, font=f) <= width), fonts[-1])


def print_panel(views: dict, flicker: pd.DataFrame, path, density_factor: float, methods, tone: str = "aces",
                exposure=(99.0, 4.0)):
    """The static panel for print (``scene_images.png``), from the viewer's frames: per scene, each method's
    frame 0 and each own truth that is not the facets, box-filtered to tiles of at most PANEL_TILE_PX
    pixels, in radiance, shown at the scene's default exposure through ``tone`` (the viewer's default),
    at most PANEL_COLUMNS per row, titled with the method and its flicker. Written with Pillow (text
    in DejaVu Sans); the viewer page has every pixel."""
    from PIL import Image, ImageDraw
    first = next(iter(views.values()))
    tw = min(PANEL_TILE_PX, first.width)
    th = round(tw * first.height / first.width)
    fs, gap, margin = PANEL_FONT_PX, 14, 20
    width = 2 * margin + PANEL_COLUMNS * tw + (PANEL_COLUMNS - 1) * gap
    big, small, head = _font(fs, True), _font(round(fs * 0.8)), _font(round(fs * 1.15), True)
    smaller = _font(round(fs * 0.7))
    caption = (f"Glint renders at {first.width} × {first.height} (radiance: glinty D × Schlick F × Smith G / (4 cos θo) "
               f"under one directional light; an intensity method's value as it returns), frame 1 of the camera path, "
               f"each scene at its default exposure (2^e with e = −log2 of {exposure[1]:g} × the smooth render's "
               f"{exposure[0]:g}th percentile) "
               f"through the {tone.upper() if tone == 'aces' else tone} tone curve, tiles box-filtered to {tw} px. "
               f"Facet density {density_factor:g} × the scene files' N, the same facets per pixel at every resolution; "
               f"{density_statement(methods)}. σ×: temporal deviation / the own truth's; pops per 1000 pixel-frames "
               f"(glints appearing or vanishing with no change in the own truth). Every pixel, any exposure, "
               f"differences and the flicker video: scene_images.html.")
    probe = ImageDraw.Draw(Image.new("L", (1, 1)))
    cap_lines = _wrap(probe, caption, small, width - 2 * margin)
    label_h = 2 * fs + 8
    blocks = []
    for view in views.values():
        keys = []
        for c in view.columns:
            keys.append(c["method"])
            if c["own"] not in (c["method"], FACETS):
                keys.append(c["own"])
        blocks.append((view, keys))
    height = margin + len(cap_lines) * (fs + 4) + sum(
        round(fs * 1.15) + 16 + -(-len(k) // PANEL_COLUMNS) * (label_h + th + gap) for _, k in blocks) + margin
    img = Image.new("L", (width, height), 255)
    draw = ImageDraw.Draw(img)
    y = margin
    for line in cap_lines:
        draw.text((margin, y), line, fill=0, font=small)
        y += fs + 4
    for view, keys in blocks:
        draw.text((margin, y + 6), f"{view.name}", fill=0, font=head)
        y += round(fs * 1.15) + 16
        for i, key in enumerate(keys):
            col, row = i % PANEL_COLUMNS, i // PANEL_COLUMNS
            x, ty = margin + col * (tw + gap), y + row * (label_h + th + gap)
            title, numbers = _tile_caption(view, key, flicker)
            draw.text((x, ty), title, fill=0, font=_fitting(draw, title, (big, small, smaller), tw))
            draw.text((x, ty + fs + 4), numbers, fill=60, font=_fitting(draw, numbers, (small, smaller), tw))
            tile = Image.fromarray(view.images[key].astype(np.float32), "F").resize((tw, th), Image.BOX)
            img.paste(Image.fromarray(display_bytes(np.asarray(tile), view.exposure, tone)), (x, ty + label_h))
        y += -(-len(keys) // PANEL_COLUMNS) * (label_h + th + gap)
    path = Path(path)
    img.save(path, optimize=False, compress_level=6)
    return path


def aliasing_figure(al: pd.DataFrame):
    """Per scene and method: the 1-sample image's relative RMS error against its own supersampled image
    (bars, with the spread over frames) and the temporal deviation ratio 1-sample / supersampled."""
    import matplotlib.pyplot as plt
    methods = list(dict.fromkeys(al.method))
    scenes = list(dict.fromkeys(al.scene))
    f = al.set_index(["scene", "method"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.8))
    width = 0.8 / max(len(methods), 1)
    x = np.arange(len(scenes))
    for k, m in enumerate(methods):
        axes[0].bar(x + k * width, [f.loc[(s, m)].alias_rel_rmse for s in scenes], width,
                    yerr=[f.loc[(s, m)].alias_rel_rmse_spread for s in scenes], label=IMAGE_METHODS.get(m).label,
                    error_kw={"lw": 0.6})
        axes[1].bar(x + k * width, [f.loc[(s, m)].std_ratio_vs_supersampled for s in scenes], width)
    axes[0].set_yscale("log")
    axes[1].set_yscale("log")
    axes[1].axhline(1, color="k", lw=0.8)
    for ax, title in ((axes[0], "1-sample vs own supersampled: RMS error / mean (± spread over frames)"),
                      (axes[1], "temporal std, 1-sample / supersampled")):
        ax.set_xticks(x + 0.4 - width / 2)
        ax.set_xticklabels(scenes, fontsize=8)
        ax.set_title(title, fontsize=9)
    r = al.iloc[0]
    fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=min(len(methods), 8), fontsize=7)
    fig.suptitle(f"Aliasing: each method against itself box-filtered over {r.supersample} sub-pixels "
                 f"({int(r.frames)} frames; docs/math/glint_images.md#glint-aliasing)", fontsize=10)
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    return fig


def flicker_figure(flicker: pd.DataFrame):
    """Per scene and method: the temporal deviation ratio and the pop rate (the truth's change rate as
    the level a coherent method would show)."""
    import matplotlib.pyplot as plt
    methods = [m for m in dict.fromkeys(flicker.method) if m not in ("truth", "smooth")]
    scenes = list(dict.fromkeys(flicker.scene))
    f = flicker.set_index(["scene", "method"])
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6))
    width = 0.8 / max(len(methods), 1)
    x = np.arange(len(scenes))
    for k, m in enumerate(methods):
        axes[0].bar(x + k * width, [f.loc[(s, m)].std_ratio for s in scenes], width,
                    label=IMAGE_METHODS.get(m).label)
        axes[1].bar(x + k * width, [1000 * f.loc[(s, m)].pop_rate for s in scenes], width)
    axes[0].axhline(1, color="k", lw=0.8)
    axes[1].plot(x + 0.4 - width / 2, [1000 * f.loc[(s, "truth")].truth_change_rate for s in scenes], "k_",
                 markersize=30, label="truth's own changes")
    for ax, title in ((axes[0], "temporal std / truth's"), (axes[1], "pops per 1000 pixel-frames")):
        ax.set_xticks(x + 0.4 - width / 2)
        ax.set_xticklabels(scenes, fontsize=8)
        ax.set_title(title, fontsize=10)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=len(methods), fontsize=7)
    axes[1].legend(fontsize=7)
    fig.suptitle("Flicker along the camera path (docs/math/glint_images.md#glint-flicker)", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return fig


def command_params(scenes, **params) -> dict:
    """``glintlab images``' section parameters for ``scenes`` (as in ``DEFAULTS``; the timing uses the first
    scene unless named, the viewer the path's resolution unless ``viewer_scale`` is given), checked;
    ``compute_scenes`` takes them."""
    unknown = sorted(set(params) - set(DEFAULTS))
    if unknown:
        V.fail("params", unknown, f"parameters among {', '.join(DEFAULTS)}")
    if not scenes:
        V.fail("scenes", scenes, "at least one scene")
    names = [s.name for s in scenes]
    return {**DEFAULTS, "timing_scene": names[0],
            "viewer_scale": params.get("scale", DEFAULTS["scale"]),
            "sparkle_scene": DEFAULTS["sparkle_scene"] if DEFAULTS["sparkle_scene"] in names else names[0],
            "response_scene": DEFAULTS["response_scene"] if DEFAULTS["response_scene"] in names else names[0], **params}


def light_response_figure(summary: pd.DataFrame, lobe: pd.DataFrame):
    """Left: each method's decorrelation over its truth's per move and axis (failing below LR.MIN_RATIO);
    right: its mean D / D(h) across the lobe (the slopes along t and b), D(h) at 1. One colour per method."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6))
    colour = {m: plt.get_cmap("tab20")(k % 20) for k, m in enumerate(summary.method)}
    label = dict(zip(summary.method, summary.label))
    keys = [f"{m}_{a}" for m in LR.MOVES for a in LR.AXES]
    x = np.arange(len(keys))
    shown = summary[np.isfinite(summary[keys].to_numpy(float)).any(axis=1)]
    width = 0.8 / max(len(shown), 1)
    for k, r in enumerate(shown.itertuples()):
        axes[0].bar(x + k * width, [getattr(r, c) for c in keys], width, color=colour[r.method])
    axes[0].axhline(LR.MIN_RATIO, color="r", lw=0.8, ls="--")
    axes[0].axhline(1, color="k", lw=0.6)
    axes[0].set_xticks(x + 0.4 - width / 2)
    axes[0].set_xticklabels([k.replace("_", " along ") for k in keys], fontsize=8)
    axes[0].set_yscale("log")
    axes[0].set_title(f"decorrelation of the moved image / its truth's (fails below {LR.MIN_RATIO:g}, red)", fontsize=9)
    for name, g in lobe.groupby("method", sort=False):
        for axis, ls in (("t", "-"), ("b", ":")):
            s = g[g.axis == axis].sort_values("slope_over_alpha")
            if axis == "b":
                s = pd.concat([g[(g.axis == "t") & (g.slope_over_alpha == 0)], s])
            axes[1].plot(s.slope_over_alpha, s.ratio, ls, marker="o", ms=3, color=colour.get(name, "k"))
    axes[1].axhline(1, color="k", lw=0.6)
    axes[1].axvline(LR.LOBE_CHECKED, color="grey", lw=0.6, ls="--")
    axes[1].set_xlabel(f"slope of h / alpha (solid: along t, dotted: along b; checked up to {LR.LOBE_CHECKED:g})",
                       fontsize=8)
    axes[1].set_title("mean D over the pixels / D(h) across the lobe", fontsize=9)
    handles = [plt.Rectangle((0, 0), 1, 1, color=colour[m]) for m in summary.method]
    fig.legend(handles, [label[m] for m in summary.method], loc="lower center", ncol=min(len(handles), 6), fontsize=7)
    sc = summary.scene.iloc[0] if len(summary) else ""
    fig.suptitle(f"Light and view response on {sc} (docs/math/glint_images.md#glint-light-response)", fontsize=10)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    return fig
