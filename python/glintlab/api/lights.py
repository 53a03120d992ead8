"""Lights for glints (docs/math/lighting.md#lighting-lights): ``gl.lights.cap``, ``rect``, ``disk`` (regions of
directions of constant radiance, seen from the shading point) and ``envmap`` (an equirectangular map split
into a few regions of constant radiance, KK25's assumption), plus the shipped procedural sky
(:func:`sky_image`) and a reader for a user's map (:func:`load_image`).

Directions live in the tangent frame, normal +z. Every light is distant: one region of directions for
all the points of a footprint. Directions below the horizon are hidden by the surface and never lit.

>>> import glintlab as gl
>>> sun = gl.lights.cap((0.3, 0.0, 1.0), half_angle=0.05)
>>> round(sun.solid_angle, 6)
0.007851
"""
from __future__ import annotations

import math
import os

import numpy as np

from .. import _core
from . import checks as V

PARTITIONS = ("log_kmeans", "quantile")


def _vector(name, value):
    a = V.as_float_array(name, value)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        V.fail(name, value, "three finite numbers (x, y, z) in the tangent frame, normal +z")
    return tuple(float(x) for x in a)


def _radiance(value):
    r = V.real("radiance", value)
    if not (math.isfinite(r) and r >= 0):
        V.fail("radiance", value, "a finite radiance >= 0")
    return r


class Light:
    """One light of constant ``radiance``: a convex region of directions (``kind`` "cap", "rect" or "disk")."""

    def __init__(self, core, kind: str, params: dict, radiance: float):
        self._core, self.kind, self.params, self.radiance = core, kind, params, radiance

    @property
    def center(self) -> np.ndarray:
        """The unit direction towards the light's centre."""
        return np.array(self._core.center)

    @property
    def solid_angle(self) -> float:
        """The light's solid angle in steradians, the horizon ignored (closed forms for the cap and the
        rectangle, cubature for the disk)."""
        return self._core.solid_angle

    def visible_solid_angle(self) -> float:
        """The solid angle of the part above the horizon (cubature)."""
        return _core.visible_solid_angle(self._core)[0]

    def contains(self, w) -> np.ndarray:
        """Whether unit directions ``w`` (..., 3) lie in the light (the horizon not tested)."""
        w = V.as_float_array("w", w)
        if w.shape[-1:] != (3,):
            V.fail("w", f"an array of shape {w.shape}", "an array of shape (..., 3)")
        return self._core.contains(np.ascontiguousarray(w.reshape(-1, 3))).reshape(w.shape[:-1])

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"gl.lights.{self.kind}({args}, radiance={self.radiance:g})"


def cap(direction, half_angle, radiance: float = 1.0) -> Light:
    """The directions within ``half_angle`` radians (in (0, pi/2]) of ``direction``: a spherical light seen
    from afar, or the sun."""
    d, a = _vector("direction", direction), V.real("half_angle", half_angle)
    if not (0 < a <= math.pi / 2):
        V.fail("half_angle", half_angle, "an angle in (0, pi/2] radians")
    return Light(_core.Light.cap(d, a), "cap", {"direction": d, "half_angle": a}, _radiance(radiance))


def rect(center, edge_u, edge_v, radiance: float = 1.0) -> Light:
    """The parallelogram ``center`` +- ``edge_u``/2 +- ``edge_v``/2 (positions relative to the shading point;
    its distance sets its angular size): a panel or a window."""
    c, u, v = _vector("center", center), _vector("edge_u", edge_u), _vector("edge_v", edge_v)
    return Light(_core.Light.rect(c, u, v), "rect", {"center": c, "edge_u": u, "edge_v": v}, _radiance(radiance))


def disk(center, normal, radius, radiance: float = 1.0) -> Light:
    """The disk of ``radius`` around ``center`` in the plane of ``normal`` (relative positions)."""
    c, n, r = _vector("center", center), _vector("normal", normal), V.real("radius", radius)
    return Light(_core.Light.disk(c, n, r), "disk", {"center": c, "normal": n, "radius": r}, _radiance(radiance))


def directions(rows: int, cols: int) -> np.ndarray:
    """The unit directions (rows, cols, 3) at the centres of an equirectangular grid: row i at polar angle
    (i + 1/2) pi / rows (row 0 at the zenith, +z), column j at azimuth (j + 1/2) 2 pi / cols from +x."""
    theta = (np.arange(rows) + 0.5) * math.pi / rows
    phi = (np.arange(cols) + 0.5) * 2 * math.pi / cols
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    return np.stack(np.broadcast_arrays(st * np.cos(phi)[None], st * np.sin(phi)[None], ct), axis=-1)


def cell_solid_angles(rows: int, cols: int) -> np.ndarray:
    """The exact solid angle of each cell of the equirectangular grid, (rows, cols)."""
    edges = np.arange(rows + 1) * math.pi / rows
    band = (np.cos(edges[:-1]) - np.cos(edges[1:])) * 2 * math.pi / cols
    return np.broadcast_to(band[:, None], (rows, cols)).copy()


def _luminance(image) -> np.ndarray:
    img = V.as_float_array("image", image)
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = 0.2126 * img[..., 0] + 0.7152 * img[..., 1] + 0.0722 * img[..., 2]
    if img.ndim != 2 or img.shape[0] < 2 or img.shape[1] < 2:
        V.fail("image", f"an array of shape {np.shape(image)}", "an equirectangular map (rows, cols) or (rows, cols, 3)")
    if not np.all(np.isfinite(img)) or img.min() < 0:
        V.fail("image", "an array with negative or non-finite values", "finite radiances >= 0")
    return img


def _partition(lum, weight, upper, k, method):
    """Labels (rows, cols) of k regions over the upper hemisphere (-1 below), ordered by radiance: 1D
    k-means on log radiance weighted by each cell's energy (radiance x solid angle, so that a small bright
    sun weighs as much as the sky it outshines), started at the weighted quantiles; or those quantiles."""
    x = np.log(np.maximum(lum, 1e-12 * max(lum.max(), 1e-300)))
    xs, ws = x[upper], (weight * np.maximum(lum, 1e-12 * max(lum.max(), 1e-300)))[upper]
    order = np.argsort(xs, kind="stable")
    cw = np.cumsum(ws[order]) / ws.sum()
    cuts = [xs[order][min(np.searchsorted(cw, (i + 1) / k), len(xs) - 1)] for i in range(k - 1)]
    if method == "log_kmeans":
        # Lloyd's iterations from centres spread evenly over the range of log radiance; an empty cluster
        # restarts at the point furthest from its centre in the cluster of the largest weighted spread.
        centres = np.linspace(xs.min(), xs.max(), k)
        for _ in range(200):
            lab = np.argmin(np.abs(xs[:, None] - centres[None]), axis=1)
            new = centres.copy()
            for r in range(k):
                if np.any(lab == r):
                    new[r] = np.average(xs[lab == r], weights=ws[lab == r])
            for r in range(k):
                if not np.any(lab == r):
                    sse = [np.sum(ws[lab == q] * (xs[lab == q] - new[q]) ** 2) for q in range(k)]
                    q = int(np.argmax(sse))
                    members = np.flatnonzero(lab == q)
                    far = members[np.argmax(np.abs(xs[members] - new[q]))]
                    new[r], lab[far] = xs[far], r
            new = np.sort(new)
            if np.allclose(new, centres, rtol=0, atol=1e-12):
                break
            centres = new
        cuts = list(0.5 * (centres[1:] + centres[:-1]))
    labels = np.full(lum.shape, -1, dtype=np.int64)
    labels[upper] = np.searchsorted(np.asarray(cuts), xs, side="right")
    return labels


class EnvMap:
    """An equirectangular environment map partitioned into ``regions`` regions of constant radiance over
    the upper hemisphere (docs/math/lighting.md#lighting-env): ``labels`` (rows, cols), -1 below the
    horizon; ``region_radiance`` the solid-angle-weighted mean of the map over each region; ``image`` the
    map's own radiance (its luminance for a colour map)."""

    def __init__(self, image, regions: int = 3, partition: str = "log_kmeans", labels=None):
        self.image = _luminance(image)
        rows, cols = self.image.shape
        self.regions = V.integer("regions", regions, minimum=1, maximum=64)
        V.choice("partition", partition, PARTITIONS)
        self.partition = partition
        self.solid_angles = cell_solid_angles(rows, cols)
        upper = directions(rows, cols)[..., 2] > 0
        if labels is None:
            labels = _partition(self.image, self.solid_angles, upper, self.regions, partition)
        else:
            labels = np.asarray(labels)
            if labels.shape != self.image.shape or labels.min() < -1 or labels.max() >= self.regions:
                V.fail("labels", f"an array of shape {labels.shape}", f"integers in [-1, {self.regions}) shaped like the image")
            labels = np.where(upper, labels, -1).astype(np.int64)
        self.labels = labels
        w = self.solid_angles
        self.region_radiance = np.array([np.sum(self.image * w * (labels == r)) / max(np.sum(w * (labels == r)), 1e-300)
                                         for r in range(self.regions)])
        self.region_solid_angle = np.array([np.sum(w * (labels == r)) for r in range(self.regions)])
        self._filtered: dict = {}

    @property
    def shape(self):
        return self.image.shape

    def constant_image(self) -> np.ndarray:
        """The map with each region replaced by its constant radiance (0 below the horizon)."""
        return np.where(self.labels >= 0, self.region_radiance[np.maximum(self.labels, 0)], 0.0)

    def lookup(self, w, radiance: str = "map", filter: str = "nearest") -> np.ndarray:
        """The radiance at unit directions ``w`` (..., 3), ``radiance`` "map" (its own values) or "regions"
        (the partition's constants), 0 below the horizon; ``filter`` "nearest" (the cell holding each
        direction: the piecewise constant map the exact p and the facet truth read) or "bilinear" (between
        the cells' centres, wrapping in azimuth: a continuous radiance, for integrals by quadrature)."""
        V.choice("radiance", radiance, ("map", "regions"))
        V.choice("filter", filter, ("nearest", "bilinear"))
        w = V.as_float_array("w", w)
        rows, cols = self.shape
        y = np.arccos(np.clip(w[..., 2], -1, 1)) / math.pi * rows
        x = np.mod(np.arctan2(w[..., 1], w[..., 0]), 2 * math.pi) / (2 * math.pi) * cols
        img = self.image if radiance == "map" else self.constant_image()
        if filter == "nearest":
            out = img[np.minimum(y.astype(int), rows - 1), np.minimum(x.astype(int), cols - 1)]
        else:
            y = np.clip(y - 0.5, 0, rows - 1)
            y0 = np.minimum(np.floor(y).astype(int), rows - 2)
            x0 = np.floor(x - 0.5).astype(int)
            fy, fx = y - y0, x - 0.5 - x0
            a, b = np.mod(x0, cols), np.mod(x0 + 1, cols)
            out = (img[y0, a] * (1 - fx) + img[y0, b] * fx) * (1 - fy) + (img[y0 + 1, a] * (1 - fx) + img[y0 + 1, b] * fx) * fy
        return np.where(w[..., 2] > 0, out, 0.0)

    def core_args(self, radiance: str = "map"):
        """(rows, cols, regions, labels, radiance) as the core takes them; ``radiance`` "map" (the map's
        own values) or "regions" (the partition's constants)."""
        img = self.image if radiance == "map" else self.constant_image()
        rows, cols = self.shape
        return rows, cols, self.regions, self.labels.reshape(-1).astype(int).tolist(), img.reshape(-1).tolist()

    def __repr__(self):
        return f"gl.lights.envmap(image of {self.shape[0]}x{self.shape[1]}, regions={self.regions})"


def envmap(image, regions: int = 3, partition: str = "log_kmeans", labels=None) -> EnvMap:
    """An environment map of ``regions`` regions: ``image`` an equirectangular radiance map (rows, cols) or
    (rows, cols, 3) (row 0 at the zenith), a file path (.npy, .pfm, or anything OpenImageIO reads when it
    is installed), or "sky" for the shipped procedural sky (:func:`sky_image`). ``labels`` gives the
    partition explicitly."""
    if isinstance(image, (str, os.PathLike)):
        image = sky_image() if str(image) == "sky" else load_image(image)
    return EnvMap(image, regions, partition, labels)


def sky_image(rows: int = 64, cols: int = 128) -> np.ndarray:
    """The shipped procedural environment: a sky brightening towards the horizon (radiance 0.3 to 1), a sun
    (a disk of 2.5 degrees radius, radiance 2000, at 35 degrees from the zenith, azimuth 200 degrees) and a
    window (a bright rectangle of radiance 40, 25 x 15 degrees around polar angle 60, azimuth 150 degrees);
    a dark ground (0.05) below the horizon."""
    rows, cols = V.integer("rows", rows, minimum=4), V.integer("cols", cols, minimum=4)
    d = directions(rows, cols)
    theta = np.arccos(np.clip(d[..., 2], -1, 1))
    phi = np.mod(np.arctan2(d[..., 1], d[..., 0]), 2 * math.pi)
    img = np.where(d[..., 2] > 0, 0.3 + 0.7 * (theta / (math.pi / 2)) ** 2, 0.05)
    st, sp = math.radians(35.0), math.radians(200.0)
    sun = np.array([math.sin(st) * math.cos(sp), math.sin(st) * math.sin(sp), math.cos(st)])
    img = np.where(d @ sun >= math.cos(math.radians(2.5)), 2000.0, img)
    window = (np.abs(theta - math.radians(60.0)) <= math.radians(7.5)) & \
             (np.abs(phi - math.radians(150.0)) <= math.radians(12.5))
    return np.where(window, 40.0, img)


def _read_pfm(path) -> np.ndarray:
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind not in (b"PF", b"Pf"):
            V.fail("path", str(path), "a PFM file (header PF or Pf)")
        width, height = (int(x) for x in f.readline().split())
        scale = float(f.readline())
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    img = data.reshape(height, width, channels) if channels == 3 else data.reshape(height, width)
    return np.flipud(img).astype(float)  # PFM stores the bottom row first


def load_image(path) -> np.ndarray:
    """An equirectangular HDR map from a file: .npy, .pfm, or through OpenImageIO (python3-openimageio)
    when it is installed (.exr, .hdr, ...)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        V.fail("path", path, "an existing file")
    if path.endswith(".npy"):
        return np.load(path)
    if path.endswith(".pfm"):
        return _read_pfm(path)
    try:
        import OpenImageIO as oiio  # optional: Debian's python3-openimageio
    except ImportError:
        V.fail("path", path, "a .npy or .pfm file (install python3-openimageio for .exr and .hdr)")
    buf = oiio.ImageBuf(path)
    return np.asarray(buf.get_pixels(oiio.FLOAT), dtype=float)
