"""A per-pixel, per-wave GPU cost model from the compiler's ISA and measured trip counts
(docs/guide/gpu_cost.md#the-per-wave-cost-model).

Static statistics count a loop body with an assumed trip count (ACO's estimate assumes 8 iterations per
loop level); glint methods loop data-dependently. The model costs a pixel by the path it takes:

1. **Blocks and loops from the ISA.** The assembly RADV returns is split into basic blocks; a branch to
   an earlier block closes a loop (its back edge), and loops nest by containment. Each block's cost is
   its issue cycles (:func:`issue_cycles`: one cycle per instruction of a wave, four for the quarter-rate
   transcendental ops, a wave64 VALU op on GCN's SIMD16 four).
2. **Trip counts per pixel**, one array per loop in the order the loops open in the ISA, measured on the
   scene by the method's C++ twin (or its formulas); a block runs, for a wave, the product over its
   enclosing loops of the largest trip count among the wave's lanes (the slowest lane sets the wave).
3. **A wave's cycles** = ACO's inverse throughput x (the wave's issue cycles with those trip counts) /
   (the issue cycles with ACO's assumed trip counts): ACO's estimate keeps what it knows (latency hidden
   at the occupancy the registers allow), with its loop guess replaced by the measured counts.
4. **A frame** = the sum over the waves covering the lit pixels (8 x 4 pixel tiles for wave32, 8 x 8 for
   wave64) divided by the named GPU's SIMDs x clock.

Left out: memory (no caches, no texture units: the glint methods here hash instead of fetching), the
rest of the frame (geometry, the G-buffer, other passes, the papers' timings include them), launch and
tail effects, the branch weights ACO applies to uniform and divergent ifs.
"""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np

from ..api import checks as V

_LABEL = re.compile(r"^(BB\d+):")
_BRANCH = re.compile(r"\bs_(?:c?branch\w*)\s+(BB\d+)")
_QUARTER_RATE = re.compile(r"^v_(sin|cos|exp|log|rcp|rsq|sqrt)_")
_FREE = ("s_waitcnt", "s_endpgm", "s_code_end", "s_inst_prefetch", "s_delay_alu", "s_clause")


@dataclasses.dataclass
class Loop:
    start: int   # index of the header block
    end: int     # index of the block holding the back edge
    depth: int   # 1 for an outermost loop
    parent: int  # index in the loop list of the enclosing loop, -1 for none


@dataclasses.dataclass
class KernelISA:
    blocks: list   # [(label, [instruction lines])]
    cycles: np.ndarray  # issue cycles per block
    loops: list    # [Loop] in the order they open


def issue_cycles(line: str, wave_size: int) -> int:
    """Issue cycles of one instruction for one wave: 0 for waits and markers, s_nop k: k + 1, a quarter-
    rate transcendental 4, any other 1; a vector op of a wave64 on GCN's SIMD16 four times that."""
    op = line.split()[0] if line.split() else ""
    if not op or op.startswith(_FREE):
        return 0
    if op == "s_nop":
        m = re.search(r"s_nop\s+(\d+|0x[0-9a-fA-F]+)", line)
        return 1 + (int(m.group(1), 0) if m else 0)
    cycles = 4 if _QUARTER_RATE.match(op) else 1
    if op.startswith("v_") and wave_size == 64:
        cycles *= 4
    return cycles


def parse_isa(isa: str, wave_size: int) -> KernelISA:
    """The ISA's basic blocks, their issue cycles and its loops (back edges, nested by containment)."""
    blocks = []
    for raw in isa.splitlines():
        line = raw.split(";")[0].strip()
        m = _LABEL.match(line)
        if m:
            blocks.append((m.group(1), []))
        elif line:
            if not blocks:
                blocks.append(("BB_entry", []))
            blocks[-1][1].append(line)
    order = {label: i for i, (label, _) in enumerate(blocks)}
    cycles = np.array([sum(issue_cycles(x, wave_size) for x in body) for _, body in blocks], dtype=np.float64)
    spans = {}
    for i, (_, body) in enumerate(blocks):
        for line in body:
            m = _BRANCH.search(line)
            if m and m.group(1) in order and order[m.group(1)] <= i:
                h = order[m.group(1)]
                spans[h] = max(spans.get(h, h), i)
    loops = []
    for start in sorted(spans):
        end = spans[start]
        parent = -1
        for j in range(len(loops) - 1, -1, -1):
            if loops[j].start <= start and end <= loops[j].end:
                parent = j
                break
        loops.append(Loop(start, end, 1 if parent < 0 else loops[parent].depth + 1, parent))
    return KernelISA(blocks, cycles, loops)


def aco_weights(k: KernelISA) -> np.ndarray:
    """Executions per block that ACO's estimate assumes: 8 at loop depth 1, x4 at depth 2, x2 per level deeper."""
    w = np.ones(len(k.blocks))
    for i in range(len(k.blocks)):
        depth = max([lp.depth for lp in k.loops if lp.start <= i <= lp.end], default=0)
        w[i] = (8.0 if depth > 0 else 1.0) * (4.0 if depth > 1 else 1.0) * (2.0 ** max(depth - 2, 0))
    return w


def innermost_loop(k: KernelISA) -> np.ndarray:
    """Per block, the index of its innermost enclosing loop (-1 outside every loop)."""
    owner = np.full(len(k.blocks), -1)
    for j, lp in enumerate(k.loops):  # later loops that open inside earlier ones are deeper
        owner[lp.start:lp.end + 1] = j
    return owner


@dataclasses.dataclass
class KernelCost:
    """A kernel's cost model on one architecture: ``isa`` (blocks, loops), ``inverse_throughput`` and
    ``waves_per_simd`` (ACO's), ``wave_size``; :meth:`wave_cycles` costs waves from trip counts."""
    isa: KernelISA
    inverse_throughput: float
    waves_per_simd: float
    wave_size: int

    @classmethod
    def from_stats(cls, stats: dict) -> "KernelCost":
        """From a row of ``gl.gpu_cost(..., isa=True)`` (or ``compile_stats(..., isa=True)``)."""
        return cls(parse_isa(stats["isa"], int(stats["wave_size"])), float(stats["inverse_throughput"]),
                   float(stats["waves_per_simd"]), int(stats["wave_size"]))

    @property
    def n_loops(self) -> int:
        return len(self.isa.loops)

    def scale(self) -> float:
        """Cycles per issue cycle: ACO's inverse throughput over the issue cycles at its assumed trip counts."""
        return self.inverse_throughput / float(np.dot(self.isa.cycles, aco_weights(self.isa)))

    def loop_cycles(self) -> tuple[float, np.ndarray]:
        """(fixed, per_iteration): issue cycles outside every loop and of each loop's own body (blocks
        not inside a deeper loop), in ACO-scaled cycles."""
        owner = innermost_loop(self.isa)
        s = self.scale()
        per = np.array([self.isa.cycles[owner == j].sum() for j in range(self.n_loops)]) * s
        return float(self.isa.cycles[owner < 0].sum() * s), per

    def wave_cycles(self, trips) -> np.ndarray:
        """Cycles per wave from ``trips``: one array per loop (in ISA order) of shape (waves, lanes), the
        loop's iterations per lane of each wave (per iteration of its parent loop, for a nested loop);
        lanes that are not pixels hold 0. A loop runs, per wave, the largest count among its lanes."""
        trips = list(trips)
        if len(trips) != self.n_loops:
            V.fail("trips", f"{len(trips)} arrays", f"one per loop of the ISA ({self.n_loops})")
        fixed, per = self.loop_cycles()
        runs = []
        for j, lp in enumerate(self.isa.loops):
            t = np.asarray(trips[j], dtype=np.float64)
            own = t.max(axis=-1) if t.ndim >= 2 else t
            runs.append(own * (runs[lp.parent] if lp.parent >= 0 else 1.0))
        total = np.full(np.shape(runs[0]) if runs else (), fixed)
        for j in range(self.n_loops):
            total = total + per[j] * runs[j]
        return total


def tiles(values: np.ndarray, mask: np.ndarray, wave_size: int) -> tuple[np.ndarray, np.ndarray]:
    """An image's per-pixel values (H, W, ...) grouped into the waves that cover it: 8 x 4 pixel tiles for
    wave32, 8 x 8 for wave64 (rows of 8 lanes), only tiles with a lit pixel (``mask``); lanes off the
    mask hold 0. Returns (values (waves, lanes, ...), lane mask (waves, lanes))."""
    h, w = mask.shape
    th, tw = (4, 8) if wave_size == 32 else (8, 8)
    H, W = math.ceil(h / th) * th, math.ceil(w / tw) * tw
    vals = np.zeros((H, W) + values.shape[2:], dtype=np.float64)
    m = np.zeros((H, W), dtype=bool)
    vals[:h, :w] = np.where(mask.reshape(mask.shape + (1,) * (values.ndim - 2)), values, 0.0)
    m[:h, :w] = mask
    vals = vals.reshape(H // th, th, W // tw, tw, *values.shape[2:]).swapaxes(1, 2).reshape(
        (H // th) * (W // tw), th * tw, *values.shape[2:])
    m = m.reshape(H // th, th, W // tw, tw).swapaxes(1, 2).reshape(-1, th * tw)
    keep = m.any(axis=1)
    return vals[keep], m[keep]


def frame_seconds(wave_cycles: np.ndarray, arch: dict) -> float:
    """A frame's seconds: the waves' cycles summed, spread over the named GPU's SIMDs at its clock
    (``arch``: a row of ``gl.gpu_architectures()``)."""
    simds = int(arch["compute_units"]) * int(arch["simds_per_cu"])
    return float(np.sum(wave_cycles)) / (simds * float(arch["clock_mhz"]) * 1e6)
