"""Blending a counting law between LOD levels (docs/math/blends.md; DB23 §3-4, KPT25 §3.3.3, WB16 §3.2).

Level l has cells of area ``A_l = base_area * level_ratio**l`` (any integer l; ratio 4 for mip
levels, the default, or 2 as DB23 eq. 13 prints). A footprint of area P lies between
``A_lo <= P < A_hi``; ``w = log_ratio(P / A_lo)`` is its fractional LOD and
``w_area = (P - A_lo) / (A_hi - A_lo)`` DB23's area weight. With b the inner law:

``nearest``      ``K = (P / A_l) b(N A_l, p)`` at the nearer level (WB16 stepping; pops)
``zk16_linear``  ``K = P [(1 - w) b(N A_lo, p) / A_lo + w b(N A_hi, p) / A_hi]`` (ZK16; ghosting)
``distributed``  ``K = b((1 - w_area) N A_lo, p) + b(w_area N A_hi, p)`` (DB23 eq. 10)
``roulette``     each reflecting facet of a level kept with the level's weight (KPT25 eq. 8;
                 ``epsilon=0`` hard, ``epsilon=0.1`` KPT25's mollified default)

Each level draws from its own cells: ``sample`` gives independent samples (sample i sits in cell i
at every level); ``sample_at`` evaluates at texture positions, so pixels in one level cell and
successive frames share random numbers (the coherence a renderer sees).

>>> import glintlab as gl
>>> bl = gl.blended_law("distributed", inner="binomial")
>>> d = bl.pmf(4096, 2.5 / 64, 0.1)      # exactly Binomial(160, 0.1): integer trial counts
>>> gl.distance(d, gl.law("binomial").pmf(160, 0.1), "tv") < 1e-12
True
>>> bl.sample(4096, 2.5 / 64, 0.1, size=10**5, seed=1).mean()
16.0
"""
from __future__ import annotations

import numpy as np

from .. import _core
from . import checks as V
from .laws import CustomLaw, Law
from .laws import law as get_law


class BlendedLaw:
    """A blend rule, an inner single-footprint law and a level ladder. Use ``glintlab.blended_law``."""

    def __init__(self, core, inner):
        self._core = core
        self._inner = inner

    name = property(lambda self: self._core.name)
    params = property(lambda self: dict(self._core.params))
    inner = property(lambda self: self._inner, doc="The inner law (a glintlab Law).")
    level_ratio = property(lambda self: self._core.level_ratio)
    base_area = property(lambda self: self._core.base_area)
    has_pmf = property(lambda self: self._core.has_pmf)

    @property
    def binning(self) -> str:
        """"none" when K is always an integer, else "round" (samples binned by ``bin``, as ``pmf`` is)."""
        return self._core.binning

    def bin(self, samples) -> np.ndarray:
        x = np.asarray(samples, dtype=np.float64)
        return np.floor(x + 0.5) if self.binning == "round" else x

    def __repr__(self):
        args = "".join(f", {k}={val!r}" for k, val in self.params.items())
        return (f"glintlab.blended_law({self.name!r}, inner={self._inner.name!r}, level_ratio={self.level_ratio:g}, "
                f"base_area={self.base_area:g}{args})")

    def at_density(self, N) -> "_AtDensity":
        """A law-like view of this blend at facet density N: ``.pmf(n, p)`` and ``.sample(n, p, size,
        seed)`` with P = n / N (plugs into ``studies.db23_figure9.figure9``, which compares laws of (n, p))."""
        return _AtDensity(self, _density(N))

    def variance_ratio(self, P) -> np.ndarray:
        """Var[K] / Var[Binomial(N P, p)] with an exact binomial inner law, as the rule declares it
        (zk16_linear: P [(1 - w)^2 / A_lo + w^2 / A_hi]; nearest: P / A_l; distributed: 1; NaN where
        the rule has no closed form, as for roulette). Broadcasts over P."""
        P = V.as_float_array("P", P)
        if not np.all(np.isfinite(P) & (P > 0)):
            V.fail("P", P, "finite areas > 0")
        return np.asarray(self._core.variance_ratio(P), dtype=np.float64)

    def levels(self, P) -> dict:
        """Where area P sits: level index, area_lo, area_hi, w_lod and w_area."""
        return dict(self._core.bracket(_number("P", P)))

    def pmf(self, N, P, p, max_support: int = 50_000_000):
        """Exact law of K at scalar (N, P, p) (binned to integers when ``binning == "round"``).

        NotImplementedError when the inner law has no exact law or gives non-integer counts, and for
        the mollified roulette (its K has a continuous part).
        """
        V.integer("max_support", max_support, minimum=1)
        return self._core.pmf(_density(N), _number("P", P), _number("p", p), int(max_support))

    def sample(self, N, P, p, size=None, seed=None, out=None) -> np.ndarray:
        """Independent draws of K. N is a scalar density; P and p broadcast numpy-style with ``size``.

        Sample i draws level l from the cell keyed by (seed, i, l): the same output whatever the
        number of threads. ``out``: a preallocated float64 array of the output's shape, filled in
        place and returned (as ``Law.sample``'s).
        """
        shape = V.size(size)
        seed = V.seed(seed)
        Pf, pf, shape = V.broadcast_params(P, p, shape)
        count = int(np.prod(shape, dtype=np.int64))
        flat = None if out is None else V.out_array(out, shape)
        result = self._core.sample(_density(N), Pf, pf, count, seed, out=flat)
        return out if out is not None else result.reshape(shape)

    def sample_at(self, N, P, p, x, y, seed=0, out=None) -> np.ndarray:
        """K for footprints of area P centred at texture positions (x, y) (arrays broadcast together).

        Level l's count comes from the cell (floor(x / s_l), floor(y / s_l)), s_l = sqrt(A_l), of the
        seed's realization: fixed seed and position give the same K in every frame, and moving across
        a cell edge draws a new cell (what a renderer's grid does). ``out``: a preallocated float64 array
        of the broadcast shape, filled in place and returned.
        """
        seed = V.seed(seed)
        arrays = [V.as_float_array(name, a) for name, a in (("P", P), ("p", p), ("x", x), ("y", y))]
        try:
            shape = np.broadcast_shapes(*(a.shape for a in arrays))
        except ValueError:
            raise ValueError("P, p, x and y do not broadcast together: shapes "
                             f"{[a.shape for a in arrays]}; expected numpy-compatible shapes") from None
        flat = [a.reshape(1) if a.size == 1 else np.ascontiguousarray(np.broadcast_to(a, shape)).ravel()
                for a in arrays]
        count = int(np.prod(shape, dtype=np.int64))
        target = None if out is None else V.out_array(out, shape)
        result = self._core.sample_at(_density(N), *flat, count, seed, out=target)
        return out if out is not None else result.reshape(shape)


class _AtDensity:
    def __init__(self, blend, N):
        self._blend, self._N = blend, N
        self.name = f"{blend.name}[{blend.inner.name}]"
        self.params = {"N": N}

    def pmf(self, n, p):
        return self._blend.pmf(self._N, _number("n", n) / self._N, p)

    def sample(self, n, p, size=None, seed=None):
        return self._blend.bin(self._blend.sample(self._N, np.asarray(n, dtype=np.float64) / self._N, p,
                                                  size=size, seed=seed))


def blended_law(name: str, inner="binomial", level_ratio: float = 4, base_area: float = 1.0, **params) -> BlendedLaw:
    """The blend ``name`` (see ``blends()``) over ``inner`` (a law name, a ``gl.law(...)`` or a
    ``gl.custom_law``) on levels of area ``base_area * level_ratio**l``. Extra keyword parameters go to
    the blend (``roulette``: ``epsilon``)."""
    if not isinstance(name, str):
        V.fail("name", name, "a blend name (str)")
    ratio = _number("level_ratio", level_ratio)
    base = _number("base_area", base_area)
    if isinstance(inner, str):
        inner = get_law(inner)
    if isinstance(inner, CustomLaw):
        def fn(n, p, u, _law=inner):
            return _law._call(n, p, u)
        core = _core.make_blended_law_custom(name, params, fn, inner.n_uniforms, inner.name, ratio, base)
    elif isinstance(inner, Law):
        core = _core.make_blended_law(name, params, inner._core, ratio, base)
    else:
        V.fail("inner", inner, "a law name, a glintlab.law(...) or a glintlab.custom_law(...)")
    return BlendedLaw(core, inner)


def blends() -> list[str]:
    """Names of the blend rules: distributed, nearest, roulette, zk16_linear."""
    return sorted(name for name, _ in _core.blend_infos())


def blend_summaries() -> dict[str, str]:
    return dict(sorted(_core.blend_infos()))


def roulette_keep_moments(weight: float, epsilon: float = 0.1) -> tuple[float, float]:
    """E[R] and E[R^2] of KPT25's mollified keep weight R(r, weight), r ~ U(0, 1) (eq. 8)."""
    w, e = _number("weight", weight), _number("epsilon", epsilon)
    if not 0 <= w <= 1:
        V.fail("weight", weight, "a number in [0, 1]")
    if not 0 <= e <= 0.5:
        V.fail("epsilon", epsilon, "a number in [0, 0.5]")
    m1, m2 = _core.roulette_moments(w, e)
    return float(m1), float(m2)


def zk16_variance_ratio(P, level_ratio: float = 4, base_area: float = 1.0):
    """Var[K_zk16] / Var[Binomial(N P, p)] for a binomial inner law: P [(1 - w)^2 / A_lo + w^2 / A_hi]
    (the analytic variance deficit of output blending; 1 on the levels, lowest near w = 1/2).
    The zk16_linear rule's own ``variance_ratio``, declared with it in core/blends/zk16_linear.cpp."""
    return blended_law("zk16_linear", inner="binomial", level_ratio=level_ratio,
                       base_area=base_area).variance_ratio(P)


def _number(name, value):
    x = V.real(name, value)
    if not np.isfinite(x):
        V.fail(name, value, "a finite real number")
    return x


def _density(N):
    x = _number("N", N)
    if x < 0:
        V.fail("N", N, "a facet density >= 0")
    return x
