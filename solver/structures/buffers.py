"""Float buffers that one structure solve hands on to the next in the same thread.

Why: the stage graphs of a block with a per-block door count hold a few MB of float
tables (g of three graphs of 6,894 states x 21 elements, the weights of 6,480
queries). Fresh arrays that large are mapped from the system page by page and given
back when freed, so every solve paid about 870 page faults and 1.8 ms of system time
(half the cost of the whole block without the door count). A solve takes its tables
here (:func:`take`) and its caller gives them back when nothing reads them any more
(:func:`give_back`, ``StageGraphs.release``); the next solve reuses them.

Safe by construction: a buffer is only reused after it was given back, and only the
code that took it gives it back (``solve_structure``, once its solutions are read;
a StageGraphs made elsewhere never gives its tables back, and they are freed as
usual). At most :data:`MAX_KEPT` bytes are kept per thread.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable

import numpy as np

MAX_KEPT = 64 * 2**20


class _Free(threading.local):
    def __init__(self) -> None:
        self.buffers: list[np.ndarray] = []   # flat float64 arrays, none referenced


_free = _Free()


def take(rows: int, cols: int) -> np.ndarray:
    """An uninitialised float64 array of shape (rows, cols): a view of the smallest
    buffer given back that holds it (if it is not more than four times too large),
    else a new array."""
    need = rows * cols
    free = _free.buffers
    best = -1
    for i, b in enumerate(free):
        if need <= b.size <= 4 * need + 4096 and (best < 0 or b.size < free[best].size):
            best = i
    if best < 0:
        return np.empty((rows, cols))
    return free.pop(best)[:need].reshape(rows, cols)


def give_back(arrays: Iterable[np.ndarray]) -> None:
    """Keep the memory of arrays from :func:`take` that nothing reads any more, the
    largest first, up to :data:`MAX_KEPT` bytes in all."""
    free = _free.buffers
    for a in arrays:
        base = a
        while base.base is not None:
            base = base.base   # the buffer's own flat array, or the array take made
        free.append(base.reshape(-1))
    free.sort(key=lambda b: -b.size)
    kept, total = [], 0
    for b in free:
        if total + b.nbytes <= MAX_KEPT:
            kept.append(b)
            total += b.nbytes
    _free.buffers = kept
