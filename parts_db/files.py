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
from pathlib import Path

_UMASK = os.umask(0)
os.umask(_UMASK)
TMP_MARK = ".tmp-"     # in every temporary's name, so a later run can sweep leftovers


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path to write; on success it is renamed to ``path``."""
    path = Path(path)
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


# the files an all_or_nothing block replaced, each with a hard link to its old content
_UNDO: ContextVar[list[tuple[Path, Path]] | None] = ContextVar("undo", default=None)


def _keep_for_undo(path: Path) -> None:
    """Within :func:`all_or_nothing`, a file about to be replaced keeps its old content
    under a hidden link (a temporary's name: a killed run's is swept), to be put back
    if the block fails. Best effort: a file system without hard links keeps none."""
    undo = _UNDO.get()
    if undo is None or not path.is_file() or any(p == path for p, _b in undo):
        return
    keep = path.parent / f".{path.stem}{TMP_MARK}undo-{os.getpid()}{path.suffix}"
    try:
        os.link(path, keep)
    except OSError:
        return
    undo.append((path, keep))


@contextlib.contextmanager
def all_or_nothing(folder: str | Path) -> Iterator[None]:
    """Files and folders made in ``folder`` by the block go again if it fails, and the
    files it replaced get their old content back: a command that writes several files
    (a layout's JSON, its USD, the part files it references) and meets an error after
    the first (a disk that filled, a part's mesh damaged since ingest, a name the file
    system refuses) leaves the folder as it found it, not half a result (a street run
    again into its folder left the new JSON and USD beside the old GLB)."""
    root = Path(folder)
    existed = root.exists()
    before = set(root.rglob("*")) if existed else set()
    undo: list[tuple[Path, Path]] = []
    token = _UNDO.set(undo)
    try:
        yield
    except BaseException:
        _UNDO.reset(token)
        for path, keep in reversed(undo):
            with contextlib.suppress(OSError):
                os.replace(keep, path)
        made = (set(root.rglob("*")) if root.exists() else set()) - before
        for p in sorted(made, key=lambda q: len(q.parts), reverse=True):   # deepest first
            with contextlib.suppress(OSError):
                p.rmdir() if p.is_dir() and not p.is_symlink() else p.unlink()
        if not existed:
            with contextlib.suppress(OSError):
                root.rmdir()
        raise
    _UNDO.reset(token)
    for _path, keep in undo:
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

