"""Complex buildings (issue 13, item 3): T junctions whose wing leaves on the street side
of the main line (a courtyard ring facing out, with a wing going out) and T junctions
whose branches meet another T (an H, a ladder). From the command line each builds, its
layout meets every stage length within the stage's interval, its USD validates and it
meets the 3D audit's bar."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from citysynth import examples
from citysynth.export.usd import validate
from citysynth.pipeline.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_audit import _audit, _failures  # noqa: E402

SKELETONS = examples.ROOT / "skeletons"


def _build(tmp_path: Path, name: str, style: str, k: int = 1) -> list[dict]:
    assert main(["building", str(SKELETONS / f"{name}.geojson"), "--library",
                 str(examples.SAMPLE_LIBRARY), "--style", style, "--k", str(k),
                 "--no-preview", "-o", str(tmp_path)]) == 0
    suffix = [""] if k == 1 else [f"_{r}" for r in range(1, k + 1)]
    return [json.loads((tmp_path / f"{name}{s}.layout.json").read_text()) for s in suffix]


def _check_layout(tmp_path: Path, lay: dict, sample_db, name: str) -> None:
    """Every stage's parts meet its length interval, the USD validates, the audit's bar
    holds."""
    for st in lay["structures"]:
        for stage in st["stages"]:
            lo, hi = stage["asked"]["length"]
            assert lo - 1e-9 <= stage["met"]["length"] <= hi + 1e-9
            assert abs(stage["stretch"] - 1.0) <= (hi - lo) / 2 / stage["length"] + 1e-6
    usd = tmp_path / f"{name}.usda"
    assert validate(usd) == []
    assert _failures(*_audit(tmp_path / f"{name}.layout.json", sample_db)) == []


@pytest.mark.parametrize("style", ["classic", "modern"])
def test_outward_ring_with_a_wing_into_the_street(tmp_path, style, sample_db):
    """Facades facing out, one wing out into the street (its T turned over) and one into
    the courtyard (behind the facade, as T parts are made)."""
    (lay,) = _build(tmp_path, "ring_outward_wings", style)
    (st,) = lay["structures"]
    poses = sorted(k.get("pose", "") for k in st["keys"] if k["kind"] == "t_junction")
    assert poses == ["", "swap+street"]
    _check_layout(tmp_path, lay, sample_db, "ring_outward_wings")
