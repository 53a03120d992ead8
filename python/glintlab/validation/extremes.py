"""The numerical-extremes suite (docs/math/extremes.md), for every law, in float32 and float64.

Every law (and every blend, on footprints exactly on a level boundary and one ulp either side) is
evaluated over the grid of docs/math/extremes.md#extremes-grid

    n in {0, 1e-6, 0.5, 1, 2, 16, 17, 1e9, 1e15},  p in {0, 1e-300, 1e-12, 1e-7, 0.5, 1 - 1e-7, 1}

on three sets of uniforms: ``ordinary`` (``gl.uniforms(samples, k, seed)``, what ``sample`` uses),
``corners`` (every coordinate exactly 0, 1/2 or 1: Φ⁻¹ is infinite at 0 and 1) and ``half`` (the
ordinary uniforms rounded to 16-bit floats, as a shader's random texture stores them: u can become
exactly 0 or 1). Each evaluation must give a finite K in [0, ⌈n⌉] and never raise; the exact pmf,
where the law has one, must sum to 1 on a support within [0, ⌈n⌉]. Mean bias against n p is
reported (approximate laws are biased by design) but is not a check.

Blends have no ``evaluate``: their ordinary draws are ``sample`` (Philox keyed by cell and level);
for ``corners`` and ``half`` the inner law's uniforms are snapped to {0, 1/2, 1} (by thirds) or
rounded to float16 before the inner law evaluates them (the roulette's own keep uniforms are not
touched). Blends run in float64 only.

A second table checks the other half of the rule (docs/math/extremes.md#extremes-invalid): invalid inputs raise a clear error:
n in {-1, nan, inf}, p in {-1e-300, 1 + 1e-15, nan}, u in {-1e-300, 1 + 2^-52, nan} must raise a
ValueError whose message names the parameter and its value.

>>> from glintlab.validation import extremes
>>> t = extremes.extremes_table(["binomial"])     # default: all laws and blends, about 6 s on 2 cores
>>> s = extremes.extremes_summary(t)
>>> s[["law", "precision", "points", "failures"]]
        law precision  points  failures
0  binomial   float64     189         0
>>> import tempfile
>>> from glintlab.report.html import write_extremes_report    # the page: figure, CSVs, extremes.html
>>> path = write_extremes_report(tempfile.mkdtemp(), t, extremes.invalid_inputs_table(["binomial"]), s)
>>> path.name
'extremes.html'
"""
from __future__ import annotations

import math
import os
import re
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd

from ..api.blends import BlendedLaw, blended_law, blends as blend_names
from ..api.laws import CustomLaw, Law, law as get_law, law_label, law_traits, laws as law_names, uniforms
from ..api import checks as V

GRID_N = (0.0, 1e-6, 0.5, 1.0, 2.0, 16.0, 17.0, 1e9, 1e15)
GRID_P = (0.0, 1e-300, 1e-12, 1e-7, 0.5, 1 - 1e-7, 1.0)
UNIFORM_SETS = ("ordinary", "corners", "half")
CHECKS = ("nonfinite", "below_zero", "above_n", "error", "pmf_mass", "pmf_support")
PMF_MASS_TOL = 1e-9


def unbounded_laws() -> dict[str, str]:
    """Laws whose count has no upper bound by definition (the check K <= ceil(n) does not apply to
    them), with the reason each declares with its code (``support`` "unbounded"). A law that declares
    nothing (a plugin, a custom law) is held to K <= ceil(n)."""
    out = {}
    for name in law_names():
        traits = law_traits(name)
        if traits["declared"] and traits["support"] == "unbounded":
            out[name] = traits["support_note"]
    return out


# Blends are evaluated at footprints on the boundary between level 0 and level 1 (P = A_1 =
# base_area * level_ratio) and one ulp either side: w -> 1 from below, w = 0 (P = A_1 is also w = 1
# of the lower bracket) and w = 0 plus one ulp.
BLEND_FOOTPRINTS = (("w=1-", -1), ("w=0", 0), ("w=0+", 1))

_EPS = {"float64": float(np.finfo(np.float64).eps), "float32": float(np.finfo(np.float32).eps)}
_MAX_CORNER_ROWS = 4096
_CHUNK_VALUES = 1 << 22  # doubles of uniforms materialized per evaluate call


# --------------------------------------------------------------------------------------------------
# Subjects: a law or a blend at one footprint, with one evaluation interface.

class _Subject:
    kind = "law"

    def __init__(self, lw, unbounded):
        self.obj = lw
        self.label = law_label(lw.name, lw.params)
        self.name = lw.name
        self.k = int(lw.n_uniforms)
        self.precisions = tuple(lw.precisions)
        self.binning = lw.binning
        self.has_pmf = bool(lw.has_pmf)
        self.bounded = lw.name not in unbounded
        if isinstance(lw, CustomLaw):
            self.kind = "custom"

    def n_eff(self, n):
        return n

    def evaluate(self, n, p, u, precision, uniform_set):
        """Raw K for rows (n, p, u); a custom law's output is returned unchecked (NaN stays NaN)."""
        if isinstance(self.obj, CustomLaw):
            # The law's public unchecked path: float32 inputs by the one float32 uniform rule, as every
            # other law gets them (docs/math/laws.md#float32-uniforms), never exact 0 or 1 uniforms.
            lw, m = self.obj, u.shape[0]
            n = np.broadcast_to(np.asarray(n, dtype=np.float64), (m,))
            p = np.broadcast_to(np.asarray(p, dtype=np.float64), (m,))
            out = lw.raw(n, p, u, precision)
            if out.shape != (m,):
                raise ValueError(f"custom law {lw.name!r} returned {out.size} values; expected {m}")
            return out
        return self.obj.evaluate(n, p, u, precision=precision)

    def pmf(self, n, p, max_support):
        return self.obj.pmf(n, p, max_support=max_support)


class _BlendSubject(_Subject):
    """A blend at a fixed footprint area P; n = N P, so N = n / P (rounded so that N P <= n)."""
    kind = "blend"

    def __init__(self, bl: BlendedLaw, tag: str, ulps: int):
        self.obj = bl
        self.name = bl.name
        self.label = f"{law_label(bl.name, bl.params)}[{bl.inner.name}]@{tag}"
        self.k = int(bl.inner.n_uniforms)
        self.precisions = ("float64",)
        self.binning = bl.binning
        self.has_pmf = bool(bl.has_pmf)
        self.bounded = bl.inner.name not in unbounded_laws()
        area = bl.base_area * bl.level_ratio ** 1
        for _ in range(abs(ulps)):
            area = float(np.nextafter(area, np.inf if ulps > 0 else 0.0))
        self.area = area
        self._variants = {}

    def density(self, n):
        if n == 0:
            return 0.0
        N = n / self.area
        while N * self.area > n:
            N = float(np.nextafter(N, 0.0))
        return N

    def n_eff(self, n):
        return self.density(n) * self.area

    def _blend_for(self, uniform_set):
        """ordinary: the blend itself. corners / half: the same blend over an inner law that maps its
        (Philox) uniforms to {0, 1/2, 1} or to 16-bit floats before evaluating the real inner law."""
        if uniform_set == "ordinary":
            return self.obj
        if uniform_set not in self._variants:
            bl, inner = self.obj, self.obj.inner
            transform = _snap_corners if uniform_set == "corners" else _to_half

            def fn(n, p, u, _inner=inner, _t=transform):
                return _inner.evaluate(n, p, _t(np.asarray(u, dtype=np.float64)))

            wrapped = CustomLaw(fn, inner.n_uniforms, f"{inner.name}<{uniform_set}>")
            self._variants[uniform_set] = blended_law(bl.name, inner=wrapped, level_ratio=bl.level_ratio,
                                                      base_area=bl.base_area, **bl.params)
        return self._variants[uniform_set]

    def sample_rows(self, n, p_rows, seed, uniform_set):
        bl = self._blend_for(uniform_set)
        return bl.sample(self.density(n), self.area, p_rows, size=len(p_rows), seed=seed)

    def pmf(self, n, p, max_support):
        return self.obj.pmf(self.density(n), self.area, p, max_support=max_support)


def _snap_corners(u):
    return np.where(u < 1 / 3, 0.0, np.where(u < 2 / 3, 0.5, 1.0))


def _to_half(u):
    return np.clip(np.asarray(u, dtype=np.float64).astype(np.float16).astype(np.float64), 0.0, 1.0)


def _subjects(laws, unbounded):
    out = []
    if laws is None:
        laws = list(law_names()) + [blended_law(b, inner="binomial") for b in blend_names()]
    elif isinstance(laws, (str, Law, BlendedLaw)):
        laws = [laws]
    for item in laws:
        if isinstance(item, str):
            item = get_law(item)
        if isinstance(item, BlendedLaw):
            out.extend(_BlendSubject(item, tag, ulps) for tag, ulps in BLEND_FOOTPRINTS)
        elif isinstance(item, Law):
            out.append(_Subject(item, unbounded))
        else:
            raise ValueError(f"laws: {item!r} is invalid; expected a law name, a glintlab.law(...), "
                             "a glintlab.custom_law(...) or a glintlab.blended_law(...)")
    return out


# --------------------------------------------------------------------------------------------------
# Uniform sets.

def corner_uniforms(k: int, max_rows: int = _MAX_CORNER_ROWS, seed: int = 1) -> np.ndarray:
    """Uniform rows whose coordinates are exactly 0, 1/2 or 1.

    All 3^k rows of {0, 1/2, 1}^k when that fits in ``max_rows`` (k <= 7; this includes the 2^k
    corners); otherwise all 2^k corners if they fit, else structured corners (all 0, all 1, one
    coordinate flipped, prefixes of zeros and of ones, alternating) plus random corners; then the
    1/2 mixes (all 1/2, one coordinate 1/2 among zeros or ones, random rows over {0, 1/2, 1}).
    """
    if k == 0:
        return np.zeros((1, 0))
    if 3 ** k <= max_rows:
        grid = np.array(np.meshgrid(*([[0.0, 0.5, 1.0]] * k), indexing="ij")).reshape(k, -1).T
        return np.ascontiguousarray(grid)
    rng = np.random.default_rng(seed)
    half_budget = max_rows // 2
    if 2 ** k <= half_budget:
        corners = ((np.arange(2 ** k)[:, None] >> np.arange(k)) & 1).astype(np.float64)
    else:
        eye = np.eye(k)
        tri = np.tril(np.ones((k + 1, k)), -1)  # rows with the first j coordinates 1
        alt = (np.arange(k) % 2).astype(np.float64)
        structured = np.vstack([np.zeros((1, k)), np.ones((1, k)), eye, 1 - eye, tri, 1 - tri, alt, 1 - alt])
        extra = rng.integers(0, 2, size=(max(0, half_budget - len(structured)), k)).astype(np.float64)
        corners = np.vstack([structured, extra])
    eye = np.eye(k)
    mixes = np.vstack([np.full((1, k), 0.5), 0.5 * eye, 1 - 0.5 * eye,
                       0.5 * rng.integers(0, 3, size=(max(0, max_rows - len(corners) - 2 * k - 1), k))])
    rows = np.unique(np.vstack([corners, mixes]), axis=0)
    return np.ascontiguousarray(rows)


def _uniform_sets(k, samples, seed):
    ordinary = uniforms(samples, k, seed=seed)
    return {"ordinary": ordinary, "corners": corner_uniforms(k, seed=seed), "half": _to_half(ordinary)}


# --------------------------------------------------------------------------------------------------
# The table.

def _reference_var(n, p):
    """Variance of the stratified binomial at (n, p): m p q + f p (1 - f p), n = m + f."""
    m = math.floor(n)
    f = n - m
    return m * p * (1 - p) + f * p * (1 - f * p)


def _evaluate_law(sub, precision, set_name, U, nn, pp):
    """Values per grid point (array or None) and error text per point."""
    m = U.shape[0]
    values, errors = [None] * len(nn), [""] * len(nn)
    per_chunk = max(1, _CHUNK_VALUES // max(1, m * max(1, sub.k)))
    for i0 in range(0, len(nn), per_chunk):
        idx = range(i0, min(len(nn), i0 + per_chunk))
        try:
            with np.errstate(all="ignore"):
                big = sub.evaluate(np.repeat(nn[idx.start:idx.stop], m), np.repeat(pp[idx.start:idx.stop], m),
                                   np.tile(U, (len(idx), 1)), precision, set_name)
            for j, i in enumerate(idx):
                values[i] = big[j * m:(j + 1) * m]
        except Exception:  # attribute the failure to grid points
            for i in idx:
                try:
                    with np.errstate(all="ignore"):
                        values[i] = sub.evaluate(np.full(m, nn[i]), np.full(m, pp[i]), U, precision, set_name)
                except Exception as exc:
                    errors[i] = f"evaluate: {type(exc).__name__}: {exc}"
    return values, errors


def _evaluate_blend(sub, set_name, samples, seed, nn, pp):
    values, errors = [None] * len(nn), [""] * len(nn)
    for n in sorted(set(nn.tolist())):
        idx = np.flatnonzero(nn == n)
        try:
            with np.errstate(all="ignore"):
                big = sub.sample_rows(n, np.repeat(pp[idx], samples), seed, set_name)
            for j, i in enumerate(idx):
                values[i] = big[j * samples:(j + 1) * samples]
        except Exception:
            for i in idx:
                try:
                    with np.errstate(all="ignore"):
                        values[i] = sub.sample_rows(n, np.full(samples, pp[i]), seed, set_name)
                except Exception as exc:
                    errors[i] = f"sample: {type(exc).__name__}: {exc}"
    return values, errors


def _pmf_point(sub, n, p, max_support):
    """(pmf_mass, pmf_support_ok, pmf_above_n, note, error) at one point."""
    try:
        d = sub.pmf(n, p, max_support)
    except NotImplementedError as exc:
        return np.nan, None, np.nan, f"no exact pmf: {exc}", ""
    except ValueError as exc:
        msg = str(exc)
        if "max_support" in msg or "support points" in msg:
            return np.nan, None, np.nan, f"not computed (support too large): {msg}", ""
        return np.nan, None, np.nan, "", f"pmf: ValueError: {msg}"
    except Exception as exc:  # noqa: BLE001 - a valid input must not raise: recorded as a failure
        return np.nan, None, np.nan, "", f"pmf: {type(exc).__name__}: {exc}"
    probs, support = np.asarray(d.probs), np.asarray(d.support)
    mass = abs(float(np.sum(probs)) - 1.0) if np.all(np.isfinite(probs)) else np.inf
    top = math.ceil(sub.n_eff(n)) if sub.bounded else np.inf
    ok = bool(support.size > 0 and np.all(np.isfinite(support)) and support.min() >= 0 and support.max() <= top)
    above = float(np.sum(probs[support > top])) if sub.bounded else np.nan
    return mass, ok, above, "", ""


def extremes_table(laws=None, precisions=("float64", "float32"), samples: int = 4096, seed: int = 1, *,
                   n=GRID_N, p=GRID_P, pmf_max_support: int = 2_000_000, blend_pmf_max_support: int = 5_000,
                   unbounded=None,
                   threads=None) -> pd.DataFrame:
    """The numerical-extremes suite (docs/math/extremes.md): one row per (law, precision, n, p, uniform set).

    laws: names, ``gl.law(...)``, ``gl.custom_law(...)`` or ``gl.blended_law(...)`` objects (a blend
    is evaluated at the three ``BLEND_FOOTPRINTS``, labelled ``name[inner]@w=...``; blends run in
    float64 only); default every registered law plus every blend over the binomial. A law is run in
    each of ``precisions`` it supports.

    Columns: law, kind (law, custom, blend), precision, n, p, uniforms, evaluations, nonfinite,
    below_zero (raw K < 0), above_n (K > ceil(n), binned K for laws with binning "round"; 0 for
    laws of ``unbounded_laws()`` such as poisson), bound, k_min and k_max (finite raw K: on the corners
    they show what u = 0 and u = 1 do), mean, mean_err (mean - n p), mean_rel_err,
    mean_z, half_shift (half rows: mean of the float16-rounded draws minus the ordinary mean, same
    draws rounded), pmf_mass (|sum(probs) - 1|), pmf_support_ok (support within [0, ceil(n)]), pmf_above_n
    (the pmf's mass above ceil(n): how likely a break is), pmf_note (why no pmf), error (text of
    any exception on these valid inputs), ok. The counts are numbers of evaluations.

    mean, mean_err and mean_z are filled for the ``ordinary`` and ``half`` sets (NaN for corners and
    when any draw is non-finite). mean_z = mean_err / se with se^2 = max(s^2, v) / samples +
    (eps max(|n p|, 1))^2: s^2 the sample variance, v the variance of the exact reference (the
    stratified binomial, m p q + f p (1 - f p) for n = m + f; n p for unbounded laws), eps the
    precision's epsilon. So mean_z counts the standard errors an exact sampler would have, and stays
    finite where the draws are all equal (n p ~ 0, zero-variance laws, float32 rounding of n p).
    Blends use n = N P with N = n / P rounded down until N P <= n.

    The pmf is computed once per (law, n, p) (``max_support`` = ``pmf_max_support``, and
    ``blend_pmf_max_support`` for blends, whose exact laws combine two levels' supports: zk16_linear's
    output blend costs the product of the supports, 8 minutes at n = 1e9, p = 1/2; a refusal for a
    too large support is noted in pmf_note, not a failure) and reported on the float64
    ``ordinary`` row. ok = no non-finite, negative or above-n K, no exception, pmf_mass <= 1e-9
    and pmf support within [0, ceil(n)] where computed. Elapsed seconds are in
    ``table.attrs["seconds"]``.
    """
    t0 = time.perf_counter()
    V.integer("samples", samples, minimum=2)
    for prec in precisions:
        if prec not in _EPS:
            V.fail("precisions", precisions, "'float64' and/or 'float32'")
    unbounded = unbounded_laws() if unbounded is None else dict(unbounded)
    subjects = _subjects(laws, unbounded)
    nn, pp = (a.ravel() for a in np.meshgrid(np.asarray(n, dtype=float), np.asarray(p, dtype=float), indexing="ij"))

    workers = threads or os.cpu_count() or 2
    # pmf per (subject, point), then the evaluations per (subject, precision, uniform set), both on
    # every core (pmf, evaluate and sample release the GIL).
    jobs = [(s, i) for s in subjects if s.has_pmf for i in range(nn.size)]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        results = list(pool.map(lambda job: _pmf_point(
            job[0], nn[job[1]], pp[job[1]], blend_pmf_max_support if job[0].kind == "blend" else pmf_max_support),
            jobs))
    pmf = {(id(s), i): r for (s, i), r in zip(jobs, results)}

    sets = {id(sub): _uniform_sets(sub.k, samples, seed) for sub in subjects if sub.kind != "blend"}

    def run(job):
        sub, prec, set_name = job
        if sub.kind == "blend":
            values, errors = _evaluate_blend(sub, set_name, samples, seed, nn, pp)
        else:
            values, errors = _evaluate_law(sub, prec, set_name, sets[id(sub)][set_name], nn, pp)
        bound = "ceil(n)" if sub.bounded else f"none ({unbounded.get(sub.name, 'unbounded')})"
        return [_row(sub, prec, set_name, nn[i], pp[i], values[i], errors[i], pmf.get((id(sub), i)), bound)
                for i in range(nn.size)]

    jobs = [(sub, prec, set_name) for sub in subjects for prec in precisions if prec in sub.precisions
            for set_name in UNIFORM_SETS]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        rows = [r for chunk in pool.map(run, jobs) for r in chunk]
    cols = ["law", "kind", "precision", "n", "p", "uniforms", "evaluations", "nonfinite", "below_zero", "above_n",
            "bound", "k_min", "k_max", "mean", "mean_err", "mean_rel_err", "mean_z", "pmf_mass", "pmf_support_ok",
            "pmf_above_n", "pmf_note", "error", "ok"]
    table = pd.DataFrame(rows, columns=cols)
    table["pmf_support_ok"] = table["pmf_support_ok"].astype("boolean")
    # How far rounding the uniforms to float16 moves the mean (a shader's stored random numbers).
    keys = ["law", "precision", "n", "p"]
    ordinary = table.loc[table.uniforms == "ordinary", keys + ["mean"]].rename(columns={"mean": "_ordinary_mean"})
    merged = table[keys].merge(ordinary, on=keys, how="left")
    shift = table["mean"].to_numpy() - merged["_ordinary_mean"].to_numpy()
    table.insert(cols.index("mean_z") + 1, "half_shift", np.where(table.uniforms == "half", shift, np.nan))
    table.attrs["seconds"] = time.perf_counter() - t0
    table.attrs["samples"] = samples
    table.attrs["seed"] = seed
    return table


def _row(sub, prec, set_name, n, p, v, error, pmf_result, bound):
    n_eff = sub.n_eff(n)
    row = dict(law=sub.label, kind=sub.kind, precision=prec, n=n, p=p, uniforms=set_name,
               evaluations=0 if v is None else int(v.size), nonfinite=0, below_zero=0, above_n=0, bound=bound,
               k_min=np.nan, k_max=np.nan,
               mean=np.nan, mean_err=np.nan, mean_rel_err=np.nan, mean_z=np.nan, pmf_mass=np.nan,
               pmf_support_ok=None, pmf_above_n=np.nan, pmf_note="", error=error)
    if pmf_result is not None:
        mass, sup_ok, above, note, pmf_error = pmf_result
        if prec == "float64" and set_name == "ordinary":
            row.update(pmf_mass=mass, pmf_support_ok=sup_ok, pmf_above_n=above, pmf_note=note)
            if pmf_error:
                row["error"] = f"{error}; {pmf_error}" if error else pmf_error
    if v is not None:
        finite = np.isfinite(v)
        binned = np.floor(v + 0.5) if sub.binning == "round" else v
        row["nonfinite"] = int(np.count_nonzero(~finite))
        if finite.any():
            row["k_min"], row["k_max"] = float(np.min(v[finite])), float(np.max(v[finite]))
        row["below_zero"] = int(np.count_nonzero(finite & (v < 0)))
        if sub.bounded:
            row["above_n"] = int(np.count_nonzero(finite & (binned > math.ceil(n_eff))))
        if set_name != "corners" and finite.all() and v.size > 1:
            expected = n_eff * p
            mean = float(np.mean(v))
            s2 = float(np.var(v, ddof=1))
            ref = n_eff * p if not sub.bounded else _reference_var(n_eff, p)
            se = math.sqrt(max(s2, ref) / v.size + (_EPS[prec] * max(abs(expected), 1.0)) ** 2)
            err = mean - expected
            row.update(mean=mean, mean_err=err, mean_rel_err=err / expected if expected else np.nan, mean_z=err / se)
    row["ok"] = bool(row["nonfinite"] == 0 and row["below_zero"] == 0 and row["above_n"] == 0 and not row["error"]
                     and not (row["pmf_mass"] > PMF_MASS_TOL) and row["pmf_support_ok"] is not False)
    return row


def failed_checks(table: pd.DataFrame) -> pd.DataFrame:
    """Boolean frame (one column per check of ``CHECKS``): which checks each row fails."""
    return pd.DataFrame({
        "nonfinite": table["nonfinite"] > 0,
        "below_zero": table["below_zero"] > 0,
        "above_n": table["above_n"] > 0,
        "error": table["error"].fillna("").astype(str) != "",
        "pmf_mass": table["pmf_mass"].fillna(0) > PMF_MASS_TOL,
        "pmf_support": table["pmf_support_ok"].astype("boolean").fillna(True) == False,  # noqa: E712
    }, index=table.index)


# --------------------------------------------------------------------------------------------------
# Summary.

def _fmt(x):
    return f"{x:.12g}" if isinstance(x, (float, np.floating)) else str(x)


def extremes_summary(table: pd.DataFrame, where_limit: int = 3) -> pd.DataFrame:
    """Per law and precision: points (rows), failures (rows not ok), the number of failing rows per
    check, failed_checks (text), where_failed (the first ``where_limit`` (n, p, uniforms) per failing
    check), worst_mean_z (largest |mean_z| over the ordinary draws, signed), its (n, p) and mean_err,
    and worst_half_shift (largest |half_shift| / max(1, n p): what float16 uniforms do to the mean)
    with its (n, p)."""
    fails = failed_checks(table)
    out = []
    for (name, prec), g in table.groupby(["law", "precision"], sort=False):
        f = fails.loc[g.index]
        counts = {c: int(f[c].sum()) for c in CHECKS}
        where = []
        for c in CHECKS:
            if counts[c]:
                pts = g[f[c]].head(where_limit)
                where.append(f"{c}: " + ", ".join(f"(n={_fmt(r.n)}, p={_fmt(r.p)}, {r.uniforms})"
                                                    for r in pts.itertuples()))
        ordinary = g[(g.uniforms == "ordinary") & g.mean_z.notna()]
        if len(ordinary):
            worst = ordinary.loc[ordinary.mean_z.abs().idxmax()]
            wz, wn, wp, werr = float(worst.mean_z), float(worst.n), float(worst.p), float(worst.mean_err)
        else:
            wz = wn = wp = werr = np.nan
        half = g[(g.uniforms == "half") & g.half_shift.notna()]
        hs, hn, hp = np.nan, np.nan, np.nan
        if len(half):
            rel = half.half_shift.abs() / np.maximum(1.0, half.n * half.p)
            worst = half.loc[rel.idxmax()]
            hs, hn, hp = float(rel.max()), float(worst.n), float(worst.p)
        out.append(dict(law=name, kind=g.kind.iloc[0], precision=prec, points=len(g),
                        failures=int((~g.ok).sum()), **counts,
                        failed_checks=", ".join(f"{c} ({counts[c]})" for c in CHECKS if counts[c]),
                        where_failed="; ".join(where), worst_mean_z=wz, worst_z_n=wn, worst_z_p=wp,
                        worst_z_mean_err=werr, worst_half_shift=hs, worst_half_n=hn, worst_half_p=hp))
    return pd.DataFrame(out)


# --------------------------------------------------------------------------------------------------
# Invalid inputs.

INVALID_N = (-1.0, float("nan"), float("inf"))
INVALID_P = (-1e-300, 1 + 1e-15, float("nan"))
INVALID_U = (-1e-300, float(np.nextafter(1.0, 2.0)), float("nan"))


def _value_named(message, param, value):
    """(names_parameter, names_value): the message has "param = value" (or "param[i, j] = value")."""
    m = re.search(rf"(?<![\w.]){re.escape(param)}(\[[^\]]*\])?\s*=\s*([^\s;,]+)", message)
    if not m:
        return False, False
    token = m.group(2).rstrip(".:)")
    try:
        got = float(token)
    except ValueError:
        return True, False
    same = (math.isnan(got) and math.isnan(value)) or got == value
    return True, bool(same)


def _try(fn):
    try:
        fn()
    except ValueError as exc:
        return "ValueError", str(exc)
    except Exception as exc:  # noqa: BLE001 - recorded, not hidden
        return type(exc).__name__, str(exc)
    return "returned", ""


def invalid_inputs_table(laws=None) -> pd.DataFrame:
    """Invalid inputs must raise ValueError naming the parameter and the value.

    Laws (default: every registered law and every blend over the binomial): ``evaluate`` in each
    supported precision with n in ``INVALID_N``, p in ``INVALID_P`` and u in ``INVALID_U`` (the
    other arguments valid: n = 16, p = 0.5, u = 0.5), ``sample`` with the bad n and p, and ``pmf``
    when the law has one. Blends: ``sample`` and ``pmf`` with bad N, P (also 0) and p.

    Columns: law, method, precision, parameter, value, outcome (ValueError, another exception's
    name, or "returned" when nothing was raised), message, names_parameter, names_value, ok.
    """
    if laws is None:
        laws = list(law_names()) + [blended_law(b, inner="binomial") for b in blend_names()]
    elif isinstance(laws, (str, Law, BlendedLaw)):
        laws = [laws]
    rows = []

    def record(label, method, prec, param, value, fn):
        outcome, msg = _try(fn)
        named_p, named_v = _value_named(msg, param, value) if outcome == "ValueError" else (False, False)
        rows.append(dict(law=label, method=method, precision=prec, parameter=param, value=value, outcome=outcome,
                         message=msg, names_parameter=named_p, names_value=named_v,
                         ok=outcome == "ValueError" and named_p and named_v))

    for item in laws:
        item = get_law(item) if isinstance(item, str) else item
        if isinstance(item, BlendedLaw):
            label = f"{law_label(item.name, item.params)}[{item.inner.name}]"
            N, P, p = 4096.0, 2.5 * item.base_area, 0.5
            cases = [("N", v, (v, P, p)) for v in INVALID_N] + \
                    [("P", v, (N, v, p)) for v in (-1.0, 0.0, float("nan"), float("inf"))] + \
                    [("p", v, (N, P, v)) for v in INVALID_P]
            for param, value, args in cases:
                record(label, "sample", "float64", param, value,
                       lambda a=args: item.sample(a[0], a[1], a[2], size=4, seed=1))
                if item.has_pmf:
                    record(label, "pmf", "float64", param, value, lambda a=args: item.pmf(*a))
            continue
        if not isinstance(item, Law):
            raise ValueError(f"laws: {item!r} is invalid; expected a law name, a law object or a blended law")
        label, k = law_label(item.name, item.params), item.n_uniforms
        good_u = np.full((1, k), 0.5)
        np_cases = [("n", v, (v, 0.5)) for v in INVALID_N] + [("p", v, (16.0, v)) for v in INVALID_P]
        for prec in item.precisions:
            for param, value, (n, p) in np_cases:
                record(label, "evaluate", prec, param, value,
                       lambda n=n, p=p, prec=prec: item.evaluate(n, p, good_u, precision=prec))
            if k:
                for value in INVALID_U:
                    bad_u = np.full((1, k), 0.5)
                    bad_u[0, k - 1] = value
                    record(label, "evaluate", prec, "u", value,
                           lambda bad_u=bad_u, prec=prec: item.evaluate(16.0, 0.5, bad_u, precision=prec))
        for param, value, (n, p) in np_cases:
            record(label, "sample", "float64", param, value, lambda n=n, p=p: item.sample(n, p, size=4, seed=1))
            if item.has_pmf:
                record(label, "pmf", "float64", param, value, lambda n=n, p=p: item.pmf(n, p))
    return pd.DataFrame(rows, columns=["law", "method", "precision", "parameter", "value", "outcome", "message",
                                       "names_parameter", "names_value", "ok"])
