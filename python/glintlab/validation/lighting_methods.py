"""The registered image methods under a distant extended light (docs/math/lighting.md#lighting-methods): any
image method that returns an NDF (``gl.image_methods("ndf")``: DB23's grids, ZK16, KPT25, WWH18, a user's)
rendered as an engine renders a glinty NDF under an area light it has no closed form for, by deterministic
stratified quadrature of the light integral over the light's directions,

    value(pixel) = L sum_s w_s D_glint(h_s) (h_s . n) / (4 (wo . h_s)),   h_s = normalize(wo + l_s),

l_s the light's S sample directions and w_s their solid angles (sum w_s = the light's solid angle; under an
environment map, the map's cells pooled in blocks, each sample weighted by its region's radiance). For the
smooth D this is L times the exact p of docs/math/lighting.md#lighting-probability (L1), the facet truth's and
the counting laws' scale (radiance x K / n), so a method's value is compared with the facets lit by the same
light (:func:`method_light_path`, tabled by ``lighting_images.light_table``).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..api import checks as V
from ..api import lights as gl_lights
from ..api.glinty_ndf import SmoothNDF
from ..api.lighting import reflection_probability
from ..api.method_registry import IMAGE_METHODS, image_methods, make_method
from .lighting_images import SceneLight, light_path, plane_material

#: Light samples per pixel by default: an 8 x 8 stratified grid (docs/math/lighting.md#lighting-methods: the
#: smooth NDF's relative error against the exact p is below 1e-3 on the report's paths).
SAMPLES = 64
#: The deliberately wrong variants the tests reject: the half vector's Jacobian 1 / (4 wo.h) left out, or
#: the light's solid angle left out (the weights 1 / S: the mean p density taken as a probability).
WRONG_VARIANTS = ("no_jacobian", "no_solid_angle")
#: An environment map's cells pooled per sample by default: blocks of 8 x 8 cells, one sample per region present
#: in a block (docs/math/lighting.md#lighting-methods: 112 samples for the shipped 64 x 128 sky in 3 regions,
#: its sun and window at their own cells).
MAP_BLOCK = 8
#: Evaluations per call of a method's ``evaluate`` (pixels x samples are batched up to this many).
BATCH = 1 << 20


def _grid_side(samples) -> int:
    s = V.integer("samples", samples, minimum=1)
    k = math.isqrt(s)
    if k * k != s:
        V.fail("samples", samples, "a perfect square (a k x k stratified grid over the light)")
    return k


def light_samples(light: gl_lights.Light, samples: int = SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """(directions (S, 3), solid angles (S,)): the midpoints of a k x k stratified grid over ``light``
    (``samples`` = k^2). A cap: k rings of equal width in cos(rho) about its axis by k sectors in azimuth
    (cells of equal solid angle, Omega / S each). A rectangle: the midpoints of its k x k sub-rectangles,
    each weighted by the solid angle it subtends there (|e_u x e_v| |N . x| / |x|^3 / S), rescaled so that
    the weights sum to the exact solid angle. Directions at or below the horizon keep their weight; the
    integrand is 0 there."""
    k = _grid_side(samples)
    mid = (np.arange(k) + 0.5) / k
    if not isinstance(light, gl_lights.Light) or light.kind not in ("cap", "rect"):
        V.fail("light", light, "a cap or a rectangle from gl.lights")
    if light.kind == "cap":
        a = light.params["half_angle"]
        c = light.center
        e1 = np.cross(c, [1.0, 0.0, 0.0] if abs(c[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(c, e1)
        cos_rho = 1.0 - mid * (1.0 - math.cos(a))
        sin_rho = np.sqrt(np.maximum(0.0, 1.0 - cos_rho ** 2))
        psi = 2 * math.pi * mid
        ring = cos_rho[:, None, None] * c + sin_rho[:, None, None] * (np.cos(psi)[None, :, None] * e1
                                                                      + np.sin(psi)[None, :, None] * e2)
        dirs = ring.reshape(-1, 3)
        return dirs / np.linalg.norm(dirs, axis=1, keepdims=True), np.full(k * k, light.solid_angle / (k * k))
    c, eu, ev = (np.asarray(light.params[x], float) for x in ("center", "edge_u", "edge_v"))
    normal = np.cross(eu, ev)
    x = c + (mid[:, None, None] - 0.5) * eu + (mid[None, :, None] - 0.5) * ev
    x = x.reshape(-1, 3)
    r = np.linalg.norm(x, axis=1)
    w = np.abs(x @ normal) / r ** 3
    return x / r[:, None], w * (light.solid_angle / w.sum())


def map_samples(env: gl_lights.EnvMap, block: int = MAP_BLOCK) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(directions (S, 3), solid angles (S,), regions (S,)): the map's cells above the horizon pooled in blocks
    of ``block`` x ``block`` cells, one sample per (block, region) pair present: the direction of the
    solid-angle-weighted mean of the region's cells in the block (normalised), weighted by their total solid
    angle. A region of fewer than ``block``^2 cells (a sun, a window: small and bright) keeps its own cells,
    each at its centre; ``block`` 1 is the map's own cells."""
    if not isinstance(env, gl_lights.EnvMap):
        V.fail("env", env, "an environment map from gl.lights.envmap")
    b = V.integer("block", block, minimum=1)
    rows, cols = env.shape
    cell = (np.arange(rows) // b)[:, None] * (-(-cols // b)) + (np.arange(cols) // b)[None, :]
    small = np.bincount(env.labels[env.labels >= 0], minlength=env.regions) < b * b
    own = np.arange(rows * cols).reshape(rows, cols) + cell.max() + 1  # a cell of its own: a key of its own
    cell = np.where(small[np.maximum(env.labels, 0)], own, cell)
    keep = env.labels >= 0
    dirs, w = gl_lights.directions(rows, cols)[keep], env.solid_angles[keep]
    key, inv = np.unique(cell[keep] * env.regions + env.labels[keep], return_inverse=True)
    weights = np.bincount(inv, weights=w)
    mean = np.stack([np.bincount(inv, weights=w * dirs[:, i]) for i in range(3)], axis=1)
    return mean / np.linalg.norm(mean, axis=1, keepdims=True), weights, key % env.regions


def light_integral(method, uv, J, wo, directions, weights, seed: int = 0, wrong: str | None = None) -> np.ndarray:
    """sum_s w_s D(h_s) (h_s . n) / (4 (wo . h_s)) per pixel: ``method`` (a glinty NDF: ``evaluate(uv, J, h,
    seed)``) at the half vectors of the views ``wo`` (m, 3, unit, tangent frame) and the light's sample
    ``directions`` (S, 3), or per pixel (m, S, 3) (a curved surface: each pixel's frame), of solid angles
    ``weights`` (S,); 0 for a direction at or below the pixel's horizon or a
    facet facing away. Pixels x samples are evaluated in batches of up to ``BATCH``. ``wrong``: one of
    ``WRONG_VARIANTS`` (the tests' deliberately wrong variants)."""
    if wrong is not None:
        V.choice("wrong", wrong, WRONG_VARIANTS)
    dirs, w = np.asarray(directions, float), np.asarray(weights, float)
    m, s = len(wo), dirs.shape[-2]
    if dirs.ndim == 3 and dirs.shape[0] != m:
        V.fail("directions", f"an array of shape {dirs.shape}", f"(S, 3) or one row of samples per view, ({m}, S, 3)")
    if wrong == "no_solid_angle":
        w = np.full(s, 1.0 / s)
    out = np.zeros(m)
    step = max(1, BATCH // max(s, 1))
    for lo in range(0, m, step):
        sl = slice(lo, min(m, lo + step))
        d_sl = dirs[None] if dirs.ndim == 2 else dirs[sl]
        h = wo[sl, None, :] + d_sl
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        woh = np.einsum("msk,mk->ms", h, wo[sl])
        n = h.shape[0]
        d = method.evaluate(np.repeat(uv[sl], s, axis=0), np.repeat(J[sl], s, axis=0), h.reshape(-1, 3),
                            seed=seed).reshape(n, s)
        jac = 1.0 if wrong == "no_jacobian" else 1.0 / (4.0 * np.where(woh > 0, woh, 1.0))
        visible = (d_sl[..., 2] > 0) & (woh > 0) & (h[..., 2] > 0)
        out[sl] = np.where(visible, d * h[..., 2] * jac, 0.0) @ w
    return out


def _render(method, samples, block, wrong, light, wo, uv, J, seed, frames=None):
    """A light_path renderer: the light integral of ``method`` times the radiance (a map: each sample's
    region's constant radiance, as the counting methods take it). ``frames`` (m, 3, 3): each pixel's tangent
    frame (rows t, b, n in world space) on a curved surface, ``light`` then in world space: its sample
    directions are seen in each pixel's frame (the same world samples, so the quadrature is the plane's)."""
    if isinstance(light, gl_lights.EnvMap):
        dirs, w, region = map_samples(light, block)
        w = w * light.region_radiance[region]
    else:
        dirs, w = light_samples(light, samples)
        w = light.radiance * w
    if frames is not None:
        dirs = np.einsum("kij,sj->ksi", np.asarray(frames, float), dirs)
    return light_integral(method, uv, J, wo, dirs, w, seed, wrong)


def light_methods() -> list[str]:
    """The registered image methods this path renders by default: every NDF method (``returns`` "ndf")
    except the facet ground truth itself (the facets lit by the light are the path's truth)."""
    return [n for n in image_methods("ndf") if not IMAGE_METHODS.get(n).is_truth]


def _check_methods(methods) -> list[str]:
    names = light_methods() if methods is None else list(methods)
    for name in names:
        if name not in IMAGE_METHODS.names():
            V.fail("methods", name, f"registered image methods, one of {', '.join(image_methods('ndf'))}")
        if IMAGE_METHODS.get(name).returns != "ndf":
            V.fail("methods", name, "image methods returning an NDF (an intensity method, such as WB16's shader, "
                   "has no value at a half vector to integrate over the light)")
    return names


def method_renderers(material, methods=None, samples: int = SAMPLES, wrong: str | None = None,
                     block: int = MAP_BLOCK) -> dict:
    """{label: renderer for ``lighting_images.light_path(..., renderers=)``}: each registered NDF image method
    of ``methods`` (default :func:`light_methods`) for ``material``, at its registered density, through the
    light integral at ``samples`` directions of a cap or a rectangle, or an environment map's cells pooled in
    blocks of ``block`` (labels: the registry's, with " (wrong: ...)" for a variant)."""
    _grid_side(samples)
    V.integer("block", block, minimum=1)
    if wrong is not None:
        V.choice("wrong", wrong, WRONG_VARIANTS)
    suffix = f" (wrong: {wrong})" if wrong else ""
    return {IMAGE_METHODS.get(n).label + suffix: functools.partial(_render, make_method(n, material), samples, block, wrong)
            for n in _check_methods(methods)}


def method_light_path(scene, light, methods=None, samples: int = SAMPLES, wrong: str | None = None,
                      block: int = MAP_BLOCK, **kw):
    """``lighting_images.light_path`` of ``scene`` under ``light`` (a :class:`SceneLight` or an environment map:
    on a plane in its tangent frame, on a curved surface in world space, seen in each pixel's frame) with the
    registered NDF image methods ``methods`` rendered beside the facets and the counting laws
    (:func:`method_renderers`; keyword arguments: light_path's)."""
    if not isinstance(light, (SceneLight, gl_lights.EnvMap)):
        V.fail("light", light, "a SceneLight (scene_light) or an environment map")
    mat, _ = plane_material(scene)
    renderers = {**kw.pop("renderers", {}), **method_renderers(mat, methods, samples, wrong, block)}
    return light_path(scene, light, renderers=renderers, **kw)


def quadrature_error(target: str, alpha: float, light, wo, samples: int = SAMPLES, block: int = MAP_BLOCK) -> dict:
    """The quadrature's error: the smooth NDF through :func:`light_integral` at ``samples`` directions of a
    cap or a rectangle (a map: its cells pooled in blocks of ``block``, p per region) against the exact p by
    cubature (``reflection_probability``), over the views ``wo`` (m, 3): the largest and the mean relative
    error where p > 1e-3 of the largest p (a map's: of its region), the p-weighted mean relative error and,
    for a map, the largest relative error of the value sum_r L_r p_r."""
    wo = np.asarray(wo, float)
    wo = wo / np.linalg.norm(wo, axis=1, keepdims=True)
    exact = reflection_probability(target, alpha, wo, light, "exact")
    smooth, uv, J = SmoothNDF(target, alpha), np.zeros((len(wo), 2)), np.tile([1.0, 0, 0, 1.0], (len(wo), 1))
    if isinstance(light, gl_lights.EnvMap):
        dirs, w, region = map_samples(light, block)
        quad = np.column_stack([light_integral(smooth, uv, J, wo, dirs, w * (region == r)) for r in range(light.regions)])
        samples = len(dirs)
    else:
        quad = light_integral(smooth, uv, J, wo, *light_samples(light, samples))
    big = exact > 1e-3 * exact.max(axis=0)
    rel = np.abs(quad[big] / exact[big] - 1)
    out = {"samples": int(samples), "values": int(big.sum()), "max_rel_error": float(rel.max()),
           "mean_rel_error": float(rel.mean()),
           "weighted_rel_error": float(np.abs(quad - exact).sum() / exact.sum())}
    if isinstance(light, gl_lights.EnvMap):  # the pixel's value: the regions' p weighted by their radiance
        value, value_exact = quad @ light.region_radiance, exact @ light.region_radiance
        out["max_value_rel_error"] = float(np.max(np.abs(value / value_exact - 1)))
    return out
