"""Footprint cleaning: outlines with many short sides, cleaned faithfully
(:func:`citysynth.skeletons.clean.clean_footprint`, tolerance 0.5 m, the kit's
shortest side 2.5 m) with candidates measured where they change
(:class:`citysynth.skeletons.stray.Stray`, the default) and measured whole by GEOS's
Hausdorff distance and without the floor of the farthest samples
(:meth:`~citysynth.skeletons.stray.Stray.floor`), as before 2026-12-02; both in one
run, in turn, median of --runs after a warm-up. The last column says whether both
give the same vertices.

    python -m bench.clean [--runs 3]

The outlines: a wall with n notches 1 m deep (a colonnade's bays: too deep to fill
within the tolerance, so every step tries each again), a survey of a 40 x 25 m
house drawn with n points jittered ±0.5 m, and a 200 m wall zig-zagging 0.6 m at n
points (the whole measure takes minutes past these sizes).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np
import shapely
from shapely.geometry import LinearRing, Polygon

from bench.timing import interleaved
from citysynth.skeletons import stray
from citysynth.skeletons.clean import clean_footprint
from citysynth.skeletons.from_geometry import STRAIGHT_TOL


def notched(k: int, length: float = 200.0) -> Polygon:
    step, pts = length / k, [(0.0, 0.0)]
    for i in range(k):
        x = i * step
        pts += [(x + step * .4, 0.0), (x + step * .4, 1.0), (x + step * .6, 1.0),
                (x + step * .6, 0.0)]
    return Polygon(pts + [(length, 0.0), (length, 12.0), (0.0, 12.0)])


def survey(n: int, jitter: float = 0.5, w: float = 40.0, h: float = 25.0) -> Polygon:
    rng = np.random.default_rng(0)
    s = np.linspace(0, 2 * (w + h), n, endpoint=False)
    x = np.select([s < w, s < w + h, s < 2 * w + h], [s, w, w - (s - w - h)], 0.0)
    y = np.select([s < w, s < w + h, s < 2 * w + h], [0.0, s - w, h], h - (s - 2 * w - h))
    return Polygon(np.column_stack([x, y]) + rng.uniform(-jitter, jitter, (n, 2)))


def zigzag(n: int, amp: float = 0.6, length: float = 200.0) -> Polygon:
    top = np.column_stack([np.linspace(0, length, n), np.where(np.arange(n) % 2, amp, 0.0)])
    return Polygon(np.vstack([top, [[length, -10.0], [0.0, -10.0]]]))


CASES: dict[str, Callable[[], Polygon]] = {
    "wall, 10 notches": lambda: notched(10),
    "wall, 20 notches": lambda: notched(20),
    "wall, 40 notches": lambda: notched(40),
    "survey, 500 points": lambda: survey(500),
    "survey, 1,000 points": lambda: survey(1000),
    "zig-zag, 200 points": lambda: zigzag(200),
    "zig-zag, 400 points": lambda: zigzag(400),
}


def _whole(self: stray.Stray, cand: np.ndarray, base: np.ndarray) -> float:
    """The measure as it was: every sample of either ring against the other."""
    return stray.to_nm(float(shapely.hausdorff_distance(LinearRing(cand), self.ring,
                                                        densify=0.05)))


def _no_floor(self: stray.Stray, cand: np.ndarray, base: np.ndarray) -> float:
    return 0.0


def _clean(poly: Polygon, whole: bool) -> Polygon | None:
    local, floor = stray.Stray.__call__, stray.Stray.floor
    if whole:
        stray.Stray.__call__ = _whole      # type: ignore[method-assign]
        stray.Stray.floor = _no_floor      # type: ignore[method-assign]
    try:
        return clean_footprint(poly, min_side=2.5, straight_tol=STRAIGHT_TOL)
    finally:
        stray.Stray.__call__, stray.Stray.floor = local, floor  # type: ignore[method-assign]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    print(f"{'outline':24} {'points':>7} {'local s':>9} {'whole s':>9} {'speed-up':>9}  same")
    for name, make in CASES.items():
        poly = make()
        res = interleaved({"local": lambda p=poly: _clean(p, False),
                           "whole": lambda p=poly: _clean(p, True)}, args.runs)
        (t_local, outs_local), (t_whole, outs_whole) = res["local"], res["whole"]
        assert t_local is not None and t_whole is not None
        same = all(a is not None and b is not None and a.equals_exact(b, 0.0)
                   for a, b in zip(outs_local, outs_whole, strict=True))
        print(f"{name:24} {len(poly.exterior.coords) - 1:>7,} {t_local:>9.3f} "
              f"{t_whole:>9.3f} {t_whole / t_local:>8.1f}x  {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
