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

A new method is one entry: ``register_image_method("name", lambda m: evaluator, label="...")``, with
``m`` the scene's :class:`Material` (density, target NDF, alpha, R, angular texel).
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.glinty_ndf import (ANGULAR_TEXEL, BUILTIN_IMAGE_METHODS, IMAGE_METHODS, ImageMethod, Material,  # noqa: F401
                              SmoothNDF, image_methods, make_method, register_image_method)
from .scene import SCENES_DIR, Scene, _unit, load_scene

TAU = 2.0             # a pixel shows a glint when its NDF value exceeds TAU x D(h) (docs/math/glint_images.md#glint-pops)


# --------------------------------------------------------------------------------------------------
# The image methods: one registry, in glintlab.api.glinty_ndf (re-exported here)

DEFAULT_METHODS = BUILTIN_IMAGE_METHODS


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
    its look-at point by the factor ``zoom`` per frame (a dolly: footprints shrink, the LOD moves)."""
    V.integer("frames", frames, minimum=2)
    pan_px, zoom = V.real("pan_px", pan_px), V.real("zoom", zoom)
    if not (math.isfinite(pan_px) and abs(pan_px) <= 8):
        V.fail("pan_px", pan_px, "a number of pixels in [-8, 8]")
    if not (0.5 <= zoom <= 2 and zoom != 0):
        V.fail("zoom", zoom, "a factor in [0.5, 2]")
    cam = scene.spec["camera"]
    pos, look = np.asarray(cam["position"], float), np.asarray(cam["look_at"], float)
    step = pan_px * np.linalg.norm(look - pos) / scene.focal * scene.right
    pans = frames // 2
    out = []
    for k in range(frames):
        spec = copy.deepcopy(scene.spec)
        shift = step * min(k, pans)
        p, lk = pos + shift, look + shift
        if k > pans:
            p = lk + (p - lk) * zoom ** (k - pans)
        spec["camera"]["position"], spec["camera"]["look_at"] = [float(x) for x in p], [float(x) for x in lk]
        out.append(Scene(spec, name=scene.name, source=scene.source))
    return out


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
                       b=bb, view=view_raw, light=np.ascontiguousarray(lt), h_world=h)


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


def _scene_of(scene) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, str) and "\n" not in scene and "{" not in scene:
        named = SCENES_DIR / f"{scene}.json"
        return load_scene(named if named.is_file() else scene)
    return load_scene(scene)


def render_image(method, scene, frame: int = 0, seed: int = 0, scale: float = 1.0, frames: int = 8,
                 directional: bool = True) -> np.ndarray:
    """``gl.render(method, scene, frame=0, seed=0, scale=1.0)``: one image method's image of frame
    ``frame`` of the scene's camera path (:func:`camera_path` with ``frames`` frames, the scene lit by one
    directional light unless ``directional`` is False), at ``scale`` times the resolution per side
    (density scaled to keep the facets per pixel). ``method``: an image method's name
    (``image_methods()``), or a glinty NDF / method shader object; ``scene``: a :class:`Scene`, a
    shipped scene's name ("sphere", "plane_25", ...), a path or a JSON document. Returns (rows, columns)
    or (rows, columns, 3) for a colour method shader; NaN where no surface is hit."""
    scene = _scene_of(scene)
    V.integer("frames", frames, minimum=1)
    V.integer("frame", frame, 0, frames - 1, expected=f"an integer in [0, {frames - 1}] (frames = {frames})")
    seed = V.seed(seed)
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
    cam = camera_path(scene, max(int(frames), 2))[int(frame)]
    inp = frame_inputs(cam)
    img = render(evaluator, inp, seed, frame=int(frame)).astype(np.float64)
    miss = ~inp.hit
    img[miss] = np.nan
    return img


@dataclass
class PathImages:
    """Images of one scene along a camera path: ``images[method]`` (T, H, W), ``target`` (T, H, W) the
    smooth D(h) (the pops' reference level), ``mask`` (T, H, W), seconds per method (all frames) and
    for the per-frame inputs."""
    scene: str
    images: dict
    target: np.ndarray
    mask: np.ndarray
    seconds: dict
    input_seconds: float
    material: Material


def render_path(scene: Scene, methods=DEFAULT_METHODS, frames: int = 8, pan_px: float = 0.25, zoom: float = 0.99,
                seed: int = 1, angular_texel: float = ANGULAR_TEXEL, directional: bool = True) -> PathImages:
    """Every method's images of ``scene`` along :func:`camera_path` (one directional light unless
    ``directional`` is False). The inputs of each frame are computed once and shared."""
    seed = V.seed(seed)
    if isinstance(methods, str) or not len(methods):
        V.fail("methods", methods, "a non-empty list of image method names")
    for name in methods:
        IMAGE_METHODS.get(name)
    if directional:
        scene = with_directional_light(scene)
    mat = Material.of(scene, angular_texel)
    evaluators = {name: make_method(name, mat) for name in methods}
    smooth = SmoothNDF(mat.target, mat.alpha)
    path = camera_path(scene, frames, pan_px, zoom)
    shape = (frames, scene.height, scene.width)
    images = {name: np.zeros(shape) for name in methods}
    target, mask = np.zeros(shape), np.zeros(shape, bool)
    seconds = dict.fromkeys(methods, 0.0)
    t_in = 0.0
    for k, cam in enumerate(path):
        inp = frame_inputs(cam)
        t_in += inp.seconds
        mask[k] = inp.mask
        target[k] = render(smooth, inp)
        for name, ev in evaluators.items():
            t0 = time.perf_counter()
            images[name][k] = render(ev, inp, seed, frame=k)
            seconds[name] += time.perf_counter() - t0
    return PathImages(scene.name, images, target, mask, seconds, t_in, mat)


def time_methods(scene: Scene, methods=DEFAULT_METHODS, seed: int = 1, angular_texel: float = ANGULAR_TEXEL,
                 repeats: int = 1) -> pd.DataFrame:
    """Seconds per image of each method on the first frame of ``scene`` at its own resolution (best of
    ``repeats``), with the shared per-frame inputs timed once."""
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
        rows.append({"scene": path.scene, "method": name, "label": IMAGE_METHODS.get(name).label
                     if name in IMAGE_METHODS else name, **r, "pop_rate_wider": near["pop_rate"],
                     "seconds_per_frame": path.seconds[name] / frames})
    return pd.DataFrame(rows)


def display(images: np.ndarray, material: Material, white: float = 2.0, gamma: float = 2.2) -> np.ndarray:
    """Images (NDF values) as display values in [0, 1]: (value / (white D(n)))^(1 / gamma), clipped."""
    d_n = 1.0 / (math.pi * material.alpha**2)
    return np.clip(np.asarray(images) / (white * d_n), 0.0, 1.0) ** (1.0 / gamma)
