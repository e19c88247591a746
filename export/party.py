"""Party walls: where a footprint shares a wall with its neighbour, its parts stop there.

Two buildings of a city whose outlines touch were each built with facades all round:
along the wall they share, each one's balconies, window trims and cornice reached into
the other (up to 0.3 m in the sample kit), and where the two were of one height their
eaves lay over each other in one plane, z-fighting along the seam from above (21 m²
over the 330 touching pairs of the demo district). A party wall is a wall, not a
facade: each part whose mass reaches past the shared line into the neighbour is cut
on that line (the cut's cap, in the wall's material, is the blank end of the
building), so the two buildings meet on the line, each on its own side. Their caps lie
there in one plane, facing each other, each inside the other's mass, where no view
reaches them; cut 5 mm short on each side, they left a 1 cm hairline of sky down the
street front at every seam.

The shared lines come from the city run (:mod:`citysynth.pipeline.city.party`), which
sees every footprint: each is a segment of this building's outline (its ground on the
segment's left) that lies within a few decimetres of another building's.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon

from citysynth.export.cuts import extended_x
from citysynth.export.joints import (
    EXTEND_MARGIN,
    MAX_EXTEND_DEPTHS,
    HalfPlane,
    Placed,
    clip_convex,
    clipped_plan,
)
from citysynth.parts_db import PartDB
from citysynth.parts_db.geometry import part_pieces

Segment = tuple[float, float, float, float]   # x0, y0, x1, y1: the building on the left

TOUCH = 0.3       # m: a neighbour this near an edge shares it (how a city finds the
                  # shared stretches, citysynth.pipeline.city.party)
INSET = 0.005     # m: a part whose facade lies on the shared line is cut this far
                  # behind its facade (a cap in the facade's own plane would z-fight
                  # with it where the wall stands above a lower neighbour)
REACH = 0.02      # m: a part reaching further than this past the line reaches into it
MARGIN = 0.5      # m: past a segment's ends a part still counts as along it
DEPTH = 3.0       # m: how far past the line a part may reach into the neighbour (a
                  # balcony, an eave; a facade the cleaning moved when it absorbed a
                  # short jog of the outline, up to a metre or two)
MIN_AREA = 0.005  # m²: less of a part's plan past the line is rounding
FACING = 0.1      # m: a facade this near the shared line is the party wall
PARALLEL = 0.995  # cosine: ... facing the neighbour within about 6°
_HULLS: dict[tuple[str, str], np.ndarray] = {}


def party_halves(placed: Sequence[Placed], walls: Iterable[Segment], db: PartDB) -> int:
    """Cut every part of ``placed`` that reaches into a neighbour across one of
    ``walls``: a half-plane on the line is added to it where more of
    its plan past the line lies beside the shared stretch, within :data:`DEPTH` of it,
    than elsewhere. A part that runs on past the stretch into a yard keeps its facade,
    and a wing of the building that lies past the line's continuation is not touched.
    A part whose facade lies on the shared line (:func:`_facing`) is cut just behind
    it whether or not it reaches past. Every such plane is blank: its cap is solid, a
    party wall without windows. How many cuts."""
    frames = []                                # each stretch: p0, along, out, length
    for p0, p1 in (np.asarray(w, dtype=float).reshape(2, 2) for w in walls):
        length = float(np.hypot(*(p1 - p0)))
        if length > 1e-6:
            u = (p1 - p0) / length
            frames.append((p0, u, np.array([u[1], -u[0]]), length))
    if not frames:
        return 0
    added = 0
    for p in placed:
        hull = plan_hull(db, p.part)
        # an extension to a joint moves an end by at most this (the hull is unextended)
        # (times the placement's stretch along the part, a few per cent: 1.1 is ample)
        slack = 1.1 * (MAX_EXTEND_DEPTHS * max(abs(p.y_range[0]), abs(p.y_range[1]), 1.0)
                       + EXTEND_MARGIN) if p.halves else 0.0
        world = hull @ p.a.T + p.origin
        near = [(f, front) for f, front in ((f, _facing(p, *f)) for f in frames)
                if front is not None or _beside(world, *f, slack)]
        if not near:
            continue
        corners = _extended(p, hull) @ p.a.T + p.origin
        plan: list[tuple[float, float]] | None = None
        for (p0, u, n, length), front in near:
            if front is not None:              # its facade is the shared wall
                if _add(p, p0, u, n, length, min(-INSET, front - INSET)):
                    added += 1
                continue
            if not _beside(corners, p0, u, n, length, 0.0):
                continue                       # no part of it beside the stretch
            if plan is None:
                plan = _cut_plan(p, corners)
            # the plan in the stretch's frame: t along it, d out of the building
            local = [(x * u[0] + y * u[1], x * n[0] + y * n[1])
                     for x, y in ((x - p0[0], y - p0[1]) for x, y in plan)]
            past = clip_convex(local, 0.0, -1.0, -REACH)                # d >= REACH
            past_area = _area(past)
            if past_area <= MIN_AREA:
                continue
            beside = clip_convex(clip_convex(clip_convex(past, -1.0, 0.0, MARGIN), 1.0, 0.0,
                                             length + MARGIN), 0.0, 1.0, DEPTH)
            beside_area = _area(beside)
            if beside_area <= MIN_AREA or beside_area <= past_area - beside_area:
                continue
            if _add(p, p0, u, n, length, 0.0):
                added += 1
    return added


def _add(p: Placed, p0: np.ndarray, u: np.ndarray, n: np.ndarray, length: float,
         offset: float) -> bool:
    """Cut ``p`` on the line through ``p0`` moved ``offset`` along ``n`` (out of the
    building), a blank plane: its cap solid along the stretch, ``length`` from ``p0``
    along ``u`` (a party wall has no windows; past the neighbour's end the wall keeps
    them). Whether that is a new cut."""
    a, b = p0 + n * offset, p0 + u * length + n * offset
    half = HalfPlane((float(n[0]), float(n[1])), (float(a[0]), float(a[1])),
                     extends=False, blank=True,
                     span=((float(a[0]), float(a[1])), (float(b[0]), float(b[1]))))
    if half in p.halves:
        return False
    p.halves.append(half)
    return True


def _facing(p: Placed, p0: np.ndarray, u: np.ndarray, n: np.ndarray, length: float
            ) -> float | None:
    """Where the part's facade lies on the shared stretch, facing the neighbour (within
    :data:`FACING` of its line, parallel, at least half of it beside the stretch): how
    far out of the building its facade line reaches (its nearer end), else None. Such a
    part is cut however little of it reaches past the line: above a lower neighbour its
    facade would otherwise show its windows where a party wall stands."""
    (ax, bx), (ay, by) = p.a.tolist()             # plain floats: every part, every stretch
    nx, ny = n.tolist()
    norm = math.hypot(bx, by)                     # the facade faces placement-frame -Y
    if norm < 1e-9 or -(bx * nx + by * ny) / norm < PARALLEL:
        return None
    (ox, oy), (px, py), (ux, uy) = p.origin.tolist(), p0.tolist(), u.tolist()
    x0, y0 = ox - px, oy - py
    x1, y1 = x0 + ax * p.length, y0 + ay * p.length
    d0, d1 = x0 * nx + y0 * ny, x1 * nx + y1 * ny
    if max(abs(d0), abs(d1)) > FACING:
        return None
    t0, t1 = x0 * ux + y0 * uy, x1 * ux + y1 * uy
    span = abs(t1 - t0)
    overlap = min(max(t0, t1), length) - max(min(t0, t1), 0.0)
    return min(d0, d1) if span > 1e-9 and overlap >= span / 2 else None


def _beside(corners: np.ndarray, p0: np.ndarray, u: np.ndarray, n: np.ndarray,
            length: float, slack: float) -> bool:
    """Whether points' bounds (grown by ``slack``) reach the ground beside a stretch:
    past its line by more than REACH, within DEPTH, along it within MARGIN of its
    ends."""
    rel = corners - p0
    d, t = rel @ n, rel @ u
    return bool(d.max() + slack > REACH and d.min() - slack < DEPTH
                and t.max() + slack > -MARGIN and t.min() - slack < length + MARGIN)


def _extended(p: Placed, xy: np.ndarray) -> np.ndarray:
    """Placement-frame points moved as the part's extension to its joints moves its
    mesh (a module at a mitre reaches the corner only so)."""
    cut = p.cut()
    if cut is None or cut.extend == (0.0, 0.0):
        return xy
    return np.column_stack([extended_x(xy[:, 0], p.length, cut.extend), xy[:, 1]])


def _cut_plan(p: Placed, corners: np.ndarray) -> list[tuple[float, float]]:
    """The part's plan (its hull ``corners``, convex) as its cuts so far leave it."""
    return clipped_plan([(float(x), float(y)) for x, y in corners], p.halves)


def _area(poly: list[tuple[float, float]]) -> float:
    """A polygon's area (shoelace)."""
    return abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1)
                   in zip(poly, poly[1:] + poly[:1], strict=True))) / 2 if len(poly) > 2 \
        else 0.0


def plan_hull(db: PartDB, part_id: str) -> np.ndarray:
    """The convex hull of a part's mesh seen from above (placement-frame XY), every
    piece's (a balcony reaches furthest), made once per part."""
    key = (db.library_hash, part_id)
    if key not in _HULLS:
        pieces = part_pieces(db, db.part(part_id))
        xy = np.unique(np.round(np.concatenate([pc.vertices[:, :2] for pc in pieces]), 4),
                       axis=0)
        hull = shapely.convex_hull(shapely.multipoints(xy))
        _HULLS[key] = np.asarray(hull.exterior.coords)[:-1] if isinstance(hull, Polygon) \
            else np.asarray(hull.coords)
    return _HULLS[key]
