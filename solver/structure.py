"""Structures of the paper's §3.2, first version: chains and cycles of substructures
solved by decomposition.

A structure is a sequence of substructures (stages) between key points. A key point
admits a set of key elements (a corner class, an end class, ...). A key element has
two legs, the in-leg counting toward the stage before it and the out-leg toward the
stage after it. Each stage has its own resource intervals (local, reset at every key
point). A closed structure (a cycle) starts and ends at key point 0 with the same
element, and the closing transition is paid for.

This version decomposes: for every stage and every pair of key elements at its two
ends, the k best fillings come from :func:`solver.solve` on a one-stage problem (the
key elements enter as their legs), and a k-best merge over the key choices combines
the stages. That is exact: a structure's cost is the sum of independent stage costs
once the key elements are fixed. The paper's single merged graph (with trees
spliced in through virtual T duplicates, and structure-wide intervals) is the next
step; this solver is its reference and second opinion. Trees and structure-wide
intervals are refused for now with that message.
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass, field
from typing import Any

from .errors import ProblemError
from .problem import Problem, _number
from .solve import solve

_KEYS = {"resources", "quantum", "elements", "transitions", "keypoints", "stages",
         "closed", "k", "constraints"}


@dataclass(frozen=True)
class Stage:
    constraints: dict[str, tuple[float, float]]
    elements: tuple[str, ...] | None = None   # fillers; None: every non-key element


@dataclass(frozen=True)
class Structure:
    resources: tuple[str, ...]
    quantum: dict[str, float]
    elements: dict[str, dict[str, float]]            # id -> resources (fillers)
    costs: dict[str, float]                          # id -> unary cost
    legs: dict[str, tuple[dict, dict]]               # key element id -> (in-leg, out-leg)
    transitions: dict[tuple[str, str], float]
    keypoints: tuple[tuple[str, ...], ...]
    stages: tuple[Stage, ...]
    closed: bool
    k: int = 1

    @classmethod
    def from_dict(cls, d: Any, source: str = "structure") -> Structure:
        def err(msg: str) -> ProblemError:
            return ProblemError(f"{source}: {msg}")

        if not isinstance(d, dict):
            raise err("a structure must be a JSON object")
        unknown = sorted(set(d) - _KEYS)
        if unknown:
            raise err(f"unknown key(s) {unknown}; allowed: {sorted(_KEYS)}")
        if d.get("constraints"):
            raise err("structure-wide constraints are not supported yet (they need the "
                      "merged graph of the paper); give per-stage constraints")
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
            if not isinstance(lg, list) or len(lg) != 2 or not all(isinstance(x, dict)
                                                                  for x in lg):
                raise err(f"{where}: a key element needs [in-leg, out-leg] resource objects")
            pair = []
            for leg in lg:
                vals = {}
                for r, v in leg.items():
                    if r not in base.resources:
                        raise err(f"{where}: unknown resource {r!r}")
                    vals[r] = _number(v, f"{source}: {where}.{r}")
                pair.append({r: vals.get(r, 0.0) for r in base.resources})
            legs[e["id"]] = (pair[0], pair[1])
        ids = {e.id for e in base.elements}
        kps = d.get("keypoints")
        if not isinstance(kps, list) or not kps:
            raise err('"keypoints" must be a non-empty list of {"elements": [...]}')
        keypoints = []
        for j, kp in enumerate(kps):
            els = kp.get("elements") if isinstance(kp, dict) else None
            if not isinstance(els, list) or not els:
                raise err(f"keypoints[{j}]: needs a non-empty elements list")
            for x in els:
                if x not in legs:
                    raise err(f"keypoints[{j}]: {x!r} is not a key element (it needs legs)")
            keypoints.append(tuple(els))
        st_in = d.get("stages")
        if not isinstance(st_in, list) or not st_in:
            raise err('"stages" must be a non-empty list of {"constraints": {...}}')
        closed = bool(d.get("closed", False))
        need = len(st_in) if closed else len(st_in) + 1
        if len(keypoints) != need:
            raise err(f"{len(st_in)} stages need {need} key points "
                      f"({'a cycle' if closed else 'a chain'}), got {len(keypoints)}")
        stages = []
        for i, s in enumerate(st_in):
            if not isinstance(s, dict):
                raise err(f"stages[{i}]: must be an object")
            cons = {}
            for r, iv in (s.get("constraints") or {}).items():
                if r not in base.resources or not isinstance(iv, list | tuple) or len(iv) != 2:
                    raise err(f"stages[{i}].constraints.{r}: must be [min, max] of a resource")
                lo = _number(iv[0], f"{source}: stages[{i}].constraints.{r}[0]")
                hi = _number(iv[1], f"{source}: stages[{i}].constraints.{r}[1]")
                if lo > hi:
                    raise err(f"stages[{i}].constraints.{r}: min {lo:g} > max {hi:g}")
                cons[r] = (lo, hi)
            if not cons:
                raise err(f"stages[{i}]: needs at least one constraint")
            els = s.get("elements")
            if els is not None:
                for x in els:
                    if x not in ids:
                        raise err(f"stages[{i}].elements: unknown element {x!r}")
                els = tuple(els)
            stages.append(Stage(cons, els))
        k = d.get("k", 1)
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise err(f'"k" must be a positive integer, got {k!r}')
        return cls(
            resources=base.resources, quantum=dict(base.quantum),
            elements={e.id: dict(e.resources) for e in base.elements},
            costs={e.id: e.cost for e in base.elements}, legs=legs,
            transitions={(a, b): c for a, b, c in base.transitions},
            keypoints=tuple(keypoints), stages=tuple(stages), closed=closed, k=k)


@dataclass
class StructureSolution:
    keys: list[str]                  # the element at each key point (cycles: once)
    stages: list[list[str]]          # the fillers of each stage
    cost: float
    resources: list[dict[str, float]]   # per stage, legs included


@dataclass
class StructureResult:
    status: str
    solutions: list[StructureSolution]
    stats: dict[str, Any] = field(default_factory=dict)
    reason: str | None = None


def _stage_problem(st: Structure, i: int, a: str, b: str, k: int) -> Problem:
    stage = st.stages[i]
    keyset = set(st.legs)
    fillers = [x for x in (stage.elements or st.elements) if x not in keyset]
    A, B = "^" + a, "$" + b
    elements = [{"id": A, "resources": st.legs[a][1], "cost": 0.0},
                {"id": B, "resources": st.legs[b][0], "cost": st.costs[b]}]
    elements += [{"id": f, "resources": st.elements[f], "cost": st.costs[f]} for f in fillers]
    trans = []
    for (x, y), c in st.transitions.items():
        xs = A if x == a else x if x in fillers else None
        ys = B if y == b else y if y in fillers else None
        if xs is not None and ys is not None:
            trans.append([xs, ys, c])
    return Problem.from_dict({
        "resources": list(st.resources), "quantum": st.quantum, "elements": elements,
        "transitions": trans, "front": [A], "back": [B],
        "constraints": {r: list(iv) for r, iv in stage.constraints.items()}, "k": k,
    }, f"stage {i} ({a} -> {b})")


def _k_smallest_sums(lists: list[tuple[float, object, list]], k: int):
    """k smallest (x + y) over (base cost x with payload, sorted list ys) pairs."""
    heap = []
    for n, (x, _payload, ys) in enumerate(lists):
        if ys:
            heap.append((x + ys[0][0], n, 0))
    heapq.heapify(heap)
    out = []
    while heap and len(out) < k:
        c, n, j = heapq.heappop(heap)
        x, payload, ys = lists[n]
        out.append((c, payload, ys[j]))
        if j + 1 < len(ys):
            heapq.heappush(heap, (x + ys[j + 1][0], n, j + 1))
    return out


def solve_structure(st: Structure, k: int | None = None, **solve_kw) -> StructureResult:
    """The k cheapest distinct fillings of a chain or cycle structure."""
    k = st.k if k is None else int(k)
    t0 = time.perf_counter()
    m = len(st.stages)
    K = [list(x) for x in st.keypoints]
    if st.closed:
        K.append(list(K[0]))
    cache: dict[tuple[int, str, str], list] = {}

    def stage_list(i: int, a: str, b: str) -> list:
        key = (i, a, b)
        if key not in cache:
            r = solve(_stage_problem(st, i, a, b, k), k, **solve_kw)
            cache[key] = [(s.cost, [x for x in s.sequence[1:-1]], s.resources)
                          for s in r.solutions]
        return cache[key]

    results = []
    starts = [[x] for x in K[0]] if st.closed else [K[0]]
    for first in starts:
        # layer j: for each key element, its k best partial paths
        # entry: (cost, (prev entry, stage fillers, stage resources, key))
        layer = {a: [(0.0 if st.closed else st.costs[a], (None, None, None, a))]
                 for a in first}
        for i in range(m):
            nxt = {}
            targets = [first[0]] if (st.closed and i == m - 1) else K[i + 1]
            for b in targets:
                lists = []
                for a, entries in layer.items():
                    ys = stage_list(i, a, b)
                    for e in entries:
                        lists.append((e[0], e, ys))
                picked = _k_smallest_sums(lists, k)
                if picked:
                    nxt[b] = [(c, (prev, y[1], y[2], b)) for c, prev, y in picked]
            layer = nxt
            if not layer:
                break
        for entries in layer.values():
            results.extend(entries)
    results.sort(key=lambda t: t[0])
    sols = []
    for cost, node in results[:k]:
        keys, stages, res = [], [], []
        entry = (cost, node)
        while entry is not None:
            prev, fillers, resources, key = entry[1]
            keys.append(key)
            if fillers is not None:
                stages.append(fillers)
                res.append(resources)
            entry = prev
        keys.reverse()
        stages.reverse()
        res.reverse()
        if st.closed:
            keys = keys[:-1]
        sols.append(StructureSolution(keys, stages, cost, res))
    stats = {"stage_problems": len(cache), "solve_s": time.perf_counter() - t0}
    if not sols:
        return StructureResult("infeasible", [], stats,
                               "no choice of key elements lets every stage meet its "
                               "constraints")
    return StructureResult("ok", sols, stats)
