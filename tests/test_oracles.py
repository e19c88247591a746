"""The bounds of the brute-force oracles: the counts made before enumerating equal the
sequences the enumerations then visit, a draw over the limit is rejected and counted
inside a hypothesis example and enumerated outside one."""

from __future__ import annotations

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import tests.bruteforce as bf
from citysynth.solver import Problem
from tests.bruteforce_structure import _enumerate_structure, structure_work
from tests.test_solver_bruteforce import problems
from tests.test_structure_graphs import varied


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.filter_too_much])
@given(problems())
def test_sequence_count_is_what_the_enumeration_visits(p):
    n = bf.count_sequences(p)
    assume(n <= bf.LIMIT)
    assert bf._enumerate(p, 64)[1] == n


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.filter_too_much])
@given(varied(), st.one_of(st.none(), st.integers(1, 6)))
def test_structure_count_is_what_the_enumeration_visits(d, k):
    n = structure_work(d, k)
    assume(n <= bf.LIMIT)
    assert _enumerate_structure(d, k)[1] == n


def _unit_parts(n: int, hi: int) -> Problem:
    """n elements of length 1, every transition allowed, length at most hi."""
    ids = [f"e{i}" for i in range(n)]
    return Problem.from_dict({
        "resources": ["length"],
        "elements": [{"id": x, "resources": {"length": 1}} for x in ids],
        "transitions": [[a, b, 0.0] for a in ids for b in ids],
        "constraints": {"length": [0, hi]}})


def test_a_huge_draw_is_counted_not_enumerated():
    p = _unit_parts(5, 12)
    assert bf.count_sequences(p) == sum(5 ** n for n in range(1, 13))  # 3.05e8
    assert bf.count_sequences(p, stop=bf.LIMIT) <= 2 * 5 ** 6           # stops early


def test_outside_hypothesis_the_oracle_enumerates_anything():
    p = _unit_parts(3, 9)
    assert bf.count_sequences(p) > bf.LIMIT
    assert len(bf.enumerate_feasible(p)) == sum(3 ** n for n in range(1, 10))


def test_a_draw_over_the_limit_is_rejected_and_counted():
    before = bf.SKIPPED["probe"]
    seen = []

    @settings(max_examples=40, database=None)
    @given(st.integers(0, 2 * bf.LIMIT))
    def probe(work):
        bf.within_budget("probe", work)
        seen.append(work)

    probe()
    assert len(seen) >= 40 and max(seen) <= bf.LIMIT       # the full count, all in bounds
    assert bf.SKIPPED.pop("probe") > before   # (not an oracle: out of the summary)
