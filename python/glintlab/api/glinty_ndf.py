"""Glinty NDFs as a renderer evaluates them: one value D^f per pixel (footprint, half vector).

Two estimators of the same smooth target ``gl.ndf(target, alpha)``, each registered by name
(``glinty_ndfs()``):

- ``"kpt25"``: Kemppinen et al. 2025's point process and constant-time evaluation (their Algorithm 1),
  with ``reference`` the full sum over every point of the same realization (docs/math/glinty_ndf.md).
  C++ (``_core.Kpt25Ndf``), pixels split over the OpenMP threads, deterministic per pixel.
- ``"db23"``: DB23's D_P = (D(n) / R) K / (N P) of eq. 3-4, with K counted by a grid scheme over an
  inner law (``aniso_counter(...).count_image``), docs/math/ndf.md#ndf-estimator.

Shapes: ``uv`` (..., 2) texture positions, ``J`` (..., 4) = (du/dx, dv/dx, du/dy, dv/dy) per pixel as in
``AnisoCounter.count_image``, ``h`` (..., 3) half vectors in the tangent frame (normal +z; normalised
here; h_z <= 0 gives 0). The result has shape (...).
"""
from __future__ import annotations

import math

import numpy as np

from .. import _core
from . import checks as V
from .grids import IMAGE_CONFIGS, aniso_counter
from .ndf import NDFS
from .ndf import ndf as smooth_ndf
from .registry import Registry

GLINTY_NDFS = Registry("glinty NDF")


def _arrays(uv, J, h):
    # One bad-input contract for every glinty NDF and image method (docs/math/glinty_ndf.md#glinty-inputs).
    return V.pixel_arrays(uv, J, h)


def _cos_theta(h):
    return V.unit_vectors(h)[..., 2]


class GlintyNDF:
    """Common surface of the glinty NDFs: ``name``, ``target``, ``alpha``, ``density``, ``params`` and
    ``smooth(h)``, the target D(h) the estimator converges to."""

    name = ""

    def __init__(self, target: str, alpha: float, density: float):
        if not isinstance(target, str) or target not in NDFS:
            V.fail("target", target, f"one of {', '.join(NDFS)}")
        self.target = target
        self.smooth_ndf = smooth_ndf(target, alpha)
        self.alpha = self.smooth_ndf.alpha
        density = V.real("density", density)
        if not (math.isfinite(density) and density > 0):
            V.fail("density", density, "a finite number > 0 (points per unit texture area)")
        self.density = density
        self.params: dict = {}

    def smooth(self, h) -> np.ndarray:
        """The smooth target D(h) for half vectors ``h`` (..., 3)."""
        h = V.as_float_array("h", h)
        if h.ndim < 1 or h.shape[-1] != 3:
            V.fail("h", f"an array of shape {h.shape}", "an array of shape (..., 3)")
        return self.smooth_ndf.D(_cos_theta(h))

    def label(self) -> str:
        """A short label: the name and the parameters."""
        return self.name + "[" + ",".join(f"{k}={v}" for k, v in self.params.items()) + "]"

    def __repr__(self):
        args = "".join(f", {k}={v!r}" for k, v in self.params.items())
        return f"glintlab.glinty_ndf({self.name!r}{args})"


class KPT25(GlintyNDF):
    """KPT25's glinty NDF (docs/math/glinty_ndf.md).

    ``density`` K_P (points per unit texture area), ``target`` and ``alpha`` (the smooth NDF),
    ``alpha_star`` (micro-roughness), ``k`` (angular neighbours per level: 1, 4, 9, 16), ``epsilon``
    (eq. 8's mollification; 0 = exact roulette), ``filter`` (Gaussian pixel filter std in pixels; the
    default 1 / (2 sqrt(pi)) gives an effective area abs(det J), DB23's footprint), ``compensation``
    ("square": eq. 10 as the paper does; "disk": eq. 9 exactly; "none"; "square_flipped": a deliberately
    wrong sign, for the tests) and ``blend`` ("roulette" or "linear")."""

    name = "kpt25"

    def __init__(self, density: float = 1e6, target: str = "beckmann", alpha: float = 0.5, alpha_star: float = 0.02,
                 k: int = 4, epsilon: float = 0.1, filter: float = 0.5 / math.sqrt(math.pi),
                 compensation: str = "square", blend: str = "roulette"):
        super().__init__(target, alpha, density)
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or int(k) not in (1, 4, 9, 16):
            V.fail("k", k, "1, 4, 9 or 16")
        for pname, value in (("compensation", compensation), ("blend", blend)):
            if not isinstance(value, str):
                V.fail(pname, value, "a string")
        self._core = _core.Kpt25Ndf(self.density, target, self.alpha, V.real("alpha_star", alpha_star), int(k),
                                    V.real("epsilon", epsilon), V.real("filter", filter), compensation, blend)
        self.params = {"density": self.density, "target": target, "alpha": self.alpha,
                       "alpha_star": float(alpha_star), "k": int(k), "epsilon": float(epsilon),
                       "filter": float(filter), "compensation": compensation, "blend": blend}

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        """D^f per pixel by Algorithm 1 (B(k) per level, compensation, two levels with the roulette).
        Constant time per pixel; the same realization as ``reference`` for the same ``seed``."""
        uv, J, h, shape = _arrays(uv, J, h)
        return self._core.evaluate(uv.reshape(-1), J.reshape(-1), h.reshape(-1), V.seed(seed)).reshape(shape)

    def reference(self, uv, J, h, seed: int = 0, return_points: bool = False):
        """The full sum of eq. 11's first term over every point of the same realization whose position
        falls in the filter (both levels, same roulette; no truncation to B(k), no compensation). With
        ``return_points``, also the number of points summed per pixel. Its cost grows with the number
        of points in the footprint."""
        uv, J, h, shape = _arrays(uv, J, h)
        d, pts = self._core.reference(uv.reshape(-1), J.reshape(-1), h.reshape(-1), V.seed(seed))
        return (d.reshape(shape), pts.reshape(shape)) if return_points else d.reshape(shape)

    def expected(self, J, h) -> tuple[np.ndarray, np.ndarray]:
        """Exact expectations over realizations, (E[reference], E[evaluate]), per footprint and half
        vector: D(h) times the lobe's mass in the disk, and the same with B(k) and the compensation."""
        _, J, h, shape = _arrays(None, J, h)
        er, ea = self._core.expected(J.reshape(-1), h.reshape(-1))
        return er.reshape(shape), ea.reshape(shape)

    def pixel(self, J, h) -> dict:
        """The set-up of one pixel: D(h), T(h) = (xa, ya), the angular std sigma, the fractional MIP level
        lambda, its levels and weights, the filter's box half widths."""
        _, J, h, _ = _arrays(None, np.reshape(J, (1, 4)), np.reshape(h, (1, 3)))
        return self._core.pixel(J.reshape(-1), h.reshape(-1))


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
        if not isinstance(scheme, str) or scheme not in IMAGE_CONFIGS:
            V.fail("scheme", scheme, f"a grid scheme configuration, one of {', '.join(IMAGE_CONFIGS)}")
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
        uv, J, h, shape = _arrays(uv, J, h)
        c = _cos_theta(h)
        p, _ = self.smooth_ndf.success_probability(c, self.R)
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = np.where(c[..., None] > 0, h[..., :2] / np.where(c > 0, h[..., 2], 1.0)[..., None], 0.0)
        slope = np.clip(slope * self.angular_resolution, -1e9, 1e9)
        counts = self.counter.count_image(uv, J, self.density, p, slope=slope, seed=seed)
        P = np.abs(J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2])
        with np.errstate(invalid="ignore", divide="ignore"):
            d = self.smooth_ndf.D_normal / self.R * counts.K / (self.density * P)
        return np.where((counts.status == 0) & (c > 0), d, 0.0)

    def reference(self, uv, J, h, seed: int = 0):
        """DB23 has no point realization to sum: NotImplementedError (its reference is the count's law)."""
        raise NotImplementedError("db23 has no point-process reference; compare D_P with smooth(h) "
                                  "(the convergence study) or with explicit facets")


GLINTY_NDFS.register("kpt25", KPT25)
GLINTY_NDFS.register("db23", DB23)


def glinty_ndfs() -> list[str]:
    """Names of the registered glinty NDFs."""
    return GLINTY_NDFS.names()


def glinty_ndf(name: str, **params) -> GlintyNDF:
    """``gl.glinty_ndf("kpt25", density=..., target="beckmann", alpha=0.5, alpha_star=0.02, k=4)`` or
    ``gl.glinty_ndf("db23", density=N, target=..., alpha=..., scheme="db23_trilinear", inner="binomial")``:
    see :class:`KPT25` and :class:`DB23`. Unknown names and parameters raise ValueError."""
    cls = GLINTY_NDFS.get(name)
    try:
        return cls(**params)
    except TypeError as e:  # an unknown keyword
        raise ValueError(f"glinty_ndf {name!r}: {e}") from None
