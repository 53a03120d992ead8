"""What a real GPU compiler makes of a shader glintlab runs, without a GPU (docs/guide/gpu_cost.md).

Mesa's RADV Vulkan driver creates a *null device* for an AMD GPU family named by ``RADV_FORCE_FAMILY``:
nothing executes on it, but it compiles SPIR-V through ACO, the compiler AMD GPUs run under Linux, and
reports per pipeline its instructions, registers, spills, occupancy (waves per SIMD) and ACO's latency
and inverse-throughput estimates in cycles, with the ISA. :func:`gpu_cost` compiles the very kernel
glintlab runs (the SPIR-V of a shader law, a method shader or a shader sampler: glintlab's wrapper
around the user's function) for each architecture, and the same wrapper around a function that only
reads its arguments, so the wrapper's share is reported apart from the user's function.

>>> sorted(gpu_architectures().arch)[:2]
['gfx1036', 'gfx1100']
"""
from __future__ import annotations

import functools
import os
import re
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd

from .. import _core
from . import checks as V
from .counting_shaders import DEFAULT_MATERIAL
from .glinty_ndf import IMAGE_METHODS, image_methods, make_method
from .method_shaders import ShaderMethod, shader_method
from .shader_samplers import SHIPPED_SAMPLERS, ShaderSampler, shader_sampler, shipped_sampler
from .shaders import ShaderLaw, shader_law, shipped_shader, shipped_shaders

#: RDNA2 and RDNA3, the architectures the report's tables use by default.
DEFAULT_ARCHS = ("navi21", "gfx1100")
#: The driver's statistic names and the table's columns.
STATISTICS = {"Instructions": "instructions", "VGPRs": "vgprs", "SGPRs": "sgprs", "Spilled VGPRs": "spilled_vgprs",
              "Spilled SGPRs": "spilled_sgprs", "Subgroups per SIMD": "waves_per_simd", "Latency": "latency",
              "Inverse Throughput": "inverse_throughput", "Code size": "code_size", "Scratch size": "scratch_bytes",
              "LDS size": "lds_bytes", "Copies": "copies", "Branches": "branches"}
#: The additive statistics, also given for the wrapper alone and for the function (kernel - wrapper).
ADDITIVE = ("instructions", "latency", "inverse_throughput", "code_size")

# The empty user function of each contract: it reads every argument (so the wrapper's loads stay) and
# returns their sum. {kind: {language: code}}.
_EMPTY = {
    "law": {"hlsl": "float {entry}(float n, float p, float4 u) {{ return n + p + u.x + u.y + u.z + u.w; }}\n",
            "glsl": "float {entry}(float n, float p, vec4 u) {{ return n + p + u.x + u.y + u.z + u.w; }}\n"},
    "method": {lang: ("float {entry}(GlintInput g) {{ return g.world_pos.x + g.uv.x + g.uv.y + g.J.x + g.J.y + g.J.z"
                      " + g.J.w + g.n.z + g.t.x + g.b.y + g.view.z + g.light.x + g.h.x + g.h.y + g.h.z"
                      " + float(g.pixel.x + g.pixel.y + g.frame + g.seed); }}\n") for lang in ("hlsl", "glsl")},
    "sampler": {"hlsl": "float4 sample_h(float2 uv, float4 J, float3 wo, float4 u) { return u + float4(uv, wo.z, J.x); }\n"
                        "float pdf_h(float2 uv, float4 J, float3 wo, float3 h) { return h.x + uv.y + J.w + wo.x; }\n",
                "glsl": "vec4 sample_h(vec2 uv, vec4 J, vec3 wo, vec4 u) { return u + vec4(uv, wo.z, J.x); }\n"
                        "float pdf_h(vec2 uv, vec4 J, vec3 wo, vec3 h) { return h.x + uv.y + J.w + wo.x; }\n"},
}


def gpu_architectures() -> pd.DataFrame:
    """The architectures glintlab knows (``arch``, ``generation``, the named ``gpu`` the cost model spreads
    waves over, ``wave_size``, ``compute_units``, ``simds_per_cu``, ``clock_mhz``) and whether the installed
    driver knows each (``available``)."""
    known = set(_core.gpu_known_architectures())
    rows = [dict(a, available=a["arch"] in known) for a in _core.gpu_architectures()]
    return pd.DataFrame(rows)


def gpu_driver() -> dict:
    """``library`` (the RADV library opened) and ``error`` (why it cannot be, "" when it can)."""
    library, error = _core.gpu_driver()
    return {"library": library, "error": error}


def _archs(arch) -> tuple:
    archs = (arch,) if isinstance(arch, str) else tuple(arch)
    if not archs or not all(isinstance(a, str) for a in archs):
        V.fail("arch", arch, "an architecture name or a list of them (gl.gpu_architectures())")
    return archs


def compile_stats(spirv: bytes, arch: str, isa: bool = False) -> dict:
    """One compile of SPIR-V ``spirv`` (a compute kernel of glintlab's runner layout) for ``arch``: the
    table's columns, plus ``driver``, ``device`` and, when ``isa``, ``isa`` (the assembly) and ``aco_ir``."""
    if not isinstance(spirv, (bytes, bytearray)):
        V.fail("spirv", type(spirv).__name__, "the SPIR-V as bytes (a shader object's .spirv)")
    return _stats_row(_core.gpu_compile_stats(bytes(spirv), arch, bool(isa)), isa)


def _stats_row(raw: dict, isa: bool) -> dict:
    stats = dict(raw["statistics"])
    out = {"arch": raw["arch"], "wave_size": raw["subgroup_size"]}
    out.update({col: stats.get(name, float("nan")) for name, col in STATISTICS.items()})
    out["driver"], out["device"] = raw["driver"], raw["device_name"]
    if isa:
        reps = dict(raw["representations"])
        out["isa"], out["aco_ir"] = reps.get("Assembly", ""), reps.get("ACO IR", "")
    return out


def _kind(obj) -> str:
    for cls, kind in ((ShaderLaw, "law"), (ShaderMethod, "method"), (ShaderSampler, "sampler")):
        if isinstance(obj, cls):
            return kind
    return "method" if hasattr(obj, "shade") else "law"


def _detect_kind(path: Path) -> str:
    # The file and the files it includes from its folder (a thin wrapper names its body).
    text = path.read_text(encoding="utf-8", errors="replace")
    for name in re.findall(r'^\s*#\s*include\s+"([^"]+)"', text, flags=re.M):
        if (path.parent / name).is_file():
            text += (path.parent / name).read_text(encoding="utf-8", errors="replace")
    if ("sample_h" in text and "pdf_h" in text) or ("sample_l" in text and "pdf_l" in text):
        return "sampler"
    return "method" if "GlintInput" in text or "_method_body.h" in text else "law"


def _from_file(path: Path, kind: str | None, options: dict):
    kind = kind or _detect_kind(path)
    opts = {k: v for k, v in options.items() if v is not None}
    if kind == "law":
        return shader_law(path, register=False, **opts)
    opts.pop("n_uniforms", None)
    if kind == "method":
        return shader_method(path, register=False, **opts)
    opts.pop("entry", None)
    return shader_sampler(path, **opts)


def resolve_shader(shader, kind: str | None = None, **options):
    """The shader object ``shader`` names: an object with ``.spirv`` as is; a shipped law shader's name (or
    its law's), a method shader's image-method name ("db23_shader", "zk16_shader", ...), a shipped
    sampler's name, or a file (its kind from ``kind`` or its code: a GlintInput function is a method,
    sample_h and pdf_h, or sample_l and pdf_l, a sampler, else a counting law) compiled with ``options`` (those of
    ``glintlab shader``: entry, language, n_uniforms, defines, include_dirs, device)."""
    if hasattr(shader, "spirv"):
        return shader
    V.choice("kind", kind, (None, "law", "method", "sampler"), "'law', 'method' or 'sampler'")
    if isinstance(shader, os.PathLike) or (isinstance(shader, str) and os.path.isfile(shader)):
        return _from_file(Path(shader), kind, options)
    if not isinstance(shader, str):
        V.fail("shader", shader, "a shader object, a shader file or a shipped shader's name")
    language = options.get("language") or "hlsl"
    if shader in shipped_shaders() or shader in shipped_shaders().values():
        return shader_law(shipped_shader(shader, language), register=False, defines=options.get("defines"))
    if shader in SHIPPED_SAMPLERS:
        return shader_sampler(shipped_sampler(shader, language), defines=options.get("defines"))
    if shader in image_methods():
        method = make_method(shader, options.get("material") or DEFAULT_MATERIAL)
        if hasattr(method, "spirv"):
            return method
    names = sorted({*shipped_shaders(), *SHIPPED_SAMPLERS, *shader_method_names()})
    V.fail("shader", shader, f"a shader file or a shipped shader ({', '.join(names)})")


def shader_method_names() -> list[str]:
    """The image methods that are method shaders (have SPIR-V): those glintlab ships (their registry entry
    carries a ``ShippedShader``) and the user's own (``gl.shader_method``)."""
    return [m for m in image_methods()
            if IMAGE_METHODS.get(m).shader is not None or IMAGE_METHODS.get(m).origin == "shader_method"]


def empty_twin(obj):
    """The same kind of shader object, language and entry as ``obj`` with a function that only reads its
    arguments: its kernel is glintlab's wrapper alone."""
    kind = _kind(obj)
    language = getattr(obj, "language", None) or getattr(obj, "_spec", {}).get("language", "hlsl")
    entry = getattr(obj, "entry", None) or (getattr(obj, "params", {}) or {}).get("entry")
    return _empty(kind, language, entry, int(getattr(obj, "n_uniforms", 2) or 0) if kind == "law" else 0)


@functools.lru_cache(maxsize=32)
def _empty(kind: str, language: str, entry: str | None, n_uniforms: int):
    # One wrapper kernel per contract (every law of a language shares it): compiled once per process.
    if kind == "law":
        code = _EMPTY["law"][language].format(entry=entry or "count")
        return shader_law(code, entry=entry or "count", language=language, n_uniforms=n_uniforms, register=False)
    if kind == "method":
        code = _EMPTY["method"][language].format(entry=entry or "glint")
        return shader_method(code, language=language, entry=entry or "glint", register=False)
    return shader_sampler(_EMPTY["sampler"][language], language=language)


def gpu_cost(shader, arch=DEFAULT_ARCHS, isa: bool = False, wrapper: bool = True, kind: str | None = None,
             **options) -> pd.DataFrame:
    """The GPU compiler's statistics of ``shader``'s kernel, one row per architecture of ``arch``:
    ``arch``, ``wave_size``, ``instructions``, ``vgprs``, ``sgprs``, ``spilled_vgprs``, ``spilled_sgprs``,
    ``waves_per_simd``, ``latency`` and ``inverse_throughput`` (ACO's estimates, cycles per wave),
    ``code_size`` (bytes), ``scratch_bytes``, ..., ``driver`` (e.g. "radv Mesa 22.3.6") and ``device``; with
    ``wrapper`` also ``wrapper_<s>`` (glintlab's wrapper around a function that only reads its arguments)
    and ``function_<s>`` (the kernel's minus the wrapper's) for the additive statistics; with ``isa`` the
    ``isa`` and ``aco_ir`` texts. ``shader``: a shader object, a file or a shipped name (:func:`resolve_shader`,
    ``options`` as ``glintlab shader``). An unknown architecture raises ValueError naming the known ones;
    a missing RADV raises RuntimeError."""
    archs = _archs(arch)
    # The null devices' instances here (refusing an unknown architecture before any compile), their devices
    # (RADV compiles its own shaders then, ~0.2 s of CPU each on RDNA2 and later) on a thread beside the
    # SPIR-V compiles.
    _core.gpu_open_devices(list(archs), False)
    with ThreadPoolExecutor(max_workers=1) as pool:
        opening = pool.submit(_core.gpu_open_devices, list(archs), True)
        obj = resolve_shader(shader, kind=kind, **options)
        modules = [obj.spirv] + ([empty_twin(obj).spirv] if wrapper else [])
        opening.result()
    # Every architecture on a thread of its own (its device's creation and its compiles side by side).
    raw = _core.gpu_compile_stats_many(modules, list(archs), bool(isa))
    rows = []
    for i in range(len(archs)):
        row = {"shader": getattr(obj, "name", str(shader)), **_stats_row(raw[i * len(modules)], isa)}
        if wrapper:
            base = _stats_row(raw[i * len(modules) + 1], False)
            for col in ADDITIVE:
                row[f"wrapper_{col}"] = base[col]
                row[f"function_{col}"] = row[col] - base[col]
        rows.append(row)
    return pd.DataFrame(rows)
