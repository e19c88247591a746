"""Every layout layer's root, every variant prim and every block of ``city.usda`` carries
an ``extentsHint``: a DCC that opens a city unloaded (its blocks are payloads) knew
nothing of where a block was or how tall, so it could not frame, cull or draw the
blocks as boxes before loading them all. The hint is what usd-core's own
``UsdGeomModelAPI.ComputeExtentsHint`` finds on the loaded layer (to the millimetre,
rounded outward), a variant prim's covers all its ranks, and a city block's is the
``extent`` its manifest records."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pxr import Usd, UsdGeom

from citysynth.export.usd import validate
from citysynth.pipeline.cli import main
from tests.test_faults import LIB

MM = 1e-3 + 1e-4   # the hint's outward rounding, and float32 at a few hundred metres


def _hint(prim: Usd.Prim) -> np.ndarray:
    value = UsdGeom.ModelAPI(prim).GetExtentsHintAttr().Get()
    assert value is not None, f"{prim.GetPath()} has no extentsHint"
    return np.array(value, dtype=float)


def _computed(prim: Usd.Prim) -> np.ndarray:
    """usd-core's own hint of the loaded prim, from its meshes' extents."""
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_],
                              useExtentsHint=False)
    return np.array(UsdGeom.ModelAPI(prim).ComputeExtentsHint(cache), dtype=float)[:2]


def _covers(hint: np.ndarray, box: np.ndarray, tol: float = MM) -> bool:
    return bool((hint[0] <= box[0] + 1e-4).all() and (hint[1] >= box[1] - 1e-4).all()
                and (box[0] - hint[0] <= tol).all() and (hint[1] - box[1] <= tol).all())


@pytest.fixture
def k3(k3_city):
    return k3_city[2]


def test_each_rank_layer_hints_what_usd_computes(k3):
    layers = sorted((k3 / "blocks").glob("*_[0-9].usda"))
    assert len(layers) >= 6
    for layer in layers:
        stage = Usd.Stage.Open(str(layer))   # held: a prim of a freed stage is invalid
        root = stage.GetDefaultPrim()
        hint, computed = _hint(root), _computed(root)
        assert _covers(hint, computed), (layer.name, hint, computed)
        assert hint[1][2] > 3.0   # a building's height, not an empty box


def test_a_variant_prim_hints_all_its_ranks(k3):
    for stage_file in sorted((k3 / "blocks").glob("*.usda")):
        if "_" in stage_file.stem:
            continue
        stage = Usd.Stage.Open(str(stage_file))
        root = stage.GetDefaultPrim()
        hint = _hint(root)
        vset = root.GetVariantSet("layout")
        boxes = []
        for name in vset.GetVariantNames():
            vset.SetVariantSelection(name)
            boxes.append(_computed(root))
        union = np.array([np.min([b[0] for b in boxes], axis=0),
                          np.max([b[1] for b in boxes], axis=0)])
        assert len(boxes) == 3 and _covers(hint, union), (stage_file.name, hint, union)


def test_an_unloaded_city_knows_each_blocks_box(k3):
    blocks = json.loads((k3 / "manifest.json").read_text())["blocks"]
    unloaded = Usd.Stage.Open(str(k3 / "city.usda"), Usd.Stage.LoadNone)
    loaded = Usd.Stage.Open(str(k3 / "city.usda"))
    built = [b for b, r in blocks.items() if r["status"] == "built"]
    assert len(built) == 3
    for bid in built:
        path = f"/City/block_{bid}"
        prim = unloaded.GetPrimAtPath(path)
        assert not prim.IsLoaded() and not prim.GetChildren()
        hint = _hint(prim)
        np.testing.assert_allclose(hint, blocks[bid]["extent"], atol=1e-4)
        assert _covers(hint, _computed(loaded.GetPrimAtPath(path)), tol=50.0)
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_],
                              useExtentsHint=True)
    whole = cache.ComputeWorldBound(unloaded.GetDefaultPrim()).ComputeAlignedRange()
    assert not whole.IsEmpty() and whole.GetSize()[2] > 3.0
    assert validate(k3 / "city.usda") == []


def test_a_footprints_infill_is_inside_the_hint(tmp_path):
    """A footprint deeper than the parts reach is roofed by an infill mesh (no
    instance): the layer's hint covers it as usd-core computes it."""
    ring = [[24.94, 60.17], [24.9407, 60.17], [24.9407, 60.1704], [24.94, 60.1704],
            [24.94, 60.17]]
    f = tmp_path / "deep.geojson"
    f.write_text(json.dumps({"type": "Feature", "properties": {"id": "deep"},
                             "geometry": {"type": "Polygon", "coordinates": [ring]}}))
    out = tmp_path / "out"
    assert main(["block", str(f), "--library", str(LIB), "-o", str(out), "--no-preview",
                 "--infill", "--k", "2"]) == 0
    layers = sorted(out.glob("deep_[0-9].usda"))
    assert len(layers) == 2
    for layer in layers:
        stage = Usd.Stage.Open(str(layer))
        root = stage.GetDefaultPrim()
        assert [c for c in root.GetChildren() if c.GetName().startswith("infill")]
        assert _covers(_hint(root), _computed(root)), layer.name
        assert validate(layer) == []
    stages = [Usd.Stage.Open(str(p)) for p in [out / "deep.usda", *layers]]
    hints = [_hint(s.GetDefaultPrim()) for s in stages]
    union = np.array([np.min([h[0] for h in hints[1:]], axis=0),
                      np.max([h[1] for h in hints[1:]], axis=0)])
    np.testing.assert_allclose(hints[0], union, atol=1e-4)
