"""Damaged part meshes: every one is told in one line naming the part and its file, in
the user's terms (cut short, the wrong format for its extension, no faces, faces on
missing vertices, NaN coordinates, a missing material, a folder or a link loop), with
exit 2, no traceback and no database written; never trimesh's or numpy's own words.

Hostile files are made here for each format ingest reads: OBJ, ASCII and binary STL,
ASCII and binary PLY, GLB and glTF (and OFF, which is refused by its extension).
"""

from __future__ import annotations

import json
import os
import random
import struct
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import trimesh

from citysynth.parts_db.library import DB_JSON, DB_NPZ
from citysynth.pipeline.cli import main

PART = "hostile_part"
JARGON = ("reshape", "index", "filepathresolver", "traceback", "error:", "array",
          "numpy", "trimesh", "unexpected length", "list index", "keyerror", "assertion")

_BOX = trimesh.creation.box(extents=[3, 10, 6])
_BOX.apply_translation([1.5, 5, 3])
GLB = _BOX.export(file_type="glb")
STL = _BOX.export(file_type="stl")
STL_ASCII = trimesh.exchange.stl.export_stl_ascii(_BOX).encode()
PLY = _BOX.export(file_type="ply")
PLY_ASCII = trimesh.exchange.ply.export_ply(_BOX, encoding="ascii")
OBJ = _BOX.export(file_type="obj").encode()
OFF = _BOX.export(file_type="off").encode()
_GL = trimesh.exchange.gltf.export_gltf(_BOX)
GLTF, GLTF_BUFFERS = _GL["model.gltf"], {k: v for k, v in _GL.items() if k != "model.gltf"}
_NAN = np.array(_BOX.vertices)
_NAN[2, 0] = np.nan
_FACES = np.array(_BOX.faces)
_FACES[3, 1] = 99
WHOLE = {"glb": GLB, "stl": STL, "stl_ascii": STL_ASCII, "ply": PLY, "ply_ascii": PLY_ASCII,
         "obj": OBJ}
EXT = {"stl_ascii": ".stl", "ply_ascii": ".ply"}
TRI = "v 0 0 0\nv 3 0 0\nv 3 10 0\n"

Files = dict[str, bytes]
CASES: dict[str, tuple[str, Files | Callable[[Path], None], str]] = {}
"""name -> (the part's file, its files (or a function making them), a fragment)."""


def _glb_with(change: Callable[[dict], None]) -> bytes:
    """GLB with its JSON changed (lengths fixed up): a file whose glTF is inconsistent."""
    jlen = struct.unpack_from("<I", GLB, 12)[0]
    doc = json.loads(GLB[20:20 + jlen])
    change(doc)
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    rest = GLB[20 + jlen:]
    return b"glTF" + struct.pack("<III", 2, 20 + len(js) + len(rest), len(js)) + b"JSON" + \
        js + rest


def _add(name: str, file: str, files: Files | Callable[[Path], None] | bytes,
         fragment: str) -> None:
    CASES[name] = (file, {file: files} if isinstance(files, bytes) else files, fragment)


for kind, whole in WHOLE.items():
    ext = EXT.get(kind, "." + kind)
    for at in sorted({1, 7, 40, 83, 85, len(whole) // 3, len(whole) // 2, len(whole) - 5}):
        _add(f"{kind}_cut_at_{at}", "x" + ext, whole[:at], "")
    _add(f"{kind}_empty", "x" + ext, b"", "the file is empty (0 bytes)")
    _add(f"{kind}_random", "x" + ext, random.Random(kind).randbytes(3000), "")
    for other, data in WHOLE.items():
        if EXT.get(other, "." + other) != ext:
            real = EXT.get(other, "." + other)
            _add(f"{other}_named_{kind}", "x" + ext, data,
                 f"file named {ext}; rename it to x{real}")
    _add(f"off_named_{kind}", "x" + ext, OFF, f"this is an OFF file named {ext}")
    _add(f"png_named_{kind}", "x" + ext, b"\x89PNG\r\n\x1a\n" + bytes(200),
         "this is a PNG image, not")
    _add(f"folder_named_{kind}", "x" + ext, lambda d: (d / "x.obj").mkdir(),
         "this is a folder, not a mesh file")

for cut in ("_cut_at_83", "_cut_at_85"):   # the probes' "the mesh is empty"
    CASES["stl" + cut] = (*CASES["stl" + cut][:2], "the file is cut short")
CASES["stl_cut_at_611"] = ("x.stl", {"x.stl": STL[:len(STL) - 73]},
                           "the file is cut short: its header gives 12 triangles (684 bytes)")
CASES["glb_named_obj"] = (*CASES["glb_named_obj"][:2], "this is a GLB file named .obj")
for name in [n for n in CASES if n.startswith("folder_named_")]:
    ext = CASES[name][0]
    CASES[name] = (ext, lambda d, ext=ext: (d / ext).mkdir(), CASES[name][2])

_add("obj_face_past_the_end", "x.obj", (TRI + "f 1 2 99\n").encode(),
     "a face points at vertex 99, but the file has only 3 vertices")
_add("obj_face_negative", "x.obj", (TRI + "f -50 2 3\n").encode(),
     "a face points at vertex -50")
_add("obj_face_zero", "x.obj", (TRI + "f 0 1 2\n").encode(), "OBJ counts vertices from 1")
_add("obj_face_word", "x.obj", (TRI + "f 1 two 3\n").encode(), "where a vertex number")
_add("obj_coordinate_word", "x.obj", b"v 0 0 0\nv 3 x 0\nv 3 10 0\nf 1 2 3\n",
     "has 'x' where a number belongs")
_add("obj_nan", "x.obj", (TRI.replace("v 3 0 0", "v nan 0 0") + "f 1 2 3\n").encode(),
     "not finite numbers (NaN or infinity)")
_add("obj_inf", "x.obj", OBJ.replace(b"v ", b"v inf ", 1), "not finite numbers")
_add("obj_points_only", "x.obj", TRI.encode(), "the mesh has no faces, only 3 loose points")
_add("obj_plain_text", "x.obj", b"hello\nthis is not a mesh\n", "the mesh is empty")
_add("obj_binary_inside", "x.obj", OBJ[:200] + bytes(30) + OBJ[200:], "the file is not text")
_add("obj_missing_material", "x.obj", b"mtllib walls.mtl\nusemtl brick\n" + OBJ,
     "it refers to material file 'walls.mtl', which is missing next to it; copy walls.mtl")
_add("obj_missing_texture", "x.obj",
     {"x.obj": b"mtllib m.mtl\nusemtl brick\n" + OBJ,
      "m.mtl": b"newmtl brick\nmap_Kd -s 1 1 1 brick.png\n"},
     "it refers to texture file 'brick.png', which is missing")
_add("obj_material_outside", "x.obj", b"mtllib ../../secret.mtl\n" + OBJ,
     "outside the mesh's folder")
_add("ply_face_past_the_end", "x.ply", _BOX.__class__(
    _BOX.vertices, _FACES, process=False, validate=False).export(file_type="ply"),
     "1 face on vertices the file does not have (it has 8 vertices)")
_add("ply_ascii_face_past_the_end", "x.ply",
     PLY_ASCII.replace(b"\n3 1 3 0\n", b"\n3 1 3 77\n", 1), "vertices the file does not have")
_add("ply_nan", "x.ply", trimesh.Trimesh(_NAN, _BOX.faces, process=False).export(
    file_type="ply"), "the mesh has 1 vertex whose coordinates are not finite numbers")
_add("ply_points_only", "x.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
     b"property float y\nproperty float z\nend_header\n0 0 0\n3 0 0\n3 10 6\n",
     "no faces, only 3 loose points")
_add("ply_vertex_count_huge", "x.ply", PLY.replace(b"element vertex 8", b"element vertex "
                                                   b"2000000000"), "the file is cut short")
_add("ply_header_damaged", "x.ply", PLY.replace(b"element vertex 8", b"element vertex many"),
     "its PLY header is damaged at the line 'element vertex many'")
_add("ply_ascii_last_line_cut", "x.ply", PLY_ASCII.rstrip()[:-2],
     "the file is cut short")
_add("stl_count_huge", "x.stl", STL[:80] + struct.pack("<I", 2_000_000_000) + STL[84:],
     "its header gives 2,000,000,000 triangles")
_add("stl_count_small", "x.stl", STL[:80] + struct.pack("<I", 3) + STL[84:],
     "its header gives 3 triangles")
_add("stl_nan", "x.stl", trimesh.Trimesh(_NAN, _BOX.faces, process=False).export(
    file_type="stl"), "not finite numbers")
_add("stl_ascii_nan", "x.stl", STL_ASCII.replace(b"vertex 3.", b"vertex nan 0 0 #", 1), "nan")
_add("stl_ascii_no_endsolid", "x.stl", STL_ASCII[:STL_ASCII.rfind(b"endsolid")],
     "does not end with 'endsolid'")
_add("glb_face_past_the_end", "x.glb", trimesh.Trimesh(
    _BOX.vertices, _FACES, process=False, validate=False).export(file_type="glb"),
     "1 face on vertices the file does not have")
_add("glb_nan", "x.glb", trimesh.Trimesh(_NAN, _BOX.faces, process=False).export(
    file_type="glb"), "not finite numbers")
_add("glb_accessor_huge", "x.glb", _glb_with(lambda d: d["accessors"][0].update(count=10**9)),
     "its glTF data is inconsistent: accessor 0 needs")
_add("glb_view_missing", "x.glb", _glb_with(lambda d: d["accessors"][0].update(bufferView=99)),
     "accessor 0 refers to buffer view 99")
# Draco (gltfpack -cc, Blender's compression): trimesh warned five times on stderr for
# want of DracoPy, read zeros, and ingest said "no cross-section at its in-end"
_add("glb_draco", "x.glb", _glb_with(lambda d: d.update(
    extensionsUsed=["KHR_draco_mesh_compression"],
    extensionsRequired=["KHR_draco_mesh_compression"])),
     "its meshes are compressed (KHR_draco_mesh_compression), which citysynth does not read")
_add("glb_no_scenes", "x.glb", _glb_with(lambda d: d.update(scenes=[])),
     "the file's default scene refers to scene 0")
_add("glb_view_past_buffer", "x.glb",
     _glb_with(lambda d: d["bufferViews"][0].update(byteLength=10**6)),
     "past the end of its")
_add("glb_json_damaged", "x.glb", GLB[:20] + b"{{{{" + GLB[24:],
     "its glTF JSON chunk is damaged at character")
_add("glb_version_1", "x.glb", GLB[:4] + struct.pack("<I", 1) + GLB[8:],
     "its header gives glTF version 1")
_add("gltf_cut", "x.gltf", GLTF[:len(GLTF) // 2], "its JSON is damaged at character")
_add("gltf_buffer_missing", "x.gltf", GLTF,
     "it refers to buffer file 'gltf_buffer_0.bin', which is missing next to it")
_add("gltf_buffer_cut", "x.gltf", {"x.gltf": GLTF, **{k: v[:len(v) // 2] for k, v in
                                                      GLTF_BUFFERS.items()}},
     "its buffer file 'gltf_buffer_0.bin' is cut short")
_add("gltf_buffer_outside", "x.gltf", GLTF.replace(b'"gltf_buffer_0.bin"', b'"/etc/passwd"'),
     "it refers to buffer file '/etc/passwd', outside the mesh's folder")
_add("gltf_texture_missing", "x.gltf",
     {"x.gltf": json.dumps({**json.loads(GLTF), "images": [{"uri": "wall.png"}]}).encode(),
      **GLTF_BUFFERS}, "it refers to texture file 'wall.png', which is missing")
_add("gltf_not_a_list", "x.gltf", GLTF.replace(b'"nodes":[{', b'"nodes":{"a":[{', 1)
     .replace(b'}],"buffers"', b'}]},"buffers"', 1), "")
_add("gltf_binary", "x.gltf", bytes(range(256)) * 4, "the file is not text")
_add("glb_as_gltf", "x.gltf", GLB, "this is a GLB file named .gltf")
# a NaN in a node's transform made every point NaN (a traceback: "zero-size array"),
# or, beside a good node, was dropped by ingest and written into the USD and GLB
_add("glb_node_nan", "x.glb", _glb_with(lambda d: d["nodes"][0].update(
    translation=[float("nan"), 0, 0])), "is placed by a transform that is not finite")
_add("glb_second_node_nan", "x.glb", _glb_with(lambda d: (
    d["nodes"].append({**d["nodes"][0], "scale": [1, float("inf"), 1]}),
    d["scenes"][0]["nodes"].append(len(d["nodes"]) - 1))), "not finite numbers (NaN")
_add("glb_scene_empty", "x.glb", _glb_with(lambda d: d["scenes"][0].update(nodes=[])),
     "its default scene (scene 0) places none of its 1 mesh")   # was "the mesh is empty"
_add("glb_material_missing", "x.glb", _glb_with(lambda d: d["meshes"][0]["primitives"][0]
                                                 .update(material=7)),
     "mesh 0 refers to material 7")   # was "does not hold a valid GLB mesh"
_add("gltf_buffer_name_too_long", "x.gltf", GLTF.replace(b'"gltf_buffer_0.bin"',
                                                        b'"' + b"b" * 5000 + b'.bin"'),
     "a buffer file named in 5,004 characters, longer than any file name can be")
_add("named_nfd_file_nfc", "caf\u0065\u0301.glb".encode().decode(), {"caf\u00e9.glb": GLB},
     "its accented letters encoded otherwise (Unicode NFC and NFD")
_add("glb_node_scale_0", "x.glb", _glb_with(lambda d: (
    d["nodes"].append({**d["nodes"][0], "scale": [0, 1, 1], "translation": [100, 0, 0]}),
    d["scenes"][0]["nodes"].append(len(d["nodes"]) - 1))),
     "is scaled to nothing (a scale of 0 along an axis")   # was "no cross-section"
_add("gltf_buffer_nul", "x.gltf", GLTF.replace(b'"gltf_buffer_0.bin"', b'"x%00.bin"'),
     "a buffer file whose name holds a NUL character")    # (a traceback: embedded null)
_add("link_loop", "x.obj", lambda d: (d / "x.obj").symlink_to("x.obj"),
     "a symbolic link that leads back to itself (a loop)")
_add("link_cycle", "x.stl", lambda d: ((d / "x.stl").symlink_to("y.stl"),
                                       (d / "y.stl").symlink_to("x.stl")), "(a loop)")
_add("link_dangling", "x.glb", lambda d: (d / "x.glb").symlink_to("gone.glb"),
     "it is a symbolic link to 'gone.glb', which does not exist")
_add("pipe", "x.ply", lambda d: os.mkfifo(d / "x.ply"), "not a regular file")
_add("missing", "x.obj", {}, "mesh file not found")


def _make(lib: Path, file: str, files: Files | Callable[[Path], None]) -> None:
    lib.mkdir()
    (lib / "manifest.toml").write_text(f'[library]\nname = "t"\n\n[[part]]\nid = "{PART}"\n'
                                       f'file = "{file}"\nclass = "middle"\n')
    if callable(files):
        files(lib)
        return
    for name, data in files.items():
        (lib / name).write_bytes(data)


@pytest.mark.parametrize("name", sorted(CASES))
def test_damaged_mesh_is_one_line_naming_part_and_file(name, tmp_path, capsys):
    file, files, fragment = CASES[name]
    lib, out = tmp_path / "lib", tmp_path / "db"
    _make(lib, file, files)
    capsys.readouterr()
    assert main(["ingest", str(lib), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert f'part "{PART}"' in err and str(lib / file) in err, err
    told = err.replace(str(lib / file), "").lower()
    assert not [w for w in JARGON if w in told.split("error: ", 1)[1]], err
    assert fragment in err, err
    assert ";" in told.split("): ", 1)[1], err   # what is wrong; how to fix it
    assert not (out / DB_JSON).exists() and not (out / DB_NPZ).exists()


def test_every_format_is_read_whole(tmp_path):
    """The undamaged files the hostile ones are cut from ingest (so the cases above
    fail for their damage, not for a fault of the originals)."""
    parts = [(k, f"{k}{EXT.get(k, '.' + k)}", d) for k, d in WHOLE.items()]
    lib = tmp_path / "lib"
    lib.mkdir()
    toml = ['[library]\nname = "t"']
    for k, f, d in parts:
        (lib / f).write_bytes(d)
        toml.append(f'[[part]]\nid = "{k}"\nfile = "{f}"\nclass = "middle"')
    (lib / "g.gltf").write_bytes(GLTF)
    for k, v in GLTF_BUFFERS.items():
        (lib / k).write_bytes(v)
    (lib / "m.obj").write_bytes(b"mtllib m m.mtl\nusemtl a\n" + OBJ)   # a name with a space
    (lib / "m m.mtl").write_bytes(b"newmtl a\nKd 1 0 0\n")
    toml += ['[[part]]\nid = "gltf"\nfile = "g.gltf"\nclass = "middle"',
             '[[part]]\nid = "mtl"\nfile = "m.obj"\nclass = "middle"']
    (lib / "manifest.toml").write_text("\n\n".join(toml) + "\n")
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 0


def test_a_mesh_path_with_a_nul_or_a_detour_inside_the_library(tmp_path, capsys):
    """A NUL in a part's file crashed the file system call (a traceback, exit 3); it
    is refused in words. A path that steps out and back in (``meshes/../meshes/x.glb``)
    stays inside the library and is read (it was refused as climbing out of it)."""
    lib = tmp_path / "lib"
    _make(lib, "x.glb", {"x.glb": GLB})
    manifest = lib / "manifest.toml"
    manifest.write_text(manifest.read_text().replace('file = "x.glb"', 'file = "x\\u0000.glb"'))
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 2
    err = capsys.readouterr().err
    assert 'file "x\\u0000.glb" holds a character no file name holds (a NUL' in err, err
    (lib / "m").mkdir()
    (lib / "m" / "x.glb").write_bytes(GLB)
    manifest.write_text(manifest.read_text().replace('file = "x\\u0000.glb"',
                                                     'file = "m/../m/x.glb"'))
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 0
    manifest.write_text(manifest.read_text().replace('"m/../m/x.glb"', '"m/../../x.glb"'))
    assert main(["ingest", str(lib), "-o", str(tmp_path / "db2")]) == 2
    assert "climbs out of the library folder" in capsys.readouterr().err


def test_a_gltf_of_many_nodes_checks_each_list_once():
    """The glTF pre-check asked for the node list at every reference and checked all of
    it each time: 16,000 nodes took 25 s, 150,000 over 10 minutes. Each list is checked
    once."""
    from citysynth.parts_db.mesh_faults import _Gltf

    class Counted(list):
        walks = 0

        def __iter__(self):
            Counted.walks += 1
            return super().__iter__()

    nodes = Counted({"mesh": 0} for _ in range(1000))
    g = _Gltf({"nodes": nodes, "meshes": [{}]})
    for i in range(1000):
        g.ref(i, "nodes", "scene 0")
    assert Counted.walks == 1


def test_a_large_texture_prints_no_pil_warning(tmp_path, capsys, monkeypatch):
    """A 12,000 x 12,000 texture in a part's GLB printed PIL's DecompressionBombWarning,
    with its source path, on stderr of ingest and of every command exporting the part
    (here the limit is lowered below a 64 x 64 texture). Textures are not what a part
    is measured by; the warning is no concern of the user's."""
    import warnings

    from PIL import Image
    box = trimesh.creation.box(extents=(4, 10, 6))
    box.apply_translation((2, 5, 3))
    box.visual = trimesh.visual.TextureVisuals(
        uv=np.random.default_rng(0).random((len(box.vertices), 2)),
        image=Image.new("RGB", (64, 64), (200, 100, 50)))
    lib = tmp_path / "lib"
    lib.mkdir()
    box.export(lib / "a.glb")
    (lib / "manifest.toml").write_text('[[part]]\nid = "a"\nfile = "a.glb"\n'
                                       'class = "building"\n')
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 3000)     # 4,096 pixels: a warning
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        assert main(["ingest", str(lib), "-o", str(tmp_path / "db")]) == 0
    assert not [w for w in said if issubclass(w.category, Image.DecompressionBombWarning)]
    assert "DecompressionBomb" not in capsys.readouterr().err
