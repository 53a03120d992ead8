"""The HLSL glintlab compiles is glslang's HLSL (through shaderc), not DXC's: which constructs it takes.

``CONSTRUCTS`` is the one table: each row a construct, a counting-law shader using it, whether glslang
compiles it, and for the DXC-only ones how to rewrite it. tests/python/test_hlsl_dialect.py compiles every
row (so the table is measured, not remembered) and checks that docs/guide/shaders.md#the-hlsl-dialect
shows the same table; a shader that fails to compile and uses a DXC-only construct gets that row's advice
in its one-line error (:func:`dxc_only_hint`, from ``shaders.compile_error``).
"""
from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class Construct:
    name: str         # as the docs table names it
    code: str         # a counting-law shader (float count(float n, float p, float4 u)) using it
    compiles: bool    # whether glslang's HLSL compiles it (measured by the test)
    pattern: str = ""   # a regular expression finding the construct in a source (DXC-only rows)
    rewrite: str = ""   # how to write it for glslang (DXC-only rows)


_COUNT = "float count(float n, float p, float4 u) { return %s; }"

CONSTRUCTS = (
    Construct("namespace with functions",
              "namespace glint { float half_of(float x) { return 0.5 * x; } }\n" + _COUNT % "glint::half_of(2.0 * n * p)",
              True),
    Construct("nested namespaces",
              "namespace a { namespace b { float f(float x) { return x; } } }\n" + _COUNT % "a::b::f(n * p)", True),
    Construct("a struct type declared in a namespace",
              "namespace glint { struct Lobe { float a; }; }\n"
              "float count(float n, float p, float4 u) { glint::Lobe l; l.a = n * p; return l.a; }", False,
              r"namespace\s+\w+\s*\{[^}]*\bstruct\b", "declare the struct outside the namespace"),
    Construct("static const in a namespace, named with its namespace",
              "namespace glint { static const float kHalf = 0.5; }\n" + _COUNT % "glint::kHalf * 2.0 * n * p", True),
    Construct("static const in a namespace, used unqualified inside it",
              "namespace glint { static const float kHalf = 0.5; float f(float x) { return kHalf * x; } }\n"
              + _COUNT % "glint::f(2.0 * n * p)", False,
              r"namespace\s+\w+\s*\{[^}]*\bstatic\s+const\b",
              "name the constant with its namespace inside the namespace too (glint::kHalf), or move it out"),
    Construct("using namespace",
              "namespace glint { float f(float x) { return x; } }\nusing namespace glint;\n" + _COUNT % "f(n * p)", False,
              r"\busing\s+namespace\b", "name each function with its namespace (glint::f)"),
    Construct("static const at global scope, arrays and structs",
              "struct S { float a; float b; };\nstatic const S kS = { 0.25, 0.5 };\n"
              "static const float kW[3] = { 0.25, 0.5, 0.25 };\n" + _COUNT % "4.0 * kS.a * kW[1] * 2.0 * n * p", True),
    Construct("templates (HLSL 2021)",
              "template <typename T> T twice(T x) { return x + x; }\n" + _COUNT % "0.5 * twice(n * p)", False,
              r"\btemplate\s*<", "write one function per type (overloads), or a macro"),
    Construct("operator overloading (HLSL 2021)",
              "struct V { float x; V operator+(V o) { V r; r.x = x + o.x; return r; } };\n"
              "float count(float n, float p, float4 u) { V a; a.x = n * p; V b = a + a; return b.x * 0.5; }", False,
              r"\boperator\s*[-+*/<>=!]", "a named function (add(a, b)) in place of the operator"),
    Construct("select() (HLSL 2021)",
              _COUNT % "select(u.x < 2.0, n * p, 0.0)", False,
              r"\bselect\s*\(", "the ternary operator: c ? a : b (per component on vectors)"),
    Construct("enum",
              "enum Mode { Plain, Twice };\n" + _COUNT % "(Plain == 0 ? n * p : 0.0)", False,
              r"\benum\b", "static const int values (or #defines) in place of the enum"),
    Construct("[unroll] and [loop] attributes",
              "float count(float n, float p, float4 u) { float s = 0.0; [unroll] for (int i = 0; i < 4; ++i) "
              "s += 0.25; [loop] for (int j = 0; j < 2; ++j) s += 0.0; return s * n * p; }", True),
    Construct("[branch] and [flatten] attributes",
              "float count(float n, float p, float4 u) { float r = n * p; [branch] if (u.x < 0.0) r = 0.0; "
              "[flatten] if (u.y < 0.0) r = 1.0; return r; }", True),
    Construct("cbuffer with packoffset (bound by name: uniforms=)",
              "cbuffer Material { float kScale : packoffset(c0); };\n" + _COUNT % "0.5 * kScale * n * p", True),
    Construct("struct with a member function",
              "struct Lobe { float a; float scale(float x) { return a * x; } };\n"
              "float count(float n, float p, float4 u) { Lobe l; l.a = 1.0; return l.scale(n * p); }", True),
    Construct("default parameter values",
              "float f(float x, float y = 1.0) { return x * y; }\n" + _COUNT % "f(n * p)", True),
    Construct("inout and out parameters",
              "void twice(inout float x, out float y) { x *= 2.0; y = x; }\n"
              "float count(float n, float p, float4 u) { float x = n * p * 0.5; float y; twice(x, y); return y; }",
              True),
    Construct("min16float, half and the h suffix",
              "float count(float n, float p, float4 u) { min16float a = (min16float)(n * p); half b = (half)a; "
              "return (float)b * 1.0h; }", True),
    Construct("float3x3 and mul()",
              "float count(float n, float p, float4 u) { float3x3 m = float3x3(1, 0, 0, 0, 1, 0, 0, 0, 1); "
              "return mul(m, float3(n * p, 0, 0)).x; }", True),
    Construct("sincos, asuint, firstbithigh",
              "float count(float n, float p, float4 u) { float s, c; sincos(0.0, s, c); "
              "return c * n * p + 0.0 * float(firstbithigh(asuint(p))); }", True),
)


def dxc_only_hint(code: str) -> str:
    """The advice for the first DXC-only construct ``code`` uses ("" when none), for a failed compile."""
    for row in CONSTRUCTS:
        if not row.compiles and row.pattern and re.search(row.pattern, code, re.S):
            return (f"{row.name} is DXC-only: glintlab compiles HLSL with glslang (shaderc), which does not "
                    f"take it; {row.rewrite}")
    return ""


def markdown_table() -> str:
    """The docs page's table (docs/guide/shaders.md#the-hlsl-dialect), one row per construct."""
    lines = ["| construct | glslang (glintlab) | rewrite |", "|---|---|---|"]
    for row in CONSTRUCTS:
        lines.append(f"| {row.name} | {'compiles' if row.compiles else 'DXC only'} | {row.rewrite or ''} |")
    return "\n".join(lines)
