"""A generated corpus of bad inputs, across every command and every kind of input file.

Each case builds its bad input in a fresh folder and runs the command line in-process
(``citysynth.pipeline.cli.main``); it must end with the exit code the case expects
(2 for bad input), exactly one line on stderr that names the file (or option) at fault,
no traceback, and nothing written: the folder holds the inputs it held before. A few
cases run as real processes, under a memory limit, to prove the same end to end.

Kinds: broken files (missing, folder, empty, not UTF-8, UTF-16, binary, truncated,
nested 100,000 deep, NaN, too large, a FIFO, a symlink loop), valid JSON or TOML of the
wrong shape, damaged part databases and run folders, non-finite or huge numbers, and
output paths that cannot be written.
"""

from __future__ import annotations

import copy
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"
LIB = EX / "library"
PROBLEM = json.loads((EX / "street_front.json").read_text())
STRUCTURE = json.loads((EX / "block_cycle.json").read_text())
LINES = json.loads((EX / "skeletons" / "t_building.geojson").read_text())
POLYS = json.loads((EX / "blocks" / "block.geojson").read_text())


@dataclass
class Case:
    id: str
    make: Callable[[Path], list[str]]   # writes the inputs under a folder; the argv
    names: str = "{bad}"                # what stderr must name ({bad}: the bad file)
    code: int = 2
    env: dict[str, str] | None = None


CASES: list[Case] = []


def case(id: str, make: Callable[[Path], list[str]], names: str = "{bad}", code: int = 2,
         env: dict[str, str] | None = None) -> None:
    CASES.append(Case(id, make, names, code, env))


# --- broken files, for every input kind -----------------------------------------------

def _deep(n: int) -> bytes:
    return b"[" * n + b"]" * n


BROKEN_JSON: dict[str, Callable[[bytes], bytes | None]] = {
    "missing": lambda good: None,
    "empty": lambda good: b"",
    "blank": lambda good: b"  \n\t\n",
    "latin1": lambda good: good.decode().replace('"', '"\xe9', 1).encode("latin-1"),
    "utf16": lambda good: good.decode().encode("utf-16"),
    "utf16-no-bom": lambda good: good.decode().encode("utf-16-le"),
    "binary": lambda good: bytes(range(256)) * 4,
    "truncated": lambda good: good[: len(good) // 2],
    "deep-100000": lambda good: _deep(100_000),
    "deep-500": lambda good: _deep(500),
    "nan": lambda good: b'{"a": NaN}',
    "top-list": lambda good: b"[1, 2, 3]",
    "top-null": lambda good: b"null",
    "top-number": lambda good: b"42",
    "top-string": lambda good: b'"FeatureCollection"',
    "trailing-garbage": lambda good: good + b"}}",
    "integer-of-5000-digits": lambda good: b'{"a": ' + b"9" * 5000 + b"}",
    "lone-surrogate": lambda good: b'{"type": "\\ud800"}',
    "geopackage": lambda good: b"SQLite format 3\x00" + bytes(200),
    "gzip": lambda good: __import__("gzip").compress(good, mtime=0),
    # a key given twice: the parser keeps the last value, the first vanished unsaid
    "duplicate-key": lambda good: good.replace(b"{", b'{"citysynth": 1, "citysynth": 2,', 1),
}
SPECIAL = ("folder", "fifo", "symlink-loop", "too-large")


def write_broken(path: Path, kind: str, good: bytes) -> None:
    if kind == "folder":
        path.mkdir()
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "symlink-loop":
        path.symlink_to(path.name)
    elif kind == "too-large":
        path.write_bytes(good + b" " * 1_500_000)
    else:
        data = BROKEN_JSON[kind](good)
        if data is not None:
            path.write_bytes(data)


def _dump(d: object) -> bytes:
    return json.dumps(d, indent=1).encode()


JSON_INPUTS: dict[str, tuple[bytes, Callable[[Path], list[str]]]] = {
    "problem": (_dump(PROBLEM), lambda f: ["solve", str(f)]),
    "structure": (_dump(STRUCTURE), lambda f: ["solve", str(f)]),
    "skeleton": (_dump(LINES), lambda f: ["skeleton", str(f)]),
    "skeleton-streets": (_dump(LINES), lambda f: ["skeleton", str(f), "--kind", "streets"]),
    "building": (_dump(LINES), lambda f: ["building", str(f), "--library", str(LIB), "-o",
                                          str(f.parent / "out")]),
    "block": (_dump(POLYS), lambda f: ["block", str(f), "--library", str(LIB), "-o",
                                       str(f.parent / "out")]),
    "city-streets": (_dump(LINES), lambda f: ["city", "--streets", str(f), "--library",
                                              str(LIB), "-o", str(f.parent / "out")]),
    "city-footprints": (_dump(POLYS), lambda f: ["city", "--footprints", str(f),
                                                 "--library", str(LIB), "-o",
                                                 str(f.parent / "out")]),
}

for name, (good, argv) in JSON_INPUTS.items():
    for kind in (*BROKEN_JSON, *SPECIAL):
        def make(tmp: Path, good=good, argv=argv, kind=kind) -> list[str]:
            f = tmp / "input.json"
            write_broken(f, kind, good)
            return argv(f)
        case(f"{name}-{kind}", make, env={"CITYSYNTH_MAX_INPUT_MB": "1"}
             if kind == "too-large" else None)


GOOD_TOML = {
    "city.toml": b"k = 1\n[per_side]\ndoors = [0, 3]\n",
    "manifest.toml": (LIB / "manifest.toml").read_bytes(),
}
BROKEN_TOML: dict[str, Callable[[bytes], bytes | None]] = {
    "missing": lambda good: None,
    "latin1": lambda good: b"# caf\xe9\n" + good,
    "utf16": lambda good: good.decode().encode("utf-16"),
    "binary": lambda good: bytes(range(256)) * 4,
    "truncated": lambda good: good[: len(good) // 2] + b"[[",
    "deep-100000": lambda good: b"a = " + _deep(100_000) + b"\n",
    "not-toml": lambda good: b'{"k": 1}',
}


def _toml_argv(name: str, f: Path) -> list[str]:
    if name == "city.toml":
        return ["city", "--streets", str(EX / "city" / "district_streets.geojson"),
                "--library", str(LIB), "--config", str(f), "-o", str(f.parent / "out")]
    return ["ingest", str(f.parent)]


for name, good_toml in GOOD_TOML.items():
    for kind in (*BROKEN_TOML, "folder", "fifo", "symlink-loop", "too-large"):
        def make_toml(tmp: Path, name=name, good=good_toml, kind=kind) -> list[str]:
            f = tmp / name
            if kind in BROKEN_TOML:
                data = BROKEN_TOML[kind](good)
                if data is not None:
                    f.write_bytes(data)
            else:
                write_broken(f, kind, good)
            return _toml_argv(name, f)
        case(f"{name}-{kind}", make_toml, names=name, env={"CITYSYNTH_MAX_INPUT_MB": "1"}
             if kind == "too-large" else None)


# --- valid JSON, wrong shape ------------------------------------------------------------

def edited(doc: dict, edit: Callable[[dict], object]) -> dict:
    d = copy.deepcopy(doc)
    edit(d)
    return d


def _set(path: tuple, value: object) -> Callable[[dict], object]:
    """Set ``path`` to ``value``; a path through ``("features", 0)`` is set in every
    feature (one bad feature among good ones is skipped with a warning, by design; the
    file is refused when nothing usable is left)."""
    def one(d: dict, path: tuple) -> None:
        for k in path[:-1]:
            d = d[k]
        d[path[-1]] = value

    def go(d: dict) -> None:
        if path[:2] == ("features", 0):
            for i in range(len(d["features"])):
                one(d, ("features", i, *path[2:]))
        else:
            one(d, path)
    return go


def _del(key: str) -> Callable[[dict], object]:
    return lambda d: d.pop(key)


GEOJSON_SHAPES: dict[str, Callable[[dict], object]] = {
    "features-object": _set(("features",), {}),
    "features-string": _set(("features",), "all"),
    "feature-string": _set(("features", 0), "Feature"),
    "feature-null": _set(("features", 0), None),
    "properties-list": _set(("features", 0, "properties"), [1, 2]),
    "properties-string": _set(("features", 0, "properties"), "front"),
    "geometry-string": _set(("features", 0, "geometry"), "LineString"),
    "geometry-type-unknown": _set(("features", 0, "geometry", "type"), "Curve"),
    "coordinates-strings": _set(("features", 0, "geometry", "coordinates"),
                                [["7.1", "50.73"], ["7.2", "50.73"]]),
    "coordinates-number": _set(("features", 0, "geometry", "coordinates"), 7),
    "coordinates-3-deep-wrong": _set(("features", 0, "geometry", "coordinates"),
                                     [[[[7.1]]]]),
    "coordinates-infinite": _set(("features", 0, "geometry", "coordinates"),
                                 [[1e400, 50.73], [7.2, 50.73]]),
    "coordinates-huge": _set(("features", 0, "geometry", "coordinates"),
                             [[1e300, 1e300], [-1e300, 1e300]]),
    "coordinates-bool": _set(("features", 0, "geometry", "coordinates"),
                             [[True, False], [7.2, 50.73]]),
    "type-missing": _del("type"),
    "type-wrong": _set(("type",), "Topology"),
    "crs-garbage": _set(("crs",), {"type": "name", "properties": {"name": "EPSG:nope"}}),
    "crs-string": _set(("crs",), "EPSG:4326"),
    "no-features": _set(("features",), []),
}
GEO_CONSUMERS = {k: v for k, v in JSON_INPUTS.items() if k not in ("problem", "structure")}

for name, (good, argv) in GEO_CONSUMERS.items():
    doc = json.loads(good)
    for shape, edit in GEOJSON_SHAPES.items():
        def make_shape(tmp: Path, doc=doc, edit=edit, argv=argv) -> list[str]:
            f = tmp / "input.geojson"
            f.write_bytes(_dump(edited(doc, edit)))
            return argv(f)
        case(f"{name}-{shape}", make_shape)

PROBLEM_SHAPES: dict[str, Callable[[dict], object]] = {
    "no-transitions": _del("transitions"),
    "no-elements": _del("elements"),
    "elements-object": _set(("elements",), {}),
    "element-string": _set(("elements", 0), "b00"),
    "element-resource-string": _set(("elements", 0, "resources", "length"), "4"),
    "transition-short": _set(("transitions", 0), ["b00_4.0m"]),
    "transition-unknown": _set(("transitions", 0), ["nope", "b00_4.0m", 1.0]),
    "transition-cost-string": _set(("transitions", 0), ["b00_4.0m", "b00_4.0m", "1"]),
    "k-huge": _set(("k",), 1_000_000_000),
    "k-zero": _set(("k",), 0),
    "k-float": _set(("k",), 2.5),
    "bound-reversed": _set(("constraints", "length"), [90, 10]),
    "bound-string": _set(("constraints", "length"), "83.4"),
    "quantum-zero": _set(("quantum", "length"), 0),
    "quantum-negative": _set(("quantum", "length"), -0.2),
    "resources-string": _set(("resources",), "length"),
    "unknown-key": _set(("colour",), "red"),
    "minimum-1e300": _set(("constraints", "length"), [1e300, 1e300]),
    "minimum-1e15": _set(("constraints", "length"), [1e15, 1e15]),
}
case("problem-bound-1e300", lambda t: ["solve", str(_write(t / "problem.json", edited(
    PROBLEM, _set(("constraints", "length"), [0, 1e300]))))], names="", code=0)
# (a bound past any total is no bound: solved, not a traceback)
for shape, edit in PROBLEM_SHAPES.items():
    def make_problem(tmp: Path, edit=edit) -> list[str]:
        f = tmp / "problem.json"
        f.write_bytes(_dump(edited(PROBLEM, edit)))
        return ["solve", str(f)]
    case(f"problem-{shape}", make_problem, names="problem.json")

STRUCTURE_SHAPES: dict[str, Callable[[dict], object]] = {
    "stages-object": _set(("stages",), {}),
    "stage-string": _set(("stages", 0), "front"),
    "stage-constraint-nan-like": _set(("stages", 0, "constraints", "length"), [0, "nan"]),
    "stage-unknown-key": _set(("stages", 1, "branch"), 99),
    "keypoint-branch-unknown": _set(("keypoints", 1, "branch"), 99),
    "keypoint-branch-string": _set(("keypoints", 1, "branch"), "north"),
    "keypoints-string": _set(("keypoints",), "four"),
    "closed-string": _set(("closed",), "yes"),
    # ignored before (the solver never read them); now refused, naming the place
    "keypoint-unknown-key": _set(("keypoints", 0, "colour"), "red"),
    "key-element-resources": _set(("elements", 4, "resources"), {"length": 1.0}),
    "stage-elements-empty": _set(("stages", 0, "elements"), []),   # read as "all"
}
for shape, edit in STRUCTURE_SHAPES.items():
    def make_structure(tmp: Path, edit=edit) -> list[str]:
        f = tmp / "structure.json"
        f.write_bytes(_dump(edited(STRUCTURE, edit)))
        return ["solve", str(f)]
    case(f"structure-{shape}", make_structure, names="structure.json")
# a structure-wide bound past reach is no bound (solved); a minimum past it is infeasible,
# said at once (both were refused as 10^9 ways to share the total)
for shape, interval, code, names in (("interval-0-1e9", [0, 10**9], 0, ""),
                                     ("interval-1e9-2e9", [10**9, 2 * 10**9], 1,
                                      'on "doors" asks for at least 1e+09, more than the '
                                      "stages can reach (at most 25.83)")):
    def make_wide(tmp: Path, interval=interval) -> list[str]:
        f = tmp / "structure.json"
        f.write_bytes(_dump(edited(STRUCTURE, _set(("constraints",), {"doors": interval}))))
        return ["solve", str(f)]
    case(f"structure-{shape}", make_wide, names=names, code=code)


# --- city.toml and manifest.toml of the wrong shape ---------------------------------------

CITY_TOML_SHAPES = {
    "per-side-unknown-attribute": "[per_side]\nbalconies_of_gold = [0, 3]\n",
    "per-side-string": "per_side = 'doors'\n",
    "per-side-nan": "[per_side]\ndoors = [0, nan]\n",
    "per-side-inf": "[per_side]\ndoors = [0, inf]\n",
    "k-string": "k = 'three'\n",
    "k-huge": "k = 1000000000\n",
    "setback-nan": "[setback]\ndefault = nan\n",
    "setback-negative": "[setback]\ndefault = -4\n",
    "zone-polygon-string": "[[zone]]\nname = 'a'\npolygon = 'here'\n",
    "library-missing": "library = 'no/such/library'\n",
    "origin-huge": "origin = [1e300, 1e300]\n",
    "slack-huge": "slack = 1e9\n",
    "towers-height-huge": "[[zone]]\nname = 'z'\nkind = 'towers'\nhighway = ['primary']\n"
                          "height = [40, 1e300]\nfar = [2, 4]\n",
}
for shape, text in CITY_TOML_SHAPES.items():
    def make_cfg(tmp: Path, text=text, shape=shape) -> list[str]:
        f = tmp / "city.toml"
        f.write_text(text)
        argv = _toml_argv("city.toml", f)
        if shape == "library-missing":     # --library would win over the file's
            i = argv.index("--library")
            del argv[i:i + 2]
        return argv
    case(f"city.toml-{shape}", make_cfg,
         names="no/such/library" if shape == "library-missing" else "city.toml")


def tiny_library(tmp: Path, manifest_extra: str = "", part_extra: str = "") -> Path:
    lib = tmp / "lib"
    (lib / "meshes").mkdir(parents=True)
    shutil.copy(LIB / "meshes" / "classic_mid_7.8_a0.glb", lib / "meshes")
    (lib / "manifest.toml").write_text(
        f'[library]\nname = "tiny"\nquantum = 0.2\nunits = "m"\n{manifest_extra}\n'
        f'[[part]]\nid = "m"\nfile = "meshes/classic_mid_7.8_a0.glb"\nclass = "middle"\n'
        f'style = "classic"\nlength = 7.8\n{part_extra}\n')
    return lib / "manifest.toml"


MANIFEST_SHAPES = {
    "rescale-string": ('rescale = "no"', ""),
    "quantum-string": ('quantum_note = 1', ""),
    "part-length-nan": ("", "width = nan"),
    "part-length-string": ("", 'height = "tall"'),
    "part-class-unknown": ("", ""),
    "part-file-outside": ("", ""),
    "units-unknown": ('units_extra = "parsec"', ""),
    "library-number": ("", ""),
    "library-array-of-tables": ("", ""),
    "units-list": ("", ""),
    "name-table": ("", ""),
}
WHOLE_LIBRARY = {
    "library-number": "library = 5\n",
    "library-array-of-tables": '[[library]]\nname = "x"\n',
    "units-list": '[library]\nunits = ["m"]\n',
    "name-table": "[library]\nname = {a = 1}\n",
}
for shape, (lib_extra, part_extra) in MANIFEST_SHAPES.items():
    def make_manifest(tmp: Path, lib_extra=lib_extra, part_extra=part_extra,
                      shape=shape) -> list[str]:
        m = tiny_library(tmp, lib_extra, part_extra)
        text = m.read_text()
        if shape == "part-class-unknown":
            text = text.replace('class = "middle"', 'class = "gargoyle"')
        if shape == "part-file-outside":
            text = text.replace('file = "meshes/', 'file = "../../../etc/')
        if shape in WHOLE_LIBRARY:   # [library] itself replaced (was a TypeError)
            text = WHOLE_LIBRARY[shape] + text[text.index("[[part]]"):]
        m.write_text(text)
        return ["ingest", str(m.parent), "-o", str(tmp / "db")]
    case(f"manifest-{shape}", make_manifest, names="{tmp}/lib")


# --- damaged part databases given as --library ----------------------------------------------

def _db(tmp: Path) -> Path:
    db = tmp / "db"
    assert main(["ingest", str(LIB), "-o", str(db)]) == 0
    return db


DB_DAMAGE: dict[str, Callable[[Path], None]] = {
    "json-truncated": lambda db: (db / "partdb.json").write_bytes(
        (db / "partdb.json").read_bytes()[:500]),
    "json-list": lambda db: (db / "partdb.json").write_text("[]"),
    "json-parts-missing": lambda db: (db / "partdb.json").write_text(
        (db / "partdb.json").read_text().replace('"parts"', '"partz"')),
    "json-latin1": lambda db: (db / "partdb.json").write_bytes(b'{"name": "caf\xe9"}'),
    "npz-truncated": lambda db: (db / "partdb.npz").write_bytes(
        (db / "partdb.npz").read_bytes()[:200]),
    "npz-garbage": lambda db: (db / "partdb.npz").write_bytes(b"PK\x03\x04" + b"x" * 300),
    "npz-folder": lambda db: ((db / "partdb.npz").unlink(), (db / "partdb.npz").mkdir()),
    "npz-missing": lambda db: (db / "partdb.npz").unlink(),
}


@pytest.fixture(scope="module")
def good_db(tmp_path_factory) -> Path:
    return _db(tmp_path_factory.mktemp("db"))


for dmg, how in DB_DAMAGE.items():
    for cmd in ("building", "block"):
        def make_db(tmp: Path, how=how, cmd=cmd) -> list[str]:
            db = tmp / "db"
            shutil.copytree(GOOD_DB[0], db)
            how(db)
            src = tmp / "in.geojson"
            src.write_bytes(_dump(LINES if cmd == "building" else POLYS))
            return [cmd, str(src), "--library", str(db), "-o", str(tmp / "out")]
        case(f"partdb-{dmg}-{cmd}", make_db, names="{tmp}/db")

GOOD_DB: list[Path] = []


# --- damaged run folders for diff -----------------------------------------------------------

def _run_folder(tmp: Path, name: str) -> Path:
    run = tmp / name
    shutil.copytree(GOOD_RUN[0], run)
    return run


def _first_layout(run: Path) -> Path:
    return sorted((run / "blocks").glob("*.layout.json"))[0]


def _manifest_edit(run: Path, edit: Callable[[dict], object]) -> None:
    m = json.loads((run / "manifest.json").read_text())
    edit(m)
    (run / "manifest.json").write_text(json.dumps(m))


def _files_to(target: object) -> Callable[[dict], object]:
    def go(m: dict) -> None:
        for rec in m["blocks"].values():
            rec["files"] = [target]
    return go


RUN_DAMAGE: dict[str, tuple[Callable[[Path], object], str]] = {
    "manifest-list": (lambda r: (r / "manifest.json").write_text("[]"), "manifest.json"),
    "manifest-null": (lambda r: (r / "manifest.json").write_text("null"), "manifest.json"),
    "manifest-empty-object": (lambda r: (r / "manifest.json").write_text("{}"),
                              "manifest.json"),
    "manifest-blocks-list": (lambda r: _manifest_edit(r, _set(("blocks",), [])),
                             "manifest.json"),
    "manifest-block-string": (lambda r: _manifest_edit(
        r, lambda m: m["blocks"].update({k: "built" for k in m["blocks"]})), "manifest.json"),
    "manifest-truncated": (lambda r: (r / "manifest.json").write_bytes(
        (r / "manifest.json").read_bytes()[:100]), "manifest.json"),
    "manifest-missing": (lambda r: (r / "manifest.json").unlink(), "{run}"),
    "manifest-folder": (lambda r: ((r / "manifest.json").unlink(),
                                   (r / "manifest.json").mkdir()), "manifest.json"),
    "layout-truncated": (lambda r: _first_layout(r).write_bytes(
        _first_layout(r).read_bytes()[:300]), ".layout.json"),
    "layout-truncated-says-rerun": (lambda r: _first_layout(r).write_bytes(
        _first_layout(r).read_bytes()[:300]), "damaged: rerun citysynth city into"),
    "layout-deleted": (lambda r: _first_layout(r).unlink(), ".layout.json"),
    "layout-folder": (lambda r: (lambda p: (p.unlink(), p.mkdir()))(_first_layout(r)),
                      ".layout.json"),
    "layout-empty-object": (lambda r: _first_layout(r).write_text("{}"), ".layout.json"),
    "layout-latin1": (lambda r: _first_layout(r).write_bytes(b'{"cost": "\xe9"}'),
                      ".layout.json"),
    "files-outside": (lambda r: _manifest_edit(r, _files_to("../../x.layout.json")),
                      "outside the run folder"),
    "files-absolute": (lambda r: _manifest_edit(r, _files_to("/etc/x.layout.json")),
                       "outside the run folder"),
    # a name only this run lists (not a layout): refused too, not reported as "differ"
    "files-extra-outside": (lambda r: _manifest_edit(r, lambda m: [rec["files"].append(
        "../../../../etc/passwd") for rec in m["blocks"].values()]),
        "outside the run folder"),
    # found by a probe on 2026-11-30: each was read as a run (exit 0 "the same", or
    # exit 1 with files said to differ)
    "manifest-version-99": (lambda r: _manifest_edit(r, _set(("version",), 99)),
                            "version 99, which this citysynth does not read"),
    "rank-text": (lambda r: _manifest_edit(r, lambda m: [rec.update(rank="first")
                                                         for rec in m["blocks"].values()]),
                  'rank "first", which citysynth city never writes'),
    "files-numbers": (lambda r: _manifest_edit(r, _files_to(1)), "manifest.json"),
    "files-folder": (lambda r: _manifest_edit(r, _files_to("blocks")),
                     "a folder, where the run's manifest names a block's file"),
    "status-unknown": (lambda r: _manifest_edit(r, lambda m: [rec.update(
        status=5, cost="cheap") for rec in m["blocks"].values()]), "never writes"),
    "files-symlink-outside": (lambda r: (lambda p: (p.unlink(), p.symlink_to(
        "/etc/hostname")))(_first_layout(r)), "outside the run folder"),
    "run-is-file": (lambda r: (shutil.rmtree(r), r.write_text("x")), "{run}"),
    # a valid manifest, but reached by a link out of the run folder
    "manifest-symlink-outside": (lambda r: (
        shutil.copy(r / "manifest.json", r.parent / f"{r.name}-elsewhere.json"),
        (r / "manifest.json").unlink(),
        (r / "manifest.json").symlink_to(r.parent / f"{r.name}-elsewhere.json")),
        "outside the run folder"),
}
for dmg, (how, names) in RUN_DAMAGE.items():
    for side in ("a", "b"):
        def make_run(tmp: Path, how=how, side=side) -> list[str]:
            a, b = _run_folder(tmp, "a"), _run_folder(tmp, "b")
            how(a if side == "a" else b)
            return ["diff", str(a), str(b)]
        case(f"diff-{dmg}-{side}", make_run, names=names.replace("{run}", "{tmp}/" + side))

GOOD_RUN: list[Path] = []


# --- options: non-finite and huge numbers, output paths --------------------------------------

def _problem(tmp: Path) -> Path:
    f = tmp / "problem.json"
    f.write_bytes(_dump(PROBLEM))
    return f


def _lines(tmp: Path) -> Path:
    f = tmp / "lines.geojson"
    f.write_bytes(_dump(LINES))
    return f


OPTIONS = {
    "max-memory-nan": (lambda t: ["solve", str(_problem(t)), "--max-memory", "nan"],
                       "--max-memory"),
    "max-memory-inf": (lambda t: ["solve", str(_problem(t)), "--max-memory", "inf"],
                       "--max-memory"),
    "max-memory-negative": (lambda t: ["solve", str(_problem(t)), "--max-memory", "-5"],
                            "--max-memory"),
    "max-memory-1e30": (lambda t: ["solve", str(_problem(t)), "--max-memory", "1e30"],
                        "--max-memory"),
    "max-memory-zero": (lambda t: ["solve", str(_problem(t)), "--max-memory", "0"],
                        "--max-memory"),
    "solve-k-huge": (lambda t: ["solve", str(_problem(t)), "--k", "1000000000"], "k"),
    "solve-k-zero": (lambda t: ["solve", str(_problem(t)), "--k", "0"], "--k"),
    "setback-nan": (lambda t: ["skeleton", str(_lines(t)), "--kind", "streets", "--setback",
                               "nan"], "--setback"),
    "setback-inf": (lambda t: ["skeleton", str(_lines(t)), "--kind", "streets", "--setback",
                               "inf"], "--setback"),
    "setback-negative": (lambda t: ["skeleton", str(_lines(t)), "--kind", "streets",
                                    "--setback", "-3"], "--setback"),
    "building-k-huge": (lambda t: ["building", str(_lines(t)), "--library", str(LIB), "--k",
                                   "1000000000", "-o", str(t / "out")], "k"),
    "building-k-zero": (lambda t: ["building", str(_lines(t)), "--library", str(LIB), "--k",
                                   "0", "-o", str(t / "out")], "--k"),
    # k is capped before anything is named or solved (a billion filled 24 GB naming files)
    "block-k-huge": (lambda t: ["block", str(_write(t / "p.geojson", POLYS)), "--library",
                                str(LIB), "--k", "1000000000", "-o", str(t / "out")],
                     "from 1 to 100"),
    "block-k-100000": (lambda t: ["block", str(_write(t / "p.geojson", POLYS)), "--library",
                                  str(LIB), "--k", "100000", "-o", str(t / "out")],
                       "from 1 to 100"),
    "street-k-huge": (lambda t: ["street", "--line", str(_lines(t)), "--k", "1000000",
                                 "-o", str(t / "out")], "from 1 to 100"),
    "tower-k-huge": (lambda t: ["tower", "--height", "30", "--far", "4", "--lot-area", "900",
                                "--k", "1000000", "-o", str(t / "out")], "from 1 to 100"),
    "street-offset-huge": (lambda t: ["street", "--line", str(_lines(t)), "--offset", "1e9",
                                      "-o", str(t / "out")], "--offset"),
    "city-workers-zero": (lambda t: ["city", "--streets", str(_lines(t)), "--library",
                                     str(LIB), "--workers", "0", "-o", str(t / "out")],
                          "--workers"),
    "crs-garbage": (lambda t: ["skeleton", str(_lines(t)), "--crs", "EPSG:nope"], "nope"),
    "street-slack-huge": (lambda t: ["street", "--line", str(_lines(t)), "--slack", "1e9",
                                     "-o", str(t / "out")], "--slack"),
    "street-windows-inf": (lambda t: ["street", "--line", str(_lines(t)), "--windows", "0",
                                      "inf", "-o", str(t / "out")], "--windows"),
    "tower-height-huge": (lambda t: ["tower", "--height", "1e6", "--far", "4", "--lot-area",
                                     "900", "-o", str(t / "out")], "at most 1,000 m"),
    "tower-height-1e300": (lambda t: ["tower", "--height", "1e300", "--far", "4",
                                      "--lot-area", "900", "-o", str(t / "out")], "1e+300"),
    # lon/lat degrees read as metres: a building of a millimetre, "zero-length edge"
    "crs-3857-on-lonlat": (lambda t: ["skeleton", str(_lines(t)), "--crs", "EPSG:3857"],
                           "look like longitude/latitude degrees"),
    "crs-utm-on-lonlat": (lambda t: ["block", str(_write(t / "p.geojson", POLYS)),
                                     "--library", str(LIB), "--crs", "EPSG:32632", "-o",
                                     str(t / "out")], "look like longitude/latitude degrees"),
    "scheduler-malformed": (lambda t: ["city", "--streets", str(EX / "city" /
                                                                "district_streets.geojson"),
                                       "--library", str(LIB), "--scheduler", "::::",
                                       "-o", str(t / "out")], "scheduler"),
}
for name, (argv_of, names) in OPTIONS.items():
    case(f"option-{name}", argv_of, names=names)


def _blocker(tmp: Path) -> Path:
    f = tmp / "a-file"
    f.write_text("not a folder\n")
    return f


OUT_COMMANDS = {
    "building": lambda t, o: ["building", str(_lines(t)), "--library", str(LIB), "-o", o],
    "block": lambda t, o: ["block", str(_write(t / "p.geojson", POLYS)), "--library",
                           str(LIB), "-o", o],
    "city": lambda t, o: ["city", "--streets", str(EX / "city" / "district_streets.geojson"),
                          "--library", str(LIB), "-o", o],
    "demo": lambda t, o: ["demo", "-o", o],
    "ingest": lambda t, o: ["ingest", str(LIB), "-o", o],
}


def _write(f: Path, doc: dict) -> Path:
    f.write_bytes(_dump(doc))
    return f


for cmd, argv_of in OUT_COMMANDS.items():
    case(f"out-{cmd}-is-a-file", lambda t, a=argv_of: a(t, str(_blocker(t))),
         names="{tmp}/a-file")
    case(f"out-{cmd}-under-a-file", lambda t, a=argv_of: a(t, str(_blocker(t) / "sub")),
         names="{tmp}/a-file")
# -o "" (an unset shell variable) wrote into the current folder
EMPTY_OUT = {**OUT_COMMANDS,
             "street": lambda t, o: ["street", "--line", str(_lines(t)), "-o", o],
             "tower": lambda t, o: ["tower", "--height", "30", "--far", "2", "--lot-area",
                                    "900", "-o", o],
             "gallery": lambda t, o: ["gallery", "--out", o]}
for cmd, argv_of in EMPTY_OUT.items():
    for blank in ("", " "):
        case(f"out-{cmd}-empty{'-blank' if blank else ''}",
             lambda t, a=argv_of, b=blank: a(t, b), names="-o: the folder is empty")


# --- pathological inputs: refused with an estimate, before the work --------------------------

def _crossing_streets(tmp: Path) -> Path:
    """3,000 random segments over 2 km (projected): about a million crossings."""
    import random
    rnd = random.Random(1)
    feats = [{"type": "Feature", "properties": {"highway": "residential"},
              "geometry": {"type": "LineString",
                           "coordinates": [[rnd.uniform(0, 2000), rnd.uniform(0, 2000)]
                                           for _ in range(2)]}} for _ in range(3000)]
    return _write(tmp / "crossing.geojson", {"type": "FeatureCollection", "features": feats})


def _huge_polygon(tmp: Path) -> Path:
    """One block outline of 200,000 vertices (a circle of 100 m, projected)."""
    import math
    n = 200_000
    ring = [[500 + 100 * math.cos(2 * math.pi * i / n), 500 + 100 * math.sin(2 * math.pi * i / n)]
            for i in range(n)]
    ring.append(ring[0])
    return _write(tmp / "huge.geojson", {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon",
                                                           "coordinates": [ring]}}]})


case("pathological-crossing-streets", lambda t: [
    "city", "--streets", str(_crossing_streets(t)), "--crs", "EPSG:25832", "--library",
    str(LIB), "-o", str(t / "out")], names="crossing.geojson")
case("pathological-200000-vertices-block", lambda t: [
    "block", str(_huge_polygon(t)), "--crs", "EPSG:25832", "--library", str(LIB), "-o",
    str(t / "out")], names="huge.geojson")
case("pathological-200000-vertices-footprints", lambda t: [
    "city", "--footprints", str(_huge_polygon(t)), "--crs", "EPSG:25832", "--library",
    str(LIB), "-o", str(t / "out")], names="huge.geojson")


# --- the runner -----------------------------------------------------------------------------

MEMORY_LIMIT = 8 << 30    # address space while the corpus runs: a blow-up fails its case


@pytest.fixture(scope="module", autouse=True)
def bounded_memory():
    """Bounded memory, in-process: a case that allocates past the limit raises
    MemoryError (a failure, with its traceback) instead of bringing the machine down."""
    import resource
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = MEMORY_LIMIT if hard == resource.RLIM_INFINITY else min(MEMORY_LIMIT, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    yield
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


@pytest.fixture(scope="module")
def good_run(tmp_path_factory) -> Path:
    from tests.test_faults import grid_streets
    base = tmp_path_factory.mktemp("run")
    out = base / "run"
    assert main(["city", "--streets", str(grid_streets(base / "s.geojson", 2)), "--library",
                 str(LIB), "-o", str(out), "--no-overview", "--workers", "2"]) == 0
    return out


def snapshot(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): (p.lstat().st_size if not p.is_dir() else -1)
            for p in sorted(folder.rglob("*"))}


def run_case(c: Case, tmp: Path, capsys, monkeypatch) -> None:
    tmp.mkdir(exist_ok=True)
    argv = c.make(tmp)
    for k, v in (c.env or {}).items():
        monkeypatch.setenv(k, v)
    before = snapshot(tmp)
    capsys.readouterr()
    try:
        code = main(argv)
    except SystemExit as exc:        # argparse's own usage errors
        code = exc.code if isinstance(exc.code, int) else 2
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    assert code == c.code, (code, err)
    if c.code == 0:
        assert snapshot(tmp) == before, "the command wrote or removed files"
        return
    lines = [ln for ln in err.splitlines() if ln.strip() and "warning:" not in ln
             and not ln.startswith("usage:") and not ln.startswith("citysynth: compiling")]
    assert len(lines) == 1, err
    names = c.names.replace("{tmp}", str(tmp)).replace("{bad}", "input")
    assert names in err, (names, err)
    assert snapshot(tmp) == before, "the command wrote or removed files"


@pytest.mark.parametrize("c", CASES, ids=[c.id for c in CASES])
def test_bad_input(c: Case, tmp_path, capsys, monkeypatch, good_db, good_run):
    GOOD_DB[:] = [good_db]
    GOOD_RUN[:] = [good_run]
    monkeypatch.chdir(tmp_path)         # a default output folder would land here
    run_case(c, tmp_path / "case", capsys, monkeypatch)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case"]


def test_the_corpus_is_large_and_covers_every_command():
    assert len(CASES) >= 300
    kinds = {c.id.split("-")[0] for c in CASES}
    assert {"problem", "structure", "skeleton", "building", "block", "city", "city.toml",
            "manifest.toml", "manifest", "partdb", "diff", "option", "out"} <= kinds


# --- end to end: real processes, under a memory limit -----------------------------------------

def _limited() -> None:
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (6 << 30, 6 << 30))


E2E = ["pathological-crossing-streets", "problem-deep-100000", "problem-latin1",
       "problem-k-huge", "structure-interval-1e9-2e9", "skeleton-utf16", "city-streets-folder",
       "option-max-memory-nan",
       "diff-manifest-list-a", "out-city-is-a-file", "manifest.toml-deep-100000"]


@pytest.mark.parametrize("name", E2E)
def test_bad_input_end_to_end(name, tmp_path, good_db, good_run):
    GOOD_DB[:] = [good_db]
    GOOD_RUN[:] = [good_run]
    c = next(c for c in CASES if c.id == name)
    argv = c.make(tmp_path)
    before = snapshot(tmp_path)
    env = {**os.environ, **(c.env or {})}
    res = subprocess.run([sys.executable, "-m", "citysynth.pipeline.cli", *argv], cwd=tmp_path,
                         capture_output=True, text=True, timeout=600, env=env,
                         preexec_fn=_limited)
    assert res.returncode == c.code, res.stderr
    assert "Traceback" not in res.stderr and "MemoryError" not in res.stderr
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("data, text", [
    # read as they are now (skeletons/gis_files.py): damaged ones are one line too
    # damage in plain words (GDAL's and SQLite's, in brackets, until 2026-11-30)
    (b"SQLite format 3\x00" + bytes(200), "cannot read this GeoPackage: its database is "
                                          "damaged, or it is not one (cut short, or another "
                                          "kind of file renamed); check that it is whole, or "
                                          "export"),
    (b"\x00\x00\x27\x0a" + bytes(96), "cannot read this Shapefile ("),
    (b"fgb\x03fgb\x00" + bytes(64), "this FlatGeobuf holds no layer (damaged, or saved"),
    (b"PK\x03\x04" + bytes(64), "cannot read this zipped Shapefile ("),
    (b"PAR1" + bytes(64), "cannot read this GeoParquet: it is cut short, or not a Parquet "
                          "file"),
    (b"  0\nSECTION\n  2\nENTITIES\n  0\nLWPOLYLINE\n 10\nabc\n",
     "cannot read this DXF (error at line 10 of "),
    (b"!table\n!version 300\n", "cannot read this MapInfo table ("),
    (b'{"type": "Feature", "properties": {}, "geometry": null}\n'
     b'{"type": "Feature", "properties": {}, "geometry": null}\n',
     # read as a GeoJSON Text Sequence now, whose features are then checked as any are
     "no usable features: all 2 left out (feature 0: no geometry (null)"),
])
def test_files_of_other_gis_formats_are_named_with_the_conversion(tmp_path, capsys, data,
                                                                   text):
    """What QGIS or ogr2ogr write besides GeoJSON is read, or named for what it is with
    the conversion (a GeoPackage was "not UTF-8 text ... perhaps UTF-16"); damaged, one
    line either way."""
    f = tmp_path / "input.data"
    f.write_bytes(data)
    assert main(["block", str(f), "--library", str(LIB), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert text in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()
