"""Forward graph search (FGS): the paper's baseline (§4, "Performance Evaluation").

Dijkstra over (element, consumed resources) states, ordered by cost rather than by
resource consumption, generalised to k paths by letting each state be settled up to
k times (the classic label-setting k-shortest-paths scheme; with non-negative
weights the i-th settlement of a state is its i-th cheapest prefix). It builds no
intermediate graph and no cost-to-go, so it explores every state cheaper than the
k-th answer. It lives here for benchmarks and as an independent second opinion in
the tests.

Labels are generated lazily: a settled label pushes only its cheapest child edge, and
each popped label pushes its next sibling, so the heap and label store grow with the
number of pops rather than pops × out-degree.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._table import (
    admissible,
    decode,
    fits,
    grow_f64,
    grow_i64,
    table_find,
    table_insert,
    table_new,
)
from .compiled import Compiled

STATUS_OK = 0
STATUS_TOO_LARGE = 1


@njit(cache=True)
def _push(heap, hs, lab_cost, lab):
    pos = hs
    c = lab_cost[lab]
    while pos > 0:
        par = (pos - 1) // 2
        q = heap[par]
        if c < lab_cost[q] or (c == lab_cost[q] and lab < q):
            heap[pos] = q
            pos = par
        else:
            break
    heap[pos] = lab
    return hs + 1


@njit(cache=True)
def _pop(heap, hs, lab_cost):
    top = heap[0]
    hs -= 1
    if hs > 0:
        last = heap[hs]
        c = lab_cost[last]
        pos = 0
        while True:
            ch = 2 * pos + 1
            if ch >= hs:
                break
            a = heap[ch]
            if ch + 1 < hs:
                b = heap[ch + 1]
                if lab_cost[b] < lab_cost[a] or (lab_cost[b] == lab_cost[a] and b < a):
                    ch += 1
                    a = b
            if lab_cost[a] < c or (lab_cost[a] == c and a < last):
                heap[pos] = a
                pos = ch
            else:
                break
        heap[pos] = last
    return top, hs


@njit(cache=True)
def _fgs(K, n, r, lo, cap, stride, S, off, sptr, selem, sw, front_order, omega, back,
         dense, size_hint, max_labels):
    R = len(cap)
    c = np.zeros(R, dtype=np.int64)
    tab, keys, vals, shift = table_new(dense, size_hint, S * n if dense else 1)
    pops = np.zeros(1024, dtype=np.int64)
    nnodes = 0
    # labels: cost, parent label, position j (in the parent's sorted successors, or in
    # front_order for roots), element (-1 = the sink), state
    lab_cost = np.empty(1024, dtype=np.float64)
    lab_par = np.empty(1024, dtype=np.int64)
    lab_j = np.empty(1024, dtype=np.int64)
    lab_elem = np.empty(1024, dtype=np.int64)
    lab_state = np.empty(1024, dtype=np.int64)
    nl = 0
    heap = np.empty(1024, dtype=np.int64)
    hs = 0
    results = np.empty(K, dtype=np.int64)
    nres = 0
    settled = 0

    if len(front_order) > 0:
        e = front_order[0]
        lab_cost[0] = omega[e]
        lab_par[0] = -1
        lab_j[0] = 0
        lab_elem[0] = e
        lab_state[0] = off[e]
        nl = 1
        hs = _push(heap, hs, lab_cost, 0)

    while hs > 0 and nres < K:
        if nl + 3 > len(lab_cost):
            if nl > max_labels:
                return STATUS_TOO_LARGE, results[:0], lab_par, lab_elem, settled, nl
            m = 2 * len(lab_cost)
            lab_cost, lab_par, lab_j = grow_f64(lab_cost, m), grow_i64(lab_par, m), \
                grow_i64(lab_j, m)
            lab_elem, lab_state = grow_i64(lab_elem, m), grow_i64(lab_state, m)
            heap = grow_i64(heap, m)
        lab, hs = _pop(heap, hs, lab_cost)
        e = lab_elem[lab]
        if e < 0:
            results[nres] = lab
            nres += 1
            continue
        # the next sibling of this label
        par = lab_par[lab]
        if par < 0:
            jn = lab_j[lab] + 1
            if jn < len(front_order):
                f = front_order[jn]
                lab_cost[nl] = omega[f]
                lab_par[nl] = -1
                lab_j[nl] = jn
                lab_elem[nl] = f
                lab_state[nl] = off[f]
                hs = _push(heap, hs, lab_cost, nl)
                nl += 1
        else:
            pe = lab_elem[par]
            decode(lab_state[par], cap, stride, c)
            jn = lab_j[lab] + 1
            while jn < sptr[pe + 1] and not fits(c, r, selem[jn], cap):
                jn += 1
            if jn < sptr[pe + 1]:
                f = selem[jn]
                lab_cost[nl] = lab_cost[par] + sw[jn]
                lab_par[nl] = par
                lab_j[nl] = jn
                lab_elem[nl] = f
                lab_state[nl] = lab_state[par] + off[f]
                hs = _push(heap, hs, lab_cost, nl)
                nl += 1
        # settle the state of this label at most K times
        s = lab_state[lab]
        key = s * n + e
        v = table_find(dense, tab, keys, vals, shift, key)
        if v < 0:
            if nnodes == len(pops):
                pops = grow_i64(pops, 2 * nnodes)
            v = nnodes
            pops[v] = 0
            keys, vals, shift = table_insert(dense, tab, keys, vals, shift, nnodes, key, v)
            nnodes += 1
        if pops[v] >= K:
            continue
        pops[v] += 1
        settled += 1
        decode(s, cap, stride, c)
        if back[e] and admissible(c, lo):
            lab_cost[nl] = lab_cost[lab]
            lab_par[nl] = lab
            lab_j[nl] = -1
            lab_elem[nl] = -1
            lab_state[nl] = s
            hs = _push(heap, hs, lab_cost, nl)
            nl += 1
        jn = sptr[e]
        while jn < sptr[e + 1] and not fits(c, r, selem[jn], cap):
            jn += 1
        if jn < sptr[e + 1]:
            f = selem[jn]
            lab_cost[nl] = lab_cost[lab] + sw[jn]
            lab_par[nl] = lab
            lab_j[nl] = jn
            lab_elem[nl] = f
            lab_state[nl] = s + off[f]
            hs = _push(heap, hs, lab_cost, nl)
            nl += 1
    return STATUS_OK, results[:nres], lab_par, lab_elem, nnodes, nl


def fgs(cp: Compiled, k: int, *, dense: bool, size_hint: int, max_labels: int):
    """Run FGS; returns (status, sequences, costs, states settled, labels created)."""
    # successors of each element sorted by weight, so children can be generated lazily
    rows = np.repeat(np.arange(cp.n), np.diff(cp.succ_ptr))
    order = np.lexsort((cp.succ_elem, cp.succ_w, rows))
    selem, sw = cp.succ_elem[order], cp.succ_w[order]
    zero_fit = (cp.r <= cp.cap).all(axis=1)
    fidx = np.flatnonzero(cp.front & zero_fit)
    front_order = fidx[np.lexsort((fidx, cp.omega[fidx]))].astype(np.int64)
    status, res, lab_par, lab_elem, nstates, nlabels = _fgs(
        int(k), cp.n, cp.r, cp.lo, cp.cap, cp.stride, cp.S, cp.off, cp.succ_ptr,
        selem, sw, front_order, cp.omega, cp.back, dense, size_hint, max_labels,
    )
    if status != STATUS_OK:
        return status, [], [], int(nstates), int(nlabels)
    seqs = []
    for lab in res:
        seq = []
        x = lab_par[lab]  # the sink label's parent is the last element's label
        while x >= 0:
            seq.append(int(lab_elem[x]))
            x = lab_par[x]
        seqs.append(seq[::-1])
    return status, seqs, None, int(nstates), int(nlabels)
