"""What the report's image viewer shows of the glint images (section ``scene_images``, page
``scene_images.html``; docs/guide/scenes.md#the-image-viewer): per scene, each method's first frame at the
viewer's resolution as HDR radiance beside its own truth, the facet truth and the smooth render, the
scene's default exposure, and the camera path's frames with the pixels where the flicker table counts
pops. Numbers only: :mod:`glintlab.report.viewer` writes the page.

Radiance is what the panels show (docs/math/glint_images.md#glint-shading): an NDF method's image times
the microfacet BRDF's factor F G / (4 cos_o) under the scene's directional light. An intensity method
(WB16's sparkles, a user's intensity shader) has no radiance: its value v is kept as v x ``white``, the
scene's white (``exposure_white`` x the ``exposure_percentile`` of the smooth radiance), so that at the
default exposure it shows as the panels always showed it (v = 1: the display's white under clamping).
"""
from __future__ import annotations

import inspect
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..api import checks as V
from ..validation.scene_images import (INTENSITY_GLINT_LEVEL, IMAGE_METHODS, SUPERSAMPLE, Material, SmoothNDF,
                                       frame_inputs, glint_mask, make_method, reference_image, render,
                                       shading, supersampled, truth_kind, with_directional_light)

#: Tile key of the facet ground truth and of the smooth render (the relative error's denominator).
FACETS, SMOOTH = "truth", "smooth"
#: The tolerance of the viewer's own-truth references where the method takes one (KPT25: the lobes that
#: would move a pixel by less than this x D(h) x W / K_P are left out; docs/math/glinty_ndf.md#glinty-reference-reach):
#: 1e-3, the bound below the stored images' 2^-7 relative precision at the lobe's level (measured: 2.1e-5
#: D(h) at most from the 1e-6 sums over the five scenes at 960 x 540), and 24 % less CPU than 1e-6 (2.1 s
#: of the section's 66). The camera path's own truth, which the pops are counted against, keeps
#: ``IMAGE_REFERENCE_TOL`` (1e-6): the viewer shows the reference, the table counts against it.
VIEWER_REFERENCE_TOL = 1e-3


@dataclass
class ViewerScene:
    """One scene of the viewer. ``images[key]`` (H, W) float32 radiance of frame 0 at the viewer's
    resolution: each method's under its name, each own truth that is not the facets under
    ``"<method>: <kind>"``, the facet truth under ``"truth"`` and the smooth render under ``"smooth"``.
    ``columns``: per method (in the section's order) its name, label, what it returns, its own truth's
    kind and key. ``exposure``: the default exposure in stops (display value tone(L x 2^exposure));
    ``white``: L at which the default exposure gives 1 before the tone curve. ``path``: the camera path
    (:func:`path_tiles`), ``seconds``: each method's render time of frame 0 at this resolution,
    ``input_seconds``: the shared per-pixel inputs'."""
    name: str
    width: int
    height: int
    exposure: float
    white: float
    images: dict
    columns: list
    path: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    input_seconds: float = 0.0
    pixels: int = 0


def own_truth_key(name: str) -> str:
    """The image key of method ``name``'s own truth: the facets' ``"truth"``, or ``"<name>: <kind>"``."""
    kind = truth_kind(name)
    return name if kind == "self" else FACETS if kind == "facets" else f"{name}: {kind}"


def default_exposure(smooth_radiance: np.ndarray, percentile: float = 99.0, white: float = 2.0):
    """(exposure in stops, white): white = ``white`` x the ``percentile`` of the smooth radiance over the
    pixels where it is positive, exposure = -log2(white), so that radiance ``white`` shows as 1 before
    the tone curve and the smooth lobe's bright end as 1 / ``white`` (the panels' display since the
    first report; docs/math/glint_images.md#glint-shading)."""
    lit = smooth_radiance[np.isfinite(smooth_radiance) & (smooth_radiance > 0)]
    w = float(white * np.percentile(lit, percentile)) if lit.size else 1.0
    return -math.log2(w), w


def _columns(methods) -> list:
    return [{"method": m, "label": IMAGE_METHODS.get(m).label, "returns": IMAGE_METHODS.get(m).returns,
             "truth_kind": truth_kind(m), "own": own_truth_key(m)} for m in methods]


def _radiance(images: dict, shade: np.ndarray, methods, white: float) -> dict:
    """float32 radiance of each NDF image (x ``shade``), an intensity method's value x ``white``; NaN
    (a method shader off the surface) as 0."""
    out = {}
    for key, img in images.items():
        name = key.split(": ")[0]
        intensity = name in IMAGE_METHODS and IMAGE_METHODS.get(name).returns == "intensity"
        v = np.asarray(img, float) * (white if intensity else shade)
        out[key] = np.nan_to_num(v, nan=0.0, posinf=0.0, neginf=0.0).astype(np.float32)
    return out


def render_frames(scene, methods, seed: int, angular_texel: float, exposure=(99.0, 2.0)) -> ViewerScene:
    """Frame 0 of ``scene`` (already scaled, at its facet density) for each method and its own truth,
    rendered at the scene's resolution with the per-pixel inputs computed once (as the camera path's
    frames are), each method's seconds measured as ``time_methods`` does."""
    scene = with_directional_light(scene)
    mat = Material.of(scene, angular_texel)
    inp = frame_inputs(scene)
    shade = shading(inp, mat)
    raw, seconds = {SMOOTH: render(SmoothNDF(mat.target, mat.alpha), inp)}, {}
    for name in dict.fromkeys([FACETS, *methods]):
        ev = make_method(name, mat)
        t0 = time.perf_counter()
        raw[name] = render(ev, inp, seed, frame=0)
        seconds[name] = time.perf_counter() - t0
        kind = truth_kind(name)
        if kind == "reference":
            raw[own_truth_key(name)] = _reference(ev, inp, seed)
        elif kind == "supersampled":
            raw[own_truth_key(name)] = supersampled(ev, inp, seed, frame=0, n=SUPERSAMPLE)
    stops, white = default_exposure(raw[SMOOTH] * shade, *exposure)
    return ViewerScene(scene.name, scene.width, scene.height, stops, white, _radiance(raw, shade, methods, white),
                       _columns(methods), seconds={m: seconds[m] for m in methods}, input_seconds=inp.seconds,
                       pixels=int(inp.mask.sum()))


def _reference(ev, inp, seed: int) -> np.ndarray:
    """``reference_image`` to VIEWER_REFERENCE_TOL where the method's ``reference`` takes a tolerance."""
    if "tol" not in inspect.signature(ev.reference).parameters:
        return reference_image(ev, inp, seed)
    img = np.zeros(inp.mask.shape)
    m = inp.mask
    if m.any():
        tol = max(VIEWER_REFERENCE_TOL, getattr(ev, "reference_tol", 0.0))
        img[m] = ev.reference(inp.uv[m], inp.J[m], inp.h[m], seed=seed, tol=tol)
    return img


def frames_of_path(path, methods, exposure=(99.0, 2.0)) -> ViewerScene:
    """The viewer's frames taken from frame 0 of a rendered camera path (when the viewer's resolution is
    the path's: ``glintlab images``), nothing rendered again."""
    shade = path.shade[0]
    raw = {SMOOTH: path.target[0], FACETS: path.images[FACETS][0]}
    for m in methods:
        raw[m] = path.images[m][0]
        if path.truths is not None and truth_kind(m) in ("reference", "supersampled"):
            raw[own_truth_key(m)] = path.truths[m][0]
    stops, white = default_exposure(raw[SMOOTH] * shade, *exposure)
    T, H, W = path.target.shape
    return ViewerScene(path.scene, W, H, stops, white, _radiance(raw, shade, methods, white), _columns(methods),
                       seconds={m: path.seconds[m] / T for m in methods}, input_seconds=path.input_seconds / T,
                       pixels=int(path.mask[0].sum()))


def pop_pixels(name: str, images, truth, target, mask, tau: float) -> list:
    """Per consecutive frame pair (t - 1, t), t = 1..T-1, the flat pixel indices where method ``name``
    pops against ``truth``: exactly the pixel-frames ``flicker_metrics`` counts in its ``pop_rate``
    (``own_truth_metrics``' ``own_pop_rate`` with the own truth; an intensity method's glints are its
    values above INTENSITY_GLINT_LEVEL), with the table's radius 0 (a truth change at the pixel itself is
    the only cause). ``tests/python/test_viewer.py`` checks the two agree."""
    if IMAGE_METHODS.get(name).returns == "intensity":
        target = np.full(np.shape(target), INTENSITY_GLINT_LEVEL / tau)
    valid = np.asarray(mask, bool).all(axis=0) if np.ndim(mask) == 3 else np.asarray(mask, bool)
    lit_m, lit_t = glint_mask(np.asarray(images), target, tau), glint_mask(np.asarray(truth), target, tau)
    changed_m = lit_m[1:] != lit_m[:-1]
    pops = changed_m & ~(lit_t[1:] != lit_t[:-1]) & valid
    return [np.flatnonzero(p) for p in pops]


def path_tiles(path, methods, white: float, tau: float) -> dict:
    """The camera path as the viewer's video shows it: ``tiles[key]`` (T, H, W) float32 radiance of each
    method but the smooth render (it has no glints to flicker: the video leaves it out, a twelfth of its
    bytes) and each own truth (keys as :class:`ViewerScene`'s), ``pops[method]`` its pop pixels per frame
    pair against its own truth (:func:`pop_pixels`), ``pop_rate[method]`` their share of the valid
    pixel-frames (the table's ``own_pop_rate``) and ``valid`` the number of pixels valid in every frame."""
    raw = {FACETS: path.images[FACETS]}
    pops, rates = {}, {}
    valid = int(path.mask.all(axis=0).sum())
    pairs = max(valid * (path.target.shape[0] - 1), 1)
    for m in methods:
        if m != SMOOTH:
            raw[m] = path.images[m]
        own = path.truths[m] if path.truths is not None else path.images[FACETS]
        if truth_kind(m) in ("reference", "supersampled"):
            raw[own_truth_key(m)] = own
        pops[m] = pop_pixels(m, path.images[m], own, path.target, path.mask, tau)
        rates[m] = float(sum(len(p) for p in pops[m]) / pairs)
    tiles = _radiance(raw, path.shade, methods, white)
    T, H, W = path.target.shape
    return {"tiles": tiles, "pops": pops, "pop_rate": rates, "valid": valid, "frames": T, "width": W, "height": H}


def timing_table(views: dict, name: str) -> pd.DataFrame:
    """``time_methods``' table from the viewer's renders of scene ``name`` (each method's frame 0 at the
    viewer's resolution, timed as it was rendered)."""
    v = views[name]
    rows = [{"scene": name, "method": "(inputs uv, J, h)", "width": v.width, "height": v.height,
             "seconds": v.input_seconds, "pixels": v.pixels}]
    rows += [{"scene": name, "method": m, "width": v.width, "height": v.height, "seconds": s, "pixels": v.pixels}
             for m, s in v.seconds.items()]
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------------------
# Display: the tone curves and the sRGB encoding of the viewer's script (data/report/viewer.js), in numpy,
# for the print panel and for the browser test that compares the page's canvas with the stored images.

#: The viewer's tone curves (first: the default): clamp min(x, 1), Reinhard x / (1 + x), and Narkowicz's
#: fit of the ACES filmic curve x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), clamped to [0, 1].
TONE_CURVES = ("aces", "reinhard", "clamp")


def tone_curve(x, tone: str = "aces") -> np.ndarray:
    """The tone curve ``tone`` of ``x`` (radiance x 2^exposure, negative and NaN taken as 0)."""
    x = np.asarray(x, float)
    x = np.where(x > 0, x, 0.0)
    if tone == "clamp":
        return np.minimum(x, 1.0)
    if tone == "reinhard":
        return x / (1.0 + x)
    if tone == "aces":
        return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)
    V.fail("tone", tone, "one of " + ", ".join(TONE_CURVES))


def srgb_encode(y) -> np.ndarray:
    """The sRGB transfer function of display-linear values in [0, 1]."""
    y = np.asarray(y, float)
    return np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.power(np.maximum(y, 0.0031308), 1 / 2.4) - 0.055)


def display_bytes(radiance, exposure: float, tone: str = "aces") -> np.ndarray:
    """8-bit display values of ``radiance`` at ``exposure`` stops through ``tone``: the viewer's
    Math.round(255 srgb(tone(L 2^exposure)))."""
    return np.floor(255.0 * srgb_encode(tone_curve(np.asarray(radiance, float) * 2.0 ** exposure, tone)) + 0.5
                    ).astype(np.uint8)
