"""The guide's engine sampler that returns L (docs/guide/engine_code.md#engine-sampler-l): the glue printed on
the page, run as printed on examples/engine/engine_sampler_l.hlsl, is at most ten lines and passes; the same
glue on the file without its Jacobian line fails.

False-failure rate: one verdict at the harness's significance 1e-3 (seed 11, so a run is reproducible). The
wrong variant is rejected at p = 0 (its pdf integrates to about 3 over the hemisphere)."""
from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path

import pytest

import glintlab as gl

pytestmark = pytest.mark.skipif(not gl.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = "examples/engine/engine_sampler_l.hlsl"
JACOBIAN = "  pdf /= 4.0 * VoH;\n"


def _glue() -> str:
    """The section's Python block, as printed."""
    page = (ROOT / "docs" / "guide" / "engine_code.md").read_text()
    section = page[page.index("(engine-sampler-l)="):]
    section = section[:m.start()] if (m := re.search(r"^\(.+\)=$", section[1:], flags=re.M)) else section
    return re.search(r"```python\n(.*?)```", section, flags=re.S).group(1)


def _run(glue: str) -> dict:
    scope = {}
    old = os.getcwd()
    os.chdir(ROOT)  # the page runs it from the repository's root
    try:
        with contextlib.redirect_stdout(io.StringIO()) as out:
            exec(compile(glue, "engine_code.md", "exec"), scope)
    finally:
        os.chdir(old)
    scope["printed"] = out.getvalue()
    return scope


def test_the_glue_is_at_most_ten_lines_and_passes():
    glue = _glue()
    lines = [ln for ln in glue.splitlines() if ln.strip() and not ln.strip().startswith("#")]
    assert len(lines) <= 10, lines  # counted: 4 (the import included)
    assert EXAMPLE in glue
    scope = _run(glue)
    res, s = scope["res"], scope["s"]
    assert s.functions == ("sample_l", "pdf_l") and res.passed and res.mismatches == 0, repr(res)
    assert scope["printed"].startswith("('sample_l', 'pdf_l') pass")


def test_the_same_glue_fails_without_the_jacobian(tmp_path):
    code = (ROOT / EXAMPLE).read_text()
    assert code.count(JACOBIAN) == 1
    wrong = tmp_path / "engine_sampler_l.hlsl"
    wrong.write_text(code.replace(JACOBIAN, ""))
    scope = _run(_glue().replace(EXAMPLE, str(wrong)))
    res = scope["res"]
    assert res.verdict == "FAIL" and res.pvalue < 1e-12 and res.integral > 2.5, repr(res)
    assert " FAIL " in scope["printed"]
