"""The k best layouts as a ``layout`` variantSet: ``citysynth block --k 3`` writes
``block.usda`` whose prim switches between ``rank_1`` .. ``rank_3`` (``rank_1``
selected), and each variant composes to exactly that rank's layout: the same instances
(part, prim path, placement) and prototypes as the rank's layout JSON and its own
layer. Validated like every other file, and byte-identical on a second run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

from citysynth.export.layout import Layout
from citysynth.export.usd import USER, prim_name, validate
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
BLOCK = ROOT / "examples" / "blocks" / "block.geojson"


@pytest.fixture(scope="module")
def block_k3(tmp_path_factory):
    out = tmp_path_factory.mktemp("variants")
    assert main(["block", str(BLOCK), "--library", str(LIB), "--style", "modern",
                 "--k", "3", "-o", str(out), "--no-preview"]) == 0
    return out


def _composed(stage: Usd.Stage) -> list[tuple[str, str, tuple]]:
    """Every instance as (path below the root, part, world matrix rounded)."""
    root = stage.GetDefaultPrim().GetPath()
    cache = UsdGeom.XformCache()
    return [(p.GetPath().MakeRelativePath(root).pathString,
             p.GetAttribute(USER + "part").Get(),
             tuple(np.round(np.asarray(cache.GetLocalToWorldTransform(p)), 6).ravel()))
            for p in stage.Traverse() if p.IsInstance()]


def _prototypes(stage: Usd.Stage) -> set[str]:
    """The prototypes the composed instances reference (one each): a library part's
    file in parts/, or a cut prototype's prim in the block's cuts file."""
    out = set()
    for p in stage.Traverse():
        if p.IsInstance():
            for spec in p.GetPrimStack():
                where = Path(spec.layer.realPath)
                if where.parent.name == "parts":
                    out.add(where.stem)
                elif where.name.endswith(".cuts.usdc") and spec.path.GetParentPath().name == \
                        "Cuts":
                    out.add(spec.path.name)
    return out


def test_k3_block_switches_between_its_layouts(block_k3):
    variants = block_k3 / "block.usda"
    assert validate(variants) == []
    stage = Usd.Stage.Open(str(variants))
    root = stage.GetDefaultPrim()
    vset = root.GetVariantSets().GetVariantSet("layout")
    assert vset.GetVariantNames() == ["rank_1", "rank_2", "rank_3"]
    assert vset.GetVariantSelection() == "rank_1"
    seen = set()
    for rank in (1, 2, 3):
        assert vset.SetVariantSelection(f"rank_{rank}")
        lay = Layout.from_dict(json.loads((block_k3 / f"block_{rank}.layout.json").read_text()))
        own = Usd.Stage.Open(str(block_k3 / f"block_{rank}.usda"))
        got = _composed(stage)
        assert got == _composed(own)
        assert [part for _p, part, _m in got] == [i.part for i in lay.instances]
        assert len(stage.GetPrototypes()) == len(lay.prototypes())
        assert _prototypes(stage) == {prim_name(p) for p in lay.prototypes()}
        assert root.GetAttribute(USER + "rank").Get() == rank
        assert root.GetAttribute(USER + "cost").Get() == pytest.approx(lay.cost)
        seen.add(tuple(part for _p, part, _m in got))
    assert len(seen) == 3, "the three variants are three different layouts"


def test_variant_file_is_deterministic(block_k3, tmp_path):
    assert main(["block", str(BLOCK), "--library", str(LIB), "--style", "modern",
                 "--k", "3", "-o", str(tmp_path), "--no-preview"]) == 0
    for name in ("block.usda", "block_1.usda", "block_3.usda"):
        assert (tmp_path / name).read_bytes() == (block_k3 / name).read_bytes()


def test_a_rerun_with_another_k_leaves_no_stale_results(tmp_path):
    """k = 3, then k = 1, then k = 2 into one folder: each time only that run's files
    (name_3.* stayed beside name.* before, and a tool globbing *.layout.json read both);
    a building that is itself called name_7 is not touched."""
    src = Path(__file__).resolve().parent.parent / "examples" / "blocks" / "block.geojson"
    lib = Path(__file__).resolve().parent.parent / "examples" / "library"
    other = tmp_path / "block_7.layout.json"
    other.write_text(json.dumps({"name": "block_7", "rank": 1}))
    for k, want in ((3, {"block.usda", "block.cuts.usdc"} | {
                        f"block_{r}{x}" for r in (1, 2, 3)
                        for x in (".usda", ".layout.json", ".glb")}),
                    (1, {"block.usda", "block.cuts.usdc", "block.layout.json", "block.glb"}),
                    (2, {"block.usda", "block.cuts.usdc"} | {
                        f"block_{r}{x}" for r in (1, 2)
                        for x in (".usda", ".layout.json", ".glb")})):
        assert main(["block", str(src), "--library", str(lib), "--k", str(k), "-o",
                     str(tmp_path), "--no-preview"]) == 0
        got = {p.name for p in tmp_path.iterdir() if p.is_file()}
        assert got == want | {"block_7.layout.json"}, (k, sorted(got))


def test_a_rank_deleted_by_hand_hides_no_stale_rank_after_it(tmp_path):
    """k = 3, rank 2's files deleted by hand, then k = 1: rank 3's files go too (the
    sweep tried rank 1, 2, ... and stopped at the first missing one)."""
    src = Path(__file__).resolve().parent.parent / "examples" / "blocks" / "block.geojson"
    lib = Path(__file__).resolve().parent.parent / "examples" / "library"
    argv = ["block", str(src), "--library", str(lib), "-o", str(tmp_path), "--no-preview"]
    assert main([*argv, "--k", "3"]) == 0
    for p in tmp_path.glob("block_2.*"):
        p.unlink()
    assert main([*argv, "--k", "1"]) == 0
    assert not list(tmp_path.glob("block_3.*"))


def test_a_rerun_that_cuts_nothing_leaves_no_cuts_file(tmp_path):
    """The cuts file of an earlier run goes when the new layouts cut (or shear) no
    part: in a building's folder (the layouts' sweep) and in a city's blocks folder
    (the block's)."""
    from dataclasses import replace

    from citysynth.export.shear import perpendicular_y
    from citysynth.pipeline.city.config import load_config
    from citysynth.pipeline.city.jobs import solve_block, worker_library, write_block
    from citysynth.pipeline.city.run import prepare
    from citysynth.pipeline.layouts import Built, write_outputs

    streets = ROOT / "examples" / "city" / "district_streets.geojson"
    job = next(j for j in prepare(str(streets), None, load_config(None), str(LIB)).jobs
               if j.zone_kind is None)
    db = worker_library(job.library)
    built = solve_block(job, db)[1]
    uncut = Built(built.name, "ok", [replace(lay, instances=[   # nor sheared (also its own)
        replace(i, cut=None, y_axis=perpendicular_y(i, i.shear)) for i in lay.instances])
        for lay in built.layouts])
    cuts = f"{built.name}.cuts.usdc"
    for write in (lambda b: write_outputs(b, db, tmp_path, formats=("json", "usd")),
                  lambda b: write_block(b, 1, db, tmp_path / "blocks")):
        assert cuts in {p.name for p in write(built)}
        assert cuts not in {p.name for p in write(uncut)}
        assert not (tmp_path / cuts).exists() and not (tmp_path / "blocks" / cuts).exists()
