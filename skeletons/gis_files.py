"""GIS files that are not GeoJSON, read as they are: GeoPackage (QGIS's own format),
ESRI Shapefile (also zipped), FlatGeobuf, KML/KMZ (Google Earth), Esri JSON (what an
ArcGIS server's query returns), OpenStreetMap files (the website's Export, .osm XML, or
a .osm.pbf extract), GML (cadastres, INSPIRE, WFS downloads), MapInfo (.tab, .mif) and
CAD drawings (DXF), through pyogrio (GDAL); GeoParquet (geopandas, DuckDB, Overture
Maps) through pyarrow (:mod:`.geoparquet`: pyogrio's GDAL has no Parquet driver).

A DXF drawing has one layer of every entity, told apart by their CAD layer: ``FILE::
LAYER`` names a CAD layer; its entities of the geometry the caller reads are kept (closed
polylines as polygons for footprints and blocks), each named by its entity handle. It
has no CRS: ``--crs`` says which one its coordinates are in.

A layer becomes the same FeatureCollection a GeoJSON export of it would be: its CRS as
the legacy ``"crs"`` member, every attribute as a property (numbers as numbers, dates
as ISO text, missing values left out), geometries in 2D. So everything after reading
(the CRS rules, the checks, the messages naming a feature by its index) is
:mod:`.geojson`'s, and the same layer gives the same city in either format.

A file with several layers (a GeoPackage holding streets and buildings) gives the one
layer whose geometry the caller reads (lines for streets, polygons for footprints);
where that is not one layer, ``FILE::LAYER`` names it, and the message lists them (in
a GeoParquet file, ``FILE::COLUMN`` names one of several geometry columns).
"""

from __future__ import annotations

import contextlib
import re
import warnings
import zipfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from citysynth.skeletons.errors import InputWarning, SkeletonError, cannot_read
from citysynth.skeletons.geoparquet import FORMAT as PARQUET
from citysynth.skeletons.geoparquet import geojson_geometries, json_value, read_geoparquet
from citysynth.solver.safe_read import check_data_size, check_file, first_few

LAYER_SEP = "::"                    # FILE::LAYER picks one layer of a file
FORMATS = {                         # file signature -> format name
    b"SQLite format 3\x00": "GeoPackage",
    b"\x00\x00\x27\x0a": "Shapefile",
    b"fgb\x03": "FlatGeobuf",
    b"PK\x03\x04": "zipped Shapefile",
    b"PK\x05\x06": "zipped Shapefile",   # an empty zip archive
    b"PAR1": PARQUET,
}
SUFFIXES = {".gpkg": "GeoPackage", ".shp": "Shapefile", ".fgb": "FlatGeobuf",
            ".zip": "zipped Shapefile", ".kml": "KML", ".kmz": "KMZ",
            ".osm": "OpenStreetMap file", ".pbf": "OpenStreetMap file",
            ".parquet": PARQUET, ".geoparquet": PARQUET, ".gml": "GML", ".dxf": "DXF",
            ".tab": "MapInfo table", ".mif": "MapInfo table"}
OSM = "OpenStreetMap file"
DXF = "DXF"
GDB = "File Geodatabase"            # ArcGIS's: a folder name.gdb, or a zip of one
_DXF = re.compile(rb"\s*0\s*\n\s*SECTION\s*\n")   # a DXF drawing's first group
# an OpenStreetMap file holds everything in a few layers: what each option reads of it
OSM_LAYERS = {"lines": ("lines", "highway IS NOT NULL"),
              "polygons": ("multipolygons", "building IS NOT NULL")}
_HSTORE = re.compile(r'"((?:[^"\\]|\\.)*)"=>"((?:[^"\\]|\\.)*)"')   # other_tags
SNIFF = 1024                        # bytes read to tell a format (KML is XML text)
GEOMETRIES = {                      # what the caller reads -> the layer types it takes
    "lines": ("LineString", "MultiLineString"),
    "polygons": ("Polygon", "MultiPolygon"),
}


def split_layer(text: str) -> tuple[str, str]:
    """``FILE::LAYER`` as (file, layer); (text, "") when it names no layer (a file may
    have :: in its own name)."""
    if LAYER_SEP in text and not Path(text).exists():
        file, _, layer = text.rpartition(LAYER_SEP)
        return file, layer
    return text, ""


def gis_format(path: str | Path) -> tuple[Path, str | None, str] | None:
    """``(file, layer, format)`` when ``path`` (optionally ``FILE::LAYER``) names a GIS
    file of a format this module reads; None for anything else (GeoJSON, or a file the
    GeoJSON reader refuses with its own message)."""
    text = str(path)
    file, layer = split_layer(text)
    p = Path(file)
    if p.suffix.lower() == ".gdb" and p.is_dir():
        return p, layer or None, GDB   # an Esri File Geodatabase is a folder
    head = b""
    try:
        if p.is_file():   # not a FIFO (opening one waits for a writer) nor a folder
            with open(p, "rb") as f:
                head = f.read(SNIFF)
    except OSError:
        pass              # the reader names what is wrong with it
    fmt = next((name for magic, name in FORMATS.items() if head.startswith(magic)), None)
    _refuse_no_layer(p, head, fmt)
    if fmt == "zipped Shapefile" and p.suffix.lower() == ".kmz":
        fmt = "KMZ"       # Google Earth's zipped KML
    elif fmt == "zipped Shapefile" and _zipped_gdb(p):
        fmt = GDB         # ArcGIS's zipped geodatabase, which GDAL reads as it is
    elif fmt is None and _xml(head) and b"<kml" in head:
        fmt = "KML"
    elif fmt is None and (_xml(head) and b"<osm" in head or b"OSMHeader" in head[:64]):
        fmt = OSM        # the XML the website's Export button gives, or a PBF extract
    elif fmt is None and _xml(head) and b"opengis.net/gml" in head:
        fmt = "GML"      # a cadastre's, INSPIRE's or a WFS server's GML
    elif fmt is None and (_DXF.match(head.replace(b"\r", b"")) or
                          head.startswith(b"AutoCAD Binary DXF")):
        fmt = DXF        # a CAD drawing
    elif fmt is None and (head.startswith(b"!table") or head.startswith(b"Version") and
                          b"\nCoordSys" in head):
        fmt = "MapInfo table"
    elif fmt is None and b'"FeatureCollection"' not in head and (
            b'"esriGeometry' in head or b'"spatialReference"' in head and (
                b'"rings"' in head or b'"paths"' in head)):
        fmt = "Esri JSON"   # ArcGIS's own JSON (a REST query's f=json), not GeoJSON
    elif fmt is None:    # damaged or unreadable: named by its suffix, refused by GDAL
        fmt = SUFFIXES.get(p.suffix.lower())
    if fmt is None:
        if layer:
            raise SkeletonError(f"{text}: {LAYER_SEP}{layer} names a layer, but {file} is "
                                "not a GeoPackage, Shapefile, FlatGeobuf, KML, Esri JSON, "
                                "OpenStreetMap, GML, MapInfo, DXF, File Geodatabase or "
                                "GeoParquet file; a "
                                "GeoJSON file has one layer: give its path alone")
        return None
    return p, layer or None, fmt


OFFICE = {   # what a document that is no GIS layer starts with -> what it is
    b"mimetypeapplication/vnd.oasis.opendocument.spreadsheet": "an OpenDocument "
                                                                "spreadsheet (.ods)",
    b"mimetypeapplication/vnd.oasis.opendocument": "an OpenDocument file",
    b"[Content_Types].xml": "an Office Open XML file (Excel .xlsx or Word .docx)",
}
OLE2 = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"   # a Microsoft Office 97 file (.xls, .doc)


def _refuse_no_layer(path: Path, head: bytes, fmt: str | None) -> None:
    """Refuse a file that holds no layer of geometries but could be taken for one: an
    office document (a zip, told from a zipped Shapefile by its first member; it was "a
    zipped Shapefile ... not recognized", with the advice to unzip it), or osmnx's
    GraphML (XML: "convert it with ogr2ogr", which cannot read it)."""
    kind = next((k for magic, k in OFFICE.items() if fmt == "zipped Shapefile"
                 and magic in head[:200]), None) or (
        "a Microsoft Office 97 file (Excel .xls or Word .doc)" if head.startswith(OLE2)
        else None)
    if kind:
        raise SkeletonError(f"{path}: {kind}, not a layer of geometries; export the "
                            "streets or buildings from your GIS as GeoJSON or GeoPackage "
                            "and give that file")
    if _xml(head) and b"<graphml" in head:
        raise SkeletonError(f"{path}: a GraphML graph (osmnx's save_graphml), which GDAL "
                            "does not read; save the graph as a GeoPackage instead "
                            "(osmnx.io.save_graph_geopackage(G, \"streets.gpkg\")) and "
                            "give that file")


_WAY = re.compile(rb'<way\s[^>]*?\bid="(-?\d+)"[^>]*>(.*?)</way>', re.S)
_NODE_ID = re.compile(rb'<node\s[^>]*?\bid="(-?\d+)"')
_ND = re.compile(rb'<nd\s+ref="(-?\d+)"')
_OSM_KEY = {"lines": "highway", "polygons": "building"}


def _zipped_gdb(path: Path) -> bool:
    """Whether the zip archive at ``path`` holds a File Geodatabase (a ``name.gdb/``
    folder): it was refused as a zip "with no .shp file in it; unzip it and give the
    file inside", where there is no one file to give."""
    try:
        with zipfile.ZipFile(path) as archive:
            return any(Path(m).parts[:1] and Path(m).parts[0].lower().endswith(".gdb")
                       for m in archive.namelist())
    except (zipfile.BadZipFile, OSError):
        return False


def _warn_gapped_ways(path: Path, accept: str) -> None:
    """Warn of the streets or buildings of an OpenStreetMap file that name nodes the
    file does not hold between nodes it holds (an extract clipped with osmium's simple
    strategy, or osmconvert's -b without --complete-ways): GDAL joins the nodes on
    either side straight, a chord the map does not have. Missing nodes at a way's ends
    only shorten it, which is what an extract means."""
    key = _OSM_KEY.get(accept)
    if key is None:       # a layer named outright: no street or building rule to scan by
        return
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError:
        return            # the reader names what is wrong with it
    gapped = [way for way, held in (_xml_ways if _xml(head) else _pbf_ways)(path, key)
              if _gapped(held)]
    if gapped:
        what = "street" if accept == "lines" else "building"
        warnings.warn(f"{path}: {len(gapped)} {what} way(s) (e.g. way {gapped[0]}) name "
                      "nodes this file does not hold between nodes it does (an extract "
                      "clipped at its edge?): each is read as if it ran straight across "
                      "the gap; extract with osmium extract --strategy complete_ways, or "
                      "the website's Export, which keep whole ways", InputWarning,
                      stacklevel=3)


def _gapped(held: list[bool]) -> bool:
    """Whether a way's nodes (held or not) miss one between two the file holds."""
    if False not in held or True not in held:
        return False
    first, last = held.index(True), len(held) - 1 - held[::-1].index(True)
    return not all(held[first:last + 1])


def _xml_ways(path: Path, key: str) -> Iterator[tuple[str, list[bool]]]:
    """Each way of an OpenStreetMap XML file tagged ``key``: its id, and for each of
    its nodes whether the file holds it (a regex scan: JOSM's files give new objects
    negative ids, which osmium's location indexes do not take)."""
    try:
        data = path.read_bytes()
    except OSError:
        return
    tag = f'k="{key}"'.encode()
    nodes = set(_NODE_ID.findall(data))
    for way_id, body in _WAY.findall(data):
        if tag in body:
            yield way_id.decode(), [ref in nodes for ref in _ND.findall(body)]


def _pbf_ways(path: Path, key: str) -> Iterator[tuple[str, list[bool]]]:
    """Each way of an OpenStreetMap PBF file tagged ``key``: its id, and for each of
    its nodes whether the file holds it (osmium: its node location index, in C++,
    tells which nodes the file gave a location). A file osmium cannot read yields
    nothing: GDAL's reader then names what is wrong with it."""
    import osmium  # loaded only when such a file is given

    try:
        ways = osmium.FileProcessor(osmium.io.File(str(path), "pbf"),
                                    osmium.osm.NODE | osmium.osm.WAY) \
            .with_locations().with_filter(osmium.filter.KeyFilter(key))
        for obj in ways:
            if isinstance(obj, osmium.osm.Way):
                yield str(obj.id), [n.location.valid() for n in obj.nodes]
    except (RuntimeError, ValueError, OSError):
        return


def _check_shp_length(path: Path) -> None:
    """A .shp shorter than its header says (a copy or download cut short): GDAL reads
    the shapes its index promises past the end as features without geometry, and the
    run would say "no geometry (null)" of each."""
    try:
        with open(path, "rb") as f:
            head = f.read(28)
        size = path.stat().st_size
    except OSError:
        return            # the reader names what is wrong with it
    if len(head) == 28 and head[:4] == b"\x00\x00\x27\x0a":   # the file code, 9994
        declared = int.from_bytes(head[24:28], "big") * 2       # in 16-bit words
        if size < declared:
            raise SkeletonError(f"{path}: cut short: its header gives {declared:,} bytes, "
                                f"the file has {size:,}; copy or export it again")


def _check_unpacked(path: Path, fmt: str) -> None:
    """Refuse what GDAL would read past the input limit though the file given is under
    it: a zipped Shapefile or KMZ by the sizes its members declare (a 10 MB zip of a
    520 MB Shapefile took 5 GB and crashed), a Shapefile with its .dbf and the other
    files beside it (the limit saw the .shp alone), a MapInfo table with its .dat,
    .map and .mid files likewise."""
    if fmt == GDB and path.is_dir():
        size = sum(f.stat().st_size for f in path.iterdir() if f.is_file())
        how = "its files together"
    elif fmt in ("zipped Shapefile", "KMZ", GDB):
        try:
            with zipfile.ZipFile(path) as archive:
                size = sum(member.file_size for member in archive.infolist())
                members = [m.filename for m in archive.infolist() if not m.is_dir()]
        except (zipfile.BadZipFile, OSError):
            return        # GDAL names what is wrong with it
        _check_zip_holds(path, fmt, members)
        how = "unzipped"
    elif fmt in ("Shapefile", "MapInfo table"):
        size = sum(f.stat().st_size for f in path.parent.iterdir()
                   if f.stem.lower() == path.stem.lower() and f.is_file())
        how = f"with the other files of the {fmt} beside it"
    else:
        return
    check_data_size(path, size, how, "keep the area you build (e.g. ogr2ogr -spat)",
                    SkeletonError)


def _in_zip_folder(path: Path, fmt: str) -> Path | str:
    """What GDAL opens for ``path``: a zipped Shapefile whose .shp files all sit in one
    folder inside the archive (zipping a folder makes one) as that folder,
    ``/vsizip/<zip>/<folder>``; GDAL reads only an archive's top level, and such a zip
    was refused with GDAL's "not recognized as being in a supported file format".
    Anything else as it is."""
    if fmt != "zipped Shapefile":
        return path
    try:
        with zipfile.ZipFile(path) as archive:
            shps = [m.filename for m in archive.infolist()
                    if m.filename.lower().endswith(".shp")]
    except (zipfile.BadZipFile, OSError):
        return path
    folders = {m.rsplit("/", 1)[0] if "/" in m else "" for m in shps}
    if len(folders) != 1 or "" in folders:
        return path
    return f"/vsizip/{Path(path).resolve()}/{folders.pop()}"


def _check_zip_holds(path: Path, fmt: str, members: list[str]) -> None:
    """Refuse a zip archive that is not the format it was taken for: one without a
    .shp (a zipped GeoJSON or GeoPackage, or a zip renamed .geojson) or a KMZ without
    a .kml, naming what it holds, so the user unzips it rather than reading GDAL's
    "not recognized as being in a supported file format"."""
    if fmt == GDB:
        return
    wanted = ".kml" if fmt == "KMZ" else ".shp"
    if any(m.lower().endswith(wanted) for m in members):
        return
    held = first_few(members, 3)
    raise SkeletonError(f"{path}: a zip archive holding {held or 'nothing'}, with no "
                        f"{wanted} file in it (a zipped "
                        f"{'KML' if fmt == 'KMZ' else 'Shapefile'} is read as it is); "
                        "unzip it and give the file inside")


def _warn_unread_prj(path: Path, fmt: str, crs: object) -> None:
    """Warn when a Shapefile's .prj is there but GDAL read no CRS from it (a damaged or
    hand-written one) and ``crs`` (the file's, or True for the user's ``--crs``) is
    none: its coordinates are then taken as GeoJSON's lon/lat, which is wrong for
    projected data."""
    if fmt != "Shapefile" or crs:
        return
    prj = [f for f in path.parent.glob("*") if f.stem.lower() == path.stem.lower()
           and f.suffix.lower() == ".prj" and f.is_file()]
    if prj:
        warnings.warn(f"{prj[0]}: not a coordinate system GDAL can read; the "
                      f"coordinates of {path.name} are taken as lon/lat (give --crs if "
                      "they are projected, or export the layer again)", InputWarning,
                      stacklevel=2)


def _xml(head: bytes) -> bool:
    """Whether a file starts as XML (a GeoJSON property may hold "<kml" or "<osm")."""
    return head.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<")


def read_gis_file(path: Path, layer: str | None, fmt: str, accept: str,
                  crs_given: bool = False) -> dict[str, Any]:
    """The layer of the GIS file at ``path`` as a GeoJSON FeatureCollection (a dict);
    ``accept`` ("lines", "polygons" or "any") picks the layer when ``layer`` is None
    (a GeoParquet file's ``layer`` is a geometry column; it has one table);
    ``crs_given``: the user said which CRS its coordinates are in (``--crs``)."""
    if fmt == PARQUET:
        return read_geoparquet(path, layer)
    with _no_gfs_left(path, fmt):
        return _read_gdal(path, layer, fmt, accept, crs_given)


@contextmanager
def _no_gfs_left(path: Path, fmt: str) -> Iterator[None]:
    """A GML file read without its schema has GDAL write what it guessed of the schema
    to ``<name>.gfs`` beside it: the user's input folder gained a file each run. One
    that was not there before is removed after reading."""
    gfs = Path(path).with_suffix(".gfs")
    made = fmt == "GML" and not gfs.exists()
    try:
        yield
    finally:
        if made:
            gfs.unlink(missing_ok=True)


def _read_gdal(path: Path, layer: str | None, fmt: str, accept: str, crs_given: bool
               ) -> dict[str, Any]:
    """:func:`read_gis_file` of a file GDAL reads (every format but GeoParquet)."""
    import pyogrio  # GDAL: loaded only when such a file is given
    from pyogrio.errors import DataLayerError, DataSourceError

    if not (fmt == GDB and path.is_dir()):   # a geodatabase folder: its files counted
        check_file(path, fmt, SkeletonError)
    _check_unpacked(path, fmt)
    gdal = _in_zip_folder(path, fmt)
    if fmt == "Shapefile":
        _check_shp_length(path)
    if fmt == OSM:   # node ids out of order (JOSM's new objects, merged extracts) too
        pyogrio.set_gdal_config_options({"OSM_USE_CUSTOM_INDEXING": "NO"})
        _warn_gapped_ways(path, accept)
    if fmt == DXF:   # a footprint drawn as a closed polyline is a polygon
        pyogrio.set_gdal_config_options(
            {"DXF_CLOSED_LINE_AS_POLYGON": "TRUE" if accept == "polygons" else "FALSE"})
    unreadable = (DataSourceError, DataLayerError, OSError, RuntimeError)
    try:
        with _gdal_quiet():
            layers = pyogrio.list_layers(gdal)
    except unreadable as exc:
        raise _cannot_read(path, fmt, exc) from None
    where = None
    if fmt == OSM and layer is None:
        if accept not in OSM_LAYERS:
            raise SkeletonError(f"{path}: an OpenStreetMap file holds every kind of map "
                                f"feature; name the layer to read: {path}{LAYER_SEP}lines "
                                f"or {path}{LAYER_SEP}multipolygons")
        name, where = OSM_LAYERS[accept]   # streets: ways with highway=*; buildings
    elif fmt == DXF:
        name, where = str(layers[0][0]), _cad_layer(path, layer)
    else:
        name = _layer(path, layer, fmt, accept, layers)
    try:
        with _gdal_quiet():
            meta, _, wkb, fields = pyogrio.raw.read(gdal, layer=name, force_2d=True,
                                                    datetime_as_string=True, where=where)
    except unreadable as exc:
        raise _cannot_read(path, fmt, exc) from None
    if wkb is None or len(wkb) == 0:
        raise _no_features(path, fmt, name, accept, _listed(gdal, name) if where is None
                           else 0)
    _warn_unread_prj(path, fmt, meta.get("crs") or crs_given)
    geoms = shapely.from_wkb(np.asarray(wkb, dtype=object), on_invalid="ignore")
    names = [str(n) for n in meta["fields"]]
    columns = [_values(c) for c in fields]
    rows: Sequence[int] = range(len(geoms))
    if fmt == DXF:   # its texts, dimensions and hatches are no streets or buildings
        geoms, rows = _cad_rows(path, geoms, accept, layer, names, columns)
    geometries = geojson_geometries(geoms)
    features = []
    for i in rows:
        props = {k: col[i] for k, col in zip(names, columns, strict=True)
                 if col[i] is not None}
        if fmt == OSM and isinstance(props.get("other_tags"), str):
            props = {**_tags(props.pop("other_tags")), **props}   # lanes, width, levels
        features.append({"type": "Feature", "properties": props,
                         "geometry": geometries[i]})
    data: dict[str, Any] = {"type": "FeatureCollection", "features": features}
    if meta.get("crs"):
        data["crs"] = {"type": "name", "properties": {"name": str(meta["crs"])}}
    return data


@contextmanager
def _gdal_quiet() -> Iterator[None]:
    """GDAL's own warnings kept off the user's screen: an Esri JSON's
    ``"wkid": 102100`` (Web Mercator as Esri numbered it) printed two RuntimeWarnings
    with pyogrio's source lines ("EPSG:102100 is not a valid CRS code", "CRS
    EPSG:102100 is deprecated") before a run that read it right."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        # a measured (M) geometry is read as plain x, y: nothing of it is lost to us
        warnings.filterwarnings("ignore", "Measured \\(M\\) geometry", UserWarning)
        yield


def _cad_layer(path: Path, layer: str | None) -> str | None:
    """The attribute filter picking a DXF drawing's CAD layer ``layer`` (checked to be
    one of its layers), or None for every entity."""
    import pyogrio

    if layer is None:
        return None
    _, _, _, fields = pyogrio.raw.read(path, columns=["Layer"], read_geometry=False)
    found = sorted({str(v) for v in fields[0].tolist()}) if fields else []
    if layer not in found:
        listed = ", ".join(found[:30]) + (", ..." if len(found) > 30 else "")
        raise SkeletonError(f"{path}: no CAD layer {layer!r}; its layers are "
                            f"{listed or 'none'}")
    return "Layer = '" + layer.replace("'", "''") + "'"


def _cad_entities(path: Path, geoms: np.ndarray, accept: str, layer: str | None,
                  cad_layers: list[Any]) -> list[int]:
    """The entities of a DXF drawing with the geometry the caller reads (all with a
    line or polygon geometry for "any"); with no CAD layer named, a warning when they
    come from several (a drawing's frame or its plot border is a closed polyline too)."""
    fits = GEOMETRIES.get(accept, GEOMETRIES["lines"] + GEOMETRIES["polygons"])
    kinds = shapely.get_type_id(geoms)
    wanted = {shapely.GeometryType[f.upper()].value for f in fits}   # "LINESTRING", ...
    rows = [i for i, k in enumerate(kinds) if int(k) in wanted]
    several = sorted({str(cad_layers[i]) for i in rows})
    if layer is None and len(several) > 1:
        shown = ", ".join(several[:10]) + (", ..." if len(several) > 10 else "")
        warnings.warn(f"{path}: read the entities of {len(several)} CAD layers ({shown}); "
                      f"name the one to read as {path}{LAYER_SEP}{several[0]}",
                      InputWarning, stacklevel=2)
    if not rows:
        what = {"lines": "lines (streets)", "polygons": "closed polylines or polygons "
                "(footprints)"}.get(accept, "lines or polygons")
        on = f" on CAD layer {layer!r}" if layer else ""
        raise SkeletonError(f"{path}: no {what}{on} in this drawing; name the CAD layer "
                            f"that holds them as {path}{LAYER_SEP}LAYER")
    return rows


def _listed(path: Path | str, layer: str) -> int:
    """How many features the header of the file's ``layer`` lists (0 when it cannot
    tell)."""
    import pyogrio
    try:
        return max(int(pyogrio.read_info(path, layer=layer)["features"]), 0)
    except Exception:   # noqa: BLE001 - GDAL's many errors: the count is only a hint
        return 0


def _no_features(path: Path, fmt: str, layer: str, accept: str, listed: int = 0
                 ) -> SkeletonError:
    """The file's layer is empty: for an OpenStreetMap file, what it lacks in its
    terms (GDAL's layer names, "multipolygons", mean nothing to a user of OSM data);
    a file whose header lists features none of which could be read is cut short (a
    FlatGeobuf copied part-way was "layer 'b' has no features")."""
    if listed:
        return SkeletonError(f"{path}: its header lists {listed} feature"
                             f"{'s' if listed > 1 else ''} in layer {layer!r} but none could "
                             f"be read: the {fmt} is cut short or damaged; copy or export "
                             "it again")
    if fmt == OSM:
        what = {"lines": "streets (ways tagged highway=*)",
                "polygons": "buildings (areas tagged building=*)"}[accept]
        return SkeletonError(f"{path}: no {what} in this OpenStreetMap file; check that "
                             "the extract covers them, or leave the file out")
    return SkeletonError(f"{path}: layer {layer!r} has no features; export the layer "
                         "with its features, or leave the file out")


def _cad_rows(path: Path, geoms: np.ndarray, accept: str, layer: str | None,
              names: list[str], columns: list[Any]) -> tuple[np.ndarray, list[int]]:
    """A drawing's entities to read (:func:`_cad_entities`), its footprints with their
    courtyards (:func:`_cad_courtyards`); ``names`` and ``columns`` gain the entity
    handle as each feature's id."""
    rows = _cad_entities(path, geoms, accept, layer,
                         columns[names.index("Layer")] if "Layer" in names
                         else [""] * len(geoms))
    names.append("id")
    columns.append(columns[names.index("EntityHandle")] if "EntityHandle" in names
                   else [None] * len(geoms))
    return _cad_courtyards(geoms, rows) if accept == "polygons" else (geoms, rows)


def _cad_courtyards(geoms: np.ndarray, rows: list[int]) -> tuple[np.ndarray, list[int]]:
    """A drawing's closed polylines read as CAD draws courtyards: a polyline inside
    another is a hole in it, one inside that hole a building again (even-odd, by how
    many of the others enclose it; the smallest of those is its ring's owner). A
    drawing has no polygon with holes to give: each courtyard, a closed polyline of
    its own, was left out as "lies inside" its building, and the building built solid.
    Polylines that cross or touch another's line are left as they are."""
    polys = {i: geoms[i] for i in rows if geoms[i] is not None
             and shapely.get_type_id(geoms[i]) == shapely.GeometryType.POLYGON.value
             and geoms[i].is_valid and not geoms[i].is_empty}
    if len(polys) < 2:
        return geoms, rows
    keys = list(polys)
    tree = shapely.STRtree([polys[i] for i in keys])
    outer, inner = tree.query([polys[i] for i in keys], predicate="contains_properly")
    owners: dict[int, list[int]] = {}
    for a, b in zip(outer.tolist(), inner.tolist(), strict=True):   # a holds b
        owners.setdefault(keys[b], []).append(keys[a])
    holes: dict[int, list[int]] = {}
    for i, around in owners.items():
        if len(around) % 2 == 1:             # an odd number round it: a courtyard
            owner = min(around, key=lambda j: (polys[j].area, j))
            holes.setdefault(owner, []).append(i)
    out = geoms.copy()
    for owner, yards in holes.items():
        shell = polys[owner]
        out[owner] = shapely.Polygon(shell.exterior, [*shell.interiors,
                                                      *(polys[y].exterior for y in yards)])
    inner = {y for ys in holes.values() for y in ys}
    return out, [i for i in rows if i not in inner]


_OSM_TABLES = {"nodes": "node", "ways": "way", "polygons_standalone": "way"}


def _cannot_read(path: Path, fmt: str, exc: Exception) -> SkeletonError:
    text = " ".join(str(exc).split())
    dup = re.search(r"UNIQUE constraint failed: (\w+)\.id", text) if fmt == OSM else None
    if dup:   # GDAL's index of the file's objects, in SQLite: an id given twice
        kind = _OSM_TABLES.get(dup[1], "relation" if "relation" in dup[1] else "object")
        return SkeletonError(f"{path}: two {kind}s of this OpenStreetMap file share one id "
                             "(ids are unique in OpenStreetMap data: a file merged from "
                             "extracts, or edited by hand); merge extracts with osmium "
                             "merge, which keeps each object once, or export the layer as "
                             "GeoJSON")
    if re.search(r"Unable to open \S+\.shx", text):   # GDAL's fix would write one
        return SkeletonError(f"{path}: its index file {path.with_suffix('.shx').name} is "
                             "missing (a Shapefile is several files: .shp, .shx, .dbf and "
                             ".prj, side by side); copy it beside the .shp, or export the "
                             "layer as GeoJSON")
    if fmt == "GeoPackage" and _empty_geopackage(path):   # GDAL: "not recognized"
        return SkeletonError(f"{path}: this GeoPackage holds no layer (saved empty); "
                             "export the layer again")
    detail = text.split("; It might help")[0]
    detail = detail.rsplit("failed: ", 1)[-1].split("; ")[0]   # SQLite: its own words
    detail = re.sub(r"^\S+\.cpp, \d+: ", "", detail)   # GDAL's source file and line
    whole = {"Shapefile": " (a Shapefile needs its .shx and .dbf beside it)",
             "MapInfo table": " (a .tab needs its .dat, .map and .id beside it)"}.get(
        fmt.removeprefix("zipped "), "")
    return cannot_read(path, fmt, detail, whole)


def _empty_geopackage(path: Path) -> bool:
    """Whether ``path`` is a whole GeoPackage that lists no table (QGIS's "new
    GeoPackage" saved before a layer was added): GDAL calls it "not recognized as
    being in a supported file format", which read as a damaged file."""
    import sqlite3

    try:
        uri = Path(path).resolve().as_uri() + "?mode=ro"   # read only, never made
        with contextlib.closing(sqlite3.connect(uri, uri=True)) as db:
            return db.execute("SELECT count(*) FROM gpkg_contents").fetchone()[0] == 0
    except sqlite3.Error:
        return False


def _layer(path: Path, layer: str | None, fmt: str, accept: str, layers: np.ndarray) -> str:
    """The layer to read: the one named, else the one whose geometry the caller reads."""
    found = [(str(n), str(t)) for n, t in layers]
    if not found:
        raise SkeletonError(f"{path}: this {fmt} holds no layer (damaged, or saved "
                            "empty); export the layer again")
    listed = ", ".join(f"{n} ({t})" for n, t in found)
    if layer is not None:
        if layer not in {n for n, _ in found}:
            raise SkeletonError(f"{path}: no layer {layer!r}; its layers are {listed}")
        return layer
    fits = GEOMETRIES.get(accept)
    usable = [n for n, t in found if (_plain(t) in fits if fits else t not in ("", "None"))]
    if fits and not usable and len(found) > 1:   # layers of no declared type: by features
        usable = [n for n, t in found if _plain(t) == "Unknown" and _holds(path, n, fits)]
    if len(usable) == 1 or (len(found) == 1 and not usable):
        return usable[0] if usable else found[0][0]   # one layer: its features are checked
    what = {"lines": "line", "polygons": "polygon"}.get(accept, "geometry")
    if not usable:
        raise SkeletonError(f"{path}: no {what} layer; its layers are {listed}; name "
                            f"the one to read as {path}{LAYER_SEP}{found[0][0]}, or give "
                            f"the {fmt} that holds the {what} layer")
    # the one suggested holds features: an empty layer beside the real one (a
    # template's, a sorted-first "aaa_empty") was suggested, then said to hold none
    held = [n for n in usable if _listed(path, n) > 0] or usable
    named = ", ".join(n if n in held else f"{n}: empty" for n in usable)
    raise SkeletonError(f"{path}: {len(usable)} {what} layers ({named}); "
                        f"name the one to read as {path}{LAYER_SEP}{held[0]}")


SNIFF = 100   # features a layer of no declared geometry type is judged by


def _holds(path: Path, name: str, fits: tuple[str, ...]) -> bool:
    """Whether the first :data:`SNIFF` features of layer ``name`` are all of the
    geometry types ``fits``: a layer whose type GDAL cannot declare (every folder of a
    KML, a GeoPackage layer written as generic geometry) is picked by what it holds,
    so ``--streets both.kml --footprints both.kml`` reads each its layer."""
    import pyogrio
    from pyogrio.errors import DataLayerError, DataSourceError
    try:
        _meta, _, wkb, _fields = pyogrio.raw.read(path, layer=name, columns=[],
                                                  max_features=SNIFF, force_2d=True)
    except (DataSourceError, DataLayerError, OSError, RuntimeError):
        return False   # an unreadable layer is told when it is read, if it is chosen
    geoms = shapely.from_wkb(np.asarray(wkb if wkb is not None else [], dtype=object),
                             on_invalid="ignore")
    kinds = {g.geom_type for g in geoms if g is not None}
    return bool(kinds) and kinds <= set(fits)


def _tags(hstore: str) -> dict[str, str]:
    """GDAL's ``other_tags`` of an OpenStreetMap feature (``"lanes"=>"2","width"=>"7"``)
    as properties, as a GeoJSON export of the same ways would have them."""
    return {k.replace('\\"', '"'): v.replace('\\"', '"') for k, v in _HSTORE.findall(hstore)}


def _plain(kind: str) -> str:
    """A layer's geometry type without its dimensions ("LineString Z" -> "LineString")."""
    return kind.removeprefix("3D ").removesuffix(" ZM").removesuffix(" Z").removesuffix(" M")


def _values(column: np.ndarray) -> list[Any]:
    """A field's values as JSON would hold them (:func:`.geoparquet.json_value`): a
    list field (GML's StringList: an osmnx edge's ``highway`` of a merged street) as a
    list, as the GeoJSON it came from holds it (GDAL gives an array, which a street's
    tags crashed on), and OGR's text of a list, ``(2:residential,unclassified)`` as a
    GeoPackage stores one, as that list (it was read as one odd class)."""
    return [_listed_text(json_value(v)) for v in column.tolist()]


_OGR_LIST = re.compile(r"^\((\d+):(.*)\)$", re.DOTALL)


def _listed_text(v: Any) -> Any:
    """OGR's text of a StringList, IntegerList or RealList field, ``(n:a,b,...)`` with
    n items, as the list; any other value as it is."""
    if not isinstance(v, str):
        return v
    m = _OGR_LIST.match(v)
    if m is None:
        return v
    items = m.group(2).split(",") if m.group(2) else []
    return items if len(items) == int(m.group(1)) else v
