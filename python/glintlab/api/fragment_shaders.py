"""Fragment-shader glint code as written: the fragment mode of the method contract.

A renderer's glint function often lives in a GLSL fragment shader: ``#version``, ``in`` varyings from the
vertex stage, ``out vec4 fragColor``, loose ``uniform``s, ``dFdx(uv)``, ``texture()``. The fragment mode
runs that file unchanged (``shader_method("glints.frag")``, or ``mode="fragment"``):

- the code is adapted line for line (so the compiler's line numbers stay the file's): the ``#version`` and
  ``precision`` lines are dropped, ``in`` and ``out`` globals become plain globals, each loose
  ``uniform`` becomes a one-member uniform block (filled by name from ``uniforms=``, as every uniform is),
  ``void main()`` is renamed for glintlab's kernel to call;
- glintlab's compute kernel runs it four times per pixel, a quad (the pixel, one right, one down, both),
  each lane's surface moved by the pixel's differentials (uv by J, the position by the ray differentials,
  the normal by its difference to the neighbouring pixel), and ``dFdx``, ``dFdy`` and ``fwidth`` are the
  differences across the quad, as a GPU takes them between neighbouring pixels; ``texture()`` reads the
  mip level those derivatives select; ``gl_FragCoord`` is the lane's pixel centre
  (data/shaders/glintlab_fragment_glsl.h);
- each ``in`` varying, and any uniform the scene should drive, is set from a GlintInput field by
  ``varyings={"vUv": "uv", "uLightDir": "light"}``; a varying not named there is matched by its name (uv,
  texcoord -> uv; normal -> n; world / position -> world_pos; tangent -> t; bitangent / binormal -> b;
  view / eye -> view; light -> light; half -> h); one that matches nothing is refused naming it;
- the pixel's value is the one ``out`` variable's rgb (``output=`` picks one among several).

docs/guide/shaders.md#shaders-fragment.
"""
from __future__ import annotations

import re

import numpy as np

from .. import _core
from . import checks as V
from .method_shaders import GLINT_INPUT_FIELDS, ShaderMethod, check_output, frame_rows, register_fragment_factory

FIELDS = tuple(name for name, _, _ in GLINT_INPUT_FIELDS)
# A field's type in the kernel (the lane's value) and how a vec4 varying takes it (position w = 1).
_FIELD_TYPES = {"world_pos": "vec3", "uv": "vec2", "J": "vec4", "n": "vec3", "t": "vec3", "b": "vec3",
                "view": "vec3", "light": "vec3", "h": "vec3", "pixel": "uvec2", "frame": "uint", "seed": "uint"}
_GUESSES = (("bitangent", "b"), ("binormal", "b"), ("tangent", "t"), ("normal", "n"), ("texcoord", "uv"),
            ("uv", "uv"), ("world", "world_pos"), ("position", "world_pos"), ("pos", "world_pos"), ("view", "view"),
            ("eye", "view"), ("light", "light"), ("half", "h"))
_DECLARATION = re.compile(
    r"^(?P<indent>\s*)(?:layout\s*\([^)]*\)\s*)?(?:(?:flat|smooth|noperspective|centroid|highp|mediump|lowp)\s+)*"
    r"(?P<q>in|out|uniform)\s+(?:(?:highp|mediump|lowp)\s+)?(?P<type>\w+)\s+(?P<name>\w+)\s*(?P<array>\[[^\]]*\])?"
    r"\s*;(?P<rest>.*)$")
_VERSION = re.compile(r"^\s*(#\s*version\b|precision\s+\w+\s+\w+\s*;)")
_MAIN = re.compile(r"\bvoid\s+main\s*\(\s*(void)?\s*\)")
_OPAQUE = re.compile(r"^(sampler|isampler|usampler|texture|image)")


def adapt(code: str) -> tuple[str, dict]:
    """The fragment shader ``code`` as glintlab's kernel compiles it (same lines) and what it declares:
    {"in": {name: type}, "out": {name: type}, "uniform": {name: type}} (loose, non-opaque uniforms)."""
    found = {"in": {}, "out": {}, "uniform": {}}
    lines = []
    for line in code.split("\n"):
        if _VERSION.match(line):
            lines.append("// " + line.strip())
            continue
        m = _DECLARATION.match(line)
        if m and not (m.group("q") == "uniform" and _OPAQUE.match(m.group("type"))):
            q, typ, name = m.group("q"), m.group("type"), m.group("name")
            found[q][name] = typ
            decl = f"{typ} {name}{m.group('array') or ''};"
            if q == "uniform":  # a block of its own: filled by name, as a cbuffer's members are
                decl = f"layout(std140) uniform glintlab_uniform_{name} {{ {decl} }};"
            line = m.group("indent") + decl + m.group("rest")
        lines.append(_MAIN.sub("void glintlab_fragment_main()", line))
    text = "\n".join(lines)
    if not _MAIN.search(code):
        V.fail("source", "a fragment shader without void main()", "GLSL fragment code defining void main()")
    return text, found


def _guess(name: str) -> str | None:
    low = name.lower()
    return next((field for key, field in _GUESSES if key in low), None)


def plan(found: dict, varyings: dict | None, output: str | None) -> tuple[str, str, list]:
    """(assign, output, uniforms set from the scene): the GLSL setting the user's globals in each lane,
    and the expression stored."""
    varyings = dict(varyings or {})
    for name, field in varyings.items():
        if field not in _FIELD_TYPES:
            V.fail(f"varyings[{name!r}]", field, f"a GlintInput field among {', '.join(_FIELD_TYPES)}")
        if name not in found["in"] and name not in found["uniform"]:
            V.fail("varyings", name, f"an `in` variable or uniform of the shader ({', '.join(found['in'])})")
    assign = []
    for name, typ in found["in"].items():
        field = varyings.get(name) or _guess(name)
        if field is None:
            V.fail("varyings", f"nothing for `in {typ} {name}`",
                   f"varyings={{{name!r}: field}} with a GlintInput field among {', '.join(_FIELD_TYPES)}")
        assign.append(_assignment(name, typ, field))
    driven = [n for n in varyings if n in found["uniform"]]
    for name in driven:
        assign.append(_assignment(name, found["uniform"][name], varyings[name]))
    outs = list(found["out"])
    if output is None:
        if len(outs) != 1:
            V.fail("output", None, f"the `out` variable that holds the colour, one of {outs}" if outs
                   else "an `out` variable in the shader (its colour)")
        output = outs[0]
    elif output not in found["out"]:
        V.fail("output", output, f"an `out` variable of the shader ({', '.join(outs) or 'none'})")
    return "\n".join(assign), output, driven


def _assignment(name: str, typ: str, field: str) -> str:
    value = f"glintlab_{field}"
    have = _FIELD_TYPES[field]
    if typ == have:
        return f"  {name} = {value};"
    if typ == "vec4" and have == "vec3":
        return f"  {name} = vec4({value}, {'1.0' if field == 'world_pos' else '0.0'});"
    if typ == "vec3" and have == "vec2":
        return f"  {name} = vec3({value}, 0.0);"
    V.fail(f"varyings[{name!r}]", f"{typ} {name} <- {field} ({have})", "a variable of the field's type "
           "(vec4 takes a vec3 field with w = 1 for the position, 0 for directions)")


def fragment_rows(inputs, seed: int = 0, frame: int = 0, method: str = "a fragment shader"):
    """(rows, hit): frame_rows' words per hit pixel, then the differentials the quad's lanes move by:
    the position's per pixel (the ray differentials) and the normal's (its difference to the right /
    lower neighbour where that pixel sees the surface, else to the left / upper one, else 0)."""
    base, hit = frame_rows(inputs, seed, frame, method)
    if inputs.dxdpx is None:
        V.fail("inputs", "frame inputs without ray differentials", "FrameInputs from frame_inputs(scene)")
    n = np.asarray(inputs.n, np.float64)
    rows = np.zeros((base.shape[0], _core.FRAGMENT_INPUT_WORDS), np.uint32)
    rows[:, :base.shape[1]] = base
    extra = [inputs.dxdpx, inputs.dxdpy, _neighbour_difference(n, hit, 1), _neighbour_difference(n, hit, 0)]
    w = base.shape[1]  # the differentials follow GlintInput's words
    rows[:, w:w + 12] = np.concatenate([np.asarray(a, np.float32)[hit] for a in extra], axis=-1).view(np.uint32)
    return rows, hit


def _neighbour_difference(n, hit, axis):
    """The forward difference of ``n`` along ``axis`` (1: columns, 0: rows) where the next pixel is hit,
    else the backward one where the previous is, else 0."""
    size = hit.shape[axis]
    fwd = np.zeros_like(n)
    bwd = np.zeros_like(n)
    ok_f = np.zeros_like(hit)
    ok_b = np.zeros_like(hit)
    take = (slice(None),) * axis
    fwd[take + (slice(0, size - 1),)] = n[take + (slice(1, None),)] - n[take + (slice(0, size - 1),)]
    ok_f[take + (slice(0, size - 1),)] = hit[take + (slice(1, None),)]
    bwd[take + (slice(1, None),)] = n[take + (slice(1, None),)] - n[take + (slice(0, size - 1),)]
    ok_b[take + (slice(1, None),)] = hit[take + (slice(0, size - 1),)]
    return np.where(ok_f[..., None], fwd, np.where(ok_b[..., None], bwd, 0.0))


class FragmentMethod(ShaderMethod):
    """A method shader in the fragment mode (module docstring): ``run(rows)`` takes rows of
    ``_core.FRAGMENT_INPUT_WORDS`` words (:func:`fragment_rows`), ``image(inputs, seed, frame)`` a frame."""

    kind = "fragment shader"

    def _make_kernel(self, s, includes):
        return _core.MethodKernel.fragment(s["adapted"], s["source_name"], s["assign"], s["output"],
                                           [(k, str(val)) for k, val in s["defines"]], list(s["include_dirs"]),
                                           s["device"], includes)

    def run(self, rows) -> np.ndarray:
        """The shader on packed fragment rows (m, _core.FRAGMENT_INPUT_WORDS) uint32: (m, 4) float32, (r, g, b, 3)."""
        rows = np.ascontiguousarray(rows, dtype=np.uint32)
        words = _core.FRAGMENT_INPUT_WORDS
        if rows.ndim != 2 or rows.shape[1] != words:
            V.fail("rows", f"an array of shape {rows.shape}", f"an array of shape (m, {words}) (fragment_rows)")
        return self._kernel.run(rows, self._spec["timeout"])

    def image(self, inputs, seed: int = 0, frame: int = 0) -> np.ndarray:
        """One frame's (H, W, 3) image: the shader's colour where the surface is hit, 0 elsewhere."""
        rows, hit = fragment_rows(inputs, seed, frame, f"fragment shader {self.name!r}")
        values = self.run(rows)[:, :3]
        check_output(self.name, values, f"frame {frame}", "intensity")
        img = np.zeros(hit.shape + (3,))
        img[hit] = values
        return img


def fragment_spec(spec: dict, varyings: dict | None, output: str | None) -> dict:
    """``spec`` (a method shader's) with the fragment mode's adapted code, assignments and output."""
    if spec["language"] != "glsl":
        V.fail("language", spec["language"], "'glsl' (the fragment mode reads GLSL fragment shaders)")
    adapted, found = adapt(spec["code"])
    assign, out, driven = plan(found, varyings, output)
    # A uniform the scene drives is a plain global set per lane, not a block to fill.
    for name in driven:
        adapted = adapted.replace(f"layout(std140) uniform glintlab_uniform_{name} {{ {found['uniform'][name]} {name}; }};",
                                  f"{found['uniform'][name]} {name};")
    return dict(spec, adapted=adapted, assign=assign, output=out, mode="fragment")


def fragment_method(spec: dict, varyings: dict | None, output: str | None) -> FragmentMethod:
    """The fragment-mode method of a method shader's spec (``shader_method(..., mode="fragment")``)."""
    return FragmentMethod(fragment_spec(spec, varyings, output))


register_fragment_factory(fragment_method)
