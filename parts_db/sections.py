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

from typing import NamedTuple, overload

import numpy as np
import shapely
import trimesh
from shapely.geometry.base import BaseGeometry
from trimesh.constants import tol

from citysynth.parts_db.section_loops import chain, plain_rings, segments

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


@overload
def disagreement(a: np.ndarray, b: np.ndarray) -> np.ndarray: ...
@overload
def disagreement(a: BaseGeometry, b: BaseGeometry) -> float: ...
def disagreement(a, b):
    """Area of the symmetric difference of two sections, or of each pair (vectorised
    over arrays): the transition cost table's measure, and the seam's (two modules
    start alike)."""
    out = shapely.area(shapely.symmetric_difference(a, b))
    return out if isinstance(a, np.ndarray) else float(out)


SCALE = round(1 / GRID)   # GEOS snaps to this integral scale (as its PrecisionModel does)
MERGE = tol.merge         # a vertex this close to the plane is on it, as for mesh_plane


def loop_section(vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray, origin,
                 normal, u, v) -> BaseGeometry | None:
    """:func:`plane_section` of the mesh (vertices, faces), faster where its segments
    chain simply, or None where they do not (the caller then takes plane_section).

    Cut prototypes take a section per cut plane, and plane_section's per-body shapely
    work (noding, polygonizing, normalizing every loop) was most of a cut's time. Here
    the segments are found from the vertices' signed distances, in ``mesh_plane``'s
    cases (a face crossing the plane; through one vertex; along an edge, counted from
    the face whose third vertex is on the positive side), their ends snapped to
    :data:`GRID` as ``set_precision`` snaps them. Where every snapped end of a body is
    shared by at most two of its segments, they chain into closed loops and open
    chains; where these are moreover simple and touch no other (``is_simple`` of the
    body's linework), noding changes nothing, polygonizing drops the open chains and
    gives back the loops, and the body's material is built from them directly: a loop
    in no other loop is a shell, one in a single other is that shell's hole; a loop
    deeper in lies in a hole, which plane_section's even-odd rule removes whole. Any
    other linework (a point three ends share, segments touching, crossing or doubling
    back) returns None."""
    grid, lab = _segments(vertices, faces, labels, origin, normal, u, v)
    if not len(grid):
        return EMPTY
    return _loops_material(grid, lab)


class Rings(NamedTuple):
    """A section as rings to triangulate: ``xy`` [P, 2] points in metres on the plane's
    (u, v) axes, each ring closed (its first point repeated last); ring r is
    xy[ring_ends[r]:ring_ends[r + 1]]; polygon k's rings (its shell, then its holes) are
    ring_ends' rings poly_ends[k] to poly_ends[k + 1]."""

    xy: np.ndarray
    ring_ends: np.ndarray
    poly_ends: np.ndarray


NO_RINGS = Rings(np.empty((0, 2)), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64))


def plain_rings_section(vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray,
                        origin, normal, u, v) -> Rings | None:
    """:func:`loop_section`'s polygons as :class:`Rings`, without shapely, where the
    section is plainly apart: its segments chain into closed loops only, no two loops
    (of any bodies) touch, and no loop lies inside a loop of another body; else None.

    Such loops are polygons as they stand: a loop in no other loop of its body is a
    shell, in exactly one that shell's hole, deeper ones lie in a hole (dropped, as
    the even-odd rule drops them); bodies apart need no union. A cut's cap is such a
    section nine times in ten, and shapely's per-call work on it (building, validating,
    uniting and normalizing the polygons, then reading their rings back) was most of
    the cap's time. Any other section (open chains, touching or nested bodies, a loop
    folding back on itself, or sides so many and so long that testing them pairwise
    would take longer than noding them) is for loop_section and, failing that,
    plane_section."""
    grid, lab = _segments(vertices, faces, labels, origin, normal, u, v)
    if not len(grid):
        return NO_RINGS
    walks = _walks(grid, lab)
    if walks is None:
        return None
    flat, lo, slots, starts, closed_walk = walks
    if not closed_walk.all() or (flat.max(axis=0) - lo >= 1 << 30).any():
        return None    # open chains; or integer tests that could overflow
    pts = flat[slots] - lo
    rings, polys = plain_rings(pts, starts, lab[slots[starts[:-1]] >> 1])
    if not len(polys):
        return None
    sizes = np.diff(starts)[rings]
    take = np.concatenate([np.arange(starts[r], starts[r + 1]) for r in rings])
    return Rings((pts[take] + lo) / SCALE, np.r_[0, np.cumsum(sizes)], polys)


def _segments(vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray, origin, normal,
              u, v) -> tuple[np.ndarray, np.ndarray]:
    """The plane's segments, their ends snapped to the grid (in grid units, [S, 2, 2]),
    and the body of each."""
    origin = np.asarray(origin, dtype=float)
    dots = np.dot(vertices - origin, np.asarray(normal, dtype=float))
    return segments(np.ascontiguousarray(vertices, dtype=np.float64),
                    np.ascontiguousarray(faces, dtype=np.int64),
                    np.ascontiguousarray(labels, dtype=np.int64), dots, origin,
                    np.asarray(u, dtype=float), np.asarray(v, dtype=float), MERGE,
                    float(SCALE), _CASE, _TURN, _FROM, _TO)


def _cases() -> tuple[np.ndarray, ...]:
    """For each face's sides (0 below, 1 on, 2 above; code 9 s0 + 3 s1 + s2): whether
    it gives a segment, as trimesh's ``mesh_plane`` counts them; the turn of its
    vertices that puts the lone one first (alone on its side; on the plane; off it);
    and, in that turn, the edge (from, to) each end of its segment lies on."""
    case = np.zeros(27, dtype=bool)
    turn = np.tile(np.arange(3), (27, 1))
    ends_from = np.zeros((27, 2), dtype=np.int64)
    ends_to = np.zeros((27, 2), dtype=np.int64)
    for c in range(27):
        s = [c // 9, c // 3 % 3, c % 3]
        n = [s.count(x) for x in (0, 1, 2)]
        if n[1] == 0 and n[0] and n[2]:      # crossing: both ends on the lone's edges
            lone, ends_from[c], ends_to[c] = s.index(0 if n[0] == 1 else 2), (0, 0), (1, 2)
        elif n == [1, 1, 1]:                 # through a vertex, to the opposite edge
            lone, ends_from[c], ends_to[c] = s.index(1), (0, 1), (0, 2)
        elif n == [0, 2, 1]:                 # along an edge, counted from its face above
            lone, ends_from[c], ends_to[c] = s.index(2), (1, 2), (1, 2)
        else:
            continue
        case[c] = True
        turn[c] = [(lone + i) % 3 for i in range(3)]
    return case, turn, ends_from, ends_to


_CASE, _TURN, _FROM, _TO = _cases()


def _loops_material(grid: np.ndarray, lab: np.ndarray) -> BaseGeometry | None:
    """The even-odd material of each body's segments (snapped ends [S, 2, 2] in grid
    units, body of each), or None unless every body's segments chain into simple
    closed loops and open chains, none touching another. An open chain (a body that
    a seam splits into face-connected bodies leaves them) bounds nothing:
    polygonizing drops it."""
    walks = _walks(grid, lab)
    if walks is None:
        return None
    flat, _lo, slots, starts, closed_walk = walks
    sizes = np.diff(starts)
    by_body = np.argsort(lab[slots[starts[:-1]] >> 1], kind="stable")
    body = lab[slots[starts[by_body]] >> 1]
    closed_walk, sizes = closed_walk[by_body], sizes[by_body]
    xy = flat[np.concatenate([slots[starts[w]:starts[w + 1]] for w in by_body])] / SCALE
    ends = np.r_[0, np.cumsum(sizes)]
    bodies = np.r_[0, np.flatnonzero(np.diff(body)) + 1, len(by_body)]
    lines = shapely.from_ragged_array(shapely.GeometryType.MULTILINESTRING, xy, (ends, bodies))
    if not shapely.is_simple(lines).all():
        return None
    closed = np.flatnonzero(closed_walk)
    if not len(closed):
        return EMPTY
    return _even_odd_loops(xy, ends, closed, body[closed])


def _walks(grid: np.ndarray, lab: np.ndarray) -> tuple[np.ndarray, ...] | None:
    """The segments (snapped ends [S, 2, 2] in grid units, body of each) chained into
    walks, keyed by (body, point): (their ends [2S, 2], the least of them, the walks'
    slots, starts and closedness as :func:`chain` gives them), or None where three
    ends or more meet at a point, a closed walk doubles back on itself (two
    segments), or the keys would overflow (a part kilometres long)."""
    flat = grid.reshape(-1, 2)
    lo = flat.min(axis=0)
    span = flat.max(axis=0) - lo + 1
    if (int(lab.max()) + 1) * int(span[0]) * int(span[1]) >= 1 << 62:
        return None
    key = (np.repeat(lab, 2) * span[1] + (flat[:, 1] - lo[1])) * span[0] + (flat[:, 0] - lo[0])
    slots, starts, closed_walk = chain(key)
    if not len(starts) or (np.diff(starts)[closed_walk] < 4).any():
        return None
    return flat, lo, slots, starts, closed_walk


def _even_odd_loops(xy: np.ndarray, ends: np.ndarray, closed: np.ndarray,
                    body: np.ndarray) -> BaseGeometry:
    """The material of disjoint simple loops (walks ``closed`` of the points xy, split
    at ``ends``; the body of each): a loop in no other loop of its body is a shell, a
    loop in exactly one is a hole of it, deeper ones lie in holes."""
    loops = [xy[ends[w]:ends[w + 1]] for w in closed]
    polys = _polygons(loops, np.arange(len(loops) + 1))
    first = xy[ends[closed]]
    # a loop crossing no other lies in one exactly when its first point does
    i, j = np.nonzero((body[:, None] == body[None, :]) & ~np.eye(len(body), dtype=bool))
    inside = shapely.contains_xy(polys[j], first[i, 0], first[i, 1])
    i, j = i[inside], j[inside]
    depth = np.bincount(i, minlength=len(closed))
    shells = np.flatnonzero(depth == 0)
    hole = (depth[i] == 1) & (depth[j] == 0)        # a hole and the shell around it
    owner = np.concatenate([np.arange(len(shells)), np.searchsorted(shells, j[hole])])
    members = np.concatenate([shells, i[hole]])[np.argsort(owner, kind="stable")]
    solid = _polygons([loops[m] for m in members], np.r_[0, np.cumsum(np.bincount(owner))])
    return shapely.normalize(shapely.make_valid(shapely.unary_union(solid)))


def _polygons(rings: list[np.ndarray], starts: np.ndarray) -> np.ndarray:
    """Polygons of closed rings of points, each polygon's rings from starts[k] (its
    shell) to starts[k + 1] (its holes before that), built in one call."""
    return shapely.from_ragged_array(shapely.GeometryType.POLYGON, np.concatenate(rings),
                                     (np.cumsum([0, *map(len, rings)]), starts))
