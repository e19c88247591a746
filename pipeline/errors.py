"""The errors a user can cause, in one list, so a bug is never mistaken for one.

Each stage raises its own class (a malformed problem, a bad library, bad GeoJSON, a
layout that fails its checks, a wrong option or run setting), always with one message
that says what is wrong, where, and how to fix it. :data:`USER_ERRORS` lists them all.
The command line prints those as one line and exits 2; a city worker records them as
the block's reason. Anything else (a ``KeyError``, an ``IndexError``, a ``ValueError``
from numpy) is a bug in citysynth: it keeps its traceback and is reported as one.
"""

from __future__ import annotations

import errno
import functools
from collections.abc import Callable
from typing import Any

from citysynth.export.errors import ExportError
from citysynth.parts_db.errors import LibraryError
from citysynth.skeletons.errors import FarFromFrame, SkeletonError
from citysynth.solver.errors import ProblemError, TooLargeError
from citysynth.solver.safe_read import shown  # the one way messages quote a file's value

EXIT_OK = 0
EXIT_INFEASIBLE = 1     # an answer: the problem has no solution, with its reason
EXIT_BAD_INPUT = 2      # a user error: one line on stderr, nothing written
EXIT_INTERNAL = 3       # a bug: its traceback on stderr (the city run: in report.json)


class UsageError(ValueError):
    """A command-line option or a run setting is wrong (``--k 0``, ``--workers 0``, a
    folder that is not a run); the message names the option and what it accepts."""


MAX_K = 100   # layouts a command writes: each is its own files (100 are ~50 MB a block)
MAX_STRETCH = 0.05   # stretch a city.toml or --stretch may ask: more shows in parts


def check_k(k: int, name: str = "--k", what: str = "layouts") -> None:
    """Refuse a k no run should write: under 1, or over :data:`MAX_K` (a billion
    asked for once filled the machine's memory naming the files before any estimate)."""
    if isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= MAX_K:
        got = f"{k:,}" if isinstance(k, int) and not isinstance(k, bool) else shown(k)
        raise UsageError(f"{name} must be an integer from 1 to {MAX_K} (each of the k "
                         f"{what} is written as its own files), got {got}")


class ConfigError(UsageError):
    """A bad ``city.toml`` (the message names the key), or a city run asked for what it
    cannot do (no inputs, no library, an unreachable Dask scheduler)."""


def names_its_file(attr: str, *kinds: type[Exception]
                   ) -> Callable[[Callable[[Any], int]], Callable[[Any], int]]:
    """A command's ``run(args)`` whose errors of ``kinds`` (default: skeleton errors)
    all name its input file (``args.<attr>``): a feature's or a line's own checks name
    the feature ("feature 0 (h): edge constraint on 'unicorns' ...") but not the file it
    is in. The error keeps its class and attributes (a TooLargeError its figures); only
    its message gains the file."""
    caught = kinds or (SkeletonError,)

    def wrap(run: Callable[[Any], int]) -> Callable[[Any], int]:
        @functools.wraps(run)
        def named(args: Any) -> int:
            try:
                return run(args)
            except caught as exc:
                path = str(getattr(args, attr))
                if path not in str(exc):
                    exc.args = (f"{path}: {exc}", *exc.args[1:])
                raise
        return named
    return wrap


USER_ERRORS: tuple[type[Exception], ...] = (
    ProblemError, TooLargeError, LibraryError, SkeletonError, FarFromFrame, ExportError,
    UsageError, ConfigError,
)
"""Every error class a user can cause; subclasses are listed too, so the list reads as
the complete catalogue. ``except USER_ERRORS`` catches exactly the user's mistakes."""

__all__ = ["EXIT_BAD_INPUT", "EXIT_INFEASIBLE", "EXIT_INTERNAL", "EXIT_OK", "USER_ERRORS",
           "ConfigError", "ExportError", "LibraryError", "ProblemError", "SkeletonError",
           "TooLargeError", "UsageError"]


_FIXES = {errno.ENOSPC: "free space", errno.EDQUOT: "free space",
          errno.EACCES: "fix the permissions", errno.EPERM: "fix the permissions",
          errno.EROFS: "write to a writable folder",
          errno.ENAMETOOLONG: "choose a shorter output folder or name",
          # a file where a folder should be (mkdir of it, or a path through it)
          errno.EEXIST: "move that file out of the way or choose another path",
          errno.ENOTDIR: "a file stands where a folder should be: move it or choose "
                         "another path",
          errno.EISDIR: "a folder stands where a file should be: choose another name"}


def environment_message(exc: OSError) -> str:
    """One line for a failure of the machine (disk full, no permission, a path too
    long): what, where, the fix for that failure, and that running again once it is
    fixed is safe (a city run folder resumes; other commands write all or nothing)."""
    where = f"{exc.filename}: " if exc.filename else ""
    if exc.errno == errno.ENAMETOOLONG and exc.filename and len(str(exc.filename)) > 120:
        where = f"{str(exc.filename)[:60]}...{str(exc.filename)[-40:]}: "
    fix = _FIXES.get(exc.errno or 0, "free space or fix the permissions")
    return f"{where}{exc.strerror or exc}; {fix} and run again"
