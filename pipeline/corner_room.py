"""Whether a rigid library corner part has room behind its corner.

A mitre joint's modules are cut where the block is thin (the medial planes of
:mod:`citysynth.export.place`), but a library corner part is placed whole. At the
bottom of a narrow notch, or where a short side runs close to another facade, its
mass behind the corner would reach through the far facade into the street and into
the modules behind it (a concave corner part 15 m from the opposite side of a block,
found on a radial street network: 1.6 m past the outline, 166 m² of overlap). So a
corner part is offered only where the ground its legs cover, its depth deep, stays
clear of every other facade of the skeleton and of the modules behind it (as deep as
the style's deepest facade module); elsewhere the corner is a mitre joint.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import shapely
from shapely.geometry import Polygon

from citysynth.parts_db import Part
from citysynth.skeletons import Skeleton
from citysynth.skeletons.model import Edge

CLEARANCE = 0.3   # m: how far a corner part's mass may touch another side's ground


def mass_depth(part: Part) -> float:
    """How deep a part's mass reaches behind its facade (its sections' backmost point)."""
    return max(-float(shapely.bounds(s)[0]) for s in (part.sec_in, part.sec_out))


def _mass_normal_at(xy: dict[int, np.ndarray], e: Edge, start: int) -> np.ndarray:
    """The unit normal into the mass of edge ``e`` walked from key point ``start``
    (facades face the front side; the mass lies on the other)."""
    other = e.b if start == e.a else e.a
    t = xy[other] - xy[start]
    t = t / np.hypot(*t)
    front = e.front if start == e.a else ("left" if e.front == "right" else "right")
    left = np.array([-t[1], t[0]])
    return left if front == "right" else -left


def _strip(a: np.ndarray, t: np.ndarray, n: np.ndarray, length: float, depth: float) -> Polygon:
    return Polygon([a, a + t * length, a + t * length + n * depth, a + n * depth])


class CornerRoom:
    """The mass strips of a skeleton's sides, to test corner parts against."""

    def __init__(self, sk: Skeleton, depth: float) -> None:
        self._edges = sk.edges
        self._xy = {k.id: np.asarray(k.xy, dtype=float) for k in sk.keypoints}
        strips = []
        for e in sk.edges:
            a, b = self._xy[e.a], self._xy[e.b]
            length = float(np.hypot(*(b - a)))
            t = (b - a) / length
            strips.append(_strip(a, t, _mass_normal_at(self._xy, e, e.a), length, depth))
        self._strips = strips
        self._tree = shapely.STRtree(strips)

    def fits(self, part: Part, at: int, own: Iterable[int]) -> bool:
        """Whether ``part``'s legs (the longer of them, its full depth, along both sides
        leaving key point ``at``) keep clear of every side but its own edges ``own``."""
        own = set(own)
        v = self._xy[at]
        reach, depth = max(part.legs), mass_depth(part)
        legs = []
        for i, e in enumerate(self._edges):
            if at in (e.a, e.b):
                w = self._xy[e.b if at == e.a else e.a]
                t = (w - v) / np.hypot(*(w - v))
                legs.append(_strip(v, t, _mass_normal_at(self._xy, e, at), reach, depth))
                own.add(i)
        ground = shapely.union_all(legs).buffer(-CLEARANCE)
        if ground.is_empty:
            return True
        near = self._tree.query(ground, predicate="intersects")
        return all(int(i) in own for i in near)
