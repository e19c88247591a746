"""Party walls (pipeline/city/party.py, export/party.py): where two footprints share a
wall, neither building's parts reach into the other. Before, each was built with
facades all round: on the shared wall its balconies, trims and eaves stood up to
0.3 m inside its neighbour, and at the street front one's cornice ran through the
other's. Measured on what usd-core composes from the written files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon, box

from citysynth.export.audit import _coplanar_roofs, instance_triangles
from citysynth.export.party import INSET
from citysynth.pipeline.city import run as city_run
from citysynth.pipeline.city.config import parse_config
from citysynth.pipeline.city.party import MIN_LENGTH, TOUCH, shared_stretches
from citysynth.pipeline.city.run import prepare
from citysynth.pipeline.cli import main
from citysynth.skeletons.geojson import lonlat_from_local

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
ORIGIN = (24.94, 60.17)

ROW = {   # local metres: three houses in a row, and a wing behind the middle one
    "west": [(0, 0), (30, 0), (30, 14), (0, 14)],
    "middle": [(30, 0), (62, 0), (62, 14), (30, 14)],
    "east": [(62, 0), (80, 0), (80, 14), (62, 14)],
    "back": [(34, 14), (48, 14), (48, 30), (34, 30)],
}


def write(path: Path, scene: dict) -> Path:
    feats = [{"type": "Feature", "properties": {"id": n, "building:levels": 4},
              "geometry": {"type": "Polygon",
                           "coordinates": [lonlat_from_local(ring + ring[:1], ORIGIN)]}}
             for n, ring in scene.items()]
    path.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    return path


def test_a_shared_edge_is_one_stretch_with_the_building_on_its_left():
    a, b = box(0, 0, 30, 14), box(30, 0, 62, 14)
    (seg,) = shared_stretches(a, [b])
    p0, p1 = np.array(seg[:2]), np.array(seg[2:])
    assert sorted([tuple(p0), tuple(p1)]) == [(30.0, 0.0), (30.0, 14.0)]
    u = p1 - p0
    c = np.array(a.centroid.coords[0]) - p0
    assert u[0] * c[1] - u[1] * c[0] > 0      # ground on the left
    (seg_b,) = shared_stretches(b, [a])
    assert seg_b[:2] == seg[2:] and seg_b[2:] == seg[:2]              # the other way round


def test_what_counts_as_shared():
    a = box(0, 0, 30, 14)
    assert len(shared_stretches(a, [box(30 + TOUCH / 2, 0, 50, 14)])) == 1   # drawn apart
    assert shared_stretches(a, [box(31, 0, 50, 14)]) == ()                 # a passage
    assert shared_stretches(a, [box(30, 14, 50, 30)]) == ()                # a corner
    assert shared_stretches(a, [box(30, 13.5, 50, 30)]) == ()              # < MIN_LENGTH
    assert MIN_LENGTH > 0.5
    (part,) = shared_stretches(a, [box(30, 4, 50, 10)])                     # part of a side
    assert sorted([part[1], part[3]]) == [4.0, 10.0]
    ring = Polygon([(0, 0), (40, 0), (40, 40), (0, 40)], [[(10, 10), (30, 10), (30, 30),
                                                          (10, 30)]])
    inner = shared_stretches(ring, [box(10, 10, 30, 20)])                   # in a courtyard
    assert len(inner) == 3 and all(9.9 < min(s[1], s[3]) for s in inner)


def test_the_city_run_gives_each_footprint_its_shared_walls(tmp_path):
    fp = write(tmp_path / "row.geojson", ROW)
    jobs = {j.footprint.ref: j for j in prepare(None, fp, parse_config({"k": 1}), LIB).jobs}
    counts = {ref: len(j.footprint.party) for ref, j in jobs.items()}
    assert counts == {"west": 1, "middle": 3, "east": 1, "back": 1}


def _run(tmp_path: Path, name: str) -> dict[str, dict[str, np.ndarray]]:
    fp = write(tmp_path / "row.geojson", ROW)
    out = tmp_path / name
    assert main(["city", "--footprints", str(fp), "--library", str(LIB), "-o", str(out),
                 "--workers", "1", "--no-overview", "--config",
                 str(_config(tmp_path))]) == 0
    jobs = prepare(None, fp, parse_config({"k": 1}), LIB).jobs
    return {j.footprint.ref: instance_triangles(out / "blocks" / f"{j.id}.usda")
            for j in jobs}


def _config(tmp_path: Path) -> Path:
    cfg = tmp_path / "city.toml"
    cfg.write_text("k = 1\n")
    return cfg


def _reach(tris: dict[str, np.ndarray], seg: tuple[float, ...]) -> float:
    """How far the building's meshes reach past the shared line, along the middle of
    the stretch (metres; negative: they stop short of it)."""
    p0, p1 = np.array(seg[:2]), np.array(seg[2:])
    length = float(np.hypot(*(p1 - p0)))
    u = (p1 - p0) / length
    n = np.array([u[1], -u[0]])
    pts = np.concatenate([t.reshape(-1, 3)[:, :2] for t in tris.values()])
    t = (pts - p0) @ u
    mid = (t > 0.5) & (t < length - 0.5)
    return float(((pts[mid] - p0) @ n).max())


@pytest.fixture(scope="module")
def row(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("party")
    fp = write(tmp / "row.geojson", ROW)
    jobs = {j.footprint.ref: j for j in prepare(None, fp, parse_config({"k": 1}), LIB).jobs}
    with_walls = _run(tmp, "with")
    mp = pytest.MonkeyPatch()
    mp.setattr(city_run, "with_party_walls", lambda built: built)
    try:
        without = _run(tmp, "without")
    finally:
        mp.undo()
    return jobs, with_walls, without


def _intruding(tris: dict[str, np.ndarray], seg: tuple[float, ...]) -> float:
    """The length of the shared stretch (metres, probed every 0.25 m) along which the
    building's meshes, seen from above, reach more than 1 mm past the line."""
    p0, p1 = np.array(seg[:2]), np.array(seg[2:])
    length = float(np.hypot(*(p1 - p0)))
    u = (p1 - p0) / length
    n = np.array([u[1], -u[0]])
    faces = np.concatenate(list(tris.values()))[:, :, :2]
    plan = shapely.union_all([Polygon(f) for f in faces if Polygon(f).area > 1e-6],
                             grid_size=1e-4)
    probes = [LineString([p0 + u * t + n * 1e-3, p0 + u * t + n * 1.0])
              for t in np.arange(0.125, length, 0.25)]
    return 0.25 * int(shapely.intersects(plan, probes).sum())


def test_no_part_reaches_into_its_neighbour(row):
    """On every wall shared along a whole side, each building's meshes stop INSET short
    of the line (their cut's cap is the wall); without party walls balconies and eaves
    reached in all along. Where a stretch ends in the middle of a module that runs on
    into a yard (the back wing against the middle house), that module keeps its facade:
    at most its overlap with the stretch is left."""
    jobs, with_walls, without = row
    before, after, partial = [], [], []
    for ref, job in jobs.items():
        for seg in job.footprint.party:
            length = float(np.hypot(seg[2] - seg[0], seg[3] - seg[1]))
            if ref == "middle" and abs(seg[1] - seg[3]) < 0.01 and length < 20:
                partial.append((_intruding(with_walls[ref], seg),
                                _intruding(without[ref], seg)))
                continue
            assert _intruding(with_walls[ref], seg) == 0.0
            assert _intruding(without[ref], seg) >= length - 0.5     # all along, before
            after.append(_reach(with_walls[ref], seg))
            before.append(_reach(without[ref], seg))
    assert len(after) == 5 and len(partial) == 1
    assert max(before) > 0.15                     # the old layouts reached in
    assert max(after) <= -INSET + 1e-3
    assert min(after) >= -0.03                    # the wall is still on the line
    assert partial[0][0] <= 2.5 < 12 <= partial[0][1]   # of the 14 m stretch


def test_the_seam_has_neither_overlap_nor_gap(row):
    """Where two houses meet wall to wall along a whole side, their meshes meet within
    1 cm, and none of their up faces lie over each other in one plane (z-fighting).
    Against the back wing, whose stretch ends inside one of the middle house's
    modules, what that module keeps of its eave stays under 0.05 m²."""
    jobs, with_walls, without = row
    for a, b in (("west", "middle"), ("middle", "east"), ("middle", "back")):
        both = {**{"a" + k: v for k, v in with_walls[a].items()},
                **{"b" + k: v for k, v in with_walls[b].items()}}
        shared = _coplanar_roofs(both) - _coplanar_roofs(with_walls[a]) - \
            _coplanar_roofs(with_walls[b])
        assert shared <= (0.05 if b == "back" else 1e-6)
        if b == "back":
            continue
        (seg,) = [s for s in jobs[a].footprint.party
                  if any(np.allclose(s[:2], t[2:], atol=0.01) and np.allclose(s[2:], t[:2],
                                                                             atol=0.01)
                         for t in jobs[b].footprint.party)]
        gap = -_reach(with_walls[a], seg) - _reach(with_walls[b], (*seg[2:], *seg[:2]))
        assert 0 <= gap <= 0.03


def test_citysynth_block_gives_touching_features_party_walls(tmp_path):
    """``citysynth block`` lays each feature out alone too: features of its file that
    touch (a row of footprints) stop their parts at the wall they share, as a city's
    do; before, each reached up to 0.3 m into its neighbour all along."""
    from citysynth.pipeline.city.party import party_walls
    from citysynth.skeletons import read_geojson

    fp = write(tmp_path / "row.geojson", ROW)
    out = tmp_path / "out"
    assert main(["block", str(fp), "--library", str(LIB), "-o", str(out), "--infill",
                 "--no-preview"]) == 0
    feats, _frame = read_geojson(fp)
    walls = dict(zip((f.properties["id"] for f in feats),
                     party_walls([f.geometry for f in feats]), strict=True))
    assert {k: len(v) for k, v in walls.items()} == {"west": 1, "middle": 3, "east": 1,
                                                     "back": 1}
    tris = {k: instance_triangles(out / f"{k}.usda") for k in walls}
    ground = {f.properties["id"]: f.geometry for f in feats}
    for a, b in (("west", "middle"), ("middle", "east")):
        seg = min(walls[a], key=lambda s: ground[b].distance(LineString([s[:2], s[2:]])))
        assert _intruding(tris[a], seg) == 0.0
        assert -0.03 <= _reach(tris[a], seg) <= -INSET + 1e-3
        both = {**{"a" + k: v for k, v in tris[a].items()},
                **{"b" + k: v for k, v in tris[b].items()}}
        assert _coplanar_roofs(both) - _coplanar_roofs(tris[a]) - \
            _coplanar_roofs(tris[b]) <= 1e-6


def test_overlapping_features_share_no_wall():
    """A shape drawn twice, or two that overlap by more than a wall digitised twice,
    share no wall (each whole outline would count, and every balcony be cut off);
    walls drawn a few centimetres into each other still do."""
    from citysynth.pipeline.city.party import party_walls

    a = box(0, 0, 30, 14)
    assert party_walls([a, box(0, 0, 30, 14)]) == [(), ()]
    assert party_walls([a, box(20, 0, 50, 14)]) == [(), ()]
    walls = party_walls([a, box(30 - TOUCH / 2, 0, 50, 14)])
    assert [len(w) for w in walls] == [1, 1]
