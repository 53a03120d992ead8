"""The files-to-touch table of docs/architecture.md is true.

The table names, for each kind of extension, the files one adds or edits. This test reads the table and
checks it against the tree and the running package (what it proves and what it does not is stated under
the table): every named file or folder exists; for the C++ kinds, the registry is the single list (the
names the module reports are exactly those registered by the files of the row's folder, CMake globs that
folder, and a vector path's per-ISA files have their flags); for the Python kinds, a new method shader
with its twin, a new glinty NDF and a new report section, added inside a copy of the package exactly as
the table says, are rendered, tested and documented by the project's own generic tests run in that copy,
with no other edit; the shipped shaders are exactly those the laws' traits and the registry declare.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import glintlab as gl

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "architecture.md"
KINDS = ("law", "law with a vector path", "blend", "grid scheme", "glinty NDF / image method",
         "method shader with its twin", "sampler", "shader law", "shader sampler", "report section", "pipeline metric")


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
    """The file paths a cell names: backticked tokens with a '/' (from the repository's root), and bare
    file names, which live in the folder of the path before them (`a/b/<x>_body.h`, `<x>.hlsl` ->
    a/b/<x>.hlsl) unless they are files of the root (`README.md`, `CMakeLists.txt`)."""
    out, folder = [], ""
    for token in re.findall(r"`([^`]+)`", cell):
        if not re.search(r"\.(py|cpp|hpp|inc|h|hlsl|glsl|md|json|txt)$", token) or " " in token:
            continue
        if "/" in token:
            folder = token.rsplit("/", 1)[0]
            out.append(token)
        elif folder and not ("<" not in token and (ROOT / token).is_file()):
            out.append(f"{folder}/{token}")
        else:
            out.append(token)
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


def test_a_vector_path_is_the_files_the_table_names():
    """Every per-ISA file of the core has its ISA's flags in CMakeLists.txt (the row's one CMake step),
    and every per-pixel body is included by an AVX2 and an AVX-512 file, its block functions declared in
    detail/pixel_blocks.hpp, where a law's evaluate_pixels finds them."""
    row = _table()["law with a vector path"]["files to touch"]
    for named in ("`CMakeLists.txt`", "`core/src/simd/simd_math.hpp`", "`core/include/glintlab/detail/pixel_blocks.hpp`"):
        assert named in row, named
    cmake = (ROOT / "CMakeLists.txt").read_text()
    flags = {"avx2": "-mavx2", "avx512": "-mavx512f"}
    per_isa = [p for p in (ROOT / "core").rglob("*.cpp") if re.search(r"_(avx2|avx512)$", p.stem)]
    assert len(per_isa) >= 8
    for source in per_isa:
        isa = source.stem.rsplit("_", 1)[1]
        rel = source.relative_to(ROOT).as_posix()
        assert re.search(re.escape(rel) + r"\s+PROPERTIES\s+COMPILE_OPTIONS\s+\"[^\"]*" + flags[isa], cmake), rel
    declared = (ROOT / "core" / "include" / "glintlab" / "detail" / "pixel_blocks.hpp").read_text()
    laws = "".join(p.read_text() for p in (ROOT / "core" / "laws").glob("*.cpp"))
    bodies = list((ROOT / "core").rglob("*_pixels_body.inc"))
    assert bodies
    for body in bodies:
        includers = {p.stem.rsplit("_", 1)[1] for p in per_isa if f'#include "{body.name}"' in p.read_text()}
        assert includers == {"avx2", "avx512"}, body.name
        block = body.name.removesuffix("_body.inc") + "_block"
        for isa in flags:
            assert f"{block}_{isa}(" in declared and f"detail::{block}_{isa}" in laws, (block, isa)


def test_shipped_shaders_are_declared_by_traits_and_the_registry(listed):
    from glintlab.api.method_shaders import shipped_method_shaders
    from glintlab.api.shader_samplers import SHIPPED_SAMPLERS, WRONG_SAMPLERS
    from glintlab.validation.lighting_images import AREA_LIGHT_SHADER
    row = _table()["shader law"]
    assert "`shader`" in row["files to touch"] and "`LawTraits::shader`" in row["registered by"]
    declared = {s: law for law, s in listed["traits_shaders"].items() if s}
    assert declared and listed["shipped"] == declared
    shaders = ROOT / "python" / "glintlab" / "data" / "shaders"
    for stem in declared:
        for suffix in ("_body.h", ".hlsl", ".glsl"):
            assert (shaders / f"{stem}{suffix}").exists(), f"{stem}{suffix}"
    # Every shipped .glsl/.hlsl file is a law's wrapper (declared by the traits), a shipped sampler
    # (SHIPPED_SAMPLERS, or a deliberately wrong one of WRONG_SAMPLERS) or a method shader of the registry of
    # image methods, or the area-light contract's example (lighting_images.AREA_LIGHT_SHADER); each has its
    # one body.
    assert "`register_image_method`" in _table()["method shader with its twin"]["registered by"]
    files = {p.name for p in [*shaders.glob("*.glsl"), *shaders.glob("*.hlsl")]}
    laws = {f for f in files if f.rsplit(".", 1)[0] in listed["shipped"]}
    samplers = {f for f in files if f.rsplit(".", 1)[0] in {*SHIPPED_SAMPLERS, *WRONG_SAMPLERS}}
    methods = {f"{e.files}.{lang}" for e in shipped_method_shaders().values() for lang in ("glsl", "hlsl")}
    examples = {f"{AREA_LIGHT_SHADER}.{lang}" for lang in ("glsl", "hlsl")}
    assert files - laws - samplers - examples == methods
    for name in files:
        assert (shaders / (name.rsplit(".", 1)[0] + "_body.h")).exists(), name
    assert "`SHIPPED_SAMPLERS`" in _table()["shader sampler"]["registered by"]


# ---------------------------------------------------------------------------------------------- Python kinds
# Each added inside a copy of the package exactly as its row says: (the row, {path in the copy: text}
# for the new files, {path in the copy: a line appended, or text -> text} for the existing files edited).

_METHOD_SHADER = ("method shader with its twin", {
    "python/glintlab/data/shaders/x_glow_body.h": '''
        // A test's method shader: the half vector's height times a gain.
        #ifndef X_GLOW_GAIN
        #define X_GLOW_GAIN 2.0
        #endif
        float glint(GlintInput g) { return abs(g.h.z) * X_GLOW_GAIN; }
    ''',
    "python/glintlab/data/shaders/x_glow.glsl": '#include "glintlab_method_glsl.h"\n#include "x_glow_body.h"\n',
    "python/glintlab/data/shaders/x_glow.hlsl": '#include "glintlab_method_hlsl.h"\n#include "x_glow_body.h"\n',
    "python/glintlab/api/x_glow.py": '''
        """A test's method shader with its numpy twin."""
        from pathlib import Path

        import numpy as np

        from ..resources import data_path
        from .glinty_ndf import register_image_method
        from .method_shaders import ShippedShader, shader_method, unpack_inputs


        def x_glow_method(gain=2.0):
            return shader_method(Path(data_path("shaders", "x_glow.glsl")), name="x_glow", register=False,
                                 defines={"X_GLOW_GAIN": gain})


        def x_glow_compare(rows, material=None, method=None):
            twin = np.abs(unpack_inputs(rows)["h"][:, 2]) * np.float32(2.0)
            bad = (method or x_glow_method()).shade(rows) != twin
            return {"share": float(bad.mean()), "pixels": int(bad.size), "beyond": np.nonzero(bad)[0]}


        register_image_method("x_glow", lambda m: x_glow_method(), label="x glow", returns="intensity",
                              doc="docs/math/glint_images.md" "#glint-x-glow",
                              shader=ShippedShader("x_glow", x_glow_compare, lambda m: {"gain 2.2": x_glow_method(2.2)}))
    ''',
}, {
    "python/glintlab/__init__.py": "from .api import x_glow  # noqa: F401",
    "docs/math/glint_images.md": "\n(glint-x-glow)=\n### A test's method shader\n\n`x_glow`: |h_z| times a gain.\n",
})

_GLINTY_NDF = ("glinty NDF / image method", {
    "python/glintlab/api/x_flat.py": '''
        """A test's glinty NDF: the smooth NDF."""
        from .glinty_ndf import GLINTY_NDFS, GlintyNDF, register_image_method


        class XFlat(GlintyNDF):
            name = "x_flat"

            def evaluate(self, uv, J, h, seed=0):
                return self.smooth(h)


        GLINTY_NDFS.register("x_flat", XFlat)
        register_image_method("x_flat", lambda m: XFlat(m.target, m.alpha, m.density), label="x flat",
                              doc="docs/math/glinty_ndf.md" "#glinty-x-flat")
    ''',
}, {
    "python/glintlab/__init__.py": "from .api import x_flat  # noqa: F401",
    "docs/math/glinty_ndf.md": "\n(glinty-x-flat)=\n## A test's glinty NDF\n\n`x_flat`: the smooth NDF.\n",
})

_SAMPLER = ("sampler", {
    "python/glintlab/api/x_beckmann.py": '''
        """A test's sampler: the Beckmann normals under another name (its wrong variants: the class's)."""
        from .samplers import BeckmannNormals, register_sampler


        @register_sampler
        class XBeckmann(BeckmannNormals):
            name = "x_beckmann"
            summary = "a test's copy of the Beckmann normal sampler"
            doc = "docs/math/sampling.md" "#x-beckmann"
    ''',
}, {
    "python/glintlab/__init__.py": "from .api import x_beckmann  # noqa: F401",
    "docs/math/sampling.md": "\n(x-beckmann)=\n## A test's sampler\n\n`x_beckmann`: Beckmann normals.\n",
})

_SECTION = ("report section", {
    "python/glintlab/studies/x_section.py": '''
        """A test's report section."""
        NAME = "x_section"
        TITLE = "A test's section"
        MEANING = "Nothing: a test adds it."
        DEFAULTS = {"size": 3}


        def compute(params, ctx):
            return {}


        def figures(tables, ctx):
            return []
    ''',
}, {
    "README.md": "\n| `x_section` | A test's section | Nothing: a test adds it. |\n",
    "python/glintlab/data/report/default.json": lambda text: json.dumps(
        {**json.loads(text), "sections": [*json.loads(text)["sections"], {"name": "x_section"}]}, indent=1),
})

# (The anchors the new entries cite exist in the copy only: written in two pieces, so that the citation
# check of the tree, tests/python/test_doc_references.py, does not read them as the tree's.)
# The generic tests run in the copy: each new entry's own ids, and the tests over the whole registries.
_SELECT = ("x_glow or x_flat or x_beckmann or registries_hold or registered_later or sampler_registry or readme_says "
           "or sections_are_the_discovered")


def _copy_tree(dest: Path) -> None:
    """The package (its built _core linked, not copied), the docs, the README and the generic tests."""
    core = next((ROOT / "python" / "glintlab").glob("_core*.so"))
    shutil.copytree(ROOT / "python" / "glintlab", dest / "python" / "glintlab",
                    ignore=shutil.ignore_patterns("__pycache__", "_core*.so"))
    os.symlink(core, dest / "python" / "glintlab" / core.name)
    shutil.copytree(ROOT / "docs", dest / "docs", ignore=shutil.ignore_patterns("_build", "api"))
    shutil.copy(ROOT / "README.md", dest / "README.md")
    (dest / "tests" / "python").mkdir(parents=True)
    for name in ("conftest.py", "test_extension_registries.py", "test_report.py"):
        shutil.copy(ROOT / "tests" / "python" / name, dest / "tests" / "python" / name)


def _add(dest: Path, kind: str, files: dict, lines: dict) -> None:
    """Adds a kind as its row says, and checks that each path it writes is one the row names."""
    row = _paths(_table()[kind]["files to touch"])
    patterns = [re.compile(re.sub(r"<[^>]+>", r"\\w+", re.escape(p))) for p in row]
    for path in [*files, *lines]:
        assert any(p.fullmatch(path) for p in patterns), f"{kind}: {path} is not a file its row names ({row})"
    for path, text in files.items():
        (dest / path).write_text(textwrap.dedent(text).lstrip())
    for path, edit in lines.items():
        text = (dest / path).read_text()
        (dest / path).write_text(edit(text) if callable(edit) else text + (edit if edit.endswith("\n") else edit + "\n"))


def test_python_kinds_added_inside_a_copy_of_the_package(tmp_path):
    """The Done-when of issue 43: a method shader with its twin and a sampler (and a glinty NDF, a report
    section) added inside the package as the table says are rendered, tested and documented with no other
    edit."""
    dest = tmp_path / "tree"
    _copy_tree(dest)
    for kind, files, lines in (_METHOD_SHADER, _GLINTY_NDF, _SAMPLER, _SECTION):
        _add(dest, kind, files, lines)
    env = dict(os.environ, PYTHONPATH=str(dest / "python"), PYTHONDONTWRITEBYTECODE="1")
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rA", "-k", _SELECT,
                          str(dest / "tests" / "python" / "test_extension_registries.py"),
                          str(dest / "tests" / "python" / "test_report.py")],
                         capture_output=True, text=True, timeout=300, cwd=dest, env=env)
    log = out.stdout + out.stderr
    assert out.returncode == 0, log[-4000:]
    passed = set(re.findall(r"^PASSED \S+::(\w+(?:\[[^\]]+\])?)", log, flags=re.M))
    want = {"test_every_image_method_renders[x_flat]", "test_every_shipped_image_method_is_documented[x_flat]",
            "test_every_shipped_image_method_is_documented[x_glow]",
            "test_every_shipped_method_shader_has_one_body_and_thin_wrappers[x_glow]",
            "test_every_sampler_passes_and_its_wrong_variants_fail[x_beckmann]",
            "test_every_sampler_is_documented[x_beckmann]",
            "test_readme_says_what_each_figure_means", "test_sections_are_the_discovered_studies"}
    if gl.vulkan_devices():  # the shader's render and its twin need a Vulkan device (lavapipe here)
        want |= {"test_every_image_method_renders[x_glow]",
                 "test_every_shipped_method_shader_agrees_with_its_twin_and_rejects_its_wrong_variants[x_glow]"}
    assert want <= passed, (sorted(want - passed), log[-3000:])
    # The copy was what ran: its package, with the new entries, and the tree's own package unchanged.
    check = ("import glintlab as gl, glintlab.report.sections as s; print(gl.__file__); "
             "print('x_glow' in gl.image_methods(), 'x_flat' in gl.glinty_ndfs(), 'x_beckmann' in gl.samplers(), "
             "'x_section' in s.discover().names())")
    shown = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=120, cwd=dest,
                           env=env).stdout.split()
    assert shown[0].startswith(str(dest)) and shown[1:] == ["True"] * 4, shown
    assert "x_glow" not in gl.image_methods() and not (ROOT / "python" / "glintlab" / "api" / "x_glow.py").exists()
