"""A street of complete buildings along a line (the paper's Fig. 7).

The street line (its centre line, or the facade line with ``offset`` 0) gives one
facade line per side, ``offset`` metres to its left or right. A facade line is cut
into runs where it turns by more than :data:`BEND` degrees; each run is a street front
solved on its own (:func:`~citysynth.pipeline.library_problems.street_front_problem`):
buildings filling its length within the stretch tolerance (the city's: a fraction of
the length or ``slack`` metres, whichever is larger, and at least half a quantum),
with the asked intervals on doors, balconies or windows. The buildings stand on the
side away from the street, their facades to it; each is stretched by its run's one
factor and set on the chord of the line between its two ends, so a run bent by a few
degrees is followed. Where a run turns toward its buildings, both runs stop short of
the bend by what their depth needs, so the rows meet like two street fronts at a
corner instead of overlapping.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString
from shapely.ops import substring

from citysynth.export.joints import HalfPlane, Placed, bisector
from citysynth.export.layout import Instance, Layout
from citysynth.export.place import y_range
from citysynth.parts_db import Part, PartDB
from citysynth.pipeline.errors import UsageError, shown
from citysynth.pipeline.layouts import Built
from citysynth.pipeline.library_problems import street_front_problem
from citysynth.skeletons import InputWarning
from citysynth.skeletons.errors import SkeletonError
from citysynth.solver import Problem, Result, TooLargeError, solve
from citysynth.solver.diagnose import nearest

BEND = 5.0           # degrees: a facade line turning more than this starts a new run
MIN_RUN = 6.0        # metres: shorter runs (between close bends) stay empty
SIDES = ("left", "right")


Locate = Callable[[Any], str]   # a local point in the input's coordinates, as text
RunProgress = Callable[[int, int], None]   # (runs solved, runs in all)


@dataclass(frozen=True)
class Run:
    """A straight (or gently bent) facade line, travelled with the buildings on its
    left (the canonical frame: facade toward -Y, to the right of +X)."""

    side: str
    index: int
    line: LineString

    @property
    def name(self) -> str:
        return f"{self.side}_{self.index}"


def _turns(coords: np.ndarray) -> np.ndarray:
    """Signed turn (degrees, + = left) at each inner vertex."""
    d = np.diff(coords, axis=0)
    a = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    return (np.diff(a) + 180.0) % 360.0 - 180.0


# an offset corner reaches at most this many offsets from the bend, else it is bevelled
# (at 10, a 170° turn's outer row ran 60 m past the street's end)
MITRE_LIMIT = 2.0
NOISE = (0.1, 0.3, 1.0)   # m: a line whose offset folds is straightened this much first


def facade_line(street: LineString, side: str, offset: float,
                locate: Locate | None = None) -> LineString:
    """The facade line of one side, travelled with the buildings on its left. Where the
    offset of a small kink folds (digitising noise: a 5 cm bump, offset 6 m, crosses
    itself), the line is straightened by up to :data:`NOISE` first; a real bend too
    tight for the offset is refused, saying where."""
    line = _offset(street, side, offset)
    for tol in NOISE:
        if isinstance(line, LineString) and not line.is_empty:
            break
        line = _offset(street.simplify(tol), side, offset)
    if not isinstance(line, LineString) or line.is_empty:
        raise SkeletonError(f"the street line offset by {offset:g} m to the {side} is not "
                            "one line (a bend tighter than the offset folds it, "
                            f"{_fold(street, side, locate)}); use a smaller --offset, or "
                            "give the street as two lines at the bend")
    return line if side == "left" else line.reverse()


def _offset(street: LineString, side: str, offset: float) -> shapely.Geometry:
    return street if offset == 0 else street.offset_curve(
        offset if side == "left" else -offset, join_style="mitre", mitre_limit=MITRE_LIMIT)


def _fold(street: LineString, side: str, locate: Locate | None) -> str:
    """Where a street's offset folds (``locate``: a local point in the input's
    coordinates): its sharpest turn toward that side, whose inside the offset crosses."""
    coords = np.asarray(street.coords)
    turns = _turns(coords)
    if not len(turns):
        return "at its ends"
    i = int(np.argmax(turns if side == "left" else -turns)) + 1
    xy = (float(coords[i][0]), float(coords[i][1]))
    return f"near {locate(xy)}" if locate else f"near ({xy[0]:.1f}, {xy[1]:.1f}) m"


def runs(street: LineString, side: str, offset: float, depth: float,
         locate: Locate | None = None) -> list[Run]:
    """The facade line of ``side`` cut at its bends, the run leaving a bend toward the
    buildings (a left turn) starting behind the row that runs on to it (:func:`_cut`). A
    street that closes on itself (a loop) is a ring: its closing point is a corner like
    the others (:func:`loop_runs`)."""
    if street.is_closed and len(street.coords) >= 4:
        return loop_runs(street, side, offset, depth)
    coords = np.asarray(facade_line(street, side, offset, locate).coords)
    out = _cut(coords, np.r_[0.0, _turns(coords), 0.0], side, depth)
    _warn_left_empty(LineString(coords), out, side, locate)
    return out


def _warn_left_empty(line: LineString, kept: list[Run], side: str,
                     locate: Locate | None) -> None:
    """Warn when most of a side stays empty because its bends come closer together
    than :data:`MIN_RUN` (a line that zig-zags: ±2 m every 2 m built two 9 m rows of a
    200 m street, exit 0 without a word), saying how much and where the longest empty
    stretch lies. Ends trimmed at a bend toward the buildings are no loss to tell."""
    total = line.length
    spans = sorted((line.project(shapely.Point(r.line.coords[0])),
                    line.project(shapely.Point(r.line.coords[-1]))) for r in kept)
    empty = total - sum(b - a for a, b in spans)
    if empty <= max(4 * MIN_RUN, total / 4):
        return
    gaps = [(b0 - a1, a1, b0) for (_a0, a1), (b0, _b1) in
            zip([(0.0, 0.0), *spans], [*spans, (total, total)], strict=True)]
    _gap, a, b = max(gaps)
    mid = line.interpolate((a + b) / 2)
    where = locate((mid.x, mid.y)) if locate else f"({mid.x:.1f}, {mid.y:.1f}) m"
    warnings.warn(f"the {side} side: {empty:.0f} m of its {total:.0f} m stay empty (e.g. "
                  f"near {where}): the line bends by more than {BEND:g}° every few metres, "
                  f"and a run between bends shorter than {MIN_RUN:g} m is not built; "
                  "straighten the line (simplify it in the GIS tool) to build there",
                  InputWarning, stacklevel=3)


def loop_runs(street: LineString, side: str, offset: float, depth: float) -> list[Run]:
    """The runs of one side of a street that closes on itself: its facade ring (the
    loop's area shrunk or grown by ``offset``: an offset curve of a closed line drops
    the sides at its ends) travelled with the buildings on its left and cut at its
    bends, the closing point included."""
    area = shapely.Polygon(street.coords)
    inside = (side == "left") == area.exterior.is_ccw    # the buildings within the loop
    ring = area.buffer(-offset if inside else offset, join_style="mitre", mitre_limit=MITRE_LIMIT)
    if not isinstance(ring, shapely.Polygon) or ring.is_empty:
        raise SkeletonError(f"the street loop offset by {offset:g} m to the {side} is not "
                            "one ring (the loop is narrower than the offset); use a smaller "
                            "--offset")
    pts = np.asarray(shapely.geometry.polygon.orient(ring, 1.0 if inside else -1.0)
                     .exterior.coords)[:-1]
    return _ring_cut(pts, side, depth, BEND)


def _ring_cut(pts: np.ndarray, side: str, depth: float, bend: float) -> list[Run]:
    """A closed facade line (``pts``, the first point not repeated, travelled with the
    buildings on its left) cut at its turns of more than ``bend`` degrees, from its
    sharpest corner, each run leaving a left turn starting behind the one before."""
    closed = np.vstack([pts, pts[:1], pts[1:2]])
    turns = np.r_[0.0, _turns(closed)]            # turns[i]: at vertex i (i >= 1)
    turns[0] = turns[len(pts)]
    start = int(np.argmax(np.abs(turns[: len(pts)])))
    order = np.r_[np.arange(start, len(pts)), np.arange(0, start + 1)]
    return _cut(pts[order], turns[order], side, depth, bend)


def _cut(coords: np.ndarray, turns: np.ndarray, side: str, depth: float,
         bend: float = BEND) -> list[Run]:
    """A facade line cut into runs at the vertices turning by more than ``bend``
    degrees (its two ends always). At a left turn (toward the buildings: a block's
    outer corner) the run arriving runs on to the corner and the one leaving starts
    behind its row (:func:`behind`): the corner is built, the first row's end wall on
    the second street. (Both were trimmed by the depth times the half-turn's tangent,
    which left a square the rows' depth wide open at a square corner, two blank end
    walls facing each other across it.) ``turns`` holds the turn at every vertex, the
    ends' included (0 for a line's ends, the corner's own turn for a ring's). Runs
    shorter than :data:`MIN_RUN` stay empty."""
    cuts = [0] + [i for i in range(1, len(coords) - 1) if abs(turns[i]) > bend] + \
        [len(coords) - 1]
    out: list[Run] = []
    for a, b in zip(cuts, cuts[1:], strict=False):
        line = LineString(coords[a:b + 1])
        lo = behind(float(turns[a]), depth)
        if line.length - lo < MIN_RUN:
            continue
        out.append(Run(side, len(out), substring(line, lo, line.length)))
    return out


def behind(turn: float, depth: float) -> float:
    """How far along the run leaving a left turn of ``turn`` degrees its row starts so
    as to stand clear of the row (``depth`` deep) that runs on to the corner: at a square
    corner the depth (its first building against the other's back), at a gentler turn
    the depth times the turn's sine (the other's end lies across the corner), at a
    sharper one times the half-turn's tangent (its back reaches past the other's end).
    0 at a right turn (away from the buildings: the rows fan apart behind)."""
    if turn <= 0.0:
        return 0.0
    t = math.radians(min(turn, 179.0))
    return depth * (math.sin(t) if turn <= 90.0 else math.tan(t / 2))


RING_SIMPLIFY = 0.25  # m: a block outline is straightened this much before it is cut
RING_BEND = 0.01     # degrees: ... and cut at every turn left (rows on chords of a bent
#                      run would overlap behind a left turn: depth² tan(turn) / 2)
FOLD = math.sin(math.radians(RING_BEND))   # a row's chords turning by more: folded


def ring_runs(polygon: shapely.Polygon, depth: float, side: str = "ring") -> list[Run]:
    """The runs of a polygon's rings, the buildings inside (a block's sides: each ring
    travelled with the polygon on its left, from its sharpest corner), straightened
    by :data:`RING_SIMPLIFY` and cut at every turn, as a street's sides at their left
    turns: at each convex corner one row runs on to the corner and the next starts
    behind it, so neighbouring runs' rows meet without overlapping; ``side`` names
    them (``ring_0``, ...)."""
    poly = shapely.geometry.polygon.orient(polygon.simplify(RING_SIMPLIFY), 1.0)
    out: list[Run] = []
    for ring in [poly.exterior, *poly.interiors]:
        for r in _ring_cut(np.asarray(ring.coords)[:-1], side, depth, RING_BEND):
            out.append(Run(side, len(out), r.line))
    return out


def clear_runs(all_runs: list[Run], ground: shapely.Geometry, depth: float,
               tol: float = 0.5) -> list[Run]:
    """The runs whose rows (``depth`` deep on their left) stand on ``ground`` without
    crossing each other: longest first, a run whose band would leave the ground or
    cover a kept band by more than ``tol`` m² is shortened to its longest piece that
    does not (:func:`_fit`; a notch near a corner, a block narrower than two rows), or
    stays empty. The kept runs, in their given order."""
    kept = _Bands(max(4 * depth, 20.0))
    keep: dict[int, Run] = {}
    for i in sorted(range(len(all_runs)), key=lambda i: (-all_runs[i].line.length, i)):
        line = _fit(all_runs[i].line, ground, kept, depth, tol)
        if line is None:
            continue
        keep[i] = Run(all_runs[i].side, all_runs[i].index, line)
        kept.add(_band(line, depth))
    return [keep[i] for i in sorted(keep)]


class _Bands:
    """The kept rows' bands, filed by the grid cells their boxes cover: a run is
    tested against the bands near it (the ground left free, cut by every band kept so
    far, grew a hole a run: a zigzag street of 10,000 runs took minutes)."""

    def __init__(self, cell: float) -> None:
        self.cell = cell
        self.bands: list[shapely.Geometry] = []
        self.cells: dict[tuple[int, int], list[int]] = {}

    def _cells(self, g: shapely.Geometry) -> list[tuple[int, int]]:
        x0, y0, x1, y1 = (math.floor(v / self.cell) for v in g.bounds)
        return [(x, y) for x in range(x0, x1 + 1) for y in range(y0, y1 + 1)]

    def add(self, band: shapely.Geometry) -> None:
        for c in self._cells(band):
            self.cells.setdefault(c, []).append(len(self.bands))
        self.bands.append(band)

    def near(self, g: shapely.Geometry) -> shapely.Geometry:
        """The union of the kept bands that meet ``g`` (empty: none)."""
        ids = sorted({i for c in self._cells(g) for i in self.cells.get(c, ())})
        return shapely.union_all([self.bands[i] for i in ids if self.bands[i].intersects(g)])


def _band(line: LineString, depth: float) -> shapely.Geometry:
    return line.buffer(depth, single_sided=True, cap_style="flat", join_style="mitre")


def _fit(line: LineString, ground: shapely.Geometry, kept: _Bands, depth: float,
         tol: float) -> LineString | None:
    """The longest piece of ``line`` whose band stays on ``ground`` off the ``kept``
    bands: the span where it leaves (a notch near a corner, a row across the block) is
    cut out, the longer end kept; None when less than :data:`MIN_RUN` is left."""
    for _ in range(4):
        band = _band(line, depth)
        off = shapely.union(band.difference(ground), band.intersection(kept.near(band)))
        bad = [g for g in shapely.get_parts(off) if g.area > tol / 10]
        if sum(g.area for g in bad) <= tol:
            return line
        at = [line.project(shapely.Point(c)) for g in bad for c in g.exterior.coords]
        lo, hi = min(at), max(at)
        a, b = max(((0.0, lo), (hi, line.length)), key=lambda ab: ab[1] - ab[0])
        if b - a < MIN_RUN:
            return None
        line = substring(line, a, b)
    return None


def building_depth(parts: list[Part]) -> float:
    """How far the deepest building reaches back from its facade."""
    return max(-min(shapely.bounds(p.sec_in)[0], shapely.bounds(p.sec_out)[0]) for p in parts)


def tolerance(length: float, quantum: float, stretch: float, slack: float) -> float:
    """How closely a run's length must be met (the city's rule)."""
    return max(quantum / 2, slack, stretch * length)


@dataclass(frozen=True)
class Loosen:
    """How a refusal tells the user to loosen what they asked, in the words of where
    they asked it: the street command's flags, or a city's settings (a row zone), so the
    advice names a knob the user has."""

    length: str = "allow more --stretch or --slack"
    interval: str = "the {name} interval"     # the interval of a resource {name}


CITY_LOOSEN = Loosen("allow more stretch or slack in city.toml",
                     "the {name} interval of per_side in city.toml")


@dataclass(frozen=True)
class StreetAsk:
    """What a street asks: sides, offset, stretch tolerance, intervals, style, k, and
    how to advise loosening them."""

    sides: tuple[str, ...]
    offset: float = 0.0
    stretch: float = 0.005
    slack: float = 0.3
    constraints: tuple[tuple[str, float, float], ...] = ()
    style: str | None = None
    k: int = 1
    loosen: Loosen = Loosen()


def solve_street(name: str, street: LineString, db: PartDB, ask: StreetAsk,
                 frame: str = "local", locate: Locate | None = None, source: str = "",
                 progress: RunProgress | None = None) -> Built:
    """The k best rows of buildings along ``street`` (each run's i-th best, or its last
    when it has fewer), or infeasible with the first run that has none (``locate``: a
    local point in the input's coordinates, as text, to say where that run lies;
    ``source``: the line's file, which a refusal names; ``progress``: told as runs
    are solved, see :func:`solve_runs`)."""
    parts = db.select("building", ask.style)
    if not parts:
        styles = sorted({p.style for p in db.select("building")})
        has = (f"; it has them in {', '.join(styles)}" if styles else
               "; a street is filled with parts of class building, and it has none")
        raise UsageError(f"the library {db.name!r} has no complete buildings"
                         f"{f' of style {shown(ask.style)}' if ask.style else ''}{has}")
    depth = building_depth(parts)
    with warnings.catch_warnings(record=True) as told:   # said only if something is built
        warnings.simplefilter("always", InputWarning)
        found = [r for side in ask.sides for r in runs(street, side, ask.offset, depth, locate)]
    for w in told if found else []:
        warnings.warn(w.message, w.category, stacklevel=2)
    all_runs = _apart(found, depth, locate)
    if not all_runs:
        bends = int((np.abs(_turns(np.asarray(street.coords))) > BEND).sum())
        raise UsageError(f"{source or name}: the street line has no straight run of at least "
                         f"{MIN_RUN:g} m to build on"
                         + (f" (it bends by more than {BEND:g}° at {bends} of its points "
                            f"over its {street.length:.0f} m: straighten it, e.g. simplify "
                            "it in the GIS tool)" if bends > 1 else ""))
    return solve_runs(name, all_runs, db, ask, frame, locate, progress)


def _apart(all_runs: list[Run], depth: float, locate: Locate | None) -> list[Run]:
    """The runs with their rows kept off each other's ground (a street that turns back
    on itself closer than two building depths, a U or a hairpin, would stack them):
    :func:`clear_runs` on open ground, longest first; each run it shortens or leaves
    empty is told as a warning, saying where."""
    if not all_runs:
        return all_runs
    reach = 4 * depth + 10.0    # open ground round every run, as a box grown from the
    # runs' bounds (the box of a straight street along an axis is flat: grown after, by
    # buffer, it lost most of the street)
    x0, y0, x1, y1 = shapely.bounds(shapely.union_all([r.line for r in all_runs])).tolist()
    ground = shapely.box(x0 - reach, y0 - reach, x1 + reach, y1 + reach)
    kept = clear_runs(all_runs, ground, depth)
    by_name = {r.name: r for r in kept}
    where = locate or (lambda xy: f"({xy[0]:.1f}, {xy[1]:.1f})")
    for r in all_runs:
        k = by_name.get(r.name)
        if k is not None and k.line.length >= r.line.length - 0.01:
            continue
        mid = r.line.interpolate(0.5, normalized=True)
        what = (f"shortened from {r.line.length:.1f} m to {k.line.length:.1f} m"
                if k is not None else "left empty")
        warnings.warn(f"the {r.side} side's run at {where((mid.x, mid.y))} is {what}: its "
                      "buildings would stand on those of another run (the street comes "
                      f"back within {2 * depth:.0f} m of itself)", InputWarning, stacklevel=3)
    return kept


def _blamed(problem: dict, ask: StreetAsk) -> list[str] | None:
    """When the run's length alone can be filled, the asked intervals that each keep
    it from being filled (e.g. doors in [1, 2]: too few doors for 80 m of buildings),
    with the lengths such rows reach; None when the length itself is the cause. The
    solver's diagnosis keeps every maximum, so it blames the length for them."""
    cons = problem["constraints"]

    def fails(*names: str) -> Result | None:
        r = solve(Problem.from_dict({**problem, "k": 1,
                                     "constraints": {n: cons[n] for n in names}}))
        return None if r.status == "ok" else r

    if not ask.constraints or fails("length"):
        return None
    said = []
    for a, lo, hi in ask.constraints:
        r = fails("length", a)
        if r is not None:
            near = [x for d in r.details if d["constraint"] == "length" for x in nearest(d)]
            said.append(f"its length cannot be filled by {_kind(ask)} with {a} in "
                        f"[{lo:g}, {hi:g}]" + (f" (such rows measure "
                                               f"{' or '.join(f'{x:g}' for x in near)} m)"
                                               if near else "")
                        + f"; widen {ask.loosen.interval.format(name=a)} or leave it out")
    return said or ["its length can be filled, and each asked interval met, but not all "
                    "together; widen one of the intervals"]


FAR_PAST, SOME = 2.0, 10.0   # an asked count past twice (and 10 more) what a row can have


def _past_reach(problem: dict, cons: dict, ask: StreetAsk) -> list[str]:
    """The asked counts no row of the run's length comes near, found at once: no
    building has more doors (windows, ...) a metre than the densest, nor fewer than the
    sparsest, so a row of L metres has between those rates times L. Far past them (10
    million windows on 200 m), the solver searched minutes for a table of counts no row
    reaches, or was refused in its own words (``--max-memory``, a quantum) that
    ``street`` has no option for. Near them, the solver's answer says more (the rows
    the count allows measure 48 m), so it is left to say it."""
    lo_len, hi_len = cons["length"]
    said = []
    for a, lo, hi in ask.constraints:
        rates = [e["resources"].get(a, 0.0) / e["resources"]["length"]
                 for e in problem["elements"] if e["resources"].get("length", 0) > 0]
        if not rates:
            continue
        most, least = max(rates) * hi_len, min(rates) * lo_len
        if lo > FAR_PAST * most + SOME or FAR_PAST * hi + SOME < least:
            bound = f"at most {math.floor(most + 1e-9):,}" if lo > most \
                else f"at least {math.ceil(least - 1e-9):,}"
            said.append(f"its {a} in [{lo:g}, {hi:g}] cannot be met by {_kind(ask)}, "
                        f"which make {bound} there; widen "
                        f"{ask.loosen.interval.format(name=a)}")
    return said


def _kind(ask: StreetAsk) -> str:
    """The buildings a street asks for, as a refusal names them."""
    return f"the {ask.style} buildings" if ask.style else "the buildings"


def _why(run: Run, details: list[dict], ask: StreetAsk, locate: Locate | None = None,
         blamed: list[str] | None = None) -> str:
    """Why a run takes no row of buildings, in metres and the asked intervals (the
    solver's details: each blocking constraint and the nearest totals it reaches, or
    what :func:`_blamed` found), and where the run lies when ``locate`` can say it in
    the input's coordinates."""
    ends = "" if locate is None else (f", from {locate(run.line.coords[0])} to "
                                      f"{locate(run.line.coords[-1])}")
    run_name = (f"the {run.side} side's run {run.index + 1}" if run.side in SIDES
                else f"{run.side} {run.index + 1}")    # a block's own side, in a row zone
    where = f"{run_name} ({run.line.length:.1f} m{ends})"
    if blamed:
        return f"{where}: " + "; ".join(blamed)
    said = []
    kind = _kind(ask)
    for d in details:
        near = " or ".join(f"{x:g}" for x in nearest(d))
        if d["constraint"] == "length":
            said.append(f"no row of {kind} fits its length" +
                        (f" (the nearest rows measure {near} m); {ask.loosen.length}"
                         if near else ""))
        else:
            lo, hi = d["asked"]
            said.append(f"its {d['constraint']} in [{lo:g}, {hi:g}] cannot be met by {kind}"
                        + (f", which make {near} there" if near else "") +
                        f"; widen {ask.loosen.interval.format(name=d['constraint'])}")
    return f"{where}: " + ("; ".join(said) or f"{kind} meet its length and the asked "
                           "intervals each alone but not together; relax one")


def _street_too_large(name: str, run: Run, ask: StreetAsk,
                      exc: TooLargeError) -> TooLargeError:
    """A street run too large to fill, in a street user's words: the solver's own text
    speaks of partial sequences, quanta and --max-memory, which ``street`` does not
    have (a 100 km line with doors and windows intervals was told to give a quantum)."""
    budget = f"{exc.budget_mb:,.0f} MB" if exc.budget_mb is not None else "the memory"
    if exc.k is not None:
        text = (f"{name}: k = {exc.k:,} rows of buildings would take at least "
                f"{(exc.need_mb or 0) / 1024:,.1f} GB to keep, over the {budget} budget; "
                "ask for fewer (--k)")
    else:
        asked = ", ".join(a for a, _lo, _hi in ask.constraints)
        fix = (f"narrow or drop the intervals on {asked}, or split the street into "
               "shorter lines" if asked else "split the street into shorter lines")
        text = (f"{name}: filling its {run.line.length:,.0f} m run with buildings would "
                f"take more than the {budget} budget; {fix}")
    return TooLargeError(text, need_mb=exc.need_mb, budget_mb=exc.budget_mb, k=exc.k)


def solve_runs(name: str, all_runs: list[Run], db: PartDB, ask: StreetAsk,
               frame: str = "local", locate: Locate | None = None,
               progress: RunProgress | None = None) -> Built:
    """The k best rows of buildings on ``all_runs`` (each run solved on its own; see
    :func:`solve_street`); ``progress`` is told after each run (a street of 20,000
    runs takes half a minute)."""
    t0 = time.perf_counter()
    solved = []
    # one problem for every run, parsed once: the runs differ in their length only (a
    # problem built and parsed a run, 0.1 s each, took a street of 10,000 runs minutes)
    base = street_front_problem(db, 0.0, style=ask.style, k=ask.k)
    parsed: Problem | None = None
    for run in all_runs:
        tol = tolerance(run.line.length, db.quantum, ask.stretch, ask.slack)
        cons = {"length": [run.line.length - tol, run.line.length + tol],
                **{a: [lo, hi] for a, lo, hi in ask.constraints}}
        problem = {**base, "constraints": cons}
        far = _past_reach(problem, cons, ask)
        if far:
            return Built(name, "infeasible", reason=_why(run, [], ask, locate, far),
                         timings={"solve_s": time.perf_counter() - t0})
        parsed = Problem.from_dict(problem) if parsed is None else parsed.with_constraints(
            {r: (float(lo), float(hi)) for r, (lo, hi) in cons.items()})
        try:
            r = solve(parsed)
        except TooLargeError as exc:
            raise _street_too_large(name, run, ask, exc) from None
        if r.status != "ok":
            blamed = (_blamed(problem, ask) if not r.details or any(
                d["constraint"] == "length" for d in r.details) else None)
            return Built(name, "infeasible", reason=_why(run, r.details, ask, locate, blamed),
                         timings={"solve_s": time.perf_counter() - t0})
        solved.append(r.solutions)
        if progress is not None:
            progress(len(solved), len(all_runs))
    t1 = time.perf_counter()
    index = db.by_id
    count = max(len(s) for s in solved)
    layouts = [street_layout(name, i + 1, all_runs, [s[min(i, len(s) - 1)] for s in solved],
                             index, db, ask, frame)
               for i in range(count)]
    return Built(name, "ok", layouts, timings={"solve_s": t1 - t0,
                                               "layout_s": time.perf_counter() - t1})


def _place(run: Run, si: int, sequence: list[str], parts: dict[str, Part]
           ) -> tuple[list[Instance], float]:
    """Each building on the chord of the run between its (stretched) ends."""
    solved = math.fsum(parts[x].length for x in sequence)
    stretch = run.line.length / solved
    out, at = [], 0.0
    chords = []
    for pid in sequence:
        p = parts[pid]
        p0 = run.line.interpolate(at * stretch)
        at += p.length
        p1 = run.line.interpolate(at * stretch)
        c = np.array([p1.x - p0.x, p1.y - p0.y])
        u = c / float(np.linalg.norm(c))
        n = np.array([-u[1], u[0]])
        x_axis = c / p.length
        chords.append((u, np.array([p1.x, p1.y])))
        out.append(Instance(pid, p.cls, si, 0, None, (float(x_axis[0]), float(x_axis[1])),
                            (float(n[0]), float(n[1])), (p0.x, p0.y)))
    return _folded(out, chords, parts), stretch


def _folded(row: list[Instance], chords: list[tuple[np.ndarray, np.ndarray]],
            parts: dict[str, Part]) -> list[Instance]:
    """A row whose chords bend (a run bent by less than :data:`BEND`, a curved street):
    each pair of neighbours meets on the bisector plane of their chords through the
    point they share, each keeping its own side, as a block's modules do at a fold.
    Standing on chords, their backs overlapped where the run turns toward the buildings
    (4.4 % of the ground of a row round a 120 m arc), and fanned apart where it turns
    away (a wedge open at the back, as much ground again): there both are extended up
    to the plane (a concave fold) before the cut."""
    halves: list[list[HalfPlane]] = [[] for _ in row]
    for i in range(len(row) - 1):
        (u, at), (v, _end) = chords[i], chords[i + 1]
        turn = u[0] * v[1] - u[1] * v[0]
        if abs(turn) <= FOLD:     # straight on
            continue
        b, p = bisector(u, v), (float(at[0]), float(at[1]))
        away = bool(turn < 0)
        halves[i].append(HalfPlane((float(b[0]), float(b[1])), p, extends=away))
        halves[i + 1].append(HalfPlane((float(-b[0]), float(-b[1])), p, extends=away))
    out = []
    for inst, h in zip(row, halves, strict=True):
        if h:
            part = parts[inst.part]
            placed = Placed(inst.part, inst.cls, part.length, y_range(part),
                            inst.structure, inst.stage, inst.key,
                            np.array([inst.x_axis, inst.y_axis]).T, np.array(inst.origin), h)
            inst = replace(inst, cut=placed.cut())
        out.append(inst)
    return out


def street_layout(name: str, rank: int, all_runs: list[Run], solutions: list,
                  parts: dict[str, Part], db: PartDB, ask: StreetAsk, frame: str) -> Layout:
    structures, instances = [], []
    for si, (run, sol) in enumerate(zip(all_runs, solutions, strict=True)):
        placed, stretch = _place(run, si, sol.sequence, parts)
        instances += placed
        asked = {a: [lo, hi] for a, lo, hi in ask.constraints}
        structures.append({
            "name": run.name, "closed": False, "cost": sol.cost, "keys": [],
            "resources": dict(sol.resources), "asked": asked,
            "stages": [{"from": 0, "to": 1, "front": "right",   # the mass left of travel
                        "length": run.line.length, "stretch": stretch,
                        "parts": list(sol.sequence), "asked": asked,
                        "met": dict(sol.resources),
                        "polyline": [list(c) for c in run.line.coords]}]})
    styles = sorted({parts[i.part].style for i in instances})
    return Layout(name, rank, {"name": db.name, "hash": db.library_hash,
                               "quantum": db.quantum},
                  styles[0] if len(styles) == 1 else "+".join(styles), frame,
                  structures, instances)
