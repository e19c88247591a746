"""The faithful cleaning's shortcuts give what the full measure gives.

:func:`citysynth.skeletons.clean._step` spares the Hausdorff distance of a candidate
whose floors (:func:`~citysynth.skeletons.clean._h_floor`,
:meth:`~citysynth.skeletons.stray.Stray.floor`) pass the tolerance, measures the rest
where they changed (:class:`~citysynth.skeletons.stray.Stray`), and
:func:`~citysynth.skeletons.clean._beyond` measures it only for options tied on the
ground they change. The reference here measures every candidate whole with GEOS, as
the cleaning did before (it took a Kotka leftover block 121 of its 157 s, a wall with
60 notches 275 s): on every footprint of the shipped district and on generated
stepped and notched outlines, both clean to the same vertices; and the local measure
is the whole one, on generated rings and changes.
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
from citysynth.skeletons.stray import to_nm

ROOT = Path(__file__).resolve().parent.parent
BUILDINGS = ROOT / "examples" / "city" / "district_buildings.geojson"


def _hausdorff(a, ring):
    """The full measure: every sample of either ring against the other (GEOS), to the
    nanometre the cleaning compares distances in."""
    return to_nm(float(shapely.hausdorff_distance(shapely.LinearRing(a), ring,
                                                  densify=0.05)))


def _reference_step(pts, stray, min_side, straight_tol, tolerance, relaxed, party=None):
    """The step as it was: every candidate measured whole, the options ordered by it."""
    ring = stray.ring
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
        scored = sorted(((_hausdorff(c, ring), k, c)
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


@pytest.mark.parametrize("tolerance, small", [(0.5, 64), (0.05, 64), (0.5, 0)])
def test_every_district_footprint_cleans_as_the_full_measure_does(monkeypatch, tolerance,
                                                                   small):
    from citysynth.skeletons import stray as stray_module

    monkeypatch.setattr(stray_module, "SMALL", small)
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
@given(stepped(), st.sampled_from([0.5, 0.1]), st.sampled_from([2.5, 4.0]),
       st.sampled_from([64, 0]))
def test_stepped_outlines_clean_as_the_full_measure_does(pts, tolerance, min_side, small):
    from citysynth.skeletons import stray as stray_module

    poly = shapely.Polygon(pts)
    if not poly.is_valid:
        return
    poly = shapely.geometry.polygon.orient(poly, 1.0)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(stray_module, "SMALL", small)
        got, want = _both(poly, min_side, tolerance, mp)
    assert np.array_equal(got, want)


@st.composite
def notched(draw):
    """A wall with 2-12 notches 0.2-1.5 m deep, too deep for the tolerance to fill
    faithfully: every step tries each again (the case the local measure is for)."""
    k, length = draw(st.integers(2, 12)), draw(st.floats(30, 120))
    step = length / k
    pts = [(0.0, 0.0)]
    for i in range(k):
        depth, width = draw(st.floats(0.2, 1.5)), draw(st.floats(0.3, 0.6))
        x = i * step + step * 0.3
        pts += [(x, 0.0), (x, depth), (x + width * step * 0.5, depth),
                (x + width * step * 0.5, 0.0)]
    pts += [(length, 0.0), (length, 12.0), (0.0, 12.0)]
    return np.asarray(pts)


@settings(max_examples=30, deadline=None)
@given(notched(), st.sampled_from([0.5, 0.1]), st.sampled_from([64, 0]))
def test_notched_walls_clean_as_the_full_measure_does(pts, tolerance, small):
    """``small`` 0: every ring measured where it changed (by default a ring of up to
    64 sides is measured whole, as it is quicker)."""
    from citysynth.skeletons import stray as stray_module

    poly = shapely.geometry.polygon.orient(shapely.Polygon(pts), 1.0)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(stray_module, "SMALL", small)
        got, want = _both(poly, 2.5, tolerance, mp)
    assert np.array_equal(got, want)


@st.composite
def changed_rings(draw):
    """An input ring (a star-shaped polygon of 5-40 points) and a chain of rings made
    from it the way cleaning makes them: a run of vertices replaced by one point, or
    dropped."""
    n = draw(st.integers(5, 40))
    ang = np.sort(draw(st.lists(st.floats(0, 2 * np.pi), min_size=n, max_size=n,
                                unique=True)))
    rad = np.asarray(draw(st.lists(st.floats(5, 20), min_size=n, max_size=n)))
    ring = np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    chain = [ring]
    for _ in range(draw(st.integers(1, 6))):
        base = chain[-1]
        m = len(base)
        if m < 4:
            break
        i, span = draw(st.integers(0, m - 1)), draw(st.integers(0, 2))
        j = (i + span) % m
        rest = [base[(j + 1 + t) % m] for t in range(m - span - 1)]
        if draw(st.booleans()) and len(rest) >= 3:
            chain.append(np.array(rest))
        elif len(rest) >= 2:
            off = np.array([draw(st.floats(-1, 1)), draw(st.floats(-1, 1))])
            chain.append(np.array([(base[i] + base[j]) / 2 + off] + rest))
    return ring, chain


@settings(max_examples=80, deadline=None)
@given(changed_rings(), st.sampled_from([250_000, 0]))
def test_the_local_measure_is_the_whole_hausdorff_distance(case, matrix):
    """Stray(cand, base) equals GEOS's densified Hausdorff distance to the nanometre,
    by the matrix and by the tree (``matrix`` 0), and its floor never exceeds it."""
    from citysynth.skeletons import stray as stray_module

    ring, chain = case
    line = shapely.LinearRing(ring)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(stray_module, "MATRIX", matrix)
        mp.setattr(stray_module, "SMALL", 0)
        measure = stray_module.Stray(line)
        for base, cand in zip(chain[:-1], chain[1:], strict=True):
            floor = measure.floor(cand, base)
            got = measure(cand, base)
            want = _hausdorff(cand, line)
            assert got == want, (got, want)
            assert floor <= got + 1e-9     # got is to the nanometre
