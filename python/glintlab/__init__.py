"""glintlab: exact laws, samplers and metrics for the counting laws of glint rendering.

>>> import glintlab as gl
>>> law = gl.law("binomial")
>>> d = law.pmf(100, 0.1)                 # exact distribution
>>> x = law.sample(100, 0.1, size=10**6, seed=1)
>>> gl.chi2_test(x, d).pvalue                # samples against their own law: no rejection
0.171
"""
# The public names, re-exported from the layers (api <- validation <- studies <- report <- cli); no
# module of the package imports this file, so the order of these imports does not matter, except
# _openmp's: first, before anything loads the OpenMP runtime (_core).
from . import _openmp  # noqa: F401
from . import _core
from .api import checks as _checks
from ._core import Chi2Result, Distribution, __version__
from .api.blends import BlendedLaw, blend_summaries, blended_law, blends, roulette_keep_moments, zk16_variance_ratio
from .api.exact import binomial, poisson
from .api.glinty_ndf import GlintyNDF, glinty_ndf, glinty_ndfs
from .api.wwh18 import WWH18  # registers the "wwh18" glinty NDF (docs/math/wwh18.md)
from .api.glinty_ndf import image_methods
from .api.glinty_ndf import matched_density, db23_visible_glints
from .api.method_shaders import ShaderMethod, shader_method
from .api import fragment_shaders  # noqa: F401 -- registers the fragment mode of shader_method
# Registers the "db23_shader" and "kpt25_shader" image methods (docs/math/glint_images.md#glint-db23-shader).
from .api import counting_shaders  # noqa: F401
from .api import zk16_shaders  # noqa: F401  (ZK16, its gated variant and the no-glints baseline as method shaders)
from .api.gpu_cost import gpu_architectures, gpu_cost
from .api.grids import AnisoCounter, aniso_counter, footprint_shapes, grid_schemes
from .api.laws import (CustomLaw, Law, custom_law, law, law_label, law_summaries, law_traits, law_variants, laws,
                       parse_law_label, uniforms)
from .api.metrics import METRICS, chi2_test, chi2_test_two_sample, distance, sidak_alpha
from .api.ndf import NDF, ndf
from .api.plugins import load_plugin, loaded_plugins
from .api.shaders import ShaderLaw, shader_law, shipped_shader, vulkan_devices
from .api.shaders import ShaderDeviceBusy, ShaderOutputError
from .api.shaders import emit_shader, shipped_shaders
from .api.spatial import Ellipse, GroundTruth, Rect, footprint_for_area, ground_truth, joint_counts
from .report.html import write_extremes_report
from .validation.advisor import Advice, advise
from .validation.bounds import perturbed_law
from .validation.pipeline import check, check_pipeline, pipeline_metrics, register_pipeline_metric
from .studies import pipeline_metrics as _pipeline_metrics  # noqa: F401  (registers the built-in metrics)
from .studies.experiment_plots import run_experiment
from .validation.extremes import extremes_summary, extremes_table, invalid_inputs_table
from .validation.grid import standard_grid
from .validation.profile import SceneProfile, profile_scene
from .validation.scene import Scene, load_scene
from .validation.scene_images import render_image as render
from .validation.light_response import LightResponse, light_response
from .validation.sweep import error_table, sweep
from .api.samplers import Sampler, sampler, samplers, wrong_sampler
from .validation.sampler_test import SamplerTestResult, sampler_test
from .validation.furnace import furnace
from .api.shader_samplers import ShaderSampler, shader_sampler, shipped_sampler
from .api.shader_resources import SamplerState
from .api import lights  # gl.lights.cap / rect / disk / envmap (docs/math/lighting.md#lighting-lights)
from .api.lighting import facet_truth, multinomial_counts, reflection_probability
from .api.light_truths import expected_light_counts, kpt25_light_truth, wwh18_light_truth


def set_num_threads(threads: int) -> None:
    """Threads used by sampling and evaluation (default: all cores, or $GLINTLAB_NUM_THREADS)."""
    threads = _checks.integer("threads", threads, minimum=1)
    _core.set_num_threads(threads)


def get_num_threads() -> int:
    return _core.num_threads()


__all__ = [
    "__version__",
    "AnisoCounter", "aniso_counter", "NDF", "ndf", "GlintyNDF", "glinty_ndf", "glinty_ndfs", "Scene", "load_scene", "Advice",
    "SceneProfile", "advise",
    "profile_scene", "footprint_shapes", "grid_schemes",
    "sweep", "check", "check_pipeline", "pipeline_metrics", "register_pipeline_metric", "perturbed_law", "run_experiment",
    "BlendedLaw", "Chi2Result", "CustomLaw", "blend_summaries", "blended_law", "blends", "roulette_keep_moments",
    "zk16_variance_ratio", "Distribution", "Ellipse", "GroundTruth", "Law", "METRICS", "Rect", "binomial",
    "chi2_test", "chi2_test_two_sample", "footprint_for_area", "ground_truth", "joint_counts",
    "custom_law", "law_label", "law_traits", "law_variants", "parse_law_label", "distance", "error_table", "extremes_summary",
    "extremes_table", "invalid_inputs_table",
    "write_extremes_report", "get_num_threads", "law", "law_summaries", "laws", "poisson",
    "set_num_threads", "sidak_alpha", "standard_grid", "uniforms", "load_plugin", "loaded_plugins",
    "ShaderLaw", "shader_law", "shipped_shader", "vulkan_devices",
    "image_methods", "ShaderMethod", "shader_method", "render",
    "ShaderDeviceBusy", "ShaderOutputError",
    "Sampler", "sampler", "samplers", "wrong_sampler", "SamplerTestResult", "sampler_test",
    "furnace",
]
__all__ += ["emit_shader", "shipped_shaders"]  # shipped shaders: declared in law traits, emitted paste-ready
__all__ += ["ShaderSampler", "shader_sampler", "shipped_sampler"]  # samplers as shaders (docs/math/sampling.md#shader-samplers)
__all__ += ["SamplerState"]  # how a shader's texture is read (docs/guide/shaders.md#textures-buffers-and-uniforms)
__all__ += ["gpu_architectures", "gpu_cost"]  # shaders compiled for AMD GPUs without one (docs/guide/gpu_cost.md)
__all__ += ["WWH18"]  # the "wwh18" glinty NDF's class (docs/math/wwh18.md)
__all__ += ["matched_density", "db23_visible_glints"]  # KPT25 <-> DB23 (docs/math/glinty_ndf.md#glinty-matched)
__all__ += ["lights", "reflection_probability", "facet_truth", "multinomial_counts"]  # docs/math/lighting.md
__all__ += ["kpt25_light_truth", "wwh18_light_truth", "expected_light_counts"]  # docs/math/lighting.md
__all__ += ["LightResponse", "light_response"]  # docs/math/glint_images.md#glint-light-response
