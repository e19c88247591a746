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

from citysynth.export.joints import behind
from citysynth.parts_db import Part
from citysynth.skeletons import Skeleton
from citysynth.skeletons.model import flip

CLEARANCE = 0.3   # m: how far a corner part's mass may touch another side's ground


def mass_depth(part: Part) -> float:
    """How deep a part's mass reaches behind its facade (its sections' backmost point)."""
    return max(-float(shapely.bounds(s)[0]) for s in (part.sec_in, part.sec_out))


class CornerRoom:
    """The mass strips of a skeleton's sides, to test corner parts against."""

    def __init__(self, sk: Skeleton, depth: float) -> None:
        self._edges = sk.edges
        self._xy = {k.id: np.asarray(k.xy, dtype=float) for k in sk.keypoints}
        self._at: dict[int, list[int]] = {}   # key point -> its edges (a scan of every
        for i, e in enumerate(sk.edges):      # edge a corner took 2,000 stages 13 s)
            for key in dict.fromkeys((e.a, e.b)):
                self._at.setdefault(key, []).append(i)
        self._tree = shapely.STRtree([behind([self._xy[e.a], self._xy[e.b]], e.front, depth)
                                      for e in sk.edges])

    def fits(self, part: Part, at: int, own: Iterable[int]) -> bool:
        """Whether ``part``'s legs (the longer of them, its full depth, along both sides
        leaving key point ``at``) keep clear of every side but its own edges ``own``."""
        own = set(own)
        v = self._xy[at]
        reach, depth = max(part.legs), mass_depth(part)
        legs = []
        for i in self._at.get(at, []):   # the sides walked away from the corner, their
            e = self._edges[i]            # fronts with them
            w = self._xy[e.b if at == e.a else e.a]
            t = (w - v) / np.hypot(*(w - v))
            legs.append(behind([v, v + t * reach], e.front if at == e.a else flip(e.front),
                               depth))
            own.add(i)
        ground = shapely.union_all(legs).buffer(-CLEARANCE)
        if ground.is_empty:
            return True
        near = self._tree.query(ground, predicate="intersects")
        return all(int(i) in own for i in near)
