"""Counting laws by name, and custom laws written in Python.

A law maps (n, p) and a few uniform random numbers to a count K. Built-in laws live in C++
(core/laws/); ``custom_law`` wraps a vectorized Python function so that it gets the same sampling,
comparison and reporting machinery.
"""
from __future__ import annotations

import hashlib
import inspect

import numpy as np

from .. import _core
from . import checks as v
from .._core import Distribution
from .plugins import CUSTOM_LAWS, load_plugin

PRECISIONS = ("float64", "float32")
_CHUNK = 1 << 20  # rows of uniforms materialized at once for custom laws (8 MB per uniform)


class Law:
    """A counting law. Obtain one with ``glintlab.law(name, **params)``."""

    def __init__(self, core):
        self._core = core

    @property
    def name(self) -> str:
        return self._core.name

    @property
    def params(self) -> dict:
        return dict(self._core.params)

    @property
    def label(self) -> str:
        """The law's name with its parameters, e.g. ``gaussian[rounding=floor]``: how tables, stores and
        bounds name it (``parse_law_label`` reads it back)."""
        return law_label(self.name, self.params)

    @property
    def identity(self) -> str:
        """What the law is, beyond its name: its label for a built-in law, ``plugin:<sha256 of the
        library file>:<label>`` for a plugin law. Stores key their rows by it."""
        plugin = next((path for path, names in _core.loaded_plugins() if self.name in names), None)
        if plugin is None:
            return self.label
        return f"plugin:{_file_digest(plugin)}:{self.label}"

    @property
    def traits(self) -> dict:
        """What the law declares about itself, next to its code (see ``law_traits``)."""
        return law_traits(self.name)

    def work_units(self, n, p) -> np.ndarray:
        """The law's cost model: work one evaluation at (n, p) does beyond its fixed cost, in the law's
        own unit (zk16: Bernoulli trials of its loop); 0 for constant-time laws. Broadcasts n and p."""
        return np.asarray(self._core.work_units(n, p), dtype=np.float64)

    @property
    def n_uniforms(self) -> int:
        """Random numbers one ``evaluate`` row consumes."""
        return self._core.n_uniforms

    @property
    def has_pmf(self) -> bool:
        return self._core.has_pmf

    @property
    def binning(self) -> str:
        """How outputs are binned for ``pmf`` and comparisons: "none" (integer counts) or "round"
        (round half up, unit bins [k - 1/2, k + 1/2)); apply it to samples with ``bin``."""
        return self._core.binning

    def bin(self, samples) -> np.ndarray:
        """Samples binned as ``pmf`` is (identity for integer-valued laws)."""
        x = np.asarray(samples, dtype=np.float64)
        return np.floor(x + 0.5) if self.binning == "round" else x

    @property
    def precisions(self) -> tuple:
        """Arithmetic the law can be evaluated in: ("float64",) or ("float64", "float32")."""
        return tuple(x for x in PRECISIONS if self._core.supports(x))

    def __repr__(self):
        args = "".join(f", {k}={val!r}" for k, val in self.params.items())
        return f"glintlab.law({self.name!r}{args})"

    def __eq__(self, other):
        # Two laws are equal when they are the same law: same name, parameters and code (identity).
        if not isinstance(other, Law):
            return NotImplemented
        return type(self) is type(other) and self.identity == other.identity

    def __hash__(self):
        return hash((type(self).__name__, self.identity))

    def __reduce__(self):
        # Pickled as what rebuilds it (name, parameters, and the plugin library a plugin law came
        # from), so laws travel to Dask workers and other processes.
        plugin = next((path for path, names in _core.loaded_plugins() if self.name in names), None)
        return (_rebuild_law, (self.name, self.params, plugin))

    def pmf(self, n, p, max_support: int = 50_000_000) -> Distribution:
        """Exact distribution of K for scalar (n, p), trimmed to all but 1e-14 of its mass.

        Raises NotImplementedError when the law has no exact distribution, and ValueError when the
        support would exceed ``max_support`` points (use the cdf/sf functions then).
        """
        n, p = _scalar("n", n), _scalar("p", p)
        v.integer("max_support", max_support, minimum=1)
        return self._core.pmf(n, p, int(max_support))

    def cdf(self, k, n, p) -> np.ndarray:
        """P(K <= k) of the exact law (``pmf``), vectorized: k, n and p broadcast numpy-style. For a
        law with binning "round", K is the binned count. NotImplementedError without an exact law."""
        return self._tabulated(k, n, p, "cdf")

    def sf(self, k, n, p) -> np.ndarray:
        """P(K > k), summed from the upper tail (accurate where ``1 - cdf`` would cancel)."""
        return self._tabulated(k, n, p, "sf")

    def ppf(self, q, n, p) -> np.ndarray:
        """The smallest support value k with P(K <= k) >= q (scipy's convention for discrete laws);
        q in [0, 1], broadcast with n and p like ``cdf``."""
        return self._tabulated(q, n, p, "ppf")

    def _tabulated(self, x, n, p, what):
        x = v.as_float_array("q" if what == "ppf" else "k", x)
        n = v.as_float_array("n", n)
        p = v.as_float_array("p", p)
        try:
            x, n, p = np.broadcast_arrays(x, n, p)
        except ValueError:
            raise ValueError(f"{'q' if what == 'ppf' else 'k'} (shape {x.shape}), n (shape {n.shape}) and p "
                             f"(shape {p.shape}) do not broadcast together; expected numpy-compatible shapes") from None
        if what == "ppf" and not np.all((x >= 0) & (x <= 1)):
            bad = x[~((x >= 0) & (x <= 1))].ravel()[0]
            v.fail("q", float(bad), "probabilities in [0, 1]")
        if what != "ppf" and np.isnan(x).any():
            v.fail("k", float("nan"), "numbers (not NaN)")
        out = np.empty(x.shape, dtype=np.float64)
        pairs = np.stack([n.ravel(), p.ravel()], axis=1)
        unique, inverse = np.unique(pairs, axis=0, return_inverse=True)
        # The elements of each distinct (n, p), grouped once (not a scan of every element per pair).
        order = np.argsort(inverse.ravel(), kind="stable")
        starts = np.searchsorted(inverse.ravel()[order], np.arange(len(unique) + 1))
        flat_x, flat_out = x.ravel(), out.reshape(-1)
        for j, (nj, pj) in enumerate(unique):  # one exact law per distinct (n, p)
            d = self.pmf(float(nj), float(pj))
            support, probs = np.asarray(d.support), np.asarray(d.probs)
            sel = order[starts[j]:starts[j + 1]]
            if what == "ppf":
                cum = np.minimum(np.cumsum(probs), 1.0)
                # A level within rounding of the total mass maps to the last support point.
                idx = np.searchsorted(cum, flat_x[sel] * cum[-1] - 1e-15, side="left")
                flat_out[sel] = support[np.minimum(idx, support.size - 1)]
            else:
                idx = np.searchsorted(support, flat_x[sel], side="right")  # points <= k
                if what == "cdf":
                    cum = np.concatenate([[0.0], np.cumsum(probs)])
                    flat_out[sel] = np.minimum(cum[idx], 1.0)
                else:
                    tail = np.concatenate([np.cumsum(probs[::-1])[::-1], [0.0]])
                    flat_out[sel] = np.minimum(tail[idx], 1.0)
        return out if out.ndim else out[()]

    def sample(self, n, p, size=None, seed=None, precision: str = "float64", out=None) -> np.ndarray:
        """Draws counts (float64). n, p: scalars or arrays broadcast numpy-style with ``size``.

        Sample i uses random numbers keyed by (seed, i) only, so the output is the same whatever the
        number of threads; ``seed=None`` draws a fresh seed from the operating system.
        ``precision="float32"`` evaluates the law in single precision (see ``precisions``).

        ``out``: a preallocated, writeable, C-contiguous float64 array of the output's shape, filled in
        place and returned (numpy's generators' convention; ValueError naming ``out`` otherwise). Worth
        it when the same shape is drawn again and again (a sweep, an image per frame): a fresh array's
        pages are faulted in on first touch, about 1-1.5 ns per sample, a large share of a fast law's
        batch cost. The values are the same with or without it.
        """
        shape = v.size(size)
        seed = v.seed(seed)
        precision = _precision(precision)
        nf, pf, shape = v.broadcast_params(n, p, shape)
        count = int(np.prod(shape, dtype=np.int64))
        flat = None if out is None else v.out_array(out, shape)
        result = self._sample_flat(nf, pf, count, seed, precision, flat)
        return out if out is not None else result.reshape(shape)

    def _sample_flat(self, nf, pf, count, seed, precision, out=None):
        return self._finite(self._core.sample(nf, pf, count, seed, precision, out=out), nf, pf)

    def _finite(self, out, nf, pf):
        """One rule for every kind of law: a count that is NaN or infinite is an error naming the law and
        the row, never a value passed on to be binned. Built-in laws declare their traits and are held
        to finite counts by the extremes suite; laws that declare nothing (plugins) are checked here."""
        if getattr(self, "_declared", None) is None:
            self._declared = bool(law_traits(self.name)["declared"])
        if not self._declared:
            _require_finite(f"law {self.name!r}", out, nf, pf)
        return out

    def evaluate(self, n, p, u, precision: str = "float64") -> np.ndarray:
        """Deterministic counts from explicit uniforms u of shape (m, n_uniforms); n, p broadcast to (m,)."""
        precision = _precision(precision)
        u = _uniform_rows(u, self.n_uniforms)
        nf, pf, _ = v.broadcast_params(n, p, (u.shape[0],))
        return self._finite(self._core.evaluate(nf, pf, u, precision), nf, pf)

    def estimate_pmf(self, n, p, samples: int = 10**6, seed=0, precision: str = "float64") -> Distribution:
        """Empirical distribution of ``samples`` draws at scalar (n, p).

        Each probability has Monte Carlo standard error sqrt(q (1 - q) / samples).
        """
        n, p = _scalar("n", n), _scalar("p", p)
        v.integer("samples", samples, minimum=1)
        return Distribution.empirical(self.sample(n, p, size=int(samples), seed=seed, precision=precision))


class CustomLaw(Law):
    """A law defined by a vectorized Python function ``fn(n, p, u) -> counts``.

    ``fn`` receives float64 arrays n and p of shape (m,) and u of shape (m, n_uniforms) and returns
    m counts. ``sample`` feeds it the same counter-based uniforms a built-in law would use, so a
    custom re-implementation of a built-in law reproduces its samples seed for seed.
    """

    def __init__(self, fn, n_uniforms: int, name: str, binning: str = "none"):
        self._fn = fn
        self._k = n_uniforms
        self._name = name
        self._binning = binning

    name = property(lambda self: self._name)
    params = property(lambda self: {})
    n_uniforms = property(lambda self: self._k)
    has_pmf = property(lambda self: False)
    precisions = property(lambda self: PRECISIONS)
    binning = property(lambda self: self._binning)

    @property
    def identity(self) -> str:
        """``python:<sha256 of the function's source (or code)>:<binning>:<name>``: two functions
        registered under one name are two laws."""
        return f"python:{_function_digest(self._fn)}:{self._binning}:{self._name}"

    def __reduce__(self):  # the function travels by value (cloudpickle, as Dask sends it)
        return (CustomLaw, (self._fn, self._k, self._name, self._binning))

    def pmf(self, n, p, max_support: int = 50_000_000):
        raise NotImplementedError(
            f"custom law {self._name!r} has no exact distribution; use "
            f"law.estimate_pmf(n, p, samples=..., seed=...) for a Monte Carlo estimate")

    @staticmethod
    def _rows(nf, pf, u, precision):
        """The function's inputs for m rows: n and p broadcast to (m,); in float32, float32 n and p and
        the uniforms by the float32 rule (uniforms_float32), as a shader would see them."""
        m = u.shape[0]
        n_rows = np.broadcast_to(nf, (m,)) if nf.size == 1 else nf
        p_rows = np.broadcast_to(pf, (m,)) if pf.size == 1 else pf
        if precision == "float32":
            n_rows, p_rows, u = n_rows.astype(np.float32), p_rows.astype(np.float32), uniforms_float32(u)
        return n_rows, p_rows, u

    def raw(self, n, p, u, precision: str = "float64") -> np.ndarray:
        """The function's output for rows (n, p, u) (u of shape (m, n_uniforms)), given its inputs exactly
        as ``evaluate`` gives them
        (the float32 uniform rule included) but unchecked: a NaN or negative count is returned as is,
        for the extremes suite to report (``evaluate`` refuses it). Flattened; its length is the
        caller's to check."""
        precision = _precision(precision)
        u = np.asarray(u, dtype=np.float64)  # (m, n_uniforms)
        nf = np.asarray(n, dtype=np.float64).reshape(-1)
        pf = np.asarray(p, dtype=np.float64).reshape(-1)
        return np.asarray(self._fn(*self._rows(nf, pf, u, precision)), dtype=np.float64).reshape(-1)

    def _call(self, nf, pf, u, precision="float64"):
        m = u.shape[0]
        n_rows, p_rows, u = self._rows(nf, pf, u, precision)
        try:
            out = np.asarray(self._fn(n_rows, p_rows, u), dtype=np.float64)
        except Exception as exc:
            raise ValueError(f"custom law {self._name!r}: the function raised {exc!r}") from exc
        if out.shape != (m,):
            out = out.reshape(-1) if out.size == m else out
        if out.shape != (m,):
            raise ValueError(f"custom law {self._name!r} returned shape {out.shape}; expected ({m},)")
        _require_finite(f"custom law {self._name!r}", out, n_rows, p_rows)
        return out

    def _check_np(self, nf, pf):
        for name, arr, ok, expected in (
                ("n", nf, lambda a: np.isfinite(a) & (a >= 0), "a finite number >= 0"),
                ("p", pf, lambda a: (a >= 0) & (a <= 1), "a probability in [0, 1]")):
            bad = ~ok(arr)
            if bad.any():
                i = int(np.argmax(bad))
                label = name if arr.size == 1 else f"{name}[{i}]"
                v.fail(f"{self._name}: {label}", arr[i], expected)

    def evaluate(self, n, p, u, precision: str = "float64"):
        precision = _precision(precision)
        u = _uniform_rows(u, self._k)
        nf, pf, _ = v.broadcast_params(n, p, (u.shape[0],))
        self._check_np(nf, pf)
        return self._call(nf, pf, u, precision)

    def _sample_flat(self, nf, pf, count, seed, precision, out=None):
        self._check_np(nf, pf)
        out = np.empty(count) if out is None else out
        for i0 in range(0, count, _CHUNK):
            i1 = min(count, i0 + _CHUNK)
            u = _core.uniforms(i0, i1 - i0, self._k, seed, 0)
            out[i0:i1] = self._call(nf if nf.size == 1 else nf[i0:i1],
                                    pf if pf.size == 1 else pf[i0:i1], u, precision)
        return out


def _plain(value):
    """Integral floats from the C++ traits back to int ({"cap": 4.0} -> {"cap": 4}), so labels, seeds
    and test ids read as the law's parameters are written."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, dict):
        return {k: _plain(x) for k, x in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_plain(x) for x in value)
    return value


def law_traits(name: str) -> dict:
    """The traits a built-in law declares in its C++ file: ``output`` ("integer" or "real"),
    ``support`` ("bounded_by_n", "n_plus_one" or "unbounded", with ``support_note``),
    ``constant_time``, ``reference`` (an exact model rather than an approximation), ``regime`` and
    ``cost`` (one line each), the parameter variants used by the trade study, the benchmarks and the
    generic tests (``study_variants``, ``bench_variants``, ``test_variants``), ``cost_points``, the
    domains of its error ``bounds``, and its numeric ``domain`` (``max_n``, the largest n it is
    evaluated at, and why: n beyond it raises ValueError). Custom and plugin laws declare nothing
    (``declared`` False); a plugin law still gets the default numeric domain.

    >>> law_traits("zk16")["test_variants"]
    [{}, {'cap': 4}]
    """
    if not isinstance(name, str):
        v.fail("name", name, "a law name (str)")
    if name in CUSTOM_LAWS:
        return {"name": name, "declared": False, "output": "real", "support": "unbounded", "support_note": "",
                "constant_time": False, "reference": False, "regime": "", "cost": "", "study_variants": [],
                "bench_variants": [], "test_variants": [], "cost_points": [], "bounds": [],
                "domain": {"max_n": float("inf"), "note": "a Python law: its function's own domain"}}
    return _plain(_core.law_traits(name))


def law_variants(use: str, reference=None) -> list[tuple[str, dict]]:
    """(name, params) of every registered law variant declared for ``use``: "study" (the speed/accuracy
    trade study), "bench" (``make bench``) or "test" (the generic law tests); ``reference`` True or
    False keeps only the exact models or only the approximations. Derived from the registry: a new law
    appears here by declaring its variants in its own file."""
    v.choice("use", use, ("study", "bench", "test"), "'study', 'bench' or 'test'")
    out = []
    for name in laws():
        traits = law_traits(name)
        if reference is not None and traits["reference"] != reference:
            continue
        out.extend((name, params) for params in traits[f"{use}_variants"])
    return out


def law_label(name: str, params: dict) -> str:
    """``name[key=value]...`` with the parameters in key order; just ``name`` without parameters."""
    return name + "".join(f"[{k}={val}]" for k, val in sorted(params.items()))


def parse_law_label(label: str) -> tuple[str, dict]:
    """(name, params) of a ``law_label``; numeric values come back as floats."""
    name, _, rest = label.partition("[")
    params = {}
    for item in ("[" + rest).split("[")[1:] if rest else []:
        key, _, value = item.rstrip("]").partition("=")
        try:
            params[key] = float(value)
        except ValueError:
            params[key] = value
    return name, params


def _require_finite(who: str, out, n_rows, p_rows) -> None:
    """The one rule for every kind of law: a NaN or infinite count is an error naming the law and the
    row (n and p broadcast: a length-1 array serves every row)."""
    bad = ~np.isfinite(out)
    if bad.any():
        i = int(np.argmax(bad))
        n_i, p_i = np.ravel(n_rows)[i % np.size(n_rows)], np.ravel(p_rows)[i % np.size(p_rows)]
        raise ValueError(f"{who} returned {out[i]} at row {i} (n = {n_i}, p = {p_i}); counts must be finite")


def _rebuild_law(name, params, plugin):
    if plugin is not None:
        load_plugin(plugin)
    return law(name, **params)


def law(name: str, **params) -> Law:
    """The counting law registered as ``name``, with keyword parameters (e.g. ``law("zk16", cap=16)``)."""
    if not isinstance(name, str):
        v.fail("name", name, "a law name (str)")
    if name in CUSTOM_LAWS:
        if params:
            raise ValueError(f"custom law {name!r} takes no parameters; got {sorted(params)}")
        return CUSTOM_LAWS.get(name)
    return Law(_core.make_law(name, params))


def laws() -> list[str]:
    """Names of every registered law (built-in and custom), sorted."""
    return sorted({name for name, _ in _core.law_infos()} | set(CUSTOM_LAWS))


def law_summaries() -> dict[str, str]:
    out = {name: summary for name, summary in _core.law_infos()}
    out.update({name: "custom law (Python)" for name in CUSTOM_LAWS})
    return dict(sorted(out.items()))


BINNINGS = ("none", "round")


def _file_digest(path) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()[:16]


def _function_digest(fn) -> str:
    """A digest of what the function computes: its source when Python can read it, else its bytecode,
    constants and names (a lambda typed at a prompt), plus the values it closes over."""
    try:
        text = inspect.getsource(fn)
    except (OSError, TypeError):
        text = ""
    # The bytecode too: two lambdas on one source line share their source text.
    code = getattr(fn, "__code__", None)
    text += repr((code.co_code, code.co_consts, code.co_names)) if code is not None else repr(fn)
    cells = getattr(fn, "__closure__", None) or ()
    text += repr([_cell_repr(c) for c in cells])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _cell_repr(cell):
    try:
        value = cell.cell_contents
    except ValueError:
        return "<empty>"
    return getattr(value, "identity", None) or repr(value)


def custom_law(fn, n_uniforms: int = 2, name: str = "custom", binning: str = "none") -> CustomLaw:
    """Registers a vectorized ``fn(n, p, u) -> counts`` as a law named ``name`` and returns it.

    ``binning``: how its outputs are compared with an integer law: "none" (they are counts) or "round"
    (real outputs, round half up to unit bins, as the built-in real-valued laws are). A sampled
    comparison of real outputs with "none" warns: unbinned, they match no integer value.
    Registering a name again replaces the earlier custom law; built-in names are refused.
    """
    if not callable(fn):
        v.fail("fn", fn, "a callable fn(n, p, u)")
    v.integer("n_uniforms", n_uniforms, minimum=0)
    if not isinstance(name, str) or not name:
        v.fail("name", name, "a non-empty string")
    if name in {n for n, _ in _core.law_infos()}:
        v.fail("name", name, "a name that no built-in law uses")
    v.choice("binning", binning, BINNINGS, "'none' (integer counts) or 'round' (real outputs, unit bins)")
    law_ = CustomLaw(fn, int(n_uniforms), name, binning)
    CUSTOM_LAWS.register(name, law_, replace=True)
    return law_


def uniforms(size: int, n_uniforms: int, seed=0, start: int = 0) -> np.ndarray:
    """The (size, n_uniforms) uniforms in (0, 1) that ``sample`` hands to ``evaluate``, rows start..start+size-1."""
    shape = v.size(size)
    if shape is None or len(shape) != 1:
        v.fail("size", size, "an integer >= 0")
    v.integer("n_uniforms", n_uniforms, minimum=0)
    v.integer("start", start, minimum=0)
    return _core.uniforms(int(start), shape[0], int(n_uniforms), v.seed(seed), 0)


def uniforms_float32(u) -> np.ndarray:
    """glintlab's uniforms as a shader receives them: the top 23 bits of u plus half a step,
    (floor(u 2^23) + 1/2) 2^-23, an exact float32 in [2^-24, 1 - 2^-24] (never 0 or 1). The C++
    float32 laws, custom laws in float32 and the Vulkan runner of shader laws apply this one rule
    (docs/math/laws.md#float32-uniforms)."""
    u = np.asarray(u, dtype=np.float64)
    k = np.clip(np.floor(u * 2.0**23), 0, 2.0**23 - 1)
    return ((k + 0.5) / 2.0**23).astype(np.float32)


def _precision(value):
    v.choice("precision", value, PRECISIONS, "'float64' or 'float32'")
    return value


def _scalar(name, value):
    arr = v.as_float_array(name, value)
    if arr.size != 1:
        v.fail(name, value, "a scalar")
    return float(arr.reshape(-1)[0])


def _uniform_rows(u, k):
    u = v.as_float_array("u", u)
    if u.ndim == 1 and k == 1:
        u = u.reshape(-1, 1)
    if u.ndim != 2 or u.shape[1] != k:
        raise ValueError(f"u has shape {u.shape}; expected (m, {k}) for a law with n_uniforms = {k}")
    bad = ~((u >= 0) & (u <= 1))
    if bad.any():
        i, j = np.argwhere(bad)[0]
        v.fail(f"u[{i}, {j}]", u[i, j], "a uniform number in [0, 1]")
    return np.ascontiguousarray(u)
