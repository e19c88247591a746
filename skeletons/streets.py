"""Street networks -> blocks, as GIS tools export them.

Centre lines (GeoJSON LineStrings with OSM-style tags: ``highway``, sometimes
``width`` or ``lanes``) are noded and polygonised; each face between them becomes a
block once every street around it is cut away by its own setback (half its width plus
a sidewalk, or what its class implies; see :func:`street_setback`). Streets are
buffered with square caps and mitred joins, so blocks keep sharp corners at junctions.
Faces that leave nothing, or only slivers, are skipped with a reason.
"""

from __future__ import annotations

import ast
import math
import re
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString, Polygon

from citysynth.skeletons.errors import InputWarning, SkeletonError
from citysynth.skeletons.geojson import Feature, local_xy
from citysynth.solver.safe_read import shown

_NUMBER = re.compile(r"\s*((?:\d+(?:[.,]\d+)?|[.,]\d+)(?:[eE][+-]?\d+)?)")
# OSM's feet: 40' or 40'6" (feet and inches), or 40 ft
_FEET = re.compile(r"\s*(?:'\s*(?:(\d+(?:\.\d+)?)\s*(?:\"|''))?|(?:ft|feet|foot)\b)", re.I)
FOOT, INCH = 0.3048, 0.0254


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

    def __call__(self, props: dict[str, Any]) -> float:
        return street_setback(props, self)


def tag_values(v: Any) -> list[Any]:
    """A tag's values. osmnx gives a merged edge the list of its ways' values
    (``["primary", "secondary"]``; GDAL writes it as a JSON array, osmnx's own files as
    the text of a Python list, ``"['2', '3']"``); OSM separates several values with
    ``;``. One value is a list of one; a missing one, an empty list."""
    if isinstance(v, str):
        text = v.strip()
        if text.startswith("[") and text.endswith("]"):
            try:
                parsed = ast.literal_eval(text)
            except (ValueError, SyntaxError):
                parsed = None
            if isinstance(parsed, list | tuple):
                return [x for item in parsed for x in tag_values(item)]
        return [part.strip() for part in text.split(";") if part.strip()]
    if isinstance(v, list | tuple):
        return [x for item in v for x in tag_values(item)]
    return [] if v is None else [v]


def osm_number(v: Any, most: float = math.inf) -> float | None:
    """A positive number from one OSM value (``7``, ``"7"``, ``"7 m"``, ``"7,5"``,
    ``"1e3"``; ``"3;4"`` or ``["3", "4"]``: the first; ``"40'"``, ``"40'6\""`` or
    ``"40 ft"`` in metres, as OSM writes feet) up to ``most``, else None: a
    value no street or building has (``1e308``, a typo) counts as no value, as an
    unreadable one does.
    Streets' widths and lanes and footprints' heights and storeys are all read by it."""
    if not isinstance(v, int | float):   # "3;4", a list (GDAL) or its text (osmnx): first
        v = next(iter(tag_values(v)), None)
    if isinstance(v, bool) or v is None:
        return None
    if isinstance(v, int | float):
        try:
            x = float(v)
        except OverflowError:   # an int past every float (osmnx's text of a list)
            return None
    else:
        m = _NUMBER.match(str(v))
        if m is None:
            return None
        x = float(m.group(1).replace(",", "."))
        feet = _FEET.match(str(v), m.end())
        if feet is not None:
            x = x * FOOT + float(feet.group(1) or 0) * INCH
    return x if math.isfinite(x) and 0 < x <= most else None


_METRES = re.compile(r"\s*(?:m|metres?|meters?)?\s*$", re.I)


def read_wholly(v: Any) -> bool:
    """Whether ``osm_number`` reads all of ``v``: one number, in metres or feet as OSM
    writes them. ``"4-5"``, ``"3;4"``, ``"about 12"`` or ``"12 m approx"`` are read in
    part (the first number), which the caller tells the user rather than hide."""
    if isinstance(v, int | float):
        return True
    values = tag_values(v)
    if len(values) != 1 or isinstance(values[0], bool):
        return False
    if isinstance(values[0], int | float):
        return True
    text = str(values[0])
    m = _NUMBER.match(text)
    if m is None:
        return False
    feet = _FEET.match(text, m.end())
    return _METRES.match(text, feet.end() if feet is not None else m.end()) is not None


MAX_WIDTH = 250.0   # m: no street is wider (the widest avenues are about 140 m)
MAX_LANES = 50      # lanes: nor has more (toll plazas have about 40)


def widest(v: Any, most: float = math.inf) -> float | None:
    """The largest number among a tag's values (a merged edge is as wide as its widest
    way) up to ``most``, or None when none is such a number: a value past it (a width
    of 1e308, a typo of 3000 for 3.00) is read as no value, as an unreadable one is,
    and the street falls back to its next rule instead of swallowing the city."""
    numbers = [x for x in (osm_number(t, most) for t in tag_values(v)) if x is not None]
    return max(numbers, default=None)


NOT_STREETS = ("footway", "path", "cycleway", "steps", "bridleway", "corridor",
               "elevator", "platform", "proposed", "construction", "abandoned", "razed",
               "service=driveway", "service=parking_aisle", "service=drive-through",
               "tunnel=yes", "railway=subway", "railway=tram", "route=ferry")
"""Ways of an OSM export that bound no block (paths across courtyards, sidewalks drawn
beside their street, driveways, ways not built; roads in tunnels, which run under the
blocks; subways; tram lines, which run down their street's middle; ferry routes): a
``highway`` class, or a ``tag=value``. A merged edge (osmnx's lists of values) is no
street only when every one of its values is such: a footway merged with a street, or
a road partly in a tunnel (``tunnel=["no", "yes"]``), still bounds blocks."""


def not_a_street(props: dict[str, Any], rules: Sequence[str]) -> str | None:
    """The rule of ``rules`` (see :data:`NOT_STREETS`) that says a line is no street:
    a ``tag=value`` rule each of its values of that tag meets, or a class rule naming
    each of its highway classes (a merged edge of a footway and a street is a street,
    and so is one partly in a tunnel; until 2026-11-30 any ``tunnel`` value of
    ``"yes"`` dropped the whole edge); else None."""
    classes = highway_classes(props)
    for rule in rules:
        key, eq, value = rule.partition("=")
        values = [str(v) for v in tag_values(props.get(key))]
        if eq and values and all(v == value for v in values):
            return rule
    if classes and all(c in rules for c in classes):
        return "highway=" + classes[0]
    return None


def is_roundabout(props: dict[str, Any]) -> bool:
    """Whether a way is part of a roundabout (``junction=roundabout`` or ``circular``):
    the block its ring encloses is its island, no building ground."""
    return bool({"roundabout", "circular"} & set(tag_values(props.get("junction"))))


def highway_classes(props: dict[str, Any]) -> tuple[str, ...]:
    """A street's ``highway`` classes, one or several (a merged edge), in order."""
    out: list[str] = []
    for v in tag_values(props.get("highway")):
        if isinstance(v, str) and v not in out:
            out.append(v)
    return tuple(out)


def street_setback(props: dict[str, Any], s: Setbacks) -> float:
    """A street's setback: ``width`` / 2 + sidewalk, else ``lanes`` * lane width / 2 +
    sidewalk, else its ``highway`` class's setback (the default for a class not in the
    table). Several values (osmnx's merged edges, OSM's "2;3") take the widest."""
    width = widest(props.get("width"), MAX_WIDTH)
    if width is not None:
        return width / 2 + s.sidewalk
    lanes = widest(props.get("lanes"), MAX_LANES)
    if lanes is not None:
        return lanes * s.lane_width / 2 + s.sidewalk
    table = dict(s.by_class)
    return max((table.get(c, s.default) for c in highway_classes(props)), default=s.default)


def unread_width(props: dict[str, Any]) -> str | None:
    """What of a street's ``width`` and ``lanes`` was given but read as no value
    (``lanes="two"``, ``width="wide"``, a width of 1e308), when none of it was read:
    the street then stands at its class's setback, and the user should hear why."""
    if widest(props.get("width"), MAX_WIDTH) is not None or \
            widest(props.get("lanes"), MAX_LANES) is not None:
        return None
    given = [f"{k} {shown(props[k], 40)}" for k in ("width", "lanes")
             if props.get(k) not in (None, "", [])]
    return " and ".join(given) or None


def _warn_unread_widths(owners: Sequence[Feature]) -> None:
    """One warning for the streets whose width and lanes could not be read, naming the
    first and counting the rest (a city export can have thousands)."""
    unread = [(f, text) for f in owners if (text := unread_width(f.properties))]
    if not unread:
        return
    f, text = unread[0]
    more = f" (and {len(unread) - 1} more streets)" if len(unread) > 1 else ""
    warnings.warn(f"{f.where}: {text} is no width in metres (up to {MAX_WIDTH:g}) or "
                  f"number of lanes (up to {MAX_LANES}){more}: its highway class's "
                  "setback is used instead; write the width in metres (width=7.5) or the "
                  "lanes as a number (lanes=2)", InputWarning, stacklevel=3)


MAX_CROSSINGS = 100_000   # street crossings: each makes up to a block, a job of its own
CROSSING_SAMPLE = 50_000  # pairs of lines tested to estimate how many cross
SAMPLE_LINES = 256        # lines whose neighbours are counted to estimate all pairs
CHUNK_LINES = 16          # lines queried at once (a line drawn 20,000 times over meets
                          # 20,000 boxes: all pairs at once were 6 GB)


def _check_crossings(lines: list, feats: list[Feature]) -> None:
    """Refuse, before noding, a network whose lines cross each other so often that
    noding and polygonising it would take minutes and gigabytes (a few thousand random
    segments cross a million times; a whole real city crosses far less). The pairs of
    lines whose boxes meet are counted for a sample of lines, a few at a time, and the
    share that cross measured on a sample of those pairs: so no step holds more than a
    few lines' pairs, however the lines pile up."""
    arr = np.asarray(lines, dtype=object)
    if not len(arr):
        return
    tree = shapely.STRtree(arr)
    picked = np.unique(np.linspace(0, len(arr) - 1, min(len(arr), SAMPLE_LINES)).astype(int))
    met, tested, crossed = 0, 0, 0
    per_chunk = CROSSING_SAMPLE // max(1, len(picked) // CHUNK_LINES)   # pairs tested
    for at in range(0, len(picked), CHUNK_LINES):
        some = picked[at:at + CHUNK_LINES]
        pairs = tree.query(arr[some])           # boxes that meet: fast, an upper bound
        met += pairs.shape[1]
        keep = np.arange(0, pairs.shape[1], max(1, pairs.shape[1] // per_chunk))
        tested += len(keep)
        crossed += int(shapely.crosses(arr[some][pairs[0, keep]], arr[pairs[1, keep]]).sum())
    pairs_all = met * len(arr) / len(picked)
    if pairs_all <= 2 * MAX_CROSSINGS:
        return
    crossings = int(crossed / max(tested, 1) * pairs_all / 2)
    if crossings > MAX_CROSSINGS:
        src = feats[0].source + ": " if feats and feats[0].source else ""
        raise SkeletonError(
            f"{src}{len(lines):,} street lines cross each other about {crossings:,} times, "
            f"making about as many blocks (noding them would take about "
            f"{crossings * 4e-6:,.1f} GB and minutes); more than the {MAX_CROSSINGS:,} a "
            "street network has: check that these are street centre lines, or split "
            "the area")


def _distinct(lines: list) -> list:
    """The lines, each drawn once: a line given twice, or both ways (osmnx's graphs hold
    a two-way street as two edges), is noded once; GEOS noding one line drawn 20,000
    times over ran out of memory (the union is the same either way)."""
    keys = shapely.to_wkb(shapely.normalize(np.asarray(lines, dtype=object)))
    _, first = np.unique(keys, return_index=True)
    return [lines[i] for i in sorted(first)]


_CUT = {"cap_style": "square", "join_style": "mitre", "mitre_limit": 3.0}
NO_AREA = 0.05   # m²: what the setbacks leave of a block below this is nothing


def _joined_cuts(lines: list, widths: list[float]) -> list[Polygon]:
    """What the streets cut out of the faces: the lines of each setback, noded, joined
    end to end where one goes on into the next (:func:`shapely.line_merge`: a node
    only two of them meet at), each joined line buffered once. A street's square cap stands
    where it ends, not where a GIS split it: a network exported as two-point segments
    (or cut every 2 m) buffered piece by piece put a cap's corner into the block at
    every bend, a saw-tooth of 3 m notches, and a block failed on a side they left."""
    by_width: dict[float, list] = {}
    for g, w in zip(lines, widths, strict=True):
        by_width.setdefault(w, []).extend(shapely.get_parts(g))
    out: list[Polygon] = []
    for w in sorted(by_width):
        # noded first, so that a street passing through a junction and one split
        # there are the same lines: how a GIS split the network changes nothing
        merged = shapely.line_merge(shapely.union_all(_distinct(by_width[w])))
        out += [p.buffer(w, **_CUT) for p in shapely.get_parts(merged)]
    return out


def _lines_of(g: shapely.Geometry) -> LineString | MultiLineString | None:
    """A feature's street lines: its LineString or MultiLineString, or a
    GeometryCollection that holds only lines (as a MultiLineString: some GIS exports
    write a street's pieces so); None for anything else."""
    if isinstance(g, LineString | MultiLineString):
        return g
    if isinstance(g, shapely.GeometryCollection) and not g.is_empty:
        parts = shapely.get_parts(g)
        if all(isinstance(q, LineString | MultiLineString) for q in parts):
            return MultiLineString([ls for q in parts for ls in shapely.get_parts(q)])
    return None


def street_blocks(features: Iterable[Feature], setback: float | Callable[[dict], float] = 6.0,
                  *, min_area: float = 50.0,
                  skipped_shapes: list[Polygon | None] | None = None,
                  locate: Callable[[tuple[float, float]], str] | None = None
                  ) -> tuple[list[Block], list[str]]:
    """The blocks between street centre lines, each cut back by the setbacks of the
    streets around it, sorted by position; and the reasons for the pieces skipped
    (features that are not lines come first: a Point of an Overpass export is no
    street). ``Block.streets`` index ``features``. ``skipped_shapes``, when given,
    receives each skipped piece's outline (None for a feature), in step with the
    reasons, so a run can show where they were. ``locate`` words a local point as the
    user's data has it (a frame's ``at``: lon/lat or the input's CRS); without it, a
    point is given in local metres."""
    shapes: list[Polygon | None] = skipped_shapes if skipped_shapes is not None else []
    feats = list(features)
    lines, owners, at, skipped = [], [], [], []
    for k, f in enumerate(feats):
        g = _lines_of(f.geometry)
        if g is None:
            skipped.append(f"{f.where}: a {f.geometry.geom_type} is no street centre line "
                           "(LineString or MultiLineString)"
                           + (" (it holds other geometry than lines; split it into "
                              "LineString features)" if isinstance(
                                  f.geometry, shapely.GeometryCollection) else ""))
            shapes.append(None)
            continue
        lines.append(g)
        owners.append(f)
        at.append(k)
    if not lines:
        raise SkeletonError(f"{feats[0].source + ': ' if feats and feats[0].source else ''}"
                            "no street centre lines (LineStrings) in the input"
                            + (f"; e.g. {skipped[0]}" if skipped else ""))
    width = setback if callable(setback) else (lambda _p, d=float(setback): d)
    widths = [width(f.properties) for f in owners]
    if isinstance(setback, Setbacks):   # read from the tags: say which could not be
        _warn_unread_widths(owners)
    distinct = _distinct(lines)
    _check_crossings(distinct, feats)   # first: noding the setbacks' lines took minutes
    cuts = [g.buffer(w, **_CUT) for g, w in zip(lines, widths, strict=True)]
    tree = shapely.STRtree(cuts)
    joined = _joined_cuts(lines, widths)
    joined_tree = shapely.STRtree(joined)
    noded = shapely.union_all(distinct)
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    blocks = []
    for i, face in enumerate(sorted(faces, key=lambda p: (round(p.centroid.x, 3),
                                                          round(p.centroid.y, 3)))):
        near = tree.query(face, predicate="intersects")
        cut = joined_tree.query(face, predicate="intersects")
        left = face.difference(shapely.union_all([joined[j] for j in cut])) if len(cut) \
            else face
        left = shapely.simplify(left, 0.01)   # drop the collinear vertices cuts leave
        # (a sliver of no area the setbacks leave is nothing, not a piece "of 0.0 m²")
        parts = [p for p in shapely.get_parts(left) if isinstance(p, Polygon)
                 and not p.is_empty and p.area >= NO_AREA]
        def where(i=i, face=face, piece=None, no=1, pieces=1) -> str:
            # said only of a piece skipped (placing a point in lon/lat costs time); of
            # one of several pieces the setbacks leave, that piece (they shared a name)
            at = face if piece is None else piece
            of = f" (piece {no} of {pieces})" if pieces > 1 else ""
            return f"block {i}{of} at {(locate or local_xy)((at.centroid.x, at.centroid.y))}"
        if not parts:
            skipped.append(f"{where()}: nothing left after the street setbacks")
            shapes.append(face)
            continue
        for piece_no, p in enumerate(sorted(parts, key=lambda q: -q.area), 1):
            if p.area < min_area:   # rounded down: 49.97 m² was "50.0 m², below 50 m²"
                skipped.append(f"{where(piece=p, no=piece_no, pieces=len(parts))}: "
                               f"{math.floor(p.area * 10) / 10:.1f} m² after the "
                               f"setbacks, below {min_area:g} m²")
                shapes.append(p)
                continue
            touching = tuple(sorted(at[int(j)] for j in near
                                    if cuts[j].distance(p) < 0.01))
            blocks.append(Block(shapely.normalize(p), face, touching))
    return blocks, skipped
