"""GeoParquet files (what geopandas' ``to_parquet``, DuckDB, QGIS and Overture Maps
write), read through pyarrow as :mod:`.gis_files` reads the formats GDAL knows: the
table becomes the FeatureCollection a GeoJSON export of it would be.

GeoParquet is a Parquet table with a ``geo`` entry in its metadata naming its geometry
columns, their encoding and their CRS (version 1.0 and 1.1 of the specification). The
geometry is the primary column (or the one ``FILE::COLUMN`` names), as WKB or in one of
GeoArrow's native encodings (``point`` ... ``multipolygon``, coordinates as x/y structs
or interleaved); every other column is a property, nested ones (Overture's ``names``,
``bbox``, ``sources``) as JSON objects and lists. The CRS is the column's PROJJSON, as
its authority code where it has one; a column without one is lon/lat (OGC:CRS84), as
the specification says, and one whose CRS is null (unknown) is read as a GeoJSON file
without a ``crs`` member is: lon/lat, or refused with the advice to give ``--crs``.
A Parquet table without ``geo`` metadata but with a binary ``geometry`` (or ``geom``,
``wkb_geometry``) column, as older DuckDB exports are, is read as WKB in lon/lat.
"""

from __future__ import annotations

import datetime as dt
import decimal
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import shapely

from citysynth.skeletons.errors import SkeletonError, cannot_read
from citysynth.solver.safe_read import check_data_size, check_file

FORMAT = "GeoParquet"
WKB_NAMES = ("geometry", "geom", "wkb_geometry", "the_geom")   # columns read as WKB
NATIVE = {   # GeoArrow encoding -> (GeoJSON type, nesting depth of its coordinates)
    "point": ("Point", 0), "linestring": ("LineString", 1), "polygon": ("Polygon", 2),
    "multipoint": ("MultiPoint", 1), "multilinestring": ("MultiLineString", 2),
    "multipolygon": ("MultiPolygon", 3),
}


def read_geoparquet(path: Path, column: str | None) -> dict[str, Any]:
    """The GeoParquet file at ``path`` as a GeoJSON FeatureCollection (a dict): the
    geometry column ``column`` (by default the primary one), the others as properties."""
    # Arrow's own allocator (jemalloc or mimalloc) reserves gigabytes of address space
    # up front: under a memory limit (ulimit -v 3 GB) the USD writer's allocations then
    # failed and the process died of a segmentation fault, leaving half a run behind.
    # The C library's allocator reserves what it uses. Read once, before Arrow's pool.
    os.environ.setdefault("ARROW_DEFAULT_MEMORY_POOL", "system")
    import pyarrow as pa  # loaded only when such a file is given
    import pyarrow.parquet as pq

    check_file(path, FORMAT, SkeletonError)
    unreadable = (pa.ArrowException, OSError, ValueError)
    try:
        parquet = pq.ParquetFile(path)
    except unreadable as exc:
        raise _cannot_read(path, exc) from None
    _check_size(path, parquet, pq, unreadable)
    try:
        table = parquet.read()
    except unreadable as exc:
        raise _cannot_read(path, exc) from None
    geo = _geo_metadata(path, table.schema.metadata or {})
    name = _geometry_column(path, table, geo, column)
    meta = geo.get("columns", {}).get(name, {}) if geo else {}
    if not isinstance(meta, dict):
        meta = {}
    encoding = str(meta.get("encoding", "WKB")).lower()
    geometries = _geometries(path, table.column(name), encoding)
    skip = set(geo.get("columns", {})) if geo else {name}
    names = [n for n in table.column_names if n not in skip and n != name]
    columns = [[json_value(v) for v in table.column(n).to_pylist()] for n in names]
    features = []
    for i, geometry in enumerate(geometries):
        props = {k: col[i] for k, col in zip(names, columns, strict=True)
                 if col[i] is not None}
        features.append({"type": "Feature", "properties": props, "geometry": geometry})
    if not features:
        raise SkeletonError(f"{path}: this {FORMAT} has no rows; export the layer with its "
                            "features, or leave the file out")
    data: dict[str, Any] = {"type": "FeatureCollection", "features": features}
    crs = _crs_name(path, name, meta) if geo else None
    if crs is not None:
        data["crs"] = {"type": "name", "properties": {"name": crs}}
    return data


def _cannot_read(path: Path, exc: Exception) -> SkeletonError:
    detail = " ".join(str(exc).split())[:200]
    return cannot_read(path, FORMAT, detail)


def _check_size(path: Path, parquet, pq, unreadable: tuple[type[Exception], ...]) -> None:
    """Refuse a table whose data, written out, is past the input size limit, before it
    is: Parquet compresses several times over, and stores a repeated text or WKB once
    in a dictionary, so a file of a few kB can hold gigabytes (its rows become Python
    objects as a GeoJSON file's do). In three steps, each cheap: cells (a count of
    rows of cells of 8 bytes at least), the data as stored uncompressed, then the data
    with every dictionary written out, measured on a read that keeps the dictionaries
    (text and binary columns, nested ones too)."""
    metadata = parquet.metadata
    cells = metadata.num_rows * max(metadata.num_columns, 1) * 8
    raw = sum(metadata.row_group(i).total_byte_size for i in range(metadata.num_row_groups))
    _refuse_past_limit(path, max(cells, raw), "uncompressed")
    texts = [metadata.schema.column(j).path for j in range(metadata.num_columns)
             if metadata.schema.column(j).physical_type == "BYTE_ARRAY"]
    if not texts:
        return
    try:
        kept = pq.ParquetFile(path, read_dictionary=texts).read()
    except unreadable as exc:
        raise _cannot_read(path, exc) from None
    _refuse_past_limit(path, sum(_written_out(c) for c in kept.columns),
                       "with its repeated values written out")


def _refuse_past_limit(path: Path, size: int, how: str) -> None:
    check_data_size(path, size, how, "keep the area you build (e.g. ogr2ogr -spat, or "
                    "DuckDB with a bounding box)", SkeletonError)


def _written_out(array) -> int:
    """The bytes of an Arrow array (or chunked array) with its dictionaries written
    out: a dictionary-encoded value counts once per row that refers to it."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if isinstance(array, pa.ChunkedArray):
        return sum(_written_out(chunk) for chunk in array.chunks)
    kind = array.type
    if pa.types.is_dictionary(kind):
        values = kind.value_type
        if not any(test(values) for test in (pa.types.is_string, pa.types.is_binary,
                                             pa.types.is_large_string,
                                             pa.types.is_large_binary)):
            return 8 * len(array)   # numbers (a pandas category): counted as cells
        lengths = pc.binary_length(array.dictionary)
        return int(pc.sum(pc.take(lengths, array.indices)).as_py() or 0) + 8 * len(array)
    if pa.types.is_struct(kind):
        return sum(_written_out(array.field(i)) for i in range(kind.num_fields)) + len(array)
    if pa.types.is_map(kind):
        return _written_out(array.keys) + _written_out(array.items) + 8 * len(array)
    if pa.types.is_list(kind) or pa.types.is_large_list(kind) or \
            pa.types.is_fixed_size_list(kind):
        return _written_out(array.flatten()) + 8 * len(array)
    return int(array.nbytes)


def _geo_metadata(path: Path, metadata: dict[bytes, bytes]) -> dict[str, Any] | None:
    raw = metadata.get(b"geo")
    if raw is None:
        return None
    try:
        geo = json.loads(raw)
    except ValueError:
        geo = None
    if not isinstance(geo, dict) or not isinstance(geo.get("columns", {}), dict):
        raise SkeletonError(f"{path}: its \"geo\" metadata is not GeoParquet's (a JSON "
                            "object naming the geometry columns); write it again with "
                            "geopandas' to_parquet or ogr2ogr, or export it as GeoJSON")
    return geo


def _geometry_column(path: Path, table, geo: dict[str, Any] | None, column: str | None
                     ) -> str:
    """The geometry column to read: the one named, else the primary one (or, without
    GeoParquet metadata, the first binary column of a usual geometry name)."""
    declared = list(geo.get("columns", {})) if geo else [
        n for n in WKB_NAMES if n in table.column_names and _binary(table.schema.field(n).type)]
    listed = ", ".join(declared) or "none"
    if column is not None:
        if column not in declared:
            raise SkeletonError(f"{path}: no geometry column {column!r}; its geometry "
                                f"columns are {listed}")
        return column
    primary = geo.get("primary_column") if geo else None
    if isinstance(primary, str) and primary in table.column_names:
        return primary
    if declared and declared[0] in table.column_names:
        return declared[0]
    named = primary if isinstance(primary, str) else (declared or [None])[0]
    if named is not None:
        raise SkeletonError(f"{path}: its \"geo\" metadata names geometry column "
                            f"{named!r}, which the table does not hold; write the file "
                            "again, or export it as GeoJSON")
    raise SkeletonError(f"{path}: a Parquet table with no geometry column (no GeoParquet "
                        "\"geo\" metadata, no binary \"geometry\" column); write it with "
                        "geopandas' to_parquet, or export it as GeoJSON")


def _binary(kind) -> bool:
    """Whether an Arrow type holds bytes (WKB)."""
    import pyarrow as pa

    return bool(pa.types.is_binary(kind) or pa.types.is_large_binary(kind))


def _geometries(path: Path, column, encoding: str) -> list[dict[str, Any] | None]:
    """Each row's geometry as a GeoJSON geometry (2D), None where it has none."""
    if encoding == "wkb":
        if not _binary(column.type):
            raise SkeletonError(f"{path}: the geometry column is said to be WKB but holds "
                                f"{column.type}; write the file again, or export it as "
                                "GeoJSON")
        wkb = np.array(column.to_pylist(), dtype=object)
        return geojson_geometries(shapely.force_2d(shapely.from_wkb(wkb, on_invalid="ignore")))
    if encoding not in NATIVE:
        raise SkeletonError(f"{path}: geometry encoding {encoding!r} is not one GeoParquet "
                            f"defines (WKB, {', '.join(NATIVE)}); write the file again, or "
                            "export it as GeoJSON")
    kind, depth = NATIVE[encoding]
    out = []
    for i, value in enumerate(column.to_pylist()):
        try:
            coords = _native(value, depth)
        except TypeError:
            raise SkeletonError(f"{path}: row {i}: its geometry is not a {kind} as GeoArrow "
                                f"lays one out ({encoding} encoding: coordinates {depth} "
                                "lists deep, each an x/y struct or [x, y]); write the file "
                                "again, or export it as GeoJSON") from None
        out.append(None if coords is None or coords == [] else
                   {"type": kind, "coordinates": coords})
    return out


def geojson_geometries(geoms: np.ndarray) -> list[dict[str, Any] | None]:
    """Shapely geometries as GeoJSON geometries (lists, as a GeoJSON file holds them),
    None for a missing or empty one: how every reader of another format hands its
    geometries to the GeoJSON reader."""
    texts = shapely.to_geojson(geoms)
    return [None if g is None or g.is_empty else json.loads(t)
            for g, t in zip(geoms, texts, strict=True)]


def _native(value: Any, depth: int) -> Any:
    """GeoArrow's nested coordinates (x/y structs or [x, y, ...] lists at ``depth``
    list levels down) as GeoJSON's, in 2D; None for a null. TypeError where the value
    is not nested so."""
    if value is None:
        return None
    if depth == 0:
        if isinstance(value, dict):
            return [value.get("x"), value.get("y")]
        if isinstance(value, list) and len(value) >= 2:
            return value[:2]
        raise TypeError(value)
    if not isinstance(value, list):
        raise TypeError(value)
    return [c for c in (_native(v, depth - 1) for v in value) if c is not None]


def _crs_name(path: Path, column: str, meta: dict[str, Any]) -> str | None:
    """The CRS of the geometry column as a name the GeoJSON reader takes (its authority
    code, else its WKT); None for lon/lat (no ``crs`` key: OGC:CRS84) or unknown (null)."""
    if "crs" not in meta or meta["crs"] is None:
        return None
    crs = meta["crs"]
    try:
        parsed = pyproj.CRS.from_json_dict(crs) if isinstance(crs, dict) else \
            pyproj.CRS.from_user_input(str(crs))
    except (pyproj.exceptions.CRSError, TypeError, ValueError):
        raise SkeletonError(f"{path}: cannot read the CRS of geometry column {column!r}; "
                            "give the CRS with --crs, e.g. --crs EPSG:25832") from None
    from citysynth.skeletons.geojson import crs_id  # (geojson reads this module)
    return crs_id(parsed)


def json_value(v: Any) -> Any:
    """A value as JSON would hold it: Python numbers and text, None for missing (NaN,
    NaT, null), dates as ISO text, durations in seconds, bytes as hex, decimals as
    floats; lists and objects likewise, element by element. An infinity stays one, as
    JSON's 1e400 reads: no missing value but one no building has, which a note tells
    (a GeoPackage's building:levels of inf was dropped without a word)."""
    if isinstance(v, float) and math.isnan(v):
        return None
    if isinstance(v, dt.date | dt.datetime | dt.time):
        return v.isoformat()
    if isinstance(v, dt.timedelta):
        return v.total_seconds()
    if isinstance(v, bytes):
        return v.hex()
    if isinstance(v, decimal.Decimal):
        return json_value(float(v))
    if isinstance(v, dict):
        return {str(k): json_value(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [json_value(x) for x in v]
    if isinstance(v, np.ndarray):   # GDAL's list fields (GML's StringList)
        return [json_value(x) for x in v.tolist()]
    if isinstance(v, np.generic):
        return json_value(v.item())
    return v
