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

from citysynth.solver._table import (
    admissible,
    decode,
    fits,
    grow_f64,
    grow_i64,
    hash_find,
    hash_put,
    table_new,
    table_rehash,
)
from citysynth.solver.compiled import Compiled
from citysynth.solver.interrupts import kernel_calls

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
def _fgs_steps(K, n, r, lo, cap, stride, off, sptr, selem, sw, front_order, omega, back,
               dense, tab, keys, vals, shift, pops, lab_cost, lab_par, lab_j, lab_elem,
               lab_state, heap, results, counters, max_pops):
    """Pop labels until done, until ``max_pops`` pops, or until the arrays are nearly
    full (the driver then grows them and calls again; nothing is reallocated in here,
    see graph.py). counters = [labels, heap size, results, states, settled]."""
    c = np.zeros(len(cap), dtype=np.int64)
    nl, hs, nres, nnodes, settled = counters[0], counters[1], counters[2], counters[3], \
        counters[4]
    while hs > 0 and nres < K and max_pops > 0:
        if nl + 3 > len(lab_cost) or nnodes + 1 > len(pops) or \
                (not dense and 2 * (nnodes + 1) > len(keys)):
            break
        max_pops -= 1
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
        if dense:
            v = np.int64(tab[key])
        else:
            v = hash_find(keys, vals, shift, key)
        if v < 0:
            v = nnodes
            pops[v] = 0
            if dense:
                tab[key] = v
            else:
                hash_put(keys, vals, shift, key, v)
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
    counters[0], counters[1], counters[2], counters[3], counters[4] = nl, hs, nres, nnodes, \
        settled


POPS_PER_CALL = 1 << 18   # labels one kernel call pops at most (tens of milliseconds)


@kernel_calls()
def _fgs(K, n, r, lo, cap, stride, S, off, sptr, selem, sw, front_order, omega, back,
         dense, size_hint, max_labels):
    """The search's driver, in Python between kernel calls of at most
    :data:`POPS_PER_CALL` pops (as the A*'s): asked for by name on a large problem,
    FGS runs minutes, and a compiled driver held Ctrl-C and SIGTERM until it ended."""
    tab, keys, vals, shift = table_new(dense, size_hint, S * n if dense else 1)
    m = 1 << 16
    pops = np.zeros(m, dtype=np.int64)
    lab_cost = np.empty(m, dtype=np.float64)
    lab_par = np.empty(m, dtype=np.int64)
    lab_j = np.empty(m, dtype=np.int64)
    lab_elem = np.empty(m, dtype=np.int64)
    lab_state = np.empty(m, dtype=np.int64)
    heap = np.empty(m, dtype=np.int64)
    results = np.empty(K, dtype=np.int64)
    counters = np.zeros(5, dtype=np.int64)  # labels, heap size, results, states, settled
    if len(front_order) > 0:
        e = front_order[0]
        lab_cost[0] = omega[e]
        lab_par[0] = -1
        lab_j[0] = 0
        lab_elem[0] = e
        lab_state[0] = off[e]
        heap[0] = 0
        counters[0] = 1
        counters[1] = 1
    while True:
        _fgs_steps(K, n, r, lo, cap, stride, off, sptr, selem, sw, front_order, omega, back,
                   dense, tab, keys, vals, shift, pops, lab_cost, lab_par, lab_j, lab_elem,
                   lab_state, heap, results, counters, POPS_PER_CALL)
        nl, hs, nres, nnodes = counters[0], counters[1], counters[2], counters[3]
        if hs == 0 or nres >= K:
            break
        if nl + 3 > len(lab_cost):
            if len(lab_cost) >= max_labels:
                return STATUS_TOO_LARGE, results[:0], lab_par, lab_elem, nnodes, nl
            # never past the budget: doubling from just under it asked for twice the
            # budget (2.65 GB of a 2 GB budget, then numpy's MemoryError, exit 3)
            m = min(2 * len(lab_cost), max_labels + 3)
            lab_cost, lab_par, lab_j = grow_f64(lab_cost, m), grow_i64(lab_par, m), \
                grow_i64(lab_j, m)
            lab_elem, lab_state = grow_i64(lab_elem, m), grow_i64(lab_state, m)
            heap = grow_i64(heap, m)
        if nnodes + 1 > len(pops):
            pops = grow_i64(pops, 2 * len(pops))
        if not dense and 2 * (nnodes + 1) > len(keys):
            keys, vals, shift = table_rehash(keys, vals, shift)
    return STATUS_OK, results[:counters[2]], lab_par, lab_elem, counters[3], counters[0]


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
