"""Triangles clipped to the kept side of a vertical plane, compiled.

A city cuts tens of parts a block at its joints and folds; clipping a part of about
800 triangles took a few dozen small numpy passes (0.1-0.2 ms, mostly their call
overhead). Here it is two compiled loops over the faces (count, then fill), with the
same arithmetic in the same order as the numpy version it replaced, so the pieces (and
the USD written from them) are the same to the bit: a vertex's signed distance
``(x - a c) a + (y - b c) b``, a face's side code ``9 s0 + 3 s1 + s2``, the crossing
point ``p + t (q - p)`` with ``t = dp / (dp - dq)`` clipped to [0, 1], the in-plane
faces' normals and the sliver test written out as numpy's ``cross`` computes them.
"""

from __future__ import annotations

import numpy as np
from numba import njit

ON_PLANE = 1e-8        # m: a vertex this close to a plane is on it (trimesh's tol.merge)
SLIVER = 1e-24         # squared doubled area below which a new face is dropped


def _sides() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each face's sides (0 kept, 1 on the plane, 2 cut; code 9 s0 + 3 s1 + s2):
    how many of its vertices are cut away, how many kept, and which one is alone on
    its side (the one cut away, or the one kept)."""
    sides = np.array([[c // 9, c // 3 % 3, c % 3] for c in range(27)])
    out_n, in_n = (sides == 2).sum(axis=1), (sides == 0).sum(axis=1)
    lone = np.argmax(sides == np.where(out_n == 1, 2, 0)[:, None], axis=1)
    return out_n.astype(np.int64), in_n.astype(np.int64), lone.astype(np.int64)


_OUT_N, _IN_N, _LONE = _sides()


def clip(verts: np.ndarray, faces: np.ndarray, plane: tuple[float, float, float]
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangles clipped to the kept side ``a*x + b*y <= c`` of a cut's plane, as
    trimesh's ``slice_faces_plane`` keeps them (a face lying on the plane stays when it
    faces out of the kept side), for all pieces in one pass: (vertices, faces, the input
    face each output face comes from). A face crossed by the plane keeps its winding;
    new vertices are appended (two per crossed face, in the order of the faces: first
    every face with one vertex cut away, then every face with one kept)."""
    a, b, c = (float(x) for x in plane)
    return _clip(np.ascontiguousarray(verts, dtype=np.float64),
                 np.ascontiguousarray(faces, dtype=np.int64), a, b, c,
                 _OUT_N, _IN_N, _LONE)


@njit(cache=True)
def _area2(v, i, j, k):   # pragma: no cover (compiled)
    """Twice the triangle's area, squared, as numpy computes it from ``v[f]``."""
    e1x, e1y, e1z = v[j, 0] - v[i, 0], v[j, 1] - v[i, 1], v[j, 2] - v[i, 2]
    e2x, e2y, e2z = v[k, 0] - v[i, 0], v[k, 1] - v[i, 1], v[k, 2] - v[i, 2]
    x = e1y * e2z - e1z * e2y
    y = e1z * e2x - e1x * e2z
    z = e1x * e2y - e1y * e2x
    return x * x + y * y + z * z


@njit(cache=True)
def _cross_point(verts, d, p, q, out, row):   # pragma: no cover (compiled)
    """Where edge p -> q meets the plane (d: the vertices' signed distances)."""
    dp, dq = d[p], d[q]
    den = 1.0 if dp == dq else dp - dq
    t = min(max(dp / den, 0.0), 1.0)
    for c in range(3):
        out[row, c] = verts[p, c] + t * (verts[q, c] - verts[p, c])


@njit(cache=True)
def _clip(verts, faces, a, b, c, out_n_t, in_n_t, lone_t):  # noqa: C901 (one pass, cases inline)
    # pragma: no cover (compiled)
    nv, nf = verts.shape[0], faces.shape[0]
    ac, bc = a * c, b * c
    d = np.empty(nv)
    side = np.empty(nv, dtype=np.int64)
    for i in range(nv):
        d[i] = (verts[i, 0] - ac) * a + (verts[i, 1] - bc) * b
        side[i] = 0 if d[i] < -ON_PLANE else (2 if d[i] > ON_PLANE else 1)
    # 0: dropped, 1: kept whole, 2: one vertex cut away (a quad stays), 3: one kept
    kind = np.zeros(nf, dtype=np.int64)
    lone = np.empty(nf, dtype=np.int64)
    n_keep = m1 = m2 = 0
    for f in range(nf):
        code = side[faces[f, 0]] * 9 + side[faces[f, 1]] * 3 + side[faces[f, 2]]
        out_n, in_n = out_n_t[code], in_n_t[code]
        lone[f] = lone_t[code]
        if out_n == 0:
            if in_n == 0:            # all three on the plane: kept when facing out
                i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
                e1x, e1y, e1z = verts[j, 0] - verts[i, 0], verts[j, 1] - verts[i, 1], \
                    verts[j, 2] - verts[i, 2]
                e2x, e2y, e2z = verts[k, 0] - verts[i, 0], verts[k, 1] - verts[i, 1], \
                    verts[k, 2] - verts[i, 2]
                nx = e1y * e2z - e1z * e2y
                ny = e1z * e2x - e1x * e2z
                if not nx * a + ny * b > 0:
                    continue
            kind[f] = 1
            n_keep += 1
        elif out_n == 1 and in_n >= 1:
            kind[f] = 2
            m1 += 1
        elif out_n == 2 and in_n == 1:
            kind[f] = 3
            m2 += 1
    v = np.empty((nv + 2 * m1 + 2 * m2, 3))
    v[:nv] = verts
    total = n_keep + 2 * m1 + m2
    out_f = np.empty((total, 3), dtype=np.int64)
    src = np.empty(total, dtype=np.int64)
    r = 0
    for f in range(nf):
        if kind[f] == 1:
            out_f[r, 0], out_f[r, 1], out_f[r, 2] = faces[f, 0], faces[f, 1], faces[f, 2]
            src[r] = f
            r += 1
    # a crossed face adds P_ki (on edge k -> i) and P_jk (on edge j -> k); with its one
    # vertex k cut away it keeps i, j, P_jk, P_ki as two triangles (all firsts, then all
    # seconds), with only k kept the triangle k, P_ki, P_jk (after those)
    t1 = t2 = 0
    for f in range(nf):
        if kind[f] < 2:
            continue
        k = lone[f]
        fk, fi, fj = faces[f, k], faces[f, (k + 1) % 3], faces[f, (k + 2) % 3]
        if kind[f] == 2:
            ki, jk = nv + t1, nv + m1 + t1
            r1, r2 = n_keep + t1, n_keep + m1 + t1
            out_f[r1, 0], out_f[r1, 1], out_f[r1, 2] = fi, fj, jk
            out_f[r2, 0], out_f[r2, 1], out_f[r2, 2] = fi, jk, ki
            src[r1] = src[r2] = f
            t1 += 1
        else:
            ki, jk = nv + 2 * m1 + t2, nv + 2 * m1 + m2 + t2
            r1 = n_keep + 2 * m1 + t2
            out_f[r1, 0], out_f[r1, 1], out_f[r1, 2] = fk, ki, jk
            src[r1] = f
            t2 += 1
        _cross_point(verts, d, fk, fi, v, ki)
        _cross_point(verts, d, fj, fk, v, jk)
    ok = np.empty(total, dtype=np.bool_)
    n_ok = 0
    for r in range(total):
        ok[r] = _area2(v, out_f[r, 0], out_f[r, 1], out_f[r, 2]) > SLIVER
        n_ok += ok[r]
    keep_f = np.empty((n_ok, 3), dtype=np.int64)
    keep_src = np.empty(n_ok, dtype=np.int64)
    w = 0
    for r in range(total):
        if ok[r]:
            keep_f[w] = out_f[r]
            keep_src[w] = src[r]
            w += 1
    return v, keep_f, keep_src


def split(n_verts: int, faces: np.ndarray, owner: np.ndarray, n_pieces: int
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The clipped mesh (``n_verts`` vertices, ``faces``) parted into its pieces again
    (``owner``: each face's piece), each piece's faces in their order, its vertices in
    theirs, renumbered from 0: as a boolean mask and a running count per piece made
    them (a pass over every vertex and face for each of a part's ten or so pieces), in
    one compiled pass. Returns (used, used_ends, local, face_ends): piece i's vertices
    are ``used[used_ends[i]:used_ends[i + 1]]``, its faces ``local[face_ends[i]:
    face_ends[i + 1]]``."""
    return _split(n_verts, np.ascontiguousarray(faces, dtype=np.int64),
                  np.ascontiguousarray(owner, dtype=np.int64), n_pieces)


@njit(cache=True)
def _split(n_verts, faces, owner, n_pieces):   # pragma: no cover (compiled)
    n_faces = faces.shape[0]
    face_ends = np.zeros(n_pieces + 1, dtype=np.int64)
    for f in range(n_faces):
        face_ends[owner[f] + 1] += 1
    for i in range(n_pieces):
        face_ends[i + 1] += face_ends[i]
    row = face_ends[:-1].copy()
    local = np.empty((n_faces, 3), dtype=np.int64)
    used = np.empty(n_faces * 3, dtype=np.int64)
    used_ends = np.zeros(n_pieces + 1, dtype=np.int64)
    number = np.full(n_verts, -1, dtype=np.int64)
    n_used = 0
    for i in range(n_pieces):
        for f in range(n_faces):            # mark the vertices piece i uses
            if owner[f] == i:
                for c in range(3):
                    number[faces[f, c]] = 0
        k = 0
        for v in range(n_verts):            # number them in vertex order
            if number[v] == 0:
                k += 1
                number[v] = k
                used[n_used + k - 1] = v
        for f in range(n_faces):            # its faces, in order, renumbered
            if owner[f] == i:
                for c in range(3):
                    local[row[i], c] = number[faces[f, c]] - 1
                row[i] += 1
        for j in range(n_used, n_used + k):
            number[used[j]] = -1
        n_used += k
        used_ends[i + 1] = n_used
    return used[:n_used], used_ends, local, face_ends
