"""What is wrong with a damaged mesh file, told in the user's terms.

trimesh reads what it can and raises whatever its parser met (an ``IndexError``,
"cannot reshape array", advice about its ``FilePathResolver``), or quietly returns an
empty mesh for a file it could not parse at all: a cut-short STL and a GLB named
``.obj`` both came out "empty". So a file is looked at before trimesh reads it (is it a
file, is it the format its extension says, is it whole, are the files it refers to
there) and what trimesh made of it is checked after (faces, vertices, coordinates).
Every finding is a :class:`MeshFault`: what is wrong, and the fix where one is specific.
"""

from __future__ import annotations

import errno
import json
import os
import re
import stat
import struct
import unicodedata
from pathlib import Path, PurePosixPath
from urllib.parse import unquote

import numpy as np
import trimesh

NAMES = {".glb": "GLB", ".gltf": "glTF", ".obj": "OBJ", ".ply": "PLY", ".stl": "STL"}
SUFFIX = {name: ext for ext, name in NAMES.items()}
_MAGIC = ((b"glTF", "GLB"), (b"ply\n", "PLY"), (b"ply\r\n", "PLY"),
          (b"PK\x03\x04", "ZIP archive"), (b"\x1f\x8b", "gzip archive"),
          (b"\x89PNG", "PNG image"), (b"\xff\xd8\xff", "JPEG image"), (b"%PDF", "PDF"),
          (b"Kaydara FBX", "FBX file"), (b"BLENDER", "Blender file"),
          (b"PXR-USDC", "USD file"), (b"#usda", "USD file"), (b"7z\xbc\xaf", "7-Zip archive"))
_OBJ_LINE = re.compile(rb"^[ \t]*(v|vt|vn|f|o|g|mtllib|usemtl)[ \t]", re.MULTILINE)
_GLTF_SIZES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_GLTF_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_GLTF_PART = {"buffers": "buffer", "bufferViews": "buffer view", "accessors": "accessor",
              "meshes": "mesh", "nodes": "node", "scenes": "scene", "materials": "material"}
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2,
              "int16": 2, "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4,
              "float": 4, "float32": 4, "double": 8, "float64": 8}
_MTLLIB = re.compile(r"^[ \t]*mtllib[ \t]+(.+?)[ \t]*$", re.MULTILINE)   # an OBJ's materials
_ZERO_FACE = re.compile(rb"^[ \t]*f[ \t](?:[^\n]*[ \t])?0(?:/|[ \t\r]|$)", re.MULTILINE)
_RELINK = "point the link at the mesh file, or name the mesh file itself in the manifest"


MAX_TRIANGLES = 2_000_000   # a part's; measuring takes about 350 bytes a triangle
BYTES_PER_TRIANGLE = 350
MAX_FILE_BYTES = 2**30      # a part's mesh file: 2,000,000 triangles take far less in
                            # any format; the file is read whole, so a larger one is
                            # refused unread (8 GB of zeros was a MemoryError traceback)


def too_many_triangles(n: int) -> str:
    """Why a part of ``n`` triangles (past :data:`MAX_TRIANGLES`) is refused."""
    return (f"{n:,} triangles, past the {MAX_TRIANGLES:,} a part may have (measuring it "
            f"would take about {n * BYTES_PER_TRIANGLE / 2**30:.1f} GB)")


DECIMATE = "decimate it in its modelling tool"


class MeshFault(Exception):
    """Why a mesh file cannot be used, and the fix when one is specific to the fault
    (else the caller's: export again, or ingest again)."""

    def __init__(self, why: str, fix: str | None = None) -> None:
        super().__init__(why)
        self.why, self.fix = why, fix


def read_file(path: Path) -> bytes:
    """The file's bytes, or a MeshFault for a path that is no readable mesh file: a
    symlink loop or dangling link, a folder named like a mesh, a pipe (reading one
    would hang), an empty or unreadable file."""
    try:
        st = path.stat()
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise MeshFault("the path is a symbolic link that leads back to itself (a loop)",
                            _RELINK) from None
        if path.is_symlink():
            raise MeshFault(f"it is a symbolic link to {os.readlink(path)!r}, which does "
                            "not exist", _RELINK) from None
        if exc.errno in (errno.ENOENT, errno.ENOTDIR):
            raise MeshFault("mesh file not found", _near_miss(path) or (
                "check its file in the manifest (a path relative to the library "
                "folder)")) from None
        raise MeshFault(f"the file cannot be opened ({exc.strerror})") from None
    if stat.S_ISDIR(st.st_mode):
        raise MeshFault("this is a folder, not a mesh file",
                        "name the mesh file inside it in the manifest") from None
    if not stat.S_ISREG(st.st_mode):
        raise MeshFault("this is not a regular file (a pipe, socket or device)",
                        "name the mesh file itself in the manifest")
    if st.st_size == 0:
        raise MeshFault("the file is empty (0 bytes)")
    if st.st_size > MAX_FILE_BYTES:
        raise MeshFault(f"the file is {st.st_size / 2**30:,.1f} GB, more than the "
                        f"{MAX_FILE_BYTES / 2**30:.0f} GB a part's mesh may be (a part has at "
                        f"most {MAX_TRIANGLES:,} triangles, far less in any format)", DECIMATE)
    try:
        return path.read_bytes()
    except PermissionError:
        raise MeshFault("the file cannot be read: permission denied",
                        "make it readable (chmod a+r)") from None
    except OSError as exc:
        raise MeshFault(f"the file cannot be read ({exc.strerror})") from None


def _near_miss(path: Path) -> str | None:
    """The fix for a mesh path that is almost right: written with Windows' backslashes
    (a backslash is part of a file name on Linux and macOS), or in another case than
    the file's (file names differ in case here): said, where "not found" sent the user
    looking for a file that is there."""
    if "\\" in str(path):
        return ("write its path in the manifest with / between folders, not \\ (a "
                "backslash is part of a file name here)")
    try:
        names = [p.name for p in path.parent.iterdir()]
    except OSError:
        return None
    same = [n for n in names if n.lower() == path.name.lower()]
    if same:
        return (f"the folder has {same[0]!r}: file names differ in case here; write it so "
                "in the manifest")
    nfc = unicodedata.normalize("NFC", path.name)
    if any(unicodedata.normalize("NFC", n) == nfc for n in names):   # looks the same
        return ("the folder has a file of this name with its accented letters encoded "
                "otherwise (Unicode NFC and NFD, which look alike); copy the file's name "
                "from the folder into the manifest")
    return None


def sniff(data: bytes) -> str | None:
    """What the bytes look like ("GLB", "OBJ", "PNG image" ...), from their first bytes
    and not the file's name; "text" for text of no known format, None if unknown."""
    for magic, kind in _MAGIC:
        if data.startswith(magic):
            return kind
    if len(data) >= 84 and 84 + 50 * struct.unpack_from("<I", data, 80)[0] == len(data):
        return "STL"    # a binary STL has no magic, only a size its header predicts
    text = _text(data[:65536])
    if text is None:
        return None
    head = text.lstrip()
    words = head.split(None, 1)
    first = words[0] if words else ""
    if head.startswith("{"):
        return "glTF" if '"asset"' in head or '"meshes"' in head else "JSON file"
    if first in ("OFF", "COFF", "NOFF", "STOFF", "4OFF"):
        return "OFF"
    if first == "solid" and ("facet" in head or "endsolid" in head):
        return "STL"
    if head.startswith("<"):
        return "COLLADA (.dae) file" if "COLLADA" in head else "XML file"
    if _OBJ_LINE.search(text.encode()):
        return "OBJ"
    return "text"


def _text(head: bytes) -> str | None:
    """``head`` as text if it reads as text (no NUL bytes, few undecodable bytes)."""
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return head.decode("utf-16", errors="replace")
    if b"\0" in head:
        return None
    text = head.decode("utf-8", errors="replace")
    odd = sum(1 for c in text if c == "\ufffd" or (ord(c) < 32 and c not in "\t\r\n\f"))
    return text if odd <= len(text) // 100 else None


def check_content(path: Path, data: bytes) -> None:
    """A MeshFault if the bytes are not the format the extension says, are cut short,
    or refer to files (buffers, materials, textures) that are missing."""
    ext = path.suffix.lower()
    name = NAMES[ext]
    kind = sniff(data)
    if kind in SUFFIX and kind != name:
        new = path.with_suffix(SUFFIX[kind]).name
        raise MeshFault(f"this is {_a(kind)} file named {ext}",
                        f"rename it to {new} (and its file in the manifest)")
    if kind == "OFF":
        raise MeshFault(f"this is an OFF file named {ext}", "convert it to one of "
                        f"{', '.join(sorted(NAMES))} (e.g. with Blender or MeshLab)")
    if kind not in (None, "text", name, "JSON file"):
        raise MeshFault(f"this is {_a(kind)}, not {_a(name)} mesh",
                        "name the part's mesh file in the manifest")
    {".glb": _check_glb, ".gltf": _check_gltf, ".obj": _check_obj, ".ply": _check_ply,
     ".stl": _check_stl}[ext](path, data, kind)


def _check_glb(path: Path, data: bytes, kind: str | None) -> None:
    """A GLB's header, chunks and glTF JSON (trimesh reads on past a short GLB into its
    JSON and reports that instead)."""
    size = len(data)
    if size < 12 or data[:4] != b"glTF":
        raise MeshFault("the file has no glTF header (it is not a GLB, or is cut short "
                        "within its first 12 bytes)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise MeshFault(f"its header gives glTF version {version}; only glTF 2 is read")
    if length > size:
        raise MeshFault(f"the file is cut short: its header gives {length:,} bytes, the "
                        f"file has {size:,}")
    if size < 20:
        raise MeshFault("the file is cut short: it ends after its header, before its "
                        "glTF JSON")
    jlen, jtype = struct.unpack_from("<I4s", data, 12)
    if jtype != b"JSON" or 20 + jlen > size:
        raise MeshFault("its glTF JSON chunk is damaged (its length or type is wrong)")
    doc = _json(data[20:20 + jlen], "its glTF JSON chunk")
    rest = data[20 + jlen + (-jlen % 4):]
    binary = None
    if len(rest) >= 8:
        blen, btype = struct.unpack_from("<I4s", rest)
        binary = min(blen, len(rest) - 8) if btype == b"BIN\0" else None
    _check_gltf_doc(doc, binary, path.parent)


def _check_gltf(path: Path, data: bytes, kind: str | None) -> None:
    """A .gltf's JSON (trimesh takes damaged JSON for a missing file) and what it
    refers to."""
    if kind is None:
        raise MeshFault("the file is not text, so it is not a glTF (.gltf is JSON)")
    _check_gltf_doc(_json(data, "its JSON"), None, path.parent)


def _json(raw: bytes, what: str) -> dict:
    try:
        doc = json.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError as exc:
        raise MeshFault(f"{what} is damaged: byte {exc.start} is not text") from None
    except json.JSONDecodeError as exc:
        raise MeshFault(f"{what} is damaged at character {exc.pos} ({exc.msg})") from None
    except RecursionError:
        raise MeshFault(f"{what} is nested too deeply to be glTF") from None
    if not isinstance(doc, dict):
        raise MeshFault(f"{what} is not a glTF object (it holds a {type(doc).__name__})")
    return doc


_PACKED_GEOMETRY = {"KHR_draco_mesh_compression", "EXT_meshopt_compression",
                    "KHR_meshopt_compression"}   # extensions whose vertex data trimesh
                                                 # cannot decode without more packages


def _check_gltf_doc(doc: dict, binary: int | None, folder: Path) -> None:
    """Buffers exist and are as long as declared, and every reference between buffers,
    views, accessors, meshes, nodes and scenes lands on something that exists and fits
    (else trimesh fails with "cannot reshape array" or a bare IndexError)."""
    g = _Gltf(doc)
    # compressed meshes the file cannot be read without (merely "used", the file keeps
    # plain data to fall back on): trimesh warned on stderr and read zeros, which
    # ingest then called a mesh that is not closed
    required = doc.get("extensionsRequired", [])
    packed = sorted({e for e in required if e in _PACKED_GEOMETRY}) \
        if isinstance(required, list) else []
    if packed:
        raise MeshFault(f"its meshes are compressed ({', '.join(packed)}), which citysynth "
                        "does not read (Blender: glTF export with Data > Compression off; "
                        "gltfpack without -c)")
    have = [g.buffer(i, buf, binary, folder) for i, buf in enumerate(g.items("buffers"))]
    for img in g.items("images"):
        uri = img.get("uri")
        if isinstance(uri, str) and not uri.startswith("data:"):
            _resource(folder, uri, "texture")
    views = g.items("bufferViews")
    for i, view in enumerate(views):
        b = g.ref(view.get("buffer"), "buffers", f"buffer view {i}")
        end = g.number(view, "byteOffset", f"buffer view {i}") + \
            g.number(view, "byteLength", f"buffer view {i}")
        if end > have[b]:
            raise MeshFault(f"its glTF data is inconsistent: buffer view {i} ends at byte "
                            f"{end:,}, past the end of its {have[b]:,}-byte buffer")
    for i, acc in enumerate(g.items("accessors")):
        if "bufferView" in acc:
            g.accessor(i, acc)
    for i, mesh in enumerate(g.items("meshes")):
        g.mesh(i, mesh)
    for i, node in enumerate(g.items("nodes")):
        if "mesh" in node:
            g.ref(node["mesh"], "meshes", f"node {i}")
        g.refs(node.get("children", []), "nodes", f"node {i}")
    for i, scene in enumerate(g.items("scenes")):
        g.refs(scene.get("nodes", []), "nodes", f"scene {i}")
    if "scene" in doc or "scenes" in doc:    # without "scene", the first is shown
        shown_scene = g.ref(doc.get("scene", 0), "scenes", "the file's default scene")
        meshes = len(g.items("meshes"))
        if meshes and not _places_a_mesh(g, g.items("scenes")[shown_scene].get("nodes", [])):
            # trimesh read nothing, and ingest said "the file holds no vertices or faces"
            raise MeshFault(f"its default scene (scene {shown_scene}) places none of its "
                            f"{_many(meshes, 'mesh')}: the modelling tool exported an empty "
                            "scene", "export it again with the part's objects in the "
                            "scene (not only the selected objects of another)")


def _places_a_mesh(g: _Gltf, roots: object) -> bool:
    """Whether the nodes ``roots`` (a scene's) or their descendants place a mesh."""
    nodes = g.items("nodes")
    todo = list(roots) if isinstance(roots, list) else []
    seen: set[int] = set()
    while todo:
        i = todo.pop()
        if not isinstance(i, int) or i in seen or not 0 <= i < len(nodes):
            continue
        seen.add(i)
        if "mesh" in nodes[i]:
            return True
        children = nodes[i].get("children", [])
        todo += children if isinstance(children, list) else []
    return False


class _Gltf:
    """A glTF document's parts, each read defensively (a damaged file may hold any JSON
    where a list, object or count belongs)."""

    def __init__(self, doc: dict) -> None:
        self.doc = doc
        self._checked: dict[str, list[dict]] = {}

    def items(self, key: str) -> list[dict]:
        """The list ``key`` holds, checked once (each reference asks for its list: checked
        again each time, a file of 16,000 nodes took 25 s, 150,000 over 10 minutes)."""
        got = self._checked.get(key)
        if got is not None:
            return got
        got = self.doc.get(key, [])
        if not isinstance(got, list) or not all(isinstance(g, dict) for g in got):
            raise MeshFault(f"its glTF {key!r} is not a list of objects: the file is damaged")
        self._checked[key] = got
        return got

    def ref(self, value: object, key: str, what: str) -> int:
        n = len(self.items(key))
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value < n:
            raise MeshFault(f"its glTF data is inconsistent: {what} refers to "
                            f"{_GLTF_PART[key]} {value!r}, and the file has "
                            f"{_many(n, _GLTF_PART[key])}")
        return value

    def refs(self, values: object, key: str, what: str) -> None:
        for v in values if isinstance(values, list) else [values]:
            self.ref(v, key, what)

    @staticmethod
    def number(d: dict, key: str, what: str, default: int = 0) -> int:
        v = d.get(key, default)
        if not isinstance(v, int) or isinstance(v, bool) or v < 0:
            raise MeshFault(f"its glTF data is damaged: {what} has {key} {v!r}")
        return v

    def buffer(self, i: int, buf: dict, binary: int | None, folder: Path) -> int:
        """The declared length of buffer ``i``, once its data is known to hold it."""
        uri = buf.get("uri")
        need = self.number(buf, "byteLength", f"buffer {i}")
        if uri is None and binary is None:
            raise MeshFault(f"its glTF buffer {i} has no data (no file and no binary chunk)")
        if uri is None:
            size = binary or 0
        elif isinstance(uri, str) and uri.startswith("data:"):
            size = need
        else:
            size = _resource(folder, uri, "buffer").stat().st_size
        if size < need:
            what = f"its buffer file {uri!r}" if uri else "its binary chunk"
            raise MeshFault(f"{what} is cut short: the glTF gives {need:,} bytes, it "
                            f"has {size:,}")
        return need

    def mesh(self, i: int, mesh: dict) -> None:
        """Mesh ``i``'s primitives read accessors that exist."""
        prims = mesh.get("primitives", [])
        if not isinstance(prims, list) or not all(isinstance(p, dict) for p in prims):
            raise MeshFault(f"its glTF mesh {i} is damaged (its primitives are not a list)")
        for p in prims:
            attrs = p.get("attributes", {})
            if not isinstance(attrs, dict):
                raise MeshFault(f"its glTF mesh {i} is damaged (attributes not an object)")
            self.refs([*attrs.values(), *([p["indices"]] if "indices" in p else [])],
                      "accessors", f"mesh {i}")
            if "material" in p:   # trimesh failed on it: "does not hold a valid GLB mesh"
                self.ref(p["material"], "materials", f"mesh {i}")

    def accessor(self, i: int, acc: dict) -> None:
        """Accessor ``i``'s values fit inside its buffer view."""
        v = self.ref(acc["bufferView"], "bufferViews", f"accessor {i}")
        view = self.items("bufferViews")[v]
        width = _GLTF_WIDTH.get(str(acc.get("type")))
        step = _GLTF_SIZES.get(acc.get("componentType"))  # type: ignore[arg-type]
        if width is None or step is None:
            raise MeshFault(f"its glTF data is damaged: accessor {i} has an unknown type")
        count = self.number(acc, "count", f"accessor {i}")
        stride = self.number(view, "byteStride", f"buffer view {v}") or width * step
        end = self.number(acc, "byteOffset", f"accessor {i}") + \
            (max(count - 1, 0) * stride + width * step if count else 0)
        held = self.number(view, "byteLength", f"buffer view {v}")
        if end > held:
            raise MeshFault(f"its glTF data is inconsistent: accessor {i} needs {end:,} "
                            f"bytes of its buffer view, which holds {held:,}")


def _resource(folder: Path, uri: object, what: str) -> Path:
    """The file a mesh refers to (a glTF buffer or texture, an OBJ material or
    texture): it must lie in the mesh's folder tree and exist."""
    if not isinstance(uri, str) or not uri.strip():
        raise MeshFault(f"it refers to a {what} file with no name: the file is damaged")
    name = unquote(uri.strip())
    if "\0" in name:   # (%00): the file system call raised a traceback
        raise MeshFault(f"it refers to a {what} file whose name holds a NUL character "
                        f"({json.dumps(uri)[:80]}): the file is damaged")
    if any(len(part.encode("utf-8")) > 255 for part in PurePosixPath(name).parts):
        raise MeshFault(f"it refers to a {what} file named in {len(name):,} characters, "
                        "longer than any file name can be: the file is damaged")
    target = (folder / name).resolve()
    if PurePosixPath(name).is_absolute() or re.match(r"^[A-Za-z]:[\\/]", name) or \
            not target.is_relative_to(folder.resolve()):
        raise MeshFault(f"it refers to {what} file {name!r}, outside the mesh's folder",
                        "copy that file next to the mesh and refer to it by its name")
    if not target.is_file():
        raise MeshFault(f"it refers to {what} file {name!r}, which is missing next to it",
                        f"copy {PurePosixPath(name).name} into {folder}, or export the "
                        "mesh again with its files (a .glb holds them all)")
    return target


def _check_obj(path: Path, data: bytes, kind: str | None) -> None:
    """An OBJ is text; its materials and their textures exist; its last line is whole."""
    if kind is None:
        raise MeshFault("the file is not text, so it is not an OBJ (OBJ is a text format)")
    text = data.decode("utf-8", errors="replace")
    for libs in _MTLLIB.findall(text):
        for lib in _names(path.parent, libs):
            mtl = _resource(path.parent, lib, "material")
            mtext = mtl.read_bytes().decode("utf-8", errors="replace")
            for tex in re.findall(r"^[ \t]*(?:map_\w+|bump|disp|decal|refl)[ \t]+(.+?)[ \t]*$",
                                  mtext, re.MULTILINE):
                _resource(mtl.parent, _names(mtl.parent, tex)[-1], "texture")
    if _ZERO_FACE.search(data):    # trimesh takes vertex 0 (OBJ counts from 1) silently
        raise _text_lines(data, ".obj") or MeshFault("a face points at vertex 0; OBJ "
                                                      "counts vertices from 1")
    last = text.rsplit("\n", 1)[-1].split()
    if last[:1] in (["v"], ["f"]) and len(last) < 4:
        raise MeshFault(f"the file is cut short: it ends within a line ({' '.join(last)!r})")


def companions(path: Path, data: bytes) -> list[Path]:
    """The files a mesh file reads beside itself, which a library's hash covers with
    it: a .gltf's external buffers and images, an OBJ's material libraries (editing
    only a glTF's .bin kept the cached database of the old geometry). Faults are left
    to :func:`check_content`: a damaged or missing one is simply not listed."""
    names: list[tuple[Path, str, str]] = []
    try:
        if path.suffix.lower() == ".gltf":
            doc = _json(data, "its JSON")
            for key, what in (("buffers", "buffer"), ("images", "texture")):
                names += [(path.parent, item["uri"], what) for item in _Gltf(doc).items(key)
                          if isinstance(item.get("uri"), str)
                          and not item["uri"].startswith("data:")]
        elif path.suffix.lower() == ".obj":
            text = data.decode("utf-8", errors="replace")
            for libs in _MTLLIB.findall(text):
                names += [(path.parent, lib, "material") for lib in _names(path.parent, libs)]
    except MeshFault:
        return []
    found = []
    for folder, name, what in names:
        try:
            found.append(_resource(folder, name, what))
        except (MeshFault, OSError):
            continue
    return found


def _names(folder: Path, rest: str) -> list[str]:
    """The file names on an ``mtllib`` or texture line: the whole rest of the line if
    that is a file (names may hold spaces), else its words (several libraries, or
    texture options before the name)."""
    return [rest] if (folder / rest).is_file() else rest.split()


def _whole_last_line(body: bytes, lines: list[list[bytes]]) -> None:
    """An ASCII PLY whose last line is shorter than the one before it and has no line
    end was cut within that line (it would load as one face fewer, silently)."""
    if len(lines) > 1 and not body.rstrip(b" \t").endswith(b"\n") and \
            len(lines[-1]) < len(lines[-2]):
        raise MeshFault("the file is cut short: it ends within its last line "
                        f"({b' '.join(lines[-1]).decode(errors='replace')!r})")


def _many(n: int, thing: str) -> str:
    """``3 vertices``, ``1 face``."""
    plural = {"vertex": "vertices", "mesh": "meshes"}.get(thing, thing + "s")
    return f"{n:,} {thing if n == 1 else plural}"


def _a(kind: str) -> str:
    """``an STL file``, ``a GLB file``: the article as the name is spoken."""
    return ("an " if kind.split()[0] in ("STL", "OBJ", "OFF", "FBX", "XML") else "a ") + kind


def _check_stl(path: Path, data: bytes, kind: str | None) -> None:
    """An ASCII STL ends with ``endsolid``; a binary one has the size its triangle
    count gives (trimesh returns an empty mesh for either cut short)."""
    if kind == "STL" and data.lstrip().startswith(b"solid") and _text(data[:65536]):
        if not re.search(rb"endsolid[^\n]*\s*$", data[-4096:]):
            raise MeshFault("the file is cut short: the ASCII STL does not end with "
                            "'endsolid'")
        return
    if kind == "text":
        raise MeshFault("the file is text but not an ASCII STL (which starts with 'solid')")
    size = len(data)
    if size < 84:
        raise MeshFault(f"the file is cut short: {size} bytes, less than the 84-byte "
                        "header of a binary STL")
    count = struct.unpack_from("<I", data, 80)[0]
    need = 84 + 50 * count
    if need > size:
        raise MeshFault(f"the file is cut short{'' if need < 100 * size else ' or is not an STL'}"
                        f": its header gives {count:,} triangles ({need:,} bytes), the file "
                        f"has {size:,}")
    if need < size:
        raise MeshFault(f"the file is damaged or not an STL: its header gives {count:,} "
                        f"triangles ({need:,} bytes), the file has {size:,}")
    if count > MAX_TRIANGLES:   # told from the header, before trimesh reads them all
        raise MeshFault(f"its header gives {too_many_triangles(count)}", DECIMATE)


def _check_ply(path: Path, data: bytes, kind: str | None) -> None:
    """A PLY's header is whole and its data as long as the header's element counts
    need (an ASCII PLY cut short loaded as fewer faces, silently)."""
    if kind != "PLY":
        raise MeshFault("the file does not start with 'ply', so it is not a PLY file")
    end = data.find(b"end_header")
    if end < 0:
        raise MeshFault("the file is cut short within its PLY header (no 'end_header')")
    body = data[data.find(b"\n", end) + 1:] if data.find(b"\n", end) >= 0 else b""
    fmt = ""
    elements: list[tuple[str, int]] = []
    sizes: list[int] = []    # the fewest bytes one of each element takes (lists empty)
    for line in data[:end].decode("ascii", errors="replace").splitlines()[1:]:
        w = line.split()
        try:
            if w[:1] == ["format"]:
                fmt = w[1]
            elif w[:1] == ["element"]:
                elements.append((w[1], int(w[2])))
                sizes.append(0)
                if elements[-1][1] < 0:
                    raise ValueError
            elif w[:1] == ["property"] and elements:   # a list counts its length only
                sizes[-1] += _PLY_SIZES[w[2] if w[1] == "list" else w[1]]
        except (IndexError, ValueError, KeyError):
            raise MeshFault(f"its PLY header is damaged at the line {line.strip()!r}") from None
    faces = sum(n for name, n in elements if name == "face")
    if faces > MAX_TRIANGLES:   # (each face one triangle at least)
        raise MeshFault(f"its header gives {too_many_triangles(faces)}", DECIMATE)
    counts = " and ".join(_many(n, name) for name, n in elements) or "no elements"
    if fmt == "ascii":
        lines = [ln.split() for ln in body.splitlines() if ln.strip()]
        if len(lines) < sum(n for _, n in elements):
            raise MeshFault(f"the file is cut short: its header gives {counts}, the file "
                            f"has {len(lines):,} data lines")
        _whole_last_line(body, lines)
    elif sum(n * b for (_, n), b in zip(elements, sizes, strict=True)) > len(body):
        raise MeshFault(f"the file is cut short: its header gives {counts}, more than its "
                        f"{len(body):,} bytes of data hold")


def explain_failure(path: Path, data: bytes, exc: BaseException) -> MeshFault:
    """Why trimesh failed on a file that passed :func:`check_content`, found by reading
    the file again in its own terms (an OBJ's faces and numbers); never the parser's
    text."""
    ext = path.suffix.lower()
    if isinstance(exc, MemoryError):
        return MeshFault("the file declares more data than fits in memory: it is damaged")
    if ext in (".obj", ".stl"):
        fault = _text_lines(data, ext)
        if fault:
            return fault
    if ext == ".ply":
        return MeshFault("the file is cut short or damaged: its data does not match what "
                         "its PLY header declares")
    return MeshFault(f"the file is damaged: it does not hold a valid {NAMES[ext]} mesh")


def _text_lines(data: bytes, ext: str) -> MeshFault | None:
    """The first line of an OBJ or ASCII STL that is not what its format needs: a
    coordinate that is no number, a face that points at a vertex the file lacks."""
    count = 0
    for no, raw in enumerate(data.decode("utf-8", errors="replace").splitlines(), 1):
        w = raw.split()
        if not w or w[0] not in ("v", "f", "vertex", "facet"):
            continue
        if w[0] == "f":
            for token in w[1:]:
                try:
                    k = int(token.split("/")[0])
                except ValueError:
                    return MeshFault(f"line {no} ({raw.strip()[:60]!r}) has {token!r} where "
                                     "a vertex number belongs")
                if k == 0:
                    return MeshFault(f"line {no}: a face points at vertex 0, but OBJ counts "
                                     "vertices from 1", "number the face's vertices from 1")
                if not (1 <= k <= count or -count <= k <= -1):
                    return MeshFault(f"line {no}: a face points at vertex {k}, but the file "
                                     f"has only {_many(count, 'vertex')} before it: the "
                                     "file is damaged")
            continue
        count += w[0] == "v"
        nums = w[1:4] if w[0] != "facet" else w[2:5]
        for token in nums:
            try:
                x = float(token)
            except ValueError:
                return MeshFault(f"line {no} ({raw.strip()[:60]!r}) has {token!r} where a "
                                 "number belongs")
            if not np.isfinite(x):
                return MeshFault(f"line {no} has a coordinate that is not a finite number "
                                 f"({token})", "fix or delete that vertex in the modelling "
                                 "tool and export again")
    return None


def check_loaded(loaded: object) -> None:
    """What trimesh made of the file is a mesh: some faces, every face on vertices that
    exist, every coordinate a finite number."""
    if isinstance(loaded, trimesh.Scene):
        placed = [(n, *loaded.graph[n]) for n in loaded.graph.nodes_geometry]
        geoms = [loaded.geometry.get(g) for _, _, g in placed]
        for node, transform, _ in placed:   # a NaN there made every point NaN: a
            if not np.isfinite(transform).all():   # traceback, or NaN in the USD
                raise MeshFault(f"its scene node {json.dumps(str(node))[:60]} is placed "
                                "by a transform that is not finite numbers (NaN or "
                                "infinity in its translation, rotation or scale)",
                                "fix that node's transform in the modelling tool and "
                                "export again")
            if abs(np.linalg.det(np.asarray(transform, dtype=float)[:3, :3])) < 1e-12:
                # its mesh flattened to a point or a plane: the part then measured to
                # it and its sections came out empty ("no cross-section at its out-end")
                raise MeshFault(f"its scene node {json.dumps(str(node))[:60]} is scaled to "
                                "nothing (a scale of 0 along an axis flattens its mesh)",
                                "delete that node, or give it its scale, in the modelling "
                                "tool and export again")
    else:
        geoms = [loaded]
    meshes = [g for g in geoms if isinstance(g, trimesh.Trimesh)]
    points = sum(len(getattr(g, "vertices", ())) for g in geoms)
    faces = 0
    for m in meshes:
        f = np.asarray(m.faces)
        v = len(m.vertices)
        faces += len(f)
        if f.size and (f.min() < 0 or f.max() >= v):
            bad = int(((f < 0) | (f >= v)).any(axis=1).sum())
            raise MeshFault(f"the mesh has {_many(bad, 'face')} on vertices the file does "
                            f"not have (it has {_many(v, 'vertex')}): the file is damaged")
        if f.size and not np.isfinite(m.vertices).all():
            bad = int((~np.isfinite(m.vertices)).any(axis=1).sum())
            raise MeshFault(f"the mesh has {_many(bad, 'vertex')} whose coordinates are not "
                            "finite numbers (NaN or infinity)", "fix or delete those "
                            "vertices in the modelling tool and export again")
    if faces == 0:
        raise MeshFault(f"the mesh has no faces, only {points:,} loose points" if points
                        else "the mesh is empty: the file holds no vertices or faces")
