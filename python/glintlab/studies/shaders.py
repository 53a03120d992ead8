"""The shaders as they run: each shipped shader (HLSL and GLSL), compiled to SPIR-V and run by Vulkan,
against its C++ float32 twin on the same uniforms (row by row), against the twin's exact pmf
(chi-square at DB23's Figure 9 points) and for speed (ns per evaluation, the twin as the baseline).
Whole method shaders too: DB23's counting pipeline as a shader against glintlab's C++ DB23 on one
scene's pixels, as rendered and under the float32 effects a renderer meets (uv far from the origin,
far geometry, grazing footprints; docs/math/glint_images.md#glint-db23-shader).

Also ``glintlab shader``'s report (``verdict_tables``, ``verdict_files``; the report runner writes the
tables as CSV): the verdict as JSON and Markdown, and the TV map of the shader against the law it
claims to approximate.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from ..api.shaders import LANGUAGES, shader_law, shipped_shader, shipped_shaders, shipped_twin, vulkan_devices
from ..validation.method_twins import float32_study
from ..validation.shader_check import point_table, row_table, speed_table
from .base import Context, Tables

NAME = "shaders"
TITLE = "The shaders as they run: C++ emulation against the real SPIR-V run"
MEANING = ("Each shipped shader, compiled to SPIR-V and run on Vulkan, matches its exact pmf, and its C++ float32 "
           "twin row by row except at most a few rows in 10^4, where the device's pow, exp or log is a few ulps off. "
           "DB23's counting pipeline and KPT25's Algorithm 1 as whole method shaders agree with glintlab's C++ DB23 "
           "and KPT25 pixel by pixel on plane_25 (115 x 65 pixels, 16 mismatches examined per case); float32 keeps "
           "DB23 within the allowance up to about 1e4 texels from the uv origin and KPT25 up to about 1e2, and "
           "grazing footprints flip DB23's Gaussian count by one on up to a tenth of the pixels.")
# method_scene at method_scale of its resolution (plane_25: 115 x 65 = 7 475 lit pixels at 0.06): the
# DB23 and KPT25 method shaders' float32 table, about 2 s plus their two compilations (1.5 s each).
DEFAULTS = {"rows": 1_000_000, "samples": 1_000_000, "speed_evaluations": 1_000_000, "method_scene": "plane_25",
            "method_scale": 0.06}
QUICK = {"rows": 100_000, "samples": 200_000, "speed_evaluations": 200_000, "method_scale": 0.04}
TABLE = {"shaders_as_they_run": ["shader", "device", "binned_differ_max", "raw_differ_max", "binned_max_dk",
                                 "chi2_min_pvalue", "ratio"],
         "method_shader_float32": ["method", "case", "pixels", "mismatch_share", "beyond_1pct", "max_rel_err",
                                   "reasons"]}
#: The DB23 and KPT25 method shaders as rendered may differ from their twins beyond the float32
#: allowance on at most this share of the pixels (measured on lavapipe: 0 to 0.13 %).
METHOD_MAX_SHARE = 0.002


def compute(params: dict, ctx: Context) -> Tables:
    devices = vulkan_devices()
    if not devices:
        return Tables({}, failures=["no Vulkan device: install mesa-vulkan-drivers (lavapipe)"])
    summary, per_point = [], []
    failures = []
    for name in shipped_shaders():
        for language in LANGUAGES:
            ctx.progress(f"{name}.{language}")
            law = shader_law(shipped_shader(name, language), name=f"{name}.{language}", register=False)
            twin = shipped_twin(name)
            rows = row_table(law, twin, rows=params["rows"], seed=ctx.seed)
            points = point_table(law, twin, samples=params["samples"], seed=ctx.seed)
            speed = speed_table(law, twin, evaluations=params["speed_evaluations"])
            per_point.append(rows.assign(shader=f"{name}.{language}", twin=twin.name))
            summary.append(dict(shader=f"{name}.{language}", twin=twin.name, device=law.device,
                                raw_differ_max=rows.raw_differ.max(), raw_max_dk=rows.raw_max_dk.max(),
                                binned_differ_max=rows.binned_differ.max(), binned_max_dk=rows.binned_max_dk.max(),
                                chi2_min_pvalue=points.pvalue.min(), shader_ns=speed.shader_ns[0],
                                twin_ns=speed.baseline_ns[0], ratio=speed.ratio[0]))
            failures += [f"{name}.{language} differs from {twin.name} at n = {r.n:g}, p = {r.p:g} "
                         f"({r.binned_differ:.3g} of the rows)" for r in rows.itertuples() if not r.ok]
            failures += [f"{name}.{language} against the pmf of {twin.name} at n = {r.n:g}, p = {r.p:g}: "
                         f"p-value {r.pvalue:.3g}" for r in points.itertuples() if not r.ok]
    table = pd.DataFrame(summary)
    ctx.progress("db23 and kpt25 method shaders, float32 cases")
    method = float32_study(params["method_scene"], params["method_scale"], seed=ctx.seed, explain_limit=16)
    rendered = method[method.case == "as rendered"].set_index("method")
    for name, r in rendered.iterrows():
        if r.mismatch_share > METHOD_MAX_SHARE:
            failures.append(f"the {name} method shader differs from its C++ twin beyond the float32 allowance on "
                            f"{r.mismatch_share:.3g} of the pixels of {params['method_scene']} (at most {METHOD_MAX_SHARE})")
    return Tables({"shaders_as_they_run": table, "method_shader_float32": method},
                  {"device": devices[0]["name"] if len(devices) == 1 else table.device[0],
                   "largest share of rows differing (binned)": float(table.binned_differ_max.max()),
                   "shader / C++ twin time (gated.hlsl)": float(table.ratio[table.shader == "gated.hlsl"].iloc[0]),
                   **{f"{m} method shader: pixels beyond the float32 allowance, as rendered ({params['method_scene']}, "
                      f"{int(r.pixels)} px) / at uv + 1e6 texels": f"{r.mismatch_share:.2g} / "
                      f"{float(method.mismatch_share[(method.method == m) & (method.case == 'uv + 1e6 texels')].iloc[0]):.2g}"
                      for m, r in rendered.iterrows()}},
                  failures, extra={"shaders_row_by_row": pd.concat(per_point, ignore_index=True)})


def figures(tables: Tables, ctx: Context) -> list:
    import matplotlib.pyplot as plt
    if "shaders_row_by_row" not in tables:
        return []
    t = tables["shaders_row_by_row"]
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    labels = [f"({n:g}, {p:g})" for n, p in zip(t.n, t.p)]
    shaders = list(dict.fromkeys(t.shader))
    width = 0.8 / len(shaders)
    xs = np.arange(len(labels) // len(shaders))
    for i, s in enumerate(shaders):
        g = t[t.shader == s]
        ax.bar(xs + i * width, np.maximum(g.binned_differ, 1e-7), width, label=f"{s} (binned)")
        ax.plot(xs + i * width, np.maximum(g.raw_differ, 1e-7), "k.", ms=4)
    ax.set_yscale("log")
    ax.set_xticks(xs + 0.4 - width / 2, labels[:len(xs)], fontsize=7)
    ax.set_xlabel("(n, p)")
    ax.set_ylabel("share of rows differing (1e-7: none)")
    ax.set_title("Vulkan run against the C++ float32 twin, same uniforms (dots: raw output)", fontsize=9)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    return [ctx.save(fig, "shaders_row_by_row.png", 110)]


def verdict_tables(verdict: dict, law, against: str, twin: str | None) -> Tables:
    """``glintlab shader``'s tables (one CSV each, written by the report runner's one writing path) and
    what ``verdict_files`` needs besides them."""
    return Tables(dict(verdict["tables"]), data={"verdict": verdict, "law": law, "against": against, "twin": twin})


def verdict_files(tables: Tables, ctx: Context) -> list:
    """``glintlab shader``'s report in ``ctx.out`` besides the CSVs: ``tv_map.png`` (TV of the shader's
    histograms to the exact pmf of ``against`` over the standard grid, and the sampling floor),
    ``verdict.json`` and ``verdict.md``. Returns their paths, the Markdown page last."""
    import matplotlib.pyplot as plt
    out = Path(ctx.out)
    verdict, law, against, twin = (tables[k] for k in ("verdict", "law", "against", "twin"))
    tables = tables.tables
    grid = tables["grid"]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
    for ax, col, title in zip(axes, ("tv", "tv_floor"), (f"TV(shader, {against})", f"floor: TV({against} draws, {against})")):
        piv = grid.pivot(index="p", columns="n", values=col)
        im = ax.pcolormesh(piv.columns, piv.index, piv.to_numpy(), shading="nearest", vmin=0,
                           vmax=max(float(np.nan_to_num(grid.tv.max())), 1e-3))
        ax.set_xscale("log")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("n")
    axes[0].set_ylabel("p")
    fig.colorbar(im, ax=axes)
    fig.savefig(out / "tv_map.png", dpi=100)
    plt.close(fig)
    speed = tables["speed"].iloc[0]
    summary = {"shader": law.source_name, "language": law.language, "entry": law.entry, "device": law.device,
               "against": against, "twin": twin, "passed": not verdict["failures"], "failures": verdict["failures"],
               "gpu_faithful": verdict.get("gpu_faithful", True), "caveat": verdict.get("caveat"),
               "ns_per_evaluation": float(speed.shader_ns), "baseline": speed.baseline,
               "baseline_precision": speed.get("baseline_precision", "float32"),
               "baseline_ns": float(speed.baseline_ns), "ratio": float(speed.ratio),
               "grid_tv_max": float(grid.tv.max()), "grid_tv_floor_max": float(grid.tv_floor.max())}
    if "rows" in tables:
        summary["rows_binned_differ_max"] = float(tables["rows"].binned_differ.max())
        summary["rows_binned_max_dk"] = float(tables["rows"].binned_max_dk.max())
    (out / "verdict.json").write_text(json.dumps(summary, indent=1) + "\n")
    pts = tables["points"]
    lines = [f"# glintlab shader: {Path(law.source_name).name} ({law.language}, entry {law.entry})", "",
             f"Device: {law.device}. Verdict: **{'pass' if summary['passed'] else 'FAIL'}**.", ""]
    lines += [f"- {f}" for f in verdict["failures"]]
    if summary["caveat"]:
        lines += ["", f"**Not what a GPU would compute**: {summary['caveat']}."]
    lines += ["", f"## Against the exact pmf of {against} (Figure 9 points)", "",
              "| n | p | TV | chi2 | dof | p-value | pass |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r.n:g} | {r.p:g} | {r.tv:.4g} | {r.chi2:.4g} | {r.dof} | {r.pvalue:.3g} | {r.ok} |"
              for r in pts.itertuples()]
    lines += ["", f"Standard grid: largest TV {summary['grid_tv_max']:.4g} (sampling floor up to "
              f"{summary['grid_tv_floor_max']:.4g}); map: tv_map.png.", ""]
    if "rows" in tables:
        lines += [f"## Row by row against the C++ twin {twin} (float32, same uniforms)", "",
                  "| n | p | raw rows differing | largest raw dK | binned rows differing | largest binned dK |",
                  "|---|---|---|---|---|---|"]
        lines += [f"| {r.n:g} | {r.p:g} | {r.raw_differ:.3g} | {r.raw_max_dk:.3g} | {r.binned_differ:.3g} | "
                  f"{r.binned_max_dk:g} |" for r in tables["rows"].itertuples()]
        lines.append("")
    ext = tables["extremes"]
    lines += [f"Extremes suite (float32): {int(ext.breaks.sum())} rows with NaN, inf, negative counts or errors; "
              f"{int((ext.above_n > 0).sum())} rows with counts above ceil(n), of {len(ext)}.", "",
              f"Speed: {speed.shader_ns:.3g} ns per evaluation on {law.device} (transfers included); "
              f"{speed.baseline} in C++ {summary['baseline_precision']}: {speed.baseline_ns:.3g} ns; "
              f"ratio {speed.ratio:.3g}.", ""]
    path = out / "verdict.md"
    path.write_text("\n".join(lines))
    return [out / "tv_map.png", out / "verdict.json", path]
