"""blocks.geojson, what a city run leaves for a GIS user: every block with its status
and reason and every piece skipped before it became a block, in the input's CRS (plain
RFC 7946 lon/lat for lon/lat input, the input's projected CRS named in a ``crs`` member
otherwise), so it lies on the streets it came from in QGIS: read back through the same
reader, each outline lands on its block's outline in the city frame within 1 mm."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from shapely.geometry import shape

from citysynth.pipeline.city.config import load_config
from citysynth.pipeline.city.folder import BLOCKS_GEOJSON
from citysynth.pipeline.city.jobs import run_block
from citysynth.pipeline.city.outputs import (
    write_blocks_geojson,
    write_city_glb,
    write_summary,
)
from citysynth.pipeline.city.run import prepare
from citysynth.pipeline.cli import main
from citysynth.skeletons import parse_geojson
from tests.test_gltf import assert_clean, glb_json

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
CITY = ROOT / "examples" / "city"
DISTRICT = CITY / "district_streets.geojson"


def _records(inputs) -> dict[str, dict]:
    """A run's records: the first block failed, the second skipped, the others built."""
    recs = {}
    for n, job in enumerate(inputs.jobs):
        if n == 0:
            recs[job.id] = {"status": "failed", "reason": "side from 1 to 2: no layout"}
        elif n == 1:
            recs[job.id] = {"status": "skipped", "reason": "nothing buildable is left"}
        else:
            recs[job.id] = {"status": "built", "rank": 1, "of": 1, "cost": 12.5}
    return recs


def _check_round_trip(doc: dict, inputs) -> None:
    blocks = [f for f in doc["features"] if f["properties"]["id"] is not None]
    assert [f["properties"]["id"] for f in blocks] == [j.id for j in inputs.jobs]
    assert blocks[0]["properties"]["status"] == "failed"
    assert blocks[0]["properties"]["reason"] == "side from 1 to 2: no layout"
    assert blocks[1]["properties"]["status"] == "skipped"
    assert {f["properties"]["status"] for f in blocks[2:]} == {"built"}
    skipped = [f for f in doc["features"] if f["properties"]["id"] is None]
    assert len(skipped) == len(inputs.skipped) > 0
    assert all(f["properties"]["reason"] for f in skipped)
    # a skipped piece of a block (a sliver, what the setbacks leave) shows where it was
    pieces = [f for f in skipped if f["properties"]["kind"] == "block"]
    assert pieces and all(f["geometry"]["type"] == "MultiPolygon" for f in pieces)
    if doc.get("crs") is None:        # lon/lat: the pieces lie among the blocks
        area = shapely.union_all([shape(f["geometry"]) for f in blocks]).envelope.buffer(0.01)
        assert all(shape(f["geometry"]).within(area) for f in pieces)
        # and their reasons say where in lon/lat, as the data has it (local metres
        # before: "block 3 at (-375.5, -376.9)")
        for f in pieces:
            x, y = map(float, re.search(r" at \((-?[\d.]+), (-?[\d.]+)\)",
                                        f["properties"]["reason"]).groups())
            assert shapely.Point(x, y).within(area), f["properties"]["reason"]
    feats, _frame = parse_geojson({**doc, "features": blocks}, "blocks.geojson",
                                  origin=inputs.frame.origin)
    for feat, job in zip(feats, inputs.jobs, strict=True):
        want = shapely.from_wkt(job.wkt)
        assert feat.geometry.symmetric_difference(want).area < 1e-3 * want.length
        assert shapely.hausdorff_distance(feat.geometry, want) < 1e-3


def test_what_footprints_take_of_a_street_block_is_told_in_lonlat():
    """A street block whose ground the footprints take, or whose yards they close, is
    skipped with where it is in the data's lon/lat (the run's local metres before:
    "block at (-375.5, -376.9)")."""
    inputs = prepare(DISTRICT, CITY / "district_buildings.geojson",
                     load_config(CITY / "city.toml"), LIB)
    taken = [s["reason"] for s in inputs.skipped if "footprint buildings" in s["reason"]]
    assert taken
    for reason in taken:
        lon, lat = map(float, re.match(r"block at \((-?[\d.]+), (-?[\d.]+)\): ",
                                       reason).groups())
        assert 24.9 < lon < 25.0 and 60.1 < lat < 60.2, reason


def test_blocks_geojson_in_lonlat(tmp_path):
    inputs = prepare(DISTRICT, None, load_config(CITY / "city.toml"), LIB)
    path = write_blocks_geojson(tmp_path / BLOCKS_GEOJSON, inputs, _records(inputs))
    doc = json.loads(path.read_text())
    assert "crs" not in doc   # RFC 7946: lon/lat, no crs member
    lon, lat = doc["features"][0]["geometry"]["coordinates"][0][0]
    assert 24.9 < lon < 25.0 and 60.1 < lat < 60.2
    _check_round_trip(doc, inputs)


def test_blocks_geojson_in_web_mercator(tmp_path):
    """Streets in EPSG:3857 give blocks.geojson in EPSG:3857."""
    data = json.loads(DISTRICT.read_text())
    tf = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:3857", always_xy=True)
    for f in data["features"]:
        g = shape(f["geometry"])
        f["geometry"] = shapely.geometry.mapping(shapely.transform(
            g, lambda c: np.column_stack(tf.transform(c[:, 0], c[:, 1]))))
    data["crs"] = {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::3857"}}
    streets = tmp_path / "streets_3857.geojson"
    streets.write_text(json.dumps(data))
    inputs = prepare(streets, None, load_config(CITY / "city.toml"), LIB)
    path = write_blocks_geojson(tmp_path / BLOCKS_GEOJSON, inputs, _records(inputs))
    doc = json.loads(path.read_text())
    assert pyproj.CRS(doc["crs"]["properties"]["name"]) == pyproj.CRS("EPSG:3857")
    x, y = doc["features"][0]["geometry"]["coordinates"][0][0]
    assert 2.7e6 < x < 2.8e6 and 8.4e6 < y < 8.5e6   # metres of Web Mercator at 60°N
    _check_round_trip(doc, inputs)


def test_a_small_city_run_gives_blocks_geojson_and_a_city_glb(tmp_path):
    """Three real blocks of the district built by the city's own job runner; the summary
    writes blocks.geojson with their real statuses, and city.glb holds every built
    block and passes Khronos's validator."""
    inputs = prepare(DISTRICT, None, load_config(CITY / "city.toml"), LIB)
    inputs.jobs = inputs.jobs[:3]
    results = {job.id: run_block(job, str(tmp_path)) for job in inputs.jobs}
    report = write_summary(inputs, results, tmp_path, 0.0, 1, None)
    doc = json.loads((tmp_path / BLOCKS_GEOJSON).read_text())
    statuses = {f["properties"]["id"]: f["properties"]["status"] for f in doc["features"]
                if f["properties"]["id"] is not None}
    assert statuses == {i: r["status"] for i, r in results.items()}
    assert report["built"], "some block of the three is built"
    city = write_city_glb(tmp_path, inputs, report)
    assert city is not None
    assert_clean([city])
    gltf = glb_json(city)
    root = gltf["nodes"][gltf["scenes"][0]["nodes"][0]]
    assert [gltf["nodes"][c]["name"] for c in root["children"]] == \
        [f"block_{b}" for b in report["built"]]
    assert root["extras"]["citysynth"]["georeference"]["origin_lat"] == \
        pytest.approx(60.17, abs=0.05)


def test_city_glb_on_request_from_the_command_line(tmp_path, capsys):
    from tests.test_faults import grid_streets

    out = tmp_path / "run"
    streets = grid_streets(tmp_path / "streets.geojson", 2)
    assert main(["city", "--streets", str(streets), "--library", str(LIB), "-o", str(out),
                 "--no-overview", "--workers", "1", "--glb"]) == 0
    assert f"{out / 'city.glb'}" in capsys.readouterr().out
    assert_clean([out / "city.glb"])
    manifest = json.loads((out / "manifest.json").read_text())
    doc = json.loads((out / BLOCKS_GEOJSON).read_text())
    assert {f["properties"]["id"]: f["properties"]["status"] for f in doc["features"]
            if f["properties"]["id"] is not None} == \
        {i: b["status"] for i, b in manifest["blocks"].items()}
    gltf = glb_json(out / "city.glb")
    built = [i for i, b in manifest["blocks"].items() if b["status"] == "built"]
    root = gltf["nodes"][gltf["scenes"][0]["nodes"][0]]
    assert len(root["children"]) == len(built) == 2


def test_a_city_that_builds_nothing_is_not_a_success(tmp_path, capsys):
    """Setbacks that leave nothing of any block: every piece skipped, 0 built. That is
    exit 1 with a line saying so, not 0 ("built / attempted 100 %" read as a city)."""
    cfg = tmp_path / "city.toml"
    cfg.write_text(f'library = "{LIB}"\n[setback]\ndefault = 500.0\n')
    code = main(["city", "--streets", str(DISTRICT), "--config", str(cfg), "-o",
                 str(tmp_path / "run"), "--no-overview", "--workers", "1"])
    assert code == 1
    err = capsys.readouterr().err
    assert "nothing was built" in err and "Traceback" not in err
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["counts"]["built"] == 0 and report["counts"]["skipped"] > 0


def test_diff_knows_every_status_a_run_writes():
    """`citysynth diff` checks a manifest's statuses against its own list (it loads no
    geometry library, so it does not import the job module): the two stay the same."""
    from typing import get_args

    from citysynth.pipeline.city.jobs import BlockStatus
    from citysynth.pipeline.commands.diff import STATUSES
    assert set(STATUSES) == set(get_args(BlockStatus))


def test_a_building_on_the_antimeridian_is_cut_there_in_blocks_geojson(tmp_path):
    """A footprint across ±180° was written to blocks.geojson as one polygon from
    -179.9997 to 179.9997: a band round the globe in a GIS. It is now a MultiPolygon
    cut on the meridian (RFC 7946, 3.1.9), each part a few metres wide."""
    from citysynth.pipeline.cli import main
    from citysynth.skeletons.geojson import lonlat_from_local

    ring = [(-32, -20), (32, -20), (32, 20), (-32, 20), (-32, -20)]
    fp = tmp_path / "fp.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {"building": "yes", "building:levels": 4},
        "geometry": {"type": "Polygon",
                     "coordinates": [lonlat_from_local(ring, (180.0, -16.5))]}}]}))
    lib = str(Path(__file__).resolve().parent.parent / "examples" / "library")
    out = tmp_path / "run"
    assert main(["city", "--footprints", str(fp), "--library", lib, "-o", str(out),
                 "--workers", "1", "--no-overview"]) == 0
    (feat,) = json.loads((out / "blocks.geojson").read_text())["features"]
    geom = feat["geometry"]
    assert geom["type"] == "MultiPolygon" and len(geom["coordinates"]) == 2, geom
    for part in geom["coordinates"]:
        lons = [x for x, _y in part[0]]
        assert -180 <= min(lons) and max(lons) <= 180 and max(lons) - min(lons) < 0.001
