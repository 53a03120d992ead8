"""``glintlab aniso``: anisotropic grid schemes against stratified facets in the ellipse."""
from __future__ import annotations

from ..report.runner import write_section_files
from ..studies import aniso
from ..studies.base import Context
from .common import add_outputs, add_samples, add_seed, print_table


def add_parser(sub):
    p = sub.add_parser("aniso", help="anisotropic grid schemes against stratified facets in the ellipse",
                       description="DB23's trilinear and tetrahedral grids (area or log LOD weights, the shader's "
                                   "48-evaluation interpolation) and the ZK16 baseline against the exact ground "
                                   "truth over (n, r, phi, p): mean bias, variance ratio, TV, chi-square p; weight "
                                   "maps; a 1920 x 1080 image timed per scheme with its evaluation histogram.")
    p.add_argument("--full", action="store_true", help="the full grid (5 n, 14 r, 16 phi, p 0.1 and 0.5)")
    add_samples(p, "draws per point (default: 10000, 40000 with --full)")
    add_seed(p)
    p.add_argument("--no-image", action="store_true", help="skip the image timing")
    add_outputs(p, "out/aniso", plugins=False)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    tables = aniso.command_tables(full=args.full, samples=args.samples, seed=args.seed, image=not args.no_image)
    paths = write_section_files(tables, aniso.figures, Context(args.out, args.seed))
    if not args.quiet:
        print_table(tables["aniso_summary"], args.quiet)
        if "aniso_image" in tables:
            print_table(tables["aniso_image"], args.quiet)
        print(f"\nwrote {', '.join(str(p) for p in paths)} and CSV tables in {args.out}")
    return 0
