"""Direction samplers with their pdfs, registered by name (docs/math/sampling.md#reference-samplers).

A sampler is any object with ``domain`` ("hemisphere", "sphere", "disk" or "square"), ``sample(size,
seed) -> (points, pdf)`` and ``pdf(points) -> density``; ``gl.sampler_test`` accepts one in place of the
two callables. The registered ones are the anchors and controls of the harness:

- ``"beckmann"``, ``"ggx"``: half vectors drawn from D(h) (h . n) by inverting the marginal of theta
  (Walter et al. 2007), pdf D(h) (h . n) per steradian of h;
- ``"ggx_vndf"``, ``"beckmann_vndf"``: visible normals for an outgoing direction ``wo``, pdf
  G1(wo) max(0, wo . h) D(h) / (wo . n): GGX by Heitz 2018's hemisphere-section construction,
  Beckmann by sampling the visible slopes in the standard configuration (exact rejection, below);
- ``"vmf_mixture"``: a synthetic spiky pdf, equal-weight von Mises-Fisher lobes a fraction of a degree
  wide on the hemisphere, the stand-in for a glinty pixel's pdf.

``wrong_sampler(s, kind)`` makes the deliberately wrong variants the tests must see rejected.
Random numbers: numpy's Philox generator keyed by the seed (one stream, single-threaded), so the same
seed gives the same points on any machine and thread count.
"""
from __future__ import annotations

import math
import pathlib

import numpy as np

from . import checks as V
from .ndf import NDF
from .registry import Registry

SAMPLERS = Registry("sampler")
DOMAINS = ("hemisphere", "sphere", "disk", "square")


def _rng(seed):
    return np.random.Generator(np.random.Philox(V.seed(seed)))


def _size(size) -> int:
    shape = V.size(size)
    if shape is None or len(shape) != 1:
        V.fail("size", size, "an integer >= 0")
    return shape[0]


def _points(points, dim: int) -> np.ndarray:
    p = V.as_float_array("points", points)
    if p.ndim != 2 or p.shape[1] != dim:
        V.fail("points", f"an array of shape {p.shape}", f"an array of shape (size, {dim})")
    return p


def _unit(name, value) -> np.ndarray:
    w = V.as_float_array(name, value).reshape(-1)
    if w.size != 3 or not np.isfinite(w).all() or not np.linalg.norm(w) > 0:
        V.fail(name, value, "a direction (x, y, z) with z > 0")
    w = w / np.linalg.norm(w)
    if not w[2] > 0:
        V.fail(name, value, "a direction (x, y, z) with z > 0")
    return w


def register_sampler(cls):
    """Registers a :class:`Sampler` subclass under its ``name`` (a class decorator: the class is the one
    entry, carrying its ``summary``, its ``doc`` section and the ``wrong_variants`` it declares, all the
    generic tests and the harness read); returns the class."""
    if not (isinstance(cls, type) and issubclass(cls, Sampler)) or not cls.name:
        V.fail("cls", cls, "a Sampler subclass with a name")
    SAMPLERS.register(cls.name, cls)
    return cls


class Sampler:
    """Common surface: ``name``, ``domain``, ``params``, ``sample(size, seed)``, ``pdf(points)``, ``doc``
    (the section of the docs naming it), and ``wrong_variants``: the deliberately wrong variants
    ``wrong_sampler(s, kind)`` builds of this sampler, declared by its class (the tests, ``glintlab
    sampler --wrong`` and the report run exactly these). Losing samples (``"drop_0.1%"``) wraps any
    sampler; a class adds the variants its parameters allow (``"alpha+2%"`` needs
    ``with_params(alpha=...)``, ``"no_jacobian"`` a microfacet pdf with its (h . n))."""

    name = ""
    domain = "hemisphere"
    summary = ""
    wrong_variants: tuple = ("drop_0.1%",)
    #: The section documenting the sampler (a page and its anchor); a registered sampler's names it.
    doc = "docs/math/sampling.md#reference-samplers"

    def __init__(self):
        self.params: dict = {}

    def with_params(self, **changes) -> "Sampler":
        """The same sampler with some parameters changed (``alpha+2%`` draws from one). By default the
        class is called with ``params`` updated, which holds where ``params`` are its constructor's."""
        try:
            return type(self)(**{**self.params, **changes})
        except TypeError as exc:  # a class whose params are not its constructor's arguments
            raise ValueError(f"sampler {self.name!r} cannot be rebuilt with {changes}: {exc}") from None

    def sample(self, size, seed=0):
        raise NotImplementedError

    def pdf(self, points):
        raise NotImplementedError

    def label(self) -> str:
        return self.name + "[" + ",".join(f"{k}={_fmt(v)}" for k, v in self.params.items()) + "]"

    def __repr__(self):
        args = "".join(f", {k}={_fmt(v)}" for k, v in self.params.items())
        return f"glintlab.sampler({self.name!r}{args})"


def _fmt(v):
    if isinstance(v, (tuple, list)):
        return "(" + ", ".join(f"{x:.6g}" if isinstance(x, float) else str(x) for x in v) + ")"
    return f"{v:.6g}" if isinstance(v, float) else repr(v)


def _cos(h):
    return h[:, 2] / np.maximum(np.linalg.norm(h, axis=1), 1e-300)


class _Microfacet(Sampler):
    ndf_name = ""
    wrong_variants = ("alpha+2%", "no_jacobian", "drop_0.1%")

    def __init__(self, alpha: float = 0.3):
        super().__init__()
        self.ndf = NDF(self.ndf_name, alpha)
        self.alpha = self.ndf.alpha
        self.params = {"alpha": self.alpha}


class NormalSampler(_Microfacet):
    """Half vectors from D(h) (h . n): the marginal of theta inverted, phi uniform (Walter et al. 2007)."""

    def sample(self, size, seed=0):
        n = _size(size)
        u = _rng(seed).random((n, 2))
        a2 = self.alpha * self.alpha
        if self.ndf_name == "ggx":
            tan2 = a2 * u[:, 0] / (1.0 - u[:, 0])            # eq. 35 of Walter et al. in tan^2 form
        else:
            tan2 = -a2 * np.log1p(-u[:, 0])                   # eq. 28
        cos = 1.0 / np.sqrt(1.0 + tan2)
        sin = np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
        phi = 2.0 * math.pi * u[:, 1]
        h = np.stack([sin * np.cos(phi), sin * np.sin(phi), cos], axis=1)
        return h, self.pdf(h)

    def pdf(self, points):
        c = _cos(_points(points, 3))
        return self.ndf.D(c) * np.maximum(c, 0.0)


@register_sampler
class BeckmannNormals(NormalSampler):
    name, ndf_name = "beckmann", "beckmann"
    summary = "Beckmann half vectors from D(h)(h.n) (Walter et al. 2007)"


@register_sampler
class GGXNormals(NormalSampler):
    name, ndf_name = "ggx", "ggx"
    summary = "GGX half vectors from D(h)(h.n) (Walter et al. 2007)"


class _VisibleNormals(_Microfacet):
    def __init__(self, alpha: float = 0.3, wo=(0.6, 0.0, 0.8)):
        super().__init__(alpha)
        self.wo = _unit("wo", wo)
        self.params["wo"] = tuple(float(x) for x in self.wo)

    def pdf(self, points):
        h = _points(points, 3)
        c = _cos(h)
        hn = h / np.maximum(np.linalg.norm(h, axis=1), 1e-300)[:, None]
        return self.ndf.G1(self.wo[2]) * np.maximum(hn @ self.wo, 0.0) * self.ndf.D(c) / self.wo[2]


@register_sampler
class GGXVisibleNormals(_VisibleNormals):
    """Heitz 2018: stretch wo to the alpha = 1 configuration, where the visible normals are uniform over
    the projected hemisphere: a uniform point of the unit disk, its second coordinate compressed onto
    the part of the disk the hemisphere projects to, lifted onto the hemisphere, unstretched."""

    name, ndf_name = "ggx_vndf", "ggx"
    summary = "GGX visible normals for wo (Heitz 2018)"

    def sample(self, size, seed=0):
        n = _size(size)
        u = _rng(seed).random((n, 2))
        a = self.alpha
        v = np.array([a * self.wo[0], a * self.wo[1], self.wo[2]])
        v /= np.linalg.norm(v)
        lensq = v[0] ** 2 + v[1] ** 2
        t1 = np.array([-v[1], v[0], 0.0]) / math.sqrt(lensq) if lensq > 0 else np.array([1.0, 0.0, 0.0])
        t2 = np.cross(v, t1)
        r = np.sqrt(u[:, 0])
        phi = 2.0 * math.pi * u[:, 1]
        p1, p2 = r * np.cos(phi), r * np.sin(phi)
        s = 0.5 * (1.0 + v[2])
        p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + s * p2
        p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
        nh = p1[:, None] * t1 + p2[:, None] * t2 + p3[:, None] * v
        h = np.stack([a * nh[:, 0], a * nh[:, 1], np.maximum(nh[:, 2], 0.0)], axis=1)
        h /= np.linalg.norm(h, axis=1)[:, None]
        return h, self.pdf(h)


@register_sampler
class BeckmannVisibleNormals(_VisibleNormals):
    """Visible Beckmann normals in the slope domain (docs/math/sampling.md#beckmann-visible-normals).

    In the stretched configuration (alpha = 1, wo at angle theta in the xz-plane) the visible slopes
    (x, y) have density proportional to (cot theta - x)_+ exp(-x^2 - y^2): y is Gaussian with variance
    1/2, and x is drawn by exact rejection from the proposal (cot theta + |x|) exp(-x^2), a mixture of
    a Gaussian and of |x| exp(-x^2) (|x| = sqrt(-log u)); its acceptance rate is at least 1/2. The
    slopes are then rotated to wo's azimuth, unstretched by alpha, and h = (-x, -y, 1) normalised."""

    name, ndf_name = "beckmann_vndf", "beckmann"
    summary = "Beckmann visible normals for wo (slope-domain rejection, exact)"

    def sample(self, size, seed=0):
        n = _size(size)
        rng = _rng(seed)
        a = self.alpha
        v = np.array([a * self.wo[0], a * self.wo[1], self.wo[2]])
        v /= np.linalg.norm(v)
        sin_t = math.hypot(v[0], v[1])
        cos_p, sin_p = (v[0] / sin_t, v[1] / sin_t) if sin_t > 0 else (1.0, 0.0)
        mu = v[2] / sin_t if sin_t > 1e-12 else math.inf
        x = np.empty(n)
        todo = np.arange(n)
        while todo.size:
            m = todo.size
            if math.isinf(mu):
                x[todo] = rng.normal(0.0, math.sqrt(0.5), m)
                break
            # mixture weights: the Gaussian part has mass mu sqrt(pi), the |x| exp(-x^2) part mass 1
            gauss = rng.random(m) < mu * math.sqrt(math.pi) / (mu * math.sqrt(math.pi) + 1.0)
            prop = np.where(gauss, rng.normal(0.0, math.sqrt(0.5), m),
                            np.sqrt(-np.log(rng.random(m))) * np.where(rng.random(m) < 0.5, -1.0, 1.0))
            accept = rng.random(m) * (mu + np.abs(prop)) < np.maximum(mu - prop, 0.0)
            x[todo[accept]] = prop[accept]
            todo = todo[~accept]
        y = rng.normal(0.0, math.sqrt(0.5), n)
        sx, sy = a * (cos_p * x - sin_p * y), a * (sin_p * x + cos_p * y)
        h = np.stack([-sx, -sy, np.ones(n)], axis=1)
        h /= np.linalg.norm(h, axis=1)[:, None]
        return h, self.pdf(h)


@register_sampler
class VMFMixture(Sampler):
    """Equal-weight von Mises-Fisher lobes on the hemisphere: ``lobes`` lobes of angular width
    ``width_deg`` (kappa = 1 / width^2), centres between ``theta_deg`` = (min, max) polar angles.
    ``layout="random"`` draws the centres from ``layout_seed``; ``"cell_centres"`` puts them at the
    centres of distinct cells of a 30 x 60 (theta, phi) grid (the fixed-grid comparison of the tests
    and the report). ``shift_deg`` moves each lobe the *sampler* draws from by that angle in a random
    direction while ``pdf`` keeps the true centres: a deliberately wrong lobe position."""

    name = "vmf_mixture"
    domain = "hemisphere"
    summary = "a spiky pdf: von Mises-Fisher lobes a fraction of a degree wide"

    def __init__(self, lobes: int = 200, width_deg: float = 0.3, theta_deg=(5.0, 80.0), layout: str = "random",
                 layout_seed: int = 7, shift_deg: float = 0.0):
        super().__init__()
        V.integer("lobes", lobes, 1, 10**5)
        width = V.real("width_deg", width_deg)
        if not (0.01 <= width <= 30.0):
            V.fail("width_deg", width_deg, "a number in [0.01, 30] (degrees)")
        th = V.as_float_array("theta_deg", theta_deg).reshape(-1)
        if th.size != 2 or not (0.0 <= th[0] < th[1] <= 85.0):
            V.fail("theta_deg", theta_deg, "(min, max) with 0 <= min < max <= 85 degrees")
        if layout not in ("random", "cell_centres"):
            V.fail("layout", layout, "'random' or 'cell_centres'")
        shift = V.real("shift_deg", shift_deg)
        if not (0.0 <= shift <= 30.0):
            V.fail("shift_deg", shift_deg, "a number in [0, 30] (degrees)")
        rng = np.random.Generator(np.random.Philox(V.seed(layout_seed)))
        if layout == "random":
            z = rng.uniform(math.cos(math.radians(th[1])), math.cos(math.radians(th[0])), lobes)
            theta = np.arccos(z)
            phi = rng.uniform(0.0, 2.0 * math.pi, lobes)
        else:
            rows = [i for i in range(30) if th[0] <= 3.0 * i and 3.0 * (i + 1) <= th[1]]
            cells = [(i, j) for i in rows for j in range(60)]
            if len(cells) < lobes:
                V.fail("lobes", lobes, f"at most {len(cells)} lobes for layout 'cell_centres' in theta_deg = {tuple(th)}")
            pick = rng.choice(len(cells), lobes, replace=False)
            theta = np.radians([3.0 * cells[k][0] + 1.5 for k in pick])
            phi = np.radians([6.0 * cells[k][1] + 3.0 for k in pick])
        self.centres = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
        self.kappa = 1.0 / math.radians(width) ** 2
        self.sample_centres = self.centres
        self._frames = None
        if shift > 0:
            t1, t2 = _frames(self.centres)
            ang = rng.uniform(0.0, 2.0 * math.pi, lobes)
            d = math.radians(shift)
            c = math.cos(d) * self.centres + math.sin(d) * (np.cos(ang)[:, None] * t1 + np.sin(ang)[:, None] * t2)
            self.sample_centres = c / np.linalg.norm(c, axis=1)[:, None]
        self.params = {"lobes": int(lobes), "width_deg": width, "theta_deg": (float(th[0]), float(th[1])),
                       "layout": layout, "layout_seed": int(layout_seed), "shift_deg": shift}

    def sample(self, size, seed=0):
        n = _size(size)
        rng = _rng(seed)
        lobe = rng.integers(0, len(self.centres), n)
        u = rng.random((n, 2))
        k = self.kappa
        w = 1.0 + np.log(u[:, 0] + (1.0 - u[:, 0]) * math.exp(-2.0 * k)) / k   # cos of the angle to the centre
        r = np.sqrt(np.maximum(0.0, 1.0 - w * w))
        phi = 2.0 * math.pi * u[:, 1]
        # Tangent frames per lobe, computed once: x = w mu + r (cos phi t1 + sin phi t2) is unit to
        # rounding.
        if self._frames is None:
            self._frames = _frames(self.sample_centres)
        t1, t2 = self._frames
        c, s = r * np.cos(phi), r * np.sin(phi)
        x = w[:, None] * self.sample_centres[lobe] + c[:, None] * t1[lobe] + s[:, None] * t2[lobe]
        return x, self.pdf(x)

    def pdf(self, points):
        p = _points(points, 3)
        k = self.kappa
        norm = k / (2.0 * math.pi * -math.expm1(-2.0 * k)) / len(self.centres)
        table, ns, nt = self._lookup()
        # Each point sees only the lobes whose cap (where a lobe is within exp(-50) of its peak) meets
        # its cell of a (cos theta, phi) grid: a few lobes instead of all of them.
        z = np.clip(p[:, 2], 0.0, 1.0)
        t = np.arctan2(p[:, 1], p[:, 0]) / (2.0 * math.pi) % 1.0
        cell = np.minimum((z * ns).astype(np.int64), ns - 1) * nt + np.minimum((t * nt).astype(np.int64), nt - 1)
        out = np.zeros(len(p))
        for col in range(table.shape[1]):
            lobe = table[cell, col]
            use = np.nonzero(lobe >= 0)[0]
            if use.size == 0:
                continue
            d = np.einsum("ij,ij->i", p[use], self.centres[lobe[use]])
            out[use] += np.exp(np.minimum(k * (d - 1.0), 0.0)) * (d > 1.0 - 50.0 / k)
        out *= norm
        return np.where(np.isfinite(p).all(axis=1) & (p[:, 2] >= 0), out, 0.0)

    def _lookup(self):
        """For each cell of a ns x nt grid over (cos theta, phi / 2 pi), the lobes whose cap can reach
        it (a conservative box in cos theta and phi around each cap), padded with -1."""
        if getattr(self, "_table", None) is not None:
            return self._table
        ns, nt = 128, 256
        rho = math.acos(max(-1.0, 1.0 - 50.0 / self.kappa)) * 1.01 + 1e-9  # cap radius, with a margin
        cells: list[list[int]] = [[] for _ in range(ns * nt)]
        for m, c in enumerate(self.centres):
            th = math.acos(min(1.0, max(-1.0, c[2])))
            z0, z1 = math.cos(min(math.pi, th + rho)), math.cos(max(0.0, th - rho))
            i0, i1 = max(0, int(z0 * ns)), min(ns - 1, int(max(z1, 0.0) * ns))
            if th <= rho or th + rho >= math.pi or math.sin(rho) >= math.sin(th):
                js = range(nt)
            else:
                dphi = math.asin(min(1.0, math.sin(rho) / math.sin(th)))
                ph = math.atan2(c[1], c[0]) / (2.0 * math.pi)
                j0, j1 = math.floor((ph - dphi / (2.0 * math.pi)) * nt), math.floor((ph + dphi / (2.0 * math.pi)) * nt)
                js = [j % nt for j in range(j0, j1 + 1)]
            for i in range(i0, i1 + 1):
                for j in js:
                    cells[i * nt + j].append(m)
        width = max(1, max(len(c) for c in cells))
        table = np.full((ns * nt, width), -1, dtype=np.int64)
        for n, c in enumerate(cells):
            table[n, :len(c)] = c
        self._table = (table, ns, nt)
        return self._table


def _frames(mu):
    """Two unit tangents orthogonal to each row of ``mu`` (and to each other)."""
    helper = np.where(np.abs(mu[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]))
    t1 = np.cross(helper, mu)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    return t1, np.cross(mu, t1)


def sampler(name: str, **params) -> Sampler:
    """``gl.sampler("ggx_vndf", alpha=0.3, wo=(0.6, 0, 0.8))``: a registered sampler (``samplers()``)."""
    if not isinstance(name, str):
        V.fail("name", name, "a sampler name, one of " + ", ".join(SAMPLERS.names()))
    cls = SAMPLERS.get(name)
    try:
        return cls(**params)
    except TypeError as exc:  # an unknown keyword: bad input, named
        raise ValueError(f"sampler {name!r}: {exc}") from None


# Samplers from files, by file suffix (".hlsl", ".glsl", ...): a loader is a function (path, **params) ->
# sampler object. `glintlab sampler FILE` looks the file's suffix up here; shader samplers register
# their loader, e.g. SAMPLER_LOADERS.register(".glsl", shader_sampler).
SAMPLER_LOADERS = Registry("sampler file type")


def load_sampler(name_or_file: str, **params) -> Sampler:
    """A registered sampler by name, or a sampler file through the loader of its suffix."""
    if isinstance(name_or_file, str) and name_or_file in SAMPLERS:
        return sampler(name_or_file, **params)
    path = pathlib.Path(str(name_or_file))
    if path.suffix and path.suffix in SAMPLER_LOADERS:
        return SAMPLER_LOADERS.get(path.suffix)(str(path), **params)
    known = ", ".join(SAMPLERS.names())
    kinds = ", ".join(SAMPLER_LOADERS.names()) or "none registered"
    V.fail("sampler", name_or_file, f"a sampler name ({known}) or a sampler file ({kinds})")


def samplers() -> dict:
    """The registered samplers by name, with a one-line summary each."""
    return {name: cls.summary for name, cls in SAMPLERS.items()}


class WrongSampler(Sampler):
    """A deliberately wrong variant of a sampler (``wrong_sampler``)."""

    wrong_variants = ()

    def __init__(self, base: Sampler, kind: str, sample_from: Sampler | None = None):
        super().__init__()
        self.base, self.kind, self.sample_from = base, kind, sample_from
        self.domain = base.domain
        self.name = f"{base.name}~{kind}"
        self.params = dict(base.params)

    @property
    def loop_caveat(self):
        """The base sampler's (a shader sampler's loops on lavapipe), or None."""
        return getattr(self.base, "loop_caveat", None)

    def sample(self, size, seed=0):
        src = self.sample_from or self.base
        x, p = src.sample(size, seed)
        if self.kind == "drop_0.1%":
            # A sampler that loses one sample in a thousand (returns NaN for it, as a renderer marks an
            # invalid sample), every thousandth row counted from a seeded offset.
            drop = (np.arange(len(x)) + int(V.seed(seed)) % 1000) % 1000 == 0
            x = x.copy()
            x[drop] = np.nan
            p = np.where(drop, 0.0, p)
        return x, self.pdf(x) if self.kind == "no_jacobian" else p

    def pdf(self, points):
        p = self.base.pdf(points)
        if self.kind == "no_jacobian":
            # D(h) instead of D(h) (h . n): the pdf forgets the projection factor.
            c = _cos(_points(points, 3))
            with np.errstate(divide="ignore", invalid="ignore"):
                p = np.where(c > 0, p / np.where(c > 0, c, 1.0), 0.0)
        return p


#: Every kind of wrong variant ``wrong_sampler`` knows how to build; each sampler declares which apply to it
#: (``Sampler.wrong_variants``).
WRONG_KINDS = ("alpha+2%", "no_jacobian", "drop_0.1%")


def wrong_sampler(base: Sampler, kind: str) -> WrongSampler:
    """A deliberately wrong variant the harness must reject, one of ``base.wrong_variants``: ``"alpha+2%"``
    (samples drawn with alpha 2 % larger, pdf at the true alpha), ``"no_jacobian"`` (pdf without the
    (h . n) factor) and ``"drop_0.1%"`` (one sample in a thousand lost)."""
    declared = tuple(getattr(base, "wrong_variants", ()))
    if not isinstance(kind, str) or kind not in declared:
        label = getattr(base, "name", "") or type(base).__name__
        V.fail("kind", kind, f"one of the wrong variants {label} declares: " + (", ".join(declared) or "none"))
    if kind == "alpha+2%":
        if "alpha" not in base.params:
            V.fail("base", base, "a sampler with an alpha parameter")
        return WrongSampler(base, kind, sample_from=base.with_params(alpha=base.params["alpha"] * 1.02))
    if kind == "no_jacobian" and base.domain != "hemisphere":
        V.fail("base", base, "a hemisphere sampler")
    return WrongSampler(base, kind)
