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


@njit(cache=True)
def _orient(ax, ay, bx, by, cx, cy):   # pragma: no cover (compiled)
    """The sign of the turn a -> b -> c (exact on grid integers)."""
    d = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (d > 0) - (d < 0)


@njit(cache=True)
def _on(ax, ay, bx, by, px, py):   # pragma: no cover (compiled)
    """Whether p, collinear with segment ab, lies within its box (on it)."""
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


@njit(cache=True)
def _meet(p, q, r, s):   # pragma: no cover (compiled)
    """Whether the closed segments pq and rs share any point (exact on integers)."""
    d1 = _orient(r[0], r[1], s[0], s[1], p[0], p[1])
    d2 = _orient(r[0], r[1], s[0], s[1], q[0], q[1])
    d3 = _orient(p[0], p[1], q[0], q[1], r[0], r[1])
    d4 = _orient(p[0], p[1], q[0], q[1], s[0], s[1])
    if d1 * d2 < 0 and d3 * d4 < 0:
        return True
    return ((d1 == 0 and _on(r[0], r[1], s[0], s[1], p[0], p[1]))
            or (d2 == 0 and _on(r[0], r[1], s[0], s[1], q[0], q[1]))
            or (d3 == 0 and _on(p[0], p[1], q[0], q[1], r[0], r[1]))
            or (d4 == 0 and _on(p[0], p[1], q[0], q[1], s[0], s[1])))


@njit(cache=True)
def _inside(pts, a, b, x, y):   # pragma: no cover (compiled)
    """Whether (x, y), on no edge, lies inside the closed ring pts[a:b] (even-odd)."""
    c = False
    for k in range(a, b - 1):
        x0, y0, x1, y1 = pts[k, 0], pts[k, 1], pts[k + 1, 0], pts[k + 1, 1]
        if (y0 > y) != (y1 > y):
            # x < x0 + (y - y0) (x1 - x0) / (y1 - y0), without dividing
            lhs = (x - x0) * (y1 - y0)
            rhs = (y - y0) * (x1 - x0)
            if (lhs < rhs) == (y1 > y0):
                c = not c
    return c


@njit(cache=True)
def plain_rings(pts, ends, body):   # pragma: no cover (compiled)
    """Closed rings (pts[ends[r]:ends[r + 1]], grid integers, each repeating its first
    point last; the body of each) as polygons, when they are plainly apart: no two of
    their sides share a point except a ring's consecutive sides at their common
    corner, and no ring lies inside a ring of another body (bodies are united: that
    would need the union). Returns (the rings in polygon order: each shell then its
    holes, and each polygon's first entry in that order with the total last), or two
    empty arrays when they are not plainly apart.

    In a body, a ring inside no other is a shell, one inside exactly one is that
    shell's hole, and deeper ones lie in a hole, dropped: the even-odd material that
    ``plane_section`` makes of them."""
    fail = (np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))
    if _touching(pts, ends, PAIRS_PER_SIDE * (ends[-1] + 16)):
        return fail
    # rings cross nowhere, so a ring lies in another exactly when its first point does
    nr = len(ends) - 1
    depth = np.zeros(nr, dtype=np.int64)
    outer = np.full(nr, -1, dtype=np.int64)    # a depth-1 ring's shell
    for r in range(nr):
        x, y = pts[ends[r], 0], pts[ends[r], 1]
        for o in range(nr):
            if o != r and _inside(pts, ends[o], ends[o + 1], x, y):
                if body[o] != body[r]:
                    return fail
                depth[r] += 1
                outer[r] = o
    rings = np.empty(nr, dtype=np.int64)
    poly = np.empty(nr + 1, dtype=np.int64)
    n = p = 0
    for r in range(nr):
        if depth[r] != 0:
            continue
        poly[p] = n
        p += 1
        rings[n] = r
        n += 1
        for h in range(nr):
            if depth[h] == 1 and outer[h] == r:
                rings[n] = h
                n += 1
    poly[p] = n
    return rings[:n], poly[:p + 1]


PAIRS_PER_SIDE = 64    # box-overlapping side pairs tested, a side, before giving up


@njit(cache=True)
def _touching(pts, ends, budget):   # pragma: no cover (compiled)
    """Whether any two sides of the rings share a point, other than a ring's
    consecutive sides at their common corner (there, whether they fold back over each
    other): pairwise among the sides whose boxes overlap, in a sweep along x. Past
    ``budget`` pairs it gives up and answers True (a dense section of long sides over
    one another would make the sweep quadratic; shapely's noding is not)."""
    nr = len(ends) - 1
    ns = ends[nr] - nr                         # sides: each ring repeats one point
    sx0 = np.empty(ns, dtype=np.int64)
    ring_of = np.empty(ns, dtype=np.int64)
    first = np.empty(ns, dtype=np.int64)       # the side's first point in pts
    s = 0
    for r in range(nr):
        for k in range(ends[r], ends[r + 1] - 1):
            sx0[s] = min(pts[k, 0], pts[k + 1, 0])
            ring_of[s], first[s] = r, k
            s += 1
    order = np.argsort(sx0, kind="mergesort")
    for i in range(ns):
        a = first[order[i]]
        ax1 = max(pts[a, 0], pts[a + 1, 0])
        ay0, ay1 = min(pts[a, 1], pts[a + 1, 1]), max(pts[a, 1], pts[a + 1, 1])
        for j in range(i + 1, ns):
            if sx0[order[j]] > ax1:
                break
            b = first[order[j]]
            if max(pts[b, 1], pts[b + 1, 1]) < ay0 or min(pts[b, 1], pts[b + 1, 1]) > ay1:
                continue
            budget -= 1
            if budget < 0:
                return True
            r = ring_of[order[i]]
            lo, hi = min(a, b), max(a, b)
            if r == ring_of[order[j]] and (hi == lo + 1 or (lo == ends[r]
                                                            and hi == ends[r + 1] - 2)):
                wraps = hi != lo + 1              # the last side, then the first
                if _folds_back(pts, hi if wraps else lo, lo if wraps else hi):
                    return True
            elif _meet(pts[a], pts[a + 1], pts[b], pts[b + 1]):
                return True
    return False


@njit(cache=True)
def _folds_back(pts, p, q):   # pragma: no cover (compiled)
    """Whether side q, which starts where side p ends, turns straight back over p."""
    ux, uy = pts[p, 0] - pts[q, 0], pts[p, 1] - pts[q, 1]
    vx, vy = pts[q + 1, 0] - pts[q, 0], pts[q + 1, 1] - pts[q, 1]
    return ux * vy - uy * vx == 0 and ux * vx + uy * vy > 0
