"""Whole-method shaders against their C++ twins on a scene's pixels, and the float32 effects a renderer
meets (docs/math/glint_images.md#glint-db23-shader): texture coordinates far from the origin, far
geometry (large footprints), grazing footprints (thin ellipses).

:func:`scene_rows` packs one frame's lit pixels as GlintInput rows; :func:`compare` runs a shipped method
shader and its twin on the same float32 rows through the method's registry entry
(``method_shaders.ShippedShader``: its ``compare``) and counts the pixels beyond the allowance, saying
for each why it differs (its ``explain``: for DB23 a grid coordinate or an angular coordinate within
float32 rounding of a cell boundary, "cell boundary", otherwise the gated law's floor or gate moved by a
transcendental's last place, "count floor"; for KPT25 a point at the filter's edge, a box or block
edge, ...). :func:`float32_study` is the table of cases over every shipped method shader whose entry
explains its mismatches: no list here names them.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.glinty_ndf import Material, method_density
from ..api.method_shaders import frame_rows, shipped_method_shaders
from . import scene_images as si

#: The study's cases: (name, uv offset in texels, footprint scale, stretch of the footprint's y column).
#: A texel is the finest grid cell's side 1 / sqrt(N) (one facet per cell).
CASES = (("as rendered", 0.0, 1.0, 1.0), ("uv + 1e2 texels", 1e2, 1.0, 1.0), ("uv + 1e4 texels", 1e4, 1.0, 1.0),
         ("uv + 1e6 texels", 1e6, 1.0, 1.0), ("far: J x 64", 0.0, 64.0, 1.0),
         ("far: J x 64, uv + 1e4 texels", 1e4, 64.0, 1.0), ("grazing: J_y x 64", 0.0, 1.0, 64.0),
         ("grazing: J_y x 4096", 0.0, 1.0, 4096.0))


def scene_rows(scene="plane_25", scale: float = 0.1, frame: int = 0, seed: int = 0):
    """(rows, material): the GlintInput rows of the lit pixels of one frame of a shipped scene at
    ``scale`` of its resolution (facets per pixel kept), lit by one directional light."""
    sc = si.with_directional_light(si._scene_of(scene).scaled(V.real("scale", scale), keep_n=True))
    cam = si.camera_path(sc, 2)[min(int(frame), 1)]
    inp = si.frame_inputs(cam)
    rows, _ = frame_rows(dataclasses.replace(inp, hit=inp.mask), seed, frame)
    return rows, Material.of(sc)


def transform_rows(rows, material: Material, offset_texels: float = 0.0, footprint: float = 1.0,
                   stretch: float = 1.0):
    """Rows with uv + offset_texels / sqrt(N) (both components; N the facet density of ``material``), J
    scaled by ``footprint`` and its y column (du/dy, dv/dy) by ``stretch``, rounded to float32 as the
    shader and its twin both read them."""
    out = np.array(rows, dtype=np.uint32, copy=True)
    f = out[:, :27].view(np.float32)
    texel = 1.0 / math.sqrt(material.density)
    f[:, 3:5] = (f[:, 3:5].astype(np.float64) + offset_texels * texel).astype(np.float32)
    J = f[:, 5:9].astype(np.float64) * footprint
    J[:, 2:4] *= stretch
    f[:, 5:9] = J.astype(np.float32)
    return out


def compare(rows, material: Material, method=None, explain_limit: int = 64, name: str = "db23_shader") -> dict:
    """The shipped method shader ``name`` (or ``method``, e.g. a deliberately wrong variant) against its C++
    twin on the same rows, for ``material`` as the method runs it (its density mapped: ``method_density``):
    its entry's figures (share, share_1pct, rel_err, max_rel_err, pixels) and, for up to ``explain_limit``
    of the mismatching pixels, their reasons and the number ``explained``."""
    entries = shipped_method_shaders()
    if name not in entries:
        V.fail("name", name, "a shipped method shader among " + ", ".join(entries))
    entry = entries[name]
    r = dict(entry.compare(rows, material, method))
    bad = r.pop("beyond")
    if explain_limit and entry.explain is not None:
        r.update(entry.explain(rows, material, bad, explain_limit))
        r["explained"] = min(len(bad), explain_limit)
    return r


def kpt25_compare(rows, material: Material, method=None, explain_limit: int = 64) -> dict:
    """:func:`compare` for the KPT25 method shader (``material`` at K_P, its matched density)."""
    return compare(rows, material, method, explain_limit, name="kpt25_shader")


def explained_methods() -> list[str]:
    """The shipped method shaders whose registry entry explains its mismatches (the float32 study's)."""
    return [n for n, entry in shipped_method_shaders().items() if entry.explain is not None]


_FIGURES = ("pixels", "share", "share_1pct", "rel_err", "max_rel_err", "explained")


def float32_study(scene="plane_25", scale: float = 0.1, seed: int = 0, cases=CASES, methods=None,
                  explain_limit: int = 64) -> pd.DataFrame:
    """One row per method shader (``methods``: default :func:`explained_methods`, "db23_shader" and
    "kpt25_shader") and case of ``cases`` (:data:`CASES`): pixels, share beyond the allowance and beyond
    1 %, mean and largest relative error, the mismatches examined and their reasons (DB23: "cell
    boundary", "count floor"; KPT25: "point at an edge", "box or block edge", "lobe at the square's
    edge", "ulps"). Each method runs at its own density for the scene's material (KPT25: matched to the
    facets' glint count, as its image method); the offsets are in the facets' texels for all."""
    rows, material = scene_rows(scene, scale, seed=seed)
    known = explained_methods()
    out = []
    for name in known if methods is None else methods:
        V.choice("methods", name, tuple(known), "method shaders among " + ", ".join(known))
        own = dataclasses.replace(material, density=method_density(name, material))
        for case, offset, footprint, stretch in cases:
            moved = transform_rows(rows, material, offset, footprint, stretch)
            r = compare(moved, own, explain_limit=explain_limit, name=name)
            reasons = {k: v for k, v in r.items() if k not in _FIGURES}
            out.append({"method": name, "case": case, "pixels": r["pixels"], "mismatch_share": r["share"],
                        "beyond_1pct": r["share_1pct"], "mean_rel_err": r["rel_err"], "max_rel_err": r["max_rel_err"],
                        "examined": r.get("explained", 0),
                        "reasons": ", ".join(f"{k} {v}" for k, v in reasons.items() if v) or "-"})
    return pd.DataFrame(out)
