"""The k best structures of a chain or a cycle, lazily: the combining program of
:mod:`citysynth.solver.structures.combine` for structures whose key points each have
at most one stage out (block outlines, streets), with at most one structure-wide
resource.

Why: the general program builds, for every key point, element and share of the
structure-wide resource, the k best completions in full, and wants k paths of every
stage list up front; on a 40-corner block with a per-block door count that is
hundreds of thousands of sums and 6,480 lists of k paths, nearly all of which no
structure among the k best ever uses. Here the completions form a DAG over
(key point, element, share) whose k best paths are enumerated the lazy way of
:mod:`citysynth.solver.kbest` (Jiménez & Marzal; Huang & Chiang's Algorithm 3):

* the best completion of every node is one min-plus pass over the shares, on arrays
  (:func:`_first_items`), from the first entry of every stage list;
* a node's next completions come from a heap of candidates "stage list entry i, then
  completion j of the node after it", created only when a node is asked for its
  second completion; popping (i, j) offers (i, j + 1), and (i + 1, 0) after (i, 0),
  each asked for only then (a stage list finds more paths on demand, ``more``);
  entry 1 of a list with one path so far is offered at a lower bound on its cost
  (``second``) and its path found only if that candidate becomes the least, which
  most never do (a candidate may wait under a key below its own: it is taken only
  once found, so the pops keep their order);
* the results are a merge of the root's streams, read back through links that
  completions share (one per completion), copied into rows only for the k returned.

Exactly the same sums, in the same order, as the general program: a candidate costs
stage + (completion + unary cost of the element between), ties go to the end element
in key point order, then the smaller stage share, then the entry positions; the
root's streams merge by (cost, element at the root, share, position), as its stable
sort did. A test compares the two on generated structures.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from citysynth.solver.structures.model import Structure

SMALL_START = 32   # at most this many first pairs: a node's heap made without arrays
Share = tuple[int, ...]
StageList = list[tuple[float, Any]]
Payload = dict[int, tuple[str, Any, "Payload"]]
Item = tuple[float, int, int, int]      # (cost, pair t = end element * S + share, i, j)
# a structure read back: the element at every key point, the fillers and totals of
# every stage (see ChainProgram's ``read``); each structure's own lists
Rows = tuple[list[str], list[list[str]], list[dict[str, float]]]
# a completion read back (ChainProgram._link): the key point at its position and the
# element there, then its stage, that stage's fillers and totals (the reader's own,
# -1 and None at the leaf of an open chain), and the completion after it (None at the
# end). Completions share the ones after them, so reading one back adds one tuple
Link = tuple[int, str, int, "list[str] | None", "dict[str, float] | None", "Link | None"]
Read = Callable[[int, str, str, Any], tuple[list[str], dict[str, float]]]


def chain_of(st: Structure, ghi: list[int]) -> tuple[list[int], list[int]] | None:
    """The key points from the root and the stage out of each, when every key point
    has at most one stage out, its elements are distinct and there is at most one
    structure-wide resource; else None (the general program)."""
    if len(ghi) > 1 or any(len(set(kp)) != len(kp) for kp in st.keypoints):
        return None
    out: dict[int, int] = {}
    for i, s in enumerate(st.stages):
        if s.start in out:
            return None
        out[s.start] = i
    if st.closed:
        root = 0
    else:
        ends = {s.end for s in st.stages}
        roots = [v for v in range(len(st.keypoints)) if v not in ends]
        if len(roots) != 1:
            return None
        root = roots[0]
    keys: list[int] = [root]
    stages: list[int] = []
    while keys[-1] in out and len(stages) < len(st.stages):
        si = out[keys[-1]]
        stages.append(si)
        nxt = st.stages[si].end
        if nxt == root:
            break
        keys.append(nxt)
    if len(stages) != len(st.stages) or (st.closed and st.stages[stages[-1]].end != root):
        return None
    return keys, stages


@njit(cache=True)
def _first_items(A, cf, ne, closed, r):
    """Best completion of every (chain position, element, share) and its pair.

    A[l, e, f, g]: cost of the first entry of stage l's list from element e to f
    with share g (inf: none); cf[l, f] the unary cost of element f at position l;
    ne[l] the number of elements there. A cycle (``closed``) returns to element r
    of position 0: its last stage's list is the completion itself. Returns B
    [positions, E, S] and arg (t = f * S + g1, -1 for none), the first minimum in
    (f, g1) order, summed as stage + (completion + unary)."""
    L, E, _, S = A.shape
    P = L if closed else L + 1
    B = np.full((P, E, S), np.inf)
    arg = np.full((P, E, S), -1, dtype=np.int64)
    if closed:
        last = L - 1
        for e in range(ne[last]):
            for g in range(S):
                if A[last, e, r, g] < np.inf:
                    B[last, e, g] = A[last, e, r, g]
                    arg[last, e, g] = r * S + g
        top = L - 2
    else:
        for e in range(ne[L]):   # the leaf: one empty completion
            B[L, e, 0] = 0.0
            arg[L, e, 0] = 0
        top = L - 1
    for l in range(top, -1, -1):
        for e in range(ne[l]):
            # every (f, g1, g2) with both present, f then g1 ascending: for each share
            # g = g1 + g2 the pairs come in (f, g1) order, and "<" keeps the first
            for f in range(ne[l + 1]):
                cfl = cf[l + 1, f]
                for g1 in range(S):
                    a = A[l, e, f, g1]
                    if a == np.inf:
                        continue
                    for g2 in range(S - g1):
                        b = B[l + 1, f, g2]
                        if b == np.inf:
                            continue
                        c = a + (b + cfl)
                        if c < B[l, e, g1 + g2]:
                            B[l, e, g1 + g2] = c
                            arg[l, e, g1 + g2] = f * S + g1
    return B, arg


@njit(cache=True)
def _first_pairs(a, b, cf, S):
    """A node's first candidates: cost a[f, g1] + (b[f, g1] + cf[f]) and pair
    f * S + g1 of every pair with both terms finite, sorted by (cost, pair) (a stable
    sort of the pairs made in ascending order)."""
    F, G = a.shape
    c = np.empty(F * G)
    t = np.empty(F * G, dtype=np.int64)
    m = 0
    for f in range(F):
        for g1 in range(G):
            x = a[f, g1]
            y = b[f, g1]
            if x < np.inf and y < np.inf:
                c[m] = x + (y + cf[f])
                t[m] = f * S + g1
                m += 1
    order = np.argsort(c[:m], kind="mergesort")
    return c[:m][order], t[:m][order]


class _Node:
    """The completions of one (position, element, share) found so far."""

    __slots__ = ("items", "heap", "rest", "at", "pending", "done", "links")

    def __init__(self, first: Item | None):
        self.items: list[Item] = [] if first is None else [first]
        self.heap: list[Item] | None = None
        # many first candidates (_start_heap): their costs and pairs sorted by (cost,
        # pair), rest[.][at:] not taken yet, kept out of the heap
        self.rest: tuple[list[float], list[int]] | None = None
        self.at = 0
        self.pending: Item | None = None   # popped, its successors not offered yet
        self.done = first is None
        self.links: dict[int, Link] | None = None   # completions read back (_link), by j


def _pop(node: _Node, heap: list[Item], offers: list[Item]) -> Item | None:
    """A node's least candidate once ``offers`` join its heap, taken out (None: none
    left). With first candidates still in ``node.rest`` (sorted), the least of them
    not taken yet against the least in the heap: together the least of all, as one
    heap of them all would pop it (keys are distinct: a first candidate has i = j = 0,
    an offer not)."""
    rest = node.rest
    if rest is not None and node.at < len(rest[0]):
        for x in offers:
            heapq.heappush(heap, x)
        first = (rest[0][node.at], rest[1][node.at], 0, 0)
        if heap and heap[0] < first:
            return heapq.heappop(heap)
        node.at += 1
        return first
    if offers:   # push all but the last, then push it and pop the least at once
        for x in offers[:-1]:
            heapq.heappush(heap, x)
        return heapq.heappushpop(heap, offers[-1])
    return heapq.heappop(heap) if heap else None


class ChainProgram:
    """The k best structures of a chain or cycle (see the module docstring).

    ``stage_lists(s, a, b)``: share -> cost-sorted list, as for the general program.
    A list may say that only its ``final`` leading entries are final (more paths may
    follow, :class:`citysynth.solver.structures.stage_kbest.Growing`); ``more(s, a, b,
    share)`` then replaces it by a longer one and returns its new ``final`` count (k
    once complete). Without ``final`` a list is complete. ``second(s, a, b, share)``:
    a lower bound on the cost of entry 1 of such a list, which is then found only
    when needed (see :meth:`_offers`). ``firsts``: the cost of every
    list's first entry, C[stage, start element, end element, share] (elements by their
    index at their key point, inf for none; see ``StageGraphs.first_costs``), when
    the provider has them without making the lists: then a list is only asked for
    when the enumeration reads it. ``read(s, a, b, payload)``: the fillers and totals of
    a stage list entry (the provider's ``filling``, once per entry); with it the
    structures come back as :data:`Rows` instead of payloads (see :meth:`_link`)."""

    def __init__(self, st: Structure, k: int, ghi: list[int], glo: list[int],
                 chain: tuple[list[int], list[int]],
                 stage_lists: Callable[[int, str, str], dict[Share, StageList]],
                 more: Callable[[int, str, str, Share], int] | None = None,
                 firsts: np.ndarray | None = None, read: Read | None = None,
                 second: Callable[[int, str, str, Share], float] | None = None):
        self.st, self.k, self.glo = st, k, glo
        self.keys, self.stages = chain
        self.stage_lists, self._more, self._second = stage_lists, more, second
        self.one = len(ghi) == 1
        self.S = ghi[0] + 1 if self.one else 1
        self.elems = [list(st.keypoints[v]) for v in self.keys]
        if not st.closed:   # the leaf after the last stage
            self.elems.append(list(st.keypoints[st.stages[self.stages[-1]].end]))
        self.L = len(self.stages)
        self.E = max(len(x) for x in self.elems)
        self.cf = np.zeros((len(self.elems), self.E))
        for p, es in enumerate(self.elems):
            self.cf[p, :len(es)] = [st.costs[e] for e in es]
        self.ne = np.array([len(es) for es in self.elems], dtype=np.int64)
        self.cfl: list[list[float]] = self.cf.tolist()
        self.shares: list[Share] = [self.share(g) for g in range(self.S)]
        self.last = self.L - 1 if st.closed else -1   # the position closing a cycle
        # the provider's lists by position, start and end element, asked for once
        self.lists: list[list[list[dict[Share, StageList] | None]]] = [
            [[None] * len(self.elems[(p + 1) % len(self.elems)]) for _e in self.elems[p]]
            for p in range(self.L)]
        self._payloads: dict[tuple[int, int, int, int, int], Payload] = {}
        self.read = read
        self.kps = list(self.keys) + ([] if st.closed else [st.stages[self.stages[-1]].end])
        if firsts is not None:   # by stage: by position here (as it is, when in order)
            A = firsts if self.stages == list(range(self.L)) else firsts[self.stages]
            self.A = np.ascontiguousarray(A[:, :self.E, :self.E, :self.S])
        else:
            self.A = self._first_entries()

    def _first_entries(self) -> np.ndarray:
        """The first entry of every list (made final first), as ``A`` holds them."""
        A = np.full((self.L, self.E, self.E, self.S), np.inf)
        at: list[int] = []      # flat indices into A and the first entries' costs
        firsts: list[float] = []
        for p, s in enumerate(self.stages):
            ends = self.elems[(p + 1) % len(self.elems)]
            for ei, e in enumerate(self.elems[p]):
                for fi, f in enumerate(ends):
                    base = ((p * self.E + ei) * self.E + fi) * self.S
                    lists = self._lists(p, ei, fi)
                    for share, ls in lists.items():
                        if getattr(ls, "final", 1) < 1:   # entry 0 final first
                            self._grow(s, e, f, share, 0)
                            ls = lists[share]
                        if ls:
                            at.append(base + (share[0] if self.one else 0))
                            firsts.append(ls[0][0])
        A.reshape(-1)[at] = firsts
        return A

    def _lists(self, p: int, ei: int, fi: int) -> dict[Share, StageList]:
        """The provider's lists of stage position p from element ei to fi by share (its
        own dict: lists grow in place)."""
        row = self.lists[p][ei]
        got = row[fi]
        if got is None:
            got = row[fi] = self.stage_lists(self.stages[p], self.elems[p][ei],
                                             self.elems[(p + 1) % len(self.elems)][fi])
        return got

    def _grow(self, s: int, e: str, f: str, share: Share, i: int) -> None:
        """Ask for more paths until entry i of a list is final (or known absent)."""
        if self._more is None:
            raise AssertionError("a stage list that may grow, and no way to grow it")
        while self._more(s, e, f, share) <= i:
            pass

    def share(self, g: int) -> Share:
        return (g,) if self.one else ()

    def _entry(self, p: int, ei: int, fi: int, share: Share, i: int
               ) -> tuple[float, Any] | None:
        """Entry i of the list of stage position p from element ei to fi, or None;
        finds more paths first when entry i is not final yet (entry 0 always is,
        from the constructor on)."""
        lists = self.lists[p][ei][fi]
        if lists is None:
            lists = self._lists(p, ei, fi)
        ls = lists.get(share)
        if ls is None or i >= self.k:
            return None
        if i >= getattr(ls, "final", self.k):
            self._grow(self.stages[p], self.elems[p][ei],
                       self.elems[(p + 1) % len(self.elems)][fi], share, i)
            ls = lists[share]
        return ls[i] if i < len(ls) else None

    # ---- lazy enumeration ---------------------------------------------------------
    def run(self) -> list[tuple[float, str, Payload | Rows]]:
        st, S = self.st, self.S
        heap: list[tuple[float, int, int]] = []
        streams: list[tuple[dict[tuple[int, int, int], _Node], int, int, np.ndarray,
                            np.ndarray]] = []
        roots = self.elems[0]
        lo = self.glo[0] if self.one else 0
        shared: tuple[np.ndarray, np.ndarray] | None = None
        for ri, e in enumerate(roots):
            if st.closed:
                B, arg = _first_items(self.A, self.cf, self.ne, True, ri)
            else:
                if shared is None:
                    shared = _first_items(self.A, self.cf, self.ne, False, 0)
                B, arg = shared
            nodes: dict[tuple[int, int, int], _Node] = {}
            for g in range(lo, S):
                c = float(B[0, ri, g])
                if c < np.inf:
                    heap.append((c + st.costs[e], len(streams), 0))
                    streams.append((nodes, ri, g, B, arg))
        heapq.heapify(heap)
        results: list[tuple[float, str, Payload | Rows]] = []
        while heap and len(results) < self.k:
            c, t, j = heapq.heappop(heap)
            nodes, ri, g, B, arg = streams[t]
            results.append((c, roots[ri], self._payload(nodes, B, arg, 0, ri, g, j)
                            if self.read is None else
                            self._rows(self._link(nodes, B, arg, 0, ri, g, j))))
            if len(results) == self.k:
                break
            nxt = self._item(nodes, B, arg, 0, ri, g, j + 1)
            if nxt is not None:
                heapq.heappush(heap, (nxt[0] + st.costs[roots[ri]], t, j + 1))
        return results

    def _node(self, nodes: dict[tuple[int, int, int], _Node], B: np.ndarray,
              arg: np.ndarray, p: int, ei: int, g: int) -> _Node:
        key = (p, ei, g)
        node = nodes.get(key)
        if node is None:
            t = int(arg[p, ei, g])
            node = _Node(None if t < 0 else (float(B[p, ei, g]), t, 0, 0))
            nodes[key] = node
        return node

    def _item(self, nodes: dict[tuple[int, int, int], _Node], B: np.ndarray,
              arg: np.ndarray, p: int, ei: int, g: int, j: int) -> Item | None:
        """Completion j of (position p, element ei, share g), or None."""
        node = nodes.get((p, ei, g))
        if node is None:
            node = self._node(nodes, B, arg, p, ei, g)
        items = node.items
        if j < len(items):
            return items[j]
        if j >= self.k:
            return None
        while len(items) <= j and not node.done:
            self._advance(nodes, B, arg, p, ei, g, node)
        return items[j] if j < len(items) else None

    def _is_last(self, p: int) -> bool:
        """Position p's stage closes the cycle: its completions are its list."""
        return self.st.closed and p == self.L - 1

    def _advance(self, nodes: dict[tuple[int, int, int], _Node], B: np.ndarray,
                 arg: np.ndarray, p: int, ei: int, g: int, node: _Node) -> None:
        """Find the node's next completion (or mark it done)."""
        if len(node.items) >= self.k or p == self.L:   # an open chain's leaf: one
            node.done = True                            # empty completion
            return
        if p == self.last:
            self._advance_closing(p, ei, g, node)
            return
        if node.heap is None:
            self._start_heap(B, p, ei, g, node)
        heap = node.heap
        assert heap is not None
        offers = [] if node.pending is None else \
            self._offers(nodes, B, arg, p, ei, g, node.pending)
        node.pending = None
        item = _pop(node, heap, offers)
        while item is not None and item[3] < 0:   # offered at a bound: find its entry
            item = _pop(node, heap, self._resolve(nodes, p, ei, g, item))
        if item is None:
            node.done = True
        else:
            node.items.append(item)
            node.pending = item

    def _offers(self, nodes: dict[tuple[int, int, int], _Node], B: np.ndarray,
                arg: np.ndarray, p: int, ei: int, g: int, taken: Item) -> list[Item]:
        """The candidates a node offers once it took (i, j): (i, j + 1), and (i + 1, 0)
        after (i, 0). Every pair once, each after one with a smaller key, so the pops
        are all pairs in key order exactly as the general program's heap (which offers
        both and keeps a seen set) pops them.

        (i, j + 1) needs completion j + 1 of the node after, found now if it is not
        yet: the recursion of the lazy program, once per key point a structure's
        completions go down. (i + 1, 0) needs entry i + 1 of the stage list: read
        directly when it is found and final (most are), else found (``more``); but
        entry 1 of a list that has one path so far is offered at a lower bound on its
        cost (``second``, the provider's, without the path) and found only when that
        is the least candidate (:meth:`_resolve`): most such lists never get that far
        (100 structures of a 40-corner block offer 55 and use 8 of them: 13 calls for
        more paths instead of 55, each several times the bound's cost)."""
        _c, t, i, j = taken
        fi, g1 = divmod(t, self.S)
        share, sub = self.shares[g1], g - g1
        lists = self.lists[p][ei][fi]
        if lists is None:
            lists = self._lists(p, ei, fi)
        ls = lists.get(share)
        after = nodes.get((p + 1, fi, sub))
        if after is None:
            after = self._node(nodes, B, arg, p + 1, fi, sub)
        items = after.items
        cf = self.cfl[p + 1][fi]
        out: list[Item] = []
        j2 = j + 1
        if j2 < self.k:
            while len(items) <= j2 and not after.done:
                self._advance(nodes, B, arg, p + 1, fi, sub, after)
            if j2 < len(items):   # entry i is found and final: (i, j) used it
                a = ls[i][0] if ls is not None and i < len(ls) else \
                    self._entry_cost(p, ei, fi, share, i)
                out.append((a + (items[j2][0] + cf), t, i, j2))
        if j == 0:
            i2 = i + 1
            if ls is not None and i2 < len(ls) and i2 < getattr(ls, "final", i2 + 1):
                out.append((ls[i2][0] + (items[0][0] + cf), t, i2, 0))
            elif i2 == 1 and self._second is not None and \
                    getattr(ls, "final", None) is not None and i2 < self.k:
                bound = self._second(self.stages[p], self.elems[p][ei],
                                     self.elems[(p + 1) % len(self.elems)][fi], share)
                out.append((bound + (items[0][0] + cf), t, i2, -1))
            else:
                ent = self._entry(p, ei, fi, share, i2)
                if ent is not None:
                    out.append((ent[0] + (items[0][0] + cf), t, i2, 0))
        return out

    def _resolve(self, nodes: dict[tuple[int, int, int], _Node], p: int, ei: int, g: int,
                 cand: Item) -> list[Item]:
        """A candidate (i, 0) offered at a bound (j = -1, see :meth:`_offers`) that is a
        node's least now: its entry found, and the candidate at its own cost (at least
        the bound: it goes back into the heap), or none when the list has no entry i.
        The node's pops stay in key order: every candidate waits in the heap under a
        key no larger than its own, and is taken only once found."""
        bound, t, i, _j = cand
        fi, g1 = divmod(t, self.S)
        ent = self._entry(p, ei, fi, self.shares[g1], i)
        if ent is None:
            return []
        c = ent[0] + (nodes[(p + 1, fi, g - g1)].items[0][0] + self.cfl[p + 1][fi])
        if c < bound:
            raise AssertionError("a stage list entry costs less than its bound")
        return [(c, t, i, 0)]

    def _entry_cost(self, p: int, ei: int, fi: int, share: Share, i: int) -> float:
        """The cost of entry i of a list, known to be there."""
        ent = self._entry(p, ei, fi, share, i)
        assert ent is not None
        return ent[0]

    def _advance_closing(self, p: int, ei: int, g: int, node: _Node) -> None:
        """The next completion of a node at the stage closing a cycle: the next entry
        of its list back to the root's element."""
        r = node.items[0][1] // self.S
        ent = self._entry(p, ei, r, self.shares[g], len(node.items))
        if ent is None:
            node.done = True
        else:
            node.items.append((ent[0], node.items[0][1], len(node.items), 0))

    def _start_heap(self, B: np.ndarray, p: int, ei: int, g: int, node: _Node) -> None:
        """Every first candidate, as the general program's heap holds them; the first
        one popped is the completion the array pass found, its successors pending.

        Many pairs (a structure-wide resource: every end element and share, up to a
        few hundred) come sorted by (cost, pair) from arrays and stay there
        (``node.rest``), taken one by one as they become the least candidate: a
        node asked for a few more completions takes a few of them, so the others are
        never made into tuples and heap entries."""
        S, F = self.S, int(self.ne[p + 1])
        a = self.A[p, ei, :F, :g + 1]
        b = B[p + 1, :F, g::-1]                  # b[f, g1] = completion at share g - g1
        # (f, g1) ascending: the pairs' order. A few pairs (no structure-wide resource)
        # by a Python loop, which costs less than the array calls; the same float sums
        first: Item
        if F * (g + 1) <= SMALL_START:
            cf, al, bl, inf = self.cfl[p + 1], a.tolist(), b.tolist(), math.inf
            cand = [(x + (y + cf[fi]), fi * S + g1, 0, 0) for fi in range(F)
                    for g1, (x, y) in enumerate(zip(al[fi], bl[fi], strict=True))
                    if x < inf and y < inf]
            heapq.heapify(cand)
            first = heapq.heappop(cand)
            node.heap = cand
        else:
            c, t = _first_pairs(a, b, self.cf[p + 1, :F], S)
            cl, tl = c.tolist(), t.tolist()
            first = (cl[0], tl[0], 0, 0)
            node.heap, node.rest, node.at = [], (cl, tl), 1
        if first[:2] != node.items[0][:2]:
            raise AssertionError("first completion differs from the array pass")
        node.pending = first

    def _payload(self, nodes: dict[tuple[int, int, int], _Node], B: np.ndarray,
                 arg: np.ndarray, p: int, ei: int, g: int, j: int) -> Payload:
        """Completion j of (p, ei, g) as the general program's nested payload; a
        completion's payload is made once and shared by every structure through it
        (payloads are only read)."""
        if p == self.L:
            return {}
        key = (id(nodes), p, ei, g, j)
        got = self._payloads.get(key)
        if got is not None:
            return got
        item = self._item(nodes, B, arg, p, ei, g, j)
        assert item is not None
        _c, t, i, j2 = item
        fi, g1 = divmod(t, self.S)
        ent = self._entry(p, ei, fi, self.shares[g1], i)
        assert ent is not None
        f = self.elems[(p + 1) % len(self.elems)][fi]
        sub = {} if self._is_last(p) else self._payload(nodes, B, arg, p + 1, fi, g - g1, j2)
        out: Payload = {self.stages[p]: (f, ent[1], sub)}
        self._payloads[key] = out
        return out

    def _link(self, nodes: dict[tuple[int, int, int], _Node], B: np.ndarray,
              arg: np.ndarray, p: int, ei: int, g: int, j: int) -> Link:
        """Completion j of (p, ei, g) read back as a :data:`Link`: its stage's entry read
        (``read``) and the link of the completion after it. Made once per completion
        and shared by every structure through it, so a completion costs one tuple
        where a copy of whole rows (key points, fillers, totals) per completion cost
        three lists as long as the structure (100 structures of a 40-corner block:
        about 1,250 completions); :meth:`_rows` copies only the k structures returned.
        Walks down to the first completion read back already, then links back up."""
        # (the node's links, j, p, ei, pair t and entry i; t = -1 at the leaf)
        todo: list[tuple[dict[int, Link], int, int, int, int, int]] = []
        link: Link | None = None
        S, L, last = self.S, self.L, self.last
        while True:
            node = nodes.get((p, ei, g))
            if node is None:
                node = self._node(nodes, B, arg, p, ei, g)
            links = node.links
            if links is None:
                links = node.links = {}
            else:
                link = links.get(j)
                if link is not None:
                    break
            if p == L:   # the leaf of an open chain
                todo.append((links, j, p, ei, -1, 0))
                break
            _c, t, i, j2 = node.items[j]   # found: the structure ran through it
            todo.append((links, j, p, ei, t, i))
            if p == last:   # the stage closing the cycle: no completion after it
                break
            p, ei, g, j = p + 1, t // S, g - t % S, j2
        read, elems, kps, stages, shares = self.read, self.elems, self.kps, self.stages, \
            self.shares
        assert read is not None
        for links, j, p, ei, t, i in reversed(todo):
            e = elems[p][ei]
            if t < 0:
                link = (kps[p], e, -1, None, None, None)
            else:
                fi, g1 = divmod(t, S)
                lists = self.lists[p][ei][fi]
                if lists is None:   # entry 0 found from the first entries' array
                    lists = self._lists(p, ei, fi)
                s = stages[p]
                # the cycle closes on the root's element, which position 0 holds
                link = (kps[p], e, s,
                        *read(s, e, elems[(p + 1) % len(elems)][fi], lists[shares[g1]][i][1]),
                        None if p == last else link)
            links[j] = link
        assert link is not None
        return link

    def _rows(self, link: Link | None) -> Rows:
        """A structure from the link of its root completion: the element at every key
        point, the fillers and totals of every stage, copied (a structure's own lists,
        where the reader's are shared by every structure using the same entry)."""
        keys: list[str] = [None] * len(self.st.keypoints)   # type: ignore[list-item]
        fills: list[list[str]] = [None] * self.L            # type: ignore[list-item]
        totals: list[dict[str, float]] = [None] * self.L    # type: ignore[list-item]
        while link is not None:
            kp, e, s, fill, total, link = link
            keys[kp] = e
            if fill is not None:
                fills[s] = fill.copy()
                totals[s] = total.copy()   # type: ignore[union-attr]
        return keys, fills, totals
