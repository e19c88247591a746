"""Solver problems built from a part database (the pipeline's job: parts_db and the
solver know nothing of each other).

A problem's elements are parts, their resources the parts' snapped lengths (legs) and
attributes, their transitions the database's allowed pairs with the section
disagreement as cost. Two builders for now: a street front of complete buildings and
a tower of stacked floors with a floor-area interval (the paper's Fig. 4).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from citysynth.parts_db import LibraryError, Part, PartDB


def _transitions(db: PartDB, parts: list[Part]) -> list[list[str | float]]:
    idx = db.index()
    out: list[list[str | float]] = []
    for a in parts:
        for b in parts:
            i, j = idx[a.id], idx[b.id]
            if db.allowed[i, j]:
                out.append([a.id, b.id, float(db.cost[i, j])])
    return out


def street_front_problem(db: PartDB, length: float, *, style: str | None = None,
                         constraints: dict[str, list[float]] | None = None,
                         k: int = 1) -> dict:
    """Complete buildings (class ``building``) filling exactly ``length`` metres, with
    optional intervals on attributes such as doors or balconies."""
    parts = db.select("building", style)
    if not parts:
        raise LibraryError(f"the library {db.name!r} has no buildings"
                           f"{f' of style {style}' if style else ''}")
    attrs = sorted({a for p in parts for a in p.attributes})
    cons = {"length": [length, length], **(constraints or {})}
    return {
        "resources": ["length", *attrs],
        "quantum": {"length": db.quantum},
        "elements": [{"id": p.id, "resources": {"length": p.length, **p.attributes}}
                     for p in parts],
        "transitions": _transitions(db, parts),
        "constraints": cons,
        "k": k,
    }


def tower_problem(db: PartDB, height: float, floor_area: tuple[float, float], *,
                  style: str | None = None, area_quantum: float = 10.0, k: int = 1,
                  keep: Callable[[Part], bool] | None = None) -> dict:
    """A ground floor, floors and a roof stacked to exactly ``height`` metres, with the
    total floor area (ground floor and floors; roofs count none) inside ``floor_area``.
    Floor areas are not multiples of anything, so they are quantised to
    ``area_quantum`` m² and the rounding error is reported by the solver. ``keep``
    leaves out parts (``citysynth tower``: those that do not fit the lot)."""
    styled = [p for p in db.parts if p.cls in ("ground_floor", "floor", "roof")
              and (style is None or p.style == style)]
    parts = [p for p in styled if keep is None or keep(p)]
    if not _stacks(styled):   # no tower of the style at all: not the lot's fault
        towers = sorted({p.style for p in db.parts if p.cls == "ground_floor"}
                        & {p.style for p in db.parts if p.cls == "roof"})
        raise LibraryError(
            f"the library {db.name!r} has no tower parts{f' of style {style}' if style else ''}"
            ": a tower needs ground_floor, floor and roof parts" + (
                f"; its towers are of style {', '.join(towers)} (--style {towers[0]})"
                if towers else ""))
    if not _stacks(parts):
        raise LibraryError(f"no {style + ' ' if style else ''}tower of the library "
                           f"{db.name!r} fits the lot: every ground floor or roof of it "
                           "stands past the lot's outline; give a larger lot")

    def area(p: Part) -> float:
        return 0.0 if p.cls == "roof" else float(np.round(p.floor_area or 0.0, 3))

    return {
        "resources": ["height", "floor_area"],
        "quantum": {"height": db.quantum, "floor_area": area_quantum},
        "elements": [{"id": p.id, "resources": {"height": p.length, "floor_area": area(p)}}
                     for p in parts],
        "transitions": _transitions(db, parts),
        "front": [p.id for p in parts if p.cls == "ground_floor"],
        "back": [p.id for p in parts if p.cls == "roof"],
        "constraints": {"height": [height, height],
                        "floor_area": [float(floor_area[0]), float(floor_area[1])]},
        "k": k,
    }


def _stacks(parts: list[Part]) -> bool:
    """Whether ``parts`` hold a ground floor and a roof, the least a tower is."""
    return any(p.cls == "ground_floor" for p in parts) and any(p.cls == "roof" for p in parts)
