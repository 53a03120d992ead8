"""The files-to-touch table of docs/architecture.md is true.

The table names, for each kind of extension, the files one adds or edits. This test reads the table and
checks it against the tree and the running package (what it proves and what it does not is stated under
the table): every named file or folder exists; for the C++ kinds, the registry is the single list (the
names the module reports are exactly those registered by the files of the row's folder, and CMake globs
that folder); for the Python kinds, a dummy added from one new file in a fresh interpreter is listed and
usable with no other edit; the shipped shaders are exactly those the laws' traits declare, each with its
files.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "architecture.md"
KINDS = ("law", "blend", "grid scheme", "glinty NDF / image method", "report section", "sampler",
         "shipped shader law", "shipped method shader", "shipped shader sampler")


def _table() -> dict[str, dict[str, str]]:
    text = DOC.read_text()
    start = text.index("## Files to touch")
    section = text[start:text.index("\n## ", start + 1)]
    rows = [line for line in section.splitlines() if line.startswith("| ")]
    header = [c.strip() for c in rows[0].strip("|").split("|")]
    table = {}
    for line in rows[1:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        table[cells[0]] = dict(zip(header[1:], cells[1:]))
    return table


def _paths(cell: str) -> list[str]:
    """The file paths a cell names (backticked tokens with a file extension or a '/'); a bare file name
    after a path lives in that path's folder (`a/b/<x>_body.h`, `<x>.hlsl` -> a/b/<x>.hlsl)."""
    out, folder = [], ""
    for token in re.findall(r"`([^`]+)`", cell):
        if token.startswith(("gl.", "register", "GLINTY", "SAMPLERS", "LawTraits", "discover", "report.")):
            continue
        if "/" in token:
            folder = token.rsplit("/", 1)[0]
            out.append(token)
        elif re.search(r"\.(py|cpp|h|hlsl|glsl|md|json)$", token) and folder:
            out.append(f"{folder}/{token}")
    return out


def test_the_table_has_every_kind():
    assert tuple(_table()) == KINDS


@pytest.mark.parametrize("kind", KINDS)
def test_every_named_file_exists(kind):
    # A path with a <placeholder> must match at least one existing file: the pattern is the real layout.
    paths = _paths(_table()[kind]["files to touch"])
    assert paths, kind
    for path in paths:
        if "<" in path:
            pattern = re.sub(r"<[^>]+>", "*", path)
            assert list(ROOT.glob(pattern)), f"{kind}: no file matches {path}"
        else:
            assert (ROOT / path).exists(), f"{kind}: {path} does not exist"


# The C++ kinds: the registering call each file of the folder makes, and the module's listing.
_CPP = {
    "law": ("core/laws", "law", "laws"),
    "blend": ("core/blends", "blend", "blends"),
    "grid scheme": ("core/grids", "grid_scheme", "grid_schemes"),
}


@pytest.fixture(scope="module")
def listed() -> dict:
    # A fresh interpreter: this process may hold plugin or custom laws other tests registered.
    code = ("import json, glintlab as gl; print(json.dumps({'laws': gl.laws(), 'blends': gl.blends(), "
            "'grid_schemes': gl.grid_schemes(), 'shipped': gl.shipped_shaders(), "
            "'traits_shaders': {n: gl.law_traits(n).get('shader', '') for n in gl.laws()}}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    return json.loads(out.stdout)


@pytest.mark.parametrize("kind", sorted(_CPP))
def test_cpp_registry_is_the_single_list(kind, listed):
    folder, what, listing = _CPP[kind]
    row = _table()[kind]
    assert f"`{folder}/<name>.cpp`" in row["files to touch"]
    assert f"register_{what}" in row["registered by"]
    call = re.compile(r"register_(?:parameterless_)?" + what + r"(?:<\w+>)?\(\s*\{?\s*\"([\w.-]+)\"")
    registered = []
    for source in sorted((ROOT / folder).glob("*.cpp")):
        names = call.findall(source.read_text())
        assert names, f"{source.relative_to(ROOT)} registers no {kind}"
        registered += names
    # Every listed entry comes from a file of the folder, and nowhere else registers one.
    assert sorted(registered) == sorted(listed[listing])
    elsewhere = [p for p in (ROOT / "core").rglob("*.cpp")
                 if not p.is_relative_to(ROOT / folder) and call.search(p.read_text())]
    assert not elsewhere, f"{kind}s registered outside {folder}: {elsewhere}"
    # A new file of the folder is compiled without a CMake edit.
    assert f"{folder}/*.cpp" in (ROOT / "CMakeLists.txt").read_text()


def test_shipped_shaders_are_declared_by_traits(listed):
    row = _table()["shipped shader law"]
    assert "`shader`" in row["files to touch"] and "`LawTraits::shader`" in row["registered by"]
    declared = {s: law for law, s in listed["traits_shaders"].items() if s}
    assert declared and listed["shipped"] == declared
    shaders = ROOT / "python" / "glintlab" / "data" / "shaders"
    for stem in declared:
        for suffix in ("_body.h", ".hlsl", ".glsl"):
            assert (shaders / f"{stem}{suffix}").exists(), f"{stem}{suffix}"


def test_shipped_method_shaders_and_samplers_are_declared_where_the_table_says(listed):
    from glintlab.api.method_shaders import shipped_method_shaders
    from glintlab.api.shader_samplers import SHIPPED_SAMPLERS
    row = _table()["shipped method shader"]
    assert "`register_image_method`" in row["registered by"]
    for module in ("method_shaders", "counting_shaders"):
        assert f"`python/glintlab/api/{module}.py`" in row["files to touch"], module
    shaders = ROOT / "python" / "glintlab" / "data" / "shaders"
    # Every shipped .glsl/.hlsl file is a law's wrapper (declared by the traits), a shipped sampler
    # (SHIPPED_SAMPLERS) or a method shader one of the two modules declares; each has its one body.
    files = {p.name for p in [*shaders.glob("*.glsl"), *shaders.glob("*.hlsl")]}
    laws = {f for f in files if f.rsplit(".", 1)[0] in listed["shipped"]}
    samplers = {f for f in files if f.rsplit(".", 1)[0] in SHIPPED_SAMPLERS}
    methods = {f"{e.files}.{lang}" for e in shipped_method_shaders().values() for lang in ("glsl", "hlsl")}
    assert files - laws - samplers == methods
    for name in files:
        assert (shaders / (name.rsplit(".", 1)[0] + "_body.h")).exists(), name
    for module in ("method_shaders", "counting_shaders"):
        assert "register_image_method(" in (ROOT / "python" / "glintlab" / "api" / f"{module}.py").read_text()
    assert "`SHIPPED_SAMPLERS`" in _table()["shipped shader sampler"]["registered by"]


# The Python kinds, added from one new file each, in a fresh interpreter; nothing in the tree is edited.
_DUMMIES = {
    "dummy_glinty_ndf.py": '''
        import numpy as np
        from glintlab.api.glinty_ndf import GLINTY_NDFS, GlintyNDF, register_image_method

        class DummyNDF(GlintyNDF):
            name = "dummy_ndf"
            def evaluate(self, uv, J, h, seed=0):
                return self.smooth(h)

        GLINTY_NDFS.register("dummy_ndf", DummyNDF)
        register_image_method("dummy_ndf", lambda m: DummyNDF(m.target, m.alpha, m.density), label="dummy")
    ''',
    "dummy_sampler.py": '''
        import numpy as np
        from glintlab.api.samplers import SAMPLERS, BeckmannNormals

        class DummySampler(BeckmannNormals):
            name = "dummy_sampler"
            summary = "a test's copy of the Beckmann normal sampler"

        SAMPLERS.register(DummySampler.name, DummySampler)
    ''',
    "studies/dummy_section.py": '''
        NAME = "dummy_section"
        TITLE = "A dummy section"
        DEFAULTS = {"size": 3}

        def compute(params, ctx):
            return {}

        def figures(tables, ctx):
            return []
    ''',
}

_CHECK = '''
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
import glintlab as gl
import glintlab.studies
glintlab.studies.__path__.append(sys.argv[1] + "/studies")
import dummy_glinty_ndf, dummy_sampler
from glintlab.report import sections

assert "dummy_ndf" in gl.glinty_ndfs() and "dummy_ndf" in gl.image_methods("ndf")
img = gl.render("dummy_ndf", "sphere", scale=0.1)
assert img.ndim == 2 and np.nanmax(img) > 0
assert "dummy_sampler" in gl.samplers()
s = gl.sampler("dummy_sampler", alpha=0.3)
x, pdf = s.sample(100, seed=1)
assert x.shape == (100, 3) and np.all(pdf > 0) and np.array_equal(pdf, s.pdf(x))
assert gl.wrong_sampler(s, "alpha+2%").sample(10, seed=1)[0].shape == (10, 3)
found = sections.discover()
assert "dummy_section" in found.names() and found.get("dummy_section").defaults == {"size": 3}
print("ok")
'''


def test_python_kinds_need_only_their_file(tmp_path):
    table = _table()
    assert "`GLINTY_NDFS.register`" in table["glinty NDF / image method"]["registered by"]
    assert "`SAMPLERS.register`" in table["sampler"]["registered by"]
    assert "`python/glintlab/studies/<name>.py`" in table["report section"]["files to touch"]
    (tmp_path / "studies").mkdir()
    for name, body in _DUMMIES.items():
        (tmp_path / name).write_text(textwrap.dedent(body))
    out = subprocess.run([sys.executable, "-c", _CHECK, str(tmp_path)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-3000:]
