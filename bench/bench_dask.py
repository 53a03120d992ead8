#!/usr/bin/env python3
"""`make bench` (Dask part): speed-up of a fixed sweep on a LocalCluster of 1 and 2 workers, and the
per-task overhead, in one run.

  serial    gl.sweep(engine="threads", threads=1) with glintlab's own threads set to 1: one core;
  dask K    the same sweep on a LocalCluster of K single-threaded worker processes (started before
            the clock; its start-up time is reported apart);
  overhead  (time on 1 worker - serial time) / tasks, for 200 one-row tasks of negligible work.
Every table is checked equal to the serial one (bitwise). The sweep: gated, head_cf and binomial,
n in 10..1e6 (6 values), p in {0.01, 0.1, 0.3, 0.5}, 1e6 draws per row (72 rows).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

import glintlab as gl

SWEEP = dict(laws=["gated", "head_cf", "binomial"], n=list(np.logspace(1, 6, 6)), p=[0.01, 0.1, 0.3, 0.5],
             metrics=["tv", "chi2_pvalue"], seed=1)


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def main(argv=None):
    import distributed
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=1_000_000, help="draws per row (default: 1e6)")
    ap.add_argument("--out", type=Path, default=Path("out/bench"))
    args = ap.parse_args(argv)
    kw = dict(SWEEP, samples=args.samples, progress=False)
    gl.set_num_threads(1)
    t_serial, serial = timed(lambda: gl.sweep(**kw, threads=1))
    trivial = dict(laws=["binomial"], n=list(range(1, 201)), p=[0.5], metrics=["tv"], progress=False)
    t_trivial_serial, _ = timed(lambda: gl.sweep(**trivial, threads=1))
    rows = [dict(engine="serial (1 thread)", workers=0, startup_s=0.0, sweep_s=t_serial, speedup=1.0, equal=True)]
    overhead = None
    for workers in (1, 2):
        t0 = time.perf_counter()
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                      dashboard_address=":0", env={"GLINTLAB_NUM_THREADS": "1"}) as cluster:
            address = cluster.scheduler_address
            gl.sweep(["binomial"], n=[16], p=[0.1], engine="dask", scheduler=address, progress=False)  # warm-up
            startup = time.perf_counter() - t0
            t, table = timed(lambda: gl.sweep(**kw, engine="dask", scheduler=address))
            equal = table.equals(serial)
            rows.append(dict(engine="dask LocalCluster", workers=workers, startup_s=startup, sweep_s=t,
                             speedup=t_serial / t, equal=equal))
            if workers == 1:
                t1, _ = timed(lambda: gl.sweep(**trivial, engine="dask", scheduler=address, chunk=1))
                overhead = (t1 - t_trivial_serial) / 200
    df = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    report = dict(rows=rows, per_task_overhead_s=overhead, rows_in_sweep=len(serial), samples=args.samples,
                  version=gl.__version__)
    (args.out / "dask.json").write_text(json.dumps(report, indent=1))
    print(f"== sweep of {len(serial)} rows x {args.samples:.0e} draws: serial vs Dask LocalCluster")
    print(df.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    print(f"per-task overhead (1 worker, 200 one-row tasks): {overhead * 1e3:.2f} ms")
    print(f"[{'PASS' if df.equal.all() else 'FAIL'}] every Dask table equals the serial one bit for bit")
    print(f"wrote {args.out / 'dask.json'}")


if __name__ == "__main__":
    main()
