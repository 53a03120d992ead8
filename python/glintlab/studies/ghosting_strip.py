"""Ghosting along a receding plane (DB23 Fig. 2 idea): one LOD transition seen as a strip of pixels,
per blend and for the ground truth (``lod.strip_images``)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from . import lod
from .base import Context, Tables

NAME = "ghosting_strip"
TITLE = "Ghosting along a receding plane (DB23 Fig. 2 idea)"
MEANING = ("Across one LOD transition, output blending (zk16_linear) shows a denser, dimmer band of ghost glints "
           "mid-way, nearest jumps at the level change, and the distributed law looks like the ground truth.")
DEFAULTS = {"N": 1e8, "p": 0.01, "width": 256, "height": 64, "level": -10}
QUICK = {"N": 2.5e7, "width": 128, "height": 32, "level": -9}
NOTEBOOK = "lod_blending.ipynb"
TABLE: dict = {}


def compute(params: dict, ctx: Context) -> Tables:
    images, exponents = lod.strip_images(N=params["N"], p=params["p"], width=params["width"],
                                         height=params["height"], level=params["level"], seed=ctx.seed)
    mid = (exponents > 0.4) & (exponents < 0.6)
    lit = {k: float((v[:, mid] > 0).mean()) for k, v in images.items()}
    table = pd.DataFrame([{"image": k, "lit_share_mid": lit[k], "lit_share_vs_truth": lit[k] / lit["ground truth"],
                           "mean_intensity": float(v.mean())} for k, v in images.items()])
    return Tables({"lod_strip": table},
                  {"lit pixels mid-way, zk16_linear / truth": lit.get("zk16_linear", math.nan) / lit["ground truth"]},
                  data={"images": images, "exponents": exponents})


def figures(tables: Tables, ctx: Context) -> list:
    return [ctx.save(strip_figure(tables["images"], tables["exponents"]), "lod_strip.png", 110)]


def strip_figure(images, exponents, vmax: float = 4.0):
    """The receding-plane strip of ``lod.strip_images``: intensity K / (N P p) per pixel per law."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(images), 1, figsize=(9, 1.05 * len(images) + 0.6), squeeze=False)
    for ax, (label, img) in zip(axes[:, 0], images.items()):
        ax.imshow(np.sqrt(np.clip(img, 0, vmax) / vmax), cmap="magma", vmin=0, vmax=1, aspect="auto",
                  interpolation="nearest")
        ax.set_ylabel(label, rotation=0, ha="right", va="center", fontsize=8)
        ax.set_yticks([])
        edges = np.searchsorted(exponents, [0.0, 0.5, 1.0])
        ax.set_xticks(edges)
        ax.set_xticklabels(["A_lo", "w=1/2", "A_hi"], fontsize=7)
        for x in edges:
            ax.axvline(x, color="white", lw=0.4, alpha=0.5)
    fig.suptitle("A plane receding across one LOD transition (left: level lo, right: level hi); "
                 "pixel intensity K / (N P p), sqrt scale", fontsize=9)
    fig.tight_layout()
    return fig
