"""Mitre joints and folds in world space, and the cuts they become on each part.

Two facade runs meeting at a key point with no corner part (a *mitre joint*), or a run
bending under a part (a *fold*), meet on the vertical plane through the meeting point
that bisects their directions: its normal is the mean of the incoming and outgoing
travel directions. The module before it keeps what lies before the plane, the module
after it what lies after; each is first extended as far as the plane needs (behind a
concave joint, in front of a convex one where a cornice overhangs). So walls, cornices
and roofs meet exactly on one plane, convex or concave, at any angle.

**Acute corners.** Below :data:`ACUTE_DEG` between the two facades, a mitred convex
corner would end in a sliver of wall, sharper than any building. There the tip is cut
off square to the bisector, :data:`NOSE` metres wide, and capped: a short end wall
facing the street corner (the "nose" of a flatiron building). Nothing then reaches past
the outline. Above it, a convex mitre would still carry a cornice's overhang past the
corner by its reach over the sine of half the angle (0.2 m becomes 0.6 m at 40
degrees), so every convex mitre is also chamfered square to the bisector
:data:`CHAMFER` metres outside the corner: only the overhang is clipped, the walls
meet on the corner line.

A concave joint that sharp is only extended up to :data:`MAX_EXTEND_DEPTHS` building
depths behind the corner; what the bisector would need beyond that stays open
at the back, out of sight from the street.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.base import BaseGeometry

from citysynth.export.layout import AXIS_DIGITS, COORD_DIGITS, WHOLE, Cut, Instance

ACUTE_DEG = 40.0          # below this angle between the facades, a convex corner gets a nose
NOSE = 2.0                # m: the width of that end wall
CHAMFER = 0.25            # m: a convex mitre's overhang is clipped this far out of the corner
MAX_EXTEND_DEPTHS = 2.0   # an end is extended at most this many part depths
PLANE_DIGITS = 6          # plane normals in the part frame
SPAN_MARGIN = 0.5         # m past a part's box a solid span is kept (an overhang)
EXTEND_MARGIN = 0.01      # m beyond what the plane needs, so the cut always finds material


@dataclass(frozen=True)
class HalfPlane:
    """Keep world points X with (X - point) . normal <= 0 (a vertical plane). A part
    next to the plane (``extends``) is extended to reach it; a part further off is only
    cut where its mass reaches past it. A ``blank`` plane is a party wall: capped
    solid (see :class:`~citysynth.export.layout.Cut`) between the two world points of
    ``span`` on its line (where the neighbour stands; the whole cap without them)."""

    normal: tuple[float, float]
    point: tuple[float, float]
    extends: bool = True
    blank: bool = False
    span: tuple[tuple[float, float], tuple[float, float]] | None = None


def _rounded(x: float, y: float, digits: int) -> tuple[float, float]:
    """(x, y) rounded to ``digits`` as the layout JSON keeps them, -0.0 written 0.0
    (plain calls: a city rounds thousands of these a block)."""
    return (round(x, digits) or 0.0, round(y, digits) or 0.0)


@dataclass
class Placed:
    """A part instance before it is written: its 2D affine placement and the world
    half-planes it is cut by (none for most)."""

    part: str
    cls: str
    length: float                  # the part's length in its placement frame
    y_range: tuple[float, float]   # its extent across (placement-frame Y)
    structure: int
    stage: int | None
    key: int | None
    a: np.ndarray                  # 2x2: placement-frame XY -> layout XY
    origin: np.ndarray
    halves: list[HalfPlane] = field(default_factory=list)

    def instance(self) -> Instance:
        """The instance at the precision the layout JSON keeps (so JSON, USD and glTF
        carry the same numbers and the checks test what is written)."""
        (a00, a01), (a10, a11) = self.a.tolist()
        ox, oy = self.origin.tolist()
        return Instance(self.part, self.cls, self.structure, self.stage, self.key,
                        _rounded(a00, a10, AXIS_DIGITS), _rounded(a01, a11, AXIS_DIGITS),
                        _rounded(ox, oy, COORD_DIGITS), self.cut())

    def local_planes(self, extending: bool = False) -> list[tuple[float, float, float]]:
        """The half-planes in the part's frame: keep a*x + b*y <= c, (a, b) unit (only
        those the part is extended to, with ``extending``)."""
        return sorted({p for p, h in self._framed() if h.extends or not extending})

    def _framed(self) -> list[tuple[tuple[float, float, float], HalfPlane]]:
        """Each half-plane in the part's frame (those whose normal the placement does not
        collapse), with the half-plane it comes from (whether the part is extended to it,
        whether it is blank). Plain floats: a city places hundreds of parts a block."""
        if not self.halves:
            return []
        (a00, a01), (a10, a11) = self.a.tolist()
        ox, oy = self.origin.tolist()
        out = []
        for h in self.halves:
            nx, ny = float(h.normal[0]), float(h.normal[1])
            gx, gy = a00 * nx + a10 * ny, a01 * nx + a11 * ny      # a.T @ n
            norm = math.hypot(gx, gy)
            if norm < 1e-12:
                continue
            c = ((float(h.point[0]) - ox) * nx + (float(h.point[1]) - oy) * ny) / norm
            out.append(((round(gx / norm, PLANE_DIGITS) + 0.0,
                         round(gy / norm, PLANE_DIGITS) + 0.0,
                         round(c, PLANE_DIGITS) + 0.0), h))
        return out

    def cut(self) -> Cut | None:
        framed = self._framed()
        if not framed:
            return None
        planes = sorted({p for p, _h in framed})
        extending = sorted({p for p, h in framed if h.extends})
        extend = _extension(extending, self.length, self.y_range)
        blank = sorted({p + self._solid_span(p, h.span, extend) for p, h in framed
                        if h.blank})
        return Cut(extend, tuple(planes), tuple(blank))

    def _solid_span(self, plane: tuple[float, float, float],
                    span: tuple[tuple[float, float], tuple[float, float]] | None,
                    extend: tuple[float, float]) -> tuple[float, float]:
        """A blank plane's solid stretch (world points on its line) as the range of its
        cap's horizontal coordinate (the part-frame point's dot with (-b, a), as
        :func:`~citysynth.export.cuts._cap` lays the cap out), no further than
        :data:`SPAN_MARGIN` past the part's extended box; (-WHOLE, WHOLE) where it
        covers that box (every opening of the part lies in it), or has no ends. So the
        modules cut alike along a party wall stay one prototype."""
        if span is None:
            return (-WHOLE, WHOLE)
        (a00, a01), (a10, a11) = self.a.tolist()
        det = a00 * a11 - a01 * a10
        ux, uy = -plane[1], plane[0]
        ends = []
        for wx, wy in span:
            dx, dy = wx - float(self.origin[0]), wy - float(self.origin[1])
            qx, qy = (a11 * dx - a01 * dy) / det, (a00 * dy - a10 * dx) / det
            ends.append(qx * ux + qy * uy)
        box = [x * ux + y * uy for x in (-extend[0], self.length + extend[1])
               for y in self.y_range]
        if min(ends) <= min(box) + 1e-6 and max(ends) >= max(box) - 1e-6:
            return (-WHOLE, WHOLE)
        lo, hi = min(box) - SPAN_MARGIN, max(box) + SPAN_MARGIN
        return (round(max(min(ends), lo), COORD_DIGITS) + 0.0,
                round(min(max(ends), hi), COORD_DIGITS) + 0.0)


def facade_span(cut: Cut | None, length: float) -> tuple[float, float]:
    """The part-frame X range of a part's facade line (Y = 0) that a cut leaves."""
    if cut is None:
        return 0.0, length
    lo, hi = -cut.extend[0], length + cut.extend[1]
    for a, _b, c in cut.planes:
        if a > 1e-9:
            hi = min(hi, c / a)
        elif a < -1e-9:
            lo = max(lo, c / a)
    return lo, hi


def _extension(planes: list[tuple[float, float, float]], length: float,
               y_range: tuple[float, float]) -> tuple[float, float]:
    """How far each end must reach for every plane to find material across the part's
    whole depth (capped at MAX_EXTEND_DEPTHS depths)."""
    start = end = 0.0
    cap = MAX_EXTEND_DEPTHS * max(abs(y_range[0]), abs(y_range[1]), 1.0)
    for a, b, c in planes:
        if abs(a) < 1e-6:
            continue
        xs = [(c - b * y) / a for y in y_range]
        if a > 0:
            end = max(end, max(xs) - length)
        else:
            start = max(start, -min(xs))
    start = min(start + EXTEND_MARGIN, cap) if start > 0 else 0.0
    end = min(end + EXTEND_MARGIN, cap) if end > 0 else 0.0
    return round(start, 3), round(end, 3)


def bisector(u_in: np.ndarray, u_out: np.ndarray) -> np.ndarray:
    """The normal of the plane where a run arriving along ``u_in`` meets one leaving
    along ``u_out``: their mean direction (the plane bisects the angle)."""
    n = np.asarray(u_in, dtype=float) + np.asarray(u_out, dtype=float)
    norm = float(np.hypot(*n))
    if norm < 1e-9:   # a full reversal: the plane is square to the runs' common line
        return np.array([-u_in[1], u_in[0]])
    return n / norm


def _turn(u_in: np.ndarray, u_out: np.ndarray) -> float:
    """The signed turn, in degrees, from travel along ``u_in`` to travel along ``u_out``."""
    return math.degrees(math.atan2(u_in[0] * u_out[1] - u_in[1] * u_out[0],
                                   float(np.asarray(u_in) @ np.asarray(u_out))))


def is_convex(u_in: np.ndarray, u_out: np.ndarray, mass_left: bool) -> bool:
    """Whether a joint turns toward the mass (a street corner) rather than away from it
    (a corner the end modules are extended behind, up to the bisector)."""
    return (_turn(u_in, u_out) > 0) == mass_left


def concave_reach(p: np.ndarray, u: np.ndarray, half: HalfPlane, front: str,
                  depth: float, incoming: bool) -> BaseGeometry:
    """The ground a module at a concave joint ``p`` covers past it once extended up to
    the joint's plane ``half``: its stage's band (``depth`` deep, its stage running
    along ``u`` into p when ``incoming``, else out of it) continued past p up to the
    plane, as far as an extension goes. The band itself stops square at p and misses
    this, so a stage beyond it would not see that mass."""
    u = np.asarray(u, dtype=float)
    p = np.asarray(p, dtype=float)
    far = MAX_EXTEND_DEPTHS * max(depth, 1.0)
    line = [p, p + u * far] if incoming else [p - u * far, p]
    strip = behind(line, front, depth)
    n, q = np.asarray(half.normal, dtype=float), np.asarray(half.point, dtype=float)
    t = np.array([-n[1], n[0]])
    size = 4.0 * (far + depth)
    keep = Polygon([q + t * size, q + t * size - n * size, q - t * size - n * size,
                    q - t * size])
    return strip.intersection(keep)


def joint_halves(p: np.ndarray, u_in: np.ndarray, u_out: np.ndarray, mass_left: bool
                 ) -> tuple[list[HalfPlane], list[HalfPlane], str, float]:
    """The half-planes for the module arriving at ``p`` and the one leaving it, the
    treatment ("mitre", or "nose" for an acute convex corner), and how far back from
    ``p`` each facade then ends (0 for a mitre)."""
    n = bisector(u_in, u_out)
    before = [HalfPlane(tuple(n), tuple(p))]
    after = [HalfPlane(tuple(-n), tuple(p))]
    turn = _turn(u_in, u_out)
    convex = is_convex(u_in, u_out, mass_left)
    between = 180.0 - abs(turn)                 # the angle between the two facades
    into = -np.asarray(u_in) + np.asarray(u_out)   # the bisector, into the mass
    into = into / max(float(np.hypot(*into)), 1e-12)
    if convex and between < ACUTE_DEG:
        depth = NOSE / (2 * math.tan(math.radians(between) / 2))
        nose = HalfPlane(tuple(-into), tuple(np.asarray(p) + into * depth))
        trim = depth / float(np.asarray(u_out) @ into)
        return before + [nose], after + [nose], "nose", trim
    if convex:
        chamfer = HalfPlane(tuple(-into), tuple(np.asarray(p) - into * CHAMFER), extends=False)
        return before + [chamfer], after + [chamfer], "mitre", 0.0
    return before, after, "mitre", 0.0


def clip_convex(poly: list[tuple[float, float]], a: float, b: float, c: float
                ) -> list[tuple[float, float]]:
    """A convex polygon (its corners in order) cut to where a*x + b*y <= c, in plain
    floats: a footprint asks this of every part near each shared stretch, and a
    layout of every module as its cuts leave it, thousands of times (GEOS's
    intersection with a large square took 40 us a cut)."""
    out: list[tuple[float, float]] = []
    for i, (x0, y0) in enumerate(poly):
        x1, y1 = poly[(i + 1) % len(poly)]
        f0, f1 = a * x0 + b * y0 - c, a * x1 + b * y1 - c
        if f0 <= 0:
            out.append((x0, y0))
        if (f0 < 0 < f1) or (f1 < 0 < f0):
            k = f0 / (f0 - f1)
            out.append((x0 + (x1 - x0) * k, y0 + (y1 - y0) * k))
    return out


def clipped_plan(plan: list[tuple[float, float]], halves: Sequence[HalfPlane]
                 ) -> list[tuple[float, float]]:
    """A convex plan (its corners in order, plain floats) as ``halves`` leave it."""
    for h in halves:
        nx, ny = float(h.normal[0]), float(h.normal[1])
        plan = clip_convex(plan, nx, ny, nx * float(h.point[0]) + ny * float(h.point[1]))
    return plan


def half_polygon(n: Sequence[float] | np.ndarray, p: Sequence[float] | np.ndarray,
                 size: float) -> Polygon:
    """The plan of the half-plane (X - p) . n <= 0, as a square ``size`` across."""
    # in plain floats, the same sums in the same order as on arrays (t = (-n_y, n_x)):
    # a footprint's layout makes thousands, and small numpy arrays cost more than this
    nx, ny, px, py = float(n[0]) * size, float(n[1]) * size, float(p[0]), float(p[1])
    return shapely.polygons([(px - ny, py + nx), (px - ny - nx, py + nx - ny),
                             (px + ny - nx, py - nx - ny), (px + ny, py - nx)])


def half_polygons(n: np.ndarray, p: np.ndarray, size: np.ndarray) -> np.ndarray:
    """:func:`half_polygon` for many at once (rows of ``n`` and ``p``, ``size`` one
    each): the same four corners, built in one call."""
    along = np.stack([-n[:, 1], n[:, 0]], axis=1) * size[:, None]
    past = n * size[:, None]
    return shapely.polygons(np.stack([p + along, p + along - past, p - along - past,
                                      p - along], axis=1))


def behind(points: Any, front: str, depth: float) -> BaseGeometry:
    """The ground behind a facade polyline, ``depth`` deep, mitred at its bends (the
    mass lies left of travel where the facades face right). A polyline that ends where
    it starts (a stage round a whole ring: a round block's one seam) is buffered as two
    halves sharing its middle segment, since GEOS buffers a closed line on one side
    wrongly (the ring's inside filled, or the wrong side)."""
    side = depth if front == "right" else -depth
    pts = [tuple(p) for p in points]
    halves = [pts]
    if len(pts) >= 4 and pts[0] == pts[-1]:
        m = len(pts) // 2
        halves = [pts[:m + 1], pts[m - 1:]]
    return shapely.union_all([LineString(h).buffer(side, single_sided=True, cap_style="flat",
                                                   join_style="mitre") for h in halves])

