"""The sphere under extended lights (glintlab.validation.lighting_images with per-pixel frames;
docs/math/lighting.md#lighting-scene-images): every pixel sees the world-space light in its own tangent frame,
in the facet truth (each facet's mirror direction mapped to world space) and in the exact p (the light rotated
into the pixel's frame, cubature per pixel); under the sky map in world space, each pixel sees the map's
directions in its frame, cut at its own horizon.

Statistics: on every other pixel of every other row the footprints (circles of radius 1/sqrt(pi) pixel around
pixels 2 apart) are disjoint, so the lit facets are a sum of independent Bernoulli counts (one per facet of the
stratified layout, each with its own normal), whose variance is at most its mean E = sum n p_exact. The check
|K - E| <= 4 sqrt(E) then fails a correct truth with probability at most ~6e-5 (normal approximation; E ~ 10^3),
with a fixed seed. The deliberately wrong variant lights every pixel by the light seen in one pixel's frame
(what the plane's one-frame path would do on the sphere): it lies tens of standard deviations away."""
import copy

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import lighting as L
from glintlab.api.lighting import facet_truth, reflection_probability
from glintlab.api.spatial import Ellipse
from glintlab.validation import lighting_images as LI
from glintlab.validation.scene import Scene
from glintlab.validation.scene_images import frame_inputs, resolve_scene, with_density, with_directional_light

Z_MAX = 4.0


def sharp_sphere():
    """The shipped sphere at 1/20 of its size per side, alpha 0.3 (a lobe narrow enough that where the
    light sits in each pixel's frame matters), 40 x its facets per pixel."""
    spec = copy.deepcopy(resolve_scene("sphere").scaled(1 / 20, keep_n=True).spec)
    spec["material"]["alpha"] = 0.3
    spec["material"]["density"] *= 40
    return Scene(spec, name="sphere", source="test")


def disjoint_pixels(scene, light):
    """(material, side, frames, wo, footprints, centres, n) on the pixels 2 apart of the scene lit by ``light``
    (a SceneLight, or None for a map: every pixel that sees the surface)."""
    spec = with_directional_light(scene).spec
    spec["light"] = {"type": "directional", "direction": list(light.direction) if light else [0.0, 0.0, 1.0]}
    lit = Scene(spec, name=scene.name, source="test")
    mat, side = LI.plane_material(lit)
    inp = LI._narrow_footprints(frame_inputs(lit), env=light is None)
    y, x = np.mgrid[0:lit.height, 0:lit.width]
    inp.mask &= (y % 2 == 0) & (x % 2 == 0)
    _, frames, wo, uv, J, nf = LI._frame_geometry(inp, mat.density, per_pixel=True)
    return mat, side, frames, wo, [Ellipse.from_uv_derivatives(*j) for j in J], [tuple(c) for c in np.mod(uv, 1)], nf


@pytest.mark.parametrize("kind,size", [("cap", (0.2, 0.0)), ("rect", (0.3, 0.2))])
def test_sphere_facets_meet_the_per_pixel_expectation_and_one_frame_is_rejected(kind, size):
    scene = sharp_sphere()
    light = LI.scene_light(scene, kind, size)
    mat, side, frames, wo, fps, centres, nf = disjoint_pixels(scene, light)
    world = LI._world_light(light)
    expected = float((nf * reflection_probability(mat.target, mat.alpha, wo, world, frames=frames)).sum())
    count = facet_truth(mat.target, mat.alpha, side * side, fps, centres, wo, world, seed=1, frames=frames).counts.sum()
    assert expected > 500
    assert abs(count - expected) <= Z_MAX * np.sqrt(expected)
    # One frame for all pixels (the centre pixel's): the facets and the exact p are both far from the truth.
    one = light.in_frame(*frames[len(frames) // 2])
    wrong = facet_truth(mat.target, mat.alpha, side * side, fps, centres, wo, one, seed=1).counts.sum()
    assert abs(wrong - expected) > 5 * Z_MAX * np.sqrt(expected)
    wrong_p = float((nf * reflection_probability(mat.target, mat.alpha, wo, one)).sum())
    assert abs(count - wrong_p) > 5 * Z_MAX * np.sqrt(wrong_p)


def test_sphere_facets_per_region_of_the_world_map_meet_the_per_pixel_expectation():
    """Per region of the sky: |K_r - E_r| <= 4 sqrt(E_r) for each of the 3 regions (false failure <= 2e-4)."""
    scene = sharp_sphere()
    env = gl.lights.envmap("sky", regions=3)
    mat, side, frames, wo, fps, centres, nf = disjoint_pixels(scene, None)
    expected = (nf[:, None] * reflection_probability(mat.target, mat.alpha, wo, env, frames=frames)).sum(axis=0)
    count = facet_truth(mat.target, mat.alpha, side * side, fps, centres, wo, env, seed=1, frames=frames).counts.sum(axis=0)
    assert expected.min() > 50
    assert np.all(np.abs(count - expected) <= Z_MAX * np.sqrt(expected))
    # The map in each pixel's tangent frame (as on a plane): the facets and the exact p both leave the truth.
    wrong = facet_truth(mat.target, mat.alpha, side * side, fps, centres, wo, env, seed=1).counts.sum(axis=0)
    assert np.abs(wrong - expected).max() > 5 * Z_MAX * np.sqrt(expected[0])
    wrong_p = (nf[:, None] * reflection_probability(mat.target, mat.alpha, wo, env)).sum(axis=0)
    assert np.abs(count - wrong_p).max() > 5 * Z_MAX * np.sqrt(wrong_p[0])


def test_the_map_per_frame_matches_a_fine_quadrature_in_the_frame():
    """The exact p per region with a tilted frame against a 512 x 1024 midpoint sum over the frame's hemisphere
    (its cell boundaries cost it ~1e-3 relative on the small regions)."""
    env = gl.lights.envmap("sky", regions=3)
    th, ph = np.radians(70.0), np.radians(200.0)  # tilted towards the sun
    n = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    t = np.cross([0.0, 0.0, 1.0], n)
    t /= np.linalg.norm(t)
    frame = np.array([t, np.cross(n, t), n])
    wo = np.array([0.1, 0.2, 0.95]) / np.linalg.norm([0.1, 0.2, 0.95])
    got = reflection_probability("beckmann", 0.3, wo[None], env, frames=frame[None])[0]
    d, dw = gl.lights.directions(512, 1024), gl.lights.cell_solid_angles(512, 1024)
    up = d[..., 2] > 0
    local = d[up]
    dens = L.density("beckmann", 0.3, np.broadcast_to(wo, local.shape), local) * dw[up]
    world = local @ frame  # local components times the rows t, b, n
    rows, cols = env.shape
    theta, phi = np.arccos(np.clip(world[:, 2], -1, 1)), np.mod(np.arctan2(world[:, 1], world[:, 0]), 2 * np.pi)
    lab = env.labels[np.minimum((theta / np.pi * rows).astype(int), rows - 1),
                     np.minimum((phi / (2 * np.pi) * cols).astype(int), cols - 1)]
    quad = np.array([dens[lab == r].sum() for r in range(env.regions)])
    assert np.all(quad > 0) and np.allclose(got, quad, rtol=1e-2, atol=0)
    unrotated = reflection_probability("beckmann", 0.3, wo[None], env)[0]
    assert not np.allclose(unrotated, quad, rtol=0.1, atol=0)


def test_per_view_frames_equal_the_light_built_in_each_frame():
    rng = np.random.default_rng(4)
    frames, views = [], []
    world = gl.lights.rect((0.5, 0.1, 1.0), (0.4, 0.0, -0.2), (0.0, 0.5, 0.0))
    while len(frames) < 12:
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        f = (q * np.sign(np.linalg.det(q))).T  # rows t, b, n: a rotation
        if (f @ world.center)[2] > 0.3:
            frames.append(f)
            views.append([0.3 * rng.normal(), 0.3 * rng.normal(), 1.0])
    frames, views = np.array(frames), np.array(views)
    c, u, v = (np.array(world.params[k]) for k in ("center", "edge_u", "edge_v"))
    for method in ("exact", "point"):
        got = reflection_probability("ggx", 0.3, views, world, method, frames=frames)
        each = [reflection_probability("ggx", 0.3, w, gl.lights.rect(f @ c, f @ u, f @ v), method) for w, f in zip(views, frames)]
        assert np.allclose(got, each, rtol=1e-12, atol=0)


def test_bad_frames_are_refused():
    light = gl.lights.cap((0.0, 0.0, 1.0), 0.1)
    with pytest.raises(ValueError, match="frames"):
        reflection_probability("ggx", 0.3, [[0, 0, 1.0]] * 2, light, frames=np.eye(3)[None])
    with pytest.raises(ValueError, match="frames"):
        reflection_probability("ggx", 0.3, [0, 0, 1.0], light, frames=2 * np.eye(3))
    with pytest.raises(ValueError, match="frames"):
        reflection_probability("ggx", 0.3, [0, 0, 1.0], light, "cap", frames=np.eye(3))
    with pytest.raises(ValueError, match="frames"):
        reflection_probability("ggx", 0.3, [0, 0, 1.0], gl.lights.envmap("sky"), frames=np.stack([np.eye(3)] * 2))


def test_a_plane_per_pixel_equals_the_one_frame_path():
    scene = with_density(resolve_scene("plane_25").scaled(1 / 24, keep_n=True), 0.25)
    light = LI.scene_light(scene, "cap", (0.2, 0.0), radiance=3.0)
    one = LI.light_path(scene, light, frames=2, seed=5, grid_nodes=11)
    each = LI.light_path(scene, light, frames=2, seed=5, per_pixel=True)
    both = one.mask & each.mask  # the per-pixel path leaves out footprints wider than MAX_FOOTPRINT
    assert both.sum() > 0.8 * one.mask.sum()
    for name in ("facets", "binomial (exact p)", "gated (point p)"):
        assert np.array_equal(one.images[name][both], each.images[name][both]), name
    # The exact p: the grid's interpolation against cubature per pixel.
    assert np.abs(one.target - each.target)[both].max() <= 1e-3 * one.target.max()


def test_the_sphere_path_renders_and_a_sphere_needs_per_pixel_frames():
    scene = with_density(resolve_scene("sphere").scaled(1 / 24, keep_n=True), 4.0)
    light = LI.scene_light(scene, "cap", (0.2, 0.0))
    path = LI.light_path(scene, light, frames=2, seed=2)
    t = LI.light_table(path).set_index("method")
    assert path.grid_error is None and t.loc["facets", "lit_facets"] > 300
    assert 0.8 < t.loc["facets", "expected_ratio"] < 1.25
    with pytest.raises(ValueError, match="per_pixel"):
        LI.light_path(scene, light, frames=2, per_pixel=False)
