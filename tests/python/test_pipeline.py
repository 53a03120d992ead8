"""Pipelines (``glintlab check PIPELINE.json``, issue 41): a renderer's whole glint pipeline gated in CI.

A custom pipeline (a shader law with an include folder, the distributed blend, a shader sampler, an NDF
method shader) is recorded once; then each deliberately wrong stage (the shader law with the K + 1 bug,
the blend with its weights swapped, the sampler drawing with alpha 2 % off, the method without its
cos^4) must fail that stage's bounds and no other. Every measurement uses the pipeline's fixed seed, so
the recorded bounds of a correct pipeline hold bit for bit on the same machine; the sampler's chi-square
bound is the test's significance, 1e-3 (its false-failure rate under a new seed). Sizes are small (the
file runs in a few seconds of CPU); the shipped pipelines are timed by bench/bench_pipeline.py.
"""
import copy
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import shaders as S
from glintlab.cli.main import main
from glintlab.resources import data_path
from glintlab.validation import pipeline as P
from glintlab.validation.bounds import regime_points

vulkan = pytest.mark.skipif(not S.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

LAW = '#define GLINTLAB_HLSL\n#include "glintlab_prelude.h"\n#include "team_gate.h"\n'
HEADER = '// the team\'s header, found through the pipeline\'s "includes"\n#include "gated_body.h"\n'
SAMPLER = """#define GLINTLAB_HLSL
#include "glintlab_prelude.h"
#define GGX_VNDF_HELPERS_ONLY
#include "ggx_vndf_body.h"
float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return ggx_vndf_sample(ALPHA * SAMPLE_SCALE, wo, u.xy); }
float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return ggx_vndf_pdf(ALPHA, wo, h); }
"""
NDF = """float glint(GlintInput g) {
  float c = dot(normalize(g.h), g.n);
  if (c <= 0.0) return 0.0;
  float a2 = GLINTLAB_ALPHA * GLINTLAB_ALPHA, c2 = c * c;
  return exp((c2 - 1.0) / (c2 * a2)) / (3.14159265 * a2 * c2 * COS4);
}
"""


def _pipeline() -> dict:
    return {"name": "team", "seed": 3, "stages": [
        {"id": "law", "kind": "law", "law": {"shader": "team_law.hlsl", "includes": ["include"]}, "twin": "gated_shader",
         "range": {"n": [8, 1000], "p": [0.1, 0.5]}, "rows": 20000,
         "bounds": [{"metric": "tv"}, {"metric": "mean_rel_err"}, {"metric": "twin_rows"}, {"metric": "gpu_instructions"}]},
        {"id": "blend", "kind": "blend", "blend": "distributed", "inner": "binomial",
         "range": {"cases": [[64, 16, 0.1]], "paths": 50},
         "bounds": [{"metric": "blend_tv"}, {"metric": "blend_pop_rate"}]},
        {"id": "sampler", "kind": "sampler", "wo": [0.6, 0, 0.8], "samples": 100000,
         "sampler": {"shader": "team_sampler.hlsl", "defines": {"ALPHA": 0.3, "SAMPLE_SCALE": 1.0}},
         "bounds": [{"metric": "sampler_pvalue"}, {"metric": "sampler_normalization"}, {"metric": "sampler_pdf_mismatch"}]},
        {"id": "method", "kind": "method", "pixels": 50,
         "method": {"shader": "team_ndf.glsl", "returns": "ndf", "defines": {"COS4": "c2"}},
         "range": {"theta_h_deg": [20, 40], "points": [30], "anisotropy": [1]},
         "scene": {"file": "sphere", "scale": 0.1, "frames": 2},
         "bounds": [{"metric": "mean_d_err"}, {"metric": "light_response"}]}]}


def _stage(doc, sid):
    return next(s for s in doc["stages"] if s["id"] == sid)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """The team's pipeline, recorded: (folder, recorded document, the recording's table)."""
    d = tmp_path_factory.mktemp("pipeline")
    (d / "include").mkdir()
    (d / "include" / "team_gate.h").write_text(HEADER)
    (d / "team_law.hlsl").write_text(LAW)
    (d / "team_sampler.hlsl").write_text(SAMPLER)
    (d / "team_ndf.glsl").write_text(NDF)
    (d / "pipeline.json").write_text(json.dumps(_pipeline()))
    assert main(["check", str(d / "pipeline.json"), "--record"]) == 0
    doc = json.loads((d / "pipeline.json").read_text())
    return d, doc


class SwappedWeights:
    """A blend with its two levels' weights swapped: evaluated at the area mirrored inside its level pair
    (A_lo + A_hi - P), which for the distributed binomial is exactly the blend with w and 1 - w exchanged."""

    def __init__(self, blend):
        self.blend = blend

    has_pmf = property(lambda self: self.blend.has_pmf)

    def _mirrored(self, P):
        r, base = self.blend.level_ratio, self.blend.base_area
        lo = base * r ** np.floor(np.log(np.asarray(P, dtype=float) / base) / np.log(r) + 1e-9)
        return lo * (1 + r) - P

    def pmf(self, N, P, p):
        return self.blend.pmf(N, float(self._mirrored(P)), p)

    def bin(self, x):
        return self.blend.bin(x)

    def sample_at(self, N, P, p, x, y, seed=0):
        return self.blend.sample_at(N, self._mirrored(P), p, x, y, seed=seed)


def test_swapped_weights_are_the_blend_at_the_mirrored_area():
    # The wrong blend the tests use is what its name says: K = b(w N A_lo, p) + b((1 - w) N A_hi, p), the
    # distributed binomial (DB23 eq. 10) with w and 1 - w exchanged (b with its non-integer trial rule).
    bl = gl.blended_law("distributed", base_area=16 / 4096)
    b = gl.law("binomial")
    for cells in (20, 32, 44):
        w = (cells - 16) / 48
        lo, hi = b.pmf(w * 16, 0.1), b.pmf((1 - w) * 64, 0.1)
        assert lo.support[0] == hi.support[0] == 0
        got = SwappedWeights(bl).pmf(4096, cells / 4096, 0.1)
        want = np.convolve(lo.probs, hi.probs)
        assert np.array_equal(got.support, np.arange(len(want))) and np.allclose(got.probs, want, atol=1e-12)


@vulkan
def test_recorded_pipeline_holds_and_states_how_it_was_recorded(recorded):
    d, doc = recorded
    assert set(doc["recorded"]) == {"glintlab_version", "machine", "seed", "date"}
    assert doc["recorded"]["seed"] == 3 and doc["recorded"]["glintlab_version"] == gl.__version__
    for s in doc["stages"]:
        for b in s["bounds"]:
            limit = b.get("maximum", b.get("minimum"))
            assert limit is not None and b["measured"] is not None
            if "maximum" in b:  # the file's margin rule: at least 25 % above the measured value
                assert b["maximum"] >= b["measured"] * 1.25
    table = gl.check(str(d / "pipeline.json"))
    assert table.ok.all(), table[~table.ok].to_string()
    assert list(table.id) == [f"{s['id']}/{b['metric']}" for s in doc["stages"] for b in s["bounds"]]


def _wrong(d, doc, name, edit):
    wrong = copy.deepcopy(doc)
    edit(wrong)
    path = d / f"wrong_{name}.json"
    path.write_text(json.dumps(wrong))
    return path


WRONG = {
    "law": lambda doc: _stage(doc, "law")["law"].update(defines={"GATED_BUG_PLUS_ONE": 1}),  # K + 1
    "sampler": lambda doc: _stage(doc, "sampler")["sampler"]["defines"].update(SAMPLE_SCALE=1.02),  # alpha 2 % off
    "method": lambda doc: _stage(doc, "method")["method"]["defines"].update(COS4="1.0"),  # no cos^4
}


@vulkan
@pytest.mark.parametrize("stage", ["law", "blend", "sampler", "method"])
def test_a_wrong_stage_fails_its_bounds_and_only_there(recorded, stage):
    d, doc = recorded
    if stage == "blend":
        path, sub = d / "pipeline.json", {"blend": lambda a: SwappedWeights(gl.blended_law("distributed", base_area=a))}
    else:
        path, sub = _wrong(d, doc, stage, WRONG[stage]), None
    table = gl.check(str(path), substitute=sub)
    bad = table[~table.ok]
    assert len(bad) and set(bad.stage) == {stage}, table.to_string()
    if stage == "method":  # the NDF read at the wrong lobe: its light response's lobe check sees it too
        assert set(bad.metric) == {"mean_d_err", "light_response"}, table.to_string()


@vulkan
def test_cli_exit_codes_junit_and_rerecording_diff(recorded, tmp_path, capsys):
    d, doc = recorded
    wrong = _wrong(d, doc, "law_cli", WRONG["law"])
    assert main(["check", str(wrong), "--junit", str(tmp_path / "c.xml"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "VIOLATED law/mean_rel_err" in err and "VIOLATED blend" not in err
    suite = ET.parse(tmp_path / "c.xml").getroot()
    cases = suite.findall("testcase")
    assert len(cases) == sum(len(s["bounds"]) for s in doc["stages"]) == int(suite.get("tests"))
    failed = {c.get("name") for c in cases if c.find("failure") is not None}
    assert failed and all(n.startswith("law/") for n in failed)
    # Re-recording the same pipeline on the same seed changes nothing; a hand-edited bound shows in the diff.
    again = _wrong(d, doc, "again", lambda x: _stage(x, "blend")["bounds"][1].update(maximum=0.5))
    assert main(["check", str(again), "--record"]) == 0
    out = capsys.readouterr().out
    assert "blend/blend_pop_rate: bound 0.5 -> 1e-09" in out and "law/tv" not in out
    assert main(["check", str(again), "--record"]) == 0
    assert "no bound changed" in capsys.readouterr().out


@vulkan
def test_recording_a_failing_stage_says_so(recorded, tmp_path, capsys):
    d, doc = recorded
    # A sampler failing its chi-square test keeps its fixed level: recording it is a violation (exit 1).
    wrong = _wrong(d, doc, "sampler_rec", WRONG["sampler"])
    assert main(["check", str(wrong), "--record"]) == 1
    assert "VIOLATED sampler/sampler_pvalue" in capsys.readouterr().err
    # A shader returning NaN measures nothing: nothing is recorded, and its check fails (exit 1, not 2).
    (d / "nan_law.hlsl").write_text("float count(float n, float p, float4 u) { return sqrt(-1.0 - u.x); }\n")
    nan = _wrong(d, doc, "nan", lambda x: _stage(x, "law")["law"].update(shader="nan_law.hlsl"))
    before = nan.read_text()
    assert main(["check", str(nan), "--record"]) == 1
    assert "cannot record law/tv: it measured nan" in capsys.readouterr().err and nan.read_text() == before
    assert main(["check", str(nan), "--quiet"]) == 1
    assert "VIOLATED law/tv" in capsys.readouterr().err


BAD = [
    ({"stages": []}, "/stages"),
    ({"stages": [{"id": "a", "kind": "law", "law": "gated", "bounds": [{"metric": "tv", "maximum": -1}]}]},
     "/stages/0/bounds/0/maximum"),
    ({"stages": [{"id": "a", "kind": "law", "law": "gated", "bounds": [{"metric": "blend_tv"}]}]},
     "/stages/0/bounds/0/metric"),
    ({"stages": [{"id": "a", "kind": "law", "law": "gated", "bounds": [{"metric": "twin_rows"}]}]},
     "/stages/0/bounds/0/metric"),
    ({"stages": [{"id": "a", "kind": "law", "law": "gated", "bounds": [{"metric": "tv", "minimum": 0.1}]}]},
     "/stages/0/bounds/0/minimum"),
    ({"stages": [{"id": "a", "kind": "blend", "blend": "nope", "bounds": [{"metric": "blend_tv"}]}]}, "/stages/0/blend"),
    ({"stages": [{"id": "a", "kind": "law", "law": {"shader": "missing.hlsl"}, "bounds": [{"metric": "tv"}]}]},
     "/stages/0/law/shader"),
    ({"stages": [{"id": "a", "kind": "grid", "scheme": "db23", "bounds": [{"metric": "grid_count_bias"}]}]},
     "/stages/0/scheme"),
    ({"stages": [{"id": "a", "kind": "law", "law": "gated", "bounds": [{"metric": "tv"}]},
                 {"id": "a", "kind": "law", "law": "zk16", "bounds": [{"metric": "tv"}]}]}, "/stages/1/id"),
    ({"stages": [{"id": "a", "kind": "sampler", "sampler": "ggx", "samples": 10, "bounds": [{"metric": "sampler_pvalue"}]}]},
     "/stages/0/samples"),
]


@pytest.mark.parametrize("doc, pointer", BAD, ids=[p for _, p in BAD])
def test_bad_pipeline_files_exit_2_naming_the_pointer(tmp_path, capsys, doc, pointer):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    assert main(["check", str(path)]) == 2
    assert f"{path}: at {pointer}: expected" in capsys.readouterr().err


def test_a_metric_registered_later_plugs_in():
    snapshot = P.PIPELINE_METRICS.snapshot()
    try:
        def hellinger(stage):  # the law's Hellinger distance to the binomial at the range's points
            pts = regime_points(stage.spec["range"])
            vals = [gl.distance(stage.obj.pmf(n, p), gl.law("binomial").pmf(n, p), "hellinger") for n, p in pts]
            return P.Measured(max(vals), points=len(pts))
        gl.register_pipeline_metric("hellinger", "law", "max", hellinger, "Hellinger distance to the binomial",
                                    "0 (exact)", "one pmf per point")
        doc = {"stages": [{"id": "a", "kind": "law", "law": "gated", "range": {"n": [8, 1000], "p": [0.1]},
                           "bounds": [{"metric": "hellinger", "maximum": 1e-3}, {"metric": "tv", "maximum": 1.0}]}]}
        table = gl.check(doc)
        assert list(table.metric) == ["hellinger", "tv"] and not table.ok.iloc[0] and table.ok.iloc[1]
        assert "hellinger" in set(gl.pipeline_metrics().name)
    finally:
        P.PIPELINE_METRICS.restore(snapshot)
    with pytest.raises(ValueError, match="kinds"):
        gl.register_pipeline_metric("x", "nope", "max", hellinger, "", "", "")


def test_every_registered_metric_has_its_row_in_the_guide():
    guide = (Path(__file__).resolve().parents[2] / "docs" / "guide" / "ci_pipeline.md").read_text()
    rows = {m for line in guide.splitlines() if line.startswith("| `") for m in re.findall(r"`(\w+)`", line.split("|")[1])}
    names = set(gl.pipeline_metrics().name)
    assert len(names) >= 18 and names <= rows, names - rows


# A team's law whose count is DB23's gated law plus a uniform offset: 0 is the gated law, 1 the K+1 bug.
OFFSET_LAW = ('#define GLINTLAB_HLSL\n#include "glintlab_prelude.h"\n#define count gated_count\n'
              '#include "gated_body.h"\n#undef count\ncbuffer Team { float team_offset; };\n'
              'float count(float n, float p, float4 u) { return gated_count(n, p, u) + team_offset; }\n')


@vulkan
def test_shader_uniforms_pass_through_only_when_given(tmp_path):
    (tmp_path / "s.hlsl").write_text(OFFSET_LAW)

    def doc(**options):
        law = {"shader": str(tmp_path / "s.hlsl"), **options}
        return {"seed": 3, "stages": [{"id": "a", "kind": "law", "law": law, "bounds": [{"metric": "tv"}]}]}
    # Given, the uniform reaches the shader: offset 0 is the gated law, offset 1 its K+1 bug (larger TV).
    tv = {k: P.check_pipeline(doc(uniforms={"team_offset": k}))["worst"].iloc[0] for k in (0.0, 1.0)}
    shipped = {"seed": 3, "stages": [{"id": "a", "kind": "law", "law": "gated_shader", "bounds": [{"metric": "tv"}]}]}
    assert tv[0.0] == pytest.approx(P.check_pipeline(shipped)["worst"].iloc[0], rel=1e-9) and tv[1.0] > tv[0.0]
    # Not given, the shader's declared block is left unbound: the file's error naming it (exit 2), not a crash.
    with pytest.raises(ValueError, match="team_offset|Team"):
        gl.check(doc())


def test_shipped_pipelines_cover_the_configurations_and_are_recorded():
    names = sorted(p.stem for p in data_path("pipelines").glob("*.json"))
    assert names == ["db23_paper", "db23_shader_48", "kpt25", "wwh18_filtered", "zk16"]
    for name in names:
        doc, _, _ = P.load_pipeline(data_path("pipelines", f"{name}.json"))
        assert doc["recorded"]["seed"] == doc["seed"] and doc["margin"]["relative"] == 0.25
        assert {"method", "sampler"} <= {s["kind"] for s in doc["stages"]}
        for s in doc["stages"]:
            assert all(("maximum" in b) != ("minimum" in b) and b["measured"] is not None for b in s["bounds"])


@vulkan
def test_a_method_shader_against_its_twin_and_on_a_scene(tmp_path):
    # The shipped DB23 method shader matches its C++ twin on every pixel of a frame; another shader
    # checked against that twin (the smooth NDF's) does not: the pixel check can fail.
    scene = {"file": "sphere", "scale": 0.05, "frames": 2}
    doc = {"stages": [
        {"id": "db23", "kind": "method", "method": "db23_shader", "twin": "db23_shader", "scene": scene,
         "bounds": [{"metric": "twin_pixels", "maximum": 1e-9}]},
        {"id": "other", "kind": "method", "method": "smooth_shader", "twin": "db23_shader", "scene": scene,
         "bounds": [{"metric": "twin_pixels", "maximum": 1e-9}]},
        {"id": "scene", "kind": "method", "method": "db23_trilinear[gated]", "scene": scene,
         "bounds": [{"metric": "scene_std_ratio_err", "maximum": 1.0}, {"metric": "scene_pop_rate", "maximum": 1.0}]}]}
    table = gl.check(doc).set_index("id")
    assert table.loc["db23/twin_pixels"].ok and table.loc["db23/twin_pixels"].worst == 0
    assert not table.loc["other/twin_pixels"].ok and table.loc["other/twin_pixels"].worst > 0.5
    assert table.loc["scene/scene_std_ratio_err"].ok and table.loc["scene/scene_pop_rate"].ok
    # A scene metric needs a named image method and a scene: exit 2 at the bound otherwise.
    doc["stages"][2].pop("scene")
    with pytest.raises(ValueError, match=r"at /stages/2/bounds/0/metric: expected a metric that applies"):
        gl.check(doc)
