"""Planar cross-sections of part meshes as shapely geometry.

A section is the mesh cut by a plane, expressed in 2D coordinates of that plane's own
(u, v) axes, so sections taken at the ends of different parts are directly
comparable: for facade parts u points out of the facade and v up, for floor parts
(u, v) = (x, y). trimesh cuts the mesh and assembles closed loops with their holes
(``polygons_full``); loops of separate bodies are united.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

EMPTY = shapely.Polygon()


def plane_section(mesh, origin, normal, u, v) -> BaseGeometry:
    """The cut of ``mesh`` by the plane (origin, normal) in the plane's (u, v) axes."""
    origin = np.asarray(origin, dtype=float)
    normal = np.asarray(normal, dtype=float)
    path = mesh.section(plane_normal=normal, plane_origin=origin)
    if path is None or len(path.entities) == 0:
        return EMPTY
    to_2d = np.eye(4)
    to_2d[0, :3], to_2d[1, :3], to_2d[2, :3] = u, v, normal
    to_2d[:3, 3] = -to_2d[:3, :3] @ origin
    planar, _ = path.to_2D(to_2D=to_2d, check=False)
    polys = [p for p in planar.polygons_full if p is not None and not p.is_empty]
    if not polys:
        return EMPTY
    geom = shapely.make_valid(shapely.unary_union(polys))
    return shapely.normalize(geom)


def disagreement(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Area of the symmetric difference of each pair (vectorised over arrays)."""
    return shapely.area(shapely.symmetric_difference(a, b))
