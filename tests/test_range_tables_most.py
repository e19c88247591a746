"""The range tables' most (solver.bounds.range_tables, ``rmax``) against brute-force
enumeration, on problems with elements that consume none of the level resource.

When no such element may follow another, a level of the relaxation holds at most one
of them in a row and the backward program over minus the other resource is exact:
the table's most must equal the most that enumerating every completion finds. When one
that consumes some of the other resource may follow such an element, the most is left
unbounded (+inf), and where such an element may follow itself and completes, repeating
it does make the most grow without end. A tower (a roof adds height, no floor area, and
no roof follows a roof) is answered at the root from the most height its floor area
allows."""

from __future__ import annotations

import functools

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from citysynth.solver import Problem, solve
from citysynth.solver.bounds import most_is_exact, range_tables, zero_chains
from citysynth.solver.compiled import compile_problem
from citysynth.solver.diagnose import reach_given

PATHS = 20_000   # completions the enumeration may visit from one node


@st.composite
def zero_level_problems(draw):
    """Two resources: ``lv`` (the level, narrow) and ``ot``; one to three of the
    elements consume no ``lv`` (but some ``ot``), and the transitions between those
    are drawn like the rest, so some problems let them follow each other (or
    themselves) and some not."""
    n = draw(st.integers(2, 5))
    zeros = draw(st.integers(1, min(3, n - 1)))
    elements = []
    for i in range(n):
        lv = 0 if i < zeros else draw(st.integers(1, 3))
        ot = draw(st.integers(1 if lv == 0 else 0, 4))   # compile refuses (0, 0)
        elements.append({"id": f"e{i}", "resources": {"lv": lv, "ot": ot}, "cost": 0.0})
    ids = [e["id"] for e in elements]
    zero_pairs = draw(st.booleans())   # may zero-level elements follow each other at all?
    transitions = []
    for a in range(n):
        for b in range(n):
            if a < zeros and b < zeros and not zero_pairs:
                continue
            if draw(st.integers(0, 2)) > 0:
                transitions.append([ids[a], ids[b], 0.0])
    lo = draw(st.integers(0, 5))
    hi = lo + draw(st.integers(0, 2))
    d = {"resources": ["lv", "ot"], "elements": elements, "transitions": transitions,
         "constraints": {"lv": [lo, hi], "ot": [0, 1000]},
         "front": draw(st.lists(st.sampled_from(ids), min_size=1, unique=True)),
         "back": draw(st.lists(st.sampled_from(ids), min_size=1, unique=True))}
    return Problem.from_dict(d)


def _setup(p: Problem):
    """Successor lists from the problem's transitions, and the consumptions and the
    level interval in the compiled problem's quanta (compiling may scale a resource
    by the common divisor of its amounts), in the compiled element order."""
    cp = compile_problem(p)
    index = {x: i for i, x in enumerate(cp.ids)}
    level, j = cp.bounded.index("lv"), cp.bounded.index("ot")
    succ: list[list[int]] = [[] for _ in range(cp.n)]
    for a, b, _w in p.transitions:
        succ[index[a]].append(index[b])
    rl = [int(x) for x in cp.r[:, level]]
    ro = [int(x) for x in cp.r[:, j]]
    back = {index[x] for x in p.back}
    return cp.n, succ, rl, ro, back, int(cp.lo[level]), int(cp.cap[level])


def _enumerated_most(p: Problem, e: int, c: int, max_len: int) -> float | None:
    """The most of ``ot`` that any completion of (e, c) of the relaxation consuming
    only ``lv``'s interval (e's own consumption excluded, at most ``max_len`` more
    elements) consumes, by visiting every one; -inf when none completes, None when
    there are more than :data:`PATHS` to visit."""
    _n, succ, rl, ro, back, lo, hi = _setup(p)
    best = -np.inf
    visited = 0

    def rec(x: int, cons: int, got: int, depth: int) -> bool:
        nonlocal best, visited
        visited += 1
        if visited > PATHS:
            return False
        if x in back and cons >= lo:
            best = max(best, got)
        if depth >= max_len:
            return True
        for y in succ[x]:
            if cons + rl[y] <= hi and not rec(y, cons + rl[y], got + ro[y], depth + 1):
                return False
        return True

    return best if rec(e, c, 0, 0) else None


def _zero_cycle_can_repeat(p: Problem, e: int) -> bool:
    """Element e consumes no ``lv`` but some ``ot`` and may follow itself."""
    _n, succ, rl, ro, *_ = _setup(p)
    return rl[e] == 0 and ro[e] > 0 and e in succ[e]


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(zero_level_problems())
def test_the_most_is_the_enumerated_most_or_unbounded_where_a_zero_level_cycle_repeats(p):
    cp = compile_problem(p)
    assume(not cp.empty_bounds)
    level, j = cp.bounded.index("lv"), cp.bounded.index("ot")
    ranges = range_tables(cp, level, 1 << 30)
    t = list(ranges["rother"]).index(j)
    cap = int(cp.cap[level])
    size = (cap + 1) * cp.n
    got = ranges["rmax"][t * size:(t + 1) * size].reshape(cap + 1, cp.n)
    least = ranges["rmin"][t * size:(t + 1) * size].reshape(cap + 1, cp.n)
    zero = cp.r[:, level] == 0
    consumes = zero & (cp.r[:, j] > 0)
    exact = most_is_exact(cp, level, j)
    assert exact == (not consumes.any() or not zero_chains(cp, level))
    for e in range(cp.n):
        for c in range(int(cp.r[e, level]), cap + 1):
            if exact:
                # no zero-level element follows another: a completion is at most
                # 2 (cap + 1) elements long, every one is visited
                want = _enumerated_most(p, e, c, 2 * (cap + 1) + 1)
                assume(want is not None)
                assert got[c, e] == want, (e, c)
            else:
                assert got[c, e] == np.inf, (e, c)
                if _zero_cycle_can_repeat(p, e) and least[c, e] < np.inf:
                    # e completes and may repeat on its level: the most of completions
                    # of at most L elements grows with L (any completion, shortest at
                    # most (cap + 1) n long, after L more copies of e)
                    short = (cap + 1) * cp.n + 1
                    assert (_longest(p, e, c, 2 * short)
                            > _longest(p, e, c, short) > -np.inf), (e, c)


def _longest(p: Problem, e: int, c: int, max_len: int) -> float:
    """The most of ``ot`` over completions of (e, c) of at most ``max_len`` more
    elements (every one, by recursion over (element, consumption, length left))."""
    _n, succ, rl, ro, back, lo, hi = _setup(p)

    @functools.cache
    def rec(x: int, cons: int, left: int) -> float:
        best = 0.0 if x in back and cons >= lo else -np.inf
        if left:
            for y in succ[x]:
                if cons + rl[y] <= hi:
                    best = max(best, ro[y] + rec(y, cons + rl[y], left - 1))
        return best

    return rec(e, c, max_len)


def _tower(height: tuple[float, float]) -> Problem:
    """A ground floor, floors and two roofs (height, no floor area; no roof follows a
    roof) on at most 500 m² of floor area: floor area is the narrower resource, the
    level of the range tables."""
    return Problem.from_dict({
        "resources": ["height", "floor_area"], "quantum": {"height": 0.1, "floor_area": 1},
        "elements": [{"id": "ground", "resources": {"height": 5, "floor_area": 150}},
                     {"id": "floor", "resources": {"height": 3, "floor_area": 100}},
                     {"id": "roof", "resources": {"height": 4, "floor_area": 0}},
                     {"id": "spire", "resources": {"height": 7, "floor_area": 0}}],
        "transitions": [["ground", "floor", 0], ["floor", "floor", 1], ["floor", "roof", 0],
                        ["floor", "spire", 0], ["ground", "roof", 0]],
        "front": ["ground"], "back": ["roof", "spire"],
        "constraints": {"height": list(height), "floor_area": [0, 500]}, "k": 1})


def test_a_tower_has_an_exact_most_height_over_its_floor_area():
    """At most three floors fit 500 m² over a 150 m² ground floor: the tallest tower is
    5 + 3 * 3 + 7 = 21 m, which the table says from the ground floor (16 m above it),
    so a 300 m tower is refused at the root where the search used to try every
    stack of floors first."""
    p = _tower((300, 300))
    cp = compile_problem(p)
    level, j = cp.bounded.index("floor_area"), cp.bounded.index("height")
    assert cp.cap[level] < cp.cap[j]
    assert most_is_exact(cp, level, j) and not zero_chains(cp, level)
    ranges = range_tables(cp, level, 1 << 30)
    t = list(ranges["rother"]).index(j)
    size = (int(cp.cap[level]) + 1) * cp.n
    ground = cp.ids.index("ground")
    assert ranges["rmax"][t * size + 150 * cp.n + ground] == 160   # 0.1 m quanta
    assert ranges["rmin"][t * size + 150 * cp.n + ground] == 40
    r = solve(p, method="bounded")
    assert r.status == "infeasible"
    assert r.stats["labels"] <= 1
    assert reach_given(cp, "floor_area", "height") == (9, 21)
    ok = solve(_tower((21, 21)), method="bounded")
    assert ok.status == "ok"
    assert ok.solutions[0].sequence == ["ground", "floor", "floor", "floor", "spire"]
