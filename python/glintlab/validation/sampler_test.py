"""The direction-sampler harness: samples against their pdf by chi-square on adaptive bins, the pdf's
normalization with the lost samples, and the sampler's own pdf against ``pdf`` (docs/math/sampling.md).

``sampler_test(sample, pdf, domain=..., samples=..., seed=..., bins="adaptive")`` draws the samples in
chunks (``sample(size, seed)`` with seeds derived from ``seed``), builds the bins over the domain's
area-preserving square from the pdf's mass and from an independent pilot sample, integrates the pdf
over every bin by adaptive Genz-Malik cubature (the C++ core asks for node batches; each batch is one
``pdf`` call), counts the samples per bin and returns a :class:`SamplerTestResult`. With ``out`` the
result is written there (``.npz`` and ``.csv`` of every bin, a PNG of observed, expected and normalised
residual over the square) when it fails, or always with ``write="always"``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _core
from ..api import checks as V

DOMAINS = ("hemisphere", "sphere", "disk", "square")
_DIM = {"hemisphere": 3, "sphere": 3, "disk": 2, "square": 2}
# What the square's axes are on each domain (plot labels and docs/math/sampling.md#area-preserving-maps).
AXES = {"hemisphere": ("cos theta", "phi / 2 pi"), "sphere": ("(cos theta + 1) / 2", "phi / 2 pi"),
        "disk": ("r^2", "phi / 2 pi"), "square": ("x", "y")}


@dataclass
class SamplerTestResult:
    """What ``sampler_test`` measured. ``pvalue`` combines the chi-square over the bins and the exact
    two-sided Poisson test of the lost samples (weighted Bonferroni: 95 % / 5 %); ``passed`` is
    ``pvalue >= significance`` with no pdf mismatch and a converged cubature. Per bin (in the bins'
    Z order): ``rects`` (s0, t0, width_s, width_t) on the unit square, ``observed``, ``expected``,
    ``expected_error`` (cubature error, in samples). ``merged_*``: the bins as the statistic merged them."""
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

    @property
    def bins(self) -> int:
        return len(self.observed)

    @property
    def note(self) -> str:
        return "; ".join(self.notes)

    def __repr__(self):
        verdict = "pass" if self.passed else "FAIL"
        t = ", ".join(f"{k} {v:.2f} s" for k, v in self.times.items())
        return (f"SamplerTestResult({self.name or 'sampler'} on the {self.domain}: {verdict}, p = {self.pvalue:.4g} "
                f"(chi2 = {self.statistic:.6g}, dof = {self.dof}; {self.bins} bins, {self.samples} samples), "
                f"integral = {self.integral:.6f} +- {self.integral_error:.2g}, lost = {self.lost} "
                f"(expected {self.lost_expected:.3g}), pdf mismatches = {self.mismatches}/{self.checked} "
                f"(worst {self.worst_rel_diff:.2g}), cubature shift <= {self.cubature_shift:.3g} "
                f"(limit {self.cubature_limit:.3g}); {t}"
                + (f"; notes: {self.note}" if self.notes else "") + ")")

    def summary(self) -> dict:
        """The headline numbers as one flat row (tables, the CLI)."""
        return {"name": self.name, "domain": self.domain, "samples": self.samples, "bins": self.bins,
                "dof": self.dof, "statistic": self.statistic, "pvalue": self.pvalue, "passed": self.passed,
                "integral": self.integral, "integral_error": self.integral_error, "lost": self.lost,
                "lost_expected": self.lost_expected, "mismatches": self.mismatches,
                "worst_rel_diff": self.worst_rel_diff, "evaluations": self.evaluations,
                "cubature_shift": self.cubature_shift, "cubature_limit": self.cubature_limit,
                **{f"time_{k}": v for k, v in self.times.items()}}

    def write(self, out, stem: str = "sampler_test") -> list:
        """Writes ``stem.npz`` and ``stem.csv`` (every bin: rectangle, observed, expected, its error,
        residual) and ``stem.png`` (observed, expected and normalised residual over the square) into
        the folder ``out``; returns the paths."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        resid = _residual(self.observed, self.expected)
        npz = out / f"{stem}.npz"
        np.savez_compressed(npz, rects=self.rects, observed=self.observed, expected=self.expected,
                            expected_error=self.expected_error, residual=resid, merged_starts=self.merged_starts,
                            merged_observed=self.merged_observed, merged_expected=self.merged_expected,
                            lost=self.lost, lost_expected=self.lost_expected, domain=self.domain)
        csv = out / f"{stem}.csv"
        header = "s0,t0,width_s,width_t,observed,expected,expected_error,residual"
        np.savetxt(csv, np.column_stack([self.rects, self.observed, self.expected, self.expected_error, resid]),
                   delimiter=",", header=header, comments="", fmt="%.10g")
        png = out / f"{stem}.png"
        plot_bins(self, png)
        self.files = [str(npz), str(csv), str(png)]
        return self.files


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
    (o - e) / sqrt(e) per bin, with the bins' edges where they are coarse enough to see."""
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
    fig.savefig(path, dpi=90)
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
    sphere (Mitsuba's layout), in r and phi on the disk, in x and y on the square."""
    try:
        n1, n2 = (int(g) for g in grid)
    except (TypeError, ValueError):
        V.fail("bins", grid, "'adaptive' or a fixed grid (n1, n2) of integers >= 1")
    if n1 < 1 or n2 < 1 or n1 * n2 > 10**6:
        V.fail("bins", grid, "a fixed grid (n1, n2) of integers >= 1 with at most 1e6 cells")
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


def sampler_test(sample, pdf=None, domain: str | None = None, samples: int = 10**6, seed=0, bins="adaptive", *,
                 significance: float = 1e-3, min_expected: float = 5.0, target: float | None = None,
                 rtol: float = 1e-3, unit_tol: float = 1e-4, check_pdf: bool = True, pilot: int | None = None,
                 chunk: int = 2**20, cubature_tol: float = 0.1, rel_tol: float | None = None,
                 max_depth: int = 16, max_evaluations: int | None = None,
                 out=None, write: str = "failure", name: str | None = None) -> SamplerTestResult:
    """Tests a direction sampler against its pdf (docs/math/sampling.md).

    ``sample(size, seed) -> (points, pdfs)`` with points (size, 3) on the hemisphere and sphere, (size, 2)
    on the unit disk and the unit square [0, 1]^2, and ``pdfs`` the sampler's own density of each point
    (or None); ``pdf(points) -> (size,)`` the density, per steradian on the hemisphere and sphere, per
    unit area on the disk and square. A sampler object (``sample``, ``pdf`` and ``domain`` attributes,
    e.g. ``gl.sampler("ggx_vndf")``) may be passed as ``sample`` alone.

    ``bins``: ``"adaptive"`` (quadtree over the area-preserving square, split while a bin expects more
    than ``target`` samples; default target max(8 min_expected, samples^(3/5))) or a fixed grid
    ``(n_theta, n_phi)``. Points that are NaN, outside the domain or (hemisphere, sphere) not unit
    within ``unit_tol`` are lost; their expected number is what the pdf does not integrate to.
    ``rtol``: the relative difference beyond which the sampler's pdf and ``pdf`` disagree.
    ``significance``: the p-value below which the test fails (its false-failure rate).
    ``cubature_tol``: the global cubature rule (docs/math/sampling.md#cubature-error): the integrals are
    refined until the bound on the shift of the chi-square statistic's mean that all bins' cubature errors
    can cause is at most ``cubature_tol`` sqrt(2 dof) (0: off); ``rel_tol`` (default off): also require
    each bin's error to be at most ``rel_tol`` sqrt(max(expected, 1)) samples.
    Same ``seed``, same result whatever the thread count.
    """
    if pdf is None and hasattr(sample, "sample") and hasattr(sample, "pdf"):
        obj = sample
        sample, pdf = obj.sample, obj.pdf
        domain = domain or getattr(obj, "domain", None)
        name = name or getattr(obj, "name", "") or type(obj).__name__
    if not callable(sample):
        V.fail("sample", sample, "a function sample(size, seed) or a sampler object")
    if not callable(pdf):
        V.fail("pdf", pdf, "a function pdf(points)")
    domain = domain or "hemisphere"
    if domain not in DOMAINS:
        V.fail("domain", domain, "one of " + ", ".join(DOMAINS))
    dim = _DIM[domain]
    V.integer("samples", samples, 1, 10**10, expected="an integer in [1, 1e10]")
    samples = int(samples)
    key = V.seed(seed)
    significance = V.real("significance", significance)
    if not 0 < significance < 1:
        V.fail("significance", significance, "a number in (0, 1)")
    min_expected = V.real("min_expected", min_expected)
    if not (min_expected > 0 and math.isfinite(min_expected)):
        V.fail("min_expected", min_expected, "a finite number > 0")
    rtol = V.real("rtol", rtol)
    if not rtol > 0:
        V.fail("rtol", rtol, "a number > 0")
    unit_tol = V.real("unit_tol", unit_tol)
    if not unit_tol > 0:
        V.fail("unit_tol", unit_tol, "a number > 0")
    V.integer("chunk", chunk, minimum=1)
    cubature_tol = V.real("cubature_tol", cubature_tol)
    if not (cubature_tol >= 0 and math.isfinite(cubature_tol)):
        V.fail("cubature_tol", cubature_tol, "a finite number >= 0")
    rel_tol = 0.0 if rel_tol is None else V.real("rel_tol", rel_tol)
    if not (rel_tol >= 0 and math.isfinite(rel_tol)):
        V.fail("rel_tol", rel_tol, "a finite number >= 0 (or None)")
    if cubature_tol == 0 and rel_tol == 0:
        V.fail("cubature_tol", cubature_tol, "a number > 0 when rel_tol is off (the cubature needs a stopping rule)")
    if write not in ("failure", "always", "never"):
        V.fail("write", write, "'failure', 'always' or 'never'")
    if target is None:
        # About 2 N^(2/5) bins for a smooth pdf (Mann & Wald's rule of thumb: power against smooth
        # deviations falls as the bins multiply), more where a spiky pdf's mass forces splits.
        target = max(8.0 * min_expected, samples ** 0.6)
    target = V.real("target", target)
    if not (target > 0 and math.isfinite(target)):
        V.fail("target", target, "a finite number > 0")
    if max_evaluations is None:
        # pdf evaluations the cubature may spend: enough for thousands of resolved lobes, and a stop for a
        # pdf that is not integrable (a 1/cos singularity splits cells along the horizon forever).
        max_evaluations = max(4_000_000, 2 * samples)
    notes = []
    times = {"sampling": 0.0, "binning": 0.0, "integration": 0.0, "pdf_check": 0.0}
    t_start = time.perf_counter()

    def draw(size, seed_):
        t0 = time.perf_counter()
        pts, pdfs = _call_sample(sample, size, seed_, dim)
        times["sampling"] += time.perf_counter() - t0
        return pts, pdfs

    # 1. The bins: from an independent pilot sample (another seed), so that the bins never depend on
    # the samples they test, and from the pdf's own mass.
    if isinstance(bins, str):
        if bins != "adaptive":
            V.fail("bins", bins, "'adaptive' or a fixed grid (n1, n2)")
        n_pilot = samples // 2 if pilot is None else int(pilot)
        n_pilot = max(0, min(n_pilot, samples))
        ps, pt = np.zeros(0), np.zeros(0)
        for k, start in enumerate(range(0, n_pilot, chunk)):
            pts, _ = draw(min(chunk, n_pilot - start), _derived(key, 1, k))
            t0 = time.perf_counter()
            s, t, lost = _core.sampler_to_square(domain, pts, unit_tol)
            ps, pt = np.concatenate([ps, s[lost == 0]]), np.concatenate([pt, t[lost == 0]])
            times["binning"] += time.perf_counter() - t0
        t0 = time.perf_counter()
        # The pdf at the pilot points shows peaks the cubature's nodes may have stepped over.
        pq = _call_pdf(pdf, _core.sampler_from_square(domain, ps, pt), dim) if len(ps) else np.zeros(0)
        b = _core.SamplerBins(domain, float(samples), target, 2, int(max_depth), 12, float(rel_tol),
                              int(max_evaluations), ps, pt, float(n_pilot), pq, shift_tol=float(cubature_tol),
                              min_expected=float(min_expected))
        bins_kind = "adaptive"
    else:
        s_edges, t_edges = _grid_edges(domain, bins)
        t0 = time.perf_counter()
        b = _core.SamplerBins.grid(domain, float(samples), 12, float(rel_tol), int(max_evaluations), s_edges, t_edges,
                                   shift_tol=float(cubature_tol), min_expected=float(min_expected))
        bins_kind = f"grid {len(s_edges) - 1}x{len(t_edges) - 1}"
    # 2. Cubature: one pdf call per round of nodes.
    while not b.done:
        b.supply(_call_pdf(pdf, b.nodes(), dim))
    times["integration"] += time.perf_counter() - t0
    if b.unconverged:
        notes.append(f"cubature error above {rel_tol:g} sqrt(expected) in {b.unconverged} bin(s) "
                     "(depth or evaluation budget exhausted)")
    shift, shift_limit = float(b.shift_bound), float(b.shift_limit) if cubature_tol > 0 else math.nan
    shift_ok = not cubature_tol > 0 or shift <= shift_limit
    # The mass's limit is a refinement target, not a condition of validity: the lost-sample test accepts
    # the whole range the mass's error allows, so a larger error costs power against lost samples only.
    mass_ok = not cubature_tol > 0 or float(b.mass_error) <= float(b.mass_limit)
    if not shift_ok:
        notes.append(f"the cubature errors may shift the chi-square statistic by up to {shift:.3g}, above "
                     f"{cubature_tol:g} sqrt(2 dof) = {shift_limit:.3g} (depth or evaluation budget exhausted)")
    if not mass_ok:
        notes.append(f"the total mass's cubature error is {b.mass_error:.3g} samples, above {cubature_tol:g} "
                     f"sqrt(N) = {b.mass_limit:.3g} (evaluation budget exhausted): the lost-sample test cannot "
                     "see a loss of fewer samples")
    # 3. The samples, in chunks with derived seeds; binned, and their pdfs checked.
    counts = np.zeros(b.size)
    lost_total, mismatches, checked, worst = 0.0, 0, 0, 0.0
    for k, start in enumerate(range(0, samples, chunk)):
        pts, pdfs = draw(min(chunk, samples - start), _derived(key, 0, k))
        t0 = time.perf_counter()
        c, lost = b.count(domain, pts, unit_tol)
        counts += c
        lost_total += lost
        times["binning"] += time.perf_counter() - t0
        if check_pdf and pdfs is not None:
            t0 = time.perf_counter()
            ok = np.isfinite(pts).all(axis=1) & np.isfinite(pdfs)
            ref = _call_pdf(pdf, pts[ok], dim)
            got = pdfs[ok]
            with np.errstate(divide="ignore", invalid="ignore"):
                rel = np.abs(got - ref) / np.maximum(np.abs(got), np.abs(ref))
            rel = np.where((got == ref), 0.0, rel)
            mismatches += int((rel > rtol).sum())
            checked += int(ok.sum())
            if rel.size:
                worst = max(worst, float(np.nanmax(rel)))
            times["pdf_check"] += time.perf_counter() - t0
    if check_pdf and checked == 0:
        notes.append("the sampler returned no pdfs: consistency not checked")
    integral, error = np.asarray(b.integral), np.asarray(b.error)
    chi = _core.sampler_chi_square(counts, integral, error, lost_total, float(samples), min_expected)
    if chi["note"]:
        notes.append(chi["note"])
    mass, mass_err = float(integral.sum()), float(error.sum())
    if abs(mass - 1.0) > max(3 * mass_err, 1e-9):
        notes.append(f"the pdf integrates to {mass:.6g} +- {mass_err:.2g} over the {domain}")
    if mismatches:
        notes.append(f"{mismatches} of {checked} sampler pdfs differ from pdf(point) by more than rtol = {rtol:g} "
                     f"(worst relative difference {worst:.3g})")
    pvalue = float(chi["pvalue"])
    passed = bool(pvalue >= significance) and mismatches == 0 and b.unconverged == 0 and shift_ok
    times["total"] = time.perf_counter() - t_start
    res = SamplerTestResult(
        name=name or getattr(sample, "__name__", ""), domain=domain, samples=samples, seed=key, bins_kind=bins_kind,
        significance=significance, passed=passed, pvalue=pvalue, statistic=float(chi["statistic"]), dof=int(chi["dof"]),
        pvalue_chi2=float(chi["pvalue_chi2"]), pvalue_lost=float(chi["pvalue_lost"]), notes=notes,
        rects=np.asarray(b.rects()), observed=counts, expected=samples * integral, expected_error=samples * error,
        merged_starts=np.asarray(chi["starts"], dtype=np.int64), merged_observed=np.asarray(chi["observed"]),
        merged_expected=np.asarray(chi["expected"]), lost=int(lost_total), lost_expected=float(chi["lost_expected"]),
        integral=mass, integral_error=mass_err, mismatches=mismatches, checked=checked, worst_rel_diff=worst,
        rtol=rtol, evaluations=int(b.evaluations), unconverged=int(b.unconverged), times=times,
        cubature_shift=shift, cubature_limit=shift_limit)
    if out is not None and (write == "always" or (write == "failure" and not passed)):
        res.write(out, stem=_stem(res.name))
    return res


def _stem(name: str) -> str:
    keep = "".join(c if c.isalnum() or c in "-_." else "_" for c in (name or "sampler"))
    return f"sampler_test_{keep}"[:120]
