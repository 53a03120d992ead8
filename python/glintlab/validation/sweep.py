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

import hashlib
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from .._core import __version__ as _version
from ..api import checks as v
from .._core import Distribution
from .grid import _label, standard_grid
from ..api.laws import Law, law as get_law
from .engines import ThreadEngine
from ..api.metrics import METRICS, chi2_test, distance

MOMENT_METRICS = ("mean_rel_err", "var_rel_err")
SAMPLED_ONLY = ("chi2_pvalue",)
SWEEP_METRICS = tuple(METRICS) + MOMENT_METRICS + SAMPLED_ONLY
DEFAULT_METRICS = ("tv", "mean_rel_err", "var_rel_err")
STORE_FORMAT = 1


# ---------------------------------------------------------------------------------------------
# References: what a law is compared with.

class LawReference:
    """Another law (by default the exact binomial) as the reference."""

    def __init__(self, law_: Law):
        self.law = law_
        self.spec = _label(law_)

    @property
    def has_pmf(self) -> bool:
        return self.law.has_pmf

    def pmf(self, n, p) -> Distribution:
        return self.law.pmf(n, p)

    def sample(self, n, p, size, seed):
        return self.law.bin(self.law.sample(n, p, size=size, seed=seed))


class GroundTruthReference:
    """The ground truth of a facet layout (``gl.ground_truth``): at grid point (n, p), the count in a
    footprint of area n / density (a rectangle or ellipse of the given aspect and angle) placed at a
    uniformly random position."""

    def __init__(self, layout="stratified", density=None, footprint="rect", aspect=1.0, angle=0.0):
        from ..api.spatial import LAYOUTS
        if layout not in LAYOUTS:
            v.fail("layout", layout, "one of " + ", ".join(LAYOUTS))
        self.layout, self.density = layout, v.real("density", density)
        if not (self.density >= 1 and math.isfinite(self.density)):
            v.fail("density", density, "a number >= 1")
        if footprint not in ("rect", "ellipse"):
            v.fail("footprint", footprint, "'rect' or 'ellipse'")
        self.footprint, self.aspect, self.angle = footprint, v.real("aspect", aspect), v.real("angle", angle)
        if not self.aspect >= 1:
            v.fail("aspect", aspect, "a number >= 1")
        self.spec = {"ground_truth": dict(layout=layout, density=self.density, footprint=footprint,
                                          aspect=self.aspect, angle=self.angle)}

    has_pmf = True

    def _truth(self, n, p):
        from ..api.spatial import footprint_for_area, ground_truth
        area = n / self.density
        if not 0 < area <= 1:
            raise ValueError(f"ground truth reference: n = {n!r} gives a footprint of area n / density = {area!r}; "
                             f"expected an area in (0, 1] (n in (0, {self.density:g}])")
        fp = footprint_for_area(area, aspect=self.aspect, angle=self.angle, shape=self.footprint)
        density = int(self.density) if self.layout != "poisson" else self.density
        return ground_truth(self.layout, density=density, footprint=fp, p=p)

    def pmf(self, n, p) -> Distribution:
        return self._truth(n, p).pmf()

    def sample(self, n, p, size, seed):
        return self._truth(n, p).sample(size=size, seed=seed)


def make_reference(spec):
    """A reference from a law name, a Law, {"law": spec}, {"ground_truth": {...}} or a reference object."""
    if isinstance(spec, (LawReference, GroundTruthReference)):
        return spec
    if isinstance(spec, Law):
        return LawReference(spec)
    if isinstance(spec, dict) and "ground_truth" in spec:
        return GroundTruthReference(**spec["ground_truth"])
    if isinstance(spec, dict) and "law" in spec:
        return LawReference(resolve_law(spec["law"]))
    if isinstance(spec, str):
        return LawReference(resolve_law(spec))
    v.fail("reference", spec, "a law name, a Law, {'law': ...} or {'ground_truth': {...}}")


def resolve_law(spec, base_dir: Path | None = None) -> Law:
    """A law from a name, a Law, or an experiment's law object ({name, params}, {name, plugin} or
    {name, python, n_uniforms}); plugin and python file paths are relative to ``base_dir``."""
    if isinstance(spec, Law):
        return spec
    if isinstance(spec, str):
        return get_law(spec)
    if not isinstance(spec, dict) or "name" not in spec:
        v.fail("law", spec, "a law name, a Law or an object with a name")
    name = spec["name"]
    if "plugin" in spec:
        from ..api.plugins import load_plugin
        path = Path(spec["plugin"])
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        names = load_plugin(str(path))
        if name not in names:
            raise ValueError(f"plugin {str(path)!r} has no law named {name!r}; it has {names}")
        return get_law(name)
    if "python" in spec:
        from ..api.laws import custom_law
        fn = _import_function(spec["python"], base_dir)
        return custom_law(fn, n_uniforms=int(spec.get("n_uniforms", 2)), name=name)
    return get_law(name, **spec.get("params", {}))


def _import_function(target: str, base_dir: Path | None):
    """'package.module:function' or 'path/to/file.py:function'."""
    import importlib
    import importlib.util
    where, sep, attr = target.rpartition(":")
    if not sep or not where or not attr:
        v.fail("python", target, "'module:function' or 'file.py:function'")
    if where.endswith(".py"):
        path = Path(where)
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        if not path.is_file():
            v.fail("python", target, f"an existing Python file ({path} does not exist)")
        module_name = "glintlab_user_" + hashlib.sha1(str(path.resolve()).encode()).hexdigest()[:12]
        spec = importlib.util.spec_from_file_location(module_name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(where)
        except ImportError as exc:
            raise ValueError(f"python = {target!r} is invalid: cannot import {where!r} ({exc})") from None
    fn = getattr(module, attr, None)
    if not callable(fn):
        v.fail("python", target, f"a callable named {attr!r} in {where!r}")
    return fn


# ---------------------------------------------------------------------------------------------
# Rows.

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
    from scipy.special import gammaln
    m = float(samples)
    q = np.asarray(dist.probs, dtype=np.float64)
    q = q[(q > 0) & (q < 1)]
    if q.size == 0:
        return 0.0
    nu = np.floor(m * q) + 1
    log_mad = (np.log(2 * nu) + gammaln(m + 1) - gammaln(nu + 1) - gammaln(m - nu + 1)
               + nu * np.log(q) + (m - nu + 1) * np.log1p(-q))
    return float(np.sum(np.exp(log_mad)) / (2 * m))


def _rel(a, b):
    return abs(a - b) / abs(b) if b else abs(a)


def _moments(d: Distribution, ref_mean, ref_var):
    return {"mean_rel_err": _rel(d.mean, ref_mean),
            "var_rel_err": (abs(d.var - ref_var) / ref_var if ref_var else (0.0 if d.var == 0 else math.inf))}


def compute_row(lw: Law, label: str, reference, n: float, p: float, metrics, samples, seed) -> dict:
    """One row of a sweep (pure: the same arguments give the same row)."""
    row = {"law": label, "n": float(n), "p": float(p)}
    want_dist = [m for m in metrics if m in METRICS]
    if samples is None:
        d = lw.pmf(n, p)
        d_ref = reference.pmf(n, p)
        row.update({m: distance(d, d_ref, m) for m in want_dist})
        mom = _moments(d, d_ref.mean, d_ref.var)
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
    row.update({m: distance(d, d_ref, m) for m in want_dist})
    mom = _moments(d, d_ref.mean, d_ref.var)
    row.update({m: mom[m] for m in metrics if m in MOMENT_METRICS})
    if "chi2_pvalue" in metrics:
        row["chi2_pvalue"] = chi2_test(x, d_ref).pvalue if reference.has_pmf else math.nan
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
    for i, n, p in items:
        try:
            row = compute_row(laws[i], labels[i], reference, n, p, metrics, samples, seed)
        except (ValueError, NotImplementedError) as exc:
            raise ValueError(f"sweep: law {labels[i]!r} at n = {n!r}, p = {p!r}: {exc}") from exc
        rows.append(json.loads(json.dumps(row)))
    return rows


# ---------------------------------------------------------------------------------------------
# The store: JSON lines, header first.

class SweepStore:
    """A resumable store of finished rows (see the module docstring)."""

    def __init__(self, path, config: dict):
        self.path = Path(path)
        self.config = config
        self.key = hashlib.sha256(json.dumps(config, sort_keys=True).encode()).hexdigest()
        self.rows: dict[tuple, dict] = {}
        self._last_sync = time.monotonic()
        if self.path.exists() and self.path.stat().st_size > 0:
            self._load()
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            header = {"glintlab_store": STORE_FORMAT, "glintlab_version": _version, "key": self.key,
                      "config": config}
            with open(self.path, "w") as f:
                f.write(json.dumps(header) + "\n")
                f.flush()
                os.fsync(f.fileno())
        self._file = open(self.path, "a")

    def _load(self):
        raw = self.path.read_bytes()
        lines = raw.split(b"\n")
        try:
            header = json.loads(lines[0])
        except ValueError:
            header = None
        if not isinstance(header, dict) or header.get("glintlab_store") != STORE_FORMAT:
            raise ValueError(f"store = {str(self.path)!r} is invalid; expected a glintlab sweep store "
                             "(a JSON-lines file written by sweep(store=...))")
        if header.get("key") != self.key:
            old = header.get("config", {})
            diff = sorted(k for k in set(old) | set(self.config) if old.get(k) != self.config.get(k))
            raise ValueError(f"store = {str(self.path)!r} holds a different sweep (differs in: {', '.join(diff)}); "
                             "use another store path, or delete it to start over")
        # Complete lines end with a newline; what follows the last one was cut by a kill: it is
        # dropped (cut from the file) and its row recomputed.
        if len(lines) == 1:  # the header's newline never reached the file
            with open(self.path, "ab") as f:
                f.write(b"\n")
            return
        good_end = len(lines[0]) + 1
        for line in lines[1:-1]:
            if line:
                try:
                    row = json.loads(line)
                except ValueError:
                    break
                self.rows[_row_key(row)] = row
            good_end += len(line) + 1
        if good_end < len(raw):
            with open(self.path, "r+b") as f:
                f.truncate(good_end)

    def add(self, row: dict):
        self._file.write(json.dumps(row) + "\n")
        self._file.flush()  # in the kernel's hands: survives kill -9 of this process
        self.rows[_row_key(row)] = row
        if time.monotonic() - self._last_sync > 1.0:  # and on disk, about once a second
            os.fsync(self._file.fileno())
            self._last_sync = time.monotonic()

    def close(self):
        if not self._file.closed:
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()


def _row_key(row):
    return (row["law"], float(row["n"]).hex(), float(row["p"]).hex())


# ---------------------------------------------------------------------------------------------
# The sweep.

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
        if m not in SWEEP_METRICS:
            v.fail("metric", m, "one of " + ", ".join(SWEEP_METRICS))
    if samples is None and "chi2_pvalue" in metrics:
        v.fail("metrics", metrics, "no 'chi2_pvalue' in an exact sweep (samples=None); pass samples=...")
    return list(dict.fromkeys(metrics))


def sweep(laws, n=None, p=None, metrics=DEFAULT_METRICS, reference="binomial", samples=None, seed=1,
          store=None, progress=None, threads=None, points=None, engine="threads", scheduler=None, workers=None,
          chunk=None, timeout=10.0) -> pd.DataFrame:
    """Evaluates every law at every grid point; one row per law and point, in law, n, p order.

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
    engine     "threads" (this process) or "dask" (glintlab.dask_engine): ``scheduler`` the address of a
               running Dask scheduler, or None for a LocalCluster of ``workers`` processes here;
               ``chunk`` rows per task (default: about four tasks per worker); ``timeout`` seconds
               to wait for the scheduler. The table is the same, bit for bit, with any engine.

    Columns: law, n, p, the metrics, then for sampled sweeps tv_noise (with tv), mean_rel_err_se
    (with mean_rel_err), samples and the row's seed. ``df.attrs`` holds the configuration and, for
    stored sweeps, how many rows came from the store.
    """
    if isinstance(laws, (str, Law, dict)):
        laws = [laws]
    laws = [resolve_law(x) for x in laws]
    if not laws:
        v.fail("laws", laws, "a non-empty list of laws")
    labels = [_label(lw) for lw in laws]
    if len(set(labels)) != len(labels):
        v.fail("laws", labels, "distinct laws")
    if samples is not None:
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
            v.fail("samples", samples, "None (exact) or an integer >= 1")
        samples = int(samples)
    seed = v.seed(seed)
    metrics = _metric_list(metrics, samples)
    ref = make_reference(reference)
    if samples is None:
        for lw in laws:
            if not lw.has_pmf:
                raise ValueError(f"law {_label(lw)!r} has no exact distribution; an exact sweep needs one "
                                 "(pass samples=... for a Monte Carlo sweep)")
        if not ref.has_pmf:
            raise ValueError("the reference has no exact distribution; pass samples=...")
    if points is None:
        nn, pp = _axis("n", n, "n"), _axis("p", p, "p")
        grid = [(float(a), float(b)) for a in nn for b in pp]
    else:
        arr = v.as_float_array("points", points)
        if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] == 0:
            v.fail("points", points, "a non-empty list of (n, p) pairs")
        _axis("points[:, 0]", arr[:, 0], "n"), _axis("points[:, 1]", arr[:, 1], "p")
        grid = [(float(a), float(b)) for a, b in arr]
    tasks = [(i, j, a, b) for i in range(len(laws)) for j, (a, b) in enumerate(grid)]
    config = {"laws": labels, "grid": [[a, b] for a, b in grid], "metrics": metrics, "reference": ref.spec,
              "samples": samples, "seed": seed}

    st = SweepStore(store, config) if store is not None else None
    done = st.rows if st is not None else {}
    todo = [t for t in tasks if (labels[t[0]], t[2].hex(), t[3].hex()) not in done]
    resumed = len(tasks) - len(todo)
    results: dict[tuple, dict] = dict(done)
    if threads is None:
        threads = os.cpu_count() or 2
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        v.fail("threads", threads, "an integer >= 1")
    if engine not in ("threads", "dask"):
        v.fail("engine", engine, "'threads' or 'dask'")
    if engine == "threads" and (scheduler is not None or workers is not None):
        v.fail("engine", engine, "'dask' when a scheduler or workers are given")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        v.fail("workers", workers, "an integer >= 1")
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1):
        v.fail("chunk", chunk, "an integer >= 1")
    timeout = v.real("timeout", timeout)
    if not timeout > 0:
        v.fail("timeout", timeout, "a number of seconds > 0")

    if engine == "dask":
        from .engines import DaskEngine
        eng = DaskEngine(scheduler, workers, timeout)
    else:
        eng = ThreadEngine(threads)
    if chunk is None:  # a few chunks per worker: balance, and little lost work on an interruption
        chunk = 1 if engine == "threads" else max(1, min(256, -(-len(todo) // (4 * eng.slots))))
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
                    results[_row_key(row)] = row
                    if st is not None:
                        st.add(row)
                    bar.update(1)
            refill()
    except BaseException:
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
