"""Rows: one law at one grid point against a reference, exact or sampled, and the Monte Carlo error
beside the sampled metrics. The one engine under ``sweep``, ``error_table``, experiments and bounds.

exact    (``samples=None``) the law's exact distribution against the reference's.
sampled  (``samples=m``) m draws of the law, binned as its pmf is, against the reference's exact
         distribution (or m draws of the reference when it has none). Each row draws with its own
         seed, ``row_seed(seed, law, n, p)``: a hash of the row's identity.
"""
from __future__ import annotations

import hashlib
import json
import math
import warnings

import numpy as np
from scipy.special import gammaln

from .._core import Distribution
from ..api.laws import Law
from ..api.metrics import METRICS, chi2_test, distance

MOMENT_METRICS = ("mean_rel_err", "var_rel_err")
SAMPLED_ONLY = ("chi2_pvalue",)
SWEEP_METRICS = tuple(METRICS) + MOMENT_METRICS + SAMPLED_ONLY


def row_seed(seed: int, law_label: str, n: float, p: float) -> int:
    """The seed of one sampled row: a 64-bit hash of (seed, law, n, p), exact in n and p (float.hex)."""
    key = f"{int(seed)}|{law_label}|{float(n).hex()}|{float(p).hex()}".encode()
    return int.from_bytes(hashlib.blake2b(key, digest_size=8).digest(), "little")


def tv_noise(dist: Distribution, samples: int) -> float:
    """Exact E[TV(empirical law of m draws, dist)] for m = samples: the TV of pure sampling noise.

    Each cell count X_k is Binomial(m, q_k), and E|X - m q| has de Moivre's closed form
    2 nu C(m, nu) q^nu (1 - q)^(m - nu + 1) with nu = floor(m q) + 1 (computed in logs), so
    E[TV] = sum_k E|X_k - m q_k| / (2 m).
    """
    m = float(samples)
    q = np.asarray(dist.probs, dtype=np.float64)
    q = q[(q > 0) & (q < 1)]
    if q.size == 0:
        return 0.0
    nu = np.floor(m * q) + 1
    log_mad = (np.log(2 * nu) + gammaln(m + 1) - gammaln(nu + 1) - gammaln(m - nu + 1)
               + nu * np.log(q) + (m - nu + 1) * np.log1p(-q))
    return float(np.sum(np.exp(log_mad)) / (2 * m))


def relative_error(value, reference) -> float:
    """|value - reference| / |reference|, or |value| when the reference is 0 (an absolute error there)."""
    return abs(value - reference) / abs(reference) if reference else abs(value)


def moment_errors(d: Distribution, ref_mean, ref_var) -> dict:
    """mean_rel_err and var_rel_err of ``d`` against the reference's moments; var_rel_err is 0 when both
    variances are 0 and inf when only the reference's is (a spread where none should be)."""
    return {"mean_rel_err": relative_error(d.mean, ref_mean),
            "var_rel_err": (abs(d.var - ref_var) / ref_var if ref_var else (0.0 if d.var == 0 else math.inf))}


def compute_row(lw: Law, label: str, reference, n: float, p: float, metrics, samples, seed,
                reference_pmf: Distribution | None = None) -> dict:
    """One row of a sweep (pure: the same arguments give the same row). ``reference_pmf``: the
    reference's exact distribution at (n, p) when the caller already has it."""
    row = {"law": label, "n": float(n), "p": float(p)}
    want_dist = [m for m in metrics if m in METRICS]
    if samples is None:
        d = lw.pmf(n, p)
        d_ref = reference.pmf(n, p) if reference_pmf is None else reference_pmf
        row.update({m: distance(d, d_ref, m) for m in want_dist})
        mom = moment_errors(d, d_ref.mean, d_ref.var)
        row.update({m: mom[m] for m in metrics if m in MOMENT_METRICS})
        return row
    rs = row_seed(seed, label, n, p)
    x = lw.bin(lw.sample(n, p, size=samples, seed=rs))
    d = Distribution.empirical(np.ascontiguousarray(x))
    if reference.has_pmf:
        d_ref = reference.pmf(n, p)
    else:  # two samples: the reference draws with a seed of its own
        d_ref = Distribution.empirical(np.ascontiguousarray(
            reference.sample(n, p, samples, row_seed(seed, "reference:" + label, n, p))))
    if lw.binning == "none" and not np.array_equal(x, np.floor(x)) and \
            np.array_equal(np.asarray(d_ref.support), np.floor(np.asarray(d_ref.support))):
        # Real outputs compared unbinned with a law of integers match none of its values: the
        # distances then say more about the binning than about the law.
        # One message per law (no n, p in it), so that Python's warning filter shows it once per sweep
        # instead of once per grid point.
        warnings.warn(f"law {label!r} returns non-integer counts and declares binning 'none', against a "
                      "reference of integer counts: they are compared unbinned (give a custom law "
                      "binning='round')", UserWarning, stacklevel=2)
    row.update({m: distance(d, d_ref, m) for m in want_dist})
    mom = moment_errors(d, d_ref.mean, d_ref.var)
    row.update({m: mom[m] for m in metrics if m in MOMENT_METRICS})
    if "chi2_pvalue" in metrics:
        # The test's note (impossible samples, the exact small-sample test) travels with its p-value.
        test = chi2_test(x, d_ref) if reference.has_pmf else None
        row["chi2_pvalue"] = test.pvalue if test is not None else math.nan
        row["chi2_note"] = test.note if test is not None else "no exact reference: no chi-square test"
        # A Monte Carlo p-value cannot go below its resolution: a check against a smaller alpha needs it.
        row["chi2_resolution"] = test.resolution if test is not None else math.nan
    if "tv" in metrics:
        row["tv_noise"] = tv_noise(d_ref, samples) if reference.has_pmf else math.nan
    if "mean_rel_err" in metrics:
        sd = float(np.std(x, ddof=1)) if samples > 1 else math.nan
        row["mean_rel_err_se"] = sd / math.sqrt(samples) / abs(d_ref.mean) if d_ref.mean else sd / math.sqrt(samples)
    row["samples"] = int(samples)
    row["seed"] = rs
    return row


def compute_chunk(laws, labels, reference, metrics, samples, seed, items) -> list:
    """Rows of (law index, n, p) items, each through the store's JSON round trip (so fresh, stored
    and remote rows agree bit for bit). Module-level and pure: Dask ships it to workers."""
    rows = []
    ref_pmf = {}  # exact rows of several laws at one point compute the reference's pmf once
    for i, n, p in items:
        try:
            d_ref = None
            if samples is None:
                key = (float(n).hex(), float(p).hex())
                if key not in ref_pmf:
                    ref_pmf = {key: reference.pmf(n, p)}  # items come point by point: keep one
                d_ref = ref_pmf[key]
            row = compute_row(laws[i], labels[i], reference, n, p, metrics, samples, seed, d_ref)
        except (ValueError, NotImplementedError) as exc:
            raise ValueError(f"sweep: law {labels[i]!r} at n = {n!r}, p = {p!r}: {exc}") from exc
        rows.append(json.loads(json.dumps(row)))
    return rows
