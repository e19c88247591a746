"""Progress of long work on stderr: one line rewritten in place on a terminal, else a
line per tenth of the work (and one at the end), so a log stays short."""

from __future__ import annotations

from collections.abc import Callable
from typing import TextIO

Shown = Callable[[int, int, str], None]   # (done, total, the line to show)


def progress_line(stream: TextIO) -> Shown:
    """A function that shows ``line`` for ``done`` of ``total`` on ``stream``."""
    tty = stream.isatty()
    step = [0]

    def show(done: int, total: int, line: str) -> None:
        if tty:
            print("\r" + line, end="\n" if done == total else "", file=stream, flush=True)
        elif total and (done * 10 // total > step[0] or done == total):
            step[0] = done * 10 // total
            print(line, file=stream, flush=True)
    return show
