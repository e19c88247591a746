"""Exhaustive enumeration of every feasible filling of a small structure (chain,
cycle or tree with T junctions): the oracle for the structure solver. Independent of
it: every choice of key elements, every filler sequence of every stage, summed as the
README defines (each key element's unary cost once, the closing transition of a cycle
included), structure-wide intervals checked on the sum of all stage totals.

Asked for the k smallest totals only, it first drops, for each choice of key
elements, every stage filling beaten by k others of the same stage with the same
structure-wide totals: such a filling can be swapped for any of those k in a
combination, so no combination using it is among the k cheapest. That keeps the
product over stages small without changing the k smallest totals. Each stage is
filled once per pair of key elements at its ends, not once per choice of all of them.

Bounded like :mod:`tests.bruteforce`: the stage sequences and combinations a draw
would visit are counted first (per stage, a count per (last element, totals)), and a
hypothesis draw over ``LIMIT`` of them is rejected and counted instead of enumerated.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter, defaultdict

from tests.bruteforce import within_budget

EPS = 1e-9


def _most_fillers(cons: dict, fillers: list[str], vals: dict) -> int:
    """The most fillers a stage can hold: some resource every filler consumes bounds
    it (a stage of length 9 may hold nine fillers of length 1)."""
    bound = 12
    for r, (_lo, hi) in cons.items():
        m = min((vals[f][r] for f in fillers), default=0.0)
        if m > 0:
            bound = min(bound, int(math.floor(hi / m + EPS)))
    return bound


def _read(d: dict):
    """The structure dict as the oracle uses it: resources, elements by id, their
    resource values, unary costs and legs, the transition tables (ordinary, out of a
    T's branch leg, into a T's branch leg), the key points, and each stage as (from,
    to, spec) (a chain or cycle when from/to are left out)."""
    res = d["resources"]
    el = {e["id"]: e for e in d["elements"]}
    vals = {i: {r: float(e.get("resources", {}).get(r, 0.0)) for r in res}
            for i, e in el.items()}
    omega = {i: float(e.get("cost", 0.0)) for i, e in el.items()}
    legs = {i: [{r: float(x.get(r, 0.0)) for r in res} for x in e["legs"]]
            for i, e in el.items() if "legs" in e}
    delta = {(a, b): float(c) for a, b, c in d["transitions"]}
    bdelta = {(a, b): float(c) for a, b, c in d.get("branch_transitions", d["transitions"])}
    idelta = {(a, b): float(c)
              for a, b, c in d.get("branch_in_transitions", d["transitions"])}
    kps = d["keypoints"]
    n = len(kps)
    stages = [((s["from"], s["to"]) if "from" in s else (i, (i + 1) % n)) + (s,)
              for i, s in enumerate(d["stages"])]
    return res, el, vals, omega, legs, (delta, bdelta, idelta), kps, stages


def _stage_specs(d: dict, read) -> list[tuple]:
    """Per stage: start and end key point, whether it leaves its start on the branch
    leg, its first transition table, its intervals, its fillers, the most fillers it
    can hold, the leg of its end element (2 when it ends on a T's branch leg, else 0)
    and the table of its last transition (from a filler into the end element; with no
    filler the first table decides)."""
    res, el, vals, omega, legs, (delta, bdelta, idelta), kps, stages = read
    fillers_all = [i for i in el if i not in legs]
    out = []
    for s_index, (start, end, spec) in enumerate(stages):
        branch_leg = kps[start].get("branch") == s_index
        end_leg = 2 if kps[end].get("branch") == s_index else 0
        cons = spec["constraints"]
        fillers = [x for x in spec.get("elements", fillers_all) if x not in legs]
        out.append((start, end, branch_leg, bdelta if branch_leg else delta, cons, fillers,
                    _most_fillers(cons, fillers, vals), end_leg,
                    idelta if end_leg == 2 else delta))
    return out


def _ok(cons: dict, tot: dict, final: bool) -> bool:
    return all(tot[r] <= hi + EPS and (not final or tot[r] >= lo - EPS)
               for r, (lo, hi) in cons.items())


def _stage_work(read, spec: tuple, a: str, b: str, wide: dict, k: int | None) -> tuple[int, int]:
    """Without enumerating: how many filler sequences :func:`_fillings` visits for one
    stage between key elements ``a`` and ``b``, and how many fillings it keeps (a
    count per (last element, totals), layer by layer)."""
    res, _el, vals, _omega, legs, (delta, _bd, _id), _kps, _stages = read
    _start, _end, branch_leg, first, cons, fillers, max_fill, end_leg, into = spec
    layer = {(a, tuple(legs[a][2 if branch_leg else 1][r] for r in res)): 1}
    trans, visited, groups = first, 0, Counter()
    for depth in range(max_fill + 1):
        nxt: dict[tuple, int] = defaultdict(int)
        for (last, tot), n in layer.items():
            visited += n
            t = dict(zip(res, tot, strict=True))
            if (last, b) in (first if depth == 0 else into):
                t2 = {r: t[r] + legs[b][end_leg][r] for r in res}
                if _ok(cons, t2, True):
                    groups[tuple(round(t2[r], 9) for r in wide)] += n
            if depth == max_fill:
                continue
            for f in fillers:
                if (last, f) in trans:
                    t2 = {r: t[r] + vals[f][r] for r in res}
                    if _ok(cons, t2, False):
                        nxt[(f, tuple(t2[r] for r in res))] += n
        layer, trans = nxt, delta
    kept = sum(groups.values()) if k is None else sum(min(n, k) for n in groups.values())
    return visited, kept


def _fillings(read, spec: tuple, a: str, b: str, wide: dict,
              k: int | None) -> tuple[list, int]:
    """Every filling of one stage between key elements ``a`` and ``b`` as (cost,
    totals), asked for the k smallest only k per structure-wide totals (see the
    module docstring); and the number of filler sequences visited."""
    res, _el, vals, omega, legs, (delta, _bd, _id), _kps, _stages = read
    _start, _end, branch_leg, first, cons, fillers, max_fill, end_leg, into = spec
    out = []
    visited = 0

    def rec(last, trans, seq, cost, tot):
        nonlocal visited
        visited += 1
        last_table = into if seq else first
        if (last, b) in last_table:
            t2 = {r: tot[r] + legs[b][end_leg][r] for r in res}
            if _ok(cons, t2, True):
                out.append((cost + last_table[(last, b)], t2))
        if len(seq) >= max_fill:
            return
        for f in fillers:
            if (last, f) in trans:
                t2 = {r: tot[r] + vals[f][r] for r in res}
                if _ok(cons, t2, False):
                    rec(f, delta, seq + [f], cost + trans[(last, f)] + omega[f], t2)

    rec(a, first, [], 0.0, dict(legs[a][2 if branch_leg else 1]))
    if k is not None:  # k best per structure-wide totals (see the module docstring)
        groups: dict = {}
        for c, t in sorted(out, key=lambda x: x[0]):
            ls = groups.setdefault(tuple(round(t[r], 9) for r in wide), [])
            if len(ls) < k:
                ls.append((c, t))
        out = [x for ls in groups.values() for x in ls]
    return out, visited


def structure_work(d: dict, k: int | None = None) -> int:
    """How many stage sequences and combinations :func:`enumerate_structure` visits,
    counted without enumerating them."""
    read = _read(d)
    specs = _stage_specs(d, read)
    wide = d.get("constraints", {})
    work: dict[tuple, tuple[int, int]] = {}
    total = 0
    for keys in itertools.product(*[kp["elements"] for kp in read[6]]):
        kept = 1
        for i, spec in enumerate(specs):
            ab = (i, keys[spec[0]], keys[spec[1]])
            if ab not in work:
                work[ab] = _stage_work(read, spec, ab[1], ab[2], wide, k)
                total += work[ab][0]
            kept *= work[ab][1]
        total += kept
    return total


def enumerate_structure(d: dict, k: int | None = None) -> list[float]:
    """Every feasible total in ascending order, or only the k smallest."""
    within_budget("enumerate_structure", structure_work(d, k))
    return _enumerate_structure(d, k)[0]


def _enumerate_structure(d: dict, k: int | None) -> tuple[list[float], int]:
    """The totals, and the number of stage sequences and combinations visited. Each
    stage's fillings are enumerated once per pair of key elements at its ends."""
    read = _read(d)
    omega, kps = read[3], read[6]
    specs = _stage_specs(d, read)
    wide = d.get("constraints", {})
    memo: dict[tuple, list] = {}
    totals, visited = [], 0
    for keys in itertools.product(*[kp["elements"] for kp in kps]):
        parts = []
        for i, spec in enumerate(specs):
            ab = (i, keys[spec[0]], keys[spec[1]])
            if ab not in memo:
                memo[ab], n = _fillings(read, spec, ab[1], ab[2], wide, k)
                visited += n
            parts.append(memo[ab])
        base = sum(omega[x] for x in keys)
        visited += math.prod(len(p) for p in parts)
        for combo in itertools.product(*parts):
            if all(lo - EPS <= sum(t[r] for _c, t in combo) <= hi + EPS
                   for r, (lo, hi) in wide.items()):
                totals.append(base + sum(c for c, _t in combo))
    totals.sort()
    return (totals if k is None else totals[:k]), visited


def solution_cost(d: dict, keys: list[str], fills: list[list[str]]) -> float:
    """The cost of one filling of structure ``d`` (an element per key point, fillers
    per stage), checked against every rule the enumeration above follows: allowed
    elements and transitions, each stage's interval and the structure-wide ones.
    Raises AssertionError for a filling that breaks one."""
    res, el, vals, omega, legs, (delta, bdelta, idelta), kps, stages = _read(d)
    cost = 0.0
    for key, kp in zip(keys, kps, strict=True):
        assert key in kp["elements"]
        cost += omega[key]
    totals = {r: 0.0 for r in res}
    for i, ((a, b, s), fill) in enumerate(zip(stages, fills, strict=True)):
        branch = kps[a].get("branch") == i
        end_leg = 2 if kps[b].get("branch") == i else 0
        allowed = [x for x in s.get("elements", el) if x not in legs]
        assert all(x in allowed for x in fill)
        seq = [keys[a], *fill, keys[b]]
        for j, (x, y) in enumerate(zip(seq, seq[1:], strict=False)):
            table = bdelta if j == 0 and branch else idelta if j == len(fill) and \
                end_leg == 2 and j > 0 else delta
            assert (x, y) in table, (x, y)
            cost += table[(x, y)]
            if j < len(fill):  # y is a filler: its unary cost
                cost += omega[y]
        tot = {r: legs[keys[a]][2 if branch else 1][r] + legs[keys[b]][end_leg][r]
               + sum(vals[x][r] for x in fill) for r in res}
        for r, (lo, hi) in s["constraints"].items():
            assert lo - EPS <= tot[r] <= hi + EPS, (i, r, tot[r])
        for r in res:
            totals[r] += tot[r]
    for r, (lo, hi) in d.get("constraints", {}).items():
        assert lo - EPS <= totals[r] <= hi + EPS, (r, totals[r])
    return cost
