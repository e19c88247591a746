"""Towers on a lot (the paper's Fig. 4): a ground floor, floors and a roof stacked to an
exact height, with the floor-area ratio (total floor area over lot area) inside an
interval, placed on the lot.

The stack is a sequence problem (:func:`~citysynth.pipeline.library_problems.tower_problem`);
this module adds the lot: only the parts whose outline (both their sections, a ground
floor's podium included) fits the lot, centred on it and turned to its longer side,
take part, and each solution becomes a :class:`~citysynth.export.layout.Layout` whose
instances are lifted floor by floor (``Instance.z``), so the USD, glTF and preview
writers show it like any other layout. A library's tower parts share one vertical axis
(their placement frame's origin); that axis lands on the lot's centre.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon, box
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient
from shapely.ops import polylabel

from citysynth.export.layout import Instance, Layout
from citysynth.parts_db import Part, PartDB
from citysynth.pipeline.city.config import MAX_TOWER_HEIGHT
from citysynth.pipeline.errors import UsageError
from citysynth.pipeline.layouts import Built
from citysynth.pipeline.library_problems import tower_problem
from citysynth.skeletons.clean import mean_width
from citysynth.solver import Problem, TooLargeError, solve
from citysynth.solver.compiled import Compiled, compile_problem, with_bounds
from citysynth.solver.diagnose import nearest, reach_given, spans_fit
from citysynth.solver.quantize import is_multiple

FIT_TOL = 0.01        # metres a part may reach past its lot (the lot's own rounding)
AREA_QUANTUM = 1.0    # m² of floor area the solver counts in (its rounding error is
#                       reported; the asked interval holds in m² all the same)
AREA_STEPS = 50       # ... finer for a narrower floor-area interval: one that many quanta wide
FINEST_AREA = 0.01    # m²: the finest quantum; an interval narrower than AREA_STEPS of it
#                       is refused where the floor areas are not multiples of AREA_QUANTUM


@dataclass(frozen=True)
class Lot:
    """A lot in the local metric frame: its outline, the tower axis's place on it (the
    centre) and the angle (degrees) its longer side makes with +X."""

    polygon: Polygon
    centre: tuple[float, float]
    angle: float
    frame: str = "local"

    @property
    def area(self) -> float:
        return float(self.polygon.area)

    @classmethod
    def square(cls, area: float) -> Lot:
        """A square lot of ``area`` m² centred on the origin (``--lot-area``)."""
        if not (math.isfinite(area) and area > 0):
            raise UsageError(f"--lot-area must be a positive number of m², got {area:g}")
        h = math.sqrt(area) / 2
        return cls(Polygon([(-h, -h), (h, -h), (h, h), (-h, h)]), (0.0, 0.0), 0.0)

    @classmethod
    def from_polygon(cls, poly: Polygon, frame: str) -> Lot:
        """A lot drawn as a polygon: centred on its centroid (on its most inland point
        when the centroid lies outside, as in an L-shaped lot), turned to the longer
        side of its minimum rotated rectangle (of two equal sides, the one nearer +X)."""
        c = poly.centroid
        lot = cls(poly, (round(c.x, 6), round(c.y, 6)), _long_side_angle(poly), frame)
        return lot if poly.contains(c) else lot.inland()

    def inland(self) -> Lot:
        """The lot with the tower axis on its most inland point (the centre of the
        widest circle inside it)."""
        c = polylabel(self.polygon, tolerance=0.01)
        return replace(self, centre=(round(c.x, 6), round(c.y, 6)))


def _long_side_angle(poly: Polygon) -> float:
    rect = poly.minimum_rotated_rectangle
    pts = list(rect.exterior.coords)
    best: tuple[float, float] | None = None       # (-length, |angle|) -> angle
    angle = 0.0
    for (x0, y0), (x1, y1) in zip(pts[:2], pts[1:3], strict=True):
        a = math.degrees(math.atan2(y1 - y0, x1 - x0))
        a = (a + 90.0) % 180.0 - 90.0             # a direction, not a heading: [-90, 90)
        key = (-round(math.hypot(x1 - x0, y1 - y0), 6), abs(round(a, 6)))
        if best is None or key < best:
            best, angle = key, a
    return round(angle, 6)


def _footprint(part: Part) -> BaseGeometry:
    """Everything of a stacked part's outline: its bottom and top sections."""
    return shapely.union(part.sec_in, part.sec_out)


def fits(part: Part, lot: Lot) -> bool:
    """Does the part, on the lot's axis and turned to it, stay inside the lot?"""
    g = affinity.rotate(_footprint(part), lot.angle, origin=(0.0, 0.0))
    g = affinity.translate(g, *lot.centre)
    return bool(lot.polygon.buffer(FIT_TOL, join_style="mitre").covers(g))


def _extent(g: BaseGeometry) -> tuple[float, float]:
    x0, y0, x1, y1 = g.bounds
    return x1 - x0, y1 - y0


def _fits_both(db: PartDB, lot: Lot, style: str | None) -> bool:
    """Does some ground floor and some roof of the library fit the lot?"""
    return all(any(fits(p, lot) for p in db.parts if p.cls == cls and
                   (style is None or p.style == style)) for cls in ("ground_floor", "roof"))


def fitted_lot(db: PartDB, lot: Lot, style: str | None) -> Lot | None:
    """The lot with its tower axis where a ground floor and a roof of the library fit:
    its centre, else its most inland point (a centroid a few metres beside a courtyard
    or between an easement's holes took no tower though a circle of 68 m fitted
    elsewhere); None where neither takes one."""
    for placed in (lot, lot.inland()):
        if _fits_both(db, placed, style):
            return placed
    return None


def check_lot(db: PartDB, lot: Lot, style: str | None) -> Lot:
    """The lot as :func:`fitted_lot` places its tower; one clear message when no ground
    floor or no roof fits it at all (the solver would only say there is no tower)."""
    placed = fitted_lot(db, lot, style)
    if placed is not None:
        return placed
    lot = lot.inland()
    for cls in ("ground_floor", "roof"):
        cands = [p for p in db.parts if p.cls == cls and (style is None or p.style == style)]
        if not cands or any(fits(p, lot) for p in cands):
            continue
        small = min(cands, key=lambda p: _footprint(p).envelope.area)
        lw, ld = _extent(affinity.rotate(lot.polygon, -lot.angle, origin=lot.centre))
        pw, pd = _extent(_footprint(small))
        inland = polylabel(lot.polygon, tolerance=0.01)
        wide = 2 * lot.polygon.boundary.distance(inland)   # its largest circle inside
        hole = " round a courtyard (a hole in it)" if lot.polygon.interiors else ""
        raise UsageError(f"no {cls.replace('_', ' ')} of the library {db.name!r} fits the "
                         f"lot ({lot.area:g} m², {lw:.1f} x {ld:.1f} m{hole}; the widest "
                         f"circle inside it is {wide:.1f} m across): the smallest, "
                         f"{small.id}, needs {pw:.1f} x {pd:.1f} m; give a larger lot")
    return lot


MAX_FAR = 500.0   # a 1,000 m tower covering its whole lot has a ratio of about 300


def far_interval(values: list[float], tolerance: float) -> tuple[float, float]:
    """``--far LO HI``, or ``--far X`` within ``tolerance`` (a share of X) either side."""
    if not values or len(values) > 2 or not all(math.isfinite(v) and v > 0 for v in values):
        raise UsageError("--far takes one positive ratio X or two, LO HI; got "
                         + " ".join(f"{v:g}" for v in values))
    if min(values) > MAX_FAR:   # 1e300 reached the solver as a floor area past counting
        raise UsageError(f"--far {min(values):g}: a floor-area ratio past any tower (one "
                         f"of {MAX_TOWER_HEIGHT:,.0f} m covering its whole lot has about "
                         f"300); ask for at most {MAX_FAR:g}")
    if len(values) == 1:
        if not 0 <= tolerance < 1:
            raise UsageError(f"--far-tolerance must be a share in [0, 1), got {tolerance:g}")
        x = values[0]
        return x * (1 - tolerance), x * (1 + tolerance)
    lo, hi = values
    if lo > hi:
        raise UsageError(f"--far LO HI: LO ({lo:g}) is above HI ({hi:g})")
    return lo, hi


def _said(x: float) -> str:
    """A height as asked: in six figures, or every figure it needs (120.00001)."""
    short = f"{x:g}"
    return short if float(short) == x else repr(float(x))


def _apart(x: float, asked: float) -> str:
    """``x`` with as few figures as tell it from ``asked`` (at least six): 120 m said
    against an ask of 120.00001 m reads as the ask met."""
    for digits in range(6, 16):
        text = f"{x:.{digits}g}"
        if text != f"{asked:.{digits}g}":
            return text
    return f"{x:.16g}"


def _why(details: list[dict], lot: Lot, area: tuple[float, float],
         reach: tuple[float, float] | None, height: float, lowest: float) -> str:
    """Why no tower fits, in heights and floor-area ratios (the solver's details, or
    :func:`_range_details` in their form, name its resources: height, floor_area;
    ``reach`` is the floor area towers of the asked height have,
    :func:`~citysynth.solver.diagnose.reach_given`). The ratio first: a height is often
    out of reach only because of it."""
    by = {d["constraint"]: d for d in details}
    said = []
    if reach is None and not by:   # the height alone: below the lowest, or off-quantum
        return "no stack of the tower parts has that height" + (
            f"; the lowest is {lowest:g} m (a ground floor and a roof)" if height < lowest
            else "")
    if reach is not None and (reach[0] > area[1] or reach[1] < area[0]):
        lo, hi = (x / lot.area for x in reach)
        said.append("every stack of the tower parts of that height has a floor-area ratio "
                    + (f"of at least {lo:.4g}" if hi == math.inf else
                       f"of {lo:.4g}" if lo == hi else f"between {lo:.4g} and {hi:.4g}"))
    elif "floor_area" in by:
        below, above = (by["floor_area"].get(k) for k in ("nearest_below", "nearest_above"))
        ratios = [f"{x / lot.area:.4g}" for x in (below, above) if x is not None]
        said.append("no stack of the tower parts of that height has that floor-area ratio"
                    + (f"; the nearest reach {' or '.join(ratios)}" if ratios else ""))
    if "height" in by:
        tall = " or ".join(f"{_apart(x, height)} m" for x in nearest(by["height"]))
        alone = by["height"].get("blocks") != "together" and not said
        said.append(("no stack of the tower parts has that height" if alone else
                     "with that floor-area ratio no stack of the tower parts has that height")
                    + (f"; the nearest are {tall} tall" if tall else ""))
    return "; ".join(said) or ("the tower parts meet the height and the floor-area ratio "
                               "each alone but not together; relax one")


def _most_floor_area(problem: dict, height: float) -> float:
    """A bound on the floor area of a tower of ``height`` metres: every metre of it at
    the densest part's floor area per metre."""
    dense = max(e["resources"]["floor_area"] / e["resources"]["height"]
                for e in problem["elements"] if e["resources"]["height"] > 0)
    return dense * height


def _lowest(problem: dict) -> float:
    """The lowest tower of a tower problem: its shortest ground floor and roof."""
    height = {e["id"]: e["resources"]["height"] for e in problem["elements"]}
    return min(height[x] for x in problem["front"]) + min(height[x] for x in problem["back"])


def _area_reach(cp: Compiled) -> tuple[float, float] | None:
    """The least and the most floor area (m²) of towers of the asked height."""
    return reach_given(cp, "height", "floor_area")


def _height_reach(cp: Compiled) -> tuple[float, float] | None:
    """The least and the most height (m) of towers of the asked floor area, whatever
    the height asked: it bounds how many parts a stack holds, and so how much floor
    area the tables reach (``Compiled.cap``), which would hide taller towers of that
    floor area. Bounded by :data:`MAX_TOWER_HEIGHT` instead, only towers taller than
    any citysynth stacks are left out."""
    h = cp.bounded.index("height")
    lo, hi = cp.lo.copy(), cp.hi.copy()
    lo[h], hi[h] = 0, math.floor(MAX_TOWER_HEIGHT / cp.quant[h].quantum)
    return reach_given(with_bounds(cp, lo, hi), "floor_area", "height")


def _range_details(cp: Compiled, area: tuple[float, float],
                   reach: tuple[float, float] | None, height: tuple[float, float],
                   lowest: float) -> list[dict] | None:
    """What :func:`_why` needs of an infeasible tower, from the range tables alone (a
    few milliseconds), or None when only the solver's diagnosis can tell it (it grows
    the whole box of heights and floor areas: 4 to 30 s for skyscrapers).

    They tell it when no stack has the height at all (``reach`` is None) or the floor
    areas of those that do (``reach``) all miss ``area``, and the heights of the stacks
    with that floor area lie all below or all above the asked: the nearest is then the
    tallest or the lowest of them, as the diagnosis finds it (its ``height`` detail).
    They cannot when towers of that height reach floor areas on both sides of the
    interval (some sum falls between), or those heights lie on both sides of the asked
    (the nearest is some height between)."""
    lo, hi = height
    if reach is None:
        if hi < lowest:
            return []   # below the lowest tower: _why names it
        if not spans_fit(cp, "height"):
            return None   # the tables did not fit: None proves nothing
    elif area[0] <= reach[1] and reach[0] <= area[1]:
        return None
    tall = _height_reach(cp)
    if tall is None:
        return []   # no stack of any height has that floor area (or not known): no more
    least, most = tall
    if most < lo:
        below, above = most, None
    elif least > hi:
        below, above = None, least
    else:
        return None
    if above is not None and above > MAX_TOWER_HEIGHT:
        return []   # a height the tower command would refuse is no help
    return [{"constraint": "height", "asked": [lo, hi], "nearest_below": below,
             "nearest_above": above, "blocks": "alone" if reach is None else "together"}]


def solve_tower(name: str, db: PartDB, lot: Lot, height: float | tuple[float, float],
                far: tuple[float, float], *, style: str | None = None, k: int = 1) -> Built:
    """The k best towers of exactly ``height`` metres (or of any height in the interval
    ``(lo, hi)``, a city zone's) and a floor-area ratio in ``far`` on ``lot``
    (infeasible, with the reason, when there is none)."""
    lo, hi = (height, height) if isinstance(height, int | float) else height
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise UsageError(f"--height must be a positive number of metres, got {lo:g}"
                         + (f"-{hi:g}" if hi != lo else ""))
    if hi > MAX_TOWER_HEIGHT:
        raise UsageError(f"a tower of {hi:.12g} m: citysynth stacks towers of at most "
                         f"{MAX_TOWER_HEIGHT:,.0f} m (the tallest building stands 828 m); "
                         "ask for a lower one")
    lot = check_lot(db, lot, style)
    t0 = time.perf_counter()
    area = (far[0] * lot.area, far[1] * lot.area)
    problem = tower_problem(db, hi, area, style=style, k=k, area_quantum=AREA_QUANTUM,
                            keep=lambda p: fits(p, lot))
    problem["constraints"]["height"] = [lo, hi]
    at = _said(lo) if lo == hi else f"{_said(lo)}-{_said(hi)}"
    ratio = f"{far[0]:g}" if far[0] == far[1] else f"{far[0]:g}-{far[1]:g}"   # not "10-10"
    problem["quantum"]["floor_area"] = area_quantum(problem, area, lambda: (
        f"a floor-area ratio of {ratio} on a {lot.area:g} m² lot"))
    asked = Problem.from_dict(problem)
    lowest = _lowest(problem)
    try:
        cp = compile_problem(asked)
        reach = _area_reach(cp)
        told = _range_details(cp, area, reach, (lo, hi), lowest)
        # when the range tables prove that no tower meets the ask, and say why, neither
        # the search nor the solver's diagnosis (seconds for a skyscraper) is needed
        result = solve(asked) if told is None else None
    except TooLargeError as exc:
        most = _most_floor_area(problem, hi)
        if area[0] <= most:   # the search itself: said in towers, not labels and quanta
            budget = f"the {exc.budget_mb:,.0f} MB" if exc.budget_mb else "the"
            raise TooLargeError(
                f"a tower of {at} m with a floor-area ratio of {ratio} on a "
                f"{lot.area:g} m² lot: its floors stack in too many ways to search for "
                f"the best within {budget} memory budget; ask for a lower height, a wider "
                "floor-area ratio interval or fewer towers (k)", need_mb=exc.need_mb,
                budget_mb=exc.budget_mb, k=exc.k) from None
        # a floor area more floors than a search can count, and range tables too large
        # to tell (a lot of 1e12 m² is told by them)
        return Built(name, "infeasible", reason=f"floor-area ratio {ratio} at "
                     f"{at} m on a {lot.area:g} m² lot: every stack of the tower parts of "
                     f"that height has a floor-area ratio of at most {most / lot.area:.4g}",
                     timings={"solve_s": time.perf_counter() - t0})
    t1 = time.perf_counter()
    timings = {"solve_s": t1 - t0}
    if result is None or result.status != "ok":
        why = _why(result.details if result is not None else told or [], lot, area, reach,
                   hi, lowest)
        return Built(name, "infeasible", reason=f"floor-area ratio {ratio} at "
                     f"{at} m on a {lot.area:g} m² lot: {why}", timings=timings)
    parts = db.by_id
    layouts = [tower_layout(name, rank, sol.sequence, sol.cost, parts, db, lot,
                            {"height": [lo, hi], "floor_area": list(area)}, far)
               for rank, sol in enumerate(result.solutions, start=1)]
    timings["layout_s"] = time.perf_counter() - t1
    return Built(name, "ok", layouts, timings=timings)


def area_quantum(problem: dict, area: tuple[float, float], asked: Callable[[], str]
                 ) -> float:
    """The m² the solver counts a tower's floor area in: :data:`AREA_QUANTUM`, or for a
    floor-area interval narrower than :data:`AREA_STEPS` of it, a finer quantum that
    many times narrower (at least :data:`FINEST_AREA`). Floor areas are measured (296.39,
    303.20375 m²) and rounded to the quantum, and the stacks whose rounded total meets
    the interval are checked in m²: an interval of a quantum or two let few of them
    through, and a 200 m tower with a floor area of ±1 m² was searched for 80 s and
    refused (in 1 s with 0.1 m² quanta). An interval too narrow even for the finest
    quantum (an exact ratio, ``--far-tolerance 0``) is refused at once, unless every
    floor area is a whole number of quanta, where the count is exact."""
    width = area[1] - area[0]
    areas = [e["resources"]["floor_area"] for e in problem["elements"]]
    if width >= AREA_STEPS * AREA_QUANTUM or all(is_multiple(a, AREA_QUANTUM) for a in areas):
        return AREA_QUANTUM
    if width < AREA_STEPS * FINEST_AREA:
        share = AREA_STEPS * FINEST_AREA / 2 / area[0] if area[0] > 0 else 0.0
        sample = ", ".join(f"{a:g} m²" for a in sorted(set(areas) - {0.0})[:3])
        raise UsageError(
            f"{asked()} asks for a floor area of {_interval(area)} m², an interval "
            f"narrower than {AREA_STEPS * FINEST_AREA:g} m²: the floor areas of the tower "
            f"parts ({sample}, ...) are measured, and a stack of them meets so narrow an "
            "interval only by chance; give a wider one (--far-tolerance "
            f"{_share(share)} or more, or --far LO HI; in a city.toml zone, far = [LO, HI])")
    return max(width / AREA_STEPS, FINEST_AREA)


def _interval(area: tuple[float, float]) -> str:
    lo, hi = (f"{x:.2f}" for x in area)
    return lo if lo == hi else f"{lo} to {hi}"


def _share(x: float) -> str:
    """A share rounded up to two figures (a tolerance given that is wide enough)."""
    if x <= 0:
        return "0.001"
    digits = 1 - math.floor(math.log10(x))
    return f"{math.ceil(x * 10 ** digits) / 10 ** digits:g}"


def tower_layout(name: str, rank: int, sequence: list[str], cost: float,
                 parts: dict[str, Part], db: PartDB, lot: Lot, asked: dict[str, list[float]],
                 far: tuple[float, float]) -> Layout:
    """One stacked solution on its lot: the ground floor and the roof are the tower's
    two key points, the floors its one stage; each part sits on the one below."""
    a = math.radians(lot.angle)
    x_axis, y_axis = (math.cos(a), math.sin(a)), (-math.sin(a), math.cos(a))
    instances, z = [], 0.0
    for i, pid in enumerate(sequence):
        p = parts[pid]
        key = 0 if i == 0 else 1 if i == len(sequence) - 1 else None
        instances.append(Instance(pid, p.cls, 0, None if key is not None else 0, key,
                                  x_axis, y_axis, lot.centre, z=round(z, 6)))
        z += p.length
    floor_area = math.fsum(p.floor_area or 0.0 for p in (parts[s] for s in sequence)
                           if p.cls != "roof")
    met = {"height": round(z, 6), "floor_area": round(floor_area, 6),
           "far": round(floor_area / lot.area, 6)}
    cx, cy = lot.centre
    keys = [{"part": sequence[j], "kind": parts[sequence[j]].cls, "xy": [cx, cy],
             "z": round(zz, 6), "joint": "part"}
            for j, zz in ((0, 0.0), (len(sequence) - 1, instances[-1].z))]
    structure: dict[str, Any] = {
        "name": name, "closed": False, "cost": cost, "keys": keys,
        "stages": [{"from": 0, "to": 1, "length": met["height"], "stretch": 1.0,
                    "parts": list(sequence), "asked": asked, "met": met,
                    "polyline": [[cx, cy, 0.0], [cx, cy, met["height"]]]}],
        "resources": met, "asked": {**asked, "far": list(far)},
        "lot": {"area": lot.area, "centre": [cx, cy], "angle": lot.angle,
                "polygon": [list(c) for c in lot.polygon.exterior.coords]},
    }
    if lot.polygon.interiors:   # a courtyard or an easement: Polygon(polygon, holes)
        structure["lot"]["holes"] = [[list(c) for c in ring.coords]
                                     for ring in lot.polygon.interiors]
    return Layout(name, rank, {"name": db.name, "hash": db.library_hash,
                               "quantum": db.quantum},
                  parts[sequence[0]].style, lot.frame, [structure], instances)


# --- towers on the lots of a city block --------------------------------------------------

MIN_LOT_SHARE = 0.4   # a lot smaller than this share of size x size is dropped
LARGEST_LOT = 1.5     # a lot is at most this many times size along each side
MIN_LOT_WIDTH = 0.5   # ... and one narrower on average than this share of size


def cut_lots(ground: BaseGeometry, size: float) -> list[Polygon]:
    """Roughly square lots of about ``size`` metres cut from ``ground`` (a block inset
    by its setback; a polygon or several): a grid turned to each polygon's longer side,
    as many cells along each side as fit best (so a cell is between 2/3 and 3/2 of
    ``size``), each clipped to the polygon; pieces too small or too thin for a tower
    (:data:`MIN_LOT_SHARE`, :data:`MIN_LOT_WIDTH`) are dropped. Coordinates to the
    millimetre, in a fixed order (row by row along the grid)."""
    lots: list[Polygon] = []
    for poly in shapely.get_parts(ground):
        if not isinstance(poly, Polygon) or poly.is_empty:
            continue
        angle = _long_side_angle(poly)
        c = poly.centroid
        g = affinity.rotate(poly, -angle, origin=c)
        x0, y0, x1, y1 = g.bounds
        nx, ny = max(1, round((x1 - x0) / size)), max(1, round((y1 - y0) / size))
        w, h = (x1 - x0) / nx, (y1 - y0) / ny
        for j in range(ny):
            for i in range(nx):
                cell = box(x0 + i * w, y0 + j * h, x0 + (i + 1) * w, y0 + (j + 1) * h)
                for piece in shapely.get_parts(g.intersection(cell)):
                    if (not isinstance(piece, Polygon) or piece.area < MIN_LOT_SHARE * size ** 2
                            or mean_width(piece) < MIN_LOT_WIDTH * size / 2):
                        continue
                    back = affinity.rotate(piece, angle, origin=c)
                    back = shapely.transform(back, lambda xy: np.round(xy, 3))
                    lots.append(orient(back.simplify(0.0), 1.0))
    return lots


def towers_layout(name: str, rank: int, towers: list[Layout]) -> Layout:
    """Several towers (one structure each, on its own lot) as one layout: a city
    block's, the i-th structure's instances numbered i."""
    structures, instances = [], []
    for si, t in enumerate(towers):
        structures += t.structures
        instances += [replace(inst, structure=si) for inst in t.instances]
    first = towers[0]
    return Layout(name, rank, first.library, first.style, first.frame, structures, instances)


def far_bounds(db: PartDB, style: str | None, height: tuple[float, float], size: float
               ) -> tuple[float, float]:
    """The lowest and highest floor-area ratio any tower of the library between
    ``height`` metres could have on any lot :func:`cut_lots` keeps for ``size``
    (between :data:`MIN_LOT_SHARE` of size x size and 1.5 size square): bounds, so an
    interval outside them is impossible on every lot."""
    parts = [p for p in db.parts if p.cls in ("ground_floor", "floor")
             and (style is None or p.style == style) and p.length > 0]
    roofs = [p.length for p in db.parts if p.cls == "roof" and (style is None or p.style == style)]
    if not parts or not roofs:
        return 0.0, 0.0
    density = [(p.floor_area or 0.0) / p.length for p in parts]
    lo = min(density) * max(height[0] - max(roofs), 0.0) / (LARGEST_LOT * size) ** 2
    hi = max(density) * height[1] / (MIN_LOT_SHARE * size ** 2)
    return lo, hi
