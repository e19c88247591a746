"""Loading part meshes with trimesh (GLB/glTF, OBJ, PLY, STL), like trimesh's own
``exchange/load.py``: one entry point, the format chosen by the file extension.

A glTF scene may name its sub-meshes ("window_3", "door", "balcony_1" ...); those
names are counted so a manifest need not repeat what the model already says.
"""

from __future__ import annotations

import json
import re
import struct
from pathlib import Path

import numpy as np
import trimesh

from citysynth.parts_db.errors import LibraryError

FORMATS = {".glb", ".gltf", ".obj", ".ply", ".stl"}
COUNTED = ("window", "door", "balcony")
COUNT_ATTRIBUTE = {"window": "windows", "door": "doors", "balcony": "balconies"}
_NAME = re.compile(r"^(window|door|balcony)s?(?:[_\-.\s]|\d|$)", re.IGNORECASE)


def load_part_mesh(path: Path, part_id: str, meters_per_unit: float):
    """(mesh in metres, counts of named sub-meshes). Raises LibraryError naming the part."""
    where = f'part "{part_id}" ({path})'
    if path.suffix.lower() not in FORMATS:
        raise LibraryError(f"{where}: unsupported mesh format {path.suffix!r}; use one of "
                           f"{', '.join(sorted(FORMATS))}")
    if not path.is_file():
        raise LibraryError(f"{where}: mesh file not found")
    loaded = read_mesh(path, where, "export the mesh again from its modelling tool, or "
                       "drop the part from the manifest")
    counts = {k: 0 for k in COUNTED}
    if isinstance(loaded, trimesh.Scene):
        for node in loaded.graph.nodes_geometry:
            _, geom_name = loaded.graph[node]
            m = _NAME.match(str(node)) or _NAME.match(str(geom_name))
            if m:
                counts[m.group(1).lower()] += 1
        mesh = _flatten(loaded)
    else:
        mesh = loaded
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise LibraryError(f"{where}: the mesh is empty (no triangles)")
    if not np.isfinite(mesh.vertices).all():
        raise LibraryError(f"{where}: the mesh has non-finite vertex coordinates")
    mesh.process()  # merge duplicate vertices: sections find bodies by shared edges
    if meters_per_unit != 1.0:
        mesh = mesh.copy()
        mesh.apply_scale(meters_per_unit)
    return mesh, counts


def read_mesh(path: Path, where: str, fix: str):
    """The file loaded by trimesh (a Scene or a Trimesh, unprocessed), or a LibraryError
    ``where: why; fix`` saying in the format's terms what is wrong with it: what a GLB's
    header says first (:func:`glb_damage`), a .gltf's JSON checked before trimesh reads
    it (trimesh takes damaged JSON for a missing file), else :func:`unreadable`."""
    try:
        damage = glb_damage(path)
        if damage is None and path.suffix.lower() == ".gltf":
            json.loads(path.read_bytes().decode("utf-8"))
        loaded = None if damage else trimesh.load(str(path), force=None, process=False)
    except Exception as exc:  # trimesh raises many kinds for unreadable files
        raise LibraryError(f"{where}: {unreadable(exc, path)}; {fix}") from None
    if damage:
        raise LibraryError(f"{where}: the mesh cannot be read: {damage}; {fix}")
    return loaded


def glb_damage(path: Path) -> str | None:
    """What a GLB's own header says is wrong with it (no glTF header, a version other
    than 2, fewer bytes than it declares), or None (and None for other formats).
    trimesh reads on past a short GLB into its JSON and reports that instead."""
    if path.suffix.lower() != ".glb":
        return None
    with path.open("rb") as f:
        head = f.read(12)
    size = path.stat().st_size
    if len(head) < 12 or head[:4] != b"glTF":
        return "the file has no glTF header (it is not a GLB, or is cut short within its " \
            "first 12 bytes)"
    version, length = struct.unpack("<II", head[4:12])
    if version != 2:
        return f"its header gives glTF version {version}; only glTF 2 is read"
    if length > size:
        return f"the file is cut short: its header gives {length:,} bytes, the file has {size:,}"
    return None


def unreadable(exc: Exception, path: Path | str) -> str:
    """Why a mesh file could not be read, in the file's terms (where its format says
    what went wrong), not the parser's exception text alone."""
    kind = Path(path).suffix.lower()
    name = kind.lstrip(".").upper()
    if isinstance(exc, json.JSONDecodeError):
        where = "its glTF JSON chunk" if kind == ".glb" else "its JSON"
        return f"the mesh cannot be read: {where} is damaged at character {exc.pos} ({exc.msg})"
    if isinstance(exc, UnicodeDecodeError):
        return f"the mesh cannot be read: byte {exc.start} is not text where {name} needs text"
    if isinstance(exc, struct.error | EOFError | ValueError | KeyError | IndexError):
        return (f"the mesh cannot be read: the file is cut short or not a valid {name} file "
                f"({type(exc).__name__}: {exc})")
    return f"the mesh cannot be read ({type(exc).__name__}: {exc})"


def _flatten(scene: trimesh.Scene):
    """All triangle geometry of a scene in world coordinates, as one mesh (colours are
    not needed for measuring; this is several times faster than Scene.to_geometry)."""
    verts, faces, offset = [], [], 0
    for node in scene.graph.nodes_geometry:
        transform, geom_name = scene.graph[node]
        g = scene.geometry.get(geom_name)
        if not isinstance(g, trimesh.Trimesh) or len(g.faces) == 0:
            continue
        verts.append(trimesh.transform_points(g.vertices, transform))
        faces.append(g.faces + offset)
        offset += len(g.vertices)
    if not verts:
        return None
    return trimesh.Trimesh(np.vstack(verts), np.vstack(faces), process=False)
