"""A city run: streets (and footprints) in, a folder of blocks out. Independent
per-block jobs (:mod:`.jobs`) run in a local process pool, or on a Dask cluster; reruns
skip blocks whose inputs are unchanged. What the run leaves beside its blocks (manifest,
report, city stage, overview) is written by :mod:`.outputs`.

The run folder::

    OUT/city.usda            references every built block's layer
    OUT/city.png             overview: perspective beside a top view
    OUT/manifest.json        every block: input hash, status, files, cost (no timings,
                             so two runs of the same inputs write the same manifest)
    OUT/report.json          counts, reasons, bugs met (with tracebacks), time per stage
    OUT/blocks/<id>.layout.json, <id>.usda (its cut prototypes: <id>.cuts.usdc),
                             <id>.done.json, parts/<part>.usdc (library parts)
                             (k > 1: <id>.usda switches between <id>_<rank>.usda)
"""

from __future__ import annotations

import json
import os
import sys
import time
import warnings
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol, TextIO

import shapely

from citysynth.export.cuts import load_kernels
from citysynth.export.ground import polygons_in
from citysynth.export.usd import MATERIALS_DIR, PARTS_DIR
from citysynth.parts_db import PartDB, load_library
from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.files import sweep_temporaries
from citysynth.pipeline.city.config import BuildSettings, CityConfig, ZoneKind
from citysynth.pipeline.city.folder import BLOCKS_DIR, MARKER
from citysynth.pipeline.city.footprints import (
    CUT,
    FootprintSpec,
    cut_back_outlines,
    footprint_spec,
    not_built,
    street_crossings,
    style_families,
    wanted_storeys,
)
from citysynth.pipeline.city.gaps import with_gaps_closed
from citysynth.pipeline.city.jobs import (
    STATUSES,
    BlockJob,
    BlockKind,
    BlockRecord,
    block_id,
    cached,
    frame_tuple,
    outline_wkt,
    run_block,
    solve_block,
    usd_files,
    worker_library,
)
from citysynth.pipeline.city.outputs import Report, write_summary
from citysynth.pipeline.city.overlaps import TOUCH as OVERLAP_NOISE
from citysynth.pipeline.city.overlaps import Footprint, separate
from citysynth.pipeline.city.party import with_party_walls
from citysynth.pipeline.city.process import (
    run_lock,
    stop_pool,
    terminate_as_interrupt,
    worker_init,
)
from citysynth.pipeline.compile_notice import announce_compile
from citysynth.pipeline.errors import ConfigError, UsageError, shown
from citysynth.pipeline.layouts import check_style, default_style
from citysynth.pipeline.paths import same_input
from citysynth.pipeline.progress import progress_line
from citysynth.pipeline.towers import LARGEST_LOT, Lot, check_lot, far_bounds
from citysynth.skeletons import Feature, Features, Frame, parse_geojson, read_geojson
from citysynth.skeletons.clean import mean_width
from citysynth.skeletons.degrees import in_degrees
from citysynth.skeletons.errors import (
    FarFromFrame,
    FarFromFrameWarning,
    InputWarning,
    SkeletonError,
)
from citysynth.skeletons.from_geometry import why_invalid
from citysynth.skeletons.geojson import Accept, box_around
from citysynth.skeletons.streets import (
    Block,
    highway_classes,
    is_roundabout,
    not_a_street,
    street_blocks,
)

CONNECT_TIMEOUT = "10s"      # to reach a Dask scheduler
REPAIR_AREA = 0.01           # share of its area an invalid footprint's repair may change
ORIGIN_DIGITS = 2            # the frame's lon/lat origin, rounded: streets edited at the
                             # edge of a network do not move every block (and its id)

Outline = tuple[BlockKind, shapely.Polygon, tuple[str, ...], FootprintSpec | str | None]
"""kind, polygon, the highways along it, and a footprint's feature and settings (or CUT:
a street block cut back where footprints stand)"""
Progress = Callable[[int, int, BlockRecord], None]   # (done, to do, the record just done)


@dataclass
class CityInputs:
    jobs: list[BlockJob]
    skipped: list[dict]                  # pieces that never became jobs, with reasons
    frame: Frame
    timings: dict[str, float] = field(default_factory=dict)


def prepare(streets: str | Path | None, footprints: str | Path | None, cfg: CityConfig,
            library: str | Path | None, crs: str | None = None) -> CityInputs:
    """Read the inputs and turn every block and footprint into a job."""
    t0 = time.perf_counter()
    outlines: list[Outline] = []
    skipped: list[dict] = []
    frame = None
    lines: Features = Features()
    # one file given as both (a GeoJSON of streets and buildings): each reader leaves
    # the other's features out without a warning (each was "left out", twice over)
    both = streets is not None and footprints is not None and same_input(streets, footprints)
    if streets is not None:
        frame, lines = _street_outlines(streets, cfg, crs, outlines, skipped,
                                        "polygons" if both else None)
    if footprints is not None:
        fframe = _footprint_outlines(footprints, cfg, crs, frame, lines, outlines, skipped,
                                     "lines" if both else None)
        frame = frame or fframe
    if streets is not None and footprints is not None:   # no two facades share ground
        assert frame is not None       # both readers set it
        outlines, reasons = cut_back_outlines(outlines, min_area=cfg.min_area,
                                              min_width=cfg.min_width, locate=frame.at)
        skipped += [{"kind": "block", "reason": r} for r in reasons]
    if frame is None:
        raise ConfigError("nothing to build: give --streets, --footprints or both")
    jobs = _jobs(outlines, cfg, _zone_polygons(cfg, frame, crs, outlines), frame, library, skipped)
    return CityInputs(jobs, skipped, frame, {"inputs_s": time.perf_counter() - t0})


def _skip(kind: str, reason: str, outline: shapely.Geometry | None) -> dict:
    """A skipped piece: its kind and reason, and its outline (WKT, in the frame) for
    blocks.geojson only (report.json keeps kind and reason)."""
    rec = {"kind": kind, "reason": reason}
    if outline is not None and not outline.is_empty:
        rec["wkt"] = shapely.to_wkt(outline, rounding_precision=3)
    return rec


def _street_outlines(streets: str | Path, cfg: CityConfig, crs: str | None,
                     outlines: list[Outline], skipped: list[dict],
                     others: Accept | None = None) -> tuple[Frame, Features]:
    """The blocks between the streets (slivers skipped, with reasons); the frame and the
    streets (the lines that are streets, in it)."""
    feats, frame = read_geojson(streets, crs=crs, origin=cfg.origin,
                                origin_digits=ORIGIN_DIGITS, accept="lines", others=others)
    skipped += [{"kind": "feature", "reason": r} for r in feats.skipped]
    feats = _streets_only(feats, cfg.not_streets, streets, skipped)
    shapes: list = []
    blocks, reasons = street_blocks(feats, cfg.setbacks, min_area=cfg.min_area,
                                    skipped_shapes=shapes, locate=frame.at)
    skipped += [_skip("block", r, g) for r, g in zip(reasons, shapes, strict=True)]
    for b in blocks:
        width = mean_width(b.polygon)
        c = b.polygon.centroid
        if b.streets and all(is_roundabout(feats[i].properties) for i in b.streets):
            skipped.append(_skip("block", f"block at {frame.at((c.x, c.y))}: a roundabout's "
                                 "island (every street round it is junction=roundabout)",
                                 b.polygon))
            continue
        if width < cfg.min_width:
            skipped.append(_skip("block", f"block at {frame.at((c.x, c.y))}: a sliver, "
                                 f"{width:.1f} m wide on average (min_width "
                                 f"{cfg.min_width:g} m)", b.polygon))
            continue
        outlines.append(("block", b.polygon, _highways(b, feats), None))
    return frame, feats


def _streets_only(feats: Features, rules: tuple[str, ...], source: str | Path,
                  skipped: list[dict]) -> Features:
    """The lines that are streets: those ``rules`` (city.toml's ``not_streets``) call
    no street (footways, driveways) are left out, one skipped entry per rule; all of
    them left out is refused."""
    kept, left = Features(skipped=feats.skipped), Counter[str]()
    for f in feats:
        rule = not_a_street(f.properties, rules)
        if rule is None:
            kept.append(f)
        else:
            left[rule] += 1
    skipped += [{"kind": "feature", "reason": f"{source}: {n} line(s) with {rule} left out: "
                 "not streets (not_streets in city.toml)"} for rule, n in sorted(left.items())]
    if feats and not kept:
        raise ConfigError(f"{source}: every line is one of not_streets ("
                          + ", ".join(sorted(left)) + "); no street is left to bound a block. "
                          "Give the streets, or set not_streets in city.toml")
    return kept


def _footprint_outlines(footprints: str | Path, cfg: CityConfig, crs: str | None,
                        streets: Frame | None, lines: Features, outlines: list[Outline],
                        skipped: list[dict], others: Accept | None = None) -> Frame:
    """Every footprint polygon (invalid or small ones skipped, with reasons; one across
    a street's centre line, ``lines``, remarked on); the frame: the streets' when there
    are streets (each file read in its own CRS)."""
    feats, frame = read_geojson(footprints, crs=crs, origin=cfg.origin,
                                origin_digits=ORIGIN_DIGITS, accept="polygons",
                                within=streets, others=others)
    skipped += [{"kind": "feature", "reason": r} for r in feats.skipped]
    found: list[Footprint] = []
    fp = cfg.footprints
    tree = shapely.STRtree([f.geometry for f in lines])
    for f in feats:
        why = not_built(f.properties)
        if why:
            skipped.append(_skip("footprint", f"{footprints}: {f.name}: {why}; left out",
                                 f.geometry))
            continue
        for p in _one_building(f.geometry):
            if p.geom_type != "Polygon":
                raise ConfigError(f"{footprints}: {f.name}: footprints must be Polygons, "
                                  f"got {p.geom_type}")
            if not p.is_valid:
                fixed, why = _repaired(p, frame)
                if fixed is None:
                    skipped.append(_skip("footprint", f"{footprints}: {f.name}: {why}", p))
                    continue
                p = fixed
            if p.area < cfg.min_area:
                skipped.append(_skip("footprint", f"{footprints}: {f.name}: {p.area:.1f} m², "
                                     f"below min_area {cfg.min_area:g}", p))
                continue
            spec = footprint_spec(str(footprints), f.index, f.properties, frame.source_crs,
                                  fp.stretch, fp.tolerance, fp.storeys, fp.infill)
            if lines:
                spec = street_crossings(spec, p, lines, tree)
            found.append(Footprint(p, spec))
    built, left = separate(found, cfg.min_area)     # one building's facades per ground
    built = _once_per_outline(built, lambda fps: with_party_walls(  # none on a wall shared
        with_gaps_closed(fps)))                     # a wall drawn twice is one wall
    outlines += [("footprint", f.polygon, (), f.spec) for f in built]
    skipped += [_skip("footprint", why, p) for why, p in left]
    return frame


def _once_per_outline(built: list[Footprint],
                      step: Callable[[list[Footprint]], list[Footprint]]) -> list[Footprint]:
    """``step`` (closing gaps, finding party walls) done on the first footprint of each
    distinct outline; a copy of an outline (the same building drawn again, kept by
    :func:`~.overlaps.separate` to be told as a copy when its job is made) takes its
    first's outline as ``step`` left it. Copies met each other in ``step``: 800 copies of
    one Helsinki footprint took 264 s, growing as the cube of their number; and where
    the first grew to meet a neighbour, a copy could not grow over it, so it was built
    as a second, overlapping building."""
    first: dict[str, int] = {}
    of = [first.setdefault(outline_wkt(f.polygon), i) for i, f in enumerate(built)]
    distinct = sorted(first.values())
    done = dict(zip(distinct, step([built[i] for i in distinct]), strict=True))
    return [done[i] if i in done else replace(built[i], polygon=done[of[i]].polygon)
            for i in range(len(built))]


def _one_building(geom: shapely.Geometry) -> list[shapely.Geometry]:
    """A footprint feature's polygons; a MultiPolygon whose parts overlap (invalid, but
    written so by hand-drawn data) as their union: each part was a footprint of its own,
    the smaller "50 % of it lies inside feature 0", itself."""
    parts = list(shapely.get_parts(geom))
    if len(parts) < 2 or not all(p.geom_type == "Polygon" and p.is_valid for p in parts):
        return parts
    whole = shapely.union_all(parts)
    if sum(p.area for p in parts) - whole.area <= OVERLAP_NOISE:
        return parts
    return list(shapely.get_parts(whole))


def _repaired(p: shapely.Polygon, frame: Frame) -> tuple[shapely.Polygon | None, str]:
    """An invalid footprint made valid where that leaves one polygon (a zero-width spike
    drawn out and back, a repeated corner: the building itself is plain), else None and
    why, at the point in the input's coordinates (an outline crossing itself, a bowtie,
    is two buildings or a mistake: which, only the user knows). A repair that changes
    the ground covered (a courtyard drawn equal to its outline, or across it: GEOS made
    the first the solid outline, 2,400 m² of a building drawn as none) is no repair."""
    fixed = shapely.make_valid(p)
    polys = polygons_in(fixed)
    if len(polys) == 1 and abs(polys[0].area - p.area) <= max(1.0, REPAIR_AREA * p.area):
        return polys[0], ""
    what, fix = why_invalid(p, frame)   # GEOS's words as the skeletons say them
    return None, f"its outline is invalid: {what}; left out ({fix} in your GIS)"


def _jobs(outlines: list[Outline], cfg: CityConfig, zones: list[shapely.Geometry | None],
          frame: Frame, library: str | Path | None, skipped: list[dict]) -> list[BlockJob]:
    """One job per distinct outline, by id; the same outline again (a footprint drawn
    twice) is built once, and its second drawing is told among the skipped pieces."""
    libraries: dict[str, PartDB] = {}
    jobs: dict[str, BlockJob] = {}
    for z in cfg.zones:   # every zone of another kind is checked, blocks in it or not
        if z.kind.kind != "perimeter":
            _library_style(z.settings, library, libraries, z.kind, z.name, cfg)
    for kind, poly, highways, spec in outlines:
        wkt = outline_wkt(poly)
        zone_name, s, zk = _zone_for(cfg, zones, poly, highways)
        zone_kind = zk if kind == "block" and zk.kind != "perimeter" else None
        db, path, style = _library_style(s, library, libraries, zone_kind, zone_name, cfg)
        _check_resources(cfg, s, zone_name, db, path)
        job = BlockJob(block_id(kind, wkt), kind, wkt, frame_tuple(frame), zone_name, path,
                       db.library_hash, style, s.k, s.pick, cfg.seed,
                       tuple((n, lo, hi) for n, (lo, hi) in sorted(s.per_side.items())),
                       tuple((n, lo, hi) for n, (lo, hi) in sorted(s.per_block.items())),
                       cfg.stretch, cfg.corner_tolerance, cfg.mitre_cost,
                       cfg.min_edge, cfg.slack,
                       spec if isinstance(spec, FootprintSpec) else None,
                       cut=spec == CUT, zone_kind=zone_kind).with_hash()
        first = jobs.setdefault(job.id, job)
        if first is not job:
            here, there = _where(job), _where(first)
            file = here.split(": ", 1)[0] + ": "
            there = there.removeprefix(file) if here.startswith(file) else there
            skipped.append(_skip(kind, f"{here}: the same outline as {there}, built once"
                                 f"{_storeys_not_used(job, first)}", poly))
    if any(j.footprint is not None for j in jobs.values()):
        _check_families(cfg, list(libraries.values()))
    return sorted(jobs.values(), key=lambda j: j.id)


def _check_families(cfg: CityConfig, dbs: list[PartDB]) -> None:
    """Every style and family tag city.toml's ``[footprints]`` tables name is one the
    run's libraries have: a typo (``z = 4``) would otherwise drop the style's real
    families from the storey choice without a word."""
    where = f"{cfg.path}: " if cfg.path else ""
    for key, style, tag in cfg.footprints.named:
        have = [db for db in dbs if any(p.style == style for p in db.parts)]
        if not have:
            styles = sorted({p.style for db in dbs for p in db.parts})
            raise ConfigError(f"{where}{key}: the library has no style {shown(style)}; it has "
                              f"{', '.join(styles)}")
        tags = set().union(*(style_families(db, style) for db in have))
        if tags and tag not in tags:    # no tags at all: every part is the first family
            raise ConfigError(f"{where}{key}: no part of the {style} style has family "
                              f"{tag!r} (the _<letter> token of a part id, as _a0 in "
                              f"classic_mid_7.8_a0); its families are "
                              f"{', '.join(sorted(tags))}")


def _where(job: BlockJob) -> str:
    return job.footprint.where if job.footprint is not None else f"block {job.id}"


def _storeys_not_used(twin: BlockJob, built: BlockJob) -> str:
    """What of a footprint drawn twice the built drawing does not take: its storeys,
    when the two ask for different ones (levels 3 and 6 on one outline: the second's
    were dropped without a word)."""
    if twin.footprint is None or built.footprint is None:
        return ""
    mine, theirs = wanted_storeys(twin.footprint), wanted_storeys(built.footprint)
    if mine is None or mine == theirs:
        return ""
    asked = f"{theirs} storeys asked" if theirs is not None else "no storeys given"
    return f" ({asked} there; its own {mine} not used: delete one of the two)"


def _check_resources(cfg: CityConfig, s: BuildSettings, zone: str, db: PartDB,
                     path: str) -> None:
    """Every constrained name is the length or an attribute some part of the library
    has: a typo would otherwise fail every block, one by one."""
    known = {"length"} | {a for p in db.parts for a in p.attributes}
    for table, names in (("per_side", s.per_side), ("per_block", s.per_block)):
        for name in sorted(names):
            if name not in known:
                where = f"{cfg.path}: " if cfg.path else ""
                zone_of = f"zone {zone!r}: " if zone else ""
                raise ConfigError(f"{where}{zone_of}{table}.{name}: no part of the library "
                                  f"{path} has this attribute; it has "
                                  f"{', '.join(sorted(known))}")


def _library_style(s: BuildSettings, library: str | Path | None,
                   libraries: dict[str, PartDB], kind: ZoneKind | None = None,
                   zone: str = "", cfg: CityConfig | None = None) -> tuple[PartDB, str, str]:
    """The part database (each library loaded once, kept in ``libraries``), its folder
    and the style a block with settings ``s`` (of a zone of ``kind``) is built in
    (checked to exist). ``--library`` (``library``) wins over the config's top-level
    ``library``, as a flag over a file; a zone's own library holds in the zone. (The
    config's won: a city was built from another library than the command named, exit 0
    without a word, even with ``--library`` a missing folder.)"""
    top = cfg.settings.library if cfg is not None else None
    own = s.library if s.library and (s.library != top or not library) else None
    path = own or (str(Path(library).resolve()) if library else None)
    if path is None:
        raise ConfigError("no part library: give --library or library = \"...\" in the "
                          "config")
    where = f"{cfg.path if cfg and cfg.path else 'city.toml'}: " + (
        f"zone {zone!r}: " if zone else "")
    if path not in libraries:
        try:
            libraries[path] = load_library(path)
        except LibraryError as exc:   # a library city.toml names: say the key too
            if not own:
                raise
            raise ConfigError(f"{where}library = {shown(s.library)}: {exc}") from None
    db = libraries[path]
    if kind is not None:
        return db, path, _kind_style(db, s, kind, where)
    style = s.style or default_style(db)
    try:
        check_style(db, style)
    except UsageError as exc:
        raise ConfigError(f"{where}style: {exc}") from None
    return db, path, style


def _kind_style(db: PartDB, s: BuildSettings, kind: ZoneKind, where: str) -> str:
    """The style a row or towers zone builds in (a towers zone: its own ``style``, else
    the library's first style with towers), checked against the library and the zone's
    keys: a row takes no ``per_block`` (it is solved side by side), a towers zone's
    ``far`` must be within what its heights and lot size allow."""
    cls, what = ("ground_floor", "towers") if kind.kind == "towers" else \
        ("building", "complete buildings")
    styles = sorted({p.style for p in db.parts if p.cls == cls})
    if kind.kind == "towers":
        style = kind.style or (styles[0] if styles else "")
    else:
        style = s.style or default_style(db)
    if style not in styles:
        raise ConfigError(f"{where}style: the library {db.name!r} has no {what} of style "
                          f"{style!r}; it has {', '.join(styles) or 'none'}")
    if kind.kind == "row" and s.per_block:
        raise ConfigError(f"{where}per_block: a row is solved one side at a time, so "
                          "whole-block intervals cannot hold; use per_side (or per_block "
                          "= {} in the zone to drop an inherited one)")
    if kind.kind == "towers":
        try:   # the largest lot cut_lots keeps is 1.5 lot square
            check_lot(db, Lot.square((LARGEST_LOT * kind.lot) ** 2), style)
        except UsageError as exc:
            raise ConfigError(f"{where}lot: lots of about {kind.lot:g} m are too small for "
                              f"any tower: {exc}") from None
        lo, hi = far_bounds(db, style, kind.height, kind.lot)
        if kind.far[0] > hi or kind.far[1] < lo:
            raise ConfigError(
                f"{where}far: [{kind.far[0]:g}, {kind.far[1]:g}] cannot be met: towers of "
                f"{kind.height[0]:g}-{kind.height[1]:g} m of the {style} parts on lots of "
                f"about {kind.lot:g} m have a floor-area ratio between {_ratio(lo)} and "
                f"{_ratio(hi)}; ask within that, or change height or lot")
    return style


def _ratio(x: float) -> str:
    """A floor-area ratio as a message gives it: 0.30, or 2.5e-08 for an absurd lot."""
    return f"{x:.2f}" if 0.01 <= x < 1e4 else f"{x:.3g}"


def _highways(b: Block, feats: list[Feature]) -> tuple[str, ...]:
    """The classes of the streets around a block (a merged osmnx edge has several)."""
    return tuple(sorted({c for i in b.streets for c in highway_classes(feats[i].properties)}))


def _zone_polygons(cfg: CityConfig, frame: Frame, crs: str | None,
                   outlines: list[Outline]) -> list[shapely.Geometry | None]:
    """Each zone's polygon in the city frame (projected like the streets), or None for
    a zone chosen by street class; in the order of ``cfg.zones``. Polygons are lon/lat;
    with projected input they may also be written in the input's CRS (told apart by
    range: projected metres are never all within +-180, +-90).

    A zone polygon no block falls in is warned of, with how far the nearest block is:
    a zone whose points were mistyped, given as (lat, lon), or kept from another city's
    city.toml applies to none, which a user should hear. One so far away that the
    run's frame cannot hold it (the demo's city.toml, whose zones lie in Helsinki, run
    on New York's streets) is left out as an empty polygon, where the frame's check of
    far data refused the run, or warned of buildings too large that are not there,
    without saying that the zones were what lay far."""
    with_poly = [(z.name, z.polygon) for z in cfg.zones if z.polygon]
    if not with_poly:
        return [None] * len(cfg.zones)
    lonlat = all(in_degrees(x, y) for _, poly in with_poly for x, y in poly)
    zone_crs = None if lonlat else (frame.source_crs or crs)
    points = shapely.MultiPoint([o[1].representative_point() for o in outlines])
    geoms = iter([_zone_polygon(name, poly, zone_crs, frame, points)
                  for name, poly in with_poly])
    return [next(geoms) if z.polygon else None for z in cfg.zones]


ZONE_MARGIN = 1000.0   # m around the blocks a zone polygon is clipped to (see below)


def _zone_polygon(name: str, poly: tuple[tuple[float, float], ...], zone_crs: str | None,
                  frame: Frame, blocks: shapely.MultiPoint) -> shapely.Geometry:
    """One zone's polygon in the city frame (see :func:`_zone_polygons`); ``blocks``:
    the point of each block :func:`_zone_for` places by. A polygon reaching past the
    blocks is clipped to a box :data:`ZONE_MARGIN` around them first (a zone of the
    whole country, or of the world, was projected whole: told far from the frame, or
    garbled so that no block fell in it, "the nearest is 234,906 m outside it"). Not
    a polygon read as lon/lat that lies past +-180, +-90 (metres, where the input is
    lon/lat): clipped, the box round the blocks was all that was left of it, and the
    zone applied to every block where a smaller one in metres was refused."""
    shape: dict = {"type": "Polygon", "coordinates": [[*map(list, poly), list(poly[0])]]}
    source = f"city.toml zone {name!r}"
    off = [(x, y) for x, y in poly if not in_degrees(x, y)]
    if zone_crs is None and off:
        raise SkeletonError(f"{source}: its polygon's points such as {off[0][0]:g}, "
                            f"{off[0][1]:g} are not longitude/latitude, as the streets' "
                            "and footprints' are; give the zone's points as [lon, lat]")
    if not blocks.is_empty:
        x0, y0, x1, y1 = blocks.bounds
        box = box_around(frame, (x0 - ZONE_MARGIN, y0 - ZONE_MARGIN, x1 + ZONE_MARGIN,
                                 y1 + ZONE_MARGIN), zone_crs)
        near = shapely.clip_by_rect(shapely.Polygon(poly), *box)
        near = shapely.union_all([p for p in shapely.get_parts(near)
                                  if isinstance(p, shapely.Polygon) and not p.is_empty])
        if not near.is_empty:   # else the whole polygon, to say how far it lies
            shape = json.loads(shapely.to_geojson(near))
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": name}, "geometry": shape}]}
    far = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            (feat,), _ = parse_geojson(fc, source, zone_crs, within=frame)
            geom: shapely.Geometry = feat.geometry
        except FarFromFrame as e:
            geom, far = shapely.Polygon(), e.reach
    empty = geom.is_empty or not geom.intersects(blocks)
    for w in caught:
        if isinstance(w.message, FarFromFrameWarning) and empty:
            far = w.message.reach      # said below, as the zone's, not the buildings'
            continue
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if far is not None:
        warnings.warn(f"{source}: its polygon lies {far} east or west of the streets and "
                      "footprints, and no block falls in it: left out (is this city.toml "
                      "another place's? a zone's points are lon, lat)", InputWarning,
                      stacklevel=4)
        return shapely.Polygon()
    if empty and not blocks.is_empty:
        warnings.warn(f"{source}: no block falls in its polygon (the nearest is "
                      f"{geom.distance(blocks):,.0f} m outside it), so it applies to none",
                      InputWarning, stacklevel=4)
    return geom


def _zone_for(cfg: CityConfig, zones: list[shapely.Geometry | None], poly: shapely.Polygon,
              highways: tuple[str, ...]) -> tuple[str, BuildSettings, ZoneKind]:
    """The first zone the block falls in (its representative point inside the zone's
    polygon, or a street of the zone's classes along it), its settings and kind."""
    c = poly.representative_point()
    for z, geom in zip(cfg.zones, zones, strict=True):
        if (geom is not None and geom.contains(c)) or (set(z.highway) & set(highways)):
            return z.name, z.settings, z.kind
    return "", cfg.settings, ZoneKind()


# --- executing ------------------------------------------------------------------------

class _Finished(Protocol):
    """A finished future, local or Dask."""

    def result(self) -> BlockRecord: ...


RECYCLE_BLOCKS = 400
"""Blocks a local worker builds before it is replaced by a fresh fork of the warm parent.
A worker's resident memory grows by about 150 KB a block that nothing in Python holds
(usd-core keeps every prim name and path it has seen in its tables for good), so a
worker living through a 10,000-block city ended near 1 GB; replaced every 400 blocks,
the whole run's peak no longer depends on the city's size. A fork costs milliseconds."""


def _local(jobs: list[BlockJob], out: Path, workers: int) -> Iterator[BlockRecord]:
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            yield run_block(job, str(out))
        return
    warm_up(jobs[0])
    for batch in pool_batches(jobs, workers, RECYCLE_BLOCKS):
        yield from _pool(batch, out, workers)


def pool_batches(jobs: list[BlockJob], workers: int, per_worker: int) -> list[list[BlockJob]]:
    """``jobs`` in runs of ``workers * per_worker``, each for one pool of fresh workers
    (the last run takes a short remainder along rather than a pool of its own)."""
    size = max(1, workers * per_worker)
    cuts = list(range(0, len(jobs), size))
    if len(cuts) > 1 and len(jobs) - cuts[-1] < size // 4:
        cuts.pop()
    return [jobs[a:b] for a, b in zip(cuts, [*cuts[1:], len(jobs)], strict=False)]


def _pool(jobs: list[BlockJob], out: Path, workers: int) -> Iterator[BlockRecord]:
    """``jobs`` on a pool of ``workers`` processes forked for them, in finishing order."""
    pool = ProcessPoolExecutor(workers, initializer=worker_init, initargs=(os.getpid(),))
    try:
        futures = {pool.submit(run_block, job, str(out)): job for job in jobs}
        for fut in as_completed(futures):
            yield _result(fut, futures[fut])
    except BaseException:   # interrupted or terminated: stop now, not after the queue
        stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def warm_up(job: BlockJob) -> None:
    """Solve one block here before the local workers fork, discarding the answer, and
    run the cut kernels once: the workers inherit the compiled solver and cut kernels
    and the loaded library instead of each compiling them (a minute of CPU each on a
    first run) or loading them. Whatever goes wrong is left for the block's worker to
    meet and record."""
    try:
        solve_block(job, worker_library(job.library))
        load_kernels()
    except Exception:   # noqa: BLE001 - recorded where it belongs, by the block's worker
        return


def connect(address: str):
    """A Dask client for ``address``; any failure to reach or parse it is the user's."""
    try:
        from distributed import Client
    except ImportError:   # pragma: no cover - distributed is a dependency
        raise ConfigError("--scheduler needs the distributed package (pip install "
                          "distributed)") from None
    try:
        return Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise ConfigError(f"cannot reach the Dask scheduler at {address} ({exc}); start "
                          "one (dask scheduler), give its address as tcp://HOST:PORT, or "
                          "leave --scheduler out") from None


def _dask(jobs: list[BlockJob], out: Path, client) -> Iterator[BlockRecord]:
    from distributed import as_completed as dask_completed

    with client:
        futures = client.map(run_block, jobs, out_dir=str(out),
                             key=[f"citysynth-{j.id}-{j.input_hash[:8]}" for j in jobs])
        by_key = {f.key: j for f, j in zip(futures, jobs, strict=True)}
        for fut in dask_completed(futures):
            yield _result(fut, by_key[fut.key])


def _result(fut: _Finished, job: BlockJob) -> BlockRecord:
    """A finished job's record; a worker that died (killed, out of memory, lost from
    the cluster) fails its block instead of the run. No marker is written, so a rerun
    tries the block again."""
    try:
        return fut.result()
    except Exception as exc:  # the worker's own errors are records already
        return {"id": job.id, "kind": job.kind, "zone": job.zone, "style": job.style,
                "input_hash": job.input_hash, "files": [], "status": "failed",
                "reason": f"the worker running it died ({type(exc).__name__}: {exc})"}


def run_city(inputs: CityInputs, out_dir: str | Path, *, workers: int = 1,
             scheduler: str | None = None,
             progress: Progress | None = None) -> Report:
    """Run every job not already done; write the manifest and the report; the report.

    The scheduler is reached before the run folder is made (an unreachable one leaves
    nothing behind); the folder is locked for the run (:func:`run_lock`); SIGTERM stops
    the run as SIGINT does, the workers with it."""
    out = Path(out_dir)
    client = connect(scheduler) if scheduler else None
    with run_lock(out), terminate_as_interrupt():
        for folder in (out, out / BLOCKS_DIR, out / BLOCKS_DIR / PARTS_DIR,
                       out / BLOCKS_DIR / PARTS_DIR / MATERIALS_DIR):
            sweep_temporaries(folder)
        _remove_stale(out, {j.id for j in inputs.jobs})
        t0 = time.perf_counter()
        results: dict[str, BlockRecord] = {}
        todo = []
        tell = progress or (lambda done, total, rec: None)
        for job in inputs.jobs:
            rec = cached(out, job)
            if rec is not None:
                results[job.id] = {**rec, "cached": True}
                tell(len(results), len(inputs.jobs), results[job.id])
            else:
                todo.append(job)
        if todo and client is None:   # (said here, not before a config is read: a
            announce_compile()        # one-second refusal came after it)
        stream: Iterable[BlockRecord] = _dask(todo, out, client) if client else \
            _local(todo, out, workers)
        for rec in stream:
            results[rec["id"]] = rec
            tell(len(results), len(inputs.jobs), rec)
        t_blocks = time.perf_counter() - t0
        return write_summary(inputs, results, out, t_blocks, workers, scheduler)


def _remove_stale(out: Path, keep: set[str]) -> None:
    """Blocks of an earlier run whose inputs no longer exist leave the folder, so the
    folder always describes this run: those with a marker, and those a killed run left
    half-written without one (their layout JSON is written first; they stayed for
    good once the streets changed)."""
    blocks = out / BLOCKS_DIR
    ids = {m.name[: -len(suffix)] for suffix in (MARKER, ".layout.json")
           for m in blocks.glob(f"*{suffix}")}
    for bid in sorted(ids):
        if bid not in keep:
            for suffix in (".layout.json", MARKER):
                (out / BLOCKS_DIR / f"{bid}{suffix}").unlink(missing_ok=True)
            for layer in usd_files(out / BLOCKS_DIR, bid):
                layer.unlink(missing_ok=True)


def progress_printer(stream: TextIO | None = None, pieces: int = 0) -> Progress:
    """One updating line on a terminal; a line per tenth of the work otherwise. Its
    counts are the summary's: ``skipped`` starts at the ``pieces`` skipped before any
    block ran, and blocks served from an earlier run count as built (or failed, or
    skipped) as they were, and as cached. ``stream``: stderr (as it is when called)."""
    shown = progress_line(stream or sys.stderr)
    t0 = time.perf_counter()
    state = dict.fromkeys((*STATUSES, "cached", "ran"), 0)
    state["skipped"] = pieces

    def show(done: int, total: int, rec: BlockRecord) -> None:
        state[rec["status"]] += 1
        state["cached" if rec.get("cached") else "ran"] += 1
        rate = state["ran"] / max(time.perf_counter() - t0, 1e-9)
        bugs = f", internal errors {state['error']}" if state["error"] else ""
        # cached: blocks an earlier run finished, built or skipped (as the summary
        # counts them; "built 26 (28 cached)" read as more cached than built)
        cache = f", cached {state['cached']}" if state["cached"] else ""
        speed = f" ({rate:.1f} blocks/s)" if state["ran"] else ""
        shown(done, total, f"[{done:>{len(str(total))}}/{total}] built {state['built']}, "
                           f"failed {state['failed']}, skipped {state['skipped']}{cache}"
                           f"{bugs}{speed}")
    return show


