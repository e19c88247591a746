"""A sharp inner corner (a narrow slot cut into a building, a concave joint of a few
tens of degrees) next to a wing no deeper than the slot's modules: the module at
the slot's tip is extended past the corner up to the joint's plane, 30 m and more at
such an angle, and ran on through the wing and out of its far wall into the street (a
Helsinki building, feature 61, had a 13 m blade standing out of its east wall). Now
an extension that runs out through a facade stops just behind it
(export/place.py, ``_Placer._stop_at_facades``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import shapely

from citysynth.export.audit import audit_usd, footprint, instance_triangles
from citysynth.pipeline.cli import main
from citysynth.skeletons.geojson import lonlat_from_local

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
DEPTH = 14.0             # the sample library's building depth
ORIGIN = (24.94, 60.17)


def build(tmp_path: Path, features: list[dict]) -> Path:
    fp = tmp_path / "b.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    cfg = tmp_path / "c.toml"
    cfg.write_text('k = 1\npick = "best"\n')
    out = tmp_path / "run"
    assert main(["city", "--footprints", str(fp), "--library", str(LIB), "-o", str(out),
                 "--config", str(cfg), "--workers", "1", "--no-overview"]) == 0
    return out


def outside(usd: Path, outline) -> float:
    """Plan area of the building's mass more than 1 m outside its outline (m²)."""
    feet = [footprint(t) for t in instance_triangles(usd).values()]
    return shapely.union_all(feet).difference(
        outline.buffer(1.0, join_style="mitre")).area


@pytest.mark.parametrize("ring", [
    # a 45 degree notch whose tip lies 16 m from the east wall: the tip module itself
    # stands clear of the east wing's 14 m, its extension (34 m) does not
    [(0, 0), (36, 0), (36, 40), (4, 40), (20, 24), (0, 24)],
    # a 40 degree notch, 20 m from the east wall
    [(0, 0), (40, 0), (40, 40), (1, 40), (20, 24), (0, 24)],
], ids=["45deg", "40deg"])
def test_notch_tip_does_not_run_out_of_the_far_wall(tmp_path, ring):
    feature = {"type": "Feature", "properties": {"id": "slot", "building:levels": "4"},
               "geometry": {"type": "Polygon",
                            "coordinates": [lonlat_from_local(ring + ring[:1], ORIGIN)]}}
    out = build(tmp_path, [feature])
    ((bid, rec),) = json.loads((out / "manifest.json").read_text())["blocks"].items()
    assert rec["status"] == "built", rec
    usd = out / "blocks" / f"{bid}.usda"
    lay = json.loads((out / "blocks" / f"{bid}.layout.json").read_text())
    a = audit_usd(usd, lay["structures"], DEPTH)
    past = outside(usd, shapely.Polygon(ring))
    print(f"\nbeyond {a.beyond_max:.2f} m, {past:.1f} m² more than 1 m outside, overlap "
          f"{a.overlap:.1f} m², band gap {a.band_gap:.1f} of {a.band:.1f} m²")
    assert a.beyond_max <= 0.7                 # a cornice's overhang, no wall
    assert past <= 0.5


def test_helsinki_feature_61_stays_inside(tmp_path):
    """The shipped Helsinki footprints' feature 61, where the blade was seen."""
    src = json.loads((ROOT / "examples" / "city" / "district_buildings.geojson").read_text())
    out = build(tmp_path, [src["features"][61]])
    ((bid, rec),) = json.loads((out / "manifest.json").read_text())["blocks"].items()
    assert rec["status"] == "built", rec
    lay = json.loads((out / "blocks" / f"{bid}.layout.json").read_text())
    a = audit_usd(out / "blocks" / f"{bid}.usda", lay["structures"], DEPTH)
    print(f"\nbeyond {a.beyond_max:.2f} m")
    assert a.beyond_max <= 0.7
