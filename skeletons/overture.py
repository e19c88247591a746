"""Overture Maps' attributes read as the OpenStreetMap tags they mean.

Overture's transportation ``segment`` features (``subtype`` "road") name their street
class ``class`` with OSM's highway vocabulary (primary, residential, footway, ...) and
a driveway or parking aisle as ``subclass``; its ``building`` features give
``num_floors`` and ``roof_shape`` where OSM has ``building:levels`` and ``roof:shape``.
Read once, where a feature's properties are read (:func:`.geojson.parse_geojson`), so
the setbacks, the not-a-street rules, zones by highway class and storeys by levels all
work on an Overture download (GeoParquet, GeoJSON or GeoJSON sequence) as on an OSM
export. A tag the feature has itself is never replaced.
"""

from __future__ import annotations

from typing import Any

SERVICE = ("driveway", "parking_aisle", "alley", "drive_through")   # subclass -> service=
_BUILDING = (("num_floors", "building:levels"), ("roof_shape", "roof:shape"))


def osm_tags(props: dict[str, Any]) -> dict[str, Any]:
    """``props`` with the OSM tags its Overture attributes mean, where it lacks them
    (the same dict when there are none to add)."""
    extra: dict[str, Any] = {}
    if props.get("subtype") == "road" and isinstance(props.get("class"), str):
        extra["highway"] = props["class"]
        sub = props.get("subclass")
        if isinstance(sub, str) and sub in SERVICE:
            extra["service"] = sub.replace("drive_through", "drive-through")
    for overture, osm in _BUILDING:
        if props.get(overture) is not None:
            extra[osm] = props[overture]
    extra = {k: v for k, v in extra.items() if k not in props}
    return {**props, **extra} if extra else props
