"""Runs a report: the configured sections into an output directory, one record per section, then the page.

Each section writes its figures (PNG) and tables (CSV) into the output directory and a record
``sections/NAME.json`` (title, meaning, parameters, seed, seconds, headline numbers, failures, tables,
the command that regenerates it alone); ``report.json`` and ``index.html`` are assembled from the
records present, so ``glintlab report --only NAME`` re-runs one section and rebuilds the page.
"""
from __future__ import annotations

import json
import platform
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from .._core import __version__
from ..api import checks as V
from ..studies.base import Context, Tables
from .config import load_config, section_params
from .html import fmt, write_report_page, write_section_pages
from .sections import SECTIONS


class Progress:
    """A rich progress bar over sections on a terminal (elapsed time, current step); nothing otherwise."""

    def __init__(self, total: int, quiet: bool):
        self.enabled = not quiet and sys.stderr.isatty()
        self.total = total

    def __enter__(self):
        if self.enabled:
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
            self.p = Progress(TextColumn("[bold]report[/bold] {task.completed}/{task.total}"), BarColumn(),
                              TimeElapsedColumn(), TextColumn("{task.description}"), transient=True)
            self.p.__enter__()
            self.task = self.p.add_task("", total=self.total)
        return self

    def __exit__(self, *a):
        return self.p.__exit__(*a) if self.enabled else False

    def label(self, text: str):
        if self.enabled:
            self.p.update(self.task, description=text)

    def advance(self):
        if self.enabled:
            self.p.update(self.task, advance=1)


def command(out: Path, name: str | None, quick: bool, seed: int, config: str | None) -> str:
    """The command line that regenerates the report (``name`` None) or one section."""
    parts = ["glintlab report", f"--out {out}"]
    if name:
        parts.append(f"--only {name}")
    if quick:
        parts.append("--quick")
    parts.append(f"--seed {seed}")
    if config:
        parts.append(f"--config {config}")
    return " ".join(parts)


def _jsonable(stats: dict) -> dict:
    return {k: (float(v) if isinstance(v, (np.floating, np.integer)) else v) for k, v in stats.items()}


def write_section_files(tables: Tables, figures: Callable, ctx: Context) -> list:
    """The one writing path of a section's files, shared by the report and the commands that write one
    section's outputs (``glintlab aniso``, ``images``, ``profile``, ``bench``, ``shader``): the figures
    ``figures(tables, ctx)`` draws into ``ctx.out`` and every table of ``tables.tables`` and
    ``tables.extra`` as ``NAME.csv`` there. Returns the figure paths."""
    import matplotlib
    matplotlib.use("Agg")
    out = Path(ctx.out)
    out.mkdir(parents=True, exist_ok=True)
    paths = figures(tables, ctx)
    for name, df in {**tables.tables, **tables.extra}.items():
        df.to_csv(out / f"{name}.csv", index=False)
    return paths


def run_section(entry: dict, out: Path, seed: int, quick: bool, base: Path, config: str | None,
                progress: Progress) -> dict:
    """Runs one configured section into ``out``: its CSV tables, figures and record; returns the record."""
    sec = SECTIONS.get(entry["name"])
    prm = section_params(entry, quick)
    progress.label(sec.short)
    ctx = Context(out, seed, quick, lambda label: progress.label(f"{sec.short}: {label}"), base)
    t0, c0 = time.perf_counter(), time.process_time()
    tables = sec.compute(prm, ctx)
    figures = write_section_files(tables, sec.figures, ctx)
    write_section_pages(sec.name, tables, out)
    seconds = time.perf_counter() - t0
    # CPU seconds of the whole process (every thread): less sensitive than wall time to other jobs on a
    # shared machine, and above the wall time where the section's C++ calls ran on several threads.
    cpu_seconds = time.process_time() - c0
    record = {"name": sec.name, "title": sec.title, "meaning": sec.meaning, "params": prm, "seed": seed,
              "quick": quick, "seconds": round(seconds, 2), "cpu_seconds": round(cpu_seconds, 2),
              "notebook": sec.notebook,
              "command": command(out, sec.name, quick, seed, config),
              "figures": [Path(f).name for f in figures], "stats": _jsonable(tables.stats),
              "failures": tables.failures,
              "tables": {k: json.loads(v.to_json(orient="records")) for k, v in tables.tables.items()},
              "glintlab_version": __version__}
    (out / "sections" / f"{sec.name}.json").write_text(json.dumps(record, indent=1))
    return record


def run(out: Path, quick: bool = False, seed: int | None = None, quiet: bool = False, only=None,
        config=None) -> dict:
    """Runs the configured sections (or those named in ``only``) into ``out``, rebuilds index.html and
    report.json from every section record present, and returns the summary (report.json's content)."""
    doc, source = load_config(config)
    base = Path(source).parent if isinstance(config, (str, Path)) else Path.cwd()
    seed = V.seed(doc.get("seed", 1) if seed is None else seed)
    entries = doc["sections"]
    if only:
        names = [e["name"] for e in entries]
        for name in only:
            if name not in names:
                V.fail("only", name, f"a section of {source}: {', '.join(names)}")
        entries = [e for e in entries if e["name"] in only]
    out = Path(out)
    (out / "sections").mkdir(parents=True, exist_ok=True)
    import matplotlib
    matplotlib.use("Agg")
    config_arg = None if config is None else str(config)
    t0, c0 = time.perf_counter(), time.process_time()
    with Progress(len(entries), quiet) as progress:
        for entry in entries:
            run_section(entry, out, seed, quick, base, config_arg, progress)
            progress.advance()
    order = [e["name"] for e in doc["sections"]]
    records = [json.loads(p.read_text()) for p in sorted((out / "sections").glob("*.json"))]
    records = sorted((r for r in records if r["name"] in order), key=lambda r: order.index(r["name"]))
    summary = {
        "glintlab_version": __version__,
        "config": source,
        "command": command(out, None, quick, seed, config_arg),
        "seed": seed,
        "quick": quick,
        "python": platform.python_version(),
        "seconds": round(time.perf_counter() - t0, 2),
        "cpu_seconds": round(time.process_time() - c0, 2),
        "ran": [e["name"] for e in entries],
        "sections": {r["name"]: {**{k: r[k] for k in ("title", "seconds", "command", "stats", "failures", "params")},
                                 "cpu_seconds": r.get("cpu_seconds")}
                     for r in records},
        "tables": {k: v for r in records for k, v in r["tables"].items()},
        "figures": [f for r in records for f in r["figures"]],
        "failures": [f for r in records for f in r["failures"]],
    }
    (out / "report.json").write_text(json.dumps(summary, indent=1))
    write_report_page(out, summary, records)
    return summary


def print_summary(summary: dict) -> None:
    """The headline numbers and the study's chosen table columns of each section that ran."""
    tables = summary["tables"]
    for name in summary["ran"]:
        sec, rec = SECTIONS.get(name), summary["sections"][name]
        cpu = f", {rec['cpu_seconds']} s CPU" if rec.get("cpu_seconds") is not None else ""
        print(f"\n== {sec.title} ({rec['seconds']} s{cpu})")
        for k, v in rec["stats"].items():
            print(f"   {k}: {fmt(v)}")
        for table, cols in sec.table.items():
            if table in tables and tables[table]:
                df = pd.DataFrame(tables[table])
                print(df[[c for c in cols if c in df]].head(40).to_string(index=False, float_format=lambda v: f"{v:.4g}"))
        for f in rec["failures"]:
            print(f"   FAILED: {f}")
