"""Part prototypes cut for mitre joints and folds.

Where two facade runs meet at an angle no corner part fits, or where a run bends under
a part, the modules meeting there are cut along the joint's bisector plane and the cut
is capped, so walls, cornices and roofs meet exactly, convex or concave, at any angle.
A :class:`~citysynth.export.layout.Cut` says how, in the part's own placement frame:

1. **Extend.** Where the bisector plane lies beyond a part's end (behind a concave
   corner, or in front of a convex one, where a cornice overhangs), the part's end is
   first extended by stretching a thin band at that end (:data:`BAND` wide): a wall or
   cornice face that runs to the end runs on, with its profile, and nothing else moves.
2. **Cut.** Every face is clipped to the kept side of each plane (:func:`clip`, which
   keeps what trimesh's ``slice_faces_plane`` keeps, all pieces in one pass), each
   face staying in its piece, so each keeps its material.
3. **Cap.** The part's solid cross-section on each plane (the even-odd section of its
   bodies, as ingest measures sections; taken from the section's segments chained
   into loops where they chain simply, the same polygons without noding them) is
   triangulated and added to the walls piece, facing out of the cut, so the cut part
   is closed again.

The cut pieces of a (part, cut) pair are computed once per process and, being plain
prototypes, are instanced by USD and glTF like any part.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import shapely
import trimesh
from shapely.geometry import box

from citysynth.export.layout import Cut
from citysynth.parts_db import Part, PartDB
from citysynth.parts_db.geometry import Piece, part_pieces
from citysynth.parts_db.sections import body_labels, loop_section, plane_section

BAND = 0.02            # m at each end of a part: what an extension stretches
CACHED_CUTS = 1024     # cut prototypes kept per process (a building has tens)
_CACHE: OrderedDict[tuple[str, str, Cut], tuple[Piece, ...]] = OrderedDict()
_LABELS: dict[tuple[str, str], np.ndarray] = {}
CAP_PIECE = "walls"    # the material a cap takes (else the part's first piece's)


def cut_pieces(db: PartDB, part: Part, cut: Cut) -> tuple[Piece, ...]:
    """The pieces of ``part`` extended, cut and capped as ``cut`` says (cached: the k
    layouts of a building mostly cut the same joints; a cut is seldom met again in
    another building, so only the last :data:`CACHED_CUTS` are kept, and a worker
    building thousands of blocks does not hold every cut it ever made)."""
    key = (db.library_hash, part.id, cut)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    pieces = part_pieces(db, part)
    labels = _LABELS.get(key[:2])
    if labels is None:   # which body each face belongs to: the same for every cut
        labels = _LABELS[key[:2]] = _body_labels(pieces)
    out = _CACHE[key] = _cut(pieces, length(part), cut, labels)
    if len(_CACHE) > CACHED_CUTS:
        _CACHE.popitem(last=False)
    return out


def _body_labels(pieces: tuple[Piece, ...]) -> np.ndarray:
    """The closed body each face of the part belongs to, as ingest sees it: on the
    vertex-merged mesh (the pieces repeat a vertex where two materials meet, so on the
    pieces as given a closed body falls apart into open patches, whose sections are
    dropped, and the cut was left uncapped)."""
    whole = _whole(pieces, [p.vertices for p in pieces])
    whole.merge_vertices()
    return body_labels(whole)


def length(part: Part) -> float:
    """A straight part's length along X in its placement frame."""
    return float(part.legs_measured[0] * part.scale)


def extend(v: np.ndarray, length: float, ext: tuple[float, float]) -> np.ndarray:
    """Vertices with each end of the part moved out by ext[0] (start, -X) and ext[1]
    (end, +X), stretching only the band of :data:`BAND` at that end."""
    v = v.copy()
    x = v[:, 0]
    band = min(BAND, length / 4)
    if ext[1] > 0:
        at = x > length - band
        x[at] = (length - band) + (x[at] - (length - band)) * (band + ext[1]) / band
    if ext[0] > 0:
        at = x < band
        x[at] = band - (band - x[at]) * (band + ext[0]) / band
    return v


def _whole(pieces: tuple[Piece, ...], vertices: list[np.ndarray]) -> trimesh.Trimesh:
    """All pieces as one mesh (vertices given per piece, e.g. extended)."""
    return trimesh.Trimesh(*_joined(pieces, vertices), process=False)


def _joined(pieces: tuple[Piece, ...], vertices: list[np.ndarray]
            ) -> tuple[np.ndarray, np.ndarray]:
    """All pieces' vertices and faces as one mesh's arrays (no trimesh object: a cut
    only needs one where its cap falls back to plane_section)."""
    return (np.concatenate(vertices),
            np.concatenate(_offset_faces([p.faces for p in pieces], [len(v) for v in vertices])))


def _cut(pieces: tuple[Piece, ...], length_: float, cut: Cut,
         labels: np.ndarray) -> tuple[Piece, ...]:
    vertices = [extend(p.vertices, length_, cut.extend) for p in pieces]
    whole_v, whole_f = _joined(pieces, vertices)
    verts, faces = whole_v, whole_f
    owner = np.repeat(np.arange(len(pieces)), [len(p.faces) for p in pieces])
    for plane in cut.planes:
        verts, faces, source = clip(verts, faces, plane)
        owner = owner[source]
    out: list[Piece] = []
    for i, piece in enumerate(pieces):
        kept = faces[owner == i]
        if len(kept):
            used = np.zeros(len(verts), dtype=bool)    # the vertices it uses, renumbered
            used[kept] = True
            out.append(Piece(piece.name, piece.rgba, verts[used],
                             (np.cumsum(used, dtype=np.int64) - 1)[kept]))
    caps = [c for c in (_cap(whole_v, whole_f, plane, cut.planes, labels)
                        for plane in cut.planes) if c is not None]
    if not caps:
        return tuple(out)
    return _with_caps(out, pieces, caps)


ON_PLANE = 1e-8        # m: a vertex this close to a plane is on it (trimesh's tol.merge)


def clip(verts: np.ndarray, faces: np.ndarray, plane: tuple[float, float, float]
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangles clipped to the kept side of a cut's plane, as trimesh's
    ``slice_faces_plane`` keeps them (a face lying on the plane stays when it faces out
    of the kept side), for all pieces in one pass: (vertices, faces, the input face
    each output face comes from). A face crossed by the plane keeps its winding; new
    vertices are appended."""
    a, b, c = plane
    # the plane through (a c, b c) with normal (a, b), as the caps take it ((a, b) is
    # rounded, so a*x + b*y = c would sit up to c * 1e-6 away from them)
    d = (verts[:, 0] - a * c) * a + (verts[:, 1] - b * c) * b   # > 0: the side cut away
    side = np.ones(len(verts), dtype=np.int64)          # 0 kept, 1 on the plane, 2 cut
    side[d < -ON_PLANE] = 0
    side[d > ON_PLANE] = 2
    code = side[faces] @ _CODE
    out_n, in_n, lone = _OUT_N[code], _IN_N[code], _LONE[code]
    keep = out_n == 0
    flat = keep & (in_n == 0)                           # all three on the plane
    if flat.any():
        tri = verts[faces[flat]]
        nz = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        keep[np.flatnonzero(flat)] = nz[:, 0] * a + nz[:, 1] * b > 0
    one_out = (out_n == 1) & (in_n >= 1)                # a quad stays (or a triangle)
    two_out = (out_n == 2) & (in_n == 1)                # a triangle stays
    new_v, new_f, new_src = [verts], [faces[keep]], [np.flatnonzero(keep)]
    n = len(verts)
    for rows, pick in ((np.flatnonzero(one_out), 1), (np.flatnonzero(two_out), -1)):
        if not len(rows):
            continue
        # rotate each face so the lone vertex (outside, or inside) comes first
        k = lone[rows]
        f = faces[rows]
        idx = np.arange(len(rows))
        fk, fi, fj = f[idx, k], f[idx, (k + 1) % 3], f[idx, (k + 2) % 3]
        p_ki = _cross_point(verts, d, fk, fi)            # on edge k -> i
        p_jk = _cross_point(verts, d, fj, fk)            # on edge j -> k
        m = len(rows)
        ki, jk = n + np.arange(m), n + m + np.arange(m)
        new_v += [p_ki, p_jk]
        n += 2 * m
        if pick == 1:          # k cut away: i, j, P_jk, P_ki (two triangles)
            tris = np.concatenate([np.stack([fi, fj, jk], 1), np.stack([fi, jk, ki], 1)])
            src = np.concatenate([rows, rows])
        else:                  # only k kept: k, P_ki, P_jk
            tris, src = np.stack([fk, ki, jk], 1), rows
        new_f.append(tris)
        new_src.append(src)
    v = np.concatenate(new_v)
    f = np.concatenate(new_f).astype(np.int64)
    src = np.concatenate(new_src)
    ok = _area2(v[f]) > 1e-24                            # no slivers where a vertex was on it
    return v, f[ok], src[ok]


def _sides() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each face's sides (0 kept, 1 on the plane, 2 cut; code 9 s0 + 3 s1 + s2):
    how many of its vertices are cut away, how many kept, and which one is alone on
    its side (the one cut away, or the one kept)."""
    sides = np.array([[c // 9, c // 3 % 3, c % 3] for c in range(27)])
    out_n, in_n = (sides == 2).sum(axis=1), (sides == 0).sum(axis=1)
    lone = np.argmax(sides == np.where(out_n == 1, 2, 0)[:, None], axis=1)
    return out_n, in_n, lone


_CODE = np.array([9, 3, 1])
_OUT_N, _IN_N, _LONE = _sides()


def _area2(t: np.ndarray) -> np.ndarray:
    """Twice each triangle's area, squared (t: [m, 3, 3]); the sums of ``np.cross``,
    written out: numpy's cross costs more in its axis handling than in arithmetic."""
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    x = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
    y = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
    z = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    return x * x + y * y + z * z


def _cross_point(verts: np.ndarray, d: np.ndarray, p: np.ndarray, q: np.ndarray
                 ) -> np.ndarray:
    """Where each edge p -> q meets the plane (d: signed distances of the vertices)."""
    dp, dq = d[p], d[q]
    t = np.clip(dp / np.where(dp == dq, 1.0, dp - dq), 0.0, 1.0)
    return verts[p] + t[:, None] * (verts[q] - verts[p])


def _offset_faces(faces: list[np.ndarray], counts: list[int]) -> list[np.ndarray]:
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
    return [f + o for f, o in zip(faces, offsets, strict=True)]


def _cap(mesh_v: np.ndarray, mesh_f: np.ndarray, plane: tuple[float, float, float],
         planes: tuple[tuple[float, float, float], ...], labels: np.ndarray
         ) -> tuple[np.ndarray, np.ndarray] | None:
    """The triangulated cross-section of the part (its extended mesh: mesh_v, mesh_f)
    on ``plane`` (within the other planes), facing out of the kept side: (vertices,
    faces), or None when empty. The section is ingest's :func:`plane_section`, taken
    by :func:`loop_section` where the segments chain simply (the same polygons, without
    noding them: that was most of a cut's time)."""
    a, b, c = plane
    origin = np.array([a * c, b * c, 0.0])
    normal = np.array([a, b, 0.0])
    u = np.array([-b, a, 0.0])                 # horizontal, in the plane
    w = np.array([0.0, 0.0, 1.0])
    section = loop_section(mesh_v, mesh_f, labels, origin, normal, u, w)
    if section is None:
        whole = trimesh.Trimesh(mesh_v, mesh_f, process=False)
        section = plane_section(whole, origin, normal, u, w, labels)
    for a2, b2, c2 in planes:                  # the other planes bound it along u
        if (a2, b2, c2) == plane:
            continue
        k = a2 * -b + b2 * a                   # (a2, b2) . u
        base = a2 * origin[0] + b2 * origin[1]
        if abs(k) < 1e-9:
            continue
        limit = (c2 - base) / k
        half = box(-1e6, -1e6, limit, 1e6) if k > 0 else box(limit, -1e6, 1e6, 1e6)
        section = section.intersection(half)
    polys = [g for g in shapely.get_parts(section) if g.geom_type == "Polygon" and g.area > 1e-8]
    if not polys:
        return None
    verts, faces = [], []
    n = 0
    for poly in polys:
        v2, f = trimesh.creation.triangulate_polygon(poly)
        v3 = origin + np.outer(v2[:, 0], u) + np.outer(v2[:, 1], w)
        tri = v3[f]
        facing = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]) @ normal
        f = np.where((facing < 0)[:, None], f[:, ::-1], f)   # out of the kept side
        verts.append(v3)
        faces.append(f + n)
        n += len(v3)
    return np.concatenate(verts), np.concatenate(faces)


def _with_caps(out: list[Piece], original: tuple[Piece, ...],
               caps: list[tuple[np.ndarray, np.ndarray]]) -> tuple[Piece, ...]:
    """The caps joined to the walls piece (or, failing one, added as the first piece's
    material)."""
    cv = np.concatenate([v for v, _f in caps])
    offsets = np.concatenate([[0], np.cumsum([len(v) for v, _f in caps])[:-1]])
    cf = np.concatenate([f + o for (_v, f), o in zip(caps, offsets, strict=True)])
    for i, p in enumerate(out):
        if p.name == CAP_PIECE:
            out[i] = Piece(p.name, p.rgba, np.concatenate([p.vertices, cv]),
                           np.concatenate([p.faces, cf + len(p.vertices)]))
            return tuple(out)
    ref = next((p for p in original if p.name == CAP_PIECE), original[0])
    return (*out, Piece(ref.name, ref.rgba, cv, cf))
