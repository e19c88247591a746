"""Skeleton inputs: projection, key-point classes, footprints and courtyards, street
blocks, and every kind of bad geometry (one message naming the feature)."""

from __future__ import annotations

import json

import pyproj
import pytest
import shapely

from citysynth.skeletons import (
    SkeletonError,
    blocks_from_streets,
    parse_geojson,
    read_geojson,
    skeleton_from_lines,
    skeletons_from_polygons,
)

GEOD = pyproj.Geod(ellps="WGS84")
LON, LAT = 7.1, 50.73


def fc(*features):
    return {"type": "FeatureCollection", "features": list(features)}


def feat(geom_type, coords, **props):
    return {"type": "Feature", "properties": props,
            "geometry": {"type": geom_type, "coordinates": coords}}


def walk(lon, lat, az, dist):
    x, y, _ = GEOD.fwd(lon, lat, az, dist)
    return [x, y]


def metres(points_xy):
    """Local metric points (x east, y north) -> lon/lat around (LON, LAT)."""
    out = []
    for x, y in points_xy:
        p = walk(LON, LAT, 90.0, x) if x else [LON, LAT]
        p = walk(p[0], p[1], 0.0, y) if y else p
        out.append(p)
    return out


def test_lon_lat_is_projected_to_true_metres():
    a = [LON, LAT]
    b = walk(LON, LAT, 63.0, 137.25)
    feats, frame = parse_geojson(fc(feat("LineString", [a, b])))
    assert feats[0].geometry.length == pytest.approx(137.25, abs=1e-3)
    assert "transverse Mercator" in frame.crs


def test_projected_input_needs_and_honours_an_explicit_crs(tmp_path):
    data = fc(feat("LineString", [[365000.0, 5621000.0], [365030.0, 5621040.0]]))
    with pytest.raises(SkeletonError, match="--crs EPSG"):
        parse_geojson(data)
    feats, frame = parse_geojson(data, crs="EPSG:25832")
    assert feats[0].geometry.length == pytest.approx(50.0)
    data["crs"] = {"type": "name", "properties": {"name": "EPSG:25832"}}
    f = tmp_path / "p.geojson"
    f.write_text(json.dumps(data))
    feats, _ = read_geojson(f)
    assert feats[0].geometry.length == pytest.approx(50.0)
    with pytest.raises(SkeletonError, match="unknown CRS"):
        parse_geojson(data, crs="EPSG:999999")


def test_t_shaped_building_skeleton():
    main = metres([(0, 0), (40, 0)])
    wing = metres([(20, 0), (20, 25), (35, 25)])
    feats, frame = parse_geojson(fc(feat("LineString", main, constraints={"doors": [1, 2]}),
                                    feat("LineString", wing, front="left")))
    sk = skeleton_from_lines(feats, frame)
    kinds = sorted(k.kind for k in sk.keypoints)
    assert kinds == ["corner", "end", "end", "end", "t_junction"]
    assert not sk.closed and len(sk.edges) == 4
    t = next(k for k in sk.keypoints if k.kind == "t_junction")
    assert sk.edges[t.branch].source.startswith("input: feature 1")
    corner = next(k for k in sk.keypoints if k.kind == "corner")
    assert corner.angle == pytest.approx(90, abs=0.01)
    # the wing turns right with its facade on the left: around the mass, convex
    assert corner.convex is True
    main_edges = [e for e in sk.edges if e.source.startswith("input: feature 0")]
    assert [e.constraints for e in main_edges] == [{"doors": (1.0, 2.0)}] * 2
    assert sum(e.length for e in main_edges) == pytest.approx(40, abs=1e-3)


def test_corner_angles_convexity_and_bends():
    pts = metres([(0, 0), (30, 0), (30 + 20 * 0.7071, 20 * 0.7071), (70, 20 * 0.7071),
                  (90, 20 * 0.7071 + 1)])
    feats, frame = parse_geojson(fc(feat("LineString", pts)))
    sk = skeleton_from_lines(feats, frame)
    inner = [k for k in sk.keypoints if k.degree == 2]
    by_x = sorted(inner, key=lambda k: k.xy[0])
    assert by_x[0].kind == "corner" and by_x[0].angle == pytest.approx(135, abs=0.05)
    assert by_x[0].convex is True          # left turn, facade on the right
    assert by_x[1].kind == "corner" and by_x[1].convex is False
    assert by_x[2].kind == "bend"          # 2.9 degrees off straight


def test_footprint_with_courtyard_gives_two_cycles():
    outer = metres([(0, 0), (40, 0), (40, 30), (20, 30), (20, 50), (0, 50), (0, 0)])
    hole = metres([(5, 5), (15, 5), (15, 15), (5, 15), (5, 5)])
    feats, frame = parse_geojson(fc(feat("Polygon", [outer, hole[::-1]], id="house")))
    outline, court = skeletons_from_polygons(feats, frame)
    assert outline.closed and court.closed
    assert sorted(k.convex for k in outline.keypoints) == [False] + [True] * 5
    assert all(k.kind == "corner" and k.convex is False for k in court.keypoints)
    assert outline.length == pytest.approx(180, abs=0.01)
    assert "courtyard" in court.name and all(e.front == "right" for e in court.edges)


def test_streets_polygonise_into_inset_blocks():
    lines = [feat("LineString", metres([(x, -10), (x, 310)])) for x in (0, 100, 200, 300)]
    lines += [feat("LineString", metres([(-10, y), (310, y)])) for y in (0, 100, 200, 300)]
    lines.append(feat("LineString", metres([(-10, 95), (110, 95)])))  # a sliver block
    feats, frame = parse_geojson(fc(*lines))
    blocks, skipped = blocks_from_streets(feats, setback=6.0)
    assert len(blocks) == 9
    areas = sorted(round(b.area) for b in blocks)
    assert areas[0] == pytest.approx(83 * 88, rel=0.01)   # the block next to the sliver
    assert areas[-1] == pytest.approx(88 * 88, rel=0.01)
    assert len(skipped) == 1 and "setback" in skipped[0]
    cycles = skeletons_from_polygons(
        [type(feats[0])(i, b, {}) for i, b in enumerate(blocks)], frame)
    assert all(c.closed for c in cycles)
    # the stub of the y=95 street beyond x=100 cuts its own setback into the next block
    assert sorted(len(c.edges) for c in cycles) == [4] * 8 + [6]


def test_street_setbacks_follow_width_lanes_and_class():
    from citysynth.skeletons.streets import Setbacks, street_blocks
    s = Setbacks(default=5.0, sidewalk=2.0, lane_width=3.0, by_class=(("primary", 12.0),))
    assert s({"width": "8 m"}) == 6.0 and s({"lanes": "2"}) == 5.0
    assert s({"highway": "primary"}) == 12.0 and s({"highway": "track"}) == 5.0
    assert s({"width": "n/a", "lanes": 4}) == 8.0
    lines = [feat("LineString", metres([(x, -10), (x, 110)]), highway="primary" if x else "x")
             for x in (0, 100)]
    lines += [feat("LineString", metres([(-10, y), (110, y)])) for y in (0, 100)]
    feats, _frame = parse_geojson(fc(*lines))
    (block,), skipped = street_blocks(feats, s)
    x0, y0, x1, y1 = block.polygon.bounds
    assert (x1 - x0) == pytest.approx(100 - 12 - 5, abs=0.01)   # primary on one side
    assert (y1 - y0) == pytest.approx(100 - 5 - 5, abs=0.01)
    assert len(block.streets) == 4 and not skipped


def test_a_street_width_or_lanes_not_read_is_warned_of_once():
    """``lanes="two"`` or ``width="wide"`` fell back to the class's setback without a
    word (a footprint's unreadable storeys got a note); now one warning names the first
    such street and counts the others. Streets with a readable width or lanes, or none
    given, are not warned of."""
    import warnings

    from citysynth.skeletons.errors import InputWarning
    from citysynth.skeletons.streets import Setbacks, street_blocks, unread_width
    assert unread_width({"lanes": "two"}) == 'lanes "two"'
    assert unread_width({"width": "n/a", "lanes": 4}) is None
    assert unread_width({"highway": "primary"}) is None
    lines = [feat("LineString", metres([(x, -10), (x, 110)]), lanes="two") for x in (0, 100)]
    lines += [feat("LineString", metres([(-10, 0), (110, 0)]), width="wide"),
              feat("LineString", metres([(-10, 100), (110, 100)]), width="7")]
    feats, _frame = parse_geojson(fc(*lines))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        (block,), _skipped = street_blocks(feats, Setbacks())
    said = [str(w.message) for w in caught if issubclass(w.category, InputWarning)]
    assert len(said) == 1, said
    assert "feature 0" in said[0] and 'lanes "two" is no width in metres' in said[0]
    assert "(and 2 more streets): its highway class's setback is used" in said[0], said
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        street_blocks(feats, 6.0)   # a setback given outright reads no tags
    assert not [w for w in caught if issubclass(w.category, InputWarning)]


def test_a_merged_edge_partly_in_a_tunnel_is_a_street():
    """osmnx merges the ways of an edge and lists their values: a road that dips into a
    tunnel for a stretch has ``tunnel=["no", "yes"]`` (or that list's text in its own
    files). A ``tag=value`` rule matched any value and dropped the whole street, so the
    blocks on either side merged into one; it now needs every value, as the highway
    class rule does."""
    from citysynth.skeletons.streets import NOT_STREETS, not_a_street
    assert not_a_street({"highway": "primary", "tunnel": "yes"}, NOT_STREETS) == "tunnel=yes"
    assert not_a_street({"highway": "primary", "tunnel": ["yes", "yes"]},
                        NOT_STREETS) == "tunnel=yes"
    for partly in (["no", "yes"], "['no', 'yes']", "no;yes"):
        assert not_a_street({"highway": "primary", "tunnel": partly}, NOT_STREETS) is None
    assert not_a_street({"highway": ["footway", "primary"]}, NOT_STREETS) is None
    assert not_a_street({"highway": ["footway", "path"]}, NOT_STREETS) == "highway=footway"
    assert not_a_street({"highway": "primary", "tunnel": None}, NOT_STREETS) is None


def test_streets_split_anywhere_give_the_same_blocks():
    """A network exported as two-point segments (or cut every few metres) gives the
    blocks the whole lines give: a square cap at every piece's end put a corner of it
    into the block at each bend, a saw-tooth of notches (one failed its side)."""
    ring = [(0, 0), (60, -8), (120, 0), (112, 60), (120, 120), (60, 128), (0, 120),
            (8, 60), (0, 0)]      # bent out and in: a cap's corner stands in the block
    whole = [feat("LineString", metres(ring[i:i + 3])) for i in (0, 2, 4, 6)]
    pieces = [feat("LineString", metres([a, b])) for a, b in zip(ring[:-1], ring[1:], strict=True)]
    halves = [feat("LineString", metres([a, ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)]))
              for a, b in zip(ring[:-1], ring[1:], strict=True)] + \
        [feat("LineString", metres([((a[0] + b[0]) / 2, (a[1] + b[1]) / 2), b]))
         for a, b in zip(ring[:-1], ring[1:], strict=True)]
    got = []
    for lines in (whole, pieces, halves):
        feats, _frame = parse_geojson(fc(*lines))
        (block,), _skipped = blocks_from_streets(feats, setback=6.0)
        got.append(shapely.normalize(block))
    inset = shapely.Polygon(ring).buffer(-6.0, join_style="mitre")
    for block in got:   # the street's inset, its 8 corners and no notch anywhere
        assert block.area == pytest.approx(inset.area, rel=1e-4)
        assert len(block.exterior.coords) == len(ring), block.wkt
        assert block.symmetric_difference(got[0]).area < 1e-3


def test_street_blocks_place_only_the_pieces_they_skip():
    """Naming where a block lies (in the input's lon/lat) is for a piece skipped: a
    1,000-block network spent 14 of its 16 s reading its streets placing every block
    it kept; and the transformer that places them is made once."""
    from citysynth.skeletons import geojson
    from citysynth.skeletons.streets import street_blocks
    lines = [feat("LineString", metres([(x, -10), (x, 210)])) for x in (0, 100, 103)]
    lines += [feat("LineString", metres([(-10, y), (110, y)])) for y in (0, 100, 200)]
    feats, frame = parse_geojson(fc(*lines))
    placed = []

    def locate(xy):
        placed.append(xy)
        return frame.at(xy)
    blocks, skipped = street_blocks(feats, 6.0, locate=locate)
    assert len(blocks) == 2 and len(skipped) == 2   # the 3 m strips between x=100 and 103
    assert len(placed) == len(skipped) and all(" at (" in r for r in skipped)
    geojson.transformer.cache_clear()
    for _ in range(3):
        frame.at((5.0, 5.0))
    assert geojson.transformer.cache_info().misses == 1


@pytest.mark.parametrize("features, kind, fragment", [
    ([feat("Polygon", [metres([(0, 0), (10, 10), (10, 0), (0, 10), (0, 0)])], id="bow")],
     "poly", "invalid polygon"),
    # where and how, not "degenerate polygon (area 0.00 m²)"
    ([feat("Polygon", [metres([(0, 0), (10, 0), (20, 0), (0, 0)])])], "poly",
     "encloses 0.00 m², under the 1 m² of the smallest block; check its coordinates are in "
     "the CRS the file says (or --crs), or remove it"),
    # what a block is laid out from, not "expected a Polygon, got GeometryCollection"
    # (a collection of polygons and label points is read as its polygons)
    ([{"type": "Feature", "properties": {}, "geometry": {
        "type": "GeometryCollection", "geometries": [{"type": "Polygon", "coordinates": [
            metres([(0, 0), (20, 0), (20, 20), (0, 0)])]},
            {"type": "LineString", "coordinates": metres([(0, 0), (20, 0)])}]}}], "poly",
     "a GeometryCollection is no outline; blocks are laid out from Polygon and "
     "MultiPolygon features (holes as courtyards); give each of its polygons as a feature "
     "of its own"),
    ([feat("Polygon", [metres([(0, 0), (20, 0), (20, 20), (0, 20), (0, 0)]),
                       metres([(30, 0), (35, 0), (35, 5), (30, 5), (30, 0)])])], "poly",
     "(hole lies outside shell at ("),
    ([feat("Polygon", [metres([(0, 0), (20, 0), (20, 20), (0, 20), (0, 0)]),
                       metres([(30, 0), (35, 0), (35, 5), (30, 5), (30, 0)])])], "poly",
     "); move the courtyard inside the outline, or drop it"),
    # a courtyard touching the outline is valid, but no wall stands between: a block's
    # parts were laid out 28 m past its outline
    ([feat("Polygon", [metres([(0, 0), (60, 0), (60, 50), (0, 50), (0, 0)]),
                       metres([(0, 0), (30, 20), (30, 10), (0, 0)])], id="v")], "poly",
     "feature 0 (v): courtyard 1 reaches the outline at ("),
    ([feat("Polygon", [metres([(0, 0), (60, 0), (60, 50), (0, 50), (0, 0)]),
                       metres([(30, 0), (20, 20), (40, 20), (30, 0)])])], "poly",
     "), with no wall between; move the courtyard in from it, or make it a notch"),
    ([feat("Polygon", [metres([(0, 0), (60, 0), (60, 50), (0, 50), (0, 0)]),
                       metres([(10, 10), (10, 20), (20, 20), (20, 10), (10, 10)]),
                       metres([(20, 20), (20, 30), (30, 30), (30, 20), (20, 20)])])],
     "poly", "courtyard 2 reaches courtyard 1 at ("),
    ([feat("LineString", metres([(0, 0), (2, 0), (2, 30)]))], "lines", "shorter than the "
     "smallest part"),
    ([feat("LineString", metres([(0, 0), (30, 0)])),
      feat("LineString", metres([(50, 0), (80, 0)]))], "lines", "disconnected"),
    ([feat("LineString", metres([(0, 0), (30, 0)])),
      feat("LineString", metres([(15, -10), (15, 10)]))], "lines", "cross"),
    ([feat("LineString", metres([(0, 0), (20, 0)])),
      feat("LineString", metres([(20, 0), (40, 0)])),
      feat("LineString", metres([(20, 0), (20, 20)])),
      feat("LineString", metres([(20, 0), (20, -20)]))], "lines", "4 edges meet"),
    ([feat("LineString", metres([(0, 0), (20, 0)])),
      feat("LineString", metres([(20, 0), (20, 20)]), front="left")], "lines",
     'put their facades on opposite sides; a line\'s facades face the left of the way it is '
     'drawn (its "front"), and feature 1 is drawn away from this point: reverse it, or give '
     'it "front": "right"'),
    ([feat("Point", [LON, LAT])], "lines", "LineStrings"),
    ([feat("LineString", metres([(0, 0), (30, 0)]), constraints={"doors": [3, 1]})], "lines",
     "constraint doors"),
    ([feat("LineString", metres([(0, 0), (30, 0)])),    # the wing cuts off a 1 m stub
      feat("LineString", metres([(29, 0), (29, 20)]))], "lines", "shorter than the smallest"),
])
def test_bad_geometry_is_one_message(features, kind, fragment):
    assert fragment in skeleton_error(features, kind)


def test_a_skeleton_of_many_pieces_names_three_in_one_short_line():
    """1,000 disconnected lines: the message listed every piece's key point count (2,103
    characters) and named no line."""
    msg = skeleton_error([feat("LineString", metres([(50 * i, 0), (50 * i + 30, 0)]))
                          for i in range(1000)], "lines")
    assert "1,000 separate pieces, feature 0 / feature 1 / feature 2 and 997 more" in msg
    assert "lines join only where an end of one lies on the other (within 1 cm), and the " \
        "largest lies 20.0 m from the nearest other at (" in msg and len(msg) < 400, msg


def test_a_wing_ending_short_of_its_main_line_says_by_how_much():
    """A wing drawn to end 2 cm short of the main line: two buildings' worth of lines,
    and the message says where they nearly meet."""
    msg = skeleton_error([feat("LineString", metres([(0, 0), (63, 0)])),
                          feat("LineString", metres([(31.5, -0.02), (31.5, -40)]))],
                         "lines")
    assert "2 separate pieces" in msg and "lies 20 mm from the nearest other at (" in msg


def test_a_point_not_finite_is_named():
    """A GIS file's geometry with an infinite or NaN coordinate (GeoJSON's parser refuses
    them first) names the point, not just "non-finite coordinates"."""
    from citysynth.skeletons.geojson import _geometry
    with pytest.raises(SkeletonError, match=r"f.gpkg: feature 3: its point 1 \(\[1.0, "
                       r"Infinity\]\) is not finite numbers; fix or remove that point"):
        _geometry({"type": "LineString", "coordinates": [[0, 0], [1, float("inf")], [2, 2]]},
                  "f.gpkg: feature 3")


def skeleton_error(features: list, kind: str) -> str:
    """The message reading ``features`` as polygons ("poly") or skeleton lines raises."""
    feats, frame = parse_geojson(fc(*features))
    with pytest.raises(SkeletonError) as exc:
        if kind == "poly":
            skeletons_from_polygons(feats, frame)
        else:
            skeleton_from_lines(feats, frame, min_edge=3.0)
    return str(exc.value)


def test_malformed_geojson(tmp_path):
    f = tmp_path / "x.geojson"
    f.write_text("{nope")
    with pytest.raises(SkeletonError, match="not valid JSON at line 1"):
        read_geojson(f)
    with pytest.raises(SkeletonError, match="not a GeoJSON FeatureCollection"):
        parse_geojson({"type": "Topology"})
    with pytest.raises(SkeletonError, match="feature 0: malformed LineString"):
        parse_geojson(fc({"type": "Feature", "properties": {},
                          "geometry": {"type": "LineString", "coordinates": [[1]]}}))


def test_skeleton_cli(capsys, tmp_path):
    from pathlib import Path

    from citysynth.pipeline.cli import main
    examples = Path(__file__).resolve().parent.parent / "examples" / "skeletons"
    assert main(["skeleton", str(examples / "t_building.geojson")]) == 0
    out = capsys.readouterr().out
    assert "tree, 4 edges, 135.4 m" in out and "1 t_junction" in out
    assert main(["skeleton", str(examples / "footprint_courtyard.geojson"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert [len(s["edges"]) for s in d["skeletons"]] == [4, 4]
    bad = tmp_path / "bad.geojson"
    bad.write_text(json.dumps(fc(feat("LineString", metres([(0, 0), (30, 0)])),
                                 feat("LineString", metres([(15, -10), (15, 10)])))))
    assert main(["skeleton", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "cross" in err and len(err.strip().splitlines()) == 1


def test_corner_angles_match_the_library_within_a_tolerance():
    from citysynth.skeletons import match_corner_angles
    outer = metres([(0, 0), (40, 0), (40, 30), (20, 30), (20, 50), (0, 50), (0, 0)])
    feats, frame = parse_geojson(fc(feat("Polygon", [outer])))
    (sk,) = skeletons_from_polygons(feats, frame)
    lib = [(90, True), (90, False), (135, True)]
    chosen = match_corner_angles(sk, lib)
    assert sorted(chosen.values()) == [(90.0, False)] + [(90.0, True)] * 5
    with pytest.raises(SkeletonError) as exc:
        match_corner_angles(sk, [(90, True), (135, False)])
    msg = str(exc.value)
    assert "concave corner of 90.0°" in msg and "90° convex, 135° concave" in msg


def test_a_round_ring_gets_one_seam():
    """A ring that only bends (a 64-gon: 5.6° a vertex) would have nowhere to anchor
    parts; its sharpest bend becomes a corner, once, and the rest stay bends. A ring
    with a real corner is left as it is."""
    import math
    circle = metres([(40 * math.cos(2 * math.pi * i / 64), 40 * math.sin(2 * math.pi * i / 64))
                     for i in range(64)] + [(40.0, 0.0)])
    circle[7] = [circle[7][0] * 1.0000005, circle[7][1]]     # 0.25 m out: the sharpest bend
    feats, frame = parse_geojson(fc(feat("Polygon", [circle], id="plaza")))
    (sk,) = skeletons_from_polygons(feats, frame)
    corners = [k for k in sk.keypoints if k.kind == "corner"]
    assert len(corners) == 1 and len(sk.keypoints) == 64
    assert corners[0].id == 7 and corners[0].convex is True and 165 < corners[0].angle < 175
    lines = skeleton_from_lines(*parse_geojson(fc(feat("LineString", circle))))
    assert lines.closed and sum(k.kind == "corner" for k in lines.keypoints) == 1
    square = metres([(0, 0), (30, 0), (30, 30), (0, 30), (0, 0)])
    (sq,) = skeletons_from_polygons(*parse_geojson(fc(feat("Polygon", [square]))))
    assert [k.kind for k in sq.keypoints] == ["corner"] * 4


def test_a_densely_drawn_curve_is_one_side():
    """Edges between bends need not hold a part: a circle drawn with 2,000 vertices
    (15 cm edges) is one side round a seam, as a smooth one is, and is simplified within
    2 cm first (about 110 vertices: modules fold across a few bends, not dozens)."""
    import math
    circle = metres([(48 * math.cos(2 * math.pi * i / 2000), 48 * math.sin(2 * math.pi * i / 2000))
                     for i in range(2000)] + [(48.0, 0.0)])
    (sk,) = skeletons_from_polygons(*parse_geojson(fc(feat("Polygon", [circle]))), min_edge=2.4)
    assert sum(k.kind == "corner" for k in sk.keypoints) == 1
    assert 80 < len(sk.keypoints) < 150


def _located(message: str) -> tuple[float, float]:
    import re
    m = re.search(r" at \((-?[\d.]+), (-?[\d.]+)\)", message)
    assert m is not None, message
    return float(m.group(1)), float(m.group(2))


@pytest.mark.parametrize("features, kind, where", [
    ([feat("Polygon", [metres([(0, 0), (10, 10), (10, 0), (0, 10), (0, 0)])], id="bow")],
     "poly", (5, 5)),
    ([feat("LineString", metres([(0, 0), (30, 0)])),
      feat("LineString", metres([(15, -10), (15, 10)]))], "lines", (15, 0)),
    ([feat("LineString", metres([(0, 0), (20, 0), (20, 0), (20, 20)]))], "lines", (20, 0)),
])
def test_a_bad_geometry_is_located_in_the_inputs_coordinates(features, kind, where):
    """Where a skeleton error lies is given in lon/lat, as the file has it (to 1e-6°),
    not in the local frame's metres, so a user finds it in their GIS."""
    assert _located(skeleton_error(features, kind)) == pytest.approx(metres([where])[0],
                                                                     abs=2e-6)


def test_a_bad_geometry_is_located_in_a_kept_projected_crs_in_its_unit():
    """In a CRS kept as it is (New York's Long Island plane, in US feet), the place is
    given in that CRS's feet, not in the frame's metres."""
    import pyproj
    tf = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:2263", always_xy=True)
    ring = [list(tf.transform(-73.98 + x * 1e-4, 40.75 + y * 1e-4))   # crossing off centre
            for x, y in ((0, 0), (1, 1), (1, 0), (0, 1), (-2, 1), (0, 0))]
    data = dict(fc(feat("Polygon", [ring])),
                crs={"type": "name", "properties": {"name": "EPSG:2263"}})
    feats, frame = parse_geojson(data)
    assert frame.crs.endswith("(projected, EPSG:2263)")
    with pytest.raises(SkeletonError, match="self-intersection at") as exc:
        skeletons_from_polygons(feats, frame)
    import shapely
    from shapely.validation import explain_validity
    geos = _located(" at (" + explain_validity(shapely.Polygon(ring)).split("[")[1]
                    .rstrip("]").replace(" ", ", ") + ")")   # GEOS, in the file's feet
    assert _located(str(exc.value)) == pytest.approx(geos, abs=0.02)


def _utm(*features):
    return parse_geojson(fc(*features), crs="EPSG:25832")


def test_a_densely_drawn_line_is_its_shape_not_its_vertices():
    """A straight 150 m side drawn with 1,000 points is one edge (each vertex was a bend
    cutting the parts across it: 950 part pieces instead of 20, and 48 s instead of 3);
    a quarter circle densified every 2 cm keeps its shape within 2 cm with few bends."""
    import math

    import numpy as np
    import shapely
    x0, y0 = 366000.0, 5622000.0
    line = [[x0 + 150 * i / 999, y0] for i in range(1000)]
    feats, frame = _utm(feat("LineString", line))
    sk = skeleton_from_lines(feats, frame)
    assert len(sk.edges) == 1 and sk.edges[0].length == pytest.approx(150.0)
    arc = [[x0 + 40 * math.cos(t), y0 + 40 * math.sin(t)]
           for t in np.linspace(0, math.pi / 2, 3142)]
    feats, frame = _utm(feat("LineString", arc))
    sk = skeleton_from_lines(feats, frame)
    drawn = feats[0].geometry
    kept = shapely.LineString([k.xy for k in sorted(sk.keypoints, key=lambda k: k.id)])
    assert 3 < len(sk.edges) < 200
    assert shapely.hausdorff_distance(kept, drawn) <= 0.02 + 1e-9


def test_dense_lines_keep_the_vertices_where_lines_meet():
    """A wing ending on an inner vertex of a densely drawn main line stays joined there
    (a T junction); a dense closed line keeps its four corners and stays closed."""
    x0, y0 = 366000.0, 5622000.0
    main = [[x0 + i * 0.5, y0] for i in range(121)]                  # 60 m, a point a 0.5 m
    wing = [[x0 + 30.0, y0 + j * 0.5] for j in range(61)]            # from (30, 0) north
    feats, frame = _utm(feat("LineString", main), feat("LineString", wing))
    sk = skeleton_from_lines(feats, frame)
    assert sorted(k.degree for k in sk.keypoints) == [1, 1, 1, 3]
    square = [[x0 + i, y0] for i in range(40)] + [[x0 + 40, y0 + i] for i in range(40)] + \
        [[x0 + 40 - i, y0 + 40] for i in range(40)] + [[x0, y0 + 40 - i] for i in range(41)]
    feats, frame = _utm(feat("LineString", square))                   # drawn closed
    sk = skeleton_from_lines(feats, frame)
    assert sk.closed and sorted(k.kind for k in sk.keypoints) == ["corner"] * 4


def test_a_repeated_point_of_a_dense_line_is_still_told():
    x0, y0 = 366000.0, 5622000.0
    line = [[x0 + i, y0] for i in range(30)]
    line.insert(10, list(line[10]))
    feats, frame = _utm(feat("LineString", line))
    with pytest.raises(SkeletonError, match="a zero-length edge at .*remove the repeated"):
        skeleton_from_lines(feats, frame)


@pytest.mark.parametrize("geometry, text", [
    ({"type": "Circle", "coordinates": [0, 0]}, 'unknown geometry type "Circle"; GeoJSON has'),
    ({"type": "Polygon"}, "malformed Polygon (its coordinates must be an array: [[[x, y]"),
    ({"type": "Polygon", "coordinates": 5}, "malformed Polygon (its coordinates must be an"),
    ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0, 3], [1, 1], [0, 0]]]},
     "every position with the same count of numbers"),
    ({"type": "LineString", "coordinates": [0, 0]}, "malformed LineString (its coordinates "
                                                    "do not nest as a LineString's do"),
])
def test_malformed_geometry_says_how_it_should_nest(geometry, text):
    """Not numpy's or Python's words ("inhomogeneous shape", "'int' object is not
    subscriptable", "'coordinates'")."""
    with pytest.raises(SkeletonError) as exc:
        parse_geojson(fc({"type": "Feature", "properties": {}, "geometry": geometry}))
    assert text in str(exc.value)
    assert not any(w in str(exc.value) for w in ("inhomogeneous", "subscriptable", "array "
                                                 "element", "object is"))


def test_a_multipolygon_whose_parts_overlap_is_refused_where_they_do():
    """Each part valid, together not: two buildings on the same ground (built as two
    overlapping blocks, exit 0, before)."""
    a = [[366000.0, 5622000.0], [366040.0, 5622000.0], [366040.0, 5622030.0],
         [366000.0, 5622030.0], [366000.0, 5622000.0]]
    b = [[x + 20.0, y] for x, y in a]
    feats, frame = _utm(feat("MultiPolygon", [[a], [b]]))
    with pytest.raises(SkeletonError, match=r"feature 0: its polygons overlap \(self-"
                                            r"intersection at \(3660\d\d\.\d\d, "):
        skeletons_from_polygons(feats, frame)
    apart = [[x + 60.0, y] for x, y in a]
    feats, frame = _utm(feat("MultiPolygon", [[a], [apart]]))
    assert len(skeletons_from_polygons(feats, frame)) == 2


def test_points_and_sides_in_messages():
    """A side shorter than the points' precision (5 cm in lon/lat's 6 decimals) was
    "from (7.100000, 50.730000) to (7.100000, 50.730000)"; a point just west of
    Greenwich "(-0.000000, ...)"."""
    from citysynth.skeletons.geojson import format_xy, side_words
    assert format_xy((-1e-7, 89.9999)) == "(0.000000, 89.999900)"
    assert format_xy((-0.001, 12.0)) == "(-0.001000, 12.000000)"
    assert format_xy((-0.001, 500.0)) == "(0.00, 500.00)"
    p = format_xy((7.1, 50.73))
    assert side_words(0.05, p, p) == "the 0.05 m side at (7.100000, 50.730000)"
    assert side_words(6.0, "(0.00, 0.00)", "(6.00, 0.00)") == \
        "the 6.00 m side from (0.00, 0.00) to (6.00, 0.00)"


def test_pieces_of_one_block_skipped_are_told_apart():
    """The setbacks may cut a block in pieces (a dumbbell's neck): each skipped piece
    was "block 0 at (x, y)" with the same point, the block's; and an area rounded up
    read "50.0 m² after the setbacks, below 50 m²". Each piece is named and placed on
    its own, and its area rounded down."""
    import math

    from citysynth.skeletons.streets import street_blocks
    ring = [(0, 0), (40, 0), (40, 15), (70, 15), (70, 0), (110, 0), (110, 40), (70, 40),
            (70, 25), (40, 25), (40, 40), (0, 40), (0, 0)]
    feats, frame = parse_geojson(fc(feat("LineString", metres(ring))))
    blocks, _ = street_blocks(feats, 6.0, min_area=0.0)
    areas = sorted((b.polygon.area for b in blocks), reverse=True)
    assert len(areas) == 2                           # the 10 m neck is gone
    blocks, skipped = street_blocks(feats, 6.0, min_area=2000.0, locate=frame.at)
    assert not blocks and len(skipped) == 2
    assert skipped[0].startswith("block 0 (piece 1 of 2) at (")
    assert skipped[1].startswith("block 0 (piece 2 of 2) at (")
    assert skipped[0].split(" at ")[1] != skipped[1].split(" at ")[1]
    for reason, area in zip(skipped, areas, strict=True):
        assert f": {math.floor(area * 10) / 10:.1f} m² after the setbacks, below 2000 m²" \
            in reason, (reason, area)


def test_a_collection_of_street_lines_is_streets():
    """A GeometryCollection of LineStrings (some GIS exports write a street's pieces
    so) was "no street centre lines (LineStrings) in the input" though it held seven.
    It is read as the MultiLineString it is; one holding other geometry is told."""
    from citysynth.skeletons.streets import street_blocks
    lines = [metres([(x, -10), (x, 110)]) for x in (0, 100)] + \
        [metres([(-10, y), (110, y)]) for y in (0, 100)]
    multi, _ = parse_geojson(fc(feat("MultiLineString", lines)))
    coll, _ = parse_geojson(fc({"type": "Feature", "properties": {}, "geometry": {
        "type": "GeometryCollection",
        "geometries": [{"type": "LineString", "coordinates": c} for c in lines]}}))
    want, _ = street_blocks(multi, 6.0)
    got, skipped = street_blocks(coll, 6.0)
    assert len(got) == 1 and not skipped
    assert got[0].polygon.equals(want[0].polygon)
    mixed, _ = parse_geojson(fc({"type": "Feature", "properties": {}, "geometry": {
        "type": "GeometryCollection", "geometries": [
            {"type": "Point", "coordinates": lines[0][0]},
            *({"type": "LineString", "coordinates": c} for c in lines)]}}))
    with pytest.raises(SkeletonError, match=r"no street centre lines \(LineStrings\) in the "
                       r"input; e\.g\. input: feature 0: a GeometryCollection is no street centre "
                       r"line .*split it into LineString features"):
        street_blocks(mixed, 6.0)


@pytest.mark.parametrize("tip", [25.0, 18.0, 29.0])
def test_a_sharp_corner_between_long_sides_is_the_ground_s_own(tip):
    """Cleaning a street block cut every corner sharper than 30° along the chord
    between its neighbours, as if it were a spike of survey noise: a trapezoid with a
    25° corner was built as a triangle of 23 % of its ground, and a wedge between two
    avenues was skipped whole ("nothing buildable is left once its sides too short for
    corners are absorbed"; 5 of the 8 blocks of a star junction). Only a sharp corner
    on an edge shorter than ``min_edge`` is a spike now; the others are kept, for the
    nose (:func:`without_tips`) to build."""
    import math

    from citysynth.skeletons.clean import absorb_short_edges
    t = math.radians(tip)
    quad = shapely.Polygon([(0, 0), (200, 0), (200, 40), (40 / math.tan(t), 40)])
    wedge = shapely.Polygon([(0, 0), (100, 0), (100, 100 * math.tan(t))])
    for poly in (quad, wedge):
        got = absorb_short_edges(poly, min_edge=4.0, min_stage=2.4, straight_tol=8.0,
                                 nose=2.0)
        assert got is not None and got.area == pytest.approx(poly.area, rel=1e-6), got
    noisy = shapely.Polygon([(0, 0), (60, 0), (60, 40), (30, 40), (29, 43.5), (28.3, 40),
                             (0, 40)])   # a 3.5 m jag of 11°, on 1 m edges: noise
    got = absorb_short_edges(noisy, min_edge=4.0, min_stage=2.4, straight_tol=8.0, nose=2.0)
    assert got is not None and got.area == pytest.approx(60 * 40, abs=1.0), got.wkt
