"""Experiments as data: a JSON file (data/schema/experiment.schema.json) describing laws, an (n, p)
grid, metrics, a reference, sample counts and a seed; ``run_experiment`` runs it through ``sweep``.

Documents are parsed and validated in C++ through ``validation.documents.parse_document`` (the same
code the fuzzer exercises): a bad file raises ``InputError`` (a ValueError) whose message names the
file, the JSON pointer of the bad field and what was expected. Defaults are filled in by the parser,
and results (results.json) carry the complete configuration and the glintlab version, so
``glintlab run results.json`` re-runs an experiment exactly.
"""
from __future__ import annotations

import json
import shlex
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .._core import __version__
from .documents import RESULT_FORMAT, parse_document  # noqa: F401  (parse_document re-exported: tests import it here)
from .grid import standard_grid
from .references import resolve_law
from .sweep import sweep


def axis_values(spec, which: str) -> np.ndarray:
    """An experiment's grid axis: a list, {"logspace": [lo, hi, count]}, {"linspace": ...} or "standard"."""
    if isinstance(spec, str):
        n, p = standard_grid()
        return n if which == "n" else p
    if isinstance(spec, dict) and "logspace" in spec:
        lo, hi, count = spec["logspace"]
        return np.logspace(lo, hi, int(count))
    if isinstance(spec, dict) and "linspace" in spec:
        lo, hi, count = spec["linspace"]
        return np.linspace(lo, hi, int(count))
    return np.asarray(spec, dtype=np.float64)


@dataclass
class ExperimentResult:
    table: pd.DataFrame
    config: dict
    source: str
    seconds: float
    files: list = field(default_factory=list)


def run_experiment(source, out=None, store=None, progress=None, threads=None, plot=None,
                   **engine) -> ExperimentResult:
    """Runs an experiment (a path, JSON text or dict; or a results.json to re-run). With ``out``,
    writes results.csv, results.json and (with ``plot``) one PNG per metric there, as the document's
    outputs say. ``plot(table, metrics, out) -> [paths]`` draws the PNGs: this layer does not plot
    (``glintlab.run_experiment`` and ``glintlab run`` pass :func:`glintlab.studies.experiment_plots.plot_results`).
    ``engine``: sweep's engine, scheduler, workers, chunk and timeout (e.g. engine="dask")."""
    doc, name, base = parse_document("experiment", source)
    laws = []
    for i, spec in enumerate(doc["laws"]):
        try:
            laws.append(resolve_law(spec, base))
        except ValueError as exc:
            raise ValueError(f"{name}: at /laws/{i}: {exc}") from None
    reference = doc["reference"]
    if isinstance(reference, dict) and "law" in reference:
        try:
            reference = resolve_law(reference["law"], base)
        except ValueError as exc:
            raise ValueError(f"{name}: at /reference/law: {exc}") from None
    n = axis_values(doc["grid"]["n"], "n")
    p = axis_values(doc["grid"]["p"], "p")
    t0 = time.perf_counter()
    try:
        table = sweep(laws, n=n, p=p, metrics=doc["metrics"], reference=reference, samples=doc["samples"],
                      seed=doc["seed"], store=store, progress=progress, threads=threads, **engine)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None
    result = ExperimentResult(table, doc, name, round(time.perf_counter() - t0, 3))
    if out is not None:
        result.files = write_results(result, Path(out), base, plot)
    return result


def write_results(result: ExperimentResult, out: Path, base: Path | None, plot=None) -> list:
    out.mkdir(parents=True, exist_ok=True)
    doc, files = result.config, []
    if doc["outputs"]["csv"]:
        files.append(out / "results.csv")
        result.table.to_csv(files[-1], index=False)
    if doc["outputs"]["json"]:
        files.append(out / "results.json")
        payload = {"glintlab_result": RESULT_FORMAT, "glintlab_version": __version__, "config": doc,
                   "source": result.source, "base_dir": str(base) if base else None,
                   "command": "glintlab run " + shlex.quote(str(out / "results.json")),
                   "python": sys.version.split()[0], "seconds": result.seconds,
                   "rows": result.table.to_dict("records")}
        # numpy scalars as Python numbers: repr of a float round-trips exactly.
        files[-1].write_text(json.dumps(payload, indent=1, default=lambda x: x.item()))
    if doc["outputs"]["plots"] and plot is not None:
        files += plot(result.table, doc["metrics"], out)
    return files
