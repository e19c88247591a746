"""A city run: streets (and footprints) in, a folder of blocks, a city stage and a
report out. Independent per-block jobs run in a local process pool, or on a Dask
cluster; reruns skip blocks whose inputs are unchanged.

The run folder::

    OUT/city.usda            references every built block's layer
    OUT/city.png             overview: perspective beside a top view
    OUT/manifest.json        every block: input hash, status, files, cost (no timings,
                             so two runs of the same inputs write the same manifest)
    OUT/report.json          counts, reasons, time per stage
    OUT/blocks/<id>.layout.json, <id>.usda, <id>.done.json, parts/<part>.usdc
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import shapely

from citysynth.parts_db import PartDB, load_library
from citysynth.parts_db.files import sweep_temporaries, write_text
from citysynth.pipeline.city.config import BuildSettings, CityConfig, ConfigError
from citysynth.pipeline.city.jobs import (
    BLOCKS_DIR,
    BlockJob,
    block_id,
    cached,
    outline_wkt,
    run_block,
)
from citysynth.pipeline.layouts import check_style, default_style
from citysynth.skeletons import Frame, parse_geojson, read_geojson
from citysynth.skeletons.streets import Block, street_blocks

MANIFEST = "manifest.json"
REPORT = "report.json"
RUN_SCHEMA = "citysynth.run"
CONNECT_TIMEOUT = "10s"      # to reach a Dask scheduler
ORIGIN_DIGITS = 2            # the frame's lon/lat origin, rounded: streets edited at the
                             # edge of a network do not move every block (and its id)


@dataclass
class CityInputs:
    jobs: list[BlockJob]
    skipped: list[dict]                  # pieces that never became jobs, with reasons
    frame: Frame
    timings: dict[str, float] = field(default_factory=dict)


def _frame_tuple(frame: Frame) -> tuple[str, float, float]:
    return (frame.crs, frame.origin[0], frame.origin[1])


def prepare(streets: str | Path | None, footprints: str | Path | None, cfg: CityConfig,
            library: str | Path | None, crs: str | None = None) -> CityInputs:
    """Read the inputs and turn every block and footprint into a job."""
    t0 = time.perf_counter()
    if streets is None and footprints is None:
        raise ConfigError("nothing to build: give --streets, --footprints or both")
    origin = cfg.origin
    libraries: dict[str, PartDB] = {}

    def settings_db(s: BuildSettings) -> tuple[PartDB, str, str]:
        path = s.library or (str(Path(library).resolve()) if library else None)
        if path is None:
            raise ConfigError("no part library: give --library or library = \"...\" in the "
                              "config")
        if path not in libraries:
            libraries[path] = load_library(path)
        db = libraries[path]
        style = s.style or default_style(db)
        check_style(db, style)
        return db, path, style

    outlines: list[tuple[str, object, tuple[str, ...]]] = []   # (kind, polygon, highways)
    skipped: list[dict] = []
    frame = None
    if streets is not None:
        feats, frame = read_geojson(streets, crs=crs, origin=origin,
                                    origin_digits=ORIGIN_DIGITS)
        blocks, reasons = street_blocks(feats, cfg.setbacks, min_area=cfg.min_area)
        skipped += [{"kind": "block", "reason": r} for r in reasons]
        for b in blocks:
            width = 2 * b.polygon.area / b.polygon.length
            if width < cfg.min_width:
                c = b.polygon.centroid
                skipped.append({"kind": "block", "reason": f"block at ({c.x:.1f}, {c.y:.1f}): "
                                f"a sliver, {width:.1f} m wide on average (min_width "
                                f"{cfg.min_width:g} m)"})
                continue
            outlines.append(("block", b.polygon, _highways(b, feats)))
    if footprints is not None:
        feats, fframe = read_geojson(footprints, crs=crs,
                                     origin=frame.origin if frame else origin,
                                     origin_digits=ORIGIN_DIGITS)
        frame = frame or fframe
        for f in feats:
            polys = shapely.get_parts(f.geometry)
            for p in polys:
                if p.geom_type != "Polygon":
                    raise ConfigError(f"{footprints}: {f.name}: footprints must be Polygons, "
                                      f"got {p.geom_type}")
                if not p.is_valid or p.area < cfg.min_area:
                    skipped.append({"kind": "footprint", "reason": f"{f.name}: "
                                    + ("invalid outline" if not p.is_valid else
                                       f"{p.area:.1f} m², below min_area {cfg.min_area:g}")})
                    continue
                outlines.append(("footprint", p, ()))
    zones = _zone_polygons(cfg, frame, crs)
    jobs: dict[str, BlockJob] = {}
    for kind, poly, highways in outlines:
        wkt = outline_wkt(poly)
        zone_name, s = _zone_for(cfg, zones, poly, highways)
        db, path, style = settings_db(s)
        job = BlockJob(block_id(kind, wkt), kind, wkt, _frame_tuple(frame), zone_name, path,
                       db.library_hash, style, s.k, s.pick, cfg.seed,
                       tuple((n, lo, hi) for n, (lo, hi) in sorted(s.per_side.items())),
                       tuple((n, lo, hi) for n, (lo, hi) in sorted(s.per_block.items())),
                       cfg.stretch, cfg.corner_tolerance, cfg.mitre_cost,
                       cfg.min_edge).with_hash()
        jobs.setdefault(job.id, job)   # the same outline twice is one block
    return CityInputs(sorted(jobs.values(), key=lambda j: j.id), skipped, frame,
                      {"inputs_s": time.perf_counter() - t0})


def _highways(b: Block, feats) -> tuple[str, ...]:
    return tuple(sorted({str(feats[i].properties.get("highway")) for i in b.streets
                         if feats[i].properties.get("highway")}))


def _zone_polygons(cfg: CityConfig, frame: Frame, crs: str | None) -> list:
    """Each zone's polygon in the city frame (projected like the streets), or None for
    a zone chosen by street class; in the order of ``cfg.zones``."""
    with_poly = [z for z in cfg.zones if z.polygon]
    if not with_poly:
        return [None] * len(cfg.zones)
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": z.name},
         "geometry": {"type": "Polygon", "coordinates": [[*map(list, z.polygon),
                                                          list(z.polygon[0])]]}}
        for z in with_poly]}
    feats, _ = parse_geojson(fc, "city.toml zones", crs, frame.origin)
    geoms = iter(f.geometry for f in feats)
    return [next(geoms) if z.polygon else None for z in cfg.zones]


def _zone_for(cfg: CityConfig, zones, poly, highways) -> tuple[str, BuildSettings]:
    c = poly.representative_point()
    for z, geom in zip(cfg.zones, zones, strict=True):
        if (geom is not None and geom.contains(c)) or (set(z.highway) & set(highways)):
            return z.name, z.settings
    return "", cfg.settings


# --- executing ------------------------------------------------------------------------

def _local(jobs: list[BlockJob], out: Path, workers: int) -> Iterator[dict]:
    if workers <= 1:
        for job in jobs:
            yield run_block(job, str(out))
        return
    with ProcessPoolExecutor(workers) as pool:
        futures = {pool.submit(run_block, job, str(out)): job for job in jobs}
        for fut in as_completed(futures):
            yield _result(fut, futures[fut])


def _dask(jobs: list[BlockJob], out: Path, address: str) -> Iterator[dict]:
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:   # pragma: no cover - distributed is a dependency
        raise ConfigError("--scheduler needs the distributed package (pip install "
                          "distributed)") from None
    try:
        client = Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        raise ConfigError(f"cannot reach the Dask scheduler at {address} ({exc}); start "
                          "one (dask scheduler) or leave --scheduler out") from None
    with client:
        futures = client.map(run_block, jobs, out_dir=str(out),
                             key=[f"citysynth-{j.id}-{j.input_hash[:8]}" for j in jobs])
        by_key = {f.key: j for f, j in zip(futures, jobs, strict=True)}
        for fut in dask_completed(futures):
            yield _result(fut, by_key[fut.key])


def _result(fut, job: BlockJob) -> dict:
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
             progress: Callable[[int, int, dict], None] | None = None) -> dict:
    """Run every job not already done; write the manifest and the report; the report."""
    out = Path(out_dir)
    (out / BLOCKS_DIR).mkdir(parents=True, exist_ok=True)
    for folder in (out, out / BLOCKS_DIR, out / BLOCKS_DIR / "parts"):
        sweep_temporaries(folder)
    _remove_stale(out, {j.id for j in inputs.jobs})
    t0 = time.perf_counter()
    results: dict[str, dict] = {}
    todo = []
    for job in inputs.jobs:
        rec = cached(out, job)
        if rec is not None:
            results[job.id] = {**rec, "cached": True}
        else:
            todo.append(job)
    stream: Iterable[dict] = _dask(todo, out, scheduler) if scheduler else \
        _local(todo, out, workers)
    for done, rec in enumerate(stream, 1):
        results[rec["id"]] = rec
        if progress:
            progress(done, len(todo), rec)
    t_blocks = time.perf_counter() - t0
    return _write_summary(inputs, results, out, t_blocks, workers, scheduler)


def _remove_stale(out: Path, keep: set[str]) -> None:
    """Blocks of an earlier run whose inputs no longer exist leave the folder, so the
    folder always describes this run."""
    for marker in (out / BLOCKS_DIR).glob("*.done.json"):
        bid = marker.name[: -len(".done.json")]
        if bid not in keep:
            for suffix in (".layout.json", ".usda", ".done.json"):
                (out / BLOCKS_DIR / f"{bid}{suffix}").unlink(missing_ok=True)


def _write_summary(inputs: CityInputs, results: dict[str, dict], out: Path,
                   t_blocks: float, workers: int, scheduler: str | None) -> dict:
    ids = sorted(results)
    manifest = {"schema": RUN_SCHEMA, "version": 1, "frame": list(_frame_tuple(inputs.frame)),
                "blocks": {i: {k: results[i].get(k) for k in
                               ("kind", "zone", "input_hash", "status", "reason", "files",
                                "cost", "rank", "of", "style")
                               if results[i].get(k) is not None} for i in ids},
                "skipped": inputs.skipped}
    write_text(out / MANIFEST, json.dumps(manifest, sort_keys=True, indent=1) + "\n")
    counts = {s: sum(1 for r in results.values() if r["status"] == s)
              for s in ("built", "failed", "skipped")}
    counts["skipped"] += len(inputs.skipped)
    counts["cached"] = sum(1 for r in results.values() if r.get("cached"))
    stage: dict[str, float] = dict(inputs.timings)
    for r in results.values():
        if r.get("cached"):
            continue
        for k, v in r.get("timings", {}).items():
            if k != "total_s":
                stage[k] = stage.get(k, 0.0) + v
    stage["blocks_wall_s"] = t_blocks
    attempted = counts["built"] + counts["failed"]
    report = {"counts": counts, "blocks": len(inputs.jobs),
              "built_share": counts["built"] / attempted if attempted else 1.0,
              "failed": [{"id": i, "reason": results[i].get("reason")} for i in ids
                         if results[i]["status"] == "failed"],
              "skipped": inputs.skipped + [{"id": i, "reason": results[i].get("reason")}
                                           for i in ids if results[i]["status"] == "skipped"],
              "timings": stage, "workers": workers, "scheduler": scheduler,
              "built": [i for i in ids if results[i]["status"] == "built"]}
    write_report(out, report)
    return report


def write_report(out: Path, report: dict) -> None:
    write_text(out / REPORT, json.dumps(report, sort_keys=True, indent=1) + "\n")


def progress_printer(stream=sys.stderr) -> Callable[[int, int, dict], None]:
    """One updating line on a terminal; a line per tenth of the work otherwise."""
    tty = stream.isatty()
    t0 = time.perf_counter()
    state = {"built": 0, "failed": 0, "skipped": 0, "step": 0}

    def show(done: int, total: int, rec: dict) -> None:
        state[rec["status"]] += 1
        rate = done / max(time.perf_counter() - t0, 1e-9)
        line = (f"[{done:>{len(str(total))}}/{total}] built {state['built']}, failed "
                f"{state['failed']}, skipped {state['skipped']} ({rate:.1f} blocks/s)")
        if tty:
            print("\r" + line, end="\n" if done == total else "", file=stream, flush=True)
        elif total and (done * 10 // total > state["step"] or done == total):
            state["step"] = done * 10 // total
            print(line, file=stream, flush=True)
    return show


def cpu_count() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)


# --- city-wide outputs ------------------------------------------------------------------

def finish_city(inputs: CityInputs, report: dict, out: Path, *, overview: bool = True,
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


def write_city_stage(out: Path, report: dict) -> Path:
    """``city.usda``: every built block's layer, in the city's one frame."""
    from citysynth.export.usd import write_city

    return write_city(out / "city.usda", [(f"block_{b}", f"{BLOCKS_DIR}/{b}.usda")
                                          for b in report["built"]])


def render_overview(out: Path, inputs: CityInputs, report: dict, *,
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
    mesh = trimesh.util.concatenate([make(lay, db) for lay, db in lays])
    counts = report["counts"]
    title = (f"{counts['built']} blocks built, {counts['failed']} failed, "
             f"{counts['skipped']} skipped")
    return render_meshes(mesh, out / "city.png", title=title, size=(1600, 800), zoom=1.7)
