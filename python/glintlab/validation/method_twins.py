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
from ..api.glinty_ndf import Material, method_density
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
        err = np.where(np.isfinite(err), err, np.where(shader == twin, 0.0, np.inf))  # as twin_mismatch
        bad = np.nonzero(err > CS.COUNT_ALLOWANCE)[0]
        r.update(explain(rows, material, bad, explain_limit))
        r["explained"] = min(len(bad), explain_limit)
    return r


METHODS = ("db23", "kpt25")


def float32_study(scene="plane_25", scale: float = 0.1, seed: int = 0, cases=CASES, methods=METHODS,
                  explain_limit: int = 64) -> pd.DataFrame:
    """One row per method shader ("db23", "kpt25") and case of ``cases`` (:data:`CASES`): pixels, share
    beyond the allowance and beyond 1 %, mean and largest relative error, the mismatches examined and
    their reasons (DB23: "cell boundary", "count floor"; KPT25: "point at an edge", "box or block edge",
    "lobe at the square's edge", "ulps"). KPT25 runs at the density matched to the facets' glint count
    (as its image method); the offsets are in the facets' texels for both."""
    rows, material = scene_rows(scene, scale, seed=seed)
    kpt = dataclasses.replace(material, density=method_density("kpt25_shader", material))
    out = []
    for method in methods:
        V.choice("methods", method, METHODS, "'db23' and/or 'kpt25'")
        for name, offset, footprint, stretch in cases:
            moved = transform_rows(rows, material, offset, footprint, stretch)
            r = (compare(moved, material, explain_limit=explain_limit) if method == "db23"
                 else kpt25_compare(moved, kpt, explain_limit=explain_limit))
            reasons = {k: v for k, v in r.items()
                       if k not in ("pixels", "share", "share_1pct", "rel_err", "max_rel_err", "explained")}
            out.append({"method": f"{method}_shader", "case": name, "pixels": r["pixels"], "mismatch_share": r["share"],
                        "beyond_1pct": r["share_1pct"], "mean_rel_err": r["rel_err"], "max_rel_err": r["max_rel_err"],
                        "examined": r["explained"],
                        "reasons": ", ".join(f"{k} {v}" for k, v in reasons.items() if v) or "-"})
    return pd.DataFrame(out)


# --------------------------------------------------------------------------------------------------
# KPT25

def _philox(c, key):
    """Philox4x32-10 on uint32 arrays c (4, m) and key (2,), as the core's CounterRng::block."""
    c = [np.asarray(x, np.uint64) & 0xFFFFFFFF for x in c]
    k0, k1 = np.uint64(key[0]), np.uint64(key[1])
    mask = np.uint64(0xFFFFFFFF)
    for r in range(10):
        if r:
            k0, k1 = (k0 + np.uint64(0x9E3779B9)) & mask, (k1 + np.uint64(0xBB67AE85)) & mask
        p0 = np.uint64(0xD2511F53) * c[0]
        p1 = np.uint64(0xCD9E8D57) * c[2]
        c = [((p1 >> np.uint64(32)) ^ c[1] ^ k0) & mask, p1 & mask, ((p0 >> np.uint64(32)) ^ c[3] ^ k1) & mask, p0 & mask]
    return c


def kpt25_explain(rows, material: Material, which, limit: int = 64, ulps: float = 64.0) -> dict:
    """Why KPT25 pixels differ: for up to ``limit`` rows of ``which``, the points of B(k) at the pixel's
    levels in float64 (the twin's arithmetic), and whether one of them sits within ``ulps`` float32
    spacings of the filter's edge (q = 9) or of the disk U's rim ("point at an edge"), or the pixel's
    spatial box or angular block is at a floor ("box or block edge"), or every point's offset from the
    pixel is rounded to |uv| 2^-24, beyond 1e-4 of the filter's std ("point offsets"), or the lobe lies
    within 8 stds of the unit square's edge ("lobe at the square's edge": the compensation's erfc
    differences); else "ulps" (exp, erfc, log2)."""
    uv, J, h, seed = CS.tangent_inputs(rows)
    nd = CS.kpt25_twin_ndf(material)
    out = {"point at an edge": 0, "point offsets": 0, "box or block edge": 0, "lobe at the square's edge": 0, "ulps": 0}
    eps32 = float(np.finfo(np.float32).eps) * ulps
    for i in list(which)[:limit]:
        px = nd.pixel(J[i], h[i])
        f2 = 0.25 / math.pi
        suu = f2 * (J[i, 0] ** 2 + J[i, 2] ** 2)
        svv = f2 * (J[i, 1] ** 2 + J[i, 3] ** 2)
        suv = f2 * (J[i, 0] * J[i, 1] + J[i, 2] * J[i, 3])
        det = suu * svv - suv * suv
        ia, ib, ic = svv / det, -suv / det, suu / det
        hu, hv = 3 * math.sqrt(suu), 3 * math.sqrt(svv)
        res = math.sqrt(material.density)
        reason = "ulps"
        lam = max(0.0, float(px["lambda"]))
        l0 = int(math.floor(lam))
        edges = [lam]
        for level in ([l0, l0 + 1] if lam > l0 else [l0]):
            cell, na = 2.0**level / res, 2**level
            edges += [(uv[i, 0] - hu) / cell, (uv[i, 0] + hu) / cell, (uv[i, 1] - hv) / cell, (uv[i, 1] + hv) / cell]
            qa, qb = px["xa"] * na - 0.5, px["ya"] * na - 0.5
            edges += [qa, qb] if na > 2 else []
            a0 = 0 if na <= 2 else min(max(int(math.floor(qa)), 0), na - 2)
            b0 = 0 if na <= 2 else min(max(int(math.floor(qb)), 0), na - 2)
            ii = np.arange(math.floor((uv[i, 0] - hu) / cell), math.floor((uv[i, 0] + hu) / cell) + 1)
            jj = np.arange(math.floor((uv[i, 1] - hv) / cell), math.floor((uv[i, 1] + hv) / cell) + 1)
            aa = np.arange(a0, min(a0 + 1, na - 1) + 1)
            bb = np.arange(b0, min(b0 + 1, na - 1) + 1)
            I, Jj, A, B = (x.ravel() for x in np.meshgrid(ii, jj, aa, bb, indexing="ij"))
            word3 = (8 << 24) | (level << 20) | B
            r = _philox([2 * A, I, Jj, word3], (seed & 0xFFFFFFFF, seed >> 32))
            unit = [(x.astype(np.float64) + 0.5) * 2.0**-32 for x in r]
            mx, my = (A + unit[2]) / na, (B + unit[3]) / na
            rim = (mx - 0.5) ** 2 + (my - 0.5) ** 2
            dx, dy = (I + unit[0]) * cell - uv[i, 0], (Jj + unit[1]) * cell - uv[i, 1]
            q = ia * dx * dx + 2 * ib * dx * dy + ic * dy * dy
            # float32 keeps |uv| 2^-24 of the point's offset: q moves by that much relative to the footprint
            dq = 2 * math.sqrt(max(ia, ic)) * 3 * (abs(uv[i]).max() + 1) * eps32
            if np.any((np.abs(q - 9.0) <= dq + 9 * eps32) & (rim < 0.25)) or np.any(np.abs(rim - 0.25) <= eps32):
                reason = "point at an edge"
        # The point's offset (i + u) cell - uv keeps |uv| 2^-24: relative to the filter's std that moves every
        # point's q, so the weights exp(-q / 2), by more than the allowance when it exceeds 1e-4.
        if reason == "ulps" and 3 * float(np.spacing(np.float32(np.abs(uv[i]).max()))) * math.sqrt(max(ia, ic)) > 1e-4:
            reason = "point offsets"
        # A lobe within 8 stds of the unit square's edge (T(h) at U's rim: grazing h, sigma ~ 1e-7 to 1e-3):
        # the compensation's 1D masses there are differences of erfc of float32 arguments.
        if reason == "ulps" and min(px["xa"], 1 - px["xa"], px["ya"], 1 - px["ya"]) < 8 * px["sigma"]:
            reason = "lobe at the square's edge"
        if reason == "ulps":
            e = np.asarray(edges)
            if np.any(np.abs(e - np.round(e)) <= eps32 * (np.abs(e) + 1)):
                reason = "box or block edge"
        out[reason] += 1
    return out


def kpt25_compare(rows, material: Material, method=None, explain_limit: int = 64) -> dict:
    """The KPT25 method shader (or ``method``) against its C++ twin on the same rows, with the reasons."""
    method = method if method is not None else CS.kpt25_method(material)
    shader = method.shade(rows)
    twin = CS.kpt25_twin(rows, material)
    r = CS.kpt25_mismatch(shader, twin, rows, material)
    if explain_limit:
        _, _, h, _ = CS.tangent_inputs(rows)
        d = CS.kpt25_twin_ndf(material).smooth(h)
        with np.errstate(divide="ignore", invalid="ignore"):
            err = np.abs(shader.astype(np.float64) - twin) / np.maximum(np.abs(twin), 1e-2 * d)
        err = np.where(np.isfinite(err), err, np.where(shader == twin, 0.0, np.inf))  # as kpt25_mismatch
        bad = np.nonzero(err > 1e-3)[0]
        r.update(kpt25_explain(rows, material, bad, explain_limit))
        r["explained"] = min(len(bad), explain_limit)
    return r
