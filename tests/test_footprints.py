"""Footprints re-skinned faithfully (issue 12): short sides fit, the cleaned outline stays
within 0.5 m of the input, storeys follow the data, and failures speak the user's
language. Two city runs are shared by the tests that measure them (module fixtures):
a generated residential district of 220 houses and the shipped Helsinki buildings."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon

from citysynth.examples.footprint_shapes import footprints
from citysynth.export.rings import building_ground
from citysynth.pipeline.city.config import load_config, parse_config
from citysynth.pipeline.city.footprints import part_families, party_lines
from citysynth.pipeline.city.party import party_walls
from citysynth.pipeline.city.run import prepare
from citysynth.pipeline.cli import main
from citysynth.skeletons.clean import TOLERANCE, clean_footprint, outline_distance
from citysynth.skeletons.geojson import lonlat_from_local

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
HELSINKI = ROOT / "examples" / "city" / "district_buildings.geojson"
SHORTEST_END = 5.2                  # the sample library's end parts (classic)
SOLVER_WORDS = ("front", "back list", "transition", "stage", "element", "key point",
                "sequence", "bounds")


def run_city(out: Path, fp: Path, config: str = "k = 1\npick = \"best\"\n",
             workers: int = 2) -> int:
    cfg = out.parent / f"{out.name}.toml"
    cfg.write_text(config)
    return main(["city", "--footprints", str(fp), "--library", str(LIB), "-o", str(out),
                 "--config", str(cfg), "--workers", str(workers), "--no-overview"])


def figures(out: Path, fp: Path) -> dict[str, dict]:
    """Per footprint job: its status, the input outline and (built) the distance from
    the facade line it stands on (every stage's polyline) to that outline."""
    inputs = prepare(None, fp, load_config(out.parent / f"{out.name}.toml"), LIB)
    manifest = json.loads((out / "manifest.json").read_text())["blocks"]
    rows = {}
    for job in inputs.jobs:
        rec = manifest[job.id]
        poly = shapely.from_wkt(job.wkt)
        row = {"status": rec["status"], "poly": poly, "rec": rec, "job": job}
        if rec["status"] == "built":
            lay = json.loads((out / "blocks" / f"{job.id}.layout.json").read_text())
            lines = shapely.union_all([LineString(s["polyline"]) for st in lay["structures"]
                                       for s in st["stages"]])
            row["distance"] = outline_distance(lines, poly)
            row["layout"] = lay
        rows[job.id] = row
    return rows


def sides_of(poly: Polygon) -> list[float]:
    return [float(np.hypot(*np.subtract(q, p))) for ring in [poly.exterior, *poly.interiors]
            for p, q in zip(ring.coords[:-1], ring.coords[1:], strict=True)]


def shares(rows: dict[str, dict], eligible) -> tuple[int, float, float]:
    picked = [r for r in rows.values() if eligible(r)]
    built = [r for r in picked if r["status"] == "built"]
    close = [r for r in built if r["distance"] <= TOLERANCE]
    return len(picked), len(built) / len(picked), len(close) / max(len(built), 1)


# --- the generated district ------------------------------------------------------------

@pytest.fixture(scope="module")
def district(tmp_path_factory):
    d = tmp_path_factory.mktemp("houses")
    fp = d / "houses.geojson"
    fp.write_text(json.dumps(footprints(220)))
    assert run_city(d / "run", fp) in (0, 1)
    by_id = {f["properties"]["id"]: f["properties"] for f in footprints(220)["features"]}
    rows = figures(d / "run", fp)
    for r in rows.values():
        r["props"] = by_id[r["job"].footprint.ref]
    return rows


def test_generated_houses_are_built_faithfully(district):
    n, built, close = shares(district, lambda r: r["poly"].area >= 50
                             and r["props"]["min_side"] >= 2 * SHORTEST_END)
    everyone = shares(district, lambda r: True)
    print(f"\ngenerated houses: {n} eligible, {100 * built:.1f} % built, "
          f"{100 * close:.1f} % within {TOLERANCE} m; all {everyone[0]}: "
          f"{100 * everyone[1]:.1f} % built, {100 * everyone[2]:.1f} % within")
    assert n >= 40            # 50 of the 220 have every wall 10.4 m or longer
    assert built >= 0.98
    assert close >= 0.95
    assert everyone[1] >= 0.98     # narrower wings and notches are built too


def test_every_generated_shape_keeps_its_wings(district):
    """An L keeps its six corners, a U its eight, a courtyard its hole: no wing is cut
    off to make a footprint easier."""
    for r in district.values():
        if r["status"] != "built":
            continue
        corners = sum(len([k for k in st["keys"]]) for st in r["layout"]["structures"])
        want = {"rectangle": 4, "L": 6, "U": 8, "courtyard": 8, "notched": 4}
        assert corners >= want[r["props"]["shape"]], r["props"]
        if r["props"]["shape"] == "courtyard":
            assert len(r["layout"]["structures"]) == 2


# --- Helsinki --------------------------------------------------------------------------

@pytest.fixture(scope="module")
def helsinki():
    """Every Helsinki footprint cleaned as its job cleans it (no solving: the shape the
    facades stand on is decided here; tests/test_city.py builds them): its distance to
    the input, or the message naming the side that stays too short."""
    from citysynth.pipeline.city.footprints import prepare as prepare_job
    from citysynth.pipeline.city.jobs import worker_library
    from citysynth.skeletons.errors import SkeletonError

    inputs = prepare(None, HELSINKI, load_config(None), LIB)
    db = worker_library(inputs.jobs[0].library)
    rows = []
    for job in inputs.jobs:
        poly = shapely.from_wkt(job.wkt)
        try:
            prep = prepare_job(job, db)
        except SkeletonError as exc:
            rows.append({"poly": poly, "reason": str(exc)})
            continue
        assert not isinstance(prep, str)
        lines = shapely.union_all([LineString([*(k.xy for k in sk.keypoints),
                                               sk.keypoints[0].xy]) for sk in prep.rings])
        rows.append({"poly": poly, "distance": outline_distance(lines, poly)})
    return rows


def test_helsinki_outlines_stay_close(helsinki):
    ok = [r for r in helsinki if "distance" in r]
    eligible = [r for r in helsinki if r["poly"].area >= 50
                and min(sides_of(r["poly"])) >= 2 * SHORTEST_END]
    close = sum(r["distance"] <= TOLERANCE for r in ok) / len(ok)
    print(f"\nHelsinki: {len(helsinki)} footprints, {len(ok)} buildable outlines, "
          f"{100 * close:.1f} % within {TOLERANCE} m, worst "
          f"{max(r['distance'] for r in ok):.1f} m; {len(eligible)} eligible")
    assert len(ok) / len(helsinki) >= 0.98
    assert close >= 0.55          # was 44 %: short sides the kit cannot make remain
    assert max(r["distance"] for r in ok) < 6.0     # was 21.4 m (a dropped wing)
    assert all(r["distance"] <= TOLERANCE for r in eligible if "distance" in r)


def test_helsinki_failures_speak_the_users_language(helsinki):
    for r in helsinki:
        if "reason" in r:
            reason = r["reason"]
            assert re.search(r"district_buildings\.geojson: feature \d+", reason), reason
            assert re.search(r"the \d+\.\d\d m side from \(", reason), reason
            assert not any(w in reason for w in SOLVER_WORDS), reason


# --- cleaning --------------------------------------------------------------------------

def noisy(pts, seed=0, jitter=0.08):
    r = np.random.default_rng(seed)
    return [(x + r.uniform(-jitter, jitter), y + r.uniform(-jitter, jitter)) for x, y in pts]


@pytest.mark.parametrize("shape", [
    [(0, 0), (20, 0), (20, 8), (8, 8), (8, 20), (0, 20)],                  # an L
    [(0, 0), (10, 0), (10, 3), (16, 3), (16, 0), (26, 0), (26, 12), (0, 12)],   # a notch
    [(0, 0), (28, 0), (28, 20), (20, 20), (20, 10), (8, 10), (8, 20), (0, 20)],  # a U
])
def test_cleaning_keeps_wings_and_notches(shape):
    poly = Polygon(noisy(shape))
    clean = clean_footprint(poly, min_side=2.5, straight_tol=15.0)
    assert clean is not None
    assert len(clean.exterior.coords) - 1 == len(shape)
    assert outline_distance(clean, poly) <= TOLERANCE


def test_cleaning_absorbs_a_small_jog_within_the_tolerance():
    # a 0.6 m step in a 30 m wall: two 0.6 m sides no kit makes
    shape = [(0, 0), (15, 0), (15, 0.6), (30, 0.6), (30, 12), (0, 12)]
    poly = Polygon(shape)
    clean = clean_footprint(poly, min_side=2.5, straight_tol=15.0)
    assert clean is not None and outline_distance(clean, poly) <= TOLERANCE
    turns = len(clean.exterior.coords) - 1
    assert turns <= 5      # the jog is gone (a bend at most)


def test_a_narrow_notch_becomes_a_flat_wall_but_a_wing_never_goes():
    notch = [(0, 0), (10, 0), (10, 2), (11.5, 2), (11.5, 0), (26, 0), (26, 12), (0, 12)]
    clean = clean_footprint(Polygon(notch), min_side=2.5, straight_tol=15.0)
    assert clean is not None and clean.area >= Polygon(notch).area
    wing = [(0, 0), (10, 0), (10, -10), (11.5, -10), (11.5, 0), (26, 0), (26, 12), (0, 12)]
    clean = clean_footprint(Polygon(wing), min_side=2.5, straight_tol=15.0)
    assert clean is not None and clean.covers(Polygon(wing).buffer(-0.01))


@pytest.mark.parametrize("width", [1.5, 4.0])
def test_a_bump_too_shallow_for_the_kit_goes_rather_than_leaning_the_facade_out(width):
    """A bump 2 m deep on a 26 m facade: its 2 m sides no kit makes. Filling the
    "notches" either side of it leaned the whole facade out to the bump's face, 2 m
    past the outline into the street (24.5 m² for a 1.5 m bump); now the bump goes
    (3 m²) and the facade stands on its line."""
    shape = Polygon([(0, 0), (10, 0), (10, -2), (10 + width, -2), (10 + width, 0), (26, 0),
                     (26, 12), (0, 12)])
    clean = clean_footprint(shape, min_side=2.5, straight_tol=15.0)
    assert clean is not None
    assert clean.difference(shape).area <= 0.01                 # nothing past the outline
    assert shape.difference(clean).area <= 2.0 * width + 0.01   # the bump, no more
    assert clean.symmetric_difference(Polygon([(0, 0), (26, 0), (26, 12), (0, 12)])).area < 0.01


def test_a_step_in_a_facade_cuts_the_short_side_not_the_long_one_into_the_street():
    """A 1.2 m step near the end of a 46 m facade (a demo district house stood 1.75 m
    into the street along 58 m of facade, 75 m², from one such step): of the two ways
    to absorb it, the short side's corner goes (3.6 m² off the house) rather than the
    long side leaning out to the step's far corner (24 m² of street built on)."""
    shape = Polygon([(0, 0), (12, 0), (12, 40), (13.2, 40), (13.2, 46), (0, 46)])
    clean = clean_footprint(shape, min_side=2.5, straight_tol=15.0)
    assert clean is not None
    assert clean.difference(shape).area <= 0.01
    assert shape.difference(clean).area == pytest.approx(1.2 * 6 / 2, abs=0.01)
    sides = np.hypot(*np.diff(np.asarray(clean.exterior.coords), axis=0).T)
    assert sides.min() >= 2.5


def _sides(poly: Polygon) -> np.ndarray:
    return np.hypot(*np.diff(np.asarray(poly.exterior.coords), axis=0).T)


def test_a_wing_a_little_narrower_than_the_kit_is_widened_within_the_tolerance():
    """A 2.05 m wing on a small house (Kotka's feature 2189): no way of absorbing its
    end stayed within the tolerance, and cutting the wing off is never done, so the
    house failed ("the 2.05 m side ... is shorter than the 2.5 m the classic kit
    needs"). One of the wing's sides now moves out 0.45 m: the wing is 2.5 m wide and
    every corner stays."""
    shape = Polygon([(0, 0), (12, 0), (12, 3), (16, 3), (16, 5.05), (12, 5.05), (12, 8),
                     (0, 8)])
    clean = clean_footprint(shape, min_side=2.5, straight_tol=15.0)
    assert clean is not None and len(clean.exterior.coords) == len(shape.exterior.coords)
    assert _sides(clean).min() >= 2.5
    assert outline_distance(clean, shape) <= TOLERANCE
    assert shape.difference(clean).area < 0.01                  # nothing of it is cut
    assert clean.difference(shape).area == pytest.approx(0.451 * 4, abs=0.02)


# Kotka's feature 214 (OSM way 424090458), a stepped terrace, in metres about its centroid
TERRACE = [(-17.64, 28.76), (-13.55, 33.24), (-10.86, 30.78), (-13.0, 28.44), (-6.8, 22.77),
           (-9.15, 20.18), (-2.88, 14.45), (-4.92, 12.23), (1.44, 6.42), (0.64, 5.48),
           (6.82, 0.53), (2.76, -4.53), (8.95, -9.51), (6.5, -12.57), (12.41, -18.07),
           (10.39, -19.95), (15.62, -24.89), (8.62, -28.1), (7.23, -25.17), (3.44, -26.94),
           (2.39, -24.72), (6.16, -22.91), (4.73, -19.91), (7.75, -17.0), (1.71, -11.48),
           (4.01, -8.97), (-2.34, -3.17), (0.34, -0.24), (-5.47, 5.06), (-3.4, 7.32),
           (-9.81, 13.18), (-7.69, 15.51), (-13.46, 20.78), (-11.39, 23.04)]


def test_a_terrace_step_nothing_absorbs_is_built_a_little_longer():
    """A real stepped terrace: once its other short steps are absorbed, one 2.45 m step
    is left that no way of absorbing takes (each cuts more of the narrow terrace than
    it grows), and the building failed ("the 2.45 m side ... is shorter than the
    2.5 m the classic kit needs"). The side beyond it now moves 5 cm."""
    poly = Polygon(TERRACE)
    clean = clean_footprint(poly, min_side=2.5, straight_tol=15.0)
    assert clean is not None and _sides(clean).min() >= 2.5
    assert clean.symmetric_difference(poly).area < 0.06 * poly.length


# a house whose wall on its neighbour has a 2 m step no kit makes (a 2 m side between
# corners), and the neighbour wrapping round the step
STEP = [(0, 0), (10, 0), (10, 2), (30, 2), (30, 14), (0, 14)]
NEXT_DOOR = [(-5, -12), (30, -12), (30, 2), (10, 2), (10, 0), (-5, 0)]


def test_a_step_in_a_shared_wall_is_not_absorbed_into_the_neighbour():
    """Beyond the tolerance, a short side was absorbed by filling a notch; on a shared
    wall that notch is the neighbour's ground, and the house stood 20 m² inside it
    (its walls through the neighbour's; 106 m² of such overlaps on the demo district,
    33.8 m² of it two houses of one wall). The cleaning takes the way that changes
    least ground: the step's corner off the house (10 m²), nothing inside the
    neighbour, told its party walls or not. Cleaned each on its own, the two still
    differ by a 3.3 m² sliver where the neighbour's step goes the other way."""
    step, neighbour = Polygon(STEP), Polygon(NEXT_DOOR)
    lines = [party_lines(w) for w in party_walls([step, neighbour])]
    blind = [clean_footprint(p, min_side=2.5, straight_tol=15.0) for p in (step, neighbour)]
    told = [clean_footprint(p, min_side=2.5, straight_tol=15.0, party=w)
            for p, w in zip((step, neighbour), lines, strict=True)]
    assert blind[0] is not None and blind[0].intersection(neighbour).area <= 0.01
    assert told[0] is not None and told[0].intersection(neighbour).area <= 0.01
    assert step.difference(told[0]).area <= 10.0 + 0.01
    sides = np.hypot(*np.diff(np.asarray(told[0].exterior.coords), axis=0).T)
    assert sides.min() >= 2.5                             # the 2 m side is gone
    assert blind[1] is not None and told[1] is not None
    assert blind[0].intersection(blind[1]).area <= 3.5
    assert told[0].intersection(told[1]).area <= 3.5
    assert step.union(neighbour).difference(told[0].union(told[1])).area <= 0.01


def test_a_wing_never_goes_beside_a_neighbour_either():
    """Knowing party walls lets a step's corner go instead of growing into the
    neighbour, never more: a 1.5 m wing on the street side of a house with a neighbour
    along its back stays whole (its 1.5 m end left for the caller to report; cutting
    it to a point took 7.5 m² off it)."""
    wing = Polygon([(0, 0), (10, 0), (10, -10), (11.5, -10), (11.5, 0), (26, 0), (26, 12),
                    (0, 12)])
    neighbour = Polygon([(0, 12), (26, 12), (26, 30), (0, 30)])
    walls = party_walls([wing, neighbour])[0]
    assert walls
    lines = party_lines(walls)
    clean = clean_footprint(wing, min_side=2.5, straight_tol=15.0, party=lines)
    assert clean is not None and clean.covers(wing.buffer(-0.01))


def test_neighbours_built_from_a_stepped_wall_overlap_less(tmp_path):
    """The same two houses as a city's footprints (the party walls found by the run):
    the outlines their layouts stand on share at most the 3.3 m² sliver, and leave
    none of the two footprints' ground unbuilt."""
    fp = tmp_path / "step.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": ref, "building:levels": "4"},
         "geometry": {"type": "Polygon",
                      "coordinates": [lonlat_from_local(r + r[:1], (24.94, 60.17))]}}
        for ref, r in (("step", STEP), ("next", NEXT_DOOR))]}))
    assert run_city(tmp_path / "run", fp, workers=1) == 0
    grounds = [building_ground(json.loads(f.read_text())["structures"])
               for f in sorted((tmp_path / "run" / "blocks").glob("*.layout.json"))]
    assert len(grounds) == 2
    assert grounds[0].intersection(grounds[1]).area <= 3.5
    both = grounds[0].union(grounds[1]).area
    assert both >= Polygon(STEP).area + Polygon(NEXT_DOOR).area - 0.5


# --- storeys, roofs, messages ----------------------------------------------------------

def houses(tmp_path: Path, props: list[dict], w: float = 20.0, h: float = 12.0) -> Path:
    feats = []
    for i, p in enumerate(props):
        x = 60.0 * i
        ring = lonlat_from_local([(x, 0), (x + w, 0), (x + w, h), (x, h), (x, 0)],
                                 (24.94, 60.17))
        feats.append({"type": "Feature", "properties": p,
                      "geometry": {"type": "Polygon", "coordinates": [ring]}})
    fp = tmp_path / "houses.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    return fp


def test_storeys_follow_the_data(tmp_path):
    fp = houses(tmp_path, [{"id": "three", "building:levels": "3"},
                           {"id": "five", "building:levels": 5},
                           {"id": "tall", "building:levels": "9"},
                           {"id": "by height", "height": "13.2 m"},
                           {"id": "mansard", "roof:shape": "mansard"}])
    assert run_city(tmp_path / "run", fp, workers=1) == 0
    out = tmp_path / "run"
    manifest = json.loads((out / "manifest.json").read_text())["blocks"]
    by_ref = {r["feature"].split("(")[1].rstrip(")"): (bid, r) for bid, r in manifest.items()}
    fams = {"a": 4, "b": 5, "c": 3, "d": 6}
    for ref, storeys in (("three", 3), ("five", 5), ("tall", 6), ("by height", 4),
                         ("mansard", 5)):
        bid, rec = by_ref[ref]
        if ref != "mansard":
            assert rec["storeys"] == storeys, ref
        lay = json.loads((out / "blocks" / f"{bid}.layout.json").read_text())
        used = {i["part"] for i in lay["instances"]}
        families = set().union(*(part_families(p, fams) for p in used))
        assert {fams[f] for f in families} == {storeys}, (ref, used)
    report = json.loads((out / "report.json").read_text())
    notes = [n["note"] for n in report["storeys_not_matched"]]
    assert len(notes) == 1 and "feature 2 (tall)" in notes[0] and "9 storeys" in notes[0]


def test_failures_name_the_feature_and_side_without_solver_words(tmp_path):
    fp = houses(tmp_path, [{"osm_id": 4242}, {"id": "way/7"}], w=17.28, h=9.0)
    assert run_city(tmp_path / "run", fp, 'k = 1\n[per_side]\ndoors = [6, 9]\n',
                    workers=1) == 1
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    reasons = sorted(f["reason"] for f in report["failed"])
    assert len(reasons) == 2
    assert "feature 0 (4242)" in reasons[0] and "feature 1 (way/7)" in reasons[1]
    for reason in reasons:
        assert re.search(r"the \d+\.\d\d m side from \(24\.\d+, 60\.\d+\) to", reason)
        assert "doors = [6, 9]" in reason
        assert not any(w in reason for w in SOLVER_WORDS), reason


def test_a_side_the_kit_cannot_make_says_what_it_makes():
    from citysynth.examples import SAMPLE_LIBRARY
    from citysynth.parts_db import load_library
    from citysynth.pipeline.city.footprints import side_advice

    db = load_library(SAMPLE_LIBRARY)
    fillers = [p for p in db.select("middle", "classic")
               if part_families(p.id, "abcd") <= {"c"}]
    text = side_advice(1.9, 1.85, 1.95, fillers, db.quantum, "classic")
    assert text is not None and text.startswith("the classic kit makes ")
    # 2.8 m is 47 % away from 1.9 m: no stretch a city.toml or --stretch may ask (5 %)
    # makes it, and "allow 47.4 % stretch" was advice no one could follow
    assert re.search(r"makes 2\.8 m here, 47 % away, past the 5 % stretch allowed: the "
                     r"side's length in the data must change$", text), text
    # 0.1 m of 2.7 m is 3.704 %: "allow 3.7 %" fell short of it; rounded up, with the
    # slack that does the same
    near = side_advice(2.7, 2.69, 2.71, fillers, db.quantum, "classic")
    assert near is not None and re.search(
        r"makes 2\.8 m here; allow 3\.8 % stretch or 0\.1 m of slack$", near), near
    # a long side a few centimetres off was told "allow 0.0 % stretch"
    long = side_advice(120.03, 120.02, 120.04, fillers, db.quantum, "classic")
    assert long is not None and re.search(
        r"makes 120\.0 or 120\.2 m here; allow 0\.025 % stretch or 0\.03 m of slack", long), long


def test_footprint_config_is_validated(tmp_path):
    cfg = parse_config({"slack": 0.2, "footprints": {
        "stretch": 0.03, "storeys": {"classic": {"a": 4, "b": 5}},
        "roofs": {"classic": {"flat": "a"}}}})
    assert cfg.slack == 0.2 and cfg.footprints.stretch == 0.03
    assert ("classic", "b", 5) in cfg.footprints.storeys.families
    assert ("classic", "c", 3) not in cfg.footprints.storeys.families
    assert ("modern", "d", 8) in cfg.footprints.storeys.families
    for bad, key in (({"stretch": 0.2}, "footprints.stretch"),
                     ({"storeys": {"classic": {"a": 0}}}, "footprints.storeys.classic.a"),
                     ({"roofs": {"classic": {"flat": 3}}}, "footprints.roofs.classic.flat"),
                     ({"colour": 1}, "footprints.colour")):
        with pytest.raises(Exception, match=re.escape(key)):
            parse_config({"footprints": bad})


@pytest.mark.parametrize("table, says", [
    ({"storeys": {"classic": {"z": 4}}},
     "footprints.storeys.classic.z: no part of the classic style has family 'z'"),
    ({"roofs": {"classic": {"gabled": ["a", "q"]}}},
     "footprints.roofs.classic.gabled: no part of the classic style has family 'q'"),
    ({"storeys": {"gothic": {"a": 4}}},
     'footprints.storeys.gothic.a: the library has no style "gothic"'),
])
def test_footprint_families_are_checked_against_the_library(table, says):
    """A family or style city.toml names that the library lacks: one message, not a
    storey table silently missing the style's real families."""
    from citysynth.pipeline.errors import ConfigError
    with pytest.raises(ConfigError, match=re.escape(says)):
        prepare(None, HELSINKI, parse_config({"footprints": table}), LIB)
    ok = {"storeys": {"classic": {"a": 4, "b": 5}}, "roofs": {"classic": {"gabled": "a"}}}
    assert prepare(None, HELSINKI, parse_config({"footprints": ok}), LIB).jobs


# --- streets and footprints together ---------------------------------------------------

def test_street_blocks_cut_back_where_footprints_stand(tmp_path):
    """On the shipped district, streets and footprints together: no part instance of a
    street block covers any ground of a footprint building."""
    from dataclasses import replace

    from citysynth.export.audit import footprint, instance_triangles
    from citysynth.pipeline.city.run import run_city as run

    city = ROOT / "examples" / "city"
    cfg = parse_config({"k": 1, "pick": "best", "per_side": {"doors": [0, 6]}})
    inputs = prepare(city / "district_streets.geojson", HELSINKI, cfg, LIB)
    buildings = shapely.union_all([shapely.from_wkt(j.wkt) for j in inputs.jobs
                                   if j.kind == "footprint"])
    blocks = replace(inputs, jobs=[j for j in inputs.jobs if j.kind == "block"])
    assert len(blocks.jobs) >= 15        # (17 since three in courtyards and yards went)
    assert any("taken by footprint buildings" in s["reason"] for s in inputs.skipped)
    report = run(blocks, tmp_path / "run", workers=2)
    assert report["counts"]["built"] >= 12
    overlap = 0.0
    for bid in report["built"]:
        tris = instance_triangles(tmp_path / "run" / "blocks" / f"{bid}.usda")
        feet = [footprint(t) for t in tris.values()]
        overlap += sum(f.intersection(buildings).area for f in feet)
    print(f"\nstreet blocks over footprint buildings: {overlap:.4f} m²")
    assert overlap == pytest.approx(0.0, abs=1e-6)


def test_no_block_is_built_in_a_courtyard_or_an_enclosed_yard():
    """What footprints leave of a street block is built only where a street reaches it:
    a building's courtyard is its own ground (a perimeter block was built in the
    courtyard of one of the district's buildings), and a yard its neighbours close round
    has no street (two row houses stood in one)."""
    from shapely.geometry import box

    from citysynth.pipeline.city.footprints import cut_back

    block = box(0, 0, 200, 200)
    ring = box(20, 20, 180, 180).difference(box(40, 40, 160, 160))     # a 120 m courtyard
    pieces, why = cut_back([block], [ring], min_area=50, min_width=6)
    assert not any(p.intersects(box(50, 50, 150, 150)) for p in pieces)
    assert pieces and all(p.exterior.distance(block.exterior) < 0.01 for p in pieces)
    walls = [box(20, 20, 180, 40), box(20, 160, 180, 180), box(20, 40, 40, 160),
             box(160, 40, 180, 160)]                  # the same, as four buildings
    pieces, why = cut_back([block], walls, min_area=50, min_width=6)
    assert not any(p.intersects(box(50, 50, 150, 150)) for p in pieces)
    assert any("1 yard(s) the footprint buildings close round" in w for w in why)
    open_u = walls[:3]                                # one side open to the street
    pieces, _ = cut_back([block], open_u, min_area=50, min_width=6)
    assert any(p.contains(box(50, 50, 150, 150)) for p in pieces)


def test_a_light_well_too_small_for_the_kit_is_closed_with_a_note(tmp_path):
    """A 50 x 40 m building with a 2 x 2 m light well (its sides under the kit's 2.5 m)
    and a 20 x 12 m courtyard: the light well is closed under the roof, with a note
    naming it; the courtyard keeps its facades."""
    outer = [(0, 0), (50, 0), (50, 40), (0, 40), (0, 0)]
    well = [(6, 30), (6, 32), (8, 32), (8, 30), (6, 30)]
    court = [(15, 14), (15, 26), (35, 26), (35, 14), (15, 14)]
    rings = [lonlat_from_local(r, (24.94, 60.17)) for r in (outer, well, court)]
    fp = tmp_path / "wells.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "house"},
         "geometry": {"type": "Polygon", "coordinates": rings}}]}))
    assert run_city(tmp_path / "run", fp, workers=1) == 0
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())["blocks"]
    ((bid, rec),) = manifest.items()
    assert rec["status"] == "built"
    assert "4.0 m² courtyard closed under the roof" in rec["note"], rec
    lay = json.loads((tmp_path / "run" / "blocks" / f"{bid}.layout.json").read_text())
    assert len(lay["structures"]) == 2      # the outline and the courtyard, no light well
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert [n["note"] for n in report["notes"]] == [rec["note"]]
    assert report["storeys_not_matched"] == []


def test_a_courtyards_narrow_niche_is_filled_but_a_narrow_wing_stays(tmp_path):
    """A 40 x 30 m building round a 20 x 12 m courtyard with a 2 x 3 m niche (its 2 m
    side under the kit's 2.5 m between corners, too deep for cleaning to absorb) failed
    whole, as the shipped district's feature 7 did: the niche is now filled under the
    roof, with a note, and the courtyard keeps its facades. A 1.5 m wide wing of the
    outline still fails, naming its side: a wing is never cut off."""
    niche = [[(0, 0), (40, 0), (40, 30), (0, 30), (0, 0)],
             [(10, 9), (30, 9), (30, 21), (16, 21), (16, 24), (14, 24), (14, 21), (10, 21),
              (10, 9)]]
    wing = [[(80, 0), (100, 0), (100, 14), (91, 14), (91, 20), (89.5, 20), (89.5, 14),
             (80, 14), (80, 0)]]
    fp = tmp_path / "narrow.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": ref},
         "geometry": {"type": "Polygon",
                      "coordinates": [lonlat_from_local(r, (24.94, 60.17)) for r in rings]}}
        for ref, rings in (("niche", niche), ("wing", wing))]}))
    assert run_city(tmp_path / "run", fp, workers=1) == 1
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())["blocks"]
    by_ref = {r["feature"].split("(")[1].rstrip(")"): (bid, r) for bid, r in manifest.items()}
    bid, rec = by_ref["niche"]
    assert rec["status"] == "built", rec
    assert "1 niche of a courtyard filled under the roof (6.0 m²;" in rec["note"], rec
    lay = json.loads((tmp_path / "run" / "blocks" / f"{bid}.layout.json").read_text())
    assert len(lay["structures"]) == 2       # the outline and the courtyard
    (court,) = shapely.get_parts(shapely.polygonize(
        [LineString(s["polyline"]) for s in lay["structures"][1]["stages"]]))
    assert court.area == pytest.approx(240.0, abs=3.0)     # 20 x 12, the niche gone
    _bid, rec = by_ref["wing"]
    assert rec["status"] == "failed" and "the 1.50 m side from" in rec["reason"], rec


def test_niches_of_many_courtyards_fill_but_not_where_a_neighbour_stands(tmp_path):
    """Five courtyards each with a 2 x 3 m niche: all five filled, told once (a limit of
    four fillings a footprint failed the fifth, with advice to raise the tolerance). A
    niche with another building standing in it is not filled (the two would overlap):
    that footprint fails naming its side, as before."""
    def ring(x0: float, y0: float) -> list:
        return [(x0, y0), (x0 + 20, y0), (x0 + 20, y0 + 12), (x0 + 6, y0 + 12),
                (x0 + 6, y0 + 15), (x0 + 4, y0 + 15), (x0 + 4, y0 + 12), (x0, y0 + 12),
                (x0, y0)]
    five = [[(0, 0), (200, 0), (200, 30), (0, 30), (0, 0)],
            *[ring(10 + 40 * i, 9) for i in range(5)]]
    host = [[(300, 0), (340, 0), (340, 30), (300, 30), (300, 0)], ring(310, 9)]
    guest = [[(313, 11), (327, 11), (327, 21), (316, 21), (316, 24), (314, 24), (314, 21),
              (313, 21), (313, 11)]]          # in the courtyard, a wing in its niche
    fp = tmp_path / "courts.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": ref},
         "geometry": {"type": "Polygon",
                      "coordinates": [lonlat_from_local(r, (24.94, 60.17)) for r in rings]}}
        for ref, rings in (("five", five), ("host", host), ("guest", guest))]}))
    assert run_city(tmp_path / "run", fp, workers=1) == 1
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())["blocks"]
    by_ref = {r["feature"].split("(")[1].rstrip(")"): r for r in manifest.values()}
    assert by_ref["five"]["status"] == "built", by_ref["five"]
    assert "5 niches of 5 courtyards filled under the roof (30.0 m²;" in \
        by_ref["five"]["note"], by_ref["five"]
    assert by_ref["host"]["status"] == "failed" and "2.00 m side" in by_ref["host"]["reason"]


def test_a_footprint_drawn_twice_is_built_once_and_told(tmp_path):
    """The same outline twice is one block; the second drawing is among the skipped
    pieces with the feature it repeats (it appeared nowhere)."""
    fp = houses(tmp_path, [{"id": "a"}, {"id": "b"}])
    data = json.loads(fp.read_text())
    data["features"].append(json.loads(json.dumps(data["features"][0])))
    data["features"][-1]["properties"] = {"id": "again"}
    fp.write_text(json.dumps(data))
    assert run_city(tmp_path / "run", fp, workers=1) == 0
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["counts"]["built"] == 2
    assert [s["reason"] for s in report["skipped"]] == [
        f"{fp}: feature 2 (again): the same outline as feature 0 (a), built once"]
    # drawn twice with other storeys: the ones not used are told
    data["features"][-1]["properties"] = {"id": "again", "building:levels": 6}
    data["features"][0]["properties"]["building:levels"] = 3
    fp.write_text(json.dumps(data))
    assert run_city(tmp_path / "run2", fp, workers=1) == 0
    report = json.loads((tmp_path / "run2" / "report.json").read_text())
    assert [s["reason"] for s in report["skipped"]] == [
        f"{fp}: feature 2 (again): the same outline as feature 0 (a), built once (3 "
        "storeys asked there; its own 6 not used: delete one of the two)"]


def test_a_zero_width_spike_is_repaired_and_a_bowtie_named_where_it_crosses(tmp_path):
    """An outline drawn out and back along one line (invalid: it touches itself) is one
    building: made valid and built, the spike cleaned away. An outline crossing itself
    is left out, saying where, in the input's coordinates, and in which file."""
    spike = [(0, 0), (30, 0), (30, 20), (15, 20), (15, 40), (15, 20), (0, 20), (0, 0)]
    bowtie = [(60, 0), (90, 20), (90, 0), (60, 20), (60, 0)]
    feats = [{"type": "Feature", "properties": {"id": name},
              "geometry": {"type": "Polygon",
                           "coordinates": [lonlat_from_local(ring, (24.94, 60.17))]}}
             for name, ring in (("spike", spike), ("bowtie", bowtie))]
    fp = tmp_path / "odd.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    inputs = prepare(None, fp, parse_config({"k": 1}), LIB)
    (job,) = inputs.jobs
    outline = shapely.from_wkt(job.wkt)
    assert outline.is_valid and outline.area == pytest.approx(600, rel=0.01)
    (skip,) = [s["reason"] for s in inputs.skipped if s["kind"] == "footprint"]
    assert str(fp) in skip and "feature 1 (bowtie)" in skip, skip
    assert re.search(r"self-intersection at \(24\.94\d+, 60\.17\d+\)", skip), skip
    assert "left out (fix the outline so it does not cross itself in your GIS)" in skip, skip


def test_a_footprint_refused_at_a_corner_is_named_with_its_file(tmp_path):
    """A footprint whose 36.9° corner leaves no room for the nose before its 3 m side
    ends failed as "feature 180 (424090060): the convex corner ..." (Kotka), where
    every other footprint message names the file first."""
    import math

    a = math.radians(36.9)
    sharp = [(0, 0), (30, 0), (30, 12), (3 * math.cos(a), 3 * math.sin(a)), (0, 0)]
    fp = tmp_path / "sharp.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "sharp-1"}, "geometry": {
            "type": "Polygon", "coordinates": [lonlat_from_local(sharp, (24.94, 60.17))]}}]}))
    assert run_city(tmp_path / "run", fp, workers=1) == 1
    (failed,) = json.loads((tmp_path / "run" / "report.json").read_text())["failed"]
    assert failed["reason"].startswith(f"{fp}: feature 0 (sharp-1): the convex corner of "
                                       "36.9° at (24.940000, 60.170000) is too sharp"), failed


def test_a_footprint_of_two_distinct_corners_is_left_out_in_words(tmp_path):
    """GEOS's "Too few points in geometry component" reached the report as it was."""
    ring = [(0, 0), (30, 0), (0, 0), (0, 0)]
    fp = tmp_path / "flat.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {
            "type": "Polygon", "coordinates": [lonlat_from_local(ring, (24.94, 60.17))]}}]}))
    inputs = prepare(None, fp, parse_config({"k": 1}), LIB)
    (skip,) = [s["reason"] for s in inputs.skipped if s["kind"] == "footprint"]
    assert "too few points at (24.94" in skip and "at least 3 distinct corners" in skip
    assert "geometry component" not in skip, skip


def test_a_light_well_no_layout_lines_is_closed_and_the_building_built(tmp_path):
    """A 40 x 40 m building round a 4 x 4 m light well: its sides are longer than the
    kit's shortest (2.5 m), but no corners and modules of the kit line 4 m between two
    concave corners, and the whole building failed ("the classic kit makes 5.4 m here").
    A light well under 50 m² that blocks every layout is closed under the roof too."""
    outer = [(0, 0), (40, 0), (40, 40), (0, 40), (0, 0)]
    well = [(18, 18), (18, 22), (22, 22), (22, 18), (18, 18)]
    rings = [lonlat_from_local(r, (24.94, 60.17)) for r in (outer, well)]
    fp = tmp_path / "well.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "house", "building:levels": "4"},
         "geometry": {"type": "Polygon", "coordinates": rings}}]}))
    assert run_city(tmp_path / "run", fp, workers=1) == 0
    ((bid, rec),) = json.loads((tmp_path / "run" / "manifest.json").read_text())[
        "blocks"].items()
    assert rec["status"] == "built", rec
    assert ("16.0 m² courtyard closed under the roof (no layout of the classic kit lines "
            "it)") in rec["note"], rec
    lay = json.loads((tmp_path / "run" / "blocks" / f"{bid}.layout.json").read_text())
    assert len(lay["structures"]) == 1      # the outline only


def test_a_footprint_across_a_street_is_remarked_on(tmp_path):
    """A footprint a street's centre line runs through (a misdrawn building or street:
    an artist sees a house in the road) is built as given, with a remark naming the
    street and how much of it is inside; a building passage (tunnel=building_passage)
    is no such error, and the district's own 304 buildings cross none."""
    streets = json.loads((ROOT / "examples" / "city" / "district_streets.geojson").read_text())
    buildings = json.loads(HELSINKI.read_text())
    g = shapely.geometry.shape(buildings["features"][2]["geometry"])
    (x0, y0, x1, y1), c = g.bounds, g.centroid
    streets["features"] += [
        {"type": "Feature", "properties": {"highway": "service", "name": "Through"},
         "geometry": {"type": "LineString",
                      "coordinates": [[x0 - 3e-4, c.y], [x1 + 3e-4, c.y]]}},
        {"type": "Feature", "properties": {"highway": "service",
                                           "tunnel": "building_passage"},
         "geometry": {"type": "LineString",
                      "coordinates": [[c.x, y0 - 2e-4], [c.x, y1 + 2e-4]]}}]
    s = tmp_path / "streets.geojson"
    s.write_text(json.dumps(streets))
    cfg = parse_config({"k": 1})
    jobs = prepare(s, HELSINKI, cfg, LIB).jobs
    remarks = {j.footprint.feature: j.footprint.remarks for j in jobs if j.footprint}
    assert len(remarks) > 250
    assert [f for f, r in remarks.items() if r] == [2], remarks
    text = remarks[2]
    assert text.startswith(f"{HELSINKI}: feature 2") and len(text.splitlines()) == 1
    assert "stands across the centre line of street feature 489 (Through) of " in text
    inside = float(re.search(r"\((\d+\.\d) m of it inside", text).group(1))
    assert inside > 5   # metres in the local frame, not degrees


@pytest.mark.parametrize("value, metres", [
    ("40'", 12.192), ("40'6\"", 12.344), ("40 ft", 12.192), ("40 feet", 12.192),
    ("12 m", 12.0), ("12", 12.0), ("12,5", 12.5), ("3;4", 3.0)])
def test_osm_heights_in_feet_are_read_as_metres(value, metres):
    """OSM writes feet as 40' or 40'6\" (or 40 ft); they were read as 40 m, and a
    four-storey house was asked for 12 storeys."""
    from citysynth.skeletons.streets import osm_number
    assert osm_number(value) == pytest.approx(metres, abs=1e-3)


def test_many_light_wells_are_told_by_count_and_size(tmp_path):
    """A footprint of many light wells had a note naming each ("a 4.0 m² courtyard and
    a 4.0 m² courtyard and ...": 23,112 characters for 1,000); past three it says how
    many and how large."""
    from citysynth.pipeline.city.footprints import courtyards_said

    assert courtyards_said([4.0, 6.5]) == "a 4.0 m² courtyard and a 6.5 m² courtyard"
    assert courtyards_said([4.0] * 999 + [9.0]) == \
        "1,000 courtyards of 4.0 to 9.0 m² (4,005.0 m² in all)"
    outer = [(0, 0), (50, 0), (50, 40), (0, 40), (0, 0)]
    wells = [[(x, 30), (x, 32), (x + 2, 32), (x + 2, 30), (x, 30)] for x in (6, 16, 26, 36)]
    rings = [lonlat_from_local(r, (24.94, 60.17)) for r in (outer, *wells)]
    fp = tmp_path / "wells.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "house"},
         "geometry": {"type": "Polygon", "coordinates": rings}}]}))
    assert run_city(tmp_path / "run", fp, workers=1) == 0
    (rec,) = json.loads((tmp_path / "run" / "manifest.json").read_text())["blocks"].values()
    assert rec["status"] == "built"
    assert "4 courtyards of 4.0 m² each closed under the roof" in rec["note"], rec
