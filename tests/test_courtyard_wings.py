"""A building round a courtyard whose wings are narrower than two building depths
(export/place.py, ``_Placer.medial_against``): the courtyard's facades and the
outline's meet in the middle of each wing, corners split on their bisector, instead of
running 14 m deep through each other and out of the far wall into the street (the
audit measured 8.8 m beyond and 890 m² shared on a Helsinki building before).

The audit (export/audit.py) now bounds a courtyard's band by the outline round it, so
it sees geometry past the outer wall as beyond.

Where wings of two widths meet at a courtyard corner, a module's medial plane against
the other ring's facade (its infinite line, past that facade's end) took off a
triangle no module covered, and the roof opened there: 7.7 m² on the square building,
31.9 m² on the skewed one, 243 m² on Helsinki's feature 23. Such a plane is now given
back (``export/place.py``, ``_reopen``), also behind a side only two corner parts
build (11 m² on feature 8)."""

from __future__ import annotations

from pathlib import Path

import pytest

from citysynth.export.audit import audit_usd
from citysynth.skeletons.geojson import lonlat_from_local
from tests.footprint_build import DEPTH, build_feature, helsinki_feature


def build(tmp_path: Path, outer, yard) -> tuple[Path, dict]:
    rings = [lonlat_from_local(r + r[:1], (24.94, 60.17)) for r in (outer, yard)]
    return build_feature(tmp_path, {
        "type": "Feature", "properties": {"id": "yard", "building:levels": "4"},
        "geometry": {"type": "Polygon", "coordinates": rings}})


@pytest.mark.parametrize("outer, yard", [
    # 8 m wings all round a 24 x 17.5 m courtyard
    ([(0, 0), (40, 0), (40, 33.5), (0, 33.5)], [(8, 8), (32, 8), (32, 25.5), (8, 25.5)]),
    # a skewed outline, wings of 7-11 m
    ([(0, 0), (44, 3), (42, 38), (-2, 35)], [(9, 10), (33, 11), (32, 27), (8, 26)]),
], ids=["square", "skewed"])
def test_narrow_wings_stay_inside_the_outline(tmp_path, outer, yard):
    usd, lay = build(tmp_path, outer, yard)
    assert len(lay["structures"]) == 2
    a = audit_usd(usd, lay["structures"], DEPTH)
    print(f"\nfootprint {a.footprint:.1f} m², overlap {a.overlap:.2f} m², beyond "
          f"{a.beyond_max:.2f} m, band gap {a.band_gap:.2f} of {a.band:.1f} m²")
    assert a.beyond_max <= 0.7                # a cornice's overhang, no wall
    assert a.overlap <= 0.005 * a.footprint   # the audit's bar (tests/test_audit.py)
    assert a.band_gap <= 0.002 * a.band       # no triangle where wings of two widths meet


@pytest.mark.parametrize("feature, gap_before, share, shared", [
    (23, 243.3, 0.7, 0.005), (25, 172.4, 0.7, 0.005),
    # an 11 m² triangle behind a side made only of two corner parts (no module): the
    # building's ground there is as deep as the corners' legs, not zero. (Its 32 m² of
    # shared ground, 1.4 %, where three courtyards' wings meet, is older.)
    (8, 95.4, 0.92, 0.015)])
def test_helsinki_courtyard_roofs_close(tmp_path, feature, gap_before, share, shared):
    """Shipped Helsinki footprints with courtyards whose roofs were open where wings of
    two widths meet (the band gap the audit measured before, m²; ``share`` of it may
    stay: deep-plan ground no module reaches is not these triangles; ``shared``: the
    share of the footprint two instances may share)."""
    usd, lay = build_feature(tmp_path, helsinki_feature(feature))
    a = audit_usd(usd, lay["structures"], DEPTH)
    print(f"\nfeature {feature}: overlap {a.overlap:.2f} m², beyond {a.beyond_max:.2f} m, "
          f"band gap {a.band_gap:.1f} of {a.band:.1f} m² (was {gap_before})")
    assert a.band_gap <= share * gap_before
    assert a.overlap <= shared * a.footprint
    assert a.beyond_max <= 0.7


def test_only_structures_within_reach_are_cut_against_each_other(tmp_path, monkeypatch):
    """A footprint of nine courtyards: each structure's modules are cut against another
    structure's masses only where their bounding boxes meet (``_medial_between``), and
    the layout is byte for byte the one every pair gave. 361 courtyards made 130,000
    pairs, each building its masses again, for minutes."""
    import itertools

    from citysynth.export import place

    outer = [(0, 0), (124, 0), (124, 124), (0, 124)]
    yards = [[(x, y), (x + 18, y), (x + 18, y + 18), (x, y + 18)]
             for x in (14, 53, 92) for y in (14, 53, 92)]
    rings = [lonlat_from_local(r + r[:1], (24.94, 60.17)) for r in (outer, *yards)]
    feature = {"type": "Feature", "properties": {"id": "yards", "building:levels": "4"},
               "geometry": {"type": "Polygon", "coordinates": rings}}
    calls: list[int] = []
    against = place._Placer.medial_against

    def counted(self, other):
        calls.append(1)
        return against(self, other)
    monkeypatch.setattr(place._Placer, "medial_against", counted)
    _usd, some = build_feature(tmp_path / "some", feature)
    pairs = len(calls)

    def every_pair(placers, db):
        for a, b in itertools.permutations(placers, 2):
            a.medial_against(b)
    monkeypatch.setattr(place, "_medial_between", every_pair)
    calls.clear()
    _usd, every = build_feature(tmp_path / "every", feature)
    assert some == every
    assert pairs <= 0.7 * len(calls), (pairs, len(calls))      # 58 of 90
