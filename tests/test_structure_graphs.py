"""The shared stage graphs (solver.stage_graphs, the default structure solver) against
exhaustive enumeration and against the decomposition (method "decompose"), on
structures that exercise what the graphs share: stages with the same fillers and
different intervals, stages with fillers of their own, T branches with their branch
transitions, cycles, intervals on two resources, structure-wide intervals (also on a
resource a stage constrains itself); and the refusals."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.solver import ProblemError, TooLargeError
from citysynth.solver.samples import block_cycle, fig1c_like
from citysynth.solver.structures import Structure, solve_structure
from tests.bruteforce_structure import enumerate_structure, solution_cost
from tests.test_structure import structures, trees

ROOT = Path(__file__).resolve().parent.parent


@st.composite
def varied(draw):
    """A chain, cycle or tree, then: own fillers for some stages, a doors interval on
    some, and a structure-wide interval on doors or on length."""
    d = draw(st.one_of(structures(), trees()))
    fillers = [e["id"] for e in d["elements"] if "legs" not in e]
    for s in d["stages"]:
        if draw(st.integers(0, 2)) == 0:
            s["elements"] = draw(st.lists(st.sampled_from(fillers), min_size=1, unique=True))
        if draw(st.integers(0, 2)) == 0:
            lo = draw(st.integers(0, 1))
            s["constraints"]["doors"] = [lo, lo + draw(st.integers(0, 2))]
    wide = draw(st.sampled_from(["none", "doors", "length"]))
    if wide == "doors":
        lo = draw(st.integers(0, 3))
        d["constraints"] = {"doors": [lo, lo + draw(st.integers(0, 2))]}
    elif wide == "length":
        lo = sum(s["constraints"]["length"][0] for s in d["stages"])
        lo += draw(st.integers(0, 2))
        d["constraints"] = {"length": [lo, lo + draw(st.integers(0, 1))]}
    return d


def check(d: dict, r, k: int, expected: list[float]) -> None:
    """r holds the k best costs, and each solution is a valid, distinct filling that
    costs what it says."""
    assert [s.cost for s in r.solutions] == pytest.approx(expected[:k])
    assert r.status == ("ok" if expected else "infeasible")
    seen = set()
    for s in r.solutions:
        assert solution_cost(d, s.keys, s.stages) == pytest.approx(s.cost)
        seen.add((tuple(s.keys), tuple(map(tuple, s.stages))))
    assert len(seen) == len(r.solutions)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(varied(), st.integers(1, 6))
def test_shared_graphs_match_enumeration_and_decomposition(d, k):
    expected = enumerate_structure(d, k)
    new = solve_structure(Structure.from_dict(d), k)
    old = solve_structure(Structure.from_dict(d), k, "decompose")
    assert new.stats["stages_by"] == "graphs"
    check(d, new, k, expected)
    check(d, old, k, expected)
    assert [s.cost for s in new.solutions] == [s.cost for s in old.solutions]
    for a, b in zip(new.solutions, old.solutions, strict=True):
        if a.keys == b.keys and a.stages == b.stages:
            assert a.resources == b.resources


def test_stage_interval_on_a_structure_wide_resource_still_holds():
    """Stage 0 allows at most one door while the building needs three or more: the
    decomposition used to let the structure-wide share replace the stage's own
    interval (three doors on stage 0)."""
    d = {"resources": ["length", "doors"],
         "elements": [{"id": "d", "resources": {"length": 1, "doors": 1}},
                      {"id": "w", "resources": {"length": 1}, "cost": 1.0},
                      {"id": "k", "legs": [{"length": 1}, {"length": 1}]}],
         "transitions": [[a, b, 0.0] for a in "dwk" for b in "dwk"],
         "keypoints": [{"elements": ["k"]}] * 3,
         "stages": [{"constraints": {"length": [5, 5], "doors": [0, 1]}},
                    {"constraints": {"length": [5, 5]}}],
         "constraints": {"doors": [3, 6]}}
    expected = enumerate_structure(d, 3)
    assert expected == [2.0, 2.0, 2.0]
    for method in ("rcksp", "decompose"):
        r = solve_structure(Structure.from_dict(d), 3, method)
        check(d, r, 3, expected)
        assert all(s.resources[0]["doors"] <= 1 for s in r.solutions)


@pytest.mark.parametrize("make, k", [(fig1c_like, 10), (lambda: block_cycle(12), 10)])
def test_same_answers_as_the_decomposition_and_between_row_tables(make, k):
    st_ = Structure.from_dict(make())
    new = solve_structure(st_, k)
    hashed = solve_structure(st_, k, table="hash")
    old = solve_structure(st_, k, "decompose")
    fgs = solve_structure(st_, k, "fgs")
    assert [vars(s) for s in new.solutions] == [vars(s) for s in hashed.solutions]
    assert [s.cost for s in new.solutions] == [s.cost for s in old.solutions] \
        == [s.cost for s in fgs.solutions]
    assert new.stats["stages_by"] == "graphs" and old.stats["stages_by"] == "pairs (rcksp)"
    assert fgs.stats["stages_by"] == "pairs (fgs)"


_DUMP = """
import json, sys
from citysynth.solver.samples import fig1c_like, block_cycle
from citysynth.solver.structures import Structure, solve_structure
out = [[vars(s) for s in solve_structure(Structure.from_dict(d), 10).solutions]
       for d in (fig1c_like(), block_cycle(8))]
print(json.dumps(out, sort_keys=True))
"""


def test_same_input_same_solutions_in_any_process():
    """Ties come out in one order whatever the string hash seed of the process."""
    outs = []
    for seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        outs.append(subprocess.run([sys.executable, "-c", _DUMP], cwd=ROOT, env=env,
                                   capture_output=True, text=True, check=True).stdout)
    assert outs[0] == outs[1] and json.loads(outs[0])


def test_rounding_quantum_takes_the_decomposition():
    """Values that are not multiples of the quantum: totals must be re-checked in
    original units, which the one-stage solves do."""
    d = {"resources": ["length"], "quantum": {"length": 0.5},
         "elements": [{"id": "a", "resources": {"length": 2.4}},
                      {"id": "b", "resources": {"length": 3.1}, "cost": 0.5},
                      {"id": "k", "legs": [{"length": 1.2}, {"length": 1.2}]}],
         "transitions": [[x, y, 0.25] for x in "abk" for y in "abk"],
         "keypoints": [{"elements": ["k"]}] * 2,
         "stages": [{"constraints": {"length": [10.0, 11.0]}}]}
    r = solve_structure(Structure.from_dict(d), 5)
    assert r.stats["stages_by"] == "pairs (auto)" and r.status == "ok"
    assert all(10.0 <= s.resources[0]["length"] <= 11.0 for s in r.solutions)


def _long_block(quantum: float) -> dict:
    d = block_cycle(4)
    d["quantum"] = {"length": quantum}
    return d


def test_too_large_structure_is_refused_before_anything_is_allocated(monkeypatch):
    import citysynth.solver.structures.stage_graphs as sg

    def never(*_a, **_k):
        raise AssertionError("a graph was grown")

    monkeypatch.setattr(sg, "_grow_graph", never)
    with pytest.raises(TooLargeError) as exc:
        solve_structure(Structure.from_dict(_long_block(0.0001)), max_memory_mb=64)
    msg = str(exc.value)
    assert msg.startswith("structure too large") and "64 MB" in msg
    assert '"length"' in msg and "coarser quantum" in msg and "--max-memory" in msg


def test_the_graphs_of_a_structure_share_its_budget():
    """Every stage graph is kept until the structures are read. Each was held to the
    budget alone, so a city block with a per-block window count grew 27 graphs of up to
    the budget each (5 GB under a 2 GB budget; a traceback under a 3 GB ulimit). Here
    three graphs of about 1.05 MB: 3.5 MB holds them, 3 MB is refused with what all
    would take, though each alone fits."""
    d = block_cycle(4, doors=(0, 1e9))
    d["constraints"] = {"doors": [4, 1e9]}
    ok = solve_structure(Structure.from_dict(d), k=2, max_memory_mb=3.5)
    assert ok.status == "ok" and ok.stats["stage_graphs"] == 3
    with pytest.raises(TooLargeError) as exc:
        solve_structure(Structure.from_dict(d), k=2, max_memory_mb=3)
    msg = str(exc.value)
    assert "its 3 stage graphs would take about 3.2 MB (2 fit" in msg, msg
    assert "over the memory budget of 3 MB" in msg
    assert 3 < exc.value.need_mb < 3.5


def test_too_large_structure_file_exits_2_with_the_message(tmp_path, capsys):
    from citysynth.pipeline.cli import main
    f = tmp_path / "huge.json"
    f.write_text(json.dumps(_long_block(0.0001)))
    assert main(["solve", str(f), "--max-memory", "64"]) == 2
    err = capsys.readouterr().err
    assert f"error: {f}: structure too large" in err and "coarser quantum" in err
    assert len(err.strip().splitlines()) == 1


def test_structure_refusals_of_the_stage_graphs():
    base = {"resources": ["length", "doors"],
            "elements": [{"id": "f", "resources": {"length": 1}},
                         {"id": "ghost", "resources": {"doors": 1}},
                         {"id": "k", "legs": [{"length": 1}, {"length": 1}]}],
            "transitions": [[x, y, 0.0] for x in ("f", "ghost", "k")
                            for y in ("f", "ghost", "k")],
            "keypoints": [{"elements": ["k"]}] * 2,
            "stages": [{"constraints": {"length": [4, 4]}}]}
    with pytest.raises(ProblemError, match='"ghost" consumes nothing .* stage 0'):
        solve_structure(Structure.from_dict(base))
    with pytest.raises(ProblemError, match="unknown structure method"):
        solve_structure(Structure.from_dict(base), method="merged")
    ok = {**base, "stages": [{"constraints": {"length": [4, 4]}, "elements": ["f"]}]}
    assert solve_structure(Structure.from_dict(ok)).status == "ok"
    bad = {**ok, "stages": [{"constraints": {"length": [2.5, 2.9]}, "elements": ["f"]}]}
    r = solve_structure(Structure.from_dict(bad))
    assert r.status == "infeasible"
    assert "stage 0 between k and k" in r.reason and "nearest achievable" in r.reason


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(varied())
def test_k1_array_combination_is_the_general_one(d):
    """k = 1 combines stage lists by arrays over the shares (combine._Best1): the same
    solution, ties included, as the general per-pair merge, and the enumeration's cost."""
    from citysynth.solver.structures import combine

    s = Structure.from_dict(d)
    combine.MIN_SHARES = 0       # arrays whatever the number of shares (small draws)
    try:
        fast = solve_structure(s, 1)
        combine.ARRAYS_K1 = False
        slow = solve_structure(s, 1)
    finally:
        combine.ARRAYS_K1, combine.MIN_SHARES = True, 4
    assert [(x.cost, x.keys, x.stages) for x in fast.solutions] == \
        [(x.cost, x.keys, x.stages) for x in slow.solutions]
    expected = enumerate_structure(d, 1)
    assert [x.cost for x in fast.solutions] == pytest.approx(expected[:1])


@st.composite
def chains(draw):
    """A chain or cycle (the lazy program's structures), sometimes
    with transition costs like 0.1 and 0.7 whose sums round differently by order (the
    stage lists' two ways of summing must not reorder them)."""
    d = draw(structures())
    if draw(st.booleans()):
        for t in d["transitions"]:
            t[2] = draw(st.sampled_from([0.1, 0.2, 0.3, 0.7, 1.1]))
    wide = draw(st.sampled_from(["none", "doors", "length"]))
    if wide == "doors":
        lo = draw(st.integers(0, 3))
        d["constraints"] = {"doors": [lo, lo + draw(st.integers(0, 2))]}
    elif wide == "length":
        lo = sum(s["constraints"]["length"][0] for s in d["stages"])
        d["constraints"] = {"length": [lo, lo + draw(st.integers(0, 2))]}
    return d


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(chains(), st.integers(1, 9), st.sampled_from([1, 2, 4]))
def test_lazy_chain_program_is_the_general_one(d, k, first):
    """Chains and cycles take the lazy program (combine.LAZY_CHAINS; chain_kbest), its
    stage lists starting with ``first`` paths and growing on demand: the same
    solutions in the same order, ties included, as the general program with full
    lists; every one feasible, distinct and costing what it says, the costs the k
    smallest of the exhaustive enumeration."""
    from citysynth.solver.structures import combine

    s = Structure.from_dict(d)
    old = combine.FIRST_PATHS
    combine.FIRST_PATHS = first
    try:
        lazy = solve_structure(s, k)
        combine.LAZY_CHAINS = False
        general = solve_structure(s, k)
    finally:
        combine.LAZY_CHAINS, combine.FIRST_PATHS = True, old
    assert lazy.stats["program"] == "lazy chain"
    assert general.stats["program"] == "general"
    assert [(x.cost, x.keys, x.stages, x.resources) for x in lazy.solutions] == \
        [(x.cost, x.keys, x.stages, x.resources) for x in general.solutions]
    expected = enumerate_structure(d, k)
    check(d, lazy, k, expected)
    for sol in lazy.solutions:
        for res, stage in zip(sol.resources, d["stages"], strict=True):
            for name, (lo, hi) in stage["constraints"].items():
                assert lo - 1e-9 <= res[name] <= hi + 1e-9
        for name, (lo, hi) in d.get("constraints", {}).items():
            assert lo - 1e-9 <= sum(res[name] for res in sol.resources) <= hi + 1e-9


@pytest.mark.parametrize("doors", [None, (20.0, 60.0), (10.0, 14.0)])
def test_lazy_chain_program_on_a_block_outline(doors):
    """A 12-corner block like the benchmark's, k = 30: the lazy program (stage lists
    growing from one path) gives the general program's 30 solutions, in its order."""
    from citysynth.solver.structures import combine

    s = Structure.from_dict(block_cycle(12, doors=doors))
    combine.FIRST_PATHS = 1
    try:
        lazy = solve_structure(s, 30)
        combine.LAZY_CHAINS = False
        general = solve_structure(s, 30)
    finally:
        combine.LAZY_CHAINS, combine.FIRST_PATHS = True, 1
    assert len(lazy.solutions) == 30
    assert [(x.cost, x.keys, x.stages) for x in lazy.solutions] == \
        [(x.cost, x.keys, x.stages) for x in general.solutions]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(varied(), chains()))
def test_best_fillings_by_argmin_chains_are_the_enumerations(d):
    """One-path stage lists (k = 1, and the lazy program's first paths) come from the
    graphs' costs alone, their paths found when a solution reads them, the lists made
    when read and the lazy program's first entries taken as one array
    (stage_kbest.one_path, StageGraphs.first_costs): the same solutions, costs, totals
    and order as with the lazy enumeration's first paths, at k = 1 and k = 3."""
    from citysynth.solver.structures import stage_kbest

    s = Structure.from_dict(d)
    for k in (1, 3):
        fast = solve_structure(s, k)
        stage_kbest.BEST_BY_ARGMIN = False
        try:
            slow = solve_structure(s, k)
        finally:
            stage_kbest.BEST_BY_ARGMIN = True
        assert [(x.cost, x.keys, x.stages, x.resources) for x in fast.solutions] == \
            [(x.cost, x.keys, x.stages, x.resources) for x in slow.solutions]


def test_paths_whose_sums_disagree_are_final_only_below_a_margin():
    """Should the enumeration's sums and the front-to-back ones ever differ, a list
    found with K paths keeps as final only the paths cheaper than the K-th by a margin
    (a path not yet found may sort before the others); complete lists are plain."""
    from citysynth.solver.structures.stage_kbest import Growing, sorted_paths

    costs = [1.0, 2.0, 3.0 + 1e-15, 3.0]       # the last two out of order by rounding
    ls = sorted_paths(costs, 0, 4, 4, 10, False, 7, 0, 5)
    assert isinstance(ls, Growing)
    assert [c for c, _ in ls] == [1.0, 2.0, 3.0, 3.0 + 1e-15]
    assert ls.final == 2 and (ls.gi, ls.q, ls.K) == (0, 5, 4)
    assert ls[0][1] == (7, 0)
    same = sorted_paths([1.0, 2.0], 0, 2, 2, 10, True, 0, 0, 0)
    assert isinstance(same, Growing) and same.final == 2     # in order: all final
    done = sorted_paths(costs, 0, 4, 4, 4, False, 0, 0, 0)   # K = k: complete
    assert not isinstance(done, Growing) and len(done) == 4


def _graphs(s: Structure, k: int):
    from citysynth.solver.structures.solve import _global_grid
    from citysynth.solver.structures.stage_graphs import StageGraphs

    return StageGraphs(s, k, _global_grid(s), 512, "dense")._graph_of


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(varied(), chains()))
def test_dense_forward_pass_is_the_general_kernels(d):
    """Dense stage graphs are grown by stage_forward.forward_dense, states in order,
    instead of graph._grow_graph: the same g bit for bit on every graph, so the same
    solutions in the same order (k = 1 and 3), and on the benchmark's block with its
    door interval."""
    from citysynth.solver.structures import stage_graphs

    s = Structure.from_dict(d)
    for k in (1, 3):
        fast, fast_graphs = solve_structure(s, k, table="dense"), _graphs(s, k)
        stage_graphs.DENSE_FORWARD = False
        try:
            slow, slow_graphs = solve_structure(s, k, table="dense"), _graphs(s, k)
        finally:
            stage_graphs.DENSE_FORWARD = True
        assert len(fast_graphs) == len(slow_graphs)
        for (a, _, _), (b, _, _) in zip(fast_graphs, slow_graphs, strict=True):
            assert a.g.shape == b.g.shape and (a.g == b.g).all()
            assert a.qbase == b.qbase and (a.row_state == b.row_state).all()
        assert [(x.cost, x.keys, x.stages, x.resources) for x in fast.solutions] == \
            [(x.cost, x.keys, x.stages, x.resources) for x in slow.solutions]


def test_dense_forward_pass_on_a_block_with_a_door_interval():
    from citysynth.solver.structures import stage_graphs

    s = Structure.from_dict(block_cycle(12, doors=(6.0, 14.0)))
    fast = _graphs(s, 1)
    stage_graphs.DENSE_FORWARD = False
    try:
        slow = _graphs(s, 1)
    finally:
        stage_graphs.DENSE_FORWARD = True
    for (a, _, _), (b, _, _) in zip(fast, slow, strict=True):
        assert (a.g == b.g).all()


def test_tables_given_back_serve_the_next_solve_unchanged():
    """A solve gives its graphs' tables back (buffers) and the next one reuses them:
    solves in turn of different blocks give what fresh tables give; a buffer is handed
    out again only once given back, and no larger than four times what is asked."""
    from citysynth.solver.structures import buffers

    blocks = [Structure.from_dict(block_cycle(12, doors=(6.0, 14.0))),
              Structure.from_dict(block_cycle(8)),
              Structure.from_dict(block_cycle(12, doors=(4.0, 9.0)))]
    buffers._free.buffers = []
    first = [[(x.cost, x.keys, x.stages) for x in solve_structure(b, 3).solutions]
             for b in blocks]
    assert buffers._free.buffers   # given back
    again = [[(x.cost, x.keys, x.stages) for x in solve_structure(b, 3).solutions]
             for b in reversed(blocks)]
    assert again[::-1] == first
    buffers._free.buffers = []
    a = buffers.take(2000, 3)
    b = buffers.take(2000, 3)
    assert not np.shares_memory(a, b)
    buffers.give_back([a])
    c = buffers.take(1000, 3)
    assert np.shares_memory(a, c) and c.shape == (1000, 3)
    assert not np.shares_memory(buffers.take(1000, 3), a)   # handed out already
    buffers.give_back([c])
    assert not np.shares_memory(buffers.take(100, 3), a)   # more than four times too large


@st.composite
def chains_with_a_wide_interval(draw):
    """A chain or cycle with a structure-wide interval on doors (a door count per
    block) or on length: the path the issue's per-block interval takes (stage lists
    made when read from the graphs' best costs, the first entries as one array, the
    structures read back as rows)."""
    d = draw(chains())
    if "constraints" not in d:
        lo = draw(st.integers(0, 3))
        d["constraints"] = {"doors": [lo, lo + draw(st.integers(0, 3))]}
    return d


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(chains_with_a_wide_interval())
def test_structure_wide_interval_k1_and_k3_are_the_enumerations(d):
    """With a structure-wide interval, k = 1 and k = 3: the costs are the k smallest of
    the exhaustive enumeration, every structure valid and within the interval, and the
    same structures as the general program's (lists made in full, payloads)."""
    from citysynth.solver.structures import combine

    s = Structure.from_dict(d)
    expected = enumerate_structure(d, 3)
    for k in (1, 3):
        r = solve_structure(s, k)
        assert r.stats["program"] == "lazy chain"
        check(d, r, k, expected)
        for sol in r.solutions:
            for name, (lo, hi) in d["constraints"].items():
                assert lo - 1e-9 <= sum(res[name] for res in sol.resources) <= hi + 1e-9
        combine.LAZY_CHAINS = False
        try:
            general = solve_structure(s, k)
        finally:
            combine.LAZY_CHAINS = True
        assert [(x.cost, x.keys, x.stages, x.resources) for x in r.solutions] == \
            [(x.cost, x.keys, x.stages, x.resources) for x in general.solutions]


@pytest.mark.parametrize("doors", [None, (6.0, 14.0)])
def test_first_candidates_by_loop_or_by_arrays_are_the_same(doors):
    """A node's first candidates (chain_kbest._start_heap) come from a Python loop when
    there are few, from arrays otherwise: the same structures either way."""
    from citysynth.solver.structures import chain_kbest

    s = Structure.from_dict(block_cycle(12, doors=doors))
    old = chain_kbest.SMALL_START
    got = []
    for small in (0, 10**6):
        chain_kbest.SMALL_START = small
        try:
            got.append([(x.cost, x.keys, x.stages) for x in solve_structure(s, 30).solutions])
        finally:
            chain_kbest.SMALL_START = old
    assert len(got[0]) == 30 and got[0] == got[1]
