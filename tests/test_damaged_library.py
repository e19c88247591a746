"""A damaged or hand-edited part database given as --library: every command refuses it
at load time in one line (exit 2) naming the file, the part or key and what is wrong,
and says how to write it again; never a traceback, never a later "no row fits", never
a silently different layout. The database is a small library freshly ingested, then
damaged one way per case (the npz's hash recomputed, so the value check is reached)."""

from __future__ import annotations

import hashlib
import io
import json
import shutil
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from citysynth.parts_db import load_db, load_library
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"
PARTS = ["classic_mid_7.8_a0", "classic_mid_8.4_a1", "classic_end_left", "classic_end_right",
         "classic_corner_90_convex", "classic_corner_90_concave", "classic_t",
         "tower_ground_square18", "tower_floor_square18_3.0", "tower_roof_square18",
         "bldg_00_6.0m_classic_4s"]


def _small_library(lib: Path) -> Path:
    """A few parts of every class from the sample library, in a library of their own."""
    specs = tomllib.loads((EX / "library" / "manifest.toml").read_text())["part"]
    (lib / "meshes").mkdir(parents=True)
    text = '[library]\nname = "small"\nquantum = 0.2\n'
    for s in (s for s in specs if s["id"] in PARTS):
        shutil.copy(EX / "library" / s["file"], lib / "meshes")
        text += "\n[[part]]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in s.items()
                                          if not isinstance(v, dict))
        if "attributes" in s:
            text += "attributes = {" + ", ".join(f"{k} = {v}" for k, v in
                                                s["attributes"].items()) + "}\n"
    (lib / "manifest.toml").write_text(text.replace("True", "true"))
    return lib


@pytest.fixture(scope="module")
def small_db(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("small")
    lib = _small_library(base / "lib")
    assert main(["ingest", str(lib), "-o", str(base / "db")]) == 0
    return base / "db"


# --- ways to damage a database ----------------------------------------------------------

Meta = dict
Tables = dict[str, np.ndarray]


def _index(meta: Meta, pid: str) -> int:
    return next(i for i, p in enumerate(meta["parts"]) if p["id"] == pid)


def _part(pid: str, **changes) -> Callable[[Meta], None]:
    def edit(meta: Meta) -> None:
        meta["parts"][_index(meta, pid)].update(changes)
    return edit


def _meta(**changes) -> Callable[[Meta], None]:
    return lambda meta: meta.update(changes)


def _cost(table: str, value, allowed: bool = True) -> Callable[[Tables], None]:
    """Set the first entry of ``table`` where a transition is (or is not) allowed."""
    def edit(t: Tables) -> None:
        e, f = np.argwhere(t["allowed"] == allowed)[0]
        if table == "cost_branch":   # a T part's row
            e, f = np.argwhere(np.isfinite(t["cost_branch"]))[0]
        t[table][e, f] = value
    return edit


def _drop_key(pid: str, key: str) -> Callable[[Meta], None]:
    return lambda meta: meta["parts"][_index(meta, pid)].pop(key)


MID, CORNER, T, FLOOR = "classic_mid_7.8_a0", "classic_corner_90_convex", "classic_t", \
    "tower_floor_square18_3.0"
BOWTIE = "POLYGON ((0 0, 3 3, 3 0, 0 1, 0 0))"   # crosses itself

# name: (damage of partdb.json's JSON, damage of the npz tables, what the message says)
JSON_DAMAGE: dict[str, tuple[Callable[[Meta], None], str]] = {
    "format-99": (_meta(format=99), "format 99, written by another version"),
    "format-missing": (lambda m: m.pop("format"), "format None"),
    "unknown-key": (_meta(colour="red"), "unknown key(s) ['colour']"),
    "quantum-zero": (_meta(quantum=0), "quantum: must be a positive number, got 0"),
    "quantum-changed": (_meta(quantum=0.25), "snapped to the 0.25 m quantum"),
    "parts-empty": (_meta(parts=[]), "parts must be a non-empty list"),
    "part-not-object": (lambda m: m["parts"].__setitem__(0, "x"), "must be a JSON object"),
    "part-key-missing": (_drop_key(MID, "legs"), "has no legs"),
    "part-key-unknown": (_part(MID, width=3), "unknown key(s) ['width']"),
    "duplicate-ids": (_part(CORNER, id=MID), f'duplicate id "{MID}"'),
    "ids-one-file": (_part(CORNER, id=MID.upper()), "differ only in case"),
    "class-unknown": (_part(MID, cls="spaceship"), 'unknown class "spaceship"'),
    "class-changed": (_part(MID, cls="building"), "against their classes"),
    "legs-string": (_part(MID, legs="x"), "legs must be a list of 1 finite positive"),
    "leg-string": (_part(MID, legs=["7.8"]), "legs must be a list of 1 finite positive"),
    "leg-nan": (_part(MID, legs=[float("nan")]), "legs must be a list of 1 finite positive"),
    "leg-zero": (_part(MID, legs=[0.0]), "legs must be a list of 1 finite positive"),
    "leg-negative": (_part(MID, legs=[-7.8]), "legs must be a list of 1 finite positive"),
    "leg-edited": (_part(MID, legs=[8.0]), "are not its legs_measured snapped"),
    "leg-huge-int": (_part(MID, legs=[10 ** 400]), "legs must be a list of 1 finite"),
    "corner-one-leg": (_part(CORNER, legs=[16.8], legs_measured=[16.8]),
                       "legs_measured must be a list of 2"),
    "length-huge": (_part(MID, legs=[1e300], legs_measured=[1e300]), "outside the 0.2-150 m"),
    "scale-zero": (_part(MID, scale=0), "scale must be a number above 0, got 0"),
    "scale-nan": (_part(MID, scale=float("nan")), "scale must be a number above 0, got nan"),
    "scale-string": (_part(MID, scale="1"), "scale must be a number above 0"),
    "scale-edited": (_part(MID, scale=2.0), "scale must be 1 or its legs over"),
    "height-huge": (_part(MID, height=1e300), "height must be a number above 0 to 10,000"),
    "origin-nan": (_part(MID, origin=[0, float("nan"), 0]), "origin must be a list of 3"),
    "origin-huge": (_part(MID, origin=[1e300, 0, 0]), "origin [1e+300, 0, 0] lies more"),
    "section-huge": (_part(MID, sec_in="POLYGON ((0 0, 1e300 0, 0 1e300, 0 0))"),
                     "sec_in must be a polygon of positive area"),
    "directions": (_part(CORNER, directions=[[1, 0], [0, 1]]), "directions must be"),
    "angle-out-of-range": (_part(CORNER, angle=200), "angle must lie between 0 and 180"),
    "angle-on-a-middle": (_part(MID, angle=90.0), "angle and convex are for corners"),
    "floor-area-string": (_part(FLOOR, floor_area="big"), "floor_area must be a number"),
    "attribute-nan": (_part(MID, attributes={"windows": float("nan")}), "attribute windows"),
    "attribute-huge": (_part(MID, attributes={"doors": 1e300}), "attribute doors"),
    "section-empty": (_part(MID, sec_in="POLYGON EMPTY"), "sec_in must be a polygon of "
                                                          "positive area"),
    "section-empty-all": (lambda m: [p.update(sec_in="POLYGON EMPTY", sec_out="POLYGON EMPTY")
                                     for p in m["parts"]], "must be a polygon of positive"),
    "section-garbage": (_part(MID, sec_out="POLYGON ((garbage"), "sec_out is not readable"),
    "section-point": (_part(MID, sec_in="POINT (0 0)"), "sec_in must be a polygon"),
    "section-nan": (_part(MID, sec_in="POLYGON ((0 0, nan 1, 1 0, 0 0))"), "sec_in"),
    "section-crossing": (_part(MID, sec_in=BOWTIE), "sec_in is an invalid polygon"),
    "section-number": (_part(MID, sec_in=3), "sec_in must be a cross-section"),
    "branch-missing": (_part(T, sec_branch=None), "sec_branch must be a cross-section"),
    "file-not-a-mesh": (_part(MID, file="meshes/../../../../etc/passwd"),
                        "climbs out of the library folder"),
    "file-not-a-mesh-inside": (_part(MID, file="manifest.toml"), "is not a mesh file"),
    "file-absolute": (_part(MID, file="/tmp/x.glb"), "must be a path relative"),
    "mesh-gone": (_part(MID, file="meshes/nowhere.glb"), "its mesh"),
    "library-moved": (_meta(library_root="/no/such/library"), "is not a folder any more"),
    "warnings-not-strings": (_meta(warnings=[1]), "warnings must be a list of strings"),
}
NPZ_DAMAGE: dict[str, tuple[Callable[[Tables], None], str]] = {
    "cost-text": (lambda t: t.update(cost=t["cost"].astype(str)), "the cost table holds text"),
    "cost-nan": (_cost("cost", np.nan), "the cost table gives nan for part"),
    "cost-inf-where-allowed": (_cost("cost", np.inf), "the cost table gives inf"),
    "cost-huge": (_cost("cost", 1e300), "the cost table gives 1e+300"),
    "cost-negative": (_cost("cost", -5.0), "gives -5 for part"),
    "cost-where-forbidden": (_cost("cost", 1.0, allowed=False), "may never follow it"),
    "cost-branch-nan": (_cost("cost_branch", np.nan), "the cost_branch table gives nan"),
    "cost-shape": (lambda t: t.update(cost=t["cost"][:3, :3]), "the cost table is 3 × 3, not"),
    "cost-flat": (lambda t: t.update(cost=t["cost"].ravel()), "the cost table is"),
    "allowed-int": (lambda t: t.update(allowed=t["allowed"].astype(int) * 7),
                    "the allowed table holds int64 values"),
    "allowed-none": (lambda t: t["allowed"].fill(False), "against their classes"),
    "table-missing": (lambda t: t.pop("cost_branch"), "has no cost_branch table"),
}


def _write_tables(db: Path, tables: Tables) -> None:
    buf = io.BytesIO()
    np.savez_compressed(buf, **tables)
    (db / "partdb.npz").write_bytes(buf.getvalue())
    meta = json.loads((db / "partdb.json").read_text())
    meta["npz_sha256"] = hashlib.sha256(buf.getvalue()).hexdigest()
    (db / "partdb.json").write_text(json.dumps(meta))


def _damage_json(db: Path, edit: Callable[[Meta], None]) -> None:
    meta = json.loads((db / "partdb.json").read_text())
    edit(meta)
    (db / "partdb.json").write_text(json.dumps(meta))


def _damage_npz(db: Path, edit: Callable[[Tables], None]) -> None:
    with np.load(db / "partdb.npz") as z:
        tables = {k: z[k] for k in z.files}
    edit(tables)
    _write_tables(db, tables)


FILE_DAMAGE: dict[str, tuple[Callable[[Path], None], str]] = {
    "json-empty": (lambda db: (db / "partdb.json").write_text(""), "partdb.json: empty"),
    "json-cut": (lambda db: (db / "partdb.json").write_bytes(
        (db / "partdb.json").read_bytes()[:300]), "partdb.json: not valid JSON at line"),
    "json-list": (lambda db: (db / "partdb.json").write_text("[]"), "holds list"),
    "npz-edited-unhashed": (lambda db: (db / "partdb.npz").write_bytes(
        (db / "partdb.npz").read_bytes()[:-10]), "does not match the hash"),
    "npz-garbage": (lambda db: _write_raw_npz(db, b"PK\x03\x04" + b"x" * 300),
                    "partdb.npz: not a readable table archive"),
    "npz-missing": (lambda db: (db / "partdb.npz").unlink(), "partdb.npz: missing"),
}


def _write_raw_npz(db: Path, data: bytes) -> None:
    (db / "partdb.npz").write_bytes(data)
    _damage_json(db, lambda m: m.update(npz_sha256=hashlib.sha256(data).hexdigest()))


CASES: dict[str, tuple[Callable[[Path], None], str]] = {
    **{f"json-{k}": ((lambda db, e=e: _damage_json(db, e)), say)
       for k, (e, say) in JSON_DAMAGE.items()},
    **{f"npz-{k}": ((lambda db, e=e: _damage_npz(db, e)), say)
       for k, (e, say) in NPZ_DAMAGE.items()},
    **FILE_DAMAGE,
}


def _damaged(small_db: Path, tmp: Path, name: str) -> Path:
    db = tmp / "db"
    shutil.copytree(small_db, db)
    CASES[name][0](db)
    return db


def _refused(argv: list[str], capsys) -> str:
    """Run a command that must refuse its --library: exit 2, one line, no traceback."""
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return err


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_damaged_database_is_refused_naming_what_is_wrong(name, small_db, tmp_path,
                                                           capsys):
    db = _damaged(small_db, tmp_path, name)
    out = tmp_path / "out"
    err = _refused(["building", str(EX / "skeletons" / "t_building.geojson"), "--library",
                    str(db), "-o", str(out), "--no-preview"], capsys)
    assert CASES[name][1] in err, err
    assert str(db / "partdb.") in err                 # names the file
    assert f"citysynth ingest {small_db.parent / 'lib'} -o {db} --force" in err or \
        f"citysynth ingest LIBRARY -o {db} --force" in err     # and how to write it again
    for word in ("Error:", "numpy", "dtype", "shapely", "GEOS", "Errno", "np."):
        assert word not in err, err
    assert not out.exists()


COMMANDS: dict[str, Callable[[Path, Path], list[str]]] = {
    "building": lambda db, o: ["building", str(EX / "skeletons" / "t_building.geojson"),
                               "--library", str(db), "-o", str(o)],
    "block": lambda db, o: ["block", str(EX / "blocks" / "block.geojson"), "--library",
                            str(db), "-o", str(o)],
    "street": lambda db, o: ["street", "--line", str(_line(o.parent)), "--library", str(db),
                             "-o", str(o)],
    "tower": lambda db, o: ["tower", "--height", "30", "--far", "3", "--lot-area", "400",
                            "--library", str(db), "-o", str(o)],
    "city": lambda db, o: ["city", "--streets", str(EX / "city" / "district_streets.geojson"),
                           "--library", str(db), "-o", str(o), "--workers", "1"],
}


def _line(folder: Path) -> Path:
    f = folder / "line.geojson"
    f.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {
            "type": "LineString", "coordinates": [[0, 0], [0.00054, 0]]}}]}))   # 60 m
    return f


@pytest.mark.parametrize("name", ["json-format-99", "json-scale-zero", "json-leg-string",
                                  "json-section-empty-all", "npz-cost-text", "npz-cost-nan",
                                  "json-duplicate-ids"])
@pytest.mark.parametrize("cmd", sorted(COMMANDS))
def test_every_command_taking_a_library_refuses_a_damaged_database(cmd, name, small_db,
                                                                   tmp_path, capsys):
    db = _damaged(small_db, tmp_path, name)
    out = tmp_path / "out"
    err = _refused(COMMANDS[cmd](db, out), capsys)
    assert CASES[name][1] in err, err
    assert not out.exists()


def test_the_database_ingest_writes_is_read_back_whole(small_db):
    """The checks refuse nothing ingest writes: the small library and the sample one."""
    db = load_db(small_db)
    assert sorted(db.ids) == sorted(PARTS)
    load_library(EX / "library")             # ingested (or read) once per session
    sample = load_library(EX / "library")    # read back through the checks: not refused,
    assert sample.cache_hit and len(sample.parts) == 268   # which would measure it again


def test_a_damaged_cache_is_measured_again_not_refused(tmp_path, monkeypatch):
    """The cache beside a library heals: a damaged one is ingested again, silently."""
    monkeypatch.setenv("CITYSYNTH_CACHE", str(tmp_path / "cache"))
    lib = _small_library(tmp_path / "lib")
    first = load_library(lib)
    _damage_json(first.path, _part(MID, scale=0))
    again = load_library(lib)
    assert not again.cache_hit and again.part(MID).scale > 0
    assert load_library(lib).cache_hit


@pytest.mark.parametrize("cmd", ["ingest", "building"])
def test_a_library_link_that_loops_or_dangles_says_so(tmp_path, capsys, cmd):
    """A library named through a loop of symbolic links was "no such folder", sending
    the user to look for a folder that is there; a link to nothing names its target."""
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    (tmp_path / "gone").symlink_to(tmp_path / "moved_away")
    line = Path(__file__).parents[1] / "examples" / "skeletons" / "t_building.geojson"
    for name, said in (("a", "a symbolic link that leads back to itself (a loop of links)"),
                       ("gone", f"a symbolic link to {tmp_path / 'moved_away'}, which does "
                                "not exist")):
        lib = str(tmp_path / name)
        argv = (["ingest", lib, "-o", str(tmp_path / "out")] if cmd == "ingest" else
                ["building", str(line), "--library", lib, "-o", str(tmp_path / "out")])
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"{lib}: {said}; " in err and len(err.strip().splitlines()) == 1


def test_a_folder_where_the_database_goes_leaves_nothing_written(tmp_path, capsys):
    """A folder named ``partdb.json`` in the output: the npz was renamed into place,
    then the JSON's rename failed ("Is a directory"), and a stray npz stayed. Both
    places are looked at before either file is written."""
    from citysynth.parts_db.library import DB_JSON, DB_NPZ
    lib = _small_library(tmp_path / "lib")
    out = tmp_path / "db"
    (out / DB_JSON).mkdir(parents=True)
    assert main(["ingest", str(lib), "-o", str(out)]) == 2
    assert "a folder stands where the part database's partdb.json goes" in \
        capsys.readouterr().err
    assert not (out / DB_NPZ).exists()


def test_a_library_too_large_for_its_tables_is_refused_before_measuring(tmp_path, capsys,
                                                                         monkeypatch):
    """15,000 parts were measured for 195 s, then ingest died making a 3.4 GB table (a
    traceback). Their tables (an entry per ordered pair of parts) are estimated from
    the manifest and refused before any mesh is read."""
    from citysynth.parts_db import library
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "manifest.toml").write_text("".join(
        f'[[part]]\nid = "p{i}"\nfile = "gone.glb"\nclass = "middle"\nstyle = "s"\n'
        for i in range(11_000)))
    monkeypatch.setattr(library, "_measure_all", lambda *a: pytest.fail("measured"))
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert "11,000 parts: their transition-cost tables (an entry for each part that may " \
           "follow each part) would take 2,077 MB, over the memory budget of 2,048 MB " \
           "(at most about 10,922 parts); split the library" in err, err


def test_the_cost_table_filled_in_bands_is_the_table():
    """The cost table is filled a band of rows at a time from integer pair codes (the
    pairs as Python lists took 3.4 GB for 15,000 parts): any band height gives the
    table an exhaustive pair-by-pair computation gives."""
    import shapely
    from shapely.geometry import box

    from citysynth.parts_db import costs
    rng = np.random.default_rng(5)
    n = 60
    outs = [box(0, 0, 1 + rng.integers(0, 4) * 0.5, 2 + rng.integers(0, 3)) for _ in range(n)]
    ins = [box(0, 0, 1 + rng.integers(0, 4) * 0.5, 2 + rng.integers(0, 3)) for _ in range(n)]
    classes = list(rng.choice(["middle", "corner", "end_left", "end_right", "building"], n))
    allowed = costs.allowed_matrix(classes)
    want = np.full((n, n), np.inf)
    for e, f in zip(*np.nonzero(allowed), strict=True):
        want[e, f] = round(shapely.symmetric_difference(outs[e], ins[f]).area, 4)
    for band in (1, 7, n, 10 * n * n):
        costs.CHUNK_PAIRS = band
        try:
            got = costs.cost_matrix(outs, ins, allowed)
        finally:
            costs.CHUNK_PAIRS = 1 << 22
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert np.isinf(costs.cost_matrix(outs, ins, np.zeros((n, n), bool))).all()


def test_a_database_whose_library_changed_since_is_refused(tmp_path):
    """A database written with ``ingest -o`` was used as it was after its library's
    meshes were edited: a 6 m part made 9 m was placed at 6 m pitch, ten buildings
    each overlapping the next by 3 m, exit 0. Read while its library is still where
    it was (its meshes are read from there), a database must match it."""
    from citysynth.parts_db import LibraryError
    lib = _small_library(tmp_path / "lib")
    out = tmp_path / "db"
    assert main(["ingest", str(lib), "-o", str(out)]) == 0
    assert load_library(out).library_hash == load_db(out).library_hash   # unchanged: fine
    meshes = sorted((lib / "meshes").iterdir())
    kept = meshes[0].read_bytes()
    meshes[0].write_bytes(meshes[1].read_bytes())
    with pytest.raises(LibraryError, match="whose manifest or meshes have changed since"):
        load_library(out)
    meshes[0].write_bytes(kept)                     # put back: the database is its again
    assert load_library(out).library_hash == load_db(out).library_hash
