"""The timing helper the bench scripts share (imported as ``from timing import best``: a script's own folder
is on ``sys.path`` when it runs as ``python bench/<script>.py``)."""
from __future__ import annotations

import time


def best(fn, repeats: int):
    """(last result, best seconds of ``repeats`` calls). The previous result is dropped before each call, so
    that its memory is reused as in a render loop: a first call also pays the kernel's zeroing of fresh
    pages (Scene.trace: 23 float64 per pixel, 380 MB at 1080p), which ``repeats=1`` shows."""
    out, t = None, float("inf")
    for _ in range(repeats):
        out = None
        t0 = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
    return out, t
