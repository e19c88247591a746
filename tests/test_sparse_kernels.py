"""The intermediate graph walking its transition lists (the kernels for sparse
tables) against exhaustive enumeration, with the checks and hypothesis problems of
tests/test_solver_bruteforce.py (rcksp on dense and hashed rows, and fgs); and a small
motion graph, where the lists are what a solve uses, against the other methods."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.solver import Problem, solve
from citysynth.solver.compiled import Compiled, compile_problem
from citysynth.solver.graph import build_graph
from citysynth.solver.samples import motion_graph
from tests.test_solver_bruteforce import _check, problems


@pytest.fixture
def lists_kernels(monkeypatch):
    """Make the intermediate graph walk its transition lists on every problem."""
    monkeypatch.setattr(Compiled, "sparse", property(lambda self: True))


@settings(max_examples=150, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(problems(), st.integers(1, 8))
def test_rcksp_on_transition_lists_matches_enumeration(lists_kernels, p, k):
    _check(p, k)


@settings(max_examples=40, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(problems(real_lengths=True), st.integers(1, 6))
def test_transition_lists_with_real_valued_lengths(lists_kernels, p, k):
    _check(p, k)


def test_motion_graph_is_sparse_and_every_method_agrees():
    p = Problem.from_dict(motion_graph(5.0, 146, segments=60, successors=6))
    cp = compile_problem(p)
    assert cp.sparse and cp._W is None
    rows = [solve(p, k=15, method=m, table=t) for m, t in
            (("rcksp", "dense"), ("rcksp", "hash"), ("fgs", "auto"), ("bounded", "auto"))]
    assert rows[0].status == "ok" and len(rows[0].solutions) == 15
    for r in rows[1:]:
        assert [s.cost for s in r.solutions] == [s.cost for s in rows[0].solutions]
    for r in (rows[1], rows[3]):
        assert [s.sequence for s in r.solutions] == [s.sequence for s in rows[0].solutions]
    build_graph(cp, dense=False, rows_hint=64, max_rows=10**6)
    assert cp._W is None  # the graph grew without the dense table
