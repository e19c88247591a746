"""Skeletons and the sample library become structures that the solver fills: a block
cycle with corners, a T-shaped building, and the refusals on the way."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from citysynth.pipeline.skeleton_to_structure import skeleton_structure
from citysynth.skeletons import (
    SkeletonError,
    parse_geojson,
    skeleton_from_lines,
    skeletons_from_polygons,
)
from citysynth.solver.structures import solve_structure

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_skeletons import fc, feat, metres  # noqa: E402


@pytest.fixture
def db(sample_db):
    """The sample library, ingested once per session (conftest)."""
    return sample_db


def block(w, h):
    feats, frame = parse_geojson(fc(feat("Polygon", [metres([(0, 0), (w, 0), (w, h),
                                                             (0, h), (0, 0)])])))
    (sk,) = skeletons_from_polygons(feats, frame)
    return sk


def test_block_cycle_from_a_footprint(db):
    sk = block(90, 70)
    d = skeleton_structure(sk, db, "classic", k=3).structure
    r = solve_structure(d)
    assert r.status == "ok" and len(r.solutions) == 3
    edge = sorted(e.length for e in sk.edges)
    for s in r.solutions:
        assert all(key == "classic_corner_90_convex" for key in s.keys)
        got = sorted(res["length"] for res in s.resources)
        assert all(abs(a - b) <= 0.1 + 1e-9 for a, b in zip(got, edge, strict=True))


def test_t_shaped_building(db):
    feats, frame = parse_geojson(fc(feat("LineString", metres([(0, 0), (80, 0)])),
                                    feat("LineString", metres([(40, 0), (40, 50)]))))
    sk = skeleton_from_lines(feats, frame)
    d = skeleton_structure(sk, db, "modern", k=2).structure
    r = solve_structure(d)
    assert r.status == "ok"
    best = r.solutions[0]
    assert sorted(best.keys) == ["modern_end_left", "modern_end_right", "modern_end_right",
                                 "modern_t"]
    assert sorted(round(x["length"], 1) for x in best.resources) == [40.0, 40.0, 50.0]


def test_infeasible_block_names_the_stage(db):
    plan = skeleton_structure(block(100, 64), db, "classic")
    r = solve_structure(plan.structure)
    assert r.status == "infeasible"
    assert "stage" in r.reason and "nearest achievable" in r.reason


def test_corner_without_a_part_lists_the_angles(db):
    tri = metres([(0, 0), (90, 0), (45, 78), (0, 0)])
    feats, frame = parse_geojson(fc(feat("Polygon", [tri])))
    (sk,) = skeletons_from_polygons(feats, frame)
    with pytest.raises(SkeletonError, match="convex corner of 60.0° .* library has corners of 90"):
        skeleton_structure(sk, db, "classic")
