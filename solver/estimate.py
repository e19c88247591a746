"""How big a problem is before we allocate anything for it.

The graph is stored as one row of n values per state reached (:mod:`citysynth.solver.graph`),
so memory is bounded by (states in the box) x (row size); the box is already
tightened by the longest possible sequence (:mod:`citysynth.solver.compiled`). We refuse when
that bound exceeds the caller's budget, and say which resource makes the box large
and what to change. Growth also stops at the same budget, so an estimate that is
wrong can never turn into an out-of-memory crash.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from citysynth.solver.compiled import Compiled
from citysynth.solver.errors import TooLargeError
from citysynth.solver.methods import DEFAULT_MAX_MEMORY_MB

DENSE_TABLE_MAX_BYTES = 1 << 28    # rows indexed by state up to this size, else hashed


@dataclass(frozen=True)
class Estimate:
    nodes: int          # upper bound on nodes (elements x states)
    bytes: int          # memory for every state row, the row table and W (if dense)
    dense: bool         # rows indexed by state (else hashed)
    max_rows: int       # row budget enforced during growth

    def to_dict(self) -> dict:
        return {"nodes_bound": self.nodes, "bytes_bound": self.bytes,
                "table": "dense" if self.dense else "hash"}


def row_bytes(n: int, dense: bool) -> int:
    """g and h for n elements, the state, two bucket links and flags (+ hash slot)."""
    return 16 * n + 18 + (0 if dense else 48)


def dense_rows(cp: Compiled) -> bool:
    """Whether the state box is small enough to index rows by state (no hashing)."""
    return cp.S * row_bytes(cp.n, True) <= DENSE_TABLE_MAX_BYTES


def estimate(cp: Compiled, max_memory_mb: float = DEFAULT_MAX_MEMORY_MB) -> Estimate:
    budget = int(max_memory_mb * 2**20)
    fitting = int((cp.r <= cp.cap).all(axis=1).sum())
    nodes = max(fitting, 1) * cp.S
    dense = dense_rows(cp)
    fixed = 0 if cp.sparse else 8 * cp.n * cp.n  # the dense transition table, if used
    need = cp.S * row_bytes(cp.n, dense) + fixed
    max_rows = max((budget - fixed) // row_bytes(cp.n, dense), 1)
    est = Estimate(int(nodes), int(need), dense, int(max_rows))
    if need > budget:
        raise too_large(cp, est.nodes, need, budget)
    return est


def too_large(cp: Compiled, nodes: int, need: int, budget: int) -> TooLargeError:
    """The refusal of a problem whose graph would take ``need`` bytes, over ``budget``."""
    widest = int(np.argmax(cp.cap))
    name = cp.bounded[widest]
    q = cp.quant[widest]
    values = int(cp.cap[widest]) + 1
    return TooLargeError(
        f"problem too large: up to {nodes:,} graph states (~{need / 2**20:,.0f} MB) "
        f"exceed the memory budget of {budget / 2**20:,.0f} MB. "
        f'The widest resource is "{name}" ({values:,} values at quantum {q.quantum:g}): '
        f"use a coarser quantum (e.g. {coarser_quanta(cp, need / max(budget, 1))}), "
        "tighten the bounds, or raise the budget (--max-memory MB)",
        need_mb=need / 2**20, budget_mb=budget / 2**20)


MANY_VALUES = 100   # a resource with fewer values is left its quantum in the advice


def coarser_quanta(cp: Compiled, overshoot: float) -> str:
    """Quanta that fit a graph ``overshoot`` times the budget, as a problem file gives
    them: the graph grows with the product of the bounded resources' values, so each
    of the R with many values (a count of doors in [1, 3] keeps its unit) is made
    coarser by the overshoot's R-th root (and a fifth more). Doubling the widest was
    advised whatever the overshoot (18,692 MB against 2,048: "0.4" for 0.2, and refused
    again)."""
    wide = [i for i in range(len(cp.bounded)) if cp.cap[i] >= MANY_VALUES] \
        or [int(np.argmax(cp.cap))]
    factor = max(2.0, (1.2 * overshoot) ** (1.0 / max(len(wide), 1)))
    return '"quantum": {' + ", ".join(
        f'"{cp.bounded[i]}": {cp.quant[i].quantum * math.ceil(factor):.6g}' for i in wide) + "}"
