"""Speed against accuracy, per law, in one run (``glintlab bench`` and the report's trade section).

Accuracy: the law's error against the exact binomial over the standard grid, exact when the law
has an exact pmf (``sweep`` with samples=None), otherwise sampled on a coarser grid with its Monte
Carlo noise floor (``tv_noise``) reported beside it. Speed: ns/sample of ``law.sample`` from Python
on glintlab's threads (both cores), best of ``repeats`` calls of ``samples`` draws at each timing
point, against numpy's binomial (``Generator(PCG64).binomial``, one thread: numpy has no other) at
the same points, timed in the same run.
"""
from __future__ import annotations

import time

import numpy as np
import pandas as pd

from . import _validate as v
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
    import matplotlib
    matplotlib.use("Agg")
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
    import matplotlib
    matplotlib.use("Agg")
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
