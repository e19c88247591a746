"""Skeletons and the sample library become structures that the solver fills: a block
cycle with corners, a T-shaped building, and the refusals on the way."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from citysynth.pipeline.skeleton_to_structure import skeleton_structure
from citysynth.skeletons import (
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
        # a right-angled corner part (of any profile family) or a mitre joint
        assert all(key.startswith(("classic_corner_90_convex", "joint:mitre")) for key in s.keys)
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
    kinds = sorted(key.rsplit("_", 1)[0] if key.count("_") > 2 else key for key in best.keys)
    assert sorted(k.split("_")[1] for k in best.keys) == ["end", "end", "end", "t"]
    assert all(k.startswith("modern_") for k in kinds)
    assert sorted(round(x["length"], 1) for x in best.resources) == [40.0, 40.0, 50.0]


def test_infeasible_block_names_the_stage(db):
    plan = skeleton_structure(block(100, 64), db, "classic", per_side={"doors": (60, 60)})
    r = solve_structure(plan.structure)
    assert r.status == "infeasible"
    assert "stage" in r.reason and "nearest achievable" in r.reason


def test_corner_without_a_part_is_a_mitre_joint(db):
    """A 60° corner, for which the library has no corner part, is a mitre joint: the
    modules on either side are cut on its bisector (any angle builds)."""
    tri = metres([(0, 0), (90, 0), (45, 78), (0, 0)])
    feats, frame = parse_geojson(fc(feat("Polygon", [tri])))
    (sk,) = skeletons_from_polygons(feats, frame)
    plan = skeleton_structure(sk, db, "classic", slack=0.3)
    assert all(any(x.startswith("joint:mitre") for x in opts)
               for opts in plan.structure.keypoints)
    r = solve_structure(plan.structure)
    assert r.status == "ok" and all(k.startswith("joint:mitre") for k in r.solutions[0].keys)


def test_a_corner_part_needs_room_behind_its_corner(db):
    """A 12 m slot cut 50 m into a block: the library's concave 90° corner part fits the
    slot's west bottom corner, but not its east one, 18 m from the block's east side,
    where its mass would reach through that side into the street; that corner is a
    mitre joint (whose modules are cut where the block is thin)."""
    slot = metres([(0, 0), (100, 0), (100, 80), (82, 80), (82, 30), (70, 30), (70, 80),
                   (0, 80), (0, 0)])
    feats, frame = parse_geojson(fc(feat("Polygon", [slot])))
    (sk,) = skeletons_from_polygons(feats, frame)
    plan = skeleton_structure(sk, db, "classic")
    # the frame is centred on the block: (70, 30) is (20, -10)
    spots = {(20, -10): "slot west", (32, -10): "slot east", (-50, -40): "south-west"}
    at = {}
    for key, opts in zip(plan.placement.keys, plan.structure.keypoints, strict=True):
        near = [n for (x, y), n in spots.items() if abs(x - key.xy[0]) + abs(y - key.xy[1]) < 0.1]
        if near:
            at[near[0]] = [x for x in opts if not x.startswith("joint:")]
    assert len(at) == 3
    assert any("concave" in x for x in at["slot west"]), at["slot west"]
    assert at["slot east"] == []
    assert any("convex" in x for x in at["south-west"])


def _attributes_placed(db, st: dict) -> dict[str, float]:
    """The doors, windows ... of every part a layout structure places: its fillers and
    its key parts (a T in a pose is its part; a mitre joint has none), each once."""
    from collections import Counter

    from citysynth.export.t_poses import SEP
    total: Counter = Counter()
    ids = [p for stage in st["stages"] for p in stage["parts"]
           if not p.startswith("joint:") and db.part(p.split(SEP)[0]).cls == "middle"]
    ids += [k["part"].split(SEP)[0] for k in st["keys"] if not k["part"].startswith("joint:")]
    for pid in ids:
        total.update(db.part(pid).attributes)
    return dict(total)


@pytest.mark.parametrize("source", ["examples/blocks/block.geojson",
                                    "examples/skeletons/t_building.geojson"])
def test_a_layouts_totals_count_every_part_key_parts_too(db, tmp_path, source):
    """The doors and windows a structure meets (and per_block intervals bound) are those
    of every part it places, its corners' and T's too; each side's share of a key part
    is a whole number (it was the fillers' alone: a block's corners, 40-96 windows
    each, went uncounted)."""
    import json

    from citysynth.pipeline.cli import main
    root = Path(__file__).resolve().parent.parent
    command = "block" if "blocks" in source else "building"
    assert main([command, str(root / source), "--library", str(root / "examples" / "library"),
                 "--k", "2", "-o", str(tmp_path), "--no-preview"]) == 0
    layouts = sorted(tmp_path.glob("*.layout.json"))
    assert layouts
    for f in layouts:
        for st in json.loads(f.read_text())["structures"]:
            placed = _attributes_placed(db, st)
            assert placed and any(k["joint"] == "part" for k in st["keys"])
            for a, v in placed.items():
                assert st["resources"][a] == pytest.approx(v), (f.name, a)
                assert all(float(s["met"][a]).is_integer() for s in st["stages"])
