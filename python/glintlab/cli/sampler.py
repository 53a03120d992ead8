"""``glintlab sampler``: a direction sampler against its pdf, chi-square on adaptive bins (exit 0/1/2)."""
from __future__ import annotations

import sys

from ..api import checks as V
from ..api.samplers import SAMPLERS, WRONG_KINDS, load_sampler, wrong_sampler
from ..api.shaders import ShaderOutputError
from ..validation.sampler_test import sampler_test
from .common import (add_outputs, add_resource_options, add_samples, add_seed, add_shader_options,
                     given_resource_options, given_shader_options, resource_options, shader_options)


def add_parser(sub):
    p = sub.add_parser("sampler", help="a direction sampler against its pdf: chi-square on adaptive bins (exit 0/1/2)",
                       description="Tests a registered sampler (gl.samplers(): beckmann, ggx, ggx_vndf, "
                                   "beckmann_vndf, vmf_mixture) or a sampler file against its pdf "
                                   "(docs/math/sampling.md). Exit 0 pass, 1 fail or inconclusive, 2 bad input. On "
                                   "failure the bins (NPZ, CSV) and a figure are written to --out.")
    p.add_argument("sampler", metavar="NAME_OR_FILE",
                   help="a registered sampler name or a sampler file (a shader sampler: .hlsl, .glsl; "
                        "--param NAME=VALUE sets wo, uv, J or a define, e.g. ALPHA=0.5)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="a sampler parameter (repeatable): alpha=0.3, wo=0.6,0,0.8")
    add_samples(p, "samples (default: 1e6)", default=10**6)
    add_seed(p, help="seed (default: 1)")
    add_resource_options(p)
    p.add_argument("--bins", default="adaptive", help="'adaptive' (default) or a fixed grid N1xN2, e.g. 30x60")
    p.add_argument("--significance", type=float, default=1e-3,
                   help="fail below this p-value (the false-failure rate; default 1e-3)")
    p.add_argument("--write-always", action="store_true", help="write the bins and figure even on a pass")
    p.add_argument("--domain", choices=("half", "reflected"),
                   help="for a shader sampler, the directions tested: half (half vectors, sample_h's default) or "
                        "reflected (sample_l's, and sample_h's draws as l = 2 (wo.h) h - wo with pdf_h / (4 wo.h), "
                        "glintlab's conversion); the contract is read from the functions the file defines")
    p.add_argument("--clamp-pdf", action="store_true",
                   help="for a shader sampler, read a pdf that is negative or NaN only where wo.h < 0 (where a "
                        "visible-normal sampler never draws) as 0 there, reported in the notes")
    add_shader_options(p)
    p.add_argument("--wrong", metavar="KIND",
                   help="test a deliberately wrong variant of the sampler instead (it must fail: exit 1), one of "
                        "those the sampler declares (" + ", ".join(WRONG_KINDS) + " for the microfacet samplers; "
                        "drop_0.1%% for any)")
    add_outputs(p, "out/sampler", plugins=False)
    p.set_defaults(func=run)
    return p


def sampler_params(items):
    """--param k=v (repeatable): numbers, comma-separated tuples of numbers, or strings."""
    params = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            V.fail("--param", item, "NAME=VALUE (e.g. alpha=0.3, wo=0.6,0,0.8)")
        parts = value.split(",")
        try:
            nums = [float(p) for p in parts]
            params[key] = tuple(nums) if len(nums) > 1 else (int(nums[0]) if parts[0].strip().lstrip("-").isdigit()
                                                             else nums[0])
        except ValueError:
            params[key] = value
    return params


def check_sampler(sampler, args) -> int:
    """Runs the harness on a sampler object with the command's options and prints the verdict: the exit
    status (0 pass, 1 fail or inconclusive). The hook for every kind of sampler (registered by name,
    shader files)."""
    bins = args.bins
    if bins != "adaptive":
        try:
            bins = tuple(int(x) for x in bins.lower().split("x"))
        except ValueError:
            V.fail("--bins", args.bins, "'adaptive' or a grid N1xN2 (e.g. 30x60)")
    res = sampler_test(sampler, samples=args.samples, seed=args.seed, bins=bins, significance=args.significance,
                       out=args.out, write="always" if args.write_always else "failure")
    if not args.quiet:
        print(repr(res))
        for path in res.files:
            print(f"wrote {path}")
    caveat = getattr(sampler, "loop_caveat", None)
    if caveat:  # as glintlab shader: lavapipe cuts loops short, a GPU would not
        print(f"glintlab sampler: NOTE not what a GPU would compute: {caveat}", file=sys.stderr)
    if res.inconclusive:
        print(f"glintlab sampler: INCONCLUSIVE {res.name}: {res.note}", file=sys.stderr)
    elif not res.passed:
        print(f"glintlab sampler: FAIL {res.name}: p = {res.pvalue:.4g}" + (f" ({res.note})" if res.notes else ""),
              file=sys.stderr)
    elif not args.quiet:
        print(f"verdict: pass (p = {res.pvalue:.4g} >= {args.significance:g})")
    return 0 if res.passed else 1


def shader_sampler_params(args) -> dict:
    """The flags that only a shader sampler file takes, as its loader's keywords; refused by name for a
    registered sampler, which compiles nothing."""
    given = {**given_shader_options(args), **given_resource_options(args), "--domain": args.domain,
             "--clamp-pdf": args.clamp_pdf or None}
    given = {flag: value for flag, value in given.items() if value is not None}
    if args.sampler in SAMPLERS:
        for flag, value in given.items():
            V.fail(flag, value, f"no {flag} for a registered sampler ({args.sampler}): it is a flag of shader "
                                "sampler files")
        return {}
    options = shader_options(args)
    params = {**options.pop("defines"), **options,
              **{k: given for k, given in resource_options(args).items() if given}}
    if args.domain:
        params["directions"] = args.domain
    if args.clamp_pdf:
        params["clamp_pdf"] = True
    return params


def run(args) -> int:
    V.integer("--samples", args.samples, minimum=1)
    try:
        s = load_sampler(args.sampler, **sampler_params(args.param), **shader_sampler_params(args))
    except RuntimeError as exc:  # no Vulkan device for a shader sampler: the environment, not the sampler
        print(f"glintlab sampler: {str(exc).strip().splitlines()[0]}", file=sys.stderr)
        return 2
    if args.wrong is not None and args.wrong not in s.wrong_variants:
        V.fail("--wrong", args.wrong, f"one of the wrong variants {s.name} declares: "
                                      + (", ".join(s.wrong_variants) or "none"))
    try:
        return check_sampler(wrong_sampler(s, args.wrong) if args.wrong else s, args)
    except ShaderOutputError as exc:  # a shader sampler's NaN or negative pdf: a failed check, not bad input
        print(f"glintlab sampler: FAIL {exc}", file=sys.stderr)
        return 1
