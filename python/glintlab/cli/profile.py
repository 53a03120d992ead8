"""``glintlab profile``: scenes' regime maps, law errors and the SIMD cost of grid schemes."""
from __future__ import annotations

import time

from ..api.laws import parse_law_label
from ..report.runner import write_section_files
from ..studies import scenes as scene_study
from ..studies.base import Context
from ..validation.advisor import advice_table
from ..validation.profile import profile_scene
from ..validation.scene import load_scene
from .common import add_costs, add_outputs, add_scale, add_scenes, add_seed, print_table, scene_costs


def add_parser(sub):
    p = sub.add_parser("profile", help="profile scenes: regime map, law errors, SIMD cost of grid schemes",
                       description="Per scene (data/schema/scene.schema.json): the (n, p, r) regime map, exact "
                                   "pixel-weighted law errors, evaluations and weight bias per grid scheme, a SIMD "
                                   "cost model (8 x 4 groups cost their worst pixel) and ZK16 / DB23 cost ratios. "
                                   "Writes CSV tables and PNG figures.")
    add_scenes(p)
    add_scale(p, 1.0, "resolution factor per side; the density follows so n per pixel is kept (default: 1)")
    p.add_argument("--max-tv", type=float, default=0.05, help="budget of the advisor table (default: 0.05)")
    add_costs(p, "law costs (law, ns_per_eval, ns_per_trial), e.g. a scene_cost_units.csv, instead of the "
                 "costs recorded with the package; 'measure' times the laws in this process (then the "
                 "costs follow the machine's load)")
    add_seed(p)
    add_outputs(p, "out/scenes", plugins=False)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    scenes = [load_scene(path) for path in args.scenes]  # all validated before any work
    costs = scene_costs(args.costs)
    laws = None if costs is None or isinstance(costs, str) else [parse_law_label(x) for x in costs.law]
    profiles = []
    for sc in scenes:
        t0 = time.perf_counter()
        profiles.append(profile_scene(sc, laws=laws, seed=args.seed, scale=args.scale, costs=costs))
        if not args.quiet:
            prof = profiles[-1]
            print(f"{sc.name}: {prof.summary['width']} x {prof.summary['height']} profiled in "
                  f"{time.perf_counter() - t0:.2f} s ({', '.join(f'{k} {v:.2f}' for k, v in prof.seconds.items())})")
    note = f" (scale {args.scale:g}, density x {args.scale ** 2:g} to keep n)" if args.scale != 1 else ""
    tables = scene_study.command_tables(profiles, advice=advice_table(profiles, max_tv=args.max_tv), title_note=note)
    paths = write_section_files(tables, scene_study.figures, Context(args.out, args.seed))
    tables = tables.tables
    if not args.quiet:
        print_table(tables["scene_table1"][["scene", "method", "mean_pixel", "mean_group", "worst_group",
                                            "simd_efficiency", "zk16_over_this_worst_group", "paper_ms"]], args.quiet)
        print_table(tables["scene_advice"][["scene", "max_tv", "law", "cost_mean_group", "tv_worst"]], args.quiet)
        print(f"\nwrote {len(paths)} figures and {len(tables)} CSV tables in {args.out}")
    return 0
