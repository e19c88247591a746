"""``export.clip.clip`` (all pieces of a part clipped in one pass, each output face
knowing its input face) keeps exactly what trimesh's ``slice_faces_plane`` keeps, face
group by face group: the same area, the same oriented area (so windings agree) and the
same extent, on random meshes and planes, planes through vertices, and faces lying in
the plane; and a real part cut both ways gives the same pieces."""

from __future__ import annotations

import numpy as np
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from citysynth.export.clip import clip
from citysynth.parts_db.geometry import Piece


def _area_vector(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    t = v[f]
    return 0.5 * np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])


def _trimesh_kept(v, f, plane):
    a, b, c = plane
    kept_v, kept_f = trimesh.intersections.slice_faces_plane(
        v, f, plane_normal=np.array([-a, -b, 0.0]), plane_origin=np.array([a * c, b * c, 0.0]))[:2]
    return np.asarray(kept_v), np.asarray(kept_f, dtype=np.int64)


def _same(v, f, plane, groups):
    """clip and trimesh agree on every group of faces (clipped one group at a time by
    trimesh, all at once by clip)."""
    cv, cf, src = clip(v, f, plane)
    for g in np.unique(groups):
        tv, tf = _trimesh_kept(v, f[groups == g], plane)
        mine = cf[groups[src] == g]
        want, got = _area_vector(tv, tf), _area_vector(cv, mine)
        np.testing.assert_allclose(np.abs(np.linalg.norm(got, axis=1)).sum(),
                                   np.abs(np.linalg.norm(want, axis=1)).sum(), atol=1e-9)
        np.testing.assert_allclose(got.sum(axis=0), want.sum(axis=0), atol=1e-9)
        if len(tf):
            used = np.unique(mine)
            np.testing.assert_allclose(cv[used].min(axis=0), tv[np.unique(tf)].min(axis=0),
                                       atol=1e-9)
            np.testing.assert_allclose(cv[used].max(axis=0), tv[np.unique(tf)].max(axis=0),
                                       atol=1e-9)
        else:
            assert len(mine) == 0


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**31), angle=st.floats(0, 2 * np.pi), offset=st.floats(-1.5, 1.5),
       through_vertex=st.booleans())
def test_clip_keeps_what_trimesh_keeps(seed, angle, offset, through_vertex):
    rng = np.random.default_rng(seed)
    boxes = [trimesh.creation.box(extents=rng.uniform(0.2, 2, 3)).apply_translation(
        rng.uniform(-1, 1, 3)) for _ in range(3)]
    whole = trimesh.util.concatenate(boxes)
    v, f = np.asarray(whole.vertices, dtype=float), np.asarray(whole.faces, dtype=np.int64)
    groups = np.repeat(np.arange(3), [len(b.faces) for b in boxes])
    a, b = np.cos(angle), np.sin(angle)
    c = float(v[rng.integers(len(v)), :2] @ (a, b)) if through_vertex else offset
    _same(v, f, (a, b, c), groups)


def test_faces_in_the_plane_stay_when_they_face_out():
    box = trimesh.creation.box(extents=(2, 1, 1))       # x from -1 to 1
    v, f = np.asarray(box.vertices, dtype=float), np.asarray(box.faces, dtype=np.int64)
    groups = np.zeros(len(f), dtype=int)
    for plane in [(1.0, 0.0, 1.0), (-1.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.5)]:
        _same(v, f, plane, groups)
    _cv, cf, _src = clip(v, f, (1.0, 0.0, 1.0))          # the +x end face lies in it
    assert len(cf) == len(f)


def _numpy_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Unit face normals in plain numpy, the arithmetic the compiled version keeps."""
    t = v[f]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    n = np.cross(e1, e2)
    norm = np.sqrt((n * n).sum(axis=1))
    ok = norm > 1e-13
    n[~ok] = 0.0
    n[ok] /= norm[ok, None]
    return n


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), angle=st.floats(0, 2 * np.pi), offset=st.floats(-1.5, 1.5))
def test_cut_pieces_normals_are_numpys_to_the_bit(seed, angle, offset):
    """The compiled face normals USD writes equal numpy's to the bit on clipped meshes
    (slivers and faces of no area included, which get zero normals), and so do the
    float32 arrays written from them (points, indices, normals, extent)."""
    rng = np.random.default_rng(seed)
    whole = trimesh.util.concatenate([trimesh.creation.box(extents=rng.uniform(0.2, 2, 3))
                                      .apply_translation(rng.uniform(-1, 1, 3))
                                      for _ in range(3)])
    v, f = np.asarray(whole.vertices, dtype=float), np.asarray(whole.faces, dtype=np.int64)
    cv, cf, _src = clip(v, f, (np.cos(angle), np.sin(angle), offset))
    cf = np.concatenate([cf, [[0, 0, 1], [0, 1, 1]]])            # two faces of no area
    got = Piece("walls", (1, 2, 3, 255), cv, cf).normals
    assert got.tobytes() == _numpy_normals(cv, cf).tobytes()
    assert (got[-2:] == 0).all()
    pts, indices, normals, extent = Piece("walls", (1, 2, 3, 255), cv, cf).float32_arrays()
    assert pts.tobytes() == cv.astype(np.float32).tobytes()
    assert indices.tobytes() == cf.astype(np.int32).ravel().tobytes()
    assert normals.tobytes() == got.astype(np.float32).tobytes()
    f32 = cv.astype(np.float32)
    assert extent.tobytes() == np.stack([f32.min(axis=0), f32.max(axis=0)]).tobytes()


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.integers(1, 60), st.integers(1, 6), st.integers(0, 2**31 - 1))
def test_split_parts_the_pieces_as_a_mask_per_piece_did(n_verts, n_faces, n_pieces, seed):
    """``split`` (one compiled pass) gives each piece the faces, vertices and numbering
    the boolean mask and running count per piece gave, to the index: pieces with no
    face, vertices no face uses and vertices shared between pieces included."""
    from citysynth.export.clip import split

    rng = np.random.default_rng(seed)
    faces = rng.integers(0, n_verts, size=(n_faces, 3))
    owner = rng.integers(0, n_pieces, size=n_faces)
    used, used_ends, local, face_ends = split(n_verts, faces, owner, n_pieces)
    for i in range(n_pieces):
        kept = faces[owner == i]
        mask = np.zeros(n_verts, dtype=bool)
        mask[kept] = True
        assert np.array_equal(used[used_ends[i]:used_ends[i + 1]], np.flatnonzero(mask))
        assert np.array_equal(local[face_ends[i]:face_ends[i + 1]],
                              (np.cumsum(mask, dtype=np.int64) - 1)[kept])
