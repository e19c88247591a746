"""Why a problem is infeasible, in the user's units.

"Infeasible" is an answer, so it comes with a reason: which constraint cannot be met
and the nearest values that can. For each constrained resource we relax its own
bounds (lower bound to zero, upper bound extended by the largest element) and keep
all the others, grow the graph forward only, and read off the totals that complete
sequences reach. A resource whose interval none of them hits is a blocking
constraint; its nearest achievable totals below and above are reported.
"""

from __future__ import annotations

import numpy as np

from citysynth.solver.bounds import range_tables
from citysynth.solver.compiled import Compiled, with_bounds
from citysynth.solver.estimate import dense_rows
from citysynth.solver.graph import grow


def nearest(detail: dict) -> list[float]:
    """A blocking constraint's nearest achievable totals (below, then above; those
    that exist), from an entry of :func:`diagnose`'s details."""
    return [x for x in (detail.get("nearest_below"), detail.get("nearest_above"))
            if x is not None]


def _fmt(x: float) -> str:
    """A total as a message says it: short (``%g``) unless that rounds it, as six
    digits round 999,999.6 m and 1,000,001.4 m alike to "1e+06"; then in full."""
    v = round(x, 9)
    short = f"{v:g}"
    return short if float(short) == v else f"{v:.15g}"


def _interval_text(name: str, lo: float, hi: float) -> str:
    if lo == hi:
        return f"{name} = {_fmt(lo)}"
    return f"{name} in [{_fmt(lo)}, {_fmt(hi)}]"


def _reachable_totals(cp: Compiled, max_rows: int) -> np.ndarray | None:
    """Quantised totals (rows) of complete sequences meeting cp's upper bounds; None
    when growing them is cut short by the row budget, or by the machine's memory: the
    budget is the solver's, and a process limited below it (``ulimit -v 3 GB``) met a
    MemoryError here, a traceback while explaining an infeasible tower (a 200.1 m tower
    at a FAR of 1 to 100); the diagnosis then says less, as when the budget cuts it."""
    try:
        (status, nrows, G, _H, row_state, *_), _table = grow(
            cp, dense=dense_rows(cp), rows_hint=min(cp.S, 1 << 12), max_rows=max_rows,
            forward_only=True, complete=False)
    except MemoryError:
        return None
    if status != 0:
        return None
    reached = (G[:nrows][:, cp.back] < np.inf).any(axis=1)
    st = row_state[:nrows][reached]
    return np.stack([(st // cp.stride[i]) % (cp.cap[i] + 1) for i in range(cp.R)], axis=1)


SPAN_BYTES = 256 << 20   # range tables the diagnosis may build


def spans_fit(cp: Compiled, given: str) -> bool:
    """Do the range tables over resource ``given`` (16 bytes a node of its relaxation)
    fit :data:`SPAN_BYTES`? When not, :func:`reach_given` says None without knowing."""
    return 16 * (int(cp.cap[cp.bounded.index(given)]) + 1) * cp.n <= SPAN_BYTES


def _spans(cp: Compiled, level: int | None = None) -> tuple[int, dict[int, tuple[int, int]]]:
    """The resource L (``level``, by default the narrowest) and, for every other
    resource j, the least and the most (-1: unbounded) of j (quanta) that sequences
    meeting L's interval alone consume (none: no such sequence). Growing the graph
    with j's bounds relaxed only sees totals up to one element past j's interval; a
    tower of 300 m needs twice the floor area a 900 m² lot allows at FAR 4, far past
    that window, and only this says how far."""
    if cp.R < 2:
        return -1, {}
    if level is None:
        level = min(range(cp.R), key=lambda i: (int(cp.cap[i]), i))
    ranges = range_tables(cp, level, SPAN_BYTES)
    if not ranges:
        return level, {}
    n, out = cp.n, {}
    first = np.flatnonzero(cp.front & (cp.r[:, level] <= cp.cap[level]))
    at = cp.r[first, level] * n + first
    size = (int(cp.cap[level]) + 1) * n
    for t, j in enumerate(ranges["rother"]):
        lo = cp.r[first, j] + ranges["rmin"][t * size + at]
        hi = cp.r[first, j] + ranges["rmax"][t * size + at]
        lo, hi = lo[np.isfinite(lo)], hi[hi > -np.inf]
        if len(lo) and len(hi):
            out[int(j)] = (int(lo.min()), int(hi.max()) if np.isfinite(hi.max()) else -1)
    return level, out


def reach_given(cp: Compiled, given: str, other: str) -> tuple[float, float] | None:
    """The least and the most of resource ``other`` (in its units) that sequences
    meeting resource ``given``'s interval alone consume, or None when no sequence meets
    it (or the tables do not fit, :func:`spans_fit`): what a tower of that height can
    have of floor area, or how tall towers of that floor area are, say, however far
    from what was asked. Both are exact: some sequence consumes the least, and one the
    most; the most is inf when it may be unbounded
    (:func:`~citysynth.solver.bounds.most_is_exact`; not for towers: a roof adds height
    and no floor area, but no roof follows a roof)."""
    i, j = cp.bounded.index(given), cp.bounded.index(other)
    _level, spans = _spans(cp, i)
    if j not in spans:
        return None
    least, most = spans[j]
    q = cp.quant[j].quantum
    return round(least * q, 9), (round(most * q, 9) if most >= 0 else float("inf"))


def _beyond_window(cp: Compiled, asked: list[tuple[float, ...]], details: list[dict]
                   ) -> list[str]:
    """When the grown graphs named no constraint: those missed by sequences meeting
    the narrowest constraint alone (:func:`_spans`), appended to ``details``; their
    reasons."""
    level, spans = _spans(cp)
    blocking = []
    for j, (least, most) in spans.items():
        name, q = cp.bounded[j], cp.quant[j].quantum
        if least <= cp.hi[j] and (most < 0 or most >= cp.lo[j]):
            continue
        below = round(most * q, 9) if 0 <= most < cp.lo[j] else None
        above = round(least * q, 9) if least > cp.hi[j] else None
        details.append({"constraint": name, "asked": [asked[j][0], asked[j][1]],
                        "nearest_below": below, "nearest_above": above,
                        "blocks": "together", "given": cp.bounded[level]})
        reach = (f"at least {_fmt(least * q)}" if above is not None
                 else f"at most {_fmt(most * q)}")
        blocking.append(f"{_interval_text(name, *asked[j])} cannot be met together with "
                        f"{_interval_text(cp.bounded[level], *asked[level])}: sequences "
                        f"meeting that reach {name} {reach}")
    return blocking


def _alone_blocks(cp: Compiled, i: int, no_minimums: np.ndarray | None) -> bool:
    """True when resource i's interval is missed even with every other lower bound
    dropped (so the other constraints are not to blame). ``no_minimums`` holds the
    totals reached with every lower bound dropped, grown once for all resources."""
    if no_minimums is None:
        return False
    hit = (no_minimums[:, i] >= cp.lo[i]) & (no_minimums[:, i] <= cp.hi[i])
    return not hit.any()


SMALL_BOX = 1 << 22   # (states x elements): a box the diagnosis grows at once, exactly


def _multiples(cp: Compiled, asked: list[tuple[float, ...]], details: list[dict],
               blocking: list[str]) -> None:
    """The constraints no total can meet because every element's amount is a multiple
    of some g quanta and the interval holds no multiple of g (every part a multiple of
    0.2 m, a length of exactly 3000.1 m): exact, and found in microseconds, where growing
    the graph to find out took minutes and gigabytes, and ran out of budget. Asked only
    of a box larger than :data:`SMALL_BOX` (a small one is grown: its nearest totals are
    the ones sequences reach; these are the nearest multiples)."""
    for i, name in enumerate(cp.bounded):
        amounts = cp.r[:, i][cp.r[:, i] > 0].astype(np.int64)
        g = int(np.gcd.reduce(amounts)) if len(amounts) else 0
        lo, hi = int(cp.lo[i]), int(cp.hi[i])
        if g <= 1 or lo > hi or (hi // g) * g >= lo:
            continue
        q = cp.quant[i].quantum
        below, above = round((hi // g) * g * q, 9), round(-(-lo // g) * g * q, 9)
        details.append({"constraint": name, "asked": [asked[i][0], asked[i][1]],
                        "nearest_below": below, "nearest_above": above, "blocks": "alone"})
        blocking.append(f"{_interval_text(name, *asked[i])} is out of reach: every "
                        f"element's {name} is a multiple of {_fmt(g * q)}, and no multiple "
                        f"lies in it; nearest possible: {_fmt(below)} (below), "
                        f"{_fmt(above)} (above)")


def diagnose(cp: Compiled, max_rows: int) -> tuple[str, list[dict]]:
    """A one-line reason and per-constraint details for an infeasible problem: for each
    blocking constraint its name, the interval asked, the nearest totals below and above
    it that complete sequences reach, and what blocks it (``blocks``: "alone", out of
    reach even with the other minimums dropped; "together", only with the others;
    "quantum", its interval holds no multiple of its quantum), in the reason's order."""
    asked = [tuple(q.asked) for q in cp.quant]
    details: list[dict] = []
    blocking: list[str] = []
    if cp.S * cp.n > SMALL_BOX:   # growing would be dear: first what multiples prove
        _multiples(cp, asked, details, blocking)
        if blocking:
            return "; ".join(blocking), details
    cut_short = False
    # totals with every lower bound dropped: grown on first need, shared by every
    # blocking resource
    no_minimums: np.ndarray | None = None
    grown = False
    any_reach = False
    for i, name in enumerate(cp.bounded):
        lo = cp.lo.copy()
        hi = cp.hi.copy()
        lo[i] = 0
        hi[i] = cp.hi[i] + int(cp.r[:, i].max())
        totals = _reachable_totals(with_bounds(cp, lo, hi), max_rows)
        if totals is None:
            cut_short = True
            continue
        others = np.ones(len(totals), dtype=bool)
        for j in range(cp.R):
            if j != i:
                others &= totals[:, j] >= cp.lo[j]
        vals = np.unique(totals[others, i])
        if len(vals) == 0:
            continue
        any_reach = True
        q = cp.quant[i].quantum
        inside = vals[(vals >= cp.lo[i]) & (vals <= cp.hi[i])]
        if len(inside):
            continue
        below = vals[vals < cp.lo[i]]
        above = vals[vals > cp.hi[i]]
        nearest_below = round(float(below.max()) * q, 9) if len(below) else None
        nearest_above = round(float(above.min()) * q, 9) if len(above) else None
        detail = {"constraint": name, "asked": [asked[i][0], asked[i][1]],
                  "nearest_below": nearest_below, "nearest_above": nearest_above,
                  "blocks": "together"}
        details.append(detail)
        near = []
        if nearest_below is not None:
            near.append(f"{_fmt(nearest_below)} (below)")
        if nearest_above is not None:
            near.append(f"{_fmt(nearest_above)} (above)")
        why = "cannot be met together with the other constraints"
        if not grown:
            no_minimums = _reachable_totals(
                with_bounds(cp, np.zeros_like(cp.lo), cp.hi.copy()), max_rows)
            grown = True
        if _alone_blocks(cp, i, no_minimums):
            why, detail["blocks"] = "is out of reach even ignoring the other minimums", "alone"
        if cp.lo[i] > cp.hi[i]:
            why, detail["blocks"] = f"holds no multiple of its quantum {q:g}", "quantum"
        blocking.append(f"{_interval_text(name, *asked[i])} {why}; nearest achievable: "
                        f"{', '.join(near) or 'none'}")
    if not details:   # the grown graphs saw nothing in their window: look further
        blocking += _beyond_window(cp, asked, details)
    return _reason(cp, asked, blocking, any_reach, cut_short), details


def _reason(cp: Compiled, asked: list[tuple[float, ...]], blocking: list[str],
            any_reach: bool, cut_short: bool) -> str:
    """The one-line reason: the blocking constraints, else what the growth saw (nothing
    at all, or too much to grow: then it says so, not that front and back are
    unconnected)."""
    if blocking:
        return "; ".join(blocking)
    if not any_reach and cut_short:
        return ("no sequence meets every constraint, and finding which one blocks would "
                "take more than the memory budget (--max-memory); try each constraint "
                "alone, or a coarser quantum")
    if not any_reach:
        return ('no sequence of elements, each allowed to follow the one before (the '
                '"transitions"), leads from a first element to a last one (the "front" '
                'and "back" lists; every element when they are left out) within the '
                'bounds; check the transitions, which may list too few pairs')
    wanted = ", ".join(_interval_text(n, *asked[i]) for i, n in enumerate(cp.bounded))
    return f"each constraint can be met alone but not all together ({wanted}); relax one of them"
