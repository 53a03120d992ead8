"""Report configurations: which sections run, in what page order, with what overrides.

A configuration (``glintlab/data/report/default.json``, schema ``glintlab/data/schema/report.schema.json``)
lists sections by name; each entry may override the study's parameters (``params``) and, for
``--quick``, its quick sizes (``quick``). A section's parameters are, in order of precedence: the
entry's ``quick`` (with --quick), the entry's ``params``, the study's ``QUICK`` (with --quick), the
study's ``DEFAULTS``.
"""
from __future__ import annotations

import math

from ..api import checks as V
from ..resources import data_path
from ..validation.documents import fail, parse_document, render
from .sections import SECTIONS

DEFAULT_CONFIG = data_path("report", "default.json")
SCHEMA = data_path("schema", "report.schema.json")


def load_config(source=None) -> tuple[dict, str]:
    """(document, source name) of a report configuration: a path, JSON text or a dict; default
    ``glintlab/data/report/default.json``. Validated against ``glintlab/data/schema/report.schema.json`` (in
    C++, through ``validation.documents.parse_document``, like every document glintlab reads) and
    against the registered sections' names and parameters; a bad document raises ValueError
    ``<source>: at <JSON pointer>: expected <what>, got <value>``."""
    doc, name, _ = parse_document("report", DEFAULT_CONFIG if source is None else source)
    seen = {}
    for i, entry in enumerate(doc["sections"]):
        at = f"/sections/{i}"
        if entry["name"] not in SECTIONS:
            fail(name, f"{at}/name", f"one of {', '.join(SECTIONS.names())}", entry["name"])
        if entry["name"] in seen:
            fail(name, f"{at}/name", f"a section not listed before (as /sections/{seen[entry['name']]}/name)",
                 entry["name"])
        seen[entry["name"]] = i
        sec = SECTIONS.get(entry["name"])
        for part in ("params", "quick"):
            for key, value in entry.get(part, {}).items():
                pointer = V.json_pointer(["sections", i, part, key])
                if key not in sec.defaults:
                    fail(name, pointer, f"a parameter of {entry['name']} ({', '.join(sec.defaults)})", key)
                check_type(f"{name}: at {pointer}", value, sec.defaults[key])
    return doc, name


def check_type(where: str, value, default) -> None:
    """A parameter has its default's type: bool, int, number (finite), string, or a list of the default's kind."""
    if isinstance(default, bool):
        ok, what = isinstance(value, bool), "true or false"
    elif isinstance(default, int):  # counts (positive defaults) must be >= 1; other integers (a level) any sign
        ok = isinstance(value, int) and not isinstance(value, bool) and (value >= 1 or default <= 0)
        what = "an integer >= 1" if default > 0 else "an integer"
    elif isinstance(default, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        what = "a finite number"
    elif isinstance(default, str):
        ok, what = isinstance(value, str) and value != "", "a non-empty string"
    elif default is None:  # an optional size (None: off)
        ok = value is None or (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
                               and value > 0)
        what = "null or a finite number > 0"
    elif default and all(isinstance(x, str) for x in default):  # names (methods, targets)
        ok = isinstance(value, list) and len(value) > 0 and all(isinstance(x, str) and x != "" for x in value)
        what = "a non-empty list of non-empty strings"
    else:  # a list takes its default's kind: indices (integers >= 0), values that may be 0, or numbers > 0
        indices = all(isinstance(x, int) and not isinstance(x, bool) for x in default)
        zero_ok = indices or any(x == 0 for x in default)
        ok = (isinstance(value, list) and len(value) > 0 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
            and (x >= 0 if zero_ok else x > 0) and (isinstance(x, int) or not indices) for x in value))
        what = ("a non-empty list of integers >= 0" if indices else
                "a non-empty list of finite numbers >= 0" if zero_ok else "a non-empty list of finite numbers > 0")
    if not ok:
        raise ValueError(f"{where}: expected {what}, got {render(value)}")


def section_params(entry: dict, quick: bool) -> dict:
    """The parameters a configuration entry runs its section with (see the module docstring)."""
    sec = SECTIONS.get(entry["name"])
    prm = {**sec.defaults, **(sec.quick if quick else {}), **entry.get("params", {})}
    if quick:
        prm.update(entry.get("quick", {}))
    return prm
