"""Ground truth: spatialized Bernoulli trials (DB23 §4.1, docs/math/ground_truth.md).

Facets are placed on the unit torus; a facet reflects iff its uniform theta < p, and K counts the
reflecting facets inside a footprint. Layouts:

``uniform``     ``density`` = N i.i.d. uniform facets (an integer):  K ~ Binomial(N, |F| p)
``poisson``     a Poisson process of intensity N:                    K ~ Poisson(N |F| p)
``stratified``  one jittered facet per cell of an M x M grid, N = M^2: a Poisson-binomial over the
                cells the footprint touches, with the exact covered fraction of each (DB23's layout)

>>> import glintlab as gl
>>> gt = gl.ground_truth("stratified", density=100**2, footprint=gl.Rect(0.1, 0.07, angle=0.3), p=0.3)
>>> d = gt.pmf()                      # exact (averaged over a random centre: quadrature, see pmf)
>>> k = gt.sample(size=10**5, seed=1) # realizations, counted facet by facet near the edges
>>> gl.chi2_test(k, d).pvalue
0.635

A realization costs time proportional to the footprint's perimeter in cells, not its area: cells
the footprint covers fully are counted with one binomial (or Poisson) draw per realization.
"""
from __future__ import annotations

import math

import numpy as np

from .. import _core
from . import checks as V

LAYOUTS = ("uniform", "poisson", "stratified")


_number = V.real


class _Footprint:
    """A convex footprint centred at the origin, lengths in units of the domain's side."""

    _core: _core.Footprint

    @property
    def area(self) -> float:
        return self._core.area

    @property
    def angle(self) -> float:
        return self._core.angle

    def contains(self, x, y):
        """Whether points (x, y), relative to the centre, lie in the footprint (vectorized)."""
        return self._core.contains(V.as_float_array("x", x), V.as_float_array("y", y))

    def overlap(self, x0, y0, x1, y1) -> float:
        """Exact area of the footprint ∩ the box [x0, x1] x [y0, y1] (relative to the centre)."""
        return self._core.overlap(float(x0), float(y0), float(x1), float(y1))

    def __repr__(self):
        return repr(self._core)


class Rect(_Footprint):
    """A width x height rectangle rotated counter-clockwise by ``angle`` radians."""

    def __init__(self, width, height, angle=0.0):
        self._core = _core.Footprint.rect(_number("width", width), _number("height", height), _number("angle", angle))

    @property
    def width(self) -> float:
        return self._core.a

    @property
    def height(self) -> float:
        return self._core.b


class Ellipse(_Footprint):
    """An ellipse with semi-axes a, b, rotated counter-clockwise by ``angle`` radians."""

    def __init__(self, a, b, angle=0.0):
        self._core = _core.Footprint.ellipse(_number("a", a), _number("b", b), _number("angle", angle))

    @property
    def a(self) -> float:
        return self._core.a

    @property
    def b(self) -> float:
        return self._core.b

    @classmethod
    def from_uv_derivatives(cls, dudx, dvdx, dudy, dvdy) -> "Ellipse":
        """The footprint of a unit pixel with texture derivatives (du/dx, dv/dx), (du/dy, dv/dy).

        The ellipse J {|x| <= 1/sqrt(pi)} with J = [[du/dx, du/dy], [dv/dx, dv/dy]]: the pixel's
        Jacobian image, scaled so its area equals the pixel's, |det J|. Axes from the SVD of J.
        """
        fp = _core.Footprint.from_uv_derivatives(_number("dudx", dudx), _number("dvdx", dvdx),
                                                 _number("dudy", dudy), _number("dvdy", dvdy))
        out = cls.__new__(cls)
        out._core = fp
        return out


def _footprint(value):
    if not isinstance(value, _Footprint):
        V.fail("footprint", value, "a glintlab.Rect or glintlab.Ellipse")
    return value._core


def _center(name, value):
    if value is None:
        return None
    try:
        x, y = value
    except (TypeError, ValueError):
        V.fail(name, value, "None or a pair (x, y) of numbers")
    return (_number(f"{name}[0]", x), _number(f"{name}[1]", y))


def _layout(value):
    V.choice("layout", value, LAYOUTS, "one of " + ", ".join(LAYOUTS))
    return value


class GroundTruth:
    """The count K of reflecting facets of one layout in one footprint (see the module docs)."""

    def __init__(self, layout, density, footprint, p, center=None):
        self._core = _core.GroundTruth(_layout(layout), _number("density", density), _footprint(footprint),
                                       _number("p", p), _center("center", center))
        self.footprint = footprint

    layout = property(lambda self: self._core.layout)
    density = property(lambda self: self._core.density)
    p = property(lambda self: self._core.p)
    center = property(lambda self: self._core.center, doc="(x, y) on [0, 1)^2, or None: a random centre")
    n = property(lambda self: self._core.n, doc="expected number of facets in the footprint, N |F|")
    grid_side = property(lambda self: self._core.grid_side, doc="cells per side of the scan grid")

    def pmf(self, max_support: int = 50_000_000, quadrature: int = 16):
        """Exact law of K.

        uniform: Binomial(N, |F| p); poisson: Poisson(N |F| p); stratified with a centre: the
        Binomial of the fully covered cells convolved with the Poisson-binomial of the cells the
        edge crosses (exact overlap areas). Stratified without a centre: the law averaged over a
        uniformly random centre, by the midpoint rule on a ``quadrature`` x ``quadrature`` grid of
        offsets within one cell (the law is periodic there); compare two quadratures to see its error.
        """
        q = V.size(quadrature)
        if q is None or len(q) != 1 or q[0] < 1:
            V.fail("quadrature", quadrature, "an integer >= 1")
        return self._core.pmf(int(max_support), int(q[0]))

    def sample(self, size: int, seed=None, out=None) -> np.ndarray:
        """``size`` independent realizations of the layout (and of the centre when None): K of each.

        Realization r depends on (seed, r) only, whatever the number of threads.
        """
        shape = V.size(size)
        if shape is None or len(shape) != 1:
            V.fail("size", size, "an integer >= 0")
        if out is None:
            return self._core.sample(shape[0], V.seed(seed))
        # The simulator builds its own buffer: out= is accepted for a uniform API, copied into, and
        # saves nothing here (the cost is the facet placement, not the output's pages).
        flat = V.out_array(out, shape)
        flat[:] = self._core.sample(shape[0], V.seed(seed))
        return out

    def __repr__(self):
        return (f"GroundTruth(layout={self.layout!r}, density={self.density:g}, footprint={self.footprint!r}, "
                f"p={self.p:g}, center={self.center})")


def ground_truth(layout="stratified", density=None, footprint=None, p=None, center=None) -> GroundTruth:
    """The ground-truth count of ``layout`` facets of density N in ``footprint`` (see GroundTruth)."""
    for name, value in (("density", density), ("footprint", footprint), ("p", p)):
        if value is None:
            V.fail(name, value, "a value (it has no default)")
    return GroundTruth(layout, density, footprint, p, center)


def joint_counts(layout, density, p, footprints, centers, size, seed=None) -> np.ndarray:
    """K in several placed footprints on the same realizations: shape (size, len(footprints)).

    All footprints are counted on one facet layout per realization (a zoom or pan path); they must
    fit in the unit domain together. Row r depends on (seed, r) only.
    """
    fps = [_footprint(f) for f in footprints]
    cs = [_center(f"centers[{i}]", c) for i, c in enumerate(centers)]
    if any(c is None for c in cs):
        V.fail("centers", centers, "one (x, y) pair per footprint")
    shape = V.size(size)
    if shape is None or len(shape) != 1:
        V.fail("size", size, "an integer >= 0")
    return _core.joint_counts(_layout(layout), _number("density", density), _number("p", p), fps, cs, shape[0],
                              V.seed(seed))


def footprint_for_area(area, aspect=1.0, angle=0.0, shape="rect"):
    """A footprint of the given area: a rectangle (or ellipse) with side (axis) ratio ``aspect``."""
    area, aspect = _number("area", area), _number("aspect", aspect)
    if not area > 0 or not math.isfinite(area):
        V.fail("area", area, "a finite area > 0")
    if not aspect > 0 or not math.isfinite(aspect):
        V.fail("aspect", aspect, "a finite ratio > 0")
    if shape == "rect":
        w = math.sqrt(area * aspect)
        return Rect(w, area / w, angle)
    if shape == "ellipse":
        a = math.sqrt(area * aspect / math.pi)
        return Ellipse(a, area / (math.pi * a), angle)
    V.fail("shape", shape, "'rect' or 'ellipse'")
