"""Direction samplers written as shaders, run on Vulkan and tested by the sampler harness
(docs/math/sampling.md#shader-samplers).

The contract a shader sampler meets is two functions (HLSL; GLSL writes ``vec2``, ``vec3``, ``vec4``)::

    float4 sample_h(float2 uv, float4 J, float3 wo, float4 u)   // (h.x, h.y, h.z, pdf)
    float  pdf_h(float2 uv, float4 J, float3 wo, float3 h)      // pdf per steradian of h

``sample_h`` draws one unit half vector h (shading frame, z along the normal) from four uniforms and
returns it with its pdf; ``pdf_h`` evaluates that density at a given h. Renderers sample the reflected
direction instead, and a file may define that pair in their place (the contract is picked from the
functions the file defines, read from its preprocessed text)::

    float4 sample_l(float2 uv, float4 J, float3 wo, float4 u)   // (l.x, l.y, l.z, pdf of l)
    float  pdf_l(float2 uv, float4 J, float3 wo, float3 l)      // pdf per steradian of l

An l below the surface is a lost draw. ``directions="reflected"`` tests an h-sampler's draws as l, through
glintlab's own conversion l = 2 (wo.h) h - wo, pdf_l = pdf_h / (4 wo.h), so that the sampler's pdf of l
is checked as a renderer will use it (docs/math/sampling.md#reflected-directions). ``uv`` and ``J`` are the
pixel's texture position and footprint (du/dx, dv/dx, du/dy, dv/dy), ``wo`` the unit outgoing
direction; a smooth sampler ignores uv and J. glintlab wraps both functions in one compute kernel of
its own, compiled and run by the shader-law runner (shaderc, Vulkan; lavapipe on the CPU), and the
include file it puts before the code (``glintlab_sampler_hlsl.h`` / ``glintlab_sampler_glsl.h``)
states the contract.

``shader_sampler(source)`` returns a :class:`~glintlab.api.samplers.Sampler` for one pixel and one
``wo``: ``gl.sampler_test`` tests it like the reference samplers, and ``glintlab sampler FILE.hlsl``
(or ``.glsl``) does through the ``SAMPLER_LOADERS`` hook. The uniforms are glintlab's: numpy's Philox
generator keyed by the seed, four per row in row order, converted to float32 by the rule of the
shader laws (``uniforms_float32``: never 0 or 1), so the same seed gives the same directions on any
machine and whatever the chunking. GGX visible normals (Heitz 2018) ship as the example
(:func:`shipped_sampler`), one body for HLSL and GLSL.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from .. import _core
from ..resources import data_path
from . import checks as V
from . import shader_resources
from .samplers import SAMPLER_LOADERS, Sampler, _points, _size, _unit
from .shaders import (_ERROR_LINE, _EXTENSIONS, _WRAPPER_FILE, DEFAULT_TIMEOUT_S, LANGUAGES, ShaderBacked,
                      ShaderCompileError, ShaderOutputError, _utf8, compile_error, kernel_spec)

SAMPLE_ENTRY, PDF_ENTRY = "sample_h", "pdf_h"
#: The two contracts' functions: on the half vector ("h") and on the reflected direction ("l").
CONTRACTS = {"h": (SAMPLE_ENTRY, PDF_ENTRY), "l": ("sample_l", "pdf_l")}
#: What each contract's draws are, and the directions an h-sampler may also be tested on.
DIRECTIONS = {"h": ("half", "reflected"), "l": ("reflected",)}
#: The shipped examples, one per contract: GGX visible normals, ``ggx_vndf.hlsl`` / ``.glsl`` (one body)
#: returning h, and ``ggx_vndf_l`` returning the reflected direction.
SHIPPED_SAMPLERS = {"ggx_vndf": "GGX visible normals (Heitz 2018), -D ALPHA=a (default 0.3)",
                    "ggx_vndf_l": "GGX visible normals returning the reflected direction l (sample_l, pdf_l), "
                                  "-D ALPHA=a (default 0.3)"}
#: Deliberately wrong shipped samplers, one per contract, that the harness must reject (the Jacobian
#: 4 (wo.h) between the pdfs of h and of l mishandled).
WRONG_SAMPLERS = {"ggx_vndf_missing_jacobian": "sample_h / pdf_h returning the pdf of l as the pdf of h",
                  "ggx_vndf_l_missing_jacobian": "sample_l / pdf_l returning the pdf of h as the pdf of l"}
_CHUNK = 1 << 20  # rows per call to the runner (the input rows of one call stay under 64 MiB)
_MODE_SAMPLE, _MODE_PDF = 0, 1
DEFAULT_WO = (0.6, 0.0, 0.8)
DEFAULT_UV = (0.0, 0.0)
DEFAULT_J = (1e-3, 0.0, 0.0, 1e-3)


def _compile_error(exc: ValueError, source_name: str, language: str, contract: str = "h") -> ShaderCompileError:
    """The runner's compile failure as one line: ``shaders.compile_error``, the one wording of shader laws,
    method shaders and shader samplers, with the two functions of the sampler's contract; except where
    every error is in glintlab's wrapper at its call of one of the two functions without naming it (a
    result or argument the call cannot convert): that function is named with its expected signature,
    not the wrapper blamed."""
    text = str(exc)
    errors = [m for m in (_ERROR_LINE.match(ln.strip()) for ln in text.partition("\n")[2].splitlines()) if m]
    in_wrapper = errors and all(m.group("loc").startswith(_WRAPPER_FILE) for m in errors)
    named = any(f"'{e}'" in m.group("msg") for m in errors for e in CONTRACTS[contract])
    called = _called_function(errors, language, contract) if in_wrapper and not named else None
    if called:
        return ShaderCompileError(_signature_message(called, source_name, language, errors[0].group("msg")), text)
    sig = _core.sampler_signature(language, *CONTRACTS[contract], contract).split(" and ")
    return compile_error(exc, source_name, language, "shader sampler", dict(zip(CONTRACTS[contract], sig)))


def _expected_signature(function: str, language: str) -> str:
    contract = "h" if function in CONTRACTS["h"] else "l"
    both = _core.sampler_signature(language, *CONTRACTS[contract], contract).split(" and ")
    return both[CONTRACTS[contract].index(function)]


def _called_function(errors, language: str, contract: str) -> str | None:
    """The contract's function whose call in glintlab's wrapper the first wrapper error is on, if any (the
    wrapper calls sample_h on one line and pdf_h on another)."""
    wrapper = _core.sampler_wrapper_source(language, *CONTRACTS[contract], "x", contract).splitlines()
    for m in errors:
        loc = m.group("loc")
        if not loc.startswith(_WRAPPER_FILE):
            continue
        line = int(loc.rsplit(":", 1)[1])
        text = wrapper[line - 1] if 0 < line <= len(wrapper) else ""
        for function in CONTRACTS[contract]:
            if f" {function}(" in text:
                return function
    return None


def _signature_message(function: str, source_name: str, language: str, compiler: str) -> str:
    return (f"shader {source_name}: {function} does not have the contract's signature: expected "
            f"{_expected_signature(function, language)} ({language}); the compiler, at glintlab's call of "
            f"{function}: {compiler}")


# Declarations of the contract's functions in the user's code, and the type names a check can judge
# (a macro or typedef standing for a type is left to the compiler).
_DECLARATION = re.compile(r"(?P<ret>\b[A-Za-z_]\w*)\s+(?P<name>sample_[hl]|pdf_[hl])\s*\((?P<params>[^()]*)\)\s*(?=[{;])")
_KNOWN_TYPES = re.compile(r"^(?:float|half|double|int|uint|bool|min16float|min16int|min16uint)[1-4]?$|"
                          r"^(?:[iudb]?vec[2-4])$")
_QUALIFIERS = {"in", "const", "uniform", "precise", "highp", "mediump", "lowp", "inout", "out"}


def _strip_comments(code: str) -> str:
    return re.sub(r"//[^\n]*|/\*.*?\*/", lambda m: re.sub(r"[^\n]", " ", m.group()), code, flags=re.S)


def _check_declarations(code: str, source_name: str, language: str, contract: str) -> None:
    """Refuses, before compiling, a declaration of sample_h or pdf_h (sample_l, pdf_l) whose types are all
    plain type names and none of which is the contract's: HLSL converts a float4 argument to a float2
    parameter, or a float2 result to float, without an error, and the sampler would run on what is left."""
    text = _strip_comments(code)
    for function in CONTRACTS[contract]:
        expected = _types(_DECLARATION.search(_expected_signature(function, language) + ";"))
        found = [m for m in _DECLARATION.finditer(text) if m.group("name") == function]
        judged = [(m, _types(m)) for m in found]
        judged = [(m, t) for m, t in judged if t is not None]
        if not judged or len(judged) < len(found) or any(t == expected for _, t in judged):
            continue
        m = judged[0][0]
        line = text.count("\n", 0, m.start()) + 1
        declared = " ".join(m.group().split())
        raise ShaderCompileError(f"shader {source_name}:{line}: {declared} is not the contract's {function}: expected "
                                 f"{_expected_signature(function, language)} ({language})", declared)


def _types(m) -> tuple | None:
    """(return type, parameter types) of a declaration, each in GLSL's spelling (glintlab's prelude lets
    GLSL code write float4 for vec4), or None when a type is not a plain type name."""
    types = [m.group("ret")]
    params = m.group("params").strip()
    for param in (params.split(",") if params and params != "void" else []):
        words = [w for w in param.split() if w not in _QUALIFIERS]
        if len(words) != 2:
            return None
        types.append(words[0])
    if not all(_KNOWN_TYPES.match(t) for t in types):
        return None
    return tuple(_GLSL_VECTORS.sub(lambda v: _VECTOR_PREFIX[v.group(1)] + "vec" + v.group(2), t) for t in types)


_GLSL_VECTORS = re.compile(r"^(float|int|uint|bool|double)([2-4])$")
_VECTOR_PREFIX = {"float": "", "int": "i", "uint": "u", "bool": "b", "double": "d"}


def _check_defines(code: str, included: list, defines: list, source_name: str) -> None:
    """Refuses a define whose name the code and the files it includes never mention: it changes nothing,
    and a run at the code's own default would pass as if it had been tested at the value given."""
    words = set(re.findall(r"[A-Za-z_]\w*", _strip_comments(code)))
    for _, content in included:
        words |= set(re.findall(r"[A-Za-z_]\w*", _strip_comments(bytes(content).decode("utf-8", "replace"))))
    for key, _ in defines:
        if key not in words:
            like = sorted(w for w in words if w.lower() == key.lower())
            hint = f" (the code reads {', '.join(like)})" if like else ""
            V.fail("defines", key, f"a name the code ({source_name} and the files it includes) mentions; a define "
                                   f"it never mentions changes nothing{hint}")


class ShaderSampler(ShaderBacked, Sampler):
    """A direction sampler computed by two shader functions (see :func:`shader_sampler`) for one pixel
    (``uv``, ``J``) and one outgoing direction ``wo``: ``sample(size, seed) -> (x, pdf)`` and ``pdf(x)``,
    as the reference samplers, on the hemisphere (or the sphere), x the half vector h or the reflected
    direction l (``directions``). A pdf that is infinite, or NaN or negative where the sampler may draw,
    raises ``ShaderOutputError`` (``clamp_pdf``: read as 0 where it never draws). The kernel's
    properties, pickles (the code and its included files) and device are the shader-backed objects'
    (``shaders.ShaderBacked``)."""

    kind = "shader sampler"
    summary = "a sampler written as a shader (sample_h, pdf_h or sample_l, pdf_l)"
    # Its parameters are defines fixed at compile time, so the variants that redraw with another alpha are
    # not built; losing samples is a Python-side wrapper of any sampler.
    wrong_variants = ("drop_0.1%",)

    def __init__(self, spec: dict):
        Sampler.__init__(self)
        ShaderBacked.__init__(self, spec)
        self._kernel  # compiled now: a sampler that does not compile is refused when made
        s = self._spec
        self.name = s["name"]
        self.domain = s["domain"]
        self.contract, self.directions, self.clamp_pdf = s["contract"], s["directions"], s["clamp_pdf"]
        self.wo = np.asarray(s["wo"], dtype=np.float64)
        self.uv = np.asarray(s["uv"], dtype=np.float64)
        self.J = np.asarray(s["J"], dtype=np.float64)
        self.params = {"wo": tuple(s["wo"]), "uv": tuple(s["uv"]), "J": tuple(s["J"]),
                       **{k: val for k, val in s["defines"]}}
        if self.directions != DIRECTIONS[self.contract][0]:
            self.params["directions"] = self.directions
        if self.directions == "reflected":
            # Reflected draws below the surface are lost by design (8.6 % for GGX at alpha 0.3, wo 37
            # degrees off the normal): one more lost in a thousand hides in their noise at the sizes a test
            # runs (1.5 sigma at 2e5 draws), so it is no wrong variant here. The shipped wrong samplers
            # (WRONG_SAMPLERS) are this contract's.
            self.wrong_variants = ()
        self.clamped = 0  # pdf values read as 0 under clamp_pdf (the harness reports how many, per test)
        # The fixed part of every row: uv, J, wo in float32 (the shader's view of them).
        head = np.zeros(_core.SAMPLER_INPUT_WORDS, np.float32)
        head[0:2], head[2:6], head[6:9] = self.uv, self.J, self.wo
        self._head = head.view(np.uint32)

    @property
    def functions(self) -> tuple:
        """The contract's two functions: ("sample_h", "pdf_h") or ("sample_l", "pdf_l")."""
        return CONTRACTS[self.contract]

    def _make_kernel(self, s, includes):
        sample_entry, pdf_entry = CONTRACTS[s["contract"]]
        return _core.SamplerKernel(s["code"], s["source_name"], sample_entry, pdf_entry, s["language"],
                                   [(k, val) for k, val in s["defines"]], list(s["include_dirs"]), s["device"],
                                   includes, s["contract"])

    def _compile_failure(self, exc: ValueError) -> ShaderCompileError:
        return _compile_error(exc, self._spec["source_name"], self._spec["language"], self._spec["contract"])

    @property
    def identity(self) -> str:
        """``shader_sampler:<sha256 of the SPIR-V, the device, the pixel and the directions>:<name>``."""
        extra = b"" if self.directions == DIRECTIONS[self.contract][0] else self.directions.encode()
        return f"shader_sampler:{self._digest(self._head.tobytes() + extra)}:{self.name}"

    def __repr__(self):
        return f"ShaderSampler({self.name!r}, {self.language}, {self.functions[0]}, directions {self.directions}, " \
               f"wo={tuple(round(float(x), 6) for x in self.wo)}, device={self.device!r})"

    def _rows(self, mode: int, words: np.ndarray) -> np.ndarray:
        rows = np.empty((len(words), _core.SAMPLER_INPUT_WORDS), np.uint32)
        rows[:] = self._head
        rows[:, 9] = mode
        rows[:, 10:10 + words.shape[1]] = words
        return rows

    def run(self, rows) -> np.ndarray:
        """The kernel on packed rows (m, 16) uint32: (m, 4) float32 (docs/math/sampling.md#shader-samplers)."""
        rows = np.ascontiguousarray(rows, dtype=np.uint32)
        if rows.ndim != 2 or rows.shape[1] != _core.SAMPLER_INPUT_WORDS:
            V.fail("rows", f"an array of shape {rows.shape}", f"an array of shape (m, {_core.SAMPLER_INPUT_WORDS})")
        out = np.empty((len(rows), _core.SAMPLER_OUTPUT_WORDS), np.float32)
        for i0 in range(0, len(rows), _CHUNK):
            out[i0:i0 + _CHUNK] = self._kernel.run(rows[i0:i0 + _CHUNK], self._spec["timeout"])
        return out

    def uniforms(self, size, seed=0) -> np.ndarray:
        """The (size, 4) float32 uniforms ``sample(size, seed)`` hands to sample_h, row by row."""
        n = _size(size)
        u = np.random.Generator(np.random.Philox(V.seed(seed))).random((n, 4))
        # uniforms_float32's rule, (floor(u 2^23) + 1/2) 2^-23, in float32 arithmetic that is exact here
        # (k < 2^23, so k + 1/2 has 24 significant bits) and 30 times faster than in float64; the tests
        # check it equals uniforms_float32 bit for bit.
        k = (u * 8388608.0).astype(np.uint32)  # u < 1: k <= 2^23 - 1, the clip is never needed
        return (k.astype(np.float32) + np.float32(0.5)) * np.float32(2.0**-23)

    def sample(self, size, seed=0):
        """(x, pdf): ``size`` draws of sample_h (sample_l), as float64 arrays (size, 3) and (size,); an
        h-sampler tested on reflected directions returns l = 2 (wo.h) h - wo and pdf_h / (4 wo.h). A draw
        the shader returns as NaN stays NaN (the harness counts it as a lost sample)."""
        u = self.uniforms(size, seed)
        out = self.run(self._rows(_MODE_SAMPLE, u.view(np.uint32)))
        x, p = out[:, :3].astype(np.float64), out[:, 3].astype(np.float64)
        if self.contract == "h" and self.directions == "reflected":
            cos_oh = x @ self.wo
            with np.errstate(divide="ignore", invalid="ignore"):
                x, p = 2.0 * cos_oh[:, None] * x - self.wo, p / (4.0 * cos_oh)
        return x, p

    def pdf(self, points):
        """pdf_h (pdf_l) at each direction (size, 3), evaluated on float32(points), returned as float64; an
        h-sampler tested on reflected directions: pdf_h(h) / (4 wo.h) at h = normalize(wo + l)."""
        points = _points(points, 3)
        finite = np.isfinite(points).all(axis=1)
        if not finite.all():  # the caller's input, not the shader's fault
            i = int(np.argmin(finite))
            V.fail("points", f"row {i} = {tuple(float(x) for x in points[i])}", "finite directions")
        half = _half_vectors(self.wo, points) if self.contract == "l" or self.directions == "reflected" else points
        x = half if self.contract == "h" else points
        x32 = np.ascontiguousarray(x, dtype=np.float32)
        out = self.run(self._rows(_MODE_PDF, x32.view(np.uint32)))[:, 0].astype(np.float64)
        out = self._defined(out, x32, half)
        if self.contract == "h" and self.directions == "reflected":
            with np.errstate(divide="ignore", invalid="ignore"):
                out = np.where(out > 0, out / (4.0 * (half @ self.wo)), 0.0)
        return out

    def _defined(self, out, x32, half) -> np.ndarray:
        """``out`` where the pdf is a finite number >= 0. A NaN or negative value where wo.h < 0 (where a
        visible-normal sampler never draws: engines evaluate their pdf only at their own draws) is read
        as 0 under clamp_pdf and otherwise refused in one line naming that region; elsewhere, and an
        infinite value anywhere, is the shader's fault (``ShaderOutputError``)."""
        bad = ~np.isfinite(out) | (out < 0)
        if not bad.any():
            return out
        fn = self.functions[1]
        outside = (half @ self.wo) < 0
        clampable = bad & ~np.isinf(out) & outside
        if (bad & ~clampable).any():
            i = int(np.argmax(bad & ~clampable))
            raise ShaderOutputError(f"shader sampler {self.name!r}: {fn} returned {out[i]} at {self.functions[0][-1]} = "
                                    f"{tuple(float(x) for x in x32[i])} (row {i}); a pdf must be finite and >= 0")
        if not self.clamp_pdf:
            i = int(np.argmax(bad))
            raise ShaderOutputError(
                f"shader sampler {self.name!r}: {fn} returned {out[i]} at {self.functions[0][-1]} = "
                f"{tuple(float(x) for x in x32[i])} (row {i}), and is negative or NaN only where wo.h < 0 "
                f"({int(bad.sum())} of {len(out)} directions), a region a visible-normal sampler never draws: an "
                "engine's pdf is defined only where the engine calls it; clamp_pdf=True (glintlab sampler "
                "--clamp-pdf) reads it as 0 there")
        self.clamped += int(bad.sum())
        return np.where(bad, 0.0, out)

    def clamp_note(self, count: int) -> str:
        """The note of a test in which ``count`` pdf values were read as 0 (clamp_pdf)."""
        return (f"clamp_pdf: {self.functions[1]} was negative or NaN at {count} directions, all where wo.h < 0 "
                "(where the sampler never draws), and read as 0 there")


def _half_vectors(wo, points) -> np.ndarray:
    """h = normalize(wo + l) for each reflected direction l (NaN where l = -wo)."""
    h = wo + points
    with np.errstate(divide="ignore", invalid="ignore"):
        return h / np.linalg.norm(h, axis=1)[:, None]


def _vector(name, value, n) -> tuple:
    a = V.as_float_array(name, value).reshape(-1)
    if a.size != n or not np.isfinite(a).all():
        V.fail(name, value, f"{n} finite numbers")
    return tuple(float(x) for x in a)


def _pick_contract(spec: dict, contract) -> str:
    """The contract the code meets: ``contract`` when given ("h" or "l"), else the one whose functions the
    preprocessed code declares (``_core.sampler_functions``): sample_l or pdf_l without sample_h or pdf_h
    is "l"; both pairs complete is ambiguous (name one); otherwise "h", whose compile then names what is
    missing. Code that does not preprocess is left to the compile, which reports it."""
    V.choice("contract", contract, (None, "h", "l"), "None (from the functions the code defines), 'h' or 'l'")
    if contract is not None:
        return contract
    try:
        found = set(_core.sampler_functions(spec["code"], spec["source_name"], spec["language"],
                                            [(k, val) for k, val in spec["defines"]], list(spec["include_dirs"])))
    except ValueError:
        return "h"
    if set(CONTRACTS["h"]) <= found and set(CONTRACTS["l"]) <= found:
        V.fail("contract", None, f"'h' or 'l': {spec['source_name']} defines sample_h, pdf_h, sample_l and pdf_l")
    return "l" if found & set(CONTRACTS["l"]) and not found & set(CONTRACTS["h"]) else "h"


def shader_sampler(source, language: str | None = None, name: str | None = None, defines: dict | None = None,
                   wo=DEFAULT_WO, uv=DEFAULT_UV, J=DEFAULT_J, domain: str = "hemisphere", include_dirs=(),
                   device="auto", timeout: float = DEFAULT_TIMEOUT_S, *, contract: str | None = None,
                   directions: str | None = None, clamp_pdf: bool = False, textures: dict | None = None,
                   samplers: dict | None = None, buffers: dict | None = None,
                   uniforms: dict | None = None) -> ShaderSampler:
    """A direction sampler written as a shader: ``sample_h`` and ``pdf_h``, or ``sample_l`` and
    ``pdf_l`` (module docstring), compiled by shaderc and run by Vulkan for one pixel and one outgoing
    direction.

    ``source``: a file path (``.hlsl``, ``.glsl``, ...) or the code as a string; ``language``:
    "hlsl" or "glsl" (default: from the extension; "hlsl" for code in a string). ``defines``
    ({"NAME": value}) are passed as ``-D NAME=value``. ``wo``: the unit outgoing direction (z > 0;
    normalised here); ``uv`` and ``J``: the pixel (2 and 4 numbers). ``domain``: "hemisphere" (z > 0)
    or "sphere". ``include_dirs`` are searched after the file's folder and glintlab's shader folder.
    ``name``: default the file's name ("ggx_vndf.hlsl"), or "shader_sampler" for code in a string.
    ``device``, ``timeout``: as ``shader_law``. ``contract``: "h" or "l" (default: from the functions
    the code defines). ``directions``: what is tested, "half" (an h-sampler's default) or "reflected"
    (an l-sampler's, and an h-sampler's draws as l through glintlab's 4 (wo.h)). ``clamp_pdf``: a pdf
    negative or NaN only where wo.h < 0, where a visible-normal sampler never draws, is read as 0 there
    (the test's notes say how often) instead of refused. A shader that does not compile, or lacks either
    function or gives it another signature, raises ``ShaderCompileError`` (a ``ValueError``; one line
    naming file:line, the compiler's text in ``.messages``); no Vulkan device raises ``RuntimeError``.
    ``textures``, ``samplers``, ``buffers``, ``uniforms``: the data of the read-only resources the code
    declares, by name (``glintlab.api.shader_resources``).

    >>> s = shader_sampler(shipped_sampler("ggx_vndf"), defines={"ALPHA": 0.5})  # doctest: +SKIP
    >>> gl.sampler_test(s, samples=10**5).passed                                 # doctest: +SKIP
    True
    """
    spec = kernel_spec(source, language, SAMPLE_ENTRY, defines, include_dirs, device, timeout,
                       defaults=(data_path("shaders"),),
                       resources=shader_resources.resource_spec(textures, samplers, buffers, uniforms))
    for d in spec["include_dirs"][:-1]:  # the caller's (glintlab's own comes last)
        if not os.path.isdir(d):
            V.fail("include_dirs", d, "existing folders")
    code, source_name, language, define_list = spec["code"], spec["source_name"], spec["language"], spec["defines"]
    if name is None:
        name = Path(source_name).name if source_name != "<string>" else "shader_sampler"
    if not isinstance(name, str) or not name:
        V.fail("name", name, "a non-empty string")
    _utf8("name", name)
    V.choice("domain", domain, ("hemisphere", "sphere"), "'hemisphere' or 'sphere'")
    if not isinstance(clamp_pdf, (bool, np.bool_)):
        V.fail("clamp_pdf", clamp_pdf, "True or False")
    contract = _pick_contract(spec, contract)
    directions = DIRECTIONS[contract][0] if directions is None else directions
    V.choice("directions", directions, DIRECTIONS[contract],
             " or ".join(f"'{d}'" for d in DIRECTIONS[contract]) + f" for a sampler defining {CONTRACTS[contract][0]}")
    _check_declarations(code, source_name, language, contract)
    spec.update(name=name, wo=tuple(float(x) for x in _unit("wo", wo)), uv=_vector("uv", uv, 2), J=_vector("J", J, 4),
                domain=domain, contract=contract, directions=directions, clamp_pdf=bool(clamp_pdf))
    sampler = ShaderSampler(spec)
    _check_defines(code, sampler._spec["includes"], define_list, source_name)
    return sampler


def shipped_sampler(name: str = "ggx_vndf", language: str = "hlsl") -> Path:
    """The path of a shader sampler glintlab ships (``SHIPPED_SAMPLERS``, or a deliberately wrong one of
    ``WRONG_SAMPLERS``), in "hlsl" or "glsl"."""
    names = (*SHIPPED_SAMPLERS, *WRONG_SAMPLERS)
    V.choice("name", name, names, "one of " + ", ".join(names))
    V.choice("language", language, LANGUAGES, "'hlsl' or 'glsl'")
    return Path(data_path("shaders", f"{name}.{language}"))


_KEYWORDS = ("language", "name", "wo", "uv", "J", "domain", "device", "timeout", "contract", "directions",
             "clamp_pdf", "include_dirs", "textures", "samplers", "buffers", "uniforms")


def load_shader_sampler(path: str, **params) -> ShaderSampler:
    """The ``SAMPLER_LOADERS`` entry for shader files (``glintlab sampler FILE.hlsl --param k=v``): the
    keywords of :func:`shader_sampler` (wo, uv, J, domain, language, name, device, timeout, contract,
    directions, clamp_pdf, include_dirs) are passed
    as such; every other parameter is a define (``--param ALPHA=0.5`` is ``-D ALPHA=0.5``)."""
    kwargs = {k: params.pop(k) for k in list(params) if k in _KEYWORDS}
    return shader_sampler(path, defines=params, **kwargs)


for _suffix in (x for x in _EXTENSIONS if x != ".frag"):  # a fragment shader is a method, never a sampler
    SAMPLER_LOADERS.register(_suffix, load_shader_sampler)
