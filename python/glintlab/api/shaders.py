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
from pathlib import Path

import numpy as np

from .. import _core
from ..resources import data_path
from . import checks as v
from .laws import BINNINGS, CustomLaw, _require_finite, _uniform_rows, law, uniforms_float32
from .plugins import CUSTOM_LAWS

LANGUAGES = ("hlsl", "glsl")
_EXTENSIONS = {".hlsl": "hlsl", ".hlsli": "hlsl", ".fx": "hlsl", ".glsl": "glsl", ".comp": "glsl"}
DEFAULT_TIMEOUT_S = 60.0
_CHUNK = 1 << 22  # rows handed to the runner at once (the runner submits 2^20 at a time)

# The shipped shaders: name -> the C++ law that is its twin (same arithmetic in float32).
SHIPPED = {"gated": "gated_shader", "gated_continuous": "gated_continuous", "dual_gated": "dual_gated",
           "head_cf": "head_cf"}


def vulkan_devices() -> list[dict]:
    """Every Vulkan device the loader sees: ``index``, ``name`` (e.g. "llvmpipe (LLVM 15.0.6, 256
    bits)"), ``type`` ("discrete_gpu", "integrated_gpu", "cpu", ...), ``api_version`` and ``driver``.
    Empty when there is none (then install mesa-vulkan-drivers for lavapipe)."""
    return list(_core.vulkan_devices())


def shipped_shader(name: str, language: str = "hlsl") -> Path:
    """The path of a shader glintlab ships (``SHIPPED``: "gated", "gated_continuous", "dual_gated",
    "head_cf"), in "hlsl" or "glsl"."""
    if name not in SHIPPED:
        v.fail("name", name, f"a shipped shader among {sorted(SHIPPED)}")
    if language not in LANGUAGES:
        v.fail("language", language, "'hlsl' or 'glsl'")
    return Path(data_path("shaders", f"{name}.{language}"))


def shipped_twin(name: str):
    """The C++ law that computes what the shipped shader ``name`` computes (in float32)."""
    if name not in SHIPPED:
        v.fail("name", name, f"a shipped shader among {sorted(SHIPPED)}")
    return law(SHIPPED[name])


def _read_source(source, language):
    """(code, source_name, language) from a path or from the code itself."""
    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source and
                                     (os.path.splitext(source)[1].lower() in _EXTENSIONS or os.path.isfile(source))):
        path = Path(source)
        if not path.is_file():
            v.fail("source", str(source), "an existing shader file or the shader code as a string")
        code = path.read_text(encoding="utf-8")
        if language is None:
            language = _EXTENSIONS.get(path.suffix.lower())
            if language is None:
                v.fail("language", None, f"'hlsl' or 'glsl' (the extension {path.suffix!r} does not say)")
        return code, str(path.resolve()), language
    if not isinstance(source, str) or not source.strip():
        v.fail("source", source, "a shader file path or the shader code as a non-empty string")
    return source, "<string>", language or "hlsl"


class ShaderLaw(CustomLaw):
    """A counting law computed by a shader function on a Vulkan device (see ``shader_law``).

    It is a custom law to the rest of glintlab (sampling, chi-square, sweeps, bounds, extremes,
    blends, the report), with the shader's output as the count: float32 arithmetic whatever
    ``precision`` is asked (both give the same numbers). A NaN, infinite or negative count is an
    error naming the row. ``device`` names the Vulkan device it runs on.
    """

    def __init__(self, spec: dict):
        self._spec = dict(spec)
        s = self._spec
        self._kernel = _core.ShaderKernel(s["code"], s["source_name"], s["entry"], s["language"], s["n_uniforms"],
                                          [(k, str(val)) for k, val in s["defines"]], list(s["include_dirs"]),
                                          s["device"])
        super().__init__(self._run, s["n_uniforms"], s["name"], s["binning"])

    device = property(lambda self: self._kernel.device, doc="The Vulkan device's name.")
    device_type = property(lambda self: self._kernel.device_type, doc='"cpu", "discrete_gpu", ...')
    language = property(lambda self: self._spec["language"])
    entry = property(lambda self: self._spec["entry"])
    source_name = property(lambda self: self._spec["source_name"])
    spirv = property(lambda self: self._kernel.spirv, doc="The SPIR-V the pipeline runs (bytes).")

    @property
    def identity(self) -> str:
        """``shader:<sha256 of the SPIR-V and the device>:<binning>:<name>``: the compiled code (with
        its #includes and defines) and the device that runs it (GPUs differ in pow, exp, log)."""
        digest = hashlib.sha256(self._kernel.spirv + self.device.encode()).hexdigest()[:16]
        return f"shader:{digest}:{self._binning}:{self._name}"

    def __repr__(self):
        return f"ShaderLaw({self._name!r}, {self.language}, device={self.device!r})"

    def __reduce__(self):  # the code travels by value (Dask workers compile it again)
        return (ShaderLaw, (self._spec,))

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
        _require_finite(f"shader law {self._name!r}", out, nf, pf)
        bad = out < 0
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"shader law {self._name!r} returned {out[i]} at row {i} (n = {nf[i % nf.size]}, "
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
               binning: str = "round", timeout: float = DEFAULT_TIMEOUT_S, register: bool = True) -> ShaderLaw:
    """A counting law computed by a shader function, compiled by shaderc and run by Vulkan.

    ``source``: a file path (``.hlsl``, ``.glsl``, ...) or the code as a string. The code defines
    ``float <entry>(float n, float p, float4 u)`` (GLSL: ``vec4 u``) and may ``#include`` files next
    to it or in ``include_dirs``; ``defines`` ({"NAME": value}) are passed as ``-D NAME=value``.
    ``language``: "hlsl" or "glsl" (default: from the extension; "hlsl" for code in a string).
    ``n_uniforms``: 0 to 4. ``device``: "auto" (a GPU when there is one, else lavapipe), "gpu", "cpu",
    a device index or part of its name (``vulkan_devices()``). ``binning``: "round" (default: real
    outputs, round half up, as the built-in real-valued laws) or "none" (the shader returns integer
    counts). ``timeout``: seconds a submission may run before a ``TimeoutError``.

    Unless ``register`` is False, the law is registered as a custom law under ``name`` (default: the
    file's name, e.g. "gated.hlsl", or "shader"), so
    experiments, sweeps and bounds can name it. A shader that does not compile raises ``ValueError``
    with the compiler's messages (file:line); no Vulkan device raises ``RuntimeError`` naming the
    package to install.
    """
    if language is not None and language not in LANGUAGES:
        v.fail("language", language, "'hlsl' or 'glsl'")
    code, source_name, language = _read_source(source, language)
    if not isinstance(entry, str) or not entry.isidentifier():
        v.fail("entry", entry, "a function name")
    if isinstance(n_uniforms, bool) or not isinstance(n_uniforms, (int, np.integer)) or not 0 <= n_uniforms <= 4:
        v.fail("n_uniforms", n_uniforms, "an integer from 0 to 4")
    if name is None:
        name = Path(source_name).name if source_name != "<string>" else "shader"
    if not isinstance(name, str) or not name:
        v.fail("name", name, "a non-empty string")
    if name in {n for n, _ in _core.law_infos()}:
        v.fail("name", name, "a name that no built-in law uses")
    defines = dict(defines or {})
    for key in defines:
        if not isinstance(key, str) or not key.isidentifier():
            v.fail("defines", key, "macro names that are identifiers")
    if isinstance(include_dirs, (str, Path)):
        include_dirs = [include_dirs]
    if binning not in BINNINGS:
        v.fail("binning", binning, "'round' (real outputs, unit bins) or 'none' (integer counts)")
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not (0 < timeout < float("inf")):
        v.fail("timeout", timeout, "a number of seconds > 0")
    if not isinstance(device, str):
        v.fail("device", device, "'auto', 'gpu', 'cpu', a device index or part of a device name")
    spec = {"code": code, "source_name": source_name, "entry": entry, "language": language,
            "n_uniforms": int(n_uniforms), "name": name,
            "defines": sorted((k, "1" if val is True else str(val)) for k, val in defines.items()),
            "include_dirs": [str(d) for d in include_dirs], "device": device, "binning": binning,
            "timeout": float(timeout)}
    law_ = ShaderLaw(spec)
    if register:
        CUSTOM_LAWS.register(name, law_, replace=True)
    return law_
