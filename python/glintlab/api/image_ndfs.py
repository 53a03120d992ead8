"""Glinty NDFs as an image renderer evaluates them: ``evaluate(uv, J, h, seed)`` -> NDF value per pixel
(docs/math/glint_images.md).

Every evaluator here takes, per pixel, the texture position ``uv`` (..., 2), the footprint Jacobian ``J``
(..., 4) = (du/dx, dv/dx, du/dy, dv/dy) as ``AnisoCounter.count_image`` takes it, and the half vector
``h`` (..., 3) in the surface's tangent frame (x along the u axis, z the shading normal), and returns
the NDF term per pixel (shape ``uv.shape[:-1]``):

``SmoothNDF``    the target D(h) itself (no glints)
``FacetNDF``     the ground truth: stratified facets of density N counted one by one in the footprint
                 ellipse (C++, :func:`facet_counts`), D_P = (D(n) / R) K / (N P) (DB23 eq. 4-6)

A grid scheme with an inner counting law (DB23 trilinear or tetrahedral, ZK16) is the same D_P with K from
``AnisoCounter.count_image``: ``glinty_ndf("db23", scheme=..., inner=...)`` (``glintlab.api.glinty_ndf``),
with ``angular_resolution = 1 / angular_texel``.

Counting methods share DB23's success probability p = min(R D(h) / D(n), 1) and the angular texel of a
pixel, ``floor(slope / angular_texel)`` with slope (h_x / h_z, h_y / h_z): a facet's reflection uniform
is drawn per texel, so a glint lives while h stays in its texel.

>>> import numpy as np, glintlab as gl
>>> from glintlab.api.image_ndfs import FacetNDF
>>> f = FacetNDF(density=1e4, target="beckmann", alpha=0.5)
>>> uv = np.array([[0.3, 0.4]]); J = np.array([[0.05, 0.0, 0.0, 0.05]]); h = np.array([[0.0, 0.0, 1.0]])
>>> float(f.evaluate(uv, J, h, seed=1)[0]) >= 0
True
"""
from __future__ import annotations

import math

import numpy as np

from .. import _core
from . import checks as V
from .ndf import ndf as get_ndf

FACET_STATUS = {0: "ok", 1: "degenerate", 2: "non_finite", 4: "too_large"}


def facet_counts(uv, J, p, density, slope=None, seed: int = 0, max_cells: float = 2.0**26):
    """Ground-truth counts per pixel: the facets of the stratified layout of density ``density`` (one
    jittered facet per cell of side 1 / sqrt(N)) inside each pixel's footprint ellipse that reflect
    (their uniform, drawn per angular texel ``floor(slope)``, is below ``p``).

    Returns (K, status, tested) shaped like ``uv[..., 0]``: K (NaN where the ellipse spans more than
    ``max_cells`` cells), status (0 ok, 1 degenerate, 2 non_finite, 4 too_large; ``FACET_STATUS``) and
    the facets tested. Same seed, same counts, whatever the number of threads."""
    uv, J, shape = _pixels(uv, J)
    pa = np.ascontiguousarray(V.as_float_array("p", p))
    if pa.size != 1 and pa.shape != shape:
        V.fail("p", f"an array of shape {pa.shape}", f"a scalar or an array of shape {shape}")
    sl = None
    if slope is not None:
        sl = np.ascontiguousarray(V.as_float_array("slope", slope))
        if sl.shape != uv.shape:
            V.fail("slope", f"an array of shape {sl.shape}", f"an array of shape {uv.shape}")
        sl = sl.reshape(-1)
    k, st, tested = _core.facet_counts(V.real("density", density), pa.reshape(-1), uv.reshape(-1), J.reshape(-1),
                                       sl, V.seed(seed), V.real("max_cells", max_cells))
    return k.reshape(shape), st.reshape(shape), tested.reshape(shape)


def _pixels(uv, J):
    uv = np.ascontiguousarray(V.as_float_array("uv", uv))
    J = np.ascontiguousarray(V.as_float_array("J", J))
    if uv.ndim < 1 or uv.shape[-1:] != (2,):
        V.fail("uv", f"an array of shape {uv.shape}", "an array of shape (..., 2)")
    if J.shape != uv.shape[:-1] + (4,):
        V.fail("J", f"an array of shape {J.shape}", f"an array of shape {uv.shape[:-1] + (4,)}")
    return uv, J, uv.shape[:-1]


def _method_inputs(uv, J, h):
    """(uv, J, unit h, shape) under the one bad-input contract of every glinty NDF and image method
    (``checks.pixel_arrays``, docs/math/glinty_ndf.md#glinty-inputs)."""
    uv, J, h, shape = V.pixel_arrays(uv, J, h)
    return uv, J, V.unit_vectors(h), shape


class SmoothNDF:
    """The smooth target D(h) (``gl.ndf(target, alpha)``) as an image method: what the glints converge
    to, with no glints and no flicker."""

    def __init__(self, target: str = "beckmann", alpha: float = 0.5):
        self.ndf = get_ndf(target, alpha)
        self.target, self.alpha = target, self.ndf.alpha

    def __repr__(self):
        return f"SmoothNDF({self.target!r}, alpha={self.alpha:g})"

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D(h) per pixel (uv, J and seed are accepted for the common signature and unused)."""
        _, _, hn, _ = _method_inputs(uv, J, h)
        V.seed(seed)
        return self.ndf.D(hn[..., 2])


class _CountingNDF:
    """D_P = (D(n) / R) K / (N P) of DB23 eq. 4-6 from per-pixel counts K (subclasses count)."""

    def __init__(self, density, target, alpha, R, angular_texel):
        self.density = V.real("density", density)
        if not (math.isfinite(self.density) and self.density > 0):
            V.fail("density", density, "a finite facet density > 0")
        self.ndf = get_ndf(target, alpha)
        self.target, self.alpha = target, self.ndf.alpha
        self.R = V.real("R", R)
        if not (0 < self.R <= 1):
            V.fail("R", R, "a number in (0, 1]")
        self.angular_texel = V.real("angular_texel", angular_texel)
        if not (math.isfinite(self.angular_texel) and self.angular_texel > 0):
            V.fail("angular_texel", angular_texel, "a finite angular texel size > 0 (slope units)")

    def inputs(self, uv, J, h):
        """(uv, J, p, slope in texels, P = |det J|, shape) of the pixels."""
        uv, J, hn, shape = _method_inputs(uv, J, h)
        cos = hn[..., 2]
        p = np.minimum(self.R * self.ndf.D(cos) / self.ndf.D_normal, 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = np.where(cos[..., None] > 0, hn[..., :2] / cos[..., None], 0.0) / self.angular_texel
        slope = np.clip(slope, -1e9, 1e9)
        P = np.abs(J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2])
        return uv, J, p, slope, P, shape

    def from_counts(self, K, P) -> np.ndarray:
        """D_P from counts and footprint areas (0 where the footprint is empty or K unknown)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            d = self.ndf.D_normal / self.R * K / (self.density * P)
        return np.where(np.isfinite(d), d, 0.0)

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D_P per pixel (see the module docstring)."""
        uv, J, p, slope, P, _ = self.inputs(uv, J, h)
        return self.from_counts(self.counts(uv, J, p, slope, V.seed(seed)), P)


class FacetNDF(_CountingNDF):
    """The ground truth: explicit stratified facets counted in each footprint ellipse (:func:`facet_counts`)."""

    def __init__(self, density, target: str = "beckmann", alpha: float = 0.5, R: float = 0.5,
                 angular_texel: float = 0.05, max_cells: float = 2.0**26):
        super().__init__(density, target, alpha, R, angular_texel)
        self.max_cells = V.real("max_cells", max_cells)

    def __repr__(self):
        return f"FacetNDF(density={self.density:g}, {self.target!r}, alpha={self.alpha:g}, R={self.R:g})"

    def counts(self, uv, J, p, slope, seed):
        """K per pixel (see :func:`facet_counts`)."""
        return facet_counts(uv, J, p, self.density, slope, seed, self.max_cells)[0]
