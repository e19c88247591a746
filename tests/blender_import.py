"""Import a USD or GLB file into Blender (the ``bpy`` package) and print what an artist
would see, as one JSON object: every object (name, type, parent, its world-space
bounds, materials, custom properties from ``userProperties`` or glTF ``extras``) and
every material, and every mesh as drawn (world-space bounds). Run by
tests/test_blender.py in its own interpreter (the venv that ``make`` builds in
build/bpy: bpy carries its own USD, which must not meet usd-core's in one process):

    build/bpy/bin/python tests/blender_import.py FILE.usda|FILE.glb
"""

from __future__ import annotations

import json
import os
import sys

import bpy
import numpy as np


def _box(obj, matrix) -> list[list[float]] | None:
    """The world-space bounds of the mesh's vertices (not of its transformed bounding
    box, which a rotation or a shear would widen)."""
    if obj.type != "MESH" or not obj.data.vertices:
        return None
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    m = np.array(matrix)
    pts = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    return [pts.min(axis=0).tolist(), pts.max(axis=0).tolist()]


def _instances() -> list[dict]:
    """Every mesh the evaluated scene shows, as Blender draws it (collection instances
    of USD prototypes resolved): its object and world-space bounds."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    out = []
    for inst in depsgraph.object_instances:
        box = _box(inst.object, inst.matrix_world)
        if box is not None:
            out.append({"object": inst.object.name, "bounds": box,
                        "instance": inst.is_instance})
    return out


def _props(obj) -> dict:
    out = {}
    for key in obj.keys():
        value = obj[key]
        if isinstance(value, int | float | str | bool):
            out[key] = value
        elif hasattr(value, "to_dict"):
            out[key] = value.to_dict()
        elif hasattr(value, "to_list"):
            out[key] = value.to_list()
    return out


def main(path: str) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.endswith(".glb"):
        bpy.ops.import_scene.gltf(filepath=path)
    else:
        # the library's materials are one prim each in the composed stage's prototypes;
        # Blender keeps one material per name with this option
        bpy.ops.wm.usd_import(filepath=path, mtl_name_collision_mode="REFERENCE_EXISTING")
    objects = [{"name": o.name, "type": o.type, "parent": o.parent.name if o.parent else None,
                "props": _props(o),
                "collection": o.instance_collection.name if o.instance_collection else None,
                "materials": [s.material.name for s in o.material_slots if s.material]}
               for o in bpy.context.scene.objects]
    materials = sorted(m.name for m in bpy.data.materials if m.users)
    print(json.dumps({"objects": objects, "drawn": _instances(), "materials": materials}))


if __name__ == "__main__":
    main(sys.argv[1])
    sys.stdout.flush()
    os._exit(0)   # bpy 4.2 as a module may crash while tearing down after some imports
