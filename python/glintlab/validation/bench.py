"""Speed against accuracy, per law, in one run (``glintlab bench`` and the report's trade section).

Accuracy: the law's error against the exact binomial over the standard grid, exact when the law
has an exact pmf (``sweep`` with samples=None), otherwise sampled on a coarser grid with its Monte
Carlo noise floor (``tv_noise``) reported beside it. Speed: ns/sample of ``law.sample`` from Python
on glintlab's threads (both cores), best of ``repeats`` calls of ``samples`` draws at each timing
point, against numpy's binomial (``Generator(PCG64).binomial``, one thread: numpy has no other) at
the same points, timed in the same run.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pandas as pd

from ..api import checks as v
from .grid import _label, standard_grid
from .sweep import resolve_law, sweep

TIMING_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6)]
DEFAULT_LAWS = [("binomial", {}), ("gaussian", {"rounding": "floor"}), ("gaussian", {"rounding": "round"}),
                ("zk16", {}), ("gated", {}), ("gated_shader", {}), ("gated_continuous", {}), ("dual_gated", {}),
                ("threshold", {}), ("head_cf", {})]


def best_time(fn, repeats: int) -> float:
    """Seconds of the fastest of `repeats` calls of fn, after one warm-up call."""
    fn()  # warm-up: page in code and tables
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def speed_accuracy(laws=None, samples: int = 10**6, seed: int = 1, repeats: int = 2, timing_points=TIMING_POINTS,
                   sampled_grid: int = 8, sampled_draws: int = 20000, progress=None):
    """(summary, errors): one summary row per law (law, accuracy, tv_max, tv_median, hellinger_max,
    w1_max, mean_rel_err_max, var_rel_err_median, tv_noise, ns_per_sample, ns_ratio_1e9_vs_16,
    numpy_ns, speedup_vs_numpy) and the per-point error table behind it.

    Laws without an exact pmf are measured on ``sampled_grid`` x ``sampled_grid`` points of the
    standard grid with ``sampled_draws`` draws each (accuracy "sampled"; tv_noise is the largest
    TV pure sampling noise would give there on average).
    """
    seed = v.seed(seed)
    for name, value in (("samples", samples), ("repeats", repeats)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            v.fail(name, value, "an integer >= 1")
    if laws is None:
        laws = [resolve_law({"name": name, "params": params}) for name, params in DEFAULT_LAWS]
    else:
        laws = [resolve_law(x) for x in laws]
    exact = [lw for lw in laws if lw.has_pmf]
    other = [lw for lw in laws if not lw.has_pmf]
    metrics = ["tv", "hellinger", "w1", "mean_rel_err", "var_rel_err"]
    tables = []
    if exact:
        tables.append(sweep(exact, metrics=metrics, progress=progress).assign(accuracy="exact"))
    if other:
        gn, gp = standard_grid()
        pick = lambda a: a[np.linspace(0, a.size - 1, sampled_grid).astype(int)]
        tables.append(sweep(other, n=pick(gn), p=pick(gp), metrics=metrics, samples=sampled_draws, seed=seed,
                            progress=progress).assign(accuracy="sampled"))
    errors = pd.concat(tables, ignore_index=True)
    agg = dict(tv_max=("tv", "max"), tv_median=("tv", "median"), hellinger_max=("hellinger", "max"),
               w1_max=("w1", "max"), mean_rel_err_max=("mean_rel_err", "max"),
               var_rel_err_median=("var_rel_err", "median"), accuracy=("accuracy", "first"))
    if "tv_noise" in errors:
        agg["tv_noise"] = ("tv_noise", "max")
    summary = errors.groupby("law", sort=False).agg(**agg).reset_index()
    rng = np.random.default_rng(seed)
    numpy_ns = [best_time(lambda: rng.binomial(int(n), p, size=samples), repeats) / samples * 1e9
                for n, p in timing_points]
    speed = {}
    for lw in laws:
        times = [best_time(lambda: lw.sample(n, p, size=samples, seed=seed), repeats) / samples * 1e9
                 for n, p in timing_points]
        speed[_label(lw)] = (float(np.mean(times)), times[-1] / times[0],
                             float(np.mean(np.array(numpy_ns) / np.array(times))))
    summary["ns_per_sample"] = summary.law.map(lambda k: speed[k][0])
    summary["ns_ratio_1e9_vs_16"] = summary.law.map(lambda k: speed[k][1])
    summary["numpy_ns"] = float(np.mean(numpy_ns))
    summary["speedup_vs_numpy"] = summary.law.map(lambda k: speed[k][2])
    summary["pareto"] = pareto_front(summary.ns_per_sample.to_numpy(), summary.tv_max.to_numpy())
    return summary, errors


def pareto_front(cost, error) -> np.ndarray:
    """Whether each (cost, error) point is on the Pareto front (no other point is at least as good in
    both and better in one)."""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    out = np.ones(cost.size, dtype=bool)
    for i in range(cost.size):
        better = (cost <= cost[i]) & (error <= error[i]) & ((cost < cost[i]) | (error < error[i]))
        out[i] = not better.any()
    return out


def pareto_figure(summary: pd.DataFrame, floor: float = 1e-6):
    """Worst (red) and median (blue) TV against ns/sample, the Pareto front joined by a line."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4))
    for i, (_, row) in enumerate(summary.sort_values("ns_per_sample").iterrows()):
        marker = "o" if row.accuracy == "exact" else "^"
        ax.plot(row.ns_per_sample, max(row.tv_max, floor), marker, color="#b2182b")
        ax.plot(row.ns_per_sample, max(row.tv_median, floor), "s", color="#2166ac", alpha=0.7)
        label = row.law + (" (exact)" if row.tv_max < floor else "") + (" (sampled)" if row.accuracy != "exact" else "")
        # Laws of similar cost and error sit on each other: stagger their labels.
        ax.annotate(label, (row.ns_per_sample, max(row.tv_max, floor)), fontsize=7, xytext=(4, 2 - 9 * (i % 3)),
                    textcoords="offset points")
    front = summary[summary.pareto].sort_values("ns_per_sample")
    ax.plot(front.ns_per_sample, np.maximum(front.tv_max, floor), "-", color="#b2182b", alpha=0.4, lw=1)
    ax.set_yscale("log")
    ax.set_xscale("log")
    ax.set_ylim(floor / 2, 2)
    ax.set_xlabel("ns / sample (from Python, both cores, mean of the timing points)")
    ax.set_ylabel("TV to the binomial")
    ax.set_title("Speed / accuracy over the standard grid (red: worst, blue: median; line: Pareto front)",
                 fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def grid_maps(path, table: pd.DataFrame, names, column: str, floor: float, cmap: str, label: str, title: str):
    """One log-scaled map of `column` over the standard grid (n by p) per law, four to a row."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    cols = 4
    rows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.8 * rows), squeeze=False)
    n_values, p_values = standard_grid()
    for ax, name in zip(axes.ravel(), names):
        sub = table[table.law == name].pivot(index="p", columns="n", values=column)
        im = ax.imshow(np.clip(sub.to_numpy(), floor, 1), origin="lower", aspect="auto",
                       norm=LogNorm(floor, 1), extent=[0, len(n_values), 0, len(p_values)], cmap=cmap)
        ax.set_title(name, fontsize=8)
        ax.set_xticks([0, len(n_values) / 2, len(n_values)], ["1", "1e3", "1e6"], fontsize=7)
        ax.set_yticks([0, len(p_values) / 2, len(p_values)], ["1e-6", "0.5", "1-1e-6"], fontsize=7)
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.8, label=label)
    fig.suptitle(title, fontsize=9)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def write_bench(out, summary: pd.DataFrame, errors: pd.DataFrame) -> list:
    """bench.csv, bench_errors.csv, bench_pareto.png and, for exact laws, bench_error_maps_tv.png."""
    import matplotlib.pyplot as plt
    from pathlib import Path
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = [out / "bench.csv", out / "bench_errors.csv", out / "bench_pareto.png"]
    summary.to_csv(files[0], index=False)
    errors.to_csv(files[1], index=False)
    fig = pareto_figure(summary)
    fig.savefig(files[2], dpi=110)
    plt.close(fig)
    exact = list(summary[summary.accuracy == "exact"].law)
    if exact:
        files.append(grid_maps(out / "bench_error_maps_tv.png", errors, exact, "tv", 1e-6, "magma",
                               "TV to the binomial", "Exact TV over the standard grid: n (log, x) by p (y)"))
    return files


THRESHOLDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 1024.0)
# Above every n p of the standard grid (at most 1e6 - 1e-6... times p < 1): the explicit count everywhere.
EXPLICIT_T = 1e7


def threshold_trade(thresholds=THRESHOLDS, n=None, p=None, draws_per_point: int = 8, repeats: int = 3,
                    seed: int = 1) -> pd.DataFrame:
    """WWH18's threshold trade (their Fig. 15 idea): the filtered model ``threshold`` (K = n p when
    n p > T, an explicit count below) as T varies, over the (n, p) points of a grid (default: standard).

    Error, exact per point against the binomial: TV, and ``rel_intensity_err`` = W1 / (n p), the mean
    absolute error of a pixel's D_P relative to D(h) when the filtered value replaces the count (W1 is
    the optimal coupling, so no renderer can do better with that law). Summaries over the points:
    median, 90th percentile and maximum. WWH18 measure PSNR of a whole rendering against the
    unfiltered one; this is the per-pixel version over a stated population of pixels.

    Cost, measured in this run: ns per draw of ``law.sample`` on the whole population (each point
    ``draws_per_point`` times, both cores, best of ``repeats``), and ``cost_ratio`` to the explicit
    count everywhere (T = EXPLICIT_T): the explicit count is an inversion whose loop grows with n p,
    which is why a threshold pays.
    """
    from ..api.laws import law as get_law
    from .grid import error_table
    seed = v.seed(seed)
    if n is None or p is None:
        gn, gp = standard_grid()
        n = gn if n is None else np.atleast_1d(np.asarray(n, float))
        p = gp[gp <= 0.5] if p is None else np.atleast_1d(np.asarray(p, float))
    for T in thresholds:
        if not (isinstance(T, (int, float)) and math.isfinite(T) and T > 0):
            v.fail("thresholds", T, "finite numbers > 0")
    laws = [get_law("threshold", T=float(T)) for T in thresholds] + [get_law("threshold", T=EXPLICIT_T)]
    errors = error_table(laws, n=n, p=p, metrics=("tv", "w1"))
    errors["rel_intensity_err"] = errors.w1 / (errors.n * errors.p)
    errors["filtered"] = errors.n * errors.p > errors.law.map({_label(lw): lw.params["T"] for lw in laws})
    nn, pp = np.meshgrid(np.asarray(n, float), np.asarray(p, float), indexing="ij")
    pop_n, pop_p = np.repeat(nn.ravel(), draws_per_point), np.repeat(pp.ravel(), draws_per_point)
    rows = []
    for lw in laws:
        g = errors[errors.law == _label(lw)]
        seconds = best_time(lambda: lw.sample(pop_n, pop_p, seed=seed), repeats)
        ri = g.rel_intensity_err
        rows.append({"T": lw.params["T"], "law": _label(lw), "points": len(g), "filtered_share": g.filtered.mean(),
                     "tv_median": g.tv.median(), "tv_p90": g.tv.quantile(0.9), "tv_max": g.tv.max(),
                     "rel_intensity_err_median": ri.median(), "rel_intensity_err_p90": ri.quantile(0.9),
                     "rel_intensity_err_max": ri.max(), "ns_per_draw": seconds / pop_n.size * 1e9})
    table = pd.DataFrame(rows)
    table["cost_ratio"] = table.ns_per_draw / table.ns_per_draw.iloc[-1]
    table["explicit"] = table["T"] == EXPLICIT_T
    return table


def threshold_figure(table: pd.DataFrame, paper_T: float = 16.0):
    """Error (left axis) and cost relative to the explicit count (right axis) against the threshold T."""
    import matplotlib.pyplot as plt

    t = table[~table.explicit]
    fig, ax = plt.subplots(figsize=(6.8, 3.9))
    ax.loglog(t["T"], t.rel_intensity_err_max, "o-", color="#b2182b", label="W1 / (n p): worst point")
    ax.loglog(t["T"], t.rel_intensity_err_p90, "s--", color="#b2182b", alpha=0.6, label="W1 / (n p): 90th percentile")
    # Just above T the lost spread is E|K - n p| / (n p) ~ sqrt(2 (1 - p) / (pi n p)) <= sqrt(2 / (pi T)).
    ax.loglog(t["T"], np.sqrt(2 / (math.pi * t["T"])), ":", color="k", lw=1, label="sqrt(2 / (pi T))")
    ax.set_xlabel("threshold T (filter when n p > T)")
    ax.set_ylabel("error against the explicit count", color="#b2182b")
    ax.axvline(paper_T, color="grey", lw=0.8, ls=":")
    ax.annotate(f"WWH18: T = {paper_T:g}", (paper_T, ax.get_ylim()[0]), fontsize=7, xytext=(3, 4),
                textcoords="offset points")
    ax.grid(True, which="both", alpha=0.3)
    ax2 = ax.twinx()
    ax2.loglog(t["T"], t.ns_per_draw, "D-", color="#2166ac", label="cost: ns / draw over the population")
    ax2.axhline(table.ns_per_draw.iloc[-1], color="#2166ac", lw=0.8, ls="--")
    ax2.annotate(f"explicit count everywhere: {table.ns_per_draw.iloc[-1]:.3g} ns", (t["T"].iloc[0],
                 table.ns_per_draw.iloc[-1]), fontsize=7, color="#2166ac", xytext=(2, -10), textcoords="offset points")
    ax2.set_ylabel("ns / draw (both cores)", color="#2166ac")
    lines = ax.get_legend_handles_labels()[0] + ax2.get_legend_handles_labels()[0]
    labels = ax.get_legend_handles_labels()[1] + ax2.get_legend_handles_labels()[1]
    ax.legend(lines, labels, fontsize=7, loc="lower left")
    ax.set_title(f"WWH18 Fig. 15 idea: the filtered model's threshold over the standard grid, p <= 1/2 "
                 f"({t.points.iloc[0]} (n, p) points)", fontsize=8)
    fig.tight_layout()
    return fig
