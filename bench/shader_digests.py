#!/usr/bin/env python3
"""Digests of every shipped shader's outputs on the Vulkan device, to show that a change of the shader
runner's plumbing (its wrappers, its submit path, the Python objects around it) kept every output bit.

    python bench/shader_digests.py before.json                       # on the old build
    python bench/shader_digests.py after.json --compare before.json  # on the new one: exit 1 if any differs

Outputs: each shipped shader law (``gl.shipped_shaders()``) in HLSL and GLSL with n and p per row and
broadcast; a string law with 0 to 4 uniforms; WB16's method shader and its two baselines; the DB23 and
KPT25 method shaders on a small frame of the plane scene; a user's intensity and NDF method shader;
each shipped shader sampler's sample_h and pdf_h. Each on both languages. Digests are per device (GPUs
differ in transcendentals): compare runs on the same device. A minute on lavapipe; not a test (the
digests change whenever a shader is meant to change), a before/after tool.
"""
import argparse
import dataclasses
import hashlib
import json
import sys

import numpy as np

import glintlab as gl
from glintlab.api import counting_shaders as CS
from glintlab.api import method_shaders as MS
from glintlab.api import shader_samplers as SS
from glintlab.api.glinty_ndf import Material, method_density
from glintlab.validation import scene_images as si

digests = {}
LANGS = ("hlsl", "glsl")


def dig(key, a):
    a = np.ascontiguousarray(np.asarray(a))
    digests[key] = hashlib.sha256(str(a.dtype).encode() + a.tobytes()).hexdigest()[:16]


def laws(rng):
    m = 4000
    n = np.exp(rng.uniform(np.log(0.3), np.log(1e6), m))
    p = rng.uniform(0, 1, m)
    u = rng.uniform(0, 1, (m, 2))
    for name in sorted(gl.shipped_shaders()):
        for lang in LANGS:
            law = gl.shader_law(gl.shipped_shader(name, lang), name=f"digest_{name}_{lang}", register=False)
            dig(f"law:{name}:{lang}:rows", law.evaluate_raw(n, p, u))
            dig(f"law:{name}:{lang}:broadcast", law.evaluate_raw(37.5, 0.3, u))
            dig(f"law:{name}:{lang}:sample", law.sample(n[:500], p[:500], seed=3))
    for k in range(5):
        for lang in LANGS:
            terms = " + ".join(f"u.{'xyzw'[j]}" for j in range(k)) or "0.0"
            vec = "float4" if lang == "hlsl" else "vec4"
            code = f"float count(float n, float p, {vec} u) {{ return n * p + {terms}; }}\n"
            law = gl.shader_law(code, language=lang, n_uniforms=k, name=f"digest_u{k}_{lang}", register=False)
            dig(f"law:string_u{k}:{lang}", law.evaluate_raw(n[:300], p[:300], rng.uniform(0, 1, (300, k))))


def methods(rng):
    m = 3000
    rows = MS.pack_inputs(m, world_pos=rng.uniform(-1, 1, (m, 3)), uv=rng.uniform(0, 1, (m, 2)),
                          J=rng.uniform(-1e-3, 1e-3, (m, 4)), n=[0, 0, 1], t=[1, 0, 0], b=[0, 1, 0],
                          view=rng.uniform(-3, 3, (m, 3)) + [0, 0, 4], light=[0, 0.6, 0.8],
                          h=[0, 0.3, 0.9539392], pixel=np.arange(2 * m).reshape(m, 2) % 97, frame=3, seed=11)
    for lang in LANGS:
        for params in ({}, {"shape": 1}, {"noise": 1}):
            dig(f"method:wb16{params}:{lang}", MS.wb16_method(lang, **params).run(rows))
    sc = si.with_directional_light(si._scene_of("plane_25").scaled(0.05, keep_n=True))
    inp = si.frame_inputs(sc)
    frame_rows, _ = MS.frame_rows(dataclasses.replace(inp, hit=inp.mask), seed=1)
    facets = Material.of(sc)
    kpt = dataclasses.replace(facets, density=method_density("kpt25_shader", facets))
    for lang in LANGS:
        dig(f"method:db23:{lang}", CS.db23_method(facets, language=lang).shade(frame_rows))
        dig(f"method:kpt25:{lang}", CS.kpt25_method(kpt, language=lang).shade(frame_rows))
        vec = "float3" if lang == "hlsl" else "vec3"
        user = f"{vec} glint(GlintInput g) {{ return abs(g.view) * float(g.seed % 7u) + g.uv.x; }}\n"
        dig(f"method:user_colour:{lang}", gl.shader_method(user, language=lang, register=False).run(rows))
        ndf = "float glint(GlintInput g) { return GLINTLAB_ALPHA * abs(g.h.z) + float(g.pixel.x); }\n"
        method = gl.shader_method(ndf, language=lang, register=False, returns="ndf", material=facets)
        dig(f"method:user_ndf:{lang}", method.shade(rows))


def samplers(rng):
    h = rng.normal(size=(2000, 3))
    h[:, 2] = np.abs(h[:, 2])
    h /= np.linalg.norm(h, axis=1)[:, None]
    for name in sorted(SS.SHIPPED_SAMPLERS):
        for lang in LANGS:
            s = SS.shader_sampler(SS.shipped_sampler(name, lang), defines={"ALPHA": 0.4})
            x, pdf = s.sample(5000, seed=9)
            dig(f"sampler:{name}:{lang}:sample", np.concatenate([x.ravel(), pdf]))
            dig(f"sampler:{name}:{lang}:pdf", s.pdf(h))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="JSON file the digests are written to")
    parser.add_argument("--compare", help="digests of another build: exit 1 if any differs")
    args = parser.parse_args()
    rng = np.random.default_rng(17)
    laws(rng)
    methods(rng)
    samplers(rng)
    digests["device"] = gl.vulkan_devices()[0]["name"] if gl.vulkan_devices() else "none"
    with open(args.out, "w") as f:
        json.dump(digests, f, indent=1, sort_keys=True)
    print(f"{len(digests)} digests -> {args.out}")
    if args.compare:
        with open(args.compare) as f:
            before = json.load(f)
        differ = sorted(k for k in set(before) | set(digests) if before.get(k) != digests.get(k))
        for k in differ:
            print(f"DIFFERS {k}: {before.get(k)} -> {digests.get(k)}")
        print("all digests equal" if not differ else f"{len(differ)} differ")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
