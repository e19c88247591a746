"""A deterministic set of house footprints shaped like a residential district:
rectangles, Ls, Us, notched quadrilaterals and courtyard rings, sides of 8-30 m, with
survey noise (vertices jittered by up to 0.1 m, and extra vertices a few centimetres off
the straight line along some sides), turned at any angle, as GeoJSON in lon/lat.

Used by the footprint tests and ``bench/footprints.py``; ``python -m
citysynth.examples.footprint_shapes OUT.geojson [N]`` writes the set. Each feature
carries ``id``, ``shape`` and ``min_side`` (its shortest wall in the noise-free
outline, for the eligibility rule: every side at least twice the shortest end part).
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from citysynth.skeletons.geojson import lonlat_from_local

ORIGIN = (24.94, 60.17)       # lon, lat of the set's local frame
SPACING = 70.0                # m between the houses' centres
SHAPES = ("rectangle", "L", "U", "notched", "courtyard")

Ring = list[tuple[float, float]]


def _rectangle(r: np.random.Generator) -> list[Ring]:
    w, h = r.uniform(8, 30), r.uniform(8, 22)
    return [[(0, 0), (w, 0), (w, h), (0, h)]]


def _l(r: np.random.Generator) -> list[Ring]:
    w, h = r.uniform(16, 30), r.uniform(16, 28)
    a, b = r.uniform(8, w - 8), r.uniform(8, h - 8)    # the leg widths
    return [[(0, 0), (w, 0), (w, b), (a, b), (a, h), (0, h)]]


def _u(r: np.random.Generator) -> list[Ring]:
    w, h = r.uniform(26, 30), r.uniform(18, 28)
    leg = r.uniform(8, (w - 8) / 2)
    depth = r.uniform(8, h - 8)
    return [[(0, 0), (w, 0), (w, h), (w - leg, h), (w - leg, h - depth), (leg, h - depth),
             (leg, h), (0, h)]]


def _notched(r: np.random.Generator) -> list[Ring]:
    """A quadrilateral (a rectangle sheared a little) with a notch in its long side."""
    w, h = r.uniform(24, 30), r.uniform(10, 20)
    skew = r.uniform(-0.15, 0.15) * h
    nw, nd = r.uniform(3, 8), r.uniform(1.0, 3.0)
    x0 = r.uniform(8, w - 8 - nw)
    return [[(0, 0), (x0, 0), (x0, nd), (x0 + nw, nd), (x0 + nw, 0), (w, 0),
             (w + skew, h), (skew, h)]]


def _courtyard(r: np.random.Generator) -> list[Ring]:
    w, h = r.uniform(26, 30), r.uniform(26, 30)
    d = r.uniform(8, 10)
    return [[(0, 0), (w, 0), (w, h), (0, h)],
            [(d, d), (d, h - d), (w - d, h - d), (w - d, d)]]


MAKERS: dict[str, Callable[[np.random.Generator], list[Ring]]] = {
    "rectangle": _rectangle, "L": _l, "U": _u, "notched": _notched, "courtyard": _courtyard}


def _min_side(rings: list[Ring]) -> float:
    return min(math.dist(p, q) for ring in rings for p, q in zip(ring, ring[1:] + ring[:1],
                                                                    strict=True))


def _noisy(ring: Ring, r: np.random.Generator) -> Ring:
    """The ring with every vertex jittered by up to 0.1 m and, on some sides, an extra
    vertex up to 0.15 m off the line (what a survey or a tracer leaves)."""
    out: Ring = []
    for p, q in zip(ring, ring[1:] + ring[:1], strict=True):
        out.append((p[0] + r.uniform(-0.1, 0.1), p[1] + r.uniform(-0.1, 0.1)))
        if r.random() < 0.4:
            t = r.uniform(0.3, 0.7)
            d = np.subtract(q, p)
            n = np.array([-d[1], d[0]]) / np.linalg.norm(d)
            m = np.add(p, t * d) + n * r.uniform(-0.15, 0.15)
            out.append((float(m[0]), float(m[1])))
    return out


def footprints(n: int = 220, seed: int = 12) -> dict[str, Any]:
    """``n`` houses (the shapes in turn), as a GeoJSON FeatureCollection in lon/lat."""
    r = np.random.default_rng(seed)
    cols = math.ceil(math.sqrt(n))
    feats = []
    for i in range(n):
        shape = SHAPES[i % len(SHAPES)]
        rings = MAKERS[shape](r)
        angle = r.uniform(0, 2 * math.pi)
        rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
        centre = np.array([(i % cols) * SPACING, (i // cols) * SPACING])
        coords = []
        for ring in rings:
            pts = np.asarray(_noisy(ring, r)) @ rot.T + centre
            ll = lonlat_from_local(pts, ORIGIN)
            coords.append(ll + ll[:1])
        feats.append({"type": "Feature",
                      "properties": {"id": f"house/{i}", "shape": shape, "building": "house",
                                     "min_side": round(_min_side(rings), 3)},
                      "geometry": {"type": "Polygon", "coordinates": coords}})
    return {"type": "FeatureCollection", "features": feats}


if __name__ == "__main__":   # pragma: no cover - a convenience for the shell
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 220
    with open(sys.argv[1], "w", encoding="utf-8") as fh:
        json.dump(footprints(count), fh)
