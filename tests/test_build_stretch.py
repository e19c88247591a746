"""``--stretch`` and ``--slack`` on ``citysynth building`` and ``block``: the city's
meaning (a side met within a share of its length or a number of metres, whichever is
larger, and at least half a quantum), in every shipped style."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from citysynth import examples
from citysynth.pipeline.cli import main

T_BUILDING = examples.ROOT / "skeletons" / "t_building.geojson"
BLOCK = examples.ROOT / "blocks" / "block.geojson"


def _stages(out: Path, name: str) -> list[dict]:
    lay = json.loads((out / f"{name}.layout.json").read_text())
    return [s for st in lay["structures"] for s in st["stages"]]


@pytest.mark.parametrize("style", ["classic", "modern"])
def test_stretch_widens_every_side_as_in_a_city(tmp_path, style):
    base = ["building", str(T_BUILDING), "--library", str(examples.SAMPLE_LIBRARY),
            "--style", style, "--no-preview"]
    assert main([*base, "-o", str(tmp_path / "exact")]) == 0
    assert main([*base, "--stretch", "0.02", "--slack", "0.3",
                 "-o", str(tmp_path / "loose")]) == 0
    exact = _stages(tmp_path / "exact", "t_building")
    loose = _stages(tmp_path / "loose", "t_building")
    for e, s in zip(exact, loose, strict=True):
        lo, hi = e["asked"]["length"]
        assert hi - lo == pytest.approx(0.2)           # half a quantum either side
        lo, hi = s["asked"]["length"]
        tol = max(0.1, 0.3, 0.02 * s["length"])
        assert (lo, hi) == pytest.approx((s["length"] - tol, s["length"] + tol), abs=1e-6)
        assert lo - 1e-9 <= s["met"]["length"] <= hi + 1e-9
    cost = [json.loads((tmp_path / d / "t_building.layout.json").read_text())["cost"]
            for d in ("exact", "loose")]
    assert cost[1] <= cost[0] + 1e-9                    # more room never costs more


def test_block_takes_stretch_too(tmp_path):
    assert main(["block", str(BLOCK), "--library", str(examples.SAMPLE_LIBRARY),
                 "--style", "classic", "--stretch", "0.01", "--no-preview",
                 "-o", str(tmp_path)]) == 0
    for s in _stages(tmp_path, "block"):
        lo, hi = s["asked"]["length"]
        assert hi - lo == pytest.approx(2 * max(0.1, 0.01 * s["length"]), abs=1e-6)


@pytest.mark.parametrize("opt", [["--stretch", "0.2"], ["--stretch", "-0.01"],
                                 ["--slack", "5"]])
def test_stretch_out_of_range_is_a_usage_error(tmp_path, capsys, opt):
    assert main(["building", str(T_BUILDING), "--library", str(examples.SAMPLE_LIBRARY),
                 *opt, "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--stretch is a share in [0, 0.05]" in err and "Traceback" not in err
