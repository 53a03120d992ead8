"""Counting laws written as shader functions, compiled and run on Vulkan.

A renderer's counting law lives in a shader. ``shader_law`` takes that source, HLSL or GLSL, compiles
it with shaderc inside glintlab's own compute kernel and runs it with Vulkan (lavapipe, Vulkan on the
CPU, when there is no GPU), so that what glintlab measures is the shader itself, not a port of it.

The contract the shader meets is one function::

    float count(float n, float p, float4 u)   // HLSL; GLSL: float count(float n, float p, vec4 u)

where ``u.x .. u.w`` are the law's uniforms (unused ones are 0). glintlab passes float(n), float(p)
and its own uniforms (``gl.uniforms``, same seed, same numbers) converted to float32 by the rule of
``uniforms_float32`` (glintlab.api.laws; never 0 or 1), the rule the C++ float32 laws use too: a shader and its C++ twin
compare row by row. See docs/guide/shaders.md.
"""
from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import numpy as np

from .. import _core
from ..resources import data_path
from . import checks as v
from . import shader_resources
from .hlsl_dialect import dxc_only_hint
from .laws import BINNINGS, CustomLaw, _require_finite, _uniform_rows, law
from .plugins import CUSTOM_LAWS

LANGUAGES = ("hlsl", "glsl")
_EXTENSIONS = {".hlsl": "hlsl", ".hlsli": "hlsl", ".fx": "hlsl", ".glsl": "glsl", ".comp": "glsl", ".frag": "glsl"}
DEFAULT_TIMEOUT_S = 60.0
_CHUNK = 1 << 22  # rows handed to the runner at once (the runner submits 2^20 at a time)

_INCLUDE_LINE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')


def vulkan_devices() -> list[dict]:
    """Every Vulkan device the loader sees: ``index``, ``name`` (e.g. "llvmpipe (LLVM 15.0.6, 256
    bits)"), ``type`` ("discrete_gpu", "integrated_gpu", "cpu", ...), ``api_version`` and ``driver``.
    Empty when there is none (then install mesa-vulkan-drivers for lavapipe)."""
    return list(_core.vulkan_devices())


def shipped_shaders() -> dict[str, str]:
    """The shaders glintlab ships, each declared by the C++ law that is its twin (same arithmetic in
    float32) in that law's traits (``law_traits(law)["shader"]``): {shader name: twin law's name}.

    >>> shipped_shaders()["gated"]
    'gated_shader'
    """
    return {traits["shader"]: name for name, traits in _core.all_law_traits().items() if traits["shader"]}


def _shipped_name(name) -> str:
    """A shipped shader's name from its own name or from the name of the law declaring it."""
    shipped = shipped_shaders()
    if isinstance(name, str) and name not in shipped:
        name = {law_name: shader for shader, law_name in shipped.items()}.get(name, name)
    if not isinstance(name, str) or name not in shipped:
        v.fail("name", name, f"a shipped shader among {sorted(shipped)} (or the law declaring it: "
                             f"{sorted(shipped.values())})")
    return name


def shipped_shader(name: str, language: str = "hlsl") -> Path:
    """The path of a shader glintlab ships (``shipped_shaders()``: "gated", "gated_continuous",
    "dual_gated", "head_cf", or the name of the law whose traits declare it), in "hlsl" or "glsl".
    The file is a thin wrapper including the law's one body (``<name>_body.h``, shared by both
    languages); ``emit_shader`` gives it with its includes inlined."""
    name = _shipped_name(name)
    v.choice("language", language, LANGUAGES, "'hlsl' or 'glsl'")
    return Path(data_path("shaders", f"{name}.{language}"))


def shipped_twin(name: str):
    """The C++ law that computes what the shipped shader ``name`` computes (in float32)."""
    return law(shipped_shaders()[_shipped_name(name)])


def _inline_includes(path: Path, seen: set, out: list) -> None:
    """``path``'s lines into ``out`` with each ``#include "x"`` (resolved next to the including file, as
    the compiler does) replaced by x's lines, each file once (the shipped headers are guarded, so a
    second inclusion would add nothing)."""
    for line in _decode(path).splitlines():
        match = _INCLUDE_LINE.match(line)
        if match is None:
            out.append(line)
            continue
        target = (path.parent / match.group(1)).resolve()
        if target in seen:
            out.append(f"// ({match.group(1)}: inlined above)")
            continue
        seen.add(target)
        out.append(f"// ---- {match.group(1)} (inlined) ----")
        _inline_includes(target, seen, out)
        out.append(f"// ---- end of {match.group(1)} ----")


def emit_shader(name: str, language: str = "hlsl") -> str:
    """A shipped shader as one self-contained, paste-ready file: the wrapper with every ``#include``
    inlined (the prelude, ``glintlab_math.h``, the law's body), comments kept. It compiles alone and
    computes exactly what ``shipped_shader(name, language)`` does (the same preprocessed code).
    ``name``: a shipped shader or the law declaring it. (``glintlab shader --emit NAME --lang L``.)

    >>> any(line.lstrip().startswith("#include") for line in emit_shader("gated_continuous", "glsl").splitlines())
    False
    """
    path = shipped_shader(name, language)
    out = [f"// {path.name} as glintlab ships it, with its #includes inlined: one self-contained file."]
    _inline_includes(path, {path.resolve()}, out)
    return "\n".join(out) + "\n"


def _utf8(name: str, text: str) -> str:
    """``text`` as it will reach the compiler: a lone surrogate (from a file decoded with
    errors="surrogateescape", or built by hand) cannot be UTF-8, so it is bad input, named here."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        v.fail(name, f"<text with {text[exc.start]!r} at character {exc.start}>",
               "valid Unicode text (a lone surrogate cannot be encoded as UTF-8)")
    return text


def _decode(path: Path) -> str:
    """A shader file's text. Files are UTF-8, a leading byte-order mark (Visual Studio's default) is
    dropped; any other byte that is not UTF-8, even in a comment, is an error naming the file, the byte,
    its offset and line, so that what compiles is never a guess at an encoding."""
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ValueError(f"source = {str(path)!r} is invalid; byte 0x{data[exc.start]:02x} at offset {exc.start} "
                         f"(line {line}) is not UTF-8; expected a UTF-8 file (save it as UTF-8)") from None
    return text[1:] if text.startswith("\ufeff") else text


def _is_path_text(text: str) -> bool:
    """The rule that tells a path from code in a string: an existing file or folder is a path, and so
    is a single line with none of ``( { ; }`` (every shader defining a function has them) that is not
    a preprocessor line (``#include "count.hlsl"`` is code), whatever its extension, so a mistyped
    file name is reported as missing and never compiled as code."""
    if "\n" in text or "\0" in text or text.lstrip().startswith("#"):  # '#include "x.hlsl"' is code
        return False
    return not any(c in text for c in "({;}") or os.path.exists(text)


def _read_source(source, language):
    """(code, source_name, language) from a path or from the code itself."""
    if isinstance(source, str):
        _utf8("source", source)
    if isinstance(source, os.PathLike) or (isinstance(source, str) and source.strip() and _is_path_text(source)):
        path = Path(source)
        if path.is_dir():
            v.fail("source", str(source), "a shader file, not a folder")
        if not path.is_file():
            v.fail("source", str(source), "an existing shader file or the shader code as a string")
        # A file name that is not UTF-8 (decoded by Python with surrogates) cannot name the file to
        # the compiler, whose messages and #include resolution use it.
        _utf8("source", str(path.resolve()))
        code = _decode(path)
        if language is None:
            language = _EXTENSIONS.get(path.suffix.lower())
            if language is None:
                v.fail("language", None, f"'hlsl' or 'glsl' (the extension {path.suffix!r} does not say)")
        return code, str(path.resolve()), language
    if not isinstance(source, str) or not source.strip():
        v.fail("source", source, "a shader file path or the shader code as a non-empty string")
    code = source[1:] if source.startswith("\ufeff") else source
    return code, "<string>", language or "hlsl"


def _define_value(key, value) -> str:
    """A define's value as the compiler's text: True/False are 1/0 (as the C preprocessor reads them),
    None or "" a define without a value (``#define NAME``), numbers and strings as written."""
    if isinstance(value, (bool, np.bool_)):
        return "1" if value else "0"
    if value is None:
        return ""
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        if not np.isfinite(value):
            v.fail(f"defines[{key!r}]", value, "a finite number")
        return repr(float(value))
    if isinstance(value, str):
        if "\n" in value or "\r" in value:
            v.fail(f"defines[{key!r}]", value, "a value on one line")
        return _utf8(f"defines[{key!r}]", value)
    v.fail(f"defines[{key!r}]", value, "a string, a number, True/False or None (a define without a value)")


def _device_request(device) -> str:
    """``device`` as the runner's text: "auto", "gpu", "cpu", an index (int or digits) or part of a name."""
    if isinstance(device, (int, np.integer)) and not isinstance(device, (bool, np.bool_)):
        if device < 0:
            v.fail("device", device, "a device index >= 0 (gl.vulkan_devices())")
        return str(int(device))
    if not isinstance(device, str) or not device.strip():
        v.fail("device", device, "'auto', 'gpu', 'cpu', a device index or part of a device name")
    return _utf8("device", device)


class ShaderCompileError(ValueError):
    """A shader that does not compile, or lacks a function of its contract (a shader law, a method
    shader, a shader sampler). ``str()`` is one line saying what is wrong where (:func:`compile_error`);
    ``messages`` holds the compiler's full text."""

    def __init__(self, line: str, messages: str):
        super().__init__(line)
        self.messages = messages


_ERROR_LINE = re.compile(r"^(?P<loc>.+?:\d+):\s*error:?\s*(?P<msg>.*)$")
_NO_BODY = re.compile(r"No function definition \(body\) found:\s*(?:\S+:)?\s*(?P<fn>[A-Za-z_]\w*)\(")
_SIGNATURE = re.compile(r"with the expected signature (?P<sig>.+?) \((?:hlsl|glsl)\); the compiler says")
_WRAPPER_FILE = "glintlab_kernel."


def is_compile_failure(exc: ValueError) -> bool:
    """Whether the runner's ValueError is a compile failure (not a refused resource, an include cycle, ...)."""
    head = str(exc).split("\n", 1)[0]
    return "does not compile" in head or "no function" in head


def compile_error(exc: ValueError, source_name: str, language: str, kind: str,
                  signatures: dict | None = None) -> ShaderCompileError:
    """The runner's compile failure as one line, the one wording of shader laws, method shaders and shader
    samplers (``kind``: "shader law", "method shader", "shader sampler"):

    - a function declared without a body (a prototype whose definition is missing) is named as such;
    - an error in the user's files: the first one (file:line: message, with how many more);
    - every error inside glintlab's wrapper, naming a function of the contract (``signatures``: entry ->
      expected signature; default: the one the runner's message states): that function is missing or
      has another signature;
    - every error inside the wrapper, none naming a function: a declaration left unfinished at the end
      of the user's code (an unclosed parameter list or body), whose errors the compiler reports after it.
    """
    text = str(exc)
    head, _, messages = text.partition("\n")
    lines = [ln.strip() for ln in messages.splitlines()]
    errors = [m for m in (_ERROR_LINE.match(ln) for ln in lines) if m]
    user = [m for m in errors if not m.group("loc").startswith(_WRAPPER_FILE)]
    if signatures is None:
        found = _SIGNATURE.search(head)
        entry = re.search(r"no function (\w+) with", head)
        signatures = {entry.group(1): found.group("sig")} if found and entry else {}
    no_body = _NO_BODY.search(" ".join(lines))
    if no_body and not user:
        fn = no_body.group("fn")
        define = f"; define {signatures[fn]}" if fn in signatures else ""
        return ShaderCompileError(f"{kind} does not compile ({language}): function {fn} is declared in {source_name} "
                                  f"but has no body (a prototype without its definition{define})", text)
    wrapper_text = " ".join(m.group("msg") for m in errors)
    named = [e for e in signatures if f"'{e}'" in wrapper_text]
    if "no function" in head and not user and named:
        first = f" ({errors[0].group('msg')})" if errors else ""
        return ShaderCompileError(f"shader {source_name}: no function {named[0]} with the expected signature "
                                  f"{signatures[named[0]]} ({language}){first}", text)
    if user:
        m = user[0]
        more = f" (+{len(errors) - 1} more: see .messages)" if len(errors) > 1 else ""
        return ShaderCompileError(f"{kind} does not compile ({language}): {m.group('loc')}: error: "
                                  f"{m.group('msg')}{more}", text)
    if errors:  # every error inside glintlab's wrapper, none naming a function: code left unfinished
        return ShaderCompileError(f"{kind} does not compile ({language}): {errors[0].group('msg')} in glintlab's "
                                  f"wrapper, after the end of {source_name} (a declaration left unfinished?)", text)
    return ShaderCompileError(head if head.strip() else text, text)


class ShaderOutputError(ValueError):
    """A shader returned a NaN, infinite or negative count (``sample`` and ``evaluate``): the shader is
    faulty, not the caller's input, so a verdict counts it as a failed check (exit 1), not bad input."""


# A call that could not start within its timeout because the device still ran an earlier kernel that
# had passed its own timeout (a TimeoutError; this call's kernel never ran).
ShaderDeviceBusy = _core.ShaderDeviceBusy
# No Vulkan device (or none of the kind asked for): a RuntimeError naming the package to install. The
# commands report it on one line, exit 2 (the environment, not the shader).
NoVulkanDevice = _core.NoVulkanDevice
LAVAPIPE_LOOP_CAP = 65535


class ShaderBacked:
    """What every shader-backed object shares: a shader law (:class:`ShaderLaw`), a method shader
    (``method_shaders.ShaderMethod``) and a shader sampler (``shader_samplers.ShaderSampler``).

    The object is made from its spec (:func:`kernel_spec`: the code, its file's name, entry, language,
    defines, include folders, device and timeout, plus what the kind adds) and compiles its kernel
    (``_make_kernel``, the kind's ``_core`` kernel) on first use; the subclass asks for ``_kernel`` in
    its constructor when a shader that does not compile must be refused there. A compile failure is
    one line (``_compile_failure``: :func:`compile_error`, worded by ``kind``). The files the first compile #include'd travel
    in the spec (``includes``), so a pickle (the spec, by value) compiles the same code anywhere,
    whatever happened to the files since. The kernel's properties (device, SPIR-V, included files,
    loops lavapipe may cut short) are read here for every kind."""

    kind = "shader"  # as a compile error names it: "shader law", "method shader", "shader sampler"

    def __init__(self, spec: dict):
        self._spec = dict(spec)
        self._compiled = None

    def _make_kernel(self, spec: dict, includes: list):
        """The kind's ``_core`` kernel from ``spec``, #includes served from ``includes`` when not empty."""
        raise NotImplementedError

    def _compile_failure(self, exc: ValueError) -> ShaderCompileError:
        """The runner's compile failure as one line (:func:`compile_error`, worded by ``kind``); a kind with
        several entries says which one is missing (``shader_samplers``)."""
        return compile_error(exc, self._spec["source_name"], self._spec["language"], self.kind)

    @property
    def _kernel(self):
        if self._compiled is None:
            s = self._spec
            sealed = [(path, content) for path, content in s.get("includes", ())]
            try:
                kernel = self._make_kernel(s, sealed)
            except ValueError as exc:
                if is_compile_failure(exc):
                    error = self._compile_failure(exc)
                    # HLSL that only DXC compiles: say which construct, and how glslang takes it.
                    hint = dxc_only_hint(s["code"]) if s["language"] == "hlsl" else ""
                    raise (ShaderCompileError(f"{error}; {hint}", error.messages) if hint else error) from None
                raise
            # The data of the textures, buffers and uniforms the code declares, checked against the
            # declarations (a kernel whose resources do not fit is never kept).
            shader_resources.bind(kernel, s.get("resources", {}), s["source_name"])
            self._compiled = kernel
            if "includes" not in s:
                s["includes"] = [(path, bytes(content)) for path, content in self._compiled.included_files]
        return self._compiled

    device = property(lambda self: self._kernel.device, doc="The Vulkan device's name.")
    device_type = property(lambda self: self._kernel.device_type, doc='"cpu", "discrete_gpu", ...')
    language = property(lambda self: self._spec["language"])
    entry = property(lambda self: self._spec["entry"])
    source_name = property(lambda self: self._spec["source_name"])
    spirv = property(lambda self: self._kernel.spirv, doc="The SPIR-V the pipeline runs (bytes).")
    unbounded_loops = property(lambda self: self._kernel.unbounded_loops,
                               doc="Loops of the SPIR-V whose trip count is not a known constant <= 65535.")

    @property
    def included_files(self) -> list:
        """The files #include'd at the first compile (their content travels in pickles)."""
        self._kernel
        return [path for path, _ in self._spec["includes"]]

    @property
    def loop_caveat(self) -> str | None:
        """Why results on this device may not be what a GPU computes, or None: lavapipe (llvmpipe) stops
        every loop after 65535 iterations, and the shader has loops whose trip count is not shown to stay
        below that (a SPIR-V inspection: a counter from a constant, a constant step, a constant bound)."""
        loops = self.unbounded_loops
        if not loops or not self.device.startswith("llvmpipe"):
            return None
        return (f"{loops} loop(s) of the {self.kind} have a trip count that is not a constant <= {LAVAPIPE_LOOP_CAP}, "
                f"and lavapipe ({self.device}) stops every loop after {LAVAPIPE_LOOP_CAP} iterations: results on "
                "this device are not what a GPU would compute where a loop runs longer")

    def _digest(self, extra: bytes = b"") -> str:
        """The first 16 hex digits of the sha256 of the SPIR-V, the device's name and ``extra``: what an
        identity names (the compiled code with its #includes and defines, and the device that runs it:
        GPUs differ in pow, exp, log)."""
        resources = self._spec.get("resources")
        bound = shader_resources.digest(resources) if resources else b""
        return hashlib.sha256(self._kernel.spirv + self.device.encode() + extra + bound).hexdigest()[:16]

    def _reduce_args(self) -> tuple:
        return (self._spec,)

    def __reduce__(self):
        # The code travels by value, with the files it included (workers compile it again); an object
        # not compiled yet (made without a Vulkan device) has read no file, and its copy reads them then.
        return (type(self), self._reduce_args())


def kernel_spec(source, language, entry, defines, include_dirs, device, timeout, defaults: tuple = (),
                none_defines: bool = True, resources: dict | None = None) -> dict:
    """The spec every shader-backed object starts from: the code and its file's name (``source``: a path
    or the code; ``language`` from the extension when None, "hlsl" for code in a string), ``entry``,
    the defines as sorted (name, text) pairs (:func:`_define_value`; ``none_defines`` False refuses
    None as a value), the include folders (then ``defaults``, glintlab's own), the device request
    (:func:`_device_request`: "auto", "gpu", "cpu", an index or part of a name), the timeout and the
    ``resources`` (``shader_resources.resource_spec``: textures, samplers, buffers, uniforms)."""
    if language is not None and language not in LANGUAGES:
        v.fail("language", language, "'hlsl' or 'glsl'")
    code, source_name, language = _read_source(source, language)
    if not isinstance(entry, str) or not entry.isidentifier():
        v.fail("entry", entry, "a function name")
    defines = dict(defines or {})
    for key, value in defines.items():
        if not isinstance(key, str) or not key.isidentifier():
            v.fail("defines", key, "macro names that are identifiers")
        if value is None and not none_defines:
            v.fail(f"defines[{key!r}]", value, "a string, a number or True/False (\"\" for a define without a value)")
    if isinstance(include_dirs, (str, os.PathLike)):
        include_dirs = [include_dirs]
    v.positive("timeout", timeout, "a number of seconds > 0")
    return {"code": code, "source_name": source_name, "entry": entry, "language": language,
            "defines": sorted((k, _define_value(k, val)) for k, val in defines.items()),
            "include_dirs": [_utf8("include_dirs", os.fspath(d)) for d in include_dirs] + [str(d) for d in defaults],
            "device": _device_request(device), "timeout": float(timeout), "resources": dict(resources or {})}


class ShaderLaw(ShaderBacked, CustomLaw):
    """A counting law computed by a shader function on a Vulkan device (see ``shader_law``).

    It is a custom law to the rest of glintlab (sampling, chi-square, sweeps, bounds, extremes,
    blends, the report), with the shader's output as the count: float32 arithmetic whatever
    ``precision`` is asked (both give the same numbers). A NaN, infinite or negative count is an
    error naming the row. ``device`` names the Vulkan device it runs on.
    """

    kind = "shader law"

    def __init__(self, spec: dict):
        ShaderBacked.__init__(self, spec)
        self._kernel  # compiled now: a law that does not compile is refused when made
        s = self._spec
        CustomLaw.__init__(self, self._run, s["n_uniforms"], s["name"], s["binning"])

    def _make_kernel(self, s, includes):
        return _core.ShaderKernel(s["code"], s["source_name"], s["entry"], s["language"], s["n_uniforms"],
                                  [(k, str(val)) for k, val in s["defines"]], list(s["include_dirs"]), s["device"],
                                  includes)

    @property
    def identity(self) -> str:
        """``shader:<sha256 of the SPIR-V and the device>:<binning>:<name>``: the compiled code (with
        its #includes and defines) and the device that runs it (GPUs differ in pow, exp, log)."""
        return f"shader:{self._digest()}:{self._binning}:{self._name}"

    def __repr__(self):
        return f"ShaderLaw({self._name!r}, {self.language}, device={self.device!r})"

    def _run(self, n_rows, p_rows, u):
        out = np.empty(u.shape[0])
        timeout = self._spec["timeout"]
        for i0 in range(0, u.shape[0], _CHUNK):
            i1 = min(u.shape[0], i0 + _CHUNK)
            nn = n_rows if n_rows.size == 1 else n_rows[i0:i1]
            pp = p_rows if p_rows.size == 1 else p_rows[i0:i1]
            out[i0:i1] = self._kernel.run(nn, pp, u[i0:i1], timeout)
        return out

    def _call(self, nf, pf, u, precision="float64"):
        m = u.shape[0]
        nf = np.ascontiguousarray(nf, dtype=np.float64).reshape(-1)
        pf = np.ascontiguousarray(pf, dtype=np.float64).reshape(-1)
        out = self._run(nf, pf, np.ascontiguousarray(u, dtype=np.float64))
        try:
            _require_finite(f"shader law {self._name!r}", out, nf, pf)
        except ValueError as exc:
            raise ShaderOutputError(str(exc)) from None
        bad = out < 0
        if bad.any():
            i = int(np.argmax(bad))
            raise ShaderOutputError(f"shader law {self._name!r} returned {out[i]} at row {i} (n = {nf[i % nf.size]}, "
                             f"p = {pf[i % pf.size]}); counts must be >= 0")
        if out.shape != (m,):
            raise ValueError(f"shader law {self._name!r} returned shape {out.shape}; expected ({m},)")
        return out

    def evaluate_raw(self, n, p, u) -> np.ndarray:
        """What the shader returns, NaN, inf and negative values included (``evaluate`` refuses them):
        for the extremes suite and for inspecting a faulty shader."""
        u = _uniform_rows(u, self._k)
        nf, pf, _ = v.broadcast_params(n, p, (u.shape[0],))
        return self._run(np.ascontiguousarray(nf).reshape(-1), np.ascontiguousarray(pf).reshape(-1), u)


def shader_law(source, entry: str = "count", language: str | None = None, n_uniforms: int = 2,
               name: str | None = None, defines: dict | None = None, include_dirs=(), device: str = "auto",
               binning: str = "round", timeout: float = DEFAULT_TIMEOUT_S, register: bool = True,
               textures: dict | None = None, samplers: dict | None = None, buffers: dict | None = None,
               uniforms: dict | None = None) -> ShaderLaw:
    """A counting law computed by a shader function, compiled by shaderc and run by Vulkan.

    ``source``: a file path (``.hlsl``, ``.glsl``, ...) or the code as a string (a string on one line
    without any of ``( { ; }`` is a path). Files are UTF-8 (a byte-order mark is dropped). The code
    defines ``float <entry>(float n, float p, float4 u)`` (GLSL: ``vec4 u``) and may ``#include``
    files next to it or in ``include_dirs``; ``defines`` ({"NAME": value}) are passed as
    ``-D NAME=value`` (True/False as 1/0, None as a define without a value).
    ``language``: "hlsl" or "glsl" (default: from the extension; "hlsl" for code in a string).
    ``n_uniforms``: 0 to 4. ``device``: "auto" (a GPU when there is one, else lavapipe), "gpu", "cpu",
    a device index (int or digits) or part of its name (``vulkan_devices()``). ``binning``: "round" (default: real
    outputs, round half up, as the built-in real-valued laws) or "none" (the shader returns integer
    counts). ``timeout``: seconds a submission may run before a ``TimeoutError`` (``ShaderDeviceBusy``,
    a ``TimeoutError`` too, when it waited that long behind an earlier kernel that had timed out).

    Unless ``register`` is False, the law is registered as a custom law under ``name`` (default: the
    file's name, e.g. "gated.hlsl", or "shader"), so
    experiments, sweeps and bounds can name it. ``textures``, ``samplers``, ``buffers``, ``uniforms``:
    the data of the read-only resources the code declares, by name (``glintlab.api.shader_resources``;
    a declared resource left unbound, a name never declared or data that does not fit its declaration is
    a ``ValueError`` naming it). A shader that does not compile raises ``ValueError``
    with the compiler's messages (file:line), as does one declaring a resource glintlab cannot bind
    (a storage image, a push constant of its own) and an ``#include`` cycle; no Vulkan device raises
    ``RuntimeError`` naming the package to install. A NaN, infinite or negative count from ``sample``
    or ``evaluate`` raises ``ShaderOutputError`` (a ``ValueError``).
    """
    spec = kernel_spec(source, language, entry, defines, include_dirs, device, timeout,
                       resources=shader_resources.resource_spec(textures, samplers, buffers, uniforms))
    v.integer("n_uniforms", n_uniforms, 0, 4, expected="an integer from 0 to 4")
    if name is None:
        name = Path(spec["source_name"]).name if spec["source_name"] != "<string>" else "shader"
    if not isinstance(name, str) or not name:
        v.fail("name", name, "a non-empty string")
    _utf8("name", name)
    if name in {n for n, _ in _core.law_infos()}:
        v.fail("name", name, "a name that no built-in law uses")
    v.choice("binning", binning, BINNINGS, "'round' (real outputs, unit bins) or 'none' (integer counts)")
    spec.update(n_uniforms=int(n_uniforms), name=name, binning=binning)
    law_ = ShaderLaw(spec)
    if register:
        CUSTOM_LAWS.register(name, law_, replace=True)
    return law_
