"""Exhaustive enumeration of every feasible filling of a small structure (chain,
cycle or tree with T junctions): the oracle for the structure solver. Independent of
it: every choice of key elements, every filler sequence of every stage, summed as the
README defines (each key element's unary cost once, the closing transition of a cycle
included), structure-wide intervals checked on the sum of all stage totals."""

from __future__ import annotations

import itertools

EPS = 1e-9


def enumerate_structure(d: dict, max_fill: int = 6) -> list[float]:
    res = d["resources"]
    el = {e["id"]: e for e in d["elements"]}
    vals = {i: {r: float(e.get("resources", {}).get(r, 0.0)) for r in res}
            for i, e in el.items()}
    omega = {i: float(e.get("cost", 0.0)) for i, e in el.items()}
    legs = {i: [{r: float(x.get(r, 0.0)) for r in res} for x in e["legs"]]
            for i, e in el.items() if "legs" in e}
    delta = {(a, b): float(c) for a, b, c in d["transitions"]}
    bdelta = {(a, b): float(c) for a, b, c in d.get("branch_transitions", d["transitions"])}
    kps = d["keypoints"]
    n = len(kps)
    stages = []
    for i, s in enumerate(d["stages"]):
        a, b = (s["from"], s["to"]) if "from" in s else (i, (i + 1) % n)
        stages.append((a, b, s))
    fillers_all = [i for i in el if i not in legs]

    def fillings(s_index, a, b):
        start, _end, spec = stages[s_index]
        branch_leg = kps[start].get("branch") == s_index
        first = bdelta if branch_leg else delta
        cons = spec["constraints"]
        fillers = [x for x in spec.get("elements", fillers_all) if x not in legs]
        out = []

        def ok(tot, final):
            return all(tot[r] <= hi + EPS and (not final or tot[r] >= lo - EPS)
                       for r, (lo, hi) in cons.items())

        def rec(last, trans, seq, cost, tot):
            if (last, b) in trans:
                t2 = {r: tot[r] + legs[b][0][r] for r in res}
                if ok(t2, True):
                    out.append((cost + trans[(last, b)], t2))
            if len(seq) >= max_fill:
                return
            for f in fillers:
                if (last, f) in trans:
                    t2 = {r: tot[r] + vals[f][r] for r in res}
                    if ok(t2, False):
                        rec(f, delta, seq + [f], cost + trans[(last, f)] + omega[f], t2)

        rec(a, first, [], 0.0, dict(legs[a][2 if branch_leg else 1]))
        return out

    wide = d.get("constraints", {})
    totals = []
    for keys in itertools.product(*[k["elements"] for k in kps]):
        parts = [fillings(i, keys[a], keys[b]) for i, (a, b, _s) in enumerate(stages)]
        base = sum(omega[x] for x in keys)
        for combo in itertools.product(*parts):
            if all(lo - EPS <= sum(t[r] for _c, t in combo) <= hi + EPS
                   for r, (lo, hi) in wide.items()):
                totals.append(base + sum(c for c, _t in combo))
    return sorted(totals)
