"""Closed rings of facades read back from a layout's structures (its JSON list): the
ground a block or a building's outline encloses, its courtyards, the tips cut off at
acute corners. The 3D audit measures against them and the roof infill fills them
(:mod:`citysynth.export.infill`), so both see one outline."""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from citysynth.export.joints import half_polygon, joint_halves


def building_ground(structures: list[dict]) -> BaseGeometry:
    """The ground a building's closed rings enclose: inside every ring facing out (its
    outline), outside every ring facing in (its courtyards) and outside the tips cut
    off at its acute corners (street, past a nose's end wall). Empty when no ring is
    closed (a building drawn as lines, a row)."""
    rings = [closed_ring(st) for st in structures]
    owners = [r for r, owns in rings if r is not None and owns]
    yards = [r for r, owns in rings if r is not None and not owns]
    tips = [t for st in structures for t in nose_tips(st)]
    return shapely.union_all(owners).difference(shapely.union_all([*yards, *tips]))


def nose_tips(st: dict) -> list[Polygon]:
    """The tips cut off at a structure's acute corners: a nose joint (the layout's
    ``joint``) ends both facades at a short end wall, and what lies past its plane is
    street, not a gap in the roof."""
    ins = {s["to"]: s for s in st["stages"]}
    outs = {s["from"]: s for s in st["stages"]}
    tips = []
    for j, key in enumerate(st.get("keys", [])):
        s_in, s_out = ins.get(j), outs.get(j)
        if key.get("joint") != "nose" or s_in is None or s_out is None:
            continue
        p = np.asarray(key["xy"], dtype=float)
        a, b = (np.asarray(q, dtype=float) for q in s_in["polyline"][-2:])
        c, d = (np.asarray(q, dtype=float) for q in s_out["polyline"][:2])
        u_in, u_out = (b - a) / np.hypot(*(b - a)), (d - c) / np.hypot(*(d - c))
        before, _after, how, trim = joint_halves(p, u_in, u_out, s_in["front"] == "right")
        if how != "nose":
            continue
        nose = before[-1]                   # past its plane, near the tip
        tips.append(half_polygon(-np.asarray(nose.normal), np.asarray(nose.point),
                                 4.0 * (trim + 1.0)))
    return tips


def ring_order(stages: list[dict]) -> list[dict]:
    """A ring's stages in travel order (each leaves the key point the last reached)."""
    by_from = {s["from"]: s for s in stages}
    out = [stages[0]]
    while len(out) < len(stages) and out[-1]["to"] in by_from:
        nxt = by_from[out[-1]["to"]]
        if nxt is stages[0]:
            break
        out.append(nxt)
    return out


def ring_inside(st: dict) -> Polygon | None:
    """The ground a closed ring of facades facing out encloses (a block's inside)."""
    ring, owns = closed_ring(st)
    return ring if owns else None


def closed_ring(st: dict) -> tuple[Polygon | None, bool]:
    """The polygon of a closed ring of facades (None if the structure is none), and
    whether its facades face out (its mass inside: a block, a building's outline) rather
    than in (a courtyard's)."""
    if not st.get("closed"):
        return None, False
    pts = [tuple(p) for s in ring_order(st["stages"]) for p in s["polyline"][:-1]]
    if len(pts) < 3:
        return None, False
    ring = Polygon(pts)
    if not ring.is_valid or ring.area <= 0:
        return None, False
    (x0, y0), (x1, y1) = st["stages"][0]["polyline"][:2]
    dx, dy = x1 - x0, y1 - y0
    norm = float(np.hypot(dx, dy)) or 1.0
    side = 1.0 if st["stages"][0]["front"] == "right" else -1.0  # mass left of travel
    probe = ((x0 + x1) / 2 - side * dy / norm * 0.05, (y0 + y1) / 2 + side * dx / norm * 0.05)
    return ring, bool(ring.contains(shapely.Point(probe)))


def rings_inside(structures: list[dict]) -> list[Polygon]:
    return [r for st in structures if (r := ring_inside(st)) is not None]
