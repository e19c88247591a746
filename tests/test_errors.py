"""User errors against bugs: one list of user-error classes (USER_ERRORS), a usage error
for options, and a city worker that reports a bug as a bug (status "error", traceback,
no marker, exit 3) instead of as a block's reason."""

from __future__ import annotations

import ast
import importlib
import json
from pathlib import Path

import pytest

from citysynth.pipeline.city import jobs as city_jobs
from citysynth.pipeline.city.config import CityConfig
from citysynth.pipeline.city.run import prepare
from citysynth.pipeline.cli import build_parser, main
from citysynth.pipeline.errors import (
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    USER_ERRORS,
    ConfigError,
    UsageError,
)
from citysynth.skeletons import SkeletonError

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
LIB = EXAMPLES / "library"
DISTRICT = EXAMPLES / "city" / "district_streets.geojson"
# exceptions used as signals inside citysynth, caught where they are raised' callers and
# never reaching a user (each a deliberate exception to USER_ERRORS)
SIGNALS = {("citysynth.solver.structures.stage_graphs", "NotExact"),
           ("citysynth.parts_db.mesh_faults", "MeshFault"),   # told as a LibraryError
           # the machine's own OSError, carrying the blocks' summary to print before it
           ("citysynth.pipeline.city.outputs", "SummaryNotWritten")}


def _error_classes() -> set[tuple[str, str]]:
    """(module, name) of every class in citysynth's sources derived from an ...Error or
    ...Exception (read from the source, so nothing is imported for it)."""
    found = set()
    for sub in ("solver", "parts_db", "skeletons", "export", "pipeline"):
        folder = Path(importlib.import_module(f"citysynth.{sub}").__path__[0])
        for f in sorted(folder.rglob("*.py")):
            rel = f.relative_to(folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            module = ".".join(["citysynth", sub, *parts])
            for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
                if isinstance(node, ast.ClassDef) and any(
                        ast.unparse(b).endswith(("Error", "Exception")) for b in node.bases):
                    found.add((module, node.name))
    return found


def test_every_error_class_of_citysynth_is_a_listed_user_error():
    """A new error class missing from USER_ERRORS would reach the user as a traceback
    (and a city worker would report it as a bug)."""
    listed = {(c.__module__, c.__name__) for c in USER_ERRORS}
    assert _error_classes() - SIGNALS == listed
    assert all(issubclass(c, ValueError) for c in USER_ERRORS)
    assert issubclass(ConfigError, UsageError)


@pytest.mark.parametrize("argv, fragment", [
    (["solve", str(EXAMPLES / "facade_small.json"), "--k", "0"],
     "--k must be a positive integer, got 0"),
    # the option's fault, not the problem file's (it was said as "facade_small.json: the
    # memory budget must be ...")
    (["solve", str(EXAMPLES / "facade_small.json"), "--max-memory", "-1"],
     "error: --max-memory: the memory budget must be a positive number"),
    (["city", "--streets", str(DISTRICT), "--workers", "0"], "--workers must be at least 1"),
    # a worker holds ~150 MB: 100,000 of them filled the machine until the OOM killer came
    (["city", "--streets", str(DISTRICT), "--workers", "100000"], "GB in all"),
    (["city", "--streets", str(DISTRICT), "--workers", "9" * 20],
     "in all more memory than any machine has"),
])
def test_a_bad_option_exits_2_with_a_usage_message(capsys, argv, fragment):
    assert main(argv) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert fragment in err and f"citysynth {argv[0]}: error:" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    args = build_parser().parse_args(argv)
    with pytest.raises(UsageError):
        args.run(args)


@pytest.fixture(scope="module")
def job():
    return prepare(DISTRICT, None, CityConfig(), LIB).jobs[0]


def _raises(exc: Exception):
    def solve_layouts(*args, **kwargs):
        raise exc
    return solve_layouts


def test_a_bug_in_a_block_is_not_a_user_error(job, tmp_path, monkeypatch):
    monkeypatch.setattr(city_jobs, "solve_layouts", _raises(KeyError("stage 7")))
    rec = city_jobs.run_block(job, str(tmp_path))
    assert rec["status"] == "error" and "reason" not in rec
    assert rec["error"] == "KeyError: 'stage 7'"
    assert "Traceback" in rec["traceback"] and "in solve_layouts" in rec["traceback"]
    # no marker: the next run builds the block again instead of reusing the bug
    assert city_jobs.cached(tmp_path, job) is None
    assert not city_jobs.marker_path(tmp_path, job.id).exists()


def test_a_user_error_in_a_block_is_its_reason(job, tmp_path, monkeypatch):
    monkeypatch.setattr(city_jobs, "solve_layouts",
                        _raises(SkeletonError("two cycles; split the outline")))
    rec = city_jobs.run_block(job, str(tmp_path))
    assert rec["status"] == "failed" and rec["reason"] == "two cycles; split the outline"
    assert "error" not in rec and "traceback" not in rec
    assert city_jobs.cached(tmp_path, job) == rec      # an answer: kept for the rerun


def test_a_city_run_reports_a_bug_with_its_traceback(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(city_jobs, "solve_layouts", _raises(KeyError("stage 7")))
    out = tmp_path / "run"
    code = main(["city", "--streets", str(DISTRICT), "--library", str(LIB), "-o", str(out),
                 "--workers", "1", "--no-overview"])   # one worker: in this process
    assert code == EXIT_INTERNAL
    cap = capsys.readouterr()
    assert "internal error in block" in cap.err and "KeyError: 'stage 7'" in cap.err
    assert "Traceback" in cap.err
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["error"] == len(report["errors"]) > 0
    assert report["failed"] == [] and report["built"] == []
    assert all("KeyError" in e["traceback"] for e in report["errors"])
    manifest = json.loads((out / "manifest.json").read_text())
    assert {b["status"] for b in manifest["blocks"].values()} == {"error"}
    assert not list((out / "blocks").glob("*.done.json"))


def test_any_other_bug_exits_3_with_its_traceback_never_1(tmp_path, capsys, monkeypatch):
    """Exit 1 means "no layout exists": a pipeline branching on it must never see a
    crash there (a building whose solve raised a stray exception exited 1)."""
    from citysynth.pipeline import layouts  # the command imports it when it runs
    monkeypatch.setattr(layouts, "solve_layouts", _raises(ZeroDivisionError("oops")))
    code = main(["building", str(ROOT / "examples" / "skeletons" / "t_building.geojson"),
                 "--library", str(LIB), "-o", str(tmp_path), "--no-preview"])
    assert code == EXIT_INTERNAL
    err = capsys.readouterr().err
    assert "Traceback" in err and "ZeroDivisionError: oops" in err
    assert "internal error (a bug, not your input)" in err.strip().splitlines()[-1]


def test_a_disk_that_fills_while_usd_is_written_is_one_line_exit_2(tmp_path, capsys,
                                                                    monkeypatch):
    """usd-core reports a full disk as its own exception, not an OSError: it is turned
    into one, so the command says so in one line (exit 2) instead of a traceback."""
    from pxr import Sdf, Tf

    def export(self, path, *args, **kwargs):
        raise Tf.ErrorException(f"Could not write {path}: No space left on device")
    monkeypatch.setattr(Sdf.Layer, "Export", export)
    code = main(["block", str(ROOT / "examples" / "blocks" / "block.geojson"), "--library",
                 str(LIB), "-o", str(tmp_path), "--no-preview"])
    assert code == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "Traceback" not in err and "No space left on device" in err
    assert len(err.strip().splitlines()) == 1


def test_a_folder_that_takes_no_file_is_said_of_the_file_asked_for(tmp_path, capsys,
                                                                    monkeypatch):
    """A read-only output folder (a probe's read-only mount): the temporary file a write
    starts with cannot be made, and the message named it (".map.tmp-qljrwxxf.png", for
    `diff --png map.png`); it names the file asked for."""
    import errno
    import tempfile

    def refused(dir=None, prefix="", suffix="", **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied",
                              f"{dir}/{prefix}qljrwxxf{suffix}")
    monkeypatch.setattr(tempfile, "mkstemp", refused)
    code = main(["block", str(ROOT / "examples" / "blocks" / "block.geojson"), "--library",
                 str(LIB), "-o", str(tmp_path / "out"), "--no-preview"])
    err = capsys.readouterr().err
    assert code == EXIT_BAD_INPUT and "Permission denied" in err, err
    assert ".tmp-" not in err and f"{tmp_path / 'out'}/block" in err, err
    assert len(err.strip().splitlines()) == 1


def test_a_bound_past_any_count_is_no_bound(tmp_path):
    """doors = [0, 1e20] on a side: no int64 overflow (it crashed), the same layout as
    no bound at all."""
    line = {"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {
        "constraints": {"doors": [0, 1e20]}}, "geometry": {"type": "LineString",
        "coordinates": [[7.1, 50.73], [7.100566538, 50.729999999]]}}]}
    src = tmp_path / "huge.geojson"
    src.write_text(json.dumps(line))
    free = tmp_path / "free.geojson"
    del line["features"][0]["properties"]["constraints"]
    free.write_text(json.dumps(line))
    for f in (src, free):
        assert main(["building", str(f), "--library", str(LIB), "-o", str(tmp_path / f.stem),
                     "--no-preview"]) == 0
    a, b = (json.loads((tmp_path / n / f"{n}.layout.json").read_text())
            for n in ("huge", "free"))
    assert a["cost"] == b["cost"] and a["parts_used"] == b["parts_used"]


def test_a_building_too_large_to_solve_is_refused_with_an_estimate(tmp_path, capsys):
    """A staircase line of 2,500 corners (6 m steps): refused up front, with what it
    would take, instead of minutes of solving (20,000 ran past 150 s; reading the
    skeleton alone took minutes before its touching-ends check used a tree)."""
    import math
    lon0, lat0 = 7.1, 50.73
    pts = []
    for i in range(2501):
        x, y = 6.0 * ((i + 1) // 2), 6.0 * (i // 2)
        pts.append([lon0 + x / (111320 * math.cos(math.radians(lat0))), lat0 + y / 110540])
    src = tmp_path / "stairs.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "LineString",
                                                          "coordinates": pts}}]}))
    assert main(["building", str(src), "--library", str(LIB), "-o", str(tmp_path / "out"),
                 "--no-preview"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "corners, ends and T junctions" in err and "GB" in err and "split it" in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_block_too_large_is_worded_from_the_refusals_figures():
    """``too_large`` words a city's message from the figures the solver's refusal
    carries (its text speaks of stage graphs; it is never parsed)."""
    from types import SimpleNamespace

    from citysynth.pipeline.layouts import too_large
    from citysynth.solver import TooLargeError

    sk = SimpleNamespace(edges=[SimpleNamespace(length=25.0), SimpleNamespace(length=15.0)])
    shares = TooLargeError("structure-wide constraints on doors, windows: 2,000,000 ways "
                           "to share ...", shares=2_000_000, resources=("doors", "windows"))
    assert too_large("b", [sk], shares) == (
        "b: its per-block intervals on doors, windows leave 2,000,000 ways to share the "
        "totals between its sides, too many to solve; narrow them")
    big = TooLargeError("the graph of stage 3 ...", need_mb=3072.4, budget_mb=2048)
    assert too_large("b", [sk], big) == (
        "b: too large to lay out: 40 m of facade (its longest side 25 m) would take about "
        "3,072 MB to solve, over the 2,048 MB budget; split it into smaller blocks or "
        "buildings")
    assert "too much memory" in too_large("b", [sk], TooLargeError("grew past the budget"))
    many = TooLargeError("k = 10^12 ...", need_mb=2e9, budget_mb=2048, k=10**12)
    assert too_large("b", [sk], many) == (
        "b: k = 1,000,000,000,000 layouts would take at least 1,953,125.0 GB to keep, over "
        "the 2,048 MB budget; ask for fewer (--k)")


def test_config_values_are_quoted_as_the_file_spells_them():
    """city.toml's true, strings and dates came back as Python spells them (True,
    'a', datetime.datetime(1979, 5, 27, ...))."""
    import datetime

    from citysynth.pipeline.city.config import parse_config
    from citysynth.pipeline.errors import ConfigError, shown
    assert shown(True) == "true" and shown("a") == '"a"' and shown(None) == "null"
    assert shown(datetime.datetime(1979, 5, 27, 7, 32)) == "1979-05-27T07:32:00"
    assert shown(["a", 1]) == '["a", 1]' and shown(1000000000) == "1,000,000,000"
    # a float as TOML spells it short (1e9 was 1000000000.0), but only where exact
    assert shown(1e9) == "1e+09" and shown(1234567.0) == "1234567.0" and shown(2.5) == "2.5"
    assert shown(5820000.0) == "5820000.0" and shown(1e-7) == "1e-07"
    for value, says in ((True, "got true"), ("3", 'got "3"'),
                        (datetime.date(1979, 5, 27), "got 1979-05-27")):
        with pytest.raises(ConfigError) as exc:
            parse_config({"k": value})
        assert str(exc.value).endswith(says)


def test_setbacks_past_any_street_are_refused_with_the_most():
    """A setback of 1e300 m (default, a street class's, a zone's) overflowed GEOS's
    buffer into a TopologyException, exit 3: now one line naming the key and the most
    it takes. 500 m is still taken (every block then skipped, as any too-deep inset)."""
    from citysynth.pipeline.city.config import MAX_SETBACK, parse_config
    from citysynth.pipeline.errors import ConfigError

    zone = {"name": "z", "kind": "row", "polygon": [[0, 0], [1, 0], [1, 1]]}
    for data, key in (({"setback": {"default": 1e300}}, "setback.default"),
                      ({"setback": {"highway": {"residential": 1e6}}},
                       "setback.highway.residential"),
                      ({"setback": {"sidewalk": 501.0}}, "setback.sidewalk"),
                      ({"zone": [{**zone, "setback": 1e300}]}, "setback")):
        with pytest.raises(ConfigError) as exc:
            parse_config(data)
        text = str(exc.value)
        assert key in text and f"must be at most {MAX_SETBACK:g}, got" in text, text
    assert parse_config({"setback": {"default": MAX_SETBACK}}).setbacks.default == MAX_SETBACK


def _squares(tmp_path, name: str, centres: list[tuple[float, float]]):
    """A GeoJSON file of 40 x 30 m footprints around each (lon, lat)."""
    from citysynth.skeletons.geojson import lonlat_from_local

    ring = [(0, 0), (40, 0), (40, 30), (0, 30), (0, 0)]
    feats = [{"type": "Feature", "properties": {"building": "yes"},
              "geometry": {"type": "Polygon", "coordinates": [lonlat_from_local(ring, c)]}}
             for c in centres]
    f = tmp_path / f"{name}.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    return f


def test_data_too_far_apart_for_one_frame_are_refused(tmp_path, capsys):
    """Footprints in Helsinki and Santiago de Chile were put in one local frame centred
    between them and built 7.7 % too large, exit 0; a city.toml origin 1,900 km from
    the streets 4.4 % too large. Now refused (exit 2, nothing written), saying how far
    and what to do; data 1,000 km apart east to west are built with a warning (0.3 %);
    a city is not (its frame is true to 0.001 %)."""
    import warnings as w

    from citysynth.skeletons import InputWarning
    from citysynth.skeletons.geojson import read_geojson

    lib = str(Path(__file__).resolve().parent.parent / "examples" / "library")
    far = _squares(tmp_path, "far", [(24.94, 60.17), (-70.65, -33.45)])
    out = tmp_path / "out"
    assert main(["city", "--footprints", str(far), "--library", lib, "-o", str(out),
                 "--workers", "1", "--no-overview"]) == 2
    err = capsys.readouterr().err
    assert "km east or west of the run's frame centre" in err and "too long" in err
    assert "run each city or region on its own" in err and "Traceback" not in err
    assert not out.exists()
    # a quarter of the globe apart: the projection has no finite x there ("inf km" before)
    across = _squares(tmp_path, "across", [(-90.0, 0.0), (90.0, 0.0)])
    assert main(["city", "--footprints", str(across), "--library", lib, "-o", str(out),
                 "--workers", "1", "--no-overview"]) == 2
    err = capsys.readouterr().err
    assert "degrees of longitude east or west" in err and "inf" not in err, err
    assert not out.exists()
    near = _squares(tmp_path, "near", [(24.94, 60.17), (24.96, 60.18)])
    cfg = tmp_path / "city.toml"
    cfg.write_text("origin = [-120.0, -45.0]\n")
    assert main(["city", "--footprints", str(near), "--library", lib, "-o", str(out),
                 "--workers", "1", "--no-overview", "--config", str(cfg)]) == 2
    assert "origin in city.toml" in capsys.readouterr().err and not out.exists()
    wide = _squares(tmp_path, "wide", [(2.0, 48.0), (15.5, 48.0)])      # about 1,000 km apart
    with pytest.warns(InputWarning, match=r"0\.\d% too long"):
        read_geojson(wide, accept="polygons")
    with w.catch_warnings():
        w.simplefilter("error", InputWarning)
        read_geojson(near, accept="polygons")


@pytest.mark.parametrize("name, kind", [("blocks", "file"), ("report.json", "folder"),
                                        ("city.usda", "folder")])
def test_a_run_folder_with_the_wrong_kind_of_entry_is_refused_first(tmp_path, capsys, name,
                                                                    kind):
    """A file named ``blocks`` made every block fail "a failure of the machine" (exit 1)
    and marked them all failed in a rewritten manifest; a folder named ``report.json``
    or ``city.usda`` was refused only after every block was solved and written. Both are
    now one line, exit 2, before anything is solved or written."""
    from tests.test_faults import grid_streets

    out = tmp_path / "run"
    out.mkdir()
    if kind == "file":
        (out / name).write_text("not a folder")
    else:
        (out / name).mkdir()
    streets = grid_streets(tmp_path / "streets.geojson", blocks=1)
    lib = str(Path(__file__).resolve().parent.parent / "examples" / "library")
    assert main(["city", "--streets", str(streets), "--library", lib, "-o", str(out),
                 "--workers", "1", "--no-overview"]) == 2
    err = capsys.readouterr().err
    assert f"{out / name}: a {kind} where the run " in err and "give another -o" in err, err
    assert len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in out.iterdir()) == [name]     # nothing else written


def test_a_courtyard_drawn_as_its_own_outline_is_no_building(tmp_path):
    """A footprint whose courtyard is its outline covers no ground: GEOS's repair made
    it the solid outline and the city built a 60 x 40 m house (``block`` refused it). It
    is now left out with the reason, as an outline crossing itself is; a repair that
    keeps the ground (a spike drawn out and back) still builds."""
    from citysynth.skeletons.geojson import lonlat_from_local

    ring = [(0, 0), (60, 0), (60, 40), (0, 40), (0, 0)]
    spike = [(0, 0), (30, 0), (30, -8), (30, 0), (60, 0), (60, 40), (0, 40), (0, 0)]
    feats = [{"type": "Feature", "properties": {"id": i, "building": "yes"},
              "geometry": {"type": "Polygon", "coordinates": [
                  lonlat_from_local([(x + 100 * i, y) for x, y in r], (24.94, 60.17))
                  for r in rings]}}
             for i, rings in enumerate([[ring, ring], [spike]])]
    fp = tmp_path / "fp.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    lib = str(Path(__file__).resolve().parent.parent / "examples" / "library")
    out = tmp_path / "run"
    assert main(["city", "--footprints", str(fp), "--library", lib, "-o", str(out),
                 "--workers", "1", "--no-overview"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["built"] == 1, report["counts"]
    reasons = [s["reason"] for s in report["skipped"]]
    assert len(reasons) == 1 and "feature 0 (0): its outline is invalid: self-intersection" \
        in reasons[0], reasons


def test_no_error_line_is_longer_than_a_screenful(tmp_path, capsys):
    """A 10 MB style string in city.toml was quoted whole in the refusal (10 MB on
    stderr): a value is quoted short, and no error line passes 2,000 characters."""
    from citysynth.pipeline.cli import MESSAGE_MOST
    from tests.test_faults import grid_streets

    cfg = tmp_path / "city.toml"
    cfg.write_text(f'style = "{"a" * 1_000_000}"\n')
    lib = str(Path(__file__).resolve().parent.parent / "examples" / "library")
    assert main(["city", "--streets", str(grid_streets(tmp_path / "s.geojson", 1)),
                 "--library", lib, "--config", str(cfg), "-o", str(tmp_path / "out"),
                 "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert "has no style" in err and len(err) < 300, len(err)
    from citysynth.pipeline.cli import _cut
    long = _cut("x" * 5000)
    assert len(long) <= MESSAGE_MOST and long.endswith("(cut: 5,000 characters in all)")


@pytest.mark.parametrize("data, key, says", [
    ({"zone": [{"name": 5, "highway": ["primary"]}]}, "zone[0].name", "must be text, got 5"),
    ({"zone": [{"name": "old", "highway": ["primary"]},
               {"name": "old", "highway": ["secondary"]}]}, "zone[1].name",
     '"old" names zone[0] too'),
    ({"corner_tolerance": 360}, "corner_tolerance", "must be at most 90, got 360"),
    ({"footprints": {"tolerance": 1e9}}, "footprints.tolerance",
     "must be at most 10, got 1e+09"),
    ({"footprints": {"storeys": {"classic": {"a": 100000}}}}, "footprints.storeys.classic.a",
     "a whole number from 1 to 200), got 100,000"),
    ({"mitre_cost": 1e308}, "mitre_cost", "must be at most 1e+15 (a cost this large sums to "
                                          "infinity), got 1e+308"),
    ({"mitre_cost": 1.7e308}, "mitre_cost", "must be at most 1e+15"),
    ({"mitre_cost": 1e16}, "mitre_cost", "must be at most 1e+15"),
])
def test_config_values_no_city_means_are_refused(data, key, says):
    """city.toml values a probe found taken without a word: a zone named by a number or
    by another zone's name (reports tell zones by name), a corner bent by 360°, a
    footprint outline moved by a million km, a facade family of 100,000 storeys, a
    mitre cost past the solver's bound on costs (1e308 summed to infinity, and every
    footprint with a mitre failed as "allow more stretch")."""
    from citysynth.pipeline.city.config import parse_config
    from citysynth.pipeline.errors import ConfigError

    with pytest.raises(ConfigError) as exc:
        parse_config(data)
    assert key in str(exc.value) and says in str(exc.value), str(exc.value)


def test_a_mitre_cost_past_the_solvers_bound_is_refused_before_the_run(tmp_path, capsys):
    """``mitre_cost = 1e308`` was taken: the city ran, and footprints whose costs summed
    to infinity failed with "its sides can each be made ... but not all of them at
    once; allow more stretch" (exit 1). Now city.toml is refused at load, one line
    naming the key and the bound the solver holds costs to (exit 2, nothing written);
    the bound itself is taken."""
    from citysynth.pipeline.city.config import parse_config
    from citysynth.solver.problem import MAX_COST
    from tests.test_faults import grid_streets

    assert parse_config({"mitre_cost": MAX_COST}).mitre_cost == MAX_COST
    cfg = tmp_path / "city.toml"
    cfg.write_text("mitre_cost = 1e308\n")
    lib = str(Path(__file__).resolve().parent.parent / "examples" / "library")
    out = tmp_path / "out"
    assert main(["city", "--streets", str(grid_streets(tmp_path / "s.geojson", 1)),
                 "--library", lib, "--config", str(cfg), "-o", str(out),
                 "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert f"{cfg}: mitre_cost: must be at most 1e+15" in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not out.exists()
