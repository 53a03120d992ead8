"""Validation of glints under extended lights (docs/math/lighting.md#lighting-validation): the approximate
reflection probabilities against the exact one, the counting laws against the facet truth lit by the same
light, and the multinomial counts per region of an environment map.

Every count test uses whole-cell footprints: a square of s x s cells of the stratified layout, centred so
that its edges run along cell edges, holds exactly M = s^2 facets, so the facet truth's count of one light
is Binomial(M, p) and its counts per region Multinomial(M, p_1, ..., p_k) exactly (facet positions and
normals are independent). One realization of the layout gives one independent count per footprint: the
footprints tile the torus without overlapping.
"""
from __future__ import annotations

import itertools
import math
import time

import numpy as np
import pandas as pd
import scipy.stats

from ..api import light_truths as LT
from ..api import lights as gl_lights
from ..api.glinty_ndf import KPT25
from ..api.laws import law as make_law
from ..api.lighting import facet_truth, multinomial_counts, reflection_probability
from ..api.metrics import chi2_test, distance
from ..api.ndf import ndf
from ..api.spatial import Ellipse, Rect
from ..api.wwh18 import WWH18

APPROXIMATIONS = ("ltc", "cap", "point")
COUNTING_LAWS = ("binomial", "gated", "gated_continuous", "dual_gated")


def _unit(theta, phi=0.0):
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])


def probability_table(targets=("beckmann", "ggx"), alphas=(0.05, 0.2, 0.5), half_angles=(0.01, 0.05, 0.2),
                      elevations_deg=(20.0, 45.0), views_deg=(10.0, 40.0, 70.0), kinds=("cap", "rect")) -> pd.DataFrame:
    """p of each approximation against the exact p for caps (half-angle a) and squares (of the same solid
    angle) at polar angle ``elevation`` (azimuth 180 degrees, the side of the view's mirror direction), seen
    from polar angle ``view`` at azimuth 0: one row per configuration, with the relative errors and the
    exact p's CPU time."""
    rows = []
    for target, alpha, a, el, vw, kind in itertools.product(targets, alphas, half_angles, elevations_deg, views_deg, kinds):
        centre = _unit(math.radians(el), math.pi)
        if kind == "cap":
            light = gl_lights.cap(centre, a)
        else:  # a square facing the shading point with the cap's solid angle, at unit distance
            side = math.sqrt(2 * math.pi * (1 - math.cos(a)))  # the cap's solid angle to first order
            e1 = np.cross(centre, [0.0, 1.0, 0.0])
            e1 /= np.linalg.norm(e1)
            e2 = np.cross(centre, e1)
            light = gl_lights.rect(centre, side * e1, side * e2)
        wo = _unit(math.radians(vw))
        t0 = time.process_time()
        exact, err = reflection_probability(target, alpha, wo, light, "exact", return_error=True)
        cpu = time.process_time() - t0
        row = dict(target=target, alpha=alpha, kind=kind, half_angle=a, solid_angle=light.solid_angle,
                   elevation_deg=el, view_deg=vw, p_exact=float(exact), exact_error=float(err), exact_ms=1e3 * cpu)
        for m in APPROXIMATIONS:
            p = float(reflection_probability(target, alpha, wo, light, m))
            row[f"p_{m}"] = p
            row[f"rel_err_{m}"] = p / exact - 1 if exact > 1e-12 else float("nan")
        rows.append(row)
    return pd.DataFrame(rows)


def where_accurate(table: pd.DataFrame, tolerance: float = 0.05) -> pd.DataFrame:
    """Per approximation, target and light size: the share of configurations (with p_exact > 1e-6) whose
    relative error is within ``tolerance``."""
    t = table[table.p_exact > 1e-6]
    rows = []
    for m in APPROXIMATIONS:
        for (target, kind, a), g in t.groupby(["target", "kind", "half_angle"]):
            e = np.abs(g[f"rel_err_{m}"])
            rows.append(dict(method=m, target=target, kind=kind, half_angle=a, tolerance=tolerance,
                             configurations=len(g), share_within=float(np.mean(e <= tolerance)),
                             median_abs_rel_err=float(np.median(e)), max_abs_rel_err=float(np.max(e))))
    return pd.DataFrame(rows)


def whole_cell_footprints(side: int, cells: int):
    """Footprints of cells x cells whole cells tiling the torus of a layout of side x side cells: (footprints,
    centres, M)."""
    per = side // cells
    fp = Rect(cells / side, cells / side)
    centres = [((cells * i + cells / 2) / side, (cells * j + cells / 2) / side) for i in range(per) for j in range(per)]
    return [fp] * len(centres), centres, cells * cells


def facet_samples(target, alpha, light, wo, side=128, cells=4, realizations=2, seed=0):
    """Counts of the facet truth in whole-cell footprints, pooled over realizations: (counts (samples,
    channels), radiance (samples,), M)."""
    fps, cs, m = whole_cell_footprints(side, cells)
    counts, rad = [], []
    for r in range(realizations):
        t = facet_truth(target, alpha, side * side, fps, cs, wo, light, seed=seed + r)
        counts.append(t.counts)
        rad.append(t.radiance)
    return np.concatenate(counts), np.concatenate(rad), m


def area_light_counts(target="ggx", alpha=0.2, half_angles=(1e-3, 0.02, 0.1, 0.3), view_deg=30.0, side=128, cells=4,
                      realizations=2, seed=0, laws=COUNTING_LAWS) -> pd.DataFrame:
    """Counts under a cap centred on the view's mirror direction, from a point (1e-3 rad) to a large panel:
    the facet truth against Binomial(M, p_exact), and each law at each p against the facet truth (chi-square
    p-value of the facet counts under the law's exact pmf, TV between them, mean and spread of the
    footprint's radiance)."""
    wo = _unit(math.radians(view_deg))
    mirror = wo * np.array([-1.0, -1.0, 1.0])
    rows = []
    for a in half_angles:
        light = gl_lights.cap(mirror, a)
        k, rad, m = facet_samples(target, alpha, light, wo, side, cells, realizations, seed)
        k = k[:, 0]
        for method in ("exact",) + APPROXIMATIONS:
            p = min(float(reflection_probability(target, alpha, wo, light, method)), 1.0)
            for name in laws if method != "exact" else ("binomial",) + tuple(x for x in laws if x != "binomial"):
                d = make_law(name).pmf(m, p)
                rows.append(dict(half_angle=a, solid_angle=light.solid_angle, M=m, method=method, law=name, p=p,
                                 samples=len(k), chi2_pvalue=float(chi2_test(k, d).pvalue), tv=distance(k, d),
                                 facet_mean=float(k.mean()), law_mean=float(d.mean), facet_sd=float(k.std()),
                                 law_sd=math.sqrt(max(d.var, 0.0)), radiance_mean=float(rad.mean()),
                                 radiance_sd=float(rad.std())))
    return pd.DataFrame(rows)


def point_limit_table(target="ggx", alpha=0.2, view_deg=30.0, light_deg=35.0, half_angles=(0.1, 0.03, 0.01, 1e-3, 1e-4)):
    """p_exact / p_point as the cap shrinks (-> 1), and DB23's ratio R that makes today's point-light p =
    R D(h) / D(n) equal to the point p (docs/math/lighting.md#lighting-point)."""
    wo = _unit(math.radians(view_deg))
    centre = _unit(math.radians(light_deg), math.pi)
    nd = ndf(target, alpha)
    h = (wo + centre) / np.linalg.norm(wo + centre)
    rows = []
    for a in half_angles:
        light = gl_lights.cap(centre, a)
        exact = float(reflection_probability(target, alpha, wo, light))
        point = float(reflection_probability(target, alpha, wo, light, "point"))
        r_equiv = nd.D_normal * h[2] * light.solid_angle / (4 * float(wo @ h))
        db23 = float(nd.success_probability(h[2], min(r_equiv, 1.0))[0])
        rows.append(dict(half_angle=a, solid_angle=light.solid_angle, p_exact=exact, p_point=point,
                         ratio=exact / point, R_equivalent=r_equiv, p_db23=db23))
    return pd.DataFrame(rows)


# ---------------------------------------------------------------------------------------------------------
# Environment maps

def multinomial_pmf(m: int, probs) -> dict:
    """The exact joint law of the counts (K_1, ..., K_k) of m facets over k regions of probabilities ``probs``
    (the rest: none), as {tuple: probability}."""
    p = np.asarray(probs, float)
    rest = max(0.0, 1.0 - p.sum())
    out = {}
    for ks in itertools.product(range(m + 1), repeat=len(p)):
        s = sum(ks)
        if s <= m:
            out[ks] = float(np.exp(scipy.stats.multinomial.logpmf(list(ks) + [m - s], m, list(p) + [rest])))
    return out


def joint_chi2(samples, pmf: dict, min_expected: float = 5.0):
    """Pearson's chi-square of joint count samples (n, k) against a joint pmf: cells sorted by probability,
    the smallest pooled until each expects >= min_expected (an outcome outside the pmf's support fails the
    test outright). Returns (statistic, dof, p-value)."""
    n = len(samples)
    keys = sorted(pmf, key=pmf.get, reverse=True)
    index = {k: i for i, k in enumerate(keys)}
    observed = np.zeros(len(keys))
    for row in map(tuple, np.asarray(samples).astype(int)):
        if row not in index:
            return math.inf, 0, 0.0
        observed[index[row]] += 1
    expected = np.array([pmf[k] for k in keys]) * n
    if np.any((expected == 0) & (observed > 0)):  # an outcome the law cannot produce
        return math.inf, 0, 0.0
    cut = len(keys)
    while cut > 1 and expected[cut - 1:].sum() < min_expected:
        cut -= 1
    obs = np.concatenate([observed[:cut - 1], [observed[cut - 1:].sum()]])
    exp = np.concatenate([expected[:cut - 1], [expected[cut - 1:].sum()]])
    small = exp < min_expected
    if small.any():  # pool the remaining small cells into the last
        obs = np.concatenate([obs[~small], [obs[small].sum()]])
        exp = np.concatenate([exp[~small], [exp[small].sum()]])
    stat = float(np.sum((obs - exp) ** 2 / np.where(exp > 0, exp, 1.0)))
    dof = len(obs) - 1
    return stat, dof, float(scipy.stats.chi2.sf(stat, dof)) if dof > 0 else 1.0


def envmap_counts(env=None, target="ggx", alpha=0.3, view_deg=30.0, side=128, cells=3, realizations=2, seed=0,
                  schemes=(("binomial", "chain"), ("dual_gated", "tree"), ("dual_gated", "chain"), ("binomial", "independent"))):
    """Counts per region of an environment map: the facet truth and each sampling scheme against the exact
    multinomial at the exact p (joint chi-square), the facet truth against the multinomial at the filtered
    and unfiltered p, and the radiance: the facet truth with the map's own radiance against the partition's
    constants (the partition's own error)."""
    env = env if env is not None else gl_lights.envmap("sky", regions=3)
    wo = _unit(math.radians(view_deg))
    k_true, rad_true, m = facet_samples(target, alpha, env, wo, side, cells, realizations, seed)
    rows = []
    p_exact = reflection_probability(target, alpha, wo, env)
    for method in ("exact", "filtered", "unfiltered"):
        p = np.clip(reflection_probability(target, alpha, wo, env, method), 0, 1)
        stat, dof, pv = joint_chi2(k_true, multinomial_pmf(m, p))
        rows.append(dict(source="facets", method=method, scheme="", chi2=stat, dof=dof, chi2_pvalue=pv,
                         **{f"p_{r}": p[r] for r in range(env.regions)}))
    pmf = multinomial_pmf(m, p_exact)
    for i, (name, scheme) in enumerate(schemes):
        draws = multinomial_counts(m, p_exact, law=name, scheme=scheme, size=len(k_true), seed=seed + 1000 + i)
        stat, dof, pv = joint_chi2(draws, pmf)
        rows.append(dict(source=name, method="exact", scheme=scheme, chi2=stat, dof=dof, chi2_pvalue=pv,
                         **{f"p_{r}": p_exact[r] for r in range(env.regions)}))
    table = pd.DataFrame(rows)
    const = k_true @ env.region_radiance
    partition = dict(radiance_map_mean=float(rad_true.mean()), radiance_regions_mean=float(const.mean()),
                     expected_map=float(m * np.sum(p_exact * env.region_radiance)),
                     rel_partition_error=float(np.mean(np.abs(const - rad_true)) / max(rad_true.mean(), 1e-300)))
    return table, partition


# ---------------------------------------------------------------------------------------------------------
# Images of a plane under an area light

def plane_pixels(width=64, height=40, camera_height=1.0, tilt_deg=50.0, fov_deg=40.0, texture_scale=0.3):
    """A pinhole camera above the plane z = 0 (the tangent frame), looking down at ``tilt_deg`` from the
    vertical towards +x: per pixel the texture position uv (wrapped to [0, 1)), the uv Jacobian J (du/dx,
    dv/dx, du/dy, dv/dy) by finite differences, and the unit view direction wo. One texture unit spans
    1 / ``texture_scale`` world units."""
    t = math.radians(tilt_deg)
    fwd = np.array([math.sin(t), 0.0, -math.cos(t)])
    right = np.array([0.0, -1.0, 0.0])
    up = np.cross(right, fwd)
    f = 0.5 / math.tan(math.radians(fov_deg) / 2)
    xs = (np.arange(width + 1) - width / 2) / width
    ys = (np.arange(height + 1) - height / 2) / width
    d = fwd[None, None] * f + xs[None, :, None] * right + ys[::-1, None, None] * up
    cam = np.array([0.0, 0.0, camera_height])
    s = -cam[2] / d[..., 2]
    hit = cam + s[..., None] * d
    uv = hit[..., :2] * texture_scale
    J = np.stack([uv[:-1, 1:, 0] - uv[:-1, :-1, 0], uv[:-1, 1:, 1] - uv[:-1, :-1, 1],
                  uv[1:, :-1, 0] - uv[:-1, :-1, 0], uv[1:, :-1, 1] - uv[:-1, :-1, 1]], axis=-1)
    wo = cam - hit[:-1, :-1]
    return np.mod(uv[:-1, :-1], 1.0), J, wo / np.linalg.norm(wo, axis=-1, keepdims=True)


def plane_images(light, target="ggx", alpha=0.2, side=1024, seed=0, width=64, height=40, laws=("binomial", "gated")):
    """The plane under ``light``: the facet truth's count per pixel, and each law's count per pixel drawn at
    n = N |det J| with the exact p and with the point p. Returns ({name: image}, table): the table gives
    each image's mean count against the truth's and the expected n p_exact."""
    uv, J, wo = plane_pixels(width, height)
    fps = [Ellipse.from_uv_derivatives(*j) for j in J.reshape(-1, 4)]
    truth = facet_truth(target, alpha, side * side, fps, [tuple(c) for c in uv.reshape(-1, 2)], wo.reshape(-1, 3),
                        light, seed=seed)
    n = side * side * np.abs(J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2])
    p = {m: np.clip(reflection_probability(target, alpha, wo, light, m), 0, 1) for m in ("exact", "point")}
    images = {"facets": truth.counts[:, 0].reshape(height, width)}
    for name in laws:
        for m, pm in p.items():
            images[f"{name} ({m} p)"] = make_law(name).sample(n, pm, seed=seed + 1).reshape(height, width)
    rows = [dict(image=k, mean_count=float(v.mean()), vs_facets=float(v.mean() / max(images["facets"].mean(), 1e-300)),
                 vs_expected=float(v.mean() / max((n * p["exact"]).mean(), 1e-300)), lit_share=float(np.mean(v > 0)))
            for k, v in images.items()]
    return images, pd.DataFrame(rows)


def own_truth_lights():
    """The lights of :func:`own_truth_table`: (name, light, view), each light off the view's mirror direction
    so that the wrong variant (the normal tested in place of its mirror direction) sees other facets."""
    return [("cap", gl_lights.cap((0.8, 0.0, 1.0), 0.1), (-0.8, 0.0, 1.0)),
            ("rect", gl_lights.rect((0.5, 0.2, 1.0), (0.3, 0.0, 0.0), (0.0, 0.2, 0.0)), (-0.4, -0.1, 1.0)),
            ("disk", gl_lights.disk((-0.3, 0.3, 1.0), (0.3, -0.3, -1.0), 0.1), (0.2, -0.3, 1.0)),
            ("sky", gl_lights.envmap("sky", regions=3), (0.5, 0.0, 1.0))]


def own_truth_table(seed: int = 0, pixels: int = 128, footprint: float = 0.02, density: float = 1e6,
                    z_max: float = 4.5) -> pd.DataFrame:
    """KPT25's points and WWH18's flakes lit by each light of :func:`own_truth_lights`, each glint's lobe
    integrated over the light (``lit_as`` "lobe"; docs/math/lighting.md#lighting-own-truths, #lighting-lobes):
    the counts pooled
    over ``pixels`` disjoint square footprints of side ``footprint`` in one realization against their
    expectation (:func:`glintlab.api.light_truths.expected_light_counts`) as a z (Poisson spread; for the
    map a chi-square over the regions on the same scale, :func:`_own_z`), beside the same check of the wrong
    variants: the normal tested in place of its mirror direction, the light's solid angle left out of p, and
    the lobe without its normalisation."""
    side = math.ceil(math.sqrt(pixels))
    k = np.arange(pixels)
    uv = np.stack([(k % side + 0.5) / side, (k // side + 0.5) / side], -1)
    J = np.broadcast_to([footprint, 0.0, 0.0, footprint], (pixels, 4))
    methods = [("kpt25", KPT25(density=density, alpha=0.3), LT.kpt25_light_truth),
               ("wwh18", WWH18(density=density, alpha=0.3, dpf="exact"), LT.wwh18_light_truth)]
    rows = []
    for (name, light, wo), (method, nd, truth) in itertools.product(own_truth_lights(), methods):
        is_map = isinstance(light, gl_lights.EnvMap)
        lit_as = "lobe"
        expected = LT.expected_light_counts(nd, J, wo, light, lit_as=lit_as).sum(axis=0)

        def z_of(test, expected=expected, truth=truth, nd=nd, light=light, wo=wo, lit_as=lit_as):
            counts = truth(nd, uv, J, wo, light, seed=seed, test=test, lit_as=lit_as).counts.sum(axis=0)
            return _own_z(counts, expected), counts

        z, counts = z_of("mirror")
        z_normal = z_of("normal")[0]
        z_omega = z_unnorm = float("nan")  # a map's regions have no one solid angle to leave out
        if not is_map:
            no_omega = LT.expected_light_counts(nd, J, wo, light, method="point").sum(axis=0) / light.solid_angle
            z_omega = _own_z(counts, no_omega)
        if lit_as == "lobe":
            z_unnorm = z_of("unnormalised")[0]
        rows.append({"method": method, "light": name, "lit_as": lit_as, "expected": float(expected.sum()),
                     "count": float(counts.sum()), "z": z, "z_normal_variant": z_normal, "z_no_solid_angle": z_omega,
                     "z_unnormalised": z_unnorm,
                     "pass": abs(z) < z_max and abs(z_normal) > z_max and not abs(z_omega) <= z_max
                     and not abs(z_unnorm) <= z_max})
    return pd.DataFrame(rows)


def _own_z(counts, expected):
    """One light: (count - E) / sqrt(E). Several regions: Pearson's chi-square over them on the normal scale
    by Wilson and Hilferty's cube root (finite where its tail probability underflows; above 4.5 it rejects
    at about the upper-tail rate of one light's z)."""
    if counts.size == 1:
        return float((counts[0] - expected[0]) / math.sqrt(expected[0]))
    chi2, k = float(np.sum((counts - expected) ** 2 / expected)), counts.size
    return float(((chi2 / k) ** (1 / 3) - (1 - 2 / (9 * k))) / math.sqrt(2 / (9 * k)))
