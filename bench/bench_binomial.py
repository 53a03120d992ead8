#!/usr/bin/env python3
"""`make bench`: ns per sample of glintlab's exact binomial sampler against numpy and the C++ std.

One run measures, at the issue's four (n, p) points and for one call of --size samples:
  numpy       numpy.random.Generator(PCG64).binomial(int(n), p, size), one thread;
  std C++     std::binomial_distribution<long long> on std::mt19937_64, one thread (C++ binary);
  gl Py 1T    gl.law("binomial").sample(n, p, size=size, seed=...) after gl.set_num_threads(1);
  gl Py <T>T  the same call on glintlab's default threads (all cores, or $GLINTLAB_NUM_THREADS);
  gl C++ 1T   binomial::Sampler in a plain loop, one thread (C++ binary);
  gl C++ <T>T sample_many, the driver behind law.sample(), without Python (C++ binary).
Each time is the best (minimum) of --repeats calls: noise from other processes only ever adds time.
A multi-threaded call that visibly did not get its cores is repeated (up to RETRIES more times per
repeat, every attempt recorded in the JSON file).
The Python calls are interleaved (numpy, gl default threads, gl 1 thread, numpy, ...) so that a
burst of load from elsewhere hits all of them alike.

The target (project issue): faster than numpy at every point, from Python, for a 1e7-sample call,
with glintlab on its default threads. A sanity check guards the timings: glintlab's sample mean and
variance must be within 5 standard errors of n p and n p q, so a broken sampler cannot look fast.
The baselines get the same check, reported but not held against glintlab (GCC 12's
std::binomial_distribution fails it at n p ~ 10: its rejection branch, used from n p >= 8, has a
mean bias of about +0.016).

The machine is shared, so the run also records how many cores each multi-threaded call actually got
(process CPU time / wall time) and how busy the other processes kept the machine; a multi-threaded
time measured while another process held a core is flagged rather than silently reported.

This is a benchmark, not a test: it exits 0 whenever the measurements complete, PASS or FAIL.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import glintlab as gl

POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6)]
TARGET_SIZE = 10**7
# Sanity limit on |sample mean - n p| in standard errors: a correct sampler exceeds it with
# probability ~6e-7 per check.
Z_LIMIT = 5.0
REPO = Path(__file__).resolve().parents[1]
# A multi-threaded call is "starved" when its process CPU time / wall time is below STARVED x its
# threads; that is only judged for calls of at least MIN_JUDGED_S (other threads' CPU time is
# accounted at ticks and context switches, too coarsely for shorter calls).
STARVED, MIN_JUDGED_S, RETRIES = 0.85, 0.05, 3


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cpp", type=Path, default=REPO / "build/bench/glintlab_bench_binomial",
                    help="the C++ benchmark binary (default: %(default)s)")
    ap.add_argument("--size", type=int, default=TARGET_SIZE,
                    help="samples per call (default: 10**7, the target's size)")
    ap.add_argument("--repeats", type=int, default=3,
                    help="timed calls per method; the best is kept (default: 3)")
    ap.add_argument("--seed", type=int, default=1, help="seed of every generator (default: 1)")
    ap.add_argument("--json", type=Path, default=Path("out/bench/binomial.json"),
                    help="where to write all measurements (default: %(default)s)")
    args = ap.parse_args(argv)
    if args.size < 1 or args.repeats < 1:
        ap.error("--size and --repeats must be >= 1")
    if not 0 <= args.seed < 2**64:
        ap.error("--seed must be in [0, 2^64)")
    if not args.cpp.is_file():
        ap.error(f"--cpp {args.cpp}: no such file (build it with: make build)")
    return args


def run_cpp(path: Path, size: int, repeats: int, seed: int) -> dict:
    """Runs the C++ benchmark binary and returns its JSON document."""
    cmd = [str(path), "--size", str(size), "--repeats", str(repeats), "--seed", str(seed)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(f"bench_binomial: {' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}")
    return json.loads(proc.stdout)


def time_python(n: float, p: float, size: int, repeats: int, seed: int, threads: int) -> dict:
    """Times numpy and glintlab (on 1 and on `threads` threads) at one point: best and median
    ns/sample, cores of the best call, every attempt, and the last output's mean and variance."""
    rng = np.random.Generator(np.random.PCG64(seed))
    law = gl.law("binomial")
    calls = {
        "numpy": (1, lambda: rng.binomial(int(n), p, size)),
        "gl_py_mt": (threads, lambda: law.sample(n, p, size=size, seed=seed)),
        "gl_py_1t": (1, lambda: law.sample(n, p, size=size, seed=seed)),
    }
    try:
        # One untimed full-size call each: starts OpenMP's threads and lets the process obtain its
        # memory once (without it, the first full-size calls in a process measured several ns per
        # sample slower here, which favoured whichever method ran later).
        for t, call in calls.values():
            gl.set_num_threads(t)
            call()  # the result is dropped at once
        runs = {k: [] for k in calls}  # (ns per sample, cores used) per call
        last = {}
        for _ in range(repeats):
            for k, (t, call) in calls.items():
                gl.set_num_threads(t)
                for _attempt in range(1 + (RETRIES if t > 1 else 0)):
                    last.pop(k, None)  # free the previous output: each call allocates fresh memory
                    c0, t0 = time.process_time_ns(), time.perf_counter_ns()
                    last[k] = call()
                    t1, c1 = time.perf_counter_ns(), time.process_time_ns()
                    cores = (c1 - c0) / (t1 - t0)
                    runs[k].append(((t1 - t0) / size, cores))
                    if cores >= STARVED * t or (t1 - t0) < MIN_JUDGED_S * 1e9:
                        break
    finally:
        gl.set_num_threads(threads)
    out = {}
    for k, v in runs.items():
        best = sorted(v)
        out[k] = {"ns_per_sample": best[0][0], "median_ns_per_sample": best[len(v) // 2][0],
                  "cores": best[0][1], "mean": float(last[k].mean()),
                  "var": float(last[k].var(ddof=1)), "runs": v}
    return out


def sanity(mean: float, var: float, n: float, p: float, size: int) -> tuple[float, float, float]:
    """Relative error of the sample mean against n p, the same error in standard errors, and the
    error of the sample variance against n p q in standard errors."""
    mu, v = n * p, n * p * (1 - p)
    # Var(sample variance) ~ (mu4 - v^2) / size, with the binomial's central fourth moment
    # mu4 = v (1 + 3 (n - 2) p q), so mu4 - v^2 = v (1 - 6 p q) + 2 v^2.
    var_se = math.sqrt((v * (1 - 6 * p * (1 - p)) + 2 * v * v) / size)
    return (mean - mu) / mu, (mean - mu) / math.sqrt(v / size), (var - v) / var_se


def busy_seconds() -> float | None:
    """CPU seconds all processes have spent busy since boot (/proc/stat), or None off Linux."""
    try:
        fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
    except OSError:
        return None
    user, nice, system, idle, iowait, irq, softirq, steal = (int(x) for x in fields[:8])
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def own_cpu_seconds() -> float:
    """CPU seconds of this process and its finished children (the C++ binary)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def short(x: float) -> str:
    """1e6 rather than 1e+06 in labels."""
    return f"{x:g}".replace("e+0", "e").replace("e+", "e").replace("e-0", "e-")


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def measure_point(n: float, p: float, args, threads: int, cpp_by_point: dict) -> dict:
    """Everything measured at one (n, p): ns per sample of the six methods (Python timed here, C++ from
    the binary's document), their sanity checks, the ratios of the target and the cores they got."""
    print(f"bench_binomial: Python side, n = {short(n)}, p = {short(p)} ...", file=sys.stderr,
          flush=True)
    py = time_python(n, p, args.size, args.repeats, args.seed, threads)
    c = cpp_by_point[(float(n), float(p))]
    methods = {"numpy": py["numpy"], "std_cpp": c["std"], "gl_py_1t": py["gl_py_1t"],
               "gl_py_mt": py["gl_py_mt"], "gl_cpp_1t": c["gl_1t"], "gl_cpp_mt": c["gl_mt"]}
    ns = {k: m["ns_per_sample"] for k, m in methods.items()}
    checks = {k: sanity(m["mean"], m["var"], n, p, args.size) for k, m in methods.items()}
    z = {k: max(abs(zm), abs(zv)) for k, (_, zm, zv) in checks.items()}
    sane = all(z[k] <= Z_LIMIT for k in methods if k.startswith("gl_"))
    return {
        "n": n, "p": p,
        "ns_per_sample": ns,
        "median_ns_per_sample": {k: m["median_ns_per_sample"] for k, m in methods.items()},
        "runs": {k: m["runs"] for k, m in methods.items()},  # [ns per sample, cores] each
        "mean": {k: m["mean"] for k, m in methods.items()},
        "var": {k: m["var"] for k, m in methods.items()},
        "mean_rel_err": {k: c[0] for k, c in checks.items()},
        "mean_z": {k: c[1] for k, c in checks.items()},
        "var_z": {k: c[2] for k, c in checks.items()},
        "worst_abs_z": z,  # max(|mean_z|, |var_z|)
        "ratios": {
            "numpy_over_gl_py_mt": ns["numpy"] / ns["gl_py_mt"],
            "numpy_over_gl_py_1t": ns["numpy"] / ns["gl_py_1t"],
            "std_over_gl_cpp_1t": ns["std_cpp"] / ns["gl_cpp_1t"],
        },
        # Same seed, and sample i depends only on (seed, i): Python and C++ must draw the same
        # numbers, whatever the thread count. Integer sums below 2^53 are exact, so means match
        # exactly (variances could differ in the last bits with the summation order).
        "gl_same_draws_py_cpp": methods["gl_py_mt"]["mean"] == methods["gl_cpp_mt"]["mean"]
                                == methods["gl_py_1t"]["mean"] == methods["gl_cpp_1t"]["mean"],
        "sane": sane,  # glintlab's outputs; the baselines' z scores are in worst_abs_z
        "cores": {k: methods[k]["cores"] for k in ("gl_py_mt", "gl_cpp_mt")},
        "faster_than_numpy": sane and ns["gl_py_mt"] < ns["numpy"],
    }


def judged_cores(pt: dict, k: str, size: int) -> float:
    """Cores the best call of method k got at point pt, or nan for a call too short to judge: process
    CPU time includes other threads' time only as of their last tick or context switch, so the ratio
    means something only for calls well above a tick (50 ms here)."""
    long_enough = pt["ns_per_sample"][k] * size >= MIN_JUDGED_S * 1e9
    return pt["cores"][k] if long_enough else math.nan


def summary_table(points: list, T: str, size: int) -> pd.DataFrame:
    """One row per point: ns per sample of every method, the ratios, the sanity |z| and the cores."""
    rows = []
    for pt in points:
        ns, z = pt["ns_per_sample"], pt["worst_abs_z"]
        rows.append({
            "n": short(pt["n"]), "p": short(pt["p"]),
            "numpy": ns["numpy"], "std C++": ns["std_cpp"],
            "gl Py 1T": ns["gl_py_1t"], f"gl Py {T}": ns["gl_py_mt"],
            "gl C++ 1T": ns["gl_cpp_1t"], f"gl C++ {T}": ns["gl_cpp_mt"],
            f"numpy/gl Py {T}": pt["ratios"]["numpy_over_gl_py_mt"],
            "numpy/gl Py 1T": pt["ratios"]["numpy_over_gl_py_1t"],
            "std/gl C++ 1T": pt["ratios"]["std_over_gl_cpp_1t"],
            "gl mean rel err": pt["mean_rel_err"]["gl_py_mt"],
            "gl |z|": max(v for k, v in z.items() if k.startswith("gl_")),
            "numpy |z|": z["numpy"], "std |z|": z["std_cpp"],
            f"cores Py {T}": judged_cores(pt, "gl_py_mt", size),
            f"cores C++ {T}": judged_cores(pt, "gl_cpp_mt", size),
        })
    return pd.DataFrame(rows)


def print_tables(table: pd.DataFrame, args, threads: int, other_cores: float | None) -> None:
    """The times and ratios table, then the sanity and cores table, with their legends."""
    T = f"{threads}T"
    ns_cols = ["numpy", "std C++", "gl Py 1T", f"gl Py {T}", "gl C++ 1T", f"gl C++ {T}"]
    ratio_cols = [f"numpy/gl Py {T}", "numpy/gl Py 1T", "std/gl C++ 1T"]
    check_cols = ["gl mean rel err", "gl |z|", "numpy |z|", "std |z|", f"cores Py {T}",
                  f"cores C++ {T}"]
    fmt = {**{c: "{:.1f}".format for c in ns_cols}, **{c: "x{:.2f}".format for c in ratio_cols},
           "gl mean rel err": "{:+.1e}".format,
           **{c: "{:.1f}".format for c in ["gl |z|", "numpy |z|", "std |z|"]},
           **{c: "{:.2f}".format for c in [f"cores Py {T}", f"cores C++ {T}"]}}
    print(f"binomial sampler: ns/sample, best of {args.repeats} calls of {args.size:g} samples "
          f"(seed {args.seed}); {cpu_model()}, {os.cpu_count()} cores; numpy {np.__version__}; "
          f"glintlab {gl.__version__} default threads: {threads}")
    print(table[["n", "p"] + ns_cols + ratio_cols].to_string(index=False, formatters=fmt))
    print("ratios > 1: glintlab faster (numpy and std use one thread)")
    print()
    print(table[["n", "p"] + check_cols].to_string(index=False, formatters=fmt, na_rep="-"))
    print(f"sanity: |z| = larger of |sample mean - n p| and |sample variance - n p q| in standard "
          f"errors, limit {Z_LIMIT:g} (gl: worst of its four runs).\ncores: CPU time / wall time "
          f"of the best {T} call (- if under 50 ms).")
    if other_cores is not None:
        print(f"other processes kept {other_cores:.2f} of {os.cpu_count()} cores busy on average "
              f"during this run")


def print_point_notes(points: list, threads: int, size: int) -> None:
    """Per point: a failed sanity check, biased baselines, starved calls, draws that differ."""
    for pt in points:
        where = f"({short(pt['n'])}, {short(pt['p'])})"
        bad = [k for k, v in pt["worst_abs_z"].items() if v > Z_LIMIT]
        if not pt["sane"]:
            print(f"SANITY FAIL at {where}: glintlab's sample mean or variance is off: {bad}")
        elif bad:
            print(f"note: at {where} the baseline(s) {bad} fail the sanity check: they are biased "
                  f"there, so their times are not those of an exact sampler")
        for k in pt["cores"]:
            c = judged_cores(pt, k, size)
            if threads > 1 and c < STARVED * threads:  # False for nan (too short to judge)
                print(f"warning: at {where} the best {k} call used only {c:.2f} of {threads} "
                      f"cores even after retries: another process held the CPU, so that time "
                      f"overstates the cost")
        if not pt["gl_same_draws_py_cpp"]:
            print(f"note: at {where} glintlab's sample means differ between Python and C++ or "
                  f"between thread counts with the same seed: {pt['mean']}")


def print_verdict(points: list, threads: int, size: int) -> tuple[bool, list]:
    """Prints the target's PASS or FAIL; returns it and the points that failed without all cores."""
    T = f"{threads}T"
    passed = all(pt["faster_than_numpy"] for pt in points)
    # Points that failed while another process held one of glintlab's cores: the verdict there
    # says more about the machine than about the sampler.
    starved = [short(pt["n"]) + ", " + short(pt["p"]) for pt in points
               if not pt["faster_than_numpy"] and judged_cores(pt, "gl_py_mt", size) < STARVED * threads]
    worst = min(points, key=lambda pt: pt["ratios"]["numpy_over_gl_py_mt"])
    caveat = "" if size == TARGET_SIZE else f" [measured with --size {size}, not 1e7]"
    margin = worst["ratios"]["numpy_over_gl_py_mt"]
    print(f"target: faster than numpy at every point, from Python, 1e7-sample call, {T}: "
          f"{'PASS' if passed else 'FAIL'} (smallest margin x{margin:.2f} at n = "
          f"{short(worst['n'])}, p = {short(worst['p'])}){caveat}")
    if starved:
        print(f"  (unreliable: at ({'), ('.join(starved)}) the {T} call did not get all cores; "
              f"rerun on an idle machine)")
    return passed, starved


def write_report(args, threads: int, points: list, cpp: dict, other_cores: float | None, passed: bool,
                 starved: list) -> None:
    """Every measurement, the machine and the verdict, as JSON in --json."""
    report = {
        "size": args.size, "repeats": args.repeats, "seed": args.seed,
        "statistic": "min over repeats", "threads": threads,
        "machine": {"cpu": cpu_model(), "cores": os.cpu_count(),
                    "python": platform.python_version(), "other_processes_cores_busy": other_cores},
        "versions": {"numpy": np.__version__, "glintlab": gl.__version__},
        "points": points, "cpp_raw": cpp,
        "target": {"description": "faster than numpy at every point, from Python, for a 1e7-sample "
                                  "call (glintlab on its default threads)",
                   "size_matches_target": args.size == TARGET_SIZE, "pass": passed,
                   "failed_without_all_cores": starved},
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.json}")


def main(argv=None) -> int:
    args = parse_args(argv)
    threads = gl.get_num_threads()
    busy0, own0, wall0 = busy_seconds(), own_cpu_seconds(), time.perf_counter()
    print(f"bench_binomial: C++ side ({args.cpp}) ...", file=sys.stderr, flush=True)
    cpp = run_cpp(args.cpp, args.size, args.repeats, args.seed)
    cpp_by_point = {(pt["n"], pt["p"]): pt for pt in cpp["points"]}
    points = [measure_point(n, p, args, threads, cpp_by_point) for n, p in POINTS]
    table = summary_table(points, f"{threads}T", args.size)
    other_cores = None
    busy1 = busy_seconds()
    if busy0 is not None and busy1 is not None:
        wall = time.perf_counter() - wall0
        other_cores = max(0.0, (busy1 - busy0) - (own_cpu_seconds() - own0)) / wall
    print_tables(table, args, threads, other_cores)
    print_point_notes(points, threads, args.size)
    passed, starved = print_verdict(points, threads, args.size)
    write_report(args, threads, points, cpp, other_cores, passed, starved)
    return 0


if __name__ == "__main__":
    sys.exit(main())
