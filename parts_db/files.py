"""Atomic file writing, shared by every stage that writes output.

A file appears complete or not at all: it is written to a temporary file in the same
folder (same suffix, so format-sniffing writers like usd-core and trimesh still work)
and renamed over the target. A run killed at any moment leaves no partial file, only
at worst a hidden ``.name.tmp-*`` temporary, which :func:`sweep_temporaries` removes.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path

_UMASK = os.umask(0)
os.umask(_UMASK)
TMP_MARK = ".tmp-"     # in every temporary's name, so a later run can sweep leftovers


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path to write; on success it is renamed to ``path``."""
    path = Path(path)
    block = _BLOCK.get()
    if block is not None:
        block.folders.extend(_missing_folders(path.parent))
        new = not os.path.lexists(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}{TMP_MARK}",
                                   suffix=path.suffix)
    except OSError as exc:   # a read-only folder: said of the file asked for, not the
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None  # temp
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_UMASK)   # mkstemp makes 0600; outputs are shared files
        _keep_for_undo(path)
        os.replace(tmp, path)
        if block is not None and new:
            block.files.append(path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        if exc.filename in (None, tmp):   # a full disk met on flush names no file
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
        raise
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes(path: str | Path, data: bytes) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text(path: str | Path, text: str) -> Path:
    return write_bytes(path, text.encode("utf-8"))


def sweep_temporaries(folder: str | Path) -> int:
    """Remove the temporaries a killed run left in ``folder``; how many there were."""
    n = 0
    for p in Path(folder).glob(f".*{TMP_MARK}*"):
        if p.is_file():
            p.unlink(missing_ok=True)
            n += 1
    return n


@dataclass
class _Block:
    """What an :func:`all_or_nothing` block wrote: the files it replaced, each with a
    hard link to its old content, and the files and folders it made."""

    undo: list[tuple[Path, Path]] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    folders: list[Path] = field(default_factory=list)


_BLOCK: ContextVar[_Block | None] = ContextVar("block", default=None)


def _missing_folders(folder: Path) -> list[Path]:
    """``folder`` and those of its parents that do not exist yet, deepest first."""
    out = []
    while not os.path.lexists(folder) and folder != folder.parent:
        out.append(folder)
        folder = folder.parent
    return out


def _keep_for_undo(path: Path) -> None:
    """Within :func:`all_or_nothing`, a file about to be replaced keeps its old content
    under a hidden link (a temporary's name: a killed run's is swept), to be put back
    if the block fails. Best effort: a file system without hard links keeps none."""
    block = _BLOCK.get()
    if block is None or not path.is_file() or any(p == path for p, _b in block.undo):
        return
    keep = path.parent / f".{path.stem}{TMP_MARK}undo-{os.getpid()}{path.suffix}"
    try:
        os.link(path, keep)
    except OSError:
        return
    block.undo.append((path, keep))


@contextlib.contextmanager
def all_or_nothing(folder: str | Path) -> Iterator[None]:
    """Files and folders made in ``folder`` by the block go again if it fails, and the
    files it replaced get their old content back: a command that writes several files
    (a layout's JSON, its USD, the part files it references) and meets an error after
    the first (a disk that filled, a part's mesh damaged since ingest, a name the file
    system refuses) leaves the folder as it found it, not half a result (a street run
    again into its folder left the new JSON and USD beside the old GLB). Only what the
    block itself wrote goes: another run writing into the same folder meanwhile keeps
    its files (everything new in the folder went, so one run's Ctrl-C deleted the
    other's finished buildings), and the folders made for ``folder`` go too if they
    are left empty (``-o a/b/c`` on a full disk left ``a/b``)."""
    root = Path(folder)
    block = _Block(folders=_missing_folders(root))
    token = _BLOCK.set(block)
    try:
        yield
    except BaseException:
        _BLOCK.reset(token)
        for path, keep in reversed(block.undo):
            with contextlib.suppress(OSError):
                os.replace(keep, path)
        for path in block.files:
            with contextlib.suppress(OSError):
                path.unlink()
        for d in sorted(set(block.folders), key=lambda q: len(q.parts), reverse=True):
            with contextlib.suppress(OSError):   # not empty: another run's, or the user's
                d.rmdir()
        raise
    _BLOCK.reset(token)
    for _path, keep in block.undo:
        keep.unlink(missing_ok=True)


def no_such_folder(path: Path) -> str:
    """Why ``path`` is no folder, as a message starts it: "no such folder", or, for a
    symbolic link, where it leads (a loop of links read as "no such folder", sending
    the user to look for a folder that is there)."""
    if not os.path.islink(path):
        return "no such folder"
    try:
        path.resolve(strict=True)
    except RuntimeError:   # Python 3.11 says a loop so
        return "a symbolic link that leads back to itself (a loop of links)"
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "a symbolic link that leads back to itself (a loop of links)"
    return f"a symbolic link to {os.readlink(path)}, which does not exist"

