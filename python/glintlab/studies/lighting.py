"""Glints under real lights (KK24, KK25; docs/math/lighting.md): the reflection probability of an area light,
exact by cubature against its approximations, the counting laws against facets lit by the same light, and
an environment map's regions counted as a multinomial (numbers: ``validation.lighting``)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api import lights as gl_lights
from ..api.lighting import reflection_probability
from ..api.method_registry import IMAGE_METHODS
from ..api.shaders import NoVulkanDevice
from ..validation import lighting as VL
from ..validation import lighting_images as LI
from ..validation import lighting_methods as LM
from ..validation.scene_images import resolve_scene, with_density
from . import sampling_lighting
from .base import Context, Tables

NAME = "lighting"
TITLE = "Glints under area lights and environment maps (KK24, KK25)"
MEANING = ("The probability that a facet mirrors the view into an extended light, exact by cubature, is what "
           "explicit facets lit by that light count (binomial per light, multinomial per region of a map); "
           "the point-light and locally constant approximations hold for lights small against the NDF's lobe, "
           "and only a joint test over the regions sees a multinomial drawn as independent binomials.")
DEFAULTS = {"targets": ["beckmann", "ggx"], "alphas": [0.05, 0.2, 0.5], "half_angles": [0.01, 0.05, 0.2],
            "elevations_deg": [20.0, 45.0], "views_deg": [10.0, 40.0, 70.0], "count_half_angles": [0.001, 0.02, 0.1, 0.3],
            "realizations": 2, "tolerance": 0.05,
            # Images of a Table 1 plane under a cap, a window and the sky (validation.lighting_images): this
            # fraction of 1920 x 1080 per side, N x density_factor x scale^2, frames of the scene images' path
            # (about 10 s; FULL_SCENE's sizes, 4 minutes, are make bench's: bench/bench_lighting.py).
            "scene": "plane_25", "scene_scale": 1.0 / 12, "scene_density_factor": 0.25, "scene_frames": 3,
            "scene_cap_half_angle": 0.2, "scene_rect_half_widths": [0.3, 0.2], "scene_grid_nodes": 13,
            # The registered NDF image methods under the cap and the window by quadrature over the light's
            # directions (validation.lighting_methods; S = k^2 samples per pixel): "smooth" is the quadrature's check.
            # (make run's budget: the quadrature costs about 0.5 us per pixel and sample, so three methods at 25
            # samples, ZK16 under the map only; make bench's FULL_SCENE renders all four on larger images at 36.)
            "scene_methods": ["smooth", "db23_trilinear[gated]", "kpt25"],
            "scene_method_samples": 25, "scene_method_lights": ["cap"],  # make run: the cap; QUICK and bench: both
            # ... and under the sky: its cells pooled in blocks of scene_map_block (its sun and window at their own cells).
            "scene_map_methods": ["smooth", "zk16"], "scene_map_block": 16,
            # The sphere under the same cap and window, each pixel lit in its own tangent frame (the exact p by
            # cubature per pixel at sphere_rel_tol; docs/math/lighting.md#lighting-scene-images).
            "sphere_scene": "sphere", "sphere_scale": 1.0 / 20, "sphere_rel_tol": 1e-6,
            # The sphere under the sky in world space at this scale, or None: the map's exact p per pixel costs
            # ~7 ms (20x a cap's), so the report leaves it to make bench (FULL_SCENE).
            "sphere_envmap_scale": None}
# KPT25's Algorithm 2 under the sky map (studies.sampling_lighting with the map's radiance): pixels of its
# PIXELS, estimates x samples per estimator, the view's polar angle; |z| above alg2_max_z fails the section.
DEFAULTS.update({"alg2_pixels": [0, 2], "alg2_repeats": 64, "alg2_samples": 256, "alg2_wo_theta_deg": 30.0,
                 "alg2_max_z": 4.0})
# make bench's full sizes; the registered methods at QUICK's lists and samples (at 480 x 270 x 8 frames each
# method costs about 0.5 us per pixel and sample: ~10 s per method and light at 36 samples).
FULL_SCENE = {"scene_scale": 0.25, "scene_frames": 8, "scene_grid_nodes": 17, "sphere_scale": 0.125,
              "sphere_envmap_scale": 1.0 / 20,
              "scene_methods": ["smooth", "db23_trilinear[gated]", "zk16", "kpt25"], "scene_method_samples": 36,
              "scene_method_lights": ["cap", "rect"],
              "scene_map_methods": ["smooth", "zk16"], "scene_map_block": 16}
QUICK = {"scene_scale": 1.0 / 16, "scene_frames": 3, "scene_grid_nodes": 9, "scene_method_samples": 25,
         "scene_method_lights": ["cap", "rect"],
         "scene_methods": ["smooth", "db23_trilinear[gated]", "zk16", "kpt25"], "scene_map_methods": ["smooth", "zk16"],
         "scene_map_block": 16,
         "alphas": [0.05, 0.3], "half_angles": [0.01, 0.1], "elevations_deg": [30.0], "views_deg": [20.0, 60.0],
         "count_half_angles": [0.001, 0.1, 0.3], "realizations": 1, "alg2_pixels": [0], "alg2_repeats": 32,
         "alg2_samples": 128}
NOTEBOOK = "lighting.ipynb"
TABLE = {
    "lighting_accuracy": ["method", "target", "kind", "half_angle", "configurations", "share_within",
                          "median_abs_rel_err", "max_abs_rel_err"],
    "lighting_counts": ["half_angle", "method", "law", "p", "chi2_pvalue", "tv", "facet_mean", "law_mean", "facet_sd",
                        "law_sd"],
    "lighting_point_limit": ["half_angle", "p_exact", "p_point", "ratio", "R_equivalent", "p_db23"],
    "lighting_envmap": ["source", "method", "scheme", "chi2", "dof", "chi2_pvalue", "p_0", "p_1", "p_2"],
    "lighting_own_truths": ["method", "light", "lit_as", "expected", "count", "z", "z_normal_variant",
                            "z_no_solid_angle", "z_unnormalised", "pass"],
    "lighting_images": ["image", "mean_count", "vs_facets", "vs_expected", "lit_share"],
    "lighting_kpt25_envmap": ["pixel", "estimator", "samples", "reference", "reference_error", "mean", "z",
                              "relative_std_per_sample", "rmse_ratio_to_alg2"],
    "lighting_scene_images": ["scene", "light", "method", "own_std_ratio", "own_pop_rate", "own_truth_change_rate",
                              "own_mean_ratio", "smooth_mean_ratio", "lit_facets", "count_ratio", "expected_ratio",
                              "streak_excess"],
}
#: The shipped area-light shader's lit facets over their expectation at the exact p must lie within this
#: factor: with the section's ~10^2 to 10^3 expected lit facets per path a Poisson count misses it with probability
#: far below 1e-6, while the shader without the light's solid angle is off by 1 / Omega (8 for the cap).
SHADER_FACTOR = 2.0
#: The smooth NDF through the registered methods' quadrature over the light (validation.lighting_methods) must sum
#: to the exact p's sum within this relative error (the quadrature's, about 1.5e-3 p-weighted at the QUICK 25 samples, and
#: the exact p grid's, below 1e-4): deterministic, so a failure is a bug.
QUADRATURE_TOL = 1e-2
PASS = 1e-3  # the chi-square level of the exact paths' checks (their false-failure rate; the seeds are fixed)


def compute(params: dict, ctx: Context) -> Tables:
    ctx.progress("probabilities")
    probs = VL.probability_table(tuple(params["targets"]), tuple(params["alphas"]), tuple(params["half_angles"]),
                                 tuple(params["elevations_deg"]), tuple(params["views_deg"]))
    accuracy = VL.where_accurate(probs, params["tolerance"])
    ctx.progress("counts under a cap")
    counts = VL.area_light_counts(half_angles=tuple(params["count_half_angles"]), realizations=params["realizations"],
                                  seed=ctx.seed)
    limit = VL.point_limit_table()
    ctx.progress("environment map")
    env = gl_lights.envmap("sky", regions=3)
    envtab, partition = VL.envmap_counts(env, realizations=params["realizations"], seed=ctx.seed)
    ctx.progress("KPT25's points and WWH18's flakes under the lights")
    own = VL.own_truth_table(seed=ctx.seed)
    ctx.progress("images")
    images, image_table = VL.plane_images(window_light(), seed=ctx.seed)
    ctx.progress("KPT25's Algorithm 2 under the map")
    alg2 = kpt25_envmap(params, env, ctx.seed)
    ctx.progress("scene images under the lights")
    paths, scene_table = scene_images(params, ctx.seed)
    failures = [f"KPT25's Algorithm 2 under the sky, {r.pixel}: z = {r.z:.2f} against the quadrature"
                for r in alg2[alg2.estimator == "kpt25_alg2"].itertuples() if abs(r.z) > params["alg2_max_z"]]
    exact = counts[(counts.method == "exact") & (counts.law == "binomial")]
    for _, r in exact[exact.chi2_pvalue <= PASS].iterrows():
        failures.append(f"facets under a cap of {r.half_angle:g} rad are not Binomial(M, p_exact): p = {r.chi2_pvalue:.2g}")
    if abs(limit.ratio.iloc[-1] - 1) > 1e-6:
        failures.append(f"point-light limit: p_exact / p_point = {limit.ratio.iloc[-1]:.9g} at the smallest cap")
    for r in own[~own["pass"]].itertuples():
        failures.append(f"{r.method}'s own truth under the {r.light}: z = {r.z:.2f}, the normal variant's "
                        f"{r.z_normal_variant:.2f}, without the solid angle {r.z_no_solid_angle:.2f}")
    e = envtab.set_index(["source", "method", "scheme"]).chi2_pvalue
    if e[("facets", "exact", "")] <= PASS or e[("binomial", "exact", "chain")] <= PASS:
        failures.append("environment map: the facets or the binomial chain are not the exact multinomial")
    shipped = scene_table[scene_table.method == "area_light (glsl)"]
    for _, r in shipped.iterrows():
        if not (1 / SHADER_FACTOR <= r.expected_ratio <= SHADER_FACTOR):
            failures.append(f"the area-light method shader on {r.scene} under the {r.light}: lit facets / expected = "
                            f"{r.expected_ratio:.3g}")
    quad = scene_table[scene_table.method == "smooth D(h)"]
    for _, r in quad[(quad.expected_ratio - 1).abs() > QUADRATURE_TOL].iterrows():
        failures.append(f"the smooth NDF by quadrature over the {r.light}: {r.expected_ratio:.6g} x the exact p")
    ms = probs.exact_ms
    stats = {"exact p: CPU ms per (view, light), median / max": f"{ms.median():.3g} / {ms.max():.3g}",
             "exact p: largest error estimate / p (p > 1e-20)":
                 float((probs.exact_error / probs.p_exact)[probs.p_exact > 1e-20].max()),
             f"point p within {params['tolerance']:.0%} of exact (half-angle {min(params['half_angles']):g})":
                 float(accuracy[(accuracy.method == "point") & (accuracy.half_angle == min(params["half_angles"]))]
                       .share_within.mean()),
             "environment map: partition's relative radiance error": partition["rel_partition_error"],
             "scene images: exact p grid's largest relative error (p > 1e-3 max p), over the lights":
                 max(p.grid_error["max_rel_error_p_above_1e-3_max"] for p in paths if p.grid_error is not None),
             "scene images: the smooth NDF by quadrature over the light / the exact p, largest |ratio - 1|":
                 float((quad.expected_ratio - 1).abs().max()) if len(quad) else float("nan"),
             "scene images: CPU s of the registered methods by quadrature":
                 sum(v for p in paths for k, v in p.seconds.items() if k in _method_labels(params)),
             "scene images: the sphere's exact p per pixel (cubature), seconds over its lights":
                 sum(p.seconds.get("binomial (exact p)", 0.0) for p in paths if p.grid_error is None)}
    return Tables({"lighting_accuracy": accuracy, "lighting_counts": counts, "lighting_point_limit": limit,
                   "lighting_envmap": envtab, "lighting_own_truths": own, "lighting_images": image_table,
                   "lighting_scene_images": scene_table, "lighting_kpt25_envmap": alg2},
                  stats, failures, extra={"lighting_probabilities": probs},
                  data={"env": env, "partition": partition, "images": images, "scene_paths": paths})


def figures(tables: Tables, ctx: Context) -> list:
    return [ctx.save(accuracy_figure(tables["lighting_probabilities"]), "lighting_accuracy.png"),
            ctx.save(envmap_figure(tables["env"]), "lighting_envmap.png"),
            ctx.save(images_figure(tables["images"]), "lighting_images.png"),
            ctx.save(scene_figure(tables["scene_paths"]), "lighting_scene_images.png")]


def kpt25_envmap(params: dict, env, seed: int):
    """KPT25's Algorithm 2 as the importance sampler of the lighting integral under the map ``env`` (its own
    radiance, bilinear between the cells' centres: ``EnvMap.lookup``; a continuous radiance lets the reference
    quadrature converge as for a smooth integral) beside sampling the smooth NDF and the visible normals: per pixel
    and estimator the bias table of studies.sampling_lighting and each estimator's RMSE over Algorithm 2's at
    the largest sample count."""
    rmse, bias = sampling_lighting.study(params["alg2_pixels"], int(params["alg2_repeats"]), int(params["alg2_samples"]),
                                         float(params["alg2_wo_theta_deg"]), seed,
                                         light=lambda w: env.lookup(w, filter="bilinear"))
    last = rmse[rmse.samples == rmse.samples.max()].set_index(["pixel", "estimator"]).ratio_to_alg2
    bias["rmse_ratio_to_alg2"] = [last[(r.pixel, r.estimator)] for r in bias.itertuples()]
    return bias


def scene_images(params: dict, seed: int):
    """The plane under a cap, a window (rectangle) and the shipped sky, and the sphere under the same cap and
    window (and the sky in world space when ``sphere_envmap_scale`` is set), each pixel lit in its own tangent
    frame: ([LightPath], their table). The shipped area-light method shader and its wrong variant are rendered
    under the cap and the window when a Vulkan device is present, and the registered image methods
    ``scene_methods`` by quadrature over the lights of ``scene_method_lights`` (validation.lighting_methods; on
    the sphere, each pixel sees the light's samples in its own frame), ``scene_map_methods`` under the plane's map."""
    scene = with_density(resolve_scene(params["scene"]).scaled(params["scene_scale"], keep_n=True),
                         params["scene_density_factor"])
    sphere = with_density(resolve_scene(params["sphere_scene"]).scaled(params["sphere_scale"], keep_n=True),
                          params["scene_density_factor"])
    mat, _ = LI.plane_material(scene)
    try:
        shaders = {"area_light (glsl)": LI.area_light_shader(mat),
                   "area_light without solid angle (wrong)": LI.area_light_shader(mat, wrong=True)}
        sphere_mat, _ = LI.plane_material(sphere)
        sphere_shaders = {"area_light (glsl)": LI.area_light_shader(sphere_mat),
                          "area_light without solid angle (wrong)": LI.area_light_shader(sphere_mat, wrong=True)}
    except NoVulkanDevice:
        shaders, sphere_shaders = {}, {}
    kw = dict(frames=params["scene_frames"], seed=seed)
    grid = dict(grid_nodes=params["scene_grid_nodes"])
    for name in params["scene_method_lights"]:
        V.choice("scene_method_lights", name, ("cap", "rect"))
    paths = [LM.method_light_path(scene, light, shaders=shaders, samples=params["scene_method_samples"],
                                  methods=params["scene_methods"] if light.kind in params["scene_method_lights"] else [],
                                  **grid, **kw) for light in scene_lights(scene, params)]
    paths.append(LM.method_light_path(scene, gl_lights.envmap("sky", regions=3), methods=params["scene_map_methods"],
                                      block=params["scene_map_block"], **grid, **kw))
    paths += [LM.method_light_path(sphere, light, shaders=sphere_shaders, rel_tol=params["sphere_rel_tol"],
                                   samples=params["scene_method_samples"],
                                   methods=params["scene_methods"] if light.kind in params["scene_method_lights"] else [],
                                   **kw) for light in scene_lights(sphere, params)]
    if params["sphere_envmap_scale"]:
        small = with_density(resolve_scene(params["sphere_scene"]).scaled(params["sphere_envmap_scale"], keep_n=True),
                             params["scene_density_factor"])
        paths.append(LI.light_path(small, gl_lights.envmap("sky", regions=3), rel_tol=params["sphere_rel_tol"], **kw))
    return paths, pd.concat([LI.light_table(p) for p in paths], ignore_index=True)


def _method_labels(params) -> set:
    return {IMAGE_METHODS.get(n).label for n in params["scene_methods"] + params["scene_map_methods"]}


def scene_lights(scene, params: dict):
    """The section's cap and window for ``scene``, centred where its light is."""
    return [LI.scene_light(scene, "cap", (params["scene_cap_half_angle"], 0.0)),
            LI.scene_light(scene, "rect", tuple(params["scene_rect_half_widths"]))]


def scene_figure(paths):
    """Frame 0 of each scene under each light: the facet truth beside each method (radiance per facet)."""
    import matplotlib.pyplot as plt

    cols = max(len(p.images) for p in paths)
    fig, axes = plt.subplots(len(paths), cols, figsize=(2.4 * cols, 1.6 * len(paths)), squeeze=False)
    for row, path in zip(axes, paths):
        vmax = max(float(np.percentile(path.images["facets"][0][path.mask[0]], 99.9)), 1e-12)
        for ax in row:
            ax.axis("off")
        for ax, (name, seq) in zip(row, path.images.items()):
            ax.imshow(seq[0], cmap="inferno", vmin=0, vmax=vmax, interpolation="nearest")
            ax.set_title(f"{path.scene}, {path.light}: {name}", fontsize=6)
    fig.suptitle("scenes under extended lights: each method beside the facets lit the same way (frame 0)", fontsize=8)
    fig.tight_layout()
    return fig


def window_light():
    """A window-sized panel (0.6 x 0.8 at distance 2) ahead of the camera of ``plane_pixels``, centred on
    the mirror direction of the image's centre."""
    wo = np.array([-0.62, 0.0, 0.78])
    wo /= np.linalg.norm(wo)
    mirror = wo * np.array([-1.0, -1.0, 1.0])
    return gl_lights.rect(2 * mirror, (0.6 * mirror[2], 0.0, -0.6 * mirror[0]), (0.0, 0.8, 0.0))


def images_figure(images):
    """Counts per pixel of the plane under the window: the facets beside the laws at the exact and point p."""
    import matplotlib.pyplot as plt

    names = list(images)
    fig, axes = plt.subplots(1, len(names), figsize=(2.6 * len(names), 2.2))
    vmax = max(float(np.percentile(v, 99.5)) for v in images.values())
    for ax, name in zip(axes, names):
        ax.imshow(images[name], cmap="inferno", vmin=0, vmax=vmax, interpolation="nearest")
        ax.set_title(name, fontsize=7)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle("a plane under a window light: reflecting facets per pixel", fontsize=8)
    fig.tight_layout()
    return fig


def accuracy_figure(probs):
    """|relative error| of each approximation against the exact p, by light size, one panel per target."""
    import matplotlib.pyplot as plt

    targets = sorted(probs.target.unique())
    fig, axes = plt.subplots(1, len(targets), figsize=(4.2 * len(targets), 3.6), squeeze=False)
    for ax, target in zip(axes[0], targets):
        t = probs[(probs.target == target) & (probs.p_exact > 1e-6)]
        for i, (m, colour) in enumerate((("ltc", "#1b9e77"), ("cap", "#d95f02"), ("point", "#7570b3"))):
            x = t.half_angle * (1 + 0.08 * (i - 1))
            ax.scatter(x, np.abs(t[f"rel_err_{m}"]).clip(1e-9), s=10, color=colour, alpha=0.6, label=m)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.axhline(0.05, color="grey", ls=":", lw=0.8)
        ax.set_xlabel("light half-angle (rad)")
        ax.set_ylabel("|p / p_exact - 1|")
        ax.set_title(f"{target}: approximations against the exact p", fontsize=8)
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def envmap_figure(env):
    """The shipped sky, its partition, and the per-region p of a view (exact, filtered)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(11, 3.0))
    axes[0].imshow(np.log10(env.image), cmap="magma", aspect="auto")
    axes[0].set_title("sky (log10 radiance)", fontsize=8)
    axes[1].imshow(env.labels, cmap="tab10", aspect="auto", vmin=-1, vmax=9)
    axes[1].set_title(f"{env.regions} regions (-1: below the horizon)", fontsize=8)
    wo = np.array([np.sin(0.5), 0.0, np.cos(0.5)])
    for i, m in enumerate(("exact", "filtered")):
        p = reflection_probability("ggx", 0.3, wo, env, m)
        axes[2].bar(np.arange(env.regions) + 0.4 * i, p, width=0.4, label=m)
    axes[2].set_yscale("log")
    axes[2].set_xlabel("region")
    axes[2].set_title("p per region, GGX 0.3, view at 29 degrees", fontsize=8)
    axes[2].legend(fontsize=7)
    fig.tight_layout()
    return fig
