"""A lower bound on the cost to go that sees two resources at once.

The one-resource tables of :mod:`citysynth.solver.bounds` bound each resource alone, and
their maximum is weak where two resources move together: a tower's height and its
floor area both grow with every floor, so a stack of floors cheap enough to reach the
height may lie far from any floor area in the interval, and the search weighs it all
the same. At 300 m on a 2,500 m² lot it filled the 2 GB budget in half a minute and the
tower was refused.

The *pair* relaxation keeps two resources: a *level* resource l that every element
consumes at least one quantum of (a tower's height), known exactly, and another j
known to levels of s quanta (as :func:`~citysynth.solver.bounds.coarse_cost_to_go`
knows one). Its cost to go g[c, q, e] is filled by a backward program over c from
the top down: every element moves c up by at least one, so a row is final once the
rows above it are. Why it is a consistent lower bound: an element consuming r of j
moves a sequence from level floor(c_j / s) to that plus floor(r / s) or one more
(floor((c_j + r) / s) is one of the two, whatever c_j's remainder), and a sequence
ending with c_j in [lo_j, cap_j] ends on a level in [floor(lo_j / s), floor(cap_j /
s)]; so every completion of node (e, c) of the real problem is a completion of (e,
c_l, floor(c_j / s)) in the relaxation, for the same cost, and the relaxation's
Bellman equation takes the cheaper of the two steps where the real one takes one of
them: g(e, c) <= w(e, f) + g(f, c + r_f) on every transition.

Built only where a search on the one-resource tables ran out of its first share of
labels (:func:`citysynth.solver.bounded.bounded_k_best`): the program costs levels x
steps x transitions, more than every row of the benches spends in all.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numba import njit

from citysynth.solver.bounds import Bounds
from citysynth.solver.compiled import Compiled

PAIR_LEVELS = 512
"""The other resource is known to at most about this many levels (a tower's 15,300 m²
of floor area in steps of 30 m²: its floors are 400 m² and more)."""
MIN_PAIR_LEVELS = 8
"""Fewer levels than this (the budget allows no finer table) bound too little to pay."""
PAIR_TABLE_SHARE = 8
"""A pair table may take 1/8 of the solver's memory budget (256 MB of 2 GB)."""


@njit(cache=True, fastmath={"nnan", "nsz"})
def pair_to_go(rl, lo, cap, lo_step, hi_step, qlo, qcap, back, pred_ptr, pred_elem,
               pred_w):
    """g[c, q, e]: the cheapest completion from element e with c quanta of the level
    resource consumed (every element consuming at least one: ``rl`` >= 1) and the
    other resource on level q, that ends (where a sequence may end) with c in [lo,
    cap] and q in [qlo, qcap], an element f moving q up by ``lo_step[f]`` or
    ``hi_step[f]``, whichever is cheaper; inf when none does."""
    n = len(rl)
    g = np.full((cap + 1, qcap + 1, n), np.inf)
    for c in range(max(lo, 0), cap + 1):
        for q in range(max(qlo, 0), qcap + 1):
            for e in range(n):
                if back[e]:
                    g[c, q, e] = 0.0
    for c in range(cap, -1, -1):
        for f in range(n):
            c2 = c + rl[f]
            if c2 > cap:
                continue
            a, b = pred_ptr[f], pred_ptr[f + 1]
            for q in range(qcap + 1):
                v = np.inf
                q1 = q + lo_step[f]
                if q1 <= qcap:
                    v = g[c2, q1, f]
                q2 = q + hi_step[f]
                if hi_step[f] > lo_step[f] and q2 <= qcap and g[c2, q2, f] < v:
                    v = g[c2, q2, f]
                if v == np.inf:
                    continue
                for j in range(a, b):
                    p = pred_elem[j]
                    x = pred_w[j] + v
                    if x < g[c, q, p]:
                        g[c, q, p] = x
    return g


def pair_choice(cp: Compiled, budget_bytes: int) -> tuple[int, int, int] | None:
    """(level resource, other resource, levels' step s) for ``cp``'s pair table within
    ``budget_bytes``, or None: with one resource, without a resource every element
    consumes some of (the program needs one), or where the budget leaves the other
    fewer than :data:`MIN_PAIR_LEVELS` levels. The level resource is the narrowest of
    those every element consumes; the other the widest of the rest."""
    if cp.R < 2 or cp.n == 0:
        return None
    levels = [i for i in range(cp.R) if int(cp.r[:, i].min()) >= 1]
    if not levels:
        return None
    lv = min(levels, key=lambda i: (int(cp.cap[i]), i))
    j = max((i for i in range(cp.R) if i != lv), key=lambda i: (int(cp.cap[i]), -i))
    rows = int(cp.cap[lv]) + 1
    most = budget_bytes // (8 * cp.n * rows)         # levels of j the budget allows
    wide = int(cp.cap[j]) + 1
    s = max(1, -(-wide // min(PAIR_LEVELS, max(most, 1))))
    if wide // s + 1 > most or wide // s + 1 < MIN_PAIR_LEVELS:
        return None
    return lv, j, s


def pair_table(cp: Compiled, lv: int, j: int, s: int) -> np.ndarray:
    """The pair relaxation's cost to go (:func:`pair_to_go`) of level resource lv and
    resource j in levels of s quanta, as g[c_lv, c_j // s, e]."""
    rj = cp.r[:, j].astype(np.int64)
    return pair_to_go(cp.r[:, lv].astype(np.int64), int(cp.lo[lv]), int(cp.cap[lv]),
                      rj // s, -(-rj // s), max(int(cp.lo[j]), 0) // s, int(cp.cap[j]) // s,
                      cp.back, cp.pred_ptr, cp.pred_elem, cp.pred_w)


def with_pair(cp: Compiled, bounds: Bounds, budget_bytes: int) -> Bounds | None:
    """``bounds`` with the pair table :func:`pair_choice` picks within
    ``budget_bytes``, or None where none applies."""
    choice = pair_choice(cp, budget_bytes)
    if choice is None:
        return None
    lv, j, s = choice
    g = pair_table(cp, lv, j, s)
    one = np.ones(1, dtype=np.int64)
    return replace(bounds, pl=one * lv, pj=one * j, ps=one * s, pq=one * (g.shape[1] - 1),
                   pbase=np.zeros(1, dtype=np.int64), ptab=g.ravel())
