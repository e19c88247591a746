"""Timing helpers shared by the benches: interleaved medians and peak memory.

Methods are compared in the same run, called in turn (a warm-up round first, then
``runs`` timed rounds), so a machine that is busy with something else slows them
alike and their ratio stays meaningful; each figure is the median of its rounds.
Rounds of a few milliseconds are repeated until they fill SHORT seconds (at least
``runs`` of them): a short spike of another process then moves the median less.
``CLOCK`` is wall time; the benches' --cpu switches it to this process's CPU time,
which a shared machine disturbs less (the kernels are single-threaded).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

from citysynth.solver import TooLargeError

SHORT = 0.3
CLOCK: list[Callable[[], float]] = [time.perf_counter]


def use_cpu_time(on: bool) -> None:
    """Time with this process's CPU time instead of wall time."""
    CLOCK[0] = time.process_time if on else time.perf_counter


def interleaved(fns: dict[str, Callable[[], Any]], runs: int
                ) -> dict[str, tuple[float | None, list[Any]]]:
    """Median time and the results of each function (None for a function that was
    refused with TooLargeError: then its time is None too)."""
    clock = CLOCK[0]
    times: dict[str, list[float]] = {name: [] for name in fns}
    outs: dict[str, list[Any]] = {name: [] for name in fns}
    refused: set[str] = set()
    rounds, rep, spent = runs, 0, 0.0
    while rep <= rounds:
        t_round = clock()
        for name, fn in fns.items():
            if name in refused:
                continue
            t = clock()
            try:
                out = fn()
            except TooLargeError:
                refused.add(name)
                continue
            if rep:
                times[name].append(clock() - t)
                outs[name].append(out)
        if rep:
            spent += clock() - t_round
            rounds = max(runs, min(10 * runs, int(SHORT * rep / max(spent, 1e-9))))
        rep += 1
    return {name: (None if name in refused else statistics.median(times[name]),
                   outs[name]) for name in fns}


def timed(fn: Callable[[], Any], runs: int) -> tuple[float, list[Any]]:
    """Median time of ``fn`` alone (a warm-up first) and its results."""
    t, outs = interleaved({"fn": fn}, runs)["fn"]
    if t is None:
        raise TooLargeError("refused")
    return t, outs


def stat_median(results, key: str) -> float:
    """Median of one timing the solver reports (setup_s / solve_s) over the runs."""
    return statistics.median(r.stats[key] for r in results)


def ms(x: float | None, width: int = 8) -> str:
    return f"{'refused':>{width}}" if x is None else f"{1e3 * x:{width}.2f}"


def ratio(a: float | None, b: float | None, width: int = 6) -> str:
    return f"{'—':>{width}}" if a is None or b is None else f"{a / b:{width}.2f}"


PEAK_RSS = '''
def hwm():  # peak RSS of this process image (VmHWM)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
'''


def run_child(code: str) -> dict:
    """Run ``code`` in a fresh interpreter (with :data:`PEAK_RSS`'s ``hwm()``) and read
    the JSON it prints last."""
    out = subprocess.run([sys.executable, "-c", PEAK_RSS + code], capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])
