"""Roof infill: the flat roof over a deep building's ground that no part reaches.

Facade parts are as deep as a wing (9 to 14 m in the sample kit). A footprint deeper
than two of them (a department store, a station, a school) was built as a ring of
wings round open ground: seen from above the building had a hole the footprint does
not have, and the ground showed through it. A footprint's layout therefore fills, with
one flat mass per open area, the ground inside its outline (less its courtyards and the
street past a nose's end wall) that no part covers, as the parts' meshes cover it seen
from above:

- **what**: the outline less every instance's plan (its walls' and roof's faces
  projected on the ground, the part extended and cut as the instance is), opened by
  :data:`SEAM` (:data:`SLIVER` on a street block) so the hairline seams between
  modules stay as they are; areas under
  :data:`MIN_AREA` are left out, and those under :data:`NOTCH` that touch the outline
  (a notch in a facade, where a plain infill wall would face the street; a speck
  inside, where hip roofs meet round it, shows the ground through them);
- **how high**: :data:`DROP` below the lowest back eave of the parts round it (where a
  part's solid cross-section meets its back plane), so the infill never shows above a
  roof it meets and never lies in one plane with a flat roof (no z-fighting);
- **looks**: its top in the roof material and its sides in the wall material of that
  lowest part (the library's own materials, as a cut's caps are).

What is roofed (:data:`Roof`): all of it on a footprint (``citysynth city``'s
footprints, ``citysynth block --infill``), which has no open ground but its courtyards.
A street block keeps its yards open and roofs only its **pockets**: open ground no
circle of :data:`YARD` radius fits in, left between wings where they meet at an acute
corner or behind a nose (a 27 x 18 m block had a 5.5 m diamond of ground showing
through its roofs; no yard is that narrow).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
import shapely
from mapbox_earcut import triangulate_float64
from shapely.geometry import LineString, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from citysynth.export.cuts import extended_x, length
from citysynth.export.ground import GRID, footprint
from citysynth.export.joints import half_polygons
from citysynth.export.layout import COORD_DIGITS, Infill, Instance
from citysynth.export.rings import building_ground
from citysynth.parts_db import Part, PartDB
from citysynth.parts_db.geometry import Piece, part_pieces

MIN_AREA = 0.3         # m²: open ground smaller than this is left open
NOTCH = 2.0            # m²: smaller open ground on the outline is a notch in a facade
TOUCH = 0.05           # m: open ground this near the outline is on it
SLIVER = 0.15          # m: a street block's open ground thinner than twice this is a
                       # seam, not a hole (and a slit that keeps a pocket from its yard)
SEAM = 0.02            # m: the same on a footprint, which has no yard: wider seams are
                       # cracks through its roofs (0.25 m wide and 10 m long, where a
                       # chamfer's corner part met the courtyard ring's modules)
DROP = 0.3             # m: the infill's top below the lowest back eave round it
NEIGHBOUR = 0.5        # m: a part this near an open area is round it
MIN_HEIGHT = 2.5       # m: lower than this, the parts round it are no building
YARD = 2.5             # m: street-block ground no circle this big fits in is a pocket
MASS_PIECES = ("walls", "roof")    # the pieces a part's plan is taken from
TOP_PIECE, SIDE_PIECE = "roof", "walls"
_PLANS: dict[tuple[str, str], BaseGeometry] = {}
_EAVES: dict[tuple[str, str], float] = {}

Roof = Literal["all", "pockets", "none"]
"""What of a layout's open ground is roofed: ``all`` (a footprint), ``pockets`` (a
street block: its yards stay open, what no circle of :data:`YARD` radius fits in is
roofed), ``none``."""


def plan_infill(structures: list[dict], instances: Sequence[Instance], db: PartDB,
                roof: Roof = "all") -> list[Infill]:
    """The infill of a layout (its ``structures`` as the layout JSON holds them, its
    ``instances``): one :class:`Infill` per open area ``roof`` asks to roof, largest
    first; none when every bit of ground is covered or no ring is closed."""
    if roof == "none" or not instances:
        return []
    ground = building_ground(structures)
    if ground.is_empty:
        return []
    grounds = instance_grounds(db, instances)
    areas = open_areas(ground, grounds, roof)
    tree = shapely.STRtree(grounds)
    out: list[Infill] = []
    for area in sorted(areas, key=lambda p: (-round(p.area, 3), p.bounds)):
        near = sorted({instances[int(i)].part
                       for i in tree.query(area, predicate="dwithin", distance=NEIGHBOUR)})
        if not near:
            continue
        eave, part = min((back_eave(db, db.part(p)), p) for p in near)
        z = round(eave - DROP, COORD_DIGITS)
        if z < MIN_HEIGHT:
            continue
        out.extend(Infill(part, z, _rings(piece)) for piece in _on_grid(area))
    return out


def _on_grid(area: Polygon) -> list[Polygon]:
    """``area`` simplified (5 mm) and snapped to the layout JSON's 0.1 mm grid, as
    valid polygons: rounding each corner alone made a ring cross itself where it
    pinched (a corner 0.01 mm over its own edge; 6 of the demo district's 556 roofs),
    and its triangles then overlapped (2 m² of one roof drawn twice). A pinch becomes
    two polygons."""
    snapped = shapely.set_precision(shapely.simplify(area, 0.005), 10.0 ** -COORD_DIGITS)
    parts = [g for g in shapely.get_parts(snapped) if isinstance(g, Polygon)]
    return sorted((p for p in parts if p.area > 0), key=lambda p: (-round(p.area, 3), p.bounds))


def open_areas(ground: BaseGeometry, grounds: list[BaseGeometry], roof: Roof
               ) -> list[Polygon]:
    """The open areas of a building's ``ground`` (less the instances' ``grounds``)
    that ``roof`` asks to roof: at least :data:`MIN_AREA`, not a notch on the outline,
    and for ``pockets`` no yard."""
    try:
        open_ = _open_ground(ground, grounds, None, roof)
    except shapely.errors.GEOSException:   # slivers of cuts can tangle a ring: snapped
        open_ = _open_ground(ground, grounds, GRID, roof)
    edge = ground.boundary
    areas = [p for p in shapely.get_parts(open_)
             if p.geom_type == "Polygon" and p.area >= MIN_AREA
             and (p.area >= NOTCH or p.distance(edge) > TOUCH)]
    return [p for p in areas if is_pocket(p)] if roof == "pockets" else areas


def is_pocket(area: Polygon) -> bool:
    """Whether open ground is too narrow to be a yard: no circle of :data:`YARD` radius
    fits in it (it vanishes when shrunk by that much)."""
    return bool(shapely.buffer(area, -YARD).is_empty)


def _open_ground(ground: BaseGeometry, grounds: list[BaseGeometry], grid: float | None,
                 roof: Roof) -> BaseGeometry:
    """The building's ground no instance covers, less seams thinner than 2 SEAM (2
    SLIVER for ``pockets``): an opening, shrunk by it, the cores, grown back within the
    open ground.

    The instances' union is GEOS's disjoint-subset union when not snapped: the same
    union, in 40 % of the time on a street block's ring of wings. For ``pockets`` only
    the cores no circle of YARD - SLIVER radius fits in are grown back: a core one
    fits in grows into an area a circle of YARD radius fits in, a yard, and growing
    and trimming the yard was most of the cost of a street block's pocket search.
    Grown alone, a pocket no longer joins the yard it opens into through a slit (a
    wedge between two wings diverging from the yard's tip: the yard's core, grown
    with mitred corners, reached up the slit and took the wedge in)."""
    covered = (shapely.disjoint_subset_union_all(grounds) if grid is None
               else shapely.union_all(grounds, grid_size=grid))
    open_ = shapely.difference(ground, covered, grid_size=grid)
    seam = SLIVER if roof == "pockets" else SEAM
    cores = shapely.buffer(open_, -seam, join_style="mitre")
    if roof == "pockets":
        cores = shapely.union_all([c for c in shapely.get_parts(cores)
                                   if shapely.buffer(c, SLIVER - YARD).is_empty])
        if cores.is_empty:
            return cores
        open_ = shapely.union_all([p for p in shapely.get_parts(open_)
                                   if p.intersects(cores)])
    opened = shapely.buffer(cores, seam, join_style="mitre")
    return shapely.intersection(opened, open_, grid_size=grid)


def instance_grounds(db: PartDB, instances: Sequence[Instance]) -> list[BaseGeometry]:
    """The ground each instance covers seen from above, in the layout frame: its part's
    plan (:func:`part_plan`), its ends extended and cut as the instance is
    (:class:`~citysynth.export.layout.Cut`), then placed. All at once, plane by plane
    (a footprint has a hundred instances and as many cuts: one at a time took three
    times as long)."""
    if not instances:
        return []
    parts = [db.part(i.part) for i in instances]
    plans = np.array([part_plan(db, p) for p in parts], dtype=object)
    cuts = [i.cut for i in instances]
    ext = np.array([c.extend if c is not None else (0.0, 0.0) for c in cuts])
    moved = np.flatnonzero((ext > 0).any(axis=1))
    if len(moved):
        xy, at = shapely.get_coordinates(plans[moved], return_index=True)
        lengths = np.array([length(parts[k]) for k in moved])
        xy[:, 0] = extended_x(xy[:, 0], lengths[at], ext[moved][at])
        plans[moved] = shapely.set_coordinates(plans[moved].copy(), xy)
    planes = [c.planes if c is not None else () for c in cuts]
    for r in range(max(map(len, planes))):
        at = np.array([k for k, p in enumerate(planes) if len(p) > r], dtype=int)
        plans[at] = _kept(plans[at], np.array([planes[k][r] for k in at]))
    xy, at = shapely.get_coordinates(plans, return_index=True)
    axes = np.array([(i.x_axis, i.y_axis) for i in instances])        # [n, 2, 2]
    origin = np.array([i.origin for i in instances])
    placed = xy[:, :1] * axes[at, 0] + xy[:, 1:] * axes[at, 1] + origin[at]
    return list(shapely.set_coordinates(plans.copy(), placed))


def _kept(plans: np.ndarray, abc: np.ndarray) -> np.ndarray:
    """What of each plan its plane keeps (``a*x + b*y <= c``, a row of ``abc`` each):
    all of it where the plane passes clear of it (a cut may hold a plane hundreds of
    metres off, where a wing ends), nothing where it lies wholly past it, else the plan
    less a square past the plane round it."""
    out = plans.copy()
    b = shapely.bounds(plans)                                   # nan: already empty
    corners = np.stack([b[:, [0, 1]], b[:, [0, 3]], b[:, [2, 1]], b[:, [2, 3]]], axis=1)
    side = np.einsum("nkj,nj->nk", corners, abc[:, :2]) - abc[:, 2:]
    live = ~np.isnan(side).any(axis=1)
    out[live & (side.min(axis=1) >= 0)] = Polygon()
    cut = live & (side.min(axis=1) < 0) & (side.max(axis=1) > 0)
    if cut.any():
        norm = np.hypot(abc[cut, 0], abc[cut, 1])
        n = abc[cut, :2] / norm[:, None]
        centre = corners[cut].mean(axis=1)
        on = centre - n * ((n * centre).sum(axis=1) - abc[cut, 2] / norm)[:, None]
        size = 4.0 * (b[cut, 2] - b[cut, 0] + b[cut, 3] - b[cut, 1] + 1.0)
        out[cut] = shapely.intersection(plans[cut], half_polygons(n, on, size))
    return out


def part_plan(db: PartDB, part: Part) -> BaseGeometry:
    """A part's plan in its placement frame: its walls' and roof's faces (all its
    faces when it names no such piece) projected on the ground; balconies, sills and
    trim are left out, so the infill runs on under them to the wall. Once per part."""
    key = (db.library_hash, part.id)
    if key not in _PLANS:
        pieces = part_pieces(db, part)
        mass = [p for p in pieces if p.name in MASS_PIECES] or list(pieces)
        tris = np.concatenate([p.vertices[p.faces] for p in mass])
        _PLANS[key] = footprint(tris)
    return _PLANS[key]


def back_eave(db: PartDB, part: Part) -> float:
    """How high a part's solid cross-section reaches at its back plane (its eave
    there, or a flat roof's top): the height an infill behind it must stay under."""
    key = (db.library_hash, part.id)
    if key not in _EAVES:
        sec = part.sec_in
        if not isinstance(sec, BaseGeometry) or sec.is_empty:
            return 0.0                           # no section: no height to stay under
        u0, v0, _u1, v1 = sec.bounds             # u out of the facade: its back is u0
        at = sec.intersection(LineString([(u0 + 0.02, v0 - 1.0), (u0 + 0.02, v1 + 1.0)]))
        _EAVES[key] = float(at.bounds[3]) if not at.is_empty else float(v1)
    return _EAVES[key]


def _rings(area: Polygon) -> tuple[tuple[tuple[float, float], ...], ...]:
    """The area's shell (anticlockwise) then its holes (clockwise), each without its
    closing point, rounded as the layout JSON rounds coordinates, and each starting at
    its least point (by x, then y): where GEOS starts a ring depends on how the area
    was found, and the same area must read the same in the JSON."""
    area = orient(area, sign=1.0)
    out = []
    for ring in (area.exterior, *area.interiors):
        rounded = [(round(x, COORD_DIGITS), round(y, COORD_DIGITS))
                   for x, y in ring.coords[:-1]]
        # two corners a hair apart round to one point: kept twice, its wall had two
        # faces of no area (28 of 1,081 rings of the demo district)
        pts = [p for i, p in enumerate(rounded) if p != rounded[i - 1]] or rounded[:1]
        first = pts.index(min(pts))
        out.append(tuple(pts[first:] + pts[:first]))
    return tuple(out)


def infill_pieces(infill: Infill, db: PartDB) -> tuple[Piece, ...]:
    """The infill's mesh in the layout frame: its flat top (the part's roof piece) and
    its sides down to the ground (its walls piece), facing out; no bottom, as a part
    has none on the ground."""
    pieces = part_pieces(db, db.part(infill.part))
    top_ref = next((p for p in pieces if p.name == TOP_PIECE), pieces[0])
    side_ref = next((p for p in pieces if p.name == SIDE_PIECE), pieces[0])
    rings = [np.asarray(r, dtype=float) for r in infill.rings]
    xy = np.concatenate(rings)
    ends = np.cumsum([len(r) for r in rings])
    top = triangulate_float64(xy, ends.astype(np.uint32)).reshape(-1, 3).astype(np.int64)
    a, b, c = xy[top[:, 0]], xy[top[:, 1]], xy[top[:, 2]]
    up = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    top = np.where((up < 0)[:, None], top[:, ::-1], top)
    top_v = np.c_[xy, np.full(len(xy), infill.z)]
    side_v: list[np.ndarray] = []
    side_f: list[np.ndarray] = []
    for r in rings:
        nxt = np.roll(r, -1, axis=0)
        n = len(r)
        quad = np.concatenate([np.c_[r, np.zeros(n)], np.c_[nxt, np.zeros(n)],
                               np.c_[nxt, np.full(n, infill.z)], np.c_[r, np.full(n, infill.z)]])
        i = np.arange(n) + sum(len(v) for v in side_v)
        side_v.append(quad)
        side_f.append(np.r_[np.c_[i, i + n, i + 2 * n], np.c_[i, i + 2 * n, i + 3 * n]])
    # the triangulation may skip a collinear corner: its point goes (a loose vertex)
    return (Piece(top_ref.name, top_ref.rgba, top_v, top).with_faces(top),
            Piece(side_ref.name, side_ref.rgba, np.concatenate(side_v),
                  np.concatenate(side_f)))

