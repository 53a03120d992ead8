"""Target normal distribution functions (isotropic Beckmann and GGX) and DB23's success probability.

DB23 eq. 4 turns a smooth NDF into a counting law: p = R D(h) / D(n), with D(n) the NDF at the shading
normal and R in [0, 1] a user ratio, so that D_P = (D(n) / R) K / n has E[D_P] = D(h) when E[K] = n p.
The paper says D(n) keeps p in [0, 1]; that holds only when the NDF peaks at the normal, which is
true for Beckmann when alpha^2 <= 1/2 and for GGX when alpha <= 1. Beyond, ``max_ratio`` (the supremum
of D(h) / D(n), derived below) exceeds 1: DB23's own Table 1 setup (Beckmann, alpha = 1) reaches
4 / e = 1.47, so p must be clamped (``success_probability`` does, and reports how often).

Both NDFs are normalised as projected-area densities: the integral of D(h) (h . n) over the
hemisphere is 1 (checked by the tests).
"""
from __future__ import annotations

import math

import numpy as np
import scipy.special as sp

from . import checks as V
from . import fpmath

NDFS = ("beckmann", "ggx")


class NDF:
    """``D(cos_theta_h)`` of an isotropic NDF of roughness ``alpha`` (Walter et al. 2007 conventions)."""

    def __init__(self, name: str, alpha: float):
        V.choice("ndf", name, NDFS, f"one of {', '.join(NDFS)}")
        alpha = V.real("alpha", alpha)
        if not (math.isfinite(alpha) and alpha > 0):
            V.fail("alpha", alpha, "a finite number > 0")
        self.name, self.alpha = name, alpha

    def __repr__(self):
        return f"NDF({self.name!r}, alpha={self.alpha:g})"

    def D(self, cos_theta):
        """NDF value at half vectors with (h . n) = cos_theta (0 below the horizon)."""
        c = np.clip(V.as_float_array("cos_theta", cos_theta), 0.0, 1.0)
        a2 = self.alpha * self.alpha
        c2 = c * c
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.name == "beckmann":
                tan2 = (1.0 - c2) / c2
                # fpmath.exp: the same bits whatever the arrays' addresses (numpy's exp loop depends on them).
                d = fpmath.exp(-tan2 / a2) / (math.pi * a2 * c2 * c2)
            else:  # GGX: a^2 / (pi ((a^2 - 1) c^2 + 1)^2)
                d = a2 / (math.pi * ((a2 - 1.0) * c2 + 1.0) ** 2)
        return np.where(c > 0, np.nan_to_num(d, nan=0.0, posinf=0.0), 0.0)

    def smith_lambda(self, cos_theta):
        """Smith's Lambda of a direction with (w . n) = cos_theta (docs/math/sampling.md#smith-masking):
        GGX (sqrt(1 + alpha^2 tan^2) - 1) / 2; Beckmann (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)),
        a = 1 / (alpha tan). 0 at the normal; +inf at and below the horizon."""
        c = np.clip(V.as_float_array("cos_theta", cos_theta), -1.0, 1.0)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            tan = np.sqrt(np.maximum(1.0 - c * c, 0.0)) / c
            if self.name == "ggx":
                lam = 0.5 * (np.sqrt(1.0 + (self.alpha * tan) ** 2) - 1.0)
            else:
                a = 1.0 / (self.alpha * tan)
                # erfc and erfcx keep the difference accurate at large a (near the normal), where both
                # terms tend to 0.
                lam = 0.5 * (np.exp(-a * a) / (a * math.sqrt(math.pi)) - sp.erfc(a))
                lam = np.where(np.isfinite(a), lam, 0.0)
        return np.where(c > 0, np.where(tan == 0, 0.0, lam), np.inf)

    def G1(self, cos_theta):
        """Smith's masking 1 / (1 + Lambda) of a direction with (w . n) = cos_theta (0 below the horizon)."""
        return 1.0 / (1.0 + self.smith_lambda(cos_theta))

    @property
    def D_normal(self) -> float:
        """D at the shading normal: 1 / (pi alpha^2) for both."""
        return 1.0 / (math.pi * self.alpha**2)

    @property
    def max_ratio(self) -> float:
        """sup over h of D(h) / D(n).

        Beckmann: with t = tan^2, D / D(n) = (1 + t)^2 exp(-t / a^2), whose maximum is at t = 2a^2 - 1
        when a^2 > 1/2, giving 4 a^4 exp(1/a^2 - 2). GGX: a^4 / ((a^2 - 1) c^2 + 1)^2, largest at grazing
        h (c -> 0) when a > 1, giving a^4."""
        a2 = self.alpha**2
        if self.name == "beckmann":
            return 4.0 * a2 * a2 * math.exp(1.0 / a2 - 2.0) if a2 > 0.5 else 1.0
        return a2 * a2 if a2 > 1.0 else 1.0

    def success_probability(self, cos_theta, R: float = 1.0):
        """(p, clamped): DB23 eq. 4's p = R D(h) / D(n), clamped to [0, 1], and the mask of clamped entries."""
        R = V.real("R", R)
        if not (0.0 <= R <= 1.0):
            V.fail("R", R, "a number in [0, 1]")
        raw = R * self.D(cos_theta) / self.D_normal
        return np.minimum(raw, 1.0), raw > 1.0


def ndf(name: str, alpha: float) -> NDF:
    """``gl.ndf("beckmann", alpha=0.5)``: see :class:`NDF`."""
    return NDF(name, alpha)
