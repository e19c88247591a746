"""Stage lists by decomposition: one one-stage problem per stage, key pair and share.

The first structure solver, kept as the reference the shared stage graphs
(:mod:`citysynth.solver.structures.stage_graphs`) are tested against, as the baseline
that runs stages with FGS, and as the fallback for rounding quanta (one-stage solves
re-check totals in original units, see :func:`citysynth.solver.entry._truly_feasible`).
For every stage i and every pair (a, b) of key elements at its ends,
:func:`citysynth.solver.entry.solve` gives the k best fillings of a problem whose first and
last elements are a's and b's legs; with structure-wide intervals it does so once per
share of each structure-wide resource (an equality added to the stage's constraints).
Exact, and slow: a 40-corner block with three corner parts is 360 problems.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from citysynth.solver.entry import solve
from citysynth.solver.problem import Element, Problem
from citysynth.solver.structures.blocked import Blocked
from citysynth.solver.structures.combine import Share, StageList
from citysynth.solver.structures.model import Interval, Stage, Structure

# the structure-wide resources on their integer grid: names, quanta, bounds in quanta
Grid = tuple[list[str], list[float], list[int], list[int]]


def start_leg(st: Structure, s: int) -> int:
    """The leg of the element at stage s's start that counts toward s (see
    :meth:`Structure.start_leg`)."""
    return st.start_leg(s)


def stage_fillers(st: Structure, i: int) -> tuple[str, ...]:
    """The elements that may fill stage i (never a key element)."""
    stage = st.stages[i]
    return tuple(x for x in (stage.elements or st.elements) if x not in st.legs)


def shares_allowed(stage: Stage, shares: np.ndarray, gnames: list[str], gq: list[float]
                   ) -> np.ndarray:
    """Which shares (rows of ``shares``, in quanta of ``gq``) of the structure-wide
    resources stage may take: a share of one it also constrains locally must lie
    inside its own interval too. All rows at once (a share at a time took a
    10,000-stage cycle with a structure-wide doors interval minutes)."""
    ok = np.ones(len(shares), dtype=bool)
    for j, (r, q) in enumerate(zip(gnames, gq, strict=True)):
        if r in stage.constraints:
            lo, hi = stage.constraints[r]
            x = shares[:, j] * q
            ok &= (lo - 1e-9 * max(1.0, lo) <= x) & (x <= hi + 1e-9 * max(1.0, hi))
    return ok


def share_allowed(stage: Stage, share: tuple[int, ...], gnames: list[str], gq: list[float]
                  ) -> bool:
    """Whether stage may take one share (:func:`shares_allowed`)."""
    row = np.asarray(share, dtype=np.int64).reshape(1, len(gnames))
    return bool(shares_allowed(stage, row, gnames, gq)[0])


class StageBuilder:
    """One-stage problems of a structure, built straight from validated data (no
    re-parsing: a 40-corner block needs hundreds of them)."""

    def __init__(self, st: Structure, k: int):
        self.st, self.k = st, k
        self._inner: dict[tuple[str, ...], tuple[tuple[Element, ...],
                                                 tuple[tuple[str, str, float], ...]]] = {}

    def inner(self, fillers: tuple[str, ...]
              ) -> tuple[tuple[Element, ...], tuple[tuple[str, str, float], ...]]:
        """Filler elements and filler-to-filler transitions, shared by every stage with
        the same fillers."""
        if fillers not in self._inner:
            st, fs = self.st, set(fillers)
            els = tuple(Element(f, st.elements[f], st.costs[f]) for f in fillers)
            trans = tuple((x, y, c) for (x, y), c in st.transitions.items()
                          if x in fs and y in fs)
            self._inner[fillers] = (els, trans)
        return self._inner[fillers]

    def problem(self, i: int, a: str, b: str, extra: dict[str, Interval] | None = None
                ) -> Problem:
        """Stage i between key elements a (at its start) and b (at its end); the keys'
        unary costs are counted at their key points, not here."""
        st = self.st
        stage = st.stages[i]
        fillers = stage_fillers(st, i)
        fs = set(fillers)
        els, inner = self.inner(fillers)
        A, B = "^" + a, "$" + b
        leg_a = start_leg(st, i)
        trans = [(A, B if y == b else y, c) for (x, y), c in st.first_table(i).items()
                 if x == a and (y in fs or y == b)]
        trans += [(x, B, c) for (x, y), c in st.last_table(i).items() if y == b and x in fs]
        return Problem(
            resources=st.resources,
            elements=(Element(A, st.legs[a][leg_a], 0.0),
                      Element(B, st.legs[b][st.end_leg(i)], 0.0)) + els,
            transitions=tuple(trans) + inner, front=(A,), back=(B,),
            constraints={**stage.constraints, **(extra or {})}, quantum=dict(st.quantum),
            k=self.k)


class PairProblems:
    """Stage lists (see :mod:`citysynth.solver.structures.combine`) solved pair by pair,
    on demand; a list's payload is the stage's (fillers, resource totals)."""

    def __init__(self, st: Structure, k: int, grid: Grid, solve_kw: dict[str, Any]):
        self.st, self.k = st, k
        self.gnames, self.gq, _glo, ghi = grid
        self.shares = list(itertools.product(*[range(h + 1) for h in ghi]))
        self.solve_kw = solve_kw
        self.builder = StageBuilder(st, k)
        self.cache: dict[tuple[int, str, str], dict[Share, StageList]] = {}
        self.why: list[Blocked] = []

    def lists(self, i: int, a: str, b: str) -> dict[Share, StageList]:
        """share of the structure-wide resources -> k best fillings of stage i"""
        if (i, a, b) not in self.cache:
            gnames, gq = self.gnames, self.gq
            lists: dict[Share, StageList] = {}
            for g in self.shares:
                if not share_allowed(self.st.stages[i], g, gnames, gq):
                    continue
                extra = {r: (x * q, x * q) for r, x, q in zip(gnames, g, gq, strict=True)}
                r = solve(self.builder.problem(i, a, b, extra), self.k,
                          **{"explain": not gnames, **self.solve_kw})
                if r.solutions:
                    lists[g] = [(x.cost, (x.sequence[1:-1], x.resources))
                                for x in r.solutions]
                elif r.reason and not gnames:
                    self.why.append(Blocked(i, f"stage {i} between {a} and {b}: {r.reason}",
                                            r.details))
            self.cache[(i, a, b)] = lists
        return self.cache[(i, a, b)]

    def filling(self, i: int, a: str, b: str, payload: Any
                ) -> tuple[list[str], dict[str, float]]:
        """The fillers of a stage list entry and the stage's totals (legs included)."""
        fill, res = payload
        return list(fill), res

    def reason(self) -> Blocked | None:
        return self.why[0] if self.why else None

    def stats(self) -> dict[str, Any]:
        return {"stages_by": f"pairs ({self.solve_kw.get('method', 'rcksp')})",
                "stage_problems": len(self.shares) * len(self.cache)}
