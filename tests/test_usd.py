"""USD as DCCs show it: prims named for their part and stage, one shared material
library (one material layer per library material, referenced by every part that
uses it), display colours in linear space, the layout's facts as ``userProperties:``
attributes, the frame's georeference on the root, a city whose blocks are payloads
(opened unloaded, loaded on demand); every file still passes every UsdValidation
validator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom, UsdShade

from citysynth.export.layout import Layout
from citysynth.export.materials import linear_rgb, material_name, srgb_to_linear
from citysynth.export.prototypes import prototype_pieces
from citysynth.export.usd import USER, prim_name, validate, write_city
from citysynth.pipeline.city.outputs import write_city_stage
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
T_BUILDING = ROOT / "examples" / "skeletons" / "t_building.geojson"
BLOCK = ROOT / "examples" / "blocks" / "block.geojson"


@pytest.fixture
def db(sample_db):
    return sample_db


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("usd")
    assert main(["building", str(T_BUILDING), "--library", str(LIB), "--style", "classic",
                 "--k", "2", "-o", str(out), "--no-preview"]) == 0
    assert main(["block", str(BLOCK), "--library", str(LIB), "--style", "modern",
                 "-o", str(out), "--no-preview"]) == 0
    return out


def _layout(path: Path) -> Layout:
    return Layout.from_dict(json.loads(path.read_text()))


def _instances(stage: Usd.Stage) -> list[Usd.Prim]:
    return [p for p in stage.Traverse() if p.IsInstance()]


@pytest.mark.parametrize("stem", ["block", "t_building_1"])
def test_prims_named_for_stage_and_part(run_dir, stem):
    lay = _layout(run_dir / f"{stem}.layout.json")
    stage = Usd.Stage.Open(str(run_dir / f"{stem}.usda"))
    prims = _instances(stage)
    assert [p.GetAttribute(USER + "part").Get() for p in prims] == \
        [i.part for i in lay.instances]
    root = stage.GetDefaultPrim().GetPath()
    for prim, inst in zip(prims, lay.instances, strict=True):
        rel = prim.GetPath().MakeRelativePath(root).pathString
        s, group, name = rel.split("/")
        assert s == f"structure_{inst.structure:02d}"
        assert group == ("keys" if inst.stage is None else f"stage_{inst.stage:02d}")
        assert name.startswith(prim_name(inst.part) + "_")
        assert Sdf.Path.IsValidIdentifier(name)
    fillers = [p.GetName() for p, i in zip(prims, lay.instances, strict=True)
               if i.stage == 0 and i.structure == 0]
    assert fillers[0].endswith("_00") and fillers[-1].endswith(f"_{len(fillers) - 1:02d}")


def test_layout_facts_and_georeference_as_user_properties(run_dir):
    lay = _layout(run_dir / "t_building_2.layout.json")
    stage = Usd.Stage.Open(str(run_dir / "t_building_2.usda"))
    root = stage.GetDefaultPrim()
    assert root.GetAttribute(USER + "rank").Get() == 2
    assert root.GetAttribute(USER + "cost").Get() == pytest.approx(lay.cost)
    assert root.GetAttribute(USER + "constraints_met").Get() is True
    assert list(root.GetAttribute(USER + "parts_used").Get()) == lay.parts_used()
    assert root.GetAttribute(USER + "origin_lon").Get() == pytest.approx(7.10045, abs=1e-6)
    assert root.GetAttribute(USER + "origin_lat").Get() == pytest.approx(50.73018, abs=1e-6)
    assert "transverse Mercator" in root.GetAttribute(USER + "crs").Get()
    geo = root.GetCustomData()["citysynth"]["georeference"]
    assert geo["origin_lon"] == pytest.approx(7.10045, abs=1e-6)
    stage0 = stage.GetPrimAtPath(root.GetPath().AppendPath("structure_00/stage_00"))
    met = lay.structures[0]["stages"][0]["met"]
    assert stage0.GetAttribute(USER + "met:doors").Get() == pytest.approx(met["doors"])


def test_one_shared_material_per_library_material(run_dir, db):
    lay = _layout(run_dir / "block.layout.json")
    stage = Usd.Stage.Open(str(run_dir / "block.usda"))
    want = {material_name(p): p for i in lay.instances for p in prototype_pieces(db, i)}
    files = sorted((run_dir / "parts" / "materials").glob("*.usda"))
    assert {f.stem for f in files} >= set(want)
    for f in files:   # one material each, and the same file for every part using it
        assert validate(f) == []
        mat_stage = Usd.Stage.Open(str(f))
        (prim,) = mat_stage.GetPseudoRoot().GetChildren()
        assert prim.IsA(UsdShade.Material) and prim.GetName() == f.stem
    bound: dict[str, set[str]] = {}
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        material, _rel = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        assert material, prim.GetPath()
        shader = material.ComputeSurfaceSource()[0]
        layers = {spec.layer.realPath for spec in shader.GetPrim().GetPrimStack()}
        bound.setdefault(material.GetPrim().GetName(), set()).update(layers)
        # display colour: the material's colour, linear (not the sRGB bytes)
        colour = UsdGeom.Mesh(prim).GetDisplayColorPrimvar().Get()[0]
        piece = want[material.GetPrim().GetName()]
        np.testing.assert_allclose(colour, linear_rgb(piece), atol=1e-6)
        np.testing.assert_allclose(shader.GetInput("diffuseColor").Get(), colour, atol=1e-6)
    assert set(bound) == set(want)
    for name, layers in bound.items():   # defined in the library only, never in a part
        assert layers == {str(run_dir / "parts" / "materials" / f"{name}.usda")}


def test_srgb_to_linear():
    assert srgb_to_linear(0) == 0.0 and srgb_to_linear(255) == pytest.approx(1.0)
    assert srgb_to_linear(188) == pytest.approx(0.5029, abs=1e-4)
    assert srgb_to_linear(10) == pytest.approx(10 / 255 / 12.92)


def test_city_blocks_are_payloads_loaded_on_demand(run_dir, tmp_path):
    report = {"built": ["block", "t_building_1"]}
    blocks = tmp_path / "blocks"
    blocks.mkdir()
    for name in report["built"]:   # a city folder: blocks/<id>.usda beside blocks/parts
        (blocks / f"{name}.usda").write_bytes((run_dir / f"{name}.usda").read_bytes())
    for cuts in run_dir.glob("*.cuts.usdc"):   # and the prototypes they cut
        (blocks / cuts.name).write_bytes(cuts.read_bytes())
    (blocks / "parts").symlink_to(run_dir / "parts")
    frame = _layout(run_dir / "block.layout.json").frame
    city = write_city_stage(tmp_path, report, frame)
    assert validate(city) == []
    stage = Usd.Stage.Open(str(city), load=Usd.Stage.LoadNone)
    assert _instances(stage) == []
    blocks_prims = stage.GetDefaultPrim().GetAllChildren()
    assert [p.GetName() for p in blocks_prims] == ["block_block", "block_t_building_1"]
    assert all(p.HasAuthoredPayloads() and not p.IsLoaded() for p in blocks_prims)
    assert stage.GetDefaultPrim().GetAttribute(USER + "origin_lat").Get() == \
        pytest.approx(50.730384, abs=1e-6)
    stage.Load(blocks_prims[0].GetPath())
    n = len(_layout(run_dir / "block.layout.json").instances)
    assert len(_instances(stage)) == n
    full = Usd.Stage.Open(str(city))
    assert len(_instances(full)) == n + len(_layout(run_dir / "t_building_1.layout.json")
                                            .instances)


def test_city_by_reference_when_asked(run_dir):
    city = write_city(run_dir / "refs.usda", [("t", "t_building_1.usda")], payload=False)
    stage = Usd.Stage.Open(str(city), load=Usd.Stage.LoadNone)
    assert len(_instances(stage)) == len(_layout(run_dir / "t_building_1.layout.json")
                                         .instances)
    city.unlink()


def test_part_files_of_another_library_are_written_again(tmp_path):
    """A folder written again from an edited library (or another of the same part
    ids) kept its old ``parts/*.usdc``: the layers showed the old meshes, and
    ``citysynth diff`` saw nothing. A part file is now written again unless it holds
    the library's hash, and one left empty (a disk that filled) too."""
    import shutil

    lib = tmp_path / "lib"
    shutil.copytree(LIB, lib, ignore=shutil.ignore_patterns(".citysynth"))
    line = ROOT / "examples" / "skeletons" / "t_building.geojson"

    def build(out: Path) -> None:
        assert main(["building", str(line), "--library", str(lib), "--style", "classic",
                     "--no-preview", "-o", str(out)]) == 0

    build(tmp_path / "used")
    with (lib / "manifest.toml").open("a") as f:
        f.write("\n# edited\n")   # a new library hash, as an edited mesh gives
    part = sorted((tmp_path / "used" / "parts").glob("*.usdc"))[0]
    part.write_bytes(b"")
    import citysynth.export.usd as usd
    getattr(usd, "_OF_LIBRARY", {}).clear()   # a new process: the files are unknown
    build(tmp_path / "used")
    build(tmp_path / "fresh")
    for fresh in sorted((tmp_path / "fresh" / "parts").glob("*.usdc")):
        used = tmp_path / "used" / "parts" / fresh.name
        assert used.read_bytes() == fresh.read_bytes(), fresh.name
    layer = Sdf.Layer.FindOrOpen(str(part))
    from citysynth.parts_db import load_library
    assert layer.GetPrimAtPath(layer.defaultPrim).customData["citysynth"]["library"] \
        == load_library(lib).library_hash


def test_a_cut_that_leaves_nothing_of_its_part_writes_no_empty_looks(tmp_path, sample_db):
    """A short part at a sharp corner can be cut away whole by the corner's two planes
    (5 of the demo district's 14,259 cut prototypes): its prototype holds no mesh, and
    had an empty ``Looks`` scope all the same, clutter in a DCC's outliner. A cut that
    keeps some of the part still binds its materials there."""
    from citysynth.export.layout import Cut, Instance
    from citysynth.export.usd import ensure_parts, write_cuts

    part = next(p for p in sample_db.parts if p.cls == "middle")
    gone = Cut((0.0, 0.0), ((1.0, 0.0, -1.0),))          # keeps x <= -1: nothing
    kept = Cut((0.0, 0.0), ((1.0, 0.0, 0.5),))           # keeps x <= 0.5
    insts = {name: Instance(part.id, part.cls, 0, 0, None, (1.0, 0.0), (0.0, 1.0),
                            (0.0, 0.0), cut) for name, cut in (("gone", gone), ("kept", kept))}
    assert not prototype_pieces(sample_db, insts["gone"])
    path = tmp_path / "b.cuts.usdc"
    ensure_parts(sample_db, insts, tmp_path)       # the materials the cuts reference
    write_cuts(sample_db, insts, path)
    layer = Sdf.Layer.FindOrOpen(str(path))
    protos = {p.customData["citysynth"]["cut"]["planes"][0]: p
              for p in layer.GetPrimAtPath("/Cuts").nameChildren}
    empty, full = protos["[1.0, 0.0, -1.0]"], protos["[1.0, 0.0, 0.5]"]
    assert [c.name for c in empty.nameChildren] == []
    assert "Looks" in [c.name for c in full.nameChildren]
    assert any(c.typeName == "Mesh" for c in full.nameChildren)
    assert validate(path) == []
