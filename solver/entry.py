"""The public entry point: ``solve(problem, k, method)``.

A thin layer over the kernels (like shapely's Python API over its vectorised core):
compile and quantise, pick the method, estimate and refuse if too large, find the k
best sequences (the cost-bounded search ``bounded``, the intermediate graph and its
k best paths ``rcksp``, or the baseline ``fgs``), then map indices back to ids,
recompute every cost and resource total from the sequence itself in one canonical
order, and explain infeasibility.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from citysynth.solver.bounded import bounded_k_best, bounds_for
from citysynth.solver.compiled import HI_CAP, Compiled, compile_problem
from citysynth.solver.diagnose import diagnose
from citysynth.solver.errors import ProblemError, TooLargeError
from citysynth.solver.estimate import dense_rows, estimate, row_bytes, too_large
from citysynth.solver.fgs import fgs
from citysynth.solver.graph import build_graph
from citysynth.solver.kbest import k_best
from citysynth.solver.methods import DEFAULT_MAX_MEMORY_MB, METHODS, Method
from citysynth.solver.problem import Problem
from citysynth.solver.quantize import quanta_text

# a result holds the k best sequences, or none and the reason
Status = Literal["ok", "infeasible"]


@dataclass(frozen=True)
class Solution:
    sequence: list[str]
    cost: float
    resources: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        return {"sequence": list(self.sequence), "cost": self.cost,
                "resources": dict(self.resources)}


@dataclass
class Result:
    status: Status
    solutions: list[Solution]
    stats: dict[str, Any]
    reason: str | None = None        # why infeasible
    details: list[dict] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "status": self.status,
            "solutions": [s.to_dict() for s in self.solutions],
            "stats": self.stats,
        }
        if self.reason is not None:
            d["reason"] = self.reason
            d["details"] = self.details
        return d


def _transition_keys(cp: Compiled) -> np.ndarray:
    """e * n + f of every listed transition, ascending (the successor lists' order)."""
    rows = np.repeat(np.arange(cp.n, dtype=np.int64), np.diff(cp.succ_ptr))
    return rows * cp.n + cp.succ_elem


def _sequence_cost(cp: Compiled, seq: list[int], keys: np.ndarray | None = None) -> float:
    """Eq. (4) of the paper summed front to back: omega(e1) + sum(delta + omega); one
    canonical order, so every method reports bit-identical costs. ``keys`` is
    :func:`_transition_keys` (computed here when not given)."""
    if keys is None:
        keys = _transition_keys(cp)
    a = np.asarray(seq, dtype=np.int64)
    j = np.searchsorted(keys, a[:-1] * cp.n + a[1:])
    c = float(cp.omega[seq[0]])
    for w in cp.succ_w[j].tolist():
        c += w  # delta(a, b) + omega(b), added as one term
    return c


def _sequence_resources(p: Problem, seq: list[int]) -> dict[str, float]:
    """Totals in original units: exact sums (fsum) of the elements' own values."""
    el = p.elements
    return {r: round(math.fsum(el[i].resources[r] for i in seq), 9) for r in p.resources}


# What "auto" weighs, measured (README "Speed"): asked for thousands of sequences, the
# best-first search spends 120-180 us per sequence (80 m three-resource street, motion
# graph 5 m / 146 frames, k = 1,000-4,000); the intermediate graph sweeps its state
# box for about 1.8 ns per (state, transition) on the dense matrix, 0.7 ns on the
# lists, whatever k. Below MANY sequences the search wins on every benchmark row.
SEARCH_S_PER_RESULT = 150e-6
GRAPH_S_PER_EDGE = {False: 1.8e-9, True: 0.7e-9}   # by Compiled.sparse
MANY = 1000


def choose_method(cp: Compiled, k: int, max_memory_mb: float) -> Method:
    """The method ``"auto"`` runs.

    * One constrained resource: ``bounded``. Its one table is the exact cost to go,
      one backward dynamic program, less work than growing the intermediate graph
      from both ends and completing it, at every street length.
    * Several: ``bounded`` as well (a few thousand labels where the graph spans
      millions of nodes), unless k is so large that the search would cost more than
      sweeping the whole state box once and the graph fits the budget: then
      ``rcksp``, whose k paths cost little once it is built (k = 10,000 on an 80 m
      three-resource street: 0.7 s against 1.3 s; on the motion graph at 5 m / 146
      frames 0.5 s against 2.1 s).
    """
    if cp.R < 2 or k < MANY:
        return "bounded"
    graph_s = GRAPH_S_PER_EDGE[cp.sparse] * cp.S * max(len(cp.succ_elem), 1)
    if k * SEARCH_S_PER_RESULT <= graph_s:
        return "bounded"
    try:
        estimate(cp, max_memory_mb)
    except TooLargeError:
        return "bounded"
    return "rcksp"


SOLUTION_BYTES = 2048    # what a kept solution takes (its sequence, cost, totals, and
                         # its result object): 1,000,000 solutions of the sample street
                         # took 1.3 GB (3.3 GB printed as JSON); 256 let 5 M reach 15 GB
ELEMENT_BYTES = 16       # an element of a kept solution: in the enumeration's array,
                         # then in the sequence's list
MAX_BUDGET_MB = float(1 << 30)   # a memory budget past 1 PB is a typo


def check_budget(max_memory_mb: float) -> None:
    """The memory budget is a number of megabytes a machine can have (a budget of 1e30
    overflowed the kernels' integers; 0 or less refused everything as over it)."""
    if not (0 < max_memory_mb <= MAX_BUDGET_MB):   # NaN too
        raise ProblemError(f"the memory budget must be a positive number of megabytes up "
                           f"to {MAX_BUDGET_MB:,.0f}, got {max_memory_mb:g}; give it in "
                           "megabytes (--max-memory MB)")


def check_k(k: int, max_memory_mb: float) -> None:
    """``k`` is positive, and k solutions fit the memory budget (checked before any
    array of k is allocated)."""
    if k < 1:
        raise ProblemError(f"k must be a positive integer, got {k}")
    need = k * SOLUTION_BYTES
    if need > max_memory_mb * 2**20:
        big = k >= 1e12   # said in three figures, not in 31 digits
        size = f"{k:.3g}" if big else f"{k:,}"
        amount = (f"{need / 2**30:.3g} GB" if big else f"{need / 2**30:,.1f} GB"
                  if need >= 2**30 else f"{need / 2**20:,.1f} MB" if need >= 2**20
                  else f"{need / 2**10:,.0f} KB")
        budget = f"{max_memory_mb:,.0f}" if max_memory_mb >= 1 else f"{max_memory_mb:g}"
        raise TooLargeError(f"k = {size}: keeping that many solutions takes at least "
                            f"{amount}, over the memory budget of "
                            f"{budget} MB; ask for fewer (k), or raise the "
                            "budget (--max-memory MB)", need_mb=need / 2**20,
                            budget_mb=max_memory_mb, k=k)


def check_length(cp: Compiled, max_memory_mb: float, k: int = 1) -> None:
    """Refuse at once a minimum past what can be counted (1e300 m at 0.2 m), and one that
    only a solution too long for any search within the budget can reach: every element
    of a solution is a node or label of the search, 16 bytes at the very least. Both
    searched (until the budget or for ever) before. So are ``k`` solutions that long:
    each element of each is kept in the enumeration's array and then in a list (two
    words); k = 1,000,000 solutions of 300 one-metre elements died of MemoryError."""
    shortest = 0
    for i, q in enumerate(cp.quant):
        if q.lo > HI_CAP:
            raise TooLargeError(
                f'resource "{q.resource}": its minimum {q.asked[0]:g} is '
                f"{quanta_text(q.asked[0] / q.quantum)} of {q.quantum:g}, more than can be "
                f"counted ({HI_CAP:.3g}); ask for less, or give a coarser quantum",
                budget_mb=max_memory_mb)
        most = int(cp.r[:, i].max(initial=0))
        if cp.lo[i] > 0 and most > 0:
            shortest = max(shortest, -(-int(cp.lo[i]) // most))
    if shortest * 16 > max_memory_mb * 2**20:
        raise TooLargeError(
            f"problem too large: a solution needs at least {shortest:,} elements to reach "
            f"its minimums, more than a search within the memory budget of "
            f"{max_memory_mb:,.0f} MB can hold; ask for less, or raise the budget "
            "(--max-memory MB)", need_mb=shortest * 16 / 2**20, budget_mb=max_memory_mb)
    need = k * max(SOLUTION_BYTES, ELEMENT_BYTES * shortest)
    if need > max_memory_mb * 2**20:   # k long solutions: check_k counts short ones
        raise TooLargeError(
            f"k = {k:,}: keeping that many solutions of at least {shortest:,} elements "
            f"each takes at least {need / 2**30:,.1f} GB, over the memory budget of "
            f"{max_memory_mb:,.0f} MB; ask for fewer (k), or raise the budget "
            "(--max-memory MB)", need_mb=need / 2**20, budget_mb=max_memory_mb, k=k)


def solve(problem: Problem, k: int | None = None, method: Method = "auto", *,
          max_memory_mb: float = DEFAULT_MAX_MEMORY_MB, table: str = "auto",
          explain: bool = True) -> Result:
    """The k cheapest distinct feasible sequences of ``problem`` in ascending cost.

    ``k`` defaults to ``problem.k``. ``method``: "auto" (the default, see
    :func:`choose_method`), "bounded" (cost-bounded search), "rcksp" (the paper's
    intermediate graph) or "fgs" (the baseline); all return the same sequences.
    Raises :class:`ProblemError` for problems that cannot be posed (unbounded
    elements, no common quantum) and :class:`TooLargeError` when the search exceeds
    ``max_memory_mb``. ``table`` forces the row table of rcksp and fgs ("dense" or
    "hash"; tests and benchmarks use it, "auto" picks dense when the state box is
    small). ``explain=False`` skips the diagnosis of an infeasible problem (callers
    that solve many sub-problems).

    A front of 14 to 18 m with one or two shops (a shop has a door), its four
    cheapest fillings:

    >>> from citysynth.solver import Problem, solve
    >>> p = Problem.from_dict({
    ...     "resources": ["length", "doors"],
    ...     "elements": [{"id": "shop", "resources": {"length": 6.0, "doors": 1}},
    ...                  {"id": "flat", "resources": {"length": 4.0}, "cost": 0.5}],
    ...     "transitions": [["shop", "flat", 0.0], ["flat", "flat", 0.25],
    ...                     ["flat", "shop", 1.0]],
    ...     "constraints": {"length": [14, 18], "doors": [1, 2]}})
    >>> r = solve(p, k=4)
    >>> for s in r.solutions:
    ...     print(s.cost, s.sequence, s.resources)
    1.25 ['shop', 'flat', 'flat'] {'length': 14.0, 'doors': 1.0}
    1.5 ['shop', 'flat', 'shop'] {'length': 16.0, 'doors': 2.0}
    2.0 ['shop', 'flat', 'flat', 'flat'] {'length': 18.0, 'doors': 1.0}
    2.0 ['flat', 'shop', 'flat'] {'length': 14.0, 'doors': 1.0}
    """
    if method not in METHODS:
        raise ProblemError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if table not in ("auto", "dense", "hash"):
        raise ProblemError(f'table must be "auto", "dense" or "hash", got {table!r}')
    k = problem.k if k is None else int(k)
    check_budget(max_memory_mb)
    check_k(k, max_memory_mb)
    t0 = time.perf_counter()
    cp = compile_problem(problem)
    check_length(cp, max_memory_mb, k)
    if method == "auto":
        method = choose_method(cp, k, max_memory_mb)
    stats: dict[str, Any] = {
        "method": method, "k": k, "elements": cp.n,
        "quantisation": {q.resource: q.to_dict() for q in cp.quant},
        "levels": cp.top + 1,
    }
    if cp.empty_bounds:
        return _infeasible(cp, stats, t0, max_memory_mb, explain=explain)
    run = {"bounded": _bounded, "rcksp": _rcksp, "fgs": _fgs}[method]
    seqs, t1 = run(problem, cp, k, max_memory_mb, table, stats)
    t2 = time.perf_counter()
    stats["setup_s"] = t1 - t0
    stats["solve_s"] = t2 - t1
    if not seqs:
        return _infeasible(cp, stats, t0, max_memory_mb, explain=explain)
    keys = _transition_keys(cp)
    sols = []
    for s in seqs:
        ids = [cp.ids[i] for i in s]
        cost = _sequence_cost(cp, s, keys)
        sols.append((cost, s, Solution(ids, cost, _sequence_resources(problem, s))))
    sols.sort(key=lambda t: (t[0], t[1]))
    return Result("ok", [t[2] for t in sols], stats)


def _bounded(problem: Problem, cp: Compiled, k: int, max_memory_mb: float, table: str,
             stats: dict) -> tuple[list[list[int]], float]:
    """The cost-bounded search (:mod:`citysynth.solver.bounded`); its setup is the bound tables."""
    budget = int(max_memory_mb * 2**20)
    bounds = bounds_for(cp, budget, k)
    stats["estimate"] = {"bound_tables_bytes": bounds.nbytes, "table": "hash"}
    t1 = time.perf_counter()
    seqs = _truly_feasible(problem, cp, k,
                           lambda kk: bounded_k_best(cp, kk, budget, bounds, stats), stats)
    return seqs, t1


def _row_table(cp: Compiled, max_memory_mb: float, table: str, stats: dict):
    """Estimate the intermediate graph and pick its row table; refuses when too large."""
    est = estimate(cp, max_memory_mb)
    dense = est.dense if table == "auto" else table == "dense"
    if dense and cp.S * row_bytes(cp.n, True) > max_memory_mb * 2**20:
        raise too_large(cp, est.nodes, cp.S * row_bytes(cp.n, True),
                        int(max_memory_mb * 2**20))
    stats["estimate"] = est.to_dict()
    stats["estimate"]["table"] = "dense" if dense else "hash"
    return est, dense


def _rcksp(problem: Problem, cp: Compiled, k: int, max_memory_mb: float, table: str,
           stats: dict) -> tuple[list[list[int]], float]:
    """The intermediate graph grown, met and pruned, then its k best paths."""
    est, dense = _row_table(cp, max_memory_mb, table, stats)
    graph = build_graph(cp, dense=dense, rows_hint=min(cp.S, 1 << 12),
                        max_rows=est.max_rows)
    if graph is None:
        raise too_large(cp, est.nodes, est.bytes, int(max_memory_mb * 2**20))
    t1 = time.perf_counter()
    touched = 0

    def enumerate_k(kk: int) -> list[list[int]]:
        nonlocal touched
        seqs, _, touched = k_best(graph, kk)
        return seqs

    seqs = _truly_feasible(problem, cp, k, enumerate_k, stats)
    stats.update(nodes=graph.kept, nodes_generated=graph.nodes,
                 meet_level=graph.meet_level, kbest_nodes=touched)
    return seqs, t1


# bytes FGS holds a label by at most: its five arrays and heap slot (56 B), the copy a
# growth makes beside them, and the state table's share (a state a label at most)
FGS_LABEL_BYTES = 128


def _fgs(problem: Problem, cp: Compiled, k: int, max_memory_mb: float, table: str,
         stats: dict) -> tuple[list[list[int]], float]:
    """The baseline. It needs no row table, only a node table: dense when the box is
    small, else hashed; the label store is what the budget bounds."""
    dense = dense_rows(cp) if table == "auto" else table == "dense"
    stats["estimate"] = {"table": "dense" if dense else "hash"}
    size_hint = min(cp.S * max(cp.n, 1), 1 << 20)
    t1 = time.perf_counter()
    counters: dict[str, int] = {}

    def enumerate_k(kk: int) -> list[list[int]]:
        status, seqs, _, settled, labels = fgs(
            cp, kk, dense=dense, size_hint=size_hint,
            max_labels=max(int(max_memory_mb * 2**20) // FGS_LABEL_BYTES, 1024))
        if status != 0:
            raise TooLargeError(
                f"FGS stopped after {labels:,} labels: the search exceeds the memory "
                f"budget of {max_memory_mb:,.0f} MB; use method bounded or a smaller k",
                budget_mb=max_memory_mb)
        counters.update(nodes=settled, labels=labels)
        return seqs

    seqs = _truly_feasible(problem, cp, k, enumerate_k, stats)
    stats.update(counters)
    return seqs, t1


def _truly_feasible(problem: Problem, cp: Compiled, k: int, enumerate_k, stats: dict
                    ) -> list[list[int]]:
    """The k best sequences whose totals *in original units* meet the constraints.

    With an exact quantum the quantised model is the problem itself. With a rounding
    quantum, totals of rounded values can stray outside the asked interval (27 floors
    each rounded by up to 5 m² add up); such sequences are dropped and the enumeration
    is continued until k valid ones are found or none are left. The count dropped is
    reported as ``stats["rejected_by_rounding"]``."""
    if all(q.exact for q in cp.quant):
        return enumerate_k(k)
    want, rejected = k, 0
    while True:
        seqs = enumerate_k(want)
        valid = [s for s in seqs if _meets(problem, s)]
        rejected = len(seqs) - len(valid)
        if len(valid) >= k or len(seqs) < want:
            break
        want = 2 * want + (k - len(valid))
    stats["rejected_by_rounding"] = rejected
    return valid[:k]


def _meets(problem: Problem, seq: list[int]) -> bool:
    totals = _sequence_resources(problem, seq)
    return all(lo - 1e-9 * max(1.0, abs(lo)) <= totals[r] <= hi + 1e-9 * max(1.0, abs(hi))
               for r, (lo, hi) in problem.constraints.items())


def _infeasible(cp: Compiled, stats: dict, t0: float, max_memory_mb: float,
                max_rows: int | None = None, *, explain: bool = True) -> Result:
    if max_rows is None:   # a row's G, H, state, links and hash slots; and while its
        # arrays double, the old ones beside the new: half as many again
        max_rows = int(max_memory_mb * 2**20) * 2 // (3 * (16 * cp.n + 64))
    stats.setdefault("nodes", 0)
    stats.setdefault("setup_s", time.perf_counter() - t0)
    stats.setdefault("solve_s", 0.0)
    if not explain:
        return Result("infeasible", [], stats, "infeasible (not diagnosed)", [])
    if stats.get("rejected_by_rounding"):   # the quantised problem had answers
        worst = max((q for q in cp.quant if not q.exact), key=lambda q: q.max_error)
        return Result("infeasible", [], stats, (
            f"the {stats['rejected_by_rounding']} sequence(s) whose totals meet the "
            f"constraints in quanta all break them in the amounts given (each amount of "
            f'"{worst.resource}" is rounded to the quantum {worst.quantum:g}, by up to '
            f"{worst.max_error:.3g}); give a finer quantum, or widen the interval"), [])
    reason, details = diagnose(cp, max_rows)
    return Result("infeasible", [], stats, reason, details)
