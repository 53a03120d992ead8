#!/usr/bin/env python3
"""`make bench`: the paths renderers and sweeps take (project issue 21), each beside its baseline.

One run measures, from Python, every row of the issue's table with the baseline of that row timed in
the same run (numpy's binomial, the law's own batch, or the inner law), on one thread and on
glintlab's default threads, and prints the ratio the issue's goal is stated in:

  batch[law]        law.sample(n, p, size=--size) at the four benchmark points   vs numpy binomial
  per_pixel[law]    law.sample(n_array, p_array), --pixels random (n, p) of the standard grid
                    (gated, head_cf: vs the law's own batch at the four points, mean ns; binomial: vs
                    numpy's binomial on the same arrays)
  blend[rule/law]   gl.blended_law(rule, inner=law).sample(N, P, p) with P log-uniform over two levels
                    per sample                                                   vs the inner law's batch
                    (note: the bound, the inner law's per-pixel ns on the samples' level (n, p) pairs)
  blend ... one P   the same at P = 4 for every sample (each level at one (n, p)) vs the inner law's batch
  ... one P = 8     the same at P = 8 (w = 1/2: both levels drawn, both thinned by the roulette)
  ... one P = 409   hundreds of base cells (levels 4 and 5, w = 0.34; N A_l = 2.6e6 and 1e7 trials, step tables of
                    2^18 cells kept across calls: the note gives a first call's time too)
  ... P 200-800     a footprint area per sample over [200, 800] (levels 3 to 5; gated inside only: the exact
                    binomial's per-pixel draws at 1e6 trials are microseconds each)
  count_image[cfg]  AnisoCounter.count_image on a 1920 x 1080 tilted plane (gated inside): ns per pixel
                    per inner evaluation                                         vs per-pixel gated ns
  out=              the per-pixel and batch calls again with a preallocated ``out=`` buffer: the
                    share of the time that is the fresh output array's page faults.
  bound: ...        what the batch rows cannot go below: the Philox4x32-10 rows (two uniforms, one
                    block, per sample) every sampler draws, and the first touch of a fresh float64
                    array (the kernel zeroing its pages), each measured in the same run.

What is timed: the whole Python call, including the allocation of the output array (the user pays
it), except in the ``out=`` rows, which reuse one buffer. numpy has one thread only. Each time is the
best (minimum) of --repeats calls after a warm-up: noise from other processes only adds time.
``--busy`` also times 1 and 2 threads while a competing process spins on one core (the shared-machine
case: two threads must not be slower than one).

Written to out/bench/paths.{csv,json,md}. A benchmark, not a test: exits 0 when the measurements
complete, whatever the goals say (each row prints PASS or FAIL against its goal).
"""
from __future__ import annotations

import argparse
import json
import math
import mmap
import multiprocessing as mp
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd

import glintlab as gl
from bench_binomial import cpu_model  # the same machine line in every bench table (a sibling script)
from glintlab import _core
from glintlab.validation.bench import best_time

POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6)]
BLENDS = ["distributed", "zk16_linear", "roulette", "nearest"]


PER_SAMPLE_GOAL = 8  # blends with a footprint area per sample, against the inner law's batch


def simd_name(level: int) -> str:
    return {2: "AVX-512", 1: "AVX2", 0: "portable (scalar)"}.get(level, str(level))


def _blend_level_trials(rule, N, P):
    """The inner law's trial counts at the levels each sample of a blend draws (default ladder: ratio 4,
    base area 1; the rules of core/blends/, levels with no trials left out), concatenated."""
    lo = np.floor(np.log(P) / np.log(4.0))
    a_lo, a_hi = 4.0**lo, 4.0 ** (lo + 1)
    if rule == "distributed":
        w = (P - a_lo) / (a_hi - a_lo)
        n = np.concatenate([(1 - w) * N * a_lo, w * N * a_hi])
    elif rule == "nearest":
        n = np.where(np.log(P / a_lo) / np.log(4.0) >= 0.5, N * a_hi, N * a_lo)
    else:
        n = np.concatenate([N * a_lo, N * a_hi])
    return n[n > 0]


def _spin(stop):
    x = 0
    while not stop.is_set():
        for _ in range(10000):
            x += 1


def _blend_rows(ns, add, thread_settings, M, seed):
    """The blend rows (issues 21, 32, 43): every rule over gated and binomial, one footprint area and per sample,
    each beside the inner law's batch."""
    # blends: P log-uniform over [1, 16] (two levels of ratio 4), N = 1e4 facets per unit area, p = 0.01
    N, p_blend = 1e4, 0.01
    P = np.exp(np.random.default_rng(seed + 1).uniform(0, math.log(16), M))
    P_hundreds = np.exp(np.random.default_rng(seed + 2).uniform(math.log(200), math.log(800), M))
    inner_point = (N * 4.0, p_blend)  # the geometric middle of the P range
    # The honest bound of the per-sample-P rows: each sample needs its own bracket and, at two levels,
    # two inner evaluations at their own (n, p): the inner law's per-pixel ns on the same (n, p) pairs
    # (one per level drawn) is printed beside the goal. "one P" rows: every sample at P = 4 (scalar),
    # where each level's (n, p) is fixed and the inner law's fixed-parameter evaluator serves.
    for inner, goal in (("gated", 4), ("binomial", 3)):
        law = gl.law(inner)
        for t in thread_settings:
            base = ns(lambda: law.sample(inner_point[0], inner_point[1], size=M, seed=seed), M, t)
            for rule in BLENDS:
                b = gl.blended_law(rule, inner=inner)
                lv = b.levels(4.0)
                level_n = _blend_level_trials(rule, N, P)  # the (n, p) each sample's levels are drawn at
                pix = ns(lambda: law.sample(level_n, p_blend, seed=seed), level_n.size, t)
                per_pixel_bound = pix * level_n.size / M
                v = ns(lambda: b.sample(N, P, p_blend, seed=seed), M, t)
                r = v / base
                # A footprint area per sample: issue 32's goal is 8x the inner batch for any rule.
                add(f"blend {rule}[{inner}]", f"blend/inner batch <= {PER_SAMPLE_GOAL}", v, base,
                    f"{inner} batch at (n, p) = ({inner_point[0]:g}, {p_blend:g})", r, r <= PER_SAMPLE_GOAL, t,
                    note=f"bound: {inner} per-pixel on its levels' (n, p) = {per_pixel_bound:.1f} ns/sample "
                         f"({v / per_pixel_bound:.1f}x)")
                v = ns(lambda: b.sample(N, 4.0, p_blend, size=M, seed=seed), M, t)
                r = v / base
                add(f"blend {rule}[{inner}] one P", f"blend/inner batch <= {goal}", v, base,
                    f"{inner} batch at (n, p) = ({inner_point[0]:g}, {p_blend:g})", r, r <= goal, t,
                    note=f"P = 4 for every sample (level {lv['level']}, w = {lv['w_lod']:g})")
                # P = 8 (w = 1/2): both levels drawn and, for the roulette, both thinned (at P = 4 the
                # upper level has weight 0 and is not drawn at all).
                v = ns(lambda: b.sample(N, 8.0, p_blend, size=M, seed=seed), M, t)
                r = v / base
                add(f"blend {rule}[{inner}] one P = 8", f"blend/inner batch <= {goal}", v, base,
                    f"{inner} batch at (n, p) = ({inner_point[0]:g}, {p_blend:g})", r, r <= goal, t,
                    note="P = 8 for every sample (w = 0.5)")
                # Hundreds of base cells (issue 43): the levels' step tables are large; a blend keeps them across
                # calls, so the best of --repeats calls is a later call's time, and a fresh blend's is the first's.
                v = ns(lambda: b.sample(N, 409.0, p_blend, size=M, seed=seed), M, t)
                first = ns(lambda: gl.blended_law(rule, inner=inner).sample(N, 409.0, p_blend, size=M, seed=seed),
                           M, t)
                r = v / base
                add(f"blend {rule}[{inner}] one P = 409", f"blend/inner batch <= {goal}", v, base,
                    f"{inner} batch at (n, p) = ({inner_point[0]:g}, {p_blend:g})", r, r <= goal, t,
                    note=f"P = 409 for every sample (w = 0.34); a first call {first:.1f} ns ({first / base:.1f}x)")
                if inner == "gated":
                    v = ns(lambda: b.sample(N, P_hundreds, p_blend, seed=seed), M, t)
                    r = v / base
                    add(f"blend {rule}[{inner}] P 200-800", f"blend/inner batch <= {PER_SAMPLE_GOAL}", v, base,
                        f"{inner} batch at (n, p) = ({inner_point[0]:g}, {p_blend:g})", r, r <= PER_SAMPLE_GOAL, t,
                        note="P log-uniform over [200, 800] per sample (levels 3 to 5)")


class Rows:
    """The table being measured: ``ns`` times a call (best of ``repeats``, ns per item, on a given number
    of threads), ``add`` records one row against its baseline and goal."""

    def __init__(self, repeats: int, default_threads: int):
        self.repeats, self.default_threads, self.rows = repeats, default_threads, []

    def ns(self, fn, count, threads):
        gl.set_num_threads(threads)
        try:
            return best_time(fn, self.repeats) / count * 1e9
        finally:
            gl.set_num_threads(self.default_threads)

    def add(self, path, goal, value, baseline, baseline_name, ratio, ok, threads, note=""):
        self.rows.append(dict(path=path, threads=threads, ns=value, baseline=baseline_name, baseline_ns=baseline,
                              ratio=ratio, goal=goal, ok=bool(ok), note=note))

    def measured_ns(self, path, threads):
        """The ns of the row already recorded for path on that many threads."""
        return [r for r in self.rows if r["path"] == path and r["threads"] == threads][0]["ns"]


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=10**7, help="samples of the batch calls (default 1e7)")
    ap.add_argument("--pixels", type=int, default=10**6, help="samples of the per-pixel and blend calls (1e6)")
    ap.add_argument("--repeats", type=int, default=3, help="timed calls per measurement; best kept")
    ap.add_argument("--image", default="1920x1080", help="count_image size WxH ('0' skips it)")
    ap.add_argument("--busy", action="store_true", help="also time 1 vs 2 threads beside a competing process")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("out/bench"))
    args = ap.parse_args(argv)
    if args.size < 64 or args.pixels < 64 or args.repeats < 1:
        ap.error("--size >= 64, --pixels >= 64 and --repeats >= 1 are required")
    return args


def _pixel_parameters(seed, M):
    """M random (n, p) of the standard grid: the per-pixel calls' parameters."""
    gn, gp = gl.standard_grid()
    pick = np.random.default_rng(seed).integers(0, gn.size * gp.size, M)
    return gn[pick // gp.size], gp[pick % gp.size]


def _numpy_baselines(rng, S, R, pix_n, pix_p):
    """numpy's binomial (one thread; numpy has no other): ns per sample at each point for a batch of S,
    and per pixel on the per-pixel calls' (n, p)."""
    numpy_ns = {pt: best_time(lambda: rng.binomial(int(pt[0]), pt[1], size=S), R) / S * 1e9 for pt in POINTS}
    pix_n_int = np.floor(pix_n).astype(np.int64)
    M = pix_n.size
    numpy_pixel_ns = best_time(lambda: rng.binomial(pix_n_int, pix_p), R) / M * 1e9
    return numpy_ns, numpy_pixel_ns


def _batch_rows(b, thread_settings, S, seed, numpy_ns):
    """The batch rows against numpy; returns every law's batch ns by (law, n, p, threads), head_cf's too
    (its batch is the baseline of its per-pixel row, not a row of its own)."""
    batch_ns = {}
    for name in ("gated", "head_cf", "binomial"):
        law = gl.law(name)
        for t in thread_settings:
            for n, p in POINTS:
                v = b.ns(lambda: law.sample(n, p, size=S, seed=seed), S, t)
                batch_ns[(name, n, p, t)] = v
                if name == "head_cf":
                    continue  # only its per-pixel row is in the table; the batch is its baseline
                goal = 10 if name == "gated" else 2
                r = numpy_ns[(n, p)] / v
                b.add(f"batch {name} ({n:g}, {p:g})", f"numpy/law >= {goal}", v, numpy_ns[(n, p)], "numpy binomial",
                      r, r >= goal, t)
    return batch_ns


def _per_pixel_rows(b, thread_settings, seed, pix_n, pix_p, numpy_pixel_ns, batch_ns):
    """The per-pixel rows: binomial against numpy on the same arrays, gated and head_cf against their
    own batch (mean of the four points)."""
    M = pix_n.size
    for name in ("gated", "head_cf", "binomial"):
        law = gl.law(name)
        for t in thread_settings:
            v = b.ns(lambda: law.sample(pix_n, pix_p, seed=seed), M, t)
            if name == "binomial":
                r = numpy_pixel_ns / v
                b.add(f"per_pixel {name}", "numpy/law >= 2", v, numpy_pixel_ns, "numpy binomial per pixel", r, r >= 2,
                      t)
            else:
                base = float(np.mean([batch_ns[(name, n, p, t)] for n, p in POINTS]))
                r = v / base
                b.add(f"per_pixel {name}", "law/batch <= 2", v, base, f"{name} batch (mean of 4 points)", r, r <= 2, t)


def _out_buffer_rows(b, thread_settings, S, seed, pix_n, pix_p, batch_ns):
    """out=: the same calls into a reused buffer: the share of the fresh array's page faults, and the
    two-thread speed-up without them."""
    M = pix_n.size
    buf = np.empty(S)
    pbuf = np.empty(M)
    for name in ("gated", "binomial"):
        law = gl.law(name)
        for t in thread_settings:
            for n, p in POINTS if name == "gated" else POINTS[1:2]:
                v = b.ns(lambda: law.sample(n, p, size=S, seed=seed, out=buf), S, t)
                base = batch_ns[(name, n, p, t)]
                b.add(f"batch {name} ({n:g}, {p:g}) out=", "info", v, base, "same call, fresh array", v / base, True, t)
            v = b.ns(lambda: law.sample(pix_n, pix_p, seed=seed, out=pbuf), M, t)
            base = b.measured_ns(f"per_pixel {name}", t)
            b.add(f"per_pixel {name} out=", "info", v, base, "same call, fresh array", v / base, True, t)


def _bound_rows(b, thread_settings, S, R, batch_ns):
    """What bounds the batch rows: the counter-based Philox4x32-10 rows every sampler draws (two uniforms
    per sample: one Philox block), generated into memory that malloc reuses (1 MiB calls), and the
    first touch of a fresh output array (the kernel zeroes its pages), as ns per float64."""
    rows_per_call, calls = 1 << 16, max(1, S // (1 << 16))

    def philox_rows():
        for _ in range(calls):  # each result dropped at once, so malloc hands the same pages back
            _core.uniforms(0, rows_per_call, 2, 1, 0)
    for t in thread_settings:
        v = b.ns(philox_rows, rows_per_call * calls, t)
        b.add("bound: Philox rows, 2 uniforms", "info", v, batch_ns[("gated", 16, 0.1, t)],
              "gated batch (16, 0.1)", v / batch_ns[("gated", 16, 0.1, t)], True, t)
    # Fresh pages from mmap itself (malloc may hand back pages it already holds), advised as huge pages
    # as numpy advises its large arrays; numpy's arrays of --size float64 (80 MB) are above glibc's
    # largest mmap threshold (32 MiB), so they are fresh pages too.
    reuse = np.empty(S)
    touch_reused = best_time(lambda: reuse.fill(1.0), R) / S * 1e9

    def fresh_fill():
        with mmap.mmap(-1, S * 8, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS) as m:
            if hasattr(mmap, "MADV_HUGEPAGE"):
                m.madvise(mmap.MADV_HUGEPAGE)
            a = np.frombuffer(m, dtype=np.float64)
            a.fill(1.0)
            del a
    touch_fresh = best_time(fresh_fill, R) / S * 1e9
    b.add("bound: first touch of a fresh array", "info", touch_fresh - touch_reused, touch_reused,
          "writing a reused array", (touch_fresh - touch_reused) / touch_reused, True, 1,
          note="ns per float64 (numpy fill, one thread)")


def _count_image_rows(b, thread_settings, image, seed, R):
    """count_image: ns per pixel per inner evaluation against the per-pixel gated cost."""
    from glintlab.api.grids import IMAGE_CONFIGS, configured_counter
    from glintlab.studies.aniso import plane_image
    w, h = (int(x) for x in image.lower().split("x"))
    uv, J = plane_image(w, h, tilt_deg=60.0)
    Nimg = 1024.0**2
    for t in thread_settings:
        pixel = b.measured_ns("per_pixel gated", t)
        for label in IMAGE_CONFIGS:
            c = configured_counter(IMAGE_CONFIGS[label], "gated", Nimg)
            res = c.count_image(uv, J, Nimg, 0.1, seed=seed)
            evals = float(res.evaluations.sum())
            gl.set_num_threads(t)
            try:
                sec = best_time(lambda: c.count_image(uv, J, Nimg, 0.1, seed=seed), max(1, R - 1))
            finally:
                gl.set_num_threads(b.default_threads)
            per_eval = sec / max(evals, 1) * 1e9
            r = per_eval / pixel
            b.add(f"count_image {label}", "ns/eval / per-pixel gated <= 2", per_eval, pixel, "per_pixel gated",
                  r, r <= 2, t, note=f"{sec:.3f} s, {sec / (w * h) * 1e9:.0f} ns/pixel, "
                                     f"{evals / (w * h):.1f} evaluations/pixel")


def _busy_rows(b, S, seed, pix_n, pix_p):
    """The shared-machine case: 1 and the default threads while a competing process spins on one core."""
    M = pix_n.size
    default_threads = b.default_threads
    stop = mp.Event()
    proc = mp.Process(target=_spin, args=(stop,), daemon=True)
    proc.start()
    try:
        time.sleep(0.2)
        for name in ("gated", "binomial"):
            law = gl.law(name)
            n, p = POINTS[1]
            one = b.ns(lambda: law.sample(n, p, size=S, seed=seed), S, 1)
            two = b.ns(lambda: law.sample(n, p, size=S, seed=seed), S, default_threads)
            b.add(f"busy batch {name} ({n:g}, {p:g})", f"{default_threads}T <= 1T", two, one,
                  "1 thread, same competing process", two / one, two <= one * 1.05, default_threads)
            one = b.ns(lambda: law.sample(pix_n, pix_p, seed=seed), M, 1)
            two = b.ns(lambda: law.sample(pix_n, pix_p, seed=seed), M, default_threads)
            b.add(f"busy per_pixel {name}", f"{default_threads}T <= 1T", two, one,
                  "1 thread, same competing process", two / one, two <= one * 1.05, default_threads)
    finally:
        stop.set()
        proc.join()


def _write_and_print(df, args, thread_settings, default_threads):
    """The two-thread speed-up of each path, then paths.csv, paths.json and paths.md in --out, and the
    table printed."""
    R, S, M = args.repeats, args.size, args.pixels
    if len(thread_settings) > 1:
        one = df[df.threads == 1].set_index("path").ns
        speed = df[(df.threads == default_threads)].set_index("path").ns
        df["speedup_threads"] = df.path.map(one / speed)
    simd = _core.simd_level() if hasattr(_core, "simd_level") else -1
    load = os.getloadavg()
    header = (f"CPU: {cpu_model()}; SIMD level: {simd_name(simd)}; cores: {os.cpu_count()}; "
              f"default threads: {default_threads}; load average at the end: {load[0]:.2f}; "
              f"glintlab {gl.__version__}; numpy {np.__version__}")
    args.out.mkdir(parents=True, exist_ok=True)
    df.to_csv(args.out / "paths.csv", index=False)
    (args.out / "paths.json").write_text(json.dumps(dict(
        cpu=cpu_model(), simd_level=simd, simd=simd_name(simd), cores=os.cpu_count(), threads=default_threads,
        loadavg=load, size=S, pixels=M, repeats=R, seed=args.seed, version=gl.__version__,
        rows=df.to_dict("records")), indent=1, default=float))
    show = df.copy()
    show["result"] = np.where(show.goal == "info", "", np.where(show.ok, "PASS", "FAIL"))
    cols = ["path", "threads", "ns", "baseline", "baseline_ns", "ratio", "goal", "result"] + \
        (["speedup_threads"] if "speedup_threads" in show else []) + ["note"]
    table = show[cols].round(3)
    md = ["# glintlab paths (issue 21)", "", header, "",
          "Times: ns per sample (count_image: ns per inner evaluation), best of "
          f"{R} calls, output allocation included except in the `out=` rows.", "",
          "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    md += ["| " + " | ".join(str(x) for x in r) + " |" for r in table.itertuples(index=False)]
    (args.out / "paths.md").write_text("\n".join(md) + "\n")
    pd.set_option("display.width", 250)
    pd.set_option("display.max_colwidth", 60)
    print("== issue 21 paths: " + header)
    print(table.to_string(index=False))
    print(f"wrote {args.out / 'paths.csv'}, paths.json and paths.md")


def main(argv=None):
    args = parse_args(argv)
    R, S, M = args.repeats, args.size, args.pixels
    default_threads = gl.get_num_threads()
    thread_settings = sorted({1, default_threads})
    b = Rows(R, default_threads)
    pix_n, pix_p = _pixel_parameters(args.seed, M)
    numpy_ns, numpy_pixel_ns = _numpy_baselines(np.random.default_rng(args.seed), S, R, pix_n, pix_p)
    batch_ns = _batch_rows(b, thread_settings, S, args.seed, numpy_ns)
    _per_pixel_rows(b, thread_settings, args.seed, pix_n, pix_p, numpy_pixel_ns, batch_ns)
    _out_buffer_rows(b, thread_settings, S, args.seed, pix_n, pix_p, batch_ns)
    _bound_rows(b, thread_settings, S, R, batch_ns)
    _blend_rows(b.ns, b.add, thread_settings, M, args.seed)
    if args.image != "0":
        _count_image_rows(b, thread_settings, args.image, args.seed, R)
    if args.busy and default_threads > 1:
        _busy_rows(b, S, args.seed, pix_n, pix_p)
    _write_and_print(pd.DataFrame(b.rows), args, thread_settings, default_threads)


if __name__ == "__main__":
    main()
