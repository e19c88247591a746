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

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from citysynth.solver.errors import ProblemError

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
        """Build and validate a problem from the JSON shape documented in the README."""
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

    def element_index(self) -> dict[str, int]:
        return {e.id: i for i, e in enumerate(self.elements)}


def load_json(path: str | Path) -> Any:
    """The JSON in ``path``; unreadable files and syntax errors become one message."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ProblemError(f"{p}: cannot read the problem file ({exc.strerror})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ProblemError(
            f"{p}: not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None


def _number(value: Any, where: str, *, minimum: float | None = 0.0) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ProblemError(f"{where}: expected a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ProblemError(f"{where}: expected a finite number, got {value!r}")
    if minimum is not None and v < minimum:
        raise ProblemError(f"{where}: must be >= {minimum:g}, got {value!r}")
    return v


def check_object(d: Any, allowed: set[str], what: str, source: str) -> None:
    """``d`` is a JSON object with only ``allowed`` keys (typos are caught here)."""
    if not isinstance(d, dict):
        raise ProblemError(f"{source}: the {what} must be a JSON object")
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise ProblemError(f"{source}: unknown key(s) {unknown}; allowed keys are "
                           f"{sorted(allowed)}")


def parse_intervals(c_in: Any, resources, where: str, source: str
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
                               f"{list(resources)}")
        if not isinstance(iv, list | tuple) or len(iv) != 2:
            raise ProblemError(f"{source}: {at}: must be [min, max] (equal for an "
                               f"equality), got {iv!r}")
        lo = _number(iv[0], f"{source}: {at}[0]")
        hi = _number(iv[1], f"{source}: {at}[1]")
        if lo > hi:
            raise ProblemError(f"{source}: {at}: min {lo:g} is greater than max {hi:g}")
        out[rname] = (lo, hi)
    return out


def _parse(d: Any, source: str) -> Problem:
    def err(msg: str) -> ProblemError:
        return ProblemError(f"{source}: {msg}")

    check_object(d, _TOP_KEYS, "problem", source)

    resources = d.get("resources")
    if (not isinstance(resources, list) or not resources
            or not all(isinstance(r, str) and r for r in resources)):
        raise err('"resources" must be a non-empty list of names, e.g. ["length", "doors"]')
    if len(set(resources)) != len(resources):
        raise err(f'"resources" has duplicate names: {resources}')
    rset = set(resources)

    quantum: dict[str, float] = {}
    q_in = d.get("quantum", {}) or {}
    if not isinstance(q_in, dict):
        raise err('"quantum" must be an object like {"length": 0.2}')
    for name, q in q_in.items():
        if name not in rset:
            raise err(f'quantum.{name}: unknown resource; resources are {resources}')
        qv = _number(q, f"{source}: quantum.{name}")
        if qv <= 0:
            raise err(f"quantum.{name}: must be > 0, got {q!r}")
        quantum[name] = qv

    elems_in = d.get("elements")
    if not isinstance(elems_in, list) or not elems_in:
        raise err('"elements" must be a non-empty list')
    elements: list[Element] = []
    seen: set[str] = set()
    for i, e in enumerate(elems_in):
        where = f"elements[{i}]"
        if not isinstance(e, dict):
            raise err(f"{where}: must be an object with id, resources and optional cost")
        extra = sorted(set(e) - {"id", "resources", "cost"})
        if extra:
            raise err(f"{where}: unknown key(s) {extra}; allowed: id, resources, cost")
        eid = e.get("id")
        if not isinstance(eid, str) or not eid:
            raise err(f"{where}.id: must be a non-empty string")
        if eid in seen:
            raise err(f'{where}.id: duplicate element id "{eid}"')
        seen.add(eid)
        res_in = e.get("resources", {}) or {}
        if not isinstance(res_in, dict):
            raise err(f"{where}.resources: must be an object like {{\"length\": 4.0}}")
        res: dict[str, float] = {}
        for rname, val in res_in.items():
            if rname not in rset:
                raise err(f'{where}.resources.{rname}: unknown resource; resources are {resources}')
            res[rname] = _number(val, f"{source}: {where}.resources.{rname}")
        for rname in resources:
            res.setdefault(rname, 0.0)
        cost = _number(e.get("cost", 0.0), f"{source}: {where}.cost")
        elements.append(Element(eid, {r: res[r] for r in resources}, cost))

    tr_in = d.get("transitions", [])
    if not isinstance(tr_in, list):
        raise err('"transitions" must be a list of [from, to, cost]')
    transitions: list[tuple[str, str, float]] = []
    pairs: set[tuple[str, str]] = set()
    for i, t in enumerate(tr_in):
        where = f"transitions[{i}]"
        if not isinstance(t, list | tuple) or len(t) != 3:
            raise err(f"{where}: must be [from_id, to_id, cost], got {t!r}")
        a, b, c = t
        for side, x in (("from", a), ("to", b)):
            if x not in seen:
                raise err(f"{where}: unknown {side} element {x!r}")
        if (a, b) in pairs:
            raise err(f"{where}: duplicate transition {a!r} -> {b!r}")
        pairs.add((a, b))
        transitions.append((a, b, _number(c, f"{source}: {where} cost")))

    def ids(key: str) -> tuple[str, ...]:
        v = d.get(key)
        if v is None:
            return tuple(e.id for e in elements)
        if not isinstance(v, list) or not v:
            raise err(f'"{key}" must be a non-empty list of element ids (or be left out for all)')
        for x in v:
            if x not in seen:
                raise err(f'{key}: unknown element {x!r}')
        if len(set(v)) != len(v):
            raise err(f'"{key}" lists an element twice')
        return tuple(v)

    front, back = ids("front"), ids("back")

    constraints = parse_intervals(d.get("constraints", {}), resources, "constraints", source)
    if not constraints:
        raise err('no constraints: give at least one [min, max] interval, e.g. '
                  '"constraints": {"length": [20.0, 20.0]}')

    k = d.get("k", 1)
    if isinstance(k, bool) or not isinstance(k, int) or k < 1:
        raise err(f'"k" must be a positive integer, got {k!r}')

    return Problem(
        resources=tuple(resources),
        elements=tuple(elements),
        transitions=tuple(transitions),
        front=front,
        back=back,
        constraints=constraints,
        quantum=quantum,
        k=k,
    )
