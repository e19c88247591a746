"""The sample library the generator writes (into a temporary folder, not the shipped
one): the transition costs decide (many non-zero, many distinct values per style), the
massing varies (heights, T parts, corners, end parts per family), every part is clean
(closed bodies that neither overlap nor double a face), every counted window can be
seen, and each kind of piece keeps its own material through ``part_pieces``."""

from __future__ import annotations

from itertools import islice
from pathlib import Path

import numpy as np
import pytest
import shapely
import trimesh

from citysynth.parts_db import PartDB, ingest
from citysynth.parts_db.costs import GROUPS
from citysynth.parts_db.geometry import part_pieces
from citysynth.parts_db.sample import generate, key_parts, middle_parts
from citysynth.parts_db.sample_styles import CLASSIC, MODERN

STYLES = ("classic", "modern")
# What two parts of one profile cost side by side: their own small deviations
# (sample.JITTER, about 0.01 m2 per mm); a step between variants of a family is tens of m2
FITS = 1.0


@pytest.fixture(scope="module")
def library(tmp_path_factory) -> tuple[Path, PartDB]:
    out = tmp_path_factory.mktemp("samplelib")
    generate(out)
    return out, ingest(out, tmp_path_factory.mktemp("samplelib_db"))


def facade(db: PartDB, style: str) -> list[int]:
    return [i for i, p in enumerate(db.parts) if p.style == style and GROUPS[p.cls] == "facade"]


def scene_mesh(path: Path) -> tuple[trimesh.Trimesh, list[tuple[str, np.ndarray]]]:
    """A part's GLB as one mesh in its own frame (nodes placed), vertices merged, and
    each window node's placed triangles."""
    scene = trimesh.load(str(path), process=False)
    tris, windows = [], []
    for node in sorted(scene.graph.nodes_geometry):
        transform, geom = scene.graph[node]
        g = scene.geometry[geom]
        t = trimesh.transform_points(g.vertices, transform)[g.faces]
        tris.append(t)
        if str(node).startswith("window"):
            windows.append((str(node), t))
    allt = np.concatenate(tris)
    mesh = trimesh.Trimesh(allt.reshape(-1, 3), np.arange(len(allt) * 3).reshape(-1, 3))
    mesh.merge_vertices()
    return mesh, windows


# --- the costs decide ---------------------------------------------------------------------

@pytest.mark.parametrize("style", STYLES)
def test_transition_costs_vary_within_each_style(library, style):
    _, db = library
    idx = facade(db, style)
    allowed = db.allowed[np.ix_(idx, idx)]
    costs = db.cost[np.ix_(idx, idx)][allowed]
    assert allowed.sum() > 1000
    assert (costs > 0).mean() >= 0.6
    assert len(np.unique(costs)) >= 20
    # the same section on both sides of a joint is free
    assert (costs == 0).any()


@pytest.mark.parametrize("style", STYLES)
def test_massing_varies(library, style):
    _, db = library
    parts = [db.parts[i] for i in facade(db, style)]
    mids = [p for p in parts if p.cls == "middle"]
    assert len({round(p.height) for p in mids}) >= 3          # visible heights
    ts = [p for p in parts if p.cls == "t_junction"]
    plain = [t for t in ts if not t.id.endswith("_door")]
    assert len(plain) >= 2
    index = db.index()
    for t in ts:             # a T with an entrance: its plain twin's section, a door more
        if t.id.endswith("_door"):
            twin = db.parts[index[t.id.removesuffix("_door")]]
            assert shapely.symmetric_difference(t.sec_in, twin.sec_in).area < 1e-6
            assert t.attributes.get("doors", 0) == twin.attributes.get("doors", 0) + 1
    sections = [t.sec_in for t in plain]
    assert all(shapely.symmetric_difference(a, b).area > 5.0
               for k, a in enumerate(sections) for b in sections[k + 1:])
    corners = {(p.angle, p.convex) for p in parts if p.cls == "corner"}
    angles = {a for a, _ in corners}
    assert len(angles) >= 3 and all((a, c) in corners for a in angles for c in (True, False))
    # every family (an end part's profile) has its end parts, T part and corners, and
    # every T is continued by some middle part on each of its legs: at no more than the
    # parts' own small deviations cost (sample.JITTER), far below a variant step
    ends = [index[p.id] for p in parts if p.cls == "end_left"]
    assert len(ends) >= 3
    for e in ends:
        for cls in ("end_right", "t_junction", "corner"):
            assert min(db.cost[e, index[p.id]] for p in parts if p.cls == cls) < FITS, \
                (db.parts[e].id, cls)
    for t in ts:
        i = index[t.id]
        for table in (db.cost, db.cost_branch):
            assert min(table[i, index[p.id]] for p in mids) < FITS, t.id


def outline(part) -> shapely.Geometry:
    """Where a part may stand: its facade lines with the mass side behind them (a
    corner's two legs as one line round the key point, mitred; a T's main range and
    wing), the street side of every facade outside."""
    ends = [(dx * leg, dy * leg) for (dx, dy), leg in zip(part.directions, part.legs,
                                                          strict=True)]
    if part.cls == "corner":
        lines = [[ends[0], (0.0, 0.0), ends[1]]]
    else:                          # T: the main range from -X to +X, the wing along +Y
        lines = [[ends[0], ends[1]], [(0.0, 0.0), ends[2]]]
    return shapely.union_all([shapely.LineString(p).buffer(40.0, single_sided=True,
                                                           cap_style="flat",
                                                           join_style="mitre")
                              for p in lines])


def test_nothing_reaches_far_past_the_facade_lines(library):
    """Cornices and balconies stay within the audit's 0.3 m of a building's outline,
    also where a cornice turns round a convex corner."""
    root, db = library
    for part in db.parts:
        if GROUPS[part.cls] != "facade":
            continue
        mesh, _ = scene_mesh(root / part.file)
        pts = mesh.vertices
        if part.cls in ("middle", "end_left", "end_right"):
            reach = float(-pts[:, 1].min())
        else:
            reach = float(shapely.distance(outline(part), shapely.points(pts[:, :2])).max())
        assert reach <= 0.3 + 1e-4, (part.id, reach)


# --- clean solids -----------------------------------------------------------------------------

def crossing_errors(tris: np.ndarray, axis: int, h: float = 0.3) -> int:
    """Lines parallel to ``axis`` on an h-grid (offset off every round coordinate) must
    enter and leave the part alternately: two bodies overlapping, a body crossing
    itself, a doubled face or one wound the wrong way all show as two entries or two
    exits in a row. Faces that touch (one body's exit where the next one's entry is)
    are fine. Returns the number of grid lines that break the rule."""
    a, b = (axis + 1) % 3, (axis + 2) % 3
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    keep = np.abs(n[:, axis]) > 1e-9
    tris, n = tris[keep], n[keep]
    p = tris[:, :, [a, b]]
    g0 = p.reshape(-1, 2).min(axis=0) - np.array([0.01371, 0.02913])
    lo = np.ceil((p.min(axis=1) - g0) / h - 0.5).astype(int)
    hi = np.floor((p.max(axis=1) - g0) / h - 0.5).astype(int)
    ni, nj = np.maximum(hi - lo + 1, 0).T
    count = ni * nj
    tri = np.repeat(np.arange(len(tris)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    ci = lo[tri, 0] + k // np.maximum(nj[tri], 1)
    cj = lo[tri, 1] + k % np.maximum(nj[tri], 1)
    q = g0 + (np.stack([ci, cj], axis=1) + 0.5) * h
    v0 = p[tri, 0]
    e1, e2, w = p[tri, 1] - v0, p[tri, 2] - v0, q - v0

    def det(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return x[:, 0] * y[:, 1] - x[:, 1] * y[:, 0]

    d = det(e1, e2)
    l1, l2 = det(w, e2) / d, det(e1, w) / d
    inside = (l1 > 0) & (l2 > 0) & (l1 + l2 < 1)
    tri, ci, cj, l1, l2 = tri[inside], ci[inside], cj[inside], l1[inside], l2[inside]
    z = tris[tri, 0, axis] + l1 * (tris[tri, 1, axis] - tris[tri, 0, axis]) \
        + l2 * (tris[tri, 2, axis] - tris[tri, 0, axis])
    sign = np.where(n[tri, axis] > 0, 1, -1)              # +1 leaves, -1 enters
    cell = ci.astype(np.int64) * 1_000_003 + cj
    # crossings at one point (a line grazing an edge, two bodies touching) cancel out
    keys, inverse = np.unique(np.stack([cell, np.round(z / 1e-5).astype(np.int64)], axis=1),
                              axis=0, return_inverse=True)
    net = np.bincount(inverse.reshape(-1), weights=sign, minlength=len(keys)).astype(int)
    doubled = len(np.unique(keys[np.abs(net) > 1, 0]))
    keys, net = keys[net != 0], net[net != 0]                # sorted by cell, then z
    cell, leaves = keys[:, 0], net > 0
    starts = np.r_[0, np.nonzero(np.diff(cell))[0] + 1]
    sizes = np.diff(np.r_[starts, len(cell)])
    rank = np.arange(len(cell)) - np.repeat(starts, sizes)
    bad = leaves != (rank % 2 == 1)
    return doubled + len(np.unique(cell[bad])) + int((sizes % 2 == 1).sum())


def unpaired_edges(faces: np.ndarray) -> int:
    """Directed edges without exactly one partner running the other way: zero when every
    body is closed, consistently wound and no edge is shared by more than two faces."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    uniq, counts = np.unique(directed, axis=0, return_counts=True)
    twins = np.unique(np.concatenate([uniq, uniq[:, ::-1]]), axis=0, return_counts=True)[1]
    return int((counts != 1).sum() + (twins != 2).sum())


def body_volumes(mesh: trimesh.Trimesh) -> np.ndarray:
    """The signed volume of each connected body (positive when its faces point out)."""
    labels = trimesh.graph.connected_component_labels(mesh.face_adjacency,
                                                      node_count=len(mesh.faces))
    t = mesh.triangles
    six = np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2]))
    return np.bincount(labels, weights=six) / 6.0


def test_every_part_is_closed_bodies_that_do_not_overlap(library):
    root, db = library
    for part in db.parts:
        mesh, _ = scene_mesh(root / part.file)
        assert unpaired_edges(mesh.faces) == 0, part.id
        assert (body_volumes(mesh) > 1e-6).all(), part.id
        tris = mesh.triangles
        for axis in range(3):
            assert crossing_errors(tris, axis) == 0, (part.id, axis)


def test_a_corner_made_of_two_overlapping_boxes_fails_the_check():
    a = trimesh.creation.box(bounds=[[-10, 0, 0], [0, 11, 14]])
    b = trimesh.creation.box(bounds=[[-11, 0, 0], [0, 16, 14]])
    both = np.concatenate([a.triangles, b.triangles])
    assert crossing_errors(both, 2) > 0 and crossing_errors(a.triangles, 2) == 0
    flipped = a.faces.copy()
    flipped[0] = flipped[0, ::-1]
    assert unpaired_edges(flipped) > 0 and unpaired_edges(a.faces) == 0


# --- windows that count are windows that show --------------------------------------------------

def _blocked(origins: np.ndarray, dirs: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Whether each ray (origin, direction) hits any triangle (Moller-Trumbore, a few
    dozen rays against all triangles at once)."""
    e1 = tris[:, 1] - tris[:, 0]
    e2 = tris[:, 2] - tris[:, 0]
    out = np.zeros(len(origins), dtype=bool)
    for s in range(0, len(origins), 32):
        o, d = origins[s:s + 32, None, :], dirs[s:s + 32, None, :]
        pv = np.cross(d, e2[None])
        det = np.einsum("rtk,tk->rt", pv, e1)
        ok = np.abs(det) > 1e-12
        inv = 1.0 / np.where(ok, det, 1.0)
        tv = o - tris[None, :, 0]
        u = np.einsum("rtk,rtk->rt", tv, pv) * inv
        qv = np.cross(tv, e1[None])
        v = np.einsum("rtk,rk->rt", qv, d[:, 0]) * inv
        t = np.einsum("rtk,tk->rt", qv, e2) * inv
        out[s:s + 32] = (ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)).any(axis=1)
    return out


def _pane_normal(pts: np.ndarray) -> np.ndarray:
    """The horizontal direction in which a pane is thinnest (either way)."""
    _, _, vt = np.linalg.svd(pts[:, :2] - pts[:, :2].mean(axis=0), full_matrices=False)
    return np.array([vt[-1][0], vt[-1][1], 0.0]) / np.linalg.norm(vt[-1])


def _directions(normal: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(direction, the side of the pane it leaves from): either way along the facade
    normal, then tilted up and to the sides."""
    up = np.array([0.0, 0.0, 1.0])
    side = np.cross(up, normal)
    out = []
    for lift in (0.0, 0.6, 1.5, 4.0):
        for turn in (0.0, 1.0, -1.0, 3.0, -3.0):
            for sign in (1.0, -1.0):
                d = sign * normal + turn * side + lift * up
                out.append((d / np.linalg.norm(d), sign * normal))
    return out


def visible_windows(path: Path) -> tuple[int, int]:
    """(window nodes, those from which some ray leaves the part unobstructed): rays
    start just off the pane and try the directions of :func:`_directions` in turn."""
    mesh, windows = scene_mesh(path)
    tris = mesh.triangles
    todo = []
    for _name, t in windows:
        pts = t.reshape(-1, 3)
        todo.append((pts.mean(axis=0), _directions(_pane_normal(pts))))
    seen = np.zeros(len(todo), dtype=bool)
    for k in range(len(_directions(np.array([1.0, 0.0, 0.0])))):
        open_ = np.nonzero(~seen)[0]
        if len(open_) == 0:
            break
        dirs = np.array([todo[i][1][k][0] for i in open_])
        # start 3 cm off the pane (its half-thickness is 2 cm) on the ray's side
        off = np.array([todo[i][1][k][1] for i in open_])
        origins = np.array([todo[i][0] for i in open_]) + 0.03 * off
        seen[open_] = ~_blocked(origins, dirs, tris)
    return len(windows), int(seen.sum())


def test_counted_windows_are_the_visible_ones(library):
    """Every window node is counted, and in the parts where one body could hide
    another's windows (corners, T parts, an end wall's, behind balconies) every one can
    be seen."""
    root, db = library
    risky = [p for p in db.parts if p.cls in ("corner", "t_junction")]
    risky += db.select("end_left")[:2]
    risky += [p for p in db.select("middle") if p.attributes.get("balconies")][:3]
    for part in db.parts:
        nodes = trimesh.load(str(root / part.file)).graph.nodes_geometry
        assert part.attributes.get("windows", 0) == sum(str(n).startswith("window")
                                                        for n in nodes), part.id
    for part in risky:
        n, seen = visible_windows(root / part.file)
        assert n > 0 and seen == n, (part.id, n - seen)


def test_corners_have_windows_on_both_street_faces_and_the_courtyard(library):
    root, db = library
    for part in db.select("corner"):
        mesh, windows = scene_mesh(root / part.file)
        legs = [np.array([*d, 0.0]) for d in part.directions]
        front = {0: 0, 1: 0}
        back = 0
        for _n, t in windows:
            c = t.reshape(-1, 3).mean(axis=0)
            leg = int(np.argmax([c @ d for d in legs]))
            offset = c @ np.array([legs[leg][1], -legs[leg][0], 0.0])  # out of the facade
            if offset > -1.0:
                front[leg] += 1
            else:
                back += 1
        assert min(front.values()) >= 4 and back >= 4, part.id


# --- materials ----------------------------------------------------------------------------

def test_each_kind_of_piece_keeps_its_material(library):
    _, db = library
    for style in STYLES:
        kinds: dict[str, set] = {}
        for part in [db.parts[i] for i in facade(db, style)]:
            for piece in part_pieces(db, part):
                kinds.setdefault(piece.name, set()).add(piece.rgba)
        assert {"walls", "trim", "roof", "window", "door", "balcony"} <= set(kinds)
        for a in kinds:
            for b in kinds:
                if a < b:
                    assert not kinds[a] & kinds[b], (style, a, b)
    t = db.select("t_junction", "classic")[0]
    names = [p.name for p in part_pieces(db, t)]
    assert {"walls", "trim", "roof", "window"} <= set(names)


# --- size and determinism ------------------------------------------------------------------

def test_size_and_contents(library):
    root, db = library
    size = sum(f.stat().st_size for f in (root / "meshes").iterdir())
    assert size < 10e6
    assert len(db.select("building")) >= 70 and len(db.select("floor")) >= 10
    for style in STYLES:
        assert len(db.select("middle", style)) >= 30


def test_generation_is_deterministic():
    for style in (CLASSIC, MODERN):
        first = [(e.id, e.mesh.glb()) for e in islice(middle_parts(style), 4)]
        again = [(e.id, e.mesh.glb()) for e in islice(middle_parts(style), 4)]
        assert first == again
    a = next(key_parts(CLASSIC))
    b = next(key_parts(CLASSIC))
    assert a.id == b.id and a.mesh.glb() == b.mesh.glb()
