"""Shader samplers (docs/math/sampling.md#shader-samplers): the sample_h / pdf_h contract compiled and run
on Vulkan, the shipped GGX visible-normal shader against the harness and against the numpy reference
sampler's pdf, broken shader samplers rejected at the same sample size, determinism, pickles, errors,
timeouts and `glintlab sampler FILE` exit codes.

False-failure rates: every harness verdict here uses significance 1e-3 (the harness's default), so the
three correct-sampler verdicts fail by chance with probability about 3e-3 together; the seeds are fixed,
so a run is reproducible. The broken ones are rejected far below 1e-3 (p recorded in each comment,
measured at N = 5e5, seed 11, on lavapipe)."""
from __future__ import annotations

import pickle
import textwrap

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import shader_samplers as SS
from glintlab.api.samplers import load_sampler

pytestmark = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

N, SEED = 5 * 10**5, 11
WO = (0.6, 0.0, 0.8)


def broken(sample_line: str, pdf_line: str, name: str, language: str = "hlsl"):
    """A sampler built from the shipped body's helpers (ggx_vndf_body.h) with its own sample_h and pdf_h."""
    guard = "GLINTLAB_HLSL" if language == "hlsl" else "GLINTLAB_GLSL"
    code = textwrap.dedent(f"""
        #define {guard}
        #include "glintlab_prelude.h"
        #define GGX_VNDF_HELPERS_ONLY
        #include "ggx_vndf_body.h"
        float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) {{ {sample_line} }}
        float pdf_h(float2 uv, float4 J, float3 wo, float3 h) {{ {pdf_line} }}
        """)
    return gl.shader_sampler(code, language=language, name=name, wo=WO)


@pytest.mark.parametrize("language", ["hlsl", "glsl"])
def test_shipped_ggx_vndf_passes_and_its_pdf_is_the_reference_one(language):
    s = gl.shader_sampler(gl.shipped_sampler("ggx_vndf", language), wo=WO)
    assert s.domain == "hemisphere" and s.device and "ggx_vndf_body.h" in " ".join(s.included_files)
    res = gl.sampler_test(s, samples=N, seed=SEED)
    # Measured: p = 0.13 (both languages compute the same draws), 0 pdf mismatches of 5e5.
    assert res.passed, repr(res)
    assert res.mismatches == 0 and res.checked == N
    # pdf_h against the numpy reference (float64) at the sampled h and at uniform directions: float32
    # agreement (relative 3e-5; absolute 1e-6 of the peak where wo.h -> 0 cancels).
    ref = gl.sampler("ggx_vndf", alpha=0.3, wo=WO)
    rng = np.random.default_rng(5)
    v = rng.normal(size=(20000, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1)[:, None]
    h, p = s.sample(20000, seed=3)
    for pts in (h, v):
        got, want = s.pdf(pts), ref.pdf(pts)
        assert np.all(np.abs(got - want) <= 3e-5 * want + 1e-6 * want.max()), np.max(np.abs(got - want) / want)
    assert np.array_equal(p, s.pdf(h))  # sample_h's pdf is pdf_h's, bit for bit
    # A different alpha through the define, at a view 80 degrees from the normal too, checked against
    # the reference there (at sampled and at uniform directions).
    for wo in (WO, (0.98, 0.1, 0.17)):
        s5 = gl.shader_sampler(gl.shipped_sampler("ggx_vndf", language), defines={"ALPHA": 0.5}, wo=wo)
        ref5 = gl.sampler("ggx_vndf", alpha=0.5, wo=wo)
        for pts in (s5.sample(20000, seed=4)[0], v):
            want = ref5.pdf(pts)
            assert np.all(np.abs(s5.pdf(pts) - want) <= 3e-5 * want + 1e-6 * want.max()), wo


@pytest.mark.parametrize("kind, sample_line, pdf_line", [
    # Draws with alpha 2 % too large, pdfs at the true alpha: chi-square p = 1e-15.
    ("alpha+2%", "float4 r = ggx_vndf_sample(0.306, wo, u.xy); return float4(r.xyz, ggx_vndf_pdf(0.3, wo, r.xyz));",
     "return ggx_vndf_pdf(0.3, wo, h);"),
    # The pdf without its normalisation G1(wo) / wo.z (D(h) max(0, wo.h) alone): it integrates to 0.81.
    ("no_g1", "float4 r = ggx_vndf_sample(0.3, wo, u.xy); "
              "return float4(r.xyz, max(0.0, dot(wo, r.xyz)) * ggx_vndf_d(0.3, r.xyz));",
     "return h.z > 0.0 ? max(0.0, dot(wo, h)) * ggx_vndf_d(0.3, h) : 0.0;"),
    # Visible normals drawn, the pdf of plain normal sampling D(h) (h.n) declared: a sample/pdf mismatch.
    ("ndf_pdf", "float4 r = ggx_vndf_sample(0.3, wo, u.xy); return float4(r.xyz, r.z * ggx_vndf_d(0.3, r.xyz));",
     "return h.z > 0.0 ? h.z * ggx_vndf_d(0.3, h) : 0.0;"),
    # sample_h's own pdf 1 % off pdf_h's: every draw is a pdf mismatch (rtol 1e-3).
    ("pdf+1%", "float4 r = ggx_vndf_sample(0.3, wo, u.xy); return float4(r.xyz, 1.01 * r.w);",
     "return ggx_vndf_pdf(0.3, wo, h);"),
    # Half vectors 0.1 % too long (a normalisation left out or done in half precision): every draw is
    # off the unit sphere by more than the harness's unit_tol = 1e-4, so it is lost.
    ("unnormalised", "float3 h = 1.001 * ggx_vndf_sample(0.3, wo, u.xy).xyz; return float4(h, ggx_vndf_pdf(0.3, wo, h));",
     "return ggx_vndf_pdf(0.3, wo, h);"),
    # One draw in a thousand lost as NaN (u.z < 1e-3): 500 lost where the pdf leaves room for none.
    ("drop_0.1%", "float4 r = ggx_vndf_sample(0.3, wo, u.xy); float bad = u.z < 0.001 ? sqrt(-1.0 - u.z) : 0.0; "
                  "return r + float4(bad, bad, bad, 0.0);",
     "return ggx_vndf_pdf(0.3, wo, h);"),
])
def test_broken_shader_samplers_are_rejected(kind, sample_line, pdf_line):
    s = broken(sample_line, pdf_line, kind)
    res = gl.sampler_test(s, samples=N, seed=SEED)
    assert not res.passed, repr(res)
    if kind == "unnormalised":
        assert res.lost == N
    elif kind == "pdf+1%":
        assert res.mismatches == res.checked == N
    elif kind == "drop_0.1%":
        assert res.lost == pytest.approx(500, abs=60) and res.pvalue < 1e-6
    else:
        assert res.pvalue < 1e-6 and res.mismatches == 0


def test_glsl_broken_sampler_is_rejected_too():
    s = broken("vec4 r = ggx_vndf_sample(0.306, wo, u.xy); return vec4(r.xyz, ggx_vndf_pdf(0.3, wo, r.xyz));",
               "return ggx_vndf_pdf(0.3, wo, h);", "alpha+2%", language="glsl")
    assert not gl.sampler_test(s, samples=N, seed=SEED).passed


def test_the_shipped_sampler_is_written_once():
    """ggx_vndf.hlsl and .glsl are thin wrappers around one body and differ only in the language's name."""
    import re
    texts = {lang: gl.shipped_sampler("ggx_vndf", lang).read_text() for lang in ("hlsl", "glsl")}
    for lang, text in texts.items():
        code = [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("//")]
        assert code == [f"#define GLINTLAB_{lang.upper()}", '#include "glintlab_prelude.h"', '#include "ggx_vndf_body.h"']
    swap = {"hlsl": "glsl", "glsl": "hlsl", "HLSL": "GLSL", "GLSL": "HLSL"}
    assert re.sub(r"hlsl|glsl|HLSL|GLSL", lambda m: swap[m.group()], texts["hlsl"]) == texts["glsl"]
    with pytest.raises(ValueError, match="name = "):
        gl.shipped_sampler("beckmann_vndf")


def test_a_sphere_sampler_written_in_glsl():
    """A user's sampler with no glintlab helper: uniform directions on the whole sphere, pdf 1 / (4 pi)
    (domain "sphere"); and the same with z drawn as u instead of 2u - 1 (only the upper hemisphere),
    which the harness rejects (the pdf claims mass where no draw goes)."""
    code = textwrap.dedent("""
        vec4 sample_h(vec2 uv, vec4 J, vec3 wo, vec4 u) {
            float z = Z_OF_U;
            float r = sqrt(max(0.0, 1.0 - z * z));
            float phi = 2.0 * GLINTLAB_PI * u.y;
            return vec4(r * cos(phi), r * sin(phi), z, 1.0 / (4.0 * GLINTLAB_PI));
        }
        float pdf_h(vec2 uv, vec4 J, vec3 wo, vec3 h) { return 1.0 / (4.0 * GLINTLAB_PI); }
        """)
    good = gl.shader_sampler(code, language="glsl", domain="sphere", defines={"Z_OF_U": "2.0 * u.x - 1.0"})
    bad = gl.shader_sampler(code, language="glsl", domain="sphere", defines={"Z_OF_U": "u.x"}, name="upper only")
    assert gl.sampler_test(good, samples=10**5, seed=SEED).passed
    res = gl.sampler_test(bad, samples=10**5, seed=SEED)
    assert not res.passed and res.pvalue < 1e-6


def test_determinism_uniforms_and_pickles():
    s = gl.shader_sampler(gl.shipped_sampler("ggx_vndf", "glsl"), wo=(0.3, -0.2, 0.9), uv=(0.5, 0.25))
    h1, p1 = s.sample(3000, seed=7)
    h2, p2 = s.sample(3000, seed=7)
    assert np.array_equal(h1, h2) and np.array_equal(p1, p2)
    assert not np.array_equal(s.sample(3000, seed=8)[0], h1)
    assert np.array_equal(s.sample(1000, seed=7)[0], h1[:1000])  # row i's uniforms do not depend on size
    # The uniforms: Philox by the seed, four per row, float32 by the shader laws' rule (never 0 or 1).
    u = s.uniforms(3000, seed=7)
    assert u.dtype == np.float32 and u.shape == (3000, 4) and u.min() > 0 and u.max() < 1
    raw = np.random.Generator(np.random.Philox(7)).random((3000, 4))
    assert np.array_equal(u, gl.api.laws.uniforms_float32(raw))
    t = pickle.loads(pickle.dumps(s))
    assert repr(t) == repr(s) and t.identity == s.identity
    h3, p3 = t.sample(3000, seed=7)
    assert np.array_equal(h3, h1) and np.array_equal(p3, p1)
    assert s.params["wo"] == pytest.approx((0.3 / np.sqrt(0.94), -0.2 / np.sqrt(0.94), 0.9 / np.sqrt(0.94)))


def test_bad_input_and_compile_errors_name_the_problem(tmp_path):
    ok = "float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return float4(0.0, 0.0, 1.0, 1.0); }\n"
    pdf = "float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return 1.0; }\n"
    src = tmp_path / "typo.hlsl"
    src.write_text(ok + pdf.replace("return 1.0;", "return 1.0"))
    with pytest.raises(ValueError, match=r"typo\.hlsl:2: ") as err:
        gl.shader_sampler(src)
    assert "\n" not in str(err.value) and isinstance(err.value, SS.ShaderCompileError) and err.value.messages
    with pytest.raises(ValueError, match=r"no function pdf_h with the expected signature float pdf_h\(float2 uv"):
        gl.shader_sampler(ok)
    # A declaration that is not the contract's is named with its line and the expected signature, before
    # the compiler blames glintlab's wrapper (or HLSL converts a float4 to a float2 without a word).
    expected = r"expected float4 sample_h\(float2 uv, float4 J, float3 wo, float4 u\) \(hlsl\)"
    with pytest.raises(ValueError, match=r"<string>:1: float4 sample_h\(float2 uv, float3 wo, float4 u\) is not the "
                                         r"contract's sample_h: " + expected):
        gl.shader_sampler(ok.replace("float4 J, ", "") + pdf)
    for wrong in ("float3 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return float3(0.0, 0.0, 1.0); }\n",
                  ok.replace("float4 u)", "float2 u)")):   # HLSL would truncate the uniforms silently
        with pytest.raises(ValueError, match=r"is not the contract's sample_h: " + expected):
            gl.shader_sampler(wrong + pdf)
    with pytest.raises(ValueError, match=r"<string>:2: float2 pdf_h\(.*is not the contract's pdf_h"):
        gl.shader_sampler(ok + pdf.replace("float pdf_h", "float2 pdf_h").replace("return 1.0", "return float2(1, 1)"))
    # A type the check cannot read (a macro) is left to the compiler, whose error at glintlab's call of
    # sample_h names the function and the signature, not "a declaration left unfinished".
    with pytest.raises(ValueError, match=r"sample_h does not have the contract's signature: " + expected):
        gl.shader_sampler("#define RET float3\n" + ok.replace("float4 sample_h", "RET sample_h").replace(
            "float4(0.0, 0.0, 1.0, 1.0)", "float3(0.0, 0.0, 1.0)") + pdf)
    with pytest.raises(ValueError, match=r"float pdf_h\(vec3 h\) is not the contract's pdf_h: expected .*vec3 h\) "
                                         r"\(glsl\)"):
        gl.shader_sampler(ok.replace("float4", "vec4").replace("float2", "vec2").replace("float3", "vec3") +
                          "float pdf_h(vec3 h) { return 1.0; }\n", language="glsl")
    with pytest.raises(ValueError, match=r"after the end of <string> \(a declaration left unfinished\?\)"):
        gl.shader_sampler(ok + pdf + "float junk(\n")
    with pytest.raises(ValueError, match="resource 'mine'.*read-only"):  # the runner's resource check, as for laws
        gl.shader_sampler("RWStructuredBuffer<float> mine;\n" + ok.replace("1.0, 1.0)", "1.0, mine[0])") + pdf)
    for kwargs, needle in [({"wo": (0.0, 0.0, -1.0)}, "wo = "), ({"J": (1.0, 0.0, 0.0)}, "J = "),
                           ({"uv": (np.nan, 0.0)}, "uv = "), ({"language": "cuda"}, "language = "),
                           ({"domain": "disk"}, "domain = "), ({"timeout": 0}, "timeout = "),
                           ({"defines": {"1X": 1}}, "defines")]:
        with pytest.raises(ValueError, match=needle):
            gl.shader_sampler(ok + pdf, **kwargs)
    with pytest.raises(ValueError, match="source = "):
        gl.shader_sampler(str(tmp_path / "missing.glsl"))
    s = gl.shader_sampler(ok + pdf.replace("return 1.0;", "return h.z > 0.5 ? 1.0 : -1.0;"), name="negative")
    with pytest.raises(gl.ShaderOutputError, match="pdf_h returned -1"):
        s.pdf([[0.0, 0.6, 0.8], [1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="points"):
        s.pdf([[0.0, 1.0]])
    # A NaN direction is the caller's input, not the shader's NaN pdf.
    with pytest.raises(ValueError, match=r"points = 'row 1 = \(nan, 0.0, 1.0\)' is invalid; expected finite"):
        s.pdf([[0.0, 0.6, 0.8], [np.nan, 0.0, 1.0]])
    with pytest.raises(ValueError, match="include_dirs = .*missing.* expected existing folders"):
        gl.shader_sampler(ok + pdf, include_dirs=[tmp_path / "missing"])
    # A define the code never mentions changes nothing: refused, with the name the code does read.
    with pytest.raises(ValueError, match=r"defines = 'alpha' .*never mentions changes nothing \(the code reads ALPHA\)"):
        gl.shader_sampler(gl.shipped_sampler("ggx_vndf"), defines={"alpha": 0.9})
    with pytest.raises(ValueError, match=r"defines = 'UNUSED'"):
        gl.shader_sampler(ok + pdf, defines={"UNUSED": 1})


def test_timeout_is_an_error_and_the_device_recovers():
    # 5000 rows of 60000 sin each (about 1 s on lavapipe) against a timeout of 0.05 s.
    slow = gl.shader_sampler(textwrap.dedent("""
        float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) {
            float acc = u.x;
            for (int i = 0; i < 60000; ++i) acc = sin(acc * 1.0001 + float(i) * 1e-7 + u.y);
            return float4(0.0, 0.0, 1.0, acc);
        }
        float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return 1.0; }
        """), name="slow", timeout=0.05)
    with pytest.raises(TimeoutError, match="timeout"):
        slow.sample(5000, seed=1)
    s = gl.shader_sampler(gl.shipped_sampler("ggx_vndf"))  # queued behind the slow kernel, then served
    assert np.isfinite(s.sample(10, seed=1)[1]).all()


def test_cli_runs_shader_files_with_exit_codes(tmp_path, capsys):
    from glintlab.cli.main import main
    path = str(gl.shipped_sampler("ggx_vndf", "hlsl"))
    assert isinstance(load_sampler(path, ALPHA=0.5, wo=WO), SS.ShaderSampler)
    base = ["sampler", path, "--samples", "200000", "--quiet", "--out", str(tmp_path)]
    assert main(base + ["--param", "ALPHA=0.4", "--param", "wo=0.6,0,0.8"]) == 0
    assert main(base + ["--wrong", "drop_0.1%"]) == 1  # a Python-side wrong variant of the shader sampler
    bad = tmp_path / "bad.glsl"
    bad.write_text("vec4 sample_h(vec2 uv, vec4 J, vec3 wo, vec4 u) { return vec4(0.0, 0.0, 1.0, 1.0); }\n"
                   "float pdf_h(vec2 uv, vec4 J, vec3 wo, vec3 h) { return 1.0 }\n")
    capsys.readouterr()
    assert main(["sampler", str(bad), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.glsl:2:" in err and "Traceback" not in err
    nan = tmp_path / "nan.hlsl"
    nan.write_text("float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return float4(0.0, 0.0, 1.0, 1.0); }\n"
                   "float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return sqrt(-1.0 - h.z); }\n")
    assert main(["sampler", str(nan), "--quiet", "--samples", "1000", "--out", str(tmp_path)]) == 1
    assert "FAIL" in capsys.readouterr().err
    assert main(["sampler", path, "--param", "wo=0,0,-1"]) == 2
    # Shader samplers declare their wrong variants: alpha+2% is not one (its alpha is a define).
    capsys.readouterr()
    assert main(["sampler", path, "--wrong", "alpha+2%", "--samples", "1000"]) == 2
    assert main(["sampler", path, "--param", "alpha=0.9", "--samples", "1000"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 2 and "Traceback" not in err and "declares: drop_0.1%" in err and "reads ALPHA" in err


def test_a_nan_pdf_from_sample_h_is_a_failed_check(tmp_path, capsys):
    # sample_h returns a NaN pdf on every draw while pdf_h is fine: the consistency check used to keep
    # only finite pdfs, and glintlab sampler printed "verdict: pass".
    from glintlab.cli.main import main
    nan = tmp_path / "nan_pdf.hlsl"
    nan.write_text("#define GLINTLAB_HLSL\n#include \"glintlab_prelude.h\"\n"
                   "#define GGX_VNDF_HELPERS_ONLY\n#include \"ggx_vndf_body.h\"\n"
                   "float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) {\n"
                   "  float4 r = ggx_vndf_sample(0.3, wo, u.xy); return float4(r.xyz, sqrt(-1.0 - u.x)); }\n"
                   "float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return ggx_vndf_pdf(0.3, wo, h); }\n")
    res = gl.sampler_test(gl.shader_sampler(nan, wo=WO), samples=20_000, seed=SEED)
    assert not res.passed and res.mismatches == res.invalid_pdfs == 20_000 and "NaN 20000" in res.note, res
    assert main(["sampler", str(nan), "--samples", "2e4", "--out", str(tmp_path)]) == 1
    out = capsys.readouterr()
    assert "verdict: pass" not in out.out and "FAIL" in out.err


def test_the_loop_caveat_is_shown(tmp_path, capsys):
    # A loop whose trip count depends on the uniforms: lavapipe cuts every loop at 65535 iterations, so
    # what it computes may not be what a GPU computes; glintlab sampler says so, as glintlab shader does.
    from glintlab.cli.main import main
    loop = tmp_path / "loop.hlsl"
    loop.write_text("float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) {\n"
                    "  float z = u.x; for (int i = 0; i < int(u.y * 3.0); ++i) { if (u.w < 0.0) z = 0.0; }\n"
                    "  float r = sqrt(max(0.0, 1.0 - z * z)), phi = 2.0 * GLINTLAB_PI * u.z;\n"
                    "  return float4(r * cos(phi), r * sin(phi), z, 1.0 / (2.0 * GLINTLAB_PI)); }\n"
                    "float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return 1.0 / (2.0 * GLINTLAB_PI); }\n")
    s = gl.shader_sampler(loop)
    if not s.loop_caveat:
        pytest.skip("not on lavapipe: no loop caveat")
    res = gl.sampler_test(s, samples=20_000, seed=SEED)
    assert "not what a GPU would compute" in res.note and "65535" in res.note
    assert main(["sampler", str(loop), "--samples", "2e4", "--quiet", "--out", str(tmp_path)]) == 0
    assert "NOTE not what a GPU would compute" in capsys.readouterr().err
