"""Street files as GIS tools really write them give the same blocks as the plain file.

The plain file is the shipped demo district (examples/city/district_streets.geojson,
RFC 7946 lon/lat). Each variant is written by the tool itself where the tool runs
offline: geopandas (pyogrio, GDAL's GeoJSON driver) with its default options (a legacy
``"crs"`` member naming CRS84) and with RFC7946=YES, in Web Mercator, in a UTM zone
near the data and in one far from it; a QGIS-style MultiLineString Z layer with null
geometries; osmnx's ``graph_to_gdfs`` with list-valued tags (on a graph built here,
and on a real osmnx graph read from OSM XML and simplified); an Overpass-style export
that mixes nodes (Points) with ways. "The same blocks" is checked on the city run's
jobs (``prepare``): the same block ids (a hash of the outline to the millimetre, so
the same outlines), zones, styles and input hashes (so the same layouts), and for
input that stays in its own projected frame, the same outlines within the length
tolerance once mapped back to lon/lat.
"""

from __future__ import annotations

import copy
import json
import re
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely

from citysynth.pipeline.city.config import load_config
from citysynth.pipeline.city.run import CityInputs, prepare
from citysynth.skeletons import InputWarning, SkeletonError, parse_geojson, read_geojson
from citysynth.skeletons.streets import Setbacks, highway_classes, street_setback, tag_values

gpd = pytest.importorskip("geopandas")
pytest.importorskip("pyogrio")

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
CITY = ROOT / "examples" / "city"
DISTRICT = CITY / "district_streets.geojson"
CRS84_NAME = "urn:ogc:def:crs:OGC:1.3:CRS84"
LENGTH_TOL = 1e-5            # 1 mm per 100 m


# --- helpers ------------------------------------------------------------------------------

def jobs_of(path: Path, crs: str | None = None) -> CityInputs:
    """The demo district's city jobs (zones, styles, setbacks from examples/city)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        return prepare(path, None, load_config(CITY / "city.toml"), LIB, crs)


def summary(inputs: CityInputs) -> list[tuple[str, str, str, str]]:
    return [(j.id, j.zone, j.style, j.input_hash) for j in inputs.jobs]


def feature_skips(inputs: CityInputs) -> list[str]:
    return [s["reason"] for s in inputs.skipped if s["kind"] == "feature"]


def outlines_lonlat(inputs: CityInputs, frame_crs: str) -> list[shapely.Polygon]:
    """Each job's outline back in lon/lat (x east, y north, degrees)."""
    to_lonlat = pyproj.Transformer.from_crs(frame_crs, "EPSG:4326", always_xy=True)
    ox, oy = inputs.frame.origin
    unit = pyproj.CRS(frame_crs).axis_info[0].unit_conversion_factor

    def back(c: np.ndarray) -> np.ndarray:
        return np.column_stack(to_lonlat.transform(c[:, 0] / unit + ox, c[:, 1] / unit + oy))
    return [shapely.transform(shapely.from_wkt(j.wkt), back) for j in inputs.jobs]


def outlines_in(inputs: CityInputs) -> list[shapely.Polygon]:
    return [shapely.from_wkt(j.wkt) for j in inputs.jobs]


@pytest.fixture(scope="module")
def plain() -> CityInputs:
    inputs = jobs_of(DISTRICT)
    assert len(inputs.jobs) >= 20 and any(j.zone == "main roads" for j in inputs.jobs)
    assert not feature_skips(inputs)
    return inputs


@pytest.fixture(scope="module")
def district_gdf():
    g = gpd.read_file(DISTRICT)            # pyogrio, geopandas' default engine
    assert str(g.crs) == "EPSG:4326" and len(g) == 489
    return g


def crs_member(path: Path) -> str | None:
    member = json.loads(path.read_text()).get("crs")
    return None if member is None else member["properties"]["name"]


# --- geopandas, default options and RFC 7946 ----------------------------------------------

def test_geopandas_default_geojson_with_its_crs84_member(plain, district_gdf, tmp_path):
    f = tmp_path / "streets.geojson"
    district_gdf.to_file(f, driver="GeoJSON")
    assert crs_member(f) == CRS84_NAME        # what GDAL, QGIS and osmnx write
    got = jobs_of(f)
    assert summary(got) == summary(plain) and got.frame == plain.frame


def test_geopandas_rfc7946(plain, district_gdf, tmp_path):
    f = tmp_path / "streets.geojson"
    district_gdf.to_file(f, driver="GeoJSON", RFC7946="YES")
    assert crs_member(f) is None
    assert summary(jobs_of(f)) == summary(plain)


# --- QGIS: MultiLineString Z, null geometries and null attributes ---------------------------

def test_qgis_style_multilinestring_z_with_nulls(plain, district_gdf, tmp_path):
    g = district_gdf.copy()
    g["geometry"] = [shapely.MultiLineString([shapely.force_3d(line, 12.5)])
                     for line in g.geometry]
    blanks = g.iloc[[3, 50, 200]].copy()
    blanks["geometry"] = None                         # QGIS keeps rows whose geometry
    blanks["lanes"] = None                            # was deleted, with null values
    g = gpd.GeoDataFrame(
        gpd.pd.concat([g.iloc[:10], blanks.iloc[:1], g.iloc[10:300], blanks.iloc[1:],
                       g.iloc[300:]], ignore_index=True), crs=g.crs)
    f = tmp_path / "qgis.geojson"
    g.to_file(f, driver="GeoJSON")
    raw = json.loads(f.read_text())
    assert raw["features"][0]["geometry"]["type"] == "MultiLineString"
    assert len(raw["features"][0]["geometry"]["coordinates"][0][0]) == 3     # x, y, z
    nulls = [i for i, ft in enumerate(raw["features"]) if ft["geometry"] is None]
    assert nulls == [10, 301, 302]
    with pytest.warns(InputWarning) as caught:
        feats, _ = read_geojson(f, accept="lines")
    messages = [str(w.message) for w in caught]
    assert feats.skipped == messages and len(messages) == 3
    for i, msg in zip(nulls, messages, strict=True):
        assert re.match(rf"{re.escape(str(f))}: feature {i}\b", msg), msg
        assert "no geometry (null)" in msg
    got = jobs_of(f)
    assert summary(got) == summary(plain)
    assert feature_skips(got) == messages     # counted in the run's report


# --- osmnx: list-valued tags ------------------------------------------------------------------

def _as_osmnx_edges(gdf):
    """The district as osmnx's ``graph_to_gdfs`` gives merged edges, through osmnx itself:
    a MultiDiGraph in osmnx's layout (nodes with x, y; edges with geometry and osmid), every
    street carrying list-valued tags as a merged edge would, each list's widest value
    being the street's own (lanes ["1", "2"] for a two-lane street; primary streets as
    ["secondary", "primary"], so a zone on primary must match any class of the list)."""
    ox = pytest.importorskip("osmnx")
    import networkx as nx
    g = nx.MultiDiGraph(crs="EPSG:4326")
    nodes: dict[tuple[float, float], int] = {}
    for i, row in gdf.iterrows():
        coords = list(row.geometry.coords)
        u, v = (nodes.setdefault(tuple(c), len(nodes)) for c in (coords[0], coords[-1]))
        lanes = row["lanes"]
        cls = row["highway"]
        g.add_edge(u, v, osmid=[1000 + i, 2000 + i],
                   highway=["secondary", "primary"] if cls == "primary" else [cls, "service"],
                   lanes=sorted({str(int(lanes) - 1 or 1), lanes}) if isinstance(lanes, str)
                   else None,
                   name=[row["name"]] * 2 if isinstance(row["name"], str) else None,
                   oneway=row["oneway"] == "yes", reversed=[False, True],
                   length=float(row.geometry.length), geometry=row.geometry)
    for (x, y), n in nodes.items():
        g.add_node(n, x=x, y=y)
    return ox.graph_to_gdfs(g, nodes=False)


def test_osmnx_edges_with_list_valued_tags(plain, district_gdf, tmp_path):
    edges = _as_osmnx_edges(district_gdf)
    f = tmp_path / "osmnx.geojson"
    edges.to_file(f, driver="GeoJSON")
    raw = json.loads(f.read_text())
    props = [ft["properties"] for ft in raw["features"]]
    assert {"u", "v", "key", "osmid"} <= set(props[0])
    assert all(isinstance(p["highway"], list) for p in props)      # JSON arrays
    assert any(isinstance(p["lanes"], list) and len(p["lanes"]) == 2 for p in props)
    got = jobs_of(f)
    assert summary(got) == summary(plain)        # widest setbacks; zones match any class
    assert any(j.zone == "main roads" and j.style == "modern" for j in got.jobs)


def test_a_real_osmnx_graph_read_from_osm_xml(district_gdf, tmp_path):
    """osmnx's own pipeline, offline: OSM XML -> graph_from_xml (simplified: ways merged
    into edges with list-valued tags) -> graph_to_gdfs -> GeoJSON. Every edge is read and
    a merged edge's setback comes from its widest lanes value."""
    ox = pytest.importorskip("osmnx")
    osm = tmp_path / "district.osm"
    osm.write_text(_osm_xml(district_gdf), encoding="utf-8")
    graph = ox.graph_from_xml(osm, simplify=True, retain_all=True)
    edges = ox.graph_to_gdfs(graph, nodes=False)
    f = tmp_path / "osmnx.geojson"
    edges.to_file(f, driver="GeoJSON")
    feats, _ = read_geojson(f, accept="lines")
    assert len(feats) == len(edges) and not feats.skipped
    s = Setbacks(lane_width=3.25, sidewalk=2.5)
    merged = [ft for ft in feats if isinstance(ft.properties.get("lanes"), list)]
    assert merged, "osmnx merged ways with different lanes into list-valued edges"
    for ft in merged:
        lanes = [float(x) for x in ft.properties["lanes"]]
        assert len(set(lanes)) > 1
        assert street_setback(ft.properties, s) == max(lanes) * 3.25 / 2 + 2.5


def _osm_xml(gdf) -> str:
    from xml.sax.saxutils import quoteattr
    nodes: dict[tuple[float, float], int] = {}
    ways = []
    for i, row in gdf.iterrows():
        refs = [nodes.setdefault(tuple(c), len(nodes) + 1) for c in row.geometry.coords]
        tags = {k: row[k] for k in ("highway", "lanes", "name", "oneway")
                if isinstance(row[k], str)}
        ways.append((i + 1, refs, tags))
    out = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6">']
    out += [f'<node id="{n}" lat="{y}" lon="{x}" version="1"/>' for (x, y), n in nodes.items()]
    for wid, refs, tags in ways:
        out.append(f'<way id="{wid}" version="1">')
        out += [f'<nd ref="{r}"/>' for r in refs]
        out += [f"<tag k={quoteattr(k)} v={quoteattr(str(v))}/>" for k, v in tags.items()]
        out.append("</way>")
    return "\n".join([*out, "</osm>"])


def test_list_valued_and_multi_valued_tags():
    s = Setbacks(default=6.0, sidewalk=2.5, lane_width=3.0,
                 by_class=(("primary", 10.0), ("secondary", 9.0), ("living_street", 4.0)))
    assert s({"lanes": ["2", "3"]}) == s({"lanes": "3"}) == s({"lanes": "2;3"}) == 7.0
    assert s({"lanes": "['2', '3']"}) == 7.0                  # osmnx's own files
    assert s({"width": ["7", "9 m", "n/a"]}) == 9 / 2 + 2.5
    assert s({"width": [None, "x"], "lanes": [1, 2]}) == 5.5  # no width: lanes
    assert s({"highway": ["secondary", "primary"]}) == 10.0
    assert s({"highway": ["living_street", "unclassified"]}) == 6.0   # the default is wider
    assert s({"highway": ["track", "path"]}) == 6.0
    assert highway_classes({"highway": ["secondary", "primary", "secondary"]}) == \
        ("secondary", "primary")
    assert highway_classes({"highway": "['primary', 'trunk']"}) == ("primary", "trunk")
    assert highway_classes({"highway": None}) == () and tag_values("a; b") == ["a", "b"]


# --- Overpass: ways mixed with nodes ------------------------------------------------------------

def test_overpass_export_with_points(plain, tmp_path):
    data = json.loads(DISTRICT.read_text())
    features = []
    for i, ft in enumerate(data["features"]):
        way = {"type": "Feature", "id": f"way/{1000 + i}",
               "properties": {"@id": f"way/{1000 + i}", **ft["properties"]},
               "geometry": ft["geometry"]}
        features.append(way)
        if i % 50 == 7:       # a traffic signal on the way: a node, a Point
            x, y = ft["geometry"]["coordinates"][0]
            features.append({"type": "Feature", "id": f"node/{i}",
                             "properties": {"@id": f"node/{i}", "highway": "traffic_signals"},
                             "geometry": {"type": "Point", "coordinates": [x, y]}})
    f = tmp_path / "export.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "generator": "overpass-turbo",
                             "copyright": "The data included in this document is from "
                             "www.openstreetmap.org.", "features": features}))
    points = [i for i, ft in enumerate(features) if ft["geometry"]["type"] == "Point"]
    got = jobs_of(f)
    assert summary(got) == summary(plain)
    skips = feature_skips(got)
    assert len(skips) == len(points) == 10
    for i, msg in zip(points, skips, strict=True):
        assert re.match(rf"{re.escape(str(f))}: feature {i}\b", msg), msg
        assert "a Point cannot be a line" in msg


# --- projected CRSs ---------------------------------------------------------------------------

def test_web_mercator_is_reprojected_to_true_lengths(plain, district_gdf, tmp_path):
    f = tmp_path / "mercator.geojson"
    district_gdf.to_crs("EPSG:3857").to_file(f, driver="GeoJSON")
    assert crs_member(f) == "urn:ogc:def:crs:EPSG::3857"
    merc, frame = read_geojson(f, origin_digits=2)
    ref, ref_frame = read_geojson(DISTRICT, origin_digits=2)
    assert frame.crs == ref_frame.crs and frame.origin == ref_frame.origin
    assert frame.source_crs == "EPSG:3857"
    for a, b in zip(merc, ref, strict=True):
        assert abs(a.geometry.length - b.geometry.length) <= LENGTH_TOL * b.geometry.length
    got = jobs_of(f)
    assert len(got.jobs) == len(plain.jobs)
    for a, b in zip(outlines_in(got), outlines_in(plain), strict=True):
        assert shapely.hausdorff_distance(a, b) < 0.002
    assert summary(got) == summary(plain)


def test_a_far_utm_zone_is_reprojected(plain, district_gdf, tmp_path):
    """Helsinki in UTM zone 31 (central meridian 3° E, 22° away): 4 % off true scale."""
    f = tmp_path / "far.geojson"
    district_gdf.to_crs("EPSG:32631").to_file(f, driver="GeoJSON")
    feats, frame = read_geojson(f, origin_digits=2)
    assert frame.crs == plain.frame.crs and frame.source_crs == "EPSG:32631"
    assert summary(jobs_of(f)) == summary(plain)


def test_a_near_utm_zone_stays_in_its_own_frame(plain, district_gdf, tmp_path):
    """ETRS-TM35FIN (EPSG:3067, UTM zone 35 extended over Finland) is true to scale over
    Helsinki within 0.03 %: kept as it is, so blocks come out in its axes. Mapped into
    the plain file's frame they are the plain file's blocks within 2 cm: the setbacks,
    measured in the zone's metres, are off by its 0.024 % scale error (2.4 mm on 10 m,
    more at sharp corners), and the outlines are simplified at 1 cm."""
    f = tmp_path / "tm35fin.geojson"
    district_gdf.to_crs("EPSG:3067").to_file(f, driver="GeoJSON")
    got = jobs_of(f)
    assert got.frame.crs.endswith("(projected, EPSG:3067)") and \
        got.frame.source_crs == "EPSG:3067"
    assert len(got.jobs) == len(plain.jobs)
    to_plain = pyproj.Transformer.from_crs("EPSG:4326", _tmerc(plain), always_xy=True)
    ref = outlines_in(plain)
    for p, job in zip(outlines_lonlat(got, "EPSG:3067"), got.jobs, strict=True):
        p = shapely.transform(p, lambda c: np.column_stack(to_plain.transform(c[:, 0],
                                                                               c[:, 1])))
        k = min(range(len(ref)), key=lambda r: ref[r].centroid.distance(p.centroid))
        assert len(p.exterior.coords) == len(ref[k].exterior.coords)
        assert shapely.hausdorff_distance(p, ref[k]) < 0.02
        assert (job.zone, job.style) == (plain.jobs[k].zone, plain.jobs[k].style)


@pytest.fixture(scope="module")
def tm35fin_block(district_gdf, tmp_path_factory):
    """The district in EPSG:3067 (kept as it is: true to scale over Helsinki), read as
    the city run reads it, and the built block nearest its frame's origin, written by the
    city's own job runner (layout JSON and USD layer) with city.usda over it."""
    from citysynth.pipeline.city.jobs import run_block
    from citysynth.pipeline.city.outputs import write_city_stage

    out = tmp_path_factory.mktemp("tm35fin")
    f = out / "tm35fin.geojson"
    district_gdf.to_crs("EPSG:3067").to_file(f, driver="GeoJSON")
    got = jobs_of(f)
    near = sorted(got.jobs, key=lambda j: shapely.from_wkt(j.wkt).centroid.distance(
        shapely.Point(0, 0)))
    for job in near:
        if run_block(job, str(out))["status"] == "built":
            write_city_stage(out, {"built": [job.id]}, got.frame.describe())
            return got, job, out
    raise AssertionError("no block of the district in EPSG:3067 is built")


def _georeference_of(usda: Path) -> dict:
    from pxr import Usd

    stage = Usd.Stage.Open(str(usda), load=Usd.Stage.LoadNone)
    root = stage.GetDefaultPrim()
    attrs = {a.GetName().rsplit(":", 1)[-1]: a.Get() for a in root.GetAttributes()
             if a.GetName().startswith("userProperties:citysynth:")}
    geo = dict(root.GetCustomData()["citysynth"]["georeference"])
    for key in ("crs", "origin_lon", "origin_lat"):
        assert attrs[key] == geo[key], key     # the attributes a DCC shows say the same
    return geo


def test_a_kept_projected_frame_is_georeferenced_in_a_crs_tools_resolve(plain, tm35fin_block):
    """The georeference of a run in EPSG:3067 (each block's layer, city.usda) names its
    CRS so pyproj resolves it, and its origin's lon/lat lies within a metre of where the
    lon/lat run puts that point: the run's blocks moved onto the same blocks of the
    lon/lat run (each outline within 2 cm, see above) by the rigid motion that fits them
    best (TM35FIN's north is turned 1.8° from the district's meridian), which carries
    the frame's origin into the lon/lat run's frame. It named the CRS
    "ETRS89 / TM35FIN(E,N) (projected)", which nothing resolves, and gave no lon/lat."""
    got, job, out = tm35fin_block
    layout = json.loads((out / "blocks" / f"{job.id}.layout.json").read_text())
    assert layout["frame"] == got.frame.describe()
    assert "(projected, EPSG:3067), origin" in layout["frame"]
    to_plain = pyproj.Transformer.from_crs("EPSG:4326", _tmerc(plain), always_xy=True)
    ref = [p.centroid for p in outlines_in(plain)]
    pairs = []
    for mine, lonlat in zip(outlines_in(got), outlines_lonlat(got, "EPSG:3067"), strict=True):
        there = shapely.Point(to_plain.transform(lonlat.centroid.x, lonlat.centroid.y))
        near = min(ref, key=there.distance)
        pairs.append((mine.centroid.x, mine.centroid.y, near.x, near.y))
    a, b = np.array(pairs)[:, :2], np.array(pairs)[:, 2:]
    u, _s, vt = np.linalg.svd((a - a.mean(0)).T @ (b - b.mean(0)))     # Kabsch
    turn = (u @ vt).T
    assert np.linalg.det(turn) > 0
    # every block within 0.25 m: TM35FIN's scale is 0.024 % off over the district's 1 km
    assert np.abs((a - a.mean(0)) @ turn.T + b.mean(0) - b).max() < 0.25
    origin = b.mean(0) - turn @ a.mean(0)      # the frame's (0, 0) in the lon/lat run
    for usda in (out / "blocks" / f"{job.id}.usda", out / "city.usda"):
        geo = _georeference_of(usda)
        assert pyproj.CRS.from_user_input(geo["crs"]) == pyproj.CRS("EPSG:3067"), usda
        assert geo["crs_name"] == "ETRS89 / TM35FIN(E,N)"
        assert list(geo["origin"]) == pytest.approx(list(got.frame.origin), abs=1e-6)
        written = np.array(to_plain.transform(geo["origin_lon"], geo["origin_lat"]))
        assert np.hypot(*(written - origin)) < 1.0, (usda, written, origin)


def test_writing_builds_one_transformer_per_crs_not_one_per_layer(tm35fin_block, tmp_path,
                                                                  monkeypatch):
    """Five layers and a city stage in the EPSG:3067 frame ask pyproj for at most one
    transformer (made when the first georeference is written). Each layer built one from
    the frame's text, a search of PROJ's database by name that failed, 0.2-0.6 s a layer:
    the district's JSON + USD took 74 CPU s in EPSG:3067 against 11 in lon/lat."""
    from citysynth.export.layout import Layout
    from citysynth.export.usd import write_city, write_layout
    from citysynth.parts_db import load_library

    _got, job, out = tm35fin_block
    lay = Layout.from_dict(json.loads((out / "blocks" / f"{job.id}.layout.json").read_text()))
    db = load_library(LIB)
    made: list[tuple] = []
    from_crs = pyproj.Transformer.from_crs

    def counted(*args, **kwargs):
        made.append(args)
        return from_crs(*args, **kwargs)
    monkeypatch.setattr(pyproj.Transformer, "from_crs", counted)
    layers = [write_layout(lay, db, tmp_path / f"layer_{n}.usda") for n in range(5)]
    city = write_city(tmp_path / "city.usda", [(p.stem, p.name) for p in layers],
                      frame=lay.frame)
    assert len(made) <= 1, made
    for usda in (*layers, city):
        assert "origin_lon" in _georeference_of(usda)


def test_a_kept_crs_with_no_code_is_written_as_its_wkt(district_gdf):
    """A projected CRS no authority code matches (a transverse Mercator given as a PROJ
    string) is kept as it is, and the frame names it by its WKT on one line, which
    pyproj resolves to the same CRS; the origin's lon/lat follows from it."""
    from citysynth.export.materials import georeference

    crs = ("+proj=tmerc +lat_0=60 +lon_0=24.9 +k=1 +x_0=300000 +y_0=7000000 "
           "+ellps=GRS80 +units=m +no_defs")
    data = json.loads(district_gdf.to_crs(crs).to_json())
    _feats, frame = parse_geojson(data, "custom.geojson", crs=crs)
    assert "(projected, PROJCRS[" in frame.crs and "\n" not in frame.crs
    geo = georeference(frame.describe())
    assert pyproj.CRS.from_user_input(geo["crs"]) == pyproj.CRS(crs)
    tf = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    assert [geo["origin_lon"], geo["origin_lat"]] == \
        pytest.approx(list(tf.transform(*frame.origin)), abs=1e-7)


def _tmerc(inputs: CityInputs) -> str:
    lon, lat = inputs.frame.origin
    return (f"+proj=tmerc +lat_0={lat} +lon_0={lon} +k=1 +x_0=0 +y_0=0 +ellps=WGS84 "
            "+units=m +no_defs")


# --- CRS spellings, and what is refused ------------------------------------------------------

LINE = {"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {"name": "a"},
     "geometry": {"type": "LineString", "coordinates": [[24.94, 60.17], [24.95, 60.171]]}}]}


@pytest.mark.parametrize("name", [
    "urn:ogc:def:crs:OGC:1.3:CRS84", "urn:ogc:def:crs:OGC::CRS84", "OGC:CRS84", "CRS84",
    "urn:ogc:def:crs:EPSG::4326", "urn:ogc:def:crs:EPSG:6.6:4326", "EPSG:4326", "epsg:4326",
    "http://www.opengis.net/def/crs/OGC/1.3/CRS84",
    "http://www.opengis.net/def/crs/EPSG/0/4326", "EPSG:4979",
])
def test_every_spelling_of_lon_lat_means_lon_lat(name):
    ref, ref_frame = parse_geojson(LINE)
    member = dict(LINE, crs={"type": "name", "properties": {"name": name}})
    for feats, frame in (parse_geojson(member), parse_geojson(LINE, crs=name)):
        assert frame == ref_frame
        assert shapely.equals_exact(feats[0].geometry, ref[0].geometry, tolerance=0)
    old = dict(LINE, crs={"type": "EPSG", "properties": {"code": 4326}})
    assert parse_geojson(old)[1] == ref_frame


def test_another_geographic_crs_goes_through_lon_lat():
    etrs = dict(LINE, crs={"type": "name", "properties": {"name": "EPSG:4258"}})
    feats, frame = parse_geojson(etrs)
    ref, _ = parse_geojson(LINE)
    assert frame.source_crs == "EPSG:4258" and "reprojected" in frame.describe()
    assert feats[0].geometry.length == pytest.approx(ref[0].geometry.length, rel=LENGTH_TOL)


def test_crs_members_that_cannot_be_read():
    link = dict(LINE, crs={"type": "link", "properties": {"href": "http://x/crs.wkt"}})
    with pytest.raises(SkeletonError, match="links to a CRS definition"):
        parse_geojson(link, "s.geojson")
    with pytest.raises(SkeletonError, match='s.geojson: cannot read the "crs" member'):
        parse_geojson(dict(LINE, crs="EPSG:4326"), "s.geojson")


def test_a_crs_that_is_not_a_map_is_refused():
    with pytest.raises(SkeletonError, match=r"EPSG:4978 \(WGS 84\) is a geocentric"):
        parse_geojson(LINE, "s.geojson", crs="EPSG:4978")
    with pytest.raises(SkeletonError, match=r"EPSG:5703 \(NAVD88 height\) is a vertical "
                                            r"CRS, not a map"):      # once "vertical crs CRS"
        parse_geojson(LINE, "s.geojson", crs="EPSG:5703")
    # a site grid (an engineering CRS, as a GIS file's WKT gives it): named, not quoted
    # whole, and "an engineering CRS" (it was the whole WKT, and "a engineering")
    wkt = ('ENGCRS["site grid",EDATUM["site"],CS[Cartesian,2],'
           'AXIS["easting",east,LENGTHUNIT["metre",1]],'
           'AXIS["northing",north,LENGTHUNIT["metre",1]]]')
    with pytest.raises(SkeletonError) as exc:
        parse_geojson(LINE, "s.geojson", crs=wkt)
    assert str(exc.value).startswith("s.geojson: site grid is an engineering CRS, not a "
                                     "map of the ground (a local site grid"), str(exc.value)


def _projected(crs: str, scale: float = 1.0) -> dict:
    tf = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    line = copy.deepcopy(LINE)
    geom = line["features"][0]["geometry"]
    geom["coordinates"] = [[c * scale for c in tf.transform(*xy)] for xy in geom["coordinates"]]
    line["crs"] = {"type": "name", "properties": {"name": crs}}
    return line


def test_coordinates_outside_the_area_of_their_crs_are_refused():
    """Web Mercator metres given in feet put Helsinki beyond 85° N, outside the square
    world of EPSG:3857: a wrong unit, refused with what to check."""
    feats, frame = parse_geojson(_projected("EPSG:3857"))
    assert frame.origin == pytest.approx((24.945, 60.1705))
    with pytest.raises(SkeletonError, match=r"s.geojson: in WGS 84 / Pseudo-Mercator the "
                       r"data lands at longitude 81.82, latitude 88.51, beyond the latitudes "
                       r"that map is made for \(-85.06 to 85.06\); is the CRS right, and are "
                       r"the coordinates in its unit \(metre\)\?"):
        parse_geojson(_projected("EPSG:3857", 3.28084), "s.geojson")


def test_a_utm_zone_used_beyond_its_band_is_accepted():
    """Countries use one zone far beyond its 6° band (Norway: zone 33, 12-18° E, over all
    its 4-31° E); Helsinki (24.9° E) in zone 32 (6-12° E) is read and true to length."""
    ref, _ = parse_geojson(LINE)
    feats, frame = parse_geojson(_projected("EPSG:25832"))
    assert frame.source_crs == "EPSG:25832"
    assert feats[0].geometry.length == pytest.approx(ref[0].geometry.length, rel=LENGTH_TOL)


def test_crs_option_over_the_files_member_is_said():
    member = _projected("EPSG:3857")
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        feats, frame = parse_geojson(member, "s.geojson", crs="EPSG:3857")
    assert not got
    with pytest.warns(InputWarning, match="s.geojson: the file says its coordinates are in "
                      "EPSG:3857, but --crs says EPSG:3395; using EPSG:3395"):
        parse_geojson(member, "s.geojson", crs="EPSG:3395")


def test_a_regional_crs_far_from_the_data_is_warned_of():
    """UTM 32N coordinates read as Swiss LV95 (``--crs EPSG:2056``) landed in Greenland
    and a 100 m street became 80.2 m of buildings, without a word. A regional CRS whose
    area of use lies far from the data is warned of; the right one is not."""
    line = {"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {},
            "geometry": {"type": "LineString",
                         "coordinates": [[500000, 5600000], [500100, 5600000]]}}]}
    with pytest.warns(InputWarning, match=r"in CH1903\+ / LV95 the data lands at longitude "
                      r"-65\.00, latitude 74\.26, 71° from where that CRS is made for "
                      r"\(Liechtenstein; Switzerland\)"):
        parse_geojson(line, "s.geojson", crs="EPSG:2056")
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        feats, _frame = parse_geojson(line, "s.geojson", crs="EPSG:25832")
    assert not [w for w in got if issubclass(w.category, InputWarning)]
    assert abs(feats[0].geometry.length - 100.0) < 0.5


@pytest.mark.parametrize("option, says", [
    ("foo", 's.geojson: unknown CRS "foo"; give it as EPSG:<code>'),
    ("EPSG:" + "9" * 5000, 's.geojson: unknown CRS "EPSG:99999'),   # (quoted in full: 5 kB)
    ("EPSG:4326", 'are not longitude/latitude (RFC 7946); give the CRS of projected input, '
                  'e.g. --crs EPSG:25832 (the file\'s "crs" member says EPSG:25832; leaving '
                  "--crs out uses it)"),
])
def test_a_crs_option_refused_over_the_files_member_is_one_message(option, says):
    """A --crs that cannot be used, over a file whose own "crs" member names another:
    one error naming the member, no warning line before it (it warned "using foo",
    then refused foo)."""
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        with pytest.raises(SkeletonError) as exc:
            parse_geojson(_projected("EPSG:25832"), "s.geojson", crs=option)
    assert says in str(exc.value) and len(str(exc.value)) < 500
    assert not [w for w in got if issubclass(w.category, InputWarning)]


def test_a_block_across_the_date_line_is_framed_there():
    """A block across ±180° is framed at 180°, not at 0° (where the transverse Mercator
    would mirror it), and measures what the same block at 0° does."""
    ring = [[179.999, 0], [-179.999, 0], [-179.999, 0.001], [179.999, 0.001], [179.999, 0]]
    feats, frame = parse_geojson({"type": "Polygon", "coordinates": [ring]})
    assert abs(frame.origin[0]) == 180 and frame.origin[1] == pytest.approx(0.0005)
    same = [[x - 180 if x > 0 else x + 180, y] for x, y in ring]   # moved by 180°
    ref, _ = parse_geojson({"type": "Polygon", "coordinates": [same]})
    assert feats[0].geometry.length == pytest.approx(ref[0].geometry.length, rel=1e-9)
    assert feats[0].geometry.area == pytest.approx(ref[0].geometry.area, rel=1e-9)
    assert shapely.is_ccw(feats[0].geometry.exterior) == shapely.is_ccw(ref[0].geometry.exterior)


def test_nothing_usable_is_refused_naming_the_file_and_feature(tmp_path):
    f = tmp_path / "nulls.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "x"}, "geometry": None},
        {"type": "Feature", "properties": None, "geometry": None}]}))
    with pytest.raises(SkeletonError) as exc:
        read_geojson(f)
    msg = str(exc.value)
    assert msg.startswith(f"{f}: no usable features: all 2 left out (feature 0 (x): no "
                          "geometry (null); ...)")
    assert "NoneType" not in msg
    points = copy.deepcopy(LINE)
    points["features"][0]["geometry"] = {"type": "Point", "coordinates": [24.9, 60.1]}
    with pytest.raises(SkeletonError, match="p.geojson: no usable features: all 1 left out "
                                            r"\(feature 0 \(a\): a Point cannot be a line"):
        parse_geojson(points, "p.geojson", accept="lines")


def test_bad_features_name_the_file_and_index():
    bad = copy.deepcopy(LINE)
    bad["features"].append({"type": "Feature", "properties": {},
                            "geometry": {"type": "LineString", "coordinates": [[1]]}})
    with pytest.raises(SkeletonError, match=r"s.geojson: feature 1: malformed LineString "
                       r"\(a position has 1 number; GeoJSON gives \[x, y\] or \[x, y, z\]\)"):
        parse_geojson(bad, "s.geojson")
    bad["features"][1] = {"type": "Feature", "properties": ["x"], "geometry": None}
    with pytest.raises(SkeletonError, match="s.geojson: feature 1: properties must be"):
        parse_geojson(bad, "s.geojson")
    bad["features"][1] = ["not", "a", "feature"]
    with pytest.raises(SkeletonError, match="s.geojson: feature 1 is not a GeoJSON Feature"):
        parse_geojson(bad, "s.geojson")


def test_downstream_messages_name_the_file(tmp_path):
    from citysynth.skeletons import skeleton_from_lines
    from citysynth.skeletons.streets import street_blocks
    f = tmp_path / "mixed.geojson"
    data = copy.deepcopy(LINE)
    data["features"].append({"type": "Feature", "properties": {},
                             "geometry": {"type": "Point", "coordinates": [24.9, 60.1]}})
    f.write_text(json.dumps(data))
    feats, frame = read_geojson(f)              # any geometry: the caller decides
    with pytest.raises(SkeletonError, match=f"{f}: feature 1: a skeleton is made of "
                                            "LineStrings, got Point"):
        skeleton_from_lines(feats, frame)
    blocks, skipped = street_blocks(feats)
    assert blocks == [] and skipped == [f"{f}: feature 1: a Point is no street centre line "
                                        "(LineString or MultiLineString)"]


def test_the_skeleton_command_warns_and_goes_on(tmp_path, capsys):
    from citysynth.pipeline.cli import main
    data = json.loads(DISTRICT.read_text())
    data["features"].insert(5, {"type": "Feature", "properties": {"highway": "crossing"},
                                "geometry": {"type": "Point", "coordinates": [24.94, 60.17]}})
    data["features"].insert(9, {"type": "Feature", "properties": {}, "geometry": None})
    f = tmp_path / "streets.geojson"
    f.write_text(json.dumps(data))
    with pytest.warns(InputWarning, match=f"{f}: feature 9: no geometry"):
        assert main(["skeleton", str(f), "--kind", "streets"]) == 0
    out = capsys.readouterr().out
    assert f"skipped {f}: feature 5: a Point is no street centre line" in out


def test_the_skeleton_command_reads_highway_lines_as_streets(capsys):
    """Without --kind, lines with a highway tag are a street network (read as building
    skeleton lines they would cross each other and be refused)."""
    from citysynth.pipeline.cli import main
    assert main(["skeleton", str(DISTRICT)]) == 0
    auto = capsys.readouterr().out
    assert main(["skeleton", str(DISTRICT), "--kind", "streets"]) == 0
    assert auto == capsys.readouterr().out and "(block 0): cycle" in auto


def test_zone_polygons_stay_lon_lat_when_the_streets_are_reprojected(district_gdf, tmp_path):
    """city.toml zone polygons are lon/lat; with Web Mercator streets given by --crs they
    still land where they do for lon/lat streets."""
    cfg = tmp_path / "city.toml"
    cfg.write_text(f'library = "{LIB}"\n[[zone]]\nname = "east"\nstyle = "modern"\n'
                   "polygon = [[24.9470, 60.160], [24.960, 60.160], [24.960, 60.180], "
                   "[24.9470, 60.180]]\n")
    f = tmp_path / "mercator.geojson"
    district_gdf.to_crs("EPSG:3857").to_file(f, driver="GeoJSON")
    ref = prepare(DISTRICT, None, load_config(cfg), None)
    got = prepare(f, None, load_config(cfg), None, "EPSG:3857")
    assert {j.zone for j in ref.jobs} == {"", "east"}
    assert summary(got) == summary(ref)


def test_zone_polygons_in_lon_lat_or_in_the_kept_crs(district_gdf, tmp_path):
    """Streets in a true-to-scale projected CRS are kept in its axes; a zone polygon in
    lon/lat, or in that CRS's own metres, picks the same blocks as with lon/lat streets."""
    ring = [[24.9470, 60.160], [24.960, 60.160], [24.960, 60.180], [24.9470, 60.180]]
    tf = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:3067", always_xy=True)
    zones = {}
    for name, poly in (("lonlat", ring), ("tm35", [list(tf.transform(*q)) for q in ring])):
        cfg = tmp_path / f"{name}.toml"
        cfg.write_text(f'library = "{LIB}"\n[[zone]]\nname = "east"\nstyle = "modern"\n'
                       f"polygon = {json.dumps(poly)}\n")
        zones[name] = load_config(cfg)
    f = tmp_path / "tm35fin.geojson"
    district_gdf.to_crs("EPSG:3067").to_file(f, driver="GeoJSON")
    ref = prepare(DISTRICT, None, zones["lonlat"], None)
    east = sorted(j.id for j in ref.jobs if j.zone == "east")
    assert east and len(east) < len(ref.jobs)
    for cfg in zones.values():
        got = prepare(f, None, cfg, None)
        assert got.frame.source_crs == "EPSG:3067"
        assert len([j for j in got.jobs if j.zone == "east"]) == len(east)


def _moved(path: Path, lon: float, lat: float, out: Path) -> Path:
    """The GeoJSON at ``path`` moved by (lon, lat) degrees: the same streets elsewhere."""
    data = json.loads(path.read_text())
    for f in data["features"]:
        f["geometry"]["coordinates"] = [[x + lon, y + lat]
                                        for x, y in f["geometry"]["coordinates"]]
    out.write_text(json.dumps(data))
    return out


@pytest.mark.parametrize("lon, lat, far", [(-98.95, -19.47, "3,4"),   # New York
                                           (-10.55, -10.07, "58")])   # Prague
def test_zones_of_another_city_are_left_out_by_name(tmp_path, lon, lat, far):
    """The demo's city.toml, whose polygon zones lie in Helsinki, used for the district's
    streets moved to another city: each zone is named, said to be that far away and
    left out, and the city is read. 3,440 km away the run was refused saying the data
    reached too far from the frame centre ("give data of one place"); 584 km away it
    was warned that buildings there come out 0.4 % too large: neither named the zones,
    and no building was too large."""
    streets = _moved(DISTRICT, lon, lat, tmp_path / "streets.geojson")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = prepare(streets, None, load_config(CITY / "city.toml"), None)
    said = [str(w.message) for w in caught if issubclass(w.category, InputWarning)]
    for zone in ("rows", "towers"):
        (line,) = [s for s in said if s.startswith(f"city.toml zone '{zone}'")]
        assert f"lies {far}" in line and "km east or west" in line and "left out" in line
    assert not any("too large" in s for s in said), said
    assert {j.zone for j in got.jobs} <= {"", "main roads"}
    demo = load_config(CITY / "city.toml")
    plain = replace(demo, zones=tuple(z for z in demo.zones if not z.polygon))
    assert [j.id for j in got.jobs] == [j.id for j in prepare(streets, None, plain, None).jobs]


def test_a_zone_no_block_falls_in_is_warned_of(tmp_path):
    """A zone polygon beside the district (1 km east), or with its points given as
    (lat, lon): no block falls in it, and the user hears so; a zone over blocks is not
    warned of."""
    near = [[24.975, 60.160], [24.985, 60.160], [24.985, 60.180], [24.975, 60.180]]
    over = [[24.9470, 60.160], [24.960, 60.160], [24.960, 60.180], [24.9470, 60.180]]
    swapped = [[y, x] for x, y in over]
    cfg = tmp_path / "city.toml"
    zones = (("near", near), ("over", over), ("swapped", swapped))
    cfg.write_text(f'library = "{LIB}"\n' + "".join(
        f'[[zone]]\nname = "{n}"\nstyle = "modern"\npolygon = {p}\n' for n, p in zones))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = prepare(DISTRICT, None, load_config(cfg), None)
    said = [str(w.message) for w in caught if issubclass(w.category, InputWarning)]
    (line,) = [s for s in said if "zone 'near'" in s]
    assert "no block falls in its polygon" in line and "m outside it" in line
    (line,) = [s for s in said if "zone 'swapped'" in s]
    assert "km east or west" in line and "lon, lat" in line
    assert not any("zone 'over'" in s for s in said)
    assert {j.zone for j in got.jobs} == {"", "over"}


def test_a_zone_of_a_country_or_of_the_world_holds_the_blocks_in_it(tmp_path):
    """A zone polygon much larger than the data: the whole world, or everything east of
    a meridian through the district up to 40 degrees E (edges of 2,000 km). Each picks
    the blocks it covers, as a small polygon over the same ground does, without a
    word. Both were projected whole: the world's was garbled ("no block falls in its
    polygon (the nearest is 234,906 m outside it)"), the eastern one picked none of the
    18 blocks the small one picks, and a country's was told to stretch buildings that
    were not there."""
    world = [[-180, -85], [180, -85], [180, 85], [-180, 85]]
    east = [[24.9465, 50.0], [40.0, 50.0], [40.0, 70.0], [24.9465, 70.0]]
    small = [[24.9465, 60.16], [24.97, 60.16], [24.97, 60.18], [24.9465, 60.18]]
    picked = {}
    for name, poly in (("world", world), ("east", east), ("small", small)):
        cfg = tmp_path / f"{name}.toml"
        cfg.write_text(f'library = "{LIB}"\n[[zone]]\nname = "z"\nstyle = "modern"\n'
                       f"polygon = {poly}\n")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            got = prepare(DISTRICT, None, load_config(cfg), None)
        said = [str(w.message) for w in caught if "zone" in str(w.message)]
        assert not said, (name, said)
        picked[name] = sorted(j.id for j in got.jobs if j.zone == "z")
        if name == "world":
            assert len(picked[name]) == len(got.jobs)
    assert picked["small"] and picked["east"] == picked["small"]


def test_a_bare_geometry_is_one_feature():
    """RFC 7946 allows a GeoJSON text that is just a geometry: it reads as one feature."""
    ring = [[24.94, 60.17], [24.941, 60.17], [24.941, 60.1705], [24.94, 60.17]]
    bare, _ = parse_geojson({"type": "Polygon", "coordinates": [ring]})
    wrapped, _ = parse_geojson({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon",
                                                          "coordinates": [ring]}}]})
    assert len(bare) == 1 and bare[0].geometry.equals(wrapped[0].geometry)


@pytest.mark.parametrize("coords, says", [
    ([[24.94, 60.17]], "malformed LineString (a line needs at least 2 points)"),
    ([[24.94, 60.17, 0, 1], [24.95, 60.17, 0, 1]],
     "malformed LineString (a position has 4 numbers; GeoJSON gives [x, y] or [x, y, z])"),
])
def test_malformed_geometry_is_said_without_geos_words(coords, says):
    """GEOS's own text ("IllegalArgumentException: point array must contain 0 or >1
    elements", with its line break) is put in GeoJSON's words."""
    with pytest.raises(SkeletonError) as exc:
        parse_geojson({"type": "LineString", "coordinates": coords}, "s.geojson")
    assert str(exc.value) == f"s.geojson: feature 0: {says}"


def test_huge_coordinates_are_said_in_three_figures():
    with pytest.raises(SkeletonError, match=r"^s.geojson: coordinates such as 1e\+300, "
                       r"2e\+300 are not longitude/latitude"):
        parse_geojson({"type": "LineString", "coordinates": [[1e300, 2e300], [1, 2]]},
                      "s.geojson")


def _in_crs(src: Path, dst: Path, crs: str) -> Path:
    """``src`` (lon/lat) reprojected to ``crs``, with its ``"crs"`` member, as GDAL's
    GeoJSON driver writes it with RFC7946=NO."""
    tf = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    doc = json.loads(src.read_text())

    def move(c):
        return [*tf.transform(c[0], c[1])] if isinstance(c[0], int | float) else \
            [move(x) for x in c]
    for f in doc["features"]:
        f["geometry"]["coordinates"] = move(f["geometry"]["coordinates"])
    doc["crs"] = {"type": "name", "properties": {"name": crs.replace(":", "::").join(
        ["urn:ogc:def:crs:", ""])}}
    dst.write_text(json.dumps(doc))
    return dst


@pytest.mark.parametrize("streets_crs, footprints_crs", [
    ("EPSG:3067", None), (None, "EPSG:3067"), ("EPSG:3857", "EPSG:3067")])
def test_streets_and_footprints_in_different_crss_share_one_frame(tmp_path, streets_crs,
                                                                  footprints_crs):
    """Each file is read in its own CRS and lands in the first one's frame. Before, the
    streets' origin was passed to the footprints as if in their CRS: projected streets
    with lon/lat footprints crashed (a projected origin as lon/lat), and lon/lat
    streets with projected footprints put the footprints in the Bering Sea."""
    streets, fps = DISTRICT, CITY / "district_buildings.geojson"
    cfg = load_config(CITY / "city.toml")

    def run(s_crs, f_crs):
        s = _in_crs(streets, tmp_path / f"s_{s_crs}.geojson", s_crs) if s_crs else streets
        f = _in_crs(fps, tmp_path / f"f_{f_crs}.geojson", f_crs) if f_crs else fps
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputWarning)
            return prepare(s, f, cfg, LIB)
    mixed = run(streets_crs, footprints_crs)
    same = run(streets_crs, streets_crs)          # both files in the streets' CRS
    assert mixed.frame == same.frame
    got, want = outlines_in(mixed), outlines_in(same)
    assert len(got) == len(want) and len(got) > 10
    assert sum(j.kind == "footprint" for j in mixed.jobs) == \
        sum(j.kind == "footprint" for j in same.jobs) > 0
    for a in got:                                 # each outline where its twin is
        assert min(shapely.hausdorff_distance(a, b) for b in want) < 0.01, a.centroid


def test_footways_sidewalks_and_driveways_bound_no_block(tmp_path):
    """An OSM export of every way (osmnx's "all", Overpass) has paths across courtyards,
    sidewalks drawn beside their streets and driveways: city.toml's ``not_streets``
    (footways, paths, cycleways, driveways ... by default) leaves them out, so they
    neither split blocks nor pull their edges in; ``not_streets = []`` keeps them."""
    from citysynth.pipeline.city.config import parse_config
    from citysynth.pipeline.errors import ConfigError
    from citysynth.skeletons import lonlat_from_local
    o = (24.94, 60.17)

    def line(pts, **props):
        return {"type": "Feature", "properties": props, "geometry": {
            "type": "LineString", "coordinates": lonlat_from_local(pts, o)}}
    grid = [line([(x, -10), (x, 310)], highway="residential") for x in (0, 100, 200, 300)]
    grid += [line([(-10, y), (310, y)], highway="residential") for y in (0, 100, 200, 300)]
    extra = [line([(100, 100), (200, 200)], highway="footway"),                # a path
             line([(100, 150), (200, 150)], highway="service", service="driveway"),
             line([(0, 107), (300, 107)], highway="footway", footway="sidewalk"),
             line([(150, 200), (150, 300)], highway=["cycleway", "footway"])]
    def write(name, feats):
        p = tmp_path / name
        p.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
        return p
    plain, busy = write("plain.geojson", grid), write("busy.geojson", grid + extra)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        ref = prepare(plain, None, parse_config({}), LIB)
        got = prepare(busy, None, parse_config({}), LIB)
        kept = prepare(busy, None, parse_config({"not_streets": []}), LIB)
    assert [j.wkt for j in got.jobs] == [j.wkt for j in ref.jobs] and len(ref.jobs) == 9
    said = " ".join(s["reason"] for s in got.skipped)
    assert "2 line(s) with highway=footway" in said and "service=driveway" in said, said
    assert "highway=cycleway" in said                    # a merged cycleway + footway
    assert len(kept.jobs) > len(ref.jobs)                # the path and driveway split blocks
    paths = write("paths.geojson", extra[:1])
    with pytest.raises(ConfigError, match="every line is one of not_streets"):
        prepare(paths, None, parse_config({}), LIB)
    with pytest.raises(ConfigError, match="not_streets: must be a list"):
        parse_config({"not_streets": "footway"})


def test_a_roundabouts_island_is_no_block(tmp_path):
    """The ground inside a roundabout (a closed ring of junction=roundabout ways) is its
    island: left out, with a reason, where it was built as a block of facades."""
    from citysynth.pipeline.city.config import parse_config
    from citysynth.skeletons import lonlat_from_local
    o = (24.94, 60.17)

    def line(pts, **props):
        return {"type": "Feature", "properties": props, "geometry": {
            "type": "LineString", "coordinates": lonlat_from_local(pts, o)}}
    ring = [(150 + 25 * np.cos(t), 150 + 25 * np.sin(t)) for t in np.linspace(0, 2 * np.pi, 25)]
    feats = [line([(x, -10), (x, 310)], highway="residential") for x in (0, 300)]
    feats += [line([(-10, y), (310, y)], highway="residential") for y in (0, 300)]
    feats += [line(ring, highway="primary", junction="roundabout"),
              line([(0, 150), (125, 150)], highway="primary"),
              line([(175, 150), (300, 150)], highway="primary")]
    src = tmp_path / "rb.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        got = prepare(src, None, parse_config({}), LIB)
    island = shapely.Point(150, 150).buffer(25)
    assert got.jobs and not any(island.contains(shapely.from_wkt(j.wkt).representative_point())
                                for j in got.jobs)
    assert any("a roundabout's island" in s["reason"] for s in got.skipped), got.skipped


def test_a_line_across_the_antimeridian_is_said_with_its_digits():
    """179.9995 to 180.0005: the longitude past 180 is said as it is (it read "180.0",
    which looked right) and how to write such a line."""
    with pytest.raises(SkeletonError, match=r"coordinates such as 180\.0005, 50\.73 are "
                       r"not longitude/latitude.*antimeridian.*from -180"):
        parse_geojson({"type": "LineString", "coordinates": [[179.9995, 50.73],
                                                             [180.0005, 50.73]]}, "s.geojson")


@pytest.mark.parametrize("geometry, says", [
    ({"type": "Polygon", "coordinates": [[[24.94, 60.17], [24.95, 60.17]]]},
     "malformed Polygon (a ring needs at least 4 positions: 3 corners, then the first "
     "again; fix or delete the feature in your GIS)"),
    ({"type": "MultiLineString", "coordinates": [[[24.94, 60.17], [24.95, 60.17]], []]},
     "malformed MultiLineString (one of the lines in it has no positions; delete the "
     "empty part in your GIS)"),
])
def test_more_geos_complaints_are_said_in_geojson_words(geometry, says):
    """shapely's "A linearring requires at least 4 coordinates." and "Can't create
    MultiLineString with empty component" reached the user as they were."""
    with pytest.raises(SkeletonError) as exc:
        parse_geojson(geometry, "s.geojson")
    assert str(exc.value) == f"s.geojson: feature 0: {says}"


@pytest.mark.parametrize("case", ["far east", "web mercator read as tm35fin"])
def test_footprints_where_the_kept_crs_is_not_true_to_scale_are_refused(district_gdf,
                                                                      tmp_path, case):
    """Streets in EPSG:3067 are kept in its axes; footprints read into it were never
    checked for scale: 2,000 km east (still EPSG:3067), or Web Mercator numbers taken
    as EPSG:3067 (``--crs EPSG:3067`` over a file that says 3857), were built 2,000 to
    2,900 km off and 4 % to 2x too large, exit 0. Refused, as lon/lat data that far
    from the frame is, naming how far and how wrong."""
    streets = tmp_path / "streets.geojson"
    district_gdf.to_crs("EPSG:3067").to_file(streets, driver="GeoJSON")
    x, y = district_gdf.to_crs("EPSG:3067").union_all().centroid.coords[0]
    ring = np.array([[0, 0], [30, 0], [30, 14], [0, 14], [0, 0]], dtype=float)
    if case == "far east":
        at, crs_member = ring + [x + 2_000_000, y], "EPSG:3067"
    else:
        tf = pyproj.Transformer.from_crs("EPSG:3067", "EPSG:3857", always_xy=True)
        at, crs_member = np.column_stack(tf.transform(*(ring + [x, y]).T)), "EPSG:3857"
    foot = tmp_path / "foot.geojson"
    foot.write_text(json.dumps({"type": "FeatureCollection", "crs": {
        "type": "name", "properties": {"name": crs_member}}, "features": [
        {"type": "Feature", "properties": {"building": "yes"}, "geometry": {
            "type": "Polygon", "coordinates": [at.tolist()]}}]}))
    with pytest.raises(SkeletonError, match="are the two inputs of one place") as got, \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prepare(streets, foot, load_config(None), LIB,
                "EPSG:3067" if crs_member == "EPSG:3857" else None)
    assert re.search(r"data reach [\d,]+ km from the run's frame centre", str(got.value))


def test_a_collection_holding_a_footprint_is_read_as_its_polygons():
    """A Google Earth placemark is a MultiGeometry of its label's Point and its
    Polygon (GDAL reads it as a GeometryCollection); some exports wrap each footprint
    in a collection. Such footprints were all refused ("a GeometryCollection cannot be
    a polygon"); their polygons are read. A closed line is still no footprint, said
    with what to do."""
    ring = [[24.94, 60.17], [24.9405, 60.17], [24.9405, 60.1702], [24.94, 60.1702],
            [24.94, 60.17]]
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "A"}, "geometry": {
            "type": "GeometryCollection", "geometries": [
                {"type": "Point", "coordinates": ring[0]},
                {"type": "Polygon", "coordinates": [ring]}]}},
        {"type": "Feature", "properties": {"name": "B"}, "geometry": {
            "type": "LineString", "coordinates": ring}}]}
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        feats, _ = parse_geojson(fc, "foot.geojson", accept="polygons")
    assert len(feats) == 1 and feats[0].geometry.geom_type == "Polygon"
    assert feats[0].geometry.area == pytest.approx(27.7 * 22.2, rel=0.02)
    (line,) = [str(w.message) for w in seen if "(B)" in str(w.message)]
    assert "a LineString cannot be a polygon" in line and "export it as a Polygon" in line


def test_a_crs_without_an_authority_code_is_named_in_a_line_on_the_console(tmp_path, capsys):
    """Streets in a custom transverse Mercator (no authority code: named by its WKT,
    884 characters on one line) made ``skeleton``'s frame line a screenful; the line
    names the CRS and says where its WKT is, which ``--json``'s frame (what a layout
    records, for tools) still holds whole. Input reprojected from such a CRS is told
    by its name too."""
    from citysynth.pipeline.cli import main
    from citysynth.skeletons.geojson import LONLAT_FRAME, Frame

    crs = pyproj.CRS.from_proj4("+proj=tmerc +lat_0=0 +lon_0=24.5 +k=0.9999 +x_0=500000 "
                                "+y_0=0 +ellps=GRS80 +units=m +no_defs")
    wkt = crs.to_wkt()
    assert crs.to_authority(min_confidence=90) is None and len(wkt) > 500
    x0, y0 = 385000, 6672000
    ring = [(x0, y0), (x0 + 100, y0), (x0 + 100, y0 + 80), (x0, y0 + 80), (x0, y0)]
    path = tmp_path / "streets.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"highway": "residential"},
         "geometry": {"type": "LineString", "coordinates": [a, b]}}
        for a, b in zip(ring, ring[1:], strict=False)]}))
    assert main(["skeleton", str(path), "--crs", wkt]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first == ("frame: a custom CRS (projected, no authority code: its WKT is in "
                     "--json's frame), origin 385050.000000, 6672040.000000")
    assert main(["skeleton", str(path), "--crs", wkt, "--json"]) == 0
    assert wkt in json.loads(capsys.readouterr().out)["frame"]
    told = Frame(LONLAT_FRAME, (24.5, 60.2), wkt).describe(told=True)
    assert told.endswith("(input in a custom CRS (WKT), reprojected)") and len(told) < 150
    kept = Frame("ETRS89 / TM35FIN(E,N) (projected, EPSG:3067)", (1.0, 2.0))
    assert kept.describe(told=True) == kept.describe()
