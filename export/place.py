"""Put a solved structure back on its skeleton: every part's placement, then checks.

Along a stage, the key part at its start reaches in by its leg, the key part at its
end by its leg, and the middle parts fill what lies between, all stretched by the one
factor that absorbs the quantisation (the solver met the length within half a
quantum; the stage's ``stretch`` reports the factor). A corner is placed by the affine
map that sends its legs' canonical directions onto the skeleton's edges, each leg
stretched with its own stage, which also adapts it to an angle a few degrees off its
own. T parts stay rigid (their main legs are collinear, so one linear map cannot
stretch them by two factors); the rest of their stages absorbs the difference. A stage
whose facades face the left of travel is placed mirrored (the canonical facade faces
the right, -Y). A part that spans a bend follows the bend's chord.

A mitre (a corner made of the style's two end parts, see
:func:`pipeline.structures.skeleton_structure`) is two instances: the end part that
closes the incoming stage and the one that opens the outgoing stage, meeting at the key
point at whatever angle the corner has.

Then every layout is checked, and a failed check is an error: each stage's parts
measure its skeleton length within the stage's length interval (half a quantum unless
the caller allowed a relative stretch; so the stretch only absorbs what was allowed,
under 0.5 % on stages over 20 m at a 0.2 m quantum), consecutive parts meet
(gap or overlap under 1 mm), key-part legs end on their edges, every facade has both
ends on the skeleton and faces the stage's front side (so its mass lies behind the
skeleton line, never on the street side).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from citysynth.export.errors import ExportError
from citysynth.export.layout import AXIS_DIGITS, COORD_DIGITS, Instance, Layout
from citysynth.export.plan import Front, PlacementPlan, PlanStage, other_side
from citysynth.parts_db import Part, PartDB

TOL = 0.001          # metres: the largest gap, overlap or offset the checks accept


class _Path:
    """A stage's polyline, by arc length."""

    def __init__(self, points):
        self.p = np.asarray(points, dtype=float)
        seg = np.diff(self.p, axis=0)
        self.len = np.hypot(seg[:, 0], seg[:, 1])
        self.cum = np.concatenate([[0.0], np.cumsum(self.len)])
        self.dir = seg / self.len[:, None]

    @property
    def length(self) -> float:
        return float(self.cum[-1])

    def at(self, s: float) -> np.ndarray:
        i = int(np.clip(np.searchsorted(self.cum, s, side="right") - 1, 0, len(self.len) - 1))
        return self.p[i] + self.dir[i] * (s - self.cum[i])

    def distance(self, q) -> float:
        """Distance from point q to the polyline."""
        q = np.asarray(q, dtype=float)
        t = np.clip(((q - self.p[:-1]) * self.dir).sum(axis=1), 0, self.len)
        near = self.p[:-1] + self.dir * t[:, None]
        return float(np.min(np.hypot(*(q - near).T)))


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


def layout(name: str, rank: int, plans: Sequence[PlacementPlan],
           solutions: Sequence[StructureSolution], db: PartDB) -> Layout:
    """The layout of ``solutions[i]`` (the solver's answer for a structure: the part at
    each key point and the fillers of each stage) on ``plans[i]``, checked."""
    parts = {p.id: p for p in db.parts}
    out = Layout(name, rank, {"name": db.name, "hash": db.library_hash,
                              "quantum": db.quantum},
                 plans[0].style if plans else "", plans[0].frame if plans else "", [])
    for si, (plan, sol) in enumerate(zip(plans, solutions, strict=True)):
        placer = _Placer(si, plan, sol, parts)
        instances, record = placer.place()
        _check(plan, record, parts, instances)
        out.instances.extend(instances)
        out.structures.append(_summary(plan, sol, record))
    return out


class StructureSolution(Protocol):
    """What export reads of a solved structure (the solver's ``StructureSolution``)."""

    keys: list[str]
    stages: list[list[str]]
    cost: float
    resources: list[dict[str, float]]


@dataclass
class _StageRecord:
    fill: list[int]                # instance indices of the stage's fillers
    stretch: float
    start_leg: int
    path: _Path
    solved: float                  # what its parts measure, unstretched


@dataclass
class _Record:
    """Which instance realises each key leg, and each stage's fillers: what the checks
    and the summary read back."""

    keys: dict[tuple[int, int], int] = field(default_factory=dict)
    stages: dict[int, _StageRecord] = field(default_factory=dict)


class _Placer:
    """Places one structure's solution on its plan: one stretch per stage, then the key
    parts, then the fillers."""

    def __init__(self, si: int, plan: PlacementPlan, sol: StructureSolution,
                 parts: dict[str, Part]):
        self.si, self.plan, self.sol, self.parts = si, plan, sol, parts
        self.paths = [_Path(st.points) for st in plan.stages]
        self.ins = plan.incoming()
        self.outs = plan.outgoing()
        self.kxy = [np.array(k.xy) for k in plan.keys]
        self.instances: list[Instance] = []
        self.record = _Record()
        self.stretch: list[float] = []
        self.solved: list[float] = []

    def place(self) -> tuple[list[Instance], _Record]:
        self._stretches()
        for j in range(len(self.plan.keys)):
            self._place_key(j)
        for s in range(len(self.plan.stages)):
            self._place_fillers(s)
        return self.instances, self.record

    # -- what stands at a key point ----------------------------------------------------

    def leg_part(self, j: int, leg: int) -> Part:
        """The part that realises key j's leg: the key part, or for a mitre the end
        part on that side of the corner."""
        mitre = self.plan.mitres.get(self.sol.keys[j])
        if mitre is None:
            return self.parts[self.sol.keys[j]]
        return self.parts[mitre.end_in if leg == 0 else mitre.end_out]

    def leg_len(self, j: int, leg: int) -> float:
        """How far key j reaches along a leg: its geometry, or a mitre's chosen length."""
        mitre = self.plan.mitres.get(self.sol.keys[j])
        if mitre is None:
            return _leg(self.leg_part(j, leg), leg)
        return mitre.length_in if leg == 0 else mitre.length_out

    def _stretches(self) -> None:
        """One stretch per stage: every part on it stretches, except T parts (rigid:
        their two main legs are collinear, so no linear map stretches them by two
        factors)."""
        for s, st in enumerate(self.plan.stages):
            ends = [(self.leg_part(st.start, st.start_leg), self.leg_len(st.start, st.start_leg)),
                    (self.leg_part(st.end, 0), self.leg_len(st.end, 0))]
            rigid = sum(x for p, x in ends if p.cls == "t_junction")
            elastic = sum(x for p, x in ends if p.cls != "t_junction") + \
                sum(_geom_length(self.parts[x]) for x in self.sol.stages[s])
            self.stretch.append((self.paths[s].length - rigid) / elastic if elastic > 0
                                else 1.0)
            self.solved.append(rigid + elastic)

    # -- key parts ------------------------------------------------------------------------
    # each leg is aimed at the point of its stage's polyline that lies its (stretched)
    # length along from the key point, so legs land on the skeleton even where a bend
    # comes before the leg ends

    def _legs(self, j: int) -> dict[int, tuple[Part, np.ndarray]]:
        """Key j's legs: the part realising each and the vector it spans from the key."""
        legs = {}
        s_in = self.ins[j]
        if s_in is not None:
            p = self.leg_part(j, 0)
            scale = 1.0 if p.cls == "t_junction" else self.stretch[s_in]
            path = self.paths[s_in]
            legs[0] = (p, path.at(path.length - self.leg_len(j, 0) * scale) - self.kxy[j])
        for s in self.outs[j]:
            leg = self.plan.stages[s].start_leg
            p = self.leg_part(j, leg)
            scale = 1.0 if p.cls == "t_junction" else self.stretch[s]
            legs[leg] = (p, self.paths[s].at(self.leg_len(j, leg) * scale) - self.paths[s].p[0])
        return legs

    def _front(self, j: int) -> Front:
        s_in = self.ins[j]
        main_out = [s for s in self.outs[j] if self.plan.branch.get(j) != s]
        return self.plan.stages[s_in if s_in is not None else main_out[0]].front

    def _place_key(self, j: int) -> None:
        legs = self._legs(j)
        front = self._front(j)
        key_id = self.sol.keys[j]
        p = None if key_id in self.plan.mitres else self.parts[key_id]
        if p is None or p.cls in ("end_left", "end_right"):  # straight: an end, a mitre
            for leg, (q, v) in legs.items():
                self.record.keys[(j, leg)] = len(self.instances)
                self.instances.append(_straight_key(q, self.si, j, self.kxy[j], v, leg == 0,
                                                    front))
            if p is not None:   # an end part: one instance realises its only leg
                for leg in (0, 1, 2):
                    self.record.keys[(j, leg)] = len(self.instances) - 1
            return
        if p.cls == "corner":
            a = _fit(np.asarray(p.directions[0]) * p.legs_measured[0],
                     np.asarray(p.directions[1]) * p.legs_measured[1], legs[0][1], legs[1][1])
        else:  # a T: fitted to its in-leg and its branch; its out-leg follows the in-leg
            v_br = legs[2][1]
            _check_t_sides(self.plan, j, self.kxy[j], -legs[0][1], v_br, front,
                           self.plan.stages[self.plan.branch[j]].front)
            a = _fit(np.asarray(p.directions[0]) * p.legs_measured[0],
                     np.asarray(p.directions[2]) * p.legs_measured[2], legs[0][1], v_br)
        for leg in (0, 1, 2):
            self.record.keys[(j, leg)] = len(self.instances)
        self.instances.append(_instance(p, self.si, None, j, a, self.kxy[j]))

    # -- fillers, from the end of the start key's leg on ----------------------------------

    def _place_fillers(self, s: int) -> None:
        st = self.plan.stages[s]
        path, stretch = self.paths[s], self.stretch[s]
        p_lo = self.leg_part(st.start, st.start_leg)
        leg = self.leg_len(st.start, st.start_leg)
        pos = leg if p_lo.cls == "t_junction" else leg * stretch
        idx = []
        for x in self.sol.stages[s]:
            p = self.parts[x]
            w = _geom_length(p) * stretch
            q0, q1 = path.at(pos), path.at(pos + w)
            chord = q1 - q0
            c = float(np.hypot(*chord))
            u = chord / c
            a = np.column_stack([u * (c / _geom_length(p)),
                                 _left(u) if st.front == "right" else -_left(u)])
            idx.append(len(self.instances))
            self.instances.append(_instance(p, self.si, s, None, a, q0))
            pos += w
        self.record.stages[s] = _StageRecord(idx, stretch, st.start_leg, path, self.solved[s])


def _straight_key(p: Part, si: int, j: int, xy, v, before: bool, front: str) -> Instance:
    """A straight part spanning vector v from key point xy: before the key (it ends at
    the key, v points back along its stage) or after it."""
    length = float(np.hypot(*v))
    u = (-v if before else v) / length
    a = np.column_stack([u * (length / _geom_length(p)),
                         _left(u) if front == "right" else -_left(u)])
    return _instance(p, si, None, j, a, xy + v if before else xy)


def _instance(p: Part, structure: int, stage, key, a: np.ndarray, origin) -> Instance:
    """An instance at the precision the layout JSON keeps, so JSON, USD and glTF
    carry the same numbers (and the checks test what is written)."""
    def r(v, nd):
        return tuple(0.0 if x == 0 else x for x in (round(float(c), nd) for c in v))
    return Instance(p.id, p.cls, structure, stage, key, r(a[:, 0], AXIS_DIGITS),
                    r(a[:, 1], AXIS_DIGITS), r(origin, COORD_DIGITS))


def _fit(d0, d1, w0, w1) -> np.ndarray:
    """The 2x2 map sending canonical leg directions d0, d1 onto w0, w1."""
    src = np.column_stack([d0, d1]).astype(float)
    dst = np.column_stack([w0, w1]).astype(float)
    return dst @ np.linalg.inv(src)


def _check_t_sides(plan: PlacementPlan, j: int, xy, u_in, u_br, front: Front,
                   branch_front: Front) -> None:
    """The library's T parts have their wing behind the main facade, its own facade to
    the right of the wing's travel when the main facade is to the right of its own."""
    where = f"{plan.name}: the T junction at ({xy[0]:.1f}, {xy[1]:.1f})"
    side = u_in[0] * u_br[1] - u_in[1] * u_br[0]   # > 0: the wing leaves to the left
    if (side > 0) != (front == "right"):
        raise ExportError(f"{where}: its wing leaves on the street side of the main line; "
                          "T parts put the wing behind the main facade, so flip the main "
                          "line's front (or draw the wing on the other side)")
    if branch_front != front:
        raise ExportError(f"{where}: the wing's facade faces the other way from the T "
                          "parts' wing; set the wing line's front to "
                          f'"{other_side(branch_front)}"')


def _check(plan: PlacementPlan, record: _Record, parts: dict[str, Part],
           inst: list[Instance]) -> None:
    """The layout's geometry against its skeleton; any failure is an ExportError."""
    for s, r in record.stages.items():
        st = plan.stages[s]
        k_lo = record.keys[(st.start, r.start_leg)]
        k_hi = record.keys[(st.end, 0)]
        p_lo, p_hi = parts[inst[k_lo].part], parts[inst[k_hi].part]
        where = f"{plan.name}: stage {s}"
        _check_length(where, st, r)
        # facade segments in travel order: start key's leg, fillers, end key's leg
        segs = [_key_leg_segment(inst[k_lo], p_lo, r.start_leg, outgoing=True)]
        for i in r.fill:
            p = parts[inst[i].part]
            segs.append((inst[i].apply([0.0, 0.0]), inst[i].apply([_geom_length(p), 0.0])))
        segs.append(_key_leg_segment(inst[k_hi], p_hi, 0, outgoing=False))
        _check_joined(where, segs, bool(r.fill))
        owners = [k_lo, *r.fill, k_hi]
        for (a, b), i in zip(segs, owners, strict=True):
            p = p_lo if i == k_lo else p_hi if i == k_hi else parts[inst[i].part]
            _check_on_path(where, r.path, (a, b), inst[i].part,
                           "leg of the key part" if i in (k_lo, k_hi) else "part")
            facing = _facade_normal(inst[i], p, i, k_lo, k_hi, r.start_leg)
            _check_facing(where, (a, b), facing, st.front, inst[i].part)


def _check_length(where: str, st: PlanStage, r: _StageRecord) -> None:
    lo, hi = st.length_interval
    if abs(r.path.length - r.solved) > (hi - lo) / 2 + TOL:
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


def _check_on_path(where: str, path: _Path, seg: tuple[np.ndarray, np.ndarray],
                   part: str, what: str) -> None:
    for q in seg:
        off = path.distance(q)
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


def _key_leg_segment(inst: Instance, p: Part, leg: int, *,
                     outgoing: bool) -> tuple[np.ndarray, np.ndarray]:
    """The facade segment of a key part's leg, in travel order."""
    if p.cls in ("end_left", "end_right"):
        return inst.apply([0.0, 0.0]), inst.apply([_geom_length(p), 0.0])
    key = inst.apply([0.0, 0.0])
    end = inst.apply(np.asarray(p.directions[leg]) * p.legs_measured[leg])
    return (key, end) if outgoing else (end, key)


def _facade_normal(inst: Instance, p: Part, i: int, k_lo: int, k_hi: int,
                   start_leg: int) -> np.ndarray:
    """Where the facade of this instance (on this stage) faces, in the layout frame:
    the image of the canonical facade normal, the right of the leg's travel."""
    if p.cls in ("corner", "t_junction") and i in (k_lo, k_hi):
        leg = start_leg if i == k_lo else 0
        d = np.asarray(p.directions[leg], dtype=float)
        travel = d if i == k_lo else -d
        n = np.array([travel[1], -travel[0]])
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
            "parts": [sol.keys[st.start], *sol.stages[s], sol.keys[st.end]],
            "asked": {k: list(v) for k, v in st.asked.items()},
            "met": dict(sol.resources[s]),
            "skeleton_edges": list(st.edges),
        })
    keys = [{"part": sol.keys[j], "kind": k.kind, "xy": list(k.xy),
             "skeleton_key": k.skeleton_key} for j, k in enumerate(plan.keys)]
    total: dict[str, float] = {}
    for res in sol.resources:
        for name, v in res.items():
            total[name] = total.get(name, 0.0) + v
    out = {"name": plan.name, "closed": plan.closed, "cost": sol.cost,
           "keys": keys, "stages": stages, "resources": total}
    if plan.asked:
        out["asked"] = {k: list(v) for k, v in plan.asked.items()}
    return out


def max_stretch(lay: Layout) -> float:
    """The largest |stretch - 1| over the layout's stages."""
    return max((abs(s["stretch"] - 1.0) for st in lay.structures for s in st["stages"]),
               default=0.0)

