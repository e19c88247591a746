"""Coarse bound tables (solver.bounds.coarse_cost_to_go: the amount consumed known to
levels of s quanta), which guide the search for the best sequence (k = 1) at a
fraction of the exact tables' cost: the table against a plain Bellman-Ford of its own
relaxation, a lower bound on the exact relaxed cost to
go, consistent on every transition; the search on coarse tables (at forced factors, so
the small hypothesis problems take them) against exhaustive enumeration for k = 1..8;
``auto`` taking them on the street and, when they guide badly, giving up for the
exact tables with the same answer.

Costs are multiples of 1/8 (tests/test_solver_bruteforce.py), so sums are exact and
the comparisons are equalities."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.solver import Problem, solve
from citysynth.solver import bounded as bounded_mod
from citysynth.solver import bounds as bounds_mod
from citysynth.solver.astar import astar_k_best
from citysynth.solver.bounds import (
    coarse_cost_to_go,
    coarse_factor,
    relaxation_bounds,
    relaxed_cost_to_go,
)
from citysynth.solver.compiled import compile_problem
from citysynth.solver.samples import street_front
from tests.test_bounded_solver import _check_result, _check_sequences, ends_and_edges
from tests.test_solver_bruteforce import problems


def _coarse_by_bellman_ford(p: Problem, cp, i: int, s: int) -> np.ndarray:
    """The coarse relaxation's cost to go by Bellman-Ford from infinity, straight from
    its definition: from element e on level q, end (where a sequence may end) on a
    level within [lo // s, cap // s], or take a transition to f, moving up by
    r_f // s or by ceil(r_f / s) levels (within cap // s); read at node (e, c) on
    level c // s."""
    r = cp.r[:, i]
    lo, cap = int(cp.lo[i]), int(cp.cap[i])
    qlo, qcap = max(lo, 0) // s, cap // s
    back, edges = ends_and_edges(p)
    g = np.full((qcap + 1, cp.n), np.inf)
    changed = True
    while changed:
        changed = False
        for q in range(qcap + 1):
            for e in range(cp.n):
                best = 0.0 if e in back and qlo <= q else np.inf
                for a, b, w in edges:
                    for step in {int(r[b]) // s, -(-int(r[b]) // s)}:
                        if a == e and q + step <= qcap:
                            best = min(best, w + g[q + step, b])
                if best < g[q, e]:
                    g[q, e] = best
                    changed = True
    return g[np.arange(cap + 1) // s]


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(), st.integers(2, 4))
def test_coarse_tables_bound_the_exact_ones_consistently(p, s):
    """Each coarse table is its relaxation's cost to go (Bellman-Ford), at most the
    exact relaxed cost to go on every node, and consistent: h(e, c) <= w(e, f) +
    h(f, c + r_f) on every transition that stays within the box."""
    cp = compile_problem(p)
    if cp.empty_bounds:
        return
    for i in range(cp.R):
        h = coarse_cost_to_go(cp, i, s)
        assert np.array_equal(h, _coarse_by_bellman_ford(p, cp, i, s))
        exact = relaxed_cost_to_go(cp.r[:, i].copy(), int(cp.lo[i]), int(cp.cap[i]),
                                   cp.back, cp.pred_ptr, cp.pred_elem, cp.pred_w)
        assert np.all(h <= exact)
        cap, r = int(cp.cap[i]), cp.r[:, i]
        for e in range(cp.n):
            for j in range(cp.succ_ptr[e], cp.succ_ptr[e + 1]):
                f, w = cp.succ_elem[j], cp.succ_w[j]
                for c in range(cap + 1 - r[f]):
                    assert h[c, e] <= w + h[c + r[f], f]


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(), st.integers(1, 8), st.integers(2, 4))
def test_search_on_coarse_tables_matches_enumeration(p, k, s):
    """The search guided by coarse tables (every resource at factor s) returns the
    enumeration's first k in (cost, lexicographic) order, as on the exact tables."""
    cp = compile_problem(p)
    if cp.empty_bounds:
        return
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bounds_mod, "coarse_factor", lambda cp, i: s)
        bounds = relaxation_bounds(cp, 1 << 30, coarse=True)
    assert bounds.coarse and not bounds.exact
    status, seqs, _ = astar_k_best(cp, bounds, k, 1 << 30)
    assert status == 0
    _check_sequences(p, seqs, k, f"coarse factor {s}")


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(real_lengths=True), st.integers(2, 6))
def test_solve_on_coarse_tables_and_after_giving_up_matches_enumeration(p, s):
    """``solve(k=1)`` through the coarse tables, and through them with a label budget
    of one (so it gives up and starts again on the exact tables): the enumeration's
    best, cost and sequence."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bounds_mod, "coarse_factor", lambda cp, i: s)
        _check_result(p, 1)
        mp.setattr(bounded_mod, "coarse_labels", lambda cp, bounds: 1)
        _check_result(p, 1)


def test_auto_takes_coarse_tables_for_the_best_street_front_only():
    """On the 100 m street front: k = 1 searches on a coarse table (8 quanta a level,
    its 74 buildings are 4-20 m on the 0.2 m grid) and finds FGS's best; k = 2 keeps
    the exact table. A label budget of one makes it give up and answer the same."""
    p = Problem.from_dict(street_front(100))
    cp = compile_problem(p)
    assert coarse_factor(cp, 0) == 8
    best = solve(p, k=1)
    assert best.stats["path"] == "astar" and best.stats["coarse"]
    fgs = solve(p, k=1, method="fgs", max_memory_mb=4096)
    assert [(s.cost, s.sequence) for s in best.solutions] == \
        [(s.cost, s.sequence) for s in fgs.solutions]
    assert solve(p, k=2).stats["path"] == "exact"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bounded_mod, "coarse_labels", lambda cp, bounds: 1)
        again = solve(p, k=1)
    assert again.stats["coarse_gave_up"] >= 1 and again.stats["path"] == "exact"
    assert [(s.cost, s.sequence) for s in again.solutions] == \
        [(s.cost, s.sequence) for s in best.solutions]


def test_no_coarse_table_without_a_lower_bound_or_for_small_amounts():
    """Factor 1 (the exact table) for an upper bound alone, for amounts of a few quanta
    (a coarse table would save nothing) and for sequences long against the table (the
    search would settle every element); else half the least amount, at most
    lo / COARSE_LEVELS."""
    def compiled(lengths, lo, hi):
        ids = [f"e{x}" for x in lengths]
        return compile_problem(Problem.from_dict({
            "resources": ["len"], "constraints": {"len": [lo, hi]},
            "elements": [{"id": f"e{x}", "resources": {"len": x}, "cost": 1.0}
                         for x in lengths],
            "transitions": [[a, b, 0.0] for a in ids for b in ids]}))
    many = list(range(20, 60))
    assert coarse_factor(compiled(many, 0, 2000), 0) == 1
    assert coarse_factor(compiled([3, 4], 3000, 3000), 0) == 1
    assert coarse_factor(compiled(many, 2000, 2000), 0) == 10
    assert coarse_factor(compiled(many, 200, 210), 0) == 4
    # sequences long against the table: two elements filling 20,000 are 1,000 deep
    assert coarse_factor(compiled([20, 21], 20000, 20000), 0) == 1
