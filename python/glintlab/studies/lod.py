"""LOD studies: DB23 Figure 4 (blending against the spatial ground truth) and coherence along camera
paths (zoom, pan) and across a receding plane: the numbers behind the studies db23_figure4,
ghosting_strip, roulette_vs_linear and lod_coherence (which draw them). Tables are pandas DataFrames.

The ground truth is always the stratified layout (DB23's: one jittered facet per cell of an M x M
grid, N = M^2) counted by ``gl.ground_truth`` / ``gl.joint_counts``.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.optimize
import pandas as pd

from ..api.blends import blended_law
from ..api.laws import law as get_law
from ..api.metrics import chi2_test, distance
from ..api.spatial import Rect, ground_truth, joint_counts
from ..api import checks as V

# DB23 Fig. 4 settings: (M, cells per level-lo texel, p). Levels of c and 4c cells (ratio 4); the
# footprint, a rectangle of whole cells, sits at area weight w_area = 1/4, 1/2, 3/4 between them,
# where eq. 10's trial counts are integers, so the exact claim is testable.
FIGURE4_CASES = [(64, 16, 0.1), (64, 16, 0.5), (1024, 1024, 0.01), (1024, 1024, 0.1)]
FIGURE4_WEIGHTS = (0.25, 0.5, 0.75)

# The blends of the coherence studies: (label, blend, params).
COHERENCE_BLENDS = [("nearest", "nearest", {}), ("zk16_linear", "zk16_linear", {}),
                    ("distributed", "distributed", {}), ("roulette", "roulette", {"epsilon": 0.0}),
                    ("roulette_eps0.1", "roulette", {"epsilon": 0.1})]


def _rect_of_cells(cells: int, side: int):
    """Width x height (in cells) of a near-square rectangle of `cells` whole cells, height <= side."""
    best = None
    for h in range(1, side + 1):
        if cells % h == 0 and cells // h <= side:
            w = cells // h
            if best is None or abs(w - h) < abs(best[0] - best[1]):
                best = (w, h)
    return best


def figure4_cases(cases=FIGURE4_CASES, weights=FIGURE4_WEIGHTS):
    """The footprints of the Figure 4 study: one dict per (case, weight)."""
    out = []
    for M, c_lo, p in cases:
        for wa in weights:
            cells = round(c_lo + wa * 3 * c_lo)  # P = A_lo + w_area (A_hi - A_lo)
            w, h = _rect_of_cells(cells, M)
            out.append(dict(M=M, N=M * M, cells_lo=c_lo, p=p, w_area=wa, cells=cells, rect=(w, h)))
    return out


def figure4_table(samples: int = 200_000, seed: int = 1, cases=FIGURE4_CASES, weights=FIGURE4_WEIGHTS,
                  inners=("binomial",)):
    """DB23 Fig. 4 quantified: per footprint, the ground truth (exact law of a rectangle of whole
    stratified cells, and its Monte Carlo realizations) against ZK16 linear blending and the
    distributed binomial (each with every inner law of `inners`).

    Returns (table, panels): one row per footprint and source with the chi-square p-value of
    `samples` draws against the exact ground truth, the exact TV to it (when the source has an
    exact law), the variance ratio Var[K] / Var_truth from the samples (unbinned) with its standard
    error, and ZK16's analytic ratio; `panels` holds the exact laws and samples for plotting.
    """
    rows, panels = [], []
    for i, case in enumerate(figure4_cases(cases, weights)):
        M, N, p = case["M"], case["N"], case["p"]
        h = 1.0 / M
        w, hh = case["rect"]
        P = case["cells"] / N
        a_lo = case["cells_lo"] / N
        gt = ground_truth("stratified", density=N, footprint=Rect(w * h, hh * h), p=p,
                          center=(0.25 + w * h / 2, 0.25 + hh * h / 2))
        truth = gt.pmf()
        # The same footprint area as a square at a uniformly random position (not a union of cells).
        square = ground_truth("stratified", density=N, footprint=Rect(math.sqrt(P), math.sqrt(P)), p=p).pmf()
        base = dict(M=M, N=N, p=p, P=P, n=N * P, w_area=case["w_area"], footprint=f"{w}x{hh} cells")
        panel = dict(base, truth=truth, square=square, sources={})
        sources = [("ground truth (realizations)", None)]
        for inner in inners:
            suffix = "" if inner == "binomial" else f"[{inner}]"
            sources += [(f"zk16_linear{suffix}", blended_law("zk16_linear", inner=inner, base_area=a_lo)),
                        (f"distributed{suffix}", blended_law("distributed", inner=inner, base_area=a_lo))]
        for j, (label, bl) in enumerate(sources):
            s = seed + 1000 * i + j
            if bl is None:
                x, binned, exact = gt.sample(samples, seed=s), None, truth
            else:
                x = bl.sample(N, P, p, size=samples, seed=s)
                exact = bl.pmf(N, P, p) if bl.has_pmf else None
            binned = np.floor(x + 0.5) if bl is not None and bl.binning == "round" else x
            var = float(np.var(x, ddof=1))
            # The variance each blend rule declares for an exact binomial inner law (NaN without a closed form).
            analytic = (float(bl.variance_ratio(P)) * N * P * p * (1 - p) / truth.var if bl is not None
                        else float("nan"))
            rows.append(dict(base, source=label,
                             pvalue=chi2_test(binned, truth).pvalue,
                             pvalue_vs_square=chi2_test(binned, square).pvalue,
                             tv=distance(exact, truth, "tv") if exact is not None else float("nan"),
                             tv_vs_square=distance(exact, square, "tv") if exact is not None else float("nan"),
                             var_ratio=var / truth.var,
                             var_ratio_se=var / truth.var * math.sqrt(2.0 / (samples - 1)),
                             var_ratio_analytic=analytic,
                             mean_ratio=float(np.mean(x)) / truth.mean, samples=samples, seed=s))
            panel["sources"][label] = dict(exact=exact, samples=binned)
        panels.append(panel)
    return pd.DataFrame(rows), panels


def non_integer_trials_table(cases=((4096, 16, 0.1), (4096, 16, 0.5), (4096, 16, 0.9), (1024**2, 1024, 0.1)),
                             per_cell: int = 8, max_points: int = 400, refine: int = 3):
    """The effect of the non-integer trial-count rule: the distributed binomial (each level's
    Binomial(floor n, p) + Bernoulli(frac(n) p)) against Binomial(N P, p) (the same rule for N P),
    worst TV and worst variance excess (bound p^2 / 2) over the whole range of areas between the
    levels (c_lo to 4 c_lo cells).

    The TV is piecewise smooth in the area, with kinks where a level's trial count crosses an
    integer, so a scan at a few points per cell can miss its peaks: the range is scanned at
    ``per_cell`` points per cell (coarser when that exceeds ``max_points``; the step is in the table)
    and the ``refine`` largest local maxima are then maximized by a bounded scalar search within one
    scan step. ``worst_cells`` is where the worst TV was found."""
    rows = []
    binomial = get_law("binomial")
    for N, c_lo, p in cases:
        a_lo = c_lo / N
        bl = blended_law("distributed", inner="binomial", base_area=a_lo)

        def at(cells):
            d, ref = bl.pmf(N, cells / N, p), binomial.pmf(cells, p)
            return distance(d, ref, "tv"), d.var - ref.var

        span = 3.0 * c_lo
        step = max(1.0 / per_cell, span / max_points)
        grid = c_lo + step * np.arange(1, int(round(span / step)))
        scanned = np.array([at(c) for c in grid])
        tvs, excess = scanned[:, 0], scanned[:, 1]
        peaks = [i for i in range(len(tvs)) if (i == 0 or tvs[i] >= tvs[i - 1]) and
                 (i == len(tvs) - 1 or tvs[i] >= tvs[i + 1])]
        worst_tv, worst_cells = float(tvs.max()), float(grid[int(tvs.argmax())])
        for i in sorted(peaks, key=lambda i: -tvs[i])[:refine]:
            lo, hi = max(c_lo + 1e-9, grid[i] - step), min(4.0 * c_lo - 1e-9, grid[i] + step)
            res = scipy.optimize.minimize_scalar(lambda c: -at(c)[0], bounds=(lo, hi), method="bounded",
                                                 options={"xatol": 1e-4})
            if -res.fun > worst_tv:
                worst_tv, worst_cells = float(-res.fun), float(res.x)
        rows.append(dict(N=N, cells_lo=c_lo, p=p, max_tv=worst_tv, worst_cells=worst_cells,
                         mean_tv=float(np.mean(tvs)), max_var_excess=float(excess.max()), bound=p * p / 2,
                         scan_step=step, scanned=len(grid)))
    return pd.DataFrame(rows)


def coherence_metrics(K, lag: int = 1) -> dict:
    """Coherence of counts along paths: K has shape (paths, steps).

    mean_abs_step: mean |K[s+1] - K[s]|; pop_rate: share of steps with |dK| >= 2; lag_corr: the
    correlation of K[s] and K[s+lag] after removing each step's mean over paths (so a trend in the
    mean does not count as coherence), pooled over s; nan when K does not vary.
    """
    K = np.asarray(K, dtype=np.float64)
    if K.ndim != 2 or K.shape[1] < 2:
        raise ValueError(f"K has shape {K.shape}; expected (paths, steps) with steps >= 2")
    V.integer("lag", lag, 1, K.shape[1] - 1)
    d = np.abs(np.diff(K, axis=1))
    c = K - K.mean(axis=0, keepdims=True)
    a, b = c[:, :-lag], c[:, lag:]
    denom = math.sqrt(float(np.sum(a * a)) * float(np.sum(b * b)))
    return dict(mean_abs_step=float(d.mean()), pop_rate=float(np.mean(d >= 2)),
                lag_corr=float(np.sum(a * b)) / denom if denom > 0 else float("nan"))


def _paths_table(kind, K_by_source, steps, extra):
    rows = []
    for (label, inner), K in K_by_source.items():
        m1 = coherence_metrics(K, 1)
        mq = coherence_metrics(K, max(1, steps // 4))
        rows.append(dict(path=kind, law=label, inner=inner, mean_abs_step=m1["mean_abs_step"],
                         pop_rate=m1["pop_rate"], corr_lag1=m1["lag_corr"],
                         **{f"corr_lag{max(1, steps // 4)}": mq["lag_corr"]},
                         corr_ends=coherence_metrics(K[:, [0, -1]], 1)["lag_corr"],
                         mean_K=float(K.mean()), **extra))
    return pd.DataFrame(rows)


def zoom_study(N: float = 1e6, p: float = 0.1, cells_lo: int = 64, steps: int = 64, paths: int = 1000,
               seed: int = 1, inners=("binomial", "gated"), blends=COHERENCE_BLENDS):
    """Coherence along a zoom from A_lo = cells_lo / N to A_hi = 4 A_lo (steps + 1 footprints, each
    step multiplies the area by 4^(1/steps)), at `paths` random positions, fixed seeds.

    Each law is evaluated at the path's position with ``sample_at`` (the cells a renderer would
    read); the ground truth counts nested squares on one stratified facet realization per path.
    Returns (table, K) with K[(law, inner)] of shape (paths, steps + 1).
    """
    a_lo = cells_lo / N
    areas = a_lo * 4.0 ** (np.arange(steps + 1) / steps)
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0.1, 0.9, size=(paths, 2))
    K = {("ground truth", "-"): np.stack([
        joint_counts("stratified", N, p, [Rect(math.sqrt(a), math.sqrt(a)) for a in areas], [tuple(c)] * len(areas),
                     size=1, seed=seed + r)[0] for r, c in enumerate(xy)])}
    for inner in inners:
        for label, name, params in blends:
            bl = blended_law(name, inner=inner, base_area=a_lo, **params)
            K[(label, inner)] = bl.sample_at(N, areas[None, :], p, xy[:, :1], xy[:, 1:], seed=seed)
    return _paths_table("zoom", K, steps, dict(N=N, p=p, n_lo=N * a_lo, n_hi=4 * N * a_lo)), K


def pan_study(N: float = 1e6, p: float = 0.1, cells_lo: int = 64, w_lod: float = 0.5, steps: int = 64,
              step_fraction: float = 1 / 16, paths: int = 1000, seed: int = 1, inners=("binomial", "gated"),
              blends=COHERENCE_BLENDS):
    """Coherence along a pan: a square footprint of area A_lo 4^w_lod moved along x by
    `step_fraction` of its side per step. The ground truth counts the shifted squares on one
    stratified realization per path; each law reads its cells at the moving centre."""
    a_lo = cells_lo / N
    P = a_lo * 4.0 ** w_lod
    side = math.sqrt(P)
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0.1, 0.5, size=(paths, 2))
    shifts = np.arange(steps + 1) * step_fraction * side
    K = {("ground truth", "-"): np.stack([
        joint_counts("stratified", N, p, [Rect(side, side)] * len(shifts), [(x + d, y) for d in shifts],
                     size=1, seed=seed + r)[0] for r, (x, y) in enumerate(xy)])}
    for inner in inners:
        for label, name, params in blends:
            bl = blended_law(name, inner=inner, base_area=a_lo, **params)
            K[(label, inner)] = bl.sample_at(N, P, p, xy[:, :1] + shifts[None, :], xy[:, 1:], seed=seed)
    return _paths_table("pan", K, steps, dict(N=N, p=p, n_lo=N * a_lo, n_hi=4 * N * a_lo)), K


def strip_images(N: float = 1e8, p: float = 0.01, level: int = -10, width: int = 256, height: int = 64,
                 seed: int = 1, inner: str = "binomial", blends=COHERENCE_BLENDS):
    """A plane receding across one LOD transition (DB23 Fig. 2, KPT25 Fig. 6 ideas): column j's
    square pixel footprints have area A_lo 4^e_j, e_j from -0.25 to 1.25 (pure level lo, the blend
    zone, pure level hi); pixels tile the texture. Intensity = K / (N P p) (D_P / D: 1 on average).

    Returns (images, exponents): images[label] of shape (height, width), ground truth included
    (one stratified realization counted in every pixel by ``joint_counts``).
    """
    a_lo = 4.0 ** level
    e = np.linspace(-0.25, 1.25, width)
    P = a_lo * 4.0 ** e
    side = np.sqrt(P)
    u0 = 0.05 + np.concatenate([[0.0], np.cumsum(side)[:-1]])  # column j spans [u0_j, u0_j + side_j)
    if u0[-1] + side[-1] > 0.95 or height * side.max() > 0.9:
        raise ValueError(f"the strip ({width} x {height} pixels at level {level}) does not fit in the unit domain; "
                         "lower width/height or the level")
    rows = np.arange(height)
    cx = (u0 + side / 2)[None, :].repeat(height, 0)
    cy = 0.05 + (rows[:, None] + 0.5) * side[None, :]
    areas = np.broadcast_to(P[None, :], (height, width))
    fps = [Rect(s, s) for s in np.broadcast_to(side[None, :], (height, width)).ravel()]
    k_gt = joint_counts("stratified", N, p, fps, list(zip(cx.ravel(), cy.ravel())), size=1, seed=seed)[0]
    images = {"ground truth": k_gt.reshape(height, width) / (N * areas * p)}
    for label, name, params in blends:
        bl = blended_law(name, inner=inner, level_ratio=4, base_area=1.0, **params)
        images[label] = bl.sample_at(N, areas, p, cx, cy, seed=seed) / (N * areas * p)
    return images, e


# KPT25 Fig. 6: Russian roulette against linear blending of two MIP levels (and DB23's distributed law).
APPEARANCE_BLENDS = [("linear (zk16_linear)", "zk16_linear", {}), ("roulette (eps 0.1)", "roulette", {"epsilon": 0.1}),
                     ("distributed", "distributed", {})]


def blend_appearance(facets_lo: float = 4.0, p: float = 0.05, weights=None, samples: int = 50_000, seed: int = 1,
                     inner: str = "binomial", blends=APPEARANCE_BLENDS) -> pd.DataFrame:
    """How a glint field looks between two levels (KPT25 Fig. 6 idea), pixel statistics against the LOD
    weight w: footprint P = A_lo 4^w with N A_lo = ``facets_lo`` facets in a level-lo cell, so n = N P
    goes from ``facets_lo`` to 4 ``facets_lo``. Per blend (``samples`` independent pixels) and for the
    truth (the exact stratified Binomial(N P, p)): lit_share P(K > 0), lit_intensity E[I | K > 0] with
    I = K / (N P p) (D_P / D(h)), and mean_intensity E[I]. Linear blending at w = 1/2 lights about
    twice the truth's pixels at about half the intensity: the "twice the glints at half intensity" that
    DB23 Fig. 2 and KPT25 Fig. 6 show. Sampled columns carry standard errors (``*_se``)."""
    weights = np.linspace(0.0, 1.0, 21) if weights is None else np.asarray(weights, float)
    N = facets_lo / 4.0**-8  # level -8 as the low level: the blend's levels are powers of 4 of base_area 1
    rows = []
    b = get_law("binomial")
    for w in weights:
        P = 4.0**-8 * 4.0**w
        n = N * P
        d = b.pmf(n, p)
        p0 = float(d.probs[0]) if d.support[0] == 0 else 0.0
        rows.append({"blend": "truth (stratified binomial)", "w": w, "n": n, "lit_share": 1 - p0,
                     "lit_intensity": (d.mean / (1 - p0)) / (n * p), "mean_intensity": d.mean / (n * p),
                     "lit_share_se": 0.0, "lit_intensity_se": 0.0, "mean_intensity_se": 0.0})
    for i, (label, name, params) in enumerate(blends):
        bl = blended_law(name, inner=inner, level_ratio=4, base_area=1.0, **params)
        for j, w in enumerate(weights):
            P = 4.0**-8 * 4.0**w
            n = N * P
            K = bl.sample(N, P, p, size=samples, seed=(seed * 1_000_003 + 977 * i + j) % 2**64)
            I = K / (n * p)
            lit = K > 0
            m = int(lit.sum())
            lit_I = I[lit]
            rows.append({"blend": label, "w": w, "n": n, "lit_share": m / samples,
                         "lit_intensity": float(lit_I.mean()) if m else math.nan,
                         "mean_intensity": float(I.mean()),
                         "lit_share_se": math.sqrt(m / samples * (1 - m / samples) / samples),
                         "lit_intensity_se": float(lit_I.std(ddof=1) / math.sqrt(m)) if m > 1 else math.nan,
                         "mean_intensity_se": float(I.std(ddof=1) / math.sqrt(samples))})
    t = pd.DataFrame(rows)
    truth = t[t.blend.str.startswith("truth")].set_index("w")
    t["lit_share_vs_truth"] = t.lit_share / t.w.map(truth.lit_share)
    t["lit_intensity_vs_truth"] = t.lit_intensity / t.w.map(truth.lit_intensity)
    return t


def blend_insets(facets_lo: float = 4.0, p: float = 0.05, weights=(0.1, 0.5), size: int = 64, seed: int = 1,
                 inner: str = "binomial", blends=APPEARANCE_BLENDS):
    """Image insets for ``blend_appearance``'s setup: a ``size`` x ``size`` block of square pixels of area
    P = A_lo 4^w tiling the texture, intensity I = K / (N P p), for the truth (one stratified
    realization counted in every pixel) and each blend. Returns {w: {label: image}}."""
    N = facets_lo / 4.0**-8
    out = {}
    for w in weights:
        P = 4.0**-8 * 4.0**w
        side = math.sqrt(P)
        if 0.05 + size * side > 0.95:
            raise ValueError(f"size = {size} pixels of side {side:.3g} do not fit in the unit domain; expected fewer")
        c = 0.05 + (np.arange(size) + 0.5) * side
        cx, cy = np.meshgrid(c, c)
        fps = [Rect(side, side)] * (size * size)
        k = joint_counts("stratified", N, p, fps, list(zip(cx.ravel(), cy.ravel())), size=1, seed=seed)[0]
        images = {"truth (stratified facets)": k.reshape(size, size) / (N * P * p)}
        for label, name, params in blends:
            bl = blended_law(name, inner=inner, level_ratio=4, base_area=1.0, **params)
            images[label] = bl.sample_at(N, P, p, cx, cy, seed=seed) / (N * P * p)
        out[float(w)] = images
    return out
