"""Part libraries: hand-made meshes with known sections, the shipped sample library,
the cache, and every kind of bad input (one message naming part and file, exit 2,
nothing written)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import shapely
import trimesh
from hypothesis import given
from hypothesis import strategies as st

from citysynth.export.usd import prim_name
from citysynth.parts_db import LibraryError, ingest, load_library
from citysynth.parts_db.costs import allowed_matrix
from citysynth.parts_db.library import DB_JSON, DB_NPZ
from citysynth.parts_db.manifest import id_key
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
SAMPLE = ROOT / "examples" / "library"


def _box(x0, x1, y0, y1, z0, z1):
    m = trimesh.creation.box(extents=[x1 - x0, y1 - y0, z1 - z0])
    m.apply_translation([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    return m


def _library(tmp: Path, parts: list[tuple[str, str, object, str]], extra: str = "",
             library: str = "") -> Path:
    """parts: (id, file name, mesh or bytes, extra toml lines)."""
    lib = tmp / "lib"
    lib.mkdir(exist_ok=True)
    lines = ["[library]", 'name = "test"', library, ""]
    for pid, fname, mesh, more in parts:
        if isinstance(mesh, bytes):
            (lib / fname).write_bytes(mesh)
        elif mesh is not None:
            mesh.export(lib / fname)
        lines += ["[[part]]", f'id = "{pid}"', f'file = "{fname}"', more, ""]
    (lib / "manifest.toml").write_text("\n".join(lines) + extra)
    return lib


def test_two_boxes_of_known_profiles_give_a_known_cost(tmp_path):
    lib = _library(tmp_path, [
        ("A", "a.stl", _box(0, 4, 0, 10, 0, 6), 'class = "building"'),
        ("B", "b.obj", _box(0, 3, 0, 10, 0, 9), 'class = "building"'),
        ("C", "c.ply", _box(0, 5, 0, 8, 0, 6), 'class = "building"'),
    ])
    db = ingest(lib, tmp_path / "db")
    i = db.index()
    a, b, c = db.parts[i["A"]], db.parts[i["B"]], db.parts[i["C"]]
    assert a.legs == [4.0] and b.legs == [3.0] and c.legs == [5.0]
    assert a.sec_out.area == pytest.approx(60) and b.sec_in.area == pytest.approx(90)
    assert a.sec_in.bounds == pytest.approx((-10, 0, 0, 6))  # u = -y (facade out), v = z
    assert db.cost[i["A"], i["B"]] == pytest.approx(30)      # 10 x 3 m more of B
    assert db.cost[i["A"], i["C"]] == pytest.approx(12)      # 2 x 6 m less of C
    assert db.cost[i["A"], i["A"]] == pytest.approx(0)


@given(st.text(st.characters(codec="utf-8", categories=("L", "N", "P", "S", "Zs")),
               min_size=1, max_size=12))
def test_an_ids_key_is_its_usd_name(pid):
    """The key ingest tells ids apart by is the name usd-core gives the part's prim and
    file (case-folded): ids of one key are refused, ids of two keys never share a
    file."""
    assert id_key(pid) == prim_name(pid).casefold()


def test_a_mirrored_node_is_wound_back(tmp_path):
    """A glTF part holding a mirrored copy (a node scaled -1 in x, as a modelling tool's
    mirror exports) is read as glTF says a renderer must: its faces wound back, so they
    face out as the plain box's do. They were inside out: each exported piece had a
    negative volume, its faces looking into the wall (an engine culling back faces
    showed a hole where the part stood)."""
    from citysynth.parts_db.geometry import part_pieces
    plain, mirrored = trimesh.Scene(), trimesh.Scene()
    plain.add_geometry(_box(0, 4, 0, 10, 0, 6), node_name="wall")
    flip = np.diag([-1.0, 1.0, 1.0, 1.0])
    flip[0, 3] = 4.0   # x -> 4 - x: the same box
    mirrored.add_geometry(_box(0, 4, 0, 10, 0, 6), node_name="wall", transform=flip)
    lib = _library(tmp_path, [("A", "a.glb", plain, 'class = "building"'),
                              ("M", "m.glb", mirrored, 'class = "building"')])
    db = ingest(lib, tmp_path / "db")
    i = db.index()
    a, m = db.parts[i["A"]], db.parts[i["M"]]
    assert m.legs == a.legs and m.sec_in.equals(a.sec_in)
    for part in (a, m):
        (piece,) = part_pieces(db, part)
        mesh = trimesh.Trimesh(piece.vertices, piece.faces, process=False)
        assert mesh.volume == pytest.approx(240.0)


@pytest.mark.parametrize("before", ["a good database", "nothing"])
def test_a_disk_filling_while_the_database_is_written_leaves_the_old_one(
        tmp_path, monkeypatch, before):
    """``ingest --force`` over a good database met a full disk while writing the JSON,
    after the new npz had replaced the old one: the old database no longer loaded
    ("does not match the hash partdb.json records"), and into an empty folder a lone
    npz was left. Both temporaries are written before either replaces anything."""
    import errno

    from citysynth.parts_db.library import load_db
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    one = _library(tmp_path / "one", [("A", "a.stl", _box(0, 4, 0, 10, 0, 6),
                                       'class = "building"')])
    two = _library(tmp_path / "two", [("A", "a.stl", _box(0, 4, 0, 10, 0, 6),
                                       'class = "building"'),
                                      ("B", "b.stl", _box(0, 3, 0, 10, 0, 9),
                                       'class = "building"')])
    db = tmp_path / "db"
    if before == "a good database":
        ingest(one, db)
    written = {p.name: p.read_bytes() for p in db.glob("*")} if db.exists() else {}
    def full(real):
        def write(self, *a, **k):   # the JSON's temporary meets the full disk
            if self.name.startswith(".partdb") and self.suffix == ".json":
                raise OSError(errno.ENOSPC, "No space left on device", str(self))
            return real(self, *a, **k)
        return write
    monkeypatch.setattr(Path, "write_text", full(Path.write_text))
    monkeypatch.setattr(Path, "write_bytes", full(Path.write_bytes))
    with pytest.raises(OSError, match="No space left"):
        ingest(two, db, force=True)
    monkeypatch.undo()
    assert {p.name: p.read_bytes() for p in db.glob("*")} == written
    if written:
        assert [p.id for p in load_db(db).parts] == ["A"]


def test_a_part_of_too_many_triangles_is_refused_with_the_memory_it_takes(
        tmp_path, monkeypatch, capsys):
    """A scanned part of 6.2 million triangles was measured for 24 s in 2 GB, and
    under a memory limit ended in a traceback inside trimesh. Past the limit (here
    lowered to 10, for a 12-triangle box) a part is refused before it is measured."""
    import citysynth.parts_db.mesh_faults as mesh_faults
    monkeypatch.setattr(mesh_faults, "MAX_TRIANGLES", 10)
    lib = _library(tmp_path, [("A", "a.glb", _box(0, 4, 0, 10, 0, 6), 'class = "building"')])
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert '"A"' in err and "12 triangles, past the 10 a part may have" in err, err
    assert "decimate it" in err and not (tmp_path / "db").exists()


@pytest.mark.parametrize("ext", ["stl", "ply"])
def test_a_mesh_past_the_triangles_or_the_size_is_refused_before_it_is_read(
        tmp_path, monkeypatch, capsys, ext):
    """A binary STL of 10 million triangles was refused only after trimesh read it
    (2.7 GB); 40 million under a 4 GB limit were called "damaged"; an 8 GB file was a
    MemoryError traceback, read whole before any check. The STL's and PLY's headers
    tell the count before the file is read, and a file over the size a part's mesh
    may be is refused unread."""
    import trimesh

    import citysynth.parts_db.mesh_faults as mesh_faults
    box = trimesh.creation.box(extents=(4, 10, 6))
    box.apply_translation((2, 5, 3))
    lib = _library(tmp_path, [("A", f"a.{ext}", box, 'class = "building"')])
    monkeypatch.setattr(mesh_faults, "MAX_TRIANGLES", 10)
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("read"))
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert "its header gives 12 triangles, past the 10 a part may have" in err, err
    monkeypatch.setattr(mesh_faults, "MAX_TRIANGLES", 2_000_000)
    monkeypatch.setattr(mesh_faults, "MAX_FILE_BYTES", 100)
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert "GB, more than the 0 GB a part's mesh may be" in err and "decimate it" in err, err


def test_tower_floors_stack_along_z(tmp_path):
    lower = _box(-5, 5, -5, 5, 0, 3.2)
    upper = _box(-4, 4, -4, 4, 0, 3.6)
    lib = _library(tmp_path, [
        ("G", "g.stl", lower, 'class = "ground_floor"\nstyle = "t"'),
        ("F", "f.stl", upper, 'class = "floor"\nstyle = "t"'),
        ("R", "r.stl", _box(-4, 4, -4, 4, 0, 1.0), 'class = "roof"\nstyle = "t"'),
    ])
    db = ingest(lib, tmp_path / "db")
    i = db.index()
    g, f = db.parts[i["G"]], db.parts[i["F"]]
    assert g.legs == [3.2] and f.legs == [3.6]
    assert f.attributes["floor_area"] == pytest.approx(64)
    assert db.cost[i["G"], i["F"]] == pytest.approx(100 - 64)
    assert not db.allowed[i["F"], i["G"]] and not db.allowed[i["R"], i["F"]]
    assert not db.warnings


def test_a_tower_part_off_the_vertical_axis_is_warned_of(tmp_path):
    """A floor modelled 3 to 13 m along X (the ground floor and roof about the axis)
    stacked 8 m out over the street, told only by a high cost. A tower part whose plan
    does not reach the axis x = y = 0 its storeys stack along is warned of."""
    lib = _library(tmp_path, [
        ("G", "g.stl", _box(-5, 5, -5, 5, 0, 4), 'class = "ground_floor"\nstyle = "t"'),
        ("F", "f.stl", _box(3, 13, -5, 5, 0, 4), 'class = "floor"\nstyle = "t"'),
        ("R", "r.stl", _box(-5, 5, -5, 5, 0, 1), 'class = "roof"\nstyle = "t"')])
    db = ingest(lib, tmp_path / "db")
    assert db.warnings == ["F: its plan (x 3 to 13 m, y -5 to 5 m) lies 3 m off the vertical "
                           "axis x = y = 0 that a tower's storeys stack along; move it to its "
                           "canonical frame (see README)"], db.warnings


def test_class_rules():
    cls = ["end_left", "middle", "end_right", "corner", "building", "floor", "roof"]
    a = allowed_matrix(cls)
    assert not a[:, 0].any()                   # nothing precedes an end_left
    assert not a[2, :].any()                   # nothing follows an end_right
    assert a[0, 1] and a[1, 3] and a[3, 2]
    assert not a[1, 4] and not a[4, 1]         # groups never mix
    assert a[4, 4] and a[5, 6] and not a[6, 5]


def test_sample_library_contents(sample_db):
    db = sample_db
    by = {}
    for p in db.parts:
        by.setdefault((p.cls, p.style), []).append(p)
    facade_styles = {s for (c, s) in by if c == "middle"}
    assert len(facade_styles) >= 2
    for s in facade_styles:
        mids = by[("middle", s)]
        assert len({p.length for p in mids}) >= 6
        # geometry differs: many distinct cross-sections, so costs mean something
        assert len({shapely.to_wkb(p.sec_out) for p in mids}) >= 4
        assert by[("end_left", s)] and by[("end_right", s)] and by[("t_junction", s)]
        corners = {(p.angle, p.convex) for p in by[("corner", s)]}
        assert {(90, True), (90, False)} <= corners
        assert any(a != 90 for a, _ in corners)
    floors = [p for p in db.parts if p.cls == "floor"]
    assert len(floors) >= 10
    assert all(3.0 <= p.height <= 5.0 for p in floors)
    assert len({round(p.floor_area) for p in floors}) >= 8
    assert db.select("ground_floor") and db.select("roof")
    buildings = db.select("building")
    assert len(buildings) >= 70
    assert min(p.length for p in buildings) >= 6 and max(p.length for p in buildings) <= 24
    assert len({round(p.height, 1) for p in buildings}) >= 5


def test_sample_attributes_come_from_named_submeshes(sample_db):
    b = sample_db.select("building")[0]
    scene = trimesh.load(SAMPLE / b.file)
    names = [str(n) for n in scene.graph.nodes_geometry]
    assert b.attributes["windows"] == sum(n.startswith("window") for n in names) > 0
    assert b.attributes["doors"] == 1


def test_a_window_of_several_nodes_or_primitives_counts_once(tmp_path):
    """``window_1`` with its ``window_1_frame`` and ``window_1_glass`` nodes counted 3
    windows, and a door mesh of two primitives (frame and leaf materials, the usual
    multi-material export; trimesh makes a child node of each) 2 doors. A numbered
    window counts once whatever its nodes, a node once whatever its primitives;
    windows of other numbers, or unnumbered nodes of their own, count each."""
    from citysynth.parts_db.meshes import _named_features
    s = trimesh.Scene()
    for i, name in enumerate(["window_1", "window_1_frame", "window_1_glass", "window_2",
                              "Window3", "windows", "door", "body"]):
        s.add_geometry(_box(0, 1, 0, 1, 0, 1), node_name=name, geom_name=f"g{i}")
    s.export(tmp_path / "a.glb")
    got = _named_features(trimesh.load(tmp_path / "a.glb", process=False))
    assert sorted(got) == [("door", "door"), ("window", "#1"), ("window", "#2"),
                           ("window", "#3"), ("window", "windows")], got
    (tmp_path / "b.gltf").write_text(json.dumps(_two_primitive_door()))
    assert sorted(_named_features(trimesh.load(tmp_path / "b.gltf", process=False))) == [
        ("door", "door_main")]


def _two_primitive_door() -> dict:
    """A glTF of one node, ``door_main``, whose mesh has two primitives (a unit
    triangle each), its buffer inline."""
    import base64
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype="<f4").tobytes()
    i = np.array([0, 1, 2], dtype="<u4").tobytes()
    data = "data:application/octet-stream;base64," + base64.b64encode(v + i).decode()
    prim = {"attributes": {"POSITION": 0}, "indices": 1}
    return {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0, "name": "door_main"}],
            "meshes": [{"primitives": [prim, dict(prim)]}],
            "buffers": [{"uri": data, "byteLength": len(v + i)}],
            "bufferViews": [{"buffer": 0, "byteLength": len(v)},
                            {"buffer": 0, "byteOffset": len(v), "byteLength": len(i)}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3,
                           "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                          {"bufferView": 1, "componentType": 5125, "count": 3,
                           "type": "SCALAR"}]}


def test_sample_costs_and_lengths(sample_db):
    db = sample_db
    q = db.quantum
    for p in db.parts:
        for leg in p.legs:
            assert abs(leg / q - round(leg / q)) < 1e-9
    i = db.index()
    finite = db.cost[db.allowed]
    assert np.isfinite(finite).all() and (finite >= 0).all()
    assert not np.isfinite(db.cost[~db.allowed]).any()
    mids = [p for p in db.parts if p.cls == "middle"]
    # a straight part with the same section at both ends fits itself (the library's
    # seam and step parts, which change profile along their length, do not)
    same = [p for p in mids if p.sec_in.symmetric_difference(p.sec_out).area < 1e-6]
    assert len(same) >= 10
    assert all(db.cost[i[p.id], i[p.id]] < 1e-6 for p in same)
    t = db.select("t_junction")[0]
    assert t.sec_branch is not None and len(t.legs) == 3
    assert np.isfinite(db.cost_branch[i[t.id]]).any()


def test_cache_hit_and_invalidation(tmp_path, monkeypatch):
    monkeypatch.delenv("CITYSYNTH_CACHE", raising=False)
    lib = tmp_path / "lib"
    shutil.copytree(SAMPLE, lib, ignore=shutil.ignore_patterns(".citysynth"))
    first = ingest(lib)
    assert not first.cache_hit and (lib / ".citysynth" / DB_JSON).is_file()
    again = load_library(lib)
    assert again.cache_hit and again.library_hash == first.library_hash
    assert np.array_equal(again.cost, first.cost)
    assert [p.attributes for p in again.parts] == [p.attributes for p in first.parts]
    mesh_file = lib / first.parts[0].file
    mesh_file.write_bytes(mesh_file.read_bytes() + b"\0")  # changed content
    assert not ingest(lib).cache_hit


def test_a_cache_that_cannot_be_written_falls_back_and_is_read_back(tmp_path, monkeypatch):
    """``$CITYSYNTH_CACHE`` naming a file: the database was cached in the user's cache
    folder instead, on every run, and never read from there (measured again each time,
    "warnings: none"). The fallback is said and read back."""
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder\n")
    monkeypatch.setenv("CITYSYNTH_CACHE", str(blocker))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    lib = _library(tmp_path, [("A", "a.stl", _box(0, 4, 0, 10, 0, 6), 'class = "building"')])
    first = ingest(lib)
    assert not first.cache_hit and str(tmp_path / "xdg") in str(first.path)
    assert any("cached it in" in w for w in first.warnings), first.warnings
    again = ingest(lib)
    assert again.cache_hit and again.path == first.path


@pytest.mark.parametrize("written, said", [
    ("meshes\\\\a.stl", "with / between folders, not \\"),   # TOML: meshes\\a.stl
    ("meshes/A.STL", "the folder has 'a.stl': file names differ in case here"),
])
def test_a_mesh_path_almost_right_says_what_is_wrong(tmp_path, capsys, written, said):
    """A mesh path written with Windows' backslashes, or in another case than the
    file's, was "mesh file not found", sending the user to look for a file that is
    there."""
    lib = tmp_path / "lib"
    (lib / "meshes").mkdir(parents=True)
    _box(0, 4, 0, 10, 0, 6).export(lib / "meshes" / "a.stl")
    (lib / "manifest.toml").write_text('[library]\nname = "t"\n\n[[part]]\nid = "A"\n'
                                       f'file = "{written}"\nclass = "building"\n')
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert "mesh file not found" in err and said in err, err


def test_cache_folder_policy(tmp_path, monkeypatch):
    """Beside a library the user may write; under $CITYSYNTH_CACHE when set; in the
    user cache folder for an installed (site-packages) or read-only library."""
    from citysynth.parts_db.library import cache_dir
    monkeypatch.delenv("CITYSYNTH_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    lib = tmp_path / "lib"
    lib.mkdir()
    assert cache_dir(lib) == lib.resolve() / ".citysynth"
    installed = tmp_path / "venv" / "site-packages" / "citysynth" / "examples" / "library"
    installed.mkdir(parents=True)
    assert cache_dir(installed).parent == tmp_path / "xdg" / "citysynth" / "partdb"
    monkeypatch.setenv("CITYSYNTH_CACHE", str(tmp_path / "c"))
    assert cache_dir(lib).parent == tmp_path / "c"
    assert cache_dir(lib) != cache_dir(installed)


GOOD = _box(0, 3, 0, 10, 0, 6)
GLB = GOOD.export(file_type="glb")


@pytest.mark.parametrize("parts, extra_lib, fragment", [
    ([("A", "missing.stl", None, 'class = "middle"')], "", "mesh file not found"),
    ([("A", "bad.glb", b"glTF this is not a binary gltf", 'class = "middle"')], "",
     "its header gives glTF version"),
    ([("A", "json.glb", GLB[:20] + GLB[20:].replace(b'":', b'";', 1), 'class = "middle"')],
     "", "its glTF JSON chunk is damaged at character"),
    ([("A", "short.glb", GLB[:len(GLB) // 2], 'class = "middle"')], "",
     f"the file is cut short: its header gives {len(GLB):,} bytes"),
    ([("A", "head.glb", GLB[:9], 'class = "middle"')], "", "the file has no glTF header"),
    ([("A", "a.gltf", b'{"asset": {"version": "2.0"}, "meshes": [', 'class = "middle"')],
     "", "its JSON is damaged at character 41"),
    ([("A", "a.ply", GOOD.export(file_type="ply")[:200], 'class = "middle"')], "",
     "the file is cut short within its PLY header"),
    ([("A", "empty.obj", b"# no geometry\n", 'class = "middle"')], "", "empty"),
    ([("A", "nan.obj", b"v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", 'class = "middle"')], "",
     "not finite numbers (NaN or infinity)"),
    ([("A", "flat.obj", b"v 0 0 0\nv 3 0 0\nv 3 0 6\nv 0 0 6\nf 1 2 3\nf 1 3 4\n",
       'class = "middle"')], "", "no cross-section"),
    ([("A", "a.stl", _box(0, 300, 0, 1000, 0, 600), 'class = "middle"\nlength = 3.0')], "",
     "centimetres"),
    # a double export's two coincident copies cancel out in every section: it was "the
    # mesh must be closed", which it is, twice
    ([("A", "a.glb", trimesh.util.concatenate([GOOD, GOOD]), 'class = "middle"')], "",
     "the mesh holds 12 of its faces twice (two coincident copies of a body"),
    # 1,000,000 km out a GLB's 32-bit coordinates step by 64 m: it was told only "0 m
    # along its primary axis is implausible"
    ([("A", "a.glb", _box(1e9, 1e9 + 5, 0, 10, 0, 6), 'class = "middle"')], "",
     "(its points lie 1,000,000,000 m from its origin, where a file's 32-bit coordinates "
     "step by 64 m"),
    # only centimetres were told (2026-12-01): millimetres, and metres under "cm"
    ([("A", "a.stl", _box(0, 3000, 0, 10000, 0, 6000), 'class = "middle"\nlength = 3.0')], "",
     '(millimetres? set units = "mm"; or a stray vertex far from the rest?)'),
    ([("A", "a.stl", _box(0, 3, 0, 10, 0, 6), 'class = "middle"\nlength = 300.0')], "",
     'it measures 1/100 of the length given: a mesh in metres under units = "cm"?'),
    ([("A", "a.stl", GOOD, 'class = "middle"'), ("A", "b.stl", GOOD, 'class = "middle"')],
     "", 'duplicate id "A"'),
    ([("wall.2", "a.stl", GOOD, 'class = "middle"'), ("Wall_2", "b.stl", GOOD,
                                                         'class = "middle"')],
     "", 'its id and "wall.2" differ only in case or in characters other than letters'),
    # "ü" is "__" in USD (a "_" per UTF-8 byte): one prototype file for both parts
    ([("ü", "a.stl", GOOD, 'class = "middle"'), ("__", "b.stl", GOOD, 'class = "middle"')],
     "", 'its id and "ü" differ only in case or in characters other than letters'),
    ([("A\\nB", "a.stl", GOOD, 'class = "middle"')], "",
     'its id "A\\nB" holds a character that prints as no letter (U+000A'),
    # found by the ingest fuzzing pass of 2026-12-01: ids no listing tells apart, an id
    # Windows opens as a device, a style or library name that cleared the terminal
    ([("caf\u00e9", "a.stl", GOOD, 'class = "middle"'),
      ("cafe\u0301", "b.stl", GOOD, 'class = "middle"')], "",
     'its id and "caf\u00e9" are one text written two ways'),
    ([("a", "a.stl", GOOD, 'class = "middle"'), ("a ", "b.stl", GOOD, 'class = "middle"')],
     "", 'id "a " begins or ends with a space'),
    ([("CON", "a.stl", GOOD, 'class = "middle"')], "", "parts/CON.usdc, a device name"),
    ([("lpt1", "a.stl", GOOD, 'class = "middle"')], "", "a device name Windows does not"),
    # the raw file keys of NFD é ("e" and the accent's two bytes) and "e__" are one
    ([("e\u0301", "a.stl", GOOD, 'class = "middle"'), ("e__", "b.stl", GOOD,
                                                        'class = "middle"')],
     "", "differ only in case or in characters other than letters"),
    ([("A", "a.stl", GOOD, 'class = "middle"\nstyle = "s\\u001b[2J"')], "",
     'style "s\\u001b[2J" holds a character that prints as no letter (U+001B'),

    ([("x" * 201, "a.stl", GOOD, 'class = "middle"')], "", "an id is at most 200 characters"),
    # 120 characters, 240 bytes: its files' names went past the file system's 255
    ([("é" * 120, "a.stl", GOOD, 'class = "middle"')], "", "counted in UTF-8 bytes"),
    ([("A", "a.stl", GOOD, 'class = "middle"\nattributes = {doors = 1e300}')], "",
     "attribute doors must be a number from 0 to 10,000"),
    ([("A", "a.stl", GOOD, 'class = "window"')], "", 'unknown class "window"'),
    ([("A", "/etc/passwd", None, 'class = "middle"')], "",
     'file "/etc/passwd" must be a path relative to the library folder'),
    ([("A", "../other/a.stl", None, 'class = "middle"')], "",
     'file "../other/a.stl" climbs out of the library folder'),
    ([("A", "a.stl", GOOD, 'class = "corner"')], "", "a corner needs an angle"),
    ([("A", "a.stl", GOOD, 'class = "middle"')], 'units = "furlong"', 'units "furlong"'),
    # past what a database may hold (it was written, then every reader refused it,
    # telling the user to ingest again): now refused as measured
    ([("A", "a.stl", _box(0, 3, 0, 10, 0, 100_000), 'class = "middle"')], "",
     "100000 m across along Z, implausible for a building part (expected 0.2-1000 m)"),
    # a modelling tool's stray vertex 1e30 m up: trimesh's sections failed (a traceback)
    ([("A", "a.obj", b"v 0 0 0\nv 3 0 0\nv 3 10 0\nv 0 10 0\nv 0 0 6\nv 3 0 6\n"
      b"v 3 10 6\nv 0 10 6\nv 1 1 1e30\nf 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\n"
      b"f 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n"
      b"f 5 6 9\n", 'class = "middle"')], "", "(a stray vertex far from the rest?)"),
    # a micrometre box was "not closed" (its sections were empty)
    ([("A", "a.stl", _box(0, 1e-6, 0, 1e-6, 0, 1e-6), 'class = "middle"')], "",
     "1e-06 m across along X, implausible for a building part"),
    ([("A", "a.stl", _box(0, 1e-6, 0, 10, 0, 6), 'class = "middle"')], "",
     "1e-06 m along its primary axis is implausible (expected 0.2-150 m)"),
])
def test_bad_input_is_one_message_exit_2_nothing_written(tmp_path, capsys, parts, extra_lib,
                                                         fragment):
    lib = _library(tmp_path, parts, library=extra_lib)
    out = tmp_path / "db"
    with pytest.raises(LibraryError) as exc:
        ingest(lib, out)
    msg = str(exc.value)
    assert fragment in msg
    if not any(w in fragment for w in ("duplicate", "units", "differ", "printable", "UTF-8")):
        assert f'"{parts[-1][0]}"' in msg     # the part it is about, by its id
    assert main(["ingest", str(lib), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (out / DB_JSON).exists() and not (out / DB_NPZ).exists()


def test_a_library_name_with_a_control_character_is_refused(tmp_path):
    """A library's name is printed by ingest's summary: an escape sequence in it
    cleared the terminal."""
    lib = _library(tmp_path, [("A", "a.stl", GOOD, 'class = "middle"')])
    text = (lib / "manifest.toml").read_text().replace('name = "test"', 'name = "x\\u001b[2J"')
    (lib / "manifest.toml").write_text(text)
    with pytest.raises(LibraryError, match=r'\[library\] name "x\\u001b\[2J" holds a '
                       r'character that prints as no letter \(U\+001B'):
        ingest(lib, tmp_path / "db")


def test_ingest_cli_summary(tmp_path, capsys):
    lib = _library(tmp_path, [("A", "a.stl", GOOD, 'class = "middle"\nstyle = "s"'),
                              ("B", "b.stl", _box(0, 4.1, 0, 10, 0, 7), 'class = "middle"')])
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 0
    out = capsys.readouterr().out
    assert "2 parts" in out and "middle" in out and "transition costs" in out
    assert "B: snapped by 0.100 m" in out
    meta = json.loads((tmp_path / "db" / DB_JSON).read_text())
    assert [p["legs"] for p in meta["parts"]] == [[3.0], [4.0]]
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 0
    assert "cache hit" in capsys.readouterr().out


def test_corner_keys_on_another_class_are_warned_of(tmp_path, capsys):
    """``angle``/``convex`` on a part that is not a corner (a corner labelled middle,
    most likely) are not silently dropped: the ingest summary says they were ignored
    and how to make the part a corner."""
    lib = _library(tmp_path, [("A", "a.stl", GOOD, 'class = "middle"\nangle = 90.0\n'
                               'convex = true'),
                              ("B", "b.stl", GOOD, 'class = "middle"')])
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 0
    out = capsys.readouterr().out
    assert 'A: angle and convex ignored: only corners have them, and its class is ' \
        'middle (set class = "corner" if it is a corner)' in out
    assert "B:" not in out


def test_a_corner_whose_mesh_contradicts_its_angle_is_warned_of(tmp_path, capsys):
    """A corner's outgoing leg is measured along the direction its ``angle`` and
    ``convex`` give: an L-shaped 90-degree corner labelled 120 was taken without a
    word (its leg measured askew, the corner placed turned). Now ingest warns, naming
    the direction its walls run; the same mesh labelled 90 (and every corner of the
    sample library) passes quietly."""
    from shapely.geometry import Polygon

    ell = trimesh.creation.extrude_polygon(   # in-leg along -X, out-leg along +Y
        Polygon([(-6, 0), (0, 0), (0, 6), (-2, 6), (-2, 2), (-6, 2)]), 7.0)
    for angle, warned in ((120, True), (90, False)):
        (tmp_path / str(angle)).mkdir()
        lib = _library(tmp_path / str(angle), [
            ("C", "c.stl", ell, f'class = "corner"\nangle = {angle}\nconvex = true'),
            ("M", "m.stl", GOOD, 'class = "middle"')])
        assert main(["ingest", str(lib), "-o", str(tmp_path / str(angle) / "db")]) == 0
        out = capsys.readouterr().out
        assert ("C: its outgoing leg's walls run mostly at 90° to its incoming leg's, "
                "where angle = 120, convex = true puts that leg at 60°" in out) == warned, out
    db = ingest(ROOT / "examples" / "library", tmp_path / "sample_db")
    assert not [w for w in db.warnings if "outgoing leg" in w]


def test_sample_library_files_match_the_generator(tmp_path):
    from citysynth.parts_db.sample import generate
    generate(tmp_path)
    for f in sorted(tmp_path.rglob("*")):
        if f.is_file():
            rel = f.relative_to(tmp_path)
            assert (SAMPLE / rel).read_bytes() == f.read_bytes(), rel


def test_parallel_measurement_matches_serial_and_reports_bad_parts(tmp_path, monkeypatch):
    import citysynth.parts_db.library as library
    parts = [(f"P{i}", f"p{i}.stl", _box(0, 3 + 0.2 * i, 0, 10, 0, 6 + i), 'class = "middle"')
             for i in range(6)]
    lib = _library(tmp_path, parts)
    serial = ingest(lib, tmp_path / "serial")
    monkeypatch.setattr(library, "PARTS_PER_WORKER", 1)  # a real process pool
    parallel = ingest(lib, tmp_path / "parallel", force=True)
    assert [p.legs for p in parallel.parts] == [p.legs for p in serial.parts]
    assert np.array_equal(parallel.cost, serial.cost)
    (lib / "p3.stl").write_bytes(b"")
    with pytest.raises(LibraryError, match='"P3"'):
        ingest(lib, tmp_path / "broken", force=True)
    assert not (tmp_path / "broken" / DB_JSON).exists()


def test_parallel_cost_table_matches_serial(monkeypatch):
    import citysynth.parts_db.costs as costs
    rng = np.random.default_rng(3)
    secs = [shapely.box(0, 0, float(w), float(h)) for w, h in rng.uniform(1, 5, (30, 2))]
    allowed = np.ones((30, 30), dtype=bool)
    serial = costs.cost_matrix(secs, secs[::-1], allowed)
    monkeypatch.setattr(costs, "PAIRS_PER_WORKER", 100)  # a real process pool
    assert np.array_equal(costs.cost_matrix(secs, secs[::-1], allowed), serial)


def test_a_mesh_damaged_after_ingest_is_told_when_it_is_exported(tmp_path):
    """Export reads part meshes again (their colours); one cut short since the library
    was ingested is told in the GLB's terms, as ingest tells it, with the fix."""
    from citysynth.parts_db.geometry import part_pieces

    lib = _library(tmp_path, [("A", "a.glb", GLB, 'class = "middle"')])
    db = ingest(lib, tmp_path / "db")
    (lib / "a.glb").write_bytes(GLB[:len(GLB) // 2])
    with pytest.raises(LibraryError) as exc:
        part_pieces(db, db.part("A"))
    msg = str(exc.value)
    assert f"the file is cut short: its header gives {len(GLB):,} bytes" in msg
    assert msg.endswith("it changed since the library was ingested; ingest the library again")


def test_a_manifest_link_that_loops_is_not_called_missing(tmp_path, capsys):
    """A manifest.toml that is a symbolic link to itself was reported "missing"."""
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "manifest.toml").symlink_to(lib / "manifest.toml")
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert "symbolic links" in err and "missing" not in err, err


def test_a_part_off_its_canonical_frame_is_warned_of(tmp_path, capsys):
    """A part exported at its world position (100 km out) or below the ground was
    measured as any other: its building stood 100 km behind the street, or buried,
    with no word. Ingest warns, naming the part and how far."""
    lib = _library(tmp_path, [("far", "a.stl", _box(0, 3, 1e5, 1e5 + 10, 0, 6),
                               'class = "middle"'),
                              ("deep", "b.stl", _box(0, 3, 0, 10, -50, -44),
                               'class = "middle"'),
                              ("ok", "c.stl", GOOD, 'class = "middle"')])
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 0
    out = capsys.readouterr().out
    assert "far: it lies 100000 m behind the facade plane y = 0 (the skeleton line)" in out
    assert "deep: its lowest point is at z = -50 m, not on the ground z = 0" in out
    assert "ok:" not in out


@pytest.mark.parametrize("manifest, said", [
    ('[library]\nname = "t"\n[part]\nid = "A"\nfile = "a.stl"\nclass = "middle"\n',
     "[part] is one table; write each part as a [[part]] table (two brackets)"),
    ('part = 3\n[library]\nname = "t"\n',
     "no parts (part = 3 is no table); add [[part]] tables"),
    ('[library]\nname = "t"\n', "no parts; add [[part]] tables"),
])
def test_a_manifest_without_part_tables_says_what_it_has(tmp_path, capsys, manifest, said):
    """``[part]`` (one table, one bracket) and ``part = 3`` were both told "no parts;
    add [[part]] tables", which the first already looks like it has."""
    lib = tmp_path / "lib"
    lib.mkdir()
    GOOD.export(lib / "a.stl")
    (lib / "manifest.toml").write_text(manifest)
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert said in err and len(err.strip().splitlines()) == 1, err


def test_parts_far_out_in_32_bit_floats_or_inside_out_are_warned_of(tmp_path):
    """A 5.1 m GLB box 20,000 km along X measured 6.0 m (its float32 coordinates step
    by 2 m there), and a box whose faces all point inwards was exported inside out
    (every building of a street of it had a volume of -720 m³), both without a word.
    Both are warned of; the same parts at home, faces out, are not (nor is an OBJ far
    out: its text keeps every digit)."""
    far = _box(2e7, 2e7 + 5.2, 0, 10, 0, 15)
    inverted = _box(0, 6, 0, 10, 0, 12)
    inverted.invert()
    lib = _library(tmp_path, [
        ("far", "far.glb", far, 'class = "building"'),
        ("near", "near.glb", _box(0, 5.2, 0, 10, 0, 15), 'class = "building"'),
        ("far_obj", "far.obj", _box(1e6, 1e6 + 5.2, 0, 10, 0, 15), 'class = "building"'),
        ("inv", "inv.stl", inverted, 'class = "building"')])
    db = ingest(lib, tmp_path / "db")
    said = {w.split(":", 1)[0]: w for w in db.warnings if "snapped" not in w}
    assert "32-bit coordinates step by 2,000 mm" in said["far"], db.warnings
    assert "its faces point inwards (a closed mesh of negative volume)" in said["inv"]
    assert "near" not in said and "far_obj" not in said, db.warnings
    assert db.part("far_obj").legs_measured[0] == pytest.approx(5.2, abs=1e-6)


def test_editing_only_a_gltf_buffer_or_an_obj_material_measures_the_part_again(tmp_path):
    """The library's hash covered only the files the manifest names: a .gltf's
    external .bin rewritten (a 5 m box made 9 m) kept the cached database ("cache
    hit", 5 m) until --force. The files a mesh reads beside itself (a .gltf's buffers
    and images, an OBJ's material libraries) are hashed with it."""
    def gltf_files(length: float) -> dict[str, bytes]:
        return trimesh.exchange.gltf.export_gltf(_box(0, length, 0, 10, 0, 15))

    lib = tmp_path / "lib"
    lib.mkdir()
    for name, data in gltf_files(5.0).items():
        (lib / name).write_bytes(data)
    (lib / "a.obj").write_text("mtllib a.mtl\nusemtl brick\n" + _box(0, 6, 0, 10, 0, 15)
                               .export(file_type="obj"))
    (lib / "a.mtl").write_text("newmtl brick\nKd 0.8 0.3 0.2\n")
    (lib / "manifest.toml").write_text(
        '[[part]]\nid = "g"\nfile = "model.gltf"\nclass = "building"\n\n'
        '[[part]]\nid = "o"\nfile = "a.obj"\nclass = "building"\n')
    first = ingest(lib, tmp_path / "db")
    assert first.part("g").legs_measured[0] == pytest.approx(5.0)
    nine = gltf_files(9.0)
    for name in (n for n in nine if n.endswith(".bin")):   # the .gltf itself kept
        (lib / name).write_bytes(nine[name])
    assert ingest(lib, tmp_path / "db").part("g").legs_measured[0] == pytest.approx(9.0)
    again = ingest(lib, tmp_path / "db").library_hash
    (lib / "a.mtl").write_text("newmtl brick\nKd 0.2 0.3 0.8\n")
    assert ingest(lib, tmp_path / "db").library_hash != again


def test_ingest_into_a_folder_holding_another_librarys_database_is_refused(tmp_path):
    """``ingest B -o X`` where X holds library A's database replaced it without a word,
    and every command reading X as A's then placed B's parts. Refused, naming A; the
    same library again (changed since) and --force replace it."""
    from citysynth.parts_db.library import load_db
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = _library(tmp_path / "a", [("A", "a.stl", GOOD, 'class = "middle"')])
    b = _library(tmp_path / "b", [("B", "b.stl", GOOD, 'class = "middle"')])
    out = tmp_path / "db"
    ingest(a, out)
    with pytest.raises(LibraryError, match=r"db: holds the part database of another library "
                       r'\("test", from .*a/lib\); a folder holds one library\'s database: '
                       r"give another output folder \(-o\), or --force to replace it"):
        ingest(b, out)
    assert [p.id for p in load_db(out).parts] == ["A"]
    _box(0, 4, 0, 10, 0, 6).export(a / "a.stl")      # its mesh edited
    ingest(a, out)                                   # its own library, changed: replaced
    assert [p.id for p in ingest(b, out, force=True).parts] == ["B"]
    assert [p.id for p in load_db(out).parts] == ["B"]


def test_ingest_reads_the_database_it_finds_once(tmp_path, monkeypatch):
    """``ingest -o X`` of the library X already holds: partdb.json is read and parsed
    once for the checks and the load (it was three times: the other-library check, the
    cache check and the load each parsed it, megabytes for a large library)."""
    lib = _library(tmp_path, [("A", "a.stl", GOOD, 'class = "middle"')])
    out = tmp_path / "db"
    ingest(lib, out)
    reads = []
    for method in ("read_bytes", "read_text"):
        real = getattr(Path, method)

        def counted(self, *args, _real=real, **kw):
            if self.name == "partdb.json":
                reads.append(self)
            return _real(self, *args, **kw)
        monkeypatch.setattr(Path, method, counted)
    db = ingest(lib, out)
    assert db.cache_hit and [p.id for p in db.parts] == ["A"]
    assert len(reads) == 1
