"""An impossible tower is told from the range tables (the floor-area ratios towers of that
height have, and how tall the towers of the ratio asked are) without the search and the
solver's generic diagnosis, which grows the whole box of heights and floor areas (4 to
30 s for a skyscraper, of which 0.01 s was the search); the solver still runs when only
its diagnosis can tell. And the exact most of a resource when elements that consume
nothing of the given one consume some of it (a roof has a height but no floor area)."""

from __future__ import annotations

import importlib
import itertools

import pytest

from citysynth.examples import SAMPLE_LIBRARY
from citysynth.parts_db import load_library
from citysynth.pipeline import towers
from citysynth.pipeline.cli import main
from citysynth.pipeline.towers import Lot, solve_tower
from citysynth.solver import Problem
from citysynth.solver import diagnose as diagnosis
from citysynth.solver.compiled import compile_problem
from citysynth.solver.diagnose import reach_given

solve_module = importlib.import_module("citysynth.solver.entry")


@pytest.fixture(scope="module")
def db():
    return load_library(SAMPLE_LIBRARY)


@pytest.fixture
def diagnosed(monkeypatch) -> list[str]:
    """What of the solver ran: the tower's solve ("solve"), the generic diagnosis's entry
    point as solve calls it ("diagnose") and the graphs it grows ("grow"), whoever
    calls it."""
    runs: list[str] = []

    def spy(name, real):
        def run(*args, **kwargs):
            runs.append(name)
            return real(*args, **kwargs)
        return run

    monkeypatch.setattr(towers, "solve", spy("solve", towers.solve))
    monkeypatch.setattr(solve_module, "diagnose", spy("diagnose", solve_module.diagnose))
    monkeypatch.setattr(diagnosis, "_reachable_totals",
                        spy("grow", diagnosis._reachable_totals))
    return runs


FAR4 = (4 * 0.98, 4 * 1.02)   # --far 4, within 2 %


# height, lot: the ratios towers of that height have, and the nearest height at FAR 4
TOLD = [
    (150, 900, "between 4.357 and 16.2", "148.4 m"),
    (300, 900, "between 8.423 and 32.96", "148.4 m"),
    (500, 900, "between 13.85 and 55.37", "148.4 m"),
    (300, 400, "between 18.95 and 72.54", "63.2 m"),
    (35, 900, "between 1.239 and 3.348", "39.8 m"),        # too low: the nearest above
    # the diagnosis's graphs (heights up to 505 m) saw no tower of that ratio and said
    # nothing of heights; the range tables see all of them
    (500, 2500, "between 4.984 and 19.93", "418.4 m"),
    # the search, over floor-area levels (narrower than 1,000 m of heights), could not
    # bound the height a roof adds: it filled its 2 GB and refused in its own words
    (1000, 900, "between 27.4 and 111.2", "148.4 m"),
]


@pytest.mark.parametrize("height, lot, ratios, nearest", TOLD)
def test_impossible_towers_are_told_without_the_generic_diagnosis(db, diagnosed, height,
                                                                   lot, ratios, nearest):
    b = solve_tower("t", db, Lot.square(lot), height, FAR4)
    assert b.status == "infeasible"
    assert b.reason == (f"floor-area ratio 3.92-4.08 at {height} m on a {lot} m² lot: every "
                        f"stack of the tower parts of that height has a floor-area ratio "
                        f"{ratios}; with that floor-area ratio no stack of the tower parts "
                        f"has that height; the nearest are {nearest} tall")
    assert diagnosed == []


def test_the_command_says_the_same_without_the_diagnosis(tmp_path, capsys, diagnosed):
    assert main(["tower", "--height", "300", "--far", "4", "--lot-area", "900",
                 "--no-preview", "-o", str(tmp_path)]) == 1
    assert capsys.readouterr().err == (
        "citysynth tower: tower_300m_far4: infeasible: floor-area ratio 3.92-4.08 at 300 m "
        "on a 900 m² lot: every stack of the tower parts of that height has a floor-area "
        "ratio between 8.423 and 32.96; with that floor-area ratio no stack of the tower "
        "parts has that height; the nearest are 148.4 m tall\n")
    assert diagnosed == []
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("height, lot", [(300, 900), (35, 900), (500, 2500)])
def test_the_nearest_height_told_is_a_tower(db, height, lot):
    """The nearest height named is built at the ratio asked."""
    why = solve_tower("t", db, Lot.square(lot), height, FAR4).reason
    assert why is not None
    nearest = float(why.rsplit("the nearest are ", 1)[1].split(" m tall")[0])
    b = solve_tower("t", db, Lot.square(lot), nearest, FAR4)
    assert b.status == "ok"
    assert 3.92 <= b.layouts[0].structures[0]["resources"]["far"] <= 4.08


@pytest.mark.parametrize("height, lot, text", [
    (148.5, 900, "at 148.5 m on a 900 m² lot: no stack of the tower parts has that height; "
                 "the nearest are 148.4 m tall"),
    (7.1, 900, "at 7.1 m on a 900 m² lot: no stack of the tower parts has that height; the "
               "lowest is 7.4 m (a ground floor and a roof)"),
])
def test_a_height_no_tower_has_is_told_without_the_diagnosis(db, diagnosed, height, lot,
                                                             text):
    b = solve_tower("t", db, Lot.square(lot), height, FAR4)
    assert b.reason is not None and b.reason.endswith(text)
    assert diagnosed == []


def test_a_city_zones_interval_of_heights_is_told_without_the_diagnosis(db, diagnosed):
    b = solve_tower("lot_0", db, Lot.square(900), (300, 320), (3, 5))
    assert b.reason == ("floor-area ratio 3-5 at 300-320 m on a 900 m² lot: every stack of "
                        "the tower parts of that height has a floor-area ratio between 8.192 "
                        "and 35.22; with that floor-area ratio no stack of the tower parts "
                        "has that height; the nearest are 183.4 m tall")
    assert diagnosed == []


@pytest.mark.parametrize("height, lot, text", [
    # towers of 40 m fall just short of FAR 3.92, those of the ratio asked are 39.8 m to
    # 148.4 m tall: which of those is nearest only the grown graphs know
    (40, 900, "ratio between 1.374 and 3.916; with that floor-area ratio no stack of the "
              "tower parts has that height; the nearest are 39.8 m or 40.6 m tall"),
    # a height no stack has, between towers of the ratio asked
    (45.3, 900, "no stack of the tower parts has that height; the nearest are 45.2 m or "
                "45.4 m tall"),
])
def test_what_the_range_tables_cannot_tell_the_diagnosis_does(db, diagnosed, height, lot,
                                                              text):
    b = solve_tower("t", db, Lot.square(lot), height, FAR4)
    assert b.reason is not None and b.reason.endswith(text)
    assert diagnosed[:2] == ["solve", "diagnose"]


def test_a_feasible_tower_is_built_as_before(db, diagnosed):
    b = solve_tower("t", db, Lot.square(900), 300, (12 * 0.98, 12 * 1.02))
    assert b.status == "ok"
    met = b.layouts[0].structures[0]["resources"]
    assert met["height"] == pytest.approx(300, abs=1e-6)
    assert 11.76 <= met["far"] <= 12.24
    assert diagnosed == ["solve"]


# --- the most of a resource given another, with elements consuming none of the given --

ELEMENTS = {"ground": (5, 150), "floor": (3, 100), "tall": (4, 90), "roof": (4, 0),
            "crown": (6, 0)}


def _stack_problem(area: tuple[int, int], extra: dict | None = None) -> dict:
    floors = ["floor", "tall"]
    p = {"resources": ["height", "floor_area"],
         "quantum": {"height": 1, "floor_area": 1},
         "elements": [{"id": e, "resources": {"height": h, "floor_area": a}}
                      for e, (h, a) in ELEMENTS.items()],
         "transitions": ([["ground", f, 0] for f in floors]
                         + [[f, g, 0] for f in floors for g in floors]
                         + [[f, r, 0] for f in floors for r in ("roof", "crown")]),
         "front": ["ground"], "back": ["roof", "crown"],
         "constraints": {"height": [0, 200], "floor_area": list(area)}, "k": 1}
    if extra:
        p["elements"].append(extra["element"])
        p["transitions"] += extra["transitions"]
    return p


def _brute_heights(area: tuple[int, int]) -> tuple[int, int]:
    """Heights of every ground, 1-14 floors, roof stack with its floor area in ``area``."""
    heights = []
    for m in range(1, 15):
        for floors in itertools.product(("floor", "tall"), repeat=m):
            a = ELEMENTS["ground"][1] + sum(ELEMENTS[f][1] for f in floors)
            if area[0] <= a <= area[1]:
                h = ELEMENTS["ground"][0] + sum(ELEMENTS[f][0] for f in floors)
                heights += [h + ELEMENTS[r][0] for r in ("roof", "crown")]
    return min(heights), max(heights)


@pytest.mark.parametrize("area", [(1000, 1000), (1000, 1100), (700, 760), (240, 250)])
def test_the_most_height_of_stacks_of_a_floor_area_is_exact(area):
    """Roofs have a height but no floor area: the range tables leave the most height
    unbounded (inf); no roof follows another, so it is exact."""
    cp = compile_problem(Problem.from_dict(_stack_problem(area)))
    assert reach_given(cp, "floor_area", "height") == _brute_heights(area)


def test_the_most_stays_unbounded_when_such_elements_may_follow_one_another():
    """A zero-area spire may follow itself: a stack of some floor area can be as tall as
    you like."""
    spire = {"element": {"id": "spire", "resources": {"height": 2, "floor_area": 0}},
             "transitions": [["roof", "spire", 0], ["spire", "spire", 0],
                             ["spire", "crown", 0]]}
    cp = compile_problem(Problem.from_dict(_stack_problem((1000, 1100), spire)))
    least, most = reach_given(cp, "floor_area", "height")
    assert least == _brute_heights((1000, 1100))[0]
    assert most == float("inf")


def test_a_tower_too_large_to_search_is_told_in_towers(tmp_path, capsys, monkeypatch):
    """A search past the memory budget (a 1,000 m tower of FAR 20: 8 million labels at
    2 GB) was told in the solver's words (cost-bounded search, labels, graph states, a
    quantum and --max-memory, which tower has not): now in the tower's, with what to
    ask instead. Here under a 20 MB budget, so it is met in a second."""
    real = solve_module.solve
    monkeypatch.setattr(towers, "solve", lambda p, **kw: real(p, max_memory_mb=20, **kw))
    assert main(["tower", "--height", "1000", "--far", "20", "--lot-area", "2500",
                 "-o", str(tmp_path / "o"), "--no-preview"]) == 2
    err = capsys.readouterr().err
    assert "a tower of 1000 m with a floor-area ratio of 19.6-20.4 on a 2500 m² lot: its " \
           "floors stack in too many ways" in err and "lower height" in err, err
    assert not any(w in err for w in ("label", "quantum", "--max-memory", "graph")), err
    assert not (tmp_path / "o").exists()
