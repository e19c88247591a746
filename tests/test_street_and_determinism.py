"""The sample street problem: rcksp and fgs agree, results are deterministic, and
the shipped example files match their generator."""

import json
from pathlib import Path

import pytest

from citysynth.solver import Problem, solve
from citysynth.solver.samples import street_front
from examples.make_examples import GENERATED, render

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("length, resources, k", [(20.0, 1, 10), (37.4, 1, 25),
                                                  (30.0, 3, 10)])
def test_rcksp_and_fgs_agree_on_the_street(length, resources, k):
    p = Problem.from_dict(street_front(length, resources=resources))
    a = solve(p, k=k)
    b = solve(p, k=k, method="fgs")
    assert a.status == b.status == "ok"
    assert [s.cost for s in a.solutions] == [s.cost for s in b.solutions]
    for s in a.solutions:
        assert s.resources["length"] == length
        for name, (lo, hi) in p.constraints.items():
            assert lo <= s.resources[name] <= hi


def test_hash_and_dense_rows_give_identical_results():
    p = Problem.from_dict(street_front(41.2, resources=3))
    a = solve(p, k=30, table="dense")
    b = solve(p, k=30, table="hash")
    assert [x.to_dict() for x in a.solutions] == [x.to_dict() for x in b.solutions]
    assert a.stats["nodes"] == b.stats["nodes"]


def test_same_input_same_bytes():
    p = Problem.from_dict(street_front(60.0, k=20))

    def dump():
        d = solve(p).to_dict()
        d["stats"] = {k: v for k, v in d["stats"].items() if not k.endswith("_s")}
        return json.dumps(d, sort_keys=True)

    assert dump() == dump()


@pytest.mark.parametrize("name", sorted(GENERATED))
def test_example_files_match_generator(name):
    assert (ROOT / "examples" / name).read_text(encoding="utf-8") == render(name)
