"""GLB for game engines and DCCs: one file per layout, or one for a city.

glTF 2.0 is Y-up and right-handed with metres as units, so the layout frame (Z-up,
right-handed) sits under one root node that turns it -90 degrees about X: ground on
y = 0, height along +Y, east along +X, north along -Z, handedness kept (a rotation,
not a mirror). Engines and Blender's importer show the buildings upright.

Each prototype (a part, or a part cut at a joint) is one glTF mesh defined once, one
primitive per piece, each with the shared material of its library material (one
material per kind and colour, named as in USD, base colour in linear space); every
part instance is a node with its placement matrix using that mesh. glTF forbids shear
in node matrices (they must decompose into translation, rotation and scale), so an
instance whose placement shears (a corner adapted to an angle off its own) gets its own
baked mesh; mirrors and stretches are plain TRS and stay instanced (a negative
determinant flips the winding, as the spec says). Nodes are named as the USD prims
(``structure_00`` > ``stage_03`` > ``classic_mid_5.2_4s_07``) and carry the layout's
facts in ``extras.citysynth`` (part, class, stage or key point on an instance; asked
and met on a stage; rank, cost, parts used, library and georeference on the root),
which Blender shows as custom properties. No normals are stored: glTF clients compute
flat normals then, which these boxy parts want. The file is written by hand (a JSON
chunk and a binary chunk), deterministic to the byte, and clean under Khronos's glTF
Validator (tests/test_gltf.py).
"""

from __future__ import annotations

import json
import struct
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from citysynth.export.assemble import place
from citysynth.export.infill import infill_pieces
from citysynth.export.layout import Instance, Layout
from citysynth.export.materials import (
    georeference,
    linear_rgb,
    material_name,
    opacity,
    roughness,
)
from citysynth.export.naming import (
    constraints_met,
    infill_name,
    instance_labels,
    stage_group,
    structure_group,
)
from citysynth.export.prototypes import prototype_pieces
from citysynth.export.shear import sheared
from citysynth.parts_db import PartDB
from citysynth.parts_db.files import atomic_path
from citysynth.parts_db.geometry import Piece

Z_UP_TO_Y_UP = [-0.7071067811865476, 0.0, 0.0, 0.7071067811865476]   # -90° about X (x,y,z,w)
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
FLOAT, UNSIGNED_INT = 5126, 5125


def trs_matrix(inst: Instance) -> list[float]:
    """The instance's placement as a glTF node matrix (column-major), its axes made
    exactly orthogonal: a shear under SHEAR_TOL (rounding in the layout, well under
    2 mm across a part) would make the matrix fail glTF's TRS rule."""
    m = inst.matrix()
    x, y = m[:3, 0].copy(), m[:3, 1].copy()
    y -= x * float(x @ y) / float(x @ x)
    m[:3, 1] = y * (np.linalg.norm(m[:3, 1]) / np.linalg.norm(y))
    return [float(v) + 0.0 for v in m.flatten(order="F")]   # + 0.0: no "-0.0" written


IDENTITY = [float(v) for v in np.eye(4).flatten()]   # a node's default: not written


class GlbBuilder:
    """A glTF document and its binary buffer, built up node by node; meshes and
    materials are defined once and shared (keyed by library and prototype)."""

    def __init__(self, generator: str = "citysynth") -> None:
        self.doc: dict[str, Any] = {
            "asset": {"version": "2.0", "generator": generator}, "scene": 0,
            "scenes": [], "nodes": [], "meshes": [], "materials": [], "accessors": [],
            "bufferViews": [], "buffers": []}
        self.bin = bytearray()
        self._materials: dict[str, int] = {}
        self._meshes: dict[tuple[str, str], int] = {}

    # --- data ---------------------------------------------------------------------
    def _view(self, data: bytes, target: int) -> int:
        self.bin.extend(b"\0" * (-len(self.bin) % 4))
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": len(self.bin),
                                        "byteLength": len(data), "target": target})
        self.bin.extend(data)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, arr: np.ndarray, target: int, **extra: Any) -> int:
        view = self._view(arr.tobytes(), target)
        component = FLOAT if arr.dtype == np.float32 else UNSIGNED_INT
        kind = "VEC3" if arr.ndim == 2 else "SCALAR"
        self.doc["accessors"].append({"bufferView": view, "componentType": component,
                                      "count": len(arr), "type": kind, **extra})
        return len(self.doc["accessors"]) - 1

    def material(self, piece: Piece) -> int:
        name = material_name(piece)
        if name not in self._materials:
            mat: dict[str, Any] = {"name": name, "pbrMetallicRoughness": {
                "baseColorFactor": [*linear_rgb(piece), opacity(piece)],
                "metallicFactor": 0.0, "roughnessFactor": roughness(piece)}}
            if piece.rgba[3] < 255:
                mat["alphaMode"] = "BLEND"
            self.doc["materials"].append(mat)
            self._materials[name] = len(self.doc["materials"]) - 1
        return self._materials[name]

    def mesh(self, key: tuple[str, str], parts: Sequence[tuple[np.ndarray, np.ndarray, Piece]],
             shared: bool = True) -> int:
        """The mesh ``key`` (library hash, name), defined from ``parts`` (vertices,
        faces, piece) the first time (every time unless ``shared``): one primitive per
        piece."""
        if shared and key in self._meshes:
            return self._meshes[key]
        prims = []
        for v, f, piece in parts:
            pos = np.ascontiguousarray(v, dtype=np.float32)
            idx = np.ascontiguousarray(f, dtype=np.uint32).ravel()
            position = self._accessor(pos, ARRAY_BUFFER, min=pos.min(axis=0).tolist(),
                                      max=pos.max(axis=0).tolist())
            indices = self._accessor(idx, ELEMENT_ARRAY_BUFFER)
            prims.append({"attributes": {"POSITION": position}, "indices": indices,
                          "material": self.material(piece), "mode": 4})
        self.doc["meshes"].append({"name": key[1], "primitives": prims})
        self._meshes[key] = len(self.doc["meshes"]) - 1
        return self._meshes[key]

    def node(self, name: str, *, children: Sequence[int] = (), extras: dict | None = None,
             **fields: Any) -> int:
        node: dict[str, Any] = {"name": name, **fields}
        if children:
            node["children"] = list(children)
        if extras:
            node["extras"] = {"citysynth": extras}
        self.doc["nodes"].append(node)
        return len(self.doc["nodes"]) - 1

    # --- layouts ------------------------------------------------------------------
    def layout(self, lay: Layout, db: PartDB, name: str | None = None, **fields: Any) -> int:
        """The layout's subtree (in its own Z-up frame); its root node's index
        (``fields``: more of the root node's, e.g. the Y-up rotation)."""
        labels = instance_labels(lay)
        members: dict[tuple[int, str], list[int]] = {}
        for inst, label in zip(lay.instances, labels, strict=True):
            idx = self._instance(inst, label, db)
            members.setdefault((inst.structure, stage_group(inst)), []).append(idx)
        by_structure: dict[int, list[tuple[str, list[int]]]] = {}
        for (s, group), nodes in sorted(members.items(), key=_group_order):
            by_structure.setdefault(s, []).append((group, nodes))
        structures = []
        for si, st in enumerate(lay.structures):   # (each sorting every group was
            # quadratic: a street of 8,000 runs spent 7.5 s in it)
            groups = [self.node(group, children=nodes, extras=_stage_facts(st, group))
                      for group, nodes in by_structure.get(si, [])]
            structures.append(self.node(structure_group(si), children=groups, extras={
                "name": st.get("name"), "cost": st["cost"], "met": st.get("resources"),
                "asked": st.get("asked")}))
        infill = [self.node(infill_name(n), mesh=self.mesh(
                      (db.library_hash, f"{lay.name}/{infill_name(n)}"),
                      [(p.vertices, p.faces, p) for p in infill_pieces(fill, db)], shared=False),
                      extras={"infill": True, "part": fill.part, "z": fill.z})
                  for n, fill in enumerate(lay.infill)]
        return self.node(name or lay.name, children=structures + infill,
                         extras=layout_facts(lay), **fields)

    def _instance(self, inst: Instance, label: str, db: PartDB) -> int:
        pieces = prototype_pieces(db, inst)
        extras = {"part": inst.part, "class": inst.cls, "prototype": inst.proto,
                  "structure": inst.structure}
        extras.update({"stage": inst.stage} if inst.stage is not None else {"key": inst.key})
        if not pieces:      # cut wholly away at an acute nose: a node without a mesh
            return self.node(label, extras=extras)
        if sheared(inst):   # its own geometry, baked into the layout frame
            parts = [(*place(p, inst), p) for p in pieces]
            mesh = self.mesh((db.library_hash, f"{inst.proto}@{label}"), parts, shared=False)
            return self.node(label, mesh=mesh, extras=extras)
        mesh = self.mesh((db.library_hash, inst.proto),
                         [(p.vertices, p.faces, p) for p in pieces])
        matrix = trs_matrix(inst)   # the identity is the default (the validator's
        # NODE_MATRIX_DEFAULT): not written
        placed: dict[str, Any] = {} if matrix == IDENTITY else {"matrix": matrix}
        return self.node(label, mesh=mesh, extras=extras, **placed)

    def scene(self, name: str, root: int) -> None:
        self.doc["scenes"].append({"name": name, "nodes": [root]})

    def glb(self) -> bytes:
        """The binary glTF: header, JSON chunk (space-padded), BIN chunk (zero-padded)."""
        self.bin.extend(b"\0" * (-len(self.bin) % 4))
        doc = {k: v for k, v in self.doc.items() if v != []}
        doc["buffers"] = [{"byteLength": len(self.bin)}]
        text = json.dumps(doc, sort_keys=True, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        total = 12 + 8 + len(text) + 8 + len(self.bin)
        return b"".join([struct.pack("<4sII", b"glTF", 2, total),
                         struct.pack("<I4s", len(text), b"JSON"), text,
                         struct.pack("<I4s", len(self.bin), b"BIN\0"), bytes(self.bin)])


def _group_order(item: tuple[tuple[int, str], list[int]]) -> tuple[int, int, str]:
    """Structures in order, their key points first, then their stages in order."""
    (s, group), _nodes = item
    return s, 0 if group == "keys" else 1, group


def _stage_facts(st: dict, group: str) -> dict:
    if group == "keys":
        return {"keys": st.get("keys")}
    stage = st["stages"][int(group.removeprefix("stage_"))]
    return {k: stage.get(k) for k in ("asked", "met", "stretch", "length", "parts")}


def layout_facts(lay: Layout) -> dict:
    """What a layout's root says in a DCC: the same facts as its USD root."""
    return {"schema": "citysynth.layout", "name": lay.name, "rank": lay.rank,
            "cost": lay.cost, "style": lay.style, "library": lay.library["name"],
            "library_hash": lay.library["hash"], "parts_used": lay.parts_used(),
            "constraints_met": constraints_met(lay), "frame": lay.frame,
            "georeference": georeference(lay.frame)}


def write_glb(lay: Layout, db: PartDB, path: str | Path) -> Path:
    builder = GlbBuilder()
    builder.scene(lay.name, builder.layout(lay, db, rotation=Z_UP_TO_Y_UP))
    with atomic_path(path) as tmp:
        tmp.write_bytes(builder.glb())
    return Path(path)


def write_city_glb(path: str | Path, layouts: Sequence[tuple[str, Layout, PartDB]],
                   name: str = "City", extras: dict | None = None) -> Path:
    """One GLB of several layouts in one frame (a city's blocks): each under a node
    named for it, the parts of one library shared between all."""
    builder = GlbBuilder()
    nodes = [builder.layout(lay, db, name=child) for child, lay, db in layouts]
    builder.scene(name, builder.node(name, children=nodes, rotation=Z_UP_TO_Y_UP,
                                     extras=extras))
    with atomic_path(path) as tmp:
        tmp.write_bytes(builder.glb())
    return Path(path)
