"""Read a stored part database (``partdb.json`` + ``partdb.npz``) and check it, once.

A database folder is written by ``citysynth ingest`` but may be edited by hand, cut
short, copied from another version or moved. Everything the pipeline later trusts is
checked here, against the same rules ingest applies (the manifest's checks of a part's
fields, the measurement's plausible extents, the snapping to the quantum, the class
rules of the cost table), so a damaged value is named where it is stored (file, part,
key) instead of crashing or silently changing a layout far downstream. Every refusal
is a :class:`LibraryError` naming the file; the loader adds how to write the database
again.
"""

from __future__ import annotations

import io
import json
import math
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import shapely.errors

from citysynth.parts_db.costs import allowed_matrix
from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.manifest import (
    PartSpec,
    check_attributes,
    check_class,
    check_corner,
    check_file,
    check_id,
    check_style,
    finite,
    positive,
)
from citysynth.parts_db.measure import (
    EPS,
    PLAUSIBLE_LENGTH,
    PLAUSIBLE_STOREY,
    STACKED,
    STRAIGHT,
    leg_directions,
    snap_legs,
)
from citysynth.parts_db.meshes import FORMATS
from citysynth.solver.safe_read import _lone_surrogate, decode

TABLES = ("allowed", "cost", "cost_branch")
META_KEYS = {"format", "name", "library_hash", "quantum", "warnings", "parts"}
META_OPTIONAL = {"library_root", "meters_per_unit", "npz_sha256"}
PART_KEYS = {"id", "cls", "style", "file", "attributes", "legs", "legs_measured",
             "directions", "scale", "origin", "height", "floor_area", "angle", "convex",
             "sec_in", "sec_out", "sec_branch"}
MAX_FLOOR_AREA = 1e6     # m² of one storey (a square kilometre)
MAX_HEIGHT = 10_000.0    # m of one part
MAX_COORD = 1e9          # m: no mesh lies farther out (1e300 overflowed placing parts)
LEGS = {"corner": 2, "t_junction": 3}   # legs per class; every other class has one


def _show(v: object) -> str:
    """A stored value for a message, cut short (a damaged file may hold megabytes)."""
    r = repr(v)
    return r if len(r) <= 40 else r[:37] + "..."


def read_json(path: Path) -> object:
    """The JSON value of ``path``, every failure one LibraryError (read once where
    several checks look at ``partdb.json``: :func:`read_meta` takes it). NaN is let through:
    the check of the key holding it names it, which parse_json cannot."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise LibraryError(f"{path}: missing") from None
    except OSError as exc:
        raise LibraryError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    text = decode(data, path, "part database", LibraryError)
    if not text.strip():
        raise LibraryError(f"{path}: empty")
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise LibraryError(f"{path}: not valid JSON at line {exc.lineno}, column "
                           f"{exc.colno} (cut short or edited)") from None
    except (ValueError, RecursionError):   # thousands of digits; nesting too deep
        raise LibraryError(f"{path}: not a part database (a number of thousands of "
                           "digits, or nesting hundreds of levels deep)") from None
    if "\\u" in text and _lone_surrogate(value):
        raise LibraryError(f"{path}: a string holds half of a UTF-16 surrogate pair (a "
                           "\\udXXX escape without its partner), which is no character")
    return value


def read_meta(path: Path, format_version: int, parsed: object = None) -> dict[str, Any]:
    """The JSON of ``partdb.json`` (``parsed``: already read), its top-level keys
    checked (``format`` first: a database of another version is named as such, not as
    damaged)."""
    meta = read_json(path) if parsed is None else parsed
    if not isinstance(meta, dict):
        raise LibraryError(f"{path}: holds {type(meta).__name__}, not a part database "
                           "(a JSON object)")
    if meta.get("format") != format_version:
        raise LibraryError(f"{path}: a part database of format {_show(meta.get('format'))}, "
                           f"written by another version of citysynth (this one reads format "
                           f"{format_version})")
    missing = sorted(META_KEYS - set(meta))
    unknown = sorted(set(meta) - META_KEYS - META_OPTIONAL)
    if missing or unknown:
        raise LibraryError(f"{path}: " + (f"has no {', '.join(missing)}" if missing
                                           else f"unknown key(s) {unknown}"))
    for key in ("name", "library_hash"):
        if not isinstance(meta[key], str):
            raise LibraryError(f"{path}: {key} must be a string, got {_show(meta[key])}")
    positive(meta["quantum"], f"{path}: quantum")
    positive(meta.get("meters_per_unit", 1.0), f"{path}: meters_per_unit")
    if not isinstance(meta["warnings"], list) or \
            not all(isinstance(w, str) for w in meta["warnings"]):
        raise LibraryError(f"{path}: warnings must be a list of strings")
    if not isinstance(meta.get("npz_sha256", ""), str):
        raise LibraryError(f"{path}: npz_sha256 must be a string")
    root = meta.get("library_root")
    if root is not None and (not isinstance(root, str) or not Path(root).is_dir()):
        shown = root if isinstance(root, str) else _show(root)
        raise LibraryError(f"{path}: the library it was ingested from ({shown}) is not a "
                           "folder any more (moved or deleted?); its part meshes are read "
                           "from there")
    if not isinstance(meta["parts"], list) or not meta["parts"]:
        raise LibraryError(f"{path}: parts must be a non-empty list")
    return meta


def read_tables(path: Path, data: bytes) -> dict[str, np.ndarray]:
    """The tables of ``partdb.npz`` (its bytes ``data``), every one read now."""
    try:
        with np.load(io.BytesIO(data)) as z:
            missing = [k for k in TABLES if k not in z.files]
            if missing:
                raise LibraryError(f"{path}: has no {', '.join(missing)} table")
            return {k: z[k] for k in TABLES}
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        if isinstance(exc, LibraryError):
            raise
        raise LibraryError(f"{path}: not a readable table archive (cut short, or overwritten "
                           "with another file)") from None


def _numbers(v: object, n: int, where: str, key: str, *, signed: bool = False
             ) -> list[float]:
    """A list of ``n`` finite numbers, above 0 unless ``signed``."""
    xs = [finite(x) for x in v] if isinstance(v, list) else [None]
    if len(xs) != n or any(x is None or (not signed and x <= 0) for x in xs):
        what = f"{'' if signed else 'positive '}number{'s' if n > 1 else ''}"
        raise LibraryError(f"{where}: {key} must be a list of {n} finite {what}, got "
                           f"{_show(v)}")
    return [float(x) for x in xs if x is not None]


def _number(v: object, where: str, key: str, lo: float, hi: float, *,
            above: bool = False) -> float:
    x = finite(v)
    if x is None or not (lo < x if above else lo <= x) or x > hi:
        bound = (f"above {lo:g}" if above else f"from {lo:g}") + \
            (f" to {hi:,g}" if hi < math.inf else "")
        raise LibraryError(f"{where}: {key} must be a number {bound}, got {_show(v)}")
    return x


def _section(v: object, where: str, key: str) -> object:
    """A cross-section: WKT of a valid, non-empty polygon of finite coordinates."""
    if not isinstance(v, str):
        raise LibraryError(f"{where}: {key} must be a cross-section (polygon WKT text), got "
                           f"{_show(v)}")
    try:
        with np.errstate(invalid="ignore"):   # NaN coordinates: refused below
            g = shapely.from_wkt(v)
    except (shapely.errors.ShapelyError, ValueError):
        raise LibraryError(f"{where}: {key} is not readable polygon WKT: {_show(v)}") from None
    if g is None or g.geom_type not in ("Polygon", "MultiPolygon") or g.is_empty \
            or not (np.abs(g.bounds) <= MAX_COORD).all() or not 0 < g.area < math.inf:
        raise LibraryError(f"{where}: {key} must be a polygon of positive area (coordinates "
                           f"within {MAX_COORD:g} m), got {_show(v)}")
    if not g.is_valid:
        raise LibraryError(f"{where}: {key} is an invalid polygon (its outline crosses "
                           "itself, or a hole lies outside it)")
    return g


def part_fields(d: object, i: int, path: Path, seen: dict[str, str], quantum: float
                ) -> dict[str, Any]:
    """The fields of part ``i`` as :class:`~citysynth.parts_db.library.Part` takes them,
    each checked as ingest makes it."""
    pid = d.get("id") if isinstance(d, dict) else None
    named = isinstance(pid, str) and pid.isprintable() and len(pid) <= 200
    where = f"{path}: part #{i + 1}" + (f' "{pid}"' if named else "")
    if not isinstance(d, dict):
        raise LibraryError(f"{where}: must be a JSON object, got {_show(d)}")
    missing, unknown = sorted(PART_KEYS - set(d)), sorted(set(d) - PART_KEYS)
    if missing or unknown:
        raise LibraryError(f"{where}: " + (f"has no {', '.join(missing)}" if missing
                                            else f"unknown key(s) {unknown}"))
    f = dict(d)
    pid = check_id(pid, where, seen)
    cls = f["cls"] = check_class(d["cls"], where)
    check_style(d["style"], where)
    if Path(check_file(d["file"], where)).suffix.lower() not in FORMATS:
        raise LibraryError(f"{where}: file {_show(d['file'])} is not a mesh file (one of "
                           f"{', '.join(sorted(FORMATS))})")
    f["attributes"] = check_attributes(d["attributes"], where,
                                       {"floor_area": MAX_FLOOR_AREA})
    n = LEGS.get(cls, 1)
    measured = f["legs_measured"] = _numbers(d["legs_measured"], n, where, "legs_measured")
    total = sum(measured)
    lo, hi = PLAUSIBLE_STOREY if cls in STACKED else PLAUSIBLE_LENGTH
    if not lo <= total <= hi or min(measured) < 4 * EPS:
        raise LibraryError(f"{where}: legs_measured {_show(d['legs_measured'])} total "
                           f"{total:g} m, outside the {lo:g}-{hi:g} m ingest accepts")
    legs = f["legs"] = _numbers(d["legs"], n, where, "legs")
    snapped = snap_legs(measured, quantum)
    if not np.allclose(legs, snapped, rtol=0, atol=1e-9):
        raise LibraryError(f"{where}: legs {_show(d['legs'])} are not its legs_measured "
                           f"snapped to the {quantum:g} m quantum ({_show(snapped)})")
    angle = convex = None
    if cls == "corner":
        angle, convex = check_corner(d["angle"], d["convex"], where)
    elif d["angle"] is not None or d["convex"] is not None:
        raise LibraryError(f"{where}: angle and convex are for corners; a {cls} has null")
    f["angle"], f["convex"] = angle, convex
    dirs = leg_directions(PartSpec(pid, d["file"], cls, d["style"], angle, convex))
    got = d["directions"]
    if not isinstance(got, list) or len(got) != len(dirs) or not all(
            isinstance(g, list) and len(g) == 2 and all(finite(x) is not None for x in g)
            for g in got) or (dirs and not np.allclose(got, dirs, rtol=0, atol=1e-9)):
        raise LibraryError(f"{where}: directions must be {_show([list(x) for x in dirs])} for "
                           f"this {cls}, got {_show(got)}")
    scale = f["scale"] = _number(d["scale"], where, "scale", 0, math.inf, above=True)
    rescaled = legs[0] / measured[0] if cls in STRAIGHT or cls in STACKED else 1.0
    if not any(math.isclose(scale, s, rel_tol=1e-9) for s in (1.0, rescaled)):
        raise LibraryError(f"{where}: scale must be 1 or its legs over its legs_measured "
                           f"({rescaled:.9g}), got {_show(d['scale'])}")
    f["origin"] = _numbers(d["origin"], 3, where, "origin", signed=True)
    if max(map(abs, f["origin"])) > MAX_COORD:
        raise LibraryError(f"{where}: origin {_show(d['origin'])} lies more than "
                           f"{MAX_COORD:g} m out")
    f["height"] = _number(d["height"], where, "height", 0, MAX_HEIGHT, above=True)
    if cls in STACKED:
        f["floor_area"] = _number(d["floor_area"], where, "floor_area", 0, MAX_FLOOR_AREA)
    elif d["floor_area"] is not None:
        raise LibraryError(f"{where}: floor_area is for tower storeys; a {cls} has null")
    f["sec_in"] = _section(d["sec_in"], where, "sec_in")
    f["sec_out"] = _section(d["sec_out"], where, "sec_out")
    if cls == "t_junction":
        f["sec_branch"] = _section(d["sec_branch"], where, "sec_branch")
    elif d["sec_branch"] is not None:
        raise LibraryError(f"{where}: sec_branch is for T junctions; a {cls} has null")
    return f


def check_tables(path: Path, tables: dict[str, np.ndarray], parts: list) -> None:
    """The tables against the parts: ``allowed`` as their classes rule, each cost a
    finite area where allowed (no larger than the two cross-sections together) and
    infinite elsewhere, as ingest writes them."""
    n = len(parts)
    for k, a in tables.items():
        kind = "b" if k == "allowed" else "f"
        if a.dtype.kind != kind:
            holds = {"U": "text", "S": "text", "b": "true/false values"}.get(
                a.dtype.kind, f"{a.dtype.name} values")
            raise LibraryError(f"{path}: the {k} table holds {holds}, not "
                               f"{'true/false values' if kind == 'b' else 'numbers'}")
        if a.shape != (n, n):
            size = " × ".join(map(str, a.shape)) or "a single value"
            raise LibraryError(f"{path}: the {k} table is {size}, not {n} × {n} (one row and "
                               "column per part)")
    classes = [p.cls for p in parts]
    rules = allowed_matrix(classes)
    bad = np.argwhere(tables["allowed"] != rules)
    if len(bad):
        e, f = bad[0]
        may = "may" if tables["allowed"][e, f] else "may not"
        raise LibraryError(f'{path}: the allowed table says part "{parts[f].id}" {may} follow '
                           f'part "{parts[e].id}", against their classes ({classes[e]}, '
                           f"{classes[f]})")
    is_t = np.array([c == "t_junction" for c in classes])
    area_in = shapely.area(np.array([p.sec_in for p in parts], dtype=object))
    for k, where_ok, outs in (
            ("cost", rules, [p.sec_out for p in parts]),
            ("cost_branch", rules & is_t[:, None],
             [p.sec_branch if p.sec_branch is not None else p.sec_out for p in parts])):
        cost = tables[k]
        top = shapely.area(np.array(outs, dtype=object))[:, None] + area_in[None, :]
        with np.errstate(invalid="ignore"):
            ok = np.where(where_ok, (cost >= 0) & (cost <= top * (1 + 1e-6) + 0.01),
                          cost == np.inf)
        bad = np.argwhere(~ok)
        if len(bad):
            e, f = bad[0]
            should = (f"a finite area from 0 to {top[e, f]:.2f} m² (the two cross-sections "
                      "together)" if where_ok[e, f] else
                      "inf (the part may never follow it)")
            raise LibraryError(f'{path}: the {k} table gives {float(cost[e, f]):g} for part '
                               f'"{parts[f].id}" after part "{parts[e].id}"; it must be '
                               f"{should}")


def check_meshes(path: Path, root: Path, parts: list) -> None:
    """Every part's mesh is where the database says (its library folder may have been
    changed since ingest: found now, not half-way through writing a layout)."""
    for i, p in enumerate(parts):
        if not (root / p.file).is_file():
            raise LibraryError(f'{path}: part #{i + 1} "{p.id}": its mesh {root / p.file} is '
                               f"not there (the library at {root} changed since it was "
                               "ingested)")


def library_of(path: Path) -> str | None:
    """The library folder a damaged database names, when it is still a library (for
    the command that writes the database again); None when it cannot be told."""
    try:
        root = json.loads(path.read_text(encoding="utf-8")).get("library_root")
        return root if isinstance(root, str) and (Path(root) / "manifest.toml").is_file() \
            else None
    except (OSError, ValueError, AttributeError, RecursionError):
        return None
