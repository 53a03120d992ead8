"""Error bounds a renderer's CI gates on (``glintlab check BOUNDS.json``).

A bounds file (data/schema/bounds.schema.json) lists bounds: one law, one metric, a regime of (n, p)
(grid axes as in experiments, narrowed by optional n, p and n*p ranges), the reference (default: the
exact binomial) and a limit: ``maximum`` for errors, ``minimum`` for chi-square p-values. ``check``
sweeps each bound's regime, takes the worst value (largest, or smallest for a minimum) and says
whether it is within the limit, and where the worst point is.

``perturbed_law`` builds the wrong law a bound must catch: the same law evaluated at a wrong
reflection probability (p scaled, as a mis-normalized D(h) would do) and/or with every count shifted.
The test suite uses it to show that every bound of data/bounds/default.json can fail.
"""
from __future__ import annotations

import json
import math
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd

from .._core import Distribution
from ..api import checks as v
from ..api.laws import Law
from ..resources import data_path
from .documents import parse_document
from .experiment import axis_values
from .references import resolve_law
from .sweep import sweep

DEFAULT_BOUNDS = data_path("bounds", "default.json")


def load_bounds(source) -> tuple[dict, str, Path | None]:
    """(normalized document, source name, base directory) from a path, JSON text or a dict."""
    return parse_document("bounds", source)


def regime_points(regime: dict) -> np.ndarray:
    """The (n, p) points of a regime: the grid of its axes, filtered by n_range, p_range, np_range."""
    nn, pp = axis_values(regime.get("n", "standard"), "n"), axis_values(regime.get("p", "standard"), "p")
    n, p = (a.ravel() for a in np.meshgrid(nn, pp, indexing="ij"))
    keep = np.ones(n.size, dtype=bool)
    for key, values in (("n_range", n), ("p_range", p), ("np_range", n * p)):
        if key in regime:
            lo, hi = regime[key]
            keep &= (values >= lo) & (values <= hi)
    return np.column_stack([n[keep], p[keep]])


def check(bounds=DEFAULT_BOUNDS, substitute: dict | None = None, progress=None) -> pd.DataFrame:
    """Evaluates every bound; one row per bound: id, law, metric, limit ("max" or "min"), bound,
    worst, at_n, at_p, points, ok, measured (the value recorded when the bound was set), seconds.

    ``substitute`` maps a bound's law label (e.g. "gated") to a Law object evaluated in its place
    (how the tests show that a wrong law violates a bound).
    """
    doc, source, base = load_bounds(bounds)
    substitute = substitute or {}
    rows = []
    # Bounds that differ only in their metric (a law's tv and mean_rel_err over one regime) share one
    # sweep with every metric they ask for: the law's and the reference's distributions at each point
    # are computed once (the values are the same as one sweep per bound: each metric is a function of
    # those two distributions, or of the same seeded samples).
    groups: dict[str, list] = {}
    for b in doc["bounds"]:
        groups.setdefault(_sweep_key(b), []).append(b["metric"])
    sweeps: dict[tuple, pd.DataFrame] = {}
    for i, b in enumerate(doc["bounds"]):
        t0 = time.perf_counter()
        try:
            lw = resolve_law(b["law"], base)
        except ValueError as exc:
            raise ValueError(f"{source}: at /bounds/{i}/law: {exc}") from None
        label = lw.label
        lw = substitute.get(label, lw)
        pts = regime_points(b.get("regime", {}))
        limit = "max" if "maximum" in b else "min"
        value = b["maximum"] if limit == "max" else b["minimum"]
        row = dict(id=b["id"], law=label, metric=b["metric"], limit=limit, bound=value, worst=math.nan,
                   at_n=math.nan, at_p=math.nan, points=len(pts), ok=False, measured=b.get("measured"))
        if len(pts) == 0:
            raise ValueError(f"{source}: at /bounds/{i}/regime: expected a regime with at least one (n, p) "
                             "point, got none after the ranges")
        group = _sweep_key(b)
        # A substituted law is the caller's object (the same one for every bound of its label).
        cached = (group, label, id(lw) if label in substitute else str(lw.identity))
        if cached not in sweeps:
            sweeps[cached] = sweep([lw], points=pts, metrics=list(dict.fromkeys(groups[group])),
                                   reference=b.get("reference", "binomial"), samples=b.get("samples"),
                                   seed=b.get("seed", 1), progress=progress)
        df = sweeps[cached]
        vals = df[b["metric"]].to_numpy(dtype=float)
        # NaN is never within a bound: it counts as the worst value.
        key = np.where(np.isnan(vals), np.inf, vals if limit == "max" else -vals)
        k = int(np.argmax(key))
        row.update(worst=float(vals[k]), at_n=float(df.n.iloc[k]), at_p=float(df.p.iloc[k]))
        # What the test said at the worst point (e.g. "3 samples fall on values the law gives
        # probability 0 (first: 17)"): the line that explains a failed chi-square bound.
        row["note"] = str(df.chi2_note.iloc[k]) if "chi2_note" in df and isinstance(df.chi2_note.iloc[k], str) else ""
        row["ok"] = bool(np.isfinite(vals).all() and (vals.max() <= value if limit == "max" else vals.min() >= value))
        if b["metric"] == "chi2_pvalue" and "chi2_resolution" in df and row["ok"]:
            # A Monte Carlo p-value has a resolution r (it is never below r): above a minimum smaller
            # than r it shows the bound holds only when it is clearly above its own noise (5 standard
            # errors of an estimate from 1/r draws); otherwise the check cannot pass on it.
            res = df.chi2_resolution.to_numpy(dtype=float)
            open_ = (res > value) & (vals - 5.0 * np.sqrt(np.maximum(vals, 0.0) * res) <= value)
            if open_.any():
                k = int(np.argmax(open_))
                row.update(ok=False, worst=float(vals[k]), at_n=float(df.n.iloc[k]), at_p=float(df.p.iloc[k]),
                           note=f"Monte Carlo p-value {vals[k]:.3g} with resolution {res[k]:.3g} cannot show "
                                f"p >= {value:g}: undecided ({df.chi2_note.iloc[k]})")
        row["seconds"] = round(time.perf_counter() - t0, 3)
        rows.append(row)
    out = pd.DataFrame(rows)
    out.attrs.update(source=source)
    return out


def _sweep_key(b: dict) -> str:
    """What a bound's sweep depends on besides its metric: law, regime, reference, samples and seed."""
    return json.dumps([b["law"], b.get("regime", {}), b.get("reference", "binomial"), b.get("samples"),
                       b.get("seed", 1)], sort_keys=True, default=str)


def write_junit(table: pd.DataFrame, path, name: str = "glintlab.check") -> Path:
    """JUnit XML for CI systems: one testcase per bound, a <failure> for each violated one."""
    suite = ET.Element("testsuite", name=name, tests=str(len(table)), failures=str(int((~table.ok).sum())),
                       time=f"{table.seconds.sum():.3f}")
    for r in table.itertuples():
        case = ET.SubElement(suite, "testcase", classname=f"{name}.{r.law}", name=r.id, time=f"{r.seconds:.3f}")
        if not r.ok:
            rel = "<=" if r.limit == "max" else ">="
            note = f" ({r.note})" if getattr(r, "note", "") else ""
            f = ET.SubElement(case, "failure", message=f"{r.metric} = {r.worst:.6g} at n = {r.at_n:g}, p = {r.at_p:g}; "
                                                       f"bound: {r.metric} {rel} {r.bound:.6g}{note}")
            f.text = (f"law {r.law}, metric {r.metric}, worst {r.worst!r} at (n, p) = ({r.at_n!r}, {r.at_p!r}) "
                      f"over {r.points} points{note}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)
    return path


def format_table(table: pd.DataFrame) -> str:
    cols = ["id", "law", "metric", "limit", "bound", "worst", "at_n", "at_p", "points", "ok"]
    t = table[cols].copy()
    t["ok"] = t.ok.map({True: "ok", False: "VIOLATED"})
    text = t.to_string(index=False, float_format=lambda x: f"{x:.4g}")
    notes = [f"{r.id}: {r.note}" for r in table.itertuples() if getattr(r, "note", "") and not r.ok]
    return text + "".join("\n  " + line for line in notes)


class PerturbedLaw(Law):
    """``base`` evaluated at p' = min(1, p * p_scale), every count then shifted by ``shift``."""

    def __init__(self, base: Law, p_scale: float = 1.5, shift: float = 0.0):
        self._base = base
        self._scale = v.real("p_scale", p_scale)
        self._shift = v.real("shift", shift)
        if not (self._scale > 0 and math.isfinite(self._scale)):
            v.fail("p_scale", p_scale, "a finite number > 0")

    def __reduce__(self):
        return (PerturbedLaw, (self._base, self._scale, self._shift))

    def _p(self, p):
        return np.minimum(1.0, np.asarray(p, dtype=float) * self._scale)

    name = property(lambda self: f"{self._base.name}~perturbed")
    params = property(lambda self: {**self._base.params, "p_scale": self._scale, "shift": self._shift})
    n_uniforms = property(lambda self: self._base.n_uniforms)
    has_pmf = property(lambda self: self._base.has_pmf)
    binning = property(lambda self: self._base.binning)
    precisions = property(lambda self: self._base.precisions)

    def pmf(self, n, p, max_support: int = 50_000_000):
        d = self._base.pmf(n, float(self._p(p)), max_support)
        return Distribution(np.asarray(d.support) + self._shift, np.asarray(d.probs))

    def sample(self, n, p, size=None, seed=None, precision="float64"):
        return self._base.sample(n, self._p(p), size=size, seed=seed, precision=precision) + self._shift

    def evaluate(self, n, p, u, precision="float64"):
        return self._base.evaluate(n, self._p(p), u, precision=precision) + self._shift


def perturbed_law(law, p_scale: float = 1.5, shift: float = 0.0) -> PerturbedLaw:
    """A deliberately wrong law (see PerturbedLaw) for showing that a bound can fail."""
    return PerturbedLaw(resolve_law(law), p_scale, shift)
