"""The cost-bounded method: the k best sequences without spanning the feasible box.

The intermediate graph (:mod:`citysynth.solver.graph`) holds every node of the feasible box, and
with several constraints that box is large (millions of nodes on a three-resource
street) while the k best sequences pass through a few hundred of them. This method
spends its work near the answer instead:

1. **Bounds.** The exact cost to go of each one-resource relaxation, by a backward
   dynamic program per resource (:mod:`citysynth.solver.bounds`).
2. **One resource.** The relaxation is the problem, the table is the exact cost to go
   of every node, and the lazy k-best enumeration (:mod:`citysynth.solver.kbest`) runs on it
   directly: a plain dynamic program, then k paths. No growth from both ends, no
   completing passes. For the best sequence alone (k = 1) a *coarse* table (the
   amount known to levels of several quanta: a fraction of the program) guides the
   search of 3. instead, which then sees a few hundred labels; should it make more
   than about 1.5 times the exact program's work, it starts again on the exact table.
3. **Several resources.** A best-first (A*) search over (element, state) labels
   ordered by g + bound, ties broken lexicographically, returns the first k
   sequences in (cost, lexicographic) order (:mod:`citysynth.solver.astar`). For
   k = 1 a wide resource's table is coarse too, where it is at least 6 times smaller.
4. **Two resources at once.** Where that search makes a sixteenth of its labels
   without an answer and a pair table applies (:mod:`citysynth.solver.pair_bounds`:
   a resource every element consumes, with another in steps; a tower's height and
   floor area), the search starts again with it and the whole budget.

Exact throughout: the bound never exceeds the true cost to go, so nothing cheaper than
the k-th answer is ever cut, and the sequences are those the other methods return.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from citysynth.solver.astar import STATUS_OK, all_labels, astar_k_best
from citysynth.solver.bounds import Bounds, relaxation_bounds
from citysynth.solver.compiled import Compiled
from citysynth.solver.errors import TooLargeError
from citysynth.solver.graph import Graph
from citysynth.solver.kbest import k_best
from citysynth.solver.pair_bounds import PAIR_TABLE_SHARE, pair_choice, with_pair

BOUNDS_SHARE = 4   # bound tables may use 1/4 of the memory budget, the search the rest
EXACT_SHARE = 2    # a single resource's exact table 1/2, its enumeration the rest
PAIR_FIRST = 16    # where a pair table could be made, the search first takes 1/16 of
PAIR_FIRST_LABELS = 1 << 20   # its labels (at least this many: every bench row needs
                              # fewer), then the pair table and the whole budget


COARSE_STEPS_PER_LABEL = 3000
"""A search on a coarse table gives up for the exact table after one label per this
many (level, transition) steps of the exact table's backward program: a label costs
about 1.2-1.7 us, a step 0.3-0.4 ns (street bench), so the search may spend about
1.5 times what the exact program would have, and a problem the coarse table guides
badly costs at most about 2.5 times the exact path. On the street bench the search
makes 24-1,006 labels, under the 200-1,280 it may."""


def bounds_for(cp: Compiled, budget_bytes: int, k: int = 0) -> Bounds:
    """The relaxation tables this method uses for ``cp`` under the memory budget:
    coarse ones where they apply when only the best sequence is asked for (k = 1: the
    search for it sees a few hundred labels, so a table a fraction of the work guides
    it as well). Not for the second best on: the exact tables save more search than
    they cost (k = 2 took 1.3-2.7x longer on coarse ones on the street bench)."""
    share = EXACT_SHARE if cp.R == 1 else BOUNDS_SHARE
    return relaxation_bounds(cp, budget_bytes // share, coarse=k == 1)


def coarse_labels(cp: Compiled, bounds: Bounds) -> int:
    """The labels a search on coarse tables may make before it gives up for the
    exact tables (:data:`COARSE_STEPS_PER_LABEL`)."""
    steps = sum(int(cp.cap[i]) + 1 for i in bounds.res) * max(len(cp.succ_elem), cp.n)
    return max(256, steps // COARSE_STEPS_PER_LABEL)


def exact_graph(cp: Compiled, bounds: Bounds) -> Graph:
    """The single-resource table as an intermediate graph with dense rows (row = state),
    which is all :func:`citysynth.solver.kbest.k_best` reads."""
    S = int(cp.cap[0]) + 1
    H = bounds.table.reshape(S, cp.n)
    empty = np.zeros((0, cp.n))
    return Graph(cp, 0, 0, 0, S, empty, H, np.arange(S, dtype=np.int64), True,
                 np.full(1, -1, dtype=np.int64), np.full(1, -1, dtype=np.int32), 0, 0, 0)


def _refusal(cp: Compiled, labels: int, budget_bytes: int) -> TooLargeError:
    widest = int(np.argmax(cp.cap))
    name = cp.bounded[widest]
    q = cp.quant[widest].quantum
    values = int(cp.cap[widest]) + 1
    return TooLargeError(
        f"problem too large: the search stopped at the memory budget of "
        f"{budget_bytes / 2**20:,.0f} MB after {labels:,} partial sequences, and more "
        f"come as close to the best cost. The widest resource is \"{name}\" ({values:,} "
        f"values at quantum {q:g}): use a quantum for it several times coarser (e.g. "
        f'"quantum": {{"{name}": {10 * q:g}}}), tighten the bounds, ask for a smaller k, '
        "or raise the budget (--max-memory MB)",
        budget_mb=budget_bytes / 2**20)


def bounded_k_best(cp: Compiled, k: int, budget_bytes: int, bounds: Bounds | None = None,
                   stats: dict[str, Any] | None = None) -> list[list[int]]:
    """The k best sequences (element indices) in (cost, lexicographic) order. Raises
    TooLargeError beyond ``budget_bytes``."""
    st: dict[str, Any] = {} if stats is None else stats
    if bounds is None:
        bounds = bounds_for(cp, budget_bytes)
    st["bound_tables"] = [cp.bounded[i] for i in bounds.res]
    if bounds.exact:
        seqs, _costs, touched = k_best(exact_graph(cp, bounds), k)
        st.update(path="exact", nodes=int(bounds.table.size), kbest_nodes=touched)
        return seqs
    pair = budget_bytes // PAIR_TABLE_SHARE
    first = None if bounds.coarse or len(bounds.pl) or pair_choice(cp, pair) is None \
        else max(PAIR_FIRST_LABELS, all_labels(budget_bytes - bounds.nbytes) // PAIR_FIRST)
    status, seqs, counters = astar_k_best(
        cp, bounds, k, budget_bytes - bounds.nbytes,
        max_labels=coarse_labels(cp, bounds) if bounds.coarse else first)
    st.update(path="astar", labels=counters["labels"], nodes=counters["nodes"],
              settled=counters["settled"], coarse=bounds.coarse)
    if status != STATUS_OK and bounds.coarse:   # a weak coarse bound: the exact tables
        st["coarse_gave_up"] = counters["labels"]  # (within what the coarse ones leave:
        rest = budget_bytes - bounds.nbytes        # the caller may still hold them)
        return bounded_k_best(cp, k, rest, bounds_for(cp, rest), st)
    if status != STATUS_OK and first is not None:  # two resources moving together: the
        paired = with_pair(cp, bounds, pair)        # pair table, then the whole budget
        if paired is not None:
            st["pair_after"] = counters["labels"]
            return bounded_k_best(cp, k, budget_bytes, paired, st)
    if status != STATUS_OK:
        raise _refusal(cp, counters["labels"], budget_bytes)
    return seqs
