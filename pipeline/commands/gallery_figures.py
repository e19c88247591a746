"""The figures of ``citysynth gallery`` (see :mod:`.gallery`): each solves its
layouts from the shipped sample library the way its command does and returns them
with a title; :data:`FIGURES` names them."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import cast

import trimesh
from shapely.geometry import LineString

from citysynth import examples
from citysynth.export.assemble import world_mesh
from citysynth.export.layout import Layout
from citysynth.parts_db import PartDB
from citysynth.pipeline.commands.gallery_joints import JOINTS, STYLES, joint_panels, render_sheet
from citysynth.pipeline.layouts import solve_layouts
from citysynth.pipeline.streets import StreetAsk, solve_street
from citysynth.pipeline.towers import Lot, solve_tower
from citysynth.skeletons import read_geojson, skeleton_from_lines

GAP = 20.0           # metres between layouts set side by side
RING = examples.ROOT / "skeletons" / "ring_with_wings.geojson"
T_BUILDING = examples.ROOT / "skeletons" / "t_building.geojson"
DOORS = ((0.0, 0.0), (1.0, 2.0), (3.0, 4.0))      # Fig. 8: doors per side


def _ok(built) -> list[Layout]:
    if built.status != "ok":   # the shipped inputs always solve; a failure is a bug
        raise RuntimeError(f"gallery: {built.name}: {built.reason}")
    return built.layouts


def _building(db: PartDB, path: Path, style: str, k: int = 1, **options) -> list[Layout]:
    feats, frame = read_geojson(path)
    mids = [p.length for p in db.select("middle", style)]
    sk = skeleton_from_lines(feats, frame, name=path.stem, min_edge=min(mids))
    return _ok(solve_layouts(path.stem, [sk], db, style, k, **options))


def side_by_side(lays: list[Layout], db: PartDB) -> trimesh.Trimesh:
    """The layouts' meshes in a row along +X, ``GAP`` apart, bottoms on z = 0."""
    meshes, x = [], 0.0
    for lay in lays:
        m = world_mesh(lay, db)
        lo, hi = m.bounds
        m.apply_translation([x - lo[0], -(lo[1] + hi[1]) / 2, 0.0])
        meshes.append(m)
        x += float(hi[0] - lo[0]) + GAP
    return cast(trimesh.Trimesh, trimesh.util.concatenate(meshes))


def _fig1c(db):
    return _building(db, RING, "classic"), "Fig. 1(c): a ring with nested T junctions"


def _fig1d(db):
    return _building(db, RING, "modern"), "Fig. 1(d): the same ring, modern style"


def _fig4(db):
    lays = [_ok(solve_tower(f"far{far}", db, Lot.square(400.0), 120.0,
                            (far * 0.98, far * 1.02)))[0] for far in (10, 15, 20)]
    return lays, "Fig. 4: 120 m towers at FAR 10, 15, 20"


def _fig5(db):
    return ([_building(db, RING, s)[0] for s in ("classic", "modern")],
            "Fig. 5: one structure, two styles")


def _fig6(db):
    return _building(db, RING, "classic", k=3), "Fig. 6: the three best layouts"


def _fig7(db):
    ask = StreetAsk(("left",), k=1)
    return (_ok(solve_street("street_80m", LineString([(0, 0), (80, 0)]), db, ask)),
            "Fig. 7: an 80 m street of complete buildings")


def _fig8(db):
    lays = [_building(db, T_BUILDING, "classic", per_side={"doors": iv})[0] for iv in DOORS]
    return lays, "Fig. 8: doors per side " + ", ".join(f"{a:g}-{b:g}" for a, b in DOORS)


def _complex(db):
    lays = [_building(db, examples.ROOT / "skeletons" / f"{name}.geojson", "classic")[0]
            for name in ("h_building", "ladder_building", "ring_outward_wings")]
    return lays, "An H, a ladder, a ring facing out with a wing into the street"


FIGURES: dict[str, Callable[[PartDB], tuple[list[Layout], str]]] = {
    "fig1c": _fig1c, "fig1d": _fig1d, "fig4": _fig4, "fig5": _fig5, "fig6": _fig6,
    "fig7": _fig7, "fig8": _fig8, "complex": _complex}
SHEETS = ("joints",)    # figures of their own layout (a grid of close-ups)


def joints_sheet(db: PartDB, out: Path) -> str:
    """The close-up sheet of joints (joints.png); what it holds, for the listing."""
    path = render_sheet(joint_panels(db), out / "joints.png")
    return f"{path}  ({len(STYLES) * len(JOINTS)} layout(s)"


