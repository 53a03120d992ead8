"""Anisotropic pixel footprints and the virtual grids that count glints in them (docs/math/grids.md).

A pixel's footprint is the ellipse its UV derivatives span: area ``P``, ratio ``r >= 1`` of its
semi-axes, orientation ``phi`` (radians, major axis, modulo pi). A grid scheme distributes the count
over a few virtual grids; an ``AnisoCounter`` evaluates a scheme with an inner counting law:

``db23_trilinear``    DB23 §5.2: 8 grids of the (scale, ratio, orientation) cell, trilinear weights
``db23_tetrahedral``  DB23 §6.1: the cell cut into 9 tetrahedra, 4 grids with barycentric weights
``zk16_aniso``        ZK16: min(ceil r, 16) isotropic mip probes along the major axis, widened beyond

Scheme parameters (keywords of ``aniso_counter``): ``level_ratio`` (4) and ``base_area`` (1) of the
scale levels; for DB23 ``scale_weights`` ("area": DB23 eq. 10, or "log": the public shader's
frac(lod)), ``ratio_weights`` ("linear", the shader, or "log"), ``orientation_step`` (22.5 degrees at
ratio 2, halved per ratio level), ``max_ratio`` (2**20); for ZK16 ``max_aniso`` (16) and ``blend``
("zk16_linear" or "distributed").

Realizations may be interpolated (docs/math/grids.md#grid-realizations): ``spatial`` "none", "square" (4 corners, bilinear) or
"simplex" (3 vertices, barycentric; DB23 §6.2), ``angular`` "none" or "bilinear" (4 texels, DB23
eq. 14), combined by ``realization`` "blend" (weights v_j: mean kept, variance times sum v_j^2, DB23)
or "select" (one vertex with probability v_j: the marginal law kept exactly).

>>> import glintlab as gl
>>> c = gl.aniso_counter("db23_tetrahedral", inner="binomial", base_area=1 / 1024**2)
>>> t = c.terms(1024**2, 50 / 1024**2, r=3, phi=0.3)  # grids, weights and trial counts
>>> t[["scale_level", "ratio_level", "orientation", "weight", "trials"]].round(3)
   scale_level  ratio_level  orientation  weight  trials
0            2            1            1   0.500  16.000
1            2            2            1   0.472  30.215
2            2            2            2   0.014   0.896
3            3            2            2   0.014   3.556
>>> c.pmf(1024**2, 50 / 1024**2, 3, 0.3, p=0.1).mean   # exact law of K
5.0667
>>> c.mean_bias(1024**2, 50 / 1024**2, 3, 0.3)          # sum of trials / (N P): 1 conserves the count
1.0133
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .. import _core
from . import checks as V
from .laws import CustomLaw, Law
from .laws import law as get_law

STATUS = {0: "ok", 1: "degenerate", 2: "non_finite", 3: "clamped"}
# What DB23 §6 says each configuration costs per pixel (binomial evaluations).
DB23_EVALUATIONS = {"trilinear (10 grids, 4 spatial, 4 angular)": 160, "tetrahedral, square": 64,
                    "tetrahedral, simplex": 48}


def grid_schemes() -> list[str]:
    """Names of the registered grid schemes."""
    return sorted(name for name, _ in _core.grid_scheme_infos())


def grid_scheme_summaries() -> dict[str, str]:
    return dict(_core.grid_scheme_infos())


def footprint_shapes(J) -> pd.DataFrame:
    """Footprint ellipses of Jacobians ``J`` (..., 4) = (du/dx, dv/dx, du/dy, dv/dy), one row each:
    P (area, the image of a unit pixel), a >= b (semi-axes), r = a / b, phi (major axis, radians in
    [0, pi)) and status ("ok", "degenerate": det J = 0 or r > 1e12, "non_finite"). Never raises on a
    bad Jacobian: a renderer's silhouettes produce them, so they are reported per row."""
    j = np.ascontiguousarray(np.asarray(J, dtype=np.float64))
    if j.shape[-1:] != (4,):
        V.fail("J", f"an array of shape {j.shape}", "an array of shape (..., 4)")
    shapes, status = _core.footprint_shapes(j.reshape(-1, 4))
    df = pd.DataFrame(shapes, columns=["P", "a", "b", "r", "phi"])
    df["status"] = pd.Categorical([STATUS[int(s)] for s in status], categories=list(STATUS.values()))
    return df


@dataclass
class ImageCounts:
    """Output of ``AnisoCounter.count_image``: arrays shaped like the image."""
    K: np.ndarray             # counts (0 where the footprint is degenerate or non-finite)
    evaluations: np.ndarray   # inner-law evaluations per pixel
    status: np.ndarray        # 0 ok, 1 degenerate, 2 non_finite, 3 clamped (see STATUS)

    def evaluation_histogram(self) -> pd.Series:
        """Pixels per evaluation count."""
        values, counts = np.unique(self.evaluations, return_counts=True)
        return pd.Series(counts, index=pd.Index(values, name="evaluations"), name="pixels")

    def status_counts(self) -> dict[str, int]:
        values, counts = np.unique(self.status, return_counts=True)
        return {STATUS[int(v)]: int(c) for v, c in zip(values, counts)}


class AnisoCounter:
    """A grid scheme evaluated with an inner law. Use ``glintlab.aniso_counter``."""

    def __init__(self, core, inner, spatial, angular, realization):
        self._core = core
        self._inner = inner
        self.spatial, self.angular, self.realization = spatial, angular, realization

    scheme = property(lambda self: self._core.scheme_name)
    params = property(lambda self: dict(self._core.scheme_params))
    inner = property(lambda self: self._inner)
    has_pmf = property(lambda self: self._core.has_pmf)
    evaluations_per_term = property(lambda self: self._core.evaluations_per_term)

    @property
    def binning(self) -> str:
        """"none" when K is an integer, else "round" (``bin`` rounds half up, as the study does)."""
        return "none" if self._core.integer_output else "round"

    def bin(self, samples) -> np.ndarray:
        x = np.asarray(samples, dtype=np.float64)
        return np.floor(x + 0.5) if self.binning == "round" else x

    def label(self) -> str:
        extra = "".join(f",{k}={v}" for k, v in sorted(self._user_params.items())) if self._user_params else ""
        interp = "" if (self.spatial, self.angular) == ("none", "none") else \
            f"/{self.spatial}+{self.angular}:{self.realization}"
        return f"{self.scheme}{extra}{interp}"

    _user_params: dict = {}

    def __repr__(self):
        args = "".join(f", {k}={v!r}" for k, v in self.params.items())
        return (f"glintlab.aniso_counter({self.scheme!r}, inner={self._inner.name!r}, spatial={self.spatial!r}, "
                f"angular={self.angular!r}, realization={self.realization!r}{args})")

    def terms(self, N, P, r, phi) -> pd.DataFrame:
        """The grids one footprint's count is distributed over: one row per term (scale, ratio and
        orientation level, cell sizes, probe offset, weight, trial count, output scale)."""
        rows, clamped = self._core.terms(float(N), float(P), float(r), float(phi))
        df = pd.DataFrame(rows)
        df.attrs["clamped"] = clamped
        return df

    def mean_bias(self, N, P, r, phi) -> float:
        """E[K] / (N P p) for an inner law with mean n p: sum of scale * trials over N P. 1 when the
        scheme conserves the expected count."""
        t = self.terms(N, P, r, phi)
        return float((t["scale"] * t["trials"]).sum() / (float(N) * float(P)))

    def evaluations(self, N, P, r, phi) -> int:
        """Inner-law evaluations for one pixel with this footprint."""
        return len(self.terms(N, P, r, phi)) * self.evaluations_per_term

    def pmf(self, N, P, r, phi, p, max_support: int = 50_000_000):
        """Exact law of K (selected or no realizations, independent terms, an exact integer inner
        law); NotImplementedError otherwise."""
        return self._core.pmf(float(N), float(P), float(r), float(phi), float(p), int(max_support))

    def sample(self, N, P, r, phi, p, size: int, seed: int = 0, out=None) -> np.ndarray:
        """``size`` realizations of K for one footprint, each on fresh grids at a random position and
        angular coordinate. Same seed, same output, whatever the number of threads. ``out``: a
        preallocated float64 array of shape ``size``, filled in place and returned."""
        shape = V.size(size) or ()
        count = int(np.prod(shape)) if shape else 1
        flat = None if out is None else V.out_array(out, shape)
        res = self._core.sample(V.real("N", N), V.real("P", P), V.real("r", r), V.real("phi", phi),
                                V.real("p", p), count, V.seed(seed), out=flat)
        if out is not None:
            return out
        return res.reshape(shape) if shape else res[0]

    def count_image(self, uv, J, N, p, slope=None, seed: int = 0) -> ImageCounts:
        """Counts of a whole image: ``uv`` (H, W, 2) texture positions, ``J`` (H, W, 4) Jacobians
        (du/dx, dv/dx, du/dy, dv/dy), ``p`` a scalar or (H, W), ``slope`` (H, W, 2) angular coordinates
        in texels (default 0). Every pixel reads the same grids (``seed``), so neighbours share cells."""
        uv = np.ascontiguousarray(np.asarray(uv, dtype=np.float64))
        J = np.ascontiguousarray(np.asarray(J, dtype=np.float64))
        if uv.shape[-1:] != (2,):
            V.fail("uv", f"an array of shape {uv.shape}", "an array of shape (..., 2)")
        if J.shape != uv.shape[:-1] + (4,):
            V.fail("J", f"an array of shape {J.shape}", f"an array of shape {uv.shape[:-1] + (4,)}")
        shape = uv.shape[:-1]
        pa = np.ascontiguousarray(np.asarray(p, dtype=np.float64))
        V.scalar_or_shape("p", pa, shape)
        sl = None
        if slope is not None:
            sl = np.ascontiguousarray(np.asarray(slope, dtype=np.float64))
            if sl.shape != uv.shape:
                V.fail("slope", f"an array of shape {sl.shape}", f"an array of shape {uv.shape}")
            sl = sl.reshape(-1)
        k, ev, st = self._core.count_pixels(V.real("N", N), pa.reshape(-1), uv.reshape(-1), J.reshape(-1), sl,
                                            V.seed(seed))
        return ImageCounts(k.reshape(shape), ev.reshape(shape), st.reshape(shape))


def aniso_counter(scheme: str, inner="binomial", spatial: str = "none", angular: str = "none",
                  realization: str = "select", **params) -> AnisoCounter:
    """The grid scheme ``scheme`` (see ``grid_schemes()``) with ``inner`` (a law name, ``gl.law(...)``
    or ``gl.custom_law``); keyword parameters go to the scheme (see the module docstring)."""
    if not isinstance(scheme, str):
        V.fail("scheme", scheme, "a grid scheme name (str)")
    for name, value in (("spatial", spatial), ("angular", angular), ("realization", realization)):
        if not isinstance(value, str):
            V.fail(name, value, "a string")
    if isinstance(inner, str):
        inner = get_law(inner)
    if isinstance(inner, CustomLaw):
        def fn(n, p, u, _law=inner):
            return _law._call(n, p, u)
        core = _core.make_aniso_counter_custom(scheme, params, fn, inner.n_uniforms, inner.name, spatial, angular,
                                               realization)
    elif isinstance(inner, Law):
        core = _core.make_aniso_counter(scheme, params, inner._core, spatial, angular, realization)
    else:
        V.fail("inner", inner, "a law name, a glintlab.law(...) or a glintlab.custom_law(...)")
    counter = AnisoCounter(core, inner, spatial, angular, realization)
    counter._user_params = dict(params)
    return counter


def ellipse_axes(P: float, r: float) -> tuple[float, float]:
    """Semi-axes (a, b) of the ellipse of area P and ratio r."""
    return math.sqrt(P * r / math.pi), math.sqrt(P / (r * math.pi))


# Named configurations of the grid schemes that the studies and the scene profiles compare:
# label -> (scheme, keyword arguments of aniso_counter)
CONFIGS = {
    "db23_trilinear": ("db23_trilinear", {}),
    "db23_tetrahedral": ("db23_tetrahedral", {}),
    "db23_trilinear[log lod]": ("db23_trilinear", {"scale_weights": "log"}),
    "db23_tetrahedral[log lod]": ("db23_tetrahedral", {"scale_weights": "log"}),
    "db23_shader_48": ("db23_tetrahedral", {"scale_weights": "log", "spatial": "simplex", "angular": "bilinear",
                                            "realization": "blend"}),
    "zk16_aniso": ("zk16_aniso", {}),
}
# The image timing adds DB23's costliest variant: 8 grids x 4 square corners x 4 angular texels.
IMAGE_CONFIGS = {**CONFIGS, "db23_trilinear_128": ("db23_trilinear", {"spatial": "square", "angular": "bilinear",
                                                                      "realization": "blend"})}


def configured_counter(label, law, N):
    """The counter of a named configuration (a label of ``IMAGE_CONFIGS``, or a (scheme, keyword
    arguments) pair) with inner law ``law`` at facet density N (base_area 1 / N)."""
    scheme, kwargs = {**IMAGE_CONFIGS}[label] if isinstance(label, str) else label
    kw = dict(kwargs)
    opts = {k: kw.pop(k) for k in ("spatial", "angular", "realization") if k in kw}
    return aniso_counter(scheme, inner=law, base_area=1.0 / N, **opts, **kw)
