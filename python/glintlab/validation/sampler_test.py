"""The direction-sampler harness: samples against their pdf by chi-square on adaptive bins and on rows
of the polar angle, the pdf's normalization with the lost samples, and the sampler's own pdf against
``pdf`` (docs/math/sampling.md).

``sampler_test(sample, pdf, domain=..., samples=..., seed=..., bins="adaptive")`` draws the samples in
chunks (``sample(size, seed)`` with seeds derived from ``seed``), builds the bins over the domain's
area-preserving square from the pdf's mass and from an independent pilot sample, integrates the pdf
over every bin by adaptive Genz-Malik cubature (the C++ core asks for node batches; each batch is one
``pdf`` call), counts the samples per bin and returns a :class:`SamplerTestResult`. With ``out`` the
result is written there (``.npz`` and ``.csv`` of every bin, a PNG of observed, expected and normalised
residual over the square) when it fails, or always with ``write="always"``.
"""
from __future__ import annotations

import hashlib
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.stats

from .. import _core
from ..api import checks as V

DOMAINS = ("hemisphere", "sphere", "disk", "square")
_DIM = {"hemisphere": 3, "sphere": 3, "disk": 2, "square": 2}
# What the square's axes are on each domain (plot labels and docs/math/sampling.md#area-preserving-maps).
AXES = {"hemisphere": ("cos theta", "phi / 2 pi"), "sphere": ("(cos theta + 1) / 2", "phi / 2 pi"),
        "disk": ("r^2", "phi / 2 pi"), "square": ("x", "y")}
# Rows of the marginal test by default (docs/math/sampling.md#polar-rows): 3 degrees of theta on the
# hemisphere and sphere, 1/30 of the radius on the disk; none on the square.
MARGINAL_ROWS = {"hemisphere": 30, "sphere": 60, "disk": 30, "square": 0}
# Shares of the significance (weighted Bonferroni, fixed in advance): the chi-square on the adaptive
# bins, the chi-square on the rows, the lost samples (docs/math/sampling.md#lost-sample-bin).
WEIGHTS = {"chi2": 0.85, "marginal": 0.10, "lost": 0.05}
WEIGHTS_WITHOUT_ROWS = {"chi2": 0.95, "lost": 0.05}
# Memory a pilot point takes while the bins are built (its square coordinates, the pdf there, the point
# itself, the C++ copies and the partition's scratch), in bytes per coordinate of the domain's points plus
# a fixed part; the up-front check refuses a pilot that would not fit.
_PILOT_BYTES = (8, 72)


@dataclass
class SamplerTestResult:
    """What ``sampler_test`` measured. ``pvalue`` combines the chi-square over the adaptive bins, the
    chi-square over the rows of the polar angle (``pvalue_marginal``; r on the disk) and the exact
    two-sided Poisson test of the lost samples (weighted Bonferroni: 85 % / 10 % / 5 %, or 95 % / 5 %
    without rows); ``passed`` is ``pvalue >= significance`` with no pdf mismatch and a cubature that
    resolved the pdf. ``inconclusive``: the test could not decide (too few samples, or a pdf the
    cubature cannot resolve): ``pvalue`` is NaN and ``passed`` False. Per bin (in the bins' Z order):
    ``rects`` (s0, t0, width_s, width_t) on the unit square, ``observed``, ``expected``,
    ``expected_error`` (cubature error, in samples). ``merged_*``: the bins as the statistic merged them.
    ``marginal_*``: the rows (``marginal_edges`` in s) with their counts."""
    name: str
    domain: str
    samples: int
    seed: int
    bins_kind: str
    significance: float
    passed: bool
    pvalue: float
    statistic: float
    dof: int
    pvalue_chi2: float
    pvalue_lost: float
    notes: list
    rects: np.ndarray
    observed: np.ndarray
    expected: np.ndarray
    expected_error: np.ndarray
    merged_starts: np.ndarray
    merged_observed: np.ndarray
    merged_expected: np.ndarray
    lost: int
    lost_expected: float
    integral: float
    integral_error: float
    mismatches: int
    checked: int
    worst_rel_diff: float
    rtol: float
    evaluations: int
    unconverged: int
    times: dict = field(default_factory=dict)
    files: list = field(default_factory=list)
    cubature_shift: float = 0.0
    cubature_limit: float = float("nan")
    inconclusive: bool = False
    pvalue_marginal: float = float("nan")
    marginal_statistic: float = float("nan")
    marginal_dof: int = 0
    marginal_edges: np.ndarray | None = None
    marginal_observed: np.ndarray | None = None
    marginal_expected: np.ndarray | None = None
    invalid_pdfs: int = 0
    seed_ignored: bool = False

    @property
    def bins(self) -> int:
        return len(self.observed)

    @property
    def note(self) -> str:
        return "; ".join(self.notes)

    @property
    def verdict(self) -> str:
        """"pass", "FAIL" or "inconclusive" (a test that could not decide, ``pvalue`` NaN)."""
        return "pass" if self.passed else ("inconclusive" if self.inconclusive else "FAIL")

    def __repr__(self):
        t = ", ".join(f"{k} {v:.2f} s" for k, v in self.times.items())
        rows = (f", rows p = {self.pvalue_marginal:.4g} (chi2 = {self.marginal_statistic:.6g}, dof = "
                f"{self.marginal_dof})" if self.marginal_edges is not None else "")
        return (f"SamplerTestResult({self.name or 'sampler'} on the {self.domain}: {self.verdict}, p = {self.pvalue:.4g} "
                f"(chi2 = {self.statistic:.6g}, dof = {self.dof}; {self.bins} bins, {self.samples} samples{rows}), "
                f"integral = {self.integral:.6f} +- {self.integral_error:.2g}, lost = {self.lost} "
                f"(expected {self.lost_expected:.3g}), pdf mismatches = {self.mismatches}/{self.checked} "
                f"(worst {self.worst_rel_diff:.2g}), cubature shift <= {self.cubature_shift:.3g} "
                f"(limit {self.cubature_limit:.3g}); {t}"
                + (f"; notes: {self.note}" if self.notes else "") + ")")

    def summary(self) -> dict:
        """The headline numbers as one flat row (tables, the CLI)."""
        return {"name": self.name, "domain": self.domain, "samples": self.samples, "bins": self.bins,
                "dof": self.dof, "statistic": self.statistic, "pvalue": self.pvalue, "passed": self.passed,
                "verdict": self.verdict, "pvalue_chi2": self.pvalue_chi2, "pvalue_marginal": self.pvalue_marginal,
                "pvalue_lost": self.pvalue_lost, "integral": self.integral, "integral_error": self.integral_error,
                "lost": self.lost, "lost_expected": self.lost_expected, "mismatches": self.mismatches,
                "worst_rel_diff": self.worst_rel_diff, "evaluations": self.evaluations,
                "cubature_shift": self.cubature_shift, "cubature_limit": self.cubature_limit,
                **{f"time_{k}": v for k, v in self.times.items()}}

    def write(self, out, stem: str = "sampler_test") -> list:
        """Writes ``stem.npz`` and ``stem.csv`` (every bin: rectangle, observed, expected, its error,
        residual) and ``stem.png`` (observed, expected and normalised residual over the square) into
        the folder ``out``; returns the paths. Never replaces a file nor follows a link: where any of
        the three names exists, ``stem-2``, ``stem-3``, ... is used instead."""
        out = Path(out)
        _check_out(out)
        out.mkdir(parents=True, exist_ok=True)
        resid = _residual(self.observed, self.expected)
        header = "s0,t0,width_s,width_t,observed,expected,expected_error,residual"
        table = np.column_stack([self.rects, self.observed, self.expected, self.expected_error, resid])
        writers = {
            "npz": lambda fh: np.savez_compressed(
                fh, rects=self.rects, observed=self.observed, expected=self.expected,
                expected_error=self.expected_error, residual=resid, merged_starts=self.merged_starts,
                merged_observed=self.merged_observed, merged_expected=self.merged_expected, lost=self.lost,
                lost_expected=self.lost_expected, domain=self.domain),
            "csv": lambda fh: np.savetxt(fh, table, delimiter=",", header=header, comments="", fmt="%.10g"),
            "png": lambda fh: plot_bins(self, fh)}
        self.files = [str(p) for p in _write_new(out, stem, writers)]
        return self.files


def _check_out(out: Path) -> None:
    """``out`` must be a folder or a path a folder can be made at: refused up front (before any draw)
    when it, or a folder above it, names an existing file."""
    for path in (out, *out.parents):
        if path.is_dir():
            return
        if os.path.lexists(path):
            V.fail("out", str(out), f"a folder ({path} is an existing file)")


def _write_new(out: Path, stem: str, writers: dict) -> list:
    """Creates out/stem.<ext> for every writer, each file opened with O_CREAT | O_EXCL (which neither
    replaces a file nor follows a symbolic link at the name); the first stem, stem-2, stem-3, ... whose
    names are all free is taken."""
    for k in range(1, 10_000):
        name = stem if k == 1 else f"{stem}-{k}"
        paths = [out / f"{name}.{ext}" for ext in writers]
        if any(os.path.lexists(p) for p in paths):
            continue
        made = []
        try:
            for path, write in zip(paths, writers.values()):
                with open(path, "xb") as fh:
                    made.append(path)
                    write(fh)
            return paths
        except FileExistsError:  # taken between the check and the open: the next name
            for path in made:
                path.unlink()
    V.fail("out", str(out), f"a folder with a free name for {stem} (10000 taken)")


def _residual(o, e):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(e > 0, (o - e) / np.sqrt(np.where(e > 0, e, 1.0)), np.where(o > 0, np.inf, 0.0))


def raster(rects, values, resolution: int = 256, density: bool = True):
    """Paints per-bin values onto a resolution^2 image of the unit square (rows: t, columns: s). With
    ``density`` each bin's value is spread over the pixels it covers (bins smaller than a pixel add up:
    counts per pixel); otherwise each pixel shows the value of the smallest bin painted on it."""
    img = np.zeros((resolution, resolution))
    order = np.argsort(-(rects[:, 2] * rects[:, 3]), kind="stable")
    for k in order:
        s0, t0, ws, wt = rects[k]
        i0, i1 = int(s0 * resolution), max(int(s0 * resolution) + 1, int(math.ceil((s0 + ws) * resolution - 1e-9)))
        j0, j1 = int(t0 * resolution), max(int(t0 * resolution) + 1, int(math.ceil((t0 + wt) * resolution - 1e-9)))
        i1, j1 = min(i1, resolution), min(j1, resolution)
        if density:
            img[j0:j1, i0:i1] += values[k] / ((i1 - i0) * (j1 - j0))
        else:
            img[j0:j1, i0:i1] = values[k]
    return img


def plot_bins(res: SamplerTestResult, path, resolution: int = 256):
    """Observed and expected counts per pixel of the square (log scale) and the normalised residual
    (o - e) / sqrt(e) per bin, with the bins' edges where they are coarse enough to see. ``path``: a
    file name or a binary file object (written as PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), constrained_layout=True)
    obs, exp = raster(res.rects, res.observed, resolution), raster(res.rects, res.expected, resolution)
    vmax = max(obs.max(), exp.max(), 1.0)
    extent = (0, 1, 0, 1)
    xl, yl = AXES.get(res.domain, ("s", "t"))
    for ax, img, title in ((axes[0], obs, "observed"), (axes[1], exp, "expected")):
        im = ax.imshow(np.log10(np.maximum(img, vmax * 1e-6)), origin="lower", extent=extent, aspect="auto",
                       vmin=math.log10(vmax) - 6, vmax=math.log10(vmax), cmap="magma")
        ax.set_title(f"{title} (log10 samples per pixel)")
        fig.colorbar(im, ax=ax)
    resid = np.clip(_residual(res.observed, res.expected), -10, 10)
    im = axes[2].imshow(raster(res.rects, resid, resolution, density=False), origin="lower", extent=extent,
                        aspect="auto", vmin=-5, vmax=5, cmap="RdBu_r")
    axes[2].set_title("(o - e) / sqrt(e) per bin")
    fig.colorbar(im, ax=axes[2])
    for ax in axes:
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
    fig.suptitle(f"{res.name or 'sampler'} on the {res.domain}: p = {res.pvalue:.3g}, {res.bins} bins, "
                 f"{res.samples} samples, lost {res.lost} (expected {res.lost_expected:.3g})")
    fig.savefig(path, dpi=90, format="png")
    plt.close(fig)
    return path


def _derived(seed: int, *keys) -> int:
    """A 64-bit seed for chunk `keys` of a run keyed by `seed` (numpy's SeedSequence hashing)."""
    return int(np.random.SeedSequence(seed, spawn_key=keys).generate_state(1, np.uint64)[0])


def _call_sample(sample, size, seed, dim):
    out = sample(size, seed)
    if not isinstance(out, (tuple, list)) or len(out) < 1:
        V.fail("sample", sample, "a function sample(size, seed) returning (points, pdfs)")
    pts = np.ascontiguousarray(V.as_float_array("sample(...)[0]", out[0]))
    if pts.shape != (size, dim):
        V.fail("sample(...)[0]", f"an array of shape {pts.shape}", f"an array of shape ({size}, {dim})")
    pdfs = None
    if len(out) > 1 and out[1] is not None:
        pdfs = V.as_float_array("sample(...)[1]", out[1]).reshape(-1)
        if pdfs.shape != (size,):
            V.fail("sample(...)[1]", f"an array of shape {pdfs.shape}", f"an array of shape ({size},)")
    return pts, pdfs


def _call_pdf(pdf, points, dim):
    pts = points.reshape(-1, dim)
    vals = V.as_float_array("pdf(...)", pdf(pts)).reshape(-1)
    if vals.shape != (len(pts),):
        V.fail("pdf(...)", f"an array of shape {vals.shape}", f"an array of shape ({len(pts)},)")
    return vals


def _grid_edges(domain, grid):
    """s and t edges of a fixed grid (n_theta, n_phi): uniform in theta and phi on the hemisphere and
    sphere (equal angles, not equal areas), in r and phi on the disk, in x and y on the square."""
    expected = "'adaptive' or a fixed grid (n1, n2) of integers >= 1 with at most 1e6 cells"
    if not isinstance(grid, (tuple, list)) or len(grid) != 2:
        V.fail("bins", grid, expected)
    for g in grid:  # a float is refused, never truncated: (3.7, 5) is not a grid
        if isinstance(g, (bool, np.bool_)) or not isinstance(g, (int, np.integer)):
            V.fail("bins", grid, expected)
    n1, n2 = (int(g) for g in grid)
    if n1 < 1 or n2 < 1 or n1 * n2 > 10**6:
        V.fail("bins", grid, expected)
    u = np.linspace(0.0, 1.0, n1 + 1)
    if domain == "hemisphere":
        s = np.cos(u[::-1] * math.pi / 2)
    elif domain == "sphere":
        s = 0.5 * (np.cos(u[::-1] * math.pi) + 1.0)
    elif domain == "disk":
        s = u * u
    else:
        s = u
    s[0], s[-1] = 0.0, 1.0
    return list(s), list(np.linspace(0.0, 1.0, n2 + 1))


@dataclass
class _Options:
    """sampler_test's arguments, checked."""
    domain: str
    dim: int
    samples: int
    key: int
    grid: tuple | None
    significance: float
    min_expected: float
    target: float
    rtol: float
    unit_tol: float
    check_pdf: bool
    n_pilot: int
    chunk: int
    cubature_tol: float
    rel_tol: float
    max_depth: int
    max_evaluations: int
    rows: int


def _real(name, value, ok, expected) -> float:
    x = V.real(name, value, expected)
    if not ok(x):
        V.fail(name, value, expected)
    return x


def _options(domain, samples, seed, bins, significance, min_expected, target, rtol, unit_tol, check_pdf, pilot,
             chunk, cubature_tol, rel_tol, max_depth, max_evaluations, marginal_rows, write) -> _Options:
    domain = domain or "hemisphere"
    V.choice("domain", domain, DOMAINS, "one of " + ", ".join(DOMAINS))
    samples = V.integer("samples", samples, 1, 10**10, expected="an integer in [1, 1e10]")
    key = V.seed(seed)
    grid = None
    if isinstance(bins, str):
        if bins != "adaptive":
            V.fail("bins", bins, "'adaptive' or a fixed grid (n1, n2)")
    else:
        grid = _grid_edges(domain, bins)
    finite = math.isfinite
    significance = _real("significance", significance, lambda x: 0 < x < 1, "a number in (0, 1)")
    min_expected = _real("min_expected", min_expected, lambda x: x > 0 and finite(x), "a finite number > 0")
    rtol = _real("rtol", rtol, lambda x: x > 0, "a number > 0")
    unit_tol = _real("unit_tol", unit_tol, lambda x: x > 0, "a number > 0")
    chunk = V.integer("chunk", chunk, minimum=1)
    cubature_tol = _real("cubature_tol", cubature_tol, lambda x: x >= 0 and finite(x), "a finite number >= 0")
    rel_tol = 0.0 if rel_tol is None else _real("rel_tol", rel_tol, lambda x: x >= 0 and finite(x),
                                                 "a finite number >= 0 (or None)")
    if cubature_tol == 0 and rel_tol == 0:
        V.fail("cubature_tol", cubature_tol, "a number > 0 when rel_tol is off (the cubature needs a stopping rule)")
    if write not in ("failure", "always", "never"):
        V.fail("write", write, "'failure', 'always' or 'never'")
    if target is None:
        # About 2 N^(2/5) bins for a smooth pdf (Mann & Wald's rule of thumb: power against smooth
        # deviations falls as the bins multiply), more where a spiky pdf's mass forces splits.
        target = max(8.0 * min_expected, samples ** 0.6)
    target = _real("target", target, lambda x: x > 0 and finite(x), "a finite number > 0")
    max_depth = V.integer("max_depth", max_depth, 0, 30)
    if max_evaluations is None:
        # pdf evaluations the cubature may spend: enough for thousands of resolved lobes, and a stop for a
        # pdf that is not integrable (a 1/cos singularity splits cells along the horizon forever).
        max_evaluations = max(4_000_000, 2 * samples)
    max_evaluations = V.integer("max_evaluations", max_evaluations, minimum=1)
    n_pilot = 0 if grid else (samples // 2 if pilot is None else min(V.integer("pilot", pilot, minimum=0), samples))
    rows = MARGINAL_ROWS[domain] if marginal_rows is None else V.integer("marginal_rows", marginal_rows, 0, 10**5)
    return _Options(domain, _DIM[domain], samples, key, grid, significance, min_expected, target, rtol, unit_tol,
                    bool(check_pdf), n_pilot, chunk, cubature_tol, rel_tol, max_depth, max_evaluations,
                    0 if grid else rows)


def _check_memory(o: _Options, pilot_given: bool) -> None:
    """Refuses, before any draw, a test whose pilot sample and chunks would not fit in memory."""
    chunk = min(o.chunk, o.samples)
    need = o.n_pilot * (_PILOT_BYTES[0] * o.dim + _PILOT_BYTES[1]) + chunk * (24 * o.dim + 64)
    have = V._physical_memory()
    if need > have:
        name, value = ("pilot", o.n_pilot) if pilot_given else ("samples", o.samples)
        V.fail(name, value, f"a test that fits in memory: a pilot sample of {o.n_pilot:.4g} points and chunks of "
                            f"{chunk:.4g} need about {need / 1e9:.3g} GB, {have / 1e9:.3g} GB here (pass a smaller "
                            "pilot=, chunk= or samples=)")


class _Draws:
    """Calls ``sample`` (timed) and remembers a fingerprint of each draw: the same points for two seeds
    mean a sampler that ignores its seed, whose pilot draws are its test draws."""

    def __init__(self, sample, dim, times):
        self.sample, self.dim, self.times = sample, dim, times
        self.seen, self.repeat = {}, None

    def __call__(self, size, seed, label):
        t0 = time.perf_counter()
        pts, pdfs = _call_sample(self.sample, size, seed, self.dim)
        self.times["sampling"] += time.perf_counter() - t0
        if size:
            key = hashlib.sha256(pts[:32].tobytes()).digest()
            if key in self.seen and self.repeat is None:
                self.repeat = (self.seen[key], label)
            self.seen.setdefault(key, label)
        return pts, pdfs


def _integrate(b, pdf, dim):
    while not b.done:  # one pdf call per round of nodes
        b.supply(_call_pdf(pdf, b.nodes(), dim))


def _adaptive_bins(o: _Options, draw, pdf, times):
    """The quadtree from the pilot sample (another seed than the test's, so that the bins never depend
    on the samples they test) and the pdf's own mass."""
    s_parts, t_parts = [], []
    for k, start in enumerate(range(0, o.n_pilot, o.chunk)):
        pts, _ = draw(min(o.chunk, o.n_pilot - start), _derived(o.key, 1, k), f"pilot chunk {k}")
        t0 = time.perf_counter()
        s, t, lost = _core.sampler_to_square(o.domain, pts, o.unit_tol)
        s_parts.append(s[lost == 0])
        t_parts.append(t[lost == 0])
        times["binning"] += time.perf_counter() - t0
    ps = np.concatenate(s_parts) if s_parts else np.zeros(0)
    pt = np.concatenate(t_parts) if t_parts else np.zeros(0)
    t0 = time.perf_counter()
    # The pdf at the pilot points shows peaks the cubature's nodes may have stepped over.
    pq = _call_pdf(pdf, _core.sampler_from_square(o.domain, ps, pt), o.dim) if len(ps) else np.zeros(0)
    b = _core.SamplerBins(o.domain, float(o.samples), o.target, 2, o.max_depth, 12, o.rel_tol, o.max_evaluations,
                          ps, pt, float(o.n_pilot), pq, shift_tol=o.cubature_tol, min_expected=o.min_expected)
    _integrate(b, pdf, o.dim)
    times["integration"] += time.perf_counter() - t0
    return b


def _grid_bins(o: _Options, s_edges, t_edges, pdf, times):
    t0 = time.perf_counter()
    b = _core.SamplerBins.grid(o.domain, float(o.samples), 12, o.rel_tol, o.max_evaluations, s_edges, t_edges,
                               shift_tol=o.cubature_tol, min_expected=o.min_expected)
    _integrate(b, pdf, o.dim)
    times["integration"] += time.perf_counter() - t0
    return b


def _rows(o: _Options, b, pdf, times):
    """The rows of the marginal test, integrated from the adaptive bins' own integration cells (cut along
    the rows' edges), so that they inherit the resolution the pilot-guided tree found."""
    t0 = time.perf_counter()
    rows = _core.SamplerBins.regrid(b, _grid_edges(o.domain, (o.rows, 1))[0], [0.0, 1.0])
    _integrate(rows, pdf, o.dim)
    times["integration"] += time.perf_counter() - t0
    return rows


class _Tally:
    """The test draws: counts per bin and per row, lost samples, and the sampler's pdfs checked against
    ``pdf`` (docs/math/sampling.md#pdf-consistency)."""

    def __init__(self, o: _Options, bins, rows, pdf, times):
        self.o, self.bins, self.rows, self.pdf, self.times = o, bins, rows, pdf, times
        self.counts = np.zeros(bins.size)
        self.row_counts = np.zeros(rows.size) if rows is not None else None
        self.lost, self.mismatches, self.checked, self.worst = 0.0, 0, 0, 0.0
        self.invalid = {"NaN": 0, "infinite": 0, "negative": 0}
        self.with_pdfs = False

    def add(self, pts, pdfs):
        o = self.o
        t0 = time.perf_counter()
        c, lost = self.bins.count(o.domain, pts, o.unit_tol)
        self.counts += c
        self.lost += lost
        if self.rows is not None:
            self.row_counts += self.rows.count(o.domain, pts, o.unit_tol)[0]
        self.times["binning"] += time.perf_counter() - t0
        if o.check_pdf and pdfs is not None:
            t0 = time.perf_counter()
            self._check(pts, pdfs)
            self.times["pdf_check"] += time.perf_counter() - t0

    def _check(self, pts, pdfs):
        """A returned pdf that is NaN, infinite or negative at a valid point (one not lost) is a mismatch
        whatever ``pdf`` says there; a finite one is compared with ``pdf(point)`` (relative rtol)."""
        o = self.o
        self.with_pdfs = True
        valid = _core.sampler_to_square(o.domain, pts, o.unit_tol)[2] == 0
        finite = np.isfinite(pdfs)
        bad = valid & ~(finite & (pdfs >= 0))
        self.invalid["NaN"] += int((valid & np.isnan(pdfs)).sum())
        self.invalid["infinite"] += int((valid & np.isinf(pdfs)).sum())
        self.invalid["negative"] += int((valid & finite & (pdfs < 0)).sum())
        comparable = np.isfinite(pts).all(axis=1) & finite
        ref = _call_pdf(self.pdf, pts[comparable], o.dim)
        got = pdfs[comparable]
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(got - ref) / np.maximum(np.abs(got), np.abs(ref))
        rel = np.where(got == ref, 0.0, rel)
        mismatch = bad.copy()
        mismatch[comparable] |= rel > o.rtol
        self.mismatches += int(mismatch.sum())
        self.checked += int((comparable | valid).sum())
        if rel.size:
            self.worst = max(self.worst, float(np.nanmax(rel)))


def _lowered_pvalue(statistic: float, dof: int, shift: float) -> float:
    """The chi-square p-value with the statistic lowered by the largest shift the cubature errors may
    cause (docs/math/sampling.md#unresolved-pdf): a rejection that survives it does not depend on them."""
    if dof < 1:
        return math.nan
    if math.isinf(statistic):
        return 0.0
    return float(scipy.stats.chi2.sf(max(0.0, statistic - shift), dof))


def _part(chi: dict, b, cubature_tol: float):
    """(p-value as used, whether the cubature met its rule) for one chi-square over bins ``b``."""
    trusted = (not cubature_tol > 0 or float(b.shift_bound) <= float(b.shift_limit)) and b.unconverged == 0
    p = float(chi["pvalue_chi2"])
    if not trusted and not math.isnan(p):
        p = _lowered_pvalue(float(chi["statistic"]), int(chi["dof"]), float(b.shift_bound))
    return p, trusted


def sampler_test(sample, pdf=None, domain: str | None = None, samples: int = 10**6, seed=0, bins="adaptive", *,
                 significance: float = 1e-3, min_expected: float = 5.0, target: float | None = None,
                 rtol: float = 1e-3, unit_tol: float = 1e-4, check_pdf: bool = True, pilot: int | None = None,
                 chunk: int = 2**20, cubature_tol: float = 0.1, rel_tol: float | None = None,
                 max_depth: int = 16, max_evaluations: int | None = None, marginal_rows: int | None = None,
                 out=None, write: str = "failure", name: str | None = None) -> SamplerTestResult:
    """Tests a direction sampler against its pdf (docs/math/sampling.md).

    ``sample(size, seed) -> (points, pdfs)`` with points (size, 3) on the hemisphere and sphere, (size, 2)
    on the unit disk and the unit square [0, 1]^2, and ``pdfs`` the sampler's own density of each point
    (or None); ``pdf(points) -> (size,)`` the density, per steradian on the hemisphere and sphere, per
    unit area on the disk and square. A sampler object (``sample``, ``pdf`` and ``domain`` attributes,
    e.g. ``gl.sampler("ggx_vndf")``) may be passed as ``sample`` alone.

    ``bins``: ``"adaptive"`` (quadtree over the area-preserving square, split while a bin expects more
    than ``target`` samples; default target max(8 min_expected, samples^(3/5))), tested together with
    ``marginal_rows`` rows of equal polar angle (r on the disk; default 3 degrees, none on the square; 0:
    off), or a fixed grid ``(n_theta, n_phi)`` alone. Points that are NaN, outside the domain or
    (hemisphere, sphere) not unit within ``unit_tol`` are lost; their expected number is what the pdf does
    not integrate to. ``rtol``: the relative difference beyond which the sampler's pdf and ``pdf``
    disagree. ``significance``: the p-value below which the test fails (its false-failure rate).
    ``cubature_tol``: the global cubature rule (docs/math/sampling.md#cubature-error): the integrals are
    refined until the bound on the shift of the chi-square statistic's mean that all bins' cubature errors
    can cause is at most ``cubature_tol`` sqrt(2 dof) (0: off); ``rel_tol`` (default off): also require
    each bin's error to be at most ``rel_tol`` sqrt(max(expected, 1)) samples. A test whose cubature
    cannot meet its rule rejects only where the rejection survives the largest shift, and is otherwise
    inconclusive (p NaN), as is one whose pdf has peaks the cubature cannot resolve.
    Same ``seed``, same result whatever the thread count.
    """
    obj = sample if pdf is None and hasattr(sample, "sample") and hasattr(sample, "pdf") else None
    if obj is not None:
        sample, pdf = obj.sample, obj.pdf
        domain = domain or getattr(obj, "domain", None)
        name = name or getattr(obj, "name", "") or type(obj).__name__
    if not callable(sample):
        V.fail("sample", sample, "a function sample(size, seed) or a sampler object")
    if not callable(pdf):
        V.fail("pdf", pdf, "a function pdf(points)")
    o = _options(domain, samples, seed, bins, significance, min_expected, target, rtol, unit_tol, check_pdf, pilot,
                 chunk, cubature_tol, rel_tol, max_depth, max_evaluations, marginal_rows, write)
    _check_memory(o, pilot is not None)
    if out is not None and write != "never":
        _check_out(Path(out))  # before any draw: a file at `out` is found now, not after the test
    notes = []
    owner = obj if obj is not None else getattr(sample, "__self__", None)
    clamped = getattr(owner, "clamped", 0)  # a shader sampler's pdf values read as 0 (clamp_pdf) before this test
    caveat = getattr(owner, "loop_caveat", None)
    if caveat:  # a shader sampler on lavapipe whose loops may have been cut short
        notes.append(f"not what a GPU would compute: {caveat}")
    times = {"sampling": 0.0, "binning": 0.0, "integration": 0.0, "pdf_check": 0.0}
    t_start = time.perf_counter()
    draw = _Draws(sample, o.dim, times)
    # 1. The bins, with their expected masses; the rows of the marginal test.
    if o.grid:
        b, bins_kind = _grid_bins(o, *o.grid, pdf, times), f"grid {len(o.grid[0]) - 1}x{len(o.grid[1]) - 1}"
    else:
        b, bins_kind = _adaptive_bins(o, draw, pdf, times), "adaptive"
    rows = _rows(o, b, pdf, times) if o.rows else None
    # 2. The samples, in chunks with derived seeds; binned, and their pdfs checked.
    tally = _Tally(o, b, rows, pdf, times)
    for k, start in enumerate(range(0, o.samples, o.chunk)):
        tally.add(*draw(min(o.chunk, o.samples - start), _derived(o.key, 0, k), f"test chunk {k}"))
    if o.n_pilot == 0:  # no pilot to compare with: a few points drawn with a seed of their own
        draw(min(32, o.samples), _derived(o.key, 2, 0), "a probe")
    res = _result(o, b, rows, tally, draw.repeat, notes, name or getattr(sample, "__name__", ""), bins_kind, times)
    times["total"] = time.perf_counter() - t_start
    if getattr(owner, "clamped", 0) > clamped:
        res.notes.append(owner.clamp_note(owner.clamped - clamped))
    if out is not None and (write == "always" or (write == "failure" and not res.passed)):
        res.write(out, stem=_stem(res.name))
    return res


def _result(o: _Options, b, rows, tally: _Tally, repeat, notes, name, bins_kind, times) -> SamplerTestResult:
    """The statistics, the combined p-value and the verdict (docs/math/sampling.md#lost-sample-bin)."""
    integral, error = np.asarray(b.integral), np.asarray(b.error)
    chi = _core.sampler_chi_square(tally.counts, integral, error, tally.lost, float(o.samples), o.min_expected)
    p_chi2, trusted = _part(chi, b, o.cubature_tol)
    p_rows, rows_trusted, rchi = math.nan, True, None
    if rows is not None:
        rchi = _core.sampler_chi_square(tally.row_counts, np.asarray(rows.integral), np.asarray(rows.error),
                                        tally.lost, float(o.samples), o.min_expected)
        p_rows, rows_trusted = _part(rchi, rows, o.cubature_tol)
    p_lost = float(chi["pvalue_lost"])
    if math.isnan(p_chi2):  # no power: only the lost samples can still reject
        pvalue = p_lost if p_lost < 1 else math.nan
    else:
        w = WEIGHTS if rows is not None else WEIGHTS_WITHOUT_ROWS
        parts = [p_chi2 / w["chi2"], p_lost / w["lost"]] + ([p_rows / w["marginal"]] if rows is not None else [])
        pvalue = min([1.0] + [p for p in parts if not math.isnan(p)])
    mass, mass_err = float(integral.sum()), float(error.sum())
    # Peaks the cubature could not follow that could hold more samples than the mass's error allowance:
    # the integrals and their error estimates are then not to be trusted at the harness's resolution.
    unresolved = b.unresolved_peaks > 0 and float(b.unresolved_reach) > max(1.0, float(b.mass_limit))
    if not unresolved:  # (when the pdf is unresolved, its own note says why the numbers below mean nothing)
        notes += ([chi["note"]] if chi["note"] else []) + _cubature_notes(o, b, rows)
    seed_ignored = repeat is not None
    if unresolved:
        notes.append(f"the cubature cannot resolve the pdf: in {b.unresolved_peaks} bin(s) the pdf at a pilot point "
                     f"peaks far above the bin's integral, finer than the bins (max_depth {o.max_depth}) and the "
                     f"evaluation budget ({o.max_evaluations}) can follow (those peaks could hold up to "
                     f"{float(b.unresolved_reach):.3g} samples); the integral it found, {mass:.4g} +- {mass_err:.2g}, "
                     "cannot be trusted: the test is inconclusive (p NaN)")
        pvalue, mass, mass_err = math.nan, math.nan, math.nan
    elif not (trusted and rows_trusted) and not math.isnan(pvalue):
        # The rows are a second look: their lowered statistic only costs them power. The bins are the test:
        # a pass they cannot vouch for is no pass.
        if pvalue < o.significance:
            notes.append("rejected even with each chi-square statistic lowered by the largest shift the cubature "
                         "errors may cause")
        elif not trusted:
            notes.append("the cubature errors are too large to decide: the test is inconclusive (p NaN)")
            pvalue = math.nan
        else:
            notes.append("the rows' chi-square is lowered by the largest shift their cubature errors may cause")
    if seed_ignored:
        notes.append(f"sample(size, seed) returned the same points for two seeds ({repeat[0]} and {repeat[1]}): the "
                     "sampler ignores its seed, so its draws are not independent (and adaptive bins, built from a "
                     "pilot draw, would depend on the samples they test); no p-value (NaN)")
        pvalue = math.nan
    notes += _mass_notes(o, mass, mass_err, tally.lost)
    notes += _pdf_notes(o, tally)
    decided = not math.isnan(pvalue)
    passed = decided and pvalue >= o.significance and tally.mismatches == 0 and not seed_ignored
    inconclusive = not decided and tally.mismatches == 0 and not seed_ignored
    return SamplerTestResult(
        name=name, domain=o.domain, samples=o.samples, seed=o.key, bins_kind=bins_kind,
        significance=o.significance, passed=bool(passed), pvalue=float(pvalue), statistic=float(chi["statistic"]),
        dof=int(chi["dof"]), pvalue_chi2=float(chi["pvalue_chi2"]), pvalue_lost=p_lost, notes=notes,
        rects=np.asarray(b.rects()), observed=tally.counts, expected=o.samples * integral,
        expected_error=o.samples * error, merged_starts=np.asarray(chi["starts"], dtype=np.int64),
        merged_observed=np.asarray(chi["observed"]), merged_expected=np.asarray(chi["expected"]),
        lost=int(tally.lost), lost_expected=float(chi["lost_expected"]), integral=mass, integral_error=mass_err,
        mismatches=tally.mismatches, checked=tally.checked, worst_rel_diff=tally.worst, rtol=o.rtol,
        evaluations=int(b.evaluations) + (int(rows.evaluations) if rows is not None else 0),
        unconverged=int(b.unconverged), times=times, cubature_shift=float(b.shift_bound),
        cubature_limit=float(b.shift_limit) if o.cubature_tol > 0 else math.nan, inconclusive=bool(inconclusive),
        pvalue_marginal=float(rchi["pvalue_chi2"]) if rchi else math.nan,
        marginal_statistic=float(rchi["statistic"]) if rchi else math.nan, marginal_dof=int(rchi["dof"]) if rchi else 0,
        marginal_edges=np.asarray(_grid_edges(o.domain, (o.rows, 1))[0]) if rchi else None,
        marginal_observed=tally.row_counts, marginal_expected=o.samples * np.asarray(rows.integral) if rchi else None,
        invalid_pdfs=sum(tally.invalid.values()), seed_ignored=seed_ignored)


def _cubature_notes(o: _Options, b, rows) -> list:
    notes = []
    if b.unconverged:
        notes.append(f"cubature error above {o.rel_tol:g} sqrt(expected) in {b.unconverged} bin(s) "
                     "(depth or evaluation budget exhausted)")
    for label, bins in (("", b), (" over the rows", rows)):
        if bins is not None and o.cubature_tol > 0 and float(bins.shift_bound) > float(bins.shift_limit):
            notes.append(f"the cubature errors may shift the chi-square statistic{label} by up to "
                         f"{float(bins.shift_bound):.3g}, above {o.cubature_tol:g} sqrt(2 dof) = "
                         f"{float(bins.shift_limit):.3g} (depth or evaluation budget exhausted)")
    # The mass's limit is a refinement target, not a condition of validity: the lost-sample test accepts
    # the whole range the mass's error allows, so a larger error costs power against lost samples only.
    if o.cubature_tol > 0 and float(b.mass_error) > float(b.mass_limit):
        notes.append(f"the total mass's cubature error is {b.mass_error:.3g} samples, above {o.cubature_tol:g} "
                     f"sqrt(N) = {b.mass_limit:.3g} (evaluation budget exhausted): the lost-sample test cannot "
                     "see a loss of fewer samples")
    return notes


def _mass_notes(o: _Options, mass: float, mass_err: float, lost: float) -> list:
    """The pdf's normalization, both ways: below 1 the lost-sample test expects the missing mass lost,
    above 1 beyond its error the pdf claims samples that were never drawn (docs/math/sampling.md#lost-sample-bin)."""
    if math.isnan(mass) or not abs(mass - 1.0) > max(3 * mass_err, 1e-9):
        return []
    text = f"the pdf integrates to {mass:.6g} +- {mass_err:.2g} over the {o.domain}"
    if mass - mass_err > 1.0:
        text += (f": above 1 beyond its error, it claims {o.samples * (mass - mass_err - 1.0):.3g} samples more than "
                 "were drawn")
    elif lost < (few := o.samples * (1.0 - mass - mass_err)) - 3.0 * math.sqrt(few):
        # Only beyond the lost count's Poisson noise: a sampler that loses draws by design (reflected
        # directions below the horizon) loses fewer than expected half the time.
        text += f": below 1, yet only {lost:g} of the {o.samples * (1.0 - mass):.3g} samples it leaves out were lost"
    return [text]


def _pdf_notes(o: _Options, tally: _Tally) -> list:
    notes = []
    if o.check_pdf and not tally.with_pdfs:
        notes.append("the sampler returned no pdfs: consistency not checked")
    if tally.mismatches:
        bad = {k: v for k, v in tally.invalid.items() if v}
        text = f"{tally.mismatches} of {tally.checked} sampler pdfs differ from pdf(point) by more than rtol = {o.rtol:g}"
        if tally.mismatches > sum(bad.values()):
            text += f" (worst relative difference {tally.worst:.3g})"
        if bad:
            text += (f"; {sum(bad.values())} of them are not finite numbers >= 0 at valid points ("
                     + ", ".join(f"{k} {v}" for k, v in bad.items()) + ")")
        notes.append(text)
    return notes


def _stem(name: str) -> str:
    keep = "".join(c if c.isalnum() or c in "-_." else "_" for c in (name or "sampler"))
    return f"sampler_test_{keep}"[:120]
