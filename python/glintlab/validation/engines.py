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

import ast
import multiprocessing
import os
import socket
import sys
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

from ..api import checks as V

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


def _check_local_cluster_can_start():
    """Refuses, at once and with the reason, the two ways a LocalCluster hangs instead of starting.

    Its workers are started by the spawn method, which re-imports the main program's file in every
    worker: a program read on stdin has no file to re-import (each worker dies, is restarted, and
    prints a traceback, forever), and a program without an ``if __name__ == "__main__":`` guard starts
    a cluster again inside each worker while it is being spawned."""
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        raise ValueError("engine = 'dask': a LocalCluster was started while a worker process was being spawned, "
                         "i.e. the program that starts it runs again in each worker; expected the call under "
                         "`if __name__ == \"__main__\":` in the main program")
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if path is not None and not os.path.isfile(path):
        raise ValueError(f"engine = 'dask': a LocalCluster cannot start its workers from a program with no file "
                         f"(the main module is {path!r}: read on stdin?); expected a program saved to a file, "
                         f"or scheduler = 'tcp://HOST:PORT' of a running scheduler")
    if path is not None:
        line = _unguarded_main_line(main, path)
        if line is not None:
            raise ValueError(f"engine = 'dask': a LocalCluster started at {path}:{line}, outside an "
                             f"`if __name__ == \"__main__\":` block, would start again in each of its workers "
                             f"(they re-import the program); expected the call under that guard")


def _probe_scheduler(distributed, address: str, timeout: float):
    """Checks the address and that something listens there before a Client is built: a Client that
    fails to connect still tries to close itself when collected, and prints a traceback 20 s later."""
    from distributed.comm.addressing import parse_address, parse_host_port
    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location)
    except ValueError as exc:
        V.fail("scheduler", address, f"an address such as 'tcp://host:8786' ({exc})")
    if scheme not in ("tcp", "tls"):
        return  # other transports (inproc, ucx) are left to the Client
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        raise ValueError(f"scheduler = {address!r} did not answer within {timeout:g} s; expected the address of a "
                         f"running Dask scheduler ({exc.strerror or exc})") from None


def _unguarded_main_line(main, path):
    """The line of the main program's module-level code that led here, when it is not inside an
    ``if __name__ == "__main__":`` block (None when it is, or when that cannot be told)."""
    frame = sys._getframe()
    while frame is not None and not (frame.f_code.co_name == "<module>" and frame.f_globals is vars(main)):
        frame = frame.f_back
    if frame is None:
        return None
    try:
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read())
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return None
    line = frame.f_lineno
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_main_guard(node.test):
            if node.body[0].lineno <= line <= (node.body[-1].end_lineno or line):
                return None
    return line


def _is_main_guard(test) -> bool:
    return (isinstance(test, ast.Compare) and isinstance(test.left, ast.Name) and test.left.id == "__name__"
            and len(test.comparators) == 1 and isinstance(test.comparators[0], ast.Constant)
            and test.comparators[0].value == "__main__")


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
            _check_local_cluster_can_start()
            workers = workers or os.cpu_count() or 2
            # One thread per worker and per law call: workers are the unit of parallelism here.
            self.cluster = distributed.LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                dashboard_address=":0", env={"GLINTLAB_NUM_THREADS": "1"})
            address = self.cluster.scheduler_address
        else:
            if not isinstance(scheduler, str) or not scheduler:
                V.fail("scheduler", scheduler, "an address such as 'tcp://host:8786'")
            address = scheduler
            _probe_scheduler(distributed, address, timeout)
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
