"""The standard regime grid and exact error tables of laws against the binomial over it."""
from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from ..api.laws import law as get_law
from ..api.metrics import distance

from ..resources import data_path


def standard_grid() -> tuple[np.ndarray, np.ndarray]:
    """(n values, p values) of data/grids/standard.json: 51 x 47 points."""
    spec = json.loads(data_path("grids", "standard.json").read_text())
    return np.array(spec["n"]), np.array(spec["p"])


def error_table(laws, n=None, p=None, metrics=("tv", "hellinger", "w1"), reference="binomial",
                threads=None) -> pd.DataFrame:
    """Exact errors of each law against `reference` at every (n, p) of the grid (default: standard).

    One row per law and grid point: law, n, p, each metric, mean_rel_err and var_rel_err (of the
    law's exact distribution against the reference's; var_rel_err is |var - var_ref| / var_ref, inf
    when only var_ref is 0). Every law needs an exact pmf. Both cores: pmf and distance release the
    GIL, so a thread pool runs grid points in parallel.
    """
    if n is None or p is None:
        gn, gp = standard_grid()
        n = gn if n is None else np.atleast_1d(n)
        p = gp if p is None else np.atleast_1d(p)
    laws = [get_law(x) if isinstance(x, str) else x for x in laws]
    for lw in laws:
        if not lw.has_pmf:
            raise ValueError(f"law {lw.name!r} has no exact pmf; error_table needs one")
    ref = get_law(reference) if isinstance(reference, str) else reference
    points = [(float(a), float(b)) for a in n for b in p]

    def one(point):
        nn, pp = point
        d_ref = ref.pmf(nn, pp)
        rows = []
        for lw in laws:
            d = lw.pmf(nn, pp)
            row = {"law": _label(lw), "n": nn, "p": pp}
            row.update({m: distance(d, d_ref, m) for m in metrics})
            row["mean_rel_err"] = abs(d.mean - d_ref.mean) / d_ref.mean if d_ref.mean else abs(d.mean)
            row["var_rel_err"] = (abs(d.var - d_ref.var) / d_ref.var if d_ref.var
                                  else (0.0 if d.var == 0 else float("inf")))
            rows.append(row)
        return rows

    with ThreadPoolExecutor(max_workers=threads or os.cpu_count() or 2) as pool:
        rows = [r for chunk in pool.map(one, points) for r in chunk]
    return pd.DataFrame(rows).sort_values(["law", "n", "p"], kind="stable").reset_index(drop=True)


def _label(lw) -> str:
    params = lw.params
    return lw.name + "".join(f"[{k}={v}]" for k, v in sorted(params.items())) if params else lw.name
