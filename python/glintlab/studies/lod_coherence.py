"""Coherence along zoom and pan paths (``lod.zoom_study``, ``lod.pan_study``) and the cost of
non-integer trial counts (``lod.non_integer_trials_table``)."""
from __future__ import annotations

import pandas as pd

from . import lod
from .base import Context, Tables

NAME = "lod_coherence"
TITLE = "Coherence along zoom and pan paths; non-integer trial counts"
MEANING = ("Along zoom and pan paths every blend is temporally coherent (consecutive counts strongly correlated, "
           "as the ground truth's are); non-integer trial counts (eq. 10) cost at most a small, bounded TV.")
DEFAULTS = {"paths": 1000}
QUICK = {"paths": 200}
NOTEBOOK = "lod_blending.ipynb"
TABLE = {"lod_coherence": ["path", "law", "inner", "mean_abs_step", "pop_rate", "corr_lag1", "corr_ends"]}


def compute(params: dict, ctx: Context) -> Tables:
    trials = lod.non_integer_trials_table()
    zoom, zoom_K = lod.zoom_study(paths=params["paths"], seed=ctx.seed)
    pan, pan_K = lod.pan_study(paths=params["paths"], seed=ctx.seed)
    coh = pd.concat([zoom, pan], ignore_index=True)
    return Tables({"lod_coherence": coh, "lod_non_integer_trials": trials},
                  {"largest TV from non-integer trials": float(trials.max_tv.max())},
                  data={"zoom": zoom, "zoom_K": zoom_K, "pan": pan, "pan_K": pan_K})


def figures(tables: Tables, ctx: Context) -> list:
    fig = coherence_figure(tables["zoom_K"], tables["pan_K"], tables["zoom"], tables["pan"])
    return [ctx.save(fig, "lod_coherence.png")]


def coherence_figure(zoom_K, pan_K, zoom_table, pan_table, examples: int = 3):
    """Counts along a few zoom and pan paths per law (same paths and seeds for every law), and the
    coherence metrics of ``lod.zoom_study`` / ``lod.pan_study``."""
    import matplotlib.pyplot as plt

    labels = [key for key in zoom_K if key[1] in ("-", "binomial")]
    fig, axes = plt.subplots(2, len(labels), figsize=(2.6 * len(labels), 5.2), sharey="row", squeeze=False)
    for row, (K_by, table, kind) in enumerate(((zoom_K, zoom_table, "zoom"), (pan_K, pan_table, "pan"))):
        for col, key in enumerate(labels):
            ax = axes[row, col]
            K = K_by[key]
            for j in range(min(examples, K.shape[0])):
                ax.plot(K[j], lw=1.0)
            m = table[(table.law == key[0]) & (table.inner == key[1])].iloc[0]
            ax.set_title(f"{kind}: {key[0]}\n|dK| {m.mean_abs_step:.2f}, pops {m.pop_rate:.3f}, "
                         f"r1 {m.corr_lag1:.2f}", fontsize=7)
            ax.set_xlabel("step", fontsize=7)
            ax.tick_params(labelsize=7)
        axes[row, 0].set_ylabel("K")
    fig.suptitle("Coherence along a zoom (A_lo to A_hi) and a pan (1/16 footprint per step): same paths, "
                 "same seeds; ground truth counted on one facet realization per path", fontsize=8)
    fig.tight_layout()
    return fig
