"""Whole-method shaders against their C++ twins on a scene's pixels, and the float32 effects a renderer
meets (docs/math/glint_images.md#glint-db23-shader): texture coordinates far from the origin, far
geometry (large footprints), grazing footprints (thin ellipses).

:func:`scene_rows` packs one frame's lit pixels as GlintInput rows; :func:`compare` runs the shader and
its twin on the same float32 rows and counts the pixels beyond the allowance, saying for each why it
differs (:func:`explain`): a grid coordinate or an angular coordinate within float32 rounding of a cell
boundary ("cell boundary"), otherwise the gated law's floor or gate moved by a transcendental's last
place ("count floor"). :func:`float32_study` is the table of cases.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api import counting_shaders as CS
from ..api.glinty_ndf import Material
from ..api.grids import aniso_counter, footprint_shapes
from ..api.method_shaders import frame_rows
from . import scene_images as si

#: The study's cases: (name, uv offset in texels, footprint scale, stretch of the footprint's y column).
#: A texel is the finest grid cell's side 1 / sqrt(N) (one facet per cell).
CASES = (("as rendered", 0.0, 1.0, 1.0), ("uv + 1e2 texels", 1e2, 1.0, 1.0), ("uv + 1e4 texels", 1e4, 1.0, 1.0),
         ("uv + 1e6 texels", 1e6, 1.0, 1.0), ("far: J x 64", 0.0, 64.0, 1.0),
         ("far: J x 64, uv + 1e4 texels", 1e4, 64.0, 1.0), ("grazing: J_y x 64", 0.0, 1.0, 64.0),
         ("grazing: J_y x 4096", 0.0, 1.0, 4096.0))
#: A coordinate this many float32 spacings (of its own magnitude) from an integer counts as "at a cell
#: boundary": the shader's rotation and division round it by a few spacings.
BOUNDARY_ULPS = 16


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
    """Rows with uv + offset_texels / sqrt(N) (both components), J scaled by ``footprint`` and its y
    column (du/dy, dv/dy) by ``stretch``, rounded to float32 as the shader and its twin both read them."""
    out = np.array(rows, dtype=np.uint32, copy=True)
    f = out[:, :27].view(np.float32)
    texel = 1.0 / math.sqrt(material.density)
    f[:, 3:5] = (f[:, 3:5].astype(np.float64) + offset_texels * texel).astype(np.float32)
    J = f[:, 5:9].astype(np.float64) * footprint
    J[:, 2:4] *= stretch
    f[:, 5:9] = J.astype(np.float32)
    return out


def explain(rows, material: Material, which, limit: int = 64) -> dict:
    """Why mismatching pixels differ: for up to ``limit`` of the row indices ``which``, whether a grid
    coordinate of one of its terms (in float64, as the twin computes it) or its angular coordinate lies
    within BOUNDARY_ULPS float32 spacings of an integer. Returns counts {"cell boundary", "count floor"}."""
    uv, J, h, _ = CS.tangent_inputs(rows)
    counter = aniso_counter("db23_trilinear", inner="gated_shader", base_area=1.0 / material.density)
    out = {"cell boundary": 0, "count floor": 0}
    which = np.asarray(list(which)[:limit], dtype=np.int64)
    shapes = footprint_shapes(J[which]) if which.size else None
    for row, i in enumerate(which):
        shp = shapes.iloc[row]
        coords = list(h[i, :2] / h[i, 2] / material.angular_texel)
        if shp.status in ("ok", "clamped"):
            terms, _ = counter._core.terms(float(material.density), float(shp.P), float(shp.r), float(shp.phi))
            for t in terms:
                c, s = math.cos(t["angle"]), math.sin(t["angle"])
                coords += [(-uv[i, 0] * s + uv[i, 1] * c) / t["cell_minor"], (uv[i, 0] * c + uv[i, 1] * s) / t["cell_major"]]
        x = np.asarray(coords)
        tol = BOUNDARY_ULPS * np.spacing(np.abs(x).astype(np.float32) + np.float32(1.0)).astype(np.float64)
        out["cell boundary" if bool(np.any(np.abs(x - np.round(x)) <= tol)) else "count floor"] += 1
    return out


def compare(rows, material: Material, method=None, explain_limit: int = 64) -> dict:
    """The DB23 method shader (or ``method``, e.g. a deliberately wrong variant) against the C++ twin on
    the same rows: twin_mismatch's share, rel_err, max_rel_err, and the reasons of the mismatches."""
    method = method if method is not None else CS.db23_method(material)
    shader = method.shade(rows)
    twin = CS.db23_twin(rows, material)
    r = CS.twin_mismatch(shader, twin, rows, material)
    if explain_limit:
        _, J, _, _ = CS.tangent_inputs(rows)
        P = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
        one = 1.0 / (math.pi * material.alpha**2) / (material.R * material.density * P)
        with np.errstate(divide="ignore", invalid="ignore"):
            err = np.abs(shader.astype(np.float64) - twin) / np.maximum(np.abs(twin), one)
        bad = np.nonzero(~(err <= CS.COUNT_ALLOWANCE))[0]
        r.update(explain(rows, material, bad, explain_limit))
        r["explained"] = min(len(bad), explain_limit)
    return r


def float32_study(scene="plane_25", scale: float = 0.1, seed: int = 0, cases=CASES) -> pd.DataFrame:
    """One row per case of ``cases`` (:data:`CASES`): pixels, share beyond the allowance, mean and largest
    relative error, and of the mismatches examined how many sit at a cell boundary."""
    rows, material = scene_rows(scene, scale, seed=seed)
    out = []
    for name, offset, footprint, stretch in cases:
        r = compare(transform_rows(rows, material, offset, footprint, stretch), material)
        out.append({"case": name, "pixels": r["pixels"], "mismatch_share": r["share"], "beyond_1pct": r["share_1pct"], "mean_rel_err": r["rel_err"],
                    "max_rel_err": r["max_rel_err"], "examined": r["explained"],
                    "at_cell_boundary": r["cell boundary"], "count_floor": r["count floor"]})
    return pd.DataFrame(out)
