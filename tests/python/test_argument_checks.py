"""One argument vocabulary: bad input is refused through ``glintlab/api/checks.py`` (``fail``, ``integer``,
``choice``, ``positive``, ``scalar_or_shape``), as the layout test greps imports. The test greps the package for the
hand-written bool/int idiom, for hand-written "NAME = VALUE is invalid" raises, and for direct
``raise ValueError(`` outside checks.py beyond a per-file allowance, each with its reason: a new direct
raise fails here until it goes through the helpers or its file's allowance and reason are updated."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import glintlab
from glintlab.api import checks as V

PACKAGE = Path(glintlab.__file__).resolve().parent
CHECKS = PACKAGE / "api" / "checks.py"

# file (relative to the package) -> (direct raises allowed, why they are not a checks.py helper)
ALLOWED = {
    "validation/engines.py": (6, "Dask environment errors (a LocalCluster started from stdin or outside a main "
                                 "guard, a scheduler that does not answer): not a NAME = VALUE check"),
    "api/laws.py": (6, "what a custom law's function returned (shape, finiteness, its own exception re-raised "
                       "with the law's name) and numpy broadcasting messages"),
    "cli/main.py": (5, "output paths that cannot be written: the message says which ancestor is the problem"),
    "validation/documents.py": (4, "document errors located by JSON pointer (FILE: at /pointer: expected ...)"),
    "cli/common.py": (4, "--laws LAW-SPEC syntax: the whole spec is quoted, then the part that is wrong"),
    "validation/references.py": (3, "a law reference that cannot be resolved (plugin, import, footprint area)"),
    "validation/extremes.py": (3, "what a custom law returned, and a law of unknown kind in a list"),
    "validation/experiment.py": (3, "errors of the experiment re-raised located in its document (/laws/i)"),
    "studies/lod.py": (3, "array shapes and strips that do not fit the unit domain"),
    "api/registry.py": (2, "the registry's own duplicate and unknown-name messages (every registry's format)"),
    "validation/sweep.py": (2, "a law without an exact pmf asked for an exact sweep"),
    "validation/store.py": (2, "a store of another format or another sweep"),
    "validation/bounds.py": (2, "bounds-file errors located by JSON pointer"),
    "api/shaders.py": (2, "a shader source that is not UTF-8 (byte and line), what a shader returned"),
    "api/glinty_ndf.py": (2, "core errors re-raised with the NDF's name and the element's index"),
    "validation/shader_check.py": (1, "a twin reading another number of uniforms than the shader"),
    "validation/rows.py": (1, "a law's error re-raised with the (law, n, p) row it happened at"),
    "validation/profile.py": (1, "a scene whose camera sees no pixel of the primitive"),
    "report/sections.py": (2, "a study module whose QUICK sets parameters it does not define, or that is "
                              "neither a study nor a helper"),
    "report/config.py": (1, "configuration errors located in the document"),
    "cli/advise.py": (1, "no budget flag at all (no single NAME = VALUE to name)"),
    "api/blends.py": (1, "numpy broadcasting message"),
    "api/samplers.py": (2, "a sampler's construction error re-raised with its name (by name; a wrong variant rebuilt)"),
}


def sources():
    return [(p.relative_to(PACKAGE).as_posix(), p.read_text(encoding="utf-8"))
            for p in sorted(PACKAGE.rglob("*.py")) if p != CHECKS]


def test_no_hand_written_bool_int_check():
    idiom = re.compile(r"isinstance\([^()]*,\s*bool\)\s+or\s+not\s+isinstance\(")
    bad = [f"{name}:{text[:m.start()].count(chr(10)) + 1}" for name, text in sources() for m in idiom.finditer(text)]
    assert not bad, "use checks.integer / checks.positive instead of the bool/int idiom:\n" + "\n".join(bad)


def test_no_hand_written_invalid_message():
    # checks.fail's format, written by hand: it must be checks.fail (or integer/choice/positive).
    pattern = re.compile(r'raise ValueError\(f?"[^"\n]*= \{[^}\n]*\}[^"\n]*is invalid; expected')
    bad = [f"{name}:{text[:m.start()].count(chr(10)) + 1}" for name, text in sources() for m in pattern.finditer(text)]
    assert not bad, "use checks.fail(name, value, expected):\n" + "\n".join(bad)


def test_direct_raises_stay_within_their_allowance():
    counts = {name: text.count("raise ValueError(") for name, text in sources()}
    over = [f"{name}: {n} direct raise ValueError(...), {ALLOWED.get(name, (0,))[0]} allowed"
            for name, n in counts.items() if n > ALLOWED.get(name, (0,))[0]]
    assert not over, ("raise through glintlab/api/checks.py (fail, integer, choice, positive, scalar_or_shape), or add "
                      "the file to ALLOWED with the reason:\n" + "\n".join(over))
    stale = [name for name, (n, _) in ALLOWED.items() if counts.get(name, 0) < n]
    assert not stale, f"allowances larger than needed (lower them): {stale}"


def test_the_helpers_name_parameter_and_value():
    assert V.integer("k", np.int64(4), 1, 16) == 4
    for bad in (True, np.True_, 2.0, "3", 0, 17):
        with pytest.raises(ValueError, match=r"^k = .* is invalid; expected an integer in \[1, 16\]$"):
            V.integer("k", bad, 1, 16)
    with pytest.raises(ValueError, match=r"^engine = 'mpi' is invalid; expected one of 'threads', 'dask'$"):
        V.choice("engine", "mpi", ("threads", "dask"))
    with pytest.raises(ValueError, match="expected one of 1, 4"):
        V.choice("k", True, (1, 4))  # True == 1, but a bool is not an option
    with pytest.raises(ValueError, match="engine = array"):
        V.choice("engine", np.array(["dask", "x"]), ("threads", "dask"))
    with pytest.raises(ValueError, match=r"^timeout = nan is invalid; expected a finite number > 0$"):
        V.positive("timeout", float("nan"))
    with pytest.raises(ValueError,
                       match=r"^p = 'an array of shape \(3,\)' is invalid; expected a scalar or an array of shape \(4,\)$"):
        V.scalar_or_shape("p", np.zeros(3), (4,))
    V.scalar_or_shape("p", np.zeros(1), (4,))
    V.scalar_or_shape("p", np.zeros(4), (4,))
