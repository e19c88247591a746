"""How far a cleaned footprint ring strays from its input, measured where it changed.

Faithful cleaning (:mod:`citysynth.skeletons.clean`) tries, at every step, each way of
absorbing each short side, and keeps one whose ring stays within the tolerance of the
input ring: the Hausdorff distance between the two, both densified (a corner cut off
lies between vertices). Measured whole each time (``shapely.hausdorff_distance(...,
densify=0.05)``), that is every sampled point of one ring against every side of the
other, for every candidate at every step: a 245-point wall with 60 one-metre notches
took 275 s, 243 s of it in 18,006 such measures.

A candidate differs from the ring it is made from (the *base*) in a few sides only.
:class:`Stray` keeps, for the base, how far each of its sides strays from the input
and how far each sampled point of the input lies from the base, and by which side;
a candidate's distance is then worked out from the sides it adds and the input's
points whose nearest side it removes. The result is the same Hausdorff distance
(the same samples: each side cut in 20 equal steps, as GEOS densifies by 0.05), to
the nanometre it is given in (:func:`to_nm`); unrounded, one in ten differs from
GEOS's in the last bit.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LinearRing

STEPS = 20            # samples a side is cut into (shapely's densify=0.05)


def to_nm(d: float) -> float:
    """A distance rounded to the nanometre, as every candidate's is compared with the
    tolerance and with each other's: computed two ways (here, and by GEOS whole), the
    same distance differs in its last bits, and one exactly at the tolerance (a 1 m
    notch filled at its middle, 0.5 m) was within it one way and past it the other;
    two candidates equally far were ranked by those bits, not by their order."""
    return round(d, 9)


def _samples(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The points the Hausdorff distance samples on the sides a[k] -> b[k]: each side's
    start and the 19 points between, as GEOS places them (start + i * step)."""
    i = np.arange(STEPS, dtype=float)[None, :, None]
    return (a[:, None, :] + i * ((b - a) / STEPS)[:, None, :]).reshape(-1, 2)


def _to_sides(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (len(q) x len(a)) from points ``q`` to the sides a[k] -> b[k]."""
    return _distance(q[:, 0:1], q[:, 1:2], a[None, :, 0], a[None, :, 1], b[None, :, 0],
                     b[None, :, 1])


def _distance(qx: np.ndarray, qy: np.ndarray, ax: np.ndarray, ay: np.ndarray,
              bx: np.ndarray, by: np.ndarray) -> np.ndarray:
    """Distances from points (qx, qy) to the sides (ax, ay) -> (bx, by), broadcast,
    following GEOS's ``LineSegment::closestPoint`` then ``Coordinate::distance`` (the
    nearest point on the side, then the distance to it). GEOS's own figures still
    differ in the last bit now and then; :func:`to_nm` makes them agree."""
    dx, dy = bx - ax, by - ay
    with np.errstate(divide="ignore", invalid="ignore"):
        r = ((qx - ax) * dx + (qy - ay) * dy) / (dx * dx + dy * dy)
    at_a = (qx == ax) & (qy == ay)
    at_b = (qx == bx) & (qy == by)
    r = np.where(at_a, 0.0, np.where(at_b, 1.0, r))
    inside = (r > 0) & (r < 1)
    d0 = np.sqrt((ax - qx) * (ax - qx) + (ay - qy) * (ay - qy))
    d1 = np.sqrt((bx - qx) * (bx - qx) + (by - qy) * (by - qy))
    px, py = ax + r * dx - qx, ay + r * dy - qy
    return np.where(inside, np.sqrt(px * px + py * py), np.where(d0 < d1, d0, d1))


SMALL = 64           # sides of an input ring measured whole (most footprints)
WITNESSES = 64       # input samples :meth:`Stray.floor` measures candidates by
MATRIX = 250_000     # point-side distances worked out at once; past it, a tree first
KEPT = 64_000_000    # bytes of candidates' measures kept for when one becomes the base


def _nearest(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each point of ``q``, the distance to the nearest of the sides a[k] -> b[k]
    and that side's index: all pairs at once where they are few, else by a tree (a
    survey of 12,000 vertices has 240,000 samples)."""
    if len(q) * len(a) <= MATRIX:
        d = _to_sides(q, a, b)
        by = np.argmin(d, axis=1)
        return d[np.arange(len(q)), by], by
    # the tree finds the nearest by its own formula; every side within a hair of it
    # is measured as above, and the least taken
    tree = shapely.STRtree(shapely.linestrings(np.stack([a, b], axis=1)))
    points = shapely.points(q)
    _, rough = tree.query_nearest(points, return_distance=True, all_matches=False)
    pq, ps = tree.query(points, predicate="dwithin", distance=rough * (1 + 1e-9) + 1e-9)
    d = _distance(q[pq, 0], q[pq, 1], a[ps, 0], a[ps, 1], b[ps, 0], b[ps, 1])
    order = np.lexsort((d, pq))                # per point, nearest first
    first = order[np.r_[True, pq[order][1:] != pq[order][:-1]]]
    near, by = np.empty(len(q)), np.empty(len(q), dtype=np.intp)
    near[pq[first]], by[pq[first]] = d[first], ps[first]
    return near, by


def _keys(ring: np.ndarray) -> list[bytes]:
    """Each side of a ring (vertex k to k + 1, closing) by its two ends' exact bits: a
    candidate keeps the base's vertices unchanged, so a side it keeps has the same key."""
    nxt = np.roll(ring, -1, axis=0)
    both = np.ascontiguousarray(np.hstack([ring, nxt]))
    return [row.tobytes() for row in both]


class _Measured:
    """One ring, measured: its sides' keys and how far each strays from the input
    (``out``); for each of the input's samples, how far the ring is (``near``) and which
    of its sides that is, by key index into ``keys`` (``by``)."""

    def __init__(self, keys: list[bytes], out: np.ndarray, near: np.ndarray,
                 by: np.ndarray) -> None:
        self.keys, self.out, self.near, self.by = keys, out, near, by
        self.where = {k: i for i, k in enumerate(keys)}


class Stray:
    """The Hausdorff distance of candidate rings from one input ``ring``, each measured
    against the base ring it was made from (see the module's docstring)."""

    def __init__(self, ring: LinearRing) -> None:
        r = np.asarray(ring.coords, dtype=float)[:, :2]
        self.ring = ring
        self._sides = (r[:-1], r[1:])
        self._small = len(r) - 1 <= SMALL
        # the input's samples: every side's, and its closing vertex
        self._q = np.vstack([_samples(r[:-1], r[1:]), r[-1:]])
        self._side: dict[bytes, float] = {}     # side key -> how far it strays
        self._base: bytes | None = None
        self._at: _Measured | None = None
        self._seen: dict[bytes, _Measured] = {}  # candidates of the current base
        # as many as fit in KEPT bytes: the next base is one of them, most often
        self._room = max(4, KEPT // (16 * len(self._q)))
        self._far: dict[int, None] = {}         # input samples that lay farthest (ordered)

    def _out(self, ring: np.ndarray, keys: list[bytes]) -> np.ndarray:
        """How far each side of ``ring`` strays from the input (the largest distance of
        its samples and its end), cached by side."""
        new = [k for k, key in enumerate(keys) if key not in self._side]
        if new:
            a, b = ring[new], np.roll(ring, -1, axis=0)[new]
            samples = np.concatenate([_samples(a, b).reshape(len(new), STEPS, 2),
                                      b[:, None, :]], axis=1)
            d, _by = _nearest(samples.reshape(-1, 2), self._sides[0], self._sides[1])
            for k, v in zip(new, d.reshape(len(new), STEPS + 1).max(axis=1), strict=True):
                self._side[keys[k]] = float(v)
        return np.array([self._side[key] for key in keys])

    def _whole(self, ring: np.ndarray) -> _Measured:
        """``ring`` measured from nothing: every input sample against its nearest side."""
        keys = _keys(ring)
        near, by = _nearest(self._q, ring, np.roll(ring, -1, axis=0))
        return _Measured(keys, self._out(ring, keys), near, by)

    def _rebase(self, base: np.ndarray) -> _Measured:
        """What is known of ``base``: measured as a candidate of the last base, or from
        the last base as one (a spike's tip cut off is not measured before it is
        taken), or (the first) from nothing."""
        key = base.tobytes()
        if key != self._base:
            seen, at = self._seen.get(key), self._at
            if seen is None and at is not None:
                keys = _keys(base)
                seen = _Measured(keys, self._out(base, keys),
                                 *self._near(at, base, keys, slice(None)))
            self._at = seen or self._whole(base)
            self._base, self._seen = key, {}
        assert self._at is not None
        return self._at

    def _near(self, at: _Measured, cand: np.ndarray, keys: list[bytes],
              pick: np.ndarray | slice) -> tuple[np.ndarray, np.ndarray]:
        """For the input samples ``pick``: how far ``cand`` lies from each, and by which
        of its sides, from what ``at`` (its base) knows: the same side where cand keeps
        it, one of the sides cand adds where that is nearer, all of cand's sides
        searched only for samples whose nearest side cand drops."""
        kept = np.array([at.where.get(key, -1) for key in keys])
        fresh = np.flatnonzero(kept < 0)                 # the sides cand adds
        index = np.full(len(at.keys), -1, dtype=np.intp)  # base side -> cand's, or -1
        index[kept[kept >= 0]] = np.flatnonzero(kept >= 0)
        q, near, was = self._q[pick], at.near[pick].copy(), at.by[pick]
        by = index[was]
        a, b = cand, np.roll(cand, -1, axis=0)
        if len(fresh):
            # only samples nearer the new sides' box than to the ring can come nearer
            ends = np.vstack([a[fresh], b[fresh]])
            lo, hi = ends.min(axis=0), ends.max(axis=0)
            gap = np.maximum(np.maximum(lo - q, q - hi), 0.0)
            may = np.flatnonzero(np.einsum("ij,ij->i", gap, gap) <= near * near)
            d = _to_sides(q[may], a[fresh], b[fresh])
            k = np.argmin(d, axis=1)
            dk = d[np.arange(len(d)), k]
            closer = dk < near[may]
            near[may[closer]], by[may[closer]] = dk[closer], fresh[k[closer]]
        lost = np.flatnonzero(index[was] < 0)     # their nearest side is gone: all anew
        if len(lost):
            near[lost], by[lost] = self._anew(q[lost], a, b, fresh)
        return near, by

    @staticmethod
    def _anew(q: np.ndarray, a: np.ndarray, b: np.ndarray, fresh: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """:func:`_nearest` for samples ``q`` whose nearest side was dropped, searching
        only the sides that may beat the new ones (``fresh``): those within the
        farthest of their distances to a new side, around the samples' box. A long
        zig-zag drops the nearest side of hundreds of samples at each step."""
        if not len(fresh):
            return _nearest(q, a, b)
        reach = float(_to_sides(q, a[fresh], b[fresh]).min(axis=1).max())
        lo, hi = q.min(axis=0) - reach, q.max(axis=0) + reach
        sel = np.flatnonzero(np.all(np.minimum(a, b) <= hi, axis=1)
                             & np.all(np.maximum(a, b) >= lo, axis=1))
        near, k = _nearest(q, a[sel], b[sel])
        return near, sel[k]

    def __call__(self, cand: np.ndarray, base: np.ndarray) -> float:
        """The Hausdorff distance of ``cand`` (a ring made from ``base`` by changing a
        few of its sides) from the input ring."""
        if self._small:          # measured whole: quicker than keeping books on it
            return to_nm(float(shapely.hausdorff_distance(LinearRing(cand), self.ring,
                                                          densify=0.05)))
        at = self._rebase(base)
        keys = _keys(cand)
        near, by = self._near(at, cand, keys, slice(None))
        out = self._out(cand, keys)
        if len(self._seen) < self._room:
            self._seen[cand.tobytes()] = _Measured(keys, out, near, by)
        far = int(np.argmax(near))
        self._far.pop(far, None)
        self._far[far] = None
        if len(self._far) > WITNESSES:
            del self._far[next(iter(self._far))]
        return to_nm(float(max(out.max(), near.max())))

    def floor(self, cand: np.ndarray, base: np.ndarray) -> float:
        """A lower bound of the distance :meth:`__call__` would give ``cand``: how far
        it lies from the input samples that lay farthest from the candidates measured
        before (each such distance is one the Hausdorff distance takes the largest of).
        The same way of absorbing a notch too deep for the tolerance is tried again at
        every step; its notch's floor says at once that it still strays too far."""
        if not self._far:
            return 0.0
        near, _by = self._near(self._rebase(base), cand, _keys(cand),
                               np.fromiter(self._far, dtype=np.intp))
        return float(near.max())
