"""The package's data files (schemas, default bounds, the standard grid, scenes, experiments).

They live in ``glintlab/data/`` and are found with :mod:`importlib.resources`, so the same code reads
them from the source tree and from an installed copy (``pip install .``). glintlab is installed as
plain files, never zipped, so a resource is an ordinary path.
"""
from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def data_path(*parts: str) -> Path:
    """Path of a file or folder under ``glintlab/data/``, e.g. ``data_path("bounds", "default.json")``."""
    return Path(str(files(__package__).joinpath("data", *parts)))
