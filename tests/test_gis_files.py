"""GeoPackage, Shapefile, FlatGeobuf, KML/KMZ, Esri JSON, GeoParquet and GeoJSON Text
Sequences read as they are (skeletons/gis_files.py, geoparquet.py, geojson.py): the same
layer gives the same city as its GeoJSON export, byte for byte in every block file
(``citysynth diff`` exits 0); a file with several layers gives the one the option reads,
or says how to name it; a damaged file is one line; Overture Maps' attributes work as
the OpenStreetMap tags they mean.

The files are written by geopandas through GDAL (pyogrio) or pyarrow, as a GIS user's
would be."""

from __future__ import annotations

import json
import shutil
import warnings
import zipfile
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely

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
    metric.to_parquet(d / "streets.parquet")                   # WKB, PROJJSON of 3067
    few.to_parquet(d / "few.parquet", geometry_encoding="geoarrow")   # native encoding
    streets.to_file(d / "streets.geojsons", driver="GeoJSONSeq")      # RFC 8142's RS
    (d / "streets.geojsonl").write_text("\n".join(                 # a feature per line
        json.dumps(f) for f in json.loads(STREETS.read_text())["features"]) + "\n")
    for name, options in (("streets.gml", {"driver": "GML"}),
                          ("streets.tab", {"driver": "MapInfo File"}),
                          ("streets.mif", {"driver": "MapInfo File", "FORMAT": "MIF"})):
        metric.to_file(d / name, **options)
        # the reference: the same file read by GDAL and written as GeoJSON (GML keeps 15
        # digits, MapInfo names TM35FIN as UTM 35N: the same lines, other bits)
        gpd.read_file(d / name).to_file(d / f"{name}.geojson", driver="GeoJSON")
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


@pytest.mark.parametrize("reference, name", [
    (STREETS, "streets.kml"), (STREETS, "streets.kmz"),
    # in EPSG:3067 (the .prj, the PROJJSON say so): Shapefile plain or zipped, GeoParquet
    ("streets.geojson", "streets.shp"), ("streets.geojson", "streets.zip"),
    ("streets.geojson", "streets.parquet"),
    (STREETS, "streets.geojsons"), (STREETS, "streets.geojsonl"),   # GeoJSON sequences
    ("streets.gml.geojson", "streets.gml"), ("streets.tab.geojson", "streets.tab"),
    ("streets.mif.geojson", "streets.mif")])
def test_streets_of_other_formats_build_the_city_their_geojson_does(files, tmp_path,
                                                                    reference, name):
    cfg = tmp_path / "c.toml"
    cfg.write_text("k = 1\n")
    assert city(tmp_path / "a", "--streets", str(files / reference), "--config",
                str(cfg)) == 0
    assert city(tmp_path / "b", "--streets", str(files / name), "--config", str(cfg)) == 0
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    manifest = json.loads((tmp_path / "b" / "manifest.json").read_text())
    assert len(manifest["blocks"]) >= 20
    if reference == "streets.geojson":
        assert "3067" in json.dumps(manifest["frame"]) or "TM35FIN" in json.dumps(
            manifest["frame"])


@pytest.mark.parametrize("reference, name", [
    ("few.geojson", "few.fgb"), ("few.geojson", "few.parquet"),
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


def test_an_empty_layer_is_never_the_one_suggested(files, tmp_path, capsys):
    """An empty layer sorted first (a template's) was suggested, and reading it then
    said it holds no features."""
    import pyogrio

    two = tmp_path / "two.gpkg"
    b = gpd.read_file(files / "city.gpkg", layer="buildings")
    pyogrio.write_dataframe(b.iloc[:0], two, layer="aaa_empty", driver="GPKG",
                            geometry_type="Polygon")
    b.iloc[:5].to_file(two, layer="zzz_houses", driver="GPKG")
    assert city(tmp_path / "o", "--footprints", str(two)) == 2
    err = capsys.readouterr().err
    assert f"{two}: 2 polygon layers (aaa_empty: empty, zzz_houses); name the one to " \
           f"read as {two}::zzz_houses" in err, err


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
    assert f"{lone}: its index file lone.shx is missing (a Shapefile is several files" \
        in err and "copy it beside the .shp" in err, err
    assert "SHAPE_RESTORE_SHX" not in err    # GDAL's fix writes into the user's folder
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_overture_maps_attributes_work_as_the_osm_tags_they_mean(tmp_path, capsys):
    """An Overture Maps download as GeoParquet: transportation segments (``subtype``
    road, the street class in ``class``, a sidewalk as class footway, names and bounding
    boxes as structs) and buildings (``num_floors``, ``roof_shape``) give the city the
    same streets and buildings tagged the OpenStreetMap way give: the setbacks by class,
    the footway left out, the storeys and roofs chosen from the data (30 buildings and
    the streets round them, in the middle of the demo district)."""
    import pandas as pd
    import shapely

    buildings = gpd.read_file(BUILDINGS)[["geometry"]]
    x0, y0, x1, y1 = buildings.total_bounds
    centre = shapely.Point((x0 + x1) / 2, (y0 + y1) / 2)
    near = shapely.distance(shapely.centroid(buildings.geometry.to_numpy()), centre)
    buildings = buildings.iloc[sorted(range(len(near)), key=near.__getitem__)[:30]]
    x0, y0, x1, y1 = buildings.total_bounds
    streets = gpd.read_file(STREETS)[["highway", "geometry"]]   # setbacks by class alone
    streets = streets[streets.intersects(shapely.box(x0 - 0.0015, y0 - 0.0008,
                                                     x1 + 0.0015, y1 + 0.0008))]
    streets = gpd.GeoDataFrame(pd.concat([streets, streets.iloc[[0]].assign(
        highway="footway")], ignore_index=True), crs=4326)
    ids = [f"08b1f{i:011x}" for i in range(len(streets))]
    streets.assign(id=ids).to_file(tmp_path / "osm_streets.geojson", driver="GeoJSON")
    gpd.GeoDataFrame({
        "id": ids, "subtype": "road", "class": streets["highway"].to_numpy(),
        "subclass": [None] * (len(streets) - 1) + ["sidewalk"],
        "names": [{"primary": f"street {i}"} for i in range(len(streets))],
        "bbox": [dict(zip(("xmin", "ymin", "xmax", "ymax"), map(float, b), strict=True))
                 for b in streets.geometry.bounds.to_numpy()]},
        geometry=streets.geometry.to_numpy(), crs=4326).to_parquet(tmp_path / "segments.parquet")
    levels = [(4, 5, 3, 6)[i % 4] for i in range(len(buildings))]   # families a, b, c, d
    roofs = [("gabled", "mansard", None)[i % 3] for i in range(len(buildings))]
    bids = [f"08b2f{i:011x}" for i in range(len(buildings))]
    buildings.assign(id=bids, **{"building:levels": levels, "roof:shape": roofs}).to_file(
        tmp_path / "osm_buildings.geojson", driver="GeoJSON")
    buildings.assign(id=bids, num_floors=levels, roof_shape=roofs, subtype="residential",
                     height=None).to_parquet(tmp_path / "buildings.parquet")
    cfg = tmp_path / "c.toml"
    cfg.write_text('k = 1\npick = "best"\n')
    for run, (s, b) in (("a", ("osm_streets.geojson", "osm_buildings.geojson")),
                        ("b", ("segments.parquet", "buildings.parquet"))):
        assert city(tmp_path / run, "--streets", str(tmp_path / s), "--footprints",
                    str(tmp_path / b), "--config", str(cfg)) in (0, 1)
    capsys.readouterr()
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    report = json.loads((tmp_path / "b" / "report.json").read_text())
    reasons = " ".join(s["reason"] for s in report["skipped"])
    assert "with highway=footway left out: not streets" in reasons
    families = set()
    for p in (tmp_path / "b" / "blocks").glob("*.layout.json"):
        lay = json.loads(p.read_text())
        if "08b2f" in lay["structures"][0]["name"]:   # a building, storeys from num_floors
            families |= {part.split("_")[3][0] for part in lay["parts_used"]
                         if part.startswith("classic_mid_")}
    assert families >= {"a", "b", "c", "d"}, families


def _parquet(path: Path, table_columns: dict, geo: dict | str | None) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table(table_columns)
    if geo is not None:
        table = table.replace_schema_metadata(
            {"geo": geo if isinstance(geo, str) else json.dumps(geo)})
    pq.write_table(table, path)


_LINE = bytes.fromhex("010200000002000000713d0ad7a3f03840f6285c8fc2154e403333333333f33840"
                      "f6285c8fc2154e40")   # LINESTRING (24.94 60.17, 24.95 60.17)


def _wkb_geo(**column) -> dict:
    return {"version": "1.1.0", "primary_column": "geometry",
            "columns": {"geometry": {"encoding": "WKB", "geometry_types": [], **column}}}


@pytest.mark.parametrize("columns, geo, text", [
    ({"a": [1]}, None, "a Parquet table with no geometry column (no GeoParquet \"geo\" "
                       "metadata, no binary \"geometry\" column)"),
    ({"geometry": [_LINE]}, "{not json", "its \"geo\" metadata is not GeoParquet's"),
    ({"geometry": [1]}, _wkb_geo(), "the geometry column is said to be WKB but holds int64"),
    ({"geometry": [_LINE]}, _wkb_geo(encoding="ewkb"),
     "geometry encoding 'ewkb' is not one GeoParquet defines"),
    ({"geometry": [_LINE]}, _wkb_geo(crs={"type": "nonsense"}),
     "cannot read the CRS of geometry column 'geometry'; give the CRS with --crs"),
    ({"geometry": [b"\x01\x02", b"zz"]}, _wkb_geo(),
     "no usable features: all 2 left out (feature 0: no geometry (null)"),
    ({"geometry": [[1.0, 2.0]]}, _wkb_geo(encoding="linestring"),
     "row 0: its geometry is not a LineString as GeoArrow lays one out"),
    ({"geometry": [_LINE]}, {"primary_column": "geom", "columns": {"geom": {}}},
     "its \"geo\" metadata names geometry column 'geom', which the table does not hold"),
])
def test_hostile_geoparquet_is_one_line(tmp_path, capsys, columns, geo, text):
    """A GeoParquet file that is not one, or not a well-formed one: one line naming what
    is wrong, exit 2, nothing written."""
    bad = tmp_path / "bad.parquet"
    _parquet(bad, columns, geo)
    assert city(tmp_path / "o", "--streets", str(bad)) == 2
    err = capsys.readouterr().err
    assert text in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_a_parquet_table_with_a_wkb_column_and_no_metadata_is_lon_lat(tmp_path, capsys):
    """DuckDB's older exports: a binary ``geometry`` column of WKB, no "geo" metadata:
    read as lon/lat; ``FILE::COLUMN`` names a geometry column, or the message lists
    them; a truncated file is one line."""
    from citysynth.skeletons.geojson import read_geojson

    plain = tmp_path / "duck.parquet"
    _parquet(plain, {"name": ["a"], "geometry": [_LINE]}, None)
    feats, frame = read_geojson(plain, accept="lines")
    assert feats[0].properties == {"name": "a"} and round(feats[0].geometry.length) == 555
    assert frame.source_crs == ""
    assert city(tmp_path / "o", "--streets", f"{plain}::geom") == 2
    assert "no geometry column 'geom'; its geometry columns are geometry" in \
        capsys.readouterr().err
    cut = tmp_path / "cut.parquet"
    cut.write_bytes(plain.read_bytes()[:60])
    assert city(tmp_path / "o", "--streets", str(cut)) == 2
    assert f"{cut}: cannot read this GeoParquet: it is cut short, or not a Parquet file" \
        in capsys.readouterr().err


def test_geojson_text_sequences_are_read_record_by_record(tmp_path, capsys):
    """RFC 8142 records (a bare geometry among features, a record over several lines)
    and a feature per line are read as one FeatureCollection; a broken record is named
    by its line, one message, exit 2."""
    from citysynth.skeletons.geojson import read_geojson

    line = {"type": "LineString", "coordinates": [[24.94, 60.17], [24.95, 60.17]]}
    feat = {"type": "Feature", "properties": {"a": 1}, "geometry": line}
    rs = tmp_path / "rs.geojsons"
    rs.write_text("\x1e" + json.dumps(line) + "\n\x1e" + json.dumps(feat, indent=2) + "\n")
    feats, _ = read_geojson(rs, accept="lines")
    assert [f.properties for f in feats] == [{}, {"a": 1}]
    lines = tmp_path / "lines.geojsonl"
    lines.write_text(json.dumps(feat) + "\n\n" + json.dumps(feat)[:-3] + "\n")
    assert main(["skeleton", str(lines)]) == 2
    err = capsys.readouterr().err
    assert f"{lines}, line 3: not valid JSON" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("props, added", [
    ({"subtype": "road", "class": "primary"}, {"highway": "primary"}),
    ({"subtype": "road", "class": "service", "subclass": "driveway"},
     {"highway": "service", "service": "driveway"}),
    ({"subtype": "road", "class": "primary",
      "road_flags": [{"values": ["is_tunnel"], "between": None}]},
     {"highway": "primary", "tunnel": "yes"}),
    ({"subtype": "road", "class": "primary",     # a tunnel under a stretch only: a street
      "road_flags": [{"values": ["is_tunnel"], "between": [0.2, 0.6]}]},
     {"highway": "primary"}),
    ({"subtype": "rail", "class": "tram"}, {"railway": "tram"}),
    ({"subtype": "water"}, {"route": "ferry"}),
    ({"num_floors": 5, "roof_shape": "gabled", "is_underground": False},
     {"building:levels": 5, "roof:shape": "gabled"}),
    ({"is_underground": True}, {"location": "underground"}),
    ({"min_floor": 2, "min_height": 7.5}, {"building:min_level": 2}),
    ({"subtype": "transportation", "class": "roof"}, {"building": "roof"}),   # a canopy
    ({"class": "roof", "building": "yes"}, {}),
    # GDAL's writers' names for OSM's keys: a Shapefile's ten characters, GML's "_"
    ({"building_l": 6}, {"building:levels": 6}),
    ({"building_levels": "4", "roof_shape": "flat"},
     {"building:levels": "4", "roof:shape": "flat"}),
    ({"subtype": "road", "class": "primary", "highway": "secondary"}, {}),   # its own wins
    ({"class": "residential"}, {}),               # a class without Overture's subtype
])
def test_overture_attributes_as_osm_tags(props, added):
    from citysynth.skeletons.overture import osm_tags

    assert osm_tags(props) == {**props, **added}


@pytest.mark.parametrize("props, why", [
    ({"building": "roof"}, "a roof on pillars (building=roof): no walls to build"),
    ({"building": "Roof ", "building:levels": "1"}, "a roof on pillars"),
    ({"building": "yes", "min_height": "12"},
     'starts above the ground, at 12 m (min_height = "12")'),
    ({"building": "yes", "building:min_level": 3},
     "starts above the ground, at storey 3 (building:min_level = 3)"),
    ({"min_floor": 1}, "at storey 1 (min_floor = 1)"),                 # Overture's name
    ({"subtype": "commercial", "class": "roof"}, "a roof on pillars"),  # Overture's
    ({"building": "yes", "min_height": "0"}, None),                     # on the ground
    ({"building": "yes", "min_height": "-3"}, None),                    # no such height
    ({"building": "yes", "building:min_level": "0"}, None),
    ({"building": "yes"}, None),
    ({"building": "roof;yes"}, None),              # several values: a building among them
])
def test_roofs_on_pillars_and_masses_above_the_ground_are_not_built(props, why):
    """A canopy (``building=roof``: 5 of the demo district's footprints, up to 400 m²)
    was built as a block of flats of the default storeys, and a building over a
    passage (``min_height`` 12 m) from the ground, closing the passage. Each is left
    out, the report saying why and which tag to change to build it."""
    from citysynth.pipeline.city.footprints import not_built
    from citysynth.skeletons.overture import osm_tags

    got = not_built(osm_tags(props))
    assert (why in got and "build it" in got) if why else got is None, got


@pytest.mark.parametrize("props, levels, height, roof, said", [
    # ArcGIS writes field names in capitals; a key may keep a space from a header
    ({"HEIGHT": 20}, None, 20.0, None, ""),
    ({"BUILDING_L": 6, "ROOF_SHAPE": "MANSARD"}, 6.0, None, "mansard", ""),
    ({"building:levels ": "3", "Roof:Shape": "Mansard "}, 3.0, None, "mansard", ""),
    ({"Height": "tall"}, None, None, None, 'Height "tall" is no height'),
    ({"BUILDING_L": "4-5"}, 4.0, None, None, 'BUILDING_L "4-5" read as 4'),
    ({"roof:shape": "mansard;gabled"}, None, None, "mansard",
     'roof:shape "mansard;gabled" read as mansard (the first value)'),
    ({"roof:shape": ["gabled"]}, None, None, "gabled", ""),
    ({"building:levels": 5, "height": 9}, 5.0, 9.0, None, ""),     # its own keys win
])
def test_footprint_keys_are_read_whatever_their_case(props, levels, height, roof, said):
    """``HEIGHT``, ``BUILDING_L``, ``ROOF_SHAPE`` (an ArcGIS export's capitals) and a
    roof shape in capitals were ignored without a note: the storeys and family fell
    back to the defaults. They are read, and a note names the field as the file does."""
    from citysynth.pipeline.city.footprints import Storeys, footprint_spec
    from citysynth.skeletons.overture import osm_tags

    spec = footprint_spec("f.geojson", 0, osm_tags(props), "", 0.05, 0.3, Storeys())
    assert (spec.levels, spec.height, spec.roof) == (levels, height, roof)
    assert (said in spec.remarks) if said else spec.remarks == "", spec.remarks


@pytest.mark.parametrize("props, said", [
    ({"min_floor": 3}, "(min_floor = 3)"),
    ({"MIN_HEIGHT": "6"}, '(MIN_HEIGHT = "6")'),
    ({"is_underground": True}, "underground (is_underground)"),
    ({"is_underground": "true"}, "underground (is_underground)"),     # as text (GDAL)
    ({"location": "Underground"}, "underground (location=underground)"),
    ({"LOCATION": "underground"}, "underground (LOCATION=underground)"),
])
def test_a_footprint_left_out_names_the_field_the_file_has(props, said):
    """Overture's ``min_floor`` was told as ``building:min_level`` and the advice said to
    remove that key, which the file does not have; ``is_underground`` as text and
    ``location=Underground`` were built as buildings."""
    from citysynth.pipeline.city.footprints import not_built
    from citysynth.skeletons.overture import osm_tags

    why = not_built(osm_tags(props))
    assert why is not None and said in why, why
    if "=" in said and "underground" not in said:
        assert f"remove {said[1:].split(' =')[0]} " in why, why


def test_a_roof_shape_the_kit_does_not_build_is_told():
    """``roof:shape = onion`` picked no family and said nothing; now the building's note
    says which roofs the kit builds, and a known shape in capitals picks its family."""
    from citysynth.parts_db import load_library
    from citysynth.pipeline.city.footprints import Storeys, choose_family, footprint_spec
    from citysynth.skeletons.overture import osm_tags

    db = load_library(LIB)
    onion = footprint_spec("f.geojson", 0, {"roof:shape": "onion", "building:levels": 4},
                           "", 0.05, 0.3, Storeys())
    _parts, storeys, note = choose_family(onion, db, "classic")
    assert storeys == 4 and note is not None, note
    assert "roof:shape onion is none the classic kit builds (its roofs are gabled, " \
           "mansard" in note, note
    mansard = footprint_spec("f.geojson", 0, osm_tags({"ROOF_SHAPE": "MANSARD"}), "", 0.05,
                             0.3, Storeys())
    parts, storeys, note = choose_family(mansard, db, "classic")
    assert storeys == 5 and note is None and parts, note      # family b: 5 storeys


def test_an_infinite_storey_count_in_a_geopackage_is_told(tmp_path):
    """A GeoPackage's REAL ``building:levels`` of inf was read as missing (as NaN, GDAL's
    null, is) and dropped without a note; as the GeoJSON ``1e400`` it is a value no
    building has, and the building's note says so. NaN stays no value, with no note."""
    from shapely.geometry import box

    from citysynth.skeletons.geojson import lonlat_from_local
    ring = lonlat_from_local([(0, 0), (30, 0), (30, 20), (0, 20)], (24.94, 60.17))
    gdf = gpd.GeoDataFrame({"building": ["yes", "yes"],
                            "building:levels": [float("nan"), float("inf")]},
                           geometry=[shapely.Polygon(ring), box(24.9410, 60.17, 24.9415,
                                                                 60.1702)], crs=4326)
    gdf.to_file(tmp_path / "b.gpkg", driver="GPKG")
    assert main(["city", "--footprints", str(tmp_path / "b.gpkg"), "--library", str(LIB),
                 "-o", str(tmp_path / "run"), "--workers", "1", "--no-overview"]) == 0
    notes = [b.get("note") for b in json.loads((tmp_path / "run" / "manifest.json")
                                               .read_text())["blocks"].values()]
    told = [n for n in notes if n]
    assert len(notes) == 2 and len(told) == 1 and \
        "feature 1: building:levels inf is no storey count" in told[0], notes


def test_one_file_as_streets_and_footprints_warns_of_nothing(tmp_path, recwarn):
    """A GeoJSON of a street and a building given as both ``--streets`` and
    ``--footprints`` (as the README suggests for one download) warned of each feature
    that the other option reads ("a Polygon cannot be a line ...; left out", and the
    mirror) and listed both as skipped, though both were used."""
    w, h = 0.000541773311896, 0.0001809299801
    mixed = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"building": "yes"}, "geometry": {
            "type": "Polygon", "coordinates": [[[24.94, 60.17], [24.94 + w, 60.17],
                                                [24.94 + w, 60.17 + h], [24.94, 60.17 + h],
                                                [24.94, 60.17]]]}},
        {"type": "Feature", "properties": {"highway": "residential"}, "geometry": {
            "type": "LineString", "coordinates": [[24.9395, 60.1698], [24.9412, 60.1698]]}}]}
    f = tmp_path / "map.geojson"
    f.write_text(json.dumps(mixed))
    (tmp_path / "link.geojson").symlink_to(f)
    assert main(["city", "--streets", str(f), "--footprints", str(tmp_path / "link.geojson"),
                 "--library", str(LIB), "-o", str(tmp_path / "run"), "--workers", "1",
                 "--no-overview"]) == 0
    told = [str(w.message) for w in recwarn if "cannot be" in str(w.message)]
    assert not told, told
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["counts"]["built"] == 1 and not [
        s for s in report["skipped"] if "cannot be" in s["reason"]], report["skipped"]
    # given as footprints alone, the line is still told
    assert main(["city", "--footprints", str(f), "--library", str(LIB), "-o",
                 str(tmp_path / "run2"), "--workers", "1", "--no-overview"]) == 0
    again = json.loads((tmp_path / "run2" / "report.json").read_text())["skipped"]
    assert [s for s in again if "feature 1: a LineString cannot be a polygon" in s["reason"]]
    assert [w for w in recwarn if "feature 1: a LineString cannot be" in str(w.message)]


def test_geoparquet_footprints_build_in_a_3_gb_address_space(files, tmp_path):
    """Arrow's allocator reserved gigabytes of address space once a GeoParquet file was
    read: under ``ulimit -v 3000000`` the USD writer then died of a segmentation fault
    (exit 139, half a run folder left). Arrow now uses the C library's allocator."""
    import subprocess
    import sys

    few = gpd.read_parquet(files / "few.parquet").iloc[:1]
    few.to_parquet(tmp_path / "one.parquet")      # WKB, as geopandas writes by default
    out = tmp_path / "run"
    code = ("import resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_AS, (3_000_000_000, 3_000_000_000))\n"
            "from citysynth.pipeline.cli import main\n"
            f"sys.exit(main(['city', '--footprints', {str(tmp_path / 'one.parquet')!r}, "
            f"'--library', {str(LIB)!r}, '-o', {str(out)!r}, '--workers', '1', "
            "'--no-overview']))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 0, (p.returncode, p.stderr[-2000:])
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["built"] == 1, report["counts"]


def test_tunnels_tram_lines_ferries_and_underground_buildings_bound_and_build_nothing(
        tmp_path, capsys):
    """Lines that run under the blocks (a road tunnel), down a street's middle (a tram
    line) or over water (a ferry route) bound no block: the city is the one without
    them, each kind one entry in the report; a footprint under the ground (an Overture
    garage, ``location=underground``) is left out with that reason."""
    data = json.loads(STREETS.read_text())
    plain = tmp_path / "plain.geojson"
    plain.write_text(json.dumps(data))
    feats = data["features"]
    xs = [c[0] for f in feats for c in f["geometry"]["coordinates"]]
    ys = [c[1] for f in feats for c in f["geometry"]["coordinates"]]
    across = [[min(xs), (min(ys) + max(ys)) / 2], [max(xs), (min(ys) + max(ys)) / 2]]
    for props in ({"highway": "primary", "tunnel": "yes"}, {"railway": "tram"},
                  {"route": "ferry"}):
        feats.append({"type": "Feature", "properties": props,
                      "geometry": {"type": "LineString", "coordinates": across}})
    extra = tmp_path / "extra.geojson"
    extra.write_text(json.dumps(data))
    buildings = json.loads(BUILDINGS.read_text())
    buildings["features"] = buildings["features"][:3]
    buildings["features"][1]["properties"]["location"] = "underground"
    buildings["features"][2]["properties"]["building"] = "no"   # mapped, not a building
    fp = tmp_path / "fp.geojson"
    fp.write_text(json.dumps(buildings))
    cfg = tmp_path / "c.toml"
    cfg.write_text("k = 1\n")
    assert city(tmp_path / "a", "--streets", str(plain), "--config", str(cfg)) == 0
    assert city(tmp_path / "b", "--streets", str(extra), "--config", str(cfg)) == 0
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    reasons = [s["reason"] for s in
               json.loads((tmp_path / "b" / "report.json").read_text())["skipped"]]
    for rule in ("tunnel=yes", "railway=tram", "route=ferry"):
        assert f"1 line(s) with {rule} left out: not streets" in " ".join(reasons), reasons
    assert city(tmp_path / "f", "--footprints", str(fp), "--config", str(cfg)) == 0
    report = json.loads((tmp_path / "f" / "report.json").read_text())
    assert report["counts"]["built"] == 1
    assert any("feature 1" in s["reason"] and "underground (location=underground)" in
               s["reason"] for s in report["skipped"]), report["skipped"]
    assert any("feature 2: building=no: not a building; left out" in s["reason"]
               for s in report["skipped"]), report["skipped"]



def _dxf(polygons, lines, path: Path) -> None:
    """A CAD drawing as a draughtsman's would be: footprints as closed LWPOLYLINEs on
    CAD layer BUILDINGS, street centre lines on STREETS, a note and a curb besides."""
    out = ["0", "SECTION", "2", "ENTITIES"]
    for layer, shapes, closed in (("BUILDINGS", polygons, 1), ("STREETS", lines, 0)):
        for n, pts in enumerate(shapes):
            out += ["0", "LWPOLYLINE", "5", f"{layer[0]}{n:X}", "8", layer,
                    "90", str(len(pts)), "70", str(closed)]
            for x, y in pts:
                out += ["10", repr(x), "20", repr(y)]
    out += ["0", "TEXT", "8", "NOTES", "10", "0", "20", "0", "40", "2", "1", "north",
            "0", "LINE", "8", "CURB", "10", "0", "20", "0", "11", "9", "21", "0",
            "0", "ENDSEC", "0", "EOF"]
    path.write_text("\n".join(out) + "\n")


def test_a_closed_polyline_inside_another_is_its_courtyard(tmp_path):
    """A drawing has no polygon with holes: a courtyard is a closed polyline inside the
    building's, and a kiosk inside the courtyard a building again (even-odd, as CAD
    fills). The courtyard was left out as "100 % of it lies inside" the building, and
    the building built solid (a tester's drawing of the demo district: 7 courtyards
    lost)."""
    from citysynth.pipeline.city.config import parse_config
    from citysynth.pipeline.city.run import prepare

    x0, y0 = 385000.0, 6672000.0
    square = [(0, 0), (60, 0), (60, 60), (0, 60)]
    yard = [(20, 20), (40, 20), (40, 40), (20, 40)]
    kiosk = [(25, 25), (35, 25), (35, 35), (25, 35)]
    loose = [(100, 0), (130, 0), (130, 20), (100, 20)]     # a house on its own
    drawing = tmp_path / "yard.dxf"
    _dxf([[(x0 + x, y0 + y) for x, y in r] for r in (square, yard, kiosk, loose)], [],
         drawing)
    inputs = prepare(None, f"{drawing}::BUILDINGS", parse_config({"k": 1}), LIB,
                     "EPSG:3067")
    shapes = sorted((shapely.from_wkt(j.wkt) for j in inputs.jobs), key=lambda g: -g.area)
    assert [round(g.area) for g in shapes] == [3200, 600, 100]
    assert [len(g.interiors) for g in shapes] == [1, 0, 0]
    assert not any("lies inside" in s["reason"] for s in inputs.skipped), inputs.skipped


def test_a_cad_drawing_builds_the_city_its_geojson_does(files, tmp_path, capsys):
    """A DXF drawing in EPSG:3067 (``--crs``: a drawing has no CRS): its STREETS layer's
    polylines are the streets, its BUILDINGS layer's closed polylines the footprints,
    each named by its entity handle; the city is the GeoJSON one, byte for byte. A CAD
    layer it lacks, or no CRS, is one line."""
    metric = gpd.read_file(files / "streets.geojson")
    buildings = gpd.read_file(BUILDINGS).to_crs(3067).iloc[:20]
    polygons = [list(getattr(g, "geoms", [g])[0].exterior.coords)[:-1]
                for g in buildings.geometry]
    lines = [list(g.coords) for g in metric.geometry]
    drawing = tmp_path / "city.dxf"
    _dxf(polygons, lines, drawing)
    import shapely

    gpd.GeoDataFrame({"id": [f"B{n:X}" for n in range(len(polygons))]},
                     geometry=[shapely.Polygon(p) for p in polygons], crs=3067).to_file(
        tmp_path / "b.geojson", driver="GeoJSON")
    gpd.GeoDataFrame(geometry=[shapely.LineString(p) for p in lines], crs=3067).to_file(
        tmp_path / "s.geojson", driver="GeoJSON")
    cfg = tmp_path / "c.toml"
    cfg.write_text('k = 1\npick = "best"\n')
    assert city(tmp_path / "a", "--streets", str(tmp_path / "s.geojson"), "--footprints",
                str(tmp_path / "b.geojson"), "--config", str(cfg)) in (0, 1)
    assert city(tmp_path / "b", "--streets", f"{drawing}::STREETS", "--footprints",
                f"{drawing}::BUILDINGS", "--crs", "EPSG:3067", "--config", str(cfg)) in (0, 1)
    capsys.readouterr()
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    built = json.loads((tmp_path / "b" / "report.json").read_text())["counts"]["built"]
    assert built >= 30
    assert city(tmp_path / "c", "--footprints", f"{drawing}::WALLS", "--crs",
                "EPSG:3067") == 2
    assert "no CAD layer 'WALLS'; its layers are BUILDINGS, CURB, NOTES, STREETS" in \
        capsys.readouterr().err
    assert city(tmp_path / "c", "--footprints", f"{drawing}::NOTES", "--crs",
                "EPSG:3067") == 2
    assert "no closed polylines or polygons (footprints) on CAD layer 'NOTES'" in \
        capsys.readouterr().err
    assert city(tmp_path / "c", "--footprints", str(drawing)) == 2
    assert "are not longitude/latitude" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()
    from citysynth.skeletons import InputWarning
    from citysynth.skeletons.geojson import read_geojson

    with pytest.warns(InputWarning, match=r"read the entities of 3 CAD layers \(BUILDINGS, "
                      r"CURB, STREETS\); name the one to read as .*::BUILDINGS"):
        feats, _ = read_geojson(drawing, crs="EPSG:3067", accept="lines")
    assert len(feats) == len(lines) + len(polygons) + 1
    assert feats[0].name == "feature 0 (B0)"       # named by its entity handle


def test_a_geoparquet_past_the_limit_uncompressed_is_refused_before_reading(
        tmp_path, capsys, monkeypatch):
    """Parquet compresses many times over: a 20 MB table in a file of a few kB is
    refused on its uncompressed size, with the estimate, before it is read."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 200_000
    table = pa.table({"note": ["x" * 100] * n, "geometry": [_LINE] * n})
    table = table.replace_schema_metadata({"geo": json.dumps(_wkb_geo())})
    small = tmp_path / "small.parquet"
    pq.write_table(table, small, compression="zstd", use_dictionary=False)
    assert small.stat().st_size < 1e6
    monkeypatch.setenv("CITYSYNTH_MAX_INPUT_MB", "1")
    assert city(tmp_path / "o", "--streets", str(small)) == 2
    err = capsys.readouterr().err
    assert "MB of data uncompressed, more than the 1 MB an input may hold" in err, err
    assert "raise $CITYSYNTH_MAX_INPUT_MB" in err and not (tmp_path / "o").exists()


@pytest.mark.parametrize("nested", [False, True])
def test_a_geoparquet_whose_dictionary_repeats_a_megabyte_is_refused(tmp_path, capsys,
                                                                     nested):
    """Parquet stores a repeated value once in a dictionary: 2,000 rows of one 1 MB text
    fit a file of 2 kB and are 2 GB once read (a MemoryError, or the machine's memory,
    before). The data are measured with the dictionaries kept, nested columns too, and
    refused like any input past the limit."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    n, text = 2000, "x" * 1_000_000
    # built as dictionaries (the test would otherwise hold the gigabytes itself)
    note = pa.DictionaryArray.from_arrays(pa.array(np.zeros(n, dtype=np.int32)),
                                          pa.array([text]))
    if nested:
        rules = pa.ListArray.from_arrays(pa.array(np.arange(n + 1, dtype=np.int32)),
                                         pa.StructArray.from_arrays([note], ["value"]))
        note = pa.StructArray.from_arrays([note, rules], ["primary", "rules"])
    table = pa.table({"geometry": pa.array([_LINE] * n, pa.binary()), "note": note})
    table = table.replace_schema_metadata({"geo": json.dumps(_wkb_geo())})
    bomb = tmp_path / "bomb.parquet"
    pq.write_table(table, bomb, compression="zstd")
    assert bomb.stat().st_size < 10_000
    assert city(tmp_path / "o", "--streets", str(bomb)) == 2
    err = capsys.readouterr().err
    assert f"{2 * n if nested else n:,} MB of data with its repeated values written out, " \
        "more than the 100 MB an input may hold" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("zipped", [True, False])
def test_a_shapefile_past_the_limit_in_its_zip_or_dbf_is_refused(tmp_path, capsys,
                                                                 monkeypatch, zipped):
    """The limit saw the file given: a zip of a few MB held a 520 MB Shapefile (5 GB
    read, then a crash), and a Shapefile's .dbf beside its small .shp was not counted.
    The zip's members' sizes and every file of the Shapefile count now."""
    import os

    n = 10_000
    lines = shapely.linestrings(np.broadcast_to([[24.94, 60.17], [24.95, 60.17]], (n, 2, 2)))
    frame = gpd.GeoDataFrame({"note": ["x" * 200] * n, "highway": ["residential"] * n},
                             geometry=lines, crs="EPSG:4326")
    frame.to_file(tmp_path / "pile.shp", engine="pyogrio")
    given = tmp_path / "pile.shp"
    if zipped:
        given = tmp_path / "pile.zip"
        with zipfile.ZipFile(given, "w", zipfile.ZIP_DEFLATED) as archive:
            for f in sorted(tmp_path.glob("pile.*")):
                if f != given:
                    archive.write(f, f.name)
        assert given.stat().st_size < 200_000
    assert os.path.getsize(tmp_path / "pile.shp") < 1e6
    monkeypatch.setenv("CITYSYNTH_MAX_INPUT_MB", "1")
    assert city(tmp_path / "o", "--streets", str(given)) == 2
    err = capsys.readouterr().err
    how = "unzipped" if zipped else "with the other files of the Shapefile beside it"
    assert f"MB of data {how}, more than the 1 MB an input may hold" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("kind", ["node", "way"])
def test_an_osm_file_giving_an_id_twice_says_so(tmp_path, capsys, kind):
    """GDAL indexes an OpenStreetMap file's objects in SQLite; an id given twice was
    told as "cannot read this OpenStreetMap file (nodes.id); check that it is whole"."""
    nodes = [f'<node id="{i}" lat="50.73" lon="{7.1 + i / 1000}" version="1"/>'
             for i in range(1, 6)]
    ring = "".join(f'<nd ref="{i}"/>' for i in (1, 2, 3, 1))
    ways = [f'<way id="100" version="1">{ring}<tag k="building" v="yes"/></way>',
            f'<way id="{100 if kind == "way" else 101}" version="1">'
            f'<nd ref="3"/><nd ref="4"/><nd ref="5"/><nd ref="3"/>'
            '<tag k="building" v="yes"/></way>']
    if kind == "node":
        nodes.append('<node id="2" lat="50.74" lon="7.2" version="1"/>')
    f = tmp_path / "map.osm"
    f.write_text('<?xml version="1.0" encoding="UTF-8"?>\n<osm version="0.6">\n'
                 + "\n".join(nodes + ways) + "\n</osm>\n")
    assert main(["city", "--footprints", str(f), "--library", str(LIB), "-o",
                 str(tmp_path / "run"), "--no-overview"]) == 2
    err = capsys.readouterr().err
    assert f"two {kind}s of this OpenStreetMap file share one id" in err, err
    assert "osmium merge" in err and not (tmp_path / "run").exists()


@pytest.mark.parametrize("option, what", [
    ("--footprints", "no buildings (areas tagged building=*) in this OpenStreetMap file"),
    ("--streets", "no streets (ways tagged highway=*) in this OpenStreetMap file")])
def test_an_osm_file_without_what_is_asked_says_so_in_osm_terms(tmp_path, capsys, option,
                                                                what):
    """An extract with neither buildings nor streets (a park's paths only): told in
    OpenStreetMap's terms, not as GDAL's empty layer ("layer 'multipolygons' has no
    features"), found by a probe on 2026-11-30."""
    nodes = [f'<node id="{n}" lat="{50.73 + n * 1e-4}" lon="7.1" version="1"/>'
             for n in range(1, 4)]
    way = ('<way id="100" version="1"><nd ref="1"/><nd ref="2"/><nd ref="3"/>'
           '<tag k="leisure" v="park"/></way>')
    f = tmp_path / "park.osm"
    f.write_text('<?xml version="1.0" encoding="UTF-8"?>\n<osm version="0.6">\n'
                 + "\n".join([*nodes, way]) + "\n</osm>\n")
    assert main(["city", option, str(f), "--library", str(LIB), "-o",
                 str(tmp_path / "run"), "--no-overview"]) == 2
    err = capsys.readouterr().err
    assert what in err and "multipolygons" not in err, err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "run").exists()


def test_a_shapefile_cut_short_is_told_so(files, tmp_path, capsys):
    """A .shp shorter than its header says: GDAL gave its lost shapes as features
    without geometry, told as "no geometry (null)"."""
    for ext in ("shx", "dbf", "prj"):
        shutil.copy(files / f"streets.{ext}", tmp_path / f"cut.{ext}")
    data = (files / "streets.shp").read_bytes()
    (tmp_path / "cut.shp").write_bytes(data[:len(data) // 2])
    assert city(tmp_path / "o", "--streets", str(tmp_path / "cut.shp")) == 2
    err = capsys.readouterr().err
    assert f"cut short: its header gives {len(data):,} bytes, the file has " \
           f"{len(data) // 2:,}" in err, err
    assert not (tmp_path / "o").exists()


def test_a_flatgeobuf_cut_after_its_header_is_told_so(files, tmp_path, capsys):
    """A FlatGeobuf copied part-way, its header whole and no feature after it, read as
    "layer 'few' has no features; export the layer with its features": its header
    lists 12, none could be read."""
    data = (files / "few.fgb").read_bytes()
    header = 12 + int.from_bytes(data[8:12], "little")   # magic, size, header
    (tmp_path / "few.fgb").write_bytes(data[:header])
    assert city(tmp_path / "o", "--footprints", str(tmp_path / "few.fgb")) == 2
    err = capsys.readouterr().err
    assert err.endswith(f"{tmp_path / 'few.fgb'}: its header lists 12 features in layer "
                        "'few' but none could be read: the FlatGeobuf is cut short or "
                        "damaged; copy or export it again\n"), err
    assert not (tmp_path / "o").exists()
    # cut part-way through its features: GDAL's "(Fatal error parsing feature)" before
    (tmp_path / "few.fgb").write_bytes(data[:(header + len(data)) // 2])
    assert city(tmp_path / "o", "--footprints", str(tmp_path / "few.fgb")) == 2
    assert "cannot read this FlatGeobuf: it ends part-way through its features (cut short " \
        "or damaged); check that it is whole" in capsys.readouterr().err


def test_an_osm_street_with_a_gap_in_its_nodes_is_warned_of(tmp_path, capsys):
    """An extract clipped with osmium's simple strategy keeps ways whose nodes outside
    it are gone; GDAL joins the nodes either side of a gap straight, a chord the map
    has not: warned of, by way. A way missing nodes only at its ends (it left the
    extract) is merely shorter: no warning."""
    nodes = [(1, 7.100), (2, 7.101), (4, 7.103), (5, 7.100), (6, 7.103)]
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6">']
    lines += [f'<node id="{i}" lat="{50.73 + 0.0003 * (i > 4)}" lon="{lon}" version="1"/>'
              for i, lon in nodes]
    lines += ['<way id="100" version="1"><nd ref="1"/><nd ref="2"/><nd ref="3"/>'
              '<nd ref="4"/><tag k="highway" v="residential"/></way>',
              '<way id="101" version="1"><nd ref="9"/><nd ref="5"/><nd ref="6"/>'
              '<tag k="highway" v="residential"/></way>', "</osm>"]
    f = tmp_path / "clipped.osm"
    f.write_text("\n".join(lines) + "\n")
    from citysynth.skeletons import InputWarning
    from citysynth.skeletons.geojson import read_geojson
    with pytest.warns(InputWarning) as caught:
        read_geojson(f, accept="lines")
    gaps = [str(w.message) for w in caught if "name nodes this file does not hold" in
            str(w.message)]
    assert len(gaps) == 1 and "1 street way(s) (e.g. way 100)" in gaps[0], gaps
    assert "osmium extract --strategy complete_ways" in gaps[0]


def test_an_osm_pbf_street_with_a_gap_in_its_nodes_is_warned_of(tmp_path):
    """The same extract as a PBF file (written by libosmium, as osmium extract and
    osmconvert write them): its ways are scanned too, by osmium's node location
    index. A whole way, and one missing only its first node, give no warning."""
    import osmium

    from citysynth.skeletons import InputWarning
    from citysynth.skeletons.geojson import read_geojson

    f = tmp_path / "clipped.osm.pbf"
    writer = osmium.SimpleWriter(str(f))
    for i, lon in [(1, 7.100), (2, 7.101), (4, 7.103), (5, 7.100), (6, 7.103), (7, 7.104)]:
        writer.add_node(osmium.osm.mutable.Node(id=i, location=(lon, 50.73 + 0.0003 * (i > 4)),
                                                version=1))
    street = {"highway": "residential"}
    for way, refs in [(100, [1, 2, 3, 4]), (101, [9, 5, 6]), (102, [5, 6, 7])]:
        writer.add_way(osmium.osm.mutable.Way(id=way, nodes=refs, tags=street, version=1))
    writer.close()
    with pytest.warns(InputWarning) as caught:
        read_geojson(f, accept="lines")
    gaps = [str(w.message) for w in caught if "name nodes this file does not hold" in
            str(w.message)]
    assert len(gaps) == 1 and "1 street way(s) (e.g. way 100)" in gaps[0], gaps


@pytest.mark.parametrize("inside", ["x.geojson", "city.gpkg", ""])
def test_a_zip_without_a_shapefile_says_what_it_holds(files, tmp_path, capsys, inside):
    """A zipped GeoJSON renamed .geojson (or a zip of a GeoPackage, or an empty one) was
    called a zipped Shapefile GDAL did not recognise; now it is said to be a zip
    archive, with what it holds and no .shp, to unzip."""
    given = tmp_path / "streets.geojson"
    with zipfile.ZipFile(given, "w") as archive:
        if inside:
            archive.write(STREETS if inside.endswith("json") else files / inside, inside)
    assert city(tmp_path / "o", "--streets", str(given)) == 2
    err = capsys.readouterr().err
    assert f"a zip archive holding {inside or 'nothing'}, with no .shp file" in err, err
    assert "unzip it" in err and "not recognized" not in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_a_shapefile_whose_prj_is_not_read_is_warned_of(files, tmp_path):
    """A .prj GDAL cannot read (damaged, hand-written) left the Shapefile without a CRS,
    silently taken as lon/lat; now warned of, naming the .prj; not when --crs says the
    CRS."""
    from citysynth.skeletons import InputWarning
    from citysynth.skeletons.geojson import read_geojson
    for ext in ("shp", "shx", "dbf"):
        shutil.copy(files / f"streets.{ext}", tmp_path / f"s.{ext}")
    (tmp_path / "s.prj").write_text("bad prj garbage")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_geojson(tmp_path / "s.shp", crs="EPSG:3067", accept="lines")
    assert not [w for w in caught if "s.prj" in str(w.message)]
    with pytest.warns(InputWarning) as caught:
        try:
            read_geojson(tmp_path / "s.shp", accept="lines")
        except Exception:
            pass   # projected coordinates taken as lon/lat are refused after the warning
    said = [str(w.message) for w in caught if "s.prj" in str(w.message)]
    assert len(said) == 1 and "not a coordinate system GDAL can read" in said[0], said
    assert "give --crs" in said[0]


def test_an_osm_object_without_a_name_is_named_by_its_osm_id(files):
    """Messages named an OpenStreetMap building without a name "feature 107", which no
    map shows; it is named by its way's id now, as GDAL reads it."""
    from citysynth.skeletons.geojson import read_geojson
    feats, _frame = read_geojson(files / "map.osm", accept="polygons")
    unnamed = [f for f in feats if "name" not in f.properties]
    assert unnamed, [f.properties for f in feats]
    for f in unnamed:
        assert f.name == f"feature {f.index} (way {f.properties['osm_way_id']})", f.name


def test_layers_of_no_declared_type_are_picked_by_their_features(files, tmp_path, capsys):
    """A KML of two folders (ogr2ogr's, or Google Earth's) and a GeoPackage written as
    generic geometry declare no geometry type ("Unknown"): each option reads the layer
    whose features it takes (both were refused as "no line layer")."""
    from citysynth.skeletons.gis_files import read_gis_file
    streets = gpd.read_file(files / "city.gpkg", layer="streets").iloc[:40]
    houses = gpd.read_file(files / "city.gpkg", layer="buildings").iloc[:6]
    for name, driver, extra in (("both.kml", "KML", {}),
                                ("generic.gpkg", "GPKG", {"geometry_type": "Unknown"})):
        path = tmp_path / name
        streets.to_file(path, layer="streets", driver=driver, **extra)
        houses.to_file(path, layer="buildings", driver=driver, **extra)
        fmt = "KML" if driver == "KML" else "GeoPackage"
        lines = read_gis_file(path, None, fmt, "lines")["features"]
        polygons = read_gis_file(path, None, fmt, "polygons")["features"]
        assert len(lines) == 40 and {f["geometry"]["type"] for f in lines} <= \
            {"LineString", "MultiLineString"}, name
        assert len(polygons) == 6 and {f["geometry"]["type"] for f in polygons} <= \
            {"Polygon", "MultiPolygon"}, name


def test_an_esri_json_numbered_102100_reads_without_gdal_warnings(files, tmp_path):
    """Esri's own number for Web Mercator (``"wkid": 102100`` without ``latestWkid``,
    as older ArcGIS servers send it) printed GDAL's RuntimeWarnings with pyogrio's
    source lines before a run that read it right."""
    web = gpd.read_file(files / "few3857.geojson")
    data = esri_json(web)
    data["spatialReference"] = {"wkid": 102100}
    path = tmp_path / "old.esri.json"
    path.write_text(json.dumps(data))
    import warnings

    from citysynth.skeletons.gis_files import read_gis_file
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        got = read_gis_file(path, None, "Esri JSON", "polygons")
    assert len(got["features"]) == len(web)
    assert not [w for w in seen if issubclass(w.category, RuntimeWarning)], \
        [str(w.message) for w in seen]


def _gml_streets(lines: list, path: Path) -> Path:
    """A GML file of street lines in EPSG:3067 without its schema, as a WFS or a
    cadastre gives one; a tag given a list repeats its element, which GDAL reads as a
    list field (StringList, IntegerList)."""
    feats = []
    for i, (coords, tags) in enumerate(lines):
        pos = " ".join(f"{x} {y}" for x, y in coords)
        props = "".join(f"<ogr:{k}>{v}</ogr:{k}>" for k, vs in tags.items()
                        for v in (vs if isinstance(vs, list) else [vs]))
        feats.append(f'<ogr:featureMember><ogr:streets gml:id="s.{i}"><ogr:geometryProperty>'
                     '<gml:LineString srsName="urn:ogc:def:crs:EPSG::3067"><gml:posList>'
                     f"{pos}</gml:posList></gml:LineString></ogr:geometryProperty>{props}"
                     "</ogr:streets></ogr:featureMember>")
    path.write_text('<?xml version="1.0" encoding="utf-8" ?>\n<ogr:FeatureCollection '
                    'xmlns:ogr="http://ogr.maptools.org/" '
                    'xmlns:gml="http://www.opengis.net/gml/3.2">' + "".join(feats)
                    + "</ogr:FeatureCollection>\n")
    return path


def _listed_grid() -> list:
    """A 2 x 2 grid of blocks 100 m apart whose tags are lists (an osmnx merged edge),
    and a footway across one block, which bounds none."""
    x0, y0 = 385000.0, 6672000.0
    lines: list = []
    for i in range(3):
        lines.append(([(x0 + 100 * i, y0), (x0 + 100 * i, y0 + 200)],
                      {"highway": ["residential", "unclassified"],
                       "junction": ["no", "yes"][:1 + i % 2]}))
        lines.append(([(x0, y0 + 100 * i), (x0 + 200, y0 + 100 * i)],
                      {"highway": "residential", "lanes": ["2", "3"]}))
    lines.append(([(x0 + 10, y0 + 50), (x0 + 90, y0 + 50)], {"highway": ["footway", "path"]}))
    return lines


def _geojson_of(lines: list, path: Path) -> Path:
    path.write_text(json.dumps({"type": "FeatureCollection", "crs": {
        "type": "name", "properties": {"name": "EPSG:3067"}}, "features": [
        {"type": "Feature", "properties": tags, "geometry": {
            "type": "LineString", "coordinates": coords}} for coords, tags in lines]}))
    return path


def test_list_fields_of_gml_and_geopackage_read_as_the_geojson_lists(tmp_path, capsys):
    """GDAL reads a GML element given twice as a list field, and a GeoPackage stores a
    list as OGR's text ``(2:residential,unclassified)``. A street whose ``junction``
    was such a list crashed the run (an internal error, exit 3); a footway given
    ``highway`` as a list bounded a block, and ``lanes`` of a list fell back to the
    default setback, without a word. Both read as the GeoJSON of the same lists does;
    and reading the GML leaves no ``.gfs`` beside it (GDAL writes its guess of the
    schema there)."""
    lines = _listed_grid()
    ref = _geojson_of(lines, tmp_path / "ref.geojson")
    gml = _gml_streets(lines, tmp_path / "streets.gml")
    import pyogrio
    gpkg = tmp_path / "streets.gpkg"
    frame = gpd.GeoDataFrame(
        {k: [_ogr_text(tags.get(k)) for _, tags in lines]
         for k in ("highway", "junction", "lanes")},
        geometry=[shapely.LineString(c) for c, _ in lines], crs="EPSG:3067")
    pyogrio.write_dataframe(frame, gpkg, driver="GPKG")
    assert city(tmp_path / "ref", "--streets", str(ref)) == 0
    want = json.loads((tmp_path / "ref" / "manifest.json").read_text())["blocks"]
    assert len([b for b in want.values() if b["status"] == "built"]) == 4
    for src in (gml, gpkg):
        capsys.readouterr()
        assert city(tmp_path / src.suffix[1:], "--streets", str(src)) == 0, \
            capsys.readouterr().err
        got = json.loads((tmp_path / src.suffix[1:] / "manifest.json").read_text())["blocks"]
        assert sorted(got) == sorted(want), src
    assert sorted(p.name for p in tmp_path.glob("streets.*")) == ["streets.gml",
                                                                  "streets.gpkg"]


def _ogr_text(v) -> str | None:
    """A value as a GeoPackage written by GDAL stores a list: ``(2:a,b)``."""
    if isinstance(v, list):
        return f"({len(v)}:{','.join(map(str, v))})"
    return v


def test_measured_geometry_reads_without_pyogrio_warnings(tmp_path):
    """Lines with M values (``-dim XYM`` exports, linear referencing) printed pyogrio's
    "Measured (M) geometry types are not supported" with its source lines, three a
    layer, before a run that read them right."""
    import sqlite3

    import pyogrio

    from citysynth.skeletons.gis_files import read_gis_file
    frame = gpd.GeoDataFrame(
        {"highway": ["residential"]},
        geometry=[shapely.LineString([(385000, 6672000), (385100, 6672000)])], crs="EPSG:3067")
    path = tmp_path / "m.gpkg"
    pyogrio.write_dataframe(frame, path, driver="GPKG")   # pyogrio writes no M layer:
    with sqlite3.connect(path) as db:                     # the layer is made one
        db.execute("UPDATE gpkg_geometry_columns SET m = 1")
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        got = read_gis_file(path, None, "GeoPackage", "lines")
    assert len(got["features"]) == 1
    assert not [str(w.message) for w in seen], [str(w.message) for w in seen]


def test_osm_buildings_exported_as_a_shapefile_keep_their_storeys(tmp_path):
    """GDAL writes ``building:levels`` to a Shapefile as ``building_l`` (and to GML as
    ``building_levels``): the footprints of a Shapefile export lost their storeys
    (families of 4, 5 and 6 storeys mixed where every building asked for 6), exit 0
    without a word. They read as the GeoJSON they came from."""
    from citysynth.skeletons import read_geojson
    ring = [(385000, 6672000), (385030, 6672000), (385030, 6672014), (385000, 6672014)]
    frame = gpd.GeoDataFrame({"building": ["yes"], "building:levels": ["6"],
                              "roof:shape": ["gabled"]},
                             geometry=[shapely.Polygon(ring)], crs="EPSG:3067")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # GDAL says it shortens the field names
        frame.to_file(tmp_path / "foot.shp")
        frame.to_file(tmp_path / "foot.gml", driver="GML")
    for name in ("foot.shp", "foot.gml"):
        (feat,), _ = read_geojson(tmp_path / name, accept="polygons")
        assert feat.properties["building:levels"] == "6", (name, feat.properties)
        assert feat.properties["roof:shape"] == "gabled", (name, feat.properties)


def test_a_zipped_folder_of_a_shapefile_reads_as_the_flat_zip(files, tmp_path):
    """Zipping a folder puts the Shapefile in it inside the archive (``sub/streets.shp``):
    GDAL reads only an archive's top level, and such a zip was refused with GDAL's
    "not recognized as being in a supported file format". It reads as the flat zip."""
    from citysynth.skeletons import read_geojson
    nested = tmp_path / "nested.zip"
    with zipfile.ZipFile(nested, "w") as z:
        for ext in ("shp", "shx", "dbf", "prj", "cpg"):
            if (files / f"streets.{ext}").exists():
                z.write(files / f"streets.{ext}", f"export/streets.{ext}")
    flat, _ = read_geojson(files / "streets.zip", accept="lines")
    got, _ = read_geojson(nested, accept="lines")
    assert len(got) == len(flat) > 400
    assert all(a.geometry.equals(b.geometry) for a, b in zip(got, flat, strict=True))


def test_an_esri_file_geodatabase_reads_as_its_geojson(files, tmp_path):
    """ArcGIS's File Geodatabase is a folder ``name.gdb`` (often shipped zipped): it
    was refused as "a folder, not a GeoJSON file; give the file's path", and its zip
    as one "with no .shp file in it; unzip it and give the file inside", where there
    is no one file to give. Both are read, each layer as its GeoJSON."""
    from citysynth.skeletons import read_geojson
    streets = gpd.read_file(files / "streets.geojson")
    gdb = tmp_path / "city.gdb"
    streets.to_file(gdb, layer="streets", driver="OpenFileGDB")
    with zipfile.ZipFile(tmp_path / "city.gdb.zip", "w") as z:
        for f in sorted(gdb.iterdir()):
            z.write(f, f"city.gdb/{f.name}")
    ref, _ = read_geojson(files / "streets.geojson", accept="lines")
    for src in (gdb, tmp_path / "city.gdb.zip"):
        got, frame = read_geojson(src, accept="lines")
        assert frame.source_crs == "EPSG:3067" and len(got) == len(ref), src
        # a geodatabase stores lines as MultiLineStrings, on a 0.1 mm grid
        assert max(a.geometry.hausdorff_distance(b.geometry)
                   for a, b in zip(got, ref, strict=True)) < 1e-3, src


def test_a_geopackage_saved_without_a_layer_says_so(tmp_path, capsys):
    """A whole GeoPackage that lists no layer (saved before a layer was added) was
    "cannot read this GeoPackage ('...' not recognized as being in a supported file
    format.); check that it is whole", of a file that is whole."""
    import sqlite3
    path = tmp_path / "empty.gpkg"
    gpd.GeoDataFrame({"a": [1]}, geometry=[shapely.Point(0, 0)], crs="EPSG:3067").to_file(
        path, layer="x", driver="GPKG")
    with sqlite3.connect(path) as db:
        db.execute("DELETE FROM gpkg_geometry_columns")
        db.execute("DELETE FROM gpkg_contents")
        db.execute("DROP TABLE x")
    assert main(["skeleton", str(path)]) == 2
    err = capsys.readouterr().err
    assert "this GeoPackage holds no layer (saved empty)" in err and "whole" not in err, err


def test_an_esri_prj_of_an_epsg_crs_is_named_by_its_code(files, tmp_path):
    """The .prj ArcGIS and ogr2ogr write names EPSG:3067 "EUREF_FIN_TM35FIN": the run's
    frame (in every message, layout and blocks.geojson) was its whole WKT, 1.5 kB; it is
    named by the code."""
    import pyproj

    from citysynth.skeletons import read_geojson
    for ext in ("shp", "shx", "dbf"):
        shutil.copy(files / f"streets.{ext}", tmp_path / f"streets.{ext}")
    (tmp_path / "streets.prj").write_text(
        pyproj.CRS("EPSG:3067").to_wkt(pyproj.enums.WktVersion.WKT1_ESRI))
    _, frame = read_geojson(tmp_path / "streets.shp", accept="lines")
    assert frame.crs.endswith("(projected, EPSG:3067)") and len(frame.crs) < 80, frame.crs


def _office(path: Path, first: str, mimetype: str | None) -> Path:
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(zipfile.ZipInfo(first), mimetype or "<Types/>")
        z.writestr("content.xml", "<x/>")
    return path


@pytest.mark.parametrize("name, make, said", [
    ("sheet.ods", lambda p: _office(p, "mimetype",
                                    "application/vnd.oasis.opendocument.spreadsheet"),
     "an OpenDocument spreadsheet (.ods), not a layer of geometries; export the streets"),
    ("sheet.xlsx", lambda p: _office(p, "[Content_Types].xml", None),
     "an Office Open XML file (Excel .xlsx or Word .docx), not a layer of geometries"),
    ("sheet.xls", lambda p: p.write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + b"\0" * 500),
     "a Microsoft Office 97 file (Excel .xls or Word .doc), not a layer of geometries"),
    ("graph.graphml", lambda p: p.write_text(
        '<?xml version="1.0" encoding="utf-8"?>\n<graphml xmlns="http://graphml.graphdrawing'
        '.org/xmlns"><graph edgedefault="directed"><node id="1"/></graph></graphml>\n'),
     "a GraphML graph (osmnx's save_graphml), which GDAL does not read; save the graph as "
     "a GeoPackage instead (osmnx.io.save_graph_geopackage"),
])
def test_documents_that_hold_no_layer_are_named_for_what_they_are(tmp_path, capsys, name,
                                                                   make, said):
    """A spreadsheet was "cannot read this zipped Shapefile (... not recognized ...);
    check that it is whole", and osmnx's GraphML "XML ...: convert it, e.g. ogr2ogr",
    which cannot read it: each is named, with what to give instead."""
    path = tmp_path / name
    make(path)
    out = tmp_path / "out"
    assert city(out, "--streets", str(path)) == 2
    err = capsys.readouterr().err
    assert f"{path}: {said}" in err, err
    assert len(err.strip().splitlines()) == 1 and not out.exists()
