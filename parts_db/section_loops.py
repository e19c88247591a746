"""The compiled half of :func:`~citysynth.parts_db.sections.loop_section`: a mesh's
segments on a plane, snapped to the grid, paired end to end and chained into walks.

A city takes a section for every cut plane at its joints, tens a block, on parts of
about 800 triangles; done as two dozen numpy passes (and a Python walk over the
segments) this was most of a cap's time, nearly all of it call overhead. The numbers
are those of the numpy version: the same cases as trimesh's ``mesh_plane``, each end
``p + t (q - p)`` projected on the plane's axes and snapped to the grid as GEOS snaps
(half up), the ends keyed by (body, y, x) and sorted stably, the walks in the same
order (open chains from their free ends, in slot order, then closed loops from their
lowest segment).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def snap(x: float) -> float:   # pragma: no cover (compiled)
    """x rounded as GEOS rounds to a grid (half up, Java's Math.round: the integer r
    with r - x in (-0.5, 0.5]); x + 0.5 can round up across an integer, then undone."""
    r = np.floor(x + 0.5)
    if r - x > 0.5:
        r -= 1.0
    return r


@njit(cache=True)
def segments(vertices, faces, labels, dots, origin, u, v, merge, scale,
             case, turn, ends_from, ends_to):   # pragma: no cover (compiled)
    """The plane's segments as snapped grid ends [S, 2, 2] (int64) and the body of
    each, collapsed segments dropped (``dots``: the vertices' signed distances)."""
    nf = faces.shape[0]
    code = np.empty(nf, dtype=np.int64)
    n_hit = 0
    for f in range(nf):
        c = 0
        for k in range(3):
            dk = dots[faces[f, k]]
            c = c * 3 + (0 if dk < -merge else (2 if dk > merge else 1))
        code[f] = c
        n_hit += case[c]
    grid = np.empty((n_hit, 2, 2), dtype=np.int64)
    lab = np.empty(n_hit, dtype=np.int64)
    s = 0
    for f in range(nf):
        c = code[f]
        if not case[c]:
            continue
        for e in range(2):
            p = faces[f, turn[c, ends_from[c, e]]]
            q = faces[f, turn[c, ends_to[c, e]]]
            dp = dots[p]
            den = dp - dots[q]
            t = dp / den if den != 0 else 0.0
            r0 = vertices[p, 0] + t * (vertices[q, 0] - vertices[p, 0]) - origin[0]
            r1 = vertices[p, 1] + t * (vertices[q, 1] - vertices[p, 1]) - origin[1]
            r2 = vertices[p, 2] + t * (vertices[q, 2] - vertices[p, 2]) - origin[2]
            grid[s, e, 0] = np.int64(snap((r0 * u[0] + r1 * u[1] + r2 * u[2]) * scale))
            grid[s, e, 1] = np.int64(snap((r0 * v[0] + r1 * v[1] + r2 * v[2]) * scale))
        if grid[s, 0, 0] != grid[s, 1, 0] or grid[s, 0, 1] != grid[s, 1, 1]:
            lab[s] = labels[f]
            s += 1
    return grid[:s], lab[:s]


@njit(cache=True)
def chain(key):   # pragma: no cover (compiled)
    """Segment ends (slots 2i, 2i + 1 of segment i, keyed by their snapped point and
    body) chained into walks: (the slots of every walk concatenated, each walk's start
    in that array with the total last, and whether each is closed: its first slot then
    repeated last), or an empty start array when three ends or more share a point."""
    n = key.shape[0]
    order = np.argsort(key, kind="mergesort")
    partner = np.full(n, -1, dtype=np.int64)
    i = 0
    while i < n - 1:
        if key[order[i]] == key[order[i + 1]]:
            if i + 2 < n and key[order[i + 2]] == key[order[i]]:
                return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64), \
                    np.empty(0, dtype=np.bool_)
            partner[order[i]], partner[order[i + 1]] = order[i + 1], order[i]
            i += 2
        else:
            i += 1
    m = n // 2
    seen = np.zeros(m, dtype=np.bool_)
    slots = np.empty(n + m, dtype=np.int64)       # each ring repeats its first slot
    starts = np.empty(m + 1, dtype=np.int64)
    closed = np.empty(m, dtype=np.bool_)
    w = n_walks = 0
    for slot0 in range(n):                         # open chains, from their free ends
        if partner[slot0] >= 0 or seen[slot0 >> 1]:
            continue
        starts[n_walks], closed[n_walks] = w, False
        n_walks += 1
        slot = slot0
        slots[w] = slot
        w += 1
        while slot >= 0:
            seen[slot >> 1] = True
            slot ^= 1
            slots[w] = slot
            w += 1
            slot = partner[slot]
    for seg in range(m):                           # closed loops
        if seen[seg]:
            continue
        starts[n_walks], closed[n_walks] = w, True
        n_walks += 1
        slot = 2 * seg
        first = slot
        while not seen[slot >> 1]:
            seen[slot >> 1] = True
            slots[w] = slot
            w += 1
            slot = partner[slot ^ 1]
        slots[w] = first
        w += 1
    starts[n_walks] = w
    return slots[:w], starts[:n_walks + 1], closed[:n_walks]
