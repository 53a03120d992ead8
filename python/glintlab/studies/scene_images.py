"""Glint images of DB23's Table 1 scenes per method, their flicker along a camera path, and an animation:
the report's opening picture (numbers: ``validation.scene_images``; docs/math/glint_images.md)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from ..api import checks as V
from ..resources import data_path
from ..validation.scene import table1_scenes
from ..validation.scene_images import (ANGULAR_TEXEL, DEFAULT_METHODS, IMAGE_METHODS, TAU, display, flicker_table,
                                       render_path, time_methods, with_density)
from .base import Context, Tables

NAME = "scene_images"
TITLE = "Glint images of the Table 1 scenes per method, and their flicker along a camera path"
MEANING = ("The first thing users of glint methods compare: on DB23's Table 1 scenes under one directional light, "
           "the facet ground truth beside DB23's grids (three inner laws, trilinear and tetrahedral, and the 48-evaluation "
           "shader configuration), ZK16 and KPT25's constant-time NDF, "
           "with each method's temporal deviation relative to the truth's and its rate of pops (glints that "
           "appear or vanish with no cause in the truth) along sub-pixel pans and zoom steps.")
DEFAULTS = {
    "scenes": str(data_path("scenes")),
    "scale": 0.2,             # images at this fraction of 1920 x 1080 per side, density x scale^2 (same n per pixel)
    "density_factor": 0.0625,  # N x 1/16 of the scene files: n p ~ 0.2 facing, sparse glints (1: the files' N)
    "frames": 8,              # half sub-pixel pans, half zoom steps
    "pan_px": 0.25,
    "zoom": 0.99,
    "angular_texel": ANGULAR_TEXEL,
    "tau": TAU,
    "methods": ",".join(DEFAULT_METHODS),
    "animation_scene": "sphere",
    "animation_methods": "truth,db23_trilinear[gated],db23_tetrahedral[gated],zk16",
    "timing_scene": "plane_25",
    "timing_scale": 1.0,      # seconds per image at 1920 x 1080
}
QUICK = {"scale": 1.0 / 12, "frames": 4, "timing_scale": 1.0 / 12}
NOTEBOOK = "scene_images.ipynb"
TABLE = {"scene_images_flicker": ["scene", "method", "std_ratio", "pop_rate", "pop_rate_wider", "change_rate",
                                  "truth_change_rate", "mean_ratio"],
         "scene_images_timing": ["scene", "method", "width", "height", "seconds"]}


def _names(param: str, value: str) -> list[str]:
    names = [s.strip() for s in str(value).split(",") if s.strip()]
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
    return Tables({"scene_images_flicker": flicker, "scene_images_timing": timing}, stats,
                  data={"paths": paths, "methods": methods, "anim": anim, "anim_scene": params["animation_scene"],
                        "scale": scale, "density_factor": params["density_factor"]})


def figures(tables: Tables, ctx: Context) -> list:
    paths, methods = tables["paths"], tables["methods"]
    flicker = tables["scene_images_flicker"]
    out = [ctx.save(panel_figure(paths, methods, flicker, tables["scale"], tables["density_factor"]), "scene_images.png", 80),
           ctx.save(flicker_figure(flicker), "scene_images_flicker.png", 90)]
    gif = Path(ctx.out) / "scene_images_animation.gif"
    write_animation(paths[tables["anim_scene"]], tables["anim"], gif)
    out.append(gif)
    return out


def panel_figure(paths: dict, methods, flicker: pd.DataFrame, scale: float = 1.0, density_factor: float = 1.0):
    """Rows: scenes; columns: methods; the first frame of each, titled with its flicker numbers."""
    import matplotlib.pyplot as plt
    scenes = list(paths)
    h, w = next(iter(paths.values())).target.shape[1:]
    cw = 2.3
    fig, axes = plt.subplots(len(scenes), len(methods), figsize=(cw * len(methods), (cw * h / w + 0.5) * len(scenes) + 0.6),
                             squeeze=False)
    f = flicker.set_index(["scene", "method"])
    for i, sc in enumerate(scenes):
        p = paths[sc]
        for j, m in enumerate(methods):
            ax = axes[i, j]
            ax.imshow(display(p.images[m][0], p.material), cmap="gray", vmin=0, vmax=1, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            label = IMAGE_METHODS.get(m).label
            r = f.loc[(sc, m)]
            if m == "truth":
                sub = f"changes {1000 * r.truth_change_rate:.1f}‰"
            else:
                sub = f"σ×{r.std_ratio:.2f}  pops {1000 * r.pop_rate:.1f}‰"
            ax.set_title(f"{label}\n{sub}", fontsize=7.5)
            if j == 0:
                ax.set_ylabel(sc, fontsize=9)
    fig.suptitle(f"Glint images (NDF term, one directional light) at {w} x {h}; facet density {density_factor:g} x the "
                 f"scene's N at 1920 x 1080 (x {scale ** 2:.3g} here, the same n per pixel); frame 1 of the path.\n"
                 f"σ×: temporal deviation / the truth's; pops per 1000 pixel-frames (glints appearing or vanishing "
                 f"with no change in the truth)", fontsize=9)
    fig.tight_layout()
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
    for ax, m in zip(axes[0], methods):
        ims.append(ax.imshow(display(path.images[m][0][crop], path.material), cmap="gray", vmin=0, vmax=1,
                             interpolation="nearest"))
        ax.set_title(IMAGE_METHODS.get(m).label, fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])
    text = fig.suptitle("", fontsize=8)
    fig.tight_layout()

    def step(t):
        for im, m in zip(ims, methods):
            im.set_data(display(path.images[m][t][crop], path.material))
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
    return {**DEFAULTS, "animation_scene": names[0], "timing_scene": names[0], **params}
