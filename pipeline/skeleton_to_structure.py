"""A skeleton and a part database become a structure for the solver.

Key points take the library's key parts of the chosen style: corners matching their
angle and convexity (:func:`skeletons.match_corner_angles`), T parts at T junctions
(their branch leg on the skeleton's branch edge), end parts at ends. Bends (nearly
straight vertices) are not key points: their edges merge into one stage. Each stage
must be filled to its skeleton length within half a quantum (the export's uniform
stretch absorbs the rest) and meets the edge's own constraints on part attributes.
Fillers are the style's middle parts; transition costs are the database's.

Stages are oriented so facades face the right of travel wherever the skeleton allows
(the canonical frame's facade faces -Y, to the right of +X): a cycle is walked in that
direction, and a tree is rooted at the end that puts most stages so. A stage whose
front is still on its left is mirrored by the export. :class:`StructurePlan` keeps
what the export needs to put the solution back on the ground: each structure key point's
skeleton key point and each stage's polyline and front.

Key parts contribute their legs' lengths to the stages they touch, and their attributes
(windows, doors) split between their legs in whole numbers (:func:`_shares`), so they
count toward each side's intervals and, in full, toward the structure-wide ones.
"""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict, defaultdict
from dataclasses import dataclass, field
from typing import cast

import numpy as np
import shapely
import shapely.affinity

from citysynth.export.joints import ACUTE_DEG, NOSE
from citysynth.export.place import TOL
from citysynth.export.plan import (
    FILLED,
    JOINT,
    Front,
    PlacementPlan,
    PlanKey,
    PlanStage,
    Point,
    is_joint,
    other_side,
)
from citysynth.export.t_poses import (
    SEP,
    main_depth,
    part_leg,
    pose_from_ground,
    t_element,
    t_pose,
)
from citysynth.parts_db import Part, PartDB
from citysynth.parts_db.manifest import PartClass
from citysynth.parts_db.sections import disagreement
from citysynth.pipeline.corner_room import CornerRoom, mass_depth
from citysynth.skeletons import KeyPoint, Skeleton
from citysynth.skeletons.errors import SkeletonError
from citysynth.skeletons.from_geometry import STRAIGHT_TOL, opposite_fronts
from citysynth.solver.structures import Stage, Structure

MAX_KEYS = 2_000    # key points of one structure: more is refused with an estimate
KEY_MB = 0.55       # MB of solving a key point takes (500: 525 MB, 2,000: 1.1 GB)
JOINT_COST = 10.0  # a mitre joint's cost (m² of section mismatch, the scale of the costs)
JOINT_LEGS = 8     # a joint's legs are 1..JOINT_LEGS quanta on either side
CORNER_FIT = 0.05     # m: how far a rigid corner part's leg end may miss its facade line
STRAIGHT_DEG = 2.0   # a facade bending less than this still takes a rigid corner part
JOINT_LEG_COST = 1.0   # per metre of leg beyond one quantum: modules keep their widths


@dataclass(frozen=True)
class _Chain:
    a: int                         # key points at its two ends, as found
    b: int
    length: float
    constraints: dict
    edges: tuple[int, ...]
    vertices: tuple[int, ...]      # a ... b through bends


def _chains(sk: Skeleton) -> tuple[list[int], list[_Chain]]:
    """Merge edges through bends: the key point ids and the chains between them."""
    kind = {k.id: k.kind for k in sk.keypoints}
    adj = defaultdict(list)
    for i, e in enumerate(sk.edges):
        adj[e.a].append((i, e.b))
        adj[e.b].append((i, e.a))
    keys = [k.id for k in sk.keypoints if k.kind != "bend"]
    if not keys:
        raise SkeletonError(f"{sk.name}: no corner, end or T junction to anchor parts at")
    used: set[int] = set()
    chains = []
    for start in keys:
        for i, nxt in adj[start]:
            if i in used:
                continue
            edges, verts, v = [i], [start, nxt], nxt
            length, cons = sk.edges[i].length, dict(sk.edges[i].constraints)
            used.add(i)
            while kind[v] == "bend":
                j, w = next((j, w) for j, w in adj[v] if j != edges[-1])
                used.add(j)
                edges.append(j)
                verts.append(w)
                length += sk.edges[j].length
                cons.update(sk.edges[j].constraints)
                v = w
            chains.append(_Chain(start, v, length, cons, tuple(edges), tuple(verts)))
    return keys, chains


def _front_along(sk: Skeleton, chain: _Chain, forward: bool) -> Front:
    """The side the chain's facades face when it is walked a -> b (forward) or back."""
    e = sk.edges[chain.edges[0]]
    side: Front = "right" if e.front == "right" else "left"
    if e.a != chain.vertices[0]:
        side = other_side(side)
    return side if forward else other_side(side)


def _orient(sk: Skeleton, keys: list[int], chains: list[_Chain]) -> tuple[int, dict]:
    """Root key index and each chain's direction as (from, to) key indices.

    The chains form main lines: a line runs on through every corner and through the
    main line of every T junction, and stops where it meets a T by its branch. A key
    part's in-leg and out-leg lie on one line, so each line is walked one way: the way
    that leaves most T junctions by their branch (stages branch off as T parts are
    made), then faces most facades to the right of travel (the canonical facade faces
    right), then starts at its first key point. A line may still end at a T by its
    branch (the bar of an H is the branch of both its T junctions). The root is the
    first key point no stage enters (a tree) or the first key point of the cycle that
    only the cycle enters (a cycle)."""
    index = {v: j for j, v in enumerate(keys)}
    ends = [(index[c.a], index[c.b]) for c in chains]
    branch_of = {index[k.id]: next(s for s, c in enumerate(chains) if k.branch in c.edges)
                 for k in sk.keypoints if k.kind == "t_junction"}
    inc: dict[int, list[int]] = defaultdict(list)
    for s, (a, b) in enumerate(ends):
        inc[a].append(s)
        inc[b].append(s)
    if len(chains) > len(keys):
        raise SkeletonError(f"{sk.name}: more than one cycle; split it into a cycle and "
                            "trees, or into several buildings")
    def score(walk: list[tuple[int, int, int]]) -> tuple[int, int, int]:
        leave = sum(branch_of.get(a) == s for s, a, _b in walk)
        right = sum(_front_along(sk, chains[s], index[chains[s].a] == a) == "right"
                    for s, a, _b in walk)
        return leave, right, -walk[0][1]

    oriented: dict[int, tuple[int, int]] = {}
    bars = []        # lines that are the branch at both ends (an H's bar)
    for line in _main_lines(ends, inc, branch_of):
        back = [(s, b, a) for s, a, b in reversed(line)]
        for s, a, b in max((line, back), key=score):   # the first of equals: as found
            oriented[s] = (a, b)
        if branch_of.get(line[0][1]) == line[0][0] and branch_of.get(line[-1][2]) == \
                line[-1][0]:
            bars.append(line)
    root = _root(keys, chains, ends, inc, oriented)
    for line in bars:   # a cycle of bars and ranges may need a bar turned to be cut
        if root is not None:
            break
        for s, _a, _b in line:
            oriented[s] = oriented[s][::-1]
        root = _root(keys, chains, ends, inc, oriented)
    if root is None:
        kp_of = {k.id: k for k in sk.keypoints}
        xy = kp_of[keys[0]].xy
        raise SkeletonError(f"{sk.name}: its cycle (near {sk.frame.at(xy)}) has "
                            "no key point where it could be cut: every one is also entered "
                            "by a T junction's branch; draw one wing the other way")
    return root, oriented


def _main_lines(ends: list[tuple[int, int]], inc: dict[int, list[int]],
                branch_of: dict[int, int]) -> list[list[tuple[int, int, int]]]:
    """The chains as main lines, each as (chain, from, to) in walking order: chains that
    meet where neither is a T's branch run on as one line (a path, or once round a
    cycle)."""
    def other(s: int, v: int) -> int:
        a, b = ends[s]
        return b if a == v else a

    def nxt(v: int, s: int) -> int | None:
        if branch_of.get(v) == s:
            return None
        return next((t for t in inc[v] if t != s and t != branch_of.get(v)), None)
    seen: set[int] = set()
    lines = []
    for s0 in range(len(ends)):
        if s0 in seen:
            continue
        v, s = ends[s0][0], s0      # back to an end of the line (or once round it)
        while (t := nxt(v, s)) is not None and t != s0:
            v, s = other(t, v), t
        line: list[tuple[int, int, int]] = []
        cur: int | None = s
        while cur is not None and cur not in seen:
            w = other(cur, v)
            line.append((cur, v, w))
            seen.add(cur)
            cur, v = nxt(w, cur), w
        lines.append(line)
    return lines


def _root(keys: list[int], chains: list[_Chain], ends: list[tuple[int, int]],
          inc: dict[int, list[int]], oriented: dict[int, tuple[int, int]]) -> int | None:
    """The structure's root: the first key point no stage enters (a tree), or the first
    key point of the cycle that exactly one stage enters, on the cycle (a cycle: there
    it is cut; None if there is none)."""
    enters: defaultdict[int, int] = defaultdict(int)
    for _a, b in oriented.values():
        enters[b] += 1
    if len(chains) < len(keys):
        return next(j for j in range(len(keys)) if not enters[j])
    on_cycle = {v for s in range(len(chains)) if _on_cycle(s, inc, ends)
                for v in ends[s]}
    for j in range(len(keys)):
        if j in on_cycle and enters[j] == 1 and any(
                oriented[s][1] == j and _on_cycle(s, inc, ends) for s in inc[j]):
            return j
    return None


@dataclass(frozen=True)
class StructurePlan:
    """A skeleton made into a structure: the solver's input and export's way back."""

    structure: Structure           # what the solver solves
    placement: PlacementPlan       # what export places the solution on
    # a stage two T parts could span alone but not exactly -> the lengths they do span
    alone: dict[int, tuple[float, ...]] = field(default_factory=dict)


@dataclass(frozen=True)
class _KeyParts:
    """What may stand at each structure key point, and the parts and mitres behind it."""

    options: tuple[tuple[str, ...], ...]      # key element ids per key point
    branch: dict[int, int]                    # T key point -> its branch stage
    parts: dict[str, Part]                    # key parts used, by id
    joint: bool                               # some key point may be a mitre joint
    # a ring's seam joints: id -> (its joint, the module it hands on ("": any), extra cost)
    seam: dict[str, tuple[str, str, float]] = field(default_factory=dict)


MIN_CORNER_DEG = 5.0   # a sharper corner is a line drawn back on itself, not a building


def _check_hairpins(sk: Skeleton) -> None:
    """Refuse a corner sharper than :data:`MIN_CORNER_DEG`, convex or concave: its two
    sides run almost on top of each other (a line drawn back on itself), and the cuts
    at such a corner come out millimetres apart (at 1-4.5° placement failed with "parts
    do not meet"; from 5° up every side length that fits parts builds)."""
    for k in sk.keypoints:
        if k.kind == "corner" and k.angle is not None and round(k.angle, 3) < MIN_CORNER_DEG:
            raise SkeletonError(
                f"{sk.name}: the corner of {k.angle:.1f}° at {sk.frame.at(k.xy)} is sharper "
                f"than the {MIN_CORNER_DEG:g}° citysynth builds: its two sides run almost "
                "on top of each other; open the corner up, or draw its sides as separate "
                "lines")


def _check_noses(sk: Skeleton, chains: list[_Chain]) -> None:
    """Refuse a convex corner so sharp that its nose (the end wall squaring off an acute
    corner, :data:`~citysynth.export.joints.NOSE` wide, set back NOSE / (2 sin(angle/2))
    along each facade) lies past the end of a side it joins: the facades there would
    end before they start (a hairpin of a skeleton line)."""
    for k in sk.keypoints:
        if k.kind != "corner" or not k.convex or k.angle is None or k.angle >= ACUTE_DEG:
            continue
        if round(k.angle, 1) == 0:   # its nose would be "2030998.7 m back"
            raise SkeletonError(
                f"{sk.name}: at {sk.frame.at(k.xy)} a side turns straight back on itself "
                "(a spike: out and back along one line, a corner of 0.0°); remove the "
                "spike's point")
        back = NOSE / (2 * math.sin(math.radians(k.angle) / 2))
        sides = [c.length for c in chains if k.id in (c.a, c.b)]
        if sides and back >= min(sides):
            raise SkeletonError(
                f"{sk.name}: the convex corner of {k.angle:.1f}° at {sk.frame.at(k.xy)} is "
                f"too sharp for its sides: its tip is squared off by a {NOSE:g} m end wall "
                f"{back:.1f} m back along each facade, past the end of its "
                f"{min(sides):.1f} m side; open the corner up or lengthen its sides")


def skeleton_structure(sk: Skeleton, db: PartDB, style: str, *, k: int = 1,
                       angle_tol: float = 7.5, joint_cost: float = JOINT_COST,
                       stretch: float = 0.0, slack: float = 0.0,
                       per_side: dict | None = None,
                       per_structure: dict | None = None,
                       parts: frozenset[str] | None = None) -> StructurePlan:
    """The structure for ``sk`` built from ``db``'s parts of ``style``, with the way
    back to the skeleton.

    A corner takes the library's corner parts of its convexity within ``angle_tol``
    degrees of its angle, or, at ``joint_cost``, a mitre joint (:data:`JOINT`): the
    modules on either side run to the corner and are cut on its bisector, which fits
    any angle and needs no length of its own. Each stage must meet its skeleton length
    within the largest of half a quantum, ``stretch`` (a fraction of it) and ``slack``
    (metres). ``per_side`` intervals apply to every stage (an edge's own constraints
    win), ``per_structure`` ones to the whole structure. ``parts`` limits the parts to
    those ids (a footprint's facade family; None: every part of the style)."""
    if parts is not None:
        db = cast(PartDB, _only(db, parts))
    keys, chains = _chains(sk)
    if len(keys) > MAX_KEYS:
        raise SkeletonError(
            f"{sk.name}: {len(keys):,} corners, ends and T junctions; one building or "
            f"block this large would take about {len(keys) * KEY_MB / 1024:,.1f} GB and "
            f"minutes to solve (measured: 2,000 took 17 s and 1.1 GB); split it into "
            f"buildings of at most {MAX_KEYS:,}, or simplify its outline")
    _check_noses(sk, chains)     # a convex tip: told with its nose and side first
    _check_hairpins(sk)
    root, oriented = _orient(sk, keys, chains)
    # renumber so the root is key point 0
    order = [root] + [j for j in range(len(keys)) if j != root]
    renum = {j: i for i, j in enumerate(order)}
    keys = [keys[j] for j in order]
    oriented = {s: (renum[a], renum[b]) for s, (a, b) in oriented.items()}
    fillers = db.select("middle", style)
    if not fillers:
        raise SkeletonError(f"the library has no middle parts of style {style!r}")
    attrs = sorted({a for p in fillers for a in p.attributes})
    for name in {**(per_side or {}), **(per_structure or {})}:
        if name not in attrs:
            raise SkeletonError(f"{sk.name}: constraint on {name!r}, which no {style} "
                                f"middle part has (they have {', '.join(attrs)})")
    stages, placed = _stages(sk, max(db.quantum / 2, slack), keys, chains, oriented,
                             stretch, per_side or {}, attrs, style)
    kp = _key_parts(sk, db, style, keys, chains, oriented, angle_tol, placed)
    resources = ("length", *attrs)
    common = dict(quantum={"length": db.quantum}, **_transitions(db, fillers, kp),
                  keypoints=kp.options, branch=kp.branch, k=k, source=sk.name,
                  global_constraints={n: (float(lo), float(hi))
                                      for n, (lo, hi) in (per_structure or {}).items()})
    structure = Structure.build(
        resources=resources, stages=stages,
        **_elements(fillers, kp, resources, joint_cost, db.quantum), **common)
    rigid = _rigid_gaps(structure, kp, [c.length for c in chains])
    if rigid:   # rare: a short side between rigid key parts; asked for a middle part
        most = float(max(st.constraints["length"][1] for st in stages)
                     // min(p.length for p in fillers) + 1)
        resources = (*resources, FILLED)
        stages = [Stage({**st.constraints, FILLED: (1.0, most)}, st.elements, st.start,
                        st.end) if s in rigid else st for s, st in enumerate(stages)]
        structure = Structure.build(
            resources=resources, stages=stages,
            **_elements(fillers, kp, resources, joint_cost, db.quantum), **common)
    kp_of = {v.id: v for v in sk.keypoints}
    placement = PlacementPlan(
        name=sk.name, closed=sk.closed, style=style, frame=sk.frame.describe(),
        keys=tuple(PlanKey(kp_of[v].xy, kp_of[v].kind, v) for v in keys),  # type: ignore[arg-type]
        stages=tuple(PlanStage(st.start, st.end, structure.start_leg(s), *placed[s],
                               asked={r: iv for r, iv in st.constraints.items()
                                      if r != FILLED},
                               end_leg=structure.end_leg(s))
                     for s, st in enumerate(structure.stages)),
        branch=dict(kp.branch), asked=dict(structure.global_constraints),
        joints=_joints(db.quantum, kp.seam) if kp.joint else {})
    return StructurePlan(structure, placement, rigid)


class _only:
    """A part database seen through a set of part ids: ``select`` keeps only those."""

    def __init__(self, db: PartDB, ids: frozenset[str]) -> None:
        self._db, self._ids = db, ids

    def __getattr__(self, name: str):
        return getattr(self._db, name)

    def select(self, cls: PartClass | None = None, style: str | None = None) -> list[Part]:
        return [p for p in self._db.select(cls, style) if p.id in self._ids]


def _key_parts(sk: Skeleton, db: PartDB, style: str, keys: list[int], chains: list[_Chain],
               oriented: dict[int, tuple[int, int]], angle_tol: float,
               placed: list[tuple[tuple[Point, ...], Front, tuple[int, ...]]]) -> _KeyParts:
    """The key elements each key point admits: corner parts by angle and convexity, and
    a mitre joint; T parts in the pose the junction asks for (:mod:`citysynth.export.t_poses`)
    with their branch stage; end parts by the way the stage runs."""
    kp_of = {kp.id: kp for kp in sk.keypoints}
    corners = db.select("corner", style)
    room = CornerRoom(sk, max((mass_depth(p) for p in db.select("middle", style)),
                              default=0.0)) if corners else None
    options: list[tuple[str, ...]] = []
    branch: dict[int, int] = {}
    parts: dict[str, Part] = {}
    poses: dict[str, Part] = {}     # T key element -> its part
    seam: dict[str, tuple[str, str, float]] = {}
    for j, v in enumerate(keys):
        kp = kp_of[v]
        extra: list[str] = []
        if kp.kind == "corner":
            run = _straight_run(v, chains, kp_of)
            opts = [p for p in corners if p.convex == kp.convex and p.angle is not None
                    and kp.angle is not None and abs(p.angle - kp.angle) <= angle_tol
                    and _fits(p, kp.angle, run)]
            if opts and room is not None:   # rigid: only where the block has room for it
                own = [i for c in chains if v in (c.a, c.b) for i in c.edges]
                opts = [p for p in opts if room.fits(p, v, own)]
            if _is_seam(kp, v, chains):   # a ring that only bends: joined as it runs on
                seam = _seam_joints(db, db.select("middle", style))
                extra = list(seam)
            else:
                extra = list(_joint_variants(db.quantum))
        elif kp.kind == "t_junction":
            branch[j] = next(s for s, c in enumerate(chains) if kp.branch in c.edges)
            swap, street = _t_pose(sk, j, v, branch[j], oriented, placed)
            ts = db.select("t_junction", style)
            if street:   # the wing must still reach past the key point
                ts = [p for p in ts if p.legs[2] > main_depth(p.sec_in, db.quantum) + 1e-9]
            extra = [t_element(p.id, swap, street) for p in ts]
            poses.update((t_element(p.id, swap, street), p) for p in ts)
            opts = []
        else:
            starts = any(a == j for a, _b in oriented.values())
            opts = db.select("end_left" if starts else "end_right", style)
        if not opts and not extra:
            raise SkeletonError(f"{sk.name}: the library has no {kp.kind} part of style "
                                f"{style!r} for the key point at {sk.frame.at(kp.xy)}")
        options.append(tuple([p.id for p in opts] + extra))
        parts.update((p.id, p) for p in opts)
    return _KeyParts(tuple(options), branch, {**parts, **poses},
                     any(is_joint(x) for o in options for x in o), seam)


def _joints(q: float, seam: dict[str, tuple[str, str, float]]
            ) -> dict[str, tuple[float, float]]:
    """Every mitre joint's legs by id, a ring's seam joints (:func:`_seam_joints`)
    included under their own ids."""
    plain = _joint_variants(q)
    return {**plain, **{sid: plain[jid] for sid, (jid, _p, _c) in seam.items()}}


def _is_seam(kp: KeyPoint, v: int, chains: list[_Chain]) -> bool:
    """Whether key point v is a ring's seam: its one key point (the ring runs from it
    back to it), turning as little as a bend (a real corner there stays a corner)."""
    return (abs(kp.turn or 0.0) < STRAIGHT_TOL
            and any(c.a == c.b == v for c in chains))


def _seam_joints(db: PartDB, fillers: list[Part]) -> dict[str, tuple[str, str, float]]:
    """The mitre joints at the seam of a ring that only bends (its one key point, where
    the ring is cut: :func:`citysynth.skeletons.from_geometry.seamed`), each carrying
    the section of a family of modules: the module before it pays the database's
    transition into that family, and only a module of it follows. A plain joint joins
    any two modules at no cost, as at a corner; at a seam the facade runs on nearly
    straight, and a round block closed a row of tall modules onto a row of low ones
    there with no transition part (a step in the roof, a cut face standing above it).
    Both legs of a seam count toward the ring's one stage, so one joint per total leg
    length is all the solver needs (each option at a key point is a stage graph). A
    plain joint stays, at the cost of the worst transition between the modules, for a
    library whose modules cannot close a ring on their own transitions."""
    totals: dict[float, str] = {}
    for jid, (a, b) in _joint_variants(db.quantum).items():
        totals.setdefault(round(a + b, 9), jid)
    families: list[Part] = []
    for p in fillers:
        if not any(_start_alike(p, f) for f in families):
            families.append(p)
    ids = [db.index()[p.id] for p in fillers]
    costs = db.cost[np.ix_(ids, ids)]
    worst = float(costs[np.isfinite(costs)].max(initial=0.0))
    out = {f"{jid}{SEP}{p.id}": (jid, p.id, 0.0) for jid in totals.values() for p in families}
    out.update({f"{jid}{SEP}any": (jid, "", worst) for jid in totals.values()})
    return out


SEAM_SAME = 0.5   # m² of section disagreement under which modules start alike at a seam


def _start_alike(a: Part, b: Part) -> bool:
    """Whether two modules start with the same section (within :data:`SEAM_SAME`)."""
    return disagreement(a.sec_in, b.sec_in) <= SEAM_SAME


def _t_pose(sk: Skeleton, j: int, v: int, b: int, oriented: dict[int, tuple[int, int]],
            placed: list[tuple[tuple[Point, ...], Front, tuple[int, ...]]]
            ) -> tuple[bool, bool]:
    """(swap, street) of the T parts at structure key point j, whose branch stage is b:
    from the main line's travel and front through it and the wing's direction and
    front (seen leaving the junction)."""
    s_in = next(s for s, (_a, e) in oriented.items() if e == j and s != b)
    s_out = next(s for s, (a, _e) in oriented.items() if a == j and s != b)
    pts_in, front_in, _ = placed[s_in]
    if placed[s_out][1] != front_in:
        e = sk.edges[placed[s_out][2][0]]
        raise SkeletonError(opposite_fronts(
            f"{sk.name}: the T junction at {sk.frame.at(pts_in[-1])}", e,
            v, what="the main line's two halves meeting there"))
    pts_b, front_b, _ = placed[b]
    leaves = oriented[b][0] == j
    u = np.subtract(pts_in[-1], pts_in[-2])
    w = np.subtract(pts_b[1], pts_b[0]) if leaves else np.subtract(pts_b[-2], pts_b[-1])
    wing_right = (front_b == "right") == leaves
    return pose_from_ground(u / np.hypot(*u), front_in == "right", w / np.hypot(*w),
                            wing_right)


def _fits(p: Part, angle: float, run: float) -> bool:
    """Whether rigid corner part ``p`` (made for ``p.angle``) fits a corner of ``angle``
    whose sides run straight for ``run`` metres: both legs on the straight runs, and
    each leg's end within :data:`CORNER_FIT` of the facade line it should meet (a leg
    10 m long off by 3 degrees misses by 0.5 m: a wedge gap or a doubled roof)."""
    assert p.angle is not None
    off = math.sin(math.radians(abs(p.angle - angle)))
    return max(p.legs) <= run and max(p.legs) * off <= CORNER_FIT


def _straight_run(v: int, chains: list[_Chain], kp_of: dict) -> float:
    """How far the facade runs straight (within :data:`STRAIGHT_DEG`) from key point
    ``v`` on every side: a library corner part is rigid, so it fits only where both its
    legs lie on straight runs (a leg across a bend would leave a wedge gap behind the
    bend and an overlap in front; a mitre joint, whose modules fold, fits anywhere)."""
    best = math.inf
    for c in chains:
        for verts in ((c.vertices,) if c.a == v else ()) + ((c.vertices[::-1],) if c.b == v
                                                              else ()):
            pts = [np.asarray(kp_of[u].xy, dtype=float) for u in verts]
            run = 0.0
            for i in range(1, len(pts)):
                run += float(np.hypot(*(pts[i] - pts[i - 1])))
                if i + 1 < len(pts) and _turn_deg(pts[i - 1], pts[i], pts[i + 1]) > STRAIGHT_DEG:
                    break
            best = min(best, run)
    return best


def _turn_deg(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    u, w = b - a, c - b
    return abs(math.degrees(math.atan2(u[0] * w[1] - u[1] * w[0], float(u @ w))))


def _joint_variants(q: float) -> dict[str, tuple[float, float]]:
    """Mitre joints by id: legs of 1..JOINT_LEGS quanta, the same on both sides or one
    side at one quantum (22 variants; every pair would be 64 and solve far more
    slowly). The legs give short sides the slack a few module widths lack (the sample
    library's modules come in bays of about 3 m, so up to 1.6 m a side closes every
    gap between their sums): the modules beside the joint are extended over them (a
    wider corner pier), at a small cost per metre. Symmetric legs alone (8 variants)
    solve a block about four times faster, but a ring's sides then share their legs
    pairwise and some rings no longer close (the Fig. 1(c) ring in the modern style)."""
    pairs = sorted({(a, a) for a in range(1, JOINT_LEGS + 1)}
                   | {(1, a) for a in range(2, JOINT_LEGS + 1)}
                   | {(a, 1) for a in range(2, JOINT_LEGS + 1)})
    return {f"{JOINT}+{a * q:.1f}+{b * q:.1f}": (round(a * q, 9), round(b * q, 9))
            for a, b in pairs}


def _stages(sk: Skeleton, floor: float, keys: list[int], chains: list[_Chain],
            oriented: dict[int, tuple[int, int]], stretch: float,
            per_side: dict, attrs: list[str], style: str
            ) -> tuple[list[Stage], list[tuple[tuple[Point, ...], Front, tuple[int, ...]]]]:
    """Each chain as a stage (its intervals: the length within ``floor`` metres or the
    stretch, whichever is larger, and the attribute intervals), with its polyline,
    front and edges in travel order."""
    kp_of = {kp.id: kp for kp in sk.keypoints}
    stages, placed = [], []
    for s, chain in enumerate(chains):
        lo, hi = oriented[s]
        forward = chain.a == keys[lo]
        verts = chain.vertices if forward else chain.vertices[::-1]
        placed.append((tuple(kp_of[v].xy for v in verts), _front_along(sk, chain, forward),
                       chain.edges if forward else chain.edges[::-1]))
        tol = max(floor, stretch * chain.length)
        c = {"length": (round(chain.length - tol, 6), round(chain.length + tol, 6))}
        for name, iv in {**per_side, **chain.constraints}.items():
            if name not in attrs:
                raise SkeletonError(f"{sk.name}: edge constraint on {name!r}, which no "
                                    f"{style} middle part has (they have {', '.join(attrs)})")
            c[name] = (float(iv[0]), float(iv[1]))
        stages.append(Stage(c, None, lo, hi))
    return stages, placed


def _legs(p: Part, element: str, quantum: float | None) -> tuple[float, ...]:
    """A key element's legs (in, out, branch): a T part's as its pose puts them; on the
    quantum grid (the solver's), or as its geometry measures them (``quantum`` None:
    what placing it spans)."""
    if p.cls in ("end_left", "end_right"):
        x = p.length if quantum is not None else p.legs_measured[0] * p.scale
        return (x, x)
    src = p.legs if quantum is not None else p.legs_measured
    legs = [src[part_leg(element, i)] for i in range(len(p.legs))]
    if p.cls == "t_junction" and t_pose(element).street:
        legs[2] = round(legs[2] - main_depth(p.sec_in, quantum), 9)
    return tuple(legs)


def _rigid_gaps(st: Structure, kp: _KeyParts, lengths: list[float]
                ) -> dict[int, tuple[float, ...]]:
    """The stages the solver could fill with two T parts alone (their legs on the grid
    within the stage's length interval) though the parts' geometry misses the
    skeleton's ``lengths`` by more than the export's tolerance: a T part is rigid (the
    export stretches corners and ends with a stage's modules, never a T), so only a
    middle part's stretch takes up the difference (an H's bar of 10.5 m between two T
    parts whose wings measure 5.2 m each failed to place, 100 mm apart). Such a stage
    must hold a middle part (:data:`FILLED`). A pair that meets exactly beside one that
    does not loses its empty stage too (a skeleton side within a millimetre of two legs'
    sum is chance, not design). Each with the lengths its T parts span exactly (what
    a refusal names as buildable)."""
    out: dict[int, tuple[float, ...]] = {}
    for s, stage in enumerate(st.stages):
        lo, hi = stage.constraints["length"]
        first, a_leg, b_leg = st.first_table(s), st.start_leg(s), st.end_leg(s)
        rigid = [[x for x in st.keypoints[v] if x in kp.parts
                  and kp.parts[x].cls == "t_junction"] for v in (stage.start, stage.end)]
        spans, missed = set(), False
        for a, b in itertools.product(*rigid):
            if (a, b) not in first:
                continue
            grid = st.legs[a][a_leg]["length"] + st.legs[b][b_leg]["length"]
            measured = (_legs(kp.parts[a], a, None)[a_leg]
                        + _legs(kp.parts[b], b, None)[b_leg])
            spans.add(round(measured, 3))
            missed |= lo - 1e-9 <= grid <= hi + 1e-9 and abs(measured - lengths[s]) > TOL
        if missed:
            out[s] = tuple(sorted(spans))
    return out


def _shares(attributes: dict[str, float], n: int) -> list[dict[str, float]]:
    """A key part's doors, windows ... split between the ``n`` sides it joins (its legs:
    a corner's two, a T's three; an end has one side), so they count toward each side's
    intervals and, in full, toward the whole block's: whole numbers stay whole (95
    windows over a T's three legs: 32, 32, 31)."""
    out: list[dict[str, float]] = [{} for _ in range(n)]
    for a, v in attributes.items():
        if v.is_integer():
            base, extra = divmod(int(v), n)
            for i in range(n):
                out[i][a] = float(base + (i < extra))
        else:
            for i in range(n):
                out[i][a] = v / n
    return out


def _elements(fillers: list[Part], kp: _KeyParts, resources: tuple[str, ...],
              joint_cost: float, quantum: float) -> dict:
    """Fillers with their length and attributes; key parts with their legs; mitre
    joints at their cost, with their legs (the modules next to a joint are extended
    over them to reach the corner)."""
    zero = dict.fromkeys(resources, 0.0)
    elements: dict[str, dict[str, float]] = {}
    costs: dict[str, float] = {}
    legs: dict[str, tuple[dict[str, float], ...]] = {}
    filled = {FILLED: 1.0} if FILLED in resources else {}
    for p in fillers:
        elements[p.id] = {**zero, "length": p.length, **filled,
                          **{a: float(v) for a, v in p.attributes.items()}}
        costs[p.id] = 0.0
    for pid, p in kp.parts.items():
        elements[pid], costs[pid] = dict(zero), 0.0
        lengths = _legs(p, pid, quantum)
        shares = _shares({a: float(v) for a, v in p.attributes.items() if a in zero},
                         1 if p.cls in ("end_left", "end_right") else len(lengths))
        legs[pid] = tuple({**zero, "length": x, **shares[min(i, len(shares) - 1)]}
                          for i, x in enumerate(lengths))
    if kp.joint:
        for jid, (a, b) in _joint_variants(quantum).items():
            elements[jid] = dict(zero)
            costs[jid] = float(joint_cost) + JOINT_LEG_COST * (a + b - 2 * quantum)
            legs[jid] = ({**zero, "length": a}, {**zero, "length": b})
        for sid, (jid, _p, extra) in kp.seam.items():
            elements[sid], costs[sid], legs[sid] = elements[jid], costs[jid] + extra, legs[jid]
    return {"elements": elements, "costs": costs, "legs": legs}


def _transitions(db: PartDB, fillers: list[Part], kp: _KeyParts) -> dict:
    """:func:`_transition_tables`, made once per process for each set of parts (every
    block of a style asks for the same tables, which took milliseconds of Python a
    block to build); each caller gets its own copies."""
    key = (db.library_hash, tuple(p.id for p in fillers), tuple(kp.parts), kp.joint,
           bool(kp.seam))
    tables = _TABLES.get(key)
    if tables is None:
        tables = _TABLES[key] = _transition_tables(db, fillers, kp)
        if len(_TABLES) > CACHED_TABLES:
            _TABLES.popitem(last=False)
    return {name: dict(table) for name, table in tables.items()}


CACHED_TABLES = 64    # sets of parts whose transition tables a process keeps
_TABLES: OrderedDict[tuple, dict[str, dict[tuple[str, str], float]]] = OrderedDict()


def _transition_tables(db: PartDB, fillers: list[Part], kp: _KeyParts) -> dict:
    """The database's costs between every pair of parts; from a T's branch leg, the
    branch costs; into a T's branch leg (an H's bar ending at its T), the disagreement
    with the branch section. A T part in another pose than its own
    (:mod:`citysynth.export.t_poses`) meets its neighbours with the sections that pose puts
    at its ends, compared as the database compares sections. A mitre joint joins the
    modules on either side at no
    cost of its own (they are cut to meet; its cost is its unary cost), and only modules:
    a stage with no module beside a joint would leave its corner empty. A seam joint
    (:func:`_seam_joints`) passes on the transition between the modules it joins."""
    ids = [p.id for p in fillers] + list(kp.parts)
    idx = db.index()
    base = {x: t_pose(x).part for x in ids}
    posed = {x for x in ids if base[x] != x}
    trans, btrans = {}, {}
    for x in ids:
        for y in ids:
            i, j = idx[base[x]], idx[base[y]]
            if db.allowed[i, j] and np.isfinite(db.cost[i, j]) and not {x, y} & posed:
                trans[(x, y)] = float(db.cost[i, j])
            if np.isfinite(db.cost_branch[i, j]):
                btrans[(x, y)] = float(db.cost_branch[i, j])
    posed_trans, into_branch = _section_costs(db, ids, base, posed)
    trans.update(posed_trans)
    if kp.joint:   # only modules meet a joint: they are what is cut to fill its corner
        for jid in _joint_variants(db.quantum):
            for p in fillers:
                trans[(p.id, jid)] = trans[(jid, p.id)] = 0.0
    for sid, (_jid, y, _extra) in kp.seam.items():   # across a seam: the modules' own
        family = [p for p in fillers if not y or _start_alike(p, db.by_id[y])]
        trans.update(((sid, p.id), 0.0) for p in family)
        trans.update(((x.id, sid), trans[(x.id, y)] if y else 0.0) for x in fillers
                     if not y or (x.id, y) in trans)
    return {"transitions": trans, "branch_transitions": btrans,
            "branch_in_transitions": into_branch}


def _section_costs(db: PartDB, ids: list[str], base: dict[str, str], posed: set[str]
                   ) -> tuple[dict[tuple[str, str], float], dict[tuple[str, str], float]]:
    """Transitions into and out of T parts in a pose of their own, and from every part
    into a T's branch leg: the database's section disagreement between what meets (a
    turned T's out-leg is its part's in-leg; a T turned over shows its main sections
    mirrored about the middle of their depth; the branch leg its branch section)."""
    parts = db.by_id
    ts = [y for y in ids if parts[base[y]].cls == "t_junction"]
    if not ts:
        return {}, {}
    idx = db.index()

    def ends(x: str) -> tuple[object, object]:
        p = parts[base[x]]
        if x not in posed:
            return p.sec_in, p.sec_out
        pose = t_pose(x)
        a, b = (p.sec_out, p.sec_in) if pose.swap else (p.sec_in, p.sec_out)
        if pose.street:
            mid = -main_depth(p.sec_in, db.quantum) / 2
            a, b = (shapely.affinity.scale(g, -1.0, 1.0, origin=(mid, 0.0)) for g in (a, b))
        return a, b

    sec = {x: ends(x) for x in ids}
    pairs = [(x, y) for x in ids for y in ids if (x in posed or y in posed)
             and db.allowed[idx[base[x]], idx[base[y]]]]
    into = [(x, y) for x in ids for y in ts if db.allowed[idx[base[x]], idx[base[y]]]]
    areas = np.round(disagreement(
        np.array([sec[x][1] for x, _y in pairs + into], dtype=object),
        np.array([sec[y][0] for _x, y in pairs] + [parts[base[y]].sec_branch
                                                  for _x, y in into], dtype=object)), 4)
    a = areas.tolist() if pairs or into else []
    return (dict(zip(pairs, a[:len(pairs)], strict=True)),
            dict(zip(into, a[len(pairs):], strict=True)))


def shortest_stage(db: PartDB, style: str) -> float:
    """The shortest stage two mitre joints can close: one middle part of the style.
    Block sides shorter than this cannot be built, so cleaning absorbs them into their
    corners."""
    return min((p.length for p in db.select("middle", style)), default=0.0)


def _on_cycle(s: int, inc: dict[int, list[int]], ends: list[tuple[int, int]]) -> bool:
    """Whether chain s lies on the (single) cycle: removing it keeps its ends joined."""
    a, b = ends[s]
    seen, todo = {a}, [a]
    while todo:
        v = todo.pop()
        for t in inc[v]:
            w = ends[t][1] if ends[t][0] == v else ends[t][0]
            if t != s and w not in seen:
                seen.add(w)
                todo.append(w)
    return b in seen
