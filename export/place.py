"""Put a solved structure back on its skeleton: every part's placement, then checks.

Along a stage, the key part at its start reaches in by its leg, the key part at its
end by its leg, and the middle parts fill what lies between, all stretched by the one
factor that absorbs the quantisation (the solver met the length within its interval;
the stage's ``stretch`` reports the factor). A corner part is placed by the affine map
that sends its legs' canonical directions onto the skeleton's edges, each leg
stretched with its own stage, which also adapts it to an angle a few degrees off its
own. T parts stay rigid (their main legs are collinear, so one linear map cannot
stretch them by two factors); the rest of their stages absorbs the difference. A stage
whose facades face the left of travel is placed mirrored (the canonical facade faces
the right, -Y).

Where no corner part stands at a corner, the key point is a **mitre joint** (a key
element :func:`~citysynth.export.plan.is_joint`, whose legs are a quantum or a few):
the last module of the incoming stage and the first of the outgoing one are extended
over the joint's legs to the corner and cut on the plane that bisects it
(:mod:`citysynth.export.joints`). A module that
spans a **bend** of its stage is **folded** there: one instance per straight run,
each cut on the bend's bisector plane, instead of one instance along the chord.

Then every layout is checked, and a failed check is an error: each stage's parts
measure its skeleton length within the stage's length interval, consecutive parts meet
(gap or overlap under 1 mm), facades end on the skeleton and face the stage's front
side (so the mass lies behind the skeleton line, never on the street side).
"""

from __future__ import annotations

import itertools
from bisect import bisect_right
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol, cast

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from citysynth.export.errors import ExportError
from citysynth.export.ground import GRID, polygons_in
from citysynth.export.infill import Roof, plan_infill
from citysynth.export.joints import (
    EXTEND_MARGIN,
    MAX_EXTEND_DEPTHS,
    HalfPlane,
    Placed,
    behind,
    bisector,
    clipped_plan,
    concave_reach,
    facade_span,
    half_polygon,
    is_convex,
    joint_halves,
)
from citysynth.export.layout import Instance, Layout
from citysynth.export.party import Segment, party_halves, plan_hull
from citysynth.export.plan import FILLED, Front, PlacementPlan, PlanStage, is_joint
from citysynth.export.t_poses import SEP, main_depth, part_leg, t_pose
from citysynth.parts_db import Part, PartDB

TOL = 0.001          # metres: the largest gap, overlap or offset the checks accept
CHORD_TOL = 0.1      # metres a T's leg may stand off the bends it spans before it folds


class _Path:
    """A stage's polyline, by arc length."""

    def __init__(self, points):
        self.p = np.asarray(points, dtype=float)
        seg = np.diff(self.p, axis=0)
        self.len = np.hypot(seg[:, 0], seg[:, 1])
        self.cum = np.concatenate([[0.0], np.cumsum(self.len)])
        self.dir = seg / self.len[:, None]
        self._cum = self.cum.tolist()    # for bisect: a block asks hundreds of times

    @property
    def length(self) -> float:
        return float(self.cum[-1])

    def segment(self, s: float) -> int:
        """The segment arc length s lies on (the first or last beyond the ends)."""
        return min(max(bisect_right(self._cum, s) - 1, 0), len(self._cum) - 2)

    def at(self, s: float) -> np.ndarray:
        i = self.segment(s)
        return self.p[i] + self.dir[i] * (s - self.cum[i])

    def bends_within(self, s0: float, s1: float) -> list[int]:
        """Indices of the inner vertices strictly inside the arc-length range."""
        lo, hi = s0 + TOL, s1 - TOL
        return [i for i in range(1, len(self._cum) - 1) if lo < self._cum[i] < hi]

    def distances(self, q: np.ndarray) -> np.ndarray:
        """Distance from each point q [m, 2] to the polyline, in one pass."""
        rel = q[:, None, :] - self.p[None, :-1]                      # [m, segments, 2]
        t = np.clip((rel * self.dir).sum(axis=2), 0, self.len)
        off = rel - self.dir * t[..., None]
        return np.hypot(off[..., 0], off[..., 1]).min(axis=1)


def _left(u) -> np.ndarray:
    return np.array([-u[1], u[0]])


def _geom_length(p: Part) -> float:
    """The length of a straight part's geometry in its placement frame."""
    return float(p.legs_measured[0] * p.scale)


def _leg(p: Part, leg: int) -> float:
    """How far a key part reaches along one of its legs (its geometry, not snapped)."""
    if p.cls in ("end_left", "end_right"):
        return _geom_length(p)
    return float(p.legs_measured[leg])


def _depth(p: Part, element: str) -> float:
    """How far behind the key point a T part's own key point lies: its main range's
    depth when it is turned over (the ``street`` pose), else 0."""
    if p.cls != "t_junction" or not t_pose(element).street:
        return 0.0
    return main_depth(p.sec_in)


def y_range(p: Part) -> tuple[float, float]:
    """A part's extent across its facade line (placement-frame Y): overhang to depth."""
    sec = p.sec_in
    if not isinstance(sec, BaseGeometry) or sec.is_empty:
        return (0.0, 0.0)
    u0, _v0, u1, _v1 = sec.bounds      # u points out of the facade (-Y)
    return (-u1, -u0)


def layout(name: str, rank: int, plans: Sequence[PlacementPlan],
           solutions: Sequence[StructureSolution], db: PartDB, infill: Roof = "pockets",
           party: Sequence[Segment] = ()) -> Layout:
    """The layout of ``solutions[i]`` (the solver's answer for a structure: the part at
    each key point and the fillers of each stage) on ``plans[i]``, checked. The ground
    inside its outline no part covers gets a flat roof as ``infill`` says (all of it
    on a footprint, the pockets too narrow for a yard on a street block: see
    :mod:`~citysynth.export.infill`); ``party`` walls (a footprint's
    stretches shared with a neighbour) stop the parts reaching into it
    (:mod:`~citysynth.export.party`)."""
    parts = db.by_id
    out = Layout(name, rank, {"name": db.name, "hash": db.library_hash,
                              "quantum": db.quantum},
                 plans[0].style if plans else "", plans[0].frame if plans else "", [])
    placers = [_Placer(si, plan, sol, parts)
               for si, (plan, sol) in enumerate(zip(plans, solutions, strict=True))]
    for placer in placers:
        placer.place()
    _medial_between(placers, db)
    for placer in placers:
        placer.medial_extensions()
    _reopen(placers)
    for placer in placers:
        instances = [p.instance() for p in placer.placed]
        _check(placer.plan, placer.record, parts, instances, placer.sol.keys,
               [res.get("length") for res in placer.sol.resources], db.quantum)
        # checked before: a party wall stops the facades beside it short of the line
        if party_halves(placer.placed, party, db):
            instances = [p.instance() for p in placer.placed]
        out.instances.extend(instances)
        out.structures.append(_summary(placer.plan, placer.sol, placer.record))
    out.infill = plan_infill(out.structures, out.instances, db, infill)
    return out


class StructureSolution(Protocol):
    """What export reads of a solved structure (the solver's ``StructureSolution``)."""

    keys: list[str]
    stages: list[list[str]]
    cost: float
    resources: list[dict[str, float]]


@dataclass
class _StageRecord:
    fill: list[int]                # instance indices of the stage's fillers (and folds)
    stretch: float
    start_leg: int
    end_leg: int
    path: _Path
    solved: float                  # what its parts measure, unstretched


@dataclass
class _Record:
    """Which instance realises each key leg, each stage's fillers, and each joint's
    treatment: what the checks and the summary read back."""

    keys: dict[tuple[int, int], int] = field(default_factory=dict)
    stages: dict[int, _StageRecord] = field(default_factory=dict)
    joints: dict[int, str] = field(default_factory=dict)
    # where the facades end on either side of a joint (the corner itself for a mitre)
    joint_ends: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    # a T leg folded over a bend: the piece its far end lies on (``keys``: the near one)
    leg_ends: dict[tuple[int, int], int] = field(default_factory=dict)


@dataclass(frozen=True)
class _Arm:
    """One leg of a corner part: the vector it spans from the key point, its unit, the
    normal into its mass, its ground (at a concave corner with the square past the key
    point) and a size a half-plane square must have to hold it."""

    leg: np.ndarray
    unit: np.ndarray
    mass: np.ndarray
    ground: BaseGeometry
    size: float


class _Placer:
    """Places one structure's solution on its plan: one stretch per stage, then the key
    parts, the fillers (folded at bends), and the cuts at mitre joints."""

    def __init__(self, si: int, plan: PlacementPlan, sol: StructureSolution,
                 parts: dict[str, Part]):
        self.si, self.plan, self.sol, self.parts = si, plan, sol, parts
        self.paths = [_Path(st.points) for st in plan.stages]
        self.ins = plan.incoming()
        self.outs = plan.outgoing()
        self.kxy = [np.array(k.xy) for k in plan.keys]
        self.placed: list[Placed] = []
        # filler instance -> its part-frame X range (over any joint leg it reaches across)
        self.span: dict[int, tuple[float, float]] = {}
        self.record = _Record()
        self.stretch: list[float] = []
        self.solved: list[float] = []
        self._bands: dict[int, BaseGeometry] = {}     # once every module is placed
        self._band_tree: shapely.STRtree | None = None   # every stage's band, once placed
        self._at_key: dict[int, set[int]] | None = None   # key point -> the stages there
        self._street: dict[int, BaseGeometry] = {}
        # stage -> (its segment at the joint, the ground its end module covers past a
        # concave mitre joint, up to the joint's plane)
        self._reach: dict[int, list[tuple[int, BaseGeometry]]] = {}
        # module -> the ground it covers past its concave mitre joint (its share of the
        # stage's ``_reach``), which its plan rectangle stops short of
        self._extension: dict[int, list[BaseGeometry]] = {}
        self._placed_masses: list[BaseGeometry] | None = None
        self._street_boxes: dict[int, tuple[float, ...]] = {}
        # (instance, plane) of each medial plane against another structure, or of a
        # corner against a stage of its own past a narrow wing (what _reopen may undo)
        self._against: list[tuple[int, HalfPlane]] = []
        # corner instance split on its bisector -> the ground of both its arms
        self._corners: dict[int, BaseGeometry] = {}

    def place(self) -> None:
        """Every part placed and cut within its structure (``placed``, ``record``)."""
        self._stretches()
        for j in range(len(self.plan.keys)):
            self._place_key(j)
        for s in range(len(self.plan.stages)):
            self._place_fillers(s)
        for s, st in enumerate(self.plan.stages):
            self._meet_t_end(s, st.start, st.start_leg, start=True)
            self._meet_t_end(s, st.end, st.end_leg, start=False)
        for j in range(len(self.plan.keys)):
            if is_joint(self.sol.keys[j]):
                self._joint(j)
            else:
                self._corner_reach(j)
        self._medial_cuts()

    def _add(self, placed: Placed) -> int:
        self.placed.append(placed)
        return len(self.placed) - 1

    # -- what stands at a key point ----------------------------------------------------

    def leg_part(self, j: int) -> Part | None:
        """The key part at key j (None for a mitre joint, which has no part)."""
        key = self.sol.keys[j]
        return None if is_joint(key) else self.parts[t_pose(key).part]

    def _sides(self, j: int) -> tuple[int | None, int | None]:
        """The stages arriving at key j and leaving it along its main line (not its
        branch), None where there is none (an end)."""
        return self.ins[j], next((s for s in self.outs[j] if self.plan.branch.get(j) != s),
                                 None)

    def _turn(self, s_in: int, s_out: int) -> tuple[np.ndarray, np.ndarray, bool]:
        """How the facade turns at the key point stage s_in arrives at and s_out leaves
        from: the direction in, the direction out, and whether the mass lies left of
        them (what :func:`joint_halves` and :func:`is_convex` take)."""
        return (self.paths[s_in].dir[-1], self.paths[s_out].dir[0],
                self.plan.stages[s_in].front == "right")

    def leg_len(self, j: int, leg: int) -> float:
        """How far key j reaches along a leg (a mitre joint: what it counts for; the
        modules beside it are extended over that to the corner)."""
        p = self.leg_part(j)
        if p is None:
            return self.plan.joints[self.sol.keys[j]][0 if leg == 0 else 1]
        return _leg(p, part_leg(self.sol.keys[j], leg)) - (
            _depth(p, self.sol.keys[j]) if leg == 2 else 0.0)

    def _stretches(self) -> None:
        """One stretch per stage: every part on it stretches, except T parts (rigid:
        their two main legs are collinear, so no linear map stretches them by two
        factors)."""
        for s, st in enumerate(self.plan.stages):
            ends = [(self.leg_part(st.start), self.leg_len(st.start, st.start_leg)),
                    (self.leg_part(st.end), self.leg_len(st.end, st.end_leg))]
            rigid = sum(x for p, x in ends if p is not None and p.cls == "t_junction")
            elastic = sum(x for p, x in ends if p is None or p.cls != "t_junction") + \
                sum(_geom_length(self.parts[x]) for x in self.sol.stages[s])
            self.stretch.append((self.paths[s].length - rigid) / elastic if elastic > 0
                                else 1.0)
            self.solved.append(rigid + elastic)

    # -- key parts ------------------------------------------------------------------------
    # each leg is aimed at the point of its stage's polyline that lies its (stretched)
    # length along from the key point, so legs land on the skeleton even where a bend
    # comes before the leg ends

    def _legs(self, j: int, p: Part) -> dict[int, np.ndarray]:
        """The vector each of key j's legs spans from the key point."""
        legs = {}
        rigid = p.cls == "t_junction"
        # what enters j: its main line by the in-leg, an H's bar by the branch leg
        for s in [self.ins[j]] + [b for b in [self.plan.branch.get(j)] if b is not None
                                  and self.plan.stages[b].end == j]:
            if s is None:
                continue
            leg = self.plan.stages[s].end_leg
            scale = 1.0 if rigid else self.stretch[s]
            path = self.paths[s]
            legs[leg] = path.at(path.length - self.leg_len(j, leg) * scale) - self.kxy[j]
        for s in self.outs[j]:
            leg = self.plan.stages[s].start_leg
            scale = 1.0 if rigid else self.stretch[s]
            legs[leg] = self.paths[s].at(self.leg_len(j, leg) * scale) - self.paths[s].p[0]
        return legs

    def _front(self, j: int) -> Front:
        s_in = self.ins[j]
        main_out = [s for s in self.outs[j] if self.plan.branch.get(j) != s]
        return self.plan.stages[s_in if s_in is not None else main_out[0]].front

    def _place_key(self, j: int) -> None:
        p = self.leg_part(j)
        if p is None:      # a mitre joint: its neighbours are cut in _joint
            return
        legs = self._legs(j, p)
        front = self._front(j)
        if p.cls in ("end_left", "end_right"):   # one straight instance realises its leg
            (leg, v), = legs.items()
            i = self._add(_straight_key(p, self.si, j, self.kxy[j], v, leg == 0, front))
            self.span[i] = (0.0, self.placed[i].length)
            for leg in (0, 1, 2):
                self.record.keys[(j, leg)] = i
            return
        if p.cls == "corner":
            a = _fit(np.asarray(p.directions[0]) * p.legs_measured[0],
                     np.asarray(p.directions[1]) * p.legs_measured[1], legs[0], legs[1])
        else:
            self._place_t(j, p, legs)
            return
        i = self._add(_instance(p, self.si, None, j, a, self.kxy[j]))
        for leg in (0, 1, 2):
            self.record.keys[(j, leg)] = i

    def _place_t(self, j: int, p: Part, legs: dict[int, np.ndarray]) -> None:
        """A T part, fitted to its in-leg and its branch; its out-leg follows the in-leg
        where the main line runs straight through the junction. Where the main line
        bends there (a digitised T rarely runs dead straight), a rigid part would miss
        the far side by its leg times the bend (15 mm at 0.05 degrees, 0.8 m at 3): the
        part is placed twice, each kept on its own side of the wing's facade line, so
        both main facades lie on the skeleton and meet at the key point, as a filler
        folds at a bend. The one whose side the wing is built on (its part's leg 0
        side: README, "The canonical frame") is fitted to its main leg and the branch;
        the other, whose wing is cut away, only turned onto its leg (fitted to the
        branch too, it would shear by the bend and open a wedge against the next
        module: 0.6 m across at 3 degrees on a 12 m deep range)."""
        key = self.sol.keys[j]
        back, wing = _leg_reach(p, key, 2)   # turned over, its key point is on its back face
        runs = self._t_runs(j)
        for leg, run in runs.items():   # a leg over a bend: aimed along its first run
            if run is not None and len(run[1]) > 1:
                path, segs, at_start = run
                u = path.dir[segs[0]] if at_start else -path.dir[segs[-1]]
                legs[leg] = u * self.leg_len(j, leg)

        def fit(leg: int) -> np.ndarray:
            m = part_leg(key, leg)
            return _fit(np.asarray(p.directions[m]) * p.legs_measured[m], wing, legs[leg],
                        legs[2])

        def place(a: np.ndarray) -> int:
            return self._add(_instance(p, self.si, None, j, a, self.kxy[j] - a @ back))

        u_in, u_out = -legs[0], legs[1]
        off = abs(float(u_in[0] * u_out[1] - u_in[1] * u_out[0])) / float(np.hypot(*u_in))
        if off <= TOL / 10:         # straight through: the out-leg lands on its line
            i = place(fit(0))
            for leg in (0, 1, 2):
                self.record.keys[(j, leg)] = i
            self._fold_t(j, p, runs)
            return
        wing_leg = 0 if part_leg(key, 0) == 0 else 1
        other = 1 - wing_leg
        a = {wing_leg: fit(wing_leg)}
        # along its leg onto the skeleton's point its leg's length along (a chord a
        # hair shorter where the line bends under the leg: 1-2 mm past the checks'
        # tolerance at full length), square across it
        m = part_leg(key, other)
        x = legs[other] / (float(p.directions[m][0]) * p.legs_measured[m])
        y = _left(x) / float(np.hypot(*x)) * np.sign(np.linalg.det(a[wing_leg]))
        a[other] = np.column_stack([x, y])
        idx = {leg: place(a[leg]) for leg in (wing_leg, other)}
        # the two meet on the wing's facade line moved out by what its facade bears
        # (cornices, sills: cut on the line itself, the wing's facade lost them), the
        # wing's own on its part's leg 0 side (README, "The canonical frame") ...
        bears = float(cast(BaseGeometry, p.sec_branch).bounds[2])
        split = self._part_plane(idx[wing_leg], (1.0, 0.0), bears)
        self.placed[idx[wing_leg]].halves.append(split)
        self.placed[idx[other]].halves.append(HalfPlane(tuple(-np.asarray(split.normal)),
                                                        split.point, extends=False))
        # ... and the other keeps only its main range: of its wing (turned with it) a
        # wedge stood past the wing's facade, 1 m into the yard at 3 degrees
        self.placed[idx[other]].halves.append(
            self._part_plane(idx[other], (0.0, 1.0), y_range(p)[1]))
        for leg in (0, 1):
            self.record.keys[(j, leg)] = idx[leg]
        self.record.keys[(j, 2)] = idx[wing_leg]
        self._fold_t(j, p, runs, {wing_leg: [split], other: [self.placed[idx[other]].halves[0]]})

    def _t_runs(self, j: int) -> dict[int, tuple[_Path, list[int], bool] | None]:
        """The straight runs of the skeleton under T key j's main legs (0, 1): each
        leg's stage path, the indices of the path's segments it covers (in the path's
        order) and whether the key point is the path's start; None without such a
        stage. Where the main line bends at the junction too (the T placed twice), a leg
        whose chord stays within :data:`CHORD_TOL` of its bends spans them as a chord,
        as it spans that bend (folded 0.3 m past a bent junction, its pieces left 1 %
        of the roof band open); where it runs straight through, a leg is folded at any
        bend (spanned as a chord it is placed twice and sheared: an H's bar between two
        T parts doubled 10.7 m² at a 10 degree bend 0.5 m along)."""
        runs: dict[int, tuple[_Path, list[int], bool] | None] = {}
        offs = {}
        for leg in (0, 1):
            if leg == 0:
                s = self.ins[j]
            else:
                s = next((t for t in self.outs[j] if self.plan.stages[t].start_leg == 1),
                         None)
            if s is None or (leg == 0 and self.plan.stages[s].end_leg != 0):
                runs[leg] = None
                continue
            path, n = self.paths[s], self.leg_len(j, leg)
            lo, hi = (0.0, n) if leg == 1 else (path.length - n, path.length)
            bends = path.bends_within(lo, hi)
            a, b = path.at(lo), path.at(hi)
            chord = (b - a) / max(float(np.hypot(*(b - a))), 1e-12)
            offs[leg] = max((abs(float(chord[0] * (path.p[k] - a)[1]
                                       - chord[1] * (path.p[k] - a)[0])) for k in bends),
                            default=0.0)
            runs[leg] = (path, [path.segment(lo + TOL)] + bends, leg == 1)
        first = [r[0].dir[r[1][0]] if r[2] else r[0].dir[r[1][-1]]
                 for r in runs.values() if r is not None]
        bent = len(first) == 2 and abs(float(first[0][0] * first[1][1]
                                             - first[0][1] * first[1][0])) > TOL / 10
        for leg, run in runs.items():
            if run is not None and bent and offs[leg] <= CHORD_TOL:
                path, segs, at_start = run
                runs[leg] = (path, [segs[0] if at_start else segs[-1]], at_start)
        return runs

    def _fold_t(self, j: int, p: Part, runs: dict[int, tuple[_Path, list[int], bool] | None],
                sides: dict[int, list[HalfPlane]] | None = None) -> None:
        """A T part's main leg over a bend of its skeleton is folded there, as a module
        is: the part is rigid, and spanning the bend as a chord its facade stood up to
        0.6 m off the skeleton at 10 degrees 5 m along (or its range doubled the next
        module's ground, 1 % of the footprint). The placed copy keeps the run at the key
        point; each further run takes a copy turned about the skeleton onto it (the leg
        keeps its length along the skeleton), with its main range only, and each is cut
        on the bend's bisector. ``sides``: what every piece of a leg keeps to, where the
        T is placed twice (its side of the wing's facade line: a bend 0.3 m past a bent
        junction doubled a wedge of the other copy's range, 8 m² of roof)."""
        for leg, run in runs.items():
            if run is None or len(run[1]) < 2:
                continue
            path, segs, at_start = run
            i = self.record.keys[(j, leg)]
            base, near = self.placed[i], (segs[0] if at_start else segs[-1])
            u0, key = path.dir[near], self.kxy[j]
            s_key = 0.0 if at_start else path.length
            pieces, own = [], list(base.halves)
            folds: list[list[HalfPlane]] = []     # each piece's fold planes
            for n, k in enumerate(segs):
                if k == near:
                    pieces.append(i)
                else:
                    u = path.dir[k]
                    c, sn = float(u0 @ u), float(u0[0] * u[1] - u0[1] * u[0])
                    rot = np.array([[c, -sn], [sn, c]])
                    origin = rot @ (base.origin - key) + path.p[k] + u * (s_key - path.cum[k])
                    pieces.append(self._add(_instance(p, self.si, None, j, rot @ base.a,
                                                      origin)))
                    self.placed[pieces[-1]].halves.extend(
                        [*(sides or {}).get(leg, []),
                         self._part_plane(pieces[-1], (0.0, 1.0), y_range(p)[1])])
                # (a T is not extended to a plane: its x is no length)
                folds.append(_run_folds(path, segs, n, extends=False))
                self.placed[pieces[-1]].halves.extend(folds[-1])
            if self.record.keys[(j, 2)] == i:    # the copy holding the wing
                turned = list(zip(pieces, folds, strict=True))
                self._keep_wing(j, p, i, own, turned[1:] if at_start else turned[-2::-1])
            self.record.leg_ends[(j, leg)] = pieces[-1] if at_start else pieces[0]

    def _keep_wing(self, j: int, p: Part, i: int, own: list[HalfPlane],
                   turned: list[tuple[int, list[HalfPlane]]]) -> None:
        """A bend closer to the junction than the wing is wide (5 m along, under a wing
        about 12 m deep) has its fold plane run through the wing behind the main range:
        what of the wing lies past it (2-3 % of the roof band open) is kept by a copy
        per ``turned`` copy beside it (with its fold planes, from the key point out),
        cut to the wing's width, to that copy's run and behind its range (a millimetre
        behind: its back face lies in that plane). Where the bend turns toward the wing,
        the turned range reaches into it (13 m² doubled at 15 degrees, cut against the
        wing's own range); where it turns away, this copy's range fills what opens
        between the wing and it (a 16 m² notch at 14 degrees)."""
        base, (_y0, back) = self.placed[i], y_range(p)
        u0, _v0, u1, _v1 = cast(BaseGeometry, p.sec_branch).bounds
        box = np.array([(x, y) for x in (u0, u1) for y in (back, p.legs_measured[2])])
        world = base.origin + box @ base.a.T
        for t, planes in turned:
            if any(float(((world - np.asarray(h.point)) @ np.asarray(h.normal)).min()) > -TOL
                   for h in planes):    # the wing lies wholly outside this copy's run
                break
            w = self._add(_instance(p, self.si, None, j, base.a, base.origin))
            self.placed[w].halves.extend([*own, *planes,
                                          self._part_plane(w, (-1.0, 0.0), TOL - min(u0, u1)),
                                          self._part_plane(t, (0.0, -1.0), -back - TOL)])

    def _part_plane(self, i: int, normal: tuple[float, float], c: float) -> HalfPlane:
        """The world half-plane of instance i's part-frame half-plane ``normal . X <=
        c`` (``normal`` an axis)."""
        placed = self.placed[i]
        n = np.linalg.inv(placed.a).T @ np.asarray(normal)
        point = placed.origin + placed.a @ (np.asarray(normal) * c)
        return HalfPlane(tuple(n / float(np.hypot(*n))), tuple(point), extends=False)

    def _meet_t_end(self, s: int, j: int, leg: int, *, start: bool) -> None:
        """A T part fitted to a wing that leaves its main line off the square (80
        degrees; or a main line bending at the junction, on the wing's side) is sheared:
        its leg's end face runs along the wing, not square to the facade, and the next
        module's square end left a wedge of ground open on one side and doubled on the
        other (0.86 % of the footprint overlapping, 1.51 % of the roof band open at 80
        degrees). That module is cut and extended to the T's end face instead."""
        i = self.record.leg_ends.get((j, leg), self.record.keys.get((j, leg)))
        fill = self.record.stages[s].fill if s in self.record.stages else []
        if i is None or not fill or self.placed[i].cls != "t_junction":
            return
        placed, key = self.placed[i], self.sol.keys[j]
        o, reach = _leg_reach(self.parts[placed.part], key, leg)
        end = placed.origin + placed.a @ (o + reach)        # the leg's end on the facade
        face = placed.a @ (np.array([1.0, 0.0]) if leg == 2 else np.array([0.0, 1.0]))
        path = self.paths[s]
        u = path.dir[0] if start else path.dir[-1]
        face = face / float(np.hypot(*face))
        deep = max(abs(placed.y_range[0]), abs(placed.y_range[1]))
        if abs(float(face @ u)) * deep < TOL:   # square to the facade: the module meets it
            return
        n = np.array([-face[1], face[0]])
        n = n if float(n @ (-u if start else u)) > 0 else -n   # toward the T's side
        target = fill[0] if start else fill[-1]
        self.placed[target].halves.append(HalfPlane(tuple(n), tuple(end)))

    # -- fillers, from the end of the start key's leg on ----------------------------------

    def _place_fillers(self, s: int) -> None:
        st = self.plan.stages[s]
        path, stretch = self.paths[s], self.stretch[s]
        p_lo = self.leg_part(st.start)
        leg = self.leg_len(st.start, st.start_leg)
        pos = leg if p_lo is not None and p_lo.cls == "t_junction" else leg * stretch
        fillers = self.sol.stages[s]
        # next to a mitre joint a module reaches on, over the joint's leg, to the corner
        reach_lo = 0.0 if p_lo is None else None
        reach_hi = path.length if self.leg_part(st.end) is None else None
        idx = []
        for n, x in enumerate(fillers):
            p = self.parts[x]
            w = _geom_length(p) * stretch
            lo = reach_lo if n == 0 and reach_lo is not None else pos
            hi = reach_hi if n == len(fillers) - 1 and reach_hi is not None else pos + w
            scale = w / _geom_length(p)
            for placed in self._filler(p, s, path, pos, w, (lo, hi), st.front):
                idx.append(self._add(placed))
                self.span[idx[-1]] = ((lo - pos) / scale, (hi - pos) / scale)
            pos += w
        self.record.stages[s] = _StageRecord(idx, stretch, st.start_leg, st.end_leg, path,
                                             self.solved[s])

    def _filler(self, p: Part, s: int, path: _Path, pos: float, w: float,
                reach: tuple[float, float], front: Front) -> list[Placed]:
        """A filler placed at arc length [pos, pos + w] and reaching over ``reach``: one
        instance per straight run it covers, folded at each bend between them."""
        bends = path.bends_within(*reach)
        runs = [path.segment(reach[0] + TOL)] + bends
        out = []
        for n, k in enumerate(runs):
            u = path.dir[k]
            a = np.column_stack([u * (w / _geom_length(p)),
                                 _left(u) if front == "right" else -_left(u)])
            placed = _instance(p, self.si, s, None, a, path.p[k] + u * (pos - path.cum[k]))
            placed.halves.extend(_run_folds(path, runs, n))
            out.append(placed)
        _fold_at_ends(out, path, runs, reach)
        return out

    # -- where two stages' masses meet away from a corner ----------------------------------

    def _medial_cuts(self) -> None:
        """Where the masses of two stages that share no key point overlap (a narrow end
        of a block, a block too small for a courtyard), each module keeps what lies
        nearer its own facade: the plane of equal depth behind both facades. At a right
        angle this is the corner's bisector; facing each other, the middle. A stage's
        mass is its band, and past a concave mitre joint its end module's extension up
        to the joint's plane (:meth:`_medial_reach`). (An end module's extension is
        cut against the other stages last: :meth:`medial_extensions`.)"""
        stages = self.plan.stages
        bands = [self._stage_band(s) for s in range(len(stages))]
        tree = shapely.STRtree(bands)
        for s in range(len(stages)):
            apart = set(self._apart(s))
            fill = self.record.stages[s].fill
            feet = _footprints([self.placed[i] for i in fill], [self.span[i] for i in fill])
            for i, foot in zip(fill, feet, strict=True):
                met = set()
                for t in tree.query(foot, predicate="intersects"):
                    if int(t) not in apart:
                        continue
                    if foot.intersection(bands[t]).area > MEDIAL_MIN_AREA:
                        met.add(int(t))
                        self._medial(i, s, int(t))
                self._stop_at_facades(i, s, self, [t for t in range(len(stages)) if t != s])
                self._medial_reach(i, s, foot, apart - met)
        corners = [j for j in range(len(self.plan.keys))
                   if (p := self.leg_part(j)) is not None and p.cls == "corner"]
        if corners:         # a city block's joints are mostly mitres: no masses to build
            masses = self._masses()
            tree = shapely.STRtree(masses)
            for j in corners:
                self._medial_corner(j, self, masses, tree)
        for s in range(len(stages)):
            self._medial_runs(s)

    def medial_extensions(self) -> None:
        """Each end module's extension past a concave mitre joint against the stages
        of its structure that share no key point with its own
        (:meth:`_medial_extension`): last, once every other medial plane of every
        structure is cut, so that what covers the ground it gives up is known (a plane
        against a courtyard, cut after, took ground one covered, and giving that plane
        back reopened a triangle of roof)."""
        for s in range(len(self.plan.stages)):
            apart = self._apart(s)
            for i in self.record.stages[s].fill:
                self._medial_extension(i, s, apart)

    def medial_against(self, other: _Placer) -> None:
        """Where this structure's modules reach into the mass of another structure of
        the same layout (a courtyard's facades and the outline's round a wing narrower
        than two building depths, which would run through each other and out of the far
        wall), each keeps what lies nearer its own facade, as between two sides of one
        structure that share no corner (:meth:`_medial_cuts`). A module's reach counts
        its extension past a concave mitre joint: a courtyard's end module reached past
        its corner into the outline's wing beyond and stood in its modules."""
        bands = other.masses()
        tree = shapely.STRtree(bands)
        for s in range(len(self.plan.stages)):
            fill = self.record.stages[s].fill
            feet = _footprints([self.placed[i] for i in fill], [self.span[i] for i in fill])
            for i, foot in zip(fill, feet, strict=True):
                self._stop_at_facades(i, s, other, range(len(other.plan.stages)))
                if self._extension.get(i):   # its ground past a concave mitre too
                    foot = shapely.union_all([foot, *self._extension[i]])
                for t in _overlapping(tree, bands, foot):
                    half = self._medial_half(i, s, t, other=other)
                    if half is not None and half not in self.placed[i].halves:
                        self.placed[i].halves.append(half)
                        self._against.append((i, half))
        for j in range(len(self.plan.keys)):
            self._medial_corner(j, other, bands, tree)

    def masses(self) -> list[BaseGeometry]:
        """:meth:`_masses` once every structure of the layout is placed (they no longer
        change then), made once: each other structure meets them."""
        if self._placed_masses is None:
            self._placed_masses = self._masses()
        return self._placed_masses

    def region(self) -> tuple[float, float, float, float]:
        """The bounds of all another structure's modules can meet of this one (once
        placed): its stages' masses and the ground in front of its facades."""
        geoms = [g for g in [*self.masses(),
                             *(self._street_band(t) for t in range(len(self.paths)))]
                 if not g.is_empty]
        if not geoms:
            return (np.inf, np.inf, -np.inf, -np.inf)
        x0, y0, x1, y1 = shapely.total_bounds(geoms)
        return (float(x0), float(y0), float(x1), float(y1))

    def reach(self, db: PartDB) -> tuple[float, float, float, float]:
        """The bounds of all this structure's modules cover (once placed): each part's
        plan hull where it stands, grown by the most its ends may be extended, and the
        extensions past its concave mitre joints."""
        boxes = [shapely.total_bounds(self._extension[i]) for i in sorted(self._extension)
                 if self._extension[i]]
        for p in self.placed:
            xy = plan_hull(db, p.part) @ p.a.T + p.origin
            grow = MAX_EXTEND_DEPTHS * max(abs(p.y_range[0]), abs(p.y_range[1]), 1.0) \
                * float(np.abs(p.a).max()) + EXTEND_MARGIN
            (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
            boxes.append(np.array([x0 - grow, y0 - grow, x1 + grow, y1 + grow]))
        b = np.array(boxes).reshape(-1, 4)
        b = b[np.isfinite(b).all(axis=1)]          # an empty geometry's bounds are NaN
        if not len(b):
            return (np.inf, np.inf, -np.inf, -np.inf)
        return (float(b[:, 0].min()), float(b[:, 1].min()), float(b[:, 2].max()),
                float(b[:, 3].max()))

    def _masses(self) -> list[BaseGeometry]:
        """Each stage's mass as another structure's modules (or a corner part of this
        one) meet it: its band (:meth:`_mass_band`) and what its end modules cover past
        a concave mitre joint."""
        return [shapely.union_all([self._mass_band(t), *(r for _k, r in self._reach.get(t, []))])
                for t in range(len(self.plan.stages))]

    def _medial_corner(self, j: int, other: _Placer, bands: list[BaseGeometry],
                       tree: shapely.STRtree) -> None:
        """A corner part whose legs reach into the mass of another structure's stages
        (or of its own that share no key point with either leg's stage: the far side of
        a wing narrower than the part is deep) is split on its bisector plane, and each
        half cut on the medial plane of its own leg: one plane for the whole part would
        cut the other leg's arm, which runs the other way. A corner split before (by
        another structure) only takes the new planes."""
        i = self.record.keys.get((j, 0))
        p = self.leg_part(j)
        s_in, s_out = self._sides(j)
        if i is None or p is None or p.cls != "corner" or s_in is None or s_out is None:
            return
        allowed = (set(range(len(other.plan.stages))) if other is not self
                   else set(self._apart(s_in)) & set(self._apart(s_out)))
        key = self.kxy[j]
        arms = self._arms(j, p, i, s_in, s_out)
        self._corners[i] = arms[0].ground.union(arms[1].ground)
        split = arms[0].unit + arms[1].unit
        if float(np.hypot(*split)) < 1e-6:
            return
        w = np.array([-split[1], split[0]]) / float(np.hypot(*split))
        sides = {0: w if float(w @ arms[0].unit) < 0 else -w}     # keeps leg 0's side
        sides[1] = -sides[0]
        halves: dict[int, list[HalfPlane]] = {0: [], 1: []}
        for leg in (0, 1):
            v, m = arms[leg].leg, arms[leg].mass
            arm = arms[leg].ground.intersection(half_polygon(sides[leg], key,
                                                             arms[leg].size))
            facade = np.array([key, key + v])
            for t in _overlapping(tree, bands, arm):
                if t not in allowed:
                    continue
                half = _wing_plane(m, key, facade, other, t, None, arm, self.placed[i])
                if half is not None and half not in halves[leg]:
                    halves[leg].append(half)
        if not (halves[0] or halves[1]):
            return
        if self.record.keys[(j, 1)] == i:           # split on the bisector, once
            first = self.placed[i]
            second = replace(first, halves=list(first.halves))
            first.halves.append(HalfPlane(tuple(sides[0]), tuple(key), extends=False))
            second.halves.append(HalfPlane(tuple(sides[1]), tuple(key), extends=False))
            self.record.keys[(j, 1)] = self._add(second)
            self._corners[self.record.keys[(j, 1)]] = self._corners[i]
        for leg in (0, 1):
            n = self.record.keys[(j, leg)]
            for h in halves[leg]:
                if h not in self.placed[n].halves:
                    self.placed[n].halves.append(h)
                    self._against.append((n, h))

    def _arms(self, j: int, p: Part, i: int, s_in: int, s_out: int) -> dict[int, _Arm]:
        """The arms of corner part p (instance i) at key j, leg 0 along stage s_in and
        leg 1 along s_out."""
        legs = self._legs(j, p)
        key = self.kxy[j]
        depth = max(abs(self.placed[i].y_range[0]), abs(self.placed[i].y_range[1]))
        units = {leg: legs[leg] / float(np.hypot(*legs[leg])) for leg in (0, 1)}
        arms = {}
        for leg, s in ((0, s_in), (1, s_out)):
            v, u = legs[leg], units[leg]
            m = _mass_normal(-u if leg == 0 else u, self.plan.stages[s].front)
            # the leg's arm, and at a concave corner the square past the key point too
            back = 0.0 if float(m @ units[1 - leg]) > 0 else depth
            arms[leg] = _Arm(v, u, m, shapely.Polygon([
                key - u * back, key + v, key + v + m * depth, key - u * back + m * depth]),
                10.0 * (float(np.hypot(*v)) + depth + 1.0))
        return arms

    def _medial_reach(self, i: int, s: int, foot: BaseGeometry, apart: set[int]) -> None:
        """Module i against the ground a stage t extends over past a concave mitre
        joint (outside t's band: a narrow wing's inner corner, whose end module reaches
        past the corner into the modules of the far side). Tested with module i as its
        own joints cut it (its plain rectangle would reach the other side of its
        corner's plane too), and cut only where what the medial plane removes lies
        mostly within t's mass: the plane is infinite, t's extension is not."""
        clipped = None
        for t in sorted(apart.intersection(self._reach)):   # the few stages reaching on
            for k, reach in self._reach[t]:
                if not foot.intersects(reach):
                    continue
                if clipped is None:
                    clipped = _clipped_footprint(self.placed[i], self.span[i])
                if clipped.intersection(reach).area <= MEDIAL_MIN_AREA:
                    continue
                half = self._medial_half(i, s, t, k)
                if half is None or half in self.placed[i].halves:
                    continue
                past = self._past(i, half)
                if past.area <= MEDIAL_MIN_AREA:
                    continue
                mass = shapely.union_all([self._stage_band(t), reach])
                if past.intersection(mass).area >= REACH_SHARE * past.area:
                    self.placed[i].halves.append(half)
                    clipped = None

    def _medial_extension(self, i: int, s: int, apart: Sequence[int]) -> None:
        """Module i's extension past its concave mitre joint, where it stays inside the
        building, against the band of a stage t that shares no key point with stage s:
        where a third facade stands a wing's width from the inner corner, the extension
        reached diagonally into that facade's modules (feature 64 of the shipped
        footprints: ground two instances share 42.3 m², 18.8 since). Cut on the plane
        of equal depth behind both facades, as where two sides' modules meet
        (:meth:`_medial_cuts`), only where the other modules and the street cover all
        the plane takes off (:meth:`_covered_by_others`): the extension may be all that
        roofs the ground behind a shallower module of t (feature 162's wing at (122,
        129), where the plane opened a 0.26 m² triangle of roof, so 27.6 m² stay
        shared). (An extension running out through a facade is
        :meth:`_stop_at_facades`'s.)"""
        ext = self._extension.get(i)
        if not ext:
            return
        placed = self.placed[i]
        mass = _clipped(shapely.union_all(ext), placed)     # as its cuts so far leave it
        for t in apart:
            if mass.is_empty:
                return
            medial = None
            if mass.intersection(self._stage_band(t)).area > MEDIAL_MIN_AREA:
                medial = self._medial_half(i, s, t)
            if medial is None:
                half = self._beside(i, s, t, mass)
                if half is None:
                    continue
            elif self._covered_cut(i, t, medial, mass) is not None:
                half = medial
            else:       # the fallback, made only then
                half = self._short_of_sliver(i, s, t, medial, mass)
                if self._covered_cut(i, t, half, mass) is None:
                    continue
            assert half is not None
            placed.halves.append(half)
            mass = _clipped(mass, replace(placed, halves=[half]))

    def _beside(self, i: int, s: int, t: int, ext: BaseGeometry) -> HalfPlane | None:
        """Where module i's extension ``ext`` (of stage s) meets the extension of a
        stage t whose facade runs parallel to s's, facing the same way (a bay's two
        inner corners), the plane it is cut on: no plane of equal depth lies between
        such facades, so both modules roofed the ground behind the bay (44.2 m²,
        2.8 % of a block with a 10 m bay) or, where they were cut against the bay's
        sides, neither did (27 m²). Of the plane across both facades midway between
        their joints and the plane of t's joint (giving up all t's extension covers),
        the one that takes off the most of what the others cover
        (:meth:`_covered_cut`): midway, a module deeper than t's keeps the strip behind
        t's, and t's module, cut midway after it, stood in its half. None where s and
        t are not so, their extensions do not meet, or neither plane is covered."""
        reach = [g for _k, g in self._reach.get(t, [])]
        if not reach or ext.intersection(shapely.union_all(reach)).area <= MEDIAL_MIN_AREA:
            return None
        centre = np.asarray(ext.centroid.coords[0])
        path_s, path_t = self.paths[s], self.paths[t]
        u = path_s.dir[_nearest_segment(centre, path_s)]
        m_s = _mass_normal(u, self.plan.stages[s].front)
        m_t = _mass_normal(path_t.dir[_nearest_segment(centre, path_t)],
                           self.plan.stages[t].front)
        if float(m_s @ m_t) < FACING_AWAY:
            return None
        k_s = min((path_s.p[0], path_s.p[-1]), key=lambda q: float(np.hypot(*(q - centre))))
        at_start = float(np.hypot(*(path_t.p[0] - k_s))) <= float(np.hypot(*(path_t.p[-1]
                                                                                 - k_s)))
        k_t = path_t.p[0] if at_start else path_t.p[-1]
        along = float(u @ (k_t - k_s))
        if abs(along) <= TOL:
            return None
        n = u / float(np.hypot(*u)) * np.sign(along)
        planes = [HalfPlane(tuple(n), tuple((k_s + k_t) / 2.0), extends=False)]
        joint = self._joint_plane(t, at_start)
        if joint is not None:
            planes.append(HalfPlane(tuple(-np.asarray(joint.normal)), joint.point,
                                    extends=False))
        cuts = [(h, self._covered_cut(i, t, h, ext)) for h in planes]
        best = max(((h, c) for h, c in cuts if c is not None), key=lambda hc: hc[1].area,
                   default=None)
        return None if best is None else best[0]

    def _joint_plane(self, t: int, start: bool) -> HalfPlane | None:
        """The plane of the mitre joint at stage t's start (or end) keeping t's side,
        or None where no mitre joint is there."""
        st = self.plan.stages[t]
        j = st.start if start else st.end
        s_in, s_out = self._sides(j)
        if not is_joint(self.sol.keys[j]) or s_in is None or s_out is None:
            return None
        before, after, _how, _trim = joint_halves(self.kxy[j], *self._turn(s_in, s_out))
        return after[0] if start else before[0]

    def _covered_cut(self, i: int, t: int, half: HalfPlane | None,
                     ext: BaseGeometry) -> BaseGeometry | None:
        """What ``half`` takes off module i (with its extension ``ext``), where it is a
        new plane for it that takes off some of it and only what others cover
        (:meth:`_covered_by_others`); else None. Returned, so that choosing among
        planes by what they take off measures it once."""
        if half is None or half in self.placed[i].halves:
            return None
        past = self._past(i, half, ext)
        return past if past.area > MEDIAL_MIN_AREA and self._covered_by_others(i, t, past) \
            else None

    def _short_of_sliver(self, i: int, s: int, t: int, medial: HalfPlane | None,
                         ground: BaseGeometry) -> HalfPlane | None:
        """The medial plane of module i (of stage s) against stage t moved toward t by
        as much as module i is deeper than the shallowest of t's modules its extension
        (``ground``) meets, or None where it is not deeper: what that plane takes off
        lies within t's modules. The medial plane itself took off, past the backs of
        those modules, a sliver no one covers (0.15 m² at an L's or a Z's inner corner
        round a 14 m wing: 11.5 m modules against 11.2 m ones), so the extension was not
        cut at all, and stood 20.7 m² into t's modules. Moved, it leaves a strip as wide
        as the depths differ doubled (about 2 m² there), and no roof open."""
        if medial is None:
            return None
        placed = self.placed[i]
        met = [j for j in self.record.stages[t].fill
               if _clipped_footprint(self.placed[j], self.span[j]).intersects(ground)]
        deeper = placed.y_range[1] - min((self.placed[j].y_range[1] for j in met),
                                         default=placed.y_range[1])
        centre = _centre(placed)
        path_t = self.paths[t]
        m_s = _mass_normal(placed.a[:, 0], self.plan.stages[s].front)
        m_t = _mass_normal(path_t.dir[_nearest_segment(centre, path_t)],
                           self.plan.stages[t].front)
        if deeper <= 0.0 or float(m_s @ m_t) <= -FACING_AWAY:   # (back to back: not medial)
            return None
        n = np.asarray(medial.normal)
        return HalfPlane(medial.normal, tuple(np.asarray(medial.point) + n * deeper
                                              / float(np.hypot(*(m_s - m_t)))),
                         extends=False)

    def _covered_by_others(self, i: int, t: int, ground: BaseGeometry) -> bool:
        """Whether the street in front of stage t and this structure's instances other
        than i (as cut so far) cover all of ``ground`` but :data:`UNCOVERED_AREA`:
        stage t's modules' plans first (they mostly do), then any instance whose plan (a
        corner part's arms) or extension meets the box of what is left, t's modules'
        extensions too (at a bay's inner corners, what one module gives up the other's
        extension covers)."""
        fill = self.record.stages[t].fill
        left = ground.difference(self._cover(t))     # (i is a module of another stage)
        for j in self._coverers():
            if left.area <= UNCOVERED_AREA:
                break
            if j == i or j in fill and j not in self._extension:   # (_cover has its plan)
                continue
            near = shapely.box(*left.bounds)
            plan = self._corners[j] if j in self._corners else shapely.Polygon(
                _plan_corners(self.placed[j], self.span[j]))
            if plan.intersects(near) or any(e.intersects(near)
                                            for e in self._extension.get(j, [])):
                left = left.difference(self._covered(j))
        return left.area <= UNCOVERED_AREA

    def _stop_at_facades(self, i: int, s: int, other: _Placer, stages: Sequence[int]
                         ) -> None:
        """Cut the extension of module i (of stage s) past its concave mitre joint where
        it runs out through a facade of ``other`` (this structure or another): at a
        sharp inner corner the extension runs tens of metres on, through a narrow wing
        and out of its far wall into the street (a Helsinki building had a 13 m blade
        standing out of its east wall). It is cut on the medial plane of its own facade
        and the one it runs out of, as where two sides' modules meet
        (:meth:`_medial_cuts`), so it also stops standing through that wing's modules;
        where that plane would cut its own facade, or take off ground the wing's modules
        do not cover (:meth:`_covers`: a short step's modules stop at its corners, and
        the roof would open), just behind the far facade (:data:`FACADE_INSET`, so the
        cut's cap hides behind that wall instead of z-fighting with it), if that leaves
        the module's own plan rectangle whole.
        Only an extension that runs out of the building is cut: one that stays within
        it may be all that covers the ground behind the corner, and a cut there would
        open the roof."""
        ext = self._extension.get(i)
        if not ext:
            return
        x0, y0, x1, y1 = shapely.total_bounds(ext)
        near = [t for t in stages if (b := other._street_box(t))[0] <= x1 and
                x0 <= b[2] and b[1] <= y1 and y0 <= b[3]]
        if not near:                  # (bounds first: a city asks this tens of thousands
            return                    # of times, and mostly of stages far away)
        placed = self.placed[i]
        own = self.plan.stages[s].front
        mass = _clipped(shapely.union_all(ext), placed)     # as its cuts so far leave it
        for t in near:
            if mass.is_empty or not mass.intersects(other._street_band(t)):
                continue
            path, front = other.paths[t], other.plan.stages[t].front
            for k in range(len(path.len)):
                m = _mass_normal(path.dir[k], front)
                half = HalfPlane(tuple(-m), tuple(path.p[k] + m * FACADE_INSET),
                                 extends=False)
                out = _beyond(mass, half, placed)
                strip = _in_front(path.p[k:k + 2], front, other._stage_depth(t))
                if out.intersection(strip).area <= MEDIAL_MIN_AREA:
                    continue
                facade = self._facade(i)
                cut = _medial_plane(_mass_normal(placed.a[:, 0], own), placed.origin,
                                    facade, path, front, k)
                if cut is not None and not other._covers(t, self._past(i, cut, mass)):
                    cut = None
                if cut is None:               # the facade itself, just behind it
                    n = np.asarray(half.normal)
                    if (facade @ n > float(np.asarray(half.point) @ n) - TOL).any() \
                            or self._past(i, half).area > MEDIAL_MIN_AREA:
                        continue              # it would cut the module itself
                    cut = half
                if cut not in placed.halves:
                    placed.halves.append(cut)
                mass = _clipped(mass, replace(placed, halves=[cut]))

    def _covered(self, i: int, without: HalfPlane | None = None) -> BaseGeometry:
        """The ground instance i covers as cut so far (less the plane ``without``): a
        module's plan rectangle and its extension past a concave mitre joint, a corner
        part's arms."""
        placed = self.placed[i]
        if without is not None:
            placed = replace(placed, halves=[h for h in placed.halves if h != without])
        ground = self._corners[i] if i in self._corners else _footprint(placed, self.span[i])
        return _clipped(shapely.union_all([ground, *self._extension.get(i, [])]), placed)

    def _coverers(self) -> list[int]:
        """The instances whose ground :meth:`_covered` knows: modules, corner parts."""
        return [*(i for st in self.record.stages.values() for i in st.fill), *self._corners]

    def _covers(self, t: int, ground: BaseGeometry) -> bool:
        """Whether stage t's modules (as cut so far) or the street in front of it
        cover nearly all of ``ground`` (:data:`COVER_SHARE`): a medial plane against t
        may then take it off another module without opening the roof."""
        return ground.difference(self._cover(t)).area <= max(
            MEDIAL_MIN_AREA, (1 - COVER_SHARE) * ground.area)

    def _cover(self, t: int) -> BaseGeometry:
        """The ground stage t's modules (as cut so far) and the street in front of it
        cover."""
        return shapely.union_all([self._street_band(t), *(
            _clipped_footprint(self.placed[j], self.span[j])
            for j in self.record.stages[t].fill)])

    def _street_band(self, t: int) -> BaseGeometry:
        """The ground in front of stage t's facades (as deep as its mass behind)."""
        if t not in self._street:
            st = self.plan.stages[t]
            self._street[t] = _in_front(st.points, st.front, self._stage_depth(t))
        return self._street[t]

    def _street_box(self, t: int) -> tuple[float, ...]:
        """The bounds of :meth:`_street_band` (made once)."""
        if t not in self._street_boxes:
            self._street_boxes[t] = tuple(float(v) for v in self._street_band(t).bounds)
        return self._street_boxes[t]

    def _touching(self, s: int) -> set[int]:
        """The stages that share a key point with stage s (s too); the stages at each
        key point are listed once: testing every pair took a building of 2,000 stages
        7 s."""
        if self._at_key is None:
            self._at_key = {}
            for t, o in enumerate(self.plan.stages):
                for key in {o.start, o.end}:
                    self._at_key.setdefault(key, set()).add(t)
        st = self.plan.stages[s]
        return self._at_key.get(st.start, set()) | self._at_key.get(st.end, set())

    def _apart(self, s: int) -> list[int]:
        """The stages that share no key point with stage s."""
        near = self._touching(s)
        return [t for t in range(len(self.plan.stages)) if t not in near]

    def _stage_depth(self, s: int) -> float:
        """How deep stage s's deepest module reaches behind its facade."""
        return max((self.placed[i].y_range[1] for i in self.record.stages[s].fill),
                   default=0.0)

    def _stage_band(self, s: int) -> BaseGeometry:
        """The ground behind stage s's facades, as deep as its deepest module (once all
        modules are placed: joints and medial cuts come after)."""
        if s not in self._bands:
            st = self.plan.stages[s]
            self._bands[s] = behind(st.points, st.front, self._stage_depth(s))
        return self._bands[s]

    def _mass_band(self, s: int) -> BaseGeometry:
        """Stage s's band (:meth:`_stage_band`), or where it has no module (a side two
        long-legged corners make) the ground behind it as deep as those corners. (With
        what its end modules cover past a concave mitre joint, ``_reach``, the ground
        another structure's modules meet it on.)"""
        if self.record.stages[s].fill:
            return self._stage_band(s)
        st = self.plan.stages[s]
        return behind(st.points, st.front, self._mass_depth(s))

    def _mass_depth(self, s: int) -> float:
        """How deep stage s's mass reaches behind its facade: its deepest module, or
        where it has none its end corners."""
        if self.record.stages[s].fill:
            return self._stage_depth(s)
        st = self.plan.stages[s]
        ends = [self.record.keys.get((st.start, st.start_leg)),
                self.record.keys.get((st.end, st.end_leg))]
        return max((self.placed[i].y_range[1] for i in ends if i is not None), default=0.0)

    def _far_band(self, s: int, near: BaseGeometry) -> BaseGeometry:
        """The ground behind every stage that shares no key point with stage s, where
        it meets ``near`` (only the bands that reach it: the union of every far band,
        once a stage, made a building of 1,000 stages take minutes, N² in its
        stages)."""
        if self._band_tree is None:
            self._band_tree = shapely.STRtree(
                [self._stage_band(t) for t in range(len(self.plan.stages))])
        touching = self._touching(s)
        hits = sorted(int(t) for t in self._band_tree.query(near) if int(t) not in touching)
        return shapely.union_all([self._stage_band(t) for t in hits])

    def _medial_runs(self, s: int) -> None:
        """Within one stage, a bend's fold plane separates every piece before it from
        every piece after it, not only the two pieces folded there: a short run between
        two bends, or a module starting just past a bend that tilts forward at depth,
        would otherwise leave a piece reaching behind its neighbours' facades."""
        path = self.paths[s]
        fill = self.record.stages[s].fill
        if len(path.len) < 2 or not fill:
            return
        run = {i: self._run_of(i, path) for i in fill}
        centre = {i: self.placed[i].origin + self.placed[i].a @ np.array(
            [self.placed[i].length / 2, 0.0]) for i in fill}
        reach = {i: self.placed[i].length + abs(self.placed[i].y_range[0])
                 + abs(self.placed[i].y_range[1]) for i in fill}
        for k in range(1, len(path.p) - 1):
            fold = bisector(path.dir[k - 1], path.dir[k])
            for i in fill:
                if float(np.hypot(*(centre[i] - path.p[k]))) > reach[i]:
                    continue
                half = HalfPlane(tuple(fold if run[i] < k else -fold), tuple(path.p[k]),
                                 extends=False)
                if half not in self.placed[i].halves and self._reaches_past(i, half):
                    self.placed[i].halves.append(half)

    def _reaches_past(self, i: int, half: HalfPlane) -> bool:
        """Whether module i has mass past ``half`` (more than MEDIAL_MIN_AREA of plan)
        while its facade stays clear of it (a plane that would cut the facade is left)."""
        n, c = np.asarray(half.normal), float(np.asarray(half.point) @ np.asarray(half.normal))
        facade = self._facade(i)
        if (facade @ n > c + TOL).any():
            return False
        return self._past(i, half).area > MEDIAL_MIN_AREA

    def _past(self, i: int, half: HalfPlane, extra: BaseGeometry | None = None
              ) -> BaseGeometry:
        """The plan of module i (as cut so far), with ``extra`` ground of it (its
        extension past a concave joint, as cut so far), on the far side of ``half``."""
        placed = self.placed[i]
        foot = _clipped_footprint(placed, self.span[i])
        if extra is not None:
            foot = shapely.union_all([foot, extra])
        return _beyond(foot, half, placed)

    def _facade(self, i: int) -> np.ndarray:
        """The world end points of module i's facade line as its cuts so far leave it (a
        folded piece's facade stops at its bends)."""
        placed = self.placed[i]
        lo, hi = self.span[i]
        for a, _b, c in placed.local_planes():
            if a > 1e-9:
                hi = min(hi, c / a)
            elif a < -1e-9:
                lo = max(lo, c / a)
        return np.array([[lo, 0.0], [max(lo, hi), 0.0]]) @ placed.a.T + placed.origin

    def _run_of(self, i: int, path: _Path) -> int:
        return _nearest_segment(self._facade(i).mean(axis=0), path)

    def _medial(self, i: int, s: int, t: int, k: int | None = None) -> None:
        """Cut module i (of stage s) where it lies deeper behind its facade than behind
        stage t's facade segment k (by default the one nearest the module)."""
        half = self._medial_half(i, s, t, k)
        if half is not None:
            self.placed[i].halves.append(half)

    def _medial_half(self, i: int, s: int, t: int, k: int | None = None,
                     other: _Placer | None = None) -> HalfPlane | None:
        """The plane of :meth:`_medial` (None where there is none, or where it would
        cut module i's facade); stage t of ``other`` structure, if given."""
        placed = self.placed[i]
        centre = _centre(placed)
        of_t = other if other is not None else self
        path_t = of_t.paths[t]
        if k is None:
            k = _nearest_segment(centre, path_t)
        return _wing_plane(_mass_normal(placed.a[:, 0], self.plan.stages[s].front),
                           placed.origin, self._facade(i), of_t, t, k,
                           _clipped_footprint(placed, self.span[i]), placed)

    # -- mitre joints ---------------------------------------------------------------------

    def _cut_reaching(self, order, half: HalfPlane, s: int, t: int, *,
                      bisector: bool = False) -> None:
        """Add ``half`` to the modules of stage s, nearest the corner first, whose
        footprint reaches past it; the first (the one at the corner) always. A module
        whose mass past the plane misses stage t (the other side of the joint) and lies
        in a stage sharing no corner with s is left to the medial plane between those
        two (:meth:`_medial_cuts`): past a short side t (an acute corner cut off by a
        few metres of facade) the joint's plane would leave a wedge of roof open. No
        facade of a straight stage lies past the ``bisector`` (through the corner), so
        a module (after the corner's own) whose facade reaches past it is on a stage
        that curved back (a crescent round a roundabout, a sliver's bending side), and
        no part of the corner: it is left. (A nose's plane takes whole facades near an
        acute corner by design.)"""
        other = self._stage_band(t)
        for n, i in enumerate(order):
            placed = self.placed[i]
            (x0, x1), (y0, y1) = self.span[i], placed.y_range
            corners = np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1]]) @ placed.a.T \
                + placed.origin
            if n > 0 and not ((corners - half.point) @ np.asarray(half.normal) > TOL).any():
                return
            if bisector and n > 0 and (self._facade(i) @ np.asarray(half.normal)
                                       > float(np.asarray(half.point) @ np.asarray(
                                           half.normal)) + TOL).any():
                continue
            past = self._past(i, half) if n > 0 else None
            if past is not None and past.intersection(other).area <= MEDIAL_MIN_AREA \
                    and past.intersection(self._far_band(s, past)).area > MEDIAL_MIN_AREA:
                continue
            placed.halves.append(half if n == 0 else replace(half, extends=False))

    def _past_concave(self, j: int, s_in: int, s_out: int, before: HalfPlane,
                      after: HalfPlane, depth: Callable[[int], float]
                      ) -> list[tuple[int, BaseGeometry]]:
        """At concave key j: the ground past the key point behind each side's facade
        line (each stage's band continued, ``depth(s)`` deep, up to the corner's
        bisector plane: ``before`` keeps s_in's side, ``after`` s_out's), which the
        stage's band stops short of; added to each stage's ``_reach``, so that the
        stages apart from it and other structures' modules meet it there. Its (stage,
        ground) pairs."""
        out = []
        for s, u, half, incoming in ((s_in, self.paths[s_in].dir[-1], before, True),
                                     (s_out, self.paths[s_out].dir[0], after, False)):
            k = len(self.paths[s].len) - 1 if incoming else 0
            reach = concave_reach(self.kxy[j], u, half, self.plan.stages[s].front,
                                  depth(s), incoming)
            self._reach.setdefault(s, []).append((k, reach))
            out.append((s, reach))
        return out

    def _corner_reach(self, j: int) -> None:
        """A concave corner part's ground past its key point (the square behind both
        sides' facade lines, which it covers and neither stage's band does) as its two
        stages' ``_reach``, split on its bisector as a concave mitre joint's extensions
        are: a courtyard's corner part stood in the modules of the outline's ring
        round a 14 m wing, which met no mass there and were not cut (54 m² shared, 2.1 %
        of a 60 m block), and the outline's convex corner part was not split there
        either (58.6 m²)."""
        p = self.leg_part(j)
        i = self.record.keys.get((j, 0))
        s_in, s_out = self._sides(j)
        if p is None or p.cls != "corner" or i is None or s_in is None or s_out is None:
            return
        u_in, u_out, mass_left = self._turn(s_in, s_out)
        if is_convex(u_in, u_out, mass_left):
            return
        before, after, _how, _trim = joint_halves(self.kxy[j], u_in, u_out, mass_left)
        depth = max(abs(self.placed[i].y_range[0]), abs(self.placed[i].y_range[1]))
        self._past_concave(j, s_in, s_out, before[0], after[0], lambda _s: depth)

    def _end_part(self, s: int, start: bool) -> list[int]:
        """The end part closing stage s at its start (or end), as a list: none where that
        end is a corner, a T or a joint. Beside a sharp corner a short wing reaches past
        the joint's plane with its end part too, into the other wing's end part (two
        60 m wings at 15 degrees overlapped on 39 m² there), so it is cut like a module."""
        st = self.plan.stages[s]
        i = self.record.keys.get((st.start, st.start_leg) if start else (st.end, st.end_leg))
        return [i] if i is not None and self.placed[i].cls in ("end_left", "end_right") else []

    def _joint(self, j: int) -> None:
        """Cut the modules meeting at joint j on its bisector plane."""
        s_in, s_out = self._sides(j)
        if s_in is None or s_out is None:
            return
        fill_in = self.record.stages[s_in].fill
        fill_out = self.record.stages[s_out].fill
        if not fill_in or not fill_out:
            xy = self.kxy[j]
            raise ExportError(f"{self.plan.name}: a side at the corner ({xy[0]:.1f}, "
                              f"{xy[1]:.1f}) is too short for any module of the style; "
                              "merge it into its neighbours or use a corner part")
        u_in, u_out, mass_left = self._turn(s_in, s_out)
        before, after, how, trim = joint_halves(self.kxy[j], u_in, u_out, mass_left)
        # every module near the corner whose mass reaches past a plane is cut by it (at
        # a right angle, the modules within a building depth of the corner)
        for m, half in enumerate(before):   # the first through the corner, the bisector
            self._cut_reaching([*reversed(fill_in), *self._end_part(s_in, start=True)], half,
                               s_in, s_out, bisector=m == 0)
        for m, half in enumerate(after):
            self._cut_reaching([*fill_out, *self._end_part(s_out, start=False)], half, s_out,
                               s_in, bisector=m == 0)
        if how == "mitre" and not is_convex(u_in, u_out, mass_left):
            # (in, then out: one stage is both at a ring's seam)
            for end, (_s, reach) in zip((fill_in[-1], fill_out[0]), self._past_concave(
                    j, s_in, s_out, before[0], after[0], self._stage_depth), strict=True):
                self._extension.setdefault(end, []).append(reach)
        self.record.joints[j] = how
        self.record.joint_ends[j] = (self.kxy[j] - u_in * trim, self.kxy[j] + u_out * trim)


MEDIAL_MIN_AREA = 0.05   # m²: a module reaching less into another stage's mass is left
COVER_SHARE = 0.9        # of what a medial plane takes off an extension that runs out
                         # of a facade, the share that facade's modules must cover
FACADE_INSET = 0.05      # m: an extension running out through a facade stops this far
                         # behind it (see _Placer._stop_at_facades)
FACING_AWAY = 0.985      # cos 10°: two facades this near back to back across a wing
REOPEN_SHARE = 0.8       # of what dropping a medial plane gives back, the share that
                         # must be open ground inside the building (see _reopen)
UNCOVERED_AREA = 0.01    # m²: the most a cut of a module's extension may leave unroofed
                         # (in plan; 0.05 left 5 cm triangles open, seen from above)
REACH_SHARE = 0.5        # a medial plane against a concave extension must remove mostly
                         # ground that extension (or its stage's band) covers


def _medial_between(placers: list[_Placer], db: PartDB) -> None:
    """Each structure's modules against every other's masses (a courtyard against its
    outline, :meth:`_Placer.medial_against`), in the same order as ever, but only where
    what one reaches meets the other's masses or street front (bounding boxes): a
    footprint of 361 small courtyards made 130,000 pairs, each building its masses
    again, and ran for minutes; a pair whose boxes stay apart has nothing to cut."""
    if len(placers) < 2:
        return
    reach = [p.reach(db) for p in placers]
    region = [p.region() for p in placers]
    for a, b in itertools.permutations(range(len(placers)), 2):
        (ax0, ay0, ax1, ay1), (bx0, by0, bx1, by1) = reach[a], region[b]
        if ax0 <= bx1 and bx0 <= ax1 and ay0 <= by1 and by0 <= ay1:
            placers[a].medial_against(placers[b])


def _reopen(placers: Sequence[_Placer]) -> None:
    """Give back ground a medial plane against another structure took off a module
    and no module now covers. The plane is the one of equal depth behind the module's
    facade and the other facade's infinite line; past the end of that facade (where a
    courtyard's wing meets one of another width) it takes off ground that belongs to
    no one, and the roof opens in a triangle. The plane is dropped where what that
    gives back lies mostly (:data:`REOPEN_SHARE`) on such open ground inside the
    building, so a module never takes back much ground another already covers.
    (Ownership by the nearest facade segment instead of its line would need no repair,
    but is not convex: a module would need two pieces.) The same holds for a corner
    part cut against its own ring's far side across a narrow wing. The building's
    ground is every side's mass band: a side only two corner parts build has no module,
    and its ground is as deep as their legs (a zero-deep band hid the gap behind it)."""
    if not any(p._against for p in placers):
        return
    inside, street = [], []
    for p in placers:
        for s in range(len(p.plan.stages)):
            inside.append(p._mass_band(s))
            street.append(p._street_band(s))
    building = shapely.union_all(inside).difference(shapely.union_all(street))
    feet = {(n, i): p._covered(i) for n, p in enumerate(placers) for i in p._coverers()}
    gaps = building.difference(shapely.union_all(list(feet.values())))
    if gaps.area <= MEDIAL_MIN_AREA:
        return
    for n, p in enumerate(placers):
        for i, half in p._against:
            if (n, i) not in feet or half not in p.placed[i].halves:
                continue
            whole = p._covered(i, without=half)
            if not gaps.intersects(whole):
                continue
            placed = p.placed[i]
            back = whole.difference(feet[(n, i)])
            if back.area <= MEDIAL_MIN_AREA:
                continue
            # on the overlay grid: unsnapped, GEOS once found all of a 101 m² piece in
            # gaps of which 29 m² lay in the building at all (the rest in a courtyard),
            # and a module dropped its plane and stood 69 m² into the courtyard
            if _shared_area(back, gaps) >= REOPEN_SHARE * back.area:
                placed.halves.remove(half)
                feet[(n, i)] = p._covered(i)
                gaps = gaps.difference(back)


def _centre(placed: Placed) -> np.ndarray:
    """The middle of a placed part's facade (where it meets its stage's path)."""
    return placed.origin + placed.a @ np.array([placed.length / 2, 0.0])


def _shared_area(a: BaseGeometry, b: BaseGeometry) -> float:
    """The area ``a`` and ``b`` share, overlaid on :data:`GRID` (their polygons only: a
    difference may hold lines too, which a snapped overlay refuses)."""
    return float(shapely.intersection(shapely.multipolygons(polygons_in(a)),
                                      shapely.multipolygons(polygons_in(b)),
                                      grid_size=GRID).area)


def _run_folds(path: _Path, runs: list[int], n: int, extends: bool = True
               ) -> list[HalfPlane]:
    """The bend planes that cut the piece on run ``runs[n]`` of ``path`` (a segment
    index; ``runs`` those a folded module or T leg covers, in order): past the bend
    before it, and short of the next, each on the bend's bisector."""
    k, out = runs[n], []
    if n > 0:            # after the bend at vertex k: keep what lies past it
        fold = bisector(path.dir[k - 1], path.dir[k])
        out.append(HalfPlane(tuple(-fold), tuple(path.p[k]), extends))
    if n < len(runs) - 1:   # before the next bend
        nxt = runs[n + 1]
        fold = bisector(path.dir[k], path.dir[nxt])
        out.append(HalfPlane(tuple(fold), tuple(path.p[nxt]), extends))
    return out


def _fold_at_ends(pieces: list[Placed], path: _Path, runs: list[int],
                  reach: tuple[float, float]) -> None:
    """A module that ends (or starts) exactly on a bend is cut there too, on the bend's
    bisector: square-ended, it would overlap its neighbour behind a concave bend and
    leave a wedge open behind a convex one."""
    first, last = runs[0], runs[-1]
    if 1 <= first and abs(path.cum[first] - reach[0]) <= TOL:
        fold = bisector(path.dir[first - 1], path.dir[first])
        pieces[0].halves.append(HalfPlane(tuple(-fold), tuple(path.p[first])))
    nxt = last + 1
    if nxt <= len(path.p) - 2 and abs(path.cum[nxt] - reach[1]) <= TOL:
        fold = bisector(path.dir[last], path.dir[nxt])
        pieces[-1].halves.append(HalfPlane(tuple(fold), tuple(path.p[nxt])))


def _medial_plane(m_s: np.ndarray, p_s: np.ndarray, facade: np.ndarray, path_t: _Path,
                  front_t: Front, k: int | None = None) -> HalfPlane | None:
    """The plane of equal depth behind a facade (through ``p_s``, its mass normal
    ``m_s``, its end points ``facade``) and segment k of stage path ``path_t`` (by
    default the one nearest the facade's middle), keeping the first's side; None where
    the facades are parallel and face the same way, or where it would cut the facade."""
    if k is None:
        k = _nearest_segment(facade.mean(axis=0), path_t)
    m_t = _mass_normal(path_t.dir[k], front_t)
    n = m_s - m_t
    norm = float(np.hypot(*n))
    if norm < 1e-6:
        return None
    c = (float(p_s @ m_s) - float(path_t.p[k] @ m_t)) / norm
    n = n / norm
    if (facade @ n > c - TOL).any():   # it would cut the facade itself: leave it
        return None
    return HalfPlane(tuple(n), tuple(n * c), extends=False)


def _wing_plane(m_s: np.ndarray, p_s: np.ndarray, facade: np.ndarray, of_t: _Placer,
                t: int, k: int | None, ground: BaseGeometry, placed: Placed
                ) -> HalfPlane | None:
    """The plane a facade's mass (its mass normal ``m_s``, a point ``p_s`` and the end
    points ``facade`` of the facade; what it covers, ``ground``, of instance ``placed``)
    is cut on against stage t of ``of_t``: the plane of equal depth behind both
    (:func:`_medial_plane`, at segment k of t, by default the one nearest the facade's
    middle). Where the two stand
    back to back across a wing and t's mass is shallower than half the wing, that middle
    would leave a slit of open roof behind t's mass: there the back of t's mass, if it
    leaves more of ``ground``."""
    path_t, front_t = of_t.paths[t], of_t.plan.stages[t].front
    if k is None:
        k = _nearest_segment(facade.mean(axis=0), path_t)
    half = _medial_plane(m_s, p_s, facade, path_t, front_t, k)
    m_t = _mass_normal(path_t.dir[k], front_t)
    depth = of_t._mass_depth(t)
    if half is None or float(m_s @ m_t) > -FACING_AWAY or depth <= 0.0 or ground.is_empty:
        return half
    back = HalfPlane(tuple(-m_t), tuple(path_t.p[k] + m_t * depth), extends=False)
    return back if (_beyond(ground, back, placed).area
                    < _beyond(ground, half, placed).area) else half


def _beyond(ground: BaseGeometry, half: HalfPlane, placed: Placed) -> BaseGeometry:
    """What of ``ground`` (of instance ``placed``) lies on the far side of ``half``."""
    return ground.intersection(half_polygon(-np.asarray(half.normal),
                                            np.asarray(half.point), _reach(placed, half)))


def _in_front(points, front: Front, depth: float) -> BaseGeometry:
    """The ground in front of a facade polyline (the street side), ``depth`` deep
    (at least 1 m): :func:`~citysynth.export.joints.behind` turned round."""
    return behind(points, "left" if front == "right" else "right", max(depth, 1.0))


def _mass_normal(direction: np.ndarray, front: Front) -> np.ndarray:
    """The unit normal of a facade running along ``direction``, into its mass."""
    u = np.asarray(direction, dtype=float)
    u = u / float(np.hypot(*u))
    return _left(u) if front == "right" else -_left(u)


def _footprint(placed: Placed, span: tuple[float, float]) -> BaseGeometry:
    """A module's plan rectangle (over its span, front overhang to depth)."""
    return shapely.polygons(_plan_corners(placed, span))


def _plan_corners(placed: Placed, span: tuple[float, float]) -> list[tuple[float, float]]:
    """The corners of a module's plan rectangle: as :func:`_footprints` makes them, in
    plain floats (the same sums in the same order; a layout asks for thousands one at a
    time, and small numpy arrays cost more)."""
    (x0, x1), (y0, y1) = span, placed.y_range
    (a00, a01), (a10, a11) = placed.a.tolist()
    ox, oy = placed.origin.tolist()
    return [(a00 * x + a01 * y + ox, a10 * x + a11 * y + oy)
            for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]


def _footprints(placed: Sequence[Placed], spans: Sequence[tuple[float, float]]
                ) -> np.ndarray:
    """Modules' plan rectangles (each over its span, front overhang to depth), built
    in one call (a block has hundreds)."""
    if not placed:
        return np.empty(0, dtype=object)
    (x0, x1), (y0, y1) = np.array(spans).T, np.array([p.y_range for p in placed]).T
    local = np.stack([np.stack([x0, x1, x1, x0], axis=1),
                      np.stack([y0, y0, y1, y1], axis=1)], axis=2)       # [n, 4, 2]
    a = np.array([p.a for p in placed])                                # [n, 2, 2]
    origin = np.array([p.origin for p in placed])
    return shapely.polygons(np.einsum("nkj,nij->nki", local, a) + origin[:, None, :])


def _clipped_footprint(placed: Placed, span: tuple[float, float]) -> BaseGeometry:
    """A module's plan rectangle less what its half-planes cut away so far: the
    rectangle of :func:`_footprint` clipped in plain floats (a convex quad stays
    convex; a layout asks this thousands of times)."""
    plan = clipped_plan(_plan_corners(placed, span), placed.halves)
    return shapely.polygons(plan) if len(plan) >= 3 else shapely.Polygon()


def _clipped(foot: BaseGeometry, placed: Placed) -> BaseGeometry:
    """Ground ``foot`` of a module less what its half-planes cut away so far."""
    for h in placed.halves:
        foot = foot.intersection(half_polygon(h.normal, h.point, _reach(placed, h)))
    return foot


def _reach(placed: Placed, half: HalfPlane) -> float:
    """How large a square round the half-plane's point covers the module: its own size
    and its distance from that point (a medial plane's point is where the plane passes
    nearest the frame's origin, which in a city is hundreds of metres away)."""
    ox, oy = placed.origin.tolist()
    return 10.0 * (placed.length + abs(placed.y_range[0]) + abs(placed.y_range[1]) + 1.0) \
        + 2.0 * float(np.hypot(float(half.point[0]) - ox, float(half.point[1]) - oy))


def _overlapping(tree: shapely.STRtree, bands: list[BaseGeometry],
                 region: BaseGeometry) -> list[int]:
    """The bands (indices into ``bands``, which ``tree`` holds, in order) that
    ``region`` reaches into by more than MEDIAL_MIN_AREA."""
    return [t for t in sorted(int(t) for t in tree.query(region, predicate="intersects"))
            if region.intersection(bands[t]).area > MEDIAL_MIN_AREA]


def _nearest_segment(q: np.ndarray, path: _Path) -> int:
    """The index of the segment of ``path`` nearest point ``q`` (the first, on a tie)."""
    return int(np.argmin([_seg_distance(q, path.p[n], path.p[n + 1])
                          for n in range(len(path.len))]))


def _seg_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    t = float(np.clip((q - a) @ d / max(float(d @ d), 1e-12), 0.0, 1.0))
    return float(np.hypot(*(q - (a + d * t))))


def _straight_key(p: Part, si: int, j: int, xy, v, before: bool, front: str) -> Placed:
    """A straight part spanning vector v from key point xy: before the key (it ends at
    the key, v points back along its stage) or after it."""
    length = float(np.hypot(*v))
    u = (-v if before else v) / length
    a = np.column_stack([u * (length / _geom_length(p)),
                         _left(u) if front == "right" else -_left(u)])
    return _instance(p, si, None, j, a, xy + v if before else xy)


def _instance(p: Part, structure: int, stage, key, a: np.ndarray, origin) -> Placed:
    """A placed part (cut later where it meets a joint or a bend)."""
    length = _geom_length(p) if p.cls in ("middle", "end_left", "end_right") else 0.0
    return Placed(p.id, p.cls, length, y_range(p), structure, stage, key,
                  np.asarray(a, dtype=float), np.asarray(origin, dtype=float))


def _fit(d0, d1, w0, w1) -> np.ndarray:
    """The 2x2 map sending canonical leg directions d0, d1 onto w0, w1."""
    src = np.column_stack([d0, d1]).astype(float)
    dst = np.column_stack([w0, w1]).astype(float)
    return dst @ np.linalg.inv(src)
_Segment = tuple[np.ndarray, np.ndarray, int | None, int | None]   # a, b, instance, leg


def _check(plan: PlacementPlan, record: _Record, parts: dict[str, Part],
           inst: list[Instance], keys: Sequence[str],
           solved: Sequence[float | None], quantum: float) -> None:
    """The layout's geometry against its skeleton (``keys``: the solution's element at
    each key point; ``solved``: the length the solver counted on each stage, legs
    included, and ``quantum`` the length quantum it counted in); any failure is an
    ExportError."""
    for s, r in record.stages.items():
        st = plan.stages[s]
        where = f"{plan.name}: stage {s}"
        _check_length(where, st, r, solved[s], quantum)
        # facade segments in travel order: start key's leg, fillers, end key's leg
        segs = [_key_segment(plan, record, parts, inst, keys, st.start, r.start_leg,
                             outgoing=True)]
        for i in r.fill:
            lo, hi = facade_span(inst[i].cut, _geom_length(parts[inst[i].part]))
            if hi > lo:      # else the nose of an acute corner took its whole facade
                segs.append((inst[i].apply([lo, 0.0]), inst[i].apply([hi, 0.0]), i, None))
        segs.append(_key_segment(plan, record, parts, inst, keys, st.end, r.end_leg,
                                 outgoing=False))
        _check_joined(where, [(a, b) for a, b, _i, _leg in segs], bool(r.fill))
        ends = np.array([(a, b) for a, b, _i, _leg in segs], dtype=float)
        offs = r.path.distances(ends.reshape(-1, 2)).reshape(-1, 2)
        for n, (a, b, idx, leg) in enumerate(segs):
            if idx is None:     # a mitre joint: a point, and no part of its own
                continue
            i = idx
            p = parts[inst[i].part]
            _check_on_path(where, (a, b), offs[n], inst[i].part,
                           "leg of the key part" if leg is not None else "part")
            element = keys[st.start] if n == 0 else keys[st.end]
            _check_facing(where, (a, b), _facade_normal(inst[i], p, element, leg), st.front,
                          inst[i].part)


def _key_segment(plan: PlacementPlan, record: _Record, parts: dict[str, Part],
                 inst: list[Instance], plan_keys: Sequence[str], j: int, leg: int, *,
                 outgoing: bool) -> _Segment:
    """The facade segment of key j's leg on a stage, in travel order (at a mitre joint:
    the corner, or across the nose of an acute one)."""
    i = record.keys.get((j, leg))
    if i is None:
        xy = np.asarray(plan.keys[j].xy, dtype=float)
        a, b = record.joint_ends.get(j, (xy, xy))
        return a, b, None, None
    p = parts[inst[i].part]
    if p.cls in ("end_left", "end_right"):
        return inst[i].apply([0.0, 0.0]), inst[i].apply([_geom_length(p), 0.0]), i, None
    o, reach = _leg_reach(p, plan_keys[j], leg)
    far = record.leg_ends.get((j, leg), i)     # a leg folded over a bend ends on its last piece
    key, end = inst[i].apply(o), inst[far].apply(o + reach)
    return (key, end, i, leg) if outgoing else (end, key, i, leg)


def _leg_reach(p: Part, element: str, leg: int) -> tuple[np.ndarray, np.ndarray]:
    """Key part p's key point in its own frame (on its back face when a T is turned
    over) and the vector its structure leg ``leg`` spans from there to the leg's end on
    the facade."""
    m = part_leg(element, leg)
    o = np.array([0.0, _depth(p, element)])
    return o, np.asarray(p.directions[m]) * (p.legs_measured[m] - (o[1] if m == 2 else 0.0))


def _check_length(where: str, st: PlanStage, r: _StageRecord, solver: float | None,
                  quantum: float) -> None:
    """The stage's parts fill its skeleton as the solver counted: its count within the
    stage's interval, and the parts' own geometry within a quantum a key part of that
    count. The solver counts a key part's legs on the quantum grid, but a corner or a T
    is not stretched to them (two legs at an angle, or collinear, take no one scale), so
    a library drawn off the grid (a 0.3 m quantum over a 0.2 m design) has legs up to
    half a quantum off, and a turned-over T's depth as much again: the fillers' stretch
    takes that up too."""
    lo, hi = st.length_interval
    counted = r.solved if solver is None else solver
    keys = 0.0 if solver is None else 2 * quantum     # two ends, leg and depth each
    if abs(r.path.length - counted) > (hi - lo) / 2 + TOL or \
            abs(r.solved - counted) > keys + TOL:
        raise ExportError(f"{where}: its parts measure {r.solved:.3f} m for "
                          f"{r.path.length:.3f} m of skeleton, more than the "
                          f"{(hi - lo) / 2:g} m a stretch may absorb")


def _check_joined(where: str, segs: list[tuple[np.ndarray, np.ndarray]],
                  has_fill: bool) -> None:
    """Consecutive facade segments meet (gap or overlap under TOL)."""
    for (_a, b), (c, _d) in zip(segs[:-1], segs[1:], strict=True):
        gap = float(np.hypot(*(c - b)))
        if gap > TOL:
            at = (b + c) / 2
            hint = "" if has_fill else (" (no middle part lies between its key "
                                        "parts to absorb the difference)")
            raise ExportError(f"{where}: parts do not meet at ({at[0]:.2f}, "
                              f"{at[1]:.2f}), {1e3 * gap:.1f} mm apart{hint}")


def _check_on_path(where: str, seg: tuple[np.ndarray, np.ndarray], offs: np.ndarray,
                   part: str, what: str) -> None:
    """A facade segment's ends (``offs``: their distances to the skeleton) lie on it."""
    for q, off in zip(seg, offs.tolist(), strict=True):
        if off > TOL:
            raise ExportError(f"{where}: a {what} {part} ends {1e3 * off:.1f} mm off the "
                              f"skeleton at ({q[0]:.2f}, {q[1]:.2f})")


def _check_facing(where: str, seg: tuple[np.ndarray, np.ndarray], facing: np.ndarray,
                  front: Front, part: str) -> None:
    a, b = seg
    mid = (a + b) / 2
    tangent = (b - a) / max(float(np.hypot(*(b - a))), 1e-12)
    into_mass = _left(tangent) * (1.0 if front == "right" else -1.0)
    if float(facing @ -into_mass) <= 0:
        raise ExportError(f"{where}: part {part} at ({mid[0]:.2f}, {mid[1]:.2f}) does not "
                          f"face the street side ({front} of travel)")


def _facade_normal(inst: Instance, p: Part, element: str, leg: int | None) -> np.ndarray:
    """Where the facade of this instance (on this stage) faces, in the layout frame:
    the image of the canonical facade normal, the right of the leg's travel (a T turned
    over shows its main range's back face)."""
    if p.cls in ("corner", "t_junction") and leg is not None:
        m = part_leg(element, leg)
        d = np.asarray(p.directions[m], dtype=float)
        travel = d if m != 0 else -d
        n = np.array([travel[1], -travel[0]])
        if m != 2 and t_pose(element).street:
            n = -n
    else:
        n = np.array([0.0, -1.0])
    a = np.array([inst.x_axis, inst.y_axis]).T
    return a @ n


def _summary(plan: PlacementPlan, sol: StructureSolution, record: _Record) -> dict[str, Any]:
    stages = []
    for s, st in enumerate(plan.stages):
        r = record.stages[s]
        stages.append({
            "from": st.start, "to": st.end, "front": st.front,
            "length": r.path.length, "stretch": r.stretch,
            "parts": [t_pose(sol.keys[st.start]).part, *sol.stages[s],
                      t_pose(sol.keys[st.end]).part],
            "asked": {k: list(v) for k, v in st.asked.items()},
            "met": {r: v for r, v in sol.resources[s].items() if r != FILLED},
            "skeleton_edges": list(st.edges),
            "polyline": [list(p) for p in st.points],
        })
    keys = [{"part": t_pose(sol.keys[j]).part, "kind": k.kind, "xy": list(k.xy),
             "skeleton_key": k.skeleton_key, "joint": record.joints.get(j, "part"),
             **_pose_field(sol.keys[j])}
            for j, k in enumerate(plan.keys)]
    total: dict[str, float] = {}
    for res in sol.resources:
        for name, v in res.items():
            if name != FILLED:
                total[name] = total.get(name, 0.0) + v
    out = {"name": plan.name, "closed": plan.closed, "cost": sol.cost,
           "keys": keys, "stages": stages, "resources": total}
    if plan.asked:
        out["asked"] = {k: list(v) for k, v in plan.asked.items()}
    return out


def _pose_field(element: str) -> dict[str, str]:
    """A T part's pose in the summary ("swap", "street", "swap+street"), when it has one."""
    _part, _, flags = element.partition(SEP)
    return {"pose": flags} if flags and not is_joint(element) else {}


def max_stretch(lay: Layout) -> float:
    """The largest |stretch - 1| over the layout's stages."""
    return max((abs(s["stretch"] - 1.0) for st in lay.structures for s in st["stages"]),
               default=0.0)
