"""The structure model of the paper's §3.2: trees and cycles of substructures
(stages) between key points, with T junctions, as plain validated data.

A structure is a graph of key points joined by substructures (stages). A key point
admits a set of key elements (a corner class, an end class, a T class ...). A key
element has one leg per incident stage: leg 0 counts toward the stage that ends at
the key point, leg 1 toward the stage that starts there, and leg 2 toward the branch
stage of a T junction, which may leave the T or end there (an H: the bar between two
T junctions is the branch of both, so it ends at one of them). Each stage has its own
resource intervals (local, reset at every key point). A structure is a tree (one
stage fewer than key points) or one cycle through key point 0 with trees hanging off
it; the cycle is cut at key point 0 (which exactly one stage enters, on the cycle),
whose element is the same at both ends of the unrolled sequence, and its closing
transition is paid for. Stages run either way along the tree; only the main line
through a key point (everything but a T's branch) passes it, one stage in and one
out.

There is one way to make a valid :class:`Structure`: :meth:`Structure.build` from
typed values (what the pipeline does), which runs every structural check;
:meth:`Structure.from_dict` reads a structure file into those values and calls it,
and :meth:`Structure.to_dict` writes one back.

Solving is :func:`citysynth.solver.structures.solve.solve_structure`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from numbers import Real
from typing import Any

import numpy as np

from citysynth.solver.errors import ProblemError
from citysynth.solver.problem import Problem, _number, check_object, parse_intervals, parse_k
from citysynth.solver.safe_read import shown

_KEYS = {"resources", "quantum", "elements", "transitions", "branch_transitions",
         "branch_in_transitions", "keypoints", "stages", "closed", "k", "constraints"}

Interval = tuple[float, float]
Legs = tuple[dict[str, float], ...]   # a key element's legs: in, out (and branch)
_Err = Callable[[str], ProblemError]


@dataclass(frozen=True)
class Stage:
    """A substructure between two key points: its own intervals (reset at every key
    point), the elements that may fill it, and the key points it leaves and reaches."""

    constraints: dict[str, Interval]
    elements: tuple[str, ...] | None = None   # fillers; None: every non-key element
    start: int = 0                            # key point it leaves
    end: int = 1                              # key point it reaches


@dataclass(frozen=True)
class Structure:
    """A validated structure; make one with :meth:`build` or :meth:`from_dict`."""

    resources: tuple[str, ...]
    quantum: dict[str, float]
    elements: dict[str, dict[str, float]]            # id -> resources (every element)
    costs: dict[str, float]                          # id -> unary cost
    legs: dict[str, Legs]                            # key element id -> its legs
    transitions: dict[tuple[str, str], float]
    branch_transitions: dict[tuple[str, str], float]  # from a T's branch leg
    keypoints: tuple[tuple[str, ...], ...]
    branch: dict[int, int]                           # T key point -> its branch stage
    stages: tuple[Stage, ...]
    closed: bool
    k: int = 1
    global_constraints: dict[str, Interval] = field(default_factory=dict)
    # into a T's branch leg (a branch stage that ends at its T)
    branch_in_transitions: dict[tuple[str, str], float] = field(default_factory=dict)

    def start_leg(self, s: int) -> int:
        """The leg of the element at stage s's start that counts toward s: the branch
        leg (2) for a T's branch stage, else the out-leg (1)."""
        return 2 if self.branch.get(self.stages[s].start) == s else 1

    def end_leg(self, s: int) -> int:
        """The leg of the element at stage s's end that counts toward s: the branch leg
        (2) for a branch stage that ends at its T, else the in-leg (0)."""
        return 2 if self.branch.get(self.stages[s].end) == s else 0

    def first_table(self, s: int) -> dict[tuple[str, str], float]:
        """The transitions stage s takes out of its start element: the branch costs
        when it leaves a T's branch leg (also when it has no fillers and ends on a
        branch leg), else the ordinary ones."""
        if self.start_leg(s) == 2:
            return self.branch_transitions
        return self.transitions

    def last_table(self, s: int) -> dict[tuple[str, str], float]:
        """The transitions stage s takes from a filler into its end element: into a T's
        branch leg, the branch-in costs, else the ordinary ones."""
        return self.branch_in_transitions if self.end_leg(s) == 2 else self.transitions

    @classmethod
    def build(cls, *, resources: Sequence[str], quantum: Mapping[str, float],
              elements: Mapping[str, Mapping[str, float]], costs: Mapping[str, float],
              legs: Mapping[str, Sequence[Mapping[str, float]]],
              transitions: Mapping[tuple[str, str], float],
              branch_transitions: Mapping[tuple[str, str], float],
              keypoints: Sequence[Sequence[str]], branch: Mapping[int, int],
              stages: Sequence[Stage], k: int = 1,
              global_constraints: Mapping[str, Interval] | None = None,
              branch_in_transitions: Mapping[tuple[str, str], float] | None = None,
              source: str = "structure") -> Structure:
        """A structure from typed values, checked: values known and non-negative, legs
        of known elements, key points holding key elements, stage elements and key
        point indices known, T junctions naming their branch stage, and the shape (a
        tree, or one cycle through key point 0; this decides ``closed``). Resources an
        element or leg leaves out are 0, costs left out are 0; transitions into a T's
        branch leg are ``transitions`` unless given. Raises
        :class:`ProblemError` naming ``source`` and the place.

        >>> from citysynth.solver.structures import Stage, Structure
        >>> parts = dict(
        ...     resources=["length"], quantum={},
        ...     elements={"wall": {"length": 2.0}, "corner": {}},
        ...     costs={"wall": 0.0, "corner": 0.5},
        ...     legs={"corner": [{"length": 1.0}, {"length": 1.0}]},
        ...     transitions={("corner", "wall"): 0.0, ("wall", "wall"): 0.25,
        ...                  ("wall", "corner"): 0.0},
        ...     branch_transitions={}, keypoints=[["corner"]] * 3, branch={},
        ...     stages=[Stage({"length": (6.0, 6.0)}, None, 0, 1),
        ...             Stage({"length": (4.0, 4.0)}, None, 1, 2),
        ...             Stage({"length": (4.0, 4.0)}, None, 2, 0)])
        >>> st = Structure.build(**parts)
        >>> st.closed, st.legs["corner"], st.elements["corner"]
        (True, ({'length': 1.0}, {'length': 1.0}), {'length': 0.0})
        >>> Structure.build(**{**parts, "keypoints": [["wall"]] * 3}, source="block 7")
        ... # doctest: +NORMALIZE_WHITESPACE
        Traceback (most recent call last):
          ...
        citysynth.solver.errors.ProblemError: block 7: keypoints[0]: 'wall' is not a key
        element (it needs legs)
        """
        def err(msg: str) -> ProblemError:
            return ProblemError(f"{source}: {msg}")

        res = _checked_resources(resources, err)
        els = {x: _checked_amounts(v, res, f"elements[{x!r}]", err)
               for x, v in elements.items()}
        kps = _checked_keypoints(keypoints, legs, err)
        sts = tuple(_checked_stage(i, s, res, els, len(kps), set(legs), err)
                    for i, s in enumerate(stages))
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise err(f'"k" must be a positive integer, got {shown(k)}')
        lgs = _checked_legs(legs, res, els, err)
        br = dict(branch)
        closed = _check_shape(sts, kps, br, lgs, err)
        return cls(
            resources=res, quantum=_checked_quantum(quantum, res, err), elements=els,
            costs=_checked_costs(costs, els, err), legs=lgs,
            transitions=_checked_transitions(transitions, els, "transitions", err),
            branch_transitions=_checked_transitions(branch_transitions, els,
                                                    "branch_transitions", err),
            keypoints=kps, branch=br, stages=sts, closed=closed, k=k,
            global_constraints=_checked_intervals(global_constraints or {}, res,
                                                  "constraints", err),
            branch_in_transitions=_checked_transitions(
                transitions if branch_in_transitions is None else branch_in_transitions,
                els, "branch_in_transitions", err))

    @classmethod
    def from_dict(cls, d: Any, source: str = "structure") -> Structure:
        """Read a structure file's JSON (the README's shape) and :meth:`build` it.
        Stages without ``from``/``to`` form a chain (or, with ``"closed": true``, a
        cycle) through the key points in order; ``branch_transitions`` and
        ``branch_in_transitions`` default to ``transitions``.

        >>> st = Structure.from_dict({
        ...     "resources": ["length"],
        ...     "elements": [{"id": "wall", "resources": {"length": 2}},
        ...                  {"id": "end", "legs": [{"length": 1}, {"length": 1}]}],
        ...     "transitions": [["end", "wall", 0], ["wall", "wall", 0.5],
        ...                     ["wall", "end", 0]],
        ...     "keypoints": [{"elements": ["end"]}, {"elements": ["end"]}],
        ...     "stages": [{"constraints": {"length": [6, 8]}}]})
        >>> st.closed, st.stages
        (False, (Stage(constraints={'length': (6.0, 8.0)}, elements=None, start=0, end=1),))
        >>> Structure.from_dict({**st.to_dict(), "stages": [{"from": 0, "to": 0,
        ...     "constraints": {"length": [6, 8]}}]}, "block.json")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
          ...
        citysynth.solver.errors.ProblemError: block.json: stages[0]: from and to are the same ...
        """
        check_object(d, _KEYS, "structure", source)
        base = _parse_base(d, source)
        transitions = {(a, b): c for a, b, c in base.transitions}
        legs = _parse_legs(d["elements"], base.resources, source)
        keypoints, branch = _parse_keypoints(d.get("keypoints"), source)
        stages = _parse_stages(d, len(keypoints), base.resources, source)
        k = parse_k(d.get("k", 1), source)
        bt = _parse_branch_transitions(d, base, source)
        bit = _parse_branch_transitions(d, base, source, "branch_in_transitions")
        glob = parse_intervals(d.get("constraints"), base.resources, "constraints", source)
        return cls.build(
            resources=base.resources, quantum=base.quantum,
            elements={e.id: e.resources for e in base.elements},
            costs={e.id: e.cost for e in base.elements}, legs=legs,
            transitions=transitions, branch_transitions=transitions if bt is None else bt,
            keypoints=keypoints, branch=branch, stages=stages, k=k,
            global_constraints=glob, branch_in_transitions=bit, source=source)

    def to_dict(self) -> dict[str, Any]:
        """The structure as :meth:`from_dict` reads it (JSON-ready), e.g. to write a
        structure file for debugging; it reads back to an equal structure.

        >>> st = Structure.from_dict({
        ...     "resources": ["length"],
        ...     "elements": [{"id": "wall", "resources": {"length": 2}},
        ...                  {"id": "end", "legs": [{"length": 1}, {"length": 1}]}],
        ...     "transitions": [["end", "wall", 0], ["wall", "wall", 0.5],
        ...                     ["wall", "end", 0]],
        ...     "keypoints": [{"elements": ["end"]}, {"elements": ["end"]}],
        ...     "stages": [{"constraints": {"length": [6, 8]}}]})
        >>> d = st.to_dict()
        >>> d["elements"][1]  # doctest: +NORMALIZE_WHITESPACE
        {'id': 'end', 'resources': {'length': 0.0}, 'cost': 0.0, 'legs': [{'length': 1.0},
        {'length': 1.0}]}
        >>> d["stages"], d["closed"]
        ([{'from': 0, 'to': 1, 'constraints': {'length': [6.0, 8.0]}}], False)
        >>> Structure.from_dict(d) == st
        True
        """
        elements = []
        for x, values in self.elements.items():
            e: dict[str, Any] = {"id": x, "resources": dict(values), "cost": self.costs[x]}
            if x in self.legs:
                e["legs"] = [dict(leg) for leg in self.legs[x]]
            elements.append(e)
        d: dict[str, Any] = {
            "resources": list(self.resources), "quantum": dict(self.quantum),
            "elements": elements,
            "transitions": [[a, b, c] for (a, b), c in self.transitions.items()]}
        for name, table in (("branch_transitions", self.branch_transitions),
                            ("branch_in_transitions", self.branch_in_transitions)):
            if table != self.transitions:
                d[name] = [[a, b, c] for (a, b), c in table.items()]
        d["keypoints"] = [{"elements": list(kp),
                           **({"branch": self.branch[j]} if j in self.branch else {})}
                          for j, kp in enumerate(self.keypoints)]
        d["stages"] = [{"from": s.start, "to": s.end,
                        "constraints": {r: [lo, hi] for r, (lo, hi) in s.constraints.items()},
                        **({} if s.elements is None else {"elements": list(s.elements)})}
                       for s in self.stages]
        d["closed"] = self.closed
        d["k"] = self.k
        if self.global_constraints:
            d["constraints"] = {r: [lo, hi] for r, (lo, hi) in self.global_constraints.items()}
        return d


# ---- reading a structure dict into typed values (from_dict) ----------------------------

def _parse_base(d: dict, source: str) -> Problem:
    """Resources, quanta, elements (legs aside) and transitions, validated through the
    one-stage model (its constraint is a placeholder)."""
    elems = d.get("elements")
    resources = d.get("resources")
    return Problem.from_dict({
        "resources": resources, "quantum": d.get("quantum", {}),
        "elements": [{k: v for k, v in e.items() if k != "legs"} if isinstance(e, dict)
                     else e for e in elems] if isinstance(elems, list) else elems,
        "transitions": d.get("transitions", []),
        "constraints": {resources[0]: [0, 0]} if isinstance(resources, list)
        and resources and isinstance(resources[0], str) else {},
    }, source)


def _parse_legs(elems: list[dict], resources: tuple[str, ...], source: str
                ) -> dict[str, Legs]:
    """Key element id -> its legs (2, or 3 for a T), every resource filled in."""
    legs: dict[str, Legs] = {}
    for i, e in enumerate(elems):
        if "legs" not in e:
            continue
        lg = e["legs"]
        where = f"elements[{i}].legs"
        if any(_number(v, f"{source}: elements[{i}].resources.{r}") for r, v in
               (e.get("resources") or {}).items()):    # all zero: what to_dict writes
            raise ProblemError(f"{source}: elements[{i}].resources: key element "
                               f"{e['id']!r} has legs, which are all it counts (its "
                               '"resources" would be ignored); put the amounts in its '
                               'legs and leave "resources" out')
        if not isinstance(lg, list) or not 2 <= len(lg) <= 3 or not all(
                isinstance(x, dict) for x in lg):
            raise ProblemError(f"{source}: {where}: a key element needs [in-leg, out-leg] "
                               "(and a branch leg for T parts) as resource objects")
        pair = []
        for leg in lg:
            vals = {}
            for r, v in leg.items():
                if r not in resources:
                    raise ProblemError(f"{source}: {where}: unknown resource {r!r}")
                vals[r] = _number(v, f"{source}: {where}.{r}")
            pair.append({r: vals.get(r, 0.0) for r in resources})
        legs[e["id"]] = tuple(pair)
    return legs


_KEYPOINT_KEYS = {"elements", "branch"}


def _parse_keypoints(kps: Any, source: str
                     ) -> tuple[list[tuple[str, ...]], dict[int, int]]:
    """The key elements each key point admits, and T key point -> its branch stage."""
    if not isinstance(kps, list) or not kps:
        raise ProblemError(f'{source}: "keypoints" must be a non-empty list of '
                           '{"elements": [...]}')
    keypoints: list[tuple[str, ...]] = []
    branch: dict[int, int] = {}
    for j, kp in enumerate(kps):
        unknown = sorted(set(kp) - _KEYPOINT_KEYS) if isinstance(kp, dict) else []
        if unknown:
            raise ProblemError(f"{source}: keypoints[{j}]: unknown key {unknown[0]!r}; a key "
                               f"point has {', '.join(sorted(_KEYPOINT_KEYS))}")
        els = kp.get("elements") if isinstance(kp, dict) else None
        if not isinstance(els, list) or not els:
            raise ProblemError(f"{source}: keypoints[{j}]: needs a non-empty elements list")
        for x in els:
            if not isinstance(x, str):
                raise ProblemError(f"{source}: keypoints[{j}]: {x!r} is not a key element "
                                   "(it needs legs)")
        keypoints.append(tuple(els))
        if "branch" in kp:
            b = kp["branch"]
            if isinstance(b, bool) or not isinstance(b, int):
                raise ProblemError(f"{source}: keypoints[{j}].branch: must be the index of "
                                   f"the stage that branches off, got {shown(b)}")
            branch[j] = b
    return keypoints, branch


_STAGE_KEYS = {"constraints", "elements", "from", "to"}


def _parse_stages(d: dict, n_keypoints: int, resources: tuple[str, ...], source: str
                  ) -> list[Stage]:
    """The stages, each with explicit key points: given as ``from``/``to``, or a chain
    (a cycle when ``closed``) through the key points in order."""
    st_in = d.get("stages")
    if not isinstance(st_in, list) or not st_in:
        raise ProblemError(f'{source}: "stages" must be a non-empty list of '
                           '{"constraints": {...}}')
    closed = d.get("closed", False)
    if not isinstance(closed, bool):
        raise ProblemError(f'{source}: "closed" must be true or false, got {shown(closed)}')
    explicit = any(isinstance(s, dict) and ("from" in s or "to" in s) for s in st_in)
    if not explicit:
        need = len(st_in) if closed else len(st_in) + 1
        if n_keypoints != need:
            raise ProblemError(f"{source}: {len(st_in)} stages need {need} key points "
                               f"({'a cycle' if closed else 'a chain'}), got {n_keypoints}")
    stages = []
    for i, s in enumerate(st_in):
        if not isinstance(s, dict):
            raise ProblemError(f"{source}: stages[{i}]: must be an object")
        unknown = sorted(set(s) - _STAGE_KEYS)
        if unknown:
            raise ProblemError(f"{source}: stages[{i}]: unknown key {unknown[0]!r}; a stage "
                               f"has {', '.join(sorted(_STAGE_KEYS))}")
        cons = parse_intervals(s.get("constraints"), resources, f"stages[{i}].constraints",
                               source)
        els = s.get("elements")
        if els is not None and not isinstance(els, list):
            raise ProblemError(f"{source}: stages[{i}].elements: must be a list of element "
                               f"ids, got {shown(els)}")
        for x in els or []:
            if not isinstance(x, str):
                raise ProblemError(f"{source}: stages[{i}].elements: unknown element {x!r}")
        ends = (s.get("from"), s.get("to")) if explicit else (i, (i + 1) % n_keypoints)
        for v, name in zip(ends, ("from", "to"), strict=True):
            wrong = _bad_end(i, name, v, n_keypoints)
            if wrong:
                raise ProblemError(f"{source}: {wrong}")
        if explicit and ends[0] == ends[1]:
            raise ProblemError(f"{source}: stages[{i}]: from and to are the same key point")
        stages.append(Stage(cons, None if els is None else tuple(els), *ends))
    return stages


def _parse_branch_transitions(d: dict, base: Problem, source: str,
                              key: str = "branch_transitions"
                              ) -> dict[tuple[str, str], float] | None:
    """The transitions from (or, for ``branch_in_transitions``, into) a T's branch leg,
    if given (validated like transitions)."""
    if key not in d:
        return None
    return {(a, b): c for a, b, c in Problem.from_dict({
        "resources": list(base.resources),
        "elements": [{"id": e.id} for e in base.elements],
        "transitions": d[key],
        "constraints": {base.resources[0]: [0, 0]}}, source).transitions}


# ---- checking typed values (build) -----------------------------------------------------

def _amount(v: Any, where: str, err: _Err) -> float:
    """A finite number >= 0, as a float."""
    if isinstance(v, bool) or not isinstance(v, Real) or not math.isfinite(v) or v < 0:
        raise err(f"{where}: must be a finite number >= 0, got {shown(v)}")
    return float(v)


def _checked_resources(resources: Sequence[str], err: _Err) -> tuple[str, ...]:
    res = tuple(resources)
    if not res or not all(isinstance(r, str) and r for r in res) or len(set(res)) < len(res):
        raise err(f"resources must be distinct non-empty names, got {list(res)}")
    return res


def _checked_amounts(values: Mapping[str, float], resources: tuple[str, ...], where: str,
                     err: _Err) -> dict[str, float]:
    """Resource values of an element or leg, every resource present (0 if left out)."""
    for r in values:
        if r not in resources:
            raise err(f"{where}: unknown resource {shown(r)}; resources are "
                      f"{', '.join(resources)}")
    return {r: _amount(values.get(r, 0.0), f"{where}.{r}", err) for r in resources}


def _checked_quantum(quantum: Mapping[str, float], resources: tuple[str, ...], err: _Err
                     ) -> dict[str, float]:
    out = {}
    for r, q in quantum.items():
        if r not in resources or _amount(q, f"quantum.{r}", err) == 0:
            raise err(f"quantum.{r}: must be > 0 and name a resource of {list(resources)}, "
                      f"got {shown(q)}")
        out[r] = float(q)
    return out


def _checked_costs(costs: Mapping[str, float], elements: Mapping[str, object], err: _Err
                   ) -> dict[str, float]:
    for x in costs:
        if x not in elements:
            raise err(f"costs: unknown element {x!r}")
    return {x: _amount(costs.get(x, 0.0), f"costs[{x!r}]", err) for x in elements}


def _checked_legs(legs: Mapping[str, Sequence[Mapping[str, float]]],
                  resources: tuple[str, ...], elements: Mapping[str, object], err: _Err
                  ) -> dict[str, Legs]:
    """Legs of known elements: in and out (and branch, for a T), complete."""
    out: dict[str, Legs] = {}
    for x, lg in legs.items():
        if x not in elements:
            raise err(f"legs: unknown element {x!r}")
        if not 2 <= len(lg) <= 3:
            raise err(f"legs of {x!r}: a key element needs [in-leg, out-leg] (and a branch "
                      f"leg for T parts), got {len(lg)} legs")
        out[x] = tuple(_checked_amounts(leg, resources, f"legs of {x!r}[{i}]", err)
                       for i, leg in enumerate(lg))
    return out


def _checked_transitions(transitions: Mapping[tuple[str, str], float],
                         elements: Mapping[str, object], what: str, err: _Err
                         ) -> dict[tuple[str, str], float]:
    for a, b in transitions:
        for side, x in (("from", a), ("to", b)):
            if x not in elements:
                raise err(f"{what}: unknown {side} element {x!r}")
    values = list(transitions.values())
    if all(type(c) is float or type(c) is int for c in values):   # checked at once
        arr = np.asarray(values, dtype=float)
        if bool(np.all(arr >= 0)) and bool(np.all(np.isfinite(arr))):
            return dict(zip(transitions, arr.tolist(), strict=True))
    return {(a, b): _amount(c, f"{what}[{a!r}, {b!r}]", err)
            for (a, b), c in transitions.items()}


def _checked_keypoints(keypoints: Sequence[Sequence[str]],
                       legs: Mapping[str, object], err: _Err) -> tuple[tuple[str, ...], ...]:
    """Every key point admits at least one element, and only key elements."""
    if not keypoints:
        raise err("a structure needs at least one key point")
    for j, els in enumerate(keypoints):
        if not els:
            raise err(f"keypoints[{j}]: needs a non-empty elements list")
        for x in els:
            if x not in legs:
                raise err(f"keypoints[{j}]: {x!r} is not a key element (it needs legs)")
    return tuple(tuple(els) for els in keypoints)


def _checked_intervals(intervals: Mapping[str, Interval], resources: tuple[str, ...],
                       where: str, err: _Err) -> dict[str, Interval]:
    """``{resource: (min, max)}`` on known resources, 0 <= min <= max."""
    out = {}
    for r, (lo, hi) in intervals.items():
        if r not in resources:
            raise err(f"{where}.{r}: unknown resource; resources are {', '.join(resources)}")
        a, b = _amount(lo, f"{where}.{r}[0]", err), _amount(hi, f"{where}.{r}[1]", err)
        if a > b:
            raise err(f"{where}.{r}: min {a:g} is greater than max {b:g}")
        out[r] = (a, b)
    return out


def _bad_end(i: int, name: str, v: object, n_keypoints: int) -> str | None:
    """What is wrong with stage i's ``from`` or ``to`` (``name``), ``v``, or None."""
    if v is None:   # other stages name theirs: the in-order shorthand is off
        return (f'stages[{i}]: no "{name}"; give every stage its "from" and "to" key '
                "points, or none of them (the stages then run through the key points in "
                'order, round a cycle when "closed" is true)')
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < n_keypoints:
        return (f"stages[{i}].{name}: must be a key point index from 0 to "
                f"{n_keypoints - 1}, got {shown(v)}")
    return None


def _checked_stage(i: int, s: Stage, resources: tuple[str, ...],
                   elements: Mapping[str, object], n_keypoints: int, keys: set[str],
                   err: _Err) -> Stage:
    """Stage i: at least one interval, known fillers that are not key elements (a list
    of key elements only left the stage no filler, untold), two distinct key points
    (one, when it is the only key point: a cycle of one stage)."""
    cons = _checked_intervals(s.constraints, resources, f"stages[{i}].constraints", err)
    if not cons:
        raise err(f"stages[{i}]: needs at least one constraint")
    if s.elements is not None and not s.elements:   # would read as "every filler"
        raise err(f"stages[{i}].elements: empty, so no element may fill the stage; list "
                  "the elements that may, or leave \"elements\" out for all of them")
    for x in s.elements or ():
        if x not in elements:
            raise err(f"stages[{i}].elements: unknown element {x!r}")
        if x in keys:
            raise err(f"stages[{i}].elements: {x!r} is a key element (it has legs), which "
                      "stands at key points, not between them; list the fillers that may "
                      "fill the stage")
    for v, name in ((s.start, "from"), (s.end, "to")):
        wrong = _bad_end(i, name, v, n_keypoints)
        if wrong:
            raise err(wrong)
    if s.start == s.end and n_keypoints > 1:  # one key point: a cycle of one stage
        raise err(f"stages[{i}]: from and to are the same key point")
    return Stage(cons, None if s.elements is None else tuple(s.elements), s.start, s.end)


# ---- the shape: a tree, or one cycle through key point 0 ---------------------------------

def _check_shape(stages: Sequence[Stage], keypoints: Sequence[Sequence[str]],
                 branch: Mapping[int, int], legs: Mapping[str, Legs], err: _Err) -> bool:
    """A tree, or one cycle through key point 0 that exactly one stage enters (the
    stage that closes it); at every key point the main line enters once and leaves once
    (see :func:`_check_junctions`). Returns True for the cycle."""
    n = len(keypoints)
    inc: list[list[int]] = [[] for _ in range(n)]
    for i, s in enumerate(stages):
        inc[s.start].append(i)
        inc[s.end].append(i)
    if len(stages) not in (n - 1, n):
        raise err(f"{len(stages)} stages and {n} key points form neither a tree "
                  f"({n - 1} stages) nor one cycle ({n} stages)")
    _check_connected(stages, inc, err)
    closed = len(stages) == n
    if closed:
        ring = _cycle(stages, inc)
        into0 = sorted({i for i in inc[0] if stages[i].end == 0})  # a 1-stage cycle: once
        if len(into0) != 1 or into0[0] not in ring:
            raise err("a cyclic structure needs its cycle through key point 0, and exactly "
                      "one stage entering key point 0, on the cycle (the stage that closes "
                      "it)")
    _check_junctions(stages, keypoints, inc, branch, legs, err)
    return closed


def _check_connected(stages: Sequence[Stage], inc: list[list[int]], err: _Err) -> None:
    """Every key point is reached from key point 0 along the stages (either way)."""
    seen, todo = {0}, [0]
    while todo:
        v = todo.pop()
        for i in inc[v]:
            for w in (stages[i].start, stages[i].end):
                if w not in seen:
                    seen.add(w)
                    todo.append(w)
    if len(seen) != len(inc):
        raise err("the structure is disconnected (or its cycle does not pass key point 0)")


def _cycle(stages: Sequence[Stage], inc: list[list[int]]) -> set[int]:
    """The stages of the one cycle of a connected graph with as many stages as key
    points: what is left once key points with one stage are pruned, again and again."""
    deg = [len(x) for x in inc]
    alive = set(range(len(stages)))
    leaves = [v for v, d in enumerate(deg) if d == 1]
    while leaves:
        v = leaves.pop()
        for i in inc[v]:
            if i in alive:
                alive.discard(i)
                for w in (stages[i].start, stages[i].end):
                    deg[w] -= 1
                    if deg[w] == 1:
                        leaves.append(w)
    return alive


def _check_junctions(stages: Sequence[Stage], keypoints: Sequence[Sequence[str]],
                     inc: list[list[int]], branch: Mapping[int, int],
                     legs: Mapping[str, Legs], err: _Err) -> None:
    """At most three stages meet at a key point; where three meet (a T junction), it
    names the one that branches off and each of its elements has a branch leg. The
    other stages are its main line: at most one enters it and at most one leaves."""
    for v, b in branch.items():
        if v < len(inc) and b not in inc[v]:
            raise err(f"keypoints[{v}].branch: {b!r} is not a stage that meets this key "
                      f"point (those are {inc[v] or 'none'}); name one of them, or leave "
                      "it out")
        for x in keypoints[v] if v < len(keypoints) else ():
            if len(legs[x]) < 3:   # the branch stage counts from its branch leg
                raise err(f"keypoints[{v}]: {x!r} has no branch leg (a T part needs 3 "
                          "legs), yet the key point names a branch stage; give it T "
                          'parts only, or leave "branch" out')
    for v in range(len(keypoints)):
        deg = len(inc[v])
        if deg > 3:
            raise err(f"keypoints[{v}]: {deg} stages meet there; at most 3 (a T junction)")
        if deg == 3:
            if branch.get(v) not in inc[v]:
                raise err(f"keypoints[{v}]: three stages meet there; name the one that "
                          'branches off with "branch": <stage index>')
            for x in keypoints[v]:
                if len(legs[x]) < 3:
                    raise err(f"keypoints[{v}]: {x!r} has no branch leg (a T part needs 3 "
                              "legs)")
        main = {i for i in inc[v] if branch.get(v) != i}
        ins = sum(stages[i].end == v for i in main)
        if ins > 1 or sum(stages[i].start == v for i in main) > 1:
            way = "enter" if ins > 1 else "leave"
            raise err(f"keypoints[{v}]: two stages {way} it (besides a branch); the main "
                      "line through a key point enters it once and leaves it once")
