"""Glint images of DB23's Table 1 scenes per method, their flicker along a camera path, and an animation:
the report's opening picture (numbers: ``validation.scene_images``; docs/math/glint_images.md)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.glinty_ndf import panel_methods
from ..api.method_shaders import shipped_method_shaders
from ..resources import data_path
from ..validation.scene import table1_scenes
from ..validation.scene_images import (ANGULAR_TEXEL, IMAGE_METHODS, SUPERSAMPLE, TAU, aliasing_table,
                                       display, flicker_table, render_path, sparkle_table, time_methods, with_density)
from .base import Context, Tables

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
    "animation_scene": "sphere",
    "animation_methods": "truth,db23_trilinear[gated],db23_tetrahedral[gated],zk16",
    "timing_scene": "plane_25",
    # Seconds per image at 960 x 540 (a quarter of 1920 x 1080's pixels: every method's cost is per pixel,
    # and timing ten methods at full size cost the report about 13 s; `glintlab images` can time any size).
    "timing_scale": 0.5,
    # Display (docs/math/glint_images.md#glint-shading): radiance under the scene's light, white at
    # exposure_white x the exposure_percentile of the smooth render (one exposure per scene, every method).
    "exposure_percentile": 99.0,
    "exposure_white": 2.0,
    "crop_px": 40,            # the 1:1 crops (pixels per side) around the smooth highlight
    # Aliasing (docs/math/glint_images.md#glint-aliasing): small frames, each method against itself
    # box-filtered over aliasing_supersample^2 sub-pixels; "" to skip.
    "aliasing_methods": "truth,db23_trilinear[gated],kpt25,wb16,wb16_star,wb16_lookup_noise",
    "aliasing_scale": 0.025,
    "aliasing_frames": 3,
    "aliasing_supersample": SUPERSAMPLE,
    # WB16's density against depth and sparkle size: one frame of this scene at this scale ("" to skip).
    "sparkle_scene": "plane_25",
    "sparkle_scale": 0.25,
}
QUICK = {"scale": 1.0 / 12, "frames": 4, "timing_scale": 1.0 / 12, "aliasing_scale": 0.02, "aliasing_frames": 2,
         "sparkle_scale": 1.0 / 12}
NOTEBOOK = "scene_images.ipynb"
TABLE = {"scene_images_flicker": ["scene", "method", "std_ratio", "pop_rate", "pop_rate_wider", "change_rate",
                                  "truth_change_rate", "mean_ratio"],
         "scene_images_timing": ["scene", "method", "width", "height", "seconds"],
         "scene_images_own_truth": ["scene", "method", "own_truth", "own_std_ratio", "own_pop_rate",
                                    "own_truth_change_rate", "own_mean_ratio", "smooth_mean_ratio", "smooth_rel_rmse"],
         "scene_images_aliasing": ["scene", "method", "supersample", "alias_rel_rmse", "alias_rel_rmse_spread",
                                   "std_ratio_vs_supersampled", "mean_ratio_vs_supersampled"],
         "scene_images_sparkles": ["scene", "method", "width", "height", "distance_lo", "distance_hi",
                                   "sparkles_per_1000_px", "mean_size_px", "p90_size_px"]}


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


def compute_scenes(scenes, params: dict, ctx: Context) -> Tables:
    """The section's tables for any list of scenes (``compute`` uses the Table 1 scenes of
    ``params["scenes"]``; ``glintlab images`` the files it is given)."""
    methods = _names("methods", params["methods"])
    if "truth" not in methods:
        V.fail("methods", params["methods"], "a list that includes the ground truth 'truth'")
    anim = _names("animation_methods", params["animation_methods"])
    scale = V.real("scale", params["scale"])
    by_name = {s.name: s for s in scenes}
    for key in ("animation_scene", "timing_scene"):
        if params[key] not in by_name:
            V.fail(key, params[key], f"one of the scenes {', '.join(by_name)}")
    paths, rows = {}, []
    for sc in scenes:
        ctx.progress(sc.name)
        small = with_density(sc.scaled(scale, keep_n=True), params["density_factor"])
        names = list(dict.fromkeys(methods + (anim if sc.name == params["animation_scene"] else [])))
        path = render_path(small, names, params["frames"], params["pan_px"], params["zoom"], seed=ctx.seed,
                           angular_texel=params["angular_texel"])
        paths[sc.name] = path
        rows.append(flicker_table(path, tau=params["tau"]))
    flicker = pd.concat(rows, ignore_index=True)
    flicker = flicker[flicker.method.isin(methods)].reset_index(drop=True)
    ctx.progress("timing")
    big = with_density(by_name[params["timing_scene"]].scaled(V.real("timing_scale", params["timing_scale"]), keep_n=True),
                       params["density_factor"])
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
    return Tables(tables, stats,
                  data={"paths": paths, "methods": methods, "anim": anim, "anim_scene": params["animation_scene"],
                        "scale": scale, "density_factor": params["density_factor"],
                        "exposure": (V.real("exposure_percentile", params["exposure_percentile"]),
                                     V.real("exposure_white", params["exposure_white"])),
                        "crop_px": int(params["crop_px"])})


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
        for sc in scenes:
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
    paths, methods = tables["paths"], tables["methods"]
    flicker = tables["scene_images_flicker"]
    out = [ctx.save(panel_figure(paths, methods, flicker, tables["scale"], tables["density_factor"],
                                 tables["exposure"], tables["crop_px"]), "scene_images.png", 80),
           ctx.save(flicker_figure(flicker), "scene_images_flicker.png", 90)]
    if "scene_images_aliasing" in tables.tables:
        out.append(ctx.save(aliasing_figure(tables["scene_images_aliasing"]), "scene_images_aliasing.png", 90))
    gif = Path(ctx.out) / "scene_images_animation.gif"
    write_animation(paths[tables["anim_scene"]], tables["anim"], gif)
    out.append(gif)
    return out


def exposure_of(path, percentile: float = 99.0, white: float = 2.0) -> float:
    """The display's white for a scene: ``white`` x the ``percentile`` of the smooth render's radiance
    (D(h) x the BRDF factor) over the lit pixels of the first frame; the same for every method."""
    L = path.target[0] * path.shade[0]
    lit = path.mask[0] & (L > 0)
    return float(white * np.percentile(L[lit], percentile)) if lit.any() else 1.0


def shaded(path, name: str, image: np.ndarray, white: float, frame: int = 0) -> np.ndarray:
    """Display values in [0, 1] of one image of method ``name`` (docs/math/glint_images.md#glint-shading):
    an NDF method's radiance (its image x the BRDF factor of frame ``frame``) over ``white``, an
    intensity method's value as it returns it, both clipped and raised to 1 / 2.2."""
    if IMAGE_METHODS.get(name).returns == "intensity" if name in IMAGE_METHODS else False:
        v = np.asarray(image, float)
    else:
        v = np.asarray(image, float) * path.shade[frame] / white
    return np.clip(np.nan_to_num(v), 0.0, 1.0) ** (1.0 / 2.2)


def _columns(path, methods):
    """(label, method name, image sequence) per panel column: each method followed by its own truth
    where that is not the facet truth (its exact reference, or itself supersampled)."""
    cols = []
    for m in methods:
        cols.append((IMAGE_METHODS.get(m).label, m, path.images[m]))
        kind = IMAGE_METHODS.get(m).truth
        if path.truths is not None and kind in ("reference", "supersampled"):
            cols.append((f"{IMAGE_METHODS.get(m).label}: {kind}", m, path.truths[m]))
    return cols


def _crop(path, size: int):
    """The (rows, cols) slices of a size x size crop centred on the highlight: the pixel of the largest
    smooth D(h) in the first frame (the radiance's own maximum sits on a grazing rim, where Fresnel
    and 1 / cos_o grow)."""
    L = np.where(path.mask[0], path.target[0], 0.0)
    H, W = L.shape
    r, c = np.unravel_index(int(np.argmax(L)), L.shape)
    size = max(4, min(int(size), H, W))
    r0, c0 = int(np.clip(r - size // 2, 0, H - size)), int(np.clip(c - size // 2, 0, W - size))
    return slice(r0, r0 + size), slice(c0, c0 + size)


def panel_figure(paths: dict, methods, flicker: pd.DataFrame, scale: float = 1.0, density_factor: float = 1.0,
                 exposure=(99.0, 2.0), crop_px: int = 40):
    """Per scene three rows: the first frame of each method (and of its own truth where that is not the
    facets) shaded with the microfacet BRDF under the scene's light at one exposure, titled with its
    flicker against its own truth; below, a crop_px x crop_px crop at 1:1 (nearest) around the highlight,
    and the temporal difference of that crop between the first two frames (display values)."""
    import matplotlib.pyplot as plt
    scenes = list(paths)
    h, w = next(iter(paths.values())).target.shape[1:]
    ncol = len(_columns(next(iter(paths.values())), methods))
    cw = 2.0
    rows = 3  # per scene: the frame, its 1:1 crop, the temporal difference |frame 2 - frame 1| of the crop
    fig, axes = plt.subplots(rows * len(scenes), ncol,
                             figsize=(cw * ncol, (cw * h / w + 2 * cw + 1.0) * len(scenes) + 0.9), squeeze=False,
                             gridspec_kw={"height_ratios": [h / w, 1.0, 1.0] * len(scenes)})
    f = flicker.set_index(["scene", "method"])
    for i, sc in enumerate(scenes):
        p = paths[sc]
        white = exposure_of(p, *exposure)
        cr = _crop(p, crop_px)
        for j, (label, m, seq) in enumerate(_columns(p, methods)):
            ax, axc, axd = axes[rows * i, j], axes[rows * i + 1, j], axes[rows * i + 2, j]
            img = shaded(p, m, seq[0], white)
            ax.imshow(img, cmap="gray", vmin=0, vmax=1, interpolation="antialiased")
            axc.imshow(img[cr], cmap="gray", vmin=0, vmax=1, interpolation="nearest")
            if seq.shape[0] > 1:
                diff = np.abs(shaded(p, m, seq[1], white, frame=1) - img)
                axd.imshow(diff[cr], cmap="magma", vmin=0, vmax=1, interpolation="nearest")
            if j == 0:
                ax.add_patch(plt.Rectangle((cr[1].start, cr[0].start), cr[1].stop - cr[1].start,
                                           cr[0].stop - cr[0].start, fill=False, ec="tab:red", lw=0.7))
            for a in (ax, axc, axd):
                a.set_xticks([])
                a.set_yticks([])
            r = f.loc[(sc, m)]
            is_truth_col = label.endswith(": reference") or label.endswith(": supersampled")
            if m == "truth" or is_truth_col:
                sub = (f"changes {1000 * r.truth_change_rate:.1f}‰" if m == "truth"
                       else f"changes {1000 * r.own_truth_change_rate:.1f}‰")
            elif "own_std_ratio" in r and r.own_truth not in ("facets", "self"):
                sub = f"vs {r.own_truth}: σ×{r.own_std_ratio:.2f} pops {1000 * r.own_pop_rate:.1f}‰"
            else:
                sub = f"σ×{r.std_ratio:.2f}  pops {1000 * r.pop_rate:.1f}‰"
            ax.set_title(f"{label}\n{sub}", fontsize=7)
            if j == 0:
                ax.set_ylabel(sc, fontsize=9)
                axc.set_ylabel(f"{crop_px} px 1:1", fontsize=7)
                axd.set_ylabel("|frame 2 - frame 1|", fontsize=7)
    fig.suptitle(f"Glint renders (microfacet BRDF: glinty D x Schlick F x Smith G / (4 cos_o), one directional light; "
                 f"white = {exposure[1]:g} x the {exposure[0]:g}th percentile of the smooth render, every method; "
                 f"intensity methods as they return) at {w} x {h}, frame 1.\nFacet density {density_factor:g} x the "
                 f"scene's N at 1920 x 1080 (x {scale ** 2:.3g} here, the same n per pixel); {density_statement(methods)}.\n"
                 f"σ×: temporal deviation / the own truth's; pops per 1000 pixel-frames (glints appearing or vanishing "
                 f"with no change in the own truth: facets unless the column after says reference / supersampled)",
                 fontsize=8)
    fig.tight_layout()
    return fig


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


def write_animation(path, methods, out: Path, fps: int = 4) -> Path:
    """A GIF of ``methods`` side by side along the camera path (matplotlib's Pillow writer)."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter
    T = path.target.shape[0]
    # Cropped to the pixels that see the surface in some frame (the sphere fills a fifth of its image).
    seen = path.mask.any(axis=0)
    rows, cols = np.flatnonzero(seen.any(axis=1)), np.flatnonzero(seen.any(axis=0))
    crop = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)) if rows.size else (slice(None), slice(None))
    h, w = seen[crop].shape
    fig, axes = plt.subplots(1, len(methods), figsize=(2.6 * len(methods), 2.6 * h / w + 0.5), squeeze=False)
    ims = []
    # The panel's display: the BRDF-shaded radiance at the smooth render's exposure (glint-shading).
    white = exposure_of(path) if path.shade is not None else None

    def show(m, t):
        if white is None:
            return display(path.images[m][t][crop], path.material)
        return shaded(path, m, path.images[m][t], white, frame=t)[crop]

    for ax, m in zip(axes[0], methods):
        ims.append(ax.imshow(show(m, 0), cmap="gray", vmin=0, vmax=1, interpolation="nearest"))
        ax.set_title(IMAGE_METHODS.get(m).label, fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])
    text = fig.suptitle("", fontsize=8)
    fig.tight_layout()

    def step(t):
        for im, m in zip(ims, methods):
            im.set_data(show(m, t))
        text.set_text(f"{path.scene}: frame {t + 1}/{T} ({'pan' if t <= T // 2 else 'zoom'})")
        return ims

    anim = FuncAnimation(fig, step, frames=T, blit=False)
    anim.save(out, writer=PillowWriter(fps=fps), dpi=100)
    plt.close(fig)
    return Path(out)


def command_params(scenes, **params) -> dict:
    """``glintlab images``' section parameters for ``scenes`` (as in ``DEFAULTS``; the animation and the
    timing use the first scene unless named), checked; ``compute_scenes`` takes them."""
    unknown = sorted(set(params) - set(DEFAULTS))
    if unknown:
        V.fail("params", unknown, f"parameters among {', '.join(DEFAULTS)}")
    if not scenes:
        V.fail("scenes", scenes, "at least one scene")
    names = [s.name for s in scenes]
    return {**DEFAULTS, "animation_scene": names[0], "timing_scene": names[0],
            "sparkle_scene": DEFAULTS["sparkle_scene"] if DEFAULTS["sparkle_scene"] in names else names[0], **params}
