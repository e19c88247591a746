"""What a city run leaves beside its blocks: the manifest, the report, blocks.geojson,
the city stage and the overview.

``manifest.json`` describes every block (input hash, status, files, cost) and carries
no timings, so two runs of the same inputs write the same manifest (``citysynth diff``
reads it). ``report.json`` adds counts, reasons, the bugs met (with tracebacks) and the
time per stage. ``blocks.geojson`` shows every block and skipped piece with its status
and reason in the input's CRS (open it in QGIS beside the streets). ``city.usda`` holds
every built block's layer as a payload in the city's one frame; ``city.png`` shows the
built blocks from a perspective and from above.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from citysynth.export.imports import import_shielded
from citysynth.parts_db import PartDB, load_library
from citysynth.parts_db.files import write_text
from citysynth.pipeline.city.folder import (
    BLOCKS_DIR,
    BLOCKS_GEOJSON,
    MANIFEST,
    REPORT,
    RUN_SCHEMA,
    RUN_VERSION,
)
from citysynth.pipeline.city.jobs import STATUSES, BlockRecord, frame_tuple
from citysynth.skeletons import Frame
from citysynth.skeletons.geojson import LONLAT_FRAME, tmerc_proj4, transformer

if TYPE_CHECKING:   # the run imports this module to write its summary
    from citysynth.export.layout import Layout
    from citysynth.pipeline.city.run import CityInputs

STOREYS_ASKED = re.compile(r": \d+ storeys? asked; ")   # a note of footprints.py
_MANIFEST_KEYS = ("kind", "zone", "input_hash", "status", "reason", "error", "files", "cost",
                  "rank", "of", "style", "feature", "storeys", "note", "extent")

Report = dict[str, Any]   # report.json, as written


def write_summary(inputs: CityInputs, results: dict[str, BlockRecord], out: Path,
                  t_blocks: float, workers: int, scheduler: str | None) -> Report:
    """Write ``manifest.json`` and ``report.json`` for ``results`` (every job's record,
    by block id); the report."""
    ids = sorted(results)
    recs: dict[str, dict[str, Any]] = {i: dict(results[i]) for i in ids}
    manifest = {"schema": RUN_SCHEMA, "version": RUN_VERSION,
                "frame": list(frame_tuple(inputs.frame)),
                "blocks": {i: {k: recs[i][k] for k in _MANIFEST_KEYS
                               if recs[i].get(k) is not None} for i in ids},
                "skipped": _reasons(inputs.skipped)}
    counts: dict[str, int] = {s: sum(1 for r in recs.values() if r["status"] == s)
                              for s in STATUSES}
    counts["skipped"] += len(inputs.skipped)
    counts["cached"] = sum(1 for r in recs.values() if r.get("cached"))
    attempted = counts["built"] + counts["failed"] + counts["error"]

    def with_status(status: str, key: str) -> list[dict[str, Any]]:
        return [{"id": i, key: recs[i].get(key)} for i in ids if recs[i]["status"] == status]

    def skipped_blocks() -> list[dict[str, Any]]:   # with their kind, as pieces have one
        return [{"id": i, "kind": recs[i]["kind"], "reason": recs[i].get("reason")}
                for i in ids if recs[i]["status"] == "skipped"]

    report: Report = {
        "counts": counts, "blocks": len(inputs.jobs),
        "built_share": counts["built"] / attempted if attempted else 1.0,
        "failed": with_status("failed", "reason"),
        "machine_failed": [i for i in ids if recs[i].get("machine")],
        "storeys_not_matched": [{"id": i, "note": n} for i in ids
                                for n in _notes(recs[i]) if STOREYS_ASKED.search(n)],
        "notes": [{"id": i, "note": n} for i in ids for n in _notes(recs[i])],
        "skipped": _reasons(inputs.skipped) + skipped_blocks(),
        "errors": [{"id": i, "error": recs[i]["error"], "traceback": recs[i]["traceback"]}
                   for i in ids if recs[i]["status"] == "error"],
        "kinds": count_kinds(inputs, recs),
        "timings": _stage_times(inputs, recs, t_blocks), "workers": workers,
        "scheduler": scheduler, "built": [i for i in ids if recs[i]["status"] == "built"]}
    try:
        write_text(out / MANIFEST, json.dumps(manifest, sort_keys=True, indent=1) + "\n")
        write_report(out, report)
        write_blocks_geojson(out / BLOCKS_GEOJSON, inputs, recs)
    except OSError as exc:
        raise SummaryNotWritten(report, exc) from None
    return report


class SummaryNotWritten(OSError):
    """The machine refused the run's own files (a full disk at ``manifest.json``): the
    machine's error, carrying the ``report`` of the blocks, so the user still sees what
    the blocks came to before the one line saying why (there was only the line)."""

    def __init__(self, report: Report, exc: OSError) -> None:
        super().__init__(exc.errno, exc.strerror or str(exc), exc.filename)
        self.report = report


def _notes(rec: dict[str, Any]) -> list[str]:
    """A block's notes (what its build changed of the input, e.g. storeys the kit could
    not match, a light well closed), one by one."""
    return [n for n in str(rec.get("note") or "").split("\n") if n]


def count_kinds(inputs: CityInputs, recs: dict[str, dict[str, Any]]
                ) -> dict[str, dict[str, int]]:
    """Blocks by what they became (a zone's kind: perimeter, row or towers; or a
    footprint), each by status: ``{"row": {"built": 4}, ...}``."""
    out: dict[str, dict[str, int]] = {}
    for job in inputs.jobs:
        kind = job.zone_kind.kind if job.zone_kind else \
            "perimeter" if job.kind == "block" else job.kind
        status = recs.get(job.id, {}).get("status", "not run")
        out.setdefault(kind, {}).setdefault(status, 0)
        out[kind][status] += 1
    return {k: dict(sorted(v.items())) for k, v in sorted(out.items())}


def to_input_crs(frame: Frame) -> Callable[[np.ndarray], np.ndarray]:
    """Local metric coordinates of ``frame`` -> the input's CRS: lon/lat for lon/lat
    input (through the same local transverse Mercator the reader used), the input's
    projected CRS otherwise (reprojected back from lon/lat, or only moved back from
    the local origin and into the CRS's unit when it was kept)."""
    import pyproj

    if frame.crs != LONLAT_FRAME:   # a projected CRS kept as it is: shifted, in metres
        unit = pyproj.CRS.from_user_input(frame.source_crs).axis_info[0] \
            .unit_conversion_factor
        shift = np.asarray(frame.origin, dtype=float)
        return lambda xy: xy / unit + shift
    tf = transformer(tmerc_proj4(frame.origin), frame.source_crs or "EPSG:4326")
    return lambda xy: np.column_stack(tf.transform(xy[:, 0], xy[:, 1]))


def _reasons(skipped: list[dict]) -> list[dict]:
    """Skipped pieces as report.json keeps them: kind and reason, not the outline."""
    return [{k: v for k, v in s.items() if k != "wkt"} for s in skipped]


def write_blocks_geojson(path: Path, inputs: CityInputs,
                         recs: dict[str, dict[str, Any]]) -> Path:
    """``blocks.geojson``: every block (its outline, status, reason and what was built)
    and every piece skipped before it became a block (its reason, and its outline where
    it had one: a feature that is no street has none), in the input's CRS, for a user
    to inspect in QGIS. Lon/lat input gives plain RFC 7946; a projected one names its
    CRS in a ``crs`` member, as GDAL writes it."""
    import shapely

    project = to_input_crs(inputs.frame)
    digits = 9 if inputs.frame.crs == LONLAT_FRAME and not inputs.frame.source_crs else 4

    def ring(coords: Any) -> list[list[float]]:
        xy = project(np.asarray(coords, dtype=float)[:, :2])
        return [[round(float(x), digits), round(float(y), digits)] for x, y in xy]

    features: list[dict[str, Any]] = []
    for job in inputs.jobs:
        poly = shapely.from_wkt(job.wkt)
        rec = recs.get(job.id, {"status": "not run"})
        props = {"id": job.id, "kind": job.kind, "zone": job.zone, "style": job.style,
                 "status": rec["status"]}
        if job.footprint is None:   # a street block: what its zone makes of it
            props["zone_kind"] = job.zone_kind.kind if job.zone_kind else "perimeter"
        props.update({k: rec[k] for k in ("reason", "error", "rank", "of", "cost", "note")
                      if rec.get(k) is not None})
        geometry = {"type": "Polygon", "coordinates": [ring(poly.exterior.coords)] +
                    [ring(r.coords) for r in poly.interiors]}
        if digits == 9:
            geometry = across_antimeridian(geometry)
        features.append({"type": "Feature", "properties": props, "geometry": geometry})
    for piece in inputs.skipped:
        where: dict[str, Any] | None = None
        if piece.get("wkt"):
            polys = shapely.get_parts(shapely.from_wkt(piece["wkt"]))
            where = {"type": "MultiPolygon", "coordinates": [
                [ring(p.exterior.coords)] + [ring(r.coords) for r in p.interiors]
                for p in polys if p.geom_type == "Polygon"]}
        features.append({"type": "Feature", "geometry": where, "properties": {
            "id": None, "kind": piece.get("kind"), "status": "skipped",
            "reason": piece.get("reason")}})
    doc: dict[str, Any] = {"type": "FeatureCollection", "name": "blocks"}
    if inputs.frame.source_crs:
        doc["crs"] = {"type": "name", "properties": {"name": inputs.frame.source_crs}}
    doc["features"] = features
    return write_text(path, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")


def across_antimeridian(geometry: dict[str, Any]) -> dict[str, Any]:
    """A lon/lat Polygon that crosses the ±180° meridian (its longitudes jump from
    179.9 to -179.9) cut there into a MultiPolygon, as RFC 7946 (3.1.9) asks: drawn as
    it was, a 64 m building became a band round the whole globe in a GIS and in
    ``citysynth diff --png``. Any other geometry is returned as it is."""
    import shapely

    rings = geometry["coordinates"]
    lons = [x for r in rings for x, _y in r]
    if geometry["type"] != "Polygon" or max(lons) - min(lons) <= 180:
        return geometry
    east = shapely.Polygon(*[[(x + 360 if x < 0 else x, y) for x, y in r]
                             for r in rings[:1]],
                           [[(x + 360 if x < 0 else x, y) for x, y in r] for r in rings[1:]])
    parts = []
    for lo, shift in ((0.0, 0.0), (180.0, -360.0)):
        piece = east.intersection(shapely.box(lo, -90.0, lo + 180.0, 90.0))
        for p in shapely.get_parts(piece):
            if p.geom_type == "Polygon" and p.area > 0:
                p = shapely.geometry.polygon.orient(shapely.affinity.translate(p, shift), 1.0)
                parts.append([[[round(x, 9), round(y, 9)] for x, y in p.exterior.coords]] +
                             [[[round(x, 9), round(y, 9)] for x, y in r.coords]
                              for r in p.interiors])
    return {"type": "MultiPolygon", "coordinates": parts}


def _stage_times(inputs: CityInputs, recs: dict[str, dict[str, Any]],
                 t_blocks: float) -> dict[str, float]:
    """CPU seconds per stage summed over the blocks built in this run (not those read
    from an earlier one), the input reading, and the wall time of all blocks."""
    stage: dict[str, float] = dict(inputs.timings)
    for r in recs.values():
        if r.get("cached"):
            continue
        for k, v in r.get("timings", {}).items():
            if k != "total_s":
                stage[k] = stage.get(k, 0.0) + v
    stage["blocks_wall_s"] = t_blocks
    return stage


def write_report(out: Path, report: Report) -> None:
    write_text(out / REPORT, json.dumps(report, sort_keys=True, indent=1) + "\n")


def finish_city(inputs: CityInputs, report: Report, out: Path, *, overview: bool = True,
                started: float | None = None, glb: bool = False) -> tuple[Path, Path | None]:
    """After the blocks: ``city.usda``, (with ``overview``) ``city.png`` and (with
    ``glb``) ``city.glb``, their times (and the total since ``started``) added to the
    report, which is written again."""
    t = time.perf_counter()
    city = write_city_stage(out, report, inputs.frame.describe())
    report["timings"]["city_stage_s"] = time.perf_counter() - t
    if glb:
        t = time.perf_counter()
        write_city_glb(out, inputs, report)
        report["timings"]["city_glb_s"] = time.perf_counter() - t
    png = None
    if overview:
        t = time.perf_counter()
        png = render_overview(out, inputs, report)
        report["timings"]["overview_s"] = time.perf_counter() - t
    if started is not None:
        report["timings"]["total_s"] = time.perf_counter() - started
    write_report(out, report)
    return city, png


def write_city_stage(out: Path, report: Report, frame: str = "") -> Path:
    """``city.usda``: every built block's layer as a payload (the city opens unloaded
    when asked and loads blocks on demand), in the city's one frame, whose CRS and
    origin go on the root. Each block's box (its ``extent`` in ``manifest.json``) is its
    prim's ``extentsHint``, so a DCC that opens the city unloaded frames and culls it."""
    from citysynth.export.usd import write_city

    built = set(report["built"])
    boxes = {f"block_{b}": box for b, box in _extents(out).items() if b in built}
    return write_city(out / "city.usda", [(f"block_{b}", f"{BLOCKS_DIR}/{b}.usda")
                                          for b in report["built"]], frame=frame, boxes=boxes)


def _extents(out: Path) -> dict[str, list[list[float]]]:
    """Each built block's box as the run's manifest records it (none without one: a
    stage written over layers of another origin)."""
    try:
        blocks = json.loads((out / MANIFEST).read_text(encoding="utf-8"))["blocks"]
    except FileNotFoundError:
        return {}
    return {b: r["extent"] for b, r in blocks.items() if "extent" in r}


def _built_layouts(out: Path, inputs: CityInputs, report: Report
                   ) -> list[tuple[str, Layout, PartDB]]:
    """Every built block's layout (read back from its JSON) with its library."""
    from citysynth.export.layout import Layout

    jobs = {j.id: j for j in inputs.jobs}
    dbs: dict[str, PartDB] = {}
    lays = []
    for bid in report["built"]:
        path = jobs[bid].library
        dbs.setdefault(path, load_library(path))
        d = json.loads((out / BLOCKS_DIR / f"{bid}.layout.json").read_text(encoding="utf-8"))
        lays.append((bid, Layout.from_dict(d), dbs[path]))
    return lays


def write_city_glb(out: Path, inputs: CityInputs, report: Report) -> Path | None:
    """``city.glb``: every built block in one Y-up GLB (a node per block, named
    ``block_<id>`` as in city.usda; parts shared), the frame's georeference on the
    root's extras. None when nothing was built."""
    from citysynth.export.gltf import write_city_glb as write_glb
    from citysynth.export.materials import georeference

    if not report["built"]:
        return None
    frame = inputs.frame.describe()
    return write_glb(out / "city.glb", [(f"block_{bid}", lay, db) for bid, lay, db
                                        in _built_layouts(out, inputs, report)],
                     extras={"frame": frame, "georeference": georeference(frame),
                             "blocks": len(report["built"])})


def render_overview(out: Path, inputs: CityInputs, report: Report, *,
                    max_triangles: int | None = None) -> Path | None:
    """``city.png``: the built blocks from a perspective and from above; full geometry
    when it fits ``max_triangles``, else each part as its bounding box."""
    import trimesh

    from citysynth.export.assemble import triangle_count, world_boxes, world_mesh
    preview = import_shielded("citysynth.export.preview")   # (VTK's import: see there)
    MAX_TRIANGLES, render_meshes = preview.MAX_TRIANGLES, preview.render_meshes

    if not report["built"]:
        return None
    max_triangles = MAX_TRIANGLES if max_triangles is None else max_triangles
    lays = [(lay, db) for _bid, lay, db in _built_layouts(out, inputs, report)]
    total = sum(triangle_count(lay, db) for lay, db in lays)
    make = world_mesh if total <= max_triangles else world_boxes
    # meshes concatenate into a mesh (trimesh types the result as any geometry)
    mesh = cast(trimesh.Trimesh, trimesh.util.concatenate([make(lay, db) for lay, db in lays]))
    counts = report["counts"]
    title = (f"{counts['built']} blocks built, {counts['failed']} failed, "
             f"{counts['skipped']} skipped")
    return render_meshes(mesh, out / "city.png", title=title, size=(1600, 800), zoom=1.7)
