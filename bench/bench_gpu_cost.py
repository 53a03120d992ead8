#!/usr/bin/env python3
"""How long ``glintlab cost`` takes: one shader for three architectures (issue 39's budget: under 5 s), each
run a fresh process (the null devices and the kernels are made once per process, so only a fresh one pays
what a user's command pays).

``python bench/bench_gpu_cost.py [--shader zk16_shader] [--repeats 3]`` prints, per variant, the best wall
time and the CPU time (user + system, the children's rusage) of ``--repeats`` runs, and the load average
(the machine's other work stretches the wall time, not the CPU time):

* ``import``: ``import glintlab.cli.main`` alone, what every command pays;
* ``cost``: ``glintlab cost SHADER --arch navi10 --arch navi21 --arch gfx1100 --quiet``;
* ``sequential``: the same compiles one after another on one thread (the architectures' devices made at
  their first compile, the kernel's SPIR-V before any device): the baseline the ``cost`` path is
  measured against, as the ratio of its wall time over the baseline's.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time

ARCHS = ("navi10", "navi21", "gfx1100")

SEQUENTIAL = """
import sys
import glintlab.cli.main  # the command's import, so that the two differ by their compiles only
from glintlab.api import gpu_cost as G
obj = G.resolve_shader(sys.argv[1])
empty = G.empty_twin(obj)
for arch in sys.argv[2:]:
    G.compile_stats(obj.spirv, arch)
    G.compile_stats(empty.spirv, arch)
"""


def run_once(cmd: list[str]) -> tuple[float, float]:
    """(wall s, CPU s) of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shader", default="zk16_shader", help="a shipped shader's name or a file")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    arch_args = [a for arch in ARCHS for a in ("--arch", arch)]
    variants = {
        "import": [sys.executable, "-c", "import glintlab.cli.main"],
        "cost": [sys.executable, "-m", "glintlab.cli.main", "cost", args.shader, *arch_args, "--quiet"],
        "sequential": [sys.executable, "-c", SEQUENTIAL, args.shader, *ARCHS],
    }
    best = {}
    for name, cmd in variants.items():
        runs = [run_once(cmd) for _ in range(args.repeats)]
        best[name] = min(runs)
        wall, cpu = best[name]
        print(f"{name:11s} best of {args.repeats}: wall {wall:5.2f} s, CPU {cpu:5.2f} s "
              f"(load average {os.getloadavg()[0]:.1f}, {os.cpu_count()} cores)", flush=True)
    ratio = best["cost"][0] / best["sequential"][0]
    print(f"glintlab cost {args.shader} for {', '.join(ARCHS)}: wall {best['cost'][0]:.2f} s "
          f"({ratio:.2f} x the sequential baseline's), CPU {best['cost'][1]:.2f} s; "
          f"budget 5 s: {'met' if best['cost'][0] < 5 else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
