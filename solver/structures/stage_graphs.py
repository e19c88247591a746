"""Stage lists from shared forward graphs: the structure solver's fast path.

Why: solving one problem per (stage, start key, end key, share) repeats almost all
of its work. A stage's intermediate graph grown *forward* from its start key
element depends neither on where the stage must end (its intervals) nor on the
element at its end: both only decide which of its nodes may be last. So stages
with the same fillers and constrained resources share one graph per start element
(and start leg), grown once over the union of their state boxes
(:mod:`citysynth.solver.graph`, forward only), and every (stage, end element, share)
becomes a query on it: a virtual sink fed by the nodes whose state plus the end key's
leg is admissible. One kernel call per graph enumerates the k best fillings of all its
queries (:mod:`citysynth.solver.structures.stage_kbest`). A 40-corner block outline
with three corner parts is three graphs instead of 360 problems.

Exact for the same reason as the decomposition (:mod:`citysynth.solver.structures.combine`
combines the lists the same way): every query's list holds the k cheapest fillings of that
stage between those key elements with that share, found by an exact k-shortest-path
enumeration. Quantisation must be exact (every value a multiple of its resource's
quantum); otherwise :class:`NotExact` sends the caller to the decomposition, whose
one-stage solves re-check totals in original units.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NoReturn

import numpy as np

from citysynth.solver.entry import solve
from citysynth.solver.errors import ProblemError, TooLargeError
from citysynth.solver.estimate import DENSE_TABLE_MAX_BYTES, row_bytes
from citysynth.solver.graph import STATUS_OK, _grow_graph
from citysynth.solver.quantize import bounds_in_quanta, exact_divisor, is_multiple
from citysynth.solver.structures import stage_kbest
from citysynth.solver.structures.blocked import Blocked
from citysynth.solver.structures.buffers import give_back, take
from citysynth.solver.structures.combine import Share, StageList
from citysynth.solver.structures.decompose import (
    Grid,
    StageBuilder,
    shares_allowed,
    stage_fillers,
    start_leg,
)
from citysynth.solver.structures.model import Structure
from citysynth.solver.structures.stage_forward import forward_dense
from citysynth.solver.structures.stage_kbest import (
    Growing,
    StageGraph,
    _best_fill,
    _second_cost,
    _stage_best_costs,
    _stage_kbest_of,
    first_lists,
    one_path,
    sorted_paths,
)

DENSE_FORWARD = True   # dense row tables by stage_forward (tests compare with _grow_graph)


def _empty() -> np.ndarray:
    return np.zeros(0, dtype=np.int64)


class NotExact(Exception):
    """Some value is not a multiple of its resource's quantum (a rounding quantum)."""


@dataclass
class _Group:
    """Stages that share their graphs: same fillers, same tracked resources."""

    fillers: tuple[str, ...]
    dims: tuple[str, ...]      # constrained resources, stage-local and structure-wide
    stages: list[int]
    # set by StageGraphs._plan: consumption of each filler in quanta (int64 [fillers,
    # dims]), the state box (start leg and fillers so far), the most fillers in one
    # stage, the weights over [start, fillers...] (column 0 empty)
    r: np.ndarray = field(default_factory=_empty)
    cap: np.ndarray = field(default_factory=_empty)
    max_len: int = 0
    W: np.ndarray = field(default_factory=_empty)


def _quanta(st: Structure, names: set[str], gnames: list[str], gq: list[float]
            ) -> dict[str, float]:
    """One exact quantum per tracked resource, for the whole structure (structure-wide
    resources keep the grid of their shares)."""
    used = sorted({x for i in range(len(st.stages)) for x in stage_fillers(st, i)})
    keys = sorted({x for kp in st.keypoints for x in kp})
    out = dict(zip(gnames, gq, strict=True))
    for r in sorted(names):
        values = [st.elements[x][r] for x in used] + [leg[r] for x in keys
                                                      for leg in st.legs[x]]
        if r not in out:
            q = st.quantum.get(r)
            if q is None:
                frac = exact_divisor(values)
                if frac is None:
                    raise NotExact(r)
                q = float(frac)
            out[r] = q
        if not all(is_multiple(v, out[r]) for v in values):
            raise NotExact(r)
    return out


def _box(hi: np.ndarray, r: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, int]:
    """Caps of the state box (a state counts the start leg and the fillers so far) and
    the most fillers a stage can hold, as in :func:`citysynth.solver.compiled._box`: every
    filler consumes at least one quantum, some consume at least m of a resource."""
    hi = np.maximum(hi, 0)
    if len(r) == 0:
        return hi, 0
    max_len = int(hi.sum() // max(int(r.sum(axis=1).min()), 1))
    for d in range(r.shape[1]):
        m = int(r[:, d].min())
        if m > 0:
            max_len = min(max_len, int(hi[d]) // m)
    return np.minimum(hi, start + max_len * r.max(axis=0)), max_len


@dataclass
class _QuerySet:
    """The (stage, end element, share) queries on a group's graph from one start leg,
    as arrays: the same whatever the start element (only the weights of the edges out
    of it differ, :meth:`StageGraphs._weights`). Query q asks stage ``stages[pos[q]]``
    to end on element ``bi[q]`` of its end key point with share ``shares[share[q]]``
    (``code[q]``: the share's value when there is one structure-wide resource), its
    last node inside the box qlo[q]..qhi[q]. ``span``: where the queries of a stage
    and end element lie; ``ends``: the rows of each set of end elements and their leg.
    Stage lists are made from them when read (:meth:`StageGraphs.lists`): a block with
    a per-block door count asks 6,480 queries and its k best read a few dozen lists."""

    stages: list[int]
    qlo: np.ndarray
    qhi: np.ndarray
    pos: np.ndarray
    bi: np.ndarray
    share: np.ndarray
    code: np.ndarray
    span: dict[tuple[int, str], tuple[int, int]]
    ends: list[tuple[int, int]]   # each set of end elements (key point, leg), in order
    qw: np.ndarray                # each query's row in the weights of its graph: the
                                  # rows of ends[0]'s end elements, then ends[1]'s...


@dataclass
class _Solved:
    """The queries of one graph (start element ``a``) and where their lists are: the
    best cost of each (``costs``, one-path lists made when read), or made already
    (None: ``StageGraphs._lists`` holds them)."""

    a: str
    qs: _QuerySet
    gid: int
    gi: int
    costs: np.ndarray | None


def _mb(x: float) -> str:
    """Megabytes as a message gives them: whole from 10 up, else one decimal (3.2 MB
    over a 3 MB budget read "3 MB, over the memory budget of 3 MB")."""
    return f"{x:,.0f}" if x >= 10 else f"{x:.1f}".removesuffix(".0")


def _cat(xs: list[np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
    return np.concatenate(xs) if xs else np.zeros(shape, dtype=np.int64)


class StageGraphs:
    """Every stage list of a structure, from shared graphs solved up front; a list's
    payload is (paths index, path index). ``first``: how many paths each query gets
    up front (k unless given); :meth:`more` finds more of one query on demand. With
    one path each, only the queries' best costs are found up front (arrays, one per
    graph) and a list is made when it is read (:meth:`lists`; the lazy program takes
    the first entries as one array, :meth:`first_costs`). :meth:`release` gives the
    graphs' tables back for the next solve."""

    def __init__(self, st: Structure, k: int, grid: Grid, max_memory_mb: float,
                 table: str = "auto", first: int | None = None):
        if table not in ("auto", "dense", "hash"):
            raise ProblemError(f'table must be "auto", "dense" or "hash", got {table!r}')
        self.st, self.k, self.table = st, k, table
        self.first = k if first is None else max(1, min(first, k))
        self._graph_of: list[tuple[StageGraph, int, tuple[str, ...]]] = []
        self._deferred: dict[int, int] = {}   # paths index -> graph, for one-path lists
        self._read: dict[tuple[int, int], tuple[int, int]] = {}   # their paths, once found
        self._weights_of: dict[tuple[int, str, int, tuple[str, ...], int], np.ndarray] = {}
        self._legs_of: dict[tuple[int, tuple[str, ...], int], np.ndarray] = {}
        self._fillers_of: dict[tuple[int, tuple[str, ...], int], np.ndarray] = {}
        self._boxes: dict[tuple[int, int], tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 np.ndarray]] = {}
        self._sets: dict[tuple[int, tuple[int, ...]], _QuerySet] = {}
        self._from: dict[tuple[int, str], _Solved | None] = {}   # (stage, start element)
        self._solved: list[_Solved] = []
        self._taken: list[np.ndarray] = []   # tables from buffers.take, given back by release
        gnames, gq, _glo, ghi = grid
        self.gnames, self.gq, self.ghi = gnames, gq, ghi
        self.shares = list(itertools.product(*[range(h + 1) for h in ghi]))
        self._share_arr = np.array(self.shares, dtype=np.int64).reshape(
            len(self.shares), len(ghi))
        self._all_shares = np.arange(len(self.shares), dtype=np.int64)
        self._alike: dict[tuple[str, ...], int] = {}   # end elements -> first key point
        tracked = {r for s in st.stages for r in s.constraints} | set(gnames)
        self.q = _quanta(st, tracked, gnames, gq)
        self.budget = int(max_memory_mb * 2**20)
        self._lists: dict[tuple[int, str, str], dict[Share, StageList]] = {}
        self._seconds: dict[tuple[int, str, str, Share], float] = {}   # (second_cost)
        self._paths: list[tuple[np.ndarray, np.ndarray, tuple[str, ...]]] = []
        self._shares_of: dict[int, np.ndarray] = {}
        self.counts = {"stage_graphs": 0, "stage_queries": 0, "graph_rows": 0}
        groups = self._groups()
        for grp in groups:  # every box is checked before any graph is grown
            self._plan(grp)
        starts = [(grp, a, leg) for grp in groups
                  for a, leg in dict.fromkeys((a, start_leg(st, i)) for i in grp.stages
                                              for a in st.keypoints[st.stages[i].start])]
        # the graphs are all kept until the structures are read: their tables share the
        # budget (each was held to it alone, and a block with a per-block window count
        # grew 27 graphs to 5 GB)
        self._held, self._grown, self._graphs = 0, 0, len(starts)
        for grp, a, leg in starts:
            self._solve(grp, a, leg)

    # ---- layout -----------------------------------------------------------------
    def _ints(self, values: dict[str, float], dims: Sequence[str]) -> np.ndarray:
        """Values in quanta (exact: every value is a multiple of its quantum)."""
        return np.array([round(values[r] / self.q[r]) for r in dims], dtype=np.int64)

    def _bounds(self, i: int, dims: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """Stage i's own intervals in quanta; a structure-wide resource it does not
        constrain itself lies in [0, its structure-wide maximum]."""
        stage = self.st.stages[i]
        lo, hi = [], []
        for r in dims:
            a, b = 0, 1 << 62
            if r in stage.constraints:
                a, b = bounds_in_quanta(*stage.constraints[r], q=self.q[r])
            if r in self.gnames:
                b = min(b, self.ghi[self.gnames.index(r)])
            lo.append(a)
            hi.append(b)
        return np.array(lo, dtype=np.int64), np.array(hi, dtype=np.int64)

    def _groups(self) -> list[_Group]:
        st = self.st
        groups: dict[tuple[tuple[str, ...], tuple[str, ...]], _Group] = {}
        for i, stage in enumerate(st.stages):
            dims = tuple(r for r in st.resources
                         if r in stage.constraints or r in self.gnames)
            fillers = stage_fillers(st, i)
            groups.setdefault((fillers, dims), _Group(fillers, dims, [])).stages.append(i)
        return list(groups.values())

    def _plan(self, grp: _Group) -> None:
        """The group's state box and weights; refuse a box over the memory budget."""
        st, dims = self.st, grp.dims
        grp.r = np.array([self._ints(st.elements[x], dims) for x in grp.fillers],
                         dtype=np.int64).reshape(len(grp.fillers), len(dims))
        for x, lev in zip(grp.fillers, grp.r.sum(axis=1), strict=True):
            if lev == 0:
                raise ProblemError(
                    f'element "{x}" consumes nothing of the constrained resource(s) '
                    f"{', '.join(dims)} of stage {grp.stages[0]} (after quantisation), so "
                    "a stage could repeat it without end; give it a positive amount of a "
                    "constrained resource, or constrain a resource it uses")
        hi = np.zeros(len(dims), dtype=np.int64)     # most a state can hold
        start = np.zeros(len(dims), dtype=np.int64)  # most a start leg holds
        for i in grp.stages:
            stage = st.stages[i]
            end_leg = np.min([self._ints(st.legs[b][st.end_leg(i)], dims)
                              for b in st.keypoints[stage.end]], axis=0)
            hi = np.maximum(hi, self._bounds(i, dims)[1] - end_leg)
            start = np.max([start] + [self._ints(st.legs[a][start_leg(st, i)], dims)
                                      for a in st.keypoints[stage.start]], axis=0)
        grp.cap, grp.max_len = _box(hi, grp.r, start)
        n = len(grp.fillers) + 1
        states = math.prod(int(c) + 1 for c in grp.cap)
        need = states * row_bytes(n, self._dense(states, n)) + 8 * n * n
        if need > self.budget:
            widest = int(np.argmax(grp.cap))
            name = dims[widest]
            raise TooLargeError(
                f"structure too large: the graph of stage {grp.stages[0]} (shared by "
                f"{len(grp.stages)} stage(s) with the same fillers) has up to "
                f"{states * n:,} states (~{need / 2**20:,.0f} MB), over the memory budget "
                f'of {self.budget / 2**20:,.0f} MB. The widest resource is "{name}" '
                f"({int(grp.cap[widest]) + 1:,} values at quantum {self.q[name]:g}): use "
                f'a coarser quantum for it (e.g. "quantum": {{"{name}": '
                f"{2 * self.q[name]:g}}}), tighten its bounds, or raise the budget "
                "(--max-memory MB)", need_mb=need / 2**20, budget_mb=self.budget / 2**20)
        grp.W = np.full((n, n), np.inf)
        for j, f in enumerate(grp.fillers, 1):
            for t, e in enumerate(grp.fillers, 1):
                if (e, f) in st.transitions:
                    grp.W[j, t] = st.transitions[(e, f)] + st.costs[f]

    def _dense(self, states: int, n: int) -> bool:
        """Rows indexed by state (else hashed): small boxes, unless told otherwise."""
        if self.table != "auto":
            return self.table == "dense"
        return states * row_bytes(n, True) <= DENSE_TABLE_MAX_BYTES

    # ---- one graph and its queries ----------------------------------------------
    def _stages_from(self, grp: _Group, a: str, leg: int) -> list[int]:
        """The group's stages that may start with key element a on leg ``leg``."""
        st = self.st
        return [i for i in grp.stages
                if start_leg(st, i) == leg and a in st.keypoints[st.stages[i].start]]

    def _query_set(self, grp: _Group, stages: list[int]) -> _QuerySet:
        """The queries of a graph of the group whose start may begin ``stages``: every
        stage, end element and allowed share at once; made once for every start element
        that begins the same stages (the three corner parts of a block outline)."""
        key = (id(grp), tuple(stages))
        got = self._sets.get(key)
        if got is not None:
            return got
        st = self.st
        R = len(grp.dims)
        cols: list[list[np.ndarray]] = [[], [], [], [], []]   # share, qlo, qhi, bi, pos
        span: dict[tuple[int, str], tuple[int, int]] = {}
        ends: dict[tuple[int, int], tuple[list[np.ndarray], list[np.ndarray]]] = {}
        at = 0
        for p, i in enumerate(stages):
            stage = st.stages[i]
            end = (stage.end, st.end_leg(i))   # a T is reached by its in- or branch leg
            box = self._stage_boxes(grp, i, *end)
            bi = box[3]
            m = len(bi)
            for col, arr in zip(cols, (*box, np.full(m, p, dtype=np.int64)), strict=True):
                col.append(arr)
            bs = st.keypoints[stage.end]
            cut = (at + np.searchsorted(bi, np.arange(len(bs) + 1))).tolist()
            for x, b in enumerate(bs):
                span[(i, b)] = (cut[x], cut[x + 1])
            rows, bis = ends.setdefault((self._end_key(stage.end), end[1]), ([], []))
            rows.append(np.arange(at, at + m))
            bis.append(bi)
            at += m
        share, qlo, qhi, bi, pos = (_cat(col, (0, R) if c in (1, 2) else (0,))
                                    for c, col in enumerate(cols))
        code = self._share_arr[share, 0] if len(self.ghi) == 1 else np.zeros_like(share)
        qw = np.empty(at, dtype=np.int64)
        first = 0
        for (v, _leg), (rows, bis) in ends.items():
            for at_rows, elements in zip(rows, bis, strict=True):
                qw[at_rows] = first + elements
            first += len(st.keypoints[v])
        got = self._sets[key] = _QuerySet(list(stages), qlo, qhi, pos, bi, share, code,
                                          span, list(ends), qw)
        return got

    def _end_key(self, v: int) -> int:
        """The first key point with the same elements as key point v (alike key points
        share their legs and weights: one array operation for every corner of a block)."""
        return self._alike.setdefault(tuple(self.st.keypoints[v]), v)

    def _stage_boxes(self, grp: _Group, i: int, v: int, end_leg: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Stage i's queries on a graph of its group, whatever its start element: every
        end element and allowed share at once, the stage's own interval with the share
        on the structure-wide dimensions, the end key's leg taken off (a block with a
        per-block door count has dozens of shares per stage and end element, a city
        corner 20-30 end elements). Returns the share (index into ``shares``) of each,
        their boxes and the end element (index into key point v's elements) of each,
        by end element, then share."""
        key = (id(grp), i)
        got = self._boxes.get(key)
        if got is not None:
            return got
        lo, hi = self._bounds(i, grp.dims)
        legs = self._legs(grp, v, end_leg)
        idx = self._allowed_shares(i)
        R = len(grp.dims)
        LO = np.empty((len(idx), R), dtype=np.int64)
        HI = np.empty((len(idx), R), dtype=np.int64)
        LO[:] = lo
        HI[:] = hi
        for w, r in enumerate(self.gnames):   # the share on each structure-wide dimension
            d = grp.dims.index(r)
            LO[:, d] = HI[:, d] = self._share_arr[idx, w]
        qlo = np.maximum(LO[None, :, :] - legs[:, None, :], 0)
        qhi = np.minimum(HI[None, :, :] - legs[:, None, :], grp.cap)
        bi, j = np.nonzero((qlo <= qhi).all(axis=2))   # by end element, then share
        got = self._boxes[key] = (idx[j], qlo[bi, j], qhi[bi, j], bi)
        return got

    def _legs(self, grp: _Group, v: int, end_leg: int) -> np.ndarray:
        """The legs (``end_leg``) of key point v's elements in quanta, once per group and
        set of end elements (every corner of a block outline has the same)."""
        st = self.st
        key = (id(grp), tuple(st.keypoints[v]), end_leg)
        got = self._legs_of.get(key)
        if got is None:
            bs = st.keypoints[v]
            got = self._legs_of[key] = np.array(
                [self._ints(st.legs[b][end_leg], grp.dims) for b in bs],
                dtype=np.int64).reshape(len(bs), len(grp.dims))
        return got

    def _weights(self, grp: _Group, a: str, leg: int, v: int, end_leg: int) -> np.ndarray:
        """The weights of the edges into each end element of key point v (from start
        element a itself, then from each filler; into a T's branch leg, the branch-in
        costs), once per group, start, leg and set of end elements."""
        st = self.st
        key = (id(grp), a, leg, tuple(st.keypoints[v]), end_leg)
        got = self._weights_of.get(key)
        if got is None:
            first = st.branch_transitions if leg == 2 else st.transitions
            bs = st.keypoints[v]
            got = self._weights_of[key] = np.empty((len(bs), len(grp.fillers) + 1))
            got[:, 0] = [first.get((a, b), np.inf) for b in bs]
            got[:, 1:] = self._filler_weights(grp, key[3], end_leg)
        return got

    def _filler_weights(self, grp: _Group, bs: tuple[str, ...], end_leg: int) -> np.ndarray:
        """The weights of the edges from each filler into each end element ``bs`` (as
        :meth:`_weights` lays them out), once per group and end: every start element
        of the group shares them."""
        key = (id(grp), bs, end_leg)
        got = self._fillers_of.get(key)
        if got is None:
            last = self.st.branch_in_transitions if end_leg == 2 else self.st.transitions
            got = self._fillers_of[key] = np.array(
                [[last.get((f, b), np.inf) for f in grp.fillers] for b in bs],
                dtype=np.float64).reshape(len(bs), len(grp.fillers))
        return got

    def _allowed_shares(self, i: int) -> np.ndarray:
        """The shares (indices into ``shares``) of the structure-wide resources stage i
        may take (its own interval on such a resource, if any), once per stage."""
        got = self._shares_of.get(i)
        if got is None:
            stage = self.st.stages[i]
            if any(r in stage.constraints for r in self.gnames):
                ok = shares_allowed(stage, self._share_arr, self.gnames, self.gq)
                got = np.flatnonzero(ok).astype(np.int64)
            else:
                got = self._all_shares
            self._shares_of[i] = got
        return got

    def _graph(self, grp: _Group, a: str, leg: int, qs: _QuerySet
               ) -> tuple[StageGraph, int]:
        """Grow the graph of start element a on leg ``leg`` (forward only) and wrap it
        with its queries for the kernel; returns it and its row count."""
        st = self.st
        n = len(grp.fillers) + 1
        first = st.branch_transitions if leg == 2 else st.transitions
        W = grp.W.copy()
        for j, f in enumerate(grp.fillers, 1):
            if (a, f) in first:
                W[j, 0] = first[(a, f)] + st.costs[f]
        r = np.vstack([self._ints(st.legs[a][leg], grp.dims)[None, :], grp.r])
        cap = grp.cap
        R = len(cap)
        stride = np.cumprod(np.concatenate(([1], cap[:-1] + 1))).astype(np.int64)
        S = int(stride[-1] * (cap[-1] + 1))
        dense = self._dense(S, n)
        off = r @ stride
        # the weights of the edges into the end elements, a row per end element (not
        # per query: a per-block window count asked 184,788 queries of 47 elements, and
        # a row each held 66 MB a graph, 1.8 GB for the 27 graphs of a 100 m block)
        wq = np.concatenate([self._weights(grp, a, leg, v, end_leg)
                             for v, end_leg in qs.ends]) if qs.ends else np.zeros((0, n))
        left = self.budget - self._held - 8 * n * n
        if dense and DENSE_FORWARD:   # a row per state: the states in order suffice
            keeps = S * (8 * n + 8)   # g and the states, as a grown graph's rows below
            if keeps > left:
                self._over_budget(grp, keeps)
            self._account(keeps)
            g = self._take(S, n)
            forward_dense(n, r, cap, stride, S, off, W, g)
            return StageGraph(S * n, n, W, g, np.arange(S, dtype=np.int64), off, cap, stride,
                              True, np.full(1, -1, dtype=np.int64),
                              np.full(1, -1, dtype=np.int32), 0, qs.qlo, qs.qhi, wq,
                              qs.qw), S
        front = np.zeros(n, dtype=np.bool_)
        front[0] = True
        max_rows = max(left // row_bytes(n, dense), 1)
        (status, nrows, g, _h, row_state, *_), (keys, vals, shift) = _grow_graph(
            n, r, np.zeros(R, dtype=np.int64), cap, stride, S, off,
            r.sum(axis=1), int(cap.sum()), W, np.ones(n, dtype=np.int64), front,
            np.zeros(n, dtype=np.bool_), np.zeros(n), dense, min(S, 1 << 12), max_rows,
            True, False)
        if status != STATUS_OK:
            self._over_budget(grp, max_rows * row_bytes(n, dense))
        # what the graph keeps: its rows of g and states and its hash table (the rest
        # of g's capacity is never written, so never mapped; h is dropped)
        self._account(int(nrows) * (8 * n + 8) + keys.nbytes + vals.nbytes)
        return StageGraph(int(nrows) * n, n, W, g, row_state, off, cap, stride, dense, keys,
                          vals, int(shift), qs.qlo, qs.qhi, wq, qs.qw), int(nrows)

    def _account(self, nbytes: int) -> None:
        """One more graph kept, of ``nbytes``."""
        self._held += nbytes
        self._grown += 1

    def _over_budget(self, grp: _Group, at_least: int) -> NoReturn:
        """Refuse the structure: the next graph (``at_least`` bytes or more) does not fit
        beside the graphs kept. What all of them would take is estimated from those
        grown so far (the graphs of one structure are much alike)."""
        left = self._graphs - self._grown
        each = max(at_least, self._held // max(self._grown, 1))
        need = self._held + left * each
        mb, budget = need / 2**20, self.budget / 2**20
        raise TooLargeError(
            f"structure too large: its {self._graphs:,} stage graphs would take about "
            f"{_mb(mb)} MB ({self._grown:,} fit, stage {grp.stages[0]}'s next one does "
            f"not), over the memory budget of {_mb(budget)} MB; use a coarser quantum, "
            "tighter bounds or raise the budget (--max-memory MB)",
            need_mb=mb, budget_mb=budget)

    def _solve(self, grp: _Group, a: str, leg: int) -> None:
        """Solve the queries of the graph of (a, leg): their best costs (one-path lists,
        made when read), or their lists of ``first`` paths."""
        stages = self._stages_from(grp, a, leg)
        qs = self._query_set(grp, stages)
        rec = None
        if len(qs.bi) and not (self._ints(self.st.legs[a][leg], grp.dims) > grp.cap).any():
            G, rows = self._graph(grp, a, leg, qs)
            gid, gi = len(self._paths), len(self._graph_of)
            self._graph_of.append((G, grp.max_len + 3, grp.fillers))
            if self.first == 1 and stage_kbest.BEST_BY_ARGMIN:
                # entries point at their queries: paths found when read
                rec = _Solved(a, qs, gid, gi, _stage_best_costs(G))
                self._deferred[gid] = gi
                self._paths.append((_empty(), _empty(), grp.fillers))
            else:
                found, paths = first_lists(G, self.first, self.k, grp.max_len + 3, gid, gi)
                self._paths.append((*paths, grp.fillers))
                rec = _Solved(a, qs, gid, gi, None)
                shares = self.shares
                for i in stages:
                    for b in self.st.keypoints[self.st.stages[i].end]:
                        lo, hi = qs.span[(i, b)]
                        self._lists[(i, a, b)] = {
                            shares[x]: ls for x, ls in zip(qs.share[lo:hi].tolist(),
                                                           found[lo:hi], strict=True)
                            if ls is not None}
            self._solved.append(rec)
            self.counts["stage_graphs"] += 1
            self.counts["stage_queries"] += len(qs.bi)
            self.counts["graph_rows"] += rows
        for i in stages:
            self._from[(i, a)] = rec

    def _take(self, rows: int, cols: int) -> np.ndarray:
        a = take(rows, cols)
        self._taken.append(a)
        return a

    def release(self) -> None:
        """Give the graphs' tables back for the next solve (:mod:`.buffers`): call it
        once nothing reads this provider any more; it can answer nothing after."""
        self._graph_of.clear()
        self._solved.clear()
        self._from.clear()
        self._lists.clear()
        give_back(self._taken)
        self._taken.clear()

    # ---- the provider interface (see citysynth.solver.structures.combine) --------
    def lists(self, i: int, a: str, b: str) -> dict[Share, StageList]:
        """Stage i's lists from a to b by share (made on first reading from the best
        costs of a graph's queries, then kept: :meth:`more` grows them in place)."""
        got = self._lists.get((i, a, b))
        if got is None:
            got = self._lists[(i, a, b)] = self._one_path_lists(i, a, b)
        return got

    def _one_path_lists(self, i: int, a: str, b: str) -> dict[Share, StageList]:
        rec = self._from.get((i, a))
        if rec is None or rec.costs is None:
            return {}
        lo, hi = rec.qs.span.get((i, b), (0, 0))
        shares, k, gid, gi = self.shares, self.k, rec.gid, rec.gi
        return {shares[x]: one_path(c, gid, q, k, gi)
                for q, c, x in zip(range(lo, hi), rec.costs[lo:hi].tolist(),
                                   rec.qs.share[lo:hi].tolist(), strict=True)
                if c < math.inf}

    def first_costs(self) -> np.ndarray | None:
        """The cost of the first entry of every stage list as one array C[stage, start
        element, end element, share] (elements by their index at their key point,
        inf where there is none; shares by value, one structure-wide resource at
        most), when every list is made from its graph's best costs (else None): what
        the lazy program of :mod:`.chain_kbest` starts from, without making the lists."""
        if len(self.gnames) > 1 or any(rec.costs is None for rec in self._solved):
            return None
        st = self.st
        E = max(len(kp) for kp in st.keypoints)
        C = np.full((len(st.stages), E, E, self.ghi[0] + 1 if self.gnames else 1), np.inf)
        for rec in self._solved:
            qs = rec.qs
            ai = np.array([st.keypoints[st.stages[i].start].index(rec.a) for i in qs.stages],
                          dtype=np.int64)
            stage = np.array(qs.stages, dtype=np.int64)
            C[stage[qs.pos], ai[qs.pos], qs.bi, qs.code] = rec.costs
        return C

    def more(self, i: int, a: str, b: str, share: Share) -> int:
        """Find twice as many paths of a :class:`Growing` list (at most k); returns how
        many of its entries are final now (k once it is complete). The list is
        replaced by a longer one with the same leading entries."""
        old = self._lists[(i, a, b)][share]
        assert isinstance(old, Growing)
        G, depth, fillers = self._graph_of[old.gi]
        K = min(self.k, 2 * old.K)
        costs, offs, fill, first, same = _stage_kbest_of(G, np.array([old.q]), K, depth)
        gid = len(self._paths)
        self._paths.append((offs, fill, fillers))
        ls = sorted_paths(costs.tolist(), 0, int(first[1]), K, self.k, same, gid, old.gi,
                          old.q)
        self._lists[(i, a, b)][share] = ls
        return ls.final if isinstance(ls, Growing) else self.k

    def second_cost(self, i: int, a: str, b: str, share: Share) -> float:
        """A lower bound on the cost of entry 1 of a :class:`Growing` list that holds
        one final path so far (inf: there is no second path), from its graph's costs
        along the best path (:func:`~citysynth.solver.structures.stage_kbest._second_cost`,
        its very cost in practice), without finding the second path as :meth:`more`
        does (several times dearer): the lazy program asks for that only once it is
        the least of its candidates. Once per list (with a structure-wide resource,
        nodes of the lazy program at several shares offer the same list's entry)."""
        key = (i, a, b, share)
        got = self._seconds.get(key)
        if got is None:
            ls = self._lists[(i, a, b)][share]
            assert isinstance(ls, Growing)
            got = self._seconds[key] = float(_second_cost(self._graph_of[ls.gi][0], ls.q))
        return got

    def filling(self, i: int, a: str, b: str, payload: tuple[int, int]
                ) -> tuple[list[str], dict[str, float]]:
        """The fillers of a stage list entry and the stage's totals in original units
        (legs included), summed exactly as one-stage solutions are."""
        gid, p = payload
        if gid in self._deferred:
            gid, p = self._best_path(gid, p)
        offs, fill, fillers = self._paths[gid]
        ids = [fillers[j - 1] for j in fill[offs[p]:offs[p + 1]].tolist()]
        st = self.st
        legs = (st.legs[a][start_leg(st, i)], st.legs[b][st.end_leg(i)])
        return ids, {r: round(math.fsum([legs[0][r], legs[1][r]]
                                        + [st.elements[x][r] for x in ids]), 9)
                     for r in st.resources}

    def _best_path(self, gid: int, q: int) -> tuple[int, int]:
        """Where the best path of query q of a one-path list set (see
        :func:`~citysynth.solver.structures.stage_kbest.first_lists`) is, found once."""
        got = self._read.get((gid, q))
        if got is None:
            G, _depth, fillers = self._graph_of[self._deferred[gid]]
            fill, same = _best_fill(G, q)
            offs = np.array([0, len(fill)], dtype=np.int64)
            if not same:
                raise AssertionError("a best filling's front-to-back sum differs from its "
                                     "graph cost")
            got = self._read[(gid, q)] = (len(self._paths), 0)
            self._paths.append((offs, fill, fillers))
        return got

    def stats(self) -> dict[str, Any]:
        return {"stages_by": "graphs", **self.counts}

    def reason(self) -> Blocked | None:
        """Why no structure fits, from the one-stage diagnosis of a stage that no pair
        of key elements can fill (else of the first pair that cannot)."""
        if self.gnames:
            return None
        st = self.st
        empty = sorted(((i, a, b) for i, a in self._from
                        for b in st.keypoints[st.stages[i].end] if not self.lists(i, a, b)),
                       key=lambda t: t[0])
        blocked = [(i, a, b) for i, a, b in empty
                   if not any(self.lists(i, x, y)
                              for x in st.keypoints[st.stages[i].start]
                              for y in st.keypoints[st.stages[i].end])]
        if not empty:
            return None
        i, a, b = (blocked or empty)[0]
        r = solve(StageBuilder(st, 1).problem(i, a, b), 1)
        return Blocked(i, f"stage {i} between {a} and {b}: {r.reason}", r.details) \
            if r.reason else None
