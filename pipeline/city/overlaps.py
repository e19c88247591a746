"""Footprints that overlap: each piece of ground gets one building's facades.

Real footprint files overlap: a tower or a wing mapped as its own building inside the
building it belongs to (OpenStreetMap's Helsinki cathedral has six), a building drawn
twice, neighbours whose shared wall was digitised twice and crosses by a few
centimetres. Built as they are, two sets of facades stand in the same ground: walls
inside walls, and a neighbour's corner sticking through the street front.

The rule, larger first (by area, then feature order, so it never depends on which file
order a GIS wrote):

- the largest footprint is kept whole (whether its layout is then found or not);
- a footprint with at least half its area under larger ones is left out, and the report
  says inside which (a building part, or a building drawn twice);
- a footprint that overlaps larger ones less is trimmed to the ground they leave, and
  its block's note says by how much and where; slivers the trim leaves thinner than
  ``2 * OPEN`` go, and so do pieces under ``min_area``;
- overlaps under ``TOUCH`` are left alone (numerical noise of a shared wall), and so is
  the same outline drawn twice, which the run builds once and reports as such.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import shapely

from citysynth.export.ground import polygons_in
from citysynth.pipeline.city.footprints import FootprintSpec
from citysynth.pipeline.city.jobs import outline_wkt

TOUCH = 0.01      # m²: smaller overlaps are noise along a shared wall
INSIDE = 0.5      # share of a footprint under larger ones from which it is left out
OPEN = 0.05       # m: half the width of a sliver a trim may leave (removed)


@dataclass(frozen=True)
class Footprint:
    """A footprint polygon (in the city frame) and its feature."""

    polygon: shapely.Polygon
    spec: FootprintSpec


def _share(share: float) -> str:
    """A share of a footprint in words that never round up to all of it: two drawings
    5 mm apart overlap by 99.97 %, which read "100 %"."""
    if share >= 1 - 1e-9:
        return "all"
    pct = 100 * share
    return f"{math.floor(pct):.0f} %" if pct < 99 else f"{math.floor(pct * 100) / 100:g} %"


def separate(footprints: list[Footprint], min_area: float
             ) -> tuple[list[Footprint], list[tuple[str, shapely.Polygon]]]:
    """The footprints to build (in input order, a trimmed one with its note and as many
    pieces as the trim leaves) and the ones left out, each with its reason."""
    order = sorted(range(len(footprints)),
                   key=lambda i: (-footprints[i].polygon.area, footprints[i].spec.feature, i))
    tree = shapely.STRtree([f.polygon for f in footprints])
    # one number per distinct outline: the same outline drawn 20,000 times meets itself
    # 400 M times, which a Python loop took minutes over and numpy drops at once
    outline = np.unique([outline_wkt(f.polygon) for f in footprints], return_inverse=True)[1]
    kept: dict[int, list[Footprint]] = {}
    left: dict[int, tuple[str, shapely.Polygon]] = {}
    for i in order:
        fp = footprints[i]
        near = tree.query(fp.polygon)
        under = [j for j in np.sort(near[outline[near] != outline[i]]).tolist()
                 if j in kept
                 and sum(fp.polygon.intersection(k.polygon).area for k in kept[j]) > TOUCH]
        if not under:
            kept[i] = [fp]
            continue
        rest = fp.polygon.difference(shapely.union_all([k.polygon for j in under
                                                        for k in kept[j]]))
        share = 1.0 - rest.area / fp.polygon.area
        where = names_of(fp.spec, [footprints[j].spec for j in under])
        if share >= INSIDE:
            larger = max(footprints[j].polygon.area for j in under)
            size = "larger" if larger > fp.polygon.area * (1 + 1e-3) else "as large"
            left[i] = (f"{fp.spec.where}: {_share(share)} of it lies inside {where}, "
                       f"{size} and kept; left out (a part of that building, or the same "
                       "building drawn twice)", fp.polygon)
            continue
        pieces = _pieces(rest, min_area)
        if not pieces:
            left[i] = (f"{fp.spec.where}: what {where} (larger, kept) leaves of it is "
                       f"slivers under min_area {min_area:g} m²; left out", fp.polygon)
            continue
        lost = fp.polygon.area - sum(p.area for p in pieces)
        note = (f"{fp.spec.where}: trimmed by {lost:.2f} m² where it overlapped "
                f"{where}, larger and kept whole")
        kept[i] = [Footprint(p, replace(fp.spec, trimmed=note)) for p in pieces]
    return ([f for i in range(len(footprints)) for f in kept.get(i, [])],
            [left[i] for i in range(len(footprints)) if i in left])


def names_of(spec: FootprintSpec, others: list[FootprintSpec]) -> str:
    """Other footprints as ``spec``'s messages name them: by feature (and file, when
    theirs is another), joined by "and"."""
    return " and ".join(o.label if o.source == spec.source else o.where for o in others)


def _pieces(rest: shapely.Geometry, min_area: float) -> list[shapely.Polygon]:
    """The polygons a trim leaves, slivers opened away, each of ``min_area`` or more."""
    opened = shapely.buffer(shapely.buffer(rest, -OPEN, join_style="mitre"), OPEN,
                            join_style="mitre")
    opened = shapely.intersection(opened, rest)    # the opening never grows the ground
    return [g for g in polygons_in(shapely.make_valid(opened)) if g.area >= min_area]
