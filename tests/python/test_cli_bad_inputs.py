"""Every subcommand against a table of bad inputs: exit 2 ("bad input", never 1, which means a check
failed) with one line on stderr naming the file or flag, and never a traceback. Run in-process: an
uncaught exception fails the test by itself."""
import json
import os
import subprocess
import sys

import pytest

from glintlab.cli.main import main
from glintlab.resources import data_path

SCENE = str(data_path("scenes", "plane_90.json"))


@pytest.fixture()
def files(tmp_path):
    f = {}
    f["a_file"] = tmp_path / "a_file"
    f["a_file"].write_text("x")
    f["folder"] = tmp_path / "folder"
    f["folder"].mkdir()
    f["deep"] = tmp_path / "deep.json"
    f["deep"].write_text("[" * 100_000 + "]" * 100_000)
    f["deep_obj"] = tmp_path / "deep_obj.json"
    f["deep_obj"].write_text('{"a":' * 50_000 + "1" + "}" * 50_000)
    f["syntax"] = tmp_path / "broken_law.py"
    f["syntax"].write_text("def count(n, p, u:\n    return n\n")
    f["bad_shader"] = tmp_path / "broken.hlsl"
    f["bad_shader"].write_text("float count(float n, float p, float4 u) {\n  return n * p +;\n}\n")
    f["latin1_shader"] = tmp_path / "latin1.hlsl"
    f["latin1_shader"].write_bytes(b"// caf\xe9\nfloat count(float n, float p, float4 u) { return n; }\n")
    f["set1_shader"] = tmp_path / "set1.glsl"
    f["set1_shader"].write_text("layout(std430, set = 1, binding = 0) readonly buffer X { float x[]; };\n"
                                "float count(float n, float p, vec4 u) { return x[0]; }\n")
    f["cycle_shader"] = tmp_path / "cycle.hlsl"
    f["cycle_shader"].write_text('#include "cycle.hlsl"\nfloat count(float n, float p, float4 u) { return n; }\n')
    f["law"] = tmp_path / "good_law.py"
    f["law"].write_text("def count(n, p, u):\n    return n * p + 0 * u[..., 0]\n")
    bad_scene = json.loads(open(SCENE).read())
    bad_scene["material"]["R"] = 5
    f["bad_scene"] = tmp_path / "bad_scene.json"
    f["bad_scene"].write_text(json.dumps(bad_scene))
    f["readonly"] = tmp_path / "readonly"
    f["readonly"].mkdir()
    os.chmod(f["readonly"], 0o500)
    yield f
    os.chmod(f["readonly"], 0o700)


SWEEP = ["sweep", "--laws", "gated", "--n", "16", "--p", "0.1"]
# (command line with {placeholders} from the fixture, text the one-line message must contain)
CASES = [
    (SWEEP + ["--out", "{a_file}"], "--out"),
    (SWEEP + ["--out", "{readonly}/sub"], "readonly"),
    (SWEEP + ["--store", "{folder}"], "--store"),
    (SWEEP + ["--n", "nan"], "--n = 'nan'"),
    (SWEEP + ["--p", "inf"], "--p = 'inf'"),
    (SWEEP + ["--n", "logspace:0:nan:3"], "--n"),
    (SWEEP + ["--samples", "100000000000"], "/samples"),
    (SWEEP + ["--scheduler", "nonsense"], "scheduler = 'nonsense'"),
    (["sweep", "--laws", "{syntax}:count", "--n", "16", "--p", "0.1"], "broken_law.py:1"),
    (["sweep", "--laws", "{law}:missing", "--n", "16", "--p", "0.1"], "missing"),
    (["sweep", "--laws", "{law}:count:n_uniforms=two", "--n", "16", "--p", "0.1"], "n_uniforms"),
    (["sweep", "--laws", "gated", "--name", "../x"], "--name"),
    (["run", "{deep}"], "deep.json"),
    (["run", "{deep_obj}"], "deep_obj.json"),
    (["run", "{folder}/missing.json"], "missing.json"),
    (["run", "{a_file}"], "a_file"),
    (["check", "{deep}"], "deep.json"),
    (["check", "--junit", "{folder}"], "--junit"),
    (["check", "{folder}/none.json"], "none.json"),
    (["profile", "{bad_scene}", "--out", "{folder}/p"], "/material/R"),
    (["profile", "{deep}", "--out", "{folder}/p"], "deep.json"),
    (["advise", "{deep}", "--max-tv", "0.1"], "deep.json"),
    (["advise", SCENE], "budget"),
    (["report", "--config", "{deep}", "--out", "{folder}/r"], "deep.json"),
    (["report", "--out", "{a_file}"], "--out"),
    (["extremes", "--laws", "nosuchlaw", "--out", "{folder}/e"], "nosuchlaw"),
    (["extremes", "--out", "{a_file}"], "--out"),
    (["bench", "--laws", "{syntax}:count", "--out", "{folder}/b"], "broken_law.py:1"),
    (["bench", "--out", "{a_file}"], "--out"),
    (["aniso", "--samples", "0", "--out", "{folder}/a"], "samples = 0"),
    (["images", "{bad_scene}", "--out", "{folder}/i"], "/material/R"),
    (["images", "{deep}", "--out", "{folder}/i"], "deep.json"),
    (["images", SCENE, "--out", "{a_file}"], "--out"),
    (["images", SCENE, "--look", "highlight", "--highlight-alpha", "1.5", "--out", "{folder}/i"], "highlight_alpha = 1.5"),
    (["shader", "{folder}/missing.hlsl", "--out", "{folder}/s"], "missing.hlsl"),
    (["shader", "{syntax}", "--out", "{folder}/s"], "language = None"),
    (["shader", "{bad_shader}", "--out", "{folder}/s"], "broken.hlsl:2"),
    (["shader", "{a_file}", "--out", "{a_file}"], "--out"),
    (["shader", "typo.txt", "--out", "{folder}/s"], "source = 'typo.txt'"),
    (["shader", "{folder}", "--out", "{folder}/s"], "not a folder"),
    (["shader", "{latin1_shader}", "--out", "{folder}/s"], "byte 0xe9 at offset 6"),
    (["shader", "{set1_shader}", "--out", "{folder}/s"], "data for the storage buffer 'X'"),
    (["shader", "{cycle_shader}", "--out", "{folder}/s"], "#include cycle cycle.hlsl -> cycle.hlsl"),
    (["shader", "{bad_shader}", "--samples", "1.5", "--out", "{folder}/s"], "--samples"),
    (["shader", "{bad_shader}", "--samples", "1e400", "--out", "{folder}/s"], "--samples"),
    (["shader", "{bad_shader}", "--timeout", "0", "--out", "{folder}/s"], "--timeout = 0"),
    (["shader", "{bad_shader}", "--device", "", "--out", "{folder}/s"], "device = ''"),
    (["sampler", "nosuch", "--out", "{folder}/q"], "sampler = 'nosuch'"),
    (["sampler", "{folder}/missing.hlsl", "--out", "{folder}/q"], "missing.hlsl"),
    (["sampler", "ggx", "--samples", "-5", "--out", "{folder}/q"], "--samples = -5"),
    (["sampler", "ggx", "--param", "alpha=-1", "--out", "{folder}/q"], "alpha = -1.0"),
    (["sampler", "ggx", "--param", "junk", "--out", "{folder}/q"], "--param = 'junk'"),
    (["sampler", "ggx", "--bins", "0x3", "--out", "{folder}/q"], "bins = (0, 3)"),
    (["sampler", "ggx", "--wrong", "nope", "--out", "{folder}/q"], "--wrong"),
    (["sampler", "ggx", "--out", "{a_file}"], "--out"),
    (["images", SCENE, "--method", "{folder}/none.hlsl", "--out", "{folder}/i"], "none.hlsl"),
    (["images", SCENE, "--method", "{bad_shader}", "--out", "{folder}/i"], "broken.hlsl"),
    (["aniso", "--out", "{readonly}/a"], "readonly"),
]


@pytest.mark.parametrize("argv,needle", CASES, ids=[" ".join(c[0])[:60] for c in CASES])
def test_bad_input_exits_2_with_one_line(argv, needle, files, capsys, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    if os.geteuid() == 0 and "{readonly}" in " ".join(argv):
        pytest.skip("root writes into a read-only folder")
    args = [a.format(**files) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("glintlab ")]
    assert len(lines) == 1, err
    # The line names the flag or file; a shader's compile error follows it with the compiler's own
    # messages (file:line: error ...).
    assert needle in (err if "the compiler says" in lines[0] else lines[0]), err


def test_an_unwritable_output_is_refused_before_the_work(tmp_path, capsys):
    # A result is never computed and then lost: an --out under a file is refused at once (this sweep
    # would take minutes), and a refused command leaves no folder behind.
    (tmp_path / "f").write_text("x")
    argv = ["sweep", "--laws", "binomial", "--samples", "1000000000", "--out", str(tmp_path / "f" / "sub")]
    assert main(argv) == 2
    assert "is a file, expected a folder" in capsys.readouterr().err
    assert main(SWEEP[:2] + ["nosuchlaw", "--n", "16", "--p", "0.1", "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


def _run_child(code, tmp_path, stdin=None, script=None):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    argv = [sys.executable] + ([str(script)] if script else ["-"])
    return subprocess.run(argv, input=stdin if stdin is not None else None, capture_output=True,
                          text=True, timeout=120, cwd=tmp_path, env=env)


SWEEP_ON_DASK = ("import glintlab as gl\n"
                 "gl.sweep(['gated'], n=[16], p=[0.1], engine='dask', workers=1, progress=False)\n")


def test_local_cluster_from_stdin_is_refused_at_once(tmp_path):
    run = _run_child(None, tmp_path, stdin=SWEEP_ON_DASK)
    assert run.returncode == 1
    assert "no file" in run.stderr and "stdin" in run.stderr, run.stderr[-2000:]


def test_local_cluster_without_main_guard_is_refused_at_once(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text(SWEEP_ON_DASK)
    run = _run_child(None, tmp_path, script=script)
    assert run.returncode == 1
    assert "unguarded.py:2" in run.stderr and "__main__" in run.stderr, run.stderr[-2000:]
