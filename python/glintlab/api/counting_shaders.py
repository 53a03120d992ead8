"""DB23's counting pipeline as a whole method shader, with glintlab's C++ DB23 as its twin
(docs/math/glint_images.md#glint-db23-shader).

``db23_method.glsl`` computes, per pixel from GlintInput's uv, J, shading frame and h, DB23's glinty
NDF value D_P = (D(n) / R) K / (N P) with K counted on the trilinear anisotropic grids by the gated
Gaussian as DB23's public shader runs it (``gated_body.h``, the law shaders' body). It returns D, so it
is an NDF image method (``returns="ndf"``): the scene images shade it with the microfacet BRDF.

Its twin is ``glinty_ndf("db23", scheme="db23_trilinear", inner="gated_shader")`` (C++), fed the same
float32 GlintInput rows (:func:`db23_twin`). The shader reads the core's own per-cell random numbers
(splitmix64 keys of grid, angular texel and cell; 64-bit arithmetic emulated on 32-bit words), so the
two agree pixel by pixel except where a float32 rounding of the footprint, the level selection or a
grid coordinate moves a value across a floor (:func:`twin_mismatch`, :func:`float32_study`).

>>> from glintlab.api.glinty_ndf import Material
>>> sorted(db23_defines(Material(4194304.0, "beckmann", 1.0, 0.5)).items())[:3]
[('DB23_ALPHA', 1.0), ('DB23_ANGULAR_RES', 20.0), ('DB23_DENSITY', 4194304.0)]
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from ..resources import data_path
from . import checks as V
from .glinty_ndf import DB23, GlintyNDF, Material, register_image_method
from .method_shaders import ShaderMethod, frame_rows, pack_inputs, shader_method, unpack_inputs

DB23_SHADER = "db23_method.glsl"
#: A pixel "mismatches" when shader and twin differ by more than this share of the pixel's one-facet
#: value D(n) / (R N P) (a count difference of 1e-3 facets: far above float32's relative 1e-6 on a soft
#: gate's ramp, far below any count flip, whose size is the gate's value times 1).
COUNT_ALLOWANCE = 1e-3


def db23_shader() -> Path:
    """The path of the shipped DB23 method shader (GLSL)."""
    return Path(data_path("shaders", DB23_SHADER))


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


def _glsl_float(x: float) -> str:
    r = repr(float(x))
    return r if ("." in r or "e" in r) else r + ".0"


class NdfShaderMethod(ShaderMethod, GlintyNDF):
    """A method shader that returns the glinty NDF value D per pixel (``returns = "ndf"``): its image is
    D on the lit pixels (as every NDF method's), shaded by the scene images' BRDF; ``smooth(h)`` is its
    target; ``evaluate(uv, J, h, seed)`` runs it on tangent-frame inputs (normal +z, tangent +x)."""

    returns = "ndf"

    def __init__(self, spec: dict, target: str, alpha: float, density: float):
        ShaderMethod.__init__(self, spec)
        params = self.params
        GlintyNDF.__init__(self, target, alpha, density)
        self.params = params
        self._ndf_args = (target, alpha, density)

    def __reduce__(self):
        return (NdfShaderMethod, (self._spec, *self._ndf_args))

    def smooth(self, h):
        return GlintyNDF.smooth(self, h)

    def image(self, inputs, seed: int = 0, frame: int = 0) -> np.ndarray:
        """D on the pixels of ``inputs.mask`` (those that see the lit surface), 0 elsewhere."""
        import dataclasses
        rows, mask = frame_rows(dataclasses.replace(inputs, hit=inputs.mask), seed, frame)
        img = np.zeros(mask.shape)
        img[mask] = self.shade(rows)
        return img

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D per pixel from tangent-frame inputs (uv (..., 2), J (..., 4), h (..., 3))."""
        uv = np.asarray(V.as_float_array("uv", uv), float)
        shape = uv.shape[:-1]
        m = int(np.prod(shape)) if shape else 1
        h = np.asarray(V.as_float_array("h", h), float).reshape(m, 3)
        hn = h / np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-300)
        rows = pack_inputs(m, uv=uv.reshape(m, 2), J=np.reshape(J, (m, 4)), h=hn, n=[0.0, 0.0, 1.0],
                           t=[1.0, 0.0, 0.0], b=[0.0, 1.0, 0.0], seed=np.uint32(V.seed(seed) & 0xFFFFFFFF))
        return self.shade(rows).astype(np.float64).reshape(shape)


@functools.lru_cache(maxsize=16)
def _db23(key: tuple) -> NdfShaderMethod:
    material, lod_bias, key_salt = key
    defines = {k: (_glsl_float(v) if isinstance(v, float) else v)
               for k, v in db23_defines(material, lod_bias, key_salt).items()}
    # Compiled under a name of its own (shader_method keeps registered NDF methods' names for them).
    base = shader_method(db23_shader(), language="glsl", name="db23_method", defines=defines, register=False)
    return NdfShaderMethod(dict(base._spec, name="db23_shader"), material.target, material.alpha, material.density)


def db23_method(material: Material, lod_bias: int = 0, key_salt: int = 0) -> NdfShaderMethod:
    """DB23's counting pipeline as a method shader for ``material``, compiled once per parameter set."""
    if not isinstance(material, Material):
        V.fail("material", material, "a glintlab Material (density, target, alpha, R, angular texel)")
    return _db23((material, int(lod_bias), int(key_salt)))


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
    pixel's one-facet value D(n) / (R N P), ``share_1pct`` of those off by more than 1 %, ``rel_err`` the mean of |shader - twin| / max(twin, one
    facet) and its maximum ``max_rel_err``; ``pixels`` compared."""
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


# DB23's counting pipeline as a method shader: an NDF image method (compiled on first use, needs Vulkan;
# not in the default panel). Its own truth is the facet truth, as for the C++ DB23 methods.
register_image_method("db23_shader", lambda m: db23_method(m), label="DB23 shader (GLSL)", returns="ndf")
