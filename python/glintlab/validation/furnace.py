"""Furnace tests of NDFs (docs/math/sampling.md#furnace-tests): how much energy an NDF, used in a
microfacet BRDF with Smith masking, loses or gains.

Three quantities, for a smooth NDF (``gl.ndf``) by adaptive cubature over the half-vector hemisphere
(the harness's Genz-Malik bins, with their error), and for a glinty NDF (anything with
``evaluate(uv, J, h, seed)`` and ``smooth_ndf``, e.g. ``gl.glinty_ndf("kpt25")``) by Monte Carlo over
half vectors drawn from the smooth NDF, averaged over surface positions and footprints:

- ``projected_area``: the integral of D(h) (h . n) over the hemisphere (1 for a normalised NDF);
- ``weak_furnace``: the integral over all incident directions of D(h) G1(wo) / (4 wo . n), i.e. of the
  visible-normal density G1(wo) max(0, wo . h) D(h) / (wo . n) over h: 1 when D and G1 agree;
- ``furnace_g2``: the white furnace of the BRDF D G2 / (4 (wo . n) (wi . n)) with the height-correlated
  G2 = 1 / (1 + Lambda(wo) + Lambda(wi)), incident directions above the surface only: below 1 by the
  energy single scattering loses (no pass/fail; multiple scattering would return it).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .. import _core
from ..api import checks as V
from ..api.ndf import NDF
from ..api.samplers import BeckmannVisibleNormals, GGXVisibleNormals


def _cubature(f, rel_tol=1e-3, target=None):
    """Integral over the hemisphere of f(h) (per steradian) and its error: the harness's bins for a
    nominal 1e12 samples, so that the tolerance rel_tol sqrt(expected) of a bin is an absolute error of
    1e-9 sqrt(mass) on its integral."""
    total = 1e12
    b = _core.SamplerBins("hemisphere", total, total / 64 if target is None else target, 3, 8, 14, rel_tol,
                          4_000_000, np.zeros(0), np.zeros(0), 0.0, np.zeros(0))
    while not b.done:
        b.supply(np.asarray(f(b.nodes().reshape(-1, 3)), dtype=np.float64))
    return float(np.sum(b.integral)), float(np.sum(b.error))


def _wo(theta_deg):
    t = math.radians(theta_deg)
    return np.array([math.sin(t), 0.0, math.cos(t)])


def _reflect(wo, h):
    return 2.0 * (h @ wo)[:, None] * h - wo


def _smooth_rows(ndf: NDF, thetas):
    rows = []
    v, e = _cubature(lambda h: ndf.D(h[:, 2]) * np.maximum(h[:, 2], 0.0))
    rows.append({"quantity": "projected_area", "theta_o_deg": float("nan"), "value": v, "error": e,
                 "method": "cubature"})
    for th in thetas:
        wo = _wo(th)
        g1 = float(ndf.G1(wo[2]))
        lam_o = float(ndf.smith_lambda(wo[2]))

        def weak(h, wo=wo, g1=g1):
            return g1 * np.maximum(h @ wo, 0.0) * ndf.D(h[:, 2]) / wo[2]

        def g2(h, wo=wo, lam_o=lam_o):
            wi = _reflect(wo, h)
            ok = (wi[:, 2] > 0) & ((h @ wo) > 0)
            lam_i = ndf.smith_lambda(np.where(ok, wi[:, 2], 1.0))
            return np.where(ok, ndf.D(h[:, 2]) * np.maximum(h @ wo, 0.0) / wo[2] / (1.0 + lam_o + lam_i), 0.0)

        for name, f in (("weak_furnace", weak), ("furnace_g2", g2)):
            v, e = _cubature(f)
            rows.append({"quantity": name, "theta_o_deg": float(th), "value": v, "error": e, "method": "cubature"})
    return rows


def _glinty_rows(nd, thetas, pixels, directions, points, seed):
    smooth = nd.smooth_ndf
    rng = np.random.Generator(np.random.Philox(V.seed(seed)))
    rows = []
    for pts in points:
        side = math.sqrt(pts / nd.density)
        # Pixels far apart (40 footprints), so that no two share points: independent surface positions.
        uv = rng.uniform(0.0, 1.0, (pixels, 2)) * side * 40.0 * math.sqrt(pixels) + 10.0
        J = np.tile([side, 0.0, 0.0, side], (pixels, 1))
        cases = [("projected_area", float("nan"), None)] + [(q, float(t), _wo(t)) for t in thetas
                                                            for q in ("weak_furnace", "furnace_g2")]
        for quantity, th, wo in cases:
            u = rng.random((pixels, directions, 2))
            if wo is None:  # h ~ D(h)(h.n): estimator D^f / D
                h = _normal_draw(smooth, u)
            else:           # h ~ visible normals of the smooth NDF: estimator D^f / D (times G2 / G1)
                h = _vndf_draw(smooth, wo, u)
            hf = h.reshape(-1, 3)
            uvf = np.repeat(uv, directions, axis=0)
            Jf = np.repeat(J, directions, axis=0)
            d = smooth.D(hf[:, 2])
            df = nd.evaluate(uvf, Jf, hf, seed=seed)
            with np.errstate(divide="ignore", invalid="ignore"):
                w = np.where(d > 0, df / d, 0.0)
            if quantity == "furnace_g2":
                wi = _reflect(wo, hf)
                ok = wi[:, 2] > 0
                lam_o = float(smooth.smith_lambda(wo[2]))
                lam_i = smooth.smith_lambda(np.where(ok, wi[:, 2], 1.0))
                w = np.where(ok, w * (1.0 + lam_o) / (1.0 + lam_o + lam_i), 0.0)
            per_pixel = w.reshape(pixels, directions).mean(axis=1)
            rows.append({"quantity": quantity, "theta_o_deg": th, "points": float(pts), "value": float(per_pixel.mean()),
                         "error": float(per_pixel.std(ddof=1) / math.sqrt(pixels)), "method": "monte carlo",
                         "pixel_spread": float(per_pixel.std(ddof=1))})
    return rows


def _normal_draw(ndf, u):
    a2 = ndf.alpha ** 2
    if ndf.name == "ggx":
        tan2 = a2 * u[..., 0] / (1.0 - u[..., 0])
    else:
        tan2 = -a2 * np.log1p(-u[..., 0])
    c = 1.0 / np.sqrt(1.0 + tan2)
    s = np.sqrt(np.maximum(0.0, 1.0 - c * c))
    phi = 2.0 * math.pi * u[..., 1]
    return np.stack([s * np.cos(phi), s * np.sin(phi), c], axis=-1)


def _vndf_draw(ndf, wo, u):
    """Visible normals of the smooth NDF for wo, by the registered samplers (tested by the harness);
    their seed comes from the caller's uniforms, so one furnace seed fixes everything."""
    sampler = (GGXVisibleNormals if ndf.name == "ggx" else BeckmannVisibleNormals)(alpha=ndf.alpha, wo=tuple(wo))
    h, _ = sampler.sample(u.shape[0] * u.shape[1], seed=int(u[0, 0, 0] * 2**52))
    return h.reshape(u.shape[0], u.shape[1], 3)


def furnace(ndf, theta_o_deg=(0.0, 30.0, 60.0, 80.0), *, pixels: int = 256, directions: int = 256,
            points=(100.0, 10000.0), seed=0) -> pd.DataFrame:
    """The furnace table of ``ndf`` (docs/math/sampling.md#furnace-tests): one row per quantity and
    outgoing polar angle (degrees), with its value, error and method.

    ``ndf``: a smooth NDF (``gl.ndf("ggx", 0.3)``: cubature) or a glinty NDF (``evaluate(uv, J, h, seed)``
    and ``smooth_ndf``: Monte Carlo over ``pixels`` surface positions per footprint of ``points`` expected
    points (K_P |det J|) and ``directions`` half vectors each, drawn from the smooth NDF; ``error`` is the
    standard error over pixels, ``pixel_spread`` the spread of the per-pixel value)."""
    th = V.as_float_array("theta_o_deg", theta_o_deg).reshape(-1)
    if th.size == 0 or not np.all((th >= 0) & (th < 90)):
        V.fail("theta_o_deg", theta_o_deg, "angles in [0, 90) degrees")
    if isinstance(ndf, NDF):
        return pd.DataFrame(_smooth_rows(ndf, th))
    if not (hasattr(ndf, "evaluate") and isinstance(getattr(ndf, "smooth_ndf", None), NDF)):
        V.fail("ndf", ndf, "gl.ndf(...) or a glinty NDF with evaluate(uv, J, h, seed) and smooth_ndf")
    for pname, value in (("pixels", pixels), ("directions", directions)):
        V.integer(pname, value, minimum=2)
    pts = V.as_float_array("points", points).reshape(-1)
    if pts.size == 0 or not np.all(pts > 0):
        V.fail("points", points, "expected points per footprint, numbers > 0")
    return pd.DataFrame(_glinty_rows(ndf, th, int(pixels), int(directions), pts, seed))
