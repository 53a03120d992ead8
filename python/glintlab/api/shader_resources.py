"""The read-only resources a shader declares (textures, samplers, storage buffers, uniform blocks), bound
by name from numpy arrays, for every shader kind (``shader_law``, ``shader_sampler``, ``shader_method``).

The runner reflects the compiled SPIR-V (validation/src/spirv_inspect.cpp): every texture, sampler, storage
buffer and uniform block the code declares beside glintlab's own buffers is moved to descriptor set 1 and
described here (``kind``, dimensions, sampled type, channels, a uniform block's members). This module
checks the data given against those declarations, one line naming the resource when they disagree, and
packs it for the runner:

- ``textures={"Name": array}`` or ``{"Name": (array, SamplerState(...))}``: 1D, 2D, 3D textures and 1D/2D
  texture arrays; numpy shape (layers, depth, height, width, channels), each axis present only where the
  declaration has it, channels optional (1 when absent, at most 4);
- ``samplers={"Name": SamplerState(...)}``: HLSL's separate ``SamplerState`` (GLSL ``sampler2D`` carries
  its texture's state);
- ``buffers={"Name": array}``: storage buffers (``StructuredBuffer<T>``, ``readonly buffer``), the array's
  last axis one element's 32-bit words;
- ``uniforms={"member": value}``: the members of every uniform block (cbuffers, HLSL's ``$Global``, GLSL
  uniform blocks) by name; floats rounded to the nearest float32, integers exact.

Everything given travels in the shader's spec (pickled with it, as its #includes are) and enters its
identity. docs/guide/shaders.md#textures-buffers-and-uniforms.
"""
from __future__ import annotations

import dataclasses
import hashlib
import os
from pathlib import Path

import numpy as np
from PIL import Image

from . import checks as v

try:  # OpenEXR textures only (Debian's python3-openimageio, scripts/install-deps.sh)
    import OpenImageIO as oiio
except ImportError:  # pragma: no cover - the message below names the package
    oiio = None

FILTERS = ("nearest", "linear")
ADDRESSES = ("wrap", "clamp", "mirror")
_IMAGE_EXTENSIONS = (".png", ".exr", ".npy")


@dataclasses.dataclass(frozen=True)
class SamplerState:
    """How a texture is read: ``filter`` "nearest" or "linear" (also between mip levels), ``address``
    "wrap", "clamp" or "mirror" (outside [0, 1]), ``mips`` False (one level), True (the full chain, each
    level the 2^d box average of the one above, an odd size dropping its last texel) or a number of
    levels. Defaults: linear, wrap, one level."""

    filter: str = "linear"
    address: str = "wrap"
    mips: bool | int = False

    def __post_init__(self):
        v.choice("filter", self.filter, FILTERS)
        v.choice("address", self.address, ADDRESSES)
        if not isinstance(self.mips, (bool, np.bool_)):
            v.integer("mips", self.mips, 1, 16, expected="True, False or a number of levels from 1 to 16")


def _state(name: str, state) -> SamplerState:
    if state is None:
        return SamplerState()
    if isinstance(state, SamplerState):
        return state
    if isinstance(state, dict):
        unknown = set(state) - {"filter", "address", "mips"}
        if unknown:
            v.fail(f"{name} sampler state", sorted(unknown)[0], "keys among 'filter', 'address', 'mips'")
        return SamplerState(**state)
    v.fail(f"{name} sampler state", state, "a SamplerState or a dict with filter / address / mips")


def read_image(path) -> np.ndarray:
    """An image file as a float32 array (height, width, channels): PNG (Pillow; 8- and 16-bit integers
    scaled to [0, 1]), OpenEXR (OpenImageIO, as stored) or a ``.npy`` array (any shape: 3D textures)."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in _IMAGE_EXTENSIONS:
        v.fail("texture file", str(path), f"a file ending in one of {', '.join(_IMAGE_EXTENSIONS)}")
    if not path.is_file():
        v.fail("texture file", str(path), "an existing file")
    if ext == ".npy":
        return np.load(path, allow_pickle=False)
    if ext == ".exr":
        if oiio is None:
            v.fail("texture file", str(path), "PNG or .npy (OpenEXR needs OpenImageIO: apt-get install python3-openimageio)")
        image = oiio.ImageInput.open(str(path))
        if image is None:
            v.fail("texture file", str(path), f"an OpenEXR file OpenImageIO can read ({oiio.geterror()})")
        pixels = image.read_image("float")
        image.close()
        return np.asarray(pixels, np.float32)
    with Image.open(path) as im:
        raw = np.asarray(im)
    scale = 65535.0 if raw.dtype == np.uint16 or raw.dtype == np.int32 else 255.0
    return (raw.astype(np.float32) / np.float32(scale)).astype(np.float32)


def _texture_entry(name, value):
    if isinstance(value, tuple) and len(value) == 2:
        array, state = value
    else:
        array, state = value, None
    if isinstance(array, (str, os.PathLike)):
        array = read_image(array)
    if not isinstance(array, np.ndarray) or array.dtype.kind not in "fiub" or array.size == 0:
        v.fail(f"textures[{name!r}]", type(array).__name__, "a non-empty numpy array of numbers, or (array, SamplerState)")
    return {"array": np.array(array, copy=True), "state": dataclasses.asdict(_state(name, state))}


def resource_spec(textures=None, samplers=None, buffers=None, uniforms=None) -> dict:
    """The resources as the spec stores them (checked for their form here; against the declarations once
    compiled, :func:`bind`)."""
    out = {}
    for key, given in (("textures", textures), ("samplers", samplers), ("buffers", buffers),
                       ("uniforms", uniforms)):
        given = {} if given is None else given
        if not isinstance(given, dict):
            v.fail(key, given, "a dict {name: value}")
        for name in given:
            if not isinstance(name, str) or not name:
                v.fail(key, name, "resource names that are non-empty strings")
        if key == "textures":
            out[key] = {n: _texture_entry(n, a) for n, a in given.items()}
        elif key == "samplers":
            out[key] = {n: dataclasses.asdict(_state(n, s)) for n, s in given.items()}
        elif key == "buffers":
            out[key] = {n: _buffer_array(n, a) for n, a in given.items()}
        else:
            out[key] = {n: _uniform_value(n, a) for n, a in given.items()}
    return out if any(out.values()) else {}


def _buffer_array(name, value):
    array = np.asarray(value)
    if array.dtype.kind not in "fiub" or array.size == 0:
        v.fail(f"buffers[{name!r}]", type(value).__name__, "a non-empty numpy array of numbers")
    return np.array(array, copy=True)


def _uniform_value(name, value):
    if isinstance(value, str):
        v.fail(f"uniforms[{name!r}]", value, "a number or a sequence of numbers")
    array = np.asarray(value)
    if array.dtype.kind not in "fiub" or array.ndim > 2:
        v.fail(f"uniforms[{name!r}]", value, "a number or a sequence of numbers")
    if array.dtype.kind == "f" and not np.isfinite(array).all():
        v.fail(f"uniforms[{name!r}]", value, "finite numbers")
    return array.copy()


def digest(resources: dict) -> bytes:
    """A hash of everything bound (arrays, states, values), for the shader's identity."""
    h = hashlib.sha256()
    for key in sorted(resources):
        for name in sorted(resources[key]):
            entry = resources[key][name]
            h.update(f"{key}/{name}".encode())
            array = entry["array"] if isinstance(entry, dict) and "array" in entry else entry
            if isinstance(array, np.ndarray):
                h.update(str((array.dtype.str, array.shape)).encode() + np.ascontiguousarray(array).tobytes())
            if isinstance(entry, dict):
                h.update(repr(sorted(entry.get("state", entry).items() if "state" in entry else
                                     [(k, x) for k, x in entry.items() if k != "array"])).encode())
    return h.digest()


# ---------------------------------------------------------------- against the declarations

def _words(name: str, array: np.ndarray, scalar: str) -> np.ndarray:
    """``array`` as 32-bit words of ``scalar`` ("float", "int", "uint"; "struct": as given)."""
    kind = array.dtype.kind
    if scalar == "float" and kind not in "f":
        v.fail(name, f"an array of {array.dtype}", "floating-point data (the shader declares float)")
    if scalar in ("int", "uint") and kind not in "iub":
        v.fail(name, f"an array of {array.dtype}", f"integer data (the shader declares {scalar})")
    if scalar == "float" or (scalar == "struct" and kind == "f"):
        return np.ascontiguousarray(array, np.float32).view(np.uint32)
    lo, hi = (0, 2**32 - 1) if scalar == "uint" else (-2**31, 2**31 - 1)
    if array.size and (array.min() < lo or array.max() > hi):
        v.fail(name, f"values in [{array.min()}, {array.max()}]", f"values in [{lo}, {hi}] ({scalar})")
    return np.ascontiguousarray(array.astype(np.int64) & 0xFFFFFFFF, np.uint32)


def _mip_chain(array: np.ndarray, spatial: int, levels, integer: bool) -> list:
    """Level 0 and the levels below it, each halving every spatial axis (the box average; integers take
    the even texels); ``levels``: True for the full chain, an int for that many."""
    out = [array]
    size = array.shape[-1 - spatial:-1]
    full = 1 + int(np.log2(max(size))) if size else 1
    count = full if levels is True else (1 if levels is False else min(int(levels), full))
    for _ in range(count - 1):
        a = out[-1]
        axes = range(a.ndim - 1 - spatial, a.ndim - 1)
        for ax in axes:
            n = a.shape[ax]
            if n == 1:
                continue
            even = np.take(a, range(0, n - n % 2, 2), axis=ax)
            odd = np.take(a, range(1, n, 2), axis=ax)
            a = even if integer else (even + odd) * 0.5
        out.append(a)
    return out


def _texture_data(r: dict, entry: dict, state: dict | None) -> dict:
    name = f"textures[{r['name']!r}]"
    array = entry["array"]
    base = r["dims"] + (1 if r["arrayed"] else 0)
    axes = "(" + ", ".join((["layers"] if r["arrayed"] else []) + ["depth", "height", "width"][3 - r["dims"]:]) + \
        "[, channels])"
    if array.ndim not in (base, base + 1):
        v.fail(name, f"an array of shape {array.shape}",
               f"{axes} for the {r['dims']}D texture{' array' if r['arrayed'] else ''} the shader declares")
    if array.ndim == base:
        array = array[..., None]
    channels = array.shape[-1]
    if not 1 <= channels <= 4 or (r["channels"] and channels != r["channels"]):
        v.fail(name, f"{channels} channels", f"{r['channels'] or '1 to 4'} channel(s) (shape {axes})")
    if channels == 3:  # no 3-channel 32-bit format is sampled everywhere: alpha 1 (or 1 for integers)
        array = np.concatenate([array, np.ones(array.shape[:-1] + (1,), array.dtype)], axis=-1)
    integer = r["scalar"] != "float"
    _words(name, array[:0], r["scalar"])  # the data's type against the declaration's, before any conversion
    st = state or entry["state"]
    if integer and st["filter"] == "linear":
        v.fail(f"{name} filter", "linear", f"'nearest' (a {r['scalar']} texture is not filtered)")
    levels = _mip_chain(array.astype(np.float64) if not integer else array, r["dims"], entry["state"]["mips"],
                        integer)
    shape = array.shape[:-1]
    layers = shape[0] if r["arrayed"] else 1
    spatial = shape[1:] if r["arrayed"] else shape
    extent = list(reversed(spatial)) + [1] * (3 - len(spatial)) + [layers]
    return {"name": r["name"], "levels": [_words(name, lvl, r["scalar"]).reshape(-1) for lvl in levels],
            "extent": extent, "channels": channels, "filter": st["filter"], "address": st["address"]}


def _buffer_data(r: dict, array: np.ndarray) -> dict:
    name = f"buffers[{r['name']!r}]"
    words = max(1, r["channels"])
    if array.ndim > 1 and array.shape[-1] != words:
        v.fail(name, f"an array of shape {array.shape}",
               f"{words} 32-bit word(s) per element on the last axis ({r['size']} bytes per element as declared)")
    if array.size % words:
        v.fail(name, f"{array.size} values", f"a multiple of {words} ({r['size']}-byte elements)")
    return {"name": r["name"], "levels": [_words(name, array, r["scalar"]).reshape(-1)]}


def _block_data(r: dict, uniforms: dict, used: set) -> dict:
    block = np.zeros((r["size"] + 3) // 4, np.uint32)
    for m in r["members"]:
        if m["name"] not in uniforms:
            v.fail("uniforms", f"no value for {m['name']!r}",
                   f"a value for every member of uniform block {r['name']!r} "
                   f"({', '.join(x['name'] for x in r['members'])})")
        used.add(m["name"])
        name = f"uniforms[{m['name']!r}]"
        if not m["scalar"]:
            v.fail(name, "a matrix or structure member", "members that are scalars, vectors or arrays of them")
        value = uniforms[m["name"]]
        shape = ((m["count"],) if m["count"] else ()) + ((m["components"],) if m["components"] > 1 else ())
        if value.shape != shape:
            v.fail(name, f"a value of shape {value.shape}", f"shape {shape} (as declared in {r['name']!r})")
        rows = value.reshape(max(1, m["count"]), m["components"])
        if m["scalar"] == "float" and rows.dtype.kind in "iub":  # --uniform gain=2: an integer is a float too
            rows = rows.astype(np.float64)
        words = _words(name, rows, m["scalar"])
        stride = (m["array_stride"] or 16) // 4
        for k, row in enumerate(words):
            at = m["offset"] // 4 + k * stride
            block[at:at + m["components"]] = row
    return {"name": r["name"], "levels": [block]}


def bind(kernel, resources: dict, source_name: str) -> None:
    """Checks ``resources`` (:func:`resource_spec`) against what the compiled ``kernel`` declares and
    binds them: a declared resource left without data, data for a name the shader never declares, or a
    shape, type or channel count that does not fit is one line naming it (ValueError)."""
    declared = list(kernel.declared_resources)
    if not declared and not resources:
        return
    given = {k: dict(resources.get(k, {})) for k in ("textures", "samplers", "buffers", "uniforms")}
    data, used = [], set()
    for r in declared:
        key = {"texture": "textures", "image": "textures", "sampler": "samplers",
               "storage buffer": "buffers"}.get(r["kind"])
        if key is None:  # a uniform block: its members by name
            data.append(_block_data(r, given["uniforms"], used))
            continue
        if key == "buffers" and r["name"] not in given[key] and r["name"] in given["textures"]:
            # A file given as --texture NAME=FILE.npy where NAME is a storage buffer binds as that buffer.
            given[key][r["name"]] = given["textures"].pop(r["name"])["array"]
        if r["name"] not in given[key]:
            v.fail(key, f"no entry {r['name']!r}",
                   f"data for the {r['kind']} {r['name']!r} that {Path(source_name).name} declares "
                   f"({key}={{{r['name']!r}: ...}})")
        entry = given[key].pop(r["name"])
        if key == "textures":
            data.append(_texture_data(r, entry, None))
        elif key == "samplers":
            data.append({"name": r["name"], "levels": [], "filter": entry["filter"], "address": entry["address"]})
        else:
            data.append(_buffer_data(r, entry))
    extra = [(k, n) for k in ("textures", "samplers", "buffers") for n in given[k]]
    extra += [("uniforms", n) for n in given["uniforms"] if n not in used]
    if extra:
        key, name = extra[0]
        v.fail(f"{key}[{name!r}]", "given", f"a name {Path(source_name).name} declares "
               f"({', '.join(repr(r['name']) for r in declared) or 'it declares no resource'})")
    kernel.bind_resources(data)
