"""``glintlab cost``: a shader's kernel compiled by a real GPU compiler (RADV's ACO, no GPU needed) for
each named AMD architecture: instructions, registers, occupancy and ACO's cycle estimates, the
wrapper's share apart, the ISA on request (docs/guide/gpu_cost.md)."""
from __future__ import annotations

import re
import sys
from pathlib import Path

from ..api import checks as V
from ..api.gpu_cost import DEFAULT_ARCHS, gpu_architectures, gpu_cost
from .common import add_shader_options, print_table, shader_options

COLUMNS = ("arch", "wave_size", "instructions", "vgprs", "sgprs", "spilled_vgprs", "waves_per_simd", "latency",
           "inverse_throughput", "code_size", "wrapper_latency", "function_latency", "function_instructions")


def add_parser(sub):
    p = sub.add_parser("cost", help="a shader compiled for AMD GPUs by RADV/ACO without a GPU: registers, occupancy, cycles",
                       description="Compiles the kernel glintlab runs for FILE (a counting law, a method shader or a "
                                   "sampler; its kind from its code) or a shipped NAME (gated, db23_shader, zk16_shader, "
                                   "ggx_vndf, ...) with Mesa's RADV null devices (ACO, the compiler of AMD GPUs on "
                                   "Linux; nothing runs) and prints per architecture its instructions, VGPRs, SGPRs, "
                                   "spills, waves per SIMD and ACO's latency and inverse throughput (cycles per wave), "
                                   "with glintlab's wrapper measured apart. Exit 2: bad input, an unknown "
                                   "architecture or no RADV.")
    p.add_argument("shader", nargs="?", help="a shader file or a shipped shader's name")
    p.add_argument("--arch", action="append", metavar="ARCH",
                   help=f"an architecture (repeatable; default: {', '.join(DEFAULT_ARCHS)}); --list-archs lists them")
    p.add_argument("--list-archs", action="store_true", help="list the architectures and exit")
    p.add_argument("--kind", choices=["law", "method", "sampler"], help="the file's contract (default: from its code)")
    p.add_argument("--entry", help="the function (default: count for a law, glint for a method)")
    p.add_argument("--lang", choices=["hlsl", "glsl"], help="the language (default: from the extension)")
    p.add_argument("--uniforms", type=int, help="a law's uniforms, 0 to 4 (default: 2)")
    add_shader_options(p)
    p.add_argument("--isa", metavar="DIR", help="write each architecture's ISA (.s) and ACO IR (.aco) into DIR")
    p.add_argument("--csv", metavar="FILE", help="also write the table as CSV")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    if args.list_archs:
        print_table(gpu_architectures(), False)
        return 0
    if args.shader is None:
        V.fail("SHADER", None, "a shader file or a shipped shader's name")
    shader = shader_options(args)
    options = {"entry": args.entry, "language": args.lang, "n_uniforms": args.uniforms,
               "defines": shader["defines"] or None, "include_dirs": shader["include_dirs"] or None,
               "device": shader["device"]}
    try:
        table = gpu_cost(args.shader, arch=args.arch or DEFAULT_ARCHS, isa=bool(args.isa), kind=args.kind, **options)
    except RuntimeError as exc:  # no RADV (or no Vulkan to build the kernel): the environment, exit 2
        known = ", ".join(gpu_architectures().arch)
        print(f"glintlab cost: {str(exc).strip().splitlines()[0]}; glintlab's architectures: {known}", file=sys.stderr)
        return 2
    if args.isa:
        folder = Path(args.isa)
        folder.mkdir(parents=True, exist_ok=True)
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(str(table.shader.iloc[0])).name)
        for row in table.itertuples():
            (folder / f"{stem}.{row.arch}.s").write_text(row.isa, encoding="utf-8")
            (folder / f"{stem}.{row.arch}.aco").write_text(row.aco_ir, encoding="utf-8")
        table = table.drop(columns=["isa", "aco_ir"])
    if args.csv:
        table.to_csv(args.csv, index=False)
    if not args.quiet:
        print(f"{table.shader.iloc[0]}: compiled by {table.driver.iloc[0]} (RADV null devices, ACO; nothing ran)")
        print_table(table[[c for c in COLUMNS if c in table.columns]], False)
        if args.isa:
            print(f"wrote the ISA into {args.isa}")
    return 0
