"""Glint images of the Table 1 scenes under an area light and an environment map, each method beside the
facet truth lit by the same light, along the scene images' camera path (docs/math/lighting.md#lighting-scene-images).

A distant extended light is one region of directions in world space for every pixel (as the scene images'
directional light is one direction): a :class:`SceneLight` (a cap or a rectangle) or an environment map (on
a plane: in its tangent frame). On a plane every pixel has the same tangent frame, so the light is one region
in it and the exact p of every pixel comes from one grid of views; on a curved surface (the sphere) each
pixel sees the light in its own tangent frame (t, b, n) and cut at its own horizon: the facet truth maps each
facet's mirror direction to world space before the light test, and the exact p rotates the light (or the
map's directions) into the pixel's frame, by cubature per pixel (docs/math/lighting.md#lighting-curved).
A pixel's value is the radiance its facets reflect per facet: the facet truth's sum of the radiance of the
facets whose mirror direction of the view hits the light, over the footprint's n = N |det J| facets; a
counting method's value is the radiance times K / n, K its count at its p; the smooth value is the
radiance times the exact p (the pops' reference level, as D(h) is a point light's).

The method-shader path: :func:`light_rows` packs a frame's GlintInput rows with the light's description
(``light_kind``, ``light_radiance``, ``light_size``, ``light_edge``; docs/math/glint_images.md#glint-contract),
so a user's area-light method shader (``gl.shader_method(..., returns="intensity")`` returning radiance x
K / n) is rendered and tabled beside the facets as the shipped example ``area_light_method.glsl`` is.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api import lights as gl_lights
from ..api.glinty_ndf import Material, angular_slope
from ..api.grids import configured_counter
from ..api.laws import CustomLaw
from ..api.laws import law as make_law
from ..api.lighting import ProbabilityGrid, _split, facet_truth, reflection_probability
from ..api.method_shaders import GLINT_INPUT_FIELDS, cell_values, frame_rows, shader_method
from ..api.spatial import Ellipse
from ..resources import data_path
from .scene import Scene, _unit
from .scene_images import TAU, camera_path, flicker_metrics, frame_inputs, with_directional_light

#: GlintInput's light_kind per light (GLINTLAB_LIGHT_* of glintlab_method_body.h).
LIGHT_KINDS = {"point": 0, "cap": 1, "rect": 2}
#: The counting methods drawn in Python: (label, law, p's method); their uniforms are the shipped shader's.
#: (KK24's LTC is left out: its p costs a fit and a polygon integral per view in Python, minutes per image;
#: its error against the exact p is the section's accuracy table.)
LAW_METHODS = (("binomial (exact p)", "binomial", "exact"), ("gated (exact p)", "gated_shader", "exact"),
               ("gated (point p)", "gated_shader", "point"))
#: The environment map's methods: (label, law, scheme, p's method) (docs/math/lighting.md#lighting-multinomial).
MAP_METHODS = (("binomial chain (exact p)", "binomial", "chain", "exact"),
               ("dual_gated tree (filtered p)", "dual_gated", "tree", "filtered"),
               ("binomial independent (exact p)", "binomial", "independent", "exact"))
#: How the counting methods draw their counts (docs/math/lighting.md#lighting-scene-cells): "db23" splits the
#: footprint's facets over the cells of DB23's anisotropic virtual grids it covers at two LOD levels, each
#: cell's count drawn at the light's p with the cell's own hashed uniforms (the point-light DB23 pipeline's
#: counter, CELL_CONFIG); "texel" draws one count per pixel from the single texel of the footprint's own size
#: (texel_uniforms: rows of pixels share it on a grazing plane, so the images streak and pop; kept to show it).
CELL_SCHEMES = ("db23", "texel")
#: The grid configuration of the "db23" cells: the one the shipped DB23 method shader runs (db23_method_body.h),
#: so that the area-light shader counts on the same cells as its twin.
CELL_CONFIG = "db23_trilinear"


@dataclass(frozen=True)
class SceneLight:
    """A distant extended light in world space: ``kind`` "cap" (``size`` = (half-angle, 0)) or "rect" (a
    rectangle facing the shading point, ``size`` its half-widths at unit distance along ``edge`` and
    direction x edge), ``direction`` the unit vector towards its centre, ``edge`` a unit vector orthogonal to
    it, ``radiance`` constant."""
    kind: str
    direction: tuple
    size: tuple
    edge: tuple
    radiance: float = 1.0

    def in_frame(self, t, b, n) -> gl_lights.Light:
        """The light as ``gl.lights`` describes it in the tangent frame (t, b, n)."""
        rot = np.array([t, b, n], float)
        d, e = rot @ np.asarray(self.direction), rot @ np.asarray(self.edge)
        if self.kind == "cap":
            return gl_lights.cap(d, self.size[0], self.radiance)
        return gl_lights.rect(d, 2 * self.size[0] * e, 2 * self.size[1] * np.cross(d, e), self.radiance)

    def fields(self) -> dict:
        """The GlintInput fields of the light's extent (``pack_inputs`` names)."""
        return {"light_kind": np.uint32(LIGHT_KINDS[self.kind]), "light_radiance": self.radiance,
                "light_size": list(self.size), "light_edge": list(self.edge)}


def scene_light(scene: Scene, kind: str = "cap", size=(0.1, 0.0), radiance: float = 1.0) -> SceneLight:
    """An extended light centred where the scene's light is (its direction from the look-at point), of
    ``kind`` "cap" or "rect" and ``size`` (cap: (half-angle, 0) radians; rect: half-widths at unit
    distance); a rectangle's first axis is horizontal (orthogonal to the world's z and to its direction)."""
    V.choice("kind", kind, ("cap", "rect"))
    sx, sy = (V.real("size", s) for s in size)
    if kind == "cap" and not (0 < sx <= math.pi / 2):
        V.fail("size", size, "(half-angle in (0, pi/2], 0) for a cap")
    if kind == "rect" and not (sx > 0 and sy > 0 and math.isfinite(sx * sy)):
        V.fail("size", size, "two finite half-widths > 0 for a rectangle")
    d = _unit(with_directional_light(scene).light["direction"])
    e = np.cross([0.0, 0.0, 1.0], d) if abs(d[2]) < 0.999 else np.array([1.0, 0.0, 0.0])
    e = _unit(e - (e @ d) * d)
    return SceneLight(kind, tuple(map(float, d)), (sx, sy), tuple(map(float, e)), V.real("radiance", radiance))


def light_rows(inputs, light: SceneLight, seed: int = 0, frame: int = 0):
    """(rows, mask): a frame's GlintInput rows on the pixels of ``inputs.mask`` with the light's extent
    filled in (words 31-37; a point light leaves them 0)."""
    rows, mask = frame_rows(dataclasses.replace(inputs, hit=inputs.mask), seed, frame)
    words = {name: (lo, k) for name, lo, k in GLINT_INPUT_FIELDS}
    for name, value in light.fields().items():
        lo, k = words[name]
        a = np.asarray(value, np.uint32 if name == "light_kind" else np.float32).reshape(k)
        rows[:, lo:lo + k] = a.view(np.uint32)
    return rows, mask


#: The shipped example area-light method shader's file stem (one body, area_light_method_body.h, behind the GLSL
#: and HLSL wrappers): an example of the light-aware contract, not an image method of the registry.
AREA_LIGHT_SHADER = "area_light_method"


def area_light_shader(material: Material, language: str = "glsl", wrong: bool = False):
    """The shipped example area-light method shader (``area_light_method.glsl`` / ``.hlsl``) for
    ``material``; ``wrong`` builds its deliberately wrong variant (p without the light's solid angle)."""
    V.choice("language", language, ("glsl", "hlsl"))
    defines = {"GLINTLAB_DENSITY": float(material.density), "GLINTLAB_ALPHA": float(material.alpha),
               "GLINTLAB_GGX": int(material.target == "ggx"), "GLINTLAB_ANGULAR_RES": 1.0 / float(material.angular_texel)}
    if wrong:
        defines["AREA_LIGHT_BUG_NO_SOLID_ANGLE"] = 1
    return shader_method(data_path("shaders", f"{AREA_LIGHT_SHADER}.{language}"), language=language,
                         name="area_light" + ("_wrong" if wrong else ""), defines=defines, register=False)


def texel_uniforms(uv, J, seed: int, salt: int = 0) -> np.ndarray:
    """The shipped shader's uniforms (m, 3): glintlab_cell_values of the texel of the footprint's own size
    (level floor(-log2 |det J| / 2)) holding uv, for ``seed`` + ``salt``."""
    det = np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    level = np.floor(-0.5 * np.log2(det)).astype(np.int64)
    cell = np.floor(uv * np.exp2(level)[:, None]).astype(np.int64)
    s = np.full(len(uv), (int(seed) + int(salt)) & 0xFFFFFFFF, np.uint32)
    return cell_values(np.column_stack([cell, level]), s).astype(np.float64)


def light_slope(wo, centre, angular_resolution: float) -> np.ndarray:
    """DB23's angular coordinate (m, 2) of the half vector of the views ``wo`` (m, 3) and the light's centre
    ``centre`` (3,) or per view (m, 3) (tangent frame) in texels of 1 / ``angular_resolution``, as the DB23
    pipeline places a point light's half vector: the cells' uniforms change with the angular texel."""
    h = np.asarray(wo, float) + np.atleast_2d(np.asarray(centre, float))
    return np.clip(angular_slope(h / np.linalg.norm(h, axis=-1, keepdims=True)) * angular_resolution, -1e9, 1e9)


def cell_counts(law, density, uv, J, p, slope, seed: int) -> np.ndarray:
    """The count of each pixel's footprint on DB23's cells (CELL_CONFIG): its N |det J| facets split over the
    cells its ellipse covers at two LOD levels, each cell's count drawn by ``law`` (a name or a law) at the
    pixel's ``p`` with the cell's hashed uniforms (``seed``, the angular texel of ``slope``); 0 where the footprint
    is degenerate. The point-light DB23 pipeline's counter, so neighbouring pixels share cells."""
    counts = configured_counter(CELL_CONFIG, law, density).count_image(uv, J, density, p, slope=slope, seed=seed)
    return np.where(counts.status == 0, counts.K, 0.0)


def area_light_twin(uv, J, p, n, radiance, seed: int, slope=None, density=None, cells: str = "db23") -> np.ndarray:
    """The shipped area-light shader's value in float64 from its p: radiance x K / n, K DB23's gated Gaussian
    (``gated_shader``) on the cells (:func:`cell_counts` at ``density`` and ``slope``); ``cells="texel"``: the
    former shader's single-texel count gated(n, p, u)."""
    V.choice("cells", cells, CELL_SCHEMES)
    if cells == "texel":
        k = make_law("gated_shader").evaluate(n, p, texel_uniforms(uv, J, seed)[:, :2])
    else:
        k = cell_counts("gated_shader", density, uv, J, p, slope, seed)
    return radiance * k / n


def _scheme_counts(n, probs, lw, scheme, u):
    """Counts per region (m, k) of n facets over the regions ``probs`` (m, k), drawn as multinomial_counts draws
    them, ``u()`` giving each split's uniforms in turn."""
    m, k = probs.shape
    out = np.zeros((m, k))
    if scheme == "independent":
        for r in range(k):
            out[:, r] = _split(n, np.ones(m), probs[:, r], lw, u())
        return out
    if scheme == "chain":
        n_rem, q_rem = n.copy(), np.ones(m)
        for r in range(k):
            out[:, r] = _split(n_rem, q_rem, probs[:, r], lw, u())
            n_rem, q_rem = n_rem - out[:, r], q_rem - probs[:, r]
        return out
    allp = np.column_stack([probs, np.clip(1 - probs.sum(axis=1), 0, 1)])

    def descend(group, n_group):
        if len(group) == 1:
            if group[0] < k:
                out[:, group[0]] = n_group
            return
        left, right = group[: len(group) // 2], group[len(group) // 2:]
        kl = _split(n_group, allp[:, group].sum(axis=1), allp[:, left].sum(axis=1), lw, u())
        descend(left, kl)
        descend(right, n_group - kl)
    descend(list(range(k + 1)), n.copy())
    return out


def _map_counts(n, probs, law, scheme, uv, J, seed):
    """The "texel" cells: counts per region (m, k) per pixel, each split's uniforms hashed from the pixel's
    texel (one salt per split: the image holds still as the camera moves)."""
    lw = make_law(law)
    salt = iter(range(1, 10_000))
    return _scheme_counts(n, probs, lw, scheme, lambda: texel_uniforms(uv, J, seed, next(salt))[:, :max(lw.n_uniforms, 1)])


def _map_cell_counts(density, probs, law, scheme, uv, J, slope, seed, whole_facets: bool = True):
    """The "db23" cells: counts per region (m, k) per pixel, each cell of :func:`cell_counts` drawing its own
    multinomial over the regions (every split's uniforms from the cell's hash) and the cells' region counts
    summed as the counter sums them. A cell's trial count is fractional (its share of the LOD and ratio
    weights times N x its area): it is rounded to whole facets with one more of the cell's uniforms
    (floor(n + u), mean n), so each cell's multinomial is over whole facets (a chain of conditional binomials
    over a fractional n would clip the counts at the fraction left). The counter carries one p per pixel: it
    carries the pixel's index, coded in [0, 1), by which the cell's law reads the pixel's region
    probabilities; one pass per region, each keeping its region's count of the cell's whole multinomial
    (drawn once per batch of cells and reused by the other passes, which hand the counter's law the same
    cells: keyed by their rows). ``whole_facets=False`` is the deliberately wrong variant for the tests: the
    multinomial over the fractional trial count."""
    lw = make_law(law)
    m, k = probs.shape
    nu = max(lw.n_uniforms, 1)
    code = (np.arange(m) + 0.5) / max(m, 1)
    drawn = {}

    def cells_multinomial(n, p, u):
        key = (n.tobytes(), p.tobytes(), u.tobytes())
        if key not in drawn:
            pixel = np.minimum((p * m).astype(np.int64), m - 1)
            split = iter(range(k + 1))
            whole = np.floor(n + u[:, -1]) if whole_facets else n
            drawn[key] = _scheme_counts(whole, probs[pixel], lw, scheme, lambda: u[:, next(split) * nu:][:, :nu])
        return drawn[key]

    def region_law(r):
        return CustomLaw(lambda n, p, u: cells_multinomial(n, p, u)[:, r], (k + 1) * nu + 1,
                         f"{law} {scheme} region {r} (lighting cells)")
    return np.column_stack([cell_counts(region_law(r), density, uv, J, code, slope, seed) for r in range(k)]) \
        if m else np.zeros((0, k))


@dataclass
class LightPath:
    """Images along the camera path under one light: ``images[name]`` (T, H, W) (the facet truth's under
    "facets"), ``target`` (T, H, W) radiance x the exact p, ``mask`` (T, H, W), ``seconds`` per method,
    ``n`` (T, H, W) the footprints' facets N |det J|, ``grid_error`` the exact p grid's error."""
    scene: str
    light: str
    images: dict
    target: np.ndarray
    mask: np.ndarray
    seconds: dict
    n: np.ndarray | None = None
    grid_error: dict | None = None


def _frame_geometry(inp, material_density, per_pixel: bool = False):
    """(m, frame, wo, uv, J, nf) of one frame's masked pixels: ``frame`` the plane's one tangent frame
    (t, b, n), or with ``per_pixel`` every pixel's (k, 3, 3) (rows t, b, n in world space: a curved
    surface), ``wo`` the unit views in each pixel's frame."""
    m = inp.mask
    v = inp.view[m] / np.linalg.norm(inp.view[m], axis=-1, keepdims=True)
    if per_pixel:
        frames = np.stack([inp.t[m], inp.b[m], inp.n[m]], axis=1)
        wo = np.einsum("kij,kj->ki", frames, v)
    else:
        t, b, n = inp.t[m][0], inp.b[m][0], inp.n[m][0]
        frames = (t, b, n)
        wo = np.column_stack([v @ t, v @ b, v @ n])
    J = inp.J[m]
    nf = material_density * np.abs(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2])
    return m, frames, wo, inp.uv[m], J, nf


#: A pixel is imaged when its footprint's bounding box spans at most this share of the texture's unit square
#: per axis (the facet truth tiles the unit square; on the sphere the pixels at its poles cover every u).
MAX_FOOTPRINT = 0.5


def _narrow_footprints(inp, env: bool = False):
    """``inp`` with the pixels whose footprint's bounding box exceeds MAX_FOOTPRINT per axis left out of its
    mask (the ellipse J {|x| <= 1/sqrt(pi)}: half-widths |(du/dx, du/dy)| / sqrt(pi) and |(dv/dx, dv/dy)| / sqrt(pi)).
    Under a map (``env``) every pixel that sees the surface is kept, whatever the frame's light vector: each sees
    the part of the map above its own horizon."""
    J = inp.J
    width = 2 * np.maximum(np.hypot(J[..., 0], J[..., 2]), np.hypot(J[..., 1], J[..., 3])) / math.sqrt(math.pi)
    mask = inp.mask
    if env:
        det = J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2]
        mask = inp.hit & ((inp.view * inp.n).sum(-1) > 0) & np.isfinite(J).all(-1) & (np.abs(det) > 0)
    return dataclasses.replace(inp, mask=mask & (width <= MAX_FOOTPRINT))


def _world_light(light):
    """A SceneLight as ``gl.lights`` describes it in world space (the frame of the identity)."""
    return light.in_frame(*np.eye(3))


def _exact_p(mat, light, frames, wo, per_pixel: bool, grid, rel_tol: float):
    """The exact p of the masked pixels: per pixel by cubature with each pixel's own light (``per_pixel``),
    else from the path's ProbabilityGrid (one light for every pixel: its error is the path's)."""
    if per_pixel:
        lt = light if isinstance(light, gl_lights.EnvMap) else _world_light(light)
        return reflection_probability(mat.target, mat.alpha, wo, lt, "exact", rel_tol, frames=frames)
    return grid(wo)


def _light_frame(light, mat, side, inp, seed, shaders, k, grid, per_pixel=False, rel_tol=1e-6, renderers=None,
                 cells="db23"):
    """One frame under a SceneLight or an EnvMap: (mask, {name: values on the masked pixels}, target, {name:
    seconds}); a counting method's seconds include its p's (each p computed once, charged to its first user).
    ``renderers``: {name: render(light, wo, uv, J, seed, frames) -> values} (light_path's: the light in the
    tangent frame and frames None, or per pixel the world light and the pixels' frames); ``cells``: how the
    counting methods draw (CELL_SCHEMES).
    ``per_pixel``: every pixel sees the world-space light in its own tangent frame (a curved surface); the facet
    truth maps each facet's mirror direction to world space, the exact p is cubature per pixel at ``rel_tol``."""
    m, frames, wo, uv, J, nf = _frame_geometry(inp, mat.density, per_pixel)
    fps = [Ellipse.from_uv_derivatives(*j) for j in J]
    centres = [tuple(c) for c in np.mod(uv, 1.0)]
    env = isinstance(light, gl_lights.EnvMap)
    lt = light if env else (_world_light(light) if per_pixel else light.in_frame(*frames))
    out, secs, p = {}, {}, {}
    t0 = time.perf_counter()
    out["facets"] = facet_truth(mat.target, mat.alpha, side * side, fps, centres, wo, lt, seed=seed,
                                frames=frames if per_pixel else None).radiance / nf
    secs["facets"] = time.perf_counter() - t0
    # The cells' angular texel: the half vector of the light's centre (the map's: the plane's normal).
    # Per pixel (a curved surface), the world light's centre in each pixel's frame.
    centre = (0.0, 0.0, 1.0) if env else (np.einsum("kij,j->ki", frames, lt.center) if per_pixel else lt.center)
    slope = light_slope(wo, centre, 1.0 / mat.angular_texel)
    for label, law, *rest in (MAP_METHODS if env else LAW_METHODS):
        t0 = time.perf_counter()
        meth = rest[-1]
        if meth not in p:  # the exact p per pixel or from the path's grid (_exact_p)
            p[meth] = np.clip(_exact_p(mat, light, frames, wo, per_pixel, grid, rel_tol) if meth == "exact" else
                              reflection_probability(mat.target, mat.alpha, wo, lt, meth,
                                                     frames=frames if per_pixel else None), 0, 1)
        if env:
            kr = (_map_counts(nf, p[meth], law, rest[0], uv, J, seed) if cells == "texel" else
                  _map_cell_counts(mat.density, p[meth], law, rest[0], uv, J, slope, seed))
            out[label] = kr @ light.region_radiance / nf
        elif cells == "texel":
            lw = make_law(law)
            out[label] = light.radiance * lw.evaluate(nf, p[meth], texel_uniforms(uv, J, seed)[:, :max(lw.n_uniforms, 1)]) / nf
        else:
            out[label] = light.radiance * cell_counts(law, mat.density, uv, J, p[meth], slope, seed) / nf
        secs[label] = time.perf_counter() - t0
    for name, sh in shaders.items():
        t0 = time.perf_counter()
        rows, _ = light_rows(inp, light, seed, k)
        out[name] = np.asarray(sh.shade(rows), float)
        secs[name] = time.perf_counter() - t0
    for name, render in (renderers or {}).items():
        t0 = time.perf_counter()
        out[name] = render(lt, wo, uv, J, seed, frames if per_pixel else None)
        secs[name] = time.perf_counter() - t0
    target = p["exact"] @ light.region_radiance if env else light.radiance * p["exact"]
    return m, out, target, secs, nf


def plane_material(scene: Scene) -> tuple[Material, int]:
    """(material, side): the scene's material with its density rounded to the nearest side^2 (the facet
    truth's stratified layout has one facet per cell of a side x side grid per texture unit)."""
    mat = Material.of(scene)
    side = max(1, round(math.sqrt(mat.density)))
    return dataclasses.replace(mat, density=float(side * side)), side


def light_path(scene: Scene, light, frames: int = 4, pan_px: float = 0.25, zoom: float = 0.99, seed: int = 1,
               shaders=None, label: str | None = None, grid_nodes: int = 17, per_pixel: bool | None = None,
               rel_tol: float = 1e-6, renderers=None, cells: str = "db23",
               grid_tolerance: float | None = 1e-6) -> LightPath:
    """Every method's images of ``scene`` under ``light`` (a :class:`SceneLight` in world space, or an
    environment map from ``gl.lights.envmap``: on a plane in its tangent frame, per pixel in world space) along
    the camera path: the facet truth, the counting laws (``LAW_METHODS``; a map: ``MAP_METHODS``) and ``shaders`` ({name: method
    shader}, rendered with :func:`light_rows`; not for a map, which the contract does not carry).
    ``per_pixel`` (default: on every scene but a plane) lights each pixel by the world-space light seen in
    its own tangent frame: the facet truth with per-footprint frames and the exact p by cubature per pixel at
    ``rel_tol``. Otherwise (a plane: one frame for all pixels) the exact p of every pixel of every frame comes
    from one :class:`~glintlab.api.lighting.ProbabilityGrid` of ``grid_nodes``^2 views (its error against the
    exact p: ``LightPath.grid_error``), refined under an analytic light until its interpolation error is below
    ``grid_tolerance`` (None: ``grid_nodes`` as given). ``renderers``: {name: render(light, wo, uv, J, seed, frames)
    -> value per pixel} rendered beside them (the registered image methods by quadrature over the light:
    :mod:`glintlab.validation.lighting_methods`; on a plane the light in its tangent frame and frames None,
    per pixel the world-space light and the pixels' frames (k, 3, 3)). ``cells``: how the counting methods draw their counts
    (``CELL_SCHEMES``: "db23", DB23's cells; "texel", the single texel)."""
    V.choice("cells", cells, CELL_SCHEMES)
    per_pixel = scene.kind != "plane" if per_pixel is None else bool(per_pixel)
    if not per_pixel and scene.kind != "plane":
        V.fail("per_pixel", per_pixel, "True on a curved surface (its pixels' tangent frames differ)")
    seed = V.seed(seed)
    shaders = dict(shaders or {})
    env = isinstance(light, gl_lights.EnvMap)
    if env and shaders:
        V.fail("shaders", list(shaders), "none under an environment map (the method contract carries analytic lights)")
    if not env and not isinstance(light, SceneLight):
        V.fail("light", light, "a SceneLight (scene_light) or an environment map")
    spec = with_directional_light(scene).spec  # a copy
    # The frame's light vector: the light's centre (the map: the plane's normal, or per pixel the zenith, unused
    # but by the mask, which _narrow_footprints then takes from the view alone), as a directional light's.
    up = (0.0, 0.0, 1.0) if per_pixel else scene.normal
    spec["light"] = {"type": "directional", "direction": [float(x) for x in (up if env else light.direction)]}
    lit = Scene(spec, name=scene.name, source=scene.source)
    mat, side = plane_material(lit)
    shape = (frames, lit.height, lit.width)
    inputs = [frame_inputs(cam) for cam in camera_path(lit, frames, pan_px, zoom)]
    if per_pixel:
        inputs = [_narrow_footprints(inp, env) for inp in inputs]
    grid, grid_error, seconds = None, None, {}
    if not per_pixel:
        t0 = time.perf_counter()
        geo = [_frame_geometry(inp, mat.density) for inp in inputs]
        views = np.concatenate([g[2] for g in geo])
        # Refined until its interpolation error is below grid_tolerance (an analytic light; a map's grid keeps
        # grid_nodes: each of its nodes costs a cubature per region, ~10 ms, so a refinement to 1e-6 costs tens of
        # seconds; its measured error is the path's grid_error all the same).
        grid = ProbabilityGrid(mat.target, mat.alpha, light if env else light.in_frame(*geo[0][1]), views, grid_nodes,
                               tolerance=None if env else grid_tolerance)
        seconds["(exact p grid)"] = time.perf_counter() - t0
        grid_error = grid.error(views, seed=seed)
    images, target, mask, nf = {}, np.zeros(shape), np.zeros(shape, bool), np.zeros(shape)
    for k, inp in enumerate(inputs):
        m, out, tgt, secs, n = _light_frame(light, mat, side, inp, seed, shaders, k, grid, per_pixel, rel_tol,
                                            renderers, cells)
        mask[k], target[k][m], nf[k][m] = m, tgt, n
        for name, values in out.items():
            images.setdefault(name, np.zeros(shape))[k][m] = values
            seconds[name] = seconds.get(name, 0.0) + secs.get(name, 0.0)
    return LightPath(scene.name, label or (f"envmap ({light.regions} regions)" if env else light.kind),
                     images, target, mask, seconds, nf, grid_error)


def light_table(path: LightPath, tau: float = TAU) -> pd.DataFrame:
    """Per method: its flicker against the facet truth lit by the same light (its own truth:
    :func:`~glintlab.validation.scene_images.flicker_metrics`) and its mean and RMS difference against the
    smooth value (radiance x exact p); ``lit_facets`` the radiance-weighted count summed over pixels and
    frames (sum of value x n), ``count_ratio`` it over the facets' and ``expected_ratio`` over its expectation
    at the exact p (sums: a pixel of n < 1 showing one facet weighs as one facet, not as 1 / n);
    ``streak_excess`` the horizontal streaks' measure (:func:`streak_excess`, 0 for the facets)."""
    valid = path.mask.all(axis=0)
    d = path.target[:, valid]
    n = path.n[:, valid]
    facets = float((path.images["facets"][:, valid] * n).sum())
    rows = []
    for name, seq in path.images.items():
        r = flicker_metrics(seq, path.images["facets"], path.target, path.mask, tau)
        x = seq[:, valid]
        rows.append(dict(scene=path.scene, light=path.light, method=name, own_truth="facets (same light)",
                         own_std_ratio=r["std_ratio"], own_pop_rate=r["pop_rate"], own_change_rate=r["change_rate"],
                         own_truth_change_rate=r["truth_change_rate"], own_mean_ratio=r["mean_ratio"],
                         smooth_mean_ratio=float(x.mean() / d.mean()),
                         smooth_rel_rmse=float(np.sqrt(((x - d) ** 2).mean()) / d.mean()),
                         lit_facets=float((x * n).sum()), count_ratio=float((x * n).sum() / facets) if facets > 0 else math.nan,
                         expected_ratio=float((x * n).sum() / (d * n).sum()), streak_excess=streak_excess(path, name),
                         pixels=r["pixels"],
                         frames=r["frames"]))
    return pd.DataFrame(rows)


def horizontal_residual_correlation(path: LightPath, name: str) -> float:
    """The correlation of ``name``'s residual (value - radiance x exact p) between horizontally adjacent pixels,
    pooled over the frames' pixels whose row neighbour is on the plane too. A count drawn once per texel that
    rows of pixels share gives correlations near 1 (horizontal streaks); the facets' own correlation comes
    from their footprints' overlap."""
    r = path.images[name] - path.target
    both = path.mask[:, :, :-1] & path.mask[:, :, 1:]
    a, b = r[:, :, :-1][both], r[:, :, 1:][both]
    a, b = a - a.mean(), b - b.mean()
    den = math.sqrt(float((a * a).sum() * (b * b).sum()))
    return float((a * b).sum() / den) if den > 0 else math.nan


def streak_excess(path: LightPath, name: str) -> float:
    """``name``'s :func:`horizontal_residual_correlation` minus the facets': about 0 when a method's
    neighbouring pixels share their randomness as the facets' overlapping footprints do, large when they
    share one texel's count (streaks)."""
    return horizontal_residual_correlation(path, name) - horizontal_residual_correlation(path, "facets")
