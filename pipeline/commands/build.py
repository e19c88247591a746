"""``citysynth building`` and ``citysynth block``: one GeoJSON in, for each of the k
best layouts its layout JSON, USD layer, GLB and PNG preview out.

``building`` reads building skeleton lines (one skeleton per file); ``block`` reads
block (or footprint) polygons, one block per Polygon feature, its holes as courtyard
cycles. Both exit 0 when every building or block got a layout, 1 when one is
infeasible (the reason on stderr; the others are still written), 2 on bad input.
"""

from __future__ import annotations

import hashlib
import re
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from citysynth.parts_db.files import all_or_nothing
from citysynth.pipeline.errors import MAX_STRETCH, UsageError, check_k, names_its_file, shown
from citysynth.skeletons.errors import SkeletonError

if TYPE_CHECKING:
    from citysynth.export.infill import Roof
    from citysynth.pipeline.layouts import BlockedAt, Built
    from citysynth.skeletons import Frame, Skeleton

# What the commands run (the solver, shapely, USD) is imported in the functions that
# run it, so the command line starts without it (see pipeline.cli).


def _options(args) -> dict[str, Any]:
    """What --stretch and --slack mean to the structure (the city's stretch and slack)."""
    return {"stretch": args.stretch, "slack": args.slack}


def _common(p) -> None:
    p.add_argument("--library", required=True, metavar="DIR",
                   help="part library folder (or a database written by citysynth ingest)")
    p.add_argument("--style", default=None,
                   help="facade style of the library to build with (default: the first)")
    p.add_argument("--k", type=int, default=1, help="number of layouts to write (default 1)")
    p.add_argument("--crs", default=None, help="CRS of projected input, e.g. EPSG:25832")
    p.add_argument("-o", "--out", default="out", metavar="DIR",
                   help="output folder (default: out/)")
    p.add_argument("--no-preview", action="store_true", help="skip the PNG previews")
    p.add_argument("--stretch", type=float, default=0.0, metavar="SHARE",
                   help="a side may be met within this share of its length, as in a city "
                        "(default 0: within half a quantum)")
    p.add_argument("--slack", type=float, default=0.0, metavar="M",
                   help="... or within this many metres, whichever is larger (default 0)")


def register(sub) -> None:
    p = sub.add_parser("building", help="lay out one building from skeleton lines",
                       description="Solve a building skeleton (GeoJSON LineStrings meeting at "
                                   "shared ends) with a part library and write layout JSON, "
                                   "USD, GLB and a PNG preview for each of the k best layouts.")
    p.add_argument("file", help="LineStrings: GeoJSON, or a GeoPackage, Shapefile, "
                   "FlatGeobuf, KML, Esri JSON, GML, MapInfo, GeoParquet, DXF or File "
                   "Geodatabase layer (FILE::LAYER)")
    _common(p)
    p.set_defaults(run=run_building, geometry="lines")   # the layer of a GIS file it reads
    p = sub.add_parser("block", help="lay out blocks from polygons",
                       description="Wrap facades around each block (or footprint) polygon of "
                                   "a GeoJSON file, courtyards included, and write layout "
                                   "JSON, USD, GLB and a PNG preview for each of the k best.")
    p.add_argument("file", help="Polygons: GeoJSON, or a GeoPackage, Shapefile, "
                   "FlatGeobuf, KML, Esri JSON, GML, MapInfo, GeoParquet, DXF or File "
                   "Geodatabase layer (FILE::LAYER)")
    _common(p)
    p.add_argument("--infill", action="store_true",
                   help="the polygons are building footprints: roof over the ground "
                        "deeper than the parts reach (without it, a street block keeps "
                        "its yards open and roofs only pockets narrower than 5 m)")
    p.set_defaults(run=run_block, geometry="polygons")


MAX_NAME = 100   # characters of a name kept as they are; its files add up to 20 more


def safe_name(text: str) -> str:
    """A file-name-safe version of a feature or file name: every character but ASCII
    letters, digits, ``.``, ``_`` and ``-`` made ``_``. One that lost letters outside
    ASCII, or is left empty, or is longer than :data:`MAX_NAME` (every file system takes
    255 bytes a name at most, and a layout's files add their rank, suffix and a
    temporary part), keeps its first 80 characters and a digest of the whole, so
    distinct ids stay distinct."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_.")
    if name and len(name) <= MAX_NAME and text.isascii():
        return name
    # letters no file name here keeps ("中文", "café"), nothing left, or too long: a
    # digest of the whole keeps distinct ids distinct
    digest = hashlib.sha1(text.encode("utf-8", "surrogatepass")).hexdigest()[:12]
    return f"{name[:80]}_{digest}" if name else f"id_{digest}"


def _prepare(args):
    from citysynth.parts_db import load_library
    from citysynth.pipeline.city.config import MAX_SLACK
    from citysynth.pipeline.layouts import default_style
    from citysynth.skeletons import read_geojson

    check_k(args.k, what="layouts")
    if not (0 <= args.stretch <= MAX_STRETCH) or not (0 <= args.slack <= MAX_SLACK):
        raise UsageError(f"--stretch is a share in [0, {MAX_STRETCH:g}] and --slack a number "
                         f"of metres in [0, {MAX_SLACK:g}]; got {args.stretch:g} and "
                         f"{args.slack:g}")
    db = load_library(args.library)
    style = args.style or default_style(db)
    feats, frame = read_geojson(args.file, crs=args.crs, layer_of=args.geometry)
    return db, style, feats, frame


def _why(args, db, style: str, frame: Frame, rings: list[Skeleton], built: Built) -> str:
    """Why a building or block has no layout, in its user's words: which side, how long,
    where (in the input's coordinates), and what to change; never stages or keys."""
    from citysynth.pipeline.city.footprints import describe_side, explain, stage_side
    from citysynth.pipeline.city.jobs import frame_tuple

    at = frame_tuple(frame)
    side = stage_side(rings, built.blocked_at)
    unmet = _unmet(built.blocked_at)
    if side is not None and unmet is not None and unmet[0] != "length":
        name, lo, hi, near = unmet   # a side's own interval (the feature's constraints)
        made = " or ".join(f"{x:g}" for x in near)
        return (f"{built.name}: {describe_side(at, frame.source_crs, *side)}: its {name} "
                f"in [{lo:g}, {hi:g}] cannot be met by the {style} kit's parts"
                + (f", which make {made} there" if made else "") + "; widen the interval")
    if args.command == "block":   # rings: what a city says of a footprint it cannot build
        return explain(built.name, at, frame.source_crs, rings, db, style, None,
                       lambda length: max(db.quantum / 2, args.slack, args.stretch * length),
                       "", built.blocked_at)
    if side is None:
        return (f"{built.name}: the {style} kit's parts cannot fill every side of the "
                "skeleton at once; allow more stretch (--stretch, --slack)")
    nearest = "" if not unmet or not unmet[3] else \
        f" (the nearest they make there is {' or '.join(f'{x:.2f}' for x in unmet[3])} m)"
    return (f"{built.name}: {describe_side(at, frame.source_crs, *side)}: no row of the "
            f"{style} kit's parts fits it between the parts its ends take{nearest}; allow "
            "more stretch (--stretch, --slack), or move the skeleton's points")


def _unmet(blocked_at: BlockedAt | None) -> tuple[str, float, float, list[float]] | None:
    """The interval the blocked stage's diagnosis finds out of reach on its own (its last
    blocking constraint, when nothing else is to blame), and what the parts make nearest
    it: ("doors", 60, 60, [12]); or None."""
    from citysynth.export.plan import FILLED
    from citysynth.solver.diagnose import nearest

    told = [d for d in blocked_at[1].details if d["constraint"] != FILLED] \
        if blocked_at is not None else []
    if not told:   # the pipeline's own count of middle parts is no user's interval
        return None
    d = told[-1]
    if d.get("blocks") != "alone":
        return None
    lo, hi = d["asked"]
    return d["constraint"], float(lo), float(hi), nearest(d)


def _finish(args, db, style: str, frame: Frame,
            built_all: list[tuple[Built, list[Skeleton]]]) -> int:
    """Write every layout (after all were solved and checked: a bad one writes
    nothing), report, and choose the exit code."""
    from citysynth.pipeline.layouts import chosen_formats, summary_line, write_outputs
    from citysynth.skeletons.gis_files import LAYER_SEP  # numpy: only when run (cli)

    formats = chosen_formats(preview=not args.no_preview)
    status = 0
    for built, rings in built_all:
        if built.status != "ok":
            print(f"citysynth {args.command}: cannot build "
                  f"{_why(args, db, style, frame, rings, built)}", file=sys.stderr)
            status = 1
    with all_or_nothing(args.out):
        inputs = [args.file, str(args.file).rpartition(LAYER_SEP)[0]]   # FILE::LAYER too
        written = [(built, write_outputs(built, db, args.out, formats=formats, k=args.k,
                                         inputs=inputs))
                   for built in _told([b for b, _rings in built_all if b.status == "ok"],
                                      "written")]
    for built, paths in written:
        print(f"{built.name}: {len(built.layouts)} layout(s)")
        for lay in built.layouts:
            print("  " + summary_line(lay))
        print(f"  wrote {len(paths)} files to {Path(args.out)}/ "
              f"(solve {1e3 * built.timings['solve_s']:.0f} ms, "
              f"export {1e3 * built.timings.get('export_s', 0):.0f} ms, "
              f"preview {1e3 * built.timings.get('preview_s', 0):.0f} ms)")
    return status


@names_its_file("file")
def run_building(args) -> int:
    from citysynth.pipeline.layouts import solve_layouts
    from citysynth.skeletons import skeleton_from_lines

    db, style, feats, frame = _prepare(args)
    name = safe_name(Path(args.file).stem)
    sk = skeleton_from_lines(feats, frame, name=name, min_edge=_smallest(db, style))
    built = solve_layouts(name, [sk], db, style, args.k, label=str(args.file),
                          **_options(args))
    return _finish(args, db, style, frame, [(built, [sk])])


@names_its_file("file")
def run_block(args) -> int:
    from citysynth.pipeline.city.party import party_walls
    from citysynth.pipeline.layouts import solve_layouts
    from citysynth.skeletons import skeletons_from_polygons
    from citysynth.skeletons.from_geometry import check_outlines

    db, style, feats, frame = _prepare(args)
    from citysynth.pipeline.city.footprints import Storeys, footprint_spec
    specs = {f.index: footprint_spec(args.file, f.index, f.properties, "", 0.0, 0.0,
                                     Storeys()) for f in feats}
    feats = _distinct(args, feats)
    check_outlines(feats, frame)   # before any note, and before GEOS overlays them (a
    #                                self-crossing outline over another failed there: exit 3)
    _check_names(args.file, *_block_names(args, feats)[:2], args.k)
    _storeys_note(args, feats, specs, style)
    feats = _gaps_closed(args, _overlaps_settled(args, feats, specs))
    names, ids, labels = _block_names(args, feats)
    _check_names(args.file, names, ids, args.k)     # the pieces of a trimmed one too
    rings = [skeletons_from_polygons([f], frame, min_edge=_smallest(db, style))
             for f in feats]
    walls = party_walls([f.geometry for f in feats])   # where features touch
    roof: Roof = "all" if args.infill else "pockets"     # footprints, or street blocks
    built = [(solve_layouts(name, r, db, style, args.k, infill=roof, label=label,
                            party=w, **_options(args)), r)
             for name, label, r, w in _told(list(zip(names, labels, rings, walls,
                                                     strict=True)), "laid out")]
    # once every block is solved: an outline refused on the way (a 2° tip) is told that
    # alone; one no row fits (exit 1) is told thin too, a likely cause
    _thin_note(args, feats)
    return _finish(args, db, style, frame, built)


def _block_names(args, feats: list) -> tuple[list[str], list[str], list[str]]:
    """Each feature's block name (its files'), id (what the messages quote) and label
    (where it is in the input)."""
    stem = safe_name(Path(args.file).stem)
    names, ids, labels = [], [], []
    for f in feats:
        fid = f.properties.get("id", f.properties.get("name"))
        ids.append(str(fid) if fid is not None else f"feature {f.index}")
        labels.append(f"{args.file}: feature {f.index}"
                      + (f" ({shown(fid)})" if fid is not None else ""))
        names.append(safe_name(str(fid)) if fid is not None else
                     (stem if len(feats) == 1 else f"{stem}_{f.index}"))
    return names, ids, labels


TOLD_FROM = 20   # features from which a command says how far it has got


def _told(items: list, done: str) -> Iterator:
    """``items``, saying on stderr how many are ``done`` at each tenth when there are
    :data:`TOLD_FROM` or more: 500 blocks with previews ran minutes without a word."""
    n = len(items)
    for i, item in enumerate(items, start=1):
        yield item
        if n >= TOLD_FROM and 10 * i // n > 10 * (i - 1) // n:   # a tenth more
            print(f"  {done} {i} of {n} ({100 * i // n} %)", file=sys.stderr, flush=True)


SAID_COPIES = 3   # repeated outlines told one by one; past this, counted in one line


def _distinct(args, feats: list) -> list:
    """The features less those whose outline an earlier one already has (to the
    millimetre), each told on stderr, as a city tells its footprints: the same polygon
    given 2,000 times was laid out 2,000 times, its copies meeting each other in the
    gap and party-wall checks first, minutes without a word."""
    from citysynth.pipeline.city.jobs import outline_wkt

    first: dict[str, Any] = {}
    out, copies = [], 0
    for f in feats:
        seen = first.setdefault(outline_wkt(f.geometry), f)
        if seen is f:
            out.append(f)
            continue
        copies += 1
        if copies <= SAID_COPIES:
            print(f"citysynth {args.command}: {f.where}: the same outline as {seen.name}, "
                  "laid out once", file=sys.stderr)
    if copies > SAID_COPIES:
        print(f"citysynth {args.command}: {args.file}: {copies - SAID_COPIES:,} more "
              "features repeat an outline given before them; each outline laid out once",
              file=sys.stderr)
    return out


def _storeys_note(args, feats: list, specs: dict, style: str) -> None:
    """One line on stderr when features give storeys or heights (``specs``: each
    feature's, by index), which ``block`` does not build to (its blocks are the style's
    parts as they are) and ``city --footprints`` does: they were ignored without a
    word."""
    given = [f for f in feats
             if specs[f.index].levels is not None or specs[f.index].height is not None]
    if given:
        print(f"citysynth {args.command}: {args.file}: {len(given):,} of {len(feats):,} "
              f"features give storeys or a height ({given[0].name} first); block builds "
              f"every outline of the {style} style's parts as they are; to build "
              "footprints to their storeys, give them to citysynth city --footprints",
              file=sys.stderr)


def _thin_note(args, feats: list) -> None:
    """A line on stderr for each outline thinner on average (twice its area over its
    perimeter) than a city's ``min_width``, as a city skips a sliver: a 3 m strip or a
    0.5 m ring round a courtyard was built without a word as walls that thin, windows on
    both faces."""
    from citysynth.pipeline.city.config import CityConfig
    from citysynth.skeletons.clean import mean_width

    for f in feats:
        width = mean_width(f.geometry)
        if width < CityConfig.min_width:
            print(f"citysynth {args.command}: {f.where}: {width:.1f} m wide on average, "
                  f"under the {CityConfig.min_width:g} m below which a city leaves a "
                  "block out; laid out, its modules cut to walls that thin; check the "
                  "outline (a wall, a kerb or a courtyard drawn just inside it?)",
                  file=sys.stderr)


def _overlaps_settled(args, feats: list, specs: dict) -> list:
    """The features with overlaps settled as a city settles its footprints' (larger
    first: one inside a larger by half or more left out, one overlapping less trimmed
    to the ground the larger leaves), each told on stderr: two overlapping blocks were
    both built whole, 268 m² of walls standing through walls. A polygon a trim leaves in
    several pieces builds each, the second on named ``<name>-2``, ``-3``...; a
    MultiPolygon's polygons are settled each, and what is left of them stays one
    feature (a MultiPolygon beside an overlapping polygon was built whole: 600 m²
    doubled). ``specs``: each feature's footprint spec, by index."""
    from dataclasses import replace

    from shapely.geometry import MultiPolygon, Polygon

    from citysynth.pipeline.city.config import CityConfig
    from citysynth.pipeline.city.overlaps import Footprint, separate

    shapes = [(f, g) for f in feats for g in (
        [f.geometry] if isinstance(f.geometry, Polygon) else
        list(f.geometry.geoms) if isinstance(f.geometry, MultiPolygon) else [])]
    if len({f.index for f, _g in shapes}) < 2:
        return feats
    built, left = separate([Footprint(g, specs[f.index]) for f, g in shapes],
                           CityConfig.min_area)
    for why in dict.fromkeys(why for why, _shape in left):
        print(f"citysynth {args.command}: {why}", file=sys.stderr)
    pieces: dict[int, list] = {}
    for fp in built:
        pieces.setdefault(fp.spec.feature, []).append(fp)
    out = []
    used = {str(f.properties.get("id", f.properties.get("name"))) for f in feats}
    for f in feats:
        if not isinstance(f.geometry, Polygon | MultiPolygon):
            out.append(f)
            continue
        kept = pieces.get(f.index, [])
        for note in dict.fromkeys(fp.spec.trimmed for fp in kept if fp.spec.trimmed):
            print(f"citysynth {args.command}: {note}", file=sys.stderr)
        if isinstance(f.geometry, MultiPolygon):
            if kept:
                out.append(replace(f, geometry=kept[0].polygon if len(kept) == 1 else
                                   MultiPolygon([fp.polygon for fp in kept])))
            continue
        for n, fp in enumerate(kept, start=1):
            if n == 1:
                out.append(replace(f, geometry=fp.polygon))
                continue
            # a piece's name: its feature's (as run_block names one with no id), -n,
            # and again while another feature has that id
            own = f.properties.get("id", f.properties.get("name"))
            if own is None:
                own = f"{safe_name(Path(args.file).stem)}_{f.index}"
            piece = f"{own}-{n}"
            while piece in used:
                piece += f"-{n}"
            used.add(piece)
            out.append(replace(f, geometry=fp.polygon, properties={**f.properties, "id": piece}))
    return out


def _gaps_closed(args, feats: list) -> list:
    """The features with the gaps under 0.3 m between touching ones closed, as a
    city's footprints (each grown one said on stderr)."""
    from dataclasses import replace

    from citysynth.pipeline.city.gaps import closed_gaps, grown_note

    out = []
    for f, (shape, added, towards) in zip(feats, closed_gaps([f.geometry for f in feats]),
                                          strict=True):
        if added > 0.0:
            print(f"citysynth {args.command}: {f.where}: "
                  f"{grown_note(added, ' and '.join(feats[j].name for j in towards))}",
                  file=sys.stderr)
            f = replace(f, geometry=shape)
        out.append(f)
    return out


def _check_names(source, names: list[str], ids: list[str], k: int) -> None:
    """Refuse blocks whose files would overwrite each other's: the same name, names
    differing only in case (one file on Windows and macOS), or, with k above 1, a name
    that is another block's rank (block "x_2" against rank 2 of block "x"). ``ids``:
    what the features call them, which the message quotes."""
    seen: dict[str, int] = {}
    for n, name in enumerate(names):
        files = [name] + ([f"{name}_{r}" for r in range(1, k + 1)] if k > 1 else [])
        for file in files:
            m = seen.get(file.casefold())
            if m is not None:
                other = names[m]
                one_file = other == name and ids[m] != ids[n]   # distinct ids, one name
                why = (f"make one file name ({name!r}: a file name keeps ASCII letters, "
                       "digits, '.', '_' and '-', and no '_' or '.' at either end)"
                       if one_file else "share a name" if other == name else
                       "share a name but for letter case (one file on Windows and macOS)"
                       if other.casefold() == name.casefold() else
                       f"would write the same files ({file!r})")
                fix = ("give them ids that differ in those characters" if one_file
                       else "give each feature a distinct id")
                raise SkeletonError(
                    f"{source}: two blocks {why}: {ids[m]!r} and {ids[n]!r} (their "
                    f"\"id\"); {fix}" + (
                        f", not ending in _1 to _{k} after another's (with --k {k} a block's "
                        "files are named <id>_<rank>)" if k > 1 and
                        other.casefold() != name.casefold() else ""))
        for file in files:
            seen[file.casefold()] = n


def _smallest(db, style: str) -> float:
    """Edges shorter than the style's smallest middle part cannot hold a facade."""
    lengths = [p.length for p in db.select("middle", style)]
    return min(lengths) if lengths else 0.0
