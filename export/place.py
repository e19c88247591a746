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

import numpy as np

from citysynth.export.errors import ExportError
from citysynth.export.layout import AXIS_DIGITS, COORD_DIGITS, Instance, Layout
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


def layout(name: str, rank: int, plans: Sequence, solutions: Sequence, db: PartDB) -> Layout:
    """The layout of ``solutions[i]`` (a :class:`solver.structure.StructureSolution`)
    on ``plans[i]`` (a :class:`pipeline.structures.StructurePlan`), checked."""
    parts = {p.id: p for p in db.parts}
    out = Layout(name, rank, {"name": db.name, "hash": db.library_hash,
                              "quantum": db.quantum},
                 plans[0].style if plans else "", plans[0].skeleton.frame.describe()
                 if plans else "", [])
    for si, (plan, sol) in enumerate(zip(plans, solutions, strict=True)):
        instances, record = _place(si, plan, sol, parts)
        _check(plan, record, parts, instances)
        out.instances.extend(instances)
        out.structures.append(_summary(plan, sol, record))
    return out


def _place(si: int, plan, sol, parts: dict[str, Part]):
    st = plan.structure
    paths = [_Path(sp.points) for sp in plan.stages]
    n_keys = len(plan.keys)
    ins = {j: None for j in range(n_keys)}
    outs: dict[int, list[int]] = {j: [] for j in range(n_keys)}
    for s, d in enumerate(st["stages"]):
        ins[d["to"]] = s
        outs[d["from"]].append(s)
    branch = {j: kp["branch"] for j, kp in enumerate(st["keypoints"]) if "branch" in kp}
    xy_of = {kp.id: kp.xy for kp in plan.skeleton.keypoints}
    kxy = {j: np.array(xy_of[plan.keys[j]]) for j in range(n_keys)}

    def start_leg(s: int) -> int:
        j = st["stages"][s]["from"]
        return 2 if branch.get(j) == s else 1

    def leg_part(j: int, leg: int) -> Part:
        """The part that realises key j's leg: the key part, or for a mitre the end
        part on that side of the corner."""
        mitre = plan.mitres.get(sol.keys[j])
        return parts[sol.keys[j]] if mitre is None else parts[mitre[0 if leg == 0 else 1]]

    def leg_len(j: int, leg: int) -> float:
        """How far key j reaches along a leg: its geometry, or a mitre's chosen length."""
        mitre = plan.mitres.get(sol.keys[j])
        return _leg(leg_part(j, leg), leg) if mitre is None else mitre[2 if leg == 0 else 3]

    # one stretch per stage: every part on it stretches, except T parts (rigid: their
    # two main legs are collinear, so no linear map stretches them differently)
    stretch, solved = [], []
    for s, d in enumerate(st["stages"]):
        ends = [(leg_part(d["from"], start_leg(s)), leg_len(d["from"], start_leg(s))),
                (leg_part(d["to"], 0), leg_len(d["to"], 0))]
        rigid = sum(x for p, x in ends if p.cls == "t_junction")
        elastic = sum(x for p, x in ends if p.cls != "t_junction") + \
            sum(_geom_length(parts[x]) for x in sol.stages[s])
        stretch.append((paths[s].length - rigid) / elastic if elastic > 0 else 1.0)
        solved.append(rigid + elastic)

    instances: list[Instance] = []
    record = {"keys": {}, "stages": {}}
    # key parts: each leg is aimed at the point of its stage's polyline that lies its
    # (stretched) length along from the key point, so legs land on the skeleton even
    # where a bend comes before the leg ends
    def reach_in(j: int, length: float) -> np.ndarray:
        """Vector from key j to the point ``length`` back along its incoming stage."""
        path = paths[ins[j]]
        return path.at(path.length - length) - kxy[j]

    def reach_out(s: int, length: float) -> np.ndarray:
        """Vector from stage s's start key to the point ``length`` along it."""
        return paths[s].at(length) - paths[s].p[0]

    for j in range(n_keys):
        s_in = ins[j]
        main_out = [s for s in outs[j] if branch.get(j) != s]
        front = plan.stages[s_in if s_in is not None else main_out[0]].front
        legs = {}
        if s_in is not None:
            p = leg_part(j, 0)
            scale = 1.0 if p.cls == "t_junction" else stretch[s_in]
            legs[0] = (p, reach_in(j, leg_len(j, 0) * scale))
        for s in outs[j]:
            leg = start_leg(s)
            p = leg_part(j, leg)
            scale = 1.0 if p.cls == "t_junction" else stretch[s]
            legs[leg] = (p, reach_out(s, leg_len(j, leg) * scale))
        p = parts[sol.keys[j]] if sol.keys[j] not in plan.mitres else None
        if p is None or p.cls in ("end_left", "end_right"):  # straight: an end, a mitre
            for leg, (q, v) in legs.items():
                record["keys"][(j, leg)] = len(instances)
                instances.append(_straight_key(q, si, j, kxy[j], v, leg == 0, front))
            if p is not None:   # an end part: one instance realises its only leg
                for leg in (0, 1, 2):
                    record["keys"][(j, leg)] = len(instances) - 1
            continue
        if p.cls == "corner":
            a = _fit(np.asarray(p.directions[0]) * p.legs_measured[0],
                     np.asarray(p.directions[1]) * p.legs_measured[1], legs[0][1], legs[1][1])
        else:  # a T: fitted to its in-leg and its branch; its out-leg follows the in-leg
            v_br = legs[2][1]
            _check_t_sides(plan, j, kxy[j], -legs[0][1], v_br, front,
                           plan.stages[branch[j]].front)
            a = _fit(np.asarray(p.directions[0]) * p.legs_measured[0],
                     np.asarray(p.directions[2]) * p.legs_measured[2], legs[0][1], v_br)
        for leg in (0, 1, 2):
            record["keys"][(j, leg)] = len(instances)
        instances.append(_instance(p, si, None, j, a, kxy[j]))
    # stage fillers, from the end of the start key's leg on
    for s, d in enumerate(st["stages"]):
        path, lo = paths[s], d["from"]
        p_lo = leg_part(lo, start_leg(s))
        leg = leg_len(lo, start_leg(s))
        pos = leg if p_lo.cls == "t_junction" else leg * stretch[s]
        idx = []
        front = plan.stages[s].front
        for x in sol.stages[s]:
            p = parts[x]
            w = _geom_length(p) * stretch[s]
            q0, q1 = path.at(pos), path.at(pos + w)
            chord = q1 - q0
            c = float(np.hypot(*chord))
            u = chord / c
            a = np.column_stack([u * (c / _geom_length(p)),
                                 _left(u) if front == "right" else -_left(u)])
            idx.append(len(instances))
            instances.append(_instance(p, si, s, None, a, q0))
            pos += w
        record["stages"][s] = {"fill": idx, "stretch": stretch[s], "start_leg": start_leg(s),
                               "path": path, "solved": solved[s]}
    return instances, record


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


def _check_t_sides(plan, j, xy, u_in, u_br, front, branch_front) -> None:
    """The library's T parts have their wing behind the main facade, its own facade to
    the right of the wing's travel when the main facade is to the right of its own."""
    where = f"{plan.skeleton.name}: the T junction at ({xy[0]:.1f}, {xy[1]:.1f})"
    side = u_in[0] * u_br[1] - u_in[1] * u_br[0]   # > 0: the wing leaves to the left
    if (side > 0) != (front == "right"):
        raise ExportError(f"{where}: its wing leaves on the street side of the main line; "
                          "T parts put the wing behind the main facade, so flip the main "
                          "line's front (or draw the wing on the other side)")
    if branch_front != front:
        raise ExportError(f"{where}: the wing's facade faces the other way from the T "
                          "parts' wing; set the wing line's front to "
                          f'"{_other(branch_front)}"')


def _other(side: str) -> str:
    return "left" if side == "right" else "right"


def _check(plan, record, parts, inst: list[Instance]) -> None:
    """The layout's geometry against its skeleton; any failure is an ExportError."""
    name = plan.skeleton.name
    for s, r in record["stages"].items():
        path: _Path = r["path"]
        front = plan.stages[s].front
        d = plan.structure["stages"][s]
        k_lo = record["keys"][(d["from"], r["start_leg"])]
        k_hi = record["keys"][(d["to"], 0)]
        p_lo, p_hi = parts[inst[k_lo].part], parts[inst[k_hi].part]
        where = f"{name}: stage {s}"
        lo, hi = d["constraints"]["length"]
        if abs(path.length - r["solved"]) > (hi - lo) / 2 + TOL:
            raise ExportError(f"{where}: its parts measure {r['solved']:.3f} m for "
                              f"{path.length:.3f} m of skeleton, more than the "
                              f"{(hi - lo) / 2:g} m a stretch may absorb")
        # facade segments in travel order: start key's leg, fillers, end key's leg
        segs = [_key_leg_segment(inst[k_lo], p_lo, r["start_leg"], outgoing=True)]
        for i in r["fill"]:
            p = parts[inst[i].part]
            segs.append((inst[i].apply([0.0, 0.0]), inst[i].apply([_geom_length(p), 0.0])))
        segs.append(_key_leg_segment(inst[k_hi], p_hi, 0, outgoing=False))
        for (_a, b), (c, _d) in zip(segs[:-1], segs[1:], strict=True):
            gap = float(np.hypot(*(c - b)))
            if gap > TOL:
                at = (b + c) / 2
                hint = "" if r["fill"] else (" (no middle part lies between its key "
                                             "parts to absorb the difference)")
                raise ExportError(f"{where}: parts do not meet at ({at[0]:.2f}, "
                                  f"{at[1]:.2f}), {1e3 * gap:.1f} mm apart{hint}")
        for (a, b), i in zip(segs, [k_lo, *r["fill"], k_hi], strict=True):
            for q in (a, b):
                off = path.distance(q)
                if off > TOL:
                    what = "leg of the key part" if i in (k_lo, k_hi) else "part"
                    raise ExportError(f"{where}: a {what} {inst[i].part} ends "
                                      f"{1e3 * off:.1f} mm off the skeleton at "
                                      f"({q[0]:.2f}, {q[1]:.2f})")
            mid = (a + b) / 2
            tangent = (b - a) / max(float(np.hypot(*(b - a))), 1e-12)
            into_mass = _left(tangent) * (1.0 if front == "right" else -1.0)
            facing = _facade_normal(inst[i], p_lo if i == k_lo else p_hi if i == k_hi
                                    else parts[inst[i].part], i, k_lo, k_hi, r["start_leg"])
            if float(facing @ -into_mass) <= 0:
                raise ExportError(f"{where}: part {inst[i].part} at ({mid[0]:.2f}, "
                                  f"{mid[1]:.2f}) does not face the street side "
                                  f"({front} of travel)")


def _key_leg_segment(inst: Instance, p: Part, leg: int, *, outgoing: bool):
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


def _summary(plan, sol, record) -> dict:
    st = plan.structure
    stages = []
    for s, d in enumerate(st["stages"]):
        r = record["stages"][s]
        stages.append({
            "from": d["from"], "to": d["to"], "front": plan.stages[s].front,
            "length": r["path"].length, "stretch": r["stretch"],
            "parts": [sol.keys[d["from"]], *sol.stages[s], sol.keys[d["to"]]],
            "asked": {k: list(v) for k, v in d["constraints"].items()},
            "met": dict(sol.resources[s]),
            "skeleton_edges": list(plan.stages[s].edges),
        })
    kp_of = {kp.id: kp for kp in plan.skeleton.keypoints}
    keys = []
    for j, v in enumerate(plan.keys):
        kp = kp_of[v]
        keys.append({"part": sol.keys[j], "kind": kp.kind, "xy": list(kp.xy),
                     "skeleton_key": kp.id})
    total: dict[str, float] = {}
    for res in sol.resources:
        for k, v in res.items():
            total[k] = total.get(k, 0.0) + v
    out = {"name": plan.skeleton.name, "closed": plan.skeleton.closed, "cost": sol.cost,
           "keys": keys, "stages": stages, "resources": total}
    if st.get("constraints"):
        out["asked"] = {k: list(v) for k, v in st["constraints"].items()}
    return out


def max_stretch(lay: Layout) -> float:
    """The largest |stretch - 1| over the layout's stages."""
    return max((abs(s["stretch"] - 1.0) for st in lay.structures for s in st["stages"]),
               default=0.0)

