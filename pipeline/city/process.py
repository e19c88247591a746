"""Process hygiene of a city run: one run per folder, and no worker outlives its run.

- :func:`run_lock` takes an exclusive ``flock`` on ``<run>/.citysynth.lock`` (holding the
  owner's pid and start time). A second run on the folder is refused with a message
  naming that pid; a crashed run's lock is released by the kernel with its process, so
  a stale lock file never blocks a rerun.
- :func:`worker_init` runs in every pool worker: the kernel kills the worker when its
  parent dies (``PR_SET_PDEATHSIG``, Linux), even by SIGKILL; Ctrl-C in a terminal
  reaches the main process only through it (workers ignore SIGINT and are stopped by
  :func:`stop_pool`, so a queued block is never finished after the user asked to stop).
- :func:`terminate_as_interrupt` makes SIGTERM stop the run as SIGINT does (exit 143).
  (:class:`Terminated` is a ``KeyboardInterrupt``, so every clean-up on the way runs.)

A stopped run leaves complete blocks (each with its marker) and at worst hidden
temporaries that the next run sweeps: the folder is always resumable.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from citysynth.pipeline.errors import ConfigError

LOCK = ".citysynth.lock"
PR_SET_PDEATHSIG = 1          # <linux/prctl.h>
EXIT_TERMINATED = 128 + signal.SIGTERM


def cpu_count() -> int:
    """The cores this process may run on (its affinity, as a container or taskset
    limits it), which the local workers default to."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)


def _holder(path: Path) -> str:
    try:
        text = path.read_text(encoding="utf-8").split()
    except (OSError, UnicodeDecodeError):
        return "another process"
    return f"pid {text[0]}" if text and text[0].isdigit() else "another process"


def run_in_progress(out: Path) -> str | None:
    """Who holds the run folder ``out`` (a city run writing into it: "pid 4242"), or
    None: a lock test that takes nothing (``citysynth diff`` of a folder being written
    counted a mix of old and new blocks without a word)."""
    try:
        fd = os.open(out / LOCK, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    except OSError:
        return _holder(out / LOCK)
    finally:
        os.close(fd)


def busy(out: Path, holder: str) -> str:
    """The refusal of a second city run into ``out`` while ``holder`` writes into it."""
    return (f"{out}: another citysynth city run ({holder}) is using this run folder; "
            "wait for it to finish, or give another -o folder")


def check_not_running(out: Path) -> None:
    """Refuse at once a run into a folder another run holds, before its inputs are read
    and its blocks counted (the refusal came after "N blocks to build" on stdout, and
    after minutes of reading a large city's inputs). The lock itself is still taken
    by :func:`run_lock`, which refuses likewise if a run started meanwhile."""
    if (holder := run_in_progress(out)) is not None:
        raise ConfigError(busy(out, holder))


def _take(path: Path) -> int:
    """An open descriptor holding the lock on ``path``'s current file."""
    while True:
        try:   # never through a link: a link there had the run write over its target
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o666)
        except OSError as exc:
            if exc.errno not in (errno.ELOOP, errno.EISDIR):
                raise
            what = "folder" if exc.errno == errno.EISDIR else "link"
            raise ConfigError(f"{path}: a {what} where the run keeps its lock file; "
                              f"remove the {what}, or give another -o folder") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno not in (errno.EAGAIN, errno.EACCES):
                raise
            raise ConfigError(busy(path.parent, _holder(path))) from None
        try:   # the file we locked may have been unlinked by a run that just ended
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)


@contextlib.contextmanager
def run_lock(out: Path) -> Iterator[None]:
    """Hold the run folder ``out`` (made if missing) for the duration of the block."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / LOCK
    fd = _take(path)
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()} {time.strftime('%Y-%m-%dT%H:%M:%S')}\n".encode())
        yield
    finally:
        with contextlib.suppress(OSError):
            path.unlink()
        os.close(fd)


def _set_pdeathsig(sig: int) -> bool:
    """Ask Linux to send ``sig`` to this process when its parent dies."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, sig, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent: int) -> None:
    """Where prctl is missing: a thread that ends the worker once its parent is gone."""
    while True:
        if os.getppid() != parent:
            os._exit(EXIT_TERMINATED)
        time.sleep(0.5)


def worker_init(parent: int) -> None:
    """Pool worker set-up: die with the parent; leave SIGINT and SIGTERM to it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if not _set_pdeathsig(signal.SIGKILL):
        threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()
    if os.getppid() != parent:   # the parent died before prctl took effect
        os._exit(EXIT_TERMINATED)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: queued jobs are cancelled and running workers killed (their
    writes are atomic, so a killed block leaves only temporaries)."""
    procs = list(getattr(pool, "_processes", {}).values())
    for p in procs:
        with contextlib.suppress(OSError, ValueError):
            p.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(OSError, ValueError, AssertionError):
            p.join(timeout=1)


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived: handled as Ctrl-C is, but the command exits 143."""


def _terminated(signum, frame) -> None:
    raise Terminated()


@contextlib.contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM raises :class:`Terminated` in the main thread, so the run stops through
    the same clean-up as Ctrl-C (workers killed, lock released), and exits 143."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGTERM, _terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
