"""Exhaustive enumeration of every feasible sequence of a small problem: the oracle
the solver is proven against. Deliberately simple and independent of the solver:
depth-first over element sequences, pruned only by the upper bounds, with costs
summed front to back as eq. (1) and (4) of the paper define them.

Bounded: a hypothesis draw is only as cheap as its enumeration, and a few draws (five
elements of length 1 under a bound of 12: 5^12 sequences) would take minutes, making
the suite's time a matter of the seed. So before enumerating, the oracle counts the
sequences it would visit (a count per (last element, totals), layer by layer, never
the sequences themselves); inside a hypothesis example, a draw over ``LIMIT`` is
rejected and counted in ``SKIPPED`` (conftest prints the counts at the end of the
run) and hypothesis draws another in its place, so a property still runs its full
number of examples. Called from a plain test, the oracle enumerates whatever it is
given.
"""

from __future__ import annotations

from collections import Counter, defaultdict

from hypothesis import currently_in_test_context, event, reject

from citysynth.solver.problem import Problem

EPS = 1e-9
LIMIT = 10_000                 # sequences (or stage fillings and combinations) per draw
SKIPPED: Counter[str] = Counter()   # oracle name -> hypothesis draws skipped


def within_budget(oracle: str, work: int) -> None:
    """Inside a hypothesis example, reject the draw when its enumeration would visit
    more than ``LIMIT`` sequences, and count the skip; elsewhere do nothing."""
    if work > LIMIT and currently_in_test_context():
        SKIPPED[oracle] += 1
        event(f"{oracle}: draw skipped (enumeration over {LIMIT} sequences)")
        reject()


def _setup(p: Problem):
    """Successors with their transition costs, back elements, bounded resources and
    each element's resources, as both the count and the enumeration read them."""
    succ: dict[str, list[tuple[str, float]]] = {e.id: [] for e in p.elements}
    for a, b, c in p.transitions:
        succ[a].append((b, c))
    res = {e.id: e.resources for e in p.elements}
    return succ, set(p.back), list(p.constraints), res


def count_sequences(p: Problem, max_len: int = 64, stop: int | None = None) -> int:
    """How many sequences :func:`enumerate_feasible` visits (each start, each
    extension within the upper bounds), counted layer by layer per (last element,
    totals); stops counting once past ``stop``."""
    succ, _back, bounded, res = _setup(p)
    hi = {r: p.constraints[r][1] + EPS for r in bounded}
    layer: dict[tuple, int] = defaultdict(int)
    for f in p.front:
        tot = tuple(res[f][r] for r in bounded)
        if all(t <= hi[r] for t, r in zip(tot, bounded, strict=True)):
            layer[(f, tot)] += 1
    total = 0
    for _length in range(max_len):
        total += sum(layer.values())
        if stop is not None and total > stop:
            break
        nxt: dict[tuple, int] = defaultdict(int)
        for (last, tot), n in layer.items():
            for b, _c in succ[last]:
                nt = tuple(t + res[b][r] for t, r in zip(tot, bounded, strict=True))
                if all(t <= hi[r] for t, r in zip(nt, bounded, strict=True)):
                    nxt[(b, nt)] += n
        layer = nxt
    return total


def enumerate_feasible(p: Problem, max_len: int = 64) -> list[tuple[float, tuple[str, ...]]]:
    within_budget("enumerate_feasible", count_sequences(p, max_len, stop=LIMIT))
    return _enumerate(p, max_len)[0]


def _enumerate(p: Problem, max_len: int) -> tuple[list[tuple[float, tuple[str, ...]]], int]:
    """Every feasible sequence, sorted, and the number of sequences visited."""
    omega = {e.id: e.cost for e in p.elements}
    succ, back, bounded, res = _setup(p)
    out: list[tuple[float, tuple[str, ...]]] = []
    visited = 0

    def feasible(tot):
        return all(p.constraints[r][0] - EPS <= tot[r] <= p.constraints[r][1] + EPS
                   for r in bounded)

    def rec(seq, cost, tot):
        nonlocal visited
        visited += 1
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
    return out, visited
