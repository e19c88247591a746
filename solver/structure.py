"""Structures of the paper's §3.2, first version: trees and cycles of substructures
solved by decomposition.

A structure is a graph of key points joined by substructures (stages). A key point
admits a set of key elements (a corner class, an end class, a T class ...). A key
element has one leg per incident stage: leg 0 counts toward the stage that ends at
the key point, leg 1 toward the stage that starts there, and leg 2 toward the branch
stage of a T junction. Each stage has its own resource intervals (local, reset at
every key point). A structure is a tree (one stage fewer than key points, stages
pointing away from the root) or one cycle through key point 0 with trees hanging off
it; the cycle is cut at key point 0, whose element is the same at both ends of the
unrolled sequence, and its closing transition is paid for.

This version decomposes. For every stage and every pair of key elements at its two
ends, the k best fillings come from :func:`solver.solve` on a one-stage problem (the
key elements enter as their legs). A k-best dynamic program over the tree of key
points then combines them: below a key point with a given element, the k best
completions are the k smallest sums over its outgoing stages. That is exact, because
once the key elements are fixed a structure's cost is the sum of independent stage
costs. Structure-wide intervals are met by solving each stage once per share of the
structure-wide resource. The paper's single merged graph (one k-shortest-path search
with virtual T duplicates) is the next step; this solver is its reference and second
opinion.
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Any

from .errors import ProblemError
from .problem import Element, Problem, _number, check_object, parse_intervals
from .quantize import exact_divisor, is_multiple
from .solve import solve

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


@dataclass
class StructureSolution:
    keys: list[str]                  # the element at each key point
    stages: list[list[str]]          # the fillers of each stage
    cost: float
    resources: list[dict[str, float]]   # per stage, legs included


@dataclass
class StructureResult:
    status: str
    solutions: list[StructureSolution]
    stats: dict[str, Any] = field(default_factory=dict)
    reason: str | None = None


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


def _start_leg(st: Structure, s: int) -> int:
    """The leg of the element at stage s's start that counts toward s: the branch leg
    (2) for a T's branch stage, else the out-leg (1). The end always uses leg 0."""
    return 2 if st.branch.get(st.stages[s].start) == s else 1


class _StageBuilder:
    """One-stage problems of a structure, built straight from validated data (no
    re-parsing: a 40-corner block needs hundreds of them)."""

    def __init__(self, st: Structure, k: int):
        self.st, self.k = st, k
        keyset = set(st.legs)
        self._inner: dict[tuple[str, ...], tuple] = {}
        self._keyset = keyset

    def fillers(self, i: int) -> tuple[str, ...]:
        stage = self.st.stages[i]
        return tuple(x for x in (stage.elements or self.st.elements) if x not in self._keyset)

    def inner(self, fillers: tuple[str, ...]):
        """Filler elements and filler-to-filler transitions, shared by every stage with
        the same fillers."""
        if fillers not in self._inner:
            st, fs = self.st, set(fillers)
            els = tuple(Element(f, st.elements[f], st.costs[f]) for f in fillers)
            trans = tuple((x, y, c) for (x, y), c in st.transitions.items()
                          if x in fs and y in fs)
            self._inner[fillers] = (els, trans)
        return self._inner[fillers]

    def problem(self, i: int, a: str, b: str, extra: dict | None = None) -> Problem:
        """Stage i between key elements a (at its start) and b (at its end); the keys'
        unary costs are counted at their key points, not here."""
        st = self.st
        stage = st.stages[i]
        fillers = self.fillers(i)
        fs = set(fillers)
        els, inner = self.inner(fillers)
        A, B = "^" + a, "$" + b
        leg_a = _start_leg(st, i)
        from_a = st.branch_transitions if leg_a == 2 else st.transitions
        trans = [(A, B if y == b else y, c) for (x, y), c in from_a.items()
                 if x == a and (y in fs or y == b)]
        trans += [(x, B, c) for (x, y), c in st.transitions.items() if y == b and x in fs]
        return Problem(
            resources=st.resources,
            elements=(Element(A, st.legs[a][leg_a], 0.0), Element(B, st.legs[b][0], 0.0))
            + els,
            transitions=tuple(trans) + inner, front=(A,), back=(B,),
            constraints={**stage.constraints, **(extra or {})}, quantum=dict(st.quantum),
            k=self.k)


def _ksum(A: list, B: list, k: int) -> list:
    """The k smallest a + b over two cost-sorted lists of (cost, payload); payloads
    pair up."""
    if not A or not B:
        return []
    heap = [(A[0][0] + B[0][0], 0, 0)]
    seen = {(0, 0)}
    out = []
    while heap and len(out) < k:
        c, i, j = heapq.heappop(heap)
        out.append((c, (A[i][1], B[j][1])))
        for i2, j2 in ((i + 1, j), (i, j + 1)):
            if i2 < len(A) and j2 < len(B) and (i2, j2) not in seen:
                seen.add((i2, j2))
                heapq.heappush(heap, (A[i2][0] + B[j2][0], i2, j2))
    return out


def _global_grid(st: Structure) -> tuple[list[str], list[float], list[int], list[int]]:
    """Structure-wide resources on an exact integer grid: names, quanta, bounds."""
    names, qs, los, his = [], [], [], []
    for r, (lo, hi) in st.global_constraints.items():
        values = [v[r] for v in st.elements.values()] + [leg[r] for legs in st.legs.values()
                                                         for leg in legs]
        q = st.quantum.get(r)
        if q is None:
            frac = exact_divisor(values + [lo, hi])
            if frac is None:
                raise ProblemError(f'structure-wide constraint on "{r}": its values have no '
                                   "common divisor; give a quantum")
            q = float(frac)
        if not all(is_multiple(v, q) for v in values):
            raise ProblemError(f'structure-wide constraint on "{r}": every value must be a '
                               f"multiple of its quantum {q:g} (sums are split between "
                               "stages exactly)")
        names.append(r)
        qs.append(q)
        los.append(int(math.ceil(lo / q - 1e-9)))
        his.append(int(math.floor(hi / q + 1e-9)))
    return names, qs, los, his


def solve_structure(st: Structure, k: int | None = None, **solve_kw) -> StructureResult:
    """The k cheapest distinct fillings of a tree or cycle structure.

    Structure-wide intervals are handled exactly: every stage is solved once per
    possible share of each structure-wide resource (an equality added to its
    problem), and the dynamic program keeps k best completions per partial total."""
    k = st.k if k is None else int(k)
    t0 = time.perf_counter()
    n = len(st.keypoints)
    out: list[list[int]] = [[] for _ in range(n)]
    for i, s in enumerate(st.stages):
        out[s.start].append(i)
    gnames, gq, glo, ghi = _global_grid(st)
    shares = list(itertools.product(*[range(h + 1) for h in ghi]))
    stage_cache: dict[tuple[int, str, str], dict] = {}
    why: list[str] = []
    builder = _StageBuilder(st, k)

    def fits(g) -> bool:
        return all(x <= h for x, h in zip(g, ghi, strict=True))

    def add(g1, g2):
        return tuple(x + y for x, y in zip(g1, g2, strict=True))

    def stage_lists(i: int, a: str, b: str) -> dict:
        """share of the structure-wide resources -> k best fillings of stage i"""
        if (i, a, b) not in stage_cache:
            lists = {}
            for g in shares:
                extra = {r: (x * q, x * q) for r, x, q in zip(gnames, g, gq, strict=True)}
                r = solve(builder.problem(i, a, b, extra), k,
                          **{"explain": not gnames, **solve_kw})
                if r.solutions:
                    lists[g] = [(x.cost, (x.sequence[1:-1], x.resources))
                                for x in r.solutions]
                elif r.reason and not gnames:
                    why.append(f"stage {i} between {a} and {b}: {r.reason}")
            stage_cache[(i, a, b)] = lists
        return stage_cache[(i, a, b)]

    if st.closed:
        root = 0
        closing = next(i for i, s in enumerate(st.stages) if s.end == 0)
    else:
        root = [v for v in range(n) if all(s.end != v for s in st.stages)][0]
        closing = -1
    zero = tuple(0 for _ in gnames)

    def below(v: int, e: str, fixed_root: str | None, memo: dict) -> dict:
        """share -> k best completions of everything after key point v holding e, as
        (cost, payload); payload = {stage: (element at its end, fillers, totals,
        payload below that end)}."""
        key = (v, e)
        if key in memo:
            return memo[key]
        acc = {zero: [(0.0, {})]}
        for s in out[v]:
            w = st.stages[s].end
            options: dict = {}
            if s == closing:  # the cycle closes on key point 0's element, paid there
                for g, ls in stage_lists(s, e, fixed_root).items():
                    options.setdefault(g, []).extend(
                        (c, (fixed_root, fill, res, {})) for c, (fill, res) in ls)
            else:
                for f in st.keypoints[w]:
                    sub = below(w, f, fixed_root, memo)
                    for g1, ls in stage_lists(s, e, f).items():
                        for g2, lw in sub.items():
                            g = add(g1, g2)
                            if not fits(g):
                                continue
                            lw_f = [(cc + st.costs[f], p) for cc, p in lw]
                            options.setdefault(g, []).extend(
                                (c, (f, fill, res, p2))
                                for c, ((fill, res), p2) in _ksum(ls, lw_f, k))
            options = {g: sorted(ls, key=lambda t: t[0])[:k] for g, ls in options.items()}
            nxt: dict = {}
            for g1, la in acc.items():
                for g2, lb in options.items():
                    g = add(g1, g2)
                    if fits(g):
                        nxt.setdefault(g, []).extend(
                            (c, {**pa, s: pb}) for c, (pa, pb) in _ksum(la, lb, k))
            acc = {g: sorted(ls, key=lambda t: t[0])[:k] for g, ls in nxt.items()}
            if not acc:
                break
        memo[key] = acc
        return acc

    results = []
    for e in st.keypoints[root]:
        memo: dict = {}
        for g, ls in below(root, e, e if st.closed else None, memo).items():
            if all(x >= lo for x, lo in zip(g, glo, strict=True)):
                results.extend((c + st.costs[e], e, payload) for c, payload in ls)
    results.sort(key=lambda t: t[0])
    sols = []
    for cost, e, payload in results[:k]:
        keys: list[str | None] = [None] * n
        fills: list[list[str]] = [[] for _ in st.stages]
        totals: list[dict] = [{} for _ in st.stages]
        keys[root] = e
        todo = [payload]
        while todo:
            p = todo.pop()
            for s, (f, fill, res, sub) in p.items():
                if s != closing:
                    keys[st.stages[s].end] = f
                fills[s] = list(fill)
                totals[s] = res
                todo.append(sub)
        sols.append(StructureSolution(keys, fills, cost, totals))
    stats = {"stage_problems": len(shares) * len(stage_cache),
             "solve_s": time.perf_counter() - t0}
    if not sols:
        detail = f"; e.g. {why[0]}" if why else ""
        wide = " and the structure-wide intervals" if gnames else ""
        return StructureResult("infeasible", [], stats,
                               f"no choice of key elements lets every stage meet its "
                               f"constraints{wide}{detail}")
    return StructureResult("ok", sols, stats)
