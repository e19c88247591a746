"""A :class:`~citysynth.solver.problem.Problem` turned into the flat integer arrays the kernels use.

Only constrained ("bounded") resources enter the graph state; the others are just
summed for the report. A state is the vector c of consumed quanta, stored as one
integer in mixed radix over the box ``0 <= c_i <= cap_i``. ``cap_i`` is the upper
bound tightened by the longest possible sequence, which keeps the box (and a dense
node table) small for resources like doors that are bounded loosely.

The unary cost of an element is folded into the weight of every edge entering it
(and of the source edge), so the kernels only ever add edge weights. Successor and
predecessor tables are CSR arrays sorted by element index: the order is part of the
deterministic tie-breaking. The dense n x n table ``W`` is built only when a kernel
asks for it (:attr:`Compiled.W`): a motion graph of 9,700 segments with 32 successors
each has 310,000 transitions, and its dense table would take 750 MB to hold them.
Kernels walk the lists instead when the table is sparse (:attr:`Compiled.sparse`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from citysynth.solver.errors import ProblemError, TooLargeError
from citysynth.solver.problem import Problem
from citysynth.solver.quantize import Quantisation, quantise_resource

MAX_DENSE_TRANSITIONS_BYTES = 1 << 30
# Below this share of the n x n pairs the transition lists are walked, not the matrix:
# a dense row costs n contiguous (vectorised) steps, a list entry one indirect step.
SPARSE_DENSITY = 0.25


@dataclass
class Compiled:
    ids: list[str]
    bounded: list[str]
    quant: list[Quantisation]
    r: np.ndarray          # int64 [n, R]   quantised consumption
    lo: np.ndarray         # int64 [R]
    hi: np.ndarray         # int64 [R]
    cap: np.ndarray        # int64 [R]      box bound, <= hi
    stride: np.ndarray     # int64 [R]
    S: int                 # number of states in the box
    off: np.ndarray        # int64 [n]      linear state offset of each element
    lev: np.ndarray        # int64 [n]      level increment (sum of quanta) of each element
    top: int               # highest level
    omega: np.ndarray      # float64 [n]
    succ_ptr: np.ndarray   # int64 [n+1]
    succ_elem: np.ndarray  # int64
    succ_w: np.ndarray     # float64   delta(e, f) + omega(f)
    pred_ptr: np.ndarray
    pred_elem: np.ndarray
    pred_w: np.ndarray     # float64   delta(p, e) + omega(e)
    front: np.ndarray      # bool [n]
    back: np.ndarray       # bool [n]
    max_len: int
    _W: np.ndarray | None = field(default=None, repr=False)

    @property
    def W(self) -> np.ndarray:
        """float64 [n, n]: W[f, e] = delta(e, f) + omega(f), inf where e -> f is not
        allowed; the same table as the lists, dense and transposed, so a kernel relaxes
        every transition into f (or out of e, read as W[e, :]) as one contiguous vector
        operation. Built on first use."""
        if self._W is None:
            n = self.n
            if n * n * 8 > MAX_DENSE_TRANSITIONS_BYTES:
                raise ProblemError(
                    f"{n:,} elements need a {n * n * 8 / 2**30:.1f} GB dense transition "
                    f"table, more than the {MAX_DENSE_TRANSITIONS_BYTES / 2**30:.0f} GB "
                    "allowed; split the library by style or class so each problem holds "
                    "fewer elements")
            W = np.full((n, n), np.inf)
            rows = np.repeat(np.arange(n), np.diff(self.pred_ptr))
            W[rows, self.pred_elem] = self.pred_w
            self._W = W
        return self._W

    @property
    def sparse(self) -> bool:
        """Kernels should walk the transition lists: few transitions per element, or a
        dense table too large to build."""
        n = self.n
        return (len(self.succ_elem) < SPARSE_DENSITY * n * n
                or n * n * 8 > MAX_DENSE_TRANSITIONS_BYTES)

    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def R(self) -> int:
        return len(self.bounded)

    @property
    def empty_bounds(self) -> list[int]:
        """Indices of resources whose interval holds no multiple of the quantum."""
        return [i for i in range(self.R) if self.lo[i] > self.hi[i]]


def _csr(n: int, rows: np.ndarray, cols: np.ndarray, w: np.ndarray):
    order = np.argsort(rows * n + cols, kind="stable")  # by row, then column
    rows, cols, w = rows[order], cols[order], w[order]
    ptr = np.zeros(n + 1, dtype=np.int64)
    ptr[1:] = np.cumsum(np.bincount(rows, minlength=n))
    return ptr, cols.astype(np.int64), w.astype(np.float64)


HI_CAP = 2**53           # quanta: beyond this a bound cannot matter (nor fit int64 sums)


def compile_problem(p: Problem) -> Compiled:
    """Quantise and flatten ``p``; raises ProblemError for an unbounded element."""
    ids = [e.id for e in p.elements]
    index = p.element_index()
    n = len(ids)
    bounded = [r for r in p.resources if r in p.constraints]
    quant: list[Quantisation] = []
    cols = []
    for name in bounded:
        asked_lo, asked_hi = p.constraints[name]
        qz, ints = quantise_resource(name, [e.resources[name] for e in p.elements],
                                     asked_lo, asked_hi, p.quantum.get(name))
        quant.append(qz)
        cols.append(ints)
    R = len(bounded)
    r = np.array(cols, dtype=np.int64).T.reshape(n, R)
    lo = np.array([min(q.lo, HI_CAP) for q in quant], dtype=np.int64)
    # a bound past any countable total (1e300) is no bound: capped, the size estimates
    # then refuse or solve it like any wide interval
    hi = np.array([min(q.hi, HI_CAP) for q in quant], dtype=np.int64)

    lev = r.sum(axis=1)
    for i in np.flatnonzero(lev == 0):
        raise ProblemError(
            f'element "{ids[i]}" consumes nothing of the constrained resource(s) '
            f"{', '.join(bounded)} (after quantisation), so a sequence could repeat it "
            "without end; give it a positive amount of a constrained resource, or "
            "constrain a resource it uses"
        )

    box = _box(r, lev, lo, hi, bounded)

    omega = np.array([e.cost for e in p.elements], dtype=np.float64)
    a, b, d = p.transition_index
    w = d + omega[b]
    succ_ptr, succ_elem, succ_w = _csr(n, a, b, w)
    pred_ptr, pred_elem, pred_w = _csr(n, b, a, w)

    front = np.zeros(n, dtype=np.bool_)
    front[[index[x] for x in p.front]] = True
    back = np.zeros(n, dtype=np.bool_)
    back[[index[x] for x in p.back]] = True

    return Compiled(
        ids=ids, bounded=bounded, quant=quant, r=r, lo=lo, hi=hi,
        lev=lev.astype(np.int64), omega=omega,
        succ_ptr=succ_ptr, succ_elem=succ_elem, succ_w=succ_w,
        pred_ptr=pred_ptr, pred_elem=pred_elem, pred_w=pred_w,
        front=front, back=back, **box,
    )


def _box(r: np.ndarray, lev: np.ndarray, lo: np.ndarray, hi: np.ndarray,
         names: Sequence[str]) -> dict:
    """The state box for bounds lo..hi: caps, strides, offsets, top level (``names``:
    the resources', for a refusal)."""
    R = r.shape[1]
    # Longest possible sequence: every element uses >= 1 level, and resources that
    # every element consumes bound it more tightly.
    hi_pos = np.maximum(hi, 0)
    max_len = int(hi_pos.sum() // max(int(lev.min()), 1))
    for i in range(R):
        m = int(r[:, i].min())
        if m > 0:
            max_len = min(max_len, int(hi_pos[i]) // m)
    cap = np.minimum(hi_pos, max_len * r.max(axis=0)).astype(np.int64)
    states = math.prod(int(c) + 1 for c in cap)   # Python integers: no overflow
    if states > MAX_STATES:
        raise _box_too_large(cap, states, names)
    stride = np.ones(R, dtype=np.int64)
    for i in range(1, R):
        stride[i] = stride[i - 1] * (cap[i - 1] + 1)
    S = int(stride[-1] * (cap[-1] + 1))
    off = (r * stride).sum(axis=1).astype(np.int64)
    return dict(cap=cap, stride=stride, S=S, off=off, top=int(cap.sum()), max_len=max_len)


MAX_STATES = 1 << 62
"""The largest state box a state index (int64) can number. A box past it (intervals of
about 10^18 quanta and more) is refused before anything is allocated: it used to
overflow into negative sizes."""


def _box_too_large(cap: np.ndarray, states: int, names: Sequence[str]) -> TooLargeError:
    widest = int(np.argmax(cap))
    return TooLargeError(
        f"problem too large: its intervals span about {states:.3g} states (totals up to "
        f"{int(cap[widest]):.3g} quanta of \"{names[widest]}\"), more than "
        f"any table can number ({MAX_STATES:.3g}); tighten the bounds or give a coarser "
        "quantum")


def with_bounds(cp: Compiled, lo: np.ndarray, hi: np.ndarray) -> Compiled:
    """The same problem with other quantised bounds (used to diagnose infeasibility)."""
    lo = np.asarray(lo, dtype=np.int64)
    hi = np.asarray(hi, dtype=np.int64)
    return replace(cp, lo=lo, hi=hi, **_box(cp.r, cp.lev, lo, hi, cp.bounded))
