"""Timing helpers shared by the benches: interleaved medians and peak memory.

Methods are compared in the same run, called in turn (a warm-up round first, then
``runs`` timed rounds), so a machine that is busy with something else slows them
alike and their ratio stays meaningful; each figure is the median of its rounds.
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


def interleaved(fns: dict[str, Callable[[], Any]], runs: int
                ) -> dict[str, tuple[float | None, list[Any]]]:
    """Median wall time and the results of each function (None for a function that
    was refused with TooLargeError: then its time is None too)."""
    times: dict[str, list[float]] = {name: [] for name in fns}
    outs: dict[str, list[Any]] = {name: [] for name in fns}
    refused: set[str] = set()
    for rep in range(runs + 1):
        for name, fn in fns.items():
            if name in refused:
                continue
            t = time.perf_counter()
            try:
                out = fn()
            except TooLargeError:
                refused.add(name)
                continue
            if rep:
                times[name].append(time.perf_counter() - t)
                outs[name].append(out)
    return {name: (None if name in refused else statistics.median(times[name]),
                   outs[name]) for name in fns}


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
