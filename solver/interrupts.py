"""Ctrl-C and SIGTERM while compiled kernels run.

A compiled kernel called from Python passes through numba's dispatcher, which runs
Python code of its own around the call (unboxing arguments, unpickling a cached
kernel's constants). A signal handler raising KeyboardInterrupt there surfaces as a
``SystemError`` ("returned a result with an exception set") whose cause is the
KeyboardInterrupt: a search stopped by Ctrl-C then looked like a crash (a test on a
loaded machine saw it; the command line reported an internal error, exit 3, instead
of "interrupted", exit 130)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

T = TypeVar("T")
WAIT_S = 0.05   # how often the waiting main thread looks up (and takes signals)


def interrupt_in(exc: BaseException) -> KeyboardInterrupt | None:
    """The KeyboardInterrupt (or its subclass, a SIGTERM taken as one) that ``exc``
    was raised from, directly or through the chain a traceback shows (its cause, else
    its context unless suppressed: ``raise ... from None`` means handled); None if
    none."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return e
        seen.add(id(e))
        e = e.__cause__ if e.__cause__ is not None or e.__suppress_context__ \
            else e.__context__
    return None


@contextmanager
def kernel_calls() -> Iterator[None]:
    """Around a driver's kernel calls: a signal that landed in the dispatcher is
    raised as the KeyboardInterrupt it is."""
    try:
        yield
    except SystemError as exc:
        stop = interrupt_in(exc)
        if stop is None:
            raise
        raise stop from None


def in_background(kernel: Callable[..., T], *args: Any) -> T:
    """``kernel(*args)`` run in a daemon thread while the main thread waits in slices of
    :data:`WAIT_S`, so Ctrl-C and SIGTERM reach the main thread while the kernel runs.

    For one long compiled call that cannot be cut into short ones (the intermediate
    graph's growth: seconds on a wide three-resource problem, every level in one
    compiled loop): the kernel must be compiled with ``nogil=True``, or it would hold
    the interpreter, and with it the signal, until it ends. On a signal the
    KeyboardInterrupt is raised at once in the caller; the kernel finishes in the
    background and its result is dropped (the command line exits, which ends it)."""
    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["out"] = kernel(*args)
        except BaseException as exc:   # handed to the caller below
            box["exc"] = exc

    worker = threading.Thread(target=run, name="citysynth-kernel", daemon=True)
    worker.start()
    while worker.is_alive():   # a signal's KeyboardInterrupt is raised here
        worker.join(WAIT_S)
    if "exc" in box:
        raise box["exc"]
    return box["out"]
