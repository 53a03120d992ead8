"""Whole glint methods written as shaders: one per-pixel function, run by glintlab over a frame's inputs
(docs/math/glint_images.md#glint-contract).

The contract a method shader meets is one function (HLSL; GLSL writes ``vec3``)::

    float glint(GlintInput g)      or      float3 glint(GlintInput g)

with ``GlintInput`` declared by the include file glintlab ships (``glintlab_method_hlsl.h`` /
``glintlab_method_glsl.h`` in ``glintlab/data/shaders/``; the wrapper includes it before the method's
code): ``world_pos``, ``uv``, ``J`` (du/dx, dv/dx, du/dy, dv/dy), ``n``, ``t``, ``b`` (shading frame),
``view`` (unnormalised, surface to camera), ``light``, ``h``, ``pixel`` (column, row from the top left),
``frame`` and ``seed``, every vector in world space and float32. The include also provides a hash and
a hashed value noise (``glintlab_noise3``) standing in for a 3D noise texture.

``shader_method(source)`` compiles the function inside glintlab's compute kernel with the shader-law
runner (shaderc, Vulkan; lavapipe on the CPU) and registers it as an image method:
``gl.render(method, scene)`` returns its image. WB16's sparkle shader (Code 2) ships as the image method
``"wb16"`` (GLSL and HLSL, one body) with a C++ twin (:func:`wb16_twin`) that computes the same float32
arithmetic (and its first, numpy, form :func:`wb16_twin_numpy`).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .. import _core
from ..resources import data_path
from . import checks as V
from . import fpmath, shader_resources
from .glinty_ndf import IMAGE_METHODS, GlintyNDF, register_image_method
from .shaders import DEFAULT_TIMEOUT_S, ShaderBacked, ShaderOutputError, kernel_spec

_WORDS = {"float": 1, "vec2": 2, "vec3": 3, "vec4": 4, "uint": 1, "uvec2": 2}
#: The fields of GlintInput in the order of the row (METHOD_INPUT_WORDS words) the wrapper reads: (name, first word, words),
#: from the method shader's wrapper declaration (validation/src/method_runner.cpp), the one table.
GLINT_INPUT_FIELDS = tuple((name, word, _WORDS[kind]) for name, kind, word in _core.METHOD_INPUT_FIELDS)
_INTEGER_FIELDS = tuple(name for name, kind, _ in _core.METHOD_INPUT_FIELDS if kind.startswith("u"))
WB16_SHADER = "wb16.glsl"
#: The shipped WB16 method shader per language: thin wrappers around one body (wb16_body.h).
WB16_SHADERS = {"glsl": "wb16.glsl", "hlsl": "wb16.hlsl"}
#: WB16's parameters (the shader's -D defaults; the paper gives no values).
WB16_DEFAULTS = {"WB16_SPARKLE_SIZE": 0.9, "WB16_SPARKLE_DENSITY": 30.0, "WB16_VIEW_DEP": 1.0,
                 "WB16_NOISE_AMOUNT": 1.0, "WB16_NOISE_DENSITY": 1.0, "WB16_UNIT": 10.0, "WB16_SHAPE": 0,
                 "WB16_SHOPF_K": 3.0, "WB16_NOISE": 0, "WB16_ANISOTROPIC": 1, "WB16_KERNEL_SCALE": 1.0}


def pack_inputs(m: int, **fields) -> np.ndarray:
    """The (m, METHOD_INPUT_WORDS) uint32 rows of ``m`` pixels: every GlintInput field given by name (arrays of shape
    (m, k) or broadcastable), floats converted to float32, ``pixel``, ``frame`` and ``seed`` as
    unsigned integers. Missing fields are 0."""
    rows = np.zeros((m, _core.METHOD_INPUT_WORDS), np.uint32)
    known = {name: (lo, k) for name, lo, k in GLINT_INPUT_FIELDS}
    for name, value in fields.items():
        if name not in known:
            V.fail("fields", name, f"GlintInput fields among {', '.join(known)}")
        lo, k = known[name]
        if name in _INTEGER_FIELDS:
            a = np.asarray(value)
            if a.size and (not np.issubdtype(a.dtype, np.integer) or a.min() < 0 or a.max() > 0xFFFFFFFF):
                V.fail(name, value, "unsigned 32-bit integers")
            rows[:, lo:lo + k] = np.broadcast_to(a.reshape((-1, k)) if a.ndim else a, (m, k)).astype(np.uint32)
        else:
            a = np.asarray(V.as_float_array(name, value), np.float32)
            rows[:, lo:lo + k] = np.broadcast_to(a.reshape((-1, k)) if a.ndim else a, (m, k)).view(np.uint32)
    return rows


def unpack_inputs(rows: np.ndarray) -> dict:
    """The GlintInput fields of packed rows, as the shader reads them (float32; uint32 integers)."""
    out = {}
    for name, lo, k in GLINT_INPUT_FIELDS:
        w = np.ascontiguousarray(rows[:, lo:lo + k])
        out[name] = w if name in _INTEGER_FIELDS else w.view(np.float32)
    return out


#: GlintInput's ``seed`` and ``frame`` are one 32-bit word each: a method shader takes seeds and frames
#: below 2^32 and refuses larger ones by name (docs/guide/shaders.md#shaders-methods). Wrapped to their
#: low 32 bits, seed 2^32 would render seed 0's image.
SEED_LIMIT = 2**32


def shader_seed(seed, method: str = "a method shader", what: str = "seed") -> int:
    """``seed`` (``checks.seed``: an int, None, a SeedSequence or a Generator) as GlintInput's 32-bit
    word; a value >= 2^32 is refused naming ``method`` (ValueError), never wrapped onto another seed."""
    s = V.seed(seed)
    if s >= SEED_LIMIT:
        V.fail(what, seed, f"an integer in [0, 2^32) for {method} (GlintInput's {what} is one 32-bit word: a "
                           f"larger {what} would reach the shader as its low 32 bits, another {what}'s image)")
    return s


def frame_rows(inputs, seed: int = 0, frame: int = 0, method: str = "a method shader"):
    """(rows, mask): the packed rows of the pixels of one frame's inputs (``FrameInputs`` of the scene
    images) where the surface is hit, and that (H, W) mask. ``seed`` and ``frame`` must be < 2^32
    (:func:`shader_seed`; ``method`` names the shader in the message)."""
    seed, frame = shader_seed(seed, method), shader_seed(frame, method, "frame")
    hit = inputs.hit if inputs.hit is not None else inputs.mask
    if inputs.world_pos is None:
        V.fail("inputs", "frame inputs without world-space fields", "FrameInputs from frame_inputs(scene)")
    row, col = np.nonzero(hit)
    # One float32 block of the 27 float words, masked once (the fields in GLINT_INPUT_FIELDS order).
    floats = np.concatenate([np.asarray(a, np.float32) for a in (inputs.world_pos, inputs.uv, inputs.J, inputs.n,
                                                                 inputs.t, inputs.b, inputs.view, inputs.light,
                                                                 inputs.h_world)], axis=-1)[hit]
    rows = np.zeros((row.size, _core.METHOD_INPUT_WORDS), np.uint32)
    rows[:, :27] = floats.view(np.uint32)
    rows[:, 27], rows[:, 28] = col, row
    rows[:, 29], rows[:, 30] = frame, seed
    return rows, hit


class ShaderMethod(ShaderBacked, GlintyNDF):
    """An image method computed by a shader function per pixel (see :func:`shader_method`). Its
    ``image(inputs, seed, frame)`` runs the shader on every pixel that sees the surface (0 elsewhere);
    ``run(rows)`` on packed rows (:func:`pack_inputs`) returns the raw (m, 4) output. The kernel's
    properties, pickling and device are the shader-backed objects' (``shaders.ShaderBacked``)."""

    returns = "intensity"
    kind = "method shader"

    def __init__(self, spec: dict):
        ShaderBacked.__init__(self, spec)
        self._describe()
        self.target, self.alpha, self.density = None, None, None
        self._kernel  # compiled now: a method that does not compile is refused when made

    def _describe(self):
        s = self._spec
        self.name = s["name"]
        self.params = {"source": s["source_name"], "entry": s["entry"], "language": s["language"],
                       **dict(s["defines"])}

    def _make_kernel(self, s, includes):
        return _core.MethodKernel(s["code"], s["source_name"], s["entry"], s["language"],
                                  [(k, str(val)) for k, val in s["defines"]], list(s["include_dirs"]), s["device"],
                                  includes)

    @property
    def identity(self) -> str:
        """``method_shader:<sha256 of the SPIR-V and the device>:<name>``."""
        return f"method_shader:{self._digest()}:{self.name}"

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r}, {self.language}, device={self.device!r})"

    def smooth(self, h):
        raise NotImplementedError(f"method shader {self.name!r} returns an intensity: it has no smooth target")

    def run(self, rows, timing: bool = False):
        """The shader on packed rows (m, METHOD_INPUT_WORDS) uint32: (m, 4) float32, (r, g, b, channels). With
        ``timing``, the pair (output, milliseconds): the device's time of each dispatch (one per 262,144 rows),
        read from Vulkan timestamps written before and after it (the upload and read-back outside; on
        lavapipe, a CPU device, its CPU threads' time). A device without timestamps raises RuntimeError."""
        rows = np.ascontiguousarray(rows, dtype=np.uint32)
        if rows.ndim != 2 or rows.shape[1] != _core.METHOD_INPUT_WORDS:
            V.fail("rows", f"an array of shape {rows.shape}", f"an array of shape (m, {_core.METHOD_INPUT_WORDS})")
        if not timing:
            return self._kernel.run(rows, self._spec["timeout"])
        out, ms = self._kernel.run(rows, self._spec["timeout"], timing=True)
        return out, np.asarray(ms, dtype=np.float64)

    def shade(self, rows) -> np.ndarray:
        """The shader's values per row: (m,) for a float method, (m, 3) for a colour one."""
        out = self.run(rows)
        return out[:, 0] if out.shape[0] == 0 or out[0, 3] == 1.0 else out[:, :3]

    def image(self, inputs, seed: int = 0, frame: int = 0) -> np.ndarray:
        """One frame's image: (H, W), or (H, W, 3) for a colour method, the shader's output where the
        surface is hit, 0 elsewhere. A NaN, infinite or negative value raises ``ShaderOutputError``
        naming the method, the frame and the number of pixels (``run`` returns the raw output)."""
        rows, hit = frame_rows(inputs, seed, frame, f"method shader {self.name!r}")
        out = self.run(rows)
        colour = out.shape[0] > 0 and out[0, 3] == 3.0
        values = out[:, :3] if colour else out[:, 0]
        check_output(self.name, values, f"frame {frame}", "intensity")
        img = np.zeros(hit.shape + ((3,) if colour else ()))
        img[hit] = values
        return img


def check_output(name: str, values, where: str, what: str = "intensity") -> None:
    """Refuses a method shader's faulty output (``ShaderOutputError``): NaN, infinite or negative values
    (an intensity or an NDF value D is >= 0), counted per kind, naming the method and ``where`` (e.g.
    "frame 3") so that a verdict counts it as a failed check, not bad input."""
    values = np.asarray(values)
    with np.errstate(invalid="ignore"):
        nonfinite = ~np.isfinite(values)
        negative = values < 0
    if values.ndim > 1:  # a colour method: a pixel is faulty when one of its channels is
        nonfinite, negative = nonfinite.any(axis=-1), negative.any(axis=-1)
    faults = [f"{int(c.sum())} {kind}" for c, kind in ((nonfinite, "non-finite"), (negative, "negative")) if c.any()]
    if faults:
        raise ShaderOutputError(f"method shader {name!r} returned {' and '.join(faults)} {what} values on "
                                f"{int((nonfinite | negative).sum())} of {len(values)} pixels of {where} "
                                f"({what} values must be finite and >= 0)")


# What builds a user's shader that returns D, ``factory(spec, material)``: counting_shaders.user_ndf_method,
# which builds on this module and registers itself when imported (glintlab's __init__ imports it).
_NDF_SHADER_FACTORY = [None]


# What builds a fragment-mode method, ``factory(spec, varyings, output)``: fragment_shaders.fragment_method,
# registered when that module is imported (glintlab's __init__ imports it).
_FRAGMENT_FACTORY = [None]


def register_fragment_factory(factory) -> None:
    """Sets what ``shader_method(..., mode="fragment")`` builds (api/fragment_shaders.py calls it)."""
    _FRAGMENT_FACTORY[0] = factory


def register_ndf_shader_factory(factory) -> None:
    """Sets what ``shader_method(..., returns="ndf")`` builds (api/counting_shaders.py calls it)."""
    _NDF_SHADER_FACTORY[0] = factory


def _check_method_name(name: str) -> None:
    """A method shader may take a new name or replace the user's own earlier method shader of that name
    (either kind); never a method glintlab ships nor one registered by ``register_image_method``."""
    if name not in IMAGE_METHODS:
        return
    entry = IMAGE_METHODS.get(name)
    if entry.origin == "glintlab":
        V.fail("name", name, f"a name of your own: {name!r} is an image method glintlab ships ({entry.label}), "
                             "which a method shader never replaces")
    if entry.origin != "shader_method":
        V.fail("name", name, f"a name no other image method uses: {name!r} was registered by register_image_method, "
                             "which a method shader does not replace")


def shader_method(source, language: str | None = None, entry: str = "glint", name: str | None = None,
                  defines: dict | None = None, include_dirs=(), device: str = "auto",
                  timeout: float = DEFAULT_TIMEOUT_S, register: bool = True, returns: str = "intensity",
                  material=None, textures: dict | None = None, samplers: dict | None = None,
                  buffers: dict | None = None, uniforms: dict | None = None, mode: str | None = None,
                  varyings: dict | None = None, output: str | None = None) -> ShaderMethod:
    """A whole glint method written as a shader function, compiled and run by Vulkan.

    ``source``: a file path (``.hlsl``, ``.glsl``, ...) or the code as a string, defining
    ``float <entry>(GlintInput g)`` (or float3 / vec3). ``language``: "hlsl" or "glsl" (default: from
    the extension; "hlsl" for code in a string). ``defines`` ({"NAME": value}) are passed as
    ``-D NAME=value``: True/False as 1/0, numbers and strings as written, "" a define without a value;
    None is refused. ``include_dirs`` are searched after the file's folder and glintlab's shader
    folder. Unless ``register`` is False the method is registered as the image method ``name``
    (default: the file's stem, or "shader_method"), replacing the user's own earlier method shader of
    that name; a name glintlab ships (``shipped_image_methods()``: "truth", "wb16", ...) or one registered
    by ``register_image_method`` is refused. A shader that does not compile raises ``ShaderCompileError``
    (a ``ValueError``) in one line saying what and where (file:line; a prototype without a body; a
    declaration left unfinished; no ``glint`` of the contract's signature), the compiler's text in its
    ``messages``; no Vulkan device raises ``NoVulkanDevice`` (a ``RuntimeError``). ``image()`` refuses
    seeds >= 2^32 (GlintInput's seed is 32 bits) and NaN, infinite or negative outputs
    (``ShaderOutputError``).

    ``returns``: "intensity" (the shader's value is the pixel's intensity, shown as is) or "ndf" (the
    shader returns a glinty NDF value D, and the scene images shade it with the microfacet BRDF as every
    built-in NDF method). An NDF shader is compiled once per scene material, which it reads as the defines
    GLINTLAB_DENSITY (facets per unit texture area), GLINTLAB_ALPHA, GLINTLAB_GGX (1 for GGX, 0 for
    Beckmann) and GLINTLAB_R; the object returned is the method for ``material`` (a :class:`Material`;
    default: the sphere scene's), with ``evaluate(uv, J, h, seed)`` as every glinty NDF.

    ``textures``, ``samplers``, ``buffers``, ``uniforms``: the data of the read-only resources the code
    declares, by name (``glintlab.api.shader_resources``: a dictionary texture, a table in a storage
    buffer, a cbuffer's members).

    ``mode``: "method" (the contract above) or "fragment" (GLSL fragment-shader code as written:
    ``#version``, ``in``/``out``, loose uniforms, ``void main()``, ``dFdx``/``dFdy``/``fwidth``,
    ``texture()``; ``glintlab.api.fragment_shaders``); default "fragment" for a ``.frag`` file. In the
    fragment mode ``varyings`` ({"vUv": "uv", ...}) sets the shader's ``in`` variables (and uniforms the
    scene drives, e.g. a light direction) from GlintInput's fields, and ``output`` names the ``out``
    variable holding the colour when there are several."""
    V.choice("returns", returns, ("intensity", "ndf"))
    if mode is None:
        mode = "fragment" if str(source).lower().endswith(".frag") else "method"
    V.choice("mode", mode, ("method", "fragment"))
    if mode == "method" and (varyings is not None or output is not None):
        V.fail("varyings" if varyings is not None else "output", varyings if varyings is not None else output,
               "None outside the fragment mode (mode='fragment')")
    if mode == "fragment" and returns != "intensity":
        V.fail("returns", returns, "'intensity' in the fragment mode (the shader's colour is the pixel's)")
    spec = kernel_spec(source, language, entry, defines, include_dirs, device, timeout,
                       defaults=(data_path("shaders"),), none_defines=False,
                       resources=shader_resources.resource_spec(textures, samplers, buffers, uniforms))
    if name is None:
        name = Path(spec["source_name"]).stem if spec["source_name"] != "<string>" else "shader_method"
    if not isinstance(name, str) or not name:
        V.fail("name", name, "a non-empty string")
    if register:
        _check_method_name(name)
    spec["name"] = name
    if mode == "fragment":
        method = _FRAGMENT_FACTORY[0](spec, varyings, output)
        if register:
            register_image_method(name, lambda m, method=method: method, label=name, replace=True,
                                  returns="intensity", origin="shader_method")
        return method
    if returns == "ndf":
        factory = _NDF_SHADER_FACTORY[0]
        if register:
            register_image_method(name, lambda m, spec=spec: factory(spec, m), label=name, replace=True,
                                  returns="ndf", origin="shader_method")
        return factory(spec, material)
    method = ShaderMethod(spec)
    if register:
        register_image_method(name, lambda m, method=method: method, label=name, replace=True, returns="intensity",
                              origin="shader_method")
    return method


@dataclass(frozen=True)
class ShippedShader:
    """What the registry entry (``register_image_method(..., shader=...)``) of a method shader glintlab
    ships carries for the generic machinery (tests/python/test_extension_registries.py, the float32
    study of ``validation.method_twins``), so that no other list names it:

    - ``files``: the stem of its one body and two thin wrappers in glintlab/data/shaders
      (``<files>_body.h``, ``<files>.glsl``, ``<files>.hlsl``);
    - ``compare(rows, material, method=None)``: the shader (or ``method``) against its C++ twin on the same
      packed rows (:func:`pack_inputs`) for the method's material (its density mapped): a dict with
      ``share`` (the share of pixels beyond the twin's float32 allowance), ``pixels`` and ``beyond`` (their
      row indices), and for the counting methods ``share_1pct``, ``rel_err`` and ``max_rel_err``;
    - ``max_share``: the share the tests accept (each comparison states what it measured);
    - ``wrong(material)``: the deliberately wrong variants ({label: method}) the same comparison must
      reject (each beyond ten times ``max_share``), declared by the registrant, not assumed by the tests;
    - ``explain(rows, material, which, limit)``, where given: why the pixels ``which`` differ ({reason:
      count}); the float32 study runs the methods that have one.
    """
    files: str
    compare: Callable
    wrong: Callable
    max_share: float = 0.005
    explain: Callable | None = None

    def paths(self) -> list[Path]:
        """The body and the two wrappers."""
        return [Path(data_path("shaders", f"{self.files}{suffix}")) for suffix in ("_body.h", ".glsl", ".hlsl")]


def shipped_method_shaders() -> dict:
    """The method shaders glintlab ships, from the one registry of image methods: {image method name:
    its :class:`ShippedShader`}."""
    return {n: IMAGE_METHODS.get(n).shader for n in IMAGE_METHODS.names() if IMAGE_METHODS.get(n).shader is not None}


# --------------------------------------------------------------------------------------------------
# WB16's sparkle shader (Code 2) and its numpy twin

def wb16_shader(language: str = "glsl") -> Path:
    """The path of the shipped WB16 method shader in ``language`` ("glsl" or "hlsl"; one body,
    wb16_body.h, behind both)."""
    if language not in WB16_SHADERS:
        V.fail("language", language, "'hlsl' or 'glsl'")
    return Path(data_path("shaders", WB16_SHADERS[language]))


@functools.lru_cache(maxsize=16)
def _wb16(defines: tuple, language: str) -> ShaderMethod:
    textures = samplers = None
    defines = dict(defines)
    if "WB16_NOISE_TEXTURE" in defines:  # the seed of the texture's cell values; the shader's switch is 1
        textures = {"WB16NoiseTex": (wb16_noise_texture(defines["WB16_NOISE_TEXTURE"]),
                                     {"filter": "linear", "address": "wrap"})}
        defines["WB16_NOISE_TEXTURE"] = 1
        samplers = {"WB16NoiseSampler": {"filter": "linear", "address": "wrap"}} if language == "hlsl" else None
    return shader_method(wb16_shader(language), language=language, name="wb16", defines=defines,
                         register=False, textures=textures, samplers=samplers)


@functools.lru_cache(maxsize=2)
def wb16_noise_texture(seed: int = 0, size: int = 128) -> np.ndarray:
    """WB16's 3D noise texture (WB16_NOISE_TEXTURE 1): (size, size, size, 3) float32, texel (z, y, x)
    holding glintlab_cell_values((x, y, z), seed), so that the texture read with linear filtering and
    wrapping is the hashed noise glintlab_noise3 of that seed (at size 128)."""
    V.integer("size", size, 1, 512)
    z, y, x = np.meshgrid(np.arange(size), np.arange(size), np.arange(size), indexing="ij")
    cells = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    values = cell_values(cells, np.full(len(cells), V.integer("seed", seed, 0, 2**32 - 1), np.uint32))
    return values.reshape(size, size, size, 3)


_WB16_SWITCHES = ("WB16_SHAPE", "WB16_NOISE", "WB16_ANISOTROPIC")


def wb16_method(language: str = "glsl", noise_texture=None, **params) -> ShaderMethod:
    """WB16's sparkle shader, compiled once per language and parameter set: ``params`` are its defines
    without the ``WB16_`` prefix, lower case (``sparkle_size=0.9``, ``shape=1`` for Shopf's star,
    ``noise=1`` for Shopf's lookup jitter, ...; ``WB16_DEFAULTS``); ``language`` "glsl" or "hlsl"
    (the same body, the same image). ``noise_texture``: None (the hashed noise) or the seed whose cell
    values fill WB16's 3D noise texture, read instead (WB16_NOISE_TEXTURE 1, :func:`wb16_noise_texture`:
    the same noise for frames of that seed)."""
    if language not in WB16_SHADERS:
        V.fail("language", language, "'hlsl' or 'glsl'")
    defines = {}
    if noise_texture is not None:
        defines["WB16_NOISE_TEXTURE"] = V.integer("noise_texture", noise_texture, 0, 2**32 - 1,
                                                  expected="None or a seed in [0, 2^32)")
    for key, value in params.items():
        macro = "WB16_" + str(key).upper()
        if macro not in WB16_DEFAULTS:
            V.fail(key, value, f"a WB16 parameter among {', '.join(k[5:].lower() for k in WB16_DEFAULTS)}")
        if macro in _WB16_SWITCHES:
            V.integer(key, value, 0, 1, expected="0 or 1")
            defines[macro] = int(value)
        else:
            defines[macro] = V.real(key, value)
    return _wb16(tuple(sorted(defines.items())), language)


def _f32(x):
    return np.float32(x)


def _wb16_params(params: dict) -> dict:
    """WB16_DEFAULTS with ``params`` (names without the prefix, lower case) in place; unknown names refused."""
    prm = dict(WB16_DEFAULTS)
    for key, value in params.items():
        macro = "WB16_" + str(key).upper()
        if macro not in WB16_DEFAULTS:
            V.fail(key, value, f"a WB16 parameter among {', '.join(k[5:].lower() for k in WB16_DEFAULTS)}")
        prm[macro] = value
    return prm


def wb16_twin(rows, return_lookup: bool = False, **params):
    """WB16's Code 2 in C++ float32 (core/src/glinty/wb16.cpp), operation for operation as ``wb16_body.h``
    computes it, on packed rows (:func:`pack_inputs`; the shader reads the same float32 values), on
    every core. Returns (m,) float32, and with ``return_lookup`` also the lookup positions ``pos``
    (m, 3), whose float32 spacing bounds how far the two may differ. They agree pixel by pixel except
    where a last-place difference of a transcendental (log2, pow, sqrt) or of a fused multiply-add
    moves a value across a floor (docs/math/glint_images.md#glint-wb16). :func:`wb16_twin_numpy` is
    the same arithmetic in numpy.

    >>> rows = pack_inputs(2, world_pos=[[0.1, 0.2, 0.0], [0.3, -0.1, 0.0]], n=[0, 0, 1], view=[0.5, -2.0, 1.0])
    >>> bool(np.all(wb16_twin(rows) == wb16_twin_numpy(rows)))
    True
    """
    prm = _wb16_params(params)
    for key in _WB16_SWITCHES:
        V.integer(key[5:].lower(), prm[key], 0, 1, expected="0 or 1")
    args = {k[5:].lower(): (int(v) if k in _WB16_SWITCHES else V.real(k[5:].lower(), v)) for k, v in prm.items()}
    rows = np.ascontiguousarray(rows, dtype=np.uint32)
    if rows.ndim != 2 or rows.shape[1] != _core.METHOD_INPUT_WORDS:
        V.fail("rows", f"an array of shape {rows.shape}", f"an array of shape (m, {_core.METHOD_INPUT_WORDS})")
    out, pos = _core.wb16_twin(rows, **args)
    return (out, pos) if return_lookup else out


def wb16_twin_numpy(rows, return_lookup: bool = False, **params):
    """WB16's Code 2 in numpy float32, line for line as ``wb16_body.h`` computes it (the first twin;
    :func:`wb16_twin` is the C++ one, the same arithmetic, tens of times faster)."""
    prm = _wb16_params(params)
    g = unpack_inputs(np.ascontiguousarray(rows, dtype=np.uint32))
    f = _f32
    unit = f(prm["WB16_UNIT"])
    world_pos, view = g["world_pos"] * unit, g["view"] * unit
    seed = g["seed"][:, 0]

    def dot(a, b):
        return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]

    with np.errstate(all="ignore"):
        z = np.sqrt(dot(view, view))
        # fpmath: numpy's float32 log2 / power loops depend on the arrays' addresses (last bit).
        e = np.floor(fpmath.call(np.log2, f(0.3) * z + f(3.0), dtype=np.float32)) / f(0.3785116)
        level_z = f(0.1) * fpmath.call(np.power, f(1.3), e, dtype=np.float32) - f(0.2)
        level = f(0.12) / level_z
        sparkle_dens = f(prm["WB16_SPARKLE_DENSITY"]) * level
        noise_dens = f(prm["WB16_NOISE_DENSITY"]) * level
        v = view / z[:, None]
        view_new = v * level_z[:, None]
        view_new = np.sign(view_new) * _fract(np.abs(view_new))
        nv = view_new / np.sqrt(dot(view_new, view_new))[:, None]
        pos = sparkle_dens[:, None] * world_pos + f(prm["WB16_VIEW_DEP"]) * nv
        lookup_jitter = int(prm["WB16_NOISE"]) == 1
        if lookup_jitter:
            pos = pos + f(prm["WB16_NOISE_AMOUNT"]) * noise3(noise_dens[:, None] * world_pos, seed)
        if int(prm["WB16_SHAPE"]) == 1:
            p = _fract(pos)
            p = p * (f(1.0) - p)
            out = np.clip(f(1.0) - f(prm["WB16_SHOPF_K"]) * (p[:, 0] + p[:, 1] + p[:, 2]), f(0), f(1))
            return (out, pos) if return_lookup else out
        g_index = np.floor(pos)
        P_c = g_index / sparkle_dens[:, None]
        if lookup_jitter:
            P_x = pos - g_index - f(0.5)
        else:
            noise = f(prm["WB16_NOISE_AMOUNT"]) * noise3(noise_dens[:, None] * P_c, seed)
            P_x = pos - g_index + f(0.5) * _fract(noise + f(0.5)) - f(0.75)
        if int(prm["WB16_ANISOTROPIC"]) == 1:
            n = g["n"]
            dotvn = dot(v, n)
            ma = v - dotvn[:, None] * n
            P_x_proj = dot(P_x, ma)[:, None] * ma
            P_x = P_x + (np.abs(dotvn) - f(1.0))[:, None] * P_x_proj / dot(ma, ma)[:, None]
        dist2 = dot(P_x, P_x)
        thresh = (f(1.0) - f(prm["WB16_SPARKLE_SIZE"])) * f(prm["WB16_KERNEL_SCALE"])
        # NaN compares false, as in the shader: NaN > thresh is false, so 1 - NaN / thresh = NaN.
        out = np.where(dist2 > thresh, f(0.0), f(1.0) - dist2 / thresh).astype(np.float32)
        return (out, pos) if return_lookup else out


def _fract(x):
    return x - np.floor(x)


def _hash3(v):
    """glintlab_hash3 on uint32 (m, 3) (wrapping arithmetic, as the shader's)."""
    v = v * np.uint32(1664525) + np.uint32(1013904223)
    x, y, z = v[:, 0].copy(), v[:, 1].copy(), v[:, 2].copy()
    x += y * z
    y += z * x
    z += x * y
    x ^= x >> np.uint32(16)
    y ^= y >> np.uint32(16)
    z ^= z >> np.uint32(16)
    x += y * z
    y += z * x
    z += x * y
    return np.stack([x, y, z], axis=1)


_SEED_MIX = np.array([0x9E3779B9, 0x85EBCA6B, 0xC2B2AE35], np.uint32)


def cell_values(cell, seed) -> np.ndarray:
    """glintlab_cell_values: three values in [0, 1) (float32) per integer cell (m, 3) and seed (m,)."""
    k = np.asarray(cell).astype(np.int64).astype(np.uint32) ^ (_SEED_MIX[None, :] * np.asarray(seed, np.uint32)[:, None])
    return (_hash3(k) >> np.uint32(8)).astype(np.float32) * np.float32(1.0 / 16777216.0)


def noise3(p, seed) -> np.ndarray:
    """glintlab_noise3: the hashed value noise of the include file, float32 (m, 3)."""
    f = _f32
    x = p * f(128.0) - f(0.5)
    i = np.floor(x)
    fr = x - i
    c = i.astype(np.int64)
    v = {}
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                v[dx, dy, dz] = cell_values((c + np.array([dx, dy, dz])) & 127, seed)
    fx, fy, fz = fr[:, 0:1], fr[:, 1:2], fr[:, 2:3]
    x00 = v[0, 0, 0] + (v[1, 0, 0] - v[0, 0, 0]) * fx
    x10 = v[0, 1, 0] + (v[1, 1, 0] - v[0, 1, 0]) * fx
    x01 = v[0, 0, 1] + (v[1, 0, 1] - v[0, 0, 1]) * fx
    x11 = v[0, 1, 1] + (v[1, 1, 1] - v[0, 1, 1]) * fx
    y0 = x00 + (x10 - x00) * fy
    y1 = x01 + (x11 - x01) * fy
    return y0 + (y1 - y0) * fz


#: WB16's twin allowance (docs/math/glint_images.md#glint-wb16): per pixel, |shader - twin| may reach
#: WB16_ULPS float32 spacings of the lookup position pos (tens to hundreds of cells from the origin, so its
#: last place is 1e-5 .. 3e-5 cells) times the kernel's largest slope (2 / sqrt(threshold) for the round
#: kernel, 3 k for Shopf's star); beyond that on at most WB16_MAX_SHARE of the pixels (a cell index or a
#: level moved across its floor by such an ulp). Measured on lavapipe: 0 to 0.1 % of the pixels.
WB16_ULPS, WB16_MAX_SHARE = 8, 0.005


def wb16_beyond(a, b, pos, **params) -> np.ndarray:
    """Per pixel: a and b (two computations of WB16 with ``params``, e.g. the shader and its twin) differ
    beyond the float32 allowance of the lookup position ``pos`` (both NaN is agreement)."""
    prm = _wb16_params(params)
    slope = 3 * prm["WB16_SHOPF_K"] if prm["WB16_SHAPE"] == 1 else 2 / np.sqrt(1 - prm["WB16_SPARKLE_SIZE"])
    tol = WB16_ULPS * np.spacing(np.abs(pos).max(axis=1)) * slope
    both_nan = np.isnan(a) & np.isnan(b)
    return ~both_nan & ~(np.abs(np.asarray(a, np.float64) - b) <= tol)


def wb16_compare(rows, material=None, method=None, **params) -> dict:
    """WB16's shader with ``params`` (or ``method``) against its C++ twin with ``params`` on the same
    packed rows: ``share`` of the pixels beyond the allowance (:func:`wb16_beyond`), ``pixels``, ``beyond``
    (their row indices). ``material`` is not read (WB16 has no material)."""
    method = method if method is not None else wb16_method(**params)
    value, pos = wb16_twin(rows, return_lookup=True, **params)
    bad = wb16_beyond(method.shade(rows), value, pos, **params)
    return {"share": float(bad.mean()) if bad.size else 0.0, "pixels": int(bad.size), "beyond": np.nonzero(bad)[0]}


def _wb16_shipped(compare_params: dict, wrong: dict) -> ShippedShader:
    """WB16 (or a baseline: ``compare_params``) as a shipped shader whose wrong variants are ``wrong``:
    {label: the parameters of a WB16 that is not this one}."""
    return ShippedShader("wb16", functools.partial(wb16_compare, **compare_params),
                         lambda m: {label: wb16_method(**p) for label, p in wrong.items()}, WB16_MAX_SHARE)


# WB16 is an image method like the others: compiled on first use (needs Vulkan), never by import; an
# intensity, not in the NDF panel. The paper's baselines are image methods of their own (the aliasing
# tables compare them with WB16): Shopf's star shape (Code 1) and Shopf's noise on the lookup instead of
# on the grid centres. Each is the wrong variant of the others: the comparison must see the shape.
_WB16_DOC = "docs/math/glint_images.md#glint-wb16"
register_image_method("wb16", lambda m: wb16_method(), label="WB16 sparkles", returns="intensity", doc=_WB16_DOC,
                      shader=_wb16_shipped({}, {"kernel radius x sqrt(1.2)": {"kernel_scale": 1.2},
                                                "Shopf's star": {"shape": 1}, "lookup noise": {"noise": 1}}))
register_image_method("wb16_star", lambda m: wb16_method(shape=1), label="WB16 / Shopf star", returns="intensity",
                      doc=_WB16_DOC, shader=_wb16_shipped({"shape": 1}, {"round kernel": {}}))
register_image_method("wb16_lookup_noise", lambda m: wb16_method(noise=1), label="WB16 / lookup noise",
                      returns="intensity", doc=_WB16_DOC,
                      shader=_wb16_shipped({"noise": 1}, {"noise on the grid centres": {}}))
