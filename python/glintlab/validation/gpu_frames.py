"""Modelled GPU frame costs of the method shaders on a scene (docs/guide/gpu_cost.md#the-two-tables):
each method shader's kernel compiled by RADV/ACO, its loops' trip counts per pixel from the method's
own formulas (what its C++ twin computes: probes, terms, cells, Bernoulli trials), the per-wave model of
:mod:`glintlab.validation.gpu_model`.

The constants a material sets (density, roughness, R) change a shader's instruction counts by a few
instructions at most, so each method is compiled once per architecture at a reference material and its
trip counts are taken at each scene's material and density.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..api import checks as V
from ..api.counting_shaders import KPT25_ALPHA_STAR, tangent_inputs  # noqa: F401  (KPT25's parameters)
from ..api.method_shaders import unpack_inputs
from ..api.zk16_shaders import ZK16_CAP, ZK16_MAX_ANISO
from .gpu_model import KernelCost, frame_seconds, tiles

#: The methods of the two tables: image-method name -> label.
METHODS = {"smooth_shader": "No glints", "db23_shader": "DB23", "zk16_shader": "ZK16",
           "zk16_gated_shader": "ZK16* (gated)", "kpt25_shader": "KPT25"}


@dataclasses.dataclass
class Pixels:
    """What the trip counts need per lit pixel: image position, footprint and success probability."""
    x: np.ndarray
    y: np.ndarray
    J: np.ndarray   # (m, 4) float64
    p: np.ndarray   # DB23's p = min(R D(h) / D(n), 1)
    lit: np.ndarray  # h above the horizon (the shaders return before their loops elsewhere)
    shape: tuple    # image (H, W)


def pixels_of(rows, material) -> Pixels:
    g = unpack_inputs(np.ascontiguousarray(rows, dtype=np.uint32))
    _, J, h, _ = tangent_inputs(rows)
    c = h[:, 2] / np.linalg.norm(h, axis=1)
    a2 = material.alpha ** 2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if material.target == "ggx":
            q = (a2 - 1.0) * c * c + 1.0
            ratio = a2 * a2 / (q * q)
        else:
            ratio = np.exp(-((1.0 - c * c) / (c * c)) / a2) / (c ** 4)
    p = np.where(c > 0, np.minimum(material.R * ratio, 1.0), 0.0)
    px = g["pixel"].astype(np.int64)
    return Pixels(px[:, 0], px[:, 1], J, p, c > 0, (int(px[:, 1].max()) + 1, int(px[:, 0].max()) + 1))


def _axes(J):
    pp = J[:, 0] ** 2 + J[:, 2] ** 2
    qq = J[:, 0] * J[:, 1] + J[:, 2] * J[:, 3]
    rr = J[:, 1] ** 2 + J[:, 3] ** 2
    s1 = np.sqrt(0.5 * (pp + rr) + np.hypot(0.5 * (pp - rr), qq))
    det = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    k = 1.0 / math.sqrt(math.pi)
    return k * s1, k * det / np.maximum(s1, 1e-300), det


def zk16_trip_counts(px: Pixels, density: float) -> tuple:
    """(probes, trials on the lower level, trials on the upper level) per pixel, as zk16_method_body.h loops."""
    major, minor, _ = _axes(px.J)
    minor = np.maximum(minor, major / ZK16_MAX_ANISO)
    probes = np.clip(np.ceil(major / minor * (1 - 1e-12)), 1, ZK16_MAX_ANISO)
    area = math.pi * major * minor / probes
    lo = np.floor(0.5 * np.log2(area * density))
    trials = []
    for lv in (0, 1):
        n = 4.0 ** (lo + lv)  # N 4^l / N facets: the level's cells hold N base 4^l, base = 1 / N
        loop = n * px.p <= 5.0
        whole = np.floor(n)
        t = np.minimum(whole, ZK16_CAP) + ((whole < ZK16_CAP) & (n > whole))
        trials.append(np.where(loop, t, 0.0))
    return probes, trials[0], trials[1]


def db23_trip_counts(px: Pixels) -> np.ndarray:
    """DB23's plane vertices per level: 3 on the isotropic cell (ratio < 2), else 4."""
    major, minor, _ = _axes(px.J)
    return np.where(major / minor < 2.0, 3.0, 4.0)


def kpt25_trip_counts(px: Pixels, density: float) -> list:
    """Per MIP level (the pixel's two), the cells kpt25_method_body.h visits along i, j, a and b."""
    f2 = 0.25 / math.pi
    J = px.J
    suu, svv = f2 * (J[:, 0] ** 2 + J[:, 2] ** 2), f2 * (J[:, 1] ** 2 + J[:, 3] ** 2)
    suv = f2 * (J[:, 0] * J[:, 1] + J[:, 2] * J[:, 3])
    major = np.sqrt(0.5 * (suu + svv) + np.sqrt(np.maximum(0.0, 0.25 * (suu - svv) ** 2 + suv ** 2)))
    res = math.sqrt(density)
    lam = np.maximum(0.0, np.log2(res * 6.0 * major))
    l0 = np.floor(lam)
    second = (lam - l0) > 0
    out = []
    for lv, on in ((l0, np.ones_like(second)), (l0 + 1, second)):
        cell = 2.0 ** lv / res
        ni = np.minimum(np.floor(6.0 * np.sqrt(suu) / cell) + 1.0, 8.0)  # cells a 6-sigma box spans, typically
        nj = np.minimum(np.floor(6.0 * np.sqrt(svv) / cell) + 1.0, 8.0)
        na = np.minimum(2.0, 2.0 ** lv)
        out.append([ni * on, nj * on, na * on, na * on])
    return out


def method_trips(method: str, kernel: KernelCost, px: Pixels, density: float) -> list:
    """Per loop of ``kernel``'s ISA (in order), the trip counts per pixel; ValueError when the ISA's loops
    are not those the method's source has (a compiler that unrolled or merged them)."""
    loops = [(lp.depth, lp.parent) for lp in kernel.isa.loops]
    one = np.ones(px.x.size)
    if method == "smooth_shader" and not loops:
        return []
    if method == "db23_shader" and len(loops) == 6 and loops[5] == (2, 4):
        return [one] * 4 + [2.0 * one, db23_trip_counts(px)]  # 4 level fix-ups, 2 levels x 3 or 4 vertices
    if method == "zk16_shader" and loops == [(1, -1), (2, 0), (2, 0)]:
        return list(zk16_trip_counts(px, density))
    if method == "zk16_gated_shader" and loops == [(1, -1)]:
        return [zk16_trip_counts(px, density)[0]]
    if method == "kpt25_shader" and len(loops) == 8:
        levels = kpt25_trip_counts(px, density)
        return levels[0] + levels[1]
    V.fail("method", method, f"a method shader whose ISA loops the model knows (this ISA has {loops})")


def frame_cost(method: str, kernel: KernelCost, px: Pixels, density: float, arch: dict) -> dict:
    """The modelled frame: ``seconds`` on ``arch``'s GPU for these pixels, ``waves``, ``mean_wave_cycles``
    and ``max_wave_cycles``."""
    trips = [np.where(px.lit, t, 0.0) for t in method_trips(method, kernel, px, density)]
    mask = np.zeros(px.shape, bool)
    mask[px.y, px.x] = True
    waves = []
    for t in trips:
        img = np.zeros(px.shape)
        img[px.y, px.x] = t
        waves.append(tiles(img, mask, kernel.wave_size)[0])
    if not trips:
        n = tiles(np.zeros(px.shape), mask, kernel.wave_size)[0].shape[0]
        cycles = np.full(n, kernel.loop_cycles()[0])
    else:
        cycles = kernel.wave_cycles(waves)
    return {"seconds": frame_seconds(cycles, arch), "waves": int(cycles.size),
            "mean_wave_cycles": float(cycles.mean()), "max_wave_cycles": float(cycles.max())}
