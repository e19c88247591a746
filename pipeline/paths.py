"""Checks on the command line's output folder, made before anything is read or written,
so a bad ``-o`` is one message (exit 2) and leaves nothing behind."""

from __future__ import annotations

import math
import os
import sys
import unicodedata
from argparse import Namespace
from collections.abc import Iterable, Sequence
from pathlib import Path

from citysynth.pipeline.errors import UsageError


def check_out_dir(out: str | Path, option: str = "-o") -> None:
    """``out`` is a folder that exists, or can be made, and may be written. An empty
    path (``-o ""``, an unset shell variable) is refused: as a path it is the current
    folder, where the outputs would land unasked."""
    check_not_empty(out, option)
    p = Path(out)
    bad = next((c for c in str(p.absolute()) if unicodedata.category(c) == "Cc"), None)
    if bad is not None:   # usd-core refuses such asset paths: "Invalid asset path string"
        raise UsageError(f"{str(p.absolute())!r}: the output folder's path holds a control "
                         f"character ({bad!r}), which USD cannot open files under; give "
                         f"another {option} folder")
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


def written_over(outputs: Iterable[Path], inputs: Sequence[Path]) -> tuple[Path, Path] | None:
    """The first (output, input) pair that is one file: a command about to write an
    output over the file it reads (by another name, a link, ``./x``) must refuse. Only
    files that exist are compared (``samefile`` needs both)."""
    given = [i for i in inputs if i.is_file()]
    for out in outputs:
        if out.is_file():
            hit = next((i for i in given if os.path.samefile(out, i)), None)
            if hit is not None:
                return out, hit
    return None


def same_input(a: str | Path, b: str | Path) -> bool:
    """Whether two inputs (``FILE`` or ``FILE::LAYER``) are one: the same file by any
    name, and the same layer (or none named)."""
    from citysynth.skeletons.gis_files import split_layer

    (fa, la), (fb, lb) = split_layer(str(a)), split_layer(str(b))
    return la == lb and written_over([Path(fa)], [Path(fb)]) is not None


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
            raise UsageError(f"{_option(name)}: {value} is not a finite number; "
                             "give a number")


def check_names_encodable(args: Namespace) -> None:
    """Every name given on the command line can be a file name usd-core writes: it
    names files in UTF-8 whatever the locale, so under a Latin-1 locale a folder
    ``out_ä`` got its USD files written beside it in ``out_Ã¤`` and empty ones in it
    (exit 0); and bytes that are no UTF-8 at all (a name from another system) ended in
    a traceback."""
    utf8 = sys.getfilesystemencoding().lower().replace("-", "") == "utf8"
    for name, value in sorted(vars(args).items()):
        if not isinstance(value, str) or value.isascii():
            continue
        option = _option(name)
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            raise UsageError(f"{option}: {value.encode('utf-8', 'surrogateescape')!r} is "
                             "not UTF-8 text; rename it, or give a name in plain ASCII"
                             ) from None
        if not utf8:
            raise UsageError(
                f"{option}: {value!a} holds letters outside ASCII, and this locale "
                f"encodes file names in {sys.getfilesystemencoding()}, not the UTF-8 "
                "usd-core writes them in; run in a UTF-8 locale (e.g. LC_ALL=C.UTF-8) "
                "or give a name in plain ASCII")


def _option(name: str) -> str:
    """The command-line option of an argparse destination, as the user typed it."""
    return "-o" if name == "out" else f"--{name.replace('_', '-')}"
