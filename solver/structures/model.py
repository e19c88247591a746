"""The structure model of the paper's §3.2: trees and cycles of substructures
(stages) between key points, with T junctions, as plain validated data.

A structure is a graph of key points joined by substructures (stages). A key point
admits a set of key elements (a corner class, an end class, a T class ...). A key
element has one leg per incident stage: leg 0 counts toward the stage that ends at
the key point, leg 1 toward the stage that starts there, and leg 2 toward the branch
stage of a T junction. Each stage has its own resource intervals (local, reset at
every key point). A structure is a tree (one stage fewer than key points, stages
pointing away from the root) or one cycle through key point 0 with trees hanging off
it; the cycle is cut at key point 0, whose element is the same at both ends of the
unrolled sequence, and its closing transition is paid for.

Solving is :func:`citysynth.solver.structures.solve.solve_structure`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from citysynth.solver.errors import ProblemError
from citysynth.solver.problem import Problem, _number, check_object, parse_intervals

_KEYS = {"resources", "quantum", "elements", "transitions", "branch_transitions",
         "keypoints", "stages", "closed", "k", "constraints"}


@dataclass(frozen=True)
class Stage:
    constraints: dict[str, tuple[float, float]]
    elements: tuple[str, ...] | None = None   # fillers; None: every non-key element
    start: int = 0                            # key point it leaves
    end: int = 1                              # key point it reaches


@dataclass(frozen=True)
class Structure:
    resources: tuple[str, ...]
    quantum: dict[str, float]
    elements: dict[str, dict[str, float]]            # id -> resources (fillers)
    costs: dict[str, float]                          # id -> unary cost
    legs: dict[str, tuple[dict, ...]]                # key element id -> its legs
    transitions: dict[tuple[str, str], float]
    branch_transitions: dict[tuple[str, str], float]  # from a T's branch leg
    keypoints: tuple[tuple[str, ...], ...]
    branch: dict[int, int]                           # T key point -> its branch stage
    stages: tuple[Stage, ...]
    closed: bool
    k: int = 1
    global_constraints: dict[str, tuple[float, float]] = field(default_factory=dict)

    @classmethod
    def from_dict(cls, d: Any, source: str = "structure") -> Structure:
        def err(msg: str) -> ProblemError:
            return ProblemError(f"{source}: {msg}")

        check_object(d, _KEYS, "structure", source)
        # validate elements, transitions and quantum through the one-stage model
        base = Problem.from_dict({
            "resources": d.get("resources"), "quantum": d.get("quantum", {}),
            "elements": [{k: v for k, v in e.items() if k != "legs"}
                         for e in d.get("elements") or []]
            if isinstance(d.get("elements"), list) else d.get("elements"),
            "transitions": d.get("transitions", []),
            "constraints": {d["resources"][0]: [0, 0]} if isinstance(d.get("resources"), list)
            and d["resources"] else {},
        }, source)
        legs: dict[str, tuple[dict, dict]] = {}
        for i, e in enumerate(d["elements"]):
            if "legs" not in e:
                continue
            lg = e["legs"]
            where = f"elements[{i}].legs"
            if not isinstance(lg, list) or not 2 <= len(lg) <= 3 or not all(
                    isinstance(x, dict) for x in lg):
                raise err(f"{where}: a key element needs [in-leg, out-leg] (and a branch leg "
                          "for T parts) as resource objects")
            pair = []
            for leg in lg:
                vals = {}
                for r, v in leg.items():
                    if r not in base.resources:
                        raise err(f"{where}: unknown resource {r!r}")
                    vals[r] = _number(v, f"{source}: {where}.{r}")
                pair.append({r: vals.get(r, 0.0) for r in base.resources})
            legs[e["id"]] = tuple(pair)
        ids = {e.id for e in base.elements}
        kps = d.get("keypoints")
        if not isinstance(kps, list) or not kps:
            raise err('"keypoints" must be a non-empty list of {"elements": [...]}')
        keypoints, branch = [], {}
        for j, kp in enumerate(kps):
            els = kp.get("elements") if isinstance(kp, dict) else None
            if not isinstance(els, list) or not els:
                raise err(f"keypoints[{j}]: needs a non-empty elements list")
            for x in els:
                if x not in legs:
                    raise err(f"keypoints[{j}]: {x!r} is not a key element (it needs legs)")
            keypoints.append(tuple(els))
            if "branch" in kp:
                branch[j] = kp["branch"]
        st_in = d.get("stages")
        if not isinstance(st_in, list) or not st_in:
            raise err('"stages" must be a non-empty list of {"constraints": {...}}')
        closed = bool(d.get("closed", False))
        explicit = any(isinstance(s, dict) and ("from" in s or "to" in s) for s in st_in)
        if not explicit:
            need = len(st_in) if closed else len(st_in) + 1
            if len(keypoints) != need:
                raise err(f"{len(st_in)} stages need {need} key points "
                          f"({'a cycle' if closed else 'a chain'}), got {len(keypoints)}")
        stages = []
        for i, s in enumerate(st_in):
            if not isinstance(s, dict):
                raise err(f"stages[{i}]: must be an object")
            cons = parse_intervals(s.get("constraints"), base.resources,
                                   f"stages[{i}].constraints", source)
            if not cons:
                raise err(f"stages[{i}]: needs at least one constraint")
            els = s.get("elements")
            if els is not None:
                for x in els:
                    if x not in ids:
                        raise err(f"stages[{i}].elements: unknown element {x!r}")
                els = tuple(els)
            if explicit:
                a, b = s.get("from"), s.get("to")
                for v, name in ((a, "from"), (b, "to")):
                    if isinstance(v, bool) or not isinstance(v, int) or not \
                            0 <= v < len(keypoints):
                        raise err(f"stages[{i}].{name}: must be a key point index, got {v!r}")
                if a == b:
                    raise err(f"stages[{i}]: from and to are the same key point")
            else:
                a, b = i, (i + 1) % len(keypoints)
            stages.append(Stage(cons, els, a, b))
        k = d.get("k", 1)
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise err(f'"k" must be a positive integer, got {k!r}')
        transitions = {(a, b): c for a, b, c in base.transitions}
        bt = transitions
        if "branch_transitions" in d:
            bt = {(a, b): c for a, b, c in Problem.from_dict({
                "resources": list(base.resources),
                "elements": [{"id": e.id} for e in base.elements],
                "transitions": d["branch_transitions"],
                "constraints": {base.resources[0]: [0, 0]}}, source).transitions}
        closed = _check_shape(stages, keypoints, branch, legs, err)
        glob = parse_intervals(d.get("constraints"), base.resources, "constraints", source)
        return cls(
            resources=base.resources, quantum=dict(base.quantum),
            elements={e.id: dict(e.resources) for e in base.elements},
            costs={e.id: e.cost for e in base.elements}, legs=legs,
            transitions=transitions, branch_transitions=bt, keypoints=tuple(keypoints),
            branch=branch, stages=tuple(stages), closed=closed, k=k,
            global_constraints=glob)


def _check_shape(stages, keypoints, branch, legs, err) -> bool:
    """A tree with stages pointing away from its root, or one cycle through key point 0
    (every key point entered exactly once); returns True for the cycle."""
    n = len(keypoints)
    indeg = [0] * n
    out: list[list[int]] = [[] for _ in range(n)]
    for i, s in enumerate(stages):
        indeg[s.end] += 1
        out[s.start].append(i)
    if len(stages) == n - 1:
        roots = [v for v in range(n) if indeg[v] == 0]
        if len(roots) != 1 or any(x > 1 for x in indeg):
            raise err("a tree structure needs its stages to point away from one root key "
                      "point (each other key point entered by exactly one stage)")
        closed = False
    elif len(stages) == n:
        if any(x != 1 for x in indeg):
            raise err("a cyclic structure needs every key point entered by exactly one "
                      "stage (the cycle through key point 0, branches pointing away)")
        closed = True
    else:
        raise err(f"{len(stages)} stages and {n} key points form neither a tree "
                  f"({n - 1} stages) nor one cycle ({n} stages)")
    seen, todo = {0 if closed else indeg.index(0)}, [0 if closed else indeg.index(0)]
    while todo:
        v = todo.pop()
        for i in out[v]:
            if stages[i].end not in seen:
                seen.add(stages[i].end)
                todo.append(stages[i].end)
    if len(seen) != n:
        raise err("the structure is disconnected (or its cycle does not pass key point 0)")
    for v in range(n):
        deg = len(out[v]) + indeg[v]
        if deg > 3:
            raise err(f"keypoints[{v}]: {deg} stages meet there; at most 3 (a T junction)")
        if len(out[v]) == 2:
            if branch.get(v) not in out[v]:
                raise err(f"keypoints[{v}]: two stages leave it; name the one that branches "
                          f'off with "branch": <stage index>')
            for x in keypoints[v]:
                if len(legs[x]) < 3:
                    raise err(f"keypoints[{v}]: {x!r} has no branch leg (a T part needs 3 "
                              "legs)")
    return closed
