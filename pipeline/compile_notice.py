"""The first run after an install compiles the solver's numba kernels (about a minute
on a laptop core) and would sit silent meanwhile; this says so, once, beforehand.

Whether the kernels are compiled is read from numba's own on-disk cache: every
``cache=True`` kernel of :mod:`citysynth.solver` has an index file there, and a kernel
whose index is missing or stale (another source) will be compiled. Reading the indexes
costs about a millisecond. More than half of them cold means a fresh install (or a
cleared cache): a warm cache always has most of them, the few cold ones being kernels
of a method the user never ran.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
from typing import TextIO

COMPILE_SECONDS = 60      # CPU seconds to compile every kernel once (2-core dev machine)
COLD_SHARE = 0.5          # more than this share of kernels uncompiled: a cold cache
NOTICE = (f"citysynth: compiling the solver kernels once, about {COMPILE_SECONDS} s "
          "(later runs reuse them)")


def _dispatchers() -> list:
    """Every cached numba kernel of the solver package."""
    from numba.core.registry import CPUDispatcher

    import citysynth.solver as solver

    found = []
    for info in pkgutil.walk_packages(solver.__path__, "citysynth.solver."):
        mod = importlib.import_module(info.name)
        for obj in vars(mod).values():
            if isinstance(obj, CPUDispatcher) and obj.__module__ == mod.__name__ and \
                    type(getattr(obj, "_cache", None)).__name__ == "FunctionCache":
                found.append(obj)
    return found


def kernels_cold() -> bool:
    """True when most solver kernels have no usable compiled copy on disk."""
    try:
        kernels = _dispatchers()
        cold = sum(1 for k in kernels if not k._cache._cache_file._load_index())
    except Exception:      # numba's cache layout changed: say nothing rather than fail
        return False
    return bool(kernels) and cold > COLD_SHARE * len(kernels)


_SAID: list[bool] = []    # the notice printed in this process (``demo`` runs a city)


def announce_compile(stream: TextIO | None = None) -> bool:
    """Print :data:`NOTICE` (on stderr) when the kernels are about to be compiled, once
    in a process; whether it did."""
    if not _SAID and kernels_cold():
        print(NOTICE, file=stream or sys.stderr, flush=True)
        _SAID.append(True)
        return True
    return False
