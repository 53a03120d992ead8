"""The methods' own truths under an extended light (docs/math/lighting.md#lighting-own-truths): KPT25's point
process and WWH18's flakes lit by a cap, a rectangle, a disk or an environment map's regions, as the facet
truth of :func:`glintlab.api.lighting.facet_truth` is. Each point or flake is a facet: it reflects a light
when its mirror direction of the view hits it (the core's one test, ``LightHit``), and adds the radiance
there, so the counts per light or region are exact for a realization.

Their expectations over realizations come from the method's own distribution of normals: WWH18's flakes
are drawn from D(m)(m.n), so E[count] = N |det J| p(wo, L); KPT25's points are uniform on the disk U of
area pi/4, which T maps to D(h)(h.n), so E[count] = K_P |det J| (pi/4) p(wo, L) (the two levels' roulette
keep rates add to 1), with p(wo, L) the exact reflection probability (L1) of the light.

>>> import glintlab as gl
>>> from glintlab.api import light_truths as lt
>>> nd = gl.WWH18(density=1e5, alpha=0.3)
>>> sun = gl.lights.cap((0.3, 0.0, 1.0), 0.2)
>>> t = lt.wwh18_light_truth(nd, [[0.5, 0.5]], [[0.05, 0, 0, 0.05]], (-0.3, 0.0, 1.0), sun, seed=1)
>>> t.counts.shape, bool(t.radiance[0] == t.counts[0, 0])
((1, 1), True)
"""
from __future__ import annotations

import math

import numpy as np

from .. import _core
from . import checks as V
from .glinty_ndf import KPT25, _core_call, footprint_area, pixel_arrays
from .lighting import FacetCounts, _view, reflection_probability
from .lights import EnvMap, Light
from .wwh18 import WWH18

TESTS = ("mirror", "normal")  # "normal": the normal itself tested against the light (the wrong variant)
# E[count] / (density x footprint area x p): points per unit footprint area per unit of p.
KPT25_POINTS_PER_P = math.pi / 4  # the area of the disk U, whose points T maps to D(h)(h.n)


def _lights(light):
    if isinstance(light, EnvMap):
        return None
    lights = [light] if isinstance(light, Light) else list(light) if isinstance(light, (list, tuple)) else []
    if not lights or not all(isinstance(x, Light) for x in lights):
        V.fail("light", light, "a light from gl.lights, a list of them, or an environment map")
    return lights


def light_hit(light, radiance: str = "map"):
    """The core's test of which light (the first that contains the mirror direction) or region of a map
    a facet reflects (``radiance``: a map's own values, "map", or its regions' constants, "regions")."""
    lights = _lights(light)
    if lights is None:
        V.choice("radiance", radiance, ("map", "regions"))
        return _core.LightHit(*light.core_args(radiance))
    return _core.LightHit([x._core for x in lights], [x.radiance for x in lights])


def _arrays(uv, J, wo):
    uv, J, _, shape = pixel_arrays(uv, J, None)
    wo = np.ascontiguousarray(np.broadcast_to(_view(wo), shape + (3,)))
    return uv, J, wo, shape


def _counts(result, shape):
    c, r, f = result
    return FacetCounts(c.reshape(shape + (c.shape[-1],)), r.reshape(shape), f.reshape(shape))


def _default_h(wo, light):
    """The half vector of the view and the (first) light's centre; the normal for a map."""
    lights = _lights(light)
    if lights is None:
        return np.broadcast_to([0.0, 0.0, 1.0], wo.shape).copy()
    s = wo + lights[0].center
    return s / np.linalg.norm(s, axis=-1, keepdims=True)


def kpt25_light_truth(ndf: KPT25, uv, J, wo, light, seed: int = 0, h=None, test: str = "mirror",
                      radiance: str = "map") -> FacetCounts:
    """KPT25's points (realization ``seed``) in DB23's footprint ellipse of each pixel (``uv`` (..., 2),
    ``J`` (..., 4)), each a facet of normal T^-1 of its point, counted with its roulette weight for the
    light or region its mirror direction of ``wo`` ((3,) or (..., 3)) hits. ``h`` (default: the half
    vector of wo and the light's centre, the normal for a map) selects the MIP levels KPT25 sums there;
    ``test`` "normal" is the deliberately wrong variant. ``facets``: the weighted points in the ellipse."""
    if not isinstance(ndf, KPT25):
        V.fail("ndf", ndf, "a gl.KPT25")
    ndf._uv_only("light truth")
    V.choice("test", test, TESTS)
    uv, J, wo, shape = _arrays(uv, J, wo)
    h = _default_h(wo, light) if h is None else pixel_arrays(uv, J, h)[2]
    hit = light_hit(light, radiance)
    return _counts(_core_call(shape, ndf._core.light_counts, uv.reshape(-1), J.reshape(-1), h.reshape(-1),
                              wo.reshape(-1), V.seed(seed), hit, test == "mirror"), shape)


def wwh18_light_truth(ndf: WWH18, uv, J, wo, light, seed: int = 0, test: str = "mirror",
                      radiance: str = "map") -> FacetCounts:
    """WWH18's truth flakes (realization ``seed``) in each pixel's footprint parallelogram, counted for
    the light or region their mirror direction of ``wo`` hits; ``test`` "normal" is the deliberately
    wrong variant. ``facets``: the flakes in the footprint."""
    if not isinstance(ndf, WWH18):
        V.fail("ndf", ndf, "a gl.WWH18")
    V.choice("test", test, TESTS)
    uv, J, wo, shape = _arrays(uv, J, wo)
    hit = light_hit(light, radiance)
    return _counts(_core_call(shape, ndf._core.light_counts, uv.reshape(-1), J.reshape(-1), wo.reshape(-1),
                              V.seed(seed), hit, test == "mirror"), shape)


def points_per_p(ndf) -> float:
    """E[count] / (|det J| p): the density of the method's facets times the share of them p stands for."""
    if isinstance(ndf, WWH18):
        return ndf.density
    if not isinstance(ndf, KPT25):
        V.fail("ndf", ndf, "a gl.KPT25 or gl.WWH18")
    if ndf.mapping != "uv" or ndf.alpha_y != ndf.alpha or ndf.ggx_map != "orthographic" or ndf.anisotropy != (1, 1):
        V.fail("ndf", ndf, "an isotropic uv-mapped KPT25 with the orthographic map (whose points T maps to "
               "D(h)(h.n))")
    return ndf.density * KPT25_POINTS_PER_P


def expected_light_counts(ndf, J, wo, light, method: str = "exact", rel_tol: float = 1e-6) -> np.ndarray:
    """E[counts] (..., channels) of :func:`kpt25_light_truth` or :func:`wwh18_light_truth` over
    realizations: ``points_per_p(ndf)`` |det J| p(wo, L), p from :func:`reflection_probability` with
    ``method`` ("exact", or "point": the point-light limit (L2)). ``light``: one Light or an EnvMap."""
    scale = points_per_p(ndf)
    _, J, _, shape = pixel_arrays(np.zeros(np.shape(J)[:-1] + (2,)), J, None)
    wo = np.broadcast_to(_view(wo), shape + (3,))
    if not isinstance(light, (Light, EnvMap)):
        V.fail("light", light, "one light from gl.lights or an environment map")
    # One cubature per distinct view (a map's regions cost milliseconds each; pixels often share a view).
    views, inverse = np.unique(wo.reshape(-1, 3), axis=0, return_inverse=True)
    p = reflection_probability(ndf.target, ndf.alpha, views, light, method=method, rel_tol=rel_tol)
    p = p.reshape(len(views), -1)[inverse.reshape(-1)].reshape(shape + (-1,))
    return scale * footprint_area(J)[..., None] * p
