"""Sweeps on Dask (python3-distributed): a scheduler given by address, or a LocalCluster here.

Rows go to workers in chunks; every row draws with its own seed (``row_seed``), a hash of the
row's identity, so the table is bitwise the serial one whatever the number of workers, the chunk
size and the order chunks finish in. Tasks are pure: when a worker dies, Dask runs its chunks
again elsewhere and nothing changes. The client writes finished rows to the sweep's store as
chunks complete, so a restarted client resumes as a local sweep does.

Workers need glintlab importable (a LocalCluster's do: they run this interpreter). Laws travel by
pickle: built-in and plugin laws as their name, parameters and plugin path (``Law.__reduce__``),
Python custom laws with their function (cloudpickle).
"""
from __future__ import annotations

import os
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

DEFAULT_TIMEOUT = 10.0


class ThreadEngine:
    """Chunks on a local thread pool (the C++ releases the GIL)."""

    def __init__(self, threads: int):
        self.pool = ThreadPoolExecutor(max_workers=threads)
        self.slots = threads

    def submit(self, fn, *args):
        return self.pool.submit(fn, *args)

    def wait_first(self, pending):
        return wait(pending, return_when=FIRST_COMPLETED)

    def close(self, cancel=False):
        self.pool.shutdown(wait=not cancel, cancel_futures=cancel)


class DaskEngine:
    """Chunks on a Dask cluster: ``scheduler`` an address ("tcp://host:8786"), or None for a
    LocalCluster of ``workers`` single-threaded worker processes on this machine (loopback only)."""

    def __init__(self, scheduler=None, workers=None, timeout: float = DEFAULT_TIMEOUT):
        try:
            import distributed
        except ImportError:
            raise ValueError("engine = 'dask' needs python3-distributed (apt-get install python3-distributed)") from None
        self._distributed = distributed
        self.cluster = None
        if scheduler is None:
            workers = workers or os.cpu_count() or 2
            # One thread per worker and per law call: workers are the unit of parallelism here.
            self.cluster = distributed.LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                dashboard_address=":0", env={"GLINTLAB_NUM_THREADS": "1"})
            address = self.cluster.scheduler_address
        else:
            if not isinstance(scheduler, str) or not scheduler:
                raise ValueError(f"scheduler = {scheduler!r} is invalid; expected an address such as 'tcp://host:8786'")
            address = scheduler
        try:
            self.client = distributed.Client(address, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            if self.cluster is not None:
                self.cluster.close()
            raise ValueError(f"scheduler = {address!r} did not answer within {timeout:g} s; expected the "
                             f"address of a running Dask scheduler ({type(exc).__name__}: {exc})") from None
        self._completed = distributed.as_completed(loop=self.client.loop)
        self.slots = max(1, sum(w.get("nthreads", 1) for w in self.client.scheduler_info()["workers"].values()))

    def submit(self, fn, *args):
        # pure=False: two chunks with equal arguments are still two tasks (never the case here, but
        # a cached result must not hide a rerun after a failure).
        fut = self.client.submit(fn, *args, pure=False)
        self._completed.add(fut)
        return fut

    def wait_first(self, pending):
        done = {next(self._completed)}  # blocks until one chunk is done (or failed)
        done.update(self._completed.next_batch(block=False))
        return done, set(pending) - done

    def close(self, cancel=False):
        try:
            self.client.close()
        finally:
            if self.cluster is not None:
                self.cluster.close()
