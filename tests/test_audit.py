"""The 3D audit of assembled layouts (issue 11): what an artist sees, measured from the
written USD composed by usd-core with every instance resolved to world space.

What holds today, kept from regressing: the demo's T building and block have no part
overlapping another and no coplanar overlapping roofs; over the demo district, part
overlap stays under 0.5 % of the footprint (3.06 % with the old two-end-part mitres)
and coplanar roofs under 0.5 % of it. The issue's full bar (per block, nothing past
the outline by more than 0.3 m, roof-band gaps under 1 %) is not met on every block yet:
narrow block ends and sharp concave corners still leave gaps and reach past the line.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from citysynth.export.audit import audit_usd
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
CITY = ROOT / "examples" / "city"

MAX_OVERLAP = 0.005      # of the footprint
MAX_COPLANAR = 0.005     # of the footprint


def _depth(layout: dict, db) -> float:
    """The shallowest facade module's depth: the roof band every block must fill."""
    parts = {p.id: p for p in db.parts}
    return min(-parts[i["part"]].sec_in.bounds[0] for i in layout["instances"]
               if i["class"] == "middle")


def _audit(layout_path: Path, db):
    lay = json.loads(layout_path.read_text())
    usd = layout_path.with_name(layout_path.name.replace(".layout.json", ".usda"))
    return lay["name"], audit_usd(usd, lay["structures"], _depth(lay, db))


@pytest.fixture(scope="module")
def demo_buildings(tmp_path_factory, sample_db):
    out = tmp_path_factory.mktemp("audit_demo")
    assert main(["building", str(ROOT / "examples" / "skeletons" / "t_building.geojson"),
                 "--library", str(LIB), "--style", "classic", "--k", "3", "-o", str(out),
                 "--no-preview"]) == 0
    assert main(["block", str(ROOT / "examples" / "blocks" / "block.geojson"),
                 "--library", str(LIB), "--style", "modern", "-o", str(out),
                 "--no-preview"]) == 0
    return out


def test_demo_building_and_block_have_no_overlaps(demo_buildings, sample_db):
    paths = sorted(demo_buildings.glob("*.layout.json"))
    assert len(paths) == 4
    for p in paths:
        name, a = _audit(p, sample_db)
        assert a.footprint > 500 and a.band > 500, f"{name}: {a.line()}"
        assert a.overlap_share < MAX_OVERLAP, f"{name}: {a.line()}"
        assert a.coplanar_roof < MAX_COPLANAR * a.footprint, f"{name}: {a.line()}"


def test_district_blocks_meet_without_overlapping(tmp_path, sample_db):
    assert main(["city", "--streets", str(CITY / "district_streets.geojson"), "--config",
                 str(CITY / "city.toml"), "-o", str(tmp_path), "--no-overview"]) in (0, 1)
    paths = sorted((tmp_path / "blocks").glob("*.layout.json"))
    assert len(paths) >= 20
    audits = [_audit(p, sample_db)[1] for p in paths]
    footprint = sum(a.footprint for a in audits)
    assert sum(a.overlap for a in audits) < MAX_OVERLAP * footprint
    assert sum(a.coplanar_roof for a in audits) < MAX_COPLANAR * footprint
    # every joint is a clean mitre or a nose: no end part stands at a corner any more
    for p in paths:
        for st in json.loads(p.read_text())["structures"]:
            for k in st["keys"]:
                assert k["joint"] in ("part", "mitre", "nose")
                assert k["kind"] != "corner" or "end_" not in k["part"]
