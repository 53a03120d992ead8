"""A renderer's glint pipeline gated in CI (``glintlab check PIPELINE.json``, docs/guide/ci_pipeline.md).

A pipeline file (data/schema/pipeline.schema.json) lists the stages one renderer configuration uses (a
counting law, a LOD blend, a grid scheme, a glinty NDF or method, a direction sampler), each built in by
name or the team's own shader, with its operating range and its bounds: one metric each, with a maximum
(errors) or a minimum (p-values). ``check`` measures every bound and returns one table (one row per
bound); ``record`` measures the pipeline and writes the bounds from the measured values by the margin
rule stated in the file, with the seed, glintlab's version and the machine.

The metrics are a registry (``PIPELINE_METRICS``): one entry per metric, registered by name with the
stage kinds it applies to, its direction, what it means, its false-failure rate and its cost. The
stage kinds are a registry too (``PIPELINE_STAGES``: kind -> the function that builds the stage's object
from its fields). The built-in entries are in studies/pipeline_metrics.py (they reuse the studies'
measurements); a later metric plugs in with ``register_pipeline_metric``.
"""
from __future__ import annotations

import dataclasses
import datetime
import json
import math
import os
import platform
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Callable

import pandas as pd

from .._core import __version__
from ..api import checks as V
from ..api.registry import Registry
from ..api.shaders import ShaderOutputError
from .bounds import DEFAULT_BOUNDS, check as check_bounds
from .documents import fail, parse_document

PIPELINE_METRICS = Registry("pipeline metric")
PIPELINE_STAGES = Registry("pipeline stage kind")
LIMITS = ("max", "min")


@dataclasses.dataclass(frozen=True)
class Measured:
    """A metric's worst value over the stage's range: ``where`` it is reached, how many ``points`` were
    measured, a ``note`` explaining it (shown with a violation) and ``se``, the value's standard error (0
    for exact metrics)."""
    value: float
    where: str = ""
    points: int = 1
    note: str = ""
    se: float = 0.0


@dataclasses.dataclass(frozen=True)
class PipelineMetric:
    """A registered pipeline metric: ``measure(stage) -> Measured`` for a ``Stage`` of one of ``kinds``.
    ``limit``: "max" (an error: the bound is a maximum) or "min" (a p-value: a minimum, the fixed
    ``level`` --record writes). ``meaning``, ``false_failure`` and ``cost`` are the docs' columns."""
    name: str
    kinds: tuple
    limit: str
    measure: Callable
    meaning: str
    false_failure: str
    cost: str
    level: float | None = None
    applies: Callable | None = None  # stage -> bool: whether the metric can be measured on it (its docstring says what it needs)


def register_pipeline_metric(name: str, kinds, limit: str, measure, meaning: str, false_failure: str, cost: str,
                             level: float | None = None, applies=None, replace: bool = False) -> PipelineMetric:
    """Registers a pipeline metric by name (see ``PipelineMetric``); returns it."""
    kinds = (kinds,) if isinstance(kinds, str) else tuple(kinds)
    for k in kinds:
        if k not in PIPELINE_STAGES:
            V.fail("kinds", kinds, "stage kinds, each one of " + ", ".join(PIPELINE_STAGES.names()))
    V.choice("limit", limit, LIMITS, "'max' (an error) or 'min' (a p-value)")
    if limit == "min" and level is None:
        V.fail("level", level, "the fixed minimum of a p-value metric (a number in (0, 1))")
    if not callable(measure):
        V.fail("measure", measure, "a function measure(stage) -> Measured")
    entry = PipelineMetric(name, kinds, limit, measure, meaning, false_failure, cost, level, applies)
    return PIPELINE_METRICS.register(name, entry, replace=replace)


def pipeline_metrics() -> pd.DataFrame:
    """The registered metrics: name, kinds, limit, meaning, false_failure, cost."""
    return pd.DataFrame([dict(name=m.name, kinds=", ".join(m.kinds), limit=m.limit, meaning=m.meaning,
                              false_failure=m.false_failure, cost=m.cost) for _, m in PIPELINE_METRICS.items()])


class Stage:
    """One stage of a pipeline as the metrics see it: ``spec`` (its normalized fields), ``pointer`` (its
    JSON pointer, for messages), ``base`` (the folder relative paths start from), ``seed``, and ``obj``
    (the law, blend, counter, method or sampler, built on first use or substituted)."""

    def __init__(self, spec: dict, pointer: str, source: str, base: Path | None, seed: int, obj=None):
        self.spec, self.pointer, self.source, self.base, self.seed = spec, pointer, source, base, seed
        self._obj = obj
        self._shared: dict = {}

    kind = property(lambda self: self.spec["kind"])
    id = property(lambda self: self.spec["id"])

    @property
    def obj(self):
        if self._obj is None:
            self._obj = PIPELINE_STAGES.get(self.kind)(self)
        return self._obj

    def shared(self, key: str, compute):
        """``compute()`` once per stage: what several metrics of one stage read (one sampler test, one
        sweep)."""
        if key not in self._shared:
            self._shared[key] = compute()
        return self._shared[key]

    def path(self, text: str) -> Path:
        """A path of the file, relative to the pipeline file's folder."""
        p = Path(text)
        return p if p.is_absolute() or self.base is None else self.base / p

    def fail(self, field: str, expected: str, got) -> None:
        """Bad input in this stage: ``<file>: at <stage pointer>/<field>: expected ..., got ...``."""
        fail(self.source, f"{self.pointer}/{field}" if field else self.pointer, expected, got)


def load_pipeline(source) -> tuple[dict, str, Path | None]:
    """(normalized document, source name, base directory) from a path, JSON text or a dict."""
    return parse_document("pipeline", source)


def is_pipeline(source) -> bool:
    """Whether ``source`` (a dict, JSON text or a path) is read as a pipeline rather than a bounds file:
    a JSON object without "bounds" (a bounds file's one required field), so that a pipeline missing
    "stages" is reported as such."""
    if isinstance(source, dict):
        return "bounds" not in source
    text = source if isinstance(source, str) and source.lstrip().startswith("{") else None
    if text is None:
        try:
            text = Path(source).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError, TypeError):
            return False
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError):  # the C++ parser then reports it, with the file's name
        return False
    return isinstance(doc, dict) and "bounds" not in doc


def _stages(doc: dict, source: str, base, substitute: dict) -> list[Stage]:
    ids: dict = {}
    out = []
    for i, spec in enumerate(doc["stages"]):
        at = f"/stages/{i}"
        if spec["id"] in ids:
            fail(source, at + "/id", f"an id not used before (as /stages/{ids[spec['id']]}/id)", spec["id"])
        ids[spec["id"]] = i
        seen: dict = {}
        for j, b in enumerate(spec["bounds"]):
            _check_bound(b, spec, f"{at}/bounds/{j}", source, seen)
        out.append(Stage(spec, at, source, base, doc["seed"], substitute.get(spec["id"])))
    for key in substitute:
        if key not in ids:
            V.fail("substitute", key, "stage ids of the pipeline (" + ", ".join(ids) + ")")
    return out


def _check_bound(b: dict, spec: dict, at: str, source: str, seen: dict) -> None:
    name = b["metric"]
    if name not in PIPELINE_METRICS:
        fail(source, at + "/metric", "a pipeline metric (" + ", ".join(PIPELINE_METRICS.names()) + ")", name)
    m = PIPELINE_METRICS.get(name)
    if spec["kind"] not in m.kinds:
        fail(source, at + "/metric", f"a metric of a {spec['kind']} stage ({', '.join(_names_for(spec['kind']))})", name)
    if name in seen:
        fail(source, at + "/metric", f"a metric not bounded before in this stage (as {seen[name]})", name)
    seen[name] = at
    other = "minimum" if m.limit == "max" else "maximum"
    if other in b:
        fail(source, f"{at}/{other}", f"no \"{other}\" for the metric {name} (it takes a "
                                      f"\"{'maximum' if m.limit == 'max' else 'minimum'}\")", b[other])


def _names_for(kind: str) -> list[str]:
    return [n for n, m in PIPELINE_METRICS.items() if kind in m.kinds]


def _check_applies(stages: list[Stage]) -> None:
    """Every stage's object builds and every bound's metric can be measured on its stage: bad input
    (exit 2) is reported before anything is measured."""
    for stage in stages:
        stage.obj  # noqa: B018  (builds it: a bad law, blend, method, sampler or shader fails here)
        for j, b in enumerate(stage.spec["bounds"]):
            metric = PIPELINE_METRICS.get(b["metric"])
            if metric.applies is not None and not metric.applies(stage):
                stage.fail(f"bounds/{j}/metric", f"a metric that applies to this stage ({metric.name} needs "
                                                 f"{metric.applies.__doc__})", metric.name)


def check_pipeline(pipeline, substitute: dict | None = None, progress=None) -> pd.DataFrame:
    """Measures every bound of a pipeline (a path, JSON text or a dict); one row per bound: id (stage
    id/metric), stage, kind, metric, limit, bound, worst, where, points, ok, measured, seconds, note.

    ``substitute`` maps a stage id to an object used in its place (a law, a blend, a sampler, ...): how the
    tests show that a deliberately wrong stage fails its bounds. ``progress``: print one line per bound
    to stderr when True."""
    doc, source, base = load_pipeline(pipeline)
    stages = _stages(doc, source, base, substitute or {})
    _check_applies(stages)
    rows = []
    for stage in stages:
        for b in stage.spec["bounds"]:
            metric = PIPELINE_METRICS.get(b["metric"])
            t0 = time.perf_counter()
            got = _measure(stage, metric)
            limit = "maximum" if metric.limit == "max" else "minimum"
            bound = b.get(limit, math.nan)
            ok = _within(got.value, bound, metric.limit)
            note = got.note if ok or not math.isnan(bound) else "no bound yet: record it (glintlab check --record)"
            rows.append(dict(id=f"{stage.id}/{metric.name}", stage=stage.id, kind=stage.kind, metric=metric.name,
                             limit=metric.limit, bound=bound, worst=got.value, se=got.se, where=got.where, points=got.points,
                             ok=ok, measured=b.get("measured"), seconds=round(time.perf_counter() - t0, 3), note=note))
            if progress:
                print(f"glintlab check: {rows[-1]['id']} = {got.value:.6g} ({rows[-1]['seconds']:.1f} s)",
                      file=sys.stderr)
    out = pd.DataFrame(rows)
    out.attrs.update(source=source, name=doc["name"], seed=doc["seed"])
    return out


def check(source=DEFAULT_BOUNDS, substitute: dict | None = None, progress=None) -> pd.DataFrame:
    """``gl.check``: the table of a pipeline (``check_pipeline``) or of a bounds file (``bounds.check``),
    by what ``source`` is (a path, JSON text or a dict; a pipeline has "stages"). Default: the package's
    bounds file. ``substitute`` maps a stage id (pipelines) or a law label (bounds) to an object used in
    its place."""
    if is_pipeline(source):
        return check_pipeline(source, substitute=substitute, progress=progress)
    return check_bounds(source, substitute=substitute, progress=progress)


def _measure(stage: Stage, metric: PipelineMetric) -> Measured:
    """The metric on the stage; a shader's NaN, inf or negative output (``ShaderOutputError``, also as
    the cause of a sweep's error) is a failed bound (NaN, with the message), not bad input."""
    try:
        return metric.measure(stage)
    except ValueError as exc:
        if isinstance(exc, ShaderOutputError) or isinstance(exc.__cause__, ShaderOutputError):
            return Measured(math.nan, note=str(exc))
        raise


def _within(value: float, bound: float, limit: str) -> bool:
    # NaN (a metric that could not be measured, or a bound not recorded yet) is never within a bound.
    if math.isnan(value) or math.isnan(bound):
        return False
    return value <= bound if limit == "max" else value >= bound


def recorded_bound(metric: PipelineMetric, measured: float, margin: dict, se: float = 0.0) -> float:
    """The bound --record writes: for an error, (measured + noise x se) x (1 + relative) + absolute,
    rounded up to ``digits`` significant digits; for a p-value, the metric's fixed level."""
    if metric.limit == "min":
        return float(metric.level)
    if not math.isfinite(measured):
        V.fail("measured", measured, f"a finite value of {metric.name} to record a bound from")
    x = (measured + margin["noise"] * (se if math.isfinite(se) else 0.0)) * (1.0 + margin["relative"]) \
        + margin["absolute"]
    if x <= 0:
        return 0.0
    scale = 10.0 ** (math.floor(math.log10(x)) - margin["digits"] + 1)
    return float(f"{math.ceil(x / scale - 1e-9) * scale:.{margin['digits'] + 1}g}")


def machine() -> str:
    """The machine a pipeline was recorded on: CPU model, cores, OS."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def record(pipeline, out=None, substitute: dict | None = None, progress=None) -> tuple[dict, pd.DataFrame, pd.DataFrame]:
    """Measures the pipeline and writes its bounds: (the recorded document, the table measured, the
    diff against the bounds the file had, with ``holds``: whether the measured value is within its new
    bound). Each bound gets ``measured`` and its limit by the file's margin rule; ``recorded`` says the
    seed, glintlab's version, the machine and the date. ``out``: a path to write the document to
    (default: the pipeline's own file when it was given as a path). A metric that could not be measured
    (NaN: a shader returning NaN, an inconclusive test) has no bound to record: then nothing is written."""
    doc, source, base = load_pipeline(pipeline)
    table = check_pipeline(doc if base is None else pipeline, substitute=substitute, progress=progress)
    by_id = {r.id: r for r in table.itertuples()}
    diff = []
    for stage in doc["stages"]:
        for b in stage["bounds"]:
            metric = PIPELINE_METRICS.get(b["metric"])
            r = by_id[f"{stage['id']}/{metric.name}"]
            limit = "maximum" if metric.limit == "max" else "minimum"
            new = recorded_bound(metric, r.worst, doc["margin"], r.se) if math.isfinite(r.worst) else math.nan
            diff.append(dict(id=r.id, old_measured=b.get("measured"), measured=r.worst, old_bound=b.get(limit),
                             bound=new, holds=_within(r.worst, new, metric.limit), note=r.note))
            b["measured"], b[limit] = float(r.worst), new
    doc["recorded"] = dict(glintlab_version=__version__, machine=machine(), seed=doc["seed"],
                           date=datetime.date.today().isoformat())
    target = out if out is not None else (source if base is not None else None)
    if target is not None and all(math.isfinite(d["measured"]) for d in diff):
        Path(target).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return doc, table, pd.DataFrame(diff)


def format_diff(diff: pd.DataFrame) -> str:
    """The lines of a re-recording that changed a bound or a measured value."""
    lines = []
    for r in diff.itertuples():
        if r.old_bound is None or (isinstance(r.old_bound, float) and math.isnan(r.old_bound)):
            lines.append(f"  {r.id}: new bound {r.bound:.6g} (measured {r.measured:.6g})")
        elif r.old_bound != r.bound or r.old_measured != r.measured:
            lines.append(f"  {r.id}: bound {r.old_bound:.6g} -> {r.bound:.6g}, measured "
                         f"{_g(r.old_measured)} -> {r.measured:.6g}")
    return "\n".join(lines) if lines else "  no bound changed"


def _g(x) -> str:
    return "none" if x is None else f"{x:.6g}"


def format_table(table: pd.DataFrame) -> str:
    t = table[["id", "metric", "limit", "bound", "worst", "where", "points", "ok"]].copy()
    t["ok"] = t.ok.map({True: "ok", False: "VIOLATED"})
    text = t.to_string(index=False, float_format=lambda x: f"{x:.4g}")
    notes = [f"{r.id}: {r.note}" for r in table.itertuples() if r.note and not r.ok]
    return text + "".join("\n  " + line for line in notes)


def violation_line(r) -> str:
    """One line for stderr about a violated bound."""
    rel = "<=" if r.limit == "max" else ">="
    at = f" at {r.where}" if r.where else ""
    return f"{r.metric} = {r.worst:.6g}{at} (bound {rel} {r.bound:.6g})" + (f"; {r.note}" if r.note else "")


def write_junit(table: pd.DataFrame, path, name: str | None = None) -> Path:
    """JUnit XML: one testcase per bound (classname glintlab.pipeline.<name>.<stage>), a <failure> for
    each violated one."""
    name = name or f"glintlab.pipeline.{table.attrs.get('name', 'pipeline')}"
    suite = ET.Element("testsuite", name=name, tests=str(len(table)), failures=str(int((~table.ok).sum())),
                       time=f"{table.seconds.sum():.3f}")
    for r in table.itertuples():
        case = ET.SubElement(suite, "testcase", classname=f"{name}.{r.stage}", name=r.id, time=f"{r.seconds:.3f}")
        if not r.ok:
            f = ET.SubElement(case, "failure", message=violation_line(r))
            f.text = f"stage {r.stage} ({r.kind}), metric {r.metric}, worst {r.worst!r} over {r.points} points"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)
    return path
