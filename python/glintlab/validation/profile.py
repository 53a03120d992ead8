"""Scene profiles: regime map, pixel-weighted law errors, grid-scheme evaluations and a SIMD cost model
(the advisor, ``glintlab.validation.advisor``, picks a law from them).

Law errors. A law's error at a pixel is its exact error against the binomial at the pixel's (n, p)
(the single-footprint law, docs/math/laws.md; the grid scheme's own error is reported separately as its
weight bias). Pixels are binned in (log10 n, log10 p) with ``bins_per_decade`` bins per decade;
each occupied bin is evaluated once, at the pixel-weighted mean (n, p) of its pixels, and its
errors are given to all its pixels. ``binning_check`` compares with a binning twice as fine.
Pixels with p = 0 (unlit, or D(h) = 0) have K = 0 under every law: error 0.

Cost model (modelled cost units = ns of one CPU evaluation, not GPU milliseconds). The cost of a
pixel under (grid scheme, law) is evaluations x c_law, the evaluations counted per pixel by
``count_image``, c_law the law's ns per evaluation (mean over fixed (n, p) points, each draw at its own
(n, p) within a factor 2 of the point, so that a law's per-(n, p) setup is paid per draw as at a scene's
pixels: a constant, which flatters laws whose cost grows with n p). A law whose
cost grows with (n, p) declares a cost model with its code (``law.work_units``; zk16: min(ceil n_t,
cap) Bernoulli trials when n_t p <= 5, DB23 §7.1) and the points that separate its terms
(``cost_points``): c_law and the ns per work unit are fitted to its timings there, and each term of a
pixel adds work_units(n_t, p) at that price, n_t the term's trial count from the scheme's ``terms``
(evaluated per (n, r, phi) bin and scaled by n / n_bin). The ns come from the table recorded with the
package (``glintlab/data/costs/laws.json``, written by ``scripts/record_law_costs.py`` from
``measure_costs``), not from timing in this process: a profile, and so the advisor's pick and the
report, must not change with the machine's load. Timing in-process is the explicit ``costs="measure"``.
A SIMD group of 8 x 4 pixels
costs its most expensive lane (branches diverge: every lane waits for the worst); pixels that miss
the primitive are inactive lanes of cost 0.
"""
from __future__ import annotations

import json
import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .. import _core
from ..api import checks as V
from ..api import fpmath
from ..api.grids import IMAGE_CONFIGS, configured_counter
from ..api.laws import law as get_law, law_label, law_traits, parse_law_label
from ..api.metrics import distance
from ..resources import data_path
from .bench import DEFAULT_LAWS  # the trade study's laws, labelled by name and parameters
from .scene import Scene, load_scene

# Grid scheme configurations (labels of glintlab.api.grids.IMAGE_CONFIGS); each is counted with its
# scheme's native law (declared with the scheme in core/grids/).
DEFAULT_SCHEMES = ("db23_trilinear", "db23_tetrahedral", "db23_shader_48", "zk16_aniso")
# Expected counts below this are "dark": K = 0 with probability > 1 - 1e-9 under every law, and the
# pmfs (trimmed at 1e-14 of mass) cannot resolve relative errors there. They count as exact.
DARK_NP = 1e-9
TILE = (4, 8)  # SIMD group: 4 rows x 8 columns = 32 lanes
N_BANDS = (0.0, 1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6, math.inf)
P_BANDS = ("p = 0", "p < 1e-6", "1e-6 <= p < 1e-2", "1e-2 <= p < 0.5", "0.5 <= p <= 1-1e-6", "p > 1-1e-6")
R_BANDS = (1.0, 2.0, 16.0, math.inf)
# The comparison of DB23 Table 1: (label, scheme, law) and the paper's ms (min, max over densities).
TABLE1_METHODS = (("ZK16", "zk16_aniso", "zk16"), ("DB23 tetrahedral", "db23_tetrahedral", "gated"),
                  ("DB23 shader (48)", "db23_shader_48", "gated"))
TABLE1_MS = {"sphere": ((0.79, 0.82), (1.15, 1.41)), "plane_90": ((1.15, 1.25), (1.40, 1.83)),
             "plane_25": ((1.15, 1.26), (2.50, 3.18)), "heightfield_90": ((1.52, 1.63), (1.93, 2.48)),
             "heightfield_25": ((1.44, 1.54), (3.29, 4.15))}


def native_law(config: str) -> str:
    """The law a scheme configuration is counted with: its scheme's declared native law."""
    scheme = IMAGE_CONFIGS[config][0]
    return _core.grid_scheme_traits(scheme)["native_law"]


def has_cost_model(lw) -> bool:
    """Whether the law declares a cost that grows with (n, p) (cost points to fit it on)."""
    return bool(law_traits(lw.name)["cost_points"])


def _resolve_laws(laws):
    out = {}
    for item in DEFAULT_LAWS if laws is None else laws:
        if isinstance(item, str):
            item = (item, {})
        name, params = item
        lw = get_law(name, **params)
        if not lw.has_pmf:
            V.fail("laws", name, "laws with an exact pmf (the errors are exact)")
        out[law_label(name, params)] = lw  # as given: "zk16", not zk16[cap=16.0]
    if "binomial" not in out:
        out = {"binomial": get_law("binomial"), **out}
    return out


# --------------------------------------------------------------------------------------------------
# Cost table

_COST_CACHE: dict = {}
COST_POINTS = ((3.5, 0.5), (16.0, 0.1), (1e3, 1e-2), (1e6, 0.3))


def measure_costs(laws=None, size: int = 100_000, repeats: int = 5) -> pd.DataFrame:
    """ns per evaluation of each law, measured in this process (``law.sample`` on one core, its CPU
    time, best of ``repeats``; at each point ``size`` draws, each at its own (n, p) around the point,
    :func:`spread_point`): what ``costs="measure"`` uses (profiles default to the recorded table,
    ``recorded_costs``). A constant-cost law: the mean over COST_POINTS, ``ns_per_trial`` 0. A law with a cost
    model (``law.work_units`` and its declared ``cost_points``): ns = ns_per_eval + ns_per_trial x
    work_units fitted by least squares to its timings at those points (zk16: its Gaussian branch and
    its loop of 1 and 16 Bernoulli trials). Cached per process."""
    laws = _resolve_laws(laws)
    todo = {label: lw for label, lw in laws.items() if (label, size, repeats) not in _COST_CACHE}
    if todo:
        # Round robin over the laws, best of `repeats` rounds per (law, point): a machine shared with
        # other jobs slows whole stretches of time, and interleaving spreads that over every law.
        best = {}

        def points(lw):
            return tuple(tuple(x) for x in law_traits(lw.name)["cost_points"]) or COST_POINTS

        threads = _core.num_threads()
        _core.set_num_threads(1)  # one core: no dispatch overhead, and less exposed to a busy second core
        try:
            rounds(todo, points, best, repeats, size)
        finally:
            _core.set_num_threads(threads)
        for label, lw in todo.items():
            if has_cost_model(lw):
                pts = points(lw)
                # The mean work of the draws timed at each point (they spread around it: spread_point).
                work = np.array([float(np.mean(lw.work_units(*spread_point(n, p, size)))) for n, p in pts])
                ns = np.array([best[label, n, p] for n, p in pts])
                (fixed, per_unit), *_ = np.linalg.lstsq(np.stack([np.ones_like(work), work], axis=1), ns, rcond=None)
                _COST_CACHE[label, size, repeats] = {"ns_per_eval": max(float(fixed), 0.0),
                                                     "ns_per_trial": max(float(per_unit), 0.0)}
            else:
                _COST_CACHE[label, size, repeats] = {
                    "ns_per_eval": float(np.mean([best[label, n, p] for n, p in COST_POINTS])), "ns_per_trial": 0.0}
    return pd.DataFrame([{"law": label, **_COST_CACHE[label, size, repeats]} for label in laws])


#: Each timed draw has its own (n, p): the point's times a log-uniform factor in [1/SPREAD, SPREAD] each
#: (p at most P_SPREAD_MAX), seeded.
SPREAD, P_SPREAD_MAX, SPREAD_SEED = 2.0, 0.99, 1


def spread_point(n: float, p: float, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``size`` (n, p) pairs around the point, each its own: a scene's pixels each have their own (n, p), so
    a law's per-(n, p) setup (the binomial's sampler constants, a law's regime and tables) is paid at every
    draw, as in a scene. 100,000 draws at one (n, p) paid it once: the exact binomial timed 8.7 ns there
    and 15-29 ns over the shipped scenes' own pixels (bench/bench_advisor_costs.py)."""
    rng = np.random.default_rng(SPREAD_SEED)
    f = np.exp(rng.uniform(-math.log(SPREAD), math.log(SPREAD), (2, size)))
    return n * f[0], np.minimum(p * f[1], P_SPREAD_MAX)


def rounds(todo, points, best, repeats, size):
    # The calling thread's CPU time (the draws run on it: one thread): a busy machine delays a timing
    # but adds little to it (wall-clock timings of one law varied 8x under a load of 10 on 2 cores).
    pairs = {}
    for _ in range(repeats):
        for label, lw in todo.items():
            for n, p in points(lw):
                if (n, p) not in pairs:
                    pairs[n, p] = spread_point(n, p, size)
                t0 = time.thread_time()
                lw.sample(*pairs[n, p], seed=1)
                dt = (time.thread_time() - t0) / size * 1e9
                best[label, n, p] = min(best.get((label, n, p), math.inf), dt)


# The law costs recorded with the package (see the module docstring): the profile's default.
RECORDED_COSTS = ("costs", "laws.json")


def recorded_costs(labels=None) -> pd.DataFrame:
    """The recorded law costs (``glintlab/data/costs/laws.json``): law, ns_per_eval, ns_per_trial, one
    row per label of ``labels`` (default: every recorded label). A label without a recorded cost is a
    ValueError naming it: pass ``costs="measure"`` (timed in this process) or a table instead."""
    doc = json.loads(data_path(*RECORDED_COSTS).read_text())
    table = pd.DataFrame([{"law": label, "ns_per_eval": float(c["ns_per_eval"]), "ns_per_trial": float(c["ns_per_trial"])}
                          for label, c in doc["laws"].items()])
    if labels is None:
        return table
    missing = [x for x in labels if x not in set(table.law)]
    if missing:
        V.fail("costs", f"the recorded table without {missing}",
               "a recorded cost for every law (scripts/record_law_costs.py), costs='measure' or a table")
    return table.set_index("law").loc[list(labels)].reset_index()


def _cost_table(costs, labels):
    if costs is None:
        costs = recorded_costs(labels)
    elif isinstance(costs, str):
        if costs != "measure":
            V.fail("costs", costs, "None (the recorded costs), 'measure', a table or a dict")
        costs = measure_costs([parse_law_label(x) for x in labels])
    if isinstance(costs, dict):
        costs = pd.DataFrame([{"law": k, "ns_per_eval": v if not isinstance(v, (tuple, list)) else v[0],
                               "ns_per_trial": 0.0 if not isinstance(v, (tuple, list)) else v[1]}
                              for k, v in costs.items()])
    missing = [x for x in labels if x not in set(costs.law)]
    if missing:
        V.fail("costs", f"a table without {missing}", "a cost (ns per evaluation) for every law")
    costs = costs.set_index("law").loc[list(labels)].reset_index()
    if "ns_per_trial" not in costs:
        costs["ns_per_trial"] = 0.0
    for row in costs.itertuples():
        if not (math.isfinite(row.ns_per_eval) and row.ns_per_eval >= 0):
            V.fail(f"costs[{row.law!r}]", row.ns_per_eval, "a finite number >= 0")
    return costs


# --------------------------------------------------------------------------------------------------
# SIMD groups

def group_max(cost: np.ndarray, active: np.ndarray | None = None, tile=TILE):
    """(group cost, active lanes) per tile of ``tile`` = (rows, columns) pixels: the maximum over the
    tile's active pixels (0 when none). Edge tiles are padded with inactive lanes."""
    cost = np.asarray(cost, dtype=np.float64)
    active = np.ones(cost.shape, bool) if active is None else np.asarray(active, bool)
    th, tw = tile
    H, W = cost.shape
    Hp, Wp = -(-H // th) * th, -(-W // tw) * tw
    c = np.zeros((Hp, Wp))
    a = np.zeros((Hp, Wp), bool)
    c[:H, :W] = np.where(active, cost, 0.0)
    a[:H, :W] = active
    c = c.reshape(Hp // th, th, Wp // tw, tw)
    a = a.reshape(Hp // th, th, Wp // tw, tw)
    return c.max(axis=(1, 3)), a.sum(axis=(1, 3))


def simd_stats(cost: np.ndarray, active: np.ndarray, tile=TILE) -> dict:
    g, lanes = group_max(cost, active, tile)
    used = lanes > 0
    mean_px = float(cost[active].mean()) if active.any() else 0.0
    mean_g = float(g[used].mean()) if used.any() else 0.0
    return {"mean_pixel": mean_px, "mean_group": mean_g, "p95_group": float(np.percentile(g[used], 95)) if used.any() else 0.0,
            "worst_group": float(g.max()) if used.any() else 0.0,
            "simd_efficiency": mean_px / mean_g if mean_g > 0 else 1.0}


# --------------------------------------------------------------------------------------------------
# Binning and exact errors

def _log_bins(x, per_decade):
    # fpmath: numpy's log10 loop depends on the arrays' addresses (last bit), enough to move a bin edge.
    return np.floor(fpmath.call(np.log10, x) * per_decade).astype(np.int64)


def _bin_pixels(n, p, per_decade):
    """Bin index per pixel over occupied (log10 n, log10 p) bins, with the pixel-weighted mean (n, p)
    of each bin; p = 0 and dark pixels (n p < DARK_NP) go to a bin of their own (evaluated as exact)."""
    pos = n * p >= DARK_NP
    key = np.full(n.shape, -1, np.int64)
    i, j = _log_bins(n[pos], per_decade), _log_bins(p[pos], per_decade)
    key[pos] = (i - i.min() + 1) * 10_000_000 + (j - j.min() + 1) if pos.any() else 0
    uniq, inv = np.unique(key, return_inverse=True)
    counts = np.bincount(inv)
    rep_n = np.bincount(inv, weights=n) / counts
    rep_p = np.bincount(inv, weights=p) / counts
    zero = uniq == -1
    rep_p[zero] = 0.0
    rep_n[zero] = 0.0
    return inv, counts, rep_n, rep_p


def law_errors(laws: dict, n_points, p_points, threads: int | None = None) -> pd.DataFrame:
    """Exact errors of each law against the binomial at points (n_k, p_k): tv, mean_rel_err =
    |E[K] / (n p) - 1| (the intensity error of D_P, docs/math/ndf.md#ndf-estimator) and rel_rms = sqrt(E[(K - n p)^2]) / (n p)
    (the per-pixel noise of D_P against D(h)). Like ``gl.error_table`` but on a list of points and
    with the second moment; pmfs release the GIL, so threads run points in parallel."""
    ref = get_law("binomial")

    def one(k):
        nn, pp = float(n_points[k]), float(p_points[k])
        if pp <= 0 or nn * pp < DARK_NP:
            return [{"law": lab, "point": k, "tv": 0.0, "mean_rel_err": 0.0, "rel_rms": 0.0} for lab in laws]
        d_ref = ref.pmf(nn, pp)
        mu = nn * pp
        rows = []
        for lab, lw in laws.items():
            d = d_ref if lab == "binomial" else lw.pmf(nn, pp)
            rows.append({"law": lab, "point": k, "tv": 0.0 if d is d_ref else distance(d, d_ref, "tv"),
                         # The reference's mean is n p exactly (floor(n) p + frac(n) p); its pmf's mean
                         # differs by round-off and the 1e-14 trimming, which is no error of the law.
                         "mean_rel_err": 0.0 if d is d_ref else abs(d.mean / mu - 1.0),
                         "rel_rms": math.sqrt(max(d.var + (d.mean - mu) ** 2, 0.0)) / mu})
        return rows

    with ThreadPoolExecutor(max_workers=threads or 2) as pool:
        rows = [r for chunk in pool.map(one, range(len(n_points))) for r in chunk]
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------------------
# Regimes

def n_band(n):
    idx = np.searchsorted(N_BANDS, n, side="right") - 1
    labels = ["n < 1"] + [f"{N_BANDS[k]:g} <= n < {N_BANDS[k + 1]:g}" for k in range(1, len(N_BANDS) - 2)] + \
             [f"n >= {N_BANDS[-2]:g}"]
    return idx, labels


def _p_band(p):
    idx = np.select([p == 0, p < 1e-6, p < 1e-2, p < 0.5, p <= 1 - 1e-6], [0, 1, 2, 3, 4], 5)
    return idx, list(P_BANDS)


def _r_band(r):
    idx = np.searchsorted(R_BANDS, r, side="right") - 1
    return np.clip(idx, 0, 2), ["1 <= r < 2", "2 <= r < 16", "r >= 16"]


def regime_table(n, p, r) -> pd.DataFrame:
    """Pixels and share per (n band, p band, r band), occupied cells only; ``in_standard_grid`` marks
    the cells inside the standard grid's range (n in [1, 1e6], p in [1e-6, 1 - 1e-6])."""
    (ni, nl), (pi, pl), (ri, rl) = n_band(n), _p_band(p), _r_band(r)
    key = (ni * 10 + pi) * 10 + ri
    uniq, counts = np.unique(key, return_counts=True)
    rows = []
    for k, c in zip(uniq, counts):
        a, b, c3 = k // 100, (k // 10) % 10, k % 10
        rows.append({"n_band": nl[a], "p_band": pl[b], "r_band": rl[c3], "pixels": int(c),
                     "share": c / n.size, "in_standard_grid": bool(1 <= a <= 6 and b in (2, 3, 4))})
    return pd.DataFrame(rows)


HIST_EDGES = (np.arange(-3.0, 7.01, 0.25), np.arange(-7.0, 0.01, 0.25), np.arange(0.0, 10.01, 0.25))


def regime_histogram(n, p, r):
    """3-D histogram of (log10 n, log10 p, log2 r) over pixels (edges HIST_EDGES; values outside are
    put in the edge bins; p = 0 pixels are left out)."""
    pos = p > 0
    x = np.stack([np.clip(fpmath.call(np.log10, n[pos]), -3, 7 - 1e-9),
                  np.clip(fpmath.call(np.log10, p[pos]), -7, -1e-12),
                  np.clip(fpmath.call(np.log2, r[pos]), 0, 10 - 1e-9)], axis=1)
    h, _ = np.histogramdd(x, bins=HIST_EDGES)
    return h


# --------------------------------------------------------------------------------------------------
# Profile

@dataclass
class SceneProfile:
    """What ``profile_scene`` returns: tables (DataFrames), per-pixel maps and the data the advisor needs."""
    name: str
    summary: dict
    tables: dict
    maps: dict                      # (H, W) arrays: n, p, r, cost maps
    valid: np.ndarray
    law_bin: np.ndarray             # bin index per valid pixel
    law_bin_errors: pd.DataFrame    # law, point (bin), tv, mean_rel_err, rel_rms
    bin_n: np.ndarray
    evaluations: dict               # scheme -> (H, W) evaluations per pixel
    loops: dict                     # (scheme, law label) -> (H, W) work units per pixel (laws with a cost model)
    costs: pd.DataFrame
    histogram: np.ndarray
    seconds: dict = field(default_factory=dict)

    def pixel_cost(self, scheme: str, law: str) -> np.ndarray:
        c = self.costs.set_index("law").loc[law]
        out = self.evaluations[scheme] * c.ns_per_eval
        if (scheme, law) in self.loops:
            out = out + self.loops[scheme, law] * c.ns_per_trial
        return np.where(self.valid, out, 0.0)

    def pixel_error(self, law: str, metric: str = "tv") -> np.ndarray:
        """Per valid pixel (flattened in row-major order of ``valid``)."""
        e = self.law_bin_errors[self.law_bin_errors.law == law].sort_values("point")[metric].to_numpy()
        return e[self.law_bin]


def _terms_tables(counter, N, n, r, phi, bins_per_octave=4, phi_bins=16):
    """Per (log2 n, log2 r, phi) bin of the pixels: the terms' distinct trial counts with their
    multiplicity (padded), and the weight bias sum(scale x trials) / (N P), at the bin's pixel mean."""
    i = np.floor(fpmath.call(np.log2, n) * bins_per_octave).astype(np.int64)  # fpmath: see _log_bins
    j = np.floor(fpmath.call(np.log2, np.maximum(r, 1.0)) * bins_per_octave).astype(np.int64)
    k = np.floor(phi / math.pi * phi_bins).astype(np.int64) % phi_bins
    key = ((i - i.min()) * 10_000 + j) * 100 + k
    uniq, inv = np.unique(key, return_inverse=True)
    cnt = np.bincount(inv)
    rep_n = fpmath.exp(np.bincount(inv, weights=fpmath.call(np.log, n)) / cnt)
    rep_r = fpmath.exp(np.bincount(inv, weights=fpmath.call(np.log, np.maximum(r, 1.0))) / cnt)
    rep_phi = np.bincount(inv, weights=phi) / cnt
    trials, mult, bias = [], [], np.empty(uniq.size)
    for b in range(uniq.size):
        P = rep_n[b] / N
        rows, _ = counter._core.terms(float(N), float(P), float(rep_r[b]), float(rep_phi[b]))
        t = np.array([x["trials"] for x in rows])
        s = np.array([x["scale"] for x in rows])
        bias[b] = float((s * t).sum() / (N * P)) if len(rows) else 0.0
        u, c = np.unique(t, return_counts=True)
        trials.append(u)
        mult.append(c)
    width = max(len(u) for u in trials)
    T = np.zeros((uniq.size, width))
    M = np.zeros((uniq.size, width))
    for b, (u, c) in enumerate(zip(trials, mult)):
        T[b, :len(u)], M[b, :len(c)] = u, c
    return inv, rep_n, T, M, bias


def work_per_pixel(lw, inv, rep_n, T, M, n, p, per_term):
    """The law's work units per pixel: the sum over the pixel's terms of ``lw.work_units(n_t, p)``
    (zk16: terms with n_t p <= 5 loop min(ceil n_t, cap) times), times the evaluations per term."""
    out = np.zeros(n.size)
    for c0 in range(0, n.size, 1 << 18):
        sl = slice(c0, c0 + (1 << 18))
        t = T[inv[sl]] * (n[sl] / rep_n[inv[sl]])[:, None]
        used = M[inv[sl]] > 0
        # Round-off in the rescaled trial counts (16 -> 16.000000000000004) must not add a trial.
        t = np.where(np.abs(t - np.round(t)) < 1e-9, np.round(t), t)
        work = lw.work_units(np.where(used, t, 0.0), np.broadcast_to(p[sl, None], t.shape))
        out[sl] = (M[inv[sl]] * np.where(used, work, 0.0)).sum(axis=1)
    return out * per_term


def profile_scene(scene, laws=None, schemes=DEFAULT_SCHEMES, seed: int = 1, scale: float = 1.0, costs=None,
                  bins_per_decade: int = 8) -> SceneProfile:
    """Profiles ``scene`` (a Scene, a path or a dict): regime map, pixel-weighted exact law errors,
    per-scheme evaluations and weight bias, and the SIMD cost of every (scheme, law) pair.

    ``costs``: None (the recorded costs, ``recorded_costs``: the same tables whatever the machine's
    load), ``"measure"`` (timed in this process, ``measure_costs``), or a table / dict of ns per
    evaluation per law label (and, for a law with a cost model, a (ns_per_eval, ns_per_trial) pair).
    ``scale`` multiplies the resolution per side. Same seed and costs, same tables."""
    t_all = time.perf_counter()
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    if scale != 1.0:
        scene = scene.scaled(scale, keep_n=True)
    seed = V.seed(seed)
    V.integer("bins_per_decade", bins_per_decade, 1, 64)
    schemes = list(schemes)
    for s in schemes:
        if s not in _scheme_labels():
            V.fail("schemes", s, f"labels among {', '.join(_scheme_labels())}")
    law_objs = _resolve_laws(laws)
    labels = list(law_objs)
    cost_table = _cost_table(costs, labels)
    seconds = {}

    t0 = time.perf_counter()
    geo = scene.geometry()
    seconds["geometry"] = time.perf_counter() - t0
    valid = geo.valid
    if not valid.any():  # nothing to profile: say so rather than fail on empty tables
        raise ValueError(f"scene {scene.name!r}: no pixel sees the {scene.kind} (all {geo.width} x "
                         f"{geo.height} pixels are sky or degenerate); expected a camera that sees the primitive")
    n, p, r, phi = geo.n[valid], geo.p[valid], geo.r[valid], geo.phi[valid]

    regimes, hist = regime_table(n, p, r), regime_histogram(n, p, r)
    t0 = time.perf_counter()
    laws_table, errs, inv, rep_n = _law_stage(law_objs, n, p, bins_per_decade)
    seconds["law_errors"] = time.perf_counter() - t0
    schemes_table, evaluations, loops = _scheme_stage(schemes, law_objs, geo, scene.density, n, p, r, phi, seed,
                                                      seconds)
    prof = SceneProfile(scene.name, {}, {}, {}, valid, inv, errs, rep_n, evaluations, loops, cost_table, hist)
    costs_table = _cost_stage(prof, schemes, labels)
    table1 = _table1_stage(prof, costs_table, scene.name, schemes, labels)
    _finish(prof, scene, geo, n, p, regimes, laws_table, schemes_table, costs_table, table1, schemes, labels,
            bins_per_decade)
    seconds["total"] = time.perf_counter() - t_all
    prof.seconds = {k: round(v, 3) for k, v in seconds.items()}
    prof.summary["profile_seconds"] = prof.seconds["total"]
    prof.tables["summary"] = pd.DataFrame([prof.summary])
    return prof


def _law_stage(law_objs, n, p, bins_per_decade):
    """Stage 1: exact law errors per (n, p) bin, pixel-weighted into one row per law. Returns (laws
    table, per-bin errors, each pixel's bin, the bins' representative n)."""
    labels = list(law_objs)
    inv, counts, rep_n, rep_p = _bin_pixels(n, p, bins_per_decade)
    errs = law_errors(law_objs, rep_n, rep_p)
    w = counts / counts.sum()
    pos = rep_p > 0
    vis = rep_n * rep_p >= 1.0  # relative noise is only meaningful where glints are expected
    law_rows = []
    for lab in labels:
        e = errs[errs.law == lab].sort_values("point")
        tv, mre, rms = e.tv.to_numpy(), e.mean_rel_err.to_numpy(), e.rel_rms.to_numpy()
        law_rows.append({"law": lab, "tv_mean": float(w @ tv), "tv_worst": float(tv.max()),
                         "tv_p99": _wquantile(tv, counts, 0.99),
                         "share_tv_gt_0.05": float(w @ (tv > 0.05)),
                         "rel_intensity_err_mean": float(w[pos] @ mre[pos] / max(w[pos].sum(), 1e-300)),
                         "rel_intensity_err_worst": float(mre.max()),
                         "rel_rms_mean_np_ge_1": float(w[vis] @ rms[vis] / max(w[vis].sum(), 1e-300)),
                         "rel_rms_worst_np_ge_1": float(rms[vis].max()) if vis.any() else 0.0})
    laws_table = pd.DataFrame(law_rows)

    return laws_table, errs, inv, rep_n


def _scheme_stage(schemes, law_objs, geo, N, n, p, r, phi, seed, seconds):
    """Stage 2: per grid scheme, evaluations per pixel (count_image) and the terms per bin (weight
    bias, each law's work per pixel). Returns (schemes table, evaluations, loops); adds each
    scheme's seconds to ``seconds``."""
    valid = geo.valid
    H, W = geo.hit.shape
    p_img = np.where(valid, geo.p, 0.0)
    J = np.where(valid[..., None], geo.J, 0.0)
    evaluations, loops, scheme_rows, kmaps = {}, {}, [], {}
    for label in schemes:
        t0 = time.perf_counter()
        counter = configured_counter(label, native_law(label), N)
        res = counter.count_image(geo.uv, J, N, p_img, seed=seed)
        ev = np.where(valid, res.evaluations, 0).astype(np.float64)
        evaluations[label] = ev
        tinv, trep, T, M, bias = _terms_tables(counter, N, n, r, phi)
        for lab, lw in law_objs.items():
            if has_cost_model(lw):
                lp = np.zeros((H, W))
                lp[valid] = work_per_pixel(lw, tinv, trep, T, M, n, p, counter.evaluations_per_term)
                loops[label, lab] = lp
        bias_px = bias[tinv]
        k_ratio = float(res.K[valid].sum() / max((n * p).sum(), 1e-300))
        seconds[f"scheme {label}"] = time.perf_counter() - t0
        hist_ev = np.bincount(ev[valid].astype(np.int64))
        scheme_rows.append({"scheme": label, "inner_law": native_law(label),
                            "evaluations_mean": float(ev[valid].mean()), "evaluations_max": int(ev[valid].max()),
                            "evaluations_mode": int(np.argmax(hist_ev)),
                            "weight_bias_mean_abs": float(np.mean(np.abs(bias_px - 1))),
                            "weight_bias_max": float(bias_px.max()), "weight_bias_min": float(bias_px.min()),
                            "share_weight_bias_off_1pct": float(np.mean(np.abs(bias_px - 1) > 0.01)),
                            "image_K_over_np": k_ratio, "clamped_footprints": int((res.status[valid] == 3).sum()),
                            "seconds": round(seconds[f"scheme {label}"], 3)})
        kmaps[label] = res.K
    return pd.DataFrame(scheme_rows), evaluations, loops


def _cost_stage(prof, schemes, labels):
    """Stage 3: the SIMD cost statistics of every (scheme, law) pair."""
    cost_rows = []
    for label in schemes:
        for lab in labels:
            st = simd_stats(prof.pixel_cost(label, lab), prof.valid)
            cost_rows.append({"scheme": label, "law": lab, **st})
    return pd.DataFrame(cost_rows)


def _table1_stage(prof, costs_table, scene_name, schemes, labels):
    """Stage 4: DB23 Table 1's methods on this scene, with the ZK16 / method cost ratios."""
    valid = prof.valid
    t1_rows = []
    for method, sch, lab in TABLE1_METHODS:
        if sch in schemes and lab in labels:
            row = costs_table[(costs_table.scheme == sch) & (costs_table.law == lab)].iloc[0]
            t1_rows.append({"scene": scene_name, "method": method, "scheme": sch, "law": lab,
                            **{k: row[k] for k in ("mean_pixel", "mean_group", "p95_group", "worst_group",
                                                   "simd_efficiency")},
                            "cost_pixel_std": float(prof.pixel_cost(sch, lab)[valid].std())})
    table1 = pd.DataFrame(t1_rows)
    if len(table1):
        zk = table1[table1.method == "ZK16"]
        for col in ("worst_group", "mean_group"):
            table1[f"zk16_over_this_{col}"] = float(zk[col].iloc[0]) / table1[col] if len(zk) else np.nan
        ms = TABLE1_MS.get(scene_name)
        if ms:
            table1["paper_ms"] = [f"{ms[1][0]}-{ms[1][1]}" if m == "ZK16" else f"{ms[0][0]}-{ms[0][1]}"
                                  for m in table1.method]

    return table1


def _finish(prof, scene, geo, n, p, regimes, laws_table, schemes_table, costs_table, table1, schemes, labels,
            bins_per_decade):
    """Stage 5: the summary, the profile's tables and its maps."""
    valid, cost_table, rep_n = prof.valid, prof.costs, prof.bin_n
    H, W = geo.hit.shape
    summary = {"scene": scene.name, "primitive": scene.kind, "width": W, "height": H, **geo.summary(),
               "clamp_intensity_loss_mean": float(np.mean(1 - np.where(geo.p_raw[valid] > 0, p / np.where(
                   geo.p_raw[valid] > 0, geo.p_raw[valid], 1), 1))),
               "dark_share": float(np.mean(n * p < DARK_NP)), "n_p_bins": int(len(rep_n)), "bins_per_decade": bins_per_decade,
               "share_in_standard_grid": float(regimes.loc[regimes.in_standard_grid, "share"].sum())}
    cost_units = cost_table.assign(scene=scene.name)
    prof.summary = summary
    prof.tables = {"summary": pd.DataFrame([summary]), "regimes": regimes.assign(scene=scene.name),
                   "laws": laws_table.assign(scene=scene.name), "schemes": schemes_table.assign(scene=scene.name),
                   "costs": costs_table.assign(scene=scene.name), "table1": table1, "cost_units": cost_units}
    maps = {"n": np.where(valid, geo.n, np.nan), "p": np.where(valid, geo.p, np.nan),
            "r": np.where(valid, geo.r, np.nan)}
    for method, sch, lab in TABLE1_METHODS:
        if sch in schemes and lab in labels:
            maps[f"group cost {method}"] = group_max(prof.pixel_cost(sch, lab), valid)[0]
    prof.maps = maps


def _wquantile(x, w, q):
    o = np.argsort(x)
    c = np.cumsum(w[o]) / np.sum(w)
    return float(x[o][min(np.searchsorted(c, q), len(x) - 1)])


def _scheme_labels():
    return list(IMAGE_CONFIGS)


def binning_check(scene, laws=None, bins_per_decade: int = 8) -> pd.DataFrame:
    """Pixel-weighted mean and worst TV at ``bins_per_decade`` and twice as fine: how much the
    binning of (n, p) changes the answer (geometry only; no grid scheme is run)."""
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    geo = scene.geometry()
    v = geo.valid
    law_objs = _resolve_laws(laws)
    rows = []
    for bpd in (bins_per_decade, 2 * bins_per_decade):
        inv, counts, rep_n, rep_p = _bin_pixels(geo.n[v], geo.p[v], bpd)
        errs = law_errors(law_objs, rep_n, rep_p)
        for lab in law_objs:
            e = errs[errs.law == lab].sort_values("point")
            rows.append({"scene": scene.name, "law": lab, "bins_per_decade": bpd, "bins": len(rep_n),
                         "tv_mean": float(counts @ e.tv.to_numpy() / counts.sum()), "tv_worst": float(e.tv.max())})
    return pd.DataFrame(rows)
