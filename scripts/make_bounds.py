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
SAMPLED_REGIME = {"n": [16, 1000, 1e6], "p": [0.01, 0.3]}


def exact_bounds():
    """(law, regime, metrics, note) of every bound the laws declare with their code (core/laws/*.cpp,
    LawTraits::bounds): the regime where each law is meant to be used, and why."""
    out = []
    for name in gl.laws():
        for b in gl.law_traits(name)["bounds"]:
            law = {"name": name, "params": b["params"]} if b["params"] else name
            out.append((law, {k: list(v) for k, v in b["regime"].items()}, tuple(b["metrics"]), b["reason"]))
    return out


def sampled_laws():
    """Every declared law with an exact pmf: its sampler is checked against it."""
    return [name for name in gl.laws() if gl.law_traits(name)["declared"] and gl.law(name).has_pmf]


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
    for law, regime, metrics, note in exact_bounds():
        for m in metrics:
            bounds.append({"id": f"{label(law)}/{m}/{regime_label(regime)}", "law": law, "regime": regime,
                           "metric": m, "maximum": 1.0, "note": note})
    for law in sampled_laws():
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
