"""Parameter sweeps: laws x (n, p) grid -> one table row per law and grid point.

``sweep`` is the engine under experiments (``glintlab run``), the command line (``glintlab sweep``)
and bound checks (``glintlab check``). Two modes:

exact    (``samples=None``) the law's exact distribution against the reference's: deterministic,
         both need ``pmf``.
sampled  (``samples=m``) m draws of the law, binned as its pmf is, against the reference's exact
         distribution (or m draws of the reference when it has none). Every row draws with its own
         seed, ``row_seed(seed, law, n, p)``: a hash of the row's identity, so a row's numbers do not
         depend on the grid around it, the order rows finish in, or the number of threads.
         Monte Carlo error is reported next to the metrics: ``tv_noise`` is the exact expected TV
         between m draws of the reference and the reference itself (a TV at that level is sampling
         noise), ``mean_rel_err_se`` the standard error of ``mean_rel_err``.

``store=PATH`` makes a sweep resumable: a JSON-lines file whose first line holds the sweep's
configuration and whose every other line is one finished row, flushed to the operating system as
soon as the row is done. A sweep interrupted by Ctrl-C or ``kill -9`` loses no finished row; run
again with the same arguments and it computes only the missing rows. The final table is the same
as an uninterrupted run's, bit for bit (every row, fresh or stored, goes through the same JSON round
trip, which is exact for floats).
"""
from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from .. import _core
from .._core import __version__ as _version
from ..api import checks as v
from ..api.laws import Law
from .engines import DaskEngine, ThreadEngine
from .grid import standard_grid
from .references import make_reference, resolve_law
from .rows import MOMENT_METRICS, SAMPLED_ONLY, SWEEP_METRICS, compute_chunk
from .store import STORE_FORMAT, SweepStore, row_key

DEFAULT_METRICS = ("tv", "mean_rel_err", "var_rel_err")
__all__ = ["sweep", "SweepSpec", "CheckedSweep", "run_sweep", "DEFAULT_METRICS", "SWEEP_METRICS", "MOMENT_METRICS",
           "SAMPLED_ONLY", "STORE_FORMAT"]


def _axis(name, values, which):
    if values is None or (isinstance(values, str) and values == "standard"):
        gn, gp = standard_grid()
        return gn if which == "n" else gp
    arr = v.as_float_array(name, values).ravel()
    if arr.size == 0:
        v.fail(name, values, "a non-empty array")
    bad = ~np.isfinite(arr) | (arr < 0) | ((arr > 1) if which == "p" else False)
    if bad.any():
        i = int(np.argmax(bad))
        v.fail(f"{name}[{i}]" if arr.size > 1 else name, float(arr[i]),
               "a finite number >= 0" if which == "n" else "a probability in [0, 1]")
    return arr


def _metric_list(metrics, samples):
    if isinstance(metrics, str):
        metrics = [metrics]
    metrics = list(metrics)
    if not metrics:
        v.fail("metrics", metrics, "a non-empty list of metric names")
    for m in metrics:
        v.choice("metric", m, SWEEP_METRICS, "one of " + ", ".join(SWEEP_METRICS))
    if samples is None and "chi2_pvalue" in metrics:
        v.fail("metrics", metrics, "no 'chi2_pvalue' in an exact sweep (samples=None); pass samples=...")
    return list(dict.fromkeys(metrics))


@dataclass
class SweepSpec:
    """What a sweep computes and how: the arguments of :func:`sweep`, as one object. ``check()``
    validates every field (a ValueError naming the first bad one) and returns the resolved plan
    (:class:`CheckedSweep`); nothing is computed or written before it passes."""
    laws: Any
    n: Any = None
    p: Any = None
    metrics: Any = DEFAULT_METRICS
    reference: Any = "binomial"
    samples: Any = None
    seed: Any = 1
    store: Any = None
    progress: Any = None
    threads: Any = None
    points: Any = None
    engine: str = "threads"
    scheduler: Any = None
    workers: Any = None
    chunk: Any = None
    timeout: Any = 10.0

    def check(self) -> "CheckedSweep":
        laws = self.laws
        if isinstance(laws, (str, Law, dict)):
            laws = [laws]
        laws = [resolve_law(x) for x in laws]
        if not laws:
            v.fail("laws", laws, "a non-empty list of laws")
        labels = [lw.label for lw in laws]
        if len(set(labels)) != len(labels):
            v.fail("laws", labels, "distinct laws")
        samples = self.samples
        if samples is not None:
            samples = v.integer("samples", samples, minimum=1, expected="None (exact) or an integer >= 1")
        seed = v.seed(self.seed)
        metrics = _metric_list(self.metrics, samples)
        ref = make_reference(self.reference)
        if samples is None:
            for lw in laws:
                if not lw.has_pmf:
                    raise ValueError(f"law {lw.label!r} has no exact pmf (no exact distribution); an exact sweep "
                                     "(samples=None) needs one (pass samples=... for a Monte Carlo sweep)")
            if not ref.has_pmf:
                raise ValueError("the reference has no exact distribution; pass samples=...")
        if self.points is None:
            nn, pp = _axis("n", self.n, "n"), _axis("p", self.p, "p")
            grid = [(float(a), float(b)) for a in nn for b in pp]
        else:
            arr = v.as_float_array("points", self.points)
            if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] == 0:
                v.fail("points", self.points, "a non-empty list of (n, p) pairs")
            _axis("points[:, 0]", arr[:, 0], "n"), _axis("points[:, 1]", arr[:, 1], "p")
            grid = [(float(a), float(b)) for a, b in arr]
        threads = v.integer("threads", (os.cpu_count() or 2) if self.threads is None else self.threads, minimum=1)
        engine = v.choice("engine", self.engine, ("threads", "dask"), "'threads' or 'dask'")
        if engine == "threads" and (self.scheduler is not None or self.workers is not None):
            v.fail("engine", engine, "'dask' when a scheduler or workers are given")
        workers = None if self.workers is None else v.integer("workers", self.workers, minimum=1)
        chunk = None if self.chunk is None else v.integer("chunk", self.chunk, minimum=1)
        timeout = v.real("timeout", self.timeout)
        if not timeout > 0:
            v.fail("timeout", timeout, "a number of seconds > 0")
        return CheckedSweep(laws, labels, grid, metrics, ref, samples, seed, self.store, self.progress, threads,
                            engine, self.scheduler, workers, chunk, timeout)


@dataclass(frozen=True)
class CheckedSweep:
    """A :class:`SweepSpec` after ``check()``: laws resolved (with their labels), the grid as (n, p)
    pairs, the reference object, every number validated."""
    laws: list
    labels: list
    grid: list
    metrics: list
    ref: Any
    samples: int | None
    seed: int
    store: Any
    progress: Any
    threads: int
    engine: str
    scheduler: Any
    workers: int | None
    chunk: int | None
    timeout: float


def sweep(laws, n=None, p=None, metrics=DEFAULT_METRICS, reference="binomial", samples=None, seed=1,
          store=None, progress=None, threads=None, points=None, engine="threads", scheduler=None, workers=None,
          chunk=None, timeout=10.0) -> pd.DataFrame:
    """Evaluates every law at every grid point; one row per law and point, in law, n, p order.

    ``sweep(SweepSpec(...))`` takes the arguments as one object (checked by ``SweepSpec.check``); the
    keyword form below builds that object.

    laws       names, Law objects or experiment law specs (a single one is allowed)
    n, p       grid axes (arrays; None or "standard": the standard grid's axes); the grid is n x p
    points     instead of n and p: an explicit list of (n, p) pairs
    metrics    any of SWEEP_METRICS: the distances of ``gl.distance`` (tv, chi2_distance, hellinger, kl,
               js, w1, ks), mean_rel_err, var_rel_err, and chi2_pvalue (sampled sweeps only)
    reference  a law name or Law (default: the exact binomial), or {"ground_truth": {layout, density,
               footprint, aspect, angle}}
    samples    None: exact distributions; m: m draws per row (see the module docstring)
    seed       the sweep's seed (rows draw with row_seed(seed, law, n, p))
    store      a path: finished rows are written there as they finish and skipped on a rerun
    progress   True/False, or None: a progress bar when stderr is a terminal
    threads    rows computed at once by the "threads" engine (default: the number of cores)
    engine     "threads" (this process) or "dask" (glintlab.validation.engines): ``scheduler`` the address of a
               running Dask scheduler, or None for a LocalCluster of ``workers`` processes here;
               ``chunk`` rows per task (default: about four tasks per worker); ``timeout`` seconds
               to wait for the scheduler. The table is the same, bit for bit, with any engine.

    Columns: law, n, p, the metrics, then for sampled sweeps chi2_note and chi2_resolution (with
    chi2_pvalue: what the test said, e.g. samples on values of probability 0, and the p-value's
    resolution, 0 unless it is a Monte Carlo estimate), tv_noise (with tv), mean_rel_err_se
    (with mean_rel_err), samples and the row's seed. ``df.attrs`` holds the configuration and, for
    stored sweeps, how many rows came from the store.
    """
    spec = laws if isinstance(laws, SweepSpec) else SweepSpec(
        laws, n, p, metrics, reference, samples, seed, store, progress, threads, points, engine, scheduler, workers,
        chunk, timeout)
    return run_sweep(spec.check())


def run_sweep(plan: CheckedSweep) -> pd.DataFrame:
    """Runs a checked sweep (``SweepSpec(...).check()``); the table :func:`sweep` returns."""
    laws, labels, grid, metrics, ref = plan.laws, plan.labels, plan.grid, plan.metrics, plan.ref
    samples, seed, store, progress, engine = plan.samples, plan.seed, plan.store, plan.progress, plan.engine
    tasks = [(i, j, a, b) for i in range(len(laws)) for j, (a, b) in enumerate(grid)]
    # law_identities: what each law IS (a custom law's source, a plugin's file), not only its name, so
    # a store never hands one function's rows to another function registered under the same name.
    config = {"laws": labels, "law_identities": [lw.identity for lw in laws], "grid": [[a, b] for a, b in grid],
              "metrics": metrics, "reference": ref.spec, "samples": samples, "seed": seed}

    st = SweepStore(store, config) if store is not None else None
    done = st.rows if st is not None else {}
    todo = [t for t in tasks if (labels[t[0]], t[2].hex(), t[3].hex()) not in done]
    resumed = len(tasks) - len(todo)
    results: dict[tuple, dict] = dict(done)
    chunk = plan.chunk

    if engine == "dask":
        eng = DaskEngine(plan.scheduler, plan.workers, plan.timeout)
    else:
        eng = ThreadEngine(plan.threads)
    if samples is None:  # exact rows at one point share the reference's pmf: run them point by point
        todo.sort(key=lambda t: (t[1], t[0]))
    if chunk is None:  # a few chunks per worker: balance, and little lost work on an interruption
        if engine == "threads":
            chunk = len(laws) if samples is None else 1
        else:
            chunk = max(1, min(256, -(-len(todo) // (4 * eng.slots))))
    chunks = [[(t[0], t[2], t[3]) for t in todo[k:k + chunk]] for k in range(0, len(todo), chunk)]
    bar = _bar(progress, len(tasks), resumed)
    try:
        pending = set()
        it = iter(chunks)
        window = 2 * eng.slots  # chunks in flight at once

        def refill():
            for ch in it:
                pending.add(eng.submit(compute_chunk, laws, labels, ref, metrics, samples, seed, ch))
                if len(pending) >= window:
                    break
        refill()
        while pending:
            finished, pending = eng.wait_first(pending)
            for fut in finished:
                for row in fut.result():
                    results[row_key(row)] = row
                    if st is not None:
                        st.add(row)
                    bar.update(1)
            refill()
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            # Ctrl-C reached this (main) thread; the pool's threads are inside C++ batches, which
            # stop at their next chunk once asked, so that closing the pool does not wait for them.
            _core.request_interrupt()
        eng.close(cancel=True)
        if st is not None:
            st.close()
            print(f"sweep interrupted: {len(st.rows)} of {len(tasks)} rows are in {st.path}; "
                  "run the same sweep again to finish it", file=sys.stderr)
        bar.close()
        raise
    eng.close()
    bar.close()
    if st is not None:
        st.close()
    rows = [results[(labels[i], a.hex(), b.hex())] for i, _, a, b in tasks]
    df = pd.DataFrame(rows)
    df.attrs.update(config=config, resumed_rows=resumed, computed_rows=len(todo), glintlab_version=_version)
    return df


def error_table(laws, n=None, p=None, metrics=("tv", "hellinger", "w1"), reference="binomial",
                threads=None) -> pd.DataFrame:
    """Exact errors of each law against ``reference`` at every (n, p) of the grid (default: standard).

    One row per law and grid point, sorted by law, n, p: law, n, p, each metric, mean_rel_err and
    var_rel_err (of the law's exact distribution against the reference's; var_rel_err is
    |var - var_ref| / var_ref, inf when only var_ref is 0). Every law needs an exact pmf. This is an
    exact ``sweep`` (the same engine, on both cores) sorted by law name.
    """
    n = None if n is None else np.atleast_1d(n)
    p = None if p is None else np.atleast_1d(p)
    metrics = list(dict.fromkeys([*metrics, "mean_rel_err", "var_rel_err"]))
    df = sweep(laws, n=n, p=p, metrics=metrics, reference=reference, threads=threads, progress=False)
    df.attrs.clear()
    return df.sort_values(["law", "n", "p"], kind="stable").reset_index(drop=True)


def _bar(progress, total, initial):
    if progress is None:
        progress = sys.stderr.isatty()
    if not progress:
        class _Null:
            def update(self, k): pass
            def close(self): pass
        return _Null()
    from tqdm import tqdm
    return tqdm(total=total, initial=initial, desc="sweep", unit="row", file=sys.stderr, leave=False)
