"""Tower parts of the sample library: ground floors, floors and roofs that stack along +Z.

Each is one closed body of stacked slices (slab, columns, parapet, plant room; see
:func:`parts_db.sample_sweep.stack`) plus its glazing as a window body and, on a ground
floor, a door, so no two bodies overlap and no faces are doubled.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon

from citysynth.parts_db.sample_mesh import PartMesh
from citysynth.parts_db.sample_sweep import UP, stack

PALETTE = {"walls": (110, 115, 120), "trim": (200, 200, 196), "roof": (150, 150, 146),
           "window": (70, 95, 120), "door": (40, 40, 40), "balcony": (150, 150, 150)}
Z_FRAME = (np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), UP.copy())


def _rect(x0: float, x1: float, y0: float, y1: float) -> Polygon:
    return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def _regular(n: int, r: float) -> Polygon:
    return Polygon([(round(r * math.cos(a), 6), round(r * math.sin(a), 6))
                    for a in np.linspace(0, 2 * math.pi, n + 1)[:-1]])


FOOTPRINTS: dict[str, Polygon] = {
    "square18": _rect(-9, 9, -9, 9),
    "rect22x16": _rect(-11, 11, -8, 8),
    "octagon20": Polygon([(-10, -4), (-4, -10), (4, -10), (10, -4), (10, 4), (4, 10),
                          (-4, 10), (-10, 4)]),
    "cross20": shapely.normalize(_rect(-10, 10, -5, 5).union(_rect(-5, 5, -10, 10))),
    "round16": _regular(16, 10),
    "lshape": shapely.normalize(_rect(-10, 10, -10, 0).union(_rect(-10, 0, 0, 10))),
    "hexagon": _regular(6, 10),
    "square14": _rect(-7, 7, -7, 7),
    "chamfer16": Polygon([(-8, -6), (-6, -8), (6, -8), (8, -6), (8, 6), (6, 8), (-6, 8),
                          (-8, 6)]),
    "rect12x18": _rect(-6, 6, -9, 9),
    "slim10": _rect(-5, 5, -7, 7),
}


def _columns(fp: Polygon) -> MultiPolygon:
    """A column at every corner of the outline, inside it (clear of the glazing)."""
    cols = []
    for x, y in list(fp.exterior.coords)[:-1]:
        c = _rect(x - 0.25, x + 0.25, y - 0.25, y + 0.25).intersection(fp)
        if isinstance(c, Polygon) and c.area > 0.01:
            cols.append(shapely.set_precision(c, 1e-6))
    return MultiPolygon(cols)


def _glass(pm: PartMesh, fp: Polygon, z0: float, z1: float) -> None:
    body = pm.item("window")
    stack(body, [(z0, z1, fp.buffer(-0.4, join_style="mitre"))], Z_FRAME,
          lambda _k, _e: "window")


def floor_part(fp: Polygon, h: float) -> PartMesh:
    """A glazed floor: slab, corner columns, a glass wall set 0.4 m in."""
    pm = PartMesh(PALETTE)
    stack(pm.solid(), [(0.0, 0.3, fp), (0.3, h, _columns(fp))], Z_FRAME,
          lambda k, _e: "trim" if k == 0 else "walls")
    _glass(pm, fp, 0.3, h)
    return pm


PODIUM = 1.0   # metres the ground floor's podium reaches past the tower: an 18 m tower's
#                podium fills a 20 m square lot (400 m², the lot of the paper's Fig. 4)


def ground_floor(fp: Polygon, h: float) -> PartMesh:
    """A floor on a podium ``PODIUM`` wider than the tower, with an entrance door."""
    pm = PartMesh(PALETTE)
    podium = fp.buffer(PODIUM, join_style="mitre")
    stack(pm.solid(), [(0.0, 0.25, podium), (0.25, 0.3, fp), (0.3, h, _columns(fp))],
          Z_FRAME, lambda k, _e: "trim" if k < 2 else "walls")
    _glass(pm, fp, 0.3, h)
    minx, miny, maxx, _ = fp.bounds
    cx = (minx + maxx) / 2
    door = pm.item("door")
    door.box([cx - 1.5, miny + 0.25, 0.3], (np.eye(3)[0], np.eye(3)[1], UP),
             (3.0, 0.1, 2.7), "door")
    return pm


def roof_part(fp: Polygon, kind: int) -> PartMesh:
    """A roof slab with a parapet and a plant room (the outline shrunk, or its
    rectangle for ``kind`` 1)."""
    pm = PartMesh(PALETTE)
    ring = fp.difference(fp.buffer(-0.35, join_style="mitre"))
    core = fp.buffer(-3.5, join_style="mitre")
    if kind and not core.is_empty:
        core = core.minimum_rotated_rectangle.buffer(-1, join_style="mitre")
    core = shapely.set_precision(core, 1e-6)
    top = 3.0 + kind
    layers = [(0.0, 0.5, fp), (0.5, 1.6, shapely.union(ring, core)), (1.6, top, core)]
    stack(pm.solid(), layers, Z_FRAME,
          lambda k, _e: ("roof", "trim", "walls")[k])
    return pm


# (outline, storey height): the ground floors (the slender square14 too, so a slim tower
# on a small lot has a base), the floors of every outline and height, and the roofs
GROUNDS = (("square18", 4.6), ("rect22x16", 4.8), ("octagon20", 5.0), ("square14", 4.4))
FLOORS = tuple(zip(FOOTPRINTS, (3.0, 3.2, 3.4, 3.6, 3.8, 4.0, 4.2, 4.4, 4.6, 4.8, 5.0),
                   strict=True))
ROOFS = (("square18", 0), ("octagon20", 1), ("square14", 0), ("slim10", 0), ("chamfer16", 1))


def tower_parts() -> Iterator[tuple[str, str, PartMesh]]:
    """(id, class, mesh) of every tower part, in manifest order. On a 400 m² square lot
    they reach floor-area ratios from below 10 to above 20 at 120 m (the paper's
    Fig. 4; ``tests/test_tower.py``)."""
    for name, h in GROUNDS:
        yield f"tower_ground_{name}", "ground_floor", ground_floor(FOOTPRINTS[name], h)
    for name, h in FLOORS:
        yield f"tower_floor_{name}_{h:.1f}", "floor", floor_part(FOOTPRINTS[name], h)
    for name, kind in ROOFS:
        yield f"tower_roof_{name}", "roof", roof_part(FOOTPRINTS[name], kind)
