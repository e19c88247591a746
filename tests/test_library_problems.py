"""Solver problems built from the sample part library, and rounding quanta: every
solution meets the asked intervals in original units, not only after rounding."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.pipeline.library_problems import street_front_problem, tower_problem
from citysynth.solver import Problem, solve
from tests.bruteforce import enumerate_feasible


def test_tower_of_exact_height_with_floor_area_interval(sample_db):
    p = Problem.from_dict(tower_problem(sample_db, 60.0, (3000, 3500), k=5))
    r = solve(p)
    assert r.status == "ok" and len(r.solutions) == 5
    assert not r.stats["quantisation"]["floor_area"]["exact"]
    cls = {q.id: q.cls for q in sample_db.parts}
    costs = [s.cost for s in r.solutions]
    assert costs == sorted(costs)
    for s in r.solutions:
        assert s.resources["height"] == 60.0
        assert 3000 <= s.resources["floor_area"] <= 3500
        assert cls[s.sequence[0]] == "ground_floor" and cls[s.sequence[-1]] == "roof"
        assert all(cls[x] == "floor" for x in s.sequence[1:-1])


def test_street_front_from_complete_buildings(sample_db):
    p = Problem.from_dict(street_front_problem(sample_db, 83.4, constraints={"doors": [3, 5]}, k=4))
    r = solve(p)
    fgs = solve(p, method="fgs")
    assert r.status == "ok" and [s.cost for s in r.solutions] == [s.cost for s in fgs.solutions]
    for s in r.solutions:
        assert s.resources["length"] == 83.4 and 3 <= s.resources["doors"] <= 5


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.integers(1, 3), st.integers(0, 19),
                          st.sampled_from([0.0, 0.5, 1.0, 2.0])), min_size=1, max_size=4),
       st.integers(2, 8), st.integers(0, 30), st.integers(0, 20), st.integers(1, 6))
def test_rounding_quantum_never_breaks_the_asked_interval(elems, length, lo, width, k):
    p = Problem.from_dict({
        "resources": ["length", "area"],
        "quantum": {"area": 1.0},
        "elements": [{"id": f"e{i}", "resources": {"length": L, "area": a / 10 * 7},
                      "cost": c} for i, (L, a, c) in enumerate(elems)],
        "transitions": [[f"e{i}", f"e{j}", 0.25 * ((i + j) % 3)]
                        for i in range(len(elems)) for j in range(len(elems))],
        "constraints": {"length": [length, length],
                        "area": [lo / 2, (lo + width) / 2]},
    })
    r = solve(p, k=k)
    q = 1.0
    qlo = math.ceil(lo / 2 / q - 1e-9)
    qhi = math.floor((lo + width) / 2 / q + 1e-9)
    area = {e.id: e.resources["area"] for e in p.elements}

    def rounded_ok(seq):  # the quantised model: rounded values, inward-rounded bounds
        return qlo <= sum(round(area[x] / q) for x in seq) <= qhi

    expected = [c for c, seq in enumerate_feasible(p) if rounded_ok(seq)][:k]
    assert [s.cost for s in r.solutions] == expected
    for s in r.solutions:
        lo_a, hi_a = p.constraints["area"]
        assert lo_a - 1e-9 <= s.resources["area"] <= hi_a + 1e-9
