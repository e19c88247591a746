"""Lower bounds on the cost to go: exact cost-to-go tables of one-resource relaxations.

Drop every constrained resource but one, i, and the problem becomes a plain
one-resource problem over nodes (element e, consumed quanta c of resource i). Every
sequence of the full problem is a sequence of the relaxation with the same cost, so
the relaxation's exact cost-to-go h_i(e, c) is a lower bound on the real one, and it
is *consistent*: h_i(e, c) <= w(e, f) + h_i(f, c + r_i(f)) for every transition the
real problem can take, because that inequality is the relaxation's own Bellman
equation. The maximum over several resources is a consistent bound too. A node whose
bound is infinite cannot complete even in the relaxation, so the bound doubles as a
feasibility test on every kept resource's interval.

One table costs a backward dynamic program over (cap_i + 1) levels, O(transitions x
levels), filled from the highest level down: a node's value is final once every level
above it has pushed into it. Elements that consume nothing of resource i (a wall
with no door, for the door count) stay on the same level; that level is then finished
by a small Dijkstra over those zero-consumption transitions before it pushes down.

With a single constrained resource the relaxation *is* the problem, and the table is
the exact cost-to-go of every node: :mod:`citysynth.solver.bounded` enumerates the k best paths
on it directly.

For the best sequence alone a table may be *coarse* (:func:`coarse_cost_to_go`): the
relaxation that knows the amount consumed only to levels of s quanta, a program s
times smaller, still a consistent lower bound.

Tables are stored one after another in one flat array (:class:`Bounds`) so the kernels
can take the maximum over them for any node with a few loads.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from citysynth.solver.compiled import Compiled


@njit(cache=True, inline="always")
def _hpush(hk, hv, hs, key, val):
    """Push (key, val) on a binary min-heap held in hk/hv[:hs]; returns the new size."""
    pos = hs
    while pos > 0:
        par = (pos - 1) // 2
        if hk[par] <= key:
            break
        hk[pos] = hk[par]
        hv[pos] = hv[par]
        pos = par
    hk[pos] = key
    hv[pos] = val
    return hs + 1


@njit(cache=True, inline="always")
def _hpop(hk, hv, hs):
    """Remove the minimum; returns (key, val, new size)."""
    key, val = hk[0], hv[0]
    hs -= 1
    if hs > 0:
        lk, lv = hk[hs], hv[hs]
        pos = 0
        while True:
            ch = 2 * pos + 1
            if ch >= hs:
                break
            if ch + 1 < hs and hk[ch + 1] < hk[ch]:
                ch += 1
            if hk[ch] >= lk:
                break
            hk[pos] = hk[ch]
            hv[pos] = hv[ch]
            pos = ch
        hk[pos] = lk
        hv[pos] = lv
    return key, val, hs


@njit(cache=True)
def _finish_level(h, c, ri, pred_ptr, pred_elem, pred_w, hk, hv):
    """Dijkstra on level c over the transitions into elements that consume nothing of
    the resource (they stay on level c); the level's values are final afterwards."""
    n = len(ri)
    hs = 0
    for f in range(n):
        if ri[f] == 0 and h[c, f] < np.inf:
            hs = _hpush(hk, hv, hs, h[c, f], f)
    while hs > 0:
        hf, f, hs = _hpop(hk, hv, hs)
        if hf > h[c, f]:
            continue  # a stale entry
        for j in range(pred_ptr[f], pred_ptr[f + 1]):
            p = pred_elem[j]
            v = pred_w[j] + hf
            if v < h[c, p]:
                h[c, p] = v
                if ri[p] == 0:
                    hs = _hpush(hk, hv, hs, v, p)


@njit(cache=True, fastmath={"nnan", "nsz"})
def _push_down(h, c, ri, pred_ptr, pred_elem, pred_w):
    """Every finished node (f, c) offers pred_w + h to its predecessors on the level
    its own consumption came from. Full predecessor lists (dense tables) run as one
    contiguous vector loop, sparse ones entry by entry."""
    n = len(ri)
    for f in range(n):
        hf = h[c, f]
        if hf == np.inf or ri[f] == 0:
            continue
        cp = c - ri[f]
        if cp < 0:
            continue
        a, b = pred_ptr[f], pred_ptr[f + 1]
        if b - a == n:
            for p in range(n):
                h[cp, p] = min(h[cp, p], pred_w[a + p] + hf)
        else:
            for j in range(a, b):
                p = pred_elem[j]
                h[cp, p] = min(h[cp, p], pred_w[j] + hf)


@njit(cache=True)
def relaxed_cost_to_go(ri, lo, cap, back, pred_ptr, pred_elem, pred_w):
    """h[c, e]: the exact cheapest completion of a sequence that ends with element e
    having consumed c quanta of one resource (e's own included), when only that
    resource's interval [lo, cap] counts; inf when none exists."""
    n = len(ri)
    h = np.full((cap + 1, n), np.inf)
    for c in range(max(lo, 0), cap + 1):
        for e in range(n):
            if back[e] and ri[e] <= c:
                h[c, e] = 0.0
    zero = False
    for e in range(n):
        if ri[e] == 0:
            zero = True
    m = len(pred_elem) + n + 1
    hk = np.empty(m if zero else 1)
    hv = np.empty(m if zero else 1, dtype=np.int64)
    for c in range(cap, -1, -1):
        if zero:
            _finish_level(h, c, ri, pred_ptr, pred_elem, pred_w, hk, hv)
        _push_down(h, c, ri, pred_ptr, pred_elem, pred_w)
    return h


# C901: a numba kernel: the levels, both steps and the dense and sparse relaxations in
# one compiled loop. The relaxation of a row repeats _push_down's on purpose: one
# compiled helper for both (called or inlined) made both kernels 1.8x slower on the
# street front (100 m: 0.89 -> 1.61 ms exact, 0.13 -> 0.22 ms coarse)
@njit(cache=True, fastmath={"nnan", "nsz"})
def coarse_to_go(lo_step, hi_step, qlo, qcap, back, pred_ptr, pred_elem,  # noqa: C901
                 pred_w):
    """g[q, e]: the cheapest completion from element e at coarse level q that ends
    (where a sequence may end) on a level in [qlo, qcap], an element f moving it up
    by ``lo_step[f]`` or ``hi_step[f]`` levels, whichever is cheaper; inf when none
    does. Filled from the top level down like :func:`relaxed_cost_to_go`; the steps
    of no level (``lo_step`` 0) by the same small Dijkstra (:func:`_finish_level`)."""
    n = len(lo_step)
    g = np.full((qcap + 1, n), np.inf)
    for q in range(max(qlo, 0), qcap + 1):
        for e in range(n):
            if back[e]:
                g[q, e] = 0.0
    zero = False
    for f in range(n):
        if lo_step[f] == 0:
            zero = True
    m = len(pred_elem) + n + 1
    hk = np.empty(m if zero else 1)
    hv = np.empty(m if zero else 1, dtype=np.int64)
    for q in range(qcap, -1, -1):
        row = g[q]
        for f in range(n):
            v = np.inf
            if lo_step[f] >= 1 and q + lo_step[f] <= qcap:
                v = g[q + lo_step[f], f]
            if hi_step[f] > lo_step[f] and q + hi_step[f] <= qcap:
                v = min(v, g[q + hi_step[f], f])
            if v == np.inf:
                continue
            a, b = pred_ptr[f], pred_ptr[f + 1]
            if b - a == n:            # a dense row: one vector loop (a select vectorises)
                for p in range(n):
                    x = pred_w[a + p] + v
                    y = row[p]
                    row[p] = x if x < y else y
            else:
                for j in range(a, b):
                    p = pred_elem[j]
                    x = pred_w[j] + v
                    if x < row[p]:
                        row[p] = x
        if zero:
            _finish_level(g, q, lo_step, pred_ptr, pred_elem, pred_w, hk, hv)
    return g


COARSE_LEVELS = 64
"""A coarse table (:func:`coarse_factor`) has about this many levels below its
resource's lower bound."""
MIN_COARSE_FACTOR = 4
"""A coarse table at least this many times smaller than the exact one, or none: where
it would save less, the search it guides costs more than it saves (the 20 m street
front at factor 2: 0.39 ms against 0.29 ms on the exact table; the motion graph's
5 m row, 2.7 ms against 2.1 ms)."""
MIN_COARSE_FACTOR_SEVERAL = 6
"""The same with several constrained resources, where the search on a coarse table
makes more labels (the others cut less of what it lets through): the three-resource
street at 40 m, factor 4, 288 labels against 41 on the exact tables, 1.07 ms in all
against 0.84 (80 m at factor 7: 1.21 ms against 1.56)."""


COARSE_TABLE_PER_ELEMENT = 256
"""A coarse table only where the exact one holds at least this many entries per element
of the longest sequence (lo over the least amount): the search on a coarse table
settles each element of the best sequence and weighs every successor of each, where
the exact table's enumeration just walks down it. Two elements of 20 and 21 quanta
filling 20,000 exactly (1,000 deep, a table of 40,002 entries): 3.7 ms on a coarse
table against 1.6 ms on the exact one; the 100 m street front (25 deep, 37,074
entries): 0.7 against 1.2 ms."""


def coarse_factor(cp: Compiled, i: int) -> int:
    """How many quanta of resource i one level of its coarse table spans: at most half
    the least positive amount an element consumes (so an element's amount, rounded up
    to whole levels, grows by under half), about lo / :data:`COARSE_LEVELS`; 1 (the
    exact table) below :data:`MIN_COARSE_FACTOR` (:data:`MIN_COARSE_FACTOR_SEVERAL`
    with several resources), for a resource with no lower bound to reach, and for
    sequences long against the table (:data:`COARSE_TABLE_PER_ELEMENT`)."""
    r = cp.r[:, i]
    pos = r[r > 0]
    if not len(pos) or cp.lo[i] <= 0:
        return 1
    least, lo = int(pos.min()), int(cp.lo[i])
    if (lo // least) * COARSE_TABLE_PER_ELEMENT > (int(cp.cap[i]) + 1) * cp.n:
        return 1
    s = min(least // 2, -(-lo // COARSE_LEVELS))
    return s if s >= (MIN_COARSE_FACTOR if cp.R == 1 else MIN_COARSE_FACTOR_SEVERAL) else 1


def coarse_cost_to_go(cp: Compiled, i: int, s: int) -> np.ndarray:
    """A consistent lower bound on resource i's relaxed cost to go, h[c, e] for c =
    0..cap_i, from a table s times smaller: the relaxation that knows the amount
    consumed only to the level of s quanta, floor(c / s).

    An element consuming r moves a sequence from c to c + r, so from level floor(c / s)
    to floor(c / s) + floor(r / s) or one level more (floor((c + r) / s) is one of
    the two, whatever c's remainder), and a sequence that ends within [lo_i, cap_i]
    ends on a level within [floor(lo_i / s), floor(cap_i / s)]. Every completion of
    node (e, c) in the real problem is therefore a completion of level floor(c / s) in
    this relaxation, with either step allowed at each element, for the same cost: the
    table, read at floor(c / s), bounds the real cost to go from below. Consistent, as
    A* needs: h(e, c) <= w(e, f) + h(f, c + r_f), because the relaxation's Bellman
    equation takes the cheaper of f's two steps and the real one is one of them. What
    it gives up is the exact fit (up to s - 1 quanta either way), for a backward
    program over cap_i / s levels instead of cap_i."""
    r = cp.r[:, i]
    lo, cap = int(cp.lo[i]), int(cp.cap[i])
    g = coarse_to_go(r // s, -(-r // s), max(lo, 0) // s, cap // s, cp.back, cp.pred_ptr,
                     cp.pred_elem, cp.pred_w)
    return g[np.arange(cap + 1) // s]


def _no_ranges() -> np.ndarray:
    return np.zeros(0, dtype=np.int64)


@dataclass(frozen=True)
class Bounds:
    """Cost-to-go tables of one-resource relaxations, flat: table t holds resource
    ``res[t]``, value for (c, e) at ``table[base[t] + c * n + e]``.

    Range tables (:func:`range_tables`), flat the same way: table t gives, for a node
    (e, c) of resource ``rlevel[t]``'s relaxation, the least (``rmin``) and the most
    (``rmax``) of resource ``rother[t]`` any completion consumes; a label whose other
    resource can no longer land inside its interval is dropped."""

    res: np.ndarray    # int64 [T]  which constrained resource each table relaxes to
    base: np.ndarray   # int64 [T]  where each table starts in ``table``
    table: np.ndarray  # float64
    exact: bool        # the only resource is kept: the values are the exact cost-to-go
    coarse: bool = False   # some table is a coarse one (:func:`coarse_cost_to_go`)
    rlevel: np.ndarray = field(default_factory=_no_ranges)   # int64 [U]
    rother: np.ndarray = field(default_factory=_no_ranges)   # int64 [U]
    rbase: np.ndarray = field(default_factory=_no_ranges)    # int64 [U]
    rmin: np.ndarray = field(default_factory=lambda: np.zeros(0))  # float64
    rmax: np.ndarray = field(default_factory=lambda: np.zeros(0))  # float64
    # pair tables (citysynth.solver.pair_bounds), flat the same way: table u bounds node
    # (e, c) by ptab[pbase[u] + (c[pl[u]] * (pq[u] + 1) + c[pj[u]] // ps[u]) * n + e]
    pl: np.ndarray = field(default_factory=_no_ranges)      # int64 [P] level resource
    pj: np.ndarray = field(default_factory=_no_ranges)      # int64 [P] the other
    ps: np.ndarray = field(default_factory=_no_ranges)      # int64 [P] its step
    pq: np.ndarray = field(default_factory=_no_ranges)      # int64 [P] its top level
    pbase: np.ndarray = field(default_factory=_no_ranges)   # int64 [P]
    ptab: np.ndarray = field(default_factory=lambda: np.zeros(0))  # float64

    @property
    def count(self) -> int:
        return len(self.res)

    @property
    def nbytes(self) -> int:
        return int(self.table.nbytes + self.rmin.nbytes + self.rmax.nbytes
                   + self.ptab.nbytes)

    def kernel_tables(self) -> tuple:
        """The range and pair tables as the search kernels take them (one tuple)."""
        return (self.rlevel, self.rother, self.rbase, self.rmin, self.rmax,
                self.pl, self.pj, self.ps, self.pq, self.pbase, self.ptab)


def table_bytes(cp: Compiled, i: int) -> int:
    """Memory of resource i's table."""
    return 8 * cp.n * (int(cp.cap[i]) + 1)


def relaxation_bounds(cp: Compiled, budget_bytes: int, coarse: bool = False) -> Bounds:
    """Tables for every constrained resource whose table fits ``budget_bytes`` (the
    narrowest first; a resource that does not fit is simply not used for bounding),
    then, with the rest of the budget, the range tables of the other resources over
    the narrowest one's levels. With one resource the single table is exact, unless
    ``coarse``: then a resource with a wide lower bound and large amounts gets the
    coarse table (:func:`coarse_cost_to_go`), a fraction of the work, which guides a
    search for the best sequence nearly as well."""
    order = sorted(range(cp.R), key=lambda i: (int(cp.cap[i]), i))
    res: list[int] = []
    parts: list[np.ndarray] = []
    used = 0
    any_coarse = False
    for i in order:
        need = table_bytes(cp, i)
        if used + need > budget_bytes:
            continue
        s = coarse_factor(cp, i) if coarse else 1
        if s > 1:
            h = coarse_cost_to_go(cp, i, s)
            any_coarse = True
        else:
            h = relaxed_cost_to_go(cp.r[:, i].copy(), int(cp.lo[i]), int(cp.cap[i]),
                                   cp.back, cp.pred_ptr, cp.pred_elem, cp.pred_w)
        res.append(i)
        parts.append(h.ravel())
        used += need
    base = np.zeros(len(parts), dtype=np.int64)
    if parts:
        base[1:] = np.cumsum([len(p) for p in parts])[:-1]
    table = np.concatenate(parts) if parts else np.zeros(0)
    ranges = range_tables(cp, res[0], budget_bytes - used) if res and cp.R > 1 else {}
    return Bounds(np.array(res, dtype=np.int64), base, table,
                  cp.R == 1 and len(res) == 1 and not any_coarse, any_coarse, **ranges)


def zero_chains(cp: Compiled, level: int) -> bool:
    """May an element consuming none of resource ``level`` follow another such element
    (on cp's successor lists)? Only then can the relaxation over ``level`` stay on one
    level for more than one step."""
    zero = cp.r[:, level] == 0
    rows = np.repeat(np.arange(cp.n), np.diff(cp.succ_ptr))
    return bool((zero[rows] & zero[cp.succ_elem]).any())


def most_is_exact(cp: Compiled, level: int, j: int) -> bool:
    """Is the backward program of resource ``level``'s relaxation over -j (each
    transition weighing minus what its element consumes of j) the exact most of j?

    Yes when no element consuming none of ``level`` consumes some of j (every
    within-level weight is zero, Dijkstra's condition holds), or when no such element
    may follow another (:func:`zero_chains`): then a level's zero-consumption element
    has only successors on higher levels, so its value is final before the level's
    Dijkstra starts, each is popped once, and the predecessors it updates consume some
    of ``level`` and are never pushed: the within-level step is exact whatever the
    weights' sign. Otherwise such elements may repeat on one level and the most may be
    unbounded."""
    zero = cp.r[:, level] == 0
    return not np.any(zero & (cp.r[:, j] > 0)) or not zero_chains(cp, level)


def most_to_go(cp: Compiled, level: int, j: int) -> np.ndarray | None:
    """m[c, e]: the most of resource j that a completion of node (e, c) of resource
    ``level``'s relaxation consumes (-inf when none completes), or None when that is
    not known to be bounded (:func:`most_is_exact`)."""
    if not most_is_exact(cp, level, j):
        return None
    w = np.repeat(cp.r[:, j].astype(np.float64), np.diff(cp.pred_ptr))
    return -relaxed_cost_to_go(cp.r[:, level].copy(), int(cp.lo[level]),
                               int(cp.cap[level]), cp.back, cp.pred_ptr, cp.pred_elem, -w)


def range_tables(cp: Compiled, level: int, budget_bytes: int) -> dict[str, np.ndarray]:
    """For every other constrained resource j (as many as ``budget_bytes`` holds), the
    least and the most of j that a completion of node (e, c) of resource ``level``'s
    relaxation consumes: the relaxation's backward program again, each transition
    weighing what its element consumes of j (negated for the most).

    Why: the cost bounds only see one resource at a time. When two are tied together
    (a tower's height and its floor area: every floor brings both) a search can spend
    its whole budget on prefixes that meet each interval alone but can never meet both
    (300 m of floors always exceed the floor area of a 900 m² lot at FAR 4), and on an
    infeasible problem it never ends. With these tables such a prefix is dropped the
    moment it is made, and such a problem is answered at the root. Exact: a completion
    of the real problem is one of the relaxation's, so its consumption of j lies
    between the two values; only labels no feasible sequence passes through go.

    The most is the backward program over -j when it is exact there
    (:func:`most_is_exact`), else left unbounded (+inf, no pruning): a tower's roof
    has a height but no floor area, yet no roof follows a roof, so over height levels
    the most floor area is exact and labels that can no longer reach the floor-area
    minimum go too."""
    n, lo, cap = cp.n, int(cp.lo[level]), int(cp.cap[level])
    rl = cp.r[:, level].copy()
    counts = np.diff(cp.pred_ptr)
    size = (cap + 1) * n
    others = [j for j in range(cp.R) if j != level][: max(budget_bytes // (16 * size), 0)]
    if not others:
        return {}
    mins, maxs = [], []
    for j in others:
        rj = cp.r[:, j].astype(np.float64)
        w = np.repeat(rj, counts)
        mins.append(relaxed_cost_to_go(rl, lo, cap, cp.back, cp.pred_ptr, cp.pred_elem,
                                       w).ravel())
        most = most_to_go(cp, level, j)
        maxs.append(np.full(size, np.inf) if most is None else most.ravel())
    return {"rlevel": np.full(len(others), level, dtype=np.int64),
            "rother": np.array(others, dtype=np.int64),
            "rbase": np.arange(len(others), dtype=np.int64) * size,
            "rmin": np.concatenate(mins), "rmax": np.concatenate(maxs)}


@njit(cache=True, inline="always")
def pair_after(c, f, r, n, rng):
    """The pair tables' bound of node (f, c + r(f)) (0 without them; ``rng`` is
    :meth:`Bounds.kernel_tables`). Hot loops write this out too."""
    pl, pj, ps, pq, pbase, ptab = rng[5], rng[6], rng[7], rng[8], rng[9], rng[10]
    best = 0.0
    for u in range(len(pl)):
        i, j = pl[u], pj[u]
        v = ptab[pbase[u] + ((c[i] + r[f, i]) * (pq[u] + 1) + (c[j] + r[f, j]) // ps[u])
                 * n + f]
        if v > best:
            best = v
    return best


@njit(cache=True, inline="always")
def bound_after(c, f, r, n, bres, bbase, btab):
    """The bound of node (f, c + r(f)), element f appended to a sequence that has
    consumed c: the maximum over the tables of h_i(f, c_i + r_i(f)) (0 without
    tables, inf when some relaxation cannot complete). Hot loops write this out
    instead of calling it (see solver.astar._children)."""
    best = 0.0
    for t in range(len(bres)):
        i = bres[t]
        v = btab[bbase[t] + (c[i] + r[f, i]) * n + f]
        if v > best:
            best = v
    return best
