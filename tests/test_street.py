"""``citysynth street`` (the paper's Fig. 7): a 200 m street line filled with the sample
library's complete buildings, read back from the written layout and USD; the sample
buildings make neighbours matter; bad input and infeasible asks."""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely

from citysynth.examples import SAMPLE_LIBRARY
from citysynth.export.layout import Layout
from citysynth.export.usd import validate
from citysynth.parts_db import load_library
from citysynth.pipeline.cli import main
from citysynth.pipeline.streets import facade_line, runs

# 200 m in UTM 32N, bent by 3 degrees halfway (one run: gentle bends are followed)
BEND = math.radians(3)
COORDS = [[690000.0, 5335000.0], [690100.0, 5335000.0],
          [690100.0 + 100 * math.cos(BEND), 5335000.0 + 100 * math.sin(BEND)]]


def _line_file(path: Path, coords=COORDS, kind="LineString") -> Path:
    path.write_text(json.dumps({
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::25832"}},
        "features": [{"type": "Feature", "properties": {"name": "main"},
                      "geometry": {"type": kind, "coordinates": coords}}]}))
    return path


@pytest.fixture(scope="module")
def street(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("street")
    assert main(["street", "--line", str(_line_file(d / "main.geojson")), "--side", "right",
                 "--doors", "10", "14", "--k", "2", "-o", str(d / "out")]) == 0
    return d / "out"


@pytest.mark.parametrize("rank", [1, 2])
def test_street_fills_its_line_with_varied_buildings(street, rank):
    db = load_library(SAMPLE_LIBRARY)
    parts = db.by_id
    stem = street / f"main_{rank}"
    for suffix in (".layout.json", ".usda", ".glb", ".png"):
        assert Path(f"{stem}{suffix}").is_file()
    assert validate(f"{stem}.usda") == []
    lay = Layout.from_dict(json.loads(Path(f"{stem}.layout.json").read_text()))
    assert len(lay.structures) == 1                 # one side, one run
    stage = lay.structures[0]["stages"][0]
    length = stage["length"]
    assert length == pytest.approx(200.0, abs=0.05)
    seq = [i.part for i in lay.instances]
    assert seq == stage["parts"]
    # filled within the stretch tolerance (0.5 % of 200 m = 1 m), one stretch for all
    solved = math.fsum(parts[x].length for x in seq)
    assert abs(solved - length) <= 1.0 + 1e-9
    assert stage["stretch"] == pytest.approx(length / solved, abs=1e-6)
    # each building starts where the one before ends, the last one at the line's end
    line = shapely.LineString(stage["polyline"])
    for a, b in zip(lay.instances, lay.instances[1:], strict=False):
        end = np.asarray(a.origin) + np.asarray(a.x_axis) * parts[a.part].length
        assert np.allclose(end, b.origin, atol=1e-3)
        assert line.distance(shapely.Point(b.origin)) < 1e-3
    last = lay.instances[-1]
    end = np.asarray(last.origin) + np.asarray(last.x_axis) * parts[last.part].length
    assert np.allclose(end, line.coords[-1], atol=1e-3)
    assert np.allclose(lay.instances[0].origin, line.coords[0], atol=1e-3)
    # a varied row: many buildings, never one beside its own copy; the asked doors
    assert len(set(seq)) >= 6
    assert all(a != b for a, b in zip(seq, seq[1:], strict=False))
    doors = sum(parts[x].attributes.get("doors", 0) for x in seq)
    assert 10 <= doors <= 14


def test_right_side_buildings_stand_right_of_the_line(street):
    lay = Layout.from_dict(json.loads((street / "main_1.layout.json").read_text()))
    for i in lay.instances:
        # the street runs +X (roughly); right of it is -Y: the buildings' depth (+Y of
        # their placement frame) points there, their facades to the street
        assert i.y_axis[1] < -0.99


def test_sample_buildings_make_neighbours_matter(sample_db):
    """A building beside its own copy shows a step; a row can still fit exactly."""
    idx = sample_db.index()
    for p in sample_db.select("building"):
        i = idx[p.id]
        assert sample_db.cost[i, i] > 1.0
        assert (sample_db.cost[i] == 0).any() and (sample_db.cost[:, i] == 0).any()


def test_runs_split_at_bends_and_meet_at_inner_corners():
    street = shapely.LineString([(0, 0), (100, 0), (100, 80)])   # a left turn of 90 deg
    left = runs(street, "left", 6.0, 12.0)
    right = runs(street, "right", 6.0, 12.0)
    assert [r.name for r in left] == ["left_0", "left_1"]
    # left of the line is the inside of the turn: the first run goes on to the corner,
    # the second starts 12 m (the depth) behind it, against its row's back; before,
    # each stopped 12 m short and a 12 x 12 m square stood open at the corner
    assert left[0].line.length == pytest.approx(100 - 6)
    assert left[1].line.length == pytest.approx(80 - 6 - 12)
    bands = [r.line.buffer(12.0, single_sided=True, cap_style="flat", join_style="mitre")
             for r in left]
    assert bands[0].intersection(bands[1]).area < 1e-6
    assert shapely.box(82, 6, 94, 18).difference(shapely.union_all(bands)).area < 1e-6
    # right of it the outside: the runs reach the corner of the offset line
    assert sum(r.line.length for r in right) == pytest.approx(facade_line(
        street, "right", 6.0).length)


@pytest.mark.parametrize("turn", [150.0, 165.0, 175.0])
def test_the_outer_rows_of_a_hairpin_stop_near_the_turn(turn):
    """The outer facade line of a street turning back by 150-175° was mitred up to ten
    offsets past the bend (a 170° turn's rows ran 60 m past the street's end); it is
    bevelled now at :data:`MITRE_LIMIT` offsets, and the rows end there."""
    from citysynth.pipeline.streets import MITRE_LIMIT

    a = math.radians(180 - turn)
    street = shapely.LineString([(0, 0), (100, 0), (100 - 100 * math.cos(a),
                                                    100 * math.sin(a))])
    built = runs(street, "right", 6.0, 12.0)
    assert sum(r.line.length for r in built) > 190
    far = max(street.distance(shapely.Point(xy)) for r in built for xy in r.line.coords)
    assert far <= (MITRE_LIMIT + 0.25) * 6.0, far   # GEOS bevels just past the limit


@pytest.mark.parametrize("args, code, text", [
    (["--side", "both", "--offset", "0"], 2, "--offset must be a positive number"),
    (["--doors", "5", "2"], 2, "--doors LO HI needs 0 <= LO <= HI"),
    (["--doors", "60", "70"], 1, "infeasible: the left side's run 1 ("),
    # located in the file's own CRS (EPSG:25832 metres), not the local frame
    (["--doors", "60", "70"], 1, " m, from (690000.00, 5335006.00) to (690199.55, "),
    (["--doors", "60", "70"], 1, ")): its doors in [60, 70] cannot be met by the buildings, "
                                 "which make "),
    # counts no row of the length comes near: answered at once from the buildings'
    # densest rate (10 million windows searched for minutes; 1e12 doors were refused
    # "raise the budget (--max-memory MB)", an option street has not)
    (["--windows", "1e7", "1e7"], 1, ")): its windows in [1e+07, 1e+07] cannot be met by "
                                     "the buildings, which make at most "),
    (["--doors", "1e12", "1e12"], 1, "its doors in [1e+12, 1e+12] cannot be met by the "
                                     "buildings, which make at most "),
    # the length alone is met: the windows asked are the cause, said so (every building
    # has windows: told at once by the sparsest rate)
    (["--windows", "0", "0"], 1, ")): its windows in [0, 0] cannot be met by the buildings, "
                                 "which make at least "),
    # a style the library has no buildings of names those it has, as block does
    (["--style", "nosuch"], 2, 'has no complete buildings of style "nosuch"; it has them '
                               "in classic, modern"),
])
def test_street_bad_or_impossible_asks(tmp_path, capsys, args, code, text):
    argv = ["street", "--line", str(_line_file(tmp_path / "s.geojson")), "--no-preview",
            "-o", str(tmp_path / "out"), *args]
    assert main(argv) == code
    err = capsys.readouterr().err
    assert text in err and "Traceback" not in err
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").glob("*.usda"))


def test_street_line_must_be_one_linestring(tmp_path, capsys):
    ring = [COORDS[0], COORDS[1], [690100.0, 5335100.0], COORDS[0]]
    f = _line_file(tmp_path / "p.geojson", [ring], "Polygon")
    assert main(["street", "--line", str(f), "-o", str(tmp_path)]) == 2
    assert "Traceback" not in capsys.readouterr().err


def test_repeated_vertices_change_nothing_and_a_crossing_line_is_refused(tmp_path, capsys):
    """QGIS and OSM exports repeat vertices: they built 7 m of a 50 m line; now the line
    is read as without them. A line that crosses itself would build rows through each
    other: refused, exit 2."""
    el = [[690000.0, 5335000.0], [690030.0, 5335000.0], [690030.0, 5335020.0]]
    repeated = [el[0], el[0], el[1], el[1], el[1], el[2]]
    for name, coords in (("plain", el), ("repeated", repeated)):
        assert main(["street", "--line", str(_line_file(tmp_path / f"{name}.geojson", coords)),
                     "--side", "right", "--no-preview", "-o", str(tmp_path / name)]) == 0
    a, b = (json.loads((tmp_path / n / f"{n}.layout.json").read_text())
            for n in ("plain", "repeated"))
    assert a["parts_used"] == b["parts_used"] and a["cost"] == b["cost"]
    assert sum(s["length"] for st in b["structures"] for s in st["stages"]) > 45
    cross = [[690000.0, 5335000.0], [690040.0, 5335000.0], [690040.0, 5335030.0],
             [690020.0, 5335030.0], [690020.0, 5334980.0]]
    capsys.readouterr()
    assert main(["street", "--line", str(_line_file(tmp_path / "x.geojson", cross)),
                 "--side", "right", "--no-preview", "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "crosses itself" in err and "Traceback" not in err


def _lonlat_file(path: Path, coords) -> Path:
    """A street line in longitude/latitude, as a tester's GIS writes it."""
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {},
        "geometry": {"type": "LineString", "coordinates": coords}}]}))
    return path


@pytest.mark.parametrize("side", ["both", "left", "right"])
def test_a_street_that_goes_there_and_back_is_refused_at_the_turn(tmp_path, capsys, side):
    """A line 100 m east and then 70 m back west over itself (in lon/lat, so that
    projecting it left the two legs a fraction of a millimetre apart and shapely took
    the line as simple): its left side was built as one 160 m straight run, rows
    reaching 60 m past the street's end, exit 0 without a word. Now it is refused at
    the turn, in the file's coordinates, as a building line is (exit 2, nothing
    written)."""
    src = _lonlat_file(tmp_path / "back.geojson",
                       [[7.1, 50.73], [7.101420454545454, 50.73], [7.100426136363636, 50.73]])
    out = tmp_path / "out"
    assert main(["street", "--line", str(src), "--side", side, "--no-preview",
                 "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "back.geojson: the street line turns back at (7.101420, 50.730000) and runs " \
           "70." in err, err
    assert "over its own course, to (7.100426, 50.730000): the line goes there and back; " \
           "end it at the turn" in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not out.exists()


@pytest.mark.parametrize("turn, says", [
    (179.0, "turns back by 179.0° at (690100.00, 5335000.00), a corner of 1.0°, sharper "
            "than the 5° citysynth builds: its two legs run almost on top of each other "
            "(the line goes there and back; end it at the turn, or open the turn up)"),
    (175.5, "turns back by 175.5° at (690100.00, 5335000.00), a corner of 4.5°"),
])
def test_a_street_turning_back_almost_on_itself_is_refused_at_the_turn(tmp_path, capsys,
                                                                       turn, says):
    """A turn of 179° (the legs 1.2 m apart 70 m on) was built: the outer side's row
    ran 60 m past the street's end (the offset's mitre, at its limit) and back. A turn
    sharper than a building line's sharpest corner (5°) is refused there."""
    a = math.radians(180.0 - turn)
    src = _line_file(tmp_path / "t.geojson", _at([(0, 0), (100, 0),
                                                  (100 - 70 * math.cos(a), 70 * math.sin(a))]))
    assert main(["street", "--line", str(src), "--no-preview", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"t.geojson: the street line {says}" in err and "Traceback" not in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("points, says", [
    # round a block and back along its first side: refused where it overlaps
    ([(0, 0), (100, 0), (100, 20), (50, 20), (50, 0), (20, 0)],
     "comes back over its own course from (690020.00, 5335000.00) to (690050.00, "
     "5335000.00) (30.0 m); give it as lines that do not overlap (one run each)"),
    # ... ending on its own course
    ([(0, 0), (100, 0), (100, 20), (50, 20), (50, 0)],
     "touches itself at (690050.00, 5335000.00); give it as lines that do not cross or "
     "touch"),
    # ... across it
    ([(0, 0), (40, 0), (40, 30), (20, 30), (20, -20)],
     "crosses itself at (690020.00, 5335000.00); give it as lines that do not cross"),
    # a loop that goes on past its closing point
    ([(0, 0), (60, 0), (60, 60), (0, 60), (0, 0), (30, 0)],
     "comes back over its own course from (690000.00, 5335000.00) to (690030.00, "
     "5335000.00) (30.0 m)"),
])
def test_a_street_over_its_own_course_is_refused_saying_where(tmp_path, capsys, points, says):
    """A line that comes back over itself later (not at one turn) or crosses itself
    was "the street line crosses itself", where not said; now where, in the file's
    coordinates."""
    src = _line_file(tmp_path / "c.geojson", _at(points))
    assert main(["street", "--line", str(src), "--no-preview", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"c.geojson: the street line {says}" in err and "Traceback" not in err, err


def _shared_ground(out: Path, name: str) -> tuple[float, float, int]:
    """Ground two buildings of the row share (m²), all they cover, and how many."""
    from citysynth.export.audit import footprint, instance_triangles
    feet = [footprint(t) for t in instance_triangles(out / f"{name}.usda").values()]
    shared = sum(feet[i].intersection(feet[j]).area for i in range(len(feet))
                 for j in range(i + 1, len(feet)) if feet[i].intersects(feet[j]))
    return shared, sum(f.area for f in feet), len(feet)


def _at(points) -> list[list[float]]:
    x0, y0 = COORDS[0]
    return [[x0 + x, y0 + y] for x, y in points]


@pytest.mark.parametrize("ring", [[(0, 0), (60, 0), (60, 60), (0, 60), (0, 0)],
                                  [(0, 0), (0, 60), (60, 60), (60, 0), (0, 0)]])
def test_a_street_loop_is_a_ring_on_both_sides(tmp_path, capsys, ring):
    """A street that closes on itself: its closing point is a corner like the others
    (the rows inside overlapped there, 131.7 m²) and the outer side keeps all four sides
    (its offset curve dropped the two at the line's ends: 144.8 of 288 m built)."""
    src = _line_file(tmp_path / "loop.geojson", _at(ring))
    assert main(["street", "--line", str(src), "--side", "both", "-o", str(tmp_path / "o"),
                 "--no-preview"]) == 0
    lay = Layout.from_dict(json.loads((tmp_path / "o" / "loop.layout.json").read_text()))
    sides = [st["name"].rsplit("_", 1)[0] for st in lay.structures]
    assert sorted(sides) == ["left"] * 4 + ["right"] * 4, sides
    built = {s: sum(st["stages"][0]["length"] for st in lay.structures
                    if st["name"].startswith(s)) for s in ("left", "right")}
    outer = max(built.values())
    assert outer == pytest.approx(4 * 72.0, abs=4.0), built   # 60 + 2 × 6 m a side
    shared, total, n = _shared_ground(tmp_path / "o", "loop")
    assert n > 20 and shared < 0.001 * total, (shared, total)
    assert validate(tmp_path / "o" / "loop.usda") == []


def test_a_street_turning_back_on_itself_keeps_its_rows_apart(tmp_path, capsys):
    """A U whose legs are closer than two building depths: the longer run keeps its
    row, the other is shortened or left empty, with a warning saying where (its rows
    shared 703 m², 44 % of their ground)."""
    src = _line_file(tmp_path / "u.geojson", _at([(0, 0), (80, 0), (80, 10), (0, 10)]))
    with pytest.warns(UserWarning, match=r"the left side's run at .* is (left empty|"
                                         r"shortened).*comes back within"):
        assert main(["street", "--line", str(src), "--side", "left", "-o",
                     str(tmp_path / "o"), "--no-preview"]) == 0
    shared, total, n = _shared_ground(tmp_path / "o", "u")
    assert n >= 6 and shared < 0.001 * total, (shared, total)


def test_digitising_noise_does_not_fold_the_offset_line(tmp_path, capsys):
    """A 5 cm bump in a straight street: the 6 m offset of its concave side folded, and
    ``--side both`` was refused; the line is straightened that little first."""
    src = _line_file(tmp_path / "b.geojson",
                     _at([(0, 0), (40, 0), (41, 0.05), (42, 0), (80, 0)]))
    assert main(["street", "--line", str(src), "--side", "both", "-o", str(tmp_path / "o"),
                 "--no-preview"]) == 0
    shared, total, n = _shared_ground(tmp_path / "o", "b")
    assert n >= 14 and shared < 0.001 * total, (shared, total)
    notch = _line_file(tmp_path / "n.geojson",                 # a real fold: said where
                       _at([(0, 0), (40, 0), (40, -10), (42, -10), (42, 0), (80, 0)]))
    assert main(["street", "--line", str(notch), "--side", "both", "-o",
                 str(tmp_path / "o2"), "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert "to the right is not one line" in err and "near (690040.00, 5335000.00)" in err, err
    assert not (tmp_path / "o2").exists()


def test_a_multilinestring_of_one_line_is_read_as_that_line(tmp_path, capsys):
    """QGIS and shapefiles write a street as a MultiLineString; one whose parts join end
    to end is that line (it was refused as "1 feature(s) (MultiLineString first)"),
    parts apart are refused as such."""
    one = _line_file(tmp_path / "m.geojson", [COORDS[:2], COORDS[1:]], "MultiLineString")
    assert main(["street", "--line", str(one), "--side", "right", "-o", str(tmp_path / "o"),
                 "--no-preview"]) == 0
    lay = json.loads((tmp_path / "o" / "m.layout.json").read_text())
    assert len(lay["structures"]) == 1 and lay["structures"][0]["stages"][0]["length"] > 190
    apart = _line_file(tmp_path / "a.geojson", [COORDS[:2], _at([(0, 50), (100, 50)])],
                       "MultiLineString")
    capsys.readouterr()
    assert main(["street", "--line", str(apart), "-o", str(tmp_path / "o2")]) == 2
    assert "2 parts do not join end to end" in capsys.readouterr().err


@pytest.mark.parametrize("coords", [[(0, 0), (80, 0)], [(0, 0), (0, 80)]])
def test_a_straight_street_along_an_axis_keeps_its_whole_run(sample_db, coords):
    """The runs are kept apart on open ground round them; the box of a street along an
    axis is flat, and grown by buffer it left 31.7 m of an 80 m run (the gallery's
    Fig. 7)."""
    import warnings

    from citysynth.pipeline.streets import StreetAsk, solve_street
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        built = solve_street("s", shapely.LineString(coords), sample_db,
                             StreetAsk(("left",), k=1))
    assert built.status == "ok"
    (st,) = built.layouts[0].structures
    assert st["stages"][0]["length"] == pytest.approx(80.0)


def _zigzag(amplitude: float, length: float = 200.0) -> list[list[float]]:
    """A line in UTM 32N that zig-zags ``amplitude`` metres either side every 2 m."""
    return [[690000.0 + x, 5335000.0 + (amplitude if i % 2 else -amplitude)]
            for i, x in enumerate(np.arange(0.0, length + 1e-9, 2.0))]


def test_a_zigzag_street_is_told_why_it_stays_empty(tmp_path, capsys):
    """A line zig-zagging ±2 m every 2 m has no run between bends long enough to build:
    two 9 m rows of a 200 m street were written, exit 0, without a word. Each side that
    stays mostly empty is now warned of, with how much and where; a line with nothing
    to build at all (±0.5 m) is refused saying that it bends at every point."""
    from citysynth.skeletons import InputWarning

    out = tmp_path / "out"
    with pytest.warns(InputWarning) as caught:
        assert main(["street", "--line", str(_line_file(tmp_path / "z.geojson",
                                                         _zigzag(2.0))),
                     "-o", str(out), "--no-preview"]) == 0
    err = "\n".join(str(w.message) for w in caught)
    for side in ("left", "right"):
        assert f"the {side} side: " in err and " stay empty (e.g. near " in err, err
    assert "straighten the line" in err
    assert main(["street", "--line", str(_line_file(tmp_path / "g.geojson", _zigzag(0.5))),
                 "-o", str(tmp_path / "g"), "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert "no straight run of at least 6 m" in err and "bends by more than 5° at" in err
    assert f"error: {tmp_path / 'g.geojson'}: the street line" in err   # its file, not "g"
    assert "stay empty" not in err and "Traceback" not in err
    # the 200 m street of the other tests, bent by 3° once: no such warning
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        assert main(["street", "--line", str(_line_file(tmp_path / "m.geojson")),
                     "-o", str(tmp_path / "m"), "--no-preview"]) == 0


def test_an_output_is_the_input_by_any_name(tmp_path):
    """``written_over``, the one check every command makes before writing: the same
    file reached through a link, a hard link or ``./`` is the same file; a copy, or an
    output not written yet, is not."""
    from citysynth.pipeline.paths import written_over
    (tmp_path / "d").mkdir()
    f = tmp_path / "d" / "in.geojson"
    f.write_text("{}")
    (tmp_path / "link").symlink_to(tmp_path / "d")
    (tmp_path / "hard.geojson").hardlink_to(f)
    (tmp_path / "copy.geojson").write_text("{}")
    missing = tmp_path / "none.usda"
    assert written_over([missing, tmp_path / "copy.geojson"], [f]) is None
    assert written_over([tmp_path / "link" / "in.geojson"], [f]) == \
        (tmp_path / "link" / "in.geojson", f)
    dotted = tmp_path / "d" / "." / "in.geojson"
    assert written_over([tmp_path / "hard.geojson"], [missing, dotted]) == \
        (tmp_path / "hard.geojson", dotted)


def test_an_output_never_overwrites_the_input(tmp_path, capsys):
    """``street --line out/ok.layout.usda -o out`` replaced the street line with the
    USD made from it (exit 0); ``tower --lot`` and ``block`` likewise. Refused, the
    input untouched, nothing written."""
    line = _line_file(tmp_path / "ok.layout.usda")
    before = line.read_bytes()
    assert main(["street", "--line", str(line), "--side", "right", "--no-preview",
                 "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"{line}: the output ok.layout.usda would overwrite this input file" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert line.read_bytes() == before and sorted(tmp_path.iterdir()) == [line]
    lot = tmp_path / "lot" / "t.glb"
    lot.parent.mkdir()
    lot.write_text(json.dumps({
        "type": "FeatureCollection", "crs": {"type": "name", "properties": {
            "name": "urn:ogc:def:crs:EPSG::25832"}},
        "features": [{"type": "Feature", "properties": {}, "geometry": {
            "type": "Polygon", "coordinates": [[[690000, 5335000], [690030, 5335000],
                                                [690030, 5335022], [690000, 5335022],
                                                [690000, 5335000]]]}}]}))
    before = lot.read_bytes()
    assert main(["tower", "--height", "30", "--far", "3", "--lot", str(lot), "--name", "t",
                 "--no-preview", "-o", str(lot.parent)]) == 2
    assert "t.glb would overwrite this input file" in capsys.readouterr().err
    assert lot.read_bytes() == before and sorted(lot.parent.iterdir()) == [lot]


@pytest.mark.parametrize("k, said", [
    (None, "main: filling its 200 m run with buildings would take more than the 2,048 MB "
           "budget; narrow or drop the intervals on doors, or split the street into "
           "shorter lines"),
    (7, "main: k = 7 rows of buildings would take at least 4.9 GB to keep, over the "
        "2,048 MB budget; ask for fewer (--k)")])
def test_a_street_too_large_to_fill_is_told_in_street_words(tmp_path, capsys, monkeypatch,
                                                            k, said):
    """A 100 km street with doors and windows intervals was refused in the solver's
    words: "... partial sequences ... use a quantum (e.g. "quantum": {"length": 2}) ...
    or raise the budget (--max-memory MB)", options ``street`` does not have."""
    import citysynth.pipeline.streets as streets
    from citysynth.solver import TooLargeError

    def too_large(*_a, **_kw):
        raise TooLargeError('stopped at the memory budget of 2,048 MB after 2,804,571 '
                            'partial sequences; use a quantum (e.g. "quantum": '
                            '{"length": 2}) or raise the budget (--max-memory MB)',
                            need_mb=5000.0, budget_mb=2048.0, k=k)
    monkeypatch.setattr(streets, "solve", too_large)
    capsys.readouterr()
    assert main(["street", "--line", str(_line_file(tmp_path / "main.geojson")),
                 "--doors", "1", "50", "-o", str(tmp_path / "o"), "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert said in err and "--max-memory" not in err and "quantum" not in err, err


def test_a_street_of_many_runs_does_linear_work_per_run(tmp_path, monkeypatch, capsys):
    """A zigzag street of 400 runs: its GLB grouped every run's stage by sorting all
    the groups once per run (quadratic: 16 million sort keys and 7.5 s for 8,000 runs),
    and each run's problem listed its transitions as arrays again (2.5 ms a run, most
    of compiling it). A street of 20,000 runs took over 10 minutes, now 30 s. Counted,
    not timed: the sort keys the GLB's grouping makes, the transition listings made
    after parsing, and each run's solution against a problem parsed for it alone. It
    also said nothing while it worked, then printed a line per run."""
    from citysynth.export import gltf
    from citysynth.solver.problem import Problem

    lat0, n = 60.17, 200
    mx, my = 1 / (111320 * math.cos(math.radians(lat0))), 1 / 110540
    line = tmp_path / "zigzag.geojson"
    line.write_text(json.dumps({"type": "Feature", "properties": {}, "geometry": {
        "type": "LineString", "coordinates": [
            [24.94 + 20.0 * i * mx, lat0 + (15.0 if i % 2 else 0.0) * my]
            for i in range(n + 1)]}}))
    calls = {"sort": 0, "index": 0}
    order, listed = gltf._group_order, Problem.__dict__["transition_index"].func

    def counted_order(item):
        calls["sort"] += 1
        return order(item)

    def counted_listing(self):
        calls["index"] += 1
        return listed(self)

    counted = functools.cached_property(counted_listing)
    counted.__set_name__(Problem, "transition_index")
    monkeypatch.setattr(gltf, "_group_order", counted_order)
    monkeypatch.setattr(Problem, "transition_index", counted)
    out = tmp_path / "out"
    assert main(["street", "--line", str(line), "-o", str(out), "--no-preview"]) == 0
    lay = Layout.from_dict(json.loads((out / "zigzag.layout.json").read_text()))
    stages = {(i.structure, i.stage) for i in lay.instances}
    assert len(stages) >= 2 * n - 2                    # every run of both sides built
    assert calls["sort"] <= len(stages) + 2 * len(lay.structures)   # once each group
    assert calls["index"] <= 1   # the transitions listed once (parsing lists them)
    # it says how far it is (a line per tenth off a terminal), and lists the first
    # runs, not 400 lines of them (20,000 for the street of 10,000 segments)
    captured = capsys.readouterr()
    progress = [line for line in captured.err.splitlines() if "runs filled" in line]
    assert len(progress) == 10 and progress[-1].startswith(f"[{2 * n}/{2 * n}] runs filled")
    listed = [line for line in captured.out.splitlines() if " side, run " in line]
    assert len(listed) == 100
    assert f"    ... and {2 * n - 100} more runs (each in zigzag.layout.json)" in captured.out
    # a run solved from the shared problem is the run solved from its own
    from citysynth.pipeline.streets import street_front_problem
    from citysynth.solver.entry import solve
    db = load_library(SAMPLE_LIBRARY)
    base = street_front_problem(db, 0.0, k=3)
    first = Problem.from_dict({**base, "constraints": {"length": [20.0, 20.3]}})
    for lo, hi in ((25.0, 25.3), (7.9, 8.2), (40.0, 40.4)):
        shared = solve(first.with_constraints({"length": (lo, hi)}))
        own = solve(Problem.from_dict({**base, "constraints": {"length": [lo, hi]}}))
        assert [(s.sequence, s.cost) for s in shared.solutions] == \
            [(s.sequence, s.cost) for s in own.solutions]
        assert shared.solutions
