"""The methods of DB23's Table 1 and KPT25's Table 3 that glintlab did not ship as shaders: ZK16 as DB23
describes it, its gated variant (KPT25's "Zirr & Kaplanyan*") and the no-glints baseline, each a method
shader with its C++ twin (docs/guide/gpu_cost.md#the-method-shaders-of-the-two-tables).

``zk16_method_body.h`` computes DB23's D_P = (D(n) / R) K / (N P) with K counted by ZK16's anisotropic
probes (min(ceil r, 16) isotropic probes along the major axis, two mip levels each, outputs blended) and
ZK16's hybrid law (Gaussian above n p = 5, else up to 16 Bernoulli trials), or, with ``gated=True``, DB23's
gated Gaussian. Its twin is glintlab's DB23 glinty NDF with scheme "zk16_aniso" and inner law "zk16"
(``gated``: "gated_shader") on the same random numbers. ``smooth_method_body.h`` is the smooth NDF D(h),
the "No Glints" column.

>>> from glintlab.api.glinty_ndf import Material
>>> zk16_defines(Material(4194304.0, "beckmann", 1.0, 0.5), gated=True)["ZK16_GATED"]
1
"""
from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np

from ..resources import data_path
from . import checks as V
from .counting_shaders import NdfShaderMethod, _spec, tangent_inputs, twin_mismatch
from .glinty_ndf import DB23, Material, register_image_method
from .method_shaders import ShippedShader

#: ZK16's maximum anisotropy (probes per footprint) and Bernoulli-loop cap, as DB23 describes them.
ZK16_MAX_ANISO, ZK16_CAP = 16, 16


def _language(language):
    V.choice("language", language, ("glsl", "hlsl"), "'glsl' or 'hlsl'")
    return language


def _material(material):
    if not isinstance(material, Material):
        V.fail("material", material, "a glintlab Material (density, target, alpha, R, angular texel)")
    return material


def zk16_shader(language: str = "glsl") -> Path:
    """The path of the shipped ZK16 method shader (GLSL or HLSL wrapper of ``zk16_method_body.h``)."""
    return Path(data_path("shaders", f"zk16_method.{_language(language)}"))


def smooth_shader(language: str = "glsl") -> Path:
    """The path of the shipped no-glints baseline (GLSL or HLSL wrapper of ``smooth_method_body.h``)."""
    return Path(data_path("shaders", f"smooth_method.{_language(language)}"))


def zk16_defines(material: Material, gated: bool = False) -> dict:
    """The shader's -D values for a scene material (as DB23's shader's) and the law (``gated``)."""
    return {"ZK16_DENSITY": float(material.density), "ZK16_ALPHA": float(material.alpha), "ZK16_R": float(material.R),
            "ZK16_GGX": int(material.target == "ggx"), "ZK16_ANGULAR_RES": 1.0 / float(material.angular_texel),
            "ZK16_GATED": int(bool(gated)), "ZK16_MAX_ANISO": ZK16_MAX_ANISO, "ZK16_CAP": ZK16_CAP}


@functools.lru_cache(maxsize=16)
def _zk16(material: Material, gated: bool, language: str) -> NdfShaderMethod:
    name = "zk16_gated_shader" if gated else "zk16_shader"
    return NdfShaderMethod(_spec(zk16_shader(language), name, zk16_defines(material, gated)), material.target,
                           material.alpha, material.density)


def zk16_method(material: Material, gated: bool = False, language: str = "glsl") -> NdfShaderMethod:
    """ZK16 as DB23 describes it (``gated``: with DB23's gated law, KPT25's Table 3 variant) as a method
    shader for ``material``, compiled on first use, once per parameter set."""
    return _zk16(_material(material), bool(gated), _language(language))


@functools.lru_cache(maxsize=16)
def _smooth(material: Material, language: str) -> NdfShaderMethod:
    defines = {"SMOOTH_ALPHA": float(material.alpha), "SMOOTH_GGX": int(material.target == "ggx")}
    return NdfShaderMethod(_spec(smooth_shader(language), "smooth_shader", defines), material.target, material.alpha,
                           material.density)


def smooth_method(material: Material, language: str = "glsl") -> NdfShaderMethod:
    """The no-glints baseline (the smooth NDF D(h)) as a method shader for ``material``."""
    return _smooth(_material(material), _language(language))


def zk16_twin_ndf(material: Material, gated: bool = False) -> DB23:
    """The C++ twin: DB23's glinty NDF on the "zk16_aniso" probes with the law "zk16" (``gated``:
    "gated_shader", the C++ emulation of gated_body.h), at the material's density, R and angular resolution."""
    return DB23(density=material.density, target=material.target, alpha=material.alpha, scheme="zk16_aniso",
                inner="gated_shader" if gated else "zk16", R=material.R, angular_resolution=1.0 / material.angular_texel)


def footprint_ratio(J) -> np.ndarray:
    """The footprint's anisotropy (major / minor singular value of J) per row, in float64."""
    J = np.asarray(J, np.float64)
    pp = J[:, 0] ** 2 + J[:, 2] ** 2
    qq = J[:, 0] * J[:, 1] + J[:, 2] * J[:, 3]
    rr = J[:, 1] ** 2 + J[:, 3] ** 2
    s1 = np.sqrt(0.5 * (pp + rr) + np.hypot(0.5 * (pp - rr), qq))
    det = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        return s1 * s1 / det


def zk16_twin(rows, material: Material, gated: bool = False):
    """(D, compared): the C++ twin's D per packed row (the float32 values the shader reads) and the mask
    of rows the twin defines as the shader does: h above the horizon, a non-degenerate footprint, and an
    anisotropy within 16 (beyond it the twin marks the footprint clamped and gives 0, where the shader
    widens it as ZK16 does)."""
    uv, J, h, seed = tangent_inputs(rows)
    out = np.zeros(uv.shape[0])
    det = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    ok = (h[:, 2] > 0) & (det > 0) & (footprint_ratio(J) <= ZK16_MAX_ANISO * (1 - 1e-6))
    if ok.any():
        out[ok] = zk16_twin_ndf(material, gated).evaluate(uv[ok], J[ok], h[ok], seed=seed)
    return out, ok


def zk16_variant(material: Material, **defines) -> NdfShaderMethod:
    """The ZK16 shader with some defines changed (``ZK16_MAX_ANISO=4``, ``ZK16_GATED=...``): the tests'
    deliberately wrong variants."""
    return NdfShaderMethod(_spec(zk16_shader("glsl"), "zk16_wrong", {**zk16_defines(material), **defines}),
                           material.target, material.alpha, material.density)


def zk16_compare(rows, material: Material, method=None, gated: bool = False) -> dict:
    """The ZK16 shader (``gated``: ZK16*; or ``method``) against its C++ twin on the rows the twin defines as
    the shader does (:func:`zk16_twin`), with ``counting_shaders.twin_mismatch``'s figures; ``beyond`` are
    indices of ``rows``. Measured on lavapipe (plane_25 at 0.04 and 0.06, plane_90 at 0.05, heightfield_25
    at 0.05, sphere at 0.06; both laws): 0 pixels beyond the allowance."""
    method = method if method is not None else zk16_method(material, gated)
    twin, ok = zk16_twin(rows, material, gated)
    r = twin_mismatch(method.shade(rows)[ok], twin[ok], rows[ok], material)
    r["beyond"] = np.nonzero(ok)[0][r["beyond"]]
    return r


def smooth_compare(rows, material: Material, method=None) -> dict:
    """The no-glints shader (or ``method``) against the smooth NDF D(h) of the same rows (relative 1e-4:
    float32 transcendentals): ``share`` and ``beyond`` of the pixels beyond it, ``pixels``."""
    method = method if method is not None else smooth_method(material)
    _, _, h, _ = tangent_inputs(rows)
    ref = zk16_twin_ndf(material).smooth(h)
    bad = ~(np.abs(method.shade(rows) - ref) <= 1e-4 * np.abs(ref))
    return {"share": float(bad.mean()) if bad.size else 0.0, "pixels": int(bad.size), "beyond": np.nonzero(bad)[0]}


# ZK16 and its gated variant as method shaders (NDF image methods, compiled on first use, not in the
# default panel), and the no-glints baseline. Their own truth is the facet truth, as for the C++ methods.
# Their wrong variants: fewer probes (maximum anisotropy 4) and the other law; the baseline's, the other
# target NDF.
_DOC = "docs/guide/gpu_cost.md#the-method-shaders-of-the-two-tables"
register_image_method("zk16_shader", lambda m: zk16_method(m), label="ZK16 shader (GLSL)", returns="ndf", panel=False,
                      doc=_DOC, shader=ShippedShader("zk16_method", zk16_compare, lambda m: {
                          "maximum anisotropy 4": zk16_variant(m, ZK16_MAX_ANISO=4),
                          "the gated law": zk16_variant(m, ZK16_GATED=1)}))
register_image_method("zk16_gated_shader", lambda m: zk16_method(m, gated=True), label="ZK16* gated shader (GLSL)",
                      returns="ndf", panel=False, doc=_DOC,
                      shader=ShippedShader("zk16_method", functools.partial(zk16_compare, gated=True), lambda m: {
                          "maximum anisotropy 4": zk16_variant(m, ZK16_MAX_ANISO=4, ZK16_GATED=1),
                          "ZK16's own law": zk16_variant(m, ZK16_GATED=0)}))
register_image_method("smooth_shader", lambda m: smooth_method(m), label="No glints shader (GLSL)", returns="ndf",
                      panel=False, doc=_DOC, shader=ShippedShader("smooth_method", smooth_compare, lambda m: {
                          "the other target": smooth_method(dataclasses.replace(
                              m, target="ggx" if m.target == "beckmann" else "beckmann"))}))
