"""Street blocks of a ``row`` or ``towers`` zone (city.toml ``kind``): what they become,
by the modules ``citysynth street`` and ``citysynth tower`` use.

A **row** block is a street front along each of its sides: the block, inset by the
zone's ``setback``, is cut into runs at its corners
(:func:`~citysynth.pipeline.streets.ring_runs`), each run shortened at a convex corner
by what the buildings' depth needs, so neighbouring sides' rows meet without
overlapping; a run whose row would cross another's (a block narrower than two rows)
or leave the block stays empty (:func:`~citysynth.pipeline.streets.clear_runs`). Each
run is filled exactly, within the stretch tolerance, with the library's complete
buildings (:func:`~citysynth.pipeline.streets.solve_runs`), ``per_side`` intervals
holding on each run.

A **towers** block is cut into lots of about the zone's ``lot`` size
(:func:`~citysynth.pipeline.towers.cut_lots`); every lot some ground floor and roof
fit gets a tower (:func:`~citysynth.pipeline.towers.solve_tower`) of a height in the
zone's ``height`` interval (near one drawn per lot from the seed, :func:`lot_height`,
when some tower meets it) and a floor-area ratio in its ``far`` interval, centred on
the lot and turned to its longer side.

Either way the block's k layouts are a :class:`~citysynth.pipeline.layouts.Built`, kept
and written by the city job exactly as a perimeter block's (layout JSON, USD).
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING

import shapely

from citysynth.parts_db import PartDB
from citysynth.pipeline.city.footprints import Prepared, block_where, job_frame
from citysynth.pipeline.layouts import Built
from citysynth.pipeline.streets import (
    CITY_LOOSEN,
    MIN_RUN,
    RING_SIMPLIFY,
    Run,
    StreetAsk,
    building_depth,
    clear_runs,
    ring_runs,
    solve_runs,
)
from citysynth.pipeline.towers import Lot, cut_lots, fitted_lot, solve_tower, towers_layout

if TYPE_CHECKING:   # the job module imports this one
    from citysynth.pipeline.city.jobs import BlockJob


def solve_kind(job: BlockJob, db: PartDB) -> str | tuple[Prepared, Built]:
    """The k best layouts of a row or towers block (infeasible with the reason in the
    user's words), or why nothing is left to build on it; as a perimeter block's
    (:func:`~citysynth.pipeline.city.jobs.solve_block`), with no rings prepared."""
    built = _solve_kind(job, db)
    if isinstance(built, str):
        return built
    return Prepared([], built.name, job.stretch, job.slack, None), built


def _solve_kind(job: BlockJob, db: PartDB) -> Built | str:
    assert job.zone_kind is not None
    poly = shapely.from_wkt(job.wkt)
    where = block_where(job, poly)
    setback = job.zone_kind.setback
    ground = poly.buffer(-setback, join_style="mitre") if setback else poly
    if ground.is_empty:
        return f"nothing is left of it once inset by the zone's setback ({setback:g} m)"
    frame = job_frame(job).describe()
    if job.zone_kind.kind == "row":
        return _row(job, db, ground, frame, where)
    return _towers(job, db, ground, frame, where)


def _row(job: BlockJob, db: PartDB, ground: shapely.Geometry, frame: str,
         where: str) -> Built | str:
    depth = building_depth(db.select("building", job.style))
    sides = [r for p in shapely.get_parts(ground) if isinstance(p, shapely.Polygon)
             for r in ring_runs(p, depth)]
    straight = ground.simplify(RING_SIMPLIFY)      # the ground the runs were cut from
    kept = [Run("side", i, r.line) for i, r in enumerate(clear_runs(sides, straight, depth))]
    if not kept:
        return (f"no side is a straight run of at least {MIN_RUN:g} m with room for a row "
                f"{depth:.1f} m deep behind it")
    ask = StreetAsk(("left",), 0.0, job.stretch, job.slack, job.per_side, job.style, job.k,
                    CITY_LOOSEN)
    built = solve_runs(job.id, kept, db, ask, frame)
    if built.status != "ok":   # the side, why, and what to loosen in city.toml's words
        built.reason = f"{where}: {built.reason}"
    return built


def _towers(job: BlockJob, db: PartDB, ground: shapely.Geometry, frame: str,
            where: str) -> Built | str:
    zk = job.zone_kind
    assert zk is not None
    lots = [lot for lot in (fitted_lot(db, Lot.from_polygon(p, frame), job.style)
                            for p in cut_lots(ground, zk.lot)) if lot is not None]
    if not lots:
        return (f"no lot of about {zk.lot:g} m cut from it takes a ground floor and a roof "
                f"of the {job.style} towers (a smaller lot in the zone would)")
    towers, timings = [], dict[str, float]()
    for i, lot in enumerate(lots):
        b = solve_tower(f"lot_{i}", db, lot, lot_height(job, i), zk.far, style=job.style,
                        k=job.k)
        if b.status != "ok":   # nothing near the drawn height: any of the zone's
            b = solve_tower(f"lot_{i}", db, lot, zk.height, zk.far, style=job.style, k=job.k)
        for key, v in b.timings.items():
            timings[key] = timings.get(key, 0.0) + v
        if b.status != "ok":
            at = job_frame(job).at(lot.centre)   # lon/lat or the kept CRS
            return Built(job.id, "infeasible", timings=timings, reason=(
                f"{where}: lot {i} at {at}: no tower of the {job.style} "
                f"parts that fit it meets {b.reason}; widen the zone's height or far"))
        towers.append(b.layouts)
    count = max(len(t) for t in towers)
    layouts = [towers_layout(job.id, r + 1, [t[min(r, len(t) - 1)] for t in towers])
               for r in range(count)]
    return Built(job.id, "ok", layouts, timings=timings)


HEIGHT_BAND = 0.05    # a lot's drawn heights: this share of the zone's interval (or 2 m)


def lot_height(job: BlockJob, lot: int) -> tuple[float, float]:
    """The heights lot number ``lot`` of the block tries first: a band round a height
    drawn from the zone's interval by the seed, the block and the lot (a skyline, not
    every lot's one cheapest tower; the same on every run)."""
    assert job.zone_kind is not None
    lo, hi = job.zone_kind.height
    h = hashlib.sha256(f"{job.seed}:{job.id}:{lot}".encode()).digest()
    at = lo + (hi - lo) * int.from_bytes(h[:8], "big") / 2 ** 64
    band = max(2.0, HEIGHT_BAND * (hi - lo))
    return max(lo, at - band), min(hi, at + band)
