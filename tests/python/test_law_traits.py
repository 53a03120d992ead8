"""Lists of laws come from the registry: every built-in law declares its traits with its code, the
variants the studies, benchmarks and tests use are derived from them, and the shipped default bounds
are exactly the bounds the laws declare (a new law fails here until scripts/make_bounds.py has
measured its bounds)."""
import importlib.util
import json
import re
from pathlib import Path

import numpy as np
import pytest

import glintlab as gl
from glintlab.validation.bounds import DEFAULT_BOUNDS

ROOT = Path(__file__).resolve().parents[2]


def make_bounds_module():
    spec = importlib.util.spec_from_file_location("make_bounds", ROOT / "scripts" / "make_bounds.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", gl.laws())
def test_every_built_in_law_declares_its_traits(name):
    t = gl.law_traits(name)
    assert t["declared"] and t["regime"] and t["cost"], name
    assert t["output"] in ("integer", "real") and t["support"] in ("bounded_by_n", "n_plus_one", "unbounded")
    assert t["test_variants"], f"{name}: the generic tests need at least one variant"
    for params in t["study_variants"] + t["bench_variants"] + t["test_variants"]:
        gl.law(name, **params)  # every declared variant builds
    law = gl.law(name)
    w = law.work_units(np.array([0.5, 16.0, 1e3]), np.array([0.5, 0.05, 0.3]))
    assert np.all(w >= 0) and (not t["constant_time"] or np.all(w == 0)), (name, w)


def test_variants_are_derived_from_the_registry():
    study = gl.law_variants("study")
    assert ("gaussian", {"rounding": "floor"}) in study and ("gaussian", {"rounding": "round"}) in study
    assert {name for name, _ in study} <= set(gl.laws())
    assert all(not gl.law_traits(n)["reference"] for n, _ in gl.law_variants("test", reference=False))
    with pytest.raises(ValueError, match="use = 'nope'"):
        gl.law_variants("nope")


def test_zk16_cost_model_is_its_loop():
    # Below its switch (n p <= 5) zk16 runs min(ceil n, cap) Bernoulli trials, above it none.
    w = gl.law("zk16").work_units([1.0, 10.5, 40.0, 1e3], [0.05, 0.05, 0.1, 0.5])
    assert list(w) == [1.0, 11.0, 16.0, 0.0]
    assert list(gl.law("zk16", cap=4).work_units([10.5], [0.05])) == [4.0]


def test_default_bounds_are_the_declared_bounds():
    mb = make_bounds_module()
    declared = [f"{mb.label(law)}/{m}/{mb.regime_label(regime)}"
                for law, regime, metrics, _ in mb.exact_bounds() for m in metrics]
    declared += [f"{law}/sampler/chi2" for law in mb.sampled_laws()]
    shipped = [b["id"] for b in json.loads(Path(DEFAULT_BOUNDS).read_text())["bounds"]]
    assert sorted(declared) == sorted(shipped), (
        "the shipped bounds differ from those the laws declare; run scripts/make_bounds.py: "
        f"missing {sorted(set(declared) - set(shipped))}, stale {sorted(set(shipped) - set(declared))}")


LAW_FILES = sorted((ROOT / "core" / "laws").glob("*.cpp"))


@pytest.mark.parametrize("path", LAW_FILES, ids=lambda p: p.name)
def test_a_law_file_is_written_the_one_way(path):
    # One base (detail::KernelLaw, docs/architecture.md#registries-adding-a-law-a-blend-a-grid-scheme-or-a-study) and
    # public headers only: a law file includes nothing from core/src.
    text = path.read_text()
    includes = re.findall(r'^#include\s+"([^"]+)"', text, flags=re.M)
    assert all(i.startswith("glintlab/") for i in includes), f"{path.name} includes {includes}"
    laws = re.findall(r"class\s+(\w+Law)\s+final\s*:\s*(.*?)\s*\{", text)
    assert laws and all(base == f"public detail::KernelLaw<{cls}>" for cls, base in laws), f"{path.name}: {laws}"


def test_the_threads_header_is_not_the_law_header():
    # parallel.hpp (the drivers' thread split) needs the threads knob, not the law interface: the image,
    # blend, sampler and NDF drivers that include it do not depend on law.hpp through it.
    text = (ROOT / "core" / "src" / "base" / "parallel.hpp").read_text()
    assert '#include "glintlab/base/threads.hpp"' in text and "law.hpp" not in text
    assert "int num_threads();" in (ROOT / "core" / "include" / "glintlab" / "base" / "threads.hpp").read_text()
    assert "int num_threads();" not in (ROOT / "core" / "include" / "glintlab" / "counting" / "law.hpp").read_text()
