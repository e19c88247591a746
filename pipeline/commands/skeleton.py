"""``citysynth skeleton FILE``: read GeoJSON and show the skeletons it makes (key
points with their classes, edges, lengths), to check input before building."""

from __future__ import annotations

import json

from citysynth.pipeline.errors import UsageError

KINDS = ("auto", "lines", "polygons", "streets")


def register(sub) -> None:
    p = sub.add_parser("skeleton", help="show the skeletons a GeoJSON file makes",
                       description="Read GeoJSON (lon/lat, or projected with --crs) and print "
                                   "the skeletons: building skeleton lines, footprint or "
                                   "block polygons (one cycle per ring), or street centre "
                                   "lines polygonised into blocks. Exit 2 on bad input.")
    p.add_argument("file", help="GeoJSON, or a GeoPackage, Shapefile, FlatGeobuf, KML"
                   ", Esri JSON, GML, MapInfo, GeoParquet, DXF or File Geodatabase layer "
                   "(FILE::LAYER)")
    p.add_argument("--kind", choices=KINDS, default="auto",
                   help="lines: one building skeleton; polygons: footprints/blocks; "
                        "streets: centre lines -> blocks (auto: polygons by geometry, streets when "
                        "lines carry a highway tag, else lines)")
    p.add_argument("--crs", default=None, help="CRS of projected input, e.g. EPSG:25832")
    p.add_argument("--setback", type=float, default=6.0, help="streets: inset in metres")
    p.add_argument("--json", action="store_true", help="print the skeletons as JSON")
    p.set_defaults(run=run)


def run(args) -> int:
    from citysynth.skeletons import (  # shapely, pyproj: when run (see pipeline.cli)
        Feature,
        blocks_from_streets,
        describe,
        read_geojson,
        skeleton_from_lines,
        skeletons_from_polygons,
    )

    if not 0 <= args.setback < 1000:
        raise UsageError(f"--setback must be a distance in metres from 0 to 1000, got "
                         f"{args.setback:g}")
    feats, frame = read_geojson(args.file, crs=args.crs)
    kind = args.kind
    if kind == "auto":   # OSM-style street lines carry "highway"; a skeleton never does
        polygonal = all(f.geometry.geom_type in ("Polygon", "MultiPolygon") for f in feats)
        streets = any("highway" in f.properties for f in feats)
        kind = "polygons" if polygonal else "streets" if streets else "lines"
    skipped: list[str] = []
    if kind == "lines":
        skels = [skeleton_from_lines(feats, frame, name=str(args.file))]
    elif kind == "polygons":
        skels = skeletons_from_polygons(feats, frame)
    else:
        blocks, skipped = blocks_from_streets(feats, setback=args.setback)
        skels = skeletons_from_polygons(
            [Feature(i, b, {"id": f"block {i}"}) for i, b in enumerate(blocks)], frame)
    if args.json:
        print(json.dumps({"frame": frame.describe(), "skipped": skipped,
                          "skeletons": [s.to_dict() for s in skels]}, indent=1))
        return 0
    print(f"frame: {frame.describe(told=True)}")
    for s in skels:
        print(describe(s))
    for reason in skipped:
        print(f"skipped {reason}")
    if kind == "streets" and not skels and not skipped:
        # two crossing streets, a cul-de-sac: exit 0 with only the frame line said nothing
        print(f"no blocks: the {len(feats)} street line(s) enclose no ground (blocks are "
              "the faces the streets close all round)")
    return 0
