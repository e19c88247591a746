"""What every writer shares about looks and place: the library's materials (one per
kind of sub-mesh and colour, named the same in USD and glTF so a DCC shows one
material per library material) with their colours in linear space, and the layout
frame's georeference.

A part mesh's colours are sRGB bytes (what a modeller paints and a glTF vertex colour
or a PNG holds); USD's ``displayColor`` and ``UsdPreviewSurface`` inputs and glTF's
``baseColorFactor`` are linear, so they take the colour through the sRGB transfer
function's inverse (IEC 61966-2-1).
"""

from __future__ import annotations

import math
import re
from functools import lru_cache
from typing import Any

from citysynth.parts_db.geometry import Piece
from citysynth.skeletons.geojson import LONLAT_FRAME, kept_crs_parts

_FRAME = re.compile(r"^(?P<crs>.*), origin (?P<x>-?[\d.]+), (?P<y>-?[\d.]+)(?P<rest>.*)$")


def srgb_to_linear(byte: int) -> float:
    """An sRGB channel byte (0-255) as a linear value in [0, 1]."""
    c = byte / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def linear_rgb(piece: Piece) -> tuple[float, float, float]:
    """The piece's colour in linear space, rounded so files stay byte-stable."""
    return rgba_linear(piece.rgba)


def rgba_linear(rgba: tuple[int, ...]) -> tuple[float, float, float]:
    """An sRGB colour's (bytes) red, green and blue in linear space, rounded so files
    stay byte-stable."""
    r, g, b = (round(srgb_to_linear(c), 6) for c in rgba[:3])
    return r, g, b


def opacity(piece: Piece) -> float:
    return round(piece.rgba[3] / 255.0, 6)


def material_name(piece: Piece) -> str:
    """The library material a piece shows: its kind and sRGB colour ("walls_e4e4de";
    "_80" more for a translucent one's alpha), a valid identifier in USD and glTF."""
    r, g, b, a = piece.rgba
    name = f"{piece.name}_{r:02x}{g:02x}{b:02x}"
    return name if a == 255 else f"{name}_{a:02x}"


def glass(piece: Piece) -> bool:
    return piece.name.startswith("window")


def roughness(piece: Piece) -> float:
    return 0.15 if glass(piece) else 0.8


def georeference(frame: str) -> dict[str, Any]:
    """The layout frame's description ("<CRS>, origin <x>, <y>[ ...]", as a layout
    records it) as data: the CRS, the origin in it and the origin's longitude and
    latitude. Empty when the frame names no origin (a layout built in plain local
    metres).

    For a projected CRS kept as it is, ``crs`` is its identifier (an authority code
    such as "EPSG:3067", or its WKT when it has none), which pyproj, GDAL and QGIS
    resolve, and ``crs_name`` its name. The transformer to lon/lat is built once per
    CRS (:func:`_lonlat_transformer`), not once per layer written."""
    m = _FRAME.match(frame)
    if m is None:
        return {}
    out: dict[str, Any] = {"crs": m["crs"], "origin": [float(m["x"]), float(m["y"])]}
    if m["crs"] == LONLAT_FRAME:
        out["origin_lon"], out["origin_lat"] = out["origin"]
        return out
    kept = kept_crs_parts(m["crs"])
    if kept is not None:
        out["crs"], out["crs_name"] = kept[1], kept[0]
    lonlat = _to_lonlat(out["crs"], out["origin"])
    if lonlat is not None:
        out["origin_lon"], out["origin_lat"] = lonlat
    return out


def _to_lonlat(crs: str, xy: list[float]) -> tuple[float, float] | None:
    """A projected origin as lon/lat (rounded to 1e-7 degrees, about 1 cm), or None
    when pyproj does not know the CRS."""
    tf = _lonlat_transformer(crs)
    if tf is None:
        return None
    lon, lat = tf.transform(xy[0], xy[1])
    if not (math.isfinite(lon) and math.isfinite(lat)):
        return None
    return round(float(lon), 7), round(float(lat), 7)


@lru_cache(maxsize=16)
def _lonlat_transformer(crs: str) -> Any:
    """pyproj's transformer from ``crs`` (any text pyproj resolves) to lon/lat, or None
    when it resolves none; made once per CRS and process (a city writes a layer per
    block in one frame, and building one from a CRS's name, a search of PROJ's
    database, took 0.2-0.6 s)."""
    import pyproj

    try:
        return pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    except pyproj.exceptions.ProjError:     # CRSError among them
        return None
