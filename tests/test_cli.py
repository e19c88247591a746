"""The command line: exit codes 0/1/2, JSON output, one-line errors."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from citysynth.pipeline.cli import main
from tests.test_gltf import assert_clean

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"


def test_solve_prints_solutions(capsys):
    assert main(["solve", str(EXAMPLES / "facade_small.json")]) == 0
    out = capsys.readouterr().out
    assert "status: ok" in out and "A B A B" in out


def test_solve_json(capsys):
    assert main(["solve", str(EXAMPLES / "facade_small.json"), "--json", "--k", "2"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["status"] == "ok"
    assert [s["sequence"] for s in d["solutions"]] == [["A", "B", "A", "B"],
                                                       ["A", "B", "B", "A"]]
    assert d["solutions"][0]["cost"] == 1.25
    assert d["solutions"][0]["resources"] == {"length": 20.4, "doors": 2.0}
    assert {"nodes", "setup_s", "solve_s"} <= set(d["stats"])


def test_infeasible_exits_1_with_reason(capsys):
    assert main(["solve", str(EXAMPLES / "facade_infeasible.json"), "--json"]) == 1
    cap = capsys.readouterr()
    d = json.loads(cap.out)
    assert d["status"] == "infeasible" and d["solutions"] == []
    assert "length = 20" in d["reason"] and "20.4" in d["reason"]
    assert "length = 20" in cap.err


@pytest.mark.parametrize("content, fragment", [
    ("{not json", "not valid JSON at line 1"),
    ('{"resources": ["length"], "elements": []}', '"elements" must be a non-empty list'),
])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, content, fragment):
    f = tmp_path / "p.json"
    f.write_text(content)
    assert main(["solve", str(f)]) == 2
    err = capsys.readouterr().err
    assert fragment in err and str(f) in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_too_large_exits_2(tmp_path, capsys):
    d = json.loads((EXAMPLES / "street_front.json").read_text())
    d["quantum"] = {"length": 0.0001}
    f = tmp_path / "big.json"
    f.write_text(json.dumps(d))
    # the intermediate graph refuses it (auto solves it: no bound table fits, and a
    # search without one still reaches the answer within the budget)
    assert main(["solve", str(f), "--max-memory", "64", "--method", "rcksp"]) == 2
    err = capsys.readouterr().err
    assert "problem too large" in err and "coarser quantum" in err


def test_console_script_runs_as_a_process():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-m", "citysynth.pipeline.cli", "solve",
                        str(EXAMPLES / "street_front.json"), "--k", "3", "--json"],
                       capture_output=True, text=True, env=env, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    sols = json.loads(p.stdout)["solutions"]
    assert len(sols) == 3 and all(s["resources"]["length"] == 83.4 for s in sols)


def test_demo(capsys, tmp_path):
    assert main(["demo", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "83.4 m street front" in out and out.count("length 83.4") == 3
    assert "UsdValidation: clean" in out and "0 failed" in out
    for name in ("t_building_1.usda", "t_building_3.png", "block.usda", "block.glb",
                 "city.usda", "city.png", "manifest.json", "report.json"):
        assert (tmp_path / name).is_file(), name
    # every GLB the demo writes passes Khronos's glTF Validator (tests/test_gltf.py)
    assert_clean(sorted(tmp_path.rglob("*.glb")))


SOLVER_WORDS = ("stage", "key element", "joint:", "constraint", "resource", "front", "back")


def _geojson(tmp_path: Path, name: str, geometry: dict) -> Path:
    f = tmp_path / f"{name}.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": geometry}]}))
    return f


@pytest.mark.parametrize("command, geometry, side", [
    ("building", "LineString", "the 6.00 m side from (7.100000, 50.730000) to (7.100085, "
     "50.730000): no row of the classic kit's parts fits it between the parts its ends "
     "take (the nearest they make there is 7.80 m)"),
    ("block", "Polygon", "the 2.50 m side from (7.100000, 50.730000) to (7.100035, "
     "50.730000): the classic kit makes 2.8 m here, 12 % away, past the 5 % stretch "
     "allowed: the side's length in the data must change"),
])
def test_a_building_or_block_that_cannot_be_built_is_told_in_sides_and_metres(
        tmp_path, capsys, command, geometry, side):
    """Exit 1, and the side named where it is in the input, how long, and what to change;
    no solver words (stages, key elements, joints' ids, constraints)."""
    from citysynth.skeletons.geojson import lonlat_from_local
    origin = (7.1, 50.73)
    if geometry == "LineString":   # a staircase: a 6 m first step between an end and a mitre
        coords = lonlat_from_local([(0, 0), (6, 0), (6, 6), (12, 6), (12, 12)], origin)
    else:                          # a 2.5 m deep block, shorter than any module
        coords = [lonlat_from_local([(0, 0), (2.5, 0), (2.5, 30), (0, 30), (0, 0)], origin)]
    f = _geojson(tmp_path, "x", {"type": geometry, "coordinates": coords})
    code = main([command, str(f), "--library", str(EXAMPLES / "library"), "--style",
                 "classic", "-o", str(tmp_path / "out"), "--no-preview"])
    err = capsys.readouterr().err
    # the 2.5 m block is told thin first (a note, not the failure)
    thin = [line for line in err.splitlines() if "wide on average" in line]
    assert len(thin) == (command == "block")
    told = "\n".join(line for line in err.splitlines() if line not in thin)
    assert code == 1 and told.startswith(f"citysynth {command}: cannot build x: {side}"), err
    assert "stretch" in err
    assert not any(w in err.lower() for w in SOLVER_WORDS), err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_sides_own_interval_no_parts_meet_is_told_with_what_they_make(tmp_path, capsys):
    from citysynth.skeletons.geojson import lonlat_from_local
    f = tmp_path / "x.geojson"
    f.write_text(json.dumps({"type": "Feature", "properties": {
        "constraints": {"doors": [0.5, 0.7]}}, "geometry": {"type": "LineString",
        "coordinates": lonlat_from_local([(0, 0), (40, 0)], (7.1, 50.73))}}))
    code = main(["building", str(f), "--library", str(EXAMPLES / "library"), "-o",
                 str(tmp_path / "out"), "--no-preview"])
    err = capsys.readouterr().err
    assert code == 1 and err == (
        "citysynth building: cannot build x: the 40.00 m side from (7.100000, 50.730000) to "
        "(7.100567, 50.730000): its doors in [0.5, 0.7] cannot be met by the classic kit's "
        "parts, which make 0 or 1 there; widen the interval\n"), err


def test_a_block_too_large_to_solve_is_told_in_metres_and_megabytes(tmp_path, capsys):
    """A block 470 km across (one a run's frame still holds true to 0.1 %): exit 2, its
    facade length, what it would take against the budget, and to split it; not the
    solver's stage graphs, states and quanta."""
    err = _refused_block(tmp_path, capsys, "x", [[0, 45], [6, 45], [6, 51], [0, 51],
                                                 [0, 45]])
    assert re.fullmatch(r"citysynth block: error: \S+/x\.geojson: feature 0: too large to lay "
                        r"out: [\d,]+ m of facade "
                        r"\(its longest side [\d,]+ m\) would take about [\d,]+ MB to solve, "
                        r"over the [\d,]+ MB budget; split it into smaller blocks or "
                        r"buildings\n", err), err
    assert not any(w in err.lower() for w in SOLVER_WORDS + ("quantum", "states")), err


def test_a_block_file_repeating_one_outline_lays_it_out_once(tmp_path, capsys):
    """One 80 x 40 m polygon given 40 times (a broken export): laid out once, the first
    copies told one by one and the rest counted in one line. It was laid out 40 times
    (2,000 copies: minutes without a word, each copy met every other in the gap and
    party-wall checks first)."""
    ring = [[24.94, 60.17], [24.9414, 60.17], [24.9414, 60.17036], [24.94, 60.17036],
            [24.94, 60.17]]
    f = tmp_path / "copies.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {},
         "geometry": {"type": "Polygon", "coordinates": [ring]}}] * 40}))
    out = tmp_path / "out"
    assert main(["block", str(f), "--library", str(EXAMPLES / "library"), "-o", str(out),
                 "--no-preview"]) == 0
    captured = capsys.readouterr()
    told = [line for line in captured.err.splitlines() if "the same outline as" in line]
    assert told == [f"citysynth block: {f}: feature {n}: the same outline as feature 0, "
                    "laid out once" for n in (1, 2, 3)]
    assert (f"citysynth block: {f}: 36 more features repeat an outline given before "
            "them; each outline laid out once") in captured.err
    assert sorted(p.name for p in out.glob("*.layout.json")) == ["copies.layout.json"]


def test_a_features_own_fault_names_its_file(tmp_path, capsys):
    """A block feature's constraint no part has, and a street line whose offset folds
    at a tight bend: the message named the feature, or said "the street line", but not
    the file (found by a probe on 2026-11-30)."""
    ring = [[7.1, 50.73], [7.1008, 50.73], [7.1008, 50.7305], [7.1, 50.7305], [7.1, 50.73]]
    f = tmp_path / "h.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "h", "constraints": {"unicorns": [1, 2]}},
         "geometry": {"type": "Polygon", "coordinates": [ring]}}]}))
    assert main(["block", str(f), "--library", str(EXAMPLES / "library"), "-o",
                 str(tmp_path / "o"), "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"citysynth block: error: {f}: feature 0 (h): ") and \
        "'unicorns'" in err, err
    line = tmp_path / "l.geojson"   # and a building's line (its own fault named no file)
    line.write_text(json.dumps({"type": "Feature", "properties": {
        "constraints": {"unicorns": [1, 2]}}, "geometry": {
        "type": "LineString", "coordinates": [[7.1, 50.73], [7.1008, 50.73]]}}))
    assert main(["building", str(line), "--library", str(EXAMPLES / "library"), "-o",
                 str(tmp_path / "o"), "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"citysynth building: error: {line}: ") and "'unicorns'" in err, err
    from citysynth.skeletons.geojson import lonlat_from_local
    spiral = lonlat_from_local([(0, 0), (40, 0), (40, 3), (1, 3), (1, 1.5), (30, 1.5)],
                               (7.1, 50.73))
    s = tmp_path / "spiral.geojson"
    s.write_text(json.dumps({"type": "Feature", "properties": {},
                             "geometry": {"type": "LineString", "coordinates": spiral}}))
    assert main(["street", "--line", str(s), "-o", str(tmp_path / "o"),
                 "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"citysynth street: error: {s}: the street line "), err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def _refused_block(tmp_path: Path, capsys, name: str, ring: list) -> str:
    """``citysynth block`` on one lon/lat ring: refused (exit 2) with nothing written;
    its stderr."""
    f = _geojson(tmp_path, name, {"type": "Polygon", "coordinates": [ring]})
    code = main(["block", str(f), "--library", str(EXAMPLES / "library"), "-o",
                 str(tmp_path / "out"), "--no-preview"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert not (tmp_path / "out").exists()
    return err


def test_a_spike_in_an_outline_is_refused_as_one(tmp_path, capsys):
    """A ring point going out and straight back (a corner of 0°) was told as a nose
    "2030998.7 m back along each facade"; now as the spike it is, where it is."""
    from citysynth.skeletons.geojson import lonlat_from_local
    ring = lonlat_from_local([(0, 0), (40, 0), (40, 20), (70, 20), (40, 20 + 1e-4),
                              (40, 40), (0, 40), (0, 0)], (7.1, 50.73))
    err = _refused_block(tmp_path, capsys, "spiky", ring)
    assert err.count("\n") == 1 and "a side turns straight back on itself" in err, err
    assert "a spike" in err and "m back along" not in err, err


@pytest.mark.parametrize("degrees, code", [(0.7, 2), (1.0, 2), (5.0, 0)])
def test_a_hairpin_too_sharp_for_its_sides_is_refused_where_it_is(tmp_path, capsys, degrees,
                                                                   code):
    """A skeleton line doubling back on itself: the nose squaring off its tip would sit
    NOSE / (2 sin(angle / 2)) back along each facade, past the end of its 40 m sides
    below about 2.9°; refused naming the corner and where it is (it failed as "stage 0:
    parts do not meet ..., 125197.4 mm apart"). At 5° the nose fits, and it builds."""
    import math

    from citysynth.skeletons.geojson import lonlat_from_local
    a = math.radians(degrees)
    coords = lonlat_from_local([(0, 0), (40, 0), (40 - 40 * math.cos(a), 40 * math.sin(a))],
                               (7.1, 50.73))
    f = _geojson(tmp_path, "pin", {"type": "LineString", "coordinates": coords})
    got = main(["building", str(f), "--library", str(EXAMPLES / "library"), "-o",
                str(tmp_path / "out"), "--no-preview"])
    err = capsys.readouterr().err
    assert got == code, err
    if code:
        back = 2.0 / (2 * math.sin(a / 2))
        assert err == (f"citysynth building: error: {f}: pin: the convex corner of {degrees:.1f}° "
                       "at (7.100567, 50.730000) is too sharp for its sides: its tip is "
                       f"squared off by a 2 m end wall {back:.1f} m back along each facade, "
                       "past the end of its 40.0 m side; open the corner up or lengthen its "
                       "sides\n")
        assert not (tmp_path / "out").exists()


def test_a_block_whose_facade_would_not_fit_the_budget_is_refused_at_once(tmp_path, capsys):
    """A 40 km square block (160 km of facade): refused from its facade length before
    anything is solved (a 100 km square ran five minutes and peaked at 5.9 GB)."""
    from citysynth.skeletons.geojson import lonlat_from_local
    ring = lonlat_from_local([(0, 0), (40000, 0), (40000, 40000), (0, 40000), (0, 0)],
                             (7.1, 50.73))
    err = _refused_block(tmp_path, capsys, "big", ring)
    assert re.search(r"big\.geojson: feature 0: too large to lay out: 1[56]\d,\d\d\d m of "
                     r"facade \(its longest side [34]\d,\d\d\d m\) would take about "
                     r"2,[34]\d\d MB to solve, over the 2,048 MB budget; split it", err), err


def test_a_failure_while_writing_leaves_no_half_result(tmp_path, capsys, monkeypatch):
    """A part mesh damaged after ingest fails the export after the layout JSON was
    written: the command leaves the output folder as it found it (it left the JSON and
    part files behind). (A mesh changed before the command starts is refused when the
    database is read, before anything is written; here it is damaged as if during the
    run, after that check.)"""
    import shutil

    from citysynth.parts_db import ingest, library
    lib = tmp_path / "lib"
    shutil.copytree(EXAMPLES / "library", lib)
    ingest(lib, tmp_path / "db")
    for mesh in (lib / "meshes").glob("*.glb"):
        mesh.write_bytes(mesh.read_bytes()[:100])
    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("the user's own file\n")
    assert main(["building", str(EXAMPLES / "skeletons" / "t_building.geojson"), "--library",
                 str(tmp_path / "db"), "-o", str(out), "--no-preview"]) == 2
    assert "whose manifest or meshes have changed since" in capsys.readouterr().err
    assert sorted(p.name for p in out.rglob("*")) == ["mine.txt"]
    monkeypatch.setattr(library, "_check_still_its_library", lambda db, folder: None)
    code = main(["building", str(EXAMPLES / "skeletons" / "t_building.geojson"), "--library",
                 str(tmp_path / "db"), "-o", str(out), "--no-preview"])
    err = capsys.readouterr().err
    assert code == 2 and "ingest the library again" in err, err
    assert sorted(p.name for p in out.rglob("*")) == ["mine.txt"]
    code = main(["building", str(EXAMPLES / "skeletons" / "t_building.geojson"), "--library",
                 str(tmp_path / "db"), "-o", str(tmp_path / "fresh"), "--no-preview"])
    assert code == 2 and not (tmp_path / "fresh").exists()


@pytest.mark.parametrize("argv, said", [
    (["solve", "p.json", "--bogus"], "citysynth solve: error: unknown option --bogus; see "
                                     "citysynth solve --help"),
    (["solve", "a.json", "b.json"], "citysynth solve: error: unexpected argument b.json; see "
                                    "citysynth solve --help"),
    (["street", "--line"], "citysynth street: error: --line: needs a value; see citysynth "
                           "street --help"),
    (["street", "--line", "s.geojson", "--doors", "1"],
     "citysynth street: error: --doors: needs 2 values; see citysynth street --help"),
    (["street"], "citysynth street: error: missing --line; see citysynth street --help"),
    (["street", "--line", "s.geojson", "--side", "up"],
     "citysynth street: error: --side: 'up' is not one of 'left', 'right', 'both'; see "
     "citysynth street --help"),
    (["block", "b.geojson", "--library", "lib", "--k", "abc"],
     "citysynth block: error: --k: 'abc' is not a whole number; see citysynth block --help"),
    (["tower", "--height", "tall", "--far", "2", "--lot-area", "900"],
     "citysynth tower: error: --height: 'tall' is not a number; see citysynth tower --help"),
    (["bogus"], "citysynth: error: 'bogus' is not a command; one of 'solve', 'ingest', "
                "'skeleton', 'building', 'block', 'tower', 'street', 'city', 'diff', 'demo', "
                "'gallery'; see citysynth --help"),
    ([], "citysynth: error: no command given; see citysynth --help"),
    # "" (an unset shell variable) is no name: `ingest ""` read the current folder and
    # said "manifest.toml: missing"; `street --line ""` "a folder, not a GeoJSON file"
    (["ingest", ""], "citysynth ingest: error: LIBRARY: empty (''); give a value; see "
                     "citysynth ingest --help"),
    (["street", "--line", " "], "citysynth street: error: --line: empty (' '); give a value; "
                                "see citysynth street --help"),
    (["building", "b.geojson", "--library", "x", "--style", ""],
     "citysynth building: error: --style: empty (''); give a value; see citysynth building "
     "--help"),
])
def test_a_usage_mistake_is_one_line_saying_where_to_read_more(capsys, argv, said):
    """argparse printed its usage block (4+ lines) before the error; now the error alone,
    with the command's --help to read, exit 2 (returned, as every other exit is)."""
    assert main(argv) == 2
    cap = capsys.readouterr()
    assert cap.err.splitlines() == [said] and cap.out == ""


def test_help_still_prints_the_whole_usage(capsys):
    assert main(["street", "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: citysynth street [-h] --line FILE") and "--doors LO HI" in out


def test_a_block_file_of_many_features_says_how_far_it_has_got(tmp_path, capsys):
    """500 blocks with previews ran minutes without a word: from 20 features, the
    command says at each tenth how many are laid out, then written."""
    feats = []
    for i in range(20):
        x0 = 7.1 + i * 0.001
        ring = [[x0, 50.73], [x0 + 0.0005, 50.73], [x0 + 0.0005, 50.7303], [x0, 50.7303],
                [x0, 50.73]]
        feats.append({"type": "Feature", "properties": {"id": f"b{i}"},
                      "geometry": {"type": "Polygon", "coordinates": [ring]}})
    f = tmp_path / "many.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    assert main(["block", str(f), "--library", str(EXAMPLES / "library"), "--no-preview",
                 "-o", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    told = [line.strip() for line in err.splitlines()]
    assert [t for t in told if t.startswith("laid out")] == \
        [f"laid out {2 * i} of 20 ({10 * i} %)" for i in range(1, 11)]
    assert told[-1] == "written 20 of 20 (100 %)"


def test_a_ctrl_c_during_the_mesh_import_is_held_until_it_is_in(monkeypatch):
    """trimesh wraps its optional imports in ``except BaseException``: a Ctrl-C in
    the first half second of ``ingest`` was swallowed there (the command ran on and
    wrote its database, exit 0) or left a half-made module (a TypeError traceback);
    VTK, under pyvista, segfaulted when it landed in its import (half a folder of
    outputs left). Such imports run with Ctrl-C noted; it is raised once they end."""
    import importlib
    import os
    import signal
    import sys
    import time

    from citysynth.export import imports

    real_import = importlib.import_module
    done: list[str] = []

    def importing(name, *a, **k):
        if name in ("trimesh", "tabnanny"):
            os.kill(os.getpid(), signal.SIGINT)   # Ctrl-C while it is being imported
            time.sleep(0.05)                      # (unheld, it would land here)
            done.append(name)
        return real_import(name, *a, **k)

    monkeypatch.setattr(imports.importlib, "import_module", importing)
    # (preview, which imports VTK, is not imported anew here: a second module object
    # would stay its package's attribute and part other tests from their patches)
    for name in ("trimesh", "tabnanny"):
        monkeypatch.delitem(sys.modules, name, raising=False)
        with pytest.raises(KeyboardInterrupt):
            imports.import_shielded(name)
    assert done == ["trimesh", "tabnanny"]
    assert imports.import_shielded("trimesh") is sys.modules["trimesh"]   # loaded: as is
