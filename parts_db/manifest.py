"""The library manifest (``manifest.toml``): what each mesh file is.

A manifest labels parts; measurement (:mod:`parts_db.measure`) then checks the labels
against the geometry. Every error names the part and the manifest so the user can fix
the file. The format is documented in the README ("Part libraries").
"""

from __future__ import annotations

import math
import posixpath
import re
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Literal, get_args

from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.files import no_such_folder
from citysynth.solver.safe_read import check_printable, read_toml, shown

PartClass = Literal["end_left", "end_right", "middle", "corner", "t_junction", "floor",
                    "ground_floor", "roof", "building"]
"""What a part is for: facade parts (the ends of an open facade, fillers, corners, T
junctions), complete buildings for a street front, and the storeys of a tower."""
CLASSES: tuple[PartClass, ...] = get_args(PartClass)
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "in": 0.0254}
_PART_KEYS = {"id", "file", "class", "style", "angle", "convex", "length", "attributes"}
_LIB_KEYS = {"name", "quantum", "units", "rescale"}


@dataclass(frozen=True)
class PartSpec:
    id: str
    file: str
    cls: PartClass
    style: str
    angle: float | None = None       # corners: the angle between the two legs (degrees)
    convex: bool | None = None       # corners: True for an outer corner
    length: float | None = None      # optional nominal length, checks the units
    attributes: dict[str, float] = field(default_factory=dict)
    ignored: tuple[str, ...] = ()    # keys given that its class has no use for


@dataclass(frozen=True)
class Manifest:
    path: Path
    name: str
    quantum: float
    meters_per_unit: float
    rescale: bool
    parts: tuple[PartSpec, ...]


def read_manifest(library_dir: str | Path) -> Manifest:
    root = Path(library_dir)
    path = root / "manifest.toml"
    if not root.exists():
        raise LibraryError(f"{root}: {no_such_folder(root)}; a library is a folder with "
                           "manifest.toml and mesh files")
    if not root.is_dir():
        raise LibraryError(f"{root}: not a folder; a library is a folder with manifest.toml "
                           "and mesh files")
    if not path.exists() and not path.is_symlink():   # a link's loop: read_toml says so
        raise LibraryError(f"{path}: missing; a library needs a manifest.toml "
                           "(see README, 'Part libraries')")
    data = read_toml(path, "manifest", LibraryError)   # encoding, size: safe_read

    lib = data.get("library", {})
    if not isinstance(lib, dict):
        raise LibraryError(f"{path}: library must be one table, [library] (with name, "
                           f"quantum, units), got {shown(lib)}")
    unknown = sorted(set(lib) - _LIB_KEYS)
    if unknown:
        raise LibraryError(f"{path}: [library] has unknown key(s) "
                           f"{', '.join(map(shown, unknown))}; "
                           f"allowed: {', '.join(sorted(_LIB_KEYS))}")
    quantum = positive(lib.get("quantum", 0.2), f"{path}: [library] quantum")
    if quantum < MIN_QUANTUM:
        raise LibraryError(f"{path}: [library] quantum {quantum:g} m is finer than "
                           f"{MIN_QUANTUM:g} m (1 mm): the solver counts lengths in quanta, "
                           "and a 100 m facade would be a hundred million of them; use 0.1 "
                           "or 0.2 m")
    units = lib.get("units", "m")
    if not isinstance(units, str) or units not in UNITS:
        raise LibraryError(f"{path}: [library] units {shown(units)} unknown; use one of "
                           f"{', '.join(sorted(UNITS))}")
    extra = sorted(set(data) - {"library", "part"})
    if extra:
        raise LibraryError(f"{path}: unknown table(s) {extra}; use [library] and [[part]]")
    parts_in = data.get("part", [])
    if isinstance(parts_in, dict):   # [part], one table: TOML's array needs two brackets
        raise LibraryError(f"{path}: [part] is one table; write each part as a [[part]] "
                           "table (two brackets)")
    if not isinstance(parts_in, list) or not parts_in:
        what = "" if "part" not in data else f" (part = {shown(parts_in)} is no table)"
        raise LibraryError(f"{path}: no parts{what}; add [[part]] tables")
    parts: list[PartSpec] = []
    seen: dict[str, str] = {}   # id_key -> id
    for i, p in enumerate(parts_in):
        parts.append(_part(p, i, path, seen))
    rescale = lib.get("rescale", True)
    if not isinstance(rescale, bool):
        raise LibraryError(f"{path}: [library] rescale must be true or false, got "
                           f"{rescale!r}")
    name = lib.get("name", root.name)
    if not isinstance(name, str):
        raise LibraryError(f"{path}: [library] name must be text in quotes, got "
                           f"{shown(name)}")
    check_printable(name, str(path), "[library] name", LibraryError)
    return Manifest(path, name, quantum, UNITS[units],
                    rescale, tuple(parts))


def finite(v: object) -> float | None:
    """``v`` as a float when it is a finite number (not a bool, not NaN or infinite, not
    an integer too large for a float: JSON has those), else None."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return None
    try:
        x = float(v)
    except OverflowError:
        return None
    return x if math.isfinite(x) else None


def positive(v: object, where: str) -> float:
    x = finite(v)
    if x is None or x <= 0:
        raise LibraryError(f"{where}: must be a positive number, got {shown(v)}")
    return x


MIN_QUANTUM = 0.001     # m: the finest length step a library may count in
MAX_ATTRIBUTE = 10_000   # doors, windows...: of one part (1e300 overflowed the solver)
_DEVICES = {"CON", "PRN", "AUX", "NUL", *(f"COM{i}" for i in range(1, 10)),
            *(f"LPT{i}" for i in range(1, 10))}   # Windows opens these names as devices
MAX_ID = 200   # characters: a part's id names its files (parts/<id>.usdc), and file
               # systems take 255 bytes a name


def id_key(pid: str) -> str:
    """What a part id becomes as a USD prim and file name (every character but ASCII
    letters, digits and ``_`` made one ``_`` per byte of its UTF-8, as usd-core's
    ``Tf.MakeValidIdentifier`` does: "ü" is "__"), case-folded as Windows and macOS
    compare file names: two ids with one key would share one prototype file, and one
    of them would show the other's mesh ("ü" and "__" did, one character counted as
    one "_")."""
    key = re.sub(r"[^A-Za-z0-9_]", lambda m: "_" * len(m.group().encode("utf-8")), pid)
    return ("_" + key if pid[:1].isdigit() else key).casefold()   # as prim_name does


def check_id(pid: object, where: str, seen: dict[str, str]) -> str:
    """A part's id: a printable string, as unique as the file names it becomes."""
    if not isinstance(pid, str) or not pid:
        raise LibraryError(f"{where}: needs an id (a non-empty string)")
    check_printable(pid, where, "its id", LibraryError)
    if len(pid.encode("utf-8")) > MAX_ID:
        raise LibraryError(f"{where}: an id is at most {MAX_ID} characters (it names the "
                           "part's files: counted in UTF-8 bytes, so é counts 2); shorten it")
    if pid != pid.strip():   # "a " and "a" were two parts no listing tells apart
        raise LibraryError(f"{where}: id {shown(pid)} begins or ends with a space, which "
                           "no listing shows; remove it")
    if id_key(pid).upper() in _DEVICES:
        raise LibraryError(f"{where}: id {shown(pid)} names its prototype file "
                           f"parts/{pid}.usdc, a device name Windows does not open "
                           "as a file (CON, PRN, AUX, NUL, COM1-9, LPT1-9); rename the part")
    # its file's key, and that of the same text in NFC (é typed two ways looks one)
    keys = (id_key(pid), id_key(unicodedata.normalize("NFC", pid)))
    other = next((seen[k] for k in keys if k in seen), None)
    if other == pid:
        raise LibraryError(f'{where}: duplicate id "{pid}"')
    if other is not None and unicodedata.normalize("NFC", other) == \
            unicodedata.normalize("NFC", pid):
        raise LibraryError(f'{where}: its id and "{other}" are one text written two ways '
                           "(an accented letter as one character, and as a letter and an "
                           "accent: Unicode NFC and NFD), which no listing tells apart; "
                           "rename one of them")
    if other is not None:
        raise LibraryError(f'{where}: its id and "{other}" differ only in case or in '
                           "characters other than letters, digits and _, so both would "
                           "be written as one USD prototype file; rename one of them")
    seen.update(dict.fromkeys(keys, pid))
    return pid


def _part(p: dict, i: int, path: Path, seen: dict[str, str]) -> PartSpec:
    pid = p.get("id")
    named = isinstance(pid, str) and pid.isprintable()
    where = f"{path}: part #{i + 1}" + (f' "{pid}"' if named else "")
    pid = check_id(pid, where, seen)
    unknown = sorted(set(p) - _PART_KEYS)
    if unknown:
        raise LibraryError(f"{where}: unknown key(s) {', '.join(map(shown, unknown))}; "
                           f"allowed: {', '.join(sorted(_PART_KEYS))}")
    f = check_file(p.get("file"), where)
    cls = check_class(p.get("class"), where)
    style = check_style(p.get("style", "default"), where)
    angle = convex = None
    if cls == "corner":
        angle, convex = check_corner(p.get("angle"), p.get("convex"), where)
    length = positive(p["length"], f"{where}: length") if "length" in p else None
    attrs = check_attributes(p.get("attributes", {}), where)
    ignored = () if cls == "corner" else tuple(k for k in ("angle", "convex") if k in p)
    return PartSpec(pid, f, cls, style, angle, convex, length, attrs, ignored)


# The checks of one part's fields, shared with the reader of a stored part database
# (parts_db.stored), which holds the same fields and must refuse the same values.

def check_file(f: object, where: str) -> str:
    """A part's mesh file: a path relative to the library folder."""
    if not isinstance(f, str) or not f:
        raise LibraryError(f"{where}: needs a file (path of its mesh, relative to the library)")
    if PurePosixPath(f).is_absolute() or PureWindowsPath(f).is_absolute():
        raise LibraryError(f"{where}: file {shown(f)} must be a path relative to the "
                           "library folder (so the library can be moved and shared)")
    if any(ord(c) < 32 or 127 <= ord(c) < 160 for c in f):   # a NUL crashed os.stat
        raise LibraryError(f"{where}: file {shown(f)} holds a character no file name "
                           "holds (a NUL, a line break or another control character): "
                           "write the mesh's file name as it is")
    if posixpath.normpath(f.replace("\\", "/")).split("/")[0] == "..":
        # (meshes/../meshes/a.glb stays inside, and is read)
        raise LibraryError(f"{where}: file {shown(f)} climbs out of the library folder "
                           "(..); keep the part's mesh inside it, so the library can be "
                           "moved and shared")
    return f


def check_class(cls: object, where: str) -> PartClass:
    if cls not in CLASSES:
        raise LibraryError(f"{where}: unknown class {shown(cls)}; classes are {', '.join(CLASSES)}")
    return cls


def check_style(style: object, where: str) -> str:
    if not isinstance(style, str) or not style:
        raise LibraryError(f"{where}: style must be a non-empty string")
    check_printable(style, where, "style", LibraryError)
    return style


def check_corner(angle: object, convex: object, where: str) -> tuple[float, bool]:
    """A corner's angle (degrees between its legs, in (0, 180)) and convexity."""
    if angle is None:
        raise LibraryError(f"{where}: a corner needs an angle (degrees between its legs, "
                           "e.g. angle = 90) and convex = true|false")
    a = positive(angle, f"{where}: angle")
    if not 0 < a < 180:
        raise LibraryError(f"{where}: angle must lie between 0 and 180 degrees "
                           f"(the angle between the legs), got {a:g}")
    if not isinstance(convex, bool):
        raise LibraryError(f"{where}: a corner needs convex = true (outer corner) or "
                           "false (inner corner)")
    return a, convex


def check_attributes(attrs_in: object, where: str,
                     limits: dict[str, float] | None = None) -> dict[str, float]:
    """A part's attributes: named counts from 0 to :data:`MAX_ATTRIBUTE` (``limits``
    raises that for some names: a stored database holds measured floor areas)."""
    if not isinstance(attrs_in, dict):
        raise LibraryError(f"{where}: attributes must be a table, e.g. "
                           "attributes = {doors = 1, windows = 4}")
    attrs = {}
    for k, v in attrs_in.items():
        if not isinstance(k, str) or not k.strip() or not k.isprintable():
            raise LibraryError(f"{where}: an attribute needs a name (like doors), got {shown(k)}")
        if k == "length":
            raise LibraryError(f"{where}: an attribute may not be called length: a part's "
                               "length is measured from its mesh (or given as length = 5 "
                               "beside its attributes); name the attribute otherwise")
        top = (limits or {}).get(k, MAX_ATTRIBUTE)
        x = finite(v)
        if x is None or not 0 <= x <= top:
            what = "a count on one part" if top == MAX_ATTRIBUTE else "a measured amount"
            raise LibraryError(f"{where}: attribute {k} must be a number from 0 to "
                               f"{top:,g} ({what}), got {shown(v)}")
        attrs[k] = x
    return attrs
