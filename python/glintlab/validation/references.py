"""References: what a law is compared with, and how a law is named in an experiment.

A reference is another law (by default the exact binomial) or the ground truth of a facet layout;
``resolve_law`` turns an experiment's law object (a name, ``{name, params}``, ``{name, plugin}`` or
``{name, python, n_uniforms}``) into a law.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import math
from pathlib import Path

from .._core import Distribution
from ..api import checks as v
from ..api.laws import Law, custom_law, law as get_law
from ..api.plugins import load_plugin
from ..api.shaders import shader_law
from ..api.spatial import LAYOUTS, footprint_for_area, ground_truth


class LawReference:
    """Another law (by default the exact binomial) as the reference."""

    def __init__(self, law_: Law):
        self.law = law_
        self.spec = law_.label

    @property
    def has_pmf(self) -> bool:
        return self.law.has_pmf

    def pmf(self, n, p) -> Distribution:
        return self.law.pmf(n, p)

    def sample(self, n, p, size, seed):
        return self.law.bin(self.law.sample(n, p, size=size, seed=seed))


class GroundTruthReference:
    """The ground truth of a facet layout (``gl.ground_truth``): at grid point (n, p), the count in a
    footprint of area n / density (a rectangle or ellipse of the given aspect and angle) placed at a
    uniformly random position."""

    def __init__(self, layout="stratified", density=None, footprint="rect", aspect=1.0, angle=0.0):
        v.choice("layout", layout, LAYOUTS, "one of " + ", ".join(LAYOUTS))
        self.layout, self.density = layout, v.real("density", density)
        if not (self.density >= 1 and math.isfinite(self.density)):
            v.fail("density", density, "a number >= 1")
        v.choice("footprint", footprint, ("rect", "ellipse"), "'rect' or 'ellipse'")
        self.footprint, self.aspect, self.angle = footprint, v.real("aspect", aspect), v.real("angle", angle)
        if not self.aspect >= 1:
            v.fail("aspect", aspect, "a number >= 1")
        self.spec = {"ground_truth": dict(layout=layout, density=self.density, footprint=footprint,
                                          aspect=self.aspect, angle=self.angle)}

    has_pmf = True

    def _truth(self, n, p):
        area = n / self.density
        if not 0 < area <= 1:
            raise ValueError(f"ground truth reference: n = {n!r} gives a footprint of area n / density = {area!r}; "
                             f"expected an area in (0, 1] (n in (0, {self.density:g}])")
        fp = footprint_for_area(area, aspect=self.aspect, angle=self.angle, shape=self.footprint)
        density = int(self.density) if self.layout != "poisson" else self.density
        return ground_truth(self.layout, density=density, footprint=fp, p=p)

    def pmf(self, n, p) -> Distribution:
        return self._truth(n, p).pmf()

    def sample(self, n, p, size, seed):
        return self._truth(n, p).sample(size=size, seed=seed)


def make_reference(spec):
    """A reference from a law name, a Law, {"law": spec}, {"ground_truth": {...}} or a reference object."""
    if isinstance(spec, (LawReference, GroundTruthReference)):
        return spec
    if isinstance(spec, Law):
        return LawReference(spec)
    if isinstance(spec, dict) and "ground_truth" in spec:
        return GroundTruthReference(**spec["ground_truth"])
    if isinstance(spec, dict) and "law" in spec:
        return LawReference(resolve_law(spec["law"]))
    if isinstance(spec, str):
        return LawReference(resolve_law(spec))
    v.fail("reference", spec, "a law name, a Law, {'law': ...} or {'ground_truth': {...}}")


def resolve_law(spec, base_dir: Path | None = None) -> Law:
    """A law from a name, a Law, or an experiment's law object ({name, params}, {name, plugin},
    {name, python, n_uniforms} or {shader, entry, language, n_uniforms, name, defines, binning,
    device}); plugin, python and shader file paths are relative to ``base_dir``."""
    if isinstance(spec, Law):
        return spec
    if isinstance(spec, str):
        return get_law(spec)
    if isinstance(spec, dict) and "shader" in spec:
        path = Path(spec["shader"])
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        return shader_law(path, entry=spec.get("entry", "count"), language=spec.get("language"),
                          n_uniforms=int(spec.get("n_uniforms", 2)), name=spec.get("name"),
                          defines=spec.get("defines"), binning=spec.get("binning", "round"),
                          device=spec.get("device", "auto"))
    if not isinstance(spec, dict) or "name" not in spec:
        v.fail("law", spec, "a law name, a Law or an object with a name")
    name = spec["name"]
    if "plugin" in spec:
        path = Path(spec["plugin"])
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        names = load_plugin(str(path))
        if name not in names:
            raise ValueError(f"plugin {str(path)!r} has no law named {name!r}; it has {names}")
        return get_law(name)
    if "python" in spec:
        fn = _import_function(spec["python"], base_dir)
        return custom_law(fn, n_uniforms=int(spec.get("n_uniforms", 2)), name=name,
                          binning=spec.get("binning", "none"))
    return get_law(name, **spec.get("params", {}))


def _import_function(target: str, base_dir: Path | None):
    """'package.module:function' or 'path/to/file.py:function'."""
    where, sep, attr = target.rpartition(":")
    if not sep or not where or not attr:
        v.fail("python", target, "'module:function' or 'file.py:function'")
    if where.endswith(".py"):
        path = Path(where)
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        if not path.is_file():
            v.fail("python", target, f"an existing Python file ({path} does not exist)")
        module_name = "glintlab_user_" + hashlib.sha1(str(path.resolve()).encode()).hexdigest()[:12]
        spec = importlib.util.spec_from_file_location(module_name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(where)
        except ImportError as exc:
            raise ValueError(f"python = {target!r} is invalid: cannot import {where!r} ({exc})") from None
    fn = getattr(module, attr, None)
    if not callable(fn):
        v.fail("python", target, f"a callable named {attr!r} in {where!r}")
    return fn
