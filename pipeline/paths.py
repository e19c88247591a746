"""Checks on the command line's output folder, made before anything is read or written,
so a bad ``-o`` is one message (exit 2) and leaves nothing behind."""

from __future__ import annotations

import math
import os
from argparse import Namespace
from pathlib import Path

from citysynth.pipeline.errors import UsageError


def check_out_dir(out: str | Path, option: str = "-o") -> None:
    """``out`` is a folder that exists, or can be made, and may be written. An empty
    path (``-o ""``, an unset shell variable) is refused: as a path it is the current
    folder, where the outputs would land unasked."""
    check_not_empty(out, option)
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise UsageError(f"{p}: a file, not a folder; {option} names the output folder "
                         "(give a folder path)")
    anc = p.absolute()
    while not anc.exists():
        anc = anc.parent
    if not anc.is_dir():
        raise UsageError(f"{anc}: a file, so {p} cannot be made under it; give another "
                         f"{option} folder")
    made = "" if anc == p.absolute() else f", so {p} cannot be made in it"
    if not os.access(anc, os.W_OK | os.X_OK) or not _can_make_in(anc):
        raise UsageError(f"{anc}: may not be written (read-only or no permission){made}; "
                         f"give another {option} folder")


def _can_make_in(folder: Path) -> bool:
    """A folder can be made in ``folder`` (and is taken away again): the permission
    bits say yes to root everywhere, also in /proc, /sys or a read-only mount, where
    the first file written would fail only after the whole solve."""
    probe = folder / f".citysynth-probe-{os.getpid()}"
    try:
        probe.mkdir()
    except FileExistsError:
        return True
    except OSError:
        return False
    probe.rmdir()
    return True


def check_not_empty(folder: str | Path, option: str) -> None:
    """A folder option given as ``""`` (or blanks) is a mistake, not "here"."""
    if not str(folder).strip():
        raise UsageError(f"{option}: the folder is empty ({str(folder)!r}); give a folder "
                         f"path, e.g. {option} out")


def check_numbers(args: Namespace) -> None:
    """Every number given on the command line is finite (``--setback nan`` is not)."""
    for name, value in sorted(vars(args).items()):
        if isinstance(value, float) and not math.isfinite(value):
            raise UsageError(f"--{name.replace('_', '-')}: {value} is not a finite number; "
                             "give a number")
