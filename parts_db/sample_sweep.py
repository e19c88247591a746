"""Facade parts as profiles swept along their legs, closed as single solids.

* **Straight parts** are a run of slices along +X, each one profile. Where two profiles
  meet, the part of each section the other does not cover becomes an exposed face (a
  fire wall above a lower neighbour, the end of a deeper range); faces on either side
  share every vertex of the joint (both outlines are split at each other's vertices and
  crossings), so the solid stays closed.
* **Corners** sweep one profile along both legs and meet on the bisector plane (a
  mitre): hips on the outside, valleys inside, cornices and parapets running round.
* **T parts** sweep the main range straight through and the wing (the same profile,
  along +Y, its facade facing +X) from a V-shaped cut: two vertical planes through the
  valleys where the wing's roof meets the main roof. Because profiles are symmetric
  about the middle of their depth, the main range's courtyard half and the wing agree
  on both planes, so the T is one closed solid too.

Walls get windows where their band says (:mod:`parts_db.sample_profiles`): each window
is a hole in its face with a recess (reveals and a back) and a glass pane set inside,
clear of every other face; doors likewise with a door leaf; a balcony is a slab with a
railing in front of a French window. Windows are only placed where the face (and its
recess) is outside every neighbouring body, so every counted window can be seen.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from citysynth.parts_db.sample_mesh import PartMesh, Solid, unit
from citysynth.parts_db.sample_profiles import Band, Profile

GRID = 1e-6
UP = np.array([0.0, 0.0, 1.0])
# Ingest cuts a part's end sections 5 mm inside its ends. A plain strip of side faces
# there (two triangles per outline edge, the same in every part) makes the cut of two
# parts with one profile the very same polygon, so ingest compares each pair of
# profiles once instead of each pair of parts, however their walls are triangulated.
END_STRIP = 0.01


# --- legs and openings --------------------------------------------------------------------

@dataclass(frozen=True)
class Leg:
    """A straight run of a profile: travel direction ``d``; the facade's outward normal
    is to the right of travel. ``at(s, u, v)`` is the point s along the run, u out of the
    facade, v up."""

    d: tuple[float, float]

    @property
    def dir3(self) -> np.ndarray:
        return np.array([self.d[0], self.d[1], 0.0])

    @property
    def normal3(self) -> np.ndarray:
        return np.array([self.d[1], -self.d[0], 0.0])

    def at(self, s: float, u: float, v: float) -> np.ndarray:
        return s * self.dir3 + u * self.normal3 + v * UP


X_LEG = Leg((1.0, 0.0))


def face_normal(leg: Leg, p: Sequence[float], q: Sequence[float]) -> np.ndarray:
    """Outward normal of the face swept along ``leg`` from profile edge p -> q (the
    outline is counter-clockwise in (u, v), so outward is the edge's right side)."""
    du, dv = q[0] - p[0], q[1] - p[1]
    return unit(dv * leg.normal3 - du * UP)


@dataclass(frozen=True)
class Windows:
    """How a style opens its walls."""

    bay: float          # target bay width along a facade
    width: float        # window width
    depth: float        # reveal depth
    door: float = 1.5   # door width
    pier: float = 0.45  # least wall beside a window
    margin: float = 0.55   # least wall between a window and its face's end
    gable: bool = True  # windows in the gable walls of end parts


@dataclass(frozen=True)
class Opening:
    kind: str           # window | door | french (a window to a balcony)
    s0: float
    s1: float
    z0: float
    z1: float
    floor: float        # the storey's floor (a balcony's slab)


def bay_centres(s0: float, s1: float, bay: float) -> tuple[list[float], float]:
    """Centres of the bays that divide s0..s1 evenly, and the bay width."""
    n = max(1, round((s1 - s0) / bay))
    w = (s1 - s0) / n
    return [s0 + (k + 0.5) * w for k in range(n)], w


def openings(band: Band, centres: Sequence[float], bay_w: float, win: Windows, *,
             doors: frozenset[int] = frozenset(),
             balconies: frozenset[int] = frozenset()) -> list[Opening]:
    """The openings of one band: a window per bay centre, a door in the ground floor's
    ``doors`` bays, French windows (with balconies) in an upper floor's ``balconies``."""
    ww = min(win.width, bay_w - 2 * win.pier)
    out: list[Opening] = []
    if ww < 0.5:
        return out
    front = band.side == "front"
    for k, c in enumerate(centres):
        if front and band.storey == 0 and k in doors:
            dw = min(win.door, bay_w - 2 * win.pier)
            out.append(Opening("door", c - dw / 2, c + dw / 2, band.z0 + 0.15,
                               min(band.z0 + 2.8, band.z1 - 0.35), band.z0))
        elif front and band.storey > 0 and k in balconies:
            out.append(Opening("french", c - ww / 2, c + ww / 2, band.z0 + 0.25, band.head,
                               band.z0))
        else:
            out.append(Opening("window", c - ww / 2, c + ww / 2, band.sill, band.head,
                               band.z0))
    return out


def fitting(ops: list[Opening], lo: float, hi: float) -> list[Opening]:
    """The openings that lie inside lo..hi."""
    return [o for o in ops if o.s0 >= lo - 1e-9 and o.s1 <= hi + 1e-9]


def cut_wall(pm: PartMesh, solid: Solid, outline: Sequence, normal: np.ndarray, leg: Leg,
             u: float, ops: Sequence[Opening], win: Windows, material: str = "walls") -> None:
    """A wall face (``outline`` in 3D) at profile offset ``u`` along ``leg``, with its
    openings cut as recesses and filled with panes, door leaves and balconies."""
    holes = []
    for o in ops:
        holes.append([leg.at(o.s0, u, o.z0), leg.at(o.s1, u, o.z0), leg.at(o.s1, u, o.z1),
                      leg.at(o.s0, u, o.z1)])
    solid.polygon(outline, normal, material, holes)
    for o, corners in zip(ops, holes, strict=True):
        recess(pm, solid, corners, normal, win.depth, o)


def recess(pm: PartMesh, solid: Solid, corners: list[np.ndarray], normal: np.ndarray,
           depth: float, o: Opening) -> None:
    """Reveals and back of an opening (corners counter-clockwise seen from outside:
    bottom left, bottom right, top right, top left), and what fills it."""
    inward = -unit(normal)
    back = [c + depth * inward for c in corners]
    centre = sum(corners) / 4
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        solid.quad([a, b, back[(k + 1) % 4], back[k]], centre - (a + b) / 2, "trim")
    solid.quad(back, normal, "trim")   # behind the pane: shares the reveals' corners
    along = unit(corners[1] - corners[0])
    up = unit(corners[3] - corners[0])
    w = float(np.linalg.norm(corners[1] - corners[0]))
    h = float(np.linalg.norm(corners[3] - corners[0]))
    centre = corners[0] + along * w / 2 + up * h / 2
    if o.kind == "door":
        pm.placed("door", centre + (0.45 * depth + 0.03) * inward, along, up,
                  (w - 0.02, h - 0.02, 0.06))
        return
    pm.placed("window", centre + (0.4 * depth + 0.02) * inward, along, up,
              (w - 0.02, h - 0.02, 0.04))
    if o.kind == "french":
        balcony(pm, corners[0] - (o.z0 - o.floor) * up, along, -inward, w)


def balcony(pm: PartMesh, base: np.ndarray, along: np.ndarray, out: np.ndarray,
            width: float) -> None:
    """A French balcony before a French window: a slab on the floor line, 0.28 m deep
    (within the profiles' reach past the facade), with a railing set 3 cm in from its
    edges: one closed body (the slab's top has the railing's footprint cut), stored
    once per width and placed by its node."""
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = along, out, UP, base
    if float(np.linalg.det(m[:3, :3])) < 0:     # keep the placement a rotation
        m[:3, 0], m[:3, 3] = -along, base + width * along
    pm.instance("balcony", f"balcony_{width:.3f}", m, lambda: _balcony_body(width))


BALCONY_DEPTH = 0.28


def _balcony_body(width: float) -> Solid:
    d = BALCONY_DEPTH
    slab = Polygon([(-0.15, 0.0), (width + 0.15, 0.0), (width + 0.15, d), (-0.15, d)])
    outer = shapely.box(-0.12, 0.03, width + 0.12, d - 0.03)
    rail = outer.difference(shapely.box(-0.08, -1.0, width + 0.08, d - 0.07))
    body = Solid()
    frame = (np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), UP.copy())
    stack(body, [(0.0, 0.12, slab), (0.12, 1.0, rail)], frame, lambda _k, _e: "balcony")
    return body


# --- joints between sections ---------------------------------------------------------------

def _points_on(p: np.ndarray, q: np.ndarray, pool: np.ndarray) -> list[np.ndarray]:
    """Pool points strictly inside segment p-q, ordered from p to q."""
    if len(pool) == 0:
        return []
    d = q - p
    ll = float(d @ d)
    if ll == 0:
        return []
    t = ((pool - p) @ d) / ll
    foot = p + t[:, None] * d
    dist = np.linalg.norm(pool - foot, axis=1)
    hit = (dist < 2 * GRID) & (t > 1e-9) & (t < 1 - 1e-9)
    order = np.argsort(t[hit], kind="stable")
    return list(pool[hit][order])


def _pool(a: Polygon, b: Polygon) -> np.ndarray:
    """Every vertex of either outline and every point where they cross or touch."""
    noded = shapely.union(a.boundary, b.boundary, grid_size=GRID)
    pts = shapely.get_coordinates(noded)
    return np.unique(np.round(pts, 9), axis=0)


def _snap(ring: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """Ring vertices moved onto the pool point they stand for (computed twice by GEOS
    they may differ in the last bits)."""
    if len(pool) == 0:
        return ring
    d = np.linalg.norm(ring[:, None, :] - pool[None, :, :], axis=2)
    j = d.argmin(axis=1)
    if float(d[np.arange(len(ring)), j].max()) > 4 * GRID:
        raise ValueError("a joint face has a vertex that neither section has")
    return pool[j]


def _refine(ring: np.ndarray, pool: np.ndarray) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    n = len(ring)
    for i in range(n):
        p, q = ring[i], ring[(i + 1) % n]
        out.append(p)
        out.extend(_points_on(p, q, pool))
    return out


def _rings(poly) -> list[np.ndarray]:
    """The rings of a polygon (exterior counter-clockwise, holes clockwise)."""
    poly = shapely.geometry.polygon.orient(poly, 1.0)
    return [np.asarray(poly.exterior.coords)[:-1]] + \
        [np.asarray(r.coords)[:-1] for r in poly.interiors]


def _all_rings(geom) -> list[list[np.ndarray]]:
    """Per polygon of a (multi)polygon: its rings."""
    return [_rings(p) for p in shapely.get_parts(geom) if not p.is_empty]


Frame = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]   # origin, e1, e2, axis


def _to3d(frame: Frame, pts: Sequence | np.ndarray, t: float) -> list[np.ndarray]:
    o, e1, e2, ax = frame
    return [o + float(p[0]) * e1 + float(p[1]) * e2 + t * ax for p in pts]


def joint_faces(solid: Solid, a: Polygon, b: Polygon, frame: Frame, t: float,
                pool: np.ndarray, materials: tuple[str, str]) -> None:
    """Where slice a (below t along the axis) meets slice b (above): a's section minus
    b's faces +axis, b's minus a's faces -axis; outlines split at every pool point.
    The two must not touch along a line: the solid would have an edge of four faces
    there (two string courses meeting corner to corner, say), so that is refused."""
    a_only = shapely.difference(a, b, grid_size=GRID)
    b_only = shapely.difference(b, a, grid_size=GRID)
    if shapely.intersection(a_only.boundary, b_only.boundary).length > 1e-6:
        raise ValueError("two sections meet corner to corner along a line at a joint; "
                         "move one of their features")
    for region, sign, material in ((a_only, 1.0, materials[0]), (b_only, -1.0, materials[1])):
        for part in shapely.get_parts(region):
            if part.is_empty or part.area < 1e-9 or part.geom_type != "Polygon":
                continue
            rings = [_refine(_snap(r, pool), pool) for r in _rings(part)]
            solid.polygon(_to3d(frame, rings[0], t), sign * frame[3], material,
                          [_to3d(frame, r, t) for r in rings[1:]])


SideFn = Callable[[int, int, list[np.ndarray], np.ndarray], None]


def stack(solid: Solid, layers: Sequence[tuple[float, float, Polygon]], frame: Frame,
          material: Callable[[int, int], str], side: SideFn | None = None,
          cap: Callable[[int, list[np.ndarray], list[list[np.ndarray]], np.ndarray], None]
          | None = None, strip: float = 0.0) -> None:
    """A solid of consecutive slices along the frame's axis, each slice a polygon of the
    frame's (e1, e2) plane, closed by end caps and joint faces.

    ``material(k, e)`` names the material of slice k's side face on outline edge e (its
    exterior ring first, then holes); ``side(k, e, outline, normal)`` may build that face
    instead (to cut windows); ``cap(end, outer, holes, normal)`` may build an end cap
    (end 0 or 1) instead of a plain polygon. With ``strip``, every side face keeps a
    plain strip that wide at both ends (see :data:`END_STRIP`)."""
    n = len(layers)
    pools = [np.zeros((0, 2))] + [_pool(layers[k - 1][2], layers[k][2]) for k in range(1, n)] \
        + [np.zeros((0, 2))]
    for k, (t0, t1, poly) in enumerate(layers):
        a0 = t0 + strip if k == 0 else t0
        a1 = t1 - strip if k == n - 1 else t1
        e = 0
        for ring in [r for rings in _all_rings(poly) for r in rings]:
            m = len(ring)
            for i in range(m):
                p, q = ring[i], ring[(i + 1) % m]
                lo = [p, *_points_on(p, q, pools[k]), q]
                hi = [q, *_points_on(q, p, pools[k + 1]), p]
                outline = _to3d(frame, lo, a0) + _to3d(frame, hi, a1)
                dp = q - p
                normal = unit(dp[1] * frame[1] - dp[0] * frame[2])
                for b0, b1 in ((t0, a0), (a1, t1)):
                    if b1 > b0:
                        solid.quad(_to3d(frame, [p, q], b0) + _to3d(frame, [q, p], b1), normal,
                                   material(k, e))
                if side is not None:
                    side(k, e, outline, normal)
                else:
                    solid.polygon(outline, normal, material(k, e))
                e += 1
    for end, (poly, t) in enumerate(((layers[0][2], layers[0][0]),
                                     (layers[-1][2], layers[-1][1]))):
        normal = frame[3] * (1.0 if end else -1.0)
        for flat in _all_rings(poly):
            rings = [_to3d(frame, r, t) for r in flat]
            if cap is not None:
                cap(end, rings[0], rings[1:], normal)
            else:
                solid.polygon(rings[0], normal, material(0 if end == 0 else n - 1, -1),
                              rings[1:])
    for k in range(1, n):
        joint_faces(solid, layers[k - 1][2], layers[k][2], frame, layers[k][0], pools[k],
                    (material(k - 1, -1), material(k, -1)))


# --- straight parts ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Slice:
    """One profile from x0 to x1 along a straight part, with its doors and balconies
    (bay indices of the slice's front)."""

    x0: float
    x1: float
    profile: Profile
    doors: frozenset[int] = frozenset()
    balconies: frozenset[tuple[int, int]] = frozenset()    # (storey, bay)


STRAIGHT: Frame = (np.zeros(3), np.array([0.0, -1.0, 0.0]), UP.copy(), np.array([1.0, 0.0, 0.0]))


def straight(pm: PartMesh, slices: Sequence[Slice], win: Windows, *,
             gables: tuple[bool, bool] = (False, False)) -> None:
    """A straight part from its slices: walls with windows on both sides of every
    slice, and gable windows at an open end (``gables``: start, end)."""
    solid = pm.solid()
    layers = [(s.x0, s.x1, s.profile.polygon()) for s in slices]

    def side(k: int, e: int, outline: list[np.ndarray], normal: np.ndarray) -> None:
        sl = slices[k]
        prof = sl.profile
        band = prof.bands[e] if e < len(prof.bands) else None
        mat = prof.materials[e] if e < len(prof.materials) else prof.wall
        if band is None:
            solid.polygon(outline, normal, mat)
            return
        u = prof.points[e][0]
        centres, bw = bay_centres(sl.x0, sl.x1, win.bay)
        balc = frozenset(b for st, b in sl.balconies if st == band.storey)
        ops = openings(band, centres, bw, win, doors=sl.doors, balconies=balc)
        ops = fitting(ops, sl.x0 + win.pier, sl.x1 - win.pier)
        cut_wall(pm, solid, outline, normal, X_LEG, u, ops, win, mat)

    def cap(end: int, outer: list[np.ndarray], holes: list, normal: np.ndarray) -> None:
        prof = slices[-1 if end else 0].profile
        x = slices[-1].x1 if end else slices[0].x0
        if gables[end] and win.gable:
            gable_wall(pm, solid, prof, x, normal, win, outer)
        else:
            solid.polygon(outer, normal, prof.wall)

    def material(k: int, e: int) -> str:
        prof = slices[k].profile
        return prof.materials[e] if 0 <= e < len(prof.materials) else prof.wall

    stack(solid, layers, STRAIGHT, material, side, cap, strip=END_STRIP)


def gable_wall(pm: PartMesh, solid: Solid, prof: Profile, x: float, normal: np.ndarray,
               win: Windows, outer: list[np.ndarray]) -> None:
    """An end wall with two windows per storey, set symmetrically in the depth."""
    out = float(normal[0])
    holes, ops = [], []
    for band in prof.bands:
        if band is None or band.side != "front":
            continue
        for frac in (0.3, 0.7):
            uc = -prof.depth * frac
            w = min(win.width, 1.2)
            # corners counter-clockwise seen from outside (looking along -normal)
            u0, u1 = (uc - w / 2, uc + w / 2) if out > 0 else (uc + w / 2, uc - w / 2)
            pts = [np.array([x, -u0, band.sill]), np.array([x, -u1, band.sill]),
                   np.array([x, -u1, band.head]), np.array([x, -u0, band.head])]
            holes.append(pts)
            ops.append(Opening("window", 0, 0, band.sill, band.head, band.z0))
    solid.polygon(outer, normal, prof.wall, holes)
    for corners, o in zip(holes, ops, strict=True):
        recess(pm, solid, corners, normal, win.depth, o)


def profile_cap(solid: Solid, leg: Leg, prof: Profile, s: float, normal: np.ndarray) -> None:
    solid.polygon([leg.at(s, u, v) for u, v in prof.points], normal, prof.wall)


# --- corners ------------------------------------------------------------------------------

def _mitre(leg_in: Leg, leg_out: Leg, u: float) -> np.ndarray:
    """Where the offset-u lines of the two legs meet (2D)."""
    n1 = np.array(leg_in.normal3[:2])
    n2 = np.array(leg_out.normal3[:2])
    return u * (n1 + n2) / (1.0 + float(n1 @ n2))


def _band_range(lo_fn: Callable[[float], float], hi_fn: Callable[[float], float], u: float,
                inward: float, win: Windows) -> tuple[float, float]:
    """The stretch of a wall at offset u where a window and its reveal (reaching
    ``inward`` toward the middle of the depth) stay clear of the face's ends."""
    back = u + inward
    return (max(lo_fn(u), lo_fn(back)) + win.margin, min(hi_fn(u), hi_fn(back)) - win.margin)


def _leg_faces(pm: PartMesh, solid: Solid, leg: Leg, prof: Profile, start: list[np.ndarray],
               end: list[np.ndarray], lo_fn, hi_fn, win: Windows, strips: Strips) -> None:
    """The side faces of a leg from per-vertex start points to end points (3D), with
    windows on every band between ``lo_fn(u)`` and ``hi_fn(u)`` (s along the leg)."""
    for i, j in prof.edges():
        _edge_face(pm, solid, leg, prof, i, j, [start[i], end[i]], [start[j], end[j]],
                   lo_fn, hi_fn, win, strips=strips)


def corner(pm: PartMesh, prof: Profile, angle: float, convex: bool, leg_len: float,
           win: Windows) -> None:
    """A corner: the in-leg along -X to the key point at the origin, the out-leg turned
    left (convex) or right (concave) by 180 - angle, mitred on the bisector."""
    turn = np.radians((180.0 - angle) * (1 if convex else -1))
    leg_in = X_LEG
    leg_out = Leg((float(np.cos(turn)), float(np.sin(turn))))
    solid = pm.solid()
    mitre = [np.array([*_mitre(leg_in, leg_out, u), v]) for u, v in prof.points]
    far_in = [leg_in.at(-leg_len, u, v) for u, v in prof.points]
    far_out = [leg_out.at(leg_len, u, v) for u, v in prof.points]

    def s_in(u: float) -> float:
        return float(_mitre(leg_in, leg_out, u) @ np.array(leg_in.d))

    def s_out(u: float) -> float:
        return float(_mitre(leg_in, leg_out, u) @ np.array(leg_out.d))

    _leg_faces(pm, solid, leg_in, prof, far_in, mitre, lambda _u: -leg_len, s_in, win,
               (END_STRIP * leg_in.dir3, None))
    _leg_faces(pm, solid, leg_out, prof, mitre, far_out, s_out, lambda _u: leg_len, win,
               (None, -END_STRIP * leg_out.dir3))
    profile_cap(solid, leg_in, prof, -leg_len, -leg_in.dir3)
    profile_cap(solid, leg_out, prof, leg_len, leg_out.dir3)


# --- T parts ------------------------------------------------------------------------------

def t_part(pm: PartMesh, prof: Profile, main_len: float, wing_len: float,
           win: Windows, doors: frozenset[int] = frozenset()) -> None:
    """A T: the main range along X from -main_len to +main_len, the wing along +Y from
    the V-shaped cut under its valleys to wing_len, its facade facing +X."""
    D = prof.depth
    uc = prof.centre
    wing = Leg((0.0, 1.0))
    solid = pm.solid()
    pts = prof.points
    back = [u < uc - 1e-9 for u, _v in pts]
    mid = [abs(u - uc) <= 1e-9 for u, _v in pts]
    apex_x = uc
    left_end = [X_LEG.at(u if back[i] else -main_len, u, v) for i, (u, v) in enumerate(pts)]
    right_start = [X_LEG.at(-u - D if back[i] else -main_len, u, v) for i, (u, v) in
                   enumerate(pts)]
    start = [X_LEG.at(-main_len, u, v) for u, v in pts]
    end = [X_LEG.at(main_len, u, v) for u, v in pts]
    apex = {i: [X_LEG.at(apex_x, u, v)] for i, (u, v) in enumerate(pts) if mid[i]}
    dx = END_STRIP * X_LEG.dir3

    def main_lo(_u: float) -> float:
        return -main_len

    def main_hi(_u: float) -> float:
        return main_len

    # the street half: straight through, split only where the wing's ridge starts
    for i, j in prof.edges():
        if back[i] or back[j]:
            continue
        _edge_face(pm, solid, X_LEG, prof, i, j, [start[i], *apex.get(i, []), end[i]],
                   [start[j], *apex.get(j, []), end[j]], main_lo, main_hi, win, doors,
                   (dx, -dx))
    # the courtyard half: left of the wing and right of it
    for i, j in prof.edges():
        if not (back[i] or back[j]):
            continue
        li = [start[i], apex[i][0] if mid[i] else left_end[i]]
        lj = [start[j], apex[j][0] if mid[j] else left_end[j]]
        _edge_face(pm, solid, X_LEG, prof, i, j, li, lj, main_lo, lambda u: u, win,
                   strips=(dx, None))
        ri = [apex[i][0] if mid[i] else right_start[i], end[i]]
        rj = [apex[j][0] if mid[j] else right_start[j], end[j]]
        _edge_face(pm, solid, X_LEG, prof, i, j, ri, rj, lambda u: -u - D, main_hi, win,
                   strips=(None, -dx))
    # the wing, from the V cut (shared points) to its end
    w_start = [left_end[i] if back[i] else (apex[i][0] if mid[i] else
                                            _mirror_point(right_start, pts, i, D))
               for i in range(len(pts))]
    w_end = [wing.at(wing_len, u, v) for u, v in pts]

    def wing_lo(u: float) -> float:
        return D + u if u >= uc else -u

    _leg_faces(pm, solid, wing, prof, w_start, w_end, wing_lo, lambda _u: wing_len, win,
               (None, -END_STRIP * wing.dir3))
    profile_cap(solid, X_LEG, prof, -main_len, -X_LEG.dir3)
    profile_cap(solid, X_LEG, prof, main_len, X_LEG.dir3)
    profile_cap(solid, wing, prof, wing_len, wing.dir3)


def _mirror_point(right_start: list[np.ndarray], pts, i: int, D: float) -> np.ndarray:
    """The wing's street-half vertex i starts where the main range's courtyard vertex
    that mirrors it (u -> -D - u, same v) leaves the right-hand cut."""
    u, v = pts[i]
    for k, (uk, vk) in enumerate(pts):
        if abs(uk - (-D - u)) < 1e-7 and abs(vk - v) < 1e-7:
            return right_start[k]
    raise ValueError("profile is not symmetric about the middle of its depth")


Strips = tuple[np.ndarray | None, np.ndarray | None]


def _edge_face(pm: PartMesh, solid: Solid, leg: Leg, prof: Profile, i: int, j: int,
               chain_i: list[np.ndarray], chain_j: list[np.ndarray], lo_fn, hi_fn,
               win: Windows, doors: frozenset[int] = frozenset(),
               strips: Strips = (None, None)) -> None:
    """One side face between the lines of vertices i and j (chains from start to end),
    with a plain strip at a leg's open end (``strips``: the step into the leg from the
    chains' first and last points, or None; see :data:`END_STRIP`)."""
    p, q = prof.points[i], prof.points[j]
    normal = face_normal(leg, p, q)
    chain_i, chain_j = list(chain_i), list(chain_j)
    for end, step in ((0, strips[0]), (-1, strips[1])):
        if step is not None:
            a, b = chain_i[end], chain_j[end]
            solid.quad([a, b, b + step, a + step], normal, prof.materials[i])
            chain_i[end], chain_j[end] = a + step, b + step
    outline = [*chain_i, *reversed(chain_j)]
    band = prof.bands[i]
    if band is None:
        solid.polygon(outline, normal, prof.materials[i])
        return
    inward = -win.depth if p[0] > prof.centre else win.depth
    lo, hi = _band_range(lo_fn, hi_fn, p[0], inward, win)
    ops: list[Opening] = []
    if hi - lo > 1.0:
        centres, bw = bay_centres(lo, hi, win.bay)
        ops = fitting(openings(band, centres, bw, win, doors=doors), lo, hi)
    cut_wall(pm, solid, outline, normal, leg, p[0], ops, win, prof.materials[i])
