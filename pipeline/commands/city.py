"""``citysynth city``: a whole city from a street network (and/or footprints).

Exit codes: 0 when every attempted block was built; 1 when some failed (each listed,
with its reason, in the summary and in report.json: one bad block never stops the
city, and the run folder is complete and resumable all the same); 2 on bad input
(streets, footprints, config, library), with one line and nothing written; 3 when a
block met a bug in citysynth (the rest of the city is still built and written; each
bug's traceback goes to stderr and report.json).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from citysynth.pipeline.city.process import cpu_count
from citysynth.pipeline.errors import (
    EXIT_BAD_INPUT,
    EXIT_INFEASIBLE,
    EXIT_INTERNAL,
    EXIT_OK,
    UsageError,
)

if TYPE_CHECKING:
    from citysynth.pipeline.city.outputs import Report


def register(sub) -> None:
    p = sub.add_parser("city", help="build every block of a street network",
                       description="Polygonise street centre lines into blocks (and/or take "
                                   "building footprints), build each block's facades with a "
                                   "part library, and write per-block layout JSON and USD, a "
                                   "city USD stage, an overview PNG, manifest.json and "
                                   "report.json. Reruns skip unchanged blocks.")
    p.add_argument("--streets", metavar="FILE", help="street centre lines: GeoJSON, "
                   "GeoPackage, Shapefile, FlatGeobuf, KML, Esri JSON, GML, MapInfo, File "
                   "Geodatabase, GeoParquet "
                   "(Overture Maps too), OpenStreetMap (.osm, .osm.pbf: its highway ways) or "
                   "DXF (with --crs); FILE::LAYER picks one layer of several (a DXF's CAD "
                   "layer)")
    p.add_argument("--footprints", metavar="FILE",
                   help="building footprints to wrap (polygons, in the same formats; "
                        "an OpenStreetMap file's buildings), "
                        "instead of or beside the street blocks")
    p.add_argument("--library", metavar="DIR", help="part library (or set library in the "
                                                    "config)")
    p.add_argument("--config", metavar="city.toml", help="run settings (see README)")
    p.add_argument("-o", "--out", default="out/city", metavar="DIR",
                   help="run folder (default: out/city)")
    p.add_argument("--workers", type=int, default=None,
                   help=f"local worker processes (default: all cores, here {cpu_count()})")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the blocks on a Dask cluster, e.g. tcp://10.0.0.5:8786 (the "
                        "workers must see the library and the run folder)")
    p.add_argument("--crs", default=None, help="CRS of projected input, e.g. EPSG:25832")
    p.add_argument("--no-overview", action="store_true", help="skip city.png")
    p.add_argument("--glb", action="store_true",
                   help="also write city.glb: every built block in one Y-up GLB")
    p.set_defaults(run=run)


MAX_WORKERS_PER_CORE = 4   # local workers beyond this many per core are refused
WORKER_MB = 150            # resident memory of one local worker, about (measured 115)


def run(args) -> int:
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    if args.workers is not None and not args.scheduler and \
            args.workers > MAX_WORKERS_PER_CORE * cpu_count():
        gb = args.workers * WORKER_MB / 1024
        raise UsageError(
            f"--workers {args.workers} on {cpu_count()} cores: each local worker holds "
            f"about {WORKER_MB} MB (the library and the kernels), "
            + (f"{gb:,.1f} GB in all" if gb < 1e5 else "in all more memory than any machine has")
            + ", and more than "
            f"{MAX_WORKERS_PER_CORE} per core only wait for each other; use at most "
            f"{MAX_WORKERS_PER_CORE * cpu_count()} (or --scheduler for a cluster)")
    from citysynth.pipeline.city.folder import input_in_outputs, misplaced, not_a_run
    wrong = misplaced(args.out) or input_in_outputs(
        args.out, [args.streets, args.footprints, args.config]) or not_a_run(args.out)
    if wrong:
        raise UsageError(wrong)
    from citysynth.pipeline.city.process import check_not_running
    check_not_running(Path(args.out))
    from citysynth.pipeline.city.config import load_config  # when run (see pipeline.cli)
    from citysynth.pipeline.city.outputs import SummaryNotWritten, finish_city
    from citysynth.pipeline.city.run import prepare, progress_printer, run_city

    t0 = time.perf_counter()
    cfg = load_config(args.config)
    inputs = prepare(args.streets, args.footprints, cfg, args.library, args.crs)
    workers = max(1, min(args.workers or cpu_count(), len(inputs.jobs)))   # none idle
    where = f"Dask at {args.scheduler}" if args.scheduler else f"{workers} worker(s)"
    print(f"citysynth city: {len(inputs.jobs)} blocks to build ({len(inputs.skipped)} "
          f"pieces skipped) on {where}, into {args.out}/")
    try:
        report = run_city(inputs, args.out, workers=workers, scheduler=args.scheduler,
                          progress=progress_printer(pieces=len(inputs.skipped)))
    except SummaryNotWritten as exc:   # what the blocks came to, then why
        print(summary_table(exc.report))
        raise
    if report["counts"]["cached"]:
        print(f"{report['counts']['cached']} blocks were unchanged since the last run in "
              f"{args.out}/ and were not built again")
    try:
        city, png = finish_city(inputs, report, Path(args.out), overview=not args.no_overview,
                                started=t0, glb=args.glb)
    except OSError:   # a full disk at the city's files: what the blocks came to, then why
        print(summary_table(report))
        raise
    glb = Path(args.out) / "city.glb"
    print(summary_table(report))
    print(f"wrote {city}" + (f", {png}" if png else "") + (f", {glb}" if args.glb and
          glb.is_file() else "") + f", {Path(args.out) / 'report.json'}")
    return exit_code(report, "citysynth city")


def report_bugs(report: Report, who: str) -> int:
    """Print every bug the blocks met, with its traceback, on stderr; the exit code
    (:data:`EXIT_INTERNAL` when there was one)."""
    for e in report["errors"]:
        print(f"{who}: internal error in block {e['id']} (a bug in citysynth; please "
              f"report it with this traceback):\n{e['traceback'].rstrip()}", file=sys.stderr)
    return EXIT_INTERNAL if report["errors"] else EXIT_OK


def exit_code(report: Report, who: str) -> int:
    """A city's exit code: :data:`EXIT_INTERNAL` when a block met a bug (each printed
    by :func:`report_bugs`), else :data:`EXIT_BAD_INPUT` when the machine failed a block
    (a full disk, no permission: as every command's refusal of the machine; it was 1,
    which a pipeline reads as "infeasible"), else :data:`EXIT_INFEASIBLE` when a block
    failed or nothing at all was built (every piece skipped: a pipeline must not read
    that as a city), else :data:`EXIT_OK`."""
    bugs = report_bugs(report, who)
    if bugs:
        return bugs
    machine = report.get("machine_failed", [])
    if machine:
        why = next(f["reason"] for f in report["failed"] if f["id"] == machine[0])
        print(f"{who}: {len(machine)} block(s) could not be written, e.g. {machine[0]}: "
              f"{why}", file=sys.stderr)
        return EXIT_BAD_INPUT
    c = report["counts"]
    if not c["built"] and not c["failed"] and not c["skipped"]:
        print(f"{who}: nothing was built: the streets enclose no block (a block is the "
              "ground a closed loop of streets surrounds; one street, or streets that "
              "only branch, make none)", file=sys.stderr)
    elif not c["built"] and not c["failed"]:
        print(f"{who}: nothing was built: all {c['skipped']} pieces were skipped "
              "(report.json and blocks.geojson say why)", file=sys.stderr)
    return EXIT_INFEASIBLE if c["failed"] or not c["built"] else EXIT_OK


def summary_table(report: Report) -> str:
    c = report["counts"]
    lines = ["", f"{'blocks':<22}{'count':>8}", "-" * 30]
    for k in ("built", "failed", "skipped", "cached"):
        lines.append(f"{k:<22}{c[k]:>8}")
    if c["error"]:
        lines.append(f"{'internal errors':<22}{c['error']:>8}")
    lines.append(f"{'built / attempted':<22}{100 * report['built_share']:>7.1f}%")
    if len(report.get("kinds", {})) > 1:   # zones of several kinds: built by kind
        lines += [f"{'  ' + k + ' built':<22}{v.get('built', 0):>8}"
                  for k, v in report["kinds"].items()]
    t = report["timings"]
    lines += ["", f"{'stage':<22}{'seconds':>8}", "-" * 30]
    names = [("inputs_s", "streets -> blocks"), ("clean_s", "outlines, retries (CPU)"),
             ("structure_s", "structures (CPU)"),
             ("solve_s", "solve (CPU)"), ("layout_s", "layout + checks (CPU)"),
             ("write_s", "JSON + USD (CPU)"), ("blocks_wall_s", "all blocks (wall)"),
             ("city_stage_s", "city stage"), ("overview_s", "overview PNG"),
             ("total_s", "total (wall)")]
    for key, label in names:
        if key in t:
            lines.append(f"{label:<22}{t[key]:>8.2f}")
    for f in report["failed"][:20]:
        lines.append(f"failed {f['id']}: {f['reason']}")
    if len(report["failed"]) > 20:
        lines.append(f"... and {len(report['failed']) - 20} more in report.json")
    for e in report["errors"]:
        lines.append(f"internal error {e['id']}: {e['error']} (traceback on stderr)")
    return "\n".join(lines)
