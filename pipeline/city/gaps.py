"""Gaps in the data: neighbours drawn a little apart are made to touch.

Two buildings drawn less than :data:`~citysynth.export.party.TOUCH` apart (one wall
digitised twice, a terrace traced by hand) count as sharing a wall, but each building
stops on its own line: the gap stood in the city as a slit the buildings' full height
and depth, sky and yard showing through it from the street.

Larger first (by area, then order, as overlaps are settled): the larger keeps its
outline, and each side of the smaller that runs along one of its sides within TOUCH is
moved onto that side's line, whole: its corners slide along the sides before and after
it, so the outline keeps its corners and gains none. (A first version filled the gap
with what a closing of the two left between them; where the smaller house was the
deeper, its outline kept a 0.2 m step at the larger's corner, which ``citysynth block``
refused as a side too short and the city's cleaning turned into a slanted wall, the
slit reopened as a wedge.) A move that would make the outline invalid, overlap another
footprint or move a corner far (a side next to it nearly parallel) is not made.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from citysynth.export.party import TOUCH
from citysynth.pipeline.city.footprints import remark
from citysynth.pipeline.city.overlaps import Footprint, names_of

MIN_LENGTH = 1.0    # m: a side runs along a neighbour's for at least this, or not at all
MIN_GAP = 0.001     # m: a thinner gap is rounding of one line (a wall drawn once,
                    # through a projection), and shows nothing
PARALLEL = 0.995    # cosine: the two sides run the same way within about 6°
MAX_SLIDE = 1.0     # m: a corner moves at most this far (the side beside nearly parallel)
OVERLAP = 0.01      # m²: a moved side may overlap another footprint by rounding only


def with_gaps_closed(footprints: list[Footprint]) -> list[Footprint]:
    """``footprints`` (the ones to build, as :func:`~.overlaps.separate` leaves them)
    with the gaps under TOUCH between them closed, a grown one's note saying by how
    much and towards which."""
    out = []
    for fp, (shape, added, towards) in zip(
            footprints, closed_gaps([f.polygon for f in footprints]), strict=True):
        if added > 0.0:
            fp = Footprint(shape, remark(fp.spec, grown_note(
                added, names_of(fp.spec, [footprints[j].spec for j in towards]))))
        out.append(fp)
    return out


def grown_note(added: float, towards: str) -> str:
    """What :func:`closed_gaps` did to a footprint, for its note (``towards``: the
    neighbours it met, named)."""
    area = f"{added:.2f} m²" if added >= 0.005 else "under 0.01 m²"
    return (f"grown by {area} to meet {towards}: drawn "
            f"less than {TOUCH:g} m apart, they would have stood with a slit between them")


def closed_gaps(shapes: list[BaseGeometry]) -> list[tuple[BaseGeometry, float, list[int]]]:
    """Each of ``shapes`` (polygons or multipolygons) with its sides that run along a
    larger neighbour's within :data:`TOUCH` moved onto that neighbour's line, the area
    it gained, and those neighbours (see the module's docstring)."""
    out: list[tuple[BaseGeometry, float, list[int]]] = [(s, 0.0, []) for s in shapes]
    tree = shapely.STRtree(shapes)
    order = sorted(range(len(shapes)), key=lambda i: (-shapes[i].area, i))
    rank = {i: r for r, i in enumerate(order)}
    for i in order:
        shape = shapes[i]
        near = [int(j) for j in tree.query(shape, predicate="dwithin", distance=TOUCH)
                if int(j) != i]
        larger = [j for j in near if rank[j] < rank[i]]
        if not larger:
            continue
        window = shapely.box(*shape.bounds).buffer(2 * TOUCH, join_style="mitre")
        sides = [(j, seg) for j in larger for seg in _segments(out[j][0], window)]
        if not sides:
            continue
        towards: set[int] = set()
        parts = [_moved(p, sides, towards) for p in shapely.get_parts(shape)]
        grown = shapely.MultiPolygon(parts) if shape.geom_type == "MultiPolygon" else parts[0]
        if not towards or not _acceptable(shape, grown, [out[j][0] for j in near]):
            continue
        out[i] = (grown, grown.area - shape.area, [j for j in larger if j in towards])
    return out


def _segments(shape: BaseGeometry, window: BaseGeometry) -> list[np.ndarray]:
    """The sides of ``shape``'s rings (each a 2 x 2 array) that reach into ``window``:
    a 20 km footprint's sides are not all tried against each house beside it."""
    out = []
    for poly in shapely.get_parts(shape):
        for ring in (poly.exterior, *poly.interiors):
            pts = np.asarray(ring.coords)[:, :2]
            segs = np.stack([pts[:-1], pts[1:]], axis=1)
            near = shapely.intersects(window, shapely.linestrings(segs))
            out += [s for s, hit in zip(segs, near, strict=True) if hit]
    return out


def _moved(poly: Polygon, sides: list[tuple[int, np.ndarray]], towards: set[int]) -> Polygon:
    """``poly`` with each of its sides that runs along one of ``sides`` (a neighbour's,
    outside it, within TOUCH) moved onto that side's line, its corners sliding along
    the sides before and after it; the neighbours met added to ``towards``."""
    ground = orient(poly, 1.0)            # its ground on each ring's left
    rings = [_moved_ring(np.asarray(r.coords)[:-1, :2].copy(), sides, towards)
             for r in (ground.exterior, *ground.interiors)]
    return Polygon(rings[0], rings[1:])


def _moved_ring(pts: np.ndarray, sides: list[tuple[int, np.ndarray]],
                towards: set[int]) -> np.ndarray:
    n = len(pts)
    for k in range(n):
        a, b = pts[k], pts[(k + 1) % n]
        length = float(np.hypot(*(b - a)))
        if length < MIN_LENGTH:
            continue
        u = (b - a) / length
        out_n = np.array([u[1], -u[0]])          # out of the ground (on the left)
        best = None
        for j, seg in sides:
            v = seg[1] - seg[0]
            lv = float(np.hypot(*v))
            if lv < 1e-9 or abs(float(u @ v)) / lv < PARALLEL:
                continue
            t = (seg - a) @ u
            lo, hi = max(float(t.min()), 0.0), min(float(t.max()), length)
            if hi - lo < MIN_LENGTH:
                continue
            # how far out the neighbour's side lies, beside this one
            d = np.interp([lo, hi], np.sort(t), ((seg - a) @ out_n)[np.argsort(t)])
            if (-MIN_GAP < d.min() and MIN_GAP < d.max() <= TOUCH        # apart, not over
                    and (best is None or hi - lo > best[0])):
                best = (hi - lo, j, seg)
        if best is None:
            continue
        _o, j, seg = best
        prev, nxt = pts[(k - 1) % n], pts[(k + 2) % n]
        na = _meet(prev, a, seg)
        nb = _meet(nxt, b, seg)
        if na is None or nb is None:
            continue
        pts[k], pts[(k + 1) % n] = na, nb
        towards.add(j)
    return pts


def _meet(p: np.ndarray, q: np.ndarray, seg: np.ndarray) -> np.ndarray | None:
    """Where the line through p and q (the side beside the one moved) meets the line of
    ``seg``: the moved corner q; None when that is more than :data:`MAX_SLIDE` from q."""
    d1, d2 = q - p, seg[1] - seg[0]
    den = d1[0] * d2[1] - d1[1] * d2[0]
    if abs(den) < 1e-12:
        return None
    s = ((seg[0][0] - p[0]) * d2[1] - (seg[0][1] - p[1]) * d2[0]) / den
    x = p + s * d1
    return x if math.hypot(*(x - q)) <= MAX_SLIDE else None


def _acceptable(before: BaseGeometry, after: BaseGeometry,
                others: list[BaseGeometry]) -> bool:
    """Whether the moved outline is one a building stands on: valid (its rings simple
    and apart), grown, no corner moved more than :data:`MAX_SLIDE`, and over no other
    footprint."""
    if not after.is_valid or after.area <= before.area:
        return False
    if after.hausdorff_distance(before) > MAX_SLIDE:
        return False
    return all(after.intersection(o).area - before.intersection(o).area <= OVERLAP
               for o in others)

