"""Export benchmark: a 40-corner block (a staircase of 40 m steps, modern style, the
sample library), k=1, from skeleton to files: solve + layout, USD, GLB, preview; median
of --runs runs after a warm-up, and the sizes of what is written.

    python -m bench.export [--runs 5]

Target (issue 5): solve + layout + USD under 1 s, and under 2 MB of USD.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from shapely.geometry import Polygon

from bench.timing import timed
from citysynth.export.gltf import write_glb
from citysynth.export.preview import render_layout
from citysynth.export.usd import write_layout
from citysynth.parts_db import load_library
from citysynth.pipeline.layouts import solve_layouts
from citysynth.skeletons import Feature, Frame, skeletons_from_polygons

ROOT = Path(__file__).resolve().parent.parent


def staircase(corners: int = 40, step: float = 40.0) -> Polygon:
    """A rectilinear block with ``corners`` corners (alternately convex and concave
    along the stairs): ``(corners - 2) / 2`` steps of ``step`` metres."""
    m = (corners - 2) // 2
    pts, x, y = [(0.0, 0.0)], 0.0, 0.0
    for _ in range(m):
        x += step
        pts.append((x, y))
        y += step
        pts.append((x, y))
    pts.append((0.0, y))
    return Polygon(pts)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    db = load_library(ROOT / "examples" / "library")
    frame = Frame("local metres", (0.0, 0.0))
    poly = staircase()
    (sk,) = skeletons_from_polygons([Feature(0, poly, {"id": "block40"})], frame)
    corners = sum(k.kind == "corner" for k in sk.keypoints)
    t_solve, built = timed(lambda: solve_layouts("block40", [sk], db, "modern"), args.runs)
    lay = built[0].layouts[0]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        runs = iter(range(10 ** 6))

        def usd_fresh():  # into a new folder each time: the part prototypes are written too
            return write_layout(lay, db, out / f"run{next(runs)}" / "block40.usda")
        t_usd, paths = timed(usd_fresh, args.runs)
        usd = paths[0].stat().st_size
        protos = sum(p.stat().st_size for p in (paths[0].parent / "parts").glob("*.usdc"))
        t_glb, _ = timed(lambda: write_glb(lay, db, out / "block40.glb"), args.runs)
        glb = (out / "block40.glb").stat().st_size
        t_png, _ = timed(lambda: render_layout(lay, db, out / "block40.png"),
                         max(1, args.runs // 2))
    print(f"citysynth bench/export.py — a {corners}-corner block, {sk.length:.0f} m of facade, "
          f"{len(lay.instances)} part instances ({len(lay.parts_used())} distinct); median of "
          f"{args.runs} runs after warm-up")
    head = f"{'step':<34} {'ms':>9} {'size':>12}"
    print(head + "\n" + "-" * len(head))
    print(f"{'structure + solve + layout (k=1)':<34} {1e3 * t_solve:>9.1f} {'':>12}")
    print(f"{'USD layer + part prototypes':<34} {1e3 * t_usd:>9.1f} "
          f"{(usd + protos) / 1e6:>9.2f} MB")
    print(f"{'  of which the block layer':<34} {'':>9} {usd / 1e6:>9.2f} MB")
    print(f"{'GLB':<34} {1e3 * t_glb:>9.1f} {glb / 1e6:>9.2f} MB")
    print(f"{'PNG preview':<34} {1e3 * t_png:>9.1f}")
    total = t_solve + t_usd
    print(f"\nsolve + layout + USD: {1e3 * total:.0f} ms (target under 1000 ms); USD "
          f"{(usd + protos) / 1e6:.2f} MB (target under 2 MB)")


if __name__ == "__main__":
    main()
