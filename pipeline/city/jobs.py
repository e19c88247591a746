"""One block of a city run: a self-contained, picklable job and the function that runs
it, in a local worker process or on a Dask worker alike.

A :class:`BlockJob` carries everything that decides the block's output: its outline
(in the city's frame, to the millimetre), the library (path and content hash), style,
k, which of the k to keep, constraints and tolerances. ``input_hash`` is the sha256 of
all that (and of the output format versions), so a rerun can skip a block whose hash
is unchanged. :func:`run_block` writes ``<id>.layout.json`` (the layout it keeps) and
``<id>.usda`` (each atomically; with k > 1, ``<id>.usda`` is a ``layout`` variantSet
over every rank's layer ``<id>_<rank>.usda``, the kept one selected, so an artist
switches between a block's k best inside the city), then, last, the marker
``<id>.done.json``, which records the hash: a run
killed at any moment leaves either a complete block or one that is redone. A bad or
infeasible block is an answer (status "failed" with its reason), never an exception.
Only the user's errors (:data:`~citysynth.pipeline.errors.USER_ERRORS`) are such
answers: any other exception is a bug, recorded as status "error" with its traceback
and no marker (a rerun tries the block again), and reported as a bug by the run.
"""

from __future__ import annotations

import hashlib
import json
import time
import traceback
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Literal, NotRequired, TypedDict, cast, get_args

import shapely

from citysynth.export.assemble import extent
from citysynth.export.infill import Roof
from citysynth.export.layout import SCHEMA, VERSION
from citysynth.export.place import max_stretch
from citysynth.export.usd import CUTS_SUFFIX, library_file_ok, library_files
from citysynth.parts_db import LibraryError, PartDB, load_library
from citysynth.parts_db.files import write_text
from citysynth.pipeline.city.config import Pick, ZoneKind
from citysynth.pipeline.city.folder import BLOCKS_DIR, MARKER
from citysynth.pipeline.city.footprints import (
    FootprintSpec,
    Prepared,
    failure,
    prepare,
    prepare_again,
    well_blocking,
)
from citysynth.pipeline.city.kinds import solve_kind
from citysynth.pipeline.errors import USER_ERRORS, environment_message
from citysynth.pipeline.layouts import Built, ranked_files, solve_layouts, write_outputs
from citysynth.skeletons import Frame

JOB_VERSION = 8          # bump when a block's output changes for the same inputs
VARIANTS_VERSION = 1     # the same, for what only k > 1 writes (the layout variantSet)
CITY_SLACK = 0.3         # m: any block side may be met this closely (city.toml slack)

BlockKind = Literal["block", "footprint"]    # a street block, or a building footprint
BlockStatus = Literal["built", "failed", "skipped", "error"]
"""built: its files are written; failed: the user's input cannot be built (infeasible,
or a user error), with the reason; skipped: nothing buildable is left of it; error: a
bug in citysynth, with its traceback (the only status that writes no marker)."""
STATUSES: tuple[BlockStatus, ...] = get_args(BlockStatus)


class BlockRecord(TypedDict):
    """What a block job answers, and (but for "error") what its marker records."""

    id: str
    kind: BlockKind
    zone: str
    input_hash: str
    style: str
    files: list[str]                       # relative to the run folder
    library_files: NotRequired[list[str]]  # the shared part and material files its USD
                                           # references, relative to blocks/
    status: NotRequired[BlockStatus]
    reason: NotRequired[str]               # why it failed or was skipped
    error: NotRequired[str]                # status "error": the exception, one line
    traceback: NotRequired[str]            # status "error": where it was raised
    timings: NotRequired[dict[str, float]]
    rank: NotRequired[int]                 # the layout kept: #rank of the `of` solved
    of: NotRequired[int]
    cost: NotRequired[float]
    instances: NotRequired[int]
    stretch: NotRequired[float]
    extent: NotRequired[list[list[float]]]  # built: the box around its k best, city frame
    feature: NotRequired[str]              # footprints: the input feature, as named
    storeys: NotRequired[int]              # footprints: the storeys its family has
    note: NotRequired[str]                 # footprints: storeys asked but not matched
    cached: NotRequired[bool]              # set by the run: read from an earlier run
    machine: NotRequired[bool]             # failed by the machine (disk, rights), not the
                                           # block: not recorded, and the city exits 2


def frame_tuple(frame: Frame) -> tuple[str, float, float]:
    """A frame as a job carries it (and its hash covers): CRS description and origin."""
    return (frame.crs, frame.origin[0], frame.origin[1])


@dataclass(frozen=True)
class BlockJob:
    id: str
    kind: BlockKind
    wkt: str                                    # outline in the city frame (metres)
    frame: tuple[str, float, float]             # CRS description and origin
    zone: str
    library: str                                # folder
    library_hash: str
    style: str
    k: int
    pick: Pick
    seed: int
    per_side: tuple[tuple[str, float, float], ...]
    per_block: tuple[tuple[str, float, float], ...]
    stretch: float
    corner_tolerance: float
    mitre_cost: float
    min_edge: float
    slack: float = CITY_SLACK
    footprint: FootprintSpec | None = None      # a footprint's feature and settings
    cut: bool = False                           # a street block cut back by footprints
    zone_kind: ZoneKind | None = None           # a row or towers zone's block (kinds.py)
    input_hash: str = ""

    def with_hash(self) -> BlockJob:
        d = asdict(replace(self, input_hash=""))
        d["versions"] = [JOB_VERSION, SCHEMA, VERSION]
        if self.k > 1:   # only k > 1 writes variants: k = 1 hashes and caches stay valid
            d["versions"].append(VARIANTS_VERSION)
        del d["library"]          # where the library lives does not change the output
        if self.zone_kind is None:   # perimeter blocks keep their hashes (and caches)
            del d["zone_kind"]
        if d["footprint"] is not None:
            # the file as the user spelled it (relative, through a link) changes no
            # output; what the notes say of the feature names it too
            fp = d["footprint"]
            source = fp.pop("source")
            for key in ("trimmed", "remarks"):
                if source:
                    fp[key] = fp[key].replace(source, "")
            for key in ("trimmed", "remarks", "party"):   # footprints without these keep
                if not d["footprint"][key]:               # the hashes they had before
                    del d["footprint"][key]
        text = json.dumps(d, sort_keys=True, separators=(",", ":"))
        return replace(self, input_hash=hashlib.sha256(text.encode()).hexdigest())


def block_id(kind: BlockKind, wkt: str) -> str:
    """A stable id from the outline: a block keeps its id (and its cached output) when
    streets elsewhere change."""
    return ("b" if kind == "block" else "f") + hashlib.sha256(wkt.encode()).hexdigest()[:10]


def outline_wkt(poly: shapely.Polygon) -> str:
    return shapely.to_wkt(shapely.normalize(poly), rounding_precision=3)


def marker_path(out: Path, job_id: str) -> Path:
    return out / BLOCKS_DIR / f"{job_id}{MARKER}"


def file_hash(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


_MARKER_TYPES = {"id": str, "kind": str, "zone": str, "input_hash": str, "style": str,
                 "files": list, "status": str, "hashes": dict, "seal": str}


def _seal(marker: dict) -> str:
    """The hash of a marker's own content but its seal: a marker edited by hand (its
    status, cost or rank) was trusted as written, its files' hashes being right: a
    block "failed" by an edit dropped out of the city, a cost edited went into the
    manifest and ``diff`` called the runs the same."""
    body = {k: v for k, v in marker.items() if k != "seal"}
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


def _marker_shape_ok(rec: object, job: BlockJob) -> bool:
    """A marker of the shape :func:`_finish` writes, for this job, with a status that is
    an answer (never "error"), and one hash for each of its files."""
    if not isinstance(rec, dict):
        return False
    if any(not isinstance(rec.get(k), t) for k, t in _MARKER_TYPES.items()):
        return False
    files, hashes = rec["files"], rec["hashes"]
    return (rec["id"] == job.id and rec["input_hash"] == job.input_hash
            and rec["status"] in ("built", "failed", "skipped")
            and all(isinstance(f, str) for f in files) and sorted(hashes) == sorted(files)
            and all(isinstance(h, str) for h in hashes.values())
            and isinstance(shared := rec.get("library_files", []), list)
            and all(isinstance(f, str) for f in shared))


def _inside(out: Path, name: str) -> Path | None:
    """``out / name`` when it stays inside the run folder (no absolute path, no ..)."""
    p = Path(name)
    if p.is_absolute() or ".." in p.parts:
        return None
    return out / p


def cached(out: Path, job: BlockJob) -> BlockRecord | None:
    """The result recorded for ``job`` by an earlier run, if its inputs are unchanged
    and every file its marker vouches for is there with the content it recorded. A
    marker of any other shape, or unreadable, means "build it again"."""
    try:
        rec = json.loads(marker_path(out, job.id).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not _marker_shape_ok(rec, job) or rec["seal"] != _seal(rec):
        return None
    for name, digest in rec["hashes"].items():
        f = _inside(out, name)
        try:
            if f is None or not f.is_file() or file_hash(f) != digest:
                return None
        except OSError:
            return None
    blocks = out / BLOCKS_DIR
    for name in rec.get("library_files", []):   # shared by blocks: checked, not hashed
        f = _inside(blocks, name)
        if f is None or not library_file_ok(f, job.library_hash):
            return None
    del rec["hashes"], rec["seal"]   # the record, as run_block answered it
    if job.footprint is not None:   # the file, as this run names it (not in the hash)
        said, rec["feature"] = rec.get("feature", ""), job.footprint.where
        for key in ("reason", "note"):
            if said and isinstance(said, str) and isinstance(rec.get(key), str):
                rec[key] = rec[key].replace(said, rec["feature"])
    return cast(BlockRecord, rec)


_LIBRARIES: dict[str, PartDB] = {}


def worker_library(path: str) -> PartDB:
    """The part database, loaded once per worker process."""
    if path not in _LIBRARIES:
        _LIBRARIES[path] = load_library(path)
    return _LIBRARIES[path]


def _pick_rank(job: BlockJob, count: int) -> int:
    if job.pick == "best" or count <= 1:
        return 1
    h = hashlib.sha256(f"{job.seed}:{job.id}".encode()).digest()
    return 1 + int.from_bytes(h[:8], "big") % count


def environment_failure(exc: BaseException) -> OSError | None:
    """The OS error (disk full, permission, I/O) behind ``exc``, if any: such a failure
    is the machine's, not the block's, and is never recorded as the block's result."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, OSError) and e.errno is not None:
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def run_block(job: BlockJob, out_dir: str) -> BlockRecord:
    """Build one block and write its files; the record (also written as its marker,
    unless the block met a bug or the machine failed it)."""
    out = Path(out_dir)
    t0 = time.perf_counter()
    rec: BlockRecord = {"id": job.id, "kind": job.kind, "zone": job.zone,
                        "input_hash": job.input_hash, "style": job.style, "files": []}
    try:
        return _build(job, out, rec, t0)
    except Exception as exc:
        env = environment_failure(exc)
        if env is not None:   # failed this time; a rerun (with space, rights) retries it
            rec["files"], rec["machine"] = [], True
            if isinstance(exc, USER_ERRORS):
                what = f"{exc}; fix the disk or permissions and run again"
            else:   # "...cuts.usdc: No space left on device; free space and run again"
                what = (f"could not write {'' if env.filename else 'its files: '}"
                        f"{environment_message(env)}")
            return _unrecorded(rec, "failed", t0, f"{what} (a failure of the machine, not "
                               "recorded: the next run builds the block)")
        if isinstance(exc, USER_ERRORS):   # one bad block never stops the city
            return _finish(out, rec, "failed", t0,
                           reason=_of_block(job, str(exc)) or type(exc).__name__)
        rec["error"] = f"{type(exc).__name__}: {exc}"     # a bug: never cached
        rec["traceback"] = traceback.format_exc()
        return _unrecorded(rec, "error", t0)


def _unrecorded(rec: BlockRecord, status: BlockStatus, t0: float,
                reason: str | None = None) -> BlockRecord:
    """A record that writes no marker (a bug, or a failure of the machine)."""
    rec["status"] = status
    if reason:
        rec["reason"] = reason
    rec.setdefault("timings", {})["total_s"] = time.perf_counter() - t0
    return rec


def _build(job: BlockJob, out: Path, rec: BlockRecord, t0: float) -> BlockRecord:
    """Clean the outline, solve its layouts, keep the picked one and write it."""
    db = worker_library(job.library)
    if db.library_hash != job.library_hash:
        raise LibraryError(f"{job.library}: the library changed during the run; run again "
                           "once it is as it should be")
    if job.footprint is not None:
        rec["feature"] = job.footprint.where
    t_solve = time.perf_counter()
    solved = solve_block(job, db)
    if isinstance(solved, str):
        return _finish(out, rec, "skipped", t0, reason=solved)
    prep, built = solved
    rec["timings"] = dict(built.timings)
    # the rest of solving: cleaning the outline, and any retry (a Kotka block spent
    # 84 s there that no stage listed)
    rec["timings"]["clean_s"] = max(time.perf_counter() - t_solve
                                    - sum(built.timings.values()), 0.0)
    if built.status != "ok":
        return _finish(out, rec, "failed", t0, reason=built.reason if job.zone_kind
                       else failure(prep, job, db, built.blocked_at))
    if prep.storeys is not None:
        rec["storeys"] = prep.storeys
    if prep.note:
        rec["note"] = prep.note
    rank = _pick_rank(job, len(built.layouts))
    lay = built.layouts[rank - 1]
    t1 = time.perf_counter()
    paths = write_block(built, rank, db, out / BLOCKS_DIR)
    rec["timings"]["write_s"] = time.perf_counter() - t1
    rec["files"] = [str(p.relative_to(out)) for p in paths]
    rec["library_files"] = library_files(built.layouts, db)
    rec["rank"], rec["of"], rec["cost"] = rank, len(built.layouts), lay.cost
    rec["instances"], rec["stretch"] = len(lay.instances), max_stretch(lay)
    box = extent(built.layouts, db)
    if box is not None:
        rec["extent"] = box
    return _finish(out, rec, "built", t0)


def solve_block(job: BlockJob, db: PartDB) -> str | tuple[Prepared, Built]:
    """The block's outline cleaned and its k best layouts (a footprint that fails is
    tried once more with its short sides absorbed), or why nothing buildable is left
    of it. The layouts may be infeasible: ``Built.status`` says."""
    if job.zone_kind is not None:   # a row or towers zone's block: its reason is whole
        return solve_kind(job, db)
    prep = prepare(job, db)
    if isinstance(prep, str):
        return prep
    built = _solve(job, db, prep)
    wells: tuple[tuple[float, float], ...] = ()
    while built.status != "ok" and job.footprint is not None:   # light wells closed: again
        well = well_blocking(prep, built.blocked_at)
        if well is None:
            break
        wells += (well,)
        shut = prepare(job, db, close=wells)
        if isinstance(shut, str):
            break
        prep, built = shut, _solve(job, db, shut)
    if built.status != "ok" and job.footprint is not None:   # short sides absorbed: again
        again = prepare_again(job, db)
        if again is not None:
            retry = _solve(job, db, again)
            if retry.status == "ok":
                return again, retry
    return prep, built


def usd_files(blocks: Path, job_id: str) -> list[Path]:
    """Every USD file of a block in ``blocks``: its layer (or variant stage), with
    k > 1 each rank's layer ``<id>_<rank>.usda``, and its cut prototypes."""
    own = [p for p in (blocks / f"{job_id}.usda", blocks / f"{job_id}{CUTS_SUFFIX}")
           if p.is_file()]
    return own + [p for _rank, files in ranked_files(blocks, job_id, [".usda"])
                  for p in files]


def write_block(built: Built, rank: int, db: PartDB, blocks: Path) -> list[Path]:
    """A built block's files in ``blocks``: the kept layout's JSON, ``<id>.layout.json``
    (what the city's GLB and overview and ``citysynth diff`` read), then its USD. With
    one layout, ``<id>.usda`` is that layout's layer (as it always was); with several,
    each rank's layer ``<id>_<rank>.usda`` and ``<id>.usda`` the ``layout`` variantSet
    over them with ``rank_<rank>`` selected (the same files ``building``/``block`` write,
    by the same code). USD files of the block an earlier run left beyond these go."""
    kept = Built(built.name, "ok", [built.layouts[rank - 1]])
    if len(built.layouts) == 1:
        paths = write_outputs(kept, db, blocks, formats=("json", "usd"), k=1)
    else:
        paths = write_outputs(kept, db, blocks, formats=("json",), k=1) + write_outputs(
            built, db, blocks, formats=("usd",), selected=rank)
    for stale in set(usd_files(blocks, built.name)) - set(paths):
        stale.unlink(missing_ok=True)
    return paths


def _roof(job: BlockJob) -> Roof:
    """What of a block's open ground is roofed: a footprint's all of it (unless its
    config turns infill off), a street block's the pockets too narrow for a yard."""
    if job.footprint is None:
        return "pockets"
    return "all" if job.footprint.infill else "none"


def _solve(job: BlockJob, db: PartDB, prep: Prepared) -> Built:
    # named as its skeleton is (so that _of_block says it as every other reason): a
    # block too large to solve was the bare id ("baad70468d2: baad70468d2: too large")
    label = job.footprint.label if job.footprint is not None else \
        f"feature 0 ({job.id})"
    return solve_layouts(job.id, prep.rings, db, job.style, job.k, label=label,
                         infill=_roof(job),
                         party=job.footprint.party if job.footprint is not None else (),
                         angle_tol=job.corner_tolerance, joint_cost=job.mitre_cost,
                         per_side={n: (lo, hi) for n, lo, hi in job.per_side},
                         per_structure={n: (lo, hi) for n, lo, hi in job.per_block},
                         **prep.options())


def _of_block(job: BlockJob, reason: str) -> str:
    """A failed block's reason as the report says it beside the block's id: a street
    block's skeleton is named "feature 0 (<id>)" (the one polygon it was built from;
    the name its layouts carry), which told a user nothing, so it is left out; a
    footprint's skeleton is named as its feature without the file ("feature 180
    (424090060): the convex corner ..."), which every other footprint message gives,
    so the file is put before it."""
    fp = job.footprint
    if fp is None:
        return reason.removeprefix(f"feature 0 ({job.id}): ")
    return f"{fp.where}: {reason.removeprefix(f'{fp.label}: ')}" \
        if reason.startswith(f"{fp.label}: ") else reason


def _finish(out: Path, rec: BlockRecord, status: BlockStatus, t0: float,
            reason: str | None = None) -> BlockRecord:
    """Record the block's answer in its marker, written last and with the hash of every
    file it vouches for; a marker that cannot be written leaves the block unrecorded."""
    rec["status"] = status
    if reason:
        rec["reason"] = reason
    rec.setdefault("timings", {})["total_s"] = time.perf_counter() - t0
    marker = {**rec, "hashes": {f: file_hash(out / f) for f in rec["files"]}}
    marker["seal"] = _seal(marker)
    write_text(marker_path(out, rec["id"]), json.dumps(marker, sort_keys=True, indent=1)
               + "\n")
    return rec
