"""A macro that expands exponentially (#define A1 A0 A0, ... A40) is refused by name within a second,
with bounded memory (issue 31 item 2's leftover: compilation runs in this process and cannot be
interrupted, so timeout= cannot stop glslang; the #define lines are bounded before it expands them)."""
import functools
import subprocess
import sys

import pytest

import glintlab as gl
from glintlab.api import shaders as S

pytestmark = pytest.mark.skipif(not S.vulkan_devices(), reason="no Vulkan device (install mesa-vulkan-drivers)")

shader_law = functools.partial(gl.shader_law, register=False)
COUNT = "float count(float n, float p, float4 u) {{ return {}; }}\n"


def doubling(prefix, levels, function_like=False):
    """#define lines where each level repeats the previous twice: 2^levels tokens at the top."""
    if function_like:
        return f"#define {prefix}0(x) x\n" + "".join(f"#define {prefix}{k}(x) {prefix}{k - 1}(x) + {prefix}{k - 1}(x)\n"
                                                      for k in range(1, levels + 1))
    return f"#define {prefix}0 1.0\n" + "".join(f"#define {prefix}{k} {prefix}{k - 1} + {prefix}{k - 1}\n"
                                              for k in range(1, levels + 1))


CHILD = r"""
import resource, sys, time
resource.setrlimit(resource.RLIMIT_AS, (6 << 30, 6 << 30))  # a regression fails here, not the machine
import glintlab as gl
for path in sys.argv[1:]:
    t0 = time.perf_counter()
    try:
        gl.shader_law(path, register=False)
        print(path, "COMPILED")
    except ValueError as e:
        print(path, round(time.perf_counter() - t0, 2), str(e).replace("\n", " | "))
"""


def test_exponential_macros_are_refused_within_seconds(tmp_path):
    # Before: glslang expanded A40 (2^40 tokens) until memory ran out. In one child process with a memory
    # cap and a timeout, so that a regression cannot take the machine: in the file, in an included file,
    # and as a function-like chain.
    (tmp_path / "grow.hlsli").write_text(doubling("A", 40))
    (tmp_path / "include.hlsl").write_text('#include "grow.hlsli"\n' + COUNT.format("A40"))
    (tmp_path / "file.hlsl").write_text(doubling("A", 40) + COUNT.format("A40"))
    (tmp_path / "function_like.hlsl").write_text(doubling("A", 40, True) + COUNT.format("A40(n)"))
    # Growth at a call site: D repeats its argument, 40 nested calls make 2^40 copies of n.
    (tmp_path / "nested.hlsl").write_text("#define D(x) (x + x)\n" + COUNT.format("D(" * 40 + "n" + ")" * 40))
    files = [str(tmp_path / f"{w}.hlsl") for w in ("file", "include", "function_like", "nested")]
    run = subprocess.run([sys.executable, "-c", CHILD, *files], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr[-2000:]
    lines = {line.split()[0]: line.split(" ", 2)[1:] for line in run.stdout.splitlines()}
    for where, path in zip(("file", "include", "function_like", "nested"), files):
        seconds, message = lines[path]
        assert float(seconds) < 5, run.stdout
        assert ("grow.hlsli" if where == "include" else f"{where}.hlsl") in message, run.stdout
        if where == "nested":
            assert "the code of nested.hlsl (nested calls of function-like macros) expands to" in message, run.stdout
        elif where == "function_like":  # the bound over-counts a call's argument: refused a few levels early
            assert "macro A18 " in message, run.stdout
        else:  # the first level past 2^22 tokens: A22 (A21 has 2^22 - 1 tokens with its "+" signs)
            assert "macro A22 " in message and "expands to 8.39e+06 tokens" in message, run.stdout


def test_exponential_defines_are_refused():
    defines = {"Q0": "1.0", **{f"Q{k}": f"Q{k - 1} + Q{k - 1}" for k in range(1, 40)}}
    with pytest.raises(ValueError, match=r"macro Q22 \(from defines\) expands to"):
        shader_law(COUNT.format("Q39"), defines=defines)


def test_bounded_macros_comments_and_self_reference_still_compile():
    # 2^10 levels of repetition (2047 tokens) and 6 nested calls compile and give the right value;
    # macros in comments are not definitions; a macro naming itself is not expanded again (one token
    # for the bound).
    src = (doubling("A", 10) + "// #define C0 C1 C1 C1 C1\n/* #define D0 D1 D1 */\n#define SELF (SELF)\n"
           "#define TWICE(x) (2.0 * (x))\n#define D(x) (x + x)\n"
           + COUNT.format("TWICE(n * p) + A10 - 1024.0 + " + "D(" * 6 + "p" + ")" * 6 + " / 64.0"))
    law = shader_law(src)
    assert law.sample(8.0, 0.5, size=4, seed=1).tolist() == [8.5] * 4
