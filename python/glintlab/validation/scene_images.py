"""Glint images of the scenes per method, along a camera path, and their flicker
(docs/math/glint_images.md).

A frame of a scene gives every pixel the three inputs a glinty NDF takes, computed once and shared by
every method (:func:`frame_inputs`): the texture position ``uv`` (H, W, 2), the footprint Jacobian
``J`` (H, W, 4) (du/dx, dv/dx, du/dy, dv/dy) and the half vector ``h`` (H, W, 3) in the surface's
tangent frame, with the mask of pixels that see the lit surface, and the world-space fields a method
shader reads (position, shading frame, view and light vectors, ``GlintInput``). An *image method* is
registered by name in the one registry :data:`IMAGE_METHODS` (``glintlab.api.glinty_ndf``) as a factory
``material -> glinty NDF`` whose ``image(inputs, seed, frame)`` gives one frame's image: for the NDFs
their ``evaluate(uv, J, h, seed)`` on the lit pixels (the NDF term times a constant, no shading model),
for a method shader its own output.
:func:`render_path` renders a camera path of sub-pixel pans and zoom steps (:func:`camera_path`) for
several methods; :func:`flicker_metrics` compares each method's sequence with the ground truth's:
temporal standard deviation and pops.

A new method is one entry: ``register_image_method("name", lambda m: evaluator, label="...", truth=...)``,
with ``m`` the scene's :class:`Material` (density, target NDF, alpha, R, angular texel) and ``truth`` the
kind of its own truth ("facets", "reference", "supersampled"; docs/math/glint_images.md#glint-own-truth);
the entry also says whether the default panel renders it (``panel``, :func:`panel_methods`, read when a
render starts) and the density it runs at (``density``):
:func:`render_path` renders each method's own truth beside it and :func:`flicker_table` reads the
flicker against it (``own_*`` columns) and against the smooth image. :func:`shading` is the microfacet
BRDF's factor that turns an NDF image into the radiance the panels show; :func:`aliasing_table` and
:func:`sparkle_table` measure aliasing against the method's own supersampled image and WB16's claims.
"""
from __future__ import annotations

import copy
import math
import os
import secrets
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.glinty_ndf import (ANGULAR_TEXEL, IMAGE_METHODS, ImageMethod, Material, panel_methods,  # noqa: F401
                              SmoothNDF, image_methods, make_method, register_image_method)
from ..api.method_shaders import ShaderMethod, shader_seed
from .scene import SCENES_DIR, Scene, _unit, load_scene

TAU = 2.0             # a pixel shows a glint when its NDF value exceeds TAU x D(h) (docs/math/glint_images.md#glint-pops)


# --------------------------------------------------------------------------------------------------
# The image methods: one registry, in glintlab.api.glinty_ndf (re-exported here); the default ones are
# ``panel_methods()``, read from the registry when a render starts (a method registered later included).


# --------------------------------------------------------------------------------------------------
# Scenes, lights and camera paths

def with_directional_light(scene: Scene) -> Scene:
    """The scene lit by one directional light: a point light becomes the direction from the camera's
    look-at point towards it; a directional light is kept."""
    spec = copy.deepcopy(scene.spec)
    light = spec["light"]
    if light["type"] == "point":
        d = np.asarray(light["position"], float) - np.asarray(spec["camera"]["look_at"], float)
        spec["light"] = {"type": "directional", "direction": [float(x) for x in _unit(d)]}
    return Scene(spec, name=scene.name, source=scene.source)


def with_density(scene: Scene, factor: float) -> Scene:
    """The scene with its facet density N multiplied by ``factor`` (sparser glints below 1)."""
    factor = V.real("density_factor", factor)
    if not (math.isfinite(factor) and factor > 0):
        V.fail("density_factor", factor, "a finite factor > 0")
    spec = copy.deepcopy(scene.spec)
    spec["material"]["density"] *= factor
    return Scene(spec, name=scene.name, source=scene.source)


def camera_path(scene: Scene, frames: int, pan_px: float = 0.25, zoom: float = 0.99) -> list[Scene]:
    """``frames`` cameras: the first half pans by ``pan_px`` pixel per frame (sub-pixel steps, along the
    image's x axis, measured at the look-at distance), the second half then moves the camera towards
    its look-at point by the factor ``zoom`` per frame (a dolly: footprints shrink, the LOD moves).
    :func:`camera_at` builds one of them alone."""
    return [camera_at(scene, frames, k, pan_px, zoom) for k in range(V.integer("frames", frames, minimum=2))]


def camera_at(scene: Scene, frames: int, frame: int, pan_px: float = 0.25, zoom: float = 0.99) -> Scene:
    """Camera ``frame`` of :func:`camera_path` (the same scene, bit for bit), without building the others:
    a path of any length costs one camera per frame rendered."""
    frames = V.integer("frames", frames, minimum=2)
    k = V.integer("frame", frame, 0, frames - 1, expected=f"an integer in [0, {frames - 1}] (frames = {frames})")
    pan_px, zoom = V.real("pan_px", pan_px), V.real("zoom", zoom)
    if not (math.isfinite(pan_px) and abs(pan_px) <= 8):
        V.fail("pan_px", pan_px, "a number of pixels in [-8, 8]")
    if not (0.5 <= zoom <= 2 and zoom != 0):
        V.fail("zoom", zoom, "a factor in [0.5, 2]")
    cam = scene.spec["camera"]
    pos, look = np.asarray(cam["position"], float), np.asarray(cam["look_at"], float)
    step = pan_px * np.linalg.norm(look - pos) / scene.focal * scene.right
    pans = frames // 2
    spec = copy.deepcopy(scene.spec)
    shift = step * min(k, pans)
    p, lk = pos + shift, look + shift
    if k > pans:
        p = lk + (p - lk) * zoom ** (k - pans)
        if not np.linalg.norm(p - lk) > 1e-9 * np.linalg.norm(look - pos):  # zoom^(k - pans) underflowed
            V.fail("frame", frame, f"a frame whose camera has not reached its look-at point (zoom {zoom:g} per frame "
                                   f"over {k - pans} zoom steps leaves {zoom ** (k - pans):.3g} of the distance)")
    spec["camera"]["position"], spec["camera"]["look_at"] = [float(x) for x in p], [float(x) for x in lk]
    return Scene(spec, name=scene.name, source=scene.source)


@dataclass
class FrameInputs:
    """The per-pixel inputs of one frame, shared by every method: ``uv`` (H, W, 2), ``J`` (H, W, 4), ``h``
    (H, W, 3) in the tangent frame (x along u, z the shading normal), and ``mask`` (H, W): the pixel
    sees the surface, its footprint is not degenerate, and light and camera are above the horizon."""
    uv: np.ndarray
    J: np.ndarray
    h: np.ndarray
    mask: np.ndarray
    seconds: float = 0.0
    # World-space fields of a method shader's GlintInput (docs/math/glint_images.md#glint-contract):
    # hit (H, W) the ray meets the surface; world_pos, n, t, b (shading frame), view (unnormalised,
    # surface to camera), light (unit, surface to light), h_world (unit half vector), each (H, W, 3).
    hit: np.ndarray | None = None
    world_pos: np.ndarray | None = None
    n: np.ndarray | None = None
    t: np.ndarray | None = None
    b: np.ndarray | None = None
    view: np.ndarray | None = None
    light: np.ndarray | None = None
    h_world: np.ndarray | None = None
    # For sub-pixel samples (subpixel_inputs): the hit point's derivatives along the pixel axes (H, W, 3)
    # and the camera's position (3,).
    dxdpx: np.ndarray | None = None
    dxdpy: np.ndarray | None = None
    camera: np.ndarray | None = None


def _tangent_frame(scene: Scene, tr) -> tuple:
    """(t, b, n) per pixel: t along the u axis (d x / d u projected on the shading plane), n the shading
    normal, b = n x t."""
    n = tr["shading_normal"]
    if scene.kind == "sphere":
        q = tr["x"] - scene.center
        t = np.stack([-q[..., 1], q[..., 0], np.zeros(q.shape[:-1])], axis=-1)
    else:
        t = np.broadcast_to(scene.e1, n.shape).copy()
    t = t - (t * n).sum(-1, keepdims=True) * n
    norm = np.linalg.norm(t, axis=-1, keepdims=True)
    t = np.where(norm > 1e-12, t / np.where(norm > 0, norm, 1.0), 0.0)
    # Degenerate at a pole: any tangent will do.
    bad = norm[..., 0] <= 1e-12
    if bad.any():
        ref = np.where(np.abs(n[bad][:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
        tb = ref - (ref * n[bad]).sum(-1, keepdims=True) * n[bad]
        t[bad] = tb / np.linalg.norm(tb, axis=-1, keepdims=True)
    return t, np.cross(n, t), n


def frame_inputs(scene: Scene) -> FrameInputs:
    """uv, J, h (tangent frame) and the mask of one frame of ``scene`` (pixel centres)."""
    t0 = time.perf_counter()
    y, x = np.mgrid[0:scene.height, 0:scene.width].astype(np.float64)
    tr = scene.trace(x + 0.5, y + 0.5)
    pos = tr["x"]
    view_raw = scene.position - pos
    view = view_raw / np.linalg.norm(view_raw, axis=-1, keepdims=True)
    light = scene.light
    if light["type"] == "point":
        lt = np.asarray(light["position"], float) - pos
        lt /= np.linalg.norm(lt, axis=-1, keepdims=True)
    else:
        lt = np.broadcast_to(_unit(light["direction"]), pos.shape)
    h = view + lt
    h /= np.linalg.norm(h, axis=-1, keepdims=True).clip(1e-300)
    tb, bb, nb = _tangent_frame(scene, tr)
    hl = np.stack([(h * tb).sum(-1), (h * bb).sum(-1), (h * nb).sum(-1)], axis=-1)
    J = tr["J"]
    det = J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2]
    lit = ((view * nb).sum(-1) > 0) & ((lt * nb).sum(-1) > 0) & (hl[..., 2] > 0)
    mask = tr["hit"] & lit & np.isfinite(J).all(-1) & (np.abs(det) > 0)
    hl = np.where(mask[..., None], hl, np.array([0.0, 0.0, 1.0]))
    return FrameInputs(tr["uv"], J, hl, mask, time.perf_counter() - t0, hit=tr["hit"], world_pos=pos, n=nb, t=tb,
                       b=bb, view=view_raw, light=np.ascontiguousarray(lt), h_world=h, dxdpx=tr["dxdpx"],
                       dxdpy=tr["dxdpy"], camera=np.asarray(scene.position, float))


def render(method, inputs: FrameInputs, seed: int = 0, frame: int = 0) -> np.ndarray:
    """One method's image (H, W) of one frame: ``method.image`` (a glinty NDF: its ``evaluate`` on the
    masked pixels, 0 elsewhere; a method shader: its output where the surface is hit). An evaluator
    that is not a :class:`GlintyNDF` (only ``evaluate``) is rendered as the NDFs are."""
    if hasattr(method, "image"):
        return method.image(inputs, seed=seed, frame=frame)
    img = np.zeros(inputs.mask.shape)
    m = inputs.mask
    if m.any():
        img[m] = method.evaluate(inputs.uv[m], inputs.J[m], inputs.h[m], seed=seed)
    return img


def resolve_scene(scene) -> Scene:
    """A :class:`Scene` from what a user names a scene by, the one resolution of ``gl.render`` and
    ``glintlab images``: a Scene; a path to a scene file; a shipped scene's name ("sphere", "plane_25",
    ...: ``data/scenes/<name>.json``) when no file of that name exists; or the JSON document (text or
    dict). A name that is neither a file nor a shipped scene is refused listing the shipped ones."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, os.PathLike)) and not (isinstance(scene, str) and ("\n" in scene or "{" in scene)):
        path = Path(scene)
        if not path.exists():
            shipped = sorted(f.stem for f in Path(SCENES_DIR).glob("*.json"))
            if str(scene) in shipped:
                return load_scene(Path(SCENES_DIR) / f"{scene}.json")
            V.fail("scene", str(scene), f"a scene file or a shipped scene's name ({', '.join(shipped)}); no file "
                                        "of that name exists")
    return load_scene(scene)


_scene_of = resolve_scene  # the name method_twins and older callers use


def render_image(method, scene, frame: int = 0, seed: int = 0, scale: float = 1.0, frames: int = 8,
                 directional: bool = True) -> np.ndarray:
    """``gl.render(method, scene, frame=0, seed=0, scale=1.0)``: one image method's image of frame
    ``frame`` of the scene's camera path (:func:`camera_path` with ``frames`` frames, the scene lit by one
    directional light unless ``directional`` is False), at ``scale`` times the resolution per side
    (density scaled to keep the facets per pixel). ``method``: an image method's name
    (``image_methods()``), or a glinty NDF / method shader object; ``scene``: a :class:`Scene`, a
    shipped scene's name ("sphere", "plane_25", ...), a path or a JSON document. Returns (rows, columns)
    or (rows, columns, 3) for a colour method shader; NaN where no surface is hit. Only the rendered
    frame's camera is built (:func:`camera_at`), whatever ``frames``. A method shader takes seeds below
    2^32 (GlintInput's seed is one 32-bit word) and refuses larger ones; ``seed=None`` draws one below
    2^32 from the operating system."""
    scene = resolve_scene(scene)
    V.integer("frames", frames, minimum=1)
    V.integer("frame", frame, 0, frames - 1, expected=f"an integer in [0, {frames - 1}] (frames = {frames})")
    seed = secrets.randbits(32) if seed is None else V.seed(seed)
    if scale != 1.0:
        scene = scene.scaled(scale, keep_n=True)
    if directional:
        scene = with_directional_light(scene)
    if isinstance(method, str):
        evaluator = make_method(method, Material.of(scene))
    elif isinstance(method, ImageMethod):
        evaluator = method.factory(Material.of(scene))
    elif hasattr(method, "image") or hasattr(method, "evaluate"):
        evaluator = method
    else:
        V.fail("method", method, "an image method's name, an ImageMethod or a glinty NDF / method shader")
    cam = camera_at(scene, max(int(frames), 2), int(frame))
    inp = frame_inputs(cam)
    img = render(evaluator, inp, seed, frame=int(frame)).astype(np.float64)
    miss = ~inp.hit
    img[miss] = np.nan
    return img


@dataclass
class PathImages:
    """Images of one scene along a camera path: ``images[method]`` (T, H, W), ``target`` (T, H, W) the
    smooth D(h) (the pops' reference level), ``mask`` (T, H, W), seconds per method (all frames) and
    for the per-frame inputs; ``truths[method]`` (T, H, W) each method's own truth
    (:func:`truth_kind`; the facet truth's array itself where that is the method's truth),
    ``shade`` (T, H, W) the BRDF's factor F G / (4 cos_o) per pixel (:func:`shading`), so that
    ``images[m] * shade`` is the radiance under the scene's light for an NDF method."""
    scene: str
    images: dict
    target: np.ndarray
    mask: np.ndarray
    seconds: dict
    input_seconds: float
    material: Material
    truths: dict | None = None
    shade: np.ndarray | None = None
    truth_seconds: float = 0.0


#: Sub-pixels per side of a "supersampled" truth and of the aliasing tables (docs/math/glint_images.md#glint-aliasing).
SUPERSAMPLE = 4


def truth_kind(name: str) -> str:
    """The kind of image method ``name``'s own truth (``register_image_method(..., truth=...)``):
    "self" (it is the facet ground truth), "facets", "reference" (its evaluator's ``reference`` on the
    same realization) or "supersampled" (the same method averaged over SUPERSAMPLE^2 sub-pixels)."""
    return IMAGE_METHODS.get(name).truth


def subpixel_inputs(inputs: FrameInputs, ox: float, oy: float, n: int) -> FrameInputs:
    """The inputs of one of the n x n sub-pixels of every pixel, at offset (ox, oy) pixels from the
    centre: the hit point moved along the tangent plane (x + ox dx/dpx + oy dx/dpy), uv + J (ox, oy)
    (first order, DB23's footprint Jacobian), the footprint J / n (the sub-pixel's), the view and half
    vectors recomputed from the moved point, the shading frame and the light kept (first order);
    the pixel's mask, less sub-pixels whose h or view falls below the horizon."""
    if inputs.dxdpx is None or inputs.camera is None:
        V.fail("inputs", "frame inputs without ray differentials", "FrameInputs from frame_inputs(scene)")
    J = inputs.J
    pos = inputs.world_pos + ox * inputs.dxdpx + oy * inputs.dxdpy
    uv = inputs.uv + np.stack([J[..., 0] * ox + J[..., 2] * oy, J[..., 1] * ox + J[..., 3] * oy], axis=-1)
    view_raw = inputs.camera - pos
    view = view_raw / np.linalg.norm(view_raw, axis=-1, keepdims=True).clip(1e-300)
    h = view + inputs.light
    h /= np.linalg.norm(h, axis=-1, keepdims=True).clip(1e-300)
    hl = np.stack([(h * inputs.t).sum(-1), (h * inputs.b).sum(-1), (h * inputs.n).sum(-1)], axis=-1)
    mask = inputs.mask & (hl[..., 2] > 0) & ((view * inputs.n).sum(-1) > 0)
    hl = np.where(mask[..., None], hl, np.array([0.0, 0.0, 1.0]))
    return FrameInputs(uv, J / n, hl, mask, 0.0, hit=inputs.hit, world_pos=pos, n=inputs.n, t=inputs.t, b=inputs.b,
                       view=view_raw, light=inputs.light, h_world=h, dxdpx=inputs.dxdpx / n, dxdpy=inputs.dxdpy / n,
                       camera=inputs.camera)


def supersampled(method, inputs: FrameInputs, seed: int = 0, frame: int = 0, n: int = SUPERSAMPLE) -> np.ndarray:
    """``method``'s image of one frame box-filtered over each pixel: the mean of its n x n sub-pixel
    images (:func:`subpixel_inputs`, offsets ((i + 1/2) / n - 1/2) pixels), 0 outside the pixel mask."""
    n = V.integer("n", n, 1, 64, expected="an integer number of sub-pixels per side in [1, 64]")
    acc = None
    offs = (np.arange(n) + 0.5) / n - 0.5
    for oy in offs:
        for ox in offs:
            img = render(method, subpixel_inputs(inputs, float(ox), float(oy), int(n)), seed, frame=frame)
            acc = img if acc is None else acc + img
    out = acc / (n * n)
    out[~inputs.mask] = 0
    return out


def reference_image(method, inputs: FrameInputs, seed: int = 0) -> np.ndarray:
    """The method's exact model on the same realization: its ``reference(uv, J, h, seed)`` on the lit
    pixels (KPT25: the sum over every point; WWH18: the discrete-flake count), 0 elsewhere."""
    img = np.zeros(inputs.mask.shape)
    m = inputs.mask
    if m.any():
        img[m] = method.reference(inputs.uv[m], inputs.J[m], inputs.h[m], seed=seed)
    return img


F0 = 0.04  # Schlick's reflectance at normal incidence (a dielectric coat; docs/math/glint_images.md#glint-shading)


def smith_lambda(target: str, alpha: float, cos_theta) -> np.ndarray:
    """Smith's Lambda of the target NDF for directions at cos_theta from the normal (Beckmann: with
    a = 1 / (alpha tan), (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)); GGX: (sqrt(1 + alpha^2 tan^2) - 1) / 2)."""
    from scipy.special import erf
    c = np.clip(np.asarray(cos_theta, float), 1e-9, 1.0)
    tan2 = np.maximum(1.0 - c * c, 0.0) / (c * c)
    if target == "ggx":
        return 0.5 * (np.sqrt(1.0 + alpha * alpha * tan2) - 1.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a = 1.0 / (alpha * np.sqrt(tan2))
        lam = 0.5 * (erf(a) - 1.0) + np.exp(-a * a) / (2.0 * a * math.sqrt(math.pi))
    return np.where(np.isfinite(a), lam, 0.0)


def shading(inputs: FrameInputs, material: Material, f0: float = F0) -> np.ndarray:
    """The microfacet BRDF's factor F G / (4 cos_o) per pixel (H, W) (0 outside the mask): under a
    directional light of unit irradiance the radiance is L = f cos_i = D F G / (4 cos_o) with
    f = D F G / (4 cos_i cos_o), Schlick's F(v.h) with F0 = ``f0`` and the height-correlated Smith
    G = 1 / (1 + Lambda(o) + Lambda(i)) of the target NDF (docs/math/glint_images.md#glint-shading).
    An NDF method's radiance is its image times this factor; the smooth render is D(h) times it."""
    if inputs.view is None:
        V.fail("inputs", "frame inputs without world-space fields", "FrameInputs from frame_inputs(scene)")
    m = inputs.mask
    out = np.zeros(m.shape)
    if not m.any():
        return out
    v = inputs.view[m]
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    n, lt, h = inputs.n[m], inputs.light[m], inputs.h_world[m]
    co, ci = (v * n).sum(-1), (lt * n).sum(-1)
    vh = np.clip((v * h).sum(-1), 0.0, 1.0)
    F = f0 + (1.0 - f0) * (1.0 - vh) ** 5
    lam_o, lam_i = (smith_lambda(material.target, material.alpha, c) for c in (co, ci))
    G = 1.0 / (1.0 + lam_o + lam_i)
    out[m] = F * G / (4.0 * np.clip(co, 1e-9, None))
    return out


def _path_setup(scene: Scene, methods, seed, angular_texel: float, directional: bool):
    """What every render along a camera path starts with: the checked seed and method names, the scene
    (under one directional light unless ``directional`` is False), its material and the methods'
    evaluators. Returns (seed, scene, material, {name: evaluator})."""
    seed = V.seed(seed)
    methods = panel_methods() if methods is None else methods
    if isinstance(methods, str) or not len(methods):
        V.fail("methods", methods, "a non-empty list of image method names")
    for name in methods:
        IMAGE_METHODS.get(name)
    if directional:
        scene = with_directional_light(scene)
    mat = Material.of(scene, angular_texel)
    evaluators = {name: make_method(name, mat) for name in methods}
    for name, ev in evaluators.items():  # GlintInput's seed is 32 bits: refused before any frame is rendered
        if isinstance(ev, ShaderMethod):
            shader_seed(seed, f"method shader {name!r}")
    return seed, scene, mat, evaluators


def render_path(scene: Scene, methods=None, frames: int = 8, pan_px: float = 0.25, zoom: float = 0.99,
                seed: int = 1, angular_texel: float = ANGULAR_TEXEL, directional: bool = True,
                own_truths: bool = True, supersample: int = SUPERSAMPLE) -> PathImages:
    """Every method's images of ``scene`` along :func:`camera_path` (one directional light unless
    ``directional`` is False). The inputs of each frame are computed once and shared. With
    ``own_truths`` each method's own truth is rendered too (``PathImages.truths``, :func:`truth_kind`;
    "supersampled" with ``supersample`` x ``supersample`` sub-pixels). ``methods``: default the panel's
    (``panel_methods()``)."""
    seed, scene, mat, evaluators = _path_setup(scene, methods, seed, angular_texel, directional)
    methods = list(evaluators)
    smooth = SmoothNDF(mat.target, mat.alpha)
    path = camera_path(scene, frames, pan_px, zoom)
    shape = (frames, scene.height, scene.width)
    images = {name: np.zeros(shape) for name in methods}
    target, mask, shade = np.zeros(shape), np.zeros(shape, bool), np.zeros(shape)
    seconds = dict.fromkeys(methods, 0.0)
    kinds = {name: truth_kind(name) for name in methods} if own_truths else {}
    extra = {name: np.zeros(shape) for name, k in kinds.items() if k in ("reference", "supersampled")}
    need_facets = any(k == "facets" for k in kinds.values()) and "truth" not in methods
    facet_seq = np.zeros(shape) if need_facets else None
    facet_ev = make_method("truth", mat) if need_facets else None
    t_in = t_truth = 0.0
    for k, cam in enumerate(path):
        inp = frame_inputs(cam)
        t_in += inp.seconds
        mask[k] = inp.mask
        target[k] = render(smooth, inp)
        shade[k] = shading(inp, mat)
        for name, ev in evaluators.items():
            t0 = time.perf_counter()
            images[name][k] = render(ev, inp, seed, frame=k)
            seconds[name] += time.perf_counter() - t0
        t0 = time.perf_counter()
        if need_facets:
            facet_seq[k] = render(facet_ev, inp, seed, frame=k)
        for name, seq in extra.items():
            if kinds[name] == "reference":
                seq[k] = reference_image(evaluators[name], inp, seed)
            else:
                seq[k] = supersampled(evaluators[name], inp, seed, frame=k, n=supersample)
        t_truth += time.perf_counter() - t0
    truths = None
    if own_truths:
        facets = images["truth"] if "truth" in images else facet_seq
        truths = {name: (images[name] if k == "self" else facets if k == "facets" else extra[name])
                  for name, k in kinds.items()}
    return PathImages(scene.name, images, target, mask, seconds, t_in, mat, truths, shade, t_truth)


def time_methods(scene: Scene, methods=None, seed: int = 1, angular_texel: float = ANGULAR_TEXEL,
                 repeats: int = 1) -> pd.DataFrame:
    """Seconds per image of each method on the first frame of ``scene`` at its own resolution (best of
    ``repeats``), with the shared per-frame inputs timed once. ``methods``: default the panel's."""
    methods = panel_methods() if methods is None else methods
    scene = with_directional_light(scene)
    mat = Material.of(scene, angular_texel)
    inp = frame_inputs(scene)
    rows = [{"scene": scene.name, "method": "(inputs uv, J, h)", "width": scene.width, "height": scene.height,
             "seconds": inp.seconds, "pixels": int(inp.mask.sum())}]
    for name in methods:
        ev = make_method(name, mat)
        best = math.inf
        for _ in range(max(int(repeats), 1)):
            t0 = time.perf_counter()
            render(ev, inp, seed)
            best = min(best, time.perf_counter() - t0)
        rows.append({"scene": scene.name, "method": name, "width": scene.width, "height": scene.height,
                     "seconds": best, "pixels": int(inp.mask.sum())})
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------------------
# Flicker

def _dilate(a: np.ndarray, radius: int) -> np.ndarray:
    """Boolean (T, H, W) maps grown by ``radius`` pixels (square neighbourhood) in the image plane."""
    if radius == 0:
        return a
    out = a.copy()
    H, W = a.shape[-2:]
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            src = a[..., max(0, -dy):H - max(0, dy), max(0, -dx):W - max(0, dx)]
            out[..., max(0, dy):H - max(0, -dy), max(0, dx):W - max(0, -dx)] |= src
    return out


def glint_mask(images: np.ndarray, target: np.ndarray, tau: float = TAU) -> np.ndarray:
    """Where a pixel shows a glint: its NDF value exceeds ``tau`` times the smooth D(h) there."""
    return images > tau * target


def flicker_metrics(images, truth, target, mask=None, tau: float = TAU, radius: int = 0) -> dict:
    """Flicker of one method's sequence ``images`` (T, H, W) against the ground truth's ``truth`` on the
    same path (docs/math/glint_images.md#glint-flicker), over the pixels valid in every frame:

    - ``std_ratio``: the mean over pixels of the temporal standard deviation of the method's value,
      over the same mean for the truth (1: flickers as much as the truth);
    - ``pop_rate``: the share of (pixel, consecutive frame pair) where the pixel's glint state
      (:func:`glint_mask`) changes in the method's sequence and not in the truth's within ``radius``
      pixels (a glint appearing or disappearing with no cause in the truth), with ``appear_rate`` and
      ``disappear_rate`` its two directions;
    - ``change_rate`` and ``truth_change_rate``: glint state changes of the method and of the truth.
    """
    images, truth, target = (np.asarray(V.as_float_array(n, a)) for n, a in
                             (("images", images), ("truth", truth), ("target", target)))
    if images.ndim != 3 or images.shape[0] < 2:
        V.fail("images", f"an array of shape {images.shape}", "an array of shape (T, H, W), T >= 2")
    for name, a in (("truth", truth), ("target", target)):
        if a.shape != images.shape:
            V.fail(name, f"an array of shape {a.shape}", f"an array of shape {images.shape}")
    tau = V.real("tau", tau)
    if not (math.isfinite(tau) and tau > 0):
        V.fail("tau", tau, "a finite number > 0")
    V.integer("radius", radius, 0, 16)
    valid = np.ones(images.shape[1:], bool) if mask is None else np.asarray(mask, bool).all(axis=0) \
        if np.ndim(mask) == 3 else np.asarray(mask, bool)
    if valid.shape != images.shape[1:]:
        V.fail("mask", f"an array of shape {np.shape(mask)}", f"an array of shape {images.shape} or {images.shape[1:]}")
    pixels = int(valid.sum())
    if pixels == 0:
        V.fail("mask", "no valid pixel", "at least one pixel valid in every frame")
    s_m = images.std(axis=0)[valid].mean()
    s_t = truth.std(axis=0)[valid].mean()
    lit_m, lit_t = glint_mask(images, target, tau), glint_mask(truth, target, tau)
    ch_m = lit_m[1:] != lit_m[:-1]
    ch_t = _dilate(lit_t[1:] != lit_t[:-1], int(radius))
    pop = ch_m & ~ch_t & valid
    pairs = pixels * (images.shape[0] - 1)
    appear = pop & lit_m[1:]
    return {"std": float(s_m), "truth_std": float(s_t),
            "std_ratio": float(s_m / s_t) if s_t > 0 else (math.inf if s_m > 0 else 1.0),
            "pop_rate": float(pop.sum() / pairs), "appear_rate": float(appear.sum() / pairs),
            "disappear_rate": float((pop & ~lit_m[1:]).sum() / pairs),
            "change_rate": float((ch_m & valid).sum() / pairs),
            "truth_change_rate": float(((lit_t[1:] != lit_t[:-1]) & valid).sum() / pairs),
            "glint_share": float(lit_m[:, valid].mean()), "truth_glint_share": float(lit_t[:, valid].mean()),
            "mean_ratio": float(images[:, valid].mean() / truth[:, valid].mean()) if truth[:, valid].mean() > 0
            else math.nan, "pixels": pixels, "frames": int(images.shape[0])}


def flicker_table(path: PathImages, truth: str = "truth", tau: float = TAU, radius: int = 0) -> pd.DataFrame:
    """:func:`flicker_metrics` of every method of ``path`` against its ``truth`` method, one row each;
    ``pop_rate_wider`` is the pop rate with a truth change within ``radius + 1`` pixels as a cause."""
    if truth not in path.images:
        V.fail("truth", truth, f"one of the rendered methods: {', '.join(path.images)}")
    frames = path.target.shape[0]
    rows = []
    for name, seq in path.images.items():
        r = flicker_metrics(seq, path.images[truth], path.target, path.mask, tau, radius)
        near = flicker_metrics(seq, path.images[truth], path.target, path.mask, tau, radius + 1)
        row = {"scene": path.scene, "method": name, "label": IMAGE_METHODS.get(name).label
               if name in IMAGE_METHODS else name, **r, "pop_rate_wider": near["pop_rate"],
               "seconds_per_frame": path.seconds[name] / frames}
        if path.truths is not None and name in path.truths:
            row.update(own_truth_metrics(name, seq, path.truths[name], path.target, path.mask, tau, radius))
        rows.append(row)
    return pd.DataFrame(rows)


#: An intensity method (WB16's sparkles in [0, 1]) shows a glint where its value exceeds this level:
#: there is no D(h) to compare it with (docs/math/glint_images.md#glint-own-truth).
INTENSITY_GLINT_LEVEL = 0.5


def own_truth_metrics(name: str, images, truth, target, mask, tau: float = TAU, radius: int = 0) -> dict:
    """The flicker of method ``name`` against its own truth (:func:`truth_kind`): ``own_truth`` (the
    kind), ``own_std_ratio``, ``own_pop_rate`` and ``own_truth_change_rate`` (:func:`flicker_metrics`
    with the own truth in place of the facets; an intensity method's glints are its values above
    ``INTENSITY_GLINT_LEVEL``), and against the smooth image D(h) (NDF methods only, NaN for an
    intensity): ``smooth_mean_ratio`` (mean / the smooth mean) and ``smooth_rel_rmse`` (RMS of the
    difference / the smooth mean), over the pixels valid in every frame."""
    entry = IMAGE_METHODS.get(name)
    intensity = entry.returns == "intensity"
    level = np.full(np.shape(target), INTENSITY_GLINT_LEVEL / tau) if intensity else target
    r = flicker_metrics(images, truth, level, mask, tau, radius)
    out = {"own_truth": entry.truth, "own_std_ratio": r["std_ratio"], "own_pop_rate": r["pop_rate"],
           "own_truth_change_rate": r["truth_change_rate"], "own_mean_ratio": r["mean_ratio"]}
    valid = np.asarray(mask, bool).all(axis=0) if np.ndim(mask) == 3 else np.asarray(mask, bool)
    x, d = np.asarray(images)[:, valid], np.asarray(target)[:, valid]
    if intensity or d.mean() <= 0:
        out["smooth_mean_ratio"] = out["smooth_rel_rmse"] = math.nan
    else:
        out["smooth_mean_ratio"] = float(x.mean() / d.mean())
        out["smooth_rel_rmse"] = float(np.sqrt(((x - d) ** 2).mean()) / d.mean())
    return out


def display(images: np.ndarray, material: Material, white: float = 2.0, gamma: float = 2.2) -> np.ndarray:
    """Images (NDF values) as display values in [0, 1]: (value / (white D(n)))^(1 / gamma), clipped."""
    d_n = 1.0 / (math.pi * material.alpha**2)
    return np.clip(np.asarray(images) / (white * d_n), 0.0, 1.0) ** (1.0 / gamma)


# --------------------------------------------------------------------------------------------------
# Aliasing: each method's 1-sample image against its own supersampled image

def aliasing_table(scene: Scene, methods, frames: int = 4, n: int = SUPERSAMPLE, pan_px: float = 0.25,
                   zoom: float = 0.99, seed: int = 1, angular_texel: float = ANGULAR_TEXEL,
                   directional: bool = True) -> pd.DataFrame:
    """Per method, its 1-sample image (one evaluation at the pixel centre with the pixel's footprint)
    against its own image box-filtered over n x n sub-pixels (:func:`supersampled`) along the camera
    path (docs/math/glint_images.md#glint-aliasing), over the pixels valid in every frame:
    ``alias_rel_rmse`` (RMS of the difference over the supersampled mean, the mean over frames) and
    ``alias_rel_rmse_spread`` (its standard deviation over frames), ``std_ratio_vs_supersampled`` (the
    mean temporal standard deviation of the 1-sample sequence over the supersampled one's: aliasing
    shows as flicker the filtered image does not have), and ``seconds`` (both renders, all frames)."""
    seed, scene, mat, evaluators = _path_setup(scene, methods, seed, angular_texel, directional)
    path = camera_path(scene, frames, pan_px, zoom)
    one = {name: [] for name in methods}
    ss = {name: [] for name in methods}
    secs = dict.fromkeys(methods, 0.0)
    masks = []
    for k, cam in enumerate(path):
        inp = frame_inputs(cam)
        masks.append(inp.mask)
        for name, ev in evaluators.items():
            t0 = time.perf_counter()
            one[name].append(render(ev, inp, seed, frame=k))
            ss[name].append(supersampled(ev, inp, seed, frame=k, n=n))
            secs[name] += time.perf_counter() - t0
    valid = np.all(masks, axis=0)
    rows = []
    for name in methods:
        # A method shader may return NaN at a few pixels (WB16's unguarded normalisations, as printed):
        # those pixels are left out of that method's row.
        A, B = np.asarray(one[name]), np.asarray(ss[name])
        ok = valid & np.isfinite(A).all(axis=0) & np.isfinite(B).all(axis=0)
        a, b = A[:, ok], B[:, ok]
        scale = b.mean() if b.size and b.mean() > 0 else math.nan
        err = np.sqrt(((a - b) ** 2).mean(axis=1)) / scale if a.size else np.full(len(path), math.nan)
        s1, s2 = a.std(axis=0).mean(), b.std(axis=0).mean()
        rows.append({"scene": scene.name, "method": name, "label": IMAGE_METHODS.get(name).label,
                     "returns": IMAGE_METHODS.get(name).returns, "supersample": f"{n}x{n}",
                     "alias_rel_rmse": float(np.mean(err)), "alias_rel_rmse_spread": float(np.std(err)),
                     "std_ratio_vs_supersampled": float(s1 / s2) if s2 > 0 else math.nan,
                     "mean_ratio_vs_supersampled": float(a.mean() / scale) if scale == scale else math.nan,
                     "pixels": int(ok.sum()), "frames": len(path), "seconds": secs[name]})
    return pd.DataFrame(rows)


def sparkle_table(scene: Scene, method: str = "wb16", bins: int = 4, seed: int = 1, level: float = 0.0,
                  directional: bool = True) -> pd.DataFrame:
    """WB16's claims of density against depth and of sparkle size, on one frame of ``scene``: the
    sparkles are the 8-connected components of pixels whose value exceeds ``level``; per bin of the
    distance to the camera (``bins`` quantile bins of the hit pixels), the sparkles per 1000 pixels
    (a component counted in the bin of its brightest pixel) and their mean and 90th-percentile size
    in pixels (docs/math/glint_images.md#glint-aliasing)."""
    from scipy import ndimage
    if directional:
        scene = with_directional_light(scene)
    bins = V.integer("bins", bins, 1, 64)
    inp = frame_inputs(scene)
    ev = make_method(method, Material.of(scene))
    img = np.asarray(render(ev, inp, V.seed(seed)), float)
    if img.ndim == 3:
        img = img.mean(axis=-1)
    hit = inp.hit & np.isfinite(img)
    lit = hit & (img > level)
    lab, count = ndimage.label(lit, structure=np.ones((3, 3)))
    dist = np.linalg.norm(inp.view, axis=-1)
    edges = np.quantile(dist[hit], np.linspace(0, 1, bins + 1)) if hit.any() else np.zeros(bins + 1)
    rows = []
    if count:
        idx = np.arange(1, count + 1)
        sizes = ndimage.sum(lit, lab, idx)
        peaks = ndimage.maximum_position(np.where(lit, img, -1.0), lab, idx)
        peak_d = np.array([dist[p] for p in peaks])
    else:
        sizes, peak_d = np.zeros(0), np.zeros(0)
    for i in range(bins):
        lo, hi = edges[i], edges[i + 1]
        inb = (dist >= lo) & ((dist <= hi) if i == bins - 1 else (dist < hi)) & hit
        sel = (peak_d >= lo) & ((peak_d <= hi) if i == bins - 1 else (peak_d < hi))
        rows.append({"scene": scene.name, "method": method, "width": scene.width, "height": scene.height,
                     "distance_lo": float(lo), "distance_hi": float(hi), "pixels": int(inb.sum()),
                     "sparkles": int(sel.sum()),
                     "sparkles_per_1000_px": float(1000 * sel.sum() / max(int(inb.sum()), 1)),
                     "mean_size_px": float(sizes[sel].mean()) if sel.any() else math.nan,
                     "p90_size_px": float(np.quantile(sizes[sel], 0.9)) if sel.any() else math.nan})
    return pd.DataFrame(rows)
