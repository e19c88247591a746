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
  the element transition table whenever needed, so memory grows with nodes only.
* **Pruning.** Two completing passes give every forward-side node its exact h and
  every backward-side node its exact g. A node lies on a source→sink path iff both
  are finite; the rest are pruned (the k-best enumeration never visits them).

Storage is by *state row*: all nodes that share a consumed-resource vector c live in
one row of n values (g and h per element), and rows are the unit of the bucket queue.
Every node of a row has the same successor states, so a row is expanded with one
contiguous vector operation per successor element (min over e of g[e] + W[f, e]) —
the same inner loop as a plain dynamic program — instead of one table lookup per
edge. Rows are indexed by the state itself when the state box is small ("dense"),
else through a hash table that allocates rows only for states actually reached.
When the transition table is sparse (a motion graph: 32 successors out of 600) the
vector loops over all n elements would mostly meet "no transition"; the sweeps then
walk the successor and predecessor lists instead (:func:`_forward_level_lists`,
:func:`_backward_level_lists`), so a row costs its transitions, not n x n.
Kernels are numba-compiled; :func:`build_graph` is the only entry point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from citysynth.solver._table import (
    box_next,
    covers,
    decode,
    fits,
    grow_i32,
    grow_i64,
    hash_find,
    hash_put,
    table_rehash,
)
from citysynth.solver.compiled import Compiled
from citysynth.solver.interrupts import in_background

STATUS_OK = 0
STATUS_TOO_LARGE = 1
_FM = {"nnan", "nsz", "reassoc"}  # no NaNs ever occur; inf does, so no "ninf"


_SKIP, _FULL = -1, -2


@njit(cache=True)
def _row_of(s, create, nrows, limit, row_state, G, H, keys, vals, shift):
    """Hash mode: the row of state s, created empty when ``create`` (else _SKIP when
    absent; _FULL when ``limit`` rows exist). Returns (row, nrows).

    Dense tables skip this call at each site (``row = state``): the call passes five
    arrays, and doing it once per (row, successor) measurably slowed the dense sweeps
    (80 m street: 1.5 -> 2.4 ms)."""
    u = hash_find(keys, vals, shift, s)
    if u >= 0:
        return u, nrows
    if not create:
        return _SKIP, nrows
    if nrows >= limit:
        return _FULL, nrows
    row_state[nrows] = s
    G[nrows, :] = np.inf
    H[nrows, :] = np.inf
    hash_put(keys, vals, shift, s, nrows)
    return nrows, nrows + 1


# C901: a numba kernel, one loop nest on purpose (a call per row or successor is slower)
@njit(cache=True, fastmath=_FM)
def _forward_level(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, W, G, H,  # noqa: C901
                   row_state, headF, nxtF, inF, nrows, limit, create, mask_h,
                   dense, keys, vals, shift, c, gv, idx):
    """Push g from every row listed at ``head[lvl]`` to successor nodes whose level
    lies in [tmin, tmax]. Returns (nrows, work, completed).

    Rows are created (hash mode) only when ``create``; the caller has reserved room
    for ``limit`` rows, so no array is reallocated in here (numba keeps arrays that
    are never reassigned in registers — most of this loop's speed). With ``mask_h``
    only nodes with a finite h push (the completing pass)."""
    work = 0
    u = head[lvl]
    while u >= 0:
        s = row_state[u]
        decode(s, cap, stride, c)
        m = 0
        for e in range(n):
            x = G[u, e]
            if mask_h and H[u, e] == np.inf:
                x = np.inf
            gv[e] = x
            if x < np.inf:
                idx[m] = e
                m += 1
        if m > 0:
            sparse = 4 * m < n
            for f in range(n):
                l2 = lvl + lev[f]
                if l2 > tmax or l2 < tmin or not fits(c, r, f, cap):
                    continue
                best = np.inf
                if sparse:
                    for t in range(m):
                        v = gv[idx[t]] + W[f, idx[t]]
                        best = min(best, v)
                    work += m
                else:
                    for e in range(n):
                        best = min(best, gv[e] + W[f, e])
                    work += n
                if best == np.inf:
                    continue
                s2 = s + off[f]
                if dense:
                    u2 = s2
                else:
                    u2, nrows = _row_of(s2, create, nrows, limit, row_state, G, H,
                                        keys, vals, shift)
                    if u2 == _SKIP:
                        continue
                    if u2 == _FULL:
                        return nrows, work, False
                if best < G[u2, f]:
                    G[u2, f] = best
                    if inF[u2] == 0:
                        inF[u2] = 1
                        nxtF[u2] = headF[l2]
                        headF[l2] = u2
        u = nxt[u]
    return nrows, work, True


@njit(cache=True, fastmath=_FM)
def _backward_level(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, W, G, H,
                    row_state, headB, nxtB, inB, npred, nrows, limit, create, mask_g,
                    dense, keys, vals, shift, c):
    """Push h from every row listed at ``head[lvl]`` to predecessor nodes whose level
    lies in [tmin, tmax]; the mirror of :func:`_forward_level` (``mask_g``: only nodes
    with a finite g push). A predecessor p is relaxed at state c - r(e) even when p
    alone exceeds that state: such a node can never get a finite g, is pruned, and
    checking it per p would cost the vector loop its speed."""
    R = len(cap)
    work = 0
    u = head[lvl]
    while u >= 0:
        s = row_state[u]
        decode(s, cap, stride, c)
        for e in range(n):
            he = H[u, e]
            if he == np.inf or npred[e] == 0:
                continue
            if mask_g and G[u, e] == np.inf:
                continue
            lp = lvl - lev[e]
            if lp < tmin or lp > tmax:
                continue
            ok = True
            for i in range(R):
                if c[i] < r[e, i]:
                    ok = False
            if not ok:
                continue
            sp = s - off[e]
            if dense:
                up = sp
            else:
                up, nrows = _row_of(sp, create, nrows, limit, row_state, G, H,
                                    keys, vals, shift)
                if up == _SKIP:
                    continue
                if up == _FULL:
                    return nrows, work, False
            for p in range(n):
                H[up, p] = min(H[up, p], W[e, p] + he)
            work += n
            if inB[up] == 0:
                inB[up] = 1
                nxtB[up] = headB[lp]
                headB[lp] = up
        u = nxt[u]
    return nrows, work, True


@njit(cache=True, fastmath=_FM)
def _forward_level_lists(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, lists, G,
                         H, row_state, headF, nxtF, inF, nrows, limit, create, mask_h,
                         dense, keys, vals, shift, c, gv, idx):
    """:func:`_forward_level` over the successor lists: every finite g of a row offers
    g + w to each listed successor (the best per successor gathered in ``gv``, the
    successors touched in ``idx``), then each touched successor is checked and
    stored once. ``gv`` must hold inf on entry and holds inf again on return."""
    sptr, selem, sw = lists[0], lists[1], lists[2]
    work = 0
    u = head[lvl]
    while u >= 0:
        s = row_state[u]
        decode(s, cap, stride, c)
        m = 0
        for e in range(n):
            x = G[u, e]
            if x == np.inf or (mask_h and H[u, e] == np.inf):
                continue
            for j in range(sptr[e], sptr[e + 1]):
                f = selem[j]
                if gv[f] == np.inf:
                    idx[m] = f
                    m += 1
                gv[f] = min(gv[f], x + sw[j])
            work += sptr[e + 1] - sptr[e]
        for t in range(m):
            f = idx[t]
            best = gv[f]
            gv[f] = np.inf
            l2 = lvl + lev[f]
            if l2 > tmax or l2 < tmin or not fits(c, r, f, cap):
                continue
            s2 = s + off[f]
            if dense:
                u2 = s2
            else:
                u2, nrows = _row_of(s2, create, nrows, limit, row_state, G, H,
                                    keys, vals, shift)
                if u2 == _SKIP:
                    continue
                if u2 == _FULL:
                    for t2 in range(t + 1, m):
                        gv[idx[t2]] = np.inf
                    return nrows, work, False
            if best < G[u2, f]:
                G[u2, f] = best
                if inF[u2] == 0:
                    inF[u2] = 1
                    nxtF[u2] = headF[l2]
                    headF[l2] = u2
        u = nxt[u]
    return nrows, work, True


@njit(cache=True, fastmath=_FM)
def _backward_level_lists(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, lists,
                          G, H, row_state, headB, nxtB, inB, nrows, limit, create, mask_g,
                          dense, keys, vals, shift, c):
    """:func:`_backward_level` over the predecessor lists: a node's h reaches only its
    listed predecessors."""
    pptr, pelem, pw = lists[3], lists[4], lists[5]
    R = len(cap)
    work = 0
    u = head[lvl]
    while u >= 0:
        s = row_state[u]
        decode(s, cap, stride, c)
        for e in range(n):
            he = H[u, e]
            if he == np.inf or pptr[e + 1] == pptr[e] or (mask_g and G[u, e] == np.inf):
                continue
            lp = lvl - lev[e]
            if lp < tmin or lp > tmax:
                continue
            ok = True
            for i in range(R):
                if c[i] < r[e, i]:
                    ok = False
            if not ok:
                continue
            sp = s - off[e]
            if dense:
                up = sp
            else:
                up, nrows = _row_of(sp, create, nrows, limit, row_state, G, H,
                                    keys, vals, shift)
                if up == _SKIP:
                    continue
                if up == _FULL:
                    return nrows, work, False
            for j in range(pptr[e], pptr[e + 1]):
                p = pelem[j]
                H[up, p] = min(H[up, p], pw[j] + he)
            work += pptr[e + 1] - pptr[e]
            if inB[up] == 0:
                inB[up] = 1
                nxtB[up] = headB[lp]
                headB[lp] = up
        u = nxt[u]
    return nrows, work, True


@njit(cache=True)
def _fwd(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, W, lists, G, H, row_state,
         headF, nxtF, inF, nrows, limit, create, mask_h, dense, keys, vals, shift, c, gv,
         idx):
    """A forward sweep of one level, over the matrix or (``lists[6]`` set) the lists.
    The list sweep needs ``gv`` all inf; the matrix sweep overwrites it."""
    if lists[6][0]:
        return _forward_level_lists(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev,
                                    lists, G, H, row_state, headF, nxtF, inF, nrows, limit,
                                    create, mask_h, dense, keys, vals, shift, c, gv, idx)
    return _forward_level(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, W, G, H,
                          row_state, headF, nxtF, inF, nrows, limit, create, mask_h, dense,
                          keys, vals, shift, c, gv, idx)


@njit(cache=True)
def _bwd(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, W, lists, G, H, row_state,
         headB, nxtB, inB, npred, nrows, limit, create, mask_g, dense, keys, vals, shift, c):
    """A backward sweep of one level, over the matrix or (``lists[6]`` set) the lists."""
    if lists[6][0]:
        return _backward_level_lists(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev,
                                     lists, G, H, row_state, headB, nxtB, inB, nrows, limit,
                                     create, mask_g, dense, keys, vals, shift, c)
    return _backward_level(lvl, tmin, tmax, head, nxt, n, r, cap, stride, off, lev, W, G, H,
                           row_state, headB, nxtB, inB, npred, nrows, limit, create, mask_g,
                           dense, keys, vals, shift, c)


@njit(cache=True)
def _level_rows(head, nxt, lvl):
    m = 0
    u = head[lvl]
    while u >= 0:
        m += 1
        u = nxt[u]
    return m


@njit(cache=True)
def _reserve(need, nrows, G, H, row_state, nxtF, nxtB, inF, inB, dense, keys, vals, shift,
             max_rows):
    """Room for ``need`` more rows (arrays and hash table) before a level is expanded:
    doubled, but never past ``max_rows`` (doubling past it held up to twice the rows
    the memory budget allows, and a diagnosis reached 3.4 GB on a 2 GB budget)."""
    if dense:
        return G, H, row_state, nxtF, nxtB, inF, inB, keys, vals, shift
    if nrows + need > G.shape[0]:
        m = max(min(2 * G.shape[0], max_rows), nrows + need)
        G2 = np.empty((m, G.shape[1]))
        G2[:nrows] = G[:nrows]
        H2 = np.empty((m, G.shape[1]))
        H2[:nrows] = H[:nrows]
        G, H = G2, H2
        row_state = grow_i64(row_state, m)
        nxtF, nxtB = grow_i32(nxtF, m), grow_i32(nxtB, m)
        inF2 = np.zeros(m, dtype=np.uint8)
        inF2[:nrows] = inF[:nrows]
        inB2 = np.zeros(m, dtype=np.uint8)
        inB2[:nrows] = inB[:nrows]
        inF, inB = inF2, inB2
    while 2 * (nrows + need) > len(keys):
        keys, vals, shift = table_rehash(keys, vals, shift)
    return G, H, row_state, nxtF, nxtB, inF, inB, keys, vals, shift


@njit(cache=True)
def _front_roots(n, r, cap, off, lev, front, omega, G, H, row_state, headF, nxtF, inF,
                 nrows, max_rows, dense, keys, vals, shift, c):
    """Forward roots: g = omega for every front element that fits; returns the row
    count. Room is reserved."""
    for e in range(n):
        c[:] = 0
        if not (front[e] and fits(c, r, e, cap)):
            continue
        s = off[e]
        if dense:
            u = s
        else:
            u, nrows = _row_of(s, True, nrows, max_rows, row_state, G, H, keys, vals, shift)
        G[u, e] = omega[e]
        if inF[u] == 0:
            inF[u] = 1
            nxtF[u] = headF[lev[e]]
            headF[lev[e]] = u
    return nrows


@njit(cache=True)
def _back_roots(n, r, lo, cap, stride, back, H, row_state, G, headB, nxtB, inB, nrows,
                max_rows, dense, keys, vals, shift, c):
    """Backward roots: h = 0 for every back element on every admissible total (a
    mixed-radix counter over [lo, cap]); returns the row count. Room is reserved."""
    R = len(cap)
    for i in range(R):
        c[i] = lo[i]
    while True:
        s = 0
        lvl = 0
        for i in range(R):
            s += c[i] * stride[i]
            lvl += c[i]
        if dense:
            u = s
        else:
            u, nrows = _row_of(s, True, nrows, max_rows, row_state, G, H, keys, vals, shift)
        for e in range(n):
            if back[e] and covers(c, r, e):
                H[u, e] = 0.0
                if inB[u] == 0:
                    inB[u] = 1
                    nxtB[u] = headB[lvl]
                    headB[lvl] = u
        if not box_next(c, lo, cap):
            return nrows


@njit(cache=True)
def _complete(lam, top, maxlev, n, r, cap, stride, off, lev, W, lists, G, H, row_state,
              headF, nxtF, inF, headB, nxtB, inB, npred, nrows, dense, keys, vals, shift, c,
              gv, idx):
    """The two completing passes after the sides met at λ: exact h on the forward
    side, exact g on the backward side (no new rows)."""
    # exact h below λ: first the edges that cross λ, then downwards
    for lvl in range(lam, min(top, lam + maxlev - 1) + 1):
        _bwd(lvl, 0, lam - 1, headB, nxtB, n, r, cap, stride, off, lev, W, lists, G, H,
             row_state, headB, nxtB, inB, npred, nrows, nrows, False, False, dense, keys,
             vals, shift, c)
    for lvl in range(lam - 1, -1, -1):
        _bwd(lvl, 0, top, headF, nxtF, n, r, cap, stride, off, lev, W, lists, G, H,
             row_state, headB, nxtB, inB, npred, nrows, nrows, False, True, dense, keys,
             vals, shift, c)
    # exact g from λ up: first the edges that cross λ, then upwards
    for lvl in range(max(0, lam - maxlev), lam):
        _fwd(lvl, lam, top, headF, nxtF, n, r, cap, stride, off, lev, W, lists, G, H,
             row_state, headF, nxtF, inF, nrows, nrows, False, False, dense, keys, vals,
             shift, c, gv, idx)
    for lvl in range(lam, top + 1):
        _fwd(lvl, 0, top, headB, nxtB, n, r, cap, stride, off, lev, W, lists, G, H,
             row_state, headF, nxtF, inF, nrows, nrows, False, True, dense, keys, vals,
             shift, c, gv, idx)


@njit(cache=True)
def _grow_graph(n, r, lo, cap, stride, S, off, lev, top, W, npred,
                front, back, omega, dense, rows_hint, max_rows, forward_only, complete):
    """:func:`_grow` over the dense matrix W (the stage graphs build their own W)."""
    z = np.zeros(1, dtype=np.int64)
    lists = (z, z, np.zeros(1), z, z, np.zeros(1), np.zeros(1, dtype=np.bool_))
    return _grow(n, r, lo, cap, stride, S, off, lev, top, W, lists, npred, front, back,
                 omega, dense, rows_hint, max_rows, forward_only, complete)


# C901: a numba kernel: growth, meeting and both completing passes in one compiled
# call, inlined for speed. nogil: ``grow`` runs it in a thread the main thread waits on,
# so Ctrl-C is taken while it runs (solver.interrupts.in_background)
@njit(cache=True, nogil=True)
def _grow(n, r, lo, cap, stride, S, off, lev, top, W, lists, npred,  # noqa: C901
          front, back, omega, dense, rows_hint, max_rows, forward_only, complete):
    """Grow, meet and complete. ``lists`` = (succ_ptr, succ_elem, succ_w, pred_ptr,
    pred_elem, pred_w, [walk the lists]): with the flag set W is not read."""
    R = len(cap)
    if dense:
        m0 = S
    else:
        m0 = max(64, min(rows_hint, max_rows))
    G = np.empty((m0, n))
    H = np.empty((m0, n))
    row_state = np.empty(m0, dtype=np.int64)
    nxtF = np.full(m0, -1, dtype=np.int32)
    nxtB = np.full(m0, -1, dtype=np.int32)
    inF = np.zeros(m0, dtype=np.uint8)
    inB = np.zeros(m0, dtype=np.uint8)
    if dense:
        G[:, :] = np.inf
        H[:, :] = np.inf
        for i in range(S):
            row_state[i] = i
        keys = np.full(1, -1, dtype=np.int64)
        vals = np.full(1, -1, dtype=np.int32)
        shift = 0
        nrows = S
    else:
        bits = 6
        while (1 << bits) < 2 * m0:
            bits += 1
        keys = np.full(1 << bits, -1, dtype=np.int64)
        vals = np.full(1 << bits, -1, dtype=np.int32)
        shift = 64 - bits
        nrows = 0
    headF = np.full(top + 1, -1, dtype=np.int32)
    headB = np.full(top + 1, -1, dtype=np.int32)
    c = np.zeros(R, dtype=np.int64)
    gv = np.full(n, np.inf)
    idx = np.empty(n, dtype=np.int64)
    maxlev = np.max(lev)

    # Roots: front nodes forward; back nodes backward on every admissible total.
    n_adm = 1
    for i in range(R):
        n_adm *= max(cap[i] - lo[i] + 1, 0)
    if forward_only:
        n_adm = 0
    if not dense and n + n_adm > max_rows:  # dense rows are all allocated already
        return (STATUS_TOO_LARGE, nrows, G, H, row_state, 0, 0, 0), (keys, vals, shift)
    G, H, row_state, nxtF, nxtB, inF, inB, keys, vals, shift = _reserve(
        n + n_adm, nrows, G, H, row_state, nxtF, nxtB, inF, inB, dense, keys, vals, shift,
        max_rows)
    nrows = _front_roots(n, r, cap, off, lev, front, omega, G, H, row_state, headF, nxtF,
                         inF, nrows, max_rows, dense, keys, vals, shift, c)
    if n_adm > 0:
        nrows = _back_roots(n, r, lo, cap, stride, back, H, row_state, G, headB, nxtB, inB,
                            nrows, max_rows, dense, keys, vals, shift, c)

    # Bidirectional growth: the side that has done less work takes its next level.
    lf = 0
    lb = top
    work_f = 0
    work_b = 0
    while lf <= lb:
        fwd = forward_only or work_f <= work_b
        if fwd:
            need = _level_rows(headF, nxtF, lf) * n
        else:
            need = _level_rows(headB, nxtB, lb) * n
        need = min(need, max_rows - nrows)  # the worst case is rare; `limit` guards it
        G, H, row_state, nxtF, nxtB, inF, inB, keys, vals, shift = _reserve(
            need, nrows, G, H, row_state, nxtF, nxtB, inF, inB, dense, keys, vals, shift,
            max_rows)
        limit = nrows + need
        if fwd:
            nrows, work, done = _fwd(
                lf, 0, lb, headF, nxtF, n, r, cap, stride, off, lev, W, lists, G, H,
                row_state, headF, nxtF, inF, nrows, limit, True, False, dense, keys, vals,
                shift, c, gv, idx)
            work_f += work
            lf += 1
        else:
            nrows, work, done = _bwd(
                lb, lf, top, headB, nxtB, n, r, cap, stride, off, lev, W, lists, G, H,
                row_state, headB, nxtB, inB, npred, nrows, limit, True, False, dense, keys,
                vals, shift, c)
            work_b += work
            lb -= 1
        if not done:
            return (STATUS_TOO_LARGE, nrows, G, H, row_state, 0, 0, 0), (keys, vals, shift)
    lam = lf  # levels < lam were expanded forward, levels >= lam backward

    if complete:
        _complete(lam, top, maxlev, n, r, cap, stride, off, lev, W, lists, G, H, row_state,
                  headF, nxtF, inF, headB, nxtB, inB, npred, nrows, dense, keys, vals, shift,
                  c, gv, idx)
    return (STATUS_OK, nrows, G, H, row_state, lam, work_f, work_b), (keys, vals, shift)


@njit(cache=True)
def _count(G, H, row_state, nrows, r, cap, stride, c):
    """(nodes generated, nodes kept): valid nodes with g or h, and with both."""
    gen = 0
    kept = 0
    n = G.shape[1]
    for u in range(nrows):
        decode(row_state[u], cap, stride, c)
        for e in range(n):
            if G[u, e] < np.inf or H[u, e] < np.inf:
                if covers(c, r, e):
                    gen += 1
                    if G[u, e] < np.inf and H[u, e] < np.inf:
                        kept += 1
    return gen, kept


@dataclass
class Graph:
    """The grown, pruned intermediate graph: state rows of g and h, and the row table."""

    cp: Compiled
    nodes: int            # nodes generated
    kept: int             # nodes on a source→sink path
    meet_level: int       # λ
    rows: int
    G: np.ndarray         # [rows, n] cost from the source (inf: unreachable)
    H: np.ndarray         # [rows, n] cost to the sink (inf: no way to the sink)
    row_state: np.ndarray
    dense: bool
    keys: np.ndarray
    vals: np.ndarray
    shift: int
    work_f: int
    work_b: int


def grow(cp: Compiled, *, dense: bool, rows_hint: int, max_rows: int,
         forward_only: bool = False, complete: bool = True):
    """Run the growth kernel; returns ((status, rows, G, H, row_state, λ, work_f,
    work_b), hash_table)."""
    npred = np.diff(cp.pred_ptr).astype(np.int64)
    sparse = cp.sparse
    W = np.zeros((1, 1)) if sparse else cp.W
    lists = (cp.succ_ptr, cp.succ_elem, cp.succ_w, cp.pred_ptr, cp.pred_elem, cp.pred_w,
             np.full(1, sparse, dtype=np.bool_))
    return in_background(
        _grow, cp.n, cp.r, cp.lo, cp.cap, cp.stride, cp.S, cp.off, cp.lev, cp.top, W, lists,
        npred, cp.front, cp.back, cp.omega, dense, rows_hint, max_rows, forward_only, complete)


def build_graph(cp: Compiled, *, dense: bool, rows_hint: int, max_rows: int) -> Graph | None:
    """Grow, meet and prune. Returns None when the row budget was exceeded."""
    (status, nrows, G, H, row_state, lam, work_f, work_b), table = grow(
        cp, dense=dense, rows_hint=rows_hint, max_rows=max_rows)
    if status != STATUS_OK:
        return None
    keys, vals, shift = table
    gen, kept = _count(G, H, row_state, nrows, cp.r, cp.cap, cp.stride,
                       np.zeros(cp.R, dtype=np.int64))
    return Graph(cp, int(gen), int(kept), int(lam), int(nrows), G, H, row_state,
                 bool(dense), keys, vals, int(shift), int(work_f), int(work_b))
