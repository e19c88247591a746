"""Solving structures exactly for the k best (:func:`solve_structure`).

Once the key elements are fixed a structure's cost is the sum of independent stage
costs, so the k best fillings of every stage between every pair of key elements (per
share of the structure-wide resources) combine exactly into the k best structures by
a k-best dynamic program over the tree of key points (:mod:`.combine`). The stage
lists come from shared forward graphs, one per group of alike stages and start
element, queried for all end elements and stages at once (:mod:`.stage_graphs`, the
default); or, as the reference and the FGS baseline, from one one-stage problem per
stage and key pair (:mod:`.decompose`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

from citysynth.solver.entry import Status, check_budget, check_k
from citysynth.solver.errors import ProblemError, TooLargeError
from citysynth.solver.methods import DEFAULT_MAX_MEMORY_MB
from citysynth.solver.quantize import exact_divisor, is_multiple
from citysynth.solver.structures.blocked import Blocked
from citysynth.solver.structures.chain_kbest import Read, Rows
from citysynth.solver.structures.combine import (
    Payload,
    best_structures,
    first_paths,
    lazy_chain,
    paused_gc,
    root_of,
)
from citysynth.solver.structures.decompose import Grid, PairProblems, stage_fillers
from citysynth.solver.structures.model import Structure
from citysynth.solver.structures.stage_graphs import NotExact, StageGraphs

# how stage lists are made: shared stage graphs ("auto", the best structure method, and
# "rcksp"), or one problem per stage and key pair solved by the intermediate graph
# ("decompose", the reference), the cost-bounded search ("bounded") or FGS ("fgs")
StructureMethod = Literal["auto", "rcksp", "decompose", "bounded", "fgs"]
METHODS: tuple[StructureMethod, ...] = get_args(StructureMethod)
Provider = StageGraphs | PairProblems


@dataclass
class StructureSolution:
    keys: list[str]                  # the element at each key point
    stages: list[list[str]]          # the fillers of each stage
    cost: float
    resources: list[dict[str, float]]   # per stage, legs included


@dataclass
class StructureResult:
    status: Status
    solutions: list[StructureSolution]
    stats: dict[str, Any] = field(default_factory=dict)
    reason: str | None = None
    blocked: Blocked | None = None   # the stage the reason names, when it names one


def _global_grid(st: Structure) -> Grid:
    """Structure-wide resources on an exact integer grid: names, quanta, bounds. An
    interval every filling meets (from zero or less up to the most the stages can reach,
    no amount negative) is left out: the search needs no shares to keep it."""
    names: list[str] = []
    qs: list[float] = []
    los: list[int] = []
    his: list[int] = []
    for r, (lo, hi) in st.global_constraints.items():
        values = [v[r] for v in st.elements.values()] + [leg[r] for legs in st.legs.values()
                                                         for leg in legs]
        reach, clipped = _reach(st, r), False
        if reach is not None and lo <= 0 <= min(values, default=0.0) and hi >= reach:
            continue        # every filling meets it ("doors = [0, 1e20]"): no shares
        if reach is not None and hi > max(reach, lo):   # beyond reach: no bound
            hi, clipped = max(reach, lo), True
        q = st.quantum.get(r)
        if q is None:
            frac = exact_divisor(values + [lo] + ([] if clipped else [hi]))
            if frac is None:
                raise ProblemError(f'structure-wide constraint on "{r}": its values have no '
                                   "common divisor; give a quantum")
            q = float(frac)
        if not all(is_multiple(v, q) for v in values):
            raise ProblemError(f'structure-wide constraint on "{r}": every value must be a '
                               f"multiple of its quantum {q:g} (sums are split between "
                               "stages exactly)")
        names.append(r)
        qs.append(q)
        los.append(int(math.ceil(lo / q - 1e-9)))
        his.append(int(math.floor(hi / q + 1e-9)))
    _check_shares(names, his)
    return names, qs, los, his


def _reach(st: Structure, r: str) -> float | None:
    """An upper bound on the structure-wide total of ``r``, or None when nothing bounds
    it: each stage's upper bound on a resource every filler has a positive amount of
    (its length) caps the stage's ``r`` at that bound times the most ``r`` a filler has
    per unit of it, and the key elements add their legs'. An interval reaching past it
    ("doors = [0, 1e20]", meaning no limit) is clipped to it, so its shares stay few.

    The fillers' amounts and their most ``r`` per unit of each resource are found once
    per set of fillers, the most a key point's legs hold once per set of key elements
    (a block's sides and corners all have the same: found per side and corner, this
    took a third of a millisecond of every solve of a 40-corner block with a per-block
    interval)."""
    total = 0.0
    fillers: dict[tuple[str, ...] | None, list[dict[str, float]]] = {}
    most: dict[tuple[tuple[str, ...] | None, str], float | None] = {}   # None: unbounded
    for i, stage in enumerate(st.stages):
        fk = stage.elements   # what decides the stage's fillers (None: every filler)
        amounts = fillers.get(fk)
        if amounts is None:
            amounts = fillers[fk] = [st.elements[e] for e in stage_fillers(st, i)]
            if any(a[r] < 0 for a in amounts):
                return None
        caps = []
        for s, (_lo, hi) in stage.constraints.items():
            if not math.isfinite(hi):
                continue
            if (fk, s) not in most:
                most[(fk, s)] = (max((a[r] / a[s] for a in amounts), default=0.0)
                                 if all(a[s] > 0 for a in amounts) else None)
            m = most[(fk, s)]
            if m is not None:
                caps.append(hi * m)
        if not caps:
            return None
        total += min(caps)
    legs_of: dict[tuple[str, ...], float | None] = {}   # by key point elements
    for candidates in st.keypoints:
        if candidates not in legs_of:
            legs = [sum(leg[r] for leg in st.legs.get(e, ())) for e in candidates]
            legs_of[candidates] = None if any(x < 0 for x in legs) else max(legs, default=0.0)
        m = legs_of[candidates]
        if m is None:
            return None
        total += m
    return total


def _out_of_reach(st: Structure) -> str | None:
    """Why no filling can meet a structure-wide minimum past what the stages can reach,
    or None (asked when its shares would be refused as too many: a small one is found
    infeasible by the solve itself)."""
    for r, (lo, _hi) in st.global_constraints.items():
        reach = _reach(st, r)
        if reach is not None and lo > reach + 1e-9 * max(1.0, reach):
            return (f'the structure-wide interval on "{r}" asks for at least {lo:g}, more '
                    f"than the stages can reach (at most {reach:.4g})")
    return None


MAX_SHARES = 1_000_000   # ways to split the structure-wide totals, per stage


def share_count(his: list[int]) -> int:
    """The ways a stage may take a share of structure-wide totals whose upper bounds are
    ``his`` quanta: 0 .. hi of each."""
    return math.prod(h + 1 for h in his)


def _check_shares(names: list[str], his: list[int]) -> None:
    """Refuse, before anything is allocated, a structure-wide interval whose every
    share a stage may take would be enumerated past :data:`MAX_SHARES`."""
    shares = share_count(his)
    if shares > MAX_SHARES:
        raise TooLargeError(
            f"structure-wide constraints on {', '.join(names)}: {shares:,} ways to share "
            f"the totals between stages (each stage's solutions are kept per share; about "
            f"{shares * 64 / 2**30:,.0f} GB before any is solved), more than {MAX_SHARES:,}; "
            "narrow the interval to what the structure can reach",
            shares=shares, resources=tuple(names))


SHARE_BYTES = 64   # what a stage keeps per share of the structure-wide totals (measured:
                   # 10,000 stages x 30,001 shares reached 21 GB before the kernel killed it)


def _check_stage_shares(st: Structure, names: list[str], his: list[int],
                        max_memory_mb: float) -> None:
    """Refuse, before anything is allocated, structure-wide intervals whose shares,
    kept for every stage, pass the memory budget (a 10,000-stage cycle with a doors
    interval of [20,000, 30,000] grew until the kernel killed it)."""
    if not names:
        return
    shares = share_count(his)
    need = shares * len(st.stages) * SHARE_BYTES
    if need > max_memory_mb * 2**20:
        raise TooLargeError(
            f"structure-wide constraints on {', '.join(names)}: {shares:,} ways to share "
            f"the totals, kept for each of its {len(st.stages):,} stages, about "
            f"{need / 2**30:,.1f} GB, over the memory budget of {max_memory_mb:,.0f} MB; "
            "narrow the interval, split the structure, or raise the budget "
            "(--max-memory MB)", need_mb=need / 2**20, budget_mb=max_memory_mb,
            shares=shares, resources=tuple(names))


def solve_structure(st: Structure, k: int | None = None, method: StructureMethod = "auto",
                    *, max_memory_mb: float = DEFAULT_MAX_MEMORY_MB, table: str = "auto",
                    **solve_kw: Any) -> StructureResult:
    """The k cheapest distinct fillings of a tree or cycle structure.

    ``method``: "auto" (the default) and "rcksp" fill stages from shared stage graphs,
    the fastest way on every structure measured (``bench.structures``): one graph per
    start element serves every stage, end element and share, where one-stage solves
    repeat that work per pair; "decompose" solves one problem per stage and key pair
    with the intermediate graph (the reference), "bounded" and "fgs" do the same with
    the cost-bounded search and the FGS baseline. A rounding quantum (values that are
    not multiples of it) always takes the decomposition, whose one-stage solves
    re-check every total in original units (with the default one-stage method for
    "auto"). Structure-wide intervals are exact: stage fillings are kept per
    share of each structure-wide resource. Raises :class:`TooLargeError` when a stage
    graph would exceed ``max_memory_mb``. ``table`` forces the graphs' row tables
    ("dense" or "hash", as in :func:`citysynth.solver.entry.solve`); ``solve_kw`` go to
    the one-stage solves. ``stats["stages_by"]`` says which way the stages were filled.

    A rectangle of 10 x 7 with a corner part at every corner, walls and windows
    between (a window costs 0.25, two windows side by side 0.5 more, and no window
    may follow a corner directly):

    >>> from citysynth.solver.structures import Structure, solve_structure
    >>> ids = ("wall", "window", "corner")
    >>> st = Structure.from_dict({
    ...     "resources": ["length"],
    ...     "elements": [{"id": "wall", "resources": {"length": 2}},
    ...                  {"id": "window", "resources": {"length": 3}, "cost": 0.25},
    ...                  {"id": "corner", "legs": [{"length": 1}, {"length": 1}]}],
    ...     "transitions": [[a, b, 0.5 if a == b == "window" else 0.0]
    ...                     for a in ids for b in ids if (a, b) != ("corner", "window")],
    ...     "keypoints": [{"elements": ["corner"]}] * 4,
    ...     "stages": [{"constraints": {"length": [L, L]}} for L in (10, 7, 10, 7)],
    ...     "closed": True})
    >>> r = solve_structure(st, k=3)
    >>> r.status, [s.cost for s in r.solutions]
    ('ok', [0.5, 1.5, 1.5])
    >>> best = r.solutions[0]
    >>> for fill, totals in zip(best.stages, best.resources):
    ...     print(fill, totals)
    ['wall', 'wall', 'wall', 'wall'] {'length': 10.0}
    ['wall', 'window'] {'length': 7.0}
    ['wall', 'wall', 'wall', 'wall'] {'length': 10.0}
    ['wall', 'window'] {'length': 7.0}
    """
    if method not in METHODS:
        raise ProblemError(f"unknown structure method {method!r}; choose one of "
                           f"{', '.join(METHODS)}")
    k = st.k if k is None else int(k)
    check_budget(max_memory_mb)
    check_k(k, max_memory_mb)
    t0 = time.perf_counter()
    try:
        grid = _global_grid(st)
    except TooLargeError:   # a minimum past reach: infeasible, said without its shares
        short = _out_of_reach(st)
        if short is None:
            raise
        return StructureResult("infeasible", [], {"method": method, "stages_by": "none",
                                                  "solve_s": time.perf_counter() - t0}, short)
    gnames, _gq, glo, ghi = grid
    _check_stage_shares(st, gnames, ghi, max_memory_mb)
    with paused_gc():
        provider = _provider(st, k, method, grid, max_memory_mb, table, solve_kw)
        read = _reader(provider)
        ends = _ends_of(st)
        results = best_structures(st, k, ghi, glo, provider.lists,
                                  getattr(provider, "more", None),
                                  getattr(provider, "first_costs", None), read,
                                  getattr(provider, "second_cost", None))
        sols = [_solution(st, cost, e, payload, read, ends) for cost, e, payload in results]
        stats = {"method": method, **provider.stats(),
                 "program": "lazy chain" if lazy_chain(st, ghi) else "general",
                 "solve_s": time.perf_counter() - t0}
        blocked = None if sols else provider.reason()
        if isinstance(provider, StageGraphs):
            provider.release()   # its tables serve the next solve (nothing reads them now)
        # dropped while the collector still sleeps: reference counts free them at once,
        # where the collector, woken with the hundreds of thousands of objects made
        # since it paused, would scan them all first (and again as solutions are read)
        del provider, results, read
    if not sols:
        detail = f"; e.g. {blocked.text}" if blocked else ""
        wide = " and the structure-wide intervals" if gnames else ""
        return StructureResult("infeasible", [], stats,
                               f"no choice of key elements lets every stage meet its "
                               f"constraints{wide}{detail}", blocked)
    return StructureResult("ok", sols, stats)



def _provider(st: Structure, k: int, method: StructureMethod, grid: Grid,
              max_memory_mb: float, table: str, solve_kw: dict[str, Any]) -> Provider:
    """Where the stage lists come from: shared stage graphs for auto and rcksp (unless
    a rounding quantum needs the one-stage solves), else one problem per stage and
    pair."""
    if method in ("auto", "rcksp"):
        try:
            return StageGraphs(st, k, grid, max_memory_mb, table,
                               first=first_paths(st, k, grid[3]))
        except NotExact:
            pass
    one_stage = {"auto": "auto", "rcksp": "rcksp", "decompose": "rcksp",
                 "bounded": "bounded", "fgs": "fgs"}[method]
    return PairProblems(st, k, grid, {
        "method": one_stage,
        "max_memory_mb": max_memory_mb, "table": table, **solve_kw})


def _reader(provider: Provider) -> Read:
    """The provider's ``filling`` of a stage list entry, once per entry: the k best
    structures share most of their stages (4,000 stages of 100 solutions of a
    40-corner block are about 100 distinct entries). By stage and the entry's identity
    (the entry is kept with them, so its id stays its own; an entry belongs to one
    list, so to one pair of key elements)."""
    seen: dict[tuple[int, int], tuple[Any, list[str], dict[str, float]]] = {}

    def read(s: int, a: str, b: str, h: Any) -> tuple[list[str], dict[str, float]]:
        got = seen.get((s, id(h)))
        if got is None or got[0] is not h:
            got = seen[(s, id(h))] = (h, *provider.filling(s, a, b, h))
        return got[1], got[2]
    return read


def _solution(st: Structure, cost: float, root_element: str, payload: Payload | Rows,
              read: Read, ends: tuple[list[int], list[int]]) -> StructureSolution:
    """A structure read back into key elements, fillers and stage totals: from the
    rows of the lazy chain program (each structure's own lists, taken as they are), or
    from a combined payload, stage by stage. ``ends``: every stage's key points."""
    if isinstance(payload, tuple):
        keys, fills, totals = payload
        return StructureSolution(keys, fills, cost, totals)
    starts, stops = ends
    at: list[str | None] = [None] * len(st.keypoints)
    at[root_of(st)] = root_element
    fills = [[] for _ in starts]
    totals = [{} for _ in starts]
    todo = [payload]
    while todo:  # parents first: a stage's start key is known before the stage
        p = todo.pop()
        for s, (f, h, sub) in p.items():
            start, end = at[starts[s]], at[stops[s]]
            if start is None:   # a stage that runs up the tree ends at its parent
                assert end is not None
                a, b = f, end
                at[starts[s]] = f
            else:
                a, b = start, f
                at[stops[s]] = f
            fill, total = read(s, a, b, h)
            fills[s], totals[s] = list(fill), dict(total)
            todo.append(sub)
    assert None not in at
    return StructureSolution(at, fills, cost, totals)   # type: ignore[arg-type]


def _ends_of(st: Structure) -> tuple[list[int], list[int]]:
    """The key points at the start and at the end of every stage."""
    return [s.start for s in st.stages], [s.end for s in st.stages]
