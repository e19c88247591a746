"""``citysynth tower`` (the paper's Fig. 4): towers of exactly 120 m at floor-area ratios
10, 15 and 20 on a 400 m² lot from the sample library, read back from the files the
command writes; a drawn lot turns and centres the tower; bad input and infeasible asks."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import shapely
from shapely import affinity

from citysynth.examples import SAMPLE_LIBRARY
from citysynth.export.layout import Layout
from citysynth.export.usd import validate
from citysynth.parts_db import load_library
from citysynth.pipeline.cli import main

FARS = (10, 15, 20)


@pytest.fixture(scope="module")
def towers(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("towers")
    for far in FARS:
        assert main(["tower", "--height", "120", "--far", str(far), "--lot-area", "400",
                     "-o", str(out)]) == 0
    return out


def _layout(path: Path) -> Layout:
    return Layout.from_dict(json.loads(path.read_text()))


@pytest.mark.parametrize("far", FARS)
def test_tower_meets_height_and_far(towers, far):
    db = load_library(SAMPLE_LIBRARY)
    parts = db.by_id
    stem = towers / f"tower_120m_far{far}"
    for suffix in (".layout.json", ".usda", ".glb", ".png"):
        assert Path(f"{stem}{suffix}").is_file()
    lay = _layout(Path(f"{stem}.layout.json"))
    inst = lay.instances
    # stacked: each part on the one below, the roof's top at exactly 120 m
    for below, above in zip(inst, inst[1:], strict=False):
        assert above.z == pytest.approx(below.z + parts[below.part].length, abs=1e-6)
    top = inst[-1].z + parts[inst[-1].part].length
    assert abs(top - 120.0) <= 0.001
    assert [parts[i.part].cls for i in (inst[0], inst[-1])] == ["ground_floor", "roof"]
    assert all(parts[i.part].cls == "floor" for i in inst[1:-1])
    # floor area from the parts themselves, against the asked interval (+-2 %)
    area = math.fsum(parts[i.part].floor_area or 0.0 for i in inst
                     if parts[i.part].cls != "roof")
    assert far * 0.98 <= area / 400.0 <= far * 1.02
    assert lay.structures[0]["resources"]["far"] == pytest.approx(area / 400.0, abs=1e-5)
    assert validate(f"{stem}.usda") == []


def test_towers_grow_stouter_with_far(towers):
    """The paper's observation: the same height, more floor area per floor."""
    db = load_library(SAMPLE_LIBRARY)
    parts = db.by_id
    mean = []
    for far in FARS:
        lay = _layout(towers / f"tower_120m_far{far}.layout.json")
        floors = [parts[i.part] for i in lay.instances if i.cls == "floor"]
        mean.append(sum(p.floor_area or 0.0 for p in floors) / sum(p.length for p in floors))
    assert mean == sorted(mean) and len(set(mean)) == 3


def test_tower_on_a_drawn_lot_is_centred_and_turned(tmp_path):
    lot = affinity.rotate(shapely.box(0, 0, 30, 22), 30, origin=(0, 0))
    lot = affinity.translate(lot, 690000, 5335000)   # UTM 32N: Munich
    (tmp_path / "lot.geojson").write_text(json.dumps({
        "type": "FeatureCollection", "crs": {"type": "name", "properties": {
            "name": "urn:ogc:def:crs:EPSG::25832"}},
        "features": [{"type": "Feature", "properties": {},
                      "geometry": shapely.geometry.mapping(lot)}]}))
    out = tmp_path / "out"
    assert main(["tower", "--height", "60", "--far", "8", "12", "--lot",
                 str(tmp_path / "lot.geojson"), "--k", "2", "--no-preview",
                 "-o", str(out), "--name", "t"]) == 0
    db = load_library(SAMPLE_LIBRARY)
    parts = db.by_id
    for rank in (1, 2):
        lay = _layout(out / f"t_{rank}.layout.json")
        st = lay.structures[0]
        # the local frame is a transverse Mercator: grid north turns by a few mdeg
        assert st["lot"]["angle"] == pytest.approx(30.0, abs=0.01)
        a = math.radians(st["lot"]["angle"])
        poly = shapely.Polygon(st["lot"]["polygon"])
        assert poly.area == pytest.approx(660.0, rel=2e-3)   # UTM's scale factor
        for i in lay.instances:
            assert i.x_axis == pytest.approx((math.cos(a), math.sin(a)), abs=1e-6)
            assert i.origin == pytest.approx(tuple(st["lot"]["centre"]))
            p = parts[i.part]
            fp = affinity.rotate(shapely.union(p.sec_in, p.sec_out), st["lot"]["angle"],
                                 origin=(0, 0))
            assert poly.buffer(0.01).covers(affinity.translate(fp, *i.origin))
        assert 8 <= st["resources"]["far"] <= 12
        assert validate(out / f"t_{rank}.usda") == []


@pytest.mark.parametrize("args, code, text", [
    (["--far", "0"], 2, "--far takes one positive ratio"),
    (["--far", "12", "8"], 2, "LO (12) is above HI (8)"),
    (["--far", "60"], 1, "infeasible: floor-area ratio 58.8-61.2 at 120 m on a 400 m² lot: "
                          "every stack of the tower parts of that height has a floor-area "
                          "ratio between "),
    # a skyscraper the lot cannot carry: answered at once (it searched its whole 2 GB
    # for about 100 s, then refused in the solver's words), the ratio first
    (["--far", "4", "--height", "300"], 1, "at 300 m on a 400 m² lot: every stack of the "
                                           "tower parts of that height has a floor-area "
                                           "ratio between "),
    # below any tower: it said "each alone but not together"
    (["--far", "4", "--height", "0.001"], 1, "at 0.001 m on a 400 m² lot: no stack of the "
                                             "tower parts has that height; the lowest is "),
    # a lot of 1,000 km square: it was refused in solver words ("a solution needs at
    # least 12,136,222,899 elements to reach its minimums"), then told as "of at most"
    # the densest part's ratio over the whole height; the range tables tell it exactly
    (["--far", "4", "--lot-area", "1e12"], 1, "on a 1e+12 m² lot: every stack of the tower "
                                              "parts of that height has a floor-area ratio "
                                              "between 3.189e-09 and 1.157e-08"),
    # a ratio past any tower: it reached the solver as a floor area past counting
    (["--far", "1e300"], 2, "--far 1e+300: a floor-area ratio past any tower"),
    (["--far", "10", "--height", "120.1"], 1, "at 120.1 m on a 400 m² lot: no stack of the "
                                              "tower parts has that height; the nearest are "),
    # an exact ratio: a search of minutes (326 s) that ended in a memory refusal
    (["--far", "10", "--far-tolerance", "0"], 2,
     "a floor-area ratio of 10 on a 400 m² lot asks for a floor area of 4000.00 m², an "
     "interval narrower than 0.5 m²"),
    (["--far", "10", "10.0001"], 2, "give a wider one (--far-tolerance 6.3e-05 or more"),
    # rounded, the refusal contradicted itself ("a tower of 1000 m: ... at most 1,000 m")
    (["--far", "10", "--height", "1000.0001"], 2, "a tower of 1000.0001 m: citysynth "
                                                  "stacks towers of at most 1,000 m"),
])
def test_tower_bad_or_impossible_asks(tmp_path, capsys, args, code, text):
    argv = ["tower", "--height", "120", "--lot-area", "400", "--no-preview",
            "-o", str(tmp_path), *args]
    assert main(argv) == code
    err = capsys.readouterr().err
    assert text in err and "Traceback" not in err
    assert not list(tmp_path.glob("*.usda"))


def test_a_lot_too_small_for_any_ground_floor_is_one_clear_error(tmp_path, capsys):
    assert main(["tower", "--height", "60", "--far", "5", "--lot-area", "100",
                 "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no ground floor of the library 'citysynth sample' fits the lot (100 m², 10.0 x " \
        "10.0 m; the widest circle inside it is 10.0 m across): the smallest, " \
        "tower_ground_square14, needs 16.0 x 16.0 m" in err
    assert "Traceback" not in err


def test_a_style_with_no_tower_parts_names_the_styles_that_have_them(tmp_path, capsys):
    """--style classic (facade modules only): the lot was blamed ("no tower of style
    classic that fits the lot") on a 900 m² lot that holds every tower."""
    assert main(["tower", "--height", "40", "--far", "3", "--lot-area", "900", "--style",
                 "classic", "--no-preview", "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "has no tower parts of style classic: a tower needs ground_floor, floor and " \
        "roof parts; its towers are of style tower (--style tower)" in err, err
    assert "lot" not in err and not list(tmp_path.iterdir())


def test_a_lot_round_a_courtyard_says_so(tmp_path, capsys):
    """A 60 x 60 m lot round a 40 x 40 m courtyard was told as 60 x 60 m that a 16 m
    ground floor does not fit; the courtyard and the widest free ground (a circle in a
    corner of the 10 m band, 11.7 m) are now said."""
    from citysynth.skeletons.geojson import lonlat_from_local

    rings = [[(0, 0), (60, 0), (60, 60), (0, 60), (0, 0)],
             [(10, 10), (10, 50), (50, 50), (50, 10), (10, 10)]]
    lot = tmp_path / "lot.geojson"
    lot.write_text(json.dumps({"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {}, "geometry": {
            "type": "Polygon",
            "coordinates": [lonlat_from_local(r, (24.94, 60.17)) for r in rings]}}]}))
    assert main(["tower", "--height", "60", "--far", "1", "--lot", str(lot),
                 "-o", str(tmp_path / "out"), "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert "round a courtyard (a hole in it); the widest circle inside it is 11.7 m " \
        "across): the smallest, tower_ground_square14, needs 16.0 x 16.0 m" in err, err


def test_a_lot_whose_centre_is_beside_a_hole_takes_its_tower_inland(tmp_path, capsys):
    """A 200 m lot with a 30 m courtyard just east of its middle: its centroid lies
    3 m from the courtyard, where no 16 m ground floor fits, and the lot was refused
    ("the widest circle inside it is 109.9 m across ... needs 16.0 x 16.0 m; give a
    larger lot"). The tower now stands on the lot's most inland point, clear of it."""
    lot = _lot_file(tmp_path, "lot", shapely.Polygon(
        [(0, 0), (200, 0), (200, 200), (0, 200)],
        [[(101, 85), (101, 115), (131, 115), (131, 85)]]))
    assert main(["tower", "--height", "60", "--far", "0.1", "--far-tolerance", "0.5",
                 "--lot", str(lot), "-o", str(tmp_path / "out"), "--no-preview"]) == 0, \
        capsys.readouterr().err
    from citysynth.pipeline.commands.tower import read_lot
    layout = json.loads(next((tmp_path / "out").glob("*.layout.json")).read_text())
    ground = [i for i in layout["instances"] if i["class"] == "ground_floor"]
    drawn = read_lot(str(lot), None).polygon          # in the layout's frame
    axis = shapely.Point(ground[0]["origin"])
    assert len(ground) == 1 and drawn.contains(axis)
    assert shapely.Polygon(drawn.interiors[0]).distance(axis) > 20, axis   # 3 m before


def test_a_one_part_multipolygon_lot_is_its_polygon(tmp_path):
    """QGIS writes polygons as MultiPolygon: one part is a lot like a Polygon."""
    lot = affinity.translate(shapely.box(0, 0, 30, 22), 690000, 5335000)
    for name, geom in (("poly", shapely.geometry.mapping(lot)),
                       ("multi", shapely.geometry.mapping(shapely.MultiPolygon([lot])))):
        (tmp_path / f"{name}.geojson").write_text(json.dumps({
            "type": "FeatureCollection", "crs": {"type": "name", "properties": {
                "name": "urn:ogc:def:crs:EPSG::25832"}},
            "features": [{"type": "Feature", "properties": {}, "geometry": geom}]}))
        assert main(["tower", "--height", "60", "--far", "8", "12", "--lot",
                     str(tmp_path / f"{name}.geojson"), "--no-preview",
                     "-o", str(tmp_path / name), "--name", "t"]) == 0
    a, b = ((tmp_path / n / "t.layout.json").read_text() for n in ("poly", "multi"))
    assert json.loads(a)["structures"] == json.loads(b)["structures"]


def _lot_file(tmp_path: Path, name: str, poly) -> Path:
    path = tmp_path / f"{name}.geojson"
    path.write_text(json.dumps({
        "type": "FeatureCollection", "crs": {"type": "name", "properties": {
            "name": "urn:ogc:def:crs:EPSG::25832"}},
        "features": [{"type": "Feature", "properties": {},
                      "geometry": shapely.geometry.mapping(
                          affinity.translate(poly, 690000, 5335000))}]}))
    return path


def test_a_lot_whose_centroid_lies_outside_it_takes_its_most_inland_point(tmp_path):
    """An L-shaped lot: its centroid is outside, so the tower stands on the lot's pole of
    inaccessibility, wholly on the lot (it crashed: shapely has no top-level polylabel)."""
    ell = shapely.Polygon([(0, 0), (60, 0), (60, 22), (22, 22), (22, 60), (0, 60)])
    assert not ell.contains(ell.centroid)
    out = tmp_path / "out"
    assert main(["tower", "--height", "60", "--far", "1", "3", "--lot",
                 str(_lot_file(tmp_path, "ell", ell)), "--no-preview", "-o", str(out),
                 "--name", "t"]) == 0
    lay = _layout(out / "t.layout.json")
    st = lay.structures[0]
    poly = shapely.Polygon(st["lot"]["polygon"])
    assert poly.contains(shapely.Point(st["lot"]["centre"]))
    parts = load_library(SAMPLE_LIBRARY).by_id
    for i in lay.instances:
        p = parts[i.part]
        fp = affinity.rotate(shapely.union(p.sec_in, p.sec_out), st["lot"]["angle"],
                             origin=(0, 0))
        assert poly.buffer(0.01).covers(affinity.translate(fp, *i.origin))


def test_a_lot_that_crosses_itself_is_refused_where_it_does(tmp_path, capsys):
    bowtie = shapely.Polygon([(0, 0), (30, 30), (30, 0), (0, 30)])
    code = main(["tower", "--height", "60", "--far", "4", "--lot",
                 str(_lot_file(tmp_path, "bowtie", bowtie)), "--no-preview",
                 "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "the lot is not a valid polygon (self-intersection at (690015.00, 5335015.00))" \
        in err and "does not cross itself" in err
    assert not (tmp_path / "out").exists()


def test_a_lot_drawn_round_the_globe_is_refused(tmp_path, capsys):
    """``--lot-area`` past a million km² was refused, but a lot drawn that large (lon
    ±170, lat ±80) was taken: "a 6.87253e+12 m² lot"."""
    lot = tmp_path / "huge.geojson"
    lot.write_text(json.dumps({"type": "Feature", "properties": {}, "geometry": {
        "type": "Polygon", "coordinates": [[[-170, -80], [170, -80], [170, 80], [-170, 80],
                                            [-170, -80]]]}}))
    assert main(["tower", "--height", "60", "--far", "3", "--lot", str(lot),
                 "--no-preview", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"{lot}: a lot of " in err and "is no building lot (at most 1e+12 m²" in err, err
    assert not (tmp_path / "o").exists()


def test_a_narrow_floor_area_interval_is_counted_in_finer_quanta():
    """A floor area asked to within a square metre either side: counted in whole m²,
    few stacks whose rounded total met it met it in m², and a 200 m tower was searched
    for 80 s and refused; in quanta fifty times finer than the interval it is found."""
    from citysynth.pipeline.towers import Lot, area_quantum, solve_tower
    db = load_library(SAMPLE_LIBRARY)
    area = (14914.0, 14916.0)
    built = solve_tower("narrow", db, Lot.square(400), 200.0, (area[0] / 400, area[1] / 400))
    assert built.status == "ok"
    parts = db.by_id
    (lay,) = built.layouts
    got = math.fsum(parts[i.part].floor_area or 0.0 for i in lay.instances
                    if parts[i.part].cls != "roof")
    assert area[0] <= got <= area[1]
    problem = {"elements": [{"resources": {"floor_area": a}} for a in (296.39, 0.0)]}
    assert area_quantum(problem, area, str) == pytest.approx(0.04)
    assert area_quantum(problem, (0.0, 500.0), str) == 1.0
    whole = {"elements": [{"resources": {"floor_area": a}} for a in (400.0, 0.0)]}
    assert area_quantum(whole, (4000.0, 4000.0), str) == 1.0   # counted exactly
