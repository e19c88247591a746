"""Street networks -> blocks, as GIS tools export them.

Centre lines (GeoJSON LineStrings with OSM-style tags: ``highway``, sometimes
``width`` or ``lanes``) are noded and polygonised; each face between them becomes a
block once every street around it is cut away by its own setback (half its width plus
a sidewalk, or what its class implies; see :func:`street_setback`). Streets are
buffered with square caps and mitred joins, so blocks keep sharp corners at junctions.
Faces that leave nothing, or only slivers, are skipped with a reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import shapely
from shapely.geometry import LineString, MultiLineString, Polygon

from citysynth.skeletons.errors import SkeletonError
from citysynth.skeletons.geojson import Feature


@dataclass(frozen=True)
class Block:
    polygon: Polygon               # after the setbacks, local metres
    face: Polygon                  # the face between the centre lines
    streets: tuple[int, ...]       # indices (into the features) of the streets around it


@dataclass(frozen=True)
class Setbacks:
    """How far facades stand from a street's centre line."""

    default: float = 6.0           # no width, lanes or known class
    sidewalk: float = 2.5          # added to half the carriageway
    lane_width: float = 3.25
    by_class: tuple[tuple[str, float], ...] = ()   # highway class -> setback

    def __call__(self, props: dict) -> float:
        return street_setback(props, self)


def _number(v) -> float | None:
    """OSM numbers come as text ("7", "7 m", "2;3"); the first number, if any."""
    if isinstance(v, int | float) and not isinstance(v, bool):
        return float(v) if math.isfinite(v) and v > 0 else None
    if isinstance(v, str):
        head = v.replace(",", ".").split(";")[0].split()[0] if v.strip() else ""
        try:
            x = float(head)
        except ValueError:
            return None
        return x if math.isfinite(x) and x > 0 else None
    return None


def street_setback(props: dict, s: Setbacks) -> float:
    """A street's setback: ``width`` / 2 + sidewalk, else ``lanes`` * lane width / 2 +
    sidewalk, else its ``highway`` class's setback, else the default."""
    width = _number(props.get("width"))
    if width is not None:
        return width / 2 + s.sidewalk
    lanes = _number(props.get("lanes"))
    if lanes is not None:
        return lanes * s.lane_width / 2 + s.sidewalk
    table = dict(s.by_class)
    cls = props.get("highway")
    if isinstance(cls, str) and cls in table:
        return table[cls]
    return s.default


def street_blocks(features: Iterable[Feature], setback: float | Callable[[dict], float] = 6.0,
                  *, min_area: float = 50.0) -> tuple[list[Block], list[str]]:
    """The blocks between street centre lines, each cut back by the setbacks of the
    streets around it, sorted by position; and the reasons for the pieces skipped."""
    feats = list(features)
    lines, owners = [], []
    for f in feats:
        g = f.geometry
        if not isinstance(g, LineString | MultiLineString):
            raise SkeletonError(f"{f.name}: street centre lines must be LineStrings, got "
                                f"{g.geom_type}")
        lines.append(g)
        owners.append(f)
    if not lines:
        raise SkeletonError("no street centre lines in the input")
    width = setback if callable(setback) else (lambda _p, d=float(setback): d)
    cuts = [g.buffer(width(f.properties), cap_style="square", join_style="mitre",
                     mitre_limit=3.0) for g, f in zip(lines, owners, strict=True)]
    tree = shapely.STRtree(cuts)
    noded = shapely.union_all(lines)
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    blocks, skipped = [], []
    for i, face in enumerate(sorted(faces, key=lambda p: (round(p.centroid.x, 3),
                                                          round(p.centroid.y, 3)))):
        near = tree.query(face, predicate="intersects")
        left = face.difference(shapely.union_all([cuts[j] for j in near])) if len(near) \
            else face
        left = shapely.simplify(left, 0.01)   # drop the collinear vertices cuts leave
        parts = [p for p in shapely.get_parts(left) if isinstance(p, Polygon) and not p.is_empty]
        where = f"block {i} at ({face.centroid.x:.1f}, {face.centroid.y:.1f})"
        if not parts:
            skipped.append(f"{where}: nothing left after the street setbacks")
            continue
        for p in sorted(parts, key=lambda q: -q.area):
            if p.area < min_area:
                skipped.append(f"{where}: {p.area:.1f} m² after the setbacks, below "
                               f"{min_area:g} m²")
                continue
            touching = tuple(sorted(int(j) for j in near
                                    if cuts[j].distance(p) < 0.01))
            blocks.append(Block(shapely.normalize(p), face, touching))
    return blocks, skipped
