"""USD through usd-core: part prototypes, one layer per layout, a city stage.

Layout of the files (all paths relative, so a run folder can be moved):

- ``parts/<part>.usdc``: each part once, a ``component`` model with one Mesh per
  material (flat face normals, extent) and a ``UsdPreviewSurface`` material each, in
  the part's placement frame. Binary crate: these hold the triangles.
- ``<layout>.usda``: one layer per block or building. An ``assembly`` prim, a ``group``
  per structure and per stage, and one prim per part instance: ``instanceable`` and
  referencing its part file, with its placement as one ``xformOp:transform`` (a stretch,
  a mirror or a corner's shear are all just matrices). The layout's metadata (part
  ids, cost, constraints asked and met, stretch) is ``customData``. Text, because it is
  small and people diff it.
- ``city.usda``: an ``assembly`` that references layout layers, each under an Xform.

Why scenegraph instancing rather than a PointInstancer: every instance stays a
selectable, nameable prim in a DCC (an artist can pick "stage 3, part 7", read its
customData, or de-instance it to edit), placements may be any affine matrix (a
PointInstancer has no shear, which adapted corners need), and USD still shares one
prototype per part, so the file holds each mesh once and a block layer only holds
matrices. All layers say ``upAxis = "Z"`` and ``metersPerUnit = 1`` and set a
``defaultPrim``; :func:`validate` runs every UsdValidation validator usd-core has.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Gf, Kind, Sdf, Tf, Usd, UsdGeom, UsdShade, UsdValidation, Vt

from citysynth.export.layout import Instance, Layout
from citysynth.export.prototypes import prototype_pieces
from citysynth.parts_db import PartDB
from citysynth.parts_db.files import atomic_path

PARTS_DIR = "parts"


def prim_name(text: str) -> str:
    """A valid, readable prim name for an id ("classic_mid_2.6_4s" -> "classic_mid_2_6_4s")."""
    return Tf.MakeValidIdentifier(text)


def _stage_metadata(layer: Sdf.Layer, default_prim: str) -> None:
    layer.defaultPrim = default_prim
    layer.pseudoRoot.SetInfo(UsdGeom.Tokens.upAxis, UsdGeom.Tokens.z)
    layer.pseudoRoot.SetInfo(UsdGeom.Tokens.metersPerUnit, 1.0)


def _vt(x):
    """Python data -> values customData accepts (lists become typed arrays)."""
    if isinstance(x, dict):
        return {str(k): _vt(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        if all(isinstance(v, str) for v in x):
            return Vt.StringArray(list(x))
        if all(isinstance(v, int | float) and not isinstance(v, bool) for v in x):
            return Vt.DoubleArray([float(v) for v in x])
        return Vt.StringArray([str(v) for v in x])
    if isinstance(x, np.generic):
        return x.item()
    return x


def _export(layer: Sdf.Layer, path: Path) -> None:
    """Write ``layer`` to ``path`` atomically (a temporary file of the same format in
    the same folder, then a rename), so a killed run never leaves half a file."""
    with atomic_path(path) as tmp:
        if not layer.Export(str(tmp)):
            raise OSError(f"usd-core could not write {path}")


# --- parts ---------------------------------------------------------------------------

def part_file(part_id: str) -> str:
    return f"{PARTS_DIR}/{prim_name(part_id)}.usdc"


def write_part(db: PartDB, inst: Instance, path: Path) -> None:
    """The prototype ``inst`` shows (its part, or the part cut at a joint) as a
    component model with a mesh and a preview material per colour."""
    part = next(p for p in db.parts if p.id == inst.part)
    stage = Usd.Stage.CreateInMemory()
    name = prim_name(inst.proto)
    root = UsdGeom.Xform.Define(stage, f"/{name}")
    model = Usd.ModelAPI(root.GetPrim())
    model.SetKind(Kind.Tokens.component)
    root.GetPrim().SetCustomDataByKey("citysynth:part", part.id)
    root.GetPrim().SetCustomDataByKey("citysynth:class", part.cls)
    root.GetPrim().SetCustomDataByKey("citysynth:library", db.library_hash)
    if inst.cut is not None:
        root.GetPrim().SetCustomDataByKey("citysynth:cut", _vt(inst.cut.to_dict()))
    looks = UsdGeom.Scope.Define(stage, f"/{name}/Looks")
    for i, piece in enumerate(prototype_pieces(db, inst)):
        label = prim_name(f"{piece.name}_{i}")
        mesh = UsdGeom.Mesh.Define(stage, f"/{name}/{label}")
        pts = piece.vertices.astype(np.float32)
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(
            np.full(len(piece.faces), 3, dtype=np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(
            piece.faces.astype(np.int32).ravel()))
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(piece.normals.astype(np.float32)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.uniform)
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*pts.min(axis=0).tolist()),
                                             Gf.Vec3f(*pts.max(axis=0).tolist())]))
        material = _preview_material(stage, looks.GetPath().AppendChild(label), piece)
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    stage.SetDefaultPrim(root.GetPrim())
    layer = stage.GetRootLayer()
    _stage_metadata(layer, name)
    _export(layer, path)


def _preview_material(stage, path: Sdf.Path, piece) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path.AppendChild("PreviewSurface"))
    shader.CreateIdAttr("UsdPreviewSurface")
    rgb = [c / 255.0 for c in piece.rgba[:3]]
    glass = piece.name.startswith("window")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rgb))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.15 if glass else 0.8)
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(piece.rgba[3] / 255.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def ensure_parts(db: PartDB, prototypes: dict[str, Instance], out_dir: Path) -> list[Path]:
    """Write the prototype files a layer references that are not there yet (a part
    file's name carries no library hash: a run folder belongs to one library, see
    ``write_layout``; a cut prototype's name carries its cut's)."""
    written = []
    for proto, inst in sorted(prototypes.items()):
        path = out_dir / part_file(proto)
        if not path.is_file():
            write_part(db, inst, path)
            written.append(path)
    return written


# --- layouts and cities ----------------------------------------------------------------

def write_layout(lay: Layout, db: PartDB, path: str | Path) -> Path:
    """The layout's layer at ``path`` (and its part files beside it, in ``parts/``)."""
    path = Path(path)
    ensure_parts(db, lay.prototypes(), path.parent)
    layer = Sdf.Layer.CreateAnonymous(".usda")
    root_name = prim_name(lay.name)
    with Sdf.ChangeBlock():
        root = Sdf.PrimSpec(layer, root_name, Sdf.SpecifierDef, "Xform")
        root.kind = Kind.Tokens.assembly
        root.customData = _vt({"citysynth": {
            "schema": "citysynth.layout", "rank": lay.rank, "cost": lay.cost,
            "style": lay.style, "library": lay.library["name"],
            "library_hash": lay.library["hash"], "parts_used": lay.parts_used(),
            "frame": lay.frame}})
        groups: dict[tuple, Sdf.PrimSpec] = {}
        for si, st in enumerate(lay.structures):
            sgroup = Sdf.PrimSpec(root, f"structure_{si:02d}", Sdf.SpecifierDef, "Xform")
            sgroup.kind = Kind.Tokens.group
            data = {"name": st["name"], "cost": st["cost"], "met": st["resources"]}
            if "asked" in st:
                data["asked"] = {k: list(v) for k, v in st["asked"].items()}
            sgroup.customData = _vt({"citysynth": data})
            keys = Sdf.PrimSpec(sgroup, "keys", Sdf.SpecifierDef, "Xform")
            keys.kind = Kind.Tokens.group
            groups[(si, None)] = keys
            for s, stage in enumerate(st["stages"]):
                g = Sdf.PrimSpec(sgroup, f"stage_{s:03d}", Sdf.SpecifierDef, "Xform")
                g.kind = Kind.Tokens.group
                g.customData = _vt({"citysynth": {
                    "asked": {k: list(v) for k, v in stage["asked"].items()},
                    "met": stage["met"], "stretch": stage["stretch"],
                    "length": stage["length"], "parts": stage["parts"]}})
                groups[(si, s)] = g
        counters: dict[tuple, int] = {}
        for inst in lay.instances:
            # fillers count along their stage; a key point has one part, or two (a
            # mitre: the end parts on either side of the corner)
            gkey = (inst.structure, inst.stage, inst.key)
            n = counters.get(gkey, 0)
            counters[gkey] = n + 1
            label = f"part_{n:03d}" if inst.stage is not None else \
                f"key_{inst.key:03d}" + (f"_{n}" if n else "")
            spec = Sdf.PrimSpec(groups[(inst.structure, inst.stage)], label,
                                Sdf.SpecifierDef, "Xform")
            spec.instanceable = True
            spec.referenceList.Prepend(Sdf.Reference(f"./{part_file(inst.proto)}"))
            spec.customData = _vt({"citysynth": {"part": inst.part}})
            m = inst.matrix().T   # USD multiplies row vectors: translation in the last row
            op = Sdf.AttributeSpec(spec, "xformOp:transform", Sdf.ValueTypeNames.Matrix4d)
            op.default = Gf.Matrix4d(*m.ravel().tolist())
            order = Sdf.AttributeSpec(spec, "xformOpOrder", Sdf.ValueTypeNames.TokenArray,
                                      Sdf.VariabilityUniform)
            order.default = Vt.TokenArray(["xformOp:transform"])
        _stage_metadata(layer, root_name)
        layer.customLayerData = {"generator": "citysynth"}
    _export(layer, path)
    return path


def write_city(path: str | Path, layers: list[tuple], name: str = "City") -> Path:
    """A stage at ``path`` referencing layout layers: ``layers`` holds (prim name, path
    relative to ``path``'s folder[, (dx, dy) offset]), one Xform each under an
    ``assembly``. Layouts of one city share its frame and need no offset."""
    path = Path(path)
    layer = Sdf.Layer.CreateAnonymous(".usda")
    with Sdf.ChangeBlock():
        root = Sdf.PrimSpec(layer, prim_name(name), Sdf.SpecifierDef, "Xform")
        root.kind = Kind.Tokens.assembly
        for child, rel, *offset in layers:
            spec = Sdf.PrimSpec(root, prim_name(child), Sdf.SpecifierDef, "Xform")
            spec.referenceList.Prepend(Sdf.Reference(f"./{rel}"))
            if offset:
                op = Sdf.AttributeSpec(spec, "xformOp:translate", Sdf.ValueTypeNames.Double3)
                op.default = Gf.Vec3d(float(offset[0][0]), float(offset[0][1]), 0.0)
                order = Sdf.AttributeSpec(spec, "xformOpOrder", Sdf.ValueTypeNames.TokenArray,
                                          Sdf.VariabilityUniform)
                order.default = Vt.TokenArray(["xformOp:translate"])
        _stage_metadata(layer, prim_name(name))
        layer.customLayerData = {"generator": "citysynth"}
    _export(layer, path)
    return path


def validate(path: str | Path) -> list[str]:
    """Every UsdValidation validator usd-core registers, on the stage at ``path``:
    the errors as "validator: message" lines (empty when clean; warnings ignored)."""
    registry = UsdValidation.ValidationRegistry()
    ctx = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    stage = Usd.Stage.Open(str(path))
    out = []
    for err in ctx.Validate(stage):
        if err.GetType() == UsdValidation.ValidationErrorType.Error:
            out.append(f"{err.GetValidator().GetMetadata().name}: {err.GetMessage()}")
    return sorted(out)
