"""Zone kinds in a city run (city.toml ``kind``): rows of complete buildings along each
side of a block and towers on lots cut from it, beside perimeter blocks, on the demo
district's real blocks with the shipped config. Measured on the written files: the
rows' placed footprints (from the USD, composed by usd-core) do not overlap, each side
is filled to its length within the stretch tolerance; each tower stands inside its lot,
the lots inside the block, height and floor-area ratio inside the zone's intervals.
Reruns are byte-identical and cached, ``citysynth diff`` sees no change, and bad kind
settings are one message naming the zone and the key."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pytest
import shapely

from citysynth.export.audit import footprint, instance_triangles
from citysynth.export.usd import validate
from citysynth.pipeline.city.config import load_config, parse_config
from citysynth.pipeline.city.outputs import finish_city
from citysynth.pipeline.city.run import prepare, run_city
from citysynth.pipeline.cli import main
from citysynth.pipeline.towers import cut_lots

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
CITY = ROOT / "examples" / "city"
DISTRICT = CITY / "district_streets.geojson"
PERIMETER = (-285.57, -397.59)  # a point (local m) in one perimeter block, for company:
                                # by place, as its id moves with any change of its outline


def _inputs():
    """The demo district's jobs of the row and towers zones, and one perimeter block."""
    inputs = prepare(DISTRICT, None, load_config(CITY / "city.toml"), None)
    inputs.jobs = [j for j in inputs.jobs if j.zone_kind is not None or (
        j.kind == "block" and shapely.from_wkt(j.wkt).contains(shapely.Point(*PERIMETER)))]
    return inputs


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    out = tmp_path_factory.mktemp("kinds")
    inputs = _inputs()
    report = run_city(inputs, out, workers=2)
    finish_city(inputs, report, out)
    return out, inputs, report


def _layout(out: Path, bid: str) -> dict:
    return json.loads((out / "blocks" / f"{bid}.layout.json").read_text())


def _structure(prim: str) -> int:
    """The structure an instance prim belongs to (``/<block>/structure_03/...``: 3)."""
    return int(re.search(r"/structure_(\d+)/", prim).group(1))


def _by_kind(inputs, kind: str) -> list:
    return [j for j in inputs.jobs if j.zone_kind is not None and j.zone_kind.kind == kind]


def test_the_demo_district_has_every_kind(mixed):
    out, inputs, report = mixed
    assert report["kinds"] == {"perimeter": {"built": 1}, "row": {"built": 4},
                               "towers": {"built": 2}}
    assert report["counts"]["built"] == 7 and not report["failed"] and not report["errors"]
    blocks = json.loads((out / "blocks.geojson").read_text())["features"]
    kinds = [f["properties"]["zone_kind"] for f in blocks if f["properties"]["id"]]
    assert sorted(kinds) == ["perimeter"] + ["row"] * 4 + ["towers"] * 2
    assert validate(out / "city.usda") == []
    for bid in report["built"]:
        assert validate(out / "blocks" / f"{bid}.usda") == []
    png = (out / "city.png").read_bytes()
    assert png[:4] == b"\x89PNG"


def test_row_sides_fill_their_length_and_never_overlap(mixed):
    out, inputs, _ = mixed
    for job in _by_kind(inputs, "row"):
        lay = _layout(out, job.id)
        assert {i["class"] for i in lay["instances"]} == {"building"}
        assert len(lay["structures"]) >= 3
        for st in lay["structures"]:      # exact lengths, within the stretch tolerance
            stage = st["stages"][0]
            tol = max(0.1, job.slack, job.stretch * stage["length"])
            assert abs(st["resources"]["length"] - stage["length"]) <= tol + 1e-6
            assert 1 <= st["resources"]["doors"] <= 30     # the zone's per_side
        tris = instance_triangles(out / "blocks" / f"{job.id}.usda")
        assert len(tris) == len(lay["instances"])
        feet = {k: footprint(t) for k, t in tris.items()}
        keys = sorted(feet)
        area = sum(f.area for f in feet.values())
        shared = sum(feet[a].intersection(feet[b]).area
                     for n, a in enumerate(keys) for b in keys[n + 1:]
                     if feet[a].intersects(feet[b]))
        assert shared < 1e-3 * area, f"{job.id}: {shared:.2f} m² shared of {area:.0f}"
        block = shapely.from_wkt(job.wkt)
        assert shapely.union_all(list(feet.values())).difference(
            block.buffer(0.3, join_style="mitre")).area < 1.0


def test_towers_stand_on_their_lots_inside_the_zone_intervals(mixed):
    out, inputs, _ = mixed
    for job in _by_kind(inputs, "towers"):
        zk = job.zone_kind
        lay = _layout(out, job.id)
        ground = shapely.from_wkt(job.wkt).buffer(-zk.setback, join_style="mitre")
        lots = [shapely.Polygon(st["lot"]["polygon"]) for st in lay["structures"]]
        assert len(lots) >= 4
        assert all(ground.buffer(0.01).covers(lot) for lot in lots)
        assert sum(a.intersection(b).area for n, a in enumerate(lots)
                   for b in lots[n + 1:]) < 1e-3
        tris = instance_triangles(out / "blocks" / f"{job.id}.usda")
        heights = []
        for si, st in enumerate(lay["structures"]):
            met = st["resources"]
            assert zk.height[0] - 1e-6 <= met["height"] <= zk.height[1] + 1e-6
            assert zk.far[0] - 1e-6 <= met["far"] <= zk.far[1] + 1e-6
            heights.append(met["height"])
            top = max(float(t[:, :, 2].max()) for k, t in tris.items() if _structure(k) == si)
            assert abs(top - met["height"]) < 0.01, "the stack reaches its height"
        for k, t in tris.items():          # every floor inside its own lot
            assert footprint(t).difference(lots[_structure(k)].buffer(0.02)).area < 1e-3
        assert len(set(heights)) > 1, "a skyline, not one tower repeated"


def test_a_rerun_is_cached_and_byte_identical(mixed, tmp_path):
    out, _, report = mixed
    inputs = _inputs()
    again = run_city(inputs, tmp_path, workers=1)
    for bid in report["built"]:
        for suffix in (".layout.json", ".usda"):
            assert (tmp_path / "blocks" / f"{bid}{suffix}").read_bytes() == \
                (out / "blocks" / f"{bid}{suffix}").read_bytes()
    assert (tmp_path / "manifest.json").read_bytes() == (out / "manifest.json").read_bytes()
    assert again["kinds"] == report["kinds"]
    assert main(["diff", str(out), str(tmp_path)]) == 0
    cached = run_city(_inputs(), tmp_path, workers=1)
    assert cached["counts"]["cached"] == cached["counts"]["built"] == 7


def test_perimeter_is_the_default_kind_and_changes_no_hash():
    plain = prepare(DISTRICT, None, load_config(CITY / "city.toml"), None)
    text = (CITY / "city.toml").read_text().replace('style = "modern"',
                                                    'style = "modern"\nkind = "perimeter"')
    cfg = parse_config(tomllib.loads(text), CITY / "city.toml")
    explicit = prepare(DISTRICT, None, cfg, None)
    assert [j.input_hash for j in plain.jobs] == [j.input_hash for j in explicit.jobs]
    assert all(j.zone_kind is None for j in plain.jobs if j.zone == "main roads")


def test_lots_are_roughly_square_and_inside_the_ground():
    ground = shapely.Polygon([(0, 0), (130, 10), (120, 95), (-5, 80)])
    lots = cut_lots(ground, 36.0)
    assert 6 <= len(lots) <= 12
    for lot in lots:
        assert ground.buffer(0.01).covers(lot)
        rect = list(lot.minimum_rotated_rectangle.exterior.coords)
        sides = sorted(shapely.Point(a).distance(shapely.Point(b))
                       for a, b in zip(rect[:2], rect[1:3], strict=True))
        assert sides[1] <= 2.5 * sides[0] and lot.area >= 0.4 * 36 ** 2
    assert sum(a.intersection(b).area for n, a in enumerate(lots) for b in lots[n + 1:]) < 1e-6


@pytest.mark.parametrize("zone, fragment", [
    ('kind = "terraces"', "zone[0].kind: zone 'z': must be one of perimeter, row, towers"),
    ('kind = "towers"\nfar = [2, 6]', "zone[0].height: zone 'z': a towers zone needs height"),
    ('kind = "towers"\nheight = [40, 90]', "zone[0].far: zone 'z': a towers zone needs far"),
    ('kind = "towers"\nheight = [40, 90]\nfar = [6, 2]', "zone[0].far: zone 'z': must be"),
    ('kind = "row"\nheight = [40, 90]', "zone[0].height: zone 'z': only a zone of kind"),
    ('kind = "towers"\nheight = [40, 90]\nfar = [200, 300]', "zone 'z': far: [200, 300] "
                                                             "cannot be met"),
    # lots no ground floor fits: said as such (it was told as a ratio of 1557 to 1e5)
    ('kind = "towers"\nlot = 0.5\nheight = [40, 110]\nfar = [3, 8]',
     "zone 'z': lot: lots of about 0.5 m are too small for any tower: no ground floor"),
    # lots larger than a block: said of the lot (it was told as a ratio of 3.89e-16)
    ('kind = "towers"\nlot = 1e9\nheight = [40, 90]\nfar = [2, 6]',
     "zone[0].lot: must be at most 500, got 1e+09"),
    ('kind = "towers"\nstyle = "classic"\nheight = [40, 90]\nfar = [2, 6]',
     "zone 'z': style: the library 'citysynth sample' has no towers of style 'classic'"),
    ('kind = "row"\n[zone.per_block]\ndoors = [0, 9]', "zone 'z': per_block: a row is"),
])
def test_bad_kind_settings_name_the_zone_and_the_key(tmp_path, capsys, zone, fragment):
    cfg = tmp_path / "city.toml"
    cfg.write_text(f'[[zone]]\nname = "z"\nhighway = ["primary"]\n{zone}\n')
    assert main(["city", "--streets", str(DISTRICT), "--library", str(LIB), "--config",
                 str(cfg), "-o", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "run").exists()


def test_a_row_zone_refusal_says_once_what_to_loosen_in_city_toml():
    """A row zone's side that no row fills is told once, with the knob to turn named as
    city.toml names it (not the street command's flags), and the style's buildings."""
    from dataclasses import replace

    from citysynth.pipeline.city.jobs import solve_block, worker_library
    from citysynth.pipeline.streets import CITY_LOOSEN, Run, StreetAsk, _why

    job = _by_kind(_inputs(), "row")[0]
    db = worker_library(str(LIB))
    doors = replace(job, per_side=(("doors", 40.0, 50.0),))
    prep, built = solve_block(doors, db)
    assert built.status != "ok"
    reason = built.reason
    assert reason.count("no row") <= 1 and "--" not in reason, reason
    assert "per_side in city.toml" in reason and f"the {job.style} buildings" in reason, reason
    assert reason.count("widen") + reason.count("allow more") == 1, reason
    # where the block is, in the data's lon/lat (the run's local metres before)
    lon, lat = map(float, re.match(rf"block {job.id} at \((-?[\d.]+), (-?[\d.]+)\): ",
                                   reason).groups())
    assert 24.9 < lon < 25.0 and 60.1 < lat < 60.2, reason
    # a side no row measures: the length's knobs as city.toml names them
    ask = StreetAsk(("left",), style="classic", loosen=CITY_LOOSEN)
    side = Run("side", 1, shapely.LineString([(0, 0), (13.3, 0)]))
    why = _why(side, [{"constraint": "length", "asked": [13.2, 13.4],
                       "nearest_below": 12.6, "nearest_above": 14.0}], ask)
    assert why == ("side 2 (13.3 m): no row of the classic buildings fits its length (the "
                   "nearest rows measure 12.6 or 14 m); allow more stretch or slack in "
                   "city.toml"), why
