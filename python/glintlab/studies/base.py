"""What every study shares: the context it runs in (:class:`Context`), what its ``compute`` returns
(:class:`Tables`) and a plotting helper.

A study is a module of :mod:`glintlab.studies` with a description (``NAME``, ``TITLE``, ``MEANING``,
``DEFAULTS``, ``QUICK``, ``NOTEBOOK``, ``TABLE``) and two functions: ``compute(params, ctx) -> Tables``
(numbers only) and ``figures(tables, ctx) -> [paths]`` (plotting only). The report
(:mod:`glintlab.report.sections`) finds every such module and runs it as a section of the page.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np


def _no_progress(label: str) -> None:
    pass


@dataclass
class Context:
    """What a study sees: where to write, the seed, quick mode, a progress callback (a short label of
    the current step) and the folder that relative paths of its parameters are relative to."""
    out: Path
    seed: int
    quick: bool = False
    progress: Callable[[str], None] = _no_progress
    base: Path = Path(".")

    def path(self, value) -> Path:
        path = Path(value)
        return path if path.is_absolute() else self.base / path

    def save(self, fig, name: str, dpi: int = 100) -> Path:
        """Writes a matplotlib figure as ``out/name`` and closes it."""
        import matplotlib.pyplot as plt
        path = Path(self.out) / name
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
        return path


@dataclass
class Tables:
    """What a study's ``compute`` returns.

    ``tables``: the study's tables (each written as NAME.csv, recorded in report.json and shown on the
    page); ``stats``: the headline numbers shown under the section title; ``failures``: checks that
    failed (the report exits 1); ``extra``: tables written as CSV beside the page only; ``data``: what
    the figures need besides tables (images, distributions, samples), never written.
    ``tables["name"]`` looks in ``tables``, then ``extra``, then ``data``."""
    tables: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    failures: list = field(default_factory=list)
    extra: dict = field(default_factory=dict)
    data: dict = field(default_factory=dict)

    def __getitem__(self, name: str):
        for part in (self.tables, self.extra, self.data):
            if name in part:
                return part[name]
        raise KeyError(name)

    def __contains__(self, name: str) -> bool:
        return name in self.tables or name in self.extra or name in self.data


def support_window(d, mass: float = 1e-4):
    """The support range of distribution ``d`` holding all but ``mass`` of it (readable axes)."""
    c = np.cumsum(d.probs)
    lo = d.support[np.searchsorted(c, mass / 2)]
    hi = d.support[min(np.searchsorted(c, 1 - mass / 2), len(c) - 1)]
    return lo, hi
