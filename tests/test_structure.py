"""Chain and cycle structures against exhaustive enumeration."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.solver import ProblemError
from citysynth.solver.samples import fig1c_like
from citysynth.solver.structures import Structure, solve_structure
from tests.bruteforce_structure import enumerate_structure

COSTS = st.sampled_from([0.0, 0.25, 0.5, 1.0, 2.0])


@st.composite
def structures(draw):
    n_fill = draw(st.integers(1, 3))
    n_key = draw(st.integers(1, 3))
    closed = draw(st.booleans())
    m = draw(st.integers(1, 3))
    fill = [{"id": f"f{i}", "resources": {"length": draw(st.integers(1, 3)),
                                          "doors": draw(st.integers(0, 1))},
             "cost": draw(COSTS)} for i in range(n_fill)]
    keys = [{"id": f"k{i}", "resources": {},
             "legs": [{"length": draw(st.integers(1, 2))}, {"length": draw(st.integers(1, 2))}],
             "cost": draw(COSTS)} for i in range(n_key)]
    ids = [e["id"] for e in fill + keys]
    trans = [[a, b, draw(COSTS)] for a in ids for b in ids if draw(st.integers(0, 3)) > 0]
    n_kp = m if closed else m + 1
    kps = [{"elements": draw(st.lists(st.sampled_from([k["id"] for k in keys]), min_size=1,
                                      unique=True))} for _ in range(n_kp)]
    stages = []
    for _ in range(m):
        lo = draw(st.integers(2, 7))
        cons = {"length": [lo, lo + draw(st.sampled_from([0, 0, 1, 2]))]}
        if draw(st.booleans()):
            cons["doors"] = [0, draw(st.integers(0, 2))]
        stages.append({"constraints": cons})
    return {"resources": ["length", "doors"], "elements": fill + keys, "transitions": trans,
            "keypoints": kps, "stages": stages, "closed": closed}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(structures(), st.integers(1, 6))
def test_structures_match_enumeration(d, k):
    expected = enumerate_structure(d, k)
    r = solve_structure(Structure.from_dict(d), k)
    assert [s.cost for s in r.solutions] == expected[:k]
    assert r.status == ("ok" if expected else "infeasible")
    for s in r.solutions:
        assert len(s.stages) == len(d["stages"]) and len(s.keys) == len(d["keypoints"])
        for sol_stage, stage in zip(s.resources, d["stages"], strict=True):
            for name, (lo, hi) in stage["constraints"].items():
                assert lo - 1e-9 <= sol_stage[name] <= hi + 1e-9


def test_block_cycle_with_corners():
    d = {
        "resources": ["length"],
        "elements": [
            {"id": "wide", "resources": {"length": 6.0}, "cost": 0.0},
            {"id": "narrow", "resources": {"length": 4.0}, "cost": 0.0},
            {"id": "corner_a", "legs": [{"length": 3.0}, {"length": 3.0}], "cost": 1.0},
            {"id": "corner_b", "legs": [{"length": 2.0}, {"length": 2.0}], "cost": 0.0},
        ],
        "transitions": [[a, b, 0.5 if a == b else 0.0] for a in
                        ("wide", "narrow", "corner_a", "corner_b")
                        for b in ("wide", "narrow", "corner_a", "corner_b")],
        "keypoints": [{"elements": ["corner_a", "corner_b"]}] * 4,
        "stages": [{"constraints": {"length": [L, L]}} for L in (20.0, 14.0, 20.0, 14.0)],
        "closed": True,
    }
    r = solve_structure(Structure.from_dict(d), 3)
    assert r.status == "ok"
    assert [s.cost for s in r.solutions] == enumerate_structure(d, 3)
    best = r.solutions[0]
    assert len(best.keys) == 4 and all(s["length"] == L for s, L in
                                       zip(best.resources, (20, 14, 20, 14), strict=True))


@pytest.mark.parametrize("closed", [True, False])
def test_a_structure_of_a_thousand_corners_gives_its_k_best(closed):
    """The k-best programs recurse one key point deeper per stage: at 500 corners and
    k = 2 a cycle went past Python's 1,000 frames (RecursionError, exit 3). Each corner
    costs 1 or 0 (corner_a or corner_b), each side 0: the best is all corner_b, the
    next ones swap one corner."""
    n = 1000
    d = {"resources": ["length"], "elements": [
        {"id": "wide", "resources": {"length": 6.0}},
        {"id": "corner_a", "legs": [{"length": 3.0}, {"length": 3.0}], "cost": 1.0},
        {"id": "corner_b", "legs": [{"length": 3.0}, {"length": 3.0}]}],
        "transitions": [[a, b, 0.0] for a in ("wide", "corner_a", "corner_b")
                        for b in ("wide", "corner_a", "corner_b")],
        "keypoints": [{"elements": ["corner_a", "corner_b"]}] * (n if closed else n + 1),
        "stages": [{"constraints": {"length": [12, 12]}}] * n, "closed": closed}
    r = solve_structure(Structure.from_dict(d), 3)
    assert r.status == "ok" and [s.cost for s in r.solutions] == [0.0, 1.0, 1.0]


def test_a_branch_on_a_key_point_without_branch_legs_is_refused():
    """A key point that names a branch stage, but whose elements have two legs (a
    corner, at a leaf or on a cycle), was an IndexError (exit 3)."""
    d = {"resources": ["length"], "elements": [
        {"id": "f", "resources": {"length": 1}},
        {"id": "k", "legs": [{"length": 1}, {"length": 1}]}],
        "transitions": [["k", "f", 0], ["f", "k", 0]],
        "keypoints": [{"elements": ["k"], "branch": 0}, {"elements": ["k"]}],
        "stages": [{"constraints": {"length": [3, 3]}}]}
    with pytest.raises(ProblemError, match=r"keypoints\[0\]: 'k' has no branch leg .* "
                       'leave "branch" out'):
        Structure.from_dict(d)


def test_stages_given_from_and_to_for_some_only_are_told_so():
    """Some stages with "from"/"to", others without (the in-order shorthand is then
    off) was "stages[1].from: must be a key point index, got None"."""
    d = {"resources": ["length"], "elements": [
        {"id": "f", "resources": {"length": 1}},
        {"id": "k", "legs": [{"length": 1}, {"length": 1}]}],
        "transitions": [["k", "f", 0], ["f", "k", 0]],
        "keypoints": [{"elements": ["k"]}] * 3, "closed": True,
        "stages": [{"constraints": {"length": [3, 3]}, "from": 0, "to": 1},
                   {"constraints": {"length": [3, 3]}}, {"constraints": {"length": [3, 3]}}]}
    with pytest.raises(ProblemError, match='stages\\[1\\]: no "from"; give every stage its '
                       '"from" and "to" key points, or none of them'):
        Structure.from_dict(d)
    d["stages"][1] = {**d["stages"][1], "from": 1, "to": 7}
    with pytest.raises(ProblemError, match="must be a key point index from 0 to 2, got 7"):
        Structure.from_dict(d)


def test_structure_refusals():
    base = {"resources": ["length"], "elements": [
        {"id": "f", "resources": {"length": 1}},
        {"id": "k", "legs": [{"length": 1}, {"length": 1}]}],
        "transitions": [["k", "f", 0], ["f", "k", 0]],
        "keypoints": [{"elements": ["k"]}, {"elements": ["k"]}],
        "stages": [{"constraints": {"length": [3, 3]}}]}
    with pytest.raises(ProblemError, match="constraints.width: unknown resource"):
        Structure.from_dict({**base, "constraints": {"width": [1, 9]}})
    with pytest.raises(ProblemError, match="not a key element"):
        Structure.from_dict({**base, "keypoints": [{"elements": ["f"]}] * 2})
    with pytest.raises(ProblemError, match="1 stages need 2 key points"):
        Structure.from_dict({**base, "keypoints": [{"elements": ["k"]}]})
    assert solve_structure(Structure.from_dict(base)).status == "ok"


def test_solve_cli_runs_structure_files(capsys):
    import json
    from pathlib import Path

    from citysynth.pipeline.cli import main
    f = Path(__file__).resolve().parent.parent / "examples" / "block_cycle.json"
    assert main(["solve", str(f), "--json", "--k", "2"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["status"] == "ok" and len(d["solutions"]) == 2
    for s in d["solutions"]:
        assert [r["length"] for r in s["resources"]] == [37.4, 22.0, 37.4, 22.0]
        assert 2 <= s["resources"][0]["doors"] <= 4
        assert 8 <= sum(r["doors"] for r in s["resources"]) <= 10  # structure-wide
    api = solve_structure(Structure.from_dict(json.loads(f.read_text())), 2)
    assert [s["cost"] for s in d["solutions"]] == [s.cost for s in api.solutions]


@st.composite
def trees(draw):
    """Random trees (and cycles with trees hanging off) with T junctions."""
    n_fill = draw(st.integers(1, 3))
    fill = [{"id": f"f{i}", "resources": {"length": draw(st.integers(1, 3)),
                                          "doors": draw(st.integers(0, 1))},
             "cost": draw(COSTS)} for i in range(n_fill)]
    keys = [{"id": f"k{i}", "cost": draw(COSTS),
             "legs": [{"length": draw(st.integers(1, 2))} for _ in range(3)]}
            for i in range(draw(st.integers(1, 3)))]
    ids = [e["id"] for e in fill + keys]
    trans = [[a, b, draw(COSTS)] for a in ids for b in ids if draw(st.integers(0, 3)) > 0]
    btrans = [[a, b, draw(COSTS)] for a in ids for b in ids if draw(st.integers(0, 2)) > 0]
    closed = draw(st.booleans())
    # grow a tree: each new key point hangs off an existing one with fewer than 2 children
    n = draw(st.integers(2 if not closed else 3, 5))
    edges = [(0, 1)] if not closed else [(0, 1), (1, 2), (2, 0)]
    first_new = 2 if not closed else 3
    for v in range(first_new, n):
        deg = {u: sum(u in e for e in edges) for u in range(v)}
        parents = [u for u in range(v) if deg[u] < 3 and sum(a == u for a, _ in edges) < 2]
        edges.append((draw(st.sampled_from(parents)), v))
    kps = [{"elements": draw(st.lists(st.sampled_from([k["id"] for k in keys]), min_size=1,
                                      unique=True))} for _ in range(n)]
    for u in range(n):
        outs = [i for i, (a, _) in enumerate(edges) if a == u]
        if len(outs) == 2:
            kps[u]["branch"] = draw(st.sampled_from(outs))
    stages = [{"from": a, "to": b,
               "constraints": {"length": (lambda lo: [lo, lo + draw(st.sampled_from([0, 1, 2]))])(
                   draw(st.integers(2, 6)))}} for a, b in edges]
    return {"resources": ["length", "doors"], "elements": fill + keys, "transitions": trans,
            "branch_transitions": btrans, "keypoints": kps, "stages": stages}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees(), st.integers(1, 6))
def test_trees_and_cycles_with_branches_match_enumeration(d, k):
    expected = enumerate_structure(d, k)
    r = solve_structure(Structure.from_dict(d), k)
    assert [s.cost for s in r.solutions] == pytest.approx(expected[:k])
    for s in r.solutions:
        assert all(key is not None for key in s.keys)
        for res, stage in zip(s.resources, d["stages"], strict=True):
            for name, (lo, hi) in stage["constraints"].items():
                assert lo - 1e-9 <= res[name] <= hi + 1e-9


def test_fig1c_like_building_k3_differs_locally_and_at_a_t_joint():
    d = fig1c_like()
    r = solve_structure(Structure.from_dict(d), 3)
    assert r.status == "ok"
    assert [s.cost for s in r.solutions] == pytest.approx(enumerate_structure(d, 3))
    sols = r.solutions
    for s in sols:
        assert [res["length"] for res in s.resources][:4] == [7, 6, 9, 8]
        assert s.keys[5] == s.keys[6] == "end"
    # the k results differ locally: few stages or key points change between them
    for a, b in zip(sols, sols[1:], strict=False):
        changed = sum(x != y for x, y in zip(a.stages, b.stages, strict=True)) + \
            sum(x != y for x, y in zip(a.keys, b.keys, strict=True))
        assert 1 <= changed <= 3
    assert len({(s.keys[1], s.keys[4]) for s in sols}) > 1  # a T joint changes


def test_37_3_m_edge_within_half_a_quantum():
    d = {"resources": ["length"], "quantum": {"length": 0.2},
         "elements": [{"id": f"m{L}", "resources": {"length": L}} for L in (4.2, 5.8, 7.4)]
         + [{"id": "end", "legs": [{"length": 1.2}, {"length": 1.2}]}],
         "transitions": [[a, b, 0.0] for a in ("m4.2", "m5.8", "m7.4", "end")
                         for b in ("m4.2", "m5.8", "m7.4", "end")],
         "keypoints": [{"elements": ["end"]}, {"elements": ["end"]}],
         "stages": [{"constraints": {"length": [37.3 - 0.1, 37.3 + 0.1]}}]}
    r = solve_structure(Structure.from_dict(d), 5)
    assert r.status == "ok"
    for s in r.solutions:
        assert abs(s.resources[0]["length"] - 37.3) <= 0.1 + 1e-9


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees(), st.integers(1, 5), st.integers(0, 3), st.integers(0, 2))
def test_structure_wide_intervals_match_enumeration(d, k, lo, width):
    d = {**d, "constraints": {"doors": [lo, lo + width]}}
    expected = enumerate_structure(d, k)
    r = solve_structure(Structure.from_dict(d), k)
    assert [s.cost for s in r.solutions] == pytest.approx(expected[:k])
    for s in r.solutions:
        total = sum(res["doors"] for res in s.resources)
        assert lo <= total <= lo + width


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees(), st.integers(1, 5), st.sampled_from([0, 1, 2, 3, 41, 10**6]),
       st.sampled_from([40.0, 1e20, 1e300]))
def test_an_upper_bound_past_reach_means_no_bound(d, k, lo, hi):
    """"doors = [lo, 1e20]" (no limit, as a user writes it) is clipped to what the
    stages can reach: exact as enumeration, and its shares stay few (it was refused as
    10^20 ways to share the total), none from a minimum of zero (every filling meets
    it); a minimum past reach is infeasible at once."""
    from citysynth.solver.structures.solve import _global_grid
    hi = max(hi, 1e20) if lo > hi else hi
    d = {**d, "constraints": {"doors": [lo, hi]}}
    expected = enumerate_structure(d, k)
    st_ = Structure.from_dict(d)
    if lo > 40:   # at most 5 stages of at most 8 m, a door a metre
        r = solve_structure(st_, k)
        assert expected == [] and r.status == "infeasible" and r.solutions == []
        return
    names, qs, los, his = _global_grid(st_)
    if lo <= 0:     # every filling meets it: left out of the search
        assert names == []
    else:
        assert his[0] * qs[0] <= 40   # at most 5 stages of at most 8 m, a door a metre
    r = solve_structure(st_, k)
    assert [s.cost for s in r.solutions] == pytest.approx(expected[:k])
    for s in r.solutions:
        assert sum(res["doors"] for res in s.resources) >= lo


@pytest.mark.parametrize("method", ["auto", "decompose"])
def test_an_infeasible_structure_names_its_blocked_stage_as_data(method):
    """The stage no filling fits is named as data (index, text, the stage diagnosis's
    details), the same stage and constraint the reason's text names."""
    d = {"resources": ["length", "doors"],
         "elements": [{"id": "w", "resources": {"length": 2.0, "doors": 0}},
                      {"id": "d", "resources": {"length": 2.0, "doors": 1}},
                      {"id": "k", "resources": {}, "legs": [{"length": 1.0}, {"length": 1.0}]}],
         "transitions": [[a, b, 1.0] for a in "wdk" for b in "wdk"],
         "keypoints": [{"elements": ["k"]}] * 3,
         "stages": [{"constraints": {"length": [6, 6]}},
                    {"constraints": {"length": [6, 6], "doors": [5, 5]}}],
         "closed": False}
    r = solve_structure(Structure.from_dict(d), 2, method=method)
    assert r.status == "infeasible" and r.blocked is not None
    assert r.blocked.stage == 1 and r.blocked.text in (r.reason or "")
    (detail,) = r.blocked.details
    assert detail["constraint"] == "doors" and detail["asked"] == [5, 5]
    assert detail["blocks"] == "alone" and detail["nearest_below"] == 2
