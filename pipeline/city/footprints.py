"""Building footprints in a city run: what a footprint job knows of its input feature,
how it is cleaned, how many storeys it gets, and why it fails, in the user's words.

A footprint is re-skinned faithfully: :func:`~citysynth.skeletons.clean.clean_footprint`
keeps the outline facades stand on within ``tolerance`` (0.5 m) of the input wherever
noise and short sides allow. Its ``building:levels`` (or ``height`` over the storey
height) choose the facade family whose storey count is nearest, within
``storey_tolerance``; ``roof:shape`` prefers the families of that roof. A family is read
from part ids (:func:`part_families`). A footprint that cannot be built says which
feature of the file, which side (from-to in the input's coordinates, its length) and
what the kit makes near that length.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely

from citysynth.export.ground import polygons_in
from citysynth.export.joints import ACUTE_DEG, NOSE
from citysynth.export.party import TOUCH
from citysynth.parts_db import Part, PartDB
from citysynth.pipeline.errors import MAX_STRETCH, shown
from citysynth.pipeline.layouts import BlockedAt
from citysynth.pipeline.skeleton_to_structure import _chains, shortest_stage
from citysynth.skeletons import Feature, Frame, Skeleton, skeletons_from_polygons
from citysynth.skeletons.clean import (
    absorb_short_edges,
    clean_footprint,
    mean_width,
    without_tips,
)
from citysynth.skeletons.errors import SkeletonError
from citysynth.skeletons.from_geometry import STRAIGHT_TOL
from citysynth.skeletons.geojson import format_xy, input_xy, local_xy, side_words
from citysynth.skeletons.overture import source_key
from citysynth.skeletons.streets import osm_number, read_wholly, tag_values

if TYPE_CHECKING:   # the job module imports this one
    from citysynth.pipeline.city.jobs import BlockJob

_TAG = re.compile(r"([a-z])\d?")
REF_KEYS = ("id", "osm_id", "@id", "osm_way_id")   # how exports name a feature


@dataclass(frozen=True)
class Storeys:
    """city.toml ``[footprints]``: how data become storeys and roofs. ``families`` maps
    (style, family tag) to its storey count; ``roofs`` (style, roof:shape) to family
    tags. The defaults are the sample library's."""

    tolerance: int = 0               # storeys a building may differ from its data
    storey_height: float = 3.3       # m: `height` / this when `building:levels` is missing
    families: tuple[tuple[str, str, int], ...] = (
        ("classic", "a", 4), ("classic", "b", 5), ("classic", "c", 3), ("classic", "d", 6),
        ("modern", "a", 5), ("modern", "b", 6), ("modern", "c", 4), ("modern", "d", 8))
    roofs: tuple[tuple[str, str, tuple[str, ...]], ...] = (
        ("classic", "gabled", ("a", "c", "d")), ("classic", "mansard", ("b",)),
        ("modern", "flat", ("a", "b", "c", "d")))


@dataclass(frozen=True)
class FootprintSpec:
    """What a footprint job carries of its input feature and of the footprint settings
    (all of it covered by the job's input hash)."""

    source: str                      # the file
    feature: int                     # the feature's index in it
    ref: str                         # its id / osm_id property, or ""
    levels: float | None
    height: float | None
    roof: str | None
    source_crs: str                  # the input's CRS when not lon/lat ("" otherwise)
    stretch: float                   # a side may be met within this fraction
    tolerance: float                 # metres the cleaned outline may stray
    storeys: Storeys
    infill: bool = True              # roof over ground deeper than the parts reach
    # stretches of the outline shared with a neighbour (x0, y0, x1, y1 in the city
    # frame, the building on the left): its parts stop there (pipeline/city/party.py)
    party: tuple[tuple[float, float, float, float], ...] = ()
    trimmed: str = ""                # why the outline is less than the feature's (overlaps.py)
    remarks: str = ""                # what of its data it is not built as (see remark)

    @property
    def label(self) -> str:
        return f"feature {self.feature}" + (f" ({self.ref})" if self.ref else "")

    @property
    def where(self) -> str:
        return f"{self.source}: {self.label}" if self.source else self.label


MAX_LEVELS = 200     # storeys: past the tallest building (163)
MAX_HEIGHT = 1000.0  # m: likewise (828 m)


def feature_ref(props: dict[str, Any]) -> str:
    """The feature's own id, as OSM and cadastre exports name it, or ""."""
    for k in REF_KEYS:
        if props.get(k) not in (None, ""):
            return str(props[k])
    return ""


def footprint_spec(source: str, index: int, props: dict[str, Any], source_crs: str,
                   stretch: float, tolerance: float, storeys: Storeys, infill: bool = True
                   ) -> FootprintSpec:
    """The spec of feature ``index`` of ``source`` from its properties; a storey count
    or height no building has (``-2``, ``1e9``, ``"tall"``) counts as none, and the
    building's notes say so."""
    roof = props.get("roof:shape")
    # a roof shape as OSM spells them: lower case ("MANSARD", "Mansard " were unknown)
    roof_shape = next((str(v).strip().lower() for v in tag_values(roof)), None) or None
    levels = osm_number(props.get("building:levels"), MAX_LEVELS)
    height = osm_number(props.get("height"), MAX_HEIGHT)
    spec = FootprintSpec(source, index, feature_ref(props), levels, height, roof_shape,
                         source_crs, stretch, tolerance, storeys, infill)
    lk, hk = source_key(props, "building:levels"), source_key(props, "height")
    unread = []
    if levels is None and props.get("building:levels") not in (None, ""):
        unread.append(f"{lk} {shown(props['building:levels'], 40)} is no storey "
                      f"count (1 to {MAX_LEVELS})")
    if height is None and props.get("height") not in (None, ""):
        unread.append(f"{hk} {shown(props['height'], 40)} is no height (metres, up to "
                      f"{MAX_HEIGHT:g})")
    partly = []
    if levels is not None and not read_wholly(props.get("building:levels")):
        partly.append(f"{lk} {shown(props['building:levels'], 40)} read as {levels:g} "
                      "(the first number)")
    elif levels is not None and levels != int(levels):
        n = whole_storeys(levels)
        partly.append(f"{lk} {levels:g} is no whole number of storeys: {n} asked")
    if height is not None and not read_wholly(props.get("height")):
        partly.append(f"{hk} {shown(props['height'], 40)} read as {height:g} m (the first "
                      "number)")
    if len(tag_values(roof)) > 1:
        partly.append(f"{source_key(props, 'roof:shape')} {shown(roof, 40)} read as "
                      f"{roof_shape} (the first value)")
    if partly:
        spec = remark(spec, " and ".join(partly))
    if not unread:
        return spec
    return remark(spec, f"{' and '.join(unread)}: left out, the storeys chosen as "
                        "without it")


def remark(spec: FootprintSpec, text: str) -> FootprintSpec:
    """``spec`` with a remark on its data added (one line of the building's note: what
    of the feature it is not built as, or what looks wrong with it)."""
    line = f"{spec.where}: {text}"
    return replace(spec, remarks=f"{spec.remarks}\n{line}" if spec.remarks else line)


PASSAGE = ("building_passage",)   # tunnel=*: a street under a building, as it should be
CROSSING_MIN = 0.5                # m of a street's centre line inside a footprint


def street_crossings(spec: FootprintSpec, polygon: shapely.Polygon,
                     streets: Sequence[Feature], tree: shapely.STRtree) -> FootprintSpec:
    """``spec`` with a remark for each street whose centre line runs through the
    footprint (more than :data:`CROSSING_MIN` of it), but for building passages: a
    building standing in a street is a data error an artist would see first (the
    footprint or the street is misdrawn), and it is built as given."""
    for i in sorted(int(i) for i in tree.query(polygon, predicate="intersects")):
        street = streets[i]
        if set(tag_values(street.properties.get("tunnel"))) & set(PASSAGE):
            continue
        inside = street.geometry.intersection(polygon).length
        if inside > CROSSING_MIN:
            of = f" of {street.source}" if street.source else ""
            spec = remark(spec, f"stands across the centre line of street {street.name}{of} "
                                f"({inside:.1f} m of it inside the footprint): built as "
                                "given; check the footprint or the street (a street under "
                                "a building is tagged tunnel=building_passage)")
    return spec


def not_built(props: dict[str, Any]) -> str | None:
    """Why a footprint has no facade to build, or None: a building under the ground
    (``location=underground``, Overture's ``is_underground``: a car park under a
    square), an outline its data says is no building (``building=no``: OSM's tag for a
    structure mapped but not a building, which exports keep), a roof on pillars
    (``building=roof``: a canopy over a petrol station or a market; the kit would
    wall it in as a block of flats), or a mass that starts above the ground
    (``min_height`` or ``building:min_level`` over 0: a building over a passage or a
    street, a part on top of another building), which built from the ground would
    close what runs under it."""
    if "underground" in [str(v).strip().lower() for v in tag_values(props.get("location"))]:
        given = source_key(props, "location")
        said = "is_underground" if given == "location" and "is_underground" in props \
            else f"{given}=underground"       # the field as the file names it
        return f"underground ({said}): no facade to build"
    kind = [str(v).strip().lower() for v in tag_values(props.get("building"))]
    if kind == ["no"]:
        return "building=no: not a building"
    if kind == ["roof"]:
        return ("a roof on pillars (building=roof): no walls to build (tag it as another "
                "building to build it)")
    for key, what in (("min_height", "{:g} m"), ("building:min_level", "storey {:g}")):
        above = osm_number(props.get(key))
        if above is not None:
            given = source_key(props, key)
            return (f"starts above the ground, at {what.format(above)} ({given} = "
                    f"{shown(props[key], 20)}): a building over a passage or on another "
                    f"one, which the kit cannot build from the ground (remove {given} to "
                    "build it from the ground)")
    return None


# --- storeys ---------------------------------------------------------------------------

def part_families(part_id: str, known: Iterable[str]) -> frozenset[str]:
    """The family tags a part belongs to: the ``_<letter>[digit]`` tokens of its id
    after the style and class (``classic_mid_7.8_a0`` is ``a``, a step
    ``classic_mid_10.0_a0_b3`` is ``a`` and ``b``, ``classic_corner_90_convex_b`` is
    ``b``); an id with none belongs to the first family listed (the principal one:
    ``classic_corner_90_convex``)."""
    known = list(known)
    tags = id_tags(part_id) & set(known)
    return frozenset(tags or known[:1])


def id_tags(part_id: str) -> set[str]:
    """The ``_<letter>[digit]`` tokens of a part id after its style and class, as
    letters (``classic_mid_10.0_a0_b3``: a and b)."""
    return {m.group(1) for t in part_id.split("_")[2:] if (m := _TAG.fullmatch(t))}


def style_families(db: PartDB, style: str) -> set[str]:
    """The family tags the parts of ``style`` carry in their ids (see
    :func:`part_families`)."""
    return set().union(*(id_tags(p.id) for p in db.parts if p.style == style))


def wanted_storeys(spec: FootprintSpec) -> int | None:
    """Storeys from the data: ``building:levels``, else ``height`` over the storey
    height (rounded); None when the feature has neither."""
    if spec.levels is not None:
        return whole_storeys(spec.levels)
    if spec.height is not None:
        return whole_storeys(spec.height / spec.storeys.storey_height)
    return None


def whole_storeys(x: float) -> int:
    """``x`` storeys as a whole number, halves up (Python's ``round`` made 2.5 two
    storeys and 3.5 four), at least one."""
    return max(1, math.floor(x + 0.5))


def choose_family(spec: FootprintSpec, db: PartDB, style: str
                  ) -> tuple[frozenset[str] | None, int | None, str | None]:
    """The part ids a footprint may use (None: every part of the style), the storeys it
    gets, and a note when the data could not be matched."""
    fams = {tag: n for st, tag, n in spec.storeys.families if st == style}
    want = wanted_storeys(spec)
    shapes = {shape.strip().lower(): set(f) for st, shape, f in spec.storeys.roofs
              if st == style}
    roof_fams = shapes.get(spec.roof, set()) & set(fams) if spec.roof else set()
    roof_note = None
    if spec.roof and fams and spec.roof not in shapes:
        known = f"its roofs are {', '.join(sorted(shapes))}" if shapes else "it has no roofs"
        roof_note = (f"{spec.where}: roof:shape {spec.roof} is none the {style} kit builds "
                     f"({known} in city.toml's [footprints] roofs): built with the roof of "
                     "its storeys")
    if not fams or (want is None and not roof_fams):
        return None, None, roof_note
    if want is None:
        chosen = roof_fams
    else:
        best = min(abs(n - want) for n in fams.values())
        near = {t for t, n in fams.items() if abs(n - want) == best}
        chosen = {min(near & roof_fams or near, key=lambda t: (fams[t], t))}
    allowed = frozenset(p.id for p in db.parts if p.style == style
                        and part_families(p.id, fams) <= chosen)
    storeys = fams[next(iter(chosen))] if len(chosen) == 1 else None
    note = None
    if want is not None and storeys is not None and abs(storeys - want) > spec.storeys.tolerance:
        have = ", ".join(str(n) for n in sorted(set(fams.values())))
        note = (f"{spec.where}: {want} storey{'' if want == 1 else 's'} asked; the {style} "
                f"kit has {have}: built "
                f"with {storeys}")
    return allowed, storeys, "\n".join(n for n in (note, roof_note) if n) or None


# --- messages --------------------------------------------------------------------------

def makeable(fillers: list[Part], quantum: float, top: float) -> np.ndarray:
    """Lengths (in quanta) a side between two mitre joints can take: some run of the
    kit's modules, plus a joint leg of 1-8 quanta at each end (transitions ignored)."""
    n = int(top / quantum) + 1
    sums = np.zeros(n + 1, dtype=bool)
    sums[0] = True
    steps = sorted({round(p.length / quantum) for p in fillers if p.length > 0})
    for i in range(1, n + 1):
        sums[i] = any(i >= s and sums[i - s] for s in steps)
    sums[0] = False
    out = np.zeros(n + 1, dtype=bool)
    for legs in range(2, 17):
        out[legs:] |= sums[: n + 1 - legs]
    return out


def side_advice(length: float, lo: float, hi: float, fillers: list[Part], quantum: float,
                style: str) -> str | None:
    """What the kit makes near a side of ``length`` (met within [lo, hi]), or None when
    the side on its own can be made."""
    ok = makeable(fillers, quantum, hi + 20 * quantum)
    idx = np.flatnonzero(ok) * quantum
    if len(idx) and np.any((idx >= lo - 1e-9) & (idx <= hi + 1e-9)):
        return None
    below = idx[idx < lo]
    above = idx[idx > hi]
    near = [f"{x:.1f}" for x in (below[-1:].tolist() + above[:1].tolist())]
    if not near:
        return f"the {style} kit makes nothing this short"
    gap = min(abs(length - float(x)) for x in near)
    add = f" or add a {max(quantum, length - float(below[-1])):.1f} m part" if len(below) \
        else ""
    if gap / length > MAX_STRETCH:   # no stretch city.toml takes makes it: say so
        return (f"the {style} kit makes {' or '.join(near)} m here, "
                f"{100 * gap / length:.0f} % away, past the {100 * MAX_STRETCH:g} % "
                f"stretch allowed: the side's length in the data must change"
                f"{add.replace(' or add', ', or add')}")
    return (f"the {style} kit makes {' or '.join(near)} m here; allow "
            f"{at_least(100 * gap / length)} % stretch or {at_least(gap)} m of slack{add}")


def at_least(x: float) -> str:
    """``x`` (> 0) rounded up to two significant digits, as advice a user types: a
    stretch rounded to one decimal said "allow 0.0 % stretch" of a long side a few
    centimetres off, and "3.7 %" of a side that needs 3.704 % (3.7 % of it falls
    short)."""
    digits = max(0, 1 - math.floor(math.log10(x)))
    return f"{math.ceil(x * 10**digits - 1e-9) / 10**digits:g}"


def stage_sides(sk: Skeleton) -> list[tuple[tuple[float, float], tuple[float, float], float]]:
    """The sides of a ring skeleton between its corners: (from, to, length)."""
    kinds = {k.id: k for k in sk.keypoints}
    corners = [k.id for k in sk.keypoints if k.kind != "bend"]
    if not corners:
        return []
    sides = []
    n = len(sk.edges)
    start = next(i for i, e in enumerate(sk.edges) if e.a == corners[0])
    a, length = sk.edges[start].a, 0.0
    for t in range(n):
        e = sk.edges[(start + t) % n]
        length += e.length
        if kinds[e.b].kind != "bend":
            sides.append((kinds[a].xy, kinds[e.b].xy, length))
            a, length = e.b, 0.0
    return sides


def short_side(rings: list[Skeleton], min_side: float):
    """The first side shorter than ``min_side``, or None."""
    for sk in rings:
        for side in stage_sides(sk):
            if side[2] < min_side:
                return sk, side
    return None


def stage_side(rings: list[Skeleton], blocked_at: BlockedAt | None):
    """The side a failed solve is blocked on (its ring's chain at the blocked stage),
    as (from, to, length); None when it names none."""
    if blocked_at is None:
        return None
    ring, blocked = blocked_at
    sk = next((r for r in rings if r.name == ring), None)
    if sk is None:
        return None
    keys, chains = _chains(sk)
    xy = {k.id: k.xy for k in sk.keypoints}
    i = blocked.stage
    if i >= len(chains):
        return None
    c = chains[i]
    return xy[c.a], xy[c.b], c.length


def describe_side(frame: tuple[str, float, float], source_crs: str, a: Any, b: Any,
                  length: float) -> str:
    """'the 6.00 m side from (x, y) to (x, y)', in the input's coordinates."""
    return side_words(length, format_xy(input_xy(frame, source_crs, a)),
                      format_xy(input_xy(frame, source_crs, b)))


def explain(where: str, frame: tuple[str, float, float], source_crs: str,
            rings: list[Skeleton], db: PartDB, style: str, allowed: frozenset[str] | None,
            tol: Any, asked: str, blocked_at: BlockedAt | None = None) -> str:
    """A failed block or footprint in its user's words: the first side the kit cannot
    make on its own, with what it makes near that length; else the side the solver
    found no filling for with the asked ranges (or, naming none, all sides at once)."""
    fillers = [p for p in db.select("middle", style) if allowed is None or p.id in allowed]

    def side_text(a: Any, b: Any, length: float) -> str:
        return describe_side(frame, source_crs, a, b, length)

    for sk in rings:
        for a, b, length in stage_sides(sk):
            t = tol(length)
            advice = side_advice(length, length - t, length + t, fillers, db.quantum, style)
            if advice:
                return f"{where}: {side_text(a, b, length)}: {advice}"
    more = f" with {asked}" if asked else ""
    loosen = "allow more stretch" + (", or loosen the per-side and per-block ranges in "
                                     "city.toml" if asked else "")
    side = stage_side(rings, blocked_at)
    if side is not None:
        return (f"{where}: {side_text(*side)}: no row of the {style} kit's parts fits "
                f"it{more} beside the corners it can take; {loosen}")
    sides = [s for sk in rings for s in stage_sides(sk)]
    shortest = f" (the shortest is {side_text(*min(sides, key=lambda s: s[2]))})" \
        if sides else ""
    return (f"{where}: its sides can each be made from the {style} kit, but not all of "
            f"them at once{more}{shortest}; {loosen}")


def too_short(where: str, frame: tuple[str, float, float], source_crs: str, side: Any,
              min_side: float, style: str) -> str:
    """A side left shorter than any facade between two corners."""
    return (f"{where}: {describe_side(frame, source_crs, *side)} is shorter than the "
            f"{min_side:.1f} m the {style} kit needs between two corners, and absorbing it "
            "would move the outline by more than the cleaning tolerance (raise "
            "footprints.tolerance)")


# --- a block job's outline, ready to solve ---------------------------------------------

@dataclass
class Prepared:
    """A block's or footprint's cleaned rings and what solving them takes."""

    rings: list[Skeleton]
    where: str                         # how messages name it
    stretch: float
    slack: float
    parts: frozenset[str] | None       # the facade family's parts (None: all)
    storeys: int | None = None
    note: str | None = None            # storeys asked that the kit could not match

    def options(self) -> dict[str, Any]:
        return {"stretch": self.stretch, "slack": self.slack, "parts": self.parts}

    def tol(self, quantum: float):
        """A side's allowance: the largest of half a quantum, the slack and the stretch."""
        return lambda length: max(quantum / 2, self.slack, self.stretch * length)


def min_side(db: PartDB, style: str, slack: float) -> float:
    """The shortest side two mitre joints close: the shortest module and a one-quantum
    leg at each end, less the slack."""
    shortest = min((p.length for p in db.select("middle", style)), default=0.0)
    return max(shortest + 2 * db.quantum - slack, db.quantum)


LIGHT_WELL = 50.0     # m²: a smaller courtyard with a side too short to build is closed
NARROW_AREA = 0.05    # of a footprint's area: the most filling a courtyard's niches adds
MIN_NARROW = 0.01     # m²: less is no change
MAX_NARROW = 4        # niche fillings tried on one footprint past one per courtyard
RETRY_SIDE = 1.0      # m: a footprint no layout fits is cleaned again with sides this much longer


def _street_block(job: BlockJob, db: PartDB, poly: shapely.Polygon,
                  frame: Frame) -> Prepared | str:
    """A street block cleaned into its ring (what footprints leave of one faithfully,
    no bulging; a whole one with its short sides absorbed), less any tip too sharp for
    its nose; or why nothing is left of it."""
    if job.cut:
        clean = clean_footprint(poly, min_side=min_side(db, job.style, job.slack),
                                straight_tol=STRAIGHT_TOL, tolerance=GAP / 6)
        gone = "nothing buildable is left of it once cleaned"
    else:
        clean = absorb_short_edges(poly, min_edge=job.min_edge,
                                   min_stage=shortest_stage(db, job.style),
                                   straight_tol=STRAIGHT_TOL, nose=NOSE)
        gone = "nothing buildable is left once its sides too short for corners are absorbed"
    if clean is None:   # said where it is, as a piece skipped before it was a block is
        return f"{block_where(job, poly)}: {gone}"
    clean = without_tips(clean, acute_deg=ACUTE_DEG, nose=NOSE, straight_tol=STRAIGHT_TOL)
    rings = skeletons_from_polygons([Feature(0, clean, {"id": job.id})], frame)
    return Prepared(rings, block_where(job, poly), job.stretch, job.slack, None)


def job_frame(job: BlockJob) -> Frame:
    """The run's frame as the job carries it (its CRS and origin), for its rings and
    for :meth:`Frame.at` in its messages."""
    return Frame(job.frame[0], (job.frame[1], job.frame[2]))


def block_where(job: BlockJob, poly: shapely.Polygon) -> str:
    """How messages name a street or zone block: its id and a point inside it in the
    input's coordinates (lon/lat, or the projected CRS kept), as a GIS finds it; the
    run's local metres until 2026-11-30 ("block b2d14cdec07 at (495.6, -42.3)")."""
    c = poly.representative_point()
    return f"block {job.id} at {job_frame(job).at((c.x, c.y))}"


def prepare(job: BlockJob, db: PartDB, longer: float = 0.0,
            close: tuple[tuple[float, float], ...] = ()) -> Prepared | str:
    """Clean the job's outline into rings (a footprint faithfully, a street block as
    before); a string says why nothing is left (the block is skipped). A footprint
    side left too short to build raises the user's error naming it. ``longer`` raises
    the shortest side kept (a retry when no layout fits the faithful outline: short
    sides between joints fit only some lengths); ``close`` holds a point in each
    light well to close (a retry when one blocks every layout, :func:`well_blocking`)."""
    poly = shapely.from_wkt(job.wkt)
    frame = job_frame(job)
    fp = job.footprint
    if fp is None:
        return _street_block(job, db, poly, frame)
    shortest = min_side(db, job.style, job.slack) + longer
    walls = party_lines(fp.party)   # cleaning and niche filling keep off them
    clean = clean_footprint(poly, min_side=shortest, straight_tol=STRAIGHT_TOL,
                            tolerance=fp.tolerance, party=walls)
    if clean is None:
        return "nothing buildable is left of its outline once cleaned"
    props = {"id": fp.ref} if fp.ref else {}
    closed: list[float] = []     # the areas of the courtyards closed, m²
    unlined: list[float] = []
    if close:   # light wells no layout can line (a 4 m side between corners): closed
        wells = [shapely.Polygon(r) for r in clean.interiors]
        shut = {i for i, w in enumerate(wells)
                if any(w.contains(shapely.Point(p)) for p in close)}
        unlined = [wells[i].area for i in sorted(shut)]
        clean = shapely.Polygon(clean.exterior, [r for i, r in enumerate(clean.interiors)
                                                 if i not in shut])
    narrowed: list[tuple[int, float]] = []      # per filling: niches, m²
    tries = len(clean.interiors) + MAX_NARROW    # each courtyard once, and some more
    while True:
        rings = skeletons_from_polygons([Feature(fp.feature, clean, props)], frame)
        bad = short_side(rings, shortest)
        hole = _courtyard(bad[0].name) if bad is not None else None
        well = shapely.Polygon(clean.interiors[hole]) if hole is not None else None
        if well is not None and hole is not None and well.area >= LIGHT_WELL \
                and len(narrowed) < tries:
            fixed = _niche_filled(clean, hole, shortest, walls)
            if fixed is not None:
                again = clean_footprint(fixed[0], min_side=shortest,
                                        straight_tol=STRAIGHT_TOL, tolerance=fp.tolerance,
                                        party=walls)
                if again is not None:
                    narrowed.append(fixed[1])
                    clean = again
                    continue
        if well is None or well.area >= LIGHT_WELL:
            break
        # a light well the kit's facades cannot line: closed under the roof
        closed.append(well.area)
        clean = shapely.Polygon(clean.exterior, [r for i, r in enumerate(clean.interiors)
                                                 if i != hole])
    if bad is not None:
        raise SkeletonError(too_short(fp.where, job.frame, fp.source_crs, bad[1], shortest,
                                      job.style))
    parts, storeys, note = choose_family(fp, db, job.style)
    why = [f"{courtyards_said(closed)} closed under the roof (sides under the {shortest:.1f} "
           f"m the {job.style} kit needs)"] if closed else []
    if narrowed:
        niches = sum(n for n, _a in narrowed)
        why.append(f"{niches} niche{'s' if niches > 1 else ''} of "
                   + (f"{len(narrowed)} courtyards" if len(narrowed) > 1 else "a courtyard")
                   + f" filled under the roof ({sum(a for _n, a in narrowed):.1f} m²; "
                   f"narrower than the {shortest:.1f} m the {job.style} kit needs between "
                   "two corners)")
    if unlined:
        why.append(f"{courtyards_said(unlined)} closed under the roof (no layout of the "
                   f"{job.style} kit lines it)")
    notes = [fp.remarks or None, note, f"{fp.where}: {'; '.join(why)}" if why else None,
             fp.trimmed or None]
    return Prepared(rings, fp.where, fp.stretch, job.slack, parts, storeys,
                    "\n".join(n for n in notes if n) or None)


def courtyards_said(areas: Sequence[float], most: int = 3) -> str:
    """Courtyards of these areas (m²) in a note: each ("a 4.0 m² courtyard and a 6.5 m²
    courtyard") up to ``most``, else how many and how large (a footprint of 1,000
    light wells had a note of 23,112 characters, the same words each time)."""
    if len(areas) <= most:
        return " and ".join(f"a {a:.1f} m² courtyard" for a in areas)
    lo, hi = f"{min(areas):.1f}", f"{max(areas):.1f}"
    return (f"{len(areas):,} courtyards of " + (f"{lo} m² each" if lo == hi else
                                                f"{lo} to {hi} m² ({sum(areas):,.1f} m² in all)"))


def party_lines(party: Sequence[tuple[float, float, float, float]]
                ) -> shapely.MultiLineString | None:
    """A footprint's party walls (its job's stretches, (x0, y0, x1, y1) each) as one
    geometry, None when it has none."""
    if not party:
        return None
    return shapely.multilinestrings([[(x0, y0), (x1, y1)] for x0, y0, x1, y1 in party])


def _niche_filled(poly: shapely.Polygon, hole: int, width: float,
                  party: shapely.MultiLineString | None = None
                  ) -> tuple[shapely.Polygon, tuple[int, float]] | None:
    """``poly`` with the niches and slots of its courtyard ``hole`` narrower than
    ``width`` (where a side too short for two corners comes from one) filled under the
    roof, as a light well too small to line is closed: the courtyard's morphological
    opening, square-cornered, so a rectangular courtyard keeps its corners. (The
    outline's narrow notches are cleaning's: it makes them flat walls; a narrow wing is
    never cut off, and its side is told of.) With how many niches and m² it filled;
    None when that fills nothing, more than :data:`NARROW_AREA` of the footprint's area
    (the side is then no narrow niche: the user hears of it as before), or ground
    beside another building (on the ``party`` walls' lines, :func:`party_lines`: a
    neighbour standing in the niche would be built into: within a shared wall's
    :data:`TOUCH` of its ground)."""
    r = width / 2
    square = {"join_style": "mitre", "mitre_limit": 10.0}
    well = shapely.Polygon(poly.interiors[hole])
    opened = shapely.buffer(shapely.buffer(well, -r, **square), r, **square)
    filled = shapely.difference(well, opened)
    fixed = shapely.union(poly, filled)
    if not isinstance(fixed, shapely.Polygon) or not fixed.is_valid \
            or not MIN_NARROW < filled.area <= NARROW_AREA * poly.area:
        return None
    if party is not None and shapely.intersects(shapely.buffer(filled, TOUCH), party):
        return None
    parts = shapely.get_parts(filled)
    return fixed, (int((shapely.area(parts) > MIN_NARROW).sum()), float(filled.area))


def _courtyard(ring_name: str) -> int | None:
    """The index among the polygon's holes of the ring named ``... courtyard <n>``
    (:func:`~citysynth.skeletons.skeletons_from_polygons` numbers them from 1)."""
    m = re.search(r" courtyard (\d+)$", ring_name)
    return int(m.group(1)) - 1 if m else None


def failure(prep: Prepared, job: BlockJob, db: PartDB, blocked_at: BlockedAt | None) -> str:
    """Why a prepared block has no layout, in its user's words."""
    asked = ", ".join(f"{kind} {n} = [{lo:g}, {hi:g}]" for kind, rows in
                      (("per_side", job.per_side), ("per_block", job.per_block))
                      for n, lo, hi in rows)
    return explain(prep.where, job.frame,
                   job.footprint.source_crs if job.footprint else "", prep.rings, db,
                   job.style, prep.parts, prep.tol(db.quantum), asked, blocked_at)


# --- streets and footprints together ---------------------------------------------------

BLOCK_DEPTH = 15.0    # m: the deepest massing of the sample library (14 m and a 0.6 m variant)
CUT = "cut"           # marks an outline that is a street block cut back (cleaned faithfully)
GAP = 3.0             # m: a lane between footprint buildings and what is left of a block
STREET_TOUCH = 0.01   # m: a piece of a block this near its outline reaches its street


def cut_back(blocks: list[shapely.Polygon], buildings: list[shapely.Polygon], *,
             min_area: float, min_width: float, depth: float = BLOCK_DEPTH,
             locate: Callable[[tuple[float, float]], str] = local_xy
             ) -> tuple[list[shapely.Polygon], list[str]]:
    """Street blocks with the ground of footprint buildings taken out (and ``GAP``
    around them), so that no two facades share ground: what is left of a block is kept
    where it is at least ``depth`` wide (a facade's mass, ``depth`` deep, stays on its
    own piece), in pieces of ``min_area`` and ``min_width`` that reach the block's
    outline (a street); the reasons for the rest. A building's courtyards are its own
    ground, and a yard the buildings close round has no street: a block was built in
    the courtyard of a building of the district, another in the yard its neighbours
    enclose. ``locate`` words a point for the reasons (the run's :meth:`Frame.at`: the
    input's coordinates)."""
    if not buildings:
        return blocks, []
    taken = shapely.union_all([shapely.Polygon(p.exterior).buffer(GAP, join_style="mitre")
                               for b in buildings for p in polygons_in(b)])
    out, why = [], []
    for block in blocks:
        if not block.intersects(taken):
            out.append(block)
            continue
        left = block.difference(taken).buffer(-depth / 2, join_style="mitre") \
            .buffer(depth / 2, join_style="mitre").intersection(block.difference(taken))
        c = block.representative_point()
        kept = enclosed = 0
        street = block.exterior.buffer(STREET_TOUCH)
        for piece in shapely.get_parts(left):
            if not isinstance(piece, shapely.Polygon) or piece.is_empty:
                continue
            if piece.area < min_area or mean_width(piece) < min_width:
                continue
            if piece.exterior.intersection(street).length < min_width:
                enclosed += 1
                continue
            out.append(shapely.geometry.polygon.orient(piece, 1.0))
            kept += 1
        if enclosed:
            why.append(f"block at {locate((c.x, c.y))}: {enclosed} yard(s) the footprint "
                       "buildings close round (no street reaches them) left open")
        if not kept:
            why.append(f"block at {locate((c.x, c.y))}: its ground is taken by footprint "
                       "buildings (what is left is too small or too thin for a facade, "
                       "or a yard no street reaches)")
    return out, why


def cut_back_outlines(outlines: list, *, min_area: float, min_width: float,
                      locate: Callable[[tuple[float, float]], str] = local_xy
                      ) -> tuple[list, list[str]]:
    """:func:`cut_back` on a run's outlines ``(kind, polygon, highways, spec)``: street
    blocks lose the ground of the footprints among them; each piece left keeps its
    block's streets."""
    buildings = [o[1] for o in outlines if o[0] == "footprint"]
    out, why = [], []
    for o in outlines:
        if o[0] != "block":
            out.append(o)
            continue
        pieces, reasons = cut_back([o[1]], buildings, min_area=min_area, min_width=min_width,
                                   locate=locate)
        out += [(o[0], p, o[2], CUT if p is not o[1] else o[3]) for p in pieces]
        why += reasons
    return out, why


def well_blocking(prep: Prepared, blocked_at: BlockedAt | None) -> tuple[float, float] | None:
    """A point in the light well (a courtyard under :data:`LIGHT_WELL`) a failed
    footprint is blocked on, so a retry closes it under the roof; else None."""
    if blocked_at is None or _courtyard(blocked_at[0]) is None:
        return None
    ring = next((r for r in prep.rings if r.name == blocked_at[0]), None)
    if ring is None or len(ring.keypoints) < 3:
        return None
    well = shapely.Polygon([k.xy for k in ring.keypoints])
    if not well.is_valid or well.area >= LIGHT_WELL:
        return None
    p = well.representative_point()
    return (p.x, p.y)


def prepare_again(job: BlockJob, db: PartDB) -> Prepared | None:
    """A footprint no layout fits, cleaned again with sides ``RETRY_SIDE`` longer (less
    faithful, more buildable); None when that leaves nothing to try."""
    try:
        again = prepare(job, db, longer=RETRY_SIDE)
    except SkeletonError:
        return None
    return None if isinstance(again, str) else again
