"""``citysynth tower``: a tower of an exact height and a floor-area ratio (FAR) interval on
a lot (the paper's Fig. 4), its k best stacks written as layout JSON, USD, GLB and a PNG
preview each.

The lot is a GeoJSON polygon (``--lot``) or, for a quick look, a square of a given area
(``--lot-area``). Exits 0 with the towers written, 1 when no stack of the library's
tower parts that fit the lot meets the height and the FAR (the reason on stderr), 2 on
bad input.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from citysynth.examples import SAMPLE_LIBRARY
from citysynth.parts_db.files import all_or_nothing
from citysynth.pipeline.commands.build import safe_name
from citysynth.pipeline.errors import UsageError, check_k
from citysynth.skeletons.errors import SkeletonError

if TYPE_CHECKING:
    from citysynth.pipeline.layouts import Built
    from citysynth.pipeline.towers import Lot

# What the command runs (the solver, shapely, USD) is imported in the functions that
# run it, so the command line starts without it (see pipeline.cli).

FAR_TOLERANCE = 0.02   # --far X: within 2 % of X either side
MAX_LOT_AREA = 1e12   # m²: a million km², past any lot (larger ones lose the metre to rounding)


def register(sub) -> None:
    p = sub.add_parser("tower", help="stack a tower of exact height and floor-area ratio",
                       description="Stack a ground floor, floors and a roof of a part "
                                   "library to exactly --height metres with the total floor "
                                   "area over the lot area (FAR) inside --far, on a lot, and "
                                   "write layout JSON, USD, GLB and a PNG preview for each "
                                   "of the k best towers.")
    p.add_argument("--height", type=float, required=True, metavar="H",
                   help="the tower's height in metres (met exactly)")
    p.add_argument("--far", type=float, nargs="+", required=True, metavar="X",
                   help="floor-area ratio: X (within --far-tolerance) or an interval LO HI")
    p.add_argument("--far-tolerance", type=float, default=FAR_TOLERANCE, metavar="SHARE",
                   help=f"--far X accepts X times 1 +- SHARE (default {FAR_TOLERANCE})")
    lot = p.add_mutually_exclusive_group(required=True)
    lot.add_argument("--lot", metavar="FILE",
                     help="the lot's polygon (GeoJSON or another GIS file: see citysynth "
                          "city --help)")
    lot.add_argument("--lot-area", type=float, metavar="M2",
                     help="a square lot of this many m²")
    p.add_argument("--library", default=str(SAMPLE_LIBRARY), metavar="DIR",
                   help="part library folder (default: the sample library)")
    p.add_argument("--style", default=None,
                   help="style of the tower parts (default: any style with tower parts)")
    p.add_argument("--k", type=int, default=1, help="number of towers to write (default 1)")
    p.add_argument("--name", default=None,
                   help="output file name (default: from the height and FAR)")
    p.add_argument("--crs", default=None, help="CRS of a projected lot, e.g. EPSG:25832")
    p.add_argument("-o", "--out", default="out", metavar="DIR",
                   help="output folder (default: out/)")
    p.add_argument("--no-preview", action="store_true", help="skip the PNG previews")
    p.set_defaults(run=run)


def read_lot(path: str, crs: str | None) -> Lot:
    """The one polygon of a GeoJSON file, as a lot in its local metric frame."""
    from citysynth.pipeline.towers import Lot
    from citysynth.skeletons import read_geojson
    from citysynth.skeletons.from_geometry import why_invalid

    feats, frame = read_geojson(path, crs=crs, accept="polygons")
    geom = feats[0].geometry
    if geom.geom_type == "MultiPolygon" and len(geom.geoms) == 1:   # as QGIS writes them
        geom = geom.geoms[0]
    if len(feats) != 1 or geom.geom_type != "Polygon":
        raise SkeletonError(f"{path}: a lot is one Polygon feature; the file has "
                            f"{len(feats)} feature(s) ({geom.geom_type} first)")
    if not geom.is_valid:
        what, fix = why_invalid(geom, frame)
        raise SkeletonError(f"{path}: the lot is not a valid polygon ({what}); {fix}")
    return Lot.from_polygon(geom, frame.describe())


def _name(args, far: tuple[float, float]) -> str:
    if args.name:
        return safe_name(args.name)
    ratio = f"{args.far[0]:g}" if len(args.far) == 1 else f"{far[0]:g}-{far[1]:g}"
    return safe_name(f"tower_{args.height:g}m_far{ratio}")


def run(args) -> int:
    from citysynth.parts_db import load_library
    from citysynth.pipeline.towers import Lot, far_interval, solve_tower

    check_k(args.k, what="towers")
    far = far_interval(args.far, args.far_tolerance)
    if not args.lot and args.lot_area > MAX_LOT_AREA:
        raise UsageError(f"--lot-area {args.lot_area:g} m² is no building lot (at most "
                         f"{MAX_LOT_AREA:g} m², a million km²); give the lot's area in "
                         "square metres")
    lot = read_lot(args.lot, args.crs) if args.lot else Lot.square(args.lot_area)
    if args.lot and lot.area > MAX_LOT_AREA:   # a lot drawn round the globe was taken
        raise UsageError(f"{args.lot}: a lot of {lot.area:.3g} m² is no building lot (at "
                         f"most {MAX_LOT_AREA:g} m², a million km²); draw the lot itself")
    db = load_library(args.library)
    built = solve_tower(_name(args, far), db, lot, args.height, far, style=args.style,
                        k=args.k)
    if built.status != "ok":
        print(f"citysynth tower: {built.name}: infeasible: {built.reason}", file=sys.stderr)
        return 1
    return _write(args, db, built)


def _write(args, db, built: Built) -> int:
    from citysynth.pipeline.layouts import chosen_formats, summary_line, write_outputs

    formats = chosen_formats(preview=not args.no_preview)
    with all_or_nothing(args.out):
        paths = write_outputs(built, db, args.out, formats=formats, k=args.k,
                              inputs=[args.lot] if args.lot else [])
    print(f"{built.name}: {len(built.layouts)} tower(s)")
    for lay in built.layouts:
        met = lay.structures[0]["resources"]
        print(f"  {summary_line(lay)}  height {met['height']:g} m  floor area "
              f"{met['floor_area']:.1f} m²  FAR {met['far']:.2f}")
    print(f"  wrote {len(paths)} files to {Path(args.out)}/ "
          f"(solve {1e3 * built.timings['solve_s']:.0f} ms)")
    return 0
