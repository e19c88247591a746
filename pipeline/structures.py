"""A skeleton and a part database become a structure for the solver.

Key points take the library's key parts of the chosen style: corners matching their
angle and convexity (:func:`skeletons.match_corner_angles`), T parts at T junctions
(their branch leg on the skeleton's branch edge), end parts at ends. Bends (nearly
straight vertices) are not key points: their edges merge into one stage. Each stage
must be filled to its skeleton length within half a quantum (the export's uniform
stretch absorbs the rest) and meets the edge's own constraints on part attributes.
Fillers are the style's middle parts; transition costs are the database's.

Key parts contribute their legs' lengths to the stages they touch; their attributes
(windows, doors) are not split between legs and so do not count toward per-edge
attribute constraints (only the middle parts' do).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from parts_db import PartDB
from skeletons import Skeleton, match_corner_angles
from skeletons.errors import SkeletonError


def _stages(sk: Skeleton):
    """Merge edges through bends: returns key point ids and stages as (a, b, length,
    constraints, edges)."""
    kind = {k.id: k.kind for k in sk.keypoints}
    adj = defaultdict(list)
    for i, e in enumerate(sk.edges):
        adj[e.a].append((i, e.b))
        adj[e.b].append((i, e.a))
    keys = [k.id for k in sk.keypoints if k.kind != "bend"]
    if not keys:
        raise SkeletonError(f"{sk.name}: no corner, end or T junction to anchor parts at")
    used: set[int] = set()
    stages = []
    for start in keys:
        for i, nxt in adj[start]:
            if i in used:
                continue
            chain, length, cons, v = [i], sk.edges[i].length, dict(sk.edges[i].constraints), nxt
            used.add(i)
            prev_edge = i
            while kind[v] == "bend":
                j, w = next((j, w) for j, w in adj[v] if j != prev_edge)
                used.add(j)
                chain.append(j)
                length += sk.edges[j].length
                cons.update(sk.edges[j].constraints)
                prev_edge, v = j, w
            stages.append((start, v, length, cons, chain))
    return keys, stages


def skeleton_structure(sk: Skeleton, db: PartDB, style: str, *, k: int = 1,
                       angle_tol: float = 7.5) -> dict:
    """The structure dict (see ``solver.structure.Structure.from_dict``) for ``sk``."""
    keys, stages = _stages(sk)
    kp_of = {k.id: k for k in sk.keypoints}
    corners = [p for p in db.select("corner", style)]
    chosen = match_corner_angles(sk, [(p.angle, p.convex) for p in corners], angle_tol)
    index = {v: j for j, v in enumerate(keys)}
    adj = defaultdict(list)
    for s, (a, b, *_rest) in enumerate(stages):
        adj[index[a]].append((s, index[b]))
        adj[index[b]].append((s, index[a]))
    cyclic = len(stages) == len(keys)
    if cyclic:  # the structure's key point 0 must lie on the cycle
        root = next(j for j in range(len(keys))
                    if any(_on_cycle(s, adj, stages, index) for s, _w in adj[j]))
    else:
        root = next((index[v] for v in keys if kp_of[v].kind == "end"), 0)
    oriented: dict[int, tuple[int, int]] = {}
    if cyclic:  # walk the cycle from the root first
        prev, v = None, root
        while True:
            s, w = next((s, w) for s, w in adj[v] if s != prev and s not in oriented
                        and _on_cycle(s, adj, stages, index))
            oriented[s] = (v, w)
            prev, v = s, w
            if v == root:
                break
    todo = [root] + [w for _v, w in oriented.values()]
    seen = set(todo)
    while todo:  # then every other stage points away from what is reached
        v = todo.pop()
        for s, w in adj[v]:
            if s not in oriented and w not in seen:
                oriented[s] = (v, w)
                seen.add(w)
                todo.append(w)
    if len(oriented) != len(stages):
        raise SkeletonError(f"{sk.name}: more than one cycle; split it into a cycle and "
                            "trees, or into several buildings")
    # renumber so the root is key point 0
    order = [root] + [j for j in range(len(keys)) if j != root]
    renum = {j: i for i, j in enumerate(order)}
    keys = [keys[j] for j in order]
    oriented = {s: (renum[a], renum[b]) for s, (a, b) in oriented.items()}

    fillers = db.select("middle", style)
    if not fillers:
        raise SkeletonError(f"the library has no middle parts of style {style!r}")
    attrs = sorted({a for p in fillers for a in p.attributes})
    keypoints, key_parts = [], {}
    for j, v in enumerate(keys):
        kp = kp_of[v]
        if kp.kind == "corner":
            angle, convex = chosen[v]
            opts = [p for p in corners if (p.angle, p.convex) == (angle, convex)]
        elif kp.kind == "t_junction":
            opts = db.select("t_junction", style)
        else:
            starts = any(a == j for a, _b in oriented.values())
            opts = db.select("end_left" if starts else "end_right", style)
        if not opts:
            raise SkeletonError(f"{sk.name}: the library has no {kp.kind} part of style "
                                f"{style!r} for the key point at ({kp.xy[0]:.1f}, "
                                f"{kp.xy[1]:.1f})")
        entry = {"elements": [p.id for p in opts]}
        if kp.kind == "t_junction":
            branch_edge = kp.branch
            entry["branch"] = next(s for s, st in enumerate(stages) if branch_edge in st[4])
        keypoints.append(entry)
        for p in opts:
            key_parts[p.id] = p

    q = db.quantum
    stage_dicts = []
    for s, (_a, _b, length, cons, _chain) in enumerate(stages):
        lo, hi = oriented[s]
        c = {"length": [round(length - q / 2, 6), round(length + q / 2, 6)]}
        for name, iv in cons.items():
            if name not in attrs:
                raise SkeletonError(f"{sk.name}: edge constraint on {name!r}, which no "
                                    f"{style} middle part has (they have {attrs})")
            c[name] = list(iv)
        stage_dicts.append({"from": lo, "to": hi, "constraints": c})

    def legs(p):
        if p.cls in ("end_left", "end_right"):
            return [{"length": p.length}, {"length": p.length}]
        return [{"length": x} for x in p.legs]

    elements = [{"id": p.id, "resources": {"length": p.length, **p.attributes}}
                for p in fillers]
    elements += [{"id": pid, "legs": legs(p)} for pid, p in key_parts.items()]
    ids = [p.id for p in fillers] + list(key_parts)
    idx = db.index()
    trans, btrans = [], []
    for x in ids:
        for y in ids:
            i, j = idx[x], idx[y]
            if db.allowed[i, j] and np.isfinite(db.cost[i, j]):
                trans.append([x, y, float(db.cost[i, j])])
            if np.isfinite(db.cost_branch[i, j]):
                btrans.append([x, y, float(db.cost_branch[i, j])])
    return {"resources": ["length", *attrs], "quantum": {"length": q},
            "elements": elements, "transitions": trans, "branch_transitions": btrans,
            "keypoints": keypoints, "stages": stage_dicts, "k": k}


def _on_cycle(s, adj, stages, index) -> bool:
    """Whether stage s lies on the (single) cycle: removing it keeps its ends joined."""
    a, b = index[stages[s][0]], index[stages[s][1]]
    seen, todo = {a}, [a]
    while todo:
        v = todo.pop()
        for t, w in adj[v]:
            if t != s and w not in seen:
                seen.add(w)
                todo.append(w)
    return b in seen
