"""``block`` with outlines that overlap settles them as ``city`` settles its footprints
(pipeline/city/overlaps.py): the larger is built whole, one lying half or more inside a
larger one is left out, one overlapping less is trimmed to the ground the larger leaves
(each piece built), and stderr says which and by how much. Both were built whole: 268 m²
of walls standing through walls. Features giving storeys or a height, which ``block``
does not build to, are told once."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import shapely

from citysynth.export.audit import footprint, instance_triangles
from citysynth.pipeline.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_audit import LIB  # noqa: E402

ORIGIN = (391000.0, 5820000.0)   # EPSG:25833 (UTM 33N), in Berlin


def _file(tmp_path: Path, blocks: dict[str, list[tuple[float, float]]],
          props: dict[str, dict] | None = None) -> Path:
    src = tmp_path / "blocks.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": name, **(props or {}).get(name, {})},
         "geometry": {"type": "Polygon", "coordinates": [
             [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in ring + ring[:1]]]}}
        for name, ring in blocks.items()]}))
    return src


def _run(tmp_path: Path, src: Path, capsys) -> tuple[int, str]:
    code = main(["block", str(src), "--library", str(LIB), "--style", "classic",
                 "--crs", "EPSG:25833", "-o", str(tmp_path / "out"), "--no-preview"])
    return code, capsys.readouterr().err


def _ground(tmp_path: Path, name: str) -> shapely.Geometry:
    tris = instance_triangles(tmp_path / "out" / f"{name}.usda")
    return shapely.union_all([footprint(t) for t in tris.values()])


def test_overlapping_blocks_are_trimmed_and_one_inside_is_left_out(tmp_path, capsys):
    src = _file(tmp_path, {
        "a": [(0, 0), (60, 0), (60, 40), (0, 40)],
        "b": [(45, 10), (100, 10), (100, 50), (45, 50)],   # 15 x 30 m under a
        "c": [(10, 10), (30, 10), (30, 30), (10, 30)]})    # wholly inside a
    code, err = _run(tmp_path, src, capsys)
    assert code == 0
    assert "feature 2 (c): all of it lies inside feature 0 (a)" in err and "left out" in err
    assert "feature 1 (b): trimmed by 450.00 m² where it overlapped feature 0 (a)" in err
    out = tmp_path / "out"
    assert sorted(p.name for p in out.glob("*.layout.json")) == ["a.layout.json",
                                                                 "b.layout.json"]
    shared = _ground(tmp_path, "a").intersection(_ground(tmp_path, "b")).area
    assert shared < 1.0, f"{shared:.1f} m² of a and b stand in the same ground"


def test_a_block_cut_in_two_builds_both_pieces(tmp_path, capsys):
    src = _file(tmp_path, {
        "long": [(0, 40), (200, 40), (200, 70), (0, 70)],     # 6,000 m²
        "cross": [(80, 0), (130, 0), (130, 110), (80, 110)]})  # 5,500 m², 1,500 under
    code, err = _run(tmp_path, src, capsys)
    assert code == 0, err
    assert "feature 1 (cross): trimmed by 1500.00 m²" in err
    assert sorted(p.name for p in (tmp_path / "out").glob("*.layout.json")) == [
        "cross-2.layout.json", "cross.layout.json", "long.layout.json"]


def test_storeys_that_block_does_not_build_to_are_told(tmp_path, capsys):
    src = _file(tmp_path, {"a": [(0, 0), (60, 0), (60, 40), (0, 40)],
                           "b": [(80, 0), (140, 0), (140, 40), (80, 40)]},
                {"b": {"building:levels": 5}})
    code, err = _run(tmp_path, src, capsys)
    assert code == 0
    assert "1 of 2 features give storeys or a height (feature 1 (b) first)" in err
    assert "citysynth city --footprints" in err


def test_a_sliver_of_an_outline_is_told(tmp_path, capsys):
    """A 200 x 3 m strip and a 0.5 m ring round a courtyard were built as walls that
    thin, windows on both faces, without a word; a city skips such slivers (min_width)."""
    src = tmp_path / "thin.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": name}, "geometry": {
            "type": "Polygon", "coordinates": [[[ORIGIN[0] + x, ORIGIN[1] + y]
                                                for x, y in ring + ring[:1]]
                                               for ring in rings]}}
        for name, rings in (
            ("strip", [[(0, 0), (200, 0), (200, 3), (0, 3)]]),
            ("ring", [[(0, 100), (60, 100), (60, 160), (0, 160)],
                      [(0.5, 100.5), (0.5, 159.5), (59.5, 159.5), (59.5, 100.5)]]),
            ("block", [[(100, 100), (160, 100), (160, 140), (100, 140)]]))]}))
    code, err = _run(tmp_path, src, capsys)
    assert code == 0
    assert "feature 0 (strip): 3.0 m wide on average, under the 8 m below which a city " \
        "leaves a block out" in err
    assert "feature 1 (ring): 0.5 m wide on average" in err
    assert "feature 2 (block)" not in err


def test_pieces_of_features_without_ids_or_with_clashing_ids_get_names_of_their_own(
        tmp_path, capsys):
    """A feature with no id cut in two named both pieces alike (``blocks_1``), and one
    whose piece name another feature already had clashed: the run failed "two blocks
    share a name"."""
    src = tmp_path / "blocks.geojson"
    rings = {"long": [(0, 40), (200, 40), (200, 70), (0, 70)],
             None: [(80, 0), (130, 0), (130, 110), (80, 110)],
             "cross": [(300, 0), (350, 0), (350, 110), (300, 110)],
             "cross-2": [(400, 0), (450, 0), (450, 40), (400, 40)],
             "bar": [(220, 40), (420, 40), (420, 70), (220, 70)]}
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {} if name is None else {"id": name},
         "geometry": {"type": "Polygon", "coordinates": [
             [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in ring + ring[:1]]]}}
        for name, ring in rings.items()]}))
    code, err = _run(tmp_path, src, capsys)
    assert code == 0, err
    names = sorted(p.name.removesuffix(".layout.json")
                   for p in (tmp_path / "out").glob("*.layout.json"))
    assert names == ["bar", "blocks_1", "blocks_1-2", "cross", "cross-2", "cross-2-2",
                     "long"], names


def test_a_multipolygon_beside_an_overlapping_polygon_is_settled(tmp_path, capsys):
    """A MultiPolygon's polygons are settled each against the others' (a helper's
    fuzzing: a MultiPolygon beside an overlapping polygon was built whole, 518-600 m²
    doubled, without a word); what is left of them stays one feature."""
    src = tmp_path / "blocks.geojson"
    parts = [[(0, 0), (40, 0), (40, 36), (0, 36)], [(60, 0), (100, 0), (100, 36), (60, 36)]]
    bar = [(20, 11), (80, 11), (80, 60), (20, 60)]
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "pair"}, "geometry": {
            "type": "MultiPolygon", "coordinates": [
                [[[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in r + r[:1]]] for r in parts]}},
        {"type": "Feature", "properties": {"id": "bar"}, "geometry": {
            "type": "Polygon", "coordinates": [
                [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in bar + bar[:1]]]}}]}))
    code, err = _run(tmp_path, src, capsys)
    assert code == 0, err
    # both its polygons lose 500 m² to the bar: one line says so
    assert err.count("feature 0 (pair): trimmed by 500.00 m² where it overlapped "
                     "feature 1 (bar)") == 1, err
    assert sorted(p.name for p in (tmp_path / "out").glob("*.layout.json")) == [
        "bar.layout.json", "pair.layout.json"]
    # where the trimmed polygons touch the bar, their modules meet at a party wall (two
    # touching rectangles share about 1 m² there, as before); it was 600 m²
    shared = _ground(tmp_path, "pair").intersection(_ground(tmp_path, "bar")).area
    assert shared < 3.0, f"{shared:.1f} m² of pair and bar stand in the same ground"


def test_two_overlapping_blocks_of_one_name_are_refused_before_any_note(tmp_path, capsys):
    """Two features of one id that overlap: the refusal ("two blocks share a name") came
    after a note that one was trimmed, telling of work the run then refused to do. The
    names are checked first; the refusal is the one line said."""
    src = tmp_path / "blocks.geojson"
    rings = [[(0, 0), (60, 0), (60, 40), (0, 40)], [(50, 0), (110, 0), (110, 40), (50, 40)]]
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "a", "storeys": 4},
         "geometry": {"type": "Polygon", "coordinates": [
             [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in ring + ring[:1]]]}}
        for ring in rings]}))
    code, err = _run(tmp_path, src, capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "two blocks share a name: 'a' and 'a'" in lines[0], err
    assert not (tmp_path / "out").exists()


def test_two_ids_that_make_one_file_name_are_told_so(tmp_path, capsys):
    """Ids "a" and "a_" make one file name ("a": a file name drops '_' at its ends):
    the refusal said they "share a name" and to give each feature a distinct id, which
    they had."""
    src = tmp_path / "blocks.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": name}, "geometry": {
            "type": "Polygon", "coordinates": [[[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in
                                                [(x0, 0), (x0 + 50, 0), (x0 + 50, 40),
                                                 (x0, 40), (x0, 0)]]]}}
        for name, x0 in (("a", 0), ("a_", 100))]}))
    code, err = _run(tmp_path, src, capsys)
    assert code == 2
    assert "two blocks make one file name ('a': a file name keeps" in err, err
    assert "'a' and 'a_'" in err and "give them ids that differ in those characters" in err
    assert "share a name" not in err and not (tmp_path / "out").exists()
