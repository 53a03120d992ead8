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

# "normal": the normal itself tested against the light; "unnormalised": the lobe without its normalisation
# (KPT25: eq. 4's printed 1D factor; WWH18: the cone's 1 / sigma(gamma) left out). Both are wrong variants.
TESTS = ("mirror", "normal", "unnormalised")
LIT_AS = ("lobe", "normal")  # each glint's lobe integrated over the light, or its normal alone
LOBE_NODES = (8, 12)  # the product rules' rings (radial nodes) x sectors (docs/math/lighting.md#lighting-lobes)
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


def _options(test, lit_as, nodes):
    """The core's GlintLightOptions: ``lit_as`` "lobe" or "normal", ``nodes`` (rings, sectors) of the rules."""
    V.choice("test", test, TESTS)
    V.choice("lit_as", lit_as, LIT_AS)
    if test == "unnormalised" and lit_as != "lobe":
        V.fail("test", test, '"mirror" or "normal" with lit_as="normal" (only a lobe has a normalisation)')
    if not (isinstance(nodes, (tuple, list)) and len(nodes) == 2
            and all(isinstance(n, (int, np.integer)) and 1 <= n <= 256 for n in nodes)):
        V.fail("nodes", nodes, "(rings, sectors): two integers in [1, 256]")
    return _core.GlintLightOptions(lit_as, int(nodes[0]), int(nodes[1]), test != "normal", test == "unnormalised")


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
                      radiance: str = "map", lit_as: str = "lobe", nodes=LOBE_NODES) -> FacetCounts:
    """KPT25's points (realization ``seed``) in DB23's footprint ellipse of each pixel (``uv`` (..., 2),
    ``J`` (..., 4)), each counted with its roulette weight: ``lit_as`` "lobe" (KPT25's model, eq. 4): the
    share of its Gaussian lobe each light or region covers; "normal": the light or region the mirror
    direction of ``wo`` ((3,) or (..., 3)) about its normal T^-1 of its point hits. ``h`` (default: the half
    vector of wo and the light's centre, the normal for a map) selects the MIP levels KPT25 sums there;
    ``test`` "normal" and "unnormalised" are deliberately wrong variants; ``nodes`` (rings, sectors) sizes
    the lobe integral's rules. ``facets``: the weighted points in the ellipse."""
    if not isinstance(ndf, KPT25):
        V.fail("ndf", ndf, "a gl.KPT25")
    ndf._uv_only("light truth")
    options = _options(test, lit_as, nodes)
    uv, J, wo, shape = _arrays(uv, J, wo)
    h = _default_h(wo, light) if h is None else pixel_arrays(uv, J, h)[2]
    hit = light_hit(light, radiance)
    return _counts(_core_call(shape, ndf._core.light_counts, uv.reshape(-1), J.reshape(-1), h.reshape(-1),
                              wo.reshape(-1), V.seed(seed), hit, options), shape)


def wwh18_light_truth(ndf: WWH18, uv, J, wo, light, seed: int = 0, test: str = "mirror",
                      radiance: str = "map", lit_as: str = "lobe", nodes=LOBE_NODES) -> FacetCounts:
    """WWH18's truth flakes (realization ``seed``) in each pixel's footprint parallelogram: ``lit_as``
    "lobe" (WWH18's model, eq. 3-4): the share of the flake's cone of half-angle gamma each light or region
    covers, the cone's density 1 / sigma(gamma); "normal": counted for the light or region the mirror
    direction of ``wo`` about its normal hits. ``test`` "normal" and "unnormalised" are deliberately wrong
    variants. ``facets``: the flakes in the footprint."""
    if not isinstance(ndf, WWH18):
        V.fail("ndf", ndf, "a gl.WWH18")
    options = _options(test, lit_as, nodes)
    uv, J, wo, shape = _arrays(uv, J, wo)
    hit = light_hit(light, radiance)
    return _counts(_core_call(shape, ndf._core.light_counts, uv.reshape(-1), J.reshape(-1), wo.reshape(-1),
                              V.seed(seed), hit, options), shape)


def point_light_density(ndf, uv, J, wo, direction, seed: int = 0) -> np.ndarray:
    """The method's own point-light count per steradian of light at ``direction`` ((3,)), the limit of
    ``lit_as="lobe"`` counts over a light's solid angle as the light shrinks to that direction
    (docs/math/lighting.md#lighting-lobes), per pixel: KPT25: K_P (pi/4) (h.n) / (4 wo.h) times the glinty D
    of the points the truth counts (``footprint_ndf``: same levels, roulette and ellipse); WWH18: the
    truth's count in the cone at h (``reference_counts``) over sigma(gamma), and over 4 (wo.h) for the cone
    of half vectors."""
    uv, J, wo, shape = _arrays(uv, J, wo)
    wi = np.broadcast_to(_view(direction), wo.shape)
    h = wo + wi
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    jac = h[..., 2] / (4 * np.sum(wo * h, axis=-1))
    if isinstance(ndf, KPT25):
        ndf._uv_only("point_light_density")
        d = _core_call(shape, ndf._core.footprint_ndf, uv.reshape(-1), J.reshape(-1), h.reshape(-1), V.seed(seed))
        return points_per_p(ndf) * jac * d.reshape(shape)
    if not isinstance(ndf, WWH18):
        V.fail("ndf", ndf, "a gl.KPT25 or gl.WWH18")
    count = ndf._core.reference_counts(uv.reshape(-1), J.reshape(-1), h.reshape(-1), V.seed(seed),
                                       wi.reshape(-1)).reshape(shape)
    sigma = ndf.cone_solid_angle
    if ndf.cone == "outgoing":
        return count / sigma
    return count / (sigma * 4 * np.sum(wo * h, axis=-1))


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


# The light's rule for WWH18's cone-blurred p: smooth integrand, so Gauss-Legendre converges fast (the
# tests measure its error against a rule twice as fine).
CONE_P_NODES = (24, 48)


def _cone_density(ndf: WWH18, wo, dirs):
    """Per direction of light (rows of ``dirs``, above the horizon): the cone's mass per steradian of light,
    p_gamma(h) / (sigma(gamma) 4 (wo.h)) (cone of half vectors) or the outgoing cone's mass / sigma(gamma),
    beside the unblurred D(h) (h.n) / (4 wo.h); 0 where wo.h <= 0."""
    h = wo + dirs
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    woh = h @ wo
    ok = woh > 0
    h = np.where(ok[:, None], h, [0.0, 0.0, 1.0])
    jac = np.where(ok, 1 / (4 * np.where(ok, woh, 1.0)), 0.0)
    if ndf.cone == "outgoing":
        blurred = ndf.outgoing_cone_mass(dirs, np.broadcast_to(wo, dirs.shape)) / ndf.cone_solid_angle
    else:
        blurred = ndf.cone_mass(h) * jac / ndf.cone_solid_angle
    return np.where(ok, blurred, 0.0), ndf.ndf.D(h[:, 2]) * h[:, 2] * jac


def cone_blurred_p(ndf: WWH18, views, light, nodes=CONE_P_NODES) -> np.ndarray:
    """E[lobe count] / (N |det J|) of WWH18's flakes under ``light`` per view (rows of ``views``; (views,
    channels)): the integral over the light of the cone's mass per steradian of light (:func:`_cone_density`),
    p blurred by the cone, which tends to p as gamma -> 0 (docs/math/lighting.md#lighting-lobes). A Light: the
    lobes' light rule at ``nodes``; a map: the exact p per region plus the blur (blurred less unblurred
    density, smooth on the scale of alpha) integrated over RIM_LOSS_SUBNODES^2 nodes per cell."""
    return _lobe_p(ndf, views, light, _cone_density, nodes)


# Sub-nodes per side of each map cell for KPT25's rim loss under a map (a smooth integrand).
RIM_LOSS_SUBNODES = 2


def _kpt25_lobe_density(ndf: KPT25, wo, dirs):
    """Per direction of light (rows of ``dirs``): E[D*(h)] (h.n) / (4 wo.h) and D(h) (h.n) / (4 wo.h), h the
    half vector of ``wo`` and it: E[D*(h)] = D(h) m_U(T(h)), m_U the mass of the lobe at T(h) inside U (the
    reference's expectation, ``KPT25.expected``)."""
    h = wo + dirs
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    woh = h @ wo
    ok = (woh > 0) & (h[:, 2] > 0) & (dirs[:, 2] > 0)
    h = np.where(ok[:, None], h, [0.0, 0.0, 1.0])
    jac = np.where(ok, h[:, 2] / (4 * np.where(ok, woh, 1.0)), 0.0)
    e_ref = ndf.expected(np.broadcast_to([0.01, 0.0, 0.0, 0.01], (len(h), 4)), h)[0]
    return e_ref * jac, ndf.ndf.D(h[:, 2]) * jac


def _map_nodes(env: EnvMap, k: int):
    """k x k nodes per cell of the map (rows x cols, row 0 at the zenith): directions, solid angles, labels."""
    rows, cols = env.labels.shape
    t = (np.arange(rows * k) + 0.5) * math.pi / (rows * k)
    f = (np.arange(cols * k) + 0.5) * 2 * math.pi / (cols * k)
    T, F = np.meshgrid(t, f, indexing="ij")
    dirs = np.stack([np.sin(T) * np.cos(F), np.sin(T) * np.sin(F), np.cos(T)], -1).reshape(-1, 3)
    omega = (np.sin(T) * (math.pi / (rows * k)) * (2 * math.pi / (cols * k))).reshape(-1)
    labels = np.repeat(np.repeat(env.labels, k, axis=0), k, axis=1).reshape(-1)
    keep = (dirs[:, 2] > 0) & (labels >= 0)  # below the horizon nothing is lit
    return dirs[keep], omega[keep], labels[keep]


def kpt25_lobe_p(ndf: KPT25, views, light) -> np.ndarray:
    """E[lobe count] / (points_per_p |det J|) of KPT25's points under ``light`` per view (rows of
    ``views``; (views, channels)): the integral over the light of E[D*(h)] (h.n) / (4 wo.h), i.e. p with
    D(h) times m_U(T(h)), the share of the lobe at T(h) inside U (KPT25's loss at U's rim; (L8)). A Light:
    the lobes' light rule at CONE_P_NODES; a map: the exact p per region less the rim loss, integrated over
    RIM_LOSS_SUBNODES^2 nodes per cell."""
    return _lobe_p(ndf, views, light, _kpt25_lobe_density, CONE_P_NODES)


def _lobe_p(ndf, views, light, density, nodes) -> np.ndarray:
    """(views, channels): the integral over ``light`` of ``density(ndf, wo, dirs)[0]`` (the lobes' expected
    count per steradian of light) per view. A Light: the lobes' light rule at ``nodes``; a map: the exact p
    per region plus the integral of the lobes' difference from the plain p density (``density``'s second
    value), smooth on the scale of alpha, over RIM_LOSS_SUBNODES^2 nodes per cell."""
    out = []
    if isinstance(light, EnvMap):
        dirs, omega, labels = _map_nodes(light, RIM_LOSS_SUBNODES)
        p = reflection_probability(ndf.target, ndf.alpha, views, light).reshape(len(views), -1)
        for wo, pv in zip(np.asarray(views, dtype=float).reshape(-1, 3), p):
            lobe, plain = density(ndf, wo, dirs)
            out.append(pv + np.bincount(labels, (lobe - plain) * omega, minlength=light.regions))
        return np.array(out)
    dirs, w, _, _, _ = _core.light_nodes(light_hit(light), *nodes)
    for wo in np.asarray(views, dtype=float).reshape(-1, 3):
        out.append([np.sum(w * density(ndf, wo, dirs)[0])])
    return np.array(out)


def expected_light_counts(ndf, J, wo, light, method: str = "exact", rel_tol: float = 1e-6,
                          lit_as: str = "lobe") -> np.ndarray:
    """E[counts] (..., channels) of :func:`kpt25_light_truth` or :func:`wwh18_light_truth` over
    realizations: ``points_per_p(ndf)`` |det J| p(wo, L), p from :func:`reflection_probability` with
    ``method`` ("exact", or "point": the point-light limit (L2)). ``light``: one Light or an EnvMap.
    ``lit_as="lobe"`` (``method`` "exact"): WWH18's p becomes :func:`cone_blurred_p`, KPT25's
    :func:`kpt25_lobe_p` (uniform points under eq. 4's lobes stay uniform in U but at U's rim: (L8))."""
    scale = points_per_p(ndf)
    _, J, _, shape = pixel_arrays(np.zeros(np.shape(J)[:-1] + (2,)), J, None)
    wo = np.broadcast_to(_view(wo), shape + (3,))
    if not isinstance(light, (Light, EnvMap)):
        V.fail("light", light, "one light from gl.lights or an environment map")
    V.choice("lit_as", lit_as, LIT_AS)
    # One cubature per distinct view (a map's regions cost milliseconds each; pixels often share a view).
    views, inverse = np.unique(wo.reshape(-1, 3), axis=0, return_inverse=True)
    if isinstance(ndf, WWH18) and lit_as == "lobe" and method == "exact":
        p = cone_blurred_p(ndf, views, light)
    elif lit_as == "lobe" and method == "exact":
        p = kpt25_lobe_p(ndf, views, light)
    else:
        p = reflection_probability(ndf.target, ndf.alpha, views, light, method=method, rel_tol=rel_tol)
    p = p.reshape(len(views), -1)[inverse.reshape(-1)].reshape(shape + (-1,))
    return scale * footprint_area(J)[..., None] * p
