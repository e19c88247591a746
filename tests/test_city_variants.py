"""A city's blocks carry their k best layouts as a ``layout`` variantSet, as
``building`` and ``block`` do: in a k = 3 city (three blocks between generated streets),
each block of ``city.usda`` switches between ``rank_1`` .. ``rank_3``, the rank the run
picked selected, and each variant composes to exactly the solver's layout of that rank
(same parts, same placements) and to that rank's own layer. The city still opens
unloaded (payloads), every file passes every UsdValidation validator, a rerun writes the
same bytes (and a rerun into the same folder builds nothing), and a k = 1 city has no
variant set: its block layers are the layouts' layers, as they always were."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

from citysynth.export.layout import Layout
from citysynth.export.usd import USER, validate, write_layout
from citysynth.pipeline.city.config import load_config
from citysynth.pipeline.city.jobs import solve_block
from citysynth.pipeline.city.run import prepare
from citysynth.pipeline.cli import main
from tests.test_faults import LIB

K3 = 'k = 3\npick = "vary"\nseed = 7\n'   # seed 7 picks rank 2 for one of the blocks


def run_city(streets: Path, cfg: Path, out: Path) -> None:
    assert main(["city", "--streets", str(streets), "--library", str(LIB), "-o", str(out),
                 "--no-overview", "--workers", "1", "--config", str(cfg)]) == 0


def usd_files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in [out / "city.usda", out / "manifest.json",
                                             *sorted((out / "blocks").glob("*.usda"))]}



def _manifest(out: Path) -> dict:
    return json.loads((out / "manifest.json").read_text())["blocks"]


def _composed(stage: Usd.Stage, root: Usd.Prim) -> list[tuple[str, str, np.ndarray]]:
    """Every instance below ``root``: (path below it, part, world matrix)."""
    cache = UsdGeom.XformCache()
    return [(p.GetPath().MakeRelativePath(root.GetPath()).pathString,
             p.GetAttribute(USER + "part").Get(),
             np.asarray(cache.GetLocalToWorldTransform(p)))
            for p in Usd.PrimRange(root) if p.IsInstance()]


def _same(got: list, want: list) -> bool:
    return [(p, part) for p, part, _m in got] == [(p, part) for p, part, _m in want] and \
        all(np.allclose(a, b, atol=1e-9) for (_p, _q, a), (_r, _s, b) in zip(got, want,
                                                                            strict=True))


def test_city_blocks_switch_between_their_k_layouts(k3_city, sample_db):
    streets, cfg, out = k3_city
    jobs = {j.id: j for j in prepare(streets, None, load_config(cfg), LIB).jobs}
    blocks = _manifest(out)
    assert len(blocks) == 3 and all(r["status"] == "built" and r["of"] == 3
                                    for r in blocks.values())
    assert {r["rank"] for r in blocks.values()} != {1}, "the picks test a selection"
    stage = Usd.Stage.Open(str(out / "city.usda"))
    stage.SetEditTarget(stage.GetSessionLayer())   # switch as a DCC does: city.usda stays
    differ = False
    for bid, rec in blocks.items():
        prim = stage.GetDefaultPrim().GetChild(f"block_{bid}")
        vset = prim.GetVariantSets().GetVariantSet("layout")
        assert prim.GetVariantSets().GetNames() == ["layout"]
        assert vset.GetVariantNames() == ["rank_1", "rank_2", "rank_3"]
        assert vset.GetVariantSelection() == f"rank_{rec['rank']}"     # the picked one
        kept = Layout.from_dict(json.loads((out / "blocks" / f"{bid}.layout.json")
                                           .read_text()))
        assert kept.rank == rec["rank"]
        solved = solve_block(jobs[bid], sample_db)
        assert not isinstance(solved, str)
        layouts = solved[1].layouts
        assert len(layouts) == 3 and layouts[rec["rank"] - 1].to_dict() == kept.to_dict()
        seen = []
        for rank, lay in enumerate(layouts, start=1):
            assert vset.SetVariantSelection(f"rank_{rank}")
            got = _composed(stage, prim)
            # exactly the solver's rank-th layout: its parts, in order, where it puts them
            assert [part for _p, part, _m in got] == [i.part for i in lay.instances]
            for (_p, _part, m), inst in zip(got, lay.instances, strict=True):
                np.testing.assert_allclose(m, inst.matrix().T, atol=1e-9)
            assert prim.GetAttribute(USER + "rank").Get() == rank
            assert prim.GetAttribute(USER + "cost").Get() == pytest.approx(lay.cost)
            # and that rank's own layer, composed alone
            own = Usd.Stage.Open(str(out / "blocks" / f"{bid}_{rank}.usda"))
            assert _same(got, _composed(own, own.GetDefaultPrim()))
            seen.append([part for _p, part, _m in got])
        differ |= any(s != seen[0] for s in seen)
    assert differ, "some block's ranks are different layouts"
    assert not (out / "city.usda").read_text().count("rank_"), "selections stay in the blocks"


def test_every_file_validates_and_the_city_opens_unloaded(k3_city):
    _streets, _cfg, out = k3_city
    for path in [out / "city.usda", *sorted((out / "blocks").glob("*.usda"))]:
        assert validate(path) == [], path.name
    stage = Usd.Stage.Open(str(out / "city.usda"), load=Usd.Stage.LoadNone)
    prims = stage.GetDefaultPrim().GetAllChildren()
    assert len(prims) == 3
    assert all(p.HasAuthoredPayloads() and not p.IsLoaded() for p in prims)
    assert not any(p.IsInstance() for p in stage.Traverse())
    assert not prims[0].GetVariantSets().HasVariantSet("layout")   # inside the payload
    stage.Load(prims[0].GetPath())
    rank = _manifest(out)[prims[0].GetName().removeprefix("block_")]["rank"]
    assert prims[0].GetVariantSets().GetVariantSet("layout").GetVariantSelection() == \
        f"rank_{rank}"
    assert any(p.IsInstance() for p in stage.Traverse())
    assert not prims[1].IsLoaded()


def test_a_rerun_writes_the_same_bytes_and_resumes(k3_city, tmp_path, capsys):
    streets, cfg, out = k3_city
    run_city(streets, cfg, tmp_path / "again")
    assert usd_files(tmp_path / "again") == usd_files(out)
    mtimes = {p: p.stat().st_mtime_ns for p in (tmp_path / "again" / "blocks").iterdir()
              if p.is_file()}
    capsys.readouterr()
    run_city(streets, cfg, tmp_path / "again")      # nothing changed: nothing built
    assert "were not built again" in capsys.readouterr().out
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes


def test_a_k1_city_has_no_variant_set(k3_city, tmp_path, sample_db):
    streets, _cfg, out = k3_city
    run = tmp_path / "run"
    shutil.copytree(out, run)            # k = 3 before: k = 1 rebuilds every block
    cfg = tmp_path / "k1.toml"
    cfg.write_text("k = 1\n")
    run_city(streets, cfg, run)
    blocks = _manifest(run)
    cuts = {b for b in blocks if (run / "blocks" / f"{b}.cuts.usdc").is_file()}
    assert cuts, "street blocks cut parts at their corners"
    assert all(r["of"] == 1 and r["files"] == [f"blocks/{b}.layout.json", f"blocks/{b}.usda"]
               + ([f"blocks/{b}.cuts.usdc"] if b in cuts else []) for b, r in blocks.items())
    assert sorted(p.name for p in (run / "blocks").glob("*.usda")) == \
        sorted(f"{b}.usda" for b in blocks), "the k = 3 run's rank layers are gone"
    jobs = {j.id: j for j in prepare(streets, None, load_config(cfg), LIB).jobs}
    stage = Usd.Stage.Open(str(run / "city.usda"))
    for bid in blocks:
        prim = stage.GetDefaultPrim().GetChild(f"block_{bid}")
        assert prim.IsLoaded() and prim.GetVariantSets().GetNames() == []
        # the block's layer is its one layout's layer, byte for byte
        solved = solve_block(jobs[bid], sample_db)
        assert not isinstance(solved, str) and len(solved[1].layouts) == 1
        alone = write_layout(solved[1].layouts[0], sample_db, tmp_path / "alone" / f"{bid}.usda")
        assert alone.read_bytes() == (run / "blocks" / f"{bid}.usda").read_bytes()
    assert validate(run / "city.usda") == []
