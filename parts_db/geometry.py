"""A part's renderable geometry, in its placement frame, grouped by material.

Export needs what measuring threw away: the colours. A part mesh (a glTF scene of
named sub-meshes, or a single OBJ/PLY/STL mesh) becomes a few :class:`Piece` s, one
per kind of sub-mesh (walls, roof, trim, window, door, balcony: the leading letters of
its node name) and colour, so a USD prototype or a glTF mesh carries one material per
piece instead of one per window. Colours are read per face: one sub-mesh may hold
several (a roof and its walls painted in one mesh, as a modeller's export or an OBJ
with vertex colours does), and each becomes its own piece rather than being averaged
into the mesh's dominant colour. Coordinates are in metres in the placement frame: a
straight part starts at x = 0 and is stretched to its snapped length (when the
library rescales), a key-point part keeps its key point at the origin. Loaded once per
process and part (parts repeat hundreds of times in a city).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh
from numba import njit

from citysynth.parts_db.library import Part, PartDB
from citysynth.parts_db.meshes import mirrors, read_mesh

DEFAULT_RGBA = (200, 200, 200, 255)   # meshes without colours
_KIND = re.compile(r"^[A-Za-z]+")


@dataclass(frozen=True)
class Piece:
    name: str                      # the first sub-mesh's kind: "walls", "window" ...
    rgba: tuple[int, int, int, int]
    vertices: np.ndarray           # float64 [n, 3], placement frame, metres
    faces: np.ndarray              # int64 [m, 3]

    @property
    def normals(self) -> np.ndarray:
        """Unit face normals (flat shading suits these boxy parts); zero for a face of
        no area. Compiled: a city writes hundreds of pieces a block (a trimesh object
        cost ten times the sums, numpy's passes over small arrays three times more)."""
        return _face_normals(np.ascontiguousarray(self.vertices, dtype=np.float64),
                             np.ascontiguousarray(self.faces, dtype=np.int64))

    def with_faces(self, faces: np.ndarray) -> Piece:
        """This piece with only ``faces`` (indices into its vertices) and the points
        they use, renumbered. A point no face uses is a loose vertex in a DCC (a cut's
        dropped needles, a triangulation that skips a collinear point)."""
        used = np.zeros(len(self.vertices), dtype=bool)
        used[faces.ravel()] = True
        if used.all():
            return self if faces is self.faces else Piece(self.name, self.rgba,
                                                          self.vertices, faces)
        new_index = np.cumsum(used) - 1
        return Piece(self.name, self.rgba, self.vertices[used], new_index[faces])

    def float32_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The arrays a writer stores, in one compiled pass: points (float32), the face
        vertex indices flattened (int32), the face normals (computed in float64 as
        :attr:`normals`, then float32) and the points' extent (float32 [2, 3]: min,
        max). A city writes hundreds of pieces a block, and the seven small numpy
        passes these took cost more than the arithmetic."""
        return _float32_arrays(np.ascontiguousarray(self.vertices, dtype=np.float64),
                               np.ascontiguousarray(self.faces, dtype=np.int64))


@njit(cache=True)
def _float32_arrays(v: np.ndarray, f: np.ndarray):  # pragma: no cover (compiled)
    pts = v.astype(np.float32)
    ext = np.zeros((2, 3), dtype=np.float32)
    if pts.shape[0]:
        for c in range(3):
            ext[0, c] = ext[1, c] = pts[0, c]
        for r in range(1, pts.shape[0]):
            for c in range(3):
                x = pts[r, c]
                if x < ext[0, c]:
                    ext[0, c] = x
                if x > ext[1, c]:
                    ext[1, c] = x
    return (pts, f.astype(np.int32).ravel(), _face_normals(v, f).astype(np.float32), ext)


@njit(cache=True)
def _face_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:  # pragma: no cover (compiled)
    """Each face's unit normal, with numpy's arithmetic in numpy's order (``cross``
    written out, the norm summed left to right), so the bits are those of the numpy
    version; zero where the cross product's norm is 1e-13 or less."""
    n = np.empty((f.shape[0], 3))
    for r in range(f.shape[0]):
        i, j, k = f[r, 0], f[r, 1], f[r, 2]
        e1x, e1y, e1z = v[j, 0] - v[i, 0], v[j, 1] - v[i, 1], v[j, 2] - v[i, 2]
        e2x, e2y, e2z = v[k, 0] - v[i, 0], v[k, 1] - v[i, 1], v[k, 2] - v[i, 2]
        x = e1y * e2z - e1z * e2y
        y = e1z * e2x - e1x * e2z
        z = e1x * e2y - e1y * e2x
        norm = np.sqrt(x * x + y * y + z * z)
        if norm > 1e-13:
            n[r, 0], n[r, 1], n[r, 2] = x / norm, y / norm, z / norm
        else:
            n[r, 0] = n[r, 1] = n[r, 2] = 0.0
    return n


def part_pieces(db: PartDB, part: Part) -> tuple[Piece, ...]:
    """The pieces of ``part`` in its placement frame (cached per file and placement)."""
    return _pieces(str(db.mesh_path(part)), part.id, db.meters_per_unit,
                   tuple(part.origin), part.scale)


RGBA = tuple[int, int, int, int]
Group = list[tuple[np.ndarray, np.ndarray]]   # (vertices, faces) of the sub-meshes


@lru_cache(maxsize=1024)
def _pieces(path: str, part_id: str, meters_per_unit: float,
            origin: tuple[float, float, float], scale: float) -> tuple[Piece, ...]:
    loaded = read_mesh(Path(path), f'part "{part_id}" ({path})',
                       "it changed since the library was ingested; ingest the library again")
    groups: dict[tuple[str, RGBA], Group] = {}
    if isinstance(loaded, trimesh.Scene):
        for node in sorted(loaded.graph.nodes_geometry):
            transform, geom_name = loaded.graph[node]
            g = loaded.geometry.get(geom_name)
            if not isinstance(g, trimesh.Trimesh) or len(g.faces) == 0:
                continue
            m = _KIND.match(str(node))
            kind = m.group(0).lower() if m else "surface"
            verts = trimesh.transform_points(g.vertices, transform)
            flip = mirrors(transform)   # wound back, as :func:`placed` says why
            for rgba, faces in _by_colour(g):
                groups.setdefault((kind, rgba), []).append(
                    (verts, faces[:, ::-1] if flip else faces))
    elif isinstance(loaded, trimesh.Trimesh):
        verts = np.asarray(loaded.vertices, dtype=np.float64)
        for rgba, faces in _by_colour(loaded):
            groups.setdefault(("surface", rgba), []).append((verts, faces))
    lo = np.array(origin, dtype=np.float64)
    pieces = []
    for key in sorted(groups):
        v, f = _merge(groups[key])
        v = v * meters_per_unit - lo
        v[:, 0] *= scale
        pieces.append(Piece(key[0], key[1], v, f))
    return tuple(pieces)


def _merge(group: Group) -> tuple[np.ndarray, np.ndarray]:
    """One (vertices, faces) from several, keeping only the vertices faces use."""
    verts: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    offset = 0
    for v, f in group:
        used, inverse = np.unique(f, return_inverse=True)
        verts.append(v[used])
        faces.append(inverse.reshape(-1, 3).astype(np.int64) + offset)
        offset += len(used)
    return np.vstack(verts), np.vstack(faces)


def _rgba(values) -> RGBA:
    c = [int(x) for x in np.asarray(values).ravel()[:4]]
    c += [255] * (4 - len(c))
    return c[0], c[1], c[2], c[3]


def _by_colour(mesh: trimesh.Trimesh) -> list[tuple[RGBA, np.ndarray]]:
    """The mesh's faces grouped by colour: (rgba, faces) per colour, in colour order.
    A face takes the colour of its first vertex (vertex colours) or its own (face
    colours); a mesh without per-face colours is one group of its material's colour."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    colours = _face_colours(mesh)
    if colours is None:
        return [(_colour(mesh), faces)]
    keys, inverse = np.unique(colours, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    return [(_rgba(keys[k]), faces[inverse == k]) for k in range(len(keys))]


def _face_colours(mesh: trimesh.Trimesh) -> np.ndarray | None:
    visual = getattr(mesh, "visual", None)
    try:
        if visual is not None and visual.kind == "face":
            return np.asarray(visual.face_colors, dtype=np.uint8)
        if visual is not None and visual.kind == "vertex":
            vc = np.asarray(visual.vertex_colors, dtype=np.uint8)
            return vc[np.asarray(mesh.faces)[:, 0]]
    except (AttributeError, ValueError, TypeError, IndexError):
        pass
    return None


def _colour(mesh) -> RGBA:
    """The mesh's dominant colour: vertex/face colours, or a material's base colour."""
    visual = getattr(mesh, "visual", None)
    try:
        if visual is not None and visual.kind in ("vertex", "face"):
            return _rgba(visual.main_color)
        material = getattr(visual, "material", None)
        if material is not None:
            c = getattr(material, "baseColorFactor", None)
            if c is None:
                c = getattr(material, "main_color", None)
            if c is not None:
                return _rgba(c)
    except (AttributeError, ValueError, TypeError):
        pass
    return DEFAULT_RGBA
