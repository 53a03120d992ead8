"""DB23's counting pipeline and KPT25's Algorithm 1 as whole method shaders, with glintlab's C++ DB23
and KPT25 as their twins (docs/math/glint_images.md#glint-db23-shader,
docs/math/glint_images.md#glint-kpt25-shader).

``db23_method_body.h`` (HLSL and GLSL wrappers) computes, per pixel from GlintInput's uv, J, shading
frame and h, DB23's glinty NDF value D_P = (D(n) / R) K / (N P) with K counted on the trilinear
anisotropic grids by the gated Gaussian as DB23's public shader runs it (``gated_body.h``, the law
shaders' body); ``kpt25_method_body.h`` computes KPT25's D^f over its point process. Both return D, so
they are NDF image methods (``returns="ndf"``: ``db23_shader``, ``kpt25_shader``, not in the default
panel) that the scene images shade with the microfacet BRDF.

The twins read the same float32 GlintInput rows (:func:`db23_twin`, :func:`kpt25_twin`): DB23 on the
trilinear grids with the inner law ``gated_shader`` (the C++ emulation of ``gated_body.h``), KPT25 with
the image method's parameters. The shaders read the core's own random numbers (``glintlab_rng.h``:
splitmix64 keys per grid cell, Philox4x32-10 blocks per point, 64-bit words on 32-bit integers), so
shader and twin agree pixel by pixel except where float32 moves a value across a floor or an edge
(:func:`twin_mismatch`, :func:`kpt25_mismatch`; ``glintlab.validation.method_twins`` says why).

>>> from glintlab.api.glinty_ndf import Material
>>> sorted(db23_defines(Material(4194304.0, "beckmann", 1.0, 0.5)).items())[:3]
[('DB23_ALPHA', 1.0), ('DB23_ANGULAR_RES', 20.0), ('DB23_DENSITY', 4194304.0)]
"""
from __future__ import annotations

import dataclasses
import functools
import json
import math
from pathlib import Path

import numpy as np

from ..resources import data_path
from . import checks as V
from .glinty_ndf import (DB23, DENSITY_MAPPINGS, KPT25, GlintyNDF, Material, matched_density, pixel_arrays,
                         register_image_method)
from .method_shaders import (ShaderMethod, check_output, frame_rows, pack_inputs, register_ndf_shader_factory, shader_seed,
                             unpack_inputs)
from .shaders import DEFAULT_TIMEOUT_S, ShaderBacked, kernel_spec

#: Each method shader is one body (<name>_method_body.h) with a thin .glsl and .hlsl wrapper.
METHOD_LANGUAGES = ("glsl", "hlsl")
#: The whole-method shader files this module ships (not law shaders: no law declares them).
METHOD_SHADER_FILES = tuple(f"{n}_method.{lang}" for n in ("db23", "kpt25", "zk16", "smooth") for lang in METHOD_LANGUAGES)
#: KPT25's parameters as the image method "kpt25" runs them (its micro-roughness and roulette width).
KPT25_ALPHA_STAR, KPT25_EPSILON = 0.02, 0.1
#: A pixel "mismatches" when shader and twin differ by more than this share of the pixel's one-facet
#: value D(n) / (R N P) (a count difference of 1e-3 facets: far above float32's relative 1e-6 on a soft
#: gate's ramp, far below any count flip, whose size is the gate's value times 1).
COUNT_ALLOWANCE = 1e-3


def _language(language):
    V.choice("language", language, METHOD_LANGUAGES, "'glsl' or 'hlsl'")
    return language


def db23_shader(language: str = "glsl") -> Path:
    """The path of the shipped DB23 method shader (GLSL or HLSL wrapper of ``db23_method_body.h``)."""
    return Path(data_path("shaders", f"db23_method.{_language(language)}"))


def db23_defines(material: Material, lod_bias: int = 0, key_salt: int = 0) -> dict:
    """The shader's -D values for a scene material (density N, alpha, R, target, angular resolution);
    ``lod_bias`` and ``key_salt`` make the deliberately wrong variants the tests use."""
    defines = {"DB23_DENSITY": float(material.density), "DB23_ALPHA": float(material.alpha),
               "DB23_R": float(material.R), "DB23_GGX": int(material.target == "ggx"),
               "DB23_ANGULAR_RES": 1.0 / float(material.angular_texel)}
    if lod_bias:
        defines["DB23_LOD_BIAS"] = int(V.integer("lod_bias", lod_bias, -8, 8))
    if key_salt:
        defines["DB23_KEY_SALT"] = f"{int(V.integer('key_salt', key_salt, 0, 0xFFFFFFFF))}u"
    return defines


def _spec(path: Path, name: str, defines: dict) -> dict:
    """A method shader's spec (as ``shader_method`` builds it) for a shipped file, not compiled."""
    spec = kernel_spec(path, None, "glint", defines, (), "auto", DEFAULT_TIMEOUT_S, defaults=(data_path("shaders"),),
                       none_defines=False)
    return dict(spec, name=name)


def _glsl_float(x: float) -> str:
    r = repr(float(x))
    return r if ("." in r or "e" in r) else r + ".0"


class NdfShaderMethod(ShaderMethod):
    """A method shader that returns the glinty NDF value D per pixel (``returns = "ndf"``): its image is
    D on the lit pixels (as every NDF method's), shaded by the scene images' BRDF; ``smooth(h)`` is its
    target; ``evaluate(uv, J, h, seed)`` runs it on tangent-frame inputs (normal +z, tangent +x). Compiled
    on first use: registering or making the method (a scene's material) needs no Vulkan."""

    returns = "ndf"

    def __init__(self, spec: dict, target: str, alpha: float, density: float, reference=None):
        # reference: None or a picklable callable () -> an evaluator with ``reference(uv, J, h, seed)``.
        GlintyNDF.__init__(self, target, alpha, density)
        ShaderBacked.__init__(self, spec)
        self._describe()
        self._ndf_args = (target, alpha, density, reference)
        self._reference = reference
        self._reference_ndf = None

    def _reduce_args(self) -> tuple:
        return (self._spec, *self._ndf_args)

    def reference(self, uv, J, h, seed: int = 0):
        """The exact model on the same realization, where the method has one (KPT25: its twin's sum over
        every point); NotImplementedError otherwise."""
        if self._reference is None:
            raise NotImplementedError(f"method shader {self.name!r} has no point-process reference")
        if self._reference_ndf is None:
            self._reference_ndf = self._reference()
        return self._reference_ndf.reference(uv, J, h, seed=seed)

    def smooth(self, h):
        return GlintyNDF.smooth(self, h)

    def image(self, inputs, seed: int = 0, frame: int = 0) -> np.ndarray:
        """D on the pixels of ``inputs.mask`` (those that see the lit surface), 0 elsewhere."""
        rows, mask = frame_rows(dataclasses.replace(inputs, hit=inputs.mask), seed, frame,
                                f"method shader {self.name!r}")
        values = self.shade(rows)
        check_output(self.name, values, f"frame {frame}", "NDF")
        img = np.zeros(mask.shape)
        img[mask] = values
        return img

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D per pixel from tangent-frame inputs (uv (..., 2), J (..., 4), h (..., 3)), checked as every
        glinty NDF's (NaN, infinities, zero h and singular J refused by element); ``seed`` < 2^32 (GlintInput's
        seed is one 32-bit word: :func:`~glintlab.api.method_shaders.shader_seed`). A NaN, infinite or
        negative D raises ``ShaderOutputError``."""
        uv, J, h, shape = pixel_arrays(uv, J, h, unit_h=True)
        seed = shader_seed(seed, f"method shader {self.name!r}")
        m = int(np.prod(shape)) if shape else 1
        rows = pack_inputs(m, uv=uv.reshape(m, 2), J=J.reshape(m, 4), h=h.reshape(m, 3), n=[0.0, 0.0, 1.0],
                           t=[1.0, 0.0, 0.0], b=[0.0, 1.0, 0.0], seed=np.uint32(seed))
        values = self.shade(rows)
        check_output(self.name, values, "the evaluated pixels", "NDF")
        return values.astype(np.float64).reshape(shape)


# The sphere scene's material (data/scenes/sphere.json), what a user's NDF shader is built for by default.
DEFAULT_MATERIAL = Material(4194304.0, "beckmann", 1.0, 0.5)


def user_ndf_method(spec: dict, material: Material | None = None) -> NdfShaderMethod:
    """A user's method shader that returns D (``shader_method(..., returns="ndf")``) for a scene material,
    which its code reads as the defines GLINTLAB_DENSITY, GLINTLAB_ALPHA, GLINTLAB_GGX and GLINTLAB_R
    (beside the user's own defines); compiled on first use."""
    material = DEFAULT_MATERIAL if material is None else material
    if not isinstance(material, Material):
        V.fail("material", material, "a glintlab Material (density, target, alpha, R, angular texel)")
    ours = {"GLINTLAB_DENSITY": _glsl_float(float(material.density)), "GLINTLAB_ALPHA": _glsl_float(float(material.alpha)),
            "GLINTLAB_GGX": str(int(material.target == "ggx")), "GLINTLAB_R": _glsl_float(float(material.R))}
    clash = sorted(set(ours) & {k for k, _ in spec["defines"]})
    if clash:
        V.fail("defines", clash[0], "a name glintlab does not set for an NDF shader (it sets the material's)")
    spec = dict(spec, defines=sorted([*map(tuple, spec["defines"]), *ours.items()]))
    return _user_ndf(json.dumps(spec, sort_keys=True), material)


@functools.lru_cache(maxsize=16)
def _user_ndf(spec_json: str, material: Material) -> NdfShaderMethod:
    # One compiled method per (shader, material): the scene images ask for a scene's method once per frame.
    spec = json.loads(spec_json)
    spec["defines"] = [tuple(d) for d in spec["defines"]]
    return NdfShaderMethod(spec, material.target, material.alpha, material.density)


register_ndf_shader_factory(user_ndf_method)


@functools.lru_cache(maxsize=16)
def _db23(key: tuple) -> NdfShaderMethod:
    material, lod_bias, key_salt, language = key
    spec = _spec(db23_shader(language), "db23_shader", db23_defines(material, lod_bias, key_salt))
    return NdfShaderMethod(spec, material.target, material.alpha, material.density)


def db23_method(material: Material, lod_bias: int = 0, key_salt: int = 0, language: str = "glsl") -> NdfShaderMethod:
    """DB23's counting pipeline as a method shader for ``material`` (GLSL or HLSL: one body), compiled on
    first use, once per parameter set."""
    if not isinstance(material, Material):
        V.fail("material", material, "a glintlab Material (density, target, alpha, R, angular texel)")
    return _db23((material, int(lod_bias), int(key_salt), _language(language)))


def db23_twin_ndf(material: Material) -> DB23:
    """The C++ twin: DB23's glinty NDF on the trilinear grids with the gated law as the public shader
    runs it (``inner="gated_shader"``), at the material's density, R and angular resolution."""
    return DB23(density=material.density, target=material.target, alpha=material.alpha, scheme="db23_trilinear",
                inner="gated_shader", R=material.R, angular_resolution=1.0 / material.angular_texel)


def tangent_inputs(rows):
    """(uv, J, h, seed) in float64 from packed float32 rows: h in the rows' own frame (t, b, n), the
    float32 values the shader reads, widened exactly."""
    g = unpack_inputs(np.ascontiguousarray(rows, dtype=np.uint32))
    f = {k: np.asarray(v, np.float64) for k, v in g.items()}
    h = np.stack([(f["h"] * f["t"]).sum(1), (f["h"] * f["b"]).sum(1), (f["h"] * f["n"]).sum(1)], axis=1)
    return f["uv"], f["J"], h, int(g["seed"][0, 0]) if len(g["seed"]) else 0


def db23_twin(rows, material: Material) -> np.ndarray:
    """The C++ twin's D per packed row (:func:`pack_inputs`, the same float32 values the shader reads);
    0 where h is below the horizon or the footprint is degenerate or clamped, as the shader."""
    uv, J, h, seed = tangent_inputs(rows)
    out = np.zeros(uv.shape[0])
    ok = (h[:, 2] > 0) & (np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2]) > 0)
    if ok.any():
        out[ok] = db23_twin_ndf(material).evaluate(uv[ok], J[ok], h[ok], seed=seed)
    return out


def twin_mismatch(shader, twin, rows, material: Material) -> dict:
    """Shader against twin per pixel: ``share`` of pixels whose difference exceeds COUNT_ALLOWANCE of the
    pixel's one-facet value D(n) / (R N P), ``share_1pct`` of those off by more than 1 %, ``rel_err`` the
    mean of |shader - twin| / max(twin, one facet) and its maximum ``max_rel_err``; ``pixels`` compared."""
    shader = np.asarray(shader, np.float64)
    twin = np.asarray(twin, np.float64)
    _, J, _, _ = tangent_inputs(rows)
    P = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        one = 1.0 / (math.pi * material.alpha**2) / (material.R * material.density * P)
        scale = np.maximum(np.abs(twin), one)
        err = np.abs(shader - twin) / scale
    err = np.where(np.isfinite(err), err, np.where(shader == twin, 0.0, np.inf))
    bad = err > COUNT_ALLOWANCE
    return {"pixels": int(err.size), "share": float(bad.mean()) if err.size else 0.0,
            "share_1pct": float((err > 0.01).mean()) if err.size else 0.0,
            "rel_err": float(np.mean(np.minimum(err, 1e3))) if err.size else 0.0,
            "max_rel_err": float(err.max()) if err.size else 0.0}


# --------------------------------------------------------------------------------------------------
# KPT25's Algorithm 1

def kpt25_shader(language: str = "glsl") -> Path:
    """The path of the shipped KPT25 method shader (GLSL or HLSL wrapper of ``kpt25_method_body.h``)."""
    return Path(data_path("shaders", f"kpt25_method.{_language(language)}"))


def kpt25_twin_ndf(material: Material) -> KPT25:
    """The C++ twin: glintlab's KPT25 at K_P = ``material.density`` (points per unit uv area; the image
    method maps the facet density to it), the image method's alpha_star, k = 4, eps and filter."""
    return KPT25(density=material.density, target=material.target, alpha=material.alpha,
                 alpha_star=KPT25_ALPHA_STAR, k=4, epsilon=KPT25_EPSILON)


def kpt25_defines(material: Material, lod_bias: float = 0.0, key_salt: int = 0) -> dict:
    """The shader's -D values for K_P = ``material.density``; ``lod_bias`` (MIP levels) and
    ``key_salt`` make the tests' deliberately wrong variants."""
    defines = {"KPT25_DENSITY": float(material.density), "KPT25_RES": math.sqrt(float(material.density)),
               "KPT25_ALPHA": float(material.alpha), "KPT25_GGX": int(material.target == "ggx"),
               "KPT25_ALPHA_STAR": KPT25_ALPHA_STAR, "KPT25_EPSILON": KPT25_EPSILON,
               "KPT25_FILTER": 0.5 / math.sqrt(math.pi)}
    if lod_bias:
        defines["KPT25_LOD_BIAS"] = V.real("lod_bias", lod_bias)
    if key_salt:
        defines["KPT25_KEY_SALT"] = f"{int(V.integer('key_salt', key_salt, 0, 0xFFFFFFFF))}u"
    return defines


@functools.lru_cache(maxsize=16)
def _kpt25(key: tuple) -> NdfShaderMethod:
    material, lod_bias, key_salt, language = key
    spec = _spec(kpt25_shader(language), "kpt25_shader", kpt25_defines(material, lod_bias, key_salt))
    return NdfShaderMethod(spec, material.target, material.alpha, material.density,
                           reference=functools.partial(kpt25_twin_ndf, material))


def kpt25_method(material: Material, lod_bias: float = 0.0, key_salt: int = 0, language: str = "glsl") -> NdfShaderMethod:
    """KPT25's Algorithm 1 as a method shader at K_P = ``material.density`` (GLSL or HLSL: one body),
    compiled on first use, once per parameter set."""
    if not isinstance(material, Material):
        V.fail("material", material, "a glintlab Material (density, target, alpha, R, angular texel)")
    return _kpt25((material, float(lod_bias), int(key_salt), _language(language)))


def kpt25_level(J) -> np.ndarray:
    """KPT25's fractional MIP level before its clamp at 0, per footprint (the twin refuses a pixel above
    level 15; both give it 0), for the image method's filter and a unit resolution (add log2 sqrt(K_P))."""
    f2 = 0.25 / math.pi
    suu = f2 * (J[:, 0] ** 2 + J[:, 2] ** 2)
    svv = f2 * (J[:, 1] ** 2 + J[:, 3] ** 2)
    suv = f2 * (J[:, 0] * J[:, 1] + J[:, 2] * J[:, 3])
    disc = np.sqrt(np.maximum(0.0, 0.25 * (suu - svv) ** 2 + suv**2))
    with np.errstate(divide="ignore"):
        return np.log2(6.0 * np.sqrt(0.5 * (suu + svv) + disc))


def kpt25_twin(rows, material: Material) -> np.ndarray:
    """The C++ twin's D per packed row (the same float32 values the shader reads); 0 below the horizon
    and where the footprint is degenerate or beyond the twin's finest-to-coarsest 15 MIP levels."""
    uv, J, h, seed = tangent_inputs(rows)
    out = np.zeros(uv.shape[0])
    det = J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2]
    level = kpt25_level(J) + 0.5 * math.log2(material.density)
    ok = (h[:, 2] > 0) & (det != 0) & (level <= 15.0 - 1e-12)  # the twin refuses a level above 15
    if ok.any():
        out[ok] = kpt25_twin_ndf(material).evaluate(uv[ok], J[ok], h[ok], seed=seed)
    return out


def kpt25_mismatch(shader, twin, rows, material: Material, allowance: float = 1e-3) -> dict:
    """Shader against twin per pixel, relative to max(twin, 1e-2 D(h)) (KPT25's value is D(h) times a
    mass: its compensation alone is a fraction of D(h)): ``share`` beyond ``allowance``, ``share_1pct``
    beyond 1 %, ``rel_err`` the mean and ``max_rel_err`` the largest relative error."""
    shader = np.asarray(shader, np.float64)
    twin = np.asarray(twin, np.float64)
    _, _, h, _ = tangent_inputs(rows)
    d = kpt25_twin_ndf(material).smooth(h)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.abs(shader - twin) / np.maximum(np.abs(twin), 1e-2 * d)
    err = np.where(np.isfinite(err), err, np.where(shader == twin, 0.0, np.inf))
    n = max(err.size, 1)
    return {"pixels": int(err.size), "share": float((err > allowance).sum() / n),
            "share_1pct": float((err > 0.01).sum() / n), "rel_err": float(np.mean(np.minimum(err, 1e3))) if err.size else 0.0,
            "max_rel_err": float(err.max()) if err.size else 0.0}


# DB23's counting pipeline as a method shader: an NDF image method (compiled on first use, needs Vulkan;
# not in the default panel). Its own truth is the facet truth, as for the C++ DB23 methods.
register_image_method("db23_shader", lambda m: db23_method(m), label="DB23 shader (GLSL)", returns="ndf")
# KPT25's Algorithm 1 as a method shader, at the density matched to the facets' glint count (as "kpt25"),
# its own truth the twin's reference (the sum over every point of the same realization).
register_image_method("kpt25_shader", lambda m: kpt25_method(m), label="KPT25 shader (GLSL)", truth="reference",
                      returns="ndf")
DENSITY_MAPPINGS["kpt25_shader"] = lambda m: matched_density(m.density, KPT25_ALPHA_STAR, m.target, m.alpha, m.R)
