"""Glinty NDFs as a renderer evaluates them: one value D^f per pixel (footprint, half vector), and the
image methods glintlab ships, registered in the one registry of image methods
(:mod:`glintlab.api.method_registry`, whose names are re-exported here; docs/math/glint_images.md#glint-methods).

Every glinty NDF subclasses :class:`GlintyNDF`: one pixel-array check (:func:`pixel_arrays`), one
footprint area P = |det J| and one D_P = (D(n) / R) K / (N P) (:meth:`GlintyNDF.d_p`), one angular slope
(:func:`angular_slope`). Registered by name (``glinty_ndfs()``):

- ``"smooth"``: the target D(h) itself (no glints, no flicker).
- ``"facets"``: the ground truth: stratified facets counted one by one in each footprint ellipse (C++,
  :func:`facet_counts`), D_P of DB23 eq. 4-6.

- ``"kpt25"``: Kemppinen et al. 2025's point process and constant-time evaluation (their Algorithm 1),
  with ``reference`` the full sum over every point of the same realization (docs/math/glinty_ndf.md).
  C++ (``_core.Kpt25Ndf``), pixels split over the OpenMP threads, deterministic per pixel.
- ``"db23"``: DB23's D_P = (D(n) / R) K / (N P) of eq. 3-4, with K counted by a grid scheme over an
  inner law (``aniso_counter(...).count_image``), docs/math/ndf.md#ndf-estimator.

An *image method* (:data:`IMAGE_METHODS`, ``image_methods()``) is a registered factory ``material ->
GlintyNDF`` with a label: the scene images render every image method through
:meth:`GlintyNDF.image`, which evaluates the NDF on the pixels that see the lit surface; a method
shader (``glintlab.api.method_shaders``) is an image method whose ``image`` runs a shader over every
field of the frame's inputs.

Shapes: ``uv`` (..., 2) texture positions, ``J`` (..., 4) = (du/dx, dv/dx, du/dy, dv/dy) per pixel as in
``AnisoCounter.count_image``, ``h`` (..., 3) half vectors in the tangent frame (normal +z; normalised
here; h_z <= 0 gives 0). The result has shape (...).
"""
from __future__ import annotations

import math
import re

import numpy as np

from .. import _core
from . import checks as V
from .grids import IMAGE_CONFIGS, aniso_counter
from .ndf import NDFS
from .ndf import ndf as smooth_ndf
# The registry's names, re-exported: ``from glintlab.api.glinty_ndf import Material`` (and the rest) is the import
# path the package, the tests and the docs have used since before the registry had its own module.
from .method_registry import (ANGULAR_TEXEL, IMAGE_METHODS, ORIGINS, TRUTH_KINDS, ImageMethod,  # noqa: F401
                              Material, image_methods, make_method, method_density, panel_methods,
                              register_image_method, shipped_image_methods)
from .registry import Registry

GLINTY_NDFS = Registry("glinty NDF")


FACET_STATUS = {0: "ok", 1: "degenerate", 2: "non_finite", 4: "too_large"}


def pixel_arrays(uv, J, h, unit_h: bool = False):
    """The one check of a glinty NDF's per-pixel arrays (docs/math/glinty_ndf.md#glinty-inputs):
    ``h`` (..., 3), ``J`` (..., 4) and ``uv`` (..., 2) of one shape (read from ``h``, or from ``uv`` when
    ``h`` is None; ``uv`` may be None), checked by :func:`checks.pixel_arrays` (NaN, infinities, zero h
    and singular J refused by element); returns contiguous float64 (uv, J, h, shape), h scaled by an
    exact power of two. With ``unit_h`` the half vectors are returned normalised (the evaluators written
    in Python need that; the C++ ones normalise themselves)."""
    if h is None:  # a method of the footprint alone (facet counts): uv and J checked as with an h
        uv = np.ascontiguousarray(V.as_float_array("uv", uv))
        if uv.ndim < 1 or uv.shape[-1:] != (2,):
            V.fail("uv", f"an array of shape {uv.shape}", "an array of shape (..., 2)")
        uv, J, _, shape = V.pixel_arrays(uv, J, np.broadcast_to([0.0, 0.0, 1.0], uv.shape[:-1] + (3,)))
        return uv, J, None, shape
    uv, J, h, shape = V.pixel_arrays(uv, J, h)
    if unit_h:
        h = V.unit_vectors(h)
    return uv, J, h, shape


def _arrays(uv, J, h):
    # The name the first glinty NDFs used; kept for code written against it.
    return pixel_arrays(uv, J, h)


_ELEMENT = re.compile(r"\b(uv|J|h|wo|position|dP|n)\[(\d+), (\d+|:)\]")


def _core_call(shape, fn, *args):
    """Call the core; its errors name an element as [pixel, component] of the flattened pixels: rewrite
    the pixel as the multi-index of the caller's array of shape ``shape`` + (components,)."""
    try:
        return fn(*args)
    except ValueError as e:
        def sub(m):
            name, i, c = m.group(1), int(m.group(2)), m.group(3)
            idx = [str(int(k)) for k in np.unravel_index(i, shape)] if shape and i < math.prod(shape) else []
            if not shape and i:
                idx = [str(i)]
            parts = idx + ([] if c == ":" else [c])
            return f"{name}[{', '.join(parts)}]" if parts else name
        raise ValueError(_ELEMENT.sub(sub, str(e))) from None


def _seed(name, value):
    try:
        return V.seed(value)
    except ValueError:
        V.fail(name, value, "an integer in [0, 2^64), a numpy SeedSequence or Generator, or None")


def _cos_theta(h):
    return V.unit_vectors(h)[..., 2]


def footprint_area(J) -> np.ndarray:
    """P = |det J| per pixel: the footprint's area in texture units (DB23 eq. 3)."""
    return np.abs(J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2])


def angular_slope(h) -> np.ndarray:
    """The half vector's slope (h_x / h_z, h_y / h_z) (..., 2); 0 where h_z <= 0 (below the horizon).
    Scale-free in theory; in floating point it depends on whether ``h`` was normalised first, so each
    estimator keeps the form it always used (bit-identical images)."""
    c = h[..., 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(c[..., None] > 0, h[..., :2] / np.where(c > 0, c, 1.0)[..., None], 0.0)


class GlintyNDF:
    """Common surface of the glinty NDFs and so of every image method: ``name``, ``target``, ``alpha``,
    ``density`` (None for a method without one: the smooth NDF), ``params``, ``smooth(h)`` (the target
    D(h) the estimator converges to), ``evaluate(uv, J, h, seed)`` (one value per pixel), the one D_P
    (:meth:`d_p`) and ``image(inputs, seed, frame)``, what the scene images call."""

    name = ""
    #: "ndf": ``evaluate`` returns an NDF value per pixel; "intensity": ``image`` returns a shaded value
    #: (method shaders such as WB16's sparkle intensity), with no ``evaluate``.
    returns = "ndf"

    def __init__(self, target: str, alpha: float, density: float | None):
        V.choice("target", target, NDFS, f"one of {', '.join(NDFS)}")
        self.target = target
        self.smooth_ndf = smooth_ndf(target, alpha)
        self.alpha = self.smooth_ndf.alpha
        if density is not None:
            density = V.real("density", density)
            if not (math.isfinite(density) and density > 0):
                V.fail("density", density, "a finite number > 0 (points per unit texture area)")
        self.density = density
        self.params: dict = {}

    @property
    def ndf(self):
        """The smooth target NDF object (``gl.ndf(target, alpha)``)."""
        return self.smooth_ndf

    def smooth(self, h) -> np.ndarray:
        """The smooth target D(h) for half vectors ``h`` (..., 3)."""
        h = V.as_float_array("h", h)
        if h.ndim < 1 or h.shape[-1] != 3:
            V.fail("h", f"an array of shape {h.shape}", "an array of shape (..., 3)")
        return self.smooth_ndf.D(_cos_theta(h))

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """The NDF value per pixel (subclasses)."""
        raise NotImplementedError(f"{type(self).__name__} has no per-pixel evaluate")

    def d_p(self, K, P, R: float) -> np.ndarray:
        """DB23 eq. 4-6's D_P = (D(n) / R) K / (N P) from counts ``K`` and footprint areas ``P``
        (docs/math/ndf.md#ndf-estimator); inf or NaN where P = 0 or K is unknown (callers mask)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.smooth_ndf.D_normal / R * K / (self.density * P)

    def image(self, inputs, seed: int = 0, frame: int = 0) -> np.ndarray:
        """One frame's image (H, W): ``evaluate`` on the pixels of ``inputs.mask`` (those that see the lit
        surface; ``inputs`` has ``uv``, ``J``, ``h`` in the tangent frame and ``mask``), 0 elsewhere.
        ``frame`` is unused by the NDFs (their realization is fixed on the surface)."""
        img = np.zeros(inputs.mask.shape)
        m = inputs.mask
        if m.any():
            img[m] = self.evaluate(inputs.uv[m], inputs.J[m], inputs.h[m], seed=seed)
        return img

    def label(self) -> str:
        """A short label: the name and the parameters."""
        return self.name + "[" + ",".join(f"{k}={v}" for k, v in self.params.items()) + "]"

    def __repr__(self):
        args = "".join(f", {k}={v!r}" for k, v in self.params.items())
        return f"glintlab.glinty_ndf({self.name!r}{args})"


class SmoothNDF(GlintyNDF):
    """The smooth target D(h) (``gl.ndf(target, alpha)``) as an image method: what the glints converge
    to, with no glints and no flicker."""

    name = "smooth"

    def __init__(self, target: str = "beckmann", alpha: float = 0.5):
        if not isinstance(target, str) or target not in NDFS:  # the NDF's own message names "ndf"
            smooth_ndf(target, alpha)
        super().__init__(target, alpha, None)
        self.params = {"target": target, "alpha": self.alpha}

    def __repr__(self):
        return f"SmoothNDF({self.target!r}, alpha={self.alpha:g})"

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D(h) per pixel (uv, J and seed are accepted for the common signature and unused)."""
        _, _, hn, _ = pixel_arrays(uv, J, h, unit_h=True)
        V.seed(seed)
        return self.smooth_ndf.D(hn[..., 2])


def facet_counts(uv, J, p, density, slope=None, seed: int = 0, max_cells: float = 2.0**26):
    """Ground-truth counts per pixel: the facets of the stratified layout of density ``density`` (one
    jittered facet per cell of side 1 / sqrt(N)) inside each pixel's footprint ellipse that reflect
    (their uniform, drawn per angular texel ``floor(slope)``, is below ``p``).

    Returns (K, status, tested) shaped like ``uv[..., 0]``: K (NaN where the ellipse spans more than
    ``max_cells`` cells), status (0 ok, 1 degenerate, 2 non_finite, 4 too_large; ``FACET_STATUS``) and
    the facets tested. Same seed, same counts, whatever the number of threads."""
    uv, J, _, shape = pixel_arrays(uv, J, None)
    pa = np.ascontiguousarray(V.as_float_array("p", p))
    V.scalar_or_shape("p", pa, shape)
    sl = None
    if slope is not None:
        sl = np.ascontiguousarray(V.as_float_array("slope", slope))
        if sl.shape != uv.shape:
            V.fail("slope", f"an array of shape {sl.shape}", f"an array of shape {uv.shape}")
        sl = sl.reshape(-1)
    k, st, tested = _core.facet_counts(V.real("density", density), pa.reshape(-1), uv.reshape(-1), J.reshape(-1),
                                       sl, V.seed(seed), V.real("max_cells", max_cells))
    return k.reshape(shape), st.reshape(shape), tested.reshape(shape)


class FacetNDF(GlintyNDF):
    """The ground truth: explicit stratified facets of density N counted one by one in each footprint
    ellipse (:func:`facet_counts`), D_P of DB23 eq. 4-6, with DB23's p = min(R D(h) / D(n), 1) and the
    facets' reflection uniforms drawn per angular texel ``floor(slope / angular_texel)``
    (docs/math/glint_images.md#glint-angular)."""

    name = "facets"

    def __init__(self, density, target: str = "beckmann", alpha: float = 0.5, R: float = 0.5,
                 angular_texel: float = 0.05, max_cells: float = 2.0**26):
        super().__init__(target, alpha, density)
        self.R = V.real("R", R)
        if not (0 < self.R <= 1):
            V.fail("R", R, "a number in (0, 1]")
        self.angular_texel = V.real("angular_texel", angular_texel)
        if not (math.isfinite(self.angular_texel) and self.angular_texel > 0):
            V.fail("angular_texel", angular_texel, "a finite angular texel size > 0 (slope units)")
        self.max_cells = V.real("max_cells", max_cells)
        self.params = {"density": self.density, "target": target, "alpha": self.alpha, "R": self.R,
                       "angular_texel": self.angular_texel, "max_cells": self.max_cells}

    def __repr__(self):
        return f"FacetNDF(density={self.density:g}, {self.target!r}, alpha={self.alpha:g}, R={self.R:g})"

    def counts(self, uv, J, p, slope, seed):
        """K per pixel (see :func:`facet_counts`)."""
        return facet_counts(uv, J, p, self.density, slope, seed, self.max_cells)[0]

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D_P per pixel; 0 where the footprint is empty or K unknown."""
        uv, J, hn, _ = pixel_arrays(uv, J, h, unit_h=True)
        p, _ = self.smooth_ndf.success_probability(hn[..., 2], self.R)
        slope = np.clip(angular_slope(hn) / self.angular_texel, -1e9, 1e9)
        d = self.d_p(self.counts(uv, J, p, slope, V.seed(seed)), footprint_area(J), self.R)
        return np.where(np.isfinite(d), d, 0.0)


#: A KPT25 point is a visible glint at h when its normal lies within this many lobe stds of T(h): the
#: disk of radius 2 sigma has the area 4 pi sigma^2 = (integral of G)^2 / (integral of G^2) of the
#: Gaussian lobe, its equivalent area (docs/math/glinty_ndf.md#glinty-matched).
VISIBLE_RADIUS = 2.0


def _disk_overlap(r, R, c):
    """Area of the intersection of disks of radii r and R whose centres are c apart (arrays, closed form)."""
    r, c = np.broadcast_arrays(np.asarray(r, float), np.asarray(c, float))
    out = np.zeros(r.shape)
    inside = c <= np.abs(R - r)
    out[inside] = math.pi * np.minimum(r[inside], R) ** 2
    cut = ~inside & (c < r + R) & (r > 0)
    rr, cc = r[cut], c[cut]
    a1 = np.arccos(np.clip((cc * cc + rr * rr - R * R) / (2 * cc * rr), -1, 1))
    a2 = np.arccos(np.clip((cc * cc + R * R - rr * rr) / (2 * cc * R), -1, 1))
    out[cut] = rr * rr * (a1 - 0.5 * np.sin(2 * a1)) + R * R * (a2 - 0.5 * np.sin(2 * a2))
    return out


def db23_visible_glints(density, target: str, alpha: float, J, h, R: float) -> np.ndarray:
    """DB23's expected visible glints per pixel: the reflecting facets of its footprint, N abs(det J) p
    with p = min(1, R D(h) / D(n)) (eq. 3-4; docs/math/glinty_ndf.md#glinty-matched)."""
    _, J, h, _ = pixel_arrays(None, J, h, unit_h=True)
    p, _ = smooth_ndf(target, alpha).success_probability(h[..., 2], R)
    return V.real("density", density) * footprint_area(J) * p


def matched_density(density, alpha_star: float, target: str = "beckmann", alpha: float = 0.5, R: float = 0.5,
                    radius: float = VISIBLE_RADIUS) -> float:
    """``gl.matched_density(N, alpha_star, target, alpha, R)``: the KPT25 point density K_P that gives the
    same expected number of visible glints per pixel as DB23 with facet density N and ratio R, at every
    footprint and every half vector h with R D(h) <= D(n) whose lobe disk lies inside U:
    K_P = N R / (pi radius^2 alpha_star^2 D(n)) (docs/math/glinty_ndf.md#glinty-matched)."""
    density, alpha_star = V.real("density", density), V.real("alpha_star", alpha_star)
    if not (math.isfinite(density) and density > 0):
        V.fail("density", density, "a finite facet density > 0")
    if not (math.isfinite(alpha_star) and alpha_star > 0):
        V.fail("alpha_star", alpha_star, "a finite micro-roughness > 0")
    R, radius = V.real("R", R), V.real("radius", radius)
    if not (0 < R <= 1):
        V.fail("R", R, "a number in (0, 1]")
    if not (0 < radius <= 10):
        V.fail("radius", radius, "a number of lobe stds in (0, 10]")
    if isinstance(alpha, (tuple, list, np.ndarray)):  # (alpha_x, alpha_y): D(n) = 1 / (pi alpha_x alpha_y)
        ax, ay = (smooth_ndf(target, a).alpha for a in np.asarray(alpha, dtype=object).reshape(-1)[:2])
        d_n = 1.0 / (math.pi * ax * ay)
    else:
        d_n = smooth_ndf(target, alpha).D_normal
    return density * R / (math.pi * radius**2 * alpha_star**2 * d_n)


class KPT25(GlintyNDF):
    """KPT25's glinty NDF (docs/math/glinty_ndf.md).

    ``density`` K_P (points per unit texture area), ``target`` and ``alpha`` (the smooth NDF; a pair
    (alpha_x, alpha_y) for anisotropic roughness, docs/math/glinty_ndf.md#glinty-anisotropy), ``colors``
    (an (m, 3) RGB palette: each point takes one entry; ``evaluate`` and ``reference`` then return RGB,
    docs/math/glinty_ndf.md#glinty-colour), ``anisotropy`` (a_x, a_y): Algorithm 1's A_* (anisotropic
    glints; evaluate and reference only) with ``anisotropy_density`` "preserved" (K_P points per unit uv
    area) or "printed" (line 1's grid resolution), docs/math/glinty_ndf.md#glinty-astar,
    ``alpha_star`` (micro-roughness), ``k`` (angular neighbours per level: 1, 4, 9, 16), ``epsilon``
    (eq. 8's mollification; 0 = exact roulette), ``filter`` (Gaussian pixel filter std in pixels; the
    default 1 / (2 sqrt(pi)) gives an effective area abs(det J), DB23's footprint), ``compensation``
    ("square": eq. 10 as the paper does; "disk": eq. 9 exactly; "none"; "square_flipped": a deliberately
    wrong sign, for the tests), ``blend`` ("roulette" or "linear") and ``sample_smooth`` (Algorithm 2:
    the probability beta that a draw samples the smooth target instead of the lobes; 0 = the paper,
    which does not sample the compensation term) and ``sample_weight`` (Algorithm 2's reservoir weight
    of a point: "lobe_mass", its lobe's mass in the block, or "printed", the filter and roulette weight
    alone; docs/math/glinty_ndf.md#glinty-sampling) and ``ggx_map`` (GGX only: "orthographic", the exact
    uniformising map, or "lambert", the paper's eq. 7; docs/math/glinty_ndf.md#glinty-lambert) with
    ``lambert_jacobian`` ("map": the pdf uses the Lambert map's own Jacobian (pi / 8) D(h) abs(M^T h);
    "printed": eq. 6's printed exponent, (pi / 8) D(h), which is not the sampler's density) and
    ``reference_tol`` (the tolerance :meth:`reference` uses when called without one; 0 = the exact sum).

    ``mapping="triplanar"`` (KPT25 §3.3.6, UV-free glints; docs/math/glinty_ndf.md#glinty-triplanar):
    three point processes on the coordinate planes yz, xz, xy of the world position, blended by the
    roulette with weights ``triplanar_weights`` ("normalized": abs(n_i)^s / sum_j abs(n_j)^s, s =
    ``triplanar_sharpness``; "printed": abs(n_i)^s unnormalised, as the sentence reads; "missing_xy": a
    deliberately wrong blend for the tests) and ``plane_seeds`` ("distinct": one process per plane;
    "shared": the planes share one, so surfaces where two planes see the same coordinates see the same
    points). ``evaluate``, ``reference`` and ``expected`` then take world positions (..., 3), their screen
    derivatives dP (..., 6) = (dP/dx, dP/dy) (or (..., 2, 3)), world half vectors h and the normal ``n``
    (..., 3): each plane's footprint is the derivatives of its two coordinates.

    >>> nd = KPT25(density=1e4, alpha=0.5, alpha_star=0.05)
    >>> h, pdf = nd.sample([[0.3, 0.7]] * 2, [[0.01, 0, 0, 0.01]] * 2, seed=1)
    >>> h.shape, pdf.shape, bool(np.allclose(nd.pdf([[0.3, 0.7]] * 2, [[0.01, 0, 0, 0.01]] * 2, h, seed=1), pdf))
    ((2, 3), (2,), True)
    >>> nd.map([0.0, 0.0, 1.0]).tolist()
    [0.5, 0.5]
    >>> tri = KPT25(density=1e4, alpha=0.5, alpha_star=0.05, mapping="triplanar")
    >>> (7 * tri.triplanar_weights([0.0, 3.0, 4.0])).round(12).tolist()
    [0.0, 3.0, 4.0]
    >>> P, dP, n = [[1.0, 2.0, 0.5]], [[0.01, 0, 0, 0, 0.01, 0]], [0.0, 0.0, 1.0]
    >>> bool(tri.evaluate(P, dP, [0.1, 0.0, 1.0], seed=3, n=n)[0] >= 0)
    True
    """

    name = "kpt25"

    def __init__(self, density: float = 1e6, target: str = "beckmann", alpha: float = 0.5, alpha_star: float = 0.02,
                 k: int = 4, epsilon: float = 0.1, filter: float = 0.5 / math.sqrt(math.pi),
                 compensation: str = "square", blend: str = "roulette", sample_smooth: float = 0.0,
                 sample_weight: str = "lobe_mass", ggx_map: str = "orthographic", colors=None,
                 anisotropy=(1.0, 1.0), anisotropy_density: str = "preserved", mapping: str = "uv",
                 triplanar_weights: str = "normalized", triplanar_sharpness: float = 1.0,
                 plane_seeds: str = "distinct", reference_tol: float = 0.0, lambert_jacobian: str = "map"):
        alpha_y = 0.0
        if isinstance(alpha, (tuple, list, np.ndarray)):  # (alpha_x, alpha_y): anisotropic roughness
            pair = np.asarray(alpha, dtype=object).reshape(-1)
            if pair.size != 2:
                V.fail("alpha", alpha, "a roughness > 0 or a pair (alpha_x, alpha_y)")
            ax, ay = (smooth_ndf(target if target in NDFS else "beckmann", a).alpha for a in pair)
            alpha, alpha_y = ax, (ay if ay != ax else 0.0)
        super().__init__(target, alpha, density)
        self.alpha_y = alpha_y or self.alpha
        if ggx_map not in ("orthographic", "lambert") or (ggx_map == "lambert" and target != "ggx"):
            V.fail("ggx_map", ggx_map, "'orthographic', or 'lambert' with target 'ggx'")
        V.choice("lambert_jacobian", lambert_jacobian, ("map", "printed"), "'map' or 'printed'")
        if lambert_jacobian == "printed" and ggx_map != "lambert":
            V.fail("lambert_jacobian", lambert_jacobian, "'map' unless ggx_map='lambert'")
        V.choice("k", V.integer("k", k, expected="1, 4, 9 or 16"), (1, 4, 9, 16), "1, 4, 9 or 16")
        for pname, value in (("compensation", compensation), ("blend", blend), ("sample_weight", sample_weight)):
            if not isinstance(value, str):
                V.fail(pname, value, "a string")
        aniso = np.asarray(V.as_float_array("anisotropy", anisotropy), float).reshape(-1)
        if aniso.shape != (2,) or not np.all((aniso >= 1e-3) & (aniso <= 1e3)):
            V.fail("anisotropy", anisotropy, "a pair (a_x, a_y) of stretches in [1e-3, 1e3]")
        if anisotropy_density not in ("preserved", "printed"):
            V.fail("anisotropy_density", anisotropy_density, "'preserved' or 'printed'")
        V.choice("mapping", mapping, ("uv", "triplanar"), "'uv' or 'triplanar'")
        V.choice("triplanar_weights", triplanar_weights, ("normalized", "printed", "missing_xy"),
                 "'normalized', 'printed' or 'missing_xy'")
        V.choice("plane_seeds", plane_seeds, ("distinct", "shared"), "'distinct' or 'shared'")
        if mapping == "triplanar":  # the paper: no uv gradients to orient anisotropy by
            if alpha_y:
                V.fail("alpha", alpha, "one roughness (isotropic) with mapping='triplanar'")
            if tuple(aniso) != (1.0, 1.0):
                V.fail("anisotropy", anisotropy, "(1, 1) with mapping='triplanar'")
            if colors is not None:
                V.fail("colors", "a palette", "None with mapping='triplanar' (scalar output)")
        self._core = _core.Kpt25Ndf(self.density, target, self.alpha, V.real("alpha_star", alpha_star), int(k),
                                    V.real("epsilon", epsilon), V.real("filter", filter), compensation, blend,
                                    V.real("sample_smooth", sample_smooth), sample_weight, ggx_map, alpha_y,
                                    float(aniso[0]), float(aniso[1]), anisotropy_density == "printed",
                                    triplanar_weights, V.real("triplanar_sharpness", triplanar_sharpness), plane_seeds,
                                    lambert_jacobian)
        self.params = {"density": self.density, "target": target,
                       "alpha": (self.alpha, self.alpha_y) if alpha_y else self.alpha,
                       "alpha_star": float(alpha_star), "k": int(k), "epsilon": float(epsilon),
                       "filter": float(filter), "compensation": compensation, "blend": blend}
        if sample_smooth:
            self.params["sample_smooth"] = float(sample_smooth)
        if sample_weight != "lobe_mass":
            self.params["sample_weight"] = sample_weight
        self.ggx_map = ggx_map
        if ggx_map != "orthographic":
            self.params["ggx_map"] = ggx_map
        if lambert_jacobian != "map":
            self.params["lambert_jacobian"] = lambert_jacobian
        self.mapping = mapping
        if mapping == "triplanar":
            self.params.update(mapping=mapping, triplanar_weights=triplanar_weights,
                               triplanar_sharpness=float(triplanar_sharpness), plane_seeds=plane_seeds)
        self.anisotropy = (float(aniso[0]), float(aniso[1]))
        if self.anisotropy != (1.0, 1.0):
            self.params["anisotropy"] = self.anisotropy
            self.params["anisotropy_density"] = anisotropy_density
        # The tolerance of reference() when called without one (0: the exact sum; the scene images' own
        # truth sets one, docs/math/glinty_ndf.md#glinty-reference-reach).
        self.reference_tol = V.real("reference_tol", reference_tol)
        if not (0.0 <= self.reference_tol < 1.0):
            V.fail("reference_tol", reference_tol, "a tolerance in [0, 1) (0: the exact sum)")
        if self.reference_tol:
            self.params["reference_tol"] = self.reference_tol
        self.colors = None
        if colors is not None:  # an (m, 3) palette: RGB output (docs/math/glinty_ndf.md#glinty-colour)
            pal = V.as_float_array("colors", colors)
            if pal.ndim != 2 or pal.shape[1] != 3 or pal.shape[0] < 1 or pal.shape[0] > 2**20:
                V.fail("colors", f"an array of shape {pal.shape}", "an (m, 3) palette of RGB colours, 1 <= m <= 2^20")
            if not np.all(np.isfinite(pal)) or np.any(pal < 0):
                V.fail("colors", "a palette with a negative or non-finite entry", "finite RGB values >= 0")
            self.colors = np.ascontiguousarray(pal, dtype=float)
            self.params["colors"] = self.colors.shape[0]

    def image(self, inputs, seed: int = 0, frame: int = 0) -> np.ndarray:
        """As :meth:`GlintyNDF.image` (scalar images: a palette's RGB output is refused by name)."""
        self._uv_only("image")
        if self.colors is not None:
            V.fail("colors", f"a palette of {self.colors.shape[0]} colours", "None for scene images (scalar)")
        return super().image(inputs, seed, frame)

    def _uv_only(self, what):
        if self.mapping == "triplanar":
            V.fail("mapping", "triplanar", f"'uv' for {what} (triplanar glints: evaluate, reference and expected)")

    def _triplanar_arrays(self, position, dP, h, n):
        """The checked, flattened arrays of a triplanar call: position (..., 3), dP (..., 6) or
        (..., 2, 3), h and n (..., 3), broadcast to one shape; finite values and nonzero vectors are
        checked in the core, by element."""
        if n is None:
            V.fail("n", None, "the normals (..., 3) with mapping='triplanar'")
        arrays = {}
        for name, a, tail in (("position", position, 3), ("dP", dP, 6), ("h", h, 3), ("n", n, 3)):
            a = np.asarray(V.as_float_array(name, a), float)
            if name == "dP" and a.shape[-2:] == (2, 3):
                a = a.reshape(a.shape[:-2] + (6,))
            if a.ndim < 1 or a.shape[-1] != tail:
                V.fail(name, f"an array of shape {a.shape}", f"an array of shape (..., {tail})"
                       + (" or (..., 2, 3)" if name == "dP" else ""))
            arrays[name] = a
        try:
            shape = np.broadcast_shapes(*(a.shape[:-1] for a in arrays.values()))
        except ValueError:
            V.fail("position", "arrays of shapes " + ", ".join(f"{k} {a.shape}" for k, a in arrays.items()),
                   "position, dP, h and n of one pixel shape (or broadcastable to one)")
        flat = [np.ascontiguousarray(np.broadcast_to(a, shape + a.shape[-1:])).reshape(-1) for a in arrays.values()]
        P, d, hh, nn = flat
        return P, d, nn, hh, shape

    def _triplanar(self, position, dP, h, n, seed, reference):
        P, d, nn, hh, shape = self._triplanar_arrays(position, dP, h, n)
        v, pts = _core_call(shape, self._core.evaluate_triplanar, P, d, nn, hh, V.seed(seed), reference)
        return v.reshape(shape), pts.reshape(shape)

    def triplanar_weights(self, n) -> np.ndarray:
        """The blend weights of the yz, xz and xy planes for normals ``n`` (..., 3) (not necessarily unit)."""
        n = np.asarray(V.as_float_array("n", n), float)
        if n.ndim < 1 or n.shape[-1] != 3:
            V.fail("n", f"an array of shape {n.shape}", "an array of shape (..., 3)")
        flat = n.reshape(-1, 3)
        return np.array([self._core.triplanar_weights(np.ascontiguousarray(r)) for r in flat]).reshape(n.shape)

    def keep_rate(self, w: float) -> float:
        """E over r of R(r, w) (eq. 8's roulette): w except within epsilon of 0 and 1."""
        return float(self._core.keep_rate(V.real("w", w)))

    @property
    def expected_color(self):
        """E[GlintColor] (Algorithm 1, line 20): the palette's mean (each entry equally likely per point);
        None without a palette."""
        return None if self.colors is None else self.colors.mean(axis=0)

    def _rgb(self, uv, J, h, seed, reference):
        uv, J, h, shape = pixel_arrays(uv, J, h)
        out = _core_call(shape, self._core.evaluate_rgb, uv.reshape(-1), J.reshape(-1), h.reshape(-1), V.seed(seed),
                         self.colors.reshape(-1), reference)
        return out.reshape(shape + (3,))

    @property
    def D_normal(self) -> float:
        """D(n) of the target: 1 / (pi alpha_x alpha_y) for both Beckmann and GGX."""
        return 1.0 / (math.pi * self.alpha * self.alpha_y)

    def smooth(self, h) -> np.ndarray:
        """The target D(h), anisotropic when alpha = (alpha_x, alpha_y) (docs/math/glinty_ndf.md#glinty-anisotropy)."""
        if self.alpha_y == self.alpha:
            return super().smooth(h)
        h = V.as_float_array("h", h)
        if h.ndim < 1 or h.shape[-1] != 3:
            V.fail("h", f"an array of shape {h.shape}", "an array of shape (..., 3)")
        u = V.unit_vectors(h)
        hz = np.where(u[..., 2] > 0, u[..., 2], 1.0)
        ax, ay = self.alpha, self.alpha_y
        with np.errstate(over="ignore", under="ignore"):
            if self.target == "beckmann":
                t = (u[..., 0] / (hz * ax)) ** 2 + (u[..., 1] / (hz * ay)) ** 2
                d = np.exp(-t) / (math.pi * ax * ay * hz**4)
            else:
                q = (u[..., 0] / ax) ** 2 + (u[..., 1] / ay) ** 2 + hz**2
                d = 1.0 / (math.pi * ax * ay * q * q)
        return np.where(u[..., 2] > 0, d, 0.0)

    def evaluate(self, uv, J, h, seed: int = 0, n=None) -> np.ndarray:
        """D^f per pixel by Algorithm 1 (B(k) per level, compensation, two levels with the roulette).
        Constant time per pixel; the same realization as ``reference`` for the same ``seed``. With
        ``colors``, RGB: shape (..., 3). With ``mapping="triplanar"``: ``uv`` is the world position
        (..., 3), ``J`` its screen derivatives dP (..., 6), ``h`` the world half vector and ``n`` the
        normal (..., 3)."""
        if self.mapping == "triplanar":
            return self._triplanar(uv, J, h, n, seed, False)[0]
        if self.colors is not None:
            return self._rgb(uv, J, h, seed, False)
        uv, J, h, shape = pixel_arrays(uv, J, h)
        return _core_call(shape, self._core.evaluate, uv.reshape(-1), J.reshape(-1), h.reshape(-1),
                          V.seed(seed)).reshape(shape)

    def reference(self, uv, J, h, seed: int = 0, return_points: bool = False, n=None, tol=None):
        """The full sum of eq. 11's first term over every point of the same realization whose position
        falls in the filter (both levels, same roulette; no truncation to B(k), no compensation). With
        ``return_points``, also the number of points summed per pixel. Its cost grows with the number
        of points in the footprint. With ``colors``, RGB (..., 3) (and no point counts). With
        ``mapping="triplanar"``, arguments as :meth:`evaluate`, and the points returned are those kept
        by the roulettes (the sum of their keep weights) in the three planes' truncated filters.
        ``tol`` (None: the object's ``reference_tol``, 0 unless given): 0 is the exact sum; tol > 0
        leaves out the lobes too far from T(h) to move the value by more than tol x D(h) x W / K_P
        (W / K_P: the pixel's summed filter weight, pi / 4 in expectation;
        docs/math/glinty_ndf.md#glinty-reference-reach)."""
        tol = self.reference_tol if tol is None else V.real("tol", tol)
        if not (0.0 <= tol < 1.0):
            V.fail("tol", tol, "a tolerance in [0, 1) (0: the exact sum)")
        if self.mapping == "triplanar":
            if tol:
                V.fail("tol", tol, "0 with mapping='triplanar' (the triplanar reference is the exact sum)")
            d, pts = self._triplanar(uv, J, h, n, seed, True)
            return (d, pts) if return_points else d
        if self.colors is not None:
            if tol:
                V.fail("tol", tol, "0 with colors (the RGB reference is the exact sum)")
            return self._rgb(uv, J, h, seed, True)
        uv, J, h, shape = pixel_arrays(uv, J, h)
        d, pts = _core_call(shape, self._core.reference, uv.reshape(-1), J.reshape(-1), h.reshape(-1), V.seed(seed),
                            tol)
        return (d.reshape(shape), pts.reshape(shape)) if return_points else d.reshape(shape)

    def expected(self, J, h, n=None) -> tuple[np.ndarray, np.ndarray]:
        """Exact expectations over realizations, (E[reference], E[evaluate]), per footprint and half
        vector: D(h) times the lobe's mass in the disk, and the same with B(k) and the compensation.
        With ``mapping="triplanar"``: ``J`` is dP (..., 6), ``h`` world half vectors, ``n`` the normals;
        the planes' terms weighted by the roulette's keep rates (docs/math/glinty_ndf.md#glinty-triplanar)."""
        if self.mapping == "triplanar":
            _, d, nn, hh, shape = self._triplanar_arrays(np.zeros(3), J, h, n)
            er, ea = _core_call(shape, self._core.expected_triplanar, d, nn, hh)
            return er.reshape(shape), ea.reshape(shape)
        _, J, h, shape = pixel_arrays(None, J, h)
        er, ea = _core_call(shape, self._core.expected, J.reshape(-1), h.reshape(-1))
        return er.reshape(shape), ea.reshape(shape)

    def pixel(self, J, h) -> dict:
        """The set-up of one pixel: D(h), T(h) = (xa, ya), the angular std sigma, the fractional MIP level
        lambda, its levels and weights, the filter's box half widths."""
        _, J, h, _ = pixel_arrays(None, np.reshape(J, (1, 4)), np.reshape(h, (1, 3)))
        return _core_call((), self._core.pixel, J.reshape(-1), h.reshape(-1))

    def sample(self, uv, J, seed: int = 0, draw_seed: int = 0, wo=None):
        """KPT25's Algorithm 2: one half vector per pixel (row) drawn from the pdf of that pixel
        (docs/math/glinty_ndf.md#glinty-sampling). ``uv`` (..., 2), ``J`` (..., 4); ``seed`` selects the
        realization (the point process, as in ``evaluate``), ``draw_seed`` and the row's flat index
        select the draw, so M copies of one pixel give M independent draws from its pdf.

        Returns ``(h, pdf)``: half vectors (..., 3) and their density per steradian of h (the value
        ``pdf`` returns for them); a draw whose lobe point falls outside the disk U is lost: h = NaN
        and pdf = 0. With ``wo`` (3,) or (..., 3) (normalised here), returns ``(h, pdf, wi)`` with
        wi = 2 (wo.h) h - wo the reflected directions, NaN where wo.h <= 0 (a facet facing away from wo
        reflects nothing; h and its pdf are still returned); the density of wi is pdf / (4 wo.h)
        (docs/math/glinty_ndf.md#glinty-sampling)."""
        self._uv_only("sample")
        uv = np.ascontiguousarray(V.as_float_array("uv", uv))
        if uv.ndim < 1 or uv.shape[-1] != 2:
            V.fail("uv", f"an array of shape {uv.shape}", "an array of shape (..., 2)")
        shape = uv.shape[:-1]
        J = np.ascontiguousarray(V.as_float_array("J", J))
        if J.shape != shape + (4,):
            V.fail("J", f"an array of shape {J.shape}", f"an array of shape {shape + (4,)}")
        w = None
        if wo is not None:
            w = V.as_float_array("wo", wo)
            if w.shape not in ((3,), shape + (3,)):
                V.fail("wo", f"an array of shape {w.shape}", f"an array of shape (3,) or {shape + (3,)}")
            w = np.ascontiguousarray(np.broadcast_to(w, shape + (3,))).reshape(-1)
        h, pdf, wi = _core_call(shape, self._core.sample, uv.reshape(-1), J.reshape(-1), V.seed(seed),
                                _seed("draw_seed", draw_seed), w)
        h, pdf = h.reshape(shape + (3,)), pdf.reshape(shape)
        return (h, pdf) if wo is None else (h, pdf, wi.reshape(shape + (3,)))

    def pdf(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """The density per steradian of h with which ``sample`` draws h at each pixel, for the
        realization ``seed`` (0 below the horizon). Shapes as ``evaluate``."""
        self._uv_only("pdf")
        uv, J, h, shape = pixel_arrays(uv, J, h)
        return _core_call(shape, self._core.pdf, uv.reshape(-1), J.reshape(-1), h.reshape(-1),
                          V.seed(seed)).reshape(shape)

    def map(self, h) -> np.ndarray:
        """T(h) of docs/math/glinty_ndf.md#glinty-map for half vectors (..., 3): points (..., 2) of the unit
        square, the disk U centred at (1/2, 1/2) with radius 1/2 being the image of the hemisphere
        (NaN for h_z <= 0; h need not be normalised)."""
        h = np.ascontiguousarray(V.as_float_array("h", h))
        if h.ndim < 1 or h.shape[-1] != 3:
            V.fail("h", f"an array of shape {h.shape}", "an array of shape (..., 3)")
        shape = h.shape[:-1]
        return _core_call(shape, self._core.map, h.reshape(-1)).reshape(shape + (2,))

    def visible_glints(self, uv, J, h, seed: int = 0, radius: float = VISIBLE_RADIUS) -> np.ndarray:
        """The visible glints per pixel (docs/math/glinty_ndf.md#glinty-matched): the points of realization
        ``seed`` inside DB23's footprint ellipse J {|x| <= 1 / sqrt(pi)} (area abs(det J)) whose normal lies
        within ``radius`` lobe stds sigma = alpha_star sqrt(D(h)) of T(h), each counted with its roulette
        weight (both levels). Its mean over realizations is :meth:`expected_visible_glints`."""
        self._uv_only("visible_glints")
        uv, J, h, shape = pixel_arrays(uv, J, h)
        return _core_call(shape, self._core.visible_counts, uv.reshape(-1), J.reshape(-1), h.reshape(-1),
                          V.seed(seed), V.real("radius", radius)).reshape(shape)

    def expected_visible_glints(self, J, h, radius: float = VISIBLE_RADIUS) -> np.ndarray:
        """E[visible_glints] = K_P abs(det J) |disk(T(h), radius sigma) cap U| exactly (one point per 4D cell at
        each level, levels weighted by the roulette whose means add to 1); K_P abs(det J) pi radius^2
        alpha_star^2 D(h) while the disk lies inside U."""
        _, J, h, shape = pixel_arrays(None, J, h, unit_h=True)
        radius = V.real("radius", radius)
        if not (0 < radius <= 10):
            V.fail("radius", radius, "a number of lobe stds in (0, 10]")
        t = self.map(h)
        d = self.smooth(h)
        r = radius * self.params["alpha_star"] * np.sqrt(d)
        c = np.hypot(t[..., 0] - 0.5, t[..., 1] - 0.5)
        area = np.where(d > 0, _disk_overlap(np.where(d > 0, r, 0.0), 0.5, np.where(d > 0, c, 0.0)), 0.0)
        return self.density * footprint_area(J) * area

    def db23_density(self, R: float) -> float:
        """The facet density N of DB23 (ratio ``R``) that gives the same expected visible glints per
        pixel as this NDF at every footprint and half vector (inverse of :func:`matched_density`)."""
        R = V.real("R", R)
        if not (0 < R <= 1):
            V.fail("R", R, "a number in (0, 1]")
        a2 = self.params["alpha_star"] ** 2
        return self.density * math.pi * VISIBLE_RADIUS**2 * a2 * self.D_normal / R

    def pixel_sampler(self, uv, J, seed: int = 0, wo=None) -> "PixelSampler":
        """Algorithm 2 at one pixel as a direction sampler: ``.sample(size, seed)`` returns
        ``(directions (size, 3), pdf (size,))`` and ``.pdf(directions)`` the density, ``.domain`` says
        where the directions live ("hemisphere": half vectors; "sphere" with ``wo``: reflected
        directions wi and their density per steradian of wi)."""
        return PixelSampler(self, uv, J, seed, wo)


class PixelSampler:
    """One pixel of a KPT25 NDF as a direction sampler (``KPT25.pixel_sampler``)."""

    def __init__(self, ndf: "KPT25", uv, J, seed=0, wo=None):
        self.ndf = ndf
        self.uv = np.asarray(V.as_float_array("uv", uv), float).reshape(-1)
        self.J = np.asarray(V.as_float_array("J", J), float).reshape(-1)
        if self.uv.shape != (2,):
            V.fail("uv", uv, "one texture position (2 numbers)")
        if self.J.shape != (4,):
            V.fail("J", J, "one footprint (4 numbers)")
        self.seed = V.seed(seed)
        self.wo = None
        if wo is not None:
            w = np.asarray(V.as_float_array("wo", wo), float).reshape(-1)
            if w.shape != (3,) or not np.all(np.isfinite(w)) or not np.any(w):
                V.fail("wo", wo, "one nonzero finite direction (3 numbers)")
            w = w / np.abs(w).max()  # scaled first: no overflow or underflow in the norm
            self.wo = w / np.linalg.norm(w)
        self.domain = "hemisphere" if wo is None else "sphere"

    def _tile(self, n):
        return np.tile(self.uv, (n, 1)), np.tile(self.J, (n, 1))

    def sample(self, size: int, seed=0):
        """``size`` independent draws: (directions (size, 3), pdf (size,)); lost draws are NaN with pdf 0
        (with ``wo``, also the draws whose half vector faces away from wo)."""
        size = int(size)
        uv, J = self._tile(size)
        if self.wo is None:
            return self.ndf.sample(uv, J, seed=self.seed, draw_seed=seed)
        _, _, wi = self.ndf.sample(uv, J, seed=self.seed, draw_seed=seed, wo=self.wo)
        # wi is NaN where the draw is lost or its half vector faces away from wo (wo.h <= 0): pdf 0. The
        # others' density is computed from wi itself, as pdf(wi) does (h = normalise(wi + wo), which has
        # wo.h > 0), so that both agree to the bit: near grazing, wi fixes h only to about
        # 1e-16 / (wo.h), and pdf(h) / (4 wo.h) of the drawn h would differ from it by that much.
        reflected = np.isfinite(wi).all(axis=1)
        pdf = np.zeros(size)
        if reflected.any():
            pdf[reflected] = self.pdf(wi[reflected])
        return wi, pdf

    def pdf(self, directions) -> np.ndarray:
        """The density at ``directions`` (..., 3): per steradian of h, or of wi with ``wo``."""
        d = np.asarray(V.as_float_array("directions", directions), float)
        shape = d.shape[:-1]
        d = d.reshape(-1, 3)
        uv, J = self._tile(d.shape[0])
        if self.wo is None:
            return self.ndf.pdf(uv, J, d, seed=self.seed).reshape(shape)
        wi = d / np.linalg.norm(d, axis=1, keepdims=True)
        h = wi + self.wo
        n = np.linalg.norm(h, axis=1)
        ok = n > 1e-12
        h = np.where(ok[:, None], h / np.where(ok, n, 1.0)[:, None], [0.0, 0.0, 1.0])
        p = self.ndf.pdf(uv, J, h, seed=self.seed)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(ok, p / (4 * np.abs(np.sum(wi * h, axis=1))), 0.0).reshape(shape)

    def __repr__(self):
        return f"<KPT25 pixel sampler uv={self.uv.tolist()} J={self.J.tolist()} domain={self.domain!r}>"


class DB23(GlintyNDF):
    """DB23's D_P = (D(n) / R) K / (N P) (eq. 3-4; docs/math/ndf.md#ndf-estimator): K counted by the grid
    scheme configuration ``scheme`` (a name of ``grids.IMAGE_CONFIGS``: "db23_trilinear",
    "db23_tetrahedral", "db23_shader_48", "zk16_aniso", ...) over the inner law ``inner`` for n = N P facets (P = abs(det J)) with
    p = R D(h) / D(n) clamped to 1; ``angular_resolution`` (texels per unit slope) places the half
    vector's slope (h_x, h_y) / h_z in DB23's angular grid. ``density`` is N (facets per unit area).
    The default inner law is DB23's own gated Gaussian; ``inner="binomial"`` is exact but costs far more
    per pixel at large n (about 30x on a receding plane with n up to 1e5)."""

    name = "db23"

    def __init__(self, density: float = 1e6, target: str = "beckmann", alpha: float = 0.5,
                 scheme: str = "db23_trilinear", inner: str = "gated", R: float = 0.5,
                 angular_resolution: float = 16.0, **scheme_params):
        super().__init__(target, alpha, density)
        R = V.real("R", R)
        if not (0 < R <= 1):
            V.fail("R", R, "a number in (0, 1]")
        ares = V.real("angular_resolution", angular_resolution)
        if not (math.isfinite(ares) and ares > 0):
            V.fail("angular_resolution", angular_resolution, "a finite number > 0")
        self.R, self.angular_resolution = R, ares
        V.choice("scheme", scheme, IMAGE_CONFIGS, f"a grid scheme configuration, one of {', '.join(IMAGE_CONFIGS)}")
        # A configuration is a scheme and its options (grids.IMAGE_CONFIGS: e.g. "db23_shader_48" is
        # the tetrahedral scheme with DB23's 48-evaluation interpolation). The finest cell holds one
        # facet on average (base_area 1 / N), as in DB23's renderer, unless given.
        base_scheme, options = IMAGE_CONFIGS[scheme]
        kw = {**options, **scheme_params}
        kw.setdefault("base_area", 1.0 / self.density)
        self.counter = aniso_counter(base_scheme, inner=inner, **kw)
        self.params = {"density": self.density, "target": target, "alpha": self.alpha, "scheme": scheme,
                       "inner": inner if isinstance(inner, str) else getattr(inner, "name", repr(inner)),
                       "R": R, "angular_resolution": ares, **scheme_params}

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D_P per pixel; 0 where the footprint is degenerate (status in ``counts``) or h below the horizon."""
        uv, J, h, shape = pixel_arrays(uv, J, h)
        c = _cos_theta(h)
        p, _ = self.smooth_ndf.success_probability(c, self.R)
        slope = np.clip(angular_slope(h) * self.angular_resolution, -1e9, 1e9)
        counts = self.counter.count_image(uv, J, self.density, p, slope=slope, seed=seed)
        d = self.d_p(counts.K, footprint_area(J), self.R)
        return np.where((counts.status == 0) & (c > 0), d, 0.0)

    def reference(self, uv, J, h, seed: int = 0):
        """DB23 has no point realization to sum: NotImplementedError (its reference is the count's law)."""
        raise NotImplementedError("db23 has no point-process reference; compare D_P with smooth(h) "
                                  "(the convergence study) or with explicit facets")


GLINTY_NDFS.register("kpt25", KPT25)
GLINTY_NDFS.register("db23", DB23)
GLINTY_NDFS.register("smooth", SmoothNDF)
GLINTY_NDFS.register("facets", FacetNDF)


def glinty_ndfs() -> list[str]:
    """Names of the registered glinty NDFs."""
    return GLINTY_NDFS.names()


def glinty_ndf(name: str, **params) -> GlintyNDF:
    """``gl.glinty_ndf("kpt25", density=..., target="beckmann", alpha=0.5, alpha_star=0.02, k=4)`` or
    ``gl.glinty_ndf("db23", density=N, target=..., alpha=..., scheme="db23_trilinear", inner="binomial")``:
    see :class:`KPT25` and :class:`DB23` (and :class:`SmoothNDF`, :class:`FacetNDF`). Unknown names and
    parameters raise ValueError."""
    cls = GLINTY_NDFS.get(name)
    try:
        return cls(**params)
    except TypeError as e:  # an unknown keyword
        raise ValueError(f"glinty_ndf {name!r}: {e}") from None


# --------------------------------------------------------------------------------------------------
# The image methods glintlab ships (the registry itself: method_registry)

def _counted(scheme, inner):
    # DB23's D_P (glinty_ndf "db23") on the scheme's counts, with the scene's angular texel.
    return lambda m: glinty_ndf("db23", density=m.density, target=m.target, alpha=m.alpha, scheme=scheme, inner=inner,
                                R=m.R, angular_resolution=1.0 / m.angular_texel)


_DOC = "docs/math/glint_images.md#glint-methods"  # the table of the methods glintlab ships
register_image_method("truth", lambda m: FacetNDF(m.density, m.target, m.alpha, R=m.R, angular_texel=m.angular_texel),
                      label="ground truth (facets)", truth=True, doc=_DOC)
register_image_method("smooth", lambda m: SmoothNDF(m.target, m.alpha), label="smooth D(h)", doc=_DOC)
for _scheme, _short in (("db23_trilinear", "DB23 tri"), ("db23_tetrahedral", "DB23 tet")):
    for _inner in ("gated", "binomial", "head_cf"):
        register_image_method(f"{_scheme}[{_inner}]", _counted(_scheme, _inner), label=f"{_short} {_inner}", doc=_DOC)
# DB23's shader configuration: tetrahedral, log LOD, realizations blended over 3 simplex vertices x 4 angular
# texels (48 evaluations): glints fade in and out instead of popping (docs/math/grids.md#grid-realizations).
register_image_method("db23_shader_48[gated]", _counted("db23_shader_48", "gated"), label="DB23 shader 48 gated",
                      doc=_DOC)
register_image_method("zk16", _counted("zk16_aniso", "zk16"), label="ZK16", doc=_DOC)
# KPT25's constant-time NDF (Algorithm 1: k = 4 angular neighbours, eps = 0.1) over its own point
# process, whose density K_P is matched to the facet truth's expected glint count (docs/math/glinty_ndf.md#glinty-matched).
# Its own truth, the reference, leaves out lobes that move a pixel by less than IMAGE_REFERENCE_TOL x D(h)
# x W / K_P (docs/math/glinty_ndf.md#glinty-reference-reach): 1e-6, far below the 2 D(h) at which a pixel
# counts as a glint and the viewer's 2^-8 relative precision, and 40 % less CPU than 1e-15 on the report's
# camera paths, with the same flicker tables (the 1e-15 sums' pops; its std and mean ratios within 3e-11).
IMAGE_REFERENCE_TOL = 1e-6
register_image_method("kpt25", lambda m: glinty_ndf("kpt25", density=m.density, target=m.target, alpha=m.alpha,
                                                    alpha_star=0.02, k=4, epsilon=0.1,
                                                    reference_tol=IMAGE_REFERENCE_TOL),
                      label="KPT25", truth="reference", doc=_DOC,
                      density=lambda m: matched_density(m.density, 0.02, m.target, m.alpha, m.R))
