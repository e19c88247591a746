"""``citysynth diff A B --png MAP.png``: the diff as a plan, block outlines coloured by
what changed, so a regression is seen where it is before it is read block by block.

The outlines come from each run's ``blocks.geojson`` (lon/lat, or the run's CRS: every
block of a run shares one frame), drawn from above with Pillow: no GPU, no window, the
same bytes for the same two runs. Blocks of run B are drawn in their state; blocks only
run A has (removed) are drawn from A, hatched. Pieces a run skipped are outlines only.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import shapely
import shapely.errors
import shapely.geometry
from PIL import Image, ImageDraw, ImageFont

from citysynth.parts_db.files import atomic_path
from citysynth.pipeline.errors import UsageError
from citysynth.skeletons.degrees import in_degrees
from citysynth.solver.safe_read import read_json

BLOCKS = "blocks.geojson"
SIZE = 1600                 # px: the longer side of the map
MARGIN = 40                 # px round the blocks
LEGEND = 280                # px: the legend column on the right
MARK = 9                    # px: the radius of the ring round a block that differs
# what happened to a block -> (fill, legend text); drawn in this order
COLOURS: dict[str, tuple[tuple[int, int, int], str]] = {
    "same": ((212, 212, 212), "the same"),
    "files": ((240, 196, 40), "same layout, other files"),
    "changed": ((230, 110, 20), "layout changed"),
    "status": ((150, 80, 200), "status changed"),
    "added": ((50, 165, 80), "added"),
    "removed": ((215, 45, 45), "removed (run A's outline)"),
}
NOT_BUILT = (248, 248, 248)
EDGE = (90, 90, 90)


def outlines(run: Path) -> tuple[dict[str, tuple[shapely.Geometry, str]], str | None]:
    """Block id -> (outline, status) from the run's ``blocks.geojson``; and its CRS
    member's name (None: lon/lat)."""
    path = run / BLOCKS
    if not path.exists():
        raise UsageError(f"{path}: missing; --png draws the blocks citysynth city lists "
                         f"there: rerun citysynth city into {run}")
    data = read_json(path, "block outlines", UsageError)
    out: dict[str, tuple[shapely.Geometry, str]] = {}
    for i, f in enumerate(data.get("features", []) if isinstance(data, dict) else []):
        if isinstance(f, dict) and f.get("geometry") is None:
            continue        # a piece skipped with nothing to draw
        try:
            props, geom = f["properties"], shapely.geometry.shape(f["geometry"])
            bid = str(props.get("id", f"piece {i}"))
        except (KeyError, TypeError, ValueError, AttributeError,
                shapely.errors.GEOSException):
            raise UsageError(f"{path}: feature {i} is not a block outline (damaged?); "
                             f"rerun citysynth city into {run}") from None
        if not geom.is_empty:
            out[bid] = (geom, str(props.get("status", "")))
    try:
        crs = data["crs"]["properties"]["name"]
    except (KeyError, TypeError):
        crs = None
    return out, crs if isinstance(crs, str) else None


def _states(d: dict[str, Any]) -> dict[str, str]:
    """Block id -> what the diff ``d`` says happened to it (blocks not named: the same,
    or not built), looked up once per block instead of a scan of each list."""
    out = {c["id"]: state for key, state in (("status", "status"), ("files_changed", "files"),
                                             ("changed", "changed")) for c in d[key]}
    out.update({bid: state for key, state in (("removed", "removed"), ("added", "added"))
                for bid in d[key]})
    out.update({r["b"]: renamed_state(r) for r in d.get("renamed", [])})
    return out


def renamed_state(r: dict[str, Any]) -> str:
    """What happened to a block drawn in the same place under a new id (its layout
    compared as a block both runs have)."""
    return "status" if r["status"] else "changed" if r["change"] else "same"


def write_map(d: dict[str, Any], run_a: Path, run_b: Path, png: Path) -> Path:
    """Draw the diff ``d`` of ``run_a`` and ``run_b`` (:func:`..diff.diff_runs`) as a
    plan at ``png`` (written whole or not at all)."""
    (a, _), (b, _), states = outlines(run_a), outlines(run_b), _states(d)
    shapes: list[tuple[shapely.Geometry, tuple[int, int, int], bool]] = []
    marks: list[tuple[shapely.Point, tuple[int, int, int]]] = []   # small changes show
    for bid, (geom, status) in sorted(b.items()):
        state = states.get(bid) or ("same" if status == "built" else None)
        shapes.append((geom, COLOURS[state][0] if state else NOT_BUILT, False))
        if state not in (None, "same"):
            marks.append((geom.representative_point(), COLOURS[state][0]))
    for bid in d["removed"]:
        if bid in a:
            shapes.append((a[bid][0], COLOURS["removed"][0], True))
            marks.append((a[bid][0].representative_point(), COLOURS["removed"][0]))
    if not shapes:
        raise UsageError(f"{run_b / BLOCKS}: no block outlines to draw")
    shapes, marks = _across_antimeridian(shapes, marks)
    x0, y0, x1, y1 = shapely.total_bounds([g for g, _, _ in shapes])
    squash = math.cos(math.radians((y0 + y1) / 2)) if in_degrees(x0, y0, x1, y1) \
        else 1.0     # lon/lat: metres east shrink with latitude
    w, h = max((x1 - x0) * squash, 1e-9), max(y1 - y0, 1e-9)
    scale = (SIZE - 2 * MARGIN) / max(w, h)
    size = (int(w * scale) + 2 * MARGIN + LEGEND, max(int(h * scale) + 2 * MARGIN, 260))
    img = Image.new("RGB", size, (255, 255, 255))
    draw = ImageDraw.Draw(img)

    def px(coords) -> list[tuple[float, float]]:
        return [(MARGIN + (x - x0) * squash * scale, size[1] - MARGIN - (y - y0) * scale)
                for x, y, *_ in coords]

    for geom, fill, hatched in shapes:
        for poly in shapely.get_parts(geom):
            if poly.geom_type != "Polygon":
                continue
            draw.polygon(px(poly.exterior.coords), fill=fill if not hatched else None,
                         outline=EDGE if not hatched else fill, width=1 if not hatched else 3)
            for ring in poly.interiors:
                draw.polygon(px(ring.coords), fill=(255, 255, 255), outline=EDGE)
    for point, colour in marks:    # a ring round each block that differs, however small
        ((x, y),) = px(point.coords)
        draw.ellipse((x - MARK - 2, y - MARK - 2, x + MARK + 2, y + MARK + 2),
                     outline=(0, 0, 0), width=2)
        draw.ellipse((x - MARK, y - MARK, x + MARK, y + MARK), outline=colour, width=3)
    _legend(draw, d, size, run_a, run_b)
    with atomic_path(png) as tmp:
        img.save(tmp, format="PNG")
    return png


def _across_antimeridian(shapes: list, marks: list) -> tuple[list, list]:
    """Lon/lat outlines of a city across the ±180° meridian (blocks.geojson cuts a block
    there into two parts, RFC 7946) with longitudes taken in 0..360, where that makes
    the map narrower: drawn as they are, the map spanned the globe and the city was a
    dot at either edge."""
    x0, y0, x1, y1 = shapely.total_bounds([g for g, _, _ in shapes])
    if not (in_degrees(x0, y0, x1, y1) and x1 - x0 > 180):
        return shapes, marks

    def east(g: shapely.Geometry) -> shapely.Geometry:
        return shapely.transform(g, lambda xy: xy + [[360.0, 0.0]] * (xy[:, :1] < 0))

    moved = [(east(g), fill, hatched) for g, fill, hatched in shapes]
    e0, _, e1, _ = shapely.total_bounds([g for g, _, _ in moved])
    if e1 - e0 >= x1 - x0:
        return shapes, marks
    return moved, [(east(p), colour) for p, colour in marks]


def _legend(draw: ImageDraw.ImageDraw, d: dict[str, Any], size: tuple[int, int],
            run_a: Path, run_b: Path) -> None:
    font = ImageFont.load_default(size=15)
    counts = {"same": d["same"] + len(d.get("library_only", [])), "files": len(d["files_changed"]),
              "changed": len(d["changed"]), "status": len(d["status"]),
              "added": len(d["added"]), "removed": len(d["removed"])}
    for r in d.get("renamed", []):   # drawn in their state, so counted in it
        counts[renamed_state(r)] += 1
    x = size[0] - LEGEND + 10
    draw.text((x, 12), f"A: {run_a.name}", fill=(0, 0, 0), font=font)
    draw.text((x, 32), f"B: {run_b.name}", fill=(0, 0, 0), font=font)
    for i, (key, (fill, text)) in enumerate(COLOURS.items()):
        y = 64 + 26 * i
        draw.rectangle((x, y, x + 16, y + 14), fill=fill, outline=EDGE)
        draw.text((x + 24, y + 1), f"{text}: {counts[key]}", fill=(0, 0, 0), font=font)
