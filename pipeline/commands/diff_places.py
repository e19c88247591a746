"""Blocks two city runs drew in the same place under other ids.

A block's id is a hash of its outline to the millimetre, so a street file re-exported
by another tool (a round trip through Web Mercator, a Shapefile's rounding, a vertex
added on a straight stretch, a ring drawn the other way) gives the blocks it moved by a
fraction of a millimetre new ids, and a diff by id alone called them all removed and
added. Here a block only run A has and one only run B has are the same block when they
are of the same kind (street block or footprint) and their outlines lie within
:data:`SAME_PLACE` metres of each other everywhere (the Hausdorff distance); each block
pairs at most once, nearest first.

The outlines are read from each run's ``blocks.geojson`` (lon/lat, or the run's kept
CRS in metres); loaded only when both runs have blocks the other lacks, so a diff of
runs with the same ids loads no geometry library.
"""

from __future__ import annotations

import math
from pathlib import Path

from citysynth.skeletons.degrees import in_degrees

SAME_PLACE = 0.05   # m: outlines this close everywhere are one block re-drawn
_M_PER_DEG = 111_320.0   # metres a degree of latitude spans (and of longitude at 0°)


def same_places(run_a: Path, run_b: Path, removed: list[str],
                added: list[str]) -> list[tuple[str, str, float]]:
    """``(id in A, id in B, metres apart)`` for each removed block of run A that run B
    drew in the same place as an added one; empty when either run has no
    ``blocks.geojson`` (a run folder of an older version)."""
    if not (removed and added):
        return []
    from citysynth.pipeline.commands.diff_map import BLOCKS, outlines

    if not ((run_a / BLOCKS).exists() and (run_b / BLOCKS).exists()):
        return []
    (a, crs_a), (b, crs_b) = outlines(run_a), outlines(run_b)
    olds = _metres({bid: a[bid][0] for bid in removed if bid in a}, crs_a)
    news = _metres({bid: b[bid][0] for bid in added if bid in b}, crs_b)
    if not (olds and news):
        return []
    import shapely

    ids = sorted(news)
    tree = shapely.STRtree([news[i] for i in ids])
    candidates: list[tuple[float, str, str]] = []
    for old in sorted(olds):
        near = tree.query(olds[old], predicate="dwithin", distance=SAME_PLACE)
        for j in sorted(int(n) for n in near):
            new = ids[j]
            if old[:1] != new[:1]:   # a street block never pairs with a footprint
                continue
            apart = float(shapely.hausdorff_distance(olds[old], news[new]))
            if apart <= SAME_PLACE:
                candidates.append((apart, old, new))
    pairs: list[tuple[str, str, float]] = []
    taken: set[str] = set()
    for apart, old, new in sorted(candidates):
        if old not in taken and new not in taken:
            taken |= {old, new}
            pairs.append((old, new, round(apart, 4)))
    return sorted(pairs)


def _metres(shapes: dict, crs: str | None) -> dict:
    """Outlines in metres about where they stand: in lon/lat first (a run kept in its
    input's CRS, EPSG:3857 or a national grid, writes its outlines in it, so two runs
    of one city in two CRSs compare), then scaled by the metres a degree spans there
    (an outline is a few hundred metres across: the scale's change over it is far
    below :data:`SAME_PLACE`)."""
    import numpy as np
    import shapely

    if crs is not None and shapes:
        from pyproj import CRS, Transformer

        try:
            given = CRS.from_user_input(crs)
        except Exception:   # pyproj's CRSError: a name no tool resolves; as it is
            given = None
        if given is not None and not given.is_geographic:
            to = Transformer.from_crs(given, 4326, always_xy=True)
            shapes = {k: shapely.transform(g, lambda xy: np.column_stack(
                to.transform(xy[:, 0], xy[:, 1]))) for k, g in shapes.items()}
    out = {}
    for k, g in shapes.items():
        x0, y0, x1, y1 = g.bounds
        if in_degrees(x0, y0, x1, y1):
            east = _M_PER_DEG * math.cos(math.radians((y0 + y1) / 2))
            g = shapely.transform(g, lambda xy, e=east: xy * [e, _M_PER_DEG])
        out[k] = g
    return out
