"""Pair bound tables (solver.pair_bounds: a level resource every element consumes,
known exactly, and another known to levels of s quanta), which the cost-bounded search
takes where the one-resource tables leave it too many labels (a 300 m tower, whose
height and floor area move together): the table against a plain Bellman-Ford of its
own relaxation, a lower bound on the exact two-resource cost to go, consistent on every
transition; the search on it against exhaustive enumeration for k = 1..8, by itself
and as :func:`~citysynth.solver.bounded.bounded_k_best` takes it after a first search
runs out; and the tower it was made for.

Costs are multiples of 1/8 (tests/test_solver_bruteforce.py), so sums are exact and
the comparisons are equalities."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from citysynth.solver import Problem
from citysynth.solver import astar as astar_mod
from citysynth.solver import bounded as bounded_mod
from citysynth.solver import pair_bounds as pair_mod
from citysynth.solver.astar import astar_k_best
from citysynth.solver.bounded import bounds_for
from citysynth.solver.compiled import compile_problem
from citysynth.solver.pair_bounds import pair_table
from tests.test_bounded_solver import _check_result, _check_sequences, ends_and_edges
from tests.test_solver_bruteforce import problems


def _pair_of(cp) -> tuple[int, int] | None:
    """A level resource (every element consumes some) and another constrained one."""
    levels = [i for i in range(cp.R) if int(cp.r[:, i].min()) >= 1]
    if cp.R < 2 or not levels:
        return None
    lv = levels[0]
    return lv, next(i for i in range(cp.R) if i != lv)


def _pair_by_bellman_ford(p: Problem, cp, lv: int, j: int, s: int) -> np.ndarray:
    """The pair relaxation's cost to go straight from its definition, by Bellman-Ford
    from infinity: from element e at (c, q), end (where a sequence may end) with c in
    [lo_l, cap_l] and q in [lo_j // s, cap_j // s], or take a transition to f, adding
    r_f of the level resource and r_f // s or ceil(r_f / s) levels of the other."""
    rl, rj = cp.r[:, lv], cp.r[:, j]
    lo, cap = int(cp.lo[lv]), int(cp.cap[lv])
    qlo, qcap = max(int(cp.lo[j]), 0) // s, int(cp.cap[j]) // s
    back, edges = ends_and_edges(p)
    g = np.full((cap + 1, qcap + 1, cp.n), np.inf)
    changed = True
    while changed:
        changed = False
        for c in range(cap + 1):
            for q in range(qcap + 1):
                for e in range(cp.n):
                    best = 0.0 if e in back and lo <= c and qlo <= q else np.inf
                    for a, b, w in edges:
                        if a != e or c + rl[b] > cap:
                            continue
                        for step in {int(rj[b]) // s, -(-int(rj[b]) // s)}:
                            if q + step <= qcap:
                                best = min(best, w + g[c + rl[b], q + step, b])
                    if best < g[c, q, e]:
                        g[c, q, e] = best
                        changed = True
    return g


def _exact_by_bellman_ford(p: Problem, cp, lv: int, j: int) -> np.ndarray:
    """The exact cost to go when only resources lv and j count, h[c_l, c_j, e]."""
    rl, rj = cp.r[:, lv], cp.r[:, j]
    caps = (int(cp.cap[lv]), int(cp.cap[j]))
    los = (int(cp.lo[lv]), int(cp.lo[j]))
    back, edges = ends_and_edges(p)
    h = np.full((caps[0] + 1, caps[1] + 1, cp.n), np.inf)
    changed = True
    while changed:
        changed = False
        for c in range(caps[0] + 1):
            for d in range(caps[1] + 1):
                for e in range(cp.n):
                    best = 0.0 if e in back and los[0] <= c and los[1] <= d else np.inf
                    for a, b, w in edges:
                        if a == e and c + rl[b] <= caps[0] and d + rj[b] <= caps[1]:
                            best = min(best, w + h[c + rl[b], d + rj[b], b])
                    if best < h[c, d, e]:
                        h[c, d, e] = best
                        changed = True
    return h


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.filter_too_much])
@given(problems(), st.integers(1, 4))
def test_pair_tables_are_their_relaxation_a_lower_bound_and_consistent(p, s):
    cp = compile_problem(p)
    pair = None if cp.empty_bounds else _pair_of(cp)
    assume(pair is not None)
    lv, j = pair
    g = pair_table(cp, lv, j, s)
    assert np.array_equal(g, _pair_by_bellman_ford(p, cp, lv, j, s))
    exact = _exact_by_bellman_ford(p, cp, lv, j)
    d = np.arange(exact.shape[1])
    assert (g[:, d // s, :] <= exact).all()              # a lower bound at every node
    rl, rj = cp.r[:, lv], cp.r[:, j]
    _back, edges = ends_and_edges(p)
    for a, b, w in edges:                                # consistent on every transition
        for c in range(int(cp.cap[lv]) + 1 - int(rl[b])):
            for x in range(int(cp.cap[j]) + 1 - int(rj[b])):
                assert g[c, x // s, a] <= w + g[c + rl[b], (x + rj[b]) // s, b]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.filter_too_much])
@given(problems(), st.integers(1, 8), st.integers(1, 4))
def test_search_on_pair_tables_matches_enumeration(p, k, s):
    cp = compile_problem(p)
    pair = None if cp.empty_bounds else _pair_of(cp)
    assume(pair is not None)
    lv, j = pair
    g = pair_table(cp, lv, j, s)
    one = np.ones(1, dtype=np.int64)
    bounds = replace(bounds_for(cp, 1 << 30, k), pl=one * lv, pj=one * j, ps=one * s,
                     pq=one * (g.shape[1] - 1), pbase=np.zeros(1, dtype=np.int64),
                     ptab=g.ravel())
    status, seqs, _ = astar_k_best(cp, bounds, k, 1 << 30)
    assert status == 0
    _check_sequences(p, seqs, k, f"pair table, step {s}")


@pytest.fixture
def pair_at_once(monkeypatch):
    """The cost-bounded method giving up its first search after one label (the search
    looks at its label count between kernel calls: one pop a call here) and taking the
    pair table at any size (the small hypothesis problems then take it)."""
    monkeypatch.setattr(astar_mod, "POPS_PER_CALL", 1)
    monkeypatch.setattr(bounded_mod, "PAIR_FIRST_LABELS", 1)
    monkeypatch.setattr(bounded_mod, "PAIR_FIRST", 1 << 40)
    monkeypatch.setattr(pair_mod, "MIN_PAIR_LEVELS", 1)


@settings(max_examples=150, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(problems(), st.integers(1, 8))
def test_bounded_taking_the_pair_table_matches_enumeration(pair_at_once, p, k):
    _check_result(p, k, method="bounded")
    _check_result(p, k)   # "auto"


def test_a_300_m_tower_is_built(tmp_path):
    """``tower --height 300 --far 6 --lot-area 2500`` filled the 2 GB label budget in
    about 30 s and was refused ("its floors stack in too many ways"): the one-resource
    bounds let through every stack cheap enough for the height whatever its floor
    area. With the pair table it is built (about 28,000 labels after the first search's
    1.4 M), and the tower meets both intervals."""
    import json

    from citysynth.pipeline.cli import main

    out = tmp_path / "t"
    lib = Path(__file__).resolve().parent.parent / "examples" / "library"
    assert main(["tower", "--height", "300", "--far", "6", "--lot-area", "2500",
                 "--library", str(lib), "-o", str(out)]) == 0
    (lay,) = [json.loads(f.read_text()) for f in out.glob("*.layout.json")]
    assert lay["structures"][0]["resources"]["height"] == pytest.approx(300.0, abs=1e-6)
    area = lay["structures"][0]["resources"]["floor_area"]
    assert 5.88 * 2500 <= area <= 6.12 * 2500


def test_the_method_takes_the_pair_table_where_its_first_search_runs_out(pair_at_once):
    """On the three-resource street front (length, doors, balconies; length the level
    resource), the first search stops at once and the pair table is taken: the stats
    say so, and the answer is the one without it."""
    from citysynth.solver import solve
    from citysynth.solver.samples import street_front

    p = Problem.from_dict(street_front(40.0, resources=3, k=5))
    r = solve(p, k=5, method="bounded")
    assert r.status == "ok" and "pair_after" in r.stats, r.stats
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bounded_mod, "PAIR_FIRST_LABELS", 1 << 20)
        mp.setattr(bounded_mod, "PAIR_FIRST", 16)
        plain = solve(p, k=5, method="bounded")
    assert "pair_after" not in plain.stats
    assert [(s.cost, s.sequence) for s in r.solutions] == \
        [(s.cost, s.sequence) for s in plain.solutions]
