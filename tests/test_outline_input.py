"""Outlines a user's file gets wrong, told once and first (a hostile-input sweep,
2026-12-01): ``block`` settled the overlaps of a self-crossing outline before checking
it (GEOS failed there: a traceback, exit 3) and said a Point or a bowtie was "0.0 m
wide" before the real error; a MultiPolygon's touching polygons were said to overlap;
a MultiLineString's two parts were "feature 0 (s) / feature 0 (s)"; a line break or a
terminal escape in a feature's id was printed raw."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from citysynth.pipeline.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_audit import LIB  # noqa: E402

ORIGIN = (391000.0, 5820000.0)   # EPSG:25833 (UTM 33N), in Berlin
SQUARE = [(0, 0), (40, 0), (40, 30), (0, 30), (0, 0)]
BOWTIE = [(5, 5), (35, 25), (35, 5), (5, 25), (5, 5)]     # crosses itself, over SQUARE


def _geo(kind: str, coords) -> dict:
    def at(ring):
        return [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in ring]
    if kind == "Polygon":
        return {"type": kind, "coordinates": [at(coords)]}
    if kind == "MultiPolygon":
        return {"type": kind, "coordinates": [[at(r)] for r in coords]}
    if kind == "MultiLineString":
        return {"type": kind, "coordinates": [at(r) for r in coords]}
    return {"type": kind, "coordinates": at([coords])[0]}      # a Point


def _write(tmp_path: Path, features: list[tuple[object, dict]]) -> Path:
    src = tmp_path / "in.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": fid} if fid is not None else {},
         "geometry": geo} for fid, geo in features]}))
    return src


def _run(command: str, src: Path, out: Path, capsys) -> tuple[int, list[str]]:
    code = main([command, str(src), "--library", str(LIB), "--crs", "EPSG:25833",
                 "-o", str(out), "--no-preview"])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.err.strip().splitlines()


def test_a_self_crossing_outline_over_another_is_refused_in_one_line(tmp_path, capsys):
    src = _write(tmp_path, [("good", _geo("Polygon", SQUARE)),
                            ("bad", _geo("Polygon", BOWTIE))])
    code, err = _run("block", src, tmp_path / "out", capsys)
    assert code == 2, err
    assert len(err) == 1 and "feature 1 (bad): invalid polygon (self-intersection at" \
        in err[0], err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.parametrize("geo", [_geo("Point", (3, 4)), _geo("Polygon", BOWTIE),
                                 _geo("Polygon", [(0, 0), (100, 0), (0, 3.5), (0, 0)])])
def test_an_outline_that_is_none_is_told_without_a_width_note(tmp_path, capsys, geo):
    code, err = _run("block", _write(tmp_path, [("b", geo)]), tmp_path / "out", capsys)
    assert code == 2, err
    assert len(err) == 1 and "wide on average" not in err[0], err


def test_a_thin_outline_is_laid_out_and_said_to_be_thin(tmp_path, capsys):
    strip = [(0, 0), (60, 0), (60, 6), (0, 6), (0, 0)]
    code, err = _run("block", _write(tmp_path, [("strip", _geo("Polygon", strip))]),
                     tmp_path / "out", capsys)
    assert code == 0, err
    (note,) = [line for line in err if "wide on average" in line]
    assert "must" not in note and "below which a city leaves a block out" in note


def test_touching_polygons_of_one_feature_are_said_to_touch(tmp_path, capsys):
    right = [(40, 0), (80, 0), (80, 30), (40, 30), (40, 0)]
    src = _write(tmp_path, [("m", _geo("MultiPolygon", [SQUARE, right]))])
    code, err = _run("block", src, tmp_path / "out", capsys)
    assert code == 2, err
    assert len(err) == 1 and "feature 0 (m): its polygons touch at" in err[0], err
    assert "overlap" not in err[0] and "party wall" in err[0]


def test_a_multilinestring_s_parts_are_named_as_parts(tmp_path, capsys):
    lines = [[(0, 0), (30, 0)], [(0, 50), (30, 50)]]
    src = _write(tmp_path, [("s", _geo("MultiLineString", lines))])
    code, err = _run("building", src, tmp_path / "out", capsys)
    assert code == 2, err
    assert "feature 0 (s) part 0 / feature 0 (s) part 1" in err[0], err


@pytest.mark.parametrize("fid, shown", [("a\nb", "a\\u000ab"),
                                        ("\u001b[31mRED", "\\u001b[31mRED")])
def test_an_id_that_prints_as_no_letter_is_escaped_in_messages(tmp_path, capsys, fid, shown):
    src = _write(tmp_path, [(fid, _geo("Polygon", BOWTIE))])
    code, err = _run("block", src, tmp_path / "out", capsys)
    assert code == 2, err
    assert len(err) == 1 and f"feature 0 ({shown}): invalid polygon" in err[0], err


def test_every_refused_outline_of_a_file_is_named(tmp_path, capsys):
    """A file with two bowties named the first only: fixed, the next run stopped at the
    second. The first refusal is said whole, the other refused outlines by name."""
    far = [(x + 100, y) for x, y in BOWTIE]
    src = _write(tmp_path, [("good", _geo("Polygon", SQUARE)),
                            ("bad", _geo("Polygon", BOWTIE)),
                            ("worse", _geo("Polygon", far))])
    code, err = _run("block", src, tmp_path / "out", capsys)
    assert code == 2, err
    assert len(err) == 1 and "feature 1 (bad): invalid polygon (self-intersection at" \
        in err[0], err
    assert err[0].endswith("(1 more of the file's outlines is refused too: "
                           "feature 2 (worse))"), err


def test_a_placemark_s_polygon_and_label_is_laid_out_as_its_polygon(tmp_path, capsys):
    """A Google Earth placemark is a collection of its label's Point and its Polygon:
    ``city --footprints`` built it and ``block`` refused it ("a GeometryCollection is
    no outline"). Both build it; a collection holding a line is still refused."""
    def collection(*members):
        return {"type": "GeometryCollection", "geometries": list(members)}
    placemark = collection(_geo("Point", (20, 15)), _geo("Polygon", SQUARE))
    code, err = _run("block", _write(tmp_path, [("p", placemark)]), tmp_path / "a", capsys)
    assert code == 0, err
    code, err = _run("block", _write(tmp_path, [("p", _geo("Polygon", SQUARE))]),
                     tmp_path / "b", capsys)
    assert code == 0, err
    assert (tmp_path / "a" / "p.layout.json").read_bytes() == \
        (tmp_path / "b" / "p.layout.json").read_bytes()
    mixed = collection(_geo("MultiLineString", [[(0, 0), (40, 0)]]), _geo("Polygon", SQUARE))
    code, err = _run("block", _write(tmp_path, [("m", mixed)]), tmp_path / "c", capsys)
    assert code == 2 and len(err) == 1 and "a GeometryCollection is no outline" in err[0], err
