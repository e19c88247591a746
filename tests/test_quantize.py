import math
from fractions import Fraction

import pytest

from citysynth.solver import Problem, ProblemError, solve
from citysynth.solver.quantize import exact_divisor, quantise_resource


def test_exact_divisor_of_decimal_lengths():
    assert exact_divisor([4.0, 6.2, 83.4]) == Fraction(1, 5)
    assert exact_divisor([2, 4, 6]) == Fraction(2)
    assert exact_divisor([0.0, 0.0]) == Fraction(1)
    assert exact_divisor([0.25, 1.5]) == Fraction(1, 4)


def test_no_exact_divisor():
    assert exact_divisor([math.pi, 1.0]) is None


@pytest.mark.parametrize("tiny", [1e-10, 1e-200, 5e-324])
def test_values_that_are_all_zero_within_the_tolerance_have_no_divisor(tiny):
    """Values of 1e-10 read as 0 within 1e-9, yet none is 0: their divisor came out 0
    and the quantisation divided by it (a ZeroDivisionError, exit 3, from `solve` on a
    one-element problem of 1e-10 m). Now no divisor: one line asking for a quantum no
    larger than the values (0.1 would count each as nothing)."""
    assert exact_divisor([tiny, 2 * tiny]) is None
    with pytest.raises(ProblemError, match="no common divisor") as e:
        quantise_resource("length", [tiny], 2 * tiny, 2 * tiny, None)
    hint = float(str(e.value).split('{"length": ')[1].rstrip("}"))
    assert 0 < hint <= max(tiny, 1e-300)
    with pytest.raises(ProblemError, match="0.1}"):
        quantise_resource("length", [math.pi, 1.0], 3.0, 3.0, None)


def test_exact_quantisation_reports_no_error():
    q, ints = quantise_resource("length", [4.0, 6.2], 83.4, 83.4, None)
    assert q.quantum == pytest.approx(0.2) and q.exact and q.max_error == 0.0
    assert ints == [20, 31] and (q.lo, q.hi) == (417, 417)


def test_given_quantum_rounds_values_and_bounds_inward():
    q, ints = quantise_resource("length", [4.03, 6.2], 83.3, 83.5, 0.2)
    assert not q.exact
    assert q.max_error == pytest.approx(0.03)
    assert ints == [20, 31]
    assert (q.lo, q.hi) == (417, 417)  # 83.3 up to 83.4, 83.5 down to 83.4


def test_interval_with_no_multiple_is_infeasible_with_nearest_values():
    p = Problem.from_dict({
        "resources": ["length"], "quantum": {"length": 0.2},
        "elements": [{"id": "a", "resources": {"length": 0.2}}],
        "transitions": [["a", "a", 0.0]],
        "constraints": {"length": [83.3, 83.3]},
    })
    r = solve(p)
    assert r.status == "infeasible" and not r.solutions
    assert "quantum" in r.reason and "83.2" in r.reason and "83.4" in r.reason


def test_values_without_common_divisor_ask_for_a_quantum():
    p = Problem.from_dict({
        "resources": ["length"],
        "elements": [{"id": "a", "resources": {"length": math.pi}},
                     {"id": "b", "resources": {"length": 1.0}}],
        "transitions": [["a", "b", 0.0]],
        "constraints": {"length": [10, 10]},
    })
    with pytest.raises(ProblemError, match='give one in "quantum"'):
        solve(p)


def test_an_equality_of_many_quanta_is_not_widened_by_whole_quanta():
    """The float tolerance on bound / quantum was 1e-9 of it: two whole quanta at 2e9
    quanta (1e7 m in 0.005 m), and 1e7 m asked exactly took 10,000,000.01 m. It is at
    most a millionth of a quantum now (found by an outside brute force, 2026-11-30)."""
    from citysynth.solver import Problem, solve
    from citysynth.solver.quantize import bounds_in_quanta
    assert bounds_in_quanta(1e7, 1e7, 0.005) == (2_000_000_000, 2_000_000_000)
    assert bounds_in_quanta(83.4, 83.4, 0.2) == (417, 417)   # float noise still absorbed
    p = Problem.from_dict({
        "resources": ["len"],
        "elements": [{"id": "A", "resources": {"len": 1000000.005}},
                     {"id": "B", "resources": {"len": 1000000}, "cost": 1}],
        "transitions": [["A", "A", 0], ["A", "B", 0], ["B", "A", 0], ["B", "B", 0]],
        "constraints": {"len": [1e7, 1e7]}})
    r = solve(p, k=3)
    assert [s.sequence for s in r.solutions] == [["B"] * 10]
    assert r.solutions[0].resources["len"] == 1e7


def test_an_answer_lost_to_rounding_is_said_so():
    """Every sequence whose rounded totals met the one constraint broke it in the
    amounts given: the reason said "each constraint can be met alone but not all
    together" of a single constraint."""
    from citysynth.solver import Problem, solve
    p = Problem.from_dict({
        "resources": ["len"],
        "elements": [{"id": "A", "resources": {"len": 0.3}},
                     {"id": "B", "resources": {"len": 0.5}}],
        "transitions": [["A", "A", 0], ["A", "B", 0], ["B", "A", 0], ["B", "B", 0]],
        "constraints": {"len": [0.6, 0.6]}, "quantum": {"len": 0.2}})
    r = solve(p)
    assert r.status == "infeasible" and r.stats["rejected_by_rounding"] == 3
    assert 'each amount of "len" is rounded to the quantum 0.2, by up to 0.1' in r.reason
    assert "give a finer quantum" in r.reason and "not all together" not in r.reason
