"""Shared test setup: hypothesis profiles, one part-database cache per session (never in
the source tree), the sample library ingested once, and the skips of the bounded
brute-force oracles in the terminal summary."""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import settings

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

# Part-database caches go to one folder per session, never into the source tree (one
# named by the caller's $CITYSYNTH_CACHE is used as it is, and kept).
SESSION_CACHE = None if "CITYSYNTH_CACHE" in os.environ else tempfile.mkdtemp(
    prefix="citysynth-cache-")
if SESSION_CACHE:
    os.environ["CITYSYNTH_CACHE"] = SESSION_CACHE


def pytest_unconfigure(config: pytest.Config) -> None:
    if SESSION_CACHE:
        shutil.rmtree(SESSION_CACHE, ignore_errors=True)

# Hypothesis profiles. "default" (also in CI): the example counts the tests declare,
# drawn from a seed fixed per test, so a run's time and verdict never hinge on a lucky
# draw, and no example database is written. "deep" (HYPOTHESIS_PROFILE=deep, `make
# test-deep`): DEEP_FACTOR times the declared counts, new draws every run, no deadline;
# the database under .hypothesis/ replays a failure it found.
DEEP_FACTOR = 8
BUILTIN = settings.get_profile("default")   # not "ci", which hypothesis loads when $CI
settings.register_profile("default", BUILTIN, derandomize=True, print_blob=True)
settings.register_profile("deep", BUILTIN, deadline=None, print_blob=True)
PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "default")
settings.load_profile(PROFILE)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Under the deep profile, multiply each property test's declared example count
    (a test's own ``@settings(max_examples=...)`` overrides any profile's)."""
    if PROFILE != "deep":
        return
    for item in items:
        test = getattr(item, "obj", None)
        if not getattr(test, "is_hypothesis_test", False):
            continue
        declared = getattr(test, "_hypothesis_internal_use_settings", None)
        if declared is None:  # hypothesis moved its settings: fail, never run shallow
            raise pytest.UsageError(f"{item.nodeid}: cannot find its hypothesis settings "
                                    "to deepen")
        test._hypothesis_internal_use_settings = settings(
            declared, max_examples=declared.max_examples * DEEP_FACTOR)


@pytest.fixture(scope="session")
def sample_db():
    """The sample part library's database, ingested once per session into the
    session's cache (later ``load_library`` calls on it, the CLI's included, read that
    cache). Shared: tests read it, never change it."""
    from citysynth.examples import SAMPLE_LIBRARY
    from citysynth.parts_db import load_library
    return load_library(SAMPLE_LIBRARY)


def pytest_terminal_summary(terminalreporter) -> None:
    """How many hypothesis draws the brute-force oracles skipped as too large to
    enumerate (hypothesis drew others in their place)."""
    oracle = sys.modules.get("tests.bruteforce")
    if oracle is None:
        return
    skipped = dict(sorted(oracle.SKIPPED.items()))
    counts = ", ".join(f"{n} by {name}" for name, n in skipped.items()) or "none"
    terminalreporter.write_line(f"brute-force oracles, draws skipped as over {oracle.LIMIT} "
                                f"sequences: {counts} (hypothesis profile {PROFILE})")


@pytest.fixture(scope="session")
def helsinki_run(tmp_path_factory):
    """A city run over the full Helsinki street extract (the sample library, default
    settings, 2 workers), shared by the city and audit tests. Exit 1 (some blocks
    failed) is part of a complete run; the tests read report.json for the counts."""
    from pathlib import Path

    from citysynth.pipeline.cli import main
    root = Path(__file__).resolve().parent.parent
    out = tmp_path_factory.mktemp("helsinki")
    assert main(["city", "--streets", str(root / "examples" / "city" / "helsinki_streets.geojson"),
                 "--library", str(root / "examples" / "library"), "-o", str(out),
                 "--workers", "2"]) in (0, 1)
    return out



@pytest.fixture(autouse=True)
def _no_compile_notice(monkeypatch):
    """In-process commands never print the one-time compile notice: whichever test
    first runs the solver on a fresh machine's cold numba cache would otherwise see it
    on stderr as a second line (the one-line error tests then depended on their order).
    The notice has its own test (tests/test_faults.py), which sets it back on."""
    from citysynth.pipeline import compile_notice

    monkeypatch.setattr(compile_notice, "kernels_cold", lambda: False)


@pytest.fixture(scope="session")
def sheared_layer(tmp_path_factory, sample_db):
    """A layer of the example block (parts placed whole and cut at its corners) with
    three in four instances sheared; the layer's path and its layout (for
    tests/test_usd_shear.py, and test_blender.py's import of it into Blender)."""
    import json

    from citysynth.export.layout import Layout
    from citysynth.export.shear import sheared
    from citysynth.export.usd import write_layout
    from citysynth.pipeline.cli import main
    from tests.test_usd_shear import BLOCK, LIB, sheared_layout
    out = tmp_path_factory.mktemp("shear")
    assert main(["block", str(BLOCK), "--library", str(LIB), "-o", str(out),
                 "--no-preview"]) == 0
    lay = sheared_layout(Layout.from_dict(json.loads((out / "block.layout.json")
                                                      .read_text())))
    assert sum(sheared(i) for i in lay.instances) >= 15
    assert any(i.cut is not None and sheared(i) for i in lay.instances)
    assert any(i.cut is None and sheared(i) for i in lay.instances)
    path = out / "sheared" / "block.usda"
    path.parent.mkdir()
    write_layout(lay, sample_db, path)
    return path, lay


@pytest.fixture(scope="session")
def k3_city(tmp_path_factory):
    """A k = 3 city of three blocks between generated streets, one of them picking rank
    2 (tests/test_city_variants.py, test_extents_hint.py): its streets, its config
    and its run folder. Shared: tests read it, never change it."""
    from tests.test_city_variants import K3, run_city
    from tests.test_faults import grid_streets
    base = tmp_path_factory.mktemp("city_variants")
    streets = grid_streets(base / "streets.geojson")
    cfg = base / "k3.toml"
    cfg.write_text(K3)
    run_city(streets, cfg, base / "run")
    return streets, cfg, base / "run"
