"""Reading GeoJSON into a local metric frame.

Input is RFC 7946 GeoJSON: longitude/latitude on WGS 84. It is projected with pyproj
to a transverse Mercator centred on the data, so distances and angles are true to a
millimetre over a district. Input already in a projected CRS is accepted when the
CRS is given explicitly (the ``crs`` argument, or the legacy ``"crs"`` member of the
file); its coordinates are only moved to a local origin. Errors name the file and the
feature.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import shapely
from shapely.geometry import shape
from shapely.geometry.base import BaseGeometry

from citysynth.skeletons.errors import SkeletonError


@dataclass(frozen=True)
class Feature:
    index: int
    geometry: BaseGeometry      # in the local metric frame (metres)
    properties: dict[str, Any]

    @property
    def name(self) -> str:
        fid = self.properties.get("id", self.properties.get("name"))
        return f"feature {self.index}" + (f" ({fid})" if fid is not None else "")


@dataclass(frozen=True)
class Frame:
    """How local metres relate to the input: the CRS and the local origin."""

    crs: str
    origin: tuple[float, float]   # input coordinates of the local (0, 0)

    def describe(self) -> str:
        return f"{self.crs}, origin {self.origin[0]:.6f}, {self.origin[1]:.6f}"


def read_geojson(path: str | Path, crs: str | None = None,
                 origin: tuple[float, float] | None = None, origin_digits: int | None = None
                 ) -> tuple[list[Feature], Frame]:
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise SkeletonError(f"{p}: cannot read ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise SkeletonError(f"{p}: not valid JSON at line {exc.lineno}, column {exc.colno}: "
                            f"{exc.msg}") from None
    return parse_geojson(data, str(p), crs, origin, origin_digits)


def parse_geojson(data: Any, source: str = "input", crs: str | None = None,
                  origin: tuple[float, float] | None = None, origin_digits: int | None = None
                  ) -> tuple[list[Feature], Frame]:
    """Features in a local metric frame centred on the data's bounding box, or on
    ``origin`` (input coordinates) so that several files share one frame. With
    ``origin_digits``, a lon/lat centre is rounded to that many decimals (2: about
    1 km), so that edits at the edge of the data do not move the frame."""
    if not isinstance(data, dict) or data.get("type") not in ("FeatureCollection", "Feature"):
        raise SkeletonError(f"{source}: not a GeoJSON FeatureCollection or Feature")
    raw = data.get("features") if data["type"] == "FeatureCollection" else [data]
    if not isinstance(raw, list) or not raw:
        raise SkeletonError(f"{source}: no features")
    if crs is None:
        member = data.get("crs")
        if isinstance(member, dict):
            crs = (member.get("properties") or {}).get("name")
    geoms, props = [], []
    for i, f in enumerate(raw):
        if not isinstance(f, dict) or f.get("type") != "Feature" or "geometry" not in f:
            raise SkeletonError(f"{source}: feature {i} is not a GeoJSON Feature")
        try:
            g = shape(f["geometry"])
        except Exception as exc:  # shapely raises several kinds for malformed geometry
            raise SkeletonError(f"{source}: feature {i}: malformed geometry ({exc})") from None
        coords = shapely.get_coordinates(g)
        if len(coords) == 0 or not np.isfinite(coords).all():
            raise SkeletonError(f"{source}: feature {i}: empty or non-finite coordinates")
        geoms.append(g)
        props.append(dict(f.get("properties") or {}))
    allc = np.vstack([shapely.get_coordinates(g) for g in geoms])
    lo, hi = allc.min(axis=0), allc.max(axis=0)
    centre = (float((lo[0] + hi[0]) / 2), float((lo[1] + hi[1]) / 2)) if origin is None \
        else (float(origin[0]), float(origin[1]))
    if origin is None and crs is None and origin_digits is not None:
        centre = (round(centre[0], origin_digits), round(centre[1], origin_digits))
    if crs is None:
        if not (-180 <= lo[0] and hi[0] <= 180 and -90 <= lo[1] and hi[1] <= 90):
            raise SkeletonError(
                f"{source}: coordinates such as {allc[0, 0]:.1f}, {allc[0, 1]:.1f} are not "
                "longitude/latitude (RFC 7946); give the CRS of projected input, e.g. "
                "--crs EPSG:25832")
        local = pyproj.CRS.from_proj4(
            f"+proj=tmerc +lat_0={centre[1]} +lon_0={centre[0]} +k=1 +x_0=0 +y_0=0 "
            "+ellps=WGS84 +units=m +no_defs")
        tf = pyproj.Transformer.from_crs("EPSG:4326", local, always_xy=True)
        frame = Frame("WGS 84 lon/lat, local transverse Mercator", centre)

        def project(x, y):
            return tf.transform(x, y)
    else:
        try:
            given = pyproj.CRS.from_user_input(crs)
        except pyproj.exceptions.CRSError:
            raise SkeletonError(f"{source}: unknown CRS {crs!r}") from None
        if given.is_geographic:
            raise SkeletonError(f"{source}: CRS {crs} is geographic; leave it out for "
                                "lon/lat input, or give a projected CRS")
        unit = given.axis_info[0].unit_conversion_factor if given.axis_info else 1.0
        frame = Frame(f"{given.name} (projected)", centre)

        def project(x, y):
            return (np.asarray(x) - centre[0]) * unit, (np.asarray(y) - centre[1]) * unit
    feats = []
    for i, (g, pr) in enumerate(zip(geoms, props, strict=True)):
        local_g = shapely.transform(g, lambda c: np.column_stack(project(c[:, 0], c[:, 1])))
        feats.append(Feature(i, local_g, pr))
    return feats, frame


def angle_between(u: np.ndarray, v: np.ndarray) -> float:
    """Signed turn from direction u to direction v in degrees (left turns positive)."""
    return math.degrees(math.atan2(u[0] * v[1] - u[1] * v[0], u[0] * v[0] + u[1] * v[1]))


def lonlat_from_local(points, origin: tuple[float, float]) -> list[list[float]]:
    """Local metric points (x east, y north, metres) around ``origin`` (lon, lat) ->
    lon/lat, through the same transverse Mercator the reader uses; for writing example
    and test input in metres. Rounded to 1e-9 degrees (0.1 mm)."""
    local = pyproj.CRS.from_proj4(
        f"+proj=tmerc +lat_0={origin[1]} +lon_0={origin[0]} +k=1 +x_0=0 +y_0=0 "
        "+ellps=WGS84 +units=m +no_defs")
    tf = pyproj.Transformer.from_crs(local, "EPSG:4326", always_xy=True)
    xy = np.asarray(points, dtype=float)
    lon, lat = tf.transform(xy[:, 0], xy[:, 1])
    return [[round(float(a), 9), round(float(b), 9)] for a, b in zip(lon, lat, strict=True)]
