#!/usr/bin/env python3
"""Writes python/glintlab/data/bounds/default.json: error bounds for every built-in law, set from values measured now.

Each bound covers the regime where the law is meant to be used (a law that is exact only below a
threshold gets its bound there; a bound over a regime where the law's error already reaches 1 could
never fail). Limits:
  exact metrics (deterministic): maximum = measured * (1 + MARGIN) + 1e-12, rounded up to 3
      significant digits. The margin absorbs libm and compiler differences between machines; a law
      whose worst error grows by more than a quarter fails CI.
  chi2_pvalue (sampled, fixed seed): minimum = 1e-6 per bound, the sampler against the law's own
      exact pmf at a few points. Under a correct sampler each bound fails with probability at most
      1e-6 per seed, so the whole file has a false-failure rate below 1e-4.
The test suite (tests/python/test_check.py) shows that every bound fails for a perturbed law.

Run: .venv/bin/python scripts/make_bounds.py  (then review the diff of python/glintlab/data/bounds/default.json)
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import glintlab as gl
from glintlab.validation.bounds import check

ROOT = Path(__file__).resolve().parents[1]
MARGIN = 0.25
P_HALF = {"p_range": [0, 0.5]}
BULK = {"p_range": [0, 0.5], "np_range": [10, 1e300]}

# (law, regime, metrics, note)
EXACT = [
    ("binomial", {}, ("tv", "mean_rel_err"), "the exact law against itself: rounding only"),
    ("poisson", {"p_range": [0, 1e-3]}, ("tv", "mean_rel_err"), "the Poisson layout is the small-p limit"),
    ("gaussian", BULK, ("tv", "mean_rel_err"), "floored normal: meant for n p >= 10"),
    ({"name": "gaussian", "params": {"rounding": "round"}}, BULK, ("tv", "mean_rel_err"), "rounded normal, n p >= 10"),
    ({"name": "gaussian", "params": {"rounding": "round"}}, P_HALF, ("tv",), "rounded normal, whole lower half"),
    ("zk16", BULK, ("tv", "mean_rel_err"), "the Gaussian branch (n p > 5)"),
    ("zk16", {"n_range": [0, 16], "np_range": [0, 5]}, ("tv", "mean_rel_err"),
     "n p <= 5 and n <= cap: the Bernoulli loop is exact"),
    ("threshold", {"np_range": [0, 16]}, ("tv",), "n p <= T: the exact binomial"),
    ("threshold", {}, ("mean_rel_err",), "the mean n p is exact everywhere"),
    ("gated", P_HALF, ("tv", "mean_rel_err"), "p <= 1/2 (near p = 1 the gate fails by design, TV 0.91)"),
    ("gated_shader", P_HALF, ("tv", "mean_rel_err"), "the public shader's path, p <= 1/2"),
    ("gated_continuous", P_HALF, ("tv", "mean_rel_err"), "KK24, p <= 1/2"),
    ("dual_gated", P_HALF, ("tv", "mean_rel_err"), "KK25, p <= 1/2"),
    ("dual_gated", {}, ("tv",), "KK25 over the whole grid (fixes the gate's p -> 1 failure)"),
    ("head_cf", {}, ("tv", "mean_rel_err"), "glintlab's law over the whole standard grid"),
]
SAMPLED_REGIME = {"n": [16, 1000, 1e6], "p": [0.01, 0.3]}
SAMPLED = ["binomial", "poisson", "gaussian", "zk16", "threshold", "gated", "gated_shader", "gated_continuous",
           "dual_gated", "head_cf"]


def label(law):
    return law if isinstance(law, str) else law["name"] + "".join(f"[{k}={v}]" for k, v in law["params"].items())


def regime_label(regime):
    if not regime:
        return "standard grid"
    return ", ".join(f"{k[:-6] if k.endswith('_range') else k} in [{v[0]:g}, {v[1]:g}]" for k, v in regime.items())


def ceil3(x):
    if x <= 0:
        return 0.0
    e = math.floor(math.log10(x)) - 2
    return math.ceil(x / 10**e) * 10**e


def main():
    bounds = []
    for law, regime, metrics, note in EXACT:
        for m in metrics:
            bounds.append({"id": f"{label(law)}/{m}/{regime_label(regime)}", "law": law, "regime": regime,
                           "metric": m, "maximum": 1.0, "note": note})
    for law in SAMPLED:
        bounds.append({"id": f"{law}/sampler/chi2", "law": law, "regime": SAMPLED_REGIME, "metric": "chi2_pvalue",
                       "reference": {"law": law}, "samples": 100000, "seed": 1, "minimum": 1e-6,
                       "note": "the sampler against the law's own exact pmf"})
    doc = {"glintlab": 1,
           "description": "Error bounds of every built-in law against the exact binomial (exact metrics) and of "
                          "every sampler against its own exact pmf (chi-square, 1e5 draws per point). "
                          "Written by scripts/make_bounds.py.",
           "margin": f"maximum = measured * {1 + MARGIN} + 1e-12, rounded up to 3 significant digits; chi-square "
                     "p-values >= 1e-6 per bound (false-failure rate below 1e-4 for the file).",
           "bounds": bounds}
    table = check(doc)
    for b, r in zip(bounds, table.itertuples()):
        b["measured"] = r.worst
        if "maximum" in b:
            b["maximum"] = ceil3(r.worst * (1 + MARGIN) + 1e-12)
    out = ROOT / "python" / "glintlab" / "data" / "bounds" / "default.json"
    out.write_text(json.dumps(doc, indent=1) + "\n")
    print(check(doc).to_string())
    print(f"wrote {out} (glintlab {gl.__version__})")


if __name__ == "__main__":
    main()
