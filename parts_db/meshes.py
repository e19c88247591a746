"""Loading part meshes with trimesh (GLB/glTF, OBJ, PLY, STL), like trimesh's own
``exchange/load.py``: one entry point, the format chosen by the file extension.

A glTF scene may name its sub-meshes ("window_3", "door", "balcony_1" ...); those
names are counted so a manifest need not repeat what the model already says.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image

from citysynth.parts_db import mesh_faults
from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.mesh_faults import (
    DECIMATE,
    MeshFault,
    check_content,
    check_loaded,
    explain_failure,
    read_file,
    too_many_triangles,
)

FORMATS = {".glb", ".gltf", ".obj", ".ply", ".stl"}
COUNTED = ("window", "door", "balcony")
COUNT_ATTRIBUTE = {"window": "windows", "door": "doors", "balcony": "balconies"}
EXPORT_AGAIN = "export the mesh again from its modelling tool, or drop the part from the manifest"
_NAME = re.compile(r"^(window|door|balcony)s?(?:[_\-.\s]|\d|$)", re.IGNORECASE)


def load_part_mesh(path: Path, part_id: str, meters_per_unit: float):
    """(mesh in metres, counts of named sub-meshes). Raises LibraryError naming the part."""
    where = f'part "{part_id}" ({path})'
    if path.suffix.lower() not in FORMATS:
        raise LibraryError(f"{where}: unsupported mesh format {path.suffix!r}; use one of "
                           f"{', '.join(sorted(FORMATS))}")
    loaded = read_mesh(path, where, EXPORT_AGAIN)
    counts = {k: 0 for k in COUNTED}
    if isinstance(loaded, trimesh.Scene):
        for kind, _ in sorted(_named_features(loaded)):
            counts[kind] += 1
        mesh = _flatten(loaded)
    else:
        mesh = loaded
    check_triangles(mesh, where)
    with np.errstate(all="ignore"):   # huge coordinates warn while merging; no output
        mesh.process()  # merge duplicate vertices: sections find bodies by shared edges
    if meters_per_unit != 1.0:
        mesh = mesh.copy()
        mesh.apply_scale(meters_per_unit)
    return mesh, counts


_PRIMITIVE = re.compile(r"^(?P<node>.+)_[0-9a-f]{6}$")   # trimesh's name for one of a
                                                        # node's several primitives
_NUMBERED = re.compile(r"^(?:window|door|balcony)s?[_\-.\s]*(\d+)", re.IGNORECASE)


def _named_features(scene: trimesh.Scene) -> set[tuple[str, str]]:
    """The windows, doors and balconies a glTF scene names, each once: (kind, its
    number when its name gives one, else its node's name). A node of two primitives
    (a window's frame and glass materials: trimesh makes a child of each) is one
    window, and the nodes of one numbered window (``window_1``, ``window_1_frame``,
    ``window_1_glass``) are one window: each was counted, three windows for one."""
    parents = scene.graph.transforms.parents
    found: set[tuple[str, str]] = set()
    for node in scene.graph.nodes_geometry:
        _, geom_name = scene.graph[node]
        name = str(node)
        whole = _PRIMITIVE.match(name)
        if whole and parents.get(node) == whole["node"]:
            name = whole["node"]
        for named in (name, str(geom_name)):
            m = _NAME.match(named)
            if m:
                number = _NUMBERED.match(named)
                found.add((m.group(1).lower(), f"#{number.group(1)}" if number else named))
                break
    return found


def check_triangles(mesh, where: str) -> None:
    """Refuse, with the memory it would take, a part past
    :data:`mesh_faults.MAX_TRIANGLES` before it is measured: a scan of 6.2 million
    triangles took 2 GB and 24 s, and under a memory limit ended in a traceback inside
    trimesh (exit 3). (An STL's or PLY's header tells its count before trimesh reads
    the file: see mesh_faults.)"""
    n = 0 if mesh is None else len(mesh.faces)
    if n > mesh_faults.MAX_TRIANGLES:
        raise LibraryError(f"{where}: {too_many_triangles(n)}; {DECIMATE}")


def read_mesh(path: Path, where: str, fix: str):
    """The file loaded by trimesh (a Scene or a Trimesh with faces, unprocessed), or a
    LibraryError ``where: why; fix`` saying in the user's terms what is wrong with the
    file (:mod:`parts_db.mesh_faults`), looked at before trimesh reads it and checked
    after; the fault's own fix where it has one, else ``fix``."""
    data = mesh_bytes(path, where, fix)
    try:
        check_content(path, data)
        try:
            with warnings.catch_warnings():   # a big texture: PIL's warning, with its
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)   # path,
                loaded = trimesh.load(str(path), force=None, process=False)   # on stderr
        except (Exception, MemoryError) as exc:  # noqa: BLE001 - trimesh raises many kinds
            raise explain_failure(path, data, exc) from None
        check_loaded(loaded)
    except MeshFault as fault:
        raise LibraryError(f"{where}: {fault.why}; {fault.fix or fix}") from None
    return loaded


def mesh_bytes(path: Path, where: str, fix: str = EXPORT_AGAIN) -> bytes:
    """The bytes of a part's mesh file, or a LibraryError if the path is no readable
    file (missing, a folder, a link loop, a pipe, empty): the library's hash reads them
    first, and must tell these as loading does."""
    try:
        return read_file(path)
    except MeshFault as fault:
        raise LibraryError(f"{where}: {fault.why}; {fault.fix or fix}") from None


def placed(vertices: np.ndarray, faces: np.ndarray, transform: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """A scene node's geometry in world coordinates: its vertices moved by the node's
    ``transform``, its faces wound the other way when the transform mirrors (a negative
    determinant, as a modelling tool's mirrored copy exports), as glTF says a renderer
    must. Moved without that, a mirrored window was inside out: its faces looked away
    from the street, and an engine culling back faces showed a hole."""
    return (trimesh.transform_points(vertices, transform),
            np.ascontiguousarray(faces[:, ::-1]) if mirrors(transform) else faces)


def mirrors(transform: np.ndarray) -> bool:
    """Whether a node's transform mirrors (its 3x3 part has a negative determinant)."""
    return bool(np.linalg.det(np.asarray(transform, dtype=np.float64)[:3, :3]) < 0)


def _flatten(scene: trimesh.Scene):
    """All triangle geometry of a scene in world coordinates, as one mesh (colours are
    not needed for measuring; this is several times faster than Scene.to_geometry)."""
    verts, faces, offset = [], [], 0
    for node in scene.graph.nodes_geometry:
        transform, geom_name = scene.graph[node]
        g = scene.geometry.get(geom_name)
        if not isinstance(g, trimesh.Trimesh) or len(g.faces) == 0:
            continue
        v, f = placed(g.vertices, g.faces, transform)
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
    if not verts:
        return None
    return trimesh.Trimesh(np.vstack(verts), np.vstack(faces), process=False)
