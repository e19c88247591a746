"""What a city run leaves beside its blocks: the manifest, the report, the city stage
and the overview.

``manifest.json`` describes every block (input hash, status, files, cost) and carries
no timings, so two runs of the same inputs write the same manifest (``citysynth diff``
reads it). ``report.json`` adds counts, reasons, the bugs met (with tracebacks) and the
time per stage. ``city.usda`` references every built block's layer in the city's one
frame; ``city.png`` shows the built blocks from a perspective and from above.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from citysynth.parts_db import PartDB, load_library
from citysynth.parts_db.files import write_text
from citysynth.pipeline.city.jobs import BLOCKS_DIR, STATUSES, BlockRecord, frame_tuple

if TYPE_CHECKING:   # the run imports this module to write its summary
    from citysynth.pipeline.city.run import CityInputs

MANIFEST = "manifest.json"
REPORT = "report.json"
RUN_SCHEMA = "citysynth.run"
_MANIFEST_KEYS = ("kind", "zone", "input_hash", "status", "reason", "error", "files", "cost",
                  "rank", "of", "style", "feature", "storeys", "note")

Report = dict[str, Any]   # report.json, as written


def write_summary(inputs: CityInputs, results: dict[str, BlockRecord], out: Path,
                  t_blocks: float, workers: int, scheduler: str | None) -> Report:
    """Write ``manifest.json`` and ``report.json`` for ``results`` (every job's record,
    by block id); the report."""
    ids = sorted(results)
    recs: dict[str, dict[str, Any]] = {i: dict(results[i]) for i in ids}
    manifest = {"schema": RUN_SCHEMA, "version": 1, "frame": list(frame_tuple(inputs.frame)),
                "blocks": {i: {k: recs[i][k] for k in _MANIFEST_KEYS
                               if recs[i].get(k) is not None} for i in ids},
                "skipped": inputs.skipped}
    write_text(out / MANIFEST, json.dumps(manifest, sort_keys=True, indent=1) + "\n")
    counts: dict[str, int] = {s: sum(1 for r in recs.values() if r["status"] == s)
                              for s in STATUSES}
    counts["skipped"] += len(inputs.skipped)
    counts["cached"] = sum(1 for r in recs.values() if r.get("cached"))
    attempted = counts["built"] + counts["failed"] + counts["error"]

    def with_status(status: str, key: str) -> list[dict[str, Any]]:
        return [{"id": i, key: recs[i].get(key)} for i in ids if recs[i]["status"] == status]

    report: Report = {
        "counts": counts, "blocks": len(inputs.jobs),
        "built_share": counts["built"] / attempted if attempted else 1.0,
        "failed": with_status("failed", "reason"),
        "storeys_not_matched": [{"id": i, "note": recs[i]["note"]} for i in ids
                                if recs[i].get("note")],
        "skipped": inputs.skipped + with_status("skipped", "reason"),
        "errors": [{"id": i, "error": recs[i]["error"], "traceback": recs[i]["traceback"]}
                   for i in ids if recs[i]["status"] == "error"],
        "timings": _stage_times(inputs, recs, t_blocks), "workers": workers,
        "scheduler": scheduler, "built": [i for i in ids if recs[i]["status"] == "built"]}
    write_report(out, report)
    return report


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
                started: float | None = None) -> tuple[Path, Path | None]:
    """After the blocks: ``city.usda`` and (with ``overview``) ``city.png``, their times
    (and the total since ``started``) added to the report, which is written again."""
    t = time.perf_counter()
    city = write_city_stage(out, report)
    report["timings"]["city_stage_s"] = time.perf_counter() - t
    png = None
    if overview:
        t = time.perf_counter()
        png = render_overview(out, inputs, report)
        report["timings"]["overview_s"] = time.perf_counter() - t
    if started is not None:
        report["timings"]["total_s"] = time.perf_counter() - started
    write_report(out, report)
    return city, png


def write_city_stage(out: Path, report: Report) -> Path:
    """``city.usda``: every built block's layer, in the city's one frame."""
    from citysynth.export.usd import write_city

    return write_city(out / "city.usda", [(f"block_{b}", f"{BLOCKS_DIR}/{b}.usda")
                                          for b in report["built"]])


def render_overview(out: Path, inputs: CityInputs, report: Report, *,
                    max_triangles: int = 3_000_000) -> Path | None:
    """``city.png``: the built blocks from a perspective and from above; full geometry
    when it fits ``max_triangles``, else each part as its bounding box."""
    import trimesh

    from citysynth.export.assemble import triangle_count, world_boxes, world_mesh
    from citysynth.export.layout import Layout
    from citysynth.export.preview import render_meshes

    if not report["built"]:
        return None
    jobs = {j.id: j for j in inputs.jobs}
    dbs: dict[str, PartDB] = {}
    lays = []
    for bid in report["built"]:
        path = jobs[bid].library
        dbs.setdefault(path, load_library(path))
        d = json.loads((out / BLOCKS_DIR / f"{bid}.layout.json").read_text(encoding="utf-8"))
        lays.append((Layout.from_dict(d), dbs[path]))
    total = sum(triangle_count(lay, db) for lay, db in lays)
    make = world_mesh if total <= max_triangles else world_boxes
    # meshes concatenate into a mesh (trimesh types the result as any geometry)
    mesh = cast(trimesh.Trimesh, trimesh.util.concatenate([make(lay, db) for lay, db in lays]))
    counts = report["counts"]
    title = (f"{counts['built']} blocks built, {counts['failed']} failed, "
             f"{counts['skipped']} skipped")
    return render_meshes(mesh, out / "city.png", title=title, size=(1600, 800), zoom=1.7)
