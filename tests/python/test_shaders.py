"""Shader laws (gl.shader_law): HLSL and GLSL counting functions compiled by shaderc and run by Vulkan
(lavapipe here and in CI), measured like any law.

Statistical checks use fixed seeds and 10^6 samples; a sampler check passes at p > 1e-4, so over the
32 sampled checks of this file (4 shaders x 2 languages x 4 points) the false-failure rate is below
32 x 1e-4 = 3.2e-3 (the seeds are fixed: a pass is reproducible). Each check is shown to fail on a
deliberately wrong shader (K + 1, the gate reversed). Row-by-row agreement with the C++ twins allows
1e-4 of the rows to differ by one count: a GPU's pow, exp and log may be several ulps from the C++
library's (docs/guide/shaders.md).
"""
import concurrent.futures
import functools
import json
import os
import pickle
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from glintlab.api.plugins import CUSTOM_LAWS
from glintlab.cli.main import main

import glintlab as gl
from glintlab.api import shaders as S
from glintlab.api.laws import uniforms_float32
from glintlab.studies.db23_figure9 import FIGURE9_POINTS

pytestmark = pytest.mark.skipif(not S.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

# Not registered by name: the laws of this file stay out of gl.laws() for the other test files.
shader_law = functools.partial(gl.shader_law, register=False)
SAMPLES = 10**6
P_PASS = 1e-4
ROW_SHARE = 1e-4  # rows allowed to differ from the C++ twin (by one count at most)
SHIPPED = [(name, lang) for name in S.shipped_shaders() for lang in S.LANGUAGES]
_laws = {}


def shipped(name, language, **kw):
    key = (name, language, tuple(sorted(kw.get("defines", {}).items())))
    if key not in _laws:
        suffix = "".join(f"_{k}" for k in kw.get("defines", {}))
        _laws[key] = shader_law(S.shipped_shader(name, language), name=f"test_{name}_{language}{suffix}", **kw)
    return _laws[key]


def test_devices_and_default_device():
    devices = gl.vulkan_devices()
    assert all({"index", "name", "type", "api_version", "driver"} <= set(d) for d in devices)
    law = shipped("gated", "hlsl")
    assert law.device in [d["name"] for d in devices]
    if not any("gpu" in d["type"] for d in devices):  # auto falls back to the CPU device (lavapipe)
        assert law.device_type == "cpu"
        with pytest.raises(RuntimeError, match="no Vulkan GPU"):
            shader_law(S.shipped_shader("gated"), name="test_gpu_refused", device="gpu")


def test_uniform_rule_is_the_cpp_rule():
    """The shader receives exactly uniforms_float32(u): the rule the C++ float32 laws use."""
    law = shader_law("float count(float n, float p, float4 u) { return u.x + 2.0 * u.y; }",
                        name="test_shader_uniform_echo", binning="none")
    u = np.array([[0.0, 1.0], [1.0, 0.0], [0.5, 2.0**-30], [1 - 2.0**-40, 0.3]])
    u = np.vstack([u, gl.uniforms(1000, 2, seed=3)])
    got = law.evaluate_raw(1.0, 0.5, u)
    f = uniforms_float32(u)
    assert np.array_equal(got, (f[:, 0] + np.float32(2) * f[:, 1]).astype(np.float64))
    assert f.min() >= 2.0**-24 and f.max() <= 1 - 2.0**-24


@pytest.mark.parametrize("name,language", SHIPPED)
@pytest.mark.parametrize("n,p", FIGURE9_POINTS)
def test_shipped_shader_against_exact_pmf(name, language, n, p):
    law, twin = shipped(name, language), S.shipped_twin(name)
    x = law.bin(law.sample(n, p, size=SAMPLES, seed=11))
    assert gl.chi2_test(x, twin.pmf(n, p)).pvalue > P_PASS


POINTS = FIGURE9_POINTS + [(3.5, 0.3), (50, 0.02), (1e5, 0.9)]


@pytest.mark.parametrize("name", list(S.shipped_shaders()))
def test_shipped_shader_row_by_row_against_cpp_twin(name):
    law, twin = shipped(name, "hlsl"), S.shipped_twin(name)
    u = gl.uniforms(200_000, 2, seed=5)
    for n, p in POINTS:
        k = law.bin(law.evaluate(n, p, u))
        c = twin.bin(twin.evaluate(n, p, u, precision="float32"))
        assert np.mean(k != c) <= ROW_SHARE, (n, p)
        assert np.abs(k - c).max() <= 1, (n, p)
    # Where a GPU's pow loses DB23's P1 (small p), more rows move, still by one count (measured on
    # lavapipe: 1.3e-4 of the rows for gated; the row check of `glintlab shader` allows 1e-3).
    k = law.bin(law.evaluate(1e4, 1e-6, u))
    c = twin.bin(twin.evaluate(1e4, 1e-6, u, precision="float32"))
    assert np.mean(k != c) <= 1e-3 and np.abs(k - c).max() <= 1


@pytest.mark.parametrize("name", list(S.shipped_shaders()))
def test_hlsl_and_glsl_agree_row_by_row(name):
    u = gl.uniforms(200_000, 2, seed=6)
    for n, p in POINTS:
        assert np.array_equal(shipped(name, "hlsl").evaluate(n, p, u), shipped(name, "glsl").evaluate(n, p, u))


@pytest.mark.parametrize("bug", ["GATED_BUG_PLUS_ONE", "GATED_BUG_REVERSED_GATE"])
def test_deliberate_bugs_are_rejected(bug):
    law, twin = shipped("gated", "hlsl", defines={bug: 1}), S.shipped_twin("gated")
    u = gl.uniforms(200_000, 2, seed=5)
    for n, p in FIGURE9_POINTS:
        assert gl.chi2_test(law.bin(law.sample(n, p, size=SAMPLES, seed=11)), twin.pmf(n, p)).pvalue < 1e-10
        k, c = law.bin(law.evaluate(n, p, u)), twin.bin(twin.evaluate(n, p, u, precision="float32"))
        assert np.mean(k != c) > 0.001


def test_same_output_across_runs_threads_and_python_threads():
    law = shipped("head_cf", "glsl")
    a = law.sample(1000, 0.002, size=300_000, seed=3)
    threads = gl.get_num_threads()
    try:
        gl.set_num_threads(1)
        b = law.sample(1000, 0.002, size=300_000, seed=3)
    finally:
        gl.set_num_threads(threads)
    assert np.array_equal(a, b)
    with concurrent.futures.ThreadPoolExecutor(4) as pool:  # calls on one device queue up
        runs = list(pool.map(lambda s: law.sample(1000, 0.002, size=100_000, seed=s), [3, 4, 3, 4]))
    assert np.array_equal(runs[0], a[:100_000]) and np.array_equal(runs[0], runs[2])
    assert np.array_equal(runs[1], runs[3]) and not np.array_equal(runs[0], runs[1])


def test_pickles_by_value():
    law = shipped("gated", "glsl")
    back = pickle.loads(pickle.dumps(law))
    assert back.identity == law.identity and back.device == law.device
    assert np.array_equal(back.sample(8, 0.1, size=1000, seed=2), law.sample(8, 0.1, size=1000, seed=2))


def test_includes_and_defines(tmp_path):
    (tmp_path / "inc").mkdir()
    (tmp_path / "inc" / "lib.hlsli").write_text("float scaled(float x) { return SCALE * x; }\n")
    (tmp_path / "near.hlsli").write_text('#include "lib.hlsli"\n')
    src = tmp_path / "mine.hlsl"
    src.write_text('#include "near.hlsli"\nfloat count(float n, float p, float4 u) { return scaled(n * p); }\n')
    law = shader_law(src, include_dirs=[tmp_path / "inc"], defines={"SCALE": 3}, name="test_shader_inc",
                        binning="none")
    assert law.evaluate(10, 0.5, [[0.1, 0.2]])[0] == 15.0
    with pytest.raises(ValueError, match="lib.hlsli"):
        shader_law(src, defines={"SCALE": 3}, name="test_shader_inc2")


def test_compile_error_names_file_and_line(tmp_path):
    src = tmp_path / "broken.glsl"
    src.write_text("// a comment\nfloat count(float n, float p, vec4 u) {\n  return n * p +;\n}\n")
    with pytest.raises(ValueError, match=r"broken\.glsl:3: error") as e:
        shader_law(src, name="test_shader_broken")
    assert "does not compile" in str(e.value)


@pytest.mark.parametrize("language,code,expected", [
    ("hlsl", "float count(float n, float p) { return n * p; }", "float count(float n, float p, float4 u)"),
    ("glsl", "float count(float n, float p, vec4 u) { return n; }", "float mycount(float n, float p, vec4 u)"),
])
def test_wrong_signature_shows_the_expected_one(language, code, expected):
    entry = expected.split("(")[0].split()[-1]
    with pytest.raises(ValueError, match="expected signature") as e:
        shader_law(code, language=language, entry=entry, name="test_shader_signature")
    assert expected in str(e.value)


@pytest.mark.parametrize("language,vec4", [("hlsl", "float4"), ("glsl", "vec4")])
def test_unfinished_declarations_say_what_they_are(language, vec4):
    """Before: both were "no function count with the expected signature", which the code has."""
    sig = f"float count(float n, float p, {vec4} u)"
    with pytest.raises(S.ShaderCompileError, match=r"^shader law does not compile \(\w+\): function count is "
                                                    r"declared in <string> but has no body \(a prototype without its "
                                                    r"definition; define " + re.escape(sig) + r"\)$") as e:
        shader_law(sig + ";", language=language, register=False)
    assert "\n" not in str(e.value) and "No function definition" in e.value.messages
    helper = f"float twice(float x);\n{sig} {{ return twice(n); }}\n"  # a helper's prototype: named too
    with pytest.raises(ValueError, match=r"function twice is declared in <string> but has no body"):
        shader_law(helper, language=language, register=False)
    with pytest.raises(ValueError, match=r"after the end of <string> \(a declaration left unfinished\?\)"):
        shader_law(sig[:-1], language=language, register=False)
    with pytest.raises(ValueError, match=r"after the end of <string> \(a declaration left unfinished\?\)"):
        shader_law(sig + " { return n;", language=language, register=False)


def test_bad_arguments():
    for kwargs, match in [({"language": "cuda"}, "language"), ({"n_uniforms": 5}, "n_uniforms"),
                          ({"entry": "not a name"}, "entry"), ({"device": "no such device"}, "device"),
                          ({"timeout": 0}, "timeout"), ({"name": "gated"}, "name")]:
        with pytest.raises(ValueError, match=match):
            shader_law(S.shipped_shader("gated"), **kwargs)
    with pytest.raises(ValueError, match="source"):
        shader_law("missing_file.hlsl")


def test_nan_and_negative_counts_are_errors():
    nan = shader_law("float count(float n, float p, float4 u) { return u.x < 0.5 ? log(u.x - 2.0) : 1.0; }",
                        name="test_shader_nan")
    with pytest.raises(ValueError, match="counts must be finite"):
        nan.sample(10, 0.5, size=100, seed=1)
    assert np.isnan(nan.evaluate_raw(10, 0.5, [[0.25, 0.5]])[0])
    neg = shader_law("float count(float n, float p, float4 u) { return -n * p; }", name="test_shader_neg")
    with pytest.raises(ValueError, match=">= 0"):
        neg.sample(10, 0.5, size=10, seed=1)


def test_timeout_is_an_error_and_the_device_recovers():
    # lavapipe cuts every loop at 65535 iterations (below), so the slow kernel is slow by its rows:
    # 5000 rows of 60000 sin each, about 1 s here, against a timeout of 0.05 s.
    slow = shader_law(textwrap.dedent("""
        float count(float n, float p, float4 u) {
            float acc = u.x;
            for (int i = 0; i < int(n); ++i) acc = sin(acc * 1.0001 + float(i) * 1e-7 + p);
            return acc;
        }"""), name="test_shader_slow", timeout=0.05)
    with pytest.raises(TimeoutError, match="timeout"):
        slow.evaluate_raw(60000, 0.5, gl.uniforms(5000, 2, seed=1))
    law = shipped("gated", "hlsl")  # queued behind the slow kernel, then served
    assert law.evaluate(8, 0.1, [[0.01, 0.5]])[0] >= 1


def test_lavapipe_cuts_loops_at_65535_iterations():
    """A property of the device, not of glintlab (docs/guide/shaders.md): llvmpipe stops any loop after
    65535 iterations, so a counting loop (zk16's Bernoulli trials) returns too small a count there."""
    law = shader_law("float count(float n, float p, float4 u) { float k = 0.0; "
                        "for (int i = 0; i < int(n); ++i) k += 1.0; return k; }", name="test_shader_loop",
                        binning="none")
    got = law.evaluate_raw(np.array([10.0, 65535.0, 1e5]), 0.5, np.full((3, 2), 0.5))
    if law.device.startswith("llvmpipe"):
        assert list(got) == [10.0, 65535.0, 65535.0]
    else:
        assert list(got) == [10.0, 65535.0, 1e5]


def test_no_device_names_the_package():
    code = ("import glintlab as gl\ntry:\n    gl.shader_law('float count(float n, float p, float4 u) { return n; }')\n"
            "except RuntimeError as e:\n    print(e)\n")
    env = {**os.environ, "VK_ICD_FILENAMES": "/nonexistent.json", "VK_DRIVER_FILES": "/nonexistent.json"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert "mesa-vulkan-drivers" in r.stdout, r.stdout + r.stderr


def test_registered_by_name_and_usable_in_an_experiment(tmp_path):
    src = tmp_path / "hc.glsl"
    src.write_text(gl.emit_shader("head_cf", "glsl"))  # self-contained: nothing to include in tmp_path
    doc = tmp_path / "e.json"
    doc.write_text(json.dumps({"name": "shader_exp", "laws": [{"shader": "hc.glsl", "name": "test_shader_exp"}],
                               "grid": {"n": [8, 1000], "p": [0.1]}, "metrics": ["tv"], "samples": 200_000,
                               "outputs": {"plots": False, "csv": False, "json": False}}))
    try:
        table = gl.run_experiment(doc, out=tmp_path / "out").table
        assert isinstance(gl.law("test_shader_exp"), gl.ShaderLaw)
    finally:
        CUSTOM_LAWS._items.pop("test_shader_exp", None)  # keep gl.laws() of the other test files
    assert list(table.law) == ["test_shader_exp"] * 2 and (table.tv < 0.02).all()


def test_cli_verdicts(tmp_path, capsys):
    good = ["shader", str(S.shipped_shader("gated")), "--samples", "200000", "--grid-samples", "512",
            "--grid-stride", "12", "--rows", "100000", "--speed-evaluations", "100000", "--quiet"]
    bounds = tmp_path / "bounds.json"  # a sampled bound (a shader law has no exact pmf), TV to the binomial
    bounds.write_text(json.dumps({"glintlab": 1, "bounds": [
        {"id": "tv", "law": "gated_shader", "regime": {"p_range": [0.01, 0.5], "n_range": [8, 1000]},
         "metric": "tv", "maximum": 0.25, "samples": 20000}]}))
    good += ["--bounds", str(bounds)]
    assert main(good + ["--against", "gated_shader", "--twin", "gated_shader", "--out", str(tmp_path / "a")]) == 0
    summary = json.loads((tmp_path / "a" / "verdict.json").read_text())
    assert summary["passed"] and summary["rows_binned_differ_max"] <= 1e-3 and summary["ratio"] > 0
    assert (tmp_path / "a" / "tv_map.png").stat().st_size > 10_000
    bug = good + ["-D", "GATED_BUG_PLUS_ONE=1", "--against", "gated_shader", "--twin", "gated_shader"]
    assert main(bug + ["--out", str(tmp_path / "b")]) == 1
    err = capsys.readouterr().err
    assert "FAIL chi-square" in err and "FAIL row by row" in err and "FAIL bound tv" in err
    broken = tmp_path / "broken.hlsl"
    broken.write_text("float count(float n, float p, float4 u) {\n  return n *;\n}\n")
    assert main(["shader", str(broken), "--quiet", "--out", str(tmp_path / "c")]) == 2
    assert "broken.hlsl:2: error" in capsys.readouterr().err
    assert main(good + ["--against", "no_such_law", "--out", str(tmp_path / "d")]) == 2


def test_blends_and_grid_schemes_take_a_shader():
    """A shader law is an inner law like a custom one: a blend and a grid scheme over the head_cf shader
    give what they give over its C++ twin evaluated in float32 on the same uniforms."""
    twin = S.shipped_twin("head_cf")
    emulated = gl.custom_law(lambda n, p, u: twin.evaluate(n, p, u, precision="float32"), n_uniforms=2,
                             name="test_shader_twin_f32")
    law = shipped("head_cf", "glsl")
    n, area = 1e4, 1 / 64
    P = np.array([0.01, 0.02, 0.05, 0.2])
    for inner_a, inner_b in ((law, emulated),):
        a = gl.blended_law("distributed", inner=inner_a, base_area=area).sample(n, P, 0.3, size=4, seed=8)
        b = gl.blended_law("distributed", inner=inner_b, base_area=area).sample(n, P, 0.3, size=4, seed=8)
        assert np.array_equal(a, b) and a.sum() > 0
        c = gl.aniso_counter("db23_trilinear", inner=inner_a, base_area=area).sample(n, 50 * area, 3.0, 0.2, 0.1,
                                                                                     size=100, seed=1)
        d = gl.aniso_counter("db23_trilinear", inner=inner_b, base_area=area).sample(n, 50 * area, 3.0, 0.2, 0.1,
                                                                                     size=100, seed=1)
        assert np.array_equal(c, d) and c.sum() > 0


# ---- Each shipped shader written once (docs/guide/shaders.md#shaders-shipped) ----

SHADER_DIR = S.shipped_shader("gated").parent
FUNCTION_DEF = r"^\s*float\s+(\w+)\s*\("


def test_shipped_shaders_are_declared_by_the_law_traits():
    """The list of shipped shaders is the laws' own declaration (LawTraits::shader), and every law
    shader file glintlab ships is declared by a law (the method shaders and shader samplers are the other kinds)."""
    from glintlab import _core
    declared = {t["shader"]: name for name, t in _core.all_law_traits().items() if t["shader"]}
    assert S.shipped_shaders() == declared and len(declared) >= 4
    assert all(gl.law_traits(law)["shader"] == shader for shader, law in declared.items())
    assert gl.law_traits("binomial")["shader"] == ""
    from glintlab.api.method_shaders import shipped_method_shaders
    from glintlab.api.shader_samplers import SHIPPED_SAMPLERS, WRONG_SAMPLERS  # the third kind: direction samplers
    methods = {e.files for e in shipped_method_shaders().values()}  # their registry entries name their files
    from glintlab.validation.lighting_images import AREA_LIGHT_SHADER  # the area-light contract's example
    others = {*SHIPPED_SAMPLERS, *WRONG_SAMPLERS, AREA_LIGHT_SHADER}
    wrappers = {p.stem for p in SHADER_DIR.glob("*.[hg]lsl") if p.stem not in methods and p.stem not in others}
    assert wrappers == set(declared)
    assert S.shipped_shader("gated_shader", "glsl") == S.shipped_shader("gated", "glsl")  # the law's name too
    with pytest.raises(ValueError, match="a shipped shader among"):
        S.shipped_shader("binomial")


# The contracts' entries, which every shipped body of their kind defines (the sampler's wrong variants too).
CONTRACT_ENTRIES = ("count", "glint", "sample_h", "pdf_h", "sample_l", "pdf_l")


@pytest.mark.parametrize("name", list(S.shipped_shaders()))
def test_each_shader_is_written_once(name):
    """The .hlsl and .glsl files are thin wrappers around one body: no code of their own, and they
    differ only in the language's name; no function is defined twice among the shipped headers."""
    import re
    texts = {lang: S.shipped_shader(name, lang).read_text() for lang in S.LANGUAGES}
    for lang, text in texts.items():
        code = [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("//")]
        assert code == [f"#define GLINTLAB_{lang.upper()}", '#include "glintlab_prelude.h"',
                        f'#include "{name}_body.h"'], (lang, code)
    swap = {"hlsl": "glsl", "glsl": "hlsl", "HLSL": "GLSL", "GLSL": "HLSL"}
    assert re.sub(r"hlsl|glsl|HLSL|GLSL", lambda m: swap[m.group()], texts["hlsl"]) == texts["glsl"]
    defined = [f for path in sorted(SHADER_DIR.glob("*.h")) if not path.name.startswith("glintlab_method")
               for f in re.findall(FUNCTION_DEF, path.read_text(), re.M) if f not in CONTRACT_ENTRIES]
    assert len(defined) == len(set(defined)), sorted(defined)


@pytest.mark.parametrize("name,language", SHIPPED)
def test_emitted_shader_compiles_alone_and_gives_the_same_rows(name, language, tmp_path):
    """``emit_shader`` (``glintlab shader --emit``) is one paste-ready file: no #include left, the
    comments kept, and compiled alone (nothing next to it to include) it computes what the shipped
    wrapper computes, bit for bit."""
    text = S.emit_shader(name, language)
    assert not any(line.lstrip().startswith("#include") for line in text.splitlines())
    body = (SHADER_DIR / f"{name}_body.h").read_text()
    assert body.splitlines()[0] in text  # the law's own comments travel with it
    path = tmp_path / f"pasted.{language}"
    path.write_text(text)
    alone = shader_law(path, name=f"test_emitted_{name}_{language}")
    assert alone.included_files == []
    u = gl.uniforms(50_000, 2, seed=7)
    for n, p in POINTS + [(0.0, 0.5), (1.5, 1.0), (2.0, 0.0)]:
        assert np.array_equal(alone.evaluate_raw(n, p, u), shipped(name, language).evaluate_raw(n, p, u)), (n, p)


def test_cli_emits_a_shipped_shader(capsys):
    assert main(["shader", "--emit", "head_cf", "--lang", "glsl"]) == 0
    assert capsys.readouterr().out == S.emit_shader("head_cf", "glsl")
    assert main(["shader", "--emit", "gated_shader"]) == 0  # the law's name; HLSL by default
    assert capsys.readouterr().out == S.emit_shader("gated", "hlsl")
    assert main(["shader", "--emit", "binomial"]) == 2
    assert "a shipped shader among" in capsys.readouterr().err
    assert main(["shader"]) == 2  # neither FILE nor --emit
