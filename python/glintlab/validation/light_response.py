"""How a glint method's image responds to moving the light and the view, beside its truth
(docs/math/glint_images.md#glint-light-response).

The flicker and own-truth tables follow a camera path: a method that reads only part of the half
vector h (a port that passes h to the glint function as one float, so that its NDF reads
(h_x, h_x, h_x)) flickers as much as the fixed code there. Moving the light shows it at once. Two
checks, on one frame of a scene:

- **Decorrelation.** The light (then, separately, the view) is moved per pixel along each axis
  a of the pixel's shading frame (t, b, n): l' = normalize(l + s a) for offsets s = step, 2 step, ...,
  with the surface point, its uv and its footprint kept (the view keeps its distance). Each moved image
  is correlated (Pearson, over the pixels valid in both) with the unmoved one, for the method and for
  its truth, on the glints: an NDF image less the smooth D(h) of its pixels, an intensity image as it is,
  each less its local mean (``HIGH_PASS`` pixels). The mean decorrelation 1 - r over the offsets, method
  over truth, is the axis' ratio; an axis along which the truth decorrelates by at least
  ``TRUTH_RESPONDS`` fails when the ratio is below ``MIN_RATIO``: the method keeps its glints where the
  truth's change, it ignores that component of h. A method without glints (the smooth D(h)) is not read.
- **The lobe.** The half vector is set, in every pixel's shading frame, to h(m) of slope m along t and
  along b (m in ``LOBE_SLOPES`` x alpha; the light the view reflected about h) and the method's D is
  averaged over the frame's pixels, on the scene at its file's density (many facets per pixel) and the
  method's own (matched) density; against the target D(h). The ratio's level (its mean over the checked
  slopes) is reported; its shape is checked: per slope up to ``LOBE_CHECKED`` alpha, the ratio over the
  level within 1 +- (``LOBE_ALLOWANCE`` + ``LOBE_Z`` standard errors, from ``BLOCK`` x ``BLOCK`` pixel
  tiles so that neighbouring pixels' shared glints are not counted as independent). A lobe of the wrong
  width, or one read at the wrong h, fails; a counting scheme's mean bias (a level, not a shape) does not.

The truth is the method's own (docs/math/glint_images.md#glint-own-truth): the facets for the counting
methods, the method's ``reference`` for KPT25 and WWH18, the facets themselves for ``truth``. An
intensity method (WB16) has no target NDF: its curves are reported beside the facet truth's and nothing
is checked (how its value follows the light or the view is its own design: WB16's follows the view alone).
A method shader's NaN, infinite or negative value at a moved light fails the check.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy import ndimage

from ..api import checks as V
from ..api.counting_shaders import NdfShaderMethod, user_ndf_method
from ..api.glinty_ndf import (DB23, IMAGE_METHODS, ImageMethod, Material, SmoothNDF, angular_slope, footprint_area,
                              make_method, pixel_arrays)
from ..api.shaders import ShaderOutputError
from .scene_images import (FrameInputs, frame_inputs, reference_image, render, resolve_scene, with_density,
                           with_directional_light)

MOVES = ("light", "view")
AXES = ("t", "b", "n")
#: Offsets per move (l' = normalize(l + s a), s = step, 2 step, ...): a light move of 0.02 turns h by about
#: 0.01 rad, a fifth of an angular texel (0.05 in slope) near the normal.
STEPS, STEP = 3, 0.02
#: Slopes of the lobe sweep, in units of alpha, along t and along b: checked up to LOBE_CHECKED. Beyond it the
#: sweep is reported only: at 2 alpha (Beckmann, alpha 1) KPT25's exact expectation is 0.72 D(h) (its lobe's
#: mass in the disk, ``KPT25.expected``), a property of the model rather than a wrong width.
LOBE_SLOPES, LOBE_CHECKED = (0.0, 0.5, 1.0, 1.5, 2.0), 1.5
#: An axis is checked when the truth's mean decorrelation along it reaches TRUTH_RESPONDS; it fails below
#: MIN_RATIO times the truth's (docs/math/glint_images.md#glint-light-response: the measured ratios).
TRUTH_RESPONDS = 0.1
MIN_RATIO = 0.3
#: An NDF method has no glints when its residual's RMS is at most this fraction of the mean D(h).
NO_GLINTS = 1e-3
#: The side of the local mean taken out of the residual (pixels).
HIGH_PASS = 5
LOBE_ALLOWANCE, LOBE_Z, BLOCK, MIN_PIXELS = 0.15, 4.0, 4, 32


@dataclass
class LightResponse:
    """``gl.light_response``'s result: ``passed`` (every check that applies passed), ``notes`` (one line
    per check that failed or does not apply, and what was measured), ``table`` (the decorrelation
    curves: per move, axis and offset, the method's and its truth's correlation with their unmoved
    images), ``lobe`` (per slope: the method's mean D over the pixels, its standard error and the target
    D(h)), ``checks`` (one row per check: its value, limits and verdict) and ``seconds``."""
    method: str
    scene: str
    truth: str
    passed: bool
    notes: list = field(default_factory=list)
    table: pd.DataFrame | None = None
    lobe: pd.DataFrame | None = None
    checks: pd.DataFrame | None = None
    seconds: float = 0.0

    def __repr__(self):
        return (f"LightResponse({self.method!r} on {self.scene!r} against {self.truth}: "
                f"{'passed' if self.passed else 'FAILED'}, {len(self.checks)} checks)")


#: The defines through which a user's NDF shader reads the scene's material (api/counting_shaders.py).
_MATERIAL_DEFINES = {"GLINTLAB_DENSITY", "GLINTLAB_ALPHA", "GLINTLAB_GGX", "GLINTLAB_R"}


def _method_factory(method):
    """(name, factory material -> evaluator, registry entry or None) of what a user names a method by: an
    image method's name or entry (built for each scene's material, at its matched density), a user's NDF
    shader (compiled for each material), another glinty NDF or method shader object (used as it was built)
    or a factory ``material -> evaluator``."""
    if isinstance(method, (str, ImageMethod)):
        name = method if isinstance(method, str) else method.name
        entry = IMAGE_METHODS.get(name)
        return name, lambda m: make_method(name, m), entry
    if hasattr(method, "image") or hasattr(method, "evaluate"):
        name = getattr(method, "name", "") or type(method).__name__
        entry = IMAGE_METHODS.get(name) if name in IMAGE_METHODS else None
        if isinstance(method, NdfShaderMethod) and _MATERIAL_DEFINES <= {k for k, _ in method._spec["defines"]}:
            # A user's NDF shader (shader_method(..., returns="ndf")): compiled again for each scene's
            # material, as its registered name would be, so that its density is the scene's.
            spec = dict(method._spec, defines=[d for d in method._spec["defines"] if d[0] not in _MATERIAL_DEFINES])
            return name, lambda m: user_ndf_method(spec, m), entry
        return name, lambda m: method, entry
    if callable(method):
        return getattr(method, "__name__", "factory"), method, None
    V.fail("method", method, "an image method's name, an ImageMethod, a glinty NDF, a method shader or a factory "
                             "material -> evaluator")


def _truth_renderer(entry, evaluator, material: Material, returns: str):
    """(kind, render(inputs, seed) -> image) of the method's truth for these checks."""
    kind = entry.truth if entry is not None else "facets"
    if returns == "intensity" or kind == "supersampled":
        kind = "facets"
    if kind == "reference":
        return kind, lambda inp, seed: reference_image(evaluator, inp, seed)
    facets = make_method("truth", material)
    return ("self" if kind == "self" else "facets"), lambda inp, seed: render(facets, inp, seed)


def moved_inputs(inputs: FrameInputs, move: str, axis: str, s: float) -> FrameInputs:
    """``inputs`` with the light (``move`` "light") or the view ("view") of every pixel moved along the axis
    ``axis`` ("t", "b" or "n") of its shading frame: d' = normalize(d + s a), the view keeping its
    length; h, its tangent-frame form and the mask recomputed, the surface point, uv and J kept."""
    a = {"t": inputs.t, "b": inputs.b, "n": inputs.n}[axis]
    light, view = inputs.light, inputs.view
    if move == "light":
        light = light + s * a
        light = light / np.linalg.norm(light, axis=-1, keepdims=True).clip(1e-300)
    else:
        dist = np.linalg.norm(view, axis=-1, keepdims=True).clip(1e-300)
        v = view / dist + s * a
        view = v / np.linalg.norm(v, axis=-1, keepdims=True).clip(1e-300) * dist
    return _with_directions(inputs, view, light)


def _with_directions(inputs: FrameInputs, view, light) -> FrameInputs:
    """``inputs`` with the view (unnormalised) and light vectors given per pixel."""
    v = view / np.linalg.norm(view, axis=-1, keepdims=True).clip(1e-300)
    h = v + light
    h /= np.linalg.norm(h, axis=-1, keepdims=True).clip(1e-300)
    hl = np.stack([(h * inputs.t).sum(-1), (h * inputs.b).sum(-1), (h * inputs.n).sum(-1)], axis=-1)
    mask = (inputs.mask & ((v * inputs.n).sum(-1) > 0) & ((light * inputs.n).sum(-1) > 0) & (hl[..., 2] > 0))
    hl = np.where(mask[..., None], hl, np.array([0.0, 0.0, 1.0]))
    return replace(inputs, h=hl, mask=mask, view=view, light=np.ascontiguousarray(light), h_world=h)


def lobe_inputs(inputs: FrameInputs, h_tangent) -> FrameInputs:
    """``inputs`` with the half vector of every pixel set to ``h_tangent`` (unit, in its shading frame) and
    the light the view reflected about it. D is read at h whatever the light: a light below the horizon
    (the view reflected about a tilted h at a grazing view) does not leave the pixel out; a pixel whose
    view is on the back of the microfacet (v.h <= 0, where view + light points along -h) does."""
    ht = np.asarray(h_tangent, float)
    h = ht[0] * inputs.t + ht[1] * inputs.b + ht[2] * inputs.n
    v = inputs.view / np.linalg.norm(inputs.view, axis=-1, keepdims=True).clip(1e-300)
    vh = (v * h).sum(-1, keepdims=True)
    light = np.ascontiguousarray(2 * vh * h - v)
    keep = _surface_mask(inputs) & ((v * inputs.n).sum(-1) > 0) & (vh[..., 0] > 0) & (ht[2] > 0)
    return replace(inputs, h=np.where(keep[..., None], np.broadcast_to(ht, inputs.h.shape), [0.0, 0.0, 1.0]),
                   mask=keep, light=light, h_world=np.ascontiguousarray(h))


def _surface_mask(inputs: FrameInputs) -> np.ndarray:
    """The pixels that see the surface with a usable footprint, whatever the light."""
    J = inputs.J
    det = J[..., 0] * J[..., 3] - J[..., 1] * J[..., 2]
    hit = inputs.hit if inputs.hit is not None else inputs.mask
    return hit & np.isfinite(J).all(-1) & (np.abs(det) > 0)


def _residual(img, inputs: FrameInputs, smooth, returns: str):
    """What is correlated: the glints. An NDF image less the smooth D(h) of its pixels, an intensity image as
    it is (a colour one averaged over its channels); then less its local mean over HIGH_PASS x HIGH_PASS
    pixels of the mask, so that a lobe of another width (a smooth difference from D(h)) is not read as
    glints that stay in place."""
    img = np.asarray(img, float)
    if img.ndim == 3:
        img = img.mean(axis=-1)
    m = inputs.mask.astype(float)
    r = img if returns == "intensity" else img - np.where(inputs.mask, render(smooth, inputs), 0.0)
    r = np.where(inputs.mask, r, 0.0)
    if not np.any(r):
        return r
    with np.errstate(invalid="ignore", divide="ignore"):
        local = ndimage.uniform_filter(r, HIGH_PASS, mode="constant") / ndimage.uniform_filter(m, HIGH_PASS,
                                                                                              mode="constant")
    return np.where(inputs.mask, r - np.nan_to_num(local), 0.0)


def _correlation(a, b, valid) -> float:
    """Pearson's r of two images over ``valid``; NaN when either is constant there."""
    x, y = a[valid], b[valid]
    x, y = x - x.mean(), y - y.mean()
    den = math.sqrt(float((x * x).sum()) * float((y * y).sum()))
    return float((x * y).sum() / den) if den > 0 else math.nan


@dataclass
class ResponseSetup:
    """What every method's light response on one scene shares: the scene as rendered (``scene``: scaled, one
    directional light), its ``material`` and frame ``inputs``, the ``moved`` inputs ((move, axis, offset,
    inputs) per move), the lobe sweep's material and inputs ((axis, slope / alpha, h, inputs) per
    half vector; None without a sweep), the ``seed`` and the facet truth's residuals once rendered."""
    scene: object
    material: Material
    inputs: FrameInputs
    moved: list
    lobe_material: Material | None
    lobe: list | None
    seed: int
    facet_residuals: list | None = None


def response_setup(scene, seed: int = 1, scale: float = 0.05, density_factor: float = 0.0625, moves=MOVES,
                   steps: int = STEPS, step: float = STEP, lobe_scale: float | None = 0.1,
                   lobe_density_factor: float = 1.0) -> ResponseSetup:
    """The shared part of :func:`light_response` on ``scene`` (its parameters, checked)."""
    sc = resolve_scene(scene)
    seed = V.seed(seed)
    scale, density_factor = V.positive("scale", scale), V.positive("density_factor", density_factor)
    steps = V.integer("steps", steps, 1, 32)
    step = V.positive("step", step)
    if step * steps > 1.0:
        V.fail("step", step, f"an offset per step with steps x step <= 1 (steps = {steps}): small moves")
    if isinstance(moves, str) or not len(moves) or not set(moves) <= set(MOVES):
        V.fail("moves", moves, f"a non-empty list among {', '.join(MOVES)}")
    small = with_directional_light(with_density(sc.scaled(scale, keep_n=True), density_factor))
    inputs = frame_inputs(small)
    moved = [(move, axis, k * step, moved_inputs(inputs, move, axis, k * step))
             for move in MOVES if move in moves for axis in AXES for k in range(1, steps + 1)]
    lobe_material = lobe = None
    if lobe_scale is not None:
        ls, ld = V.positive("lobe_scale", lobe_scale), V.positive("lobe_density_factor", lobe_density_factor)
        big = with_directional_light(with_density(sc.scaled(ls, keep_n=True), ld))
        lobe_material, base = Material.of(big), frame_inputs(big)
        lobe = []
        for axis in ("t", "b"):
            for m in LOBE_SLOPES:
                if axis == "b" and m == 0:
                    continue  # the normal: the same h as along t
                ht = np.array([m * lobe_material.alpha, 0.0, 1.0] if axis == "t" else [0.0, m * lobe_material.alpha, 1.0])
                ht /= np.linalg.norm(ht)
                lobe.append((axis, m, ht, lobe_inputs(base, ht)))
    return ResponseSetup(small, Material.of(small), inputs, moved, lobe_material, lobe, seed)


def decorrelation_curves(evaluator, truth, setup: ResponseSetup, returns: str, truth_kind: str) -> pd.DataFrame:
    """The decorrelation table: one row per (move, axis, offset) with the method's and the truth's
    correlation with their unmoved images (``method_r``, ``truth_r``) and the pixels compared. The facet
    truth's residuals are rendered once per setup."""
    smooth = SmoothNDF(setup.material.target, setup.material.alpha)
    seed, inputs = setup.seed, setup.inputs
    all_inputs = [inputs] + [inp for *_, inp in setup.moved]
    mine = [_residual(render(evaluator, inp, seed), inp, smooth, returns) for inp in all_inputs]
    level = float(np.mean(render(smooth, inputs)[inputs.mask])) if returns == "ndf" and inputs.mask.any() else 0.0
    if level > 0 and float(np.sqrt(np.mean(mine[0][inputs.mask] ** 2))) <= NO_GLINTS * level:
        mine = [np.zeros_like(r) for r in mine]  # D(h) to rounding (a float32 smooth shader): no glints
    if truth_kind == "reference":
        theirs = [_residual(truth(inp, seed), inp, smooth, "ndf") for inp in all_inputs]
    else:
        if setup.facet_residuals is None:
            setup.facet_residuals = [_residual(truth(inp, seed), inp, smooth, "ndf") for inp in all_inputs]
        theirs = setup.facet_residuals
    rows = []
    for k, (move, axis, offset, inp) in enumerate(setup.moved, start=1):
        valid = inputs.mask & inp.mask
        rows.append({"move": move, "axis": axis, "offset": offset, "method_r": _correlation(mine[0], mine[k], valid),
                     "truth_r": _correlation(theirs[0], theirs[k], valid), "pixels": int(valid.sum())})
    return pd.DataFrame(rows)


def lobe_sweep(evaluator, setup: ResponseSetup, block: int = BLOCK) -> pd.DataFrame:
    """The lobe table: per direction ("t" or "b") and slope m (in units of alpha), the method's mean D over
    the frame's pixels at h = normalize(m alpha a + n) (``mean_d``; :func:`lobe_inputs`), its standard error
    over ``block`` x ``block`` pixel tiles (``se``), the target D(h) (``target_d``) and their ratio."""
    smooth = SmoothNDF(setup.lobe_material.target, setup.lobe_material.alpha)
    rows = []
    for axis, m, ht, inp in setup.lobe:
        img = np.asarray(render(evaluator, inp, setup.seed), float)
        target = float(smooth.smooth(ht))
        mean, se, pixels = _block_mean(img, inp.mask, block)
        rows.append({"axis": axis, "slope_over_alpha": m, "h_x": ht[0], "h_y": ht[1], "h_z": ht[2],
                     "mean_d": mean, "se": se, "target_d": target,
                     "ratio": mean / target if target > 0 else math.nan, "pixels": pixels})
    return pd.DataFrame(rows)


def _block_mean(img, mask, block: int):
    """(mean over the masked pixels, its standard error from the means of block x block tiles, pixels)."""
    n = int(mask.sum())
    if n == 0:
        return math.nan, math.nan, 0
    H, W = mask.shape
    hb, wb = H // block, W // block
    tiles = [(img[i:i + block, j:j + block], mask[i:i + block, j:j + block])
             for i in range(0, hb * block, block) for j in range(0, wb * block, block)]
    sums = np.array([t[m].sum() for t, m in tiles])
    counts = np.array([m.sum() for _, m in tiles], float)
    keep = counts > 0
    mean = float(img[mask].mean())
    k = int(keep.sum())
    if k < 2:
        return mean, math.inf, n
    # The ratio estimator's standard error over tiles (tiles hold different numbers of lit pixels).
    resid = sums[keep] - mean * counts[keep]
    se = math.sqrt(k / (k - 1) * float((resid ** 2).sum())) / float(counts[keep].sum())
    return mean, se, n


def _decorrelation_checks(curves: pd.DataFrame, returns: str, static: str | None = None) -> list:
    """One check per (move, axis): the method's mean decorrelation over its truth's, at least MIN_RATIO.
    ``static``: the evaluator's ``static_glints``, why its model keeps its glints in place (WWH18's), which a
    failed check's note gives as the cause."""
    rows = []
    for (move, axis), g in curves.groupby(["move", "axis"], sort=False):
        d_m, d_t = float((1 - g.method_r).mean()), float((1 - g.truth_r).mean())
        row = {"check": f"{move} along {axis}", "value": d_m / d_t if d_t > 0 else math.nan, "low": MIN_RATIO,
               "high": math.inf, "method_decorrelation": d_m, "truth_decorrelation": d_t}
        if returns == "intensity":
            row.update(applies=False, passed=True, why="an intensity method has no target NDF: how its value follows "
                                                        "the light or the view is its own design (WB16's follows the "
                                                        "view alone); reported beside the facet truth's")
        elif not math.isfinite(d_m):
            row.update(applies=False, passed=True, why="the method's image has no glints (its residual from D(h) is 0)")
        elif not d_t >= TRUTH_RESPONDS:
            row.update(applies=False, passed=True, why=f"the truth decorrelates by {d_t:.3g} < {TRUTH_RESPONDS:g}")
        else:
            ok = row["value"] >= MIN_RATIO
            row.update(applies=True, passed=ok, why="" if ok else (
                f"the method decorrelates {row['value']:.3g} times as fast as its truth: it keeps its glints where "
                "the truth's change, " + (f"by its model's design: {static}" if static else
                                          "it ignores this component of h")))
        rows.append(row)
    return rows


def _lobe_level(lobe: pd.DataFrame) -> float:
    """The mean D over D(h) averaged over the checked slopes (each slope one vote: a slope where the method
    has no variance, p clamped to 1, must not outweigh the others)."""
    ok = lobe[(lobe.pixels >= MIN_PIXELS) & (lobe.slope_over_alpha <= LOBE_CHECKED) & (lobe.target_d > 0)]
    return float(ok.ratio.mean()) if len(ok) else math.nan


def _lobe_checks(lobe: pd.DataFrame) -> list:
    """The lobe's shape: per slope, the mean D over D(h) divided by the lobe's level (:func:`_lobe_level`)
    within 1 ± (LOBE_ALLOWANCE + LOBE_Z standard errors). The level itself is reported, not checked (a
    counting scheme's mean bias, docs/math/grids.md#grid-mean, is no wrong width)."""
    level = _lobe_level(lobe)
    rows = [{"check": "lobe level (mean D / D(h))", "value": level, "low": math.nan, "high": math.nan,
             "applies": False, "passed": True, "why": ""}]
    for r in lobe.itertuples():
        name = f"lobe along {r.axis} at slope {r.slope_over_alpha:g} alpha"
        if r.slope_over_alpha > LOBE_CHECKED:
            rows.append({"check": name, "value": r.ratio / level, "low": math.nan, "high": math.nan, "applies": False,
                         "passed": True, "why": f"reported only: slopes beyond {LOBE_CHECKED:g} alpha are not checked"})
            continue
        if r.pixels < MIN_PIXELS or not level > 0:
            rows.append({"check": name, "value": math.nan, "low": math.nan, "high": math.nan, "applies": False,
                         "passed": True, "why": f"{r.pixels} pixels see the surface at this h (< {MIN_PIXELS})"})
            continue
        shape = r.ratio / level
        limit = LOBE_ALLOWANCE + LOBE_Z * r.se / (r.target_d * level)
        ok = bool(abs(shape - 1) <= limit)
        rows.append({"check": name, "value": shape, "low": 1 - limit, "high": 1 + limit, "applies": True, "passed": ok,
                     "why": "" if ok else (f"mean D / D(h) {r.ratio:.3g} is {shape:.3g} times the lobe's level {level:.3g} "
                                           f"(allowed 1 ± {limit:.3g}): the lobe's shape is not the target's")})
    return rows


def light_response(method, scene, seed: int = 1, scale: float = 0.05, density_factor: float = 0.0625,
                   moves=MOVES, steps: int = STEPS, step: float = STEP, lobe_scale: float | None = 0.1,
                   lobe_density_factor: float = 1.0, setup: ResponseSetup | None = None) -> LightResponse:
    """``gl.light_response(method, scene)``: how ``method``'s image of frame 0 of ``scene`` (one
    directional light, at ``scale`` times its resolution per side with the facets per pixel kept, density
    x ``density_factor`` as the scene images') decorrelates as the light and the view move by ``steps``
    offsets of ``step`` along each axis of the shading frame, beside its truth's; and its mean D as the half
    vector sweeps the lobe (on the scene at ``lobe_scale``, density x ``lobe_density_factor``; None: no
    sweep) against the target D(h) (docs/math/glint_images.md#glint-light-response). ``method``: an image
    method's name or ImageMethod (built for each of the two materials, at its matched density), a method
    shader from ``gl.shader_method`` (a user's NDF shader compiled for each material), a glinty NDF object
    (used as built) or a factory material -> evaluator;
    ``scene`` as ``gl.render`` takes it. ``setup`` (:func:`response_setup`) shares the scene's inputs and
    the facet truth's renders between methods, in place of the other arguments. Returns a
    :class:`LightResponse` (``.passed``, ``.notes``, ``.table``, ``.lobe``, ``.checks``)."""
    t0 = time.perf_counter()
    if setup is None:
        setup = response_setup(scene, seed, scale, density_factor, moves, steps, step, lobe_scale, lobe_density_factor)
    name, factory, entry = _method_factory(method)
    ev = factory(setup.material)
    returns = getattr(ev, "returns", "ndf") if entry is None else entry.returns
    kind, truth = _truth_renderer(entry, ev, setup.material, returns)
    curves = sweep = None
    try:
        curves = decorrelation_curves(ev, truth, setup, returns, kind)
        rows = _decorrelation_checks(curves, returns, getattr(ev, "static_glints", None))
        if setup.lobe is not None and returns == "ndf":
            sweep = lobe_sweep(factory(setup.lobe_material), setup)
            rows += _lobe_checks(sweep)
    except ShaderOutputError as exc:  # NaN, infinite or negative values at a moved light: a failed check
        rows = [{"check": "output", "value": math.nan, "low": math.nan, "high": math.nan, "applies": True,
                 "passed": False, "why": str(exc)}]
    checks = pd.DataFrame(rows)
    notes = [f"{r.check}: {'FAIL' if not r.passed else 'not checked'}: {r.why}" for r in checks.itertuples() if r.why]
    if returns != "ndf" and setup.lobe is not None:
        notes.append("lobe: not checked: an intensity method has no D to compare with D(h)")
    return LightResponse(name, setup.scene.name, kind, bool(checks.passed.all()), notes, curves, sweep, checks,
                         time.perf_counter() - t0)


# --------------------------------------------------------------------------------------------------
# Deliberately wrong variants: what the checks must reject (tests/python/test_light_response.py, the
# report's scene_images section). Each is DB23's trilinear gated NDF with one reading of h broken.

def _as_one_float(h) -> np.ndarray:
    """(h_x, h_x, h_x): the half vector passed to a float3 parameter as one float (its x component)."""
    return np.repeat(np.asarray(h, float)[..., :1], 3, axis=-1)


class OneFloatHalfVector(DB23):
    """DB23 reading h as (h_x, h_x, h_x), both for D(h) and for its angular texel: the engine port's bug
    (a half vector passed to the glint function as one float); 0 where h_x <= 0 (below its horizon)."""

    name = "db23_one_float_h"

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        uv, J, h, shape = pixel_arrays(uv, J, h)
        out = np.zeros(shape)
        up = h[..., 0] > 0
        if up.any():
            out[up] = DB23.evaluate(self, uv[up], J[up], _as_one_float(h[up]), seed=seed)
        return out


class OneFloatTexel(DB23):
    """DB23 whose D(h) reads the whole h but whose angular texel (which realization a pixel shows) reads
    (h_x, h_x, h_x): its mean is right and its glints never change with the light, a bug the lobe sweep
    cannot see."""

    name = "db23_one_float_texel"

    def evaluate(self, uv, J, h, seed: int = 0) -> np.ndarray:
        uv, J, h, shape = pixel_arrays(uv, J, h)
        c = h[..., 2] / np.linalg.norm(h, axis=-1)
        p, _ = self.smooth_ndf.success_probability(c, self.R)
        slope = np.clip(angular_slope(_as_one_float(h)) * self.angular_resolution, -1e9, 1e9)
        counts = self.counter.count_image(uv, J, self.density, p, slope=slope, seed=seed)
        d = self.d_p(counts.K, footprint_area(J), self.R)
        return np.where((counts.status == 0) & (c > 0), d, 0.0)


#: The width factor of the wrong-width variant: DB23's lobe 1.3 times the material's roughness.
WIDE_LOBE = 1.3


def wrong_variants(material: Material) -> dict:
    """{label: evaluator} of the deliberately wrong variants of DB23 (trilinear, gated) for ``material``:
    h read as one float (D and texel), only the texel read so, and a lobe ``WIDE_LOBE`` times too wide."""
    kw = dict(density=material.density, target=material.target, scheme="db23_trilinear", inner="gated",
              R=material.R, angular_resolution=1.0 / material.angular_texel)
    return {"h read as (h.x, h.x, h.x)": OneFloatHalfVector(alpha=material.alpha, **kw),
            "angular texel read from (h.x, h.x, h.x)": OneFloatTexel(alpha=material.alpha, **kw),
            f"lobe {WIDE_LOBE:g} x too wide": DB23(alpha=WIDE_LOBE * material.alpha, **kw)}


# --------------------------------------------------------------------------------------------------
# Several methods on one scene: the scene images' section and `glintlab images`

def response_tables(scene, methods, seed: int = 1, **params) -> dict:
    """:func:`light_response` of each of ``methods`` on ``scene`` with one shared :func:`response_setup`
    (``params``: its arguments): {"summary": one row per method (its verdict, the decorrelation ratio per
    move and axis, the lobe's level and largest shape deviation, the failed checks), "curves" and "lobe"
    (every method's rows, with its name), "results": the :class:`LightResponse` objects}."""
    setup = response_setup(scene, seed, **params)
    results = [light_response(m, None, setup=setup) for m in methods]
    rows, curves, lobes = [], [], []
    for r in results:
        c = r.checks
        shape = c[c.check.str.startswith("lobe along") & c.applies]
        level = c[c.check.str.startswith("lobe level")]
        row = {"scene": r.scene, "method": r.method,
               "label": IMAGE_METHODS.get(r.method).label if r.method in IMAGE_METHODS else r.method,
               "truth": r.truth, "passed": r.passed, "checked": int(c.applies.sum()),
               "failed": "; ".join(c.check[c.applies & ~c.passed])}
        for move in MOVES:
            for axis in AXES:
                v = c[c.check == f"{move} along {axis}"]
                row[f"{move}_{axis}"] = float(v.value.iloc[0]) if len(v) else math.nan
        row["lobe_level"] = float(level.value.iloc[0]) if len(level) else math.nan
        row["lobe_shape_dev"] = float((shape.value - 1).abs().max()) if len(shape) else math.nan
        row["seconds"] = r.seconds
        rows.append(row)
        if r.table is not None:
            curves.append(r.table.assign(scene=r.scene, method=r.method))
        if r.lobe is not None:
            lobes.append(r.lobe.assign(scene=r.scene, method=r.method))
    return {"summary": pd.DataFrame(rows), "curves": pd.concat(curves, ignore_index=True) if curves else pd.DataFrame(),
            "lobe": pd.concat(lobes, ignore_index=True) if lobes else pd.DataFrame(), "results": results,
            "setup": setup}
