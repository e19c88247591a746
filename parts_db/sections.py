"""Planar cross-sections of part meshes as shapely geometry.

A section is the mesh cut by a plane, in 2D coordinates along the plane's own (u, v)
axes, so sections taken at the ends of different parts are directly comparable: for
facade parts u points out of the facade and v up, for floor parts (u, v) = (x, y).

Parts are usually built from many closed bodies that touch or overlap (a wall pier
against the building mass, a cornice on top). Cutting them as one path would merge
loops where bodies touch, so the cut is assembled body by body: trimesh intersects
every triangle with the plane at once, the segments are grouped by connected body,
each body's segments are polygonized into loops, a loop nested in an odd number of
others is a hole, and the bodies are united.
"""

from __future__ import annotations

import numpy as np
import shapely
import trimesh
from shapely.geometry.base import BaseGeometry

EMPTY = shapely.Polygon()
GRID = 1e-6  # metres: segment ends computed from both sides of an edge meet on it


def body_labels(mesh) -> np.ndarray:
    """The connected body of every face (computed once per part)."""
    return trimesh.graph.connected_component_labels(mesh.face_adjacency,
                                                    node_count=len(mesh.faces))


def plane_section(mesh, origin, normal, u, v, labels: np.ndarray | None = None
                  ) -> BaseGeometry:
    """The cut of ``mesh`` by the plane (origin, normal) in the plane's (u, v) axes."""
    origin = np.asarray(origin, dtype=float)
    segs, faces = trimesh.intersections.mesh_plane(mesh, np.asarray(normal, dtype=float),
                                                   origin, return_faces=True)
    if len(segs) == 0:
        return EMPTY
    if labels is None:
        labels = body_labels(mesh)
    rel = segs - origin
    pts = np.stack([rel @ np.asarray(u, dtype=float), rel @ np.asarray(v, dtype=float)],
                   axis=-1)
    lines = shapely.set_precision(shapely.linestrings(pts), GRID)
    lab = labels[faces]
    bodies = []
    for body in np.unique(lab):
        # node the body's linework first: touching boxes merged into one body leave
        # collinear, partly overlapping segments that polygonize alone would not join
        noded = shapely.get_parts(shapely.union_all(lines[lab == body]))
        faces_b = shapely.get_parts(shapely.polygonize(noded))
        loops = {shapely.to_wkb(shapely.normalize(shapely.Polygon(f.exterior)))
                 for f in faces_b if f.area > 0}
        if loops:
            bodies.append(_even_odd([shapely.from_wkb(w) for w in sorted(loops)]))
    if not bodies:
        return EMPTY
    return shapely.normalize(shapely.make_valid(shapely.unary_union(bodies)))


def _even_odd(loops: list) -> BaseGeometry:
    """A body's material: a loop nested inside an odd number of others is a hole."""
    arr = np.array(loops, dtype=object)
    depth = np.array([int(shapely.contains_properly(arr, g).sum()) for g in loops])
    solid = shapely.unary_union(arr[depth % 2 == 0])
    holes = arr[depth % 2 == 1]
    if len(holes):
        solid = shapely.difference(solid, shapely.unary_union(holes))
    return solid


def disagreement(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Area of the symmetric difference of each pair (vectorised over arrays)."""
    return shapely.area(shapely.symmetric_difference(a, b))
