"""A part's renderable geometry, in its placement frame, grouped by material.

Export needs what measuring threw away: the colours. A part mesh (a glTF scene of
named sub-meshes, or a single OBJ/PLY/STL mesh) becomes a few :class:`Piece` s, one
per distinct colour, so a USD prototype or a glTF mesh carries one material per piece
instead of one per window. Coordinates are in metres in the placement frame: a
straight part starts at x = 0 and is stretched to its snapped length (when the
library rescales), a key-point part keeps its key point at the origin. Loaded once per
process and part (parts repeat hundreds of times in a city).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import trimesh

from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.library import Part, PartDB

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
        """Unit face normals (flat shading suits these boxy parts)."""
        return trimesh.Trimesh(self.vertices, self.faces, process=False).face_normals


def part_pieces(db: PartDB, part: Part) -> tuple[Piece, ...]:
    """The pieces of ``part`` in its placement frame (cached per file and placement)."""
    return _pieces(str(db.mesh_path(part)), part.id, db.meters_per_unit,
                   tuple(part.origin), part.scale)


@lru_cache(maxsize=1024)
def _pieces(path: str, part_id: str, meters_per_unit: float,
            origin: tuple[float, float, float], scale: float) -> tuple[Piece, ...]:
    try:
        loaded = trimesh.load(path, force=None, process=False)
    except Exception as exc:  # trimesh raises many kinds for unreadable files
        raise LibraryError(f'part "{part_id}" ({path}): cannot read the mesh '
                           f"({type(exc).__name__}: {exc}); ingest the library again") from None
    groups: dict[tuple[int, ...], list] = {}
    names: dict[tuple[int, ...], str] = {}
    if isinstance(loaded, trimesh.Scene):
        for node in sorted(loaded.graph.nodes_geometry):
            transform, geom_name = loaded.graph[node]
            g = loaded.geometry.get(geom_name)
            if not isinstance(g, trimesh.Trimesh) or len(g.faces) == 0:
                continue
            key = _colour(g)
            groups.setdefault(key, []).append((trimesh.transform_points(g.vertices,
                                                                         transform), g.faces))
            m = _KIND.match(str(node))
            names.setdefault(key, m.group(0).lower() if m else "surface")
    else:
        key = _colour(loaded)
        groups[key] = [(np.asarray(loaded.vertices, dtype=float), loaded.faces)]
        names[key] = "surface"
    lo = np.array(origin, dtype=float)
    pieces = []
    for key in sorted(groups, key=lambda c: (names[c], c)):
        verts, faces, offset = [], [], 0
        for v, f in groups[key]:
            verts.append(v)
            faces.append(np.asarray(f, dtype=np.int64) + offset)
            offset += len(v)
        v = np.vstack(verts) * meters_per_unit - lo
        v[:, 0] *= scale
        pieces.append(Piece(names[key], key, v, np.vstack(faces)))
    return tuple(pieces)


def _colour(mesh) -> tuple[int, int, int, int]:
    """The mesh's dominant colour: vertex/face colours, or a material's base colour."""
    visual = getattr(mesh, "visual", None)
    try:
        if visual is not None and visual.kind in ("vertex", "face"):
            return tuple(int(x) for x in visual.main_color)
        material = getattr(visual, "material", None)
        if material is not None:
            c = getattr(material, "baseColorFactor", None)
            if c is None:
                c = getattr(material, "main_color", None)
            if c is not None:
                return tuple(int(x) for x in np.asarray(c).ravel()[:4])
    except (AttributeError, ValueError, TypeError):
        pass
    return DEFAULT_RGBA
