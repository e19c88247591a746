"""``citysynth gallery -o DIR``: the paper's application figures made again from the
shipped sample library, one PNG each (three-quarter view beside a top view):

* ``fig1c.png``, ``fig1d.png``: the ring with wings and nested T junctions
  (``examples/skeletons/ring_with_wings.geojson``) in the classic and the modern style;
* ``fig4.png``: towers of 120 m at floor-area ratios 10, 15 and 20 on 400 m² lots;
* ``fig5.png``: the ring in both styles side by side (one structure, two databases);
* ``fig6.png``: the ring's three best layouts in the classic style;
* ``fig7.png``: an 80 m street of complete buildings;
* ``fig8.png``: the T building under three door intervals per side;
* ``complex.png``: T junctions beyond the paper's figures: an H, a ladder (bars that are
  the wing of the T junctions at both their ends) and a ring facing the street with a
  wing into it (its T part turned over);
* ``joints.png``: close-ups of every kind of joint in both styles (an acute, a right and
  an obtuse convex corner, a concave corner, a bend, a T junction; see
  :mod:`.gallery_joints`).

Each figure is solved, placed and checked the way its command does it (``building``,
``tower``, ``street``); figures of several layouts set them side by side, 20 m apart.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import cast

import trimesh
from shapely.geometry import LineString

from citysynth import examples
from citysynth.export.assemble import world_mesh
from citysynth.export.layout import Layout
from citysynth.parts_db import PartDB, load_library
from citysynth.pipeline.commands.gallery_joints import JOINTS, STYLES, joint_panels, render_sheet
from citysynth.pipeline.errors import UsageError
from citysynth.pipeline.layouts import solve_layouts
from citysynth.pipeline.streets import StreetAsk, solve_street
from citysynth.pipeline.towers import Lot, solve_tower
from citysynth.skeletons import read_geojson, skeleton_from_lines

GAP = 20.0           # metres between layouts set side by side
RING = examples.ROOT / "skeletons" / "ring_with_wings.geojson"
T_BUILDING = examples.ROOT / "skeletons" / "t_building.geojson"
DOORS = ((0.0, 0.0), (1.0, 2.0), (3.0, 4.0))      # Fig. 8: doors per side


def register(sub) -> None:
    p = sub.add_parser("gallery", help="make the paper's application figures again",
                       description="Solve and render the paper's Figs. 1(c)/(d), 4, 5, 6, 7 "
                                   "and 8 from the sample library into PNGs, and a "
                                   "close-up sheet of joints (joints.png).")
    p.add_argument("-o", "--out", default="gallery", metavar="DIR",
                   help="output folder (default: gallery/)")
    p.add_argument("--only", nargs="+", metavar="FIG", default=None,
                   help="make only these figures (e.g. fig4 fig7 joints)")
    p.set_defaults(run=run)


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


def _joints(db: PartDB, out: Path) -> str:
    path = render_sheet(joint_panels(db), out / "joints.png")
    return f"{path}  ({len(STYLES) * len(JOINTS)} layout(s)"


def run(args) -> int:
    names = args.only or [*FIGURES, *SHEETS]
    unknown = [n for n in names if n not in FIGURES and n not in SHEETS]
    if unknown:
        raise UsageError(f"--only: no figure {', '.join(unknown)}; the figures are "
                         f"{', '.join([*FIGURES, *SHEETS])}")
    from citysynth.export.preview import render_meshes  # pyvista: only when rendering

    db = load_library(examples.SAMPLE_LIBRARY)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in names:
        t = time.perf_counter()
        if name in SHEETS:
            print(f"{_joints(db, out)}, {time.perf_counter() - t:.1f} s)")
            continue
        lays, title = FIGURES[name](db)
        path = render_meshes(side_by_side(lays, db), out / f"{name}.png", title=title)
        print(f"{path}  ({len(lays)} layout(s), {time.perf_counter() - t:.1f} s)")
    return 0
