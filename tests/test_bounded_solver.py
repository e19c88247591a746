"""The cost-bounded method against exhaustive enumeration, on the same hypothesis
problems as tests/test_solver_bruteforce.py: every result feasible and distinct, costs
exactly right, the k costs equal to the k smallest, and the sequences equal to the
enumeration's first k in (cost, lexicographic) order, on every path the method can
take (the exact single-resource table, the best-first search with bounds, the same
search with no bound table at all); the bound tables against Bellman-Ford.

Costs are multiples of 1/8 so every float sum is exact whatever its order; the
comparison is then exact equality, not approximate."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.solver import Problem, TooLargeError, solve
from citysynth.solver.astar import astar_k_best
from citysynth.solver.bounded import bounds_for
from citysynth.solver.bounds import Bounds, most_is_exact, range_tables, relaxed_cost_to_go
from citysynth.solver.compiled import compile_problem
from citysynth.solver.diagnose import reach_given
from citysynth.solver.entry import choose_method
from citysynth.solver.samples import street_front
from tests.bruteforce import EPS, enumerate_feasible
from tests.test_solver_bruteforce import problems

NO_BOUNDS = Bounds(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0),
                   False)


def _expected(p: Problem, k: int) -> list[tuple[float, tuple[str, ...]]]:
    """The enumeration's first k in (cost, lexicographic element index) order."""
    index = p.element_index()
    found = enumerate_feasible(p)
    return sorted(found, key=lambda t: (t[0], [index[x] for x in t[1]]))[:k]


def _check_sequences(p: Problem, seqs: list[list[int]], k: int, what: str) -> None:
    """Raw element-index sequences (as the kernels return them, in order) against the
    enumeration: exactly its first k in (cost, lexicographic) order."""
    ids = [e.id for e in p.elements]
    want = [s for _, s in _expected(p, k)]
    assert [tuple(ids[i] for i in s) for s in seqs] == want, what


def _check_result(p: Problem, k: int, **kw) -> None:
    r = solve(p, k=k, **kw)
    want = _expected(p, k)
    assert r.status == ("ok" if want else "infeasible"), kw
    assert [s.cost for s in r.solutions] == [c for c, _ in want], kw
    assert [tuple(s.sequence) for s in r.solutions] == [s for _, s in want], kw
    omega = {e.id: e.cost for e in p.elements}
    delta = {(a, b): c for a, b, c in p.transitions}
    res = {e.id: e.resources for e in p.elements}
    for s in r.solutions:
        assert s.sequence[0] in p.front and s.sequence[-1] in p.back
        cost = omega[s.sequence[0]]
        for a, b in zip(s.sequence, s.sequence[1:], strict=False):
            cost += delta[(a, b)] + omega[b]
        assert cost == s.cost
        for name, (lo, hi) in p.constraints.items():
            total = sum(res[x][name] for x in s.sequence)
            assert lo - EPS <= total <= hi + EPS
            assert abs(s.resources[name] - total) < 1e-9
    if not want:
        assert r.reason


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(), st.integers(1, 8))
def test_bounded_and_auto_match_enumeration(p, k):
    _check_result(p, k, method="bounded")
    _check_result(p, k)  # "auto"


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(real_lengths=True), st.integers(1, 6))
def test_bounded_real_valued_lengths_match_enumeration(p, k):
    _check_result(p, k, method="bounded")


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(), st.integers(1, 8))
def test_best_first_search_with_and_without_bounds(p, k):
    """The search alone, whatever the number of resources: with every relaxation's
    table (for one resource the exact cost to go, the search then walks straight
    down), and with no table at all (a cost-ordered search with lexicographic ties)."""
    cp = compile_problem(p)
    if cp.empty_bounds:
        return
    for bounds in (bounds_for(cp, 1 << 30), NO_BOUNDS):
        status, seqs, _ = astar_k_best(cp, bounds, k, 1 << 30)
        assert status == 0
        _check_sequences(p, seqs, k, f"{bounds.count} tables")


def ends_and_edges(p: Problem, weight=None) -> tuple[set[int], list[tuple[int, int, float]]]:
    """The element indices a sequence may end with, and every transition as (from, to,
    weight) by element index: its cost (delta plus the entered element's own), or with
    ``weight`` (element index -> number) that of the element it enters."""
    index = p.element_index()
    omega = {index[e.id]: e.cost for e in p.elements}
    return {index[x] for x in p.back}, [
        (index[a], index[b], d + omega[index[b]] if weight is None else weight(index[b]))
        for a, b, d in p.transitions]


def _relaxed_by_bellman_ford(p: Problem, cp, i: int, weight=None) -> np.ndarray:
    """The cost to go of the one-resource relaxation by plain Bellman-Ford from
    infinity (the least fixed point: exact, zero-consumption cycles included); with
    ``weight`` (element index -> number) a transition weighs that of its element
    instead of its cost."""
    ri = cp.r[:, i]
    lo, cap = int(cp.lo[i]), int(cp.cap[i])
    back, edges = ends_and_edges(p, weight)
    h = np.full((cap + 1, cp.n), np.inf)
    changed = True
    while changed:
        changed = False
        for c in range(cap + 1):
            for e in range(cp.n):
                best = 0.0 if e in back and c >= max(lo, ri[e]) else np.inf
                for a, b, w in edges:
                    if a == e and c + ri[b] <= cap:
                        best = min(best, w + h[c + ri[b], b])
                if best < h[c, e]:
                    h[c, e] = best
                    changed = True
    return h


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems())
def test_relaxation_tables_are_the_relaxed_cost_to_go(p):
    """Each table is the exact cost to go of its one-resource relaxation, on every node
    an element can occupy (consumption at least its own)."""
    cp = compile_problem(p)
    if cp.empty_bounds:
        return
    for i in range(cp.R):
        h = relaxed_cost_to_go(cp.r[:, i].copy(), int(cp.lo[i]), int(cp.cap[i]), cp.back,
                               cp.pred_ptr, cp.pred_elem, cp.pred_w)
        want = _relaxed_by_bellman_ford(p, cp, i)
        for e in range(cp.n):
            own = int(cp.r[e, i])
            assert np.array_equal(h[own:, e], want[own:, e]), (cp.bounded[i], e)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems())
def test_range_tables_are_the_least_and_most_another_resource_completes_with(p):
    """Each range table holds, for every node of the level resource's relaxation, the
    least and the most of the other resource that its completions consume (Bellman-Ford
    on the element's consumption, and on its negation where no element repeats on one
    level while consuming some; unbounded there)."""
    cp = compile_problem(p)
    if cp.empty_bounds or cp.R < 2:
        return
    level = 0
    ranges = range_tables(cp, level, 1 << 30)
    size = (int(cp.cap[level]) + 1) * cp.n
    for t, j in enumerate(ranges["rother"]):
        rj = cp.r[:, j]
        least = _relaxed_by_bellman_ford(p, cp, level, lambda b, rj=rj: float(rj[b]))
        repeats = not most_is_exact(cp, level, int(j))
        most = None if repeats else -_relaxed_by_bellman_ford(p, cp, level,
                                                              lambda b, rj=rj: -float(rj[b]))
        got_min = ranges["rmin"][t * size:(t + 1) * size].reshape(-1, cp.n)
        got_max = ranges["rmax"][t * size:(t + 1) * size].reshape(-1, cp.n)
        for e in range(cp.n):
            own = int(cp.r[e, level])
            assert np.array_equal(got_min[own:, e], least[own:, e]), (j, e)
            if most is None:
                assert np.all(got_max[own:, e] == np.inf)
            else:
                assert np.array_equal(got_max[own:, e], most[own:, e]), (j, e)


def test_two_tied_resources_out_of_reach_together_are_answered_at_the_root():
    """Every floor brings 3 m of height and 100 m² of floor area: 300 m exactly with at
    most 5,000 m² is impossible, though each alone is easy. The search used to fill its
    whole budget on prefixes meeting each alone; the range tables refuse every first
    element, and they say how much floor area 300 m takes."""
    p = Problem.from_dict({
        "resources": ["height", "floor_area"], "quantum": {"height": 1, "floor_area": 1},
        "elements": [{"id": "ground", "resources": {"height": 5, "floor_area": 150}},
                     {"id": "floor", "resources": {"height": 3, "floor_area": 100}},
                     {"id": "roof", "resources": {"height": 4, "floor_area": 0}}],
        "transitions": [["ground", "floor", 0], ["floor", "floor", 1], ["floor", "roof", 0]],
        "front": ["ground"], "back": ["roof"],
        "constraints": {"height": [300, 300], "floor_area": [0, 5000]}, "k": 1})
    r = solve(p, method="bounded")
    assert r.status == "infeasible"
    assert r.stats["labels"] <= 1
    assert reach_given(compile_problem(p), "height", "floor_area") == (150 + 100 * 97,) * 2


def test_all_zero_costs_give_the_lexicographically_first_sequences_at_once():
    """Every sequence ties: the search walks depth first in lexicographic order."""
    p = Problem.from_dict({
        "resources": ["length", "doors"],
        "elements": [{"id": x, "resources": {"length": v, "doors": d}} for x, v, d in
                     (("a", 1, 0), ("b", 2, 1), ("c", 3, 0))],
        "transitions": [[x, y, 0.0] for x in "abc" for y in "abc"],
        "constraints": {"length": [6, 6], "doors": [0, 2]},
    })
    r = solve(p, k=100)
    seqs = ["".join(s.sequence) for s in r.solutions]
    index = p.element_index()
    want = sorted(enumerate_feasible(p), key=lambda t: [index[x] for x in t[1]])
    assert seqs == ["".join(s) for _, s in want]
    big = Problem.from_dict({
        "resources": ["length", "floor_area"],
        "quantum": {"length": 0.001, "floor_area": 0.01},
        "elements": [{"id": f"p{i}", "resources": {"length": 4.0 + i,
                                                   "floor_area": 100.0 + i}}
                     for i in range(20)],
        "transitions": [[f"p{i}", f"p{j}", 0.0] for i in range(20) for j in range(20)],
        "constraints": {"length": [2000, 2000], "floor_area": [0, 50000]},
    })
    r = solve(big, k=3, max_memory_mb=512)  # 7 million levels: far too many for rcksp
    assert [s.sequence for s in r.solutions] == [
        ["p0"] * 500, ["p0"] * 498 + ["p4"], ["p0"] * 497 + ["p1", "p3"]]


def test_three_resource_street_agrees_with_fgs_and_rcksp():
    p = Problem.from_dict(street_front(60.0, resources=3))
    a = solve(p, k=40)
    assert a.stats["method"] == "bounded" and a.stats["path"] == "astar"
    for other in (solve(p, k=40, method="rcksp"), solve(p, k=40, method="fgs")):
        assert [s.cost for s in a.solutions] == [s.cost for s in other.solutions]
    assert [s.to_dict() for s in a.solutions] == \
        [s.to_dict() for s in solve(p, k=40, method="rcksp").solutions]


def test_search_beyond_the_budget_is_refused_with_advice():
    """Infeasible only jointly (an odd length needs a 3 m part, which has a door): each
    relaxation completes, so the search must look at every state it can reach before
    it knows; with a small budget it stops and says so."""
    p = Problem.from_dict({
        "resources": ["length", "doors"],
        "elements": [{"id": "a", "resources": {"length": 2}},
                     {"id": "b", "resources": {"length": 4}},
                     {"id": "d", "resources": {"length": 3, "doors": 1}}],
        "transitions": [[x, y, 0.125] for x in "abd" for y in "abd"],
        "constraints": {"length": [3001, 3001], "doors": [0, 0]},
    })
    with pytest.raises(TooLargeError) as exc:
        solve(p, max_memory_mb=0.25)
    msg = str(exc.value)
    assert "the search stopped at the memory budget of 0 MB after" in msg
    assert "several times coarser" in msg and "--max-memory" in msg
    assert "labels" not in msg and "k-th" not in msg   # the user's words, not the code's
    r = solve(p)  # within the default budget it finds out
    assert r.status == "infeasible"


def test_auto_takes_the_graph_only_for_thousands_of_sequences_on_a_small_box():
    small = compile_problem(Problem.from_dict(street_front(40.0, resources=3)))
    wide = compile_problem(Problem.from_dict(street_front(200.0, resources=3)))
    one = compile_problem(Problem.from_dict(street_front(200.0)))
    assert choose_method(small, 100, 2048) == "bounded"
    assert choose_method(small, 1000, 2048) == "rcksp"
    assert choose_method(small, 1000, 1) == "bounded"      # the graph would not fit
    assert choose_method(wide, 10_000, 2048) == "bounded"  # its box is 612,000 states
    assert choose_method(one, 10**6, 2048) == "bounded"    # one resource: the exact table
    p = Problem.from_dict(street_front(40.0, resources=3))
    a = solve(p, k=1000)
    b = solve(p, k=1000, method="bounded")
    assert a.stats["method"] == "rcksp" and b.stats["method"] == "bounded"
    assert [s.cost for s in a.solutions] == [s.cost for s in b.solutions]
    # Costs here are sums of 4-decimal floats: sequences whose costs agree only up to
    # rounding may be ordered by different sums (the graph sums backwards), so the
    # sequences are compared below the last cost, where no such tie can cut the list.
    last = a.solutions[-1].cost
    assert [s.to_dict() for s in a.solutions if s.cost < last] == \
        [s.to_dict() for s in b.solutions if s.cost < last]


def test_a_long_search_lets_ctrl_c_in_between_kernel_calls(monkeypatch):
    """The search's driver runs in Python between kernel calls of a bounded number of
    pops, so SIGINT (here an alarm raising KeyboardInterrupt) stops a long search while
    it runs. The compiled driver it replaces held the signal until the whole search
    was done (a minute and more at the memory budget)."""
    from citysynth.solver import astar

    solve(Problem.from_dict(street_front(20, resources=3)), k=2, method="bounded")  # compiled
    _interrupted_while_searching(monkeypatch, astar, "_astar_steps", 3, "bounded")


def _interrupted_while_searching(monkeypatch, module, kernel_name: str, counters_from_end: int,
                                 method: str) -> None:
    """A long search (k = 300,000 on a 400 m street with three resources), its kernel
    ``module.kernel_name`` wrapped to count complete sequences after each call and to
    set an alarm raising KeyboardInterrupt 0.2 s after its first call (so a slow setup
    on a loaded machine cannot take the signal before the search runs): the signal
    stops the search between calls, well before its end."""
    import signal

    p = street_front(400, resources=3)
    p["constraints"].update(doors=[0, 1000], balconies=[0, 1000])
    problem = Problem.from_dict(p)
    k = 300_000
    seen: list[int] = []
    kernel = getattr(module, kernel_name)

    def counted(*args):
        if not seen:
            signal.setitimer(signal.ITIMER_REAL, 0.2)
        kernel(*args)
        seen.append(int(args[-counters_from_end][2]))   # complete sequences so far
    monkeypatch.setattr(module, kernel_name, counted)
    monkeypatch.setattr(module, "POPS_PER_CALL", 1 << 12)

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, interrupt)
    try:
        with pytest.raises(KeyboardInterrupt):
            solve(problem, k=k, method=method)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    assert len(seen) > 1 and seen[-1] < k, "the search ran to its end before the signal"


def test_fgs_by_name_lets_ctrl_c_in_between_kernel_calls(monkeypatch):
    """FGS, asked for by name, runs in Python between kernel calls of a bounded number
    of pops too: SIGINT stops it while it runs (its compiled driver held the signal:
    bound_huge_eq2 ran past two minutes). Chunked, it gives the same answers."""
    from citysynth.solver import fgs

    small = Problem.from_dict(street_front(30, resources=3))
    whole = solve(small, k=50, method="fgs")
    calls: list[int] = []
    kernel = fgs._fgs_steps
    with monkeypatch.context() as m:
        m.setattr(fgs, "POPS_PER_CALL", 7)
        m.setattr(fgs, "_fgs_steps", lambda *a: (calls.append(1), kernel(*a)))
        chunked = solve(small, k=50, method="fgs")
    assert [s.to_dict() for s in chunked.solutions] == [s.to_dict() for s in whole.solutions]
    assert len(calls) > 100    # 7 pops a call (arrays growing would explain a few)
    _interrupted_while_searching(monkeypatch, fgs, "_fgs_steps", 2, "fgs")
