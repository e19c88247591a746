"""Turn input geometry into skeletons: building skeleton lines, footprint and block
polygons, and street centre lines (polygonised into blocks).

Key points get their class from degree and angle: one edge is an end, two edges a
corner of the angle between them (convex when the facade turns around the building
mass), or a bend when they are within ``straight_tol`` degrees of straight, three
edges a T junction (the two most nearly collinear edges form the main line). Bad
geometry is refused with a message naming the feature and the place.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal, cast

import networkx as nx
import numpy as np
import shapely
from shapely.geometry import LinearRing, LineString, MultiLineString, MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.validation import explain_validity

from citysynth.skeletons.errors import SkeletonError
from citysynth.skeletons.geojson import Feature, Frame, angle_between, format_xy, side_words
from citysynth.skeletons.model import (
    FRONTS,
    Edge,
    Front,
    KeyPoint,
    KeyPointKind,
    Skeleton,
    flip,
)
from citysynth.skeletons.streets import street_blocks
from citysynth.solver.safe_read import first_few, shown

SAID_PIECES = 3   # pieces of a disconnected skeleton a message names
SNAP = 0.01            # metres: endpoints closer than this are the same key point
STRAIGHT_TOL = 15.0    # degrees: a smaller turn is a bend, not a corner
DENSE = 0.02           # metres: an outline simplified within this (dense CAD or GIS curves)


def _constraints(props: dict[str, Any], where: str) -> dict[str, tuple[float, float]]:
    c = props.get("constraints", {}) or {}
    if not isinstance(c, dict):
        raise SkeletonError(f"{where}: constraints must be an object like "
                            '{"doors": [1, 2]}')
    out = {}
    for k, v in c.items():
        problem = interval_problem(v, "facade")
        if problem:
            raise SkeletonError(f"{where}: constraint {k} {problem}")
        out[str(k)] = (float(v[0]), float(v[1]))
    return out


MAX_MINIMUM = 1e9   # doors, windows ... at the least on one side or building: past any


def interval_problem(v: Any, whole: str) -> str | None:
    """What is wrong with an asked interval ``v`` (``[min, max]``, finite, 0 <= min <=
    max, a minimum some ``whole``, a facade or a block, can have), or None: the one rule
    for constraints in GeoJSON and intervals in city.toml."""
    if (not isinstance(v, list | tuple) or len(v) != 2
            or not all(isinstance(x, int | float) and not isinstance(x, bool)
                       and math.isfinite(x) for x in v)
            or v[0] > v[1] or v[0] < 0):
        return f"must be [min, max] with finite numbers, 0 <= min <= max, got {shown(v)}"
    if v[0] > MAX_MINIMUM:
        return (f"asks for at least {v[0]:g}, more than any {whole} has (at most "
                f"{MAX_MINIMUM:g}); check the value")
    return None


def _front(props: dict[str, Any], where: str) -> Front:
    f = props.get("front", "right")
    if f not in FRONTS:
        raise SkeletonError(f'{where}: front must be "left" or "right" (of the line '
                            f"direction), got {shown(f)}")
    return cast(Front, f)


def _classify(ids: Iterable[int], xy: dict[int, np.ndarray], g: nx.Graph, edges: list[Edge],
              straight_tol: float, where: Callable[[int], str],
              named: Callable[[Edge], str] = lambda e: e.source) -> list[KeyPoint]:
    kps = []
    for v in ids:
        nbrs = list(g.neighbors(v))
        d = len(nbrs)
        p = (float(xy[v][0]), float(xy[v][1]))
        if d == 1:
            kps.append(KeyPoint(v, p, "end", 1))
        elif d == 2:
            e_in = edges[g[nbrs[0]][v]["index"]]
            e_out = edges[g[v][nbrs[1]]["index"]]
            # traverse nbrs[0] -> v -> nbrs[1]; fronts as seen along that traversal
            f_in = e_in.front if e_in.b == v else flip(e_in.front)
            f_out = e_out.front if e_out.a == v else flip(e_out.front)
            if f_in != f_out:
                raise SkeletonError(opposite_fronts(where(v), e_out, v, named))
            turn = angle_between(xy[v] - xy[nbrs[0]], xy[nbrs[1]] - xy[v])
            convex = turn > 0 if f_in == "right" else turn < 0
            kind: KeyPointKind = "bend" if abs(turn) < straight_tol else "corner"
            kps.append(KeyPoint(v, p, kind, 2, angle=180.0 - abs(turn), convex=convex,
                                turn=turn))
        elif d == 3:
            dirs = [(xy[u] - xy[v]) / np.linalg.norm(xy[u] - xy[v]) for u in nbrs]
            pairs = [(0, 1, 2), (0, 2, 1), (1, 2, 0)]
            i, j, k = min(pairs, key=lambda t: float(dirs[t[0]] @ dirs[t[1]]))
            kps.append(KeyPoint(v, p, "t_junction", 3, branch=g[v][nbrs[k]]["index"]))
        else:
            raise SkeletonError(f"{where(v)}: {d} edges meet here; a key point joins at most "
                                "3 (end, corner, T); split the junction into two T junctions")
    return kps


def _nearest_gap(parts: list[set[int]], edges: list[Edge], xy: dict[int, np.ndarray],
                 frame: Frame) -> str:
    """How far the largest piece of a disconnected skeleton lies from the nearest other,
    and where: a wing drawn to end 2 cm short of its main line reads as two buildings."""
    def piece(c: set[int]) -> BaseGeometry:
        return shapely.MultiLineString([[xy[e.a], xy[e.b]] for e in edges if e.a in c])

    rest = shapely.union_all([piece(c) for c in parts[1:]])
    gap = shapely.shortest_line(piece(parts[0]), rest)
    a, b = np.asarray(gap.coords)
    d = float(np.hypot(*(b - a)))
    far = f"{d * 1000:.0f} mm" if d < 0.1 else f"{d * 100:.0f} cm" if d < 1 else f"{d:,.1f} m"
    return f"the largest lies {far} from the nearest other at {frame.at(a)}"


def opposite_fronts(where: str, e: Edge, v: int, named: Callable[[Edge], str] = lambda e: e.source,
                    what: str = "the lines meeting here") -> str:
    """The message for two lines that put their facades on opposite sides of the point
    where they meet, with the fix on the second: the front is a side of the way a line
    is drawn, so two lines drawn toward each other with the same front face opposite
    ways (the message said "give both edges the same front" when they had it)."""
    towards = "toward" if e.b == v else "away from"
    return (f"{where}: {what} put their facades on opposite sides; a "
            f"line's facades face the {e.front} of the way it is drawn (its \"front\"), "
            f"and {named(e) or 'the second'} is drawn {towards} this point: reverse it, or "
            f'give it "front": "{flip(e.front)}"')


class _Nodes:
    """Key points by position: a point within :data:`SNAP` of one seen (on SNAP's
    grid) is that key point; called with a point, its key point's index; ``xy``: each
    index's position, as first seen."""

    def __init__(self) -> None:
        self.keys: dict[tuple[int, int], int] = {}
        self.xy: dict[int, np.ndarray] = {}

    def __call__(self, p: np.ndarray) -> int:
        k = (round(p[0] / SNAP), round(p[1] / SNAP))
        if k not in self.keys:
            self.keys[k] = len(self.keys)
            self.xy[self.keys[k]] = np.array([float(p[0]), float(p[1])])
        return self.keys[k]


def skeleton_from_lines(features: Iterable[Feature], frame: Frame, name: str = "skeleton",
                        *, min_edge: float = 0.0, straight_tol: float = STRAIGHT_TOL
                        ) -> Skeleton:
    """A building skeleton from LineStrings that meet at shared endpoints. A line with
    inner vertices is split there (each piece keeps the line's front and constraints)."""
    features = list(features)
    sources = sorted({f.source for f in features if f.source})
    prefix = "".join(f"{s}: " for s in sources[:1])     # messages name the file
    node = _Nodes()
    xy = node.xy
    edges: list[Edge] = []

    # each line with the feature it is drawn in and how messages name it: a
    # MultiLineString's lines by part ("feature 0 (s) part 1"), or a skeleton of two
    # disjoint parts was "2 separate pieces, feature 0 (s) / feature 0 (s)"
    drawn: list[tuple[Feature, str, np.ndarray]] = []
    for f in features:
        lines = list(f.geometry.geoms) if isinstance(f.geometry, MultiLineString) \
            else [f.geometry]
        for k, line in enumerate(lines):
            if not isinstance(line, LineString):
                raise SkeletonError(f"{f.where}: a skeleton is made of LineStrings, got "
                                    f"{f.geometry.geom_type}")
            drawn.append((f, _part_label(f.where, k, len(lines)),
                          np.asarray(line.coords)[:, :2]))
    for (f, label, raw), pts in zip(drawn, _undensified([pts for _f, _w, pts in drawn]),
                                    strict=True):
        front = _front(f.properties, f.where)
        cons = _constraints(f.properties, f.where)
        for p, q in zip(raw[:-1], raw[1:], strict=True):   # as drawn (no key points)
            if float(np.linalg.norm(q - p)) < SNAP or \
                    (round(p[0] / SNAP), round(p[1] / SNAP)) == (round(q[0] / SNAP),
                                                                 round(q[1] / SNAP)):
                raise SkeletonError(f"{label}: a zero-length edge at {frame.at(p)}; "
                                    "remove the repeated point")
        for p, q in zip(pts[:-1], pts[1:], strict=True):
            a, b = node(p), node(q)
            edges.append(Edge(a, b, float(np.linalg.norm(xy[b] - xy[a])), front, cons,
                              label))
    if not edges:
        raise SkeletonError(f"{prefix}no skeleton edges in the input")
    edges = _split_at_touching_ends(edges, xy)
    _check_crossings(edges, xy, frame)
    g = nx.Graph()
    g.add_nodes_from(xy)
    for i, e in enumerate(edges):
        if g.has_edge(e.a, e.b):
            raise SkeletonError(f"{e.source}: two edges join the same key points "
                                f"{frame.at(xy[e.a])} and {frame.at(xy[e.b])}")
        g.add_edge(e.a, e.b, index=i)
    parts = sorted(nx.connected_components(g), key=lambda c: (-len(c), min(c)))
    if len(parts) > 1:
        # each piece by a feature in it (the key point counts of 1,000 pieces made a
        # 2,103-character line that said neither which lines nor why)
        named = [next(e.source for e in edges if e.a in c).removeprefix(prefix)
                 for c in parts[:SAID_PIECES]]
        raise SkeletonError(
            f"{prefix}the skeleton is disconnected: {len(parts):,} separate pieces, "
            f"{first_few(named, SAID_PIECES, ' / ', len(parts))}; lines join only where "
            "an end of one lies on "
            f"the other (within {SNAP * 100:g} cm), and {_nearest_gap(parts, edges, xy, frame)}"
            "; connect them, or give each piece as a building of its own")

    def where(v: int) -> str:
        return f"{prefix}key point at {frame.at(xy[v])}"

    kps = _classify(sorted(xy), xy, g, edges, straight_tol, where,
                    lambda e: e.source.removeprefix(prefix))
    closed = all(k.degree == 2 for k in kps)
    sk = Skeleton(name, seamed(kps) if closed else kps, edges, closed, frame)
    _check_sides(sk, min_edge)   # after splitting: a wing drawn to a line can cut it short
    return sk


def _undensified(lines: list[np.ndarray]) -> list[np.ndarray]:
    """Each line with the vertices of a densely drawn run dropped, as an outline's are
    (within :data:`DENSE`): a straight side drawn with a point every few metres, or a
    curve densified by a GIS, would otherwise make every vertex a bend that cuts the
    parts across it (66 part pieces on a 150 m line of 50 points, 950 with 1,000 points,
    and minutes of solving). A vertex where lines meet (an end of any line, or a vertex
    two lines share) is kept, so T junctions and crossings stay where they were drawn."""
    def key(p: np.ndarray) -> tuple[int, int]:
        return round(p[0] / SNAP), round(p[1] / SNAP)

    seen: dict[tuple[int, int], int] = {}
    for pts in lines:
        for p in pts:
            seen[key(p)] = seen.get(key(p), 0) + 1
    ends = {key(pts[i]) for pts in lines for i in (0, -1) if len(pts)}
    out = []
    for pts in lines:
        cut = [0] + [i for i in range(1, len(pts) - 1)
                     if key(pts[i]) in ends or seen[key(pts[i])] > 1] + [len(pts) - 1]
        runs = [np.asarray(shapely.simplify(LineString(pts[a:b + 1]), DENSE,
                                            preserve_topology=False).coords)[:, :2]
                if b - a > 1 else pts[a:b + 1] for a, b in zip(cut[:-1], cut[1:], strict=True)]
        out.append(np.concatenate([runs[0]] + [r[1:] for r in runs[1:]]) if runs else pts)
    return out


def _check_sides(sk: Skeleton, min_edge: float, where: str = "") -> None:
    """Every side (the run between two key points that are not bends: modules fold
    across bends, so a densely drawn curve is as good as a smooth one) must hold the
    smallest part. Messages name ``where`` (else the side's feature)."""
    if min_edge <= 0:
        return
    kp = {k.id: k for k in sk.keypoints}
    at: dict[int, list[int]] = {}
    for i, e in enumerate(sk.edges):
        at.setdefault(e.a, []).append(i)
        at.setdefault(e.b, []).append(i)
    for start in (k.id for k in sk.keypoints if k.kind != "bend"):
        for first in at[start]:
            i, v, length = first, start, 0.0
            while True:
                e = sk.edges[i]
                length += e.length
                v = e.b if e.a == v else e.a
                if kp[v].kind != "bend":
                    break
                i = next(j for j in at[v] if j != i)
            if length < min_edge:
                a, b = kp[start].xy, kp[v].xy
                raise SkeletonError(
                    f"{where or sk.edges[first].source or sk.name}: "
                    f"{side_words(length, sk.frame.at(a), sk.frame.at(b))} is shorter than "
                    f"the smallest part ({min_edge:.2f} m)")


def seamed(kps: list[KeyPoint]) -> list[KeyPoint]:
    """A closed ring's key points, with a seam where it has none: a ring that only bends
    (a round plaza, a roundabout's island, a gasometer) has nowhere to anchor parts, so
    its sharpest bend (the first of equals) becomes a corner, which a mitre joint
    closes like any corner no library part fits."""
    if any(k.kind != "bend" for k in kps):
        return kps
    i = max(range(len(kps)), key=lambda j: (abs(kps[j].turn or 0.0), -j))
    return [dataclasses.replace(k, kind="corner") if j == i else k for j, k in enumerate(kps)]


def _split_at_touching_ends(edges: list[Edge], xy: dict[int, np.ndarray]) -> list[Edge]:
    """A line that ends on the inside of another (a wing drawn up to the main line)
    splits that line there, making the contact a key point."""
    out: list[Edge] = []
    ids = list(xy)
    points = shapely.points(np.array([xy[v] for v in ids]).reshape(-1, 2))
    near: dict[int, list[int]] = {}   # edge -> key points within SNAP of it (an STRtree:
    segs = [LineString([xy[e.a], xy[e.b]]) for e in edges]   # 20,000 vertices took minutes)
    for i, j in zip(*shapely.STRtree(points).query(segs, predicate="dwithin",
                                                   distance=SNAP), strict=True):
        near.setdefault(int(i), []).append(ids[int(j)])
    for n, e in enumerate(edges):
        a, b = xy[e.a], xy[e.b]
        seg = b - a
        L2 = float(seg @ seg)
        inner = []
        for v in near.get(n, []):
            if v in (e.a, e.b):
                continue
            p = xy[v]
            t = float((p - a) @ seg) / L2
            if 0 < t < 1 and np.linalg.norm(a + t * seg - p) < SNAP:
                inner.append((t, v))
        chain = [e.a] + [v for _, v in sorted(inner)] + [e.b]
        for u, w in zip(chain[:-1], chain[1:], strict=True):
            out.append(Edge(u, w, float(np.linalg.norm(xy[w] - xy[u])), e.front,
                            e.constraints, e.source))
    return out


CROSSING_CHUNK = 256   # edges whose meetings are asked of the tree at once
THERE_AND_BACK = "the line goes there and back; end it at the turn"


@dataclass(frozen=True)
class Meeting:
    """Two edges that meet other than at a key point they share: ``kind`` "twice" (the
    same edge drawn twice: a line that goes there and back), "overlap" (they run on top
    of each other) or "cross"; ``span`` is where (local metres): the doubled stretch's
    two ends, or the crossing point twice."""

    kind: Literal["twice", "overlap", "cross"]
    first: Edge
    second: Edge
    span: tuple[tuple[float, float], tuple[float, float]]


def _check_crossings(edges: list[Edge], xy: dict[int, np.ndarray], frame: Frame) -> None:
    """Refuse edges that cross, overlap or repeat: the first such pair, in the order
    the edges were drawn (:func:`_meetings`)."""
    m = next(_meetings(edges, xy), None)
    if m is None:
        return
    e, f = m.first, m.second
    one = e.source == f.source     # a line that turns back on itself
    who = e.source if one else f"{e.source} and {f.source}"
    if m.kind == "twice":
        raise SkeletonError(f"{who}: the same edge is drawn twice (from {frame.at(xy[e.a])} "
                            f"to {frame.at(xy[e.b])}"
                            + (f"): {THERE_AND_BACK}" if one else "); delete one of them"))
    if m.kind == "overlap":
        raise SkeletonError(f"{who}: edges run on top of each other from "
                            f"{frame.at(m.span[0])}; delete or move the doubled stretch")
    raise SkeletonError(f"{who}: edges cross at {frame.at(m.span[0])} without a shared key "
                        "point; split them there or move them apart")


def _meetings(edges: list[Edge], xy: dict[int, np.ndarray]) -> Iterator[Meeting]:
    """The pairs of edges that cross, overlap or repeat, in the order the edges were
    drawn. Asked of the tree :data:`CROSSING_CHUNK` edges at a time: one line drawn
    20,000 times over meets itself 400 M times, which all at once took gigabytes and
    ended in a crash; the first chunk holds the first pair."""
    geoms = [LineString([xy[e.a], xy[e.b]]) for e in edges]
    tree = shapely.STRtree(geoms)
    for start in range(0, len(geoms), CROSSING_CHUNK):
        left, right = tree.query(geoms[start:start + CROSSING_CHUNK], predicate="intersects")
        for i, j in zip((left + start).tolist(), right.tolist(), strict=True):
            if i >= j:
                continue
            e, f = edges[i], edges[j]
            inter = geoms[i].intersection(geoms[j])
            if {e.a, e.b} & {f.a, f.b} and inter.geom_type == "Point":
                continue
            pts = shapely.get_coordinates(inter)
            p, q = (float(pts[0][0]), float(pts[0][1])), (float(pts[-1][0]), float(pts[-1][1]))
            if inter.geom_type in ("LineString", "MultiLineString"):
                twice = {e.a, e.b} == {f.a, f.b}
                yield Meeting("twice" if twice else "overlap", e, f, (p, q))
            else:
                yield Meeting("cross", e, f, (p, p))


def line_meets_itself(coords: np.ndarray) -> Meeting | None:
    """Where one line (a street's, in local metres) runs over or crosses itself: the
    check building lines pass (:func:`_check_crossings`), on the line's segments, each
    split where a vertex of the line lies on it (within :data:`SNAP`), so a line that
    turns back over its course meets itself on the same edge ("twice") even where
    projecting it left the two millimetres apart. Each edge's ``source`` is the index
    of the segment it lies on (``"0"``: from ``coords[0]`` to ``coords[1]``)."""
    node = _Nodes()
    xy = node.xy
    edges = []
    for n, (p, q) in enumerate(zip(coords[:-1], coords[1:], strict=True)):
        a, b = node(p), node(q)
        if a != b:
            edges.append(Edge(a, b, float(np.linalg.norm(xy[b] - xy[a])), "right", {},
                              str(n)))
    return next(_meetings(_split_at_touching_ends(edges, xy), xy), None)


def skeletons_from_polygons(features: Iterable[Feature], frame: Frame, *,
                            min_edge: float = 0.0, straight_tol: float = STRAIGHT_TOL,
                            min_area: float = 1.0) -> list[Skeleton]:
    """One closed skeleton per ring: footprint or block outlines and their holes
    (courtyards). Rings are oriented so the mass lies to the left; facades face right.
    Skeletons are named for their feature (``feature 0 (house) courtyard 1``); messages
    also name the file."""
    out = []
    for f in features:
        polys = _outline_parts(f)
        if len(polys) > 1 and all(p.is_valid for p in polys) and not f.geometry.is_valid:
            raise SkeletonError(_parts_meet(f, polys, frame))
        for k, poly in enumerate(polys):
            label = _part_label(f.name, k, len(polys))
            poly = _checked_polygon(poly, _in_file(f, label), min_area, frame)
            rings = [poly.exterior, *poly.interiors]
            for r, ring in enumerate(rings):
                name = label + ("" if r == 0 else f" courtyard {r}")
                out.append(_ring_skeleton(ring, f, name, frame, min_edge, straight_tol))
    return out


def _in_file(f: Feature, label: str) -> str:
    return f"{f.source}: {label}" if f.source else label


def _outline_parts(f: Feature) -> list[BaseGeometry]:
    return list(f.geometry.geoms) if isinstance(f.geometry, MultiPolygon) else [f.geometry]


def _part_label(name: str, k: int, n: int) -> str:
    """Part k of a feature named ``name`` with n parts (the feature itself when n is 1)."""
    return name + (f" part {k}" if n > 1 else "")


def check_outline(f: Feature, frame: Frame) -> None:
    """Refuse feature ``f`` unless each of its polygons is a valid outline (a Polygon,
    its courtyards apart, crossing itself nowhere), as :func:`skeletons_from_polygons`
    would: a command checks this before it does anything with the outlines (``block``
    settled the overlaps of a self-crossing outline first, and GEOS failed there: exit
    3). Area and how a MultiPolygon's polygons lie to each other are left to that
    function: a trim may still settle them."""
    polys = _outline_parts(f)
    for k, poly in enumerate(polys):
        _valid_polygon(poly, _in_file(f, _part_label(f.name, k, len(polys))), frame)


def check_outlines(features: Sequence[Feature], frame: Frame, most: int = 5) -> None:
    """:func:`check_outline` for every feature, refusing them in one message: the first
    refusal whole, and the names of the other features refused (a file with two
    bowties named the first only: fixed, the run stopped at the second)."""
    refused: list[tuple[Feature, str]] = []
    for f in features:
        try:
            check_outline(f, frame)
        except SkeletonError as exc:
            refused.append((f, str(exc)))
    if not refused:
        return
    (_f, first), rest = refused[0], [f.name for f, _why in refused[1:]]
    if rest:
        named = first_few(rest, most)
        first += (f" ({len(rest)} more of the file's outlines "
                  f"{'are' if len(rest) > 1 else 'is'} refused too: {named})")
    raise SkeletonError(first)


def _parts_meet(f: Feature, polys: list[BaseGeometry], frame: Frame) -> str:
    """Why a MultiPolygon of valid polygons is not valid: they overlap, or they only
    touch (along a side or at a point; "overlap" sent the user looking for shared
    ground there was none of)."""
    what, _fix = why_invalid(f.geometry, frame)
    where = _in_file(f, f.name)
    if shapely.union_all(polys).area < sum(p.area for p in polys) - SHARED_AREA:
        return (f"{where}: its polygons overlap ({what}); two buildings cannot share "
                "ground: merge them into one polygon, or move them apart")
    at = what.rpartition(" at ")[2]
    return (f"{where}: its polygons touch at {at}; the polygons of one feature must stand "
            "apart: give each its own feature (features that touch get a party wall), or "
            "merge them into one polygon")


SHARED_AREA = 1e-3   # m²: polygons sharing less only touch


def _checked_polygon(poly: BaseGeometry, where: str, min_area: float, frame: Frame
                     ) -> Polygon:
    """A valid polygon of some area, oriented counter-clockwise (holes clockwise)."""
    _valid_polygon(poly, where, frame)
    if poly.area < min_area:
        raise SkeletonError(
            f"{where}: the outline at {frame.at(poly.exterior.coords[0])} encloses "
            f"{poly.area:.2f} m², under the {min_area:g} m² of the smallest block; check "
            "its coordinates are in the CRS the file says (or --crs), or remove it")
    return shapely.orient_polygons(poly) if hasattr(shapely, "orient_polygons") \
        else shapely.geometry.polygon.orient(poly, 1.0)


def _valid_polygon(poly: BaseGeometry, where: str, frame: Frame) -> None:
    """Refuse ``poly`` unless it is a valid Polygon whose courtyards stand apart."""
    if not isinstance(poly, Polygon):
        how = {"GeometryCollection": "; give each of its polygons as a feature of its own",
               "LineString": "; building lines go to citysynth building",
               "MultiLineString": "; building lines go to citysynth building"}
        raise SkeletonError(f"{where}: a {poly.geom_type} is no outline; blocks are laid "
                            "out from Polygon and MultiPolygon features (holes as "
                            f"courtyards){how.get(poly.geom_type, '')}")
    _check_courtyards_apart(poly, where, frame)
    if not poly.is_valid:
        what, fix = why_invalid(poly, frame)
        raise SkeletonError(f"{where}: invalid polygon ({what}); {fix}")


COURT_TOUCH = 0.01   # m: a courtyard this near the outline or another courtyard meets it


def _check_courtyards_apart(poly: Polygon, where: str, frame: Frame) -> None:
    """Each courtyard has ground all round it. One that touches the outline (or
    another courtyard) at a point is a valid polygon, but its ring and the outline's
    meet with no wall between: the facades of both were laid out on from that point,
    and a block's parts stood 28 m past its outline. (Given in lon/lat, the same
    courtyard crosses the outline by a hair once projected: told the same way.)"""
    rings = [poly.exterior, *poly.interiors]
    for i in range(1, len(rings)):
        for j in range(i):
            if shapely.distance(rings[i], rings[j]) < COURT_TOUCH:
                x, y = shapely.get_coordinates(shapely.shortest_line(rings[i], rings[j]))[0]
                other = "the outline" if j == 0 else f"courtyard {j}"
                raise SkeletonError(
                    f"{where}: courtyard {i} reaches {other} at {frame.at((x, y))}, "
                    "with no wall between; move the courtyard in from it, or make it a "
                    "notch of the outline")


def why_invalid(poly: Polygon, frame: Frame | None) -> tuple[str, str]:
    """What GEOS finds wrong with a polygon, its location in the input's coordinates
    (GEOS gives it in local metres: "Self-intersection[4.6e-15 0]"; without ``frame``,
    as they are), and what to do. An outline of fewer than 3 distinct corners, or of
    corners on one line, is said so: GEOS calls the one a "geometry component" and the
    other a "self-intersection", and neither crosses itself."""
    text = explain_validity(poly)
    m = re.fullmatch(r"\s*([^\[]+)\[\s*(\S+)\s+(\S+)\s*\]\s*", text)
    if m is None:
        return text, "fix the outline"
    what = m.group(1).strip().lower().replace(" in geometry component", "")
    xy = (float(m.group(2)), float(m.group(3)))
    if what == "self-intersection" and poly.convex_hull.area == 0:
        what = "no area: its corners lie on one line"
    fix = next((f for key, f in _FIXES.items() if what.startswith(key)), "fix the outline")
    return f"{what} at {frame.at(xy) if frame else format_xy(xy)}", fix


_FIXES = {   # what to do about each of GEOS's validity complaints (by how it starts)
    "self-intersection": "fix the outline so it does not cross itself",
    "ring self-intersection": "fix the outline so it does not touch itself",
    "hole lies outside shell": "move the courtyard inside the outline, or drop it",
    "holes are nested": "a courtyard lies inside another: drop the inner one",
    "interior is disconnected": "a courtyard cuts the block in two: give each part as "
                                "its own polygon",
    "nested shells": "give each building its own polygon",
    "too few points": "an outline needs at least 3 distinct corners",
    "no area": "an outline needs at least 3 corners that are not on one line",
}


def _ring_skeleton(ring: LinearRing, f: Feature, name: str, frame: Frame, min_edge: float,
                   straight_tol: float) -> Skeleton:
    where = _in_file(f, name)
    # a densely drawn curve (CAD, GIS densification) keeps its shape within DENSE, and
    # loses the vertices that would fold every module many times over
    ring = shapely.simplify(ring, DENSE, preserve_topology=True)
    pts = np.asarray(ring.coords)[:-1, :2]
    keep = [0]
    for i in range(1, len(pts)):  # drop repeated points
        if np.linalg.norm(pts[i] - pts[keep[-1]]) >= SNAP:
            keep.append(i)
    pts = pts[keep]
    if len(pts) >= 2 and np.linalg.norm(pts[0] - pts[-1]) < SNAP:
        pts = pts[:-1]
    if len(pts) < 3:
        raise SkeletonError(f"{where}: degenerate outline ({len(pts)} distinct points)")
    n = len(pts)
    cons = _constraints(f.properties, f.where)
    edges = []
    for i in range(n):
        a, b = i, (i + 1) % n
        length = float(np.linalg.norm(pts[b] - pts[a]))
        edges.append(Edge(a, b, length, "right", cons, f.where))
    kps = []
    for v in range(n):
        prev, nxt = (v - 1) % n, (v + 1) % n
        turn = angle_between(pts[v] - pts[prev], pts[nxt] - pts[v])
        p = (float(pts[v][0]), float(pts[v][1]))
        kind: KeyPointKind = "bend" if abs(turn) < straight_tol else "corner"
        kps.append(KeyPoint(v, p, kind, 2, angle=180.0 - abs(turn), convex=turn > 0,
                            turn=turn))
    sk = Skeleton(name, seamed(kps), edges, True, frame)
    _check_sides(sk, min_edge, where)
    return sk


def blocks_from_streets(features: Iterable[Feature], *, setback: float = 6.0,
                        min_area: float = 50.0) -> tuple[list[Polygon], list[str]]:
    """Blocks enclosed by street centre lines, ``setback`` metres from each (a number,
    or a function of a street's properties: see :mod:`skeletons.streets`). Returns the
    block polygons and the reasons for the pieces skipped (slivers and tiny blocks)."""
    blocks, skipped = street_blocks(features, setback, min_area=min_area)
    return [b.polygon for b in blocks], skipped


def describe(s: Skeleton) -> str:
    kinds: dict[str, int] = {}
    for k in s.keypoints:
        label = k.kind if k.kind != "corner" else \
            f"corner {k.angle:.0f}° {'convex' if k.convex else 'concave'}"
        kinds[label] = kinds.get(label, 0) + 1
    parts = ", ".join(f"{v} {k}" for k, v in sorted(kinds.items()))
    shape_ = "cycle" if s.closed else "tree"
    return (f"{s.name}: {shape_}, {len(s.edges)} edges, {s.length:.1f} m; key points: "
            f"{parts}")
