"""Scenes as far as the counting laws see them: per pixel uv, its Jacobian, the half vector, p and n.

A scene file (``data/schema/scene.schema.json``, examples in ``data/scenes/``) holds a pinhole camera,
one primitive (a plane, a sphere, or a plane displaced by a procedural heightfield), a point or
directional light and a glinty material (NDF, roughness alpha, DB23's ratio R, facet density N).
``Scene.trace`` (in C++, core/src/scene/scene_trace.cpp; ``Scene.trace_numpy`` is the same in numpy) intersects
the camera rays analytically (the heightfield by a conservative march and a safeguarded Newton step) and
differentiates the hit point, the texture coordinates and so the
Jacobian d(uv)/d(pixel) analytically; ``Scene.geometry`` does it for every pixel and derives the
footprint (P, r, phi) with ``gl.footprint_shapes``, D(h), p = R D(h) / D(n) (DB23 eq. 4, clamped to
1 and reported) and n = N P (docs/math/index.md#notation). No rasterizer: one primitive, first hit.

Implicit-function derivative used for every primitive: the hit point x = o + t d(q) of the ray through
pixel q lies on G(x) = 0. Differentiating G(o + t d) = 0 gives dt/dq = -t (g . dd/dq) / (g . d), with
g = grad G at x, so dx/dq = t (dd/dq - d (g . dd/dq) / (g . d)): the ray direction's change projected
onto the tangent plane along the ray.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _core
from ..api import checks as V
from ..api import fpmath
from ..api.grids import footprint_shapes
from ..api.ndf import ndf as get_ndf

from ..resources import data_path
from .documents import fail, parse_document

SCHEMA_PATH = data_path("schema", "scene.schema.json")
SCENES_DIR = data_path("scenes")
# DB23 Table 1 setups this model covers (the file stems in data/scenes/).
TABLE1_SCENES = ("sphere", "plane_90", "plane_25", "heightfield_90", "heightfield_25")


# --------------------------------------------------------------------------------------------------
# Loading and validation

def _bad(source, pointer, value, expected):
    fail(source, pointer, expected, value)


def _physical_checks(doc: dict, source: str):
    """What a schema cannot say: degenerate vectors, a camera inside the sphere or below the slab.
    (Numbers are finite: JSON has no others, and the parser refuses overflowing ones.)"""
    cam, prim, light = doc["camera"], doc["primitive"], doc["light"]
    pos, look = np.array(cam["position"], float), np.array(cam["look_at"], float)
    if np.linalg.norm(look - pos) == 0:
        _bad(source, "/camera/look_at", cam["look_at"], "a point different from /camera/position")
    fwd = (look - pos) / np.linalg.norm(look - pos)
    up = np.array(cam["up"], float)
    if np.linalg.norm(np.cross(fwd, up)) < 1e-9 * max(np.linalg.norm(up), 1e-300):
        _bad(source, "/camera/up", cam["up"], "a vector not parallel to the view direction")
    if prim["type"] == "sphere":
        c = np.array(prim["center"], float)
        if np.linalg.norm(pos - c) <= prim["radius"]:
            _bad(source, "/camera/position", cam["position"],
                 f"a point outside the sphere (center {prim['center']}, radius {prim['radius']})")
    else:
        if np.linalg.norm(prim["normal"]) == 0:
            _bad(source, "/primitive/normal", prim["normal"], "a non-zero vector")
        if prim["type"] == "heightfield":
            p0, nrm = np.array(prim["point"], float), _plane_frame(prim)[2]
            if (pos - p0) @ nrm <= prim["height"]["amplitude"] * 2.0:
                _bad(source, "/camera/position", cam["position"],
                     "a point above the heightfield's slab (height above the plane > 2 x amplitude)")
    if light["type"] == "directional" and np.linalg.norm(light["direction"]) == 0:
        _bad(source, "/light/direction", light["direction"], "a non-zero vector")


def load_scene(source, name: str | None = None) -> "Scene":
    """A :class:`Scene` from a path, a JSON string or a dict, validated against
    ``data/schema/scene.schema.json`` in C++ (defaults filled in; ``documents.parse_document``) and
    checked physically. Raises ValueError ``<file>: at <JSON pointer>: expected <what>, got <value>``."""
    doc, label, _ = parse_document("scene", source)
    _physical_checks(doc, label)
    stem = None if label == "<scene>" else Path(label).stem  # a file's stem; "<scene>" for a dict or JSON text
    return Scene(doc, name=name or doc.get("name") or stem or "scene", source=label)


# --------------------------------------------------------------------------------------------------
# The scene model

def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _plane_frame(prim):
    """(e1, e2, normal): texture axes and normal of a (tilted) plane. e1 is the world x axis projected
    onto the plane (or y when x is normal to it), e2 = normal x e1."""
    nrm = _unit(prim["normal"])
    t = math.radians(prim.get("tilt_deg", 0.0))
    rot = np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])
    nrm = rot @ nrm
    ref = np.array([1.0, 0.0, 0.0]) if abs(nrm[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = _unit(ref - (ref @ nrm) * nrm)
    return e1, np.cross(nrm, e1), nrm


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


@dataclass
class Geometry:
    """Per-pixel arrays (H, W) of a scene; see ``Scene.geometry``."""
    width: int
    height: int
    hit: np.ndarray        # the ray meets the primitive
    uv: np.ndarray         # (H, W, 2)
    J: np.ndarray          # (H, W, 4) du/dx, dv/dx, du/dy, dv/dy (0 where missed)
    P: np.ndarray
    r: np.ndarray
    phi: np.ndarray
    footprint_ok: np.ndarray  # gl.footprint_shapes status "ok"
    cos_h: np.ndarray      # h . n_shading
    D: np.ndarray          # D(h)
    p_raw: np.ndarray      # R D(h) / D(n) before clamping
    p: np.ndarray          # clamped to [0, 1]; 0 where unlit
    clamped: np.ndarray    # p_raw > 1
    unlit: np.ndarray      # the light or the camera is below the shading normal's horizon
    n: np.ndarray          # N P
    seconds: float = 0.0

    @property
    def valid(self) -> np.ndarray:
        """Pixels the statistics count: hit, with a finite non-degenerate footprint."""
        return self.hit & self.footprint_ok

    def summary(self) -> dict:
        v = self.valid
        total = self.width * self.height
        return {"pixels": total, "hit": int(self.hit.sum()), "sky": int((~self.hit).sum()),
                "degenerate": int((self.hit & ~self.footprint_ok).sum()), "valid": int(v.sum()),
                "unlit": int((v & self.unlit).sum()), "p_clamped": int((v & self.clamped).sum()),
                "p_clamped_share": float((v & self.clamped).sum() / max(v.sum(), 1)),
                "r_gt_16_share": float((v & (self.r > 16)).sum() / max(v.sum(), 1)),
                "n_median": float(np.median(self.n[v])) if v.any() else float("nan"),
                "p_median": float(np.median(self.p[v])) if v.any() else float("nan"),
                "r_median": float(np.median(self.r[v])) if v.any() else float("nan"),
                "geometry_seconds": round(self.seconds, 3)}


class Scene:
    """A validated scene (use :func:`load_scene`). ``spec`` is the JSON document with defaults."""

    def __init__(self, spec: dict, name: str = "scene", source: str = "scene"):
        self.spec, self.name, self.source = spec, name, source
        cam = spec["camera"]
        self.width, self.height = (int(x) for x in cam["resolution"])
        self.position = np.array(cam["position"], float)
        fwd = _unit(np.array(cam["look_at"], float) - self.position)
        right = _unit(np.cross(fwd, np.array(cam["up"], float)))
        self.forward, self.right, self.up = fwd, right, np.cross(right, fwd)
        prim = spec["primitive"]
        self.kind = prim["type"]
        self.uv_scale = float(prim["uv_scale"])
        if self.kind == "sphere":
            self.center, self.radius = np.array(prim["center"], float), float(prim["radius"])
        else:
            self.origin = np.array(prim["point"], float)
            self.e1, self.e2, self.normal = _plane_frame(prim)
            hf = prim.get("height")
            self.waves = []
            if hf is not None:
                # Octave k: amplitude A 2^-k, angular frequency 2 pi f 2^k, direction turned by the golden
                # angle (137.5 deg) per octave so the crests never line up, phase k.
                for k in range(int(hf["octaves"])):
                    ang = math.radians(20.0 + 137.5 * k)
                    self.waves.append((hf["amplitude"] * 0.5**k, 2 * math.pi * hf["frequency"] * 2**k,
                                       math.cos(ang), math.sin(ang), float(k)))
        mat = spec["material"]
        self.ndf = get_ndf(mat["ndf"], mat["alpha"])
        self.R, self.density = float(mat["R"]), float(mat["density"])
        self.light = spec["light"]

    def __repr__(self):
        return f"Scene({self.name!r}, {self.kind}, {self.width}x{self.height})"

    def scaled(self, scale: float, keep_n: bool = False) -> "Scene":
        """The same scene at ``scale`` times the resolution per side (same field of view). With
        ``keep_n`` the density is divided by scale^2 so that a pixel keeps the expected facet count n
        of the full-resolution pixels it stands for (footprint areas grow by 1 / scale^2)."""
        scale = V.real("scale", scale)
        if not (0 < scale <= 4):
            V.fail("scale", scale, "a number in (0, 4]")
        spec = copy.deepcopy(self.spec)
        w, h = max(1, int(round(self.width * scale))), max(1, int(round(self.height * scale)))
        spec["camera"]["resolution"] = [w, h]
        if keep_n:
            spec["material"]["density"] *= (w * h) / (self.width * self.height)
        return Scene(spec, name=self.name, source=self.source)

    @property
    def focal(self) -> float:
        """Focal length in pixels."""
        cam = self.spec["camera"]
        half = 0.5 * (self.width if cam["fov_axis"] == "horizontal" else self.height)
        return half / math.tan(math.radians(cam["fov_deg"]) / 2)

    # ---- height function of the heightfield (in the plane's frame)
    def _height(self, a, b):
        h, ha, hb = np.zeros_like(a), np.zeros_like(a), np.zeros_like(a)
        for amp, w, ca, sa, ph in self.waves:
            arg = w * (ca * a + sa * b) + ph
            # fpmath: the same bits whatever ran before in the process (numpy picks its sin / cos loop by address).
            h += amp * fpmath.sin(arg)
            c = amp * w * fpmath.cos(arg)
            ha += c * ca
            hb += c * sa
        return h, ha, hb

    def _intersect_heightfield(self, o, d):
        """First t > 0 with c(t) = h(a(t), b(t)), c the height above the plane: a conservative march
        (steps G / L, L bounding |dG/dt|, so no crossing is skipped, with a floor of 1/8 of the finest
        wavelength to end in bounded time) to a bracket, then Newton safeguarded by bisection."""
        amax = sum(w[0] for w in self.waves)
        slope = sum(w[0] * w[1] for w in self.waves)
        rel = o - self.origin
        c0 = rel @ self.normal
        dn = d @ self.normal
        da, db = d @ self.e1, d @ self.e2
        a0, b0 = rel @ self.e1, rel @ self.e2
        m = d.shape[0]
        t_hit = np.full(m, np.nan)
        down = dn < 0
        with np.errstate(divide="ignore", invalid="ignore"):
            t_top = np.where(down, np.maximum((amax - c0) / dn, 0.0), np.nan)
            t_bot = np.where(down, (-amax - c0) / dn, np.nan)
        lip = np.abs(dn) + slope * np.hypot(da, db)
        min_step = (2 * math.pi / max(w[1] for w in self.waves)) / 8 / np.hypot(da, db).clip(1e-12) \
            if self.waves and slope > 0 else np.full(m, np.inf)
        min_step = np.minimum(min_step, (t_bot - t_top) / 4)

        def G(idx, t):
            h, ha, hb = self._height(a0 + t * da[idx], b0 + t * db[idx])
            return c0 + t * dn[idx] - h, dn[idx] - ha * da[idx] - hb * db[idx]

        idx = np.flatnonzero(down)
        t = t_top[idx].copy()
        lo = t.copy()
        br_lo, br_hi = np.full(m, np.nan), np.full(m, np.nan)
        for _ in range(10_000):
            if idx.size == 0:
                break
            g, _ = G(idx, t)
            done = (g <= 0) | (t >= t_bot[idx])
            # Bracket [lo, t]: G(lo) > 0 >= G(t) (t_bot always has G <= 0).
            br_lo[idx[done]], br_hi[idx[done]] = lo[done], np.minimum(t[done], t_bot[idx[done]])
            keep = ~done
            idx, t, g = idx[keep], t[keep], g[keep]
            lo = t.copy()
            t = np.minimum(t + np.maximum(g / lip[idx], min_step[idx]), t_bot[idx])
        idx = np.flatnonzero(np.isfinite(br_lo))
        t_hit[idx] = self._refine(idx, br_lo[idx], br_hi[idx], G)
        return t_hit

    @staticmethod
    def _refine(idx, lo, hi, G):
        """Root of G in [lo, hi] (G(lo) > 0 >= G(hi)): Newton steps kept inside the bracket, bisection
        otherwise, until the step is below 1e-15 t (at most 80 rounds: bisection alone reaches double
        precision in 60). Converged rays leave the active set."""
        out = 0.5 * (lo + hi)
        act = np.arange(idx.size)
        t = out.copy()
        for _ in range(80):
            if act.size == 0:
                break
            g, dg = G(idx[act], t)
            pos = g > 0
            lo, hi = np.where(pos, t, lo), np.where(pos, hi, t)
            with np.errstate(divide="ignore", invalid="ignore"):
                tn = t - g / dg
            # Closed bracket: near the root t sits on one end and the Newton point next to it.
            inside = np.isfinite(tn) & (tn >= lo) & (tn <= hi)
            t_new = np.where(inside, tn, 0.5 * (lo + hi))
            conv = (np.abs(t_new - t) <= 1e-15 * np.abs(t)) | (hi - lo <= 1e-15 * np.abs(t))
            out[act] = t_new
            keep = ~conv
            act, t, lo, hi = act[keep], t_new[keep], lo[keep], hi[keep]
        return out

    def trace(self, px, py) -> dict:
        """Rays through pixel coordinates (px, py) (floats, pixel centres at i + 0.5; y down): hit mask,
        hit point x, ray parameter t, uv, the analytic Jacobian (du/dx, dv/dx, du/dy, dv/dy), the shading
        normal, the ray direction and the hit point's derivatives along the pixel axes. Arrays of any
        (equal) shape. Computed in C++ on every core (core/src/scene/scene_trace.cpp): the operations of
        :meth:`trace_numpy`, which it matches to float64 rounding."""
        px, py = np.broadcast_arrays(np.asarray(px, float), np.asarray(py, float))
        shape = px.shape
        sphere = self.kind == "sphere"
        zero = (0.0, 0.0, 0.0)
        plane = (zero,) * 4 if sphere else (tuple(self.origin), tuple(self.normal), tuple(self.e1), tuple(self.e2))
        out = _core.scene_trace(
            np.ascontiguousarray(px.reshape(-1)), np.ascontiguousarray(py.reshape(-1)), sphere, float(self.width),
            float(self.height), float(self.focal), tuple(self.position), tuple(self.forward), tuple(self.right),
            tuple(self.up), tuple(self.center) if sphere else zero, float(self.radius) if sphere else 0.0, *plane,
            [] if sphere else [tuple(float(v) for v in w) for w in self.waves], float(self.uv_scale))
        res = {}
        for key, value in out.items():
            value = value.astype(bool) if key == "hit" else value
            res[key] = value.reshape(shape + value.shape[1:])
        return res

    def trace_numpy(self, px, py) -> dict:
        """:meth:`trace` in numpy (the first form, kept as the reference the C++ one is compared with)."""
        px, py = np.broadcast_arrays(np.asarray(px, float), np.asarray(py, float))
        shape = px.shape
        xs, ys = (px.reshape(-1) - 0.5 * self.width) / self.focal, (py.reshape(-1) - 0.5 * self.height) / self.focal
        d = self.forward + xs[:, None] * self.right - ys[:, None] * self.up   # not normalized: t scales with it
        dd = (self.right / self.focal, -self.up / self.focal)                 # d d / d px, d d / d py
        o = self.position
        m = d.shape[0]
        if self.kind == "sphere":
            oc = o - self.center
            a, b, c = _dot(d, d), 2 * (d @ oc), oc @ oc - self.radius**2
            disc = b * b - 4 * a * c
            with np.errstate(invalid="ignore"):
                # Nearest root; written as 2c / (-b + sqrt(disc)) to avoid cancellation (c > 0: camera outside).
                t = np.where(disc >= 0, 2 * c / (-b + np.sqrt(np.maximum(disc, 0))), np.nan)
        else:
            if self.waves:
                t = self._intersect_heightfield(o, d)
            else:
                dn = d @ self.normal
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = ((self.origin - o) @ self.normal) / dn
        hit = np.isfinite(t) & (t > 0)
        t = np.where(hit, t, 1.0)
        x = o + t[:, None] * d
        if self.kind == "sphere":
            g = (x - self.center) / self.radius
            shading = g
        else:
            rel = x - self.origin
            a, b = rel @ self.e1, rel @ self.e2
            if self.waves:
                _, ha, hb = self._height(a, b)
                g = self.normal - ha[:, None] * self.e1 - hb[:, None] * self.e2
            else:
                g = np.broadcast_to(self.normal, x.shape)
            shading = g / np.linalg.norm(g, axis=1, keepdims=True)
        gd = _dot(g, d)
        # dx/dq = t (dd/dq - d (g . dd/dq) / (g . d)) (module docstring).
        dx = [t[:, None] * (v - d * ((g @ v) / gd)[:, None]) for v in dd]
        s = self.uv_scale
        if self.kind == "sphere":
            # Arc-length lat-long: u = s R phi, v = s R theta (texels square on the equator), pole +z.
            q = x - self.center
            rho2 = q[:, 0] ** 2 + q[:, 1] ** 2
            rho = np.sqrt(rho2)
            # fpmath.arctan2, not np.arctan2: numpy chooses between two atan2 loops that differ in the last
            # bit by the arrays' addresses, so uv (and the glint images) changed with what ran before.
            uv = np.stack([s * self.radius * fpmath.arctan2(q[:, 1], q[:, 0]),
                           s * self.radius * fpmath.arctan2(rho, q[:, 2])], axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                grad_phi = np.stack([-q[:, 1], q[:, 0], np.zeros(m)], axis=1) / rho2[:, None]
                # theta = atan2(rho, z): d theta = (z d rho - rho dz) / (rho^2 + z^2), d rho = (x dx + y dy) / rho
                r2 = rho2 + q[:, 2] ** 2
                grad_th = np.stack([q[:, 2] * q[:, 0] / rho, q[:, 2] * q[:, 1] / rho, -rho], axis=1) / r2[:, None]
            J = np.stack([s * self.radius * _dot(grad_phi, dx[0]), s * self.radius * _dot(grad_th, dx[0]),
                          s * self.radius * _dot(grad_phi, dx[1]), s * self.radius * _dot(grad_th, dx[1])], axis=1)
        else:
            uv = s * np.stack([a, b], axis=1)
            J = s * np.stack([dx[0] @ self.e1, dx[0] @ self.e2, dx[1] @ self.e1, dx[1] @ self.e2], axis=1)
        J = np.where(hit[:, None], J, 0.0)
        uv = np.where(hit[:, None], uv, 0.0)
        return {"hit": hit.reshape(shape), "t": t.reshape(shape), "x": x.reshape(shape + (3,)),
                "uv": uv.reshape(shape + (2,)), "J": J.reshape(shape + (4,)),
                "shading_normal": shading.reshape(shape + (3,)), "direction": d.reshape(shape + (3,)),
                # The hit point's derivatives along the pixel axes (ray differentials on the tangent plane):
                # what a sub-pixel sample's position is to first order (scene_images.subpixel_inputs).
                "dxdpx": dx[0].reshape(shape + (3,)), "dxdpy": dx[1].reshape(shape + (3,))}

    def geometry(self) -> Geometry:
        """Every pixel: uv, J, footprint (P, r, phi), half vector, D(h), p (clamped, reported) and n."""
        import time
        t0 = time.perf_counter()
        y, x = np.mgrid[0:self.height, 0:self.width].astype(np.float64)
        tr = self.trace(x + 0.5, y + 0.5)
        hit = tr["hit"]
        fp = footprint_shapes(tr["J"])
        shp = (self.height, self.width)
        P, r, phi = (fp[k].to_numpy().reshape(shp) for k in ("P", "r", "phi"))
        ok = (fp["status"] == "ok").to_numpy().reshape(shp)
        pos = tr["x"]
        view = self.position - pos
        view /= np.linalg.norm(view, axis=-1, keepdims=True)
        if self.light["type"] == "point":
            lt = np.asarray(self.light["position"], float) - pos
            lt /= np.linalg.norm(lt, axis=-1, keepdims=True)
        else:
            lt = np.broadcast_to(_unit(self.light["direction"]), pos.shape)
        ns = tr["shading_normal"]
        unlit = (_dot(view, ns) <= 0) | (_dot(lt, ns) <= 0)
        h = view + lt
        h /= np.linalg.norm(h, axis=-1, keepdims=True).clip(1e-300)
        cos_h = np.clip(_dot(h, ns), -1.0, 1.0)
        D = np.where(unlit, 0.0, self.ndf.D(cos_h))
        p_raw = self.R * D / self.ndf.D_normal
        p = np.minimum(p_raw, 1.0)
        n = self.density * np.where(ok & hit, P, 0.0)
        return Geometry(self.width, self.height, hit, tr["uv"], tr["J"], P, r, phi, ok, cos_h, D, p_raw, p,
                        p_raw > 1.0, unlit & hit, n, seconds=time.perf_counter() - t0)


def table1_scenes(directory=None) -> list[Scene]:
    """The five DB23 Table 1 scenes of ``data/scenes/``."""
    d = Path(directory) if directory else SCENES_DIR
    return [load_scene(d / f"{stem}.json") for stem in TABLE1_SCENES]
