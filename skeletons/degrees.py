"""Whether coordinates read as longitude/latitude degrees.

Projected coordinates (metres, feet) are never all within ±180, ±90 of their CRS's
origin, so this range alone tells lon/lat input from projected input wherever no CRS
says which: the frame, zone polygons, city.toml's origin, the diff maps and the way
messages print a point all ask it. One predicate, so that they cannot disagree at
the edges (each once wrote its own test).
"""

from __future__ import annotations

from typing import Any


def in_degrees(x0: Any, y0: Any, x1: Any = None, y1: Any = None) -> Any:
    """Whether the point (x0, y0), or the box from (x0, y0) to (x1, y1), lies within
    longitude ±180, latitude ±90. Takes numbers, or numpy arrays elementwise (then
    returns a boolean array)."""
    x1 = x0 if x1 is None else x1
    y1 = y0 if y1 is None else y1
    return (-180 <= x0) & (x1 <= 180) & (-90 <= y0) & (y1 <= 90)
