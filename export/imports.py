"""Importing libraries that break when Ctrl-C lands inside their import.

trimesh wraps its optional imports in ``except BaseException``, so a Ctrl-C during
``import trimesh`` was swallowed (``ingest`` ran on and wrote its database, exit 0) or
left a half-made module (a TypeError traceback later); VTK, under pyvista, crashed the
process (a segmentation fault, half a folder of outputs left, no message) when the
KeyboardInterrupt was raised inside its module initialisation. Such a library is
imported here with Ctrl-C noted rather than raised, and raised once the import ends,
where the command's own handling stops cleanly (exit 130, nothing half-written).
"""

from __future__ import annotations

import importlib
import signal
import sys
import threading
from types import ModuleType


def import_shielded(name: str) -> ModuleType:
    """Module ``name``, imported with Ctrl-C held until the import ends (then raised
    as KeyboardInterrupt); a plain import when already loaded or off the main thread
    (only the main thread may set a signal handler)."""
    loaded = sys.modules.get(name)
    if loaded is not None:
        return loaded
    if threading.current_thread() is not threading.main_thread():
        return importlib.import_module(name)
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: caught.append(signum))
    try:
        module = importlib.import_module(name)
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt
    return module
