"""The report's sections: every study of :mod:`glintlab.studies`, found by looking (each module there but
the helpers the package names in ``HELPERS``; it defines ``NAME``, ``compute`` and ``figures``),
registered by name in :data:`SECTIONS`.

A study module describes itself (``NAME``, ``TITLE``, ``MEANING``, ``DEFAULTS``, ``QUICK``, ``NOTEBOOK``,
``TABLE``; see :mod:`glintlab.studies.base`); :class:`Section` is that description plus its two
functions. A section from elsewhere joins the report with
``SECTIONS.register(module.NAME, Section.from_module(module))``.
"""
from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from types import ModuleType
from typing import Callable

from .. import studies
from ..api.registry import Registry

REQUIRED = ("NAME", "compute", "figures")


@dataclass(frozen=True)
class Section:
    name: str
    title: str
    meaning: str       # one sentence: what the figure says (the README carries it verbatim)
    defaults: dict     # every parameter and its default; a configuration may set these only
    quick: dict        # the defaults --quick overrides
    compute: Callable  # (params, ctx) -> studies.base.Tables
    figures: Callable  # (tables, ctx) -> [figure paths]
    notebook: str = ""
    table: dict = field(default_factory=dict)  # table -> columns printed on the terminal

    @property
    def short(self) -> str:
        """The title up to its first colon or parenthesis (figure captions, the thumbnail)."""
        return self.title.split(":")[0].split(" (")[0].split(",")[0]

    @classmethod
    def from_module(cls, module: ModuleType) -> "Section":
        defaults = dict(getattr(module, "DEFAULTS", {}))
        quick = dict(getattr(module, "QUICK", {}))
        unknown = sorted(set(quick) - set(defaults))
        if unknown:
            raise ValueError(f"{module.__name__}: QUICK sets {unknown}, which are not in DEFAULTS")
        return cls(module.NAME, getattr(module, "TITLE", module.NAME), getattr(module, "MEANING", ""), defaults,
                   quick, module.compute, module.figures, getattr(module, "NOTEBOOK", ""),
                   dict(getattr(module, "TABLE", {})))


def discover(package: ModuleType = studies) -> Registry:
    """Sections of every study module of ``package`` (alphabetical; the configuration sets page order):
    each module but the package's ``HELPERS`` and names starting with "_". A module that is neither a
    helper nor a complete study is an error (a study missing ``figures`` is not silently left out)."""
    found = Registry("report section")
    helpers = set(getattr(package, "HELPERS", ()))
    for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
        if info.name.startswith("_") or info.name in helpers:
            continue
        module = importlib.import_module(f"{package.__name__}.{info.name}")
        missing = [attr for attr in REQUIRED if not hasattr(module, attr)]
        if missing:
            raise ValueError(f"{module.__name__} is neither a study (it lacks {', '.join(missing)}) nor one of "
                             f"{package.__name__}.HELPERS")
        found.register(module.NAME, Section.from_module(module))
    return found


SECTIONS: Registry = discover()
