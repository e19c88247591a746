"""Footprints that overlap (pipeline/city/overlaps.py): each piece of ground gets one
building's facades. A tower mapped inside its building is left out and told; a
neighbour whose shared wall was drawn past the other's is trimmed to the ground left,
with a note; a wall shared exactly and an outline drawn twice are as before."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest
import shapely

from citysynth.pipeline.city.config import parse_config
from citysynth.pipeline.city.overlaps import TOUCH
from citysynth.pipeline.city.run import prepare
from citysynth.pipeline.cli import main
from citysynth.skeletons.geojson import lonlat_from_local

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
HELSINKI = ROOT / "examples" / "city" / "district_buildings.geojson"
ORIGIN = (24.94, 60.17)

SCENE = {   # local metres
    "hall": [(0, 0), (30, 0), (30, 20), (0, 20)],
    "tower": [(10, 5), (18, 5), (18, 13), (10, 13)],          # inside the hall
    "east": [(29.7, 0), (49.7, 0), (49.7, 20), (29.7, 20)],    # 0.3 m into the hall
    "north": [(0, 20), (30, 20), (30, 35), (0, 35)],           # shares a wall exactly
}


def write(path: Path, names: list[str]) -> Path:
    feats = [{"type": "Feature", "properties": {"id": n},
              "geometry": {"type": "Polygon",
                           "coordinates": [lonlat_from_local(SCENE[n] + SCENE[n][:1],
                                                             ORIGIN)]}}
             for n in names]
    path.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    return path


def outlines(fp: Path):
    inputs = prepare(None, fp, parse_config({"k": 1}), LIB)
    return inputs, {j.footprint.ref: shapely.from_wkt(j.wkt) for j in inputs.jobs}


def worst_overlap(polys) -> float:
    return max((a.intersection(b).area for a, b in itertools.combinations(polys, 2)),
               default=0.0)


def test_a_building_drawn_twice_5_mm_apart_is_told_as_it_is(tmp_path):
    """Two drawings of one building 5 mm apart: the second was "100 % of it lies inside
    feature 0, larger and built", neither all of it nor larger."""
    SCENE["hall_again"] = [(x + 0.005, y) for x, y in SCENE["hall"]]
    try:
        fp = write(tmp_path / "twice.geojson", ["hall", "hall_again"])
        inputs, built = outlines(fp)
    finally:
        del SCENE["hall_again"]
    assert len(built) == 1        # which one: the larger by a float's last digits
    (skip,) = [s["reason"] for s in inputs.skipped]
    assert ": 99.9" in skip and " % of it lies inside feature " in skip \
        and ", as large and kept" in skip, skip


def test_a_tower_inside_is_left_out_and_a_neighbour_drawn_over_is_trimmed(tmp_path):
    fp = write(tmp_path / "scene.geojson", list(SCENE))
    inputs, built = outlines(fp)
    assert sorted(built) == ["east", "hall", "north"]
    (skip,) = [s["reason"] for s in inputs.skipped]
    assert skip == (f"{fp}: feature 1 (tower): all of it lies inside feature 0 (hall), "
                    "larger and kept; left out (a part of that building, or the same "
                    "building drawn twice)")
    # the larger is whole, the exact neighbour untouched, the other trimmed to the wall
    assert built["hall"].area == pytest.approx(600, abs=0.05)
    assert built["north"].area == pytest.approx(450, abs=0.05)
    assert built["east"].area == pytest.approx(394, abs=0.05)
    assert built["east"].bounds[0] == pytest.approx(30, abs=0.01)
    assert worst_overlap(list(built.values())) <= TOUCH
    (east,) = [j for j in inputs.jobs if j.footprint.ref == "east"]
    assert east.footprint.trimmed == (f"{fp}: feature 2 (east): trimmed by 6.00 m² where "
                                      "it overlapped feature 0 (hall), larger and kept whole")


def test_the_rule_does_not_depend_on_the_order_of_the_file(tmp_path):
    a, _ = outlines(write(tmp_path / "a.geojson", list(SCENE)))
    b, _ = outlines(write(tmp_path / "b.geojson", list(reversed(SCENE))))
    assert sorted(j.wkt for j in a.jobs) == sorted(j.wkt for j in b.jobs)


def test_every_outline_drawn_hundreds_of_times_gives_the_same_city(tmp_path):
    """The scene with each footprint given 400 times (a broken export, or a file
    concatenated with itself): the same outlines are built, each once; every copy of
    the tower is left out inside the hall; every other copy is built once and told so.
    (Copies of one outline are told apart by number before their overlaps are
    measured: 20,000 copies of one took 82 s in a Python loop, now 10.)"""
    copies = 400
    feats = [{"type": "Feature", "properties": {"id": f"{n} {c}"},
              "geometry": {"type": "Polygon", "coordinates": [
                  lonlat_from_local(SCENE[n] + SCENE[n][:1], ORIGIN)]}}
             for c in range(copies) for n in SCENE]
    fp = tmp_path / "copies.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    inputs, built = outlines(fp)
    _once, alone = outlines(write(tmp_path / "scene.geojson", list(SCENE)))
    assert sorted(built) == ["east 0", "hall 0", "north 0"]
    assert {n.split()[0]: b.wkt for n, b in built.items()} == \
        {n: b.wkt for n, b in alone.items()}
    reasons = [s["reason"] for s in inputs.skipped]
    assert len(reasons) == 4 * copies - 3
    assert sum("(tower " in r and "lies inside feature 0 (hall 0)" in r
               for r in reasons) == copies
    assert sum("the same outline as" in r for r in reasons) == 3 * (copies - 1)


def test_copies_of_an_outline_that_grows_to_its_neighbour_are_built_once(tmp_path,
                                                                         monkeypatch):
    """A house drawn 0.1 m from a larger one, given 30 times: the first copy grows to
    meet its neighbour, and every copy takes that outline, so the house is built once
    and the copies told as such. Each copy was checked against every other in the gap
    and party-wall steps (800 copies of a Helsinki footprint: 264 s, growing as the
    cube of their number), and a copy could not grow over its grown first: it was
    built as a second house, overlapping the first."""
    from citysynth.pipeline.city import gaps

    shapes = {"big": [(0, 0), (30, 0), (30, 20), (0, 20)],
              "small": [(30.1, 0), (45, 0), (45, 14), (30.1, 14)]}
    copies = 30
    feats = [{"type": "Feature", "properties": {"id": f"{n} {c}"},
              "geometry": {"type": "Polygon", "coordinates": [
                  lonlat_from_local(shapes[n] + shapes[n][:1], ORIGIN)]}}
             for n in shapes for c in range(1 if n == "big" else copies)]
    fp = tmp_path / "copies.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    seen: list[int] = []
    closed = gaps.closed_gaps
    monkeypatch.setattr(gaps, "closed_gaps", lambda s: seen.append(len(s)) or closed(s))
    inputs, built = outlines(fp)
    assert seen == [2]                        # one footprint per distinct outline
    assert sorted(built) == ["big 0", "small 0"]
    assert built["small 0"].bounds[0] == pytest.approx(30.0, abs=0.01)   # grown to meet
    assert worst_overlap(list(built.values())) <= TOUCH
    reasons = [s["reason"] for s in inputs.skipped]
    assert sum("the same outline as feature 1 (small 0)" in r for r in reasons) == copies - 1


def test_the_trim_is_told_in_the_blocks_note(tmp_path):
    fp = write(tmp_path / "pair.geojson", ["hall", "east"])
    cfg = tmp_path / "run.toml"
    cfg.write_text('k = 1\npick = "best"\n')
    assert main(["city", "--footprints", str(fp), "--library", str(LIB), "-o",
                 str(tmp_path / "run"), "--config", str(cfg), "--workers", "1",
                 "--no-overview"]) == 0
    blocks = json.loads((tmp_path / "run" / "manifest.json").read_text())["blocks"]
    notes = [r.get("note", "") for r in blocks.values()]
    assert all(r["status"] == "built" for r in blocks.values()), blocks
    assert sum("trimmed by 6.00 m² where it overlapped feature 0 (hall)" in n
               for n in notes) == 1, notes


def test_helsinki_footprints_share_no_ground():
    """The shipped district: the cathedral's towers (features 265-266, mapped as
    churches inside it) and a wing inside the university's main building are left out;
    two neighbours drawn into theirs are trimmed; no two built footprints overlap."""
    inputs = prepare(None, HELSINKI, parse_config({"k": 1}), LIB)
    polys = [shapely.from_wkt(j.wkt) for j in inputs.jobs]
    tree = shapely.STRtree(polys)
    pairs = [(i, j) for i, j in zip(*tree.query(polys, predicate="intersects"), strict=True)
             if i < j]
    worst = max(polys[i].intersection(polys[j]).area for i, j in pairs)
    print(f"\nworst overlap of two built Helsinki footprints: {worst:.4f} m²")
    assert worst <= TOUCH
    inside = sorted(s["reason"].split(": ")[1] for s in inputs.skipped
                    if "lies inside" in s["reason"])
    assert inside == ["feature 157", "feature 265", "feature 266"]
    trimmed = sorted(j.footprint.feature for j in inputs.jobs if j.footprint.trimmed)
    assert trimmed == [14, 86]


def test_a_multipolygon_whose_parts_overlap_is_one_building(tmp_path):
    """Two overlapping parts of one MultiPolygon feature (invalid, but hand-drawn data
    has them) were two footprints: the smaller "50 % of it lies inside feature 0",
    itself, and half the building was dropped. They are built as their union."""
    parts = [SCENE["hall"], [(15, 10), (45, 10), (45, 30), (15, 30)]]
    fp = tmp_path / "multi.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {"id": "hall"},
        "geometry": {"type": "MultiPolygon", "coordinates": [
            [lonlat_from_local(p + p[:1], ORIGIN)] for p in parts]}}]}))
    inputs, built = outlines(fp)
    assert not inputs.skipped
    assert sorted(built) == ["hall"]
    assert built["hall"].area == pytest.approx(600 + 600 - 15 * 10, abs=0.1)
