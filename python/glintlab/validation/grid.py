"""The standard regime grid (``glintlab/data/grids/standard.json``): the (n, p) points every table
and bound covers by default."""
from __future__ import annotations

import json

import numpy as np

from ..resources import data_path


def standard_grid() -> tuple[np.ndarray, np.ndarray]:
    """(n values, p values) of the standard grid: 51 x 47 points."""
    spec = json.loads(data_path("grids", "standard.json").read_text())
    return np.array(spec["n"]), np.array(spec["p"])
