"""The k best fillings of a whole structure from the k best fillings of its stages.

Once the element at every key point is fixed, a structure's cost is the sum of
independent stage costs plus the key elements' unary costs. So a k-best dynamic
program over the tree of key points is exact: below a key point holding element e,
the k best completions are the k smallest sums over its outgoing stages, each stage
contributing (its filling, the element at its end, the k best completions below
that). A cycle is cut at key point 0: the program runs once per element there and
its closing stage must end on that same element.

Structure-wide intervals are met by keeping k best completions per partial total of
the structure-wide resources (in quanta): a stage list is keyed by its share.

Where the stage lists come from is the caller's business (one problem per stage and
key pair in :mod:`citysynth.solver.structures.decompose`, shared stage graphs in
:mod:`citysynth.solver.structures.stage_graphs`); this module only combines them.
"""

from __future__ import annotations

import gc
import heapq
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

import numpy as np

from citysynth.solver.structures.chain_kbest import ChainProgram, Read, Rows, chain_of
from citysynth.solver.structures.model import Structure

X = TypeVar("X")
Y = TypeVar("Y")
Tag = TypeVar("Tag")

ARRAYS_K1 = True   # k = 1 by arrays (tests switch it off to compare with the general way)
LAZY_CHAINS = True  # chains and cycles by the lazy program (tests compare the two)
FIRST_PATHS = 1     # ... whose stage lists start with this many paths and grow on demand
MIN_SHARES = 4     # ... when a structure-wide resource has at least this many values
SECOND_BOUNDS = True  # ... entry 1 of a growing list offered at a bound (tests switch it off)
Share = tuple[int, ...]
StageList = list[tuple[float, Any]]   # cost-sorted (cost, payload of the stage's provider)
StageLists = Callable[[int, str, str], dict[Share, StageList]]
# stage -> (element at its end, the stage list's payload, the payload below that end)
Payload = dict[int, tuple[str, Any, "Payload"]]
Completions = list[tuple[float, Payload]]
# every share (encoded as one int) of a key point's completions, ascending
Below = list[tuple[int, Completions]]


@contextmanager
def paused_gc() -> Iterator[None]:
    """No cyclic garbage collection while stage lists are built and combined. They
    are hundreds of thousands of small tuples and dicts, none in a reference cycle,
    and the collector would rescan them again and again as they pile up (40-corner
    block, k=100: 308 ms with it, 196 ms without)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def ksum(A: Sequence[tuple[float, X]], B: Sequence[tuple[float, Y]], k: int
         ) -> list[tuple[float, tuple[X, Y]]]:
    """The k smallest a + b over two cost-sorted lists of (cost, payload); payloads
    pair up.

    >>> ksum([(0.0, "a"), (2.0, "b")], [(1.0, "x"), (1.5, "y")], 3)
    [(1.0, ('a', 'x')), (1.5, ('a', 'y')), (3.0, ('b', 'x'))]
    """
    if not A or not B:
        return []
    if k == 1 or (len(A) == 1 and len(B) == 1):
        return [(A[0][0] + B[0][0], (A[0][1], B[0][1]))]
    heap = [(A[0][0] + B[0][0], 0, 0)]
    seen = {(0, 0)}
    out: list[tuple[float, tuple[X, Y]]] = []
    while heap and len(out) < k:
        c, i, j = heapq.heappop(heap)
        out.append((c, (A[i][1], B[j][1])))
        for i2, j2 in ((i + 1, j), (i, j + 1)):
            if i2 < len(A) and j2 < len(B) and (i2, j2) not in seen:
                seen.add((i2, j2))
                heapq.heappush(heap, (A[i2][0] + B[j2][0], i2, j2))
    return out


def merge_sums(pairs: Sequence[tuple[Sequence[tuple[float, X]], Sequence[tuple[float, Y]],
                                     float, Tag]], k: int
               ) -> list[tuple[float, tuple[Tag, X, Y]]]:
    """The k smallest a + (b + offset) over several pairs (A, B, offset, tag) of
    cost-sorted lists, as (cost, (tag, payload of a, payload of b)): one heap over
    all pairs, so only k sums are ever taken. Ties come out by pair, then by
    position in A and B (what sorting every pair's own k smallest would give)."""
    heap = [(A[0][0] + (B[0][0] + off), t, 0, 0)
            for t, (A, B, off, _tag) in enumerate(pairs) if A and B]
    heapq.heapify(heap)
    seen = {(t, 0, 0) for _c, t, _i, _j in heap}
    out: list[tuple[float, tuple[Tag, X, Y]]] = []
    while heap and len(out) < k:
        c, t, i, j = heapq.heappop(heap)
        A, B, off, tag = pairs[t]
        out.append((c, (tag, A[i][1], B[j][1])))
        for i2, j2 in ((i + 1, j), (i, j + 1)):
            if i2 < len(A) and j2 < len(B) and (t, i2, j2) not in seen:
                seen.add((t, i2, j2))
                heapq.heappush(heap, (A[i2][0] + (B[j2][0] + off), t, i2, j2))
    return out


def _best(lists: dict[int, Completions], k: int) -> dict[int, Completions]:
    return {g: sorted(ls, key=lambda t: t[0])[:k] for g, ls in lists.items()}


def root_of(st: Structure) -> int:
    """Where the program starts: key point 0 of a cycle, else the one no stage enters."""
    if st.closed:
        return 0
    return next(v for v in range(len(st.keypoints)) if all(s.end != v for s in st.stages))


def lazy_chain(st: Structure, ghi: list[int]) -> bool:
    """Whether the lazy program of :mod:`.chain_kbest` combines this structure."""
    return LAZY_CHAINS and chain_of(st, ghi) is not None


def first_paths(st: Structure, k: int, ghi: list[int]) -> int:
    """How many paths every stage list needs up front: k for the general program, a
    few for the lazy one (chains and cycles), which asks for more where it needs them."""
    return min(k, FIRST_PATHS) if lazy_chain(st, ghi) else k


def best_structures(st: Structure, k: int, ghi: list[int], glo: list[int],
                    stage_lists: StageLists,
                    more: Callable[[int, str, str, Share], int] | None = None,
                    firsts: Callable[[], np.ndarray | None] | None = None,
                    read: Read | None = None,
                    second: Callable[[int, str, str, Share], float] | None = None
                    ) -> list[tuple[float, str, Payload | Rows]]:
    """The k best (cost, element at the root, payload) of structure ``st``. A payload
    maps each stage to (element at its end, the stage list's payload, payload below
    that end). ``ghi``/``glo``: bounds of the structure-wide resources in quanta.
    Chains and cycles go to the lazy program of :mod:`.chain_kbest` (same sums, same
    order), whose lists may start short and grow by ``more`` (entry 1 offered at the
    lower bound ``second`` on its cost until it is needed), whose first entries may
    come as one array from ``firsts``, and whose structures come back as their rows
    when ``read`` reads a stage list entry (see there)."""
    chain = chain_of(st, ghi) if LAZY_CHAINS else None
    _room_for(len(st.stages))
    if chain is not None:  # (chain_of is cheap: a walk over the stages)
        return ChainProgram(st, k, ghi, glo, chain, stage_lists, more,
                            firsts() if firsts is not None else None, read,
                            second if SECOND_BOUNDS else None).run()
    return [*_Program(st, k, ghi, stage_lists).run(glo)]


FRAMES_PER_STAGE = 8   # Python frames the programs' recursion takes per key point, at most


def _room_for(stages: int) -> None:
    """Room for the programs' recursion, which goes down a structure's key points one
    by one (a lazy completion asks the next key point's, and so on): 500 corners asked
    for k = 2 went past Python's default limit of 1,000 frames. Python 3.11 runs such
    calls without growing the C stack, so a deeper limit costs only memory, a few
    hundred bytes a frame. The limit is raised, never lowered again: it is the whole
    process's, and a Dask worker may solve in several threads at once (one restoring
    the old limit would break another's solve midway)."""
    need = FRAMES_PER_STAGE * stages + 1000
    if sys.getrecursionlimit() < need:
        sys.setrecursionlimit(need)


class _Program:
    """The k-best dynamic program over the key points of one structure.

    Shares travel as one int each: digit i (radix 2 * (ghi[i] + 1)) holds resource i,
    so adding two shares that fit never carries, and a sum fits when every digit is at
    most its bound. With one structure-wide resource (the usual case) a share is just
    its value; the loops of :meth:`_stage_options` run a million times on a block with
    a per-block interval."""

    def __init__(self, st: Structure, k: int, ghi: list[int], stage_lists: StageLists):
        self.st, self.k, self.ghi, self.stage_lists = st, k, ghi, stage_lists
        self._lists: dict[tuple[int, str, str], list[tuple[int, StageList]]] = {}
        self.out, self.child = _children(st)
        self.radix = [2 * (h + 1) for h in ghi]
        self.single = len(ghi) == 1
        H = ghi[0] if self.single else 0
        self.fits: Callable[[int], bool] = (
            (lambda code: code <= H) if self.single
            else self._fits_any if ghi else (lambda code: True))
        self.closing = (next(i for i, s in enumerate(st.stages) if s.end == 0)
                        if st.closed else -1)
        # k = 1 with at most one structure-wide resource: a stage's options are one
        # min-plus convolution over shares, done on arrays (_Best1) instead of a
        # Python loop over every pair of shares
        # (worth it from a few shares on: with one share the Python loop is cheaper
        # than an array call per end element)
        arrays = ARRAYS_K1 and k == 1 and len(ghi) <= 1 and max(ghi, default=0) >= MIN_SHARES
        self.best1 = _Best1(ghi[0] if ghi else 0) if arrays else None

    def encode(self, g: Share) -> int:
        code = 0
        for x, r in zip(reversed(g), reversed(self.radix), strict=True):
            code = code * r + x
        return code

    def decode(self, code: int) -> Share:
        digits = []
        for r in self.radix:
            code, x = divmod(code, r)
            digits.append(x)
        return tuple(digits)

    def _fits_any(self, code: int) -> bool:
        return all(x <= h for x, h in zip(self.decode(code), self.ghi, strict=True))

    def lists(self, s: int, e: str, f: str) -> list[tuple[int, StageList]]:
        """stage_lists with shares encoded, in increasing order of share; once per
        (stage, e, f): a cycle's program runs again for every element at its root
        (27 key elements a corner on a city block: 27 times)."""
        key = (s, e, f)
        got = self._lists.get(key)
        if got is None:
            got = self._lists[key] = sorted(
                (self.encode(g), ls) for g, ls in self.stage_lists(s, e, f).items())
        return got

    def run(self, glo: list[int]) -> list[tuple[float, str, Payload]]:
        """The k best over every element at the root whose totals reach ``glo``."""
        st = self.st
        root = root_of(st)
        results: list[tuple[float, str, Payload]] = []
        memo: dict[tuple[int, str], Below] = {}
        for e in st.keypoints[root]:
            if st.closed:  # every completion depends on the element the cycle closes on
                memo = {}
            for code, ls in self.below(root, e, e if st.closed else None, memo):
                if all(x >= lo for x, lo in zip(self.decode(code), glo, strict=True)):
                    results.extend((c + st.costs[e], e, payload) for c, payload in ls)
        results.sort(key=lambda t: t[0])
        return results[:self.k]

    def below(self, v: int, e: str, fixed_root: str | None,
              memo: dict[tuple[int, str], Below]) -> Below:
        """share -> k best completions of everything after key point v holding e;
        ``fixed_root``: the element a cycle closes on (None for a tree)."""
        key = (v, e)
        if key in memo:
            return memo[key]
        acc: dict[int, Completions] | None = None
        for s in self.out[v]:
            if s == self.closing:  # the cycle closes on key point 0's element, paid there
                assert fixed_root is not None  # a cycle's program always fixes it
                options = self._closing_options(s, e, fixed_root)
            else:
                options = self._stage_options(s, e, fixed_root, memo)
            if acc is None:  # the first stage out of v: nothing to combine with yet
                acc = {g: [(c, {s: p}) for c, p in ls] for g, ls in options.items()}
            else:
                acc = self._join(acc, s, options)
            if not acc:
                break
        done = [(0, [(0.0, {})])] if acc is None else sorted(acc.items())  # None: a leaf
        memo[key] = done
        return done

    def _closing_options(self, s: int, e: str, root_element: str
                         ) -> dict[int, list[tuple[float, tuple[str, Any, Payload]]]]:
        """The closing stage of a cycle, from e back to the root's element."""
        return {g: [(c, (root_element, h, {})) for c, h in ls]
                for g, ls in self.lists(s, e, root_element)}

    def _stage_options(self, s: int, e: str, fixed_root: str | None,
                       memo: dict[tuple[int, str], Below]
                       ) -> dict[int, list[tuple[float, tuple[str, Any, Payload]]]]:
        """(the stage to f, the k best below f holding f) for every element f at the
        end of stage s, k best per share."""
        st, fits, single = self.st, self.fits, self.single
        w = self.child[s]

        def lists(f: str) -> list[tuple[int, StageList]]:   # a stage may run up the tree
            return self.lists(s, e, f) if w == st.stages[s].end else self.lists(s, f, e)
        if self.best1 is not None:
            return self.best1.options([(f, lists(f), self.below(w, f, fixed_root, memo),
                                         st.costs[f]) for f in st.keypoints[w]])
        pairs: dict[int, list[tuple[StageList, Completions, float, str]]] = {}
        for f in st.keypoints[w]:
            sub = self.below(w, f, fixed_root, memo)
            if not sub:
                continue
            cf = st.costs[f]
            for g1, ls in lists(f):
                for g2, lw in sub:
                    g = g1 + g2
                    if fits(g):
                        pairs.setdefault(g, []).append((ls, lw, cf, f))
                    elif single:   # shares ascend: the rest are larger still
                        break
        return {g: merge_sums(ps, self.k) for g, ps in pairs.items()}

    def _join(self, acc: dict[int, Completions], s: int,
              options: dict[int, list[tuple[float, tuple[str, Any, Payload]]]]
              ) -> dict[int, Completions]:
        """The k best per share of the stages so far (``acc``) together with stage s."""
        fits, k = self.fits, self.k
        nxt: dict[int, Completions] = {}
        for g1, la in acc.items():
            for g2, lb in options.items():
                g = g1 + g2
                if fits(g):
                    nxt.setdefault(g, []).extend(
                        (c, {**pa, s: pb}) for c, (pa, pb) in ksum(la, lb, k))
        return _best(nxt, k)


def _children(st: Structure) -> tuple[list[list[int]], list[int]]:
    """The stages below each key point (in stage order) as the program walks the tree
    from its root, and the key point each stage leads to. A stage may point either way
    (the bar of an H ends at one of its T junctions); a cycle's closing stage hangs below
    the key point it leaves."""
    closing = next((i for i, s in enumerate(st.stages) if s.end == 0), -1) \
        if st.closed else -1
    inc: list[list[int]] = [[] for _ in st.keypoints]
    for i, s in enumerate(st.stages):
        inc[s.start].append(i)
        if i != closing:
            inc[s.end].append(i)
    out: list[list[int]] = [[] for _ in st.keypoints]
    child = [-1] * len(st.stages)
    todo, up = [root_of(st)], {root_of(st): -1}
    while todo:
        v = todo.pop()
        for i in inc[v]:
            if i != up[v]:
                s = st.stages[i]
                w = s.end if s.start == v else s.start
                out[v].append(i)
                child[i] = w
                if i != closing:
                    up[w] = i
                    todo.append(w)
    return out, child


class _Best1:
    """k = 1 stage options with at most one structure-wide resource (shares 0..H):
    for every share g, the best over end elements f (in key point order) and shares
    g1 + g2 = g of stage cost a(g1) + (completion cost b(g2) + unary cost of f), the
    same float sum :func:`merge_sums` takes, with its ties: the first f, then the
    smallest g1. One (H+1) x (H+1) array sum and argmin per f instead of a Python loop
    over every pair of shares (a block with a per-block door count: about 600 share
    pairs per stage, end element and start element)."""

    def __init__(self, H: int):
        self.H = H
        g1 = np.arange(H + 1)
        shift = np.arange(H + 1)[None, :] - g1[:, None]      # g2 = g - g1
        self.valid = shift >= 0
        self.g2 = np.where(self.valid, shift, 0)
        self.cols = np.arange(H + 1)
        # rows already made, by list: a stage list serves every element at a cycle's
        # root, a completion list every stage into its key point (the list is kept
        # with its row, so its id cannot be reused while the entry lives)
        self._rows: dict[int, tuple[object, np.ndarray, list[Any]]] = {}

    def _row(self, items: Sequence[tuple[int, Sequence[tuple[float, Any]]]]
             ) -> tuple[np.ndarray, list[Any]]:
        """Costs by share (inf where there is none) and the payloads."""
        got = self._rows.get(id(items))
        if got is not None and got[0] is items:
            return got[1], got[2]
        cost = np.full(self.H + 1, np.inf)
        pay: list[Any] = [None] * (self.H + 1)
        for g, ls in items:
            if g <= self.H and ls:
                cost[g] = ls[0][0]
                pay[g] = ls[0][1]
        self._rows[id(items)] = (items, cost, pay)
        return cost, pay

    def options(self, ends: list[tuple[str, list[tuple[int, StageList]], Below, float]]
                ) -> dict[int, list[tuple[float, tuple[str, Any, Payload]]]]:
        costs, firsts, used = [], [], []
        order: list[int] = []     # shares in the order the per-pair loop first meets them
        seen = np.zeros(self.H + 1, dtype=bool)
        for f, lists, sub, cf in ends:
            if not sub or not lists:
                continue
            a, pa = self._row(lists)
            b, pb = self._row(sub)
            bg = b[self.g2]
            reach = self.valid & (a < np.inf)[:, None] & (bg < np.inf)
            m = np.where(reach, a[:, None] + (bg + cf), np.inf)
            i = np.argmin(m, axis=0)            # the smallest g1 among equal costs
            costs.append(m[i, self.cols])
            firsts.append(i)
            used.append((f, pa, pb))
            new = np.flatnonzero(reach.any(axis=0) & ~seen)
            g1min = np.argmax(reach[:, new], axis=0)   # loops: g1 ascending, then g2
            order.extend(new[np.lexsort((new, g1min))].tolist())
            seen[new] = True
        if not costs:
            return {}
        C = np.array(costs)
        t = np.argmin(C, axis=0)                # the first end element among equal costs
        c = C[t, self.cols].tolist()
        g1s = np.array(firsts)[t, self.cols].tolist()
        tl = t.tolist()
        out: dict[int, list[tuple[float, tuple[str, Any, Payload]]]] = {}
        for g in order:
            f, pa, pb = used[tl[g]]
            g1 = g1s[g]
            out[g] = [(c[g], (f, pa[g1], pb[g - g1]))]
        return out
