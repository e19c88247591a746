"""Kernels of the shared stage graphs (:mod:`citysynth.solver.structures.stage_graphs`):
the k best fillings of many stage queries, enumerated backwards on one forward graph.

A stage graph is the intermediate graph of :mod:`citysynth.solver.graph` grown *forward
only* from one start key element: element 0 is the start key's leg, the others are the
fillers, and ``g[row, e]`` is the exact cost of the cheapest prefix "start ... e"
consuming the row's state. It does not depend on where the stage ends, so every
stage with the same fillers and the same start element shares it. A *query* (one
stage, one end key element, one share of the structure-wide resources) is a virtual
sink: its in-edges come from every node (c, e) whose state c plus the end key's leg
is admissible for that stage, weighted by the transition into the end key.

The k best paths into a query are found by the lazy enumeration of
:mod:`citysynth.solver.kbest` run backwards: a node's choices are its predecessors (the
previous element at state c - r(e)), each ranked by its exact g, and the start node
ends every path. Node path lists are shared by all queries of the graph, so the
hundreds of queries of a block outline expand each prefix once.

Caching caveat: numba caches :func:`citysynth.solver.kbest.kbest_from`'s specialisation
for :class:`StageGraph` with kbest.py and does not see that it depends on the choice
function here; after editing :func:`_stage_choices`, touch solver/kbest.py (or
clear solver/__pycache__) so it is compiled again.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, types
from numba.extending import overload

from citysynth.solver._table import box_next, hash_find
from citysynth.solver.kbest import TERM, graph_choices, kbest_from

_X, _PTR, _KEY = 0, 1, 2


class StageGraph(NamedTuple):
    """What the backwards enumeration reads. Node id = row * n + element; query q
    is the vertex qbase + q."""

    qbase: int
    n: int
    W: np.ndarray          # float64 [n, n]  W[f, e] = delta(e, f) + omega(f), inf if not e->f
    g: np.ndarray          # float64 [rows, n] cost of the best prefix ending at the node
    row_state: np.ndarray  # int64 [rows]
    off: np.ndarray        # int64 [n]  state offset of each element
    cap: np.ndarray        # int64 [R]
    stride: np.ndarray     # int64 [R]
    dense: bool
    keys: np.ndarray       # row hash table (hash mode)
    vals: np.ndarray
    shift: int
    qlo: np.ndarray        # int64 [Q, R] admissible end states of each query (before
    qhi: np.ndarray        # int64 [Q, R]   the end key's leg), inside the box
    wq: np.ndarray         # float64 [B, n] weight of the edge e -> end element b, inf
    qw: np.ndarray         # int64 [Q]      if none; query q ends on element qw[q]


@njit(cache=True)
def _row(G, s):
    return s if G.dense else hash_find(G.keys, G.vals, G.shift, s)


@njit(cache=True)
def _stage_choices(v, G, c, out_f, out_i):
    """Choices of vertex v going backwards: a query's admissible last nodes (tie key
    state * n + element), a node's predecessors (tie key: the element), or TERM for
    the start node (element 0)."""
    n = G.n
    m = 0
    if v >= G.qbase:
        q = v - G.qbase
        R = len(G.cap)
        for i in range(R):
            c[i] = G.qlo[q, i]
        while True:  # every state of the query's box
            s = 0
            for i in range(R):
                s += c[i] * G.stride[i]
            row = _row(G, s)
            if row >= 0:
                for e in range(n):
                    w = G.wq[G.qw[q], e]
                    if w < np.inf and G.g[row, e] < np.inf:
                        out_f[m, 0] = G.g[row, e] + w
                        out_f[m, 1] = w
                        out_i[m, _X] = row * n + e
                        out_i[m, _PTR] = -1
                        out_i[m, _KEY] = s * n + e
                        m += 1
            if not box_next(c, G.qlo[q], G.qhi[q]):
                break
        return m
    row = v // n
    e = v % n
    if e == 0:
        out_f[0, 0] = 0.0
        out_f[0, 1] = 0.0
        out_i[0, _X] = TERM
        out_i[0, _PTR] = -1
        out_i[0, _KEY] = -1
        return 1
    rp = _row(G, G.row_state[row] - G.off[e])
    for p in range(n):
        w = G.W[e, p]
        if w < np.inf and G.g[rp, p] < np.inf:
            out_f[m, 0] = G.g[rp, p] + w
            out_f[m, 1] = w
            out_i[m, _X] = rp * n + p
            out_i[m, _PTR] = -1
            out_i[m, _KEY] = p
            m += 1
    return m


@overload(graph_choices)
def _graph_choices_stage(v, G, c, out_f, out_i):
    # numba's NamedTuple types carry the Python class (not in its annotations)
    if isinstance(G, types.BaseNamedTuple) and getattr(G, "instance_class", None) is StageGraph:
        return lambda v, G, c, out_f, out_i: _stage_choices(v, G, c, out_f, out_i)
    return None


@njit(cache=True)
def _query_states(qlo, qhi):
    """The largest number of states in one query's box."""
    most = 0
    for q in range(qlo.shape[0]):
        m = 1
        for i in range(qlo.shape[1]):
            m *= qhi[q, i] - qlo[q, i] + 1
        most = max(most, m)
    return most


@njit(cache=True)
def _stage_kbest(G, K, depth):
    """The K best fillings of every query of G (see :func:`_stage_kbest_of`)."""
    return _stage_kbest_of(G, np.arange(G.qlo.shape[0]), K, depth)


@njit(cache=True)
def _query_best(G, q, c):
    """The least of query q's choices as :func:`_stage_choices` lists them, by (cost,
    tie key): (cost, key, row, element, the least cost of every other choice); key -1
    when it has none, the last inf when it has one at most (:func:`_second_cost`)."""
    n = G.n
    R = len(G.cap)
    for i in range(R):
        c[i] = G.qlo[q, i]
    bc = np.inf
    bkey = -1
    brow = -1
    be = -1
    other = np.inf
    while True:  # every state of the query's box
        s = 0
        for i in range(R):
            s += c[i] * G.stride[i]
        row = _row(G, s)
        if row >= 0:
            for e in range(n):
                w = G.wq[G.qw[q], e]
                if w < np.inf and G.g[row, e] < np.inf:
                    cost = G.g[row, e] + w
                    key = s * n + e
                    if bkey < 0 or cost < bc or (cost == bc and key < bkey):
                        other = min(other, bc)
                        bc, bkey, brow, be = cost, key, row, e
                    else:
                        other = min(other, cost)
        if not box_next(c, G.qlo[q], G.qhi[q]):
            break
    return bc, bkey, brow, be, other


@njit(cache=True)
def _best_fill(G, q):
    """The fillers (front to back) of the best filling of query q, as
    :func:`_stage_kbest_of` with K = 1 finds it (each step back takes the least
    predecessor: cost, then element), and whether its front-to-back sum is the
    query's cost bit for bit."""
    bc, bkey, row, e, _other = _query_best(G, q, np.zeros(len(G.cap), dtype=np.int64))
    back = np.empty(max(G.n, 8), dtype=np.int64)
    m = 0
    while e != 0:
        if m == len(back):
            back = np.concatenate((back, np.empty(len(back), dtype=np.int64)))
        back[m] = e
        m += 1
        rp = _row(G, G.row_state[row] - G.off[e])
        bp = -1
        pc = np.inf
        for p in range(G.n):
            w = G.W[e, p]
            if w < np.inf and G.g[rp, p] < np.inf:
                cost = G.g[rp, p] + w
                if bp < 0 or cost < pc:
                    bp, pc = p, cost
        row, e = rp, bp
    fill = back[:m][::-1].copy()
    prev = 0
    cost = 0.0
    for f in fill:
        cost += G.W[f, prev]
        prev = f
    return fill, cost + G.wq[G.qw[q], prev] == bc


@njit(cache=True)
def _second_cost(G, q):
    """The cost of the second best filling of query q (inf: it has one at most), from
    the forward costs along its best path alone: a lower bound on entry 1 of its stage
    list that costs one walk back, where finding the path itself by the enumeration
    (:func:`_stage_kbest_of`, K = 2) costs several times more; the lazy program of
    :mod:`.chain_kbest` asks the graph for the path only once the bound is the least
    of a node's candidates, which it mostly never is.

    Any path into a node v other than its best one either comes in by another
    predecessor (at best that predecessor's g plus the edge) or by the best
    predecessor p* and another path into it: g2(v) = min(least way in other than
    p*, g2(p*) + the edge from p*). Along the best path, found as
    :func:`_best_fill` finds it, from the start (one path, g2 = inf) to the query.
    Each term is a path's front-to-back sum (g is, the forward pass adds the same
    way) and rounding is monotone, so this is the least such sum over every path but
    the best: entry 1's cost itself when the enumeration's sums are the front-to-back
    ones (:func:`sorted_paths`), and never more than it."""
    _bc, bkey, row, e, other = _query_best(G, q, np.zeros(len(G.cap), dtype=np.int64))
    if bkey < 0:
        return np.inf
    last = e
    # back along the best path: at each node the least way in but the best, and the
    # edge in from the best
    alt = np.empty(max(G.n, 8))
    into = np.empty(max(G.n, 8))
    m = 0
    while e != 0:
        if m == len(alt):
            alt = np.concatenate((alt, np.empty(len(alt))))
            into = np.concatenate((into, np.empty(len(into))))
        rp = _row(G, G.row_state[row] - G.off[e])
        bp = -1
        pc = np.inf
        o = np.inf
        for p in range(G.n):
            w = G.W[e, p]
            if w < np.inf and G.g[rp, p] < np.inf:
                cost = G.g[rp, p] + w
                if bp < 0 or cost < pc:
                    o = min(o, pc)
                    bp, pc = p, cost
                else:
                    o = min(o, cost)
        alt[m] = o
        into[m] = G.W[e, bp]
        m += 1
        row, e = rp, bp
    g2 = np.inf   # the start: one (empty) path
    for t in range(m - 1, -1, -1):
        g2 = min(alt[t], g2 + into[t])
    return min(other, g2 + G.wq[G.qw[q], last])


@njit(cache=True)
def _stage_best_costs(G):
    """The cost of the best filling of every query of G (inf: none), as
    :func:`_stage_kbest_of` with K = 1 finds it: the least of the query's choices,
    each the exact g of a node plus the edge into the end key. Without its heaps,
    path lists or paths: a block with a per-block door count asks 6,480 queries and
    its structures read a few dozen paths back (:func:`first_lists`)."""
    return _best_costs(G.g, G.wq, G.qw, G.qlo, G.qhi, G.stride, G.dense, G.keys, G.vals,
                       G.shift)


@njit(cache=True)
def _best_costs(g, wq, qw, qlo, qhi, stride, dense, keys, vals, shift):
    """:func:`_stage_best_costs` on G's arrays, read from the named tuple once, and by
    cost alone: 7x faster than :func:`_query_best` per query (6,480 queries of a block
    with a per-block door count, 0.75 to 0.11 ms). The same minimum: the states of a
    box come in increasing order (the counter's first digit has the smallest stride),
    so keys (state * n + element) do too and the first strict minimum is the least
    (cost, key); a cost with an inf term is inf and never below ``bc``."""
    Q, n = len(qw), wq.shape[1]
    R = qlo.shape[1]
    c = np.zeros(R, dtype=np.int64)
    out = np.empty(Q)
    for q in range(Q):
        for i in range(R):
            c[i] = qlo[q, i]
        bc = np.inf
        while True:  # every state of the query's box
            s = 0
            for i in range(R):
                s += c[i] * stride[i]
            row = s if dense else hash_find(keys, vals, shift, s)
            if row >= 0:
                for e in range(n):
                    cost = g[row, e] + wq[qw[q], e]
                    if cost < bc:
                        bc = cost
            if not box_next(c, qlo[q], qhi[q]):
                break
        out[q] = bc
    return out


@njit(cache=True)
def _stage_kbest_of(G, qs, K, depth):
    """The K best fillings of the queries ``qs`` of G. Returns (costs, offs, fill,
    first, same): path p of the i-th query (first[i] <= p < first[i + 1]) has the
    fillers fill[offs[p]:offs[p + 1]] front to back and the cost costs[p], summed
    front to back (start -> first filler -> ... -> end key) the way one-stage
    solutions are, so a stage costs the same bits whichever solver found it. The
    paths of a query come in the enumeration's order (ascending by its own sums,
    ties by element): a later call with a larger K extends the same sequence.
    ``same``: every cost equals the enumeration's own sum, bit for bit (see
    :func:`sorted_paths`)."""
    Q = len(qs)
    starts = qs + G.qbase
    ks, offs, seq, first, _touched = kbest_from(
        G, starts, K, G.n, len(G.cap), depth, _query_states(G.qlo, G.qhi) * G.n)
    npath = len(offs) - 1
    costs = np.empty(npath)
    fill = np.empty(len(seq), dtype=np.int64)
    for i in range(Q):
        q = qs[i]
        for p in range(first[i], first[i + 1]):
            a, b = offs[p], offs[p + 1]  # seq[a:b] = last filler ... first filler, start
            prev = 0
            cost = 0.0
            for t in range(b - a - 1):
                f = seq[b - 2 - t]
                fill[a - p + t] = f
                cost += G.W[f, prev]
                prev = f
            costs[p] = cost + G.wq[G.qw[q], prev]
    # drop the start element from every path: path p loses p elements before it
    for p in range(npath + 1):
        offs[p] -= p
    same = True
    for p in range(npath):
        same = same and costs[p] == ks[p]
    return costs, offs, fill[:len(seq) - npath], first, same


TRUST_EPS = 1e-9   # relative: far above the rounding between two ways of summing
BEST_BY_ARGMIN = True   # one-path lists from costs alone (tests compare with the kernel)

StageEntry = tuple[float, tuple[int, int]]   # (cost, (paths index, path index))


class Growing(list[StageEntry]):
    """A stage list that more paths may follow: its ``final`` leading entries keep
    their places whatever is found later; the graph (``gi``), the query (``q``) and
    how many paths were asked (``K``) say where to find more. A complete list is a
    plain list."""

    __slots__ = ("final", "gi", "q", "K")
    final: int
    gi: int
    q: int
    K: int


def first_lists(G: StageGraph, K: int, k: int, depth: int, gid: int, gi: int
                ) -> tuple[list[list[StageEntry] | None], tuple[np.ndarray, np.ndarray]]:
    """The stage list of every query of graph gi, with up to K paths (at most k are
    wanted), by the lazy enumeration, and the paths (offs, fill) the entries (cost,
    (gid, path)) point into. One-path lists need no enumeration: see
    :func:`one_path`."""
    costs, offs, fill, first, same = _stage_kbest(G, K, depth)
    return query_lists(costs.tolist(), first.tolist(), K, k, same, gid, gi), (offs, fill)


def one_path(c: float, gid: int, q: int, k: int, gi: int) -> list[StageEntry]:
    """The one-path list of query q of graph gi from its best cost alone
    (:func:`_stage_best_costs`, when BEST_BY_ARGMIN): its entry (c, (gid, q)) points at
    the query, whose path the reader finds when it needs it (``StageGraphs.filling``,
    which checks that its front-to-back sum is the cost: it always is, see
    :func:`sorted_paths`). Complete at k = 1, else :class:`Growing` (its one entry
    final)."""
    if k == 1:
        return [(c, (gid, q))]
    ls = Growing([(c, (gid, q))])
    ls.final, ls.gi, ls.q, ls.K = 1, gi, q, 1
    return ls


def query_lists(costs: list[float], first: list[int], K: int, k: int, same: bool,
                gid: int, gi: int) -> list[list[StageEntry] | None]:
    """The stage list of every query of graph gi (None for a query with no path), as
    :func:`sorted_paths` makes each; with one path each, complete and in order (k = 1),
    in one loop (a block with a per-block door count has 6,480 queries)."""
    if same and K == 1 and k == 1:
        out: list[list[StageEntry] | None] = []
        for q in range(len(first) - 1):
            p = first[q]
            out.append([(costs[p], (gid, p))] if p < first[q + 1] else None)
        return out
    return [sorted_paths(costs, first[q], first[q + 1], K, k, same, gid, gi, q)
            if first[q] < first[q + 1] else None for q in range(len(first) - 1)]


def sorted_paths(costs: list[float], lo: int, hi: int, K: int, k: int, same: bool,
                 gid: int, gi: int, q: int) -> list[StageEntry]:
    """Paths lo..hi-1 of query q of graph gi (found with a limit of K paths, at most
    k wanted) as a stage list (cost, (gid, path)) sorted by their front-to-back sums
    (stable, as the lists always were): a plain list when it is complete, else a
    :class:`Growing` one that says how many of its entries lead the sorted list of all
    its k first paths whatever comes after.

    The enumeration ranks paths by its own sums: a path's cost is an edge weight
    plus the cost of a shorter path (or the exact g of the forward pass, made of the
    same additions), which are the front-to-back sums added in the same order. So
    the two agree bit for bit (``same``: they did on every path found; 1.5 million
    paths of blocks and generated structures checked), the sort keeps the order and
    every path found stays in place when more are found. Should they ever differ,
    a path not yet found ranks after the K-th found one, so its front-to-back sum is
    at least the K-th one's less rounding: only paths cheaper than that by a margin
    are final then."""
    complete = hi - lo < K or K >= k
    if same and complete:   # already in order: a stable sort would leave it as it is
        return [(costs[p], (gid, p)) for p in range(lo, hi)]
    ls = Growing((costs[p], (gid, p)) for p in range(lo, hi))
    if not same:
        ls.sort(key=lambda t: t[0])
        if complete:
            return list(ls)
    n = len(ls)
    if not same:
        last = costs[hi - 1]
        bound = last - TRUST_EPS * max(1.0, abs(last))
        n = 0
        while n < len(ls) and ls[n][0] <= bound:
            n += 1
    ls.final, ls.gi, ls.q, ls.K = n, gi, q, K
    return ls
