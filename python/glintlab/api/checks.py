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


def real(name, value, expected: str = "a real number"):
    """`value` as a Python float (bools, strings and other objects rejected by name)."""
    if isinstance(value, (bool, str, bytes)):  # float("5") would pass a string through
        fail(name, value, expected)
    try:
        return float(value)
    except (TypeError, ValueError):
        fail(name, value, expected)


def positive(name, value, expected: str = "a finite number > 0") -> float:
    """`value` as a Python float in (0, inf) (a timeout, a scale); bools and strings refused by name.

    >>> positive("timeout", 2)
    2.0
    >>> positive("timeout", float("inf"), "a number of seconds > 0")
    Traceback (most recent call last):
    ValueError: timeout = inf is invalid; expected a number of seconds > 0
    """
    x = real(name, value, expected)
    if not 0 < x < float("inf"):
        fail(name, value, expected)
    return x


def integer(name, value, minimum: int | None = None, maximum: int | None = None, expected: str | None = None) -> int:
    """`value` as a Python int: Python and numpy integers are accepted (np.int64 from an array is as good
    as 5), bools, floats and strings refused by name, as are values outside [minimum, maximum].
    ``expected`` replaces the generated "an integer >= 1" where the message says more.

    >>> integer("samples", np.int64(5), minimum=1)
    5
    >>> integer("threads", True, minimum=1)
    Traceback (most recent call last):
    ValueError: threads = True is invalid; expected an integer >= 1
    """
    expected = expected or _integer_range(minimum, maximum)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        fail(name, value, expected)
    value = int(value)
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        fail(name, value, expected)
    return value


def choice(name, value, options, expected: str | None = None):
    """`value` if it is one of ``options``, else ValueError naming it and listing them (an array or
    other odd value is refused by name, never a TypeError).

    >>> choice("engine", "dask", ("threads", "dask"))
    'dask'
    >>> choice("engine", "mpi", ("threads", "dask"))
    Traceback (most recent call last):
    ValueError: engine = 'mpi' is invalid; expected one of 'threads', 'dask'
    """
    options = tuple(options)
    try:  # True == 1: a bool never passes as a numeric option
        ok = not isinstance(value, (bool, np.bool_)) and value in options
    except (TypeError, ValueError):  # an array compared with the options
        ok = False
    if not ok:
        fail(name, value, expected or "one of " + ", ".join(repr(o) for o in options))
    return value


def scalar_or_shape(name, arr, shape) -> None:
    """The broadcasting rule of per-pixel inputs (the Python twin of the core's "has N values; expected
    1 or M"): ``arr`` holds one value or one per element of ``shape``.

    >>> scalar_or_shape("p", np.zeros((2, 3)), (2, 2))
    Traceback (most recent call last):
    ValueError: p = 'an array of shape (2, 3)' is invalid; expected a scalar or an array of shape (2, 2)
    """
    shape = tuple(shape)
    if arr.size != 1 and arr.shape != shape:
        fail(name, f"an array of shape {arr.shape}", f"a scalar or an array of shape {shape}")


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


def _element(name, index):
    """``name[i, j, ...]`` for a multi-index (just ``name`` for a scalar)."""
    index = tuple(int(i) for i in index)
    return f"{name}[{', '.join(map(str, index))}]" if index else name


def pixel_arrays(uv, J, h):
    """The per-pixel inputs of every glinty NDF and image method, checked by one contract
    (docs/math/glinty_ndf.md#glinty-inputs): ``uv`` (..., 2) texture positions (or None when a method
    takes none), ``J`` (..., 4) footprint Jacobians (du/dx, dv/dx, du/dy, dv/dy), ``h`` (..., 3) half
    vectors. Returns (uv, J, h, shape) as C-contiguous float64 arrays; each h is scaled by the power of
    two that brings its largest component into [0.5, 1): an exact operation (the direction, and any
    normalisation of it, is unchanged bit for bit), so 1e-200 h and 1e200 h reach a method as h does.

    ValueError, naming the array, the element's multi-index and its value, for: a wrong shape, a NaN or
    infinite entry (``J[3, 0] = nan``), a zero half vector (``h[2] = (0.0, 0.0, 0.0)``) and a singular
    footprint, det J = 0 (``J[1, 4] = (...)``: a pixel that does not see the surface must be masked
    out by the caller, not evaluated). A half vector below the horizon (h_z <= 0) is valid input: every
    method returns 0 there."""
    h = np.ascontiguousarray(as_float_array("h", h))
    if h.ndim < 1 or h.shape[-1] != 3:
        fail("h", f"an array of shape {h.shape}", "an array of shape (..., 3)")
    shape = h.shape[:-1]
    J = np.ascontiguousarray(as_float_array("J", J))
    if J.shape != shape + (4,):
        fail("J", f"an array of shape {J.shape}", f"an array of shape {shape + (4,)}")
    arrays = [("J", J), ("h", h)]
    if uv is not None:
        uv = np.ascontiguousarray(as_float_array("uv", uv))
        if uv.shape != shape + (2,):
            fail("uv", f"an array of shape {uv.shape}", f"an array of shape {shape + (2,)}")
        arrays.insert(0, ("uv", uv))
    for name, a in arrays:
        bad = ~np.isfinite(a)
        if bad.any():
            idx = np.unravel_index(int(np.argmax(bad)), a.shape)
            fail(_element(name, idx), float(a[idx]), "a finite number (NaN and infinities are refused)")
    # Zero means every component exactly 0: a norm would underflow for h ~ 1e-200 (a valid direction).
    largest = _largest_component(h)
    zero = largest == 0
    if zero.any():
        idx = np.unravel_index(int(np.argmax(zero)), shape)
        fail(_element("h", idx), tuple(float(c) for c in h[idx]), "a nonzero half vector")
    _, exponent = np.frexp(largest[..., None])
    h = np.ascontiguousarray(np.ldexp(h, -exponent))
    # det J = 0 as computed in double: the products compared, not their difference against a tolerance
    # (a footprint's scale is the caller's: 1e-8 texels per pixel is a valid magnification).
    singular = J[..., 0] * J[..., 3] == J[..., 1] * J[..., 2]
    if singular.any():
        idx = np.unravel_index(int(np.argmax(singular)), shape)
        fail(_element("J", idx), tuple(float(c) for c in J[idx]),
             "a footprint with det J = du/dx dv/dy - dv/dx du/dy != 0 (mask pixels that do not see the surface)")
    return uv, J, h, shape


def _largest_component(h):
    """max(|h_x|, |h_y|, |h_z|) per vector of ``h`` (..., 3): two elementwise maxima, not numpy's reduction over
    a last axis of 3 (several times slower on the pixels x light samples of a light integral)."""
    a = np.abs(h)
    return np.maximum(np.maximum(a[..., 0], a[..., 1]), a[..., 2])


def unit_vectors(h):
    """``h`` (..., 3) normalised without underflow or overflow: scaled first by the power of two that
    brings its largest component into [0.5, 1) (exact), so for ordinary vectors the result is h / |h|
    bit for bit. Zero vectors stay zero (:func:`pixel_arrays` refuses them)."""
    h = np.asarray(h, dtype=np.float64)
    _, exponent = np.frexp(_largest_component(h)[..., None])
    s = np.ldexp(h, -exponent)
    n = np.linalg.norm(s, axis=-1, keepdims=True)
    return s / np.where(n > 0, n, 1.0)
