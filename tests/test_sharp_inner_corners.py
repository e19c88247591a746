"""A sharp inner corner (a narrow slot cut into a building, a concave joint of a few
tens of degrees) next to a wing no deeper than the slot's modules: the module at
the slot's tip is extended past the corner up to the joint's plane, 30 m and more at
such an angle, and ran on through the wing and out of its far wall into the street (a
Helsinki building, feature 61, had a 13 m blade standing out of its east wall). Now
an extension that runs out through a facade stops just behind it
(export/place.py, ``_Placer._stop_at_facades``)."""

from __future__ import annotations

from pathlib import Path

import pytest
import shapely

from citysynth.export.audit import audit_usd, footprint, instance_triangles
from citysynth.skeletons.geojson import lonlat_from_local
from tests.footprint_build import DEPTH, build_feature, helsinki_feature

ORIGIN = (24.94, 60.17)


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
    usd, lay = build_feature(tmp_path, feature)
    a = audit_usd(usd, lay["structures"], DEPTH)
    past = outside(usd, shapely.Polygon(ring))
    print(f"\nbeyond {a.beyond_max:.2f} m, {past:.1f} m² more than 1 m outside, overlap "
          f"{a.overlap:.1f} m², band gap {a.band_gap:.1f} of {a.band:.1f} m²")
    assert a.beyond_max <= 0.7                 # a cornice's overhang, no wall
    assert past <= 0.5


def test_helsinki_feature_61_stays_inside(tmp_path):
    """The shipped Helsinki footprints' feature 61, where the blade was seen."""
    usd, lay = build_feature(tmp_path, helsinki_feature(61))
    a = audit_usd(usd, lay["structures"], DEPTH)
    print(f"\nbeyond {a.beyond_max:.2f} m")
    assert a.beyond_max <= 0.7
