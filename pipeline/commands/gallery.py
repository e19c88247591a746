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
from pathlib import Path

from citysynth import examples
from citysynth.export.imports import import_shielded
from citysynth.pipeline.errors import UsageError

# The figures (the solver, trimesh, pyvista) are imported when the command runs, so the
# command line starts without them (see pipeline.cli); they live in .gallery_figures.


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


def run(args) -> int:
    from citysynth.parts_db import load_library  # when run (see pipeline.cli)
    from citysynth.pipeline.commands.gallery_figures import (
        FIGURES,
        SHEETS,
        joints_sheet,
        side_by_side,
    )

    names = list(dict.fromkeys(args.only or [*FIGURES, *SHEETS]))   # fig4 fig4: once
    unknown = [n for n in names if n not in FIGURES and n not in SHEETS]
    if unknown:
        raise UsageError(f"--only: no figure {', '.join(unknown)}; the figures are "
                         f"{', '.join([*FIGURES, *SHEETS])}")
    # pyvista only when rendering (Ctrl-C inside VTK's import crashed the process)
    render_meshes = import_shielded("citysynth.export.preview").render_meshes

    db = load_library(examples.SAMPLE_LIBRARY)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in names:
        t = time.perf_counter()
        if name in SHEETS:
            print(f"{joints_sheet(db, out)}, {time.perf_counter() - t:.1f} s)")
            continue
        lays, title = FIGURES[name](db)
        path = render_meshes(side_by_side(lays, db), out / f"{name}.png", title=title)
        print(f"{path}  ({len(lays)} layout(s), {time.perf_counter() - t:.1f} s)")
    return 0
