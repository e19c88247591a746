"""Blender itself (the ``bpy`` package, 4.2 LTS) imports what citysynth writes, as an
artist would: the selected variant of a k = 3 block's USD and its GLB, and a city's
USD stage and GLB. Every instance
comes in, upright (the height of the scene along Blender's Z is the block's height),
named by its part, with one material per library material and the part id among the
object's custom properties. bpy runs in its own venv (build/bpy, which ``make`` builds
and this module builds when it is missing): it carries its own USD, which must not
meet usd-core's in one process, and its own numpy pin."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from citysynth.export.assemble import bounds
from citysynth.export.layout import Layout
from citysynth.export.materials import material_name
from citysynth.export.prototypes import prototype_pieces
from citysynth.export.usd import prim_name
from citysynth.pipeline.city.config import load_config
from citysynth.pipeline.city.jobs import run_block
from citysynth.pipeline.city.outputs import write_city_glb, write_city_stage, write_summary
from citysynth.pipeline.city.run import prepare
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
BLOCK = ROOT / "examples" / "blocks" / "block.geojson"
CITY = ROOT / "examples" / "city"
DISTRICT = CITY / "district_streets.geojson"
BPY_VENV = ROOT / "build" / "bpy"
BPY_SPEC = ["bpy==4.2.0", "numpy<2"]   # the Makefile's pin: a cp311 manylinux wheel
SCRIPT = Path(__file__).with_name("blender_import.py")
_SUFFIX = re.compile(r"\.\d{3}$")      # Blender's ".001" for a name taken


def ensure_bpy() -> Path:
    """The python of build/bpy, a venv with bpy in it (built when missing, as the
    Makefile's rule does)."""
    python = BPY_VENV / "bin" / "python"
    stamp = BPY_VENV / ".installed-stamp"
    if not stamp.is_file():
        subprocess.run([sys.executable, "-m", "venv", "--clear", str(BPY_VENV)], check=True)
        subprocess.run([str(python), "-m", "pip", "install", "--quiet", *BPY_SPEC],
                       check=True, timeout=1800)
        stamp.touch()
    return python


def blender(path: Path) -> dict:
    p = subprocess.run([str(ensure_bpy()), str(SCRIPT), str(path)], capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


@pytest.fixture
def db(sample_db):
    return sample_db


@pytest.fixture(scope="module")
def block_k3(tmp_path_factory):
    out = tmp_path_factory.mktemp("blender")
    assert main(["block", str(BLOCK), "--library", str(LIB), "--style", "modern",
                 "--k", "3", "-o", str(out), "--no-preview"]) == 0
    return out


def _scene_bounds(scene: dict) -> np.ndarray:
    """Of every mesh Blender draws (collection instances resolved), in world space."""
    boxes = np.array([d["bounds"] for d in scene["drawn"]])
    return np.array([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])


def _check_materials(scene: dict, lay: Layout, db) -> None:
    want = {material_name(p) for i in lay.instances for p in prototype_pieces(db, i)}
    assert sorted(scene["materials"]) == sorted(want)   # once each, no ".001" copies


def _check_upright(scene: dict, lay: Layout, db) -> None:
    """Blender is Z-up: the scene stands on z = 0 and is as high as the block."""
    np.testing.assert_allclose(_scene_bounds(scene), bounds(lay, db), atol=2e-3)


def test_blender_imports_the_selected_variant(block_k3, db):
    lay = Layout.from_dict(json.loads((block_k3 / "block_1.layout.json").read_text()))
    scene = blender(block_k3 / "block.usda")
    parts = [o for o in scene["objects"] if "citysynth:part" in o["props"]]
    assert sorted(o["props"]["citysynth:part"] for o in parts) == \
        sorted(i.part for i in lay.instances)
    for o in parts:
        assert _SUFFIX.sub("", o["name"]).startswith(prim_name(o["props"]["citysynth:part"]))
    drawn = [d for d in scene["drawn"] if d["instance"]]   # prototypes, instanced
    assert len(drawn) == sum(len(prototype_pieces(db, i)) for i in lay.instances)
    _check_upright(scene, lay, db)
    _check_materials(scene, lay, db)


def test_blender_imports_the_glb_upright(block_k3, db):
    lay = Layout.from_dict(json.loads((block_k3 / "block_1.layout.json").read_text()))
    scene = blender(block_k3 / "block_1.glb")
    parts = [o for o in scene["objects"] if "part" in o["props"].get("citysynth", {})]
    assert [o["props"]["citysynth"]["part"] for o in parts] == [i.part for i in lay.instances]
    assert all(o["type"] == "MESH" and o["name"].startswith(o["props"]["citysynth"]["part"])
               for o in parts)
    assert len(scene["drawn"]) == len(lay.instances)   # one mesh object per instance
    _check_upright(scene, lay, db)
    _check_materials(scene, lay, db)


def test_blender_imports_a_whole_city(tmp_path, db):
    """Three district blocks built by the city's own job runner: city.usda (blocks as
    payloads, which Blender loads) and city.glb come in with every instance, upright,
    one material per library material."""
    inputs = prepare(DISTRICT, None, load_config(CITY / "city.toml"), LIB)
    inputs.jobs = inputs.jobs[:3]
    results = {job.id: run_block(job, str(tmp_path)) for job in inputs.jobs}
    report = write_summary(inputs, results, tmp_path, 0.0, 1, None)
    lays = [Layout.from_dict(json.loads((tmp_path / "blocks" / f"{b}.layout.json")
                                        .read_text())) for b in report["built"]]
    assert lays, {i: (r["status"], r.get("reason"), r.get("error")) for i, r in results.items()}
    instances = [i for lay in lays for i in lay.instances]
    lo = np.min([bounds(lay, db)[0] for lay in lays], axis=0)
    hi = np.max([bounds(lay, db)[1] for lay in lays], axis=0)
    want = {material_name(p) for i in instances for p in prototype_pieces(db, i)}
    usd = blender(write_city_stage(tmp_path, report, inputs.frame.describe()))
    parts = [o["props"]["citysynth:part"] for o in usd["objects"]
             if "citysynth:part" in o["props"]]
    assert sorted(parts) == sorted(i.part for i in instances)
    glb_path = write_city_glb(tmp_path, inputs, report)
    assert glb_path is not None
    glb = blender(glb_path)
    assert sum(1 for o in glb["objects"] if "part" in o["props"].get("citysynth", {})) == \
        len(instances)
    for scene in (usd, glb):
        np.testing.assert_allclose(_scene_bounds(scene), [lo, hi], atol=2e-3)
        assert sorted(scene["materials"]) == sorted(want)


def test_blender_imports_a_roof_infill(tmp_path, db):
    """A deep footprint's roof infill (``block --infill``) comes in from USD and GLB as
    a mesh object named for it, in the library's roof and wall materials (no copies),
    and the scene is as large and as high as the layout with it."""
    from citysynth.export.infill import infill_pieces
    src = tmp_path / "deep.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {"id": "deep"}, "geometry": {
            "type": "Polygon", "coordinates": [[[13.400, 52.520], [13.4009, 52.520],
                                                [13.4009, 52.5204], [13.400, 52.5204],
                                                [13.400, 52.520]]]}}]}))
    assert main(["block", str(src), "--library", str(LIB), "--infill", "-o", str(tmp_path),
                 "--no-preview"]) == 0
    lay = Layout.from_dict(json.loads((tmp_path / "deep.layout.json").read_text()))
    assert lay.infill
    pieces = [p for f in lay.infill for p in infill_pieces(f, db)]
    want = {material_name(p) for i in lay.instances for p in prototype_pieces(db, i)} | \
        {material_name(p) for p in pieces}
    for path in (tmp_path / "deep.usda", tmp_path / "deep.glb"):
        scene = blender(path)
        infill = [o for o in scene["objects"] if o["type"] == "MESH"
                  and (o["name"].startswith(("roof_", "walls_")) and o["parent"] == "infill_00"
                       or o["name"].startswith("infill_00"))]
        assert infill, [o["name"] for o in scene["objects"]][:20]
        assert {m for o in infill for m in o["materials"]} == {material_name(p) for p in pieces}
        _check_upright(scene, lay, db)
        _check_materials_set(scene, want)


def _check_materials_set(scene: dict, want: set[str]) -> None:
    assert sorted(scene["materials"]) == sorted(want)


def _usd_mesh_boxes(path: Path) -> np.ndarray:
    """Every mesh of the stage as usd-core composes it (instances resolved): its
    world-space vertex bounds, [n, 2, 3]."""
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.Open(str(path))
    cache = UsdGeom.XformCache()
    boxes = []
    for prim in stage.Traverse(Usd.TraverseInstanceProxies()):
        if prim.IsA(UsdGeom.Mesh):
            p = np.asarray(UsdGeom.Mesh(prim).GetPointsAttr().Get(), dtype=float)
            if len(p):
                w = (np.c_[p, np.ones(len(p))] @ np.asarray(cache.GetLocalToWorldTransform(
                    prim)))[:, :3]
                boxes.append([w.min(axis=0), w.max(axis=0)])
    return np.array(boxes)


def test_blender_keeps_sheared_corners_where_usd_puts_them(sheared_layer):
    """Blender decomposes a USD transform into location, rotation and scale and so
    dropped a sheared instance's shear (the demo district's adapted corners moved by
    up to 4.8 cm in Blender alone): each mesh Blender draws of a layer with three in
    four instances sheared is where usd-core composes it, to a tenth of a millimetre."""
    path, _lay = sheared_layer
    want = _usd_mesh_boxes(path)
    drawn = np.array([d["bounds"] for d in blender(path)["drawn"]])
    assert len(drawn) == len(want)
    apart = np.abs(want[:, None] - drawn[None, :]).max(axis=(2, 3)).min(axis=1)
    assert apart.max() < 1e-4, f"{int((apart > 1e-4).sum())} meshes off, by {apart.max():.4f} m"
