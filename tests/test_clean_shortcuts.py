"""The faithful cleaning's shortcuts give what the full measure gives.

:func:`citysynth.skeletons.clean._step` spares the Hausdorff distance of a candidate
whose floor (:func:`~citysynth.skeletons.clean._h_floor`) passes the tolerance, and
:func:`~citysynth.skeletons.clean._beyond` measures it only for options tied on the
ground they change. The reference here measures every candidate, as the cleaning did
before (it took a Kotka leftover block 121 of its 157 s): on every footprint of the
shipped district and on generated stepped outlines, both clean to the same vertices.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from citysynth.skeletons import clean
from citysynth.skeletons.from_geometry import STRAIGHT_TOL
from citysynth.skeletons.geojson import read_geojson

ROOT = Path(__file__).resolve().parent.parent
BUILDINGS = ROOT / "examples" / "city" / "district_buildings.geojson"


def _reference_step(pts, ring, min_side, straight_tol, tolerance, relaxed, party=None):
    """The step as it was: every candidate measured, the options ordered by it."""
    turns = np.abs(clean._turns(pts))
    for v in np.flatnonzero(turns > 180.0 - clean.MIN_ANGLE):
        cand = np.delete(pts, int(v), axis=0)
        legs = max(np.linalg.norm(pts[v] - pts[v - 1]),
                   np.linalg.norm(pts[(v + 1) % len(pts)] - pts[v]))
        if len(cand) >= 3 and 2 * clean._changed_area(pts, cand) <= tolerance * legs:
            return cand
    pool = []
    across = None
    for run, (i, j) in enumerate(clean._short_runs(pts, min_side, straight_tol)):
        scored = sorted(((clean._hausdorff(c, ring), k, c)
                         for k, c in enumerate(clean._candidates(pts, i, j))),
                        key=lambda t: t[:2])
        for h, k, cand in scored:
            if h <= tolerance and not relaxed:
                if party is None or not clean._grown_across(
                        shapely.Polygon(cand).buffer(0).difference(
                            shapely.Polygon(pts).buffer(0)), party):
                    return cand
                across = cand if across is None else across
            if relaxed:
                pool.append((h, clean._option(run, k, pts, cand, party)))
    if not relaxed:
        return across
    measured = {id(o): h for h, o in pool}
    inside = clean._allowed([o for _h, o in pool])   # in the measured order
    if not inside:
        return None
    return min(inside, key=lambda o: (o.cut + o.grown, o.across, measured[id(o)])).ring


def _both(poly: shapely.Polygon, min_side: float, tolerance: float, monkeypatch):
    got = clean.faithful_ring(poly.exterior.coords, min_side=min_side,
                              straight_tol=STRAIGHT_TOL, tolerance=tolerance)
    with monkeypatch.context() as m:
        m.setattr(clean, "_step", _reference_step)
        want = clean.faithful_ring(poly.exterior.coords, min_side=min_side,
                                   straight_tol=STRAIGHT_TOL, tolerance=tolerance)
    return got, want


@pytest.mark.parametrize("tolerance", [0.5, 0.05])
def test_every_district_footprint_cleans_as_the_full_measure_does(monkeypatch, tolerance):
    feats, _frame = read_geojson(BUILDINGS, accept="polygons")
    checked = 0
    for f in feats:
        for poly in shapely.get_parts(f.geometry):
            if not poly.is_valid:
                continue
            got, want = _both(shapely.geometry.polygon.orient(poly, 1.0), 3.0, tolerance,
                              monkeypatch)
            assert np.array_equal(got, want), f.where
            checked += 1
    assert checked > 200


@st.composite
def stepped(draw):
    """A rectangle whose sides carry steps and notches of 0.3-3 m, jittered."""
    w, h = draw(st.floats(20, 80)), draw(st.floats(15, 50))
    pts = []
    for (x0, y0), (x1, y1) in (((0, 0), (w, 0)), ((w, 0), (w, h)), ((w, h), (0, h)),
                               ((0, h), (0, 0))):
        pts.append((x0, y0))
        for t in sorted(draw(st.lists(st.floats(0.1, 0.9), max_size=3, unique=True))):
            depth = draw(st.floats(-3, 3))
            nx, ny = (y1 - y0), -(x1 - x0)
            norm = float(np.hypot(nx, ny))
            a = (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
            b = (a[0] + 0.04 * (x1 - x0), a[1] + 0.04 * (y1 - y0))
            pts += [a, (a[0] + depth * nx / norm, a[1] + depth * ny / norm),
                    (b[0] + depth * nx / norm, b[1] + depth * ny / norm), b]
    jitter = draw(st.lists(st.floats(-0.2, 0.2), min_size=2 * len(pts),
                           max_size=2 * len(pts)))
    return np.asarray(pts) + np.reshape(jitter, (-1, 2))


@settings(max_examples=60, deadline=None)
@given(stepped(), st.sampled_from([0.5, 0.1]), st.sampled_from([2.5, 4.0]))
def test_stepped_outlines_clean_as_the_full_measure_does(pts, tolerance, min_side):
    poly = shapely.Polygon(pts)
    if not poly.is_valid:
        return
    poly = shapely.geometry.polygon.orient(poly, 1.0)
    with pytest.MonkeyPatch.context() as mp:
        got, want = _both(poly, min_side, tolerance, mp)
    assert np.array_equal(got, want)
