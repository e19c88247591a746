"""GeoPackage, Shapefile, FlatGeobuf, KML/KMZ and Esri JSON read as they are
(skeletons/gis_files.py): the same layer gives the same city as its GeoJSON export, byte
for byte in every block file
(``citysynth diff`` exits 0); a file with several layers gives the one the option reads,
or says how to name it; a damaged file is one line.

The files are written by geopandas through GDAL (pyogrio), as a GIS user's would be."""

from __future__ import annotations

import json
import shutil
import zipfile
from pathlib import Path

import geopandas as gpd
import pytest

from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
CITY = ROOT / "examples" / "city"
STREETS = CITY / "district_streets.geojson"
BUILDINGS = CITY / "district_buildings.geojson"


def city(out: Path, *args: str) -> int:
    return main(["city", *args, "--library", str(LIB), "-o", str(out), "--workers", "2",
                 "--no-overview"])


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("gis")
    streets, buildings = gpd.read_file(STREETS), gpd.read_file(BUILDINGS)
    streets.to_file(d / "city.gpkg", layer="streets", driver="GPKG")
    buildings.to_file(d / "city.gpkg", layer="buildings", driver="GPKG")
    metric = streets.to_crs(3067)
    metric.to_file(d / "streets.geojson", driver="GeoJSON")   # the reference, in EPSG:3067
    metric.to_file(d / "streets.shp")
    with zipfile.ZipFile(d / "streets.zip", "w") as z:
        for ext in ("shp", "shx", "dbf", "prj", "cpg"):
            if (d / f"streets.{ext}").exists():
                z.write(d / f"streets.{ext}", f"streets.{ext}")
    streets.to_file(d / "streets.kml", driver="LIBKML")     # Google Earth's formats
    streets.to_file(d / "streets.kmz", driver="LIBKML")
    few = buildings.iloc[:12]
    few.to_file(d / "few.geojson", driver="GeoJSON")
    solid = buildings[buildings.geometry.apply(
        lambda g: g.geom_type == "Polygon" and not g.interiors)].iloc[:12]
    (d / "map.osm").write_text(osm_xml(streets, solid))   # no relations: no holes
    # the reference names each building by its way's id, as the OpenStreetMap file does
    solid = solid.assign(osm_way_id=[str(1000 + len(streets) + j) for j in range(len(solid))])
    solid.to_file(d / "solid.geojson", driver="GeoJSON")
    web = few.to_crs(3857)     # as an ArcGIS server serves it (wkid 102100)
    web.to_file(d / "few3857.geojson", driver="GeoJSON")
    (d / "few.esri.json").write_text(json.dumps(esri_json(web)))
    # no spatial index: with one, GDAL stores the features in Hilbert order, and a
    # feature's index (which messages and structure names use) is its place in the file
    few.to_file(d / "few.fgb", driver="FlatGeobuf", SPATIAL_INDEX="NO")
    return d


def esri_json(frame: gpd.GeoDataFrame) -> dict:
    """Polygons as an ArcGIS REST query returns them (``f=json``; GDAL cannot write it)."""
    feats = []
    for _, row in frame.iterrows():
        g = row.geometry
        rings = [list(map(list, r.coords)) for p in getattr(g, "geoms", [g])
                 for r in (p.exterior, *p.interiors)]
        attrs = {k: v for k, v in row.items() if k != "geometry" and isinstance(v, str)}
        feats.append({"attributes": attrs, "geometry": {"rings": rings}})
    return {"displayFieldName": "", "geometryType": "esriGeometryPolygon",
            "spatialReference": {"wkid": 102100, "latestWkid": 3857},
            "fields": [{"name": k, "type": "esriFieldTypeString"} for k in frame.columns
                       if k != "geometry"], "features": feats}


def osm_xml(lines: gpd.GeoDataFrame, polygons: gpd.GeoDataFrame) -> str:
    """Ways in the XML the OpenStreetMap website's Export button gives: one node per
    distinct point (shared where lines meet), tags from the columns."""
    nodes: dict[tuple[float, float], int] = {}
    ways = []

    def refs(coords) -> list[int]:
        return [nodes.setdefault((float(x), float(y)), len(nodes) + 1) for x, y, *_ in coords]

    for frame, ring in ((lines, False), (polygons, True)):
        for _, row in frame.iterrows():
            coords = row.geometry.exterior.coords if ring else row.geometry.coords
            tags = {k: str(v) for k, v in row.items() if k != "geometry" and v is not None
                    and v == v}
            ways.append((refs(coords), tags))
    out = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="test">']
    out += [f'<node id="{i}" lat="{y!r}" lon="{x!r}" version="1"/>'
            for (x, y), i in nodes.items()]
    for k, (nds, tags) in enumerate(ways):
        out.append(f'<way id="{1000 + k}" version="1">')
        out += [f'<nd ref="{n}"/>' for n in nds]
        out += [f'<tag k="{a}" v="{v}"/>' for a, v in tags.items()]
        out.append("</way>")
    return "\n".join([*out, "</osm>"])


def test_a_geopackage_of_two_layers_builds_the_city_its_geojson_does(files, tmp_path,
                                                                   capsys):
    """``--streets city.gpkg --footprints city.gpkg``: the line layer for the streets,
    the polygon layer for the footprints, and every block file as from the GeoJSON."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("k = 1\n")
    assert city(tmp_path / "a", "--streets", str(STREETS), "--footprints", str(BUILDINGS),
                "--config", str(cfg)) in (0, 1)
    gpkg = str(files / "city.gpkg")
    assert city(tmp_path / "b", "--streets", gpkg, "--footprints", gpkg,
                "--config", str(cfg)) in (0, 1)
    capsys.readouterr()
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    assert " 0 changed" in capsys.readouterr().out
    built = json.loads((tmp_path / "b" / "report.json").read_text())["counts"]["built"]
    assert built >= 250


@pytest.mark.parametrize("name", ["streets.shp", "streets.zip"])
def test_a_projected_shapefile_builds_the_city_its_geojson_does(files, tmp_path, name):
    """Streets in EPSG:3067 (the .prj says so), plain or zipped, against the same layer
    exported as GeoJSON."""
    assert city(tmp_path / "a", "--streets", str(files / "streets.geojson")) == 0
    assert city(tmp_path / "b", "--streets", str(files / name)) == 0
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    frame = json.loads((tmp_path / "b" / "manifest.json").read_text())["frame"]
    assert "3067" in json.dumps(frame) or "TM35FIN" in json.dumps(frame)


@pytest.mark.parametrize("name", ["streets.kml", "streets.kmz"])
def test_kml_streets_build_the_city_their_geojson_does(files, tmp_path, name):
    assert city(tmp_path / "a", "--streets", str(STREETS)) == 0
    assert city(tmp_path / "b", "--streets", str(files / name)) == 0
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0


@pytest.mark.parametrize("reference, name", [
    ("few.geojson", "few.fgb"),
    # ArcGIS's JSON in Web Mercator against the same polygons as GeoJSON in EPSG:3857
    ("few3857.geojson", "few.esri.json")])
def test_footprints_of_other_formats(files, tmp_path, reference, name):
    cfg = tmp_path / "c.toml"
    cfg.write_text('k = 1\npick = "best"\n')
    for run, given in (("a", reference), ("b", name)):
        assert city(tmp_path / run, "--footprints", str(files / given), "--config",
                    str(cfg)) in (0, 1)
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    assert len(json.loads((tmp_path / "b" / "manifest.json").read_text())["blocks"]) >= 10


def test_an_openstreetmap_export_builds_the_city_its_geojson_does(files, tmp_path, capsys):
    """``--streets map.osm --footprints map.osm``: the ways with highway=* as streets
    (their other tags, lanes and oneway, read as properties), the buildings as
    footprints; every block file as from the GeoJSON of the same streets and buildings."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("k = 1\n")
    osm = str(files / "map.osm")
    assert city(tmp_path / "a", "--streets", str(STREETS), "--footprints",
                str(files / "solid.geojson"), "--config", str(cfg)) in (0, 1)
    assert city(tmp_path / "b", "--streets", osm, "--footprints", osm,
                "--config", str(cfg)) in (0, 1)
    capsys.readouterr()
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    assert main(["skeleton", osm]) == 2
    assert f"name the layer to read: {osm}::lines or {osm}::multipolygons" in \
        capsys.readouterr().err


def test_an_openstreetmap_pbf_extract(tmp_path):
    """A .osm.pbf extract (the one pyogrio ships for its own tests; its node ids are out
    of order, as merged extracts and JOSM's new objects are): its buildings are built,
    its footways and cycleways are no streets."""
    import pyogrio

    pbf = Path(pyogrio.__file__).parent / "tests" / "fixtures" / "sample.osm.pbf"
    if not pbf.exists():
        pytest.skip("pyogrio's sample extract is not installed")
    assert city(tmp_path / "o", "--streets", str(pbf), "--footprints", str(pbf)) == 0
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    assert report["counts"]["built"] >= 2
    reasons = " ".join(s["reason"] for s in report["skipped"])
    assert "with highway=footway left out: not streets" in reasons


def test_layers_are_chosen_or_named(files, tmp_path, capsys):
    two = tmp_path / "two.gpkg"
    b = gpd.read_file(files / "city.gpkg", layer="buildings")
    b.iloc[:5].to_file(two, layer="houses", driver="GPKG")
    b.iloc[5:9].to_file(two, layer="sheds", driver="GPKG")
    assert city(tmp_path / "o", "--footprints", str(two)) == 2
    err = capsys.readouterr().err
    assert f"{two}: 2 polygon layers (houses, sheds); name the one to read as " \
           f"{two}::houses" in err and len(err.strip().splitlines()) == 1
    assert city(tmp_path / "o", "--footprints", f"{two}::sheds") in (0, 1)
    built = json.loads((tmp_path / "o" / "manifest.json").read_text())["blocks"]
    assert 1 <= len(built) <= 4
    capsys.readouterr()
    assert city(tmp_path / "p", "--footprints", f"{two}::barns") == 2
    assert "no layer 'barns'; its layers are houses (Polygon), sheds (Polygon)" in \
        capsys.readouterr().err
    assert city(tmp_path / "p", "--streets", str(two)) == 2
    assert "no line layer; its layers are houses (Polygon), sheds (Polygon)" in \
        capsys.readouterr().err
    assert city(tmp_path / "p", "--streets", f"{STREETS}::x") == 2
    assert "names a layer, but" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()


def test_block_and_building_read_their_layer_of_a_geopackage(tmp_path, capsys):
    """``block`` takes the polygon layer, ``building`` the line layer of one file."""
    import shapely

    from citysynth.skeletons.geojson import lonlat_from_local

    origin = (24.94, 60.17)
    lot = shapely.Polygon(lonlat_from_local([(0, 0), (36, 0), (36, 24), (0, 24)], origin))
    lines = [shapely.LineString(lonlat_from_local(p, origin))
             for p in ([(0, 40), (30, 40)], [(30, 40), (30, 60)])]
    both = tmp_path / "both.gpkg"
    gpd.GeoDataFrame({"id": ["lot"]}, geometry=[lot], crs=4326).to_file(
        both, layer="lots", driver="GPKG")
    gpd.GeoDataFrame({"id": ["a", "b"]}, geometry=lines, crs=4326).to_file(
        both, layer="skeleton", driver="GPKG")
    for command, out in (("block", "b"), ("building", "l")):
        assert main([command, str(both), "--library", str(LIB), "-o", str(tmp_path / out),
                     "--k", "1", "--no-preview"]) == 0, capsys.readouterr().err
        lay = json.loads(next((tmp_path / out).glob("*.layout.json")).read_text())
        sides = [len(st["stages"]) for st in lay["structures"]]
        # the 36 x 24 m lot's four sides; the skeleton's two lines
        assert sides == ([4] if command == "block" else [2]), sides


def test_a_shapefile_without_its_index_is_one_line(files, tmp_path, capsys):
    lone = tmp_path / "lone.shp"
    shutil.copy(files / "streets.shp", lone)
    assert city(tmp_path / "o", "--streets", str(lone)) == 2
    err = capsys.readouterr().err
    assert f"{lone}: cannot read this Shapefile (" in err
    assert "a Shapefile needs its .shx and .dbf beside it" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()
