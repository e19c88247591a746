"""The sequence problem of the paper (eq. 1-2), as plain validated data.

A :class:`Problem` is what a user writes in a problem file: elements with named
non-negative resources and an optional unary cost, allowed transitions with costs,
allowed first/last elements, and per-resource ``[min, max]`` intervals. It knows
nothing of quantisation or graphs; :mod:`citysynth.solver.quantize` and
:mod:`citysynth.solver.compiled` turn it into numbers. Validation lives here so every
stage downstream can trust it, and every error names the offending place
(``elements[3].resources.length``) so a user can fix the file without reading code.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from citysynth.solver.errors import ProblemError
from citysynth.solver.safe_read import check_printable, read_json, shown

_TOP_KEYS = {
    "resources", "quantum", "elements", "transitions", "front", "back", "constraints", "k",
}


@dataclass(frozen=True)
class Element:
    """One element (a building part, a motion clip ...): its resources and unary cost."""

    id: str
    resources: dict[str, float]
    cost: float = 0.0


@dataclass(frozen=True)
class Problem:
    """A validated problem. ``front``/``back`` hold element ids; ``constraints`` maps a
    resource to ``(min, max)``; resources without a constraint are only tracked."""

    resources: tuple[str, ...]
    elements: tuple[Element, ...]
    transitions: tuple[tuple[str, str, float], ...]
    front: tuple[str, ...]
    back: tuple[str, ...]
    constraints: dict[str, tuple[float, float]]
    quantum: dict[str, float] = field(default_factory=dict)
    k: int = 1

    @classmethod
    def from_dict(cls, d: Any, source: str = "problem") -> Problem:
        """Build and validate a problem from the JSON shape documented in the README.
        Left out: ``front``/``back`` (every element), ``quantum`` (found from the
        values), unary ``cost`` (0), a resource of an element (0), ``k`` (1).

        >>> p = Problem.from_dict({
        ...     "resources": ["length", "doors"],
        ...     "elements": [{"id": "shop", "resources": {"length": 6.0, "doors": 1}},
        ...                  {"id": "flat", "resources": {"length": 4.0}, "cost": 0.5}],
        ...     "transitions": [["shop", "flat", 0.0], ["flat", "flat", 0.25]],
        ...     "front": ["shop"],
        ...     "constraints": {"length": [14, 18], "doors": [1, 1]}})
        >>> p.elements[1]
        Element(id='flat', resources={'length': 4.0, 'doors': 0.0}, cost=0.5)
        >>> p.front, p.back, p.constraints
        (('shop',), ('shop', 'flat'), {'length': (14.0, 18.0), 'doors': (1.0, 1.0)})

        Every error names its place (and ``source``, the file):

        >>> Problem.from_dict({**p.to_dict(), "front": ["door"]}, "street.json")
        Traceback (most recent call last):
          ...
        citysynth.solver.errors.ProblemError: street.json: front: unknown element 'door'
        """
        return _parse(d, source)

    @classmethod
    def load(cls, path: str | Path) -> Problem:
        """Read a JSON problem file; every error names the file."""
        return _parse(load_json(path), str(path))

    def to_dict(self) -> dict[str, Any]:
        """The inverse of :meth:`from_dict` (round-trips exactly)."""
        return {
            "resources": list(self.resources),
            "quantum": dict(self.quantum),
            "elements": [
                {"id": e.id, "resources": dict(e.resources), "cost": e.cost}
                for e in self.elements
            ],
            "transitions": [[a, b, c] for a, b, c in self.transitions],
            "front": list(self.front),
            "back": list(self.back),
            "constraints": {r: [lo, hi] for r, (lo, hi) in self.constraints.items()},
            "k": self.k,
        }

    def with_constraints(self, constraints: dict[str, tuple[float, float]]) -> Problem:
        """The same problem with other intervals (a street's runs differ in length
        only), its :attr:`transition_index` kept: made anew for each run of a street of
        8,000 runs, it took 2.5 ms a run, most of compiling it."""
        out = replace(self, constraints=constraints)
        if "transition_index" in self.__dict__:
            out.__dict__["transition_index"] = self.__dict__["transition_index"]
        return out

    def element_index(self) -> dict[str, int]:
        return {e.id: i for i, e in enumerate(self.elements)}

    @cached_property
    def transition_index(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(from, to, cost) of every transition as arrays (element indices, int64;
        costs, float64), in the listed order. Parsing fills it from the id lookups it
        makes anyway to validate the list (a solve then does not look up 2 x 5,476
        ids again on a street front, about half of compiling it); a Problem built
        directly computes it on first use."""
        index = self.element_index()
        m = len(self.transitions)
        if not m:
            z = np.zeros(0, dtype=np.int64)
            return z, z, np.zeros(0, dtype=np.float64)
        a, b, d = zip(*self.transitions, strict=True)
        get = index.__getitem__
        return (np.fromiter(map(get, a), dtype=np.int64, count=m),
                np.fromiter(map(get, b), dtype=np.int64, count=m),
                np.fromiter(d, dtype=np.float64, count=m))


def load_json(path: str | Path) -> Any:
    """The JSON in ``path``; unreadable files and syntax errors become one message."""
    return read_json(path, "problem", ProblemError)   # encoding, depth, size: safe_read


MAX_COST = 1e15   # a cost past this makes sums of a few thousand inexact, then infinite
MAX_AMOUNT = 1e15  # likewise an element's amount of a resource (its totals are summed)


def _number(value: Any, where: str, *, minimum: float | None = 0.0,
            maximum: float | None = None, what: str = "cost") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ProblemError(f"{where}: expected a number, got {shown(value)}")
    v = float(value)
    if not math.isfinite(v):
        raise ProblemError(f"{where}: expected a finite number, got {shown(value)}")
    if minimum is not None and v < minimum:
        raise ProblemError(f"{where}: must be >= {minimum:g}, got {shown(value)}")
    if maximum is not None and v > maximum:
        article = "an" if what[0] in "aeiou" else "a"
        raise ProblemError(f"{where}: must be <= {maximum:g} ({article} {what} this large sums to "
                           f"infinity), got {shown(value)}; scale the {what}s down")
    return v


def check_object(d: Any, allowed: set[str], what: str, source: str) -> None:
    """``d`` is a JSON object with only ``allowed`` keys (typos are caught here)."""
    if not isinstance(d, dict):
        raise ProblemError(f"{source}: the {what} must be a JSON object")
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise ProblemError(f"{source}: unknown key(s) {', '.join(map(shown, unknown))}; "
                           f"allowed keys are {', '.join(sorted(allowed))}")


def parse_intervals(c_in: Any, resources: Collection[str], where: str, source: str
                    ) -> dict[str, tuple[float, float]]:
    """``{resource: [min, max]}`` validated against the resource names."""
    if c_in is None:
        return {}
    if not isinstance(c_in, dict):
        raise ProblemError(f'{source}: "{where}" must be an object like '
                           '{"length": [20.0, 20.0]}')
    out: dict[str, tuple[float, float]] = {}
    for rname, iv in c_in.items():
        at = f"{where}.{rname}"
        if rname not in resources:
            raise ProblemError(f"{source}: {at}: unknown resource; resources are "
                               f"{', '.join(resources)}")
        if not isinstance(iv, list | tuple) or len(iv) != 2:
            raise ProblemError(f"{source}: {at}: must be [min, max] (equal for an "
                               f"equality), got {shown(iv)}")
        lo = _number(iv[0], f"{source}: {at}[0]")
        hi = _number(iv[1], f"{source}: {at}[1]")
        if lo > hi:
            raise ProblemError(f"{source}: {at}: min {lo:g} is greater than max {hi:g}")
        out[rname] = (lo, hi)
    return out


def _parse(d: Any, source: str) -> Problem:
    """Validate a problem dict step by step: resources, quanta, elements, transitions,
    front/back lists, constraints, k. Every step raises :class:`ProblemError` naming
    ``source`` and the offending place."""
    check_object(d, _TOP_KEYS, "problem", source)
    resources = _parse_resources(d.get("resources"), source)
    quantum = _parse_quantum(d.get("quantum", {}) or {}, resources, source)
    elements = _parse_elements(d.get("elements"), resources, source)
    index = {e.id: i for i, e in enumerate(elements)}
    if "transitions" not in d:     # else every sequence of two would be "infeasible"
        raise ProblemError(f'{source}: "transitions" is missing; list the allowed pairs '
                           "as [from, to, cost]")
    transitions, arrays = _parse_transitions(d["transitions"], index, source)
    front = _parse_ends(d, "front", elements, source)
    back = _parse_ends(d, "back", elements, source)
    constraints = parse_intervals(d.get("constraints", {}), resources, "constraints", source)
    if not constraints:
        raise ProblemError(f'{source}: no constraints: give at least one [min, max] '
                           'interval, e.g. "constraints": {"length": [20.0, 20.0]}')
    problem = Problem(
        resources=tuple(resources),
        elements=elements,
        transitions=transitions,
        front=front,
        back=back,
        constraints=constraints,
        quantum=quantum,
        k=parse_k(d.get("k", 1), source),
    )
    problem.__dict__["transition_index"] = arrays  # the cached_property, already known
    return problem


def parse_k(k: Any, source: str) -> int:
    """``k`` is a positive integer (booleans are not)."""
    if isinstance(k, bool) or not isinstance(k, int) or k < 1:
        raise ProblemError(f'{source}: "k" must be a positive integer, got {shown(k)}')
    return k


def _parse_resources(resources: Any, source: str) -> list[str]:
    """A non-empty list of distinct, non-empty names."""
    if (not isinstance(resources, list) or not resources
            or not all(isinstance(r, str) and r for r in resources)):
        raise ProblemError(f'{source}: "resources" must be a non-empty list of names, e.g. '
                           '["length", "doors"]')
    if len(set(resources)) != len(resources):
        raise ProblemError(f'{source}: "resources" has duplicate names: {resources}')
    for i, r in enumerate(resources):
        check_printable(r, f"{source}: resources[{i}]", "a resource's name", ProblemError)
    return resources


def _parse_quantum(q_in: Any, resources: list[str], source: str) -> dict[str, float]:
    """``{resource: quantum}``, each quantum positive."""
    if not isinstance(q_in, dict):
        raise ProblemError(f'{source}: "quantum" must be an object like {{"length": 0.2}}')
    quantum: dict[str, float] = {}
    for name, q in q_in.items():
        if name not in resources:
            raise ProblemError(f"{source}: quantum.{name}: unknown resource; resources are "
                               f"{', '.join(resources)}")
        qv = _number(q, f"{source}: quantum.{name}", minimum=None)   # one rule: > 0
        if qv <= 0:
            raise ProblemError(f"{source}: quantum.{name}: must be > 0, got {shown(q)}")
        quantum[name] = qv
    return quantum


def _parse_elements(elems_in: Any, resources: list[str], source: str
                    ) -> tuple[Element, ...]:
    """The element list: distinct ids, every resource filled in (0 when left out)."""
    if not isinstance(elems_in, list) or not elems_in:
        raise ProblemError(f'{source}: "elements" must be a non-empty list')
    elements: list[Element] = []
    seen: set[str] = set()
    for i, e in enumerate(elems_in):
        elements.append(_parse_element(e, f"elements[{i}]", resources, seen, source))
    return tuple(elements)


def _parse_element(e: Any, where: str, resources: list[str], seen: set[str], source: str
                   ) -> Element:
    """One element; its id joins ``seen`` (ids of the elements before it)."""
    if not isinstance(e, dict):
        raise ProblemError(f"{source}: {where}: must be an object with id, resources and "
                           "optional cost")
    extra = sorted(set(e) - {"id", "resources", "cost"})
    if extra:
        raise ProblemError(f"{source}: {where}: unknown key(s) "
                           f"{', '.join(map(shown, extra))}; allowed: id, resources, cost")
    eid = e.get("id")
    if not isinstance(eid, str) or not eid:
        raise ProblemError(f"{source}: {where}.id: must be a non-empty string")
    check_printable(eid, f"{source}: {where}.id", "the id", ProblemError)
    if eid in seen:
        raise ProblemError(f'{source}: {where}.id: duplicate element id "{eid}"')
    seen.add(eid)
    res_in = e.get("resources", {}) or {}
    if not isinstance(res_in, dict):
        raise ProblemError(f'{source}: {where}.resources: must be an object like '
                           '{"length": 4.0}')
    res: dict[str, float] = {}
    for rname, val in res_in.items():
        if rname not in resources:
            raise ProblemError(f"{source}: {where}.resources.{rname}: unknown resource; "
                               f"resources are {', '.join(resources)}")
        res[rname] = _number(val, f"{source}: {where}.resources.{rname}",
                             maximum=MAX_AMOUNT, what="amount")
    cost = _number(e.get("cost", 0.0), f"{source}: {where}.cost", maximum=MAX_COST)
    return Element(eid, {r: res.get(r, 0.0) for r in resources}, cost)


def _parse_transitions(tr_in: Any, index: dict[str, int], source: str
                       ) -> tuple[tuple[tuple[str, str, float], ...],
                                  tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``[from, to, cost]`` triples between known elements (``index``: id -> position),
    each pair at most once; and the same as arrays (:attr:`Problem.transition_index`)."""
    if not isinstance(tr_in, list):
        raise ProblemError(f'{source}: "transitions" must be a list of [from, to, cost]')
    transitions: list[tuple[str, str, float]] = []
    ia: list[int] = []
    ib: list[int] = []
    pairs: set[tuple[str, str]] = set()
    for i, t in enumerate(tr_in):
        where = f"transitions[{i}]"
        if not isinstance(t, list | tuple) or len(t) != 3:
            raise ProblemError(f"{source}: {where}: must be [from_id, to_id, cost], got {shown(t)}")
        a, b, c = t
        for side, x, out in (("from", a, ia), ("to", b, ib)):
            j = index.get(x) if isinstance(x, str) else None
            if j is None:
                raise ProblemError(f"{source}: {where}: unknown {side} element {x!r}")
            out.append(j)
        if (a, b) in pairs:
            raise ProblemError(f"{source}: {where}: duplicate transition {a!r} -> {b!r}")
        pairs.add((a, b))
        transitions.append((a, b, _number(c, f"{source}: {where} cost", maximum=MAX_COST)))
    arrays = (np.array(ia, dtype=np.int64), np.array(ib, dtype=np.int64),
              np.array([t[2] for t in transitions], dtype=np.float64))
    return tuple(transitions), arrays


def _parse_ends(d: dict, key: str, elements: tuple[Element, ...], source: str
                ) -> tuple[str, ...]:
    """``front`` or ``back``: distinct known element ids; left out, every element."""
    v = d.get(key)
    if v is None:
        return tuple(e.id for e in elements)
    if not isinstance(v, list) or not v:
        raise ProblemError(f'{source}: "{key}" must be a non-empty list of element ids (or '
                           'be left out for all)')
    ids = {e.id for e in elements}
    for x in v:
        if x not in ids:
            raise ProblemError(f"{source}: {key}: unknown element {x!r}")
    if len(set(v)) != len(v):
        raise ProblemError(f'{source}: "{key}" lists an element twice')
    return tuple(v)
