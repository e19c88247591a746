"""Party walls: the stretches of each footprint's outline it shares with a neighbour.

A city's footprints touch where buildings stand wall to wall (a terrace, a perimeter
block of separate houses). Each building is laid out on its own, so it would put
facades, balconies and eaves on the wall it shares, reaching into its neighbour; the
stretches found here go with each footprint's job, and its layout stops its parts there
(:mod:`citysynth.export.party`). A stretch is an edge of the footprint's outline (or a
courtyard's) within :data:`TOUCH` of another footprint for at least :data:`MIN_LENGTH`,
as it runs along that edge; neighbours a little apart in the data (walls digitised
twice, a few centimetres off) count as touching, a passage between two buildings does
not.

Neighbours drawn apart by less than :data:`TOUCH` are first made to touch
(:mod:`~citysynth.pipeline.city.gaps`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely
from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from citysynth.export.party import TOUCH, Segment
from citysynth.pipeline.city.overlaps import Footprint

MIN_LENGTH = 1.0   # m: a shorter shared stretch is a corner touching, not a wall
DIGITS = 3         # the stretches' ends to the millimetre (the job's hash covers them)


def with_party_walls(footprints: list[Footprint]) -> list[Footprint]:
    """``footprints`` (the ones to build, as :func:`~.overlaps.separate` and
    :func:`~.gaps.with_gaps_closed` leave them), each spec carrying the stretches of
    its outline shared with the others."""
    walls = party_walls([f.polygon for f in footprints])
    return [replace(fp, spec=replace(fp.spec, party=w)) if w else fp
            for fp, w in zip(footprints, walls, strict=True)]


def party_walls(shapes: list[BaseGeometry]) -> list[tuple[Segment, ...]]:
    """For each of ``shapes`` (polygons or multipolygons: a city's footprints, the
    features of a ``citysynth block`` file), the stretches of its outline it shares
    with the others, as :func:`shared_stretches` finds them. A shape that overlaps
    this one by more than a wall digitised twice (thicker than 2 :data:`TOUCH`: the
    same building drawn twice, a block file of overlapping polygons) shares no wall
    with it: its whole outline would count as shared, and every balcony and eave be
    cut off. (A city separates overlapping footprints before this.)"""
    tree = shapely.STRtree(shapes)
    out: list[tuple[Segment, ...]] = []
    for i, shape in enumerate(shapes):
        near = [shapes[int(j)] for j in sorted(tree.query(shape, predicate="dwithin",
                                                          distance=TOUCH))
                if j != i and _touching(shape, shapes[int(j)])]
        out.append(tuple(w for poly in shapely.get_parts(shape)
                         for w in shared_stretches(poly, near)) if near else ())
    return out


def _touching(a: BaseGeometry, b: BaseGeometry) -> bool:
    """Whether two shapes near each other meet without overlapping: what they have in
    common is nowhere thicker than 2 :data:`TOUCH`."""
    return bool(shapely.buffer(shapely.intersection(a, b), -TOUCH).is_empty)


def shared_stretches(polygon: shapely.Polygon, others: list[shapely.Polygon]
                     ) -> tuple[Segment, ...]:
    """The stretches of ``polygon``'s rings that lie within :data:`TOUCH` of one of
    ``others`` for at least :data:`MIN_LENGTH`, each (x0, y0, x1, y1) along its edge
    with the polygon's ground on its left."""
    if not others:
        return ()
    whole = shapely.union_all(others)
    near = whole.buffer(TOUCH, quad_segs=2)
    ground = orient(polygon, 1.0)      # its ground on each ring's left
    out: list[Segment] = []
    for ring in (ground.exterior, *ground.interiors):
        pts = np.asarray(ring.coords)[:, :2]
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            length = float(np.hypot(*(b - a)))
            if length < MIN_LENGTH:
                continue
            u = (b - a) / length
            edge = LineString([a, b])
            # the neighbours' ground beside the edge, whose ends (not the buffer's
            # rounding past them) end the stretch
            beside = whole.intersection(edge.buffer(TOUCH, cap_style="flat"))
            for part in shapely.get_parts(edge.intersection(near)):
                if part.geom_type != "LineString" or part.length < MIN_LENGTH:
                    continue
                t = np.asarray(part.coords)[:, :2] @ u - a @ u
                there = shapely.get_coordinates(beside.intersection(
                    part.buffer(TOUCH, cap_style="flat"))) @ u - a @ u
                if not len(there):
                    continue
                t0, t1 = max(float(t.min()), float(there.min())), \
                    min(float(t.max()), float(there.max()))
                if t1 - t0 < MIN_LENGTH:
                    continue
                p0, p1 = a + u * t0, a + u * t1
                out.append((_mm(p0[0]), _mm(p0[1]), _mm(p1[0]), _mm(p1[1])))
    return tuple(out)


def _mm(x: float) -> float:
    """A coordinate to the millimetre, -0.0 as 0.0."""
    return round(float(x), DIGITS) + 0.0
