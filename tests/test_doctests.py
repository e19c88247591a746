"""The examples in the docstrings run: every module of the installed ``citysynth``
package through ``doctest.testmod``, and the public entry points each have one.

The modules are found as an installed user would find them (``pkgutil`` over
``citysynth.__path__``), not as files of the repository. An editable install maps
the namespace root to a path hook that ``pkgutil`` cannot list; then the subpackages
are the ones pyproject.toml maps, each walked the same way.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import tomllib
from pathlib import Path

import pytest

import citysynth

ROOT = Path(__file__).resolve().parent.parent

# Not run: scripts that write files when run, and modules that need an optional extra.
SKIP = {
    "citysynth.examples.make_examples": "regenerates the shipped example files",
    "citysynth.examples.city.extract_osm": "needs pyrosm and geopandas, run once by hand",
}

# The public entry points: each has a runnable example in its own docstring.
ENTRY_POINTS = [
    "citysynth.solver.entry.solve",
    "citysynth.solver.problem.Problem.from_dict",
    "citysynth.solver.structures.solve.solve_structure",
    "citysynth.solver.structures.model.Structure.from_dict",
    "citysynth.parts_db.library.load_library",
    "citysynth.export.layout.Layout.from_dict",
]


def _subpackages() -> list[str]:
    found = [m.name for m in pkgutil.iter_modules(citysynth.__path__, "citysynth.")]
    if found:
        return found
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]
    return sorted(tool["setuptools"]["package-dir"])


def _modules() -> tuple[list[str], list[str]]:
    """Every module under citysynth, and the packages that failed to import while
    walking (pkgutil would otherwise pass over them in silence)."""
    names: list[str] = []
    broken: list[str] = []
    for name in _subpackages():
        names.append(name)
        try:
            pkg = importlib.import_module(name)
        except Exception:  # noqa: BLE001 - reported by the test below, not at collection
            broken.append(name)
            continue
        if hasattr(pkg, "__path__"):
            names += [m.name for m in pkgutil.walk_packages(pkg.__path__, name + ".",
                                                            onerror=broken.append)]
    return sorted(set(names)), broken


MODULES, BROKEN = _modules()


def test_every_package_imports_and_the_walk_finds_the_core():
    assert BROKEN == []
    for name in ("citysynth.solver", "citysynth.solver.structures", "citysynth.pipeline.cli",
                 "citysynth.parts_db", "citysynth.export", "citysynth.skeletons"):
        assert name in MODULES, name


@pytest.mark.parametrize("name", [m for m in MODULES if m not in SKIP])
def test_docstring_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS, report=True)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"


def _resolve(dotted: str):
    """The object a dotted name names, importing submodules on the way."""
    parts = dotted.split(".")
    obj = importlib.import_module(parts[0])
    for i, part in enumerate(parts[1:], start=2):
        if not hasattr(obj, part):
            importlib.import_module(".".join(parts[:i]))
        obj = getattr(obj, part)
    return obj


@pytest.mark.parametrize("dotted", ENTRY_POINTS)
def test_entry_point_has_a_runnable_example(dotted):
    obj = _resolve(dotted)
    examples = doctest.DocTestParser().get_examples(obj.__doc__ or "")
    assert examples, f"{dotted} has no example in its docstring"
    assert obj.__module__ in MODULES and obj.__module__ not in SKIP  # so it is run above
