"""Cleaning real block outlines before they become skeletons.

Block outlines cut from real street networks carry what no facade can follow: survey
noise, short edges where a kerb bends, and sides between two corners too short for
any pair of corner parts. :func:`absorb_short_edges` removes them the way a designer
would: spikes sharper than ``MIN_ANGLE`` lose their tip, and each too-short run
between two corners is absorbed into its neighbours' corners, its ends merged where
the neighbouring sides' lines meet (or at its middle, when they are nearly parallel or
meet far away). Near-straight vertices stay: they are
bends inside a substructure, not key points.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely
from shapely.geometry import LinearRing, Polygon

from citysynth.skeletons.geojson import angle_between

NOISE = 0.3           # metres: Douglas-Peucker tolerance for survey noise
MIN_ANGLE = 30.0      # degrees: a sharper corner is a spike, and its tip is cut off


def _turns(pts: np.ndarray) -> np.ndarray:
    n = len(pts)
    return np.array([angle_between(pts[i] - pts[i - 1], pts[(i + 1) % n] - pts[i])
                     for i in range(n)])


def _merge_point(pts: np.ndarray, i: int, j: int) -> np.ndarray:
    """Where vertices i..j (a short run, indices mod n) collapse to: the meeting point of
    the lines of the edges before i and after j, if it is near; else the run's middle."""
    n = len(pts)
    a0, a1 = pts[(i - 1) % n], pts[i]
    b0, b1 = pts[j], pts[(j + 1) % n]
    run = [pts[(i + t) % n] for t in range((j - i) % n + 1)]
    mid = np.mean(run, axis=0)
    span = sum(float(np.linalg.norm(q - p)) for p, q in zip(run[:-1], run[1:], strict=True))
    da, db = a1 - a0, b1 - b0
    cross = da[0] * db[1] - da[1] * db[0]
    if abs(cross) < 1e-9 * np.linalg.norm(da) * np.linalg.norm(db):
        return mid
    t = ((b0 - a0)[0] * db[1] - (b0 - a0)[1] * db[0]) / cross
    p = a0 + t * da
    return p if np.linalg.norm(p - mid) <= max(2.0 * span, 2.0) else mid


def _ring(coords: Any, min_edge: float, min_stage: float, straight_tol: float) -> np.ndarray:
    pts = np.asarray(coords, dtype=float)[:-1, :2]
    for _ in range(4 * len(pts)):
        n = len(pts)
        if n < 3:
            break
        seg = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
        turns = _turns(pts)
        corner = np.abs(turns) >= straight_tol
        # runs between consecutive corners, as (first vertex, last vertex, length)
        cs = np.flatnonzero(corner)
        runs = []
        if len(cs) >= 2:
            for a, b in zip(cs, np.roll(cs, -1), strict=True):
                length = sum(seg[k % n] for k in range(a, a + (b - a) % n or n))
                runs.append((int(a), int(b), float(length)))
        spike = int(np.argmax(np.abs(turns)))
        if abs(turns[spike]) > 180.0 - MIN_ANGLE:   # a spike: cut its tip off
            pts = np.delete(pts, spike, axis=0)
            continue
        short_edge = int(np.argmin(seg))
        if seg[short_edge] < min_edge:
            i, j = short_edge, (short_edge + 1) % n
        else:
            short = [r for r in runs if r[2] < min_stage]
            if not short:
                break
            i, j, _len = min(short, key=lambda r: r[2])
        p = _merge_point(pts, i, j)
        rest = n - ((j - i) % n + 1)            # the vertices after the run, in order
        pts = np.vstack([p, pts[[(j + 1 + t) % n for t in range(rest)]]])
    return pts


def absorb_short_edges(poly: Polygon, *, min_edge: float, min_stage: float,
                       straight_tol: float) -> Polygon | None:
    """``poly`` with noise removed, edges under ``min_edge`` and corner-to-corner runs
    under ``min_stage`` absorbed into their neighbours' corners. None when nothing
    valid is left (the caller reports the block as skipped)."""
    poly = shapely.geometry.polygon.orient(
        shapely.simplify(poly, NOISE, preserve_topology=True), 1.0)
    rings = []
    for r, ring in enumerate([poly.exterior, *poly.interiors]):
        pts = _ring(ring.coords, min_edge, min_stage, straight_tol)
        if len(pts) < 3:
            if r == 0:
                return None
            continue          # a courtyard too small to keep: drop it
        rings.append(LinearRing(pts))
    out = Polygon(rings[0], rings[1:])
    if not out.is_valid or out.area <= 0:
        parts = [g for g in shapely.get_parts(shapely.make_valid(out))
                 if isinstance(g, Polygon)]
        if not parts:
            return None
        out = max(parts, key=lambda g: g.area)
    return shapely.geometry.polygon.orient(out, 1.0)
