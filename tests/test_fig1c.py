"""The paper's Fig. 1(c), 5 and 6 from the command line: the shipped ring with wings
(``examples/skeletons/ring_with_wings.geojson``: a courtyard ring, a wing out of each
side, one wing with a T of its own) builds in both sample styles, and its k = 3 best
layouts differ next to a T junction."""

from __future__ import annotations

import json

import pytest

from citysynth import examples
from citysynth.export.usd import validate
from citysynth.pipeline.cli import main

RING = examples.ROOT / "skeletons" / "ring_with_wings.geojson"


def _t_neighbourhoods(structure: dict) -> list[tuple]:
    """Per T key point: its part and the parts right beside it on each of its stages."""
    out = []
    for j, key in enumerate(structure["keys"]):
        if key["kind"] != "t_junction":
            continue
        beside = []
        for st in structure["stages"]:
            if st["from"] == j:
                beside.append(st["parts"][1])
            if st["to"] == j:
                beside.append(st["parts"][-2])
        out.append((key["part"], *beside))
    return out


@pytest.mark.parametrize("style", ["classic", "modern"])
def test_ring_with_nested_t_builds_and_its_k_best_vary_at_a_t(tmp_path, style):
    assert main(["building", str(RING), "--library", str(examples.SAMPLE_LIBRARY),
                 "--style", style, "--k", "3", "--no-preview", "-o", str(tmp_path)]) == 0
    lays = [json.loads((tmp_path / f"ring_with_wings_{r}.layout.json").read_text())
            for r in (1, 2, 3)]
    st = [lay["structures"][0] for lay in lays]
    assert all(len(lay["structures"]) == 1 for lay in lays)       # one structure
    kinds = [k["kind"] for k in st[0]["keys"]]
    assert kinds.count("t_junction") == 5                           # four wings, one nested
    costs = [lay["cost"] for lay in lays]
    assert costs == sorted(costs)
    first = _t_neighbourhoods(st[0])
    assert any(_t_neighbourhoods(s) != first for s in st[1:]), "k best identical at every T"
    for r in (1, 2, 3):
        assert validate(tmp_path / f"ring_with_wings_{r}.usda") == []
