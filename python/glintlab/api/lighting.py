"""Glints under extended lights (docs/math/lighting.md): the probability that a facet reflects a light,
exact and approximated, the facet truth lit by the same lights, and counts per region of an environment
map drawn as a multinomial.

``reflection_probability(target, alpha, wo, light, method)``: p, the probability that a facet normal drawn
from D(m)(m.n) mirrors the view wo into the light (docs/math/lighting.md#lighting-probability):

- ``"exact"``: adaptive cubature (C++, ``rel_tol`` 1e-6 by default);
- ``"ltc"``: a linearly transformed cosine fitted to the target NDF and alpha (KK24's large-light
  approximation; ``ltc_fit`` "values", Heitz et al.'s fit of the values, or "ml", the likelihood fit;
  docs/math/lighting.md#lighting-ltc);
- ``"cap"``: the NDF held at the half vector of the light's centre, the half-vector region's solid
  angle exact (KK24's locally constant approximation; docs/math/lighting.md#lighting-cap);
- ``"point"``: the point light's p density at the light's centre times the light's solid angle.

For an environment map the result is one p per region: ``"exact"`` (cubature over each region's
cells), ``"filtered"`` (KK25's NDF-filtered indicator maps), ``"unfiltered"`` (the indicator looked up
at the mirror direction: the deliberately wrong variant).

>>> import glintlab as gl
>>> light = gl.lights.cap((0.3, 0.0, 1.0), 0.1)
>>> p = gl.reflection_probability("ggx", 0.2, (-0.3, 0.0, 1.0), light)
"""
from __future__ import annotations

import functools
import math

import numpy as np
import scipy.interpolate
import scipy.optimize

from .. import _core
from . import checks as V
from .laws import law as make_law
from .lights import EnvMap, Light, directions
from .ndf import NDFS
from .ndf import ndf as smooth_ndf

METHODS = ("exact", "ltc", "cap", "point")
MAP_METHODS = ("exact", "filtered", "unfiltered")


def _view(wo):
    w = V.as_float_array("wo", wo)
    if w.shape[-1:] != (3,) or not np.all(np.isfinite(w)):
        V.fail("wo", f"an array of shape {w.shape}", "finite view directions (..., 3)")
    n = np.linalg.norm(w, axis=-1, keepdims=True)
    if np.any(w[..., 2] <= 0) or np.any(n == 0):
        V.fail("wo", "a view at or below the horizon", "views above the horizon (wo_z > 0)")
    return w / n


def _target(target, alpha):
    V.choice("target", target, NDFS)
    return smooth_ndf(target, alpha)


def density(target, alpha, wo, wi) -> np.ndarray:
    """The p density per unit solid angle of light directions, D(h)(h.n) / (4 (wo.h)) (0 below the horizon):
    the point light's p at wi is this times the light's solid angle."""
    return _density(_target(target, alpha), _view(wo), V.unit_vectors(V.as_float_array("wi", wi)))


def _density(nd, wo, wi):
    """density() without the argument checks (the LTC fit's inner loop)."""
    s = wo + wi
    h = s / np.linalg.norm(s, axis=-1, keepdims=True)
    c, woh = h[..., 2], np.sum(wo * h, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = nd.D(c) * c / (4.0 * woh)
    return np.where((wi[..., 2] > 0) & (woh > 0), out, 0.0)


def _frames(frames, count: int):
    """The tangent frames (count, 3, 3) (rows t, b, n in the lights' coordinates) as the core's flat list,
    or [] for none."""
    if frames is None:
        return []
    f = V.as_float_array("frames", frames)
    if f.shape[-2:] != (3, 3) or f.size != 9 * count or not np.all(np.isfinite(f)):
        V.fail("frames", f"an array of shape {f.shape}", f"{count} finite frames (..., 3, 3) shaped like the views")
    return np.ascontiguousarray(f.reshape(-1)).tolist()


def reflection_probability(target, alpha, wo, light, method: str = "exact", rel_tol: float = 1e-6,
                           return_error: bool = False, frames=None, ltc_fit: str = "values"):
    """p for each view ``wo`` (3,) or (..., 3) and a light from ``gl.lights`` (see the module docs).
    An environment map gives one p per region (last axis). ``return_error`` (exact only) also returns the
    cubature's error estimate. ``frames`` (..., 3, 3), one per view (an analytic light: methods "exact" and
    "point"; a map: all three): each view's tangent frame (rows t, b, n) in the light's (world) coordinates,
    the view in that frame and the light seen from it, cut at its horizon (a curved surface under one distant
    light, docs/math/lighting.md#lighting-scene-images); a map's "filtered" and "unfiltered" look up the world
    mirror direction (KK25's maps know no horizon but the map's). ``ltc_fit``: the LTC's fit (LTC_FITS, see
    ltc_table)."""
    nd = _target(target, alpha)
    wo = _view(wo)
    if frames is not None and not isinstance(light, EnvMap) and method not in ("exact", "point"):
        V.fail("frames", "per-view frames", 'method "exact" or "point" for an analytic light (or frames=None)')
    if isinstance(light, EnvMap):
        V.choice("method", method, MAP_METHODS)
        return _map_probability(nd, wo, light, method, rel_tol, return_error, frames)
    if not isinstance(light, Light):
        V.fail("light", light, "a light from gl.lights (cap, rect, disk, envmap)")
    V.choice("method", method, METHODS)
    flat = wo.reshape(-1, 3)
    frame_list = _frames(frames, len(flat))
    if method == "exact":
        rel = V.real("rel_tol", rel_tol)
        views = np.ascontiguousarray(flat).reshape(-1)
        values, errors = _core.reflection_probabilities(target, nd.alpha, views, light._core, rel, frame_list)
        values, errors = values.reshape(wo.shape[:-1]), errors.reshape(wo.shape[:-1])
        return (values, errors) if return_error else values
    if method == "point":
        centre = np.broadcast_to(light.center, flat.shape)
        if frames is not None:  # the light's centre in each view's frame: (t.c, b.c, n.c)
            centre = np.asarray(frames, float).reshape(-1, 3, 3) @ light.center
        out = density(target, nd.alpha, flat, centre) * light.solid_angle
    elif method == "cap":
        h = flat + light.center
        h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        omega_h = np.array([_core.half_vector_solid_angle(tuple(w), light._core)[0] for w in flat])
        out = nd.D(h[:, 2]) * h[:, 2] * omega_h
    else:
        out = np.array([ltc_probability(target, nd.alpha, w, light, ltc_fit) for w in flat])
    return out.reshape(wo.shape[:-1])


INTERPOLATIONS = ("chebyshev", "spline")


def _chebyshev_nodes(lo, hi, n):
    """The n Chebyshev points of the second kind (extrema, ends included) on [lo, hi], largest first: those of
    2n - 1 (the intervals doubled) hold them at their even indices, so a refinement reuses every node."""
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * np.cos(math.pi * np.arange(n) / (n - 1))


def _barycentric_weights(nodes, x):
    """(len(x), n) weights of the barycentric formula of the polynomial through Chebyshev points of the
    second kind (weights (-1)^j, halved at the ends): p(x) = weights @ values; exact at the nodes."""
    n = len(nodes)
    w = (-1.0) ** np.arange(n)
    w[0] *= 0.5
    w[-1] *= 0.5
    d = x[:, None] - nodes[None, :]
    hit = d == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = w / d
    t = np.where(hit.any(axis=1, keepdims=True), hit.astype(float), t)
    return t / t.sum(axis=1, keepdims=True)


class ProbabilityGrid:
    """The exact p of many views at the cost of a grid of them (docs/math/lighting.md#lighting-grid): the exact
    p (cubature at ``rel_tol``) at the nodes of a grid spanning ``views``, interpolated (one interpolant per
    region of a map). The grid's coordinates are the views' tangent components (x, y) when their box lies
    inside the unit disk (views around the normal), else their polar and azimuthal angles (a view box away
    from the normal, azimuths within half a turn). ``interpolation`` "chebyshev": the tensor polynomial
    through ``nodes`` x ``nodes`` Chebyshev points (spectral accuracy for a p analytic in the view);
    "spline": bicubic splines through a uniform grid. ``tolerance`` (Chebyshev): double the intervals (n -> 2n - 1
    nodes, nested, up to ``max_nodes``) until the interpolant's largest relative error at the next grid's new
    nodes, where p exceeds 1e-3 of its largest value, is below it (``refinement_error``: that of the grid one
    doubling coarser than the one kept, so an over-estimate for it; ``converged`` False when ``max_nodes``
    stopped the doubling first). Its error at the views is what :meth:`error` measures against the cubature."""

    def __init__(self, target, alpha, light, views, nodes: int = 17, rel_tol: float = 1e-6,
                 interpolation: str = "chebyshev", tolerance: float | None = None, max_nodes: int = 129):
        nd = _target(target, alpha)
        self.target, self.alpha, self.light, self.rel_tol = target, nd.alpha, light, V.real("rel_tol", rel_tol)
        self.nodes = V.integer("nodes", nodes, minimum=4, maximum=1024)
        self.interpolation = V.choice("interpolation", interpolation, INTERPOLATIONS)
        self.regions = light.regions if isinstance(light, EnvMap) else None
        self._box(_view(views).reshape(-1, 3))
        if self.interpolation == "spline":
            self.axes = [np.linspace(self.lo[i], self.hi[i], self.nodes) for i in (0, 1)]
            values = self._exact_at(*self.axes)
            self.splines = [scipy.interpolate.RectBivariateSpline(*self.axes, values[..., r]) for r in range(values.shape[2])]
            self.refinement_error = self.converged = None
            return
        self._chebyshev(tolerance, V.integer("max_nodes", max_nodes, minimum=self.nodes, maximum=1024))

    def _box(self, wo):
        if wo.shape[0] == 0 or np.any(wo[:, 2] <= 0):
            V.fail("views", f"{wo.shape[0]} views", "at least one view, all above the horizon (z > 0)")
        xy = wo[:, :2]
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        self.polar = bool(np.hypot(*np.maximum(np.abs(lo), np.abs(hi))) >= 0.999)
        self.phi0 = 0.0
        if self.polar:
            self.phi0 = float(np.angle(np.mean(np.exp(1j * self._angles(wo, None)[:, 1]))))
            ang = self._angles(wo, self.phi0)
            lo, hi = ang.min(axis=0), ang.max(axis=0)
            if hi[1] - lo[1] > math.pi:
                V.fail("views", "views all around the normal and near the horizon", "views whose box fits a grid")
        span = np.maximum(hi - lo, 1e-6)
        self.lo, self.hi = lo - 1e-9 * span, hi + 1e-9 * span

    def _exact_at(self, xs, ys):
        """The exact p at the tensor grid xs x ys: (len(xs), len(ys), channels)."""
        a, b = np.meshgrid(xs, ys, indexing="ij")
        values = np.asarray(reflection_probability(self.target, self.alpha, self._views(a.reshape(-1), b.reshape(-1)),
                                                   self.light, "exact", self.rel_tol))
        return values.reshape(len(xs), len(ys), -1)

    def _chebyshev(self, tolerance, max_nodes):
        n = self.nodes
        self.axes = [_chebyshev_nodes(self.lo[i], self.hi[i], n) for i in (0, 1)]
        self.values = self._exact_at(*self.axes)
        self.refinement_error, self.converged = None, None
        if tolerance is None:
            return
        tol = V.real("tolerance", tolerance)
        while True:
            m = 2 * n - 1
            if m > max_nodes:
                self.converged = False
                return
            axes = [_chebyshev_nodes(self.lo[i], self.hi[i], m) for i in (0, 1)]
            fine = np.empty((m, m, self.values.shape[2]))
            fine[::2, ::2] = self.values
            new = np.ones((m, m), bool)
            new[::2, ::2] = False
            for sl in ((slice(1, None, 2), slice(None)), (slice(0, None, 2), slice(1, None, 2))):
                fine[sl] = self._exact_at(axes[0][sl[0]], axes[1][sl[1]])
            a, b = np.meshgrid(*axes, indexing="ij")
            coarse = self._chebyshev_eval(np.column_stack([a[new], b[new]]))
            exact = fine[new]
            big = exact > 1e-3 * max(float(fine.max()), 1e-300)
            self.refinement_error = float((np.abs(coarse - exact)[big] / exact[big]).max()) if big.any() else 0.0
            self.axes, self.values, self.nodes, n = axes, fine, m, m
            if self.refinement_error <= tol:
                self.converged = True
                return

    def _chebyshev_eval(self, c, chunk: int = 16384):
        out = np.empty((len(c), self.values.shape[2]))
        for i in range(0, len(c), chunk):
            wx = _barycentric_weights(self.axes[0], c[i:i + chunk, 0])
            wy = _barycentric_weights(self.axes[1], c[i:i + chunk, 1])
            out[i:i + chunk] = np.einsum("ni,ijk,nj->nk", wx, self.values, wy, optimize=True)
        return out

    @staticmethod
    def _angles(wo, phi0):
        phi = np.arctan2(wo[:, 1], wo[:, 0])
        if phi0 is not None:
            phi = np.mod(phi - phi0 + math.pi, 2 * math.pi) - math.pi
        return np.column_stack([np.arccos(np.clip(wo[:, 2], -1, 1)), phi])

    def _views(self, a, b):
        if self.polar:
            phi = b + self.phi0
            return np.column_stack([np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi), np.cos(a)])
        return np.column_stack([a, b, np.sqrt(np.maximum(1 - a * a - b * b, 0.0))])

    def __call__(self, wo) -> np.ndarray:
        """p at views ``wo`` (..., 3) inside the grid's span (an environment map: (..., regions))."""
        w = _view(wo)
        flat = w.reshape(-1, 3)
        c = self._angles(flat, self.phi0) if self.polar else flat[:, :2]
        if self.interpolation == "spline":
            out = np.column_stack([s.ev(c[:, 0], c[:, 1]) for s in self.splines])
        else:
            out = self._chebyshev_eval(c)
        out = np.maximum(out, 0.0)
        return out.reshape(w.shape[:-1] + ((self.regions,) if self.regions is not None else ()))

    def error(self, wo, samples: int = 256, seed: int = 0) -> dict:
        """The interpolation's error against the exact p at ``samples`` of the views ``wo`` drawn with
        ``seed``: the largest and median |p_grid - p_exact| / max p_exact, and the largest relative error
        where p_exact > 1e-3 max p_exact."""
        flat = _view(wo).reshape(-1, 3)
        pick = np.random.default_rng(V.seed(seed)).choice(len(flat), min(samples, len(flat)), replace=False)
        exact = np.asarray(reflection_probability(self.target, self.alpha, flat[pick], self.light, "exact", self.rel_tol))
        grid = self(flat[pick])
        scale = max(float(exact.max()), 1e-300)
        big = exact > 1e-3 * scale
        rel = np.abs(grid - exact)[big] / exact[big]
        return {"max_abs_error_over_max_p": float(np.abs(grid - exact).max() / scale),
                "median_abs_error_over_max_p": float(np.median(np.abs(grid - exact)) / scale),
                "max_rel_error_p_above_1e-3_max": float(rel.max()) if rel.size else 0.0, "samples": int(len(pick))}


# ---------------------------------------------------------------------------------------------------------
# LTC (docs/math/lighting.md#lighting-ltc)

#: View angles of the fitted table: uniform in sqrt(1 - cos(theta_o)), as Heitz et al.'s tables. 8, not 16: the
#: report's configurations' median error is the same with 16 (12.3 / 4.5 % against 12.5 / 4.5 % for Beckmann /
#: GGX; the largest GGX error 1.28 against 1.4) at twice the fit's cost (docs/math/lighting.md#lighting-ltc).
LTC_NODES = 8
LTC_SAMPLES = 32
LTC_VALUE_SAMPLES = 16


def _ltc_matrix(params):
    t, lsx, lsy, k = params
    c, s = math.cos(t), math.sin(t)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return rot @ np.array([[math.exp(lsx), 0.0, k], [0.0, math.exp(lsy), 0.0], [0.0, 0.0, 1.0]])


def _ltc_inverse(params):
    """(M^-1, log |det M^-1|) of _ltc_matrix(params) in closed form (the fits' inner loops): M = R_y(t) S, so
    M^-1 = S^-1 R_y(t)^T and det M = s_x s_y."""
    t, lsx, lsy, k = params
    c, s = math.cos(t), math.sin(t)
    ix, iy = math.exp(-lsx), math.exp(-lsy)
    rot_t = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    return np.array([[ix, 0.0, -k * ix], [0.0, iy, 0.0], [0.0, 0.0, 1.0]]) @ rot_t, -(lsx + lsy)


def _ltc_log_density(params, w):
    """log of the LTC density at unit directions w: D_o(w_o) |det M^-1| / |M^-1 w|^3, D_o the clamped cosine,
    w_o = M^-1 w / |M^-1 w|: log(max(x_z, 0) / pi) + log |det M^-1| - 2 log |x|^2 with x = M^-1 w."""
    minv, log_det = _ltc_inverse(params)
    x = w @ minv.T
    r2 = np.einsum("ij,ij->i", x, x)
    return np.log(np.maximum(x[:, 2], 1e-300) / math.pi) + log_det - 2.0 * np.log(r2)


def _facet_directions(target, alpha, wo, m=LTC_SAMPLES):
    """Light directions mirrored by normals drawn from D(m)(m.n) at the midpoints of an m x m grid of
    uniforms (a deterministic sample of the p density); those above the horizon."""
    u = (np.arange(m) + 0.5) / m
    uu, vv = np.meshgrid(u, u, indexing="ij")
    a2 = alpha * alpha
    tan2 = -a2 * np.log(uu) if target == "beckmann" else a2 * uu / (1 - uu)
    c = 1 / np.sqrt(1 + tan2)
    s = np.sqrt(1 - c * c)
    mn = np.stack([s * np.cos(2 * math.pi * vv), s * np.sin(2 * math.pi * vv), c], axis=-1).reshape(-1, 3)
    d = mn @ wo
    wi = 2 * d[:, None] * mn - wo
    return wi[(d > 0) & (wi[:, 2] > 0)]


def _ltc_upper_mass(m):
    """The LTC's mass above the horizon: the clamped cosine's mass in the half-space g.w_o > 0, g the third
    row of M, which is (1 + cos(angle of g from z)) / 2."""
    g = m[2]
    return 0.5 * (1.0 + g[2] / np.linalg.norm(g))


def _cosine_directions(m=LTC_SAMPLES):
    """Clamped-cosine directions at the midpoints of an m x m grid of uniforms (fixed: the value fit's LTC
    samples move with M but not with the random numbers, so the fit is deterministic and smooth in M)."""
    u = (np.arange(m) + 0.5) / m
    uu, vv = np.meshgrid(u, u, indexing="ij")
    r = np.sqrt(uu)
    return np.stack([r * np.cos(2 * math.pi * vv), r * np.sin(2 * math.pi * vv), np.sqrt(1 - uu)], axis=-1).reshape(-1, 3)


def _ml_shape(wi, t0, sx, sy):
    """The LTC parameters maximizing the likelihood of the p density's samples wi."""
    def loss(params):
        return -np.mean(_ltc_log_density(params, wi))

    return scipy.optimize.minimize(loss, [t0, math.log(sx), math.log(sy), 0.0], method="Nelder-Mead",
                                   options={"xatol": 1e-6, "fatol": 1e-9, "maxiter": 4000}).x


def _brdf_lobe(nd, wo, wi):
    """The BRDF's lobe f_r cos(theta_i) = D(h) G2(wo, wi) / (4 cos theta_o), Fresnel 1, G2 Smith's
    height-correlated shadowing-masking (the lobe of Heitz et al.'s shading tables), 0 below the horizon."""
    s = wo + wi
    h = s / np.linalg.norm(s, axis=-1, keepdims=True)
    g2 = 1.0 / (1.0 + nd.smith_lambda(wo[2]) + nd.smith_lambda(np.clip(wi[..., 2], 1e-12, 1.0)))
    return np.where(wi[..., 2] > 0, nd.D(h[..., 2]) * g2 / (4.0 * wo[2]), 0.0)


def _value_shape(target, alpha, wo, start, upper, lobe="p"):
    """Heitz et al.'s objective: the LTC parameters minimizing the L3 error of the LTC's values against the
    normalised target lobe q over the upper hemisphere (``lobe`` "p": the p density / upper; "brdf": the
    BRDF's lobe / its integral), the integral estimated by multiple importance sampling (balance heuristic)
    over samples of the p density (the target's draws) and of the LTC."""
    n = LTC_VALUE_SAMPLES
    wi = _facet_directions(target, alpha, wo, n)  # the kept ones of n^2 draws of the p density
    cosines = _cosine_directions(n)
    nd = _target(target, alpha)
    pdf_target = _density(nd, wo, wi)
    if lobe == "p":
        def value(x, pdf):
            return pdf / upper
    else:  # the lobe's integral by the same draws: the mean of lobe / pdf over all n^2 of them
        norm = float(np.sum(_brdf_lobe(nd, wo, wi) / pdf_target)) / (n * n)

        def value(x, pdf):
            return _brdf_lobe(nd, wo, x) / norm
    q_target = value(wi, pdf_target)

    def loss(params):
        own = cosines @ _ltc_matrix(params).T
        own = own[own[:, 2] > 0]
        own /= np.sqrt(np.einsum("ij,ij->i", own, own))[:, None]
        x = np.concatenate([wi, own])
        pdf_own = _density(nd, wo, own)
        q = np.concatenate([q_target, value(own, pdf_own)])
        pdf = np.concatenate([pdf_target, pdf_own])
        ltc = np.exp(_ltc_log_density(params, x))
        return float(np.sum(np.abs(q - ltc) ** 3 / (n * n * pdf + len(cosines) * ltc)))

    scale = loss(start)
    return scipy.optimize.minimize(lambda x: loss(x) / scale, start, method="Nelder-Mead",
                                   options={"xatol": 1e-5, "fatol": 1e-7, "maxiter": 3000}).x


LTC_FITS = ("values", "brdf", "ml")


def _fit_ltc(target, alpha, theta, fit="values"):
    """The LTC parameters (t, log sx, log sy, skew) at view angle theta (view in the xz-plane, +x side) and
    its magnitude. ``fit`` "values": Heitz et al.'s L3 fit of the values of the p density (started from the
    likelihood fit), magnitude the exact p of the upper hemisphere (Heitz et al.'s norm); "brdf": the same fit
    to the BRDF's lobe (the reading in which KK24 reuse the shading's LTC), the same magnitude; "ml": the
    maximum likelihood of the p density's samples, magnitude that p divided by the LTC's mass above the
    horizon (the total conserved)."""
    wo = np.array([math.sin(theta), 0.0, math.cos(theta)])
    wi = _facet_directions(target, alpha, wo)
    mean = wi.mean(axis=0)
    t0 = math.atan2(mean[0], mean[2])
    c, s = math.cos(t0), math.sin(t0)
    local = wi @ np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]]).T
    sx = max(2 * math.sqrt(np.mean((local[:, 0] / local[:, 2]) ** 2)), 1e-3)
    sy = max(2 * math.sqrt(np.mean((local[:, 1] / local[:, 2]) ** 2)), 1e-3)
    params = _ml_shape(wi, t0, sx, sy)
    upper = _core.reflection_probability(target, alpha, tuple(wo), _core.Light.cap((0.0, 0.0, 1.0), math.pi / 2), 1e-8)[0]
    if fit != "ml":  # Heitz et al.'s norm: the target's mass, the LTC's own loss below the horizon kept
        return np.concatenate([_value_shape(target, alpha, wo, params, upper, "p" if fit == "values" else "brdf"), [upper]])
    return np.concatenate([params, [upper / max(_ltc_upper_mass(_ltc_matrix(params)), 1e-300)]])


@functools.lru_cache(maxsize=64)
def ltc_table(target: str, alpha: float, fit: str = "values") -> tuple[np.ndarray, np.ndarray]:
    """(theta nodes, parameters (nodes, 5)): the LTC fitted (``fit``, see _fit_ltc) at LTC_NODES view angles,
    cached per (target, alpha, fit); parameters are interpolated linearly between nodes."""
    V.choice("fit", fit, LTC_FITS)
    x = (np.arange(LTC_NODES) + 0.5) / LTC_NODES
    theta = np.arccos(1 - x * x)
    theta = np.minimum(theta, math.radians(89.0))
    return theta, np.array([_fit_ltc(target, alpha, t, fit) for t in theta])


def _clip_upper(poly):
    """The spherical polygon (vertices as vectors, great-arc edges) clipped to z >= 0."""
    out = []
    for i in range(len(poly)):
        a, b = poly[i], poly[(i + 1) % len(poly)]
        if a[2] >= 0:
            out.append(a)
        if (a[2] >= 0) != (b[2] >= 0):
            t = a[2] / (a[2] - b[2])
            out.append(a + t * (b - a))
    return np.array(out)


def _ltc_polygon(minv, poly):
    """The integral of the LTC over a spherical polygon: the clamped cosine's integral over the polygon
    mapped by M^-1 and clipped to the upper hemisphere (Lambert's edge formula)."""
    q = _clip_upper(poly @ minv.T)
    if len(q) < 3:
        return 0.0
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    total = 0.0
    for i in range(len(q)):
        a, b = q[i], q[(i + 1) % len(q)]
        cr = np.cross(a, b)
        n = np.linalg.norm(cr)
        if n > 0:
            total += math.atan2(n, float(a @ b)) * cr[2] / n
    return abs(total) / (2 * math.pi)


def light_polygon(light: Light, n: int = 64) -> np.ndarray:
    """The light's boundary as a spherical polygon: the rectangle's corners, n points of a cap's or a
    disk's rim (the approximation the LTC path takes for round lights)."""
    p = light.params
    if light.kind == "rect":
        c, u, v = (np.array(p[k]) for k in ("center", "edge_u", "edge_v"))
        return np.array([c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2])
    a = 2 * math.pi * np.arange(n) / n
    if light.kind == "cap":
        axis, r = np.array(p["direction"]) / np.linalg.norm(p["direction"]), math.tan(p["half_angle"])
        centre = axis
    else:
        axis, r = np.array(p["normal"]) / np.linalg.norm(p["normal"]), p["radius"]
        centre = np.array(p["center"])
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    # A cap's rim is the circle of radius tan(half_angle) on the plane tangent at its axis.
    return centre + r * (np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2)


def ltc_probability(target, alpha, wo, light: Light, fit: str = "values") -> float:
    """p by the LTC (see ltc_table, ``fit``): the view rotated into the xz-plane, the light with it."""
    wo = _view(wo).reshape(3)
    theta = math.acos(min(wo[2], 1.0))
    phi = math.atan2(wo[1], wo[0])
    c, s = math.cos(-phi), math.sin(-phi)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    nodes, params = ltc_table(target, float(alpha), fit)
    par = np.array([np.interp(theta, nodes, params[:, j]) for j in range(params.shape[1])])
    minv = np.linalg.inv(_ltc_matrix(par[:4]))
    poly = _clip_upper(light_polygon(light) @ rot.T)
    if len(poly) < 3:
        return 0.0
    return float(par[4] * _ltc_polygon(minv, poly))


# ---------------------------------------------------------------------------------------------------------
# Environment maps (docs/math/lighting.md#lighting-env)

def _filtered_maps(nd, env: EnvMap, rows: int, cols: int) -> np.ndarray:
    """KK25's NDF-filtered indicator maps at a grid of (rows, cols) lookup directions R: F_r(R) = sum over
    the map's cells of [label = r] K(w; R) dw, with K(w; R) = D(h.R) / 4, h = (R + w)/|R + w| (the p
    density with n = wo = R), normalised so that its discrete sum over the whole sphere is 1."""
    key = (nd.name, nd.alpha, rows, cols)
    if key in env._filtered:
        return env._filtered[key]
    w = directions(*env.shape).reshape(-1, 3)
    dw = env.solid_angles.reshape(-1)
    lab = env.labels.reshape(-1)
    onehot = np.stack([(lab == r) * dw for r in range(env.regions)] + [dw], axis=-1)  # last: normaliser
    # Mirror directions of views are above the horizon: the rows below the equator's neighbour are never
    # looked up (the bilinear lookup reads at most one row past the equator), so they stay 0.
    used = min(rows, rows // 2 + 2)
    R = directions(rows, cols)[:used].reshape(-1, 3)
    out = np.zeros((rows * cols, env.regions + 1))
    out[:, -1] = 1.0
    for i0 in range(0, R.shape[0], 256):
        r = R[i0:i0 + 256]
        s = r[:, None, :] + w[None, :, :]
        cos_h = np.sum(s * r[:, None, :], axis=-1) / np.maximum(np.linalg.norm(s, axis=-1), 1e-300)
        out[i0:i0 + len(r)] = (nd.D(cos_h) / 4.0) @ onehot
    maps = (out[:, :-1] / out[:, -1:]).reshape(rows, cols, env.regions)
    env._filtered[key] = maps
    return maps


def _lookup(maps, R):
    """Bilinear lookup of (rows, cols, k) equirectangular maps at unit directions R (..., 3), wrapping in phi."""
    rows, cols = maps.shape[:2]
    theta = np.arccos(np.clip(R[..., 2], -1, 1))
    phi = np.mod(np.arctan2(R[..., 1], R[..., 0]), 2 * math.pi)
    y = np.clip(theta / math.pi * rows - 0.5, 0, rows - 1)
    x = phi / (2 * math.pi) * cols - 0.5
    y0 = np.minimum(np.floor(y).astype(int), rows - 2)
    x0 = np.floor(x).astype(int)
    fy, fx = (y - y0)[..., None], (x - x0)[..., None]
    x0m, x1m = np.mod(x0, cols), np.mod(x0 + 1, cols)
    top = maps[y0, x0m] * (1 - fx) + maps[y0, x1m] * fx
    bottom = maps[y0 + 1, x0m] * (1 - fx) + maps[y0 + 1, x1m] * fx
    return top * (1 - fy) + bottom * fy


FILTER_GRID = (32, 64)


def _map_probability(nd, wo, env: EnvMap, method, rel_tol, return_error, frames=None):
    flat = wo.reshape(-1, 3)
    frame_list = _frames(frames, len(flat))
    if method == "exact":
        rows, cols, k, labels, rad = env.core_args()
        values, errors = _core.region_probabilities_many(nd.name, nd.alpha, np.ascontiguousarray(flat).reshape(-1), rows,
                                                         cols, k, labels, rad, V.real("rel_tol", rel_tol), frame_list)
        values, errors = values.reshape(wo.shape[:-1] + (k,)), errors.reshape(wo.shape[:-1] + (k,))
        return (values, errors) if return_error else values
    mirror = flat * np.array([-1.0, -1.0, 1.0])
    if frame_list:  # the mirror direction in world space: sum of its components times the rows t, b, n
        mirror = np.einsum("kji,kj->ki", np.asarray(frames, float).reshape(-1, 3, 3), mirror)
    if method == "filtered":
        out = _lookup(_filtered_maps(nd, env, *FILTER_GRID), mirror)
    else:
        onehot = np.stack([(env.labels == r).astype(float) for r in range(env.regions)], axis=-1)
        out = _lookup(onehot, mirror)
    return out.reshape(wo.shape[:-1] + (env.regions,))


# ---------------------------------------------------------------------------------------------------------
# The facet truth (docs/math/lighting.md#lighting-facets) and multinomial counts (#lighting-multinomial)

class FacetCounts:
    """One realization of the facet truth: ``counts`` (footprints, channels) of facets reflecting each light
    or region, ``radiance`` (footprints,) the sum of their radiance, ``facets`` (footprints,) the facets
    inside each footprint."""

    def __init__(self, counts, radiance, facets):
        self.counts, self.radiance, self.facets = counts, radiance, facets

    def __repr__(self):
        return f"FacetCounts({self.counts.shape[0]} footprints, {self.counts.shape[1]} channels)"


def _side(density):
    d = V.real("density", density)
    side = round(math.sqrt(d)) if d > 0 and math.isfinite(d) else 0
    if side < 1 or side * side != d:
        V.fail("density", density, "a perfect square M^2 >= 1 (the stratified layout: one facet per cell)")
    return side


def facet_truth(target, alpha, density, footprints, centers, wo, light, seed=0, radiance: str = "map",
                frames=None) -> FacetCounts:
    """The facet truth under ``light`` (a Light, a list of them, or an EnvMap): explicit facets of the
    stratified layout of ``density`` (one per cell, jittered, each with its normal drawn from D(m)(m.n)),
    counted per placed footprint (``footprints`` from gl.Rect / gl.Ellipse, ``centers`` (x, y) pairs) when the
    mirror of that footprint's view ``wo`` (one (3,) for all or one per footprint) about its normal hits a
    light (the first that contains it) or a region; for a map, ``radiance`` "map" sums the map's own
    values, "regions" the partition's constants. One realization per ``seed``, whatever the threads.
    ``frames`` (footprints, 3, 3): each footprint's tangent frame (rows t, b, n) in the light's (world)
    coordinates, ``wo`` in that frame; a facet's mirror direction is tested above that frame's horizon,
    then mapped to world space and looked up in the light or the map (a curved surface under distant
    lights); None: every footprint in the light's frame."""
    nd = _target(target, alpha)
    side = _side(density)
    fps = [f._core for f in footprints]
    cs = [(V.real("centers", c[0]), V.real("centers", c[1])) for c in centers]
    w = np.broadcast_to(_view(wo), (len(fps), 3)).reshape(-1).tolist()
    seed = V.seed(seed)
    if isinstance(light, EnvMap):
        V.choice("radiance", radiance, ("map", "regions"))
        c, r, f = _core.facet_truth_map(target, nd.alpha, side, fps, cs, w, *light.core_args(radiance), seed,
                                        _frames(frames, len(fps)))
    else:
        lights = [light] if isinstance(light, Light) else list(light)
        if not lights or not all(isinstance(x, Light) for x in lights):
            V.fail("light", light, "a light from gl.lights, a list of them, or an environment map")
        c, r, f = _core.facet_truth_lights(target, nd.alpha, side, fps, cs, w, [x._core for x in lights],
                                           [x.radiance for x in lights], seed, _frames(frames, len(fps)))
    return FacetCounts(c, r, f)


SCHEMES = ("chain", "tree", "independent")


def _split(n_rem, q_rem, p_sub, law, u):
    """One conditional draw: K ~ law(n_rem, p_sub / q_rem), binned to whole counts."""
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.clip(np.where(q_rem > 0, p_sub / q_rem, 0.0), 0.0, 1.0)
    k = law.bin(law.evaluate(n_rem, p, u)) if law.n_uniforms else law.evaluate(n_rem, p, u)
    return np.clip(k, 0, n_rem)


def multinomial_counts(n, probs, law="binomial", scheme: str = "chain", size: int = 1, seed=0) -> np.ndarray:
    """Counts per region (size, k) of n facets falling in k regions with probabilities ``probs`` (the rest
    reflect nothing), drawn as conditional binomials of ``law`` (docs/math/lighting.md#lighting-multinomial):
    "chain" region after region (K_r ~ law(n - K_1 - ... - K_{r-1}, p_r / (1 - p_1 - ... - p_{r-1})): the
    exact multinomial with the binomial), "tree" by halving the set of regions (KK25's hierarchy), or
    "independent" (K_r ~ law(n, p_r) each on its own: the deliberately wrong variant)."""
    lw = make_law(law) if isinstance(law, str) else law
    V.choice("scheme", scheme, SCHEMES)
    p = V.as_float_array("probs", probs)
    if p.ndim != 1 or np.any(p < 0) or p.sum() > 1 + 1e-12:
        V.fail("probs", probs, "a 1-D array of probabilities >= 0 summing to at most 1")
    size = V.integer("size", size, minimum=0)
    n = V.real("n", n)
    rng = np.random.default_rng(V.seed(seed))
    k = len(p)
    out = np.zeros((size, k))
    uniforms = lambda: rng.random((size, max(lw.n_uniforms, 1)))  # noqa: E731
    if scheme == "independent":
        for r in range(k):
            out[:, r] = _split(np.full(size, n), np.ones(size), p[r], lw, uniforms())
        return out
    if scheme == "chain":
        n_rem, q_rem = np.full(size, n), 1.0
        for r in range(k):
            out[:, r] = _split(n_rem, np.full(size, q_rem), p[r], lw, uniforms())
            n_rem, q_rem = n_rem - out[:, r], q_rem - p[r]
        return out
    cats = list(range(k)) + [k]  # the last category: facets that reflect nothing
    probs_all = np.concatenate([p, [max(0.0, 1.0 - p.sum())]])

    def descend(group, n_group):
        if len(group) == 1:
            if group[0] < k:
                out[:, group[0]] = n_group
            return
        left, right = group[: len(group) // 2], group[len(group) // 2:]
        q = probs_all[group].sum()
        kl = _split(n_group, np.full(size, q), probs_all[left].sum(), lw, uniforms())
        descend(left, kl)
        descend(right, n_group - kl)

    descend(cats, np.full(size, n))
    return out
