"""Every JSON document glintlab reads, through one path: experiments, error bounds, scenes and report
configurations are parsed and validated in C++ (validation/src/documents.cpp, the code ``make fuzz``
exercises) against the schemas in ``data/schema/`` (embedded at build time), with their defaults
filled in.

A bad document raises ``_core.InputError`` (a ValueError; the CLI exits 2) in one format:
``<file>: at <JSON pointer>: expected <what>, got <value>``. The checks a schema cannot state and that
need Python (a scene's geometry, the registered report sections) raise in the same format through
:func:`fail`.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from .. import _core
from ..api import checks as V

KINDS = ("experiment", "bounds", "scene", "report", "pipeline")
# results.json written by run_experiment: {"glintlab_result": RESULT_FORMAT, "config": ..., "base_dir": ...}
RESULT_FORMAT = 1


def fail(source: str, pointer: str, expected: str, got) -> None:
    """Raises ValueError ``<source>: at <pointer>: expected <expected>, got <got as JSON>`` (the C++
    InputError's format; the root pointer "" is shown as "/")."""
    raise ValueError(f"{source}: at {pointer or '/'}: expected {expected}, got {render(got)}")


def render(value, limit: int = 60) -> str:
    """A short JSON rendering of a value for messages (as the C++ validator's, about 60 characters)."""
    try:
        text = json.dumps(value, ensure_ascii=False, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def parse_document(kind: str, source) -> tuple[dict, str, Path | None]:
    """(normalized document, source name, base directory for relative paths) of a document of ``kind``
    (experiment, bounds, scene, report or pipeline) given as a path, JSON text, or an already-loaded dict.
    A string that starts with "{" is JSON text, any other a path. An experiment may also be a results
    file (results.json), whose stored configuration is re-run with paths relative to where it ran."""
    V.choice("kind", kind, KINDS, f"one of {', '.join(KINDS)}")
    if isinstance(source, dict):
        name, base = f"<{kind}>", None
        text = _dumps(source, name)
    elif isinstance(source, Path) or (isinstance(source, str) and not source.lstrip().startswith("{")):
        path = Path(source)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ValueError(f"{path}: no such file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ValueError(f"{path}: cannot read it ({exc})") from None
        name, base = str(path), path.resolve().parent
    elif isinstance(source, str):
        text, name, base = source, f"<{kind}>", None
    else:
        V.fail(kind, source, "a path, JSON text or a dict")
    if kind == "experiment":
        try:
            raw = json.loads(text)
        except (ValueError, RecursionError):  # the C++ parser below reports the error with its position
            raw = None
        if isinstance(raw, dict) and raw.get("glintlab_result") == RESULT_FORMAT and "config" in raw:
            # A results file: re-run its stored configuration, with paths relative to where it ran.
            doc = json.loads(_core.parse_document(kind, json.dumps(raw["config"]), name + "#/config"))
            return doc, name, Path(raw["base_dir"]) if raw.get("base_dir") else base
    return json.loads(_core.parse_document(kind, text, name)), name, base


def _dumps(doc, name: str) -> str:
    """JSON text of a dict; a value JSON cannot carry (NaN, a numpy integer, a set) is an error at its
    pointer, in the validator's format."""
    try:
        return json.dumps(doc, allow_nan=False)
    except (TypeError, ValueError):
        pass

    def walk(value, pointer):
        if isinstance(value, dict):
            for key, sub in value.items():
                if not isinstance(key, str):
                    fail(name, pointer, "object keys that are strings", key)
                walk(sub, f"{pointer}/{key.replace('~', '~0').replace('/', '~1')}")
        elif isinstance(value, (list, tuple)):
            for i, sub in enumerate(value):
                walk(sub, f"{pointer}/{i}")
        elif isinstance(value, float) and not math.isfinite(value):
            fail(name, pointer, "a finite number", value)
        elif not (value is None or isinstance(value, (bool, int, float, str))):
            fail(name, pointer, "a JSON value (null, a boolean, a number, a string, an array or an object)", value)

    walk(doc, "")
    raise ValueError(f"{name}: at /: expected a JSON document, got {render(doc)}")  # unreachable in practice
