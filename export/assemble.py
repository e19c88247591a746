"""Layouts as world-space triangle meshes: what the glTF baker, the previews and the
bounds checks need (USD and glTF keep instances; this module flattens them)."""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Iterator, Sequence

import numpy as np
import trimesh

from citysynth.export.infill import infill_pieces
from citysynth.export.layout import Instance, Layout
from citysynth.export.prototypes import prototype_pieces
from citysynth.export.shear import baked_prototype, perpendicular_y, sheared_pieces
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


def extent(layouts: Sequence[Layout], db: PartDB) -> list[list[float]] | None:
    """The box around ``layouts`` (a building's or block's k best: all its variant prim
    can show) as usd-core's ``UsdGeomModelAPI.ComputeExtentsHint`` finds it on the
    loaded layers, rounded outward to the millimetre: each instance's prototype box
    (its meshes' extents) placed and boxed again, so a rotated part counts its box's
    corners, not its vertices (up to a few metres more than :func:`bounds` for a long
    part at 45 degrees). A layer's ``extentsHint`` and a city manifest's block bounds;
    [[xmin, ymin, zmin], [xmax, ymax, zmax]], or None when they show nothing."""
    boxes = [_layout_box(lay, db) for lay in layouts]
    lo = np.min([b[0] for b in boxes], axis=0) if boxes else np.full(3, np.inf)
    hi = np.max([b[1] for b in boxes], axis=0) if boxes else np.full(3, -np.inf)
    if not np.isfinite(lo).all():
        return None
    return [[math.floor(x * 1000) / 1000 for x in lo], [math.ceil(x * 1000) / 1000 for x in hi]]


def _layout_box(lay: Layout, db: PartDB) -> np.ndarray:
    """:func:`extent` of one layout, unrounded (inf and -inf when empty). The last
    :data:`CACHED_LAYOUTS` are kept by identity (each with its layout, so no other
    takes its id): a block's layer, variant prim and record each ask for it, and a
    layout is not changed once placed. Prototype boxes are kept too
    (:data:`CACHED_BOXES`): placing every vertex, as :func:`bounds` does, took 3 ms a
    layout, three times this."""
    hit = _LAYOUTS.get(id(lay))
    if hit is not None and hit[0] is lay and hit[1] == db.library_hash:
        return hit[2]
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    shown: dict[str, list[Instance]] = {}
    for inst in lay.instances:   # as USD shows them: a shear baked into the prototype
        shown.setdefault(baked_prototype(inst), []).append(inst)
    for insts in shown.values():
        h = insts[0].shear
        box = _prototype_box(db, insts[0], h)
        if box is None:   # a module cut wholly away
            continue
        centre, half = (box[0] + box[1]) / 2, (box[1] - box[0]) / 2
        axes = np.array([(i.x_axis, perpendicular_y(i, h)) for i in insts])   # [n, 2, 2]
        mid = centre[:2] @ axes + np.array([i.origin for i in insts])
        reach = half[:2] @ np.abs(axes)
        z = np.array([i.z for i in insts])
        lo = np.minimum(lo, [*(mid - reach).min(axis=0), box[0][2] + z.min()])
        hi = np.maximum(hi, [*(mid + reach).max(axis=0), box[1][2] + z.max()])
    for p in infill_pieces_of(lay, db):
        if len(p.vertices):
            lo = np.minimum(lo, p.vertices.min(axis=0))
            hi = np.maximum(hi, p.vertices.max(axis=0))
    out = np.array([lo, hi])
    _LAYOUTS[id(lay)] = (lay, db.library_hash, out)
    if len(_LAYOUTS) > CACHED_LAYOUTS:
        _LAYOUTS.pop(next(iter(_LAYOUTS)))
    return out


CACHED_LAYOUTS = 16   # a block's k best (k is 3 by default in a city)
_LAYOUTS: dict[int, tuple[Layout, str, np.ndarray]] = {}


def _prototype_box(db: PartDB, inst: Instance, h: float) -> np.ndarray | None:
    """[[min], [max]] of the vertices of the prototype ``inst`` shows, sheared by ``h``,
    in its part's placement frame; None when it has none."""
    key = (db.library_hash, inst.part, inst.cut, h)
    if key in _BOXES:
        _BOXES.move_to_end(key)
        return _BOXES[key]
    v = [p.vertices for p in sheared_pieces(prototype_pieces(db, inst), h) if len(p.vertices)]
    box = None
    if v:
        box = np.array([np.min([x.min(axis=0) for x in v], axis=0),
                        np.max([x.max(axis=0) for x in v], axis=0)])
    _BOXES[key] = box
    if len(_BOXES) > CACHED_BOXES:
        _BOXES.popitem(last=False)
    return box


CACHED_BOXES = 4096   # prototypes (a block shows tens; library parts recur in every block)
_BOXES: OrderedDict[tuple, np.ndarray | None] = OrderedDict()


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
