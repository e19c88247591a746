"""The command line starts without the libraries its commands run on.

``citysynth --help``, ``--version``, a command's ``--help`` and a mistyped option answer
without loading numba, trimesh, shapely, pyproj, USD or pyvista (about 1.5 s): each
command imports what it runs when it runs, and the packages re-export their entry
points lazily (:mod:`citysynth.solver.exports`)."""

from __future__ import annotations

import ast
import importlib
import inspect
import json
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

HEAVY = ("numba", "numpy", "trimesh", "shapely", "pyproj", "pxr", "pyvista", "scipy",
         "pyogrio", "pyarrow", "PIL", "networkx", "distributed")
LAZY_PACKAGES = ("citysynth.solver", "citysynth.solver.structures", "citysynth.parts_db",
                 "citysynth.skeletons")


def loaded_after(argv: list[str]) -> tuple[int, list[str]]:
    """The exit code of ``citysynth ARGV`` in a fresh interpreter, and which of the
    heavy libraries it imported."""
    code = ("import json, sys\nfrom citysynth.pipeline.cli import main\n"
            f"code = main({argv!r})\n"
            f"print('\\n' + json.dumps([code, sorted(m for m in {HEAVY!r} "
            "if m in sys.modules)]))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    exit_code, heavy = json.loads(p.stdout.strip().splitlines()[-1])
    return exit_code, heavy


@pytest.mark.parametrize("argv, exit_code", [
    (["--version"], 0), (["--help"], 0), (["city", "--help"], 0), (["solve", "--help"], 0),
    (["building", "--help"], 0), (["gallery", "--help"], 0),
    (["solve", "--k", "three", "problem.json"], 2),   # a usage mistake
    (["tower", "--height", "60"], 2),                  # a required option missing
    (["city", "--workers", "0.5"], 2),                 # not a whole number
])
def test_the_command_line_answers_without_the_heavy_libraries(argv, exit_code):
    code, heavy = loaded_after(argv)
    assert code == exit_code
    assert heavy == [], f"citysynth {' '.join(argv)} imported {heavy}"


def test_a_command_that_runs_still_loads_what_it_runs(tmp_path):
    """The other side: a command does import its machinery when it runs (the check
    above is not passing because nothing is ever imported)."""
    problem = tmp_path / "p.json"
    problem.write_text(json.dumps({
        "resources": ["length"], "elements": [{"id": "A", "resources": {"length": 4.0}}],
        "transitions": [["A", "A", 1.0]], "constraints": {"length": [8.0, 8.0]}}))
    code, heavy = loaded_after(["solve", str(problem)])
    assert code == 0 and "numba" in heavy and "trimesh" not in heavy


def _type_checked_names(package: str) -> set[str]:
    """The names a lazy package's ``if TYPE_CHECKING:`` block imports."""
    module = importlib.import_module(package)
    tree = ast.parse(Path(module.__file__ or "").read_text(encoding="utf-8"))
    block = next(n for n in tree.body if isinstance(n, ast.If)
                 and isinstance(n.test, ast.Name) and n.test.id == "TYPE_CHECKING")
    return {a.asname or a.name for n in block.body if isinstance(n, ast.ImportFrom)
            for a in n.names}


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_lazy_packages_export_what_type_checkers_read(package):
    module = importlib.import_module(package)
    typed = _type_checked_names(package)
    eager = {n for n in module.__all__ if n in vars(module)
             and n not in typed}            # imported eagerly (the error classes)
    assert set(module.__all__) == typed | eager
    submodules = {m.name for m in pkgutil.iter_modules(module.__path__)}
    # a name that is also a module's would be replaced by that module once it loads
    assert not typed & submodules, typed & submodules
    for name in sorted(typed):
        assert not inspect.ismodule(getattr(module, name)), name
    assert typed <= set(dir(module))
    with pytest.raises(AttributeError, match="has no attribute"):
        _ = module.no_such_name


def test_the_solver_entry_point_stays_a_function_after_its_module_loads():
    """``citysynth.solver.solve`` is the function, however the modules were loaded."""
    code = ("import citysynth.solver.entry, citysynth.solver.structures.solve\n"
            "from citysynth.solver import solve\nimport inspect\n"
            "print(inspect.isfunction(solve))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120)
    assert p.stdout.strip() == "True", p.stderr
