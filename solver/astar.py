"""Best-first (A*) k-best search over (element, state) labels, guided by the lower
bounds of :mod:`citysynth.solver.bounds`.

The FGS baseline (:mod:`citysynth.solver.fgs`) settles labels in order of their cost g; here
they are settled in order of f = g + h, h being the maximum of the one-resource
relaxations' exact costs to go. h is consistent, so, exactly as in Dijkstra's
algorithm, the i-th label settled at a node is that node's i-th cheapest prefix, a
node needs at most k settlements, and complete sequences come out in ascending cost.
What changes is how much is explored: only labels with f at or below the k-th cost,
which on a street front with three constraints is a few thousand labels where the
intermediate graph spans millions of nodes.

**Ties.** Labels of equal f are ordered by their sequence, lexicographically (element
indices, a prefix before its extensions, a sequence's end label after the label it
ends). Along any sequence the keys (f, sequence) only grow: f because h is
consistent, the sequence because a prefix comes first. So this is still a best-first
order, end labels come out in (cost, lexicographic) order, and the k settled at a node
are its k smallest prefixes in that order. The k sequences returned are therefore
the first k in (cost, lexicographic) order, the same as the intermediate graph's
enumeration returns, without any extra pass. Two sequences are compared only when
two f are exactly equal, by finding where they part with Myers' skew-binary jump
pointers: each label keeps, besides its parent, one ancestor further up (one more
int64 a label), placed so that a label's ancestor at a given depth, and the first
labels where two sequences of equal depth differ, are reached in O(log depth) steps;
walking the parent chains took O(depth) a comparison, which on plateaus of equal f
with sequences thousands of elements long was most of the search's time (85 us a
label in a search whose labels reach 16,000 deep; under 2 us now).
On a problem where every cost is zero the order is a depth-first walk in
lexicographic order, which reaches the first complete sequence at once. g is summed
front to back, exactly as the reported cost is, so ties are judged on the very
numbers reported.

**Lazy children.** Settling a label computes the f of each of its children (its
successors, and its end when the sequence may end there) into a small heap of its
own, and puts only the best child on the main heap; whenever a label leaves the main
heap its next sibling takes its place. The main heap stays as small as the number of
settled labels, where pushing every child would fill it with tens of thousands that
are never popped.

Labels, child heaps and the node table are plain arrays grown by the driver between
calls of the step kernel (as in fgs.py: nothing is reallocated inside the hot loop).
Label 0 is the virtual source; its children are the front elements. A label's depth
and jump pointer share one array, ``lab_dj`` (depth of label i at 2i, jump at 2i + 1):
a separate jump array, one more array argument to every kernel call made per label,
cost 10-20 % on the street bench in numba's passing of array arguments.
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
from citysynth.solver.bounds import Bounds, bound_after, pair_after
from citysynth.solver.compiled import Compiled
from citysynth.solver.interrupts import kernel_calls

STATUS_OK = 0
STATUS_TOO_LARGE = 1
LABEL_BYTES = 88   # g, f, parent, element, state, depth + jump, child heap, heap slot
KID_BYTES = 16     # f and successor index of one child
NODE_BYTES = 40    # hash slots (two, at load 1/2) and settle count
_END = -1          # element of an end label (the sequence of its parent, complete)
_ROOT = -2         # element of label 0, the virtual source


@njit(cache=True, inline="always")
def _jump_for(p, dj):
    """The jump pointer of a new label whose parent is p (Myers' skew-binary lists):
    jump[p]'s own jump when the two jumps above p span equal depths, else p itself.
    Label 0, the root, jumps to itself. The depth of a label's jump depends only on
    the label's depth, and any ancestor is reached from a label in O(log depth) hops
    of jumps and parents. ``dj`` holds depth and jump of label i at 2i and 2i + 1."""
    j = dj[2 * p + 1]
    jj = dj[2 * j + 1]
    if dj[2 * p] - dj[2 * j] == dj[2 * j] - dj[2 * jj]:
        return jj
    return p


@njit(cache=True, inline="always")
def _ancestor_at(x, d, par, dj):
    """The ancestor of label x at depth d (x itself at its own depth)."""
    while dj[2 * x] > d:
        j = dj[2 * x + 1]
        if dj[2 * j] >= d:
            x = j
        else:
            x = par[x]
    return x


@njit(cache=True)
def _seq_less(a, b, par, elem, dj):
    """Sequence of label a before that of label b: lexicographic on element indices,
    a prefix before its extensions, an end label (the sequence of its parent) right
    after its parent. Distinct labels never share a sequence. Ancestors are reached
    by jump pointers (:func:`_jump_for`; ``dj`` holds depth and jump of label i at 2i
    and 2i + 1): O(log depth) steps where walking parents took O(depth)."""
    end_a = elem[a] == _END
    end_b = elem[b] == _END
    if end_a:
        a = par[a]
    if end_b:
        b = par[b]
    if a == b:
        return end_b and not end_a
    x, y = a, b
    da, db = dj[2 * a], dj[2 * b]
    if da > db:
        x = _ancestor_at(x, db, par, dj)
        if x == b:
            return False    # b is a proper prefix of a
    elif db > da:
        y = _ancestor_at(y, da, par, dj)
        if y == a:
            return True     # a is a proper prefix of b
    # x != y, at equal depths, so are their jumps: jump both while the jumps still
    # differ (the parting point is above them), else step both to their parents
    while par[x] != par[y]:
        jx, jy = dj[2 * x + 1], dj[2 * y + 1]
        if jx != jy:
            x, y = jx, jy
        else:
            x, y = par[x], par[y]
    return elem[x] < elem[y]   # the first elements where the sequences part


@njit(cache=True, inline="always")
def _before(a, b, f, par, elem, dj):
    """Main heap order: f, then the sequence."""
    return f[a] < f[b] or (f[a] == f[b] and _seq_less(a, b, par, elem, dj))


@njit(cache=True)
def _push(heap, hs, f, par, elem, dj, lab):
    pos = hs
    while pos > 0:
        up = (pos - 1) // 2
        q = heap[up]
        if _before(lab, q, f, par, elem, dj):
            heap[pos] = q
            pos = up
        else:
            break
    heap[pos] = lab
    return hs + 1


@njit(cache=True)
def _pop(heap, hs, f, par, elem, dj):
    top = heap[0]
    hs -= 1
    if hs > 0:
        last = heap[hs]
        pos = 0
        while True:
            ch = 2 * pos + 1
            if ch >= hs:
                break
            a = heap[ch]
            if ch + 1 < hs and _before(heap[ch + 1], a, f, par, elem, dj):
                ch += 1
                a = heap[ch]
            if _before(a, last, f, par, elem, dj):
                heap[pos] = a
                pos = ch
            else:
                break
        heap[pos] = last
    return top, hs


@njit(cache=True, inline="always")
def _kid_less(kf, kj, x, y):
    """Child order: f, then the successor index (the element order of one parent's
    successors; its end, index -1, first)."""
    return kf[x] < kf[y] or (kf[x] == kf[y] and kj[x] < kj[y])


@njit(cache=True)
def _kid_sift(kf, kj, base, size, pos):
    while True:
        ch = 2 * pos + 1
        if ch >= size:
            return
        if ch + 1 < size and _kid_less(kf, kj, base + ch + 1, base + ch):
            ch += 1
        if not _kid_less(kf, kj, base + ch, base + pos):
            return
        kf[base + ch], kf[base + pos] = kf[base + pos], kf[base + ch]
        kj[base + ch], kj[base + pos] = kj[base + pos], kj[base + ch]
        pos = ch


@njit(cache=True)
def _kid_pop(kf, kj, base, size):
    """Remove the best child of a heap at kf/kj[base:base + size]; returns (f, j)."""
    f0, j0 = kf[base], kj[base]
    size -= 1
    if size > 0:
        kf[base], kj[base] = kf[base + size], kj[base + size]
        _kid_sift(kf, kj, base, size, 0)
    return f0, j0


@njit(cache=True)
def _next_kid(P, nl, lab_g, lab_f, lab_par, lab_elem, lab_state, lab_dj, kbase, ksize, kf,
              kj, selem, sw, off, omega):
    """Move parent P's best remaining child onto a new label nl; returns nl + 1 (nl
    when P has none left)."""
    size = ksize[P]
    if size <= 0:
        return nl
    kfv, j = _kid_pop(kf, kj, kbase[P], size)
    ksize[P] = size - 1
    if lab_elem[P] == _ROOT:       # a front element: j is the element itself
        lab_g[nl], lab_elem[nl], lab_state[nl] = omega[j], j, off[j]
    elif j < 0:                    # the end of P's sequence
        lab_g[nl], lab_elem[nl], lab_state[nl] = lab_g[P], _END, lab_state[P]
    else:
        f = selem[j]
        lab_g[nl], lab_elem[nl], lab_state[nl] = lab_g[P] + sw[j], f, lab_state[P] + off[f]
    lab_f[nl], lab_par[nl] = kfv, P
    lab_dj[2 * nl], lab_dj[2 * nl + 1] = lab_dj[2 * P] + 1, _jump_for(P, lab_dj)
    kbase[nl], ksize[nl] = -1, 0
    return nl + 1


@njit(cache=True)
def _settle(lab, K, n, keys, vals, shift, pops, lab_state, lab_elem, cnt):
    """Count one settlement of the label's node; False when the node was settled K
    times already (the label is dropped). cnt = [.., .., .., nodes, settled, ..]."""
    key = lab_state[lab] * n + lab_elem[lab]
    v = hash_find(keys, vals, shift, key)
    if v < 0:
        v = cnt[3]
        cnt[3] += 1
        pops[v] = 0
        hash_put(keys, vals, shift, key, v)
    if pops[v] >= K:
        return False
    pops[v] += 1
    cnt[4] += 1
    return True


@njit(cache=True, inline="always")
def out_of_range(c, f, r, lo, cap, n, rlevel, rother, rbase, rmin, rmax):
    """Can no completion of node (f, c + r(f)) bring some resource into its interval,
    by the range tables (:func:`citysynth.solver.bounds.range_tables`)?"""
    for t in range(len(rlevel)):
        i, j = rlevel[t], rother[t]
        at = rbase[t] + (c[i] + r[f, i]) * n + f
        cj = c[j] + r[f, j]
        if cj + rmin[at] > cap[j] or cj + rmax[at] < lo[j]:
            return True
    return False


@njit(cache=True)
def _children(e, g, c, lo, r, cap, n, sptr, selem, sw, back, bres, bbase, btab, rng, kf,
              kj, nk):
    """Write the children of a settled label at element e, cost g, consumption c (its
    end, then every successor that fits and can still complete) from kid row nk on,
    as a heap; returns their count. ``rng`` holds the range and pair tables
    (:meth:`~citysynth.solver.bounds.Bounds.kernel_tables`)."""
    rlevel, rother, rbase, rmin, rmax = rng[0], rng[1], rng[2], rng[3], rng[4]
    pl, pj, ps, pq, pbase, ptab = rng[5], rng[6], rng[7], rng[8], rng[9], rng[10]
    m = 0
    if back[e] and admissible(c, lo):
        kf[nk], kj[nk] = g, -1
        m += 1
    T = len(bres)
    for j in range(sptr[e], sptr[e + 1]):
        f = selem[j]
        if not fits(c, r, f, cap):
            continue
        # the bound of (f, c + r(f)), written out: a helper taking the table arrays
        # costs ~200 ns a call here in reference counting (measured: 18 us instead of
        # 1 us for the 74 successors of a street building)
        hb = 0.0
        for t in range(T):
            i = bres[t]
            hb = max(hb, btab[bbase[t] + (c[i] + r[f, i]) * n + f])
        for u in range(len(pl)):       # pair_after, written out as the bound is
            i, jj = pl[u], pj[u]
            hb = max(hb, ptab[pbase[u] + ((c[i] + r[f, i]) * (pq[u] + 1)
                                          + (c[jj] + r[f, jj]) // ps[u]) * n + f])
        if hb == np.inf:
            continue
        out = False
        for t in range(len(rlevel)):   # out_of_range, written out as the bound is
            i, jj = rlevel[t], rother[t]
            at = rbase[t] + (c[i] + r[f, i]) * n + f
            cj = c[jj] + r[f, jj]
            if cj + rmin[at] > cap[jj] or cj + rmax[at] < lo[jj]:
                out = True
                break
        if out:
            continue
        kf[nk + m], kj[nk + m] = g + sw[j] + hb, j
        m += 1
    for top in range(m // 2 - 1, -1, -1):  # heapify, written out (see above)
        pos = top
        while True:
            ch = 2 * pos + 1
            if ch >= m:
                break
            a, b = nk + ch, nk + ch + 1
            if ch + 1 < m and (kf[b] < kf[a] or (kf[b] == kf[a] and kj[b] < kj[a])):
                ch += 1
                a = b
            p = nk + pos
            if not (kf[a] < kf[p] or (kf[a] == kf[p] and kj[a] < kj[p])):
                break
            kf[a], kf[p] = kf[p], kf[a]
            kj[a], kj[p] = kj[p], kj[a]
            pos = ch
    return m


@njit(cache=True)
def _astar_steps(K, n, r, lo, cap, stride, off, sptr, selem, sw, omega, back, bres, bbase,
                 btab, rng, keys, vals, shift, pops, lab_g, lab_f, lab_par, lab_elem, lab_state,
                 lab_dj, kbase, ksize, kf, kj, heap, results, cnt, room, max_pops):
    """Pop labels until K complete sequences are out, the heap is empty, the arrays
    have less than ``room`` free rows (the driver grows them and calls again), or
    ``max_pops`` labels were popped (the driver, in Python, lets Ctrl-C in and calls
    again). cnt = [labels, heap size, results, nodes, settled, kid rows]."""
    c = np.zeros(len(cap), dtype=np.int64)
    nl, hs, nk = cnt[0], cnt[1], cnt[5]
    popped = 0
    while hs > 0 and cnt[2] < K and popped < max_pops:
        popped += 1
        if nl + 2 > len(lab_g) or nk + room > len(kf) or cnt[3] + 1 > len(pops) or \
                2 * (cnt[3] + 1) > len(keys):
            break
        lab, hs = _pop(heap, hs, lab_f, lab_par, lab_elem, lab_dj)
        nl2 = _next_kid(lab_par[lab], nl, lab_g, lab_f, lab_par, lab_elem, lab_state,
                        lab_dj, kbase, ksize, kf, kj, selem, sw, off, omega)
        if nl2 > nl:
            hs = _push(heap, hs, lab_f, lab_par, lab_elem, lab_dj, nl)
            nl = nl2
        e = lab_elem[lab]
        if e == _END:
            results[cnt[2]] = lab
            cnt[2] += 1
            continue
        if not _settle(lab, K, n, keys, vals, shift, pops, lab_state, lab_elem, cnt):
            continue
        decode(lab_state[lab], cap, stride, c)
        m = _children(e, lab_g[lab], c, lo, r, cap, n, sptr, selem, sw, back, bres, bbase,
                      btab, rng, kf, kj, nk)
        kbase[lab], ksize[lab] = nk, m
        nk += m
        nl2 = _next_kid(lab, nl, lab_g, lab_f, lab_par, lab_elem, lab_state, lab_dj,
                        kbase, ksize, kf, kj, selem, sw, off, omega)
        if nl2 > nl:
            hs = _push(heap, hs, lab_f, lab_par, lab_elem, lab_dj, nl)
            nl = nl2
    cnt[0], cnt[1], cnt[5] = nl, hs, nk


@njit(cache=True)
def _grow_labels(m, lab_g, lab_f, lab_par, lab_elem, lab_state, lab_dj, kbase, ksize,
                 heap):
    return (grow_f64(lab_g, m), grow_f64(lab_f, m), grow_i64(lab_par, m),
            grow_i64(lab_elem, m), grow_i64(lab_state, m), grow_i64(lab_dj, 2 * m),
            grow_i64(kbase, m), grow_i64(ksize, m), grow_i64(heap, m))


@njit(cache=True)
def _root(n, r, lo, cap, off, front, omega, bres, bbase, btab, rng, lab_g, lab_f, lab_par, lab_elem,
          lab_state, lab_dj, kbase, ksize, kf, kj):
    """Label 0, the virtual source, with the front elements as its children."""
    lab_g[0], lab_f[0], lab_par[0], lab_elem[0], lab_state[0] = 0.0, 0.0, -1, _ROOT, 0
    lab_dj[0], lab_dj[1] = -1, 0   # depth -1, and the root jumps to itself
    zero = np.zeros(len(cap), dtype=np.int64)
    m = 0
    for e in range(n):
        if front[e] and fits(zero, r, e, cap):
            hb = max(bound_after(zero, e, r, n, bres, bbase, btab),
                     pair_after(zero, e, r, n, rng))
            if hb < np.inf and not out_of_range(zero, e, r, lo, cap, n, rng[0], rng[1],
                                                rng[2], rng[3], rng[4]):
                kf[m], kj[m] = omega[e] + hb, e
                m += 1
    for pos in range(m // 2 - 1, -1, -1):
        _kid_sift(kf, kj, 0, m, pos)
    kbase[0], ksize[0] = 0, m
    return m


POPS_PER_CALL = 1 << 18   # labels one kernel call pops at most (tens of milliseconds)


@kernel_calls()
def _astar(K, n, r, lo, cap, stride, off, sptr, selem, sw, front, omega, back, bres, bbase,
           btab, rng, max_labels, max_kids, max_nodes):
    """The search's driver, in Python between kernel calls of at most
    :data:`POPS_PER_CALL` pops: a search that runs to its budget (a minute and more)
    stops on Ctrl-C or SIGTERM within a call, where a compiled driver held the signal
    until it ended."""
    # the most children one settlement can write: a list and an end
    room = max(n, int(np.diff(sptr).max(initial=0))) + 2
    m = 1 << 12
    _tab, keys, vals, shift = table_new(False, 1 << 10, 1)
    pops = np.zeros(1 << 10, dtype=np.int64)
    e0 = np.empty(0, dtype=np.int64)
    lab_g, lab_f, lab_par, lab_elem, lab_state, lab_dj, kbase, ksize, heap = _grow_labels(
        m, np.empty(0), np.empty(0), e0, e0, e0, e0, e0, e0, e0)
    kf = np.empty(max(m, 4 * room))
    kj = np.empty(max(m, 4 * room), dtype=np.int64)
    results = np.empty(K, dtype=np.int64)
    cnt = np.zeros(6, dtype=np.int64)  # labels, heap size, results, nodes, settled, kids
    cnt[5] = _root(n, r, lo, cap, off, front, omega, bres, bbase, btab, rng, lab_g, lab_f, lab_par,
                   lab_elem, lab_state, lab_dj, kbase, ksize, kf, kj)
    cnt[0] = _next_kid(0, 1, lab_g, lab_f, lab_par, lab_elem, lab_state, lab_dj,
                       kbase, ksize, kf, kj, selem, sw, off, omega)
    if cnt[0] > 1:
        cnt[1] = _push(heap, 0, lab_f, lab_par, lab_elem, lab_dj, 1)
    while True:
        _astar_steps(K, n, r, lo, cap, stride, off, sptr, selem, sw, omega, back, bres,
                     bbase, btab, rng, keys, vals, shift, pops, lab_g, lab_f, lab_par, lab_elem,
                     lab_state, lab_dj, kbase, ksize, kf, kj, heap, results, cnt,
                     room, POPS_PER_CALL)
        if cnt[1] == 0 or cnt[2] >= K:
            break
        if cnt[0] > max_labels or cnt[5] > max_kids or cnt[3] > max_nodes:
            return STATUS_TOO_LARGE, results[:0], lab_par, lab_elem, cnt
        if cnt[0] + 2 > len(lab_g):
            lab_g, lab_f, lab_par, lab_elem, lab_state, lab_dj, kbase, ksize, heap = \
                _grow_labels(2 * len(lab_g), lab_g, lab_f, lab_par, lab_elem, lab_state,
                             lab_dj, kbase, ksize, heap)
        if cnt[5] + room > len(kf):
            kf = grow_f64(kf, 2 * (cnt[5] + room))
            kj = grow_i64(kj, 2 * (cnt[5] + room))
        if cnt[3] + 1 > len(pops):
            pops = grow_i64(pops, 2 * len(pops))
        while 2 * (cnt[3] + 1) > len(keys):
            keys, vals, shift = table_rehash(keys, vals, shift)
    return STATUS_OK, results[:cnt[2]], lab_par, lab_elem, cnt


def all_labels(budget_bytes: int) -> int:
    """The labels a search within ``budget_bytes`` may make (its share of the budget)."""
    return max(budget_bytes // 3, 1 << 16) // LABEL_BYTES


def astar_k_best(cp: Compiled, bounds: Bounds, k: int, budget_bytes: int,
                 max_labels: int | None = None):
    """Run the search. Returns (status, sequences, counters): the first k sequences in
    (cost, lexicographic) order, fewer when fewer exist; counters are labels, nodes
    and settlements. STATUS_TOO_LARGE when labels, children and nodes outgrow
    ``budget_bytes`` (a third each), or labels ``max_labels``."""
    share = max(budget_bytes // 3, 1 << 16)
    labels = all_labels(budget_bytes) if max_labels is None else min(
        all_labels(budget_bytes), max_labels)
    status, res, lab_par, lab_elem, cnt = _astar(
        int(k), cp.n, cp.r, cp.lo, cp.cap, cp.stride, cp.off, cp.succ_ptr, cp.succ_elem,
        cp.succ_w, cp.front, cp.omega, cp.back, bounds.res, bounds.base, bounds.table,
        bounds.kernel_tables(), labels, share // KID_BYTES, share // NODE_BYTES)
    counters = {"labels": int(cnt[0]), "nodes": int(cnt[3]), "settled": int(cnt[4])}
    if status != STATUS_OK:
        return status, [], counters
    seqs = []
    for lab in res:
        seq = []
        x = lab_par[lab]  # an end label's parent is the last element's label
        while x > 0:      # label 0 is the source
            seq.append(int(lab_elem[x]))
            x = lab_par[x]
        seqs.append(seq[::-1])
    return status, seqs, counters
