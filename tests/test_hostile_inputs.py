"""Inputs a hostile user or a broken export produce, each once found to crash a command
(exit 3), overwrite another block's files, or say the wrong thing: every one now ends
with one clear line and exit 2, or builds.

- NaN in a JSON input is named as NaN (the big-integer guard swallowed its message);
- bounds and amounts past what a float holds (1e308) are capped or refused, with no
  overflow traceback and no numpy warning on stderr;
- a street ``width`` or ``lanes`` no street has counts as no value;
- a CRS of Mars or the Moon is refused as such;
- block ids that would write each other's files (``x`` against rank 2 of ``x``) are
  refused before anything is solved, and a very long id gets a short file name;
- an absurd ``--lot-area`` is refused;
- a per-block interval every filling meets costs nothing (it was refused as "too
  large" on a 290 m block), and one that does make a block too large is named;
- a library on a 0.3 m quantum (its key parts drawn on a 0.2 m grid) builds, and its
  geometry meets the audit's bars.
"""

from __future__ import annotations

import copy
import errno
import json
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely

from citysynth.parts_db import load_library
from citysynth.pipeline.cli import environment_message, main
from citysynth.pipeline.commands.build import MAX_NAME
from citysynth.skeletons import streets
from citysynth.skeletons.streets import Setbacks, street_setback
from citysynth.solver.structures.model import Structure
from citysynth.solver.structures.solve import _global_grid, solve_structure

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"
LIB = EX / "library"
FACADE = json.loads((EX / "facade_small.json").read_text())
CYCLE = json.loads((EX / "block_cycle.json").read_text())
LON, LAT = 7.1, 50.73


def _run(argv: list[str], capsys) -> tuple[int, str]:
    capsys.readouterr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    noisy = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert not noisy, noisy
    return code, err


def _write(path: Path, data) -> Path:
    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return path


def _rect(fid: str, lon: float, w_deg: float = 0.00085, h_deg: float = 0.00041) -> dict:
    ring = [[lon, LAT], [lon + w_deg, LAT], [lon + w_deg, LAT + h_deg], [lon, LAT + h_deg],
            [lon, LAT]]
    return {"type": "Feature", "properties": {"id": fid},
            "geometry": {"type": "Polygon", "coordinates": [ring]}}


BIG = "1" + "0" * 309     # an integer past every float, short of Python's 4,300 digits


def test_an_integer_past_every_float_is_told_not_a_crash(tmp_path, capsys):
    """An integer of 310 to 4,300 digits passed every check of a value's type and
    crashed the first sum or comparison ("int too large to convert to float", exit 3)
    in a problem file, a footprint's height and a city.toml. JSON reads it as 1e400
    is, infinity, which every check tells; TOML refuses it, as its specification
    says a reader must (past 64 bits)."""
    problem = json.loads((EX / "facade_small.json").read_text())
    problem["elements"][0]["cost"] = 0
    text = json.dumps(problem).replace('"cost": 0', f'"cost": {BIG}', 1)
    code, err = _run(["solve", str(_write(tmp_path / "p.json", text))], capsys)
    assert code == 2 and "elements[0].cost: expected a finite number" in err, err
    feat = _rect("a", 24.94)
    feat["properties"]["height"] = 0
    text = json.dumps({"type": "FeatureCollection", "features": [feat]})
    fp = _write(tmp_path / "f.geojson", text.replace('"height": 0', f'"height": {BIG}'))
    code, err = _run(["city", "--footprints", str(fp), "--library", str(LIB), "-o",
                      str(tmp_path / "run"), "--workers", "1", "--no-overview"], capsys)
    assert code == 0 and "Traceback" not in err, err
    (rec,) = json.loads((tmp_path / "run" / "manifest.json").read_text())["blocks"].values()
    assert "height inf is no height" in rec["note"], rec
    for toml in (f"min_area = {BIG}\n", f"[per_side]\ndoors = [0, {BIG}]\n",
                 f"origin = [-{BIG}, 60.0]\n"):
        cfg = _write(tmp_path / "c.toml", toml)
        code, err = _run(["city", "--footprints", str(fp), "--library", str(LIB), "--config",
                          str(cfg), "-o", str(tmp_path / "run2")], capsys)
        key = toml.split(" =")[0].split("\n")[-1]
        assert code == 2 and f"{key}" in err and "past TOML's 64-bit range" in err, err
        assert not (tmp_path / "run2").exists()


@pytest.mark.parametrize("toml, said", [
    ("k = 1\nk = 2\n", "a key given a value twice (at line 2, column"),
    ("[footprints]\nstretch = 0.1\n[footprints]\ninfill = true\n",
     "the table [footprints] is declared twice (at line 3"),
    ("\x00\x00\x00", "it holds NUL bytes"),
    # a config (or manifest) written in another format: "Invalid statement"
    ('{"footprints": {"stretch": 0.1}}\n', "it looks like JSON (at line 1, column 1); this "
     "file is TOML (key = value lines under [table] headers)"),
    ("# mine\nfootprints:\n  stretch: 0.1\n", "it looks like YAML (at line 2"),
    ("- a\n- b\n", "it looks like YAML"),
    # a float a user wrote as 1e9 was echoed as 1000000000.0
    ("k = 1e9\n", "k: must be an integer from 1 to 100, got 1e+09"),
    ("k = 2.5\n", "k: must be an integer from 1 to 100, got 2.5"),
    # was refused as its floor-area ratio ("between 3.89e-16 and 1.51e-14; ask within that")
    ("[[zone]]\nname = 't'\nkind = 'towers'\nhighway = ['primary']\nheight = [40, 80]\n"
     "far = [2, 4]\nlot = 1e9\n", "zone[0].lot: must be at most 500, got 1e+09"),
    # was told as "feature 0" of a file, and to simplify it with ogr2ogr
    ("[[zone]]\nname = 'z'\nstyle = 'modern'\npolygon = [" + ", ".join(
        f"[{LON + 0.01 * math.cos(math.tau * a / 6e4):.7f}, "
        f"{LAT + 0.01 * math.sin(math.tau * a / 6e4):.7f}]"
        for a in range(60_000)) + "]\n",
     "zone[0].polygon: 60,000 points, more than the 50,000 a zone's polygon may have"),
])
def test_a_city_toml_the_reader_refuses_is_told_in_words(tmp_path, capsys, toml, said):
    """The TOML reader's own words ("Cannot overwrite a value", "Cannot declare
    ('footprints',) twice", "Invalid statement" for a file of NUL bytes) reached the
    user as they were."""
    fp = _write(tmp_path / "f.geojson", {"type": "FeatureCollection",
                                         "features": [_rect("a", LON)]})
    cfg = _write(tmp_path / "c.toml", toml)
    code, err = _run(["city", "--footprints", str(fp), "--library", str(LIB), "--config",
                      str(cfg), "-o", str(tmp_path / "run")], capsys)
    assert code == 2 and said in err and "Cannot" not in err, err


@pytest.mark.parametrize("text, said", [
    ('{"type": "Topology", "objects": {}}', "but TopoJSON; convert it to GeoJSON first"),
    ('[1, 2]', 'but a JSON array; a GeoJSON file holds one object'),
    ('{"features": []}', '(it has no "type"); export the layer again as GeoJSON'),
    ('{"type": "FeatureCollection", "features": {"a": 1}}',
     'its "features" is a JSON object, not a list of Features'),
    ('"hello"', "but a JSON string"),
    ('{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, '
     '"geometry": null, "place": {"type": "LineString", "coordinates": [[0, 0], [9, 0]]}}]}',
     'its shape is in "place" (JSON-FG); export the layer as plain GeoJSON'),
])
def test_json_that_is_no_geojson_says_what_it_is(tmp_path, capsys, text, said):
    """TopoJSON, a bare array or a collection whose features are an object were all
    "not a GeoJSON FeatureCollection, Feature or geometry" or "no features (an empty
    FeatureCollection)", and a JSON-FG feature (its shape in "place") "no geometry
    (null)", with no word of what the file is or how to fix it."""
    code, err = _run(["skeleton", str(_write(tmp_path / "x.geojson", text))], capsys)
    assert code == 2 and said in err and len(err.strip().splitlines()) == 1, err


def test_an_array_of_features_is_read_as_their_collection(tmp_path, capsys):
    """A JSON array of Features (what some web APIs return) is read as the
    FeatureCollection of them."""
    line = {"type": "Feature", "properties": {}, "geometry": {
        "type": "LineString", "coordinates": [[LON, LAT], [LON + 0.0005, LAT]]}}
    listed = _run(["skeleton", str(_write(tmp_path / "a.geojson", [line]))], capsys)
    wrapped = _run(["skeleton", str(_write(tmp_path / "c.geojson", {
        "type": "FeatureCollection", "features": [line]}))], capsys)
    assert listed[0] == wrapped[0] == 0, (listed, wrapped)


def test_a_problem_with_no_transitions_is_told_in_its_own_terms(tmp_path, capsys):
    """A problem file with no "transitions" and no "front"/"back" keys was told "check the
    front/back lists and the transitions": lists it never named."""
    problem = {"resources": ["length", "doors"], "quantum": {"length": 0.2},
               "elements": [{"id": f"e{i}", "resources": {"length": 2.0 + i, "doors": i % 2}}
                            for i in range(3)],
               "transitions": [], "constraints": {"length": [200, 200], "doors": [3, 50]},
               "k": 5}
    code, err = _run(["solve", str(_write(tmp_path / "p.json", problem))], capsys)
    assert code == 1 and "front/back lists" not in err, err
    assert 'each allowed to follow the one before (the "transitions")' in err, err


def test_nan_in_json_is_named_as_nan(tmp_path, capsys):
    bad = _write(tmp_path / "p.json", '{"k": NaN}')
    code, err = _run(["solve", str(bad)], capsys)
    assert code == 2
    assert "NaN is not a JSON number" in err and "thousands of digits" not in err


def test_a_bound_of_1e308_is_capped_and_a_minimum_of_it_refused(tmp_path, capsys):
    loose = copy.deepcopy(FACADE)
    loose["constraints"]["length"] = [20.4, 1e308]
    code, err = _run(["solve", str(_write(tmp_path / "loose.json", loose))], capsys)
    assert code == 0, err
    absurd = copy.deepcopy(FACADE)
    absurd["constraints"]["length"] = [1e308, 1e308]
    code, err = _run(["solve", str(_write(tmp_path / "absurd.json", absurd))], capsys)
    assert code == 2 and "beyond 1e308 quanta" in err and "inf" not in err, err


def test_an_amount_of_1e308_is_refused_without_a_numpy_warning(tmp_path, capsys):
    p = copy.deepcopy(FACADE)
    p["elements"][0]["resources"]["length"] = 1e308
    code, err = _run(["solve", str(_write(tmp_path / "p.json", p))], capsys)
    assert code == 2 and "Warning" not in err
    # refused where it is read (since 2026-11-30: an unconstrained amount of 1.7e308
    # overflowed the totals), before any quantisation
    assert "elements[0].resources.length: must be <= 1e+15 (an amount this large" in err, err


def test_a_stage_bound_of_1e308_is_refused_with_an_estimate_not_a_crash(tmp_path, capsys):
    st = copy.deepcopy(CYCLE)
    st["stages"][0]["constraints"]["length"] = [22, 1e308]
    code, err = _run(["solve", str(_write(tmp_path / "s.json", st))], capsys)
    assert code == 2 and "over the memory budget" in err, err


@pytest.mark.parametrize("props, fallback", [
    ({"width": 1e308, "highway": "residential"}, True),
    ({"width": "3000", "highway": "residential"}, True),
    ({"lanes": 1e12, "highway": "residential"}, True),
    ({"width": "20 m", "highway": "residential"}, False),
    ({"width": "1e4", "highway": "residential"}, True),    # exponents are read, too
    ({"width": "20,0", "highway": "residential"}, False),
])
def test_a_width_or_lane_count_no_street_has_counts_as_no_value(props, fallback):
    s = Setbacks()
    plain = street_setback({"highway": "residential"}, s)
    got = street_setback(props, s)
    assert math.isfinite(got)
    assert (got == plain) == fallback
    if not fallback:
        assert got == pytest.approx(10 + s.sidewalk)


@pytest.mark.parametrize("crs, body", [("IAU_2015:49900", "Mars"), ("IAU_2015:30100", "Moon")])
def test_a_crs_of_another_body_is_refused(crs, body, capsys):
    code, err = _run(["skeleton", str(EX / "skeletons" / "t_building.geojson"), "--crs", crs],
                     capsys)
    assert code == 2 and f"another body ({body})" in err, err


def test_block_ids_that_would_share_files_are_refused_before_solving(tmp_path, capsys):
    src = _write(tmp_path / "two.geojson", {"type": "FeatureCollection", "features": [
        _rect("x", LON), _rect("x_2", LON + 0.01)]})
    out = tmp_path / "out"
    code, err = _run(["block", str(src), "--library", str(LIB), "--k", "2", "-o", str(out),
                      "--no-preview"], capsys)
    assert code == 2 and "'x' and 'x_2'" in err and "_1 to _2" in err, err
    assert not out.exists()
    same = _write(tmp_path / "case.geojson", {"type": "FeatureCollection", "features": [
        _rect("same", LON), _rect("SAME", LON + 0.01)]})
    code, err = _run(["block", str(same), "--library", str(LIB), "-o", str(out),
                      "--no-preview"], capsys)
    assert code == 2 and "share a name" in err, err
    assert not out.exists()
    code, err = _run(["block", str(src), "--library", str(LIB), "-o", str(out),
                      "--no-preview"], capsys)          # k = 1: no rank names, no clash
    assert code == 0, err


def test_a_very_long_id_gets_a_short_distinct_file_name(tmp_path, capsys):
    src = _write(tmp_path / "long.geojson", {"type": "FeatureCollection", "features": [
        _rect("x" * 5000, LON), _rect("x" * 4999 + "y", LON + 0.01)]})
    out = tmp_path / "out"
    code, err = _run(["block", str(src), "--library", str(LIB), "-o", str(out),
                      "--no-preview"], capsys)
    assert code == 0, err
    names = sorted(p.name for p in out.glob("*.layout.json"))
    assert len(names) == 2 and all(len(n) <= MAX_NAME + 20 for n in names), names


def test_an_absurd_lot_area_is_refused(tmp_path, capsys):
    code, err = _run(["tower", "--height", "120", "--far", "10", "--lot-area", "1e300",
                      "-o", str(tmp_path / "o"), "--no-preview"], capsys)
    assert code == 2 and "no building lot" in err, err
    assert not (tmp_path / "o").exists()


def test_an_interval_every_filling_meets_is_left_out_and_solves_the_same():
    free = copy.deepcopy(CYCLE)
    assert free.pop("constraints") == {"doors": [8, 10]}
    plain = Structure.from_dict(free)
    wide = Structure.from_dict({**free, "constraints": {"doors": [0, 1e20]}})
    assert _global_grid(wide)[0] == []
    assert _global_grid(Structure.from_dict(CYCLE))[0] == ["doors"]   # a real bound stays
    a, b = solve_structure(plain, 5), solve_structure(wide, 5)
    assert [s.cost for s in a.solutions] == [s.cost for s in b.solutions]
    assert [s.stages for s in a.solutions] == [s.stages for s in b.solutions]


def test_a_too_large_block_names_its_per_block_interval():
    from citysynth.pipeline.layouts import too_large
    from citysynth.solver.errors import TooLargeError
    exc = TooLargeError("x", need_mb=4544, budget_mb=2048)
    assert "narrow or drop its per-block intervals on windows" in too_large(
        "b", [], exc, ["windows"])
    assert "split it into smaller blocks" in too_large("b", [], exc)


def test_a_name_too_long_for_the_file_system_is_said_so():
    msg = environment_message(OSError(errno.ENAMETOOLONG, "File name too long",
                                      "/out/" + "x" * 300 + ".json"))
    assert "choose a shorter output folder or name" in msg and len(msg) < 200, msg


def test_a_file_in_the_way_is_not_blamed_on_space_or_permissions():
    """`diff A B --png x/map.png` where x is a file said "File exists; free space or
    fix the permissions"."""
    msg = environment_message(OSError(errno.EEXIST, "File exists", "x"))
    assert "move that file out of the way" in msg and "free space" not in msg
    msg = environment_message(OSError(errno.ENOTDIR, "Not a directory", "x/y"))
    assert "a file stands where a folder should be" in msg


@pytest.fixture(scope="module")
def coarse_library(tmp_path_factory) -> Path:
    """The example library on a 0.3 m quantum: its key parts' legs and a T's depth land
    up to half a quantum off the grid the solver counts in."""
    lib = tmp_path_factory.mktemp("q03")
    (lib / "meshes").symlink_to(LIB / "meshes")
    text = (LIB / "manifest.toml").read_text()
    assert "quantum = 0.2" in text
    (lib / "manifest.toml").write_text(text.replace("quantum = 0.2", "quantum = 0.3", 1))
    return lib


def test_a_library_off_its_quantum_grid_builds_and_meets_the_audit(coarse_library, tmp_path,
                                                                   capsys):
    from tests.test_audit import _audit, _failures
    out = tmp_path / "out"
    code, err = _run(["building", str(EX / "skeletons" / "t_building.geojson"), "--library",
                      str(coarse_library), "--style", "classic", "-o", str(out),
                      "--no-preview"], capsys)
    assert code == 0, err
    src = _write(tmp_path / "rect.geojson", {"type": "FeatureCollection", "features": [
        _rect("r60x45", LON)]})
    code, err = _run(["block", str(src), "--library", str(coarse_library), "-o", str(out),
                      "--no-preview"], capsys)
    assert code == 0, err
    db = load_library(coarse_library)
    layouts = sorted(out.glob("*.layout.json"))
    assert len(layouts) == 2
    for p in layouts:
        assert _failures(*_audit(p, db)) == []


def _manifest_library(tmp_path: Path, edit) -> Path:
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "meshes").symlink_to(LIB / "meshes")
    (lib / "manifest.toml").write_text(edit((LIB / "manifest.toml").read_text()))
    return lib


def test_ingest_refuses_a_quantum_longer_than_a_part(tmp_path, capsys):
    lib = _manifest_library(tmp_path, lambda t: t.replace("quantum = 0.2", "quantum = 1000"))
    code, err = _run(["ingest", str(lib), "-o", str(tmp_path / "db.json")], capsys)
    assert code == 2 and "less than the library's quantum of 1000 m" in err, err
    assert not (tmp_path / "db.json").exists()


def test_ingest_refuses_an_attribute_called_length(tmp_path, capsys):
    def edit(text: str) -> str:
        at = text.index("\n", text.index("file", text.index("[[part]]"))) + 1
        return text[:at] + "attributes = {length = 5}\n" + text[at:]
    lib = _manifest_library(tmp_path, edit)
    code, err = _run(["ingest", str(lib), "-o", str(tmp_path / "db.json")], capsys)
    assert code == 2 and "may not be called length" in err, err


@pytest.mark.parametrize("props, levels, height, unread", [
    ({"building:levels": "1e308"}, None, None, 'building:levels "1e308" is no storey count'),
    ({"building:levels": 1e308, "height": 1e308}, None, None,
     "building:levels 1e+308 is no storey count (1 to 200) and height 1e+308 is no height "
     "(metres, up to 1000): left out, the storeys chosen as without it"),
    ({"building:levels": -2}, None, None, "building:levels -2 is no storey count"),
    ({"height": "tall"}, None, None, 'height "tall" is no height'),
    ({"building:levels": "5", "height": "12.5 m"}, 5.0, 12.5, ""),
    ({"building:levels": "2e1"}, 20.0, None, ""),
    ({"building:levels": "4", "height": "12,5"}, 4.0, 12.5, ""),     # a decimal comma
    ({"height": "40'6\""}, None, 12.3444, ""),                       # feet and inches
    # read in part: the first number, and the notes say which
    ({"building:levels": "4;5", "height": "12,5"}, 4.0, 12.5,
     'building:levels "4;5" read as 4 (the first number)'),
    ({"building:levels": ["4", "5"]}, 4.0, None, "read as 4"),       # a list, as GDAL writes
    ({"building:levels": "4-5"}, 4.0, None, 'building:levels "4-5" read as 4'),
    ({"height": "12 m approx."}, None, 12.0, 'height "12 m approx." read as 12 m'),
    # a fraction of a storey: rounded half up, and told (0.4 was 1 storey in silence)
    ({"building:levels": 2.5}, 2.5, None, "building:levels 2.5 is no whole number of "
                                          "storeys: 3 asked"),
    ({"building:levels": "0.4"}, 0.4, None, "0.4 is no whole number of storeys: 1 asked"),
    ({"building:levels": "", "height": None}, None, None, ""),       # no value: no note
])
def test_storeys_no_building_has_count_as_no_value(props, levels, height, unread):
    """A storey count or height no building has counts as none, and the building's
    notes (the report's, its layout's) say so."""
    from citysynth.pipeline.city.footprints import Storeys, footprint_spec
    spec = footprint_spec("f.geojson", 0, props, "", 0.05, 0.3, Storeys())
    assert spec.levels == levels and spec.height == pytest.approx(height)
    assert (unread in spec.remarks and spec.remarks.startswith("f.geojson: feature 0: ")) \
        if unread else spec.remarks == ""


def test_duplicated_building_lines_are_named_as_such(tmp_path, capsys):
    d = json.loads((EX / "skeletons" / "t_building.geojson").read_text())
    twin = copy.deepcopy(d["features"][0])
    twin["geometry"]["coordinates"] = twin["geometry"]["coordinates"][::-1]
    d["features"].append(twin)
    code, err = _run(["skeleton", str(_write(tmp_path / "dup.geojson", d))], capsys)
    assert code == 2 and "the same edge is drawn twice" in err, err
    assert "feature 0 (front) and" in err and "delete one of them" in err, err


def test_a_building_line_that_turns_back_on_itself_is_told_so(tmp_path, capsys):
    """One line drawn out and back over itself was "feature 0 and feature 0: the same
    edge is drawn twice ...; delete one of them": now it names the feature once and
    says the line goes there and back."""
    line = {"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {}, "geometry": {
            "type": "LineString",
            "coordinates": [[24.94, 60.17], [24.9410835, 60.17], [24.94, 60.170000009]]}}]}
    code, err = _run(["skeleton", str(_write(tmp_path / "back.geojson", line))], capsys)
    assert code == 2 and "feature 0: the same edge is drawn twice" in err, err
    assert "the line goes there and back; end it at the turn" in err, err
    assert "feature 0 and" not in err, err


def test_a_building_line_drawn_twenty_thousand_times_is_named_in_little_memory(tmp_path):
    """Building skeleton lines checked for crossings a chunk at a time: 20,000 copies of
    one line met each other 400 M times at once, gigabytes and a crash (SIGSEGV in a
    4 GB address space); now one line names the first copy, in a 1.5 GB space."""
    line = {"type": "Feature", "properties": {},
            "geometry": {"type": "LineString", "coordinates": [[LON, LAT],
                                                               [LON + 0.01, LAT]]}}
    src = _write(tmp_path / "pile.geojson", {"type": "FeatureCollection",
                                             "features": [line] * 20_000})
    code = ("import resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_AS, (1_500_000_000, 1_500_000_000))\n"
            "from citysynth.pipeline.cli import main\n"
            f"sys.exit(main(['skeleton', {str(src)!r}]))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 2, p.stderr[-2000:]
    assert "feature 0 and" in p.stderr and "the same edge is drawn twice" in p.stderr


def test_skeleton_of_streets_that_enclose_nothing_says_so(tmp_path, capsys):
    """``skeleton`` of two crossing streets printed only its frame line (exit 0)."""
    from citysynth.skeletons import lonlat_from_local
    feats = [{"type": "Feature", "properties": {"highway": "residential"},
              "geometry": {"type": "LineString",
                           "coordinates": lonlat_from_local(pts, (LON, LAT))}}
             for pts in ([(0, 0), (300, 0)], [(150, -150), (150, 150)])]
    src = _write(tmp_path / "cross.geojson", {"type": "FeatureCollection", "features": feats})
    capsys.readouterr()
    assert main(["skeleton", str(src)]) == 0
    out = capsys.readouterr().out
    assert "no blocks: the 2 street line(s) enclose no ground" in out, out


def test_streets_that_enclose_nothing_say_so(tmp_path, capsys):
    from citysynth.skeletons import lonlat_from_local
    line = {"type": "Feature", "properties": {"highway": "residential"},
            "geometry": {"type": "LineString",
                         "coordinates": lonlat_from_local([(0, 0), (300, 0)], (LON, LAT))}}
    src = _write(tmp_path / "one.geojson", {"type": "FeatureCollection", "features": [line]})
    code, err = _run(["city", "--streets", str(src), "--library", str(LIB), "-o",
                      str(tmp_path / "run"), "--no-overview", "--workers", "1"], capsys)
    assert code == 1 and "the streets enclose no block" in err, err


def test_a_minimum_no_facade_has_is_refused(tmp_path, capsys):
    d = json.loads((EX / "skeletons" / "t_building.geojson").read_text())
    d["features"][0]["properties"]["constraints"] = {"doors": [1e308, 1e308]}
    code, err = _run(["building", str(_write(tmp_path / "b.geojson", d)), "--library",
                      str(LIB), "-o", str(tmp_path / "o"), "--no-preview"], capsys)
    assert code == 2 and "more than any facade has" in err, err
    cfg = tmp_path / "city.toml"
    cfg.write_text("[per_block]\nwindows = [1e12, 1e12]\n")
    code, err = _run(["city", "--streets", str(_write(tmp_path / "s.geojson", {
        "type": "FeatureCollection", "features": []})), "--library", str(LIB), "--config",
        str(cfg), "-o", str(tmp_path / "run"), "--no-overview"], capsys)
    assert code == 2 and "per_block.windows" in err and "more than any block" in err, err


def test_ingest_refuses_a_quantum_finer_than_a_millimetre(tmp_path, capsys):
    lib = _manifest_library(tmp_path, lambda t: t.replace("quantum = 0.2", "quantum = 1e-9"))
    code, err = _run(["ingest", str(lib), "-o", str(tmp_path / "db.json")], capsys)
    assert code == 2 and "finer than 0.001 m" in err, err


def test_figures_are_said_with_the_digits_that_matter(tmp_path, capsys):
    code, err = _run(["solve", str(EX / "facade_small.json"), "--max-memory", "0.001"],
                     capsys)
    assert code == 2 and "over the memory budget of 0.001 MB" in err and "0.0 GB" not in err
    code, err = _run(["tower", "--height", "120.00001", "--far", "10", "--lot-area", "400",
                      "-o", str(tmp_path / "o"), "--no-preview"], capsys)
    assert code == 1 and "at 120.00001 m" in err, err


def test_ids_keep_distinct_names_in_files_and_prims(tmp_path, capsys):
    """Numeric ids keep their digits in the USD root prim ("17" was "_7", as was "27"),
    ids of letters outside ASCII keep distinct file names (both were "layout"), and
    RFC 7946's own feature "id" names a block (it was named by position)."""
    from pxr import Sdf
    feats = [_rect("17", LON), _rect("27", LON + 0.01), _rect("é", LON + 0.02),
             _rect("中文", LON + 0.03), _rect("", LON + 0.04)]
    feats[1]["properties"] = {}
    feats[1]["id"] = 27                      # the Feature's own member, a number
    feats[4]["properties"] = {}
    feats[4]["id"] = "north_block"
    src = _write(tmp_path / "ids.geojson", {"type": "FeatureCollection", "features": feats})
    out = tmp_path / "out"
    code, err = _run(["block", str(src), "--library", str(LIB), "-o", str(out),
                      "--no-preview"], capsys)
    assert code == 0, err
    stems = sorted(p.name.removesuffix(".layout.json") for p in out.glob("*.layout.json"))
    assert stems[:3] == ["17", "27", "id_7be2d2d20c10"] and stems[4] == "north_block", stems
    assert stems[3].startswith("id_") and len(set(stems)) == 5
    prims = {Sdf.Layer.FindOrOpen(str(out / f"{s}.usda")).defaultPrim for s in ("17", "27")}
    assert prims == {"_17", "_27"}


def test_a_lot_with_a_hole_is_written_with_it(tmp_path, capsys):

    from citysynth.skeletons import lonlat_from_local
    outer = lonlat_from_local([(0, 0), (60, 0), (60, 60), (0, 60), (0, 0)], (LON, LAT))
    hole = lonlat_from_local([(40, 40), (55, 40), (55, 55), (40, 55), (40, 40)], (LON, LAT))
    lot = _write(tmp_path / "lot.geojson", {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {},
         "geometry": {"type": "Polygon", "coordinates": [outer, hole]}}]})
    out = tmp_path / "o"
    code, err = _run(["tower", "--height", "60", "--far", "0.5", "1.7", "--lot", str(lot),
                      "-o", str(out), "--no-preview"], capsys)
    assert code == 0, err
    st = json.loads(next(out.glob("*.layout.json")).read_text())["structures"][0]["lot"]
    poly = shapely.Polygon(st["polygon"], st["holes"])
    assert poly.area == pytest.approx(st["area"], rel=1e-6)
    assert len(st["holes"]) == 1


def test_a_row_round_a_gentle_bend_shares_no_ground_and_leaves_no_gap(tmp_path, capsys):
    """Rows stand on chords; where a run bends by less than the run break (5°),
    neighbours meet on their bisector plane (as a block's modules at a fold): cut where
    the run turns toward its buildings, extended and cut where it turns away. Before,
    round a 120 m arc the inner row shared 4.4 % of its ground (62 m²) and the outer
    row left wedges open at the back (62 m²)."""
    from citysynth.export.audit import footprint, instance_triangles
    from citysynth.skeletons import lonlat_from_local
    arc = [(120 * math.sin(t), 120 - 120 * math.cos(t))
           for t in [i * (math.pi / 3) / 40 for i in range(41)]]
    src = _write(tmp_path / "arc.geojson", {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {
            "type": "LineString", "coordinates": lonlat_from_local(arc, (LON, LAT))}}]})
    out = tmp_path / "o"
    code, err = _run(["street", "--line", str(src), "--side", "both", "-o", str(out),
                      "--no-preview"], capsys)
    assert code == 0, err
    tris = instance_triangles(out / "arc.usda")
    for side in ("structure_00", "structure_01"):      # inside and outside the bend
        feet = [footprint(t) for k, t in sorted(tris.items()) if f"/{side}/" in k]
        total = sum(f.area for f in feet)
        shared = sum(feet[i].intersection(feet[j]).area for i in range(len(feet))
                     for j in range(i + 1, len(feet)) if feet[i].intersects(feet[j]))
        ground = shapely.union_all(feet)
        closed = ground.buffer(1.0, join_style="mitre").buffer(-1.0, join_style="mitre")
        gap = closed.difference(ground).area       # wedges between neighbours
        assert total > 1000 and shared < 0.001 * total, (side, shared, total)
        assert gap < 0.001 * total, (side, gap, total)


@pytest.mark.parametrize("interval", ["[0, 1e400]", "[-1e400, 3]"])
def test_an_infinite_constraint_is_refused_in_the_features_words(tmp_path, capsys, interval):
    """GeoJSON reads 1e400 as infinity: refused at the feature, as city.toml refuses
    it, not later in the solver's words (``stages[0].constraints``)."""
    d = json.loads((EX / "skeletons" / "t_building.geojson").read_text())
    d["features"][0]["properties"]["constraints"] = "@"
    src = _write(tmp_path / "b.geojson",
                 json.dumps(d).replace('"@"', '{"doors": ' + interval + '}'))
    code, err = _run(["building", str(src), "--library", str(EX / "library"),
                      "-o", str(tmp_path / "o"), "--no-preview"], capsys)
    assert code == 2 and "feature 0" in err and "constraint doors" in err, err
    assert "finite" in err and "stages[" not in err, err
    assert not (tmp_path / "o").exists()


def test_an_rfc8142_sequence_is_read_and_an_empty_collection_says_what_to_do(tmp_path,
                                                                           capsys):
    """ogr2ogr -lco RS=YES writes each feature after a record separator (0x1E): read as
    the GeoJSON Text Sequence it is (it was "Expecting value"); an empty
    FeatureCollection says what to do about it."""
    feat = json.dumps({"type": "Feature", "properties": {}, "geometry": {
        "type": "LineString", "coordinates": [[LON, LAT], [LON + 0.001, LAT]]}})
    rs = _write(tmp_path / "rs.geojson", "\x1e" + feat + "\n")
    code, err = _run(["street", "--line", str(rs), "-o", str(tmp_path / "s"),
                      "--no-preview"], capsys)
    assert code == 0 and list((tmp_path / "s").glob("*.layout.json")), err
    empty = _write(tmp_path / "empty.geojson", {"type": "FeatureCollection", "features": []})
    code, err = _run(["street", "--line", str(empty), "-o", str(tmp_path / "o"),
                      "--no-preview"], capsys)
    assert code == 2 and "no features (an empty FeatureCollection); export the layer" in err


_FC = {"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {},
        "geometry": {"type": "LineString", "coordinates": [[LON, LAT], [LON + 0.001, LAT]]}}]}


@pytest.mark.parametrize(("text", "said", "fix"), [
    (json.dumps(_FC) + "\ngarbage here\n", 'text after the end of the JSON ("garbage here")',
     "remove what follows it"),
    (json.dumps(_FC) + "\0" * 64, "64 NUL bytes follow the end of its JSON",
     "write the file again"),
    (json.dumps(_FC, indent=1) + "\n" + json.dumps(_FC), "a second JSON text follows",
     "give one FeatureCollection"),
    ("id,lon,lat\n1,24.9,60.1\n", "CSV or other delimited text, not JSON",
     "ogr2ogr -f GeoJSON out.geojson"),
    ("<!DOCTYPE html><html><body>404 Not Found</body></html>", "an HTML page, not JSON",
     "a download that saved a web or error page"),
    ('<?xml version="1.0"?><gml:FeatureCollection/>', "XML (GML, KML or another XML",
     "ogr2ogr -f GeoJSON out.geojson"),
])
def test_a_file_that_is_not_one_geojson_text_says_what_it_looks_like(tmp_path, capsys,
                                                                     text, said, fix):
    """Junk after the JSON was called "a GeoJSON Text Sequence", NUL padding just
    "Extra data", a CSV or HTML file "Expecting value": each now says what the file
    looks like and what to do, exit 2, nothing written."""
    src = _write(tmp_path / "in.geojson", text)
    code, err = _run(["street", "--line", str(src), "-o", str(tmp_path / "o"),
                      "--no-preview"], capsys)
    assert code == 2 and said in err and fix in err, err
    assert "Extra data" not in err and "Expecting value" not in err, err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.mark.parametrize("text, said", [
    ("\x00" * 1000, "1,000 NUL bytes and no JSON: the file was never written whole"),
    ('{"type": "FeatureCollection", "features": [{"type": "Feat',
     "the file ends inside its JSON, cut short"),
    ('{"type": "FeatureCollection", "features": [', "the file ends inside its JSON"),
    ('{"type": "FeatureCollection", "features": [],}', "a key in double quotes was expected"),
    ('{"type": "FeatureCollection" "features": []}', "a comma was expected here"),
    ('{"type": "FeatureCollection", "features": [1, ]}', "a value (a number, text in"),
])
def test_broken_json_is_told_in_plain_words(tmp_path, capsys, text, said):
    """A file of NUL bytes, a truncated file and the usual slips (a trailing comma, a
    missing one) were told in the JSON parser's own words ("Expecting value",
    "Unterminated string starting at", cut off mid-sentence): found by a probe on
    2026-11-30."""
    src = _write(tmp_path / "in.geojson", text)
    code, err = _run(["street", "--line", str(src), "-o", str(tmp_path / "o"),
                      "--no-preview"], capsys)
    assert code == 2 and said in err, err
    assert not any(w in err for w in ("Expecting", "Unterminated", "delimiter")), err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_a_non_number_coordinate_is_quoted_as_json_writes_it(tmp_path, capsys):
    """A null coordinate was shown as Python's None."""
    bad = copy.deepcopy(_FC)
    bad["features"][0]["geometry"]["coordinates"][1] = [LON + 0.001, LAT, None]
    code, err = _run(["street", "--line", str(_write(tmp_path / "n.geojson", bad)), "-o",
                      str(tmp_path / "o"), "--no-preview"], capsys)
    assert code == 2 and f"got [{LON + 0.001}, {LAT}, null]" in err, err


def _lines_file(path: Path, lines) -> Path:
    """Two-point lines (local metres round LON, LAT) as a GeoJSON file of streets (all
    points projected in one call: a transformer a line took 15 ms)."""
    from citysynth.skeletons.geojson import lonlat_from_local

    pts = np.asarray(lonlat_from_local(np.asarray(lines, dtype=float).reshape(-1, 2),
                                       (LON, LAT))).reshape(-1, 2, 2)
    return _write(path, {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"highway": "residential"},
         "geometry": {"type": "LineString", "coordinates": line.tolist()}}
        for line in pts]})


def test_streets_crossing_a_million_times_are_refused_with_an_estimate(tmp_path, capsys,
                                                                       monkeypatch):
    """3,000 random 1 km segments in a 1 km square cross each other hundreds of
    thousands of times (noding them would take gigabytes): refused before noding, with
    the estimate, exit 2. Before anything is noded: the setbacks' lines were noded and
    joined first, two minutes before the refusal."""
    def noded_first(*_a, **_k):
        raise AssertionError("the setbacks were noded before the crossings were counted")
    monkeypatch.setattr(streets, "_joined_cuts", noded_first)
    rng = np.random.default_rng(5)
    ends = rng.uniform(0, 1000, size=(3000, 2, 2))
    src = _lines_file(tmp_path / "scribble.geojson", ends.tolist())
    code, err = _run(["city", "--streets", str(src), "--library", str(LIB), "-o",
                      str(tmp_path / "o")], capsys)
    assert code == 2 and "3,000 street lines cross each other about" in err, err
    assert not (tmp_path / "o").exists()


def test_one_street_drawn_twenty_thousand_times_is_one_street(tmp_path, capsys):
    """A line given 20,000 times over (a broken export; osmnx gives a two-way street
    twice): noded once. All the pairs of their boxes at once took 6 GB, GEOS noding the
    pile ran out of memory; now it is one street, which encloses no block (exit 1)."""
    src = _lines_file(tmp_path / "pile.geojson", [[(0, 0), (500, 0)]] * 10000
                      + [[(500, 0), (0, 0)]] * 10000)
    code, err = _run(["city", "--streets", str(src), "--library", str(LIB), "-o",
                      str(tmp_path / "o")], capsys)
    assert code == 1 and "the streets enclose no block" in err, err


@pytest.mark.parametrize("name", ["new\nline", "tab\there"])
def test_an_output_folder_whose_path_holds_a_control_character_is_refused(tmp_path, capsys,
                                                                          name):
    """A run into a folder whose path holds a newline or a tab exited 0 and wrote USD
    that usd-core cannot open ("Invalid asset path string -- character 11 is control
    character 0xa"), even from inside the folder. Refused before anything is written."""
    parent = tmp_path / name
    parent.mkdir()
    line = _lines_file(tmp_path / "line.geojson", [[(0, 0), (60, 0)]])
    code, err = _run(["street", "--line", str(line), "-o",
                      str(parent / "out"), "--no-preview"], capsys)
    assert code == 2 and "holds a control character" in err, err
    assert not (parent / "out").exists()


def test_the_depth_walk_holds_one_iterator_a_level_not_every_child():
    """A 99 MB file of 33 million empty lists parsed in 2.4 GB, then the depth check
    stacked every child (a tuple each) and the reader died of MemoryError (exit 3)
    under a 3 GB limit. The walk now holds an iterator a level: walking a million
    empty lists allocates next to nothing."""
    import tracemalloc

    from citysynth.solver.safe_read import depth_error
    data = {"zz": [[] for _ in range(1_000_000)]}
    tracemalloc.start()
    try:
        assert depth_error(data) is False
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000, peak          # the stack of tuples took about 80 MB
    deep: list = []
    for _ in range(150):
        deep = [deep]
    assert depth_error(deep) and depth_error({"a": [{"b": [[]]}]}, 3)
    assert not depth_error({"a": [{"b": 1}]}, 3) and not depth_error(7)
    # lists and objects of scalars are seen whole (by their values' types): what
    # nests behind or among them is still found
    long = [*range(20), {"x": [*"abcdefghij", [[1] * 9]]}, 2.5]
    assert depth_error({"a": long}, 5) and not depth_error({"a": long}, 6)
    assert not depth_error({f"k{i}": i for i in range(30)}, 1)
    assert depth_error({**{f"k{i}": i for i in range(30)}, "z": [1]}, 1)


def test_integers_past_every_float_are_found_without_a_hook_for_each(tmp_path):
    """An integer of 309 digits or more reads as infinity (a float; as an int it
    crashed the first sum), found by a search of the text instead of a hook Python's
    parser called for each of a file's integers (a file of 4 million of them parsed
    65 % slower); digits in a string are no number."""
    from citysynth.solver.safe_read import _past_float, parse_json
    big = "2" + "0" * 308    # 2e308, past the largest float
    assert _past_float(f'{{"a": {big}}}') and not _past_float(f'{{"a": {big[:-1]}}}')
    assert parse_json(f'{{"a": [{big}, -{big}, 7], "b": "{big}"}}', "x.json", "problem",
                      ValueError) == {"a": [math.inf, -math.inf, 7], "b": big}


def test_json_too_large_for_memory_is_refused_not_a_crash(tmp_path, capsys, monkeypatch):
    """JSON that fits the input size limit but not memory once parsed is one message
    and exit 2 (it was a MemoryError traceback, exit 3)."""
    import citysynth.solver.safe_read as safe_read

    path = _write(tmp_path / "p.json", {"elements": []})

    def no_memory(*_a, **_k):
        raise MemoryError
    monkeypatch.setattr(safe_read.json, "loads", no_memory)
    code, err = _run(["solve", str(path)], capsys)
    assert code == 2 and "Traceback" not in err, err
    assert "of JSON that does not fit in the memory this machine gives citysynth" in err, err


def test_an_infeasible_tower_explained_without_memory_is_still_an_answer(tmp_path, capsys,
                                                                          monkeypatch):
    """Explaining why a tower cannot be built grows the reachable totals within the
    solver's memory budget; under a process limit below it (``ulimit -v``, 3 GB) that
    growth met a MemoryError, a traceback (exit 3) for ``tower --height 200.1 --far 1
    100``. The diagnosis now says less and the tower is reported infeasible (exit 1)."""
    import citysynth.solver.diagnose as diagnose

    def no_memory(*_a, **_k):
        raise MemoryError
    monkeypatch.setattr(diagnose, "grow", no_memory)
    code, err = _run(["tower", "--height", "200.1", "--far", "1", "100", "--lot-area", "900",
                      "-o", str(tmp_path / "t"), "--no-preview"], capsys)
    assert code == 1 and "Traceback" not in err and err.strip(), err


def _two_element_problem(length: int, k: int) -> dict:
    return {"resources": ["length"],
            "elements": [{"id": "A", "resources": {"length": 1}},
                         {"id": "B", "resources": {"length": 1}, "cost": 0.001}],
            "transitions": [[a, b, 0] for a in "AB" for b in "AB"],
            "constraints": {"length": [length, length]}, "k": k}


def test_k_long_solutions_past_the_budget_are_refused_with_an_estimate(tmp_path, capsys):
    """k = 1,000,000 solutions of 300 one-metre elements passed the check on k (which
    counts a solution as 2 KB) and died of MemoryError in the enumeration (exit 3);
    they are refused at once with what they would take. As many 60-element ones
    still fit the budget, as they did (1.8 GB)."""
    from citysynth.solver import Problem
    from citysynth.solver.compiled import compile_problem
    from citysynth.solver.entry import check_length
    path = _write(tmp_path / "p.json", _two_element_problem(300, 1_000_000))
    code, err = _run(["solve", str(path)], capsys)
    assert code == 2, err
    assert "k = 1,000,000: keeping that many solutions of at least 300 elements each " \
        "takes at least 4.5 GB, over the memory budget of 2,048 MB" in err, err
    check_length(compile_problem(Problem.from_dict(_two_element_problem(60, 1_000_000))),
                 2048.0, 1_000_000)


def test_structure_wide_shares_kept_for_every_stage_past_the_budget_are_refused(tmp_path,
                                                                               capsys):
    """A 10,000-stage cycle with a structure-wide doors interval of [20,000, 30,000]
    passed the check on shares (30,001, under a million) and then grew, a share for
    every stage, until the kernel killed it at 21 GB. Shares times stages are checked
    against the budget first: refused at once, with the figure."""
    n = 2000
    st = copy.deepcopy(CYCLE)
    st["keypoints"] = [st["keypoints"][0]] * n
    st["stages"] = [{"constraints": {"length": [37.4, 37.4], "doors": [2, 4]}}] * n
    st["constraints"] = {"doors": [4000, 6000]}
    path = _write(tmp_path / "s.json", st)
    code, err = _run(["solve", str(path), "--max-memory", "256"], capsys)
    assert code == 2, err
    assert "structure-wide constraints on doors: 6,001 ways to share the totals, kept for " \
        "each of its 2,000 stages, about 0.7 GB, over the memory budget of 256 MB" in err, err


@pytest.mark.parametrize("kind", ["polygons", "lines"])
def test_one_file_for_streets_and_footprints_with_one_kind_is_told(tmp_path, capsys, kind):
    """``city --streets F --footprints F`` (the README's one-GeoPackage city) on a file
    of footprints only, or of streets only: every feature was the other reader's, none
    was left out with a message to quote, and the run failed (IndexError, exit 3)."""
    feats = [_rect("a", LON), _rect("b", LON + 0.002)]
    if kind == "lines":
        feats = [{"type": "Feature", "properties": {"highway": "residential"},
                  "geometry": {"type": "LineString", "coordinates": f["geometry"][
                      "coordinates"][0][:2]}} for f in feats]
    src = _write(tmp_path / "city.geojson", {"type": "FeatureCollection", "features": feats})
    code, err = _run(["city", "--streets", str(src), "--footprints", str(src), "--library",
                      str(LIB), "-o", str(tmp_path / "run"), "--workers", "1",
                      "--no-overview"], capsys)
    missing = "lines" if kind == "polygons" else "polygons"
    assert code == 2 and f"city.geojson: no {missing} (" in err, err
    assert f"its 2 features are all {kind}" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


def test_a_footprint_too_large_to_lay_out_is_named_as_its_feature(tmp_path, capsys):
    """A 100 km square footprint was failed as "f9224b35296: too large to lay out"
    (its block id only, where every other reason names the file and the feature)."""
    src = _write(tmp_path / "big.geojson", {"type": "FeatureCollection",
                                            "features": [_rect("big", LON, 1.4, 0.9)]})
    code, err = _run(["city", "--footprints", str(src), "--library", str(LIB), "-o",
                      str(tmp_path / "run"), "--workers", "1", "--no-overview"], capsys)
    assert code == 1, err
    (rec,) = json.loads((tmp_path / "run" / "manifest.json").read_text())["blocks"].values()
    assert rec["status"] == "failed", rec
    assert rec["reason"].startswith(f"{src}: feature 0 (big): too large to lay out: "), rec


@pytest.mark.parametrize("corners", [[[0, 0], [1e7, 0], [1e7, 1e7], [0, 1e7]],
                                     [[-200, -200], [300, -200], [300, 300], [-200, 300]],
                                     [[200, 200], [300, 200], [300, 300], [200, 300]]])
def test_a_zone_in_metres_over_lon_lat_streets_is_refused_alike(tmp_path, capsys, corners):
    """A zone's polygon in metres where the streets are lon/lat: one lying within the
    box round the blocks once clipped (a 10,000 km square, one from -200 to 300) was
    applied to every block without a word, one of 100 m was refused."""
    grid = [[(x, 0), (x, 300)] for x in (0, 150, 300)] + \
        [[(0, y), (300, y)] for y in (0, 150, 300)]
    streets = _lines_file(tmp_path / "s.geojson", grid)
    cfg = _write(tmp_path / "c.toml", "[[zone]]\nname = 'z'\nstyle = 'modern'\n"
                                      f"polygon = {json.dumps(corners)}\n")
    code, err = _run(["city", "--streets", str(streets), "--library", str(LIB), "--config",
                      str(cfg), "-o", str(tmp_path / "run"), "--workers", "1",
                      "--no-overview"], capsys)
    assert code == 2 and "city.toml zone 'z': its polygon's points such as " in err, err
    assert "are not longitude/latitude, as the streets' and footprints' are" in err
    assert not (tmp_path / "run").exists()
