"""The built-in stage kinds and metrics of pipelines (``glintlab check PIPELINE.json``). The registries and
the check are in validation/pipeline.py; this helper sits with the studies whose measurements it reuses;
the meaning and cost of each metric are in docs/guide/ci_pipeline.md.

Every metric is one glintlab already has, measured over the stage's operating range at the pipeline's
seed: a law's TV and mean error against the binomial (``sweep``) and a shader's rows against its C++
twin (``shader_check.row_table``); a blend's TV against spatialized Bernoulli trials across the LOD
transition (``lod.figure4_cases``, ``ground_truth``) and its pops along zoom paths
(``lod.coherence_metrics``); a grid scheme's count bias and variance ratio against stratified facets in
the ellipse (``aniso.study``); a glinty NDF's or method's mean of D against the target (KPT25's pixel
lattice, ``glinty_ndf._footprints``), its furnace energy (``furnace``), its flicker on a scene against its own
truth (``scene_images.own_truth_metrics``) and a method shader's pixels against its C++ twin
(``method_twins.compare``); a sampler's chi-square p-value, normalization and pdf consistency
(``sampler_test``); and a shader's GPU cost (``gpu_cost``, RADV null devices).

Stage objects: a law stage's is a Law; a blend stage's a function ``base_area -> BlendedLaw`` (the
blend on levels whose lower one has that area); a grid stage's the configuration label; a method
stage's a glinty NDF or method shader; a sampler stage's a sampler. A method's light response
(``gl.light_response``: its image against its truth's as the light and the view move, and its lobe) is one
more metric of the registry.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..api.blends import blended_law
from ..api.glinty_ndf import Material, image_methods, make_method
from ..api.gpu_cost import DEFAULT_ARCHS, gpu_cost
from ..api.grids import IMAGE_CONFIGS
from ..api.metrics import distance
from ..api.ndf import NDF
from ..api.method_shaders import shader_method, shipped_method_shaders
from ..api.samplers import load_sampler
from ..api.shader_samplers import shader_sampler
from ..api.shaders import shader_law
from ..api.spatial import Rect, ground_truth
from .._core import Distribution
from ..resources import data_path
from ..validation.bounds import regime_points
from ..validation.furnace import furnace
from ..validation.light_response import light_response
from ..validation.method_twins import compare, scene_rows
from ..validation.pipeline import PIPELINE_STAGES, Measured, Stage, register_pipeline_metric
from ..validation.references import resolve_law
from ..validation.sampler_test import sampler_test
from ..validation.scene_images import own_truth_metrics, render_path, resolve_scene
from ..validation.shader_check import row_table
from ..validation.sweep import sweep
from . import aniso, lod
from .glinty_ndf import _footprints, _half_vector

# The sampler test's significance: the p-value bound --record writes (its false-failure rate per bound).
SAMPLER_LEVEL = 1e-3


# ---------------------------------------------------------------- stage objects (one builder per kind)

def _shader_options(stage: Stage, spec: dict, field: str) -> dict:
    """The keywords of a shader loader from a pipeline's shader object: includes (relative to the
    pipeline file) and defines always; uniforms and textures only when the file gives them."""
    includes = [str(stage.path(d)) for d in spec.get("includes", [])]
    for i, d in enumerate(includes):
        if not Path(d).is_dir():
            stage.fail(f"{field}/includes/{i}", "an existing folder", spec["includes"][i])
    opts = dict(include_dirs=includes, defines=dict(spec.get("defines", {})))
    for key in ("language", "name", "device"):
        if key in spec:
            opts[key] = spec[key]
    for key in ("uniforms", "textures"):  # the loaders' keywords for shader resources, when given
        if key in spec:
            opts[key] = spec[key]
    return opts


def _shader_file(stage: Stage, spec: dict, field: str) -> Path:
    path = stage.path(spec["shader"])
    if not path.is_file():
        stage.fail(f"{field}/shader", "an existing shader file (relative to the pipeline file)", spec["shader"])
    return path


def _load(stage: Stage, field: str, loader, path: Path, **opts):
    """``loader(path, **opts)``; a loader of this glintlab that does not take a shader option the file gives
    (uniforms, textures) is the file's error at that option."""
    try:
        return loader(path, **opts)
    except TypeError as exc:
        given = [key for key in ("uniforms", "textures") if key in opts]
        if not given:
            raise
        stage.fail(f"{field}/{given[0]}", f"shader options this glintlab's shader loader takes ({exc})", opts[given[0]])


def build_law(stage: Stage, field: str = "law"):
    spec = stage.spec[field]
    if isinstance(spec, dict) and "shader" in spec:
        opts = _shader_options(stage, spec, field)
        for key in ("entry", "n_uniforms", "binning"):
            if key in spec:
                opts[key] = spec[key]
        # As the sampler and method loaders do, glintlab's shader folder is searched last (its preludes).
        opts["include_dirs"] = [*opts["include_dirs"], str(data_path("shaders"))]
        return _load(stage, field, shader_law, _shader_file(stage, spec, field), register=False, **opts)
    try:
        return resolve_law(spec)
    except ValueError as exc:
        stage.fail(field, f"a registered law ({exc})", spec)


def build_blend(stage: Stage):
    spec = stage.spec["blend"]
    name, params = (spec, {}) if isinstance(spec, str) else (spec["name"], dict(spec.get("params", {})))
    inner = build_law(stage, "inner")
    try:
        blended_law(name, inner=inner, **params)
    except ValueError as exc:
        stage.fail("blend", f"a blend ({exc})", spec)
    return lambda base_area: blended_law(name, inner=inner, base_area=base_area, **params)


def build_grid(stage: Stage):
    label = stage.spec["scheme"]
    if label not in IMAGE_CONFIGS:
        stage.fail("scheme", "a grid configuration (" + ", ".join(IMAGE_CONFIGS) + ")", label)
    return label


def build_method(stage: Stage, material: Material | None = None):
    """The stage's method on ``material`` (default: the stage's "material")."""
    spec, m = stage.spec["method"], stage.spec["material"]
    material = material or Material(density=m["density"], target=m["target"], alpha=m["alpha"], R=m["R"])
    if isinstance(spec, dict) and "shader" in spec:
        opts = _shader_options(stage, spec, "method")
        for key in ("entry", "returns"):
            if key in spec:
                opts[key] = spec[key]
        return _load(stage, "method", shader_method, _shader_file(stage, spec, "method"), register=False,
                     material=material, **opts)
    name, params = (spec, {}) if isinstance(spec, str) else (spec["name"], spec.get("params", {}))
    if params:
        stage.fail("method/params", "no parameters (an image method takes the stage's material)", params)
    try:
        return make_method(name, material)
    except ValueError as exc:
        stage.fail("method", f"an image method ({exc})", name)


def build_sampler(stage: Stage):
    spec = stage.spec["sampler"]
    wo = {"wo": tuple(stage.spec["wo"])} if "wo" in stage.spec else {}
    if isinstance(spec, dict) and "shader" in spec:
        return _load(stage, "sampler", shader_sampler, _shader_file(stage, spec, "sampler"),
                     **_shader_options(stage, spec, "sampler"), **wo)
    name, params = (spec, {}) if isinstance(spec, str) else (spec["name"], dict(spec.get("params", {})))
    try:
        return load_sampler(name, **params, **wo)
    except ValueError as exc:
        stage.fail("sampler", f"a registered sampler ({exc})", spec)


for _kind, _builder in (("law", build_law), ("blend", build_blend), ("grid", build_grid), ("method", build_method),
                        ("sampler", build_sampler)):
    PIPELINE_STAGES.register(_kind, _builder)


# ---------------------------------------------------------------- helpers

def _worst(values, where, errors=None, points=None, note: str = "") -> Measured:
    """The largest of ``values`` (NaN counts as the worst: it is never within a bound), where it is and
    its standard error."""
    vals = np.asarray(values, dtype=float)
    k = int(np.argmax(np.where(np.isnan(vals), np.inf, vals)))
    se = 0.0 if errors is None else float(np.asarray(errors, dtype=float)[k])
    return Measured(float(vals[k]), where[k], len(vals) if points is None else points, note, se)


def _np_where(df) -> list[str]:
    return [f"n = {n:g}, p = {p:g}" for n, p in zip(df.n, df.p)]


# ---------------------------------------------------------------- law

def _law_sweep(stage: Stage):
    def compute():
        law = stage.obj
        pts = regime_points(stage.spec.get("range", {}))
        if len(pts) == 0:
            stage.fail("range", "a range with at least one (n, p) point after its ranges", stage.spec.get("range"))
        samples = None if law.has_pmf else stage.spec["samples"]
        return sweep([law], points=pts, metrics=["tv", "mean_rel_err"], samples=samples, seed=stage.seed,
                     progress=False)
    return stage.shared("sweep", compute)


def law_tv(stage: Stage) -> Measured:
    df = _law_sweep(stage)
    return _worst(df.tv, _np_where(df), df.tv_noise if "tv_noise" in df else None)


def law_mean_rel_err(stage: Stage) -> Measured:
    df = _law_sweep(stage)
    return _worst(df.mean_rel_err.abs(), _np_where(df), df.mean_rel_err_se if "mean_rel_err_se" in df else None)


def law_twin_rows(stage: Stage) -> Measured:
    df = row_table(stage.obj, resolve_law(stage.spec["twin"]), rows=stage.spec["rows"], seed=stage.seed)
    # A row differing by more than one count is a port's bug whatever its share: it counts as every row.
    share = np.where(df.binned_max_dk > 1, 1.0, df.binned_differ)
    return _worst(share, _np_where(df), note="share of rows whose binned count differs from the C++ twin's")


# ---------------------------------------------------------------- blend

def _blend_cases(stage: Stage) -> list:
    r = stage.spec["range"]
    for i, (M, c_lo, p) in enumerate(r["cases"]):
        if M != int(M) or M < 2 or c_lo != int(c_lo) or not 1 <= c_lo * 4 <= M * M or not 0 <= p <= 1:
            stage.fail(f"range/cases/{i}", "[M, cells_lo, p]: integers M >= 2 and 4 cells_lo <= M^2, p in [0, 1]",
                       r["cases"][i])
    return lod.figure4_cases([(int(M), int(c), p) for M, c, p in r["cases"]], tuple(r["weights"]))


def blend_tv(stage: Stage) -> Measured:
    tvs, where = [], []
    for i, case in enumerate(_blend_cases(stage)):
        if case["rect"] is None:
            stage.fail("range/weights", f"weights whose footprints fit an M x M grid (M = {case['M']})",
                       stage.spec["range"]["weights"])
        M, N, p = case["M"], case["N"], case["p"]
        (w, hh), h = case["rect"], 1.0 / M
        truth = ground_truth("stratified", density=N, footprint=Rect(w * h, hh * h), p=p,
                             center=(0.25 + w * h / 2, 0.25 + hh * h / 2)).pmf()
        bl, P = stage.obj(case["cells_lo"] / N), case["cells"] / N
        if bl.has_pmf:
            d = bl.pmf(N, P, p)
        else:
            d = Distribution.empirical(bl.bin(bl.sample(N, P, p, size=stage.spec["samples"], seed=stage.seed + i)))
        tvs.append(distance(d, truth, "tv"))
        where.append(f"M = {M}, cells_lo = {case['cells_lo']}, p = {p:g}, w_area = {case['w_area']:g}")
    return _worst(tvs, where)


def blend_pop_rate(stage: Stage) -> Measured:
    r = stage.spec["range"]
    M, c_lo, p = r["cases"][0]
    N = float(M) * M
    a_lo = c_lo / N
    areas = a_lo * 4.0 ** (np.arange(r["steps"] + 1) / r["steps"])
    xy = np.random.default_rng(stage.seed).uniform(0.1, 0.9, size=(r["paths"], 2))
    K = stage.obj(a_lo).sample_at(N, areas[None, :], p, xy[:, :1], xy[:, 1:], seed=stage.seed)
    m = lod.coherence_metrics(K)
    share = m["pop_rate"]
    se = math.sqrt(max(share * (1 - share), 0.0) / K[:, 1:].size)
    return Measured(share, f"zoom over one level from {c_lo:g} cells, M = {M:g}, p = {p:g}", r["paths"],
                    f"{r['paths']} paths x {r['steps']} steps", se)


# ---------------------------------------------------------------- grid scheme

def _grid_study(stage: Stage):
    r = stage.spec["range"]
    grid = {key: tuple(r[key]) for key in ("n", "r", "phi_deg", "p")}
    return stage.shared("study", lambda: aniso.study(configs=[stage.obj], laws=(stage.spec["inner"],),
                                                     N=stage.spec["density"], grid=grid, samples=stage.spec["samples"],
                                                     seed=stage.seed, threads=2))


def _grid_where(df) -> list[str]:
    return [f"n = {a:g}, r = {b:g}, phi = {c:g} deg, p = {d:g}" for a, b, c, d in zip(df.n, df.r, df.phi_deg, df.p)]


def grid_count_bias(stage: Stage) -> Measured:
    df = _grid_study(stage)
    return _worst((df.mean_bias - 1).abs(), _grid_where(df), df.mean_bias_se)


def grid_var_ratio_err(stage: Stage) -> Measured:
    df = _grid_study(stage)
    # The standard error of a sample variance's ratio: sqrt(2 / (m - 1)) of it (normal counts).
    se = df.var_ratio * math.sqrt(2.0 / (stage.spec["samples"] - 1)) * (~df.exact)
    return _worst((df.var_ratio - 1).abs(), _grid_where(df), se)


# ---------------------------------------------------------------- glinty NDF or method

def method_mean_d_err(stage: Stage) -> Measured:
    nd, r, pixels = stage.obj, stage.spec["range"], stage.spec["pixels"]
    errs, ses, where = [], [], []
    for theta in r["theta_h_deg"]:
        h = _half_vector(theta, pixels)
        h = h / np.linalg.norm(h, axis=1, keepdims=True)
        D = float(nd.smooth(h[0]))
        for pts in r["points"]:
            for an in r["anisotropy"]:
                uv, J = _footprints(pixels, math.sqrt(pts / nd.density), an, stage.seed)
                v = nd.evaluate(uv, J, h, seed=stage.seed) / D
                errs.append(abs(float(v.mean()) - 1.0))
                ses.append(float(v.std(ddof=1)) / math.sqrt(pixels))
                where.append(f"theta_h = {theta:g} deg, points = {pts:g}, anisotropy = {an:g}")
    return _worst(errs, where, ses, note="|mean of D / target D - 1| over independent pixels")


def _has_furnace(stage: Stage) -> bool:
    """a glinty NDF with a facet density and a smooth target NDF"""
    return hasattr(stage.obj, "density") and isinstance(getattr(stage.obj, "smooth_ndf", None), NDF)


def method_furnace_err(stage: Stage) -> Measured:
    r = stage.spec["range"]
    df = furnace(stage.obj, theta_o_deg=r["theta_o_deg"], pixels=stage.spec["pixels"], directions=64,
                 points=r["points"], seed=stage.seed)
    df = df[df.quantity.isin(["projected_area", "weak_furnace"])]
    where = [f"{q}{'' if math.isnan(t) else f', theta_o = {t:g} deg'}, points = {p:g}"
             for q, t, p in zip(df.quantity, df.theta_o_deg, df.points)]
    return _worst((df.value - 1).abs(), where, df.error, note="|projected area or weak furnace - 1|")


def _scene(stage: Stage):
    sc = stage.spec["scene"]
    path = stage.path(sc["file"])
    scene = resolve_scene(str(path) if path.exists() else sc["file"])
    return scene.scaled(sc["scale"], keep_n=True)


def _method_name(stage: Stage) -> str:
    spec = stage.spec["method"]
    return spec if isinstance(spec, str) else spec.get("name", "")


def _scene_own_truth(stage: Stage) -> dict:
    def compute():
        name = _method_name(stage)
        path = render_path(_scene(stage), methods=[name], frames=stage.spec["scene"]["frames"], seed=stage.seed)
        return own_truth_metrics(name, path.images[name], path.truths[name], path.target, path.mask)
    return stage.shared("scene", compute)


def _has_scene(stage: Stage) -> bool:
    """an image method named by its registered name and a "scene\""""
    return "scene" in stage.spec and _method_name(stage) in image_methods()


def method_scene_std_ratio(stage: Stage) -> Measured:
    r = _scene_own_truth(stage)
    return Measured(abs(r["own_std_ratio"] - 1.0), f"scene {stage.spec['scene']['file']} against its own truth "
                    f"({r['own_truth']})", stage.spec["scene"]["frames"], f"std ratio {r['own_std_ratio']:.4g}")


def method_scene_pop_rate(stage: Stage) -> Measured:
    r = _scene_own_truth(stage)
    return Measured(float(r["own_pop_rate"]), f"scene {stage.spec['scene']['file']} against its own truth "
                    f"({r['own_truth']})", stage.spec["scene"]["frames"],
                    f"the own truth changes at {r['own_truth_change_rate']:.3g} of the pixels")


def _light_response_method(stage: Stage):
    """What gl.light_response takes: the image method's name, or for a shader a factory material -> the
    stage's shader built for that material (an NDF shader reads the material as defines). A factory, not
    the object: gl.light_response copies a user NDF shader's spec as JSON to recompile it, and an object
    compiled before (shader methods are cached per spec and material) carries its includes' bytes."""
    spec = stage.spec["method"]
    if not (isinstance(spec, dict) and "shader" in spec):
        return _method_name(stage)

    def shader_for(material):
        return build_method(stage, material)
    shader_for.__name__ = spec.get("name") or Path(spec["shader"]).stem
    return shader_for


def _has_scene_for_response(stage: Stage) -> bool:
    """a "scene\" (the light and view move on its first frame)"""
    return "scene" in stage.spec


def method_light_response(stage: Stage) -> Measured:
    sc = stage.spec["scene"]
    path = stage.path(sc["file"])
    res = light_response(_light_response_method(stage), str(path) if path.exists() else sc["file"], seed=stage.seed,
                         scale=sc["scale"] / 2)
    applied = res.checks[res.checks.applies]
    failed = applied[~applied.passed]
    where = "; ".join(failed.check) if len(failed) else f"{len(applied)} checks on scene {sc['file']}"
    share = len(failed) / len(applied) if len(applied) else 0.0
    return Measured(float(share), where, len(applied), "; ".join(res.notes[:3]))


def _has_method_twin(stage: Stage) -> bool:
    """a "twin" naming a shipped method shader and a "scene\""""
    return "scene" in stage.spec and stage.spec.get("twin") in shipped_method_shaders()


def method_twin_pixels(stage: Stage) -> Measured:
    sc = stage.spec["scene"]
    rows, material = scene_rows(_scene(stage), scale=1.0, seed=stage.seed)
    # The method as the scene's material makes it (an NDF shader reads the material as defines); the
    # shipped shader itself when the stage names its twin.
    same = _method_name(stage) == stage.spec["twin"]
    method = None if same else build_method(stage, material)
    r = compare(rows, material, method=method, explain_limit=0, name=stage.spec["twin"])
    return Measured(float(r["share"]), f"scene {sc['file']}, frame 0", int(r["pixels"]),
                    f"largest relative error {r['max_rel_err']:.3g}")


# ---------------------------------------------------------------- sampler

def _sampler_result(stage: Stage):
    return stage.shared("test", lambda: sampler_test(stage.obj, samples=stage.spec["samples"], seed=stage.seed,
                                                     significance=SAMPLER_LEVEL, write="never"))


def sampler_pvalue(stage: Stage) -> Measured:
    res = _sampler_result(stage)
    return Measured(float(res.pvalue), f"{res.bins} bins, {res.samples} samples", res.bins, res.note)


def sampler_normalization(stage: Stage) -> Measured:
    res = _sampler_result(stage)
    return Measured(abs(float(res.integral) - 1.0), "the pdf's integral over the domain", 1, res.note,
                    float(res.integral_error))


def sampler_pdf_mismatch(stage: Stage) -> Measured:
    res = _sampler_result(stage)
    share = res.mismatches / max(res.checked, 1)
    return Measured(float(share), f"{res.checked} samples checked (rtol {res.rtol:g})", res.checked,
                    f"worst relative difference {res.worst_rel_diff:.3g}")


# ---------------------------------------------------------------- GPU cost (shader stages)

def _cost(stage: Stage):
    archs = tuple(stage.spec.get("arch", DEFAULT_ARCHS))
    return stage.shared("cost", lambda: gpu_cost(stage.obj, arch=archs))


def _cost_metric(column: str):
    def measure(stage: Stage) -> Measured:
        df = _cost(stage)
        return _worst(df[column], [f"arch {a}" for a in df.arch])
    return measure


def _is_shader(stage: Stage) -> bool:
    """a shader stage (a compiled kernel)"""
    return hasattr(stage.obj, "spirv")


def _has_twin(stage: Stage) -> bool:
    """a shader law with a "twin" (the C++ law it ports)"""
    return "twin" in stage.spec and _is_shader(stage)


_EXACT = "0 when the stage has exact distributions (the value is a deterministic function of the stage)"
_SCENE = ("fixed seed: the value is reproducible; it carries no standard error, so only the relative margin covers "
          "a new seed or machine")
_SEEDED = ("fixed seed: the value is reproducible; --record's noise term (standard errors) bounds the rate a new "
           "seed or machine fails at, about 0.13 % per bound at 3 standard errors")
for _name, _kinds, _measure, _meaning, _ff, _cost_text, _applies in (
        ("tv", "law", law_tv, "largest TV distance to the exact binomial over the range", _EXACT + "; else " + _SEEDED,
         "one pmf (or `samples` draws) per (n, p) point", None),
        ("mean_rel_err", "law", law_mean_rel_err, "largest |relative mean error| against the binomial over the range",
         _EXACT + "; else " + _SEEDED, "shares the tv sweep", None),
        ("twin_rows", "law", law_twin_rows, "largest share of rows whose binned count differs from the C++ twin's "
         "(the same uniforms; a row off by more than one count counts as all)", "0: the rows are fixed by the seed",
         "`rows` shader evaluations at 8 points", _has_twin),
        ("blend_tv", "blend", blend_tv, "largest TV to spatialized Bernoulli trials (stratified cells) across the "
         "LOD transition", _EXACT + "; else " + _SEEDED, "one exact truth and one blend pmf per footprint", None),
        ("blend_pop_rate", "blend", blend_pop_rate, "share of zoom steps where the count jumps by 2 or more "
         "(temporal coherence)", _SEEDED, "`paths` x `steps` blend evaluations", None),
        ("grid_count_bias", "grid", grid_count_bias, "largest |mean count / n p - 1| against the ellipse's facets",
         _SEEDED, "`samples` draws per (n, r, phi, p) and one exact truth", None),
        ("grid_var_ratio_err", "grid", grid_var_ratio_err, "largest |Var[K] / Var_truth - 1| against the ellipse's "
         "facets", _SEEDED, "shares the grid_count_bias study", None),
        ("mean_d_err", "method", method_mean_d_err, "largest |mean D / target D - 1| over half vectors and footprints",
         _SEEDED, "`pixels` NDF evaluations per (theta_h, points, anisotropy)", None),
        ("furnace_err", "method", method_furnace_err, "largest |projected area - 1| or |weak furnace - 1| (energy)",
         _SEEDED, "`pixels` x 64 evaluations per case", _has_furnace),
        ("scene_std_ratio_err", "method", method_scene_std_ratio, "|std of the images / std of the method's own "
         "truth - 1| on the scene's glint pixels", _SCENE, "`frames` images and their own truths", _has_scene),
        ("scene_pop_rate", "method", method_scene_pop_rate, "share of glint pixels that pop between frames without "
         "their own truth changing", _SCENE, "shares the scene's images", _has_scene),
        ("light_response", "method", method_light_response, "share of gl.light_response's checks that fail: the "
         "image decorrelating with the light and view moves as its truth's does, the lobe's shape against D(h)",
         "the light response's own rates (docs/math/glint_images.md#glint-light-response) per check",
         "frame 0 of the scene at half its scale, moved 3 x 2 x 3 times, and the lobe sweep",
         _has_scene_for_response),
        ("twin_pixels", "method", method_twin_pixels, "share of a scene's pixels where the method shader and its "
         "C++ twin differ beyond the twin's allowance", "0: the rows are fixed by the seed",
         "one frame of the scene, shader and twin", _has_method_twin),
        ("sampler_normalization", "sampler", sampler_normalization, "|integral of the pdf - 1|", _SEEDED,
         "shares the sampler test", None),
        ("sampler_pdf_mismatch", "sampler", sampler_pdf_mismatch, "share of samples whose own pdf disagrees with "
         "pdf()", "0: the samples are fixed by the seed", "shares the sampler test", None),
        ("gpu_instructions", ("law", "method", "sampler"), _cost_metric("instructions"), "instructions of the "
         "compiled kernel (largest over `arch`)", "0: a compiler's output", "one compile per architecture", _is_shader),
        ("gpu_latency", ("law", "method", "sampler"), _cost_metric("latency"), "ACO's latency estimate in cycles "
         "(largest over `arch`)", "0: a compiler's output", "shares the gpu_instructions compile", _is_shader),
        ("gpu_vgprs", ("law", "method", "sampler"), _cost_metric("vgprs"), "vector registers (largest over `arch`)",
         "0: a compiler's output", "shares the gpu_instructions compile", _is_shader)):
    register_pipeline_metric(_name, _kinds, "max", _measure, _meaning, _ff, _cost_text, applies=_applies)
register_pipeline_metric("sampler_pvalue", "sampler", "min", sampler_pvalue,
                         "p-value of the chi-square test of the samples against the pdf (sampler_test)",
                         f"{SAMPLER_LEVEL:g} per bound (the test's significance)",
                         "`samples` draws and the pdf's cubature over adaptive bins", level=SAMPLER_LEVEL)
