"""The global cubature rule of the sampler harness on a pdf with a jump, and KPT25's Algorithm 2 as the
importance sampler of a lighting integral (docs/math/sampling.md#cubature-error,
docs/math/sampling.md#lighting-integral): the unbiasedness check passes the sampler's own pdf and rejects
a pdf 10 % too large; the reference quadrature's inverse map is T's inverse."""
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.studies import sampling_lighting as SL

MAX_Z = 4.0  # |z| threshold: a false-failure rate of 6e-5 per check under the normal approximation
# A cheap glinty pixel: low finest level and wide lobes keep the quadrature at ~5e4 evaluations.
PIXEL = (dict(density=1e5, target="beckmann", alpha=0.4, alpha_star=0.05, k=4), (0.3, 0.7), (0.01, 0.0, 0.0, 0.01), 5)
WO = np.array([0.5, 0.0, math.sqrt(0.75)])


class Disk:
    """Uniform points in the disk of radius R around (1/2, 1/2) of the unit square: a pdf with a jump along
    a circle, which cubature integrates only to first order in the cell size."""
    domain = "square"

    def __init__(self, radius=0.3, power=0.5):
        self.radius, self.power, self.name = radius, power, f"disk r^{power}"

    def sample(self, size, seed):
        u = np.random.default_rng(seed).random((size, 2))
        r = self.radius * u[:, 0] ** self.power  # power 1/2: uniform in area
        p = np.column_stack([0.5 + r * np.cos(2 * np.pi * u[:, 1]), 0.5 + r * np.sin(2 * np.pi * u[:, 1])])
        return p, self.pdf(p)

    def pdf(self, p):
        inside = np.hypot(p[:, 0] - 0.5, p[:, 1] - 0.5) < self.radius
        return np.where(inside, 1.0 / (np.pi * self.radius**2), 0.0)


def test_global_rule_converges_where_the_per_bin_rule_cannot_and_still_rejects():
    n, budget = 100_000, 1_500_000
    old = gl.sampler_test(Disk(), samples=n, seed=3, cubature_tol=0.0, rel_tol=0.02, max_evaluations=budget)
    assert old.unconverged > 0 and not old.passed, old  # bins on the circle never reach 2 % of their noise
    res = gl.sampler_test(Disk(), samples=n, seed=3, max_evaluations=budget)
    assert res.passed, res
    assert 0 < res.cubature_shift <= res.cubature_limit == pytest.approx(0.1 * math.sqrt(2 * res.dof))
    assert res.evaluations < old.evaluations
    wrong = gl.sampler_test(Disk(power=0.45), samples=n, seed=3, max_evaluations=budget)
    assert not wrong.passed and wrong.pvalue < 1e-6, wrong
    with pytest.raises(ValueError, match="cubature_tol"):
        gl.sampler_test(Disk(), samples=100, cubature_tol=-1.0)
    with pytest.raises(ValueError, match="cubature_tol"):
        gl.sampler_test(Disk(), samples=100, cubature_tol=0.0, rel_tol=None)


def test_inverse_map_inverts_T():
    for kw in (PIXEL[0], SL.PIXELS[2][0]):
        nd = gl.glinty_ndf("kpt25", **kw)
        y = np.random.default_rng(0).random((500, 2))
        y = y[np.hypot(y[:, 0] - 0.5, y[:, 1] - 0.5) < 0.499]
        assert np.abs(nd.map(SL.inverse_map(nd, y)) - y).max() < 1e-12


def test_reference_quadrature_integrates_the_smooth_ndf():
    # With lobes everywhere filled (a very dense pixel) D^f is close to D; here the quadrature itself is
    # checked on the smooth NDF: the integral of D(h)(h.n) over the hemisphere is 1 exactly.
    nd = gl.glinty_ndf("kpt25", **PIXEL[0])
    x, w = np.polynomial.legendre.leggauss(8)
    cells = 16
    s = ((np.arange(cells)[:, None] + 0.5 * (x[None, :] + 1)) / cells).reshape(-1)
    ws = np.tile(0.5 * w / cells, cells)
    yy = np.stack(np.meshgrid(s, s, indexing="ij"), -1).reshape(-1, 2)
    wy = np.outer(ws, ws).reshape(-1)
    inside = np.hypot(yy[:, 0] - 0.5, yy[:, 1] - 0.5) < 0.5
    h = SL.inverse_map(nd, yy[inside])
    # dh = dy / ((pi / 4) D(h)(h.n)): D(h)(h.n) dh = (4 / pi) dy, so the sum is the disk's area times 4 / pi.
    total = np.sum(wy[inside] * nd.smooth(h) * h[:, 2] / (0.25 * np.pi * nd.smooth(h) * h[:, 2]))
    assert total == pytest.approx(4 / np.pi * np.sum(wy[inside]))
    assert np.sum(wy[inside]) == pytest.approx(np.pi / 4, rel=2e-3)


@pytest.mark.parametrize("scale,unbiased", [(1.0, True), (1.1, False)])
def test_unbiasedness_check_rejects_a_wrong_pdf(scale, unbiased):
    _, bias = SL.pixel_study(PIXEL, 40, 512, [512], WO, seed=1, pdf_scale=scale, estimators=("kpt25_alg2",))
    z = bias[0]["z"]
    assert (abs(z) <= MAX_Z) == unbiased, bias[0]


def test_smooth_estimators_are_unbiased_and_the_compensation_is_the_bias_without_it():
    _, bias = SL.pixel_study(PIXEL, 80, 512, [512], WO, seed=2, orders=(3, 4))
    for row in bias:
        assert abs(row["z"]) <= MAX_Z, row
    # Without the compensation's part every estimator misses the reference by about that part.
    alg = next(r for r in bias if r["estimator"] == "kpt25_alg2")
    assert alg["compensation_share"] > 0.03
    assert alg["z_without_compensation"] < -MAX_Z, alg
