"""Exact k best source→sink paths on the pruned intermediate graph.

The lazy recursive enumeration of Jiménez & Marzal ("Computing the K shortest paths:
a new algorithm and an experimental comparison", WAE 1999), which is the graph case
of Huang & Chiang's lazy k-best Algorithm 3 ("Better k-best parsing", 2005), run on
suffixes: every node v keeps the list P_v of its best paths to the sink found so
far, P_v[0] being the one through the exact cost-to-go h. The next path of v comes
from a heap of candidates "go to successor x, then take P_x[j]"; popping (x, j)
adds (x, j+1), which may ask x for its own next path (an explicit stack replaces the
recursion). Only nodes on the paths actually enumerated are touched, so k = 100
costs little more than k = 1 once the graph is built.

Ties are broken by the element index of the next element (ending the sequence ranks
first), then by the position in P_x, so sequences of equal cost come out in
lexicographic order of element indices: deterministic, and independent of how the
graph was grown.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._table import admissible, decode, fits, grow_i64, hash_find

TERM = -1
# slot columns
_PBASE, _PLEN, _PCAP, _HBASE, _HSIZE = 0, 1, 2, 3, 4
_EXHAUSTED = -1


@njit(cache=True)
def _choices(v, G, c, out_f, out_i):
    """Write the out-choices of node v (G[0] = nn is the virtual source) as rows
    (cost, w) / (node, 0, key); return their count."""
    (nn, n, r, lo, cap, stride, off, succ_ptr, succ_elem, succ_w, front, back, omega,
     elem, state, h, dense, tab, keys, vals, shift) = G
    m = 0
    if v == nn:
        c[:] = 0
        for e in range(n):
            if front[e] and fits(c, r, e, cap):
                if dense:
                    x = np.int64(tab[off[e] * n + e])
                else:
                    x = hash_find(keys, vals, shift, off[e] * n + e)
                if x >= 0 and h[x] < np.inf:
                    out_f[m, 0] = omega[e] + h[x]
                    out_f[m, 1] = omega[e]
                    out_i[m, 0] = x
                    out_i[m, 1] = 0
                    out_i[m, 2] = e
                    m += 1
        return m
    e = elem[v]
    s = state[v]
    decode(s, cap, stride, c)
    if back[e] and admissible(c, lo):
        out_f[m, 0] = 0.0
        out_f[m, 1] = 0.0
        out_i[m, 0] = TERM
        out_i[m, 1] = 0
        out_i[m, 2] = -1
        m += 1
    for j in range(succ_ptr[e], succ_ptr[e + 1]):
        f = succ_elem[j]
        if not fits(c, r, f, cap):
            continue
        if dense:
            x = np.int64(tab[(s + off[f]) * n + f])
        else:
            x = hash_find(keys, vals, shift, (s + off[f]) * n + f)
        if x >= 0 and h[x] < np.inf:
            out_f[m, 0] = succ_w[j] + h[x]
            out_f[m, 1] = succ_w[j]
            out_i[m, 0] = x
            out_i[m, 1] = 0
            out_i[m, 2] = f
            m += 1
    return m


@njit(cache=True, inline="always")
def _less(af, ai, a, bf, bi, b):
    """Order of rows a and b: cost, then next element, then index into P_x."""
    if af[a, 0] != bf[b, 0]:
        return af[a, 0] < bf[b, 0]
    if ai[a, 2] != bi[b, 2]:
        return ai[a, 2] < bi[b, 2]
    return ai[a, 1] < bi[b, 1]


@njit(cache=True)
def _heap_push(qf, qi, hb, hs, rf, ri, row):
    """Push row ``row`` of (rf, ri) onto the heap at qf/qi[hb : hb+hs]; returns hs+1."""
    pos = hs
    while pos > 0:
        par = (pos - 1) // 2
        if _less(rf, ri, row, qf, qi, hb + par):
            qf[hb + pos] = qf[hb + par]
            qi[hb + pos] = qi[hb + par]
            pos = par
        else:
            break
    qf[hb + pos] = rf[row]
    qi[hb + pos] = ri[row]
    return hs + 1


@njit(cache=True)
def _heap_pop(qf, qi, hb, hs, outf, outi):
    """Move the minimum into row 0 of outf/outi; returns hs-1."""
    outf[0] = qf[hb]
    outi[0] = qi[hb]
    hs -= 1
    if hs == 0:
        return 0
    lastf = qf[hb + hs].copy()
    lasti = qi[hb + hs].copy()
    pos = 0
    while True:
        ch = 2 * pos + 1
        if ch >= hs:
            break
        if ch + 1 < hs and _less(qf, qi, hb + ch + 1, qf, qi, hb + ch):
            ch += 1
        if qf[hb + ch, 0] < lastf[0] or (
            qf[hb + ch, 0] == lastf[0] and (
                qi[hb + ch, 2] < lasti[2]
                or (qi[hb + ch, 2] == lasti[2] and qi[hb + ch, 1] < lasti[1]))):
            qf[hb + pos] = qf[hb + ch]
            qi[hb + pos] = qi[hb + ch]
            pos = ch
        else:
            break
    qf[hb + pos] = lastf
    qi[hb + pos] = lasti
    return hs


@njit(cache=True)
def _grow_rows_f(a, rows):
    b = np.empty((rows, a.shape[1]), dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


@njit(cache=True)
def _grow_rows_i(a, rows):
    b = np.empty((rows, a.shape[1]), dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


@njit(cache=True)
def _append_path(slots, sl, pf, pi, pn, rf, ri, row):
    """Append row to the path vector of slot sl, relocating it when full."""
    if slots[sl, _PLEN] == slots[sl, _PCAP]:
        ncap = max(2, 2 * slots[sl, _PCAP])
        if pn + ncap > pf.shape[0]:
            pf = _grow_rows_f(pf, 2 * (pn + ncap))
            pi = _grow_rows_i(pi, 2 * (pn + ncap))
        ob = slots[sl, _PBASE]
        for t in range(slots[sl, _PLEN]):
            pf[pn + t] = pf[ob + t]
            pi[pn + t] = pi[ob + t]
        slots[sl, _PBASE] = pn
        slots[sl, _PCAP] = ncap
        pn += ncap
    b = slots[sl, _PBASE] + slots[sl, _PLEN]
    pf[b] = rf[row]
    pi[b] = ri[row]
    slots[sl, _PLEN] += 1
    return pf, pi, pn


@njit(cache=True)
def _ensure_slot(v, G, slot_of, slots, ns, pf, pi, pn, c, chf, chi):
    """Give node v a slot holding its first path (the argmin of its choices)."""
    if slot_of[v] >= 0:
        return slots, ns, pf, pi, pn
    if ns == slots.shape[0]:
        slots = _grow_rows_i(slots, 2 * ns)
    sl = ns
    ns += 1
    slot_of[v] = sl
    slots[sl, _PBASE] = 0
    slots[sl, _PLEN] = 0
    slots[sl, _PCAP] = 0
    slots[sl, _HBASE] = -1
    slots[sl, _HSIZE] = 0
    m = _choices(v, G, c, chf, chi)
    best = -1
    for t in range(m):
        if best < 0 or _less(chf, chi, t, chf, chi, best):
            best = t
    if best < 0:
        slots[sl, _HSIZE] = _EXHAUSTED
    else:
        pf, pi, pn = _append_path(slots, sl, pf, pi, pn, chf, chi, best)
    return slots, ns, pf, pi, pn


@njit(cache=True)
def _kbest(K, G, max_deg):
    nn = G[0]
    R = len(G[4])
    c = np.zeros(R, dtype=np.int64)
    chf = np.empty((max_deg + 1, 2), dtype=np.float64)
    chi = np.empty((max_deg + 1, 3), dtype=np.int64)
    rowf = np.empty((1, 2), dtype=np.float64)
    rowi = np.empty((1, 3), dtype=np.int64)
    slot_of = np.full(nn + 1, -1, dtype=np.int64)
    slots = np.empty((64, 5), dtype=np.int64)
    ns = 0
    pf = np.empty((256, 2), dtype=np.float64)
    pi = np.empty((256, 3), dtype=np.int64)
    pn = 0
    qf = np.empty((256, 2), dtype=np.float64)
    qi = np.empty((256, 3), dtype=np.int64)
    qn = 0
    stack = np.empty(64, dtype=np.int64)

    slots, ns, pf, pi, pn = _ensure_slot(nn, G, slot_of, slots, ns, pf, pi, pn, c, chf, chi)
    src = slot_of[nn]
    while slots[src, _PLEN] < K and slots[src, _HSIZE] != _EXHAUSTED:
        # compute the next path of the source; a node whose last path continues into
        # x with P_x[j] needs P_x[j+1] first, so x goes on the stack
        stack[0] = nn
        sp = 1
        while sp > 0:
            v = stack[sp - 1]
            sl = slot_of[v]
            last = slots[sl, _PBASE] + slots[sl, _PLEN] - 1
            x = pi[last, 0]
            j = pi[last, 1]
            if x != TERM:
                slots, ns, pf, pi, pn = _ensure_slot(x, G, slot_of, slots, ns, pf, pi, pn,
                                                     c, chf, chi)
                sx = slot_of[x]
                if slots[sx, _HSIZE] != _EXHAUSTED and slots[sx, _PLEN] <= j + 1:
                    if sp == len(stack):
                        stack = grow_i64(stack, 2 * sp)
                    stack[sp] = x
                    sp += 1
                    continue
            sp -= 1
            if slots[sl, _HBASE] < 0:
                # first use: a heap with every choice but the one of P_v[0]
                m = _choices(v, G, c, chf, chi)
                if qn + m + 1 > qf.shape[0]:
                    qf = _grow_rows_f(qf, 2 * (qn + m + 1))
                    qi = _grow_rows_i(qi, 2 * (qn + m + 1))
                slots[sl, _HBASE] = qn
                qn += m + 1
                hs = 0
                for t in range(m):
                    if chi[t, 0] != x:
                        hs = _heap_push(qf, qi, slots[sl, _HBASE], hs, chf, chi, t)
                slots[sl, _HSIZE] = hs
            hb = slots[sl, _HBASE]
            hs = slots[sl, _HSIZE]
            if x != TERM:
                sx = slot_of[x]
                if slots[sx, _PLEN] > j + 1:
                    nxt = slots[sx, _PBASE] + j + 1
                    rowf[0, 0] = pf[last, 1] + pf[nxt, 0]
                    rowf[0, 1] = pf[last, 1]
                    rowi[0, 0] = x
                    rowi[0, 1] = j + 1
                    rowi[0, 2] = pi[last, 2]
                    hs = _heap_push(qf, qi, hb, hs, rowf, rowi, 0)
            if hs == 0:
                slots[sl, _HSIZE] = _EXHAUSTED
                continue
            hs = _heap_pop(qf, qi, hb, hs, rowf, rowi)
            slots[sl, _HSIZE] = hs
            pf, pi, pn = _append_path(slots, sl, pf, pi, pn, rowf, rowi, 0)

    # read the paths of the source out
    npaths = min(slots[src, _PLEN], K)
    costs = np.empty(npaths, dtype=np.float64)
    offs = np.zeros(npaths + 1, dtype=np.int64)
    seq = np.empty(16, dtype=np.int64)
    sn = 0
    elem = G[13]
    for i in range(npaths):
        ent = slots[src, _PBASE] + i
        costs[i] = pf[ent, 0]
        while True:
            x = pi[ent, 0]
            if x == TERM:
                break
            if sn == len(seq):
                seq = grow_i64(seq, 2 * sn)
            seq[sn] = elem[x]
            sn += 1
            slots, ns, pf, pi, pn = _ensure_slot(x, G, slot_of, slots, ns, pf, pi, pn,
                                                 c, chf, chi)
            ent = slots[slot_of[x], _PBASE] + pi[ent, 1]
        offs[i + 1] = sn
    return costs, offs, seq[:sn], ns


def k_best(graph, k: int) -> tuple[list[list[int]], list[float], int]:
    """The k cheapest sequences (element indices) on ``graph``, with their path costs
    and the number of nodes the enumeration touched."""
    cp = graph.cp
    G = (graph.nodes, cp.n, cp.r, cp.lo, cp.cap, cp.stride, cp.off, cp.succ_ptr,
         cp.succ_elem, cp.succ_w, cp.front, cp.back, cp.omega, graph.elem, graph.state,
         graph.h, graph.dense, graph.tab, graph.keys, graph.vals, graph.shift)
    max_deg = max(int(np.diff(cp.succ_ptr).max()), cp.n)
    costs, offs, seq, touched = _kbest(int(k), G, max_deg)
    seqs = [seq[offs[i]:offs[i + 1]].tolist() for i in range(len(costs))]
    return seqs, costs.tolist(), int(touched)
