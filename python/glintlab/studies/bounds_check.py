"""The error bounds a renderer's CI can gate on (``glintlab check``), checked on every report run."""
from __future__ import annotations

from ..resources import data_path
from ..validation.bounds import check
from .base import Context, Tables

NAME = "bounds_check"
TITLE = "Error bounds (the shipped default.json)"
MEANING = "The error bounds a renderer's CI can gate on: every built-in law keeps its recorded worst case."
DEFAULTS = {"bounds": str(data_path("bounds", "default.json"))}
QUICK: dict = {}
NOTEBOOK = "speed_accuracy.ipynb"
TABLE = {"bounds_check": ["id", "law", "metric", "limit", "bound", "worst", "ok"]}


def compute(params: dict, ctx: Context) -> Tables:
    table = check(ctx.path(params["bounds"]), progress=False)
    bad = table[~table.ok]
    return Tables({"bounds_check": table}, {"bounds holding": f"{int(table.ok.sum())} of {len(table)}"},
                  [f"bound {r.id} violated: {r.metric} = {r.worst:.6g} (bound {r.bound:.6g})"
                   for r in bad.itertuples()])


def figures(tables: Tables, ctx: Context) -> list:
    return []
