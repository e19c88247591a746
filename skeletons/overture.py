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


# the OSM keys a footprint or street is read by, found whatever their case and spaces
# (ArcGIS writes field names in capitals: HEIGHT, BUILDING_L, ROOF_SHAPE)
KNOWN_KEYS = ("building", "building:levels", "building:min_level", "height", "min_height",
              "roof:shape", "location", "highway", "width", "lanes", "service", "tunnel",
              "railway", "route", *(k for k, _osm in _BUILDING), "is_underground")


def osm_tags(props: dict[str, Any]) -> dict[str, Any]:
    """``props`` with the OSM tags its Overture attributes mean, where it lacks them
    (the same dict when there are none to add); a known key written in other case or
    with spaces round it (``HEIGHT``, ``"building:levels "``) is read as that key."""
    props = _known_keys(props)
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
    under = props.get("is_underground")
    if under is True or (isinstance(under, str) and under.strip().lower() in ("true", "yes", "1")):
        extra["location"] = "underground"     # (a GDAL export may write the bool as text)
    for overture, osm in _BUILDING:
        if props.get(overture) is not None:
            extra[osm] = props[overture]
    extra = {k: v for k, v in extra.items() if k not in props}
    return {**props, **extra} if extra else props


def _known_keys(props: dict[str, Any]) -> dict[str, Any]:
    """``props`` with each of :data:`KNOWN_KEYS` it lacks added from a key that differs
    from it only in case or surrounding spaces (the first such key, in file order)."""
    missing = {k for k in KNOWN_KEYS if k not in props}
    if not missing:
        return props
    extra: dict[str, Any] = {}
    for key, value in props.items():
        if isinstance(key, str):
            plain = key.strip().lower()
            if plain in missing and plain not in extra:
                extra[plain] = value
    return {**props, **extra} if extra else props


def source_key(props: dict[str, Any], key: str) -> str:
    """The key the file gave ``key``'s value under (``min_floor`` for Overture's
    ``building:min_level``, ``HEIGHT`` for ``height``), so a message names the field the
    user can find; ``key`` itself when the file has it."""
    value = props.get(key)
    aliases = [o for o, osm in _BUILDING if osm == key and o in props] + \
        [k for k in props if isinstance(k, str) and k != key and k.strip().lower() == key]
    alias = next((a for a in aliases if props[a] is value), None)
    if alias is None:
        return key
    return source_key(props, alias) if alias == alias.strip().lower() else alias


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
