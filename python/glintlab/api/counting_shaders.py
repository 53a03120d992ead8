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
from . import shader_resources
from .glinty_ndf import DB23, KPT25, GlintyNDF, Material, matched_density, pixel_arrays, register_image_method
from .grids import aniso_counter, footprint_shapes
from .method_shaders import (ShaderMethod, ShippedShader, check_output, frame_rows, pack_inputs,
                             register_ndf_shader_factory, shader_seed, unpack_inputs)
from .shaders import DEFAULT_TIMEOUT_S, ShaderBacked, kernel_spec

#: Each method shader is one body (<name>_method_body.h) with a thin .glsl and .hlsl wrapper.
METHOD_LANGUAGES = ("glsl", "hlsl")
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
    if "includes" in spec:
        # A spec compiled once carries its #included files' bytes: hex in the cache key (JSON has no bytes).
        spec["includes"] = [(path, bytes(content).hex()) for path, content in spec["includes"]]
    # The resources' arrays are no JSON: the cache keys them by their digest and keeps them aside.
    resources = spec.pop("resources", None) or {}
    key = shader_resources.digest(resources).hex() if resources else ""
    _RESOURCES.setdefault(key, resources)
    return _user_ndf(json.dumps(spec, sort_keys=True), key, material)


_RESOURCES: dict = {}  # digest -> the resources of the NDF shaders made (what _user_ndf's key names)


@functools.lru_cache(maxsize=16)
def _user_ndf(spec_json: str, resources_key: str, material: Material) -> NdfShaderMethod:
    # One compiled method per (shader, material): the scene images ask for a scene's method once per frame.
    spec = json.loads(spec_json)
    spec["defines"] = [tuple(d) for d in spec["defines"]]
    if "includes" in spec:
        spec["includes"] = [(path, bytes.fromhex(content)) for path, content in spec["includes"]]
    spec["resources"] = _RESOURCES[resources_key]
    return NdfShaderMethod(spec, material.target, material.alpha, material.density)


register_ndf_shader_factory(user_ndf_method)


@functools.lru_cache(maxsize=16)
def _db23(key: tuple) -> NdfShaderMethod:
    material, lod_bias, key_salt, language, texture_key = key
    defines = db23_defines(material, lod_bias, key_salt)
    spec = _spec(db23_shader(language), "db23_shader", defines)
    if texture_key:
        texture = _RESOURCES[texture_key]
        spec = _spec(db23_shader(language), "db23_shader",
                     dict(defines, DB23_RANDOM_TEXTURE=1, DB23_RANDOM_TILE=texture.shape[0]))
        spec["resources"] = shader_resources.resource_spec(
            textures={"DB23RandomTex": (texture, {"filter": "nearest", "address": "wrap"})})
    return NdfShaderMethod(spec, material.target, material.alpha, material.density)


def db23_random_texture(tile: int = 64, seed: int = 0) -> np.ndarray:
    """A texture of precomputed random numbers for DB23's shader (``db23_method(random_texture=...)``):
    (tile, tile, 2) float32 uniforms, each (k + 1/2) / 2^23 for a uniform integer k < 2^23 (never 0 or 1,
    the float32 rule of glintlab's uniforms), from numpy's PCG64 seeded with ``seed``."""
    V.integer("tile", tile, 1, 4096)
    k = np.random.default_rng(V.seed(seed)).integers(0, 2**23, (tile, tile, 2))
    return ((k + 0.5) / 2.0**23).astype(np.float32)


def db23_method(material: Material, lod_bias: int = 0, key_salt: int = 0, language: str = "glsl",
                random_texture=None) -> NdfShaderMethod:
    """DB23's counting pipeline as a method shader for ``material`` (GLSL or HLSL: one body), compiled on
    first use, once per parameter set. ``random_texture``: None (each cell's two uniforms hashed from
    glintlab's keys, the C++ twin's numbers) or a (tile, tile, 2) array of uniforms in (0, 1)
    (:func:`db23_random_texture`) that the shader reads instead, as DB23's public shaders read a texture
    of precomputed random numbers (DB23_RANDOM_TEXTURE; the hashed key still offsets each grid's tiling)."""
    if not isinstance(material, Material):
        V.fail("material", material, "a glintlab Material (density, target, alpha, R, angular texel)")
    texture_key = ""
    if random_texture is not None:
        t = np.asarray(random_texture)
        if t.ndim != 3 or t.shape[0] != t.shape[1] or t.shape[2] != 2 or t.dtype.kind != "f":
            V.fail("random_texture", f"an array of shape {t.shape} ({t.dtype})", "a (tile, tile, 2) float array")
        if not ((t > 0) & (t < 1)).all():
            V.fail("random_texture", "values outside (0, 1)", "uniforms in the open interval (0, 1)")
        texture_key = "db23:" + shader_resources.digest({"textures": {"t": {"array": t}}}).hex()
        _RESOURCES.setdefault(texture_key, np.array(t, np.float32))
    return _db23((material, int(lod_bias), int(key_salt), _language(language), texture_key))


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


def _summary(err: np.ndarray, allowance: float) -> dict:
    """A comparison's figures from its per-pixel relative errors (NaN where both agree on NaN: 0)."""
    n = max(err.size, 1)
    return {"pixels": int(err.size), "share": float((err > allowance).sum() / n),
            "share_1pct": float((err > 0.01).sum() / n),
            "rel_err": float(np.mean(np.minimum(err, 1e3))) if err.size else 0.0,
            "max_rel_err": float(err.max()) if err.size else 0.0, "beyond": np.nonzero(err > allowance)[0]}


def _relative(shader, twin, scale) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.abs(shader - twin) / scale
    return np.where(np.isfinite(err), err, np.where(shader == twin, 0.0, np.inf))


def twin_mismatch(shader, twin, rows, material: Material) -> dict:
    """Shader against twin per pixel: ``share`` of pixels whose difference exceeds COUNT_ALLOWANCE of the
    pixel's one-facet value D(n) / (R N P), ``share_1pct`` of those off by more than 1 %, ``rel_err`` the
    mean of |shader - twin| / max(twin, one facet) and its maximum ``max_rel_err``; ``pixels`` compared,
    ``beyond`` the rows beyond the allowance."""
    shader = np.asarray(shader, np.float64)
    twin = np.asarray(twin, np.float64)
    _, J, _, _ = tangent_inputs(rows)
    P = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        one = 1.0 / (math.pi * material.alpha**2) / (material.R * material.density * P)
    return _summary(_relative(shader, twin, np.maximum(np.abs(twin), one)), COUNT_ALLOWANCE)


def db23_compare(rows, material: Material, method=None) -> dict:
    """The DB23 method shader (or ``method``, e.g. a deliberately wrong variant) against the C++ twin on
    the same rows (:func:`twin_mismatch`). Measured on lavapipe (plane_25, plane_90, sphere,
    heightfield_25 at 0.06 and 0.1 scale, seeds 0 and 5): 0 to 0.02 % of the pixels beyond the allowance."""
    method = method if method is not None else db23_method(material)
    return twin_mismatch(method.shade(rows), db23_twin(rows, material), rows, material)


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
    beyond 1 %, ``rel_err`` the mean and ``max_rel_err`` the largest relative error, ``beyond`` the rows
    beyond the allowance."""
    shader = np.asarray(shader, np.float64)
    twin = np.asarray(twin, np.float64)
    _, _, h, _ = tangent_inputs(rows)
    d = kpt25_twin_ndf(material).smooth(h)
    return _summary(_relative(shader, twin, np.maximum(np.abs(twin), 1e-2 * d)), allowance)


def kpt25_compare(rows, material: Material, method=None) -> dict:
    """The KPT25 method shader (or ``method``) against its C++ twin on the same rows at K_P =
    ``material.density`` (:func:`kpt25_mismatch`). Measured on lavapipe (the scenes of
    :func:`db23_compare`): 0 to 0.13 % of the pixels beyond the allowance."""
    method = method if method is not None else kpt25_method(material)
    return kpt25_mismatch(method.shade(rows), kpt25_twin(rows, material), rows, material)


# --------------------------------------------------------------------------------------------------
# Why pixels differ (the float32 study of glintlab.validation.method_twins reads these through the
# registry entries' ``explain``)

#: A coordinate this many float32 spacings (of its own magnitude) from an integer counts as "at a cell
#: boundary": the shader's rotation and division round it by a few spacings.
BOUNDARY_ULPS = 16


def db23_explain(rows, material: Material, which, limit: int = 64) -> dict:
    """Why mismatching pixels differ: for up to ``limit`` of the row indices ``which``, whether a grid
    coordinate of one of its terms (in float64, as the twin computes it) or its angular coordinate lies
    within BOUNDARY_ULPS float32 spacings of an integer. Returns counts {"cell boundary", "count floor"}."""
    uv, J, h, _ = tangent_inputs(rows)
    counter = aniso_counter("db23_trilinear", inner="gated_shader", base_area=1.0 / material.density)
    out = {"cell boundary": 0, "count floor": 0}
    which = np.asarray(list(which)[:limit], dtype=np.int64)
    shapes = footprint_shapes(J[which]) if which.size else None
    for row, i in enumerate(which):
        shp = shapes.iloc[row]
        coords = list(h[i, :2] / h[i, 2] / material.angular_texel)
        if shp.status in ("ok", "clamped"):
            terms, _ = counter._core.terms(float(material.density), float(shp.P), float(shp.r), float(shp.phi))
            for t in terms:
                c, s = math.cos(t["angle"]), math.sin(t["angle"])
                coords += [(-uv[i, 0] * s + uv[i, 1] * c) / t["cell_minor"], (uv[i, 0] * c + uv[i, 1] * s) / t["cell_major"]]
        x = np.asarray(coords)
        tol = BOUNDARY_ULPS * np.spacing(np.abs(x).astype(np.float32) + np.float32(1.0)).astype(np.float64)
        out["cell boundary" if bool(np.any(np.abs(x - np.round(x)) <= tol)) else "count floor"] += 1
    return out


def _philox(c, key):
    """Philox4x32-10 on uint32 arrays c (4, m) and key (2,), as the core's CounterRng::block."""
    c = [np.asarray(x, np.uint64) & 0xFFFFFFFF for x in c]
    k0, k1 = np.uint64(key[0]), np.uint64(key[1])
    mask = np.uint64(0xFFFFFFFF)
    for r in range(10):
        if r:
            k0, k1 = (k0 + np.uint64(0x9E3779B9)) & mask, (k1 + np.uint64(0xBB67AE85)) & mask
        p0 = np.uint64(0xD2511F53) * c[0]
        p1 = np.uint64(0xCD9E8D57) * c[2]
        c = [((p1 >> np.uint64(32)) ^ c[1] ^ k0) & mask, p1 & mask, ((p0 >> np.uint64(32)) ^ c[3] ^ k1) & mask, p0 & mask]
    return c


def kpt25_explain(rows, material: Material, which, limit: int = 64, ulps: float = 64.0) -> dict:
    """Why KPT25 pixels differ: for up to ``limit`` rows of ``which``, the points of B(k) at the pixel's
    levels in float64 (the twin's arithmetic), and whether one of them sits within ``ulps`` float32
    spacings of the filter's edge (q = 9) or of the disk U's rim ("point at an edge"), or the pixel's
    spatial box or angular block is at a floor ("box or block edge"), or every point's offset from the
    pixel is rounded to |uv| 2^-24, beyond 1e-4 of the filter's std ("point offsets"), or the lobe lies
    within 8 stds of the unit square's edge ("lobe at the square's edge": the compensation's erfc
    differences); else "ulps" (exp, erfc, log2)."""
    uv, J, h, seed = tangent_inputs(rows)
    nd = kpt25_twin_ndf(material)
    out = {"point at an edge": 0, "point offsets": 0, "box or block edge": 0, "lobe at the square's edge": 0, "ulps": 0}
    eps32 = float(np.finfo(np.float32).eps) * ulps
    for i in list(which)[:limit]:
        px = nd.pixel(J[i], h[i])
        f2 = 0.25 / math.pi
        suu = f2 * (J[i, 0] ** 2 + J[i, 2] ** 2)
        svv = f2 * (J[i, 1] ** 2 + J[i, 3] ** 2)
        suv = f2 * (J[i, 0] * J[i, 1] + J[i, 2] * J[i, 3])
        det = suu * svv - suv * suv
        ia, ib, ic = svv / det, -suv / det, suu / det
        hu, hv = 3 * math.sqrt(suu), 3 * math.sqrt(svv)
        res = math.sqrt(material.density)
        reason = "ulps"
        lam = max(0.0, float(px["lambda"]))
        l0 = int(math.floor(lam))
        edges = [lam]
        for level in ([l0, l0 + 1] if lam > l0 else [l0]):
            cell, na = 2.0**level / res, 2**level
            edges += [(uv[i, 0] - hu) / cell, (uv[i, 0] + hu) / cell, (uv[i, 1] - hv) / cell, (uv[i, 1] + hv) / cell]
            qa, qb = px["xa"] * na - 0.5, px["ya"] * na - 0.5
            edges += [qa, qb] if na > 2 else []
            a0 = 0 if na <= 2 else min(max(int(math.floor(qa)), 0), na - 2)
            b0 = 0 if na <= 2 else min(max(int(math.floor(qb)), 0), na - 2)
            ii = np.arange(math.floor((uv[i, 0] - hu) / cell), math.floor((uv[i, 0] + hu) / cell) + 1)
            jj = np.arange(math.floor((uv[i, 1] - hv) / cell), math.floor((uv[i, 1] + hv) / cell) + 1)
            aa = np.arange(a0, min(a0 + 1, na - 1) + 1)
            bb = np.arange(b0, min(b0 + 1, na - 1) + 1)
            I, Jj, A, B = (x.ravel() for x in np.meshgrid(ii, jj, aa, bb, indexing="ij"))
            word3 = (8 << 24) | (level << 20) | B
            r = _philox([2 * A, I, Jj, word3], (seed & 0xFFFFFFFF, seed >> 32))
            unit = [(x.astype(np.float64) + 0.5) * 2.0**-32 for x in r]
            mx, my = (A + unit[2]) / na, (B + unit[3]) / na
            rim = (mx - 0.5) ** 2 + (my - 0.5) ** 2
            dx, dy = (I + unit[0]) * cell - uv[i, 0], (Jj + unit[1]) * cell - uv[i, 1]
            q = ia * dx * dx + 2 * ib * dx * dy + ic * dy * dy
            # float32 keeps |uv| 2^-24 of the point's offset: q moves by that much relative to the footprint
            dq = 2 * math.sqrt(max(ia, ic)) * 3 * (abs(uv[i]).max() + 1) * eps32
            if np.any((np.abs(q - 9.0) <= dq + 9 * eps32) & (rim < 0.25)) or np.any(np.abs(rim - 0.25) <= eps32):
                reason = "point at an edge"
        # The point's offset (i + u) cell - uv keeps |uv| 2^-24: relative to the filter's std that moves every
        # point's q, so the weights exp(-q / 2), by more than the allowance when it exceeds 1e-4.
        if reason == "ulps" and 3 * float(np.spacing(np.float32(np.abs(uv[i]).max()))) * math.sqrt(max(ia, ic)) > 1e-4:
            reason = "point offsets"
        # A lobe within 8 stds of the unit square's edge (T(h) at U's rim: grazing h, sigma ~ 1e-7 to 1e-3):
        # the compensation's 1D masses there are differences of erfc of float32 arguments.
        if reason == "ulps" and min(px["xa"], 1 - px["xa"], px["ya"], 1 - px["ya"]) < 8 * px["sigma"]:
            reason = "lobe at the square's edge"
        if reason == "ulps":
            e = np.asarray(edges)
            if np.any(np.abs(e - np.round(e)) <= eps32 * (np.abs(e) + 1)):
                reason = "box or block edge"
        out[reason] += 1
    return out


# DB23's counting pipeline as a method shader: an NDF image method (compiled on first use, needs Vulkan;
# not in the default panel). Its own truth is the facet truth, as for the C++ DB23 methods. Its wrong
# variants: one LOD level off (the grids one scale coarser), and cells that read other keys (another
# realization of the same law).
register_image_method("db23_shader", lambda m: db23_method(m), label="DB23 shader (GLSL)", returns="ndf", panel=False,
                      doc="docs/math/glint_images.md#glint-db23-shader",
                      shader=ShippedShader("db23_method", db23_compare, lambda m: {
                          "one LOD level coarser": db23_method(m, lod_bias=1),
                          "other cell keys": db23_method(m, key_salt=1)}, explain=db23_explain))
# KPT25's Algorithm 1 as a method shader, at the density matched to the facets' glint count (as "kpt25"),
# its own truth the twin's reference (the sum over every point of the same realization). Its wrong
# variants: half a MIP level off (every point's weights change), another key (another realization).
register_image_method("kpt25_shader", lambda m: kpt25_method(m), label="KPT25 shader (GLSL)", truth="reference",
                      returns="ndf", panel=False, doc="docs/math/glint_images.md#glint-kpt25-shader",
                      density=lambda m: matched_density(m.density, KPT25_ALPHA_STAR, m.target, m.alpha, m.R),
                      shader=ShippedShader("kpt25_method", kpt25_compare, lambda m: {
                          "half a MIP level off": kpt25_method(m, lod_bias=0.5),
                          "another key": kpt25_method(m, key_salt=1)}, explain=kpt25_explain))
