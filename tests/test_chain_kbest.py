"""The lazy chain program (solver.structures.chain_kbest) reading its structures back
through shared links (one per completion, copied into rows only for the k structures
returned) and offering entry 1 of a growing stage list at a lower bound on its cost
(StageGraphs.second_cost, stage_kbest._second_cost) until it is needed: the same
structures, costs, fillers, totals and order as the general program (combine) and
as the lazy program with the bounds switched off; every structure's lists its own;
the bound the second path's very cost."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.solver.samples import block_cycle
from citysynth.solver.structures import Structure, combine, solve_structure
from tests.test_structure_graphs import chains, varied


def _rows(r) -> list:
    return [(x.cost, x.keys, x.stages, x.resources) for x in r.solutions]


def _solve(s: Structure, k: int, *, lazy: bool = True, bounds: bool = True, **kw):
    old = combine.LAZY_CHAINS, combine.SECOND_BOUNDS
    combine.LAZY_CHAINS, combine.SECOND_BOUNDS = lazy, bounds
    try:
        return solve_structure(s, k, **kw)
    finally:
        combine.LAZY_CHAINS, combine.SECOND_BOUNDS = old


def _own_lists(r) -> None:
    """No two structures (nor two stages) share a list or a dict: a caller may change
    one structure's fillers or totals without changing another's."""
    seen: set[int] = set()
    for x in r.solutions:
        objs = [x.keys, x.stages, x.resources, *x.stages, *x.resources]
        assert len({id(o) for o in objs}) == len(objs)
        assert not seen & {id(o) for o in objs}
        seen |= {id(o) for o in objs}


def _same_as_general(s: Structure, k: int, **kw) -> None:
    lazy = _solve(s, k, **kw)
    assert lazy.stats["program"] == "lazy chain"
    general = _solve(s, k, lazy=False, **kw)
    assert general.stats["program"] == "general"
    assert _rows(lazy) == _rows(general)
    assert _rows(_solve(s, k, bounds=False, **kw)) == _rows(lazy)
    _own_lists(lazy)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(chains(), st.sampled_from([1, 2, 3, 7, 20, 60]), st.sampled_from(["dense", "hash"]))
def test_structures_read_back_are_the_general_programs(d, k, table):
    """Chains and cycles (with and without a structure-wide interval), up to 60
    structures: the lazy program's rows (links read back) and its bounded entries give
    the general program's structures in its order, ties included, with each
    structure's own lists."""
    _same_as_general(Structure.from_dict(d), k, table=table)


@pytest.mark.parametrize("corners, doors", [(40, None), (12, (6.0, 14.0)), (12, (20.0, 60.0))])
def test_block_outlines_at_k100_are_the_general_programs(corners, doors):
    """The benchmark's 40-corner block at k = 100 (about 1,250 completions read back,
    entries offered at bounds along every structure) and 12-corner blocks with a
    per-block door interval: the general program's 100 structures, in its order."""
    _same_as_general(Structure.from_dict(block_cycle(corners, doors=doors)), 100)


def test_bounds_spare_most_second_paths(monkeypatch):
    """With the bounds, a 12-corner block at k = 30 asks its graphs for more paths far
    less often (what the bounds are for), and gets the same structures."""
    from citysynth.solver.structures.stage_graphs import StageGraphs

    s = Structure.from_dict(block_cycle(12))
    calls: list[int] = []
    more = StageGraphs.more

    def counted(self, *a):
        calls[-1] += 1
        return more(self, *a)
    monkeypatch.setattr(StageGraphs, "more", counted)
    got = []
    for bounds in (False, True):
        calls.append(0)
        got.append(_rows(_solve(s, 30, bounds=bounds)))
    assert got[0] == got[1] and len(got[0]) == 30
    assert 0 < calls[1] < calls[0] / 2


def _graphs(s: Structure, k: int, table: str):
    from citysynth.solver.structures.solve import _global_grid
    from citysynth.solver.structures.stage_graphs import StageGraphs

    return StageGraphs(s, k, _global_grid(s), 512, table)._graph_of


def _check_second_costs(s: Structure, table: str) -> int:
    """Every query of every stage graph: the bound is at most the cost of the
    enumeration's second path, that very cost when its sums are the front-to-back ones,
    and inf exactly when there is no second path. Returns the queries checked."""
    from citysynth.solver.structures.stage_kbest import _second_cost, _stage_kbest

    n = 0
    for G, depth, _fillers in _graphs(s, 2, table):
        costs, _offs, _fill, first, same = _stage_kbest(G, 2, depth)
        for q in range(len(first) - 1):
            bound = _second_cost(G, q)
            if first[q + 1] - first[q] < 2:
                assert bound == np.inf
                continue
            second = sorted(costs[first[q]:first[q + 1]])[1]
            assert bound <= second
            if same:
                assert bound == second
            n += 1
    return n


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(varied(), chains()), st.sampled_from(["dense", "hash"]))
def test_second_cost_is_the_second_paths_cost(d, table):
    _check_second_costs(Structure.from_dict(d), table)


@pytest.mark.parametrize("doors", [None, (6.0, 14.0)])
def test_second_cost_on_block_outlines(doors):
    assert _check_second_costs(Structure.from_dict(block_cycle(12, doors=doors)), "dense") > 50
