"""One option set for the commands that compile the user's shader code (issue 38, item 5): `glintlab shader`,
`sampler`, `images` (and `cost`) take -I/--include-dir, -D/--define NAME=VALUE and --device from one definition
(cli/common.py: add_shader_options, read back by shader_options), and every --samples takes 2e5.
No statistical verdict here: the sampler runs below check exit codes of verdicts whose false-failure rate is
the harness's significance 1e-3 (seed 1), and the defines are checked by compile errors, which cannot pass
by chance."""
from __future__ import annotations

import argparse

import pytest

import glintlab as gl
from glintlab.api.glinty_ndf import IMAGE_METHODS
from glintlab.cli.common import add_shader_options, shader_options
from glintlab.cli.main import build_parser, main
from glintlab.resources import data_path

COMMANDS = ("shader", "sampler", "images", "cost")
needs_vulkan = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")


def _subparser(name):
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


def _shader_actions(parser):
    return {a.dest: (tuple(a.option_strings), a.help, a.default) for a in parser._actions
            if a.dest in ("include_dirs", "defines", "device")}


def test_the_three_commands_share_one_option_set():
    reference = argparse.ArgumentParser()
    add_shader_options(reference)
    want = _shader_actions(reference)
    assert set(want) == {"include_dirs", "defines", "device"}
    for name in COMMANDS:
        assert _shader_actions(_subparser(name)) == want, name
    args = _subparser("sampler").parse_args(["f.hlsl", "-D", "A=1", "--define", "B", "-I", "x", "--include-dir", "y",
                                             "--include", "z", "--samples", "2e5"])
    assert shader_options(args) == {"defines": {"A": "1", "B": "1"}, "include_dirs": ["x", "y", "z"], "device": "auto"}
    assert args.samples == 200_000
    assert _subparser("shader").parse_args(["f.hlsl", "--samples", "2.5e5"]).samples == 250_000


def test_a_define_without_a_name_is_bad_input(capsys):
    assert main(["sampler", str(gl.shipped_sampler("ggx_vndf")), "-D", "=3", "--samples", "1000"]) == 2
    assert "--define = '=3' is invalid" in capsys.readouterr().err


@needs_vulkan
def test_defines_and_include_folders_reach_each_command(tmp_path, capsys):
    # One header in a folder of its own, needed by a shader of each kind, with a define it requires.
    inc = tmp_path / "inc"
    inc.mkdir()
    (inc / "gain.h").write_text("#ifndef GAIN\n#error GAIN is not defined\n#endif\n")
    law = tmp_path / "law.hlsl"
    law.write_text('#include "gain.h"\nfloat count(float n, float p, float4 u) { return floor(n * p * GAIN); }\n')
    sampler = tmp_path / "samp.hlsl"
    sampler.write_text('#include "gain.h"\n#define ALPHA (0.3 * GAIN)\n#include "ggx_vndf_body.h"\n')
    method = tmp_path / "gainy.hlsl"
    method.write_text('#include "gain.h"\nfloat glint(GlintInput g) { return GAIN * frac(g.uv.x * 7.0); }\n')
    out = ["--out", str(tmp_path / "o"), "--quiet"]
    scene = str(data_path("scenes", "plane_90.json"))
    images = ["images", scene, "--scale", "0.03", "--frames", "2", "--timing-scale", "0.03", "--method", str(method)]
    runs = {"shader": ["shader", str(law), "--samples", "2e3", "--grid-samples", "64", "--grid-stride", "16",
                       "--speed-evaluations", "1e3"],
            "sampler": ["sampler", str(sampler), "--samples", "2e4"], "images": images}
    try:
        for name, argv in runs.items():
            capsys.readouterr()
            assert main(argv + out) == 2, name  # the include folder missing: gain.h not found
            assert "gain.h" in capsys.readouterr().err, name
            assert main(argv + out + ["-I", str(inc)]) == 2, name  # found, without its define
            assert "GAIN is not defined" in capsys.readouterr().err, name
            rc = main(argv + out + ["-I", str(inc), "-D", "GAIN=1"])
            # The law floor(n p) is no binomial (exit 1, a verdict); the sampler and the images run (exit 0).
            assert rc == (1 if name == "shader" else 0), (name, capsys.readouterr().err)
    finally:
        IMAGE_METHODS._items.pop("gainy", None)
