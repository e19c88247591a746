"""Overture Maps' attributes read as the OpenStreetMap tags they mean.

Overture's transportation ``segment`` features (``subtype`` "road") name their street
class ``class`` with OSM's highway vocabulary (primary, residential, footway, ...), a
driveway or parking aisle as ``subclass``, and a road in a tunnel by its ``road_flags``;
a rail segment's class is OSM's ``railway`` (tram, subway, standard_gauge, ...), a
water segment is a ferry route. Its ``building`` features give ``num_floors``,
``min_floor``, ``roof_shape`` and ``is_underground`` where OSM has ``building:levels``,
``building:min_level``, ``roof:shape`` and ``location=underground`` (``min_height`` is
the same in both), and its ``class`` is OSM's ``building`` value (a canopy's ``roof``
read as ``building=roof``). So are the names GDAL's writers make of OSM's keys,
which hold a ``:`` few formats allow in a field name: ``building_levels`` (GML,
MapInfo, a File Geodatabase), ``building_l`` (a Shapefile's ten characters) and
``roof_shape``; a Shapefile export of OSM buildings lost its storeys without a word.
Read once, where a feature's properties are read (:func:`.geojson.parse_geojson`), so
the setbacks, the not-a-street rules, zones by highway class and storeys by levels all
work on an Overture download (GeoParquet, GeoJSON or GeoJSON sequence) as on an OSM
export. A tag the feature has itself is never replaced.
"""

from __future__ import annotations

from typing import Any

SERVICE = ("driveway", "parking_aisle", "alley", "drive_through")   # subclass -> service=
_BUILDING = (("num_floors", "building:levels"), ("roof_shape", "roof:shape"),
             ("min_floor", "building:min_level"),
             ("building_levels", "building:levels"), ("building_l", "building:levels"))


def osm_tags(props: dict[str, Any]) -> dict[str, Any]:
    """``props`` with the OSM tags its Overture attributes mean, where it lacks them
    (the same dict when there are none to add)."""
    extra: dict[str, Any] = {}
    kind, cls = props.get("subtype"), props.get("class")
    if kind == "road" and isinstance(cls, str):
        extra["highway"] = cls
        sub = props.get("subclass")
        if isinstance(sub, str) and sub in SERVICE:
            extra["service"] = sub.replace("drive_through", "drive-through")
        if _flagged_throughout(props.get("road_flags"), "is_tunnel"):
            extra["tunnel"] = "yes"
    elif kind == "rail" and isinstance(cls, str):
        extra["railway"] = cls
    elif kind == "water":
        extra["route"] = "ferry"
    elif cls == "roof":      # a building's class, OSM's building value: a canopy
        extra["building"] = "roof"
    if props.get("is_underground") is True:
        extra["location"] = "underground"
    for overture, osm in _BUILDING:
        if props.get(overture) is not None:
            extra[osm] = props[overture]
    extra = {k: v for k, v in extra.items() if k not in props}
    return {**props, **extra} if extra else props


def _flagged_throughout(flags: Any, flag: str) -> bool:
    """Whether Overture's ``road_flags`` (a list of ``{values, between}``) give ``flag``
    over the whole segment (``between`` null, or 0 to 1), not over a stretch of it."""
    if not isinstance(flags, list):
        return False
    for rule in flags:
        if not isinstance(rule, dict) or flag not in (rule.get("values") or ()):
            continue
        between = rule.get("between")
        if between is None or (isinstance(between, list) and len(between) == 2
                               and between[0] <= 0 and between[1] >= 1):
            return True
    return False
