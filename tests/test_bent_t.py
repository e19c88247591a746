"""A T junction whose main line bends where the wing meets it: digitised footprints and
building lines rarely run dead straight through a junction. A T part is rigid, its main
legs collinear, so it missed the far side by its leg times the bend and the command
failed with an internal message ("stage 1: parts do not meet at (15.79, -19.72), 14.9
mm apart" at 0.05 degrees, 792 mm at 3). The part is now placed twice, each copy on its
own side of the wing (export/place.py, ``_Placer._place_t``): both main facades lie on
the skeleton, and a bend of a few degrees meets the 3D audit's bar either way the main
line runs, the wing leaves and the line bends. A T whose wing leaves off the square is
sheared to it, and the modules next to its ends are cut to its end faces."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

from citysynth.pipeline.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_audit import LIB, _audit, _failures  # noqa: E402

ORIGIN = (391000.0, 5820000.0)   # EPSG:25833 (UTM 33N), in Berlin


def _t_file(tmp_path: Path, bend: float, wing_side: int, reverse: bool) -> Path:
    """A T: a 63 m main line bending ``bend`` degrees at its middle, where a wing
    leaves on ``wing_side`` (+1: left of the first half) and turns after 40 m."""
    a = math.radians(bend)
    main_line = [(0.0, 0.0), (31.5, 0.0), (31.5 + 31.5 * math.cos(a), 31.5 * math.sin(a))]
    if reverse:
        main_line.reverse()
    wing = [(31.5, 0.0), (31.5, 40.0 * wing_side), (63.0, 40.0 * wing_side)]

    return _lines_file(tmp_path / f"t_{bend:g}_{wing_side}_{int(reverse)}.geojson",
                       main_line, wing)


def _lines_file(src: Path, main_line: list[tuple[float, float]],
                wing: list[tuple[float, float]]) -> Path:
    """The main line and the wing (local metres about ORIGIN) as a GeoJSON file."""
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": name}, "geometry": {
            "type": "LineString",
            "coordinates": [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in line]}}
        for name, line in (("front", main_line), ("wing", wing))]}))
    return src


def _build(tmp_path: Path, src: Path, style: str) -> tuple[int, Path]:
    out = tmp_path / src.stem
    code = main(["building", str(src), "--library", str(LIB), "--style", style,
                 "--crs", "EPSG:25833", "-o", str(out), "--no-preview"])
    return code, out / f"{src.stem}.layout.json"


@pytest.mark.parametrize("bend,wing_side,reverse,style", [
    (0.05, 1, False, "classic"),
    (3.0, 1, False, "classic"), (3.0, -1, False, "modern"),
    (-3.0, 1, False, "modern"), (-3.0, 1, True, "classic"),
    (3.0, 1, True, "modern"), (3.0, -1, True, "classic"),
])
def test_a_t_bending_at_its_wing_builds_and_meets_the_audit_bar(
        tmp_path, sample_db, bend, wing_side, reverse, style):
    code, layout = _build(tmp_path, _t_file(tmp_path, bend, wing_side, reverse), style)
    assert code == 0
    lay = json.loads(layout.read_text())
    ts = [i for i in lay["instances"] if i["class"] == "t_junction"]
    assert len(ts) == 2 and ts[0]["part"] == ts[1]["part"]     # one part, both sides
    assert all(i["cut"]["planes"] for i in ts)
    name, a = _audit(layout, sample_db)
    assert not _failures(name, a)


def test_a_bend_under_a_t_leg_builds_and_meets_the_audit_bar(tmp_path, sample_db):
    """A 3 degree bend 6 m along the main line from the junction, under the T's leg
    (15.8-21 m in the sample library): it failed with "parts do not meet ... 514.7 mm
    apart"."""
    a = math.radians(3.0)
    main_line = [(0.0, 0.0), (31.5, 0.0), (37.5, 0.0),
                 (37.5 + 25.5 * math.cos(a), 25.5 * math.sin(a))]
    wing = [(31.5, 0.0), (31.5, -40.0), (63.0, -40.0)]
    src = _lines_file(tmp_path / "bend_under_leg.geojson", main_line, wing)
    code, layout = _build(tmp_path, src, "classic")
    assert code == 0
    name, audit = _audit(layout, sample_db)
    assert not _failures(name, audit)


def test_a_bend_under_the_leg_of_the_copy_turned_onto_it_lands_on_the_skeleton(
        tmp_path, sample_db):
    """A 0.05 degree bend at the junction and a 9.8 degree one 5 m along the other half
    (a helper's fuzzing found it): the copy turned onto that half spanned its leg's full
    length, and the skeleton's point that far along is a chord 2.4 mm nearer, past the
    checks' 1 mm ("stage 0: parts do not meet ... 2.4 mm apart"). It builds, and the
    leg is folded at the bend: it spanned it as a chord, up to 0.6 m off the skeleton
    (the audit's "beyond")."""
    a, b = math.radians(9.8), math.radians(0.05)
    west = [(26.5 - 26.5 * math.cos(a), -26.5 * math.sin(a)), (26.5, 0.0)]
    main_line = [*west, (31.5, 0.0), (31.5 + 31.5 * math.cos(b), 31.5 * math.sin(b))]
    w = math.radians(85.0)
    end = (31.5 + 40 * math.cos(w), -40 * math.sin(w))
    src = _lines_file(tmp_path / "bend_near.geojson", main_line,
                      [(31.5, 0.0), end, (end[0] + 31.5, end[1])])
    code, layout = _build(tmp_path, src, "modern")
    assert code == 0
    name, audit = _audit(layout, sample_db)
    assert not _failures(name, audit)


def test_a_straight_t_is_one_part_uncut(tmp_path):
    code, layout = _build(tmp_path, _t_file(tmp_path, 0.0, 1, False), "classic")
    assert code == 0
    ts = [i for i in json.loads(layout.read_text())["instances"]
          if i["class"] == "t_junction"]
    assert len(ts) == 1 and "cut" not in ts[0]


def test_a_sharper_bend_builds_with_no_ground_doubled(tmp_path, sample_db):
    """At 10 degrees the copy holding the wing is sheared by the bend, as a T whose wing
    leaves at 80 degrees is; the modules next to its ends meet its end faces, so no
    ground is doubled (it was 0.66 % and 1.98 % of the footprint) and the bar is met."""
    for bend, side, reverse, style in ((10.0, -1, False, "classic"),
                                       (-10.0, -1, True, "modern")):
        code, layout = _build(tmp_path, _t_file(tmp_path, bend, side, reverse), style)
        assert code == 0
        name, a = _audit(layout, sample_db)
        assert a.overlap_share < 0.001 and not _failures(name, a), a.line()


@pytest.mark.parametrize("angle,wing_side,style", [
    (80.0, 1, "classic"), (80.0, -1, "modern"), (100.0, 1, "modern")])
def test_a_t_whose_wing_leaves_off_the_square_meets_the_audit_bar(
        tmp_path, sample_db, angle, wing_side, style):
    """A wing leaving its main line at 80 or 100 degrees: the T part is sheared to it,
    its leg ends run along the wing and its wing's end along the main line, and the
    module next to each end was square, leaving wedges (at 80 degrees 0.62-1.70 % of
    the footprint doubled, 0.83-1.63 % of the roof band open; at 60 degrees up to 4.5 %
    and 6.9 %). Each is now cut and extended to the T's end face: nothing doubled, and
    at 80 and 100 degrees (one side) the bar is met."""
    a = math.radians(angle)
    end = (31.5 + 40 * math.cos(a), 40 * math.sin(a) * wing_side)
    src = _lines_file(tmp_path / f"wing_{angle:g}_{wing_side}.geojson",
                      [(0.0, 0.0), (31.5, 0.0), (63.0, 0.0)],
                      [(31.5, 0.0), end, (end[0] + 31.5, end[1])])
    code, layout = _build(tmp_path, src, style)
    assert code == 0
    name, audit = _audit(layout, sample_db)
    assert not _failures(name, audit)
    assert audit.overlap_share < 0.001, audit.line()


@pytest.mark.parametrize("bend,along,side,wing_side,style", [
    (10.0, 5.0, "east", -1, "classic"),     # was 0.99 % of the footprint doubled
    (-10.0, 5.0, "west", 1, "modern"),      # was 0.61 m beyond
    (15.0, 5.0, "west", 1, "classic"),      # was 1.28 % doubled
    (-10.0, 10.0, "east", 1, "classic"),    # was 0.61 m beyond
    (15.0, 5.0, "east", 1, "modern"),       # was 0.35 m beyond
])
def test_a_t_leg_over_a_sharper_bend_is_folded_there(tmp_path, sample_db, bend, along,
                                                     side, wing_side, style):
    """A bend of 10-15 degrees 5 or 10 m along a T's main leg (the sample library's
    legs are 15.8-21 m): the rigid leg spanned it as a chord, its facade up to 0.63 m
    off the skeleton or its range doubling the next module's ground (1.45 % of the
    footprint); 25 of 48 such buildings missed the audit's bar. The leg is folded at the
    bend as a module is (a copy of the T turned onto each further run, cut on the bend's
    bisector), and what of the wing the fold plane cuts off is kept by one more copy:
    all 48 meet the bar, nothing doubled."""
    a = math.radians(bend)
    if side == "east":
        main_line = [(0.0, 0.0), (31.5, 0.0), (31.5 + along, 0.0),
                     (31.5 + along + 30 * math.cos(a), 30 * math.sin(a))]
    else:
        main_line = [(31.5 - along - 30 * math.cos(a), 30 * math.sin(a)),
                     (31.5 - along, 0.0), (31.5, 0.0), (63.0, 0.0)]
    wing = [(31.5, 0.0), (31.5, 40.0 * wing_side), (63.0, 40.0 * wing_side)]
    src = _lines_file(tmp_path / f"fold_{bend:g}_{along:g}_{side}.geojson", main_line, wing)
    code, layout = _build(tmp_path, src, style)
    assert code == 0
    ts = [i for i in json.loads(layout.read_text())["instances"]
          if i["class"] == "t_junction"]
    turned = {tuple(round(v, 6) for v in i["x_axis"]) for i in ts}
    assert len(turned) == 2        # the copy at the key point and the one past the bend
    name, audit = _audit(layout, sample_db)
    assert audit.overlap_share < 0.001 and not _failures(name, audit), audit.line()



@pytest.mark.parametrize("main_line,wing,style", [
    # 3 degrees at the junction, 14 more 0.3 m past it: folded there, the fold piece
    # doubled a wedge of the other copy's range (8 m² of coplanar roof); the leg now
    # spans so near a bend as a chord
    ([(0.0, 0.0), (31.5, 0.0), (31.7996, 0.0157), (61.6363, 9.1377)],
     [(31.5, 0.0), (31.5, -40.0), (63.0, -40.0)], "modern"),
    # the same 0.5 m past: folded, and the notch between the wing and the range turned
    # away from it (16 m²) is filled by the wing's copy
    ([(0.0, 0.0), (31.5, 0.0), (31.999, 0.026), (61.645, 9.09)],
     [(31.5, 0.0), (31.5, -40.0), (63.0, -40.0)], "modern"),
    # two bends under one leg (2 m at -10 degrees, 6 m at -3): the wing past the first
    # fold was doubled by the copy past the second (1.08 m² of coplanar roof)
    ([(63.0, 0.0), (31.5, 0.0), (29.5, 0.0), (25.561, 0.695), (0.714, 6.431)],
     [(31.5, 0.0), (31.5, 40.0), (63.0, 40.0)], "modern"),
])
def test_bends_near_a_bent_junction_or_two_under_a_leg_meet_the_bar(
        tmp_path, sample_db, main_line, wing, style):
    """Shapes a helper's fuzzing of the fold found failing the bar (three of 430 runs)."""
    src = _lines_file(tmp_path / f"near_{len(main_line)}_{main_line[2][0]:g}.geojson",
                      main_line, wing)
    code, layout = _build(tmp_path, src, style)
    assert code == 0
    name, audit = _audit(layout, sample_db)
    assert audit.overlap_share < 0.001 and not _failures(name, audit), audit.line()


def test_an_h_whose_side_bends_just_past_its_bar_meets_the_bar(tmp_path, sample_db):
    """An H (an 11 m bar between two T parts) whose east line bends 10 degrees 0.5 m
    past the bar: spanned as a chord, the east T was placed twice and sheared, and its
    wing doubled the west T's (10.7 m², 0.72 % of the footprint). Where the main line
    runs straight through the junction the leg is folded at any bend, the T kept
    square."""
    a = math.radians(10.0)
    lines = {"west": [(0.0, 0.0), (0.0, 30.0), (0.0, 60.0)],
             "east": [(11.0 - 29.5 * math.sin(a), 30.5 + 29.5 * math.cos(a)), (11.0, 30.5),
                      (11.0, 30.0), (11.0, 0.0)],
             "bar": [(0.0, 30.0), (11.0, 30.0)]}
    src = tmp_path / "h_bend.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": name}, "geometry": {
            "type": "LineString",
            "coordinates": [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in line]}}
        for name, line in lines.items()]}))
    code, layout = _build(tmp_path, src, "classic")
    assert code == 0
    name, audit = _audit(layout, sample_db)
    assert audit.overlap_share < 0.001 and not _failures(name, audit), audit.line()
