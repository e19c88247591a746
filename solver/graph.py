"""The intermediate graph of Hartmann et al., "Efficient Multi-Constrained Optimization
for Example-Based Synthesis" (§3.1): nodes N(e, c) = (element, consumed resources).

Construction, as the paper describes it and as we make it fast:

* **Bidirectional growth ordered by resource consumption.** The level of a node is
  the sum of its consumed quanta; every element consumes at least one, so edges go
  strictly up in level and the graph is a DAG whose topological order is the level.
  Forward growth starts at the front elements (lowest level first), backward growth
  at the back elements on *every* admissible total (highest level first). Levels are
  small integers, so each direction is a bucket queue: one linked list per level.
* **Meeting in the middle.** Each level is expanded by exactly one side: the side
  that has done less work so far takes its next level, until they meet at level λ.
  A forward node's cost-from-source g is final when its level is expanded, a
  backward node's cost-to-sink h likewise, so the sweeps double as the two halves of
  the shortest-path dynamic program.
* **Implicit edges.** An edge is (node, successor element); it is regenerated from
  the element successor table whenever needed, so memory grows with nodes only.
* **Pruning.** A final pass gives every forward-side node its exact h and every
  backward-side node its exact g. A node lies on a source→sink path iff both are
  finite; the rest are pruned (never visited by the k-best enumeration).

The node table is dense or hashed (:mod:`solver._table`). Kernels are numba-compiled
over flat arrays; :func:`build_graph` is the only entry point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ._table import (
    admissible,
    covers,
    decode,
    fits,
    grow_f64,
    grow_i32,
    grow_i64,
    hash_find,
    hash_put,
    table_new,
    table_rehash,
)
from .compiled import Compiled

INF = math.inf
STATUS_OK = 0
STATUS_TOO_LARGE = 1


@njit(cache=True)
def _expand_forward(lf, lb, n, r, cap, stride, off, lev, succ_ptr, succ_elem, succ_w,
                    elem, state, g, h, nxf, nxb, headF, nn, limit,
                    dense, tab, keys, vals, shift, c):
    """Expand every forward node on level lf; returns (nn, work, completed).

    The caller reserves room for ``limit`` nodes beforehand: arrays are never
    reallocated in here (numba keeps arrays that are never reassigned in registers,
    which is most of the speed of this loop). Reaching ``limit`` stops the expansion
    and reports it unfinished."""
    work = 0
    u = headF[lf]
    while u >= 0:
        e = elem[u]
        s = state[u]
        gu = g[u]
        decode(s, cap, stride, c)
        work += 1 + succ_ptr[e + 1] - succ_ptr[e]
        for j in range(succ_ptr[e], succ_ptr[e + 1]):
            f = succ_elem[j]
            if not fits(c, r, f, cap):
                continue
            l2 = lf + lev[f]
            if l2 > lb:
                continue  # the backward side owns that level: the sweeps meet there
            key = (s + off[f]) * n + f
            if dense:
                v = np.int64(tab[key])
            else:
                v = hash_find(keys, vals, shift, key)
            if v < 0:
                if nn >= limit:
                    return nn, work, False
                v = nn
                elem[v] = f
                state[v] = s + off[f]
                g[v] = np.inf
                h[v] = np.inf
                nxb[v] = -1
                if dense:
                    tab[key] = v
                else:
                    hash_put(keys, vals, shift, key, v)
                nn += 1
            ng = gu + succ_w[j]
            if ng < g[v]:
                if g[v] == np.inf:
                    nxf[v] = headF[l2]
                    headF[l2] = v
                g[v] = ng
        u = nxf[u]
    return nn, work, True


@njit(cache=True)
def _expand_backward(lb, lf, n, r, cap, stride, off, lev, pred_ptr, pred_elem, pred_w,
                     elem, state, g, h, nxf, nxb, headB, nn, limit,
                     dense, tab, keys, vals, shift, c, cp):
    """Expand every backward node on level lb; returns (nn, work, completed). Same
    contract as :func:`_expand_forward`."""
    R = len(cap)
    work = 0
    v = headB[lb]
    while v >= 0:
        e = elem[v]
        s = state[v]
        hv = h[v]
        decode(s, cap, stride, c)
        work += 1 + pred_ptr[e + 1] - pred_ptr[e]
        # the predecessor state is c - r(e); nothing precedes when it is negative
        neg = False
        for i in range(R):
            cp[i] = c[i] - r[e, i]
            if cp[i] < 0:
                neg = True
        lp = lb - lev[e]
        if not neg and lp >= lf:
            sp = s - off[e]
            for j in range(pred_ptr[e], pred_ptr[e + 1]):
                p = pred_elem[j]
                if not covers(cp, r, p):
                    continue
                key = sp * n + p
                if dense:
                    u = np.int64(tab[key])
                else:
                    u = hash_find(keys, vals, shift, key)
                if u < 0:
                    if nn >= limit:
                        return nn, work, False
                    u = nn
                    elem[u] = p
                    state[u] = sp
                    g[u] = np.inf
                    h[u] = np.inf
                    nxf[u] = -1
                    if dense:
                        tab[key] = u
                    else:
                        hash_put(keys, vals, shift, key, u)
                    nn += 1
                nh = pred_w[j] + hv
                if nh < h[u]:
                    if h[u] == np.inf:
                        nxb[u] = headB[lp]
                        headB[lp] = u
                    h[u] = nh
        v = nxb[v]
    return nn, work, True


@njit(cache=True)
def _level_size(head, nxt, lvl):
    m = 0
    u = head[lvl]
    while u >= 0:
        m += 1
        u = nxt[u]
    return m


@njit(cache=True)
def _grow_graph(n, r, lo, cap, stride, S, off, lev, top,
                succ_ptr, succ_elem, succ_w, pred_ptr, pred_elem, pred_w,
                front, back, omega, dense, size_hint, max_nodes, forward_only):
    R = len(cap)
    tab, keys, vals, shift = table_new(dense, size_hint, S * n if dense else 1)
    m0 = max(1024, min(size_hint, max_nodes) + 1)
    elem = np.empty(m0, dtype=np.int32)
    state = np.empty(m0, dtype=np.int64)
    g = np.empty(m0, dtype=np.float64)
    h = np.empty(m0, dtype=np.float64)
    nxf = np.empty(m0, dtype=np.int32)
    nxb = np.empty(m0, dtype=np.int32)
    headF = np.full(top + 1, -1, dtype=np.int32)
    headB = np.full(top + 1, -1, dtype=np.int32)
    nn = 0
    c = np.zeros(R, dtype=np.int64)
    cp = np.zeros(R, dtype=np.int64)
    deg_f = np.max(succ_ptr[1:] - succ_ptr[:-1])
    deg_b = np.max(pred_ptr[1:] - pred_ptr[:-1])

    # Roots: front nodes forward, back nodes on every admissible total backward. We
    # count them first so the arrays are sized once.
    n_adm = 1
    for i in range(R):
        n_adm *= max(cap[i] - lo[i] + 1, 0)
    if forward_only:
        n_adm = 0
    need = n + n_adm * n
    if need > max_nodes:
        return (STATUS_TOO_LARGE, nn, elem, state, g, h, headF, headB, nxf, nxb,
                tab, keys, vals, shift, 0, 0, 0)
    elem, state, g, h, nxf, nxb, keys, vals, shift = _reserve(
        need, nn, elem, state, g, h, nxf, nxb, dense, keys, vals, shift)

    for i in range(R):
        c[i] = 0
    for e in range(n):
        if front[e] and fits(c, r, e, cap):
            elem[nn] = e
            state[nn] = off[e]
            g[nn] = omega[e]
            h[nn] = np.inf
            nxf[nn] = headF[lev[e]]
            headF[lev[e]] = nn
            nxb[nn] = -1
            if dense:
                tab[off[e] * n + e] = nn
            else:
                hash_put(keys, vals, shift, off[e] * n + e, nn)
            nn += 1
    if n_adm > 0:
        for i in range(R):
            c[i] = lo[i]
        while True:
            s = 0
            lvl = 0
            for i in range(R):
                s += c[i] * stride[i]
                lvl += c[i]
            for e in range(n):
                if back[e] and covers(c, r, e):
                    key = s * n + e
                    if dense:
                        v = np.int64(tab[key])
                    else:
                        v = hash_find(keys, vals, shift, key)
                    if v < 0:
                        v = nn
                        elem[v] = e
                        state[v] = s
                        g[v] = np.inf
                        nxf[v] = -1
                        if dense:
                            tab[key] = v
                        else:
                            hash_put(keys, vals, shift, key, v)
                        nn += 1
                    nxb[v] = headB[lvl]
                    headB[lvl] = v
                    h[v] = 0.0
            i = 0  # next admissible total: a mixed-radix counter over [lo, cap]
            while i < R:
                c[i] += 1
                if c[i] <= cap[i]:
                    break
                c[i] = lo[i]
                i += 1
            if i == R:
                break

    # Bidirectional growth: the side that has done less work takes its next level.
    lf = 0
    lb = top
    work_f = 0
    work_b = 0
    while lf <= lb:
        fwd = forward_only or work_f <= work_b
        if fwd:
            need = _level_size(headF, nxf, lf) * deg_f
        else:
            need = _level_size(headB, nxb, lb) * deg_b
        need = min(need, max_nodes - nn)  # the worst case rarely happens; the
        elem, state, g, h, nxf, nxb, keys, vals, shift = _reserve(  # limit guards it
            need, nn, elem, state, g, h, nxf, nxb, dense, keys, vals, shift)
        limit = nn + need
        if fwd:
            nn, work, done = _expand_forward(lf, lb, n, r, cap, stride, off, lev, succ_ptr,
                                             succ_elem, succ_w, elem, state, g, h, nxf, nxb,
                                             headF, nn, limit, dense, tab, keys, vals, shift,
                                             c)
            work_f += work
            lf += 1
        else:
            nn, work, done = _expand_backward(lb, lf, n, r, cap, stride, off, lev, pred_ptr,
                                              pred_elem, pred_w, elem, state, g, h, nxf, nxb,
                                              headB, nn, limit, dense, tab, keys, vals, shift,
                                              c, cp)
            work_b += work
            lb -= 1
        if not done:
            return (STATUS_TOO_LARGE, nn, elem, state, g, h, headF, headB, nxf, nxb,
                    tab, keys, vals, shift, 0, 0, 0)
    lam = lf  # levels < lam were expanded forward, levels >= lam backward
    return (STATUS_OK, nn, elem, state, g, h, headF, headB, nxf, nxb,
            tab, keys, vals, shift, lam, work_f, work_b)


@njit(cache=True)
def _reserve(need, nn, elem, state, g, h, nxf, nxb, dense, keys, vals, shift):
    """Make room for ``need`` more nodes (arrays and hash table) before a level."""
    if nn + need > len(elem):
        m = max(2 * len(elem), nn + need)
        elem, state = grow_i32(elem, m), grow_i64(state, m)
        g, h = grow_f64(g, m), grow_f64(h, m)
        nxf, nxb = grow_i32(nxf, m), grow_i32(nxb, m)
    if not dense:
        while 2 * (nn + need) > len(keys):
            keys, vals, shift = table_rehash(keys, vals, shift)
    return elem, state, g, h, nxf, nxb, keys, vals, shift


@njit(cache=True)
def _complete(n, r, lo, cap, stride, off, top, succ_ptr, succ_elem, succ_w,
              pred_ptr, pred_elem, pred_w, front, back, omega,
              elem, state, g, h, headF, headB, nxf, nxb, nn,
              dense, tab, keys, vals, shift, lam):
    """Exact h below λ (descending) and exact g from λ up (ascending); count kept nodes."""
    R = len(cap)
    c = np.zeros(R, dtype=np.int64)
    cp = np.zeros(R, dtype=np.int64)
    for lvl in range(min(lam, top + 1) - 1, -1, -1):
        u = headF[lvl]
        while u >= 0:
            e = elem[u]
            s = state[u]
            decode(s, cap, stride, c)
            best = np.inf
            if back[e] and admissible(c, lo):
                best = 0.0
            for j in range(succ_ptr[e], succ_ptr[e + 1]):
                f = succ_elem[j]
                if not fits(c, r, f, cap):
                    continue
                if dense:
                    v = np.int64(tab[(s + off[f]) * n + f])
                else:
                    v = hash_find(keys, vals, shift, (s + off[f]) * n + f)
                if v >= 0:
                    val = succ_w[j] + h[v]
                    if val < best:
                        best = val
            h[u] = best
            u = nxf[u]
    for lvl in range(lam, top + 1):
        v = headB[lvl]
        while v >= 0:
            e = elem[v]
            s = state[v]
            decode(s, cap, stride, c)
            best = np.inf
            if front[e] and s == off[e]:
                best = omega[e]
            neg = False
            for i in range(R):
                cp[i] = c[i] - r[e, i]
                if cp[i] < 0:
                    neg = True
            if not neg:
                sp = s - off[e]
                for j in range(pred_ptr[e], pred_ptr[e + 1]):
                    p = pred_elem[j]
                    if not covers(cp, r, p):
                        continue
                    if dense:
                        u = np.int64(tab[sp * n + p])
                    else:
                        u = hash_find(keys, vals, shift, sp * n + p)
                    if u >= 0:
                        val = g[u] + pred_w[j]
                        if val < best:
                            best = val
            g[v] = best
            v = nxb[v]
    kept = 0
    for u in range(nn):
        if g[u] < np.inf and h[u] < np.inf:
            kept += 1
    return kept


@dataclass
class Graph:
    """The grown, pruned intermediate graph (node arrays + the node table)."""

    cp: Compiled
    nodes: int            # nodes generated
    kept: int             # nodes on a source→sink path
    meet_level: int       # λ
    elem: np.ndarray
    state: np.ndarray
    g: np.ndarray
    h: np.ndarray
    dense: bool
    tab: np.ndarray
    keys: np.ndarray
    vals: np.ndarray
    shift: int
    work_f: int
    work_b: int


def grow(cp: Compiled, *, dense: bool, size_hint: int, max_nodes: int,
         forward_only: bool = False):
    """Run the growth kernel; returns the raw tuple (status first)."""
    return _grow_graph(
        cp.n, cp.r, cp.lo, cp.cap, cp.stride, cp.S, cp.off, cp.lev, cp.top,
        cp.succ_ptr, cp.succ_elem, cp.succ_w, cp.pred_ptr, cp.pred_elem, cp.pred_w,
        cp.front, cp.back, cp.omega, dense, size_hint, max_nodes, forward_only,
    )


def build_graph(cp: Compiled, *, dense: bool, size_hint: int, max_nodes: int) -> Graph | None:
    """Grow, meet and prune. Returns None when the node budget was exceeded."""
    (status, nn, elem, state, g, h, headF, headB, nxf, nxb,
     tab, keys, vals, shift, lam, work_f, work_b) = grow(
        cp, dense=dense, size_hint=size_hint, max_nodes=max_nodes)
    if status != STATUS_OK:
        return None
    kept = _complete(
        cp.n, cp.r, cp.lo, cp.cap, cp.stride, cp.off, cp.top,
        cp.succ_ptr, cp.succ_elem, cp.succ_w, cp.pred_ptr, cp.pred_elem, cp.pred_w,
        cp.front, cp.back, cp.omega, elem, state, g, h, headF, headB, nxf, nxb, nn,
        dense, tab, keys, vals, shift, lam,
    )
    return Graph(cp, int(nn), int(kept), int(lam), elem[:nn], state[:nn],
                 g[:nn], h[:nn], bool(dense), tab, keys, vals, int(shift),
                 int(work_f), int(work_b))
