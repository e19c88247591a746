"""``citysynth street``: a street of complete buildings along a line (the paper's Fig. 7),
its k best rows written as layout JSON, USD, GLB and a PNG preview each.

Exits 0 with the rows written, 1 when a run of the street has no filling that meets
its length and intervals (the reason on stderr), 2 on bad input.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from citysynth.examples import SAMPLE_LIBRARY
from citysynth.parts_db.files import all_or_nothing
from citysynth.pipeline.commands.build import safe_name
from citysynth.pipeline.errors import UsageError, check_k, names_its_file
from citysynth.skeletons.errors import SkeletonError

if TYPE_CHECKING:
    from citysynth.pipeline.layouts import Built
    from citysynth.pipeline.streets import StreetAsk

# What the command runs (the solver, shapely, USD) is imported in the functions that
# run it, so the command line starts without it (see pipeline.cli).

ATTRIBUTES = ("doors", "balconies", "windows")


def register(sub) -> None:
    p = sub.add_parser("street", help="fill a street line with complete buildings",
                       description="Fill one or both sides of a street line (a GeoJSON "
                                   "LineString) with a library's complete buildings, each "
                                   "straight run within the stretch tolerance and the asked "
                                   "intervals, and write layout JSON, USD, GLB and a PNG "
                                   "preview for each of the k best rows.")
    p.add_argument("--line", required=True, metavar="FILE",
                   help="the street's one LineString (GeoJSON or another GIS "
                   "file: see citysynth city --help)")
    p.add_argument("--side", choices=("left", "right", "both"), default="both",
                   help="which side of the line to build (default both)")
    p.add_argument("--offset", type=float, default=None, metavar="M",
                   help="facade lines this far from the line (default 0 for one side, "
                        "6 for both: the line is then the street's centre)")
    for a in ATTRIBUTES:
        p.add_argument(f"--{a}", type=float, nargs=2, metavar=("LO", "HI"),
                       help=f"number of {a} of each straight run")
    p.add_argument("--stretch", type=float, default=0.005, metavar="SHARE",
                   help="a run's length may be met within this share (default 0.005)")
    p.add_argument("--slack", type=float, default=0.3, metavar="M",
                   help="... or within this many metres, whichever is larger (default 0.3)")
    p.add_argument("--library", default=str(SAMPLE_LIBRARY), metavar="DIR",
                   help="part library folder (default: the sample library)")
    p.add_argument("--style", default=None, help="style of the buildings (default: any)")
    p.add_argument("--k", type=int, default=1, help="number of rows to write (default 1)")
    p.add_argument("--crs", default=None, help="CRS of a projected line, e.g. EPSG:25832")
    p.add_argument("-o", "--out", default="out", metavar="DIR",
                   help="output folder (default: out/)")
    p.add_argument("--no-preview", action="store_true", help="skip the PNG previews")
    p.set_defaults(run=run)


MAX_OFFSET = 1000.0   # m, as `skeleton --setback`: a street is no wider


def _ask(args) -> StreetAsk:
    from citysynth.pipeline.city.config import MAX_SLACK
    from citysynth.pipeline.streets import SIDES, StreetAsk

    check_k(args.k, what="rows")
    sides = SIDES if args.side == "both" else (args.side,)
    offset = args.offset if args.offset is not None else (6.0 if args.side == "both" else 0.0)
    if not math.isfinite(offset) or offset < 0 or (args.side == "both" and offset == 0):
        raise UsageError(f"--offset must be a positive number of metres (both sides need "
                         f"room between their facades), got {offset:g}")
    if offset >= MAX_OFFSET:
        raise UsageError(f"--offset is the facades' distance from the street line, under "
                         f"{MAX_OFFSET:g} m; got {offset:g}")
    if not (0 <= args.stretch <= 0.05 and 0 <= args.slack <= MAX_SLACK):
        raise UsageError(f"--stretch is a share in [0, 0.05] and --slack a number of metres "
                         f"in [0, {MAX_SLACK:g}]; got {args.stretch:g} and {args.slack:g}")
    cons = []
    for a in ATTRIBUTES:
        iv = getattr(args, a)
        if iv is None:
            continue
        if not (0 <= iv[0] <= iv[1] and math.isfinite(iv[1])):
            raise UsageError(f"--{a} LO HI needs 0 <= LO <= HI, both finite, got {iv[0]:g} "
                             f"{iv[1]:g}")
        cons.append((a, float(iv[0]), float(iv[1])))
    return StreetAsk(sides, offset, args.stretch, args.slack, tuple(cons), args.style, args.k)


def read_line(path: str, crs: str | None):
    """The one LineString of a GeoJSON file, in its local metric frame."""
    import shapely

    from citysynth.skeletons import read_geojson
    from citysynth.skeletons.from_geometry import DENSE, SNAP

    feats, frame = read_geojson(path, crs=crs, accept="lines")
    if len(feats) != 1:
        raise SkeletonError(f"{path}: a street line is one LineString feature; the file has "
                            f"{len(feats)} features: give each street its own file")
    line = feats[0].geometry
    if line.geom_type == "MultiLineString":   # QGIS and shapefiles write one line so
        line = shapely.line_merge(line)
        if line.geom_type != "LineString":
            raise SkeletonError(f"{path}: the MultiLineString's {len(line.geoms)} parts do "
                                "not join end to end into one line; give the street as "
                                "one line")
    # repeated vertices (QGIS and OSM exports have them) and dense sampling go
    line = shapely.simplify(line, DENSE)
    if line.length < SNAP or len(line.coords) < 2:
        raise SkeletonError(f"{path}: the street line has no length")
    _check_course(line, frame, path)
    if not line.is_simple:   # what the check leaves: a line that touches its own course
        raise SkeletonError(f"{path}: the street line touches itself{_touch(line, frame)}; "
                            "give it as lines that do not cross or touch (one run each)")
    return line, frame


def _touch(line, frame) -> str:
    """Where a line that is not simple touches itself (" at (x, y)" in the file's
    coordinates: a point where three or more of its pieces, noded, meet), or ""."""
    from collections import Counter

    import shapely

    ends = Counter((round(x, 6), round(y, 6)) for part in shapely.get_parts(shapely.node(line))
                   for x, y in (part.coords[0][:2], part.coords[-1][:2]))
    at = next((p for p, n in ends.items() if n >= 3), None)
    return f" at {frame.at(at)}" if at is not None else ""


def _check_course(line, frame, path: str) -> None:
    """Refuse a street line that goes back over its own course, said where in the
    file's coordinates: there and back at a turn (a street 100 m east, then 70 m back
    west over itself, was built with one side a straight 160 m run whose rows reached
    60 m past the street's end), a turn so sharp that its legs run almost on top of
    each other (a corner under the 5° building lines are held to), a stretch it comes
    back over later, or a crossing. The check is the one building lines pass
    (:func:`~citysynth.skeletons.from_geometry.line_meets_itself`)."""
    import numpy as np

    from citysynth.pipeline.skeleton_to_structure import MIN_CORNER_DEG
    from citysynth.pipeline.streets import _turns
    from citysynth.skeletons.from_geometry import THERE_AND_BACK, line_meets_itself

    coords = np.asarray(line.coords)[:, :2]
    closed = line.is_closed and len(coords) >= 4
    m = line_meets_itself(coords)
    if m is not None:
        (p, q), (s, t) = m.span, sorted((int(m.first.source), int(m.second.source)))
        if m.kind == "cross":
            raise SkeletonError(f"{path}: the street line crosses itself at {frame.at(p)}; "
                                "give it as lines that do not cross (one run each)")
        back = float(np.hypot(q[0] - p[0], q[1] - p[1]))
        if t == s + 1 or (closed and (s, t) == (0, len(coords) - 2)):
            turn = coords[t] if t == s + 1 else coords[0]   # a loop's: its closing point
            far = q if np.hypot(*(np.asarray(p) - turn)) < np.hypot(*(np.asarray(q) - turn)) \
                else p
            raise SkeletonError(f"{path}: the street line turns back at {frame.at(turn)} "
                                f"and runs {back:.1f} m over its own course, to "
                                f"{frame.at(far)}: {THERE_AND_BACK}")
        raise SkeletonError(f"{path}: the street line comes back over its own course from "
                            f"{frame.at(p)} to {frame.at(q)} ({back:.1f} m); give it as "
                            "lines that do not overlap (one run each)")
    turns = _turns(np.vstack([coords, coords[1:2]]) if closed else coords)
    for i, turn in enumerate(turns, start=1):
        corner = 180.0 - abs(float(turn))
        if round(corner, 3) < MIN_CORNER_DEG:
            d = 1 if round(corner, 1) < MIN_CORNER_DEG else 3    # never "5.0°, under 5°"
            raise SkeletonError(
                f"{path}: the street line turns back by {180.0 - corner:.{d}f}° at "
                f"{frame.at(coords[i % (len(coords) - 1) if closed else i])}, a corner of "
                f"{corner:.{d}f}°, sharper than the {MIN_CORNER_DEG:g}° citysynth builds: its "
                f"two legs run almost on top of each other ({THERE_AND_BACK}, or open the "
                "turn up)")


@names_its_file("line")
def run(args) -> int:
    from citysynth.parts_db import load_library
    from citysynth.pipeline.streets import solve_street

    ask = _ask(args)
    line, frame = read_line(args.line, args.crs)
    db = load_library(args.library)
    built = solve_street(safe_name(Path(args.line).stem), line, db, ask, frame.describe(),
                         frame.at, source=str(args.line), progress=_run_progress())
    if built.status != "ok":
        print(f"citysynth street: {built.name}: infeasible: {built.reason}", file=sys.stderr)
        return 1
    return _write(args, db, built)


PROGRESS_RUNS = 200   # runs from which solving them shows progress (about a third of a
                      # second's work: a street of 20,000 runs takes half a minute)
LISTED_RUNS = 100     # runs a row lists one by one; the rest are counted in one line


def _run_progress():
    """Progress of filling the runs on stderr, for a street of many runs."""
    from citysynth.pipeline.progress import progress_line

    shown = progress_line(sys.stderr)
    first: list[float] = []   # when the first run was filled: the rate counts from there
    # (from the command's start it rose all along, the splitting into runs in it)

    def tell(done: int, total: int) -> None:
        if total < PROGRESS_RUNS:
            return
        now = time.perf_counter()
        first[:] = first or [now]
        rate = f" ({(done - 1) / (now - first[0]):,.0f} runs/s)" if now > first[0] else ""
        shown(done, total, f"[{done:>{len(str(total))}}/{total}] runs filled{rate}")
    return tell


def _write(args, db, built: Built) -> int:
    from citysynth.pipeline.layouts import (
        chosen_formats,
        output_stem,
        summary_line,
        write_outputs,
    )

    formats = chosen_formats(preview=not args.no_preview)
    with all_or_nothing(args.out):
        paths = write_outputs(built, db, args.out, formats=formats, k=args.k,
                              inputs=[args.line])
    print(f"{built.name}: {len(built.layouts)} row(s)")
    for lay in built.layouts:
        print("  " + summary_line(lay))
        for st in lay.structures[:LISTED_RUNS]:
            met = st["resources"]
            side, run = st["name"].rsplit("_", 1)   # a run's name: <side>_<index>
            print(f"    {side} side, run {int(run) + 1}: {len(st['stages'][0]['parts'])} buildings "
                  f"({len(set(st['stages'][0]['parts']))} distinct), "
                  f"{met['length']:.1f} m for {st['stages'][0]['length']:.1f} m, "
                  + ", ".join(f"{met.get(a, 0):g} {a}" for a in ATTRIBUTES if a in met))
        if len(lay.structures) > LISTED_RUNS:
            print(f"    ... and {len(lay.structures) - LISTED_RUNS:,} more runs (each in "
                  f"{output_stem(lay, args.k)}.layout.json)")
    print(f"  wrote {len(paths)} files to {Path(args.out)}/ "
          f"(solve {1e3 * built.timings['solve_s']:.0f} ms)")
    return 0
