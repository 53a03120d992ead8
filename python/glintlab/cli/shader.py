"""``glintlab shader``: a shader's counting function run on Vulkan, its verdict (exit 0/1/2) and report."""
from __future__ import annotations

import math
import sys
from pathlib import Path

from ..api.shaders import ShaderOutputError, emit_shader, shader_law
from ..report.runner import write_section_files
from ..studies.base import Context
from ..studies.shaders import verdict_files, verdict_tables
from ..validation.bounds import check
from ..validation.references import resolve_law
from ..validation.shader_check import shader_verdict
from .common import (add_count, add_outputs, add_resource_options, add_samples, add_seed, add_shader_options,
                     load_plugins, print_table, resource_options, shader_options)
from ..api import checks as V

COUNTS = ("samples", "grid_samples", "grid_stride", "rows", "speed_evaluations")


def add_parser(sub):
    p = sub.add_parser("shader", help="a shader's counting function run on Vulkan: verdict (exit 0/1/2) and report",
                       description="Compiles FILE (HLSL or GLSL defining float ENTRY(float n, float p, float4 u)) "
                                   "inside glintlab's compute kernel, runs it on a Vulkan device (lavapipe without a "
                                   "GPU) and measures it: chi-square and TV against the exact pmf of --against at "
                                   "DB23's Figure 9 points, a TV map over the standard grid, row-by-row agreement "
                                   "with --twin, the extremes suite, ns per evaluation. Exit 0: every check passes; "
                                   "1: one fails; 2: bad input (a compile error, an unknown law).")
    p.add_argument("file", nargs="?", help="the shader source file (.hlsl, .glsl, ...; always a path, never code)")
    p.add_argument("--emit", metavar="NAME", help="print the shipped shader NAME (or its law's name) in --lang (default hlsl) "
                   "as one self-contained file, includes inlined, and exit")
    p.add_argument("--entry", default="count", help="the counting function (default: count)")
    p.add_argument("--lang", choices=["hlsl", "glsl"], help="the language (default: from the extension)")
    p.add_argument("--uniforms", type=int, default=2, help="uniforms the function reads, 0 to 4 (default: 2)")
    p.add_argument("--against", default="binomial", help="the law the shader claims to approximate (default: binomial)")
    p.add_argument("--twin", help="a C++ law computing the same in float32, compared row by row")
    add_shader_options(p)
    p.add_argument("--bounds", metavar="B.json", help="also check these error bounds, the shader standing in for --against")
    add_samples(p, "draws per Figure 9 point (default: 1e6)", 10**6)
    add_count(p, "--grid-samples", "draws per standard-grid point (default: 4096)", 4096)
    add_count(p, "--grid-stride", "every k-th n and p of the standard grid (default: 2)", 2)
    add_count(p, "--rows", "rows per point compared with --twin (default: 1e6)", 10**6)
    add_count(p, "--speed-evaluations", "evaluations per timed call (default: 1e6)", 10**6)
    add_resource_options(p)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds a kernel submission may run (default: 60)")
    add_seed(p)
    add_outputs(p, "out/shader")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    load_plugins(args.plugin)
    if args.emit:  # a shipped shader as one paste-ready file, nothing measured
        print(emit_shader(args.emit, args.lang or "hlsl"), end="")
        return 0
    if args.file is None:
        V.fail("FILE", None, "a shader file (or --emit NAME for a shipped shader)")
    for flag in COUNTS:
        if getattr(args, flag) < 1:
            V.fail(f"--{flag.replace('_', '-')}", getattr(args, flag), "an integer >= 1")
    if not (args.timeout > 0 and math.isfinite(args.timeout)):
        V.fail("--timeout", args.timeout, "seconds > 0")
    try:  # FILE is always a path, never code (a mistyped name is reported missing)
        law = shader_law(Path(args.file), entry=args.entry, language=args.lang, n_uniforms=args.uniforms,
                         timeout=args.timeout, **shader_options(args), **resource_options(args))
    except RuntimeError as exc:  # no Vulkan device: the environment, not the shader
        print(f"glintlab shader: {exc}", file=sys.stderr)
        return 2
    for name in [args.against] + ([args.twin] if args.twin else []):
        resolve_law(name)  # an unknown law is bad input (exit 2) before any measurement
    if not args.quiet:
        print(f"{args.file}: compiled ({law.language}, entry {law.entry}); device: {law.device}")
    verdict = shader_verdict(law, against=args.against, twin=args.twin, samples=args.samples,
                             grid_samples=args.grid_samples, grid_stride=args.grid_stride, seed=args.seed,
                             rows=args.rows, speed_evaluations=args.speed_evaluations)
    if args.bounds:
        try:
            table = check(args.bounds, substitute={args.against: law, law.name: law}, progress=False)
        except ShaderOutputError as exc:  # the shader's NaN or negative count: a failed check
            verdict["failures"].append(f"bounds: {exc}")
        else:
            verdict["tables"]["bounds"] = table
            verdict["failures"] += [f"bound {r.id}: {r.metric} = {r.worst:.6g} at n = {r.at_n:g}, p = {r.at_p:g} "
                                    f"(bound {r.bound:.6g})" for r in table[~table.ok].itertuples()]
    path = write_section_files(verdict_tables(verdict, law, args.against, args.twin), verdict_files,
                               Context(args.out, args.seed))[-1]
    if not args.quiet:
        print_table(verdict["tables"]["points"], False)
        if "rows" in verdict["tables"]:
            print_table(verdict["tables"]["rows"], False)
        print_table(verdict["tables"]["speed"], False)
        print(f"\nwrote {path}")
    for failure in verdict["failures"]:
        print(f"glintlab shader: FAIL {failure}", file=sys.stderr)
    if verdict["caveat"]:
        print(f"glintlab shader: NOTE not what a GPU would compute: {verdict['caveat']}", file=sys.stderr)
    if not args.quiet:
        print("verdict: " + ("FAIL" if verdict["failures"] else f"pass (against {args.against})") +
              ("" if verdict["gpu_faithful"] else " (on lavapipe, not what a GPU would compute: see the note)"))
    return 1 if verdict["failures"] else 0
