"""Exhaustive enumeration of every feasible sequence of a small problem: the oracle
the solver is proven against. Deliberately simple and independent of the solver:
depth-first over element sequences, pruned only by the upper bounds, with costs
summed front to back as eq. (1) and (4) of the paper define them."""

from __future__ import annotations

from citysynth.solver.problem import Problem

EPS = 1e-9


def enumerate_feasible(p: Problem, max_len: int = 64) -> list[tuple[float, tuple[str, ...]]]:
    omega = {e.id: e.cost for e in p.elements}
    res = {e.id: e.resources for e in p.elements}
    succ: dict[str, list[tuple[str, float]]] = {e.id: [] for e in p.elements}
    for a, b, c in p.transitions:
        succ[a].append((b, c))
    back = set(p.back)
    bounded = list(p.constraints)
    out: list[tuple[float, tuple[str, ...]]] = []

    def feasible(tot):
        return all(p.constraints[r][0] - EPS <= tot[r] <= p.constraints[r][1] + EPS
                   for r in bounded)

    def rec(seq, cost, tot):
        if seq[-1] in back and feasible(tot):
            out.append((cost, tuple(seq)))
        if len(seq) >= max_len:
            return
        for b, d in succ[seq[-1]]:
            nt = {r: tot[r] + res[b][r] for r in bounded}
            if any(nt[r] > p.constraints[r][1] + EPS for r in bounded):
                continue
            seq.append(b)
            rec(seq, cost + d + omega[b], nt)
            seq.pop()

    for f in p.front:
        tot = {r: res[f][r] for r in bounded}
        if any(tot[r] > p.constraints[r][1] + EPS for r in bounded):
            continue
        rec([f], omega[f], tot)
    out.sort()
    return out
