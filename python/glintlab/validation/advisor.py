"""The advisor: the cheapest law meeting an error budget on a scene's pixels, from its profile
(``glintlab.validation.profile``)."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.gpu_cost import gpu_cost
from ..api.shaders import shipped_shaders
from .profile import TILE, SceneProfile, group_max, n_band, profile_scene, simd_stats

#: What a law's evaluation costs: "cpu", the profile's modelled ns (the law's recorded CPU ns per
#: evaluation); "gpu", the ACO latency of its shader twin's function on ``gpu_arch`` (cycles per
#: evaluation, glintlab's wrapper subtracted; RADV null devices, docs/guide/gpu_cost.md). Either is
#: multiplied by the scheme's evaluations per pixel and charged per SIMD group by its worst lane.
COST_AXES = ("cpu", "gpu")
#: RDNA3, the GPU axis's default architecture.
GPU_ARCH = "gfx1100"


@functools.lru_cache(maxsize=8)
def gpu_law_cycles(arch: str = GPU_ARCH) -> dict:
    """{law: ACO latency of its shader twin's function on ``arch``, cycles per evaluation}: the laws with a
    shipped shader (dual_gated, gated_continuous, gated_shader, head_cf); the others (the exact binomial,
    zk16, gaussian, threshold) have no GPU cost. A compiler's output, not a timing: the same on any machine
    with the same driver. Loops in a law's code count once (ACO's estimate is static)."""
    return {twin: float(gpu_cost(shader, arch=arch).function_latency.iloc[0])
            for shader, twin in sorted(shipped_shaders().items())}


def _pixel_costs(prof, scheme: str, labels, cost_axis: str, gpu_arch: str) -> dict:
    """{law: (H, W) cost per pixel} on the chosen axis; on the GPU axis only the laws with a GPU cost."""
    if cost_axis == "cpu":
        return {lab: prof.pixel_cost(scheme, lab) for lab in labels}
    cycles = gpu_law_cycles(gpu_arch)
    return {lab: np.where(prof.valid, prof.evaluations[scheme] * cycles[lab], 0.0) for lab in labels if lab in cycles}


# --------------------------------------------------------------------------------------------------
# Advisor

@dataclass
class Advice:
    law: str
    scheme: str
    cost: float            # mean SIMD group cost (cost_axis "cpu": modelled ns; "gpu": ACO cycles)
    worst_group: float
    error: dict            # the chosen law's errors on the scene
    candidates: pd.DataFrame
    budget: dict
    per_regime: pd.DataFrame | None = None
    cost_axis: str = "cpu"
    gpu_arch: str | None = None

    def __str__(self):
        b = ", ".join(f"{k} <= {v:g}" for k, v in self.budget.items() if k in ("max_tv", "max_rel_error") and v is not None)
        cov = self.budget.get("coverage", 1.0)
        unit = (f"ACO cycles on {self.gpu_arch}, the laws with a shader" if self.cost_axis == "gpu"
                else "modelled CPU ns, not GPU ms")
        head = (f"cheapest law meeting {b or 'no budget'} on {cov:.0%} of the pixels ({self.scheme}): {self.law}\n"
                f"  expected cost {self.cost:.4g} per SIMD group of 32 (worst group {self.worst_group:.4g}; {unit})"
                f"\n  error: " + ", ".join(f"{k} {v:.3g}" for k, v in self.error.items()))
        return head

    def to_dict(self):
        return {"law": self.law, "scheme": self.scheme, "cost_axis": self.cost_axis, "gpu_arch": self.gpu_arch,
                "cost_mean_group": self.cost, "cost_worst_group": self.worst_group,
                "error": self.error, "budget": self.budget,
                "candidates": self.candidates.to_dict(orient="records"),
                "per_regime": None if self.per_regime is None else self.per_regime.to_dict(orient="records")}


def _budget(name, value):
    if value is None:
        return None
    value = V.real(name, value)
    if math.isnan(value) or value < 0:
        V.fail(name, value, "a number >= 0 (inf for no limit)")
    return value


def advise(scene_or_profile, max_tv=None, max_rel_error=None, coverage: float = 1.0, per_regime: bool = False,
           scheme: str = "db23_tetrahedral", cost_axis: str = "cpu", gpu_arch: str = GPU_ARCH,
           **profile_kwargs) -> Advice:
    """The cheapest law (by mean SIMD group cost on ``scheme``) whose per-pixel error meets the budget
    on at least ``coverage`` of the scene's pixels: TV to the binomial <= ``max_tv`` and/or the
    relative intensity error |E[K] / (n p) - 1| <= ``max_rel_error``. A budget of 0 leaves the exact
    law (and laws identical to it on every pixel of this scene); an infinite one the cheapest law.
    ``per_regime``: one law per n band (the cheapest meeting the budget there); the combined SIMD cost
    charges a group the worst lane of each law it runs (divergent branches execute one after another).
    ``cost_axis`` (:data:`COST_AXES`): "cpu" (the recorded CPU ns) or "gpu" (ACO cycles on ``gpu_arch``, the
    laws with a shader twin only: a budget none of them meets is a ValueError)."""
    V.choice("cost_axis", cost_axis, COST_AXES, "'cpu' or 'gpu'")
    max_tv, max_rel_error = _budget("max_tv", max_tv), _budget("max_rel_error", max_rel_error)
    coverage = V.real("coverage", coverage)
    if not (0 < coverage <= 1):
        V.fail("coverage", coverage, "a share in (0, 1]")
    prof = scene_or_profile if isinstance(scene_or_profile, SceneProfile) else \
        profile_scene(scene_or_profile, **profile_kwargs)
    if scheme not in prof.evaluations:
        V.fail("scheme", scheme, f"one of the profiled schemes ({', '.join(prof.evaluations)})")
    cost_px = _pixel_costs(prof, scheme, list(prof.costs.law), cost_axis, gpu_arch)
    labels = list(cost_px)
    valid = prof.valid

    def meets(errs_tv, errs_rel, mask=None):
        ok = np.ones(errs_tv.shape, bool)
        if max_tv is not None:
            ok &= errs_tv <= max_tv
        if max_rel_error is not None:
            ok &= errs_rel <= max_rel_error
        return ok

    rows, err_px = [], {}
    for lab in labels:
        tv, rel = prof.pixel_error(lab, "tv"), prof.pixel_error(lab, "mean_rel_err")
        err_px[lab] = (tv, rel)
        st = simd_stats(cost_px[lab], valid)
        share = float(meets(tv, rel).mean()) if tv.size else 1.0
        rows.append({"law": lab, "cost_mean_group": st["mean_group"], "cost_worst_group": st["worst_group"],
                     "cost_mean_pixel": st["mean_pixel"], "tv_worst": float(tv.max()) if tv.size else 0.0,
                     "tv_at_coverage": float(np.quantile(tv, coverage, method="higher")) if tv.size else 0.0,
                     "rel_err_worst": float(rel.max()) if rel.size else 0.0,
                     "share_meeting": share, "meets_budget": share >= coverage - 1e-12})
    cand = pd.DataFrame(rows).sort_values(["meets_budget", "cost_mean_group"], ascending=[False, True],
                                          kind="stable").reset_index(drop=True)
    best = cand.iloc[0]
    budget = {"max_tv": max_tv, "max_rel_error": max_rel_error, "coverage": coverage}
    if not best.meets_budget:  # on the CPU axis the exact binomial meets every budget; the GPU axis has no exact law
        V.fail("max_tv" if max_tv is not None else "max_rel_error", max_tv if max_tv is not None else max_rel_error,
               f"a budget one of the laws with a GPU cost ({', '.join(labels)}) meets on {coverage:.0%} of the "
               f"pixels (the best reaches tv {cand.tv_at_coverage.min():.3g}), or cost_axis='cpu' (the exact binomial)")
    error = {"tv_worst": best.tv_worst, "tv_at_coverage": best.tv_at_coverage, "rel_err_worst": best.rel_err_worst,
             "tv_mean": float(err_px[best.law][0].mean()) if valid.any() else 0.0}
    advice = Advice(best.law, scheme, float(best.cost_mean_group), float(best.cost_worst_group), error, cand, budget,
                    cost_axis=cost_axis, gpu_arch=gpu_arch if cost_axis == "gpu" else None)
    if per_regime:
        band, names = n_band(prof.maps["n"][valid])
        choice = np.empty(band.size, dtype=object)
        reg_rows = []
        for b in np.unique(band):
            m = band == b
            options = []
            for lab in labels:
                ok = meets(err_px[lab][0][m], err_px[lab][1][m])
                if ok.mean() >= coverage - 1e-12:
                    options.append((float(cost_px[lab][valid][m].mean()), lab))
            if not options:  # the GPU axis only: no exact law among its candidates
                V.fail("max_tv" if max_tv is not None else "max_rel_error",
                       max_tv if max_tv is not None else max_rel_error,
                       f"a budget a law with a GPU cost meets in the n band {names[b]}, or cost_axis='cpu'")
            best_b = min(options)[1]
            choice[m] = best_b
            reg_rows.append({"n_band": names[b], "pixels": int(m.sum()), "law": best_b,
                             "cost_mean_pixel": float(cost_px[best_b][valid][m].mean()),
                             "tv_worst": float(err_px[best_b][0][m].max())})
        # Divergent SIMD: a group pays, for each law it runs, that law's worst lane.
        total = np.zeros((-(-valid.shape[0] // TILE[0]), -(-valid.shape[1] // TILE[1])))
        lane_cost = np.zeros(valid.shape)
        for lab in set(choice):
            mask = np.zeros(valid.shape, bool)
            mask[valid] = choice == lab
            g, _ = group_max(cost_px[lab], mask)
            total = total + g
            lane_cost[mask] = cost_px[lab][mask]
        used = group_max(np.zeros(valid.shape), valid)[1] > 0
        reg = pd.DataFrame(reg_rows)
        reg.attrs.update(cost_mean_group=float(total[used].mean()), cost_worst_group=float(total.max()),
                         cost_mean_pixel=float(lane_cost[valid].mean()))
        advice.per_regime = reg
    return advice


# --------------------------------------------------------------------------------------------------
# Tables of several profiles

def combine_tables(profiles) -> dict:
    names = ("summary", "regimes", "laws", "schemes", "costs", "table1", "cost_units")
    return {name: pd.concat([p.tables[name] for p in profiles], ignore_index=True) for name in names}


def advice_table(profiles, max_tv: float = 0.05, scheme: str = "db23_tetrahedral") -> pd.DataFrame:
    rows = []
    for prof in profiles:
        a = advise(prof, max_tv=max_tv, scheme=scheme)
        b = advise(prof, max_tv=max_tv, scheme=scheme, per_regime=True)
        rows.append({"scene": prof.name, "max_tv": max_tv, "scheme": scheme, "law": a.law,
                     "cost_mean_group": a.cost, "cost_worst_group": a.worst_group, "tv_worst": a.error["tv_worst"],
                     "per_regime_laws": "; ".join(f"{r.n_band}: {r.law}" for r in b.per_regime.itertuples()),
                     "per_regime_cost_mean_group": b.per_regime.attrs["cost_mean_group"]})
    return pd.DataFrame(rows)
