"""Layouts as world-space triangle meshes: what the glTF baker, the previews and the
bounds checks need (USD and glTF keep instances; this module flattens them)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import trimesh

from citysynth.export.infill import infill_pieces
from citysynth.export.layout import Instance, Layout
from citysynth.export.prototypes import prototype_pieces
from citysynth.parts_db import PartDB
from citysynth.parts_db.geometry import Piece


def instances_with_pieces(lay: Layout, db: PartDB) -> Iterator[tuple[Instance, tuple[Piece, ...]]]:
    for inst in lay.instances:
        yield inst, prototype_pieces(db, inst)


def place(piece: Piece, inst: Instance, offset=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """The piece's vertices and faces in the layout frame (winding flipped for a
    mirrored instance, so normals still point out)."""
    m = inst.matrix()
    v = piece.vertices @ m[:3, :3].T + m[:3, 3] + np.asarray(offset)
    f = piece.faces[:, ::-1] if inst.mirrored else piece.faces
    return v, f


def _coloured(parts) -> trimesh.Trimesh:
    """One mesh from (vertices, faces, rgba) parts, each face coloured by its part."""
    verts, faces, colours, n = [], [], [], 0
    for v, f, rgba in parts:
        verts.append(v)
        faces.append(f + n)
        colours.append(np.tile(np.array(rgba, dtype=np.uint8), (len(f), 1)))
        n += len(v)
    if not verts:
        return trimesh.Trimesh()
    return trimesh.Trimesh(np.vstack(verts), np.vstack(faces), process=False,
                           face_colors=np.vstack(colours))


def infill_pieces_of(lay: Layout, db: PartDB) -> Iterator[Piece]:
    """The layout's roof infill (its pieces already in the layout frame)."""
    for infill in lay.infill:
        yield from infill_pieces(infill, db)


def world_mesh(lay: Layout, db: PartDB, offset=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    """The whole layout as one coloured mesh (per-face RGBA), e.g. for a preview."""
    shift = np.asarray(offset, dtype=float)
    return _coloured([*((*place(piece, inst, offset), piece.rgba)
                        for inst, pieces in instances_with_pieces(lay, db) for piece in pieces),
                      *((p.vertices + shift, p.faces, p.rgba) for p in infill_pieces_of(lay, db))])


def bounds(lay: Layout, db: PartDB) -> np.ndarray:
    """[[xmin, ymin, zmin], [xmax, ymax, zmax]] of every placed vertex."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for inst, pieces in instances_with_pieces(lay, db):
        for piece in pieces:
            v, _f = place(piece, inst)
            lo = np.minimum(lo, v.min(axis=0))
            hi = np.maximum(hi, v.max(axis=0))
    for p in infill_pieces_of(lay, db):
        lo = np.minimum(lo, p.vertices.min(axis=0))
        hi = np.maximum(hi, p.vertices.max(axis=0))
    return np.array([lo, hi])


def triangle_count(lay: Layout, db: PartDB) -> int:
    return sum(len(p.faces) for _i, pieces in instances_with_pieces(lay, db) for p in pieces) \
        + sum(len(p.faces) for p in infill_pieces_of(lay, db))


def world_boxes(lay: Layout, db: PartDB) -> trimesh.Trimesh:
    """Each instance as its part's bounding box (12 triangles, the part's main colour),
    and the roof infill as it is: a city overview with millions of triangles would not
    fit a preview."""
    unit = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])

    def box(inst, pieces):
        v = np.vstack([p.vertices for p in pieces if len(p.vertices)])
        lo, hi = v.min(axis=0), v.max(axis=0)
        main = max(pieces, key=lambda p: len(p.faces))
        shell = Piece(main.name, main.rgba, unit.vertices * (hi - lo) + lo, unit.faces)
        return (*place(shell, inst), shell.rgba)

    # a module cut wholly away (at an acute nose both legs' last modules may lie past
    # the other's plane) has no box
    return _coloured([*(box(inst, pieces) for inst, pieces in instances_with_pieces(lay, db)
                        if any(len(p.vertices) for p in pieces)),
                      *((p.vertices, p.faces, p.rgba) for p in infill_pieces_of(lay, db))])
