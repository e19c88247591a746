"""Reading GeoJSON, as GIS tools write it, into a local metric frame.

Lon/lat input (RFC 7946, or a legacy ``"crs"`` member naming CRS84 or EPSG:4326 in any
spelling, as GDAL, QGIS, geopandas and osmnx write it) is projected with pyproj to a
transverse Mercator centred on the data, so distances and angles are true to a
millimetre over a district. Input in another CRS (the ``crs`` argument, or the file's
``"crs"`` member) is handled by how true to scale that CRS is over the data: a projected
CRS whose scale factor stays within :data:`TRUE_SCALE` of 1 (a UTM zone near the data,
a national grid) is only moved to a local origin, so the local frame keeps its axes;
any other CRS (Web Mercator, a far-away zone, another geographic CRS) is transformed to
lon/lat and then into the same local transverse Mercator as lon/lat input, so lengths
come out true whatever CRS the file uses.

Features with no geometry (``null`` or empty) or with a geometry the caller cannot use
(``accept``: a Point in a street file) are left out with an :class:`InputWarning`; the
returned :class:`Features` list keeps their messages so a caller can count them. The file
is refused only when nothing usable is left. Every message names the file and the
feature's index in it.
"""

from __future__ import annotations

import functools
import json
import math
import re
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, TypeVar

import numpy as np
import pyproj
import shapely
from shapely.geometry import shape
from shapely.geometry.base import BaseGeometry

from citysynth.skeletons.degrees import in_degrees
from citysynth.skeletons.errors import (
    FarFromFrame,
    FarFromFrameWarning,
    InputWarning,
    SkeletonError,
)
from citysynth.skeletons.gis_files import gis_format, read_gis_file
from citysynth.skeletons.overture import osm_tags
from citysynth.solver.safe_read import parse_json, printable, read_text, shown

TRUE_SCALE = 1e-3      # a projected CRS whose scale strays more from 1 is reprojected
#                        (and a run's local frame warns of data it stretches more)
FRAME_SCALE = 1e-2     # ... and refuses data it stretches more than this
EARTH_RADIUS = 6_371_000.0   # m
LONLAT_FRAME = "WGS 84 lon/lat, local transverse Mercator"

Accept = Literal["any", "lines", "polygons"]
ACCEPTED: dict[str, tuple[str, ...]] = {
    "lines": ("LineString", "MultiLineString"),
    "polygons": ("Polygon", "MultiPolygon"),
}
_WHAT = {"lines": "a line", "polygons": "a polygon"}
_CRS84 = pyproj.CRS.from_user_input("OGC:CRS84")
_GEOD = pyproj.Geod(ellps="WGS84")

Coords = np.ndarray
Project = Callable[[Coords], Coords]


def feature_label(index: int, properties: dict[str, Any]) -> str:
    """``feature 3``, or ``feature 3 (Main Street)`` when the feature has an id or name;
    an OpenStreetMap object without either by its OSM id (``feature 3 (way 180464601)``,
    as GDAL names it: ``osm_way_id`` a closed way's, ``osm_id`` a line's way or a
    multipolygon's relation), so a user finds it in the map."""
    fid = properties.get("id", properties.get("name"))
    if fid is None and properties.get("osm_way_id") is not None:
        fid = f"way {properties['osm_way_id']}"
    elif fid is None and properties.get("osm_id") is not None:
        fid = f"OSM id {properties['osm_id']}"
    return f"feature {index}" + (f" ({printable(str(fid))})" if fid is not None else "")


@dataclass(frozen=True)
class Feature:
    index: int                  # the feature's index in its file
    geometry: BaseGeometry      # in the local metric frame (metres)
    properties: dict[str, Any]
    source: str = ""            # the file it came from, for messages

    @property
    def name(self) -> str:
        return feature_label(self.index, self.properties)

    @property
    def where(self) -> str:
        """The feature as messages name it: file and index."""
        return f"{self.source}: {self.name}" if self.source else self.name


class Features(list[Feature]):
    """The features read, in file order, and ``skipped``: one message for each feature
    left out (no geometry, or one the caller cannot use)."""

    def __init__(self, items: Iterable[Feature] = (), skipped: Iterable[str] = ()) -> None:
        super().__init__(items)
        self.skipped: list[str] = list(skipped)


@dataclass(frozen=True)
class Frame:
    """How local metres relate to the input: the frame, its origin (lon/lat for the
    local transverse Mercator, input coordinates for projected input kept as it is) and
    the input's CRS when it was not plain lon/lat (``source_crs``, e.g. "EPSG:3857").
    A kept projected frame's ``crs`` names the CRS for people and for tools alike
    (:func:`kept_crs`: "ETRS89 / TM35FIN(E,N) (projected, EPSG:3067)"), so a layout's
    frame, which is all a writer sees, says which CRS its georeference is in."""

    crs: str
    origin: tuple[float, float]   # input coordinates (or lon/lat) of the local (0, 0)
    source_crs: str = ""

    def at(self, xy: Any) -> str:
        """A local point as messages give it: in the input's own coordinates, so a user
        finds it in their GIS."""
        return format_xy(input_xy((self.crs, *self.origin), self.source_crs, xy))

    def describe(self, told: bool = False) -> str:
        """The frame as a layout records it: its CRS (for a kept projected one, its
        name and identifier), origin and input CRS. ``told``: as a person reads it
        on the console, where a CRS without an authority code, named by its WKT (1.5
        kB on one line), is named by its name and "WKT" only."""
        crs, source = self.crs, self.source_crs
        if told:
            kept = kept_crs_parts(crs)
            if kept is not None and _wkt(kept[1]):
                crs = (f"{_named(kept[0])} (projected, no authority code: its WKT is in "
                       "--json's frame)")
            if _wkt(source):
                source = f"{_named(pyproj.CRS.from_user_input(source).name)} (WKT)"
        text = f"{crs}, origin {self.origin[0]:.6f}, {self.origin[1]:.6f}"
        if source and self.crs == LONLAT_FRAME:
            text += f" (input in {source}, reprojected)"
        return text


def _named(name: str) -> str:
    """A CRS's name as a person reads it ("unknown", PROJ's name for one it was given
    only the parameters of, says nothing)."""
    return "a custom CRS" if name in ("", "unknown") else name


def _wkt(crs: str) -> bool:
    """Whether a CRS identifier is WKT (or PROJ JSON, or a PROJ string), not a short
    code such as "EPSG:3067"."""
    return len(crs) > 40 or "[" in crs or "{" in crs


def read_geojson(path: str | Path, crs: str | None = None,
                 origin: tuple[float, float] | None = None, origin_digits: int | None = None,
                 *, accept: Accept = "any", within: Frame | None = None,
                 layer_of: Accept | None = None, others: Accept | None = None
                 ) -> tuple[Features, Frame]:
    """A GeoJSON file's features in a local metric frame; see :func:`parse_geojson`.
    Another GIS file (GeoPackage, Shapefile, ...; ``FILE::LAYER`` for one of several
    layers) is read as the GeoJSON export of its layer would be (:mod:`.gis_files`):
    the layer of the geometry ``layer_of`` names (by default ``accept``'s), where a
    caller that takes any geometry still knows which layer it wants."""
    gis = gis_format(path)
    if gis is not None:
        data = read_gis_file(*gis, layer_of or accept, crs_given=crs is not None)
    else:
        data = _read_json_or_sequence(Path(path))
    return parse_geojson(data, str(path), crs, origin, origin_digits, accept=accept,
                         within=within, others=others)


RS = "\x1e"   # RFC 8142's record separator, before each text of a GeoJSON Text Sequence


def _read_json_or_sequence(path: Path) -> Any:
    """A GeoJSON file's JSON (its encoding, depth, size and numbers checked); or a GeoJSON
    Text Sequence (RFC 8142, ``ogr2ogr -f GeoJSONSeq``; or a feature per line, as
    Overture's and tippecanoe's tools write) as the FeatureCollection of its features."""
    text = read_text(path, "GeoJSON", SkeletonError)
    if not _is_sequence(text):
        return parse_json(text, path, "GeoJSON", SkeletonError)
    body = text.lstrip("\ufeff")
    sep = RS if RS in body else "\n"    # with separators, a record may span lines
    features: list[Any] = []
    line = 1
    for chunk in body.split(sep):
        if chunk.strip(" \t\r\n"):
            at = line + chunk[:len(chunk) - len(chunk.lstrip())].count("\n")
            record = parse_json(chunk, f"{path}, line {at}", "GeoJSON", SkeletonError)
            kind = record.get("type") if isinstance(record, dict) else None
            if kind in GEOMETRY_TYPES:   # a bare geometry, as a Feature of it
                record = {"type": "Feature", "properties": {}, "geometry": record}
            got = record.get("features") if kind == "FeatureCollection" else [record]
            features.extend(got if isinstance(got, list) else [got])
        line += chunk.count("\n") + (sep == "\n")
    return {"type": "FeatureCollection", "features": features}


def _is_sequence(text: str) -> bool:
    """Whether ``text`` is a GeoJSON Text Sequence: record separators, or a complete
    JSON object on its first line with another one starting on a later line (a
    FeatureCollection on one line, or pretty-printed, is not)."""
    body = text.lstrip("\ufeff \t\r\n")
    if body.startswith(RS):
        return True
    first, _, rest = body.partition("\n")
    if not rest.lstrip(" \t\r\n").startswith("{") or not first.rstrip().endswith("}"):
        return False
    try:
        return isinstance(json.loads(first), dict)
    except ValueError:
        return False


def parse_geojson(data: Any, source: str = "input", crs: str | None = None,
                  origin: tuple[float, float] | None = None, origin_digits: int | None = None,
                  *, accept: Accept = "any", within: Frame | None = None,
                  others: Accept | None = None) -> tuple[Features, Frame]:
    """Features in a local metric frame centred on the data's bounding box, or on
    ``origin`` (lon/lat, or input coordinates for projected input kept as it is), or in
    ``within``, the frame another file set: so that several files share one frame, each
    read in its own CRS (streets in EPSG:3067, footprints in lon/lat). With
    ``origin_digits``, a lon/lat centre is rounded to that many decimals (2: about 1 km),
    so that edits at the edge of the data do not move the frame. ``crs`` (e.g.
    "EPSG:25832") overrides the file's ``"crs"`` member.
    ``accept`` names the geometries the caller can use ("lines", "polygons"); features
    with others, or with none, are left out with a warning (:class:`Features`), but for
    those of the kind ``others`` names, which the file holds for another reader (one
    file given as both a city's streets and its footprints), left out without one."""
    if isinstance(data, list) and data and all(
            isinstance(f, dict) and f.get("type") == "Feature" for f in data):
        data = {"type": "FeatureCollection", "features": data}   # a web API's array
    raw = _raw_features(data, source)
    member = _crs_member(data, source)
    chosen, overrides = _chosen_crs(crs, member)
    given = _with_member(lambda: _input_crs(chosen, source), overrides, member)
    kept, skipped = _usable(raw, source, accept, others)
    if not kept and not skipped and others is not None and accept in ACCEPTED:
        raise SkeletonError(_only_others(source, len(raw), accept, others))
    if not kept:
        raise SkeletonError(f"{source}: no usable features: all {len(raw)} left out ("
                            + skipped[0].removeprefix(f"{source}: ").removesuffix("; left out")
                            + ("" if len(skipped) == 1 else "; ...") + ")")
    for message in skipped:
        warnings.warn(message, InputWarning, stacklevel=3)
    geoms = [g for _, g, _ in kept]
    named_by = "--crs" if crs is not None else f'the file\'s "crs" member ({member})'
    project, frame = _with_member(
        lambda: _frame(geoms, given, source, origin, origin_digits, named_by, within),
        overrides, member)
    if overrides:
        warnings.warn(f"{source}: the file says its coordinates are in {member}, but "
                      f"--crs says {crs}; using {crs}", InputWarning, stacklevel=2)
    feats = Features((Feature(i, shapely.transform(g, project), osm_tags(props), source)
                      for i, g, props in kept), skipped)
    return feats, frame


def _only_others(source: str, n: int, accept: Accept, others: Accept) -> str:
    """Why a file given for two readers (a city's streets and its footprints) holds
    nothing for this one: every feature is the other reader's. ``parse_geojson`` quoted
    the first feature it left out, and there was none (IndexError, exit 3)."""
    what = "its one feature is " + _WHAT[others] if n == 1 else \
        f"its {n:,} features are all {others}"
    return (f"{source}: no {accept} ({' or '.join(ACCEPTED[accept])}) in it: {what} "
            f"({' or '.join(ACCEPTED[others])}), which the run reads from it as well; give "
            f"the file that holds the {accept}, or add them to this one")


# --- the FeatureCollection and its features ---------------------------------------------

GEOMETRY_TYPES = ("Point", "MultiPoint", "LineString", "MultiLineString", "Polygon",
                  "MultiPolygon", "GeometryCollection")


def _raw_features(data: Any, source: str) -> list[Any]:
    """The features of a FeatureCollection, a Feature or a bare geometry; anything else
    is told what it looks like and how to make it GeoJSON."""
    if isinstance(data, dict) and data.get("type") in GEOMETRY_TYPES:
        data = {"type": "Feature", "properties": {}, "geometry": data}   # a bare geometry
    if not isinstance(data, dict) or data.get("type") not in ("FeatureCollection", "Feature"):
        raise SkeletonError(f"{source}: not a GeoJSON FeatureCollection, Feature or geometry"
                            f"{_what_else(data)}")
    raw = data.get("features") if data["type"] == "FeatureCollection" else [data]
    if raw is not None and not isinstance(raw, list):
        raise SkeletonError(f"{source}: its \"features\" is a JSON {_json_kind(raw)}, not a "
                            "list of Features; export the layer again as GeoJSON")
    if not raw:
        raise SkeletonError(f"{source}: no features (an empty FeatureCollection); export "
                            "the layer with its features, or leave the file out")
    return raw


def _json_kind(value: Any) -> str:
    return {dict: "object", list: "array", str: "string", bool: "true/false"}.get(
        type(value), "number" if isinstance(value, int | float) else "null")


def _what_else(data: Any) -> str:
    """What JSON that is no GeoJSON looks like, as advice: "" when nothing is known."""
    kind = data.get("type") if isinstance(data, dict) else None
    if kind == "Topology":
        return (" but TopoJSON; convert it to GeoJSON first (mapshaper, or topojson's "
                "topo2geo)")
    if isinstance(data, list):
        return (" but a JSON array; a GeoJSON file holds one object: "
                '{"type": "FeatureCollection", "features": [...]}')
    if isinstance(data, dict) and "type" not in data:
        return ' (it has no "type"); export the layer again as GeoJSON'
    if isinstance(data, dict):
        return f" (its type is {shown(kind, 40)}); export the layer again as GeoJSON"
    return f" but a JSON {_json_kind(data)}"


def _usable(raw: list[Any], source: str, accept: Accept, others: Accept | None = None
            ) -> tuple[list[tuple[int, BaseGeometry, dict[str, Any]]], list[str]]:
    """The features the caller can use, as (index, geometry in input coordinates,
    properties), and a message for each one left out (none for a geometry of the kind
    ``others``: another reader's)."""
    kept, skipped = [], []
    for i, f in enumerate(raw):
        if not isinstance(f, dict) or f.get("type") != "Feature":
            raise SkeletonError(f"{source}: feature {i} is not a GeoJSON Feature")
        props = f.get("properties")
        if props is not None and not isinstance(props, dict):
            raise SkeletonError(f"{source}: feature {i}: properties must be an object or "
                                f"null, got {type(props).__name__}")
        props = dict(props or {})
        fid = f.get("id")     # RFC 7946's own member, where GDAL and others write it
        if "id" not in props and isinstance(fid, str | int) and not isinstance(fid, bool) \
                and str(fid):
            props["id"] = fid
        g = _polygons_of(_geometry(f.get("geometry"), f"{source}: feature {i}"), accept)
        reason = _unusable(g, accept)
        if g is None and f.get("place") is not None:   # JSON-FG keeps projected geometry there
            reason = ('no geometry (null), its shape is in "place" (JSON-FG); export the '
                      "layer as plain GeoJSON (ogr2ogr -f GeoJSON) to use it")
        if reason is not None and others is not None and g is not None \
                and g.geom_type in ACCEPTED[others]:
            continue
        if reason is not None:
            skipped.append(f"{source}: {feature_label(i, props)}: {reason}; left out")
            continue
        assert g is not None
        kept.append((i, g, props))
    return kept, skipped


def _geometry(g: Any, where: str) -> BaseGeometry | None:
    """A feature's geometry (None when it has none); malformed geometry is refused."""
    if g is None:
        return None
    if not isinstance(g, dict):
        raise SkeletonError(f"{where}: malformed geometry (not an object)")
    kind = g.get("type")
    if kind not in GEOMETRY_TYPES:
        raise SkeletonError(f"{where}: unknown geometry type {shown(kind)}; GeoJSON has "
                            f"{', '.join(GEOMETRY_TYPES)}")
    if kind != "GeometryCollection" and not isinstance(g.get("coordinates"), list):
        raise SkeletonError(f"{where}: malformed {kind} (its coordinates must be an array: "
                            f"{NESTING[kind]})")
    _check_coordinates(g, where)
    try:
        geom = shape(g)
    except Exception as exc:  # shapely raises several kinds for malformed geometry
        raise SkeletonError(f"{where}: malformed {kind} ({_geos_words(exc, kind)})") from None
    coords = shapely.get_coordinates(geom)
    bad = ~np.isfinite(coords).all(axis=1)
    if bad.any():
        n = int(np.argmax(bad))
        raise SkeletonError(f"{where}: its point {n} ({shown(coords[n].tolist())}) is not "
                            "finite numbers; fix or remove that point")
    return geom


NESTING = {   # how each geometry's coordinates nest, as messages show it
    "Point": "[x, y]", "MultiPoint": "[[x, y], ...]", "LineString": "[[x, y], [x, y], ...]",
    "MultiLineString": "[[[x, y], [x, y], ...], ...]",
    "Polygon": "[[[x, y], [x, y], [x, y], [x, y]], ...] (rings, each closed)",
    "MultiPolygon": "[[[[x, y], ...]], ...] (polygons of rings)"}


def _geos_words(exc: Exception, kind: str = "") -> str:
    """shapely's or GEOS's complaint without the exception class GEOS prefixes and the
    line break it ends with ("IllegalArgumentException: point array must contain 0 or >1
    elements\n"): "a line needs at least 2 points" where that is what it means; numpy's
    and Python's complaints about the nesting as how the coordinates should nest."""
    if isinstance(exc, TypeError | KeyError | IndexError) or "inhomogeneous" in str(exc) \
            or "setting an array element" in str(exc):
        return (f"its coordinates do not nest as a {kind}'s do, {NESTING.get(kind, '')}, "
                "every position with the same count of numbers")
    text = str(exc).strip()
    text = re.sub(r"^[A-Za-z]*Exception:\s*", "", text)
    if "point array must contain 0 or >1 elements" in text:
        return "a line needs at least 2 points"
    if "linearring requires at least 4 coordinates" in text.lower():
        return ("a ring needs at least 4 positions: 3 corners, then the first again; "
                "fix or delete the feature in your GIS")
    if "empty component" in text:
        parts = {"MultiLineString": "lines", "MultiPolygon": "polygons"}.get(kind, "parts")
        return (f"one of the {parts} in it has no positions; delete the empty part in "
                "your GIS")
    dims = re.search(r"dimension should be 2 or 3, got (\d+)", text)
    if dims:
        n = int(dims.group(1))
        return (f"a position has {n} number{'s' if n != 1 else ''}; GeoJSON gives [x, y] "
                "or [x, y, z]")
    return text


def _num(x: float) -> str:
    """A coordinate as a message gives it: to 0.1 unit, or in 3 figures when huge."""
    return f"{x:.1f}" if abs(x) < 1e12 else f"{x:.3g}"


MAX_VERTICES = 50_000    # per feature: a street, block or building outline has far fewer


def _check_coordinates(g: dict, where: str) -> None:
    """Every coordinate is a number (shapely would read "7.1" or true as one), and the
    feature has at most :data:`MAX_VERTICES` points (counted before shapely builds it)."""
    stack: list[Any] = [g.get("coordinates", [])]
    stack += [c.get("coordinates", []) for c in g.get("geometries", []) or []
              if isinstance(c, dict)]
    n = 0
    while stack:
        v = stack.pop()
        if isinstance(v, list):
            if v and not isinstance(v[0], list):
                n += 1
                if not all(isinstance(x, int | float) and not isinstance(x, bool) for x in v):
                    raise SkeletonError(f"{where}: coordinates must be numbers, got "
                                        f"{shown(v, 200)}")
            else:
                stack.extend(v)
        elif not isinstance(v, int | float) or isinstance(v, bool):
            raise SkeletonError(f"{where}: coordinates must be numbers, got {shown(v, 200)}")
    if n > MAX_VERTICES:
        raise SkeletonError(f"{where}: {n:,} vertices, more than the {MAX_VERTICES:,} an "
                            "outline may have (cleaning it would take minutes and "
                            "gigabytes); simplify it first, e.g. ogr2ogr -simplify 0.1")


def _polygons_of(g: BaseGeometry | None, accept: Accept) -> BaseGeometry | None:
    """Where polygons may be used, a GeometryCollection's polygons (a Google Earth
    placemark is a MultiGeometry of its label's Point and its Polygon; some exports
    wrap each footprint in a collection): they were refused, "a GeometryCollection
    cannot be a polygon". A caller that takes any geometry (``block`` reads its
    polygons so, to tell a line where it belongs) gets them only when the rest are
    points, labels: ``city --footprints`` built such a placemark and ``block`` refused
    it. Anything else as it is."""
    if accept == "lines" or not isinstance(g, shapely.GeometryCollection) or \
            isinstance(g, shapely.MultiPolygon):
        return g
    parts = [p for q in shapely.get_parts(g) for p in shapely.get_parts(q) if not p.is_empty]
    polys = [p for p in parts if isinstance(p, shapely.Polygon)]
    if not polys or accept == "any" and not all(
            isinstance(p, shapely.Polygon | shapely.Point) for p in parts):
        return g
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)


def _unusable(g: BaseGeometry | None, accept: Accept) -> str | None:
    """Why a geometry cannot be used, or None."""
    if g is None:
        return "no geometry (null)"
    if g.is_empty:
        return f"an empty {g.geom_type}"
    if accept != "any" and g.geom_type not in ACCEPTED[accept]:
        why = f"a {g.geom_type} cannot be {_WHAT[accept]} ({' or '.join(ACCEPTED[accept])})"
        if accept == "polygons" and isinstance(g, shapely.LineString) and g.is_ring:
            why += "; it is a closed line: draw or export it as a Polygon"
        return why
    return None


# --- the CRS ------------------------------------------------------------------------------

def _crs_member(data: dict[str, Any], source: str) -> str | None:
    """The CRS a legacy (GeoJSON 2008) ``"crs"`` member names, if any."""
    member = data.get("crs")
    if member is None:
        return None
    props = member.get("properties") if isinstance(member, dict) else None
    kind = member.get("type") if isinstance(member, dict) else None
    if isinstance(props, dict):
        if kind == "name" and isinstance(props.get("name"), str):
            return str(props["name"])
        if kind == "EPSG" and isinstance(props.get("code"), int | str):
            return f"EPSG:{props['code']}"
        if kind == "link":
            raise SkeletonError(f"{source}: the \"crs\" member links to a CRS definition "
                                f"({props.get('href')}), which is not read; give the CRS "
                                "with --crs, e.g. --crs EPSG:25832")
    raise SkeletonError(f"{source}: cannot read the \"crs\" member {json.dumps(member)}; "
                        'it should be {"type": "name", "properties": {"name": "EPSG:..."}}, '
                        "or give the CRS with --crs")


def _chosen_crs(option: str | None, member: str | None) -> tuple[str | None, bool]:
    """``--crs`` wins over the file's ``"crs"`` member (a file can be mislabelled); and
    whether it overrides a member naming another CRS (the user hears which one is used,
    once ``--crs`` proved readable and fitting the coordinates)."""
    if option is None or member is None:
        return (member if option is None else option), False
    try:
        same = pyproj.CRS.from_user_input(option).equals(
            pyproj.CRS.from_user_input(member), ignore_axis_order=True)
    except pyproj.exceptions.CRSError:
        return option, False      # an unreadable --crs is refused as such, nothing more
    return option, not same


_T = TypeVar("_T")


def _with_member(step: Callable[[], _T], overrides: bool, member: str | None) -> _T:
    """``step``, whose refusal of a ``--crs`` that overrides the file's own "crs" member
    names that member too, in the same line (it was a warning line, then the error)."""
    try:
        return step()
    except SkeletonError as exc:
        if not overrides:
            raise
        raise SkeletonError(f'{exc} (the file\'s "crs" member says {member}; leaving '
                            "--crs out uses it)") from None


def _input_crs(crs: str | None, source: str) -> pyproj.CRS | None:
    """The input's CRS, or None for plain lon/lat on WGS 84 (CRS84 or EPSG:4326 in any
    spelling: both mean longitude, latitude in GeoJSON)."""
    if crs is None:
        return None
    if crs.strip().upper() in ("CRS84", "CRS:84"):
        return None
    try:
        given = pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError:
        raise SkeletonError(f"{source}: unknown CRS {shown(crs, 80)}; give it as "
                            "EPSG:<code>, e.g. EPSG:25832") from None
    if not (given.is_projected or given.is_geographic):
        kind = "geocentric (earth-centred X, Y, Z)" if given.is_geocentric else \
            given.type_name.lower().removesuffix(" crs")   # pyproj: "Vertical CRS"
        # (a file's CRS comes as its whole WKT: named, not quoted; "an engineering")
        named = f"{crs} ({given.name})" if len(crs) <= 40 else given.name
        article = "an" if kind[0] in "aeiou" else "a"
        local = (" (a local site grid: give it an EPSG code's projected CRS or reproject "
                 "the data)" if given.type_name.lower().startswith("engineering") else "")
        raise SkeletonError(f"{source}: {named} is {article} {kind} CRS, not a map of the "
                            f"ground{local}; give the projected or lon/lat CRS the "
                            "coordinates are in, e.g. --crs EPSG:25832")
    try:                  # a CRS of Mars or the Moon: no way to the Earth's lon/lat
        pyproj.Transformer.from_crs(given, "EPSG:4326", always_xy=True)
    except pyproj.exceptions.ProjError as exc:
        body = re.search(r"\((\w[\w ]*) vs Earth\)", str(exc))
        where = f"of another body ({body.group(1)}), not of the Earth" if body else \
            "with no way to longitude and latitude on the Earth"
        raise SkeletonError(f"{source}: {crs} ({given.name}) is a CRS {where}; give the "
                            "CRS the coordinates are in, e.g. --crs EPSG:25832") from None
    flat = given.to_2d() if given.is_geographic else given
    if flat.equals(_CRS84, ignore_axis_order=True):
        return None
    return given


def _scale_error(given: pyproj.CRS, coords: Coords) -> float:
    """How far the scale factor of ``given`` strays from 1 over the data (largest
    relative error, east, north and diagonal, at the corners and centre of the data's
    bounding box): ground distance over coordinate distance, measured on the
    ellipsoid."""
    unit = _unit(given)
    to_lonlat = pyproj.Transformer.from_crs(given, "EPSG:4326", always_xy=True)
    lo, hi = coords.min(axis=0), coords.max(axis=0)
    mid = (lo + hi) / 2
    step = 10.0 / unit                     # 10 m in input units
    worst = 0.0
    for px, py in ((lo[0], lo[1]), (lo[0], hi[1]), (hi[0], lo[1]), (hi[0], hi[1]),
                   (mid[0], mid[1])):
        for dx, dy in ((step, 0.0), (0.0, step), (step * 0.7071, step * 0.7071)):
            lon, lat = to_lonlat.transform([px, px + dx], [py, py + dy])
            ground = _GEOD.inv(lon[0], lat[0], lon[1], lat[1])[2]
            if not math.isfinite(ground):
                return math.inf
            worst = max(worst, abs(ground / (math.hypot(dx, dy) * unit) - 1.0))
    return worst


def _unit(crs: pyproj.CRS) -> float:
    """Metres per unit of the CRS's first axis."""
    return float(crs.axis_info[0].unit_conversion_factor) if crs.axis_info else 1.0


# --- the local frame ----------------------------------------------------------------------

def _frame(geoms: list[BaseGeometry], given: pyproj.CRS | None, source: str,
           origin: tuple[float, float] | None, origin_digits: int | None,
           named_by: str = "--crs", within: Frame | None = None) -> tuple[Project, Frame]:
    """How to project the input, and the frame it lands in: its own, or ``within``
    (``named_by``: where the CRS was given, for messages)."""
    allc = np.vstack([shapely.get_coordinates(g) for g in geoms])
    kept = within if within is not None and within.crs != LONLAT_FRAME else None
    to_lonlat = _to_lonlat(given, source) if given is not None else None
    if given is not None and to_lonlat is not None:
        if not given.is_geographic:
            _check_not_degrees(allc, given, source, named_by)
        _check_area(given, to_lonlat(_extent(allc)), source)
        if kept is not None:     # another file's projected CRS, kept as it is
            return _into_kept(allc, given, source, kept), kept
        if within is None and not given.is_geographic and \
                _scale_error(given, allc) <= TRUE_SCALE:
            return _kept_projected(allc, given, origin)
        allc = to_lonlat(allc)
    _check_lonlat(allc, source, given)
    if kept is not None:
        return _into_kept(allc, None, source, kept), kept
    chosen = "the streets' frame" if within is not None else (
        "origin in city.toml" if origin is not None else None)
    if within is not None:
        origin, origin_digits = within.origin, None
    centre = _lonlat_centre(allc) if origin is None else (float(origin[0]), float(origin[1]))
    if origin is None and origin_digits is not None:
        centre = (round(centre[0], origin_digits), round(centre[1], origin_digits))
    to_local = _local_tmerc(centre)
    _check_frame_scale(to_local, allc, centre, source, chosen)
    frame = within or Frame(LONLAT_FRAME, centre, given.to_string() if given is not None
                            else "")
    if to_lonlat is None:
        return to_local, frame
    first = to_lonlat
    return (lambda c: to_local(first(c))), frame


def _check_frame_scale(to_local: Project, lonlat: Coords, centre: tuple[float, float],
                       source: str, chosen: str | None = None) -> None:
    """Refuse data lying so far east or west of the run's frame centre that the frame
    stretches them by more than :data:`FRAME_SCALE` (footprints on two continents, a
    city.toml ``origin`` far from the data: buildings were solved and written several
    per cent too large without a word); warn past :data:`TRUE_SCALE`. A transverse
    Mercator's scale at x metres from its central meridian is about 1 + x²/2R²: measured
    at the points furthest east and west, and at a sample of the rest."""
    pick = np.unique(np.r_[np.argmin(lonlat[:, 0]), np.argmax(lonlat[:, 0]),
                           np.arange(0, len(lonlat), max(1, len(lonlat) // 4096))])
    x = np.abs(to_local(lonlat[pick])[:, 0])
    far = float(x.max()) if np.isfinite(x).all() else math.inf
    error = far * far / (2 * EARTH_RADIUS ** 2)
    if error <= TRUE_SCALE:
        return
    at = f"({centre[0]:.4f}, {centre[1]:.4f})"
    if math.isfinite(far):
        reach = f"{far / 1000:,.0f} km"
    else:  # a quarter of the globe or more: the projection has no finite x there
        apart = np.abs((lonlat[pick, 0] - centre[0] + 180) % 360 - 180)
        reach = f"{float(apart.max()):.0f} degrees of longitude"
    what = (f"{source}: data reach {reach} east or west of the run's frame "
            f"centre {at} (lon, lat), where its lengths are "
            + (f"{error:.1%}" if error < 1 else "far") + " too long")
    if error > FRAME_SCALE:
        keep = EARTH_RADIUS * math.sqrt(2 * FRAME_SCALE) / 1000
        fix = ("run each city or region on its own (or, if the coordinates are metres, "
               "not degrees, give their CRS with --crs)" if chosen is None else
               f"the centre is {chosen}: give data of one place, or an origin near it")
        raise FarFromFrame(f"{what}; a frame holds data within about {keep:,.0f} km of "
                           f"its centre: {fix}", reach)
    warnings.warn(FarFromFrameWarning(f"{what}: buildings there come out that much too "
                                      "large; run regions this far apart on their own",
                                      reach), stacklevel=4)


def _lonlat_centre(lonlat: Coords) -> tuple[float, float]:
    """The centre of the data's lon/lat box; across the ±180° meridian (a box wider than
    half the globe that is narrow when longitudes are taken in 0..360), the centre of
    the narrow box, so the local frame sits on the data and not on the far side."""
    lo, hi = lonlat.min(axis=0), lonlat.max(axis=0)
    mid_lon = (lo[0] + hi[0]) / 2
    if hi[0] - lo[0] > 180:
        east = lonlat[:, 0] % 360
        if east.max() - east.min() < hi[0] - lo[0]:
            mid_lon = ((east.min() + east.max()) / 2 + 180) % 360 - 180
    return float(mid_lon), float((lo[1] + hi[1]) / 2)


def _extent(coords: Coords) -> Coords:
    """The corners and centre of the coordinates' bounding box."""
    (x0, y0), (x1, y1) = coords.min(axis=0), coords.max(axis=0)
    return np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1], [(x0 + x1) / 2, (y0 + y1) / 2]])


WORLD_MARGIN = 0.5     # degrees of latitude data may stray beyond a world map's limits


def _check_area(given: pyproj.CRS, lonlat: Coords, source: str) -> None:
    """Refuse data beyond the latitudes a world map (a CRS used over all longitudes, such
    as Web Mercator, which stops at 85.06°) is made for: the mark of coordinates in
    another unit (feet given as metres). Regional CRSs are often used well beyond their
    area of use, and one far from the data is handled by reprojecting, so only world
    maps are checked."""
    area = given.area_of_use
    if area is None or not np.isfinite(lonlat).all():
        return
    west, south, east, north = area.bounds
    if west > -179 or east < 179:
        _warn_far_from_area(given, lonlat, source)
        return
    lat = lonlat[:, 1]
    if lat.min() < south - WORLD_MARGIN or lat.max() > north + WORLD_MARGIN:
        at = lonlat[np.argmax(np.abs(lat))]
        raise SkeletonError(
            f"{source}: in {given.name} the data lands at longitude {at[0]:.2f}, latitude "
            f"{at[1]:.2f}, beyond the latitudes that map is made for ({south:g} to "
            f"{north:g}); is the CRS right, and are the coordinates in its unit "
            f"({_unit_name(given)})?")


FAR_FROM_AREA = 10.0   # degrees beyond a regional CRS's area of use: another CRS's data


def _warn_far_from_area(given: pyproj.CRS, lonlat: Coords, source: str) -> None:
    """Warn when data lands far (:data:`FAR_FROM_AREA`) from where a regional CRS is
    made for: UTM 32N coordinates read as Swiss LV95 (EPSG:2056) land in Greenland and
    a 100 m street was built 80 m long, without a word. Use a little beyond the area
    is common and fine (the data is reprojected), so only a far miss is told."""
    area = given.area_of_use
    assert area is not None
    west, south, east, north = area.bounds
    lon, lat = lonlat[-1]          # the centre of the data's box
    if east < west:                # an area across the antimeridian
        east += 360.0
        lon = lon + 360.0 if lon < west else lon
    off = max(west - lon, lon - east, south - lat, lat - north)
    if off > FAR_FROM_AREA:
        warnings.warn(
            f"{source}: in {given.name} the data lands at longitude {lonlat[-1][0]:.2f}, "
            f"latitude {lat:.2f}, {off:.0f}° from where that CRS is made for "
            f"({area.name.rstrip('.')}); lengths read in it may be far off: check that the "
            "CRS is the data's", InputWarning, stacklevel=4)


def _check_not_degrees(allc: Coords, given: pyproj.CRS, source: str, named_by: str
                       ) -> None:
    """Refuse longitude/latitude degrees given a projected CRS: read as its metres, a
    whole district shrinks to centimetres and fails later as zero-length edges or
    polygons of no area. Projected coordinates are never all within ±180, ±90 of their
    CRS's origin (false eastings and northings put it outside the area the CRS is made
    for); a custom CRS with no such area (a local frame) is refused only when the data
    would span less than a metre, which no city does."""
    lo, hi = allc.min(axis=0), allc.max(axis=0)
    span = float((hi - lo).max()) * _unit(given)
    if not in_degrees(*lo, *hi) or (
            given.area_of_use is None and span >= 1.0):
        return
    fix = ("leave --crs out (GeoJSON is lon/lat) or give --crs EPSG:4326"
           if named_by == "--crs" else f"correct {named_by}, or give --crs EPSG:4326")
    name = given.name if given.name != "unknown" else given.to_string()
    raise SkeletonError(
        f"{source}: the coordinates (such as {allc[0, 0]:.6f}, {allc[0, 1]:.6f}) look like "
        f"longitude/latitude degrees, not coordinates of {name} (in {_unit_name(given)}) "
        f"as {named_by} says: all lie within ±180, ±90, and read so the whole input would span "
        f"{span:.2g} m; {fix}")


def _unit_name(crs: pyproj.CRS) -> str:
    return str(crs.axis_info[0].unit_name) if crs.axis_info else "metre"


def _kept_projected(allc: Coords, given: pyproj.CRS, origin: tuple[float, float] | None
                    ) -> tuple[Project, Frame]:
    """A projected CRS true to scale over the data: only moved to a local origin (and
    converted to metres)."""
    lo, hi = allc.min(axis=0), allc.max(axis=0)
    centre = (float((lo[0] + hi[0]) / 2), float((lo[1] + hi[1]) / 2)) if origin is None \
        else (float(origin[0]), float(origin[1]))
    unit = _unit(given)
    shift = np.array(centre)
    return (lambda c: (c - shift) * unit), \
        Frame(kept_crs(given), centre, given.to_string())


_KEPT = re.compile(r"^(?P<name>.*?) \(projected, (?P<id>.+)\)$", re.S)


def crs_id(crs: pyproj.CRS) -> str:
    """What names ``crs`` so that pyproj (and GDAL, QGIS) resolve it: its authority
    code ("EPSG:3067") when one is the same CRS (names aside: PROJ's confidence 90,
    so the ``.prj`` ArcGIS and ogr2ogr write, "EUREF_FIN_TM35FIN", is EPSG:3067; it
    was named by its whole WKT, 1.5 kB in every message and layout), else its WKT on
    one line."""
    auth = crs.to_authority(min_confidence=90)
    return ":".join(auth) if auth else crs.to_wkt()


def kept_crs(crs: pyproj.CRS) -> str:
    """A kept projected frame's CRS as a frame (and a layout's ``frame``) records it:
    its name, for people, and its identifier, for tools
    ("ETRS89 / TM35FIN(E,N) (projected, EPSG:3067)")."""
    return f"{crs.name} (projected, {crs_id(crs)})"


def kept_crs_parts(text: str) -> tuple[str, str] | None:
    """The name and the identifier in a frame's CRS text written by :func:`kept_crs`;
    None for any other (the local transverse Mercator of lon/lat input)."""
    m = _KEPT.match(text)
    return None if m is None else (m["name"], m["id"])


def _into_kept(allc: Coords, given: pyproj.CRS | None, source: str, within: Frame
               ) -> Project:
    """Input in ``given`` (None: lon/lat) into ``within``, a projected CRS kept as it is
    (another file's): moved to its origin, reprojected first when its CRS differs."""
    target = pyproj.CRS.from_user_input(within.source_crs)
    if given is not None and given == target:
        _check_kept_scale(target, allc, within, source)
        return _kept_projected(allc, given, within.origin)[0]
    into = _transform(given or "EPSG:4326", target, source,
                      f"lie outside {target.name}, the CRS the other input is kept in; are "
                      "the two inputs of one place?")
    _check_kept_scale(target, into(allc), within, source)
    shift, unit = np.array(within.origin), _unit(target)
    return lambda c: (into(c) - shift) * unit


def _check_kept_scale(target: pyproj.CRS, coords: Coords, within: Frame, source: str
                      ) -> None:
    """Refuse (past :data:`FRAME_SCALE`) or warn of (past :data:`TRUE_SCALE`) a second
    input lying where the CRS the first is kept in is no longer true to scale, as
    :func:`_check_frame_scale` does in a lon/lat run's frame. Unchecked, footprints
    2,000 km east of EPSG:3067 streets, or Web Mercator numbers read as EPSG:3067
    (``--crs`` over the file's own CRS), were built 4 % to 2x too large, exit 0."""
    error = _scale_error(target, coords)
    if error <= TRUE_SCALE:
        return
    off = np.hypot(*(coords - np.array(within.origin)).T) * _unit(target)
    far = float(off.max()) if np.isfinite(off).all() else math.inf
    reach = f"{far / 1000:,.0f} km" if math.isfinite(far) else "far"
    what = (f"{source}: data reach {reach} from the run's frame centre, where "
            f"{target.name}, the CRS the other input is kept in, gets lengths "
            + (f"{error:.1%}" if error < 1 else "far") + " wrong")
    if error > FRAME_SCALE:
        raise FarFromFrame(f"{what}; are the two inputs of one place? (check that each "
                           "file's CRS is its own: --crs names the CRS of every input)",
                           reach)
    warnings.warn(FarFromFrameWarning(f"{what}: buildings there come out that much off; "
                                      "run regions this far apart on their own", reach),
                  stacklevel=5)


def _to_lonlat(given: pyproj.CRS, source: str) -> Project:
    return _transform(given, "EPSG:4326", source,
                      f"lie outside {given.name}; is the CRS right?")


def _transform(src: pyproj.CRS | str, dst: pyproj.CRS | str, source: str, outside: str
               ) -> Project:
    """Coordinates from ``src`` to ``dst``; a point with no image there is refused,
    named, with ``outside`` saying why."""
    tf = pyproj.Transformer.from_crs(src, dst, always_xy=True)

    def project(c: Coords) -> Coords:
        out = np.column_stack(tf.transform(c[:, 0], c[:, 1]))
        if not np.isfinite(out).all():
            bad = c[~np.isfinite(out).all(axis=1)][0]
            raise SkeletonError(f"{source}: coordinates such as {_num(bad[0])}, "
                                f"{_num(bad[1])} {outside}")
        return out
    return project


def _check_lonlat(allc: Coords, source: str, given: pyproj.CRS | None) -> None:
    lo, hi = allc.min(axis=0), allc.max(axis=0)
    if in_degrees(*lo, *hi):
        return
    if given is not None:
        raise SkeletonError(f"{source}: coordinates in {given.name} land outside "
                            "longitude/latitude; is the CRS right?")
    out = ~in_degrees(allc[:, 0], allc[:, 1])
    x, y = allc[int(np.argmax(out))]      # the first point outside, with the digits
    said = (f"{x:.7g}, {y:.7g}" if abs(x) < 1e4 and abs(y) < 1e4   # that show it is
            else f"{_num(x)}, {_num(y)}")                          # (180.0005, not 180.0)
    raise SkeletonError(
        f"{source}: coordinates such as {said} are not longitude/latitude (RFC 7946); "
        "give the CRS of projected input, e.g. --crs EPSG:25832"
        + ("; a line across the antimeridian is written with longitudes past 180 "
           "negative (from -180)" if 180 < abs(x) < 181 and abs(y) <= 90 else ""))


def _local_tmerc(centre: tuple[float, float]) -> Project:
    """Lon/lat -> metres in a transverse Mercator centred on ``centre``."""
    tf = transformer("EPSG:4326", tmerc_proj4(centre))

    def to_local(c: Coords) -> Coords:
        return np.column_stack(tf.transform(c[:, 0], c[:, 1]))
    return to_local


def angle_between(u: np.ndarray, v: np.ndarray) -> float:
    """Signed turn from direction u to direction v in degrees (left turns positive)."""
    return math.degrees(math.atan2(u[0] * v[1] - u[1] * v[0], u[0] * v[0] + u[1] * v[1]))


def tmerc_proj4(centre: tuple[float, float]) -> str:
    """The local transverse Mercator centred on ``centre`` (lon, lat) a run's frame is."""
    return (f"+proj=tmerc +lat_0={centre[1]} +lon_0={centre[0]} +k=1 +x_0=0 +y_0=0 "
            "+ellps=WGS84 +units=m +no_defs")


@functools.lru_cache(maxsize=16)
def transformer(src: str, dst: str) -> pyproj.Transformer:
    """A transformer between two CRSs, made once: making one takes about 12 ms (PROJ's
    database), and messages place points one by one (a 1,000-block city's street
    blocks took 14 s naming where each was before it was kept)."""
    return pyproj.Transformer.from_crs(src, dst, always_xy=True)


def lonlat_from_local(points: Any, origin: tuple[float, float]) -> list[list[float]]:
    """Local metric points (x east, y north, metres) around ``origin`` (lon, lat) ->
    lon/lat, through the same transverse Mercator the reader uses; for writing example
    and test input in metres. Rounded to 1e-9 degrees (0.1 mm)."""
    tf = transformer(tmerc_proj4(origin), "EPSG:4326")
    xy = np.asarray(points, dtype=float)
    lon, lat = tf.transform(xy[:, 0], xy[:, 1])
    return [[round(float(a), 9), round(float(b), 9)] for a, b in zip(lon, lat, strict=True)]


def input_xy(frame: tuple[str, float, float], source_crs: str, xy: Any) -> tuple[float, float]:
    """A local point in the input's own coordinates (lon/lat, or the projected CRS)."""
    if frame[0] != LONLAT_FRAME:   # kept projected: shifted, and in metres
        unit = _unit(pyproj.CRS.from_user_input(source_crs)) if source_crs else 1.0
        return float(xy[0]) / unit + frame[1], float(xy[1]) / unit + frame[2]
    lon, lat = lonlat_from_local([xy], (frame[1], frame[2]))[0]
    if source_crs:
        x, y = transformer("EPSG:4326", source_crs).transform(lon, lat)
        return float(x), float(y)
    return lon, lat


def box_around(frame: Frame, bounds: tuple[float, float, float, float], crs: str | None
               ) -> tuple[float, float, float, float]:
    """The box, in lon/lat (``crs`` None) or in ``crs``, that holds the local box
    ``bounds`` (metres in ``frame``): its outline, 16 points a side, placed and boxed.
    A shape much larger than the data (a zone of a whole country) is clipped to it
    before it is projected: the run's frame holds the data's reach, not a country's."""
    x0, y0, x1, y1 = bounds
    t = np.linspace(0.0, 1.0, 17)[:-1]
    ring = np.concatenate([np.column_stack([x0 + (x1 - x0) * t, np.full_like(t, y0)]),
                           np.column_stack([np.full_like(t, x1), y0 + (y1 - y0) * t]),
                           np.column_stack([x1 - (x1 - x0) * t, np.full_like(t, y1)]),
                           np.column_stack([np.full_like(t, x0), y1 - (y1 - y0) * t])])
    if frame.crs == LONLAT_FRAME:
        pts = np.array(lonlat_from_local(ring, frame.origin))
    else:   # kept projected: the input's coordinates, then lon/lat
        unit = _unit(pyproj.CRS.from_user_input(frame.source_crs)) if frame.source_crs else 1.0
        pts = ring / unit + np.array(frame.origin)
        if frame.source_crs:
            pts = np.column_stack(transformer(frame.source_crs, "EPSG:4326").transform(
                pts[:, 0], pts[:, 1]))
    if crs is not None:
        pts = np.column_stack(transformer("EPSG:4326", crs).transform(pts[:, 0], pts[:, 1]))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def local_xy(p: tuple[float, float]) -> str:
    """A point in a run's local metres, as messages give it where no frame is known to
    put it in the input's coordinates (:meth:`Frame.at` does)."""
    return f"({p[0]:.1f}, {p[1]:.1f}) m"


def format_xy(p: tuple[float, float]) -> str:
    """A point as messages give it: 6 decimals for lon/lat, 2 (cm) for metres."""
    nd = 6 if in_degrees(*p) else 2
    x, y = (f"{v:.{nd}f}" for v in p)
    return f"({x.removeprefix('-') if float(x) == 0 else x}, " \
        f"{y.removeprefix('-') if float(y) == 0 else y})"   # no "-0.000000"


def side_words(length: float, a: str, b: str) -> str:
    """'the 6.00 m side from (x, y) to (x, y)' (its ends as messages give them); a side
    shorter than their precision (5 cm in lon/lat's 6 decimals) is 'at' its one point,
    not from a point to itself."""
    return f"the {length:.2f} m side " + (f"at {a}" if a == b else f"from {a} to {b}")
