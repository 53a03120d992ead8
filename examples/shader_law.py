"""An example custom law, as a renderer team would write it: a vectorized Python function
fn(n, p, u) -> counts over rows (n, p, u have one row per evaluation; u has n_uniforms columns).

round_normal: the count a shader gets from a rounded, clamped normal approximation of the binomial,
with the Beasley-Springer-Moro style inverse normal replaced by scipy's (the team's own would go here).
Used by examples/custom_python_law.json.
"""
import numpy as np
from scipy.special import ndtri


def round_normal(n, p, u):
    mean = n * p
    sd = np.sqrt(n * p * (1 - p))
    k = np.floor(mean + sd * ndtri(np.clip(u[:, 0], 1e-12, 1 - 1e-12)) + 0.5)
    return np.clip(k, 0, np.ceil(n))
