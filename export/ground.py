"""What ground a mesh covers seen from above: the union of its faces projected on the
plan. The 3D audit measures instances by it, and the roof infill
(:mod:`citysynth.export.infill`) fills what the parts leave open by it, so both see
the same plan."""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

FOOTPRINT_NZ = 0.05    # faces steeper than this project to nothing useful in plan
GRID = 1e-4            # m: overlay precision (robust unions of many small triangles)


def triangle_normals(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals of triangles [t, 3, 3], and which have any area (the others' stay
    zero)."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 1e-12
    n[ok] /= area2[ok, None]
    return n, ok


def footprint(tris: np.ndarray) -> BaseGeometry:
    """The plan of an instance: the union of its non-vertical faces projected on XY."""
    n, ok = triangle_normals(tris)
    keep = ok & (np.abs(n[:, 2]) > FOOTPRINT_NZ)
    polys = shapely.make_valid(shapely.polygons(tris[keep][:, :, :2]))
    try:
        return shapely.union_all(polys, grid_size=GRID)
    except shapely.errors.GEOSException:   # snapping slivers of a cut can tangle a ring
        return shapely.union_all(polys)


def polygons_in(geom: BaseGeometry) -> list[shapely.Polygon]:
    """The polygons of a geometry with area, however nested (what ``make_valid`` or a
    difference returns: a polygon, a multipolygon, a collection of them and lines; a
    snapped overlay refuses the lines)."""
    return [g for part in shapely.get_parts(geom) for g in shapely.get_parts(part)
            if g.geom_type == "Polygon" and g.area > 0]
