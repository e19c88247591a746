"""Exact k best source→sink paths on the pruned intermediate graph.

The lazy recursive enumeration of Jiménez & Marzal ("Computing the K shortest paths:
a new algorithm and an experimental comparison", WAE 1999), which is the graph case
of Huang & Chiang's lazy k-best Algorithm 3 ("Better k-best parsing", 2005), run on
suffixes: every node v keeps the list P_v of its best paths to the sink found so
far, P_v[0] being the one through the exact cost-to-go h. The next path of v comes
from a heap of candidates "go to successor x, then take P_x[j]"; popping (x, j)
adds (x, j+1), which may first ask x for its own next path (an explicit stack
replaces the recursion). Only nodes on the paths actually enumerated are touched,
so k = 100 costs little more than k = 1 once the graph is built.

A path is stored as one entry: (cost, edge weight, successor node x, the entry of
P_x it continues with, next element); the entries of one node are chained in order,
so "P_x[j+1]" is one pointer away and nothing is ever copied.

Ties are broken by the element index of the next element (ending the sequence ranks
first), so sequences of equal cost come out in lexicographic order of element
indices: deterministic, and independent of how the graph was grown.

The lazy core (:func:`kbest_from`) sees a graph only through
:func:`graph_choices`, which numba resolves at compile time from the type of the
graph tuple ``G``: a plain tuple is the intermediate graph (:func:`k_best`); other
graphs register their own overload for a NamedTuple class of theirs (the structure
solver's stage graphs, :mod:`citysynth.solver.structures.stage_kbest`, run this
scheme backwards from many sinks). One core, no run-time dispatch.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from citysynth.solver._table import (
    admissible,
    decode,
    fits,
    grow_i64,
    hash_find,
    hash_put,
    table_rehash,
)

TERM = -1
_FIRST, _LAST, _LEN, _HBASE, _HSIZE = 0, 1, 2, 3, 4   # slot columns
_X, _PTR, _KEY, _NEXT = 0, 1, 2, 3                      # entry int columns (ef: cost, w)
_EXHAUSTED = -1


@njit(cache=True)
def _choices(v, src, n, r, lo, cap, stride, off, succ_ptr, succ_elem, succ_w, front, back,
             omega, H, row_state, dense, keys, vals, shift, c, out_f, out_i):
    """Write the out-choices of node v (``src`` is the virtual source) as rows
    (cost, w) / (node, -1, key); return their count. Node id = row * n + element."""
    m = 0
    if v == src:
        c[:] = 0
        for e in range(n):
            if front[e] and fits(c, r, e, cap):
                s = off[e]
                row = s if dense else hash_find(keys, vals, shift, s)
                if row >= 0 and H[row, e] < np.inf:
                    out_f[m, 0] = omega[e] + H[row, e]
                    out_f[m, 1] = omega[e]
                    out_i[m, _X] = row * n + e
                    out_i[m, _PTR] = -1
                    out_i[m, _KEY] = e
                    m += 1
        return m
    row = v // n
    e = v % n
    s = row_state[row]
    decode(s, cap, stride, c)
    if back[e] and admissible(c, lo):
        out_f[m, 0] = 0.0
        out_f[m, 1] = 0.0
        out_i[m, _X] = TERM
        out_i[m, _PTR] = -1
        out_i[m, _KEY] = -1
        m += 1
    for j in range(succ_ptr[e], succ_ptr[e + 1]):
        f = succ_elem[j]
        if not fits(c, r, f, cap):
            continue
        s2 = s + off[f]
        row2 = s2 if dense else hash_find(keys, vals, shift, s2)
        if row2 >= 0 and H[row2, f] < np.inf:
            out_f[m, 0] = succ_w[j] + H[row2, f]
            out_f[m, 1] = succ_w[j]
            out_i[m, _X] = row2 * n + f
            out_i[m, _PTR] = -1
            out_i[m, _KEY] = f
            m += 1
    return m


def graph_choices(v, G, c, out_f, out_i):
    """Write the out-choices of vertex v of graph G into rows of out_f (cost, edge
    weight) and out_i (next node or TERM, -1, tie key); return their count. Kernels
    only: every graph kind registers an ``@overload`` for its own type of G."""
    raise NotImplementedError("graph_choices is resolved inside numba kernels")


@overload(graph_choices)
def _graph_choices_intermediate(v, G, c, out_f, out_i):
    if not isinstance(G, types.BaseTuple) or isinstance(G, types.BaseNamedTuple):
        return None

    def impl(v, G, c, out_f, out_i):
        (src, n, r, lo, cap, stride, off, succ_ptr, succ_elem, succ_w, front, back, omega,
         H, row_state, dense, keys, vals, shift) = G
        return _choices(v, src, n, r, lo, cap, stride, off, succ_ptr, succ_elem, succ_w,
                        front, back, omega, H, row_state, dense, keys, vals, shift, c,
                        out_f, out_i)
    return impl


@njit(cache=True, inline="always")
def _lt(c1, k1, c2, k2):
    """Candidate order: cost, then next element (a node's candidates always lead to
    distinct successors, so this is a total order)."""
    return c1 < c2 or (c1 == c2 and k1 < k2)


@njit(cache=True, inline="always")
def _move(qf, qi, dst, sf, si, src):
    """Copy candidate row src of (sf, si) into row dst of (qf, qi)."""
    qf[dst, 0] = sf[src, 0]
    qf[dst, 1] = sf[src, 1]
    for t in range(4):
        qi[dst, t] = si[src, t]


@njit(cache=True)
def _sift_down(qf, qi, hb, hs, pos):
    cf0, cf1 = qf[hb + pos, 0], qf[hb + pos, 1]
    c0, c1, c2, c3 = qi[hb + pos, 0], qi[hb + pos, 1], qi[hb + pos, 2], qi[hb + pos, 3]
    while True:
        ch = 2 * pos + 1
        if ch >= hs:
            break
        if ch + 1 < hs and _lt(qf[hb + ch + 1, 0], qi[hb + ch + 1, _KEY],
                               qf[hb + ch, 0], qi[hb + ch, _KEY]):
            ch += 1
        if _lt(qf[hb + ch, 0], qi[hb + ch, _KEY], cf0, c2):
            _move(qf, qi, hb + pos, qf, qi, hb + ch)
            pos = ch
        else:
            break
    qf[hb + pos, 0] = cf0
    qf[hb + pos, 1] = cf1
    qi[hb + pos, 0] = c0
    qi[hb + pos, 1] = c1
    qi[hb + pos, 2] = c2
    qi[hb + pos, 3] = c3


@njit(cache=True)
def _heap_push(qf, qi, hb, hs, rf, ri, row):
    pos = hs
    while pos > 0:
        par = (pos - 1) // 2
        if _lt(rf[row, 0], ri[row, _KEY], qf[hb + par, 0], qi[hb + par, _KEY]):
            _move(qf, qi, hb + pos, qf, qi, hb + par)
            pos = par
        else:
            break
    _move(qf, qi, hb + pos, rf, ri, row)
    return hs + 1


@njit(cache=True)
def _heap_pop(qf, qi, hb, hs, outf, outi):
    """Move the minimum into row 0 of outf/outi; returns the new size."""
    _move(outf, outi, 0, qf, qi, hb)
    hs -= 1
    if hs > 0:
        _move(qf, qi, hb, qf, qi, hb + hs)
        _sift_down(qf, qi, hb, hs, 0)
    return hs


@njit(cache=True)
def _slot(v, G, slots, ef, ei, qf, qi, cnt, skeys, svals, sshift, c):
    """The slot of node v, created with its first path (argmin of its choices) when
    new. Capacity is reserved by the caller; cnt = [slots, entries, heap rows]."""
    sl = hash_find(skeys, svals, sshift, v)
    if sl >= 0:
        return sl
    sl = cnt[0]
    cnt[0] += 1
    hash_put(skeys, svals, sshift, v, sl)
    # the choices go straight into this slot's heap area: the first path is their
    # minimum, and the heap is built from the rest only if a second path is asked
    hb = cnt[2]
    m = graph_choices(v, G, c, qf[hb:], qi[hb:])
    cnt[2] += m
    slots[sl, _HBASE] = hb
    slots[sl, _HSIZE] = -2 - m  # not yet a heap: -2 - (number of stored choices)
    best = -1
    for t in range(hb, hb + m):
        if best < 0 or _lt(qf[t, 0], qi[t, _KEY], qf[best, 0], qi[best, _KEY]):
            best = t
    if best < 0:
        slots[sl, _FIRST] = -1
        slots[sl, _LAST] = -1
        slots[sl, _LEN] = 0
        slots[sl, _HSIZE] = _EXHAUSTED
        return sl
    en = cnt[1]
    cnt[1] += 1
    ef[en] = qf[best]
    ei[en] = qi[best]
    ei[en, _NEXT] = -1
    slots[sl, _FIRST] = en
    slots[sl, _LAST] = en
    slots[sl, _LEN] = 1
    # move the chosen one to the end, outside the future heap
    last = hb + m - 1
    for q in range(2):
        tmp = qf[best, q]
        qf[best, q] = qf[last, q]
        qf[last, q] = tmp
    for q in range(4):
        tmp2 = qi[best, q]
        qi[best, q] = qi[last, q]
        qi[last, q] = tmp2
    return sl


@njit(cache=True)
def _next_path(start, G, slots, ef, ei, qf, qi, cnt, skeys, svals, sshift, stack, c,
               rowf, rowi):
    """Append the next path of vertex ``start`` (which has a slot) to its list, or
    mark it exhausted."""
    stack[0] = start
    sp = 1
    while sp > 0:
        v = stack[sp - 1]
        sl = hash_find(skeys, svals, sshift, v)  # v already has a slot
        last = slots[sl, _LAST]
        x = ei[last, _X]
        cur = -1
        if x != TERM:
            sx = hash_find(skeys, svals, sshift, x)
            if sx < 0:
                sx = _slot(x, G, slots, ef, ei, qf, qi, cnt, skeys, svals, sshift, c)
            cur = ei[last, _PTR]
            if cur < 0:
                cur = slots[sx, _FIRST]
            if ei[cur, _NEXT] < 0 and slots[sx, _HSIZE] != _EXHAUSTED:
                stack[sp] = x  # x must find its next path first
                sp += 1
                continue
        sp -= 1
        if slots[sl, _HSIZE] <= -2:
            # first use: heapify the stored choices but the one P_v[0] took
            hs = -2 - slots[sl, _HSIZE] - 1
            for pos in range(hs // 2 - 1, -1, -1):
                _sift_down(qf, qi, slots[sl, _HBASE], hs, pos)
            slots[sl, _HSIZE] = hs
        hb = slots[sl, _HBASE]
        hs = slots[sl, _HSIZE]
        if x != TERM:
            nxt = ei[cur, _NEXT]
            if nxt >= 0:
                rowf[2, 0] = ef[last, 1] + ef[nxt, 0]
                rowf[2, 1] = ef[last, 1]
                rowi[2, _X] = x
                rowi[2, _PTR] = nxt
                rowi[2, _KEY] = ei[last, _KEY]
                hs = _heap_push(qf, qi, hb, hs, rowf, rowi, 2)
        if hs == 0:
            slots[sl, _HSIZE] = _EXHAUSTED
            continue
        hs = _heap_pop(qf, qi, hb, hs, rowf, rowi)
        slots[sl, _HSIZE] = hs
        en = cnt[1]
        cnt[1] += 1
        ef[en] = rowf[0]
        ei[en] = rowi[0]
        ei[en, _NEXT] = -1
        ei[last, _NEXT] = en
        slots[sl, _LAST] = en
        slots[sl, _LEN] += 1


@njit(cache=True)
def _grow_rows(a, rows):
    b = np.empty((rows, a.shape[1]), dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


@njit(cache=True)
def kbest_from(G, starts, K, n, R, depth, start_choices):
    """The K best paths from each vertex in ``starts`` to TERM, in ascending cost.
    Every node's path list is shared between the starts, so a node that the paths of
    several starts pass through is expanded once.

    ``n`` elements (a node id is row * n + element), ``R`` resources (scratch for
    the choices), ``depth`` bounds the nodes on a path plus two, ``start_choices``
    the choices of a start vertex. Returns (costs, offs, seq, first, touched): path
    p has cost costs[p] and elements seq[offs[p]:offs[p + 1]]; start i owns paths
    first[i] to first[i + 1]."""
    c = np.zeros(R, dtype=np.int64)
    rowf = np.empty((3, 2))
    rowi = np.empty((3, 4), dtype=np.int64)
    stack = np.empty(depth, dtype=np.int64)
    cnt = np.zeros(3, dtype=np.int64)
    slots = np.empty((256, 5), dtype=np.int64)
    ef = np.empty((256, 2))
    ei = np.empty((256, 4), dtype=np.int64)
    qf = np.empty((256, 2))
    qi = np.empty((256, 4), dtype=np.int64)
    skeys = np.full(1024, -1, dtype=np.int64)
    svals = np.full(1024, -1, dtype=np.int32)
    sshift = 64 - 10
    heap_need = max(start_choices, n + 1) + depth * (n + 1)

    costs = np.empty(len(starts) * K)
    offs = np.zeros(len(starts) * K + 1, dtype=np.int64)
    seq = np.empty(max(K * depth, 16), dtype=np.int64)
    first = np.zeros(len(starts) + 1, dtype=np.int64)
    npath = 0
    sn = 0
    for si in range(len(starts)):
        start = starts[si]
        # phase 1: enumerate the start's paths; phase 2: read them out. Before every
        # step the pools get room for one step: at most `depth` new slots, entries and
        # heap areas (a step follows one chain of strictly rising levels).
        ss = -1
        todo = 0
        top = -1
        while True:
            if cnt[0] + 2 * depth > slots.shape[0]:
                slots = _grow_rows(slots, 2 * (cnt[0] + 2 * depth))
            if cnt[1] + 2 * depth > ef.shape[0]:
                ef = _grow_rows(ef, 2 * (cnt[1] + 2 * depth))
                ei = _grow_rows(ei, 2 * (cnt[1] + 2 * depth))
            if cnt[2] + heap_need > qf.shape[0]:
                qf = _grow_rows(qf, 2 * (cnt[2] + heap_need))
                qi = _grow_rows(qi, 2 * (cnt[2] + heap_need))
            while 2 * (cnt[0] + 2 * depth) > len(skeys):
                skeys, svals, sshift = table_rehash(skeys, svals, sshift)
            if sn + depth > len(seq):
                seq = grow_i64(seq, 2 * (sn + depth))
            if ss < 0:
                ss = _slot(start, G, slots, ef, ei, qf, qi, cnt, skeys, svals, sshift, c)
                continue
            if top < 0:  # phase 1
                if slots[ss, _LEN] < K and slots[ss, _HSIZE] != _EXHAUSTED:
                    _next_path(start, G, slots, ef, ei, qf, qi, cnt, skeys, svals, sshift,
                               stack, c, rowf, rowi)
                    continue
                todo = min(slots[ss, _LEN], K)
                top = slots[ss, _FIRST]
                if todo == 0:
                    break
            # phase 2: one path, following the entry chain down to TERM
            costs[npath] = ef[top, 0]
            ent = top
            while ei[ent, _X] != TERM:
                x = ei[ent, _X]
                seq[sn] = x % n
                sn += 1
                ptr = ei[ent, _PTR]
                if ptr < 0:
                    ptr = slots[_slot(x, G, slots, ef, ei, qf, qi, cnt, skeys, svals,
                                      sshift, c), _FIRST]
                ent = ptr
            npath += 1
            offs[npath] = sn
            top = ei[top, _NEXT]
            todo -= 1
            if todo == 0:
                break
        first[si + 1] = npath
    return costs[:npath], offs[:npath + 1], seq[:sn], first, cnt[0]


def k_best(graph, k: int) -> tuple[list[list[int]], list[float], int]:
    """The k cheapest sequences (element indices) on ``graph``, with their path costs
    and the number of nodes the enumeration touched."""
    cp = graph.cp
    src = graph.rows * cp.n  # one past every node id
    G = (src, cp.n, cp.r, cp.lo, cp.cap, cp.stride, cp.off, cp.succ_ptr, cp.succ_elem,
         cp.succ_w, cp.front, cp.back, cp.omega, graph.H, graph.row_state, graph.dense,
         graph.keys, graph.vals, graph.shift)
    costs, offs, seq, _first, touched = kbest_from(
        G, np.full(1, src, dtype=np.int64), int(k), cp.n, cp.R, int(cp.max_len) + 3, cp.n)
    seqs = [seq[offs[i]:offs[i + 1]].tolist() for i in range(len(costs))]
    return seqs, costs.tolist(), int(touched)
