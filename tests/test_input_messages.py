"""Messages about bad input name the real cause: a street's asked doors (not its
length), a row zone's own side, an outline of too few corners (not one that crosses
itself), lon/lat degrees given a projected CRS, and the key and place of a structure
file's unknown or ignored entry or of a JSON key given twice."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from shapely.geometry import LineString

from citysynth.pipeline.city.config import ConfigError, load_config
from citysynth.pipeline.cli import main
from citysynth.pipeline.streets import Run, StreetAsk, _why
from citysynth.skeletons import SkeletonError
from citysynth.skeletons.geojson import parse_geojson

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"
STRUCTURE = json.loads((EX / "block_cycle.json").read_text())
UTM = {"type": "name", "properties": {"name": "EPSG:25832"}}


def _fc(geometry: dict, crs: dict | None = UTM) -> dict:
    d = {"type": "FeatureCollection",
         "features": [{"type": "Feature", "properties": {}, "geometry": geometry}]}
    return d if crs is None else {**d, "crs": crs}


def _err(argv: list[str], capsys, code: int = 2) -> str:
    assert main(argv) == code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_doors_that_cannot_fill_a_street_are_blamed_not_its_length(tmp_path, capsys):
    line = tmp_path / "s.geojson"
    line.write_text(json.dumps(_fc({"type": "LineString", "coordinates": [
        [366000.0, 5622000.0], [366080.0, 5622000.0]]})))
    err = _err(["street", "--line", str(line), "--doors", "1", "2", "--no-preview", "-o",
                str(tmp_path / "out")], capsys, code=1)
    assert "its length cannot be filled by the buildings with doors in [1, 2] (such rows " \
           "measure 48 m); widen the doors interval or leave it out" in err, err
    assert "--stretch" not in err and not (tmp_path / "out").exists()


def test_a_row_zones_side_is_named_once():
    """A row zone's runs are the block's own sides ("side side's run 2" before)."""
    ask = StreetAsk(("left",))
    said = _why(Run("side", 1, LineString([(0, 0), (30, 0)])), [], ask)
    assert said.startswith("side 2 (30.0 m): ") and "side side" not in said
    assert _why(Run("left", 0, LineString([(0, 0), (30, 0)])), [], ask).startswith(
        "the left side's run 1 (30.0 m): ")


def test_an_outline_of_two_points_has_too_few_corners(tmp_path, capsys):
    f = tmp_path / "b.geojson"
    f.write_text(json.dumps(_fc({"type": "Polygon", "coordinates": [[
        [366000.0, 5622000.0], [366040.0, 5622000.0], [366000.0, 5622000.0]]]})))
    err = _err(["skeleton", str(f)], capsys)
    assert "too few points at (366000.00, 5622000.00)); an outline needs at least 3 " \
           "distinct corners" in err and "cross" not in err and "geometry component" not in err


@pytest.mark.parametrize("polygon, said", [
    ("[[1, 2], [3, 4], [1, 2]]", "too few points at (1.000000, 2.000000)); an outline "
                                 "needs at least 3 distinct corners"),
    ("[[1, 2], [3, 4], [5, 6]]", "no area: its corners lie on one line"),
    ("[[0, 0], [1, 1], [1, 0], [0, 1]]", "self-intersection at (0.500000, 0.500000)); fix "
                                         "the outline so it does not cross itself"),
])
def test_a_zone_polygon_says_what_is_wrong_with_it(tmp_path, polygon, said):
    cfg = tmp_path / "city.toml"
    cfg.write_text(f'[[zone]]\nname = "z"\npolygon = {polygon}\n')
    with pytest.raises(ConfigError, match="zone\\[0\\].polygon: not a valid polygon") as exc:
        load_config(cfg)
    assert said in str(exc.value)


LONLAT_LINE = {"type": "LineString", "coordinates": [[7.1, 50.73], [7.1005, 50.7302]]}


@pytest.mark.parametrize("crs", ["EPSG:3857", "EPSG:32632", "EPSG:25832", "EPSG:2263"])
def test_lonlat_degrees_given_a_projected_crs_are_said_so(crs):
    with pytest.raises(SkeletonError) as exc:
        parse_geojson(_fc(LONLAT_LINE, None), "s.geojson", crs=crs)
    said = str(exc.value)
    assert said.startswith("s.geojson: the coordinates (such as 7.100000, 50.730000) look "
                           "like longitude/latitude degrees, not coordinates of ")
    assert said.endswith("leave --crs out (GeoJSON is lon/lat) or give --crs EPSG:4326")


def test_lonlat_degrees_under_a_projected_crs_member_blame_the_member():
    with pytest.raises(SkeletonError, match='as the file\'s "crs" member \\(EPSG:25832\\) '
                       'says: .*; correct the file\'s "crs" member'):
        parse_geojson(_fc(LONLAT_LINE), "s.geojson")


def test_small_metric_data_in_a_custom_local_crs_is_kept():
    """A local frame (a CRS of no registered area) may hold a 30 m building at its
    origin: only data spanning under a metre is taken for degrees there."""
    local = "+proj=tmerc +lat_0=50 +lon_0=7 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m"
    line = {"type": "LineString", "coordinates": [[0.0, 0.0], [30.0, 40.0]]}
    feats, _ = parse_geojson(_fc(line, None), "s.geojson", crs=local)
    assert feats[0].geometry.length == pytest.approx(50.0, abs=1e-6)
    with pytest.raises(SkeletonError, match="look like longitude/latitude degrees"):
        parse_geojson(_fc(LONLAT_LINE, None), "s.geojson", crs=local)


def _structure(tmp_path: Path, edit) -> Path:
    d = json.loads(json.dumps(STRUCTURE))
    edit(d)
    f = tmp_path / "structure.json"
    f.write_text(json.dumps(d))
    return f


@pytest.mark.parametrize("edit, said", [
    (lambda d: d["keypoints"][1].update(colour="red"),
     "keypoints[1]: unknown key 'colour'; a key point has branch, elements"),
    (lambda d: d["elements"][4].update(resources={"length": 1.0}),
     "elements[4].resources: key element 'corner_small' has legs, which are all it counts"),
    (lambda d: d["stages"][2].update(elements=[]),
     'stages[2].elements: empty, so no element may fill the stage; list the elements that '
     'may, or leave "elements" out for all of them'),
    # key elements only: the stage was left with no filler, untold
    (lambda d: d["stages"][2].update(elements=["corner_small"]),
     "stages[2].elements: 'corner_small' is a key element (it has legs), which stands at "
     "key points, not between them"),
])
def test_a_structure_files_ignored_entries_are_refused_where_they_are(tmp_path, capsys,
                                                                      edit, said):
    err = _err(["solve", str(_structure(tmp_path, edit))], capsys)
    assert f"structure.json: {said}" in err, err


def test_a_key_elements_zero_resources_are_what_to_dict_writes(tmp_path, capsys):
    """Structure.to_dict writes a key element's resources as zeros: still read."""
    f = _structure(tmp_path, lambda d: d["elements"][4].update(resources={"length": 0}))
    assert main(["solve", str(f)]) == 0


def test_a_json_key_given_twice_is_named_with_its_place(tmp_path, capsys):
    f = tmp_path / "structure.json"
    text = json.dumps(STRUCTURE).replace('"cost": 0.5', '"cost": 0.5, "cost": 0', 1)
    f.write_text(text)
    err = _err(["solve", str(f)], capsys)
    assert err.endswith("structure.json: key 'cost' is given twice in the object at "
                        "elements[2]; JSON keys must be unique (the second would silently "
                        "replace the first): keep one of them"), err


def test_nearest_totals_past_six_digits_are_said_in_full():
    """A kilometres-long length's nearest totals were said in six digits: asked exactly
    1e6 m, "nearest achievable: 1e+06 (below), 1e+06 (above)"."""
    from citysynth.solver import Problem, solve

    r = solve(Problem.from_dict({
        "resources": ["length"], "quantum": {"length": 0.2},
        "elements": [{"id": "A", "resources": {"length": 333333.4}}],
        "transitions": [["A", "A", 0.0]], "constraints": {"length": [1e6, 1e6]}}))
    assert r.status == "infeasible"
    assert "length = 1e+06" in r.reason and "666666.8 (below)" in r.reason \
        and "1000000.2 (above)" in r.reason, r.reason


def test_lonlat_is_told_from_metres_by_one_rule_at_its_edges():
    """Every place that tells lon/lat from metres by range asks one predicate (it was
    written about eight times); the edges themselves are degrees."""
    import numpy as np

    from citysynth.skeletons.degrees import in_degrees

    assert in_degrees(180.0, -90.0) and in_degrees(-180.0, 90.0)
    assert not in_degrees(180.0001, 0.0) and not in_degrees(0.0, -90.5)
    assert in_degrees(-10.0, -5.0, 170.0, 60.0) and not in_degrees(-10.0, -5.0, 181.0, 60.0)
    assert in_degrees(np.array([24.9, 385000.0]), np.array([60.2, 6672000.0])).tolist() \
        == [True, False]
    # a city.toml origin past the range is refused with its value
    with pytest.raises(ValueError, match=r"must be \[lon, lat\] in degrees, got"):
        from citysynth.pipeline.city.config import _origin

        def err(key, why):
            return ValueError(f"{key}: {why}")
        _origin({"origin": [385000.0, 60.2]}, err)


def test_a_long_list_in_a_message_names_the_first_few_and_counts_the_rest():
    from citysynth.solver.safe_read import first_few

    assert first_few(["a", "b"], 3) == "a, b"
    assert first_few(["a", "b", "c", "d", "e"], 3) == "a, b, c and 2 more"
    assert first_few(["a"], 1, " / ", total=1_234) == "a and 1,233 more"
