"""A package's re-exported names, imported when first used (PEP 562).

Why: a package's ``__init__`` that imports its entry points eagerly makes every import
of any of its modules pay for them: ``citysynth --version`` or ``citysynth diff``
loaded numba, trimesh, shapely and USD (about 1.5 s) because the command line imports
``citysynth.solver.errors`` or ``citysynth.parts_db.files``. A package lists what it
re-exports, by module, and gets a module ``__getattr__`` that imports that module the
first time a name is asked for and keeps the name; ``from citysynth.solver import
solve`` works as before. Type checkers read the same names from the package's
``if TYPE_CHECKING:`` imports.

A name must not be the name of one of the package's own modules: importing that
module would bind the module over the name (the import system sets the package's
attribute), so ``citysynth.solver.solve`` is the function and its module is
``citysynth.solver.entry``.

>>> from citysynth.solver import Problem
>>> Problem.__module__
'citysynth.solver.problem'
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, exports: Mapping[str, tuple[str, ...]]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """The ``__getattr__``, ``__dir__`` and ``__all__`` of ``package``, which re-exports
    ``exports``: {module name relative to the package: the names it exports}."""
    where = {name: f"{package}.{module}" for module, names in exports.items()
             for name in names}

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)   # asked once
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(where))

    return __getattr__, __dir__, sorted(where)
