"""Ctrl-C and SIGTERM that land in numba's dispatcher.

A compiled kernel called from Python passes through numba's dispatcher, which runs
Python code of its own around the call (unboxing arguments, unpickling a cached
kernel's constants). A signal handler raising KeyboardInterrupt there surfaces as a
``SystemError`` ("returned a result with an exception set") whose cause is the
KeyboardInterrupt: a search stopped by Ctrl-C then looked like a crash (a test on a
loaded machine saw it; the command line reported an internal error, exit 3, instead
of "interrupted", exit 130)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager


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
