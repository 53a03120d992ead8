"""Argument checks shared by the Python layer: one message format, naming the parameter and value."""
from __future__ import annotations

import functools
import operator
import os
import secrets

import numpy as np


def fail(name, value, expected):
    raise ValueError(f"{name} = {value!r} is invalid; expected {expected}")


def json_pointer(path) -> str:
    """RFC 6901 pointer of a path of keys and indices (e.g. jsonschema's ``absolute_path``); "/" for the root."""
    path = list(path)
    return "/" + "/".join(str(p).replace("~", "~0").replace("/", "~1") for p in path) if path else "/"


def real(name, value):
    """`value` as a Python float (bools, strings and other objects rejected by name)."""
    if isinstance(value, (bool, str, bytes)):  # float("5") would pass a string through
        fail(name, value, "a real number")
    try:
        return float(value)
    except (TypeError, ValueError):
        fail(name, value, "a real number")


def integer(name, value, minimum: int | None = None, maximum: int | None = None) -> int:
    """`value` as a Python int: Python and numpy integers are accepted (np.int64 from an array is as good
    as 5), bools, floats and strings refused by name, as are values outside [minimum, maximum]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        fail(name, value, _integer_range(minimum, maximum))
    value = int(value)
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        fail(name, value, _integer_range(minimum, maximum))
    return value


def _integer_range(minimum, maximum) -> str:
    if minimum is not None and maximum is not None:
        return f"an integer in [{minimum}, {maximum}]"
    if minimum is not None:
        return f"an integer >= {minimum}"
    if maximum is not None:
        return f"an integer <= {maximum}"
    return "an integer"


def as_float_array(name, value):
    """`value` as a float64 array; strings, objects and complex numbers are rejected by name."""
    try:
        arr = np.asarray(value)
    except Exception:  # ragged sequences and the like
        fail(name, value, "a number or an array of numbers")
    # Booleans are refused like strings: True as n = 1 is a typo far more often than a count (the same
    # rule as for size and seed).
    if arr.dtype.kind not in "iuf":
        fail(name, value, "a number or an array of numbers")
    return arr.astype(np.float64, copy=False)


def seed(value):
    """The 64-bit key of glintlab's counter-based streams, from a user's seed.

    - an integer in [0, 2^64): the key itself;
    - ``None``: a key from the operating system (not reproducible);
    - a ``numpy.random.SeedSequence``: the first 64-bit word of its ``generate_state`` (the same
      sequence always gives the same key, as numpy's own generators do);
    - a ``numpy.random.Generator``: one 64-bit key drawn from it, which advances it. A seeded
      Generator therefore gives a reproducible *sequence* of calls, each with a fresh key.
    """
    if value is None:
        return secrets.randbits(64)
    if isinstance(value, np.random.SeedSequence):
        return int(value.generate_state(1, dtype=np.uint64)[0])
    if isinstance(value, np.random.Generator):
        return int(value.integers(0, 2**64, dtype=np.uint64))
    if isinstance(value, bool):
        fail("seed", value, "an integer in [0, 2^64), a numpy SeedSequence or Generator, or None")
    try:
        s = operator.index(value)
    except TypeError:
        fail("seed", value, "an integer in [0, 2^64), a numpy SeedSequence or Generator, or None")
    if not 0 <= s < 2**64:
        fail("seed", value, "an integer in [0, 2^64), a numpy SeedSequence or Generator, or None")
    return s


def size(value):
    """numpy-style size: None, an int >= 0 or a tuple of them; returns a shape tuple or None."""
    if value is None:
        return None
    dims = value if isinstance(value, (tuple, list)) else (value,)
    shape = []
    for d in dims:
        if isinstance(d, bool):
            fail("size", value, "an integer >= 0 or a tuple of them")
        try:
            d = operator.index(d)
        except TypeError:
            fail("size", value, "an integer >= 0 or a tuple of them")
        if d < 0:
            fail("size", value, "an integer >= 0 or a tuple of them")
        shape.append(d)
    total = 1
    for d in shape:
        total *= d
    # Refused up front rather than left to the allocator: numpy's "do not broadcast" or "array is too
    # big" messages name neither the argument nor the memory it would take.
    memory = _physical_memory()
    if total * 8 > memory:
        fail("size", value, f"at most {memory // 8:,} values in all (the output is float64, "
                            f"{total * 8 / 2**30:,.3g} GiB asked, {memory / 2**30:.3g} GiB of memory here)")
    return tuple(shape)


@functools.lru_cache(maxsize=1)
def _physical_memory() -> int:  # read once: size() runs on every sampling call
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # not POSIX: no up-front limit
        return 2**63


def broadcast_params(n, p, shape=None):
    """Broadcasts n and p (and the requested output shape) numpy-style.

    Returns (n_flat, p_flat, shape): flat contiguous float64 arrays of length 1 (a scalar, broadcast
    by the C++ drivers without a copy) or prod(shape).
    """
    n = as_float_array("n", n)
    p = as_float_array("p", p)
    try:
        common = np.broadcast_shapes(n.shape, p.shape)
        if shape is not None:
            if np.broadcast_shapes(common, shape) != tuple(shape):
                raise ValueError
            common = tuple(shape)
    except ValueError:
        raise ValueError(f"n (shape {n.shape}), p (shape {p.shape}) and size {shape} do not broadcast "
                         "together; expected numpy-compatible shapes") from None

    def flat(a):
        return a.reshape(1) if a.size == 1 else np.ascontiguousarray(np.broadcast_to(a, common)).ravel()

    return flat(n), flat(p), common


def out_array(out, shape):
    """A caller's preallocated output (numpy's ``out=`` convention): a writeable, C-contiguous float64
    array of exactly ``shape``; returns its flat view (no copy), so samplers write in place.
    ValueError naming ``out`` otherwise (a silent copy would defeat the point of passing one)."""
    shape = tuple(shape)
    if not isinstance(out, np.ndarray):
        fail("out", out, f"a numpy float64 array of shape {shape}")
    if out.dtype != np.float64:
        raise ValueError(f"out has dtype {out.dtype}; expected float64")
    if out.shape != shape:
        raise ValueError(f"out has shape {out.shape}; expected {shape}")
    if not out.flags.c_contiguous:
        raise ValueError("out is not C-contiguous; expected a C-contiguous float64 array")
    if not out.flags.writeable:
        raise ValueError("out is read-only; expected a writeable float64 array")
    return out.reshape(-1)
