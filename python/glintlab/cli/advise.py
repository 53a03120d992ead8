"""``glintlab advise``: the cheapest counting law meeting an error budget on a scene."""
from __future__ import annotations

import json
from pathlib import Path

from ..api.laws import parse_law_label
from ..validation.advisor import COST_AXES, GPU_ARCH, advise
from ..validation.profile import profile_scene
from ..validation.scene import load_scene
from .common import add_costs, add_outputs, add_scale, add_seed, print_table, scene_costs
from ..api import checks as V


def add_parser(sub):
    p = sub.add_parser("advise", help="the cheapest counting law meeting an error budget on a scene",
                       description="Profiles the scene and picks the law of least mean SIMD group cost whose "
                                   "per-pixel error meets the budget on --coverage of the pixels.")
    p.add_argument("scene", metavar="SCENE.json")
    p.add_argument("--max-tv", type=float, help="largest TV to the binomial per pixel")
    p.add_argument("--max-rel-error", type=float, help="largest relative intensity error |E[K]/(n p) - 1| per pixel")
    p.add_argument("--coverage", type=float, default=1.0, help="share of pixels that must meet it (default: 1)")
    p.add_argument("--per-regime", action="store_true", help="one law per n band, combined SIMD cost")
    p.add_argument("--scheme", default="db23_tetrahedral", help="grid scheme the cost is modelled on "
                                                                  "(default: db23_tetrahedral)")
    p.add_argument("--cost-axis", choices=list(COST_AXES), default="cpu",
                   help="cpu: the laws' recorded CPU ns per evaluation (default); gpu: their shader twins' ACO "
                        "latency in cycles on --gpu-arch (RADV null devices; the laws with a shader only)")
    p.add_argument("--gpu-arch", default=GPU_ARCH, help=f"the GPU axis's architecture (default: {GPU_ARCH}, RDNA3)")
    add_scale(p, 1.0, "resolution factor per side (default: 1)")
    add_costs(p, "law costs (law, ns_per_eval, ns_per_trial) instead of the costs recorded with the package; "
                 "'measure' times the laws in this process (then the pick may follow the machine's load)")
    add_seed(p)
    p.add_argument("--json", action="store_true", help="print the recommendation as JSON")
    add_outputs(p, None, plugins=False, out_help="none: the advice is printed, no files are written")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    for flag, value in (("--max-tv", args.max_tv), ("--max-rel-error", args.max_rel_error)):
        if value is not None and not value >= 0:
            V.fail(flag, value, "a number >= 0 (inf for no limit)")
    if args.max_tv is None and args.max_rel_error is None:
        raise ValueError("no budget given; expected --max-tv and/or --max-rel-error")
    scene = load_scene(args.scene)
    costs = scene_costs(args.costs)
    laws = None if costs is None or isinstance(costs, str) else [parse_law_label(x) for x in costs.law]
    prof = profile_scene(scene, laws=laws, seed=args.seed, scale=args.scale, costs=costs,
                         schemes=sorted({args.scheme, "zk16_aniso", "db23_tetrahedral"}))
    advice = advise(prof, max_tv=args.max_tv, max_rel_error=args.max_rel_error, coverage=args.coverage,
                    per_regime=args.per_regime, scheme=args.scheme, cost_axis=args.cost_axis, gpu_arch=args.gpu_arch)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "advice.json").write_text(json.dumps(advice.to_dict(), indent=2, default=float) + "\n")
        advice.candidates.to_csv(out / "advice_candidates.csv", index=False)
    if args.json:
        print(json.dumps(advice.to_dict(), indent=2, default=float))
        return 0
    if not args.quiet:
        print(advice)
        print_table(advice.candidates, args.quiet)
        if advice.per_regime is not None:
            a = advice.per_regime.attrs
            print(f"\nper regime (n bands), combined cost {a['cost_mean_group']:.4g} per group "
                  f"(worst {a['cost_worst_group']:.4g}; divergent groups pay each law's worst lane):")
            print_table(advice.per_regime, args.quiet)
    return 0
