"""A side between two rigid key parts with no middle part: an H whose bar is spanned by
its two T parts' wings alone. The solver counts the wings on the quantum grid and
accepts the side within half a quantum, but nothing stretches between two rigid parts:
a 10.5 m bar between wings of 5.2 m each failed to place with an internal "stage 4:
parts do not meet at (0.00, 0.00), 100.0 mm apart (no middle part lies between its key
parts ...)". Such a side now must hold a middle part (pipeline/skeleton_to_structure.py,
``_rigid_gaps``): the bar is told in metres as any side no row fits, and a bar the wings
span exactly still builds with none."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from citysynth import examples
from citysynth.export.plan import FILLED
from citysynth.pipeline.cli import main
from citysynth.pipeline.skeleton_to_structure import skeleton_structure
from citysynth.skeletons import read_geojson, skeleton_from_lines

ORIGIN = (391000.0, 5820000.0)   # EPSG:25833 (UTM 33N), in Berlin


def _h_file(tmp_path: Path, bar: float) -> Path:
    """Two 60 m lines ``bar`` metres apart, joined at their middles by a bar."""
    lines = {"left": [(0, 0), (0, 60)], "right": [(bar, 60), (bar, 0)],
             "bar": [(0, 30), (bar, 30)]}
    src = tmp_path / f"h_{bar:g}.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": name}, "geometry": {
            "type": "LineString",
            "coordinates": [[ORIGIN[0] + x, ORIGIN[1] + y] for x, y in line]}}
        for name, line in lines.items()]}))
    return src


def _build(tmp_path: Path, src: Path) -> int:
    return main(["building", str(src), "--library", str(examples.SAMPLE_LIBRARY),
                 "--style", "classic", "--crs", "EPSG:25833", "-o",
                 str(tmp_path / src.stem), "--no-preview"])


def test_a_bar_the_wings_miss_by_a_tenth_is_told_in_metres(tmp_path, capsys):
    code = _build(tmp_path, _h_file(tmp_path, 10.5))
    err = capsys.readouterr().err
    assert code == 1, err
    assert "the 10.50 m side from (391000.00, 5820030.00) to (391010.50, 5820030.00)" in err
    assert "no row of the classic kit's parts fits it" in err
    # the lengths the T parts span alone are named: it said 14.00 m, the nearest with a
    # middle part, though 10.4 m builds
    assert "(the nearest they make there is 10.40 or 11.00 m)" in err
    for internal in ("stage", "mm apart", "key part", FILLED):
        assert internal not in err
    assert not (tmp_path / "h_10.5").exists()


def test_a_bar_the_wings_span_exactly_builds_with_no_middle_part(tmp_path):
    assert _build(tmp_path, _h_file(tmp_path, 10.4)) == 0
    lay = json.loads((tmp_path / "h_10.4" / "h_10.4.layout.json").read_text())
    (struct,) = lay["structures"]
    bar = next(s for s in struct["stages"] if abs(s["length"] - 10.4) < 1e-6)
    assert [struct["keys"][bar["from"]]["kind"], struct["keys"][bar["to"]]["kind"]] == \
        ["t_junction", "t_junction"]
    assert len(bar["parts"]) == 2                       # the two T parts alone
    text = json.dumps(lay)
    assert FILLED not in text                            # the pipeline's, never shown


@pytest.mark.parametrize("bar,asked", [(10.5, True), (10.4, False), (13.5, False)])
def test_only_a_side_rigid_parts_could_miss_asks_for_a_middle_part(tmp_path, sample_db, bar,
                                                                  asked):
    """The count is added where the key parts alone come within the side's interval on
    the grid but not as measured (10.5 m); a bar they span exactly (10.4 m) or cannot
    span alone (13.5 m) leaves the structure as it was, its resources the parts'."""
    feats, frame = read_geojson(_h_file(tmp_path, bar), crs="EPSG:25833")
    sk = skeleton_from_lines(feats, frame, name="h")
    st = skeleton_structure(sk, sample_db, "classic").structure
    with_count = [s for s, stage in enumerate(st.stages) if FILLED in stage.constraints]
    assert (FILLED in st.resources) == asked
    assert len(with_count) == (1 if asked else 0)
    if asked:
        (s,) = with_count
        lo, hi = st.stages[s].constraints["length"]
        assert lo <= 10.4 <= hi and st.stages[s].constraints[FILLED][0] == 1.0
