"""WWH18's filterable discrete-flake model beside its truth, JHY14's discrete flakes (docs/math/wwh18.md).

``gl.glinty_ndf("wwh18", density=N, target="beckmann", alpha=0.5, gamma=6, lambda_seeding="node",
threshold_test="printed", T=16)``:

- ``reference_counts(uv, J, h, seed)``: the truth's count per pixel, the flakes of a Poisson process of
  density N in the footprint parallelogram (J's columns around uv, area abs(det J)) whose normal, drawn
  from D(m)(m.n), lies in the cone of half-angle ``gamma`` degrees around h. Its exact law is
  Poisson(N abs(det J) p_gamma(h)) (``expected_count``; docs/math/wwh18.md#wwh18-truth).
- ``counts(uv, J, h, seed)``: the model's count: P from the table (Sec. 4.2-4.3), Algorithm 1's spatial
  traversal over the same flakes' cells (eq. 8-9), and the filtered count N abs(det J) P above ``T``
  (eq. 10). Real valued (fractional overlaps).
- ``evaluate`` / ``reference``: the same counts as D-hat, count / (N abs(det J) sigma(gamma) h.n), which
  converges to the target D(h) as gamma -> 0 (docs/math/wwh18.md#wwh18-normalisation); sigma(gamma) =
  4 pi sin^2(gamma / 2), the cone's solid angle.

Every reading of the printed text is an option: ``lambda_seeding`` ("node" as printed, "flake", or
"pixel": eq. 8's lambda(x) as one lambda per pixel), ``cone`` ("half_vector": the normal within gamma of
h, eq. 4's Omega_h; "outgoing": the reflection of wi within gamma of wo, Sec. 4.1's cone, dpf="exact"),
``threshold_test`` ("printed": H(lambda - P); "flipped": H(P - lambda)), ``error_eps`` (the error
criterion), ``rng`` ("tea" as the paper, or "philox"), ``dpf`` ("table" or "exact": p_gamma by quadrature),
``table_res`` (degrees), ``lod`` ("table2": the level of the paper's Table 2 for alpha; "none"; or a
level in degrees) and ``storage`` ("float32": 6.00 MB at 1 degree, the paper's 5.7 read in MiB; or "float64").

>>> import glintlab as gl
>>> w = gl.glinty_ndf("wwh18", density=1e4, alpha=0.3, gamma=6, dpf="exact", threshold_test="flipped")
>>> J = [[0.05, 0, 0, 0.05]]; h = [[0.1, 0, 1]]
>>> float(w.expected_count(J, h)[0]) > 0
True
>>> w.counts([[0.5, 0.5]], J, h, seed=1).shape
(1,)
"""
from __future__ import annotations

import functools
import math

import numpy as np

from .. import _core
from . import checks as V
from .glinty_ndf import GLINTY_NDFS, GlintyNDF, pixel_arrays, register_image_method

# The paper's Table 2: the blur level (degrees) used for each roughness.
TABLE2_LOD = ((0.05, 1.0), (0.1, 2.0), (0.5, 10.0), (0.8, 30.0))
LOD_LEVELS = (1.0, 2.0, 5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 90.0)


def table2_lod(alpha: float) -> float:
    """The hierarchy level for roughness ``alpha`` by the paper's Table 2: its rows interpolated (and
    extrapolated) linearly in (log alpha, log level), then the largest of the 9 levels not above that
    (docs/math/wwh18.md#wwh18-lod). The paper also lets the light's frequency choose; glintlab has no
    light, so roughness alone decides."""
    la = np.log([a for a, _ in TABLE2_LOD])
    ll = np.log([lv for _, lv in TABLE2_LOD])
    x = math.log(alpha)
    k = int(np.clip(np.searchsorted(la, x) - 1, 0, len(la) - 2))
    y = ll[k] + (ll[k + 1] - ll[k]) * (x - la[k]) / (la[k + 1] - la[k])
    target = math.exp(y)
    below = [lv for lv in LOD_LEVELS if lv <= target * (1 + 1e-12)]
    return below[-1] if below else LOD_LEVELS[0]


def _directions(name, x):
    """A contiguous float array of shape (..., 3) of finite, nonzero vectors (ValueError otherwise)."""
    x = np.ascontiguousarray(V.as_float_array(name, x))
    if x.ndim < 1 or x.shape[-1] != 3:
        V.fail(name, f"an array of shape {x.shape}", "an array of shape (..., 3)")
    if not np.isfinite(x).all():
        V.fail(name, x[~np.isfinite(x)][0], "finite directions")
    if np.any(np.linalg.norm(x, axis=-1) == 0):
        V.fail(name, "a zero vector", "nonzero directions")
    return x


class WWH18(GlintyNDF):
    """WWH18's filterable model and JHY14's discrete-flake truth on the same flakes (module docstring,
    docs/math/wwh18.md)."""

    name = "wwh18"
    #: Why ``gl.light_response`` finds the model's glints in place where its truth's move: a property of the
    #: model as printed, whatever the reading (docs/math/wwh18.md#wwh18-light), named in the check's note.
    static_glints = ("WWH18's test lights a flake when its lambda, drawn per node (or flake, or pixel) whatever the "
                     "directions, is below P(wi, wo), a smooth function of h: the flakes lit at one h are those lit at "
                     "another of larger P, so a move of h only changes how many of the same flakes show, by |dP| / P, "
                     "and one that keeps P (around the normal) none (docs/math/wwh18.md#wwh18-light)")

    def __init__(self, density: float = 1e6, target: str = "beckmann", alpha: float = 0.5, gamma: float = 6.0,
                 lambda_seeding: str = "node", threshold_test: str = "printed", T: float = 16.0,
                 rng: str = "tea", tea_rounds: int = 4, error_eps: float = 0.0, flakes_per_cell: float = 4.0,
                 dpf: str = "table", table_res: float = 1.0, lod="table2", storage: str = "float32",
                 cone: str = "half_vector"):
        super().__init__(target, alpha, density)
        V.choice("lambda_seeding", lambda_seeding, ("node", "flake", "pixel"))
        V.choice("cone", cone, ("half_vector", "outgoing"))
        if cone == "outgoing" and dpf != "exact":
            V.fail("cone", cone, "'half_vector' with dpf='table' (the outgoing cone's table is not built: "
                   "dpf='exact'; docs/math/wwh18.md#wwh18-cone)")
        V.choice("threshold_test", threshold_test, ("printed", "flipped"))
        V.choice("rng", rng, ("tea", "philox"))
        V.choice("dpf", dpf, ("table", "exact"))
        V.choice("storage", storage, ("float32", "float64"))
        V.integer("tea_rounds", tea_rounds, expected="an integer in [1, 64]")
        if isinstance(lod, str):
            V.choice("lod", lod, ("table2", "none"))
            lod_deg = table2_lod(self.alpha) if lod == "table2" else 0.0
        else:
            lod_deg = V.real("lod", lod)
            if lod_deg not in LOD_LEVELS:
                V.fail("lod", lod, "'table2', 'none' or one of " + ", ".join(f"{v:g}" for v in LOD_LEVELS))
        T = V.real("T", T)
        if not (T > 0):
            V.fail("T", T, "a number > 0 (math.inf: never filter)")
        self.gamma = V.real("gamma", gamma)
        self.lod_deg = lod_deg
        self._core = _core.Wwh18Ndf(self.density, target, self.alpha, self.gamma, V.real("flakes_per_cell", flakes_per_cell),
                                    lambda_seeding, threshold_test, rng, int(tea_rounds), V.real("error_eps", error_eps),
                                    T, dpf, V.real("table_res", table_res), lod_deg, storage == "float32", cone)
        # sigma(Omega) of eq. 3: the cone's solid angle, 4 pi sin^2(gamma / 2) (2 pi (1 - cos gamma)
        # without its cancellation, which made it 0 below 1e-7 degrees).
        self.cone_solid_angle = self._core.cone_solid_angle
        self.cone = cone
        self.params = {"density": self.density, "target": target, "alpha": self.alpha, "gamma": self.gamma,
                       "lambda_seeding": lambda_seeding, "threshold_test": threshold_test, "T": T, "rng": rng,
                       "tea_rounds": int(tea_rounds), "error_eps": float(error_eps),
                       "flakes_per_cell": float(flakes_per_cell), "dpf": dpf, "table_res": float(table_res),
                       "lod": lod, "storage": storage, "cone": cone}

    # --- counts -------------------------------------------------------------------------------------
    def _wi(self, wi, shape):
        if wi is None:
            return None
        w = _directions("wi", wi)
        if w.shape != shape + (3,):
            V.fail("wi", f"an array of shape {w.shape}", f"an array of shape {shape + (3,)}")
        return w.reshape(-1)

    def reference_counts(self, uv, J, h, seed: int = 0, wi=None) -> np.ndarray:
        """The discrete-flake truth's count per pixel (integers; law Poisson(``expected_count``)). ``wi``
        (..., 3): the light direction, used by ``cone="outgoing"`` (default wi = h, so wo = h)."""
        uv, J, h, shape = pixel_arrays(uv, J, h)
        return self._core.reference_counts(uv.reshape(-1), J.reshape(-1), h.reshape(-1), V.seed(seed),
                                           self._wi(wi, shape)).reshape(shape)

    def counts(self, uv, J, h, seed: int = 0, wi=None) -> np.ndarray:
        """The model's count per pixel: Algorithm 1 below ``T``, N abs(det J) P above. ``wi`` (..., 3): the
        light direction for the table's look-up (default: wi = h, i.e. theta_i = theta_o, dphi = 0)."""
        return self.counts_detail(uv, J, h, seed, wi)["count"]

    def counts_detail(self, uv, J, h, seed: int = 0, wi=None) -> dict:
        """``counts`` with, per pixel, ``mode`` (0 zero, 1 traversal, 2 filtered) and the ``p`` used."""
        uv, J, h, shape = pixel_arrays(uv, J, h)
        c, mode, p = self._core.counts(uv.reshape(-1), J.reshape(-1), h.reshape(-1), self._wi(wi, shape), V.seed(seed))
        return {"count": c.reshape(shape), "mode": mode.reshape(shape), "p": p.reshape(shape)}

    def _norm(self, J, h, wi=None):
        """N abs(det J) sigma(gamma) h.n, over 4 wi.h with the outgoing cone (the Jacobian that takes the
        cone of outgoing directions to its normals: its normals' mass is D(h)(h.n) sigma / (4 wi.h))."""
        area = np.abs(J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2])
        hn = h / np.linalg.norm(h, axis=-1, keepdims=True)
        norm = self.density * area * self.cone_solid_angle * hn[..., 2]
        if self.cone == "outgoing":
            w = hn if wi is None else np.asarray(wi, float) / np.linalg.norm(wi, axis=-1, keepdims=True)
            norm = norm / (4 * np.abs(np.sum(w * hn, axis=-1)))
        return norm, hn[..., 2]

    def evaluate(self, uv, J, h, seed: int = 0, wi=None) -> np.ndarray:
        """The model's D-hat: ``counts`` / (N abs(det J) sigma(gamma) h.n) (times 4 wi.h with the outgoing
        cone); 0 below the horizon."""
        _, Jc, hc, _ = pixel_arrays(uv, J, h)
        norm, hz = self._norm(Jc, hc, wi)
        c = self.counts(uv, J, h, seed, wi)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(hz > 0, c / norm, 0.0)

    def reference(self, uv, J, h, seed: int = 0, wi=None) -> np.ndarray:
        """The truth's D-hat: ``reference_counts`` / (N abs(det J) sigma(gamma) h.n) (times 4 wi.h with the
        outgoing cone); 0 below the horizon."""
        _, Jc, hc, _ = pixel_arrays(uv, J, h)
        norm, hz = self._norm(Jc, hc, wi)
        c = self.reference_counts(uv, J, h, seed, wi)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(hz > 0, c / norm, 0.0)

    # --- exact quantities ---------------------------------------------------------------------------
    def cone_mass(self, h) -> np.ndarray:
        """p_gamma(h): the mass of D(m)(m.n) in the cone of half-angle gamma around h (quadrature)."""
        h = _directions("h", h)
        return self._core.cone_mass(h.reshape(-1)).reshape(h.shape[:-1])

    def outgoing_cone_mass(self, wi, wo) -> np.ndarray:
        """The outgoing-cone reading's P: the mass of D(m)(m.n) over the normals that reflect ``wi`` into
        the cone of half-angle gamma around ``wo`` (quadrature over that cone; docs/math/wwh18.md#wwh18-cone)."""
        wi = _directions("wi", wi)
        wo = _directions("wo", wo)
        if wi.shape != wo.shape:
            V.fail("wo", f"an array of shape {wo.shape}", f"the shape of wi, {wi.shape}, ending in 3")
        return self._core.outgoing_cone_mass(wi.reshape(-1), wo.reshape(-1)).reshape(wi.shape[:-1])

    def expected_count(self, J, h, wi=None) -> np.ndarray:
        """The truth's exact mean N abs(det J) p_gamma(h) (its law is Poisson with this mean); with
        ``cone="outgoing"``, p is the outgoing cone's mass for the light ``wi`` (default h) and wo its
        reflection about h."""
        _, J, h, shape = pixel_arrays(None, J, h)
        area = np.abs(J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2])
        hz = h[..., 2]
        if self.cone == "outgoing":
            hn = h / np.linalg.norm(h, axis=-1, keepdims=True)
            w = hn if wi is None else _directions("wi", wi) / np.linalg.norm(wi, axis=-1, keepdims=True)
            wo = 2 * np.sum(w * hn, axis=-1, keepdims=True) * hn - w
            p = self.outgoing_cone_mass(np.broadcast_to(w, hn.shape), wo)
        else:
            p = self.cone_mass(h)
        return np.where(hz > 0, self.density * area * p, 0.0)

    def p(self, h) -> np.ndarray:
        """The P the model uses for half vectors ``h`` (table look-up with wi = h, or p_gamma)."""
        h = _directions("h", h)
        return self._core.model_p(h.reshape(-1)).reshape(h.shape[:-1])

    def dpf(self, wi, wo) -> np.ndarray:
        """P(wi, wo) from the (blurred) table by trilinear interpolation (0 without a table)."""
        wi = _directions("wi", wi)
        wo = _directions("wo", wo)
        if wi.shape != wo.shape:
            V.fail("wo", f"an array of shape {wo.shape}", f"the shape of wi, {wi.shape}, ending in 3")
        return self._core.dpf(wi.reshape(-1), wo.reshape(-1)).reshape(wi.shape[:-1])

    def accumulated(self, h) -> np.ndarray:
        """Sec. 4.2's accumulation at h itself: the table cells' masses within gamma of h (no interpolation)."""
        h = _directions("h", h)
        return self._core.accumulated(h.reshape(-1)).reshape(h.shape[:-1])

    def pixel_lambda(self, seed: int, u: float, v: float) -> float:
        """lambda(x) of the pixel at (u, v) with ``lambda_seeding="pixel"`` (Philox on the bits of u, v)."""
        return float(self._core.pixel_lambda(V.seed(seed), V.real("u", u), V.real("v", v)))

    def lambdas(self, seed: int, level: int, i, j, k: int = 0) -> np.ndarray:
        """lambda of nodes (level, i, j) and flake index k as the model draws it (TEA or Philox)."""
        i = np.ascontiguousarray(i, dtype=np.int64)
        j = np.ascontiguousarray(j, dtype=np.int64)
        return self._core.lambdas(V.seed(seed), int(level), i.reshape(-1), j.reshape(-1), int(k)).reshape(i.shape)

    @property
    def cell_side(self) -> float:
        """Side of a base cell (flakes_per_cell / N = its area)."""
        return self._core.cell_side

    @property
    def table_shape(self) -> tuple:
        """(theta_i, theta_o, dphi) nodes of the table ((0, 0, 0) with ``dpf="exact"``)."""
        return tuple(self._core.table_shape)

    @property
    def table_bytes(self) -> int:
        """The table's size at its storage precision."""
        return self._core.table_bytes


GLINTY_NDFS.register("wwh18", WWH18)


# WWH18 as an image method: the filterable model at the scene's flake density, read against its own
# discrete-flake truth on the same flakes (``reference``; docs/math/glint_images.md#glint-own-truth).
# The threshold test is the flipped reading (a flake counts when lambda < P): the printed H(lambda - P)
# counts with probability 1 - P and renders the surface 1 / p_gamma too bright away from the highlight
# (docs/math/wwh18.md#wwh18-threshold-test; measured on the scenes: mean 125-275 x the smooth render).
# Its table takes seconds to build: one evaluator per material (a frozen, hashable dataclass) is kept.
# Not in the scene images' default panel (the report's flicker and timing tables): rendered on request.
@functools.lru_cache(maxsize=8)
def _wwh18_image_method(material) -> WWH18:
    return WWH18(density=material.density, target=material.target, alpha=material.alpha, threshold_test="flipped")


register_image_method("wwh18", _wwh18_image_method, label="WWH18 (flipped test)", truth="reference", panel=False,
                      doc="docs/math/glint_images.md#glint-methods")
