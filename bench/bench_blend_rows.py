"""The blend rows of bench_paths.py alone, for a loaded machine: each ratio (blend ns / inner batch ns)
comes from one blend call and its baseline timed back to back, repeated; the median ratio is printed.

    ./.venv/bin/python bench/bench_blend_rows.py [--pixels 1000000] [--repeats 3]

Rows: every rule with `gated` inside at one footprint area (P = 4, on a level: w = 0, as bench_paths;
P = 8, w = 1/2, where both levels are thinned; P = 409, hundreds of base cells, whose levels' step tables
the blend keeps across calls) and with P per sample (log-uniform over [1, 16] and over [200, 800]),
against `gated`'s batch at (n, p) = (4e4, 0.01), on one and two threads. --cpu: ratios of process CPU
time instead of wall-clock time (on a loaded machine the wall clock of a long call counts the time it
waits for a core)."""
import argparse
import math
import statistics
import time

import numpy as np

import glintlab as gl


def best(fn, calls=2, clock=time.perf_counter):
    t = math.inf
    for _ in range(calls):
        t0 = clock()
        fn()
        t = min(t, clock() - t0)
    return t


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pixels", type=int, default=10**6)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--rules", default="distributed,zk16_linear,roulette,nearest")
    ap.add_argument("--cpu", action="store_true", help="process CPU time instead of the wall clock")
    args = ap.parse_args(argv)
    clock = time.process_time if args.cpu else time.perf_counter
    M = args.pixels
    N, p = 1e4, 0.01
    P = np.exp(np.random.default_rng(2).uniform(0, math.log(16), M))
    P_hundreds = np.exp(np.random.default_rng(3).uniform(math.log(200), math.log(800), M))
    law = gl.law("gated")
    default = gl.get_num_threads()
    print(f"{'row':34s} thr  blend ns  inner ns  ratio (median of {args.repeats}; each ratio back to back)")
    for rule in args.rules.split(","):
        b = gl.blended_law(rule, inner="gated")
        for label, call in (("one P = 4", lambda: b.sample(N, 4.0, p, size=M, seed=1)),
                            ("one P = 8", lambda: b.sample(N, 8.0, p, size=M, seed=1)),
                            ("one P = 409", lambda: b.sample(N, 409.0, p, size=M, seed=1)),
                            ("P per sample", lambda: b.sample(N, P, p, seed=1)),
                            ("P per sample 200-800", lambda: b.sample(N, P_hundreds, p, seed=1))):
            for t in sorted({1, default}):
                gl.set_num_threads(t)
                ratios, vs, bs = [], [], []
                for _ in range(args.repeats):
                    base = best(lambda: law.sample(4e4, p, size=M, seed=1), clock=clock) / M * 1e9
                    v = best(call, clock=clock) / M * 1e9
                    ratios.append(v / base)
                    vs.append(v)
                    bs.append(base)
                gl.set_num_threads(default)
                print(f"{rule + ' ' + label:34s} {t:3d} {statistics.median(vs):9.1f} {statistics.median(bs):9.2f} "
                      f"{statistics.median(ratios):6.1f}x  ({', '.join(f'{r:.1f}' for r in ratios)})", flush=True)


if __name__ == "__main__":
    main()
