"""The speed side on GPUs: every shipped shader compiled by a real GPU compiler (RADV/ACO null devices,
no GPU needed), and DB23's Table 1 and KPT25's Table 3 reproduced as ratios by the per-wave cost model
beside the papers' measured ratios (docs/guide/gpu_cost.md#the-two-tables)."""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..api.glinty_ndf import Material
from ..api.gpu_cost import DEFAULT_ARCHS, gpu_architectures, gpu_cost, gpu_driver
from ..api.shader_samplers import SHIPPED_SAMPLERS
from ..api.shaders import shipped_shaders
from ..validation import method_twins as MT
from ..validation.gpu_frames import METHODS, frame_cost, pixels_of
from ..validation.gpu_model import KernelCost
from .base import Context, Tables

NAME = "gpu_cost"
TITLE = "GPU cost: the shaders compiled for AMD GPUs, DB23 Table 1 and KPT25 Table 3 as ratios"
MEANING = ("A real GPU compiler (RADV's ACO, without a GPU) gives each shader's registers, occupancy and cycles; "
           "a per-wave model with measured trip counts turns them into frame costs whose ratios stand beside "
           "the papers' measured ones.")
DEFAULTS = {"archs": ",".join(DEFAULT_ARCHS), "scale": 0.25, "density_factors": [0.0625, 1.0, 16.0], "alphas": [0.3, 1.0]}
QUICK = {"archs": "gfx1100", "scale": 0.1, "density_factors": [0.0625, 16.0], "alphas": [0.3, 1.0]}
NOTEBOOK = ""
TABLE = {"db23_table1": ["scene", "arch", "method", "model_over_no_glints", "paper_over_no_glints", "model_over_db23",
                         "paper_over_db23"],
         "kpt25_table3": ["plane", "arch", "method", "model_over_db23", "paper_over_db23"]}

# DB23 Table 1 (ms per frame, RTX 2080, 1080p; min-max over the microfacet density) for the scenes glintlab has.
TABLE1_MS = {"sphere": {"No glints": (0.49, 0.49), "DB23": (0.79, 0.82), "ZK16": (1.15, 1.41)},
             "plane_90": {"No glints": (0.49, 0.49), "DB23": (1.15, 1.25), "ZK16": (1.40, 1.83)},
             "plane_25": {"No glints": (0.49, 0.49), "DB23": (1.15, 1.26), "ZK16": (2.50, 3.18)},
             "heightfield_90": {"No glints": (0.51, 0.51), "DB23": (1.52, 1.63), "ZK16": (1.93, 2.48)},
             "heightfield_25": {"No glints": (0.51, 0.51), "DB23": (1.44, 1.54), "ZK16": (3.29, 4.15)}}
# KPT25 Table 3 (ms, RTX 3090, 1080p, 3 lights, Beckmann; low and high roughness).
TABLE3_MS = {"plane_90": {"ZK16* (gated)": (1.42, 1.48), "DB23": (2.07, 2.06), "KPT25": (3.26, 3.27)},
             "plane_25": {"ZK16* (gated)": (2.72, 2.80), "DB23": (2.09, 2.06), "KPT25": (3.31, 3.36)}}


def _range(values) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:.2f}" if abs(hi - lo) < 0.005 else f"{lo:.2f}-{hi:.2f}"


def shader_statistics(archs) -> tuple[pd.DataFrame, dict]:
    """Every shipped shader (laws, method shaders, the sampler) on each architecture; and the method
    shaders' rows with their ISA (for the model)."""
    rows, isa = [], {}
    for name in [*sorted(shipped_shaders()), *METHODS, "wb16", *SHIPPED_SAMPLERS]:
        want_isa = name in METHODS
        t = gpu_cost(name, arch=archs, isa=want_isa)
        for r in t.to_dict("records"):
            if want_isa:
                isa[(name, r["arch"])] = KernelCost.from_stats(r)
                r.pop("isa"), r.pop("aco_ir")
            rows.append({"shader": name, **{k: v for k, v in r.items() if k != "shader"}})
    return pd.DataFrame(rows), isa


def _frames(scenes, archs, kernels, scale, densities_of, alpha=None) -> pd.DataFrame:
    arch_rows = {r["arch"]: r for r in gpu_architectures().to_dict("records")}
    out = []
    for scene in scenes:
        rows, material = MT.scene_rows(scene, scale, seed=1)
        for density in densities_of(material):
            mat = Material(density, material.target, alpha or material.alpha, material.R, material.angular_texel)
            px = pixels_of(rows, mat)
            for arch in archs:
                for method, label in METHODS.items():
                    f = frame_cost(method, kernels[(method, arch)], px, density, arch_rows[arch])
                    out.append({"scene": scene, "arch": arch, "method": label, "density": density, "alpha": mat.alpha,
                                "ms_1080p": 1e3 * f["seconds"] / scale**2, "waves": f["waves"],
                                "mean_wave_cycles": f["mean_wave_cycles"], "max_wave_cycles": f["max_wave_cycles"]})
    return pd.DataFrame(out)


def table1(frames: pd.DataFrame) -> pd.DataFrame:
    out = []
    for (scene, arch), g in frames.groupby(["scene", "arch"], sort=False):
        by = {m: g[g.method == m].set_index("density").ms_1080p for m in g.method.unique()}
        paper = TABLE1_MS[scene]
        for method in ("DB23", "ZK16", "ZK16* (gated)", "KPT25"):
            m = by[method]
            row = {"scene": scene, "arch": arch, "method": method,
                   "model_over_no_glints": _range(m / by["No glints"]), "model_over_db23": _range(m / by["DB23"]),
                   "paper_over_no_glints": "", "paper_over_db23": ""}
            if method in paper:
                lo, hi = paper[method]
                row["paper_over_no_glints"] = _range([lo / paper["No glints"][0], hi / paper["No glints"][0]])
                row["paper_over_db23"] = _range([lo / paper["DB23"][0], hi / paper["DB23"][1]])
            out.append(row)
    return pd.DataFrame(out)


def table3(frames: pd.DataFrame) -> pd.DataFrame:
    out = []
    for (scene, arch), g in frames.groupby(["scene", "arch"], sort=False):
        paper = TABLE3_MS[scene]
        db = g[g.method == "DB23"].set_index(["density", "alpha"]).ms_1080p
        for method in ("ZK16* (gated)", "ZK16", "KPT25"):
            m = g[g.method == method].set_index(["density", "alpha"]).ms_1080p
            p = paper.get(method)
            out.append({"plane": scene, "arch": arch, "method": method, "model_over_db23": _range(m / db),
                        "paper_over_db23": _range([p[0] / paper["DB23"][0], p[1] / paper["DB23"][1]]) if p else ""})
    return pd.DataFrame(out)


def gpu_pareto(stats: pd.DataFrame, arch: str, out) -> pd.DataFrame:
    """Each counting law with a shader twin: its function's GPU cost per evaluation on ``arch`` (ACO
    latency and instructions of the function alone, the kernel's VGPRs) beside its worst TV and CPU ns from
    the speed_accuracy section's table when that section ran into the same folder (else TV and ns are NaN)."""
    trade_path = Path(out) / "speed_accuracy.csv"
    trade = pd.read_csv(trade_path) if trade_path.is_file() else pd.DataFrame(columns=["law", "tv_max", "ns_per_sample"])
    rows = []
    for shader, twin in sorted(shipped_shaders().items()):
        r = stats[(stats.shader == shader) & (stats.arch == arch)]
        if r.empty:
            continue
        t = trade[trade.law.isin([twin, shader])]
        rows.append({"law": twin, "shader": shader, "arch": arch, "function_latency": float(r.function_latency.iloc[0]),
                     "function_instructions": float(r.function_instructions.iloc[0]), "vgprs": float(r.vgprs.iloc[0]),
                     "tv_max": float(t.tv_max.iloc[0]) if len(t) else float("nan"),
                     "ns_per_sample": float(t.ns_per_sample.iloc[0]) if len(t) else float("nan")})
    return pd.DataFrame(rows)


def compute(params: dict, ctx: Context) -> Tables:
    driver = gpu_driver()
    if driver["error"]:
        return Tables({"unavailable": pd.DataFrame([{"reason": driver["error"]}])}, {"GPU compiler": "missing"})
    archs, scale = [a.strip() for a in params["archs"].split(",")], float(params["scale"])
    stats, kernels = shader_statistics(archs)
    # Table 1: the scene's density times each factor (DB23 varies the microfacet density).
    frames1 = _frames(TABLE1_MS, archs, kernels, scale,
                      lambda m: [m.density * f for f in params["density_factors"]])
    # Table 3: the two planes at the scene's density, low and high roughness.
    frames3 = pd.concat([_frames(TABLE3_MS, archs, kernels, scale, lambda m: [m.density], alpha=a)
                         for a in params["alphas"]], ignore_index=True)
    t1, t3 = table1(frames1), table3(frames3)
    z = t1[(t1.method == "ZK16") & (t1.arch == archs[-1])]
    headline = {"driver": str(stats.driver.iloc[0]), "architectures": ", ".join(archs),
                "ZK16 / DB23 (model, " + archs[-1] + ")": "; ".join(f"{s} {r}" for s, r in zip(z.scene, z.model_over_db23))}
    pareto = gpu_pareto(stats, archs[-1], ctx.out)
    return Tables({"db23_table1": t1, "kpt25_table3": t3, "gpu_pareto": pareto, "shader_statistics": stats},
                  headline, extra={"frames_table1": frames1, "frames_table3": frames3})


def figures(tables: Tables, ctx: Context) -> list:
    import matplotlib.pyplot as plt
    if "frames_table1" not in tables:
        return []
    frames = tables["frames_table1"]
    arch = frames.arch.iloc[-1]
    g = frames[(frames.arch == arch)]
    fig, ax = plt.subplots(figsize=(7.0, 3.8))
    scenes = list(dict.fromkeys(g.scene))
    width = 0.8 / len(METHODS)
    for k, label in enumerate(METHODS.values()):
        vals = [g[(g.scene == s) & (g.method == label)].ms_1080p.max() for s in scenes]
        ax.bar([i + k * width for i in range(len(scenes))], vals, width, label=label)
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(scenes))], scenes)
    ax.set_ylabel("model ms / 1080p frame (max over N)")
    ax.set_yscale("log")
    ax.legend(fontsize=7)
    ax.set_title(f"Per-wave model on {arch}: the glint pass alone (no geometry, no memory)", fontsize=9)
    path = Path(ctx.out) / "gpu_cost_frames.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path] + pareto_figure(tables["gpu_pareto"], ctx)


def pareto_figure(pareto: pd.DataFrame, ctx: Context) -> list:
    """Worst TV against the GPU cycles per evaluation (left) and the CPU ns per sample (right)."""
    import matplotlib.pyplot as plt
    if pareto.empty or pareto.tv_max.isna().all():
        return []
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6), sharey=True)
    for ax, col, label in ((axes[0], "function_latency", f"ACO latency of the law's function, cycles ({pareto.arch.iloc[0]})"),
                           (axes[1], "ns_per_sample", "CPU ns / sample (speed_accuracy section)")):
        for r in pareto.itertuples():
            ax.semilogy(getattr(r, col), max(r.tv_max, 1e-6), "o", color="#b2182b")
            ax.annotate(r.law, (getattr(r, col), max(r.tv_max, 1e-6)), fontsize=7, xytext=(4, 2), textcoords="offset points")
        ax.set_xlabel(label, fontsize=8)
    axes[0].set_ylabel("worst TV over the standard grid")
    fig.suptitle("Speed / accuracy with a GPU axis: the shader laws", fontsize=9)
    path = Path(ctx.out) / "gpu_pareto.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]
