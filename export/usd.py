"""USD through usd-core: part prototypes, one layer per layout, a city stage.

Layout of the files (all paths relative, so a run folder can be moved):

- ``parts/<part>.usdc``: each part once, a ``component`` model with one Mesh per
  material (flat face normals, extent) and a ``UsdPreviewSurface`` material each, in
  the part's placement frame. Binary crate: these hold the triangles.
- ``<name>.cuts.usdc``: beside a building's or block's layers (its k best), the
  prototypes they cut at their own joints and folds (``/Cuts/<prototype>``,
  components like the part files), one file for all its ranks.
- ``<layout>.usda``: one layer per block or building. An ``assembly`` prim, a ``group``
  per structure and per stage, and one prim per part instance: ``instanceable`` and
  referencing its part file (or its cut prototype), with its placement as one
  ``xformOp:transform`` (a stretch, a mirror or a corner's shear are all just
  matrices). The layout's metadata (part ids, cost, constraints asked and met,
  stretch) is ``customData``. Text, because it is small and people diff it.
- ``city.usda``: an ``assembly`` that references layout layers, each under an Xform.

Every layout layer's root, variant stage's root and city block prim carries an
``extentsHint`` (``GeomModelAPI``): the box around what it shows (all its ranks, for a
variant prim), so a DCC frames, culls and draws as boxes the blocks of a city it opened
unloaded without loading them.

Why scenegraph instancing rather than a PointInstancer: every instance stays a
selectable, nameable prim in a DCC (an artist can pick "stage 3, part 7", read its
customData, or de-instance it to edit), a placement may mirror and stretch (a
sheared one, an adapted corner, keeps its shear in a prototype of its own, as no DCC
reads a matrix's shear alike: :mod:`.shear`), and USD still shares one prototype per
part, so the file holds each mesh once and a block layer only holds matrices. All
layers say ``upAxis = "Z"`` and ``metersPerUnit = 1`` and set a ``defaultPrim``;
:func:`validate` runs every UsdValidation validator usd-core has.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path

import numpy as np
from pxr import Gf, Kind, Sdf, Tf, Usd, UsdGeom, UsdShade, UsdValidation, Vt

from citysynth.export.assemble import extent
from citysynth.export.infill import infill_pieces
from citysynth.export.layout import Infill, Instance, Layout
from citysynth.export.materials import (
    georeference,
    linear_rgb,
    material_name,
    opacity,
    rgba_linear,
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
from citysynth.export.shear import baked_prototype, perpendicular_y, sheared_pieces
from citysynth.parts_db import PartDB
from citysynth.parts_db.files import atomic_path
from citysynth.parts_db.geometry import Piece

PARTS_DIR = "parts"
MATERIALS_DIR = "materials"   # in PARTS_DIR: one small layer per library material
CUTS_SUFFIX = ".cuts.usdc"    # beside a layer <stem>.usda: the prototypes it cut
CUTS_PRIM = "Cuts"            # their parent prim there
USER = "userProperties:citysynth:"   # attributes Blender, Maya and Houdini show


def prim_name(text: str) -> str:
    """A valid, readable prim name for an id ("classic_mid_2.6_4s" -> "classic_mid_2_6_4s";
    "17" -> "_17": usd-core's ``Tf.MakeValidIdentifier`` would replace a leading digit,
    and blocks "17" and "27" would both be "_7")."""
    return Tf.MakeValidIdentifier("_" + text if text[:1].isdigit() else text)


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
        try:
            ok = layer.Export(str(tmp))
        except Tf.ErrorException as exc:   # a full disk, a vanished folder: the machine
            raise _write_error(path, exc) from None
        if not ok:
            raise OSError(errno.EIO, "usd-core could not write the file", str(path))


def _write_error(path: Path, exc: Exception) -> OSError:
    """usd-core's failure to write as the OSError the command line reports in one line
    (exit 2): its errno when the message names one (no space left, no permission)."""
    text = str(exc)
    for code in (errno.ENOSPC, errno.EACCES, errno.EROFS, errno.EDQUOT):
        if os.strerror(code) in text:
            return OSError(code, os.strerror(code), str(path))
    return OSError(errno.EIO, "usd-core could not write the file", str(path))


# --- parts ---------------------------------------------------------------------------

def part_file(part_id: str) -> str:
    return f"{PARTS_DIR}/{prim_name(part_id)}.usdc"


def material_file(name: str) -> str:
    """A library material's layer, relative to a part file."""
    return f"{MATERIALS_DIR}/{name}.usda"


def cuts_file(folder: Path, name: str) -> Path:
    """The file in ``folder`` that holds the prototypes the layouts named ``name`` (a
    building's or block's k best) cut at their own joints, ``<name>.cuts.usdc``."""
    return folder / f"{name}{CUTS_SUFFIX}"


def _prototype_spec(parent: Sdf.Layer | Sdf.PrimSpec, db: PartDB, inst: Instance,
                    parts_dir: str) -> Sdf.PrimSpec:
    """The prototype ``inst`` shows (its part, or the part cut at a joint) as a
    component model with a mesh per piece, each bound to its library material: a
    ``Looks/<material>`` prim referencing the shared material layer in ``parts_dir``
    (relative to the file holding the prototype; a prototype cannot see outside itself,
    so each holds a reference, and every one of them is the same material).
    ``displayColor`` (linear) for viewers that skip materials.

    Written as layer specs (Sdf), not through a stage: a city writes tens of cut
    prototypes a block, and a stage (composing, then copying its layer so the material
    references are added where nothing tries to resolve them) took 40 % more time for
    the same composed result."""
    part = db.part(inst.part)
    h = inst.shear
    root = Sdf.PrimSpec(parent, prim_name(baked_prototype(inst)), Sdf.SpecifierDef, "Xform")
    root.kind = Kind.Tokens.component
    data: dict = {"part": part.id, "class": part.cls, "library": db.library_hash}
    if inst.cut is not None:
        data["cut"] = _vt(inst.cut.to_dict())
    if h:
        data["shear"] = h
    root.customData = {"citysynth": data}
    _meshes_spec(root, sheared_pieces(prototype_pieces(db, inst), h), parts_dir)
    return root


def _own_prototype(inst: Instance) -> bool:
    """Whether the instance's prototype is the layer's own (in its cuts file): cut at a
    joint, or sheared; else it is a library part's file."""
    return inst.cut is not None or bool(inst.shear)


def _meshes_spec(root: Sdf.PrimSpec, pieces: Sequence[Piece], parts_dir: str) -> None:
    """A mesh per piece under ``root`` (``<piece>_<i>``), each bound to its library
    material: a ``Looks/<material>`` prim referencing the shared material layer in
    ``parts_dir``, one per material. No pieces (a part a sharp corner's two cuts leave
    nothing of) make no ``Looks`` either: an empty scope is clutter in a DCC's outliner."""
    if not pieces:
        return
    looks = Sdf.PrimSpec(root, "Looks", Sdf.SpecifierDef, "Scope")
    bound: dict[str, Sdf.Path] = {}
    for i, piece in enumerate(pieces):
        name = material_name(piece)
        if name not in bound:
            bound[name] = _material_spec(looks, name, parts_dir)
        _mesh_spec(root, prim_name(f"{piece.name}_{i}"), piece, bound[name])


def write_part(db: PartDB, inst: Instance, path: Path) -> None:
    """A library part's prototype file ``parts/<part>.usdc`` (shared by every layer)."""
    layer = Sdf.Layer.CreateAnonymous(".usdc")
    with Sdf.ChangeBlock():
        root = _prototype_spec(layer, db, inst, ".")
        _stage_metadata(layer, root.name)
    _export(layer, path)


def write_cuts(db: PartDB, prototypes: dict[str, Instance], path: Path) -> None:
    """A building's or block's cut prototypes in one file: each ``/Cuts/<prototype>``
    under a ``group`` model. A cut is made at one joint of one building, so no other
    building shares it; one file a building instead of one a cut spares the file system
    tens of thousands of files in a city, and a city a millisecond a cut."""
    layer = Sdf.Layer.CreateAnonymous(".usdc")
    with Sdf.ChangeBlock():
        root = Sdf.PrimSpec(layer, CUTS_PRIM, Sdf.SpecifierDef, "Xform")
        root.kind = Kind.Tokens.group
        for _proto, inst in sorted(prototypes.items()):
            _prototype_spec(root, db, inst, f"./{PARTS_DIR}")
        _stage_metadata(layer, CUTS_PRIM)
    _export(layer, path)


def _spec(prim: Sdf.PrimSpec, name: str, type_name, value, interpolation: str = "",
          variability=Sdf.VariabilityVarying) -> None:
    """An attribute of ``prim`` as its schema declares it (not custom)."""
    attr = Sdf.AttributeSpec(prim, name, type_name, variability)
    attr.default = value
    if interpolation:
        attr.SetInfo("interpolation", interpolation)


def _mesh_spec(parent: Sdf.PrimSpec, label: str, piece: Piece, material: Sdf.Path) -> None:
    """A UsdGeom Mesh of ``piece`` (triangles, flat normals, extent, display colour and
    opacity) bound to ``material``."""
    t = Sdf.ValueTypeNames
    mesh = Sdf.PrimSpec(parent, label, Sdf.SpecifierDef, "Mesh")
    pts, indices, normals, extent = piece.float32_arrays()
    _spec(mesh, "points", t.Point3fArray, Vt.Vec3fArray.FromNumpy(pts))
    _spec(mesh, "faceVertexCounts", t.IntArray, _triangle_counts(len(piece.faces)))
    _spec(mesh, "faceVertexIndices", t.IntArray, Vt.IntArray.FromNumpy(indices))
    _spec(mesh, "normals", t.Normal3fArray, Vt.Vec3fArray.FromNumpy(normals),
          UsdGeom.Tokens.uniform)
    _spec(mesh, "subdivisionScheme", t.Token, UsdGeom.Tokens.none,
          variability=Sdf.VariabilityUniform)
    _spec(mesh, "extent", t.Float3Array, Vt.Vec3fArray.FromNumpy(extent))
    _spec(mesh, "primvars:displayColor", t.Color3fArray, _display_color(piece.rgba),
          UsdGeom.Tokens.constant)
    if piece.rgba[3] < 255:
        _spec(mesh, "primvars:displayOpacity", t.FloatArray,
              Vt.FloatArray([opacity(piece)]), UsdGeom.Tokens.constant)
    mesh.SetInfo("apiSchemas", _BINDING_API)
    binding = Sdf.RelationshipSpec(mesh, "material:binding", False)
    binding.targetPathList.Prepend(material)


_BINDING_API = Sdf.TokenListOp.Create(prependedItems=["MaterialBindingAPI"])


@lru_cache(maxsize=1024)
def _triangle_counts(faces: int) -> Vt.IntArray:
    """``faceVertexCounts`` of ``faces`` triangles (made once per face count; a Vt
    array is a shared value, so each mesh's attribute holds the same one)."""
    return Vt.IntArray.FromNumpy(np.full(faces, 3, dtype=np.int32))


@lru_cache(maxsize=256)
def _display_color(rgba: tuple[int, int, int, int]) -> Vt.Vec3fArray:
    """A piece colour's ``displayColor`` (linear), made once per colour: a city writes
    hundreds of meshes a block in a few dozen colours."""
    return Vt.Vec3fArray([Gf.Vec3f(*rgba_linear(rgba))])


def _material_spec(looks: Sdf.PrimSpec, name: str, parts_dir: str) -> Sdf.Path:
    """``Looks/<name>``, a Material referencing the library's material layer (made
    once per prototype by the caller)."""
    spec = Sdf.PrimSpec(looks, name, Sdf.SpecifierDef, "Material")
    spec.referenceList.Prepend(Sdf.Reference(f"{parts_dir}/{material_file(name)}"))
    return spec.path


def write_material(piece: Piece, path: Path) -> None:
    """A library material's layer: one ``UsdPreviewSurface`` material (diffuse colour
    in linear space, roughness, opacity), its default prim."""
    name = material_name(piece)
    stage = Usd.Stage.CreateInMemory()
    material = UsdShade.Material.Define(stage, f"/{name}")
    shader = UsdShade.Shader.Define(stage, f"/{name}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(
        Gf.Vec3f(*linear_rgb(piece)))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness(piece))
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(opacity(piece))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    material.GetPrim().SetCustomDataByKey("citysynth:material", name)
    stage.SetDefaultPrim(material.GetPrim())
    layer = stage.GetRootLayer()
    _stage_metadata(layer, name)
    _export(layer, path)


def _library_refs(db: PartDB, prototypes: dict[str, Instance], more: Sequence[Piece] = ()
                  ) -> tuple[dict[str, Instance], dict[str, Piece]]:
    """The library files a layer of ``prototypes`` (and ``more`` pieces, a roof
    infill's) references: each uncut part's file (relative to the layer's folder) with
    an instance of it, and each material it binds, cut or not, with a piece of it."""
    materials: dict[str, Piece] = {material_name(p): p for p in more}
    parts: dict[str, Instance] = {}
    for proto, inst in sorted(prototypes.items()):
        for piece in prototype_pieces(db, inst):
            materials.setdefault(material_name(piece), piece)
        if not _own_prototype(inst):
            parts[part_file(proto)] = inst
    return parts, dict(sorted(materials.items()))


def ensure_parts(db: PartDB, prototypes: dict[str, Instance], out_dir: Path,
                 more: Sequence[Piece] = ()) -> list[Path]:
    """Write the library part files (``parts/<part>.usdc``) a layer references that
    are not there yet, and the library materials its prototypes bind, cut or not, and
    ``more`` pieces bind (a roof infill's; a part file's name carries no library hash:
    a run folder belongs to one library, see ``write_layout``). Cut prototypes go in
    the layer's own file, :func:`write_cuts`."""
    written = []
    parts, materials = _library_refs(db, prototypes, more)
    present = _file_names(out_dir / PARTS_DIR)
    for name, inst in parts.items():
        path = out_dir / name
        if path.name not in present or not _of_library(path, db.library_hash):
            write_part(db, inst, path)
            written.append(path)
            _OF_LIBRARY[str(path)] = db.library_hash
    looks = _file_names(out_dir / PARTS_DIR / MATERIALS_DIR)
    for name, piece in materials.items():
        mat = out_dir / PARTS_DIR / material_file(name)
        if mat.name not in looks or not _whole(mat):
            write_material(piece, mat)
            written.append(mat)
    return written


def library_files(layouts: Sequence[Layout], db: PartDB) -> list[str]:
    """The library files the layers of ``layouts`` reference, relative to their folder
    (``parts/<part>.usdc``, ``parts/materials/<material>.usda``): files shared by every
    block of a city, so no block's marker vouches for them by hash. A resumed city
    checks them (:func:`library_file_ok`): one deleted or emptied after a run made
    every block that used it show nothing, and the rerun rewrote none."""
    parts, materials = _library_refs(db, _prototypes(layouts), [
        p for lay in layouts for f in lay.infill for p in infill_pieces(f, db)])
    return [*parts, *(f"{PARTS_DIR}/{material_file(m)}" for m in materials)]


def library_file_ok(path: Path, library_hash: str) -> bool:
    """Whether ``path`` (one of :func:`library_files`) is there, not empty, and (a
    part file) written from the library of ``library_hash``."""
    return _whole(path) and (path.suffix != ".usdc" or _of_library(path, library_hash))


def _whole(path: Path) -> bool:
    """Whether ``path`` is a file with something in it (an emptied one is written again)."""
    try:
        return path.is_file() and path.stat().st_size > 0
    except OSError:
        return False


_OF_LIBRARY: dict[str, str] = {}   # part file -> the library hash it was found to hold


def _of_library(path: Path, library_hash: str) -> bool:
    """Whether the part file ``path`` was written from the library of ``library_hash``
    (read once a process). A folder written again with the library's meshes edited, or
    another library of the same part ids, kept the old part files: the layers showed
    the old meshes, and ``citysynth diff`` saw nothing."""
    key = str(path)
    if key not in _OF_LIBRARY:
        try:
            layer = Sdf.Layer.OpenAsAnonymous(key)
        except Tf.ErrorException:
            layer = None
        root = layer.GetPrimAtPath(layer.defaultPrim) if layer is not None and \
            layer.defaultPrim else None
        data = root.customData.get("citysynth", {}) if root is not None else {}
        _OF_LIBRARY[key] = str(data.get("library", ""))
    return _OF_LIBRARY[key] == library_hash


def _file_names(folder: Path) -> set[str]:
    """The names of the files in ``folder`` (none when it is missing): one listing
    instead of a stat per part, which a city block asks about a hundred times."""
    try:
        with os.scandir(folder) as entries:
            return {e.name for e in entries if e.is_file()}
    except (FileNotFoundError, NotADirectoryError):
        return set()


# --- layouts and cities ----------------------------------------------------------------

def _user(spec: Sdf.PrimSpec, name: str, value, type_name) -> None:
    """A ``userProperties:citysynth:<name>`` attribute (custom), which DCCs list as the
    prim's user or custom properties."""
    attr = Sdf.AttributeSpec(spec, USER + name, type_name)
    attr.custom = True
    attr.default = value


def _xform(spec: Sdf.PrimSpec, name: str, type_name, value) -> None:
    op = Sdf.AttributeSpec(spec, name, type_name)
    op.default = value
    order = Sdf.AttributeSpec(spec, "xformOpOrder", Sdf.ValueTypeNames.TokenArray,
                              Sdf.VariabilityUniform)
    order.default = _op_order(name)


@lru_cache(maxsize=8)
def _op_order(name: str) -> Vt.TokenArray:
    """``xformOpOrder`` naming one op (made once per op name)."""
    return Vt.TokenArray([name])


def _georeference(spec: Sdf.PrimSpec, frame: str) -> dict:
    """The frame's CRS (an identifier pyproj resolves, and the name when they differ)
    and origin (lon/lat) as attributes on ``spec``; the data."""
    geo = georeference(frame)
    if geo:
        _user(spec, "crs", geo["crs"], Sdf.ValueTypeNames.String)
        if "crs_name" in geo:
            _user(spec, "crs_name", geo["crs_name"], Sdf.ValueTypeNames.String)
        _user(spec, "origin", Gf.Vec2d(*geo["origin"]), Sdf.ValueTypeNames.Double2)
        if "origin_lon" in geo:
            _user(spec, "origin_lon", geo["origin_lon"], Sdf.ValueTypeNames.Double)
            _user(spec, "origin_lat", geo["origin_lat"], Sdf.ValueTypeNames.Double)
    return geo


def _layout_root(layer: Sdf.Layer, lay: Layout) -> Sdf.PrimSpec:
    root = Sdf.PrimSpec(layer, prim_name(lay.name), Sdf.SpecifierDef, "Xform")
    root.kind = Kind.Tokens.assembly
    met = constraints_met(lay)
    geo = _georeference(root, lay.frame)
    root.customData = _vt({"citysynth": {
        "schema": "citysynth.layout", "rank": lay.rank, "cost": lay.cost,
        "style": lay.style, "library": lay.library["name"],
        "library_hash": lay.library["hash"], "parts_used": lay.parts_used(),
        "frame": lay.frame, "constraints_met": met, "georeference": geo}})
    _user(root, "rank", lay.rank, Sdf.ValueTypeNames.Int)
    _user(root, "cost", float(lay.cost), Sdf.ValueTypeNames.Double)
    _user(root, "constraints_met", met, Sdf.ValueTypeNames.Bool)
    _user(root, "style", lay.style, Sdf.ValueTypeNames.String)
    _user(root, "parts_used", Vt.StringArray(lay.parts_used()), Sdf.ValueTypeNames.StringArray)
    return root


def _group(parent: Sdf.PrimSpec, name: str, data: dict) -> Sdf.PrimSpec:
    g = Sdf.PrimSpec(parent, name, Sdf.SpecifierDef, "Xform")
    g.kind = Kind.Tokens.group
    g.customData = _vt({"citysynth": data})
    return g


def _structure_groups(root: Sdf.PrimSpec, lay: Layout) -> dict[tuple, Sdf.PrimSpec]:
    """A group per structure, in it one per stage and one for the key points."""
    groups: dict[tuple, Sdf.PrimSpec] = {}
    for si, st in enumerate(lay.structures):
        data = {"name": st["name"], "cost": st["cost"], "met": st["resources"]}
        if "asked" in st:
            data["asked"] = {k: list(v) for k, v in st["asked"].items()}
        sgroup = _group(root, structure_group(si), data)
        _user(sgroup, "cost", float(st["cost"]), Sdf.ValueTypeNames.Double)
        groups[(si, "keys")] = _group(sgroup, "keys", {"keys": st.get("keys", [])})
        for s, stage in enumerate(st["stages"]):
            g = _group(sgroup, f"stage_{s:02d}", {
                "asked": {k: list(v) for k, v in stage["asked"].items()},
                "met": stage["met"], "stretch": stage["stretch"],
                "length": stage["length"], "parts": stage["parts"]})
            for res, value in sorted(stage["met"].items()):
                _user(g, f"met:{prim_name(res)}", float(value), Sdf.ValueTypeNames.Double)
            groups[(si, f"stage_{s:02d}")] = g
    return groups


def _prototype_reference(inst: Instance, cuts: str) -> Sdf.Reference:
    """A library part's file, or the layer's own prototype's prim (cut or sheared) in
    the file ``cuts``."""
    if not _own_prototype(inst):
        return Sdf.Reference(f"./{part_file(inst.proto)}")
    return Sdf.Reference(f"./{cuts}",
                         Sdf.Path.absoluteRootPath.AppendChild(CUTS_PRIM)
                         .AppendChild(prim_name(baked_prototype(inst))))


def write_layouts(layouts: Sequence[Layout], db: PartDB, paths: Sequence[str | Path]
                  ) -> list[Path]:
    """The layers of one building's or block's layouts (its k best: one name, one
    folder), each at its path, with the library part files they share (``parts/``) and
    one file of the prototypes any of them cut at its joints, ``<name>.cuts.usdc``
    (ranks mostly cut the same corners the same way): the layers' paths, then the cuts
    file's when there is one. An earlier run's files these do not replace are left to
    the caller's sweep (``pipeline.layouts``, a city block's own)."""
    files = [Path(p) for p in paths]
    folders, names = {p.parent for p in files}, {lay.name for lay in layouts}
    if len(folders) != 1 or len(names) != 1 or len(files) != len(layouts):
        raise ValueError("write_layouts: one path per layout, layouts of one name, one folder")
    folder, name = folders.pop(), names.pop()
    prototypes = _prototypes(layouts)
    infill = [[infill_pieces(f, db) for f in lay.infill] for lay in layouts]
    ensure_parts(db, prototypes, folder,
                 [p for fills in infill for pieces in fills for p in pieces])
    cuts = {p: i for p, i in prototypes.items() if _own_prototype(i)}
    cpath = cuts_file(folder, name)
    if cuts:
        write_cuts(db, cuts, cpath)
    written = [_write_layer(lay, path, cpath.name, fills, extent([lay], db))
               for lay, path, fills in zip(layouts, files, infill, strict=True)]
    return written + ([cpath] if cuts else [])


def _prototypes(layouts: Sequence[Layout]) -> dict[str, Instance]:
    """Every USD prototype the layouts show (ranks share most; see
    :func:`~citysynth.export.shear.baked_prototype`), with one instance of it."""
    prototypes: dict[str, Instance] = {}
    for lay in layouts:
        for inst in lay.instances:
            prototypes.setdefault(baked_prototype(inst), inst)
    return dict(sorted(prototypes.items()))


def write_layout(lay: Layout, db: PartDB, path: str | Path) -> Path:
    """One layout's layer at ``path`` (and the files it references beside it, see
    :func:`write_layouts`)."""
    return write_layouts([lay], db, [path])[0]


def _write_layer(lay: Layout, path: Path, cuts: str,
                 infill: Sequence[tuple[Piece, ...]] = (),
                 box: list[list[float]] | None = None) -> Path:
    """The layout's layer: prims ``<layout>/structure_00/stage_03/<part>_07`` (see
    :mod:`~citysynth.export.naming`), each instanceable and referencing its part's
    file, or its cut prototype in ``cuts`` (a file name in the same folder); and a
    footprint's roof infill, its pieces (``infill``, in the layout frame) as meshes of
    ``<layout>/infill_00`` (:func:`_infill_spec`); ``box``, its extent, the root's
    ``extentsHint``."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    root_name = prim_name(lay.name)
    with Sdf.ChangeBlock():
        root = _layout_root(layer, lay)
        extents_hint(root, box)
        groups = _structure_groups(root, lay)
        for inst, label in zip(lay.instances, instance_labels(lay), strict=True):
            spec = Sdf.PrimSpec(groups[(inst.structure, stage_group(inst))],
                                prim_name(label), Sdf.SpecifierDef, "Xform")
            spec.instanceable = True
            spec.referenceList.Prepend(_prototype_reference(inst, cuts))
            spec.customData = {"citysynth": {"part": inst.part}}
            _user(spec, "part", inst.part, Sdf.ValueTypeNames.String)
            _xform(spec, "xformOp:transform", Sdf.ValueTypeNames.Matrix4d, _usd_matrix(inst))
        for n, (fill, pieces) in enumerate(zip(lay.infill, infill, strict=True)):
            _infill_spec(root, infill_name(n), fill, pieces)
        _stage_metadata(layer, root_name)
        layer.customLayerData = {"generator": "citysynth"}
    _export(layer, path)
    return path


def _infill_spec(root: Sdf.PrimSpec, name: str, fill: Infill, pieces: tuple[Piece, ...]
                 ) -> None:
    """A roof infill as a component model (it is no instance: each is one of a kind)
    with a mesh per piece bound to its library material, as a prototype's are."""
    spec = Sdf.PrimSpec(root, name, Sdf.SpecifierDef, "Xform")
    spec.kind = Kind.Tokens.component
    spec.customData = {"citysynth": {"infill": True, "part": fill.part, "z": fill.z}}
    _user(spec, "part", fill.part, Sdf.ValueTypeNames.String)
    _meshes_spec(spec, pieces, f"./{PARTS_DIR}")


def _usd_matrix(inst: Instance) -> Gf.Matrix4d:
    """The instance's placement as USD's matrix: USD multiplies row vectors, so its rows
    are the columns of :meth:`~citysynth.export.layout.Instance.matrix` (the images of
    X, Y and Z, then the translation), less any shear, which its prototype holds
    (:func:`~citysynth.export.shear.baked_prototype`). Plain floats: a block writes hundreds."""
    (xx, xy), (ox, oy) = inst.x_axis, inst.origin
    yx, yy = perpendicular_y(inst, inst.shear)
    return Gf.Matrix4d(xx, xy, 0.0, 0.0, yx, yy, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
                       ox, oy, inst.z, 1.0)


def write_variants(path: str | Path, name: str, ranks: list[tuple[int, str]],
                   selected: int = 1, box: list[list[float]] | None = None) -> Path:
    """The k best layouts of one building or block as one prim with a ``layout``
    variantSet: variant ``rank_<r>`` references the layer of rank r (``ranks`` holds
    (rank, path relative to ``path``'s folder)), ``rank_<selected>`` is selected. An
    artist switches between the k best in the DCC's variant menu; each variant composes
    to exactly that rank's layer."""
    path = Path(path)
    layer = Sdf.Layer.CreateAnonymous(".usda")
    root_name = prim_name(name)
    with Sdf.ChangeBlock():
        root = Sdf.PrimSpec(layer, root_name, Sdf.SpecifierDef, "Xform")
        root.kind = Kind.Tokens.assembly
        extents_hint(root, box)
        vset = Sdf.VariantSetSpec(root, "layout")
        for rank, rel in ranks:
            variant = Sdf.VariantSpec(vset, f"rank_{rank}")
            variant.primSpec.referenceList.Prepend(Sdf.Reference(f"./{rel}"))
        root.variantSetNameList.Prepend("layout")
        root.variantSelections["layout"] = f"rank_{selected}"
        root.customData = _vt({"citysynth": {"variants": [f"rank_{r}" for r, _ in ranks],
                                             "selected": f"rank_{selected}"}})
        _stage_metadata(layer, root_name)
        layer.customLayerData = {"generator": "citysynth"}
    _export(layer, path)
    return path


def write_city(path: str | Path, layers: list[tuple], name: str = "City",
               frame: str = "", payload: bool = True,
               boxes: dict[str, list[list[float]]] | None = None) -> Path:
    """A stage at ``path`` over layout layers: ``layers`` holds (prim name, path
    relative to ``path``'s folder[, (dx, dy) offset]), one Xform each under an
    ``assembly``, each bringing its layer in as a payload (the stage opens with every
    block unloaded when asked to, and loads blocks on demand) or, without ``payload``,
    as a reference. Layouts of one city share its frame (``frame``: its description,
    whose CRS and origin go on the root) and need no offset. ``boxes`` (by prim name)
    are their extents, each the prim's ``extentsHint``: the one thing a DCC knows of
    a block it has not loaded."""
    path = Path(path)
    layer = Sdf.Layer.CreateAnonymous(".usda")
    with Sdf.ChangeBlock():
        root = Sdf.PrimSpec(layer, prim_name(name), Sdf.SpecifierDef, "Xform")
        root.kind = Kind.Tokens.assembly
        geo = _georeference(root, frame)
        if geo:
            root.customData = _vt({"citysynth": {"frame": frame, "georeference": geo}})
        for child, rel, *offset in layers:
            spec = Sdf.PrimSpec(root, prim_name(child), Sdf.SpecifierDef, "Xform")
            spec.kind = Kind.Tokens.assembly
            extents_hint(spec, (boxes or {}).get(child))
            if payload:
                spec.payloadList.Prepend(Sdf.Payload(f"./{rel}"))
            else:
                spec.referenceList.Prepend(Sdf.Reference(f"./{rel}"))
            if offset:
                _xform(spec, "xformOp:translate", Sdf.ValueTypeNames.Double3,
                       Gf.Vec3d(float(offset[0][0]), float(offset[0][1]), 0.0))
        _stage_metadata(layer, prim_name(name))
        layer.customLayerData = {"generator": "citysynth"}
    _export(layer, path)
    return path


def extents_hint(spec: Sdf.PrimSpec, box: list[list[float]] | None) -> None:
    """``box`` ([[xmin, ymin, zmin], [xmax, ymax, zmax]], or None: nothing) as the
    model's ``extentsHint`` (``GeomModelAPI``; the default purpose's, all a layout has)."""
    if box is None:
        return
    spec.SetInfo("apiSchemas", _MODEL_API)
    _spec(spec, "extentsHint", Sdf.ValueTypeNames.Float3Array,
          Vt.Vec3fArray([Gf.Vec3f(*box[0]), Gf.Vec3f(*box[1])]))


_MODEL_API = Sdf.TokenListOp.Create(prependedItems=["GeomModelAPI"])


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
