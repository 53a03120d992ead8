"""Transcendental functions whose float64 results do not depend on where the arrays sit in memory.

Why: numpy's float64 ``exp``, ``log``, ``sin``, ``cos``, ``arctan``, ``arctan2`` (and others, float32 ``log2``
and ``power`` among them) have two
inner loops on a CPU with AVX-512: a vector one and the C library's scalar one, which differ in the
last bit for a share of the inputs. Which one runs is decided per call by a memory-overlap test of
the operands' address ranges, and that test also counts an output that starts exactly where an input
ends (or within one stride of the end of a strided input) as overlapping. Whether a fresh output
lands there depends on the heap, so on everything the process did before: the same scene gave uv
one ulp apart, and glint images 1e-12 apart, after an unrelated image method had run in the same
process. (numpy 1.24 on a CPU with AVX-512; see tests/python/test_fpmath.py.)

:func:`call` copies the operands into one block of its own, each contiguous with a free element
between them and before the output, so the overlap test always passes and the vector loop (where the
CPU has one) always runs: the same bits whatever ran before, and the same bits numpy gives in the
common case (the vector loop's result for an element does not depend on its neighbours or stride).
"""
from __future__ import annotations

import numpy as np


def call(ufunc, *operands, dtype=np.float64) -> np.ndarray:
    """``ufunc(*operands)`` in ``dtype`` (float64, or float32 for a float32 twin of a shader; operands
    converted and broadcast), computed on private, separated buffers: see the module's docstring.
    Returns a new array of ``dtype`` (0-d for scalars)."""
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=dtype) for a in operands))
    shape, n = arrays[0].shape, arrays[0].size
    stride = n + 1  # a free element after every operand
    block = np.empty(stride * (len(arrays) + 1), dtype=dtype)
    views = [block[i * stride:i * stride + n] for i in range(len(arrays) + 1)]
    for v, a in zip(views, arrays):
        v[...] = a.reshape(-1)
    ufunc(*views[:-1], out=views[-1])
    return views[-1].reshape(shape).copy()


def exp(x) -> np.ndarray:
    """``np.exp`` independent of memory layout (:func:`call`)."""
    return call(np.exp, x)


def sin(x) -> np.ndarray:
    """``np.sin`` independent of memory layout (:func:`call`)."""
    return call(np.sin, x)


def cos(x) -> np.ndarray:
    """``np.cos`` independent of memory layout (:func:`call`)."""
    return call(np.cos, x)


def arctan2(y, x) -> np.ndarray:
    """``np.arctan2`` independent of memory layout (:func:`call`)."""
    return call(np.arctan2, y, x)
