"""Ties in the best-first search (solver/astar.py): labels of equal f are ordered by
their sequences, compared through Myers' skew-binary jump pointers.

- ``_seq_less`` against a plain comparison of the two labels' full sequences, on
  random label trees built with the search's own jump rule (``_jump_for``): deep
  chains, chains that part deep down and run on at equal depth, end labels.
- Whole searches on plateaus (every sequence of the same cost) a few hundred elements
  deep, against the brute-force enumeration's first k in (cost, lexicographic) order.
"""

from __future__ import annotations

import random

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from citysynth.solver import Problem, solve
from citysynth.solver.astar import _END, _ROOT, _jump_for, _seq_less, astar_k_best
from citysynth.solver.bounded import bounds_for
from citysynth.solver.bounds import Bounds
from citysynth.solver.compiled import compile_problem
from tests.bruteforce import enumerate_feasible

NO_BOUNDS = Bounds(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0),
                   False)


class _Tree:
    """Label arrays as the search grows them: label 0 the root, every new label after
    its parent, siblings on distinct elements, at most one end label a parent (never
    under the root), so distinct labels never share a sequence. Jump pointers by the
    search's own rule."""

    def __init__(self, size: int) -> None:
        self.par = np.full(size, -1, dtype=np.int64)
        self.elem = np.full(size, _ROOT, dtype=np.int64)
        self.dj = np.zeros(2 * size, dtype=np.int64)  # depth at 2i, jump at 2i + 1
        self.dj[0] = -1                               # the root: depth -1, jumps to itself
        self.n = 1
        self.kids: list[dict[int, int]] = [{}]

    def add(self, p: int, e: int) -> int:
        """The label of parent p's child on element e (_END: p's end), made if new."""
        if e in self.kids[p]:
            return self.kids[p][e]
        lab = self.n
        self.n += 1
        self.dj[2 * lab + 1] = _jump_for(p, self.dj)
        self.dj[2 * lab] = self.dj[2 * p] + 1
        self.par[lab], self.elem[lab] = p, e
        self.kids.append({})
        self.kids[p][e] = lab
        return lab

    def alive(self) -> list[int]:
        """The labels that may have children (all but end labels)."""
        return [i for i in range(self.n) if self.elem[i] != _END]

    def euler(self) -> tuple[list[int], list[int]]:
        """Entry and exit times of a depth-first walk: u is an ancestor of v exactly
        when enter[u] <= enter[v] and leave[v] <= leave[u]."""
        enter, leave = [0] * self.n, [0] * self.n
        clock, stack = 0, [(0, False)]
        while stack:
            v, done = stack.pop()
            clock += 1
            if done:
                leave[v] = clock
                continue
            enter[v] = clock
            stack.append((v, True))
            stack += [(c, False) for c in self.kids[v].values()]
        return enter, leave

    def key(self, lab: int) -> list[float]:
        """The reference order's key: the element indices from the front, an end label
        its parent's with -0.5 appended (after the parent, before its extensions)."""
        end = self.elem[lab] == _END
        x = int(self.par[lab]) if end else lab
        seq = []
        while x > 0:
            seq.append(int(self.elem[x]))
            x = int(self.par[x])
        return seq[::-1] + ([-0.5] if end else [])


MAX_CHAIN = 2500


@st.composite
def label_trees(draw):
    n_elem = draw(st.integers(1, 4))
    tree = _Tree(6 * MAX_CHAIN + 200)
    tips: list[int] = []
    # long chains, each from a label already there, some with a twin that takes
    # another element at one depth and then repeats the chain's elements (the two
    # part deep down and run on at equal depths)
    for start, length, seed, twin_at, ends in draw(st.lists(st.tuples(
            st.integers(0, 10**6), st.integers(1, MAX_CHAIN), st.integers(0, 2**32 - 1),
            st.one_of(st.none(), st.integers(0, MAX_CHAIN)), st.booleans()), max_size=3)):
        rng = random.Random(seed)
        alive = tree.alive()
        first = alive[start % len(alive)]
        elems = [rng.randrange(n_elem) for _ in range(length)]
        chain, x = [], first
        for e in elems:
            x = tree.add(x, e)
            chain.append(x)
        tips.append(x)
        if twin_at is not None and n_elem > 1:
            at = twin_at % length
            x = chain[at - 1] if at > 0 else first
            x = tree.add(x, (elems[at] + 1) % n_elem)
            for e in elems[at + 1:]:
                x = tree.add(x, e)
            tips.append(x)
        if ends:
            tips += [tree.add(t, _END) for t in list(tips) if tree.elem[t] != _END]
    # then random growth: off the last label (deepening), or off any label
    for mode, pick, e in draw(st.lists(st.tuples(
            st.integers(0, 2), st.integers(0, 10**6), st.integers(-1, n_elem - 1)),
            min_size=1, max_size=150)):
        alive = tree.alive()
        p = alive[-1] if mode == 0 else alive[pick % len(alive)]
        if e == _END and p == 0:
            e = 0
        tips.append(tree.add(p, _END if e == _END else e))
    picks = draw(st.lists(st.integers(1, tree.n - 1), min_size=1, max_size=25))
    chosen = sorted(set(picks + tips[-12:]))
    return tree, chosen


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.data_too_large])
@given(label_trees())
def test_seq_less_with_jump_pointers_is_the_full_sequence_order(case):
    tree, chosen = case
    par, elem, dj = tree.par[:tree.n], tree.elem[:tree.n], tree.dj[:2 * tree.n]
    dep, jump = dj[0::2], dj[1::2]
    # the pointers themselves: a proper ancestor, its depth a function of the depth
    enter, leave = tree.euler()
    depth_of_jump: dict[int, int] = {}
    for v in range(1, tree.n):
        j = jump[v]
        assert enter[j] < enter[v] and leave[v] <= leave[j] and dep[j] < dep[v], v
        assert depth_of_jump.setdefault(int(dep[v]), int(dep[j])) == dep[j], v
    keys = {lab: tree.key(lab) for lab in chosen}
    for a in chosen:
        for b in chosen:
            assert bool(_seq_less(a, b, par, elem, dj)) == (keys[a] < keys[b]), \
                (a, b, keys[a][-3:], keys[b][-3:], dep[a], dep[b])


def _in_order(p: Problem, max_len: int) -> list[tuple[float, tuple[str, ...]]]:
    """The brute-force enumeration in (cost, lexicographic) order."""
    index = p.element_index()
    found = enumerate_feasible(p, max_len=max_len)
    return sorted(found, key=lambda t: (t[0], [index[x] for x in t[1]]))


def _plateaus(depth: int) -> list[Problem]:
    zero = Problem.from_dict({   # every cost zero; sequences of three lengths, so a
        "resources": ["length", "doors"],   # complete sequence and its extension tie
        "elements": [{"id": x, "resources": {"length": v, "doors": d}, "cost": 0.0}
                     for x, v, d in (("a", 1, 0), ("b", 1, 1), ("c", 2, 1))],
        "transitions": [[x, y, 0.0] for x in "abc" for y in "abc"],
        "constraints": {"length": [depth - 2, depth], "doors": [0, 1]},
    })
    equal = Problem.from_dict({  # every sequence the same length, so the same cost
        "resources": ["length", "doors"],
        "elements": [{"id": x, "resources": {"length": 1, "doors": d}, "cost": 0.25}
                     for x, d in (("a", 0), ("b", 1), ("c", 1))],
        "transitions": [[x, y, 0.125] for x in "abc" for y in "abc" if (x, y) != ("c", "b")],
        "front": ["a", "b"],
        "constraints": {"length": [depth, depth], "doors": [1, 1]},
    })
    return [zero, equal]


def test_plateaus_hundreds_deep_give_the_enumerations_first_k():
    depth = 300
    for p in _plateaus(depth):
        found = _in_order(p, depth + 1)
        assert len({c for c, _ in found}) == 1     # a plateau: every sequence ties
        ids = [e.id for e in p.elements]
        cp = compile_problem(p)
        for k in (1, 37, len(found) + 5):
            want = [s for _, s in found[:k]]
            for bounds in (bounds_for(cp, 1 << 30), NO_BOUNDS):
                status, seqs, _ = astar_k_best(cp, bounds, k, 1 << 30)
                assert status == 0
                assert [tuple(ids[i] for i in s) for s in seqs] == want, (k, bounds.count)
            r = solve(p, k=k, method="bounded")
            assert r.stats["path"] == "astar"
            assert [tuple(s.sequence) for s in r.solutions] == want, k
