#!/usr/bin/env python3
"""`make bench`: cost of the glinty NDFs (docs/math/glinty_ndf.md).

1. A 1920 x 1080 image of a receding ground plane (footprints growing with distance, half vectors
   spread over the disk): seconds per image for KPT25's Algorithm 1 (k = 1, 4, 9, 16) and DB23's D_P
   (db23_trilinear over the gated law; over the exact binomial it costs about 30x more at these n), on
   one thread and on all threads; the two must agree bit for bit.
2. Constant time: ns per evaluation of Algorithm 1 and of the reference against the number of points in
   the footprint (10 to 1e5): Algorithm 1's cost stays bounded, the reference's grows with the points.
3. Algorithm 2 (docs/math/glinty_ndf.md#glinty-sampling): ns per draw (sample, which returns the pdf of
   its draw) and per pdf evaluation against Algorithm 1's ns per evaluation at the same pixels, for
   k = 1, 4, 9, 16 at 10 to 1e4 points per footprint (the issue's goal: within 3x).
4. What Algorithm 2 samples against what it is meant to follow: at a few pixels, the total-variation
   distance between its pdf and D^f(h)(h.n) normalised (D^f by the reference and by Algorithm 1), the
   mass its pdf loses at the rim, and the compensation's share of Algorithm 1's integral; integrals by
   Gauss-Legendre rules on T-space bins (docs/math/glinty_ndf.md#glinty-sampling).
Writes out/bench/glinty_ndf.json. Exits 0 when the measurements complete.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import glintlab as gl


def plane(H=1080, W=1920):
    y, x = np.mgrid[0:H, 0:W].astype(float)
    d = 1.0 + (H - y) / H * 20.0  # distance grows towards the top rows
    uv = np.stack([x / W * d, 1.0 / d], -1) * 4.0
    J = np.zeros((H, W, 4))
    J[..., 0] = 4.0 * d / W
    J[..., 3] = 2.0 * d * d / H
    J[..., 1] = 1e-5
    h = np.stack([(x - W / 2) / W * 0.8, (y - H / 2) / H * 0.8, np.ones_like(x)], -1)
    return uv, J, h


def timed(fn, repeats=2):
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def t_space_rule(ndf, J, sub=4, order=8):
    """Nodes h, weights per steradian-free T-space area and |dOmega/dy| over the disk U, on bins aligned
    with the pdf's jumps (1 / (2 sub 2^level) of the finer level), the chord taken exactly."""
    n = 2 * sub * 2 ** max(ndf.pixel(J, (0.0, 0.0, 1.0))["levels"])
    edges = np.linspace(0.0, 1.0, n + 1)
    t, w = np.polynomial.legendre.leggauss(order)
    t, w = 0.5 * (t + 1), 0.5 * w
    pts, wts = [], []
    for bx in range(n):
        x0, x1 = edges[bx], edges[bx + 1]
        xs = x0 + (x1 - x0) * t
        half = np.sqrt(np.maximum(0.0, 0.25 - (xs - 0.5) ** 2))
        for by in range(n):
            lo, hi = np.maximum(edges[by], 0.5 - half), np.minimum(edges[by + 1], 0.5 + half)
            for ix in np.nonzero(hi > lo)[0]:
                pts.append(np.column_stack([np.full(order, xs[ix]), lo[ix] + (hi[ix] - lo[ix]) * t]))
                wts.append((x1 - x0) * w[ix] * (hi[ix] - lo[ix]) * w)
    y, wy = np.concatenate(pts), np.concatenate(wts)
    keep = np.sum((y - 0.5) ** 2, axis=1) < 0.25
    y, wy = y[keep], wy[keep]
    d = 2 * y - 1
    r2 = np.sum(d * d, axis=1)
    a = ndf.alpha
    if ndf.target == "beckmann":
        ratio = np.sqrt(np.where(r2 > 0, -np.log1p(-r2) / np.where(r2 > 0, r2, 1.0), 1.0))
        v = np.column_stack([a * d[:, 0] * ratio, a * d[:, 1] * ratio, np.ones_like(r2)])
    else:
        v = np.column_stack([a * d[:, 0], a * d[:, 1], np.sqrt(np.maximum(0.0, 1 - r2))])
    h = v / np.linalg.norm(v, axis=1, keepdims=True)
    return h, wy, 1.0 / (0.25 * math.pi * ndf.smooth(h) * h[:, 2])


def sampling_distance():
    rows = []
    cases = [(dict(density=4e3, target="beckmann", alpha=0.5, alpha_star=0.05, k=4), (0.31, 0.57), (0.03, 0.004, -0.006, 0.025)),
             (dict(density=1e3, target="ggx", alpha=0.4, alpha_star=0.08, k=1), (1.7, -0.4), (0.05, 0.0, 0.0, 0.05)),
             (dict(density=1e6, target="beckmann", alpha=0.5, alpha_star=0.02, k=4), (0.123, 0.456), (0.003, 0, 0.0005, 0.0025)),
             (dict(density=1e4, target="beckmann", alpha=0.5, alpha_star=0.05, k=4), (0.123, 0.456), (0.1, 0, 0.01, 0.09)),
             (dict(density=1e6, target="ggx", alpha=0.2, alpha_star=0.03, k=16), (3.3, 0.1), (0.002, 0, 0, 0.002))]
    for kw, uv, J in cases:
        ndf = gl.glinty_ndf("kpt25", **kw)
        h, w, jac = t_space_rule(ndf, J, sub=1 if max(ndf.pixel(J, (0, 0, 1.0))["levels"]) > 3 else 4)
        U, JJ = np.tile(uv, (len(h), 1)), np.tile(J, (len(h), 1))
        integral = lambda f: float(np.sum(w * f * jac))  # noqa: E731
        tv = lambda a, b: 0.5 * integral(np.abs(a / integral(a) - b / integral(b)))  # noqa: E731
        pdf = ndf.pdf(U, JJ, h, seed=5)
        ref = ndf.reference(U, JJ, h, seed=5) * h[:, 2]
        alg = ndf.evaluate(U, JJ, h, seed=5) * h[:, 2]
        bare = gl.glinty_ndf("kpt25", **{**kw, "compensation": "none"}).evaluate(U, JJ, h, seed=5) * h[:, 2]
        points = kw["density"] * abs(J[0] * J[3] - J[1] * J[2])
        row = {"ndf": ndf.label(), "points_per_footprint": points, "pdf_mass": integral(pdf),
               "tv_pdf_reference": tv(pdf, ref), "tv_pdf_algorithm1": tv(pdf, alg),
               "tv_smooth_reference": tv(np.ones_like(pdf) / jac, ref),
               "compensation_share": 1.0 - integral(bare) / integral(alg)}
        print(f"{row['ndf']}: {points:.0f} points, pdf mass {row['pdf_mass']:.4f}, TV(pdf, D^f ref) "
              f"{row['tv_pdf_reference']:.3f}, TV(pdf, D^f alg1) {row['tv_pdf_algorithm1']:.3f}, TV(smooth, D^f ref) "
              f"{row['tv_smooth_reference']:.3f}, compensation share {row['compensation_share']:.3f}")
        rows.append(row)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/bench")
    args = ap.parse_args(argv)
    threads = gl.get_num_threads()
    uv, J, h = plane()
    image = []
    methods = [(f"kpt25 k={k}", gl.glinty_ndf("kpt25", density=1e7, alpha=0.3, alpha_star=0.02, k=k)) for k in (1, 4, 9, 16)]
    methods.append(("db23[gated]", gl.glinty_ndf("db23", density=1e7, alpha=0.3, inner="gated")))
    for label, ndf in methods:
        row = {"method": label}
        outs = {}
        for t in sorted({1, threads}):
            gl.set_num_threads(t)
            row[f"seconds_{t}_threads"], outs[t] = timed(lambda: ndf.evaluate(uv, J, h, seed=1))
        gl.set_num_threads(threads)
        row["same_on_all_thread_counts"] = bool(all(np.array_equal(outs[1], o) for o in outs.values()))
        row["ns_per_pixel"] = 1e9 * row[f"seconds_{threads}_threads"] / (uv.shape[0] * uv.shape[1])
        print(f"{label:16s} " + "  ".join(f"{k} = {v:.3g}" for k, v in row.items() if k != "method"))
        image.append(row)
    scaling = []
    ndf = gl.glinty_ndf("kpt25", density=1e6, alpha=0.5, alpha_star=0.02, k=4)
    for points in (10.0, 1e2, 1e3, 1e4, 1e5):
        n = 2000 if points <= 1e3 else 200
        side = math.sqrt(points / 1e6)
        pix_uv = np.random.default_rng(0).uniform(0, 100, (n, 2))
        pJ = np.tile([side, 0.0, 0.0, side], (n, 1))
        ph = np.tile([0.2, 0.1, 1.0], (n, 1))
        t_alg, _ = timed(lambda: ndf.evaluate(np.tile(pix_uv, (10, 1)), np.tile(pJ, (10, 1)), np.tile(ph, (10, 1))))
        t_ref, _ = timed(lambda: ndf.reference(pix_uv, pJ, ph), repeats=1)
        row = {"points": points, "ns_algorithm1": 1e9 * t_alg / (10 * n), "ns_reference": 1e9 * t_ref / n}
        print(f"points {points:8.0f}: Algorithm 1 {row['ns_algorithm1']:9.0f} ns, reference {row['ns_reference']:12.0f} ns")
        scaling.append(row)
    sampling = []
    for k in (1, 4, 9, 16):
        nd = gl.glinty_ndf("kpt25", density=1e6, alpha=0.5, alpha_star=0.02, k=k)
        for points in (10.0, 1e3, 1e4):
            n = 20000
            side = math.sqrt(points / 1e6)
            pix_uv = np.random.default_rng(1).uniform(0, 100, (n, 2))
            pJ = np.tile([side, 0.0, 0.0, side], (n, 1))
            ph = np.tile([0.2, 0.1, 1.0], (n, 1))
            t_alg, _ = timed(lambda: nd.evaluate(pix_uv, pJ, ph))
            t_smp, (hs, _) = timed(lambda: nd.sample(pix_uv, pJ, seed=0, draw_seed=1))
            hs = np.where(np.isfinite(hs), hs, ph)
            t_pdf, _ = timed(lambda: nd.pdf(pix_uv, pJ, hs))
            row = {"k": k, "points": points, "ns_algorithm1": 1e9 * t_alg / n, "ns_sample": 1e9 * t_smp / n,
                   "ns_pdf": 1e9 * t_pdf / n}
            row["sample_over_algorithm1"] = row["ns_sample"] / row["ns_algorithm1"]
            print(f"k = {k:2d}, points {points:6.0f}: Algorithm 1 {row['ns_algorithm1']:8.0f} ns, Algorithm 2 "
                  f"{row['ns_sample']:8.0f} ns per draw ({row['sample_over_algorithm1']:.2f}x), pdf {row['ns_pdf']:8.0f} ns")
            sampling.append(row)
    distance = sampling_distance()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "glinty_ndf.json").write_text(json.dumps({"threads": threads, "image_1920x1080": image,
                                                     "constant_time": scaling, "algorithm2": sampling,
                                                     "algorithm2_distance": distance},
                                                    indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
