"""Ingest a part library into a :class:`PartDB`, cached by content hash.

``ingest`` reads the manifest, loads and measures every mesh, snaps lengths to the
library quantum, computes the transition-cost table and writes the database (JSON
metadata + an npz of arrays) atomically. The database records the sha256 of the
manifest and every mesh (and of this format); an unchanged library is a cache hit
and is only read back. Any bad part stops the ingest before anything is written.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import shlex
import zipfile
import zlib
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
import shapely.errors

from citysynth.parts_db import stored
from citysynth.parts_db.costs import allowed_matrix, cost_matrix
from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.files import atomic_path, no_such_folder
from citysynth.parts_db.manifest import Manifest, PartClass, read_manifest
from citysynth.parts_db.measure import (
    STACKED,
    STRAIGHT,
    coarse_floats,
    corner_disagrees,
    inside_out,
    measure,
    off_frame,
    snap_legs,
)
from citysynth.parts_db.mesh_faults import companions
from citysynth.parts_db.meshes import COUNT_ATTRIBUTE, COUNTED, load_part_mesh, mesh_bytes
from citysynth.solver.methods import DEFAULT_MAX_MEMORY_MB
from citysynth.solver.safe_read import shown

FORMAT_VERSION = 2
DB_JSON = "partdb.json"
DB_NPZ = "partdb.npz"
DEFAULT_OUT = ".citysynth"  # inside the library folder, when it may be written there
CACHE_ENV = "CITYSYNTH_CACHE"   # a folder for every library's database instead
PARTS_PER_WORKER = 100      # below this a process pool costs more than it saves


@dataclass
class Part:
    """One measured part. Lengths in metres; ``legs`` snapped to the quantum."""

    id: str
    cls: PartClass
    style: str
    file: str
    attributes: dict[str, float]
    legs: list[float]             # snapped primary extents (one per leg for key parts)
    legs_measured: list[float]
    directions: list[list[float]]
    scale: float                  # stretch along the primary axis that realises `legs`
    origin: list[float]           # mesh point placed at the part's start (Measured.origin)
    height: float
    floor_area: float | None
    angle: float | None = None
    convex: bool | None = None
    sec_in: object = None         # shapely geometry
    sec_out: object = None
    sec_branch: object = None

    @property
    def length(self) -> float:
        return float(sum(self.legs))


@dataclass
class PartDB:
    """The compiled part database: parts, class rules and transition costs."""

    name: str
    library_hash: str
    quantum: float
    parts: list[Part]
    allowed: np.ndarray           # bool [n, n]
    cost: np.ndarray              # float [n, n], inf where not allowed
    cost_branch: np.ndarray       # float [n, n]: T part's branch leg -> f, inf elsewhere
    warnings: list[str] = field(default_factory=list)
    path: Path | None = None
    cache_hit: bool = False
    library_root: Path | None = None   # where the part meshes are (Part.file is relative)
    meters_per_unit: float = 1.0

    def mesh_path(self, part: Part) -> Path:
        if self.library_root is None:
            raise LibraryError(f"part database {self.path}: it does not record its library "
                               "folder; ingest the library again")
        return self.library_root / part.file

    @property
    def ids(self) -> list[str]:
        return [p.id for p in self.parts]

    def index(self) -> dict[str, int]:
        return {p.id: i for i, p in enumerate(self.parts)}

    @property
    def by_id(self) -> dict[str, Part]:
        """Every part by id (built on first use and kept: writers and placers look parts
        up per instance, thousands of times a city block). Read it, do not change it."""
        by_id = self.__dict__.get("_by_id")
        if by_id is None or len(by_id) != len(self.parts):
            by_id = self.__dict__["_by_id"] = {p.id: p for p in self.parts}
        return by_id

    def part(self, part_id: str) -> Part:
        """The part of that id."""
        return self.by_id[part_id]

    def select(self, cls: PartClass | None = None, style: str | None = None) -> list[Part]:
        """The parts of class ``cls`` and style ``style`` (None: any), in library order."""
        return [p for p in self.parts if (cls is None or p.cls == cls)
                and (style is None or p.style == style)]


def library_hash(m: Manifest) -> str:
    h = hashlib.sha256(f"citysynth-partdb-{FORMAT_VERSION}\n".encode())
    h.update(m.path.read_bytes())
    root = m.path.parent
    for spec in m.parts:
        f = root / spec.file
        h.update(spec.file.encode() + b"\0")
        data = mesh_bytes(f, f'part "{spec.id}" ({f})')
        h.update(data)
        for other in companions(f, data):   # a .gltf's .bin, an OBJ's .mtl
            h.update(b"\0" + other.name.encode() + b"\0")
            h.update(mesh_bytes(other, f'part "{spec.id}" ({other})'))
    return h.hexdigest()


def cache_dir(root: Path) -> Path:
    """Where a library's database is cached: under ``$CITYSYNTH_CACHE`` when set (one
    folder per library path); else ``<library>/.citysynth`` when the library is a folder
    of the user's that may be written; else (an installed, read-only library, such as
    the sample library inside the package) the user's cache folder. Never beside
    site-packages, so an installed citysynth stays as pip wrote it."""
    root = root.resolve()
    tag = f"{root.name}-{hashlib.sha256(str(root).encode()).hexdigest()[:12]}"
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser() / tag
    installed = any(p in ("site-packages", "dist-packages") for p in root.parts)
    if not installed and os.access(root, os.W_OK):
        return root / DEFAULT_OUT
    return user_cache_dir(root)


def user_cache_dir(root: Path) -> Path:
    """The user's cache folder for the library at ``root``."""
    root = root.resolve()
    tag = f"{root.name}-{hashlib.sha256(str(root).encode()).hexdigest()[:12]}"
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "citysynth" / "partdb" / tag


def ingest(library_dir: str | Path, out: str | Path | None = None, *, force: bool = False,
           progress: Callable[[int, int, str], None] | None = None) -> PartDB:
    """Ingest ``library_dir`` into ``out`` (default: :func:`cache_dir`)."""
    m = read_manifest(library_dir)
    _check_table_size(m)
    root = m.path.parent
    out_dir = Path(out) if out is not None else cache_dir(root)
    digest = library_hash(m)
    there = _stored_json(out_dir) if out is not None and not force else None
    if out is not None and not force:
        _check_not_anothers(there, out_dir, root, digest)
    if not force:   # where the cache falls back to, too (see _save_cache)
        for folder in [out_dir] if out is not None else _cache_folders(out_dir, root):
            cached = _read_cached(folder, digest, there if folder == out_dir else None)
            if cached is not None:
                return cached
    parts, warnings = [], []
    for i, (part, part_warnings) in enumerate(_measure_all(root, m)):
        if progress:
            progress(i, len(m.parts), part.id)
        parts.append(part)
        warnings += part_warnings
    _check_stored(parts, m)
    classes = [p.cls for p in parts]
    allowed = allowed_matrix(classes)
    cost = cost_matrix([p.sec_out for p in parts], [p.sec_in for p in parts], allowed)
    is_t = np.array([c == "t_junction" for c in classes])
    branch_ok = allowed & is_t[:, None]
    cost_branch = cost_matrix([p.sec_branch if p.sec_branch is not None else p.sec_out
                               for p in parts], [p.sec_in for p in parts], branch_ok)
    db = PartDB(m.name, digest, m.quantum, parts, allowed, cost, cost_branch, warnings,
                out_dir, False, root.resolve(), m.meters_per_unit)
    if out is None:
        _save_cache(db, out_dir, root)
    else:     # the folder the user named: failing to write it is an error
        save(db, out_dir)
    return db


def _stored_json(out_dir: Path) -> object:
    """The JSON of the database in ``out_dir``, read once for every check ingest makes
    of it (a large library's is megabytes); None when there is none or it is no JSON."""
    try:
        return stored.read_json(out_dir / DB_JSON)
    except LibraryError:
        return None


def _check_not_anothers(meta: object, out_dir: Path, root: Path, digest: str) -> None:
    """Refuse ``-o`` naming a folder that holds another library's database (``meta``,
    its JSON; another library folder, other parts): it was replaced without a word, and
    every command reading it as the other library's then placed this library's parts.
    The same library ingested again (changed since, or moved) replaces it, as ever."""
    if not isinstance(meta, dict):    # none there, or not one to keep
        return
    theirs = meta.get("library_root")
    try:
        if meta.get("library_hash") == digest or not isinstance(theirs, str) or \
                Path(theirs).resolve() == root.resolve() or not Path(theirs).is_dir():
            return
    except (OSError, ValueError):     # a path no file system has
        return
    raise LibraryError(
        f"{out_dir}: holds the part database of another library ({shown(meta.get('name'))}"
        f", from {theirs}); a folder holds one library's database: give another output "
        "folder (-o), or --force to replace it")


TABLE_BYTES = 18   # a (part, part) pair's: allowed, cost, T-branch cost and its mask


def _check_table_size(m: Manifest) -> None:
    """Refuse, before measuring a mesh, a library whose transition tables (one entry for
    each ordered pair of parts) would not fit the memory budget: 15,000 parts measured
    for 195 s and then died making a 3.4 GB table (a traceback)."""
    n = len(m.parts)
    need = n * n * TABLE_BYTES
    budget = DEFAULT_MAX_MEMORY_MB * 2**20
    if need > budget:
        most = math.isqrt(budget // TABLE_BYTES)
        raise LibraryError(
            f"{m.path}: {n:,} parts: their transition-cost tables (an entry for each part "
            f"that may follow each part) would take {need / 2**20:,.0f} MB, over the memory "
            f"budget of {DEFAULT_MAX_MEMORY_MB:,} MB (at most about {most:,} parts); "
            "split the library into smaller ones, by style or by kind of structure")


def _check_stored(parts: list[Part], m: Manifest) -> None:
    """Each part as its database entry will hold it, checked as a database is checked
    when it is read (:func:`stored.part_fields`): a part ingest measured but every reader
    would refuse (a building 100 km tall, a storey of 10,000 km², 10,001 doors counted
    from its sub-meshes) is refused now, naming its mesh, not written to be refused later
    with a fix (ingest again) that writes it again."""
    seen: dict[str, str] = {}
    for i, part in enumerate(parts):
        try:
            stored.part_fields(_part_json(part), i, m.path, seen, m.quantum)
        except LibraryError as exc:
            raise LibraryError(f"{exc} (measured from {m.path.parent / part.file}); check "
                               "the mesh, its size and the library's units") from None


def _measure_all(root: Path, m: Manifest):
    """Measure every part, in manifest order; large libraries on all cores (each part is
    independent, and a bad part's error travels back unchanged)."""
    workers = min(os.cpu_count() or 1, len(m.parts) // PARTS_PER_WORKER)
    jobs = [(root, m, spec) for spec in m.parts]
    if workers <= 1:
        yield from map(_measure_job, jobs)
        return
    with ProcessPoolExecutor(workers) as pool:
        yield from pool.map(_measure_job, jobs, chunksize=8)


def _measure_job(job) -> tuple[Part, list[str]]:
    root, m, spec = job
    warnings: list[str] = []
    return _ingest_part(root, m, spec, warnings), warnings


def _ingest_part(root: Path, m: Manifest, spec, warnings: list[str]) -> Part:
    f = root / spec.file
    where = f'part "{spec.id}" ({f})'
    mesh, counts = load_part_mesh(f, spec.id, m.meters_per_unit)
    meas = measure(mesh, spec, where)
    q = m.quantum
    shortest = min(meas.legs)
    if q > shortest:     # snapped, the part would grow to a quantum (1000 m for 5 m)
        raise LibraryError(f"{where}: it measures {shortest:.3g} m, less than the "
                           f"library's quantum of {q:g} m, the step every part length is "
                           "snapped to; choose a quantum a small fraction of the shortest "
                           "part (0.1 or 0.2 m) in [library] of the manifest")
    legs_q = snap_legs(meas.legs, q)
    scale = 1.0
    if m.rescale and (spec.cls in STRAIGHT or spec.cls in STACKED):
        scale = legs_q[0] / meas.legs[0]
    change = max(abs(a - b) for a, b in zip(legs_q, meas.legs, strict=True))
    if change > 0.25 * q:
        warnings.append(f"{spec.id}: snapped by {change:.3f} m to the {q:g} m grid")
    if (wrong := corner_disagrees(mesh, spec, meas.legs)) is not None:
        warnings.append(f"{spec.id}: {wrong}")
    for why in (off_frame(mesh, spec.cls), coarse_floats(mesh, f.suffix, m.meters_per_unit),
                inside_out(mesh)):
        if why is not None:
            warnings.append(f"{spec.id}: {why}")
    if spec.ignored:   # a corner labelled with another class would be used as that
        warnings.append(f"{spec.id}: {' and '.join(spec.ignored)} ignored: only corners "
                        f"have them, and its class is {spec.cls} (set class = \"corner\" "
                        "if it is a corner)")
    attrs = dict(spec.attributes)
    for k in COUNTED:  # named sub-meshes count where the manifest is silent
        key = COUNT_ATTRIBUTE[k]
        if key not in attrs and counts[k]:
            attrs[key] = float(counts[k])
    if meas.floor_area is not None:
        attrs.setdefault("floor_area", round(meas.floor_area, 6))
    return Part(spec.id, spec.cls, spec.style, spec.file, attrs, legs_q, meas.legs,
                [list(d) for d in meas.directions], scale, list(meas.origin), meas.height,
                meas.floor_area,
                spec.angle, spec.convex, meas.sec_in, meas.sec_out, meas.sec_branch)


# --- storage ------------------------------------------------------------------------------

def _part_json(p: Part) -> dict:
    d = {k: getattr(p, k) for k in ("id", "cls", "style", "file", "attributes", "legs",
                                     "legs_measured", "directions", "scale", "origin",
                                     "height",
                                     "floor_area", "angle", "convex")}
    for k in ("sec_in", "sec_out", "sec_branch"):
        g = getattr(p, k)
        d[k] = None if g is None else _wkt(g)
    return d


def _wkt(g) -> str:
    """A section as WKT to 1 µm; in full precision should rounding make it invalid (a
    sliver thinner than that), which the loader would refuse."""
    text = shapely.to_wkt(g, rounding_precision=6)
    return text if shapely.from_wkt(text).is_valid else shapely.to_wkt(g, rounding_precision=-1)


def save(db: PartDB, out_dir: Path) -> None:
    """Write the npz and the JSON (which carries the library hash and the npz's own
    hash, and so vouches for both), each through a temporary file and an atomic
    rename; both temporaries are written in full before either is renamed, npz first.
    A disk that filled while the JSON was written left the new npz beside the old
    JSON: ``--force`` over a good database broke it, and into an empty folder left a
    lone npz."""
    out_dir.mkdir(parents=True, exist_ok=True)
    for name in (DB_JSON, DB_NPZ):   # a rename over it would fail after the other's
        there = out_dir / name
        if there.is_dir() and not there.is_symlink():
            raise LibraryError(f"{there}: a folder stands where the part database's "
                               f"{name} goes; move it away or give another output folder (-o)")
    buf = io.BytesIO()
    np.savez_compressed(buf, allowed=db.allowed, cost=db.cost, cost_branch=db.cost_branch)
    npz = buf.getvalue()
    meta = {"format": FORMAT_VERSION, "name": db.name, "library_hash": db.library_hash,
            "quantum": db.quantum, "warnings": db.warnings,
            "library_root": str(db.library_root) if db.library_root else None,
            "meters_per_unit": db.meters_per_unit,
            "npz_sha256": hashlib.sha256(npz).hexdigest(),
            "parts": [_part_json(p) for p in db.parts]}
    with atomic_path(out_dir / DB_JSON) as tmp_json:
        tmp_json.write_text(json.dumps(meta, indent=1, sort_keys=True), encoding="utf-8")
        with atomic_path(out_dir / DB_NPZ) as tmp_npz:
            tmp_npz.write_bytes(npz)


# A damaged database (truncated, edited, another format) raises any of these on reading;
# :mod:`parts_db.stored` turns every one it can foresee into a LibraryError naming it.
_DAMAGED = (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError, EOFError,
            RecursionError, zipfile.BadZipFile, zlib.error, shapely.errors.ShapelyError)


def _read_db(out_dir: Path, parsed: object = None) -> PartDB:
    """The database in ``out_dir`` (``parsed``: its JSON, when already read), every
    table read now (an npz is read lazily), checked against the hash the JSON records
    for it, and every value checked as ingest makes it (:mod:`parts_db.stored`): what
    the pipeline reads later, it may trust."""
    meta = stored.read_meta(out_dir / DB_JSON, FORMAT_VERSION, parsed)
    try:
        npz = (out_dir / DB_NPZ).read_bytes()
    except FileNotFoundError:
        raise LibraryError(f"{out_dir / DB_NPZ}: missing") from None
    except OSError as exc:
        raise LibraryError(f"{out_dir / DB_NPZ}: cannot be read ({exc.strerror or exc})"
                           ) from None
    if "npz_sha256" in meta and hashlib.sha256(npz).hexdigest() != meta["npz_sha256"]:
        raise LibraryError(f"{out_dir / DB_NPZ}: does not match the hash {DB_JSON} records "
                           "for it (changed, or cut short, since it was written)")
    tables = stored.read_tables(out_dir / DB_NPZ, npz)
    seen: dict[str, str] = {}
    parts = [Part(**stored.part_fields(d, i, out_dir / DB_JSON, seen, meta["quantum"]))
             for i, d in enumerate(meta["parts"])]
    stored.check_tables(out_dir / DB_NPZ, tables, parts)
    if meta.get("library_root"):
        stored.check_meshes(out_dir / DB_JSON, Path(meta["library_root"]), parts)
    return PartDB(meta["name"], meta["library_hash"], float(meta["quantum"]), parts,
                  tables["allowed"], tables["cost"], tables["cost_branch"],
                  meta["warnings"], out_dir, True,
                  Path(meta["library_root"]) if meta.get("library_root") else None,
                  float(meta.get("meters_per_unit", 1.0)))


def load_db(out_dir: str | Path) -> PartDB:
    """A database folder written by ``citysynth ingest -o``; a damaged one is the
    user's to rebuild (from the library it names, when that is still there), said in
    one line that names the file, the part or key, and what is wrong."""
    out_dir = Path(out_dir)
    try:
        return _read_db(out_dir)
    except _DAMAGED as exc:   # LibraryError among them: stored's refusals
        lib = stored.library_of(out_dir / DB_JSON)
        what = str(exc) if isinstance(exc, LibraryError) else \
            f"{out_dir}: a damaged part database ({exc})"
        raise LibraryError(f"{what}; write it again with citysynth ingest "
                           f"{shlex.quote(lib or 'LIBRARY')} -o {shlex.quote(str(out_dir))} "
                           "--force") from None


def _check_still_its_library(db: PartDB, folder: Path) -> None:
    """Refuse a database written with ``ingest -o`` whose library (still where it was)
    has changed since: a part's mesh made 9 m long was placed at the 6 m the database
    measured, ten buildings each overlapping the next by 3 m, exit 0. (A library gone
    is told where its meshes are read; a manifest that no longer reads leaves the
    database as it is.)"""
    root = db.library_root
    if root is None or not (root / "manifest.toml").is_file():
        return
    try:
        digest = library_hash(read_manifest(root))
    except LibraryError:
        return
    if digest != db.library_hash:
        raise LibraryError(
            f"{folder}: the part database was written from {root}, whose manifest or "
            "meshes have changed since (a part's mesh edited, a part added or removed): "
            f"its lengths and costs are stale; write it again with citysynth ingest "
            f"{shlex.quote(str(root))} -o {shlex.quote(str(folder))} --force")


def _read_cached(out_dir: Path, digest: str, meta: object = None) -> PartDB | None:
    """The cached database when it is this library's and whole (``meta``: its JSON,
    when already read); None (ingest again, which overwrites it: the cache heals) when
    it is missing, stale or damaged."""
    try:
        if meta is None:
            meta = stored.read_json(out_dir / DB_JSON)
        if not isinstance(meta, dict) or meta.get("format") != FORMAT_VERSION or \
                meta.get("library_hash") != digest:
            return None
        return _read_db(out_dir, meta)
    except _DAMAGED:
        return None


def _cache_folders(out_dir: Path, root: Path) -> list[Path]:
    """Where the library at ``root`` is cached, in the order tried: its cache folder
    ``out_dir``, then the user's cache folder it falls back to (once, when the two are
    one). Written and read in this one order, so a fallback is found again."""
    return list(dict.fromkeys((out_dir, user_cache_dir(root))))


def _save_cache(db: PartDB, out_dir: Path, root: Path) -> None:
    """Cache ``db``; a cache folder that cannot be written (read-only, full, or a
    ``$CITYSYNTH_CACHE`` that is a file) falls back to the user's cache folder, said,
    and read from there next time (:func:`ingest` looks there too: the fallback was
    written on every run and never read); failing that the run goes on uncached."""
    for folder in _cache_folders(out_dir, root):
        try:
            save(db, folder)
        except OSError:
            continue
        if folder != out_dir:
            db.warnings.append(f"could not cache the part database in {out_dir} (not "
                               f"writable); cached it in {folder} instead")
        db.path = folder
        return
    db.warnings.append(f"could not cache the part database in {out_dir} (not writable); "
                       "it is measured again next time")


def load_library(path: str | Path) -> PartDB:
    """The database of a library folder (ingesting it, or reading the cache), or of a
    database folder written by ``citysynth ingest -o``.

    The sample library that ships with citysynth; the first call measures every part,
    later ones read the cache (here a folder of our own, unless ``$CITYSYNTH_CACHE``
    names one already: see :func:`cache_dir`):

    >>> import os, tempfile
    >>> from citysynth.examples import SAMPLE_LIBRARY
    >>> _ = os.environ.setdefault("CITYSYNTH_CACHE", tempfile.mkdtemp())
    >>> db = load_library(SAMPLE_LIBRARY)
    >>> db.name, db.quantum, sorted({p.style for p in db.parts})
    ('citysynth sample', 0.2, ['classic', 'modern', 'tower'])
    >>> load_library(SAMPLE_LIBRARY).cache_hit        # unchanged: read back, not measured
    True
    >>> corner = db.select("corner", "classic")[0]
    >>> corner.id, corner.angle, corner.convex, corner.legs   # legs snapped to 0.2 m
    ('classic_corner_90_convex', 90.0, True, [16.8, 16.8])
    """
    p = Path(path)
    if (p / "manifest.toml").is_file():
        return ingest(p)
    if (p / DB_JSON).is_file():
        db = load_db(p)
        _check_still_its_library(db, p)
        return db
    if not p.exists():
        raise LibraryError(f"{p}: {no_such_folder(p)}; give the folder of a part library (with "
                           f"manifest.toml) or of a part database (with {DB_JSON})")
    raise LibraryError(f"{p}: neither a library (no manifest.toml) nor a part database "
                       f"(no {DB_JSON})")
