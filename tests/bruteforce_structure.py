"""Exhaustive enumeration of every feasible filling of a small chain or cycle
structure: the oracle for the structure solver. Independent of it: every choice of
key elements, every filler sequence of every stage, summed as the README defines."""

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
    kps = [k["elements"] for k in d["keypoints"]]
    closed = d.get("closed", False)
    stages = d["stages"]
    fillers_all = [i for i in el if i not in legs]

    def fillings(i, a, b):
        cons = stages[i]["constraints"]
        fillers = [x for x in stages[i].get("elements", fillers_all) if x not in legs]
        out = []

        def ok(tot, final):
            for r, (lo, hi) in cons.items():
                if tot[r] > hi + EPS or (final and tot[r] < lo - EPS):
                    return False
            return True

        def rec(last, seq, cost, tot):
            if (last, b) in delta:
                t2 = {r: tot[r] + legs[b][0][r] for r in res}
                if ok(t2, True):
                    out.append(cost + delta[(last, b)] + omega[b])
            if len(seq) >= max_fill:
                return
            for f in fillers:
                if (last, f) in delta:
                    t2 = {r: tot[r] + vals[f][r] for r in res}
                    if ok(t2, False):
                        rec(f, seq + [f], cost + delta[(last, f)] + omega[f], t2)

        rec(a, [], 0.0, dict(legs[a][1]))
        return out

    totals = []
    choices = [kps[j] for j in range(len(kps))]
    for keys in itertools.product(*choices):
        seq_keys = list(keys) + ([keys[0]] if closed else [])
        parts = [fillings(i, seq_keys[i], seq_keys[i + 1]) for i in range(len(stages))]
        start = 0.0 if closed else omega[seq_keys[0]]
        for combo in itertools.product(*parts):
            totals.append(start + sum(combo))
    return sorted(totals)
