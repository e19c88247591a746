"""GLB through trimesh, for game engines: one file per layout.

Each part's pieces are glTF meshes defined once (a PBR material each, from the part's
colours); every part instance is a node with its placement matrix whose children use
those meshes, so a block's file holds each part once. glTF forbids shear in node
matrices (they must decompose into translation, rotation and scale), so an instance
whose placement shears (a corner adapted to an angle off its own) gets its own baked
copy of the geometry; mirrors and stretches are plain TRS and stay instanced.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from trimesh.visual.material import PBRMaterial

from citysynth.export.assemble import instances_with_pieces, place
from citysynth.export.layout import Instance, Layout
from citysynth.parts_db import PartDB
from citysynth.parts_db.files import atomic_path
from citysynth.parts_db.geometry import Piece

SHEAR_TOL = 1e-4   # relative; below it (~0.006°, under 2 mm over a part) an engine may drop it


def _material(piece: Piece) -> PBRMaterial:
    glass = piece.name.startswith("window")
    return PBRMaterial(name=piece.name, baseColorFactor=list(piece.rgba),
                       roughnessFactor=0.15 if glass else 0.8, metallicFactor=0.0)


def _mesh(vertices, faces, piece: Piece) -> trimesh.Trimesh:
    m = trimesh.Trimesh(vertices, faces, process=False)
    m.visual = trimesh.visual.TextureVisuals(material=_material(piece))
    return m


def sheared(inst: Instance) -> bool:
    x, y = np.asarray(inst.x_axis), np.asarray(inst.y_axis)
    return abs(float(x @ y)) > SHEAR_TOL * float(np.linalg.norm(x) * np.linalg.norm(y))


def layout_scene(lay: Layout, db: PartDB) -> trimesh.Scene:
    scene = trimesh.Scene(base_frame="world")
    defined: set[str] = set()
    for n, (inst, pieces) in enumerate(instances_with_pieces(lay, db)):
        node = f"{n:04d}_{inst.proto}"
        if sheared(inst):
            for k, piece in enumerate(pieces):
                v, f = place(piece, inst)
                scene.add_geometry(_mesh(v, f, piece), geom_name=f"{node}_{k}",
                                   node_name=f"{node}_{k}", parent_node_name="world")
            continue
        scene.graph.update(frame_from="world", frame_to=node, matrix=inst.matrix())
        for k, piece in enumerate(pieces):
            geom = f"{inst.proto}_{k}"
            if geom not in defined:
                scene.geometry[geom] = _mesh(piece.vertices, piece.faces, piece)
                defined.add(geom)
            scene.graph.update(frame_from=node, frame_to=f"{node}_{k}", geometry=geom)
    return scene


def write_glb(lay: Layout, db: PartDB, path: str | Path) -> Path:
    data = layout_scene(lay, db).export(file_type="glb")
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)
